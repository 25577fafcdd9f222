//! Gauges, as DualSPHysics users know them: what a state says at chosen places.
//! A point gauge interpolates the pressure, the velocity and the density at a point
//! from the particles within the cut-off (Shepard-normalised: a sum weighted by each
//! particle's kernel value and volume, divided by the sum of the weights); a point with
//! no particle that near has no value, which the CSV leaves empty. A height gauge finds
//! the free surface along a vertical line: the highest point of the line where the
//! particles' kernel-weighted volume, sampled every quarter spacing, still reaches half of
//! the full fluid's.

use crate::io::case;
use crate::lab::chart::PointChart;
use crate::sim::params::Domain;
use crate::sim::simulation::Simulation;
use glam::{DVec2, DVec3};
use plotters::chart::SeriesLabelPosition;
use std::fmt::Write;

/// A gauge: where, and what it measures.
#[derive(Debug, Clone, PartialEq)]
pub enum Gauge {
    /// Pressure, velocity and density at a point.
    Point {
        /// The column names' prefix.
        name: String,
        /// The point (m).
        at: DVec3,
    },
    /// The free surface's height along the vertical line through a point of the floor.
    Height {
        /// The column name's prefix.
        name: String,
        /// The line's x and z (m).
        at: DVec2,
    },
}

/// What a point gauge reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointReading {
    /// The pressure (Pa).
    pub pressure: f64,
    /// The velocity (m/s).
    pub velocity: DVec3,
    /// The density (kg/m^3).
    pub density: f64,
}

/// The Wendland C2 kernel of support `support`, normalised in 3-D.
fn wendland(r: f64, support: f64) -> f64 {
    let q = r / support;
    if q >= 1.0 {
        return 0.0;
    }
    let sigma = 21.0 / (2.0 * std::f64::consts::PI * support.powi(3));
    sigma * (1.0 - q).powi(4) * (1.0 + 4.0 * q)
}

/// The particles within `support` of `at`, or of the vertical line through it where
/// `vertical`: each slot with its position, or along a periodic axis its image nearest
/// `at` (a gauge on a periodic face reads the fluid on both sides of it).
fn near(simulation: &Simulation, at: DVec3, support: f64, vertical: bool) -> Vec<(usize, DVec3)> {
    let particles = simulation.particles();
    let domain = &simulation.params().domain;
    let extent = domain.extent();
    (0..particles.len())
        .filter_map(|slot| {
            let mut image = particles.position(slot);
            for axis in (0..3).filter(|&axis| domain.periodic[axis]) {
                let d = image[axis] - at[axis];
                image[axis] -= extent[axis] * (d / extent[axis]).round();
            }
            let mut d = image - at;
            if vertical {
                d.y = 0.0;
            }
            (d.length_squared() < support * support).then_some((slot, image))
        })
        .collect()
}

/// The support the gauges interpolate with: the model's cut-off.
fn support(simulation: &Simulation) -> f64 {
    simulation.params().h
}

/// The Shepard interpolation at `at` of the values each sample carries: each sample
/// (position, volume, values) weighted by its kernel value times its volume, the sum
/// divided by the weights'; `None` with no sample within `support`.
pub fn interpolate<const N: usize>(
    samples: impl Iterator<Item = (DVec3, f64, [f64; N])>,
    at: DVec3,
    support: f64,
) -> Option<[f64; N]> {
    let mut weights = 0.0;
    let mut sums = [0.0; N];
    for (position, volume, values) in samples {
        let weight = wendland(position.distance(at), support) * volume;
        weights += weight;
        for (sum, value) in sums.iter_mut().zip(values) {
            *sum += weight * value;
        }
    }
    (weights > 0.0).then(|| sums.map(|sum| sum / weights))
}

