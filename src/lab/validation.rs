//! How close a model is to water: the collapse of a water column on a dry floor (the dam
//! break) against the surge-front measurements of Martin and Moyce (1952), the case the
//! SPH codes people trust (DualSPHysics, PySPH, SPHysics) validate with.
//!
//! A column `a` wide and `2a` high stands against the low-x wall, through the box's whole
//! depth (or, in 2-D, in the plane of its section), and is released at t = 0. Its front, the distance x from that wall (a high
//! quantile of x among the particles near the floor, [`FRONT_QUANTILE`], plus half a
//! lattice spacing), is followed in the experiment's dimensionless variables: Z = x / a
//! against T = t sqrt(2 g / a).

use crate::lab::diagnostics::{self, Checks, Diagnostics, Failure, Vitals};
use crate::lab::progress::Progress;
use crate::lab::scene;
use crate::sim::params::{Domain, BOX_MAX, BOX_MIN, GRAVITY, RADIUS_MULTIPLIER};
use crate::sim::particles::Particles;
use crate::sim::simulation::Simulation;

/// Martin and Moyce (1952), "An experimental study of the collapse of liquid columns on a
/// rigid horizontal plane", Phil. Trans. R. Soc. A 244, 312-324, n^2 = 2, a = 1.125 in
/// (their figure 3): the surge front as (T, Z), as tabulated in PySPH's
/// `pysph/examples/db_exp_data.py`.
pub const MARTIN_MOYCE: [(f64, f64); 10] = [
    (0.849, 1.245),
    (1.212, 1.443),
    (1.602, 1.884),
    (2.283, 2.689),
    (2.950, 3.728),
    (3.598, 4.528),
    (3.905, 4.999),
    (4.592, 5.841),
    (4.961, 6.271),
    (5.316, 6.717),
];

/// Koshizuka and Oka (1996), "Moving-particle semi-implicit method for fragmentation of
/// incompressible fluid", Nucl. Sci. Eng. 123, 421-434 (their dam-break experiment, a
/// column a wide and 2a high): the surge front as (T, Z) in the same variables, as
/// tabulated in PySPH's `pysph/examples/db_exp_data.py` (less its starting point
/// (0, 1)).
pub const KOSHIZUKA_OKA: [(f64, f64); 8] = [
    (0.381, 1.111),
    (0.769, 1.252),
    (1.153, 1.505),
    (1.537, 1.892),
    (1.935, 2.241),
    (2.323, 2.615),
    (2.719, 3.003),
    (3.096, 3.624),
];

/// A set of measured fronts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurements {
    /// Who measured them, and when.
    pub name: &'static str,
    /// The fronts as (T, Z).
    pub points: &'static [(f64, f64)],
}

/// Every experiment the dam break is compared with.
pub const EXPERIMENTS: [Measurements; 2] = [
    Measurements {
        name: "Martin and Moyce (1952)",
        points: &MARTIN_MOYCE,
    },
    Measurements {
        name: "Koshizuka and Oka (1996)",
        points: &KOSHIZUKA_OKA,
    },
];

/// The quantile of x near the floor taken as the front: high enough that its lag behind
/// the leading edge stays small as the fluid spreads (1% of the spread), low enough that a
/// few strays ahead do not move it. Half a lattice spacing is added, the fluid's extent
/// beyond its last particles (the column of width a has its last particles at a - s/2).
pub const FRONT_QUANTILE: f64 = 0.99;

/// A dam break: the column's width `a` (its height is 2a) and its lattice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamBreak {
    /// The column's width a (m).
    pub width: f64,
    /// Particles per metre of the lattice.
    pub ppm: f64,
    /// Seed of the lattice jitter.
    pub seed: u64,
    /// In 2-D: the course box's x-y section, the column's section in the plane.
    pub planar: bool,
}

impl DamBreak {
    /// The column's particles, at rest: a wide and 2a high (see [`Self::column_width`]).
    pub fn particles(&self) -> Result<Particles, String> {
        let a = self.column_width();
        scene::water_column(self.ppm, self.seed, a, 2.0 * a, &self.domain())
    }

