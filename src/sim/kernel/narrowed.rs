//! The mixed kernel's course-model passes on [`Clusters`]: a cluster of 4 against a
//! partner cluster of 4 as one register of 16 `f32` lanes (lane 4i + j: particle i of
//! the cluster, partner j), with what the pair terms read narrowed to f32 once per
//! placement rather than once per pair: positions relative to their cluster's first
//! particle (each pair then adds the f64 offset between the two clusters' origins,
//! narrowed once per cluster pair), velocities, densities less the rest density and the
//! densities' reciprocals, all by place. Each cluster pair's terms are summed in f32
//! within the register and added to f64 sums by place once per cluster pair; a
//! particle's own sums stay in f32 over its cluster's partners and are widened once.
//!
//! The density pass records, per cluster, the clusters holding a partner closer than h
//! for one of its particles ([`super::ClosePairs`], the clusters alone: the pairs are
//! evaluated whole); the acceleration pass of the same placement visits only those
//! cluster pairs, 16 lanes each.

use super::clustered::unpack_add;
use super::{Accelerations, Densities, Narrowed, Packed};
use crate::sim::clusters::{Clusters, CLUSTER, EMPTY};
use crate::sim::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::sim::particles::AxisArrays;
use wide::f32x16;

/// The lanes of a cluster against itself that hold a pair once: partner j after
/// particle i.
fn own_pairs() -> f32x16 {
    let lanes: [f32; 16] = std::array::from_fn(|lane| {
        if lane % CLUSTER > lane / CLUSTER {
            f32::from_bits(u32::MAX)
        } else {
            0.0
        }
    });
    f32x16::from(lanes)
}

/// The 4 values of a cluster (its particles' in `tiled`, which holds them in each run of
/// 4 lanes, as partners), each in its run of 4 lanes (as the particles of pair terms).
#[inline(always)]
fn particles(tiled: f32x16) -> f32x16 {
    let t = tiled.to_array();
    f32x16::from(std::array::from_fn::<f32, 16, _>(|lane| t[lane / CLUSTER]))
}

/// The sums over the particles (one per partner j: lanes j, 4 + j, 8 + j, 12 + j).
#[inline(always)]
fn partner_totals(terms: f32x16) -> [f32; CLUSTER] {
    let t = terms.to_array();
    std::array::from_fn(|j| (t[j] + t[CLUSTER + j]) + (t[2 * CLUSTER + j] + t[3 * CLUSTER + j]))
}

/// The sums over the partners (one per particle i: lanes 4i..4i + 4).
#[inline(always)]
fn particle_totals(terms: f32x16) -> [f32; CLUSTER] {
    let t = terms.to_array();
    std::array::from_fn(|i| (t[4 * i] + t[4 * i + 1]) + (t[4 * i + 2] + t[4 * i + 3]))
}

/// Adds `totals` (widened) to the 4 places of cluster `k` in `sums`.
#[inline(always)]
fn add_at(sums: &mut [f64], k: usize, totals: [f32; CLUSTER]) {
    for (sum, total) in sums[k * CLUSTER..(k + 1) * CLUSTER].iter_mut().zip(totals) {
        *sum += f64::from(total);
    }
}

/// A register holding `four` in each run of 4 lanes, as a partner cluster is met.
fn tiled(four: [f32; CLUSTER]) -> f32x16 {
    f32x16::from(std::array::from_fn::<f32, 16, _>(|lane| {
        four[lane % CLUSTER]
    }))
}

/// `narrow(value)` of each cluster's particles in `source` (by slot) into `narrowed`, a
/// register per cluster holding its 4 values in each run of 4 lanes (0 at places that
/// hold no particle).
fn narrow_by_cluster(
    places: &[u32],
    source: &[f64],
    narrow: impl Fn(f64) -> f32,
    narrowed: &mut Vec<f32x16>,
) {
    narrowed.clear();
    narrowed.extend(places.chunks_exact(CLUSTER).map(|cluster| {
        tiled(std::array::from_fn(|i| match cluster[i] {
            EMPTY => 0.0,
            slot => narrow(source[slot as usize]),
        }))
    }));
}

impl Narrowed {
    /// The positions of `clusters` relative to each cluster's first particle, narrowed
    /// (an empty place lies at infinity, beyond every cut-off).
    fn narrow_positions(&mut self, clusters: &Clusters) {
        let places = clusters.places();
        for (narrowed, p) in self.p.iter_mut().zip(clusters.positions()) {
            narrowed.clear();
            narrowed.extend(
                places
                    .chunks_exact(CLUSTER)
                    .zip(p.chunks_exact(CLUSTER))
                    .map(|(cluster, p)| {
                        tiled(std::array::from_fn(|i| match cluster[i] {
                            EMPTY => f32::INFINITY,
                            _ => (p[i] - p[0]) as f32,
                        }))
                    }),
            );
        }
    }

