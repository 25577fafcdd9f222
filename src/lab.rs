//! The workbench (`fluid-lab`): everything `fluid`'s fixed contract leaves out, on the same
//! library. Each subcommand is a function of its parsed arguments.

use crate::accuracy;
use crate::chart::{self, LogChart, SweepTable};
use crate::cli;
use crate::diagnostics::{self, Diagnostics, Vitals};
use crate::energy::{EnergyMethod, Sources};
use crate::export::Snapshot;
use crate::fld::{self, OutputFile};
use crate::machine::Machine;
use crate::method::{Kernel, Method, Model};
use crate::params::TIME_STEP;
use crate::render::{self, Animation, Colouring};
use crate::scene::{self, SceneKind};
use crate::simulation::Simulation;
use crate::stability;
use crate::sweep::{self, Plan, Sweep};
use clap::builder::RangedU64ValueParser;
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use plotters::chart::SeriesLabelPosition;
use std::error::Error;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The workbench's command line.
#[derive(Debug, Parser)]
#[command(
    name = "fluid-lab",
    about = "Workbench for the fluid SPH simulator",
    version
)]
pub struct Lab {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene with a chosen model and kernel, timed; optionally write the final state.
    Run(RunArgs),
    /// Export a state, or a run every k steps, as VTK (ParaView) or CSV files.
    Export(ExportArgs),
    /// Render a state as a PNG, or a run as an animated GIF or PNG series.
    Render(RenderArgs),
    /// Compare two .fld files: largest and RMS error per field, and the worst particle.
    Compare(CompareArgs),
    /// Time per step against error, for each model and kernel, relative to the reference
    /// trajectory: a CSV and two charts.
    Accuracy(AccuracyArgs),
    /// Run a scene over time steps and resolutions and map where each model fails.
    Stability(StabilityArgs),
    /// Write a generated scene (dam break, drop, filled box, random cloud, corner block) as
    /// a .fld input.
    Scene(SceneArgs),
    /// Measure `fluid` over iteration counts (time, memory, energy) into a CSV.
    #[command(args_override_self = true)]
    Sweep(SweepArgs),
    /// Chart a sweep CSV: time, energy and power against iterations, as PNG and SVG.
    Chart(ChartArgs),
}

/// A simulation to run: input, steps, model and kernel.
#[derive(Debug, Args)]
struct SimulationArgs {
    /// Input .fld file.
    input: PathBuf,
    /// Time steps to run.
    #[arg(long, default_value_t = 1)]
    steps: u64,
    /// Physical model.
    #[arg(long, value_enum, default_value_t = Model::Course)]
    model: Model,
    /// Pair-loop implementation.
    #[arg(long, value_enum, default_value_t = Kernel::Simd)]
    kernel: Kernel,
    /// Time step in seconds.
    #[arg(long, default_value_t = TIME_STEP, value_parser = parse_time_step)]
    dt: f64,
}

#[derive(Debug, Args)]
struct RunArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Output .fld file for the final state.
    output: Option<PathBuf>,
    /// Write per-step diagnostics (speed, particles outside, energy, density error, pairs)
    /// to this CSV file.
    #[arg(long)]
    diagnostics: Option<PathBuf>,
    /// Diagnose every this many steps (and step 0 and the last).
    #[arg(long, default_value_t = 1, value_parser = RangedU64ValueParser::<u64>::new().range(1..))]
    every: u64,
}

#[derive(Debug, Args)]
struct ExportArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Folder for the files, named INPUT-STEM_STEP.vtk (or .csv).
    output_dir: PathBuf,
    /// Also export every this many steps (and step 0) [default: the final state only].
    #[arg(long, value_parser = RangedU64ValueParser::<u64>::new().range(1..))]
    every: Option<u64>,
    /// File format.
    #[arg(long, value_enum, default_value_t = ExportFormat::Vtk)]
    format: ExportFormat,
}

