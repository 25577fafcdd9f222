//! Output files that appear whole or not at all, and keep what their user set.
//!
//! An [`OutputFile`] is opened before any work (so an unwritable output fails first, with
//! SPEC.md rule 5's error), can reserve its size before a long run ([`OutputFile::reserve`]),
//! and is written whole by one [`OutputFile::commit`] (or [`OutputFile::commit_with`],
//! a piece at a time):
//! - a new file, or an existing one with a single link in a writable folder, is written to
//!   a hidden temporary file beside it and renamed over it; a new file gets mode 0666 less
//!   the umask, an existing one keeps its mode;
//! - an existing file with other hard links, or in a folder that takes no new file, is
//!   rewritten where it is, with the ending signals held back while it is written;
//! - an existing special file (`/dev/null`, a pipe, a device) is written directly; a FIFO
//!   that no program reads is refused when opened, not waited on.
//!
//! Temporary files are removed when an output is dropped unwritten, and when a signal
//! ends the process ([`crate::io::signals`]). A file a command reads and must not replace
//! ([`keep_intact`]: its input, its case) is refused as an output, whatever the name.

use crate::io::fld::FileError;
use crate::io::signals;
use std::ffi::OsString;
use std::fs::{File, OpenOptions, Permissions};
use std::io::{BufWriter, Seek, Write};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// The longest file name Linux file systems take, in bytes.
const NAME_MAX: usize = 255;
/// The buffer between [`OutputFile::commit_with`]'s writer and the file.
const WRITE_BUFFER: usize = 1 << 16;
/// The bytes a temporary name adds to the target's besides its suffix: `.`, `.` and 6
/// random characters.
const TEMPORARY_EXTRA: usize = 8;

/// The files ([`keep_intact`]) no output may replace, by device and inode.
static KEPT_INTACT: std::sync::Mutex<Vec<(u64, u64, OsString)>> = std::sync::Mutex::new(Vec::new());

/// Keeps the existing file at `path` (as the command names it) from being replaced by any
/// [`OutputFile`] of this process: a file it reads, whose name one of its outputs (a
/// table, a chart, a frame series' index) may share.
pub fn keep_intact(path: &Path) {
    if let Ok(meta) = std::fs::metadata(path) {
        let mut kept = KEPT_INTACT
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        kept.push((meta.dev(), meta.ino(), path.as_os_str().to_owned()));
    }
}

/// Refuses `path` where it is a file kept intact ([`keep_intact`]), as
/// [`OutputFile::create`] would, creating nothing: for the outputs a command knows before
/// its work, whose folder it makes later.
pub fn refuse_kept(path: &Path) -> Result<(), FileError> {
    match std::fs::metadata(path)
        .ok()
        .and_then(|meta| kept_intact(&meta))
    {
        Some(read) => Err(replacing(path, read)),
        None => Ok(()),
    }
}

/// The error of an output at `path` that would replace `read`, a file kept intact.
fn replacing(path: &Path, read: OsString) -> FileError {
    let read = match read == path.as_os_str() {
        true => "it".into(),
        false => read.to_string_lossy().into_owned(),
    };
    FileError::CannotWriteOutput {
        file: path.as_os_str().to_owned(),
        reason: format!("this command reads {read}: give its outputs a place of their own"),
    }
}

/// The name of the file kept intact that `meta` is, if it is one.
fn kept_intact(meta: &std::fs::Metadata) -> Option<OsString> {
    let kept = KEPT_INTACT
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    (kept.iter())
        .find(|(dev, ino, _)| (*dev, *ino) == (meta.dev(), meta.ino()))
        .map(|(_, _, name)| name.clone())
}

/// An output file being prepared; nothing changes at its path until [`OutputFile::commit`].
#[derive(Debug)]
pub struct OutputFile {
    /// The output name as given, for messages.
    name: OsString,
    /// The file written: the given path with symbolic links resolved.
    target: PathBuf,
    sink: Sink,
}

#[derive(Debug)]
enum Sink {
    /// A temporary file beside the target, renamed over it on commit.
    Atomic(Temporary),
    /// The existing target itself, rewritten on commit (it has other hard links, or its
    /// folder takes no new file).
    InPlace(File),
    /// An existing non-regular file, written directly.
    Direct(File),
}

