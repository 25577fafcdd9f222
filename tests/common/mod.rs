//! Helpers shared by the functional tests: paths to the bundled data and a runner for the
//! real `fluid` binary that never hangs a test.

#![allow(dead_code)] // each test crate uses its own subset of these helpers

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The bundled data folder (`data/`).
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// A bundled input, `data/in/<name>.fld`.
pub fn input(name: &str) -> PathBuf {
    data_dir().join("in").join(format!("{name}.fld"))
}

/// A bundled reference output, `data/out/<name>-<steps>.fld`.
pub fn reference_output(name: &str, steps: u32) -> PathBuf {
    data_dir().join("out").join(format!("{name}-{steps}.fld"))
}

/// How long one `fluid` run in a test may take before it counts as hung.
const TIME_LIMIT: Duration = Duration::from_secs(60);

/// Runs the `fluid` binary with `args`, killing it (and failing) after the time limit.
pub fn run_fluid<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_fluid"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn fluid");
    let start = Instant::now();
    while child.try_wait().expect("wait for fluid").is_none() {
        if start.elapsed() > TIME_LIMIT {
            child.kill().ok();
            panic!("fluid did not finish within {TIME_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait_with_output().expect("collect fluid output")
}

/// The exit status as the shell sees it (0-255).
pub fn exit_code(output: &Output) -> i32 {
    output
        .status
        .code()
        .expect("fluid exited normally, not by a signal")
}

/// The process's stdout as text.
pub fn stdout(output: &Output) -> String {
    String::from_utf8(output.stdout.clone()).expect("utf-8 stdout")
}

/// The process's stderr as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8(output.stderr.clone()).expect("utf-8 stderr")
}
