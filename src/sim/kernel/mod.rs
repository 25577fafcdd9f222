//! The pair loops, the hot part of a time step, over the neighbour structures (the tiles
//! of the neighbour search; on dense scenes, the SIMD loops over the neighbour lists):
//! each model's pair terms are passes ([`PairPass`]: the course models' density and
//! acceleration stages 3-5, [`Densities`] and [`Accelerations`], and the weakly
//! compressible model's [`WeaklyCompressible`]), and [`Kernel::run`] maps a kernel to its
//! loop. Four f64 implementations compute the same pair terms. [`Kernel::Scalar`] (one
//! pair at a time, the plain path), [`Kernel::Simd`] and [`Kernel::Simd8`] (four or
//! eight partners at a time in `f64x4` or `f64x8` lanes, one generic loop) differ in the
//! order in which terms are summed and, in the SIMD acceleration loops, in multiplying
//! by the densities' reciprocals rather than dividing by their product: the reference
//! outputs depend on neither (SPEC.md section 5; every one holds byte for byte). [`Kernel::Reference`] sums each
//! particle's terms in id order with compensated summation, for accuracy measurements.
//! A fifth, [`Kernel::Mixed`], computes the pair terms in f32 lanes, the SIMD loops with
//! each pair's differences taken in f64 and narrowed; sums by particle in f64. Less exact
//! (within 5e-7 relative on a dense step), a workbench method.
//!
//! On tiles the density loop also records where the pairs closer than h are
//! ([`ClosePairs`]): the acceleration loop, over the same positions, visits only those
//! tiles and, on the SIMD kernels, only those groups of partners (a lane-width each),
//! without testing the others again. The lists hold only such pairs already (within the
//! skin, where kept).

mod across;
pub mod floor;
mod listed;
mod reference;
mod scalar;
mod simd;
mod wcsph;

pub(crate) use simd::Lanes;
use simd::{F64x4, F64x8, MixedF32x8};
pub use wcsph::{periodic_pairs, NearWalls, Rates, State, WcsphConstants, WeaklyCompressible};

use crate::sim::isa::Record;
use crate::sim::lists::NeighbourLists;
use crate::sim::neighbours::Tile;
use crate::sim::params::Params;
use crate::sim::particles::AxisArrays;

/// The implementation of the pair loops (density increment, acceleration transfer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Kernel {
    /// One pair at a time in plain f64: the reference path.
    Scalar,
    /// Four partners at a time in `wide::f64x4` lanes, with masks for the cut-off and the
    /// tail lanes.
    Simd,
    /// As the simd kernel, eight partners at a time in `wide::f64x8` lanes (one AVX-512
    /// register; two AVX2 registers elsewhere).
    Simd8,
    /// Mixed precision: the pair terms in f32 lanes, the sums by particle in f64: eight
    /// partners (or particles) at a time, each pair's differences computed in f64 and
    /// narrowed. Not held to the reference outputs (within 5e-7 relative on a dense step);
    /// a workbench method.
    Mixed,
    /// Each particle's sums on their own, over its partners in id order, with compensated
    /// (Neumaier) summation: the reference trajectory for accuracy measurements (slow).
    Reference,
}

impl Kernel {
    /// Every kernel, in a fixed order.
    pub const ALL: [Kernel; 5] = [
        Kernel::Scalar,
        Kernel::Simd,
        Kernel::Simd8,
        Kernel::Mixed,
        Kernel::Reference,
    ];

    /// The kernels that compute in f64 throughout, held to the reference outputs.
    pub const F64: [Kernel; 4] = [
        Kernel::Scalar,
        Kernel::Simd,
        Kernel::Simd8,
        Kernel::Reference,
    ];

    /// The kernels meant for speed (the reference is meant for accuracy).
    pub const FAST: [Kernel; 4] = [Kernel::Scalar, Kernel::Simd, Kernel::Simd8, Kernel::Mixed];

    /// The fastest f64 kernel for the CPU the crate is built for: [`Kernel::Simd8`] where
    /// AVX-512 is enabled, [`Kernel::Simd`] otherwise. `fluid` runs it.
    pub const NATIVE: Kernel = if cfg!(target_feature = "avx512f") {
        Kernel::Simd8
    } else {
        Kernel::Simd
    };

