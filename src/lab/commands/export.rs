//! `fluid-lab export`: a state, or a run every k steps or every t simulated seconds, as VTK (legacy ASCII, or XML with
//! binary arrays and a `.pvd` time series, for ParaView) or CSV files.

use super::simulation_args::{
    keeping_frames, load, needed, run_visiting, Loaded, SimulationArgs, Span,
};
use crate::io::export::{frames_index, pvd_collection, Snapshot};
use crate::io::fld;
use crate::io::output::OutputFile;
use crate::lab::UsageError;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `fluid-lab export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Folder for the files, named INPUT-STEM_STEP.vtk (or .csv, .vtp).
    #[arg(required_unless_present = "case")]
    output_dir: Option<PathBuf>,
    /// Also export every this many steps (and step 0) [default: the final state only].
    #[arg(long, allow_negative_numbers = true, value_parser = super::whole::<u64>(1, i64::MAX as u64))]
    every: Option<u64>,
    #[command(flatten)]
    span: Span,
    /// File format.
    #[arg(long, value_enum, default_value_t = ExportFormat::Vtk)]
    format: ExportFormat,
}

/// The format of exported states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    /// Legacy VTK polydata, which ParaView opens (a numbered series as a time series),
    /// and INPUT-STEM-frames.csv, each file's step and physical time.
    Vtk,
    /// One row per particle, and INPUT-STEM-frames.csv, each file's step and physical
    /// time.
    Csv,
    /// VTK XML PolyData with raw binary arrays, and INPUT-STEM.pvd, the collection of the
    /// files with each one's physical time (ParaView plays it in simulated time).
    Vtp,
}

/// Runs the scene and writes the states asked for, one file each.
pub fn exec(mut args: ExportArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    args.simulation.read_case(&mut args.output_dir)?;
    args.simulation.keep_input_intact();
    args.span
        .take_case(args.simulation.read.as_ref(), args.every);
    let output_dir = needed(args.output_dir.take(), "output folder")?;
    if output_dir.exists() && !output_dir.is_dir() {
        let shown = output_dir.display();
        return Err(UsageError(format!("the output folder {shown} is a file")).into());
    }
    let extent = args.simulation.extent(args.span.until)?;
    args.span.check(extent, &args.simulation)?;
    let Loaded {
        stem,
        name,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    let _folder = super::create_output_dir(&output_dir)?;
    let visits = args.span.frames(args.every);
    let collection = match args.format {
        ExportFormat::Vtp => output_dir.join(format!("{stem}.pvd")),
        ExportFormat::Csv | ExportFormat::Vtk => output_dir.join(format!("{stem}-frames.csv")),
    };
    // The index is tried before the run: it may not replace what the export reads.
    drop(OutputFile::create(&collection)?);
    let mut frames = Vec::new();
    run_visiting(&mut simulation, extent, visits, |simulation, step| {
        let snapshot = Snapshot::of(simulation, step);
        let (bytes, extension) = match args.format {
            ExportFormat::Vtk => (
                snapshot
                    .to_vtk(&format!("fluid: {name}, step {step}"))
                    .into_bytes(),
                "vtk",
            ),
            ExportFormat::Csv => (snapshot.to_csv().into_bytes(), "csv"),
            ExportFormat::Vtp => (snapshot.to_vtp(), "vtp"),
        };
        let file = format!("{stem}_{step:06}.{extension}");
        let path = output_dir.join(&file);
        // Every format holds positions and velocities as f32: an infinity is no frame.
        fld::check_storable(simulation.particles()).map_err(|unstorable| {
            format!(
                "cannot write {}: {unstorable}, beyond what the frame's f32 values hold",
                path.display()
            )
        })?;
        OutputFile::create(&path)?.commit(&bytes)?;
        writeln!(stdout, "wrote {}", path.display())?;
        // The index of the frames and their times, rewritten with every frame, so a
        // stopped run leaves the series so far.
        frames.push((step, snapshot.time, file));
        let index = match args.format {
            ExportFormat::Vtp => {
                let files: Vec<(String, f64)> = frames
                    .iter()
                    .map(|(_, time, file)| (file.clone(), *time))
                    .collect();
                pvd_collection(&files)
            }
            ExportFormat::Csv | ExportFormat::Vtk => frames_index(&frames),
        };
        OutputFile::create(&collection)?.commit(index.as_bytes())?;
        Ok(())
    })
    .map_err(|error| keeping_frames(error, frames.len()))?;
    writeln!(stdout, "wrote {}", collection.display())?;
    Ok(())
}
