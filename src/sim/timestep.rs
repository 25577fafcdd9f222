//! The time step: fixed (the course's 1 ms, or any other), or adaptive from the state of
//! each step in the form the SPH codes use (DualSPHysics, PySPH): a Courant constant C
//! times the smallest of a force criterion, an acoustic one, and the explicit limits of
//! the viscosity and of the walls. And the leapfrog of a step whose length differs from
//! the last one's.

use crate::sim::method::Model;
use crate::sim::params::{Params, COLLISION_STIFFNESS, DAMPING, FLUID_DENSITY, PRESSURE_STIFFNESS};
use crate::sim::particles::Particles;
use std::f64::consts::PI;

/// How each step's length is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// Every step this long (seconds).
    Fixed(f64),
    /// Each step C times the shortest time scale of the state ([`adaptive_step`]).
    Adaptive {
        /// The Courant constant C (the SPH codes use about 0.2-0.4).
        courant: f64,
    },
}

/// Which time scale set an adaptive step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Limit {
    /// A fixed step: no criterion.
    Fixed,
    /// sqrt(h / |a|) of the particle with the largest acceleration.
    Force,
    /// h / (c + |hv|) of the fastest particle (hv its half-step velocity), c the sound
    /// speed of the pressure law.
    Speed,
    /// 2 / lambda, the explicit limit of the viscosity's damping at rate lambda
    /// ([`viscous_rate`]).
    Viscosity,
    /// min(2 / d_v, 2 / sqrt(s_c)), the explicit limit of the walls' damping and spring.
    Walls,
    /// Cut short to land on a requested time.
    Landing,
}

impl Limit {
    /// Every criterion.
    pub const ALL: [Limit; 6] = [
        Limit::Fixed,
        Limit::Force,
        Limit::Speed,
        Limit::Viscosity,
        Limit::Walls,
        Limit::Landing,
    ];

    /// The criterion's name in CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Limit::Fixed => "fixed",
            Limit::Force => "force",
            Limit::Speed => "speed",
            Limit::Viscosity => "viscosity",
            Limit::Walls => "walls",
            Limit::Landing => "landing",
        }
    }
}

/// The sound speed of the models' pressure law p = p_s (rho - rho_0): sqrt(p_s) m/s.
pub fn sound_speed() -> f64 {
    PRESSURE_STIFFNESS.sqrt()
}

/// The explicit stability limit of the walls' penalty (s): min(2 / d_v, 2 / sqrt(s_c)).
pub fn walls_limit() -> f64 {
    (2.0 / DAMPING).min(2.0 / COLLISION_STIFFNESS.sqrt())
}

/// The rate (1/s) at which `model`'s viscosity damps a particle's velocity relative to
/// its neighbours' in fluid at rest: each pair adds viscosity_factor * w / (rho_i rho_j)
/// times the velocity difference, w = 1 (course) or h - r <= h (fluidanimate), and a
/// particle at rest has (4/3) pi (h ppm)^3 = 20.4 neighbours within h. An explicit step
/// is stable below about 2 / rate: for the course model 0.4 ms at 100 particles per metre
/// and 15 us at 300, for fluidanimate 24 and 2.7 ms (the stability map's limits).
pub fn viscous_rate(params: &Params, model: Model) -> f64 {
    let neighbours = 4.0 / 3.0 * PI * (params.h * params.ppm).powi(3);
    let weight = match model {
        Model::Course => 1.0,
        Model::Fluidanimate => params.h,
        // Its viscosity is Monaghan's, within its own CFL step (crate::sim::wcsph).
        Model::Wcsph => 0.0,
    };
    neighbours * params.viscosity_factor * weight / (FLUID_DENSITY * FLUID_DENSITY)
}

/// The adaptive step of a state whose accelerations (pairs and gravity, stages 2-5) are
/// computed: C * min(min_i sqrt(h / |a_i|), h / (c + max_i |hv_i|), 2 / lambda, walls)
/// with lambda `model`'s [`viscous_rate`] and walls = min(2 / d_v, 2 / sqrt(s_c)) =
/// 11.5 ms, and the criterion that set it. The last two are explicit stability limits.
/// Non-finite values are skipped (the run's own checks report them).
pub fn adaptive_step(
    params: &Params,
    model: Model,
    particles: &Particles,
    courant: f64,
) -> (f64, Limit) {
    let n = particles.len();
    let squared = |arrays: &[Vec<f64>; 3], slot: usize| {
        arrays[0][slot].powi(2) + arrays[1][slot].powi(2) + arrays[2][slot].powi(2)
    };
    let (mut largest_a2, mut largest_v2) = (0.0f64, 0.0f64);
    for slot in 0..n {
        let a2 = squared(&particles.a, slot);
        let v2 = squared(&particles.hv, slot);
        if a2.is_finite() {
            largest_a2 = largest_a2.max(a2);
        }
        if v2.is_finite() {
            largest_v2 = largest_v2.max(v2);
        }
    }
    let criteria = [
        (
            (params.h / largest_a2.sqrt()).sqrt(), // infinite without accelerations
            Limit::Force,
        ),
        (params.h / (sound_speed() + largest_v2.sqrt()), Limit::Speed),
        (2.0 / viscous_rate(params, model), Limit::Viscosity),
        (walls_limit(), Limit::Walls),
    ];
    let (scale, limit) =
        criteria
            .into_iter()
            .fold((f64::INFINITY, Limit::Walls), |best, criterion| {
                if criterion.0 < best.0 {
                    criterion
                } else {
                    best
                }
            });
    (courant * scale, limit)
}

