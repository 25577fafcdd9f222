//! `fluid-lab stability`: a scene over time steps and resolutions, each run watched until
//! it fails; a CSV and the stability map.

use super::simulation_args::{is_time_step, parse_courants, Courants};
use crate::io::output::OutputFile;
use crate::lab::chart;
use crate::lab::machine::Machine;
use crate::lab::scene::SceneKind;
use crate::lab::stability;
use crate::sim::method::{Kernel, Method, Model};
use crate::sim::params::TIME_STEP;
use crate::sim::timestep::TimeStep;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `fluid-lab stability`.
#[derive(Debug, Args)]
pub struct StabilityArgs {
    /// Folder for stability.csv and stability-map.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// The scene run.
    #[arg(long, value_enum, default_value_t = SceneKind::DamBreak)]
    scene: SceneKind,
    /// Seed of the scene.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    seed: u64,
    /// Models to run.
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = Model::ALL)]
    models: Vec<Model>,
    /// Kernels to run each model with (their precision is part of the method).
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = [Kernel::NATIVE])]
    kernels: Vec<Kernel>,
    /// Particles per metre of the scene.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., default_values_t = [100.0, 150.0, 200.0, 300.0])]
    ppms: Vec<f64>,
    /// Time steps, as multiples of the course's 1e-3 s.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., default_values_t = [0.25, 0.5, 1.0, 2.0, 4.0])]
    dt_factors: Vec<f64>,
    /// Courant constants of adaptive time steps to run beside the fixed ones ("" for
    /// none).
    #[arg(long, allow_negative_numbers = true, default_value = "0.3", num_args = 1.., value_parser = parse_courants)]
    adaptive: Vec<Courants>,
    /// Simulated seconds each run must last to count as stable.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    duration: f64,
    /// Shortest adaptive step a run may take (s); a shorter one fails it as collapsed
    /// (the default, a hundredth of the course's step, keeps the map to minutes).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-5)]
    shortest_step: f64,
}

/// Watches every (model, ppm, time step) run and writes the CSV and the map.
pub fn exec(args: StabilityArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    for &factor in &args.dt_factors {
        if !is_time_step(factor * TIME_STEP) {
            return Err(
                format!("--dt-factors: {factor} does not give a positive time step").into(),
            );
        }
    }
    if !(args.duration.is_finite() && args.duration > 0.0) {
        return Err(format!(
            "--duration: {} is not a positive, finite time",
            args.duration
        )
        .into());
    }
    if !(args.shortest_step.is_finite() && args.shortest_step > 0.0) {
        return Err(format!(
            "--shortest-step: {} is not a positive step",
            args.shortest_step
        )
        .into());
    }
    let rules: Vec<TimeStep> = args
        .dt_factors
        .iter()
        .map(|factor| TimeStep::Fixed(factor * TIME_STEP))
        .chain(
            Courants::all(&args.adaptive)
                .into_iter()
                .map(|courant| TimeStep::Adaptive { courant }),
        )
        .collect();
    super::create_output_dir(&args.output_dir)?;
    // The CSV is opened before the runs, so an unwritable folder fails first.
    let csv_path = args.output_dir.join("stability.csv");
    let csv_file = OutputFile::create(&csv_path)?;
    let mut rows = format!("{}\n", stability::CSV_HEADER);
    let mut outcomes = Vec::new();
    for &model in &args.models {
        for &kernel in &args.kernels {
            let method = Method { model, kernel };
            for &ppm in &args.ppms {
                for &rule in &rules {
                    let outcome = stability::watch(
                        args.scene,
                        args.seed,
                        method,
                        ppm,
                        rule,
                        args.duration,
                        args.shortest_step,
                    )?;
                    writeln!(stdout, "{}", outcome.summary())?;
                    rows.push_str(&outcome.csv_row());
                    rows.push('\n');
                    outcomes.push(outcome);
                }
            }
        }
    }
    csv_file.commit(rows.as_bytes())?;
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
    for path in chart::render(&map, &args.output_dir, map.size())? {
        writeln!(stdout, "wrote {}", path.display())?;
    }
    Ok(())
}
