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
fn a_failing_run_stops_the_sweep_with_its_command_and_writes_no_csv() {
    let dir = tempfile::tempdir().unwrap();
    let csv_path = dir.path().join("sweep.csv");
    let small = input("small");
    let output = sweep_with("false", &[&small], &csv_path);
    assert_eq!(exit_code(&output), 1);
    let expected = format!(
        "fluid-lab: error: false 0 {} /dev/null failed (exit status: 1): \n",
        small.display()
    );
    assert!(stderr(&output).ends_with(&expected), "{}", stderr(&output));
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