/// The step lengths the leapfrog of one step uses, with the state (p_n, hv_{n-1/2},
/// v_{n-1}) and a_n: v_n = hv + a sync / 2; hv_{n+1/2} = hv + a kick;
/// p_{n+1} = p + hv_{n+1/2} dt, where sync is the last step's length and kick the mean of
/// the two. With equal steps this is SPEC.md's stage 7 bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leapfrog {
    /// This step's length.
    pub dt: f64,
    /// (last step's length + dt) / 2: the half-step velocity's change per unit a.
    pub kick: f64,
    /// The last step's length: v_n = hv_{n-1/2} + a sync / 2.
    pub sync: f64,
}

impl Leapfrog {
    /// A step of `dt` after a step of the same length.
    pub fn fixed(dt: f64) -> Leapfrog {
        Leapfrog::after(dt, dt)
    }

    /// A step of `dt` after one of `previous`.
    pub fn after(previous: f64, dt: f64) -> Leapfrog {
        Leapfrog {
            dt,
            kick: (previous + dt) / 2.0,
            sync: previous,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::TIME_STEP;

    #[test]
    fn equal_steps_kick_by_dt_exactly() {
        for dt in [TIME_STEP, 0.1, 3e-7, 0.0025] {
            assert_eq!(
                Leapfrog::fixed(dt),
                Leapfrog {
                    dt,
                    kick: dt,
                    sync: dt
                }
            );
        }
        let step = Leapfrog::after(1e-3, 3e-3);
        assert_eq!((step.kick, step.sync), (2e-3, 1e-3));
    }

    fn particles_with(a: [f64; 3], hv: [f64; 3]) -> Particles {
        let mut particles = Particles::zeroed(2);
        for axis in 0..3 {
            particles.a[axis][1] = a[axis];
            particles.hv[axis][1] = hv[axis];
        }
        particles
    }

    const STABLE: Model = Model::Fluidanimate;

    #[test]
    fn each_criterion_can_set_the_step() {
        let params = Params::new(200.0);
        let c = sound_speed();
        // At rest with gravity only: the acoustic time h / c is the shortest.
        let rest = particles_with([0.0, -9.8, 0.0], [0.0; 3]);
        let (dt, limit) = adaptive_step(&params, STABLE, &rest, 0.3);
        assert_eq!(limit, Limit::Speed);
        assert!((dt - 0.3 * params.h / c).abs() < 1e-15);
        // A violent state: |a| = 5e4 m/s^2 gives sqrt(h / |a|) well below h / c.
        let violent = particles_with([3e4, -4e4, 0.0], [1.0, 0.0, 0.0]);
        let (dt, limit) = adaptive_step(&params, STABLE, &violent, 0.25);
        assert_eq!(limit, Limit::Force);
        assert!((dt - 0.25 * (params.h / 5e4).sqrt()).abs() < 1e-15);
        // Fast particles shorten the acoustic time.
        let fast = particles_with([0.0; 3], [0.0, 0.0, 10.0]);
        let (dt, limit) = adaptive_step(&params, STABLE, &fast, 1.0);
        assert_eq!(limit, Limit::Speed);
        assert!((dt - params.h / (c + 10.0)).abs() < 1e-15);
        // The course model's viscosity, and fluidanimate's at finer resolution.
        for (ppm, model) in [(200.0, Model::Course), (292.0, STABLE)] {
            let params = Params::new(ppm);
            let (dt, limit) = adaptive_step(&params, model, &rest, 0.3);
            assert_eq!(limit, Limit::Viscosity, "{model:?} at {ppm}");
            assert!((dt - 0.6 / viscous_rate(&params, model)).abs() < 1e-15);
        }
        // Coarse particles at rest: the walls' limit is the shortest.
        let coarse = Params::new(40.0);
        let (dt, limit) = adaptive_step(&coarse, STABLE, &particles_with([0.0; 3], [0.0; 3]), 0.5);
        assert_eq!(limit, Limit::Walls);
        assert_eq!(dt, 0.5 * walls_limit());
        assert!((walls_limit() - 2.0 / COLLISION_STIFFNESS.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn the_viscous_limit_is_the_stability_maps() {
        // 2 / rate: 0.41 ms for the course model at 100 particles per metre, which is
        // stable at 0.25 ms and fails at 0.5 ms; 2.7 ms for fluidanimate at 300, stable at
        // 2 ms and failing at 4 ms (README's stability map).
        let limit = |ppm: f64, model| 2.0 / viscous_rate(&Params::new(ppm), model);
        assert!((limit(100.0, Model::Course) - 4.06e-4).abs() < 1e-6);
        assert!((limit(300.0, STABLE) - 2.66e-3).abs() < 1e-5);
        let params = Params::new(150.0);
        let ratio = viscous_rate(&params, Model::Course) / viscous_rate(&params, STABLE);
        assert!((ratio * params.h - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_calm_state_takes_longer_steps_than_a_violent_one() {
        let params = Params::new(200.0);
        let calm = particles_with([0.0, -9.8, 0.0], [0.0; 3]);
        let violent = particles_with([2e3, 0.0, 0.0], [0.0, 3.0, 0.0]);
        let calm = adaptive_step(&params, STABLE, &calm, 0.3).0;
        let violent = adaptive_step(&params, STABLE, &violent, 0.3).0;
        assert!(calm > 2.0 * violent, "{calm} against {violent}");
    }

    #[test]
    fn non_finite_values_do_not_set_the_step() {
        let params = Params::new(200.0);
        let particles = particles_with([f64::NAN, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0]);
        let (dt, limit) = adaptive_step(&params, STABLE, &particles, 0.3);
        assert_eq!(limit, Limit::Speed);
        assert!(dt.is_finite() && dt > 0.0);
    }
}