/// The format of exported states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ExportFormat {
    /// Legacy VTK polydata, which ParaView opens (a numbered series as a time series).
    Vtk,
    /// One row per particle.
    Csv,
}

#[derive(Debug, Args)]
struct RenderArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Output: .png for the final state (a numbered series with --every), .gif for an
    /// animation of the run.
    output: PathBuf,
    /// Draw every this many steps (and step 0) [default for .gif: steps / 50].
    #[arg(long, value_parser = RangedU64ValueParser::<u64>::new().range(1..))]
    every: Option<u64>,
    /// What the colours show.
    #[arg(long, value_enum, default_value_t = Colouring::Speed)]
    colour: Colouring,
    /// Colour range LOW,HIGH [default: each frame's own].
    #[arg(long, value_parser = parse_range)]
    range: Option<(f64, f64)>,
    /// Milliseconds per GIF frame.
    #[arg(long, default_value_t = 80)]
    delay_ms: u32,
}

#[derive(Debug, Args)]
struct SceneArgs {
    /// The scene.
    #[arg(value_enum)]
    kind: SceneKind,
    /// Output .fld file.
    output: PathBuf,
    /// Particles per metre: the lattice spacing is 1/ppm.
    #[arg(long, default_value_t = 400.0)]
    ppm: f32,
    /// Seed of the lattice jitter and of the random cloud.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Number of particles (random-cloud and corner-block only).
    #[arg(long)]
    particles: Option<usize>,
}

#[derive(Debug, Args)]
struct CompareArgs {
    /// The state measured.
    first: PathBuf,
    /// The state it is measured against.
    second: PathBuf,
}

#[derive(Debug, Args)]
struct AccuracyArgs {
    /// Input .fld file.
    input: PathBuf,
    /// Folder for accuracy.csv, accuracy-speed.{png,svg} and error-growth.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// Steps after which the accuracy-speed chart shows the error (the largest is the
    /// length of every run).
    #[arg(long, value_delimiter = ',', default_values_t = [5, 20, 100])]
    horizons: Vec<u64>,
    /// Models to measure.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Model::ALL)]
    models: Vec<Model>,
}

#[derive(Debug, Args)]
struct StabilityArgs {
    /// Folder for stability.csv and stability-map.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// The scene run.
    #[arg(long, value_enum, default_value_t = SceneKind::DamBreak)]
    scene: SceneKind,
    /// Seed of the scene.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Models to run.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Model::ALL)]
    models: Vec<Model>,
    /// Particles per metre of the scene.
    #[arg(long, value_delimiter = ',', default_values_t = [100.0, 150.0, 200.0, 300.0])]
    ppms: Vec<f64>,
    /// Time steps, as multiples of the course's 1e-3 s.
    #[arg(long, value_delimiter = ',', default_values_t = [0.25, 0.5, 1.0, 2.0, 4.0])]
    dt_factors: Vec<f64>,
    /// Simulated seconds each run must last to count as stable.
    #[arg(long, default_value_t = 0.5)]
    duration: f64,
}

#[derive(Debug, Args)]
struct SweepArgs {
    /// Input .fld files.
    #[arg(default_values = ["data/in/small.fld", "data/in/large.fld"])]
    inputs: Vec<PathBuf>,
    /// The CSV file to write (one row per run and per idle window).
    #[arg(long)]
    output: PathBuf,
    /// Iteration counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = sweep::DEFAULT_ITERATIONS)]
    iterations: Vec<u64>,
    /// Runs per point, and idle-baseline windows.
    #[arg(long, default_value_t = 5, value_parser = RangedU64ValueParser::<usize>::new().range(1..))]
    repeats: usize,
    /// Seconds of each idle-baseline window.
    #[arg(long, default_value_t = 1.0)]
    idle_seconds: f64,
    /// The program measured, run as `PROGRAM ITERATIONS INPUT /dev/null` [default: the
    /// `fluid` beside this binary].
    #[arg(long)]
    program: Option<PathBuf>,
    /// The perf program used for RAPL energy.
    #[arg(long, default_value = "perf")]
    perf: PathBuf,
}