    /// The f64 offset between the origins of clusters `own` and `k`, narrowed, per axis.
    #[inline(always)]
    fn shift(p: &AxisArrays, own: usize, k: usize) -> [f32x16; 3] {
        let axis =
            |axis: usize| f32x16::splat((p[axis][own * CLUSTER] - p[axis][k * CLUSTER]) as f32);
        // Three calls, not an array map: the map's closure is not always inlined.
        [axis(0), axis(1), axis(2)]
    }
}

/// The offsets p_i - p_j of a cluster pair, from the particles' relative positions
/// (`own`, one per run of 4 lanes) and the partners' (`k`), and the clusters' shift.
#[inline(always)]
fn offsets(
    narrowed: &[Vec<f32x16>; 3],
    own: &[f32x16; 3],
    k: usize,
    shift: &[f32x16; 3],
) -> [f32x16; 3] {
    let axis = |axis: usize| own[axis] - narrowed[axis][k] + shift[axis];
    [axis(0), axis(1), axis(2)]
}

/// The density terms (h^2 - r^2)^3 of the cluster pair `[own, k]` (lanes of `mask`):
/// the particles' (`rows`) added to `own_sums`, the partners' to `sums` (f64, by place).
/// Returns a bit per lane closer than h.
#[inline(always)]
fn density_pair(
    (narrowed, p): (&[Vec<f32x16>; 3], &AxisArrays),
    rows: &[f32x16; 3],
    [own, k]: [usize; 2],
    mask: f32x16,
    h2: f32x16,
    own_sums: &mut f32x16,
    sums: &mut [f64],
) -> u32 {
    let d = offsets(narrowed, rows, k, &Narrowed::shift(p, own, k));
    let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let within = r2.simd_lt(h2) & mask;
    let q = h2 - r2;
    let t = (q * q * q) & within;
    *own_sums += t;
    add_at(sums, k, partner_totals(t));
    within.to_bitmask()
}

/// Stage 3 of the mixed kernel on `clusters`: records, per cluster, the clusters
/// holding a partner closer than h for one of its particles, in `close`.
pub(super) fn increment_densities(pass: Densities, clusters: &Clusters) {
    let Densities {
        params,
        rho,
        close,
        packed,
        ..
    } = pass;
    let Packed {
        rho: sums,
        narrowed,
        ..
    } = packed;
    let empty = clusters.empty_cluster();
    narrowed.narrow_positions(clusters);
    sums.clear();
    sums.resize(empty * CLUSTER, 0.0);
    let p = clusters.positions();
    let h2 = f32x16::splat(params.h2 as f32);
    let (own_mask, all) = (own_pairs(), f32x16::splat(f32::from_bits(u32::MAX)));
    close.starts.reserve(empty + 1);
    // The recorded clusters are written without a branch on whether a cluster pair holds
    // a close pair: each at the end, which advances only past those that do.
    let mut recorded = 0;
    for own in 0..empty {
        close.starts.push(recorded as u32);
        let rows = [0, 1, 2].map(|axis| particles(narrowed.p[axis][own]));
        let mut own_sums = f32x16::ZERO;
        let positions = (&narrowed.p, p);
        density_pair(
            positions,
            &rows,
            [own, own],
            own_mask,
            h2,
            &mut own_sums,
            sums,
        );
        let windows = clusters.windows(own);
        let most: u32 = windows.iter().map(|&[begin, end]| end - begin).sum();
        if close.clusters.len() < recorded + most as usize {
            close.clusters.resize(2 * (recorded + most as usize), 0);
        }
        for &[begin, end] in windows {
            for k in begin..end {
                let at = [own, k as usize];
                let found = density_pair(positions, &rows, at, all, h2, &mut own_sums, sums);
                close.clusters[recorded] = k;
                recorded += usize::from(found != 0);
            }
        }
        add_at(sums, own, particle_totals(own_sums));
    }
    close.clusters.truncate(recorded);
    close.starts.push(close.clusters.len() as u32);
    unpack_add(clusters.places(), sums, rho);
}

