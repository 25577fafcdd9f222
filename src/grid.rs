//! The grid of blocks that partitions the box (SPEC.md section 3): its size, the block of a
//! position (clamped, so particles outside the box fall into boundary blocks), linear block
//! indices and block neighbourhoods.

use crate::params::{BOX_MAX, BOX_MIN};
use glam::DVec3;
use std::fmt;

/// Largest number of blocks a grid may have: the block order keeps one `u32` per block,
/// so this bounds that table at 256 MiB.
pub const MAX_BLOCKS: usize = 1 << 26;

/// Why no grid can be built for a smoothing length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSizeError {
    /// Blocks per axis that the smoothing length would give (floored, may be 0 or huge).
    pub blocks_per_axis: [f64; 3],
}

impl fmt::Display for GridSizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x, y, z] = self.blocks_per_axis;
        write!(
            f,
            "a grid of {x} x {y} x {z} blocks, but a grid needs at least 1 block per axis \
             and at most {MAX_BLOCKS} blocks"
        )
    }
}

/// A coordinate of a block along each axis.
pub type BlockCoords = [usize; 3];

/// Up to 13 block indices: the neighbours of a block that have a larger linear index.
#[derive(Debug, Clone, Copy, Default)]
pub struct ForwardNeighbours {
    indices: [u32; 13],
    len: usize,
}

impl ForwardNeighbours {
    /// The neighbour indices, in the order dx outer, dy, dz inner.
    pub fn as_slice(&self) -> &[u32] {
        &self.indices[..self.len]
    }
}

/// The regular grid of blocks over the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Number of blocks along x, y and z.
    pub dims: [usize; 3],
    /// Edge lengths of one block (each >= h).
    pub block_size: DVec3,
}

impl Grid {
    /// Builds the grid for smoothing length `h`: n_d = floor(extent_d / h), s_d = extent_d / n_d.
    pub fn new(h: f64) -> Result<Self, GridSizeError> {
        let extent = BOX_MAX - BOX_MIN;
        let counts = (extent / h).floor();
        let blocks_per_axis = counts.to_array();
        let fits = blocks_per_axis.iter().all(|&n| n >= 1.0)
            && counts.x * counts.y * counts.z <= MAX_BLOCKS as f64;
        if !fits {
            return Err(GridSizeError { blocks_per_axis });
        }
        Ok(Self {
            dims: blocks_per_axis.map(|n| n as usize),
            block_size: extent / counts,
        })
    }

    /// Total number of blocks.
    pub fn block_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The block coordinates of a position: floor((p - b_min) / s), clamped into the grid.
    pub fn coords_of(&self, p: DVec3) -> BlockCoords {
        let cell = ((p - BOX_MIN) / self.block_size).floor().to_array();
        // `as usize` maps NaN and negative values to 0 and saturates huge ones.
        std::array::from_fn(|d| (cell[d].max(0.0) as usize).min(self.dims[d] - 1))
    }

    /// The linear index i + n_x * (j + n_y * k) of block coordinates.
    pub fn index(&self, [i, j, k]: BlockCoords) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// The block coordinates of a linear index.
    pub fn coords(&self, index: usize) -> BlockCoords {
        let [nx, ny, _] = self.dims;
        [index % nx, (index / nx) % ny, index / (nx * ny)]
    }

    /// The linear index of the block holding position `p`.
    pub fn block_of(&self, p: DVec3) -> usize {
        self.index(self.coords_of(p))
    }

