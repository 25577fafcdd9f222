//! Neighbour lists: for each slot, the later slots of its tiles closer than a reach (the
//! cut-off, plus a skin where lists are kept over steps), so that the pair loops fill
//! every lane of a register with a pair instead of testing the candidates of whole cells
//! (about one in six closer than h) in each pass.
//!
//! A list holds each pair once (a *half* list: the partners after a slot in its own cell
//! and those of its 13 forward cells, as the tiles give them), as slot indices in cell
//! order. The build copies each cell's candidates (its own slots, then its forward
//! cells') into one run narrowed to f32 and tests each of its particles against them 16
//! at a time; the hits are left-packed into the list (`vpcompressd` on AVX-512, through
//! `sim::isa`); the density and acceleration passes of the same
//! placement share it. The last group of a list reads the slots after its end (the next
//! lists', then [`TAIL`] zeros), which the loops mask.
//!
//! Where the passes run across particles ([`ListLayout::Rows`]), the build then mirrors
//! the half lists into [`Rows`]: every slot's full list, 8 slots to a block.

use crate::sim::isa::{Gathers, InstructionSet, OnInstructionSet};
use crate::sim::neighbours::Tile;
use crate::sim::particles::{AxisArrays, PADDING};
use wide::f32x16;

/// The neighbour structure the SIMD pair loops run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum PairStructure {
    /// The tiles of whole neighbour cells (`sim::neighbours`), for comparison: what the
    /// scalar and reference kernels and scattered scenes run on either way.
    Tiles,
    /// Each particle's half list of partners within the cut-off, one particle at a time
    /// with its partners in the lanes, on dense scenes, for every model on the simd,
    /// simd8 and mixed kernels (tiles elsewhere): the fastest on every machine measured
    /// (perf/README.md, round five).
    #[default]
    Lists,
    /// As lists, but the passes read every particle's full list in rows of 8 particles
    /// (SELL-8), a particle per lane (each pair twice, nothing written to a partner; the
    /// weakly compressible model's wall images still from the half lists).
    Rows,
}

impl PairStructure {
    /// Every structure.
    pub const ALL: [PairStructure; 3] = [
        PairStructure::Tiles,
        PairStructure::Lists,
        PairStructure::Rows,
    ];

    /// Its name on the command line and in checkpoints.
    pub fn name(self) -> &'static str {
        match self {
            PairStructure::Tiles => "tiles",
            PairStructure::Lists => "lists",
            PairStructure::Rows => "rows",
        }
    }

    /// Whether the pair loops run on neighbour lists (half lists or rows).
    pub fn is_listed(self) -> bool {
        self != PairStructure::Tiles
    }
}

/// Entries after the last list, so that a group of 8 read from any list's start stays in
/// the array.
pub const TAIL: usize = 8;

/// Candidates the build tests at once, in f32 lanes.
const FILTER_LANES: usize = 16;

/// The most partners the lists hold per slot, on average, before a build gives up: a
/// collapsed scene's pairs grow as the square of its particles, and lists of them would
/// take more memory than the particles (its passes run on the tiles instead).
pub const MOST_PARTNERS_PER_SLOT: usize = 256;

/// A build given up: the pairs within reach would exceed [`MOST_PARTNERS_PER_SLOT`] per
/// slot (or the u32 entries' range).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TooManyPairs;

/// The neighbour lists of one placement.
#[derive(Debug, Clone, Default)]
pub struct NeighbourLists {
    /// Where each slot's partners start in `partners`, then the end of the last.
    starts: Vec<u32>,
    /// Every slot's partners, in slot order, then [`TAIL`] zeros (and spare room).
    partners: Vec<u32>,
    /// The slots the lists cover: every index is below it.
    slots: usize,
    /// The instruction set the lists are built and run with.
    isa: InstructionSet,
    /// The positions narrowed to f32 for the build's filter.
    narrowed: [Vec<f32>; 3],
    /// The build's candidates of one cell.
    candidates: Candidates,
    /// Every slot's full list as rows, where the passes run across particles.
    rows: Rows,
    /// Whether the build also writes [`Rows`].
    layout: ListLayout,
    /// Whether `rows` are of the last build.
    rows_built: bool,
}

