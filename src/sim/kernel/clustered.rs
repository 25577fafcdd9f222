//! The course models' SIMD pair loops on [`Clusters`]: the 4 particles of a cluster
//! against each cluster of its windows, GROMACS' cluster pairs. On 4 lanes a register
//! holds a partner cluster and each particle is a row of its own (4 x 4); on 8 lanes the
//! partner cluster fills both halves and a row holds two particles, one per half (GROMACS'
//! 2 x 4 + 4 layout on AVX-512), so every layout evaluates the same 16 pairs per cluster
//! pair. The partners are loaded once for the 4 particles, without a gather (a cluster's
//! places are contiguous); each particle's sums stay in registers over all its
//! windows, the partners' in a register over the 4 particles, added to memory once per
//! cluster pair (Newton's third law in registers). A cluster's pairs among its own
//! particles run as a pair of their own, lanes masked to the partners after each
//! particle.
//!
//! The density pass records, per cluster, the clusters of its windows that hold a partner
//! closer than h, each with the particles that have one (`ClosePairs::clusters`). The
//! acceleration pass of the same positions, bound by its square root and division per
//! lane, then runs each particle against only the clusters recorded for it, as many per
//! register as it holds (1 on 4 lanes, 2 on 8), so that no lane serves a particle
//! without a partner there. Both sum into copies by place ([`Packed`]), added to the
//! particles' slots at the end.

use super::simd::{First, Halves, Lanes, Places, Transfer};
use super::{Accelerations, Densities, Packed};
use crate::sim::clusters::{Clusters, CLUSTER, EMPTY};
use crate::sim::particles::AxisArrays;

/// Where a recorded cluster's entry holds the particles of the recording cluster that
/// have a partner closer than h in it (a bit per particle; the cluster's index below).
const PARTICLES_SHIFT: u32 = 28;

/// Every particle of a cluster, a bit each.
const ALL_PARTICLES: u32 = (1 << CLUSTER) - 1;

/// The cluster of a list entry.
#[inline(always)]
fn cluster_of(entry: u32) -> usize {
    (entry & ((1 << PARTICLES_SHIFT) - 1)) as usize
}

/// The particles of a cluster per row of `L` lanes: 1 on 4 lanes, 2 (a half each) on 8.
const fn per_row<L: Lanes>() -> usize {
    L::LANES / CLUSTER
}

/// The rows of a cluster's particles on `L` lanes.
const fn row_count<L: Lanes>() -> usize {
    CLUSTER / per_row::<L>()
}

/// The places of partner cluster `k` in a register: in each run of 4 lanes (both halves
/// of 8).
#[inline(always)]
fn partners_at(k: usize) -> Places {
    Places::fours(k * CLUSTER, k * CLUSTER)
}

/// Where a cluster pair's partner sums are added: cluster `k`'s places (first half),
/// then the `empty` cluster's (second half, on 8 lanes: zeros).
#[inline(always)]
fn sums_at(k: usize, empty: usize) -> Places {
    Places::fours(k * CLUSTER, empty * CLUSTER)
}

/// The partner sums of a register to add at [`sums_at`]: on 8 lanes, both halves (the
/// same partners) folded into the first.
#[inline(always)]
fn folded<L: Lanes>(partners: L::V) -> L::V {
    if per_row::<L>() == 2 {
        L::fold_halves(partners)
    } else {
        partners
    }
}

/// The lanes row `row` of a cluster is compared with: with `OWN` (its pairs among its
/// own particles), the particles after each of the row's; else every lane.
#[inline(always)]
fn lanes_of<L: Lanes, const OWN: bool>(row: usize) -> L::V {
    match (OWN, per_row::<L>()) {
        (false, _) => L::all(),
        (true, 1) => L::lanes_between(row + 1, CLUSTER),
        (true, _) => L::after_in_halves([2 * row, 2 * row + 1]),
    }
}

/// The places of row `row` of the cluster at `base`: its particle's twice, or its two
/// particles' (one per half).
#[inline(always)]
fn row_places<L: Lanes>(base: usize, row: usize) -> [usize; 2] {
    let first = base + row * per_row::<L>();
    [first, first + per_row::<L>() - 1]
}

/// The value of `values` at `places`, one per half.
#[inline(always)]
fn at_halves(values: &[f64], [a, b]: [usize; 2]) -> Halves {
    Halves([values[a], values[b]])
}

