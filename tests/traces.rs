//! Stage-by-stage comparison with the course's double-precision traces (SPEC.md sections
//! 5 and 6). Traces are read from `../shared/data/trz/` (or `$FLUID_TRACE_DIR`); where
//! that folder is absent the tests say so on stderr and pass without checking.

mod common;

use fluid::io::fld;
use fluid::io::trace::Trace;
use fluid::sim::cells::Wall;
use fluid::sim::stages::Stage;
use fluid::Particles;
use fluid::Simulation;
use fluid::{Kernel, Method, Model};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Tolerance for one stage fed with the previous stage's trace (SPEC.md section 5).
const SINGLE_STAGE_TOLERANCE: f64 = 1e-10;
/// Tolerance for a run chained from the input through every traced stage.
const CHAINED_TOLERANCE: f64 = 1e-8;

/// The trace folder of one input, or `None` (with a visible notice) when it is absent.
fn trace_dir(size: &str) -> Option<PathBuf> {
    let root = std::env::var_os("FLUID_TRACE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/trz"));
    let dir = root.join(size);
    if dir.is_dir() {
        return Some(dir);
    }
    // Written straight to stderr so the notice shows even though the test passes.
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED: no traces at {} (set FLUID_TRACE_DIR to the trz folder)",
        dir.display()
    );
    None
}

/// The steps that have traces for an input.
fn traced_steps(size: &str) -> std::ops::RangeInclusive<u32> {
    if size == "small" {
        1..=5
    } else {
        1..=1
    }
}

fn read_trace(dir: &Path, stage: Stage, step: u32) -> Trace {
    Trace::read(&dir.join(format!("{}-base-{step}.trz", stage.trace_name()))).expect("trace")
}

/// The input of `size` on `kernel`, placed (running stage 1 again changes nothing).
fn input_simulation(size: &str, kernel: Kernel) -> Simulation {
    let bytes = std::fs::read(common::input(size)).unwrap();
    let scene = fld::parse(&bytes, size).unwrap();
    let method = Method {
        model: Model::Course,
        kernel,
    };
    Simulation::with_method(scene.ppm.into(), scene.particles, method).unwrap()
}

/// The state of `trace`, with the parameters, grid and method of the same input. The
/// walls come from `stage_one`, the trace of stage 1 of the same step.
fn trace_simulation(input: &Simulation, trace: Trace, stage_one: &Trace) -> Simulation {
    let block_of_id = blocks_by_id(stage_one);
    let blocks: Vec<u32> = trace
        .particles
        .id
        .iter()
        .map(|&id| block_of_id[id as usize])
        .collect();
    Simulation::after_stage_one(
        *input.params(),
        *input.grid(),
        input.method(),
        trace.particles,
        &blocks,
    )
}

/// The block of each particle id in a trace.
fn blocks_by_id(trace: &Trace) -> Vec<u32> {
    let mut blocks = vec![0; trace.particles.len()];
    for (&id, block) in trace.particles.id.iter().zip(trace.blocks()) {
        blocks[id as usize] = block;
    }
    blocks
}

/// The fields a stage defines: after repositioning, density and acceleration are not yet
/// reset (stage 2 does it), so only ids and kinematics are compared.
fn fields_after(stage: Stage) -> &'static [&'static str] {
    match stage {
        Stage::Reposition => &["p", "hv", "v"],
        _ => &["p", "hv", "v", "rho", "a"],
    }
}

/// One field's arrays, each value in slot `id` (particles in id order, unpadded).
fn field(particles: &Particles, name: &str) -> Vec<Vec<f64>> {
    let arrays: Vec<&Vec<f64>> = match name {
        "p" => particles.p.iter().collect(),
        "hv" => particles.hv.iter().collect(),
        "v" => particles.v.iter().collect(),
        "a" => particles.a.iter().collect(),
        "rho" => vec![&particles.rho],
        _ => unreachable!("unknown field {name}"),
    };
    let mut by_id = vec![vec![f64::NAN; particles.len()]; arrays.len()];
    for (slot, &id) in particles.id.iter().enumerate() {
        for (target, source) in by_id.iter_mut().zip(&arrays) {
            target[id as usize] = source[slot];
        }
    }
    by_id
}

/// Largest relative difference of one field, particle by particle (matched by id), and
/// the id where it occurs: |x - y| / max(|y|, floor), where the floor (1e-3 of the field's
/// largest magnitude) keeps near-zero values from dominating; NaN counts as the worst.
fn worst_relative_error(ours: &Particles, reference: &Particles, name: &str) -> (f64, usize) {
    let mut worst = (0.0, 0);
    for (x, y) in field(ours, name).into_iter().zip(field(reference, name)) {
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let floor = (1e-3 * scale).max(f64::MIN_POSITIVE);
        for (id, (a, b)) in x.iter().zip(&y).enumerate() {
            let error = (a - b).abs() / b.abs().max(floor);
            if error.is_nan() || error > worst.0 {
                worst = (error, id);
            }
        }
    }
    worst
}

