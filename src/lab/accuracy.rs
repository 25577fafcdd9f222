//! Accuracy: the error between two states (per field: largest and RMS distance, and the
//! worst particle), and the accuracy-speed sweep, which runs methods (kernels and
//! time-step rules) to chosen physical times and measures each against the reference
//! trajectory (the compensated [`Kernel::Reference`] at a finer fixed step): position
//! errors, observables, and the CPU time each spent per simulated second.

use crate::io::gformat::format_shortest;
use crate::lab::diagnostics::{self, Failure, PairCounts, Vitals};
use crate::lab::machine::Machine;
use crate::lab::progress::{Goal, Progress};
use crate::sim::kernel::Kernel;
use crate::sim::method::Method;
use crate::sim::model::Model;
use crate::sim::params::{FLUID_DENSITY, TIME_STEP};
use crate::sim::particles::{vector_at, AxisArrays, Particles};
use crate::sim::simulation::Simulation;
use crate::sim::timestep::{Integrator, Limit, TimeStep};
use glam::DVec3;
use std::fmt::Write;

/// How far one field of a state is from another's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldError {
    /// The largest distance |a_i - b_i| (infinite if a value is not finite).
    pub max: f64,
    /// The root mean square distance.
    pub rms: f64,
    /// The particle (index) of the largest distance.
    pub worst: usize,
}

impl FieldError {
    /// No error: a state against itself.
    pub const ZERO: FieldError = FieldError {
        max: 0.0,
        rms: 0.0,
        worst: 0,
    };

    /// The error of `a` against `b`, particle by particle (`a` and `b` of equal length).
    pub fn between(a: &[DVec3], b: &[DVec3]) -> FieldError {
        assert_eq!(a.len(), b.len(), "states of different sizes");
        let mut error = FieldError::ZERO;
        let mut squares = 0.0;
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            let distance = x.distance(*y);
            let distance = if distance.is_finite() {
                distance
            } else {
                f64::INFINITY
            };
            if distance > error.max {
                error.max = distance;
                error.worst = i;
            }
            squares += distance * distance;
        }
        error.rms = (squares / a.len().max(1) as f64).sqrt();
        error
    }
}

/// The vectors of a field for the first `n` slots.
pub fn vectors(arrays: &AxisArrays, n: usize) -> Vec<DVec3> {
    (0..n).map(|slot| vector_at(arrays, slot)).collect()
}

/// The errors of positions, half velocities and velocities of `a` against `b` (both in
/// file order), or why they cannot be compared.
pub fn compare(a: &Particles, b: &Particles) -> Result<[(&'static str, FieldError); 3], String> {
    let n = a.len();
    if n != b.len() {
        return Err(format!("{n} particles against {}", b.len()));
    }
    Ok([("p", &a.p, &b.p), ("hv", &a.hv, &b.hv), ("v", &a.v, &b.v)]
        .map(|(name, x, y)| (name, FieldError::between(&vectors(x, n), &vectors(y, n)))))
}

/// The positions of a simulation's particles in file order.
pub fn positions_by_id(simulation: &Simulation) -> Vec<DVec3> {
    let particles = simulation.particles();
    let mut positions = vec![DVec3::ZERO; particles.len()];
    for slot in 0..particles.len() {
        positions[particles.id[slot] as usize] = vector_at(&particles.p, slot);
    }
    positions
}

/// A method the accuracy sweep compares: a kernel (its precision and lanes) and a
/// time-step rule; the model is the scene's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The pair-loop implementation.
    pub kernel: Kernel,
    /// How each step's length is chosen.
    pub time_step: TimeStep,
    /// The skin of reused neighbour lists, in cut-offs (none: rebuilt every step).
    pub skin: Option<f64>,
    /// How each step advances the state.
    pub integrator: Integrator,
}

impl Candidate {
    /// The f64 default of `model`: `fluid`'s kernel on the model's own time step (the
    /// course's fixed 1 ms, or the weakly compressible model's CFL step), lists rebuilt
    /// every step.
    pub fn default_for(model: Model) -> Candidate {
        Candidate {
            kernel: Kernel::NATIVE,
            time_step: model.default_time_step(),
            skin: None,
            integrator: Integrator::default(),
        }
    }

    /// A short label: `simd dt 0.5 ms`, `mixed C 0.3 skin 0.2h`, `simd dt 1 ms verlet`,
    /// `reference dt 23.93 µs verlet` (the integrator named unless it is the leapfrog).
    pub fn label(&self) -> String {
        let mut skin = self.skin.map_or(String::new(), |s| format!(" skin {s}h"));
        if self.integrator != Integrator::Leapfrog {
            skin = format!("{skin} {}", self.integrator.name());
        }
        let rule = match self.time_step {
            TimeStep::Fixed(dt) if dt < 1e-4 => {
                format!("{} dt {:.2} µs", self.kernel.name(), dt * 1e6)
            }
            TimeStep::Fixed(dt) => {
                let milliseconds = (dt * 1e7).round() / 1e4;
                format!("{} dt {milliseconds} ms", self.kernel.name())
            }
            TimeStep::Adaptive { courant } => format!("{} C {courant}", self.kernel.name()),
        };
        rule + &skin
    }

    /// The CSV cells `time_step,dt_s,courant,skin_h,integrator`.
    fn time_step_cells(&self) -> String {
        let skin = self.skin.map_or(String::new(), |s| s.to_string());
        let integrator = self.integrator.name();
        match self.time_step {
            TimeStep::Fixed(dt) => format!("fixed,{dt:e},,{skin},{integrator}"),
            TimeStep::Adaptive { courant } => format!("adaptive,,{courant},{skin},{integrator}"),
        }
    }

    /// Every kernel with every fixed step and every adaptive constant, each with lists
    /// rebuilt every step and with each of `skins`, on each of `integrators`; `model`'s
    /// default first (added if the lists leave it out).
    pub fn product(
        model: Model,
        kernels: &[Kernel],
        fixed: &[f64],
        courants: &[f64],
        skins: &[f64],
        integrators: &[Integrator],
    ) -> Vec<Candidate> {
        let rules = fixed.iter().map(|&dt| TimeStep::Fixed(dt)).chain(
            courants
                .iter()
                .map(|&courant| TimeStep::Adaptive { courant }),
        );
        let skins: Vec<Option<f64>> = std::iter::once(None)
            .chain(skins.iter().copied().map(Some))
            .collect();
        let mut candidates = vec![Candidate::default_for(model)];
        for &integrator in integrators {
            for time_step in rules.clone() {
                for &kernel in kernels {
                    for &skin in &skins {
                        let candidate = Candidate {
                            kernel,
                            time_step,
                            skin,
                            integrator,
                        };
                        if !candidates.contains(&candidate) {
                            candidates.push(candidate);
                        }
                    }
                }
            }
        }
        candidates
    }
}

