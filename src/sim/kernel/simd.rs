//! The vectorised pair loops, on any width of f64 lanes ([`Lanes`]: `f64x4` or `f64x8`):
//! for each particle of a tile, its partners a lane-width at a time. A lane counts only if
//! it holds a partner (tail mask) closer than h (cut-off mask); other lanes add exactly
//! +0. A particle visits all the tiles of its cell in one pass, its own sums in
//! registers, added once; the partners' sums are updated lane-wise in memory.
//!
//! Loads of the last, partial group read up to `LANES - 1` slots past the range: the
//! particle arrays carry [`PADDING`] extra elements so those reads stay in bounds, and the
//! masked lanes add +0 (exact for the densities, which start at +0, and the accelerations). Each loop checks the padding of every
//! array once, against the largest slot its tiles reach; the loads and stores inside
//! then skip the per-access bounds checks, which otherwise cost more instructions than
//! the arithmetic.

use super::{Accelerations, Candidates, Densities, OVERFLOW_GROUP};

/// The group bit that stands for every group from [`OVERFLOW_GROUP`] on.
const OVERFLOW_BIT: u64 = 1 << OVERFLOW_GROUP;
use crate::sim::isa::{self, Gathers, Record, Slots};
use crate::sim::neighbours::Tile;
use crate::sim::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::sim::particles::{AxisArrays, PADDING};
use std::ops::{Add, BitAnd, Div, Mul, Sub};
use wide::{f32x8, f64x4, f64x8};

/// The lanes the pair loops run on: how a group of `LANES` partners is loaded from the
/// f64 particle arrays, computed in the vector type `V`, and added back. [`F64x4`] and
/// [`F64x8`] compute in f64 throughout. [`MixedF32x8`] computes each pair's differences
/// in f64, narrows them to f32 and computes the pair terms in `f32x8` lanes; its sums
/// stay in f64.
pub(crate) trait Lanes {
    /// Partners per group.
    const LANES: usize;
    /// The vector the pair terms are computed in.
    type V: Copy
        + Add<Output = Self::V>
        + Sub<Output = Self::V>
        + Mul<Output = Self::V>
        + Div<Output = Self::V>
        + BitAnd<Output = Self::V>;
    /// A first particle's running sum, lane by lane.
    type Sum: Copy;
    /// A sum of zero.
    const ZERO_SUM: Self::Sum;
    /// Every lane `value`.
    fn splat(value: f64) -> Self::V;
    /// A mask of every lane.
    fn all() -> Self::V;
    /// A mask of the first `count` lanes (all for `count >= LANES`).
    fn first(count: usize) -> Self::V;
    /// The mask of lanes of `a` below `b`.
    fn lt(a: Self::V, b: Self::V) -> Self::V;
    /// Whether any lane of a mask is set.
    fn any(mask: Self::V) -> bool;
    /// The lane-wise maximum.
    fn max(a: Self::V, b: Self::V) -> Self::V;
    /// The lane-wise square root.
    fn sqrt(a: Self::V) -> Self::V;
    /// The lanes of `values` at `at`.
    ///
    /// # Safety
    /// Every place `at` names for the lanes is within `values`.
    unsafe fn load(values: &[f64], at: impl Site) -> Self::V;
    /// `center - ` the lanes of `values` at `at`, subtracted in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn offsets(values: &[f64], at: impl Site, center: f64) -> Self::V;
    /// The lanes of `values` at `at` `- center`, subtracted in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn differences(values: &[f64], at: impl Site, center: f64) -> Self::V;
    /// `(rho + ` the lanes of `values` at `at` `) - 2 * FLUID_DENSITY`, computed in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn excess_density(rho: f64, values: &[f64], at: impl Site) -> Self::V;
    /// The lanes of `values` at `at` `+= terms`, in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn add_to(values: &mut [f64], at: impl Site, terms: Self::V);
    /// The lanes of `values` at `at` `-= terms`, in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn subtract_from(values: &mut [f64], at: impl Site, terms: Self::V);
    /// The f64 vector of as many lanes, in which fetched values are combined before the
    /// pair terms (the lanes' own for the f64 kernels).
    type F64: Copy + Add<Output = Self::F64> + Sub<Output = Self::F64>;
    /// Every f64 lane `value`.
    fn splat_f64(value: f64) -> Self::F64;
    /// f64 lanes as the lanes the pair terms are computed in (narrowed by the mixed
    /// kernel).
    fn narrowed(values: Self::F64) -> Self::V;
    /// The lanes of `values` at `at`, in f64.
    ///
    /// # Safety
    /// As for [`Self::load`].
    unsafe fn load_f64(values: &[f64], at: impl Site) -> Self::F64;
    /// The fields of the records at the first `LANES` slots of `at`, gathered on `isa`.
    fn records<G: Gathers>(isa: G, records: &[Record], at: &Slots) -> [Self::F64; 4];
    /// Adds `terms` to field `field` of the records at the first `LANES` slots of `at`,
    /// one slot after the other, in f64.
    fn add_to_field(records: &mut [Record], at: &Slots, field: usize, terms: Self::V);
    /// Adds `terms` to `sum`.
    fn accumulate(sum: &mut Self::Sum, terms: Self::V);
    /// The total of a sum's lanes.
    fn total(sum: Self::Sum) -> f64;
    /// A sum's lanes, each on its own (the first `LANES` of 8).
    fn lanes(sum: Self::Sum) -> [f64; 8];
}

