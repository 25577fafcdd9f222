//! The density and acceleration stages 3-5, whose pair loops are the hot part of a time
//! step, over the tiles of the neighbour search. Four f64 implementations compute the
//! same pair terms. [`Kernel::Scalar`] (one pair at a time, the plain path), [`Kernel::Simd`]
//! and [`Kernel::Simd8`] (four or eight partners at a time in `f64x4` or `f64x8` lanes,
//! one generic loop) differ only in the order in which terms are summed, which the
//! reference outputs do not depend on (SPEC.md section 5). [`Kernel::Reference`] sums each
//! particle's terms in id order with compensated summation, for accuracy measurements.
//! A fifth, [`Kernel::Mixed`], runs the SIMD loop with each pair's terms in f32 lanes
//! (differences and sums in f64): less exact (within 5e-7 relative on a dense step), a
//! workbench method.
//!
//! The density loop also records where the pairs closer than h are ([`ClosePairs`]): the
//! acceleration loop, over the same positions, visits only those tiles and, on the SIMD
//! kernels, only those groups of partners (a lane-width each), without testing the others
//! again.

mod reference;
mod scalar;
mod simd;
mod wcsph;

use simd::{F64x4, F64x8, Lanes, MixedF32x8};
pub use wcsph::{Rates, State};

use crate::sim::method::Kernel;
use crate::sim::neighbours::Tile;
use crate::sim::params::Params;
use crate::sim::particles::AxisArrays;
use crate::sim::wcsph::Wcsph;

/// The viscosity of the two models that share the course's pair loops.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Viscosity {
    /// SPEC.md's: `(v_j - v_i) * 45/(pi h^6) * mu * m`.
    Course,
    /// fluidanimate's: the course's times `(h - dist)`.
    Fluidanimate,
}

/// The last group bit of [`ClosePairs::groups`], which stands for every group from it on.
const OVERFLOW_GROUP: usize = 63;

/// Where the density loop found pairs closer than h.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ClosePairs {
    /// The tiles holding at least one such pair, in the order the loop visited them.
    pub tiles: Vec<Tile>,
    /// On the SIMD kernels (empty on the others), in the order the loop visits them:
    /// cell by cell (a cell's tiles are consecutive and share their first slots), first
    /// slot by first slot, tile by tile: bit k set if partners kL..(k+1)L (of
    /// [`Tile::partners`], L the kernel's lanes) hold such a pair; bit 63 stands for every
    /// group from the 63rd on. The SIMD kernels keep all tiles of a cell with any such pair.
    pub groups: Vec<u64>,
}

impl ClosePairs {
    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        crate::sim::heap_bytes(&self.tiles) + crate::sim::heap_bytes(&self.groups)
    }

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
        Kernel::Simd => simd::increment_densities::<F64x4>(params, tiles, p, rho, close),
        Kernel::Simd8 => simd::increment_densities::<F64x8>(params, tiles, p, rho, close),
        Kernel::Mixed => simd::increment_densities::<MixedF32x8>(params, tiles, p, rho, close),
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
    viscosity: Viscosity,
    params: &Params,
    candidates: Candidates,
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    id: &[u32],
    a: &mut AxisArrays,
) {
    match (kernel, viscosity) {
        (Kernel::Scalar, Viscosity::Course) => {
            scalar::transfer_accelerations::<false>(params, candidates.tiles(), p, v, rho, a)
        }
        (Kernel::Scalar, Viscosity::Fluidanimate) => {
            scalar::transfer_accelerations::<true>(params, candidates.tiles(), p, v, rho, a)
        }
        (Kernel::Simd, _) => lanes_transfer::<F64x4>(viscosity, params, candidates, p, v, rho, a),
        (Kernel::Simd8, _) => lanes_transfer::<F64x8>(viscosity, params, candidates, p, v, rho, a),
        (Kernel::Mixed, _) => {
            lanes_transfer::<MixedF32x8>(viscosity, params, candidates, p, v, rho, a)
        }
        (Kernel::Reference, Viscosity::Course) => {
            let tiles = candidates.tiles();
            reference::transfer_accelerations::<false>(params, tiles, p, v, rho, id, a)
        }
        (Kernel::Reference, Viscosity::Fluidanimate) => {
            let tiles = candidates.tiles();
            reference::transfer_accelerations::<true>(params, tiles, p, v, rho, id, a)
        }
    }
}

