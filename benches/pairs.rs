//! The roofline of the stable model's pair passes on `large.fld` (dense, its first step),
//! per SIMD kernel, all in nanoseconds per pair closer than h (criterion's throughput is
//! in pairs): the floor, each pass's arithmetic alone over pairs packed beforehand
//! (`floor/...`), beside the parts of a step that find and fetch the pairs, the neighbour
//! lists' build (`lists/build`), and each pass over the lists (`lists/densities`,
//! `lists/accelerations`) on every instruction set this CPU runs, on the half lists and
//! (`-rows`) on the full lists' rows, across particles. `perf/README.md` tabulates them.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use fluid::io::fld;
use fluid::sim::isa::InstructionSet;
use fluid::sim::kernel::floor::PackedPairs;
use fluid::sim::lists::{ListLayout, NeighbourLists, PairStructure};
use fluid::sim::stages::Stage;
use fluid::{Kernel, Method, Model, Simulation};
use std::path::Path;

/// The stable model on `large.fld` with `kernel`, placed and its densities computed.
fn placed(kernel: Kernel, isa: InstructionSet, layout: ListLayout) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/in/large.fld");
    let bytes = std::fs::read(&path).expect("bundled input");
    let scene = fld::parse(&bytes, "large.fld").expect("valid input");
    let method = Method {
        model: Model::Fluidanimate,
        kernel,
    };
    let mut sim = Simulation::with_method(scene.ppm.into(), scene.particles, method).unwrap();
    sim.set_instruction_set(isa);
    sim.set_pair_structure(match layout {
        ListLayout::Half => PairStructure::Lists,
        ListLayout::Rows => PairStructure::Rows,
    });
    sim.run_stage(Stage::Reposition);
    sim
}

fn roofline(c: &mut Criterion) {
    for kernel in [Kernel::Simd, Kernel::Simd8, Kernel::Mixed] {
        let mut sim = placed(kernel, InstructionSet::detected(), ListLayout::Half);
        sim.run_stage(Stage::IncrementDensities);
        sim.run_stage(Stage::TransformDensities);
        let params = *sim.params();
        let lists = sim.lists().expect("a dense scene runs on lists");
        let packed = PackedPairs::new(&params, lists, sim.particles());
        let mut group = c.benchmark_group("floor");
        group.throughput(Throughput::Elements(packed.len() as u64));
        group.bench_function(format!("densities/{}", kernel.name()), |b| {
            b.iter(|| packed.density_floor(kernel, &params))
        });
        group.bench_function(format!("accelerations/{}", kernel.name()), |b| {
            b.iter(|| packed.acceleration_floor::<true>(kernel, &params))
        });
        if kernel == Kernel::Simd8 {
            for isa in InstructionSet::ALL.into_iter().filter(|i| i.is_available()) {
                let name = format!("accelerations-without-divider/simd8/{}", isa.name());
                group.bench_function(name, |b| {
                    b.iter(|| packed.acceleration_floor_without_divider(&params, isa))
                });
            }
        }
        group.finish();
        let mut group = c.benchmark_group("lists");
        group.throughput(Throughput::Elements(packed.len() as u64));
        let layouts = [(ListLayout::Half, ""), (ListLayout::Rows, "-rows")];
        for (isa, (layout, suffix)) in InstructionSet::ALL
            .into_iter()
            .filter(|i| i.is_available())
            .flat_map(|isa| layouts.map(|layout| (isa, layout)))
        {
            let name = |part: &str| format!("{part}{suffix}/{}/{}", kernel.name(), isa.name());
            let mut before = placed(kernel, isa, layout);
            if kernel == Kernel::Simd8 {
                let (tiles, particles) = (before.tiles(), before.particles());
                let mut lists = NeighbourLists::default();
                lists.set_instruction_set(isa);
                lists.set_layout(layout);
                let h = params.h;
                group.bench_function(name("build"), |b| {
                    b.iter(|| {
                        lists
                            .build(tiles, &particles.p, particles.len(), h)
                            .unwrap()
                    })
                });
            }
            for (part, stage) in [
                ("densities", Stage::IncrementDensities),
                ("accelerations", Stage::TransferAccelerations),
            ] {
                group.bench_function(name(part), |b| {
                    b.iter_batched_ref(
                        || before.clone(),
                        |sim| sim.run_stage(stage),
                        BatchSize::LargeInput,
                    )
                });
                before.run_stage(stage);
                if stage == Stage::IncrementDensities {
                    before.run_stage(Stage::TransformDensities);
                }
            }
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = roofline
}
criterion_main!(benches);
