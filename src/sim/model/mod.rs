//! The physical models, one module each: [`course`] (SPEC.md's model and PARSEC
//! fluidanimate's stable variant, one type that differs by its viscosity) and [`wcsph`]
//! (weakly compressible water). A model is a [`Dynamics`]: its constants, the state it
//! carries beyond positions and velocities, its pair passes (calls into the
//! [`crate::sim::kernel`]), its per-particle update (walls, motion), its time-step rule and
//! what a checkpoint keeps of it. The driver ([`crate::sim::simulation::Simulation`]) meets
//! the models through that trait only; [`Model::dynamics`] is the one place a model is
//! chosen by name.

pub mod course;
pub mod wcsph;

pub use course::Course;
pub use wcsph::Wcsph;

use crate::sim::cells::Walls;
use crate::sim::kernel::Kernel;
use crate::sim::lists::NeighbourLists;
use crate::sim::neighbours::Tile;
use crate::sim::params::Params;
use crate::sim::particles::Particles;
use crate::sim::stages::Stage;
use crate::sim::timestep::{Integrator, Leapfrog, Limit, TimeStep};
use glam::DVec3;

/// The physical model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum Model {
    /// The course model of SPEC.md: viscosity `(v_j - v_i) * 45/(pi h^6) * mu * m`.
    /// Unstable (the fluid leaves the box within a few steps); `fluid` always runs it.
    #[default]
    Course,
    /// The PARSEC fluidanimate variant: the viscosity term is also multiplied by
    /// `(h - dist)`, which keeps the fluid in the box.
    Fluidanimate,
    /// Weakly compressible SPH as the validated codes run water (`sim::wcsph`): Tait's
    /// equation of state (gamma 7, sound speed ten times the fastest fall), density by
    /// the continuity equation with delta-SPH, Monaghan's viscosity, the Wendland kernel
    /// (support 2.6 spacings), mirror walls (no-slip by default), and a CFL time step by
    /// default.
    Wcsph,
}

impl Model {
    /// Every model, in a fixed order.
    pub const ALL: [Model; 3] = [Model::Course, Model::Fluidanimate, Model::Wcsph];

    /// The model's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Model::Course => "course",
            Model::Fluidanimate => "fluidanimate",
            Model::Wcsph => "wcsph",
        }
    }

    /// The model's dynamics, not yet started ([`Dynamics::prepare`] starts them): the one
    /// place a model is chosen by name.
    pub fn dynamics(self) -> Box<dyn Dynamics> {
        match self {
            Model::Course => Box::new(Course::<false>::default()),
            Model::Fluidanimate => Box::new(Course::<true>::default()),
            Model::Wcsph => Box::new(Wcsph::default()),
        }
    }

    /// Whether the model keeps its fluid in the box: every model but the course's, which
    /// SPEC.md makes leave it within a few steps. A run of one that has particles more
    /// than h outside has blown up.
    pub fn keeps_to_its_box(self) -> bool {
        self != Model::Course
    }

    /// The time-step rule the model runs with unless told otherwise: the course's fixed
    /// 1 ms, or for the stiff weakly compressible model its CFL step.
    pub fn default_time_step(self) -> TimeStep {
        self.dynamics().default_time_step()
    }

    /// The parameters derived from `ppm` particles per metre, with the model's pair
    /// cut-off as h.
    pub fn params(self, ppm: f64) -> Params {
        Params::with_cutoff(ppm, self.dynamics().cutoff(ppm))
    }
}

/// What the driver lends a model for a stage: the current step's parameters, kernel,
/// neighbour tiles and walls, and the particles in cell order.
#[derive(Debug)]
pub struct Context<'a> {
    /// The derived parameters (`dt` is the fixed step of stages run alone).
    pub params: &'a Params,
    /// The pair-loop implementation.
    pub kernel: Kernel,
    /// The tiles of candidate pairs.
    pub tiles: &'a [Tile],
    /// The neighbour lists of the same placement, where the driver built them (a dense
    /// scene, a kernel on lanes, lists asked for).
    pub lists: Option<&'a NeighbourLists>,
    /// The walls of each slot's block (stage 1); of each stored particle during a step
    /// that left the particles in place ([`Dynamics::partnerless`]).
    pub walls: &'a Walls,
    /// A new number each time the particles are placed (stage 1) or the kernel changes:
    /// what a model found in an earlier placement is stale.
    pub placement: u64,
    /// How the step advances the state.
    pub integrator: Integrator,
    /// The last step's length (none before the first step).
    pub previous_step: Option<f64>,
    /// The particles, in cell order and padded (during a step that left the particles in
    /// place, the compact copy of those that may have a pair).
    pub particles: &'a mut Particles,
}

/// The density and acceleration a step's pair passes leave a particle without a partner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Partnerless {
    /// Its density (kg/m^3).
    pub density: f64,
    /// Its acceleration (m/s^2).
    pub acceleration: DVec3,
}

