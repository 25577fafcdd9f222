//! Charts of a sweep CSV (see [`crate::lab::sweep`]): time, energy and power against iterations,
//! one line per input (and energy domain), each point the median of its repeats with a
//! min-max bar. Drawn with plotters as PNG and SVG, with an embedded font (DejaVu Sans), so
//! no system font library and no network are needed.

use crate::io::output::OutputFile;
use crate::lab::energy::Domain;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::collections::BTreeMap;
use std::error::Error;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// Pixel size of the rendered charts.
pub const SIZE: (u32, u32) = (960, 600);

/// Line colours, in order (the "tab10" colours, distinct on white and in print).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// One point of a series: the median of its repeats and their spread.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// The iteration count.
    pub iterations: u64,
    /// The median of the repeats.
    pub median: f64,
    /// The smallest repeat.
    pub min: f64,
    /// The largest repeat.
    pub max: f64,
}

impl Point {
    /// Summarises the repeats of one point (`values` must not be empty).
    pub fn of(iterations: u64, values: &mut [f64]) -> Point {
        values.sort_by(f64::total_cmp);
        let middle = values.len() / 2;
        let median = if values.len() % 2 == 1 {
            values[middle]
        } else {
            values[middle - 1] / 2.0 + values[middle] / 2.0
        };
        Point {
            iterations,
            median,
            min: values[0],
            max: values[values.len() - 1],
        }
    }
}

/// A line of a chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The legend text, e.g. `large.fld` or `large.fld pkg`.
    pub label: String,
    /// The points, by increasing iterations.
    pub points: Vec<Point>,
}

/// One chart: what it plots and how it is labelled.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// The file stem (`time`, `energy`, `power`).
    pub name: &'static str,
    /// The title.
    pub title: String,
    /// The y axis' description.
    pub y_label: &'static str,
    /// The lines.
    pub series: Vec<Series>,
    /// Horizontal reference lines (the idle baseline), as (label, value).
    pub baselines: Vec<(String, f64)>,
    /// Where nothing was measured, why (written across the plot).
    pub missing: Option<String>,
    /// Where the data come from: machine, commit, method.
    pub footer: String,
    /// The largest iteration count of the sweep (the x axis covers it even without lines).
    pub largest_iterations: u64,
}

impl Chart {
    /// The x axis: from 0 to past the largest iteration count.
    pub fn x_range(&self) -> Range<f64> {
        let largest = self
            .series
            .iter()
            .flat_map(|series| &series.points)
            .map(|point| point.iterations)
            .fold(self.largest_iterations, u64::max);
        0.0..if largest > 0 {
            largest as f64 * 1.04
        } else {
            1.0
        }
    }

    /// The y axis: from 0 to past the largest value, spread and baselines included.
    pub fn y_range(&self) -> Range<f64> {
        let points = self.series.iter().flat_map(|series| &series.points);
        let largest = points
            .map(|point| point.max)
            .chain(self.baselines.iter().map(|(_, value)| *value))
            .fold(0.0, f64::max);
        // Capped: a top beyond f64's range would give an axis with no ticks to end.
        0.0..if largest > 0.0 {
            (largest * 1.08).min(f64::MAX)
        } else {
            1.0
        }
    }
}

/// One row of a sweep CSV, as far as the charts need it.
#[derive(Clone, Debug)]
struct Row {
    input: Option<String>,
    iterations: Option<u64>,
    wall_s: f64,
    energy_j: [Option<f64>; 5],
    power_w: [Option<f64>; 5],
}

/// A sweep CSV read for charting.
#[derive(Clone, Debug)]
pub struct SweepTable {
    rows: Vec<Row>,
    energy_detail: String,
    footer: String,
}

