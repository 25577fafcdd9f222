//! Cell order: stage 1 of SPEC.md section 4, computed so that the pair search does only
//! the work a scene needs.
//!
//! A particle's *cell* is its block before clamping: `floor((p - b_min) / s)` per axis,
//! with the grid's block size `s`. Inside the box a cell is exactly a block; outside, the
//! cells keep apart the particles that clamping would pile into one boundary block, so a
//! particle metres outside the box is only compared with particles near it. Every pair
//! closer than h lies in the same or adjacent cells (s >= h), as it does in blocks.
//!
//! Each step the particles are sorted by cell key (z, y, x, x fastest) with a stable
//! least-significant-digit radix sort, a sequence of counting sorts over digits of at most
//! 11 bits. Its memory is proportional to the particles, not to the grid or to the space the
//! particles spread over, and it does no work on empty cells. Particles of one cell are
//! contiguous, and so are the three cells of any row along x, which the pair search uses.
//! Within a cell the particles are in the order of their ids: the slot order, and so every
//! sum of the pair passes, depends on the particles alone, never on the order they were
//! stored in or on what the lone filter let through (SPEC.md's order of stage 1, by the old
//! block, gives the same outputs of steps 1 to 5, which do not depend on the pair order).
//! The clamped block still decides the wall stages: each particle's walls are recorded here.

use crate::sim::grid::Grid;
use crate::sim::isa::{Gathers, InstructionSet, OnInstructionSet};
use crate::sim::particles::Particles;
use glam::DVec3;
use wide::{f64x8, i64x8, u64x8};

/// Largest cell coordinate magnitude kept; beyond it (about 9,000 km from the box at 204
/// particles per metre) coordinates saturate, which keeps adjacent cells adjacent.
const CELL_LIMIT: f64 = ((1 << 30) - 1) as f64;

/// Largest digit of the radix sort: 2048 counters, which stay in the L1 cache.
const MAX_DIGIT_BITS: u32 = 11;

/// Keys larger than any cell's that end the sorted keys, so that searches through them
/// can read four keys at a time without a bounds check.
pub const SENTINELS: usize = 4;

/// Integer cell coordinates along x, y and z.
pub type Cell = [i32; 3];

/// The cell of a position: floor((p - b_min) / s) per axis, as the grid computes a block
/// but without clamping (saturated at +-(2^30 - 1); NaN gives 0).
pub fn cell_of(grid: &Grid, p: [f64; 3]) -> Cell {
    std::array::from_fn(|d| cell_coordinate(p[d], grid.min[d], grid.block_size[d]))
}

#[inline(always)]
fn cell_coordinate(p: f64, min: f64, size: f64) -> i32 {
    cell_float(p, min, size) as i32
}

/// The cell coordinate of [`cell_coordinate`] as a float (an integer, or NaN).
#[inline(always)]
fn cell_float(p: f64, min: f64, size: f64) -> f64 {
    ((p - min) / size).floor().clamp(-CELL_LIMIT, CELL_LIMIT)
}

/// [`coarsen`] of [`cell_coordinate`], computed from the float: for a coordinate of
/// magnitude m >= 2^`exact_bits`, the exponent of m is its octave and the leading bits of
/// its mantissa are the bits `coarsen` keeps, so shifting the bits of m right by
/// 52 - `exact_bits` gives both at once. One position at a time: the rule that
/// [`coarse_coordinates`], which stage 1 runs, is tested against.
#[cfg(test)]
fn coarse_coordinate(p: f64, min: f64, size: f64, exact_bits: u32) -> i32 {
    let cell = cell_float(p, min, size);
    let magnitude = cell.abs();
    let exponent_and_leading = (magnitude.to_bits() >> (52 - exact_bits)) as i64;
    let far = (exponent_and_leading - ((1022 + i64::from(exact_bits)) << exact_bits)) as i32;
    let far = if cell < 0.0 { -far } else { far };
    // NaN is not far, and becomes 0 as cell_coordinate makes it.
    if magnitude >= f64::from(1u32 << exact_bits) {
        far
    } else {
        cell as i32
    }
}

/// [`coarse_coordinate`] of 8 positions at once, on `f64x8` lanes.
#[inline(always)]
fn coarse_coordinates(p: [f64; 8], min: f64, size: f64, exact_bits: u32) -> [i32; 8] {
    let quotient = (f64x8::from(p) - f64x8::splat(min)) / f64x8::splat(size);
    let floor = quotient.floor();
    // NaN becomes 0 here, as it does in `cell_coordinate`.
    let cell = floor.is_nan().select(f64x8::ZERO, floor);
    let cell = cell
        .max(f64x8::splat(-CELL_LIMIT))
        .min(f64x8::splat(CELL_LIMIT));
    let magnitude = cell.abs();
    // A logical shift: the magnitude's sign bit is clear, and AVX2 has no arithmetic
    // shift of 64-bit lanes.
    let bits: u64x8 = wide::bytemuck::cast(magnitude);
    let leading: i64x8 = wide::bytemuck::cast(bits >> (52 - exact_bits));
    let far = leading - i64x8::splat((1022 + i64::from(exact_bits)) << exact_bits);
    let negative: i64x8 = wide::bytemuck::cast(cell.simd_lt(f64x8::ZERO));
    let far = negative.select(-far, far);
    let is_far: i64x8 =
        wide::bytemuck::cast(magnitude.simd_ge(f64x8::splat(f64::from(1u32 << exact_bits))));
    let coordinates = is_far.select(far, integer_value(cell)).to_array();
    coordinates.map(|c| c as i32)
}

/// 1.5 * 2^52: added to an integer of magnitude below 2^51, it leaves the integer in
/// the low bits of the sum's mantissa, exactly.
const INTEGER_MAGIC: f64 = 6_755_399_441_055_744.0;

/// The integers that `integral` holds (each of magnitude below 2^51) as i64 lanes, by the
/// bits of their sum with [`INTEGER_MAGIC`]: two vector additions, where a conversion
/// without AVX-512DQ goes lane by lane.
#[inline(always)]
fn integer_value(integral: f64x8) -> i64x8 {
    let magic = f64x8::splat(INTEGER_MAGIC);
    let sum: i64x8 = wide::bytemuck::cast(integral + magic);
    sum - wide::bytemuck::cast::<f64x8, i64x8>(magic)
}

/// The coarse cells of 8 positions (per axis), on lanes.
#[inline(always)]
fn group_cells(p: [[f64; 8]; 3], min: [f64; 3], size: [f64; 3], exact: [u32; 3]) -> [Cell; 8] {
    let mut axes = [[0; 8]; 3];
    for (d, axis) in axes.iter_mut().enumerate() {
        *axis = coarse_coordinates(p[d], min[d], size[d], exact[d]);
    }
    let mut cells = [[0; 3]; 8];
    for (k, cell) in cells.iter_mut().enumerate() {
        *cell = [axes[0][k], axes[1][k], axes[2][k]];
    }
    cells
}

/// Merges cells far from the box: coordinates below 2^`exact_bits` in magnitude are kept,
/// and each further octave [2^e, 2^(e+1)) is mapped onto 2^`exact_bits` coordinates, like
/// the exponent and leading mantissa bits of a float. The map is monotone and never grows
/// by more than 1 per cell, so adjacent cells stay the same or adjacent: every pair closer
/// than h is still in the same or adjacent coarse cells. Far particles share coarse cells
/// only where they are sparse, and keys need few bits (few radix passes).
pub fn coarsen(coordinate: i32, exact_bits: u32) -> i32 {
    let magnitude = coordinate.unsigned_abs();
    if magnitude >> exact_bits == 0 {
        return coordinate;
    }
    let octave = u32::BITS - 1 - magnitude.leading_zeros();
    let leading = (magnitude >> (octave - exact_bits)) & ((1 << exact_bits) - 1);
    let coarse = (((octave - exact_bits + 1) << exact_bits) | leading) as i32;
    if coordinate < 0 {
        -coarse
    } else {
        coarse
    }
}

