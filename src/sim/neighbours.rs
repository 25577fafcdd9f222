//! The neighbour search: which slots the pair loops compare, as *tiles* of contiguous
//! slot ranges over the cell order.
//!
//! Each occupied cell is compared with itself (later slots only) and with its 13 forward
//! neighbours (the adjacent cells with a larger key), so every pair of particles in
//! adjacent cells, and so every pair closer than h, is visited exactly once. Because keys
//! run x fastest, the three cells x-1..x+1 of a neighbour row are contiguous slots: the 13
//! neighbours are 5 slot ranges (the cell at x+1, the row at y+1, the three rows at z+1).
//! They are found by 5 cursors that only move forward through the sorted keys, so the
//! search costs O(particles + occupied cells) and never touches an empty cell. Two cheap
//! tests per cell (is there any key near it in its plane, in the next plane?) settle the
//! usual case of a particle far outside the box.

use crate::sim::cells::{CellLayout, SENTINELS};
use crate::sim::particles::AxisArrays;

/// A set of candidate pairs: every slot of `first..first_end` with every slot of
/// `second..second_end`, or, for a cell with itself (`first == second`), every pair of its
/// slots once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile {
    /// First slot of the cell whose particles are the first of each pair.
    pub first: u32,
    /// End of that cell's slots.
    pub first_end: u32,
    /// First slot of the partner range.
    pub second: u32,
    /// End of the partner range.
    pub second_end: u32,
}

impl Tile {
    /// Whether the tile pairs a cell with itself.
    pub fn is_within_cell(&self) -> bool {
        self.first == self.second
    }

    /// The partner slots of the particle in `slot` (one of the first range).
    pub fn partners(&self, slot: usize) -> std::ops::Range<usize> {
        let start = if self.is_within_cell() {
            slot + 1
        } else {
            self.second as usize
        };
        start..self.second_end as usize
    }

    /// The slots of the first range.
    pub fn firsts(&self) -> std::ops::Range<usize> {
        self.first as usize..self.first_end as usize
    }
}

/// The forward neighbour rows of a cell: whether the row is only the cell x+1 (else the
/// cells x-1..x+1), and the row's y and z offsets.
const FORWARD_ROWS: [(bool, i64, u32); 5] = [
    (true, 0, 0),
    (false, 1, 0),
    (false, -1, 1),
    (false, 0, 1),
    (false, 1, 1),
];

/// The first index from `from` on whose key is not below `bound` (keys ascending and
/// ending with [`SENTINELS`] maximal keys). Counts four keys at a time without branching on
/// each, as the cursors of a sparse scene move by a few keys in no predictable pattern.
fn first_not_below(keys: &[u64], mut from: usize, bound: u64) -> usize {
    loop {
        let group = &keys[from..from + SENTINELS];
        let below: usize = group.iter().map(|&k| usize::from(k < bound)).sum();
        from += below;
        if below < SENTINELS {
            return from;
        }
    }
}

/// The tiles of one step, and the list of occupied cells they are found from (reused
/// from step to step).
#[derive(Debug, Clone, Default)]
pub struct TileSearch {
    tiles: Vec<Tile>,
    /// Key of each occupied cell, ascending, then [`SENTINELS`] times `u64::MAX`.
    cell_keys: Vec<u64>,
    /// First slot of each occupied cell, then the particle count ([`SENTINELS`] times).
    cell_starts: Vec<u32>,
    /// The keys near occupied cells, for scenes of mostly lone particles.
    near: NearKeys,
    /// Which slots have a partner closer than a reach ([`Self::find_partnered`]).
    partnered: Vec<bool>,
    /// Each slot's number among those kept, then their count ([`Self::keep_partnered`]).
    renumbered: Vec<u32>,
}

/// A filter of the keys within 1 of an occupied cell's key: bit `k % 64` of the word at
/// a hash of `k / 64` is set for each such key `k`. It never misses such a key and rarely
/// holds another (its table has a word or two per cell), so one probe settles a forward
/// row x-1..x+1 of a cell, whose keys are contiguous, for the usual far particle.
#[derive(Debug, Clone, Default)]
struct NearKeys {
    words: Vec<u64>,
    /// 64 minus the table's index bits.
    shift: u32,
}