impl SweepTable {
    /// Reads the CSV text that `fluid-lab sweep` writes.
    pub fn parse(text: &str) -> Result<SweepTable, Box<dyn Error>> {
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let headers = reader.headers()?.clone();
        let column = |name: &str| {
            headers
                .iter()
                .position(|header| header == name)
                .ok_or_else(|| format!("the sweep CSV has no column {name}"))
        };
        let kind = column("kind")?;
        let input = column("input")?;
        let iterations = column("iterations")?;
        let wall = column("wall_s")?;
        let energy: Vec<usize> = Domain::ALL
            .iter()
            .map(|domain| column(&format!("energy_{}_j", domain.name())))
            .collect::<Result<_, _>>()?;
        let power: Vec<usize> = Domain::ALL
            .iter()
            .map(|domain| column(&format!("power_{}_w", domain.name())))
            .collect::<Result<_, _>>()?;
        let [detail, cpu, cpus, kernel, commit, method] = [
            "energy_detail",
            "cpu_model",
            "cpus",
            "kernel",
            "commit",
            "energy_method",
        ]
        .map(column);
        let mut rows = Vec::new();
        let mut footer = String::new();
        let mut energy_detail = String::new();
        for (line, record) in reader.records().enumerate() {
            let record = record?;
            let bad = |what: &str| format!("row {}: {what}", line + 2);
            // A measurement: empty (not measured), or a finite number >= 0.
            let number = |index: usize| -> Result<Option<f64>, String> {
                let text = &record[index];
                match text.parse::<f64>() {
                    _ if text.is_empty() => Ok(None),
                    Ok(value) if value.is_finite() && value >= 0.0 => Ok(Some(value)),
                    Ok(_) => Err(bad(&format!(
                        "{} is {text}, not a finite measurement >= 0",
                        &headers[index]
                    ))),
                    Err(_) => Err(bad(&format!("{text:?} is not a number"))),
                }
            };
            let is_run = match &record[kind] {
                "run" => true,
                "idle" => false,
                other => return Err(bad(&format!("unknown kind {other:?}")).into()),
            };
            let iterations = match &record[iterations] {
                "" if !is_run => None,
                text => Some(text.parse().map_err(|_| bad("iterations is not a count"))?),
            };
            let mut energy_j = [None; 5];
            let mut power_w = [None; 5];
            for (slot, &index) in energy_j.iter_mut().zip(&energy) {
                *slot = number(index)?;
            }
            for (slot, &index) in power_w.iter_mut().zip(&power) {
                *slot = number(index)?;
            }
            if footer.is_empty() {
                let field = |index: &Result<usize, String>| {
                    index
                        .as_ref()
                        .map_or("?", |&index| &record[index])
                        .to_string()
                };
                energy_detail = field(&detail);
                footer = format!(
                    "{} ({} CPUs), Linux {}, commit {}; energy: {}",
                    field(&cpu),
                    field(&cpus),
                    field(&kernel),
                    field(&commit),
                    field(&method)
                );
            }
            rows.push(Row {
                input: is_run.then(|| record[input].to_string()),
                iterations,
                wall_s: number(wall)?.ok_or_else(|| bad("wall_s is empty"))?,
                energy_j,
                power_w,
            });
        }
        if !rows.iter().any(|row| row.input.is_some()) {
            return Err("the sweep CSV holds no runs".into());
        }
        Ok(SweepTable {
            rows,
            energy_detail,
            footer,
        })
    }

    /// The three charts: time, energy and power against iterations.
    pub fn charts(&self) -> [Chart; 3] {
        let repeats = self.most_repeats();
        let footer = format!("{}; median and min-max of {repeats} runs", self.footer);
        let measured: Vec<Domain> = Domain::ALL
            .into_iter()
            .filter(|domain| {
                self.rows
                    .iter()
                    .any(|row| row.energy_j[*domain as usize].is_some())
            })
            .collect();
        let missing = measured.is_empty().then(|| {
            format!(
                "energy not measured on this machine\n{}",
                self.energy_detail
            )
        });
        let largest_iterations = self
            .rows
            .iter()
            .filter_map(|row| row.iterations)
            .max()
            .unwrap_or(0);
        let time = Chart {
            name: SWEEP_CHART_NAMES[0],
            title: "Wall time against iterations".into(),
            y_label: "wall time (s)",
            series: self.series(|row| Some(row.wall_s), None),
            baselines: Vec::new(),
            missing: None,
            footer: footer.clone(),
            largest_iterations,
        };
        let energy = Chart {
            name: SWEEP_CHART_NAMES[1],
            title: "Energy against iterations".into(),
            y_label: "energy (J)",
            series: measured
                .iter()
                .flat_map(|&domain| self.series(|row| row.energy_j[domain as usize], Some(domain)))
                .collect(),
            baselines: Vec::new(),
            missing: missing.clone(),
            footer: footer.clone(),
            largest_iterations,
        };
        let power = Chart {
            name: SWEEP_CHART_NAMES[2],
            title: "Average power against iterations".into(),
            y_label: "power (W)",
            series: measured
                .iter()
                .flat_map(|&domain| self.series(|row| row.power_w[domain as usize], Some(domain)))
                .collect(),
            baselines: measured
                .iter()
                .filter_map(|&domain| {
                    let mut idle: Vec<f64> = self
                        .rows
                        .iter()
                        .filter(|row| row.input.is_none())
                        .filter_map(|row| row.power_w[domain as usize])
                        .collect();
                    (!idle.is_empty()).then(|| {
                        let label = format!("idle {}", domain.name());
                        (label, Point::of(0, &mut idle).median)
                    })
                })
                .collect(),
            missing,
            footer,
            largest_iterations,
        };
        [time, energy, power]
    }

