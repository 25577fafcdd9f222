//! `fluid-lab run`: a timed run of a scene with a chosen model, kernel and time step;
//! optionally per-step diagnostics and the final state.

use super::simulation_args::{load, progress_bar, Loaded, SimulationArgs};
use crate::io::fld::{self, OutputFile};
use crate::lab::diagnostics::{self, Diagnostics, Vitals};
use crate::sim::simulation::Simulation;
use clap::builder::RangedU64ValueParser;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// The arguments of `fluid-lab run`.
#[derive(Debug, Args)]
pub struct RunArgs {
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

/// Runs the scene, timed, and writes the timing line, the diagnostics and the final state.
pub fn exec(args: RunArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
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
    let simulated = simulation.time();
    let builds = simulation.skin().map_or(String::new(), |skin| {
        format!(" list_builds={}", skin.builds())
    });
    let per_simulated_second = if simulated > 0.0 {
        format!("{:.3}", seconds / simulated)
    } else {
        String::from("none")
    };
    writeln!(
        stdout,
        "model={} kernel={} particles={particles} steps={steps} seconds={seconds:.6} \
         ns_per_particle_step={:.3} simulated_s={simulated:.6} \
         seconds_per_simulated_s={per_simulated_second}{builds}",
        args.simulation.model.name(),
        args.simulation.kernel.name(),
        per_particle_step * 1e9,
    )?;
    if let Some(file) = diagnostics_file {
        file.commit(rows.as_bytes())?;
    }
    if let Some(output) = output {
        output.commit(&fld::encode(ppm, simulation.particles()))?;
    }
    Ok(())
}