/// Where a group's lanes live in the arrays: each lane's place (a `usize`, the lanes from
/// it; [`Slots`], a neighbour list's slots).
pub(crate) trait Site: Copy {
    /// Whether no two lanes share a place, so that a group is read and written back
    /// whole (else lane after lane, each adding to what the one before wrote).
    const DISTINCT: bool;
    /// The place of lane `lane`.
    fn place(&self, lane: usize) -> usize;
}

impl Site for usize {
    const DISTINCT: bool = true;
    #[inline(always)]
    fn place(&self, lane: usize) -> usize {
        self + lane
    }
}

impl Site for Slots {
    const DISTINCT: bool = false;
    #[inline(always)]
    fn place(&self, lane: usize) -> usize {
        self.at()[lane] as usize
    }
}

/// The `N` lanes of `values` at `at`.
///
/// # Safety
/// Every place `at` names for the `N` lanes is within `values`.
#[inline(always)]
unsafe fn read<const N: usize>(values: &[f64], at: impl Site) -> [f64; N] {
    std::array::from_fn(|lane| {
        let place = at.place(lane);
        debug_assert!(place < values.len());
        // SAFETY: guaranteed by the caller.
        unsafe { *values.get_unchecked(place) }
    })
}

/// Sets the `N` lanes of `values` at `at` to `lanes`.
///
/// # Safety
/// As for [`read`].
#[inline(always)]
unsafe fn write<const N: usize>(values: &mut [f64], at: impl Site, lanes: [f64; N]) {
    for (lane, value) in lanes.into_iter().enumerate() {
        let place = at.place(lane);
        debug_assert!(place < values.len());
        // SAFETY: guaranteed by the caller.
        unsafe { *values.get_unchecked_mut(place) = value };
    }
}

/// Adds `sign` times `terms` to the `N` lanes of `values` at `at`, lane after lane (each
/// lane adding to what the ones before wrote, for sites whose lanes may share a place).
///
/// # Safety
/// As for [`read`].
#[inline(always)]
unsafe fn add_lane_by_lane<const N: usize>(
    values: &mut [f64],
    at: impl Site,
    terms: [f64; N],
    sign: f64,
) {
    for (lane, term) in terms.into_iter().enumerate() {
        let place = at.place(lane);
        debug_assert!(place < values.len());
        // SAFETY: guaranteed by the caller.
        unsafe { *values.get_unchecked_mut(place) += sign * term };
    }
}

/// Whether the lanes of `at` have distinct places.
#[inline(always)]
fn distinct<S: Site>(_: &S) -> bool {
    S::DISTINCT
}

