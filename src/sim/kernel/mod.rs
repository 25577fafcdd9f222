//! The density and acceleration stages 3-5, whose pair loops are the hot part of a time
//! step, over the tiles of the neighbour search. Three implementations compute the same
//! pair terms. [`Kernel::Scalar`] (one pair at a time, the plain path) and
//! [`Kernel::Simd`] (four partners at a time in `f64x4` lanes) differ only in the order in
//! which terms are summed, which the reference outputs do not depend on (SPEC.md section
//! 5). [`Kernel::Reference`] sums each particle's terms in id order with compensated
//! summation, for accuracy measurements.
//!
//! The density loop also records where the pairs closer than h are ([`ClosePairs`]): the
//! acceleration loop, over the same positions, visits only those tiles and, on the SIMD
//! kernel, only those groups of four partners, without testing the others again.

mod reference;
mod scalar;
mod simd;

use crate::sim::method::{Kernel, Model};
use crate::sim::neighbours::Tile;
use crate::sim::params::Params;
use crate::sim::particles::AxisArrays;

/// The last group bit of [`ClosePairs::groups`], which stands for every group from it on.
const OVERFLOW_GROUP: usize = 63;

/// Where the density loop found pairs closer than h.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ClosePairs {
    /// The tiles holding at least one such pair, in the order the loop visited them.
    pub tiles: Vec<Tile>,
    /// On the SIMD kernel (empty on the scalar one), in the order the loop visits them:
    /// cell by cell (a cell's tiles are consecutive and share their first slots), first
    /// slot by first slot, tile by tile: bit k set if partners 4k..4k+4 (of
    /// [`Tile::partners`]) hold such a pair; bit 63 stands for every group from the 63rd
    /// on. The SIMD kernel keeps all tiles of a cell with any such pair.
    pub groups: Vec<u64>,
}

impl ClosePairs {
    fn clear(&mut self) {
        self.tiles.clear();
        self.groups.clear();
    }
}

/// The candidate pairs of the acceleration transfer.
#[derive(Debug, Clone, Copy)]
pub enum Candidates<'a> {
    /// Every pair of these tiles.
    All(&'a [Tile]),
    /// Where the density increment over the same positions found close pairs.
    Close(&'a ClosePairs),
}

impl Candidates<'_> {
    fn tiles(&self) -> &[Tile] {
        match self {
            Candidates::All(tiles) => tiles,
            Candidates::Close(close) => &close.tiles,
        }
    }
}

/// Stage 3: adds (h^2 - r^2)^3 to both raw density sums of every pair of `tiles` closer
/// than h, and records in `close` where such pairs are. `id` (each slot's particle)
/// orders the reference kernel's sums.
pub fn increment_densities(
    kernel: Kernel,
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    rho: &mut [f64],
    id: &[u32],
    close: &mut ClosePairs,
) {
    close.clear();
    match kernel {
        Kernel::Scalar => scalar::increment_densities(params, tiles, p, rho, &mut close.tiles),
        Kernel::Simd => simd::increment_densities(params, tiles, p, rho, close),
        Kernel::Reference => {
            reference::increment_densities(params, tiles, p, rho, id, &mut close.tiles)
        }
    }
}

/// Stage 4: rho = (rho + h^6) * 315 / (64 pi h^9) * m.
pub fn transform_densities(params: &Params, rho: &mut [f64]) {
    for rho in rho {
        *rho = (*rho + params.h6) * params.density_factor;
    }
}

/// Stage 5: the pressure and viscosity acceleration of every candidate pair closer than
/// h, added to the first particle and subtracted from the second (SPEC.md erratum 4).
#[allow(clippy::too_many_arguments)]
pub fn transfer_accelerations(
    kernel: Kernel,
    model: Model,
    params: &Params,
    candidates: Candidates,
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    id: &[u32],
    a: &mut AxisArrays,
) {
    match (kernel, model) {
        (Kernel::Scalar, Model::Course) => {
            scalar::transfer_accelerations::<false>(params, candidates.tiles(), p, v, rho, a)
        }
        (Kernel::Scalar, Model::Fluidanimate) => {
            scalar::transfer_accelerations::<true>(params, candidates.tiles(), p, v, rho, a)
        }
        (Kernel::Simd, Model::Course) => {
            simd::transfer_accelerations::<false>(params, candidates, p, v, rho, a)
        }
        (Kernel::Simd, Model::Fluidanimate) => {
            simd::transfer_accelerations::<true>(params, candidates, p, v, rho, a)
        }
        (Kernel::Reference, Model::Course) => {
            let tiles = candidates.tiles();
            reference::transfer_accelerations::<false>(params, tiles, p, v, rho, id, a)
        }
        (Kernel::Reference, Model::Fluidanimate) => {
            let tiles = candidates.tiles();
            reference::transfer_accelerations::<true>(params, tiles, p, v, rho, id, a)
        }
    }
}
