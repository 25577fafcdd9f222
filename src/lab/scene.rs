//! Generated scenes, for benchmarks and tests beyond the two course inputs: named scenes
//! of fluid at rest on a cubic lattice of spacing 1/ppm (the spacing at which the particle
//! mass gives the rest density), or a random cloud, at a chosen ppm and seed.

use crate::io::case;
use crate::sim::grid::Grid;
use crate::sim::params::{Domain, Params, BOX_MAX, BOX_MIN};
use crate::sim::particles::Particles;
use glam::DVec3;

/// The largest scene written: an `.fld` header counts particles in an `i32`, and a scene
/// this large already takes 1.8 GB.
pub const MAX_PARTICLES: usize = 50_000_000;

/// How far lattice scenes move each particle off its lattice point, at most, per axis, as
/// a fraction of the spacing: enough to break the lattice's exact symmetry.
pub const JITTER: f64 = 0.05;

/// A named scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneKind {
    /// A column of fluid against the low-x wall (40% of the width, 70% of the height),
    /// about to collapse.
    DamBreak,
    /// A sphere of fluid (radius 2.5 cm) above a shallow pool (15% of the height).
    Drop,
    /// The box filled to half its height: a resting column.
    FilledBox,
    /// Particles uniformly at random in the whole box (default: as many as would fill 30%
    /// of it).
    RandomCloud,
    /// A cube-like block in the low corner, of `--particles` particles (default: a cube
    /// half the box's width on a side), on the exact lattice (no jitter): the scaling
    /// series.
    CornerBlock,
}

impl SceneKind {
    /// The scene's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::DamBreak => "dam-break",
            SceneKind::Drop => "drop",
            SceneKind::FilledBox => "filled-box",
            SceneKind::RandomCloud => "random-cloud",
            SceneKind::CornerBlock => "corner-block",
        }
    }

    /// Whether a particle count sets the scene's size (else it follows from ppm).
    fn takes_particle_count(self) -> bool {
        matches!(self, SceneKind::RandomCloud | SceneKind::CornerBlock)
    }

    /// Refuses a particle count for a scene whose size follows from ppm, and a count of
    /// none or past [`MAX_PARTICLES`].
    pub fn check_particle_count(self, particles: Option<usize>) -> Result<(), String> {
        match particles {
            Some(_) if !self.takes_particle_count() => Err(format!(
                "--particles sets the size of random-cloud and corner-block only; {} follows \
                 from --ppm",
                self.name()
            )),
            Some(0) => Err("--particles 0 makes no scene: give at least 1".to_string()),
            Some(count) if count > MAX_PARTICLES => Err(format!(
                "--particles {count} is past the limit of {MAX_PARTICLES} particles"
            )),
            _ => Ok(()),
        }
    }
}

/// A region of fluid of a lattice scene (the fills of a case file).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// The points p with `low` <= p < `high` on every axis.
    Box {
        /// The low corner (m).
        low: DVec3,
        /// The high corner (m).
        high: DVec3,
    },
    /// The points closer than `radius` to `centre`.
    Sphere {
        /// The centre (m).
        centre: DVec3,
        /// The radius (m).
        radius: f64,
    },
}

impl Region {
    /// Whether `point` is in it.
    fn holds(&self, point: DVec3) -> bool {
        match *self {
            Region::Box { low, high } => point.cmpge(low).all() && point.cmplt(high).all(),
            Region::Sphere { centre, radius } => point.distance(centre) < radius,
        }
    }

    /// The corners of a box around it.
    fn bounds(&self) -> (DVec3, DVec3) {
        match *self {
            Region::Box { low, high } => (low, high),
            Region::Sphere { centre, radius } => (centre - radius, centre + radius),
        }
    }

    /// The fills of a case's fluid.
    pub fn of_case(fluid: &case::Fluid) -> Vec<Region> {
        let boxes = fluid.boxes.iter().map(|fill| Region::Box {
            low: DVec3::from_array(fill.get_ref().min_m),
            high: DVec3::from_array(fill.get_ref().max_m),
        });
        let spheres = fluid.spheres.iter().map(|fill| Region::Sphere {
            centre: DVec3::from_array(fill.get_ref().centre_m),
            radius: fill.get_ref().radius_m,
        });
        boxes.chain(spheres).collect()
    }