/// The bits kept exactly by [`coarsen`] on each axis of `grid`.
fn exact_bits(grid: &Grid) -> [u32; 3] {
    grid.dims.map(|n| usize::BITS - n.leading_zeros() + 1)
}

/// A cell with [`coarsen`] applied on each axis, keeping exact every cell within a grid's
/// width of the box.
pub fn coarse_cell(grid: &Grid, cell: Cell) -> Cell {
    let exact = exact_bits(grid);
    std::array::from_fn(|d| coarsen(cell[d], exact[d]))
}

/// How coarse cells are packed into sort keys: per axis, the offset from the lowest
/// occupied coordinate, in as many bits as the occupied range needs (z highest, x lowest).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CellLayout {
    origin: Cell,
    extent: [u32; 3],
    bits: [u32; 3],
    shift: [u32; 3],
}

impl CellLayout {
    /// The layout covering the coarse cells from `lowest` to `highest` (per axis,
    /// inclusive).
    pub fn covering(lowest: Cell, highest: Cell) -> Self {
        let extent: [u32; 3] = std::array::from_fn(|d| highest[d].abs_diff(lowest[d]));
        let bits = extent.map(|e| u32::BITS - e.leading_zeros());
        Self {
            origin: lowest,
            extent,
            bits,
            shift: [0, bits[0], bits[0] + bits[1]],
        }
    }

    /// Number of bits a key uses.
    pub fn key_bits(&self) -> u32 {
        self.shift[2] + self.bits[2]
    }

    /// Largest offset from the origin on each axis.
    pub fn extent(&self) -> [u32; 3] {
        self.extent
    }

    /// Bit position of each axis's offset in a key.
    pub fn shift(&self) -> [u32; 3] {
        self.shift
    }

    /// The key of a covered coarse cell.
    pub fn key(&self, cell: Cell) -> u64 {
        self.pack(std::array::from_fn(|d| cell[d].abs_diff(self.origin[d])))
    }

    /// The key of offsets from the origin (each within the extent).
    pub fn pack(&self, offsets: [u32; 3]) -> u64 {
        (0..3).fold(0, |key, d| key | (u64::from(offsets[d]) << self.shift[d]))
    }

    /// The offsets from the origin of a key.
    pub fn unpack(&self, key: u64) -> [u32; 3] {
        std::array::from_fn(|d| ((key >> self.shift[d]) & ((1 << self.bits[d]) - 1)) as u32)
    }
}

/// Which wall a particle's block touches on one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wall {
    /// Block coordinate 0.
    Low,
    /// Block coordinate n - 1 (and not 0).
    High,
}

/// The walls of each particle's block, one [`WallBits`] per slot in cell order (per
/// stored particle after a sort that left the particles in place), and where the box's
/// walls are.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Walls {
    bits: Vec<WallBits>,
    /// The box's low corner (m).
    pub min: DVec3,
    /// The box's high corner (m).
    pub max: DVec3,
    /// The axes whose faces are periodic, not walls.
    pub periodic: [bool; 3],
}

impl Walls {
    /// Takes the walls to be those of `grid`'s box.
    fn set_box(&mut self, grid: &Grid) {
        (self.min, self.max, self.periodic) = (grid.min, grid.max, grid.periodic);
    }

    /// The walls of every slot: bit 2 * axis for the low wall, 2 * axis + 1 for the high.
    pub fn bits(&self) -> &[WallBits] {
        &self.bits
    }

    /// The slots (stored particles, after a sort that left them in place), ascending, of
    /// particles in blocks on `wall` of `axis`.
    pub fn on(&self, axis: usize, wall: Wall) -> Vec<u32> {
        let bit = wall_bit(axis, wall);
        (0..self.bits.len() as u32)
            .filter(|&slot| self.bits[slot as usize] & bit != 0)
            .collect()
    }
}

/// The walls of the block of `grid` that the particle in `slot` is in.
fn slot_walls(grid: &Grid, particles: &Particles, slot: usize) -> WallBits {
    let p = std::array::from_fn(|d| particles.p[d][slot]);
    wall_bits(grid, cell_of(grid, p).map(i64::from))
}

/// The [`WallBits`] bit of `wall` on `axis`.
pub fn wall_bit(axis: usize, wall: Wall) -> WallBits {
    1 << (2 * axis + wall as usize)
}

/// Bit 2d (low) or 2d + 1 (high) for each axis d whose block coordinate is on a wall.
pub type WallBits = u8;

/// The walls of the block holding a cell (or of a block itself), as SPEC.md stages 6 and 8
/// pick them: coordinate 0 (after clamping) is the low wall, otherwise n - 1 the high wall.
fn wall_bits(grid: &Grid, block: [i64; 3]) -> WallBits {
    (0..3).fold(0, |bits, d| {
        if block[d] <= 0 {
            bits | 1 << (2 * d)
        } else if block[d] >= grid.dims[d] as i64 - 1 {
            bits | 1 << (2 * d + 1)
        } else {
            bits
        }
    })
}

/// A filter of the particles that have no other particle in their own or an adjacent
/// coarse cell ("lone": no pair within h can involve them). Each particle is counted (up
/// to 2) in a hashed table of 2x2x2 blocks of cells; the 27 cells around a particle's cell
/// lie in 8 such blocks, so a particle is lone if those 8 count it alone. Hash collisions
/// only ever add counts, so a particle it calls lone is lone. The lookups run on lanes of
/// 8 particles, each block's 8 lookups one gather ([`Gathers::words8`]) on AVX-512, two on
/// AVX2.
#[derive(Debug, Clone)]
struct LoneFilter {
    /// Two bits per hashed block: bit 0 "one particle or more", bit 1 "two or more".
    words: Vec<u64>,
    /// 64 minus the table's index bits.
    shift: u32,
    /// The table's size in blocks per particle (rounded up to a power of two in all).
    blocks_per_particle: usize,
}

impl Default for LoneFilter {
    fn default() -> Self {
        LoneFilter {
            words: Vec::new(),
            shift: 0,
            blocks_per_particle: DEFAULT_FILTER_BLOCKS,
        }
    }
}

/// The lone filter's table size in blocks per particle, unless set otherwise: about 64
/// blocks per particle, so a block counts others by mistake rarely.
pub const DEFAULT_FILTER_BLOCKS: usize = 64;

/// The largest table the lone filter may be given, in blocks per particle (2^16: its
/// table's index bits stay below 64 for any number of particles a `u32` slot counts).
pub const MAX_FILTER_BLOCKS: usize = 1 << 16;

/// Bits per block coordinate in a packed block; coordinates are offset to be positive.
const BLOCK_BITS: u32 = 16;

/// The lone filter's hash: a packed block times this, its top bits.
const HASH_MULTIPLIER: u64 = 0x9e37_79b9_7f4a_7c15;

/// Particles per group of the lone filter's lookups.
const LANES: usize = 8;

/// Which of the 8 blocks around a cell (numbered as the lone filter's offsets) holds the
/// cell itself: bit d set where the cell's coordinate d is even.
#[inline(always)]
fn own_block(cell: Cell) -> u64 {
    (0..3).fold(0, |k, d| k | (u64::from(cell[d] & 1 == 0) << d))
}

