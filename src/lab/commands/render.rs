//! `fluid-lab render`: a state as a PNG, or a run as an animated GIF or a PNG series.

use super::simulation_args::{load, run_visiting, Loaded, SimulationArgs};
use crate::io::export::Snapshot;
use crate::lab::render::{self, Animation, Colouring};
use clap::builder::RangedU64ValueParser;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `fluid-lab render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
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

/// Runs the scene and draws the states asked for as PNG files or one GIF.
pub fn exec(args: RenderArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
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
