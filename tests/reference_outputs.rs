//! The `fluid` binary reproduces the course reference outputs byte for byte and prints the
//! seven parameter lines of SPEC.md section 1; so does the library on both layouts of the
//! neighbour lists, whichever this CPU's instruction set picks.

mod common;

use common::{exit_code, input, reference_output, run_fluid, stderr, stdout};

const SMALL_REPORT: &str = "Number of particles: 4800\nParticles per meter: 204\n\
    Smoothing length: 0.00830882\nParticle mass: 0.00011779\nGrid size: 15 x 21 x 15\n\
    Number of blocks: 4725\nBlock size: 0.00866667 x 0.00857143 x 0.00866667\n";

const LARGE_REPORT: &str = "Number of particles: 15138\nParticles per meter: 292\n\
    Smoothing length: 0.00580479\nParticle mass: 4.01653e-05\nGrid size: 22 x 31 x 22\n\
    Number of blocks: 15004\nBlock size: 0.00590909 x 0.00580645 x 0.00590909\n";

/// Runs `fluid steps <name>.fld` and returns the output file's bytes, checking the
/// success contract: exit 0, the report on stdout, nothing on stderr.
fn simulate(name: &str, steps: u32, report: &str) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.fld");
    let output = run_fluid(&[
        steps.to_string().as_ref(),
        input(name).as_os_str(),
        out.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 0, "stderr: {}", stderr(&output));
    assert_eq!(stdout(&output), report);
    assert_eq!(stderr(&output), "");
    std::fs::read(&out).expect("output file written")
}

fn check_references(name: &str, report: &str) {
    for steps in 1..=5 {
        let expected = std::fs::read(reference_output(name, steps)).unwrap();
        let actual = simulate(name, steps, report);
        assert_eq!(actual.len(), expected.len(), "{name}-{steps}: size");
        let differing = actual.iter().zip(&expected).filter(|(a, b)| a != b).count();
        assert_eq!(
            differing, 0,
            "{name}-{steps}: {differing} bytes differ from the reference"
        );
    }
}

#[test]
fn small_matches_the_references_for_1_to_5_steps() {
    check_references("small", SMALL_REPORT);
}

#[test]
fn large_matches_the_references_for_1_to_5_steps() {
    check_references("large", LARGE_REPORT);
}

#[test]
fn both_kinds_of_lists_reproduce_the_reference_outputs() {
    use fluid::io::fld;
    use fluid::sim::lists::PairStructure;
    use fluid::{Kernel, Method, Model, Simulation};
    for name in ["small", "large"] {
        let scene = fld::read(&input(name)).unwrap();
        for (kernel, structure) in [Kernel::Simd, Kernel::Simd8]
            .into_iter()
            .flat_map(|k| [PairStructure::Lists, PairStructure::Rows].map(|s| (k, s)))
        {
            let method = Method {
                model: Model::Course,
                kernel,
            };
            let particles = scene.particles.clone();
            let mut sim = Simulation::with_method(scene.ppm.into(), particles, method).unwrap();
            sim.set_pair_structure(structure);
            for steps in 1..=5 {
                sim.run(1);
                let lists = sim.lists();
                assert!(lists.is_some() || steps > 1, "the first step is dense");
                let rows = lists.map(|lists| lists.rows().is_some());
                assert!(rows.is_none_or(|rows| rows == (structure == PairStructure::Rows)));
                let bytes = fld::encode(scene.ppm, sim.particles()).unwrap();
                let expected = std::fs::read(reference_output(name, steps)).unwrap();
                let what = format!("{name}-{steps} on {kernel:?} and {structure:?}");
                assert!(bytes == expected, "{what}");
            }
        }
    }
}

#[test]
fn zero_steps_reproduce_the_input() {
    for (name, report) in [("small", SMALL_REPORT), ("large", LARGE_REPORT)] {
        let original = std::fs::read(input(name)).unwrap();
        assert!(
            simulate(name, 0, report) == original,
            "{name}: 0 steps changed the file"
        );
    }
}

#[test]
fn one_step_changes_the_state() {
    // Guards the comparisons above against a run that writes its input back.
    let original = std::fs::read(input("small")).unwrap();
    assert!(simulate("small", 1, SMALL_REPORT) != original);
}

#[test]
fn an_existing_output_is_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.fld");
    std::fs::write(&out, b"old contents").unwrap();
    let output = run_fluid(&["1".as_ref(), input("small").as_os_str(), out.as_os_str()]);
    assert_eq!(exit_code(&output), 0);
    assert_eq!(
        std::fs::read(&out).unwrap(),
        std::fs::read(reference_output("small", 1)).unwrap()
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "temporary file left over"
    );
}