impl NearKeys {
    /// Fills the filter with the keys within 1 of each of `cell_keys`.
    fn fill(&mut self, cell_keys: &[u64]) {
        let index_bits = cell_keys.len().max(64).next_power_of_two().ilog2();
        self.shift = u64::BITS - index_bits;
        self.words.clear();
        self.words.resize(1 << index_bits, 0);
        // Keys k / 64 wrap at 2^58 as k does at 2^64.
        const GROUPS: u64 = 1 << 58;
        for &key in cell_keys {
            // The bits of key - 1, key and key + 1: one word, or two where they straddle.
            let low = key.wrapping_sub(1);
            let bits = 0b111u128 << (low % 64);
            let word = self.word_of_group(low / 64);
            self.words[word] |= bits as u64;
            let carried = (bits >> 64) as u64;
            if carried != 0 {
                let next = self.word_of_group((low / 64 + 1) % GROUPS);
                self.words[next] |= carried;
            }
        }
    }

    fn word(&self, key: u64) -> usize {
        self.word_of_group(key / 64)
    }

    /// The word of the keys 64 `group`..64 `group` + 63.
    fn word_of_group(&self, group: u64) -> usize {
        (group.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> self.shift) as usize
    }

    /// Whether `key` may be within 1 of an occupied cell's key (surely not if false).
    fn may_hold(&self, key: u64) -> bool {
        self.words[self.word(key)] >> (key % 64) & 1 != 0
    }
}

