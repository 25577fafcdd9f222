//! The reference trajectory's pair loops: each particle's density and acceleration summed
//! on their own, over its partners closer than h taken in id order, with Neumaier's
//! compensated summation. The sums then depend neither on the cell order nor on the
//! order of the tiles, and carry about one rounding error each instead of one per term.
//! About ten times slower than the scalar kernel; for accuracy measurements only.

use super::scalar::pair_acceleration;
use super::{Accelerations, Densities};
use crate::sim::neighbours::Tile;
use crate::sim::particles::{vector_at, AxisArrays};

/// A compensated sum (Neumaier's variant of Kahan's): the running sum and the rounding
/// errors it lost, added back at the end.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Neumaier {
    sum: f64,
    lost: f64,
}

impl Neumaier {
    pub(crate) fn new(start: f64) -> Self {
        Neumaier {
            sum: start,
            lost: 0.0,
        }
    }

    pub(crate) fn add(&mut self, term: f64) {
        let sum = self.sum + term;
        self.lost += if self.sum.abs() >= term.abs() {
            (self.sum - sum) + term
        } else {
            (term - sum) + self.sum
        };
        self.sum = sum;
    }

    pub(crate) fn total(self) -> f64 {
        self.sum + self.lost
    }
}

/// Each slot's partners closer than h among the pairs of `tiles`, in id order; the tiles
/// holding such a pair are added to `hits`.
fn close_partners(
    tiles: &[Tile],
    p: &AxisArrays,
    h2: f64,
    id: &[u32],
    hits: &mut Vec<Tile>,
) -> Vec<Vec<u32>> {
    let mut partners = vec![Vec::new(); id.len()];
    for tile in tiles {
        let mut hit = false;
        for i in tile.firsts() {
            for j in tile.partners(i) {
                if (vector_at(p, i) - vector_at(p, j)).length_squared() < h2 {
                    partners[i].push(j as u32);
                    partners[j].push(i as u32);
                    hit = true;
                }
            }
        }
        if hit {
            hits.push(*tile);
        }
    }
    for list in &mut partners {
        list.sort_unstable_by_key(|&j| id[j as usize]);
    }
    partners
}

/// Stage 3, each particle's sum on its own.
pub(super) fn increment_densities(pass: Densities) {
    let Densities {
        params,
        tiles,
        p,
        id,
        rho,
        close,
        ..
    } = pass;
    let h2 = params.h2;
    let partners = close_partners(tiles, p, h2, id, &mut close.tiles);
    for (i, list) in partners.iter().enumerate() {
        let mut sum = Neumaier::new(rho[i]);
        for &j in list {
            let r2 = (vector_at(p, i) - vector_at(p, j as usize)).length_squared();
            let q = h2 - r2;
            sum.add(q * q * q);
        }
        rho[i] = sum.total();
    }
}

/// Stage 5, each particle's sums on their own.
pub(super) fn transfer_accelerations<const FLUIDANIMATE: bool>(pass: Accelerations<FLUIDANIMATE>) {
    let Accelerations {
        params,
        candidates,
        p,
        v,
        rho,
        id,
        a,
        ..
    } = pass;
    let partners = close_partners(candidates.tiles(), p, params.h2, id, &mut Vec::new());
    for (i, list) in partners.iter().enumerate() {
        let mut sums = [0, 1, 2].map(|axis| Neumaier::new(a[axis][i]));
        for &j in list {
            let j = j as usize;
            // The scalar kernel's terms, in the same operations.
            let offset = vector_at(p, i) - vector_at(p, j);
            let velocities = [vector_at(v, i), vector_at(v, j)];
            let da = pair_acceleration::<FLUIDANIMATE>(
                params,
                offset,
                offset.length_squared(),
                velocities,
                [rho[i], rho[j]],
            );
            for (sum, term) in sums.iter_mut().zip(da.to_array()) {
                sum.add(term);
            }
        }
        for (axis, sum) in a.iter_mut().zip(sums) {
            axis[i] = sum.total();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compensated_sums_keep_what_plain_sums_lose() {
        // 1 + 1e-16 ten thousand times: plain f64 stays at 1.
        let mut sum = Neumaier::new(1.0);
        let mut plain = 1.0;
        for _ in 0..10_000 {
            sum.add(1e-16);
            plain += 1e-16;
        }
        assert_eq!(plain, 1.0);
        assert!((sum.total() - (1.0 + 1e-12)).abs() < 1e-24 + f64::EPSILON * 1e-12);
        // Large terms that cancel: Neumaier keeps the small ones around them.
        let mut sum = Neumaier::new(0.0);
        for term in [1.0, 1e100, 1.0, -1e100] {
            sum.add(term);
        }
        assert_eq!(sum.total(), 2.0);
    }
}
