//! The `fluid-lab` workbench: runs with a chosen model and kernel (the scalar kernel also
//! reproduces the reference outputs), generated scenes, and clear errors.

mod common;

use common::{exit_code, input, reference_output, run_lab, stderr, stdout};
use fluid::fld;

#[test]
fn the_scalar_kernel_reproduces_every_reference_output() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["small", "large"] {
        for steps in 1..=5 {
            let out = dir.path().join(format!("{name}-{steps}.fld"));
            let output = run_lab(&[
                "run".as_ref(),
                "--kernel".as_ref(),
                "scalar".as_ref(),
                "--steps".as_ref(),
                steps.to_string().as_ref(),
                input(name).as_os_str(),
                out.as_os_str(),
            ]);
            assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
            let expected = std::fs::read(reference_output(name, steps)).unwrap();
            assert!(
                std::fs::read(&out).unwrap() == expected,
                "{name}-{steps} differs"
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
        report.starts_with("model=fluidanimate kernel=simd particles=4800 steps=3 seconds="),
        "{report}"
    );
    assert!(report.contains(" ns_per_particle_step="), "{report}");
}

#[test]
fn a_generated_scene_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("box.fld");
    let output = run_lab(&[
        "scene".as_ref(),
        "--ppm".as_ref(),
        "400".as_ref(),
        "--particles".as_ref(),
        "5000".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    let bytes = std::fs::read(&out).unwrap();
    let scene = fld::parse(&bytes, "box.fld").unwrap();
    assert_eq!((scene.ppm, scene.particles.len()), (400.0, 5000));
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