impl TileSearch {
    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.tiles)
            + bytes(&self.cell_keys)
            + bytes(&self.cell_starts)
            + bytes(&self.near.words)
            + bytes(&self.partnered)
            + bytes(&self.renumbered)
    }

    /// The tiles found last. A cell's tiles are consecutive: its own (if it holds two
    /// particles or more), then its rows.
    pub fn tiles(&self) -> &[Tile] {
        &self.tiles
    }

    /// Finds the tiles of the particles whose sorted cell keys are `keys` (ascending,
    /// ending with [`SENTINELS`] times `u64::MAX`), packed by `layout`. The cursors move
    /// over occupied cells, not particles.
    pub fn find(&mut self, keys: &[u64], layout: &CellLayout) {
        self.collect_cells(keys);
        let Self {
            tiles,
            cell_keys,
            cell_starts,
            near,
            ..
        } = self;
        tiles.clear();
        let cells = cell_keys.len() - SENTINELS;
        let particles = cell_starts[cells] as usize;
        // Mostly lone particles (far from the box): probe the filter for each row.
        let sparse = 2 * cells > particles;
        if sparse {
            near.fill(&cell_keys[..cells]);
        }
        let [ex, ey, ez] = layout.extent();
        let [_, shift_y, shift_z] = layout.shift();
        let (row, plane) = (1u64 << shift_y, 1u64 << shift_z);
        let mut cursors = [0usize; FORWARD_ROWS.len()];
        let mut plane_cursor = 0;
        for cell in 0..cells {
            let key = cell_keys[cell];
            let (start, end) = (cell_starts[cell], cell_starts[cell + 1]);
            let tile = |second: u32, second_end: u32| Tile {
                first: start,
                first_end: end,
                second,
                second_end,
            };
            if end - start > 1 {
                tiles.push(tile(start, end));
            }
            let [x, y, z] = layout.unpack(key);
            // Which forward rows may hold a cell: bit r for row r of FORWARD_ROWS.
            let candidates = if sparse {
                // The row x+1 of (y, z) is the next cell or none.
                u8::from(cell_keys[cell + 1] == key + 1)
                    | u8::from(near.may_hold(key + row)) << 1
                    | u8::from(near.may_hold((key + plane).wrapping_sub(row))) << 2
                    | u8::from(near.may_hold(key + plane)) << 3
                    | u8::from(near.may_hold(key + plane + row)) << 4
            } else {
                let (x1, y1) = ((x + 1).min(ex), (y + 1).min(ey));
                // Cheap tests first: a forward neighbour in plane z has a key up to that
                // of (x+1, y+1, z), so the next cell tells; plane z+1 has one forward-only
                // cursor over the cells of its rows y-1..y+1.
                let in_plane = cell_keys[cell + 1] <= layout.pack([x1, y1, z]);
                let in_next_plane = z < ez && {
                    let low = layout.pack([x.saturating_sub(1), y.saturating_sub(1), z + 1]);
                    plane_cursor = first_not_below(cell_keys, plane_cursor, low);
                    cell_keys[plane_cursor] <= layout.pack([x1, y1, z + 1])
                };
                (u8::from(in_plane) * 0b00011) | (u8::from(in_next_plane) * 0b11100)
            };
            if candidates == 0 {
                continue;
            }
            for (r, (cursor, &(single, dy, dz))) in
                cursors.iter_mut().zip(&FORWARD_ROWS).enumerate()
            {
                if candidates >> r & 1 == 0 || (dz == 1 && z == ez) {
                    continue;
                }
                let Ok(ny) = u32::try_from(i64::from(y) + dy) else {
                    continue;
                };
                if ny > ey {
                    continue;
                }
                // The key of cell (x, ny, z + dz).
                let base = key - (u64::from(y) << shift_y)
                    + (u64::from(ny) << shift_y)
                    + (u64::from(dz) << shift_z);
                let (low, high) = if single {
                    if x == ex {
                        continue;
                    }
                    (base + 1, base + 1)
                } else {
                    (base - u64::from(x > 0), base + u64::from(x < ex))
                };
                *cursor = first_not_below(cell_keys, *cursor, low);
                let row_end = first_not_below(cell_keys, *cursor, high + 1);
                if row_end > *cursor {
                    tiles.push(tile(cell_starts[*cursor], cell_starts[row_end]));
                }
            }
        }
    }

    /// Which of the `n` slots of positions `p` (in the order of the last
    /// [`Self::find`]'s keys) have a partner closer than a reach: `r^2 < reach_squared`,
    /// with r^2 = dx^2 + dy^2 + dz^2 of the differences later slot minus earlier, as the
    /// pair passes compute it. Every such pair lies in the tiles, so the answer is exact:
    /// it depends on the positions alone, not on how the tiles group them.
    pub fn find_partnered(&mut self, p: &AxisArrays, n: usize, reach_squared: f64) -> &[bool] {
        let [x, y, z] = p.each_ref().map(|axis| &axis[..n]);
        self.partnered.clear();
        self.partnered.resize(n, false);
        let partnered = &mut self.partnered[..];
        for tile in &self.tiles {
            for i in tile.firsts() {
                let mut any = false;
                for j in tile.partners(i) {
                    let (dx, dy, dz) = (x[j] - x[i], y[j] - y[i], z[j] - z[i]);
                    let close = dx * dx + dy * dy + dz * dz < reach_squared;
                    partnered[j] |= close;
                    any |= close;
                }
                partnered[i] |= any;
            }
        }
        &self.partnered
    }

    /// Keeps the tiles' pairs among the slots the last [`Self::find_partnered`] marked,
    /// numbered as they are once the others are taken out of the order: the tiles that
    /// [`Self::find`] finds on the kept slots' keys, without a second search.
    pub fn keep_partnered(&mut self) {
        let Self {
            tiles,
            partnered,
            renumbered,
            ..
        } = self;
        renumbered.clear();
        let mut kept = 0;
        for &partnered in partnered.iter() {
            renumbered.push(kept);
            kept += u32::from(partnered);
        }
        renumbered.push(kept);
        let at = |slot: u32| renumbered[slot as usize];
        tiles.retain_mut(|tile| {
            let within_cell = tile.is_within_cell();
            *tile = Tile {
                first: at(tile.first),
                first_end: at(tile.first_end),
                second: at(tile.second),
                second_end: at(tile.second_end),
            };
            if within_cell {
                tile.first_end - tile.first > 1
            } else {
                tile.first_end > tile.first && tile.second_end > tile.second
            }
        });
    }

    /// The occupied cells of sorted `keys`: their keys and first slots, plus sentinels.
    /// Branch-free: every slot writes the next free entry, which only a new key keeps.
    fn collect_cells(&mut self, keys: &[u64]) {
        let n = keys.len().saturating_sub(SENTINELS);
        self.cell_keys.resize(n + SENTINELS, 0);
        self.cell_starts.resize(n + SENTINELS, 0);
        let mut cells = 0;
        let mut previous = u64::MAX;
        for (slot, &key) in keys[..n].iter().enumerate() {
            self.cell_keys[cells] = key;
            self.cell_starts[cells] = slot as u32;
            cells += usize::from(key != previous);
            previous = key;
        }
        self.cell_keys.truncate(cells);
        self.cell_starts.truncate(cells);
        self.cell_keys.extend([u64::MAX; SENTINELS]);
        self.cell_starts.extend([n as u32; SENTINELS]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::{cell_of, coarse_cell, CellOrder};
    use crate::sim::grid::Grid;
    use crate::sim::params::Params;
    use crate::sim::particles::Particles;
    use std::collections::BTreeSet;

    /// Every pair (lower slot first) that the tiles visit, failing on a repeat.
    fn visited_pairs(tiles: &[Tile]) -> BTreeSet<(usize, usize)> {
        let mut pairs = BTreeSet::new();
        for tile in tiles {
            for i in tile.firsts() {
                for j in tile.partners(i) {
                    assert!(
                        pairs.insert((i.min(j), i.max(j))),
                        "pair {i},{j} visited twice"
                    );
                }
            }
        }
        pairs
    }

    /// A deterministic cloud: half in the box, half scattered up to `spread` metres out,
    /// in clusters of `cluster` particles (so that far particles of a cluster are within h
    /// of each other).
    fn cloud(n: usize, spread: f64, cluster: usize) -> Vec<[f64; 3]> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points = Vec::new();
        while points.len() < n {
            let scale = if points.len() % 2 == 0 { 0.12 } else { spread };
            let centre = [next(), next(), next()].map(|u| (u - 0.5) * scale);
            for _ in 0..cluster {
                points.push([next(), next(), next()].map(|u| (u - 0.5) * 0.01));
                let last = points.last_mut().unwrap();
                for d in 0..3 {
                    last[d] += centre[d];
                }
            }
        }
        points
    }

    #[test]
    fn tiles_visit_every_close_pair_once_and_only_adjacent_cells() {
        let params = Params::new(204.0);
        let grid = Grid::new(params.h, &params.domain).unwrap();
        // Clusters of 4 make dense cells; lone particles far out make the sparse search.
        for (spread, cluster) in [(0.12, 4), (5.0, 4), (500.0, 4), (5.0, 1), (50.0, 1)] {
            let points = cloud(2000, spread, cluster);
            let mut particles = Particles::zeroed(points.len());
            particles.p = std::array::from_fn(|d| points.iter().map(|p| p[d]).collect());
            let mut cells = CellOrder::default();
            // The second sort leaves out the lone particles if the first found many.
            cells.sort(&grid, &particles);
            cells.sort(&grid, &particles);
            let paired = cells.keys().len() - SENTINELS;
            assert_eq!(paired < points.len(), cluster == 1, "spread {spread}");
            let mut search = TileSearch::default();
            search.find(cells.keys(), cells.layout());
            let tiles = search.tiles();
            let sorted: Vec<[f64; 3]> = cells.order().iter().map(|&s| points[s as usize]).collect();
            let visited = visited_pairs(tiles);
            let mut close = 0;
            for i in 0..sorted.len() {
                for j in i + 1..sorted.len() {
                    let r2: f64 = (0..3).map(|d| (sorted[i][d] - sorted[j][d]).powi(2)).sum();
                    let coarse = |p| coarse_cell(&grid, cell_of(&grid, p));
                    let (ci, cj) = (coarse(sorted[i]), coarse(sorted[j]));
                    let adjacent = (0..3).all(|d| (ci[d] - cj[d]).abs() <= 1);
                    assert_eq!(
                        visited.contains(&(i, j)),
                        adjacent,
                        "spread {spread}: {i},{j}"
                    );
                    if r2 < params.h2 {
                        assert!(adjacent, "close pair {i},{j} in cells {ci:?} {cj:?}");
                        close += 1;
                    }
                }
            }
            assert!(
                close > 100,
                "spread {spread}: only {close} close pairs tested"
            );
        }
    }

    #[test]
    fn partners_are_found_exactly_and_kept_tiles_are_those_of_the_kept_slots() {
        let params = Params::new(204.0);
        let grid = Grid::new(params.h, &params.domain).unwrap();
        for (spread, cluster) in [(0.12, 4), (5.0, 4), (50.0, 2)] {
            let points = cloud(2000, spread, cluster);
            let mut particles = Particles::zeroed(points.len());
            particles.p = std::array::from_fn(|d| points.iter().map(|p| p[d]).collect());
            let mut cells = CellOrder::default();
            cells.sort(&grid, &particles);
            let sorted = particles.permuted(cells.order());
            let n = sorted.len();
            let mut search = TileSearch::default();
            search.find(cells.keys(), cells.layout());
            let partnered = search.find_partnered(&sorted.p, n, params.h2).to_vec();
            let r2 = |i: usize, j: usize| -> f64 {
                let (i, j) = (i.min(j), i.max(j));
                let d = sorted.p.each_ref().map(|axis| axis[j] - axis[i]);
                d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
            };
            for (i, &marked) in partnered.iter().enumerate() {
                let close = (0..n).any(|j| j != i && r2(i, j) < params.h2);
                assert_eq!(marked, close, "spread {spread}: slot {i}");
            }
            let count = partnered.iter().filter(|&&p| p).count();
            assert!(count > 100 && count < n, "spread {spread}: {count} of {n}");
            let kept_keys: Vec<u64> = cells.keys()[..n]
                .iter()
                .zip(&partnered)
                .filter(|&(_, &kept)| kept)
                .map(|(&key, _)| key)
                .chain([u64::MAX; SENTINELS])
                .collect();
            let mut fresh = TileSearch::default();
            fresh.find(&kept_keys, cells.layout());
            search.keep_partnered();
            assert_eq!(search.tiles(), fresh.tiles(), "spread {spread}");
        }
    }

    #[test]
    fn the_near_key_filter_holds_every_key_within_one_of_a_cell() {
        // Keys at either end of a word's 64 and of the u64 range, each alone.
        for key in [0, 63, 64, 127, 1 << 40, u64::MAX - 2] {
            let mut near = NearKeys::default();
            near.fill(&[key]);
            for k in [key.wrapping_sub(1), key, key.wrapping_add(1)] {
                assert!(near.may_hold(k), "{k} near {key}");
            }
            assert!(!near.may_hold(key.wrapping_add(2)) || !near.may_hold(key.wrapping_sub(2)));
        }
        let cells: Vec<u64> = (0..500u64).map(|k| k * k * 7919 % 100_003 + 1).collect();
        let mut near = NearKeys::default();
        near.fill(&cells);
        for &key in &cells {
            for k in [key.wrapping_sub(1), key, key.wrapping_add(1)] {
                assert!(near.may_hold(k), "{k} near {key}");
            }
        }
        let far = (0..100_000u64).filter(|&k| near.may_hold(k)).count();
        assert!(far < 10 * 3 * cells.len(), "{far} keys pass the filter");
    }

    #[test]
    fn a_search_starts_afresh_and_finds_nothing_without_particles() {
        let mut search = TileSearch::default();
        search.find(
            &[0, 0, 1, u64::MAX, u64::MAX, u64::MAX, u64::MAX],
            &CellLayout::default(),
        );
        assert!(!search.tiles().is_empty());
        search.find(&[u64::MAX; SENTINELS], &CellLayout::default());
        assert!(search.tiles().is_empty());
    }
}