    /// The kernel's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Simd => "simd",
            Kernel::Simd8 => "simd8",
            Kernel::Mixed => "mixed",
            Kernel::Reference => "reference",
        }
    }

    /// The pairs the kernel's loops evaluate at once: its lanes (1 for the scalar and
    /// reference kernels).
    pub fn lanes(self) -> usize {
        match self {
            Kernel::Scalar | Kernel::Reference => 1,
            Kernel::Simd => 4,
            Kernel::Simd8 | Kernel::Mixed => 8,
        }
    }

    /// Whether the kernel has loops on neighbour lists (the SIMD kernels; the others run
    /// on the tiles only).
    pub fn runs_on_lanes(self) -> bool {
        self.lanes() > 1
    }

    /// Runs `pass` with this kernel's loop: the one place a kernel is mapped to its loops
    /// (the lanes of each SIMD kernel included).
    pub(crate) fn run(self, pass: impl PairPass) {
        match self {
            Kernel::Scalar => pass.scalar(),
            Kernel::Simd => pass.lanes::<F64x4>(),
            Kernel::Simd8 => pass.lanes::<F64x8>(),
            Kernel::Mixed => pass.lanes::<MixedF32x8>(),
            Kernel::Reference => pass.reference(),
        }
    }
}

impl Default for Kernel {
    /// [`Kernel::NATIVE`].
    fn default() -> Self {
        Kernel::NATIVE
    }
}

/// A pass over the pairs of the tiles, as each family of kernels runs it: its inputs and
/// outputs are the implementing type's fields, so a loop takes the pass whole. A model's
/// pair terms are a pass ([`Densities`] and [`Accelerations`] for the course models,
/// [`WeaklyCompressible`]); [`Kernel::run`] picks the loop.
pub(crate) trait PairPass {
    /// One pair at a time, in plain f64.
    fn scalar(self);
    /// A lane-width of partners at a time, on lanes `L`.
    fn lanes<L: Lanes>(self);
    /// Each particle's terms on their own, in id order, with compensated sums.
    fn reference(self);
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

/// The copies the SIMD loops read (reused from step to step): over the lists, a record
/// per slot of what a pass reads of a partner; on the tiles, the densities' reciprocals.
#[derive(Debug, Clone, Default)]
pub struct Packed {
    /// The densities' reciprocals by slot, of the acceleration loops on the tiles.
    inverse_rho: Vec<f64>,
    /// A record per slot of what the pass reads of a partner: positions (and the
    /// densities or, in the density pass, the partners' sums).
    records: Vec<Record>,
    /// Velocities and the densities' reciprocals by slot.
    velocities: Vec<Record>,
}

impl Packed {
    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        crate::sim::heap_bytes(&self.inverse_rho)
            + crate::sim::heap_bytes(&self.records)
            + crate::sim::heap_bytes(&self.velocities)
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

impl<'a> Candidates<'a> {
    fn tiles(&self) -> &[Tile] {
        match self {
            Candidates::All(tiles) => tiles,
            Candidates::Close(close) => &close.tiles,
        }
    }
}

/// Stage 3: adds (h^2 - r^2)^3 to both raw density sums of every candidate pair (of
/// `tiles`, or of `lists` where given) closer than h, and records in `close` (cleared
/// first) where such pairs are.
#[derive(Debug)]
pub struct Densities<'a> {
    /// The derived parameters (h^2).
    pub params: &'a Params,
    /// The candidate pairs.
    pub tiles: &'a [Tile],
    /// The neighbour lists of the same placement, which the SIMD kernels run on where
    /// given.
    pub lists: Option<&'a NeighbourLists>,
    /// Positions.
    pub p: &'a AxisArrays,
    /// Each slot's particle: the order of the reference kernel's sums.
    pub id: &'a [u32],
    /// The raw density sums, added to.
    pub rho: &'a mut [f64],
    /// Where pairs closer than h are, for [`Candidates::Close`].
    pub close: &'a mut ClosePairs,
    /// The copies the loops over the lists read.
    pub packed: &'a mut Packed,
}

impl PairPass for Densities<'_> {
    fn scalar(self) {
        self.close.clear();
        scalar::increment_densities(self);
    }
    fn lanes<L: Lanes>(self) {
        self.close.clear();
        match self.lists {
            Some(lists) => match lists.rows() {
                Some(rows) => across::increment_densities::<L>(self, rows),
                None => listed::increment_densities::<L>(self, lists),
            },
            None => simd::increment_densities::<L>(self),
        }
    }
    fn reference(self) {
        self.close.clear();
        reference::increment_densities(self);
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
/// `FLUIDANIMATE` multiplies the viscosity term by (h - dist), as PARSEC's fluidanimate
/// does; without it the viscosity is SPEC.md's.
#[derive(Debug)]
pub struct Accelerations<'a, const FLUIDANIMATE: bool> {
    /// The derived parameters (h, the pressure and viscosity factors).
    pub params: &'a Params,
    /// The candidate pairs.
    pub candidates: Candidates<'a>,
    /// The neighbour lists of the same placement, which the SIMD kernels run on where
    /// given.
    pub lists: Option<&'a NeighbourLists>,
    /// Positions.
    pub p: &'a AxisArrays,
    /// Velocities.
    pub v: &'a AxisArrays,
    /// Densities.
    pub rho: &'a [f64],
    /// Each slot's particle: the order of the reference kernel's sums.
    pub id: &'a [u32],
    /// Accelerations, added to.
    pub a: &'a mut AxisArrays,
    /// The copies the loops over the lists read.
    pub packed: &'a mut Packed,
}

impl<const FLUIDANIMATE: bool> PairPass for Accelerations<'_, FLUIDANIMATE> {
    fn scalar(self) {
        scalar::transfer_accelerations(self);
    }
    fn lanes<L: Lanes>(self) {
        match self.lists {
            Some(lists) => match lists.rows() {
                Some(rows) => across::transfer_accelerations::<L, FLUIDANIMATE>(self, rows),
                None => listed::transfer_accelerations::<L, FLUIDANIMATE>(self, lists),
            },
            None => simd::transfer_accelerations::<L, FLUIDANIMATE>(self),
        }
    }
    fn reference(self) {
        reference::transfer_accelerations(self);
    }
}