#[derive(Debug, Args)]
struct ChartArgs {
    /// The CSV written by `fluid-lab sweep`.
    csv: PathBuf,
    /// Folder for time, energy and power .png and .svg [default: the CSV's folder].
    #[arg(long)]
    output_dir: Option<PathBuf>,
}

impl Lab {
    /// Runs the parsed command, writing its report to `stdout`.
    pub fn execute(self, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
        match self.command {
            Command::Run(args) => run(args, stdout),
            Command::Export(args) => export(args, stdout),
            Command::Render(args) => render(args, stdout),
            Command::Compare(args) => compare(args, stdout),
            Command::Accuracy(args) => accuracy(args, stdout),
            Command::Stability(args) => stability(args, stdout),
            Command::Scene(args) => write_scene(args),
            Command::Sweep(args) => measure_sweep(args, stdout),
            Command::Chart(args) => draw_charts(args, stdout),
        }
    }
}

/// An input placed for simulation.
struct Loaded {
    /// The input's file stem, for output names.
    stem: String,
    /// The input's name as given.
    name: String,
    ppm: f32,
    simulation: Simulation,
}

fn load(args: &SimulationArgs) -> Result<Loaded, Box<dyn Error>> {
    let name = args.input.display().to_string();
    let scene = fld::read(&args.input)?;
    let method = Method {
        model: args.model,
        kernel: args.kernel,
    };
    let stem = args.input.file_stem().unwrap_or_default();
    let mut simulation = cli::place(scene.ppm, scene.particles, method, name.clone())?;
    simulation.set_time_step(args.dt);
    Ok(Loaded {
        stem: stem.to_string_lossy().into_owned(),
        simulation,
        name,
        ppm: scene.ppm,
    })
}

/// A progress bar over `steps` on stderr, with steps per second, if stderr is a terminal;
/// hidden otherwise.
fn progress_bar(steps: u64) -> ProgressBar {
    if steps == 0 || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let style = ProgressStyle::with_template("{bar:30} {pos}/{len} steps  {per_sec}  eta {eta}")
        .expect("a valid template");
    ProgressBar::with_draw_target(Some(steps), ProgressDrawTarget::stderr()).with_style(style)
}

/// Runs `steps` steps, calling `visit` at step 0 and every `every` steps (if given), and
/// at the last step.
fn run_visiting(
    simulation: &mut Simulation,
    steps: u64,
    every: Option<u64>,
    mut visit: impl FnMut(&Simulation, u64) -> Result<(), Box<dyn Error>>,
) -> Result<(), Box<dyn Error>> {
    let progress = progress_bar(steps);
    for step in 0..=steps {
        if step > 0 {
            simulation.step();
            progress.inc(1);
        }
        if step == steps || every.is_some_and(|every| step % every == 0) {
            visit(simulation, step)?;
        }
    }
    progress.finish_and_clear();
    Ok(())
}