    /// One series per input (in order of first appearance) of the value `of` each run.
    fn series(&self, of: impl Fn(&Row) -> Option<f64>, domain: Option<Domain>) -> Vec<Series> {
        let mut inputs: Vec<&str> = Vec::new();
        for input in self.rows.iter().filter_map(|row| row.input.as_deref()) {
            if !inputs.contains(&input) {
                inputs.push(input);
            }
        }
        inputs
            .into_iter()
            .filter_map(|input| {
                let mut by_iterations: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
                for row in self.rows.iter() {
                    if let (Some(true), Some(iterations), Some(value)) = (
                        row.input.as_deref().map(|i| i == input),
                        row.iterations,
                        of(row),
                    ) {
                        by_iterations.entry(iterations).or_default().push(value);
                    }
                }
                let points: Vec<Point> = by_iterations
                    .into_iter()
                    .map(|(iterations, mut values)| Point::of(iterations, &mut values))
                    .collect();
                let label = match domain {
                    Some(domain) => format!("{input} {}", domain.name()),
                    None => input.to_string(),
                };
                (!points.is_empty()).then_some(Series { label, points })
            })
            .collect()
    }

    /// The largest number of runs of any point.
    fn most_repeats(&self) -> usize {
        let mut counts: BTreeMap<(&str, u64), usize> = BTreeMap::new();
        for row in &self.rows {
            if let (Some(input), Some(iterations)) = (row.input.as_deref(), row.iterations) {
                *counts.entry((input, iterations)).or_default() += 1;
            }
        }
        counts.into_values().max().unwrap_or(0)
    }
}

/// A picture that draws itself on any plotters backend, written as PNG and SVG.
pub trait Drawing {
    /// The file stem.
    fn name(&self) -> &str;
    /// Draws the picture on `root` and presents it.
    fn draw_on<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, Shift>,
    ) -> Result<(), Box<dyn Error>>
    where
        DB::ErrorType: 'static;
}

/// The names of a sweep's charts: wall time, energy and power against iterations.
pub const SWEEP_CHART_NAMES: [&str; 3] = ["time", "energy", "power"];

/// The files of the chart `name` in `folder`: its PNG and its SVG.
pub fn files(folder: &Path, name: &str) -> [PathBuf; 2] {
    ["png", "svg"].map(|extension| folder.join(format!("{name}.{extension}")))
}

/// Writes `drawing` as `DIR/NAME.png` and `DIR/NAME.svg`, `size` pixels, each whole or not
/// at all; returns both paths.
pub fn render<D: Drawing>(
    drawing: &D,
    folder: &Path,
    size: (u32, u32),
) -> Result<[PathBuf; 2], Box<dyn Error>> {
    ChartFiles::open(folder, drawing.name())?.render(drawing, size)
}

/// A bitmap's error in the system's words: plotters shows the I/O or encoding error
/// inside its wrappers in Rust's debug form (`backend error: Drawing backend error:
/// ImageError(IoError(Custom { kind: Other, error: "No space left on device" }))`); the
/// message quoted inside is what the system said.
pub fn in_plain_words(error: impl std::fmt::Display) -> Box<dyn Error> {
    let text = error.to_string();
    let quoted = ["message: \"", "error: \""].iter().find_map(|opening| {
        let start = text.find(opening)? + opening.len();
        let end = text[start..].find('"')?;
        Some(text[start..start + end].to_string())
    });
    quoted.unwrap_or(text).into()
}

/// A chart's two files, opened (their room made) before it is drawn: a command that
/// writes other files beside its charts opens every one first, so that none is replaced
/// when another cannot be written.
pub struct ChartFiles {
    png: OutputFile,
    svg: OutputFile,
    paths: [PathBuf; 2],
}

impl ChartFiles {
    /// Opens `DIR/NAME.png` and `DIR/NAME.svg`.
    pub fn open(folder: &Path, name: &str) -> Result<ChartFiles, Box<dyn Error>> {
        let paths = files(folder, name);
        let (png, svg) = (
            OutputFile::create(&paths[0])?,
            OutputFile::create(&paths[1])?,
        );
        Ok(ChartFiles { png, svg, paths })
    }

    /// Writes `drawing` into them, `size` pixels; returns both paths.
    pub fn render<D: Drawing>(
        self,
        drawing: &D,
        size: (u32, u32),
    ) -> Result<[PathBuf; 2], Box<dyn Error>> {
        self.draw(drawing, size)?.commit()
    }

    /// Draws `drawing`, `size` pixels, without replacing either file yet: the PNG into a
    /// temporary file beside it, the SVG in memory. A command commits its charts once
    /// everything that can fail has not.
    pub fn draw<D: Drawing>(
        self,
        drawing: &D,
        size: (u32, u32),
    ) -> Result<DrawnChart, Box<dyn Error>> {
        register_font()?;
        let ChartFiles { png, svg, paths } = self;
        let png = png.staged()?;
        drawing
            .draw_on(BitMapBackend::new(png.path(), size).into_drawing_area())
            .map_err(|error| format!("{}: {}", paths[0].display(), in_plain_words(error)))?;
        let mut text = String::new();
        drawing.draw_on(SVGBackend::with_string(&mut text, size).into_drawing_area())?;
        Ok(DrawnChart {
            png,
            svg,
            text,
            paths,
        })
    }
}

/// A chart drawn and not yet written ([`ChartFiles::draw`]); dropped, it leaves nothing.
pub struct DrawnChart {
    png: crate::io::output::Staged,
    svg: OutputFile,
    text: String,
    paths: [PathBuf; 2],
}

