//! The weakly compressible model's pair loop ([`crate::sim::model::wcsph`]): in one pass
//! over the candidate pairs (of the tiles, or of the neighbour lists), each pair's pressure and
//! viscosity acceleration and its density rates (the continuity equation and the
//! delta-SPH diffusion), added to both particles. A particle
//! within one support radius of a wall also meets the mirror images of its partners
//! across that wall (and across two or three walls at an edge or corner) and its own:
//! free-slip walls, or no-slip ones, whose images move at -v in the viscous terms (then
//! j's terms with the image of i take their own velocity difference,
//! [`partner_differences`]). An image of j is within the support of i only if j is within the
//! support of i and both are near that wall (|p_i - M p_j| >= |p_i - p_j| when both are
//! on the wall's side), so the images need no search of their own: each candidate pair
//! whose first particle is near a wall is also evaluated mirrored, and the image's
//! terms go to i and, mirrored back, to j. Across the floor an image's pressure is its
//! particle's plus the hydrostatic difference between them, rho g . (p' - p) (Adami et
//! al. 2012), and its density follows: the pressure keeps growing with depth, so the
//! floor holds water at rest.
//!
//! Five implementations: [`scalar`] (one pair at a time), [`lanes`] (a lane-width of
//! partners at a time over the tiles, on any [`Lanes`]), [`listed`] (the same lanes over
//! the [`NeighbourLists`], on dense scenes), [`across`] (a lane per particle over the
//! full lists' [`Rows`], the wall images as `listed`) and [`reference`] (each particle's
//! terms summed on their own in id order with compensated sums). All share [`pair`]'s formulas; the lanes
//! take one division per group where [`pair`] takes four (the viscosity's and the
//! diffusion's quotients from one reciprocal), which moves the last bits only.

use super::across::{add_lanes, lanes_of};
use super::reference::Neumaier;
use super::simd::{assert_padded, slots_used, Lanes, Site};
use super::PairPass;
use crate::sim::isa::Slots;
use crate::sim::lists::{NeighbourLists, Rows, ROW};
use crate::sim::neighbours::Tile;
use crate::sim::params::Domain;
use crate::sim::particles::{vector_at, AxisArrays};
use glam::DVec3;

/// The constants of the weakly compressible pair terms at one resolution and sound speed
/// (chosen by [`crate::sim::model::Wcsph`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WcsphConstants {
    /// Smoothing length h (m).
    pub h: f64,
    /// Support radius 2h (m), the pair cut-off.
    pub support: f64,
    /// Particle mass (kg).
    pub mass: f64,
    /// Sound speed c_0 (m/s).
    pub sound_speed: f64,
    /// 0.01 h^2, which keeps the viscosity and diffusion terms finite at r = 0.
    pub eta2: f64,
    /// G(0) of [`Self::gradient`]: 5 alpha_D / h^2, alpha_D = 21 / (16 pi h^3).
    pub gradient_factor: f64,
    /// Monaghan's artificial viscosity alpha.
    pub artificial_viscosity: f64,
    /// The delta-SPH density diffusion coefficient delta.
    pub density_diffusion: f64,
    /// The kinematic viscosity nu of the laminar term (m^2/s; 0: none).
    pub laminar_viscosity: f64,
    /// The no-slip walls, per axis low and high: their viscous terms meet images moving
    /// against their particles (-v), instead of mirrored ones (free slip).
    pub no_slip: [[bool; 2]; 3],
    /// The box whose walls mirror the particles, and gravity (along -y: the floor is the
    /// box's low y wall).
    pub domain: Domain,
}

impl WcsphConstants {
    /// The kernel gradient's factor G(r) >= 0, with grad_i W(r_ij) = -G r_ij: for the
    /// Wendland C2 kernel W = alpha_D (1 - q/2)^4 (2q + 1), q = r / h, it is
    /// 5 alpha_D / h^2 (1 - q/2)^3 within the support and 0 beyond.
    pub fn gradient(&self, r: f64) -> f64 {
        let w = (1.0 - 0.5 * r / self.h).max(0.0);
        self.gradient_factor * w * w * w
    }
}

/// The walls a particle's mirror images are taken across: per axis, the nearer box wall
/// if the particle is within one support radius of it. (Below 41 particles per metre a
/// particle can be within reach of both walls of x or z; only the nearer's images are
/// taken, and the kernels may differ in which they take: a column so coarse is no fluid.)
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearWalls {
    /// Bit k set if the particle is near a wall of axis k.
    pub axes: u8,
    /// The coordinate of that wall, per axis (unused where the bit is clear).
    pub at: [f64; 3],
    /// Bit k set if that wall of axis k is a no-slip one ([`Self::of_particle`]).
    pub no_slip: u8,
}

impl NearWalls {
    /// The walls of `domain`'s box within `support` of `position` (none along z in a
    /// planar domain, nor along a periodic axis).
    pub fn of(position: [f64; 3], support: f64, domain: &Domain) -> Self {
        let mut near = NearWalls {
            axes: 0,
            at: [0.0; 3],
            no_slip: 0,
        };
        let axes = position.into_iter().take(domain.dimensions()).enumerate();
        for (axis, x) in axes.filter(|&(axis, _)| !domain.periodic[axis]) {
            let (low, high) = (x - domain.min[axis], domain.max[axis] - x);
            if low.min(high) < support {
                near.axes |= 1 << axis;
                near.at[axis] = if low <= high {
                    domain.min[axis]
                } else {
                    domain.max[axis]
                };
            }
        }
        near
    }

    /// The walls near a particle at `position` with the pair terms' `constants`: which,
    /// and which of them are no-slip.
    pub fn of_particle(position: [f64; 3], constants: &WcsphConstants) -> Self {
        let mut near = Self::of(position, constants.support, &constants.domain);
        for axis in 0..3 {
            let high = usize::from(near.at[axis] == constants.domain.max[axis]);
            let no_slip = near.axes & (1 << axis) != 0 && constants.no_slip[axis][high];
            near.no_slip |= u8::from(no_slip) << axis;
        }
        near
    }

    /// Whether the images across the walls of `set` are no-slip ones (across any no-slip
    /// wall of the set; `set` 0, the partner itself, is none).
    pub fn is_no_slip(&self, set: u8) -> bool {
        set & self.no_slip != 0
    }

    /// Every non-empty set of the near walls' axes (as bits): the images across one wall,
    /// two (an edge) and three (a corner).
    pub fn images(self) -> impl Iterator<Item = u8> {
        (1..8u8).filter(move |&set| set & !self.axes == 0)
    }
}

/// The weakly compressible model's one pair pass: adds every pair's (and wall image's)
/// acceleration and density rates to `rates`, over the tiles or, where given, the
/// neighbour lists.
#[derive(Debug)]
pub struct WeaklyCompressible<'a> {
    /// The pair terms' constants.
    pub constants: &'a WcsphConstants,
    /// The candidate pairs.
    pub tiles: &'a [Tile],
    /// The neighbour lists of the same placement (within the support), which the SIMD
    /// kernels run on where given.
    pub lists: Option<&'a NeighbourLists>,
    /// What the pass reads.
    pub state: State<'a>,
    /// Each slot's particle (one per particle): the order of the reference kernel's sums.
    pub id: &'a [u32],
    /// What the pass adds to.
    pub rates: Rates<'a>,
}

impl PairPass for WeaklyCompressible<'_> {
    fn scalar(self) {
        scalar(self);
    }
    fn lanes<L: Lanes>(self) {
        match self.lists {
            Some(lists) => match lists.rows() {
                Some(rows) => across::<L>(self, lists, rows),
                None => listed::<L>(self, lists),
            },
            None => lanes::<L>(self),
        }
    }
    fn reference(self) {
        reference(self);
    }
}

/// What the pair loop reads: positions, velocities, densities and each particle's
/// p / rho^2.
#[derive(Debug, Clone, Copy)]
pub struct State<'a> {
    /// Positions.
    pub p: &'a AxisArrays,
    /// Velocities: [`crate::sim::model::wcsph::predicted_velocity`] (the leapfrog), or
    /// the particles' own predicted to the step's start (the velocity Verlet).
    pub v: &'a AxisArrays,
    /// Densities.
    pub rho: &'a [f64],
    /// p / rho^2 of each particle.
    pub pressure_terms: &'a [f64],
}

