//! Clusters: the neighbour structure of the SIMD pair loops on dense scenes.
//!
//! The particles of each *row* of cells (the cells of one y and z, every x: contiguous
//! slots in cell order) are sorted by x and cut into clusters of [`CLUSTER`] places, the
//! last of a row padded with empty places far from everything. A cluster is then
//! compact (a cell's cross-section, about 1.4 spacings along x at rest density), and its
//! places are contiguous, so a kernel loads a whole cluster into a quarter of an AVX-512
//! register (half an AVX2 one) without gathering. The positions are packed in that order
//! once per placement ([`Clusters::positions`]).
//!
//! Each cluster has a list of the clusters its particles are compared with
//! ([`Clusters::pairs`], GROMACS' cluster pair list): those of its own row after it and
//! of its 4 forward rows (y + 1 at its z; y - 1, y, y + 1 at z + 1) whose bounding box
//! comes within the reach of its own. With the reach at the cut-off, every pair closer
//! than it is in exactly one cluster pair or within one cluster.
//!
//! Where the cell order is kept over steps with a skin, the clusters are too, with the
//! lists built at the cut-off plus the skin: until a particle has moved half the skin,
//! every pair closer than the cut-off is in them, and a step only packs the new positions
//! ([`Clusters::repack`]).

use crate::sim::cells::CellLayout;
use crate::sim::particles::{AxisArrays, Particles};
use wide::f64x4;

/// The neighbour structure the SIMD pair loops run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum PairStructure {
    /// The tiles of whole neighbour cells (`sim::neighbours`).
    #[default]
    Tiles,
    /// Clusters of 4 along x-sorted rows of cells with their cluster pair lists
    /// (`sim::clusters`), on dense scenes, for the course models on the simd, simd8 and
    /// mixed kernels (tiles elsewhere).
    Clusters,
}

/// Places per cluster: a quarter of an `f64x8` register.
pub const CLUSTER: usize = 4;

/// The slot of a place that holds no particle.
pub const EMPTY: u32 = u32::MAX;

/// The coordinates of the empty place `place`: so far from everything, and from each
/// other, that no pair with one is within any cut-off, while squared distances stay
/// finite in f64.
fn far(place: usize) -> f64 {
    1e100 * (place + 1) as f64
}

/// A bit per cluster of `from..from + 4` (lanes from `to` on clear) whose bounding box
/// (`low` and `high` by cluster, 4 boxes more after the last) comes within the squared
/// distance `reach2` of cluster `own`'s; 4 at a time, as the candidates of a window are
/// consecutive clusters.
fn near_boxes(
    [low, high]: [&AxisArrays; 2],
    own: usize,
    from: usize,
    to: usize,
    reach2: f64,
) -> u32 {
    let lanes = |values: &[f64]| f64x4::new(std::array::from_fn(|lane| values[from + lane]));
    let mut distance2 = f64x4::ZERO;
    for axis in 0..3 {
        let above = lanes(&low[axis]) - f64x4::splat(high[axis][own]);
        let below = f64x4::splat(low[axis][own]) - lanes(&high[axis]);
        let gap = above.max(below).max(f64x4::ZERO);
        distance2 += gap * gap;
    }
    let live = (1 << (to - from).min(4)) - 1;
    distance2.simd_lt(f64x4::splat(reach2)).to_bitmask() & live
}

/// A row of cells: its y and z offsets in the cell layout, its clusters and its forward
/// rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Row {
    /// The y and z offsets of its cells.
    yz: [u32; 2],
    /// Its clusters.
    clusters: [u32; 2],
    /// The rows at (y + 1, z), (y - 1, z + 1), (y, z + 1), (y + 1, z + 1), or
    /// [`NO_ROW`].
    forward: [u32; 4],
}

/// A forward row that holds no particle.
const NO_ROW: u32 = u32::MAX;

/// The clusters of one placement.
#[derive(Debug, Clone, Default)]
pub struct Clusters {
    /// The slot at each place, or [`EMPTY`].
    places: Vec<u32>,
    /// Each cluster's bounding box at the build, its lowest and highest coordinates
    /// (along x, its first and last particle's), then 4 boxes more (never near).
    low: AxisArrays,
    high: AxisArrays,
    rows: Vec<Row>,
    /// Positions by place, then an empty cluster ([`Clusters::empty_cluster`]).
    positions: AxisArrays,
    /// A row's (x, slot) pairs while it is sorted.
    order: Vec<(f64, u32)>,
    /// For each cluster, the clusters it is compared with.
    pairs: Vec<u32>,
    /// Where each cluster's entries start in `pairs`, then their end.
    pair_starts: Vec<u32>,
}