impl LoneFilter {
    /// Marks which of `cells` (coarse cells) are lone: bit `i % 8` of `lone[i / 8]` for
    /// `cells[i]`.
    fn find<G: Gathers>(&mut self, isa: G, cells: &[Cell], lone: &mut Vec<u8>) {
        let blocks = self.blocks_per_particle * cells.len().max(1);
        // At least 32 blocks: one word.
        let index_bits = blocks.next_power_of_two().ilog2().max(5);
        self.shift = u64::BITS - index_bits;
        self.words.clear();
        self.words.resize((1 << index_bits) / 32, 0);
        for cell in cells {
            let (word, bit) = self.slot(pack_block(cell.map(|c| c >> 1)));
            let counts = &mut self.words[word];
            *counts |= (*counts >> bit & 1) << (bit + 1) | 1 << bit;
        }
        // The 8 blocks holding the cells c-1..c+1 per axis: first = (c-1) >> 1 and the
        // next one, on each axis; the particle's own block is the next one where c is even.
        let offsets: [u64; 8] = std::array::from_fn(|k| {
            (0..3).fold(0, |sum, d| {
                sum | ((k as u64 >> d) & 1) << (BLOCK_BITS * d as u32)
            })
        });
        lone.clear();
        let mut groups = cells.chunks_exact(LANES);
        let filter = &*self;
        lone.extend(
            groups
                .by_ref()
                .map(|eight| filter.lone_lanes(isa, &offsets, eight.try_into().expect("8"))),
        );
        // The last few on lanes too, the spare lanes repeating one of them (and unmarked).
        let rest = groups.remainder();
        if let Some(&last) = rest.last() {
            let mut eight = [last; LANES];
            eight[..rest.len()].copy_from_slice(rest);
            let used = ((1u16 << rest.len()) - 1) as u8;
            lone.push(self.lone_lanes(isa, &offsets, &eight) & used);
        }
    }

    /// Which of 8 cells are lone (bit k for `cells[k]`), on lanes of 8 particles: each
    /// of a particle's 8 blocks hashed from one product, (b + o) K = b K + o K (wrapping).
    #[inline(always)]
    fn lone_lanes<G: Gathers>(&self, isa: G, offsets: &[u64; 8], cells: &[Cell; LANES]) -> u8 {
        let (mut first, mut own) = ([0; LANES], [0; LANES]);
        for (lane, cell) in cells.iter().enumerate() {
            first[lane] = pack_block(cell.map(|c| (c - 1) >> 1));
            own[lane] = own_block(*cell);
        }
        let (first, own) = (u64x8::from(first), u64x8::from(own));
        let first_hashed = first * u64x8::splat(HASH_MULTIPLIER);
        let one = u64x8::splat(1);
        let mut count = u64x8::splat(0);
        for (k, offset) in offsets.iter().enumerate() {
            let offset_hashed = u64x8::splat(offset.wrapping_mul(HASH_MULTIPLIER));
            let hash: u64x8 = (first_hashed + offset_hashed) >> self.shift;
            let words = u64x8::from(isa.words8(&self.words, (hash >> 5_u32).to_array()));
            let counts = words >> ((hash & u64x8::splat(31)) << 1);
            let own_counts = own.simd_eq(u64x8::splat(k as u64)) & (counts >> 1);
            count = count + (counts & one) + (own_counts & one);
        }
        count.simd_eq(one).to_bitmask() as u8
    }

    /// A packed block's position in the table.
    #[inline(always)]
    fn hash(&self, packed: u64) -> u64 {
        packed.wrapping_mul(HASH_MULTIPLIER) >> self.shift
    }

    /// The word and bit of a packed block's counts.
    #[inline(always)]
    fn slot(&self, packed: u64) -> (usize, u32) {
        let hash = self.hash(packed) as usize;
        (hash / 32, 2 * (hash % 32) as u32)
    }
}

/// [`LoneFilter::find`] on one instruction set.
struct FindLone<'a> {
    filter: &'a mut LoneFilter,
    cells: &'a [Cell],
    lone: &'a mut Vec<u8>,
}

impl OnInstructionSet for FindLone<'_> {
    type Output = ();
    fn run<G: Gathers>(self, isa: G) {
        self.filter.find(isa, self.cells, self.lone);
    }
}

/// A block's coordinates in one integer, [`BLOCK_BITS`] each, offset so that each is
/// positive and one more does not carry: coarse coordinates stay within +-21,504 for every
/// grid of at most [`crate::sim::grid::MAX_BLOCKS`] blocks, so blocks (halves) stay within
/// +-2^14 (tested with the finest grid).
#[inline(always)]
fn pack_block(block: Cell) -> u64 {
    let bias = 1 << (BLOCK_BITS - 1);
    debug_assert!(block
        .iter()
        .all(|b| b.unsigned_abs() < 1 << (BLOCK_BITS - 2)));
    (0..3).fold(0, |packed, d| {
        packed | (((block[d] + bias) as u64) << (BLOCK_BITS * d as u32))
    })
}

/// The cell order of the particles after stage 1, and the buffers to recompute it.
#[derive(Debug, Clone, Default)]
pub struct CellOrder {
    layout: CellLayout,
    /// Key of each slot that may have a pair, in cell order, then [`SENTINELS`] times
    /// `u64::MAX`.
    keys: Vec<u64>,
    /// Where each slot's particle is stored (its index in the particles sorted).
    order: Vec<u32>,
    walls: Walls,
    /// Whether the last sort found mostly lone particles (more cells than half the
    /// particles), so that this one filters them out first.
    sparse: bool,
    /// Whether the last sort left the particles where they are stored
    /// ([`Self::sort_in_place`]): the next sort then reads them in its slot order.
    in_place: bool,
    lone_filter: LoneFilter,
    /// Whether the lone filter is off: every sort then orders every particle by cell.
    unfiltered: bool,
    /// The lone filter's answer: bit `i % 8` of byte `i / 8` for stored particle `i`.
    lone: Vec<u8>,
    /// The instructions the lone filter's lookups run on, where set (else
    /// [`InstructionSet::for_lookups`]).
    isa: Option<InstructionSet>,
    // Reused buffers.
    cells: Vec<Cell>,
    wall_bits: Vec<WallBits>,
    spare_keys: Vec<u64>,
    spare_order: Vec<u32>,
    counts: Vec<u32>,
}

impl CellOrder {
    /// Whether the last sort found mostly lone particles, so the next filters them out
    /// first (part of what a checkpoint keeps: it decides the next sort's work and where
    /// its lone particles go, never the order of the others).
    pub fn is_sparse(&self) -> bool {
        self.sparse
    }

    /// The instruction set the lone filter's lookups run on: the one set, or
    /// [`InstructionSet::for_lookups`].
    pub fn instruction_set(&self) -> InstructionSet {
        self.isa.unwrap_or_else(InstructionSet::for_lookups)
    }

    /// Runs the lone filter's lookups with `isa` from now on.
    ///
    /// # Panics
    /// If this CPU does not run it.
    pub fn set_instruction_set(&mut self, isa: InstructionSet) {
        assert!(isa.is_available(), "this CPU does not run {}", isa.name());
        self.isa = Some(isa);
    }

    /// Filters out lone particles with a table of `blocks_per_particle` blocks per
    /// particle (rounded up to a power of two in all; [`DEFAULT_FILTER_BLOCKS`] unless
    /// set), or, with `None`, never. Only the work changes: the slot order of the
    /// particles that may have a pair, and so every result, does not.
    ///
    /// # Panics
    /// If `blocks_per_particle` is `Some(0)` or above [`MAX_FILTER_BLOCKS`].
    pub fn set_lone_filter(&mut self, blocks_per_particle: Option<usize>) {
        let blocks = blocks_per_particle.unwrap_or(DEFAULT_FILTER_BLOCKS);
        assert!(
            (1..=MAX_FILTER_BLOCKS).contains(&blocks),
            "a lone filter of {blocks} blocks per particle"
        );
        self.unfiltered = blocks_per_particle.is_none();
        self.lone_filter.blocks_per_particle = blocks;
    }

