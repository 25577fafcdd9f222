//! `fluid-lab chaos`: copies of an input with one coordinate moved by one ulp, and a
//! state judged against the ensemble of states that runs on them give (see [`chaos`]).

use crate::io::fld;
use crate::io::input::read_regular;
use crate::io::output::OutputFile;
use crate::lab::chaos::{self, Statistics};
use crate::lab::commands::{create_output_dir, same_file};
use crate::lab::UsageError;
use clap::{Args, Subcommand};
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab chaos`.
#[derive(Debug, Args)]
pub struct ChaosArgs {
    #[command(subcommand)]
    action: Action,
}

#[derive(Debug, Subcommand)]
enum Action {
    /// Write copies of an input, each with one coordinate of one particle moved up by one
    /// ulp of its f32 (copy k: FOLDER/<input's name>-ulp<k>.fld).
    Perturb(PerturbArgs),
    /// Judge a state against an ensemble of states (runs of the same steps on the input
    /// and its perturbed copies): each statistic must lie within the ensemble's range
    /// widened by its standard deviation. Prints a markdown table, and how often the
    /// members themselves fall outside the others' range; exits 1 if one does not.
    Check(CheckArgs),
}

/// The arguments of `fluid-lab chaos perturb`.
#[derive(Debug, Args)]
struct PerturbArgs {
    /// The `.fld` input.
    input: PathBuf,
    /// The folder the copies go to (created if missing).
    folder: PathBuf,
    /// How many copies (at most 3 per particle: each moves another coordinate).
    #[arg(long, allow_negative_numbers = true, default_value_t = 8, value_parser = super::whole::<u32>(1, 1000))]
    copies: u32,
}

/// The arguments of `fluid-lab chaos check`.
#[derive(Debug, Args)]
struct CheckArgs {
    /// The state judged (a `.fld` output).
    candidate: PathBuf,
    /// The ensemble's states (at least two `.fld` outputs).
    #[arg(required = true, num_args = 2..)]
    ensemble: Vec<PathBuf>,
}

/// Runs `fluid-lab chaos`.
pub fn exec(args: ChaosArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    match args.action {
        Action::Perturb(args) => perturb(args, stdout),
        Action::Check(args) => check(args, stdout),
    }
}

/// Reads a regular file (never waiting on a FIFO or reading a device).
fn read(path: &Path) -> Result<Vec<u8>, String> {
    read_regular(path).map_err(|error| format!("cannot read {}: {error}", path.display()))
}

fn perturb(args: PerturbArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let name = args.input.display().to_string();
    let bytes = read(&args.input)?;
    crate::io::output::keep_intact(&args.input);
    let stem = args
        .input
        .file_stem()
        .ok_or_else(|| UsageError(format!("{name} names no file")))?
        .to_string_lossy()
        .into_owned();
    let particles =
        (fld::validate(&bytes, &args.input).map_err(|error| error.naming(&args.input)))?;
    let particles = particles.particles;
    let copies = args.copies as usize;
    if copies > chaos::most_copies(particles) {
        return Err(UsageError(format!(
            "--copies {copies}: {name} has {particles} particles, so at most {} coordinates \
             to move",
            chaos::most_copies(particles)
        ))
        .into());
    }
    let _folder = create_output_dir(&args.folder)?;
    // One copy in memory at a time; if one cannot be written, none is left.
    let mut written = Vec::new();
    let mut lines = String::from("copy,particle,axis,file\n");
    for copy in 0..copies {
        let path = args.folder.join(format!("{stem}-ulp{copy}.fld"));
        let (bytes, id, axis) = chaos::perturbed(&bytes, copy, copies, &name)?;
        if let Err(error) = OutputFile::create(&path).and_then(|file| file.commit(&bytes)) {
            for path in &written {
                let _ = std::fs::remove_file(path);
            }
            return Err(error.into());
        }
        lines += &format!("{copy},{id},{},{}\n", ["x", "y", "z"][axis], path.display());
        written.push(path);
    }
    stdout.write_all(lines.as_bytes())?;
    Ok(())
}

fn check(args: CheckArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    // A state judged against itself, or a member counted twice, is no test: refused.
    let files = std::iter::once(&args.candidate).chain(&args.ensemble);
    for (index, path) in files.clone().enumerate() {
        if let Some(other) = files
            .clone()
            .skip(index + 1)
            .find(|other| same_file(path, other))
        {
            return Err(UsageError(format!(
                "{} and {} are one file: the state judged and each member of its ensemble \
                 are files of their own",
                path.display(),
                other.display()
            ))
            .into());
        }
    }
    let statistics = |path: &PathBuf| -> Result<(fld::Header, Statistics), Box<dyn Error>> {
        let (bytes, name) = (read(path)?, path.display().to_string());
        let header = (fld::validate(&bytes, &name).map_err(|error| error.naming(path)))?;
        Ok((header, Statistics::of_file(&bytes, &name)?))
    };
    let (ours, candidate) = statistics(&args.candidate)?;
    let mut ensemble = Vec::new();
    for path in &args.ensemble {
        let (theirs, member) = statistics(path)?;
        // An ensemble is of states of one scene: runs of one input and its copies, of
        // its particles at its resolution.
        let (count, particles) = (ours.particles, theirs.particles);
        if particles != count {
            return Err(format!(
                "{} holds {particles} particles where {} holds {count}: an ensemble is of \
                 runs of one input",
                path.display(),
                args.candidate.display()
            )
            .into());
        }
        if theirs.ppm != ours.ppm {
            return Err(format!(
                "{} is at {} particles per metre where {} is at {}: an ensemble is of runs \
                 of one input",
                path.display(),
                theirs.ppm,
                args.candidate.display(),
                ours.ppm
            )
            .into());
        }
        ensemble.push(member);
    }
    let verdicts = chaos::judge(&ensemble, &candidate);
    write!(stdout, "{}", chaos::table(&verdicts))?;
    if ensemble.len() >= 3 {
        let (outside, judged) = chaos::leave_one_out(&ensemble);
        writeln!(
            stdout,
            "\nLeave one out: {outside} of {judged} statistics of the members lie outside the \
             others' range ({:.1}%), the rate at which a run as chaotic as they are fails one.",
            100.0 * outside as f64 / judged as f64
        )?;
    }
    stdout.flush()?;
    let outside: Vec<&str> = verdicts
        .iter()
        .filter(|verdict| !verdict.holds())
        .map(|verdict| verdict.name.as_str())
        .collect();
    if outside.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} of {} statistics outside the ensemble of {}: {}",
            outside.len(),
            verdicts.len(),
            ensemble.len(),
            outside.join(", ")
        )
        .into())
    }
}