/// Adds the totals of `sum`, row `row`'s, to its particles in `target` (by place) from
/// `base`.
#[inline(always)]
fn add_row_total<L: Lanes>(sum: L::Sum, target: &mut [f64], base: usize, row: usize) {
    if per_row::<L>() == 2 {
        let [a, b] = L::half_totals(sum);
        target[base + 2 * row] += a;
        target[base + 2 * row + 1] += b;
    } else {
        target[base + row] += L::total(sum);
    }
}

/// The particles (a bit each) with a partner in a register, from each row's bit per
/// lane closer than h.
#[inline(always)]
fn particles_found<L: Lanes>(found: &[u32; CLUSTER]) -> u32 {
    (0..CLUSTER).fold(0, |particles, i| {
        let (row, half) = (i / per_row::<L>(), i % per_row::<L>());
        let lanes = found[row] >> (CLUSTER * half) & ALL_PARTICLES;
        particles | u32::from(lanes != 0) << i
    })
}

/// Adds `packed` (by place) to `target` (by slot).
pub(super) fn unpack_add(places: &[u32], packed: &[f64], target: &mut [f64]) {
    for (&slot, &value) in places.iter().zip(packed) {
        if slot != EMPTY {
            target[slot as usize] += value;
        }
    }
}

/// Panics unless every packed array holds the empty cluster after the last place.
fn assert_loadable(clusters: &Clusters, arrays: &[&[f64]]) {
    let needed = (clusters.empty_cluster() + 1) * CLUSTER;
    assert!(arrays.iter().all(|a| a.len() >= needed));
}

/// The density terms (h^2 - r^2)^3 of the rows `rows` of a cluster with partner cluster
/// `k` (with `OWN`, `k` is theirs, and only the partners after each particle count):
/// each row's added to its `row_sums`, the partners' to `sums` (with the `empty`
/// cluster's). Returns each row's bit per lane holding a partner closer than h.
///
/// # Safety
/// Every place of clusters `k` and `empty` is within `sums` and every array of `p`.
#[inline(always)]
unsafe fn density_block<L: Lanes, const OWN: bool>(
    p: &AxisArrays,
    sums: &mut [f64],
    rows: &[[Halves; 3]; CLUSTER],
    h2: L::V,
    [k, empty]: [usize; 2],
    row_sums: &mut [L::Sum; CLUSTER],
) -> [u32; CLUSTER] {
    let at = partners_at(k);
    let mut partners = L::splat(0.0);
    let mut found = [0; CLUSTER];
    for (row, first) in rows.iter().enumerate().take(row_count::<L>()) {
        // SAFETY: guaranteed by the caller.
        let offset = |axis: usize| unsafe { L::offsets(&p[axis], at, first[axis]) };
        let (dx, dy, dz) = (offset(0), offset(1), offset(2));
        let r2 = dx * dx + dy * dy + dz * dz;
        let close = L::lt(r2, h2) & lanes_of::<L, OWN>(row);
        let q = h2 - r2;
        let t = (q * q * q) & close;
        L::accumulate(&mut row_sums[row], t);
        partners = partners + t;
        found[row] = L::bitmask(close);
    }
    // SAFETY: guaranteed by the caller.
    unsafe { L::add_to(sums, sums_at(k, empty), folded::<L>(partners)) };
    found
}

