//! The stages of one time step (SPEC.md section 4) and the per-particle ones among them:
//! stages 6-8. Stage 1 is the cell order ([`crate::sim::cells`]), stage 2 is done by the
//! reordering ([`Particles::reset_densities_and_accelerations`]), and the pair stages 3-5
//! are the [`crate::sim::kernel`].

use crate::sim::cells::{wall_bit, Wall, WallBits, Walls};
use crate::sim::params::{COLLISION_STIFFNESS, DAMPING, PARTICLE_SIZE};
use crate::sim::particles::Particles;
use crate::sim::timestep::Leapfrog;
use wide::{f64x8, i32x8};

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

/// Slots per group of the per-particle stages.
const LANES: usize = 8;

/// Masks of the lanes whose block is on the low wall of `axis`, and on the high wall.
#[inline(always)]
fn wall_masks(bits: [WallBits; LANES], axis: usize) -> (f64x8, f64x8) {
    let bits = i32x8::from(bits.map(i32::from));
    let on = |wall| {
        let bit = i32x8::splat(i32::from(wall_bit(axis, wall)));
        f64x8::from_i32x8(bits & bit).simd_ne(f64x8::ZERO)
    };
    (on(Wall::Low), on(Wall::High))
}

/// The box's low and high wall on `axis`.
#[inline(always)]
fn bounds(walls: &Walls, axis: usize) -> (f64, f64) {
    (walls.min[axis], walls.max[axis])
}

/// Stage 6 on one axis of eight particles: the acceleration after the wall repulsion and
/// damping of their blocks' walls (the box's at `bounds` on that axis), judged by where each particle would be after `dt` at
/// its half-step velocity (SPEC.md erratum 5: dt the step; 0 under the velocity Verlet,
/// [`Leapfrog::lookahead`]). Lanes off the walls keep `a` unchanged.
#[inline(always)]
fn collide(bounds: (f64, f64), walls: (f64x8, f64x8), dt: f64, [p, hv, v, a]: [f64x8; 4]) -> f64x8 {
    let (low, high) = walls;
    let (min, max) = (f64x8::splat(bounds.0), f64x8::splat(bounds.1));
    let (size, stiffness, damping) = (
        f64x8::splat(PARTICLE_SIZE),
        f64x8::splat(COLLISION_STIFFNESS),
        f64x8::splat(DAMPING),
    );
    let threshold = f64x8::splat(1e-10);
    let x = p + hv * dt;
    let low_depth = size - (x - min);
    let high_depth = size - (max - x);
    let pushed_up = a + (stiffness * low_depth - damping * v);
    let pushed_down = a - (stiffness * high_depth + damping * v);
    let a = (high & high_depth.simd_gt(threshold)).select(pushed_down, a);
    (low & low_depth.simd_gt(threshold)).select(pushed_up, a)
}

/// Stage 7 on one axis of eight particles: the new [p, hv, v] of
/// p += hv dt + a kick dt; v = hv + a sync / 2; hv += a kick (old hv on the right), which
/// for equal steps (kick = sync = dt) is SPEC.md's p += hv dt + a dt^2; v = hv + a dt / 2;
/// hv += a dt.
#[inline(always)]
fn motion(step: Leapfrog, [p, hv, _, a]: [f64x8; 4]) -> [f64x8; 3] {
    let (dt, kick, sync) = (
        f64x8::splat(step.dt),
        f64x8::splat(step.kick),
        f64x8::splat(step.sync),
    );
    [
        p + (hv * dt + a * (kick * dt)),
        hv + a * kick,
        hv + a * sync / 2.0,
    ]
}

/// Stage 8 on one axis of eight particles: [p, hv, v], mirrored back with both
/// velocities reversed where a particle ended beyond a wall of its block (the box's at
/// `bounds` on that axis).
#[inline(always)]
fn bounce(bounds: (f64, f64), walls: (f64x8, f64x8), [p, hv, v]: [f64x8; 3]) -> [f64x8; 3] {
    let (low, high) = walls;
    let (min, max) = (f64x8::splat(bounds.0), f64x8::splat(bounds.1));
    let below = low & (p - min).simd_lt(f64x8::ZERO);
    let above = high & (max - p).simd_lt(f64x8::ZERO);
    let p = below.select(min - (p - min), above.select(max + (max - p), p));
    let crossed = below | above;
    [p, crossed.select(-hv, hv), crossed.select(-v, v)]
}