impl Clusters {
    /// Clusters of the slots `keys` covers (their cell keys in `layout`, ascending; the
    /// slots after them are lone and have no pair), at the positions of `particles`,
    /// with the lists of the clusters within `reach` of each (the cut-off, plus a skin if
    /// kept over steps; no more than the cells' side).
    pub fn build(&mut self, keys: &[u64], layout: &CellLayout, particles: &Particles, reach: f64) {
        self.places.clear();
        for bounds in self.low.iter_mut().chain(&mut self.high) {
            bounds.clear();
        }
        self.rows.clear();
        let shift = layout.shift()[1];
        let p = &particles.p;
        let mut start = 0;
        while start < keys.len() {
            let row_key = keys[start] >> shift;
            let end = start + keys[start..].partition_point(|&k| k >> shift == row_key);
            // Sorted by x: insertion sort from the back, as a row arrives sorted cell by
            // cell and only a cell's few particles are out of order.
            self.order.clear();
            for (slot, &x) in p[0].iter().enumerate().take(end).skip(start) {
                self.order.push((x, slot as u32));
                let mut at = self.order.len() - 1;
                while at > 0 && self.order[at - 1].0 > x {
                    self.order.swap(at - 1, at);
                    at -= 1;
                }
            }
            let first = self.empty_cluster() as u32;
            for chunk in self.order.chunks(CLUSTER) {
                self.places.extend(chunk.iter().map(|&(_, slot)| slot));
                self.places
                    .extend(std::iter::repeat_n(EMPTY, CLUSTER - chunk.len()));
                for (axis, coordinates) in p.iter().enumerate() {
                    let along = chunk.iter().map(|&(_, slot)| coordinates[slot as usize]);
                    let (low, high) = along
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), c| {
                            (l.min(c), h.max(c))
                        });
                    self.low[axis].push(low);
                    self.high[axis].push(high);
                }
            }
            let [_, y, z] = layout.unpack(keys[start]);
            self.rows.push(Row {
                yz: [y, z],
                clusters: [first, self.empty_cluster() as u32],
                forward: [NO_ROW; 4],
            });
            start = end;
        }
        for bounds in self.low.iter_mut().chain(&mut self.high) {
            bounds.extend([f64::INFINITY; 4]);
        }
        self.link_rows();
        self.repack(particles);
        self.build_pairs(reach);
    }

    /// Packs the positions of `particles` by place (the clusters' particles in the same
    /// slots as at the build).
    pub fn repack(&mut self, particles: &Particles) {
        let mut positions = std::mem::take(&mut self.positions);
        for (packed, source) in positions.iter_mut().zip(&particles.p) {
            packed.clear();
            packed.extend(
                self.places
                    .iter()
                    .enumerate()
                    .map(|(place, &slot)| match slot {
                        EMPTY => far(place),
                        slot => source[slot as usize],
                    }),
            );
            let end = self.places.len();
            packed.extend((end..end + CLUSTER).map(far));
        }
        self.positions = positions;
    }

    /// Copies `source` (by slot) into `packed` by place, `empty` at empty places and in
    /// the empty cluster after the last.
    pub fn pack(&self, source: &[f64], empty: f64, packed: &mut Vec<f64>) {
        packed.clear();
        packed.extend(self.places.iter().map(|&slot| match slot {
            EMPTY => empty,
            slot => source[slot as usize],
        }));
        packed.extend(std::iter::repeat_n(empty, CLUSTER));
    }

    /// For each cluster, the clusters of its own row after it and of its forward rows
    /// whose bounding box comes within `reach` of its own. The candidates of each row
    /// are a window of its clusters by x, found by cursors: a row's clusters ascend by
    /// their low and their high x alike, so each window's ends only advance along a row.
    fn build_pairs(&mut self, reach: f64) {
        let Clusters {
            low,
            high,
            rows,
            pairs,
            pair_starts,
            ..
        } = self;
        pairs.clear();
        pair_starts.clear();
        let reach2 = reach * reach;
        // The entries are written without a branch on the box test (a third fail it,
        // unpredictably): each candidate is written at the end, which advances only
        // past those that pass.
        let mut listed = 0;
        for row in rows.iter() {
            let [first, last] = row.clusters.map(|k| k as usize);
            // For the row itself and each forward row: the window's start and end, and
            // the row's end.
            let mut windows = [row.clusters, [0; 2], [0; 2], [0; 2], [0; 2]];
            for (window, &forward) in windows[1..].iter_mut().zip(&row.forward) {
                if forward != NO_ROW {
                    *window = rows[forward as usize].clusters;
                }
            }
            let mut cursors =
                windows.map(|[start, end]| [start as usize, start as usize, end as usize]);
            for own in first..last {
                pair_starts.push(listed as u32);
                let (from_x, to_x) = (low[0][own] - reach, high[0][own] + reach);
                // In its own row, the clusters after it (none before it ends below
                // `from_x`).
                cursors[0][0] = own + 1;
                for [begin, end, row_end] in cursors.iter_mut() {
                    while *begin < *row_end && high[0][*begin] <= from_x {
                        *begin += 1;
                    }
                    *end = (*end).max(*begin);
                    while *end < *row_end && low[0][*end] < to_x {
                        *end += 1;
                    }
                    if pairs.len() < listed + (*end - *begin) + 4 {
                        pairs.resize(2 * (listed + *end - *begin + 4), 0);
                    }
                    for from in (*begin..*end).step_by(4) {
                        let near = near_boxes([low, high], own, from, *end, reach2);
                        for lane in 0..4 {
                            pairs[listed] = (from + lane) as u32;
                            listed += (near >> lane & 1) as usize;
                        }
                    }
                }
            }
        }
        pairs.truncate(listed);
        pair_starts.push(listed as u32);
    }

    /// Each cluster's list of the clusters it is compared with: the entries, and where
    /// each cluster's start in them (then their end).
    pub fn pairs(&self) -> (&[u32], &[u32]) {
        (&self.pairs, &self.pair_starts)
    }

    /// Finds each row's forward rows (rows ascend by z, then y).
    fn link_rows(&mut self) {
        let find = |rows: &[Row], y: u32, z: u32| {
            rows.binary_search_by(|row| (row.yz[1], row.yz[0]).cmp(&(z, y)))
                .map_or(NO_ROW, |at| at as u32)
        };
        for r in 0..self.rows.len() {
            let [y, z] = self.rows[r].yz;
            let targets = [
                Some((y + 1, z)),
                y.checked_sub(1).map(|below| (below, z + 1)),
                Some((y, z + 1)),
                Some((y + 1, z + 1)),
            ];
            let forward =
                targets.map(|target| target.map_or(NO_ROW, |(y, z)| find(&self.rows, y, z)));
            self.rows[r].forward = forward;
        }
    }

    /// The number of clusters; also the index of the empty cluster after the last, whose
    /// places hold no particle (the kernels fill a register's spare quarters with it).
    pub fn empty_cluster(&self) -> usize {
        self.places.len() / CLUSTER
    }

    /// The slot at each place ([`EMPTY`] for none).
    pub fn places(&self) -> &[u32] {
        &self.places
    }

    /// The positions by place, then the empty cluster.
    pub fn positions(&self) -> &AxisArrays {
        &self.positions
    }

    /// The pair lanes a pass over every listed cluster pair evaluates on `lanes` lanes
    /// (each particle of a cluster against a register of `lanes / CLUSTER` clusters, its
    /// own cluster in a register of its own; masked lanes included).
    pub fn candidate_lanes(&self, lanes: usize) -> u64 {
        let per_register = (lanes / CLUSTER).max(1);
        let registers: usize = self
            .pair_starts
            .windows(2)
            .map(|entries| 1 + ((entries[1] - entries[0]) as usize).div_ceil(per_register))
            .sum();
        (registers * CLUSTER * lanes) as u64
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.places)
            + self.low.iter().chain(&self.high).map(bytes).sum::<usize>()
            + bytes(&self.rows)
            + self.positions.iter().map(bytes).sum::<usize>()
            + bytes(&self.order)
            + bytes(&self.pairs)
            + bytes(&self.pair_starts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::CellOrder;
    use crate::sim::grid::Grid;
    use crate::sim::params::{Params, BOX_MIN};

    /// A jittered block of `side`^3 particles a spacing apart (1 / ppm) from the box's
    /// low corner, in cell order, with its cell order.
    fn block(ppm: f64, side: usize) -> (Particles, CellOrder, Grid) {
        let mut random = fastrand::Rng::with_seed(5);
        let n = side * side * side;
        let mut particles = Particles::zeroed(n);
        for slot in 0..n {
            let k = [slot % side, slot / side % side, slot / (side * side)];
            for axis in 0..3 {
                let jitter = 0.4 * (random.f64() - 0.5);
                particles.p[axis][slot] = BOX_MIN[axis] + (k[axis] as f64 + 1.0 + jitter) / ppm;
            }
        }
        let grid = Grid::new(Params::new(ppm).h).unwrap();
        let mut cells = CellOrder::default();
        cells.sort(&grid, &particles);
        let placed = particles.permuted(cells.order());
        (placed, cells, grid)
    }

    #[test]
    fn the_cluster_pairs_hold_every_pair_closer_than_the_cutoff_once() {
        let ppm = 200.0;
        let h = Params::new(ppm).h;
        let (particles, cells, _) = block(ppm, 12);
        let n = particles.len();
        let mut clusters = Clusters::default();
        clusters.build(&cells.keys()[..n], cells.layout(), &particles, h);
        let places = clusters.places();
        assert_eq!(places.len(), CLUSTER * clusters.empty_cluster());
        let mut seen: Vec<u32> = places.iter().copied().filter(|&s| s != EMPTY).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..n as u32).collect::<Vec<_>>(), "every slot once");
        let p = clusters.positions();
        for (packed, source) in p.iter().zip(&particles.p) {
            for (place, &slot) in places.iter().enumerate() {
                let expected = match slot {
                    EMPTY => far(place),
                    slot => source[slot as usize],
                };
                assert_eq!(packed[place], expected);
            }
        }
        let at = |place: usize| particles.position(places[place] as usize);
        let (pairs, starts) = clusters.pairs();
        let mut found = Vec::new();
        let mut close_pair = |i: usize, j: usize| {
            if places[i] != EMPTY && places[j] != EMPTY && at(i).distance_squared(at(j)) < h * h {
                let (a, b) = (places[i], places[j]);
                found.push((a.min(b), a.max(b)));
            }
        };
        for own in 0..clusters.empty_cluster() {
            let base = own * CLUSTER;
            for i in base..base + CLUSTER {
                for j in i + 1..base + CLUSTER {
                    close_pair(i, j);
                }
            }
            for &k in &pairs[starts[own] as usize..starts[own + 1] as usize] {
                assert!(k as usize != own);
                let other = k as usize * CLUSTER;
                for i in base..base + CLUSTER {
                    for j in other..other + CLUSTER {
                        close_pair(i, j);
                    }
                }
            }
        }
        let mut every = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                if particles
                    .position(a)
                    .distance_squared(particles.position(b))
                    < h * h
                {
                    every.push((a as u32, b as u32));
                }
            }
        }
        let found_count = found.len();
        found.sort_unstable();
        found.dedup();
        assert_eq!(found.len(), found_count, "a pair twice");
        assert_eq!(found, every);
        // The useful fraction of the lanes of a pass over every cluster pair: 16.9% on 4
        // lanes here, 15.0% on 8 (each particle against two clusters at a time; its own
        // cluster alone), a sixth of the particles on the block's faces. Whole
        // neighbour cells: 15.5% of their pairs, fewer of their lanes.
        for (lanes, expected) in [(4, 0.16), (8, 0.14)] {
            let useful = every.len() as f64 / clusters.candidate_lanes(lanes) as f64;
            println!("{lanes} lanes: {useful:.3} of the candidate lanes are pairs within h");
            assert!(useful > expected, "{lanes} lanes: {useful}");
        }
    }

    #[test]
    fn boxes_are_near_within_the_reach_of_their_gap() {
        // Cluster 0 the unit box; clusters 1..5 boxes at squared gaps 10, 0.5, 0, 4.
        let boxes = [
            ([0.0; 3], [1.0; 3]),
            ([2.0, 0.5, 4.0], [3.0, 0.7, 5.0]),
            ([-1.0, 0.0, 1.5], [-0.5, 0.2, 1.6]),
            ([0.5; 3], [0.6; 3]),
            ([0.0, 3.0, 0.0], [1.0, 4.0, 1.0]),
        ];
        let mut bounds: [AxisArrays; 2] = Default::default();
        for (low, high) in boxes
            .iter()
            .chain([&([f64::INFINITY; 3], [f64::INFINITY; 3]); 4])
        {
            for axis in 0..3 {
                bounds[0][axis].push(low[axis]);
                bounds[1][axis].push(high[axis]);
            }
        }
        let near = |from, to, reach2| near_boxes([&bounds[0], &bounds[1]], 0, from, to, reach2);
        assert_eq!(near(1, 5, 4.5), 0b1110);
        assert_eq!(near(1, 5, 4.0), 0b0110, "a gap of the reach is not near");
        assert_eq!(near(1, 5, 10.5), 0b1111);
        assert_eq!(
            near(1, 3, 10.5),
            0b0011,
            "lanes from the window's end are clear"
        );
        assert_eq!(near(3, 5, 0.1), 0b01);
    }
}