/// What a state is compared by: every particle's position and density (by id, densities
/// of the current positions), and the observables a user reads.
#[derive(Debug, Clone, PartialEq)]
pub struct Observed {
    /// Positions by id.
    pub positions: Vec<DVec3>,
    /// Densities by id.
    pub densities: Vec<f64>,
    /// Centre of mass.
    pub centre: DVec3,
    /// Kinetic energy (J).
    pub kinetic: f64,
    /// The front ([`diagnostics::front`]), if the floor holds enough particles.
    pub front: Option<f64>,
}

impl Observed {
    /// Observes a state whose densities are those of its positions
    /// ([`Simulation::with_fresh_densities`]).
    pub fn of(fresh: &Simulation) -> Observed {
        let particles = fresh.particles();
        let n = particles.len();
        let mut densities = vec![0.0; n];
        for slot in 0..n {
            densities[particles.id[slot] as usize] = particles.rho[slot];
        }
        let positions = positions_by_id(fresh);
        let centre = positions.iter().sum::<DVec3>() / n.max(1) as f64;
        Observed {
            centre,
            kinetic: Vitals::of(fresh).kinetic,
            front: diagnostics::front(fresh),
            positions,
            densities,
        }
    }
}

/// How far a method's state is from the reference's at the same physical time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    /// Median distance of a particle from where the reference puts it (m).
    pub median_position: f64,
    /// Largest such distance (m).
    pub max_position: f64,
    /// Distance between the centres of mass (m).
    pub centre: f64,
    /// |K - K_ref| / K_ref of the kinetic energies (none if the reference is at rest).
    pub kinetic: Option<f64>,
    /// Mean of |rho - rho_ref| / rho_0 over the particles.
    pub mean_density: f64,
    /// Largest |rho - rho_ref| / rho_0.
    pub max_density: f64,
    /// |front - front_ref| (m), if both states have a front.
    pub front: Option<f64>,
}

impl Errors {
    /// The CSV cells of `errors`, in [`CSV_HEADER`]'s order from `median_error_m` to
    /// `front_error_m`; all empty for none.
    pub fn cells(errors: Option<&Errors>) -> [String; 7] {
        let optional = |value: Option<f64>| value.map_or(String::new(), |v| format!("{v:e}"));
        match errors {
            None => Default::default(),
            Some(e) => [
                format!("{:e}", e.median_position),
                format!("{:e}", e.max_position),
                format!("{:e}", e.centre),
                optional(e.kinetic),
                format!("{:e}", e.mean_density),
                format!("{:e}", e.max_density),
                optional(e.front),
            ],
        }
    }

    /// The errors of `state` against `reference` (non-finite distances count as infinite).
    pub fn between(state: &Observed, reference: &Observed) -> Errors {
        let finite = |x: f64| if x.is_finite() { x } else { f64::INFINITY };
        let mut distances: Vec<f64> = state
            .positions
            .iter()
            .zip(&reference.positions)
            .map(|(a, b)| finite(a.distance(*b)))
            .collect();
        distances.sort_unstable_by(f64::total_cmp);
        let density_errors = state
            .densities
            .iter()
            .zip(&reference.densities)
            .map(|(a, b)| finite((a - b).abs() / FLUID_DENSITY));
        let (sum, max_density) =
            density_errors.fold((0.0, 0.0f64), |(sum, max), e| (sum + e, max.max(e)));
        let n = distances.len().max(1);
        Errors {
            median_position: distances.get(distances.len() / 2).copied().unwrap_or(0.0),
            max_position: distances.last().copied().unwrap_or(0.0),
            centre: finite(state.centre.distance(reference.centre)),
            kinetic: (reference.kinetic > 0.0)
                .then(|| finite((state.kinetic - reference.kinetic).abs() / reference.kinetic)),
            mean_density: sum / n as f64,
            max_density,
            front: state
                .front
                .zip(reference.front)
                .map(|(a, b)| finite((a - b).abs())),
        }
    }
}

/// Which position error a budget bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    /// The median particle's distance from the reference.
    Median,
    /// The largest particle distance from the reference.
    Max,
}

impl Metric {
    /// The metric's value among `errors`.
    pub fn of(self, errors: &Errors) -> f64 {
        match self {
            Metric::Median => errors.median_position,
            Metric::Max => errors.max_position,
        }
    }

    /// Its name in messages and chart labels.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Median => "median",
            Metric::Max => "largest",
        }
    }
}

/// One method's state at one of the sweep's times.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// The time asked for (s).
    pub requested: f64,
    /// The physical time of the state (s): the end of the first step at or after
    /// `requested`.
    pub time: f64,
    /// Steps run to reach it.
    pub steps: u64,
    /// CPU seconds of this thread spent in those steps (observations excluded).
    pub cpu_seconds: f64,
    /// The shortest step taken so far (s), of those not cut short to land on a time.
    pub shortest_step: f64,
    /// The state's pair counts.
    pub pairs: PairCounts,
    /// Its errors against the reference (none for the reference itself).
    pub errors: Option<Errors>,
}

impl Sample {
    /// CPU seconds per simulated second.
    pub fn cost(&self) -> f64 {
        self.cpu_seconds / self.time
    }
}

/// A method's run: its samples up to the time it failed, if it did.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The method.
    pub candidate: Candidate,
    /// Its state at each time reached.
    pub samples: Vec<Sample>,
    /// When it stopped before the last time, and why.
    pub failure: Option<(f64, Failure)>,
    /// The bytes the simulation held on the heap at the end.
    pub heap_bytes: usize,
}

/// The accuracy sweep's result: the reference run and each method's.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    /// The compensated kernel at a fixed step finer than every method's.
    pub reference: Run,
    /// The methods, in the order given.
    pub runs: Vec<Run>,
    /// The shortest step of the methods that reached every time (s).
    pub shortest_step: f64,
    /// The model's default method ([`Candidate::default_for`]).
    pub default: Candidate,
}

/// The shortest adaptive step the sweep follows (s), a thousandth of the course's.
pub const SHORTEST_STEP: f64 = 1e-6;

/// How a run meets the times it is sampled at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sampling {
    /// Steps as its rule chooses, sampled at the end of the first step at or after each
    /// time: the method is not disturbed by the sweep.
    Unperturbed,
    /// The last step before each time is cut short to land on it (the reference, whose
    /// cut steps are only finer still).
    Landing,
}