/// The f64 lanes of `wide::f64x4`: the design card's kernel, portable.
pub(super) struct F64x4;
/// The f64 lanes of `wide::f64x8`: one AVX-512 register, two AVX2 ones.
pub(super) struct F64x8;

macro_rules! f64_lanes {
    ($name:ident, $type:ty, $lanes:literal, $records:expr) => {
        impl Lanes for $name {
            const LANES: usize = $lanes;
            type V = $type;
            type Sum = $type;
            const ZERO_SUM: $type = <$type>::ZERO;
            type F64 = $type;

            #[inline(always)]
            fn splat_f64(value: f64) -> $type {
                <$type>::splat(value)
            }

            #[inline(always)]
            fn narrowed(values: $type) -> $type {
                values
            }

            #[inline(always)]
            fn add_to_field(records: &mut [Record], at: &Slots, field: usize, terms: $type) {
                let slots = at.at();
                for (k, term) in terms.to_array().into_iter().enumerate() {
                    records[slots[k] as usize][field] += term;
                }
            }

            #[inline(always)]
            unsafe fn load_f64(values: &[f64], at: impl Site) -> $type {
                // SAFETY: guaranteed by the caller.
                unsafe { Self::load(values, at) }
            }

            #[inline(always)]
            fn records<G: Gathers>(isa: G, records: &[Record], at: &Slots) -> [$type; 4] {
                let [a, b, c, d] = $records(isa, records, at);
                [a, b, c, d].map(<$type>::from)
            }

            #[inline(always)]
            fn splat(value: f64) -> $type {
                <$type>::splat(value)
            }

            #[inline(always)]
            fn all() -> $type {
                <$type>::new([f64::from_bits(u64::MAX); $lanes])
            }

            #[inline(always)]
            fn first(count: usize) -> $type {
                let lanes: [f64; $lanes] = std::array::from_fn(|k| k as f64);
                <$type>::new(lanes).simd_lt(<$type>::splat(count as f64))
            }

            #[inline(always)]
            fn lt(a: $type, b: $type) -> $type {
                a.simd_lt(b)
            }

            #[inline(always)]
            fn any(mask: $type) -> bool {
                mask.any()
            }

            #[inline(always)]
            fn max(a: $type, b: $type) -> $type {
                a.max(b)
            }

            #[inline(always)]
            fn sqrt(a: $type) -> $type {
                a.sqrt()
            }

            #[inline(always)]
            unsafe fn load(values: &[f64], at: impl Site) -> $type {
                // SAFETY: guaranteed by the caller.
                <$type>::from(unsafe { read::<$lanes>(values, at) })
            }

            #[inline(always)]
            unsafe fn offsets(values: &[f64], at: impl Site, center: f64) -> $type {
                // SAFETY: guaranteed by the caller.
                unsafe { <$type>::splat(center) - Self::load(values, at) }
            }

            #[inline(always)]
            unsafe fn differences(values: &[f64], at: impl Site, center: f64) -> $type {
                // SAFETY: guaranteed by the caller.
                unsafe { Self::load(values, at) - <$type>::splat(center) }
            }

            #[inline(always)]
            unsafe fn excess_density(rho: f64, values: &[f64], at: impl Site) -> $type {
                let twice_rest_density = <$type>::splat(2.0 * FLUID_DENSITY);
                // SAFETY: guaranteed by the caller.
                <$type>::splat(rho) + unsafe { Self::load(values, at) } - twice_rest_density
            }

            #[inline(always)]
            unsafe fn add_to(values: &mut [f64], at: impl Site, terms: $type) {
                // SAFETY (both): guaranteed by the caller.
                if distinct(&at) {
                    unsafe { write(values, at, (Self::load(values, at) + terms).to_array()) }
                } else {
                    unsafe { add_lane_by_lane(values, at, terms.to_array(), 1.0) }
                }
            }

            #[inline(always)]
            unsafe fn subtract_from(values: &mut [f64], at: impl Site, terms: $type) {
                // SAFETY (both): guaranteed by the caller.
                if distinct(&at) {
                    unsafe { write(values, at, (Self::load(values, at) - terms).to_array()) }
                } else {
                    unsafe { add_lane_by_lane(values, at, terms.to_array(), -1.0) }
                }
            }

            #[inline(always)]
            fn accumulate(sum: &mut $type, terms: $type) {
                *sum += terms;
            }

            #[inline(always)]
            fn total(sum: $type) -> f64 {
                sum.reduce_add()
            }

            #[inline(always)]
            fn lanes(sum: $type) -> [f64; 8] {
                let lanes = sum.to_array();
                std::array::from_fn(|k| lanes[k % $lanes])
            }
        }
    };
}

