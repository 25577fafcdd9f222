//! Poiseuille flow, the check of the water model's no-slip walls, periodic faces and
//! laminar viscosity: water between two plates (the box's y walls), periodic along the
//! flow (x), driven by a body force F along x (the case's gravity), reaches the parabola
//! u(y) = F / (2 nu) y (W - y), y from the low plate, W the gap, peak F W^2 / (8 nu).
//! The profile's error is the root mean square of each particle's u_x less the parabola
//! at its y, over the peak. From rest, the flow starts up as the series of Morris, Fox and
//! Zhu (1997), "Modeling low Reynolds number incompressible flows using SPH", J. Comput.
//! Phys. 136, 214-226, eq. (21): the parabola less its odd sine modes, each decaying as
//! exp(-n^2 pi^2 nu t / W^2).

use crate::io::case::Case;
use crate::sim::particles::Particles;
use std::f64::consts::PI;
use std::ops::Range;

/// A channel of a case: its gap, its low plate, the force and the viscosity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channel {
    /// The plates' gap W (m): the box's y extent.
    pub width: f64,
    /// The low plate's y (m).
    pub low: f64,
    /// The body force per unit mass F along x (m/s^2).
    pub force: f64,
    /// The kinematic viscosity nu (m^2/s).
    pub viscosity: f64,
}

/// Why a case is not a channel, and where in the case file (a byte range).
pub type NotAChannel = (Range<usize>, String);

impl Channel {
    /// The channel of `case`: periodic along x, its gravity [F, 0, 0] with F > 0, the
    /// laminar viscosity given, and one box of fluid from plate to plate.
    pub fn of_case(case: &Case) -> Result<Channel, NotAChannel> {
        let domain = &case.domain;
        let periodic = domain.periodic_axes();
        let whole = domain.box_min_m.span();
        if !periodic[0] {
            let why = "a Poiseuille case is periodic along x: periodic = [\"x\"]";
            // A key not there is said as missing, in its table (at its first key).
            return Err(match &domain.periodic {
                Some(given) => (given.span(), why.into()),
                None => (whole, format!("[domain] has no key periodic: {why}")),
            });
        }
        let [force, gy, gz] = *domain.gravity_m_s2.get_ref();
        if !(force > 0.0 && gy == 0.0 && gz == 0.0) {
            let vector = if domain.is_planar() {
                "[F, 0]"
            } else {
                "[F, 0, 0]"
            };
            return Err((
                domain.gravity_m_s2.span(),
                format!("a Poiseuille case is driven along x: gravity_m_s2 = {vector}, F > 0"),
            ));
        }
        // The viscosity at its key where given (else at the model's name).
        let viscosity = case.model.laminar_viscosity_m2_s.as_ref();
        let Some(viscosity) = viscosity.filter(|nu| *nu.get_ref() > 0.0) else {
            let at = match (viscosity, case.model.name.as_ref()) {
                (Some(nu), _) => nu.span(),
                (None, Some(name)) => name.span(),
                (None, None) => whole,
            };
            return Err((
                at,
                "a Poiseuille case gives its laminar_viscosity_m2_s > 0".into(),
            ));
        };
        let (low, high) = (domain.box_min_m.get_ref()[1], domain.box_max_m.get_ref()[1]);
        let fills = &case.fluid;
        let plate_to_plate =
            |fill: &crate::io::case::BoxFill| fill.min_m[1] == low && fill.max_m[1] == high;
        match (&fills.boxes[..], fills.spheres.first()) {
            ([fill], None) if plate_to_plate(fill.get_ref()) => Ok(Channel {
                width: high - low,
                low,
                force,
                viscosity: *viscosity.get_ref(),
            }),
            // At its fill where it has one (the first box, else the first sphere).
            (boxes, spheres) => Err((
                (boxes.first().map(|fill| fill.span()))
                    .or(spheres.map(|fill| fill.span()))
                    .unwrap_or(fills.particles_per_m.span()),
                "a Poiseuille case's fluid is one box from plate to plate (the box's y walls)"
                    .into(),
            )),
        }
    }

    /// The steady velocity along x at height `y` (m/s).
    pub fn velocity(&self, y: f64) -> f64 {
        let above = y - self.low;
        self.force / (2.0 * self.viscosity) * above * (self.width - above)
    }

    /// The steady profile's peak, mid-channel (m/s).
    pub fn peak(&self) -> f64 {
        self.force * self.width * self.width / (8.0 * self.viscosity)
    }

