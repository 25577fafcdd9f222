//! `fluid-lab accuracy`: methods (kernels and time-step rules) against the reference
//! trajectory at equal physical times; a CSV, the accuracy-speed chart with its Pareto
//! fronts, the error-time chart, and the fastest method within each error budget.

use super::simulation_args::{parse_courants, Courants};
use crate::io::fld;
use crate::io::output::OutputFile;
use crate::lab::accuracy::{self, Candidate, Metric, Run, Sweep};
use crate::lab::chart::{self, PointChart};
use crate::lab::machine::Machine;
use crate::sim::method::{Kernel, Method, Model};
use crate::sim::params::TIME_STEP;
use crate::sim::timestep::TimeStep;
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
    /// Folder for accuracy.csv, accuracy-speed.{png,svg} and error-time.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// Physical model of the scene.
    #[arg(long, value_enum, default_value_t = Model::Fluidanimate)]
    model: Model,
    /// Kernels to compare (each with every time-step rule).
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = [Kernel::NATIVE, Kernel::Mixed])]
    kernels: Vec<Kernel>,
    /// Fixed time steps, as multiples of the course's 1 ms (default: 0.25, 0.5, 1, 2
    /// and 4 for fluidanimate; 0.125, 0.25, 0.5 and 1 for the course model; 0.025, 0.05,
    /// 0.1 and 0.2 for wcsph).
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..)]
    dt_factors: Option<Vec<f64>>,
    /// Courant constants of the adaptive time step ("" for none).
    #[arg(long, allow_negative_numbers = true, default_value = "0.2,0.3,0.4", num_args = 1.., value_parser = parse_courants)]
    adaptive: Vec<Courants>,
    /// Skins of reused neighbour lists, in smoothing lengths, each method also run with
    /// (default: none, lists rebuilt every step).
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..)]
    skins: Vec<f64>,
    /// Physical times (s) at which states are compared, ascending (default: every 4 ms to
    /// 48 ms for fluidanimate and wcsph; 1, 2 and 3 ms for the course model, which is chaotic
    /// after). Each method is sampled at the end of its first step at or after each; the
    /// accuracy-speed chart shows the first, a middle and the last.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..)]
    times: Option<Vec<f64>>,
    /// The reference's fixed step (s) (default: an eighth of the shortest step any method
    /// took).
    #[arg(long, allow_negative_numbers = true)]
    reference_dt: Option<f64>,
    /// Error budgets, in metres or (with a trailing h, as in 0.1h) smoothing lengths:
    /// name the fastest method whose position error (by --metric) stays within each at
    /// every time.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., value_parser = parse_budget)]
    budget: Vec<Budget>,
    /// The position error the budgets and the charts use.
    #[arg(long, value_enum, default_value_t = Metric::Median)]
    metric: Metric,
}

impl AccuracyArgs {
    /// The comparison times, checked.
    fn times(&self) -> Result<Vec<f64>, String> {
        let times = self.times.clone().unwrap_or_else(|| match self.model {
            Model::Course => vec![1e-3, 2e-3, 3e-3],
            Model::Fluidanimate | Model::Wcsph => (1..=12).map(|k| k as f64 * 4e-3).collect(),
        });
        let positive = times.iter().all(|&t| t.is_finite() && t > 0.0);
        if times.is_empty() || !positive || !times.is_sorted_by(|a, b| a < b) {
            return Err("--times needs ascending, positive, finite times".into());
        }
        Ok(times)
    }

    /// The methods to compare, checked.
    fn candidates(&self) -> Result<Vec<Candidate>, String> {
        let factors = self.dt_factors.clone().unwrap_or_else(|| match self.model {
            Model::Course => vec![0.125, 0.25, 0.5, 1.0],
            Model::Fluidanimate => vec![0.25, 0.5, 1.0, 2.0, 4.0],
            // The stiff model's CFL step is near 0.1 ms at 300 per metre.
            Model::Wcsph => vec![0.025, 0.05, 0.1, 0.2],
        });
        let fixed: Vec<f64> = factors.iter().map(|f| f * TIME_STEP).collect();
        if !fixed.iter().all(|&dt| dt.is_finite() && dt > 0.0) {
            return Err("--dt-factors need positive, finite factors".into());
        }
        if !self
            .skins
            .iter()
            .all(|&s| s.is_finite() && s > 0.0 && s <= 1.0)
        {
            return Err("--skins needs widths in (0, 1] smoothing lengths".into());
        }
        Ok(Candidate::product(
            self.model,
            &self.kernels,
            &fixed,
            &Courants::all(&self.adaptive),
            &self.skins,
        ))
    }
}

