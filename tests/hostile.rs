//! Hostile use of the real binaries (issue 14): every numbered defect found by trying
//! `fluid` and `fluid-lab` as a hostile user would, each with the test that keeps it
//! fixed, and checkpoints that lose nothing when a run is killed.

mod common;

use common::{assert_refused, entries, exit_code, input, run_fluid, run_lab, stderr, stdout};
use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// An `.fld` file of particles at rest at `positions`, `ppm` particles per metre.
fn fld(path: &Path, ppm: f32, records: &[[f32; 9]]) {
    let mut bytes = ppm.to_le_bytes().to_vec();
    bytes.extend((records.len() as i32).to_le_bytes());
    for record in records {
        bytes.extend(record.iter().flat_map(|v| v.to_le_bytes()));
    }
    std::fs::write(path, bytes).unwrap();
}

/// Starts `program` with `args` in `dir`, with SIGINT and SIGHUP at their defaults (a
/// test harness started in the background may have them ignored) and `umask` set.
fn spawn(program: &str, args: &[&OsStr], dir: &Path, umask: u32) -> Child {
    let mut command = Command::new(program);
    command
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    // SAFETY: between fork and exec only async-signal-safe calls (signal, umask).
    unsafe {
        command.pre_exec(move || {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            libc::signal(libc::SIGHUP, libc::SIG_DFL);
            libc::signal(libc::SIGQUIT, libc::SIG_DFL);
            libc::umask(umask as libc::mode_t);
            // SIGQUIT would dump a core file into the folder the test inspects.
            let no_core = libc::rlimit {
                rlim_cur: 0,
                rlim_max: 0,
            };
            libc::setrlimit(libc::RLIMIT_CORE, &no_core);
            Ok(())
        });
    }
    command.spawn().unwrap()
}

/// Waits until `ready` holds (polling), failing after 60 s.
fn wait_until(what: &str, ready: impl Fn() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{what} never happened"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Waits for `child` to end, failing after 60 s; its raw status.
fn reap(child: &mut Child) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().ok();
            panic!("the child did not end");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

// 1. Panics and hangs.

#[test]
fn item_1_a_corner_block_beyond_the_box_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cb.fld");
    let output = run_lab(&[
        "scene".as_ref(),
        "corner-block".as_ref(),
        out.as_os_str(),
        "--particles".as_ref(),
        "1000000".as_ref(),
    ]);
    assert_refused(
        &output,
        2,
        "fluid-lab: error: a box at 400 particles per metre holds a corner block of at most \
         194688 particles",
    );
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn item_2_a_render_range_must_be_finite_and_nothing_is_left_half_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    for (picture, range) in [
        ("x.png", "--range=-inf,0"),
        ("x.png", "--range=-inf,inf"),
        ("x.gif", "--range=-inf,0"),
        ("x.png", "--range=nan,1"),
    ] {
        let out = dir.path().join(picture);
        let output = run_lab(&[
            "render".as_ref(),
            small.as_os_str(),
            out.as_os_str(),
            range.as_ref(),
        ]);
        assert_eq!(exit_code(&output), 2, "{range}: {}", stderr(&output));
        assert!(
            stderr(&output).contains("LOW and HIGH must be finite numbers"),
            "{}",
            stderr(&output)
        );
        assert!(entries(dir.path()).is_empty(), "{range}");
    }
}

/// A sweep CSV of one idle window and one run with `wall_s` = `wall`.
fn sweep_csv(path: &Path, wall: &str) {
    let columns = fluid::lab::sweep::COLUMNS;
    let row = |kind: &str, wall: &str| {
        columns
            .iter()
            .map(|&column| match column {
                "kind" => kind,
                "input" if kind == "run" => "small.fld",
                "particles" if kind == "run" => "4800",
                "iterations" if kind == "run" => "10",
                "repeat" => "1",
                "wall_s" => wall,
                _ => "",
            })
            .collect::<Vec<_>>()
            .join(",")
    };
    let text = format!(
        "{}\n{}\n{}\n",
        columns.join(","),
        row("idle", "1.0"),
        row("run", wall)
    );
    std::fs::write(path, text).unwrap();
}

#[test]
fn items_3_and_6_chart_refuses_measurements_that_are_not_measurements() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sweep.csv");
    for wall in ["inf", "nan", "-1", "1e400"] {
        sweep_csv(&csv, wall);
        let started = Instant::now();
        let output = run_lab(&["chart".as_ref(), csv.as_os_str()]);
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "{wall}: no spin"
        );
        let expected = format!(
            "fluid-lab: error: {}: row 3: wall_s is {wall}, not a finite measurement >= 0",
            csv.display()
        );
        assert_refused(&output, 1, &expected);
    }
    assert_eq!(entries(dir.path()), ["sweep.csv"], "no chart drawn");
    sweep_csv(&csv, "0.5");
    let folder = dir.path().join("new/charts");
    let output = run_lab(&[
        "chart".as_ref(),
        csv.as_os_str(),
        "--output-dir".as_ref(),
        folder.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(folder.join("time.png").is_file(), "--output-dir is created");
}

#[test]
fn item_4_a_fifo_input_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("in.fifo");
    mkfifo(&fifo);
    let out = dir.path().join("out.fld");
    let output = run_fluid(&["1".as_ref(), fifo.as_os_str(), out.as_os_str()]);
    assert_refused(
        &output,
        253,
        &format!("Error: Cannot open {} for reading", fifo.display()),
    );
    let output = run_lab(&["run".as_ref(), fifo.as_os_str()]);
    assert_eq!(exit_code(&output), 1);
    assert!(!out.exists());
}

// 2. Silent garbage.

#[test]
fn item_5_a_state_beyond_f32_is_an_error_not_an_infinity() {
    let dir = tempfile::tempdir().unwrap();
    let far = dir.path().join("far.fld");
    let at = |x: f32| [x, 0.0, 0.0, 0.0, 0.0, 0.0, x, 0.0, 0.0];
    fld(&far, 204.0, &[at(3e38), at(-3e38)]);
    let out = dir.path().join("out.fld");
    let output = run_fluid(&["1".as_ref(), far.as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 252);
    let message = stderr(&output);
    assert!(
        message.starts_with(&format!(
            "Error: Cannot write {}: particle 0 has ",
            out.display()
        )) && message.ends_with(", beyond what the f32 .fld format stores.\n"),
        "{message}"
    );
    assert_eq!(entries(dir.path()), ["far.fld"]);

    let (out, diagnostics) = (dir.path().join("o.fld"), dir.path().join("d.csv"));
    let output = run_lab(&[
        "run".as_ref(),
        input("small").as_os_str(),
        out.as_os_str(),
        "--dt".as_ref(),
        "0.01".as_ref(),
        "--steps".as_ref(),
        "100".as_ref(),
        "--diagnostics".as_ref(),
        diagnostics.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("beyond what the f32 .fld format stores"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists());
    let text = std::fs::read_to_string(&diagnostics).unwrap();
    let last = text.lines().last().unwrap();
    assert!(last.starts_with("100,"), "{last}");
    // The flag column, by its name (it is not the last).
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let column = header
        .iter()
        .position(|&name| name == "beyond_f32")
        .unwrap();
    let beyond: usize = last.split(',').nth(column).unwrap().parse().unwrap();
    assert!(beyond > 4000, "the flag column counts them: {last}");
    let longest = text.split([',', '\n']).map(str::len).max().unwrap();
    assert!(longest < 40, "no 140-digit numbers: {longest}");
}

// 3. Data loss and late failures.

#[test]
fn item_7_signals_leave_nothing_behind_and_end_the_process_as_they_would() {
    let dir = tempfile::tempdir().unwrap();
    let (large, small) = (input("large"), input("small"));
    let lab = env!("CARGO_BIN_EXE_fluid-lab");
    // SIGABRT as a failed memory allocation raises it.
    for signal in [
        libc::SIGINT,
        libc::SIGTERM,
        libc::SIGHUP,
        libc::SIGQUIT,
        libc::SIGABRT,
    ] {
        let runs: [(&str, Vec<&OsStr>); 3] = [
            (
                lab,
                vec![
                    "run".as_ref(),
                    large.as_os_str(),
                    "o.fld".as_ref(),
                    "--steps".as_ref(),
                    "1000000".as_ref(),
                    "--diagnostics".as_ref(),
                    "d.csv".as_ref(),
                ],
            ),
            (
                env!("CARGO_BIN_EXE_fluid"),
                vec!["1000000".as_ref(), large.as_os_str(), "o.fld".as_ref()],
            ),
            (
                lab,
                vec![
                    "render".as_ref(),
                    small.as_os_str(),
                    "r.gif".as_ref(),
                    "--steps".as_ref(),
                    "1000000".as_ref(),
                    "--every".as_ref(),
                    "1".as_ref(),
                ],
            ),
        ];
        for (program, args) in runs {
            let mut child = spawn(program, &args, dir.path(), 0o022);
            // Outputs are opened before the run: their temporary files appear first.
            wait_until("the temporary files", || {
                entries(dir.path())
                    .iter()
                    .any(|name| name.ends_with(".tmp") || name.ends_with(".tmp.gif"))
            });
            std::thread::sleep(Duration::from_millis(200));
            // SAFETY: kill sends a signal to our own child.
            assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
            let status = reap(&mut child);
            assert_eq!(status.signal(), Some(signal), "{args:?}");
            assert!(
                entries(dir.path()).is_empty(),
                "{args:?}: {:?}",
                entries(dir.path())
            );
        }
    }
}

#[test]
fn item_8_unwritable_outputs_fail_before_anything_is_printed_or_simulated() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let mut in_fld_slash = small.clone().into_os_string();
    in_fld_slash.push("/");
    let long = "n".repeat(256);
    for output in [
        OsStr::new("nodir/").to_owned(),
        in_fld_slash,
        OsStr::new("/dev/full").to_owned(),
        OsStr::new("nodir/.").to_owned(),
        OsStr::new(&long).to_owned(),
    ] {
        let run = Command::new(env!("CARGO_BIN_EXE_fluid"))
            .args(["1".as_ref(), small.as_os_str(), &output])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let message = format!(
            "Error: Cannot open {} for writing",
            output.to_string_lossy()
        );
        assert_refused(&run, 252, &message);
    }
    assert!(entries(dir.path()).is_empty());
    let missing = dir.path().join("missing/x.png");
    let started = Instant::now();
    let output = run_lab(&[
        "render".as_ref(),
        small.as_os_str(),
        missing.as_os_str(),
        "--steps".as_ref(),
        "100000".as_ref(),
    ]);
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "before simulating"
    );
    assert_refused(
        &output,
        1,
        &format!(
            "fluid-lab: error: Cannot open {} for writing",
            missing.display()
        ),
    );
}

#[test]
fn item_9_names_of_up_to_255_bytes_are_written() {
    let dir = tempfile::tempdir().unwrap();
    for length in [245, 250, 255] {
        let out = dir.path().join("n".repeat(length));
        let output = run_fluid(&["0".as_ref(), input("small").as_os_str(), out.as_os_str()]);
        assert_eq!(exit_code(&output), 0, "{length}: {}", stderr(&output));
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(input("small")).unwrap()
        );
    }
    assert_eq!(entries(dir.path()).len(), 3);
}

