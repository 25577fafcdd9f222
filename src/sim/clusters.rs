//! Clusters: the neighbour structure of the SIMD pair loops on dense scenes.
//!
//! The particles of each *row* of cells (the cells of one y and z, every x: contiguous
//! slots in cell order) are sorted by x and cut into clusters of `width` places (the
//! kernel's lanes), the last of a row padded with empty places far from everything. A
//! cluster is then compact (a cell's cross-section, about `width` / 5 cells along x at
//! rest density), and its places are contiguous, so a kernel loads a whole cluster into
//! one register without gathering. The positions are packed in that order once per
//! placement ([`Clusters::positions`]).
//!
//! A particle's candidate partners are the clusters of its own row after its own (and
//! the places after it in its own cluster) and of its 4 forward rows (y + 1 at its z;
//! y - 1, y, y + 1 at z + 1), each cut to the clusters whose x range comes within the
//! cut-off of the particle's x ([`Clusters::windows`]): every pair closer than the
//! cut-off once, and far fewer candidates than whole neighbour cells.
//!
//! Where the cell order is kept over steps with a skin, the clusters are too, with a
//! list per place of the clusters within the cut-off plus the skin at the build
//! ([`Clusters::list`]): until a particle has moved half the skin, every pair closer than
//! the cut-off is in it, and a step only packs the new positions ([`Clusters::repack`]).

use crate::sim::cells::CellLayout;
use crate::sim::particles::{AxisArrays, Particles};
use std::ops::Range;

/// The neighbour structure the SIMD pair loops run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum PairStructure {
    /// The tiles of whole neighbour cells (`sim::neighbours`).
    #[default]
    Tiles,
    /// Clusters of a kernel's lanes along x-sorted rows of cells (`sim::clusters`), on
    /// dense scenes, for the course models on the simd, simd8 and mixed kernels (tiles
    /// elsewhere). Experimental: slower than the tiles so far.
    Clusters,
}

/// The slot of a place that holds no particle.
pub const EMPTY: u32 = u32::MAX;

/// Each coordinate of an empty place: so far that no pair with it is within any cut-off,
/// while its squared distances stay finite.
const FAR: f64 = 1e100;

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
    /// Places per cluster.
    width: usize,
    /// The slot at each place, or [`EMPTY`].
    places: Vec<u32>,
    /// The x of each cluster's first and last particle.
    first_x: Vec<f64>,
    last_x: Vec<f64>,
    /// The row of each cluster.
    row_of: Vec<u32>,
    rows: Vec<Row>,
    /// Positions by place, then `width` far places (so a load of a whole cluster from any
    /// place stays in bounds).
    positions: AxisArrays,
    /// A row's (x, slot) pairs while it is sorted.
    order: Vec<(f64, u32)>,
    /// Where kept over steps: for each place, the clusters within reach of it at the
    /// build (its own for the places after it in it).
    list: Vec<u32>,
    /// Where each place's clusters start in `list`, then their end (empty without a list).
    starts: Vec<u32>,
}

