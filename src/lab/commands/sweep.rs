//! `fluid-lab sweep`: `fluid` measured over iteration counts (time, memory, energy) into a
//! CSV.

use crate::io::fld::OutputFile;
use crate::lab::energy::{EnergyMethod, Sources};
use crate::lab::machine::Machine;
use crate::lab::sweep::{self, Plan, Sweep};
use clap::builder::RangedU64ValueParser;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

/// The arguments of `fluid-lab sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
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

/// Measures every point of the sweep and writes the CSV.
pub fn exec(args: SweepArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
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