    /// The slowest mode's time constant W^2 / (pi^2 nu) (s): the start-up's time scale.
    pub fn time_constant(&self) -> f64 {
        self.width * self.width / (PI * PI * self.viscosity)
    }

    /// The velocity along x at height `y` a time `t` (s) after the flow started from rest
    /// (m/s): the parabola less its odd sine modes 4 F W^2 / (nu pi^3 n^3), each decaying
    /// as exp(-n^2 t / time_constant), summed while they matter (to 1e-12 of the peak).
    pub fn velocity_at(&self, y: f64, t: f64) -> f64 {
        let phase = PI * (y - self.low) / self.width;
        let amplitude = 4.0 * self.force * self.width * self.width / (self.viscosity * PI.powi(3));
        let decay = t / self.time_constant();
        let mut u = self.velocity(y);
        for n in (1..MOST_MODES).step_by(2) {
            let n = n as f64;
            let term = amplitude / n.powi(3) * (-n * n * decay).exp();
            if term < 1e-12 * self.peak() {
                break;
            }
            u -= term * (n * phase).sin();
        }
        u
    }
}

/// The most sine modes [`Channel::velocity_at`] sums (at t = 0, where they decay least,
/// the last leaves an error near 1e-7 of the peak).
const MOST_MODES: usize = 4001;

/// The start-up at one time: the error of every particle's u_x against the series, and
/// the flow at mid-channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartUp {
    /// The time since the flow started (s).
    pub time: f64,
    /// The root mean square of u_x less the series at each particle's y, over the peak.
    pub error: f64,
    /// The mean u_x of the particles within a lattice spacing of mid-channel (m/s; NaN
    /// where none is).
    pub centre: f64,
    /// The series' mean at the same particles (m/s).
    pub centre_series: f64,
}

impl StartUp {
    /// The start-up of `particles` in `channel` at `time`, `spacing` apart.
    pub fn of(channel: &Channel, particles: &Particles, time: f64, spacing: f64) -> StartUp {
        let middle = channel.low + 0.5 * channel.width;
        let (mut squares, mut centre, mut centre_series, mut near) = (0.0, 0.0, 0.0, 0);
        for slot in 0..particles.len() {
            let (y, u) = (particles.p[1][slot], particles.v[0][slot]);
            let series = channel.velocity_at(y, time);
            squares += (u - series).powi(2);
            if (y - middle).abs() < spacing {
                centre += u;
                centre_series += series;
                near += 1;
            }
        }
        // No particle near the middle gives NaN, not a centre at rest.
        let near = near as f64;
        StartUp {
            time,
            error: (squares / particles.len().max(1) as f64).sqrt() / channel.peak(),
            centre: centre / near,
            centre_series: centre_series / near,
        }
    }
}

/// A run's profile: each lattice row's mean u_x against its height, and the error.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// (y at the row's middle, mean u_x of its particles), m and m/s, low to high.
    pub rows: Vec<(f64, f64)>,
    /// The root mean square of u_x less the parabola over every particle, over the peak.
    pub error: f64,
}

impl Profile {
    /// The profile of `particles` in `channel`, binned into `across` rows.
    pub fn of(channel: &Channel, particles: &Particles, across: usize) -> Profile {
        let n = particles.len();
        let (mut sums, mut counts) = (vec![0.0; across], vec![0usize; across]);
        let mut squares = 0.0;
        for slot in 0..n {
            let (y, u) = (particles.p[1][slot], particles.v[0][slot]);
            let row = ((y - channel.low) / channel.width * across as f64).floor();
            let row = (row.max(0.0) as usize).min(across - 1);
            sums[row] += u;
            counts[row] += 1;
            squares += (u - channel.velocity(y)).powi(2);
        }
        let rows = (0..across)
            .filter(|&row| counts[row] > 0)
            .map(|row| {
                let y = channel.low + (row as f64 + 0.5) / across as f64 * channel.width;
                (y, sums[row] / counts[row] as f64)
            })
            .collect();
        Profile {
            rows,
            error: (squares / n as f64).sqrt() / channel.peak(),
        }
    }
}

