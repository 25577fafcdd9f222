//! Helpers shared by the functional tests: paths to the bundled data and runners for the
//! real `fluid` and `fluid-lab` binaries that never hang a test.

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

/// How long one run of a binary in a test may take before it counts as hung.
const TIME_LIMIT: Duration = Duration::from_secs(60);

/// Runs the `fluid` binary with `args`, killing it (and failing) after the time limit.
pub fn run_fluid<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    run(env!("CARGO_BIN_EXE_fluid"), args)
}

/// Runs the `fluid-lab` workbench with `args`, as [`run_fluid`] does.
pub fn run_lab<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    run(env!("CARGO_BIN_EXE_fluid-lab"), args)
}

/// Runs the `fluid-lab` workbench with `args` and the environment variables `vars`
/// added, as [`run_fluid`] does.
pub fn run_lab_with<S: AsRef<std::ffi::OsStr>>(args: &[S], vars: &[(&str, &str)]) -> Output {
    run_with(env!("CARGO_BIN_EXE_fluid-lab"), args, vars)
}

fn run<S: AsRef<std::ffi::OsStr>>(program: &str, args: &[S]) -> Output {
    run_with(program, args, &[])
}

fn run_with<S: AsRef<std::ffi::OsStr>>(program: &str, args: &[S], vars: &[(&str, &str)]) -> Output {
    let mut child = Command::new(program)
        .args(args)
        .envs(vars.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn the binary");
    // Both pipes drained while the binary runs: one that fills (64 KiB) would stop it.
    let drain = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            pipe.expect("a piped stream")
                .read_to_end(&mut bytes)
                .expect("read the binary's output");
            bytes
        })
    };
    let stdout = drain(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = drain(child.stderr.take().map(|p| Box::new(p) as _));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for the binary") {
            break status;
        }
        if start.elapsed() > TIME_LIMIT {
            child.kill().ok();
            panic!("{program} did not finish within {TIME_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Output {
        status,
        stdout: stdout.join().expect("stdout read"),
        stderr: stderr.join().expect("stderr read"),
    }
}

/// The exit status as the shell sees it (0-255).
pub fn exit_code(output: &Output) -> i32 {
    output
        .status
        .code()
        .expect("the binary exited normally, not by a signal")
}

/// The process's stdout as text.
pub fn stdout(output: &Output) -> String {
    String::from_utf8(output.stdout.clone()).expect("utf-8 stdout")
}

/// The process's stderr as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8(output.stderr.clone()).expect("utf-8 stderr")
}

/// The names in `dir`, hidden ones included, sorted.
pub fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("a readable folder")
        .map(|entry| {
            entry
                .expect("a folder entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    names
}

/// Writes at `path` two particles 2 mm apart at 100 km/s: an adaptive step of about
/// 2e-8 s, so a run to 1 s would take fifty million steps and stops at step 1.
pub fn write_fast_pair(path: &Path) {
    let mut particles = fluid::Particles::zeroed(2);
    for slot in 0..2 {
        particles.p[0][slot] = -0.01 + 0.002 * slot as f64;
        particles.hv[0][slot] = 1e5;
        particles.v[0][slot] = 1e5;
    }
    std::fs::write(path, fluid::io::fld::encode(204.0, &particles).unwrap()).unwrap();
}

/// Asserts a failed run: its exit code, one line on stderr equal to `message`, nothing
/// on stdout.
pub fn assert_refused(output: &Output, code: i32, message: &str) {
    assert_eq!(exit_code(output), code, "{}", stderr(output));
    assert_eq!(stderr(output), format!("{message}\n"));
    assert_eq!(stdout(output), "", "nothing printed, nothing simulated");
}