/// Runs `candidate` on `model` from `start` through `times` (ascending, s), sampled as
/// `sampling` says, calling `observe` with each sampled state (densities fresh); stops
/// at the first time whose state is not finite, or at an adaptive step shorter than
/// [`SHORTEST_STEP`]. Its progress is shown as a run's, labelled with the method.
fn run(
    start: &Simulation,
    model: Model,
    candidate: Candidate,
    times: &[f64],
    sampling: Sampling,
    mut observe: impl FnMut(&Simulation),
) -> Result<Run, String> {
    let mut simulation = start
        .clone_with_method(Method {
            model,
            kernel: candidate.kernel,
        })
        .map_err(|error| format!("the {} model: {error}", model.name()))?;
    simulation.set_time_step(candidate.time_step);
    simulation.set_integrator(candidate.integrator);
    let h = simulation.params().h;
    simulation
        .set_skin(candidate.skin.map(|fraction| fraction * h))
        .map_err(|error| format!("a skin of {}h: {error}", candidate.skin.unwrap_or(0.0)))?;
    let (mut cpu_seconds, mut steps, mut shortest) = (0.0, 0, f64::INFINITY);
    let mut samples = Vec::new();
    let mut failure = None;
    let last = times.last().copied().unwrap_or(0.0);
    let mut progress = Progress::towards(Goal::Until(last)).labelled(candidate.label());
    for &requested in times {
        let mut collapsed = false;
        let started = cpu_time();
        while !collapsed && !simulation.has_reached(requested) {
            match sampling {
                Sampling::Unperturbed => simulation.step(),
                Sampling::Landing => simulation.step_towards(requested),
            }
            steps += 1;
            if let Some((dt, limit)) = simulation.last_step() {
                if limit != Limit::Landing {
                    shortest = shortest.min(dt);
                }
            }
            collapsed = diagnostics::step_collapsed(&simulation, SHORTEST_STEP);
            progress.show(steps, simulation.time());
        }
        cpu_seconds += cpu_time() - started;
        if collapsed {
            failure = Some((simulation.time(), Failure::StepCollapsed));
            break;
        }
        if let Some(id) = Vitals::of(&simulation).non_finite {
            failure = Some((simulation.time(), Failure::NonFinite(id)));
            break;
        }
        let fresh = simulation.with_fresh_densities();
        observe(&fresh);
        samples.push(Sample {
            requested,
            time: simulation.time(),
            steps,
            cpu_seconds,
            shortest_step: shortest,
            pairs: PairCounts::of(&fresh),
            errors: None,
        });
    }
    progress.finish();
    Ok(Run {
        candidate,
        samples,
        failure,
        heap_bytes: simulation.heap_bytes(),
    })
}

/// Runs `candidate` on `model` from `start` through `times` (ascending, s) as the sweep
/// runs every method: undisturbed, sampled at the end of its first step at or after each
/// time, calling `observe` with each sampled state (densities fresh).
pub fn run_method(
    start: &Simulation,
    model: Model,
    candidate: Candidate,
    times: &[f64],
    observe: impl FnMut(&Simulation),
) -> Result<Run, String> {
    run(
        start,
        model,
        candidate,
        times,
        Sampling::Unperturbed,
        observe,
    )
}

/// The shortest step of the runs that reached every time (one that blew up is not worth
/// a reference finer than its last steps), at most the course's step.
pub fn shortest_step(runs: &[Run]) -> f64 {
    runs.iter()
        .filter(|run| run.failure.is_none())
        .flat_map(|run| run.samples.last())
        .map(|sample| sample.shortest_step)
        .fold(TIME_STEP, f64::min)
}

/// Every time one of `runs` was sampled at, ascending, times within rounding of each
/// other once: the times the reference lands on.
pub fn sampled_times(runs: &[Run]) -> Vec<f64> {
    let mut sampled: Vec<f64> = runs
        .iter()
        .flat_map(|run| run.samples.iter().map(|sample| sample.time))
        .collect();
    sampled.sort_by(f64::total_cmp);
    sampled.dedup_by(|later, earlier| same_time(*later, *earlier));
    sampled
}

/// Runs the reference (the compensated kernel at the fixed `step`, on the second-order
/// velocity Verlet, whose own error then falls fastest) on `model` from `start`, landing
/// on every one of `sampled` (ascending), calling `observe` with each state; a reference
/// that fails is an error.
pub fn run_reference(
    start: &Simulation,
    model: Model,
    step: f64,
    sampled: &[f64],
    observe: impl FnMut(&Simulation),
) -> Result<Run, String> {
    let candidate = Candidate {
        kernel: Kernel::Reference,
        time_step: TimeStep::Fixed(step),
        skin: None,
        integrator: Integrator::Verlet,
    };
    let reference = run(start, model, candidate, sampled, Sampling::Landing, observe)?;
    match reference.failure {
        Some((time, why)) => Err(format!(
            "the reference ({}) failed at {time} s: {why}",
            reference.candidate.label()
        )),
        None => Ok(reference),
    }
}

/// Measures each sample of `runs` (observed as `states`, run by run) against the
/// reference's state at its time (`truths`, one per time of `sampled`).
pub fn measure(runs: &mut [Run], states: &[Vec<Observed>], sampled: &[f64], truths: &[Observed]) {
    for (run, observed) in runs.iter_mut().zip(states) {
        for (sample, state) in run.samples.iter_mut().zip(observed) {
            let after = sampled.partition_point(|&t| t < sample.time);
            let at = [after.wrapping_sub(1), after]
                .into_iter()
                .find(|&k| sampled.get(k).is_some_and(|&t| same_time(t, sample.time)));
            if let Some(truth) = at.and_then(|k| truths.get(k)) {
                sample.errors = Some(Errors::between(state, truth));
            }
        }
    }
}

/// Runs every candidate on `model` from `start` through `times` (ascending, s)
/// ([`run_method`]); then the reference ([`run_reference`]) at `reference_step` (or, if
/// none, an eighth of the [`shortest_step`] any candidate took), landing on every time a
/// candidate was sampled at, unless that would take more than `most_steps` steps (an
/// error); and [`measure`]s each sample against it.
pub fn sweep(
    start: &Simulation,
    model: Model,
    candidates: &[Candidate],
    times: &[f64],
    reference_step: Option<f64>,
    most_steps: f64,
) -> Result<Sweep, String> {
    let mut states: Vec<Vec<Observed>> = Vec::new();
    let mut runs: Vec<Run> = Vec::new();
    for &candidate in candidates {
        let mut observed = Vec::new();
        runs.push(run_method(start, model, candidate, times, |fresh| {
            observed.push(Observed::of(fresh));
        })?);
        states.push(observed);
    }
    let shortest = shortest_step(&runs);
    let sampled = sampled_times(&runs);
    let mut truths = Vec::new();
    let step = reference_step.unwrap_or(shortest / 8.0);
    let last = sampled.last().copied().unwrap_or(0.0);
    if last / step > most_steps {
        return Err(format!(
            "the reference would take {:.3e} steps of {} s to reach the last sample, at {} s, \
             more than the {most_steps:.0e} a run may take",
            last / step,
            format_shortest(step),
            format_shortest(last)
        ));
    }
    let reference = run_reference(start, model, step, &sampled, |fresh| {
        truths.push(Observed::of(fresh))
    })?;
    measure(&mut runs, &states, &sampled, &truths);
    Ok(Sweep {
        reference,
        runs,
        shortest_step: shortest,
        default: Candidate::default_for(model),
    })
}

