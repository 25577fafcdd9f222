//! The errors `fluid` reports and their exit codes (SPEC.md sections 1 and 8): its own
//! argument errors (rules 1-3), and the file errors of [`crate::io::fld`] (rules 4-8),
//! whose messages that module gives.

use crate::io::fld::FileError;
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
    /// Rules 4 to 7 and section 8: the input or the output file.
    File(FileError),
}

impl FluidError {
    /// The process exit status: the C++ codes -1..-5 as Linux reports them (255..251).
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::ArgumentCount(_) | Self::StepsNotNumeric => 255,
            Self::NegativeSteps => 254,
            Self::File(FileError::CannotOpenInput(_)) => 253,
            Self::File(
                FileError::CannotOpenOutput(_)
                | FileError::CannotWriteOutput { .. }
                | FileError::Unrepresentable { .. },
            ) => 252,
            Self::File(
                FileError::InvalidParticleCount(_)
                | FileError::ParticleCountMismatch { .. }
                | FileError::InvalidInput { .. },
            ) => 251,
        }
    }
}

impl FluidError {
    /// The message after `Error: `, with file names byte for byte as given.
    pub fn message(&self) -> Vec<u8> {
        match self {
            Self::File(error) => error.message(),
            other => other.to_string().into_bytes(),
        }
    }
}

impl From<FileError> for FluidError {
    fn from(error: FileError) -> Self {
        Self::File(error)
    }
}

impl fmt::Display for FluidError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ArgumentCount(n) => write!(f, "Invalid number of arguments: {n}."),
            Self::StepsNotNumeric => write!(f, "time steps must be numeric."),
            Self::NegativeSteps => write!(f, "Invalid number of time steps."),
            Self::File(error) => error.fmt(f),
        }
    }
}

impl std::error::Error for FluidError {}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(error: FileError) -> FluidError {
        FluidError::from(error)
    }

    #[test]
    fn exit_codes_follow_the_spec_table() {
        assert_eq!(FluidError::ArgumentCount(2).exit_code(), 255);
        assert_eq!(FluidError::StepsNotNumeric.exit_code(), 255);
        assert_eq!(FluidError::NegativeSteps.exit_code(), 254);
        assert_eq!(
            file(FileError::CannotOpenInput("a".into())).exit_code(),
            253
        );
        assert_eq!(
            file(FileError::CannotOpenOutput("a".into())).exit_code(),
            252
        );
        let unwritten = FileError::CannotWriteOutput {
            file: "a".into(),
            reason: "full".into(),
        };
        assert_eq!(file(unwritten).exit_code(), 252);
        assert_eq!(file(FileError::InvalidParticleCount(0)).exit_code(), 251);
        let mismatch = FileError::ParticleCountMismatch {
            header: 3,
            found: 2,
        };
        assert_eq!(file(mismatch).exit_code(), 251);
        let invalid = FileError::InvalidInput {
            file: "a".into(),
            reason: "bad".into(),
        };
        assert_eq!(file(invalid).exit_code(), 251);
    }

    #[test]
    fn messages_match_the_spec_text() {
        assert_eq!(
            FluidError::ArgumentCount(4).to_string(),
            "Invalid number of arguments: 4."
        );
        assert_eq!(
            FluidError::StepsNotNumeric.to_string(),
            "time steps must be numeric."
        );
        assert_eq!(
            FluidError::NegativeSteps.to_string(),
            "Invalid number of time steps."
        );
        assert_eq!(
            file(FileError::CannotOpenInput("in.fld".into())).to_string(),
            "Cannot open in.fld for reading"
        );
        assert_eq!(
            file(FileError::InvalidParticleCount(-7)).to_string(),
            "Invalid number of particles: -7."
        );
        let mismatch = FileError::ParticleCountMismatch {
            header: 10,
            found: 9,
        };
        assert_eq!(
            file(mismatch).to_string(),
            "Number of particles mismatch. Header: 10, Found: 9."
        );
    }
}
