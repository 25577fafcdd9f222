//! The stages of one time step (SPEC.md section 4) and the per-particle ones among them:
//! stages 6-8. Stage 1 is the cell order ([`crate::sim::cells`]), stage 2 is done by the
//! reordering ([`Particles::reset_densities_and_accelerations`]), and the pair stages 3-5
//! are the [`crate::sim::kernel`].

use crate::sim::cells::{Wall, WallSlots};
use crate::sim::params::{BOX_MAX, BOX_MIN, COLLISION_STIFFNESS, DAMPING, PARTICLE_SIZE};
use crate::sim::particles::Particles;

/// The eight stages of a time step, in execution order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// 1. Recompute each particle's block and reorder the particles by block.
    Reposition,
    /// 2. Density 0, acceleration = gravity.
    InitAccelerations,
    /// 3. Add (h^2 - r^2)^3 to both particles of every pair closer than h.
    IncrementDensities,
    /// 4. Turn the raw sums into densities.
    TransformDensities,
    /// 5. Pressure and viscosity accelerations of every pair closer than h.
    TransferAccelerations,
    /// 6. Wall repulsion for particles in boundary blocks.
    CollideWithWalls,
    /// 7. Leapfrog integration of every particle.
    Move,
    /// 8. Reflect particles of boundary blocks that crossed a wall.
    InteractWithBoundary,
}

impl Stage {
    /// All stages in the order a time step runs them.
    pub const ALL: [Stage; 8] = [
        Stage::Reposition,
        Stage::InitAccelerations,
        Stage::IncrementDensities,
        Stage::TransformDensities,
        Stage::TransferAccelerations,
        Stage::CollideWithWalls,
        Stage::Move,
        Stage::InteractWithBoundary,
    ];

    /// The stage's name in reference trace files (`<name>-base-<step>.trz`).
    pub fn trace_name(self) -> &'static str {
        match self {
            Stage::Reposition => "repos",
            Stage::InitAccelerations => "initacc",
            Stage::IncrementDensities => "densinc",
            Stage::TransformDensities => "denstransf",
            Stage::TransferAccelerations => "acctransf",
            Stage::CollideWithWalls => "partcol",
            Stage::Move => "motion",
            Stage::InteractWithBoundary => "boundint",
        }
    }
}

/// Calls `visit(axis, wall, slots)` for the particles of each wall.
fn for_each_wall(walls: &WallSlots, mut visit: impl FnMut(usize, Wall, &[u32])) {
    for axis in 0..3 {
        for wall in [Wall::Low, Wall::High] {
            visit(axis, wall, walls.on(axis, wall));
        }
    }
}

/// Stage 6: wall repulsion and damping for particles of boundary blocks, judged by where
/// the particle would be after dt at its half-step velocity (SPEC.md erratum 5).
pub fn collide_with_walls(walls: &WallSlots, dt: f64, particles: &mut Particles) {
    let Particles { p, hv, v, a, .. } = particles;
    for_each_wall(walls, |axis, wall, slots| {
        let (p, hv, v, a) = (&p[axis], &hv[axis], &v[axis], &mut a[axis]);
        for &s in slots {
            let s = s as usize;
            let x = p[s] + hv[s] * dt;
            match wall {
                Wall::Low => {
                    let depth = PARTICLE_SIZE - (x - BOX_MIN[axis]);
                    if depth > 1e-10 {
                        a[s] += COLLISION_STIFFNESS * depth - DAMPING * v[s];
                    }
                }
                Wall::High => {
                    let depth = PARTICLE_SIZE - (BOX_MAX[axis] - x);
                    if depth > 1e-10 {
                        a[s] -= COLLISION_STIFFNESS * depth + DAMPING * v[s];
                    }
                }
            }
        }
    });
}

/// Stage 7: p += hv dt + a dt^2; v = hv + a dt / 2; hv += a dt (old hv on the right).
pub fn move_particles(dt: f64, particles: &mut Particles) {
    let n = particles.len();
    let Particles { p, hv, v, a, .. } = particles;
    for axis in 0..3 {
        let slots = p[axis][..n]
            .iter_mut()
            .zip(&mut hv[axis][..n])
            .zip(&mut v[axis][..n])
            .zip(&a[axis][..n]);
        for (((p, hv), v), &a) in slots {
            *p += *hv * dt + a * (dt * dt);
            *v = *hv + a * dt / 2.0;
            *hv += a * dt;
        }
    }
}