impl OutputFile {
    /// Checks that `path` can be written (rule 5) before anything is computed: a path
    /// naming a folder (`out/`, `..`, `x/.`), a file kept intact ([`keep_intact`]) or a
    /// name longer than 255 bytes is refused,
    /// and the temporary file is created (or the file opened for writing, and a special
    /// file given an empty write, which `/dev/full` refuses). A symbolic link is written
    /// through, not replaced, even when its target does not exist yet.
    pub fn create(path: &Path) -> Result<Self, FileError> {
        let cannot_open = || FileError::CannotOpenOutput(path.as_os_str().to_owned());
        if names_a_folder(path) {
            return Err(cannot_open());
        }
        let target = resolve_links(path).ok_or_else(cannot_open)?;
        if target.file_name().is_none_or(|name| name.len() > NAME_MAX) {
            return Err(cannot_open());
        }
        let sink = match std::fs::metadata(&target) {
            Ok(meta) if meta.is_dir() => return Err(cannot_open()),
            Ok(meta) if let Some(read) = kept_intact(&meta) => return Err(replacing(path, read)),
            Ok(meta) if !meta.is_file() => {
                let mut file = open_special(&target).map_err(|_| cannot_open())?;
                file.write(&[]).map_err(|_| cannot_open())?;
                Sink::Direct(file)
            }
            Ok(meta) => {
                let file = open_for_writing(&target).map_err(|_| cannot_open())?;
                if meta.nlink() > 1 {
                    Sink::InPlace(file)
                } else {
                    match Temporary::beside(&target, Some(meta.permissions()), ".tmp") {
                        Ok(temporary) => Sink::Atomic(temporary),
                        Err(error) if folder_refuses(&error) => Sink::InPlace(file),
                        Err(_) => return Err(cannot_open()),
                    }
                }
            }
            Err(_) => {
                Sink::Atomic(Temporary::beside(&target, None, ".tmp").map_err(|_| cannot_open())?)
            }
        };
        Ok(Self {
            name: path.as_os_str().to_owned(),
            target,
            sink,
        })
    }

    /// Makes sure `bytes` bytes can be written before a long computation: reserves the
    /// space on disk, where the file system supports it (a special file was tried when
    /// opened). Fails with rule 5's error.
    pub fn reserve(&mut self, bytes: u64) -> Result<(), FileError> {
        let refused = match &mut self.sink {
            Sink::Atomic(temporary) => !reserve_space(temporary.file.as_file(), bytes),
            Sink::InPlace(file) => !reserve_space(file, bytes),
            Sink::Direct(_) => false,
        };
        if refused {
            return Err(FileError::CannotOpenOutput(self.name.clone()));
        }
        Ok(())
    }

    /// Writes `bytes` as the whole file. On failure the target is untouched (a temporary
    /// file is removed) except for a special file, which may have taken part of them, and
    /// a file rewritten in place, which a failed write (a full disk) leaves part written.
    pub fn commit(self, bytes: &[u8]) -> Result<(), FileError> {
        self.commit_with(|out| out.write_all(bytes))
    }

    /// Writes the whole file with `write`, a piece at a time through a buffer (no copy
    /// of the whole file in memory), as [`OutputFile::commit`] writes its bytes.
    pub fn commit_with(
        self,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), FileError> {
        let failed = |error: std::io::Error| cannot_write(&self.name, &error);
        let buffered = |file: &mut File| {
            let mut out = BufWriter::with_capacity(WRITE_BUFFER, file);
            write(&mut out)?;
            out.flush()
        };
        match self.sink {
            Sink::Direct(mut file) => buffered(&mut file).map_err(failed),
            Sink::InPlace(mut file) => with_signals_held(|| {
                file.rewind()?;
                buffered(&mut file)?;
                let written = file.stream_position()?;
                file.set_len(written)
            })
            .map_err(failed),
            Sink::Atomic(mut temporary) => {
                buffered(temporary.file.as_file_mut()).map_err(failed)?;
                temporary.persist(&self.target).map_err(failed)
            }
        }
    }