/// The reading of a point gauge at `at` on `state` (whose densities are those of its
/// positions: [`Simulation::with_fresh_densities`]), or `None` with no particle within the
/// cut-off.
pub fn read_point(state: &Simulation, at: DVec3) -> Option<PointReading> {
    let support = support(state);
    let particles = state.particles();
    let mass = state.params().mass;
    let samples = near(state, at, support, false)
        .into_iter()
        .map(|(slot, image)| {
            let rho = particles.rho[slot];
            let v = crate::sim::particles::vector_at(&particles.v, slot);
            let values = [state.pressure(rho), v.x, v.y, v.z, rho];
            (image, mass / rho, values)
        });
    let [pressure, vx, vy, vz, density] = interpolate(samples, at, support)?;
    Some(PointReading {
        pressure,
        velocity: DVec3::new(vx, vy, vz),
        density,
    })
}

/// The free surface's height along the vertical line through `at` (x, z) on `state` (with
/// fresh densities, as for [`read_point`]): the highest y,
/// from the floor up in quarter spacings, at which the kernel-weighted volume of the
/// particles reaches half of the full fluid's (linear between samples), or `None` where
/// no fluid is on the line. Near a side wall or the floor the particles' mirror images
/// across it count too, so the wall does not cut the kernel short (a layer a spacing or
/// two thick on the floor reads its own thickness).
pub fn read_height(state: &Simulation, at: DVec2) -> Option<f64> {
    let support = support(state);
    let particles = state.particles();
    let mass = state.params().mass;
    let line = DVec3::new(at.x, 0.0, at.y);
    let slots = near(state, line, support, true);
    if slots.is_empty() {
        return None;
    }
    let heights = slots.iter().map(|&(_, image)| image.y);
    let (bottom, top) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
        (lo.min(y), hi.max(y))
    });
    // Each particle and its images, with its volume, once for every sample: across the
    // side walls near the line, and across the floor where the particle is near it.
    let domain = &state.params().domain;
    let mirrors = side_mirrors(domain, line, support);
    let floor = domain.min.y;
    let flip = |value: f64, wall: Option<f64>| wall.map_or(value, |w| 2.0 * w - value);
    let images: Vec<(DVec3, f64)> = slots
        .iter()
        .flat_map(|&(slot, p)| {
            let v = mass / particles.rho[slot];
            let below = (p.y - floor < support).then_some(2.0 * floor - p.y);
            mirrors.iter().flat_map(move |&(x, z)| {
                let side = DVec3::new(flip(p.x, x), p.y, flip(p.z, z));
                let floor_image = below.map(|y| (DVec3::new(side.x, y, side.z), v));
                std::iter::once((side, v)).chain(floor_image)
            })
        })
        .collect();
    let fraction = |y: f64| {
        let point = DVec3::new(at.x, y, at.y);
        let mut volume = 0.0;
        for &(image, v) in &images {
            volume += wendland(image.distance(point), support) * v;
        }
        volume
    };
    let step = 0.25 / state.params().ppm;
    // Samples by index: a step added to a large y may not move it.
    let samples = ((top + support - bottom) / step).ceil() as u64;
    let mut surface = None;
    let mut last = fraction(bottom);
    for k in 0..samples {
        let y = bottom + k as f64 * step;
        let next = fraction(y + step);
        if last >= 0.5 && next < 0.5 {
            surface = Some(y + step * (last - 0.5) / (last - next));
        }
        last = next;
    }
    surface
}

/// The walls (x, z) a position is mirrored across for its images seen from the vertical
/// `line`: the particle itself (no wall), and across the side walls of `domain` within
/// `support` of the line, each alone and both together (a periodic axis has none).
fn side_mirrors(domain: &Domain, line: DVec3, support: f64) -> Vec<(Option<f64>, Option<f64>)> {
    let wall = |axis: usize| {
        let (low, high) = (line[axis] - domain.min[axis], domain.max[axis] - line[axis]);
        if domain.periodic[axis] {
            None
        } else if low < support && low <= high {
            Some(domain.min[axis])
        } else if high < support {
            Some(domain.max[axis])
        } else {
            None
        }
    };
    let (x, z) = (wall(0), wall(2));
    let mut mirrors = vec![(None, None)];
    mirrors.extend(x.map(|x| (Some(x), None)));
    mirrors.extend(z.map(|z| (None, Some(z))));
    if x.is_some() && z.is_some() {
        mirrors.push((x, z));
    }
    mirrors
}

