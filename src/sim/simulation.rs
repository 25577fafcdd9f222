//! The simulation driver: owns the particles (in cell order, or left where they are with
//! a compact copy of those that may have a pair), the cell order and neighbour tiles of
//! the current step, the clock and the buffers reused from step to step (no step
//! allocates once the buffers have grown), and runs stages and time steps. What a step
//! computes between placing the particles and advancing the clock is the model's
//! ([`crate::sim::model::Dynamics`]); the driver names none.

use crate::sim::cells::CellOrder;
use crate::sim::grid::{Grid, GridSizeError};
use crate::sim::isa::InstructionSet;
use crate::sim::lists::{ListLayout, NeighbourLists, PairStructure, ROW};
use crate::sim::method::Method;
use crate::sim::model::{Context, Dynamics, Partnerless};
use crate::sim::neighbours::{Tile, TileSearch};
use crate::sim::params::{Domain, Params};
use crate::sim::particles::Particles;
use crate::sim::skin::{KeptSkin, Skin};
use crate::sim::stages::{self, Stage};
use crate::sim::timestep::{Integrator, Leapfrog, Limit, TimeStep};

/// How far beyond h (relative, in r^2) a particle's nearest neighbour may be for it to
/// still join the pair passes of a step that left the particles in place: a margin for
/// kernels whose r^2 rounds differently, so that no pair closer than h is ever left out.
const PARTNER_MARGIN: f64 = 1e-9;

/// Everything a simulation needs to go on exactly as it would have (a checkpoint): its
/// particles in their slot order, and the state the next step reads besides them.
#[derive(Debug, Clone, PartialEq)]
pub struct Resumable {
    /// Particles per metre (the parameters derive from it).
    pub ppm: f64,
    /// The box and gravity.
    pub domain: Domain,
    /// The model and kernel.
    pub method: Method,
    /// How steps' lengths are chosen.
    pub time_step: TimeStep,
    /// How steps advance the state.
    pub integrator: Integrator,
    /// The structure the SIMD pair loops run on (it decides the order of their sums).
    pub structure: PairStructure,
    /// Physical time simulated so far (s).
    pub time: f64,
    /// The last step's length and what set it.
    pub last_step: Option<(f64, Limit)>,
    /// Whether the last sort found the particles sparse (see [`CellOrder::is_sparse`]).
    pub sparse: bool,
    /// What the model keeps beyond the particles ([`Dynamics::saved`]: the weakly
    /// compressible model's sound speed, chosen at its start, its settings and, under the
    /// velocity Verlet, its last density rates; nothing for the others).
    pub model_state: Vec<f64>,
    /// The particles, in slot order, unpadded (with the densities of a model whose
    /// densities are a state: those of the step's start, or under the velocity Verlet
    /// those of the half step, which the next step predicts on).
    pub particles: Particles,
    /// The skin lists are kept with, and its last build, if lists are kept over steps.
    pub skin: Option<KeptSkin>,
}

/// A running simulation.
#[derive(Debug, Clone)]
pub struct Simulation {
    params: Params,
    grid: Grid,
    method: Method,
    /// The model: its constants, state and buffers.
    dynamics: Box<dyn Dynamics>,
    /// The particles, padded for the kernels' lane loads: stored cell after cell, or
    /// where they were stored before a placement that left them in place.
    particles: Particles,
    cells: CellOrder,
    search: TileSearch,
    /// The neighbour structure the SIMD pair loops run on.
    structure: PairStructure,
    /// The neighbour lists of the current placement, if built ([`Self::build_lists`]).
    lists: NeighbourLists,
    lists_built: bool,
    /// Counts the placements and kernel changes ([`Context::placement`]).
    placement: u64,
    /// Buffer reused by the reordering; where a placement leaves the particles in place,
    /// the compact copy of those that may have a pair, which the pair passes run on.
    spare: Particles,
    /// How each step's length is chosen.
    time_step: TimeStep,
    /// Physical time simulated so far (s).
    time: f64,
    /// The last step's length and what set it (none before the first step).
    last_step: Option<(f64, Limit)>,
    /// Lists reused with a skin, if the model's default or the run asks for them.
    skin: Option<Skin>,
    /// How each step advances the state.
    integrator: Integrator,
}

impl Simulation {
    /// The course model on the SIMD kernel, for `particles` (in file order) at `ppm`
    /// particles per metre, placed by stage 1.
    pub fn new(ppm: f64, particles: Particles) -> Result<Self, GridSizeError> {
        Self::with_method(ppm, particles, Method::default())
    }

    /// As [`Self::new`], with a chosen model and kernel, started as the model starts
    /// ([`Dynamics::prepare`] and [`Dynamics::initial_state`]: the weakly compressible
    /// model's densities of water at rest below the fluid's top and its sound speed for
    /// the height of its highest particle) with its own time-step rule.
    pub fn with_method(
        ppm: f64,
        particles: Particles,
        method: Method,
    ) -> Result<Self, GridSizeError> {
        Self::with_params(method.model.params(ppm), particles, method)
    }

    /// As [`Self::with_method`], in `domain` (its box and gravity), with `dynamics`, the
    /// model `method` names with choices of its own (e.g. the weakly compressible model's
    /// walls and viscosity), whose cut-off sets the parameters.
    pub fn with_dynamics(
        ppm: f64,
        domain: Domain,
        particles: Particles,
        method: Method,
        dynamics: Box<dyn Dynamics>,
    ) -> Result<Self, GridSizeError> {
        let params = Params::with_cutoff(ppm, dynamics.cutoff(ppm)).within(domain);
        Self::placed(params, particles, method, dynamics)
    }

    /// As [`Self::with_method`], with parameters of one's own (e.g. another time step, the
    /// course models' fixed step; `params.h` must be the model's cut-off).
    pub fn with_params(
        params: Params,
        particles: Particles,
        method: Method,
    ) -> Result<Self, GridSizeError> {
        Self::placed(params, particles, method, method.model.dynamics())
    }

    /// The simulation of `particles` with `dynamics`, started and placed.
    fn placed(
        params: Params,
        particles: Particles,
        method: Method,
        dynamics: Box<dyn Dynamics>,
    ) -> Result<Self, GridSizeError> {
        let grid = Grid::new(params.h, &params.domain)?;
        let mut simulation = Self::unplaced(params, grid, method, dynamics, particles);
        simulation
            .dynamics
            .initial_state(&params, &mut simulation.particles);
        simulation.reposition();
        Ok(simulation)
    }

    /// The state after stage 1 of a step, as a trace records it: `particles` in any order
    /// with every field kept, and `blocks` the block stage 1 gave each of them (which the
    /// wall stages use even after the particles have moved); placed as stage 1 places
    /// them.
    pub fn after_stage_one(
        params: Params,
        grid: Grid,
        method: Method,
        particles: Particles,
        blocks: &[u32],
    ) -> Self {
        let dynamics = method.model.dynamics();
        let mut simulation = Self::unplaced(params, grid, method, dynamics, Particles::default());
        simulation.cells.sort_with_blocks(&grid, &particles, blocks);
        simulation.particles = particles.permuted(simulation.cells.order());
        simulation.find_neighbours();
        simulation
    }

