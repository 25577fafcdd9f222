//! Criterion benchmarks: whole time steps and single stages, on the bundled inputs in their
//! initial (dense) state, in the blown-up state of the course model after 50 steps and in
//! its scattered state after 1,000 (the phase of `fluid`'s long runs), for every model
//! (single stages: the course and fluidanimate models, whose stages are SPEC.md's; the
//! weakly compressible model has one pair pass, timed in its whole steps) and every fast
//! kernel; the floor of the per-particle stages (`floor/...`: one read-modify-write pass
//! over the state arrays, [`fluid::sim::stages::state_floor`], per particle) and stage 1's
//! parts (`stage1/...`: the cell order, the gather, the tile search, per particle) on the
//! scattered states; and whole steps of generated scenes of 3,000 to 100,000 particles
//! (time per particle-step). Every model's SIMD kernels run on neighbour lists on the
//! dense states, the default since round four; their whole steps are also timed on the
//! tiles, under the same name ending in `/tiles`. The states are rebuilt every step (no
//! skin).
//!
//! `cargo bench --bench step -- --profile-time 10 <filter>` also writes a flamegraph of
//! each selected benchmark to `target/criterion/<benchmark>/profile/flamegraph.svg`.

use criterion::profiler::Profiler;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use fluid::io::fld;
use fluid::lab::scene;
use fluid::sim::cells::CellOrder;
use fluid::sim::isa::InstructionSet;
use fluid::sim::lists::PairStructure;
use fluid::sim::neighbours::TileSearch;
use fluid::sim::params::GRAVITY;
use fluid::sim::stages::{self, Stage};
use fluid::{Kernel, Method, Model};
use fluid::{Particles, Simulation};
use pprof::ProfilerGuard;
use std::fs::File;
use std::path::Path;

/// Samples per second of the flamegraph profiler (the kernel tick here is 250 Hz).
const SAMPLING_HZ: i32 = 250;

/// Steps after which the course model has blown up (most particles metres away).
const BLOW_UP_STEPS: u64 = 50;

/// Steps after which the course model is scattered: almost no particle has a partner
/// closer than h (the phase of `fluid`'s long runs, issue 35).
const SCATTERED_STEPS: u64 = 1000;

/// Criterion's hook for `--profile-time`: samples the benchmark with pprof and writes a
/// flamegraph SVG beside criterion's report.
struct FlamegraphProfiler {
    guard: Option<ProfilerGuard<'static>>,
}

impl Profiler for FlamegraphProfiler {
    fn start_profiling(&mut self, _benchmark_id: &str, _benchmark_dir: &Path) {
        self.guard = Some(ProfilerGuard::new(SAMPLING_HZ).expect("start the pprof sampler"));
    }

    fn stop_profiling(&mut self, benchmark_id: &str, benchmark_dir: &Path) {
        let Some(guard) = self.guard.take() else {
            return;
        };
        let report = guard.report().build().expect("build the pprof report");
        std::fs::create_dir_all(benchmark_dir).expect("create the profile folder");
        let path = benchmark_dir.join("flamegraph.svg");
        let file = File::create(&path).expect("create the flamegraph file");
        report.flamegraph(file).expect("write the flamegraph");
        eprintln!("{benchmark_id}: flamegraph in {}", path.display());
    }
}

fn load(name: &str, method: Method) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/in")
        .join(name);
    let bytes = std::fs::read(&path).expect("bundled input");
    let scene = fld::parse(&bytes, name).expect("valid input");
    Simulation::with_method(scene.ppm.into(), scene.particles, method).expect("valid grid")
}

/// The benchmarked states: (label, model, steps run before measuring).
const STATES: [(&str, Model, u64); 5] = [
    ("dense", Model::Course, 0),
    ("dense", Model::Fluidanimate, 0),
    ("dense", Model::Wcsph, 0),
    ("blown-up", Model::Course, BLOW_UP_STEPS),
    ("scattered", Model::Course, SCATTERED_STEPS),
];

