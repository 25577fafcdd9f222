//! `fluid-lab render`: a state as a PNG, or a run as an animated GIF or a PNG series.

use super::simulation_args::{load, run_visiting, Loaded, SimulationArgs};
use crate::io::export::Snapshot;
use crate::io::output::OutputFile;
use crate::lab::render::{self, Animation, Colouring};
use clap::builder::RangedI64ValueParser;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Output: .png for the final state (a numbered series with --every), .gif for an
    /// animation of the run.
    output: PathBuf,
    /// Draw every this many steps (and step 0) [default for .gif: steps / 50].
    #[arg(long, allow_negative_numbers = true, value_parser = RangedI64ValueParser::<u64>::new().range(1..))]
    every: Option<u64>,
    /// What the colours show.
    #[arg(long, value_enum, default_value_t = Colouring::Speed)]
    colour: Colouring,
    /// Colour range LOW,HIGH, finite [default: each frame's own].
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    range: Option<(f64, f64)>,
    /// Milliseconds per GIF frame.
    #[arg(long, allow_negative_numbers = true, default_value_t = 80)]
    delay_ms: u32,
}

/// What `render` writes, from the output's extension (in any case).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Picture {
    Gif,
    Png,
}

impl Picture {
    fn of(output: &Path) -> Result<Self, String> {
        let extension = output.extension().and_then(|e| e.to_str());
        match extension.map(str::to_ascii_lowercase).as_deref() {
            Some("gif") => Ok(Self::Gif),
            Some("png") => Ok(Self::Png),
            _ => Err(format!(
                "{}: the output must end in .png or .gif",
                output.display()
            )),
        }
    }
}

/// Runs the scene and draws the states asked for as PNG files or one GIF. Each file is
/// written whole or not at all, and the first is opened before anything is simulated.
pub fn exec(args: RenderArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let output = &args.output;
    let picture = Picture::of(output)?;
    let steps = args.simulation.steps;
    let frame_path = |step: u64| match args.every {
        Some(_) => {
            let stem = output.file_stem().unwrap_or_default().to_string_lossy();
            let extension = output.extension().unwrap_or_default().to_string_lossy();
            output.with_file_name(format!("{stem}_{step:06}.{extension}"))
        }
        None => output.clone(),
    };
    let first = match (picture, args.every) {
        (Picture::Png, Some(_)) => frame_path(0),
        _ => output.clone(),
    };
    let mut first = Some(OutputFile::create(&first)?);
    let Loaded {
        name,
        ppm,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    let style = render::Style {
        title: name.clone(),
        ppm: ppm.into(),
        colouring: args.colour,
        range: args.range,
    };
    match picture {
        Picture::Gif => {
            let every = args.every.unwrap_or((steps / 50).max(1));
            let staged = first.take().expect("the GIF's output").staged()?;
            let mut animation = Animation::create(staged.path(), args.delay_ms)?;
            let mut frames = 0;
            run_visiting(&mut simulation, steps, Some(every), |simulation, step| {
                animation.push(&Snapshot::of(simulation, step), &style)?;
                frames += 1;
                Ok(())
            })?;
            drop(animation);
            staged.commit()?;
            writeln!(stdout, "wrote {} ({frames} frames)", output.display())?;
        }
        Picture::Png => {
            run_visiting(&mut simulation, steps, args.every, |simulation, step| {
                let path = frame_path(step);
                let file = match first.take() {
                    Some(file) => file,
                    None => OutputFile::create(&path)?,
                };
                let staged = file.staged()?;
                render::render_png(&Snapshot::of(simulation, step), &style, staged.path())?;
                staged.commit()?;
                writeln!(stdout, "wrote {}", path.display())?;
                Ok(())
            })?;
        }
    }
    Ok(())
}

/// Parses `LOW,HIGH` into a non-empty range of finite numbers.
fn parse_range(text: &str) -> Result<(f64, f64), String> {
    let numbers = text.split_once(',').and_then(|(low, high)| {
        Some((
            low.trim().parse::<f64>().ok()?,
            high.trim().parse::<f64>().ok()?,
        ))
    });
    match numbers {
        Some((low, high)) if !(low.is_finite() && high.is_finite()) => {
            Err(format!("{text}: LOW and HIGH must be finite numbers"))
        }
        Some((low, high)) if low < high => Ok((low, high)),
        Some(_) => Err(format!("{text} is empty: LOW must be below HIGH")),
        None => Err(format!("{text} is not LOW,HIGH")),
    }
}
