//! The course models' SIMD pair loops over [`NeighbourLists`]: each particle against its
//! listed partners, a register of lanes at a time, every lane but the list's last group's
//! a pair (closer than h, or within the skin where lists are kept over steps).
//!
//! What a pass reads of a partner is packed by slot into [`Record`]s of 4 f64 once per
//! pass (positions with the density, velocities with the density's reciprocal), so that
//! a partner's fields come from 32 contiguous bytes ([`Lanes::records`]); the partners' sums
//! are added one partner after the other (a masked lane may repeat a slot, and adds
//! zero): the density's to the positions' spare field, then to the densities, the
//! accelerations to the particles' arrays. Each particle's own sums stay in registers
//! (Newton's third law: a half list holds each pair once).

use super::simd::{Lanes, Transfer};
use super::{Accelerations, Densities, Packed};
use crate::sim::isa::{Gathers, OnInstructionSet, Record, Slots};
use crate::sim::lists::NeighbourLists;
use crate::sim::params::FLUID_DENSITY;
use std::marker::PhantomData;

/// The slots of the group of `lists`' entries from `k`, and the mask of its lanes before
/// `end` (the list's end).
#[inline(always)]
fn group<L: Lanes>(lists: &NeighbourLists, k: usize, end: usize) -> (Slots, L::V) {
    let entries = lists.entries();
    let at: [u32; 8] = entries[k..k + 8].try_into().expect("8 entries");
    let lanes = if k + L::LANES <= end {
        L::all()
    } else {
        L::first(end - k)
    };
    (Slots::new(at, lists.slots()), lanes)
}

/// `center - ` each of the first three fields of `fields`, in the lanes of the terms.
#[inline(always)]
fn offsets<L: Lanes>(center: &Record, fields: &[L::F64; 4]) -> [L::V; 3] {
    let offset = |axis: usize| L::narrowed(L::splat_f64(center[axis]) - fields[axis]);
    [offset(0), offset(1), offset(2)]
}

/// Fills `records` with the record `of(slot)` of each of the `n` first slots.
fn pack(records: &mut Vec<Record>, n: usize, of: impl Fn(usize) -> Record) {
    records.clear();
    records.extend((0..n).map(of));
}

/// Stage 3 over `lists`.
pub(super) fn increment_densities<L: Lanes>(pass: Densities, lists: &NeighbourLists) {
    lists.instruction_set().run(DensityLoop::<L> {
        pass,
        lists,
        lanes: PhantomData,
    });
}

/// The density loop on lanes `L`.
struct DensityLoop<'a, L> {
    pass: Densities<'a>,
    lists: &'a NeighbourLists,
    lanes: PhantomData<L>,
}

impl<L: Lanes> OnInstructionSet for DensityLoop<'_, L> {
    type Output = ();

    fn run<G: Gathers>(self, isa: G) {
        let DensityLoop { pass, lists, .. } = self;
        let Densities {
            params,
            p,
            rho,
            packed,
            ..
        } = pass;
        let n = lists.slots();
        // Positions, and the partners' density sums in the last field.
        let records = &mut packed.records;
        let [x, y, z] = p;
        pack(records, n, |i| [x[i], y[i], z[i], 0.0]);
        let h2 = L::splat(params.h2);
        for i in 0..n {
            let range = lists.range(i);
            let mut sum = L::ZERO_SUM;
            let center = records[i];
            for k in range.clone().step_by(L::LANES) {
                let (at, lanes) = group::<L>(lists, k, range.end);
                let fields = L::records(isa, records, &at);
                let [dx, dy, dz] = offsets::<L>(&center, &fields);
                let r2 = dx * dx + dy * dy + dz * dz;
                let close = L::lt(r2, h2) & lanes;
                let q = h2 - r2;
                let t = (q * q * q) & close;
                L::accumulate(&mut sum, t);
                L::add_to_field(records, &at, 3, t);
            }
            rho[i] += L::total(sum);
        }
        for (rho, record) in rho.iter_mut().zip(records.iter()) {
            *rho += record[3];
        }
    }
}

/// Stage 5 over `lists`.
pub(super) fn transfer_accelerations<L: Lanes, const FLUIDANIMATE: bool>(
    pass: Accelerations<FLUIDANIMATE>,
    lists: &NeighbourLists,
) {
    lists
        .instruction_set()
        .run(AccelerationLoop::<L, FLUIDANIMATE> {
            pass,
            lists,
            lanes: PhantomData,
        });
}

/// The acceleration loop on lanes `L`.
struct AccelerationLoop<'a, L, const FLUIDANIMATE: bool> {
    pass: Accelerations<'a, FLUIDANIMATE>,
    lists: &'a NeighbourLists,
    lanes: PhantomData<L>,
}

impl<L: Lanes, const FLUIDANIMATE: bool> OnInstructionSet
    for AccelerationLoop<'_, L, FLUIDANIMATE>
{
    type Output = ();

    fn run<G: Gathers>(self, isa: G) {
        let AccelerationLoop { pass, lists, .. } = self;
        let Accelerations {
            params,
            p,
            v,
            rho,
            a,
            packed,
            ..
        } = pass;
        let n = lists.slots();
        let Packed {
            records: positions,
            velocities,
            ..
        } = packed;
        let ([x, y, z], [vx, vy, vz]) = (p, v);
        pack(positions, n, |i| [x[i], y[i], z[i], rho[i]]);
        pack(velocities, n, |i| [vx[i], vy[i], vz[i], 1.0 / rho[i]]);
        // The partners' terms are subtracted from `a` at their slots, lane after lane.
        assert!(a.iter().all(|a| a.len() >= n));
        let transfer = Transfer::<L, FLUIDANIMATE>::new(params, [&[]; 3], [&[]; 3], &[], &[]);
        let twice_rest_density = L::splat_f64(2.0 * FLUID_DENSITY);
        for i in 0..n {
            let range = lists.range(i);
            let (position, velocity) = (positions[i], velocities[i]);
            let inverse_rho_i = L::splat(velocity[3]);
            let mut sum = [L::ZERO_SUM; 3];
            for k in range.clone().step_by(L::LANES) {
                let (at, lanes) = group::<L>(lists, k, range.end);
                let p_j = L::records(isa, positions, &at);
                let d = offsets::<L>(&position, &p_j);
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let close = L::lt(r2, transfer.h2()) & lanes;
                let excess = L::narrowed(L::splat_f64(position[3]) + p_j[3] - twice_rest_density);
                let v_j = L::records(isa, velocities, &at);
                let per_density_product = inverse_rho_i * L::narrowed(v_j[3]);
                let difference =
                    |axis: usize| L::narrowed(v_j[axis] - L::splat_f64(velocity[axis]));
                let dv = [difference(0), difference(1), difference(2)];
                let terms = transfer.terms(d, r2, close, excess, per_density_product, dv);
                for (axis, terms) in terms.into_iter().enumerate() {
                    L::accumulate(&mut sum[axis], terms);
                }
                for (a, terms) in a.iter_mut().zip(terms) {
                    // SAFETY: every slot of `at` is below n (Slots::new), which `a`
                    // holds (asserted above).
                    unsafe { L::subtract_from(a, at, terms) };
                }
            }
            for (axis, sum) in sum.into_iter().enumerate() {
                a[axis][i] += L::total(sum);
            }
        }
    }
}