fn run(args: RunArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let steps = args.simulation.steps;
    let output = args.output.as_deref().map(OutputFile::create).transpose()?;
    let diagnostics_file = args
        .diagnostics
        .as_deref()
        .map(OutputFile::create)
        .transpose()?;
    let Loaded {
        ppm,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    let mut rows = String::from(diagnostics::CSV_HEADER);
    rows.push('\n');
    let mut diagnose = |simulation: &Simulation, step: u64| {
        let state = Diagnostics::of(simulation, step);
        rows.push_str(&state.csv_row());
        rows.push('\n');
    };
    if diagnostics_file.is_some() {
        diagnose(&simulation, 0);
    }
    let progress = progress_bar(steps);
    let mut seconds = 0.0;
    for step in 1..=steps {
        let started = Instant::now();
        simulation.step();
        seconds += started.elapsed().as_secs_f64();
        progress.inc(1);
        // A run that produced NaN or infinities fails here, naming the step, instead of
        // writing them out.
        if let Some(id) = Vitals::of(&simulation).non_finite {
            progress.finish_and_clear();
            return Err(
                format!("the run failed at step {step}: particle {id} is not finite").into(),
            );
        }
        if diagnostics_file.is_some() && (step % args.every == 0 || step == steps) {
            diagnose(&simulation, step);
        }
    }
    progress.finish_and_clear();
    let particles = simulation.particles().len();
    let per_particle_step = seconds / (steps.max(1) as f64 * particles as f64);
    writeln!(
        stdout,
        "model={} kernel={} particles={particles} steps={steps} seconds={seconds:.6} \
         ns_per_particle_step={:.3}",
        args.simulation.model.name(),
        args.simulation.kernel.name(),
        per_particle_step * 1e9
    )?;
    if let Some(file) = diagnostics_file {
        file.commit(rows.as_bytes())?;
    }
    if let Some(output) = output {
        output.commit(&fld::encode(ppm, simulation.particles()))?;
    }
    Ok(())
}

/// Parses a positive, finite time step.
fn parse_time_step(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(dt) if is_time_step(dt) => Ok(dt),
        _ => Err(format!("{text} is not a positive time step")),
    }
}

/// Whether `dt` can be a time step: finite and positive.
fn is_time_step(dt: f64) -> bool {
    dt.is_finite() && dt > 0.0
}

/// Parses `LOW,HIGH` into a non-empty range.
fn parse_range(text: &str) -> Result<(f64, f64), String> {
    let numbers = text
        .split_once(',')
        .and_then(|(low, high)| Some((low.trim().parse().ok()?, high.trim().parse().ok()?)));
    match numbers {
        Some((low, high)) if low < high => Ok((low, high)),
        Some(_) => Err(format!("{text} is empty")),
        None => Err(format!("{text} is not LOW,HIGH")),
    }
}