    /// The simulation before stage 1, its model `dynamics` prepared on `particles` (for
    /// the weakly compressible model, the sound speed of their heights) with its own
    /// time-step rule (a fixed one at `params.dt`).
    fn unplaced(
        params: Params,
        grid: Grid,
        method: Method,
        mut dynamics: Box<dyn Dynamics>,
        mut particles: Particles,
    ) -> Self {
        particles.pad();
        dynamics.prepare(&params, &particles);
        // The model's skin, where its grid exists (else the lists are rebuilt each step).
        let skin = dynamics
            .default_skin()
            .and_then(|fraction| Skin::new(params.h, fraction * params.h, &params.domain).ok());
        let time_step = match dynamics.default_time_step() {
            TimeStep::Fixed(_) => TimeStep::Fixed(params.dt),
            adaptive => adaptive,
        };
        Self {
            params,
            grid,
            method,
            dynamics,
            particles,
            cells: CellOrder::default(),
            search: TileSearch::default(),
            structure: PairStructure::default(),
            lists: NeighbourLists::default(),
            lists_built: false,
            placement: 0,
            spare: Particles::default(),
            time_step,
            time: 0.0,
            last_step: None,
            skin,
            integrator: Integrator::default(),
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

    /// The model and kernel.
    pub fn method(&self) -> Method {
        self.method
    }

    /// The smoothing length of the model's kernel (m): the unit of accuracy budgets in h.
    pub fn smoothing_length(&self) -> f64 {
        self.dynamics.smoothing_length(&self.params)
    }

    /// The pressure (Pa) of fluid at `density` under the model's equation of state.
    pub fn pressure(&self, density: f64) -> f64 {
        self.dynamics.pressure(density)
    }

    /// The particles (their `id` field gives the file order): in the cell order of the
    /// last placement, unless a step left them in place ([`CellOrder::is_in_place`]).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// Where each particle of the last placement's slot order is in [`Self::particles`]:
    /// the order in which sums over the particles run as they did over particles moved
    /// into cell order.
    pub fn slot_order(&self) -> impl Iterator<Item = usize> + '_ {
        let in_place = self.cells.is_in_place();
        let order = self.cells.order();
        (0..self.particles.len()).map(
            move |slot| {
                if in_place {
                    order[slot] as usize
                } else {
                    slot
                }
            },
        )
    }

    /// The cell order of the current step (and the walls of each particle's block).
    pub fn cells(&self) -> &CellOrder {
        &self.cells
    }

    /// The bytes the simulation holds on the heap: particles, the reordering's spare
    /// copy, cell order, tiles and the model's buffers (capacities, so the peak of the run).
    pub fn heap_bytes(&self) -> usize {
        self.particles.heap_bytes()
            + self.spare.heap_bytes()
            + self.cells.heap_bytes()
            + self.search.heap_bytes()
            + self.lists.heap_bytes()
            + self.dynamics.heap_bytes()
            + self.skin.as_ref().map_or(0, Skin::heap_bytes)
    }

    /// The tiles of candidate pairs of the current step. Like the lists, they index
    /// the particles as placed: [`Self::particles`], or the compact copy of those that
    /// may have a pair where a step left them in place ([`CellOrder::is_in_place`]);
    /// [`Self::with_fresh_densities`] gives a copy placed in cell order.
    pub fn tiles(&self) -> &[Tile] {
        self.search.tiles()
    }

    /// The neighbour lists of the current placement, where its pair passes run on them
    /// (indexing the particles as the tiles do).
    pub fn lists(&self) -> Option<&NeighbourLists> {
        self.lists_built.then_some(&self.lists)
    }

    /// The pair lanes a pass over every candidate of the current placement evaluates on
    /// the run's kernel and structure (a SIMD kernel's masked lanes included): on the
    /// tiles, each first slot's partner range rounded up to whole
    /// groups of the kernel's lanes (1 per pair on the scalar and reference kernels).
    /// On the lists, each slot's list rounded up to whole groups of the kernel's lanes;
    /// on their rows, each block's rows times the lanes its slots fill, rounded up to
    /// whole registers (each pair twice, so at most half of them are useful). The
    /// density pass of the course models is such a pass.
    pub fn pair_lanes(&self) -> u64 {
        let lanes = self.method.kernel.lanes();
        if let Some(rows) = self.lists().and_then(NeighbourLists::rows) {
            let n = rows.far() as usize;
            let filled = |block: usize| (n - block * ROW).min(ROW).next_multiple_of(lanes);
            let blocks = 0..rows.blocks();
            return blocks
                .map(|b| rows.rows(b).len() * filled(b))
                .sum::<usize>() as u64;
        }
        if self.lists_built {
            let groups: usize = (0..self.lists.slots())
                .map(|slot| self.lists.range(slot).len().div_ceil(lanes))
                .sum();
            return (groups * lanes) as u64;
        }
        let groups: usize = self
            .search
            .tiles()
            .iter()
            .flat_map(|tile| {
                tile.firsts()
                    .map(|i| tile.partners(i).len().div_ceil(lanes))
            })
            .sum();
        (groups * lanes) as u64
    }

    /// A copy that goes on with another kernel, or another model. A model of the same
    /// cut-off whose state, like this one's, is only the particles' positions and
    /// velocities (the course model and fluidanimate) takes over the copy as it is (its
    /// cell order, time step, skin and last step). Any other model's copy is set up as
    /// [`Self::with_method`] sets up a start (its parameters, per-particle state and
    /// time-step rule), at the same time; its cut-off may admit no grid.
    pub fn clone_with_method(&self, method: Method) -> Result<Simulation, GridSizeError> {
        let mut dynamics = method.model.dynamics();
        let ppm = self.params.ppm;
        let takes_over = !dynamics.carries_densities()
            && !self.dynamics.carries_densities()
            && dynamics.cutoff(ppm) == self.dynamics.cutoff(ppm);
        if method.model != self.method.model && !takes_over {
            let particles = self.particles_in_slot_order();
            let mut copy = Simulation::with_method(ppm, particles, method)?;
            copy.time = self.time;
            return Ok(copy);
        }
        let mut copy = self.clone();
        if method.model != self.method.model {
            dynamics.prepare(&copy.params, &copy.particles);
            copy.dynamics = dynamics;
        }
        copy.method = method;
        copy.placement += 1;
        if copy
            .skin
            .as_ref()
            .is_some_and(|skin| !skin.is_stale_by_build())
        {
            // The copy's structure as the skin's last build would have found it on the
            // copy's kernel: kept until the skin goes stale, and what a resume of the
            // copy's checkpoint rebuilds.
            copy.find_neighbours_as_built();
        } else if copy.lists_built {
            // Until the next step places them, the copy's passes run on the tiles of
            // the same cell order.
            copy.lists_built = false;
            copy.find_tiles();
        }
        Ok(copy)
    }

    /// What the model keeps beyond the particles ([`Dynamics::saved`]): for the weakly
    /// compressible model, its sound speed and settings, then (under the velocity
    /// Verlet) its last density rates.
    pub fn model_state(&self) -> Vec<f64> {
        self.dynamics.saved()
    }

    /// What a checkpoint keeps: the state from which [`Self::resume`] goes on bit for bit
    /// (with a skin, the positions of its last build, whose cell order and lists the
    /// resumed run rebuilds).
    pub fn resumable(&self) -> Resumable {
        Resumable {
            ppm: self.params.ppm,
            domain: self.params.domain,
            method: self.method,
            time_step: self.time_step,
            integrator: self.integrator,
            structure: self.structure,
            time: self.time,
            last_step: self.last_step,
            sparse: self.cells.is_sparse(),
            model_state: self.model_state(),
            particles: self.particles_in_slot_order(),
            skin: self.skin.as_ref().map(Skin::kept),
        }
    }

    /// The particles, unpadded, in the slot order of the last placement (the next sort
    /// orders them by cell and id; the lone ones keep this order).
    fn particles_in_slot_order(&self) -> Particles {
        if self.cells.is_in_place() {
            self.particles.permuted(self.cells.order()).unpadded()
        } else {
            self.particles.unpadded()
        }
    }

    /// The simulation of a [`Self::resumable`] state: its next step is the one the
    /// checkpointed simulation would have taken. Fails if its particles per metre admit
    /// no grid, the model's state is not the model's, or a skin's last build is not
    /// that of these particles.
    pub fn resume(state: Resumable) -> Result<Self, String> {
        let mut dynamics = state.method.model.dynamics();
        let model_params = state.method.model.params(state.ppm).within(state.domain);
        dynamics.restore(&model_params, &state.model_state)?;
        let params =
            Params::with_cutoff(state.ppm, dynamics.cutoff(state.ppm)).within(state.domain);
        let grid = Grid::new(params.h, &params.domain).map_err(|error| error.to_string())?;
        let mut simulation = Self::unplaced(params, grid, state.method, dynamics, state.particles);
        simulation.dynamics.restore(&params, &state.model_state)?;
        simulation.set_time_step(state.time_step);
        simulation.integrator = state.integrator;
        simulation.cells = CellOrder::resumed(state.sparse);
        simulation.time = state.time;
        simulation.last_step = state.last_step;
        simulation.structure = state.structure;
        simulation.skin = None;
        if let Some(kept) = state.skin {
            let skin = Skin::restored(params.h, kept, &params.domain)
                .map_err(|error| error.to_string())?;
            simulation.place_as_built(skin, state.sparse)?;
        }
        Ok(simulation)
    }

    /// Places the particles (in the slots of `skin`'s last build) as that build did, on
    /// the positions it recorded: the same cell order, tiles and lists, kept until they
    /// go stale, as in the run that recorded it. Fails if the particles are not in the
    /// order the build left them, or it found them sparse and now does not (or the
    /// reverse).
    fn place_as_built(&mut self, skin: Skin, sparse: bool) -> Result<(), String> {
        let n = self.particles.len();
        if skin.is_stale_by_build() {
            self.skin = Some(skin);
            return Ok(());
        }
        if skin.built().iter().any(|axis| axis.len() != n) {
            return Err("its skin's last build is of another number of particles".into());
        }
        // The build's positions (padded as the current ones) in place of the current
        // ones, for the sort and the search, then the current ones back.
        let padded = self.particles.p[0].len();
        let built = skin.built().clone().map(|mut axis| {
            axis.resize(padded, 0.0);
            axis
        });
        let now = std::mem::replace(&mut self.particles.p, built);
        let isa = self.cells.instruction_set();
        self.cells = CellOrder::resumed(skin.sorted_sparse());
        self.cells.set_instruction_set(isa);
        let moved = self.cells.sort_on(skin.grid(), &self.grid, &self.particles);
        if moved || self.cells.is_sparse() != sparse {
            self.particles.p = now;
            return Err("its particles are not in the order of its skin's last build".into());
        }
        self.skin = Some(skin);
        self.placement += 1;
        self.find_neighbours();
        self.particles.p = now;
        Ok(())
    }

    /// Changes how the steps advance the state (before the first step: the integrators
    /// keep their state differently).
    pub fn set_integrator(&mut self, integrator: Integrator) {
        self.integrator = integrator;
    }

    /// How the steps advance the state.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }

    /// Changes how the following steps' lengths are chosen (a fixed step also becomes the
    /// `dt` of [`Self::params`], which the stages run alone use).
    pub fn set_time_step(&mut self, time_step: TimeStep) {
        if let TimeStep::Fixed(dt) = time_step {
            self.params.dt = dt;
        }
        self.time_step = time_step;
    }

    /// Reuses the cell order and lists (or tiles) from step to step with a
    /// skin `width` metres wide ([`crate::sim::skin`]), or (`None`) rebuilds them every
    /// step; a simulation starts with its model's ([`Dynamics::default_skin`]). Takes
    /// effect at the next step, which builds them.
    pub fn set_skin(&mut self, width: Option<f64>) -> Result<(), GridSizeError> {
        self.skin = width
            .map(|w| Skin::new(self.params.h, w, &self.params.domain))
            .transpose()?;
        Ok(())
    }

    /// Runs the SIMD pair loops on `structure` from the next placement on, which a
    /// change makes a build where lists are kept with a skin (the reference outputs hold
    /// on either; only the order of the sums differs).
    pub fn set_pair_structure(&mut self, structure: PairStructure) {
        if structure != self.structure {
            if let Some(skin) = &mut self.skin {
                skin.expire();
            }
        }
        self.structure = structure;
    }

    /// Builds and runs the neighbour lists, and runs the cell order's lone filter, with
    /// `isa` from now on (by default the detected one, and for the lone filter's lookups
    /// [`InstructionSet::for_lookups`]).
    ///
    /// # Panics
    /// If this CPU does not run it.
    pub fn set_instruction_set(&mut self, isa: InstructionSet) {
        self.lists.set_instruction_set(isa);
        self.cells.set_instruction_set(isa);
    }

    /// Filters out lone particles in stage 1 with a table of `blocks_per_particle` blocks
    /// per particle, or never (`None`): see [`CellOrder::set_lone_filter`]. Only the work
    /// changes, never a result.
    pub fn set_lone_filter(&mut self, blocks_per_particle: Option<usize>) {
        self.cells.set_lone_filter(blocks_per_particle);
    }

    /// The structure the SIMD pair loops run on from the next placement.
    pub fn pair_structure(&self) -> PairStructure {
        self.structure
    }

    /// How steps' lengths are chosen.
    pub fn time_step(&self) -> TimeStep {
        self.time_step
    }

    /// The skin, if lists are reused.
    pub fn skin(&self) -> Option<&Skin> {
        self.skin.as_ref()
    }

    /// Physical time simulated so far, the sum of the steps' lengths (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The last step's length and the criterion that set it (none before the first step).
    pub fn last_step(&self) -> Option<(f64, Limit)> {
        self.last_step
    }

    /// A copy whose densities are those of the current positions (stage 1 and the model's
    /// density stages run on the copy), with the copy's cell order and tiles: for looking at a state without disturbing
    /// the run. A model whose densities are states of their own is placed (stage 1), its
    /// densities those it predicts for the current time (the velocity Verlet keeps them at
    /// the half step).
    pub fn with_fresh_densities(&self) -> Simulation {
        let mut copy = self.clone();
        copy.reposition();
        let (dynamics, mut context) = copy.model_and_context();
        dynamics.refresh_densities(&mut context);
        copy
    }

    /// Runs `steps` time steps.
    pub fn run(&mut self, steps: u64) {
        for _ in 0..steps {
            self.step();
        }
    }

    /// Runs one time step: all stages in order (stage 2 is part of stage 1's reordering,
    /// and stages 6-8 run as one pass).
    pub fn step(&mut self) {
        self.step_within(f64::INFINITY);
    }

    /// Whether the physical time has reached `end` (s), to 1e-12 relative (never, for an
    /// infinite or NaN `end`).
    pub fn has_reached(&self, end: f64) -> bool {
        end.is_finite() && end - self.time <= 1e-12 * end.abs()
    }

    /// One time step towards the physical time `end` (s): of the length the time-step
    /// rule chooses, cut short to land on `end` unless it is within 1e-9 (relative) of
    /// the time left. No step if `end` is reached already.
    pub fn step_towards(&mut self, end: f64) {
        if !self.has_reached(end) {
            self.step_within(end - self.time);
        }
    }

    /// One time step of the rule's length, cut to `longest` (> 0) if it is longer by more
    /// than 1e-9 relative: placement, the model's pair passes, the step's length, and the
    /// model's walls and motion.
    fn step_within(&mut self, longest: f64) {
        if self.integrator == Integrator::Verlet {
            // While the last step's accelerations are at hand; before the first step, the
            // half-step velocities are the velocities at t = 0 (v = hv).
            let half = self.last_step.map_or(0.0, |(previous, _)| previous / 2.0);
            stages::predict_velocities(half, &mut self.particles);
        }
        // Particles without a partner may stay where they are if the model gives each of
        // them the same results.
        let partnerless = match self.skin {
            None => self.dynamics.partnerless(&self.params),
            Some(_) => None,
        };
        self.place(partnerless.is_some());
        let (dynamics, mut context) = self.model_and_context();
        dynamics.interact(&mut context);
        if let Some(partnerless) = partnerless.filter(|_| self.cells.is_in_place()) {
            self.take_pair_results(partnerless);
        }
        let (chosen, limit) = match self.time_step {
            TimeStep::Fixed(dt) => (dt, Limit::Fixed),
            TimeStep::Adaptive { courant } => {
                self.dynamics
                    .adaptive_step(&self.params, &self.particles, courant)
            }
        };
        let (dt, limit) = Self::within(chosen, limit, longest);
        let step = self.leapfrog(dt);
        self.dynamics
            .advance(step, self.cells.walls(), &mut self.particles);
        self.time += dt;
        self.last_step = Some((dt, limit));
    }

    /// A step of `chosen` (set by `limit`), cut to `longest` if longer by more than 1e-9
    /// relative.
    fn within(chosen: f64, limit: Limit, longest: f64) -> (f64, Limit) {
        if chosen > longest * (1.0 + 1e-9) {
            (longest, Limit::Landing)
        } else {
            (chosen, limit)
        }
    }

    /// The leapfrog of a step of `dt` after the last one (the first step: after one of
    /// the same length, or for the velocity Verlet a half kick).
    fn leapfrog(&self, dt: f64) -> Leapfrog {
        let first = match self.integrator {
            Integrator::Leapfrog => dt,
            Integrator::Verlet => 0.0,
        };
        let previous = self.last_step.map_or(first, |(previous, _)| previous);
        Leapfrog::after(self.integrator, previous, dt)
    }

    /// The model, and the context it computes in: the current step's parameters,
    /// kernel, tiles and walls, and the particles.
    fn model_and_context(&mut self) -> (&mut dyn Dynamics, Context<'_>) {
        let context = Context {
            params: &self.params,
            kernel: self.method.kernel,
            tiles: self.search.tiles(),
            lists: self.lists_built.then_some(&self.lists),
            walls: self.cells.walls(),
            placement: self.placement,
            integrator: self.integrator,
            previous_step: self.last_step.map(|(previous, _)| previous),
            particles: if self.cells.is_in_place() {
                &mut self.spare
            } else {
                &mut self.particles
            },
        };
        (&mut *self.dynamics, context)
    }

    /// Runs one stage alone (for trace comparisons and stage benchmarks): stages 1 and 2
    /// are the driver's, the others the model's ([`Dynamics::run_stage`]). Stage 1 alone
    /// moves every particle into cell order; any other stage first moves particles that a
    /// step left in place into its slot order, where its tiles and walls index them.
    pub fn run_stage(&mut self, stage: Stage) {
        if stage != Stage::Reposition {
            self.move_into_slot_order();
        }
        match stage {
            Stage::Reposition => return self.reposition(),
            Stage::InitAccelerations => return self.reset_for_pairs(),
            _ => {}
        }
        let (dynamics, mut context) = self.model_and_context();
        dynamics.run_stage(stage, &mut context);
    }

    /// Stages 1 and 2: sorts the particles by cell (moving them only if the order
    /// changed), resets what the pair passes sum into, and finds the step's tiles; with a
    /// skin, only when the lists are stale (else the walls alone are recomputed).
    fn reposition(&mut self) {
        self.place(false);
    }

    /// [`Self::reposition`]; where `may_stay` and the last sort found the particles
    /// sparse, they stay where they are stored ([`CellOrder::sort_in_place`]), and only
    /// those with a partner closer than h are copied out, in slot order with what the
    /// pair passes sum into reset, for the pair passes to run on, on tiles.
    fn place(&mut self, may_stay: bool) {
        self.placement += 1;
        let sorted_sparse = self.cells.is_sparse();
        let moved = match &self.skin {
            Some(skin) if !skin.is_stale(&self.particles) => {
                // The lists of an earlier step still hold every pair closer than h.
                self.reset_for_pairs();
                self.cells.refresh_walls(&self.grid, &self.particles);
                return;
            }
            Some(skin) => self.cells.sort_on(skin.grid(), &self.grid, &self.particles),
            None if may_stay => self.cells.sort_in_place(&self.grid, &self.particles),
            None => self.cells.sort(&self.grid, &self.particles),
        };
        let gravity = self.params.domain.gravity;
        if self.cells.is_in_place() {
            // Only the particles with a partner are copied out for the pair passes, which
            // run on the tiles found for them.
            self.keep_partnered();
            let paired = self.cells.paired();
            if self.dynamics.carries_densities() {
                self.spare
                    .gather_with_densities(&self.particles, paired, gravity);
            } else {
                self.spare
                    .gather_for_pairs(&self.particles, paired, gravity);
            }
            self.lists_built = false;
            return;
        }
        if moved {
            let order = self.cells.order();
            if self.dynamics.carries_densities() {
                self.spare
                    .gather_with_densities(&self.particles, order, gravity);
            } else {
                self.spare
                    .gather_kinematics(&self.particles, order, gravity);
            }
            std::mem::swap(&mut self.particles, &mut self.spare);
        } else {
            self.reset_for_pairs();
        }
        if let Some(skin) = &mut self.skin {
            skin.record(&self.particles, sorted_sparse);
        }
        self.find_neighbours();
    }

    /// After a sort that left the particles in place, keeps for the pair passes only the
    /// particles with a partner closer than h (to [`PARTNER_MARGIN`]): a search of the
    /// sorted ones on their positions alone. The pair passes then run over the same
    /// particles, in the same order, whichever of them the lone filter let through.
    fn keep_partnered(&mut self) {
        let paired = self.cells.paired();
        self.spare.gather_positions(&self.particles, paired);
        let n = paired.len();
        self.find_tiles();
        let reach_squared = self.params.h2 * (1.0 + PARTNER_MARGIN);
        let partnered = self.search.find_partnered(&self.spare.p, n, reach_squared);
        self.cells.keep_paired(partnered);
        self.search.keep_partnered();
    }

    /// Where a step left the particles in place, moves them (every field) into its slot
    /// order, as a placement that moves them would have: its tiles, lists and clusters
    /// then index them, and its walls are per slot.
    fn move_into_slot_order(&mut self) {
        if self.cells.is_in_place() {
            self.spare = self.particles.permuted(self.cells.order());
            std::mem::swap(&mut self.particles, &mut self.spare);
            self.cells.moved_into_order();
        }
    }

    /// After the pair passes of a placement that left the particles in place: each stored
    /// particle gets the density and acceleration of one without a partner, then those
    /// copied out their own.
    fn take_pair_results(&mut self, partnerless: Partnerless) {
        let n = self.particles.len();
        let (placed, particles) = (&self.spare, &mut self.particles);
        let stored = self.cells.paired();
        particles.rho[..n].fill(partnerless.density);
        for (&stored, &rho) in stored.iter().zip(&placed.rho) {
            particles.rho[stored as usize] = rho;
        }
        let acceleration = partnerless.acceleration.to_array();
        for ((axis, placed), g) in particles.a.iter_mut().zip(&placed.a).zip(acceleration) {
            axis[..n].fill(g);
            for (&stored, &a) in stored.iter().zip(placed) {
                axis[stored as usize] = a;
            }
        }
    }

    /// The neighbour structure of the placement: its lists where the pair passes run on
    /// them ([`Self::build_lists`]), else its tiles.
    fn find_neighbours(&mut self) {
        let on_lanes = self.method.kernel.runs_on_lanes() && !self.cells.is_sparse();
        self.lists_built = on_lanes && self.structure.is_listed();
        if self.lists_built {
            self.build_lists();
        } else {
            self.find_tiles();
        }
    }

    /// The neighbour structure of the current cell order at the positions of the skin's
    /// last build (at the current positions without a skin): what that build found, on
    /// the current kernel and structure.
    fn find_neighbours_as_built(&mut self) {
        let n = self.particles.len();
        let now = self.particles.p.clone();
        if let Some(skin) = &self.skin {
            for (axis, built) in self.particles.p.iter_mut().zip(skin.built()) {
                axis[..n].copy_from_slice(&built[..n]);
            }
        }
        self.find_neighbours();
        self.particles.p = now;
    }

    /// The lists of the placement's tiles at the current positions, within the cut-off
    /// (plus the skin where kept over steps); where a collapsed scene has too many pairs
    /// to list, the passes run on the tiles.
    fn build_lists(&mut self) {
        self.find_tiles();
        let skin = self.skin.as_ref().map_or(0.0, Skin::width);
        let reach = self.params.h + skin;
        let particles = placed(&self.cells, &self.particles, &self.spare);
        let (tiles, n) = (self.search.tiles(), particles.len());
        let layout = if self.structure == PairStructure::Rows {
            ListLayout::Rows
        } else {
            ListLayout::Half
        };
        self.lists.set_layout(layout);
        self.lists_built = self.lists.build(tiles, &particles.p, n, reach).is_ok();
    }

    /// Stage 2: accelerations to gravity, and densities to zero unless they are states.
    fn reset_for_pairs(&mut self) {
        if self.dynamics.carries_densities() {
            self.particles
                .reset_accelerations(self.params.domain.gravity);
        } else {
            self.particles
                .reset_densities_and_accelerations(self.params.domain.gravity);
        }
    }

    fn find_tiles(&mut self) {
        self.search.find(self.cells.keys(), self.cells.layout());
    }
}

/// The particles the placement of `cells` indexes by slot (its tiles, lists and
/// clusters): the compact copy in `spare` of those that may have a pair where it left
/// the particles in place, else `particles`.
fn placed<'a>(cells: &CellOrder, particles: &'a Particles, spare: &'a Particles) -> &'a Particles {
    if cells.is_in_place() {
        spare
    } else {
        particles
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::cells::Walls;
    use crate::sim::cells::SENTINELS;
    use crate::sim::kernel::Kernel;
    use crate::sim::model::Model;
    use crate::sim::params::{BOX_MAX, BOX_MIN};

    /// Particles at the given x positions (y, z at the box's lower corner plus a margin).
    fn along_x(xs: &[f64]) -> Particles {
        let mut particles = Particles::zeroed(xs.len());
        particles.p[0] = xs.to_vec();
        particles.p[1] = vec![BOX_MIN.y + 0.05; xs.len()];
        particles.p[2] = vec![BOX_MIN.z + 0.05; xs.len()];
        particles
    }

    #[test]
    fn new_places_particles_in_cell_order() {
        let sim = Simulation::new(204.0, along_x(&[0.06, -0.06, 0.0, -0.061])).unwrap();
        assert_eq!(sim.particles().id, vec![1, 3, 2, 0]);
        assert!(sim.cells().keys()[..4].is_sorted());
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
        assert_eq!(sim.cells().keys().len(), 4 + SENTINELS);
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

    /// A lone particle from rest under gravity, its steps' lengths chosen by `time_step`,
    /// until `end`: the leapfrog is exact for a constant acceleration, so y and v follow
    /// y0 + v0 t - g t^2 / 2 with v0 = -g dt_0 / 2 (the input's hv is hv_{-1/2}) whatever
    /// the steps' lengths.
    fn assert_free_fall_until(time_step: TimeStep, end: f64) -> Vec<(f64, Limit)> {
        // The stable model, whose viscosity does not limit an adaptive step at 204 ppm.
        let method = Method {
            model: Model::Fluidanimate,
            kernel: Kernel::Simd,
        };
        let mut sim = Simulation::with_method(204.0, along_x(&[0.0]), method).unwrap();
        sim.set_time_step(time_step);
        let y0 = sim.particles().p[1][0];
        let mut steps = Vec::new();
        while !sim.has_reached(end) {
            sim.step_towards(end);
            steps.push(sim.last_step().unwrap());
        }
        let lengths: Vec<f64> = steps.iter().map(|step| step.0).collect();
        let g = 9.8;
        let (t, v0) = (sim.time(), -g * lengths[0] / 2.0);
        assert!((t - end).abs() < 1e-15, "{t} against {end}");
        let y = sim.particles().p[1][0];
        assert!((y - (y0 + v0 * t - g * t * t / 2.0)).abs() < 1e-14, "y {y}");
        let before_last = t - lengths[lengths.len() - 1];
        let v = sim.particles().v[1][0];
        assert!((v - (v0 - g * before_last)).abs() < 1e-14, "v {v}");
        steps
    }

    #[test]
    fn steps_of_any_length_keep_the_leapfrog_exact() {
        // Fixed 0.3 ms steps until 1 ms: the last is cut to 0.1 ms.
        let steps = assert_free_fall_until(TimeStep::Fixed(3e-4), 1e-3);
        assert_eq!(steps.len(), 4);
        assert_eq!(steps[2], (3e-4, Limit::Fixed));
        assert!((steps[3].0 - 1e-4).abs() < 1e-15);
        assert_eq!(steps[3].1, Limit::Landing);
        // Adaptive: the fall speeds the particle up, so every step is shorter than the last.
        let steps = assert_free_fall_until(TimeStep::Adaptive { courant: 0.3 }, 0.05);
        let lengths: Vec<f64> = steps.iter().map(|step| step.0).collect();
        assert!(lengths.windows(2).all(|w| w[1] <= w[0]), "{lengths:?}");
        let (last, before) = steps.split_last().unwrap();
        assert!(
            before.iter().all(|step| step.1 == Limit::Speed),
            "{steps:?}"
        );
        assert_eq!(last.1, Limit::Landing);
        assert!(
            lengths[0] > 1.001 * lengths[lengths.len() - 2],
            "{lengths:?}"
        );
    }

    #[test]
    fn stepping_towards_a_time_keeps_equal_steps_equal() {
        // 1 ms steps until 5 ms: five steps, none cut, the same state as `run(5)`.
        let xs = [0.0, 0.004, 0.0075, 0.0165];
        let mut by_count = Simulation::new(204.0, along_x(&xs)).unwrap();
        let mut by_time = by_count.clone();
        by_count.run(5);
        let mut steps = 0;
        while !by_time.has_reached(5e-3) {
            by_time.step_towards(5e-3);
            steps += 1;
        }
        assert_eq!(steps, 5);
        assert_eq!(by_time.particles(), by_count.particles());
        assert!((by_time.time() - 5e-3).abs() < 1e-15);
        assert_eq!(by_time.last_step(), Some((1e-3, Limit::Fixed)));
        assert!(by_time.has_reached(1e-3) && !by_time.has_reached(5.1e-3));
        assert!(!by_time.has_reached(f64::INFINITY) && !by_time.has_reached(f64::NAN));
        by_time.step_towards(1e-3);
        assert_eq!(
            by_time.particles(),
            by_count.particles(),
            "no step backwards"
        );
        // Particles and the reordering's spare copy: an id and 13 f64 per slot, each.
        assert!(by_time.heap_bytes() >= 2 * 4 * (4 + 13 * 8));
    }

    /// The pairs closer than h among `candidates` (slot pairs) of `sim`, by id, sorted.
    fn pairs_within_h(
        sim: &Simulation,
        candidates: impl Iterator<Item = (usize, usize)>,
    ) -> Vec<(u32, u32)> {
        let (particles, h2) = (sim.particles(), sim.params().h2);
        let mut pairs: Vec<(u32, u32)> = candidates
            .filter(|&(i, j)| (particles.position(i) - particles.position(j)).length_squared() < h2)
            .map(|(i, j)| {
                let (a, b) = (particles.id[i], particles.id[j]);
                (a.min(b), a.max(b))
            })
            .collect();
        pairs.sort_unstable();
        pairs
    }

    /// Every pair of slots of `sim`.
    fn all_pairs(sim: &Simulation) -> impl Iterator<Item = (usize, usize)> {
        let n = sim.particles().len();
        (0..n).flat_map(move |i| (i + 1..n).map(move |j| (i, j)))
    }

    /// The candidate pairs of slots of `sim`'s tiles.
    fn tile_pairs(sim: &Simulation) -> impl Iterator<Item = (usize, usize)> + '_ {
        sim.tiles().iter().flat_map(|tile| {
            tile.firsts()
                .flat_map(move |i| tile.partners(i).map(move |j| (i, j)))
        })
    }

    /// The candidate pairs of slots of `sim`'s lists where its pair passes run on them,
    /// else of its tiles.
    fn candidate_pairs(sim: &Simulation) -> Vec<(usize, usize)> {
        if !sim.lists_built {
            return tile_pairs(sim).collect();
        }
        let lists = &sim.lists;
        (0..lists.slots())
            .flat_map(|i| lists.partners(i).iter().map(move |&j| (i, j as usize)))
            .collect()
    }

    /// Steps `particles` 60 times with lists kept with a skin of 0.3 h (the pair loops
    /// on `structure`) and with tiles rebuilt every step; checks at every step that the
    /// kept tiles or lists hold every pair closer than h, and returns the builds and
    /// the largest distance between the runs; panics if the last step was asked to run
    /// on lists of a dense scene and did not.
    fn run_with_and_without_a_skin(particles: Particles, structure: PairStructure) -> (u64, f64) {
        let method = Method {
            model: Model::Fluidanimate,
            kernel: Kernel::Simd,
        };
        let mut sim = Simulation::with_method(150.0, particles, method).unwrap();
        let h = sim.params().h;
        let mut rebuilt = sim.clone();
        rebuilt.set_pair_structure(PairStructure::Tiles);
        sim.set_skin(Some(0.3 * h)).unwrap();
        sim.set_pair_structure(structure);
        for _ in 0..60 {
            sim.step();
            rebuilt.step();
            // Stage 1 of the next step: the kept lists, then every pair among them.
            let mut next = sim.clone();
            next.run_stage(Stage::Reposition);
            let (kept, every) = (
                pairs_within_h(&next, candidate_pairs(&next).into_iter()),
                pairs_within_h(&next, all_pairs(&next)),
            );
            let missed: Vec<_> = every.iter().filter(|p| !kept.contains(p)).collect();
            assert!(
                kept == every,
                "{} of {} pairs missed: {:?}",
                missed.len(),
                every.len(),
                &missed[..missed.len().min(5)]
            );
        }
        let largest = largest_distance(&sim, &rebuilt);
        assert!(sim.heap_bytes() > rebuilt.heap_bytes());
        let dense = !sim.cells.is_sparse();
        assert_eq!(sim.lists_built, structure.is_listed() && dense);
        (sim.skin().unwrap().builds(), largest)
    }

    /// The largest distance between the same particle in `a` and in `b`.
    fn largest_distance(a: &Simulation, b: &Simulation) -> f64 {
        let by_id = |sim: &Simulation| {
            let particles = sim.particles();
            let mut positions = vec![glam::DVec3::ZERO; particles.len()];
            for slot in 0..particles.len() {
                positions[particles.id[slot] as usize] = particles.position(slot);
            }
            positions
        };
        let (a, b) = (by_id(a), by_id(b));
        a.iter()
            .zip(&b)
            .map(|(x, y)| x.distance(*y))
            .fold(0.0, f64::max)
    }

    /// A falling, splashing block of 9^3 particles 1/150 m apart whose particles also
    /// move apart at up to 0.4 m/s (so that pairs change).
    fn splashing_block() -> Particles {
        let spacing = 1.0 / 150.0;
        let mut block = Particles::zeroed(9 * 9 * 9);
        for slot in 0..block.len() {
            let k = [slot % 9, slot / 81, (slot / 9) % 9];
            for axis in 0..3 {
                let lift = if axis == 1 { 0.04 } else { 0.0 };
                block.p[axis][slot] = BOX_MIN[axis] + 0.002 + lift + k[axis] as f64 * spacing;
                let speed = 0.1 * ((slot * 5 + axis * 11) % 9) as f64 - 0.4;
                block.v[axis][slot] = speed;
                block.hv[axis][slot] = speed;
            }
        }
        block
    }

    /// 400 particles spread over a metre around the box at up to 4 m/s, every fourth
    /// 3 mm from the one before it: mostly lone, with pairs that change from step to step.
    fn scattered_cloud() -> Particles {
        let mut cloud = Particles::zeroed(400);
        let mut random = fastrand::Rng::with_seed(35);
        for slot in 0..cloud.len() {
            for axis in 0..3 {
                let x = if slot % 4 == 1 {
                    cloud.p[axis][slot - 1] + 0.003
                } else {
                    random.f64() - 0.5
                };
                let speed = 8.0 * random.f64() - 4.0;
                cloud.p[axis][slot] = x;
                (cloud.v[axis][slot], cloud.hv[axis][slot]) = (speed, speed);
            }
        }
        cloud
    }

    /// 400 particles within 5 cm of the box's centre converging on it at up to 4 m/s,
    /// there in about 12 steps of 1 ms: sparse, then dense.
    fn converging_cloud() -> Particles {
        let mut cloud = Particles::zeroed(400);
        let mut random = fastrand::Rng::with_seed(36);
        for axis in 0..3 {
            let centre = (BOX_MIN[axis] + BOX_MAX[axis]) / 2.0;
            for slot in 0..cloud.len() {
                let offset = 0.1 * random.f64() - 0.05;
                cloud.p[axis][slot] = centre + offset;
                let speed = -offset / 0.012;
                (cloud.v[axis][slot], cloud.hv[axis][slot]) = (speed, speed);
            }
        }
        cloud
    }

    /// A model as another gives it, but with no partnerless results: its steps move every
    /// particle into cell order.
    #[derive(Debug, Clone)]
    struct Moving(Box<dyn Dynamics>);

    impl Dynamics for Moving {
        fn cutoff(&self, ppm: f64) -> f64 {
            self.0.cutoff(ppm)
        }
        fn default_time_step(&self) -> TimeStep {
            self.0.default_time_step()
        }
        fn pressure(&self, density: f64) -> f64 {
            self.0.pressure(density)
        }
        fn carries_densities(&self) -> bool {
            self.0.carries_densities()
        }
        fn prepare(&mut self, params: &Params, particles: &Particles) {
            self.0.prepare(params, particles)
        }
        fn interact(&mut self, context: &mut Context) {
            self.0.interact(context)
        }
        fn refresh_densities(&mut self, context: &mut Context) {
            self.0.refresh_densities(context)
        }
        fn adaptive_step(
            &self,
            params: &Params,
            particles: &Particles,
            courant: f64,
        ) -> (f64, Limit) {
            self.0.adaptive_step(params, particles, courant)
        }
        fn advance(&mut self, step: Leapfrog, walls: &Walls, particles: &mut Particles) {
            self.0.advance(step, walls, particles)
        }
        fn run_stage(&mut self, stage: Stage, context: &mut Context) {
            self.0.run_stage(stage, context)
        }
    }

    /// Asserts that two runs' particles agree, particle by particle (by id: a step that
    /// left the particles in place has those without a partner after those with one in
    /// its slot order, a step that moved them has them in cell order): bit for bit where
    /// `tolerance` is 0 (Debug's shortest round-trip digits tell every two f64 apart,
    /// -0.0 from 0.0), else every value to `tolerance` relative to the largest of its
    /// array, as sums of the same terms in another order leave them after a few steps.
    fn assert_agree(a: &Particles, b: &Particles, tolerance: f64, what: &str) {
        let (a, b) = (by_id(a), by_id(b));
        if tolerance == 0.0 {
            assert!(format!("{a:?}") == format!("{b:?}"), "{what}");
            return;
        }
        assert_eq!(a.id, b.id, "{what}: ids");
        let arrays = |p: &Particles| -> Vec<Vec<f64>> {
            let axes = p.p.iter().chain(&p.v).chain(&p.hv).chain(&p.a);
            axes.chain([&p.rho]).cloned().collect()
        };
        for (k, (a, b)) in arrays(&a).iter().zip(&arrays(&b)).enumerate() {
            let scale = a
                .iter()
                .chain(b)
                .fold(1.0, |largest: f64, x| largest.max(x.abs()));
            for (slot, (x, y)) in a.iter().zip(b).enumerate() {
                let close = (x - y).abs() <= tolerance * scale;
                assert!(close, "{what}: array {k}, slot {slot}: {x} against {y}");
            }
        }
    }

    /// The particles unpadded, in the order of their ids.
    fn by_id(particles: &Particles) -> Particles {
        let mut slots: Vec<u32> = (0..particles.len() as u32).collect();
        slots.sort_by_key(|&slot| particles.id[slot as usize]);
        particles.permuted(&slots).unpadded()
    }

    /// As [`assert_agree`], for two runs' checkpoints: bit for bit where `tolerance` is
    /// 0, else their times to `tolerance` relative and the rest of what they keep equal.
    fn assert_states_agree(a: &Resumable, b: &Resumable, tolerance: f64, what: &str) {
        assert_agree(&a.particles, &b.particles, tolerance, what);
        if tolerance == 0.0 {
            let [a, b] = [a, b].map(|state| Resumable {
                particles: by_id(&state.particles),
                ..state.clone()
            });
            assert!(format!("{a:?}") == format!("{b:?}"), "{what}");
            return;
        }
        let (ta, tb) = (a.time, b.time);
        assert!(
            (ta - tb).abs() <= tolerance * ta.abs(),
            "{what}: {ta} against {tb}"
        );
        assert_eq!((a.sparse, a.structure), (b.sparse, b.structure), "{what}");
    }

    #[test]
    fn steps_that_leave_lone_particles_in_place_go_as_steps_that_move_them() {
        // Every model that gives partnerless results, kernel, structure, integrator and
        // step rule, on a cloud that stays sparse and one that turns dense. Where the
        // particles stay, the pair passes run over those with a partner closer than h
        // alone; where they move, over every particle of a cell near another. Kernels that
        // add one pair at a time give the same bits (a pair farther than h adds +0); those
        // on lanes add the same terms in other groups.
        let (mut in_place, mut turned_dense) = (0, 0);
        for model in [Model::Course, Model::Fluidanimate] {
            for (kernel, structure) in Kernel::ALL
                .into_iter()
                .flat_map(|kernel| PairStructure::ALL.map(|structure| (kernel, structure)))
            {
                for integrator in [Integrator::Leapfrog, Integrator::Verlet] {
                    for time_step in [TimeStep::Fixed(1e-3), TimeStep::Adaptive { courant: 0.4 }] {
                        for cloud in [scattered_cloud(), converging_cloud()] {
                            let what = format!(
                                "{} {} {structure:?} {integrator:?} {time_step:?}",
                                model.name(),
                                kernel.name()
                            );
                            let method = Method { model, kernel };
                            // Kernels on lanes group the terms otherwise; the mixed
                            // kernel narrows positions otherwise on clusters than on
                            // tiles (5e-7 relative).
                            let tolerance = match kernel {
                                Kernel::Scalar | Kernel::Reference => 0.0,
                                Kernel::Simd | Kernel::Simd8 => 1e-6,
                                Kernel::Mixed => 1e-4,
                            };
                            let start = |dynamics| {
                                let domain = Domain::COURSE;
                                let mut sim = Simulation::with_dynamics(
                                    204.0,
                                    domain,
                                    cloud.clone(),
                                    method,
                                    dynamics,
                                )
                                .unwrap();
                                sim.set_pair_structure(structure);
                                sim.set_integrator(integrator);
                                sim.set_time_step(time_step);
                                sim
                            };
                            let mut stepped = start(model.dynamics());
                            let mut moved = start(Box::new(Moving(model.dynamics())));
                            let mut states = Vec::new();
                            for step in 0..12 {
                                states.push(stepped.resumable());
                                stepped.step();
                                moved.step();
                                assert!(!moved.cells().is_in_place());
                                in_place += usize::from(stepped.cells().is_in_place());
                                turned_dense += usize::from(
                                    stepped.cells().is_in_place() && !stepped.cells().is_sparse(),
                                );
                                // The particles in slot order.
                                let (a, b) = (stepped.resumable(), moved.resumable());
                                assert_states_agree(
                                    &a,
                                    &b,
                                    tolerance,
                                    &format!("{what}, step {step}"),
                                );
                            }
                            let end = format!("{:?}", stepped.resumable());
                            // A copy for a model that does not take over the placement.
                            let water = Method {
                                model: Model::Wcsph,
                                kernel: Kernel::Simd,
                            };
                            let [a, b] = [&stepped, &moved]
                                .map(|sim| sim.clone_with_method(water).unwrap().resumable());
                            assert_states_agree(&a, &b, tolerance, &format!("{what}: water copy"));
                            // A copy placed afresh, and stages run alone after a step.
                            let [a, b] = [&stepped, &moved].map(|sim| sim.with_fresh_densities());
                            assert_agree(a.particles(), b.particles(), tolerance, &what);
                            // Stage 2 alone moves the particles a step left in place
                            // into its slot order; the other stages after it would run on
                            // the tiles of the step's placement, which in place hold only
                            // the pairs then closer than h, so they run from stage 1.
                            stepped.run_stage(Stage::InitAccelerations);
                            moved.run_stage(Stage::InitAccelerations);
                            assert!(!stepped.cells().is_in_place());
                            assert_agree(stepped.particles(), moved.particles(), tolerance, &what);
                            for stage in Stage::ALL {
                                stepped.run_stage(stage);
                                moved.run_stage(stage);
                            }
                            assert_agree(stepped.particles(), moved.particles(), tolerance, &what);
                            // Each checkpoint resumes bit for bit.
                            for (done, state) in states.into_iter().enumerate() {
                                let mut resumed = Simulation::resume(state).unwrap();
                                resumed.run(12 - done as u64);
                                assert!(
                                    format!("{:?}", resumed.resumable()) == end,
                                    "{what}, after {done}"
                                );
                            }
                        }
                    }
                }
            }
        }
        // Steps left the particles in place, some of them where the scene turned dense.
        assert!(
            in_place > 1000 && turned_dense > 0,
            "{in_place}, {turned_dense}"
        );
    }

    #[test]
    fn a_copy_for_another_kernel_keeps_every_pair_of_kept_lists() {
        // On lists with a skin, then copied for the scalar kernel (tiles only) while
        // the skin is fresh: the copy's next steps find the same pairs on the tiles of
        // the same cell order.
        let method = |kernel| Method {
            model: Model::Fluidanimate,
            kernel,
        };
        let mut sim =
            Simulation::with_method(150.0, splashing_block(), method(Kernel::Simd)).unwrap();
        sim.set_pair_structure(PairStructure::Lists);
        sim.set_skin(Some(0.3 * sim.params().h)).unwrap();
        sim.step();
        assert!(sim.lists_built);
        let mut copy = sim.clone_with_method(method(Kernel::Scalar)).unwrap();
        for _ in 0..2 {
            sim.step();
            copy.step();
        }
        assert_eq!(copy.skin().unwrap().builds(), 1, "the skin still fresh");
        let largest = largest_distance(&sim, &copy);
        assert!(largest < 1e-12, "{largest}");
    }

    #[test]
    fn a_collapsed_scene_too_dense_to_list_steps_on_its_tiles() {
        // 729 particles within h / 2: the lists would hold 364 partners per slot.
        let mut random = fastrand::Rng::with_seed(3);
        let mut particles = Particles::zeroed(729);
        for axis in &mut particles.p {
            axis.iter_mut()
                .for_each(|x| *x = 0.01 + 0.002 * random.f64());
        }
        let method = Method {
            model: Model::Fluidanimate,
            kernel: Kernel::Simd8,
        };
        let mut listed = Simulation::with_method(200.0, particles, method).unwrap();
        let mut tiled = listed.clone();
        tiled.set_pair_structure(PairStructure::Tiles);
        listed.step();
        tiled.step();
        assert!(
            !listed.cells().is_sparse(),
            "dense cells, which lists would serve"
        );
        assert!(listed.lists().is_none(), "not listed");
        assert!(listed.particles().rho[..729]
            .iter()
            .all(|rho| rho.is_finite()));
        assert_eq!(listed.particles().p, tiled.particles().p, "the tiles' step");
        assert!(listed.heap_bytes() < 729 * 4096);
    }

    #[test]
    fn lists_kept_with_a_skin_hold_every_pair_closer_than_h() {
        // The lists go stale now and then, not every step.
        let block = splashing_block();
        // The same pairs, the same physics: only the order of the sums differs, on the
        // tiles and on the neighbour lists kept.
        for structure in PairStructure::ALL {
            let (builds, largest) = run_with_and_without_a_skin(block.clone(), structure);
            assert!(builds > 1 && builds < 40, "{builds} builds in 60 steps");
            assert!(largest < 1e-9, "{structure:?}: {largest}");
        }
        // A sparse, jittered lattice high in the box, lone particles 2.7 h apart with
        // two close pairs among them (the cell order's lone filter at work), falling.
        let mut cloud = Particles::zeroed(4 * 4 * 4 + 2);
        for slot in 0..64 {
            let k = [slot % 4, slot / 16, (slot / 4) % 4];
            for axis in 0..3 {
                let jitter = 1e-3 * ((slot * 7 + axis * 3) % 5) as f64;
                cloud.p[axis][slot] = BOX_MIN[axis] + 0.01 + 0.03 * k[axis] as f64 + jitter;
            }
            cloud.p[1][slot] += 0.08;
        }
        for (slot, partner) in [(64, 0), (65, 40)] {
            for axis in 0..3 {
                cloud.p[axis][slot] = cloud.p[axis][partner] + 0.006;
            }
        }
        let (builds, largest) = run_with_and_without_a_skin(cloud, PairStructure::Lists);
        assert!(builds > 1 && builds < 40, "{builds} builds in 60 steps");
        assert!(largest < 1e-9, "{largest}");
    }

    /// Steps `start` `steps` times, and resumes a copy from the checkpointed state
    /// before each step (the start's included): each ends bit for bit where the whole
    /// run does. Returns the whole run's builds.
    fn assert_resumes_bit_for_bit(start: &Simulation, steps: usize) -> u64 {
        let mut whole = start.clone();
        let mut states = Vec::new();
        for _ in 0..steps {
            states.push(whole.resumable());
            whole.step();
        }
        // Debug's shortest round-trip digits tell every two f64 apart, -0.0 from 0.0.
        let end = format!("{:?}", whole.resumable());
        for (done, state) in states.into_iter().enumerate() {
            let mut resumed = Simulation::resume(state).unwrap();
            for _ in done..steps {
                resumed.step();
            }
            let state = format!("{:?}", resumed.resumable());
            assert!(state == end, "resumed after step {done}");
        }
        whole.skin().unwrap().builds()
    }

    #[test]
    fn runs_with_a_skin_resume_bit_for_bit_whether_or_not_their_lists_are_fresh() {
        // The weakly compressible model keeps its lists with its own skin.
        let method = |model| Method {
            model,
            kernel: Kernel::Simd8,
        };
        let block = splashing_block();
        let wcsph = Simulation::with_method(150.0, block.clone(), method(Model::Wcsph)).unwrap();
        let skin = wcsph.skin().expect("the model's own skin").width();
        assert_eq!(skin, crate::sim::model::wcsph::SKIN * wcsph.params().h);
        let builds = assert_resumes_bit_for_bit(&wcsph, 24);
        assert!(builds > 1 && builds < 24, "{builds} builds in 24 steps");
        // Fluidanimate, with a skin asked for, on the splashing block and on a cloud of
        // lone particles (the cell order's lone filter at work).
        let mut fluidanimate =
            Simulation::with_method(150.0, block, method(Model::Fluidanimate)).unwrap();
        assert!(fluidanimate.skin().is_none(), "no skin unless asked for");
        fluidanimate
            .set_skin(Some(0.3 * fluidanimate.params().h))
            .unwrap();
        let builds = assert_resumes_bit_for_bit(&fluidanimate, 24);
        assert!(builds > 1 && builds < 24, "{builds} builds in 24 steps");
        // A lattice 3 cm apart (lone particles, more than a cell of h + skin apart),
        // jittered, 8 of them 4 mm from another.
        let mut cloud = Particles::zeroed(64);
        let mut random = fastrand::Rng::with_seed(8);
        for (d, axis) in cloud.p.iter_mut().enumerate() {
            for (slot, x) in axis.iter_mut().enumerate() {
                let k = [slot % 4, slot / 4 % 4, slot / 16][d];
                *x = BOX_MIN[d] + 0.01 + 0.03 * k as f64 + 0.002 * random.f64();
            }
            for k in 0..8 {
                axis[k] = axis[k + 32] + 0.004;
            }
        }
        let mut sparse =
            Simulation::with_method(150.0, cloud.clone(), method(Model::Fluidanimate)).unwrap();
        sparse.set_skin(Some(0.3 * sparse.params().h)).unwrap();
        sparse.run(1);
        assert!(sparse.cells().is_sparse());
        assert_resumes_bit_for_bit(&sparse, 12);
        // The weakly compressible model's placement on the cloud: its first sort ran as
        // after a dense one and found the cloud sparse, so a resume must sort the
        // build's positions as the build did, not as the next sort will.
        let cloud = Simulation::with_method(150.0, cloud, method(Model::Wcsph)).unwrap();
        assert!(cloud.cells().is_sparse());
        assert!(!cloud.skin().unwrap().kept().sorted_sparse);
        assert_resumes_bit_for_bit(&cloud, 6);
        // Kept tiles; a skin expired by a change of structure, and one set but not yet
        // built.
        let mut other = wcsph.clone();
        other.set_pair_structure(PairStructure::Tiles);
        assert!(other.skin().unwrap().is_stale_by_build());
        assert_resumes_bit_for_bit(&other, 12);
        let mut unbuilt = wcsph.clone();
        unbuilt.set_skin(Some(0.1 * unbuilt.params().h)).unwrap();
        assert_resumes_bit_for_bit(&unbuilt, 12);
        // A copy for another kernel while the skin is fresh: its lists as the build
        // would have found them on its kernel, which is what its checkpoint rebuilds.
        let mut stepped = wcsph.clone();
        stepped.run(3);
        for kernel in [Kernel::Simd, Kernel::Scalar] {
            let copy = stepped
                .clone_with_method(Method {
                    kernel,
                    ..stepped.method()
                })
                .unwrap();
            assert!(!copy.skin().unwrap().is_stale(copy.particles()), "fresh");
            assert_eq!(copy.lists().is_some(), kernel == Kernel::Simd);
            assert_resumes_bit_for_bit(&copy, 8);
        }
        // A state whose slots are not in its last build's order is refused: the first and
        // last slots' build positions swapped (the first and last cells').
        let mut moved = wcsph.clone();
        moved.run(3);
        let mut state = moved.resumable();
        let last = state.particles.len() - 1;
        for axis in &mut state.skin.as_mut().unwrap().built {
            axis.swap(0, last);
        }
        assert_eq!(
            Simulation::resume(state).unwrap_err(),
            "its particles are not in the order of its skin's last build"
        );
    }

    #[test]
    fn a_copy_of_another_model_of_the_same_state_goes_on_from_the_same_place() {
        // The course model after two 0.5 ms steps with a skin, copied to fluidanimate: the
        // copy keeps the time step, the skin, the cell order and the last step, and goes
        // on with fluidanimate's viscosity.
        let method = |model| Method {
            model,
            kernel: Kernel::Simd,
        };
        let mut particles = along_x(&[0.0, 0.004, 0.0075, 0.0165]);
        particles.v[1][0] = 1.0;
        particles.hv[1][0] = 1.0;
        let mut course = Simulation::with_method(204.0, particles, method(Model::Course)).unwrap();
        course.set_time_step(TimeStep::Fixed(5e-4));
        course.set_skin(Some(1e-3)).unwrap();
        course.run(2);
        let mut copy = course
            .clone_with_method(method(Model::Fluidanimate))
            .unwrap();
        assert_eq!(copy.method().model, Model::Fluidanimate);
        assert_eq!(copy.time_step(), TimeStep::Fixed(5e-4));
        assert_eq!(
            copy.skin().unwrap().builds(),
            course.skin().unwrap().builds()
        );
        assert_eq!(copy.last_step(), course.last_step());
        assert_eq!(copy.particles(), course.particles());
        copy.run(3);
        course.run(3);
        assert_ne!(copy.particles(), course.particles());
        // Another model's copy starts afresh at the same time.
        let stiff = course.clone_with_method(method(Model::Wcsph)).unwrap();
        assert_eq!(stiff.time(), course.time());
        assert_eq!(stiff.last_step(), None);
    }

    #[test]
    fn method_is_kept_and_models_differ() {
        let run = |model| {
            let method = Method {
                model,
                kernel: Kernel::Scalar,
            };
            let mut particles = along_x(&[0.0, 0.004]);
            particles.v[1][0] = 1.0;
            let mut sim = Simulation::with_method(204.0, particles, method).unwrap();
            assert_eq!(sim.method(), method);
            sim.step();
            sim.particles().velocity(0)
        };
        assert_ne!(run(Model::Course), run(Model::Fluidanimate));
    }
}
