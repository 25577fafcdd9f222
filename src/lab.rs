//! The workbench (`fluid-lab`): everything `fluid`'s fixed contract leaves out, on the same
//! library. Each subcommand is a function of its parsed arguments.

use crate::chart::{self, SweepTable};
use crate::cli;
use crate::energy::{EnergyMethod, Sources};
use crate::fld::{self, OutputFile};
use crate::machine::Machine;
use crate::method::{Kernel, Method, Model};
use crate::scene::{self, SceneKind};
use crate::sweep::{self, Plan, Sweep};
use clap::builder::RangedU64ValueParser;
use clap::{Args, Parser, Subcommand};
use std::error::Error;
use std::io::Write;
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
    /// Write a generated scene (dam break, drop, filled box, random cloud, corner block) as
    /// a .fld input.
    Scene(SceneArgs),
    /// Measure `fluid` over iteration counts (time, memory, energy) into a CSV.
    #[command(args_override_self = true)]
    Sweep(SweepArgs),
    /// Chart a sweep CSV: time, energy and power against iterations, as PNG and SVG.
    Chart(ChartArgs),
}

#[derive(Debug, Args)]
struct RunArgs {
    /// Input .fld file.
    input: PathBuf,
    /// Output .fld file for the final state.
    output: Option<PathBuf>,
    /// Time steps to run.
    #[arg(long, default_value_t = 1)]
    steps: u64,
    /// Physical model.
    #[arg(long, value_enum, default_value_t = Model::Course)]
    model: Model,
    /// Pair-loop implementation.
    #[arg(long, value_enum, default_value_t = Kernel::Simd)]
    kernel: Kernel,
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
            Command::Scene(args) => write_scene(args),
            Command::Sweep(args) => measure_sweep(args, stdout),
            Command::Chart(args) => draw_charts(args, stdout),
        }
    }
}

fn run(args: RunArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let name = args.input.display().to_string();
    let input = fld::map_input(&args.input)?;
    let scene = fld::parse(&input, &name)?;
    let output = args.output.as_deref().map(OutputFile::create).transpose()?;
    let method = Method {
        model: args.model,
        kernel: args.kernel,
    };
    let mut simulation = cli::place(scene.ppm, scene.particles, method, name)?;
    let started = Instant::now();
    simulation.run(args.steps);
    let seconds = started.elapsed().as_secs_f64();
    let particles = simulation.particles().len();
    let per_particle_step = seconds / (args.steps.max(1) as f64 * particles as f64);
    writeln!(
        stdout,
        "model={} kernel={} particles={particles} steps={} seconds={seconds:.6} \
         ns_per_particle_step={:.3}",
        args.model.name(),
        args.kernel.name(),
        args.steps,
        per_particle_step * 1e9
    )?;
    if let Some(output) = output {
        output.commit(&fld::encode(scene.ppm, simulation.particles()))?;
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
        for path in chart::render(&chart, &folder)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    Ok(())
}