/// What the pair loop adds to: accelerations and density rates.
#[derive(Debug)]
pub struct Rates<'a> {
    /// Accelerations (gravity on entry).
    pub a: &'a mut AxisArrays,
    /// drho/dt (zero on entry).
    pub rho: &'a mut [f64],
}

/// The terms of particle i with partner (or image) j at offset `d` = p_i - p_j, velocity
/// difference `dv` = v_i - v_j (of the continuity equation) and `viscous`, the velocity
/// difference the viscous terms take (`dv`, or across a no-slip wall v_i + v_j): i's
/// acceleration (j gets its opposite) and the density rates of i and j; `None` beyond
/// the support.
#[inline(always)]
pub(super) fn pair(
    constants: &WcsphConstants,
    d: DVec3,
    [dv, viscous]: [DVec3; 2],
    [rho_i, rho_j]: [f64; 2],
    [pressure_i, pressure_j]: [f64; 2],
) -> Option<(DVec3, [f64; 2])> {
    let r2 = d.length_squared();
    let within = r2 < constants.support * constants.support;
    if !within {
        // Beyond the support, or not a number: as the lanes' mask takes it.
        return None;
    }
    let mass_gradient = constants.mass * constants.gradient(r2.sqrt());
    let inverse = 1.0 / (r2 + constants.eta2);
    let over_densities = inverse / (rho_i + rho_j);
    let viscosity = (-2.0
        * constants.artificial_viscosity
        * constants.sound_speed
        * constants.h
        * viscous.dot(d)
        * over_densities)
        .max(0.0);
    let laminar = 4.0 * constants.laminar_viscosity * mass_gradient * r2 * over_densities;
    let acceleration =
        d * (mass_gradient * (pressure_i + pressure_j + viscosity)) - viscous * laminar;
    let continuity = -mass_gradient * dv.dot(d);
    let diffusion = 2.0
        * constants.density_diffusion
        * constants.h
        * constants.sound_speed
        * mass_gradient
        * r2
        * inverse;
    let rates = [
        continuity + diffusion * (rho_j - rho_i) / rho_j,
        continuity + diffusion * (rho_i - rho_j) / rho_i,
    ];
    Some((acceleration, rates))
}

/// The velocity differences of `pair` for particle i (velocity `v_i`) with the image
/// across the walls of `set` of a partner j (velocity `v_j`; `set` 0: j itself): the
/// mirrored one, v_i - R v_j, and the viscous terms' (the same, or v_i + v_j across a
/// no-slip wall).
fn velocity_differences(no_slip: bool, v_i: DVec3, v_j: DVec3, set: u8) -> [DVec3; 2] {
    let dv = v_i - reflected(v_j, set);
    let viscous = if no_slip { v_i + v_j } else { dv };
    [dv, viscous]
}

/// The velocity differences j's side of an image pair takes in i's frame: its terms
/// with the image of i are -R times [`pair`]'s at (`d`, these), R the reflection of
/// `set`. The mirrored difference is i's own; the no-slip one is v_i + v_j negated off
/// the walls' axes.
fn partner_differences(no_slip: bool, [dv, viscous]: [DVec3; 2], set: u8) -> [DVec3; 2] {
    if no_slip {
        [dv, -reflected(viscous, set)]
    } else {
        [dv, viscous]
    }
}

/// `vector` with the axes of `set` (bits) negated: the reflection's linear part.
fn reflected(vector: DVec3, set: u8) -> DVec3 {
    let flip = |axis: usize| if set & (1 << axis) != 0 { -1.0 } else { 1.0 };
    vector * DVec3::new(flip(0), flip(1), flip(2))
}

/// The image of the point `p` across the walls of `set`.
fn mirrored(p: DVec3, set: u8, walls: &NearWalls) -> DVec3 {
    let wall = DVec3::from_array(walls.at);
    let image = 2.0 * wall - p;
    DVec3::select(
        glam::BVec3::new(set & 1 != 0, set & 2 != 0, set & 4 != 0),
        image,
        p,
    )
}

/// The p / rho^2 and density of the image at `image` of a particle at `p` with
/// `pressure` (p / rho^2) and density `rho`: below the floor, as water at rest continues,
/// its pressure is the particle's plus rho g . (image - p), and its density the
/// particle's plus that over c0^2 (Tait's law near rest). Above the ceiling (water
/// splashed against it, not resting under it) and beside the side walls, the particle's.
fn image_of(
    constants: &WcsphConstants,
    pressure: f64,
    rho: f64,
    p: DVec3,
    image: DVec3,
) -> (f64, f64) {
    let lift = constants.domain.gravity.dot(image - p).max(0.0);
    let inverse_c2 = 1.0 / (constants.sound_speed * constants.sound_speed);
    let rho_image = rho * (1.0 + lift * inverse_c2);
    let pressure_image = (pressure * rho * rho + rho * lift) / (rho_image * rho_image);
    (pressure_image, rho_image)
}

/// Every particle's terms with its own images (only it receives them).
fn self_images(constants: &WcsphConstants, state: State, n: usize, rates: &mut Rates) {
    for i in 0..n {
        let p = vector_at(state.p, i);
        let walls = NearWalls::of_particle(p.to_array(), constants);
        let v = vector_at(state.v, i);
        let (rho, pressure) = (state.rho[i], state.pressure_terms[i]);
        for set in walls.images() {
            let image = mirrored(p, set, &walls);
            let dv = velocity_differences(walls.is_no_slip(set), v, v, set);
            let (pressure_image, rho_image) = image_of(constants, pressure, rho, p, image);
            let (pressures, densities) = ([pressure, pressure_image], [rho, rho_image]);
            if let Some((da, [rate, _])) = pair(constants, p - image, dv, densities, pressures) {
                for axis in 0..3 {
                    rates.a[axis][i] += da[axis];
                }
                rates.rho[i] += rate;
            }
        }
    }
}

/// The pair loop one pair at a time.
pub(super) fn scalar(pass: WeaklyCompressible) {
    let WeaklyCompressible {
        constants,
        tiles,
        state,
        id,
        mut rates,
        ..
    } = pass;
    let (rates, n) = (&mut rates, id.len());
    for tile in tiles {
        for i in tile.firsts() {
            let p_i = vector_at(state.p, i);
            let walls = NearWalls::of_particle(p_i.to_array(), constants);
            for j in tile.partners(i) {
                let p_j = vector_at(state.p, j);
                pair_with_images(constants, &state, rates, [i, j], &walls, p_j);
            }
        }
    }
    self_images(constants, state, n, rates);
}

/// The terms of particles `i` and `j` with each other, `j` taken at `p_j` (its position,
/// or its copy across periodic faces), and with the images of `j` across the walls of
/// `i` (`walls`), added to both: the scalar loop's body.
#[inline(always)]
fn pair_with_images(
    constants: &WcsphConstants,
    state: &State,
    rates: &mut Rates,
    [i, j]: [usize; 2],
    walls: &NearWalls,
    p_j: DVec3,
) {
    let (p_i, v_i) = (vector_at(state.p, i), vector_at(state.v, i));
    let v_j = vector_at(state.v, j);
    let (rho_i, rho_j) = (state.rho[i], state.rho[j]);
    let (pressure_i, pressure_j) = (state.pressure_terms[i], state.pressure_terms[j]);
    let images = std::iter::once(0).chain(walls.images());
    for set in images {
        let image = mirrored(p_j, set, walls);
        let no_slip = walls.is_no_slip(set);
        let dv = velocity_differences(no_slip, v_i, v_j, set);
        let (pressure_image, rho_image) = image_of(constants, pressure_j, rho_j, p_j, image);
        let pressures = [pressure_i, pressure_image];
        let d = p_i - image;
        let terms = pair(constants, d, dv, [rho_i, rho_image], pressures);
        if let Some((da, [rate_i, rate_j])) = terms {
            // j meets the image of i, which across the floor has its own hydrostatic
            // pressure and density, and across a no-slip wall its own velocity.
            let floor = set & 0b010 != 0 && walls.at[1] == constants.domain.min.y;
            let own_terms = floor || no_slip;
            let (da_j, rate_j) = if !own_terms {
                (da, rate_j)
            } else {
                let (pressure_i, rho_i) = if floor {
                    let image_i = mirrored(p_i, set, walls);
                    image_of(constants, pressure_i, rho_i, p_i, image_i)
                } else {
                    (pressure_i, rho_i)
                };
                let pressures = [pressure_i, pressure_j];
                let dv = partner_differences(no_slip, dv, set);
                let terms = pair(constants, d, dv, [rho_i, rho_j], pressures);
                terms.map_or((DVec3::ZERO, 0.0), |(da_j, [_, rate_j])| (da_j, rate_j))
            };
            let back = reflected(da_j, set);
            for axis in 0..3 {
                rates.a[axis][i] += da[axis];
                rates.a[axis][j] -= back[axis];
            }
            rates.rho[i] += rate_i;
            rates.rho[j] += rate_j;
        }
    }
}