    /// The box it runs in: the course's, or in 2-D its section ([`Domain::section`]).
    pub fn domain(&self) -> Domain {
        match self.planar {
            true => Domain::COURSE.section(self.ppm),
            false => Domain::COURSE,
        }
    }

    /// Its number of dimensions, 2 or 3.
    pub fn dimensions(&self) -> usize {
        self.domain().dimensions()
    }

    /// The width of the column the lattice gives: its columns of particles (those whose
    /// centre lies within `width`) times the spacing. This is the experiment's a.
    pub fn column_width(&self) -> f64 {
        (self.width * self.ppm - 0.5).ceil().max(1.0) / self.ppm
    }

    /// Seconds per unit of the experiment's T: sqrt(a / (2 g)).
    pub fn time_unit(&self) -> f64 {
        (self.column_width() / (2.0 * -GRAVITY.y)).sqrt()
    }

    /// The largest Z the box allows: its length over a (the front stops at the far wall).
    pub fn largest_z(&self) -> f64 {
        (BOX_MAX.x - BOX_MIN.x) / self.column_width()
    }
}

/// The front at one moment of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrontSample {
    /// Steps run.
    pub step: u64,
    /// Simulated time (s).
    pub time: f64,
    /// The experiment's dimensionless time T.
    pub t: f64,
    /// The front's distance from the low-x wall (m).
    pub front: f64,
    /// The front over the column's width, Z.
    pub z: f64,
    /// The largest |rho - rho_0| / rho_0 of the state.
    pub max_density_error: f64,
    /// The mean |rho - rho_0| / rho_0 of the state.
    pub mean_density_error: f64,
}

/// The fronts of a run, and why it stopped early, if it did.
#[derive(Debug, Clone, PartialEq)]
pub struct Collapse {
    /// The samples, every few steps from step 0.
    pub samples: Vec<FrontSample>,
    /// The failure that stopped the run before the last T (and at which T).
    pub failure: Option<(f64, Failure)>,
}

/// Runs `simulation` (the column of `dam`, placed) until the experiment's T reaches
/// `until`, sampling the front at step 0 and every `every` steps. The run stops at the
/// first failure of [`Checks`] (non-finite values, particles out of the box, energy
/// growth) or at an adaptive step shorter than `shortest` seconds: a model that blows up
/// is reported, not followed.
pub fn collapse(
    simulation: &mut Simulation,
    dam: &DamBreak,
    until: f64,
    every: u64,
    progress: &mut Progress,
    shortest: f64,
) -> Collapse {
    let unit = dam.time_unit();
    let checks = Checks::from(&Vitals::of(simulation));
    let sample = |simulation: &Simulation, step: u64| {
        let state = Diagnostics::of(simulation, step);
        let front = diagnostics::front_quantile(simulation, FRONT_QUANTILE)
            .map_or(f64::NAN, |x| x + 0.5 / dam.ppm);
        FrontSample {
            step,
            time: simulation.time(),
            t: simulation.time() / unit,
            front,
            z: front / dam.column_width(),
            max_density_error: state.max_density_error,
            mean_density_error: state.mean_density_error,
        }
    };
    let mut samples = vec![sample(simulation, 0)];
    let mut step = 0;
    let end = until * unit;
    while !simulation.has_reached(end) {
        simulation.step_towards(end);
        step += 1;
        progress.show(step, simulation.time());
        let collapsed =
            diagnostics::step_collapsed(simulation, shortest).then_some(Failure::StepCollapsed);
        if let Some(failure) = checks.failure(&Vitals::of(simulation)).or(collapsed) {
            return Collapse {
                samples,
                failure: Some((simulation.time() / unit, failure)),
            };
        }
        if step % every == 0 || simulation.has_reached(end) {
            samples.push(sample(simulation, step));
        }
    }
    Collapse {
        samples,
        failure: None,
    }
}

/// The model's front at one experimental point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// The experiment's name ([`Measurements::name`]).
    pub experiment: &'static str,
    /// The experiment's T.
    pub t: f64,
    /// The experiment's Z.
    pub z_experiment: f64,
    /// The model's Z at that T (linear between samples), if the run reached T and the
    /// front had not reached the far wall.
    pub z_model: Option<f64>,
}

