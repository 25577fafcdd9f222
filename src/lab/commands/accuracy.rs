//! `fluid-lab accuracy`: time per step against error for each model and kernel, relative
//! to the reference trajectory; a CSV and two charts.

use crate::io::fld::{self, OutputFile};
use crate::lab::accuracy;
use crate::lab::chart::{self, LogChart};
use crate::lab::machine::Machine;
use crate::sim::method::{Kernel, Method, Model};
use clap::Args;
use plotters::chart::SeriesLabelPosition;
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `fluid-lab accuracy`.
#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Input .fld file.
    input: PathBuf,
    /// Folder for accuracy.csv, accuracy-speed.{png,svg} and error-growth.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// Steps after which the accuracy-speed chart shows the error (the largest is the
    /// length of every run).
    #[arg(long, value_delimiter = ',', default_values_t = [5, 20, 100])]
    horizons: Vec<u64>,
    /// Models to measure.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Model::ALL)]
    models: Vec<Model>,
}

/// Runs every model and fast kernel against the reference and writes the CSV and charts.
pub fn exec(args: AccuracyArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let steps = args.horizons.iter().copied().max().unwrap_or(0);
    if steps == 0 {
        return Err("--horizons needs a step after 0".into());
    }
    super::create_output_dir(&args.output_dir)?;
    let scene = fld::read(&args.input)?;
    let particles = scene.particles.len();
    let name = args.input.display().to_string();
    let start = scene.into_simulation(Method::default(), &name)?;
    let file_name = args.input.file_name().unwrap_or_default().to_string_lossy();
    let mut rows = format!("{}\n", accuracy::CSV_HEADER);
    let mut trajectories = Vec::new();
    for model in args.models {
        let runs = accuracy::sweep(&start, model, &Kernel::FAST, steps);
        rows.push_str(&accuracy::csv(&file_name, particles, &runs));
        trajectories.extend(runs);
    }
    let csv_path = args.output_dir.join("accuracy.csv");
    OutputFile::create(&csv_path)?.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    let machine = Machine::this();
    let label =
        |t: &accuracy::Trajectory| format!("{} {}", t.method.model.name(), t.method.kernel.name());
    let reference_times: Vec<String> = trajectories
        .iter()
        .filter(|t| t.method.kernel == Kernel::Reference)
        .map(|t| {
            format!(
                "{} {:.2} ms",
                t.method.model.name(),
                t.seconds_per_step * 1e3
            )
        })
        .collect();
    let footer = format!(
        "{file_name}, {particles} particles; {} ({} CPUs), commit {}; error: largest position distance \
         to the reference ({} per step)",
        machine.cpu_model,
        machine.cpus,
        machine.commit,
        reference_times.join(", ")
    );
    let fast = || {
        trajectories
            .iter()
            .filter(|t| t.method.kernel != Kernel::Reference)
    };
    let speed = LogChart {
        name: "accuracy-speed",
        title: format!("Error against time per step, {file_name}"),
        x_label: "time per step (ms)".into(),
        y_label: "position error (m)".into(),
        series: args
            .horizons
            .iter()
            .map(|&horizon| {
                let points = fast()
                    .map(|t| (t.seconds_per_step * 1e3, t.errors[horizon as usize - 1].max))
                    .collect();
                (format!("after {horizon} steps"), points)
            })
            .collect(),
        lines: false,
        legend: SeriesLabelPosition::UpperRight,
        notes: fast()
            .map(|t| {
                let worst = t.errors[steps as usize - 1].max;
                (t.seconds_per_step * 1e3, worst, format!("  {}", label(t)))
            })
            .collect(),
        footer: footer.clone(),
    };
    let growth = LogChart {
        name: "error-growth",
        title: format!("Error growth against the reference, {file_name}"),
        x_label: "step".into(),
        y_label: "position error (m)".into(),
        series: fast()
            .map(|t| {
                let points = t
                    .errors
                    .iter()
                    .enumerate()
                    .map(|(k, e)| ((k + 1) as f64, e.max));
                (label(t), points.collect())
            })
            .collect(),
        lines: true,
        legend: SeriesLabelPosition::UpperLeft,
        notes: Vec::new(),
        footer,
    };
    for chart in [speed, growth] {
        for path in chart::render(&chart, &args.output_dir, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    Ok(())
}
