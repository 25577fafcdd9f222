//! `fluid-lab`: the workbench binary (see [`fluid::lab`]).

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let lab = fluid::lab::Lab::parse();
    match lab.execute(&mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("fluid-lab: error: {error}");
            ExitCode::FAILURE
        }
    }
}