/// The fields of one axis that the per-particle stages read and write.
struct AxisFields<'a> {
    p: &'a mut [f64],
    hv: &'a mut [f64],
    v: &'a mut [f64],
    a: &'a mut [f64],
}

/// Calls `update(wall masks, [p, hv, v, a])` on every group of eight slots of `0..n` of
/// one axis and stores the fields it returns (of the last group, only its slots below
/// `n`). The masks are those of `axis` from `walls` (one entry per slot; none if empty).
#[inline(always)]
fn for_each_group(
    n: usize,
    walls: &[WallBits],
    axis: usize,
    fields: AxisFields,
    mut update: impl FnMut((f64x8, f64x8), [f64x8; 4]) -> [f64x8; 4],
) {
    let AxisFields { p, hv, v, a } = fields;
    let bits = |at: usize, count: usize| {
        let mut group = [0; LANES];
        if !walls.is_empty() {
            group[..count].copy_from_slice(&walls[at..at + count]);
        }
        group
    };
    let mut arrays = [&mut p[..n], &mut hv[..n], &mut v[..n], &mut a[..n]];
    let full = n - n % LANES;
    for at in (0..full).step_by(LANES) {
        let group = std::array::from_fn(|k| lanes_at(arrays[k], at));
        let updated = update(wall_masks(bits(at, LANES), axis), group);
        for (array, lanes) in arrays.iter_mut().zip(updated) {
            array[at..at + LANES].copy_from_slice(lanes.as_array());
        }
    }
    if full < n {
        // The last, partial group, through zero-filled lanes.
        let count = n - full;
        let group = std::array::from_fn(|k| {
            let mut lanes = [0.0; LANES];
            lanes[..count].copy_from_slice(&arrays[k][full..]);
            f64x8::from(lanes)
        });
        let updated = update(wall_masks(bits(full, count), axis), group);
        for (array, lanes) in arrays.iter_mut().zip(updated) {
            array[full..].copy_from_slice(&lanes.as_array()[..count]);
        }
    }
}

/// The eight values of `values` from `at` on.
#[inline(always)]
fn lanes_at(values: &[f64], at: usize) -> f64x8 {
    f64x8::from(<[f64; LANES]>::try_from(&values[at..at + LANES]).expect("eight slots"))
}

/// The [`AxisFields`] of `axis`.
fn axis_fields(particles: &mut Particles, axis: usize) -> AxisFields<'_> {
    let Particles { p, hv, v, a, .. } = particles;
    AxisFields {
        p: &mut p[axis],
        hv: &mut hv[axis],
        v: &mut v[axis],
        a: &mut a[axis],
    }
}

/// Stage 6: wall repulsion and damping for particles of boundary blocks (walls from
/// stage 1, one entry per slot).
pub fn collide_with_walls(walls: &Walls, dt: f64, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        for_each_group(n, walls.bits(), axis, fields, |masks, [p, hv, v, a]| {
            [
                p,
                hv,
                v,
                collide(bounds(walls, axis), masks, dt, [p, hv, v, a]),
            ]
        });
    }
}

/// Stage 7: leapfrog integration of every particle.
pub fn move_particles(dt: f64, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        for_each_group(n, &[], axis, fields, |_, group| {
            let [p, hv, v] = motion(Leapfrog::fixed(dt), group);
            [p, hv, v, group[3]]
        });
    }
}

/// Stage 8: particles of boundary blocks (blocks from stage 1, not recomputed) that ended
/// beyond their wall are mirrored back and their velocities reversed on that axis.
pub fn interact_with_boundary(walls: &Walls, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        for_each_group(n, walls.bits(), axis, fields, |masks, [p, hv, v, a]| {
            let [p, hv, v] = bounce(bounds(walls, axis), masks, [p, hv, v]);
            [p, hv, v, a]
        });
    }
}