#[test]
fn item_10_outputs_keep_their_mode_links_and_folder_and_follow_the_umask() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let fluid = env!("CARGO_BIN_EXE_fluid");
    let mode = |path: &Path| std::fs::metadata(path).unwrap().permissions().mode() & 0o777;
    let run = |out: &str, umask: u32| {
        let args = ["0".as_ref(), small.as_os_str(), out.as_ref()];
        assert!(reap(&mut spawn(fluid, &args, dir.path(), umask)).success());
    };
    run("new.fld", 0o077);
    assert_eq!(
        mode(&dir.path().join("new.fld")),
        0o600,
        "0666 less the umask"
    );
    run("public.fld", 0o002);
    assert_eq!(mode(&dir.path().join("public.fld")), 0o664);
    let private = dir.path().join("private.fld");
    std::fs::write(&private, b"old").unwrap();
    std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o640)).unwrap();
    run("private.fld", 0o022);
    assert_eq!(mode(&private), 0o640, "an existing file keeps its mode");
    let link = dir.path().join("link.fld");
    std::fs::hard_link(&private, &link).unwrap();
    run("private.fld", 0o022);
    assert_eq!(
        std::fs::read(&link).unwrap(),
        std::fs::read(&small).unwrap()
    );

    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    let kept = locked.join("kept.fld");
    std::fs::write(&kept, b"old").unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let output = run_fluid(&["0".as_ref(), small.as_os_str(), kept.as_os_str()]);
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert_eq!(
        std::fs::read(&kept).unwrap(),
        std::fs::read(&small).unwrap()
    );
    assert_eq!(entries(&locked), ["kept.fld"]);
}

// 4. Unclear interfaces.

