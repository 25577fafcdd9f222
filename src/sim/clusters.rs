//! Clusters: a neighbour structure of the SIMD pair loops on dense scenes (`--pairs
//! clusters`; neighbour lists are the default).
//!
//! The particles of each *row* of cells (the cells of one y and z, every x: contiguous
//! slots in cell order) are sorted by x and cut into clusters of [`CLUSTER`] places, the
//! last of a row padded with empty places far from everything. A cluster is then
//! compact (a cell's cross-section, about 1.4 spacings along x at rest density), and its
//! places are contiguous, so a kernel loads a whole cluster into an AVX2 register (half
//! an AVX-512 one) without gathering. The positions are packed in that order
//! once per placement ([`Clusters::positions`]).
//!
//! Each cluster is compared with the clusters of 5 *windows* ([`Clusters::windows`], a
//! cluster pair list in the manner of GROMACS' kept as ranges): those of its own row
//! after it, and of its 4 forward rows (y + 1 at its z; y - 1, y, y + 1 at z + 1), whose
//! x range comes within the reach of its own. With the reach at the cut-off, every pair
//! closer than it is in exactly one cluster pair or within one cluster. (Pruning the
//! windows by bounding boxes as well was measured: it cut a third of the candidates and
//! cost more than the density pass saved, which is as fast on either.)
//!
//! Where the cell order is kept over steps with a skin, the clusters are too, with the
//! windows found at the cut-off plus the skin: until a particle has moved half the skin,
//! every pair closer than the cut-off is in them, and a step only packs the new positions
//! ([`Clusters::repack`]).

use crate::sim::cells::CellLayout;
use crate::sim::particles::{AxisArrays, Particles};

/// The neighbour structure the SIMD pair loops run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum PairStructure {
    /// The tiles of whole neighbour cells (`sim::neighbours`), for comparison: what the
    /// scalar and reference kernels and scattered scenes run on either way.
    Tiles,
    /// Clusters of 4 along x-sorted rows of cells and their windows (`sim::clusters`),
    /// on dense scenes, for every model on the simd, simd8 and mixed kernels (tiles
    /// elsewhere).
    Clusters,
    /// Each particle's list of partners within the cut-off (`sim::lists`), on dense
    /// scenes, for every model on the simd, simd8 and mixed kernels (tiles elsewhere).
    #[default]
    Lists,
}

impl PairStructure {
    /// Every structure.
    pub const ALL: [PairStructure; 3] = [
        PairStructure::Tiles,
        PairStructure::Clusters,
        PairStructure::Lists,
    ];

    /// Its name on the command line and in checkpoints.
    pub fn name(self) -> &'static str {
        match self {
            PairStructure::Tiles => "tiles",
            PairStructure::Clusters => "clusters",
            PairStructure::Lists => "lists",
        }
    }
}

/// Places per cluster: an `f64x4` register, half an `f64x8` one.
pub const CLUSTER: usize = 4;

/// The slot of a place that holds no particle.
pub const EMPTY: u32 = u32::MAX;

/// The coordinates of the empty place `place`: so far from everything, and from each
/// other, that no pair with one is within any cut-off, while squared distances stay
/// finite in f64.
fn far(place: usize) -> f64 {
    1e100 * (place + 1) as f64
}

/// The windows of each cluster: its own row's, then its forward rows'.
pub const WINDOWS: usize = 5;

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
    /// Each cluster's first and last particle's x at the build.
    first_x: Vec<f64>,
    last_x: Vec<f64>,
    rows: Vec<Row>,
    /// Positions by place, then an empty cluster ([`Clusters::empty_cluster`]).
    positions: AxisArrays,
    /// A row's (x, slot) pairs while it is sorted.
    order: Vec<(f64, u32)>,
    /// For each cluster, its [`WINDOWS`] ranges of clusters it is compared with.
    windows: Vec<[u32; 2]>,
}

impl Clusters {
    /// Clusters of the slots `keys` covers (their cell keys in `layout`, ascending; the
    /// slots after them are lone and have no pair), at the positions of `particles`,
    /// with the windows of the clusters within `reach` of each (the cut-off, plus a skin if
    /// kept over steps; no more than the cells' side).
    pub fn build(&mut self, keys: &[u64], layout: &CellLayout, particles: &Particles, reach: f64) {
        self.places.clear();
        self.first_x.clear();
        self.last_x.clear();
        self.rows.clear();
        let shift = layout.shift()[1];
        let x = &particles.p[0];
        let mut start = 0;
        while start < keys.len() {
            let row_key = keys[start] >> shift;
            let end = start + keys[start..].partition_point(|&k| k >> shift == row_key);
            // Sorted by x: insertion sort from the back, as a row arrives sorted cell by
            // cell and only a cell's few particles are out of order.
            self.order.clear();
            for (slot, &x) in x.iter().enumerate().take(end).skip(start) {
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
                self.first_x.push(chunk[0].0);
                self.last_x.push(chunk[chunk.len() - 1].0);
            }
            let [_, y, z] = layout.unpack(keys[start]);
            self.rows.push(Row {
                yz: [y, z],
                clusters: [first, self.empty_cluster() as u32],
                forward: [NO_ROW; 4],
            });
            start = end;
        }
        self.link_rows();
        self.repack(particles);
        self.find_windows(reach);
    }

