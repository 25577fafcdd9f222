//! `fluid-lab scene`: a generated scene written as a `.fld` input.

use crate::io::fld;
use crate::io::output::OutputFile;
use crate::lab::scene::{self, SceneKind};
use crate::lab::UsageError;
use crate::sim::params::Domain;
use clap::Args;
use std::error::Error;
use std::path::PathBuf;

/// The arguments of `fluid-lab scene`.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// The scene.
    #[arg(value_enum)]
    kind: SceneKind,
    /// Output .fld file.
    output: PathBuf,
    /// Particles per metre: the lattice spacing is 1/ppm (an f32, as the .fld header
    /// stores it).
    #[arg(long, allow_negative_numbers = true, default_value_t = 400.0, value_parser = parse_ppm)]
    ppm: f32,
    /// Seed of the lattice jitter and of the random cloud.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0, value_parser = super::whole::<u64>(0, u64::MAX))]
    seed: u64,
    /// Number of particles (random-cloud and corner-block only).
    #[arg(long, allow_negative_numbers = true, value_parser = super::whole::<usize>(0, u64::MAX))]
    particles: Option<usize>,
    /// Write the scene's case file (TOML, docs/case-files.md) to OUTPUT instead of its
    /// particles: its fills, run with the weakly compressible model to 0.5 s (dam-break,
    /// drop and filled-box, the fills of a lattice).
    #[arg(long, conflicts_with = "particles")]
    case_file: bool,
}

/// The physical time a scene's case runs to (s).
const CASE_UNTIL: f64 = 0.5;

/// Generates the scene and writes it as a `.fld` file.
pub fn exec(args: SceneArgs) -> Result<(), Box<dyn Error>> {
    // Before anything is made, and as usage errors (generate checks them too).
    args.kind
        .check_particle_count(args.particles)
        .map_err(UsageError)?;
    // Checked as given (the f32's shortest decimal, not its widening's digits).
    let ppm: f64 = args.ppm.to_string().parse().unwrap_or(args.ppm.into());
    scene::check_ppm(ppm, &Domain::COURSE).map_err(UsageError)?;
    let output = OutputFile::create(&args.output)?;
    if args.case_file {
        // Only a case whose scene can be made: the scene's own checks first.
        if args.kind.regions().is_some() {
            scene::generate(args.kind, args.ppm.into(), args.seed, None).map_err(UsageError)?;
        }
        let case = args
            .kind
            .case(args.ppm, args.seed, CASE_UNTIL)
            .ok_or_else(|| {
                UsageError(format!(
                    "{} is not a fill of a lattice: it has no case file",
                    args.kind.name()
                ))
            })?;
        let text = format!(
            "# The {} scene of `fluid-lab scene`, as a case file (docs/case-files.md).\n\n{}",
            args.kind.name(),
            toml::to_string(&case)?
        );
        output.commit(text.as_bytes())?;
        return Ok(());
    }
    // What the flags ask for that cannot be made (too many particles, none, a block the
    // box cannot hold) is a usage error.
    let particles = scene::generate(args.kind, args.ppm.into(), args.seed, args.particles)
        .map_err(UsageError)?;
    fld::check_storable(&particles)
        .map_err(|unstorable| unstorable.for_output(args.output.as_os_str()))?;
    output.commit_with(|out| fld::write(args.ppm, &particles, out))?;
    Ok(())
}

/// Parses particles per metre that the `.fld` header's f32 holds as a finite number > 0.
fn parse_ppm(text: &str) -> Result<f32, String> {
    match text.parse::<f64>() {
        Ok(ppm) if ppm.is_finite() && ppm > 0.0 && (ppm as f32).is_normal() => Ok(ppm as f32),
        Ok(_) => Err(format!(
            "{text} is not a number > 0 that the .fld header's f32 holds"
        )),
        Err(_) => Err(format!("{text} is not a number")),
    }
}
