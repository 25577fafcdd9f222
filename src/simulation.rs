//! The simulation driver: owns the particles in cell order, their block order and the
//! buffers reused from step to step, and runs stages and time steps.

use crate::block::BlockOrder;
use crate::grid::{Grid, GridSizeError};
use crate::params::Params;
use crate::particles::Particles;
use crate::stages::{self, Stage};

/// A running simulation of the course model.
#[derive(Debug, Clone)]
pub struct Simulation {
    params: Params,
    grid: Grid,
    /// The particles, stored block after block (cell order).
    particles: Particles,
    blocks: BlockOrder,
    /// Buffers reused by the repositioning so no step allocates.
    spare: Particles,
    block_of_slot: Vec<u32>,
    order: Vec<u32>,
}

impl Simulation {
    /// Places `particles` (in file order) into the grid for `ppm` particles per metre.
    pub fn new(ppm: f64, particles: Particles) -> Result<Self, GridSizeError> {
        let params = Params::new(ppm);
        let grid = Grid::new(params.h)?;
        let mut simulation = Self::from_cell_order(params, grid, particles, BlockOrder::default());
        simulation.reposition();
        Ok(simulation)
    }

    /// A simulation whose particles are already in cell order with block ranges `blocks`
    /// (as in a reference trace).
    pub fn from_cell_order(
        params: Params,
        grid: Grid,
        particles: Particles,
        blocks: BlockOrder,
    ) -> Self {
        Self {
            params,
            grid,
            particles,
            blocks,
            spare: Particles::default(),
            block_of_slot: Vec::new(),
            order: Vec::new(),
        }
    }

    /// The derived parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The grid of blocks.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The particles in cell order (their `id` field gives the file order).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// The block ranges of the particles.
    pub fn blocks(&self) -> &BlockOrder {
        &self.blocks
    }

    /// Runs `steps` time steps.
    pub fn run(&mut self, steps: u64) {
        for _ in 0..steps {
            self.step();
        }
    }

    /// Runs one time step: all stages in order.
    pub fn step(&mut self) {
        for stage in Stage::ALL {
            self.run_stage(stage);
        }
    }

    /// Runs one stage alone (for trace comparisons and stage benchmarks).
    pub fn run_stage(&mut self, stage: Stage) {
        let (params, grid, blocks) = (&self.params, &self.grid, &self.blocks);
        let particles = &mut self.particles;
        match stage {
            Stage::Reposition => self.reposition(),
            Stage::InitAccelerations => stages::init_accelerations(particles),
            Stage::IncrementDensities => {
                stages::increment_densities(params, grid, blocks, particles)
            }
            Stage::TransformDensities => stages::transform_densities(params, particles),
            Stage::TransferAccelerations => {
                stages::transfer_accelerations(params, grid, blocks, particles)
            }
            Stage::CollideWithWalls => stages::collide_with_walls(grid, blocks, particles),
            Stage::Move => stages::move_particles(particles),
            Stage::InteractWithBoundary => stages::interact_with_boundary(grid, blocks, particles),
        }
    }

    /// Stage 1: recomputes every particle's block from its position and reorders the
    /// particles by block with a stable counting sort (old blocks ascending, stored order
    /// within a block). Density and acceleration are left for stage 2 to reset.
    fn reposition(&mut self) {
        let (grid, particles) = (&self.grid, &self.particles);
        self.block_of_slot.clear();
        self.block_of_slot
            .extend((0..particles.len()).map(|s| grid.block_of(particles.position(s)) as u32));
        self.blocks
            .sort(&self.block_of_slot, grid.block_count(), &mut self.order);
        self.spare.gather_kinematics(&self.particles, &self.order);
        std::mem::swap(&mut self.particles, &mut self.spare);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::BOX_MIN;

    /// Particles at the given x positions (y, z at the box's lower corner plus a margin).
    fn along_x(xs: &[f64]) -> Particles {
        let mut particles = Particles::zeroed(xs.len());
        particles.p[0] = xs.to_vec();
        particles.p[1] = vec![BOX_MIN.y + 0.05; xs.len()];
        particles.p[2] = vec![BOX_MIN.z + 0.05; xs.len()];
        particles
    }

    #[test]
    fn new_places_particles_in_block_order() {
        let sim = Simulation::new(204.0, along_x(&[0.06, -0.06, 0.0, -0.061])).unwrap();
        assert_eq!(sim.particles().id, vec![1, 3, 2, 0]);
        let first = sim.grid().block_of(sim.particles().position(0));
        assert_eq!(sim.blocks().range(first), 0..2);
        assert_eq!(sim.blocks().occupied().len(), 3);
    }

    #[test]
    fn new_rejects_a_ppm_without_a_grid() {
        assert!(Simulation::new(5.0, along_x(&[0.0])).is_err());
    }

    #[test]
    fn a_step_keeps_every_particle_once() {
        let mut sim = Simulation::new(204.0, along_x(&[0.0, 0.001, 0.002, 0.05])).unwrap();
        sim.run(3);
        let mut ids = sim.particles().id.clone();
        ids.sort_unstable();
        assert_eq!(ids, vec![0, 1, 2, 3]);
        let total: usize = sim
            .blocks()
            .occupied()
            .iter()
            .map(|&b| sim.blocks().count(b as usize))
            .sum();
        assert_eq!(total, 4);
    }

    #[test]
    fn a_lone_particle_falls_under_gravity() {
        let mut sim = Simulation::new(204.0, along_x(&[0.0])).unwrap();
        let y0 = sim.particles().p[1][0];
        sim.run(2);
        // Two leapfrog steps from rest: hv = 2 g dt, y = y0 + g dt^2 + (g dt^2 + g dt^2).
        let expected = y0 - 9.8 * 3.0 * 1e-6;
        assert!((sim.particles().p[1][0] - expected).abs() < 1e-15);
        assert!((sim.particles().hv[1][0] + 2.0 * 9.8e-3).abs() < 1e-15);
    }
}