/// Stage 5 of a SIMD kernel on lanes `L`, with `viscosity`.
fn lanes_transfer<L: Lanes>(
    viscosity: Viscosity,
    params: &Params,
    candidates: Candidates,
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    a: &mut AxisArrays,
) {
    match viscosity {
        Viscosity::Course => {
            simd::transfer_accelerations::<L, false>(params, candidates, p, v, rho, a)
        }
        Viscosity::Fluidanimate => {
            simd::transfer_accelerations::<L, true>(params, candidates, p, v, rho, a)
        }
    }
}

/// The weakly compressible model's pair loop: adds every pair's (and wall image's)
/// acceleration and density rates to `rates`, over the tiles. `id` (each slot's
/// particle) orders the reference kernel's sums.
pub fn interact_weakly_compressible(
    kernel: Kernel,
    model: &Wcsph,
    tiles: &[Tile],
    state: State,
    id: &[u32],
    rates: &mut Rates,
) {
    let n = id.len();
    match kernel {
        Kernel::Scalar => wcsph::scalar(model, tiles, state, n, rates),
        Kernel::Simd => wcsph::lanes::<F64x4>(model, tiles, state, n, rates),
        Kernel::Simd8 => wcsph::lanes::<F64x8>(model, tiles, state, n, rates),
        Kernel::Mixed => wcsph::lanes::<MixedF32x8>(model, tiles, state, n, rates),
        Kernel::Reference => wcsph::reference(model, tiles, state, id, n, rates),
    }
}

#[cfg(test)]
mod tests {
    use crate::sim::method::{Kernel, Method, Model};
    use crate::sim::params::BOX_MIN;
    use crate::sim::particles::Particles;
    use crate::sim::simulation::Simulation;
    use crate::sim::stages::Stage;

    /// A jittered lattice of 20 x 20 x 20 particles one spacing (1 / ppm) apart in the
    /// box's lower corner, with small random velocities.
    fn dense_block(ppm: f64) -> Particles {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut particles = Particles::zeroed(20 * 20 * 20);
        for slot in 0..particles.len() {
            let lattice = [slot % 20, slot / 20 % 20, slot / 400];
            for axis in 0..3 {
                let offset = (lattice[axis] as f64 + 1.0 + 0.2 * next()) / ppm;
                particles.p[axis][slot] = BOX_MIN[axis] + offset;
                particles.v[axis][slot] = 0.2 * next();
            }
        }
        particles
    }

    #[test]
    fn mixed_precision_stays_within_1e_5_of_the_f64_kernels_on_a_dense_step() {
        let ppm = 292.0;
        // The weakly compressible model's kernels are compared in `wcsph`'s tests.
        for model in [Model::Course, Model::Fluidanimate] {
            let pair_stages = |kernel| {
                let method = Method { model, kernel };
                let mut sim = Simulation::with_method(ppm, dense_block(ppm), method).unwrap();
                for stage in [
                    Stage::IncrementDensities,
                    Stage::TransformDensities,
                    Stage::TransferAccelerations,
                ] {
                    sim.run_stage(stage);
                }
                sim.particles().clone()
            };
            let mixed = pair_stages(Kernel::Mixed);
            for kernel in [Kernel::Simd, Kernel::Simd8, Kernel::Scalar] {
                let exact = pair_stages(kernel);
                let n = exact.len();
                let density_error = (0..n)
                    .map(|s| (mixed.rho[s] - exact.rho[s]).abs() / exact.rho[s])
                    .fold(0.0, f64::max);
                let largest = (0..n)
                    .map(|s| exact.acceleration(s).length())
                    .fold(0.0, f64::max);
                let acceleration_error = (0..n)
                    .map(|s| (mixed.acceleration(s) - exact.acceleration(s)).length() / largest)
                    .fold(0.0, f64::max);
                println!("{model:?} vs {kernel:?}: {density_error:.2e} {acceleration_error:.2e}");
                assert!(
                    density_error < 1e-5 && density_error > 0.0,
                    "{density_error}"
                );
                assert!(acceleration_error < 1e-5 && acceleration_error > 0.0);
            }
        }
    }
}