/// Asserts the same particles, every defined field within `tolerance`, and, after stage
/// 1, that each particle's walls are those of its block in the trace.
fn assert_matches(ours: &Simulation, reference: &Trace, stage: Stage, what: &str, tolerance: f64) {
    let theirs = &reference.particles;
    let mut ids = ours.particles().id.clone();
    ids.sort_unstable();
    assert!(
        ids.iter().copied().eq(0..theirs.len() as u32),
        "{what}: particles differ"
    );
    for name in fields_after(stage) {
        let (error, id) = worst_relative_error(ours.particles(), theirs, name);
        println!("{what}: {name} worst relative error {error:.3e} (id {id})");
        assert!(
            error <= tolerance,
            "{what}: {name} differs by {error:.3e} (> {tolerance:e}) at id {id}"
        );
    }
    if stage == Stage::Reposition {
        assert_walls_match(ours, reference, what);
    }
}

/// Each particle is on exactly the walls (per axis, low or high) of its trace block.
fn assert_walls_match(ours: &Simulation, reference: &Trace, what: &str) {
    let grid = ours.grid();
    let blocks = blocks_by_id(reference);
    let mut on_walls = 0;
    for axis in 0..3 {
        for wall in [Wall::Low, Wall::High] {
            let slots = ours.cells().walls().on(axis, wall);
            let mut ids: Vec<u32> = slots
                .iter()
                .map(|&s| ours.particles().id[s as usize])
                .collect();
            ids.sort_unstable();
            let expected: Vec<u32> = (0..blocks.len() as u32)
                .filter(|&id| {
                    let c = grid.coords(blocks[id as usize] as usize)[axis];
                    match wall {
                        Wall::Low => c == 0,
                        Wall::High => c != 0 && c == grid.dims[axis] - 1,
                    }
                })
                .collect();
            assert_eq!(
                ids, expected,
                "{what}: particles on wall {wall:?} of axis {axis}"
            );
            on_walls += ids.len();
        }
    }
    assert!(on_walls > 0, "{what}: no particle on any wall");
}

fn check_single_stages(size: &str, kernel: Kernel) {
    let Some(dir) = trace_dir(size) else { return };
    let input = input_simulation(size, kernel);
    for step in traced_steps(size) {
        let stage_one = read_trace(&dir, Stage::Reposition, step);
        for (k, &stage) in Stage::ALL.iter().enumerate() {
            let mut simulation = match (k, step) {
                (0, 1) => input.clone(),
                (0, _) => {
                    let previous = read_trace(&dir, Stage::InteractWithBoundary, step - 1);
                    let previous_stage_one = read_trace(&dir, Stage::Reposition, step - 1);
                    trace_simulation(&input, previous, &previous_stage_one)
                }
                _ => trace_simulation(
                    &input,
                    read_trace(&dir, Stage::ALL[k - 1], step),
                    &stage_one,
                ),
            };
            simulation.run_stage(stage);
            let expected = read_trace(&dir, stage, step);
            let what = format!(
                "{size} step {step} {} alone ({})",
                stage.trace_name(),
                kernel.name()
            );
            assert_matches(&simulation, &expected, stage, &what, SINGLE_STAGE_TOLERANCE);
        }
    }
}

fn check_chained(size: &str, kernel: Kernel) {
    let Some(dir) = trace_dir(size) else { return };
    let mut simulation = input_simulation(size, kernel);
    for step in traced_steps(size) {
        for stage in Stage::ALL {
            simulation.run_stage(stage);
            let expected = read_trace(&dir, stage, step);
            let what = format!(
                "{size} step {step} {} chained ({})",
                stage.trace_name(),
                kernel.name()
            );
            assert_matches(&simulation, &expected, stage, &what, CHAINED_TOLERANCE);
        }
    }
}

#[test]
fn small_single_stages_match_the_traces() {
    for kernel in Kernel::F64 {
        check_single_stages("small", kernel);
    }
}

#[test]
fn large_single_stages_match_the_traces() {
    for kernel in Kernel::F64 {
        check_single_stages("large", kernel);
    }
}

#[test]
fn small_chained_run_matches_the_traces() {
    for kernel in Kernel::F64 {
        check_chained("small", kernel);
    }
}

#[test]
fn large_chained_run_matches_the_traces() {
    for kernel in Kernel::F64 {
        check_chained("large", kernel);
    }
}

#[test]
fn the_comparison_catches_a_one_in_a_billion_change() {
    let Some(dir) = trace_dir("small") else {
        return;
    };
    let reference = read_trace(&dir, Stage::TransferAccelerations, 1);
    let mut perturbed = reference.particles.clone();
    perturbed.a[1][100] *= 1.0 + 1e-9;
    let (error, id) = worst_relative_error(&perturbed, &reference.particles, "a");
    assert!(
        error > SINGLE_STAGE_TOLERANCE,
        "error {error:e} not detected"
    );
    assert_eq!(id, reference.particles.id[100] as usize);
}