    /// Prepares the output for a writer that needs a path (an image encoder, which may
    /// choose the format by the path's extension): the [`Staged`] path it writes, ending
    /// in the target's extension, which [`Staged::commit`] then makes the output.
    pub fn staged(self) -> Result<Staged, FileError> {
        let mut suffix = OsString::from(".tmp");
        if let Some(extension) = self.target.extension() {
            suffix.push(".");
            suffix.push(extension);
        }
        let file = match &self.sink {
            // Beside the target, with the mode its own temporary file has, to be renamed.
            Sink::Atomic(temporary) => temporary.file.as_file().metadata().and_then(|meta| {
                Temporary::beside(&self.target, Some(meta.permissions()), &suffix)
            }),
            // Anywhere: its bytes are copied into the target on commit.
            Sink::InPlace(_) | Sink::Direct(_) => tempfile::Builder::new()
                .prefix(".fluid-staged")
                .suffix(&suffix)
                .tempfile()
                .map(Temporary::guarded),
        };
        match file {
            Ok(file) => Ok(Staged { output: self, file }),
            Err(_) => Err(FileError::CannotOpenOutput(self.name)),
        }
    }
}

/// An output written through a path ([`OutputFile::staged`]).
#[derive(Debug)]
pub struct Staged {
    output: OutputFile,
    /// The file the writer writes.
    file: Temporary,
}

impl Staged {
    /// The path the writer writes (a temporary file, never the output itself).
    pub fn path(&self) -> &Path {
        self.file.file.path()
    }

    /// Makes what the writer wrote the output: renamed over the target where the output
    /// is written by rename, else copied into it.
    pub fn commit(self) -> Result<(), FileError> {
        let Staged { output, file } = self;
        match output.sink {
            Sink::Atomic(_) => file
                .persist(&output.target)
                .map_err(|error| cannot_write(&output.name, &error)),
            Sink::InPlace(_) | Sink::Direct(_) => {
                let path = file.file.path();
                let mut staged = File::open(path).map_err(|e| cannot_write(&output.name, &e))?;
                output.commit_with(|out| std::io::copy(&mut staged, out).map(drop))
            }
        }
    }
}

/// The error of an output named `name` whose writing failed with `error`.
fn cannot_write(name: &OsString, error: &std::io::Error) -> FileError {
    FileError::CannotWriteOutput {
        file: name.clone(),
        reason: os_reason(error),
    }
}

/// A temporary file, removed when dropped or when a signal ends the process.
#[derive(Debug)]
struct Temporary {
    file: NamedTempFile,
    _cleanup: signals::Pending,
}

impl Temporary {
    /// A new hidden temporary file beside `target`, named `.<name>.<random><suffix>` (the
    /// name shortened to fit 255 bytes), with `permissions` if given, else 0666 less the
    /// umask.
    fn beside(
        target: &Path,
        permissions: Option<Permissions>,
        suffix: impl AsRef<std::ffi::OsStr>,
    ) -> std::io::Result<Self> {
        let suffix = suffix.as_ref();
        let name = target.file_name().unwrap_or_default().as_bytes();
        let room = NAME_MAX.saturating_sub(TEMPORARY_EXTRA + suffix.len());
        let kept = name.len().min(room);
        let mut prefix = OsString::from(".");
        prefix.push(std::ffi::OsStr::from_bytes(&name[..kept]));
        prefix.push(".");
        let dir = match target.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        let file = with_signals_held(|| {
            let file = tempfile::Builder::new()
                .prefix(&prefix)
                .suffix(suffix)
                .permissions(Permissions::from_mode(0o666))
                .tempfile_in(dir)?;
            Ok(Self::guarded(file))
        })?;
        if let Some(permissions) = permissions {
            file.file.as_file().set_permissions(permissions)?;
        }
        Ok(file)
    }

    /// `file`, with its removal on signals registered.
    fn guarded(file: NamedTempFile) -> Self {
        let cleanup = signals::Pending::register(file.path());
        Self {
            file,
            _cleanup: cleanup,
        }
    }

    /// Renames the file over `target`.
    fn persist(self, target: &Path) -> std::io::Result<()> {
        self.file.persist(target).map(drop).map_err(|e| e.error)
    }
}

/// Whether `path` can only name a folder: it ends in `/`, `/.`, or is `.` or ends in `..`.
fn names_a_folder(path: &Path) -> bool {
    let bytes = path.as_os_str().as_bytes();
    bytes.ends_with(b"/") || bytes.ends_with(b"/.") || bytes == b"." || path.file_name().is_none()
}