impl Comparison {
    /// (Z_model - Z_experiment) / Z_experiment.
    pub fn relative_error(&self) -> Option<f64> {
        self.z_model
            .map(|z| (z - self.z_experiment) / self.z_experiment)
    }
}

/// The run's front at every point of every experiment up to its last sample. A point
/// whose Z is beyond what the box allows (less a margin of the course's smoothing length,
/// 1.695 spacings, for every model) is left out: there the box, not the model, stops the
/// front.
pub fn compare(collapse: &Collapse, dam: &DamBreak) -> Vec<Comparison> {
    let samples = &collapse.samples;
    let margin = RADIUS_MULTIPLIER / dam.ppm;
    let wall = dam.largest_z() - margin / dam.column_width();
    EXPERIMENTS
        .iter()
        .flat_map(|experiment| {
            experiment
                .points
                .iter()
                .map(|&point| (experiment.name, point))
        })
        .filter(|&(_, (_, z))| z < wall)
        .map(|(experiment, (t, z_experiment))| {
            let after = samples.iter().position(|sample| sample.t >= t);
            let z_model = after.filter(|&i| i > 0).map(|i| {
                let (a, b) = (&samples[i - 1], &samples[i]);
                let share = (t - a.t) / (b.t - a.t);
                a.z + share * (b.z - a.z)
            });
            Comparison {
                experiment,
                t,
                z_experiment,
                z_model: z_model.filter(|z| z.is_finite()),
            }
        })
        .collect()
}

