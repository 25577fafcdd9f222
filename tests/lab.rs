//! The `fluid-lab` workbench: runs with a chosen model and kernel (every f64 kernel
//! reproduces the reference outputs), diagnostics,
//! generated scenes, and clear errors.

mod common;

use common::{exit_code, input, reference_output, run_lab, stderr, stdout};
use fluid::io::fld;
use fluid::Kernel;

#[test]
fn every_f64_kernel_reproduces_every_reference_output() {
    let dir = tempfile::tempdir().unwrap();
    // Every f64 kernel on the tiles, and those with loops on lists on both kinds of
    // lists too.
    let kernels = Kernel::F64.map(|kernel| kernel.name());
    let tiles = kernels.iter().map(|&k| (k, "tiles"));
    let on_lists = Kernel::F64.into_iter().filter(|k| k.runs_on_lanes());
    let listed = on_lists.flat_map(|k| ["lists", "rows"].map(|pairs| (k.name(), pairs)));
    let methods = tiles.chain(listed);
    let runs = methods.flat_map(|(k, pairs)| [(k, pairs, "small"), (k, pairs, "large")]);
    for (kernel, pairs, name) in runs {
        for steps in 1..=5 {
            let out = dir.path().join(format!("{name}-{steps}.fld"));
            let output = run_lab(&[
                "run".as_ref(),
                "--pairs".as_ref(),
                pairs.as_ref(),
                "--kernel".as_ref(),
                kernel.as_ref(),
                "--steps".as_ref(),
                steps.to_string().as_ref(),
                input(name).as_os_str(),
                out.as_os_str(),
            ]);
            assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
            let expected = std::fs::read(reference_output(name, steps)).unwrap();
            assert!(
                std::fs::read(&out).unwrap() == expected,
                "{kernel} on {pairs}: {name}-{steps} differs"
            );
        }
    }
}