/// The first due time after `time` (beyond 1e-12 relative) on from `next`: sums of
/// `interval`, as the schedule takes them; where they would be more than a million, or
/// `interval` too small to move the sum, the first multiple of it past `time` (or the
/// next number past it), so that no interval makes the schedule hang.
fn next_due(next: f64, time: f64, interval: f64) -> f64 {
    let end = time * (1.0 + 1e-12);
    if (end - next) / interval > 1e6 || next + interval == next {
        let multiple = ((end / interval).floor() + 1.0) * interval;
        return if multiple > end {
            multiple
        } else {
            end.next_up()
        };
    }
    let mut next = next;
    while next <= end {
        next += interval;
    }
    next
}

/// The file of the gauges' table, in a case's `[output] folder`.
pub const TABLE_FILE: &str = "gauges.csv";

/// The names of the gauges' charts (pressure, free surface), each a PNG and an SVG
/// ([`crate::lab::chart::files`]) beside the table.
pub const CHART_NAMES: [&str; 2] = ["gauges-pressure", "gauges-surface"];

/// The columns of a point gauge, after its name.
const POINT_COLUMNS: [&str; 5] = ["pressure_pa", "vx_m_s", "vy_m_s", "vz_m_s", "density_kg_m3"];

/// The gauges' readings over a run: a row per reading, a column per gauge and quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct GaugeTable {
    gauges: Vec<Gauge>,
    /// Each reading's time (s) and values (`None`: no fluid near), in the columns' order.
    rows: Vec<(f64, Vec<Option<f64>>)>,
    /// When [`Self::read_due`] reads next (s); none before the first reading.
    next: Option<f64>,
}

impl GaugeTable {
    /// No readings yet of `gauges`.
    pub fn new(gauges: Vec<Gauge>) -> GaugeTable {
        GaugeTable {
            gauges,
            rows: Vec::new(),
            next: None,
        }
    }

    /// The gauges of a case.
    pub fn of_case(gauges: &case::Gauges) -> GaugeTable {
        let points = gauges.points.iter().map(|gauge| Gauge::Point {
            name: gauge.get_ref().name.clone(),
            at: DVec3::from_array(gauge.get_ref().at_m),
        });
        let heights = gauges.heights.iter().map(|gauge| Gauge::Height {
            name: gauge.get_ref().name.clone(),
            at: DVec2::from_array(gauge.get_ref().at_m),
        });
        GaugeTable::new(points.chain(heights).collect())
    }

    /// Whether it has no gauge.
    pub fn is_empty(&self) -> bool {
        self.gauges.is_empty()
    }

    /// The columns after `time_s`, unit in the name.
    pub fn columns(&self) -> Vec<String> {
        let mut columns = Vec::new();
        for gauge in &self.gauges {
            match gauge {
                Gauge::Point { name, .. } => columns.extend(
                    POINT_COLUMNS
                        .iter()
                        .map(|column| format!("{name}_{column}")),
                ),
                Gauge::Height { name, .. } => columns.push(format!("{name}_surface_m")),
            }
        }
        columns
    }

