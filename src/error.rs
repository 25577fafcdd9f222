//! The errors `fluid` reports, their messages and their exit codes (SPEC.md sections 1 and 8).

use std::fmt;

/// Everything that stops a run of `fluid`. `Display` gives the message after `Error: `.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FluidError {
    /// Rule 1: the argument count (program name excluded) is not 3.
    ArgumentCount(usize),
    /// Rule 2: the step count is not a decimal integer that fits an `i64`.
    StepsNotNumeric,
    /// Rule 3: the step count is negative.
    NegativeSteps,
    /// Rule 4: the input file cannot be opened or mapped for reading.
    CannotOpenInput(String),
    /// Rule 5: the output file cannot be opened (created) for writing.
    CannotOpenOutput(String),
    /// Rule 6: the header's particle count is zero or negative.
    InvalidParticleCount(i32),
    /// Rule 7: the whole records in the body are not as many as the header says.
    ParticleCountMismatch {
        /// Count in the header.
        header: i32,
        /// Whole 36-byte records found after the header.
        found: u64,
    },
    /// Section 8: any other defect of the input file (short header, partial record,
    /// non-finite or out-of-range value).
    InvalidInput {
        /// The input file name as given.
        file: String,
        /// What is wrong, without a final period.
        reason: String,
    },
    /// The output could not be written after the simulation (e.g. the disk is full).
    CannotWriteOutput {
        /// The output file name as given.
        file: String,
        /// The operating system's reason.
        reason: String,
    },
}

impl FluidError {
    /// The process exit status: the C++ codes -1..-5 as Linux reports them (255..251).
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::ArgumentCount(_) | Self::StepsNotNumeric => 255,
            Self::NegativeSteps => 254,
            Self::CannotOpenInput(_) => 253,
            Self::CannotOpenOutput(_) | Self::CannotWriteOutput { .. } => 252,
            Self::InvalidParticleCount(_)
            | Self::ParticleCountMismatch { .. }
            | Self::InvalidInput { .. } => 251,
        }
    }
}

impl fmt::Display for FluidError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ArgumentCount(n) => write!(f, "Invalid number of arguments: {n}."),
            Self::StepsNotNumeric => write!(f, "time steps must be numeric."),
            Self::NegativeSteps => write!(f, "Invalid number of time steps."),
            Self::CannotOpenInput(file) => write!(f, "Cannot open {file} for reading"),
            Self::CannotOpenOutput(file) => write!(f, "Cannot open {file} for writing"),
            Self::InvalidParticleCount(np) => write!(f, "Invalid number of particles: {np}."),
            Self::ParticleCountMismatch { header, found } => write!(
                f,
                "Number of particles mismatch. Header: {header}, Found: {found}."
            ),
            Self::InvalidInput { file, reason } => {
                write!(f, "Invalid input file {file}: {reason}.")
            }
            Self::CannotWriteOutput { file, reason } => write!(f, "Cannot write {file}: {reason}."),
        }
    }
}

impl std::error::Error for FluidError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_spec_table() {
        assert_eq!(FluidError::ArgumentCount(2).exit_code(), 255);
        assert_eq!(FluidError::StepsNotNumeric.exit_code(), 255);
        assert_eq!(FluidError::NegativeSteps.exit_code(), 254);
        assert_eq!(FluidError::CannotOpenInput("a".into()).exit_code(), 253);
        assert_eq!(FluidError::CannotOpenOutput("a".into()).exit_code(), 252);
        assert_eq!(FluidError::InvalidParticleCount(0).exit_code(), 251);
        let mismatch = FluidError::ParticleCountMismatch {
            header: 3,
            found: 2,
        };
        assert_eq!(mismatch.exit_code(), 251);
    }

    #[test]
    fn messages_match_the_spec_text() {
        assert_eq!(
            FluidError::ArgumentCount(4).to_string(),
            "Invalid number of arguments: 4."
        );
        assert_eq!(
            FluidError::CannotOpenInput("in.fld".into()).to_string(),
            "Cannot open in.fld for reading"
        );
        assert_eq!(
            FluidError::InvalidParticleCount(-7).to_string(),
            "Invalid number of particles: -7."
        );
        assert_eq!(
            FluidError::ParticleCountMismatch {
                header: 10,
                found: 9
            }
            .to_string(),
            "Number of particles mismatch. Header: 10, Found: 9."
        );
    }
}