/// How the course models' SIMD passes read the lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ListLayout {
    /// The half lists, one particle at a time, its partners in the lanes (each pair once,
    /// its terms written to the partner too).
    #[default]
    Half,
    /// The full lists in [`Rows`], a particle per lane (each pair twice, nothing written
    /// to a partner).
    Rows,
}

impl NeighbourLists {
    /// Lists of the `slots` first slots: for each slot of each tile's first range, its
    /// partners in the tile closer than `reach` at positions `p` (padded by [`PADDING`]).
    /// Fails, leaving no lists, where they would hold more than
    /// [`MOST_PARTNERS_PER_SLOT`] per slot.
    pub fn build(
        &mut self,
        tiles: &[Tile],
        p: &AxisArrays,
        slots: usize,
        reach: f64,
    ) -> Result<(), TooManyPairs> {
        assert!(p.iter().all(|axis| axis.len() >= slots + PADDING));
        assert!(tiles.iter().all(|tile| tile.second_end as usize <= slots));
        self.slots = slots;
        self.starts.clear();
        self.rows_built = false;
        let built = self.isa.run(Build {
            lists: self,
            tiles,
            p,
            reach,
        });
        if built.is_err() {
            self.slots = 0;
            self.starts.clear();
            self.partners.clear();
            self.partners.shrink_to_fit();
            self.rows = Rows::default();
        } else if self.layout == ListLayout::Rows {
            let mut rows = std::mem::take(&mut self.rows);
            rows.mirror(self);
            self.rows = rows;
            self.rows_built = true;
        }
        built
    }

    /// How the passes read the lists (from the next build on).
    pub fn set_layout(&mut self, layout: ListLayout) {
        self.rows_built &= layout == self.layout;
        self.layout = layout;
    }

    /// The full lists as rows, if the last build wrote them ([`ListLayout::Rows`]).
    pub fn rows(&self) -> Option<&Rows> {
        self.rows_built.then_some(&self.rows)
    }

    /// The instruction set the lists are built and run with.
    pub fn instruction_set(&self) -> InstructionSet {
        self.isa
    }

    /// Builds and runs the lists with `isa` from now on (the lists are the same on every
    /// instruction set).
    ///
    /// # Panics
    /// If this CPU does not run it.
    pub fn set_instruction_set(&mut self, isa: InstructionSet) {
        assert!(isa.is_available(), "this CPU does not run {}", isa.name());
        self.isa = isa;
    }

    /// The slots the lists cover.
    pub fn slots(&self) -> usize {
        self.slots
    }

    /// Where the partners of `slot` are in [`Self::entries`].
    #[inline(always)]
    pub fn range(&self, slot: usize) -> std::ops::Range<usize> {
        self.starts[slot] as usize..self.starts[slot + 1] as usize
    }

    /// Every list, one after the other, then at least [`TAIL`] zeros.
    pub fn entries(&self) -> &[u32] {
        &self.partners
    }

    /// The partners of `slot`.
    pub fn partners(&self, slot: usize) -> &[u32] {
        &self.partners[self.range(slot)]
    }

    /// The pairs listed.
    pub fn pairs(&self) -> usize {
        self.starts.last().map_or(0, |&end| end as usize)
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.starts)
            + bytes(&self.partners)
            + self.narrowed.iter().map(bytes).sum::<usize>()
            + self.candidates.p.iter().map(bytes).sum::<usize>()
            + bytes(&self.candidates.slots)
            + self.rows.heap_bytes()
    }
}

/// Slots per block of [`Rows`]: the lanes of an `f64x8` register, two `f64x4` ones.
pub const ROW: usize = 8;