/// The pairs across the domain's periodic faces, added to `rates` after any kernel's
/// pass (which finds only the pairs within the box): each particle within the support of
/// a periodic face meets the copies, shifted by the box's length, of the particles
/// within the support of the opposite face (and across two or three faces at an edge or
/// a corner), as a pair of [`pair_with_images`], its walls' images included. Each pair is
/// taken once, in id order (the first particle's, then its partners' in each cell of a
/// fixed order), so its sums depend on the particles alone. A box at least 3 cut-offs
/// long on each periodic axis ([`crate::sim::grid::Grid`]) has no pair both within it
/// and across a face.
pub fn periodic_pairs(constants: &WcsphConstants, state: State, id: &[u32], rates: &mut Rates) {
    let domain = &constants.domain;
    let axes: Vec<usize> = (0..3).filter(|&axis| domain.periodic[axis]).collect();
    if axes.is_empty() {
        return;
    }
    let (n, support) = (id.len(), constants.support);
    let mut slot_of_id = vec![0usize; n];
    for (slot, &i) in id.iter().enumerate() {
        slot_of_id[i as usize] = slot;
    }
    let length = domain.max - domain.min;
    let cell = |p: DVec3| (p / support).floor().as_i64vec3().to_array();
    // Each shift s (per periodic axis -1, 0 or 1, not all 0) with its first non-zero
    // component 1: j's copy at p_j + s L, i near the faces s points to, j near the others.
    for code in 1..3usize.pow(axes.len() as u32) {
        let mut shift = [0i32; 3];
        let mut rest = code;
        for &axis in &axes {
            shift[axis] = (rest % 3) as i32 - 1;
            rest /= 3;
        }
        if axes.iter().map(|&axis| shift[axis]).find(|&s| s != 0) != Some(1) {
            continue;
        }
        let near = |p: DVec3, towards: i32| {
            axes.iter().all(|&axis| match shift[axis] * towards {
                1 => p[axis] >= domain.max[axis] - support,
                -1 => p[axis] < domain.min[axis] + support,
                _ => true,
            })
        };
        let offset = DVec3::from_array(shift.map(f64::from)) * length;
        let mut copies: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
        for &slot in &slot_of_id {
            let p = vector_at(state.p, slot);
            if near(p, -1) {
                copies.entry(cell(p + offset)).or_default().push(slot);
            }
        }
        if copies.is_empty() {
            continue;
        }
        for &i in &slot_of_id {
            let p_i = vector_at(state.p, i);
            if !near(p_i, 1) {
                continue;
            }
            let walls = NearWalls::of_particle(p_i.to_array(), constants);
            let [x, y, z] = cell(p_i);
            for (dx, dy, dz) in (-1..=1)
                .flat_map(|dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dz| (dx, dy, dz))))
            {
                for &j in copies.get(&[x + dx, y + dy, z + dz]).into_iter().flatten() {
                    let p_j = vector_at(state.p, j) + offset;
                    pair_with_images(constants, &state, rates, [i, j], &walls, p_j);
                }
            }
        }
    }
}

/// The pair loop with each particle's terms summed on their own over its partners and
/// images in id order, with compensated sums: the reference trajectory's.
pub(super) fn reference(pass: WeaklyCompressible) {
    let WeaklyCompressible {
        constants,
        tiles,
        state,
        id,
        mut rates,
        ..
    } = pass;
    let (rates, n) = (&mut rates, id.len());
    let support2 = constants.support * constants.support;
    let mut partners = vec![Vec::new(); n];
    for tile in tiles {
        for i in tile.firsts() {
            for j in tile.partners(i) {
                let r2 = (vector_at(state.p, i) - vector_at(state.p, j)).length_squared();
                if r2 < support2 {
                    partners[i].push(j as u32);
                    partners[j].push(i as u32);
                }
            }
        }
    }
    for (i, list) in partners.iter_mut().enumerate() {
        list.push(i as u32);
        list.sort_unstable_by_key(|&j| id[j as usize]);
        let (p_i, v_i) = (vector_at(state.p, i), vector_at(state.v, i));
        let walls = NearWalls::of_particle(p_i.to_array(), constants);
        let mut a = [0, 1, 2].map(|axis| Neumaier::new(rates.a[axis][i]));
        let mut rate = Neumaier::new(rates.rho[i]);
        for &j in list.iter() {
            let j = j as usize;
            let (p_j, v_j) = (vector_at(state.p, j), vector_at(state.v, j));
            let (pressure_j, rho_j) = (state.pressure_terms[j], state.rho[j]);
            let own = usize::from(j == i);
            for set in std::iter::once(0).chain(walls.images()).skip(own) {
                let image = mirrored(p_j, set, &walls);
                let dv = velocity_differences(walls.is_no_slip(set), v_i, v_j, set);
                let (pressure_image, rho_image) =
                    image_of(constants, pressure_j, rho_j, p_j, image);
                let pressure = [state.pressure_terms[i], pressure_image];
                let rho = [state.rho[i], rho_image];
                if let Some((da, [rate_i, _])) = pair(constants, p_i - image, dv, rho, pressure) {
                    for (sum, term) in a.iter_mut().zip(da.to_array()) {
                        sum.add(term);
                    }
                    rate.add(rate_i);
                }
            }
        }
        for (axis, sum) in a.into_iter().enumerate() {
            rates.a[axis][i] = sum.total();
        }
        rates.rho[i] = rate.total();
    }
}

/// The particle whose partners a group loop visits.
struct First {
    p: [f64; 3],
    v: [f64; 3],
    rho: f64,
    pressure: f64,
    walls: NearWalls,
    /// The sets of walls its partners' images are taken across ([`NearWalls::images`]),
    /// the first `image_count`.
    images: [u8; 7],
    image_count: usize,
    /// Near the floor: the p / rho^2 and density of its image below it ([`image_of`]),
    /// which its partners meet.
    floor_image: Option<(f64, f64)>,
}

/// The arrays and constants of the lanes loop.
struct Pairs<'a, L: Lanes> {
    state: State<'a>,
    support2: L::V,
    over_2h: L::V,
    one: L::V,
    zero: L::V,
    mass_gradient: L::V,
    viscosity: L::V,
    diffusion: L::V,
    eta2: L::V,
    twice_gravity: L::V,
    inverse_sound_speed2: L::V,
    /// 4 nu of the laminar term.
    laminar: L::V,
    /// Whether there is a laminar term (nu > 0).
    laminar_term: bool,
}

/// One group's terms: i's acceleration and the partners' (before reflection; per axis),
/// and the rates of i and of the partners.
type GroupTerms<L> = (
    [<L as Lanes>::V; 3],
    [<L as Lanes>::V; 3],
    <L as Lanes>::V,
    <L as Lanes>::V,
);

