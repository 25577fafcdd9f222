//! The course models' SIMD pair loops on [`Clusters`]: each particle against whole
//! clusters of its candidate windows, a cluster one register of lanes (loaded without a
//! gather: its places are contiguous), the particle's sums in registers, the cluster's
//! updated lane-wise in memory. The density pass records, per place, the clusters that
//! hold a partner closer than h (`ClosePairs::clusters`), which the acceleration pass
//! of the same positions then visits alone. Both sum into copies by place ([`Packed`]),
//! added to the particles' slots at the end.

use super::simd::{density_group, First, Lanes, Transfer};
use super::{Accelerations, Candidates, Densities, Packed};
use crate::sim::clusters::{Clusters, EMPTY};
use crate::sim::particles::AxisArrays;

/// Calls `visit(j, end)` for each group of the place `i`: the places after it in its own
/// cluster (`i + 1..` its cluster's end), then each cluster of its own cluster's
/// `windows` (`start..start + width`). With a `list` (entries, and where each place's
/// start), only the clusters listed for `i` (its own standing for the places after it).
#[inline(always)]
fn for_each_group(
    clusters: &Clusters,
    list: Option<(&[u32], &[u32])>,
    i: usize,
    windows: &[std::ops::Range<usize>; 5],
    mut visit: impl FnMut(usize, usize),
) {
    let width = clusters.width();
    let own = i / width;
    let group = |k: usize| {
        if k == own {
            (i + 1, (own + 1) * width)
        } else {
            (k * width, (k + 1) * width)
        }
    };
    match list {
        Some((entries, starts)) => {
            let (from, to) = (starts[i] as usize, starts[i + 1] as usize);
            for &k in &entries[from..to] {
                let (j, end) = group(k as usize);
                visit(j, end);
            }
        }
        None => {
            if i + 1 < (own + 1) * width {
                visit(i + 1, (own + 1) * width);
            }
            for window in windows {
                for k in window.clone() {
                    visit(k * width, (k + 1) * width);
                }
            }
        }
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

/// Panics unless every packed array holds a whole cluster after its last place.
fn assert_loadable<L: Lanes>(clusters: &Clusters, arrays: &[&[f64]]) {
    let needed = clusters.places().len() + L::LANES;
    assert!(
        L::LANES <= clusters.width(),
        "clusters narrower than the lanes"
    );
    assert!(arrays.iter().all(|a| a.len() >= needed));
}

/// Stage 3 on `L` lanes, over `clusters`: records the clusters with a partner closer than
/// h per place in `close`.
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
    sums.clear();
    sums.resize(places.len() + clusters.width(), 0.0);
    assert_loadable::<L>(clusters, &[&p[0], &p[1], &p[2], sums]);
    let width = clusters.width();
    let h2 = L::splat(params.h2);
    close.starts.reserve(places.len() + 1);
    let kept = clusters.list();
    let mut windows = [0..0, 0..0, 0..0, 0..0, 0..0];
    // The recorded clusters are written without a branch on whether a group holds a
    // close pair (half of them do, unpredictably): each candidate is written at the
    // end, which advances only past those that do.
    let mut recorded = 0;
    for i in 0..places.len() {
        close.starts.push(recorded as u32);
        let own = i / width;
        if kept.is_none() && i % width == 0 && places[i] != EMPTY {
            windows = clusters.windows(own, params.h);
        }
        if places[i] == EMPTY {
            continue;
        }
        let candidates = match kept {
            Some((_, starts)) => (starts[i + 1] - starts[i]) as usize,
            None => 1 + windows.iter().map(ExactSizeIterator::len).sum::<usize>(),
        };
        if close.clusters.len() < recorded + candidates {
            close.clusters.resize(2 * (recorded + candidates), 0);
        }
        let first = [p[0][i], p[1][i], p[2][i]];
        let mut sum = L::ZERO_SUM;
        let record = &mut close.clusters[..];
        for_each_group(clusters, kept, i, &windows, |j, end| {
            let lanes = L::first(end - j);
            // SAFETY: j < end <= places + width, and assert_loadable checked that every
            // array holds places + width >= j + LANES elements.
            let found = unsafe { density_group::<L>(p, sums, first, h2, j, lanes, &mut sum) };
            record[recorded] = (j / width) as u32;
            recorded += usize::from(found);
        });
        sums[i] += L::total(sum);
    }
    close.clusters.truncate(recorded);
    close.starts.push(recorded as u32);
    unpack_add(places, sums, rho);
}

/// Stage 5 on `L` lanes, over `clusters`; with [`Candidates::Close`] recorded on them,
/// only the clusters recorded there.
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
    let width = clusters.width();
    let close = match candidates {
        Candidates::Close(close) if close.starts.len() == places.len() + 1 => Some(close),
        _ => None,
    };
    let Packed {
        v: packed_v,
        rho: packed_rho,
        a: packed_a,
    } = packed;
    for axis in 0..3 {
        clusters.pack(&v[axis], 0.0, &mut packed_v[axis]);
        packed_a[axis].clear();
        packed_a[axis].resize(places.len() + width, 0.0);
    }
    clusters.pack(rho, 1.0, packed_rho);
    let p = clusters.positions();
    let [vx, vy, vz] = &*packed_v;
    let arrays = [&p[0][..], &p[1], &p[2], vx, vy, vz, packed_rho];
    assert_loadable::<L>(clusters, &arrays);
    let transfer =
        Transfer::<L, FLUIDANIMATE>::new(params, [&p[0], &p[1], &p[2]], [vx, vy, vz], packed_rho);
    let [ax, ay, az] = packed_a;
    assert_loadable::<L>(clusters, &[ax, ay, az]);
    let mut sums_to = [ax, ay, az];
    let mut windows = [0..0, 0..0, 0..0, 0..0, 0..0];
    let list = close.map(|close| (&close.clusters[..], &close.starts[..]));
    for i in (0..places.len()).filter(|&i| places[i] != EMPTY) {
        if close.is_none() && i % width == 0 {
            windows = clusters.windows(i / width, params.h);
        }
        let first = First {
            p: [p[0][i], p[1][i], p[2][i]],
            v: [vx[i], vy[i], vz[i]],
            rho: packed_rho[i],
        };
        let mut sum = [L::ZERO_SUM; 3];
        for_each_group(clusters, list, i, &windows, |j, end| {
            // SAFETY: j < end <= places + width, and assert_loadable checked that every
            // array holds places + width >= j + LANES elements.
            unsafe { transfer.visit(&first, j, end, &mut sums_to, &mut sum) };
        });
        for axis in 0..3 {
            sums_to[axis][i] += L::total(sum[axis]);
        }
    }
    let a: &mut AxisArrays = a;
    for axis in 0..3 {
        unpack_add(places, &sums_to[axis][..], &mut a[axis]);
    }
}