/// Whether two sample times are one for the reference: within 1e-8 relative, so that
/// sums of equal steps that differ in their last bits, and adaptive runs whose steps
/// differ by rounding, share its state (the state moves by at most |v| 1e-8 t there).
fn same_time(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-8 * a.abs().max(b.abs())
}

/// The scene a sweep ran, as its rows name it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneId {
    /// Its file's name (the input's or the case's), as rows and charts show it.
    pub file_name: String,
    /// The CRC-32 of that file's bytes: another scene of that name is not this one.
    pub crc32: u32,
    /// Its particle count.
    pub particles: usize,
}

impl SceneId {
    /// Its CSV cells: `scene`, `scene_crc32` (8 hex digits) and `particles`.
    fn cells(&self) -> String {
        format!("{},{:08x},{}", self.file_name, self.crc32, self.particles)
    }
}

/// The column of the scene's CRC-32, which a CSV written before it lacks (and reads alike).
pub const SCENE_CRC_COLUMN: &str = "scene_crc32";

/// The CSV header of the accuracy sweep.
pub const CSV_HEADER: &str = "scene,scene_crc32,particles,model,method,kernel,time_step,dt_s,courant,skin_h,\
     integrator,requested_time_s,time_s,steps,cpu_s,cpu_s_per_simulated_s,shortest_step_s,pairs_tested,pairs_within_h,\
     heap_bytes,median_error_m,max_error_m,centre_error_m,kinetic_error,mean_density_error,\
     max_density_error,front_error_m,failure,host,cpu_model,commit";

impl Sweep {
    /// The sweep as CSV rows (with [`CSV_HEADER`]): the reference's, then each run's
    /// ([`Run::csv`]).
    pub fn csv(&self, scene: &SceneId, model: Model, machine: &Machine) -> String {
        std::iter::once(&self.reference)
            .chain(&self.runs)
            .map(|run| run.csv(scene, model, machine))
            .collect()
    }

    /// The fastest run (least CPU time per simulated second at the last time) whose
    /// position error by `metric` stays within `budget` (m) at every time, if any does.
    pub fn fastest_within(&self, budget: f64, metric: Metric) -> Option<&Run> {
        self.fastest_on(None, budget, metric)
    }

    /// As [`Self::fastest_within`], among the runs of `integrator` if one is given.
    pub fn fastest_on(
        &self,
        integrator: Option<Integrator>,
        budget: f64,
        metric: Metric,
    ) -> Option<&Run> {
        // A run without a failure reached every time.
        self.runs
            .iter()
            .filter(|run| run.failure.is_none())
            .filter(|run| integrator.is_none_or(|i| run.candidate.integrator == i))
            .filter(|run| {
                run.samples
                    .iter()
                    .all(|s| s.errors.is_some_and(|e| metric.of(&e) <= budget))
            })
            .min_by(|a, b| a.final_cost().total_cmp(&b.final_cost()))
    }

    /// The run of the model's default method.
    pub fn default_run(&self) -> Option<&Run> {
        self.runs.iter().find(|run| run.candidate == self.default)
    }
}

impl Run {
    /// The run's CSV rows (of [`CSV_HEADER`]): one per time reached, then one saying when
    /// and why it failed, if it did; the reference's errors are empty.
    pub fn csv(&self, scene: &SceneId, model: Model, machine: &Machine) -> String {
        let mut text = String::new();
        let machine_cells = format!(
            "{},{},{}",
            machine.host,
            machine.cpu_model.replace(',', " "),
            machine.commit
        );
        let method = format!(
            "{},{},{},{},{}",
            scene.cells(),
            model.name(),
            self.candidate.label(),
            self.candidate.kernel.name(),
            self.candidate.time_step_cells()
        );
        for sample in &self.samples {
            let _ = writeln!(
                text,
                "{method},{},{},{},{:e},{:e},{:e},{},{},{},{},,{machine_cells}",
                sample.requested,
                sample.time,
                sample.steps,
                sample.cpu_seconds,
                sample.cost(),
                sample.shortest_step,
                sample.pairs.tested,
                sample.pairs.within_h,
                self.heap_bytes,
                Errors::cells(sample.errors.as_ref()).join(","),
            );
        }
        if let Some((time, why)) = &self.failure {
            let _ = writeln!(
                text,
                "{method},,{time},,,,,,,{},,,,,,,,{why},{machine_cells}",
                self.heap_bytes
            );
        }
        text
    }

    /// CPU seconds per simulated second over the whole run (infinite if it failed).
    pub fn final_cost(&self) -> f64 {
        match (&self.failure, self.samples.last()) {
            (None, Some(sample)) => sample.cost(),
            _ => f64::INFINITY,
        }
    }
}

/// The convergence of one family of methods: a kernel and an integrator on fixed steps
/// (lists rebuilt every step), its error at the last time against the step.
#[derive(Debug, Clone, PartialEq)]
pub struct Convergence {
    /// The pair-loop implementation.
    pub kernel: Kernel,
    /// The integrator.
    pub integrator: Integrator,
    /// (dt, error) of each step that reached the last time, by increasing dt.
    pub points: Vec<(f64, f64)>,
    /// The least-squares slope of ln(error) against ln(dt) over the [`ORDER_STEPS`]
    /// shortest steps: the order observed, if at least two steps have a positive error.
    pub order: Option<f64>,
}

/// How many of the shortest fixed steps the order is fitted over: the asymptotic range,
/// where the error follows dt^order (the longest steps of a sweep are near the stability
/// limit, where it grows faster).
pub const ORDER_STEPS: usize = 3;

impl Sweep {
    /// Each kernel's and integrator's error by `metric` at the sweep's last time against
    /// its fixed steps, with the order fitted; families with fewer than two such runs
    /// are left out.
    pub fn convergence(&self, metric: Metric) -> Vec<Convergence> {
        let mut families: Vec<Convergence> = Vec::new();
        let last = self
            .runs
            .iter()
            .map(|run| run.samples.len())
            .max()
            .unwrap_or(0);
        for run in &self.runs {
            let (TimeStep::Fixed(dt), None) = (run.candidate.time_step, run.candidate.skin) else {
                continue;
            };
            let at_end = run
                .samples
                .get(last.wrapping_sub(1))
                .filter(|_| run.failure.is_none());
            let Some(error) = at_end.and_then(|sample| Some(metric.of(&sample.errors?))) else {
                continue;
            };
            let (kernel, integrator) = (run.candidate.kernel, run.candidate.integrator);
            let family = match families
                .iter_mut()
                .position(|f| f.kernel == kernel && f.integrator == integrator)
            {
                Some(k) => &mut families[k],
                None => {
                    families.push(Convergence {
                        kernel,
                        integrator,
                        points: Vec::new(),
                        order: None,
                    });
                    families.last_mut().expect("just pushed")
                }
            };
            family.points.push((dt, error));
        }
        families.retain(|family| family.points.len() >= 2);
        for family in &mut families {
            family.points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let shortest = family.points.len().min(ORDER_STEPS);
            family.order = fitted_slope(&family.points[..shortest]);
        }
        families
    }
}