f64_lanes!(F64x4, f64x4, 4, |isa: G, r, at| isa.records4(r, at));
f64_lanes!(F64x8, f64x8, 8, |_: G, r, at| isa::fetch_records::<8>(
    r, at
));

/// Mixed precision: differences in f64, narrowed to f32; pair terms in `wide::f32x8`;
/// sums in f64. A workbench method, never `fluid`'s.
pub(super) struct MixedF32x8;

/// Eight f64 values narrowed to f32 lanes.
#[inline(always)]
fn narrow(values: [f64; 8]) -> f32x8 {
    f32x8::from(values.map(|v| v as f32))
}

/// Eight f32 lanes widened to f64.
#[inline(always)]
fn widen(lanes: f32x8) -> [f64; 8] {
    lanes.to_array().map(f64::from)
}

impl Lanes for MixedF32x8 {
    const LANES: usize = 8;
    type V = f32x8;
    type Sum = [f64x4; 2];
    const ZERO_SUM: [f64x4; 2] = [f64x4::ZERO; 2];
    type F64 = f64x8;

    #[inline(always)]
    fn splat_f64(value: f64) -> f64x8 {
        f64x8::splat(value)
    }

    #[inline(always)]
    fn narrowed(values: f64x8) -> f32x8 {
        narrow(values.to_array())
    }

    #[inline(always)]
    fn add_to_field(records: &mut [Record], at: &Slots, field: usize, terms: f32x8) {
        let slots = at.at();
        for (k, term) in widen(terms).into_iter().enumerate() {
            records[slots[k] as usize][field] += term;
        }
    }

    #[inline(always)]
    unsafe fn load_f64(values: &[f64], at: impl Site) -> f64x8 {
        // SAFETY: guaranteed by the caller.
        f64x8::from(unsafe { read::<8>(values, at) })
    }

    #[inline(always)]
    fn records<G: Gathers>(_: G, records: &[Record], at: &Slots) -> [f64x8; 4] {
        let [a, b, c, d] = isa::fetch_records::<8>(records, at);
        [a, b, c, d].map(f64x8::from)
    }

    #[inline(always)]
    fn splat(value: f64) -> f32x8 {
        f32x8::splat(value as f32)
    }

    #[inline(always)]
    fn all() -> f32x8 {
        f32x8::new([f32::from_bits(u32::MAX); 8])
    }

    #[inline(always)]
    fn first(count: usize) -> f32x8 {
        let lanes: [f32; 8] = std::array::from_fn(|k| k as f32);
        f32x8::new(lanes).simd_lt(f32x8::splat(count.min(8) as f32))
    }

    #[inline(always)]
    fn lt(a: f32x8, b: f32x8) -> f32x8 {
        a.simd_lt(b)
    }

    #[inline(always)]
    fn any(mask: f32x8) -> bool {
        mask.any()
    }

    #[inline(always)]
    fn max(a: f32x8, b: f32x8) -> f32x8 {
        a.max(b)
    }

    #[inline(always)]
    fn sqrt(a: f32x8) -> f32x8 {
        a.sqrt()
    }

    #[inline(always)]
    unsafe fn load(values: &[f64], at: impl Site) -> f32x8 {
        // SAFETY: guaranteed by the caller.
        narrow(unsafe { read::<8>(values, at) })
    }

