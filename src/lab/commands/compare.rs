//! `fluid-lab compare`: the error between two `.fld` states, per field.

use crate::io::fld;
use crate::lab::accuracy;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `fluid-lab compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The state measured.
    first: PathBuf,
    /// The state it is measured against.
    second: PathBuf,
}

/// Reads both states and prints the error of each field.
pub fn exec(args: CompareArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let read = |path: &PathBuf| fld::read(path).map_err(|error| error.naming(path));
    let (first, second) = (read(&args.first)?, read(&args.second)?);
    let errors = accuracy::compare(&first.particles, &second.particles).map_err(|reason| {
        format!(
            "cannot compare {} with {}: {reason}",
            args.first.display(),
            args.second.display()
        )
    })?;
    if first.ppm != second.ppm {
        writeln!(stdout, "note: ppm {} against {}", first.ppm, second.ppm)?;
    }
    writeln!(stdout, "field max_error rms_error worst_particle")?;
    for (field, error) in errors {
        writeln!(
            stdout,
            "{field} {:.6e} {:.6e} {}",
            error.max, error.rms, error.worst
        )?;
    }
    Ok(())
}
