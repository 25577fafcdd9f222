//! Neighbour lists reused with a skin (Verlet lists): the cell order and tiles (and the
//! neighbour lists within h + skin) are built
//! on cells of at least h + skin, and kept while no particle has moved more than half the
//! skin since the build. Two particles closer than h now were then closer than h + skin,
//! so in the same or adjacent cells of the build: the kept tiles hold every pair closer
//! than h, and the pair loops, which test the cut-off themselves, find exactly the pairs a
//! rebuild would. The walls of each particle's block are still recomputed every step.
//!
//! A checkpoint keeps the skin's last build ([`KeptSkin`]): the positions it was built
//! at and how that sort ran, from which a resumed run rebuilds the same cell order and
//! lists and goes on bit for bit.

use crate::sim::grid::{Grid, GridSizeError};
use crate::sim::params::Domain;
use crate::sim::particles::{AxisArrays, Particles};

/// The skin's state: its width, the grid of its cells, and the positions of the build.
#[derive(Debug, Clone, PartialEq)]
pub struct Skin {
    /// The skin's width (m).
    width: f64,
    /// The grid of cells of at least h + width.
    grid: Grid,
    /// Each slot's position at the last build (empty before the first).
    built: AxisArrays,
    /// Builds so far.
    builds: u64,
    /// Whether the last build's sort ran as after a sparse one.
    sorted_sparse: bool,
}

/// What a checkpoint keeps of a skin.
#[derive(Debug, Clone, PartialEq)]
pub struct KeptSkin {
    /// The skin's width (m).
    pub width: f64,
    /// Builds so far.
    pub builds: u64,
    /// Whether the last build's sort ran as after a sparse one
    /// ([`crate::sim::cells::CellOrder::resumed`]).
    pub sorted_sparse: bool,
    /// Each slot's position at the last build (empty before the first, or expired).
    pub built: AxisArrays,
}

impl Skin {
    /// The skin's width (m).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// A skin `width` metres wide beyond the smoothing length `h`, its grid over
    /// `domain`'s box.
    pub fn new(h: f64, width: f64, domain: &Domain) -> Result<Skin, GridSizeError> {
        Ok(Skin {
            width,
            grid: Grid::new(h + width, domain)?,
            built: Default::default(),
            builds: 0,
            sorted_sparse: false,
        })
    }

    /// The skin a checkpoint `kept`, beyond the smoothing length `h`, over `domain`.
    pub fn restored(h: f64, kept: KeptSkin, domain: &Domain) -> Result<Skin, GridSizeError> {
        Ok(Skin {
            builds: kept.builds,
            sorted_sparse: kept.sorted_sparse,
            built: kept.built,
            ..Skin::new(h, kept.width, domain)?
        })
    }

    /// What a checkpoint keeps of it.
    pub fn kept(&self) -> KeptSkin {
        KeptSkin {
            width: self.width,
            builds: self.builds,
            sorted_sparse: self.sorted_sparse,
            built: self.built.clone(),
        }
    }

    /// The grid whose cells the lists are built on.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Each slot's position at the last build (empty before the first, or expired).
    pub fn built(&self) -> &AxisArrays {
        &self.built
    }

    /// Whether the sort before its last build ran as after a sort that found the
    /// particles sparse.
    pub fn sorted_sparse(&self) -> bool {
        self.sorted_sparse
    }

    /// Builds so far.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Whether the lists must be built again whatever the particles: never built, or
    /// expired ([`Self::expire`]).
    pub fn is_stale_by_build(&self) -> bool {
        self.built[0].is_empty()
    }

    /// Makes the next placement a build (as when the pair structure changes).
    pub fn expire(&mut self) {
        self.built.iter_mut().for_each(Vec::clear);
    }

    /// Whether the lists must be built again: never built or expired, or some particle
    /// (in the same slot as at the build) has moved more than half the skin since, or is
    /// not finite.
    pub fn is_stale(&self, particles: &Particles) -> bool {
        let n = particles.len();
        if self.is_stale_by_build() || self.built[0].len() != n {
            return true;
        }
        let limit = (self.width / 2.0).powi(2);
        let mut largest = 0.0f64;
        let mut finite = true;
        for slot in 0..n {
            let moved2: f64 = (0..3)
                .map(|d| (particles.p[d][slot] - self.built[d][slot]).powi(2))
                .sum();
            finite &= moved2.is_finite();
            largest = largest.max(moved2);
        }
        !finite || largest > limit
    }

    /// Records the positions of a build (the particles in their new slots) and whether
    /// its sort ran as after a sparse one.
    pub fn record(&mut self, particles: &Particles, sorted_sparse: bool) {
        self.sorted_sparse = sorted_sparse;
        let n = particles.len();
        for (built, p) in self.built.iter_mut().zip(&particles.p) {
            built.clear();
            built.extend_from_slice(&p[..n]);
        }
        self.builds = self.builds.saturating_add(1);
    }

    /// The bytes its recorded positions hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        self.built.iter().map(crate::sim::heap_bytes).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_go_stale_past_half_the_skin() {
        let h = 0.006;
        let mut skin = Skin::new(h, 0.002, &Domain::COURSE).unwrap();
        assert!(skin.grid().block_size.min_element() >= h + 0.002);
        let mut particles = Particles::zeroed(3);
        assert!(skin.is_stale(&particles), "never built");
        skin.record(&particles, false);
        assert_eq!(skin.builds(), 1);
        assert!(!skin.is_stale(&particles));
        particles.p[1][2] = 0.0009;
        assert!(!skin.is_stale(&particles), "0.9 mm of a 1 mm half skin");
        particles.p[0][2] = 0.0005;
        assert!(skin.is_stale(&particles), "1.03 mm");
        particles.p[0][2] = 0.0;
        particles.p[2][0] = f64::NAN;
        assert!(skin.is_stale(&particles), "not finite");
        assert!(skin.heap_bytes() >= 3 * 3 * 8);
        skin.expire();
        assert!(skin.is_stale(&particles), "expired");
        assert_eq!(skin.builds(), 1);
    }

    #[test]
    fn a_kept_skin_is_restored_as_it_was() {
        let h = 0.006;
        let mut skin = Skin::new(h, 0.002, &Domain::COURSE).unwrap();
        let mut particles = Particles::zeroed(4);
        particles.p[1][3] = 0.01;
        skin.record(&particles, true);
        skin.record(&particles, true);
        let restored = Skin::restored(h, skin.kept(), &Domain::COURSE).unwrap();
        assert_eq!(restored, skin);
        assert_eq!(restored.builds(), 2);
        assert_eq!(restored.kept().built[1][3], 0.01);
    }
}
