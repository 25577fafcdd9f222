//! The grid of blocks that partitions the box (SPEC.md section 3; a case's box in the
//! workbench): its size and linear block indices. The block of a position (clamped into the grid) is its cell of
//! [`crate::sim::cells`] clamped.

use crate::sim::params::Domain;
use glam::DVec3;
use std::fmt;

/// Largest number of blocks a grid may have (about 49,000 particles per metre): rejects
/// absurd inputs, and keeps every cell within a grid's width of the box exact in the
/// 48-bit keys of the cell order (`crate::sim::cells`).
pub const MAX_BLOCKS: usize = 1 << 26;

/// Largest number of blocks along one axis: the lone filter packs a block's coordinates
/// in 16 bits each (`crate::sim::cells`), which holds every coarse cell of a grid with
/// at most 511 blocks per axis (SPEC.md's box reaches [`MAX_BLOCKS`] first; a case's long
/// box can reach this).
pub const MAX_BLOCKS_PER_AXIS: usize = 511;

/// Why no grid can be built for a smoothing length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSizeError {
    /// Blocks per axis that the smoothing length would give (floored, may be 0 or huge).
    pub blocks_per_axis: [f64; 3],
    /// The periodic axes, which need 3 blocks (a pair across a face is then never also
    /// one within the box).
    pub periodic: [bool; 3],
}

impl fmt::Display for GridSizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x, y, z] = self.blocks_per_axis.map(block_count);
        let [nx, ny, nz] = self.blocks_per_axis;
        let total_fits =
            self.blocks_per_axis.iter().all(|&n| n >= 1.0) && nx * ny * nz <= MAX_BLOCKS as f64;
        let short = (0..3).find(|&axis| self.periodic[axis] && self.blocks_per_axis[axis] < 3.0);
        if let (true, Some(axis)) = (total_fits, short) {
            return write!(
                f,
                "a grid of {x} x {y} x {z} blocks, but a periodic axis needs at least 3 \
                 blocks ({} has {})",
                ["x", "y", "z"][axis],
                self.blocks_per_axis[axis]
            );
        }
        if total_fits {
            return write!(
                f,
                "a grid of {x} x {y} x {z} blocks, but a grid has at most \
                 {MAX_BLOCKS_PER_AXIS} blocks along an axis"
            );
        }
        write!(
            f,
            "a grid of {x} x {y} x {z} blocks, but a grid needs at least 1 block per axis \
             and at most {MAX_BLOCKS} blocks"
        )
    }
}

/// A whole number of blocks as an integer, or in scientific notation beyond 10^15.
fn block_count(n: f64) -> String {
    if n.abs() < 1e15 {
        format!("{n}")
    } else {
        format!("{n:.3e}")
    }
}

/// A coordinate of a block along each axis.
pub type BlockCoords = [usize; 3];

/// The regular grid of blocks over the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Number of blocks along x, y and z.
    pub dims: [usize; 3],
    /// Edge lengths of one block (each >= h).
    pub block_size: DVec3,
    /// The box's low corner (m): where block 0 starts.
    pub min: DVec3,
    /// The box's high corner (m).
    pub max: DVec3,
    /// The domain's periodic axes ([`Domain::periodic`]).
    pub periodic: [bool; 3],
}

impl Grid {
    /// Builds the grid over `domain`'s box for smoothing length `h`:
    /// n_d = floor(extent_d / h), s_d = extent_d / n_d; one block along z in a planar
    /// domain, whose particles all lie in one plane.
    pub fn new(h: f64, domain: &Domain) -> Result<Self, GridSizeError> {
        let extent = domain.max - domain.min;
        let mut counts = (extent / h).floor();
        if domain.planar {
            counts.z = 1.0;
        }
        let blocks_per_axis = counts.to_array();
        let least = |axis: usize| if domain.periodic[axis] { 3.0 } else { 1.0 };
        let fits = (0..3).all(|axis| {
            (least(axis)..=MAX_BLOCKS_PER_AXIS as f64).contains(&blocks_per_axis[axis])
        }) && counts.x * counts.y * counts.z <= MAX_BLOCKS as f64;
        if !fits {
            return Err(GridSizeError {
                blocks_per_axis,
                periodic: domain.periodic,
            });
        }
        Ok(Self {
            dims: blocks_per_axis.map(|n| n as usize),
            block_size: extent / counts,
            min: domain.min,
            max: domain.max,
            periodic: domain.periodic,
        })
    }