impl<L: Lanes> Pairs<'_, L> {
    /// The terms of `first` with the partners at `at` (lanes of `lanes`), or with their
    /// images across the walls of `set` (0: the partners themselves); zero in lanes beyond
    /// the support, `None` if every lane is. `NO_SLIP`: the images are those of no-slip
    /// walls, whose viscous terms take v_i + v_j (i's side) and its mirror (j's side,
    /// [`partner_differences`]). `LAMINAR`: with the laminar viscous term.
    ///
    /// # Safety
    /// Every place of `at` is within every array of the state.
    #[inline(always)]
    unsafe fn group<const NO_SLIP: bool, const LAMINAR: bool>(
        &self,
        first: &First,
        at: impl Site,
        lanes: L::V,
        set: u8,
    ) -> Option<GroupTerms<L>> {
        let v = self.state.v;
        let across = |axis: usize| set & (1 << axis) != 0;
        // SAFETY: guaranteed by the caller.
        let velocity = |axis: usize| unsafe {
            if across(axis) {
                L::differences(&v[axis], at, -first.v[axis])
            } else {
                L::offsets(&v[axis], at, first.v[axis])
            }
        };
        // SAFETY: guaranteed by the caller.
        let (d, r2) = unsafe { self.offsets(first, at, set) };
        let close = L::lt(r2, self.support2) & lanes;
        if !L::any(close) {
            return None;
        }
        let w = self.one - L::sqrt(r2) * self.over_2h;
        let mass_gradient = self.mass_gradient * (w * w * w);
        let dv = [velocity(0), velocity(1), velocity(2)];
        let dot = |u: &[L::V; 3]| u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
        let approach = dot(&dv);
        // The viscous terms' velocity differences, i's and j's (in i's frame): off the
        // walls' axes, v_i + v_j = 2 v_i - dv and its opposite.
        let (viscous_i, viscous_j) = if NO_SLIP {
            let twice = |axis: usize| L::splat(2.0 * first.v[axis]);
            let side = |axis: usize, sign: f64| {
                if across(axis) {
                    dv[axis]
                } else {
                    L::splat(sign) * (twice(axis) - dv[axis])
                }
            };
            (
                [side(0, 1.0), side(1, 1.0), side(2, 1.0)],
                [side(0, -1.0), side(1, -1.0), side(2, -1.0)],
            )
        } else {
            (dv, dv)
        };
        let (approach_i, approach_j) = if NO_SLIP {
            (dot(&viscous_i), dot(&viscous_j))
        } else {
            (approach, approach)
        };
        // SAFETY: guaranteed by the caller.
        let (rho_j, pressure_j) = unsafe {
            (
                L::load(self.state.rho, at),
                L::load(self.state.pressure_terms, at),
            )
        };
        let rho_i = L::splat(first.rho);
        let pressure_i = L::splat(first.pressure);
        let viscosity =
            |approach_over: L::V| L::max(self.zero - self.viscosity * approach_over, self.zero);
        let continuity = self.zero - mass_gradient * approach;
        // The acceleration d (pressure and artificial viscosity) - K u (laminar), masked.
        let terms = |scale: L::V, laminar: L::V, u: &[L::V; 3]| {
            [0, 1, 2].map(|axis| match LAMINAR {
                true => (d[axis] * scale - u[axis] * laminar) & close,
                false => (d[axis] * scale) & close,
            })
        };
        let laminar_factor = self.laminar * mass_gradient * r2;
        let softened = r2 + self.eta2;
        let floor_image = first.floor_image.filter(|_| across(1));
        let Some((pressure_i_image, rho_i_image)) = floor_image else {
            let pair = Pair {
                d,
                r2,
                close,
                mass_gradient,
                continuity,
                rho: [rho_i, rho_j],
                pressure: [pressure_i, pressure_j],
            };
            let viscous = [viscous_i, viscous_j];
            return Some(self.off_floor::<NO_SLIP, LAMINAR>(
                pair,
                viscous,
                [approach_i, approach_j],
            ));
        };
        let inverse = self.one / softened;
        let diffusion = self.diffusion * mass_gradient * r2 * inverse;
        // Across the floor an image's pressure differs from its particle's by
        // rho g_y (y' - y), and its density by that over c0^2 ([`image_of`]): j's image
        // lies y'_j - y_j = 2 (y_i - w) - 2 d_y from j; i's is the first's own.
        let height = first.p[1] - first.walls.at[1];
        let lift_j = self.twice_gravity * (L::splat(height) - d[1]);
        let rho_j_image = rho_j + rho_j * lift_j * self.inverse_sound_speed2;
        let pressure_j_image = (pressure_j * rho_j + lift_j) * rho_j / (rho_j_image * rho_j_image);
        let (rho_i_image, pressure_i_image) = (L::splat(rho_i_image), L::splat(pressure_i_image));
        let over_i = inverse / (rho_i + rho_j_image);
        let over_j = inverse / (rho_i_image + rho_j);
        let scale_i =
            mass_gradient * (pressure_i + pressure_j_image + viscosity(approach_i * over_i));
        let scale_j =
            mass_gradient * (pressure_i_image + pressure_j + viscosity(approach_j * over_j));
        let rate_i = (continuity + diffusion * (rho_j_image - rho_i) / rho_j_image) & close;
        let rate_j = (continuity + diffusion * (rho_i_image - rho_j) / rho_i_image) & close;
        Some((
            terms(scale_i, laminar_factor * over_i, &viscous_i),
            terms(scale_j, laminar_factor * over_j, &viscous_j),
            rate_i,
            rate_j,
        ))
    }
}

/// What a group's terms off the floor's images take: the offsets `p_i - p_j` and their
/// squared length, the lanes within the support, the kernel's gradient times the mass,
/// the continuity term, and both particles' densities and p / rho^2.
struct Pair<V> {
    d: [V; 3],
    r2: V,
    close: V,
    mass_gradient: V,
    continuity: V,
    rho: [V; 2],
    pressure: [V; 2],
}

impl<L: Lanes> Pairs<'_, L> {
    /// The terms of `pair` (not an image across the floor) with the viscous velocity
    /// differences `viscous` and their approaches (i's, then j's: [`Self::group`]).
    #[inline(always)]
    fn off_floor<const NO_SLIP: bool, const LAMINAR: bool>(
        &self,
        pair: Pair<L::V>,
        [viscous_i, viscous_j]: [[L::V; 3]; 2],
        [approach_i, approach_j]: [L::V; 2],
    ) -> GroupTerms<L> {
        let Pair {
            d,
            r2,
            close,
            mass_gradient,
            continuity,
            rho: [rho_i, rho_j],
            pressure: [pressure_i, pressure_j],
        } = pair;
        let viscosity =
            |approach_over: L::V| L::max(self.zero - self.viscosity * approach_over, self.zero);
        let terms = |scale: L::V, laminar: L::V, u: &[L::V; 3]| {
            [0, 1, 2].map(|axis| match LAMINAR {
                true => (d[axis] * scale - u[axis] * laminar) & close,
                false => (d[axis] * scale) & close,
            })
        };
        let laminar_factor = self.laminar * mass_gradient * r2;
        let softened = r2 + self.eta2;
        // One division for the lanes' three quotients: 1 / (softened (rho_i + rho_j))
        // of the viscosities, and 1 / rho_j, 1 / rho_i of the diffusion.
        let (densities, product) = (rho_i + rho_j, rho_i * rho_j);
        let denominator = softened * densities;
        let reciprocal = self.one / (denominator * product);
        let over_denominator = reciprocal * product;
        let over_product = reciprocal * denominator;
        let pressures = pressure_i + pressure_j;
        let scale =
            |approach: L::V| mass_gradient * (pressures + viscosity(approach * over_denominator));
        let laminar = laminar_factor * over_denominator;
        let diffusion = self.diffusion * mass_gradient * r2 * densities * over_denominator;
        let difference = (rho_j - rho_i) * diffusion * over_product;
        let rate_i = (continuity + difference * rho_i) & close;
        let rate_j = (continuity - difference * rho_j) & close;
        let da = terms(scale(approach_i), laminar, &viscous_i);
        let da_j = if NO_SLIP {
            terms(scale(approach_j), laminar, &viscous_j)
        } else {
            da
        };
        (da, da_j, rate_i, rate_j)
    }
}

impl First {
    /// Particle `i` of `state`.
    fn of(constants: &WcsphConstants, state: &State, i: usize) -> Self {
        let position = [0, 1, 2].map(|axis| state.p[axis][i]);
        let walls = NearWalls::of_particle(position, constants);
        let (rho, pressure) = (state.rho[i], state.pressure_terms[i]);
        let floor_image =
            (walls.axes & 0b010 != 0 && walls.at[1] == constants.domain.min.y).then(|| {
                let p = DVec3::from_array(position);
                image_of(constants, pressure, rho, p, mirrored(p, 0b010, &walls))
            });
        let mut images = [0; 7];
        let mut image_count = 0;
        for set in walls.images() {
            images[image_count] = set;
            image_count += 1;
        }
        First {
            p: position,
            v: [0, 1, 2].map(|axis| state.v[axis][i]),
            rho,
            pressure,
            walls,
            images,
            image_count,
            floor_image,
        }
    }
}

