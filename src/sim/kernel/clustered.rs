//! The course models' SIMD pair loops on [`Clusters`]: the 4 particles of a cluster
//! against a register of partner clusters (one on 4 lanes, two on 8) from its cluster
//! pair list, GROMACS' cluster pairs. The partners are loaded once for the 4 particles,
//! without a gather (a cluster's places are contiguous); each particle's sums stay in
//! registers over the whole list, the partners' in a register over the 4 particles,
//! added to memory once per register (Newton's third law in registers). A cluster's
//! pairs among its own particles run in a register of their own, lanes masked to the
//! partners after each particle.
//!
//! The density pass records, per cluster, the clusters of its windows that hold a partner
//! closer than h (`ClosePairs::clusters`), which the acceleration pass of the same
//! positions then visits alone, skipping the particles without such a partner in a
//! register. Both sum into copies by place ([`Packed`]), added to the particles' slots
//! at the end.

use super::simd::{First, Lanes, Places, Transfer};
use super::{Accelerations, Candidates, Densities, Packed};
use crate::sim::clusters::{Clusters, CLUSTER, EMPTY};
use crate::sim::particles::AxisArrays;

/// Where a recorded cluster's entry holds the particles of the recording cluster that
/// have a partner closer than h in it (a bit per particle; the cluster's index below).
const ROWS_SHIFT: u32 = 28;

/// Every particle of a cluster, a bit each.
const ALL_ROWS: u32 = (1 << CLUSTER) - 1;

/// The cluster of a list entry (recorded or not).
#[inline(always)]
fn cluster_of(entry: u32) -> usize {
    (entry & ((1 << ROWS_SHIFT) - 1)) as usize
}

/// The places of a register holding the clusters of the entries `chunk` (one per
/// quarter of 4 lanes), its spare quarter the `empty` cluster.
#[inline(always)]
fn places_of(chunk: &[u32], empty: usize) -> Places {
    let second = chunk.get(1).map_or(empty, |&entry| cluster_of(entry));
    Places::quarters(cluster_of(chunk[0]) * CLUSTER, second * CLUSTER)
}

/// The places of the register of cluster `own`'s pairs among its particles: its own,
/// then (on 8 lanes) the `empty` cluster.
#[inline(always)]
fn own_places(own: usize, empty: usize) -> Places {
    Places::quarters(own * CLUSTER, empty * CLUSTER)
}

/// The lanes particle `row` of a cluster is compared with: with `OWN` (its own
/// cluster's register), the particles after it; else every lane.
#[inline(always)]
fn lanes_of<L: Lanes, const OWN: bool>(row: usize) -> L::V {
    if OWN {
        L::lanes_between(row + 1, CLUSTER)
    } else {
        L::all()
    }
}

