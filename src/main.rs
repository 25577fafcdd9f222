//! `fluid <nts> <inputfile> <outputfile>`: simulates nts time steps of the course model.

use fluid::io::allocator::EndingAllocator;
use std::io::Write;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: EndingAllocator = EndingAllocator;

fn main() -> ExitCode {
    fluid::io::allocator::set_error_prefix("Error: ");
    match fluid::cli::run(std::env::args_os().skip(1), &mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let line = [&b"Error: "[..], &error.message(), b"\n"].concat();
            let _ = std::io::stderr().write_all(&line);
            ExitCode::from(error.exit_code())
        }
    }
}
