//! `fluid-lab sweep`: `fluid` measured over iteration counts (time, memory, energy) into a
//! CSV.

use super::same_file;
use crate::io::input::read_regular_text;
use crate::io::output::OutputFile;
use crate::lab::energy::{EnergyMethod, Sources};
use crate::lab::machine::Machine;
use crate::lab::slurm;
use crate::lab::sweep::{self, Plan, Sweep};
use crate::lab::UsageError;
use clap::Args;
use std::collections::HashSet;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};
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
    /// Iteration counts (at most 2^63-1, as `fluid` takes), comma- or space-separated.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..,
          default_values_t = sweep::DEFAULT_ITERATIONS,
          value_parser = super::whole::<u64>(0, i64::MAX as u64))]
    iterations: Vec<u64>,
    /// Runs per point, and idle-baseline windows.
    #[arg(long, allow_negative_numbers = true, default_value_t = 5, value_parser = super::whole::<usize>(1, i64::MAX as u64))]
    repeats: usize,
    /// Seconds of each idle-baseline window.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = parse_idle_seconds)]
    idle_seconds: f64,
    /// The program measured, run as `PROGRAM ITERATIONS INPUT /dev/null` [default: the
    /// `fluid` beside this binary].
    #[arg(long)]
    program: Option<PathBuf>,
    /// Go on from the rows already in --output (from a sweep that failed or was
    /// stopped): measure only the runs it lacks, and keep its rows.
    #[arg(long)]
    resume: bool,
    /// The perf program used for RAPL energy.
    #[arg(long, default_value = "perf")]
    perf: PathBuf,
}

/// Parses the seconds of an idle window: finite, 0 or more, at most a day.
fn parse_idle_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(seconds) if (0.0..=86_400.0).contains(&seconds) => Ok(seconds),
        _ => Err(format!("{text} is not a duration from 0 to 86400 seconds")),
    }
}