/// Every slot's *full* list (the partners before it, in slot order, then its half list)
/// in the layout GROMACS' and SELL-C's kernels read across particles: the slots in
/// blocks of [`ROW`], and block b's row m holding the m-th partner of each of its slots,
/// so that a register holds a partner of each of [`ROW`] particles. A block has as many
/// rows as its longest list; a shorter list, and a slot past the last, is padded with
/// [`Rows::far`], the slot count, which names no particle (the passes give it a record
/// far from everything).
#[derive(Debug, Clone, Default)]
pub struct Rows {
    /// Where each block's rows start, then the end of the last.
    starts: Vec<u32>,
    /// The rows.
    entries: Vec<[u32; ROW]>,
    /// Each slot's partners (then 0 to the end of the last block).
    lengths: Vec<u32>,
    /// The build's cursor of each slot: its next free row.
    next: Vec<u32>,
    /// The slots covered.
    slots: usize,
}

impl Rows {
    /// Writes the rows of `half`'s lists: each pair in both of its slots' lists, in one
    /// pass over the half lists in slot order (so a slot's earlier partners are in its
    /// rows, in order, when its own half list follows them).
    fn mirror(&mut self, half: &NeighbourLists) {
        let n = half.slots;
        self.slots = n;
        let Rows {
            starts,
            entries,
            lengths,
            next,
            ..
        } = self;
        lengths.clear();
        lengths.extend((0..n).map(|i| half.range(i).len() as u32));
        for &i in &half.partners[..half.pairs()] {
            lengths[i as usize] += 1;
        }
        lengths.resize(n.next_multiple_of(ROW), 0);
        starts.clear();
        let mut end = 0usize;
        for block_lengths in lengths.chunks_exact(ROW) {
            starts.push(end as u32);
            end += block_lengths.iter().max().copied().unwrap_or(0) as usize;
        }
        // Twice the half lists' entries, which stay within u32, may not.
        assert!(end <= u32::MAX as usize, "more rows than u32 indexes");
        starts.push(end as u32);
        entries.clear();
        entries.resize(end, [n as u32; ROW]);
        // Each slot's next free row.
        next.clear();
        next.resize(n, 0);
        for j in 0..n {
            let (first_row, lane) = (starts[j / ROW] as usize, j % ROW);
            let own = next[j] as usize;
            for (m, &i) in half.partners(j).iter().enumerate() {
                entries[first_row + own + m][lane] = i;
                let i = i as usize;
                // A half list holds later slots only, whose earlier partners are written
                // in slot order before their own lists.
                debug_assert!(i > j);
                entries[starts[i / ROW] as usize + next[i] as usize][i % ROW] = j as u32;
                next[i] += 1;
            }
        }
    }

    /// The padding slot: the slot count.
    pub fn far(&self) -> u32 {
        self.slots as u32
    }

    /// The blocks of [`ROW`] slots (the last may be partial).
    pub fn blocks(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// The rows of block `block`.
    #[inline(always)]
    pub fn rows(&self, block: usize) -> &[[u32; ROW]] {
        &self.entries[self.starts[block] as usize..self.starts[block + 1] as usize]
    }

    /// The lengths of the full lists of block `block`'s slots (0 past the last slot): in
    /// lane k, the rows from the k-th length on are padding.
    #[inline(always)]
    pub fn lengths(&self, block: usize) -> &[u32; ROW] {
        self.lengths[block * ROW..][..ROW]
            .try_into()
            .expect("whole blocks")
    }

    /// The full list of `slot`, in order.
    pub fn list(&self, slot: usize) -> impl Iterator<Item = u32> + '_ {
        let rows = self.rows(slot / ROW);
        rows[..self.lengths[slot] as usize]
            .iter()
            .map(move |row| row[slot % ROW])
    }

    /// The entries held, padding included.
    pub fn entries(&self) -> usize {
        self.entries.len() * ROW
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.starts) + bytes(&self.entries) + bytes(&self.lengths) + bytes(&self.next)
    }
}

/// The build on one instruction set.
struct Build<'a> {
    lists: &'a mut NeighbourLists,
    tiles: &'a [Tile],
    p: &'a AxisArrays,
    reach: f64,
}