    /// The neighbours (26-neighbourhood clipped at the grid edges) whose linear index is
    /// larger than `index`: visiting each block with these visits each adjacent pair once.
    pub fn forward_neighbours(&self, index: usize) -> ForwardNeighbours {
        let [i, j, k] = self.coords(index);
        let step =
            |c: usize, delta: isize, n: usize| c.checked_add_signed(delta).filter(|&c| c < n);
        let mut out = ForwardNeighbours::default();
        for dx in -1..=1 {
            let Some(x) = step(i, dx, self.dims[0]) else {
                continue;
            };
            for dy in -1..=1 {
                let Some(y) = step(j, dy, self.dims[1]) else {
                    continue;
                };
                for dz in -1..=1 {
                    let Some(z) = step(k, dz, self.dims[2]) else {
                        continue;
                    };
                    let neighbour = self.index([x, y, z]);
                    if neighbour > index {
                        out.indices[out.len] = neighbour as u32;
                        out.len += 1;
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;

    fn small_grid() -> Grid {
        Grid::new(Params::new(204.0).h).unwrap()
    }

    #[test]
    fn course_grid_sizes() {
        let small = small_grid();
        assert_eq!(small.dims, [15, 21, 15]);
        assert_eq!(small.block_count(), 4725);
        let large = Grid::new(Params::new(292.0).h).unwrap();
        assert_eq!(large.dims, [22, 31, 22]);
        assert_eq!(large.block_count(), 15004);
        assert!((large.block_size.y - 0.18 / 31.0).abs() < 1e-15);
    }

    #[test]
    fn blocks_are_at_least_h_wide() {
        for ppm in [14.0, 100.0, 204.0, 292.0, 1000.0] {
            let h = Params::new(ppm).h;
            let grid = Grid::new(h).unwrap();
            assert!(grid.block_size.min_element() >= h, "ppm {ppm}");
        }
    }

    #[test]
    fn too_coarse_or_too_fine_grids_are_rejected() {
        let err = Grid::new(Params::new(10.0).h).unwrap_err();
        assert_eq!(err.blocks_per_axis[0], 0.0);
        assert!(err.to_string().contains("0 x 1 x 0 blocks"), "{err}");
        assert!(Grid::new(Params::new(1e6).h).is_err());
        assert!(Grid::new(f64::NAN).is_err());
    }

    #[test]
    fn positions_map_to_blocks_and_outside_positions_are_clamped() {
        let g = small_grid();
        assert_eq!(g.coords_of(BOX_MIN), [0, 0, 0]);
        assert_eq!(g.coords_of(BOX_MIN + g.block_size * 1.5), [1, 1, 1]);
        assert_eq!(g.coords_of(DVec3::splat(-20.0)), [0, 0, 0]);
        assert_eq!(g.coords_of(DVec3::splat(20.0)), [14, 20, 14]);
        assert_eq!(g.coords_of(DVec3::new(20.0, -1.0, 0.0)), [14, 0, 7]);
        assert_eq!(g.coords_of(DVec3::splat(f64::NAN)), [0, 0, 0]);
        assert_eq!(g.coords_of(DVec3::splat(f64::INFINITY)), [14, 20, 14]);
    }

    #[test]
    fn linear_index_round_trips() {
        let g = small_grid();
        assert_eq!(g.index([1, 0, 0]), 1);
        assert_eq!(g.index([0, 1, 0]), 15);
        assert_eq!(g.index([0, 0, 1]), 15 * 21);
        for index in [0, 1, 17, 4724] {
            assert_eq!(g.index(g.coords(index)), index);
        }
    }

    #[test]
    fn forward_neighbours_cover_each_adjacent_pair_once() {
        let g = Grid {
            dims: [3, 4, 2],
            block_size: DVec3::ONE,
        };
        let mut pairs = std::collections::HashSet::new();
        for b in 0..g.block_count() {
            for &n in g.forward_neighbours(b).as_slice() {
                assert!(pairs.insert((b, n as usize)), "pair {b},{n} twice");
            }
        }
        let adjacent = |a: BlockCoords, b: BlockCoords| (0..3).all(|d| a[d].abs_diff(b[d]) <= 1);
        let expected = (0..g.block_count())
            .flat_map(|a| (a + 1..g.block_count()).map(move |b| (a, b)))
            .filter(|&(a, b)| adjacent(g.coords(a), g.coords(b)))
            .count();
        assert_eq!(pairs.len(), expected);
        let small = small_grid();
        assert_eq!(
            small
                .forward_neighbours(small.index([1, 1, 1]))
                .as_slice()
                .len(),
            13
        );
    }
}
