//! The time step: fixed (the course's 1 ms, or any other), or adaptive from the state of
//! each step in the form the SPH codes use (DualSPHysics, PySPH): a Courant constant C
//! times the shortest of the time scales a model names ([`Limit`]; each model's
//! criteria are in its module of [`crate::sim::model`]). And the leapfrog of a step whose
//! length differs from the last one's.

use crate::sim::particles::Particles;

/// How each step's length is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// Every step this long (seconds).
    Fixed(f64),
    /// Each step C times the shortest time scale of the state (the model's
    /// [`crate::sim::model::Dynamics::adaptive_step`]).
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
    /// 2 / lambda, the explicit limit of the viscosity's damping at rate lambda.
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

/// Whether `seconds` can be a time or a time step: positive and a normal f64 (from
/// 2.2e-308 s; a subnormal one overflows the ratios of times, such as the seconds of
/// computation per simulated second).
pub fn is_time(seconds: f64) -> bool {
    seconds.is_normal() && seconds > 0.0
}

/// The largest |a| and the largest |hv| (half-step speed) of `particles`, which the
/// models' adaptive steps scale from; non-finite values are skipped (0 without any).
pub fn largest_acceleration_and_speed(particles: &Particles) -> (f64, f64) {
    let largest = |arrays: &[Vec<f64>; 3]| {
        (0..particles.len())
            .map(|s| arrays[0][s].powi(2) + arrays[1][s].powi(2) + arrays[2][s].powi(2))
            .filter(|x| x.is_finite())
            .fold(0.0f64, f64::max)
            .sqrt()
    };
    (largest(&particles.a), largest(&particles.hv))
}

/// How a step advances the state from the accelerations of its start. Both kick the
/// half-step velocities and drift the positions (a leapfrog); they differ in the
/// velocities the velocity-dependent forces read and in where the walls judge positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum Integrator {
    /// SPEC.md's: the viscosity and the wall damping of step n read v_{n-1}, the last
    /// step's synchronised velocity, and the wall penalty judges the positions one step
    /// ahead, p_n + hv dt (the weakly compressible model: velocities predicted to the
    /// half step, densities advanced by a whole step's rate). First order in dt.
    #[default]
    Leapfrog,
    /// Velocity Verlet with predicted velocities: the forces of step n read velocities
    /// (and a carried density) predicted to t_n from the last step's rates,
    /// hv_{n-1/2} + a_{n-1} dt_{n-1} / 2, the walls judge the positions at t_n, carried
    /// densities are staggered as the velocities are, and the first step kicks by half
    /// a step (the input's half-step velocities taken as those at t = 0). Second order
    /// in dt, for
    /// the cost of one pass over the particles a step.
    Verlet,
}

impl Integrator {
    /// Every integrator.
    pub const ALL: [Integrator; 2] = [Integrator::Leapfrog, Integrator::Verlet];

    /// The name the command lines and CSV files use.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Leapfrog => "leapfrog",
            Integrator::Verlet => "verlet",
        }
    }
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
    /// The integrator the step belongs to.
    pub integrator: Integrator,
}

impl Leapfrog {
    /// A step of SPEC.md's leapfrog of `dt` after a step of the same length.
    pub fn fixed(dt: f64) -> Leapfrog {
        Leapfrog::after(Integrator::Leapfrog, dt, dt)
    }

    /// A step of `dt` of `integrator` after one of `previous` (0 for the first step of
    /// the velocity Verlet: a half kick).
    pub fn after(integrator: Integrator, previous: f64, dt: f64) -> Leapfrog {
        Leapfrog {
            dt,
            kick: (previous + dt) / 2.0,
            sync: previous,
            integrator,
        }
    }

    /// How far ahead of the step's start the wall penalty judges positions: the step
    /// (SPEC.md's p + hv dt) or none (Verlet).
    pub fn lookahead(&self) -> f64 {
        match self.integrator {
            Integrator::Leapfrog => self.dt,
            Integrator::Verlet => 0.0,
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
                    sync: dt,
                    integrator: Integrator::Leapfrog,
                }
            );
        }
        let step = Leapfrog::after(Integrator::Leapfrog, 1e-3, 3e-3);
        assert_eq!((step.kick, step.sync), (2e-3, 1e-3));
        assert_eq!(step.lookahead(), 3e-3);
        // The Verlet's first step: a half kick, its walls at the step's start.
        let first = Leapfrog::after(Integrator::Verlet, 0.0, 3e-3);
        assert_eq!(
            (first.kick, first.sync, first.lookahead()),
            (1.5e-3, 0.0, 0.0)
        );
    }
}