/// Stage 8: particles of boundary blocks (blocks from stage 1, not recomputed) that ended
/// beyond their wall are mirrored back and their velocities reversed on that axis.
pub fn interact_with_boundary(walls: &WallSlots, particles: &mut Particles) {
    let Particles { p, hv, v, .. } = particles;
    for_each_wall(walls, |axis, wall, slots| {
        let (p, hv, v) = (&mut p[axis], &mut hv[axis], &mut v[axis]);
        for &s in slots {
            let s = s as usize;
            let crossed = match wall {
                Wall::Low => {
                    let excess = p[s] - BOX_MIN[axis];
                    (excess < 0.0).then(|| BOX_MIN[axis] - excess)
                }
                Wall::High => {
                    let excess = BOX_MAX[axis] - p[s];
                    (excess < 0.0).then(|| BOX_MAX[axis] + excess)
                }
            };
            if let Some(mirrored) = crossed {
                p[s] = mirrored;
                v[s] = -v[s];
                hv[s] = -hv[s];
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::CellOrder;
    use crate::sim::grid::Grid;
    use crate::sim::params::TIME_STEP;
    use glam::DVec3;

    #[test]
    fn stage_order_and_trace_names() {
        let names: Vec<_> = Stage::ALL.iter().map(|s| s.trace_name()).collect();
        assert_eq!(
            names,
            [
                "repos",
                "initacc",
                "densinc",
                "denstransf",
                "acctransf",
                "partcol",
                "motion",
                "boundint"
            ]
        );
    }

    /// One particle, given the walls of the block at `coords` of a 3x3x3 grid over the box.
    fn wall_particle(coords: [usize; 3], p: DVec3, hv: DVec3, v: DVec3) -> (WallSlots, Particles) {
        let grid = Grid {
            dims: [3, 3, 3],
            block_size: (BOX_MAX - BOX_MIN) / 3.0,
        };
        let mut particles = Particles::zeroed(1);
        for axis in 0..3 {
            particles.p[axis][0] = p[axis];
            particles.hv[axis][0] = hv[axis];
            particles.v[axis][0] = v[axis];
        }
        let mut cells = CellOrder::default();
        cells.sort_with_blocks(&grid, &particles, &[grid.index(coords) as u32]);
        (cells.walls().clone(), particles)
    }

    #[test]
    fn low_wall_pushes_a_particle_back() {
        let p = DVec3::new(BOX_MIN.x + 0.0001, 0.0, 0.0);
        let (walls, mut particles) =
            wall_particle([0, 1, 1], p, DVec3::ZERO, DVec3::new(-0.2, 0.0, 0.0));
        collide_with_walls(&walls, TIME_STEP, &mut particles);
        let expected = COLLISION_STIFFNESS * (PARTICLE_SIZE - 0.0001) + DAMPING * 0.2;
        assert!((particles.a[0][0] - expected).abs() < 1e-9);
        assert_eq!(particles.a[1][0], 0.0);
    }

    #[test]
    fn high_wall_subtracts_stiffness_and_damping() {
        let p = DVec3::new(0.0, BOX_MAX.y - 0.0001, 0.0);
        let (walls, mut particles) =
            wall_particle([1, 2, 1], p, DVec3::ZERO, DVec3::new(0.0, 0.3, 0.0));
        collide_with_walls(&walls, TIME_STEP, &mut particles);
        let expected = -(COLLISION_STIFFNESS * (PARTICLE_SIZE - 0.0001) + DAMPING * 0.3);
        assert!((particles.a[1][0] - expected).abs() < 1e-9);
    }

    #[test]
    fn walls_only_act_within_the_particle_size() {
        let p = DVec3::new(BOX_MIN.x + 0.001, 0.0, 0.0);
        let (walls, mut particles) = wall_particle([0, 1, 1], p, DVec3::ZERO, DVec3::X);
        collide_with_walls(&walls, TIME_STEP, &mut particles);
        assert_eq!(particles.acceleration(0), DVec3::ZERO);
    }

    #[test]
    fn interior_blocks_ignore_the_walls_even_outside_the_box() {
        // The block comes from stage 1, so a particle in an interior block is left alone.
        let p = DVec3::new(BOX_MIN.x - 1.0, 0.0, 0.0);
        let (walls, mut particles) = wall_particle([1, 1, 1], p, DVec3::ZERO, DVec3::X);
        collide_with_walls(&walls, TIME_STEP, &mut particles);
        interact_with_boundary(&walls, &mut particles);
        assert_eq!(particles.acceleration(0), DVec3::ZERO);
        assert_eq!(particles.position(0), p);
    }

    #[test]
    fn motion_is_a_leapfrog_step() {
        let mut particles = Particles::zeroed(1);
        particles.p[0][0] = 1.0;
        particles.hv[0][0] = 2.0;
        particles.a[0][0] = 1000.0;
        move_particles(TIME_STEP, &mut particles);
        assert!((particles.p[0][0] - (1.0 + 2e-3 + 1e-3)).abs() < 1e-15);
        assert!((particles.v[0][0] - 2.5).abs() < 1e-15);
        assert!((particles.hv[0][0] - 3.0).abs() < 1e-15);
    }

    #[test]
    fn boundary_mirrors_crossing_particles_and_reverses_velocity() {
        let p = DVec3::new(BOX_MIN.x - 0.001, BOX_MAX.y + 0.002, 0.0);
        let (walls, mut particles) = wall_particle(
            [0, 2, 1],
            p,
            DVec3::new(-1.0, 2.0, 3.0),
            DVec3::new(-4.0, 5.0, 6.0),
        );
        interact_with_boundary(&walls, &mut particles);
        assert!((particles.p[0][0] - (BOX_MIN.x + 0.001)).abs() < 1e-15);
        assert!((particles.p[1][0] - (BOX_MAX.y - 0.002)).abs() < 1e-15);
        assert_eq!(particles.half_velocity(0), DVec3::new(1.0, -2.0, 3.0));
        assert_eq!(particles.velocity(0), DVec3::new(4.0, -5.0, 6.0));
    }
}
