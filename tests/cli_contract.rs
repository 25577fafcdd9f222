//! The command-line contract of SPEC.md sections 1 and 8, checked on the real binary:
//! exact stderr text, exit codes, nothing on stdout, and no output file left behind.

mod common;

use common::{exit_code, input, run_fluid, stderr, stdout};
use std::path::{Path, PathBuf};

/// Asserts a failed run: exit code, exactly one stderr line, empty stdout.
fn assert_error<S: AsRef<std::ffi::OsStr>>(args: &[S], code: i32, message: &str) {
    let output = run_fluid(args);
    assert_eq!(stderr(&output), format!("{message}\n"));
    assert_eq!(exit_code(&output), code, "for {message}");
    assert_eq!(stdout(&output), "", "nothing may be printed on failure");
}

/// Asserts that `fluid steps input out` fails with rule 5 for `out`.
fn assert_cannot_write(steps: &str, input: &Path, out: &Path) {
    let message = format!("Error: Cannot open {} for writing", out.display());
    assert_error(
        &[steps.as_ref(), input.as_os_str(), out.as_os_str()],
        252,
        &message,
    );
}

/// A scratch folder with an input file holding `bytes`.
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn new() -> Self {
        Self {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// The names in the folder, sorted.
    fn listing(&self) -> Vec<String> {
        common::entries(self.dir.path())
    }
}

fn small_bytes() -> Vec<u8> {
    std::fs::read(input("small")).unwrap()
}

fn with_header(ppm: f32, np: i32, body: &[u8]) -> Vec<u8> {
    let mut bytes = ppm.to_le_bytes().to_vec();
    bytes.extend(np.to_le_bytes());
    bytes.extend(body);
    bytes
}

/// Runs one step on a bad input file and checks the error and that no output appears.
fn assert_bad_file(bytes: &[u8], code: i32, message: impl Fn(&Path) -> String) {
    let scratch = Scratch::new();
    let bad = scratch.file("bad.fld", bytes);
    let out = scratch.path("out.fld");
    assert_error(
        &["1".as_ref(), bad.as_os_str(), out.as_os_str()],
        code,
        &message(&bad),
    );
    assert_eq!(
        scratch.listing(),
        vec!["bad.fld"],
        "output or temporary file left behind"
    );
}

#[test]
fn wrong_argument_counts_exit_255() {
    let none: [&str; 0] = [];
    assert_error(&none, 255, "Error: Invalid number of arguments: 0.");
    assert_error(&["1"], 255, "Error: Invalid number of arguments: 1.");
    assert_error(
        &["1", "a.fld"],
        255,
        "Error: Invalid number of arguments: 2.",
    );
    assert_error(
        &["1", "a", "b", "c"],
        255,
        "Error: Invalid number of arguments: 4.",
    );
}

#[test]
fn non_numeric_step_counts_exit_255() {
    for steps in [
        "hello",
        "3x",
        "5.0",
        "",
        " 5",
        "1e3",
        "99999999999999999999",
    ] {
        assert_error(
            &[steps, "missing.fld", "out.fld"],
            255,
            "Error: time steps must be numeric.",
        );
    }
}

#[test]
fn negative_step_counts_exit_254() {
    for steps in ["-1", "-100"] {
        assert_error(
            &[steps, "missing.fld", "out.fld"],
            254,
            "Error: Invalid number of time steps.",
        );
    }
}

#[test]
fn signed_and_padded_step_counts_are_accepted() {
    let scratch = Scratch::new();
    for steps in ["+1", "001", "-0"] {
        let out = scratch.path("out.fld");
        let output = run_fluid(&[steps.as_ref(), input("small").as_os_str(), out.as_os_str()]);
        assert_eq!(exit_code(&output), 0, "{steps}: {}", stderr(&output));
    }
}

#[test]
fn unreadable_inputs_exit_253_with_the_name_as_given() {
    let scratch = Scratch::new();
    let out = scratch.path("out.fld");
    assert_error(
        &["1".as_ref(), "no/such/input.fld".as_ref(), out.as_os_str()],
        253,
        "Error: Cannot open no/such/input.fld for reading",
    );
    let dir = scratch.dir.path();
    assert_error(
        &["1".as_ref(), dir.as_os_str(), out.as_os_str()],
        253,
        &format!("Error: Cannot open {} for reading", dir.display()),
    );
    assert!(scratch.listing().is_empty());
}

#[test]
fn unwritable_outputs_exit_252() {
    let scratch = Scratch::new();
    assert_cannot_write("1", &input("small"), &scratch.path("missing/out.fld"));
    assert_cannot_write("1", &input("small"), scratch.dir.path());
}

#[test]
fn an_unwritable_output_is_reported_before_any_simulation() {
    // With i64::MAX steps the run could only end this fast if nothing was simulated.
    let scratch = Scratch::new();
    let out = scratch.path("missing/out.fld");
    assert_cannot_write("9223372036854775807", &input("large"), &out);
}

#[test]
fn checks_run_in_the_order_of_the_spec_table() {
    let scratch = Scratch::new();
    let empty = scratch.file("empty.fld", &[]);
    let missing_dir_out = scratch.path("missing/out.fld");
    // Missing input before unwritable output.
    assert_error(
        &[
            "1".as_ref(),
            "absent.fld".as_ref(),
            missing_dir_out.as_os_str(),
        ],
        253,
        "Error: Cannot open absent.fld for reading",
    );
    // Unwritable output before the contents of the input.
    assert_cannot_write("1", &empty, &missing_dir_out);
}

#[test]
fn non_positive_particle_counts_exit_251() {
    for np in [0, -5] {
        assert_bad_file(&with_header(204.0, np, &[0; 36]), 251, |_| {
            format!("Error: Invalid number of particles: {np}.")
        });
    }
}

#[test]
fn missing_records_exit_251_with_the_mismatch_message() {
    let mut bytes = small_bytes();
    bytes.truncate(bytes.len() - 36);
    assert_bad_file(&bytes, 251, |_| {
        "Error: Number of particles mismatch. Header: 4800, Found: 4799.".to_string()
    });
    // A partial last record counts as missing.
    let mut partial = small_bytes();
    partial.truncate(partial.len() - 10);
    assert_bad_file(&partial, 251, |_| {
        "Error: Number of particles mismatch. Header: 4800, Found: 4799.".to_string()
    });
    let mut extra = small_bytes();
    extra.extend_from_slice(&small_bytes()[8..44]);
    assert_bad_file(&extra, 251, |_| {
        "Error: Number of particles mismatch. Header: 4800, Found: 4801.".to_string()
    });
}

#[test]
fn files_shorter_than_the_header_exit_251() {
    for size in [0, 6] {
        assert_bad_file(&vec![0; size], 251, |path| {
            format!(
                "Error: Invalid input file {}: it is {size} bytes long, shorter than the 8-byte header.",
                path.display()
            )
        });
    }
}

#[test]
fn trailing_bytes_exit_251() {
    let mut bytes = small_bytes();
    bytes.extend([0xAB; 3]);
    assert_bad_file(&bytes, 251, |path| {
        format!(
            "Error: Invalid input file {}: 3 stray bytes after the last of its 4800 36-byte particle records.",
            path.display()
        )
    });
}

#[test]
fn non_finite_fields_exit_251_naming_particle_and_field() {
    let cases = [
        (0, 0, f32::NAN, "px", "NaN"),
        (17, 7, f32::INFINITY, "vy", "inf"),
        (4799, 5, f32::NEG_INFINITY, "hvz", "-inf"),
    ];
    for (id, field, value, name, shown) in cases {
        let mut bytes = small_bytes();
        let at = 8 + 36 * id + 4 * field;
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        assert_bad_file(&bytes, 251, |path| {
            format!(
                "Error: Invalid input file {}: particle {id} has a non-finite {name} ({shown}).",
                path.display()
            )
        });
    }
}

#[test]
fn invalid_particles_per_meter_exit_251() {
    let body = &small_bytes()[8..];
    for (ppm, shown) in [
        (0.0, "0"),
        (-204.0, "-204"),
        (f32::NAN, "nan"),
        (f32::INFINITY, "inf"),
    ] {
        assert_bad_file(&with_header(ppm, 4800, body), 251, |path| {
            format!(
                "Error: Invalid input file {}: particles per meter is {shown}, not a finite number > 0.",
                path.display()
            )
        });
    }
}

#[test]
fn particles_per_meter_without_a_grid_exit_251() {
    let body = &small_bytes()[8..];
    assert_bad_file(&with_header(10.0, 4800, body), 251, |path| {
        format!(
            "Error: Invalid input file {}: particles per meter 10 gives a grid of 0 x 1 x 0 \
             blocks, but a grid needs at least 1 block per axis and at most 67108864 blocks.",
            path.display()
        )
    });
}

#[test]
fn a_failed_run_leaves_an_existing_output_untouched() {
    let scratch = Scratch::new();
    let bad = scratch.file("bad.fld", &with_header(204.0, 0, &[]));
    let out = scratch.file("out.fld", b"keep me");
    let output = run_fluid(&["1".as_ref(), bad.as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 251);
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
    assert_eq!(scratch.listing(), vec!["bad.fld", "out.fld"]);
}

#[cfg(unix)]
#[test]
fn dev_null_is_a_valid_output_and_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    let output = run_fluid(&[
        "2".as_ref(),
        input("small").as_os_str(),
        "/dev/null".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(stdout(&output).starts_with("Number of particles: 4800\n"));
    let kind = std::fs::metadata("/dev/null").unwrap().file_type();
    assert!(kind.is_char_device(), "/dev/null was replaced");
}
