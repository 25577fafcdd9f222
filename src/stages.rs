//! The physics stages of one time step (SPEC.md section 4, stages 2-8), each a function over
//! the cell-ordered particles. Stage 1 (repositioning) lives in the simulation driver,
//! which owns the buffers it reorders.

use crate::block::BlockOrder;
use crate::grid::Grid;
use crate::params::{
    Params, BOX_MAX, BOX_MIN, COLLISION_STIFFNESS, DAMPING, FLUID_DENSITY, GRAVITY,
    MIN_DISTANCE_SQUARED, PARTICLE_SIZE, TIME_STEP,
};
use crate::particles::{vector_at, Particles};
use std::ops::Range;

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

/// Calls `visit(i, j)` once for every pair of slots in the same or adjacent blocks:
/// blocks ascending, later slots of the same block, then every slot of each forward
/// neighbour block (SPEC.md section 5, variant (a)).
fn for_each_pair(grid: &Grid, blocks: &BlockOrder, mut visit: impl FnMut(usize, usize)) {
    for &block in blocks.occupied() {
        let block = block as usize;
        let own = blocks.range(block);
        let neighbours = grid.forward_neighbours(block);
        for i in own.clone() {
            for j in i + 1..own.end {
                visit(i, j);
            }
            for &neighbour in neighbours.as_slice() {
                for j in blocks.range(neighbour as usize) {
                    visit(i, j);
                }
            }
        }
    }
}

/// Which wall of an axis a boundary block touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wall {
    Low,
    High,
}

/// Calls `visit(axis, wall, slots)` for every occupied block on a wall, once per axis on
/// which its coordinate is 0 (low wall) or else n - 1 (high wall).
fn for_each_wall_block(
    grid: &Grid,
    blocks: &BlockOrder,
    mut visit: impl FnMut(usize, Wall, Range<usize>),
) {
    for &block in blocks.occupied() {
        let coords = grid.coords(block as usize);
        for (axis, (&c, &n)) in coords.iter().zip(&grid.dims).enumerate() {
            let wall = if c == 0 {
                Wall::Low
            } else if c == n - 1 {
                Wall::High
            } else {
                continue;
            };
            visit(axis, wall, blocks.range(block as usize));
        }
    }
}

/// Stage 2: density 0 and acceleration = gravity for every particle.
pub fn init_accelerations(particles: &mut Particles) {
    particles.rho.fill(0.0);
    for (axis, g) in particles.a.iter_mut().zip(GRAVITY.to_array()) {
        axis.fill(g);
    }
}

/// Stage 3: for every pair with r^2 < h^2, adds (h^2 - r^2)^3 to both raw density sums.
pub fn increment_densities(
    params: &Params,
    grid: &Grid,
    blocks: &BlockOrder,
    particles: &mut Particles,
) {
    let Particles { p, rho, .. } = particles;
    let h2 = params.h2;
    for_each_pair(grid, blocks, |i, j| {
        let r2 = (vector_at(p, i) - vector_at(p, j)).length_squared();
        if r2 < h2 {
            let q = h2 - r2;
            let t = q * q * q;
            rho[i] += t;
            rho[j] += t;
        }
    });
}

/// Stage 4: rho = (rho + h^6) * 315 / (64 pi h^9) * m.
pub fn transform_densities(params: &Params, particles: &mut Particles) {
    for rho in &mut particles.rho {
        *rho = (*rho + params.h6) * params.density_factor;
    }
}

/// Stage 5: pressure and viscosity acceleration of every pair with r^2 < h^2, added to
/// the first particle and subtracted from the second (SPEC.md erratum 4).
pub fn transfer_accelerations(
    params: &Params,
    grid: &Grid,
    blocks: &BlockOrder,
    particles: &mut Particles,
) {
    let Particles { p, v, rho, a, .. } = particles;
    let Params {
        h,
        h2,
        pressure_factor,
        viscosity_factor,
        ..
    } = *params;
    for_each_pair(grid, blocks, |i, j| {
        let offset = vector_at(p, i) - vector_at(p, j);
        let r2 = offset.length_squared();
        if r2 < h2 {
            let dist = r2.max(MIN_DISTANCE_SQUARED).sqrt();
            let q = h - dist;
            let pressure = pressure_factor * q * q / dist * (rho[i] + rho[j] - 2.0 * FLUID_DENSITY);
            let viscosity = (vector_at(v, j) - vector_at(v, i)) * viscosity_factor;
            let da = (offset * pressure + viscosity) / (rho[i] * rho[j]);
            for (axis, da) in a.iter_mut().zip(da.to_array()) {
                axis[i] += da;
                axis[j] -= da;
            }
        }
    });
}

