//! The vectorised pair loops: for each particle of a tile, its partners four at a time in
//! `f64x4` lanes. A lane counts only if it holds a partner (tail mask) closer than h
//! (cut-off mask); other lanes add exactly +0. A particle visits all the tiles of its cell
//! in one pass, its own sums in registers, added once; the partners' sums are updated
//! lane-wise in memory.
//!
//! Loads of the last, partial group of four read up to three slots past the range: the
//! particle arrays carry [`PADDING`] extra elements so those reads stay in bounds, and the
//! masked lanes write back exactly what they read. Each loop checks the padding of every
//! array once, against the largest slot its tiles reach; the loads and stores inside
//! then skip the per-access bounds checks, which otherwise cost more instructions than
//! the arithmetic.

use super::{Candidates, ClosePairs, OVERFLOW_GROUP};

/// The group bit that stands for every group from [`OVERFLOW_GROUP`] on.
const OVERFLOW_BIT: u64 = 1 << OVERFLOW_GROUP;
use crate::sim::neighbours::Tile;
use crate::sim::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::sim::particles::{AxisArrays, PADDING};
use wide::f64x4;

const LANES: usize = 4;

/// `values[at..at + 4]`.
///
/// # Safety
/// `at + 4 <= values.len()`.
#[inline(always)]
unsafe fn load(values: &[f64], at: usize) -> f64x4 {
    debug_assert!(at + LANES <= values.len());
    // SAFETY: the caller guarantees the four elements are in bounds; any alignment works.
    f64x4::from(unsafe {
        values
            .as_ptr()
            .add(at)
            .cast::<[f64; LANES]>()
            .read_unaligned()
    })
}

/// `values[at..at + 4] = lanes`.
///
/// # Safety
/// `at + 4 <= values.len()`.
#[inline(always)]
unsafe fn store(values: &mut [f64], at: usize, lanes: f64x4) {
    debug_assert!(at + LANES <= values.len());
    // SAFETY: as for `load`.
    unsafe {
        values
            .as_mut_ptr()
            .add(at)
            .cast::<[f64; LANES]>()
            .write_unaligned(lanes.to_array())
    }
}

/// The group bits covering `partners` partners: one per four, the last bit standing for
/// every group from [`OVERFLOW_GROUP`] on.
fn all_groups(partners: usize) -> u64 {
    let groups = partners.div_ceil(LANES);
    if groups > OVERFLOW_GROUP {
        u64::MAX
    } else {
        (1 << groups) - 1
    }
}

/// A mask of all four lanes.
const ALL_LANES: f64x4 = f64x4::new([f64::from_bits(u64::MAX); LANES]);

/// A mask of the first `count` lanes (all four for `count >= 4`).
#[inline(always)]
fn first_lanes(count: usize) -> f64x4 {
    f64x4::new([0.0, 1.0, 2.0, 3.0]).simd_lt(f64x4::splat(count as f64))
}

/// Panics unless every array leaves room for four-lane loads at the last slot `n - 1`.
fn assert_padded(n: usize, arrays: &[&[f64]]) {
    assert!(
        arrays.iter().all(|a| a.len() >= n + PADDING),
        "particle arrays must be padded by {PADDING} elements for the SIMD kernel"
    );
}

fn slots_used(tiles: &[Tile]) -> usize {
    tiles
        .iter()
        .map(|t| t.second_end as usize)
        .max()
        .unwrap_or(0)
}

pub(super) fn increment_densities(
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    rho: &mut [f64],
    close: &mut ClosePairs,
) {
    let [x, y, z] = p;
    assert_padded(slots_used(tiles), &[x, y, z, rho]);
    let h2 = f64x4::splat(params.h2);
    for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
        let groups_before = close.groups.len();
        let mut cell_groups = 0u64;
        for i in cell_tiles[0].firsts() {
            let (xi, yi, zi) = (f64x4::splat(x[i]), f64x4::splat(y[i]), f64x4::splat(z[i]));
            let mut sum = f64x4::ZERO;
            for tile in cell_tiles {
                let (mut groups, mut group_bit) = (0u64, 1u64);
                let partners = tile.partners(i);
                // SAFETY: j < partners.end <= slots_used(tiles), and assert_padded checked
                // that every array holds slots_used(tiles) + PADDING elements, so j + 4 <= len.
                let mut group = |j: usize, lanes: f64x4| {
                    // SAFETY: see above.
                    let load = |values: &[f64]| unsafe { load(values, j) };
                    let (dx, dy, dz) = (xi - load(x), yi - load(y), zi - load(z));
                    let r2 = dx * dx + dy * dy + dz * dz;
                    let close = r2.simd_lt(h2) & lanes;
                    let q = h2 - r2;
                    let t = (q * q * q) & close;
                    sum += t;
                    let rho_j = load(rho) + t;
                    // SAFETY: see above.
                    unsafe { store(rho, j, rho_j) };
                    groups |= group_bit & 0u64.wrapping_sub(u64::from(close.to_bitmask() != 0));
                    group_bit = (group_bit << 1) | (group_bit & OVERFLOW_BIT);
                };
                let mut j = partners.start;
                while j + LANES <= partners.end {
                    group(j, ALL_LANES);
                    j += LANES;
                }
                if j < partners.end {
                    group(j, first_lanes(partners.end - j));
                }
                close.groups.push(groups);
                cell_groups |= groups;
            }
            rho[i] += sum.reduce_add();
        }
        if cell_groups == 0 {
            close.groups.truncate(groups_before);
        } else {
            close.tiles.extend_from_slice(cell_tiles);
        }
    }
}