/// Stage 3 on `L` lanes, over `clusters`: records, per cluster, the clusters of its
/// windows holding a partner closer than h, with the particles that have one, in
/// `close`.
pub(super) fn increment_densities<L: Lanes>(pass: Densities, clusters: &Clusters) {
    let Densities {
        params,
        rho,
        close,
        packed,
        ..
    } = pass;
    let Packed { rho: sums, .. } = packed;
    let (places, p) = (clusters.places(), clusters.positions());
    let empty = clusters.empty_cluster();
    sums.clear();
    sums.resize((empty + 1) * CLUSTER, 0.0);
    assert_loadable(clusters, &[&p[0], &p[1], &p[2], sums]);
    let h2 = L::splat(params.h2);
    assert!(empty < 1 << PARTICLES_SHIFT, "too many clusters to record");
    // The recorded clusters are written without a branch on whether a cluster holds a
    // close pair (about half do, unpredictably): each is written at the end, which
    // advances only past those that do.
    close.starts.reserve(empty + 1);
    let mut recorded = 0;
    for own in 0..empty {
        close.starts.push(recorded as u32);
        let base = own * CLUSTER;
        let rows = std::array::from_fn(|row| {
            let places = row_places::<L>(base, row % row_count::<L>());
            [0, 1, 2].map(|axis| at_halves(&p[axis], places))
        });
        let mut row_sums = [L::ZERO_SUM; CLUSTER];
        // SAFETY (both blocks): every place of a cluster or of the empty cluster is
        // within every array (assert_loadable).
        unsafe { density_block::<L, true>(p, sums, &rows, h2, [own, empty], &mut row_sums) };
        let windows = clusters.windows(own);
        let most: u32 = windows.iter().map(|&[begin, end]| end - begin).sum();
        if close.clusters.len() < recorded + most as usize {
            close.clusters.resize(2 * (recorded + most as usize), 0);
        }
        for &[begin, end] in windows {
            for k in begin..end {
                let at = [k as usize, empty];
                let found =
                    unsafe { density_block::<L, false>(p, sums, &rows, h2, at, &mut row_sums) };
                let particles = particles_found::<L>(&found);
                close.clusters[recorded] = k | particles << PARTICLES_SHIFT;
                recorded += usize::from(particles != 0);
            }
        }
        for (row, sum) in row_sums.into_iter().enumerate().take(row_count::<L>()) {
            add_row_total::<L>(sum, sums, base, row);
        }
    }
    close.clusters.truncate(recorded);
    close.starts.push(recorded as u32);
    unpack_add(places, sums, rho);
}

/// The acceleration terms of the rows `rows` of cluster `own` among its own particles
/// (each with the particles after it): each row's added to its `row_sums`, the
/// partners' subtracted from `a` (with the `empty` cluster's). A row without a partner
/// closer than h is skipped after its distances.
///
/// # Safety
/// Every place of clusters `own` and `empty` is within every array of `transfer` and
/// `a`.
#[inline(always)]
unsafe fn own_transfer<L: Lanes, const FLUIDANIMATE: bool>(
    transfer: &Transfer<L, FLUIDANIMATE>,
    rows: &[First; CLUSTER],
    [own, empty]: [usize; 2],
    a: &mut [&mut Vec<f64>; 3],
    row_sums: &mut [[L::Sum; 3]; CLUSTER],
) {
    let at = partners_at(own);
    let mut partners = [L::splat(0.0); 3];
    for row in 0..row_count::<L>() {
        let lanes = lanes_of::<L, true>(row);
        // SAFETY: guaranteed by the caller.
        if let Some(terms) = unsafe { transfer.group(&rows[row], at, lanes) } {
            for axis in 0..3 {
                L::accumulate(&mut row_sums[row][axis], terms[axis]);
                partners[axis] = partners[axis] + terms[axis];
            }
        }
    }
    for axis in 0..3 {
        let terms = folded::<L>(partners[axis]);
        // SAFETY: guaranteed by the caller.
        unsafe { L::subtract_from(a[axis], sums_at(own, empty), terms) };
    }
}

