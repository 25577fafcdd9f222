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
    match lab.execute(&mut StandardOutput(std::io::stdout().lock())) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            // File names as given, byte for byte, where the error is a file's.
            let message = match error.downcast_ref::<FileError>() {
                Some(file_error) => file_error.message(),
                None => error.to_string().into_bytes(),
            };
            let message = without_os_codes(&message);
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

/// Standard output, whose failures say that it was standard output that failed (a full
/// disk or a closed pipe behind it), not a file of the command's.
struct StandardOutput<W>(W);

impl<W: Write> StandardOutput<W> {
    fn named(error: std::io::Error) -> std::io::Error {
        std::io::Error::new(
            error.kind(),
            format!("cannot write to standard output: {error}"),
        )
    }
}

impl<W: Write> Write for StandardOutput<W> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.write(bytes).map_err(Self::named)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush().map_err(Self::named)
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

/// `message` without the codes Rust's I/O errors end with (" (os error 2)"): the system's
/// own words say it.
fn without_os_codes(message: &[u8]) -> Vec<u8> {
    const CODE: &[u8] = b" (os error ";
    let mut kept = Vec::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.windows(CODE.len()).position(|window| window == CODE) {
        let after = &rest[at + CODE.len()..];
        let digits = after
            .iter()
            .take_while(|byte| byte.is_ascii_digit())
            .count();
        if digits > 0 && after.get(digits) == Some(&b')') {
            kept.extend_from_slice(&rest[..at]);
            rest = &after[digits + 1..];
        } else {
            // Not a code: kept as it is.
            kept.extend_from_slice(&rest[..at + CODE.len()]);
            rest = after;
        }
    }
    kept.extend_from_slice(rest);
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn os_codes_are_left_out_and_other_text_kept() {
        let cases: [(&[u8], &[u8]); 4] = [
            (
                b"cannot read a.bin: No such file or directory (os error 2)",
                b"cannot read a.bin: No such file or directory",
            ),
            (
                b"x: Permission denied (os error 13); y: Is a directory (os error 21)",
                b"x: Permission denied; y: Is a directory",
            ),
            (
                b"a file named (os error x).fld",
                b"a file named (os error x).fld",
            ),
            (b"no code here", b"no code here"),
        ];
        for (message, expected) in cases {
            assert_eq!(without_os_codes(message), expected);
        }
    }
}
