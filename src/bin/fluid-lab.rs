//! `fluid-lab`: the workbench binary (see [`fluid::lab`]).

use clap::error::ErrorKind;
use clap::Parser;
use fluid::io::allocator::EndingAllocator;
use fluid::io::case::CaseError;
use fluid::io::fld::FileError;
use fluid::lab::UsageError;
use std::io::Write;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: EndingAllocator = EndingAllocator;

fn main() -> ExitCode {
    fluid::io::allocator::set_error_prefix("fluid-lab: error: ");
    let lab = match fluid::lab::Lab::try_parse() {
        Ok(lab) => lab,
        Err(error)
            if !error.use_stderr()
                || error.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            error.exit()
        }
        Err(error) => {
            // One line, as every other error: clap's first paragraph (its message and
            // what it lists), without its usage and tips.
            let text = error.render().to_string();
            let message: Vec<&str> = (text.lines())
                .take_while(|line| !line.trim().is_empty())
                .map(str::trim)
                .collect();
            let message = message.join(" ");
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            let _ = writeln!(std::io::stderr(), "fluid-lab: error: {message}");
            return ExitCode::from(2);
        }
    };
    match lab.execute(&mut std::io::stdout().lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // File names as given, byte for byte, where the error is a file's.
            let message = match error.downcast_ref::<FileError>() {
                Some(file_error) => file_error.message(),
                None => error.to_string().into_bytes(),
            };
            let line = [&b"fluid-lab: error: "[..], &one_line(&message), b"\n"].concat();
            let _ = std::io::stderr().write_all(&line);
            // A case file refused is a usage error, as clap's are.
            match error.is::<CaseError>() || error.is::<UsageError>() {
                true => ExitCode::from(2),
                false => ExitCode::FAILURE,
            }
        }
    }
}

/// `message` on one line: each control character (a newline in a file name, say)
/// escaped as Rust writes it (`\n`, `\x1b`); every other byte as it is.
fn one_line(message: &[u8]) -> Vec<u8> {
    let mut line = Vec::with_capacity(message.len());
    for &byte in message {
        match byte {
            b'\n' => line.extend_from_slice(b"\\n"),
            b'\r' => line.extend_from_slice(b"\\r"),
            b'\t' => line.extend_from_slice(b"\\t"),
            0..=0x1f | 0x7f => line.extend_from_slice(format!("\\x{byte:02x}").as_bytes()),
            _ => line.push(byte),
        }
    }
    line
}