impl Clusters {
    /// Clusters of `width` places of the slots `keys` covers (their cell keys in
    /// `layout`, ascending; the slots after them are lone and have no pair), at the
    /// positions of `particles`; with `reach` (the cut-off plus a skin, no more than the
    /// cells' side), the list of the clusters within it of each place.
    pub fn build(
        &mut self,
        width: usize,
        keys: &[u64],
        layout: &CellLayout,
        particles: &Particles,
        reach: Option<f64>,
    ) {
        self.width = width;
        self.places.clear();
        self.first_x.clear();
        self.last_x.clear();
        self.row_of.clear();
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
            let row = self.rows.len() as u32;
            let first = self.first_x.len() as u32;
            for chunk in self.order.chunks(width) {
                self.places.extend(chunk.iter().map(|&(_, slot)| slot));
                self.places
                    .extend(std::iter::repeat_n(EMPTY, width - chunk.len()));
                self.first_x.push(chunk[0].0);
                self.last_x.push(chunk[chunk.len() - 1].0);
                self.row_of.push(row);
            }
            let [_, y, z] = layout.unpack(keys[start]);
            self.rows.push(Row {
                yz: [y, z],
                clusters: [first, self.first_x.len() as u32],
                forward: [NO_ROW; 4],
            });
            start = end;
        }
        self.link_rows();
        self.repack(particles);
        self.list.clear();
        self.starts.clear();
        if let Some(reach) = reach {
            self.build_list(reach);
        }
    }

    /// Packs the positions of `particles` by place (the clusters' particles in the same
    /// slots as at the build).
    pub fn repack(&mut self, particles: &Particles) {
        let mut positions = std::mem::take(&mut self.positions);
        for (packed, source) in positions.iter_mut().zip(&particles.p) {
            self.pack(source, FAR, packed);
        }
        self.positions = positions;
    }

    /// Copies `source` (by slot) into `packed` by place, `empty` at empty places and in
    /// `width` more places after the last (so a whole cluster loads from any place).
    pub fn pack(&self, source: &[f64], empty: f64, packed: &mut Vec<f64>) {
        packed.clear();
        packed.extend(self.places.iter().map(|&slot| match slot {
            EMPTY => empty,
            slot => source[slot as usize],
        }));
        packed.extend(std::iter::repeat_n(empty, self.width));
    }

    /// For each place, the clusters of its candidates (its own after it, its windows)
    /// holding a particle within `reach`.
    fn build_list(&mut self, reach: f64) {
        let width = self.width;
        let mut windows = [0..0, 0..0, 0..0, 0..0, 0..0];
        for i in 0..self.places.len() {
            self.starts.push(self.list.len() as u32);
            let own = i / width;
            if i % width == 0 {
                windows = self.windows(own, reach);
            }
            if self.places[i] == EMPTY {
                continue;
            }
            let Clusters {
                positions: p, list, ..
            } = self;
            let within = |places: std::ops::Range<usize>| {
                places.into_iter().any(|j| {
                    let r2: f64 = (0..3).map(|axis| (p[axis][i] - p[axis][j]).powi(2)).sum();
                    r2 < reach * reach
                })
            };
            if within(i + 1..(own + 1) * width) {
                list.push(own as u32);
            }
            for k in windows.iter().cloned().flatten() {
                if within(k * width..(k + 1) * width) {
                    list.push(k as u32);
                }
            }
        }
        self.starts.push(self.list.len() as u32);
    }

    /// Where kept over steps, each place's clusters within reach at the build: the list,
    /// and where each place's entries start in it (then their end).
    pub fn list(&self) -> Option<(&[u32], &[u32])> {
        (!self.starts.is_empty()).then_some((&self.list, &self.starts))
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

    /// Places per cluster.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The slot at each place ([`EMPTY`] for none).
    pub fn places(&self) -> &[u32] {
        &self.places
    }

    /// The positions by place, then `width` far places.
    pub fn positions(&self) -> &AxisArrays {
        &self.positions
    }

    /// The clusters the particles of cluster `own` are compared with beyond their own
    /// cluster: those of its row after it, and of its forward rows, whose x range comes
    /// within `cutoff` of its own.
    pub fn windows(&self, own: usize, cutoff: f64) -> [Range<usize>; 5] {
        let row = self.rows[self.row_of[own] as usize];
        let (low, high) = (self.first_x[own] - cutoff, self.last_x[own] + cutoff);
        let window = |clusters: [u32; 2], from: usize| {
            let all = from.max(clusters[0] as usize)..clusters[1] as usize;
            let begin = all.start + self.last_x[all.clone()].partition_point(|&last| last <= low);
            let end = all.start + self.first_x[all.clone()].partition_point(|&first| first < high);
            begin..end.max(begin)
        };
        let forward = |k: usize| match row.forward[k] {
            NO_ROW => 0..0,
            r => window(self.rows[r as usize].clusters, 0),
        };
        [
            window(row.clusters, own + 1),
            forward(0),
            forward(1),
            forward(2),
            forward(3),
        ]
    }

    /// The pair lanes a pass over every candidate evaluates (a whole cluster per
    /// candidate, masked lanes included): over the kept lists where there are, else over
    /// the windows of `cutoff`.
    pub fn candidate_lanes(&self, cutoff: f64) -> u64 {
        let width = self.width;
        let groups: usize = match self.list() {
            Some((list, _)) => list.len(),
            None => (0..self.places.len())
                .filter(|&i| self.places[i] != EMPTY)
                .map(|i| {
                    let own = i / width;
                    let own_rest = usize::from(i + 1 < (own + 1) * width);
                    let windows = self.windows(own, cutoff);
                    own_rest + windows.iter().map(ExactSizeIterator::len).sum::<usize>()
                })
                .sum(),
        };
        (groups * width) as u64
    }

    /// The bytes its buffers hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        bytes(&self.places)
            + bytes(&self.first_x)
            + bytes(&self.last_x)
            + bytes(&self.row_of)
            + bytes(&self.rows)
            + self.positions.iter().map(bytes).sum::<usize>()
            + bytes(&self.order)
            + bytes(&self.list)
            + bytes(&self.starts)
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
    fn the_windows_hold_every_pair_closer_than_the_cutoff_once() {
        let ppm = 200.0;
        let h = Params::new(ppm).h;
        let (particles, cells, _) = block(ppm, 12);
        let n = particles.len();
        for width in [4, 8] {
            let mut clusters = Clusters::default();
            let keys = &cells.keys()[..n];
            clusters.build(width, keys, cells.layout(), &particles, None);
            let places = clusters.places();
            assert_eq!(places.len() % width, 0);
            let mut seen: Vec<u32> = places.iter().copied().filter(|&s| s != EMPTY).collect();
            seen.sort_unstable();
            assert_eq!(seen, (0..n as u32).collect::<Vec<_>>(), "every slot once");
            let at = |place: usize| particles.position(places[place] as usize);
            let mut found = Vec::new();
            let mut candidates = 0;
            for i in (0..places.len()).filter(|&i| places[i] != EMPTY) {
                let own = i / width;
                let mut partners: Vec<usize> = (i + 1..(own + 1) * width).collect();
                for window in clusters.windows(own, h) {
                    partners.extend(window.flat_map(|k| k * width..(k + 1) * width));
                }
                candidates += partners.len();
                for j in partners.into_iter().filter(|&j| places[j] != EMPTY) {
                    if at(i).distance_squared(at(j)) < h * h {
                        let (a, b) = (places[i], places[j]);
                        found.push((a.min(b), a.max(b)));
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
            assert_eq!(found.len(), found_count, "width {width}: a pair twice");
            assert_eq!(found, every, "width {width}");
            // The useful fraction of the candidate lanes: 17% for clusters of 4 here, 11%
            // for clusters of 8 (whole neighbour cells: 15.5% of their pairs, fewer of
            // their lanes).
            let useful = every.len() as f64 / candidates as f64;
            println!("width {width}: {useful:.3} of the candidate lanes are pairs within h");
            let expected = if width == 4 { 0.15 } else { 0.1 };
            assert!(useful > expected, "width {width}: {useful}");
        }
    }
}
