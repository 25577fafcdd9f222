//! Case files (`docs/case-files.md`): the cases in `cases/` run through `fluid-lab run`,
//! `export` and `render --case` as their scenes do from `.fld` files, flags beside a case
//! override it, and a bad case file gets one line with its line and column, exit 2 and
//! nothing written.

mod common;

use common::{exit_code, run_lab, stderr, stdout};
use std::path::{Path, PathBuf};

/// The case `name` of `cases/`.
fn case(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(format!("{name}.toml"))
}

#[test]
fn each_bundled_case_runs_as_its_scene_does() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["dam-break", "drop", "filled-box"] {
        // The scene's particles written as a .fld file, then run with the case's model.
        let scene = dir.path().join(format!("{name}.fld"));
        let output = run_lab(&["scene".as_ref(), name.as_ref(), scene.as_os_str()]);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        // The case's start, written as a .fld file: the scene's particles.
        let start = dir.path().join(format!("{name}-start.fld"));
        let output = run_lab(&[
            "run".as_ref(),
            "--case".as_ref(),
            case(name).as_os_str(),
            start.as_os_str(),
            "--steps".as_ref(),
            "0".as_ref(),
        ]);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        let (a, b) = (
            std::fs::read(&scene).unwrap(),
            std::fs::read(&start).unwrap(),
        );
        assert!(a.len() > 1000 && a == b, "{name}: the case's scene differs");
        // Run as the case says (the water model), cut to 2 steps by the flag.
        let from_case = dir.path().join(format!("{name}-case-out.fld"));
        let output = run_lab(&[
            "run".as_ref(),
            "--case".as_ref(),
            case(name).as_os_str(),
            from_case.as_os_str(),
            "--steps".as_ref(),
            "2".as_ref(),
        ]);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        assert!(
            stdout(&output).starts_with("model=wcsph "),
            "{}",
            stdout(&output)
        );
        assert!(stdout(&output).contains(" steps=2 "), "{}", stdout(&output));
        assert_ne!(
            std::fs::read(&from_case).unwrap(),
            b,
            "{name}: the fluid moved"
        );
    }
}

#[test]
fn flags_beside_a_case_override_it_and_its_run_and_outputs_apply() {
    let dir = tempfile::tempdir().unwrap();
    let final_state = dir.path().join("final.fld");
    let text = format!(
        "[fluid]\nparticles_per_m = 120\n[[fluid.sphere]]\ncentre_m = [0.0, 0.0, 0.0]\n\
         radius_m = 0.03\n[model]\nname = \"wcsph\"\nwalls = \"free-slip\"\n\
         time_step_s = 0.0005\n[run]\nsteps = 4\n[output]\nfinal_state = \"{}\"\n",
        final_state.display()
    );
    let path = dir.path().join("ball.toml");
    std::fs::write(&path, text).unwrap();
    // As the case says: wcsph, 4 steps of 0.5 ms, the final state where it says.
    let output = run_lab(&["run".as_ref(), "--case".as_ref(), path.as_os_str()]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let report = stdout(&output);
    assert!(report.starts_with("model=wcsph "), "{report}");
    assert!(
        report.contains(" steps=4 ") && report.contains(" simulated_s=0.002000 "),
        "{report}"
    );
    assert!(final_state.exists());
    // Flags override the model, the step and the extent.
    let output = run_lab(&[
        "run".as_ref(),
        "--case".as_ref(),
        path.as_os_str(),
        "--model".as_ref(),
        "fluidanimate".as_ref(),
        "--dt".as_ref(),
        "0.001".as_ref(),
        "--until".as_ref(),
        "0.003".as_ref(),
    ]);
    // The case's walls are the water model's: refused for another model.
    assert_eq!(exit_code(&output), 1, "{}", stdout(&output));
    assert!(
        stderr(&output).contains("--model fluidanimate takes none"),
        "{}",
        stderr(&output)
    );
    let output = run_lab(&[
        "run".as_ref(),
        "--case".as_ref(),
        path.as_os_str(),
        "--dt".as_ref(),
        "0.001".as_ref(),
        "--until".as_ref(),
        "0.003".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let report = stdout(&output);
    assert!(
        report.contains(" steps=3 ") && report.contains(" simulated_s=0.003000 "),
        "{report}"
    );
    // Export and render take the case too, their output the one positional argument.
    let frames = dir.path().join("frames");
    let output = run_lab(&[
        "export".as_ref(),
        "--case".as_ref(),
        path.as_os_str(),
        frames.as_os_str(),
        "--steps".as_ref(),
        "1".as_ref(),
        "--every".as_ref(),
        "1".as_ref(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(frames.join("ball_000000.vtk").exists() && frames.join("ball_000001.vtk").exists());
    let picture = dir.path().join("ball.png");
    let output = run_lab(&[
        "render".as_ref(),
        "--case".as_ref(),
        path.as_os_str(),
        picture.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(picture.exists());
    // An input beside a case is one positional too many.
    let output = run_lab(&[
        "export".as_ref(),
        "--case".as_ref(),
        path.as_os_str(),
        path.as_os_str(),
        frames.as_os_str(),
    ]);
    assert_ne!(exit_code(&output), 0);
}

#[test]
fn a_bad_case_file_gets_its_line_and_column_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(case("dam-break")).unwrap();
    let bad = [
        (
            "until_s = 0.5",
            "until_s = 0.5\nspeed = 1",
            "unknown field `speed`",
        ),
        (
            "particles_per_m = 400.0",
            "particles_per_m = \"400\"",
            "invalid type",
        ),
        (
            "particles_per_m = 400.0",
            "particles_per_m = 0",
            "not a number > 0",
        ),
        (
            "particles_per_m = 400.0",
            "particles_per_m = 1e9",
            "the limit is",
        ),
        (
            "name = \"wcsph\"",
            "name = \"water\"",
            "none of course, fluidanimate, wcsph",
        ),
        (
            "max_m = [-0.012999999999999998",
            "max_m = [0.2",
            "outside the domain",
        ),
        ("until_s = 0.5", "until_s = 0", "time > 0"),
    ];
    for (from, to, words) in bad {
        assert!(good.contains(from), "{from}");
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        let out = dir.path().join("out.fld");
        let output = run_lab(&[
            "run".as_ref(),
            "--case".as_ref(),
            path.as_os_str(),
            out.as_os_str(),
        ]);
        assert_eq!(exit_code(&output), 2, "{to}: {}", stderr(&output));
        let message = stderr(&output);
        let prefix = format!("fluid-lab: error: {}:", path.display());
        assert!(message.starts_with(&prefix), "{message}");
        let place: Vec<&str> = message[prefix.len()..].splitn(3, ':').collect();
        assert!(
            place[0].parse::<usize>().is_ok() && place[1].parse::<usize>().is_ok(),
            "{message}"
        );
        assert!(message.contains(words), "{to}: {message}");
        assert_eq!(message.lines().count(), 1, "{message}");
        assert!(!out.exists(), "nothing written");
    }
    let entries = std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(entries, 1, "only the case file in the folder");
}