#[test]
fn a_run_reports_its_method_and_timing() {
    let small = input("small");
    let output = run_lab(&[
        "run".as_ref(),
        "--model".as_ref(),
        "fluidanimate".as_ref(),
        "--steps".as_ref(),
        "3".as_ref(),
        small.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let report = stdout(&output);
    assert!(
        report.starts_with(&format!(
            "model=fluidanimate kernel={} particles=4800 steps=3 seconds=",
            fluid::Kernel::NATIVE.name()
        )),
        "{report}"
    );
    assert!(report.contains(" ns_per_particle_step="), "{report}");
    assert!(report.contains(" simulated_s=0.003000 "), "{report}");
    // A run of 2.5e-7 s shows it in significant digits.
    let output = run_lab(&[
        "run".as_ref(),
        "--dt".as_ref(),
        "2.5e-7".as_ref(),
        "--steps".as_ref(),
        "1".as_ref(),
        small.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let report = stdout(&output);
    assert!(report.contains(" simulated_s=0.0000002500 "), "{report}");
}

#[test]
fn a_run_logged_to_a_file_prints_progress_lines_unless_quiet() {
    // Stderr is a pipe here, as in a CI or Slurm log: no bar, plain lines at the set
    // interval (0 s: after every step).
    let small = input("small");
    let args = |extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = extra.iter().map(Into::into).collect();
        args.extend(["run", "--steps", "4"].map(Into::into));
        args.push(small.clone().into());
        args
    };
    let output = run_lab(&args(&["--progress-every", "0"]));
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let log = stderr(&output);
    let lines: Vec<&str> = log.lines().collect();
    assert_eq!(lines.len(), 4, "{log}");
    assert!(
        lines[1].starts_with("fluid-lab: progress: step 2 of 4, t = 0.002000 s (50%), "),
        "{log}"
    );
    assert!(lines[1].contains(" steps/s, about "), "{log}");
    assert!(lines[3].ends_with(", about 0 s left"), "{log}");
    // The same run to a physical time gives its goal in seconds.
    let output = run_lab(&[
        "--progress-every",
        "0",
        "run",
        "--until",
        "0.002",
        small.to_str().unwrap(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    assert!(
        stderr(&output).starts_with("fluid-lab: progress: step 1, t = 0.001000 of 0.002 s (50%), "),
        "{}",
        stderr(&output)
    );
    // --quiet, before or after the subcommand: nothing on stderr.
    for quiet in [
        &["--quiet", "--progress-every", "0"][..],
        &["--progress-every", "0"],
    ] {
        let mut args = args(quiet);
        if quiet.len() == 2 {
            args.push("--quiet".into());
        }
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
        assert_eq!(stderr(&output), "");
        assert!(stdout(&output).contains(" steps=4 "), "{}", stdout(&output));
    }
    // By default a line every 10 s: a short run prints none.
    let output = run_lab(&args(&[]));
    assert_eq!(stderr(&output), "");
    let output = run_lab(&args(&["--progress-every", "-1"]));
    assert_eq!(exit_code(&output), 2);
    assert!(
        stderr(&output).contains("-1 is not a number of seconds from 0 to 1e9"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn lists_kept_with_a_skin_give_the_state_of_lists_rebuilt_every_step() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args: Vec<&std::ffi::OsStr> = ["run", "--model", "fluidanimate", "--steps", "20"]
            .iter()
            .map(std::ffi::OsStr::new)
            .collect();
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        args.extend([small.as_os_str(), out.as_os_str()]);
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        let state = fld::parse(&std::fs::read(&out).unwrap(), name).unwrap();
        (stdout(&output), state.particles)
    };
    let (plain, rebuilt) = run("rebuilt.fld", &[]);
    let (report, kept) = run("kept.fld", &["--skin", "0.3"]);
    assert!(!plain.contains("list_builds"), "{plain}");
    let builds: u64 = report
        .split_whitespace()
        .find_map(|field| field.strip_prefix("list_builds="))
        .unwrap()
        .parse()
        .unwrap();
    assert!((1..20).contains(&builds), "{report}");
    for axis in 0..3 {
        for (a, b) in kept.p[axis].iter().zip(&rebuilt.p[axis]) {
            assert!((a - b).abs() < 1e-6, "{a} against {b}");
        }
    }
    let bad = run_lab(&["run", "--skin=-1", small.to_str().unwrap()]);
    assert_eq!(exit_code(&bad), 2);
    assert!(stderr(&bad).contains("-1 is not a skin width (0 or more)"));
    // Too wide for the box: a usage error, the width as given, not in 309 digits.
    let wide = run_lab(&["run", "--skin", "1e308", small.to_str().unwrap()]);
    assert_eq!(exit_code(&wide), 2, "{}", stderr(&wide));
    assert!(
        stderr(&wide).starts_with("fluid-lab: error: --skin 1e308: too wide for the box ("),
        "{}",
        stderr(&wide)
    );
    assert_eq!(stderr(&wide).lines().count(), 1);
}

#[test]
fn an_adaptive_run_reports_every_step_it_took() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("steps.csv");
    let small = input("small");
    let output = run_lab(&[
        "run".as_ref(),
        "--model".as_ref(),
        "fluidanimate".as_ref(),
        "--adaptive".as_ref(),
        "0.3".as_ref(),
        "--steps".as_ref(),
        "20".as_ref(),
        "--diagnostics".as_ref(),
        csv.as_os_str(),
        small.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|&c| c == name).unwrap();
    let (time, dt, limit) = (column("time_s"), column("dt_s"), column("dt_limit"));
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 21);
    assert_eq!((rows[0][dt], rows[0][limit]), ("", ""));
    let mut elapsed = 0.0;
    let mut lengths = Vec::new();
    for row in &rows[1..] {
        let length: f64 = row[dt].parse().unwrap();
        assert!(length > 0.0 && length < 2e-3, "{text}");
        assert!(
            ["force", "speed", "viscosity", "walls"].contains(&row[limit]),
            "{text}"
        );
        elapsed += length;
        lengths.push(length);
        let written: f64 = row[time].parse().unwrap();
        assert!(
            (written - elapsed).abs() < 1e-6,
            "{written} against {elapsed}"
        );
    }
    assert!(lengths.iter().any(|&l| l != lengths[0]), "{lengths:?}");
    let report = stdout(&output);
    assert!(
        report.contains(&format!(" simulated_s={elapsed:.6} ")),
        "{report} against {elapsed}"
    );

    for bad in [
        &["--adaptive", "0"][..],
        &["--adaptive", "1.5"],
        &["--adaptive", "nan"],
        &["--adaptive", "0.3", "--dt", "0.001"],
    ] {
        let mut args: Vec<&std::ffi::OsStr> = vec!["run".as_ref()];
        args.extend(bad.iter().map(|&a| std::ffi::OsStr::new(a)));
        args.push(small.as_os_str());
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 2, "{bad:?}: {}", stderr(&output));
    }
}

#[test]
fn every_generated_scene_reads_back_through_the_fld_reader() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, extra, count) in [
        ("dam-break", None, 10 * 25 * 26),
        ("filled-box", None, 26 * 18 * 26),
        ("drop", None, 0),
        ("random-cloud", Some("3000"), 3000),
        ("corner-block", Some("5000"), 5000),
    ] {
        let out = dir.path().join(format!("{kind}.fld"));
        let mut args = vec![
            "scene",
            kind,
            out.to_str().unwrap(),
            "--ppm",
            "200",
            "--seed",
            "4",
        ];
        if let Some(particles) = extra {
            args.extend(["--particles", particles]);
        }
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 0, "{kind}: {}", stderr(&output));
        let bytes = std::fs::read(&out).unwrap();
        let scene = fld::parse(&bytes, kind).unwrap();
        assert_eq!(scene.ppm, 200.0, "{kind}");
        if count > 0 {
            assert_eq!(scene.particles.len(), count, "{kind}");
        }
        let expected = fluid::lab::scene::generate(
            clap::ValueEnum::from_str(kind, false).unwrap(),
            200.0,
            4,
            extra.map(|n| n.parse().unwrap()),
        )
        .unwrap();
        // The file holds the generated particles, rounded to f32.
        for axis in 0..3 {
            for (read, generated) in scene.particles.p[axis].iter().zip(&expected.p[axis]) {
                assert_eq!(*read, *generated as f32 as f64, "{kind}");
            }
        }
    }
}

#[test]
fn bad_input_and_unknown_choices_fail_clearly() {
    let missing = run_lab(&["run", "no-such-file.fld"]);
    assert_ne!(exit_code(&missing), 0);
    assert!(
        stderr(&missing).starts_with("fluid-lab: error: Cannot open no-such-file.fld"),
        "{}",
        stderr(&missing)
    );
    let unknown = run_lab(&[
        "run".as_ref(),
        "--kernel".as_ref(),
        "avx".as_ref(),
        input("small").as_os_str(),
    ]);
    assert_eq!(exit_code(&unknown), 2);
    assert!(
        stderr(&unknown).contains("possible values: scalar, simd"),
        "{}",
        stderr(&unknown)
    );
}

#[test]
fn diagnostics_follow_the_run_and_a_failing_run_names_its_step() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("diagnostics.csv");
    let small = input("small");
    let output = run_lab(&[
        "run".as_ref(),
        "--steps".as_ref(),
        "4".as_ref(),
        "--every".as_ref(),
        "2".as_ref(),
        "--diagnostics".as_ref(),
        csv.as_os_str(),
        small.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows[0].join(","), fluid::lab::diagnostics::CSV_HEADER);
    let steps: Vec<&str> = rows[1..].iter().map(|row| row[0]).collect();
    assert_eq!(steps, ["0", "2", "4"]);
    // The course model: speeds and energy explode, particles leave the box.
    let number = |row: usize, column: usize| rows[row][column].parse::<f64>().unwrap();
    assert!(number(3, 2) > 100.0 * number(1, 2), "max speed {text}");
    assert!(number(3, 6) > 100.0 * number(1, 6), "total energy {text}");
    assert_eq!(number(1, 3), 0.0);
    assert!(number(3, 3) > 2000.0, "outside {text}");

    // Time step 0.1 s: the course model overflows; no output is written.
    let out = dir.path().join("garbage.fld");
    let output = run_lab(&[
        "run".as_ref(),
        "--dt".as_ref(),
        "0.1".as_ref(),
        "--steps".as_ref(),
        "200".as_ref(),
        small.as_os_str(),
        out.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).starts_with("fluid-lab: error: the run failed at step "),
        "{}",
        stderr(&output)
    );
    assert!(stderr(&output).trim_end().ends_with("is not finite"));
    assert!(!out.exists());
    let output = run_lab(&["run", "--dt=-1", small.to_str().unwrap()]);
    assert_eq!(exit_code(&output), 2);
    assert!(stderr(&output).contains("-1 is not a positive time step"));
}

#[test]
fn compare_reports_errors_per_field_and_refuses_different_sizes() {
    let one = reference_output("small", 1);
    let two = reference_output("small", 2);
    let output = run_lab(&["compare".as_ref(), one.as_os_str(), one.as_os_str()]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert_eq!(
        stdout(&output),
        "field max_error rms_error worst_particle\n\
         p 0.000000e0 0.000000e0 0\nhv 0.000000e0 0.000000e0 0\nv 0.000000e0 0.000000e0 0\n"
    );
    let output = run_lab(&["compare".as_ref(), two.as_os_str(), one.as_os_str()]);
    let report = stdout(&output);
    let rows: Vec<Vec<&str>> = report
        .lines()
        .skip(1)
        .map(|l| l.split(' ').collect())
        .collect();
    let (before, after) = (
        fld::parse(&std::fs::read(&one).unwrap(), "1")
            .unwrap()
            .particles,
        fld::parse(&std::fs::read(&two).unwrap(), "2")
            .unwrap()
            .particles,
    );
    let worst: usize = rows[0][3].parse().unwrap();
    let moved = (0..3)
        .map(|axis| (after.p[axis][worst] - before.p[axis][worst]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert_eq!(rows[0][1], format!("{moved:.6e}"));
    let large = reference_output("large", 1);
    let output = run_lab(&["compare".as_ref(), one.as_os_str(), large.as_os_str()]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).ends_with(": 4800 particles against 15138\n"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn chaos_moves_copies_by_one_ulp_and_judges_a_state_against_their_ensemble() {
    let dir = tempfile::tempdir().unwrap();
    let (small, copies) = (input("small"), dir.path().join("copies"));
    let output = run_lab(&[
        "chaos".as_ref(),
        "perturb".as_ref(),
        small.as_os_str(),
        copies.as_os_str(),
        "--copies".as_ref(),
        "3".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert_eq!(stdout(&output).lines().count(), 4, "{}", stdout(&output));
    let original = std::fs::read(&small).unwrap();
    // The ensemble: 3 steps of fluid on the input and on each copy.
    let mut ensemble = vec![dir.path().join("run.fld")];
    let run = common::run_fluid(&["3".as_ref(), small.as_os_str(), ensemble[0].as_os_str()]);
    assert_eq!(exit_code(&run), 0);
    for k in 0..3 {
        let copy = copies.join(format!("small-ulp{k}.fld"));
        let bytes = std::fs::read(&copy).unwrap();
        let differing = (0..bytes.len())
            .filter(|&b| bytes[b] != original[b])
            .map(|b| b / 4)
            .collect::<std::collections::BTreeSet<_>>();
        assert_eq!(bytes.len(), original.len());
        assert_eq!(differing.len(), 1, "copy {k}");
        ensemble.push(dir.path().join(format!("run-{k}.fld")));
        let run = common::run_fluid(&["3".as_ref(), copy.as_os_str(), ensemble[k + 1].as_os_str()]);
        assert_eq!(exit_code(&run), 0);
    }
    let check = |candidate: &std::path::Path| {
        let mut args = vec!["chaos".as_ref(), "check".as_ref(), candidate.as_os_str()];
        args.extend(ensemble.iter().map(|path| path.as_os_str()));
        run_lab(&args)
    };
    // The reference output after 3 steps is a member's state: within.
    let output = check(&reference_output("small", 3));
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let table = stdout(&output);
    assert_eq!(table.matches("| yes |").count(), 19, "{table}");
    assert!(table.contains("Leave one out: "), "{table}");
    // After 1 step the particles are elsewhere: outside, named, exit 1.
    let output = check(&reference_output("small", 1));
    assert_eq!(exit_code(&output), 1);
    assert!(stdout(&output).contains("**NO**"), "{}", stdout(&output));
    assert!(
        stderr(&output).contains("statistics outside the ensemble of 4: "),
        "{}",
        stderr(&output)
    );
    // An ensemble of one is refused by the command line; a missing input leaves no folder.
    let output = run_lab(&["chaos", "check", "a.fld", "b.fld"]);
    assert_eq!(exit_code(&output), 2);
    let missing = dir.path().join("missing.fld");
    let nowhere = dir.path().join("nowhere");
    let output = run_lab(&[
        "chaos".as_ref(),
        "perturb".as_ref(),
        missing.as_os_str(),
        nowhere.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1);
    assert!(
        stderr(&output).contains("missing.fld"),
        "{}",
        stderr(&output)
    );
    assert!(!nowhere.exists());
    // One particle has 3 coordinates: a fourth copy would repeat one.
    let one = dir.path().join("one.fld");
    let mut particle = fluid::Particles::zeroed(1);
    particle.p[1][0] = 0.01;
    std::fs::write(&one, fld::encode(204.0, &particle).unwrap()).unwrap();
    for (copies, code) in [("3", 0), ("4", 2)] {
        let folder = dir.path().join(format!("one-{copies}"));
        let output = run_lab(&[
            "chaos".as_ref(),
            "perturb".as_ref(),
            one.as_os_str(),
            folder.as_os_str(),
            "--copies".as_ref(),
            copies.as_ref(),
        ]);
        assert_eq!(exit_code(&output), code, "{}", stderr(&output));
        assert_eq!(folder.exists(), code == 0);
    }
    // A FIFO is refused at once, not waited on.
    let fifo = dir.path().join("fifo.fld");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|status| status.success()) {
        let other = dir.path().join("other.fld");
        std::fs::copy(&one, &other).unwrap();
        let output = run_lab(&[
            "chaos".as_ref(),
            "check".as_ref(),
            fifo.as_os_str(),
            one.as_os_str(),
            other.as_os_str(),
        ]);
        assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    }
}

#[test]
fn accuracy_measures_methods_at_equal_times_and_names_the_fastest_within_a_budget() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    // The native kernel (simd, or simd8 on AVX-512), whose default method is then one
    // of the six and not added.
    let kernels = format!("{},mixed", fluid::Kernel::NATIVE.name());
    // The methods (two kernels, three rules, two integrators) and the times.
    let methods: [&std::ffi::OsStr; 12] = [
        "accuracy".as_ref(),
        small.as_os_str(),
        "--kernels".as_ref(),
        kernels.as_ref(),
        "--dt-factors".as_ref(),
        "1,2".as_ref(),
        "--adaptive".as_ref(),
        "0.3".as_ref(),
        "--integrators".as_ref(),
        "leapfrog,verlet".as_ref(),
        "--times".as_ref(),
        "0.002,0.004".as_ref(),
    ];
    let mut args = methods.to_vec();
    args.extend::<[&std::ffi::OsStr; 4]>([
        "--budget".as_ref(),
        "1,1e-30,0.5h".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    let output = run_lab(&args);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let report = stdout(&output);
    for name in [
        "accuracy.csv",
        "accuracy-speed.png",
        "accuracy-speed.svg",
        "error-time.png",
        "error-time.svg",
        "convergence.png",
        "convergence.svg",
    ] {
        assert!(report.contains(&format!("{}\n", dir.path().join(name).display())));
    }
    // Each kernel and integrator's order, fitted over its two fixed steps.
    for kernel in [fluid::Kernel::NATIVE.name(), "mixed"] {
        for integrator in ["leapfrog", "verlet"] {
            let line = format!("order {kernel} {integrator}: ");
            assert!(report.contains(&line), "{line}: {report}");
        }
    }
    assert!(report.contains("budget 1e0 m (median error): "), "{report}");
    assert!(
        report.contains("budget 0.5h = 4.154e-3 m (median error): "),
        "{report}"
    );
    assert!(
        report.contains("budget 1e-30 m (median error): no method stays within it"),
        "{report}"
    );
    let text = std::fs::read_to_string(dir.path().join("accuracy.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.join(","), fluid::lab::accuracy::CSV_HEADER);
    let column = |name: &str| header.iter().position(|&c| c == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Twelve methods (two kernels, three rules, two integrators) at two times each; the
    // reference at every time one of them was sampled at (2 and 4 ms, and the adaptive
    // runs' own), on the velocity Verlet.
    let references: Vec<&Vec<&str>> = rows
        .iter()
        .filter(|r| r[column("kernel")] == "reference")
        .collect();
    assert_eq!(rows.len() - references.len(), 12 * 2);
    assert!((2..=10).contains(&references.len()), "{text}");
    assert!(references
        .iter()
        .all(|r| r[column("integrator")] == "verlet"));
    let number = |row: &[&str], name: &str| row[column(name)].parse::<f64>().unwrap();
    for row in &rows {
        let crc32 = format!("{:08x}", crc32fast::hash(&std::fs::read(&small).unwrap()));
        assert_eq!(&row[..4], ["small.fld", &crc32, "4800", "fluidanimate"]);
        assert!(number(row, "cpu_s_per_simulated_s") > 0.0);
        assert!(number(row, "pairs_tested") >= number(row, "pairs_within_h"));
        assert_eq!(row[column("failure")], "");
        if row[column("kernel")] == "reference" {
            assert_eq!(row[column("median_error_m")], "");
            assert!(number(row, "dt_s") < 1e-3 / 8.0);
        } else {
            let requested = row[column("requested_time_s")];
            assert!(["0.002", "0.004"].contains(&requested), "{row:?}");
            let (median, max) = (number(row, "median_error_m"), number(row, "max_error_m"));
            assert!(median > 0.0 && median <= max && max < 0.01, "{row:?}");
        }
    }
    // Twice the step, more error: at 4 ms, dt 2 ms against dt 1 ms.
    let at = |method: &str| {
        let row = rows
            .iter()
            .find(|r| r[column("method")] == method && r[column("requested_time_s")] == "0.004")
            .unwrap();
        number(row, "median_error_m")
    };
    let native = fluid::Kernel::NATIVE.name();
    assert!(at(&format!("{native} dt 2 ms")) > 1.5 * at(&format!("{native} dt 1 ms")));

    // The CSV charts again with `--from-csv`; one whose times are not finite numbers >= 0
    // (or whose errors are NaN or negative) is refused, and draws nothing.
    // `args` charting `csv` again into `folder`; `redraw`, with the sweep's own arguments.
    fn from_csv<'a>(
        mut args: Vec<&'a std::ffi::OsStr>,
        csv: &'a std::path::Path,
        folder: &'a std::path::Path,
    ) -> std::process::Output {
        args.extend::<[&std::ffi::OsStr; 4]>([
            "--from-csv".as_ref(),
            csv.as_os_str(),
            "--output-dir".as_ref(),
            folder.as_os_str(),
        ]);
        run_lab(&args)
    }
    let redraw =
        |csv: &std::path::Path, folder: &std::path::Path| from_csv(methods.to_vec(), csv, folder);
    let again = redraw(&dir.path().join("accuracy.csv"), &dir.path().join("again"));
    assert_eq!(exit_code(&again), 0, "{}", stderr(&again));
    assert!(dir.path().join("again/accuracy-speed.png").is_file());
    // The last method's row (a reference's has no errors to check), as the CSV numbers it.
    let last = 2 + rows
        .iter()
        .rposition(|r| r[column("kernel")] != "reference")
        .unwrap();
    for (name, value, what) in [
        ("time_s", "nan", "a finite number >= 0"),
        ("time_s", "inf", "a finite number >= 0"),
        ("requested_time_s", "-0.002", "a finite number >= 0"),
        ("cpu_s", "-1", "a finite number >= 0"),
        ("median_error_m", "NaN", "an error >= 0"),
        ("max_error_m", "-1e-3", "an error >= 0"),
    ] {
        let k = column(name);
        let mut edited: Vec<String> = vec![header.join(",")];
        for (i, row) in rows.iter().enumerate() {
            let mut row = row.clone();
            if i + 2 == last {
                row[k] = value;
            }
            edited.push(row.join(","));
        }
        let csv = dir.path().join("edited.csv");
        std::fs::write(&csv, edited.join("\n") + "\n").unwrap();
        let folder = dir.path().join("edited");
        let refused = redraw(&csv, &folder);
        assert_eq!(exit_code(&refused), 1, "{name} {value}");
        assert_eq!(
            stderr(&refused),
            format!(
                "fluid-lab: error: {}: row {last}: {name} is {value}, not {what}\n",
                csv.display()
            )
        );
        assert!(!folder.exists(), "{name} {value}");
    }
    // A CSV of its header alone has no rows to chart (the eighth hostile pass: its scene
    // was "unknown").
    let empty = dir.path().join("empty.csv");
    std::fs::write(&empty, format!("{}\n", header.join(","))).unwrap();
    let refused = redraw(&empty, &dir.path().join("edited"));
    assert_eq!(exit_code(&refused), 1);
    assert_eq!(
        stderr(&refused),
        format!(
            "fluid-lab: error: {}: the accuracy CSV has no rows\n",
            empty.display()
        )
    );
    assert!(!dir.path().join("edited").exists());
    // Its charts drawn for another input are refused: the rows are of small.fld.
    let large = common::input("large");
    let folder = dir.path().join("other");
    let other = run_lab(&[
        "accuracy".as_ref(),
        large.as_os_str(),
        "--from-csv".as_ref(),
        dir.path().join("accuracy.csv").as_os_str(),
        "--output-dir".as_ref(),
        folder.as_os_str(),
    ]);
    assert_eq!(exit_code(&other), 1, "{}", stderr(&other));
    assert!(
        stderr(&other).contains(
            "its rows are of small.fld (4800 particles), not of large.fld (15138 particles)"
        ),
        "{}",
        stderr(&other)
    );
    assert!(!folder.exists());
    // Nor for another small.fld of as many particles (the eighth hostile pass's): one
    // coordinate moved by one ulp.
    let moved = dir.path().join("moved");
    std::fs::create_dir(&moved).unwrap();
    let mut bytes = std::fs::read(&small).unwrap();
    let at = bytes.len() - 4;
    let word = f32::from_le_bytes(bytes[at..].try_into().unwrap());
    bytes[at..].copy_from_slice(&word.next_up().to_le_bytes());
    let (moved, csv) = (moved.join("small.fld"), dir.path().join("accuracy.csv"));
    std::fs::write(&moved, &bytes).unwrap();
    let mut args = methods.to_vec();
    args[1] = moved.as_os_str();
    let other = from_csv(args, &csv, &folder);
    assert_eq!(exit_code(&other), 1, "{}", stderr(&other));
    let (theirs, ours) = (
        crc32fast::hash(&std::fs::read(&small).unwrap()),
        crc32fast::hash(&bytes),
    );
    assert!(
        stderr(&other).ends_with(&format!(
            "its rows are of another small.fld (its bytes' CRC-32 {theirs:08x}, not \
             {ours:08x}): give the input or case its sweep ran\n"
        )),
        "{}",
        stderr(&other)
    );
    assert!(!folder.exists());
    // Nor for other methods or times than the sweep's (the sixth hostile pass charted
    // them, exit 0): each flag's value changed in turn.
    // (The seventh: a subset of the times, another model or reference step passed.)
    for (from, to, extra, said) in [
        (
            "1,2",
            "0.5,2",
            None,
            "its methods or times are not these arguments'",
        ),
        (
            "0.002,0.004",
            "0.002,0.003",
            None,
            "its methods or times are not these arguments'",
        ),
        (
            "0.002,0.004",
            "0.002",
            None,
            "its methods or times are not these arguments'",
        ),
        (
            "",
            "",
            Some(["--model", "course"]),
            "its rows are of the fluidanimate model, not course",
        ),
        (
            "",
            "",
            Some(["--reference-dt", "1e-5"]),
            "not one of --reference-dt 1e-05",
        ),
    ] {
        let mut args: Vec<&std::ffi::OsStr> = methods
            .iter()
            .map(|&arg| if arg == from { to.as_ref() } else { arg })
            .collect();
        args.extend(extra.iter().flatten().map(std::ffi::OsStr::new));
        let other = from_csv(args, &csv, &folder);
        assert_eq!(exit_code(&other), 1, "{to}: {}", stderr(&other));
        assert!(stderr(&other).contains(said), "{}", stderr(&other));
        assert!(!folder.exists());
    }

    let bad = run_lab(&[
        "accuracy".as_ref(),
        small.as_os_str(),
        "--times".as_ref(),
        "0.004,0.002".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    assert_eq!(exit_code(&bad), 2);
    let unparsable = run_lab(&["accuracy", "x.fld", "--output-dir", "o", "--budget=0h"]);
    assert_eq!(exit_code(&unparsable), 2);
    assert!(stderr(&unparsable).contains("0h is not a positive error"));
    assert!(
        stderr(&bad).contains("--times needs ascending"),
        "{}",
        stderr(&bad)
    );
}

#[test]
fn stability_reports_each_run_and_maps_them() {
    let dir = tempfile::tempdir().unwrap();
    let output = run_lab(&[
        "stability".as_ref(),
        "--models".as_ref(),
        "course,fluidanimate".as_ref(),
        "--ppms".as_ref(),
        "100".as_ref(),
        "--kernels".as_ref(),
        "simd".as_ref(),
        "--dt-factors".as_ref(),
        "1,2".as_ref(),
        "--adaptive".as_ref(),
        "0.3".as_ref(),
        "--duration".as_ref(),
        "0.03".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let report = stdout(&output);
    let lines: Vec<&str> = report.lines().collect();
    assert!(
        lines[0].starts_with("course simd leapfrog, ppm 100, dt 0.001 s: failed at step "),
        "{report}"
    );
    assert!(
        lines[1].starts_with("course simd leapfrog, ppm 100, dt 0.002 s: failed at step "),
        "{report}"
    );
    assert!(
        lines[2].starts_with("course simd leapfrog, ppm 100, adaptive C 0.3: "),
        "{report}"
    );
    assert_eq!(
        lines[3],
        "fluidanimate simd leapfrog, ppm 100, dt 0.001 s: stable for 30 steps (0.030 s)"
    );
    assert_eq!(
        lines[4],
        "fluidanimate simd leapfrog, ppm 100, dt 0.002 s: stable for 15 steps (0.030 s)"
    );
    assert!(
        lines[5].starts_with("fluidanimate simd leapfrog, ppm 100, adaptive C 0.3: stable for "),
        "{report}"
    );
    let text = std::fs::read_to_string(dir.path().join("stability.csv")).unwrap();
    assert_eq!(text.lines().next(), Some(fluid::lab::stability::CSV_HEADER));
    assert_eq!(text.lines().count(), 7);
    assert!(
        text.contains(",fluidanimate,simd,100,fixed,0.001,,845,0.03,30,,,stable,,leapfrog,3\n"),
        "{text}"
    );
    for name in ["stability-map.png", "stability-map.svg"] {
        assert!(dir.path().join(name).exists());
    }
    let output = run_lab(&[
        "stability".as_ref(),
        "--dt-factors".as_ref(),
        "0".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    // A usage error, as clap's.
    assert_eq!(exit_code(&output), 2);
    assert!(stderr(&output).contains("--dt-factors: 0 does not give a positive time step"));
    let fixed_only = run_lab(&[
        "stability".as_ref(),
        "--models".as_ref(),
        "fluidanimate".as_ref(),
        "--ppms".as_ref(),
        "100".as_ref(),
        "--dt-factors".as_ref(),
        "1".as_ref(),
        "--adaptive".as_ref(),
        "".as_ref(),
        "--duration".as_ref(),
        "0.005".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
    ]);
    assert_eq!(exit_code(&fixed_only), 0, "{}", stderr(&fixed_only));
    let report = stdout(&fixed_only);
    assert_eq!(
        report.lines().filter(|l| l.contains(", ppm 100, ")).count(),
        1,
        "{report}"
    );
    assert!(!report.contains("adaptive"), "{report}");
    for duration in ["inf", "nan", "0", "-1"] {
        let output = run_lab(&[
            "stability".as_ref(),
            format!("--duration={duration}").as_ref(),
            "--output-dir".as_ref(),
            dir.path().as_os_str(),
        ]);
        assert_eq!(exit_code(&output), 2, "{duration}");
        assert!(
            stderr(&output).contains("is not a positive, finite time"),
            "{}",
            stderr(&output)
        );
    }
}

#[test]
fn an_accuracy_sweep_shows_each_runs_progress_in_a_log() {
    // Issue 47, ninth hostile pass: accuracy took --progress-every and printed nothing,
    // for a reference run of many minutes.
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let output = run_lab(&[
        "--progress-every".as_ref(),
        "0".as_ref(),
        "accuracy".as_ref(),
        small.as_os_str(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
        "--kernels".as_ref(),
        "simd".as_ref(),
        "--dt-factors".as_ref(),
        "1".as_ref(),
        "--adaptive".as_ref(),
        "".as_ref(),
        "--integrators".as_ref(),
        "leapfrog".as_ref(),
        "--times".as_ref(),
        "0.002".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let log = stderr(&output);
    for first in [
        "fluid-lab: progress: simd dt 1 ms: step 1, t = 0.001000 of 0.002 s (50%)",
        "fluid-lab: progress: reference dt 0.125 ms verlet: step 1, t = 0.000125 of 0.002 s",
    ] {
        assert!(
            log.lines().any(|line| line.starts_with(first)),
            "{first}: {log}"
        );
    }
}

#[test]
fn a_dam_break_column_too_narrow_for_a_front_is_said_so() {
    // Issue 47, ninth hostile pass: a column 2 particles wide, run past the first point,
    // was told to run to that point.
    let dir = tempfile::tempdir().unwrap();
    let output = run_lab(&[
        "validate",
        "dam-break",
        "--models",
        "wcsph",
        "--ppms",
        "100",
        "--width",
        "0.02",
        "--dimensions",
        "2",
        "--until-t",
        "0.5",
        "--output-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(
        stderr(&output).ends_with(
            "1 of 1 runs failed: wcsph 2-D at 100 per m found no front to compare (fewer than \
             10 particles within 2h of the floor at every sample: a column of 8 particles is \
             too small)\n"
        ),
        "{}",
        stderr(&output)
    );
}

#[test]
fn a_dam_break_validation_runs_to_seconds_with_until_and_to_t_with_until_t() {
    let dir = tempfile::tempdir().unwrap();
    let validate = |end: &[&str]| {
        let mut args = vec![
            "validate",
            "dam-break",
            "--models",
            "fluidanimate",
            "--ppms",
            "150",
        ];
        args.extend_from_slice(end);
        args.extend(["--output-dir", dir.path().to_str().unwrap()]);
        run_lab(&args)
    };
    // The last sample's time (s) and T in the fronts.
    let last = || {
        let fronts = std::fs::read_to_string(dir.path().join("dam-break.csv")).unwrap();
        let row: Vec<f64> = (fronts.lines().last().unwrap().split(',').skip(6).take(2))
            .map(|field| field.parse().unwrap())
            .collect();
        (row[0], row[1])
    };
    // A run that reaches no experimental point (the first is at T = 0.381) compares
    // nothing: a failed validation, its outputs written.
    let output = validate(&["--until-t", "0.3"]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(
        stderr(&output).ends_with(
            "fluid-lab: error: 1 of 1 runs failed: fluidanimate at 150 per m compared no \
             front with an experiment (the first point is at T = 0.381: run to --until-t \
             0.381 or later)\n"
        ),
        "{}",
        stderr(&output)
    );
    assert!(dir.path().join("dam-break-errors.csv").is_file());
    // --until in seconds, as everywhere else.
    let output = validate(&["--until", "0.02"]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let (time, t) = last();
    assert!((time - 0.02).abs() < 1e-12, "{time}");
    // --until-t in the experiment's T = t sqrt(2 g / a).
    let output = validate(&["--until-t", "0.5"]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let (time_at_half, t_half) = last();
    assert!((t_half - 0.5).abs() < 1e-9, "{t_half}");
    // The same unit in both runs: T / t is sqrt(2 g / a).
    assert!((t / time - t_half / time_at_half).abs() < 1e-6 * t_half / time_at_half);
    // Not both; and a time that is not one is refused.
    for end in [
        &["--until", "0.02", "--until-t", "1"][..],
        &["--until", "-1"],
    ] {
        let output = validate(end);
        assert_eq!(exit_code(&output), 2, "{end:?}: {}", stderr(&output));
    }
}

#[test]
fn a_short_dam_break_front_moves_as_the_experiment_s_and_the_course_model_fails_early() {
    let dir = tempfile::tempdir().unwrap();
    let output = run_lab(&[
        "validate".as_ref(),
        "dam-break".as_ref(),
        "--models".as_ref(),
        "course".as_ref(),
        "fluidanimate".as_ref(),
        "wcsph".as_ref(),
        "--ppms".as_ref(),
        "150".as_ref(),
        "--until-t".as_ref(),
        "2".as_ref(),
        "--output-dir".as_ref(),
        dir.path().as_os_str(),
        "--progress-every".as_ref(),
        "0".as_ref(),
    ]);
    // A validation is a test: the course model's failure fails it, after its outputs.
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    // Its log names each run in its progress lines (here after every step).
    let log = stderr(&output);
    for model in ["course", "fluidanimate", "wcsph"] {
        let first = format!("fluid-lab: progress: {model} at 150 per m: step 1, t = ");
        assert!(log.lines().any(|l| l.starts_with(&first)), "{model}");
    }
    let message: String = log
        .lines()
        .filter(|l| !l.starts_with("fluid-lab: progress: "))
        .collect();
    assert_eq!(log.lines().last(), Some(&message[..]));
    assert!(
        message.starts_with(
            "fluid-lab: error: 1 of 3 runs failed: course at 150 per m failed at T = 0.0"
        ),
        "{message}"
    );
    let report = stdout(&output);
    let course = report
        .lines()
        .find(|l| l.starts_with("model=course"))
        .unwrap();
    assert!(course.contains(" failed_at_T=0.0"), "{report}");
    let stable = report
        .lines()
        .find(|l| l.starts_with("model=fluidanimate"))
        .unwrap();
    assert!(!stable.contains("failed"), "{report}");
    for name in ["dam-break.csv", "dam-break.png", "dam-break.svg"] {
        assert!(dir.path().join(name).is_file(), "{name}");
    }
    // Each experiment's points with T <= 2 (Martin and Moyce's three, Koshizuka and
    // Oka's five), each within 35% for fluidanimate and, for the weakly compressible
    // model (a coarse column), within 10% of Martin and Moyce's and 6% of Koshizuka and
    // Oka's; it also holds its density within 3% of rest.
    let errors = std::fs::read_to_string(dir.path().join("dam-break-errors.csv")).unwrap();
    assert!(errors.starts_with(
        "model,kernel,ppm,width_m,time_step,experiment,T,Z_experiment,Z_model,relative_error,\
         dimensions\n"
    ));
    let experiments = [
        ("Martin and Moyce (1952)", 3, [0.35, 0.1]),
        ("Koshizuka and Oka (1996)", 5, [0.35, 0.06]),
    ];
    for (experiment, points, tolerances) in experiments {
        for (model, tolerance) in ["fluidanimate", "wcsph"].into_iter().zip(tolerances) {
            let compared: Vec<(f64, f64, f64)> = errors
                .lines()
                .filter(|line| line.starts_with(&format!("{model},")))
                .filter_map(|line| {
                    let cells: Vec<&str> = line.split(',').collect();
                    let number = |k: usize| cells[k].parse::<f64>().ok();
                    (cells[5] == experiment).then_some(())?;
                    Some((number(6)?, number(7)?, number(8)?))
                })
                .collect();
            assert_eq!(compared.len(), points, "{experiment}: {errors}");
            for &(t, measured, z) in &compared {
                assert!(
                    (z - measured).abs() < tolerance * measured,
                    "{model} at T = {t}: Z {z} against {measured} ({experiment})"
                );
            }
            assert!(
                compared.windows(2).all(|w| w[1].2 > w[0].2),
                "the front advances"
            );
        }
    }
    // The summary names each experiment's errors and the settings of the water.
    let weakly = report
        .lines()
        .find(|l| l.starts_with("model=wcsph"))
        .unwrap();
    // Compared up to the run's end, T = 2 (not the full runs' 3.6).
    for key in [
        " T_le=2 ",
        " max_density_error_T_le_2=",
        "martin_worst=",
        "martin_mean=",
        "koshizuka_worst=",
        "koshizuka_mean=",
    ] {
        assert!(weakly.contains(key), "{weakly}");
    }
    assert!(
        weakly.contains("settings: no-slip walls, artificial viscosity 0.1"),
        "{weakly}"
    );
    let density: f64 = weakly
        .split_whitespace()
        .find_map(|field| field.strip_prefix("max_density_error="))
        .and_then(|value| value.parse().ok())
        .unwrap();
    assert!(density < 0.03, "{weakly}");
    assert!(
        errors
            .lines()
            .filter(|l| l.starts_with("course,"))
            .all(|l| l.ends_with(",,,3")),
        "the course model fails before the first point: {errors}"
    );
}

#[test]
fn the_water_s_settings_are_the_weakly_compressible_model_s_and_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let small = input("small");
    let out = dir.path().join("out.fld");
    let run = |extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> =
            vec!["run".as_ref(), small.as_os_str(), out.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        run_lab(&args)
    };
    // Another model takes none of them.
    let output = run(&["--walls", "free-slip"]);
    assert_eq!(exit_code(&output), 2, "{}", stderr(&output));
    let message = stderr(&output);
    assert!(
        message.contains("--model course takes none") && message.lines().count() == 1,
        "{message}"
    );
    // Values the model cannot run with.
    for (option, value, why) in [
        (
            "--smoothing",
            "0",
            "smoothing length 0 is not finite and positive",
        ),
        (
            "--sound-speed",
            "inf",
            "sound speed factor inf is not finite and positive",
        ),
        (
            "--sound-speed",
            "1e300",
            "sound speed factor must be between 1 and 1000",
        ),
        (
            "--sound-speed",
            "1e-300",
            "sound speed factor must be between 1 and 1000",
        ),
        (
            "--smoothing",
            "0.4",
            "smoothing length must be between 0.5 and 26",
        ),
        (
            "--artificial-viscosity",
            "-0.1",
            "artificial viscosity -0.1 is not finite and at least 0",
        ),
        (
            "--laminar-viscosity",
            "NaN",
            "laminar viscosity NaN is not finite and at least 0",
        ),
    ] {
        let output = run(&["--model", "wcsph", option, value]);
        assert_eq!(exit_code(&output), 2, "{option} {value}");
        let message = stderr(&output);
        assert!(
            message.contains(why) && message.lines().count() == 1,
            "{message}"
        );
    }
    let output = run(&["--model", "wcsph", "--walls", "sticky"]);
    assert_eq!(exit_code(&output), 2, "{}", stderr(&output));
    assert!(!out.exists(), "no output is left behind");
    // Accepted ones run.
    let output = run(&[
        "--model",
        "wcsph",
        "--walls",
        "free-slip",
        "--laminar-viscosity",
        "1e-6",
        "--steps",
        "2",
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(out.is_file());
}

#[test]
fn the_help_says_what_each_command_runs_in_plain_words() {
    let help = |args: &[&str]| {
        let output = run_lab(args);
        assert_eq!(exit_code(&output), 0, "{args:?}: {}", stderr(&output));
        stdout(&output)
    };
    let top = help(&["--help"]);
    let summary = |name: &str| {
        top.lines()
            .find(|line| line.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in {top}"))
            .to_string()
    };
    // Every validation the subcommand runs, by name.
    for flow in ["dam break", "still water", "Poiseuille"] {
        assert!(summary("validate").contains(flow), "{top}");
    }
    assert!(summary("slurm").contains("accuracy"), "{top}");
    assert!(summary("accuracy").contains("one model"), "{top}");
    assert!(help(&["slurm", "--help"]).contains("(sweep, stability or accuracy)"));
    // No rustdoc link syntax reaches a user, in any subcommand the listing names.
    let commands: Vec<&str> = top
        .lines()
        .skip_while(|line| *line != "Commands:")
        .skip(1)
        .take_while(|line| !line.is_empty())
        .filter_map(|line| line.split_whitespace().next())
        .filter(|&name| name != "help")
        .collect();
    assert!(
        commands.len() >= 12 && commands.contains(&"validate"),
        "{top}"
    );
    for command in commands {
        let text = help(&[command, "--help"]);
        assert!(!text.contains("[`"), "{command}: {text}");
    }
}
