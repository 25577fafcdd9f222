//! The subcommands of `fluid-lab`, one module each: its arguments and its `exec`.
//! [`simulation_args`] holds what the subcommands that simulate share, and
//! [`create_output_dir`] the folder every writing subcommand makes, and [`same_file`]
//! tells when two of a command's files are one.

pub mod accuracy;
pub mod chaos;
pub mod chart;
pub mod compare;
pub mod export;
pub mod render;
pub mod run;
pub mod scene;
pub mod simulation_args;
pub mod slurm;
pub mod stability;
pub mod sweep;
pub mod validate;

use std::path::Path;

/// Creates `dir` (and its parents) for a subcommand's output files; the error names it.
pub fn create_output_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|error| format!("cannot create {}: {error}", dir.display()))
}

/// Whether `a` and `b` name the same file: the same file on disk if both exist, else the
/// same path once their folders are resolved.
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => resolved(a).is_some_and(|a| resolved(b) == Some(a)),
    }
}

/// `path` with its folder resolved (symbolic links, `..`), or `None` if it has none.
fn resolved(path: &Path) -> Option<std::path::PathBuf> {
    let folder = match path.parent() {
        Some(folder) if !folder.as_os_str().is_empty() => folder,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(folder).ok()?.join(path.file_name()?))
}