impl OnInstructionSet for Build<'_> {
    type Output = Result<(), TooManyPairs>;

    fn run<G: Gathers>(self, isa: G) -> Result<(), TooManyPairs> {
        let Build {
            lists,
            tiles,
            p,
            reach,
        } = self;
        let NeighbourLists {
            starts,
            partners,
            slots,
            narrowed,
            candidates,
            ..
        } = lists;
        let n = *slots;
        // The positions narrowed once; rounding moves each coordinate by at most half
        // an f32 epsilon of the largest, a distance by less than two, and the squared
        // distance's own rounding is a few epsilons more: within the limit below, no
        // pair closer than the reach is missed.
        let mut largest = 0.0f64;
        for (copy, axis) in narrowed.iter_mut().zip(p) {
            copy.clear();
            copy.extend(axis[..n].iter().map(|&x| {
                largest = largest.max(x.abs());
                x as f32
            }));
            // Room for the candidates' copies, a group at a time.
            copy.extend([0.0; FILTER_LANES]);
        }
        let epsilon = f64::from(f32::EPSILON);
        let limit = (reach + 2.0 * epsilon * largest) * (1.0 + 4.0 * epsilon);
        let limit2 = f32x16::splat((limit * limit) as f32);
        let lane = f32x16::from(std::array::from_fn::<f32, FILTER_LANES, _>(|k| k as f32));
        let [x, y, z] = &*narrowed;
        // Every entry, and so every start, stays within u32.
        let capacity = n
            .saturating_mul(MOST_PARTNERS_PER_SLOT)
            .min(u32::MAX as usize - FILTER_LANES - TAIL);
        let mut end = 0;
        for cell_tiles in tiles.chunk_by(|a, b| a.first == b.first) {
            // The cell's candidates in one run: its own slots, then those of its
            // forward neighbours (all after its own); a particle's partners are the
            // candidates after it.
            let own = cell_tiles[0].firsts();
            let forward = cell_tiles.iter().filter(|tile| !tile.is_within_cell());
            let most = forward
                .map(|tile| tile.second_end - tile.second)
                .sum::<u32>();
            candidates.clear(own.len() + most as usize);
            candidates.add(own.clone(), [x, y, z]);
            for tile in cell_tiles.iter().filter(|tile| !tile.is_within_cell()) {
                candidates.add(tile.second as usize..tile.second_end as usize, [x, y, z]);
            }
            candidates.pad();
            // Slots without tiles (lone, or alone in a cell without forward neighbours)
            // have empty lists.
            starts.resize(own.start, end as u32);
            for i in own.clone() {
                // Room for the list were every candidate kept, the last group's store of
                // 16 and the tail (grown by an eighth at least: the lists' memory stays
                // close to what they hold).
                if end + candidates.len() > capacity {
                    return Err(TooManyPairs);
                }
                let room = end + candidates.len() + FILTER_LANES + TAIL;
                if partners.len() < room {
                    let grown = room.max(partners.len() + partners.len() / 8);
                    partners.reserve_exact(grown - partners.len());
                    partners.resize(grown, 0);
                }
                starts.push(end as u32);
                let first = [x[i], y[i], z[i]].map(f32x16::splat);
                let position = (i - own.start) as f32;
                for g in (0..candidates.len()).step_by(FILTER_LANES) {
                    let [cx, cy, cz] = candidates.positions(g);
                    let (dx, dy, dz) = (first[0] - cx, first[1] - cy, first[2] - cz);
                    let r2 = dx * dx + dy * dy + dz * dz;
                    let after = lane.simd_gt(f32x16::splat(position - g as f32));
                    let kept = (r2.simd_lt(limit2) & after).to_bitmask() as u16;
                    end += isa.left_pack(kept, candidates.slots(g), &mut partners[end..]);
                }
            }
        }
        starts.resize(n + 1, end as u32);
        partners.resize(partners.len().max(end + TAIL), 0);
        partners[end..end + TAIL].fill(0);
        Ok(())
    }
}

/// A cell's candidates during the build: narrowed positions and slots, padded to whole
/// groups with candidates infinitely far. Ranges are copied a group at a time (past
/// their end into spare room, overwritten by the next), not by a copy call each.
#[derive(Debug, Clone, Default)]
struct Candidates {
    p: [Vec<f32>; 3],
    slots: Vec<u32>,
    /// The candidates so far.
    len: usize,
}