impl DrawnChart {
    /// Makes the drawn files the chart's; returns both paths.
    pub fn commit(self) -> Result<[PathBuf; 2], Box<dyn Error>> {
        self.png.commit()?;
        self.svg.commit(self.text.as_bytes())?;
        Ok(self.paths)
    }
}

/// Splits a chart's area into the plot and a footer line, and writes the footer.
fn plot_and_footer<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    footer: &str,
) -> Result<DrawingArea<DB, Shift>, Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (width, height) = root.dim_in_pixel();
    // About 6 pixels a character at 12 points.
    let lines = wrap(footer, (width.saturating_sub(32) / 6).max(40) as usize);
    let (plot, bottom) = root.split_vertically(height - 14 - 14 * lines.len() as u32);
    let style = ("sans-serif", 12).into_font().color(&BLACK.mix(0.7));
    for (row, line) in lines.iter().enumerate() {
        bottom.draw(&Text::new(
            line.as_str(),
            (16, 4 + 14 * row as i32),
            style.clone(),
        ))?;
    }
    Ok(plot)
}

/// Registers DejaVu Sans, from the binary itself, as plotters' `sans-serif`.
pub(crate) fn register_font() -> Result<(), Box<dyn Error>> {
    static REGISTER: Once = Once::new();
    let mut result = Ok(());
    REGISTER.call_once(|| {
        result = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        )
        .map_err(|_| "the embedded font does not load");
    });
    Ok(result?)
}

impl Drawing for Chart {
    fn name(&self) -> &str {
        self.name
    }

    fn draw_on<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, Shift>,
    ) -> Result<(), Box<dyn Error>>
    where
        DB::ErrorType: 'static,
    {
        let plot = plot_and_footer(&root, &self.footer)?;
        let (x, y) = (self.x_range(), self.y_range());
        let mut context = ChartBuilder::on(&plot)
            .caption(&self.title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(x.clone(), y.clone())?;
        context
            .configure_mesh()
            .x_desc("iterations")
            .y_desc(self.y_label)
            .x_label_formatter(&|iterations| format!("{iterations:.0}"))
            .y_labels(if self.missing.is_some() { 0 } else { 10 })
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        for (index, series) in self.series.iter().enumerate() {
            let color = COLOURS[index % COLOURS.len()];
            let points = &series.points;
            context
                .draw_series(LineSeries::new(
                    points.iter().map(|p| (p.iterations as f64, p.median)),
                    color.stroke_width(2),
                ))?
                .label(&series.label)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
            // Each bar spans min to max, with a circle at the median.
            context.draw_series(points.iter().map(|p| {
                ErrorBar::new_vertical(p.iterations as f64, p.min, p.median, p.max, color, 8)
            }))?;
        }
        for (index, (label, value)) in self.baselines.iter().enumerate() {
            let color = BLACK.mix(0.6 - 0.2 * index as f64);
            let line = [(x.start, *value), (x.end, *value)];
            context
                .draw_series(DashedLineSeries::new(line, 8, 6, color.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        if let Some(missing) = &self.missing {
            let centre = ((x.start + x.end) / 2.0, (y.start + y.end) / 2.0);
            let anchor = Pos::new(HPos::Center, VPos::Center);
            let style = ("sans-serif", 18).into_text_style(&plot).pos(anchor);
            let lines = wrap(missing, 80);
            let (cx, cy) = context.backend_coord(&centre);
            for (index, line) in lines.iter().enumerate() {
                let offset = (index as i32 * 2 - lines.len() as i32 + 1) * 12;
                plot.draw(&Text::new(line.as_str(), (cx, cy + offset), style.clone()))?;
            }
        }
        if !self.series.is_empty() || !self.baselines.is_empty() {
            context
                .configure_series_labels()
                .label_font(("sans-serif", 14))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .position(SeriesLabelPosition::UpperLeft)
                .draw()?;
        }
        root.present()?;
        Ok(())
    }
}

/// A chart of points (x, y), joined by lines or not, each axis linear or logarithmic;
/// points an axis cannot show (not finite, or not positive on a log axis) are left out.
#[derive(Clone, Debug, PartialEq)]
pub struct PointChart {
    /// The file stem.
    pub name: &'static str,
    /// The title.
    pub title: String,
    /// The x axis' description.
    pub x_label: String,
    /// Whether the x axis is logarithmic (else linear, from 0).
    pub x_log: bool,
    /// The y axis' description.
    pub y_label: String,
    /// Whether the y axis is logarithmic (else linear, from 0 or below).
    pub y_log: bool,
    /// The series: legend text and points.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// How many of the first series are measurements (an experiment's points), drawn in
    /// black and grey with markers of their own, apart from the colours of the rest.
    pub measured: usize,
    /// Whether to join each series' points with lines (else points only).
    pub lines: bool,
    /// A line per series through other points of its own (its Pareto front, say), in its
    /// colour; missing entries draw none.
    pub fronts: Vec<Vec<(f64, f64)>>,
    /// Texts written beside points: (x, y, text).
    pub notes: Vec<(f64, f64, String)>,
    /// Where the legend goes.
    pub legend: SeriesLabelPosition,
    /// Where the data come from.
    pub footer: String,
}

impl PointChart {
    /// Lines of `series` against simulated time, linear axes, no marks beyond the points.
    pub fn over_time(
        name: &'static str,
        title: String,
        y_label: &str,
        series: Vec<(String, Vec<(f64, f64)>)>,
        legend: SeriesLabelPosition,
        footer: &str,
    ) -> PointChart {
        PointChart {
            name,
            title,
            x_label: "simulated time (s)".into(),
            x_log: false,
            y_label: y_label.into(),
            y_log: false,
            series,
            measured: 0,
            lines: true,
            fronts: Vec::new(),
            notes: Vec::new(),
            legend,
            footer: footer.to_string(),
        }
    }

    /// Whether the axes can show `point`.
    fn shows(&self, (x, y): (f64, f64)) -> bool {
        x.is_finite() && y.is_finite() && (!self.y_log || y > 0.0) && (!self.x_log || x > 0.0)
    }

    /// The points drawn: those the axes can show.
    fn drawn(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.series
            .iter()
            .flat_map(|(_, points)| points.iter().copied())
            .filter(|&point| self.shows(point))
    }

    /// The x axis: from 0 to the largest x (a series over time ends where its data do;
    /// points alone get room for their markers), or (logarithmic) from below the
    /// smallest x to above the largest.
    pub fn x_range(&self) -> Range<f64> {
        let (smallest, largest) = self
            .drawn()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), (x, _)| {
                (lo.min(x), hi.max(x))
            });
        let room = if self.lines { 1.0 } else { 1.05 };
        match (self.x_log, largest > 0.0) {
            (false, true) => 0.0..largest * room,
            (false, false) => 0.0..1.0,
            (true, true) => (smallest / 1.6).min(largest / 10.0)..largest * 1.6,
            (true, false) => 0.1..1.0,
        }
    }

    /// The y axis: logarithmic, from half the smallest y to twice the largest (decades
    /// apart at least); linear, from 0 (or below the smallest y, if negative) to past
    /// the largest.
    pub fn y_range(&self) -> Range<f64> {
        let (low, high) = self
            .drawn()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), (_, y)| {
                (lo.min(y), hi.max(y))
            });
        let bottom = (low.min(0.0) * 1.1).max(f64::MIN);
        match (self.y_log, high > 0.0 || bottom < 0.0) {
            (true, true) => (low / 2.0).min(high / 10.0)..(high * 2.0).min(f64::MAX),
            (true, false) => 1e-3..1.0,
            (false, true) => bottom..(high * 1.1).min(f64::MAX),
            (false, false) => 0.0..1.0,
        }
    }
}