/// The file that writing `path` writes: its symbolic links followed (at most 40, as
/// Linux does), to a target that may not exist yet; `None` for a loop. Two outputs are
/// one file where these are one.
pub fn resolve_links(path: &Path) -> Option<PathBuf> {
    if let Ok(existing) = std::fs::canonicalize(path) {
        return Some(existing);
    }
    let mut target = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::read_link(&target) {
            Ok(next) => {
                let folder = target.parent().unwrap_or(Path::new(""));
                target = folder.join(next);
            }
            Err(_) => return Some(target),
        }
    }
    None
}

/// The operating system's own reason for `error`, without the paths that wrappers (the
/// `tempfile` crate names its temporary file) add to it.
fn os_reason(error: &std::io::Error) -> String {
    match os_code(error) {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => error.to_string(),
    }
}

/// The OS error code of `error`, also when a wrapper holds it as its source.
fn os_code(error: &std::io::Error) -> Option<i32> {
    error.raw_os_error().or_else(|| {
        let inner = error.get_ref()?.source()?;
        inner.downcast_ref::<std::io::Error>()?.raw_os_error()
    })
}

/// Opens an existing file for writing without truncating it.
fn open_for_writing(path: &Path) -> std::io::Result<File> {
    OpenOptions::new().write(true).open(path)
}

/// Opens the special file at `path` (a device, a FIFO) for writing without waiting: a FIFO
/// with no reader is refused at once (ENXIO) instead of blocking; once open, its writes
/// block as a pipe's do.
fn open_special(path: &Path) -> std::io::Result<File> {
    use std::os::fd::AsRawFd;
    use std::os::unix::fs::OpenOptionsExt;
    let file = OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    // SAFETY: fcntl on a descriptor this function owns, with flags it read from it.
    let cleared = unsafe {
        let flags = libc::fcntl(file.as_raw_fd(), libc::F_GETFL);
        flags >= 0 && libc::fcntl(file.as_raw_fd(), libc::F_SETFL, flags & !libc::O_NONBLOCK) == 0
    };
    match cleared {
        true => Ok(file),
        false => Err(std::io::Error::last_os_error()),
    }
}

/// Whether creating a file failed because the folder takes no new file (the error's kind
/// is kept by the `tempfile` crate, which wraps the OS error with its path).
fn folder_refuses(error: &std::io::Error) -> bool {
    use std::io::ErrorKind;
    matches!(
        error.kind(),
        ErrorKind::PermissionDenied | ErrorKind::ReadOnlyFilesystem
    ) || matches!(
        os_code(error),
        Some(libc::EACCES | libc::EPERM | libc::EROFS)
    )
}

/// Reserves `bytes` bytes of disk for `file` without changing its size; false only when
/// the file system says there is no room (a file system without reservations passes).
fn reserve_space(file: &File, bytes: u64) -> bool {
    use std::os::fd::AsRawFd;
    let Ok(length) = libc::off_t::try_from(bytes) else {
        return false;
    };
    // SAFETY: fallocate only reads its integer arguments; the descriptor is open.
    let result = unsafe { libc::fallocate(file.as_raw_fd(), libc::FALLOC_FL_KEEP_SIZE, 0, length) };
    result == 0
        || !matches!(
            std::io::Error::last_os_error().raw_os_error(),
            Some(libc::ENOSPC | libc::EDQUOT | libc::EFBIG)
        )
}

