//! The workbench (`fluid-lab`): everything `fluid`'s fixed contract leaves out, on the same
//! library. Each subcommand is a function of its parsed arguments.

use crate::cli;
use crate::fld::{self, OutputFile};
use crate::method::{Kernel, Method, Model};
use crate::scene;
use clap::{Args, Parser, Subcommand};
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

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
    /// Write a generated scene (a block of fluid in the box's corner) as a .fld input.
    Scene(SceneArgs),
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
    /// Output .fld file.
    output: PathBuf,
    /// Particles per metre (also the lattice density).
    #[arg(long, default_value_t = 400.0)]
    ppm: f32,
    /// Number of particles, as a cube-like block in the low corner.
    #[arg(long)]
    particles: usize,
}

impl Lab {
    /// Runs the parsed command, writing its report to `stdout`.
    pub fn execute(self, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
        match self.command {
            Command::Run(args) => run(args, stdout),
            Command::Scene(args) => write_scene(args),
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
    let particles = scene::corner_block(args.ppm.into(), args.particles);
    output.commit(&fld::encode(args.ppm, &particles))?;
    Ok(())
}
