//! The binaries' allocator: the system's, except that an allocation that fails ends the
//! process as an error does, one line on stderr and exit status 1, with its unfinished
//! outputs removed and a measured child stopped (as [`signals`] does for a signal), where
//! Rust's default prints a backtrace and aborts (status 134). Every failed allocation
//! ends the process, a fallible one too (a `try_reserve`, or std's file reads, which
//! would return an out-of-memory error): the project has none it could go on without.
//! Under Linux's default overcommit, memory itself rarely fails an allocation: the
//! kernel's out-of-memory killer ends the process (SIGKILL, which nothing can catch);
//! the line comes where an address-space limit (`ulimit -v`) or strict overcommit
//! refuses the allocation.

use crate::io::signals;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

/// The allocator (each binary's `#[global_allocator]`).
pub struct EndingAllocator;

/// What the binary puts before its error messages (`Error: `, `fluid-lab: error: `).
static ERROR_PREFIX: OnceLock<&'static str> = OnceLock::new();

/// Sets the start of the out-of-memory line to the binary's own error prefix (by default
/// `error: `).
pub fn set_error_prefix(prefix: &'static str) {
    let _ = ERROR_PREFIX.set(prefix);
}

// SAFETY: every method passes its arguments to the system allocator unchanged and returns
// what it returns; a null pointer never comes back (the process ends first).
unsafe impl GlobalAlloc for EndingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        allocated(unsafe { System.alloc(layout) }, layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        allocated(unsafe { System.alloc_zeroed(layout) }, layout.size())
    }

    unsafe fn dealloc(&self, pointer: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract, passed on.
        unsafe { System.dealloc(pointer, layout) }
    }

    unsafe fn realloc(&self, pointer: *mut u8, layout: Layout, size: usize) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        allocated(unsafe { System.realloc(pointer, layout, size) }, size)
    }
}

/// `pointer`, unless it is null: then the process ends ([`out_of_memory`]).
#[inline(always)]
fn allocated(pointer: *mut u8, bytes: usize) -> *mut u8 {
    if pointer.is_null() {
        out_of_memory(bytes);
    }
    pointer
}

/// Writes the out-of-memory line, removes the unfinished outputs and ends the process with
/// status 1, without allocating.
#[cold]
fn out_of_memory(bytes: usize) -> ! {
    // One line, if two threads fail at once: the second waits for the first's end.
    static ENDING: AtomicBool = AtomicBool::new(false);
    if ENDING.swap(true, Ordering::AcqRel) {
        loop {
            // SAFETY: pause only waits for a signal.
            unsafe { libc::pause() };
        }
    }
    let prefix = ERROR_PREFIX.get().copied().unwrap_or("error: ");
    let mut line = Line::default();
    line.push(prefix.as_bytes());
    line.push(b"out of memory: an allocation of ");
    line.push_number(bytes);
    line.push(b" bytes failed (a smaller scene, or more memory: ulimit -v)\n");
    // SAFETY: write reads `len` bytes of the line's buffer; _exit ends the process.
    unsafe {
        libc::write(2, line.bytes.as_ptr().cast(), line.len);
        signals::pass_to_child(libc::SIGTERM);
        signals::remove_unfinished();
        libc::_exit(1)
    }
}

/// A line built on the stack.
struct Line {
    bytes: [u8; 256],
    len: usize,
}

impl Default for Line {
    fn default() -> Self {
        Line {
            bytes: [0; 256],
            len: 0,
        }
    }
}

impl Line {
    /// Appends `text`, or as much as fits.
    fn push(&mut self, text: &[u8]) {
        let count = text.len().min(self.bytes.len() - self.len);
        self.bytes[self.len..self.len + count].copy_from_slice(&text[..count]);
        self.len += count;
    }

    /// Appends `number` in decimal.
    fn push_number(&mut self, mut number: usize) {
        let mut digits = [0u8; 20];
        let mut start = digits.len();
        loop {
            start -= 1;
            digits[start] = b'0' + (number % 10) as u8;
            number /= 10;
            if number == 0 {
                break;
            }
        }
        self.push(&digits[start..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_holds_its_number_in_decimal_and_stops_at_its_end() {
        let mut line = Line::default();
        line.push(b"of ");
        line.push_number(0);
        line.push(b" and ");
        line.push_number(18_446_744_073_709_551_615);
        assert_eq!(&line.bytes[..line.len], b"of 0 and 18446744073709551615");
        line.push(&[b'x'; 300]);
        assert_eq!(line.len, 256);
    }
}