fn export(args: ExportArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let Loaded {
        stem,
        name,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    std::fs::create_dir_all(&args.output_dir)
        .map_err(|error| format!("cannot create {}: {error}", args.output_dir.display()))?;
    let steps = args.simulation.steps;
    run_visiting(&mut simulation, steps, args.every, |simulation, step| {
        let snapshot = Snapshot::of(simulation, step);
        let (text, extension) = match args.format {
            ExportFormat::Vtk => (
                snapshot.to_vtk(&format!("fluid: {name}, step {step}")),
                "vtk",
            ),
            ExportFormat::Csv => (snapshot.to_csv(), "csv"),
        };
        let path = args
            .output_dir
            .join(format!("{stem}_{step:06}.{extension}"));
        OutputFile::create(&path)?.commit(text.as_bytes())?;
        writeln!(stdout, "wrote {}", path.display())?;
        Ok(())
    })
}

fn render(args: RenderArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let Loaded {
        name,
        ppm,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    let steps = args.simulation.steps;
    let range = args.range;
    let style = render::Style {
        title: name.clone(),
        ppm: ppm.into(),
        colouring: args.colour,
        range,
    };
    let output = &args.output;
    match output.extension().and_then(|e| e.to_str()) {
        Some("gif") => {
            let every = args.every.unwrap_or((steps / 50).max(1));
            let mut animation = Animation::create(output, args.delay_ms)?;
            let mut frames = 0;
            run_visiting(&mut simulation, steps, Some(every), |simulation, step| {
                animation.push(&Snapshot::of(simulation, step), &style)?;
                frames += 1;
                Ok(())
            })?;
            drop(animation);
            writeln!(stdout, "wrote {} ({frames} frames)", output.display())?;
        }
        Some("png") => {
            run_visiting(&mut simulation, steps, args.every, |simulation, step| {
                let path = match args.every {
                    Some(_) => {
                        let stem = output.file_stem().unwrap_or_default().to_string_lossy();
                        output.with_file_name(format!("{stem}_{step:06}.png"))
                    }
                    None => output.clone(),
                };
                render::render_png(&Snapshot::of(simulation, step), &style, &path)?;
                writeln!(stdout, "wrote {}", path.display())?;
                Ok(())
            })?;
        }
        _ => {
            return Err(format!("{}: the output must end in .png or .gif", output.display()).into())
        }
    }
    Ok(())
}

fn write_scene(args: SceneArgs) -> Result<(), Box<dyn Error>> {
    let output = OutputFile::create(&args.output)?;
    let particles = scene::generate(args.kind, args.ppm.into(), args.seed, args.particles)?;
    output.commit(&fld::encode(args.ppm, &particles))?;
    Ok(())
}

fn measure_sweep(args: SweepArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let idle = Duration::try_from_secs_f64(args.idle_seconds)
        .map_err(|_| format!("--idle-seconds {} is not a duration", args.idle_seconds))?;
    let program = match args.program {
        Some(program) => program,
        None => {
            let beside = std::env::current_exe()?.with_file_name("fluid");
            if !beside.is_file() {
                return Err(format!(
                    "no fluid binary at {}: build it (cargo build --release --bins) or pass --program",
                    beside.display()
                )
                .into());
            }
            beside
        }
    };
    let output = OutputFile::create(&args.output)?;
    let sources = Sources {
        perf: args.perf,
        ..Sources::default()
    };
    let sweep = Sweep {
        plan: Plan {
            program,
            inputs: args.inputs,
            iterations: args.iterations,
            repeats: args.repeats,
            idle,
        },
        energy: EnergyMethod::detect(&sources),
        machine: Machine::this(),
    };
    let records = sweep.measure(&mut std::io::stderr().lock())?;
    output.commit(&sweep.csv(&records)?)?;
    writeln!(
        stdout,
        "wrote {} ({} rows)",
        args.output.display(),
        records.len()
    )?;
    Ok(())
}

fn draw_charts(args: ChartArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let text = std::fs::read_to_string(&args.csv)
        .map_err(|error| format!("cannot read {}: {error}", args.csv.display()))?;
    let table =
        SweepTable::parse(&text).map_err(|error| format!("{}: {error}", args.csv.display()))?;
    let folder = match args.output_dir {
        Some(folder) => folder,
        None => args.csv.parent().map(PathBuf::from).unwrap_or_default(),
    };
    for chart in table.charts() {
        for path in chart::render(&chart, &folder, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    Ok(())
}

fn compare(args: CompareArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let (first, second) = (fld::read(&args.first)?, fld::read(&args.second)?);
    let errors = accuracy::compare(&first.particles, &second.particles).map_err(|reason| {
        format!(
            "cannot compare {} with {}: {reason}",
            args.first.display(),
            args.second.display()
        )
    })?;
    if first.ppm != second.ppm {
        writeln!(stdout, "note: ppm {} against {}", first.ppm, second.ppm)?;
    }
    writeln!(stdout, "field max_error rms_error worst_particle")?;
    for (field, error) in errors {
        writeln!(
            stdout,
            "{field} {:.6e} {:.6e} {}",
            error.max, error.rms, error.worst
        )?;
    }
    Ok(())
}

fn accuracy(args: AccuracyArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let steps = args.horizons.iter().copied().max().unwrap_or(0);
    if steps == 0 {
        return Err("--horizons needs a step after 0".into());
    }
    std::fs::create_dir_all(&args.output_dir)
        .map_err(|error| format!("cannot create {}: {error}", args.output_dir.display()))?;
    let scene = fld::read(&args.input)?;
    let particles = scene.particles.len();
    let name = args.input.display().to_string();
    let start = cli::place(scene.ppm, scene.particles, Method::default(), name)?;
    let file_name = args.input.file_name().unwrap_or_default().to_string_lossy();
    let mut rows = format!("{}\n", accuracy::CSV_HEADER);
    let mut trajectories = Vec::new();
    for model in args.models {
        let runs = accuracy::sweep(&start, model, &Kernel::FAST, steps);
        rows.push_str(&accuracy::csv(&file_name, particles, &runs));
        trajectories.extend(runs);
    }
    let csv_path = args.output_dir.join("accuracy.csv");
    OutputFile::create(&csv_path)?.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    let machine = Machine::this();
    let label =
        |t: &accuracy::Trajectory| format!("{} {}", t.method.model.name(), t.method.kernel.name());
    let reference_times: Vec<String> = trajectories
        .iter()
        .filter(|t| t.method.kernel == Kernel::Reference)
        .map(|t| {
            format!(
                "{} {:.2} ms",
                t.method.model.name(),
                t.seconds_per_step * 1e3
            )
        })
        .collect();
    let footer = format!(
        "{file_name}, {particles} particles; {} ({} CPUs), commit {}; error: largest position distance \
         to the reference ({} per step)",
        machine.cpu_model,
        machine.cpus,
        machine.commit,
        reference_times.join(", ")
    );
    let fast = || {
        trajectories
            .iter()
            .filter(|t| t.method.kernel != Kernel::Reference)
    };
    let speed = LogChart {
        name: "accuracy-speed",
        title: format!("Error against time per step, {file_name}"),
        x_label: "time per step (ms)".into(),
        y_label: "position error (m)".into(),
        series: args
            .horizons
            .iter()
            .map(|&horizon| {
                let points = fast()
                    .map(|t| (t.seconds_per_step * 1e3, t.errors[horizon as usize - 1].max))
                    .collect();
                (format!("after {horizon} steps"), points)
            })
            .collect(),
        lines: false,
        legend: SeriesLabelPosition::UpperRight,
        notes: fast()
            .map(|t| {
                let worst = t.errors[steps as usize - 1].max;
                (t.seconds_per_step * 1e3, worst, format!("  {}", label(t)))
            })
            .collect(),
        footer: footer.clone(),
    };
    let growth = LogChart {
        name: "error-growth",
        title: format!("Error growth against the reference, {file_name}"),
        x_label: "step".into(),
        y_label: "position error (m)".into(),
        series: fast()
            .map(|t| {
                let points = t
                    .errors
                    .iter()
                    .enumerate()
                    .map(|(k, e)| ((k + 1) as f64, e.max));
                (label(t), points.collect())
            })
            .collect(),
        lines: true,
        legend: SeriesLabelPosition::UpperLeft,
        notes: Vec::new(),
        footer,
    };
    for chart in [speed, growth] {
        for path in chart::render(&chart, &args.output_dir, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    Ok(())
}

fn stability(args: StabilityArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    for &factor in &args.dt_factors {
        if !is_time_step(factor * TIME_STEP) {
            return Err(
                format!("--dt-factors: {factor} does not give a positive time step").into(),
            );
        }
    }
    std::fs::create_dir_all(&args.output_dir)
        .map_err(|error| format!("cannot create {}: {error}", args.output_dir.display()))?;
    let mut rows = format!("{}\n", stability::CSV_HEADER);
    let mut outcomes = Vec::new();
    for &model in &args.models {
        for &ppm in &args.ppms {
            for &factor in &args.dt_factors {
                let dt = factor * TIME_STEP;
                let outcome =
                    stability::watch(args.scene, args.seed, model, ppm, dt, args.duration)?;
                writeln!(stdout, "{}", outcome.summary())?;
                rows.push_str(&outcome.csv_row());
                rows.push('\n');
                outcomes.push(outcome);
            }
        }
    }
    let csv_path = args.output_dir.join("stability.csv");
    OutputFile::create(&csv_path)?.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    let machine = Machine::this();
    let footer = format!(
        "{} seed {}, {} s each; fails on: non-finite values, particles more than h outside the \
         box, energy above 1.5 x the first; commit {}",
        args.scene.name(),
        args.seed,
        args.duration,
        machine.commit
    );
    let map = stability::StabilityMap {
        outcomes: &outcomes,
        footer,
    };
    for path in chart::render(&map, &args.output_dir, stability::SIZE)? {
        writeln!(stdout, "wrote {}", path.display())?;
    }
    Ok(())
}