    #[inline(always)]
    unsafe fn offsets(values: &[f64], at: impl Site, center: f64) -> f32x8 {
        // SAFETY: guaranteed by the caller.
        let values = unsafe { read::<8>(values, at) };
        narrow(values.map(|value| center - value))
    }

    #[inline(always)]
    unsafe fn differences(values: &[f64], at: impl Site, center: f64) -> f32x8 {
        // SAFETY: guaranteed by the caller.
        let values = unsafe { read::<8>(values, at) };
        narrow(values.map(|value| value - center))
    }

    #[inline(always)]
    unsafe fn excess_density(rho: f64, values: &[f64], at: impl Site) -> f32x8 {
        // SAFETY: guaranteed by the caller.
        let values = unsafe { read::<8>(values, at) };
        narrow(values.map(|value| rho + value - 2.0 * FLUID_DENSITY))
    }

    #[inline(always)]
    unsafe fn add_to(values: &mut [f64], at: impl Site, terms: f32x8) {
        // SAFETY: guaranteed by the caller.
        unsafe { add_lane_by_lane(values, at, widen(terms), 1.0) }
    }

    #[inline(always)]
    unsafe fn subtract_from(values: &mut [f64], at: impl Site, terms: f32x8) {
        // SAFETY: guaranteed by the caller.
        unsafe { add_lane_by_lane(values, at, widen(terms), -1.0) }
    }

    #[inline(always)]
    fn accumulate(sum: &mut [f64x4; 2], terms: f32x8) {
        let terms = widen(terms);
        for (half, sum) in sum.iter_mut().enumerate() {
            *sum += f64x4::from(<[f64; 4]>::try_from(&terms[4 * half..4 * half + 4]).unwrap());
        }
    }

    #[inline(always)]
    fn total(sum: [f64x4; 2]) -> f64 {
        (sum[0] + sum[1]).reduce_add()
    }

    #[inline(always)]
    fn lanes(sum: [f64x4; 2]) -> [f64; 8] {
        let [low, high] = sum.map(f64x4::to_array);
        std::array::from_fn(|k| if k < 4 { low[k] } else { high[k - 4] })
    }
}

/// The group bits covering `partners` partners: one per `L::LANES`, the last bit standing
/// for every group from [`OVERFLOW_GROUP`] on.
fn all_groups<L: Lanes>(partners: usize) -> u64 {
    let groups = partners.div_ceil(L::LANES);
    if groups > OVERFLOW_GROUP {
        u64::MAX
    } else {
        (1 << groups) - 1
    }
}

/// Panics unless every array leaves room for loads of `lanes` lanes at the last slot
/// `n - 1`.
pub(super) fn assert_padded(n: usize, lanes: usize, arrays: &[&[f64]]) {
    assert!(
        PADDING + 1 >= lanes,
        "{lanes} lanes need more than {PADDING} padding"
    );
    assert!(
        arrays.iter().all(|a| a.len() >= n + PADDING),
        "particle arrays must be padded by {PADDING} elements for the SIMD kernels"
    );
}

pub(super) fn slots_used(tiles: &[Tile]) -> usize {
    tiles
        .iter()
        .map(|t| t.second_end as usize)
        .max()
        .unwrap_or(0)
}