    /// Total number of blocks.
    pub fn block_count(&self) -> usize {
        self.dims.iter().product()
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::Params;
    use glam::DVec3;

    fn small_grid() -> Grid {
        Grid::new(Params::new(204.0).h, &Domain::COURSE).unwrap()
    }

    #[test]
    fn course_grid_sizes() {
        let small = small_grid();
        assert_eq!(small.dims, [15, 21, 15]);
        assert_eq!(small.block_count(), 4725);
        let large = Grid::new(Params::new(292.0).h, &Domain::COURSE).unwrap();
        assert_eq!(large.dims, [22, 31, 22]);
        assert_eq!(large.block_count(), 15004);
        assert!((large.block_size.y - 0.18 / 31.0).abs() < 1e-15);
    }

    #[test]
    fn blocks_are_at_least_h_wide() {
        for ppm in [14.0, 100.0, 204.0, 292.0, 1000.0] {
            let h = Params::new(ppm).h;
            let grid = Grid::new(h, &Domain::COURSE).unwrap();
            assert!(grid.block_size.min_element() >= h, "ppm {ppm}");
        }
    }

    #[test]
    fn too_coarse_or_too_fine_grids_are_rejected() {
        let err = Grid::new(Params::new(10.0).h, &Domain::COURSE).unwrap_err();
        assert_eq!(err.blocks_per_axis[0], 0.0);
        assert!(err.to_string().contains("0 x 1 x 0 blocks"), "{err}");
        assert!(Grid::new(Params::new(1e6).h, &Domain::COURSE).is_err());
        assert!(Grid::new(f64::NAN, &Domain::COURSE).is_err());
    }

    #[test]
    fn a_long_box_is_refused_past_511_blocks_along_an_axis() {
        let long = |length: f64| Domain {
            max: Domain::COURSE.min + DVec3::new(length, 0.1, 0.1),
            ..Domain::COURSE
        };
        let h = 0.01;
        let grid = Grid::new(h, &long(5.115)).unwrap();
        assert_eq!(grid.dims, [511, 10, 10]);
        assert_eq!(grid.min, Domain::COURSE.min);
        assert!((grid.max.x - (Domain::COURSE.min.x + 5.115)).abs() < 1e-15);
        let error = Grid::new(h, &long(5.125)).unwrap_err();
        assert_eq!(
            error.to_string(),
            "a grid of 512 x 10 x 10 blocks, but a grid has at most 511 blocks along an axis"
        );
        // The course's box reaches the total first: its message is SPEC.md-era's.
        let error = Grid::new(0.18 / 512.0, &Domain::COURSE).unwrap_err();
        assert!(
            error.to_string().ends_with("at most 67108864 blocks"),
            "{error}"
        );
    }

    #[test]
    fn a_planar_box_has_one_block_along_z() {
        let slab = Domain {
            min: DVec3::new(0.0, 0.0, -0.001),
            max: DVec3::new(1.0, 0.5, 0.001),
            planar: true,
            ..Domain::COURSE
        };
        let grid = Grid::new(0.01, &slab).unwrap();
        assert_eq!(grid.dims, [100, 50, 1]);
        assert_eq!(grid.block_size.z, 0.002);
        let deep = Domain {
            max: DVec3::new(1.0, 0.5, 1.0),
            ..slab
        };
        assert_eq!(Grid::new(0.01, &deep).unwrap().dims, [100, 50, 1]);
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
}