/// The state after `steps`, its lists rebuilt every step (a step cloned from a state
/// with a fresh skin, the weakly compressible model's default, would never build them).
fn state(input: &str, model: Model, kernel: Kernel, steps: u64) -> Simulation {
    let mut simulation = load(input, Method { model, kernel });
    simulation.set_skin(None).expect("no skin");
    simulation.run(steps);
    simulation
}

fn whole_steps(c: &mut Criterion) {
    for input in ["small.fld", "large.fld"] {
        for (label, model, steps) in STATES {
            for kernel in Kernel::FAST {
                let initial = state(input, model, kernel, steps);
                let id = format!("step/{input}/{label}/{}/{}", model.name(), kernel.name());
                c.bench_function(&id, |b| {
                    b.iter_batched_ref(|| initial.clone(), Simulation::step, BatchSize::LargeInput)
                });
                if kernel.runs_on_lanes() && label == "dense" {
                    let mut on_tiles = initial.clone();
                    on_tiles.set_pair_structure(PairStructure::Tiles);
                    c.bench_function(&format!("{id}/tiles"), |b| {
                        b.iter_batched_ref(
                            || on_tiles.clone(),
                            Simulation::step,
                            BatchSize::LargeInput,
                        )
                    });
                }
            }
        }
    }
}

/// Each stage alone, from the state in which a step reaches it.
fn single_stages(c: &mut Criterion) {
    for input in ["small.fld", "large.fld"] {
        for (label, model, steps) in STATES.into_iter().filter(|s| s.1 != Model::Wcsph) {
            for kernel in Kernel::FAST {
                let mut before = state(input, model, kernel, steps);
                for stage in Stage::ALL {
                    let pair_stage = matches!(
                        stage,
                        Stage::IncrementDensities | Stage::TransferAccelerations
                    );
                    if pair_stage || kernel == Kernel::Simd {
                        let id = format!(
                            "stage/{input}/{label}/{}/{}/{}",
                            model.name(),
                            kernel.name(),
                            stage.trace_name()
                        );
                        c.bench_function(&id, |b| {
                            b.iter_batched_ref(
                                || before.clone(),
                                |simulation| simulation.run_stage(stage),
                                BatchSize::LargeInput,
                            )
                        });
                    }
                    before.run_stage(stage);
                }
            }
        }
    }
}

/// The floor of the per-particle stages on the course model's scattered states: one
/// read-modify-write pass over the state arrays, per particle.
fn state_floor(c: &mut Criterion) {
    for input in ["small.fld", "large.fld"] {
        let scattered = state(input, Model::Course, Kernel::Simd, SCATTERED_STEPS);
        let particles = scattered.particles().clone();
        let dt = scattered.params().dt;
        let mut group = c.benchmark_group(format!("floor/{input}/scattered"));
        group.throughput(Throughput::Elements(particles.len() as u64));
        group.bench_function("state-pass", |b| {
            b.iter_batched_ref(
                || particles.clone(),
                |particles| stages::state_floor(dt, particles),
                BatchSize::LargeInput,
            )
        });
        group.finish();
    }
}