/// A group of `FILTER_LANES` from `at` of `values`.
#[inline(always)]
fn group_of<T>(values: &[T], at: usize) -> &[T; FILTER_LANES] {
    values[at..at + FILTER_LANES].try_into().unwrap()
}

/// The same, to write.
#[inline(always)]
fn group_of_mut<T>(values: &mut [T], at: usize) -> &mut [T; FILTER_LANES] {
    (&mut values[at..at + FILTER_LANES]).try_into().unwrap()
}

impl Candidates {
    /// Empties it, with room for `most` candidates (and the spare groups).
    fn clear(&mut self, most: usize) {
        let room = most + 2 * FILTER_LANES;
        if self.slots.len() < room {
            self.p.iter_mut().for_each(|axis| axis.resize(room, 0.0));
            self.slots.resize(room, 0);
        }
        self.len = 0;
    }

    /// Appends the slots of `range` with their positions `p` (each padded by a group).
    #[inline(always)]
    fn add(&mut self, range: std::ops::Range<usize>, p: [&Vec<f32>; 3]) {
        for offset in (0..range.len()).step_by(FILTER_LANES) {
            let (from, to) = (range.start + offset, self.len + offset);
            for (copy, axis) in self.p.iter_mut().zip(p) {
                *group_of_mut(copy, to) = *group_of(axis, from);
            }
            *group_of_mut(&mut self.slots, to) = std::array::from_fn(|k| (from + k) as u32);
        }
        self.len += range.len();
    }

    /// Pads to whole groups.
    fn pad(&mut self) {
        for copy in &mut self.p {
            *group_of_mut(copy, self.len) = [f32::INFINITY; FILTER_LANES];
        }
        self.len = self.len.next_multiple_of(FILTER_LANES);
    }

    /// The candidates (padding included).
    fn len(&self) -> usize {
        self.len
    }

    /// The positions of the group from `g`.
    #[inline(always)]
    fn positions(&self, g: usize) -> [f32x16; 3] {
        self.p
            .each_ref()
            .map(|axis| f32x16::from(*group_of(axis, g)))
    }