    /// An empty cell order whose next sort runs as after a sort that found the particles
    /// sparse (`sparse`) or not.
    pub fn resumed(sparse: bool) -> CellOrder {
        CellOrder {
            sparse,
            ..CellOrder::default()
        }
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.keys)
            + bytes(&self.order)
            + bytes(&self.walls.bits)
            + bytes(&self.lone_filter.words)
            + bytes(&self.lone)
            + bytes(&self.cells)
            + bytes(&self.wall_bits)
            + bytes(&self.spare_keys)
            + bytes(&self.spare_order)
            + bytes(&self.counts)
    }

    /// Sorts `particles` by cell, for the caller to move them into that order (slot k
    /// receives stored particle `order()[k]`); their walls are those of the blocks the
    /// grid gives their positions, per slot. Within a cell, the slots are in the order of
    /// the particles' ids; the lone particles follow the others in their previous slot
    /// order. Returns whether any particle changes slot (if not, [`Self::order`] is the
    /// identity).
    pub fn sort(&mut self, grid: &Grid, particles: &Particles) -> bool {
        self.sort_placing(grid, particles, false)
    }

    /// As [`Self::sort`], but where the last sort found the particles sparse (so that
    /// this one filters out lone particles, unless the filter is off), it leaves them
    /// where they are stored
    /// ([`Self::is_in_place`]): the order, keys and slot order are the same, the walls are
    /// per stored particle, and only the particles that may have a pair
    /// ([`Self::paired`]) need copying out for the pair passes. Returns whether the
    /// caller must move the particles into the order.
    pub fn sort_in_place(&mut self, grid: &Grid, particles: &Particles) -> bool {
        self.sort_placing(grid, particles, true)
    }

    fn sort_placing(&mut self, grid: &Grid, particles: &Particles, may_stay: bool) -> bool {
        self.compute_cells(grid, particles);
        self.walls.set_box(grid);
        let walls = self.cells.iter().map(|c| wall_bits(grid, c.map(i64::from)));
        self.wall_bits.clear();
        self.wall_bits.extend(walls);
        self.finish(&particles.id, may_stay)
    }

    /// As [`Self::sort`], on the cells of `search` (a grid of larger blocks, for lists
    /// with a skin), the walls still those of the blocks of `grid`.
    pub fn sort_on(&mut self, search: &Grid, grid: &Grid, particles: &Particles) -> bool {
        self.compute_cells(search, particles);
        self.walls.set_box(grid);
        self.wall_bits.clear();
        let walls = (0..particles.len()).map(|slot| slot_walls(grid, particles, slot));
        self.wall_bits.extend(walls);
        self.finish(&particles.id, false)
    }

    /// Recomputes the walls of every slot from its particle's current block of `grid`,
    /// the order kept (for lists kept from an earlier step).
    pub fn refresh_walls(&mut self, grid: &Grid, particles: &Particles) {
        self.walls.set_box(grid);
        self.walls.bits.clear();
        let walls = (0..particles.len()).map(|slot| slot_walls(grid, particles, slot));
        self.walls.bits.extend(walls);
    }

    /// As [`Self::sort`], but the walls come from given blocks (linear indices, one per
    /// particle in its current slot), as in a trace recorded after stage 1.
    pub fn sort_with_blocks(&mut self, grid: &Grid, particles: &Particles, blocks: &[u32]) -> bool {
        self.compute_cells(grid, particles);
        self.walls.set_box(grid);
        let walls = blocks
            .iter()
            .map(|&b| wall_bits(grid, grid.coords(b as usize).map(|c| c as i64)));
        self.wall_bits.clear();
        self.wall_bits.extend(walls);
        self.finish(&particles.id, false)
    }

    /// The coarse cell of every particle.
    fn compute_cells(&mut self, grid: &Grid, particles: &Particles) {
        const GROUP: usize = 8;
        let n = particles.len();
        self.cells.clear();
        self.cells.resize(n, [0; 3]);
        let exact = exact_bits(grid);
        let (min, size) = (grid.min.to_array(), grid.block_size.to_array());
        // Eight particles at a time on f64x8 lanes.
        let mut groups = self.cells.chunks_exact_mut(GROUP);
        for (group, cells) in groups.by_ref().enumerate() {
            let at = group * GROUP;
            let p = particles
                .p
                .each_ref()
                .map(|axis| <[f64; GROUP]>::try_from(&axis[at..at + GROUP]).expect("a group"));
            cells.copy_from_slice(&group_cells(p, min, size, exact));
        }
        // The last few on lanes too, the spare lanes at 0.
        let rest = groups.into_remainder();
        let at = n - rest.len();
        let mut p = [[0.0; GROUP]; 3];
        for (axis, positions) in p.iter_mut().zip(&particles.p) {
            axis[..rest.len()].copy_from_slice(&positions[at..n]);
        }
        let last = group_cells(p, min, size, exact);
        rest.copy_from_slice(&last[..rest.len()]);
    }

    fn finish(&mut self, ids: &[u32], may_stay: bool) -> bool {
        let n = self.cells.len();
        let sorting_sparse = self.sparse;
        let filtering = sorting_sparse && !self.unfiltered;
        if filtering {
            self.instruction_set().run(FindLone {
                filter: &mut self.lone_filter,
                cells: &self.cells,
                lone: &mut self.lone,
            });
        }
        let paired = self.split(filtering);
        let (lowest, highest) = self.order[..paired]
            .iter()
            .map(|&slot| self.cells[slot as usize])
            .fold(([i32::MAX; 3], [i32::MIN; 3]), |(lo, hi), c| {
                (
                    std::array::from_fn(|d| lo[d].min(c[d])),
                    std::array::from_fn(|d| hi[d].max(c[d])),
                )
            });
        self.layout = if paired == 0 {
            CellLayout::default()
        } else {
            CellLayout::covering(lowest, highest)
        };
        let layout = self.layout;
        self.keys.clear();
        // Room for the sentinels too, so that adding them never doubles the buffer.
        self.keys.reserve_exact(paired + SENTINELS);
        let keys = self.order[..paired]
            .iter()
            .map(|&slot| layout.key(self.cells[slot as usize]));
        self.keys.extend(keys);
        if !self.keys.is_sorted() {
            self.radix_sort();
        }
        self.order_cells_by_id(ids);
        let cells = n - paired + self.keys.chunk_by(|a, b| a == b).count();
        self.sparse = 2 * cells > n;
        self.keys.extend([u64::MAX; SENTINELS]);
        self.in_place = may_stay && sorting_sparse;
        self.walls.bits.clear();
        if self.in_place {
            // The walls of the stored particles are those computed; the next sort
            // computes its own into the other buffer.
            std::mem::swap(&mut self.walls.bits, &mut self.wall_bits);
            return false;
        }
        // The walls in the new order, and whether any particle moved, in one pass.
        let mut moved = false;
        let walls = self.order.iter().enumerate().map(|(slot, &stored)| {
            moved |= slot != stored as usize;
            self.wall_bits[stored as usize]
        });
        self.walls.bits.extend(walls);
        moved
    }

    /// Puts the stored particles in the previous slot order into `order`, those that
    /// may have a pair first, then (when `filtering`) the lone ones, each in that order;
    /// returns how many may have a pair.
    fn split(&mut self, filtering: bool) -> usize {
        let n = self.cells.len();
        if !self.in_place {
            self.order.clear();
            self.order.extend(0..n as u32);
        }
        if !filtering {
            return n;
        }
        // Each particle written to both lists, the cursor advancing only in its own: no
        // branch on whether a particle is lone. The paired ones are written over slots
        // already read; the lone ones pass through the radix sort's spare buffer.
        self.spare_order.clear();
        self.spare_order.resize(n, 0);
        let (order, lone_order, marks) = (&mut self.order[..n], &mut self.spare_order, &self.lone);
        let (mut paired, mut lone) = (0, 0);
        for slot in 0..n {
            let stored = order[slot];
            let is_lone = marks[stored as usize / 8] >> (stored % 8) & 1 != 0;
            order[paired] = stored;
            lone_order[lone] = stored;
            paired += usize::from(!is_lone);
            lone += usize::from(is_lone);
        }
        self.order.truncate(paired);
        self.order.extend_from_slice(&self.spare_order[..lone]);
        paired
    }

    /// Puts the slots of each cell in the order of their particles' ids (`ids`, per
    /// stored particle), so that the slot order of the particles that may have a pair
    /// depends on the particles alone, never on the order they came in (which the lone
    /// filter decides). Ids are unique, so an unstable sort gives the one order.
    fn order_cells_by_id(&mut self, ids: &[u32]) {
        let paired = self.keys.len();
        let (keys, order) = (&self.keys[..], &mut self.order[..paired]);
        let mut start = 0;
        for slot in 1..=paired {
            if slot < paired && keys[slot] == keys[start] {
                continue;
            }
            if slot - start > 1 {
                order[start..slot].sort_unstable_by_key(|&stored| ids[stored as usize]);
            }
            start = slot;
        }
    }

    /// Stable LSD radix sort of `keys` (carrying the slots at the front of `order`, one
    /// per key) in as few digits as the key bits need, skipping digits that are equal
    /// for every key.
    fn radix_sort(&mut self) {
        let n = self.keys.len();
        let bits = self.layout.key_bits();
        let passes = bits.div_ceil(MAX_DIGIT_BITS);
        let digit_bits = bits.div_ceil(passes);
        let radix = 1usize << digit_bits;
        let mask = radix as u64 - 1;
        self.counts.clear();
        self.counts.resize(passes as usize * radix, 0);
        for &key in &self.keys {
            for pass in 0..passes as usize {
                let digit = (key >> (pass as u32 * digit_bits)) & mask;
                self.counts[pass * radix + digit as usize] += 1;
            }
        }
        // The buffers trade places: each leaves room for the sentinels.
        self.spare_keys.clear();
        self.spare_keys.reserve_exact(n + SENTINELS);
        self.spare_keys.resize(n, 0);
        self.spare_order.resize(n, 0);
        for pass in 0..passes as usize {
            let starts = &mut self.counts[pass * radix..(pass + 1) * radix];
            if starts.iter().any(|&count| count as usize == n) {
                continue;
            }
            let mut total = 0;
            for count in starts.iter_mut() {
                (*count, total) = (total, total + *count);
            }
            let shift = pass as u32 * digit_bits;
            for (&key, &old) in self.keys.iter().zip(&self.order[..n]) {
                let cursor = &mut starts[((key >> shift) & mask) as usize];
                self.spare_keys[*cursor as usize] = key;
                self.spare_order[*cursor as usize] = old;
                *cursor += 1;
            }
            std::mem::swap(&mut self.keys, &mut self.spare_keys);
            // Copied back rather than swapped: the lone slots follow in `order`.
            self.order[..n].copy_from_slice(&self.spare_order[..n]);
        }
    }

    /// How cells are packed into keys this step.
    pub fn layout(&self) -> &CellLayout {
        &self.layout
    }

    /// The cell key of each slot that may have a pair, ascending, followed by
    /// [`SENTINELS`] times `u64::MAX`. These slots come first; the lone particles follow
    /// them, in their previous order.
    pub fn keys(&self) -> &[u64] {
        &self.keys
    }

    /// Where each slot's particle is stored: its index in the particles sorted.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// After a sort that left the particles in place, keeps only the slots of
    /// [`Self::paired`] that `keep` marks (one per slot), in their order; the others
    /// follow them, before the lone particles. The keys shrink to the kept slots.
    ///
    /// # Panics
    /// If the last sort did not leave the particles in place, or `keep` is not one per
    /// slot of [`Self::paired`].
    pub fn keep_paired(&mut self, keep: &[bool]) {
        assert!(
            self.in_place,
            "slots kept after a sort that moved particles"
        );
        let paired = self.paired().len();
        assert_eq!(keep.len(), paired, "one mark per slot that may have a pair");
        // Each slot written to the kept front, the cursor advancing only if kept.
        self.spare_order.clear();
        let mut kept = 0;
        for (slot, &keep) in keep.iter().enumerate() {
            let (stored, key) = (self.order[slot], self.keys[slot]);
            self.order[kept] = stored;
            self.keys[kept] = key;
            kept += usize::from(keep);
            if !keep {
                self.spare_order.push(stored);
            }
        }
        self.order[kept..paired].copy_from_slice(&self.spare_order);
        self.keys.truncate(kept);
        self.keys.extend([u64::MAX; SENTINELS]);
    }

    /// Where each particle that may have a pair is stored, in slot order: the front of
    /// [`Self::order`], the slots the keys (and so the tiles) cover.
    pub fn paired(&self) -> &[u32] {
        &self.order[..self.keys.len().saturating_sub(SENTINELS)]
    }

    /// Whether the last sort left the particles where they are stored
    /// ([`Self::sort_in_place`]): its walls are then per stored particle.
    pub fn is_in_place(&self) -> bool {
        self.in_place
    }

    /// Takes the particles that the last sort left in place to have been moved into its
    /// order since (slot k receiving stored particle `order()[k]`): the walls become
    /// those of each slot, and the next sort reads the particles in storage order.
    pub fn moved_into_order(&mut self) {
        if self.in_place {
            self.in_place = false;
            let walls = self
                .order
                .iter()
                .map(|&stored| self.walls.bits[stored as usize]);
            self.wall_bits.clear();
            self.wall_bits.extend(walls);
            std::mem::swap(&mut self.walls.bits, &mut self.wall_bits);
        }
    }

    /// The walls of each slot (of each stored particle, after a sort that left the
    /// particles in place).
    pub fn walls(&self) -> &Walls {
        &self.walls
    }
}