#[test]
fn item_12_options_take_the_forms_their_help_shows() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    // Lists separated by spaces or commas; corner-block without --particles.
    let output = run_lab(&[
        "stability",
        "--scene",
        "corner-block",
        "--models",
        "course",
        "fluidanimate",
        "--ppms",
        "100",
        "120",
        "--dt-factors",
        "1",
        "2",
        "--adaptive",
        "",
        "--duration",
        "0.002",
        "--output-dir",
        &dir.path().join("map").to_string_lossy(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let rows = std::fs::read_to_string(dir.path().join("map/stability.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 2 * 2 * 2, "{rows}");
    // A negative number reaches its check.
    let whole = |text: &str| {
        format!("{text} is not a whole number of steps from 0 to 9223372036854775807 in digits")
    };
    for (option, value, said) in [
        ("--steps", "-1", whole("-1")),
        (
            "--every",
            "-1",
            "-1 is not a whole number from 1 to 9223372036854775807".to_string(),
        ),
        // Nor a number in another form, or past the largest.
        ("--steps", "1e3", whole("1e3")),
        (
            "--steps",
            "9223372036854775808",
            whole("9223372036854775808"),
        ),
    ] {
        let args = [
            "run".as_ref(),
            small.as_os_str(),
            option.as_ref(),
            value.as_ref(),
        ];
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 2);
        assert!(stderr(&output).contains(&said), "{}", stderr(&output));
    }
    // A subnormal time, whose ratios overflow (seconds per simulated second was inf).
    let output = run_lab(&[
        "run".as_ref(),
        small.as_os_str(),
        "--until".as_ref(),
        "5e-324".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 2);
    assert!(
        stderr(&output).contains("5e-324 is not a positive, finite time in seconds"),
        "{}",
        stderr(&output)
    );
    let output = run_lab(&[
        "run".as_ref(),
        small.as_os_str(),
        "--dt".as_ref(),
        "-1".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 2);
    assert!(
        stderr(&output).contains("-1 is not a positive time step"),
        "{}",
        stderr(&output)
    );
    // Extensions in any case.
    let upper = dir.path().join("X.PNG");
    let output = run_lab(&["render".as_ref(), small.as_os_str(), upper.as_os_str()]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(std::fs::read(&upper).unwrap().starts_with(b"\x89PNG"));
}

#[test]
fn item_13_messages_print_numbers_and_names_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let huge = dir.path().join("huge.fld");
    fld(&huge, 1e30, &[[0.0; 9]]);
    let out = dir.path().join("out.fld");
    let output = run_fluid(&["1".as_ref(), huge.as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 251);
    let message = stderr(&output);
    assert!(
        message.contains("particles per meter 1e+30 gives a grid of 7.670e28 x "),
        "{message}"
    );
    assert!(!message.contains("0000000"), "{message}");
    // Two neighbouring f32 values (both too coarse for a grid) print apart.
    let (a, b) = (10.0f32, f32::from_bits(10.0f32.to_bits() + 1));
    let messages: Vec<String> = [a, b]
        .iter()
        .map(|&ppm| {
            let file = dir.path().join("near.fld");
            fld(&file, ppm, &[[0.0; 9]]);
            stderr(&run_fluid(&[
                "1".as_ref(),
                file.as_os_str(),
                out.as_os_str(),
            ]))
        })
        .collect();
    assert!(
        messages[0].contains("particles per meter 10 gives"),
        "{}",
        messages[0]
    );
    assert!(
        messages[1].contains("particles per meter 10.000001 gives"),
        "{}",
        messages[1]
    );
    // scene names the grid's real problem.
    let output = run_lab(&[
        "scene".as_ref(),
        "filled-box".as_ref(),
        out.as_os_str(),
        "--ppm".as_ref(),
        "1e30".as_ref(),
    ]);
    assert!(
        stderr(&output).contains("gives a grid of 7.670e28 x "),
        "{}",
        stderr(&output)
    );
    // File names byte for byte.
    let odd = dir.path().join(OsStr::from_bytes(b"\xff.fld"));
    let output = run_fluid(&["1".as_ref(), odd.as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 253);
    let expected = [
        b"Error: Cannot open ",
        odd.as_os_str().as_bytes(),
        b" for reading\n",
    ]
    .concat();
    assert_eq!(output.stderr, expected);
    assert!(!out.exists());
}

// Checkpoints.

/// Runs `fluid-lab run` on large.fld with `args` after the input; asserts success.
fn run_large(args: &[&OsStr]) {
    let large = input("large");
    let mut all: Vec<&OsStr> = vec!["run".as_ref(), large.as_os_str()];
    all.extend(args);
    let output = run_lab(&all);
    assert_eq!(exit_code(&output), 0, "{args:?}: {}", stderr(&output));
}

#[test]
fn a_run_to_a_physical_time_lands_on_it_and_resumes_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| -> PathBuf { dir.path().join(name) };
    let small = input("small");
    let run = |extra: &[&OsStr]| {
        let mut args: Vec<&OsStr> = vec!["run".as_ref(), small.as_os_str()];
        args.extend(
            [
                "--model",
                "fluidanimate",
                "--dt",
                "0.001",
                "--until",
                "0.0052",
            ]
            .map(OsStr::new),
        );
        args.extend(extra);
        run_lab(&args)
    };
    // 5 whole steps of 1 ms, then one of 0.2 ms that lands on 5.2 ms.
    let whole = run(&[path("whole.fld").as_os_str()]);
    assert_eq!(exit_code(&whole), 0, "{}", stderr(&whole));
    let line = stdout(&whole);
    assert!(
        line.contains(" steps=6 ") && line.contains(" simulated_s=0.005200 "),
        "{line}"
    );
    // Checkpointed after 4 steps, then resumed to the same time: the same file.
    let part = run(&[
        "--checkpoint-every".as_ref(),
        "4".as_ref(),
        "--checkpoint".as_ref(),
        path("part.ck").as_os_str(),
    ]);
    assert_eq!(exit_code(&part), 0, "{}", stderr(&part));
    let resumed = run(&[
        path("resumed.fld").as_os_str(),
        "--resume".as_ref(),
        path("part.ck").as_os_str(),
    ]);
    assert_eq!(exit_code(&resumed), 0, "{}", stderr(&resumed));
    assert!(
        stdout(&resumed).contains(" steps=2 "),
        "{}",
        stdout(&resumed)
    );
    let read = |name: &str| std::fs::read(path(name)).unwrap();
    assert_eq!(read("whole.fld"), read("resumed.fld"));
    // An end before the checkpoint's time is refused; a time that is not finite and
    // positive too.
    let mut args: Vec<&OsStr> = vec!["run".as_ref(), small.as_os_str()];
    args.extend(
        [
            "--model",
            "fluidanimate",
            "--dt",
            "0.001",
            "--until",
            "0.003",
        ]
        .map(OsStr::new),
    );
    let checkpoint = path("part.ck");
    args.extend(["--resume".as_ref(), checkpoint.as_os_str()]);
    let early = run_lab(&args);
    assert_eq!(exit_code(&early), 1);
    assert!(
        stderr(&early).contains("beyond --until 0.003"),
        "{}",
        stderr(&early)
    );
    for value in ["0", "-1", "nan", "inf"] {
        let output = run_lab(&[
            "run".as_ref(),
            small.as_os_str(),
            "--until".as_ref(),
            OsStr::new(value),
        ]);
        assert_eq!(exit_code(&output), 2, "{value}");
        assert!(stderr(&output).contains("is not a positive, finite time in seconds"));
    }
}

#[test]
fn a_run_to_a_physical_time_stops_when_its_adaptive_step_collapses() {
    // Two particles at 100 km/s: the adaptive step, C h / (c + |hv|), is 2e-8 s, so 1 s
    // would take fifty million steps (more than the ten million allowed). Each
    // simulating subcommand stops at once instead.
    let dir = tempfile::tempdir().unwrap();
    let fast = dir.path().join("fast.fld");
    common::write_fast_pair(&fast);
    let out = dir.path().join("out");
    let outputs = [
        ("run", out.with_extension("fld")),
        ("export", out.clone()),
        ("render", out.with_extension("png")),
    ];
    for (subcommand, output) in outputs {
        let run = run_lab(&[
            subcommand.as_ref(),
            fast.as_os_str(),
            output.as_os_str(),
            "--adaptive".as_ref(),
            "0.3".as_ref(),
            "--until".as_ref(),
            "1".as_ref(),
        ]);
        assert_eq!(exit_code(&run), 1, "{subcommand}");
        let message = stderr(&run);
        assert!(
            message.contains("the run failed at step 1, t = 2.4926e-08 s: its adaptive step of 2.4926e-08 s would take more than 1e7 steps for the 1 s still to go"),
            "{subcommand}: {message}"
        );
        assert_eq!(message.lines().count(), 1, "{message}");
    }
}

#[test]
fn checkpoints_continue_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| -> PathBuf { dir.path().join(name) };
    // The last is of the weakly compressible model on the velocity Verlet, whose
    // checkpoint also keeps its last density rates.
    for time_step in [
        ["--dt", "0.001", "--integrator", "leapfrog"],
        ["--adaptive", "0.3", "--integrator", "verlet"],
        ["--model", "wcsph", "--integrator", "leapfrog"],
        ["--model", "wcsph", "--integrator", "verlet"],
    ] {
        let [rule, value, integrator, name] = time_step.map(OsStr::new);
        // 12 steps in one run, checkpointed at the end.
        run_large(&[
            path("whole.fld").as_os_str(),
            "--steps".as_ref(),
            "12".as_ref(),
            rule,
            value,
            integrator,
            name,
            "--checkpoint-every".as_ref(),
            "12".as_ref(),
            "--checkpoint".as_ref(),
            path("whole.ck").as_os_str(),
        ]);
        // 5 steps, then resumed to 12.
        run_large(&[
            "--steps".as_ref(),
            "5".as_ref(),
            rule,
            value,
            integrator,
            name,
            "--checkpoint-every".as_ref(),
            "5".as_ref(),
            "--checkpoint".as_ref(),
            path("part.ck").as_os_str(),
        ]);
        run_large(&[
            path("resumed.fld").as_os_str(),
            "--steps".as_ref(),
            "12".as_ref(),
            rule,
            value,
            integrator,
            name,
            "--resume".as_ref(),
            path("part.ck").as_os_str(),
            "--checkpoint-every".as_ref(),
            "12".as_ref(),
            "--checkpoint".as_ref(),
            path("resumed.ck").as_os_str(),
        ]);
        let read = |name: &str| std::fs::read(path(name)).unwrap();
        assert_eq!(
            read("whole.ck"),
            read("resumed.ck"),
            "{time_step:?}: full f64 state"
        );
        assert_eq!(read("whole.fld"), read("resumed.fld"), "{time_step:?}");
    }
    // A checkpoint of another run is refused: the last is of the weakly compressible
    // model, on its own CFL step and the velocity Verlet.
    let resume = |extra: &[&str]| {
        let (large, checkpoint) = (input("large"), path("part.ck"));
        let mut args: Vec<&OsStr> = vec!["run".as_ref(), large.as_os_str()];
        args.extend(["--steps", "12"].map(OsStr::new));
        args.extend(extra.iter().map(OsStr::new));
        args.extend(["--resume".as_ref(), checkpoint.as_os_str()]);
        run_lab(&args)
    };
    let output = resume(&[]);
    assert_eq!(exit_code(&output), 1);
    assert!(stderr(&output).contains("a checkpoint of a run with another model or kernel"));
    let output = resume(&["--model", "wcsph", "--dt", "1e-4", "--integrator", "verlet"]);
    assert_eq!(exit_code(&output), 1);
    assert!(stderr(&output).contains("a checkpoint of a run with another time step"));
    let output = resume(&["--model", "wcsph"]);
    assert_eq!(exit_code(&output), 1);
    assert!(stderr(&output).contains("a checkpoint of a run with another integrator"));
    let output = resume(&[
        "--model",
        "wcsph",
        "--integrator",
        "verlet",
        "--walls",
        "free-slip",
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("a checkpoint of a run with another setting of its model"),
        "{}",
        stderr(&output)
    );
    // The weakly compressible model keeps its lists with a skin by default: a resume
    // that asks for none is refused.
    let output = resume(&["--model", "wcsph", "--integrator", "verlet", "--skin", "0"]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("a checkpoint of a run with another skin"),
        "{}",
        stderr(&output)
    );
    // Nor one that asks for another pair structure (the order of the sums).
    let output = resume(&[
        "--model",
        "wcsph",
        "--integrator",
        "verlet",
        "--pairs",
        "tiles",
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(stderr(&output).contains("a checkpoint of a run with another pair structure"));
    // A checkpoint of the format before the integrators (version 4, which held the
    // model's values after a one-byte count) is refused, not misread.
    let mut older = std::fs::read(path("part.ck")).unwrap();
    older[..8].copy_from_slice(b"FLUIDCK4");
    std::fs::write(path("part.ck"), older).unwrap();
    let output = resume(&["--model", "wcsph", "--integrator", "verlet"]);
    assert_eq!(exit_code(&output), 1);
    let message = stderr(&output);
    assert!(
        message.contains("an older fluid (format version 4)") && message.lines().count() == 1,
        "{message}"
    );
}

#[test]
fn a_run_killed_with_sigkill_resumes_from_its_last_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let large = input("large");
    let checkpoint = dir.path().join("run.ck");
    let args: Vec<&OsStr> = vec![
        "run".as_ref(),
        large.as_os_str(),
        "--steps".as_ref(),
        "1000000".as_ref(),
        "--checkpoint-every".as_ref(),
        "3".as_ref(),
        "--checkpoint".as_ref(),
        checkpoint.as_os_str(),
    ];
    let mut child = spawn(env!("CARGO_BIN_EXE_fluid-lab"), &args, dir.path(), 0o022);
    wait_until("the second checkpoint", || {
        std::fs::read(&checkpoint)
            .is_ok_and(|bytes| bytes.len() > 16 && bytes[8..16] != 3u64.to_le_bytes())
    });
    child.kill().unwrap();
    reap(&mut child);
    let bytes = std::fs::read(&checkpoint).unwrap();
    let step = u64::from_le_bytes(bytes[8..16].try_into().unwrap());
    assert!(step >= 6 && step % 3 == 0, "{step}");
    let target = (step + 2).to_string();
    let (whole, resumed) = (dir.path().join("whole.fld"), dir.path().join("resumed.fld"));
    run_large(&[whole.as_os_str(), "--steps".as_ref(), target.as_ref()]);
    run_large(&[
        resumed.as_os_str(),
        "--steps".as_ref(),
        target.as_ref(),
        "--resume".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(
        std::fs::read(&whole).unwrap(),
        std::fs::read(&resumed).unwrap()
    );
    let leftovers: Vec<String> = entries(dir.path())
        .into_iter()
        .filter(|name| name.ends_with(".tmp"))
        .collect();
    assert!(
        leftovers.len() <= 1,
        "SIGKILL may leave one temporary: {leftovers:?}"
    );
}

// What the review of the fixes above found.

#[test]
fn a_dangling_symbolic_link_is_written_through() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("link.fld");
    std::os::unix::fs::symlink("target.fld", &link).unwrap();
    let output = run_fluid(&["0".as_ref(), input("small").as_os_str(), link.as_os_str()]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
    assert_eq!(
        std::fs::read(dir.path().join("target.fld")).unwrap(),
        std::fs::read(input("small")).unwrap()
    );
}

#[test]
fn side_files_must_be_files_of_their_own_and_special_files_are_not_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let own = dir.path().join("in.fld");
    std::fs::copy(input("small"), &own).unwrap();
    let before = std::fs::read(&own).unwrap();
    let out = dir.path().join("out.fld");
    for (args, clash) in [
        (
            vec!["--diagnostics".as_ref(), own.as_os_str()],
            format!("--diagnostics {0} is also the input {0}", own.display()),
        ),
        (
            vec![
                "--checkpoint-every".as_ref(),
                "1".as_ref(),
                "--checkpoint".as_ref(),
                out.as_os_str(),
            ],
            format!("--checkpoint {0} is also the output {0}", out.display()),
        ),
    ] {
        let mut all: Vec<&OsStr> = vec!["run".as_ref(), own.as_os_str(), out.as_os_str()];
        all.extend(args);
        let output = run_lab(&all);
        assert_eq!(exit_code(&output), 2, "a usage error");
        assert!(
            stderr(&output).contains(&format!("{clash}: give it a file of its own")),
            "{}",
            stderr(&output)
        );
    }
    // The checkpoint resumed from is not written over by the final state or the
    // diagnostics (a new checkpoint may replace it).
    let checkpoint = dir.path().join("ck.bin");
    let output = run_lab(&[
        "run".as_ref(),
        own.as_os_str(),
        "--steps".as_ref(),
        "2".as_ref(),
        "--checkpoint-every".as_ref(),
        "1".as_ref(),
        "--checkpoint".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let saved = std::fs::read(&checkpoint).unwrap();
    let resume = |extra: &[&OsStr]| {
        let mut all: Vec<&OsStr> = vec![
            "run".as_ref(),
            own.as_os_str(),
            "--steps".as_ref(),
            "3".as_ref(),
            "--resume".as_ref(),
            checkpoint.as_os_str(),
        ];
        all.extend(extra);
        run_lab(&all)
    };
    let shown = checkpoint.display();
    for (extra, what) in [
        (vec![checkpoint.as_os_str()], "the output"),
        (
            vec![
                out.as_os_str(),
                "--diagnostics".as_ref(),
                checkpoint.as_os_str(),
            ],
            "--diagnostics",
        ),
    ] {
        let message = format!(
            "fluid-lab: error: {what} {shown} is the checkpoint resumed from: give it a file \
             of its own"
        );
        assert_refused(&resume(&extra), 2, &message);
        assert_eq!(std::fs::read(&checkpoint).unwrap(), saved);
    }
    let again = resume(&[
        "--checkpoint-every".as_ref(),
        "1".as_ref(),
        "--checkpoint".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(exit_code(&again), 0, "{}", stderr(&again));
    let output = run_lab(&[
        "sweep".as_ref(),
        "--output".as_ref(),
        own.as_os_str(),
        "--".as_ref(),
        own.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 2, "a usage error");
    assert!(
        stderr(&output).contains("is the input"),
        "{}",
        stderr(&output)
    );
    assert_eq!(
        std::fs::read(&own).unwrap(),
        before,
        "the input is untouched"
    );
    // Nor the program it measures (issue 47, a second hostile pass: it was written over).
    let program = own.with_file_name("measured.sh");
    std::fs::write(&program, "#!/bin/sh\nexit 0\n").unwrap();
    std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
    let output = run_lab(&[
        "sweep".as_ref(),
        "--iterations".as_ref(),
        "0".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
        "--idle-seconds".as_ref(),
        "0".as_ref(),
        "--program".as_ref(),
        program.as_os_str(),
        "--output".as_ref(),
        program.as_os_str(),
        "--".as_ref(),
        own.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 2, "a usage error");
    assert!(
        stderr(&output).contains("is the program measured"),
        "{}",
        stderr(&output)
    );
    assert_eq!(std::fs::read(&program).unwrap(), b"#!/bin/sh\nexit 0\n");
    assert!(!out.exists());
    let output = run_lab(&[
        "run".as_ref(),
        own.as_os_str(),
        "--resume".as_ref(),
        "/dev/zero".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("not a regular file"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn a_checkpoint_of_another_input_with_the_same_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (first, second) = (dir.path().join("a.fld"), dir.path().join("b.fld"));
    std::fs::copy(input("small"), &first).unwrap();
    let mut other = std::fs::read(input("small")).unwrap();
    other[8] ^= 1; // the lowest bit of particle 0's px
    std::fs::write(&second, other).unwrap();
    let checkpoint = dir.path().join("a.ck");
    let output = run_lab(&[
        "run".as_ref(),
        first.as_os_str(),
        "--steps".as_ref(),
        "2".as_ref(),
        "--checkpoint-every".as_ref(),
        "2".as_ref(),
        "--checkpoint".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let output = run_lab(&[
        "run".as_ref(),
        second.as_os_str(),
        "--steps".as_ref(),
        "4".as_ref(),
        "--resume".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains(
            "a checkpoint of a run from another input: give the input the run started from, \
             then the output"
        ),
        "{}",
        stderr(&output)
    );
    // Beside a case, the message speaks of the case (the eighth hostile pass: it spoke of
    // a positional input).
    let case = dir.path().join("c.toml");
    std::fs::write(&case, "[fluid]\nparticles_per_m = 100\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\nmax_m = [-0.03, -0.05, -0.03]\n").unwrap();
    let output = run_lab(&[
        "run".as_ref(),
        "--case".as_ref(),
        case.as_os_str(),
        "--resume".as_ref(),
        checkpoint.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {} is not a checkpoint of a run of {}: give --resume alone (a \
             checkpoint of a case keeps it), or the input its run started from\n",
            checkpoint.display(),
            case.display()
        )
    );
}

#[test]
fn a_run_that_turns_non_finite_draws_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let picture = dir.path().join("x.png");
    let output = run_lab(&[
        "render".as_ref(),
        input("small").as_os_str(),
        picture.as_os_str(),
        "--steps".as_ref(),
        "3".as_ref(),
        "--dt".as_ref(),
        "1e200".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("is not finite"),
        "{}",
        stderr(&output)
    );
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn a_stopped_sweep_keeps_its_rows_and_stops_the_run_it_measures() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("slow.sh");
    let pid_file = dir.path().join("pid");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\nif [ \"$1\" = 10 ]; then echo $$ > {}; exec sleep 60; fi\nexec {} \"$@\"\n",
            pid_file.display(),
            env!("CARGO_BIN_EXE_fluid")
        ),
    )
    .unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    let small = input("small");
    let args: Vec<&OsStr> = vec![
        "sweep".as_ref(),
        "--iterations".as_ref(),
        "0,10".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
        "--idle-seconds".as_ref(),
        "0".as_ref(),
        "--output".as_ref(),
        "s.csv".as_ref(),
        "--program".as_ref(),
        script.as_os_str(),
        "--".as_ref(),
        small.as_os_str(),
    ];
    let mut sweep = spawn(env!("CARGO_BIN_EXE_fluid-lab"), &args, dir.path(), 0o022);
    wait_until("the slow run", || {
        std::fs::read_to_string(&pid_file).is_ok_and(|pid| pid.ends_with('\n'))
    });
    let child: i32 = std::fs::read_to_string(&pid_file)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    // SAFETY: kill sends a signal to our own child.
    assert_eq!(unsafe { libc::kill(sweep.id() as i32, libc::SIGTERM) }, 0);
    assert_eq!(reap(&mut sweep).signal(), Some(libc::SIGTERM));
    let rows = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    assert_eq!(
        rows.lines().count(),
        3,
        "header, idle, the 0-iteration run: {rows}"
    );
    wait_until("the measured run to end", || {
        std::fs::read_to_string(format!("/proc/{child}/stat"))
            .map_or(true, |stat| stat.contains(") Z "))
    });
}

// What the second hostile pass (issue 47) found: every one a line, exit 2, no hang.

#[test]
fn limits_that_would_run_for_ever_or_overflow_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let small = small.to_str().unwrap();
    let folder = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let gif = folder("x.gif");
    let (vd, sd, ad, ex) = (folder("vd"), folder("sd"), folder("ad"), folder("ex"));
    let refused: [(Vec<&str>, &str); 7] = [
        (
            vec!["render", small, &gif, "--steps", "1", "--delay-ms", "4294967295"],
            "fluid-lab: error: invalid value '4294967295' for '--delay-ms <DELAY_MS>': 4294967295 is not a whole number from 0 to 655350",
        ),
        (
            vec!["export", small, &ex, "--until", "0.002", "--frame-every", "1e-12"],
            "fluid-lab: error: --frame-every 1e-12 would write 2.000e9 frames to 0.002 s, more than the 1e7 a run may take steps for",
        ),
        (
            vec!["validate", "dam-break", "--until-t", "1e300", "--output-dir", &vd],
            "fluid-lab: error: --until-t 1e+300 is not a T above 0, at most 1000",
        ),
        (
            vec!["validate", "dam-break", "--until", "100", "--output-dir", &vd],
            "fluid-lab: error: --until 100 is more than the 60 s a dam break may run",
        ),
        (
            vec!["stability", "--output-dir", &sd, "--ppms", "100", "--dt-factors", "1", "--adaptive", "", "--duration", "1e300"],
            "fluid-lab: error: --duration 1e+300 s on steps of 0.001 s would take 1.000e303 steps a run, more than the 1e7 a run may take",
        ),
        (
            vec!["accuracy", small, "--output-dir", &ad, "--dt-factors", "1", "--adaptive", "", "--times", "0.002", "--reference-dt", "1e-300"],
            "fluid-lab: error: --times up to 0.002 s on reference steps of 1e-300 s would take 2.000e297 steps, more than the 1e7 a run may take",
        ),
        (
            vec!["run", small, "--progress-every", "nan"],
            "fluid-lab: error: invalid value 'nan' for '--progress-every <SECONDS>': nan is not a number of seconds from 0 to 1e9",
        ),
    ];
    for (args, message) in refused {
        let output = run_lab(&args);
        assert_refused(&output, 2, message);
        assert!(
            entries(dir.path()).is_empty(),
            "{args:?}: {:?}",
            entries(dir.path())
        );
    }
    // A fixed step of 1e5 s would sample there, where the reference's steps (an eighth of
    // an adaptive method's) would never arrive: refused before anything runs (the ninth
    // hostile pass: the methods ran first), leaving nothing.
    let output = run_lab(&[
        "accuracy",
        small,
        "--output-dir",
        &ad,
        "--dt-factors",
        "1e8",
        "--times",
        "0.002",
        "--quiet",
    ]);
    assert_refused(
        &output,
        2,
        "fluid-lab: error: a fixed step of 100000 s passes the first of --times, 0.002 s: \
         each method samples every time (shorten --dt-factors or give later times)",
    );
    assert!(entries(dir.path()).is_empty(), "{:?}", entries(dir.path()));
}

#[test]
fn a_tiny_gauge_interval_reads_every_step_and_a_failed_run_says_nothing_of_replacing() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("c.toml");
    let text = |interval: &str| {
        format!(
            "[fluid]\nparticles_per_m = 100\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\n\
             max_m = [0.0, 0.0, 0.065]\n[model]\nname = \"wcsph\"\n[run]\nsteps = 2\n\
             [output]\nfolder = \"{}\"\n[gauges]\ninterval_s = {interval}\n\
             [[gauges.point]]\nname = \"p\"\nat_m = [-0.03, -0.07, 0.0]",
            dir.path().join("g").display()
        )
    };
    std::fs::write(&case, text("1e-300")).unwrap();
    let output = run_lab(&["run".as_ref(), "--case".as_ref(), case.as_os_str()]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let table = std::fs::read_to_string(dir.path().join("g/gauges.csv")).unwrap();
    assert_eq!(table.lines().count(), 1 + 3, "{table}");
    // Run again and fail (steps too long to stay finite): the table stays, unmentioned.
    let output = run_lab(&[
        "run".as_ref(),
        "--case".as_ref(),
        case.as_os_str(),
        "--dt".as_ref(),
        "1e300".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(!stderr(&output).contains("note:"), "{}", stderr(&output));
    assert_eq!(stderr(&output).lines().count(), 1, "{}", stderr(&output));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("g/gauges.csv")).unwrap(),
        table
    );
    // A run whose chart cannot be written (a folder where its PNG goes) fails before
    // the table is replaced: the table stays, unmentioned.
    let png = std::fs::read_dir(dir.path().join("g"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .find(|path| path.extension().is_some_and(|e| e == "png"))
        .expect("a gauge chart");
    std::fs::remove_file(&png).unwrap();
    std::fs::create_dir(&png).unwrap();
    std::fs::write(&case, text("0.01")).unwrap();
    let output = run_lab(&["run".as_ref(), "--case".as_ref(), case.as_os_str()]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(!stderr(&output).contains("note:"), "{}", stderr(&output));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("g/gauges.csv")).unwrap(),
        table
    );
    std::fs::remove_dir(&png).unwrap();
    // A path with control characters is refused at its key.
    let bad = text("0.01").replace("[output]\n", "[output]\nfinal_state = \"a\\nb.fld\"\n");
    std::fs::write(&case, bad).unwrap();
    let output = run_lab(&["run".as_ref(), "--case".as_ref(), case.as_os_str()]);
    assert_refused(
        &output,
        2,
        &format!(
            "fluid-lab: error: {}:11:15: a path must not hold control characters",
            case.display()
        ),
    );
}

#[test]
fn bad_flag_values_found_after_parsing_are_usage_errors_that_leave_nothing() {
    // Issue 47: values clap cannot check alone (a list's order, an extension, a flag
    // that only some scenes take) exit 2 in one line, as clap's own errors do.
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let small = input("small").to_str().unwrap().to_string();
    let cases: [(Vec<String>, String); 10] = [
        (
            vec![
                "validate".into(),
                "dam-break".into(),
                "--ppms".into(),
                "0".into(),
            ],
            "fluid-lab: error: invalid value '0' for '--ppms <PPMS>...': 0 is not a positive, \
             finite number of particles per metre"
                .into(),
        ),
        (
            vec!["stability".into(), "--ppms".into(), "100,-1".into()],
            "fluid-lab: error: invalid value '-1' for '--ppms <PPMS>...': -1 is not a \
             positive, finite number of particles per metre"
                .into(),
        ),
        (
            vec![
                "sweep".into(),
                "--idle-seconds".into(),
                "nan".into(),
                small.clone(),
            ],
            "fluid-lab: error: invalid value 'nan' for '--idle-seconds <IDLE_SECONDS>': nan is \
             not a duration from 0 to 86400 seconds"
                .into(),
        ),
        (
            vec![
                "accuracy".into(),
                small.clone(),
                "--times".into(),
                "0.002,0.001".into(),
            ],
            "fluid-lab: error: --times needs ascending, positive, finite times".into(),
        ),
        (
            vec!["render".into(), small.clone(), at("x.jpg")],
            format!(
                "fluid-lab: error: {}: the output must end in .png or .gif",
                at("x.jpg")
            ),
        ),
        (
            vec![
                "scene".into(),
                "dam-break".into(),
                at("c.fld"),
                "--particles".into(),
                "10".into(),
            ],
            "fluid-lab: error: --particles sets the size of random-cloud and corner-block only; \
             dam-break follows from --ppm"
                .into(),
        ),
        (
            vec![
                "scene".into(),
                "dam-break".into(),
                at("c.fld"),
                "--ppm".into(),
                "3000".into(),
            ],
            "fluid-lab: error: dam-break at 3000 particles per metre would hold up to \
             82134000 particles; the limit is 50000000"
                .into(),
        ),
        (
            vec![
                "scene".into(),
                "corner-block".into(),
                at("c.fld"),
                "--ppm".into(),
                "100".into(),
                "--particles".into(),
                "10000000".into(),
            ],
            "fluid-lab: error: a box at 100 particles per metre holds a corner block of at \
             most 3042 particles"
                .into(),
        ),
        (
            vec![
                "scene".into(),
                "random-cloud".into(),
                at("c.fld"),
                "--particles".into(),
                "0".into(),
            ],
            "fluid-lab: error: --particles 0 makes no scene: give at least 1".into(),
        ),
        (
            vec![
                "scene".into(),
                "corner-block".into(),
                at("c.fld"),
                "--particles".into(),
                usize::MAX.to_string(),
            ],
            format!(
                "fluid-lab: error: --particles {} is past the limit of 50000000 particles",
                usize::MAX
            ),
        ),
    ];
    for (mut args, message) in cases {
        if ["validate", "stability", "accuracy"].contains(&args[0].as_str()) {
            args.extend(["--output-dir".into(), at("out")]);
        }
        if args[0] == "sweep" {
            args.extend(["--output".into(), at("sweep.csv")]);
        }
        assert_refused(&run_lab(&args), 2, &message);
        assert!(entries(dir.path()).is_empty(), "{args:?} left files");
    }
}

#[test]
fn tiny_times_print_in_short_scientific_form_not_hundreds_of_digits() {
    // Issue 47: a rate per simulated second of 1e-300 s, and a dam-break sample at that
    // time, printed with every digit of their fixed-point forms.
    let small = input("small");
    let output = run_lab(&[
        "run".as_ref(),
        "--steps".as_ref(),
        "2".as_ref(),
        "--dt".as_ref(),
        "1e-300".as_ref(),
        "--quiet".as_ref(),
        small.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let line = stdout(&output);
    let rate = line
        .split_whitespace()
        .find_map(|field| field.strip_prefix("seconds_per_simulated_s="))
        .expect("a rate");
    assert!(rate.len() <= 12 && rate.contains('e'), "{line}");
    assert!(rate.parse::<f64>().unwrap() > 1e290, "{line}");
    let dir = tempfile::tempdir().unwrap();
    let output = run_lab(&[
        "validate".as_ref(),
        "dam-break".as_ref(),
        "--models".as_ref(),
        "fluidanimate".as_ref(),
        "--ppms".as_ref(),
        "100".as_ref(),
        "--until".as_ref(),
        "1e-300".as_ref(),
        "--quiet".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    // It compares nothing (a failed validation), and writes its fronts all the same.
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    let fronts = std::fs::read_to_string(dir.path().join("dam-break.csv")).unwrap();
    let last: Vec<&str> = fronts.lines().last().unwrap().split(',').collect();
    assert_eq!(last[6], "1e-300", "{fronts}");
    assert!(fronts.lines().all(|line| line.len() < 300), "{fronts}");
}

#[test]
fn a_dam_break_validation_refuses_a_step_too_short_to_end_and_never_hangs() {
    // Issue 47 (a second hostile pass): --dt 1e-300 ran for ever, silent.
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("fixed");
    let validate = |step: &[&str], folder: &Path| {
        let mut args = vec![
            "validate".as_ref(),
            "dam-break".as_ref(),
            "--models".as_ref(),
            "fluidanimate".as_ref(),
            "--ppms".as_ref(),
            "100".as_ref(),
            "--until-t".as_ref(),
            "0.5".as_ref(),
            "--quiet".as_ref(),
            "--output-dir".as_ref(),
            folder.as_os_str(),
        ];
        args.extend(step.iter().map(OsStr::new));
        run_lab(&args)
    };
    // A fixed step: refused before anything runs or is made.
    let output = validate(&["--dt", "1e-300"], &folder);
    assert_refused(
        &output,
        2,
        "fluid-lab: error: a time step of 1e-300 s would take 1.956e298 steps to the end \
         (0.0195615 s) of fluidanimate at 100 per m, more than the 1e7 a run may take",
    );
    assert!(!folder.exists());
    // An adaptive one: the run fails at its first step, its outputs written.
    let folder = dir.path().join("adaptive");
    let output = validate(&["--adaptive", "1e-300"], &folder);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(
        stderr(&output).ends_with(
            "fluid-lab: error: 1 of 1 runs failed: fluidanimate at 100 per m failed at T = \
             0.000 (the adaptive step fell below the limit)\n"
        ),
        "{}",
        stderr(&output)
    );
    assert!(folder.join("dam-break.csv").is_file());
}

#[test]
fn a_signal_removes_the_empty_folders_a_command_made_for_its_outputs() {
    // Issue 47 (a second hostile pass): a failure removed them, a signal did not.
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<&OsStr> = [
        "validate",
        "dam-break",
        "--models",
        "wcsph",
        "--ppms",
        "400",
        "--output-dir",
        "made/inner",
    ]
    .map(OsStr::new)
    .to_vec();
    for signal in [libc::SIGTERM, libc::SIGINT] {
        let mut validate = spawn(env!("CARGO_BIN_EXE_fluid-lab"), &args, dir.path(), 0o022);
        let inner = dir.path().join("made/inner");
        wait_until("the output folder", || inner.is_dir());
        // Well into the run, its outputs not yet written.
        std::thread::sleep(Duration::from_millis(300));
        // SAFETY: kill sends a signal to our own child.
        assert_eq!(unsafe { libc::kill(validate.id() as i32, signal) }, 0);
        assert_eq!(reap(&mut validate).signal(), Some(signal));
        assert!(
            entries(dir.path()).is_empty(),
            "{signal}: {:?}",
            entries(dir.path())
        );
    }
}

#[test]
fn a_scene_too_big_for_memory_ends_with_one_line_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.fld");
    let scene = [
        "scene",
        "corner-block",
        "--ppm",
        "800",
        "--particles",
        "1000000",
    ];
    let made = run_lab(&[&scene.map(OsStr::new)[..], &[big.as_os_str()]].concat());
    assert_eq!(exit_code(&made), 0, "{}", stderr(&made));
    // A run under an address-space limit, as a shared machine may set (KiB).
    let under = |limit: u32, binary: &str, args: &str| {
        Command::new("sh")
            .current_dir(dir.path())
            .arg("-c")
            .arg(format!("ulimit -v {limit} && exec '{binary}' {args}"))
            .output()
            .unwrap()
    };
    let (lab, fluid) = (env!("CARGO_BIN_EXE_fluid-lab"), env!("CARGO_BIN_EXE_fluid"));
    // The workbench estimates what an input's particles need and refuses it first.
    let run = under(300_000, lab, "run --steps 5 big.fld out.fld");
    assert_eq!(exit_code(&run), 1, "{}", stderr(&run));
    assert_eq!(
        stderr(&run),
        "fluid-lab: error: big.fld: its 1000000 particles need about 1.6 GB of memory; this \
         process's ulimit -v allows 307 MB\n"
    );
    // Even under a tenth of that, before the particles are decoded.
    let run = under(100_000, lab, "run --steps 5 big.fld out.fld");
    assert_eq!(exit_code(&run), 1, "{}", stderr(&run));
    assert!(stderr(&run).starts_with("fluid-lab: error: big.fld: its 1000000 particles"));
    // An allocation that fails all the same (`scene`, or `fluid`, which estimate
    // nothing): one line, exit 1, not Rust's backtrace and abort (134), and no temporary
    // output left.
    let scene = "scene corner-block --ppm 800 --particles 1000000 made.fld";
    for (run, prefix) in [
        (under(100_000, lab, scene), "fluid-lab: error: "),
        (under(150_000, fluid, "5 big.fld out.fld"), "Error: "),
    ] {
        let message = stderr(&run);
        assert_eq!(exit_code(&run), 1, "{message}");
        let line = message
            .strip_prefix(&format!("{prefix}out of memory: an allocation of "))
            .and_then(|rest| {
                rest.strip_suffix(" bytes failed (a smaller scene, or more memory: ulimit -v)\n")
            });
        assert!(
            line.is_some_and(|bytes| bytes.parse::<u64>().is_ok()),
            "{message}"
        );
        assert_eq!(entries(dir.path()), ["big.fld"], "nothing left");
    }
}

#[test]
fn a_folder_that_cannot_be_made_leaves_none_of_its_parents() {
    // The last folder's name is too long for the file system: the two made before it go.
    let dir = tempfile::tempdir().unwrap();
    let long = "x".repeat(300);
    for command in ["export", "chaos"] {
        let folder = dir.path().join("made").join("inner").join(&long);
        let mut args: Vec<&OsStr> = match command {
            "export" => vec!["export".as_ref(), "--steps".as_ref(), "0".as_ref()],
            _ => vec!["chaos".as_ref(), "perturb".as_ref()],
        };
        let small = input("small");
        args.extend([small.as_os_str(), folder.as_os_str()]);
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 1, "{command}: {}", stderr(&output));
        assert!(
            stderr(&output).contains("File name too long"),
            "{}",
            stderr(&output)
        );
        assert_eq!(stderr(&output).lines().count(), 1);
        assert!(
            entries(dir.path()).is_empty(),
            "{command}: {:?}",
            entries(dir.path())
        );
    }
}

#[test]
fn a_dam_break_s_column_and_water_flags_are_checked_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("v");
    let refused = [
        (
            "--width=-1",
            "invalid value '-1' for '--width <WIDTH>': -1 is not a width in metres > 0",
        ),
        (
            "--width=nan",
            "invalid value 'nan' for '--width <WIDTH>': nan is not a width in metres > 0",
        ),
        (
            "--width=1",
            "--width 1 at 100 per m: a column 1 m wide and 2 m high does not fit the box \
             (0.13 x 0.18 m)",
        ),
        (
            "--walls=free-slip",
            "--walls, --face, --artificial-viscosity, --laminar-viscosity, --smoothing, --sound-speed \
             and --density-diffusion are the weakly compressible model's; the models run \
             (fluidanimate) take none",
        ),
    ];
    for (flag, message) in refused {
        let output = run_lab(&[
            "validate".as_ref(),
            "dam-break".as_ref(),
            "--models".as_ref(),
            "fluidanimate".as_ref(),
            "--ppms".as_ref(),
            "100".as_ref(),
            "--until".as_ref(),
            "0.01".as_ref(),
            flag.as_ref(),
            "--output-dir".as_ref(),
            folder.as_os_str(),
        ]);
        assert_refused(&output, 2, &format!("fluid-lab: error: {message}"));
        assert!(!folder.exists(), "{flag}");
    }
}

#[test]
fn resolutions_and_factors_out_of_range_are_usage_errors_before_anything_is_made() {
    let dir = tempfile::tempdir().unwrap();
    let made = dir.path().join("made");
    let small = input("small");
    let grid = "gives a grid of 0 x 0 x 0 blocks, but a grid needs at least 1 block per axis \
                and at most 67108864 blocks";
    let cases: [(Vec<&OsStr>, String); 4] = [
        (
            ["scene", "dam-break", "--ppm", "1e-3"]
                .map(OsStr::new)
                .to_vec(),
            format!("particles per metre 0.001 {grid}"),
        ),
        (
            ["scene", "drop", "--ppm", "5"].map(OsStr::new).to_vec(),
            format!("particles per metre 5 {grid}"),
        ),
        (
            vec![
                "accuracy".as_ref(),
                small.as_os_str(),
                "--times".as_ref(),
                "0.001".as_ref(),
                "--dt-factors".as_ref(),
                "0".as_ref(),
                "--output-dir".as_ref(),
            ],
            "--dt-factors need positive, finite factors".to_string(),
        ),
        (
            ["stability", "--ppms", "5", "--output-dir"]
                .map(OsStr::new)
                .to_vec(),
            format!("--ppms 5: particles per metre 5 {grid}"),
        ),
    ];
    for (mut args, message) in cases {
        args.push(made.as_os_str());
        assert_refused(&run_lab(&args), 2, &format!("fluid-lab: error: {message}"));
        assert!(!made.exists(), "{message}");
    }
}

#[test]
fn a_sweep_of_two_inputs_of_one_name_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for folder in [&a, &b] {
        std::fs::create_dir(folder).unwrap();
        std::fs::copy(input("small"), folder.join("one.fld")).unwrap();
    }
    let output_csv = dir.path().join("sweep.csv");
    let output = run_lab(&[
        "sweep".as_ref(),
        "--output".as_ref(),
        output_csv.as_os_str(),
        "--iterations".as_ref(),
        "1".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
        "--idle-seconds".as_ref(),
        "0".as_ref(),
        "--".as_ref(),
        a.join("one.fld").as_os_str(),
        b.join("one.fld").as_os_str(),
    ]);
    let message = format!(
        "fluid-lab: error: {} and {} share the name one.fld, which the CSV's input column \
         would not tell apart",
        a.join("one.fld").display(),
        b.join("one.fld").display()
    );
    assert_refused(&output, 2, &message);
    assert!(!output_csv.exists());
}

#[test]
fn energies_past_f64_are_said_and_speeds_stay_finite() {
    // The course model on 50 ms steps: by step 72 the speeds pass 1e154 m/s, whose
    // squares, and the energies, pass the largest f64 while the state is still finite.
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("c.toml");
    std::fs::write(
        &case,
        "[fluid]\nparticles_per_m = 150.0\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\n\
         max_m = [0.0, 0.0, 0.0]\n[model]\nname = \"course\"\ntime_step_s = 0.05\n\
         [run]\nsteps = 100\n",
    )
    .unwrap();
    let diagnostics = dir.path().join("d.csv");
    let output = run_lab(&[
        "run".as_ref(),
        "--case".as_ref(),
        case.as_os_str(),
        "--diagnostics".as_ref(),
        diagnostics.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let table = std::fs::read_to_string(&diagnostics).unwrap();
    let first = table
        .lines()
        .skip(1)
        .find(|row| row.split(',').nth(4) == Some("inf"))
        .and_then(|row| row.split(',').next())
        .expect("an energy past f64");
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: note: the energies pass the largest f64 from step {first} on: inf in {}\n",
            diagnostics.display()
        )
    );
    for row in table.lines().skip(1) {
        let speed: f64 = row.split(',').nth(2).unwrap().parse().unwrap();
        assert!(speed.is_finite(), "{row}");
    }
}

#[test]
fn the_workbench_names_the_input_whose_particle_count_is_wrong() {
    // `fluid`'s messages for these are SPEC.md's and name no file; the workbench's do.
    let dir = tempfile::tempdir().unwrap();
    let zero = dir.path().join("zero.fld");
    std::fs::write(
        &zero,
        [&204f32.to_le_bytes()[..], &0i32.to_le_bytes()].concat(),
    )
    .unwrap();
    let short = dir.path().join("short.fld");
    let mut bytes = std::fs::read(input("small")).unwrap();
    bytes.truncate(bytes.len() - 36);
    std::fs::write(&short, bytes).unwrap();
    let out = dir.path().join("out.fld");
    for (path, message) in [
        (&zero, "Invalid number of particles: 0."),
        (
            &short,
            "Number of particles mismatch. Header: 4800, Found: 4799.",
        ),
    ] {
        let output = run_lab(&["run".as_ref(), path.as_os_str(), out.as_os_str()]);
        assert_eq!(exit_code(&output), 1);
        let line = format!("fluid-lab: error: {}: {message}\n", path.display());
        assert_eq!(stderr(&output), line);
        assert!(!out.exists());
    }
}

/// Makes a FIFO at `path`.
fn mkfifo(path: &Path) {
    let name = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: mkfifo reads a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
}

#[test]
fn a_fifo_given_as_a_csv_to_read_or_an_output_to_write_is_refused_at_once() {
    // Issue 47, third hostile pass: chart, accuracy --from-csv and sweep --resume waited
    // for ever on a FIFO no program wrote or read.
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("ff.csv");
    mkfifo(&fifo);
    let fifo_name = fifo.to_str().unwrap();
    let out = dir.path().join("o").to_str().unwrap().to_string();
    let small = input("small");
    let small = small.to_str().unwrap();
    let tries: [(Vec<&str>, String); 3] = [
        (
            vec!["chart", fifo_name],
            format!("fluid-lab: error: cannot read {fifo_name}: not a regular file"),
        ),
        (
            vec![
                "accuracy",
                small,
                "--from-csv",
                fifo_name,
                "--output-dir",
                &out,
            ],
            format!("fluid-lab: error: cannot read {fifo_name}: not a regular file"),
        ),
        (
            vec![
                "sweep",
                small,
                "--output",
                fifo_name,
                "--resume",
                "--iterations",
                "1",
                "--repeats",
                "1",
                "--idle-seconds",
                "0",
            ],
            format!("fluid-lab: error: Cannot open {fifo_name} for writing"),
        ),
    ];
    for (args, message) in tries {
        let started = Instant::now();
        let output = run_lab(&args);
        assert!(started.elapsed() < Duration::from_secs(20), "{args:?}");
        assert_eq!(exit_code(&output), 1, "{args:?}: {}", stderr(&output));
        assert!(stderr(&output).starts_with(&message), "{}", stderr(&output));
        assert_eq!(entries(dir.path()), ["ff.csv"], "{args:?}");
    }
}

#[test]
fn an_export_of_a_state_beyond_f32_is_an_error_not_an_infinity() {
    // Issue 47, third hostile pass: export wrote `inf` and exited 0 where run refuses. On
    // the course model, which may leave the box (the others' runs blow up at step 1).
    let dir = tempfile::tempdir().unwrap();
    let far = dir.path().join("far.fld");
    let at = |x: f32| [x, -x, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    fld(&far, 204.0, &[at(3e38), at(1e-3)]);
    for format in ["vtk", "csv", "vtp"] {
        let frames = dir.path().join("frames");
        let output = run_lab(&[
            "export".as_ref(),
            far.as_os_str(),
            frames.as_os_str(),
            "--steps".as_ref(),
            "1".as_ref(),
            "--format".as_ref(),
            format.as_ref(),
        ]);
        assert_eq!(exit_code(&output), 1, "{format}: {}", stderr(&output));
        let message = stderr(&output);
        assert!(
            message.starts_with(&format!(
                "fluid-lab: error: cannot write {}/far_000001.",
                frames.display()
            )) && message.ends_with(", beyond what the frame's f32 values hold\n"),
            "{message}"
        );
        assert_eq!(entries(dir.path()), ["far.fld"], "{format}");
    }
}

#[test]
fn a_render_never_draws_over_its_input() {
    // Issue 47, third hostile pass: `render st.png st.png` replaced the input with its
    // picture, and so did a series' first frame named as the input.
    let dir = tempfile::tempdir().unwrap();
    let original = std::fs::read(input("small")).unwrap();
    for (input_name, output_name, every) in [
        ("st.png", "st.png", None),
        ("st.gif", "st.gif", None),
        ("st_000000.png", "st.png", Some("1")),
    ] {
        let input_path = dir.path().join(input_name);
        std::fs::write(&input_path, &original).unwrap();
        let output_path = dir.path().join(output_name);
        let mut args: Vec<&OsStr> = vec![
            "render".as_ref(),
            input_path.as_os_str(),
            output_path.as_os_str(),
            "--steps".as_ref(),
            "1".as_ref(),
        ];
        if let Some(every) = every {
            args.extend([OsStr::new("--every"), OsStr::new(every)]);
        }
        let output = run_lab(&args);
        assert_refused(
            &output,
            2,
            &format!(
                "fluid-lab: error: {}: the picture would replace the input {}: give it a file \
                 of its own",
                output_path.display(),
                input_path.display()
            ),
        );
        assert_eq!(
            std::fs::read(&input_path).unwrap(),
            original,
            "{input_name}"
        );
        std::fs::remove_file(&input_path).unwrap();
        assert!(entries(dir.path()).is_empty());
    }
    // A series beside an input of another name draws.
    let other = dir.path().join("other_000000.png");
    std::fs::write(&other, &original).unwrap();
    let output = run_lab(&[
        "render".as_ref(),
        other.as_os_str(),
        dir.path().join("st.png").as_os_str(),
        "--steps".as_ref(),
        "0".as_ref(),
        "--every".as_ref(),
        "1".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert_eq!(std::fs::read(&other).unwrap(), original);
}

#[test]
fn a_file_name_with_a_newline_is_shown_on_one_line() {
    // Issue 47, third hostile pass: names from the command line were echoed raw, so the
    // error ran over two lines.
    let dir = tempfile::tempdir().unwrap();
    let odd = dir.path().join("x\ny.fld");
    let out = dir.path().join("o.fld");
    let output = run_lab(&["run".as_ref(), odd.as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 1);
    let message = stderr(&output);
    assert_eq!(message.lines().count(), 1, "{message}");
    assert!(message.contains("x\\ny.fld"), "{message}");
}

#[test]
fn a_sweep_names_its_input_when_the_input_is_at_fault() {
    // Issue 47, third hostile pass: a truncated input was blamed on the CSV resumed
    // (`--resume: s.csv: ...`), or named no file at all.
    let dir = tempfile::tempdir().unwrap();
    let short = dir.path().join("short.fld");
    let mut bytes = std::fs::read(input("small")).unwrap();
    bytes.truncate(100);
    std::fs::write(&short, bytes).unwrap();
    let csv = dir.path().join("s.csv");
    std::fs::write(&csv, "x").unwrap();
    for resume in [true, false] {
        let mut args: Vec<&OsStr> = vec![
            "sweep".as_ref(),
            short.as_os_str(),
            "--output".as_ref(),
            csv.as_os_str(),
            "--iterations".as_ref(),
            "1".as_ref(),
            "--repeats".as_ref(),
            "1".as_ref(),
        ];
        if resume {
            args.push("--resume".as_ref());
        }
        let output = run_lab(&args);
        assert_refused(
            &output,
            1,
            &format!(
                "fluid-lab: error: {}: Number of particles mismatch. Header: 4800, Found: 2.",
                short.display()
            ),
        );
        assert_eq!(std::fs::read_to_string(&csv).unwrap(), "x");
    }
}

#[test]
fn a_disk_too_full_for_the_stability_map_leaves_no_csv() {
    // Issue 47, third hostile pass: stability wrote its CSV and then failed on the map,
    // leaving the CSV of a command that failed. The output folder is a 64 KiB tmpfs in a
    // mount namespace of the run's own (`unshare`).
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("map");
    std::fs::create_dir(&folder).unwrap();
    let stability = [
        "stability",
        "--output-dir",
        folder.to_str().unwrap(),
        "--ppms",
        "100",
        "--dt-factors",
        "1",
        "--adaptive",
        "",
        "--duration",
        "0.002",
    ];
    let Some(output) = on_a_full_disk(&folder, &stability) else {
        return;
    };
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    // The system's words, not plotters' debug text of the error inside its wrappers.
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {}: No space left on device\n",
            folder.join("stability-map.png").display()
        )
    );
    // Nothing but the folder's own entries: no CSV, no temporary file.
    assert!(stdout(&output).ends_with(".\n..\n"), "{}", stdout(&output));
    // A picture too large for the disk says so, naming it, and leaves nothing.
    for picture in ["x.png", "x.gif"] {
        let path = folder.join(picture);
        let small = input("small");
        let render = [
            "render",
            small.to_str().unwrap(),
            path.to_str().unwrap(),
            "--steps",
            "2",
        ];
        let output = on_a_full_disk(&folder, &render).expect("a mount namespace");
        assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
        assert_eq!(
            stderr(&output),
            format!(
                "fluid-lab: error: {}: No space left on device\n",
                path.display()
            )
        );
        assert!(stdout(&output).ends_with(".\n..\n"), "{}", stdout(&output));
    }
}

/// `fluid-lab ARGS` with `folder` a 64 KiB tmpfs in a mount namespace of the run's own
/// (`unshare -rm`), its entries listed on stdout after the run's; `None` (said) where
/// this machine makes no mount namespace.
fn on_a_full_disk(folder: &Path, args: &[&str]) -> Option<std::process::Output> {
    let namespaces = Command::new("unshare").args(["-rm", "true"]).status();
    if !namespaces.is_ok_and(|status| status.success()) {
        eprintln!("skipped: no mount namespace here (unshare -rm)");
        return None;
    }
    let script = "folder=$1; shift; mount -t tmpfs -o size=64k none \"$folder\" && \"$@\"; \
                  status=$?; ls -a \"$folder\"; exit $status";
    let output = Command::new("unshare")
        .args(["-rm", "sh", "-c", script, "sh"])
        .arg(folder)
        .arg(env!("CARGO_BIN_EXE_fluid-lab"))
        .args(args)
        .output()
        .unwrap();
    Some(output)
}

#[test]
fn quiet_silences_a_sweep_s_lines() {
    // Issue 47, third hostile pass: `--quiet` left a sweep's line per record on stderr.
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    let small = input("small");
    let sweep = |quiet: bool| {
        let mut args: Vec<&OsStr> = Vec::new();
        if quiet {
            args.push("--quiet".as_ref());
        }
        args.extend::<[&OsStr; 10]>([
            "sweep".as_ref(),
            small.as_os_str(),
            "--output".as_ref(),
            csv.as_os_str(),
            "--iterations".as_ref(),
            "1".as_ref(),
            "--repeats".as_ref(),
            "1".as_ref(),
            "--idle-seconds".as_ref(),
            "0".as_ref(),
        ]);
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        stderr(&output)
    };
    assert!(sweep(false).contains("repeat 1: "));
    assert_eq!(sweep(true), "");
}

#[test]
fn an_os_error_is_said_in_the_system_s_words_without_its_code() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.bin");
    let output = run_lab(&[
        "run".as_ref(),
        "--resume".as_ref(),
        missing.as_os_str(),
        dir.path().join("out.fld").as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: cannot read {}: No such file or directory\n",
            missing.display()
        )
    );
}

#[test]
fn no_output_replaces_what_its_command_reads_whatever_its_name() {
    // Issue 47, ninth hostile pass: an input or case named as one of the command's own
    // outputs (a .pvd, gauges.csv, still-water.csv, accuracy.csv, a sweep's CSV, a chart)
    // was written over, exit 0.
    let dir = tempfile::tempdir().unwrap();
    let small = std::fs::read(input("small")).unwrap();
    let tank = "[fluid]\nparticles_per_m = 100\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\n\
                max_m = [0.065, 0.02, 0.065]\n[model]\nname = \"wcsph\"\n[run]\nuntil_s = 0.15\n";
    let gauged = "[fluid]\nparticles_per_m = 100\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\n\
                  max_m = [-0.03, -0.05, -0.03]\n[model]\nname = \"wcsph\"\n[run]\nsteps = 2\n\
                  [output]\nfolder = \"FOLDER\"\n[gauges]\ninterval_s = 0.001\n\
                  [[gauges.point]]\nname = \"p\"\nat_m = [-0.05, -0.07, -0.05]\n";
    // A sweep's CSV of one run, to chart.
    let measured = dir.path().join("measured.csv");
    let small_path = input("small");
    let output = run_lab(&[
        "sweep".as_ref(),
        "--iterations".as_ref(),
        "0".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
        "--idle-seconds".as_ref(),
        "0".as_ref(),
        "--output".as_ref(),
        measured.as_os_str(),
        "--".as_ref(),
        small_path.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let sweep_csv = std::fs::read(&measured).unwrap();
    let cases: [(&str, &[u8], &[&str]); 5] = [
        (
            "a.pvd",
            &small,
            &["export", "IN", "FOLDER", "--format", "vtp", "--steps", "0"],
        ),
        ("gauges.csv", gauged.as_bytes(), &["run", "--case", "IN"]),
        (
            "still-water.csv",
            tank.as_bytes(),
            &[
                "validate",
                "still-water",
                "--case",
                "IN",
                "--output-dir",
                "FOLDER",
            ],
        ),
        (
            "accuracy.csv",
            &small,
            &[
                "accuracy",
                "IN",
                "--output-dir",
                "FOLDER",
                "--kernels",
                "simd",
                "--dt-factors",
                "1",
                "--adaptive",
                "",
                "--integrators",
                "leapfrog",
                "--times",
                "0.001",
            ],
        ),
        (
            "time.png",
            &sweep_csv,
            &["chart", "IN", "--output-dir", "FOLDER"],
        ),
    ];
    for (name, content, args) in cases {
        let folder = dir.path().join(name.replace('.', "-"));
        std::fs::create_dir(&folder).unwrap();
        let path = folder.join(name);
        // A case names the folder its gauges write to; an input is left as it is.
        let content = match std::str::from_utf8(content) {
            Ok(text) => text
                .replace("FOLDER", &folder.display().to_string())
                .into_bytes(),
            Err(_) => content.to_vec(),
        };
        std::fs::write(&path, &content).unwrap();
        let args: Vec<String> = (args.iter())
            .map(|arg| {
                arg.replace("IN", &path.display().to_string())
                    .replace("FOLDER", &folder.display().to_string())
            })
            .collect();
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 1, "{name}: {}", stderr(&output));
        assert_eq!(
            stderr(&output).lines().last().unwrap(),
            format!(
                "fluid-lab: error: Cannot write {}: this command reads it: give its outputs a \
                 place of their own.",
                path.display()
            ),
            "{name}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), content, "{name}");
        assert_eq!(entries(&folder), [name], "{name}");
    }
}

#[test]
fn refusals_of_the_ninth_hostile_pass() {
    // Issue 47, ninth hostile pass: each of these ran and exited 0 on a meaningless result.
    let dir = tempfile::tempdir().unwrap();
    let (small, large) = (input("small"), input("large"));
    // An ensemble of another scene's states (the table said "within: yes"); its first
    // member a copy of the state judged.
    let copy = dir.path().join("copy.fld");
    std::fs::copy(&small, &copy).unwrap();
    let output = run_lab(&[
        "chaos".as_ref(),
        "check".as_ref(),
        small.as_os_str(),
        copy.as_os_str(),
        large.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {} holds 15138 particles where {} holds 4800: an ensemble is \
             of runs of one input\n",
            large.display(),
            small.display()
        )
    );
    assert_eq!(stdout(&output), "");
    // A colour range whose width overflows (the bar read inf and NaN), or is subnormal.
    for range in ["-1e308,1e308", "0,1e-320"] {
        let picture = dir.path().join("p.png");
        let output = run_lab(&[
            "render".as_ref(),
            small.as_os_str(),
            picture.as_os_str(),
            "--steps".as_ref(),
            "0".as_ref(),
            format!("--range={range}").as_ref(),
        ]);
        assert_eq!(exit_code(&output), 2, "{range}: {}", stderr(&output));
        assert!(
            stderr(&output).contains(&format!(
                "{range}: HIGH - LOW must be a finite width of at least 2.2250738585072014e-308"
            )),
            "{}",
            stderr(&output)
        );
        assert!(!picture.exists());
    }
    // A fixed step past the first time asked (its error at 10 s was charted as at 2 ms,
    // after a reference run to 10 s).
    let folder = dir.path().join("acc");
    let output = run_lab(&[
        "accuracy".as_ref(),
        small.as_os_str(),
        "--output-dir".as_ref(),
        folder.as_os_str(),
        "--kernels".as_ref(),
        "simd".as_ref(),
        "--dt-factors".as_ref(),
        "1,10000".as_ref(),
        "--adaptive".as_ref(),
        "".as_ref(),
        "--times".as_ref(),
        "0.002,0.004".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 2, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        "fluid-lab: error: a fixed step of 10 s passes the first of --times, 0.002 s: each \
         method samples every time (shorten --dt-factors or give later times)\n"
    );
    assert!(!folder.exists());
    // A truncated input named, as run names it (compare and chaos check did not).
    let truncated = dir.path().join("trunc.fld");
    std::fs::write(&truncated, &std::fs::read(&small).unwrap()[..100]).unwrap();
    let (first, second) = (dir.path().join("m1.fld"), dir.path().join("m2.fld"));
    std::fs::copy(&truncated, &first).unwrap();
    std::fs::copy(&truncated, &second).unwrap();
    let (first, second) = (first.to_str().unwrap(), second.to_str().unwrap());
    let said = format!(
        "fluid-lab: error: {}: Number of particles mismatch. Header: 4800, Found: 2.",
        truncated.display()
    );
    let shown = truncated.to_str().unwrap();
    for args in [
        vec!["compare", shown, shown],
        vec!["chaos", "check", shown, first, second],
        vec!["run", shown],
    ] {
        assert_refused(&run_lab(&args), 1, &said);
    }
}

#[test]
fn a_full_standard_output_is_named_and_loses_no_output_file() {
    // Issue 47, ninth hostile pass: `run ... > /dev/full` said "No space left on device" as
    // if the disk were full, and did not write its final state.
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state.fld");
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_fluid-lab"))
        .args([
            "run".as_ref(),
            input("small").as_os_str(),
            state.as_os_str(),
        ])
        .args(["--model", "fluidanimate", "--steps", "1"])
        .stdout(full)
        .output()
        .unwrap();
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        "fluid-lab: error: cannot write to standard output: No space left on device\n"
    );
    assert_eq!(std::fs::read(&state).unwrap().len(), 8 + 36 * 4800);
}

#[test]
fn refusals_of_the_tenth_hostile_pass() {
    // Issue 47, tenth hostile pass.
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let small = small.to_str().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let (out, case) = (at("out"), at("g.toml"));
    let (frames, acc, named) = (at("dangling/frames"), at("acc"), at("acc/error-time.svg"));
    let gauged = |at_m: &str| {
        format!(
            "[fluid]\nparticles_per_m = 100\n[[fluid.box]]\nmin_m = [-0.065, -0.08, -0.065]\n\
             max_m = [-0.03, -0.05, -0.03]\n[output]\nfolder = \"{out}\"\n[gauges]\n\
             interval_s = 0.01\n[[gauges.point]]\nname = \"p\"\nat_m = {at_m}\n"
        )
    };
    let refused: [(&str, Vec<&str>, String); 8] = [
        // A reference step past the first time (its CSV held inf, exit 0).
        (
            "",
            vec![
                "accuracy",
                small,
                "--output-dir",
                &out,
                "--dt-factors",
                "0.5",
                "--adaptive",
                "",
                "--times",
                "0.001",
                "--reference-dt",
                "1",
            ],
            "--reference-dt 1 passes the first of --times, 0.001 s: the reference is the \
             finest run of the sweep"
                .into(),
        ),
        // Rust's parse errors (cannot parse float from empty string; invalid digit).
        (
            "",
            vec!["accuracy", small, "--output-dir", &out, "--times", ""],
            "invalid value '' for '--times <TIMES>...': '' is not a number".into(),
        ),
        (
            "",
            vec!["scene", "random-cloud", &out, "--particles", "-1"],
            "invalid value '-1' for '--particles <PARTICLES>': -1 is not a whole number from 0 \
             to 18446744073709551615"
                .into(),
        ),
        // A fixed step longer than the run (its CSV showed a 300-digit step, exit 0).
        (
            "",
            vec![
                "stability",
                "--models",
                "fluidanimate",
                "--ppms",
                "60",
                "--adaptive",
                "",
                "--dt-factors",
                "1e300",
                "--duration",
                "0.005",
                "--output-dir",
                &out,
            ],
            "--dt-factors: a step of 1e+297 s is longer than --duration 0.005 s".into(),
        ),
        // A gauge outside, or not a point: its at_m named (it said "outside" for NaN).
        (
            "[0.07, 0.0, 0.0]",
            vec!["run", "--case", &case],
            format!("{case}:10:1: a point gauge's at_m = [0.07, 0, 0] is outside the domain"),
        ),
        (
            "[nan, 0.0, 0.0]",
            vec!["run", "--case", &case],
            format!(
                "{case}:10:1: a point gauge's at_m = [NaN, 0, 0] is not a point (its numbers \
                 must be finite)"
            ),
        ),
        // A symbolic link that leads nowhere, as a folder ("File exists").
        (
            "",
            vec!["export", small, &frames, "--steps", "0"],
            format!(
                "cannot use {} as a folder: {} is a symbolic link that leads to no file",
                frames,
                at("dangling")
            ),
        ),
        // An accuracy case named as one of its charts: refused before anything runs
        // (the sweep ran and left its CSV and first charts).
        (
            "",
            vec![
                "accuracy",
                "--case",
                &named,
                "--output-dir",
                &acc,
                "--dt-factors",
                "0.5",
                "--adaptive",
                "",
                "--times",
                "0.001",
            ],
            format!(
                "Cannot write {}: this command reads it: give its outputs a place of their own.",
                named
            ),
        ),
    ];
    std::os::unix::fs::symlink(dir.path().join("nowhere"), dir.path().join("dangling")).unwrap();
    std::fs::create_dir(dir.path().join("acc")).unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/still-water-2d.toml");
    let tank = std::fs::read_to_string(shipped)
        .unwrap()
        .replace("until_s = 2.0", "until_s = 0.01");
    std::fs::write(dir.path().join("acc/error-time.svg"), &tank).unwrap();
    for (at_m, args, message) in refused {
        if !at_m.is_empty() {
            std::fs::write(&case, gauged(at_m)).unwrap();
        }
        let output = run_lab(&args);
        assert_ne!(exit_code(&output), 0, "{args:?}");
        assert_eq!(
            stderr(&output),
            format!("fluid-lab: error: {message}\n"),
            "{args:?}"
        );
        assert!(!Path::new(&out).exists(), "{args:?}");
    }
    let mut left = entries(&dir.path().join("acc"));
    left.sort();
    assert_eq!(left, ["error-time.svg"]);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("acc/error-time.svg")).unwrap(),
        tank
    );
    // A smoothing too wide for the box, said at the flag or key that set it (it blamed
    // particles_per_m, or the input file).
    let case_2d = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dam-break-2d.toml");
    let wide = at("wide.toml");
    let text = std::fs::read_to_string(&case_2d).unwrap();
    let text = text.replace(
        "name = \"wcsph\"",
        "name = \"wcsph\"\nsmoothing_spacings = 20",
    );
    std::fs::write(&wide, &text).unwrap();
    let line = text
        .lines()
        .position(|l| l.starts_with("smoothing_spacings"))
        .unwrap()
        + 1;
    let no_grid = "the water model's cut-off at h = 20 spacings leaves the box no grid (";
    for (args, at_start) in [
        (
            vec![
                "run",
                "--case",
                case_2d.to_str().unwrap(),
                "--smoothing",
                "20",
            ],
            "--smoothing 20: ".to_string(),
        ),
        (
            vec!["run", small, "--model", "wcsph", "--smoothing", "20"],
            "--smoothing 20: ".to_string(),
        ),
        (
            vec!["run", "--case", &wide],
            format!("{wide}:{line}:22: smoothing_spacings = 20: "),
        ),
    ] {
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 2, "{args:?}: {}", stderr(&output));
        let said = format!("fluid-lab: error: {at_start}{no_grid}");
        assert!(
            stderr(&output).starts_with(&said),
            "{said}\n{}",
            stderr(&output)
        );
    }
    // A file of no particles named, as run names it.
    let zero = at("zero.fld");
    std::fs::write(&zero, [0, 0, 0x4c, 0x43, 0, 0, 0, 0]).unwrap();
    for args in [
        vec!["chaos", "perturb", &zero, &out],
        vec!["accuracy", &zero, "--output-dir", &out],
    ] {
        let said = format!("fluid-lab: error: {zero}: Invalid number of particles: 0.");
        assert_refused(&run_lab(&args), 1, &said);
        assert!(!Path::new(&out).exists(), "{args:?}");
    }
}

#[test]
fn refusals_of_the_eleventh_hostile_pass() {
    // Issue 47, eleventh hostile pass.
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let small = input("small");
    let small = small.to_str().unwrap();
    // A validation's case named as one of its charts: refused before the run (its CSVs
    // were written, then it failed).
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/still-water-2d.toml");
    std::fs::create_dir(dir.path().join("vs")).unwrap();
    let named = at("vs/still-water.png");
    let tank = std::fs::read_to_string(shipped).unwrap();
    std::fs::write(&named, &tank).unwrap();
    let vs = at("vs");
    let args = [
        "validate",
        "still-water",
        "--case",
        &named,
        "--output-dir",
        &vs,
    ];
    let said = format!(
        "fluid-lab: error: Cannot write {named}: this command reads it: give its outputs a \
         place of their own."
    );
    assert_refused(&run_lab(&args), 1, &said);
    assert_eq!(entries(&dir.path().join("vs")), ["still-water.png"]);
    assert_eq!(std::fs::read_to_string(&named).unwrap(), tank);
    // A particle that starts outside the box of a model that keeps its fluid in (it was
    // called a blow-up at step 1, "a shorter time step may").
    let mut bytes = std::fs::read(small).unwrap();
    bytes[8..12].copy_from_slice(&0.5f32.to_le_bytes());
    let outx = at("outx.fld");
    std::fs::write(&outx, &bytes).unwrap();
    let out = at("out");
    let refused: [(Vec<&str>, i32, String); 7] = [
        (
            vec!["run", &outx, "--model", "fluidanimate", "--steps", "2"],
            1,
            format!(
                "{outx}: 1 particle starts more than h outside the box, which the fluidanimate \
                 model keeps its fluid in"
            ),
        ),
        // A state judged against itself, a member twice (it could not fail).
        (
            vec!["chaos", "check", small, small, &outx],
            2,
            format!(
                "{small} and {small} are one file: the state judged and each member of its \
                 ensemble are files of their own"
            ),
        ),
        // Values named twice (run twice, or measured twice under one key).
        (
            vec![
                "validate",
                "dam-break",
                "--ppms",
                "100,100.0",
                "--output-dir",
                &out,
            ],
            2,
            "--ppms names each value once".into(),
        ),
        (
            vec![
                "validate",
                "dam-break",
                "--models",
                "wcsph,wcsph",
                "--output-dir",
                &out,
            ],
            2,
            "--models names each value once".into(),
        ),
        (
            vec![
                "sweep",
                "--iterations",
                "0,0",
                "--output",
                &out,
                "--",
                small,
            ],
            2,
            "--iterations names each value once".into(),
        ),
        // A water setting out of range at its flag (it named --model), not a number said so.
        (
            vec!["run", small, "--model", "wcsph", "--sound-speed", "5000"],
            2,
            "--sound-speed: its sound speed factor must be between 1 and 1000".into(),
        ),
        (
            vec!["run", small, "--model", "wcsph", "--smoothing", "abc"],
            2,
            "invalid value 'abc' for '--smoothing <SPACINGS>': 'abc' is not a number".into(),
        ),
    ];
    for (args, code, message) in refused {
        assert_refused(
            &run_lab(&args),
            code,
            &format!("fluid-lab: error: {message}"),
        );
        assert!(!Path::new(&out).exists(), "{args:?}");
    }
}

#[test]
fn refusals_of_the_twelfth_hostile_pass() {
    // Issue 47, twelfth hostile pass: each of these wrote or measured and exited 0.
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let small = input("small");
    let small = small.to_str().unwrap();
    // A side file that is a symbolic link to the output, not there yet: the diagnostics
    // were written over the final state.
    let (state, linked) = (at("o3.fld"), at("dg.csv"));
    std::os::unix::fs::symlink("o3.fld", &linked).unwrap();
    let output = run_lab(&[
        "run",
        small,
        &state,
        "--model",
        "fluidanimate",
        "--steps",
        "3",
        "--diagnostics",
        &linked,
    ]);
    let said = format!(
        "fluid-lab: error: --diagnostics {linked} is also the output {state}: give it a file \
         of its own"
    );
    assert_refused(&output, 2, &said);
    assert!(!Path::new(&state).exists());
    // An ensemble member at another resolution (its statistics widened the range).
    let mut bytes = std::fs::read(small).unwrap();
    bytes[..4].copy_from_slice(&999f32.to_le_bytes());
    let (member, other) = (at("m.fld"), at("ppm999.fld"));
    std::fs::copy(small, &member).unwrap();
    std::fs::write(&other, &bytes).unwrap();
    let said = format!(
        "fluid-lab: error: {other} is at 999 particles per metre where {small} is at 204: an \
         ensemble is of runs of one input"
    );
    assert_refused(
        &run_lab(&["chaos", "check", small, &member, &other]),
        1,
        &said,
    );
    // One input under two names, measured as two.
    let alias = at("alias.fld");
    std::os::unix::fs::symlink(small, &alias).unwrap();
    let csv = at("sweep.csv");
    let args = [
        "sweep",
        "--iterations",
        "0",
        "--output",
        &csv,
        "--",
        small,
        &alias,
    ];
    let said = format!("fluid-lab: error: {small} and {alias} are one file: give each input once");
    assert_refused(&run_lab(&args), 2, &said);
    assert!(!Path::new(&csv).exists());
}
