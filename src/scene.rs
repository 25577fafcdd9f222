//! Generated scenes, for benchmarks and tests beyond the two course inputs.

use crate::params::{BOX_MAX, BOX_MIN};
use crate::particles::Particles;

/// `count` particles at rest on a cubic lattice of spacing 1/`ppm`, half a spacing from
/// the walls: a block of fluid in the box's low corner, as close to a cube as the box
/// allows (x fastest, then z, then y, so the top layer may be partial). Blocks of any size
/// have the same inner density and shape, which makes them a fair scaling series.
/// Panics if the box cannot hold `count`.
pub fn corner_block(ppm: f64, count: usize) -> Particles {
    let spacing = 1.0 / ppm;
    let extent = BOX_MAX - BOX_MIN;
    let [nx, ny, nz] = (extent / spacing).floor().to_array().map(|n| n as usize);
    let side = (count as f64).cbrt().ceil() as usize;
    let (wide, deep) = (side.min(nx), side.min(nz));
    assert!(
        count <= wide * deep * ny,
        "a box at {ppm} particles per metre holds a block of at most {} particles",
        wide * deep * ny
    );
    let mut particles = Particles::zeroed(count);
    for slot in 0..count {
        let (x, z, y) = (slot % wide, (slot / wide) % deep, slot / (wide * deep));
        for (axis, k) in [x, y, z].into_iter().enumerate() {
            particles.p[axis][slot] = BOX_MIN[axis] + (k as f64 + 0.5) * spacing;
        }
    }
    particles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_a_cube_in_the_corner_on_a_regular_lattice() {
        let particles = corner_block(100.0, 125);
        assert_eq!(particles.len(), 125);
        assert!((particles.position(0) - (BOX_MIN + 0.005)).length() < 1e-15);
        // Rows of 5 along x, 5 rows along z, 5 layers: spacing 0.01 m.
        let last = particles.position(124) - particles.position(0);
        assert!((last - glam::DVec3::splat(0.04)).length() < 1e-15);
        assert!((particles.p[2][5] - particles.p[2][0] - 0.01).abs() < 1e-15);
        assert!((particles.p[1][25] - particles.p[1][0] - 0.01).abs() < 1e-15);
    }

    #[test]
    fn a_block_wider_than_the_box_grows_upwards() {
        // A cube of 3000 would be 15 wide; 13 x 13 fit across the box at 100 per metre, so
        // the block takes 18 layers, the box's full height.
        let particles = corner_block(100.0, 3000);
        let top = particles.p[1][..3000]
            .iter()
            .fold(f64::MIN, |m, &y| m.max(y));
        assert!((top - (BOX_MIN.y + 0.175)).abs() < 1e-15);
        assert!(particles.position(2999).cmplt(BOX_MAX).all());
    }

    #[test]
    #[should_panic(expected = "holds a block of at most")]
    fn refuses_more_than_the_box_holds() {
        corner_block(20.0, 10_000);
    }
}