/// Stage 3 on `L` lanes.
pub(super) fn increment_densities<L: Lanes>(pass: Densities) {
    let Densities {
        params,
        tiles,
        p,
        rho,
        close,
        ..
    } = pass;
    let [x, y, z] = p;
    assert_padded(slots_used(tiles), L::LANES, &[x, y, z, rho]);
    let h2 = L::splat(params.h2);
    for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
        let groups_before = close.groups.len();
        let mut cell_groups = 0u64;
        for i in cell_tiles[0].firsts() {
            let first = [x[i], y[i], z[i]];
            let mut sum = L::ZERO_SUM;
            for tile in cell_tiles {
                let (mut groups, mut group_bit) = (0u64, 1u64);
                let partners = tile.partners(i);
                let mut j = partners.start;
                let mut visit = |j: usize, lanes: L::V| {
                    // SAFETY: j < partners.end <= slots_used(tiles), and assert_padded
                    // checked that every array holds slots_used(tiles) + PADDING elements,
                    // PADDING >= LANES - 1, so j + LANES <= len.
                    let close =
                        unsafe { density_group::<L>(p, rho, first, h2, j, lanes, &mut sum) };
                    groups |= group_bit & 0u64.wrapping_sub(u64::from(close));
                    group_bit = (group_bit << 1) | (group_bit & OVERFLOW_BIT);
                };
                // Full groups, then the partial last one.
                while j + L::LANES <= partners.end {
                    visit(j, L::all());
                    j += L::LANES;
                }
                if j < partners.end {
                    visit(j, L::first(partners.end - j));
                }
                close.groups.push(groups);
                cell_groups |= groups;
            }
            rho[i] += L::total(sum);
        }
        if cell_groups == 0 {
            close.groups.truncate(groups_before);
        } else {
            close.tiles.extend_from_slice(cell_tiles);
        }
    }
}

/// Adds the density terms (h^2 - r^2)^3 of the particle at `first` with partners
/// j..j+LANES (lanes of `lanes` closer than h; exactly 0 in the others) to `sum` and to
/// the partners' `rho`, and returns whether any lane is closer than h.
///
/// # Safety
/// `j + LANES` is within `rho` and every array of `p`.
#[inline(always)]
unsafe fn density_group<L: Lanes>(
    p: &AxisArrays,
    rho: &mut [f64],
    first: [f64; 3],
    h2: L::V,
    j: usize,
    lanes: L::V,
    sum: &mut L::Sum,
) -> bool {
    // SAFETY: guaranteed by the caller.
    let offset = |axis: usize| unsafe { L::offsets(&p[axis], j, first[axis]) };
    let (dx, dy, dz) = (offset(0), offset(1), offset(2));
    let r2 = dx * dx + dy * dy + dz * dz;
    let close = L::lt(r2, h2) & lanes;
    let q = h2 - r2;
    let t = (q * q * q) & close;
    L::accumulate(sum, t);
    // SAFETY: guaranteed by the caller.
    unsafe { L::add_to(rho, j, t) };
    L::any(close)
}

/// The particle whose partners a group loop visits.
pub(super) struct First {
    pub(super) p: [f64; 3],
    pub(super) v: [f64; 3],
    pub(super) rho: f64,
    pub(super) inverse_rho: f64,
}