/// Runs `work` with the signals that end the process ([`signals::ENDING`]) held back, so
/// none ends it halfway; one that arrives meanwhile is delivered after.
fn with_signals_held<T>(work: impl FnOnce() -> std::io::Result<T>) -> std::io::Result<T> {
    // SAFETY: the sets are initialised by sigemptyset before use, and pthread_sigmask
    // only reads `held` and writes `previous`.
    unsafe {
        let mut held: libc::sigset_t = std::mem::zeroed();
        let mut previous: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut held);
        for signal in signals::ENDING {
            libc::sigaddset(&mut held, signal);
        }
        libc::pthread_sigmask(libc::SIG_BLOCK, &held, &mut previous);
        let result = work();
        libc::pthread_sigmask(libc::SIG_SETMASK, &previous, std::ptr::null_mut());
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    fn mode(path: &Path) -> u32 {
        std::fs::metadata(path).unwrap().permissions().mode() & 0o777
    }

    #[test]
    fn output_appears_only_on_commit() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.fld");
        let output = OutputFile::create(&target).unwrap();
        assert!(!target.exists());
        // The temporary file, named as the README says: `.NAME.XXXXXX.tmp`.
        let [temporary] = &entries(dir.path())[..] else {
            panic!("one temporary file");
        };
        let random = temporary
            .strip_prefix(".out.fld.")
            .and_then(|rest| rest.strip_suffix(".tmp"));
        assert_eq!(random.map(str::len), Some(6), "{temporary}");
        output.commit(b"data").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"data");
        assert_eq!(entries(dir.path()), ["out.fld"]);
    }

    #[test]
    fn dropped_output_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        drop(OutputFile::create(&dir.path().join("out.fld")).unwrap());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn unwritable_outputs_and_folder_names_are_rule_5() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("in.fld");
        std::fs::write(&file, b"x").unwrap();
        let mut file_as_folder = file.clone().into_os_string();
        file_as_folder.push("/");
        let mut missing_folder = dir.path().join("nodir").into_os_string();
        missing_folder.push("/");
        for path in [
            dir.path().to_path_buf(),
            dir.path().join("missing/out.fld"),
            PathBuf::from(file_as_folder),
            PathBuf::from(missing_folder),
            dir.path().join(".."),
        ] {
            let err = OutputFile::create(&path).unwrap_err();
            assert_eq!(
                err,
                FileError::CannotOpenOutput(path.clone().into_os_string())
            );
        }
        assert_eq!(entries(dir.path()), ["in.fld"], "nothing created");
    }

    #[test]
    fn names_up_to_255_bytes_are_written() {
        let dir = tempfile::tempdir().unwrap();
        for length in [240, 244, 245, 250, 255] {
            let target = dir.path().join("n".repeat(length));
            OutputFile::create(&target).unwrap().commit(b"x").unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"x", "{length}");
        }
        assert_eq!(entries(dir.path()).len(), 5);
    }

    #[test]
    fn a_new_file_follows_the_umask_and_an_existing_file_keeps_its_mode() {
        let dir = tempfile::tempdir().unwrap();
        // SAFETY: umask only swaps the process's mask (the tests that create files here
        // accept any mask).
        let umask = unsafe { libc::umask(0o027) };
        let new = dir.path().join("new.fld");
        let result = OutputFile::create(&new).and_then(|o| o.commit(b"new"));
        unsafe { libc::umask(umask) };
        result.unwrap();
        assert_eq!(mode(&new), 0o640);
        let private = dir.path().join("private.fld");
        std::fs::write(&private, b"old").unwrap();
        std::fs::set_permissions(&private, Permissions::from_mode(0o600)).unwrap();
        OutputFile::create(&private)
            .unwrap()
            .commit(b"new")
            .unwrap();
        assert_eq!(mode(&private), 0o600);
        assert_eq!(std::fs::read(&private).unwrap(), b"new");
    }

    #[test]
    fn a_hard_linked_file_is_rewritten_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let (first, second) = (dir.path().join("a.fld"), dir.path().join("b.fld"));
        std::fs::write(&first, b"a much longer old content").unwrap();
        std::fs::hard_link(&first, &second).unwrap();
        let output = OutputFile::create(&first).unwrap();
        assert!(matches!(output.sink, Sink::InPlace(_)));
        output.commit(b"new").unwrap();
        assert_eq!(std::fs::read(&second).unwrap(), b"new", "the link sees it");
        assert_eq!(entries(dir.path()), ["a.fld", "b.fld"]);
    }

    #[test]
    fn a_writable_file_in_a_folder_that_takes_no_new_file_is_rewritten_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.fld");
        std::fs::write(&target, b"old").unwrap();
        std::fs::set_permissions(dir.path(), Permissions::from_mode(0o555)).unwrap();
        let probe = tempfile::tempfile_in(dir.path());
        let output = OutputFile::create(&target);
        let result = output.and_then(|output| {
            let in_place = matches!(output.sink, Sink::InPlace(_));
            output.commit(b"new").map(|()| in_place)
        });
        std::fs::set_permissions(dir.path(), Permissions::from_mode(0o755)).unwrap();
        // Root writes into read-only folders: then the rename path is taken.
        assert_eq!(result.unwrap(), probe.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }

    #[test]
    fn special_files_are_written_directly_and_dev_full_is_refused_when_opened() {
        let mut null = OutputFile::create(Path::new("/dev/null")).unwrap();
        assert!(matches!(null.sink, Sink::Direct(_)));
        null.reserve(1 << 40).unwrap();
        null.commit(b"data").unwrap();
        assert_eq!(
            OutputFile::create(Path::new("/dev/full")).unwrap_err(),
            FileError::CannotOpenOutput("/dev/full".into())
        );
    }

    #[test]
    fn a_fifo_is_written_to_its_reader_and_refused_at_once_without_one() {
        use std::os::unix::ffi::OsStrExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let name = std::ffi::CString::new(fifo.as_os_str().as_bytes()).unwrap();
        // SAFETY: mkfifo reads a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
        // No reader: refused, not waited on.
        assert_eq!(
            OutputFile::create(&fifo).unwrap_err(),
            FileError::CannotOpenOutput(fifo.clone().into())
        );
        // A reader: the bytes reach it, written in blocking mode (more than a pipe holds).
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        let bytes = vec![7u8; 1 << 20];
        let output = loop {
            match OutputFile::create(&fifo) {
                Ok(output) => break output,
                Err(_) => std::thread::sleep(std::time::Duration::from_millis(5)),
            }
        };
        output.commit(&bytes).unwrap();
        assert_eq!(reader.join().unwrap(), bytes);
    }

    #[test]
    fn a_dangling_link_is_written_through_and_a_loop_or_long_name_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("link.fld");
        std::os::unix::fs::symlink("missing.fld", &link).unwrap();
        OutputFile::create(&link).unwrap().commit(b"new").unwrap();
        assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
        assert_eq!(
            std::fs::read(dir.path().join("missing.fld")).unwrap(),
            b"new"
        );
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::os::unix::fs::symlink(&b, &a).unwrap();
        std::os::unix::fs::symlink(&a, &b).unwrap();
        let long = dir.path().join("n".repeat(256));
        for refused in [a, long, dir.path().join("missing.fld/.")] {
            assert!(OutputFile::create(&refused).is_err(), "{refused:?}");
        }
    }

    #[test]
    fn errors_wrapped_with_a_path_still_tell_a_refusing_folder_and_the_plain_reason() {
        let wrapped = std::io::Error::new(
            std::io::ErrorKind::PermissionDenied,
            "Permission denied (os error 13) at path \"/x/.y.tmp\"",
        );
        assert!(folder_refuses(&wrapped));
        assert!(!folder_refuses(&std::io::Error::from_raw_os_error(
            libc::ENOSPC
        )));
        let plain = std::io::Error::from_raw_os_error(libc::ENOSPC);
        assert_eq!(os_reason(&plain), "No space left on device (os error 28)");
    }

    #[test]
    fn reserving_more_than_the_disk_holds_fails_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.fld");
        let mut output = OutputFile::create(&target).unwrap();
        assert_eq!(
            output.reserve(1 << 60),
            Err(FileError::CannotOpenOutput(target.clone().into_os_string()))
        );
        output.reserve(4096).unwrap();
        drop(output);
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn a_symbolic_link_is_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.fld");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.path().join("link.fld");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let output = OutputFile::create(&link).unwrap();
        assert_eq!(output.name, link.as_os_str());
        output.commit(b"new").unwrap();
        assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
    }

    #[test]
    fn a_staged_output_appears_on_commit_for_every_sink() {
        let dir = tempfile::tempdir().unwrap();
        let (plain, linked) = (dir.path().join("a.png"), dir.path().join("b.png"));
        std::fs::write(&linked, b"old").unwrap();
        std::fs::hard_link(&linked, dir.path().join("c.png")).unwrap();
        for target in [&plain, &linked] {
            let staged = OutputFile::create(target).unwrap().staged().unwrap();
            assert_ne!(staged.path(), target.as_path());
            std::fs::write(staged.path(), b"picture").unwrap();
            assert_ne!(std::fs::read(target).ok().as_deref(), Some(&b"picture"[..]));
            staged.commit().unwrap();
            assert_eq!(std::fs::read(target).unwrap(), b"picture");
        }
        assert_eq!(entries(dir.path()), ["a.png", "b.png", "c.png"]);
    }
}