#[cfg(test)]
mod tests {
    use crate::sim::kernel::Kernel;
    use crate::sim::lists::PairStructure;
    use crate::sim::method::Method;
    use crate::sim::model::Model;
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

    /// The largest relative error of `other`'s densities against `exact`'s, and of its
    /// accelerations relative to the largest of `exact`'s.
    fn largest_errors(other: &Particles, exact: &Particles) -> (f64, f64) {
        let n = exact.len();
        let density_error = (0..n)
            .map(|s| (other.rho[s] - exact.rho[s]).abs() / exact.rho[s])
            .fold(0.0, f64::max);
        let largest = (0..n)
            .map(|s| exact.acceleration(s).length())
            .fold(0.0, f64::max);
        let acceleration_error = (0..n)
            .map(|s| (other.acceleration(s) - exact.acceleration(s)).length() / largest)
            .fold(0.0, f64::max);
        (density_error, acceleration_error)
    }

    #[test]
    fn mixed_precision_stays_within_1e_5_of_the_f64_kernels_on_a_dense_step() {
        let ppm = 292.0;
        // The weakly compressible model's kernels are compared in `wcsph`'s tests; the
        // SIMD kernels run on every structure.
        let structures = PairStructure::ALL;
        for (model, structure) in [Model::Course, Model::Fluidanimate]
            .into_iter()
            .flat_map(|model| structures.map(|structure| (model, structure)))
        {
            let pair_stages = |kernel| {
                let on_structure = |sim: &mut Simulation| sim.set_pair_structure(structure);
                dense_pair_stages(ppm, model, kernel, on_structure)
                    .particles()
                    .clone()
            };
            let mixed = pair_stages(Kernel::Mixed);
            for kernel in [Kernel::Simd, Kernel::Simd8, Kernel::Scalar] {
                let exact = pair_stages(kernel);
                let (density_error, acceleration_error) = largest_errors(&mixed, &exact);
                println!(
                    "{model:?} on {structure:?} vs {kernel:?}: \
                     {density_error:.2e} {acceleration_error:.2e}"
                );
                assert!(
                    density_error < 1e-5 && density_error > 0.0,
                    "{density_error}"
                );
                assert!(acceleration_error < 1e-5 && acceleration_error > 0.0);
            }
        }
    }

    #[test]
    fn every_instruction_set_runs_the_list_loops_to_the_same_bits() {
        // The lists' build and passes on AVX-512, AVX2 and plain Rust, where this CPU runs
        // them, on every SIMD kernel and both kinds of lists: the same lists, the same
        // sums in the same order.
        use crate::sim::isa::InstructionSet;
        let ppm = 292.0;
        let listed = [PairStructure::Lists, PairStructure::Rows];
        for (kernel, structure) in [Kernel::Simd, Kernel::Simd8, Kernel::Mixed]
            .into_iter()
            .flat_map(|kernel| listed.map(|structure| (kernel, structure)))
        {
            let step = |isa| {
                let method = Method {
                    model: Model::Fluidanimate,
                    kernel,
                };
                let mut sim = Simulation::with_method(ppm, dense_block(ppm), method).unwrap();
                sim.set_instruction_set(isa);
                sim.set_pair_structure(structure);
                sim.run(2);
                let lists = sim.lists().expect("a dense block runs on lists");
                assert_eq!(lists.rows().is_some(), structure == PairStructure::Rows);
                sim.particles().clone()
            };
            let portable = step(InstructionSet::Portable);
            let available = InstructionSet::ALL
                .into_iter()
                .filter(|isa| isa.is_available());
            for isa in available {
                let what = format!("{kernel:?} on {structure:?} and {}", isa.name());
                assert!(step(isa) == portable, "{what}");
            }
        }
    }