/// A physical model as the driver runs it. A step is: the driver places the particles
/// (stage 1) and resets what the pair passes sum into (stage 2: accelerations to gravity,
/// and densities to zero unless [`Self::carries_densities`]), then [`Self::interact`],
/// the step's length (fixed, or [`Self::adaptive_step`]), then [`Self::advance`].
pub trait Dynamics: std::fmt::Debug + dyn_clone::DynClone {
    /// The pair cut-off at `ppm` particles per metre (m): the smallest side of a block.
    fn cutoff(&self, ppm: f64) -> f64;

    /// The time-step rule unless told otherwise (a fixed rule runs at [`Params::dt`]).
    fn default_time_step(&self) -> TimeStep;

    /// The pressure (Pa) of fluid at `density` (kg/m^3): the model's equation of state.
    fn pressure(&self, density: f64) -> f64;

    /// The skin its neighbour lists are kept over steps with unless told otherwise, as
    /// a fraction of the cut-off (none: rebuilt every step; [`crate::sim::skin`]).
    fn default_skin(&self) -> Option<f64> {
        None
    }

    /// The smoothing length of the model's kernel (m), in which accuracy budgets are
    /// given: the cut-off unless the kernel's support is wider than h.
    fn smoothing_length(&self, params: &Params) -> f64 {
        params.h
    }

    /// Whether the densities are a state of their own, carried from step to step (moved
    /// with the particles, kept by stage 2), rather than recomputed each step.
    fn carries_densities(&self) -> bool {
        false
    }

    /// Starts the model on `particles` (any order, padded): what depends on the start.
    fn prepare(&mut self, _params: &Params, _particles: &Particles) {}

    /// The per-particle state of a fresh start (not of a resumed or traced one).
    fn initial_state(&self, _params: &Params, _particles: &mut Particles) {}

    /// What a checkpoint keeps of the model beyond the particles: first what it holds
    /// from its start (its settings and what it chose for its particles), then what its
    /// steps added, so that a run's start is a prefix of each of its checkpoints'.
    fn saved(&self) -> Vec<f64> {
        Vec::new()
    }

    /// Starts the model from what [`Self::saved`] gave, or says what is wrong with it.
    fn restore(&mut self, _params: &Params, saved: &[f64]) -> Result<(), String> {
        match saved {
            [] => Ok(()),
            _ => Err(format!(
                "it keeps {} value(s) of its model, which keeps none",
                saved.len()
            )),
        }
    }

    /// The pair passes of a step (after stage 2): accelerations, and what else the model
    /// computes from pairs.
    fn interact(&mut self, context: &mut Context);

    /// What [`Self::interact`] leaves a particle with no partner closer than the cut-off
    /// (`params.h`), where that is the same for every such particle; `None` (the default)
    /// where it depends on the particle. Where given, the driver may leave such particles
    /// where they are and run [`Self::interact`] on a compact copy of the others
    /// ([`Context::particles`]: fewer than all, and [`Context::walls`] then per stored
    /// particle, not per slot of the copy), so a model that gives it must not read the
    /// walls in its pair passes.
    fn partnerless(&self, _params: &Params) -> Option<Partnerless> {
        None
    }

    /// The densities of the current positions, where they are not a state (stages 3 and
    /// 4), or those a state of densities predicts for the current time (the velocity
    /// Verlet's, kept at the half step): for looking at a state.
    fn refresh_densities(&mut self, _context: &mut Context) {}

    /// The adaptive step of the state after [`Self::interact`], C = `courant`, and the
    /// criterion that set it.
    fn adaptive_step(&self, params: &Params, particles: &Particles, courant: f64) -> (f64, Limit);

    /// Walls, motion and boundary for `step` (stages 6-8), and any state of the model's
    /// advanced over it.
    fn advance(&mut self, step: Leapfrog, walls: &Walls, particles: &mut Particles);

    /// Runs one stage alone (for traces and benchmarks); [`Stage::Reposition`] and
    /// [`Stage::InitAccelerations`] are the driver's.
    fn run_stage(&mut self, stage: Stage, context: &mut Context);

    /// The bytes the model's buffers hold on the heap.
    fn heap_bytes(&self) -> usize {
        0
    }
}

dyn_clone::clone_trait_object!(Dynamics);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_variants_and_the_command_line() {
        use clap::ValueEnum;
        assert_eq!(
            Model::ALL.map(Model::name),
            ["course", "fluidanimate", "wcsph"]
        );
        for model in Model::ALL {
            assert_eq!(model.to_possible_value().unwrap().get_name(), model.name());
        }
    }

    #[test]
    fn each_model_has_its_cut_off_and_step_rule() {
        // Through black_box: `powi` folded at compile time may differ from `powi` at run
        // time in the last bit, and a run's particles per metre come from its file.
        let ppm = std::hint::black_box(200.0);
        assert_eq!(Model::Course.params(ppm), Params::new(ppm));
        assert_eq!(Model::Fluidanimate.params(ppm), Params::new(ppm));
        assert_eq!(
            Model::Wcsph.params(ppm).h,
            2.0 * wcsph::Settings::default().smoothing / ppm
        );
        assert_eq!(
            Model::Course.default_time_step(),
            TimeStep::Fixed(crate::sim::params::TIME_STEP)
        );
        assert_eq!(
            Model::Wcsph.default_time_step(),
            TimeStep::Adaptive {
                courant: wcsph::COURANT
            }
        );
    }
}