/// For tests: a block of `side`^3 particles a spacing (1 / `ppm`) apart from the box's
/// low corner, each coordinate moved at random (seeded by `seed`) by up to half of
/// `jitter` spacings, placed in cell order on the grid of the course model's h at `ppm`
/// and padded, with its cell order and grid.
#[cfg(test)]
pub(crate) fn jittered_block(
    ppm: f64,
    side: usize,
    jitter: f64,
    seed: u64,
) -> (Particles, CellOrder, Grid) {
    use crate::sim::params::{Domain, Params};
    let mut random = fastrand::Rng::with_seed(seed);
    let n = side * side * side;
    let mut particles = Particles::zeroed(n);
    for slot in 0..n {
        let k = [slot % side, slot / side % side, slot / (side * side)];
        for (axis, k) in k.into_iter().enumerate() {
            let offset = k as f64 + 1.0 + jitter * (random.f64() - 0.5);
            particles.p[axis][slot] = Domain::COURSE.min[axis] + offset / ppm;
        }
    }
    let grid = Grid::new(Params::new(ppm).h, &Domain::COURSE).unwrap();
    let mut cells = CellOrder::default();
    cells.sort(&grid, &particles);
    let mut placed = particles.permuted(cells.order());
    placed.pad();
    (placed, cells, grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::{Domain, Params, BOX_MAX, BOX_MIN};

    fn grid() -> Grid {
        Grid::new(Params::new(204.0).h, &Domain::COURSE).unwrap()
    }

    /// A deterministic xorshift sequence of numbers in [0, 1) from `seed`.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn positions(points: &[[f64; 3]]) -> Particles {
        let mut particles = Particles::zeroed(points.len());
        particles.p = std::array::from_fn(|d| points.iter().map(|p| p[d]).collect());
        particles
    }

    #[test]
    fn cells_inside_the_box_are_blocks_and_outside_are_unclamped() {
        let grid = grid();
        // (0.075, 0.065, 0.095) from the lower corner, in blocks of 0.13 / 15, 0.18 / 21.
        assert_eq!(cell_of(&grid, [0.01, -0.015, 0.03]), [8, 7, 10]);
        assert_eq!(
            cell_of(&grid, [0.065 - 1e-9, 0.1 - 1e-9, -0.065]),
            [14, 20, 0]
        );
        let below = cell_of(&grid, [-0.065 - 2.5 * grid.block_size.x, 0.0, 0.0]);
        assert_eq!(below[0], -3);
        let limit = (1 << 30) - 1;
        assert_eq!(
            cell_of(&grid, [1e300, f64::NAN, -1e300]),
            [limit, 0, -limit]
        );
    }

    #[test]
    fn coarsening_keeps_the_box_exact_and_adjacent_cells_adjacent() {
        assert_eq!(exact_bits(&grid()), [5, 6, 5]);
        for c in -31..=31 {
            assert_eq!(coarsen(c, 5), c);
        }
        assert_eq!(coarsen(32, 5), 32);
        assert_eq!(coarsen(64, 5), 64);
        assert_eq!(coarsen(66, 5), 65);
        assert_eq!(coarsen(-(1 << 30) + 1, 5), -(((30 - 5) << 5) | 31));
        let mut previous = coarsen(-(1 << 22), 5);
        for c in -(1 << 22) + 1..1 << 22 {
            let coarse = coarsen(c, 5);
            assert!(coarse - previous == 0 || coarse - previous == 1, "at {c}");
            previous = coarse;
        }
    }

    #[test]
    fn each_slot_gets_the_walls_of_its_block() {
        // The course grid, and one of 1, 2 and 3 blocks a side (a single block is on
        // its low wall).
        let course = grid();
        let small = Grid {
            dims: [1, 2, 3],
            block_size: (BOX_MAX - BOX_MIN) / glam::DVec3::new(1.0, 2.0, 3.0),
            min: BOX_MIN,
            max: BOX_MAX,
            periodic: [false; 3],
        };
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        for grid in [course, small] {
            let mut points: Vec<[f64; 3]> = (0..1001)
                .map(|_| std::array::from_fn(|d| BOX_MIN[d] - 0.05 + 0.3 * next()))
                .collect();
            // Block edges, far away, and values that are no position.
            points.extend([BOX_MIN.to_array(), BOX_MAX.to_array()]);
            points.push(std::array::from_fn(|d| BOX_MIN[d] + grid.block_size[d]));
            points.push(std::array::from_fn(|d| BOX_MAX[d] - grid.block_size[d]));
            points.extend([
                [f64::NAN, 1e300, -1e300],
                [f64::INFINITY, 0.0, f64::NEG_INFINITY],
            ]);
            let particles = positions(&points);
            let mut cells = CellOrder::default();
            cells.sort(&grid, &particles);
            for (slot, &stored) in cells.order().iter().enumerate() {
                let expected = slot_walls(&grid, &particles, stored as usize);
                assert_eq!(
                    cells.walls().bits()[slot],
                    expected,
                    "at {:?}",
                    points[stored as usize]
                );
            }
            assert!(cells.walls().bits().iter().any(|&w| w & 0b10_1010 != 0));
        }
    }

    #[test]
    fn coarse_coordinates_from_the_float_are_those_of_the_integers() {
        let grid = grid();
        let exact = exact_bits(&grid);
        let size = grid.block_size.x;
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        let mut values = vec![f64::NAN, 0.0, -0.0, 1e300, -1e300, BOX_MIN.x];
        for k in 0..100_000 {
            let unit = next() - 0.5;
            values.push(unit * 10f64.powi(k % 12 - 3));
        }
        for e in 1..=31 {
            values.push(BOX_MIN.x + f64::from(1u32 << e.min(30)) * size);
            values.push(BOX_MIN.x - f64::from(1u32 << e.min(30)) * size - 1e-9);
        }
        values.extend([f64::INFINITY, f64::NEG_INFINITY, f64::MAX, -f64::MAX]);
        for p in &values {
            let cell = cell_coordinate(*p, BOX_MIN.x, size);
            assert_eq!(
                coarse_coordinate(*p, BOX_MIN.x, size, exact[0]),
                coarsen(cell, exact[0]),
                "at {p}"
            );
        }
        // Eight at a time on lanes, alike: these values on every axis's grid, and whole
        // cells (min 0, size 1) on each side of every octave for every exactness.
        values.resize(values.len().next_multiple_of(8), 0.5);
        let check = |values: &[f64], min: f64, size: f64, exact: u32| {
            for group in values.chunks_exact(8) {
                let lanes = coarse_coordinates(group.try_into().unwrap(), min, size, exact);
                let one_by_one = group
                    .iter()
                    .map(|&p| coarse_coordinate(p, min, size, exact));
                assert!(lanes.into_iter().eq(one_by_one), "at {group:?}");
            }
        };
        for d in 0..3 {
            check(&values, BOX_MIN[d], grid.block_size[d], exact[d]);
        }
        let mut whole = Vec::new();
        for e in 0..31 {
            let octave = f64::from(1u32 << e);
            for p in [
                octave - 1.0,
                octave,
                octave + 1.0,
                octave - 0.5,
                octave + 0.5,
            ] {
                whole.extend([p, -p]);
            }
        }
        whole.extend([CELL_LIMIT, -CELL_LIMIT, CELL_LIMIT + 1.0, -CELL_LIMIT - 1.0]);
        whole.resize(whole.len().next_multiple_of(8), -0.0);
        for exact in 2..=11 {
            check(&whole, 0.0, 1.0, exact);
        }
    }

    #[test]
    fn integer_values_are_those_of_a_conversion() {
        let limit = CELL_LIMIT;
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            limit,
            -limit,
            limit - 1.0,
            2.0f64.powi(50),
        ];
        let mut random = fastrand::Rng::with_seed(7);
        values.extend(
            (0..9992)
                .map(|_| (random.f64() * 2.0 - 1.0) * limit)
                .map(f64::floor),
        );
        for eight in values.chunks_exact(8) {
            let lanes = integer_value(f64x8::from(<[f64; 8]>::try_from(eight).unwrap()));
            let expected: Vec<i64> = eight.iter().map(|&x| x as i64).collect();
            assert_eq!(lanes.to_array().to_vec(), expected);
        }
    }

    #[test]
    fn layout_packs_x_fastest_and_round_trips() {
        let layout = CellLayout::covering([-2, 0, 5], [3, 1, 5]);
        assert_eq!(layout.extent(), [5, 1, 0]);
        assert_eq!(layout.key_bits(), 4);
        assert_eq!(layout.key([-2, 0, 5]), 0);
        assert_eq!(layout.key([-1, 0, 5]), 1);
        assert_eq!(layout.key([-2, 1, 5]), 8);
        assert_eq!(layout.unpack(layout.key([3, 1, 5])), [5, 1, 0]);
    }

    #[test]
    fn keys_of_the_finest_grid_fit_in_48_bits() {
        // About 2^26 blocks, the most a grid may have.
        let grid = Grid {
            dims: [360, 498, 360],
            block_size: glam::DVec3::splat(0.13 / 360.0),
            min: BOX_MIN,
            max: BOX_MIN + 0.13,
            periodic: [false; 3],
        };
        let limit = CELL_LIMIT as i32;
        let (lowest, highest) = (
            coarse_cell(&grid, [-limit; 3]),
            coarse_cell(&grid, [limit; 3]),
        );
        let layout = CellLayout::covering(lowest, highest);
        assert_eq!(layout.key_bits(), 48);
        let extent = layout.extent();
        assert_eq!(layout.unpack(layout.key(highest)), extent);
        // The lone filter's packed blocks (half a coarse cell, plus one) fit their bits.
        let largest = highest
            .iter()
            .chain(&lowest)
            .map(|c| c.unsigned_abs())
            .max();
        assert!(largest.unwrap() / 2 + 1 < 1 << (BLOCK_BITS - 1));
    }

    #[test]
    fn sort_is_stable_and_by_cell() {
        let grid = grid();
        let s = grid.block_size.x;
        // Slots 0 and 2 share a cell far below the box; slot 1 is inside; slot 3 is beyond
        // the upper x wall.
        let far = [-0.065 - 100.0 * s, 0.0, 0.0];
        let points = positions(&[far, [0.0, 0.0, 0.0], far, [1.0, 0.0, 0.0]]);
        let mut cells = CellOrder::default();
        assert!(cells.sort(&grid, &points));
        assert_eq!(cells.order(), [0, 2, 1, 3]);
        let keys = cells.keys();
        assert!(keys.is_sorted() && keys[0] == keys[1] && keys[1] < keys[2]);
        assert_eq!(keys[4..], [u64::MAX; SENTINELS]);
        assert_eq!(cells.walls().on(0, Wall::Low), [0, 1]);
        assert_eq!(cells.walls().on(0, Wall::High), [3]);
    }

    #[test]
    fn within_a_cell_slots_follow_the_ids_whatever_the_storage_order() {
        let grid = grid();
        // 40 particles in a few cells of a dense corner, and 400 lone ones far apart,
        // stored in a shuffled order; sorted as dense and as sparse (the lone filter on).
        let mut random = fastrand::Rng::with_seed(44);
        let dense = (0..40).map(|_| {
            let mut point = [0.0; 3];
            for d in 0..3 {
                point[d] = BOX_MIN[d] + 2.5 * grid.block_size[d] * random.f64();
            }
            point
        });
        let lone = (0..400).map(|k| {
            [
                0.5 + 0.1 * (k % 20) as f64,
                0.5 + 0.1 * (k / 20) as f64,
                0.5,
            ]
        });
        // And a pile of 60 in one cell.
        let pile = (0..60).map(|k| [0.001 * f64::from(k % 5), 0.0005, 0.002]);
        let points: Vec<[f64; 3]> = dense.chain(pile).chain(lone).collect();
        let mut shuffled: Vec<u32> = (0..points.len() as u32).collect();
        random.shuffle(&mut shuffled);
        let mut stored = positions(&points).permuted(&shuffled);
        stored.pad();
        for sparse in [false, true] {
            let mut cells = CellOrder::resumed(sparse);
            cells.sort(&grid, &stored);
            let paired = cells.keys().len() - SENTINELS;
            // The far lattice's coarse cells merge, so it is only partly lone.
            assert!(
                paired >= 100 && (paired < points.len()) == sparse,
                "{paired}"
            );
            let ids: Vec<u32> = cells
                .paired()
                .iter()
                .map(|&k| stored.id[k as usize])
                .collect();
            let keys = &cells.keys()[..paired];
            let mut expected: Vec<(u64, u32)> = keys.iter().copied().zip(ids.clone()).collect();
            expected.sort_unstable();
            let sorted: Vec<(u64, u32)> = keys.iter().copied().zip(ids).collect();
            assert_eq!(sorted, expected, "sparse: {sparse}");
            // Some cells hold several particles, stored out of id order; one holds 60.
            assert!(keys.windows(2).filter(|w| w[0] == w[1]).count() > 70);
            assert!(keys.chunk_by(|a, b| a == b).any(|cell| cell.len() >= 60));
        }
    }

    #[test]
    fn an_ordered_scene_is_left_in_place() {
        let grid = grid();
        let points = positions(&[[0.0, 0.0, 0.0], [0.001, 0.0, 0.0], [0.05, 0.0, 0.0]]);
        let mut cells = CellOrder::default();
        assert!(!cells.sort(&grid, &points));
        assert_eq!(cells.order(), [0, 1, 2]);
    }

    #[test]
    fn radix_sort_agrees_with_a_stable_sort_over_many_digits() {
        let grid = grid();
        // A deterministic cloud spread over kilometres: keys of three radix digits.
        let mut unit = uniform(0x2545_f491_4f6c_dd1d);
        let mut next = || unit() * 4000.0 - 2000.0;
        let points: Vec<[f64; 3]> = (0..3000).map(|_| [next(), next(), next()]).collect();
        let mut cells = CellOrder::default();
        cells.sort(&grid, &positions(&points));
        assert!(cells.layout().key_bits() > 2 * MAX_DIGIT_BITS);
        let layout = *cells.layout();
        let mut expected: Vec<u32> = (0..points.len() as u32).collect();
        expected
            .sort_by_key(|&s| layout.key(coarse_cell(&grid, cell_of(&grid, points[s as usize]))));
        assert_eq!(cells.order(), expected);
    }

    #[test]
    fn lone_particles_have_no_particle_in_an_adjacent_cell_and_go_last() {
        let grid = grid();
        // Lone particles spread over metres, and pairs of particles a few cells apart.
        let mut unit = uniform(0x853c_49e6_748f_ea9b);
        let mut next = || unit() * 40.0 - 20.0;
        let mut points: Vec<[f64; 3]> = (0..3000).map(|_| [next(), next(), next()]).collect();
        for k in 0..300 {
            let p = points[k];
            points.push([p[0] + 0.0001 * k as f64, p[1] - 0.05, p[2] + 0.01]);
        }
        let particles = positions(&points);
        let mut cells = CellOrder::default();
        cells.sort(&grid, &particles);
        assert_eq!(cells.keys().len(), points.len() + SENTINELS);
        cells.sort(&grid, &particles);
        let paired = cells.keys().len() - SENTINELS;
        let coarse: Vec<Cell> = points
            .iter()
            .map(|&p| coarse_cell(&grid, cell_of(&grid, p)))
            .collect();
        let adjacent = |a: Cell, b: Cell| (0..3).all(|d| a[d].abs_diff(b[d]) <= 1);
        let order = cells.order();
        let mut slots = order.to_vec();
        slots.sort_unstable();
        assert_eq!(slots, (0..points.len() as u32).collect::<Vec<_>>());
        for &lone in &order[paired..] {
            let cell = coarse[lone as usize];
            let others = (0..points.len()).filter(|&s| s != lone as usize);
            assert!(
                others.into_iter().all(|s| !adjacent(cell, coarse[s])),
                "slot {lone}"
            );
        }
        // Lone particles keep their order; most of them are found (the filter counts
        // particles two cells away too).
        assert!(order[paired..].is_sorted());
        let truly_lone = (0..points.len())
            .filter(|&s| (0..points.len()).all(|t| t == s || !adjacent(coarse[s], coarse[t])))
            .count();
        assert!(
            points.len() - paired > truly_lone * 4 / 5,
            "{paired} of {truly_lone}"
        );
        assert!(cells.keys()[..paired].is_sorted());
    }

    #[test]
    fn the_lone_filter_calls_lone_exactly_what_its_rule_does_on_every_instruction_set() {
        let grid = grid();
        let mut unit = uniform(0x5851_f42d_4c95_7f2d);
        let mut next = || unit() * 10.0 - 5.0;
        let points: Vec<[f64; 3]> = (0..5003).map(|_| [next(), next(), next()]).collect();
        let particles = positions(&points);
        // The filter's rule, one particle at a time from a map of counts per hashed
        // block: lone where the 8 blocks around its cell hold no other particle.
        let coarse: Vec<Cell> = points
            .iter()
            .map(|&p| coarse_cell(&grid, cell_of(&grid, p)))
            .collect();
        let index_bits = (64 * points.len()).next_power_of_two().ilog2();
        let table = LoneFilter {
            shift: u64::BITS - index_bits,
            ..LoneFilter::default()
        };
        let slot_of = |block: Cell| table.hash(pack_block(block));
        let mut counts = std::collections::HashMap::<u64, u32>::new();
        for cell in &coarse {
            *counts.entry(slot_of(cell.map(|c| c >> 1))).or_default() += 1;
        }
        let count = |block: Cell| counts.get(&slot_of(block)).copied().unwrap_or(0);
        let expected_lone: Vec<u32> = (0..points.len() as u32)
            .filter(|&slot| {
                let cell = coarse[slot as usize];
                let mut total = u32::from(count(cell.map(|c| c >> 1)) >= 2);
                for k in 0..8 {
                    let block = std::array::from_fn(|d| ((cell[d] - 1) >> 1) + (k >> d & 1));
                    total += u32::from(count(block) >= 1);
                }
                total == 1
            })
            .collect();
        assert!(!expected_lone.is_empty() && expected_lone.len() < points.len());
        let mut ran = 0;
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let mut cells = CellOrder::resumed(true);
            cells.set_instruction_set(isa);
            cells.sort(&grid, &particles);
            let paired = cells.keys().len() - SENTINELS;
            assert_eq!(cells.order()[paired..], expected_lone, "{}", isa.name());
            let mut order = cells.order().to_vec();
            order.sort_unstable();
            assert!(order.iter().copied().eq(0..points.len() as u32));
            ran += 1;
        }
        if cfg!(target_arch = "x86_64") && InstructionSet::Avx2.is_available() {
            assert!(ran >= 2);
        }
    }

    /// 3003 points spread over 6 m (from `seed`), every tenth 2 mm from the one before.
    fn scattered_with_pairs(seed: u64) -> Vec<[f64; 3]> {
        let mut unit = uniform(seed);
        let mut points: Vec<[f64; 3]> = Vec::new();
        for k in 0..3003 {
            let point = if k % 10 == 1 {
                points[k - 1].map(|x| x + 0.002)
            } else {
                [0.0; 3].map(|_| unit() * 6.0 - 3.0)
            };
            points.push(point);
        }
        points
    }

    #[test]
    fn a_sort_in_place_orders_as_a_sort_whose_particles_are_moved() {
        let grid = grid();
        // Particles over metres, every tenth 2 mm from the one before; they move between
        // sorts.
        let points = scattered_with_pairs(0x2545_f491_4f6c_dd1d);
        let n = points.len();
        let mut stored = positions(&points);
        let (mut moving, mut staying) = (CellOrder::resumed(true), CellOrder::resumed(true));
        // The particles moved into each sort's order, and where each of them is stored.
        let mut placed = stored.clone();
        for round in 0..4 {
            let moved = moving.sort(&grid, &placed);
            assert!(!staying.sort_in_place(&grid, &stored));
            assert!(moved && staying.is_in_place() && !moving.is_in_place());
            let slots: Vec<u32> = moving
                .order()
                .iter()
                .map(|&s| placed.id[s as usize])
                .collect();
            assert_eq!(staying.order(), slots, "round {round}");
            assert_eq!(staying.keys(), moving.keys());
            let paired = moving.keys().len() - SENTINELS;
            assert!(paired > 0 && paired < n / 2, "{paired}");
            assert_eq!(staying.paired(), &slots[..paired]);
            for (slot, &at) in slots.iter().enumerate() {
                let walls = staying.walls().bits()[at as usize];
                assert_eq!(walls, moving.walls().bits()[slot]);
            }
            placed = placed.permuted(moving.order());
            // Every particle moves by a few cells, by its id.
            for particles in [&mut stored, &mut placed] {
                for (d, axis) in particles.p.iter_mut().enumerate() {
                    for (x, &id) in axis.iter_mut().zip(&particles.id) {
                        *x += 0.01 * ((id as usize * 7 + d * 3 + round) % 5) as f64 - 0.02;
                    }
                }
            }
        }
        // A sort that moves the particles after one that left them in place reads them
        // in its slot order.
        assert!(staying.sort(&grid, &stored));
        moving.sort(&grid, &placed);
        let slots: Vec<u32> = moving
            .order()
            .iter()
            .map(|&s| placed.id[s as usize])
            .collect();
        assert_eq!(staying.order(), slots);
        assert_eq!(staying.keys(), moving.keys());
        assert_eq!(staying.walls(), moving.walls());
        assert!(!staying.is_in_place());
    }

    #[test]
    fn kept_slots_go_first_in_their_order_and_the_others_follow_before_the_lone() {
        let grid = grid();
        // Mostly lone particles over metres, every tenth 2 mm from the one before.
        let points = scattered_with_pairs(0x9e37_79b9_7f4a_7c15);
        let stored = positions(&points);
        // With the lone filter, and without it (every particle then sorted).
        for filter in [Some(DEFAULT_FILTER_BLOCKS), None] {
            let mut cells = CellOrder::resumed(true);
            cells.set_lone_filter(filter);
            assert!(!cells.sort_in_place(&grid, &stored));
            assert!(cells.is_in_place(), "{filter:?}");
            let (keys, order) = (cells.keys().to_vec(), cells.order().to_vec());
            let paired = cells.paired().to_vec();
            assert_eq!(paired.len() == points.len(), filter.is_none());
            let keep: Vec<bool> = (0..paired.len()).map(|slot| slot % 3 != 1).collect();
            cells.keep_paired(&keep);
            let marked = |wanted: bool| {
                let keep = &keep;
                let slots = (0..paired.len()).filter(move |&slot| keep[slot] == wanted);
                slots.map(|slot| (paired[slot], keys[slot])).unzip()
            };
            let (kept, kept_keys): (Vec<u32>, Vec<u64>) = marked(true);
            let (others, _): (Vec<u32>, Vec<u64>) = marked(false);
            assert_eq!(cells.paired(), kept);
            assert_eq!(cells.keys()[..kept.len()], kept_keys);
            assert_eq!(cells.keys()[kept.len()..], [u64::MAX; SENTINELS]);
            assert_eq!(cells.order()[kept.len()..paired.len()], others);
            assert_eq!(cells.order()[paired.len()..], order[paired.len()..]);
        }
    }

    #[test]
    fn walls_can_come_from_recorded_blocks() {
        let grid = grid();
        let points = positions(&[[0.0, 0.0, 0.0]]);
        let corner = grid.index([grid.dims[0] - 1, 0, 3]) as u32;
        let mut cells = CellOrder::default();
        cells.sort_with_blocks(&grid, &points, &[corner]);
        assert_eq!(cells.walls().on(0, Wall::High), [0]);
        assert_eq!(cells.walls().on(1, Wall::Low), [0]);
        assert!(cells.walls().on(2, Wall::Low).is_empty());
    }
}