    /// Stages 1-5 of `model` with `kernel` on a dense block at `ppm`, set up by `setup`.
    fn dense_pair_stages(
        ppm: f64,
        model: Model,
        kernel: Kernel,
        setup: impl FnOnce(&mut Simulation),
    ) -> Simulation {
        let method = Method { model, kernel };
        let mut sim = Simulation::with_method(ppm, dense_block(ppm), method).unwrap();
        setup(&mut sim);
        for stage in [
            Stage::Reposition,
            Stage::IncrementDensities,
            Stage::TransformDensities,
            Stage::TransferAccelerations,
        ] {
            sim.run_stage(stage);
        }
        sim
    }

    /// Stages 1-5 of `model` with `kernel` on the lists of `structure`, on a dense block.
    fn listed_pair_stages(model: Model, kernel: Kernel, structure: PairStructure) -> Particles {
        let on_lists = |sim: &mut Simulation| sim.set_pair_structure(structure);
        let sim = dense_pair_stages(292.0, model, kernel, on_lists);
        let lists = sim.lists().expect("a dense block runs on lists");
        assert_eq!(lists.rows().is_some(), structure == PairStructure::Rows);
        sim.particles().clone()
    }

    #[test]
    fn the_lanes_of_a_pass_on_rows_are_the_registers_it_fills() {
        use crate::sim::lists::ROW;
        // 7995 particles: a last block of 3 slots, one register of either width.
        let ppm = 292.0;
        let order: Vec<u32> = (0..7995).collect();
        let particles = dense_block(ppm).permuted(&order).unpadded();
        for kernel in [Kernel::Simd, Kernel::Simd8] {
            let method = Method {
                model: Model::Fluidanimate,
                kernel,
            };
            let mut sim = Simulation::with_method(ppm, particles.clone(), method).unwrap();
            sim.set_pair_structure(PairStructure::Rows);
            sim.run_stage(Stage::Reposition);
            let lists = sim.lists().expect("a dense block runs on lists");
            let rows = lists.rows().expect("rows asked for");
            let (n, lanes) = (rows.far() as usize, kernel.lanes());
            assert_eq!((n, n % ROW), (7995, 3));
            // The registers of `across`' loops: in each block, from each multiple of the
            // lanes below the slot count, one per row.
            let registers: usize = (0..rows.blocks())
                .flat_map(|block| (0..ROW).step_by(lanes).map(move |from| (block, from)))
                .filter(|(block, from)| block * ROW + from < n)
                .map(|(block, _)| rows.rows(block).len())
                .sum();
            assert_eq!(sim.pair_lanes(), (registers * lanes) as u64, "{kernel:?}");
            assert!(sim.pair_lanes() >= 2 * lists.pairs() as u64, "{kernel:?}");
        }
    }

    #[test]
    fn the_passes_across_particles_sum_the_half_lists_terms_in_another_order() {
        // Each pair's terms are the same numbers on either layout (on rows, each
        // particle's own, the partner's the exact negation): only the order of the sums
        // differs, within a few ulps of the largest term.
        for (model, kernel) in [Model::Course, Model::Fluidanimate]
            .into_iter()
            .flat_map(|model| [Kernel::Simd, Kernel::Simd8, Kernel::Mixed].map(|k| (model, k)))
        {
            let half = listed_pair_stages(model, kernel, PairStructure::Lists);
            let rows = listed_pair_stages(model, kernel, PairStructure::Rows);
            // The mixed kernel's terms are f32: its sums' order moves them by more.
            let tolerance = if kernel == Kernel::Mixed { 1e-6 } else { 1e-12 };
            let (density_error, acceleration_error) = largest_errors(&rows, &half);
            let what = format!("{model:?} on {kernel:?}: {density_error:e} {acceleration_error:e}");
            assert!(density_error < tolerance, "{what}");
            assert!(acceleration_error < tolerance, "{what}");
            assert!(acceleration_error > 0.0, "{what}: the same order");
        }
    }
}
