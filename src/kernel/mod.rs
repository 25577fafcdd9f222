//! The density and acceleration stages 3-5, whose pair loops are the hot part of a time
//! step, over the tiles of the neighbour search. Two implementations compute the same pair terms: [`Kernel::Scalar`]
//! (one pair at a time, the reference path) and [`Kernel::Simd`] (four partners at a
//! time in `f64x4` lanes). They differ only in the order in which terms are summed, which
//! the reference outputs do not depend on (SPEC.md section 5).
//!
//! The density loop also returns the tiles that hold at least one pair closer than h; the
//! acceleration loop, over the same positions, needs only those.

mod scalar;
mod simd;

use crate::method::{Kernel, Model};
use crate::neighbours::Tile;
use crate::params::Params;
use crate::particles::AxisArrays;

/// Stage 3: adds (h^2 - r^2)^3 to both raw density sums of every pair of `tiles` closer
/// than h, and collects in `close_tiles` the tiles where that happened.
pub fn increment_densities(
    kernel: Kernel,
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    rho: &mut [f64],
    close_tiles: &mut Vec<Tile>,
) {
    close_tiles.clear();
    match kernel {
        Kernel::Scalar => scalar::increment_densities(params, tiles, p, rho, close_tiles),
        Kernel::Simd => simd::increment_densities(params, tiles, p, rho, close_tiles),
    }
}

/// Stage 4: rho = (rho + h^6) * 315 / (64 pi h^9) * m.
pub fn transform_densities(params: &Params, rho: &mut [f64]) {
    for rho in rho {
        *rho = (*rho + params.h6) * params.density_factor;
    }
}

/// Stage 5: the pressure and viscosity acceleration of every pair of `tiles` closer than
/// h, added to the first particle and subtracted from the second (SPEC.md erratum 4).
#[allow(clippy::too_many_arguments)]
pub fn transfer_accelerations(
    kernel: Kernel,
    model: Model,
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    a: &mut AxisArrays,
) {
    match (kernel, model) {
        (Kernel::Scalar, Model::Course) => {
            scalar::transfer_accelerations::<false>(params, tiles, p, v, rho, a)
        }
        (Kernel::Scalar, Model::Fluidanimate) => {
            scalar::transfer_accelerations::<true>(params, tiles, p, v, rho, a)
        }
        (Kernel::Simd, Model::Course) => {
            simd::transfer_accelerations::<false>(params, tiles, p, v, rho, a)
        }
        (Kernel::Simd, Model::Fluidanimate) => {
            simd::transfer_accelerations::<true>(params, tiles, p, v, rho, a)
        }
    }
}