/// Stage 5 of the mixed kernel on `clusters`: each cluster against itself and the
/// clusters recorded for it by the density pass of the same placement (or, run alone,
/// every cluster of its windows), a cluster pair per register.
pub(super) fn transfer_accelerations<const FLUIDANIMATE: bool>(
    pass: Accelerations<FLUIDANIMATE>,
    clusters: &Clusters,
) {
    let Accelerations {
        params,
        candidates,
        v,
        rho,
        a,
        packed,
        ..
    } = pass;
    let Packed {
        a: sums, narrowed, ..
    } = packed;
    let places = clusters.places();
    let empty = clusters.empty_cluster();
    let recorded = candidates.recorded_on(clusters);
    if recorded.is_none() {
        // No density pass over these positions: they are not narrowed yet.
        narrowed.narrow_positions(clusters);
    }
    for axis in 0..3 {
        narrow_by_cluster(places, &v[axis], |v| v as f32, &mut narrowed.v[axis]);
        sums[axis].clear();
        sums[axis].resize(empty * CLUSTER, 0.0);
    }
    // The densities less the rest density (small numbers, exact enough in f32 for their
    // sums less twice the rest density) and their reciprocals.
    narrow_by_cluster(
        places,
        rho,
        |rho| (rho - FLUID_DENSITY) as f32,
        &mut narrowed.excess,
    );
    narrow_by_cluster(
        places,
        rho,
        |rho| (1.0 / rho) as f32,
        &mut narrowed.inverse_rho,
    );
    let p = clusters.positions();
    let terms = Terms::<FLUIDANIMATE>::new(params);
    let all = f32x16::splat(f32::from_bits(u32::MAX));
    let own_mask = own_pairs();
    for own in 0..empty {
        let rows = Rows::of(narrowed, own);
        let mut own_sums = [f32x16::ZERO; 3];
        terms.add_pair(
            (narrowed, p),
            &rows,
            [own, own],
            own_mask,
            &mut own_sums,
            sums,
        );
        match recorded {
            Some(close) => {
                let entries =
                    &close.clusters[close.starts[own] as usize..close.starts[own + 1] as usize];
                for &k in entries {
                    let k = k as usize;
                    terms.add_pair((narrowed, p), &rows, [own, k], all, &mut own_sums, sums);
                }
            }
            None => {
                for &[begin, end] in clusters.windows(own) {
                    for k in begin as usize..end as usize {
                        terms.add_pair((narrowed, p), &rows, [own, k], all, &mut own_sums, sums);
                    }
                }
            }
        }
        for axis in 0..3 {
            add_at(&mut sums[axis], own, particle_totals(own_sums[axis]));
        }
    }
    for axis in 0..3 {
        unpack_add(places, &sums[axis], &mut a[axis]);
    }
}

/// What a cluster's particles contribute to their pair terms, one per run of 4 lanes.
struct Rows {
    p: [f32x16; 3],
    v: [f32x16; 3],
    excess: f32x16,
    inverse_rho: f32x16,
}

impl Rows {
    /// The particles of cluster `own`.
    fn of(narrowed: &Narrowed, own: usize) -> Self {
        Rows {
            p: [0, 1, 2].map(|axis| particles(narrowed.p[axis][own])),
            v: [0, 1, 2].map(|axis| particles(narrowed.v[axis][own])),
            excess: particles(narrowed.excess[own]),
            inverse_rho: particles(narrowed.inverse_rho[own]),
        }
    }
}

/// The constants of the acceleration terms, in f32 lanes.
struct Terms<const FLUIDANIMATE: bool> {
    h: f32x16,
    h2: f32x16,
    min_distance_squared: f32x16,
    pressure_factor: f32x16,
    viscosity_factor: f32x16,
}

impl<const FLUIDANIMATE: bool> Terms<FLUIDANIMATE> {
    fn new(params: &Params) -> Self {
        Terms {
            h: f32x16::splat(params.h as f32),
            h2: f32x16::splat(params.h2 as f32),
            min_distance_squared: f32x16::splat(MIN_DISTANCE_SQUARED as f32),
            pressure_factor: f32x16::splat(params.pressure_factor as f32),
            viscosity_factor: f32x16::splat(params.viscosity_factor as f32),
        }
    }

    /// The acceleration terms of the cluster pair `[own, k]` (lanes of `mask`): the
    /// particles' (`rows`) added to `own_sums`, the partners' subtracted from `sums` (f64,
    /// by place).
    #[inline(always)]
    fn add_pair(
        &self,
        (narrowed, p): (&Narrowed, &AxisArrays),
        rows: &Rows,
        [own, k]: [usize; 2],
        mask: f32x16,
        own_sums: &mut [f32x16; 3],
        sums: &mut AxisArrays,
    ) {
        let d = offsets(&narrowed.p, &rows.p, k, &Narrowed::shift(p, own, k));
        if let Some(terms) = self.of(narrowed, rows, d, k, mask) {
            for axis in 0..3 {
                own_sums[axis] += terms[axis];
                let totals = partner_totals(terms[axis]).map(|t| -t);
                add_at(&mut sums[axis], k, totals);
            }
        }
    }

    /// The acceleration terms of the particles `rows` with partner cluster `k` at
    /// offsets `d` (lanes of `mask`), per axis; `None` if no pair is closer than h.
    #[inline(always)]
    fn of(
        &self,
        narrowed: &Narrowed,
        rows: &Rows,
        d: [f32x16; 3],
        k: usize,
        mask: f32x16,
    ) -> Option<[f32x16; 3]> {
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let within = r2.simd_lt(self.h2) & mask;
        if within.to_bitmask() == 0 {
            return None;
        }
        let dist = r2.max(self.min_distance_squared).sqrt();
        let q = self.h - dist;
        let excess = rows.excess + narrowed.excess[k];
        let pressure = self.pressure_factor * q * q / dist * excess;
        let per_density_product = rows.inverse_rho * narrowed.inverse_rho[k];
        let term = |axis: usize| {
            let dv = narrowed.v[axis][k] - rows.v[axis];
            let mut viscosity = dv * self.viscosity_factor;
            if FLUIDANIMATE {
                viscosity *= q;
            }
            ((d[axis] * pressure + viscosity) * per_density_product) & within
        };
        Some([term(0), term(1), term(2)])
    }
}