/// The arrays and constants of the acceleration transfer.
pub(super) struct Transfer<'a, L: Lanes, const FLUIDANIMATE: bool> {
    p: [&'a [f64]; 3],
    v: [&'a [f64]; 3],
    rho: &'a [f64],
    inverse_rho: &'a [f64],
    h: L::V,
    h2: L::V,
    min_distance_squared: L::V,
    pressure_factor: L::V,
    viscosity_factor: L::V,
}

impl<'a, L: Lanes, const FLUIDANIMATE: bool> Transfer<'a, L, FLUIDANIMATE> {
    /// The transfer of `params` over these arrays (`inverse_rho` the reciprocals of
    /// `rho`).
    pub(super) fn new(
        params: &Params,
        p: [&'a [f64]; 3],
        v: [&'a [f64]; 3],
        rho: &'a [f64],
        inverse_rho: &'a [f64],
    ) -> Self {
        Transfer {
            p,
            v,
            rho,
            inverse_rho,
            h: L::splat(params.h),
            h2: L::splat(params.h2),
            min_distance_squared: L::splat(MIN_DISTANCE_SQUARED),
            pressure_factor: L::splat(params.pressure_factor),
            viscosity_factor: L::splat(params.viscosity_factor),
        }
    }
}

impl<L: Lanes, const FLUIDANIMATE: bool> Transfer<'_, L, FLUIDANIMATE> {
    /// The acceleration terms of `first` with the partners at `at` (in the lanes of
    /// `lanes`; zero in lanes that are not a pair closer than h), or `None` if no lane is.
    ///
    /// # Safety
    /// Every place `at` names is within every array.
    #[inline(always)]
    pub(super) unsafe fn group(&self, first: &First, at: usize, lanes: L::V) -> Option<[L::V; 3]> {
        // SAFETY: guaranteed by the caller.
        let offset = |values: &[f64], center| unsafe { L::offsets(values, at, center) };
        let d = [
            offset(self.p[0], first.p[0]),
            offset(self.p[1], first.p[1]),
            offset(self.p[2], first.p[2]),
        ];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let close = L::lt(r2, self.h2) & lanes;
        if !L::any(close) {
            return None;
        }
        // SAFETY: guaranteed by the caller.
        let (inverse_rho_j, excess) = unsafe {
            let excess = L::excess_density(first.rho, self.rho, at);
            (L::load(self.inverse_rho, at), excess)
        };
        // The divider, not the lanes, bounds this loop: the densities' reciprocals are
        // taken once per particle, not per pair and axis (a square root and a division
        // per group, not three divisions more).
        let per_density_product = L::splat(first.inverse_rho) * inverse_rho_j;
        // SAFETY: guaranteed by the caller.
        let difference = |axis: usize| unsafe { L::differences(self.v[axis], at, first.v[axis]) };
        let dv = [difference(0), difference(1), difference(2)];
        Some(self.terms(d, r2, close, excess, per_density_product, dv))
    }

    /// The acceleration terms of pairs at offsets `d` (first particle less partner),
    /// `r2` apart, in the lanes of `close` (zero in the others), with `excess` the sum of
    /// their densities less twice the rest density, `per_density_product` the product of
    /// their densities' reciprocals and `dv` the partners' velocities less the first's.
    #[inline(always)]
    pub(super) fn terms(
        &self,
        d: [L::V; 3],
        r2: L::V,
        close: L::V,
        excess: L::V,
        per_density_product: L::V,
        dv: [L::V; 3],
    ) -> [L::V; 3] {
        let dist = L::sqrt(L::max(r2, self.min_distance_squared));
        let q = self.h - dist;
        let pressure = self.pressure_factor * q * q / dist * excess;
        self.terms_of(q, pressure, d, close, per_density_product, dv)
    }

    /// As [`Self::terms`], given 1 / dist (`over_dist`: of the larger of r2 and the least
    /// distance squared) instead of a square root and a division: what the floor
    /// measures of a divider-free 1/r ([`crate::sim::isa`]'s `reciprocal_sqrt8`), which
    /// the reference outputs' byte-exact kernels do not use.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn terms_over(
        &self,
        d: [L::V; 3],
        r2: L::V,
        over_dist: L::V,
        close: L::V,
        excess: L::V,
        per_density_product: L::V,
        dv: [L::V; 3],
    ) -> [L::V; 3] {
        let dist = L::max(r2, self.min_distance_squared) * over_dist;
        let q = self.h - dist;
        let pressure = self.pressure_factor * q * q * over_dist * excess;
        self.terms_of(q, pressure, d, close, per_density_product, dv)
    }

    /// The terms of a pair at `h - dist` = `q` with its pressure factor `pressure`.
    #[inline(always)]
    fn terms_of(
        &self,
        q: L::V,
        pressure: L::V,
        d: [L::V; 3],
        close: L::V,
        per_density_product: L::V,
        dv: [L::V; 3],
    ) -> [L::V; 3] {
        let term = |axis: usize| {
            let mut viscosity = dv[axis] * self.viscosity_factor;
            if FLUIDANIMATE {
                viscosity = viscosity * q;
            }
            ((d[axis] * pressure + viscosity) * per_density_product) & close
        };
        // Three calls, not an array map: the map's closure is not always inlined.
        [term(0), term(1), term(2)]
    }

    /// The cut-off squared, in every lane.
    pub(super) fn h2(&self) -> L::V {
        self.h2
    }
}

impl<L: Lanes, const FLUIDANIMATE: bool> Transfer<'_, L, FLUIDANIMATE> {
    /// Adds the acceleration terms of `first` with partners j..j+LANES (lanes before
    /// `end`) to `sum` and subtracts them from the partners' `a`.
    ///
    /// # Safety
    /// `j + LANES` is within every array.
    #[inline(always)]
    unsafe fn visit(
        &self,
        first: &First,
        j: usize,
        end: usize,
        a: &mut [&mut Vec<f64>; 3],
        sum: &mut [L::Sum; 3],
    ) {
        let lanes = if j + L::LANES <= end {
            L::all()
        } else {
            L::first(end - j)
        };
        // SAFETY: guaranteed by the caller.
        if let Some(da) = unsafe { self.group(first, j, lanes) } {
            for axis in 0..3 {
                L::accumulate(&mut sum[axis], da[axis]);
                // SAFETY: guaranteed by the caller.
                unsafe { L::subtract_from(a[axis], j, da[axis]) };
            }
        }
    }
}

