//! `fluid <nts> <inputfile> <outputfile>`: simulates nts time steps of the course model.

use std::io::Write;
use std::process::ExitCode;

fn main() -> ExitCode {
    match fluid::cli::run(std::env::args_os().skip(1), &mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let line = [&b"Error: "[..], &error.message(), b"\n"].concat();
            let _ = std::io::stderr().write_all(&line);
            ExitCode::from(error.exit_code())
        }
    }
}
