//! `fluid-lab chart`: the charts of a sweep CSV (time, energy and power against
//! iterations), as PNG and SVG.

use super::create_output_dir;
use crate::lab::chart::{self, SweepTable};
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab chart`.
#[derive(Debug, Args)]
pub struct ChartArgs {
    /// The CSV written by `fluid-lab sweep`.
    csv: PathBuf,
    /// Folder for time, energy and power .png and .svg, created if missing [default: the
    /// CSV's folder].
    #[arg(long)]
    output_dir: Option<PathBuf>,
}

/// Reads the sweep CSV and draws its charts.
pub fn exec(args: ChartArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let table = read(&args.csv)?;
    crate::io::output::keep_intact(&args.csv);
    let _made = args
        .output_dir
        .as_deref()
        .map(create_output_dir)
        .transpose()?;
    let folder = match args.output_dir {
        Some(folder) => folder,
        None => args.csv.parent().map(PathBuf::from).unwrap_or_default(),
    };
    super::try_charts(&folder, &crate::lab::chart::SWEEP_CHART_NAMES)?;
    draw(&table, &folder, stdout)
}

/// Reads and checks the sweep CSV at `csv`.
pub fn read(csv: &Path) -> Result<SweepTable, String> {
    let text = crate::io::input::read_regular_text(csv)
        .map_err(|error| format!("cannot read {}: {error}", csv.display()))?;
    SweepTable::parse(&text).map_err(|error| format!("{}: {error}", csv.display()))
}

/// Draws the charts of a sweep table into `folder`.
pub fn draw(
    table: &SweepTable,
    folder: &Path,
    stdout: &mut impl Write,
) -> Result<(), Box<dyn Error>> {
    for chart in table.charts() {
        for path in chart::render(&chart, folder, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    Ok(())
}
