//! `fluid-lab render`: a state as a PNG, or a run as an animated GIF or a PNG series.

use super::simulation_args::{
    keeping_frames, load, needed, run_visiting, Extent, Frames, Loaded, SimulationArgs, Span,
};
use crate::io::export::Snapshot;
use crate::io::output::OutputFile;
use crate::lab::render::{self, Animation, Colouring};
use crate::lab::UsageError;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Output: .png for the final state (a numbered series with --every or
    /// --frame-every), .gif for an animation of the run.
    #[arg(required_unless_present = "case")]
    output: Option<PathBuf>,
    /// Draw every this many steps (and step 0) [default for .gif: 50 frames, by steps or,
    /// with --until, by simulated time].
    #[arg(long, allow_negative_numbers = true, value_parser = super::whole::<u64>(1, i64::MAX as u64))]
    every: Option<u64>,
    #[command(flatten)]
    span: Span,
    /// What the colours show.
    #[arg(long, value_enum, default_value_t = Colouring::Speed)]
    colour: Colouring,
    /// Colour range LOW,HIGH, finite [default: each frame's own].
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    range: Option<(f64, f64)>,
    /// Milliseconds per GIF frame (the format counts hundredths of a second: at most
    /// 655350).
    #[arg(long, allow_negative_numbers = true, default_value_t = 80,
          value_parser = super::whole::<u32>(0, 655_350))]
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
pub fn exec(mut args: RenderArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    args.simulation.read_case(&mut args.output)?;
    args.simulation.keep_input_intact();
    args.span
        .take_case(args.simulation.read.as_ref(), args.every);
    let output = &needed(args.output.take(), "output (.png or .gif)")?;
    let picture = Picture::of(output).map_err(UsageError)?;
    let extent = args.simulation.extent(args.span.until)?;
    args.span.check(extent, &args.simulation)?;
    let series = args.span.is_series(args.every);
    let frame_path = |step: u64| match series {
        true => {
            let stem = output.file_stem().unwrap_or_default().to_string_lossy();
            let extension = output.extension().unwrap_or_default().to_string_lossy();
            output.with_file_name(format!("{stem}_{step:06}.{extension}"))
        }
        false => output.clone(),
    };
    // A picture over the input would lose it (a series' frames are checked by name).
    let input = args.simulation.source();
    let over_input = match series {
        false => super::same_file(output, input),
        true => is_frame_of(output, input),
    };
    if over_input {
        return Err(UsageError(format!(
            "{}: the picture would replace the input {}: give it a file of its own",
            output.display(),
            input.display()
        ))
        .into());
    }
    let first = match (picture, series) {
        (Picture::Png, true) => frame_path(0),
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
            let frames = match (args.span.frames(args.every), extent) {
                (Frames::Last, Extent::Steps(steps)) => Frames::EverySteps((steps / 50).max(1)),
                (Frames::Last, Extent::Until(end)) => Frames::EverySeconds(end / 50.0),
                (frames, _) => frames,
            };
            let staged = first.take().expect("the GIF's output").staged()?;
            let mut animation =
                Animation::create(staged.path(), &simulation.params().domain, args.delay_ms)
                    .map_err(|error| format!("{}: {error}", output.display()))?;
            let mut frames_drawn = 0;
            run_visiting(&mut simulation, extent, frames, |simulation, step| {
                animation
                    .push(&Snapshot::of(simulation, step), &style)
                    .map_err(|error| format!("{}: {error}", output.display()))?;
                frames_drawn += 1;
                Ok(())
            })?;
            drop(animation);
            staged.commit()?;
            writeln!(stdout, "wrote {} ({frames_drawn} frames)", output.display())?;
        }
        Picture::Png => {
            let frames = args.span.frames(args.every);
            let mut written = 0;
            run_visiting(&mut simulation, extent, frames, |simulation, step| {
                let path = frame_path(step);
                let file = match first.take() {
                    Some(file) => file,
                    None => OutputFile::create(&path)?,
                };
                let staged = file.staged()?;
                render::render_png(&Snapshot::of(simulation, step), &style, staged.path())
                    .map_err(|error| format!("{}: {error}", path.display()))?;
                staged.commit()?;
                written += 1;
                writeln!(stdout, "wrote {}", path.display())?;
                Ok(())
            })
            .map_err(|error| keeping_frames(error, written))?;
        }
    }
    Ok(())
}

/// Whether `path` is in the folder of `output` and named as one of its frames,
/// `STEM_NNNNNN.EXT` (six digits or more).
fn is_frame_of(output: &Path, path: &Path) -> bool {
    let (stem, extension) = (output.file_stem(), output.extension());
    let (Some(stem), Some(extension), Some(name)) = (stem, extension, path.file_name()) else {
        return false;
    };
    let step = name
        .to_str()
        .zip(stem.to_str().zip(extension.to_str()))
        .and_then(|(name, (stem, extension))| {
            name.strip_prefix(stem)?
                .strip_prefix('_')?
                .strip_suffix(extension)?
                .strip_suffix('.')
        });
    let numbered = step.is_some_and(|digits| {
        digits.len() >= 6 && digits.bytes().all(|byte| byte.is_ascii_digit())
    });
    let folder = |path: &Path| path.parent().map(PathBuf::from).unwrap_or_default();
    numbered && super::same_file(&folder(output).join("."), &folder(path).join("."))
}

/// Parses `LOW,HIGH` into a non-empty range of finite numbers whose width is finite and
/// normal.
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
        // A width the colour bar can divide by and label: finite, and not below the
        // smallest normal f64.
        Some((low, high)) if low < high && !(high - low).is_normal() => Err(format!(
            "{text}: HIGH - LOW must be a finite width of at least {:e}",
            f64::MIN_POSITIVE
        )),
        Some((low, high)) if low < high => Ok((low, high)),
        Some(_) => Err(format!("{text} is empty: LOW must be below HIGH")),
        None => Err(format!("{text} is not LOW,HIGH")),
    }
}
