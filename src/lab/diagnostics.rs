//! What a state says about the run: top speed, particles that left the box, kinetic and
//! potential energy, density error against the rest density and pairs closer than h; and
//! the checks that call a run failed (non-finite values, energy growing past a bound,
//! particles leaving the box).

use crate::sim::params::{FLUID_DENSITY, RADIUS_MULTIPLIER};
use crate::sim::particles::vector_at;
use crate::sim::simulation::Simulation;
use crate::sim::timestep::Limit;
use std::fmt;

/// The CSV header of [`Diagnostics::csv_row`].
pub const CSV_HEADER: &str = "step,time_s,max_speed_m_s,outside,kinetic_j,potential_j,\
                              total_j,mean_density_error,max_density_error,pairs_within_h,\
                              dt_s,dt_limit,beyond_f32,pair_lanes";

/// What one scan of the particles tells, without densities: cheap enough to check a run
/// after every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vitals {
    /// Largest |v|.
    pub max_speed: f64,
    /// Particles more than h outside the box.
    pub outside: usize,
    /// Kinetic energy, sum of m |v|^2 / 2.
    pub kinetic: f64,
    /// Potential energy above the box's floor, sum of m g (y - y_min).
    pub potential: f64,
    /// The first particle (by id) with a non-finite position or velocity.
    pub non_finite: Option<u32>,
    /// Particles with a finite value beyond the f32 range (+-3.4e38) that `.fld` files
    /// store: a state that cannot be written.
    pub beyond_f32: usize,
}

impl Vitals {
    /// Scans the particles of `simulation` as they are, in its slot order.
    pub fn of(simulation: &Simulation) -> Vitals {
        let params = simulation.params();
        let particles = simulation.particles();
        let mut vitals = Vitals {
            max_speed: 0.0,
            outside: 0,
            kinetic: 0.0,
            potential: 0.0,
            non_finite: None,
            beyond_f32: 0,
        };
        let domain = params.domain;
        let (low, high) = (domain.min - params.h, domain.max + params.h);
        for slot in simulation.slot_order() {
            let position = vector_at(&particles.p, slot);
            let velocity = vector_at(&particles.v, slot);
            if !(position.is_finite() && velocity.is_finite()) {
                let id = particles.id[slot];
                vitals.non_finite = Some(vitals.non_finite.map_or(id, |k| k.min(id)));
                continue;
            }
            let half_velocity = vector_at(&particles.hv, slot);
            if [position, velocity, half_velocity]
                .iter()
                .any(|vector| !vector.as_vec3().is_finite())
            {
                vitals.beyond_f32 += 1;
            }
            // Scaled by the largest component where the squares overflow: a finite
            // velocity has a finite speed.
            let speed = match velocity.length() {
                speed if speed.is_finite() => speed,
                _ => {
                    let largest = velocity.abs().max_element();
                    largest * (velocity / largest).length()
                }
            };
            vitals.max_speed = vitals.max_speed.max(speed);
            if !(position.cmpge(low).all() && position.cmple(high).all()) {
                vitals.outside += 1;
            }
            vitals.kinetic += 0.5 * params.mass * speed * speed;
            // -m g . (p - min), the y term first (as with gravity down y alone).
            let (g, above) = (domain.gravity, position - domain.min);
            vitals.potential += params.mass * -g.y * above.y;
            vitals.potential -= params.mass * (g.x * above.x + g.z * above.z);
        }
        vitals
    }

    /// Kinetic plus potential energy.
    pub fn total_energy(&self) -> f64 {
        self.kinetic + self.potential
    }

    /// Whether an energy passes the largest f64 (inf in the diagnostics) while every
    /// particle's state is finite: a blown-up run's.
    pub fn energy_overflows(&self) -> bool {
        !(self.kinetic.is_finite() && self.potential.is_finite() && self.total_energy().is_finite())
    }
}

/// Diagnostics of one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnostics {
    /// Steps run.
    pub step: u64,
    /// Simulated time, the sum of the steps' lengths.
    pub time: f64,
    /// The last step's length and the criterion that set it (none at step 0).
    pub last_step: Option<(f64, Limit)>,
    /// Speed, particles outside, energies, non-finite values.
    pub vitals: Vitals,
    /// Mean of |rho - rho_0| / rho_0.
    pub mean_density_error: f64,
    /// Largest |rho - rho_0| / rho_0.
    pub max_density_error: f64,
    /// Pairs of particles closer than h.
    pub pairs: u64,
    /// The pair lanes a pass over every candidate evaluates on the run's kernel and
    /// neighbour structure ([`Simulation::pair_lanes`]): `pairs` over it is the useful
    /// fraction of the lanes.
    pub pair_lanes: u64,
}

