//! `fluid-lab validate dam-break`: every model against the dam-break experiment of Martin
//! and Moyce (1952), at several resolutions: the fronts as a CSV, the errors at each
//! experimental point as a CSV, and a chart of Z against T with the experiment's points.

use super::create_output_dir;
use super::simulation_args::{
    asked_time_step, failure, load, parse_courant, parse_particles_per_metre, parse_seconds,
    parse_time_step, steps_beyond_limit, Extent, Loaded, SimulationArgs, WaterArgs,
    MOST_STEPS_TO_GO,
};
use crate::io::case::CaseError;
use crate::io::gformat::{format_g, format_rate, format_shortest};
use crate::io::output::OutputFile;
use crate::lab::chart::{self, PointChart};
use crate::lab::diagnostics;
use crate::lab::machine::Machine;
use crate::lab::progress::{Goal, Progress};
use crate::lab::still_water::{self, Tank};
use crate::lab::validation::{self, Collapse, Comparison, DamBreak, EXPERIMENTS};
use crate::lab::UsageError;
use crate::sim::kernel::Kernel;
use crate::sim::method::Method;
use crate::sim::model::Model;
use crate::sim::params::{Domain, BOX_MAX, BOX_MIN, FLUID_DENSITY, GRAVITY};
use crate::sim::simulation::Simulation;
use crate::sim::timestep::TimeStep;
use clap::{Args, ValueEnum};
use plotters::prelude::SeriesLabelPosition;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;
use toml::Spanned;

/// The experiments a model can be validated against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Experiment {
    /// The collapse of a water column 2a high on a dry floor: the surge fronts of Martin
    /// and Moyce (1952), n^2 = 2, and of Koshizuka and Oka (1996).
    DamBreak,
    /// A tank at rest (--case, e.g. cases/still-water.toml, whose settings it runs with):
    /// the pressures at four depths against hydrostatics, the surface's flatness, the
    /// largest speed, the particles lost.
    StillWater,
    /// Water between two plates, periodic along the flow, driven by a body force (--case,
    /// e.g. cases/poiseuille.toml): the steady velocity profile against the parabola at
    /// each --across resolution, the order of convergence, and the start-up from rest
    /// against the series solution.
    Poiseuille,
}

/// The arguments of `fluid-lab validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// The experiment.
    #[arg(value_enum)]
    experiment: Experiment,
    /// Folder for dam-break.csv, dam-break-errors.csv and dam-break.{png,svg} (or
    /// still-water.csv, still-water-checks.csv and still-water.{png,svg}).
    #[arg(long)]
    output_dir: PathBuf,
    /// The case to validate: still-water, a tank of one box of fluid on the floor, run to
    /// its until_s; dam-break, a column of one box of fluid a wide and 2a high against the
    /// low-x wall, whose model, kernel, time step, resolution and seed are its own (those
    /// flags are refused beside it; the water model's settings as flags override its;
    /// --until-t or --until, and --every, stay).
    #[arg(long, value_name = "FILE")]
    case: Option<PathBuf>,
    /// Models to run [default: every model].
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1..)]
    models: Option<Vec<Model>>,
    /// Particles per metre of the column, each run of every model [default: 200,300].
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..,
          value_parser = parse_particles_per_metre)]
    ppms: Option<Vec<f64>>,
    /// The column's width in metres (its height is twice it): a is the width of the
    /// particles' columns within it (a multiple of the spacing). The box's 0.13 m length
    /// lets the front run to Z = 0.13 / a [default: 0.03].
    #[arg(long, allow_negative_numbers = true, value_parser = parse_width)]
    width: Option<f64>,
    /// Run until the experiment's dimensionless time T = t sqrt(2 g / a) reaches this (at
    /// most 1000) [default: 4].
    #[arg(long, value_name = "T", allow_negative_numbers = true, value_parser = super::number)]
    until_t: Option<f64>,
    /// Run to this physical time in seconds instead (as --until everywhere else; at most
    /// 60).
    #[arg(long, value_name = "SECONDS", conflicts_with = "until_t", allow_negative_numbers = true, value_parser = parse_seconds)]
    until: Option<f64>,
    /// Sample the front every this many steps [default: 5]
    #[arg(long, allow_negative_numbers = true, value_parser = super::whole::<u64>(1, i64::MAX as u64))]
    every: Option<u64>,
    /// Pair-loop implementation [default: the widest f64 lanes the build's CPU has]
    #[arg(long, value_enum)]
    kernel: Option<Kernel>,
    /// Fixed time step in seconds (default: each model's own rule, the course's 1 ms or
    /// the weakly compressible model's CFL step).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_time_step)]
    dt: Option<f64>,
    /// Adaptive time step with this Courant constant instead of a fixed one.
    #[arg(long, allow_negative_numbers = true, conflicts_with = "dt", value_parser = parse_courant)]
    adaptive: Option<f64>,
    /// Seed of the lattice jitter [default: 1]
    #[arg(long, allow_negative_numbers = true, value_parser = super::whole::<u64>(0, u64::MAX))]
    seed: Option<u64>,
    /// 2 for the dam break in the plane of the box's x-y section (the water model only),
    /// 3, or 2,3 for both side by side [default: 3]
    #[arg(long, value_delimiter = ',', num_args = 1.., allow_negative_numbers = true,
          value_parser = super::whole::<u8>(2, 3))]
    dimensions: Option<Vec<u8>>,
    /// Poiseuille: particles across the channel, each a run of the case [default:
    /// 20,40,80]
    #[arg(long, value_delimiter = ',', num_args = 1.., allow_negative_numbers = true,
          value_parser = super::whole::<usize>(4, 400))]
    across: Option<Vec<usize>>,
    /// The weakly compressible model's choices (its runs only).
    #[command(flatten)]
    water: WaterArgs,
}

impl ValidateArgs {
    /// The models to run: every model, or in 2-D alone the water model.
    fn models(&self) -> Vec<Model> {
        let every = match self.dimensions().as_slice() {
            [2] => vec![Model::Wcsph],
            _ => Model::ALL.to_vec(),
        };
        self.models.clone().unwrap_or(every)
    }

    /// The numbers of dimensions to run in, each once.
    fn dimensions(&self) -> Vec<u8> {
        self.dimensions.clone().unwrap_or(vec![3])
    }

    /// The runs' models and whether each is 2-D, in the order of --dimensions: in 2-D the
    /// water model's only.
    fn plan(&self) -> Vec<(Model, bool)> {
        let dimensions = self.dimensions();
        let planar = dimensions.iter().map(|&d| d == 2);
        planar
            .flat_map(|planar| self.models().into_iter().map(move |model| (model, planar)))
            .filter(|&(model, planar)| !planar || model == Model::Wcsph)
            .collect()
    }