    /// Packs the positions of `particles` by place (the clusters' particles in the same
    /// slots as at the build).
    pub fn repack(&mut self, particles: &Particles) {
        let mut positions = std::mem::take(&mut self.positions);
        for (packed, source) in positions.iter_mut().zip(&particles.p) {
            self.pack(source, far, packed);
        }
        self.positions = positions;
    }

    /// Copies `source` (by slot) into `packed` by place, `empty(place)` at empty places
    /// and in the empty cluster after the last.
    pub fn pack(&self, source: &[f64], empty: impl Fn(usize) -> f64, packed: &mut Vec<f64>) {
        packed.clear();
        packed.extend(
            self.places
                .iter()
                .enumerate()
                .map(|(place, &slot)| match slot {
                    EMPTY => empty(place),
                    slot => source[slot as usize],
                }),
        );
        let end = self.places.len();
        packed.extend((end..end + CLUSTER).map(empty));
    }

    /// For each cluster, the windows of its own row after it and of its forward rows:
    /// the clusters whose x range comes within `reach` of its own. A row's clusters
    /// ascend by their first and their last x alike, so each window's ends only advance
    /// along a row: they are found by cursors.
    fn find_windows(&mut self, reach: f64) {
        let Clusters {
            first_x,
            last_x,
            rows,
            windows,
            ..
        } = self;
        windows.clear();
        for row in rows.iter() {
            let [first, last] = row.clusters.map(|k| k as usize);
            // For the row itself and each forward row: the window's start and end, and
            // the row's end.
            let mut rows_of = [row.clusters, [0; 2], [0; 2], [0; 2], [0; 2]];
            for (clusters, &forward) in rows_of[1..].iter_mut().zip(&row.forward) {
                if forward != NO_ROW {
                    *clusters = rows[forward as usize].clusters;
                }
            }
            let mut cursors = rows_of.map(|[start, end]| [start, start, end]);
            for own in first..last {
                let (from_x, to_x) = (first_x[own] - reach, last_x[own] + reach);
                // In its own row, the clusters after it (none before it ends below
                // `from_x`).
                cursors[0][0] = own as u32 + 1;
                for [begin, end, row_end] in cursors.iter_mut() {
                    while *begin < *row_end && last_x[*begin as usize] <= from_x {
                        *begin += 1;
                    }
                    *end = (*end).max(*begin);
                    while *end < *row_end && first_x[*end as usize] < to_x {
                        *end += 1;
                    }
                    windows.push([*begin, *end]);
                }
            }
        }
    }

    /// The [`WINDOWS`] ranges of clusters that cluster `own` is compared with.
    pub fn windows(&self, own: usize) -> &[[u32; 2]] {
        &self.windows[own * WINDOWS..(own + 1) * WINDOWS]
    }

    /// The clusters that cluster `own` is compared with, window by window.
    pub fn candidates(&self, own: usize) -> impl Iterator<Item = usize> + '_ {
        let windows = self.windows(own).iter();
        windows.flat_map(|&[begin, end]| begin as usize..end as usize)
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
    /// places hold no particle (the kernels fill a register's spare half with it).
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

    /// The pair lanes a pass over every cluster pair evaluates (masked lanes included):
    /// [`CLUSTER`] x [`CLUSTER`] per cluster and each cluster of its windows, on 4 lanes
    /// (a row per particle) and on 8 (a row per two) alike.
    pub fn candidate_lanes(&self) -> u64 {
        let pairs = self.empty_cluster()
            + self
                .windows
                .iter()
                .map(|&[b, e]| (e - b) as usize)
                .sum::<usize>();
        (pairs * CLUSTER * CLUSTER) as u64
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.places)
            + bytes(&self.first_x)
            + bytes(&self.last_x)
            + bytes(&self.rows)
            + self.positions.iter().map(bytes).sum::<usize>()
            + bytes(&self.order)
            + bytes(&self.windows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::jittered_block;
    use crate::sim::params::Params;

    #[test]
    fn the_cluster_pairs_hold_every_pair_closer_than_the_cutoff_once() {
        let ppm = 200.0;
        let h = Params::new(ppm).h;
        let (particles, cells, _) = jittered_block(ppm, 12, 0.4, 5);
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
            for k in clusters.candidates(own) {
                assert!(k != own);
                let other = k * CLUSTER;
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
        // The useful fraction of the lanes of a pass over every cluster pair: 16.0% here,
        // a sixth of the particles on the block's faces. Whole neighbour cells: 15.5% of
        // their pairs, fewer of their lanes.
        let useful = every.len() as f64 / clusters.candidate_lanes() as f64;
        println!("{useful:.3} of the candidate lanes are pairs within h");
        assert!(useful > 0.15, "{useful}");
    }
}
