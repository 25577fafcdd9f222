//! The floor of the course models' pair passes: their arithmetic alone, on the lanes of a
//! SIMD kernel, over pairs packed beforehand ([`PackedPairs`]: each pair's offsets,
//! velocity differences and density terms in contiguous arrays, every lane a pair closer
//! than h), with no search, no gather and no scatter. What a pass over neighbour lists
//! costs beyond it is the price of finding and fetching its pairs (`perf/README.md`'s
//! roofline table; `benches/pairs.rs` times both).

use super::simd::{Lanes, Transfer};
use super::{F64x4, F64x8, Kernel, MixedF32x8};
use crate::sim::isa::{Gathers, InstructionSet, OnInstructionSet};
use crate::sim::lists::NeighbourLists;
use crate::sim::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::sim::particles::{AxisArrays, Particles};
use wide::f64x8;

/// The listed pairs closer than h of a placement, packed pair after pair, then a group of
/// pairs far apart (so that loads of a last, partial group stay in the arrays and count
/// nothing).
#[derive(Debug, Clone, Default)]
pub struct PackedPairs {
    /// First particle's position less the partner's.
    d: AxisArrays,
    /// The partner's velocity less the first particle's.
    dv: AxisArrays,
    /// The sum of both densities less twice the rest density.
    excess: Vec<f64>,
    /// The product of both densities' reciprocals.
    inverse_product: Vec<f64>,
    /// The pairs.
    pairs: usize,
}

/// Loads of the last group read this far past the pairs.
const PAD: usize = 8;

impl PackedPairs {
    /// The pairs of `lists` closer than `params.h` at the state of `particles` (in the
    /// slots the lists were built on, densities computed).
    pub fn new(params: &Params, lists: &NeighbourLists, particles: &Particles) -> Self {
        let mut packed = PackedPairs::default();
        for i in 0..lists.slots() {
            for &j in lists.partners(i) {
                let j = j as usize;
                let d: [f64; 3] = std::array::from_fn(|a| particles.p[a][i] - particles.p[a][j]);
                if d.iter().map(|d| d * d).sum::<f64>() >= params.h2 {
                    continue;
                }
                for (axis, d) in d.into_iter().enumerate() {
                    packed.d[axis].push(d);
                    let v = &particles.v[axis];
                    packed.dv[axis].push(v[j] - v[i]);
                }
                let rho = &particles.rho;
                packed.excess.push(rho[i] + rho[j] - 2.0 * FLUID_DENSITY);
                packed.inverse_product.push(1.0 / rho[i] * (1.0 / rho[j]));
            }
        }
        packed.pairs = packed.excess.len();
        for axis in 0..3 {
            packed.d[axis].extend([1e100; PAD]);
            packed.dv[axis].extend([0.0; PAD]);
        }
        packed.excess.extend([0.0; PAD]);
        packed.inverse_product.extend([0.0; PAD]);
        packed
    }

    /// The pairs packed.
    pub fn len(&self) -> usize {
        self.pairs
    }

    /// Whether no pair is packed.
    pub fn is_empty(&self) -> bool {
        self.pairs == 0
    }

    /// The sum of every pair's density term (h^2 - r^2)^3 on the lanes of `kernel` (a
    /// SIMD kernel).
    ///
    /// # Panics
    /// If `kernel` has no lanes (scalar, reference).
    pub fn density_floor(&self, kernel: Kernel, params: &Params) -> f64 {
        match kernel {
            Kernel::Simd => self.densities::<F64x4>(params),
            Kernel::Simd8 => self.densities::<F64x8>(params),
            Kernel::Mixed => self.densities::<MixedF32x8>(params),
            _ => panic!("the floor is of the SIMD kernels"),
        }
    }

    /// The sum of every pair's acceleration terms (fluidanimate's with `FLUIDANIMATE`)
    /// on the lanes of `kernel` (a SIMD kernel).
    ///
    /// # Panics
    /// If `kernel` has no lanes (scalar, reference).
    pub fn acceleration_floor<const FLUIDANIMATE: bool>(
        &self,
        kernel: Kernel,
        params: &Params,
    ) -> [f64; 3] {
        match kernel {
            Kernel::Simd => self.accelerations::<F64x4, FLUIDANIMATE>(params),
            Kernel::Simd8 => self.accelerations::<F64x8, FLUIDANIMATE>(params),
            Kernel::Mixed => self.accelerations::<MixedF32x8, FLUIDANIMATE>(params),
            _ => panic!("the floor is of the SIMD kernels"),
        }
    }

    /// The sum of every pair's fluidanimate acceleration terms on 8 f64 lanes with 1/r
    /// from `isa`'s [`Gathers::reciprocal_sqrt8`] (without a divider on AVX-512) instead
    /// of a square root and a division: what a divider-free 1/r would save the floor.
    pub fn acceleration_floor_without_divider(
        &self,
        params: &Params,
        isa: InstructionSet,
    ) -> [f64; 3] {
        isa.run(WithoutDivider {
            pairs: self,
            params,
        })
    }

    /// The lanes of `values` from pair `k`.
    #[inline(always)]
    fn load<L: Lanes>(values: &[f64], k: usize) -> L::V {
        assert!(k + L::LANES <= values.len());
        // SAFETY: the lanes k..k + LANES are within `values` (checked above).
        unsafe { L::load(values, k) }
    }

    fn densities<L: Lanes>(&self, params: &Params) -> f64 {
        let h2 = L::splat(params.h2);
        let mut sum = L::ZERO_SUM;
        for k in (0..self.pairs).step_by(L::LANES) {
            // Explicit loads, not an array map: the map's closure is not always inlined.
            let dx = Self::load::<L>(&self.d[0], k);
            let dy = Self::load::<L>(&self.d[1], k);
            let dz = Self::load::<L>(&self.d[2], k);
            let r2 = dx * dx + dy * dy + dz * dz;
            let q = h2 - r2;
            let t = (q * q * q) & L::lt(r2, h2);
            L::accumulate(&mut sum, t);
        }
        L::total(sum)
    }