impl Diagnostics {
    /// Measures the state of `simulation` after `step` steps; densities and pairs are those
    /// of the current positions (computed on a copy).
    pub fn of(simulation: &Simulation, step: u64) -> Diagnostics {
        let copy = simulation.with_fresh_densities();
        let particles = copy.particles();
        let n = particles.len();
        let mut diagnostics = Diagnostics {
            step,
            time: simulation.time(),
            last_step: simulation.last_step(),
            vitals: Vitals::of(&copy),
            mean_density_error: 0.0,
            max_density_error: 0.0,
            pairs: 0,
            pair_lanes: copy.pair_lanes(),
        };
        for &density in &particles.rho[..n] {
            let error = (density - FLUID_DENSITY).abs() / FLUID_DENSITY;
            diagnostics.mean_density_error += error / n as f64;
            diagnostics.max_density_error = diagnostics.max_density_error.max(error);
        }
        diagnostics.pairs = PairCounts::of(&copy).within_h;
        diagnostics
    }

    /// Kinetic plus potential energy.
    pub fn total_energy(&self) -> f64 {
        self.vitals.total_energy()
    }

    /// One CSV row, in the order of [`CSV_HEADER`].
    pub fn csv_row(&self) -> String {
        format!(
            "{},{:.6},{},{},{},{},{},{},{},{},{},{},{},{}",
            self.step,
            self.time,
            csv_number(self.vitals.max_speed),
            self.vitals.outside,
            csv_number(self.vitals.kinetic),
            csv_number(self.vitals.potential),
            csv_number(self.total_energy()),
            csv_number(self.mean_density_error),
            csv_number(self.max_density_error),
            self.pairs,
            self.last_step
                .map_or(String::new(), |(dt, _)| csv_number(dt)),
            self.last_step.map_or("", |(_, limit)| limit.name()),
            self.vitals.beyond_f32,
            self.pair_lanes,
        )
    }
}

/// A number for a CSV cell: shortest round-trip decimal, in scientific notation below
/// 1e-5 and from 1e15 on (so a blown-up state never prints hundreds of digits).
fn csv_number(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-5..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The candidate pairs a simulation's tiles hold, and how many of them are closer than h.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PairCounts {
    /// Pairs the tiles hold as candidates (every partner of every first slot of every
    /// tile: what the scalar kernel tests; the SIMD kernels' lanes are
    /// `Simulation::pair_lanes`).
    pub tested: u64,
    /// Those closer than h at the current positions.
    pub within_h: u64,
}

impl PairCounts {
    /// Counts the pairs of the current tiles of `simulation`.
    pub fn of(simulation: &Simulation) -> PairCounts {
        let mut counts = PairCounts::default();
        for_each_candidate(simulation, |_, _, within_h| {
            counts.tested += 1;
            counts.within_h += u64::from(within_h);
        });
        counts
    }
}

/// How many particles of a placed simulation have a partner closer than h.
pub fn partnered(simulation: &Simulation) -> usize {
    let mut has_partner = vec![false; simulation.particles().len()];
    for_each_candidate(simulation, |i, j, within_h| {
        if within_h {
            (has_partner[i], has_partner[j]) = (true, true);
        }
    });
    has_partner.iter().filter(|&&partner| partner).count()
}

/// Visits every candidate pair of the tiles of `simulation` (slots `i` and `j`), with
/// whether it is closer than h.
fn for_each_candidate(simulation: &Simulation, mut visit: impl FnMut(usize, usize, bool)) {
    let (particles, h2) = (simulation.particles(), simulation.params().h2);
    for tile in simulation.tiles() {
        for i in tile.firsts() {
            for j in tile.partners(i) {
                let r2 = (vector_at(&particles.p, i) - vector_at(&particles.p, j)).length_squared();
                visit(i, j, r2 < h2);
            }
        }
    }
}

/// Whether the last step of `simulation` was an adaptive one shorter than `shortest`
/// seconds: the run has collapsed (fixed steps and steps cut to land on a time never do).
pub fn step_collapsed(simulation: &Simulation, shortest: f64) -> bool {
    simulation
        .last_step()
        .is_some_and(|(dt, limit)| !matches!(limit, Limit::Fixed | Limit::Landing) && dt < shortest)
}

