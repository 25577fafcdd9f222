//! Command-line arguments of `fluid`: `fluid <nts> <inputfile> <outputfile>` (SPEC.md section 1).

use crate::error::FluidError;
use std::ffi::OsString;
use std::path::PathBuf;

/// The validated arguments of one `fluid` run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgArgs {
    /// Number of time steps to simulate (0 copies the input).
    pub steps: u64,
    /// Input `.fld` file.
    pub input: PathBuf,
    /// Output `.fld` file.
    pub output: PathBuf,
}

impl ProgArgs {
    /// Parses the arguments after the program name, applying rules 1-3 in order.
    pub fn parse<I>(args: I) -> Result<Self, FluidError>
    where
        I: IntoIterator<Item = OsString>,
    {
        let args: Vec<OsString> = args.into_iter().collect();
        let [steps, input, output] = <[OsString; 3]>::try_from(args)
            .map_err(|args| FluidError::ArgumentCount(args.len()))?;
        Ok(Self {
            steps: parse_steps(&steps)?,
            input: input.into(),
            output: output.into(),
        })
    }
}

/// Rule 2 then rule 3: a whole decimal integer with optional sign, not negative.
fn parse_steps(text: &OsString) -> Result<u64, FluidError> {
    let steps: i64 = text
        .to_str()
        .and_then(|s| s.parse().ok())
        .ok_or(FluidError::StepsNotNumeric)?;
    u64::try_from(steps).map_err(|_| FluidError::NegativeSteps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<ProgArgs, FluidError> {
        ProgArgs::parse(args.iter().map(OsString::from))
    }

    fn steps(text: &str) -> Result<u64, FluidError> {
        parse(&[text, "in.fld", "out.fld"]).map(|a| a.steps)
    }

    #[test]
    fn accepts_three_arguments() {
        let args = parse(&["5", "in.fld", "out.fld"]).unwrap();
        assert_eq!(args.steps, 5);
        assert_eq!(args.input, PathBuf::from("in.fld"));
        assert_eq!(args.output, PathBuf::from("out.fld"));
    }

    #[test]
    fn wrong_argument_counts_report_the_count() {
        assert_eq!(parse(&[]), Err(FluidError::ArgumentCount(0)));
        assert_eq!(parse(&["1", "a"]), Err(FluidError::ArgumentCount(2)));
        assert_eq!(
            parse(&["1", "a", "b", "c"]),
            Err(FluidError::ArgumentCount(4))
        );
    }

    #[test]
    fn argument_count_is_checked_before_the_step_count() {
        assert_eq!(parse(&["x", "a"]), Err(FluidError::ArgumentCount(2)));
    }

    #[test]
    fn signed_and_zero_padded_integers_are_numbers() {
        assert_eq!(steps("+5"), Ok(5));
        assert_eq!(steps("007"), Ok(7));
        assert_eq!(steps("0"), Ok(0));
        assert_eq!(steps("-0"), Ok(0));
        assert_eq!(steps("9223372036854775807"), Ok(i64::MAX as u64));
    }

    #[test]
    fn non_integers_are_not_numeric() {
        for text in [
            "", "hello", "3x", "5.0", " 5", "5 ", "1e3", "0x10", "+", "--1", "٣",
        ] {
            assert_eq!(steps(text), Err(FluidError::StepsNotNumeric), "{text:?}");
        }
    }

    #[test]
    fn overflowing_integers_are_not_numeric() {
        assert_eq!(
            steps("99999999999999999999"),
            Err(FluidError::StepsNotNumeric)
        );
        assert_eq!(
            steps("-99999999999999999999"),
            Err(FluidError::StepsNotNumeric)
        );
    }

    #[test]
    fn negative_step_counts_are_invalid() {
        assert_eq!(steps("-1"), Err(FluidError::NegativeSteps));
        assert_eq!(
            steps("-9223372036854775808"),
            Err(FluidError::NegativeSteps)
        );
    }

    #[cfg(unix)]
    #[test]
    fn non_utf8_step_count_is_not_numeric() {
        use std::os::unix::ffi::OsStringExt;
        let args = vec![
            OsString::from_vec(vec![0x35, 0xff]),
            OsString::from("a"),
            OsString::from("b"),
        ];
        assert_eq!(ProgArgs::parse(args), Err(FluidError::StepsNotNumeric));
    }
}