/// The least-squares slope of ln(y) against ln(x) over the points with positive, finite
/// x and y, if at least two such points have different x.
pub fn fitted_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let count = logs.len() as f64;
    let (mean_x, mean_y) = logs.iter().fold((0.0, 0.0), |(sx, sy), (x, y)| {
        (sx + x / count, sy + y / count)
    });
    let (covariance, variance) = logs.iter().fold((0.0, 0.0), |(c, v), (x, y)| {
        (c + (x - mean_x) * (y - mean_y), v + (x - mean_x).powi(2))
    });
    (logs.len() >= 2 && variance > 0.0).then(|| covariance / variance)
}

/// The points of `points` (cost, error) that no other point beats on both: the Pareto
/// front, by ascending cost (points with a non-finite coordinate are left out).
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for point in sorted {
        if front.last().is_none_or(|last| point.1 < last.1) {
            front.push(point);
        }
    }
    front
}

/// This thread's CPU time (s).
fn cpu_time() -> f64 {
    let mut spec = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec to the pointer it is given.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut spec) };
    assert_eq!(
        status, 0,
        "CLOCK_THREAD_CPUTIME_ID is always available on Linux"
    );
    spec.tv_sec as f64 + spec.tv_nsec as f64 * 1e-9
}

/// The first bytes of an [`Observed::encode`]d state.
const OBSERVED_MAGIC: &[u8; 8] = b"FLUIDOB1";