impl Drawing for PointChart {
    fn name(&self) -> &str {
        self.name
    }

    fn draw_on<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, Shift>,
    ) -> Result<(), Box<dyn Error>>
    where
        DB::ErrorType: 'static,
    {
        let plot = plot_and_footer(&root, &self.footer)?;
        let mut builder = ChartBuilder::on(&plot);
        builder
            .caption(&self.title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(80);
        let log_x = |&x: &f64| {
            let digits = (1 - x.log10().floor() as i32).max(0) as usize;
            format!("{x:.digits$}")
        };
        let log_y = |y: &f64| format!("{y:.0e}");
        let (x, y) = (self.x_range(), self.y_range());
        let (x_digits, y_digits) = (tick_decimals(&x), tick_decimals(&y));
        let linear_x = move |x: &f64| format!("{x:.x_digits$}");
        let linear_y = move |y: &f64| format!("{y:.y_digits$}");
        match (self.x_log, self.y_log) {
            (true, true) => self.draw_in(
                builder.build_cartesian_2d(x.log_scale(), y.log_scale())?,
                &log_x,
                &log_y,
            )?,
            (true, false) => self.draw_in(
                builder.build_cartesian_2d(x.log_scale(), y)?,
                &log_x,
                &linear_y,
            )?,
            (false, true) => self.draw_in(
                builder.build_cartesian_2d(x, y.log_scale())?,
                &linear_x,
                &log_y,
            )?,
            (false, false) => {
                self.draw_in(builder.build_cartesian_2d(x, y)?, &linear_x, &linear_y)?
            }
        }
        root.present()?;
        Ok(())
    }
}