/// Stage 1's parts on the course model's scattered states, per particle: the cell order
/// (cells, the lone filter, the radix sort of the particles it keeps, the walls), moving
/// the particles into it or leaving them in place (as a step does), the exact partner
/// test, the gather of the state into that order or of the particles with a partner
/// alone, and the tile search over the particles the filter keeps and over those.
fn stage_one_parts(c: &mut Criterion) {
    for input in ["small.fld", "large.fld"] {
        let scattered = state(input, Model::Course, Kernel::Simd, SCATTERED_STEPS);
        let (grid, particles) = (*scattered.grid(), scattered.particles());
        let mut sorted = scattered.cells().clone();
        sorted.sort(&grid, particles);
        let mut group = c.benchmark_group(format!("stage1/{input}/scattered"));
        group.throughput(Throughput::Elements(particles.len() as u64));
        for (name, in_place) in [("cell-order", false), ("cell-order-in-place", true)] {
            group.bench_function(name, |b| {
                b.iter_batched_ref(
                    || scattered.cells().clone(),
                    |cells| match in_place {
                        true => cells.sort_in_place(&grid, particles),
                        false => cells.sort(&grid, particles),
                    },
                    BatchSize::LargeInput,
                )
            });
        }
        // The lone filter's lookups on each instruction set this CPU runs (gathers, or
        // loads lane by lane on the portable one).
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let name = format!("cell-order-in-place/{}", isa.name());
            group.bench_function(name, |b| {
                b.iter_batched_ref(
                    || {
                        let mut cells = scattered.cells().clone();
                        cells.set_instruction_set(isa);
                        cells
                    },
                    |cells| cells.sort_in_place(&grid, particles),
                    BatchSize::LargeInput,
                )
            });
        }
        group.bench_function("gather", |b| {
            let mut placed = Particles::default();
            b.iter(|| placed.gather_kinematics(particles, sorted.order(), GRAVITY))
        });
        // A step that leaves the particles in place keeps those with a partner closer
        // than h: the sorted ones' positions gathered, their tiles found, each pair's
        // distance tested, the kept slots and tiles renumbered.
        let mut staying = scattered.cells().clone();
        staying.sort_in_place(&grid, particles);
        let h2 = scattered.params().h2;
        let keep = |cells: &mut CellOrder, search: &mut TileSearch, placed: &mut Particles| {
            placed.gather_positions(particles, cells.paired());
            search.find(cells.keys(), cells.layout());
            let partnered = search.find_partnered(&placed.p, cells.paired().len(), h2);
            cells.keep_paired(partnered);
            search.keep_partnered();
        };
        group.bench_function("partner-test", |b| {
            let (mut search, mut placed) = (TileSearch::default(), Particles::default());
            b.iter_batched_ref(
                || staying.clone(),
                |cells| keep(cells, &mut search, &mut placed),
                BatchSize::LargeInput,
            )
        });
        let mut kept = staying.clone();
        keep(
            &mut kept,
            &mut TileSearch::default(),
            &mut Particles::default(),
        );
        // What it moves instead of every particle: those kept into a compact copy in
        // cell order, then every particle's acceleration and density set as for one
        // without a partner, and the copied ones' own put back.
        group.bench_function("gather-paired", |b| {
            let paired = kept.paired();
            let n = particles.len();
            let mut placed = Particles::default();
            let (mut a, mut rho) = (particles.a.clone(), particles.rho.clone());
            b.iter(|| {
                placed.gather_for_pairs(particles, paired, GRAVITY);
                rho[..n].fill(1.0);
                for (&slot, &from) in paired.iter().zip(&placed.rho) {
                    rho[slot as usize] = from;
                }
                for ((axis, from), g) in a.iter_mut().zip(&placed.a).zip(GRAVITY.to_array()) {
                    axis[..n].fill(g);
                    for (&slot, &from) in paired.iter().zip(from) {
                        axis[slot as usize] = from;
                    }
                }
            })
        });
        // The tile search over the particles the lone filter keeps (inside the partner
        // test), and over those with a partner.
        for (name, cells) in [("tile-search", &sorted), ("tile-search-kept", &kept)] {
            group.bench_function(name, |b| {
                let mut search = TileSearch::default();
                b.iter(|| search.find(cells.keys(), cells.layout()))
            });
        }
        group.finish();
    }
}

/// Whole steps of the stable model on a block of fluid at 400 particles per metre, from 3,000
/// to 100,000 particles; throughput is in particle-steps.
fn scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("scaling/corner-block-ppm400/fluidanimate/simd");
    for count in [3_000, 10_000, 30_000, 100_000] {
        let method = Method {
            model: Model::Fluidanimate,
            kernel: Kernel::Simd,
        };
        let particles = scene::corner_block(400.0, count).expect("the box holds the block");
        let initial = Simulation::with_method(400.0, particles, method).expect("valid grid");
        group.throughput(Throughput::Elements(count as u64));
        group.bench_function(count.to_string(), |b| {
            b.iter_batched_ref(|| initial.clone(), Simulation::step, BatchSize::LargeInput)
        });
    }
    group.finish();
}

fn configured() -> Criterion {
    Criterion::default().with_profiler(FlamegraphProfiler { guard: None })
}

criterion_group! {
    name = benches;
    config = configured();
    targets = whole_steps, single_stages, state_floor, stage_one_parts, scaling
}
criterion_main!(benches);