    /// As a case's fill: the case's boxes or spheres, to which it adds it.
    fn add_to(&self, fluid: &mut case::Fluid) {
        match *self {
            Region::Box { low, high } => fluid.boxes.push(toml::Spanned::new(
                0..0,
                case::BoxFill {
                    min_m: low.to_array(),
                    max_m: high.to_array(),
                },
            )),
            Region::Sphere { centre, radius } => fluid.spheres.push(toml::Spanned::new(
                0..0,
                case::SphereFill {
                    centre_m: centre.to_array(),
                    radius_m: radius,
                },
            )),
        }
    }
}

impl SceneKind {
    /// The regions of fluid of a lattice scene; `None` for the random cloud and the corner
    /// block, which are not fills of a lattice.
    pub fn regions(self) -> Option<Vec<Region>> {
        let extent = BOX_MAX - BOX_MIN;
        let height = |fraction: f64| BOX_MIN.y + fraction * extent.y;
        let below = |top: f64| Region::Box {
            low: BOX_MIN,
            high: DVec3::new(BOX_MAX.x, top, BOX_MAX.z),
        };
        match self {
            SceneKind::DamBreak => Some(vec![Region::Box {
                low: BOX_MIN,
                high: DVec3::new(BOX_MIN.x + 0.4 * extent.x, height(0.7), BOX_MAX.z),
            }]),
            SceneKind::Drop => Some(vec![
                below(height(0.15)),
                Region::Sphere {
                    centre: DVec3::new(0.0, height(0.65), 0.0),
                    radius: 0.025,
                },
            ]),
            SceneKind::FilledBox => Some(vec![below(height(0.5))]),
            SceneKind::RandomCloud | SceneKind::CornerBlock => None,
        }
    }

    /// The case file of the scene at `ppm` and `seed`, run with the weakly compressible
    /// model (the water model) for `until` seconds; `None` for the scenes that are not
    /// fills of a lattice.
    pub fn case(self, ppm: f32, seed: u64, until: f64) -> Option<case::Case> {
        let mut fluid = case::Fluid {
            particles_per_m: toml::Spanned::new(0..0, ppm.into()),
            seed,
            boxes: Vec::new(),
            spheres: Vec::new(),
        };
        for region in self.regions()? {
            region.add_to(&mut fluid);
        }
        Some(case::Case {
            domain: case::Domain::default(),
            fluid,
            model: case::ModelSettings {
                name: Some(toml::Spanned::new(0..0, "wcsph".into())),
                ..Default::default()
            },
            run: case::RunSettings {
                until_s: Some(toml::Spanned::new(0..0, until)),
                ..Default::default()
            },
            output: case::OutputSettings::default(),
            gauges: case::Gauges::default(),
        })
    }
}

/// Most lattice points the fills' bounding box may span (each is visited).
const MAX_VISITED: f64 = 1e9;

/// Why fills make no scene.
#[derive(Debug, Clone, PartialEq)]
pub enum FillError {
    /// Region `region` (its index among the fills) holds no lattice point at `ppm`.
    Empty {
        /// The index of the empty region.
        region: usize,
        /// The lattice's particles per metre.
        ppm: f64,
    },
    /// Anything else, said.
    Other(String),
}

impl std::fmt::Display for FillError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FillError::Empty { ppm, .. } => write!(
                f,
                "this fill holds no lattice point at {ppm} particles per metre"
            ),
            FillError::Other(why) => f.write_str(why),
        }
    }
}

