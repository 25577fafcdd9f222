//! The course models' SIMD pair passes across particles, over the full lists' [`Rows`]:
//! each lane is a particle of a block of consecutive slots, and a row of the block gives
//! each lane its next partner, so that a register computes one pair of each of its
//! particles. A lane's sums stay in its lane from the first row to the last and are
//! added to its particle once: no horizontal sums, no writes to partners (a full list
//! holds each pair twice, once for each of its particles, whose terms are each other's
//! exact negation), one loop exit per block.
//!
//! A partner's fields come from a record of 4 f64 packed by slot once per pass
//! ([`Lanes::records`]: positions with the density, velocities with the density's
//! reciprocal); the padding slot [`Rows::far`] has a record of its own, far from
//! everything, so a padded lane is never closer than h and adds exactly +0.

use super::simd::{Lanes, Transfer};
use super::{Accelerations, Densities, Packed};
use crate::sim::isa::{Gathers, OnInstructionSet, Record, Slots};
use crate::sim::lists::{Rows, ROW};
use crate::sim::params::FLUID_DENSITY;
use std::marker::PhantomData;

/// A coordinate of the padding slot's record: squared distances to it stay finite in f64
/// and beyond any cut-off.
const FAR: f64 = 1e100;

/// Fills `records` with the record `of(slot)` of each of the `n` first slots, then the
/// padding slot's, `far`.
fn pack(records: &mut Vec<Record>, n: usize, of: impl Fn(usize) -> Record, far: Record) {
    records.clear();
    records.extend((0..n).map(of));
    records.push(far);
}

/// The slots of a row's lanes from `from` (the first `L::LANES` of the 8), checked below
/// the records' count (written out: the water model's loop did not inline an array's
/// `from_fn` here).
#[inline(always)]
pub(super) fn lanes_of(row: &[u32; ROW], from: usize, records: usize) -> Slots {
    let at = |k: usize| row[(from + k) % ROW];
    let slots = [at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7)];
    Slots::new(slots, records)
}

/// The lanes' own slots from `first` (the padding slot past `n`).
#[inline(always)]
fn own(first: usize, n: usize, records: usize) -> Slots {
    Slots::new(std::array::from_fn(|k| (first + k).min(n) as u32), records)
}

/// Adds the first lanes of `sums` to `values` from `first`, up to `n`.
#[inline(always)]
pub(super) fn add_lanes(
    values: &mut [f64],
    first: usize,
    n: usize,
    sums: [f64; ROW],
    lanes: usize,
) {
    let count = lanes.min(n - first);
    for (value, sum) in values[first..first + count].iter_mut().zip(sums) {
        *value += sum;
    }
}

/// Stage 3 over `rows`.
pub(super) fn increment_densities<L: Lanes>(pass: Densities, rows: &Rows) {
    let isa = pass
        .lists
        .expect("rows come with their lists")
        .instruction_set();
    isa.run(DensityLoop::<L> {
        pass,
        rows,
        lanes: PhantomData,
    });
}

/// The density loop on lanes `L`.
struct DensityLoop<'a, L> {
    pass: Densities<'a>,
    rows: &'a Rows,
    lanes: PhantomData<L>,
}

impl<L: Lanes> OnInstructionSet for DensityLoop<'_, L> {
    type Output = ();

    fn run<G: Gathers>(self, isa: G) {
        let DensityLoop { pass, rows, .. } = self;
        let Densities {
            params,
            p,
            rho,
            packed,
            ..
        } = pass;
        let n = rows.far() as usize;
        let records = &mut packed.records;
        let [x, y, z] = p;
        pack(
            records,
            n,
            |i| [x[i], y[i], z[i], 0.0],
            [FAR, FAR, FAR, 0.0],
        );
        let count = records.len();
        let h2 = L::splat(params.h2);
        for block in 0..rows.blocks() {
            for from in (0..ROW).step_by(L::LANES) {
                let first = block * ROW + from;
                if first >= n {
                    break;
                }
                let center = L::records(isa, records, &own(first, n, count));
                let mut sum = L::ZERO_SUM;
                for row in rows.rows(block) {
                    let fields = L::records(isa, records, &lanes_of(row, from, count));
                    let offset = |axis: usize| L::narrowed(center[axis] - fields[axis]);
                    let [dx, dy, dz] = [offset(0), offset(1), offset(2)];
                    let r2 = dx * dx + dy * dy + dz * dz;
                    let q = h2 - r2;
                    L::accumulate(&mut sum, (q * q * q) & L::lt(r2, h2));
                }
                add_lanes(rho, first, n, L::lanes(sum), L::LANES);
            }
        }
    }
}

