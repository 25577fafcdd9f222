//! `fluid-lab accuracy`: methods (kernels and time-step rules) against the reference
//! trajectory at equal physical times; a CSV, the accuracy-speed chart with its Pareto
//! fronts, the error-time chart, and the fastest method within each error budget.

use super::simulation_args::{self, parse_courants, Courants, SimulationArgs, MOST_STEPS_TO_GO};
use crate::io::fld;
use crate::io::gformat::format_g;
use crate::io::output::OutputFile;
use crate::lab::accuracy::{
    self, Candidate, Convergence, Errors, Metric, Observed, Run, SceneId, Sweep,
};
use crate::lab::chart::{self, PointChart};
use crate::lab::machine::Machine;
use crate::lab::slurm;
use crate::lab::UsageError;
use crate::sim::kernel::Kernel;
use crate::sim::method::Method;
use crate::sim::model::Model;
use crate::sim::params::TIME_STEP;
use crate::sim::simulation::Simulation;
use crate::sim::timestep::{Integrator, TimeStep};
use clap::Args;
use plotters::chart::SeriesLabelPosition;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab accuracy`.
#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Input .fld file (none with --case).
    #[arg(required_unless_present = "case")]
    input: Option<PathBuf>,
    /// A case file (TOML, docs/case-files.md) as the start instead of an input: its
    /// scene in its domain (2-D, periodic faces), its model and the model's settings;
    /// its time step, integrator and run length are the sweep's own.
    #[arg(long, value_name = "FILE", conflicts_with = "input")]
    case: Option<PathBuf>,
    /// The case read from --case, its model settled ([`AccuracyArgs::read_case`]).
    #[arg(skip)]
    read: Option<Box<SimulationArgs>>,
    /// Output folder for accuracy.csv, accuracy-speed.{png,svg} and error-time.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// Physical model of the scene [default: the case's (course where it names none, as
    /// `run --case` takes it), else fluidanimate]
    #[arg(long, value_enum)]
    model: Option<Model>,
    /// Kernels to compare (each with every time-step rule). The model's default method
    /// (the native kernel, its default step, the leapfrog) always runs too, first: the
    /// baseline the others are measured against.
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = [Kernel::NATIVE, Kernel::Mixed])]
    kernels: Vec<Kernel>,
    /// Fixed time steps, as multiples of the course's 1 ms (default: 0.25, 0.5, 1, 2
    /// and 4 for fluidanimate; 0.125, 0.25, 0.5 and 1 for the course model; 0.025, 0.05,
    /// 0.1 and 0.2 for wcsph).
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., value_parser = super::number)]
    dt_factors: Option<Vec<f64>>,
    /// Courant constants of the adaptive time step ("" for none).
    #[arg(long, allow_negative_numbers = true, default_value = "0.2,0.3,0.4", num_args = 1.., value_parser = parse_courants)]
    adaptive: Vec<Courants>,
    /// Integrators, each with every kernel and time-step rule.
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = Integrator::ALL)]
    integrators: Vec<Integrator>,
    /// Skins of reused neighbour lists, in cut-offs (the course models' h), each method
    /// also run with (default: none, lists rebuilt every step).
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., value_parser = super::number)]
    skins: Vec<f64>,
    /// Physical times (s) at which states are compared, ascending (default: every 4 ms to
    /// 48 ms for fluidanimate and wcsph; 1, 2 and 3 ms for the course model, which is chaotic
    /// after). Each method is sampled at the end of its first step at or after each; the
    /// accuracy-speed chart shows the first, a middle and the last.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., value_parser = super::number)]
    times: Option<Vec<f64>>,
    /// The reference's fixed step (s) (default: an eighth of the shortest step any method
    /// took).
    #[arg(long, allow_negative_numbers = true, value_parser = super::number)]
    reference_dt: Option<f64>,
    /// Error budgets, in metres or (with a trailing h, as in 0.1h) smoothing lengths:
    /// name the fastest method whose position error (by --metric) stays within each at
    /// every time.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., value_parser = parse_budget)]
    budget: Vec<Budget>,
    /// The position error the budgets and the charts use.
    #[arg(long, value_enum, default_value_t = Metric::Median)]
    metric: Metric,
    /// Run nothing: draw the charts and report the orders and choices of this
    /// accuracy.csv, written by an earlier sweep of the same arguments (its methods, times
    /// and scene are checked against them).
    #[arg(long, value_name = "CSV")]
    from_csv: Option<PathBuf>,
}

impl AccuracyArgs {
    /// Reads --case, if given, and settles the model: --model, else the case's (the course
    /// model where it names none, as `run --case`), else fluidanimate. Every use of the
    /// arguments comes after it.
    ///
    /// # Errors
    /// A case that cannot be read or is refused, at its key.
    pub fn read_case(&mut self) -> Result<(), Box<dyn Error>> {
        if let Some(path) = &self.case {
            let mut args = SimulationArgs::of_case(path);
            args.model = self.model;
            args.read_case(&mut None)?;
            self.model = Some(args.model());
            args.model = self.model;
            self.read = Some(Box::new(args));
        }
        self.model = Some(self.model());
        Ok(())
    }

    /// The model the scene runs (settled by [`Self::read_case`]).
    fn model(&self) -> Model {
        self.model.unwrap_or(Model::Fluidanimate)
    }

    /// The comparison times, checked.
    fn times(&self) -> Result<Vec<f64>, String> {
        let times = self.times.clone().unwrap_or_else(|| match self.model() {
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
        let factors = self
            .dt_factors
            .clone()
            .unwrap_or_else(|| match self.model() {
                Model::Course => vec![0.125, 0.25, 0.5, 1.0],
                Model::Fluidanimate => vec![0.25, 0.5, 1.0, 2.0, 4.0],
                // The stiff model's CFL step is near 0.1 ms at 300 per metre; 0.3 ms is
                // beyond the leapfrog's stability on its dam break at 150, not the Verlet's.
                Model::Wcsph => vec![0.025, 0.05, 0.1, 0.2, 0.3],
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
            self.model(),
            &self.kernels,
            &fixed,
            &Courants::all(&self.adaptive),
            &self.skins,
            &self.integrators,
        ))
    }
}

/// The scene an accuracy sweep starts from.
struct Start {
    /// The start state, on the model asked for.
    simulation: Simulation,
    /// The scene as rows and charts name it.
    scene: SceneId,
}

impl AccuracyArgs {
    /// The times and methods, checked, with the reference's step if one is given.
    fn plan(&self) -> Result<(Vec<f64>, Vec<Candidate>), Box<dyn Error>> {
        let times = self.times().map_err(UsageError)?;
        let candidates = self.candidates().map_err(UsageError)?;
        if let Some(step) = self.reference_dt {
            if !(step.is_finite() && step > 0.0) {
                return Err(
                    UsageError("--reference-dt needs a positive, finite step".into()).into(),
                );
            }
        }
        // The most steps a run takes that is known before running: the reference's on its
        // step (or on an eighth of the shortest fixed one), to the last time.
        let fixed = candidates
            .iter()
            .filter_map(|candidate| match candidate.time_step {
                TimeStep::Fixed(dt) => Some(dt / 8.0),
                TimeStep::Adaptive { .. } => None,
            });
        let shortest = fixed.chain(self.reference_dt).fold(f64::INFINITY, f64::min);
        let last = times.iter().copied().fold(0.0, f64::max);
        // Each method samples every time at a state of its own: no step passes the first.
        let first = times.iter().copied().fold(f64::INFINITY, f64::min);
        let longest = (candidates.iter()).filter_map(|candidate| match candidate.time_step {
            TimeStep::Fixed(dt) => Some(dt),
            TimeStep::Adaptive { .. } => None,
        });
        let longest = longest.fold(f64::NEG_INFINITY, f64::max);
        if longest > first {
            return Err(UsageError(format!(
                "a fixed step of {} s passes the first of --times, {} s: each method samples \
                 every time (shorten --dt-factors or give later times)",
                format_g(longest),
                format_g(first)
            ))
            .into());
        }
        // Nor the reference's, which would land on every time in one cut step.
        if let Some(step) = self.reference_dt.filter(|&step| step > first) {
            return Err(UsageError(format!(
                "--reference-dt {} passes the first of --times, {} s: the reference is the \
                 finest run of the sweep",
                format_g(step),
                format_g(first)
            ))
            .into());
        }
        let steps = last / shortest;
        if steps > MOST_STEPS_TO_GO {
            return Err(UsageError(format!(
                "--times up to {} s on reference steps of {} s would take {steps:.3e} steps, \
                 more than the {MOST_STEPS_TO_GO:.0e} a run may take",
                format_g(last),
                format_g(shortest)
            ))
            .into());
        }
        Ok((times, candidates))
    }

    /// The input (or the case's scene) as the model's start.
    fn start(&self) -> Result<Start, Box<dyn Error>> {
        let (simulation, source, crc32) = match &self.read {
            Some(case) => {
                let text = case.case_text.as_deref().unwrap_or_default();
                let crc32 = crc32fast::hash(text.as_bytes());
                (
                    simulation_args::load(case)?.simulation,
                    case.source(),
                    crc32,
                )
            }
            None => {
                let input = self
                    .input
                    .as_deref()
                    .expect("an input or a case (clap requires one)");
                let method = Method {
                    model: self.model(),
                    kernel: Kernel::NATIVE,
                };
                // Read once: the scene and the CRC-32 of its bytes.
                let bytes = fld::map_input(input)?;
                let scene = fld::parse(&bytes, input).map_err(|error| error.naming(input))?;
                let simulation = scene.into_simulation(method, &input.display().to_string())?;
                (simulation, input, crc32fast::hash(&bytes))
            }
        };
        let scene = SceneId {
            file_name: (source.file_name().unwrap_or_default())
                .to_string_lossy()
                .into_owned(),
            crc32,
            particles: simulation.particles().len(),
        };
        Ok(Start { simulation, scene })
    }

    /// The scene's fingerprint: its file (the case, or the input) and the CRC-32 of its
    /// bytes, which a Slurm array records at submit and checks at each task and merge.
    pub fn scene_fingerprint(&self) -> Result<String, Box<dyn Error>> {
        Ok(match &self.read {
            Some(case) => {
                let text = case.case_text.as_deref().unwrap_or_default();
                slurm::fingerprint(case.source(), text.as_bytes())
            }
            None => {
                let input = self
                    .input
                    .as_deref()
                    .expect("an input or a case (clap requires one)");
                slurm::file_fingerprint(input)?
            }
        })
    }

    /// The accuracy.csv these arguments write.
    pub fn csv_path(&self) -> PathBuf {
        self.output_dir.join("accuracy.csv")
    }

    /// The folder of the CSV and the charts.
    pub fn output_dir(&self) -> &Path {
        &self.output_dir
    }

    /// Refuses what a Slurm array of these arguments could not run, before anything is
    /// submitted: `--from-csv` (which runs nothing), an input its tasks could not read, or
    /// a case whose scene a run of the sweep refuses (it is made, as a run makes it).
    pub fn check_submittable(&self) -> Result<(), Box<dyn Error>> {
        if self.from_csv.is_some() {
            return Err(UsageError(
                "--from-csv runs nothing to submit: run fluid-lab accuracy --from-csv itself"
                    .into(),
            )
            .into());
        }
        match (&self.read, &self.input) {
            (None, Some(input)) => drop(fld::header(&fld::map_input(input)?, input)?),
            _ => drop(self.start()?),
        }
        Ok(())
    }

    /// The points a Slurm array runs, one a task: each method, then the reference, which
    /// needs every method's sample times and so runs after them.
    pub fn points(&self) -> Result<Vec<String>, Box<dyn Error>> {
        let (_, candidates) = self.plan()?;
        let mut points: Vec<String> = candidates.iter().map(Candidate::label).collect();
        points.push("the reference (compensated kernel, fixed step), after every method".into());
        Ok(points)
    }

    /// Runs method `index` of [`AccuracyArgs::points`] alone, writing each sampled state
    /// to `states` (`K.obs`, the K-th sample): its CSV rows, without errors.
    pub fn run_method_point(&self, index: usize, states: &Path) -> Result<Vec<u8>, Box<dyn Error>> {
        let (times, candidates) = self.plan()?;
        let candidate = *candidates
            .get(index)
            .ok_or_else(|| format!("the sweep has no method {index}"))?;
        let start = self.start()?;
        let mut saved = States::in_folder(states)?;
        let run = accuracy::run_method(
            &start.simulation,
            self.model(),
            candidate,
            &times,
            |fresh| saved.save(fresh),
        )?;
        saved.finish()?;
        Ok(self.rows(&run, &start).into_bytes())
    }

    /// Runs the reference on every time the methods of `methods` (their merged rows) were
    /// sampled at, writing its states to `states`: its CSV rows.
    pub fn run_reference_point(
        &self,
        methods: &str,
        states: &Path,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        self.plan()?;
        let runs = accuracy::read_runs(methods)?;
        let step = self
            .reference_dt
            .unwrap_or(accuracy::shortest_step(&runs) / 8.0);
        let start = self.start()?;
        let sampled = accuracy::sampled_times(&runs);
        let mut saved = States::in_folder(states)?;
        let reference =
            accuracy::run_reference(&start.simulation, self.model(), step, &sampled, |fresh| {
                saved.save(fresh)
            })?;
        saved.finish()?;
        Ok(self.rows(&reference, &start).into_bytes())
    }

    /// `run`'s rows under the CSV's header.
    fn rows(&self, run: &Run, start: &Start) -> String {
        let machine = Machine::this();
        let rows = run.csv(&start.scene, self.model(), &machine);
        format!("{}\n{rows}", accuracy::CSV_HEADER)
    }

    /// The merged rows of an array (`merged`: the reference's, point `reference`, then
    /// each method's, every row with its `slurm_array_index`) with each method's errors
    /// filled in: its states (`states/INDEX/K.obs`) against the reference's.
    pub fn fill_errors(
        &self,
        merged: &[u8],
        states: &Path,
        reference: usize,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        let mut reader = csv::Reader::from_reader(merged);
        let headers = reader.headers()?.clone();
        let column = |name: &str| {
            headers
                .iter()
                .position(|h| h == name)
                .ok_or_else(|| format!("the merged CSV has no column {name}"))
        };
        let (index_column, requested) = (column("slurm_array_index")?, column("requested_time_s")?);
        let first_error = column("median_error_m")?;
        let records: Vec<csv::StringRecord> = reader.records().collect::<Result<_, _>>()?;
        // Each point's rows are contiguous (a shard each), in the order of its run.
        let mut order: Vec<usize> = Vec::new();
        for record in &records {
            let index: usize = record[index_column].parse()?;
            if order.last() != Some(&index) {
                order.push(index);
            }
        }
        if order.first() != Some(&reference) {
            return Err("the reference's rows are missing, so no method can be measured".into());
        }
        let mut runs = accuracy::read_runs(std::str::from_utf8(merged)?)?;
        let mut methods = runs.split_off(1);
        let load = |index: usize, count: usize| -> Result<Vec<Observed>, Box<dyn Error>> {
            (0..count)
                .map(|k| {
                    let path = states.join(index.to_string()).join(format!("{k}.obs"));
                    let bytes = crate::io::input::read_regular(&path)
                        .map_err(|error| format!("{}: {error}", path.display()))?;
                    Ok(Observed::decode(&bytes)
                        .map_err(|error| format!("{}: {error}", path.display()))?)
                })
                .collect()
        };
        let sampled = accuracy::sampled_times(&methods);
        let truths = load(reference, sampled.len())?;
        let observed: Vec<Vec<Observed>> = methods
            .iter()
            .zip(&order[1..])
            .map(|(run, &index)| load(index, run.samples.len()))
            .collect::<Result<_, _>>()?;
        accuracy::measure(&mut methods, &observed, &sampled, &truths);
        // The merged records, their error cells filled, every other cell as it was.
        let mut writer = csv::Writer::from_writer(Vec::new());
        writer.write_record(&headers)?;
        let mut next_sample = vec![0; methods.len()];
        for record in &records {
            let index: usize = record[index_column].parse()?;
            let mut cells: Vec<String> = record.iter().map(String::from).collect();
            let run = order[1..].iter().position(|&i| i == index);
            if let (Some(run), false) = (run, record[requested].is_empty()) {
                let sample = methods[run]
                    .samples
                    .get(next_sample[run])
                    .ok_or("more rows than samples")?;
                next_sample[run] += 1;
                for (k, cell) in Errors::cells(sample.errors.as_ref())
                    .into_iter()
                    .enumerate()
                {
                    cells[first_error + k] = cell;
                }
            }
            writer.write_record(&cells)?;
        }
        Ok(writer.into_inner()?)
    }

    /// Writes the charts of `sweep` into the output folder and reports its failures and
    /// choices; `cpu_model` and `commit` name where its methods ran.
    fn report(
        &self,
        sweep: &Sweep,
        start: &Start,
        cpu_model: &str,
        commit: &str,
        stdout: &mut impl Write,
    ) -> Result<(), Box<dyn Error>> {
        let (times, _) = self.plan()?;
        let metric = self.metric;
        let scene = &start.scene.file_name;
        let footer = footer(
            sweep,
            scene,
            start.scene.particles,
            self.model(),
            cpu_model,
            commit,
        );
        let convergence = sweep.convergence(metric);
        let charts = [
            Some(speed_chart(sweep, &times, metric, scene, &footer)),
            Some(time_chart(sweep, metric, scene, &footer)),
            (!convergence.is_empty())
                .then(|| convergence_chart(&convergence, &times, metric, scene, &footer)),
        ];
        for chart in charts.iter().flatten() {
            for path in chart::render(chart, &self.output_dir, chart::SIZE)? {
                writeln!(stdout, "wrote {}", path.display())?;
            }
        }
        for family in &convergence {
            let order = family
                .order
                .map_or("none".to_string(), |order| format!("{order:.2}"));
            writeln!(
                stdout,
                "order {} {}: {order} ({} error at {} ms against the {} shortest of its \
                 fixed steps)",
                family.kernel.name(),
                family.integrator.name(),
                metric.name(),
                times.last().map_or(0.0, |t| t * 1e3),
                family.points.len().min(accuracy::ORDER_STEPS)
            )?;
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
        let h = start.simulation.smoothing_length();
        for budget in &self.budget {
            writeln!(stdout, "{}", choice(sweep, budget, h, metric))?;
        }
        Ok(())
    }

    /// Checks CSV text as [`Self::chart`] reads it.
    pub fn check_csv(&self, text: &str) -> Result<(), Box<dyn Error>> {
        self.sweep_of(text).map(drop)
    }

    /// The sweep of accuracy CSV `text`, if it is these arguments': their model, their
    /// reference step if given, their methods in order, each sampled at their times (all
    /// of them, or the first until it failed).
    fn sweep_of(&self, text: &str) -> Result<Sweep, Box<dyn Error>> {
        let sweep = Sweep::read(text, self.model())?;
        let (times, candidates) = self.plan()?;
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let model = reader.headers()?.iter().position(|h| h == "model");
        let records: Vec<csv::StringRecord> = reader.records().collect::<Result<_, _>>()?;
        let name = self.model().name();
        if let Some(other) = (model.iter())
            .flat_map(|&k| records.iter().map(move |record| &record[k]))
            .find(|&cell| cell != name)
        {
            return Err(format!("its rows are of the {other} model, not {name}").into());
        }
        if let Some(step) = self.reference_dt {
            if sweep.reference.candidate.time_step != TimeStep::Fixed(step) {
                return Err(format!(
                    "its reference is {}, not one of --reference-dt {}",
                    sweep.reference.candidate.label(),
                    format_g(step)
                )
                .into());
            }
        }
        let methods: Vec<Candidate> = sweep.runs.iter().map(|run| run.candidate).collect();
        let sampled_as_asked = sweep.runs.iter().all(|run| {
            let requested: Vec<f64> = run.samples.iter().map(|sample| sample.requested).collect();
            let whole = requested.len() == times.len() || run.failure.is_some();
            whole && requested.len() <= times.len() && requested == times[..requested.len()]
        });
        if methods != candidates || !sampled_as_asked {
            return Err(format!(
                "its methods or times are not these arguments' ({} methods at {} times \
                 asked): give the arguments of the sweep that wrote it",
                candidates.len(),
                times.len()
            )
            .into());
        }
        Ok(sweep)
    }

    /// Draws the charts of the accuracy CSV at `csv` (a merged array's) and reports its
    /// failures and choices, as the sweep itself does.
    pub fn chart(&self, csv: &Path, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
        let text = crate::io::input::read_regular_text(csv)
            .map_err(|error| format!("cannot read {}: {error}", csv.display()))?;
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let headers = reader.headers()?.clone();
        let Some(first) = reader.records().next().transpose()? else {
            return Err(format!("{}: the accuracy CSV has no rows", csv.display()).into());
        };
        let cell = |name: &str| {
            headers
                .iter()
                .position(|h| h == name)
                .and_then(|k| first.get(k))
                .unwrap_or("unknown")
                .to_string()
        };
        // The rows are of this scene: its file name, its particle count and (in a CSV
        // that has the column) the CRC-32 of its bytes.
        let start = self.start()?;
        let ours = &start.scene;
        let (scene, particles) = (cell("scene"), cell("particles"));
        if scene != ours.file_name || particles != ours.particles.to_string() {
            return Err(format!(
                "{}: its rows are of {scene} ({particles} particles), not of {} ({} \
                 particles): give the input or case its sweep ran",
                csv.display(),
                ours.file_name,
                ours.particles
            )
            .into());
        }
        let crc32 = cell(accuracy::SCENE_CRC_COLUMN);
        if crc32 != "unknown" && crc32 != format!("{:08x}", ours.crc32) {
            return Err(format!(
                "{}: its rows are of another {scene} (its bytes' CRC-32 {crc32}, not \
                 {:08x}): give the input or case its sweep ran",
                csv.display(),
                ours.crc32
            )
            .into());
        }
        // And of these arguments ([`Self::sweep_of`]).
        let sweep = self
            .sweep_of(&text)
            .map_err(|error| format!("{}: {error}", csv.display()))?;
        self.report(&sweep, &start, &cell("cpu_model"), &cell("commit"), stdout)
    }
}

/// Writes a run's sampled states to a folder as `K.obs`, K counting from 0; the first
/// write that fails is kept for [`States::finish`].
struct States {
    folder: PathBuf,
    written: usize,
    error: Option<String>,
}

impl States {
    /// Creates `folder` for the states.
    fn in_folder(folder: &Path) -> Result<States, String> {
        std::fs::create_dir_all(folder)
            .map_err(|error| format!("cannot create {}: {error}", folder.display()))?;
        Ok(States {
            folder: folder.to_path_buf(),
            written: 0,
            error: None,
        })
    }

    /// Writes the next state, whole or not at all.
    fn save(&mut self, fresh: &Simulation) {
        if self.error.is_some() {
            return;
        }
        let path = self.folder.join(format!("{}.obs", self.written));
        let bytes = Observed::of(fresh).encode();
        match OutputFile::create(&path).and_then(|file| file.commit(&bytes)) {
            Ok(()) => self.written += 1,
            Err(error) => self.error = Some(error.to_string()),
        }
    }

    /// The first write that failed, if one did.
    fn finish(self) -> Result<(), String> {
        self.error.map_or(Ok(()), Err)
    }
}

/// The names of the sweep's charts: error against cost, error against time, and the
/// convergence of each family of fixed steps.
const CHART_NAMES: [&str; 3] = ["accuracy-speed", "error-time", "convergence"];

/// Runs every method against the reference and writes the CSV, the charts and the
/// choices within the budgets (or, with `--from-csv`, only the charts and choices).
pub fn exec(mut args: AccuracyArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    args.read_case()?;
    // Its outputs replace neither its input nor the CSV it charts again.
    for read in [&args.input, &args.from_csv].into_iter().flatten() {
        crate::io::output::keep_intact(read);
    }
    let (times, candidates) = args.plan()?;
    let _folder = super::create_output_dir(&args.output_dir)?;
    super::try_charts(args.output_dir(), &CHART_NAMES)?;
    if let Some(csv) = &args.from_csv {
        return args.chart(csv, stdout);
    }
    // The CSV is opened before the runs, so an unwritable folder fails first.
    let csv_path = args.csv_path();
    let csv_file = OutputFile::create(&csv_path)?;
    let start = args.start()?;
    let sweep = accuracy::sweep(
        &start.simulation,
        args.model(),
        &candidates,
        &times,
        args.reference_dt,
        MOST_STEPS_TO_GO,
    )?;
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
        sweep.csv(&start.scene, args.model(), &machine)
    );
    csv_file.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    args.report(&sweep, &start, &machine.cpu_model, &machine.commit, stdout)
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
    let mut integrators: Vec<Integrator> = Vec::new();
    for run in &sweep.runs {
        if !integrators.contains(&run.candidate.integrator) {
            integrators.push(run.candidate.integrator);
        }
    }
    // With several integrators, the fastest of each, against the leapfrog's.
    let leapfrog = sweep.fastest_on(Some(Integrator::Leapfrog), metres, metric);
    let each: String = match integrators.len() > 1 {
        false => String::new(),
        true => integrators
            .iter()
            .map(|&integrator| {
                let name = integrator.name();
                match sweep.fastest_on(Some(integrator), metres, metric) {
                    None => format!("; {name}: none"),
                    Some(best) => {
                        let speed = match leapfrog {
                            Some(first) if integrator != Integrator::Leapfrog => format!(
                                ", {:.2}x the leapfrog's",
                                first.final_cost() / best.final_cost()
                            ),
                            _ => String::new(),
                        };
                        format!(
                            "; {name}: {} ({:.3}{speed})",
                            best.candidate.label(),
                            best.final_cost()
                        )
                    }
                }
            })
            .collect(),
    };
    format!(
        "{within}: {} ({cost:.3} CPU s per simulated s{against}){each}",
        run.candidate.label()
    )
}

/// Where the charts' data come from.
fn footer(
    sweep: &Sweep,
    scene: &str,
    particles: usize,
    model: Model,
    cpu_model: &str,
    commit: &str,
) -> String {
    let failed = sweep
        .runs
        .iter()
        .filter(|run| run.failure.is_some())
        .count();
    format!(
        "{scene}, {particles} particles, {}; {}, commit {}; against {} ({:.0} CPU s per \
         simulated s){}",
        model.name(),
        cpu_model,
        commit,
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
        name: CHART_NAMES[0],
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
        measured: 0,
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

/// The error by `metric` at the last time against the fixed step, log-log, a line per
/// kernel and integrator with its fitted order (over its shortest steps) in the legend.
fn convergence_chart(
    families: &[Convergence],
    times: &[f64],
    metric: Metric,
    scene: &str,
    footer: &str,
) -> PointChart {
    let at = times.last().map_or(0.0, |t| t * 1e3);
    PointChart {
        name: CHART_NAMES[2],
        title: format!("Error against time step at {at} ms, {scene}"),
        x_label: "time step (ms)".into(),
        x_log: true,
        y_log: true,
        y_label: format!("{} position error (m)", metric.name()),
        measured: 0,
        series: families
            .iter()
            .map(|family| {
                let order = family.order.map_or("no slope".to_string(), |order| {
                    format!(
                        "slope {order:.2} (shortest {} steps)",
                        accuracy::ORDER_STEPS
                    )
                });
                let label = format!(
                    "{} {}: {order}",
                    family.kernel.name(),
                    family.integrator.name()
                );
                let points = family.points.iter().map(|&(dt, e)| (dt * 1e3, e));
                (label, points.collect())
            })
            .collect(),
        fronts: Vec::new(),
        lines: true,
        legend: SeriesLabelPosition::LowerRight,
        notes: Vec::new(),
        footer: footer.to_string(),
    }
}

/// The position error by `metric` against physical time, one line per method.
fn time_chart(sweep: &Sweep, metric: Metric, scene: &str, footer: &str) -> PointChart {
    PointChart {
        name: CHART_NAMES[1],
        title: format!("Error against time, {scene}"),
        x_label: "physical time (ms)".into(),
        x_log: false,
        y_log: true,
        y_label: format!("{} position error (m)", metric.name()),
        measured: 0,
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