/// The particle whose partners a group loop visits, and the constants of the model.
struct First {
    p: [f64x4; 3],
    v: [f64x4; 3],
    rho: f64x4,
}

/// The arrays and constants of the acceleration transfer.
struct Transfer<'a, const FLUIDANIMATE: bool> {
    p: [&'a [f64]; 3],
    v: [&'a [f64]; 3],
    rho: &'a [f64],
    h: f64x4,
    h2: f64x4,
    min_distance_squared: f64x4,
    pressure_factor: f64x4,
    viscosity_factor: f64x4,
    twice_rest_density: f64x4,
}

impl<const FLUIDANIMATE: bool> Transfer<'_, FLUIDANIMATE> {
    /// The acceleration terms of `first` with partners j..j+4 (lanes before `end`; zero
    /// in lanes that are not a pair closer than h), or `None` if no lane is.
    ///
    /// # Safety
    /// `j + 4` is within every array.
    #[inline(always)]
    unsafe fn group(&self, first: &First, j: usize, end: usize) -> Option<[f64x4; 3]> {
        let lanes = if j + LANES <= end {
            ALL_LANES
        } else {
            first_lanes(end - j)
        };
        // SAFETY: guaranteed by the caller.
        let load = |values: &[f64]| unsafe { load(values, j) };
        let d = [0, 1, 2].map(|axis| first.p[axis] - load(self.p[axis]));
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let close = r2.simd_lt(self.h2) & lanes;
        if !close.any() {
            return None;
        }
        let dist = r2.max(self.min_distance_squared).sqrt();
        let q = self.h - dist;
        let rho_j = load(self.rho);
        let pressure =
            self.pressure_factor * q * q / dist * (first.rho + rho_j - self.twice_rest_density);
        let density_product = first.rho * rho_j;
        Some([0, 1, 2].map(|axis| {
            let mut viscosity = (load(self.v[axis]) - first.v[axis]) * self.viscosity_factor;
            if FLUIDANIMATE {
                viscosity *= q;
            }
            ((d[axis] * pressure + viscosity) / density_product) & close
        }))
    }
}

/// `FLUIDANIMATE` multiplies the viscosity term by (h - dist). With `close`, only the
/// tiles and groups of four partners where the density loop found a pair closer than h
/// are visited.
pub(super) fn transfer_accelerations<const FLUIDANIMATE: bool>(
    params: &Params,
    candidates: Candidates,
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    a: &mut AxisArrays,
) {
    let tiles = candidates.tiles();
    let ([x, y, z], [vx, vy, vz]) = (p, v);
    let [ax, ay, az] = a;
    assert_padded(slots_used(tiles), &[x, y, z, vx, vy, vz, rho, ax, ay, az]);
    let transfer = Transfer::<FLUIDANIMATE> {
        p: [x, y, z],
        v: [vx, vy, vz],
        rho,
        h: f64x4::splat(params.h),
        h2: f64x4::splat(params.h2),
        min_distance_squared: f64x4::splat(MIN_DISTANCE_SQUARED),
        pressure_factor: f64x4::splat(params.pressure_factor),
        viscosity_factor: f64x4::splat(params.viscosity_factor),
        twice_rest_density: f64x4::splat(2.0 * FLUID_DENSITY),
    };
    let mut recorded_groups = match candidates {
        Candidates::Close(close) if !close.groups.is_empty() => Some(close.groups.iter()),
        _ => None,
    };
    let a = [ax, ay, az];
    for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
        for i in cell_tiles[0].firsts() {
            let first = First {
                p: [x[i], y[i], z[i]].map(f64x4::splat),
                v: [vx[i], vy[i], vz[i]].map(f64x4::splat),
                rho: f64x4::splat(rho[i]),
            };
            let mut sum = [f64x4::ZERO; 3];
            for tile in cell_tiles {
                let partners = tile.partners(i);
                let mut visit = |j: usize| {
                    // SAFETY: j < partners.end <= slots_used(tiles), and assert_padded checked
                    // that every array holds slots_used(tiles) + PADDING elements.
                    unsafe {
                        if let Some(da) = transfer.group(&first, j, partners.end) {
                            for axis in 0..3 {
                                sum[axis] += da[axis];
                                let old = load(a[axis], j);
                                store(a[axis], j, old - da[axis]);
                            }
                        }
                    }
                };
                let mut groups = match recorded_groups.as_mut() {
                    Some(groups) => *groups.next().expect("a recorded group set per tile"),
                    None => all_groups(partners.len()),
                };
                while groups != 0 {
                    let group = groups.trailing_zeros() as usize;
                    groups &= groups - 1;
                    let from = partners.start + group * LANES;
                    if group < OVERFLOW_GROUP {
                        visit(from);
                    } else {
                        (from..partners.end).step_by(LANES).for_each(&mut visit);
                    }
                }
            }
            for axis in 0..3 {
                a[axis][i] += sum[axis].reduce_add();
            }
        }
    }
}