/// The lattice points of `domain`'s box at `ppm` particles per metre in any of
/// `regions`, jittered from `seed` (the model's grid is checked where the simulation is
/// made, on its own cut-off). Each region holds at least one point, or the first that
/// holds none is the error.
pub fn filled(
    ppm: f64,
    seed: u64,
    regions: &[Region],
    domain: &Domain,
) -> Result<Particles, FillError> {
    if !(ppm.is_finite() && ppm > 0.0) {
        return Err(FillError::Other(format!(
            "particles per metre {ppm} is not a finite number > 0"
        )));
    }
    // Only the lattice points of the regions' bounding box are visited (in the same
    // order as the whole box's, so the jitter is the same), at most MAX_VISITED.
    let (low, high) = regions.iter().fold(
        (DVec3::INFINITY, DVec3::NEG_INFINITY),
        |(low, high), region| {
            let (a, b) = region.bounds();
            (low.min(a), high.max(b))
        },
    );
    let dims = lattice_dims(ppm, domain);
    let ranges: [std::ops::Range<usize>; 3] = std::array::from_fn(|axis| {
        let index = |x: f64| ((x - domain.min[axis]) * ppm - 0.5).clamp(0.0, dims[axis] as f64);
        let first = index(low[axis]).floor() as usize;
        let end = (index(high[axis]).ceil() as usize + 1).min(dims[axis]);
        first.min(end)..end
    });
    let visited: f64 = ranges.iter().map(|range| range.len() as f64).product();
    if visited > MAX_VISITED {
        return Err(FillError::Other(format!(
            "the fills' bounding box spans {visited:.3e} lattice points at {ppm} particles \
             per metre; the limit is {MAX_VISITED:.0e}"
        )));
    }
    let held: Vec<std::cell::Cell<bool>> = regions.iter().map(|_| Default::default()).collect();
    let scene = lattice_within(ppm, seed, domain, ranges, |point| {
        let mut inside = false;
        for (region, held) in regions.iter().zip(&held) {
            if region.holds(point) {
                held.set(true);
                inside = true;
            }
        }
        inside
    });
    match held.iter().position(|held| !held.get()) {
        Some(region) => Err(FillError::Empty { region, ppm }),
        None => Ok(scene),
    }
}

/// Generates `kind` at `ppm` particles per metre; `seed` drives the jitter and the random
/// cloud, `particles` the size of the random cloud and the corner block.
pub fn generate(
    kind: SceneKind,
    ppm: f64,
    seed: u64,
    particles: Option<usize>,
) -> Result<Particles, String> {
    check_ppm(ppm, &Domain::COURSE)?;
    kind.check_particle_count(particles)?;
    let [nx, ny, nz] = lattice_dims(ppm, &Domain::COURSE).map(|n| n as f64);
    let count = match (kind, particles) {
        (SceneKind::RandomCloud, None) => (0.3 * nx * ny * nz) as usize,
        (SceneKind::CornerBlock, None) => {
            let half = (nx / 2.0).floor();
            (half * half * half.min(ny)) as usize
        }
        (_, Some(count)) => count,
        _ => (nx * ny * nz) as usize,
    };
    if count > MAX_PARTICLES {
        return Err(format!(
            "{} at {ppm} particles per metre would hold up to {count} particles; the limit is {MAX_PARTICLES}",
            kind.name()
        ));
    }
    let scene = match (kind, kind.regions()) {
        (_, Some(regions)) => lattice(ppm, seed, |point| {
            regions.iter().any(|region| region.holds(point))
        }),
        (SceneKind::RandomCloud, None) => random_cloud(count, seed),
        (_, None) => corner_block(ppm, count)?,
    };
    if scene.is_empty() {
        return Err(format!(
            "{} at {ppm} particles per metre holds no particle",
            kind.name()
        ));
    }
    Ok(scene)
}

/// Particles per metre a built-in scene can have: finite, > 0, and giving a grid over
/// `domain`'s box.
pub fn check_ppm(ppm: f64, domain: &Domain) -> Result<(), String> {
    if !(ppm.is_finite() && ppm > 0.0) {
        return Err(format!(
            "particles per metre {ppm} is not a finite number > 0"
        ));
    }
    check_grid(ppm, Params::new(ppm).h, domain)
}

