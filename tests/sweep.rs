//! `fluid-lab sweep` and `fluid-lab chart` on the real binaries: a short sweep writes one
//! CSV row per run and idle window, honest about energy, and charts it; failures stop the
//! sweep with a clear message and leave no CSV.

mod common;

use common::{exit_code, input, run_lab, stderr, stdout};
use fluid::lab::sweep::COLUMNS;
use std::path::Path;

fn column(name: &str) -> usize {
    COLUMNS.iter().position(|c| *c == name).unwrap()
}

fn number(row: &csv::StringRecord, name: &str) -> f64 {
    row[column(name)]
        .parse()
        .unwrap_or_else(|_| panic!("{name}: {:?}", &row[column(name)]))
}

#[test]
fn a_short_sweep_writes_every_run_and_idle_window_and_charts_them() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let output = run_lab(&[
        "sweep".as_ref(),
        "--program".as_ref(),
        env!("CARGO_BIN_EXE_fluid").as_ref(),
        "--iterations".as_ref(),
        "0,3".as_ref(),
        "--repeats".as_ref(),
        "2".as_ref(),
        "--idle-seconds".as_ref(),
        "0.05".as_ref(),
        "--output".as_ref(),
        csv_path.as_os_str(),
        input("small").as_os_str(),
        input("large").as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    assert_eq!(
        stdout(&output),
        format!("wrote {} (10 rows)\n", csv_path.display())
    );
    let log = stderr(&output);
    assert!(log.starts_with("time: wall: monotonic clock"), "{log}");
    let energy_line = log.lines().nth(1).unwrap();
    assert!(energy_line.starts_with("energy: "), "{log}");

    let mut reader = csv::Reader::from_path(&csv_path).unwrap();
    assert_eq!(
        reader.headers().unwrap(),
        &csv::StringRecord::from(&COLUMNS[..])
    );
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    let kinds: Vec<&str> = rows.iter().map(|row| &row[column("kind")]).collect();
    assert_eq!(
        kinds,
        ["idle", "idle", "run", "run", "run", "run", "run", "run", "run", "run"]
    );
    let points: Vec<(String, String, String)> = rows[2..]
        .iter()
        .map(|row| {
            (
                row[column("input")].to_string(),
                row[column("iterations")].to_string(),
                row[column("repeat")].to_string(),
            )
        })
        .collect();
    let expected: Vec<(String, String, String)> = ["1", "2"]
        .iter()
        .flat_map(|repeat| {
            ["small.fld", "large.fld"].iter().flat_map(move |name| {
                ["0", "3"].map(|n| (name.to_string(), n.to_string(), repeat.to_string()))
            })
        })
        .collect();
    assert_eq!(points, expected);
    for row in &rows[..2] {
        assert!(number(row, "wall_s") >= 0.05);
        assert_eq!(&row[column("max_rss_kib")], "");
    }
    for row in &rows[2..] {
        let particles = if &row[column("input")] == "small.fld" {
            4800.0
        } else {
            15138.0
        };
        assert_eq!(number(row, "particles"), particles);
        assert!(number(row, "wall_s") > 0.0);
        assert!(number(row, "user_s") + number(row, "sys_s") > 0.0);
        // The binary maps the input and holds the particles: at least a megabyte.
        assert!(number(row, "max_rss_kib") > 1024.0);
    }
    let method = rows[0][column("energy_method")].to_string();
    for row in &rows {
        assert_eq!(&row[column("energy_method")], method);
        assert_eq!(
            format!("energy: {}", &row[column("energy_detail")]),
            energy_line
        );
        let pkg = &row[column("energy_pkg_j")];
        if method == "none" {
            // Never a made-up or zero energy: the cells are empty, the reason is given.
            assert!(energy_line.starts_with("energy: not available ("));
            for name in COLUMNS
                .iter()
                .filter(|c| c.ends_with("_j") || c.ends_with("_w"))
            {
                assert_eq!(&row[column(name)], "", "{name}");
            }
        } else {
            let joules: f64 = pkg.parse().unwrap();
            assert!(joules > 0.0);
            let watts = number(row, "power_pkg_w");
            assert!((watts * number(row, "wall_s") - joules).abs() <= 1e-3 * joules.max(1.0));
        }
    }

    let charts = dir.path().join("charts");
    std::fs::create_dir(&charts).unwrap();
    let output = run_lab(&[
        "chart".as_ref(),
        csv_path.as_os_str(),
        "--output-dir".as_ref(),
        charts.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    for name in ["time", "energy", "power"] {
        for extension in ["png", "svg"] {
            let path = charts.join(format!("{name}.{extension}"));
            assert!(stdout(&output).contains(&format!("wrote {}\n", path.display())));
            assert!(
                std::fs::metadata(&path).unwrap().len() > 1000,
                "{}",
                path.display()
            );
        }
    }
    let energy_svg = std::fs::read_to_string(charts.join("energy.svg")).unwrap();
    assert_eq!(
        energy_svg.contains("energy not measured on this machine"),
        method == "none"
    );
}

fn sweep_with(program: &str, inputs: &[&Path], csv_path: &Path) -> std::process::Output {
    let mut args = vec![
        "sweep".as_ref(),
        "--program".as_ref(),
        program.as_ref(),
        "--iterations".as_ref(),
        "0".as_ref(),
        "--repeats".as_ref(),
        "1".as_ref(),
        "--idle-seconds".as_ref(),
        "0".as_ref(),
        "--output".as_ref(),
        csv_path.as_os_str(),
    ];
    args.extend(inputs.iter().map(|path| path.as_os_str()));
    run_lab(&args)
}

#[test]
fn a_failing_run_names_its_command_and_keeps_the_idle_window_measured_before() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let small = input("small");
    // The warm-up run fails, after the idle window.
    let output = sweep_with("/bin/false", &[&small], &csv_path);
    assert_eq!(exit_code(&output), 1);
    let expected = format!(
        "fluid-lab: error: /bin/false 0 {} /dev/null failed (exit status: 1); \
         the 1 row measured is in {}, and --resume goes on from it\n",
        small.display(),
        csv_path.display()
    );
    assert!(stderr(&output).ends_with(&expected), "{}", stderr(&output));
    let kept = std::fs::read_to_string(&csv_path).unwrap();
    assert_eq!(kept.lines().count(), 2, "{kept}");
    assert!(
        kept.lines().nth(1).unwrap().starts_with("idle,,,,1,"),
        "{kept}"
    );
}

/// A program that runs `fluid`, or fails with "broken" (the last of two lines) when run for
/// `fail` iterations.
fn flaky_fluid(dir: &Path, fail: &str) -> std::path::PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let script = dir.join("flaky.sh");
    let text = format!(
        "#!/bin/sh\nif [ \"$1\" = \"{fail}\" ]; then echo starting >&2; echo broken >&2; exit 3; fi\nexec {} \"$@\"\n",
        env!("CARGO_BIN_EXE_fluid")
    );
    std::fs::write(&script, text).unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    script
}

#[test]
fn a_failed_point_keeps_the_rows_measured_and_resume_goes_on_from_them() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let small = input("small");
    let sweep = |fail: &str, resume: bool| {
        let program = flaky_fluid(dir.path(), fail);
        let mut args: Vec<&std::ffi::OsStr> = [
            "sweep",
            "--iterations",
            "0",
            "2",
            "--repeats",
            "2",
            "--idle-seconds",
            "0",
            "--output",
        ]
        .iter()
        .map(|a| a.as_ref())
        .collect();
        args.push(csv_path.as_os_str());
        args.extend(["--program".as_ref(), program.as_os_str()]);
        if resume {
            args.push("--resume".as_ref());
        }
        args.extend(["--".as_ref(), small.as_os_str()]);
        run_lab(&args)
    };
    let failed = sweep("2", false);
    assert_eq!(exit_code(&failed), 1);
    let message = stderr(&failed);
    assert!(
        message.contains("2 ")
            && message
                .contains("failed (exit status: 3): broken (the last of 2 lines on its stderr)"),
        "{message}"
    );
    // The error is one line, the last (the progress lines come before it).
    let last = message.lines().last().unwrap();
    assert!(
        last.starts_with("fluid-lab: error: ") && last.contains("broken (the last"),
        "{message}"
    );
    assert!(
        message.contains("; the 3 rows measured are in "),
        "{message}"
    );
    assert!(
        message.ends_with(", and --resume goes on from them\n"),
        "{message}"
    );
    assert_eq!(
        message
            .lines()
            .last()
            .unwrap()
            .matches("fluid-lab: error:")
            .count(),
        1
    );
    let kept = std::fs::read_to_string(&csv_path).unwrap();
    let rows: Vec<&str> = kept.lines().collect();
    // Header, two idle windows, the 0-iteration run of repeat 1.
    assert_eq!(rows.len(), 4, "{kept}");
    assert!(rows[3].starts_with("run,small.fld,4800,0,1,"), "{kept}");
    let resumed = sweep("never", true);
    assert_eq!(exit_code(&resumed), 0, "{}", stderr(&resumed));
    assert!(
        stdout(&resumed).contains("(6 rows)"),
        "{}",
        stdout(&resumed)
    );
    let full = std::fs::read_to_string(&csv_path).unwrap();
    assert!(full.starts_with(&kept), "the kept rows stay as they were");
    let points: Vec<(String, String)> = full
        .lines()
        .skip(1)
        .map(|line| {
            let cells: Vec<&str> = line.split(',').collect();
            (cells[3].to_string(), cells[4].to_string())
        })
        .collect();
    let expected = [
        ("", "1"),
        ("", "2"),
        ("0", "1"),
        ("2", "1"),
        ("0", "2"),
        ("2", "2"),
    ];
    assert_eq!(points.len(), expected.len(), "{full}");
    for (point, (iterations, repeat)) in points.iter().zip(expected) {
        assert_eq!(
            (point.0.as_str(), point.1.as_str()),
            (iterations, repeat),
            "{full}"
        );
    }
}