/// Stage 6: wall repulsion and damping for particles of boundary blocks, judged by where
/// the particle would be after dt at its half-step velocity (SPEC.md erratum 5).
pub fn collide_with_walls(grid: &Grid, blocks: &BlockOrder, particles: &mut Particles) {
    let Particles { p, hv, v, a, .. } = particles;
    for_each_wall_block(grid, blocks, |axis, wall, slots| {
        let (p, hv, v, a) = (&p[axis], &hv[axis], &v[axis], &mut a[axis]);
        for s in slots {
            let x = p[s] + hv[s] * TIME_STEP;
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
pub fn move_particles(particles: &mut Particles) {
    let Particles { p, hv, v, a, .. } = particles;
    for axis in 0..3 {
        let slots = p[axis]
            .iter_mut()
            .zip(&mut hv[axis])
            .zip(&mut v[axis])
            .zip(&a[axis]);
        for (((p, hv), v), &a) in slots {
            *p += *hv * TIME_STEP + a * (TIME_STEP * TIME_STEP);
            *v = *hv + a * TIME_STEP / 2.0;
            *hv += a * TIME_STEP;
        }
    }
}

/// Stage 8: particles of boundary blocks (blocks from stage 1, not recomputed) that ended
/// beyond their wall are mirrored back and their velocities reversed on that axis.
pub fn interact_with_boundary(grid: &Grid, blocks: &BlockOrder, particles: &mut Particles) {
    let Particles { p, hv, v, .. } = particles;
    for_each_wall_block(grid, blocks, |axis, wall, slots| {
        let (p, hv, v) = (&mut p[axis], &mut hv[axis], &mut v[axis]);
        for s in slots {
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
    use glam::DVec3;

    /// Two particles in one block of a 3x3x3 grid, `offset` apart along x.
    fn pair(offset: f64) -> (Params, Grid, BlockOrder, Particles) {
        let params = Params::new(204.0);
        let grid = Grid {
            dims: [3, 3, 3],
            block_size: DVec3::splat(params.h),
        };
        let mut particles = Particles::zeroed(2);
        particles.p[0][1] = offset;
        let mut blocks = BlockOrder::default();
        blocks.sort(&[13, 13], grid.block_count(), &mut Vec::new());
        (params, grid, blocks, particles)
    }

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

    #[test]
    fn init_sets_zero_density_and_gravity() {
        let mut particles = Particles::zeroed(2);
        particles.rho[1] = 5.0;
        particles.a[1][0] = 3.0;
        init_accelerations(&mut particles);
        assert_eq!(particles.rho, vec![0.0, 0.0]);
        assert_eq!(particles.acceleration(1), GRAVITY);
    }

    #[test]
    fn density_increment_of_a_close_pair() {
        let (params, grid, blocks, mut particles) = pair(0.5 * 0.008308823529411764);
        increment_densities(&params, &grid, &blocks, &mut particles);
        let r2 = particles.p[0][1] * particles.p[0][1];
        let expected = (params.h2 - r2).powi(3);
        assert!((particles.rho[0] - expected).abs() <= 1e-15 * expected);
        assert_eq!(particles.rho[0], particles.rho[1]);
    }

    #[test]
    fn pairs_at_or_beyond_h_do_not_interact() {
        let (params, grid, blocks, mut particles) = pair(Params::new(204.0).h);
        increment_densities(&params, &grid, &blocks, &mut particles);
        assert_eq!(particles.rho, vec![0.0, 0.0]);
    }

    #[test]
    fn pairs_in_adjacent_blocks_interact_and_distant_blocks_do_not() {
        let params = Params::new(204.0);
        let grid = Grid {
            dims: [4, 1, 1],
            block_size: DVec3::splat(params.h),
        };
        let mut particles = Particles::zeroed(3);
        particles.p[0] = vec![0.9 * params.h, 1.1 * params.h, 3.05 * params.h];
        let mut blocks = BlockOrder::default();
        blocks.sort(&[0, 1, 3], 4, &mut Vec::new());
        increment_densities(&params, &grid, &blocks, &mut particles);
        assert!(particles.rho[0] > 0.0 && particles.rho[0] == particles.rho[1]);
        assert_eq!(particles.rho[2], 0.0);
    }

    #[test]
    fn density_transform_adds_the_self_term() {
        let params = Params::new(204.0);
        let mut particles = Particles::zeroed(1);
        transform_densities(&params, &mut particles);
        let expected =
            params.h6 * 315.0 / (64.0 * std::f64::consts::PI * params.h.powi(9)) * params.mass;
        assert!((particles.rho[0] - expected).abs() <= 1e-12 * expected);
    }

    #[test]
    fn acceleration_transfer_is_antisymmetric_and_matches_the_formula() {
        let (params, grid, blocks, mut particles) = pair(0.004);
        particles.rho = vec![1200.0, 900.0];
        particles.v[1][1] = 0.5;
        transfer_accelerations(&params, &grid, &blocks, &mut particles);
        let dist = 0.004;
        let q = params.h - dist;
        let pressure = params.pressure_factor * q * q / dist * (2100.0 - 2000.0);
        let ax = (-dist * pressure) / (1200.0 * 900.0);
        let ay = 0.5 * params.viscosity_factor / (1200.0 * 900.0);
        assert!((particles.a[0][0] - ax).abs() <= 1e-12 * ax.abs());
        assert!((particles.a[1][1] + ay).abs() <= 1e-12 * ay.abs());
        assert_eq!(particles.acceleration(0), -particles.acceleration(1));
    }

    #[test]
    fn coincident_particles_use_the_minimum_distance() {
        let (params, grid, blocks, mut particles) = pair(0.0);
        // Without the 1e-12 floor the pressure term would be 0 * inf = NaN.
        particles.rho = vec![1100.0, 1000.0];
        particles.v[2][0] = 1.0;
        transfer_accelerations(&params, &grid, &blocks, &mut particles);
        assert!(particles.acceleration(0).is_finite());
        assert!(particles.a[2][0] < 0.0);
    }

    /// One particle alone in the block at `coords` of a 3x3x3 grid over the real box.
    fn wall_particle(
        coords: [usize; 3],
        p: DVec3,
        hv: DVec3,
        v: DVec3,
    ) -> (Grid, BlockOrder, Particles) {
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
        let mut blocks = BlockOrder::default();
        blocks.sort(
            &[grid.index(coords) as u32],
            grid.block_count(),
            &mut Vec::new(),
        );
        (grid, blocks, particles)
    }

    #[test]
    fn low_wall_pushes_a_particle_back() {
        let p = DVec3::new(BOX_MIN.x + 0.0001, 0.0, 0.0);
        let (grid, blocks, mut particles) =
            wall_particle([0, 1, 1], p, DVec3::ZERO, DVec3::new(-0.2, 0.0, 0.0));
        collide_with_walls(&grid, &blocks, &mut particles);
        let expected = COLLISION_STIFFNESS * (PARTICLE_SIZE - 0.0001) + DAMPING * 0.2;
        assert!((particles.a[0][0] - expected).abs() < 1e-9);
        assert_eq!(particles.a[1][0], 0.0);
    }

    #[test]
    fn high_wall_subtracts_stiffness_and_damping() {
        let p = DVec3::new(0.0, BOX_MAX.y - 0.0001, 0.0);
        let (grid, blocks, mut particles) =
            wall_particle([1, 2, 1], p, DVec3::ZERO, DVec3::new(0.0, 0.3, 0.0));
        collide_with_walls(&grid, &blocks, &mut particles);
        let expected = -(COLLISION_STIFFNESS * (PARTICLE_SIZE - 0.0001) + DAMPING * 0.3);
        assert!((particles.a[1][0] - expected).abs() < 1e-9);
    }

    #[test]
    fn walls_only_act_within_the_particle_size() {
        let p = DVec3::new(BOX_MIN.x + 0.001, 0.0, 0.0);
        let (grid, blocks, mut particles) = wall_particle([0, 1, 1], p, DVec3::ZERO, DVec3::X);
        collide_with_walls(&grid, &blocks, &mut particles);
        assert_eq!(particles.acceleration(0), DVec3::ZERO);
    }

    #[test]
    fn interior_blocks_ignore_the_walls_even_outside_the_box() {
        // The block comes from stage 1, so a particle in an interior block is left alone.
        let p = DVec3::new(BOX_MIN.x - 1.0, 0.0, 0.0);
        let (grid, blocks, mut particles) = wall_particle([1, 1, 1], p, DVec3::ZERO, DVec3::X);
        collide_with_walls(&grid, &blocks, &mut particles);
        interact_with_boundary(&grid, &blocks, &mut particles);
        assert_eq!(particles.acceleration(0), DVec3::ZERO);
        assert_eq!(particles.position(0), p);
    }

    #[test]
    fn motion_is_a_leapfrog_step() {
        let mut particles = Particles::zeroed(1);
        particles.p[0][0] = 1.0;
        particles.hv[0][0] = 2.0;
        particles.a[0][0] = 1000.0;
        move_particles(&mut particles);
        assert!((particles.p[0][0] - (1.0 + 2e-3 + 1e-3)).abs() < 1e-15);
        assert!((particles.v[0][0] - 2.5).abs() < 1e-15);
        assert!((particles.hv[0][0] - 3.0).abs() < 1e-15);
    }

    #[test]
    fn boundary_mirrors_crossing_particles_and_reverses_velocity() {
        let p = DVec3::new(BOX_MIN.x - 0.001, BOX_MAX.y + 0.002, 0.0);
        let (grid, blocks, mut particles) = wall_particle(
            [0, 2, 1],
            p,
            DVec3::new(-1.0, 2.0, 3.0),
            DVec3::new(-4.0, 5.0, 6.0),
        );
        interact_with_boundary(&grid, &blocks, &mut particles);
        assert!((particles.p[0][0] - (BOX_MIN.x + 0.001)).abs() < 1e-15);
        assert!((particles.p[1][0] - (BOX_MAX.y - 0.002)).abs() < 1e-15);
        assert_eq!(particles.half_velocity(0), DVec3::new(1.0, -2.0, 3.0));
        assert_eq!(particles.velocity(0), DVec3::new(4.0, -5.0, 6.0));
    }
}