/// Stages 6, 7 and 8 in one pass over each axis (each stage is per particle and per axis,
/// so the result is that of the three stages in turn), for a step of `step.dt` (the wall
/// stage judges positions [`Leapfrog::lookahead`] after its start) after one of
/// `step.sync`.
pub fn advance(walls: &Walls, step: Leapfrog, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        for_each_group(n, walls.bits(), axis, fields, |masks, [p, hv, v, a]| {
            let bounds = bounds(walls, axis);
            let a = collide(bounds, masks, step.lookahead(), [p, hv, v, a]);
            let [p, hv, v] = bounce(bounds, masks, motion(step, [p, hv, v, a]));
            [p, hv, v, a]
        });
    }
}

/// The floor of stages 6-8: [`move_particles`]' leapfrog in one plain pass per axis over
/// the state arrays, with no walls and no groups of lanes: what any step must read (p,
/// hv, a) and write (p, hv, v) of each particle, which `benches/step.rs` times beside
/// each stage.
pub fn state_floor(dt: f64, particles: &mut Particles) {
    let n = particles.len();
    let Leapfrog { dt, kick, sync, .. } = Leapfrog::fixed(dt);
    for axis in 0..3 {
        let AxisFields { p, hv, v, a } = axis_fields(particles, axis);
        let state = p[..n].iter_mut().zip(&mut hv[..n]).zip(&mut v[..n]);
        for (((p, hv), v), &a) in state.zip(&a[..n]) {
            let half = *hv;
            *p += half * dt + a * (kick * dt);
            *hv = half + a * kick;
            *v = half + a * sync / 2.0;
        }
    }
}

/// Both walls of an axis, for every lane.
const EVERY_WALL: (f64x8, f64x8) = (
    f64x8::new([f64::from_bits(u64::MAX); LANES]),
    f64x8::new([f64::from_bits(u64::MAX); LANES]),
);

/// The leapfrog of `step` for every particle, then every particle beyond a wall of the
/// box (that of `walls`) mirrored back with its velocities reversed on that axis (a last
/// guard: the weakly compressible model's walls are its particles' mirror images, and no
/// penalty).
pub fn advance_within_box(walls: &Walls, step: Leapfrog, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        let bounds = bounds(walls, axis);
        let periodic = walls.periodic[axis];
        for_each_group(n, &[], axis, fields, |_, [p, hv, v, a]| {
            let moved = motion(step, [p, hv, v, a]);
            let [p, hv, v] = match periodic {
                true => wrap(bounds, moved),
                false => bounce(bounds, EVERY_WALL, moved),
            };
            [p, hv, v, a]
        });
    }
}

/// On a periodic axis (between `bounds`), [p, hv, v] with each particle beyond a face
/// moved in at the other by the box's length, its velocities kept.
#[inline(always)]
fn wrap(bounds: (f64, f64), [p, hv, v]: [f64x8; 3]) -> [f64x8; 3] {
    let (min, max) = (f64x8::splat(bounds.0), f64x8::splat(bounds.1));
    let length = max - min;
    let below = p.simd_lt(min);
    let beyond = p.simd_ge(max);
    [
        below.select(p + length, beyond.select(p - length, p)),
        hv,
        v,
    ]
}

/// The velocities the forces of a step read under the velocity Verlet: each particle's
/// v predicted to the step's start from its half-step velocity and the last step's
/// acceleration, v = hv + a `half` (`half` the last step's length over 2).
pub fn predict_velocities(half: f64, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let (hv, a) = (&particles.hv[axis][..n], &particles.a[axis][..n]);
        for ((v, &hv), &a) in particles.v[axis][..n].iter_mut().zip(hv).zip(a) {
            *v = hv + a * half;
        }
    }
}