    /// The dam break at `ppm` particles per metre, in 2-D if `planar`.
    fn dam(&self, ppm: f64, planar: bool) -> DamBreak {
        DamBreak {
            width: self.width(),
            ppm,
            seed: self.seed(),
            planar,
        }
    }

    /// The resolutions to run each model at.
    fn ppms(&self) -> Vec<f64> {
        self.ppms.clone().unwrap_or(vec![200.0, 300.0])
    }

    /// The column's width (m).
    fn width(&self) -> f64 {
        self.width.unwrap_or(0.03)
    }

    /// The end in the experiment's T.
    fn until_t(&self) -> f64 {
        self.until_t.unwrap_or(4.0)
    }

    /// How often the front is sampled (steps).
    fn every(&self) -> u64 {
        self.every.unwrap_or(5)
    }

    /// The kernel of the runs.
    fn kernel(&self) -> Kernel {
        self.kernel.unwrap_or(Kernel::NATIVE)
    }

    /// The seed of the columns' lattice jitter.
    fn seed(&self) -> u64 {
        self.seed.unwrap_or(1)
    }

    /// The flags that only a dam break reads that were given, in order, each with
    /// whether a dam-break case gives its value instead (its model, kernel, time step and
    /// scene; the run's length and sampling stay the flags').
    fn dam_break_flags(&self) -> impl Iterator<Item = (&'static str, bool)> {
        let flags = [
            ("--models", self.models.is_some(), true),
            ("--ppms", self.ppms.is_some(), true),
            ("--width", self.width.is_some(), true),
            ("--until-t", self.until_t.is_some(), false),
            ("--until", self.until.is_some(), false),
            ("--every", self.every.is_some(), false),
            ("--kernel", self.kernel.is_some(), true),
            ("--dt", self.dt.is_some(), true),
            ("--adaptive", self.adaptive.is_some(), true),
            ("--seed", self.seed.is_some(), true),
            ("--dimensions", self.dimensions.is_some(), true),
        ];
        flags
            .into_iter()
            .filter(|&(_, given, _)| given)
            .map(|(flag, _, from_case)| (flag, from_case))
    }

    /// The first of the flags that only a dam break reads, if given (still water runs
    /// its case's model, kernel, time step and scene).
    fn dam_break_flag(&self) -> Option<&'static str> {
        self.dam_break_flags().next().map(|(flag, _)| flag)
    }
}

/// The CSV columns of the fronts.
const FRONTS_HEADER: &str = "model,kernel,ppm,width_m,time_step,step,time_s,T,front_m,Z,\
                             mean_density_error,max_density_error,dimensions";
/// The CSV columns of the comparisons.
const ERRORS_HEADER: &str = "model,kernel,ppm,width_m,time_step,experiment,T,Z_experiment,\
                             Z_model,relative_error,dimensions";
/// The longest dam break in the experiment's T (the experiments end by T = 4; the
/// column has long settled by this).
const MOST_T: f64 = 1000.0;
/// The longest dam break in seconds (a 3 cm column's T = 1000 is 35 s).
const MOST_SECONDS: f64 = 60.0;

/// The experiment's points compared in the summary: T up to this.
const SUMMARY_T: f64 = 3.6;

/// The dam break's charts: its fronts, their cost, and each model's convergence.
const DAM_BREAK_CHARTS: [&str; 5] = [
    "dam-break",
    "dam-break-cost",
    "dam-break-convergence-course",
    "dam-break-convergence-fluidanimate",
    "dam-break-convergence-wcsph",
];

/// One model at one resolution, run.
struct Validated {
    model: Model,
    ppm: f64,
    /// Run in 2-D.
    planar: bool,
    /// The simulated time it reached (s).
    simulated: f64,
    /// Its particles.
    particles: usize,
    label: String,
    collapse: Collapse,
    comparisons: Vec<Comparison>,
    seconds: f64,
}