impl PointChart {
    /// Draws the mesh, series, fronts, notes and legend in `context`, labels by
    /// `x_format` and `y_format`.
    fn draw_in<'a, DB, X, Y>(
        &self,
        mut context: ChartContext<'a, DB, Cartesian2d<X, Y>>,
        x_format: &dyn Fn(&f64) -> String,
        y_format: &dyn Fn(&f64) -> String,
    ) -> Result<(), Box<dyn Error>>
    where
        DB: DrawingBackend + 'a,
        DB::ErrorType: 'static,
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        context
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(x_format)
            .y_label_formatter(y_format)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        let count = self.series.len() - self.measured.min(self.series.len());
        for (index, (label, points)) in self.series.iter().enumerate() {
            if index < self.measured {
                // Crosses in black, then triangles in grey, and so on.
                let shade = BLACK.mix(1.0 - 0.45 * (index % 2) as f64);
                let points = points.iter().copied().filter(|&p| self.shows(p));
                if index % 2 == 0 {
                    let cross = move |p| Cross::new(p, 5, shade.stroke_width(2));
                    context
                        .draw_series(points.map(cross))?
                        .label(label.as_str())
                        .legend(move |(x, y)| Cross::new((x + 10, y), 5, shade.stroke_width(2)));
                } else {
                    let triangle = move |p| TriangleMarker::new(p, 6, shade.filled());
                    context
                        .draw_series(points.map(triangle))?
                        .label(label.as_str())
                        .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, shade.filled()));
                }
                continue;
            }
            let color = colour(index - self.measured, count);
            if let Some(front) = self.fronts.get(index) {
                let front = front.iter().copied().filter(|&p| self.shows(p));
                context.draw_series(LineSeries::new(front, color.mix(0.6).stroke_width(2)))?;
            }
            let points: Vec<(f64, f64)> =
                points.iter().copied().filter(|&p| self.shows(p)).collect();
            let markers = points.iter().map(|&p| Circle::new(p, 4, color.filled()));
            if self.lines {
                context.draw_series(LineSeries::new(
                    points.iter().copied(),
                    color.stroke_width(2),
                ))?;
            }
            context
                .draw_series(markers)?
                .label(label.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
        }
        // Notes in pixels, each moved down past the notes already placed that it would
        // overlap (text about 7 pixels a character, 14 a line).
        let area = context.plotting_area();
        let (base_x, base_y) = area.get_base_pixel();
        let pixels = area.strip_coord_spec();
        let style = ("sans-serif", 13).into_font().color(&BLACK.mix(0.8));
        let mut placed: Vec<(i32, i32, i32)> = Vec::new();
        for (x, y, text) in self.notes.iter().filter(|(x, y, _)| self.shows((*x, *y))) {
            let (px, mut py) = area.map_coordinate(&(*x, *y));
            let (px, width) = (px - base_x, 7 * text.chars().count() as i32);
            py -= base_y;
            while placed
                .iter()
                .any(|&(qx, qy, w)| (py - qy).abs() < 14 && px < qx + w && qx < px + width)
            {
                py += 14;
            }
            placed.push((px, py, width));
            pixels.draw(&Text::new(text.clone(), (px, py - 6), style.clone()))?;
        }
        context
            .configure_series_labels()
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .position(self.legend.clone())
            .draw()?;
        Ok(())
    }
}

/// The decimals a linear axis over `range` labels its ticks with: enough for ticks about
/// a tenth of the range apart to differ (0.05 apart: two), none for whole numbers.
fn tick_decimals(range: &Range<f64>) -> usize {
    let step = (range.end - range.start).abs() / 10.0;
    match step.is_finite() && step > 0.0 {
        true => (-step.log10().floor()).clamp(0.0, 12.0) as usize,
        false => 1,
    }
}

/// The colour of series `index` of `count`: the palette's, or hues around the colour
/// wheel where the palette is too short to tell them apart.
fn colour(index: usize, count: usize) -> RGBColor {
    if count <= COLOURS.len() {
        return COLOURS[index];
    }
    let (r, g, b) = HSLColor(index as f64 / count as f64, 0.75, 0.42).rgb();
    RGBColor(r, g, b)
}

