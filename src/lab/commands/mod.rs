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

use crate::io::fld::FileError;
use crate::io::signals::Pending;
use std::path::{Path, PathBuf};

/// Creates `dir` (and its parents) for a subcommand's output files; the error names it.
/// The folders it made are removed again when the returned [`MadeFolder`] is dropped, if
/// they are still empty: a command that fails before writing leaves none behind.
pub fn create_output_dir(dir: &Path) -> Result<MadeFolder, String> {
    let shown = dir.display();
    // `newd/..` is a folder that is there: nothing to make (nor to remove after).
    let dir = &through_missing_folders(dir);
    if dir.as_os_str().is_empty() {
        return Ok(MadeFolder {
            made: Vec::new(),
            registered: Vec::new(),
        });
    }
    if dir.exists() && !dir.is_dir() {
        return Err(format!("cannot use {shown} as a folder: it is a file"));
    }
    // A symbolic link that leads nowhere (to nothing, or round in a loop) is no folder
    // to make: the system's "File exists" would not say why.
    if let Some(link) = (dir.ancestors()).find(|place| place.is_symlink() && !place.exists()) {
        return Err(format!(
            "cannot use {shown} as a folder: {} is a symbolic link that leads to no file",
            link.display()
        ));
    }
    // The folders missing, outermost first.
    let mut missing: Vec<PathBuf> = (dir.ancestors())
        .take_while(|folder| !folder.as_os_str().is_empty() && !folder.exists())
        .map(Path::to_path_buf)
        .collect();
    missing.reverse();
    // Made before the folders are: a failure part way removes those it made, and so does
    // a signal.
    let registered = missing
        .iter()
        .map(|folder| Pending::register_folder(folder));
    let made = MadeFolder {
        registered: registered.collect(),
        made: missing,
    };
    std::fs::create_dir_all(dir).map_err(|error| format!("cannot create {shown}: {error}"))?;
    Ok(made)
}

/// The folders [`create_output_dir`] made, outermost first; those still empty are
/// removed when it is dropped, unless kept ([`MadeFolder::keep`]).
#[must_use = "dropped at once, it removes the folders it made"]
#[derive(Debug)]
pub struct MadeFolder {
    made: Vec<PathBuf>,
    /// The same folders, registered for removal on a signal while this lives.
    registered: Vec<Pending>,
}

impl MadeFolder {
    /// Keeps the folders made, empty or not (for what writes into them later).
    pub fn keep(mut self) {
        self.made.clear();
        self.registered.clear();
    }
}

impl Drop for MadeFolder {
    fn drop(&mut self) {
        // Innermost first; a folder that holds anything stays (and so do its parents);
        // one never made (its making failed part way) is passed over.
        for folder in self.made.iter().rev() {
            if folder.exists() && std::fs::remove_dir(folder).is_err() {
                break;
            }
        }
    }
}

/// Whether some item of `items` is there twice (for a flag's list that names each item
/// once).
pub fn repeats<T: PartialEq>(items: &[T]) -> bool {
    (1..items.len()).any(|k| items[k..].contains(&items[k - 1]))
}

/// Refuses, before any work, a chart that `names` give in `folder` (a PNG and an SVG
/// each) where it would replace a file the command reads
/// ([`crate::io::output::keep_intact`]): found there, it would fail the command after its
/// work, with its other outputs written.
pub fn try_charts(folder: &Path, names: &[&str]) -> Result<(), FileError> {
    (names.iter())
        .flat_map(|name| crate::lab::chart::files(folder, name))
        .try_for_each(|path| crate::io::output::refuse_kept(&path))
}

/// A flag's parser of numbers (each of a list), whose range its command checks, saying
/// in one line what is not one (clap's own says "cannot parse float from empty string").
pub fn number(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| format!("'{text}' is not a number"))
}

/// A flag's parser of whole numbers from `low` to `high` (and no more than `T` holds),
/// in digits (spaces around them let be), saying so in one line otherwise (clap's own
/// says "invalid digit found in string" or shows a Rust range).
pub fn whole<T: TryFrom<u64>>(
    low: u64,
    high: u64,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {
    move |text| {
        text.trim()
            .parse::<u64>()
            .ok()
            .filter(|number| (low..=high).contains(number))
            .and_then(|number| T::try_from(number).ok())
            .ok_or_else(|| format!("{text} is not a whole number from {low} to {high}"))
    }
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

/// `path` with each `..` that follows a folder that does not exist taken out with that
/// folder (a folder not there is no symbolic link, so `newd/..` is the folder before
/// it); every other `..` is left to the file system. `newd/../case.toml` names the case
/// file before `newd` is made, and making the folder of `newd/../x.fld` makes nothing.
pub fn through_missing_folders(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for component in path.components() {
        let missing_folder =
            matches!(out.components().next_back(), Some(Component::Normal(_))) && !out.exists();
        match component {
            Component::ParentDir if missing_folder => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// `path` with its symbolic links followed and its folder resolved (`..`), or `None` if
/// it has none (or its links loop).
fn resolved(path: &Path) -> Option<std::path::PathBuf> {
    // Through its symbolic links: a link to a file not there yet names that file.
    let path = &through_missing_folders(&crate::io::output::resolve_links(path)?);
    let folder = match path.parent() {
        Some(folder) if !folder.as_os_str().is_empty() => folder,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(folder).ok()?.join(path.file_name()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_numbers_are_read_in_digits_within_their_range_and_said_otherwise() {
        let across = whole::<usize>(4, 400);
        assert_eq!(across("40"), Ok(40));
        for text in ["3", "401", "-5", "1e3", "abc", "", "99999999999999999999"] {
            assert_eq!(
                across(text),
                Err(format!("{text} is not a whole number from 4 to 400")),
            );
        }
        // Spaces around the digits (a list written "20, 40") are let be.
        assert_eq!(across(" 40"), Ok(40));
        let every = whole::<u64>(1, i64::MAX as u64);
        assert_eq!(every("9223372036854775807"), Ok(i64::MAX as u64));
        for text in ["0", "9223372036854775808"] {
            assert_eq!(
                every(text),
                Err(format!(
                    "{text} is not a whole number from 1 to 9223372036854775807"
                ))
            );
        }
        // A number the type cannot hold is refused, whatever the range says.
        assert!(whole::<u8>(0, 1000)("300").is_err());
    }
}