/// Fewest particles near the floor for [`front`] to name a front.
pub const FRONT_PARTICLES: usize = 10;

/// The front of a fluid spreading along +x: the 95th percentile of x (measured from the
/// box's low-x wall) among the particles within 2h of the floor (h the course's
/// smoothing length, 1.695 spacings, whatever the model, so that every model's front is
/// taken in the same band), so that a few strays ahead of the fluid do not move it.
/// `None` with fewer than [`FRONT_PARTICLES`] there.
pub fn front(simulation: &Simulation) -> Option<f64> {
    front_quantile(simulation, 0.95)
}

/// As [`front`], with the `quantile` (in (0, 1]) of x among the particles near the floor.
pub fn front_quantile(simulation: &Simulation, quantile: f64) -> Option<f64> {
    let particles = simulation.particles();
    let h = RADIUS_MULTIPLIER / simulation.params().ppm;
    let floor = simulation.params().domain.min;
    let mut xs: Vec<f64> = (0..particles.len())
        .filter(|&slot| {
            let y = particles.p[1][slot];
            y.is_finite() && y < floor.y + 2.0 * h
        })
        .map(|slot| particles.p[0][slot] - floor.x)
        .filter(|x| x.is_finite())
        .collect();
    if xs.len() < FRONT_PARTICLES {
        return None;
    }
    xs.sort_unstable_by(f64::total_cmp);
    let rank = ((xs.len() - 1) as f64 * quantile.clamp(0.0, 1.0)).floor() as usize;
    Some(xs[rank])
}

/// Why a run is called failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Failure {
    /// A position, velocity or density is NaN or infinite (particle id).
    NonFinite(u32),
    /// Particles ended more than h outside the box.
    LeftBox(usize),
    /// Kinetic plus potential energy grew past the bound, as a multiple of the first.
    EnergyGrew(f64),
    /// An adaptive step shorter than the run allows ([`step_collapsed`]).
    StepCollapsed,
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::NonFinite(id) => write!(f, "particle {id} is not finite"),
            Failure::LeftBox(1) => write!(f, "1 particle left the box"),
            Failure::LeftBox(count) => write!(f, "{count} particles left the box"),
            Failure::EnergyGrew(factor) if *factor < 1e3 => {
                write!(f, "the energy grew {factor:.2} times")
            }
            Failure::EnergyGrew(factor) => write!(f, "the energy grew {factor:.2e} times"),
            Failure::StepCollapsed => write!(f, "the adaptive step fell below the limit"),
        }
    }
}

impl Failure {
    /// A short name for CSV files: `non-finite`, `left-box`, `energy-grew`.
    pub fn name(&self) -> &'static str {
        match self {
            Failure::NonFinite(_) => "non-finite",
            Failure::LeftBox(_) => "left-box",
            Failure::EnergyGrew(_) => "energy-grew",
            Failure::StepCollapsed => "step-collapsed",
        }
    }

    /// The failure whose text (its `Display`) is `text`, whatever its kind.
    pub fn from_text(text: &str) -> Option<Failure> {
        ["non-finite", "left-box", "energy-grew", "step-collapsed"]
            .into_iter()
            .find_map(|name| Failure::parse(name, text))
    }

    /// The failure a CSV row gives as its [`name`](Failure::name) and its text (the
    /// energy factor as printed, to its two decimals).
    pub fn parse(name: &str, detail: &str) -> Option<Failure> {
        let number = |before: &str, after: &str| -> Option<&str> {
            detail.strip_prefix(before)?.strip_suffix(after)
        };
        Some(match name {
            "non-finite" => {
                Failure::NonFinite(number("particle ", " is not finite")?.parse().ok()?)
            }
            "left-box" => Failure::LeftBox(
                number("", " particles left the box")
                    .or_else(|| number("", " particle left the box"))?
                    .parse()
                    .ok()?,
            ),
            "energy-grew" => {
                Failure::EnergyGrew(number("the energy grew ", " times")?.parse().ok()?)
            }
            "step-collapsed" => Failure::StepCollapsed,
            _ => return None,
        })
    }
}

/// The checks of a stable run, against its first state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checks {
    /// Total energy of the first state.
    pub initial_energy: f64,
    /// Largest allowed growth of the total energy, as a multiple of the first.
    pub energy_factor: f64,
}