/// Stage 5 on `L` lanes. `FLUIDANIMATE` multiplies the viscosity term by (h - dist).
/// With `close`, only the tiles and groups of partners where the density loop found a
/// pair closer than h are visited.
pub(super) fn transfer_accelerations<L: Lanes, const FLUIDANIMATE: bool>(
    pass: Accelerations<FLUIDANIMATE>,
) {
    let Accelerations {
        params,
        candidates,
        p,
        v,
        rho,
        a,
        packed,
        ..
    } = pass;
    let tiles = candidates.tiles();
    let ([x, y, z], [vx, vy, vz]) = (p, v);
    let [ax, ay, az] = a;
    // Only as far as the tiles reach: on scattered scenes the lone particles, most of
    // them, come after.
    let used = slots_used(tiles);
    let inverse_rho = &mut packed.inverse_rho;
    inverse_rho.clear();
    let reached = rho.get(..used + PADDING).unwrap_or(rho);
    inverse_rho.extend(reached.iter().map(|rho| 1.0 / rho));
    let inverse_rho = &inverse_rho[..];
    let arrays = [&x[..], y, z, vx, vy, vz, rho, inverse_rho, ax, ay, az];
    assert_padded(used, L::LANES, &arrays);
    let transfer =
        Transfer::<L, FLUIDANIMATE>::new(params, [x, y, z], [vx, vy, vz], rho, inverse_rho);
    let mut recorded_groups = match candidates {
        Candidates::Close(close) if !close.groups.is_empty() => Some(close.groups.iter()),
        _ => None,
    };
    let mut a = [ax, ay, az];
    for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
        for i in cell_tiles[0].firsts() {
            let first = First {
                p: [x[i], y[i], z[i]],
                v: [vx[i], vy[i], vz[i]],
                rho: rho[i],
                inverse_rho: inverse_rho[i],
            };
            let mut sum = [L::ZERO_SUM; 3];
            for tile in cell_tiles {
                let partners = tile.partners(i);
                let mut groups = match recorded_groups.as_mut() {
                    Some(groups) => *groups.next().expect("a recorded group set per tile"),
                    None => all_groups::<L>(partners.len()),
                };
                let mut visit = |j: usize| {
                    // SAFETY: j < partners.end <= slots_used(tiles), and assert_padded checked
                    // that every array holds slots_used(tiles) + PADDING elements.
                    unsafe { transfer.visit(&first, j, partners.end, &mut a, &mut sum) };
                };
                while groups != 0 {
                    let group = groups.trailing_zeros() as usize;
                    groups &= groups - 1;
                    let from = partners.start + group * L::LANES;
                    if group < OVERFLOW_GROUP {
                        visit(from);
                    } else {
                        (from..partners.end).step_by(L::LANES).for_each(&mut visit);
                    }
                }
            }
            for axis in 0..3 {
                a[axis][i] += L::total(sum[axis]);
            }
        }
    }
}