/// Whether `domain` takes the grid of blocks `cutoff` wide (a model's cut-off at `ppm`
/// particles per metre), said as [`check_ppm`] says it.
pub fn check_grid(ppm: f64, cutoff: f64, domain: &Domain) -> Result<(), String> {
    match Grid::new(cutoff, domain) {
        Ok(_) => Ok(()),
        Err(error) => Err(format!("particles per metre {ppm} gives {error}")),
    }
}

/// A column of fluid against the low-x wall of `domain` (SPEC.md's box, or its planar
/// section), `width` wide and `height` high (metres), through the box's whole depth, on
/// the jittered lattice at `ppm` (the dam break of the experiments: the full depth makes
/// it the quasi-2D column of a channel; a planar domain, the 2-D one).
pub fn water_column(
    ppm: f64,
    seed: u64,
    width: f64,
    height: f64,
    domain: &Domain,
) -> Result<Particles, String> {
    let extent = domain.extent();
    let fits = |size: f64, room: f64| size.is_finite() && size > 0.0 && size <= room;
    if !(fits(width, extent.x) && fits(height, extent.y)) {
        return Err(format!(
            "a column {width} m wide and {height} m high does not fit the box ({} x {} m)",
            extent.x, extent.y
        ));
    }
    check_ppm(ppm, domain)?;
    let [nx, ny, nz] = lattice_dims(ppm, domain);
    let column = lattice_within(ppm, seed, domain, [0..nx, 0..ny, 0..nz], |p| {
        p.x < domain.min.x + width && p.y < domain.min.y + height
    });
    if column.is_empty() {
        return Err(format!(
            "a column {width} m wide holds no particle at {ppm} per metre"
        ));
    }
    Ok(column)
}

/// Lattice points along x, y and z of `domain`'s box at `ppm` particles per metre:
/// floor(extent * ppm), to 1e-9 relative (a box of 0.2 m from 10 m is 0.1999999999999993
/// m wide, and holds 20 layers at 100 per metre, not 19).
fn lattice_dims(ppm: f64, domain: &Domain) -> [usize; 3] {
    (domain.extent() * ppm * (1.0 + 1e-9))
        .floor()
        .to_array()
        .map(|n| n as usize)
}

/// The lattice points of the course's box (spacing 1/`ppm`, half a spacing from the
/// walls, x fastest, then z, then y) for which `inside` holds, each jittered by up to
/// [`JITTER`] spacings per axis.
fn lattice(ppm: f64, seed: u64, inside: impl Fn(DVec3) -> bool) -> Particles {
    let domain = Domain::COURSE;
    let [nx, ny, nz] = lattice_dims(ppm, &domain);
    lattice_within(ppm, seed, &domain, [0..nx, 0..ny, 0..nz], inside)
}

/// The same in `domain`'s box, visiting only the lattice points of the index `ranges`
/// (x, y, z): all of them for which `inside` holds must be there.
fn lattice_within(
    ppm: f64,
    seed: u64,
    domain: &Domain,
    [xs, ys, zs]: [std::ops::Range<usize>; 3],
    inside: impl Fn(DVec3) -> bool,
) -> Particles {
    let spacing = 1.0 / ppm;
    let mut random = fastrand::Rng::with_seed(seed);
    let mut points = Vec::new();
    for y in ys {
        for z in zs.clone() {
            for x in xs.clone() {
                let k = DVec3::new(x as f64, y as f64, z as f64);
                let point = domain.min + (k + 0.5) * spacing;
                if inside(point) {
                    let jitter = DVec3::new(random.f64(), random.f64(), random.f64());
                    let mut point = point + (jitter * 2.0 - 1.0) * (JITTER * spacing);
                    // A planar scene's particles lie in the plane z = 0.
                    if domain.planar {
                        point.z = 0.0;
                    }
                    points.push(point);
                }
            }
        }
    }
    at_rest(&points)
}