impl Checks {
    /// How the energy may grow at most by default: 1.5 times the first state's.
    pub const ENERGY_FACTOR: f64 = 1.5;

    /// Checks against `first`, the state the run starts from.
    pub fn from(first: &Vitals) -> Checks {
        Checks {
            initial_energy: first.total_energy(),
            energy_factor: Self::ENERGY_FACTOR,
        }
    }

    /// The first failure `state` shows: non-finite values, then particles out of the box,
    /// then energy growth.
    pub fn failure(&self, state: &Vitals) -> Option<Failure> {
        if let Some(id) = state.non_finite {
            return Some(Failure::NonFinite(id));
        }
        if state.outside > 0 {
            return Some(Failure::LeftBox(state.outside));
        }
        let factor = state.total_energy() / self.initial_energy;
        (factor > self.energy_factor).then_some(Failure::EnergyGrew(factor))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::{BOX_MAX, BOX_MIN};
    use crate::sim::particles::Particles;
    use crate::sim::timestep::TimeStep;
    use glam::DVec3;

    fn simulation(points: &[(DVec3, DVec3)]) -> Simulation {
        let mut particles = Particles::zeroed(points.len());
        for (slot, (p, v)) in points.iter().enumerate() {
            for axis in 0..3 {
                particles.p[axis][slot] = p[axis];
                particles.v[axis][slot] = v[axis];
            }
        }
        Simulation::new(200.0, particles).unwrap()
    }

    #[test]
    fn energies_speeds_pairs_and_outsiders_of_a_small_state() {
        let floor = BOX_MIN + DVec3::new(0.01, 0.0, 0.01);
        let up = DVec3::Y;
        let state = simulation(&[
            (floor + up * 0.1, DVec3::new(3.0, 4.0, 0.0)),
            (floor + up * 0.1 + DVec3::X * 0.004, DVec3::ZERO),
            (floor + up * 0.05, DVec3::ZERO),
            (BOX_MAX + 0.5, DVec3::ZERO),
        ]);
        let diagnostics = Diagnostics::of(&state, 7);
        let params = state.params();
        let m = params.mass;
        assert_eq!(diagnostics.step, 7);
        assert_eq!((diagnostics.time, diagnostics.last_step), (0.0, None));
        let vitals = diagnostics.vitals;
        assert_eq!(vitals, Vitals::of(&state));
        assert_eq!(vitals.max_speed, 5.0);
        assert_eq!(vitals.outside, 1);
        assert!((vitals.kinetic - 0.5 * m * 25.0).abs() < 1e-15);
        let heights = 0.1 + 0.1 + 0.05 + (BOX_MAX.y + 0.5 - BOX_MIN.y);
        assert!((vitals.potential - m * 9.8 * heights).abs() < 1e-12);
        assert_eq!(
            diagnostics.pairs, 1,
            "only the two 4 mm apart are closer than h"
        );
        assert_eq!(vitals.non_finite, None);
        // The lone particles' densities are h^6 * factor, far below the rest density.
        let alone = params.h6 * params.density_factor;
        let error = (FLUID_DENSITY - alone) / FLUID_DENSITY;
        assert!((diagnostics.max_density_error - error).abs() < 1e-12);
        assert!(diagnostics.csv_row().starts_with("7,0.000000,5,1,"));
        // The one close pair is the one candidate: a whole group of the native lanes.
        let lanes = crate::sim::kernel::Kernel::NATIVE.lanes() as u64;
        assert_eq!(diagnostics.pair_lanes, lanes);
        assert!(diagnostics.csv_row().ends_with(&format!(",1,,,0,{lanes}")));
        assert_eq!(
            CSV_HEADER.split(',').count(),
            diagnostics.csv_row().split(',').count()
        );
    }

    #[test]
    fn time_and_step_lengths_follow_the_run() {
        let mut state = simulation(&[(BOX_MIN + 0.05, DVec3::ZERO)]);
        state.set_time_step(TimeStep::Fixed(2e-3));
        state.run(3);
        let fixed = Diagnostics::of(&state, 3);
        assert!((fixed.time - 6e-3).abs() < 1e-15);
        assert!(
            fixed.csv_row().ends_with(",0.002,fixed,0,0"),
            "{}",
            fixed.csv_row()
        );
        state.set_time_step(TimeStep::Adaptive { courant: 0.3 });
        state.step();
        let adaptive = Diagnostics::of(&state, 4);
        let (dt, limit) = adaptive.last_step.unwrap();
        assert!((adaptive.time - (6e-3 + dt)).abs() < 1e-15);
        assert!(adaptive
            .csv_row()
            .ends_with(&format!(",{},{},0,0", csv_number(dt), limit.name())));
    }

    #[test]
    fn states_beyond_f32_are_counted_and_print_in_scientific_notation() {
        let far = simulation(&[
            (BOX_MIN + 0.05, DVec3::new(1e39, 0.0, 0.0)),
            (BOX_MIN + 0.07, DVec3::ZERO),
        ]);
        let diagnostics = Diagnostics::of(&far, 1);
        assert_eq!(diagnostics.vitals.beyond_f32, 1);
        let row = diagnostics.csv_row();
        assert!(row.starts_with("1,0.000000,1e39,"), "{row}");
        assert!(row.ends_with(",1,0"), "{row}");
        assert!(row.len() < 200, "{row}");
        assert_eq!(csv_number(1.5e-7), "1.5e-7");
        assert_eq!(csv_number(0.25), "0.25");
        assert_eq!(csv_number(-3e20), "-3e20");
        assert_eq!(csv_number(0.0), "0");
    }

    #[test]
    fn the_front_is_a_high_quantile_near_the_floor_not_the_farthest_particle() {
        let at = |x: f64, y: f64| (BOX_MIN + DVec3::new(x, y, 0.065), DVec3::ZERO);
        // 100 particles 2 mm above the floor, 1 mm apart; a stray far ahead; one high up.
        let mut points: Vec<_> = (0..100)
            .map(|k| at(0.0005 + 0.001 * k as f64, 0.002))
            .collect();
        points.push(at(0.125, 0.002));
        points.push(at(0.128, 0.05));
        let state = simulation(&points);
        // 101 near the floor (2h = 17 mm at 200 per metre); the 95th percentile is the
        // 96th smallest: x = 95.5 mm, not the stray's 125 mm or the high one's 128 mm.
        let found = front(&state).unwrap();
        assert!((found - 0.0955).abs() < 1e-12, "{found}");
        assert_eq!(front(&simulation(&points[..9])), None, "too few to tell");
    }

    #[test]
    fn checks_name_the_first_failure() {
        let still = simulation(&[(BOX_MIN + 0.05, DVec3::ZERO)]);
        let first = Vitals::of(&still);
        let checks = Checks::from(&first);
        assert_eq!(checks.failure(&first), None);
        let fast = simulation(&[(BOX_MIN + 0.05, DVec3::splat(10.0))]);
        let grown = Vitals::of(&fast);
        assert!(matches!(checks.failure(&grown), Some(Failure::EnergyGrew(f)) if f > 1.5));
        let gone = Vitals::of(&simulation(&[(BOX_MAX + 1.0, DVec3::ZERO)]));
        assert_eq!(checks.failure(&gone), Some(Failure::LeftBox(1)));
        let broken = Vitals::of(&simulation(&[(BOX_MIN + 0.05, DVec3::NAN)]));
        assert_eq!(checks.failure(&broken), Some(Failure::NonFinite(0)));
        assert_eq!(
            Failure::NonFinite(0).to_string(),
            "particle 0 is not finite"
        );
        assert_eq!(Failure::LeftBox(3).to_string(), "3 particles left the box");
        assert_eq!(
            Failure::EnergyGrew(1.5642).to_string(),
            "the energy grew 1.56 times"
        );
        assert_eq!(
            Failure::EnergyGrew(12345.0).to_string(),
            "the energy grew 1.23e4 times"
        );
    }

    #[test]
    fn failures_read_back_from_their_name_and_text() {
        for failure in [
            Failure::NonFinite(17),
            Failure::LeftBox(1),
            Failure::LeftBox(250),
            Failure::EnergyGrew(1.56),
            Failure::EnergyGrew(1.23e4),
            Failure::StepCollapsed,
        ] {
            let read = Failure::parse(failure.name(), &failure.to_string());
            assert_eq!(read, Some(failure), "{failure}");
            assert_eq!(Failure::from_text(&failure.to_string()), Some(failure));
        }
        assert_eq!(
            Failure::parse("left-box", "many particles left the box"),
            None
        );
        assert_eq!(Failure::parse("melted", "the box melted"), None);
    }
}
