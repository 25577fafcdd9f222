//! Results depend on the input and the physics alone: within a cell the particles are in
//! the order of their ids, so the lone filter's table (its size, and so its collisions),
//! or no filter at all, changes the work of a step but not one byte of `fluid`'s output,
//! however long the run.

mod common;

use fluid::io::fld;
use fluid::sim::lists::PairStructure;
use fluid::{Method, Simulation};

/// The output `fluid STEPS INPUT` writes, from a simulation of the bundled input `name`
/// that `configure` has set up.
fn output_bytes(name: &str, steps: u64, configure: impl FnOnce(&mut Simulation)) -> Vec<u8> {
    let scene = fld::read(&common::input(name)).expect("the bundled input");
    let ppm = scene.ppm;
    let mut simulation = scene
        .into_simulation(Method::default(), name)
        .expect("a grid");
    configure(&mut simulation);
    simulation.run(steps);
    fld::encode(ppm, simulation.particles()).expect("a state within f32")
}

/// Asserts that every lone filter gives the bytes of the default one after `steps`, the
/// SIMD pair loops on `structure`.
fn assert_filters_agree(name: &str, steps: u64, structure: PairStructure) {
    let default = output_bytes(name, steps, |sim| sim.set_pair_structure(structure));
    // One block per particle: most blocks share a counter with another, so the filter
    // lets many lone particles through; 4096: almost none; none: every particle sorted.
    for filter in [Some(1), Some(4096), None] {
        let bytes = output_bytes(name, steps, |sim| {
            sim.set_pair_structure(structure);
            sim.set_lone_filter(filter);
        });
        assert!(
            bytes == default,
            "{name}, {steps} steps, {structure:?}: lone filter {filter:?} changed the output"
        );
    }
}

#[test]
fn no_lone_filter_changes_a_thousand_steps_of_large() {
    assert_filters_agree("large", 1000, PairStructure::default());
}

#[test]
fn no_lone_filter_changes_a_thousand_steps_of_small() {
    assert_filters_agree("small", 1000, PairStructure::default());
}

#[test]
fn no_lone_filter_changes_a_run_on_tiles() {
    // The workbench's other pair structure, on the dense steps it runs.
    assert_filters_agree("small", 1000, PairStructure::Tiles);
}
