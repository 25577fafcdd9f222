//! Criterion benchmarks of whole time steps on the bundled inputs.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use fluid::fld;
use fluid::simulation::Simulation;
use std::path::Path;

fn load(name: &str) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/in")
        .join(name);
    let bytes = std::fs::read(&path).expect("bundled input");
    let scene = fld::parse(&bytes, name).expect("valid input");
    Simulation::new(scene.ppm.into(), scene.particles).expect("valid grid")
}

fn step(c: &mut Criterion) {
    for name in ["small.fld", "large.fld"] {
        let initial = load(name);
        c.bench_function(&format!("step/{name}"), |b| {
            b.iter_batched_ref(|| initial.clone(), Simulation::step, BatchSize::LargeInput)
        });
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
