//! Accuracy: the error between two states (per field: largest and RMS distance, and the
//! worst particle), and the accuracy-speed sweep, which runs every model and fast kernel
//! against the reference trajectory (the compensated [`Kernel::Reference`]) and records
//! time per step and position error at every step.

use crate::sim::method::{Kernel, Method, Model};
use crate::sim::particles::{vector_at, AxisArrays, Particles};
use crate::sim::simulation::Simulation;
use glam::DVec3;
use std::fmt::Write;
use std::time::Instant;

/// How far one field of a state is from another's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldError {
    /// The largest distance |a_i - b_i| (infinite if a value is not finite).
    pub max: f64,
    /// The root mean square distance.
    pub rms: f64,
    /// The particle (index) of the largest distance.
    pub worst: usize,
}

impl FieldError {
    /// No error: a state against itself.
    pub const ZERO: FieldError = FieldError {
        max: 0.0,
        rms: 0.0,
        worst: 0,
    };

    /// The error of `a` against `b`, particle by particle (`a` and `b` of equal length).
    pub fn between(a: &[DVec3], b: &[DVec3]) -> FieldError {
        assert_eq!(a.len(), b.len(), "states of different sizes");
        let mut error = FieldError::ZERO;
        let mut squares = 0.0;
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            let distance = x.distance(*y);
            let distance = if distance.is_finite() {
                distance
            } else {
                f64::INFINITY
            };
            if distance > error.max {
                error.max = distance;
                error.worst = i;
            }
            squares += distance * distance;
        }
        error.rms = (squares / a.len().max(1) as f64).sqrt();
        error
    }
}

/// The vectors of a field for the first `n` slots.
pub fn vectors(arrays: &AxisArrays, n: usize) -> Vec<DVec3> {
    (0..n).map(|slot| vector_at(arrays, slot)).collect()
}

/// The errors of positions, half velocities and velocities of `a` against `b` (both in
/// file order), or why they cannot be compared.
pub fn compare(a: &Particles, b: &Particles) -> Result<[(&'static str, FieldError); 3], String> {
    let n = a.len();
    if n != b.len() {
        return Err(format!("{n} particles against {}", b.len()));
    }
    Ok([("p", &a.p, &b.p), ("hv", &a.hv, &b.hv), ("v", &a.v, &b.v)]
        .map(|(name, x, y)| (name, FieldError::between(&vectors(x, n), &vectors(y, n)))))
}

/// The positions of a simulation's particles in file order.
pub fn positions_by_id(simulation: &Simulation) -> Vec<DVec3> {
    let particles = simulation.particles();
    let mut positions = vec![DVec3::ZERO; particles.len()];
    for slot in 0..particles.len() {
        positions[particles.id[slot] as usize] = vector_at(&particles.p, slot);
    }
    positions
}

/// The CSV header of the accuracy sweep.
pub const CSV_HEADER: &str =
    "input,particles,model,kernel,step,seconds_per_step,max_error_m,rms_error_m";

/// One method's run against the reference: seconds per step and the error after each step.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// The method run.
    pub method: Method,
    /// Mean wall time of a step (errors are computed outside the timed steps).
    pub seconds_per_step: f64,
    /// The position error after steps 1, 2, ...
    pub errors: Vec<FieldError>,
}

/// Runs `model` from `start` for `steps` steps with the reference kernel and with each
/// of `kernels`, and returns the reference (errors all 0) followed by the kernels, their
/// position errors measured against the reference after every step.
pub fn sweep(start: &Simulation, model: Model, kernels: &[Kernel], steps: u64) -> Vec<Trajectory> {
    let run = |kernel: Kernel, reference: Option<&[Vec<DVec3>]>| {
        let method = Method { model, kernel };
        let mut simulation = start.clone_with_method(method);
        let mut seconds = 0.0;
        let mut states = Vec::new();
        let mut errors = Vec::new();
        for step in 0..steps as usize {
            let started = Instant::now();
            simulation.step();
            seconds += started.elapsed().as_secs_f64();
            let positions = positions_by_id(&simulation);
            match reference {
                Some(reference) => errors.push(FieldError::between(&positions, &reference[step])),
                None => {
                    errors.push(FieldError::ZERO);
                    states.push(positions);
                }
            }
        }
        let trajectory = Trajectory {
            method,
            seconds_per_step: seconds / steps.max(1) as f64,
            errors,
        };
        (trajectory, states)
    };
    let (reference, states) = run(Kernel::Reference, None);
    let mut trajectories = vec![reference];
    for &kernel in kernels {
        trajectories.push(run(kernel, Some(&states)).0);
    }
    trajectories
}

/// The trajectories as CSV rows (with [`CSV_HEADER`]), one per method and step.
pub fn csv(input: &str, particles: usize, trajectories: &[Trajectory]) -> String {
    let mut text = String::new();
    for trajectory in trajectories {
        for (step, error) in trajectory.errors.iter().enumerate() {
            let _ = writeln!(
                text,
                "{input},{particles},{},{},{},{:e},{:e},{:e}",
                trajectory.method.model.name(),
                trajectory.method.kernel.name(),
                step + 1,
                trajectory.seconds_per_step,
                error.max,
                error.rms
            );
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_errors_find_the_worst_particle() {
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let b = [DVec3::ZERO, DVec3::X * 4.0, DVec3::new(0.0, 1.0, 4.0)];
        let error = FieldError::between(&a, &b);
        assert_eq!((error.max, error.worst), (4.0, 2));
        assert!((error.rms - ((9.0 + 16.0) / 3.0f64).sqrt()).abs() < 1e-15);
        let broken = FieldError::between(&[DVec3::NAN], &[DVec3::ZERO]);
        assert_eq!(broken.max, f64::INFINITY);
        assert_eq!(FieldError::between(&a, &a), FieldError::ZERO);
    }

    #[test]
    fn comparing_needs_states_of_one_size() {
        let mut a = Particles::zeroed(2);
        let b = Particles::zeroed(3);
        assert_eq!(compare(&a, &b).unwrap_err(), "2 particles against 3");
        a.hv[1][1] = 2.0;
        let [p, hv, v] = compare(&a, &Particles::zeroed(2)).unwrap();
        assert_eq!((p.0, p.1.max), ("p", 0.0));
        assert_eq!((hv.0, hv.1.max, hv.1.worst), ("hv", 2.0, 1));
        assert_eq!((v.0, v.1.max), ("v", 0.0));
    }

    #[test]
    fn the_sweep_measures_each_kernel_against_the_reference() {
        let particles = crate::lab::scene::corner_block(150.0, 300);
        let start = Simulation::new(150.0, particles).unwrap();
        let trajectories = sweep(&start, Model::Fluidanimate, &Kernel::FAST, 3);
        let kernels: Vec<Kernel> = trajectories.iter().map(|t| t.method.kernel).collect();
        let mut expected = vec![Kernel::Reference];
        expected.extend(Kernel::FAST);
        assert_eq!(kernels, expected);
        for trajectory in &trajectories {
            assert_eq!(trajectory.errors.len(), 3);
            assert!(trajectory.seconds_per_step > 0.0);
            let bound = if trajectory.method.kernel == Kernel::Mixed {
                1e-6
            } else {
                1e-12
            };
            for error in &trajectory.errors {
                assert!(error.max < bound, "{trajectory:?}");
            }
        }
        assert!(trajectories[0].errors.iter().all(|e| e.max == 0.0));
        let text = csv("corner.fld", 300, &trajectories);
        assert_eq!(text.lines().count(), 3 * expected.len());
        assert!(text.starts_with("corner.fld,300,fluidanimate,reference,1,"));
    }
}