/// Splits `text` into lines of at most about `width` characters, at spaces and newlines.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    for paragraph in text.lines() {
        let mut line = String::new();
        for word in paragraph.split_whitespace() {
            if !line.is_empty() && line.len() + 1 + word.len() > width {
                lines.push(std::mem::take(&mut line));
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bitmap_s_error_is_the_system_s_message_inside_plotters_wrappers() {
        let cases = [
            (
                "backend error: Drawing backend error: ImageError(IoError(Custom { kind: \
                 Other, error: \"No space left on device\" }))",
                "No space left on device",
            ),
            (
                "backend error: Drawing backend error: GifEncodingError(Io(Os { code: 28, \
                 kind: StorageFull, message: \"No space left on device\" }))",
                "No space left on device",
            ),
            ("Bad layout", "Bad layout"),
        ];
        for (text, said) in cases {
            assert_eq!(in_plain_words(text).to_string(), said);
        }
    }
    use crate::lab::energy::{Energy, EnergyMethod};
    use crate::lab::machine::Machine;
    use crate::lab::sweep::{Plan, Record, Sweep, Usage};
    use std::time::Duration;

    /// A sweep CSV as `fluid-lab sweep` writes it: two inputs, iterations 0, 10 and 100,
    /// three repeats, two idle windows; with energy (pkg and ram) or without.
    fn sweep_csv(with_energy: bool) -> String {
        let energy_method = if with_energy {
            EnergyMethod::Perf {
                program: "perf".into(),
                events: vec!["power/energy-pkg/".into(), "power/energy-ram/".into()],
            }
        } else {
            EnergyMethod::Unavailable {
                reason: "no RAPL here".into(),
            }
        };
        let energy = |wall: f64, watts: f64| {
            let mut energy = Energy::default();
            if with_energy {
                energy.add(Domain::Pkg, watts * wall);
                energy.add(Domain::Ram, 2.0 * wall);
            }
            energy
        };
        let mut records = Vec::new();
        for repeat in 1..=2 {
            records.push(Record {
                input: None,
                particles: None,
                iterations: None,
                repeat,
                wall: Duration::from_secs(1),
                usage: None,
                energy: energy(1.0, 10.0 + repeat as f64),
            });
        }
        for repeat in 1..=3 {
            for (input, per_step) in [("small.fld", 0.2e-3), ("large.fld", 0.65e-3)] {
                for iterations in [0u64, 10, 100] {
                    let wall = 0.002 + per_step * iterations as f64 * (1.0 + 0.01 * repeat as f64);
                    let duration = Duration::from_secs_f64(wall);
                    records.push(Record {
                        input: Some(input.into()),
                        particles: Some(4800),
                        iterations: Some(iterations),
                        repeat,
                        wall: duration,
                        usage: Some(Usage {
                            wall: duration,
                            user: duration,
                            system: Duration::ZERO,
                            max_rss_kib: 6000,
                        }),
                        energy: energy(wall, 30.0),
                    });
                }
            }
        }
        let sweep = Sweep {
            plan: Plan {
                program: "fluid".into(),
                inputs: Vec::new(),
                iterations: Vec::new(),
                repeats: 3,
                idle_windows: 3,
                idle: Duration::from_secs(1),
            },
            energy: energy_method,
            machine: Machine {
                host: "h".into(),
                cpu_model: "Test CPU".into(),
                cpus: 2,
                kernel: "6.1".into(),
                commit: "abc".into(),
            },
        };
        String::from_utf8(sweep.csv(&records).unwrap()).unwrap()
    }

    fn covers(chart: &Chart) {
        let (x, y) = (chart.x_range(), chart.y_range());
        for point in chart.series.iter().flat_map(|series| &series.points) {
            assert!(x.contains(&(point.iterations as f64)), "{point:?} {x:?}");
            assert!(y.start <= point.min && point.max < y.end, "{point:?} {y:?}");
        }
        for (_, value) in &chart.baselines {
            assert!(y.contains(value), "{value} {y:?}");
        }
    }

    #[test]
    fn a_point_is_the_median_and_range_of_its_repeats() {
        assert_eq!(
            Point::of(5, &mut [3.0, 1.0, 9.0]),
            Point {
                iterations: 5,
                median: 3.0,
                min: 1.0,
                max: 9.0
            }
        );
        assert_eq!(Point::of(5, &mut [4.0, 1.0, 2.0, 9.0]).median, 3.0);
        assert_eq!(Point::of(5, &mut [7.0]).median, 7.0);
    }

    #[test]
    fn measured_energy_gives_a_line_per_input_and_domain_and_an_idle_baseline() {
        let table = SweepTable::parse(&sweep_csv(true)).unwrap();
        let [time, energy, power] = table.charts();
        let labels = |chart: &Chart| -> Vec<String> {
            chart.series.iter().map(|s| s.label.clone()).collect()
        };
        assert_eq!(labels(&time), ["small.fld", "large.fld"]);
        assert_eq!(
            labels(&energy),
            [
                "small.fld pkg",
                "large.fld pkg",
                "small.fld ram",
                "large.fld ram"
            ]
        );
        assert_eq!(labels(&power), labels(&energy));
        let large = &time.series[1].points;
        assert_eq!(large.len(), 3);
        assert_eq!(large[2].iterations, 100);
        assert!((large[2].median - (0.002 + 0.065 * 1.02)).abs() < 1e-6);
        assert!((large[2].min - (0.002 + 0.065 * 1.01)).abs() < 1e-6);
        assert!((large[2].max - (0.002 + 0.065 * 1.03)).abs() < 1e-6);
        assert!((power.series[0].points[1].median - 30.0).abs() < 1e-3);
        assert_eq!(power.baselines.len(), 2);
        assert_eq!(power.baselines[0].0, "idle pkg");
        assert!((power.baselines[0].1 - 11.5).abs() < 1e-6);
        assert!((power.baselines[1].1 - 2.0).abs() < 1e-6);
        for chart in [&time, &energy, &power] {
            assert_eq!(chart.missing, None);
            assert!(chart
                .footer
                .starts_with("Test CPU (2 CPUs), Linux 6.1, commit abc"));
            assert!(chart.footer.ends_with("median and min-max of 3 runs"));
            covers(chart);
        }
        assert!(time.x_range().end >= 100.0);
    }

    #[test]
    fn without_energy_the_energy_charts_say_so_and_draw_no_lines() {
        let table = SweepTable::parse(&sweep_csv(false)).unwrap();
        let [time, energy, power] = table.charts();
        assert_eq!(time.series.len(), 2);
        assert_eq!(time.missing, None);
        for chart in [&energy, &power] {
            assert!(chart.series.is_empty() && chart.baselines.is_empty());
            assert_eq!(
                chart.missing.as_deref(),
                Some("energy not measured on this machine\nnot available (no RAPL here)")
            );
            assert!(chart.x_range().end >= 100.0);
        }
    }

    #[test]
    fn a_csv_that_is_not_a_sweep_is_refused_with_the_reason() {
        let error = SweepTable::parse("kind,input\nrun,x\n").unwrap_err();
        assert_eq!(error.to_string(), "the sweep CSV has no column iterations");
        let text = sweep_csv(false);
        let header = text.lines().next().unwrap();
        let idle_only: String = text.lines().take(3).collect::<Vec<_>>().join("\n");
        assert_eq!(
            SweepTable::parse(&idle_only).unwrap_err().to_string(),
            "the sweep CSV holds no runs"
        );
        let bad = format!(
            "{header}\n{}",
            text.lines().nth(3).unwrap().replace(",0.0", ",x.0")
        );
        assert!(SweepTable::parse(&bad)
            .unwrap_err()
            .to_string()
            .starts_with("row 2: "));
    }

    #[test]
    fn rendered_charts_are_valid_png_and_svg_with_their_labels() {
        let folder = tempfile::tempdir().unwrap();
        let table = SweepTable::parse(&sweep_csv(true)).unwrap();
        for chart in table.charts() {
            let [png, svg] = render(&chart, folder.path(), SIZE).unwrap();
            let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
            let mut reader = decoder.read_info().unwrap();
            let mut pixels = vec![0; reader.output_buffer_size()];
            let frame = reader.next_frame(&mut pixels).unwrap();
            assert_eq!((frame.width, frame.height), SIZE);
            let inked = pixels[..frame.buffer_size()]
                .chunks(3)
                .filter(|rgb| rgb.iter().any(|&c| c < 128))
                .count();
            assert!(inked > 2000, "{}: only {inked} dark pixels", png.display());

            let text = std::fs::read_to_string(&svg).unwrap();
            let document = roxmltree::Document::parse(&text).unwrap();
            let root = document.root_element();
            assert_eq!(root.tag_name().name(), "svg");
            assert_eq!(root.attribute("width"), Some("960"));
            let texts: Vec<&str> = document
                .descendants()
                .filter(|node| node.is_text())
                .filter_map(|node| node.text())
                .map(str::trim)
                .filter(|text| !text.is_empty())
                .collect();
            assert!(texts.contains(&"iterations"), "{texts:?}");
            assert!(texts.contains(&chart.title.as_str()), "{texts:?}");
            for series in &chart.series {
                assert!(texts.contains(&series.label.as_str()), "{texts:?}");
            }
            let markers = document
                .descendants()
                .filter(|node| node.has_tag_name("circle"))
                .count();
            let points: usize = chart.series.iter().map(|s| s.points.len()).sum();
            assert_eq!(markers, points, "{}", svg.display());
        }
    }

    #[test]
    fn ticks_have_the_digits_to_differ_and_time_axes_end_with_their_data() {
        // A gauge over 0.3 s, heights 0 to 0.2 m: ticks 0.05 and 0.02 apart.
        let chart = PointChart::over_time(
            "gauges-surface",
            "surface".into(),
            "height (m)",
            vec![("middle".into(), vec![(0.0, 0.1), (0.15, 0.2), (0.3, 0.18)])],
            SeriesLabelPosition::UpperLeft,
            "",
        );
        assert_eq!(chart.x_range(), 0.0..0.3);
        let decimals = tick_decimals(&chart.x_range());
        let ticks: Vec<String> = (0..=6)
            .map(|k| format!("{:.decimals$}", 0.05 * k as f64))
            .collect();
        assert_eq!(
            ticks,
            ["0.00", "0.05", "0.10", "0.15", "0.20", "0.25", "0.30"]
        );
        assert_eq!(tick_decimals(&chart.y_range()), 2);
        // Whole numbers stay whole; a range of nothing keeps one decimal.
        assert_eq!(tick_decimals(&(0.0..1200.0)), 0);
        assert_eq!(tick_decimals(&(0.0..0.002)), 4);
        assert_eq!(tick_decimals(&(1.0..1.0)), 1);
    }

    #[test]
    fn long_reasons_wrap_at_spaces_and_newlines() {
        assert_eq!(
            wrap("first line\naa bb cc dd", 5),
            ["first", "line", "aa bb", "cc dd"]
        );
    }
}