impl Observed {
    /// The state as bytes (little-endian): `FLUIDOB1`, the particle count (u64), centre,
    /// kinetic energy, the front (a flag byte and its value), positions, densities (f64),
    /// so that a job array's tasks hand their states to the merge.
    pub fn encode(&self) -> Vec<u8> {
        let n = self.positions.len();
        let mut bytes = Vec::with_capacity(8 + 8 + 5 * 8 + 1 + n * 32);
        bytes.extend_from_slice(OBSERVED_MAGIC);
        bytes.extend_from_slice(&(n as u64).to_le_bytes());
        let front = self.front.unwrap_or(0.0);
        for value in self
            .centre
            .to_array()
            .into_iter()
            .chain([self.kinetic, front])
        {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
        bytes.push(self.front.is_some() as u8);
        for position in &self.positions {
            for value in position.to_array() {
                bytes.extend_from_slice(&value.to_le_bytes());
            }
        }
        for density in &self.densities {
            bytes.extend_from_slice(&density.to_le_bytes());
        }
        bytes
    }

    /// The state [`Observed::encode`] wrote, or why `bytes` are not one.
    pub fn decode(bytes: &[u8]) -> Result<Observed, String> {
        let body = bytes
            .strip_prefix(OBSERVED_MAGIC)
            .ok_or("not an observed state (FLUIDOB1)")?;
        let count = body.get(..8).ok_or("truncated")?;
        let n = u64::from_le_bytes(count.try_into().expect("8 bytes")) as usize;
        let body = &body[8..];
        if Some(body.len()) != n.checked_mul(32).and_then(|b| b.checked_add(41)) {
            return Err(format!("{} bytes do not hold {n} particles", bytes.len()));
        }
        let value = |k: usize| f64::from_le_bytes(body[8 * k..8 * k + 8].try_into().expect("8"));
        let (head, tail) = body.split_at(41);
        let at = |k: usize| f64::from_le_bytes(tail[8 * k..8 * k + 8].try_into().expect("8"));
        Ok(Observed {
            centre: DVec3::new(value(0), value(1), value(2)),
            kinetic: value(3),
            front: (head[40] == 1).then(|| value(4)),
            positions: (0..n)
                .map(|i| DVec3::new(at(3 * i), at(3 * i + 1), at(3 * i + 2)))
                .collect(),
            densities: (0..n).map(|i| at(3 * n + i)).collect(),
        })
    }
}

/// The runs of an accuracy CSV (its columns by name, so that further columns, such as a
/// Slurm array's, are let be): a run per method, in the order they first appear, each
/// with its samples and its failure.
pub fn read_runs(text: &str) -> Result<Vec<Run>, String> {
    use clap::ValueEnum;
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let headers = reader.headers().map_err(|error| error.to_string())?.clone();
    let column = |name: &str| {
        headers
            .iter()
            .position(|header| header == name)
            .ok_or_else(|| format!("the accuracy CSV has no column {name}"))
    };
    let names: Vec<&str> = (CSV_HEADER.split(','))
        .filter(|&name| name != SCENE_CRC_COLUMN)
        .collect();
    let columns: Vec<usize> = names.iter().map(|n| column(n)).collect::<Result<_, _>>()?;
    let mut runs: Vec<Run> = Vec::new();
    for (line, record) in reader.records().enumerate() {
        let record = record.map_err(|error| error.to_string())?;
        let bad = |what: String| format!("row {}: {what}", line + 2);
        let cell = |name: &str| {
            let k = names.iter().position(|n| *n == name).expect("a column");
            &record[columns[k]]
        };
        // A time, step, rule or cost: a finite number >= 0; an error: a number >= 0, where
        // infinity is a particle's blown-up distance.
        let read = |name: &str, holds: fn(f64) -> bool, what: &str| -> Result<f64, String> {
            match cell(name).parse::<f64>() {
                Ok(value) if holds(value) => Ok(value),
                Ok(_) => Err(bad(format!("{name} is {}, not {what}", cell(name)))),
                Err(_) => Err(bad(format!("{name} {:?} is not a number", cell(name)))),
            }
        };
        let number = |name: &str| read(name, |v| v.is_finite() && v >= 0.0, "a finite number >= 0");
        let error = |name: &str| read(name, |v| v >= 0.0, "an error >= 0");
        let optional = |name: &str| match cell(name) {
            "" => Ok(None),
            _ => number(name).map(Some),
        };
        let optional_error = |name: &str| match cell(name) {
            "" => Ok(None),
            _ => error(name).map(Some),
        };
        let count = |name: &str| -> Result<u64, String> {
            cell(name)
                .parse()
                .map_err(|_| bad(format!("{name} {:?} is not a count", cell(name))))
        };
        let kernel = Kernel::from_str(cell("kernel"), false)
            .map_err(|_| bad(format!("unknown kernel {:?}", cell("kernel"))))?;
        let time_step = match cell("time_step") {
            "fixed" => TimeStep::Fixed(number("dt_s")?),
            "adaptive" => TimeStep::Adaptive {
                courant: number("courant")?,
            },
            other => return Err(bad(format!("unknown time_step {other:?}"))),
        };
        let integrator = Integrator::from_str(cell("integrator"), false)
            .map_err(|_| bad(format!("unknown integrator {:?}", cell("integrator"))))?;
        let candidate = Candidate {
            kernel,
            time_step,
            skin: optional("skin_h")?,
            integrator,
        };
        let heap_bytes = count("heap_bytes")? as usize;
        let k = match runs.iter().position(|run| run.candidate == candidate) {
            Some(k) => k,
            None => {
                runs.push(Run {
                    candidate,
                    samples: Vec::new(),
                    failure: None,
                    heap_bytes,
                });
                runs.len() - 1
            }
        };
        let run = &mut runs[k];
        if cell("requested_time_s").is_empty() {
            let failure = Failure::from_text(cell("failure"))
                .ok_or_else(|| bad(format!("unknown failure {:?}", cell("failure"))))?;
            run.failure = Some((number("time_s")?, failure));
            continue;
        }
        let errors = match optional_error("median_error_m")? {
            None => None,
            Some(median_position) => Some(Errors {
                median_position,
                max_position: error("max_error_m")?,
                centre: error("centre_error_m")?,
                kinetic: optional_error("kinetic_error")?,
                mean_density: error("mean_density_error")?,
                max_density: error("max_density_error")?,
                front: optional_error("front_error_m")?,
            }),
        };
        run.samples.push(Sample {
            requested: number("requested_time_s")?,
            time: number("time_s")?,
            steps: count("steps")?,
            cpu_seconds: number("cpu_s")?,
            shortest_step: number("shortest_step_s")?,
            pairs: PairCounts {
                tested: count("pairs_tested")?,
                within_h: count("pairs_within_h")?,
            },
            errors,
        });
    }
    Ok(runs)
}

impl Sweep {
    /// The sweep of an accuracy CSV of `model` ([`read_runs`]): its first method is the
    /// reference, as [`Sweep::csv`] writes it.
    pub fn read(text: &str, model: Model) -> Result<Sweep, String> {
        let mut runs = read_runs(text)?.into_iter();
        let reference = runs.next().ok_or("the accuracy CSV has no rows")?;
        let runs: Vec<Run> = runs.collect();
        Ok(Sweep {
            shortest_step: shortest_step(&runs),
            reference,
            runs,
            default: Candidate::default_for(model),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_errors_find_the_worst_particle() {
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let b = [DVec3::ZERO, DVec3::X * 4.0, DVec3::new(0.0, 1.0, 4.0)];
        let error = FieldError::between(&a, &b);
        assert_eq!((error.max, error.worst), (4.0, 2));
        assert!((error.rms - ((9.0 + 16.0) / 3.0f64).sqrt()).abs() < 1e-15);
        let broken = FieldError::between(&[DVec3::NAN], &[DVec3::ZERO]);
        assert_eq!(broken.max, f64::INFINITY);
        assert_eq!(FieldError::between(&a, &a), FieldError::ZERO);
    }

    #[test]
    fn comparing_needs_states_of_one_size() {
        let mut a = Particles::zeroed(2);
        let b = Particles::zeroed(3);
        assert_eq!(compare(&a, &b).unwrap_err(), "2 particles against 3");
        a.hv[1][1] = 2.0;
        let [p, hv, v] = compare(&a, &Particles::zeroed(2)).unwrap();
        assert_eq!((p.0, p.1.max), ("p", 0.0));
        assert_eq!((hv.0, hv.1.max, hv.1.worst), ("hv", 2.0, 1));
        assert_eq!((v.0, v.1.max), ("v", 0.0));
    }

    #[test]
    fn candidates_are_every_kernel_with_every_rule_the_default_first() {
        let candidates = Candidate::product(
            Model::Fluidanimate,
            &[Kernel::Mixed, Kernel::NATIVE],
            &[5e-4, TIME_STEP],
            &[0.3],
            &[],
            &Integrator::ALL,
        );
        assert_eq!(candidates[0], Candidate::default_for(Model::Fluidanimate));
        // Each integrator: 2 kernels x 3 rules, the leapfrog's simd at 1 ms the default.
        assert_eq!(candidates.len(), 12, "{candidates:?}");
        assert_eq!(
            candidates[7].label(),
            format!("{} dt 0.5 ms verlet", Kernel::NATIVE.name())
        );
        let labels: Vec<String> = candidates.iter().map(Candidate::label).collect();
        assert!(
            labels.contains(&"mixed dt 0.5 ms".to_string()),
            "{labels:?}"
        );
        assert!(labels.contains(&"mixed C 0.3".to_string()), "{labels:?}");
        let fine = Candidate {
            kernel: Kernel::Reference,
            time_step: TimeStep::Fixed(2.5e-5),
            skin: None,
            integrator: Integrator::Leapfrog,
        };
        assert_eq!(fine.label(), "reference dt 25.00 µs");
        // The native kernel is the default, so that it is not added again.
        let native = Kernel::NATIVE;
        let leapfrog = [Integrator::Leapfrog];
        let skins = Candidate::product(
            Model::Course,
            &[native],
            &[TIME_STEP],
            &[],
            &[0.2],
            &leapfrog,
        );
        assert_eq!(skins.len(), 2, "{skins:?}");
        assert_eq!(
            skins[1].label(),
            format!("{} dt 1 ms skin 0.2h", native.name())
        );
        // Without the default in the lists, it is added.
        assert_eq!(
            Candidate::product(Model::Course, &[Kernel::Mixed], &[], &[0.3], &[], &leapfrog)[0],
            Candidate::default_for(Model::Course)
        );
        // The weakly compressible model's default is its CFL step.
        let stiff =
            Candidate::product(Model::Wcsph, &[Kernel::Mixed], &[1e-5], &[], &[], &leapfrog);
        assert_eq!(stiff[0].time_step, TimeStep::Adaptive { courant: 0.2 });
    }

    fn observed(
        positions: &[DVec3],
        densities: &[f64],
        kinetic: f64,
        front: Option<f64>,
    ) -> Observed {
        Observed {
            positions: positions.to_vec(),
            densities: densities.to_vec(),
            centre: positions.iter().sum::<DVec3>() / positions.len() as f64,
            kinetic,
            front,
        }
    }

    #[test]
    fn errors_compare_particles_and_observables() {
        let truth = observed(
            &[DVec3::ZERO; 3],
            &[1000.0, 1000.0, 1000.0],
            2.0,
            Some(0.05),
        );
        let state = observed(
            &[DVec3::X * 0.001, DVec3::Y * 0.002, DVec3::Z * 0.006],
            &[1010.0, 1000.0, 970.0],
            2.5,
            Some(0.04),
        );
        let errors = Errors::between(&state, &truth);
        assert_eq!(
            (errors.median_position, errors.max_position),
            (0.002, 0.006)
        );
        assert!((errors.centre - DVec3::new(0.001, 0.002, 0.006).length() / 3.0).abs() < 1e-15);
        assert_eq!(errors.kinetic, Some(0.25));
        assert!((errors.mean_density - 0.04 / 3.0).abs() < 1e-15);
        assert!((errors.max_density - 0.03).abs() < 1e-15);
        assert!((errors.front.unwrap() - 0.01).abs() < 1e-15);
        let broken = observed(&[DVec3::NAN; 3], &[f64::NAN; 3], f64::NAN, None);
        let errors = Errors::between(&broken, &truth);
        assert_eq!(errors.max_position, f64::INFINITY);
        assert_eq!(errors.kinetic, Some(f64::INFINITY));
        let resting = observed(&[DVec3::ZERO; 3], &[1000.0; 3], 0.0, None);
        assert_eq!(Errors::between(&truth, &resting).kinetic, None);
        assert_eq!(errors.front, None);
        assert_eq!(Metric::Median.of(&errors), f64::INFINITY);
    }

    #[test]
    fn the_pareto_front_keeps_the_points_nothing_beats() {
        let points = [
            (2.0, 1.0),
            (1.0, 3.0),
            (3.0, 0.5),
            (2.5, 2.0),
            (1.5, 3.0),
            (f64::NAN, 0.1),
        ];
        assert_eq!(pareto_front(&points), [(1.0, 3.0), (2.0, 1.0), (3.0, 0.5)]);
        assert!(pareto_front(&[]).is_empty());
    }

    /// The orders the sweep fits for `model` on a block collapsing in the box's corner
    /// (`count` particles at 150 per metre) over the fixed `steps` to `until`, each on
    /// both integrators: (leapfrog, verlet).
    fn orders(model: Model, count: usize, steps: &[f64], until: f64, reference: f64) -> (f64, f64) {
        let particles = crate::lab::scene::corner_block(150.0, count).unwrap();
        let method = Method {
            model,
            kernel: Kernel::NATIVE,
        };
        let start = Simulation::with_method(150.0, particles, method).unwrap();
        let candidates =
            Candidate::product(model, &[Kernel::NATIVE], steps, &[], &[], &Integrator::ALL);
        let sweep = sweep(&start, model, &candidates, &[until], Some(reference), 1e7).unwrap();
        let convergence = sweep.convergence(Metric::Median);
        let order = |integrator| {
            let family = convergence
                .iter()
                .find(|f| f.integrator == integrator)
                .expect("a family per integrator");
            assert_eq!(family.points.len(), steps.len(), "{family:?}");
            family.order.unwrap()
        };
        (order(Integrator::Leapfrog), order(Integrator::Verlet))
    }

    #[test]
    fn the_verlet_is_second_order_and_the_leapfrog_first() {
        // fluidanimate, 0.25-2 ms to 16 ms; the weakly compressible model, 25-100 us to
        // 8 ms (its CFL step is near 0.2 ms here): the median error against the
        // reference falls with dt at a fitted slope of about 1 for the leapfrog and at
        // least 1.8 for the velocity Verlet.
        for (model, steps, until, reference) in [
            (
                Model::Fluidanimate,
                vec![2.5e-4, 5e-4, 1e-3, 2e-3],
                0.016,
                1.5625e-5,
            ),
            (Model::Wcsph, vec![2.5e-5, 5e-5, 1e-4], 0.008, 3.125e-6),
        ] {
            let (leapfrog, verlet) = orders(model, 300, &steps, until, reference);
            println!(
                "{}: leapfrog {leapfrog:.2}, verlet {verlet:.2}",
                model.name()
            );
            assert!(
                (0.8..1.3).contains(&leapfrog),
                "{} {leapfrog}",
                model.name()
            );
            assert!(verlet >= 1.8, "{} {verlet}", model.name());
        }
    }

    #[test]
    fn a_fitted_slope_is_the_power_of_a_power_law() {
        let points: Vec<(f64, f64)> = [1e-4, 2e-4, 4e-4]
            .iter()
            .map(|&x| (x, 3.0 * x * x))
            .collect();
        assert!((fitted_slope(&points).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(fitted_slope(&points[..1]), None);
        assert_eq!(
            fitted_slope(&[(1e-3, 0.0), (2e-3, 1.0)]),
            None,
            "an exact run"
        );
    }

    #[test]
    fn a_reference_that_would_take_too_many_steps_is_refused_before_it_runs() {
        let particles = crate::lab::scene::corner_block(150.0, 300).unwrap();
        let start = Simulation::new(150.0, particles).unwrap();
        // A step of 1 ms sampled at 2 ms: the reference's 16 steps of 0.125 ms.
        let candidates = [Candidate {
            kernel: Kernel::NATIVE,
            time_step: TimeStep::Fixed(1e-3),
            skin: None,
            integrator: Integrator::Leapfrog,
        }];
        let refused = sweep(&start, Model::Course, &candidates, &[2e-3], None, 10.0);
        let error = refused.expect_err("16 steps, more than 10");
        assert_eq!(
            error,
            "the reference would take 1.600e1 steps of 0.000125 s to reach the last sample, \
             at 0.002 s, more than the 1e1 a run may take"
        );
        assert!(sweep(&start, Model::Course, &candidates, &[2e-3], None, 16.0).is_ok());
    }

    #[test]
    fn the_sweep_measures_methods_against_a_finer_reference_at_equal_times() {
        let particles = crate::lab::scene::corner_block(150.0, 300).unwrap();
        let start = Simulation::new(150.0, particles).unwrap();
        // The native kernel, whose run at the default step `default_run` finds.
        let simd = |time_step| Candidate {
            kernel: Kernel::NATIVE,
            time_step,
            skin: None,
            integrator: Integrator::Leapfrog,
        };
        let candidates = [
            simd(TimeStep::Fixed(1e-3)),
            simd(TimeStep::Fixed(5e-4)),
            Candidate {
                kernel: Kernel::Mixed,
                time_step: TimeStep::Fixed(1e-3),
                skin: None,
                integrator: Integrator::Leapfrog,
            },
            simd(TimeStep::Adaptive { courant: 0.3 }),
        ];
        let times = [2e-3, 4e-3];
        let sweep = sweep(&start, Model::Fluidanimate, &candidates, &times, None, 1e7).unwrap();
        let TimeStep::Fixed(reference_step) = sweep.reference.candidate.time_step else {
            panic!("a fixed reference step");
        };
        let shortest = sweep.runs.iter().map(|run| run.samples[1].shortest_step);
        assert_eq!(reference_step, shortest.fold(f64::INFINITY, f64::min) / 8.0);
        // The reference lands on 2 and 4 ms and on the adaptive run's two other times.
        let adaptive = &sweep.runs[3];
        let reference_times: Vec<f64> = sweep.reference.samples.iter().map(|s| s.time).collect();
        assert_eq!(reference_times.len(), 4, "{reference_times:?}");
        for sample in &adaptive.samples {
            assert!(sample.time > sample.requested, "{sample:?}");
            assert!(sample.time < sample.requested + 4.0 * sample.shortest_step);
            assert!(reference_times
                .iter()
                .any(|&t| (t - sample.time).abs() < 1e-15));
        }
        for (run, candidate) in sweep.runs.iter().zip(&candidates) {
            assert_eq!(run.candidate, *candidate);
            assert_eq!(run.failure, None);
            let requested: Vec<f64> = run.samples.iter().map(|s| s.requested).collect();
            assert_eq!(requested, times);
            assert!(run.heap_bytes > 300 * 13 * 8);
            for sample in &run.samples {
                assert!(sample.cost() > 0.0);
                assert!(sample.pairs.tested >= sample.pairs.within_h && sample.pairs.within_h > 0);
                assert!(sample.errors.unwrap().median_position > 0.0);
            }
        }
        // Fixed steps that divide the times land on them undisturbed.
        for run in &sweep.runs[..3] {
            for sample in &run.samples {
                assert!((sample.time - sample.requested).abs() < 1e-15, "{sample:?}");
            }
        }
        assert_eq!(sweep.runs[0].samples[1].steps, 4);
        assert_eq!(sweep.runs[1].samples[1].steps, 8);
        // Halving the step shrinks the error; the mixed kernel's error is the f64 one's.
        let error = |k: usize| sweep.runs[k].samples[1].errors.unwrap();
        assert!(error(1).median_position < 0.75 * error(0).median_position);
        assert!(
            (error(2).max_position - error(0).max_position).abs() < 1e-6 * error(0).max_position
        );
        // The fastest within a budget that every run meets is the cheapest; none meets 1e-30.
        let fastest = sweep.fastest_within(1.0, Metric::Max).unwrap();
        let cheapest = sweep
            .runs
            .iter()
            .map(Run::final_cost)
            .fold(f64::INFINITY, f64::min);
        assert_eq!(fastest.final_cost(), cheapest);
        assert_eq!(sweep.fastest_within(1e-30, Metric::Median), None);
        assert_eq!(
            sweep.default_run().unwrap().candidate,
            Candidate::default_for(Model::Fluidanimate)
        );
        let machine = Machine::this();
        let scene = SceneId {
            file_name: "corner.fld".into(),
            crc32: 0xc0ffee,
            particles: 300,
        };
        let text = sweep.csv(&scene, Model::Fluidanimate, &machine);
        assert_eq!(text.lines().count(), 4 + 4 * 2);
        for line in text.lines() {
            assert_eq!(
                line.split(',').count(),
                CSV_HEADER.split(',').count(),
                "{line}"
            );
        }
        assert!(text.starts_with("corner.fld,00c0ffee,300,fluidanimate,reference dt "));
        // The CSV reads back as the same sweep, with a column added after the others.
        let with_column: String = text
            .lines()
            .map(|line| format!("{line},node-1\n"))
            .collect();
        let read = Sweep::read(
            &format!("{CSV_HEADER},slurm_node\n{with_column}"),
            Model::Fluidanimate,
        );
        assert_eq!(read.unwrap(), sweep);
        // A failed run reads back with its failure.
        let mut failed = sweep.runs[3].clone();
        failed.samples.truncate(1);
        failed.failure = Some((0.0031, Failure::NonFinite(42)));
        let rows = failed.csv(&scene, Model::Fluidanimate, &machine);
        assert_eq!(
            read_runs(&format!("{CSV_HEADER}\n{rows}")).unwrap(),
            [failed.clone()]
        );
        // A CSV written before the scene's CRC-32 column reads alike.
        let older = |line: &str| {
            let mut cells: Vec<&str> = line.split(',').collect();
            cells.remove(1);
            cells.join(",") + "\n"
        };
        let older = older(CSV_HEADER) + &rows.lines().map(older).collect::<String>();
        assert_eq!(read_runs(&older).unwrap(), [failed]);
        assert_eq!(
            read_runs("scene,particles\n").unwrap_err(),
            "the accuracy CSV has no column model"
        );
    }

    #[test]
    fn observed_states_survive_their_encoding() {
        let particles = crate::lab::scene::corner_block(150.0, 64).unwrap();
        let simulation = Simulation::new(150.0, particles).unwrap();
        let mut observed = Observed::of(&simulation.with_fresh_densities());
        assert_eq!(Observed::decode(&observed.encode()).unwrap(), observed);
        observed.front = Some(0.0123);
        observed.positions[5] = DVec3::new(f64::NAN, -0.0, 1e300);
        let decoded = Observed::decode(&observed.encode()).unwrap();
        assert_eq!(decoded.front, Some(0.0123));
        assert!(decoded.positions[5].x.is_nan() && decoded.positions[5].y.is_sign_negative());
        assert_eq!(decoded.densities, observed.densities);
        let bytes = observed.encode();
        assert!(Observed::decode(&bytes[..bytes.len() - 1]).is_err());
        assert!(Observed::decode(b"FLUIDCK4").is_err());
    }

    #[test]
    fn runs_that_break_or_whose_step_collapses_stop_with_the_reason() {
        let mut particles = crate::lab::scene::corner_block(150.0, 30).unwrap();
        let start = Simulation::new(150.0, particles.clone()).unwrap();
        particles.hv[0][0] = 1e6; // an adaptive step of nanoseconds
        let fast = Simulation::new(150.0, particles.clone()).unwrap();
        particles.v[0][3] = f64::NAN;
        let broken = Simulation::new(150.0, particles).unwrap();
        let adaptive = Candidate {
            kernel: Kernel::Simd,
            time_step: TimeStep::Adaptive { courant: 0.3 },
            skin: None,
            integrator: Integrator::Leapfrog,
        };
        let to_1_ms = |start: &Simulation, candidate| {
            let sampling = Sampling::Unperturbed;
            run(
                start,
                Model::Fluidanimate,
                candidate,
                &[1e-3],
                sampling,
                |_| {},
            )
            .unwrap()
        };
        let collapsed = to_1_ms(&fast, adaptive);
        let (when, why) = collapsed.failure.unwrap();
        assert_eq!(why, Failure::StepCollapsed);
        assert!(when > 0.0 && when < 1e-3);
        assert!(collapsed.samples.is_empty());
        let failed = to_1_ms(&broken, Candidate::default_for(Model::Fluidanimate));
        let why = failed.failure.as_ref().unwrap().1;
        assert!(matches!(why, Failure::NonFinite(_)), "{why}");
        assert_eq!(failed.final_cost(), f64::INFINITY);
        let fine = to_1_ms(&start, adaptive);
        assert_eq!((fine.failure, fine.samples.len()), (None, 1));
    }
}