/// `count` particles uniformly at random in the box.
fn random_cloud(count: usize, seed: u64) -> Particles {
    let mut random = fastrand::Rng::with_seed(seed);
    let extent = BOX_MAX - BOX_MIN;
    let points: Vec<DVec3> = (0..count)
        .map(|_| BOX_MIN + DVec3::new(random.f64(), random.f64(), random.f64()) * extent)
        .collect();
    at_rest(&points)
}

/// Particles at `points`, at rest.
fn at_rest(points: &[DVec3]) -> Particles {
    let mut particles = Particles::zeroed(points.len());
    for (slot, point) in points.iter().enumerate() {
        for axis in 0..3 {
            particles.p[axis][slot] = point[axis];
        }
    }
    particles
}

/// `count` particles at rest on a cubic lattice of spacing 1/`ppm`, half a spacing from
/// the walls: a block of fluid in the box's low corner, as close to a cube as the box
/// allows (x fastest, then z, then y, so the top layer may be partial). Blocks of any size
/// have the same inner density and shape, which makes them a fair scaling series.
/// An error if the box cannot hold `count`.
pub fn corner_block(ppm: f64, count: usize) -> Result<Particles, String> {
    let spacing = 1.0 / ppm;
    let extent = BOX_MAX - BOX_MIN;
    let [nx, ny, nz] = (extent / spacing).floor().to_array().map(|n| n as usize);
    let side = (count as f64).cbrt().ceil() as usize;
    let (wide, deep) = (side.min(nx), side.min(nz));
    if count > wide * deep * ny {
        return Err(format!(
            "a box at {ppm} particles per metre holds a corner block of at most {} particles",
            wide * deep * ny
        ));
    }
    let mut particles = Particles::zeroed(count);
    for slot in 0..count {
        let (x, z, y) = (slot % wide, (slot / wide) % deep, slot / (wide * deep));
        for (axis, k) in [x, y, z].into_iter().enumerate() {
            particles.p[axis][slot] = BOX_MIN[axis] + (k as f64 + 0.5) * spacing;
        }
    }
    Ok(particles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn positions(particles: &Particles) -> Vec<DVec3> {
        (0..particles.len())
            .map(|i| particles.position(i))
            .collect()
    }

    #[test]
    fn lattice_scenes_fill_their_regions_at_the_lattice_density() {
        let ppm = 200.0;
        let spacing = 1.0 / ppm;
        let extent = BOX_MAX - BOX_MIN;
        for kind in [SceneKind::DamBreak, SceneKind::Drop, SceneKind::FilledBox] {
            let scene = generate(kind, ppm, 7, None).unwrap();
            let points = positions(&scene);
            assert!(points
                .iter()
                .all(|p| p.cmpgt(BOX_MIN).all() && p.cmplt(BOX_MAX).all()));
            assert!(scene.v.iter().chain(&scene.hv).flatten().all(|&v| v == 0.0));
            // Every particle is within the jitter of its lattice point.
            for p in &points {
                let offset = (*p - BOX_MIN) / spacing - 0.5;
                let off_lattice = (offset - offset.round()).abs().max_element();
                assert!(off_lattice <= JITTER + 1e-9, "{kind:?} {p}");
            }
            let expected = match kind {
                // 26 x 36 x 26 lattice points: 10 of 26 columns below 0.4 width, 25 of 36
                // rows below 0.7 height.
                SceneKind::DamBreak => 10 * 25 * 26,
                SceneKind::FilledBox => 26 * 18 * 26,
                _ => 0,
            };
            if expected > 0 {
                assert_eq!(scene.len(), expected, "{kind:?}");
            }
        }
        let drop = positions(&generate(SceneKind::Drop, ppm, 7, None).unwrap());
        let pool_top = BOX_MIN.y + 0.15 * extent.y;
        let (pool, sphere): (Vec<DVec3>, Vec<DVec3>) = drop.iter().partition(|p| p.y < pool_top);
        assert_eq!(pool.len(), 26 * 5 * 26);
        // A sphere of radius 2.5 cm holds about 4/3 pi r^3 ppm^3 lattice points.
        let expected = 4.0 / 3.0 * std::f64::consts::PI * 0.025f64.powi(3) * ppm.powi(3);
        assert!(
            (sphere.len() as f64 / expected - 1.0).abs() < 0.05,
            "{}",
            sphere.len()
        );
        assert!(sphere.iter().all(|p| p.y > pool_top + 0.05));
    }

    #[test]
    fn the_case_of_a_lattice_scene_fills_the_same_particles() {
        for kind in [SceneKind::DamBreak, SceneKind::Drop, SceneKind::FilledBox] {
            let case = kind.case(150.0, 9, 0.5).unwrap();
            // Through the file's text and back.
            let text = toml::to_string(&case).unwrap();
            let read = case::parse(&text, "scene.toml").unwrap();
            let fills = Region::of_case(&read.fluid);
            assert_eq!(Some(fills.clone()), kind.regions(), "{kind:?}");
            let ppm = *read.fluid.particles_per_m.get_ref();
            let filled = filled(ppm, read.fluid.seed, &fills, &Domain::COURSE).unwrap();
            assert_eq!(filled, generate(kind, 150.0, 9, None).unwrap(), "{kind:?}");
        }
        for kind in [SceneKind::RandomCloud, SceneKind::CornerBlock] {
            assert!(kind.case(150.0, 9, 0.5).is_none());
        }
    }

    #[test]
    fn fills_that_hold_no_point_or_too_many_are_errors() {
        let speck = Region::Sphere {
            centre: DVec3::ZERO,
            radius: 1e-6,
        };
        let error = filled(100.0, 0, &[speck], &Domain::COURSE).unwrap_err();
        assert_eq!(
            error.to_string(),
            "this fill holds no lattice point at 100 particles per metre"
        );
        // Beside a fill that holds points, the empty one is named by its index.
        let cube = Region::Box {
            low: DVec3::ZERO,
            high: DVec3::splat(0.05),
        };
        let error = filled(100.0, 0, &[cube, speck], &Domain::COURSE).unwrap_err();
        assert_eq!(
            error,
            FillError::Empty {
                region: 1,
                ppm: 100.0
            }
        );
        // A small fill at a fine lattice: only its own points are visited.
        let cube = Region::Box {
            low: DVec3::ZERO,
            high: DVec3::splat(0.01),
        };
        assert_eq!(
            filled(2600.0, 0, &[cube], &Domain::COURSE).unwrap().len(),
            26 * 26 * 26
        );
        // Fills whose bounding box spans too many lattice points, whatever they hold.
        let far = Domain {
            min: DVec3::ZERO,
            max: DVec3::splat(20.0),
            ..Domain::COURSE
        };
        let specks = [DVec3::splat(0.01), DVec3::splat(19.99)].map(|centre| Region::Sphere {
            centre,
            radius: 0.005,
        });
        let error = filled(100.0, 0, &specks, &far).unwrap_err().to_string();
        assert!(error.contains("spans 8.000e9 lattice points"), "{error}");
    }

    #[test]
    fn a_box_away_from_the_origin_holds_every_layer_of_its_fill() {
        // 10.2 - 10.0 is 0.1999999999999993: still 20 layers at 100 per metre.
        let tank = Domain {
            min: DVec3::new(10.0, 5.0, -3.0),
            max: DVec3::new(10.2, 5.15, -2.9),
            ..Domain::COURSE
        };
        let full = Region::Box {
            low: tank.min,
            high: tank.max,
        };
        let particles = filled(100.0, 0, &[full], &tank).unwrap();
        assert_eq!(particles.len(), 20 * 15 * 10);
        assert!((0..particles.len()).all(|slot| tank.contains(particles.position(slot))));
    }

    #[test]
    fn the_seed_moves_the_jitter_and_the_cloud_only() {
        for kind in [SceneKind::DamBreak, SceneKind::RandomCloud] {
            let a = generate(kind, 150.0, 1, None).unwrap();
            assert_eq!(a, generate(kind, 150.0, 1, None).unwrap(), "{kind:?}");
            assert_ne!(a.p, generate(kind, 150.0, 2, None).unwrap().p, "{kind:?}");
        }
    }

    #[test]
    fn a_random_cloud_spreads_over_the_whole_box() {
        let cloud = generate(SceneKind::RandomCloud, 150.0, 3, Some(20_000)).unwrap();
        assert_eq!(cloud.len(), 20_000);
        let points = positions(&cloud);
        let mean = points.iter().sum::<DVec3>() / points.len() as f64;
        let centre = (BOX_MIN + BOX_MAX) / 2.0;
        assert!((mean - centre).abs().max_element() < 0.003, "{mean}");
        let low = points.iter().fold(DVec3::INFINITY, |m, p| m.min(*p));
        let high = points.iter().fold(DVec3::NEG_INFINITY, |m, p| m.max(*p));
        assert!((low - BOX_MIN).max_element() < 0.002 && (BOX_MAX - high).max_element() < 0.002);
        let default = generate(SceneKind::RandomCloud, 150.0, 3, None).unwrap();
        assert_eq!(default.len(), (0.3 * 19.0 * 27.0 * 19.0) as usize);
    }

    #[test]
    fn impossible_requests_are_errors() {
        let error = generate(SceneKind::DamBreak, 200.0, 0, Some(10)).unwrap_err();
        assert!(error.starts_with("--particles sets the size of"), "{error}");
        let error = generate(SceneKind::CornerBlock, 400.0, 0, Some(1_000_000)).unwrap_err();
        assert_eq!(
            error,
            "a box at 400 particles per metre holds a corner block of at most 194688 particles"
        );
        let error = generate(SceneKind::FilledBox, 10.0, 0, None).unwrap_err();
        assert_eq!(
            error,
            "particles per metre 10 gives a grid of 0 x 1 x 0 blocks, but a grid needs at \
             least 1 block per axis and at most 67108864 blocks"
        );
        let error = generate(SceneKind::FilledBox, 1e30, 0, None).unwrap_err();
        assert!(error.contains("gives a grid of 7.670e28 x "), "{error}");
        let error = generate(SceneKind::FilledBox, f64::NAN, 0, None).unwrap_err();
        assert_eq!(error, "particles per metre NaN is not a finite number > 0");
        let error = generate(SceneKind::FilledBox, 3000.0, 0, None).unwrap_err();
        assert!(error.contains("the limit is 50000000"), "{error}");
    }

    #[test]
    fn builds_a_cube_in_the_corner_on_a_regular_lattice() {
        let particles = corner_block(100.0, 125).unwrap();
        assert_eq!(particles.len(), 125);
        assert!((particles.position(0) - (BOX_MIN + 0.005)).length() < 1e-15);
        // Rows of 5 along x, 5 rows along z, 5 layers: spacing 0.01 m.
        let last = particles.position(124) - particles.position(0);
        assert!((last - glam::DVec3::splat(0.04)).length() < 1e-15);
        assert!((particles.p[2][5] - particles.p[2][0] - 0.01).abs() < 1e-15);
        assert!((particles.p[1][25] - particles.p[1][0] - 0.01).abs() < 1e-15);
    }

    #[test]
    fn a_block_wider_than_the_box_grows_upwards() {
        // A cube of 3000 would be 15 wide; 13 x 13 fit across the box at 100 per metre, so
        // the block takes 18 layers, the box's full height.
        let particles = corner_block(100.0, 3000).unwrap();
        assert!(corner_block(100.0, 13 * 13 * 18 + 1).is_err());
        let top = particles.p[1][..3000]
            .iter()
            .fold(f64::MIN, |m, &y| m.max(y));
        assert!((top - (BOX_MIN.y + 0.175)).abs() < 1e-15);
        assert!(particles.position(2999).cmplt(BOX_MAX).all());
    }

    #[test]
    fn refuses_more_than_the_box_holds() {
        let error = corner_block(20.0, 10_000).unwrap_err();
        assert!(error.contains("holds a corner block of at most"), "{error}");
    }
}