/// Runs every method against the reference and writes the CSV, the charts and the
/// choices within the budgets.
pub fn exec(args: AccuracyArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let times = args.times()?;
    let candidates = args.candidates()?;
    if let Some(step) = args.reference_dt {
        if !(step.is_finite() && step > 0.0) {
            return Err("--reference-dt needs a positive, finite step".into());
        }
    }
    super::create_output_dir(&args.output_dir)?;
    // The CSV is opened before the runs, so an unwritable folder fails first.
    let csv_path = args.output_dir.join("accuracy.csv");
    let csv_file = OutputFile::create(&csv_path)?;
    let scene = fld::read(&args.input)?;
    let particles = scene.particles.len();
    let name = args.input.display().to_string();
    let method = Method {
        model: args.model,
        kernel: Kernel::NATIVE,
    };
    let start = scene.into_simulation(method, &name)?;
    let file_name = args.input.file_name().unwrap_or_default().to_string_lossy();
    let sweep = accuracy::sweep(&start, args.model, &candidates, &times, args.reference_dt)?;
    let reference_step = match sweep.reference.candidate.time_step {
        TimeStep::Fixed(dt) => dt,
        TimeStep::Adaptive { .. } => 0.0,
    };
    if reference_step > sweep.shortest_step {
        writeln!(
            stdout,
            "warning: the reference step is longer than the shortest method step ({:e} s), \
             so its own error is in every method's",
            sweep.shortest_step
        )?;
    }
    let machine = Machine::this();
    let rows = format!(
        "{}\n{}",
        accuracy::CSV_HEADER,
        sweep.csv(&file_name, particles, args.model, &machine)
    );
    csv_file.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    let metric = args.metric;
    let footer = footer(&sweep, &file_name, particles, args.model, &machine);
    for chart in [
        speed_chart(&sweep, &times, metric, &file_name, &footer),
        time_chart(&sweep, metric, &file_name, &footer),
    ] {
        for path in chart::render(&chart, &args.output_dir, chart::SIZE)? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
    }
    for (run, why) in sweep
        .runs
        .iter()
        .filter_map(|run| Some((run, run.failure.as_ref()?)))
    {
        writeln!(
            stdout,
            "{} failed at {:.6} s: {}",
            run.candidate.label(),
            why.0,
            why.1
        )?;
    }
    // The smoothing length (the weakly compressible model's own, half its cut-off).
    let h = start
        .weakly_compressible()
        .map_or(start.params().h, |model| model.h);
    for budget in &args.budget {
        writeln!(stdout, "{}", choice(&sweep, budget, h, metric))?;
    }
    Ok(())
}

/// An error budget as given: metres, or a multiple of the smoothing length.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Budget {
    /// So many metres.
    Metres(f64),
    /// So many smoothing lengths h.
    SmoothingLengths(f64),
}

impl Budget {
    /// The budget in metres, for smoothing length `h`.
    fn metres(self, h: f64) -> f64 {
        match self {
            Budget::Metres(metres) => metres,
            Budget::SmoothingLengths(count) => count * h,
        }
    }

    /// The budget as given: `1e-4 m`, `0.1h`.
    fn text(self) -> String {
        match self {
            Budget::Metres(metres) => format!("{metres:e} m"),
            Budget::SmoothingLengths(count) => format!("{count}h"),
        }
    }
}

/// Parses a positive, finite budget: a number of metres, or of smoothing lengths with a
/// trailing `h`.
fn parse_budget(text: &str) -> Result<Budget, String> {
    let (number, budget): (&str, fn(f64) -> Budget) = match text.strip_suffix('h') {
        Some(count) => (count, Budget::SmoothingLengths),
        None => (text, Budget::Metres),
    };
    match number.parse::<f64>() {
        Ok(value) if value.is_finite() && value > 0.0 => Ok(budget(value)),
        _ => Err(format!(
            "{text} is not a positive error in metres or smoothing lengths (0.1h)"
        )),
    }
}

