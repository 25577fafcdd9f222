//! `fluid-lab`: the workbench binary (see [`fluid::lab`]).

use clap::Parser;
use fluid::io::case::CaseError;
use fluid::io::fld::FileError;
use fluid::lab::UsageError;
use std::io::Write;
use std::process::ExitCode;

fn main() -> ExitCode {
    let lab = fluid::lab::Lab::parse();
    match lab.execute(&mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // File names as given, byte for byte, where the error is a file's.
            let message = match error.downcast_ref::<FileError>() {
                Some(file_error) => file_error.message(),
                None => error.to_string().into_bytes(),
            };
            let line = [&b"fluid-lab: error: "[..], &message, b"\n"].concat();
            let _ = std::io::stderr().write_all(&line);
            // A case file refused is a usage error, as clap's are.
            match error.is::<CaseError>() || error.is::<UsageError>() {
                true => ExitCode::from(2),
                false => ExitCode::FAILURE,
            }
        }
    }
}
