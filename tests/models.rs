//! The two models on the course inputs: the course model leaves the box within a few
//! steps, the fluidanimate variant keeps the fluid in it for 1000 steps.

mod common;

use fluid::io::fld;
use fluid::sim::params::{BOX_MAX, BOX_MIN};
use fluid::Simulation;
use fluid::{Kernel, Method, Model};

fn simulation(size: &str, model: Model) -> Simulation {
    let bytes = std::fs::read(common::input(size)).unwrap();
    let scene = fld::parse(&bytes, size).unwrap();
    let method = Method {
        model,
        kernel: Kernel::Simd,
    };
    Simulation::with_method(scene.ppm.into(), scene.particles, method).unwrap()
}

/// Particles outside the box, and the largest speed.
fn outside_and_top_speed(simulation: &Simulation) -> (usize, f64) {
    let particles = simulation.particles();
    let outside = (0..particles.len())
        .filter(|&s| {
            let p = particles.position(s);
            p.cmplt(BOX_MIN).any() || p.cmpgt(BOX_MAX).any()
        })
        .count();
    let top_speed = (0..particles.len())
        .map(|s| particles.velocity(s).length())
        .fold(0.0, f64::max);
    (outside, top_speed)
}

#[test]
fn the_fluidanimate_model_keeps_both_inputs_in_the_box_for_1000_steps() {
    for size in ["small", "large"] {
        let mut simulation = simulation(size, Model::Fluidanimate);
        simulation.run(1000);
        let (outside, top_speed) = outside_and_top_speed(&simulation);
        println!("{size}: {outside} outside, top speed {top_speed:.4} m/s");
        assert_eq!(outside, 0, "{size}: particles left the box");
        assert!(
            top_speed > 0.01 && top_speed < 0.2,
            "{size}: top speed {top_speed}"
        );
    }
}

#[test]
fn the_course_model_leaves_the_box_within_five_steps() {
    for size in ["small", "large"] {
        let mut simulation = simulation(size, Model::Course);
        simulation.run(5);
        let (outside, top_speed) = outside_and_top_speed(&simulation);
        println!("{size}: {outside} outside, top speed {top_speed:.1} m/s");
        assert!(
            outside * 10 > simulation.particles().len() * 9,
            "{size}: {outside} outside"
        );
        assert!(top_speed > 1e3, "{size}: top speed {top_speed}");
    }
}