/// The line naming the fastest method within `budget` by `metric`, and its speed-up over
/// the f64 default.
fn choice(sweep: &Sweep, budget: &Budget, h: f64, metric: Metric) -> String {
    let metres = budget.metres(h);
    let within = match budget {
        Budget::Metres(_) => format!("budget {} ({} error)", budget.text(), metric.name()),
        Budget::SmoothingLengths(_) => {
            format!(
                "budget {} = {metres:.3e} m ({} error)",
                budget.text(),
                metric.name()
            )
        }
    };
    let Some(run) = sweep.fastest_within(metres, metric) else {
        return format!("{within}: no method stays within it");
    };
    let cost = run.final_cost();
    let against = match sweep.default_run() {
        Some(default) if default.failure.is_none() => format!(
            ", {:.2}x the speed of {}",
            default.final_cost() / cost,
            default.candidate.label()
        ),
        _ => String::new(),
    };
    format!(
        "{within}: {} ({cost:.3} CPU s per simulated s{against})",
        run.candidate.label()
    )
}

/// Where the charts' data come from.
fn footer(sweep: &Sweep, scene: &str, particles: usize, model: Model, machine: &Machine) -> String {
    let failed = sweep
        .runs
        .iter()
        .filter(|run| run.failure.is_some())
        .count();
    format!(
        "{scene}, {particles} particles, {}; {}, commit {}; against {} ({:.0} CPU s per \
         simulated s){}",
        model.name(),
        machine.cpu_model,
        machine.commit,
        sweep.reference.candidate.label(),
        sweep.reference.final_cost(),
        match failed {
            0 => String::new(),
            count => format!("; {count} failed (see the CSV)"),
        }
    )
}

/// Cost (x, log) against the position error by `metric` (y, log) at up to three of the
/// times (the first, a middle one and the last), each method's point labelled at the
/// last, and each time's Pareto front.
fn speed_chart(
    sweep: &Sweep,
    times: &[f64],
    metric: Metric,
    scene: &str,
    footer: &str,
) -> PointChart {
    let mut shown = vec![0, times.len() / 2, times.len() - 1];
    shown.dedup();
    let point = |run: &Run, k: usize| {
        let sample = run.samples.get(k)?;
        Some((sample.cost(), metric.of(&sample.errors?)))
    };
    let series: Vec<(String, Vec<(f64, f64)>)> = shown
        .iter()
        .map(|&k| {
            let points = sweep.runs.iter().filter_map(|run| point(run, k)).collect();
            (format!("at {} ms", (times[k] * 1e6).round() / 1e3), points)
        })
        .collect();
    let last = times.len() - 1;
    PointChart {
        name: "accuracy-speed",
        title: format!("Error against cost, {scene} (lines: Pareto fronts)"),
        x_label: "CPU seconds per simulated second".into(),
        x_log: true,
        y_log: true,
        y_label: format!("{} position error (m)", metric.name()),
        fronts: series
            .iter()
            .map(|(_, points)| accuracy::pareto_front(points))
            .collect(),
        series,
        lines: false,
        legend: SeriesLabelPosition::UpperRight,
        notes: sweep
            .runs
            .iter()
            .filter_map(|run| {
                let (x, y) = point(run, last)?;
                Some((x, y, format!("  {}", run.candidate.label())))
            })
            .collect(),
        footer: footer.to_string(),
    }
}

/// The position error by `metric` against physical time, one line per method.
fn time_chart(sweep: &Sweep, metric: Metric, scene: &str, footer: &str) -> PointChart {
    PointChart {
        name: "error-time",
        title: format!("Error against time, {scene}"),
        x_label: "physical time (ms)".into(),
        x_log: false,
        y_log: true,
        y_label: format!("{} position error (m)", metric.name()),
        series: sweep
            .runs
            .iter()
            .map(|run| {
                let points = run
                    .samples
                    .iter()
                    .filter_map(|s| Some((s.time * 1e3, metric.of(&s.errors?))));
                (run.candidate.label(), points.collect())
            })
            .collect(),
        fronts: Vec::new(),
        lines: true,
        legend: SeriesLabelPosition::UpperLeft,
        notes: Vec::new(),
        footer: footer.to_string(),
    }
}