/// Stage 5 on `L` lanes, over `clusters`; with [`super::Candidates::Close`] recorded on them,
/// only the clusters recorded there, else every cluster of its windows.
pub(super) fn transfer_accelerations<L: Lanes, const FLUIDANIMATE: bool>(
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
    let places = clusters.places();
    let empty = clusters.empty_cluster();
    // Without a density pass over the same clusters, every cluster of the windows with
    // every particle (a pass run alone).
    let (mut every, mut every_start) = (Vec::new(), Vec::new());
    let (list, starts) = match candidates.recorded_on(clusters) {
        Some(close) => (&close.clusters[..], &close.starts[..]),
        None => {
            assert!(empty < 1 << PARTICLES_SHIFT, "too many clusters to record");
            for own in 0..empty {
                every_start.push(every.len() as u32);
                let all = clusters.candidates(own);
                every.extend(all.map(|k| k as u32 | ALL_PARTICLES << PARTICLES_SHIFT));
            }
            every_start.push(every.len() as u32);
            (&every[..], &every_start[..])
        }
    };
    let Packed {
        v: packed_v,
        rho: packed_rho,
        inverse_rho,
        a: packed_a,
        per_particle,
        ..
    } = packed;
    for axis in 0..3 {
        clusters.pack(&v[axis], |_| 0.0, &mut packed_v[axis]);
        packed_a[axis].clear();
        packed_a[axis].resize((empty + 1) * CLUSTER, 0.0);
    }
    clusters.pack(rho, |_| 1.0, packed_rho);
    inverse_rho.clear();
    inverse_rho.extend(packed_rho.iter().map(|rho| 1.0 / rho));
    let p = clusters.positions();
    let [vx, vy, vz] = &*packed_v;
    let [ax, ay, az] = packed_a;
    let arrays = [
        &p[0][..],
        &p[1],
        &p[2],
        vx,
        vy,
        vz,
        packed_rho,
        inverse_rho,
        ax,
        ay,
        az,
    ];
    assert_loadable(clusters, &arrays);
    let transfer = Transfer::<L, FLUIDANIMATE>::new(
        params,
        [&p[0], &p[1], &p[2]],
        [vx, vy, vz],
        packed_rho,
        inverse_rho,
    );
    let mut sums_to = [ax, ay, az];
    // The particle or particles (one per half) whose values `value` takes from each
    // array.
    let first_of = |value: &dyn Fn(&[f64]) -> Halves| First {
        p: [value(&p[0]), value(&p[1]), value(&p[2])],
        v: [value(vx), value(vy), value(vz)],
        rho: value(packed_rho),
        inverse_rho: value(inverse_rho),
    };
    for own in 0..empty {
        let base = own * CLUSTER;
        let rows: [First; CLUSTER] = std::array::from_fn(|row| {
            let places = row_places::<L>(base, row % row_count::<L>());
            first_of(&|values| at_halves(values, places))
        });
        let mut row_sums = [[L::ZERO_SUM; 3]; CLUSTER];
        // SAFETY: every place of a cluster or of the empty cluster is within every array
        // (assert_loadable).
        unsafe { own_transfer(&transfer, &rows, [own, empty], &mut sums_to, &mut row_sums) };
        // Each particle against the clusters where it has a close partner, as many per
        // register as it holds (1 on 4 lanes, 2 on 8): every lane of a register then
        // serves one particle, and no row is evaluated for a particle without one. The
        // lists are written without a branch, as the density pass recorded them.
        let entries = &list[starts[own] as usize..starts[own + 1] as usize];
        let stride = entries.len() + 1;
        per_particle.clear();
        per_particle.resize(CLUSTER * stride, empty as u32);
        let mut counts = [0; CLUSTER];
        for &entry in entries {
            for (i, count) in counts.iter_mut().enumerate() {
                per_particle[i * stride + *count] = cluster_of(entry) as u32;
                *count += (entry >> (PARTICLES_SHIFT + i as u32) & 1) as usize;
            }
        }
        for (i, &count) in counts.iter().enumerate() {
            let first = first_of(&|values| values[base + i].into());
            let mut sum = [L::ZERO_SUM; 3];
            let listed = &per_particle[i * stride..i * stride + count];
            // As many clusters per register as a row holds particles.
            for chunk in listed.chunks(per_row::<L>()) {
                let second = chunk.get(1).map_or(empty, |&k| k as usize);
                let at = Places::fours(chunk[0] as usize * CLUSTER, second * CLUSTER);
                // SAFETY: every place of a cluster or of the empty cluster is within
                // every array (assert_loadable).
                if let Some(terms) = unsafe { transfer.group(&first, at, L::all()) } {
                    for axis in 0..3 {
                        L::accumulate(&mut sum[axis], terms[axis]);
                        // SAFETY: as above.
                        unsafe { L::subtract_from(sums_to[axis], at, terms[axis]) };
                    }
                }
            }
            for (axis, sum) in sum.into_iter().enumerate() {
                sums_to[axis][base + i] += L::total(sum);
            }
        }
        for (row, sums) in row_sums.into_iter().enumerate().take(row_count::<L>()) {
            for (axis, sum) in sums.into_iter().enumerate() {
                add_row_total::<L>(sum, sums_to[axis], base, row);
            }
        }
    }
    let a: &mut AxisArrays = a;
    for axis in 0..3 {
        unpack_add(places, &sums_to[axis][..], &mut a[axis]);
    }
}