#[test]
fn a_resume_of_a_slurm_arrays_merged_csv_points_to_resubmit() {
    // Issue 47, eighth hostile pass: it blamed the CSV's columns.
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let columns = fluid::lab::sweep::COLUMNS.join(",");
    let merged = format!("{columns},{}\n", fluid::lab::slurm::COLUMNS.join(","));
    for (header, said) in [
        (
            merged,
            "it is a Slurm array's merged CSV: the array goes on with fluid-lab slurm resubmit",
        ),
        (
            format!("{columns},extra\n"),
            "its columns are not those of this version's sweep",
        ),
    ] {
        std::fs::write(&csv_path, &header).unwrap();
        let small = input("small");
        let output = run_lab(&[
            "sweep".as_ref(),
            "--iterations".as_ref(),
            "0".as_ref(),
            "--output".as_ref(),
            csv_path.as_os_str(),
            "--resume".as_ref(),
            "--".as_ref(),
            small.as_os_str(),
        ]);
        assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
        assert_eq!(
            stderr(&output),
            format!(
                "fluid-lab: error: --resume: {}: {said}\n",
                csv_path.display()
            )
        );
        assert_eq!(std::fs::read_to_string(&csv_path).unwrap(), header);
    }
}

#[test]
fn a_program_must_be_an_executable_file_and_iterations_what_fluid_takes() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let small = input("small");
    // A bare name is a file here, not a command looked up in PATH (`dir` is one).
    let output = sweep_with("dir", &[&small], &csv_path);
    assert_eq!(exit_code(&output), 1);
    assert_eq!(
        stderr(&output),
        "fluid-lab: error: --program ./dir: no executable file there\n"
    );
    let output = run_lab(&[
        "sweep".as_ref(),
        "--iterations".as_ref(),
        "18446744073709551615".as_ref(),
        "--output".as_ref(),
        csv_path.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 2);
    assert!(
        stderr(&output).contains("18446744073709551615"),
        "{}",
        stderr(&output)
    );
    assert!(!csv_path.exists());
}

#[test]
fn a_bad_input_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let missing = dir.path().join("missing.fld");
    let output = sweep_with(env!("CARGO_BIN_EXE_fluid"), &[&missing], &csv_path);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains(&format!("Cannot open {} for reading", missing.display())),
        "{}",
        stderr(&output)
    );
    assert!(!stderr(&output).contains("idle, repeat"));
    assert!(!csv_path.exists());
}

#[test]
fn charting_a_file_that_is_not_a_sweep_fails_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.csv");
    let output = run_lab(&["chart".as_ref(), missing.as_os_str()]);
    assert_eq!(exit_code(&output), 1);
    assert!(stderr(&output).starts_with(&format!(
        "fluid-lab: error: cannot read {}",
        missing.display()
    )));
    let other = dir.path().join("other.csv");
    std::fs::write(&other, "a,b\n1,2\n").unwrap();
    let output = run_lab(&["chart".as_ref(), other.as_os_str()]);
    assert_eq!(exit_code(&output), 1);
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {}: the sweep CSV has no column kind\n",
            other.display()
        )
    );
}