impl<'a, L: Lanes> Pairs<'a, L> {
    /// The lanes loop's constants, on `state`.
    fn new(constants: &WcsphConstants, state: State<'a>) -> Self {
        Pairs {
            state,
            support2: L::splat(constants.support * constants.support),
            over_2h: L::splat(0.5 / constants.h),
            one: L::splat(1.0),
            zero: L::splat(0.0),
            mass_gradient: L::splat(constants.mass * constants.gradient_factor),
            viscosity: L::splat(
                2.0 * constants.artificial_viscosity * constants.sound_speed * constants.h,
            ),
            diffusion: L::splat(
                2.0 * constants.density_diffusion * constants.h * constants.sound_speed,
            ),
            eta2: L::splat(constants.eta2),
            twice_gravity: L::splat(2.0 * constants.domain.gravity.y),
            inverse_sound_speed2: L::splat(1.0 / (constants.sound_speed * constants.sound_speed)),
            laminar: L::splat(4.0 * constants.laminar_viscosity),
            laminar_term: constants.laminar_viscosity != 0.0,
        }
    }

    /// The offsets of `first` from the partners at `at`, or from their images across the
    /// walls of `set` (0: the partners themselves), and their squares' sum: one formula
    /// for the distance filter and the pair terms.
    ///
    /// # Safety
    /// Every place of `at` is within the positions.
    #[inline(always)]
    unsafe fn offsets(&self, first: &First, at: impl Site, set: u8) -> ([L::V; 3], L::V) {
        let p = self.state.p;
        // SAFETY: guaranteed by the caller.
        let offset = |axis: usize| unsafe {
            if set & (1 << axis) != 0 {
                L::differences(&p[axis], at, 2.0 * first.walls.at[axis] - first.p[axis])
            } else {
                L::offsets(&p[axis], at, first.p[axis])
            }
        };
        let d = [offset(0), offset(1), offset(2)];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        (d, r2)
    }

    /// The terms of `first` with the partners at `at` (lanes of `lanes`) and
    /// with their images across `first`'s walls: `first`'s added to `sums` (its
    /// acceleration by axis, then its density rate), the partners' to `targets` (the same,
    /// by place).
    ///
    /// # Safety
    /// Every place of `at` is within every array of the state and `targets`.
    #[inline(always)]
    unsafe fn visit(
        &self,
        first: &First,
        at: impl Site,
        lanes: L::V,
        sums: &mut [L::Sum; 4],
        targets: &mut [&mut [f64]; 4],
    ) {
        // SAFETY (both): guaranteed by the caller. The partners themselves first (set 0,
        // which the compiler folds into the group), then their images.
        unsafe { self.add_group(first, at, lanes, 0, sums, targets) };
        unsafe { self.visit_images(first, at, lanes, sums, targets) };
    }

    /// [`Self::visit`]'s terms with the partners' images alone.
    ///
    /// # Safety
    /// As for [`Self::visit`].
    #[inline(always)]
    unsafe fn visit_images(
        &self,
        first: &First,
        at: impl Site,
        lanes: L::V,
        sums: &mut [L::Sum; 4],
        targets: &mut [&mut [f64]; 4],
    ) {
        for &set in &first.images[..first.image_count] {
            // SAFETY: guaranteed by the caller.
            unsafe { self.add_group(first, at, lanes, set, sums, targets) };
        }
    }

    /// The terms of the particles of `first`'s lanes (p, v, rho, p / rho^2 in f64 where
    /// the lanes narrow) with the partners at `at` themselves (lanes of `lanes`): each
    /// lane's own acceleration by axis, then its density rate; `None` if no lane is within
    /// the support. A lane's terms are the exact negation of those [`Self::group`] gives
    /// its partner with it.
    ///
    /// # Safety
    /// Every place of `at` is within every array of the state.
    #[inline(always)]
    unsafe fn own_terms(
        &self,
        first: &Lanesful<L>,
        at: Slots,
        lanes: L::V,
    ) -> Option<([L::V; 3], L::V)> {
        // `center - ` the lanes of `values` at `at`, narrowed (written out: a map of the
        // axes is not inlined).
        // SAFETY (each): guaranteed by the caller.
        let offsets = |values: &AxisArrays, center: &[L::F64; 3]| unsafe {
            [
                L::narrowed(center[0] - L::load_f64(&values[0], at)),
                L::narrowed(center[1] - L::load_f64(&values[1], at)),
                L::narrowed(center[2] - L::load_f64(&values[2], at)),
            ]
        };
        let d = offsets(self.state.p, &first.p);
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let close = L::lt(r2, self.support2) & lanes;
        if !L::any(close) {
            return None;
        }
        let dv = offsets(self.state.v, &first.v);
        let w = self.one - L::sqrt(r2) * self.over_2h;
        let mass_gradient = self.mass_gradient * (w * w * w);
        let approach = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
        // SAFETY: guaranteed by the caller.
        let (rho_j, pressure_j) = unsafe {
            (
                L::load(self.state.rho, at),
                L::load(self.state.pressure_terms, at),
            )
        };
        let pair = Pair {
            d,
            r2,
            close,
            mass_gradient,
            continuity: self.zero - mass_gradient * approach,
            rho: [first.rho, rho_j],
            pressure: [first.pressure, pressure_j],
        };
        let (viscous, approaches) = ([dv, dv], [approach, approach]);
        let (da, _, rate, _) = match self.laminar_term {
            false => self.off_floor::<false, false>(pair, viscous, approaches),
            true => self.off_floor::<false, true>(pair, viscous, approaches),
        };
        Some((da, rate))
    }

    /// [`Self::group`]'s terms, added: `first`'s to `sums`, the partners' to `targets`
    /// ([`Self::visit`]).
    ///
    /// # Safety
    /// As for [`Self::visit`].
    #[inline(always)]
    unsafe fn add_group(
        &self,
        first: &First,
        at: impl Site,
        lanes: L::V,
        set: u8,
        sums: &mut [L::Sum; 4],
        targets: &mut [&mut [f64]; 4],
    ) {
        // SAFETY: guaranteed by the caller.
        // SAFETY (each): guaranteed by the caller.
        let terms = match (first.walls.is_no_slip(set), self.laminar_term) {
            (false, false) => unsafe { self.group::<false, false>(first, at, lanes, set) },
            (false, true) => unsafe { self.group::<false, true>(first, at, lanes, set) },
            (true, false) => unsafe { self.group::<true, false>(first, at, lanes, set) },
            (true, true) => unsafe { self.group::<true, true>(first, at, lanes, set) },
        };
        let Some((da, da_j, rate_i, rate_j)) = terms else {
            return;
        };
        for axis in 0..3 {
            L::accumulate(&mut sums[axis], da[axis]);
            // SAFETY: guaranteed by the caller. An image's force on j is mirrored back.
            unsafe {
                if set & (1 << axis) != 0 {
                    L::add_to(targets[axis], at, da_j[axis]);
                } else {
                    L::subtract_from(targets[axis], at, da_j[axis]);
                }
            }
        }
        L::accumulate(&mut sums[3], rate_i);
        // SAFETY: guaranteed by the caller.
        unsafe { L::add_to(targets[3], at, rate_j) };
    }
}

/// The pair loop on `L` lanes, over the tiles.
pub(super) fn lanes<L: Lanes>(pass: WeaklyCompressible) {
    let WeaklyCompressible {
        constants,
        tiles,
        state,
        id,
        mut rates,
        ..
    } = pass;
    let (rates, n) = (&mut rates, id.len());
    let ([x, y, z], [vx, vy, vz]) = (state.p, state.v);
    let [ax, ay, az] = &mut *rates.a;
    let arrays = [&x[..], y, z, vx, vy, vz, state.rho, state.pressure_terms];
    assert_padded(slots_used(tiles), L::LANES, &arrays);
    assert_padded(slots_used(tiles), L::LANES, &[ax, ay, az, rates.rho]);
    let pairs = Pairs::<L>::new(constants, state);
    let mut targets = [&mut ax[..], ay, az, rates.rho];
    for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
        for i in cell_tiles[0].firsts() {
            let first = First::of(constants, &state, i);
            let mut sums = [L::ZERO_SUM; 4];
            for tile in cell_tiles {
                let partners = tile.partners(i);
                for j in partners.clone().step_by(L::LANES) {
                    let lanes = L::first(partners.end - j);
                    // SAFETY: j < partners.end <= slots_used(tiles), and assert_padded
                    // checked that every array holds slots_used(tiles) + PADDING
                    // elements, PADDING >= LANES - 1, so j + LANES <= len.
                    unsafe { pairs.visit(&first, j, lanes, &mut sums, &mut targets) };
                }
            }
            for (target, sum) in targets.iter_mut().zip(sums) {
                target[i] += L::total(sum);
            }
        }
    }
    self_images(constants, state, n, rates);
}