/// The order of convergence between the errors `coarse` and `fine` at `across` particles
/// across each: log(coarse / fine) / log(fine's across / coarse's).
pub fn order((coarse, across_coarse): (f64, usize), (fine, across_fine): (f64, usize)) -> f64 {
    (coarse / fine).ln() / (across_fine as f64 / across_coarse as f64).ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel() -> Channel {
        Channel {
            width: 0.01,
            low: -0.005,
            force: 0.08,
            viscosity: 1e-4,
        }
    }

    #[test]
    fn the_parabola_peaks_mid_channel_and_vanishes_at_the_plates() {
        let c = channel();
        assert!((c.peak() - 0.01).abs() < 1e-15);
        assert!((c.velocity(0.0) - c.peak()).abs() < 1e-15);
        assert_eq!(c.velocity(-0.005), 0.0);
        assert!(c.velocity(0.005).abs() < 1e-18);
    }

    #[test]
    fn a_profile_bins_by_row_and_measures_against_the_peak() {
        let c = channel();
        // Four particles, two per row of two: exact, then each 1% of the peak fast.
        let mut particles = Particles::zeroed(4);
        let ys = [-0.004, -0.003, 0.003, 0.002];
        for (slot, y) in ys.into_iter().enumerate() {
            particles.p[1][slot] = y;
            particles.v[0][slot] = c.velocity(y);
        }
        let exact = Profile::of(&c, &particles, 2);
        assert_eq!(exact.error, 0.0);
        assert_eq!(exact.rows.len(), 2);
        assert!((exact.rows[0].0 - -0.0025).abs() < 1e-15);
        for slot in 0..4 {
            particles.v[0][slot] += 0.01 * c.peak();
        }
        let fast = Profile::of(&c, &particles, 2);
        assert!((fast.error - 0.01).abs() < 1e-12, "{}", fast.error);
        assert!((order((0.04, 20), (0.01, 40)) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_series_starts_at_rest_and_tends_to_the_parabola() {
        let c = channel();
        for k in 0..=10 {
            let y = c.low + k as f64 / 10.0 * c.width;
            // At rest at the start, to the series' truncation.
            assert!(c.velocity_at(y, 0.0).abs() < 1e-6 * c.peak(), "{y}");
            // The parabola after many time constants.
            let late = c.velocity_at(y, 40.0 * c.time_constant());
            assert!((late - c.velocity(y)).abs() < 1e-15, "{y}");
        }
        // Mid-channel, one time constant on: the first modes' sum, computed apart.
        let t = c.time_constant();
        let modes: f64 = [1.0f64, 3.0, 5.0, 7.0, 9.0]
            .iter()
            .map(|&n| {
                let sign = if (n as i32 / 2) % 2 == 0 { 1.0 } else { -1.0 };
                sign * 32.0 / (PI.powi(3) * n.powi(3)) * (-n * n).exp()
            })
            .sum();
        let expected = c.peak() * (1.0 - modes);
        assert!((c.velocity_at(0.0, t) - expected).abs() < 1e-12 * c.peak());
        // About 63% of the way there, as the first mode alone says.
        let fraction = c.velocity_at(0.0, t) / c.peak();
        assert!((fraction - (1.0 - 32.0 / PI.powi(3) / std::f64::consts::E)).abs() < 1e-4);
    }

    #[test]
    fn a_start_up_measures_against_the_series_at_its_time() {
        let c = channel();
        let t = 0.5 * c.time_constant();
        let mut particles = Particles::zeroed(3);
        for (slot, y) in [-0.004, 0.0, 0.0001].into_iter().enumerate() {
            particles.p[1][slot] = y;
            particles.v[0][slot] = c.velocity_at(y, t);
        }
        let exact = StartUp::of(&c, &particles, t, 0.00025);
        assert_eq!(exact.error, 0.0);
        assert_eq!(exact.centre, exact.centre_series);
        // Only the two particles within a spacing of the middle are the centre's.
        let centre = (c.velocity_at(0.0, t) + c.velocity_at(0.0001, t)) / 2.0;
        assert!((exact.centre - centre).abs() < 1e-18);
        particles.v[0][0] += 0.03 * c.peak();
        let off = StartUp::of(&c, &particles, t, 0.00025);
        assert!(
            (off.error - 0.03 / 3f64.sqrt()).abs() < 1e-12,
            "{}",
            off.error
        );
        assert_eq!(off.centre, exact.centre);
        // With none within a spacing of the middle, the centre is unknown, not at rest.
        let far = StartUp::of(&c, &particles, t, 0.0);
        assert!(far.centre.is_nan() && far.centre_series.is_nan());
    }
}
