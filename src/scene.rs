//! Generated scenes, for benchmarks and tests beyond the two course inputs.

use crate::params::{BOX_MAX, BOX_MIN};
use crate::particles::Particles;

/// `count` particles at rest on a cubic lattice of spacing 1/`ppm`, filling the box from
/// the floor up (x fastest, then z, then y), half a spacing from the walls: a column of
/// fluid at the given particles per metre. Panics if the box cannot hold `count`.
pub fn filled_box(ppm: f64, count: usize) -> Particles {
    let spacing = 1.0 / ppm;
    let extent = BOX_MAX - BOX_MIN;
    let per_axis = (extent / spacing).floor().to_array().map(|n| n as usize);
    let [nx, ny, nz] = per_axis;
    assert!(
        count <= nx * ny * nz,
        "a box at {ppm} particles per metre holds at most {} particles",
        nx * ny * nz
    );
    let mut particles = Particles::zeroed(count);
    for slot in 0..count {
        let (x, z, y) = (slot % nx, (slot / nx) % nz, slot / (nx * nz));
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
    fn fills_the_floor_first_on_a_regular_lattice() {
        let particles = filled_box(100.0, 100);
        assert_eq!(particles.len(), 100);
        let lowest = BOX_MIN.y + 0.005;
        assert!((particles.position(0) - (BOX_MIN + 0.005)).length() < 1e-15);
        // 13 per row along x at 100 per metre over 0.13 m; the second row is one step in z.
        assert!((particles.p[0][13] - particles.p[0][0]).abs() < 1e-15);
        assert!((particles.p[2][13] - particles.p[2][0] - 0.01).abs() < 1e-15);
        assert!(particles.p[1][..100]
            .iter()
            .all(|&y| (y - lowest).abs() < 1e-15));
        assert!(particles.position(99).cmplt(BOX_MAX).all());
    }

    #[test]
    #[should_panic(expected = "holds at most")]
    fn refuses_more_than_the_box_holds() {
        filled_box(20.0, 10_000);
    }
}