impl SweepArgs {
    /// The sweep these arguments ask for: the program checked, energy detected here.
    fn sweep(&self) -> Result<Sweep, Box<dyn Error>> {
        let idle = Duration::from_secs_f64(self.idle_seconds);
        let program = match &self.program {
            Some(program) => program_path(program.clone())?,
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
        if let Some(input) = self
            .inputs
            .iter()
            .find(|input| same_file(input, &self.output))
        {
            return Err(UsageError(format!(
                "--output {} is the input {}",
                self.output.display(),
                input.display()
            ))
            .into());
        }
        // One file under two names (a link) would be measured as two inputs.
        for (index, input) in self.inputs.iter().enumerate() {
            if let Some(other) = self.inputs[..index]
                .iter()
                .find(|other| same_file(other, input))
            {
                return Err(UsageError(format!(
                    "{} and {} are one file: give each input once",
                    other.display(),
                    input.display()
                ))
                .into());
            }
        }
        // A count named twice would measure its point twice under one key.
        if super::repeats(&self.iterations) {
            return Err(UsageError("--iterations names each value once".into()).into());
        }
        if same_file(&program, &self.output) {
            return Err(UsageError(format!(
                "--output {} is the program measured, {}",
                self.output.display(),
                program.display()
            ))
            .into());
        }
        let sources = Sources {
            perf: self.perf.clone(),
            ..Sources::default()
        };
        Ok(Sweep {
            plan: Plan {
                program,
                inputs: self.inputs.clone(),
                iterations: self.iterations.clone(),
                repeats: self.repeats,
                idle_windows: self.repeats,
                idle,
            },
            energy: EnergyMethod::detect(&sources),
            machine: Machine::this(),
        })
    }

    /// The CSV the sweep writes.
    pub fn csv_path(&self) -> &Path {
        &self.output
    }

    /// Refuses what a Slurm array of these arguments could not run: `--resume` (a job
    /// array goes on with `slurm resubmit`).
    pub fn check_submittable(&self) -> Result<(), UsageError> {
        match self.resume {
            true => Err(UsageError(
                "--resume: a sweep run as a job array goes on with fluid-lab slurm resubmit".into(),
            )),
            false => Ok(()),
        }
    }

    /// The inputs' fingerprint: each file and the CRC-32 of its bytes, which a Slurm
    /// array records at submit and checks at each task and merge.
    pub fn inputs_fingerprint(&self) -> Result<String, Box<dyn Error>> {
        let prints = self
            .inputs
            .iter()
            .map(|input| slurm::file_fingerprint(input));
        Ok(prints.collect::<Result<Vec<String>, String>>()?.join("; "))
    }

    /// The points a Slurm array runs, one a task: the idle baseline (all its windows),
    /// then each input at each iteration count (all its repeats, after a warm-up run).
    pub fn points(&self) -> Result<Vec<String>, Box<dyn Error>> {
        let sweep = self.sweep()?;
        let mut points = vec![format!(
            "idle baseline, {} windows of {} s",
            self.repeats, self.idle_seconds
        )];
        for (_, name, _) in sweep.inputs()? {
            for iterations in &self.iterations {
                points.push(format!(
                    "{name}, {iterations} iterations, {} repeats",
                    self.repeats
                ));
            }
        }
        Ok(points)
    }

    /// Measures point `index` of [`SweepArgs::points`] alone: its CSV, the sweep's
    /// columns.
    pub fn measure_point(&self, index: usize) -> Result<Vec<u8>, Box<dyn Error>> {
        let mut sweep = self.sweep()?;
        let plan = &mut sweep.plan;
        match index.checked_sub(1) {
            None => {
                plan.inputs.clear();
                plan.iterations.clear();
            }
            Some(run) => {
                let per_input = plan.iterations.len();
                let (input, iterations) = (run / per_input, run % per_input);
                plan.inputs = vec![plan
                    .inputs
                    .get(input)
                    .ok_or_else(|| format!("the sweep has no point {index}"))?
                    .clone()];
                plan.iterations = vec![plan.iterations[iterations]];
                plan.idle_windows = 0;
            }
        }
        let mut records = Vec::new();
        sweep.measure(
            &mut crate::lab::progress::lines(),
            &HashSet::new(),
            &mut records,
            &mut |_| Ok(()),
        )?;
        sweep.csv(&records)
    }
}

/// Measures every point of the sweep and writes the CSV; a failed run still writes the
/// rows measured before it, which `--resume` goes on from.
pub fn exec(args: SweepArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let output = OutputFile::create(&args.output)?;
    let sweep = args.sweep()?;
    // The inputs first: a fault of theirs is theirs, not the resumed CSV's.
    sweep.inputs()?;
    let previous = match args.resume {
        true => match read_regular_text(&args.output) {
            Ok(text) => text,
            Err(error) if error.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(error) => {
                return Err(format!("cannot read {}: {error}", args.output.display()).into())
            }
        },
        false => String::new(),
    };
    let done = match previous.is_empty() {
        true => HashSet::new(),
        false => sweep
            .resumable(&previous)
            .map_err(|error| format!("--resume: {}: {error}", args.output.display()))?,
    };
    drop(output);
    // The CSV is rewritten, whole, after every record: a failure or a signal keeps the
    // rows measured so far.
    let write = |records: &[crate::lab::sweep::Record]| -> Result<(), Box<dyn Error>> {
        let mut csv = sweep.csv(records)?;
        if !previous.is_empty() {
            let header_end = csv
                .iter()
                .position(|&b| b == b'\n')
                .map_or(csv.len(), |i| i + 1);
            csv = [previous.as_bytes(), &csv[header_end..]].concat();
        }
        Ok(OutputFile::create(&args.output)?.commit(&csv)?)
    };
    let mut records = Vec::new();
    let measured = sweep.measure(
        &mut crate::lab::progress::lines(),
        &done,
        &mut records,
        &mut |records| write(records),
    );
    let rows = done.len() + records.len();
    if let Err(error) = measured {
        if rows == 0 {
            return Err(error);
        }
        let (noun, verb, them) = match rows {
            1 => ("row", "is", "it"),
            _ => ("rows", "are", "them"),
        };
        return Err(format!(
            "{error}; the {rows} {noun} measured {verb} in {}, and --resume goes on from {them}",
            args.output.display()
        )
        .into());
    }
    write(&records)?;
    writeln!(stdout, "wrote {} ({rows} rows)", args.output.display())?;
    Ok(())
}

/// The program to measure: a name without a folder is a file in the current folder (not
/// looked up in PATH), and it must be an executable file.
fn program_path(program: PathBuf) -> Result<PathBuf, String> {
    use std::os::unix::fs::PermissionsExt;
    let path = match program.components().count() {
        1 if !program.is_absolute() => Path::new(".").join(&program),
        _ => program,
    };
    match std::fs::metadata(&path) {
        Ok(meta) if meta.is_file() && meta.permissions().mode() & 0o111 != 0 => Ok(path),
        _ => Err(format!(
            "--program {}: no executable file there",
            path.display()
        )),
    }
}