/// The mirror of [`advance_within_box`] alone: every particle beyond a wall of the box
/// (that of `walls`) mirrored back, its velocities reversed on that axis.
pub fn reflect_into_box(walls: &Walls, particles: &mut Particles) {
    let n = particles.len();
    for axis in 0..3 {
        let fields = axis_fields(particles, axis);
        let bounds = bounds(walls, axis);
        let periodic = walls.periodic[axis];
        for_each_group(n, &[], axis, fields, |_, [p, hv, v, a]| {
            let [p, hv, v] = match periodic {
                true => wrap(bounds, [p, hv, v]),
                false => bounce(bounds, EVERY_WALL, [p, hv, v]),
            };
            [p, hv, v, a]
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::CellOrder;
    use crate::sim::grid::Grid;
    use crate::sim::params::{Domain, BOX_MAX, BOX_MIN, TIME_STEP};
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
    fn wall_particle(coords: [usize; 3], p: DVec3, hv: DVec3, v: DVec3) -> (Walls, Particles) {
        let grid = Grid {
            dims: [3, 3, 3],
            block_size: (BOX_MAX - BOX_MIN) / 3.0,
            min: BOX_MIN,
            max: BOX_MAX,
            periodic: [false; 3],
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
    fn the_state_floor_is_the_leapfrog_of_stage_seven() {
        // 11 particles (a partial last group of lanes), bit for bit.
        let mut random = fastrand::Rng::with_seed(5);
        let mut particles = Particles::zeroed(11);
        for axis in 0..3 {
            for slot in 0..11 {
                particles.p[axis][slot] = random.f64() - 0.5;
                particles.hv[axis][slot] = random.f64() - 0.5;
                particles.a[axis][slot] = 100.0 * (random.f64() - 0.5);
            }
        }
        let mut floor = particles.clone();
        move_particles(TIME_STEP, &mut particles);
        state_floor(TIME_STEP, &mut floor);
        assert_eq!(floor, particles);
        assert!(floor.p[0][3] != 0.0 && floor.v[2][10] != 0.0);
    }

    #[test]
    fn advance_is_stages_six_seven_and_eight_in_turn() {
        // Thirteen particles (a full group of 8, then a partial one) around and beyond
        // the walls, with the blocks a 3 x 3 x 3 grid gives their positions.
        let grid = Grid {
            dims: [3, 3, 3],
            block_size: (BOX_MAX - BOX_MIN) / 3.0,
            min: BOX_MIN,
            max: BOX_MAX,
            periodic: [false; 3],
        };
        let mut particles = Particles::zeroed(13);
        for slot in 0..13 {
            let t = slot as f64 / 12.0;
            for axis in 0..3 {
                let span = BOX_MAX[axis] - BOX_MIN[axis];
                particles.p[axis][slot] = BOX_MIN[axis] - 0.001 + (span + 0.002) * t;
                particles.hv[axis][slot] = (t - 0.5) * (axis as f64 + 1.0);
                particles.v[axis][slot] = 0.5 - t;
                particles.a[axis][slot] = 3.0 * t - 1.0;
            }
        }
        particles.pad();
        let mut cells = CellOrder::default();
        cells.sort(&grid, &particles);
        let walls = cells.walls().clone();
        let mut in_turn = particles.clone();
        collide_with_walls(&walls, TIME_STEP, &mut in_turn);
        move_particles(TIME_STEP, &mut in_turn);
        interact_with_boundary(&walls, &mut in_turn);
        advance(&walls, Leapfrog::fixed(TIME_STEP), &mut particles);
        assert_eq!(particles, in_turn);
        // Particles on walls in both groups, and one mirrored back in each.
        assert!(walls.bits()[..8].iter().any(|&bits| bits != 0));
        assert!(walls.bits()[8..].iter().any(|&bits| bits != 0));
        assert_ne!(particles.p[0][0], BOX_MIN.x - 0.001);
        assert!(particles.p[0][12] <= BOX_MAX.x);
    }

    #[test]
    fn within_the_box_every_particle_moves_and_none_stays_beyond_a_wall() {
        let mut particles = Particles::zeroed(5);
        for slot in 0..5 {
            particles.p[1][slot] = BOX_MIN.y + 1e-4;
            particles.hv[1][slot] = -1.0 + 0.5 * slot as f64;
            particles.a[1][slot] = 0.0;
        }
        let mut cells = CellOrder::default();
        cells.sort(&Grid::new(0.01, &Domain::COURSE).unwrap(), &particles);
        advance_within_box(cells.walls(), Leapfrog::fixed(1e-3), &mut particles);
        for slot in 0..5 {
            let speed = -1.0 + 0.5 * slot as f64;
            let moved = BOX_MIN.y + 1e-4 + speed * 1e-3;
            let (y, hv) = (particles.p[1][slot], particles.hv[1][slot]);
            if moved < BOX_MIN.y {
                assert!((y - (2.0 * BOX_MIN.y - moved)).abs() < 1e-15 && hv == -speed);
            } else {
                assert!((y - moved).abs() < 1e-15 && hv == speed);
            }
        }
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
