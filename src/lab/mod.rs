//! The workbench wing (`fluid-lab`): everything `fluid`'s fixed contract leaves out, on
//! the same library. Its concepts are modules here: generated [`scene`]s, per-state
//! [`diagnostics`], [`chaos`] (how far outputs scatter), [`accuracy`] against the
//! reference trajectory, [`stability`] maps, iteration [`sweep`]s with their [`energy`] and [`machine`], job arrays on [`slurm`], [`chart`]s, [`render`]ed
//! pictures, [`gauges`], [`still_water`] and [`validation`] against experiments, and a long
//! run's [`progress`]. The command line is [`Lab`], one module of `commands/` per subcommand.

pub mod accuracy;
pub mod chaos;
pub mod chart;
mod commands;
pub mod diagnostics;
pub mod energy;
pub mod gauges;
pub mod machine;
pub mod poiseuille;
pub mod progress;
pub mod render;
pub mod scene;
pub mod slurm;
pub mod stability;
pub mod still_water;
pub mod sweep;
pub mod validation;

use clap::{Parser, Subcommand};
use std::error::Error;
use std::io::Write;

/// A command line that cannot run as given (as clap's own errors, exit status 2).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl Error for UsageError {}

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
    /// Show no progress: no bar on a terminal, no progress lines in a log.
    #[arg(long, global = true)]
    quiet: bool,
    /// Seconds of wall time between two progress lines, where stderr is not a terminal
    /// (a CI or Slurm log) and a run shows its progress as lines.
    #[arg(long, global = true, value_name = "SECONDS", default_value_t = progress::DEFAULT_EVERY.as_secs_f64(), allow_negative_numbers = true, value_parser = parse_interval)]
    progress_every: f64,
}

/// Parses an interval of wall time in seconds: finite and not negative (0: a line after
/// every step).
fn parse_interval(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(seconds) if (0.0..=1e9).contains(&seconds) => Ok(seconds),
        _ => Err(format!("{text} is not a number of seconds from 0 to 1e9")),
    }
}

// The subcommands, each with its arguments (a module of `commands` each). A plain comment:
// clap would take a doc comment here as the command's `about`.
#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scene with a chosen model and kernel, timed; optionally write the final state.
    Run(commands::run::RunArgs),
    /// Export a state, or a run every k steps, as VTK (ParaView) or CSV files.
    Export(commands::export::ExportArgs),
    /// Render a state as a PNG, or a run as an animated GIF or PNG series.
    Render(commands::render::RenderArgs),
    /// Compare two .fld files: largest and RMS error per field, and the worst particle.
    Compare(commands::compare::CompareArgs),
    /// Copies of an input moved by one ulp, and a state judged against the ensemble of
    /// states runs on them give (is a change of the outputs no bigger than chaos?).
    Chaos(commands::chaos::ChaosArgs),
    /// Time per step against error, for one model and each kernel and method, relative to
    /// the reference trajectory: a CSV and two charts.
    Accuracy(commands::accuracy::AccuracyArgs),
    /// Run a scene over time steps and resolutions and map where each model fails.
    Stability(commands::stability::StabilityArgs),
    /// Write a generated scene (dam break, drop, filled box, random cloud, corner block) as
    /// a .fld input.
    Scene(commands::scene::SceneArgs),
    /// Measure `fluid` over iteration counts (time, memory, energy) into a CSV.
    #[command(args_override_self = true)]
    Sweep(commands::sweep::SweepArgs),
    /// Chart a sweep CSV: time, energy and power against iterations, as PNG and SVG.
    Chart(commands::chart::ChartArgs),
    /// Validate the models against what water does: the dam break of Martin and Moyce
    /// (1952) and Koshizuka and Oka (1996) (fronts, errors, charts), still water against
    /// hydrostatics (checks, a chart) or Poiseuille flow against its parabola and its
    /// start-up series (profiles, errors, orders); exits 1 if a run or check fails.
    Validate(commands::validate::ValidateArgs),
    /// Run a sweep, a stability map or an accuracy sweep as a Slurm job array, one point
    /// per task; merge its shards into the usual CSV and charts; resubmit the points that
    /// failed.
    Slurm(commands::slurm::SlurmArgs),
}

impl Lab {
    /// Runs the parsed command, writing its report to `stdout`.
    pub fn execute(self, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
        progress::configure(progress::Settings {
            quiet: self.quiet,
            every: std::time::Duration::from_secs_f64(self.progress_every),
        });
        match self.command {
            Command::Run(args) => commands::run::exec(args, stdout),
            Command::Export(args) => commands::export::exec(args, stdout),
            Command::Render(args) => commands::render::exec(args, stdout),
            Command::Compare(args) => commands::compare::exec(args, stdout),
            Command::Chaos(args) => commands::chaos::exec(args, stdout),
            Command::Accuracy(args) => commands::accuracy::exec(args, stdout),
            Command::Stability(args) => commands::stability::exec(args, stdout),
            Command::Scene(args) => commands::scene::exec(args),
            Command::Sweep(args) => commands::sweep::exec(args, stdout),
            Command::Chart(args) => commands::chart::exec(args, stdout),
            Command::Validate(args) => commands::validate::exec(args, stdout),
            Command::Slurm(args) => commands::slurm::exec(args, stdout),
        }
    }
}