    /// The index in [`Self::columns`] (and in each row's values) of the column `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns().iter().position(|column| column == name)
    }

    /// Reads the gauges if a reading is due at the state of `simulation`: the first, then
    /// the first state at or past each `interval` seconds after it. Whether it read.
    pub fn read_due(&mut self, simulation: &Simulation, interval: f64) -> bool {
        let time = simulation.time();
        let due = self.next.is_none_or(|next| time >= next * (1.0 - 1e-12));
        if due {
            self.read(simulation);
            self.next = Some(next_due(self.next.unwrap_or(time), time, interval));
        }
        due
    }

    /// Takes up the readings a run resumed from a checkpoint had taken (`readings`, as
    /// [`Self::rows`] gave them), so that its table is the whole run's; refused where they
    /// are not of these gauges' columns.
    pub fn resume_readings(
        &mut self,
        readings: Vec<(f64, Vec<Option<f64>>)>,
    ) -> Result<(), String> {
        let columns = self.columns().len();
        if let Some((_, values)) = readings.iter().find(|(_, values)| values.len() != columns) {
            return Err(format!(
                "its gauge readings have {} columns where the case's gauges have {columns}",
                values.len()
            ));
        }
        self.rows = readings;
        Ok(())
    }

    /// Takes up the reading schedule of a run resumed at the state of `simulation`, after
    /// [`Self::resume_readings`]: the next reading is the one the run would have taken had
    /// it not stopped (its due times are sums of `interval` from 0, the first past the last
    /// step's start, or past the resumed state where the table read it).
    pub fn resume_schedule(&mut self, simulation: &Simulation, interval: f64) {
        let Some((dt, _)) = simulation.last_step() else {
            return;
        };
        let before = simulation.time() - dt;
        let mut next = next_due(0.0, before, interval);
        // Past the reading of the resumed state itself, where the table holds it.
        let time = simulation.time();
        if self.rows.last().is_some_and(|(read, _)| *read == time) {
            next = next_due(next, time, interval);
        }
        self.next = Some(next);
    }

    /// Reads every gauge at the state of `simulation` (on a copy with the densities of its
    /// positions).
    pub fn read(&mut self, simulation: &Simulation) {
        let state = simulation.with_fresh_densities();
        let simulation = &state;
        let mut values = Vec::new();
        for gauge in &self.gauges {
            match gauge {
                Gauge::Point { at, .. } => match read_point(simulation, *at) {
                    Some(reading) => values.extend(
                        [
                            reading.pressure,
                            reading.velocity.x,
                            reading.velocity.y,
                            reading.velocity.z,
                            reading.density,
                        ]
                        .map(Some),
                    ),
                    None => values.extend([None; POINT_COLUMNS.len()]),
                },
                Gauge::Height { at, .. } => values.push(read_height(simulation, *at)),
            }
        }
        self.rows.push((simulation.time(), values));
    }

    /// The readings so far.
    pub fn rows(&self) -> &[(f64, Vec<Option<f64>>)] {
        &self.rows
    }

    /// The readings as CSV: `time_s`, then the columns; a gauge with no fluid near leaves
    /// its fields empty.
    pub fn csv(&self) -> String {
        let mut text = String::from("time_s");
        for column in self.columns() {
            write!(text, ",{column}").expect("a string");
        }
        text.push('\n');
        for (time, values) in &self.rows {
            write!(text, "{time}").expect("a string");
            for value in values {
                match value {
                    Some(value) => write!(text, ",{value}").expect("a string"),
                    None => text.push(','),
                }
            }
            text.push('\n');
        }
        text
    }

    /// The charts against time: the point gauges' pressures and the height gauges'
    /// surfaces (each where the case has such gauges), with `footer`.
    pub fn charts(&self, footer: &str) -> Vec<PointChart> {
        let columns = self.columns();
        let series = |suffix: &str| -> Vec<(String, Vec<(f64, f64)>)> {
            let picked = columns
                .iter()
                .enumerate()
                .filter(|(_, c)| c.ends_with(suffix));
            picked
                .map(|(index, column)| {
                    let points = self
                        .rows
                        .iter()
                        .filter_map(|(time, values)| values[index].map(|value| (*time, value)));
                    (
                        column.trim_end_matches(suffix).to_string(),
                        points.collect(),
                    )
                })
                .collect()
        };
        let chart = |name: &'static str, title: &str, y_label: &str, suffix: &str| {
            let legend = SeriesLabelPosition::UpperRight;
            PointChart::over_time(name, title.into(), y_label, series(suffix), legend, footer)
        };
        [
            chart(
                CHART_NAMES[0],
                "Pressure at the point gauges",
                "pressure (Pa)",
                "_pressure_pa",
            ),
            chart(
                CHART_NAMES[1],
                "Free surface at the height gauges",
                "height (m)",
                "_surface_m",
            ),
        ]
        .into_iter()
        .filter(|chart| !chart.series.is_empty())
        .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::method::Method;
    use crate::sim::model::Model;
    use crate::sim::params::{BOX_MAX, BOX_MIN, FLUID_DENSITY};
    use crate::sim::particles::Particles;

    #[test]
    fn the_kernel_is_normalised() {
        let support = 0.01;
        let shells = 20_000;
        let volume: f64 = (0..shells)
            .map(|k| {
                let r = (k as f64 + 0.5) / shells as f64 * support;
                4.0 * std::f64::consts::PI * r * r * wendland(r, support) * support / shells as f64
            })
            .sum();
        assert!((volume - 1.0).abs() < 1e-6, "{volume}");
    }

    /// A slab of water at rest, `depth` deep over the whole floor, at `ppm`, with the
    /// densities of its positions.
    fn slab(ppm: f64, depth: f64) -> Simulation {
        slab_of(Model::Fluidanimate, ppm, depth)
    }

    /// [`slab`] on `model`.
    fn slab_of(model: Model, ppm: f64, depth: f64) -> Simulation {
        let method = Method {
            model,
            kernel: crate::sim::kernel::Kernel::Scalar,
        };
        Simulation::with_method(ppm, slab_particles(ppm, depth), method)
            .unwrap()
            .with_fresh_densities()
    }

    /// The particles of [`slab`].
    fn slab_particles(ppm: f64, depth: f64) -> Particles {
        let spacing = 1.0 / ppm;
        let extent = BOX_MAX - BOX_MIN;
        let [nx, nz] = [extent.x, extent.z].map(|e| (e * ppm).floor() as usize);
        let ny = (depth * ppm).round() as usize;
        let mut particles = Particles::zeroed(nx * ny * nz);
        for (slot, k) in (0..ny)
            .flat_map(|y| (0..nz).flat_map(move |z| (0..nx).map(move |x| [x, y, z])))
            .enumerate()
        {
            for axis in 0..3 {
                particles.p[axis][slot] = BOX_MIN[axis] + (k[axis] as f64 + 0.5) * spacing;
            }
        }
        particles
    }

    #[test]
    fn shepard_interpolation_keeps_a_linear_field_on_a_lattice() {
        // A field linear in position, carried by a lattice around the point: the weights
        // are symmetric, so the interpolation is the field at the point.
        let spacing = 0.005;
        let field = |p: DVec3| [1000.0 + 100.0 * p.y, 3.0 * p.x - 2.0 * p.z];
        let at = DVec3::new(0.0011, -0.0023, 0.0007);
        let lattice = (-6..=6).flat_map(|x| {
            (-6..=6)
                .flat_map(move |y| (-6..=6).map(move |z| DVec3::new(x as f64, y as f64, z as f64)))
        });
        let samples = lattice.map(|k| {
            let p = k * spacing;
            (p, spacing.powi(3), field(p))
        });
        let [a, b] = interpolate(samples.clone(), at, 2.6 * spacing).unwrap();
        let [ea, eb] = field(at);
        // Within the field's change over a fraction of a spacing: Shepard's is exact for
        // constants, first-order for a linear field on a lattice.
        assert!((a - ea).abs() < 100.0 * 0.3 * spacing, "{a} {ea}");
        assert!((b - eb).abs() < 5.0 * 0.3 * spacing, "{b} {eb}");
        assert_eq!(interpolate(samples, DVec3::splat(1.0), 2.6 * spacing), None);
        // A constant is kept to rounding.
        let constant = (0..20).map(|k| (DVec3::new(k as f64 * 1e-3, 0.0, 0.0), 1e-9, [7.0]));
        let [c] = interpolate(constant, DVec3::new(0.004, 0.0, 0.001), 0.01).unwrap();
        assert!((c - 7.0).abs() < 1e-12);
    }

    #[test]
    fn a_point_gauge_reads_the_state_and_says_where_there_is_no_fluid() {
        let simulation = slab(150.0, 0.06);
        let at = DVec3::new(0.003, BOX_MIN.y + 0.03, -0.002);
        let reading = read_point(&simulation, at).expect("fluid near");
        // The density of a full lattice, near the rest density; the pressure the model's
        // of it; at rest.
        assert!(
            (reading.density / FLUID_DENSITY - 1.0).abs() < 0.1,
            "{reading:?}"
        );
        let pressure = simulation.pressure(reading.density);
        assert!(
            (reading.pressure - pressure).abs() < 0.05 * pressure.abs() + 1e-9,
            "{reading:?}"
        );
        assert_eq!(reading.velocity, DVec3::ZERO);
        // Above the water, nothing: no value rather than 0.
        assert_eq!(read_point(&simulation, DVec3::new(0.0, 0.05, 0.0)), None);
    }

    #[test]
    fn a_height_gauge_finds_the_surface_within_a_spacing() {
        for depth in [0.04, 0.06] {
            let ppm = 150.0;
            let simulation = slab(ppm, depth);
            let height = read_height(&simulation, DVec2::new(0.001, -0.003)).unwrap();
            let surface = BOX_MIN.y + depth;
            assert!(
                (height - surface).abs() < 1.0 / ppm,
                "{depth}: {height} {surface}"
            );
        }
        let simulation = slab(150.0, 0.04);
        assert_eq!(read_height(&simulation, DVec2::new(1.0, 1.0)), None);
    }

    #[test]
    fn a_height_gauge_on_a_wall_or_in_a_corner_reads_the_same_surface() {
        let (ppm, depth) = (150.0, 0.04);
        let simulation = slab(ppm, depth);
        let surface = BOX_MIN.y + depth;
        let middle = read_height(&simulation, DVec2::new(0.001, -0.003)).unwrap();
        // The slab fills the box from its low corner (its lattice stops short of the
        // high walls).
        for at in [
            DVec2::new(BOX_MIN.x, 0.0),
            DVec2::new(BOX_MIN.x + 0.001, 0.0),
            DVec2::new(0.0, BOX_MIN.z),
            DVec2::new(BOX_MIN.x, BOX_MIN.z),
        ] {
            let height = read_height(&simulation, at).unwrap_or(f64::NAN);
            assert!(
                (height - surface).abs() < 1.0 / ppm && (height - middle).abs() < 0.2 / ppm,
                "{at}: {height} against {middle} in the middle"
            );
        }
        // Without the images a gauge on a wall read the surface spacings low, and one in a
        // corner nothing (fewer than half of the kernel's volume anywhere).
        let mirrors = side_mirrors(&Domain::COURSE, DVec3::new(BOX_MIN.x, 0.0, BOX_MAX.z), 0.01);
        assert_eq!(
            mirrors,
            [
                (None, None),
                (Some(BOX_MIN.x), None),
                (None, Some(BOX_MAX.z)),
                (Some(BOX_MIN.x), Some(BOX_MAX.z))
            ]
        );
    }

    #[test]
    fn a_gauge_on_a_periodic_face_reads_both_sides_of_it() {
        // The eighth hostile pass: gauges at x = 0 and x = L of a box periodic along x,
        // one place, read 96 and 99 Pa (each only its own side).
        let (ppm, depth) = (150.0, 0.04);
        let domain = Domain {
            periodic: [true, false, false],
            ..Domain::COURSE
        };
        let method = Method {
            model: Model::Wcsph,
            kernel: crate::sim::kernel::Kernel::Scalar,
        };
        let particles = slab_particles(ppm, depth);
        let periodic =
            Simulation::with_dynamics(ppm, domain, particles, method, Model::Wcsph.dynamics())
                .unwrap()
                .with_fresh_densities();
        let at = |x: f64| DVec3::new(x, BOX_MIN.y + 0.5 * depth, 0.0);
        let (low, high) = (
            read_point(&periodic, at(BOX_MIN.x)).unwrap(),
            read_point(&periodic, at(BOX_MAX.x)).unwrap(),
        );
        assert!(
            (low.pressure - high.pressure).abs() < 1e-9 * low.pressure.abs().max(1.0),
            "{low:?} {high:?}"
        );
        let height = |x: f64| read_height(&periodic, DVec2::new(x, 0.0)).unwrap();
        assert!((height(BOX_MIN.x) - height(BOX_MAX.x)).abs() < 1e-12);
        assert!((height(BOX_MIN.x) - (BOX_MIN.y + depth)).abs() < 1.0 / ppm);
        // No wall to mirror across along the periodic axis.
        let mirrors = side_mirrors(&domain, DVec3::new(BOX_MIN.x, 0.0, 0.0), 0.01);
        assert_eq!(mirrors, [(None, None)]);
    }

    #[test]
    fn a_height_gauge_reads_a_layer_one_or_two_spacings_thick() {
        let ppm = 150.0;
        // On the water model, whose densities are its own (rest density here): the
        // layer's volumes are those of full particles. Without the floor's images one
        // layer read 0.86 of its thickness.
        for layers in [1.0, 2.0, 3.0] {
            let simulation = slab_of(Model::Wcsph, ppm, layers / ppm);
            let rest = simulation.particles().rho[0];
            assert!((rest / 1000.0 - 1.0).abs() < 0.01, "{rest}");
            let at = DVec2::new(0.001, -0.003);
            let height = read_height(&simulation, at).expect("a layer on the floor");
            let thickness = height - BOX_MIN.y;
            assert!(
                (thickness - layers / ppm).abs() < 0.05 / ppm,
                "{layers} layers: {thickness}"
            );
        }
    }

    #[test]
    fn no_interval_makes_the_schedule_hang() {
        // As ever: sums of the interval.
        assert_eq!(next_due(0.0, 0.025, 0.01), 0.01 + 0.01 + 0.01);
        // Too small to add, or too many sums: past the time at once.
        for (next, time, interval) in [(1.0, 1.0, 1e-300), (0.0, 1e300, 1e-3), (0.0, 5.0, 1e-9)] {
            let due = next_due(next, time, interval);
            assert!(
                due > time * (1.0 + 1e-12) && due.is_finite(),
                "{time} {interval}: {due}"
            );
        }
    }

    #[test]
    fn readings_fall_due_at_the_start_then_at_each_interval() {
        let mut simulation = slab(100.0, 0.03);
        let mut table = GaugeTable::new(vec![Gauge::Height {
            name: "middle".into(),
            at: DVec2::ZERO,
        }]);
        assert_eq!(table.column("middle_surface_m"), Some(0));
        assert_eq!(table.column("middle"), None);
        // 1 ms steps, a reading due every 2.5 ms: at 0, 3 and 5 ms.
        let mut read = vec![table.read_due(&simulation, 0.0025)];
        assert!(
            !table.read_due(&simulation, 0.0025),
            "not twice at one time"
        );
        for _ in 0..5 {
            simulation.run(1);
            read.push(table.read_due(&simulation, 0.0025));
        }
        assert_eq!(read, [true, false, false, true, false, true]);
        let times: Vec<f64> = table.rows().iter().map(|(time, _)| *time).collect();
        assert_eq!(times.len(), 3);
        assert!((times[1] - 0.003).abs() < 1e-12 && (times[2] - 0.005).abs() < 1e-12);
    }

    #[test]
    fn the_csv_names_each_gauge_and_leaves_a_dry_one_empty() {
        let simulation = slab(100.0, 0.04);
        let mut table = GaugeTable::new(vec![
            Gauge::Point {
                name: "floor".into(),
                at: DVec3::new(0.0, BOX_MIN.y + 0.005, 0.0),
            },
            Gauge::Point {
                name: "air".into(),
                at: DVec3::new(0.0, 0.09, 0.0),
            },
            Gauge::Height {
                name: "middle".into(),
                at: DVec2::ZERO,
            },
        ]);
        table.read(&simulation);
        table.read(&simulation);
        let csv = table.csv();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[0].starts_with("time_s,floor_pressure_pa,floor_vx_m_s,"));
        assert!(lines[0].ends_with(",air_density_kg_m3,middle_surface_m"));
        let fields: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(fields.len(), lines[0].split(',').count());
        assert_eq!(fields[0], "0");
        assert!(fields[1].parse::<f64>().is_ok());
        assert!(fields[6..11].iter().all(|field| field.is_empty()), "{csv}");
        let height: f64 = fields[11].parse().unwrap();
        assert!((height - (BOX_MIN.y + 0.04)).abs() < 0.01, "{csv}");
        // Charted: the floor's pressure (the dry gauge a series without points) and the
        // surface.
        let charts = table.charts("test");
        assert_eq!(charts.len(), 2);
        assert_eq!(charts[0].series.len(), 2);
        assert_eq!(charts[0].series[0].0, "floor");
        assert_eq!(charts[0].series[0].1.len(), 2);
        assert!(charts[0].series[1].1.is_empty());
        assert_eq!(charts[1].series[0].0, "middle");
    }
}