    fn accelerations<L: Lanes, const FLUIDANIMATE: bool>(&self, params: &Params) -> [f64; 3] {
        let transfer = Transfer::<L, FLUIDANIMATE>::new(params, [&[]; 3], [&[]; 3], &[], &[]);
        let mut sum = [L::ZERO_SUM; 3];
        for k in (0..self.pairs).step_by(L::LANES) {
            let load = |values: &[f64]| Self::load::<L>(values, k);
            let d = [load(&self.d[0]), load(&self.d[1]), load(&self.d[2])];
            let dv = [load(&self.dv[0]), load(&self.dv[1]), load(&self.dv[2])];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let close = L::lt(r2, transfer.h2());
            let (excess, inverse_product) = (load(&self.excess), load(&self.inverse_product));
            let terms = transfer.terms(d, r2, close, excess, inverse_product, dv);
            for (sum, terms) in sum.iter_mut().zip(terms) {
                L::accumulate(sum, terms);
            }
        }
        [L::total(sum[0]), L::total(sum[1]), L::total(sum[2])]
    }
}

/// The acceleration floor on one instruction set's 1/r.
struct WithoutDivider<'a> {
    pairs: &'a PackedPairs,
    params: &'a Params,
}

impl OnInstructionSet for WithoutDivider<'_> {
    type Output = [f64; 3];

    fn run<G: Gathers>(self, isa: G) -> [f64; 3] {
        type L = F64x8;
        let WithoutDivider { pairs, params } = self;
        let transfer = Transfer::<L, true>::new(params, [&[]; 3], [&[]; 3], &[], &[]);
        let least = f64x8::splat(MIN_DISTANCE_SQUARED);
        let mut sum = [L::ZERO_SUM; 3];
        for k in (0..pairs.pairs).step_by(L::LANES) {
            let load = |values: &[f64]| PackedPairs::load::<L>(values, k);
            let d = [load(&pairs.d[0]), load(&pairs.d[1]), load(&pairs.d[2])];
            let dv = [load(&pairs.dv[0]), load(&pairs.dv[1]), load(&pairs.dv[2])];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let close = L::lt(r2, transfer.h2());
            let over_dist = f64x8::from(isa.reciprocal_sqrt8(r2.max(least).to_array()));
            let (excess, inverse_product) = (load(&pairs.excess), load(&pairs.inverse_product));
            let terms = transfer.terms_over(d, r2, over_dist, close, excess, inverse_product, dv);
            for (sum, terms) in sum.iter_mut().zip(terms) {
                L::accumulate(sum, terms);
            }
        }
        [L::total(sum[0]), L::total(sum[1]), L::total(sum[2])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::jittered_block;
    use crate::sim::neighbours::TileSearch;

    #[test]
    fn the_floor_sums_the_terms_of_the_scalar_kernel() {
        // A jittered lattice with densities about the rest density and small velocities:
        // the floor's sums against the pairs' terms summed one by one.
        let ppm = 200.0;
        let params = Params::new(ppm);
        let (mut placed, cells, _) = jittered_block(ppm, 9, 0.3, 3);
        let mut random = fastrand::Rng::with_seed(3);
        for slot in 0..placed.len() {
            for axis in 0..3 {
                placed.v[axis][slot] = random.f64() - 0.5;
            }
            placed.rho[slot] = FLUID_DENSITY * (1.0 + 0.1 * random.f64());
        }
        let mut search = TileSearch::default();
        search.find(cells.keys(), cells.layout());
        let mut lists = NeighbourLists::default();
        lists
            .build(search.tiles(), &placed.p, placed.len(), params.h)
            .expect("a block's lists");
        let packed = PackedPairs::new(&params, &lists, &placed);
        assert!(packed.len() > 5 * placed.len());
        let (mut density, mut acceleration, mut magnitude) = (0.0, [0.0; 3], [0.0; 3]);
        for k in 0..packed.len() {
            let d = [0, 1, 2].map(|a| packed.d[a][k]);
            let r2: f64 = d.iter().map(|d| d * d).sum();
            density += (params.h2 - r2).powi(3);
            let dist = r2.max(1e-12).sqrt();
            let q = params.h - dist;
            let pressure = params.pressure_factor * q * q / dist * packed.excess[k];
            for axis in 0..3 {
                let viscosity = packed.dv[axis][k] * params.viscosity_factor * q;
                let term = (d[axis] * pressure + viscosity) * packed.inverse_product[k];
                acceleration[axis] += term;
                magnitude[axis] += term.abs();
            }
        }
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let floor = packed.acceleration_floor_without_divider(&params, isa);
            for axis in 0..3 {
                let error = (floor[axis] - acceleration[axis]).abs();
                let bound = 1e-12 * magnitude[axis];
                assert!(error <= bound, "{} axis {axis}: {error}", isa.name());
            }
        }
        for kernel in [Kernel::Simd, Kernel::Simd8, Kernel::Mixed] {
            let tolerance = if kernel == Kernel::Mixed { 1e-5 } else { 1e-12 };
            let floor = packed.density_floor(kernel, &params);
            assert!((floor - density).abs() <= tolerance * density, "{kernel:?}");
            let floor = packed.acceleration_floor::<true>(kernel, &params);
            for axis in 0..3 {
                let error = (floor[axis] - acceleration[axis]).abs();
                let bound = tolerance * magnitude[axis];
                assert!(error <= bound, "{kernel:?} axis {axis}: {error}");
            }
        }
    }
}