/// Stage 5 over `rows`.
pub(super) fn transfer_accelerations<L: Lanes, const FLUIDANIMATE: bool>(
    pass: Accelerations<FLUIDANIMATE>,
    rows: &Rows,
) {
    let isa = pass
        .lists
        .expect("rows come with their lists")
        .instruction_set();
    isa.run(AccelerationLoop::<L, FLUIDANIMATE> {
        pass,
        rows,
        lanes: PhantomData,
    });
}

/// The acceleration loop on lanes `L`.
struct AccelerationLoop<'a, L, const FLUIDANIMATE: bool> {
    pass: Accelerations<'a, FLUIDANIMATE>,
    rows: &'a Rows,
    lanes: PhantomData<L>,
}

impl<L: Lanes, const FLUIDANIMATE: bool> OnInstructionSet
    for AccelerationLoop<'_, L, FLUIDANIMATE>
{
    type Output = ();

    fn run<G: Gathers>(self, isa: G) {
        let AccelerationLoop { pass, rows, .. } = self;
        let Accelerations {
            params,
            p,
            v,
            rho,
            a,
            packed,
            ..
        } = pass;
        let n = rows.far() as usize;
        let Packed {
            records: positions,
            velocities,
            ..
        } = packed;
        let ([x, y, z], [vx, vy, vz]) = (p, v);
        let far_position = [FAR, FAR, FAR, 0.0];
        pack(positions, n, |i| [x[i], y[i], z[i], rho[i]], far_position);
        let velocity = |i: usize| [vx[i], vy[i], vz[i], 1.0 / rho[i]];
        pack(velocities, n, velocity, [0.0; 4]);
        let count = positions.len();
        let transfer = Transfer::<L, FLUIDANIMATE>::new(params, [&[]; 3], [&[]; 3], &[], &[]);
        let twice_rest_density = L::splat_f64(2.0 * FLUID_DENSITY);
        for block in 0..rows.blocks() {
            for from in (0..ROW).step_by(L::LANES) {
                let first = block * ROW + from;
                if first >= n {
                    break;
                }
                let own = own(first, n, count);
                let (p_i, v_i) = (
                    L::records(isa, positions, &own),
                    L::records(isa, velocities, &own),
                );
                let inverse_rho_i = L::narrowed(v_i[3]);
                let mut sum = [L::ZERO_SUM; 3];
                for row in rows.rows(block) {
                    let at = lanes_of(row, from, count);
                    let p_j = L::records(isa, positions, &at);
                    let offset = |axis: usize| L::narrowed(p_i[axis] - p_j[axis]);
                    let d = [offset(0), offset(1), offset(2)];
                    let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                    let close = L::lt(r2, transfer.h2());
                    let excess = L::narrowed(p_i[3] + p_j[3] - twice_rest_density);
                    let v_j = L::records(isa, velocities, &at);
                    let per_density_product = inverse_rho_i * L::narrowed(v_j[3]);
                    let difference = |axis: usize| L::narrowed(v_j[axis] - v_i[axis]);
                    let dv = [difference(0), difference(1), difference(2)];
                    let terms = transfer.terms(d, r2, close, excess, per_density_product, dv);
                    for (sum, terms) in sum.iter_mut().zip(terms) {
                        L::accumulate(sum, terms);
                    }
                }
                for (a, sum) in a.iter_mut().zip(sum) {
                    add_lanes(a, first, n, L::lanes(sum), L::LANES);
                }
            }
        }
    }
}