    /// The slots of the group from `g`.
    #[inline(always)]
    fn slots(&self, g: usize) -> &[u32; FILTER_LANES] {
        group_of(&self.slots, g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::jittered_block;
    use crate::sim::neighbours::TileSearch;
    use crate::sim::params::Params;
    use crate::sim::particles::Particles;

    /// A jittered block of `side`^3 particles a spacing apart, in cell order, with its
    /// tiles.
    fn block(ppm: f64, side: usize) -> (Particles, TileSearch) {
        let (placed, cells, _) = jittered_block(ppm, side, 0.4, 11);
        let mut search = TileSearch::default();
        search.find(cells.keys(), cells.layout());
        (placed, search)
    }

    #[test]
    fn the_lists_hold_every_pair_closer_than_the_reach_once_on_every_instruction_set() {
        let ppm = 200.0;
        let h = Params::new(ppm).h;
        let (particles, search) = block(ppm, 11);
        let n = particles.len();
        // Within the cells' side, which is at least h.
        let reach = 0.999 * h;
        let mut every = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                let r2 = particles
                    .position(a)
                    .distance_squared(particles.position(b));
                if r2 < reach * reach {
                    every.push((a as u32, b as u32));
                }
            }
        }
        assert!(every.len() > 10 * n / 2, "{} pairs", every.len());
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let mut lists = NeighbourLists::default();
            lists.set_instruction_set(isa);
            lists.build(search.tiles(), &particles.p, n, reach).unwrap();
            assert_eq!(lists.slots(), n);
            let mut found: Vec<(u32, u32)> = (0..n)
                .flat_map(|i| lists.partners(i).iter().map(move |&j| (i as u32, j)))
                .map(|(i, j)| (i.min(j), i.max(j)))
                .collect();
            assert_eq!(found.len(), lists.pairs());
            found.sort_unstable();
            let count = found.len();
            found.dedup();
            assert_eq!(found.len(), count, "{}: a pair twice", isa.name());
            // Every pair within the reach, and the few the f32 filter's margin lets in
            // (within 1e-5 of it).
            let far = |&(a, b): &(u32, u32)| {
                let r2 = particles
                    .position(a as usize)
                    .distance_squared(particles.position(b as usize));
                r2 >= reach * reach
            };
            let beyond: Vec<_> = found.iter().filter(|pair| far(pair)).copied().collect();
            for &(a, b) in &beyond {
                let r = particles
                    .position(a as usize)
                    .distance(particles.position(b as usize));
                assert!(
                    r < reach * (1.0 + 1e-5),
                    "{}: {a}, {b} listed {r}",
                    isa.name()
                );
            }
            found.retain(|pair| !far(pair));
            assert!(found == every, "{}: other pairs", isa.name());
            assert!(lists.entries().len() >= lists.pairs() + TAIL);
            assert!(lists.entries()[lists.pairs()..][..TAIL]
                .iter()
                .all(|&j| j == 0));
        }
    }

    #[test]
    fn the_rows_hold_each_slots_earlier_partners_in_order_then_its_later_ones() {
        let ppm = 200.0;
        let (particles, search) = block(ppm, 9);
        // A count that leaves the last block partial.
        let n = particles.len() - 3;
        assert_ne!(n % ROW, 0);
        let tiles: Vec<Tile> = search
            .tiles()
            .iter()
            .filter(|tile| tile.second_end as usize <= n && (tile.first_end as usize) <= n)
            .copied()
            .collect();
        let mut lists = NeighbourLists::default();
        lists.set_layout(ListLayout::Rows);
        lists
            .build(&tiles, &particles.p, n, Params::new(ppm).h)
            .unwrap();
        let rows = lists.rows().expect("rows asked for");
        assert_eq!((rows.far() as usize, rows.blocks()), (n, n.div_ceil(ROW)));
        let mut earlier = vec![Vec::new(); n];
        for j in 0..n {
            for &i in lists.partners(j) {
                earlier[i as usize].push(j as u32);
            }
        }
        let mut padded = 0;
        for slot in 0..n {
            let full: Vec<u32> = rows.list(slot).collect();
            let expected: Vec<u32> = earlier[slot]
                .iter()
                .chain(lists.partners(slot))
                .copied()
                .collect();
            assert!(full == expected, "slot {slot}");
            let lane = rows.rows(slot / ROW).iter().map(|row| row[slot % ROW]);
            let padding: Vec<u32> = lane.skip(full.len()).collect();
            assert!(padding.iter().all(|&j| j == rows.far()));
            padded += padding.len();
        }
        assert_eq!(
            rows.entries(),
            2 * lists.pairs() + padded + rows.rows(n / ROW).len() * (ROW - n % ROW)
        );
        lists.set_layout(ListLayout::Half);
        assert!(lists.rows().is_none());
    }

    #[test]
    fn a_collapsed_block_is_not_listed() {
        // 729 particles within h / 2 of each other: 265,356 pairs, above 256 per slot.
        let ppm = 200.0;
        let h = Params::new(ppm).h;
        let mut particles = jittered_block(ppm, 9, 0.4, 5).0.unpadded();
        for axis in &mut particles.p {
            let low = axis.iter().copied().fold(f64::INFINITY, f64::min);
            axis.iter_mut().for_each(|x| *x = low + (*x - low) / 20.0);
        }
        let mut cells = crate::sim::cells::CellOrder::default();
        cells.sort(
            &crate::sim::grid::Grid::new(h, &crate::sim::params::Domain::COURSE).unwrap(),
            &particles,
        );
        let mut placed = particles.permuted(cells.order());
        placed.pad();
        let mut search = TileSearch::default();
        search.find(cells.keys(), cells.layout());
        for isa in InstructionSet::ALL
            .into_iter()
            .filter(|isa| isa.is_available())
        {
            let mut lists = NeighbourLists::default();
            lists.set_instruction_set(isa);
            let built = lists.build(search.tiles(), &placed.p, 729, h);
            assert_eq!(built, Err(TooManyPairs), "{}", isa.name());
            assert_eq!((lists.slots(), lists.pairs()), (0, 0));
            assert!(lists.heap_bytes() < 729 * MOST_PARTNERS_PER_SLOT * 4);
        }
    }
}