/// The pair loop on `L` lanes over `lists`: each particle with its listed partners (and
/// their images across its walls), a register of them at a time, the last group's lanes
/// past the list masked; the partners' terms are added lane after lane (a masked lane
/// may repeat a slot, and adds zero).
pub(super) fn listed<L: Lanes>(pass: WeaklyCompressible, lists: &NeighbourLists) {
    let WeaklyCompressible {
        constants,
        state,
        id,
        mut rates,
        ..
    } = pass;
    let (rates, n) = (&mut rates, id.len());
    let bound = lists.slots();
    let ([x, y, z], [vx, vy, vz]) = (state.p, state.v);
    let [ax, ay, az] = &mut *rates.a;
    let arrays = [&x[..], y, z, vx, vy, vz, state.rho, state.pressure_terms];
    assert!(arrays.iter().all(|array| array.len() >= bound));
    assert!([&ax[..], ay, az, rates.rho]
        .iter()
        .all(|array| array.len() >= bound));
    let pairs = Pairs::<L>::new(constants, state);
    let mut targets = [&mut ax[..], ay, az, rates.rho];
    // SAFETY: every array of the state and of the targets holds `bound` (asserted above).
    unsafe { over_half_lists::<L, false>(&pairs, constants, lists, &mut targets) };
    self_images(constants, state, n, rates);
}

/// Each particle of `lists` with its half list, a register of partners at a time (the
/// last group's lanes past the list masked): all their terms ([`Pairs::visit`]), or
/// (`IMAGES_ONLY`), for the particles near a wall, their images' alone.
///
/// # Safety
/// Every array of the pairs' state and of `targets` holds the lists' slots.
unsafe fn over_half_lists<L: Lanes, const IMAGES_ONLY: bool>(
    pairs: &Pairs<L>,
    constants: &WcsphConstants,
    lists: &NeighbourLists,
    targets: &mut [&mut [f64]; 4],
) {
    let (state, entries, bound) = (&pairs.state, lists.entries(), lists.slots());
    for i in 0..bound {
        let range = lists.range(i);
        let position = || [0, 1, 2].map(|axis| state.p[axis][i]);
        let near_walls = || NearWalls::of_particle(position(), constants);
        if range.is_empty() || (IMAGES_ONLY && near_walls().axes == 0) {
            continue;
        }
        let first = First::of(constants, state, i);
        let mut sums = [L::ZERO_SUM; 4];
        for k in range.clone().step_by(L::LANES) {
            let at = Slots::new(entries[k..k + 8].try_into().expect("8 entries"), bound);
            let lanes = if k + L::LANES <= range.end {
                L::all()
            } else {
                L::first(range.end - k)
            };
            // SAFETY: every slot of `at` is below `bound` (Slots::new), which every array
            // of the state and of the targets holds (the caller's).
            unsafe {
                match IMAGES_ONLY {
                    true => pairs.visit_images(&first, at, lanes, &mut sums, targets),
                    false => pairs.visit(&first, at, lanes, &mut sums, targets),
                }
            };
        }
        for (target, sum) in targets.iter_mut().zip(sums) {
            target[i] += L::total(sum);
        }
    }
}

/// The particles of a register's lanes, as [`Pairs::own_terms`] reads them.
struct Lanesful<L: Lanes> {
    p: [L::F64; 3],
    v: [L::F64; 3],
    rho: L::V,
    pressure: L::V,
}