/// Runs every model at every resolution against the experiment and writes the CSVs, the
/// chart and a summary line per run.
pub fn exec(mut args: ValidateArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let case_flag = match args.experiment {
        Experiment::StillWater | Experiment::Poiseuille => args.dam_break_flag(),
        Experiment::DamBreak => None,
    };
    if let Some(flag) = case_flag {
        let name = args.experiment.to_possible_value().expect("a name");
        return Err(UsageError(format!(
            "{flag} is the dam break's: validate {} runs its case's model, kernel, \
             time step, scene and [run] until_s",
            name.get_name()
        ))
        .into());
    }
    if args.across.is_some() && args.experiment != Experiment::Poiseuille {
        return Err(UsageError("--across is the Poiseuille flow's".into()).into());
    }
    match (args.experiment, &args.case) {
        (Experiment::Poiseuille, Some(case)) => {
            let mut across = args.across.clone().unwrap_or(vec![20, 40, 80]);
            let given = across.len();
            across.sort_unstable();
            across.dedup();
            if across.len() < given {
                return Err(UsageError("--across names each resolution once".into()).into());
            }
            return poiseuille(case, &args.output_dir, &args.water, &across, stdout);
        }
        (Experiment::Poiseuille, None) => {
            return Err(UsageError(
                "validate poiseuille runs a case: give --case FILE (cases/poiseuille.toml)".into(),
            )
            .into());
        }
        (Experiment::StillWater, Some(case)) => {
            return still_water(case, &args.output_dir, &args.water, stdout);
        }
        (Experiment::StillWater, None) => {
            return Err(UsageError(
                "validate still-water runs a case: give --case FILE (cases/still-water.toml)"
                    .into(),
            )
            .into());
        }
        (Experiment::DamBreak, Some(case)) => {
            let case = case.clone();
            take_dam_break_case(&mut args, &case)?;
        }
        (Experiment::DamBreak, None) => {}
    }
    let until_t = args.until_t();
    if !(until_t > 0.0 && until_t <= MOST_T) {
        let t = format_g(until_t);
        let message = format!("--until-t {t} is not a T above 0, at most {MOST_T}");
        return Err(UsageError(message).into());
    }
    if let Some(end) = args.until.filter(|&end| end > MOST_SECONDS) {
        let end = format_g(end);
        let message =
            format!("--until {end} is more than the {MOST_SECONDS} s a dam break may run");
        return Err(UsageError(message).into());
    }
    let asked = asked_time_step(args.adaptive, args.dt);
    let models = args.models();
    // The water settings only a water run reads, and the column at each resolution:
    // usage errors, before anything is made.
    if args.water.any() && !models.contains(&Model::Wcsph) {
        let names: Vec<&str> = models.iter().map(|model| model.name()).collect();
        return Err(UsageError(format!(
            "--walls, --face, --artificial-viscosity, --laminar-viscosity, --smoothing, \
             --sound-speed and --density-diffusion are the weakly compressible model's; \
             the models run ({}) take none",
            names.join(", ")
        ))
        .into());
    }
    let dimensions = args.dimensions();
    if super::repeats(&dimensions) {
        return Err(UsageError("--dimensions names each number once".into()).into());
    }
    // A run named twice would run twice and count as two resolutions.
    for (flag, repeated) in [
        ("--models", super::repeats(&models)),
        ("--ppms", super::repeats(&args.ppms())),
    ] {
        if repeated {
            return Err(UsageError(format!("{flag} names each value once")).into());
        }
    }
    let only_planar = dimensions == [2];
    if let Some(other) = models
        .iter()
        .find(|&&model| model != Model::Wcsph && only_planar)
    {
        return Err(UsageError(format!(
            "--dimensions 2 runs the water model (wcsph), not {}",
            other.name()
        ))
        .into());
    }
    let plan = args.plan();
    for planar in dimensions.iter().map(|&d| d == 2) {
        for &ppm in &args.ppms() {
            args.dam(ppm, planar).particles().map_err(|why| {
                let (width, ppm) = (format_g(args.width()), format_g(ppm));
                UsageError(format!("--width {width} at {ppm} per m: {why}"))
            })?;
        }
    }
    // A fixed step that would take more steps than any run to a time may: refused before
    // anything is made.
    for &(model, planar) in &plan {
        for &ppm in &args.ppms() {
            let TimeStep::Fixed(dt) = asked.unwrap_or(model.default_time_step()) else {
                continue;
            };
            let unit = args.dam(ppm, planar).time_unit();
            let end = args.until.unwrap_or(until_t * unit);
            if let Some(steps) = steps_beyond_limit(end, dt) {
                return Err(UsageError(format!(
                    "a time step of {} s would take {steps:.3e} steps to the end ({} s) of \
                     {} at {ppm} per m, more than the {MOST_STEPS_TO_GO:.0e} a run may take",
                    format_g(dt),
                    format_g(end),
                    model.name()
                ))
                .into());
            }
        }
    }
    let _folder = create_output_dir(&args.output_dir)?;
    super::try_charts(&args.output_dir, &DAM_BREAK_CHARTS)?;
    let fronts_path = args.output_dir.join("dam-break.csv");
    let errors_path = args.output_dir.join("dam-break-errors.csv");
    let (fronts_file, errors_file) = (
        OutputFile::create(&fronts_path)?,
        OutputFile::create(&errors_path)?,
    );
    let mut fronts = format!("{FRONTS_HEADER}\n");
    let mut errors = format!("{ERRORS_HEADER}\n");
    let mut runs = Vec::new();
    for &(model, planar) in &plan {
        for &ppm in &args.ppms() {
            let dam = args.dam(ppm, planar);
            let method = Method {
                model,
                kernel: args.kernel(),
            };
            let (dynamics, settings) = match model {
                Model::Wcsph => (
                    args.water.dynamics(model)?,
                    args.water.settings()?.describe(),
                ),
                _ => (model.dynamics(), "its own constants".to_string()),
            };
            let mut simulation =
                Simulation::with_dynamics(ppm, dam.domain(), dam.particles()?, method, dynamics)
                    .map_err(|error| format!("--ppms {ppm}: {error}"))?;
            let time_step = asked.unwrap_or(model.default_time_step());
            simulation.set_time_step(time_step);
            let rule = rule_name(time_step);
            let started = Instant::now();
            // The end in the experiment's T: --until's seconds in this column's unit.
            let until = args.until.map_or(until_t, |end| end / dam.time_unit());
            let mut progress = Progress::towards(Goal::Until(until * dam.time_unit()))
                .labelled(format!("{} at {ppm} per m", model.name()));
            // An adaptive step that would take more steps than a run may fails it.
            let shortest = until * dam.time_unit() / MOST_STEPS_TO_GO;
            let collapse = validation::collapse(
                &mut simulation,
                &dam,
                until,
                args.every(),
                &mut progress,
                shortest,
            );
            progress.finish();
            let seconds = started.elapsed().as_secs_f64();
            let comparisons = validation::compare(&collapse, &dam);
            let cells = format!(
                "{},{},{ppm},{},{rule}",
                model.name(),
                args.kernel().name(),
                dam.column_width()
            );
            for sample in &collapse.samples {
                let numbers = [
                    sample.time,
                    sample.t,
                    sample.front,
                    sample.z,
                    sample.mean_density_error,
                    sample.max_density_error,
                ]
                .map(format_shortest);
                fronts += &format!(
                    "{cells},{},{},{}\n",
                    sample.step,
                    numbers.join(","),
                    dam.dimensions()
                );
            }
            for comparison in &comparisons {
                let optional = |value: Option<f64>| value.map_or(String::new(), format_shortest);
                errors += &format!(
                    "{cells},{},{},{},{},{},{}\n",
                    comparison.experiment,
                    format_shortest(comparison.t),
                    format_shortest(comparison.z_experiment),
                    optional(comparison.z_model),
                    optional(comparison.relative_error()),
                    dam.dimensions()
                );
            }
            let densest = |until: f64| {
                collapse
                    .samples
                    .iter()
                    .filter(|sample| sample.t <= until)
                    .map(|sample| sample.max_density_error)
                    .fold(0.0, f64::max)
            };
            // The summary's window: up to T = 3.6, or the run's end if sooner.
            let window = SUMMARY_T.min(until);
            let (densest_compared, densest) = (densest(window), densest(f64::INFINITY));
            let simulated = simulation.time();
            let per_simulated_second = match simulated > 0.0 {
                true => format_rate(seconds / simulated),
                false => "none".to_string(),
            };
            let agreement: String = EXPERIMENTS
                .iter()
                .map(|experiment| {
                    let key = experiment_key(experiment.name);
                    let errors = validation::errors(&comparisons, Some(experiment.name), SUMMARY_T);
                    let (worst, mean) = errors.map_or(("none".into(), "none".into()), |(w, m)| {
                        (format!("{w:.3}"), format!("{m:.3}"))
                    });
                    format!(" {key}_worst={worst} {key}_mean={mean}")
                })
                .collect();
            let failed = collapse.failure.map_or(String::new(), |(t, failure)| {
                format!(" failed_at_T={t:.3} ({failure})")
            });
            writeln!(
                stdout,
                "model={} ppm={ppm} dimensions={} particles={} T_le={window}{agreement} \
                 max_density_error_T_le_{window}={densest_compared:.3} \
                 max_density_error={densest:.3} seconds={seconds:.3} \
                 seconds_per_simulated_s={per_simulated_second}{failed} settings: {settings}",
                model.name(),
                dam.dimensions(),
                simulation.particles().len(),
                window = format_shortest(window),
            )?;
            let mut label = match dam.planar {
                true => format!("{} 2-D at {ppm} per m", model.name()),
                false => format!("{} at {ppm} per m", model.name()),
            };
            if let Some((t, _)) = collapse.failure {
                label += &format!(" (failed at T = {t:.2})");
            }
            runs.push(Validated {
                model,
                ppm,
                planar,
                simulated,
                particles: simulation.particles().len(),
                label,
                collapse,
                comparisons,
                seconds,
            });
        }
    }
    fronts_file.commit(fronts.as_bytes())?;
    errors_file.commit(errors.as_bytes())?;
    writeln!(stdout, "wrote {}", fronts_path.display())?;
    writeln!(stdout, "wrote {}", errors_path.display())?;
    let machine = Machine::this();
    let rule = asked.map_or("each model's own time step".to_string(), rule_name);
    let footer = format!(
        "column a = {} m, 2a high{}, {rule}, {} kernel; {}, commit {}; {:.0} CPU s in all{}",
        args.width(),
        match dimensions.as_slice() {
            [2] => " in 2-D",
            [3] => "",
            _ => " in 2-D and 3-D",
        },
        args.kernel().name(),
        machine.cpu_model,
        machine.commit,
        runs.iter().map(|run| run.seconds).sum::<f64>(),
        match models.contains(&Model::Wcsph) {
            true => format!("; wcsph: {}", args.water.settings()?.describe()),
            false => String::new(),
        }
    );
    let charts = [front_chart(&runs, &footer)]
        .into_iter()
        .chain(cost_chart(&runs, &footer))
        .chain(
            models
                .iter()
                .filter_map(|&model| convergence_chart(&runs, model, &footer)),
        );
    for chart in charts {
        for path in chart::render(&chart, &args.output_dir, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    // A validation is a test: its outputs are written, and a run that failed, or that
    // reached no experimental point to compare, fails it.
    let first_t = EXPERIMENTS
        .iter()
        .flat_map(|experiment| experiment.points.iter().map(|&(t, _)| t))
        .fold(f64::INFINITY, f64::min);
    let failed = runs.iter().filter_map(|run| {
        let dimensions = if run.planar { " 2-D" } else { "" };
        let name = format!("{}{dimensions} at {} per m", run.model.name(), run.ppm);
        if let Some((t, failure)) = run.collapse.failure.as_ref() {
            return Some(format!("{name} failed at T = {t:.3} ({failure})"));
        }
        let compared = run.comparisons.iter().any(|c| c.z_model.is_some());
        let reached = (run.collapse.samples.last()).is_some_and(|sample| sample.t >= first_t);
        (!compared).then(|| match reached {
            // Run far enough, its front never found: too few particles near the floor.
            true => format!(
                "{name} found no front to compare (fewer than {} particles within 2h of the \
                 floor at every sample: a column of {} particles is too small)",
                diagnostics::FRONT_PARTICLES,
                run.particles
            ),
            false => format!(
                "{name} compared no front with an experiment (the first point is at \
                 T = {first_t}: run to --until-t {first_t} or later)"
            ),
        })
    });
    verdict(String::new(), failed.collect(), runs.len(), "runs", "; ")
}

/// The error of `model`'s front at each experimental point with T up to [`SUMMARY_T`]
/// against particles per metre, a line per point, if it ran at more than one resolution
/// and reached a point: `dam-break-convergence-<model>`.
fn convergence_chart(runs: &[Validated], model: Model, footer: &str) -> Option<PointChart> {
    let runs: Vec<&Validated> = runs.iter().filter(|run| run.model == model).collect();
    let points = runs
        .first()?
        .comparisons
        .iter()
        .filter(|c| c.t <= SUMMARY_T);
    // A line per point and per dimensions (2-D and 3-D runs apart, each labelled when
    // both ran).
    let both = runs.iter().any(|run| run.planar) && runs.iter().any(|run| !run.planar);
    let kinds: &[bool] = if both {
        &[true, false]
    } else {
        &[runs[0].planar]
    };
    let lines = points.flat_map(|point| kinds.iter().map(move |&planar| (point, planar)));
    let series: Vec<(String, Vec<(f64, f64)>)> = lines
        .map(|(point, planar)| {
            let errors = runs
                .iter()
                .filter(|run| run.planar == planar)
                .filter_map(|run| {
                    let same = run
                        .comparisons
                        .iter()
                        .find(|c| c.experiment == point.experiment && c.t == point.t)?;
                    Some((run.ppm, 100.0 * same.relative_error()?))
                })
                .collect();
            let initials: String = point
                .experiment
                .split_whitespace()
                .filter_map(|word| word.chars().next().filter(char::is_ascii_uppercase))
                .collect();
            let dimensions = match (both, planar) {
                (false, _) => "",
                (true, true) => " 2-D",
                (true, false) => " 3-D",
            };
            (format!("{initials} T = {:.2}{dimensions}", point.t), errors)
        })
        .collect();
    let reached = series.iter().any(|(_, errors)| !errors.is_empty());
    let resolutions = series.iter().any(|(_, errors)| errors.len() > 1);
    (resolutions && reached).then(|| PointChart {
        name: match model {
            Model::Course => DAM_BREAK_CHARTS[2],
            Model::Fluidanimate => DAM_BREAK_CHARTS[3],
            Model::Wcsph => DAM_BREAK_CHARTS[4],
        },
        title: format!(
            "Dam break, {}: front error at each experimental point (T <= {SUMMARY_T})",
            model.name()
        ),
        x_label: "particles per metre".into(),
        x_log: true,
        y_label: "(Z_model - Z_experiment) / Z_experiment (%)".into(),
        y_log: false,
        series,
        measured: 0,
        lines: true,
        fronts: Vec::new(),
        notes: Vec::new(),
        legend: SeriesLabelPosition::UpperRight,
        footer: footer.to_string(),
    })
}

/// The mean front error against each experiment (T <= [`SUMMARY_T`], in %) against the
/// CPU seconds per simulated second, a line per model, dimensions and experiment through
/// its resolutions (each point marked with its particles per metre), if any run compared
/// a front: what accuracy costs, and what the third dimension adds to it.
/// `dam-break-cost`.
fn cost_chart(runs: &[Validated], footer: &str) -> Option<PointChart> {
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut notes = Vec::new();
    for run in runs {
        let cost = run.seconds / run.simulated;
        if !(cost.is_finite() && cost > 0.0) || run.collapse.failure.is_some() {
            continue;
        }
        for experiment in EXPERIMENTS {
            let Some((_, mean)) =
                validation::errors(&run.comparisons, Some(experiment.name), SUMMARY_T)
            else {
                continue;
            };
            let dimensions = if run.planar { "2-D" } else { "3-D" };
            let label = format!("{} {dimensions}, {}", run.model.name(), experiment.name);
            let point = (cost, 100.0 * mean);
            match series.iter_mut().find(|(name, _)| *name == label) {
                Some((_, points)) => points.push(point),
                None => series.push((label, vec![point])),
            }
            notes.push((point.0, point.1, format!("{}", run.ppm)));
        }
    }
    (!series.is_empty()).then(|| PointChart {
        name: DAM_BREAK_CHARTS[1],
        title: format!(
            "Dam break: mean front error (T <= {SUMMARY_T}) against cost, by resolution"
        ),
        x_label: "CPU seconds per simulated second".into(),
        x_log: true,
        y_label: "mean |Z_model - Z_experiment| / Z_experiment (%)".into(),
        y_log: false,
        series,
        measured: 0,
        lines: true,
        fronts: Vec::new(),
        notes,
        legend: SeriesLabelPosition::UpperRight,
        footer: footer.to_string(),
    })
}

/// An experiment's name as the summary's keys take it: its first author, in lower case.
fn experiment_key(name: &str) -> String {
    name.split_whitespace()
        .next()
        .unwrap_or_default()
        .to_lowercase()
}

/// A time-step rule as the CSVs name it.
fn rule_name(time_step: TimeStep) -> String {
    match time_step {
        TimeStep::Fixed(dt) => format!("fixed {dt} s"),
        TimeStep::Adaptive { courant } => format!("adaptive C={courant}"),
    }
}

/// Z against T: the experiment's points, and each run's front (a line) with its value at
/// each experimental T (points).
fn front_chart(runs: &[Validated], footer: &str) -> PointChart {
    let mut series: Vec<(String, Vec<(f64, f64)>)> = EXPERIMENTS
        .iter()
        .map(|experiment| (experiment.name.to_string(), experiment.points.to_vec()))
        .collect();
    let mut fronts = vec![Vec::new(); EXPERIMENTS.len()];
    for run in runs {
        let at_experiment = run
            .comparisons
            .iter()
            .filter(|comparison| comparison.experiment == EXPERIMENTS[0].name)
            .filter_map(|comparison| Some((comparison.t, comparison.z_model?)))
            .collect();
        series.push((run.label.clone(), at_experiment));
        fronts.push(
            run.collapse
                .samples
                .iter()
                .map(|sample| (sample.t, sample.z))
                .collect(),
        );
    }
    PointChart {
        name: DAM_BREAK_CHARTS[0],
        title: "Dam break: surge front against the experiments".into(),
        x_label: "T = t sqrt(2g/a)".into(),
        x_log: false,
        y_label: "Z = x / a".into(),
        y_log: false,
        series,
        measured: EXPERIMENTS.len(),
        lines: false,
        fronts,
        notes: Vec::new(),
        legend: SeriesLabelPosition::UpperLeft,
        footer: footer.to_string(),
    }
}

/// A vector's coordinates as a case writes them: "x, y, z".
fn join(vector: [f64; 3]) -> String {
    vector.map(|x| x.to_string()).join(", ")
}

/// Takes the dam break of the case at `path` in place of the flags': its one box of fluid,
/// the column (a wide and 2a high against the low-x wall, through the box's depth), gives
/// the width, its lattice the resolution and seed; its model, kernel and time step replace
/// the flags'. The weakly compressible model's settings given as flags override the
/// case's, as beside `run --case`. `--until-t` (or `--until`), `--every` and
/// `--output-dir` stay the command line's.
fn take_dam_break_case(args: &mut ValidateArgs, path: &Path) -> Result<(), Box<dyn Error>> {
    let mut simulation = SimulationArgs::of_case(path);
    simulation.water = args.water.clone();
    simulation.read_case(&mut None)?;
    let case = simulation.read.as_ref().expect("a case read");
    let ppm = *case.fluid.particles_per_m.get_ref();
    let planar = case.domain.is_planar();
    let course = match planar {
        true => Domain::COURSE.section(ppm),
        false => Domain::COURSE,
    };
    if let Some(periodic) = &case.domain.periodic {
        if case.domain.periodic_axes().contains(&true) {
            let message = "a dam-break validation runs between walls on every face: leave \
                           periodic out";
            return Err(simulation.at_key(periodic.span(), message.into()));
        }
    }
    if args.dimensions.is_some() {
        return Err(UsageError(
            "--dimensions comes from the case's [domain] dimensions with --case".into(),
        )
        .into());
    }
    // What the case gives is not also taken from a flag, and a flag is not let pass
    // unheeded (the eighth hostile pass: --ppms, --models and --seed were).
    let replaced = args.dam_break_flags().find(|&(_, from_case)| from_case);
    if let Some((flag, _)) = replaced {
        return Err(UsageError(format!(
            "{flag} comes from the case with --case (its model, kernel, time step and \
             scene): set it there"
        ))
        .into());
    }
    if case.domain.simulated() != course {
        // At the first key that differs from the course's.
        let domain = &case.domain;
        let course = [course.min, course.max, course.gravity].map(|v| v.to_array());
        let keys = [&domain.box_min_m, &domain.box_max_m, &domain.gravity_m_s2];
        let (key, _) = (keys.iter().zip(course))
            .find(|(key, course)| *key.get_ref() != *course)
            .expect("a key that differs");
        let message = format!(
            "a dam-break validation runs in the course's box, [{}] to [{}] m, under gravity \
             [{}] m/s^2 (leave [domain] out): its front is measured from that box's low-x \
             wall; run another tank with `fluid-lab run --case`",
            join(BOX_MIN.to_array()),
            join(BOX_MAX.to_array()),
            join(GRAVITY.to_array()),
        );
        return Err(simulation.at_key(key.span(), message));
    }
    // Its fluid is one box, no sphere: refused at the first fill past it.
    let fills = &case.fluid;
    let extra =
        (fills.boxes.get(1).map(Spanned::span)).or(fills.spheres.first().map(Spanned::span));
    let (Some(fill), None) = (fills.boxes.first(), extra.clone()) else {
        let message = "a dam-break case's fluid is one box, the column: no other box or sphere";
        return Err(match extra {
            Some(span) => simulation.at_key(span, message.into()),
            None => simulation.at_key(fills.particles_per_m.span(), message.into()),
        });
    };
    let (low, high) = (fill.get_ref().min_m, fill.get_ref().max_m);
    let dam = DamBreak {
        width: high[0] - low[0],
        ppm,
        seed: case.fluid.seed,
        planar,
    };
    let a = dam.column_width();
    let column = [
        (low[0], BOX_MIN.x),
        (low[1], BOX_MIN.y),
        (low[2], dam.domain().min.z),
        (high[0], BOX_MIN.x + a),
        (high[1], BOX_MIN.y + 2.0 * a),
        (high[2], dam.domain().max.z),
    ];
    if column.iter().any(|(x, y)| (x - y).abs() > 1e-9) {
        let message = format!(
            "a dam-break case's box of fluid is the column a wide and 2a high against the \
             low-x wall, through the box's depth (a = {a} m at {ppm} per metre: max_m = \
             [{}, {}, {}])",
            BOX_MIN.x + a,
            BOX_MIN.y + 2.0 * a,
            BOX_MAX.z
        );
        return Err(simulation.at_key(fill.span(), message));
    }
    args.models = Some(vec![simulation.model()]);
    args.ppms = Some(vec![ppm]);
    args.width = Some(dam.width);
    args.seed = Some(dam.seed);
    args.dimensions = Some(vec![dam.dimensions() as u8]);
    args.kernel = Some(simulation.kernel());
    args.dt = simulation.dt;
    args.adaptive = simulation.adaptive;
    args.water = simulation.water.clone();
    Ok(())
}

/// The largest L2 error of the steady profile at any resolution, relative to the peak
/// (the target at 40 particles across).
const POISEUILLE_TOLERANCE: f64 = 0.02;

/// Runs the Poiseuille case at `path` at each resolution of `across` (particles between
/// the plates) to its end, the weakly compressible model's settings in `water`
/// overriding the case's, and writes each profile, the errors and orders, and the chart
/// of the profiles over the parabola. Fails where a run's error passes
/// [`POISEUILLE_TOLERANCE`] or the finest run's passes the coarsest's (`across`
/// ascending, each once).
fn poiseuille(
    path: &Path,
    folder: &Path,
    water: &WaterArgs,
    across: &[usize],
    stdout: &mut impl Write,
) -> Result<(), Box<dyn Error>> {
    use crate::lab::poiseuille::{order, Channel, Profile, StartUp};
    let mut args = SimulationArgs::of_case(path);
    args.water = water.clone();
    args.read_case(&mut None)?;
    // None of its outputs may be the case: said before the runs, which come first.
    super::try_charts(folder, &["poiseuille", "poiseuille-startup"])?;
    for table in [
        "poiseuille.csv",
        "poiseuille-errors.csv",
        "poiseuille-startup.csv",
    ] {
        crate::io::output::refuse_kept(&folder.join(table))?;
    }
    let case = args.read.clone().expect("a case read");
    let mut channel =
        Channel::of_case(&case).map_err(|(span, message)| args.at_key(span, message))?;
    // The viscosity the runs take: a flag's over the case's (as the case's, above 0).
    if let Some(nu) = water.laminar_viscosity {
        let positive = nu > 0.0;
        if !positive {
            return Err(UsageError(format!(
                "--laminar-viscosity {}: a Poiseuille flow needs a viscosity above 0",
                format_g(nu)
            ))
            .into());
        }
        channel.viscosity = nu;
    }
    let Extent::Until(end) = args.extent(None)? else {
        let at = case.run.steps.as_ref().map_or(0..0, |steps| steps.span());
        return Err(args.at_key(at, "a Poiseuille case runs to [run] until_s".into()));
    };
    // Where the case's particles_per_m stands: a fault found there is the resolution's.
    let spacing_key = args.at_key(case.fluid.particles_per_m.span(), String::new());
    let spacing_at = spacing_key
        .downcast::<CaseError>()
        .ok()
        .and_then(|key| key.at);
    let mut runs = Vec::new();
    for &count in across {
        // The case at `count` particles across: its lattice spacing W / count.
        let ppm = count as f64 / channel.width;
        args.read = Some(case.at_particles_per_m(ppm));
        // A resolution the case's box cannot take is the flag's fault, said without the
        // place of the case's own particles_per_m (not the one that failed); any other
        // fault of the case (its gravity, a face) is at its key.
        let Loaded { mut simulation, .. } = load(&args).map_err(|error| {
            let across = |why: &dyn std::fmt::Display| -> Box<dyn Error> {
                UsageError(format!("--across {count} ({ppm} per metre): {why}")).into()
            };
            match error.downcast::<CaseError>() {
                Ok(fault) if fault.at != spacing_at => fault,
                Ok(fault) => across(&fault.message),
                Err(other) => across(&other),
            }
        })?;
        let started = Instant::now();
        let mut progress = Progress::towards(Goal::Until(end)).labelled(format!("{count} across"));
        let mut step = 0;
        // The start-up, sampled at the end of the first step at or past each time.
        let mut samples = startup_times(&channel, end).peekable();
        let mut startup = Vec::new();
        while !simulation.has_reached(end) {
            simulation.step_towards(end);
            step += 1;
            progress.show(step, simulation.time());
            if let Some(failure) = failure(&simulation, Extent::Until(end), step) {
                progress.finish();
                return Err(format!("--across {count}: {failure}").into());
            }
            if samples.next_if(|&t| simulation.has_reached(t)).is_some() {
                let (particles, t) = (simulation.particles(), simulation.time());
                startup.push(StartUp::of(&channel, particles, t, 1.0 / ppm));
            }
        }
        progress.finish();
        let seconds = started.elapsed().as_secs_f64();
        let profile = Profile::of(&channel, simulation.particles(), count);
        runs.push(ChannelRun {
            across: count,
            particles: simulation.particles().len(),
            seconds,
            profile,
            startup,
        });
    }
    let _folder = create_output_dir(folder)?;
    let profiles_path = folder.join("poiseuille.csv");
    let errors_path = folder.join("poiseuille-errors.csv");
    let startup_path = folder.join("poiseuille-startup.csv");
    let (profiles_file, errors_file, startup_file) = (
        OutputFile::create(&profiles_path)?,
        OutputFile::create(&errors_path)?,
        OutputFile::create(&startup_path)?,
    );
    let mut profiles = "across,y_m,u_m_s,u_analytic_m_s\n".to_string();
    let mut errors = "across,particles,l2_error,order,cpu_s\n".to_string();
    let mut startups = "across,t_s,l2_error,centre_u_m_s,centre_u_series_m_s\n".to_string();
    for (index, run) in runs.iter().enumerate() {
        let ChannelRun {
            across: count,
            particles,
            seconds,
            profile,
            startup,
        } = run;
        for &(y, u) in &profile.rows {
            let numbers = [y, u, channel.velocity(y)].map(format_shortest);
            profiles += &format!("{count},{}\n", numbers.join(","));
        }
        let previous = index
            .checked_sub(1)
            .map(|k| (runs[k].profile.error, runs[k].across));
        let order = previous.map(|coarse| order(coarse, (profile.error, *count)));
        let shown = order.map_or(String::new(), format_shortest);
        errors += &format!(
            "{count},{particles},{},{shown},{}\n",
            format_shortest(profile.error),
            format_shortest(*seconds)
        );
        writeln!(
            stdout,
            "across={count} particles={particles} l2_error={:.4} order={} seconds={seconds:.3}",
            profile.error,
            order.map_or("none".to_string(), |order| format!("{order:.2}")),
        )?;
        for sample in startup {
            let numbers = [
                sample.time,
                sample.error,
                sample.centre,
                sample.centre_series,
            ];
            let numbers = numbers.map(format_shortest).join(",");
            startups += &format!("{count},{numbers}\n");
        }
        match worst_startup(startup) {
            Some(worst) => writeln!(
                stdout,
                "startup across={count} worst_l2_error={:.4} at_t={:.3}",
                worst.error, worst.time
            )?,
            // Nothing to check: said, not passed over.
            None => writeln!(
                stdout,
                "startup across={count} none: the run ends before the first sample at {:.4} s \
                 (a tenth of W^2 / (pi^2 nu))",
                0.1 * channel.time_constant()
            )?,
        }
    }
    let machine = Machine::this();
    let footer = format!(
        "{}: W = {} m, F = {} m/s^2, nu = {} m^2/s, peak {:.4} m/s, to {end} s; {}, commit {}",
        path.display(),
        channel.width,
        channel.force,
        channel.viscosity,
        channel.peak(),
        machine.cpu_model,
        machine.commit
    );
    let parabola: Vec<(f64, f64)> = (0..=40)
        .map(|k| {
            let y = channel.low + k as f64 / 40.0 * channel.width;
            (
                (y - channel.low) / channel.width,
                channel.velocity(y) / channel.peak(),
            )
        })
        .collect();
    let series = std::iter::once(("parabola".to_string(), parabola)).chain(runs.iter().map(
        |ChannelRun {
             across: count,
             profile,
             ..
         }| {
            let points = profile
                .rows
                .iter()
                .map(|&(y, u)| ((y - channel.low) / channel.width, u / channel.peak()));
            (format!("{count} across"), points.collect())
        },
    ));
    let chart = PointChart {
        name: "poiseuille",
        title: "Poiseuille flow: the steady profile against the parabola".into(),
        x_label: "y / W".into(),
        x_log: false,
        y_label: "u / u_peak".into(),
        y_log: false,
        series: series.collect(),
        measured: 1,
        lines: false,
        fronts: Vec::new(),
        notes: Vec::new(),
        legend: SeriesLabelPosition::LowerRight,
        footer,
    };
    let startup_chart = startup_chart(&channel, &runs, &chart.footer);
    // The charts first: a full disk leaves no CSV.
    let mut written = chart::render(&chart, folder, chart::SIZE)?.to_vec();
    written.extend(chart::render(&startup_chart, folder, chart::SIZE)?);
    profiles_file.commit(profiles.as_bytes())?;
    errors_file.commit(errors.as_bytes())?;
    startup_file.commit(startups.as_bytes())?;
    for written in written
        .iter()
        .chain([&profiles_path, &errors_path, &startup_path])
    {
        writeln!(stdout, "wrote {}", written.display())?;
    }
    // A validation is a test: every run's error within the tolerance, and no larger at
    // the finest resolution than at the coarsest.
    let mut failed = Vec::new();
    let mut checks = 0;
    for ChannelRun {
        across: count,
        profile,
        startup,
        ..
    } in &runs
    {
        checks += 1;
        // A NaN error fails.
        let within = profile.error <= POISEUILLE_TOLERANCE;
        if !within {
            failed.push(format!(
                "the error at {count} across, {:.4}, is past {POISEUILLE_TOLERANCE}",
                profile.error
            ));
        }
        // The start-up as close to the series at every sampled time (a run too short
        // to sample has none to check).
        if let Some(worst) = worst_startup(startup) {
            checks += 1;
            let within = worst.error <= POISEUILLE_TOLERANCE;
            if !within {
                failed.push(format!(
                    "the start-up's error at {count} across, {:.4} at {:.3} s, is past \
                     {POISEUILLE_TOLERANCE}",
                    worst.error, worst.time
                ));
            }
        }
    }
    if let (Some(coarsest), Some(finest)) = (runs.first(), runs.last()) {
        if runs.len() > 1 {
            checks += 1;
            let converging = finest.profile.error <= coarsest.profile.error;
            if !converging {
                failed.push(format!(
                    "the error grows with resolution ({:.4} at {} across, {:.4} at {})",
                    coarsest.profile.error, coarsest.across, finest.profile.error, finest.across
                ));
            }
        }
    }
    let subject = format!("{}: ", path.display());
    verdict(subject, failed, checks, "checks", ", ")
}

/// One resolution of the Poiseuille validation: its particles across, its particle count,
/// its CPU seconds, its steady profile and its start-up.
struct ChannelRun {
    across: usize,
    particles: usize,
    seconds: f64,
    profile: crate::lab::poiseuille::Profile,
    startup: Vec<crate::lab::poiseuille::StartUp>,
}

/// The times the Poiseuille start-up is sampled at: every tenth of the channel's time
/// constant, to three of them (where the flow is within 5% of steady), up to `end`.
fn startup_times(channel: &crate::lab::poiseuille::Channel, end: f64) -> impl Iterator<Item = f64> {
    let tau = channel.time_constant();
    (1..=30)
        .map(move |k| k as f64 * 0.1 * tau)
        .filter(move |&t| t <= end)
}

/// The sample of `startup` furthest from the series (a NaN error the furthest).
fn worst_startup(
    startup: &[crate::lab::poiseuille::StartUp],
) -> Option<crate::lab::poiseuille::StartUp> {
    startup
        .iter()
        .copied()
        .max_by(|a, b| match (a.error.is_nan(), b.error.is_nan()) {
            (false, false) => a.error.total_cmp(&b.error),
            (nan_a, nan_b) => nan_a.cmp(&nan_b),
        })
}

/// The chart of the start-up: mid-channel velocity over the peak against time over the
/// time constant, the series and each resolution's samples.
fn startup_chart(
    channel: &crate::lab::poiseuille::Channel,
    runs: &[ChannelRun],
    footer: &str,
) -> PointChart {
    let (tau, peak) = (channel.time_constant(), channel.peak());
    let middle = channel.low + 0.5 * channel.width;
    let series_line: Vec<(f64, f64)> = (0..=60)
        .map(|k| {
            let t = k as f64 * 0.05 * tau;
            (t / tau, channel.velocity_at(middle, t) / peak)
        })
        .collect();
    let samples = runs.iter().map(|run| {
        let points = run
            .startup
            .iter()
            .map(|sample| (sample.time / tau, sample.centre / peak));
        (format!("{} across", run.across), points.collect())
    });
    PointChart {
        name: "poiseuille-startup",
        title: "Poiseuille flow: the start-up at mid-channel against the series".into(),
        x_label: "t nu pi^2 / W^2".into(),
        x_log: false,
        y_label: "u(W/2) / u_peak".into(),
        y_log: false,
        series: std::iter::once(("series (Morris et al. 1997)".to_string(), series_line))
            .chain(samples)
            .collect(),
        measured: 1,
        lines: false,
        fronts: Vec::new(),
        notes: Vec::new(),
        legend: SeriesLabelPosition::LowerRight,
        footer: footer.to_string(),
    }
}

/// Runs the still-water case at `path` to its end (the weakly compressible model's
/// settings given in `water` overriding the case's), reading its tank's gauges, and writes
/// the readings, the checks and the chart of each pressure over its hydrostatic value.
fn still_water(
    path: &Path,
    folder: &Path,
    water: &WaterArgs,
    stdout: &mut impl Write,
) -> Result<(), Box<dyn Error>> {
    let mut args = SimulationArgs::of_case(path);
    args.water = water.clone();
    args.read_case(&mut None)?;
    let case = args.read.as_ref().expect("a case read");
    let tank = Tank::of_case(case).map_err(|(span, message)| args.at_key(span, message))?;
    let Extent::Until(end) = args.extent(None)? else {
        let message = "a still-water case runs to [run] until_s, not a count of steps";
        return Err(match &case.run.steps {
            Some(steps) => args.at_key(steps.span(), message.into()),
            // Where a missing table is reported, as toml reports a missing key.
            None => Box::new(CaseError {
                file: path.display().to_string(),
                at: Some((1, 1)),
                message: "missing table [run]: a still-water case runs to its until_s".into(),
            }),
        });
    };
    // The folder once the scene is made: a case refused leaves none behind.
    let Loaded { mut simulation, .. } = load(&args)?;
    let shortest = tank.shortest_run(-simulation.params().domain.gravity.y);
    if let Some(until) = case.run.until_s.as_ref().filter(|_| end < shortest) {
        let message = format!(
            "a still-water run lasts at least the {} s its water takes to fall its depth \
             (sqrt(2 H / g)): a shorter one reads back the hydrostatic start",
            format_g(shortest)
        );
        return Err(args.at_key(until.span(), message));
    }
    let _folder = create_output_dir(folder)?;
    super::try_charts(folder, &["still-water"])?;
    let readings_path = folder.join("still-water.csv");
    let checks_path = folder.join("still-water-checks.csv");
    let (readings_file, checks_file) = (
        OutputFile::create(&readings_path)?,
        OutputFile::create(&checks_path)?,
    );
    let particles = simulation.particles().len();
    let mut table = tank.gauges();
    let interval = end / 200.0;
    let started = Instant::now();
    let mut progress = Progress::towards(Goal::Until(end));
    let mut step = 0;
    while !simulation.has_reached(end) {
        table.read_due(&simulation, interval);
        simulation.step_towards(end);
        step += 1;
        progress.show(step, simulation.time());
        if let Some(failure) = failure(&simulation, Extent::Until(end), step) {
            progress.finish();
            return Err(failure.into());
        }
    }
    progress.finish();
    table.read(&simulation);
    let seconds = started.elapsed().as_secs_f64();
    let checks = still_water::checks(&tank, &table, &simulation, particles);
    readings_file.commit(table.csv().as_bytes())?;
    checks_file.commit(still_water::checks_csv(&checks).as_bytes())?;
    for check in &checks {
        writeln!(
            stdout,
            "{}: {:.6} {} (expected {:.6}), deviation {:.4} within {:.4}: {}",
            check.name,
            check.measured,
            check.unit,
            check.expected,
            check.deviation,
            check.limit,
            if check.passed() { "pass" } else { "FAIL" }
        )?;
    }
    let machine = Machine::this();
    let footer = format!(
        "{}: {} on {particles} particles, {} kernel, H = {} m, {:.0} CPU s; {}, commit {}",
        path.display(),
        args.model().name(),
        args.kernel().name(),
        tank.depth(),
        seconds,
        machine.cpu_model,
        machine.commit
    );
    let pressure_columns = still_water::pressure_columns(&table);
    let series = still_water::DEPTHS
        .iter()
        .enumerate()
        .map(|(index, &(name, fraction))| {
            let g = -simulation.params().domain.gravity.y;
            let expected = tank.gauge_depth(fraction) * FLUID_DENSITY * g;
            let points = table.rows().iter().filter_map(|(time, values)| {
                values[pressure_columns[index]].map(|pressure| (*time, pressure / expected))
            });
            (name.replace('_', " "), points.collect())
        });
    let chart = PointChart::over_time(
        "still-water",
        "Still water: pressure at each depth over rho0 g d".into(),
        "pressure / (rho0 g d)",
        series.collect(),
        SeriesLabelPosition::LowerRight,
        &footer,
    );
    for written in chart::render(&chart, folder, (900, 560))?
        .iter()
        .chain([&readings_path, &checks_path])
    {
        writeln!(stdout, "wrote {}", written.display())?;
    }
    // A validation is a test: its outputs are written, and a failed check fails it.
    let failed = checks
        .iter()
        .filter(|check| !check.passed())
        .map(|check| check.name.clone());
    let subject = format!("{}: ", path.display());
    verdict(subject, failed.collect(), checks.len(), "checks", ", ")
}

/// A validation's verdict: success if nothing of the `total` `things` (runs or checks)
/// `failed`, else an error naming them (after `subject`), joined by `separator`.
fn verdict(
    subject: String,
    failed: Vec<String>,
    total: usize,
    things: &str,
    separator: &str,
) -> Result<(), Box<dyn Error>> {
    match failed.is_empty() {
        true => Ok(()),
        false => Err(format!(
            "{subject}{} of {total} {things} failed: {}",
            failed.len(),
            failed.join(separator)
        )
        .into()),
    }
}

/// Parses a column's width: a finite number of metres > 0.
fn parse_width(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(width) if width.is_finite() && width > 0.0 => Ok(width),
        _ => Err(format!("{text} is not a width in metres > 0")),
    }
}
