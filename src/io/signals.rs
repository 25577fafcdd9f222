//! What happens when a signal ends the process: the temporary files of unfinished
//! outputs are removed, then the folders a command made for its outputs if they are still
//! empty, and a measured child process gets the signal too; then the process ends as the
//! signal's default would (the shell sees 128 + its number).
//!
//! The handler is async-signal-safe: it reads fixed tables (no allocation, no lock),
//! calls `unlink`, `rmdir` and `kill`, and ends the process. It is installed, once, for each of
//! [`ENDING`] that the process does not ignore (under `nohup`, SIGHUP stays ignored).

use std::cell::UnsafeCell;
use std::os::unix::ffi::OsStrExt;
use std::path::Path;
use std::sync::atomic::{AtomicI32, AtomicU8, Ordering};
use std::sync::Once;

/// The signals whose default ends the process and that a user or a scheduler sends:
/// Ctrl-C, Ctrl-\\, `kill`, a closed terminal, `timeout`, and the user signals; and an
/// abort (a failed allocation ends the process without one: `io::allocator`).
pub const ENDING: [libc::c_int; 8] = [
    libc::SIGABRT,
    libc::SIGINT,
    libc::SIGQUIT,
    libc::SIGTERM,
    libc::SIGHUP,
    libc::SIGALRM,
    libc::SIGUSR1,
    libc::SIGUSR2,
];
/// Temporary files registered at once (a run writes a few outputs at a time).
const SLOTS: usize = 16;
/// The longest path registered, in bytes (Linux's PATH_MAX).
const PATH_MAX: usize = 4096;

const FREE: u8 = 0;
const FILLING: u8 = 1;
/// A temporary file, removed on a signal.
const READY: u8 = 2;
/// A folder made for outputs, removed on a signal if empty.
const READY_FOLDER: u8 = 3;
/// The deepest nesting of registered folders the handler removes, innermost first.
const FOLDER_PASSES: usize = 8;

/// One registered path: its state, and the path with a final NUL.
struct Slot {
    state: AtomicU8,
    path: UnsafeCell<[u8; PATH_MAX + 1]>,
}

// SAFETY: `path` is written only by the thread that moved `state` from FREE to
// FILLING, and read (by the handler) only in state READY.
unsafe impl Sync for Slot {}

static TABLE: [Slot; SLOTS] = [const {
    Slot {
        state: AtomicU8::new(FREE),
        path: UnsafeCell::new([0; PATH_MAX + 1]),
    }
}; SLOTS];

/// A registered temporary file or made folder, unregistered when dropped.
#[derive(Debug)]
pub struct Pending(Option<usize>);

impl Pending {
    /// Registers `path` for removal on a signal (when the table has room and the path
    /// fits; otherwise the file is only removed on drop).
    pub fn register(path: &Path) -> Self {
        Self::register_as(path, READY)
    }

    /// Registers the folder `path` for removal on a signal if it is empty then (when the
    /// table has room and the path fits).
    pub fn register_folder(path: &Path) -> Self {
        Self::register_as(path, READY_FOLDER)
    }

    fn register_as(path: &Path, ready: u8) -> Self {
        install_handlers();
        let bytes = path.as_os_str().as_bytes();
        if bytes.len() > PATH_MAX || bytes.contains(&0) {
            return Pending(None);
        }
        for (index, slot) in TABLE.iter().enumerate() {
            let claimed =
                slot.state
                    .compare_exchange(FREE, FILLING, Ordering::Acquire, Ordering::Relaxed);
            if claimed.is_ok() {
                // SAFETY: this thread owns the slot in state FILLING.
                let buffer = unsafe { &mut *slot.path.get() };
                buffer[..bytes.len()].copy_from_slice(bytes);
                buffer[bytes.len()] = 0;
                slot.state.store(ready, Ordering::Release);
                return Pending(Some(index));
            }
        }
        Pending(None)
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Some(index) = self.0 {
            TABLE[index].state.store(FREE, Ordering::Release);
        }
    }
}

/// Installs the handlers once, for each signal that is not ignored.
fn install_handlers() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        for signal in ENDING {
            if is_ignored(signal) {
                continue;
            }
            // SAFETY: the action only loads atomics, calls unlink and ends the
            // process, all async-signal-safe.
            let _ = unsafe { signal_hook::low_level::register(signal, move || on_signal(signal)) };
        }
    });
}

/// Whether `signal`'s disposition is to ignore it.
fn is_ignored(signal: libc::c_int) -> bool {
    // SAFETY: sigaction with a null new action only writes the current one into
    // `current`, a zeroed plain-data struct.
    unsafe {
        let mut current: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut current) == 0
            && current.sa_sigaction == libc::SIG_IGN
    }
}

/// The process id of the child being measured, or 0.
static CHILD: AtomicI32 = AtomicI32::new(0);

/// A child process that gets the signal that ends this one; forgotten when dropped.
#[derive(Debug)]
pub struct Forwarding(());

impl Forwarding {
    /// Passes the ending signals to `pid` (a child this process waits for) until dropped.
    pub fn to(pid: libc::pid_t) -> Self {
        install_handlers();
        CHILD.store(pid, Ordering::Release);
        Forwarding(())
    }
}

impl Drop for Forwarding {
    fn drop(&mut self) {
        CHILD.store(0, Ordering::Release);
    }
}

/// The handler: passes the signal to the child, removes the unfinished outputs
/// ([`remove_unfinished`]), then acts as the signal's default.
fn on_signal(signal: libc::c_int) {
    pass_to_child(signal);
    remove_unfinished();
    let _ = signal_hook::low_level::emulate_default_handler(signal);
}

/// Sends `signal` to the measured child process, if one runs: async-signal-safe and
/// allocation-free (the out-of-memory end calls it too, `io::allocator`).
pub fn pass_to_child(signal: libc::c_int) {
    let child = CHILD.load(Ordering::Acquire);
    if child > 0 {
        // SAFETY: kill only reads its integer arguments.
        unsafe { libc::kill(child, signal) };
    }
}

/// Removes every registered file, then every registered folder that is empty (innermost
/// first, in passes, as each emptied parent can go next): async-signal-safe, and
/// allocation-free (the out-of-memory end calls it too, `io::allocator`).
pub fn remove_unfinished() {
    for slot in &TABLE {
        if slot.state.load(Ordering::Acquire) == READY {
            // SAFETY: a READY slot holds a NUL-terminated path; unlink only reads it.
            unsafe { libc::unlink(slot.path.get().cast()) };
        }
    }
    for _ in 0..FOLDER_PASSES {
        for slot in TABLE.iter().rev() {
            if slot.state.load(Ordering::Acquire) == READY_FOLDER {
                // SAFETY: a READY_FOLDER slot holds a NUL-terminated path; rmdir only
                // reads it, and removes nothing but an empty folder.
                unsafe { libc::rmdir(slot.path.get().cast()) };
            }
        }
    }
}