/// The pair loop on `L` lanes across particles: each particle with the partners
/// themselves over the full lists' `rows`, a lane per particle of a block and its own
/// terms only (each pair is in both particles' lists); then each particle near a wall
/// with its half list's images (`lists`), whose terms go to both, as [`listed`]'s; then
/// the particles' own images.
pub(super) fn across<L: Lanes>(pass: WeaklyCompressible, lists: &NeighbourLists, rows: &Rows) {
    let WeaklyCompressible {
        constants,
        state,
        id,
        mut rates,
        ..
    } = pass;
    let (rates, n) = (&mut rates, id.len());
    let bound = lists.slots();
    assert_eq!(rows.far() as usize, bound);
    let ([x, y, z], [vx, vy, vz]) = (state.p, state.v);
    let [ax, ay, az] = &mut *rates.a;
    // A block's lanes read their own slots up to the last block's end, and the padding
    // slot `bound`.
    let read = (bound.next_multiple_of(ROW)).max(bound + 1);
    let arrays = [&x[..], y, z, vx, vy, vz, state.rho, state.pressure_terms];
    assert!(arrays.iter().all(|array| array.len() >= read));
    assert!([&ax[..], ay, az, rates.rho]
        .iter()
        .all(|array| array.len() >= bound));
    let pairs = Pairs::<L>::new(constants, state);
    let mut targets = [&mut ax[..], ay, az, rates.rho];
    for block in 0..rows.blocks() {
        let lengths = rows.lengths(block).map(f64::from);
        for from in (0..ROW).step_by(L::LANES) {
            let first = block * ROW + from;
            if first >= bound {
                break;
            }
            // SAFETY (each): first + LANES <= the last block's end, within every array
            // (asserted above).
            let own = |values: &[f64]| unsafe { L::load_f64(values, first) };
            let lanes = Lanesful::<L> {
                p: [own(x), own(y), own(z)],
                v: [own(vx), own(vy), own(vz)],
                rho: unsafe { L::load(state.rho, first) },
                pressure: unsafe { L::load(state.pressure_terms, first) },
            };
            // SAFETY: 8 lengths, read from `from` (< 8, by LANES).
            let length = unsafe { L::load(&lengths, from) };
            let mut sums = [L::ZERO_SUM; 4];
            for (m, row) in rows.rows(block).iter().enumerate() {
                let at = lanes_of(row, from, bound + 1);
                // The lanes whose lists reach this row (past them, the padding slot).
                let listed = L::lt(L::splat(m as f64), length);
                // SAFETY: every slot of `at` is at most `bound`, within every array of the
                // state (asserted above).
                if let Some((da, rate)) = unsafe { pairs.own_terms(&lanes, at, listed) } {
                    for (sum, terms) in sums.iter_mut().zip(da.into_iter().chain([rate])) {
                        L::accumulate(sum, terms);
                    }
                }
            }
            for (target, sum) in targets.iter_mut().zip(sums) {
                add_lanes(target, first, bound, L::lanes(sum), L::LANES);
            }
        }
    }
    // SAFETY: every array of the state and of the targets holds `bound` (asserted above).
    unsafe { over_half_lists::<L, true>(&pairs, constants, lists, &mut targets) };
    self_images(constants, state, n, rates);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::kernel::Kernel;
    use crate::sim::lists::PairStructure;
    use crate::sim::method::Method;
    use crate::sim::model::wcsph::{Settings, WallFriction};
    use crate::sim::model::{Model, Wcsph};
    use crate::sim::params::{BOX_MAX, BOX_MIN, GRAVITY};
    use crate::sim::particles::{Particles, PADDING};
    use crate::sim::simulation::Simulation;
    use crate::sim::stages::Stage;
    use std::f64::consts::PI;

    /// The place (x, y, z counts) of `slot` in a lattice block of `size`, x fastest.
    fn lattice_place(slot: usize, size: [usize; 3]) -> [usize; 3] {
        [
            slot % size[0],
            slot / size[0] % size[1],
            slot / (size[0] * size[1]),
        ]
    }

    /// A jittered block of `size` particles a spacing (1 / `ppm`) apart from `corner`,
    /// with random velocities and densities within 1% of rest.
    fn block(ppm: f64, size: [usize; 3], corner: DVec3, seed: u64) -> Particles {
        let mut random = fastrand::Rng::with_seed(seed);
        let n = size[0] * size[1] * size[2];
        let mut particles = Particles::zeroed(n);
        for slot in 0..n {
            let k = lattice_place(slot, size);
            for axis in 0..3 {
                let offset = (k[axis] as f64 + 0.5 + 0.3 * (random.f64() - 0.5)) / ppm;
                particles.p[axis][slot] = corner[axis] + offset;
                particles.hv[axis][slot] = 0.4 * (random.f64() - 0.5);
            }
            particles.rho[slot] = 1000.0 * (1.0 + 0.02 * (random.f64() - 0.5));
        }
        particles
    }

    /// The pair loop of `kernel` on `particles` (densities as given, velocities their
    /// hv), placed in cell order, on `structure` where the kernel runs on lists:
    /// accelerations and density rates by particle id.
    fn pass(
        kernel: Kernel,
        structure: PairStructure,
        model: &Wcsph,
        ppm: f64,
        particles: &Particles,
    ) -> (Vec<DVec3>, Vec<f64>) {
        let method = Method {
            model: Model::Wcsph,
            kernel,
        };
        let mut sim = Simulation::with_method(ppm, particles.clone(), method).unwrap();
        sim.set_pair_structure(structure);
        sim.run_stage(Stage::Reposition);
        let on_lanes = kernel.runs_on_lanes();
        let on_lists = structure.is_listed() && on_lanes;
        assert_eq!(
            sim.lists().map(|lists| lists.rows().is_some()),
            on_lists.then_some(structure == PairStructure::Rows),
            "{kernel:?} on {structure:?}"
        );
        let placed = sim.particles();
        let n = placed.len();
        // The densities as given (the simulation settled its own), in slot order.
        let mut rho: Vec<f64> = placed
            .id
            .iter()
            .map(|&id| particles.rho[id as usize])
            .collect();
        let mut pressure_terms: Vec<f64> =
            rho.iter().map(|&r| model.pressure(r) / (r * r)).collect();
        rho.resize(n + PADDING, 0.0);
        pressure_terms.resize(n + PADDING, 0.0);
        let mut a = placed.a.clone();
        for axis in &mut a {
            axis.fill(0.0);
        }
        let mut rates = vec![0.0; n + PADDING];
        let state = State {
            p: &placed.p,
            v: &placed.hv,
            rho: &rho,
            pressure_terms: &pressure_terms,
        };
        kernel.run(WeaklyCompressible {
            constants: &model.constants,
            tiles: sim.tiles(),
            lists: sim.lists(),
            state,
            id: &placed.id,
            rates: Rates {
                a: &mut a,
                rho: &mut rates,
            },
        });
        let (mut by_id_a, mut by_id_rate) = (vec![DVec3::ZERO; n], vec![0.0; n]);
        for (slot, (&id, &rate)) in placed.id.iter().zip(&rates).enumerate() {
            by_id_a[id as usize] = vector_at(&a, slot);
            by_id_rate[id as usize] = rate;
        }
        (by_id_a, by_id_rate)
    }

    /// The largest difference between two results, relative to the largest value.
    fn difference(a: &(Vec<DVec3>, Vec<f64>), b: &(Vec<DVec3>, Vec<f64>)) -> (f64, f64) {
        let largest_a = a.0.iter().map(|v| v.length()).fold(0.0, f64::max);
        let largest_rate = a.1.iter().map(|r| r.abs()).fold(0.0, f64::max);
        let da =
            a.0.iter()
                .zip(&b.0)
                .map(|(x, y)| (*x - *y).length())
                .fold(0.0, f64::max);
        let dr =
            a.1.iter()
                .zip(&b.1)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
        (da / largest_a, dr / largest_rate)
    }

    #[test]
    fn every_kernel_computes_the_same_terms_walls_included() {
        // A block in the box's low corner: images across one, two and three walls.
        let ppm = 300.0;
        let particles = block(ppm, [12, 11, 13], BOX_MIN, 7);
        // Free-slip walls, and no-slip ones with a laminar viscosity large enough to
        // weigh as much as the artificial one.
        let no_slip = Settings {
            walls: WallFriction::NoSlip,
            laminar_viscosity: 1e-3,
            ..Settings::default()
        };
        for settings in [Settings::default(), no_slip] {
            let model = Wcsph::with_settings(settings, ppm, 10.0);
            let scalar = pass(
                Kernel::Scalar,
                PairStructure::Tiles,
                &model,
                ppm,
                &particles,
            );
            assert!(scalar.0.iter().all(|a| a.is_finite() && *a != DVec3::ZERO));
            for (kernel, tolerance) in [
                (Kernel::Simd, 1e-12),
                (Kernel::Simd8, 1e-12),
                (Kernel::Reference, 1e-12),
                (Kernel::Mixed, 5e-6),
            ] {
                for structure in PairStructure::ALL {
                    let other = pass(kernel, structure, &model, ppm, &particles);
                    let (da, drate) = difference(&scalar, &other);
                    println!(
                        "{:?} {kernel:?} on {structure:?}: {da:.2e} {drate:.2e}",
                        settings.walls
                    );
                    assert!(
                        da < tolerance && drate < tolerance,
                        "{:?} {kernel:?} on {structure:?}: {da:e} {drate:e}",
                        settings.walls
                    );
                }
            }
        }
    }

    /// A lattice block of `size` particles from `corner` at `ppm`, at rest density, each
    /// moving at `velocity` of its position.
    fn flowing(
        ppm: f64,
        size: [usize; 3],
        corner: DVec3,
        velocity: impl Fn(DVec3) -> DVec3,
    ) -> Particles {
        let n = size[0] * size[1] * size[2];
        let mut particles = Particles::zeroed(n);
        for slot in 0..n {
            let k = lattice_place(slot, size);
            let p = corner + DVec3::from_array(k.map(|k| (k as f64 + 0.5) / ppm));
            let v = velocity(p);
            for axis in 0..3 {
                particles.p[axis][slot] = p[axis];
                particles.hv[axis][slot] = v[axis];
            }
            particles.rho[slot] = 1000.0;
        }
        particles
    }

    /// The laminar viscous accelerations of `particles` (at rest density: no pressure)
    /// with the walls `walls`, viscosity `nu` and no artificial viscosity, on the SIMD
    /// kernel over lists, of the particles `inside` takes: (position, velocity,
    /// acceleration) each.
    fn laminar(
        ppm: f64,
        particles: &Particles,
        walls: WallFriction,
        nu: f64,
        inside: impl Fn(DVec3) -> bool,
    ) -> Vec<(DVec3, DVec3, DVec3)> {
        let settings = Settings {
            walls,
            ..Settings::default()
        };
        laminar_with(ppm, particles, settings, Kernel::Simd, nu, inside)
    }

    /// [`laminar`]'s with the walls of `settings`, on `kernel`.
    fn laminar_with(
        ppm: f64,
        particles: &Particles,
        settings: Settings,
        kernel: Kernel,
        nu: f64,
        inside: impl Fn(DVec3) -> bool,
    ) -> Vec<(DVec3, DVec3, DVec3)> {
        let settings = Settings {
            artificial_viscosity: 0.0,
            laminar_viscosity: nu,
            ..settings
        };
        let model = Wcsph::with_settings(settings, ppm, 10.0);
        let (a, _) = pass(kernel, PairStructure::Lists, &model, ppm, particles);
        (0..particles.len())
            .filter(|&slot| inside(particles.position(slot)))
            .map(|slot| {
                (
                    particles.position(slot),
                    particles.half_velocity(slot),
                    a[slot],
                )
            })
            .collect()
    }

    #[test]
    fn a_couette_flow_over_a_no_slip_floor_is_steady() {
        // Water sheared over the floor, u_x = k y (y above the floor): a plane Couette
        // flow, whose viscous acceleration nu d2u/dy2 is zero at every height. No-slip
        // images (-v) continue the profile as it is; free-slip ones (v) fold it at the
        // wall, and the layers near it feel a drag of about nu k / (spacing).
        let (ppm, nu, k) = (200.0, 1e-3, 10.0);
        let corner = DVec3::new(-0.04, BOX_MIN.y, -0.04);
        let particles = flowing(ppm, [16, 10, 16], corner, |p| {
            DVec3::new(k * (p.y - BOX_MIN.y), 0.0, 0.0)
        });
        // Away from the block's sides and top by a support radius (2.6 spacings).
        let margin = 2.6 / ppm;
        let inside = |p: DVec3| {
            let (low, high) = (corner, corner + DVec3::new(16.0, 10.0, 16.0) / ppm);
            p.x - low.x > margin
                && high.x - p.x > margin
                && p.z - low.z > margin
                && high.z - p.z > margin
                && high.y - p.y > margin
        };
        // Along the flow (across it, the images below the floor push up: their
        // hydrostatic pressure, which this block at rest density does not balance).
        let scale = nu * k * ppm;
        let largest = |walls| {
            laminar(ppm, &particles, walls, nu, inside)
                .iter()
                .map(|(_, _, a)| a.x.abs())
                .fold(0.0, f64::max)
                / scale
        };
        let (no_slip, free_slip) = (
            largest(WallFriction::NoSlip),
            largest(WallFriction::FreeSlip),
        );
        println!("largest |a| over nu k / dx: no slip {no_slip:.2e}, free slip {free_slip:.2e}");
        assert!(no_slip < 0.01, "{no_slip}");
        assert!(free_slip > 0.3, "{free_slip}");
    }

    #[test]
    fn each_face_takes_its_own_friction() {
        // The Couette block of the test above, whose only near wall is the floor: the
        // floor chosen by face gives the terms of the whole box chosen so, on every kernel.
        let (ppm, nu, k) = (200.0, 1e-3, 10.0);
        let corner = DVec3::new(-0.04, BOX_MIN.y, -0.04);
        let particles = flowing(ppm, [16, 10, 16], corner, |p| {
            DVec3::new(k * (p.y - BOX_MIN.y), 0.0, 0.0)
        });
        let every = |walls| Settings {
            walls,
            ..Settings::default()
        };
        let floor_only = |walls, floor| {
            let mut faces = [None; 6];
            faces[2] = Some(floor);
            Settings {
                walls,
                faces,
                ..Settings::default()
            }
        };
        let (no, free) = (WallFriction::NoSlip, WallFriction::FreeSlip);
        for kernel in [
            Kernel::Scalar,
            Kernel::Simd,
            Kernel::NATIVE,
            Kernel::Reference,
        ] {
            let terms = |settings| laminar_with(ppm, &particles, settings, kernel, nu, |_| true);
            assert_eq!(terms(floor_only(free, no)), terms(every(no)), "{kernel:?}");
            assert_eq!(
                terms(floor_only(no, free)),
                terms(every(free)),
                "{kernel:?}"
            );
            // And the ceiling's choice, far away, changes nothing.
            let mut ceiling = every(no);
            ceiling.faces[3] = Some(free);
            assert_eq!(terms(ceiling), terms(every(no)), "{kernel:?}");
            assert_ne!(terms(every(free)), terms(every(no)));
        }
    }

    #[test]
    fn a_shear_wave_decays_at_nu_k_squared() {
        // u_x = U sin(k y) away from every wall: the laminar term's acceleration is
        // nu d2u/dy2 = -nu k^2 u, so the wave decays at the rate nu k^2. Fitted over the
        // particles a support radius inside the block, within 10% (the lattice's
        // discretisation: 16 spacings a wave).
        let (ppm, nu) = (200.0, 1e-3);
        let size = [12, 24, 12];
        let corner = DVec3::new(-0.03, -0.06, -0.03);
        let wave = 2.0 * PI / (16.0 / ppm);
        let particles = flowing(ppm, size, corner, |p| {
            DVec3::new(0.01 * (wave * (p.y - corner.y)).sin(), 0.0, 0.0)
        });
        let margin = 2.6 / ppm;
        let high = corner + DVec3::from_array(size.map(|s| s as f64)) / ppm;
        let inside =
            |p: DVec3| (p - corner).min_element() > margin && (high - p).min_element() > margin;
        let terms = laminar(ppm, &particles, WallFriction::FreeSlip, nu, inside);
        assert!(terms.len() > 500, "{}", terms.len());
        let (au, uu) = terms.iter().fold((0.0, 0.0), |(au, uu), (_, v, a)| {
            (au - a.x * v.x, uu + v.x * v.x)
        });
        let rate = au / uu;
        let expected = nu * wave * wave;
        println!("decay rate {rate:.4} 1/s, nu k^2 = {expected:.4} 1/s");
        assert!(
            (rate / expected - 1.0).abs() < 0.1,
            "{rate} against {expected}"
        );
        let across = terms
            .iter()
            .map(|(_, _, a)| a.y.abs().max(a.z.abs()))
            .fold(0.0, f64::max);
        assert!(
            across < 1e-6 * expected * 0.01,
            "a shear wave drives no other flow: {across}"
        );
    }

    /// The terms of a block near the free-slip walls of `axes` (images), against those of
    /// the same block with its mirror images across every subset of those walls made particles,
    /// moved by `shift` to where no wall is near: the largest differences.
    fn against_explicit_images(axes: u8, corner: DVec3, shift: DVec3) -> [(f64, f64); 2] {
        let ppm = 200.0;
        let particles = block(ppm, [6, 5, 7], corner, 3);
        let n = particles.len();
        let walls = NearWalls {
            axes,
            at: BOX_MIN.to_array(),
            no_slip: 0,
        };
        // Mirrored particles move as the images of free-slip walls.
        let free_slip = Settings {
            walls: WallFriction::FreeSlip,
            ..Settings::default()
        };
        let model = Wcsph::with_settings(free_slip, ppm, 10.0);
        let sets: Vec<u8> = std::iter::once(0).chain(walls.images()).collect();
        let mut explicit = Particles::zeroed(sets.len() * n);
        for (copy, &set) in sets.iter().enumerate() {
            for slot in 0..n {
                let p = particles.position(slot);
                let image = mirrored(p, set, &walls);
                let v = reflected(particles.half_velocity(slot), set);
                let target = copy * n + slot;
                for axis in 0..3 {
                    explicit.p[axis][target] = (image + shift)[axis];
                    explicit.hv[axis][target] = v[axis];
                }
                // An image's density carries its hydrostatic pressure difference.
                let rho = particles.rho[slot];
                let pressure = model.pressure(rho) + rho * GRAVITY.dot(image - p);
                explicit.rho[target] = 1000.0 * (1.0 + pressure / model.stiffness).powf(1.0 / 7.0);
            }
        }
        let moved = explicit.p[0..3].iter().enumerate().all(|(axis, values)| {
            values[..explicit.len()].iter().all(|&x| {
                x - BOX_MIN[axis] > model.constants.support
                    && BOX_MAX[axis] - x > model.constants.support
            })
        });
        assert!(moved, "the explicit images are near a wall");
        [Kernel::Scalar, Kernel::Simd].map(|kernel| {
            let with_images = pass(kernel, PairStructure::Lists, &model, ppm, &particles);
            let (a, rate) = pass(kernel, PairStructure::Lists, &model, ppm, &explicit);
            let block = (a[..n].to_vec(), rate[..n].to_vec());
            difference(&with_images, &block)
        })
    }

    #[test]
    fn the_walls_are_the_mirror_images_of_the_particles_near_them() {
        // An edge of two side walls (images across each and both): exactly the terms of
        // explicit images, up to rounding.
        let corner = DVec3::new(BOX_MIN.x, 0.0, BOX_MIN.z);
        let shift = DVec3::new(0.05, 0.0, 0.05);
        for (da, drate) in against_explicit_images(0b101, corner, shift) {
            assert!(da < 1e-12 && drate < 1e-12, "{da:e} {drate:e}");
        }
        // The floor and a side wall: an image's density continues water at rest by
        // Tait's law near rest (p - p_j over c0^2), the explicit images' by the law
        // itself, which differ in the second order: 2e-5 and 9e-5 here.
        let corner = DVec3::new(BOX_MIN.x, BOX_MIN.y, -0.01);
        let shift = DVec3::new(0.05, 0.07, 0.0);
        for (da, drate) in against_explicit_images(0b011, corner, shift) {
            assert!(da < 1e-4 && drate < 3e-4, "{da:e} {drate:e}");
        }
    }
}