/// The errors of the comparisons of `experiment` (every experiment's if `None`) with T
/// at most `t`: the largest |relative error| and the mean |relative error|, if any
/// comparison was made.
pub fn errors(comparisons: &[Comparison], experiment: Option<&str>, t: f64) -> Option<(f64, f64)> {
    let errors: Vec<f64> = comparisons
        .iter()
        .filter(|comparison| comparison.t <= t)
        .filter(|comparison| experiment.is_none_or(|name| comparison.experiment == name))
        .filter_map(Comparison::relative_error)
        .map(f64::abs)
        .collect();
    let worst = errors.iter().copied().reduce(f64::max)?;
    Some((worst, errors.iter().sum::<f64>() / errors.len() as f64))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dam() -> DamBreak {
        DamBreak {
            width: 0.03,
            ppm: 200.0,
            seed: 1,
            planar: false,
        }
    }

    fn sample(t: f64, z: f64) -> FrontSample {
        FrontSample {
            step: 0,
            time: 0.0,
            t,
            front: z * 0.03,
            z,
            max_density_error: 0.0,
            mean_density_error: 0.0,
        }
    }

    #[test]
    fn the_column_is_a_wide_and_2a_high_through_the_whole_depth() {
        let particles = dam().particles().unwrap();
        let spacing = 1.0 / 200.0;
        let (mut high, mut low) = (glam::DVec3::splat(f64::MIN), glam::DVec3::splat(f64::MAX));
        for slot in 0..particles.len() {
            high = high.max(particles.position(slot));
            low = low.min(particles.position(slot));
        }
        let jitter = scene::JITTER * spacing;
        assert!((low - (BOX_MIN + 0.5 * spacing)).abs().max_element() <= jitter + 1e-12);
        assert!((high.x - (BOX_MIN.x + 0.03 - 0.5 * spacing)).abs() <= jitter + 1e-12);
        assert!((high.y - (BOX_MIN.y + 0.06 - 0.5 * spacing)).abs() <= jitter + 1e-12);
        assert!((high.z - (BOX_MAX.z - 0.5 * spacing)).abs() <= jitter + 1e-12);
        assert_eq!(particles.len(), 6 * 12 * 26);
    }

    #[test]
    fn time_and_length_follow_the_experiment_s_scaling() {
        // T = t sqrt(2 g / a): for a = 0.03 m, one unit of T is sqrt(0.03 / 19.6) s.
        assert!(
            (dam().column_width() - 0.03).abs() < 1e-15,
            "6 columns of 5 mm"
        );
        assert!((dam().time_unit() - 0.039123).abs() < 1e-6);
        assert!((dam().largest_z() - 0.13 / 0.03).abs() < 1e-12);
        // At 150 per metre, 4 columns of 6.67 mm have their centres within 30 mm.
        let coarse = DamBreak {
            ppm: 150.0,
            ..dam()
        };
        assert!((coarse.column_width() - 4.0 / 150.0).abs() < 1e-15);
        assert_eq!(
            coarse.particles().unwrap().len(),
            4 * 8 * 19,
            "2a = 8 rows high"
        );
    }

    #[test]
    fn comparisons_interpolate_between_samples_and_stop_at_the_run_s_end_and_the_wall() {
        let collapse = Collapse {
            samples: vec![sample(0.0, 1.0), sample(1.0, 1.5), sample(2.0, 2.5)],
            failure: None,
        };
        let comparisons = compare(&collapse, &dam());
        // Z < 4.33 - 0.28 (1.695 spacings of 5 mm over 30 mm): Martin and Moyce's first
        // five points and all eight of Koshizuka and Oka's; T <= 2 sampled: the first
        // three and five.
        let of = |name: &str| -> Vec<Comparison> {
            comparisons
                .iter()
                .copied()
                .filter(|c| c.experiment == name)
                .collect()
        };
        let (mm, ko) = (of(EXPERIMENTS[0].name), of(EXPERIMENTS[1].name));
        assert_eq!((mm.len(), ko.len()), (5, 8));
        let z = 1.0 + 0.849 * 0.5;
        assert!((mm[0].z_model.unwrap() - z).abs() < 1e-12);
        let error = mm[0].relative_error().unwrap();
        assert!((error - (z - 1.245) / 1.245).abs() < 1e-12);
        assert!((mm[2].z_model.unwrap() - (1.5 + 0.602)).abs() < 1e-12);
        assert_eq!(mm[3].z_model, None, "T = 2.283 is after the run");
        assert!((ko[0].z_model.unwrap() - (1.0 + 0.381 * 0.5)).abs() < 1e-12);
        assert_eq!(ko[5].z_model, None, "T = 2.323 is after the run");
        let expected: Vec<f64> = mm[..3]
            .iter()
            .map(|c| c.relative_error().unwrap().abs())
            .collect();
        let (worst, mean) = errors(&comparisons, Some(EXPERIMENTS[0].name), 3.6).unwrap();
        assert_eq!(worst, expected.iter().copied().fold(0.0, f64::max));
        assert!((mean - expected.iter().sum::<f64>() / 3.0).abs() < 1e-15);
        let (both, _) = errors(&comparisons, None, 3.6).unwrap();
        assert!(both >= worst);
        assert_eq!(errors(&comparisons, None, 0.3), None);
    }

    #[test]
    fn a_released_column_spreads_and_the_run_stops_at_its_end() {
        let dam = DamBreak {
            width: 0.03,
            ppm: 150.0,
            seed: 1,
            planar: false,
        };
        let method = crate::sim::method::Method {
            model: crate::sim::model::Model::Fluidanimate,
            kernel: crate::sim::kernel::Kernel::NATIVE,
        };
        let mut simulation =
            Simulation::with_method(150.0, dam.particles().unwrap(), method).unwrap();
        let goal = crate::lab::progress::Goal::Until(dam.time_unit());
        let mut progress = Progress::towards(goal);
        let collapse = collapse(&mut simulation, &dam, 1.0, 5, &mut progress, 0.0);
        assert_eq!(collapse.failure, None);
        let (first, last) = (collapse.samples[0], *collapse.samples.last().unwrap());
        assert!((first.z - 1.0).abs() < 0.1, "{first:?}");
        assert!((last.t - 1.0).abs() < 1e-9, "{last:?}");
        assert!(last.z > first.z + 0.05, "the front moves: {last:?}");
        assert!(collapse.samples.windows(2).all(|w| w[1].step > w[0].step));
    }
}