/// Adds `packed` (by place) to `target` (by slot).
fn unpack_add(places: &[u32], packed: &[f64], target: &mut [f64]) {
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

/// The density terms (h^2 - r^2)^3 of the 4 particles at `rows` with the partners at
/// `at` (with `OWN`, only those after each): each particle's added to its `row_sums`,
/// the partners' to `sums` at `at`. Returns, for each of the 4, a bit per lane holding
/// a partner closer than h.
///
/// # Safety
/// Every place `at` names is within `sums` and every array of `p`.
#[inline(always)]
unsafe fn density_block<L: Lanes, const OWN: bool>(
    p: &AxisArrays,
    sums: &mut [f64],
    rows: &[[f64; 3]; CLUSTER],
    h2: L::V,
    at: Places,
    row_sums: &mut [L::Sum; CLUSTER],
) -> [u32; CLUSTER] {
    let mut partners = L::splat(0.0);
    let mut found = [0; CLUSTER];
    for (row, first) in rows.iter().enumerate() {
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
    unsafe { L::add_to(sums, at, partners) };
    found
}

/// Stage 3 on `L` lanes, over `clusters`: records, per cluster, the clusters of its
/// windows holding a partner closer than h in `close`.
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
    let per_register = L::LANES / CLUSTER;
    assert!(empty < 1 << ROWS_SHIFT, "too many clusters to record");
    // The recorded clusters are written without a branch on whether a cluster holds a
    // close pair (about half do, unpredictably): each is written at the end, which
    // advances only past those that do.
    close.starts.reserve(empty + 1);
    let mut recorded = 0;
    for own in 0..empty {
        close.starts.push(recorded as u32);
        let base = own * CLUSTER;
        let rows =
            std::array::from_fn(|row| [p[0][base + row], p[1][base + row], p[2][base + row]]);
        let mut row_sums = [L::ZERO_SUM; CLUSTER];
        // SAFETY (both blocks): every place of a cluster or of the empty cluster is
        // within every array (assert_loadable).
        unsafe {
            let at = own_places(base / CLUSTER, empty);
            density_block::<L, true>(p, sums, &rows, h2, at, &mut row_sums);
        }
        let windows = clusters.windows(own);
        let most: u32 = windows.iter().map(|&[begin, end]| end - begin).sum();
        if close.clusters.len() < recorded + most as usize + 1 {
            close.clusters.resize(2 * (recorded + most as usize + 1), 0);
        }
        for &[begin, end] in windows {
            // A register of `per_register` consecutive clusters of the window, the empty
            // one past its end.
            for first in (begin..end).step_by(per_register) {
                let second = if first + 1 < end {
                    first + 1
                } else {
                    empty as u32
                };
                let registered = [first, second];
                let at = Places::quarters(first as usize * CLUSTER, second as usize * CLUSTER);
                let found =
                    unsafe { density_block::<L, false>(p, sums, &rows, h2, at, &mut row_sums) };
                for (quarter, &k) in registered.iter().enumerate().take(per_register) {
                    let rows = found.iter().enumerate().fold(0, |rows, (row, &lanes)| {
                        let quarter_lanes = lanes >> (CLUSTER * quarter) & ALL_ROWS;
                        rows | u32::from(quarter_lanes != 0) << row
                    });
                    // The empty cluster has no close partner: never recorded.
                    close.clusters[recorded] = k | rows << ROWS_SHIFT;
                    recorded += usize::from(rows != 0);
                }
            }
        }
        for (row, sum) in row_sums.into_iter().enumerate() {
            sums[base + row] += L::total(sum);
        }
    }
    close.clusters.truncate(recorded);
    close.starts.push(recorded as u32);
    unpack_add(places, sums, rho);
}

/// The acceleration terms of the particles `rows` of a cluster named in `wanted` (a bit
/// each) with the partners at `at` (with `OWN`, only those after each): each
/// particle's added to its `row_sums`, the partners' subtracted from `a` at `at`. A
/// particle without a partner closer than h in the register is skipped after its
/// distances.
///
/// # Safety
/// Every place `at` names is within every array of `transfer` and `a`.
#[inline(always)]
unsafe fn transfer_block<L: Lanes, const FLUIDANIMATE: bool, const OWN: bool>(
    transfer: &Transfer<L, FLUIDANIMATE>,
    rows: &[First; CLUSTER],
    at: Places,
    a: &mut [&mut Vec<f64>; 3],
    row_sums: &mut [[L::Sum; 3]; CLUSTER],
    wanted: u32,
) {
    let mut partners = [L::splat(0.0); 3];
    let mut left = wanted;
    while left != 0 {
        let row = left.trailing_zeros() as usize;
        left &= left - 1;
        let lanes = lanes_of::<L, OWN>(row);
        // SAFETY: guaranteed by the caller.
        if let Some(terms) = unsafe { transfer.group(&rows[row], at, lanes) } {
            for axis in 0..3 {
                L::accumulate(&mut row_sums[row][axis], terms[axis]);
                partners[axis] = partners[axis] + terms[axis];
            }
        }
    }
    for axis in 0..3 {
        // SAFETY: guaranteed by the caller.
        unsafe { L::subtract_from(a[axis], at, partners[axis]) };
    }
}

/// Stage 5 on `L` lanes, over `clusters`; with [`Candidates::Close`] recorded on them,
/// only the clusters recorded there, else every cluster of each list.
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
    let (list, starts) = match candidates {
        Candidates::Close(close) if close.starts.len() == empty + 1 => {
            (&close.clusters[..], &close.starts[..])
        }
        _ => {
            for own in 0..empty {
                every_start.push(every.len() as u32);
                let all = clusters.candidates(own);
                every.extend(all.map(|k| k as u32 | ALL_ROWS << ROWS_SHIFT));
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
    } = packed;
    for axis in 0..3 {
        clusters.pack(&v[axis], 0.0, &mut packed_v[axis]);
        packed_a[axis].clear();
        packed_a[axis].resize((empty + 1) * CLUSTER, 0.0);
    }
    clusters.pack(rho, 1.0, packed_rho);
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
    let per_register = L::LANES / CLUSTER;
    for own in 0..empty {
        let base = own * CLUSTER;
        let rows: [First; CLUSTER] = std::array::from_fn(|row| {
            let i = base + row;
            First {
                p: [p[0][i], p[1][i], p[2][i]],
                v: [vx[i], vy[i], vz[i]],
                rho: packed_rho[i],
                inverse_rho: inverse_rho[i],
            }
        });
        let mut row_sums = [[L::ZERO_SUM; 3]; CLUSTER];
        // SAFETY (both blocks): every place of a cluster or of the empty cluster is
        // within every array (assert_loadable).
        unsafe {
            let at = own_places(own, empty);
            transfer_block::<L, FLUIDANIMATE, true>(
                &transfer,
                &rows,
                at,
                &mut sums_to,
                &mut row_sums,
                ALL_ROWS,
            );
        }
        let listed = &list[starts[own] as usize..starts[own + 1] as usize];
        for chunk in listed.chunks(per_register) {
            let at = places_of(chunk, empty);
            let wanted = chunk
                .iter()
                .fold(0, |rows, &entry| rows | entry >> ROWS_SHIFT);
            unsafe {
                transfer_block::<L, FLUIDANIMATE, false>(
                    &transfer,
                    &rows,
                    at,
                    &mut sums_to,
                    &mut row_sums,
                    wanted,
                )
            };
        }
        for (row, sums) in row_sums.into_iter().enumerate() {
            for (axis, sum) in sums.into_iter().enumerate() {
                sums_to[axis][base + row] += L::total(sum);
            }
        }
    }
    let a: &mut AxisArrays = a;
    for axis in 0..3 {
        unpack_add(places, &sums_to[axis][..], &mut a[axis]);
    }
}
