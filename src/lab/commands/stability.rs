//! `fluid-lab stability`: a scene over time steps and resolutions, each run watched until
//! it fails; a CSV and the stability map.

use super::simulation_args::{
    parse_courants, parse_particles_per_metre, Courants, MOST_STEPS_TO_GO,
};
use crate::io::gformat::format_g;
use crate::io::output::OutputFile;
use crate::lab::chart;
use crate::lab::machine::Machine;
use crate::lab::scene::{check_grid, SceneKind};
use crate::lab::stability::{self, rule_name, Outcome};
use crate::lab::UsageError;
use crate::sim::kernel::Kernel;
use crate::sim::method::Method;
use crate::sim::model::Model;
use crate::sim::params::TIME_STEP;
use crate::sim::timestep::{is_time, Integrator, TimeStep};
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab stability`.
#[derive(Debug, Args)]
pub struct StabilityArgs {
    /// Folder for stability.csv and stability-map.{png,svg}.
    #[arg(long)]
    output_dir: PathBuf,
    /// The scene run.
    #[arg(long, value_enum, default_value_t = SceneKind::DamBreak)]
    scene: SceneKind,
    /// Seed of the scene.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = super::whole::<u64>(0, u64::MAX))]
    seed: u64,
    /// Models to run [default: every model; in 2-D the water model, wcsph]
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1..)]
    models: Option<Vec<Model>>,
    /// 2 to run the scene's section in the plane of the course box's x-y section (the
    /// water model, a lattice scene: dam-break, drop or filled-box), or 3.
    #[arg(long, allow_negative_numbers = true, default_value_t = 3,
          value_parser = super::whole::<usize>(2, 3))]
    dimensions: usize,
    /// Kernels to run each model with (their precision is part of the method).
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = [Kernel::NATIVE])]
    kernels: Vec<Kernel>,
    /// Integrators to run each model and kernel with.
    #[arg(long, value_enum, value_delimiter = ',', num_args = 1.., default_values_t = [Integrator::Leapfrog])]
    integrators: Vec<Integrator>,
    /// Particles per metre of the scene.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1..,
          default_values_t = [100.0, 150.0, 200.0, 300.0], value_parser = parse_particles_per_metre)]
    ppms: Vec<f64>,
    /// Time steps, as multiples of the course's 1e-3 s.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', num_args = 1.., default_values_t = [0.25, 0.5, 1.0, 2.0, 4.0], value_parser = super::number)]
    dt_factors: Vec<f64>,
    /// Courant constants of adaptive time steps to run beside the fixed ones ("" for
    /// none).
    #[arg(long, allow_negative_numbers = true, default_value = "0.3", num_args = 1.., value_parser = parse_courants)]
    adaptive: Vec<Courants>,
    /// Simulated seconds each run must last to count as stable.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5, value_parser = super::number)]
    duration: f64,
    /// Shortest adaptive step a run may take (s); a shorter one fails it as collapsed
    /// (the default, a hundredth of the course's step, keeps the map to minutes).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-5, value_parser = super::number)]
    shortest_step: f64,
}

/// One run of the map: its method, integrator, particles per metre and time-step rule.
type Cell = (Method, Integrator, f64, TimeStep);

impl StabilityArgs {
    /// The models asked for, or the default of the dimensions.
    fn models(&self) -> Vec<Model> {
        match (&self.models, self.dimensions) {
            (Some(models), _) => models.clone(),
            (None, 2) => vec![Model::Wcsph],
            (None, _) => Model::ALL.to_vec(),
        }
    }

    /// The runs asked for, checked: every cell, in the map's order.
    fn cells(&self) -> Result<Vec<Cell>, Box<dyn Error>> {
        let refuse = |message: String| -> Result<Vec<Cell>, Box<dyn Error>> {
            Err(UsageError(message).into())
        };
        if self.dimensions == 2 {
            if let Some(model) = self.models().into_iter().find(|&m| m != Model::Wcsph) {
                return refuse(format!(
                    "--dimensions 2 runs the water model (wcsph), not {}",
                    model.name()
                ));
            }
            if self.scene.regions().is_none() {
                return refuse(format!(
                    "--dimensions 2 runs a lattice scene (dam-break, drop or filled-box), not \
                     the {}",
                    self.scene.name()
                ));
            }
        }
        for &factor in &self.dt_factors {
            if !is_time(factor * TIME_STEP) {
                return refuse(format!(
                    "--dt-factors: {factor} does not give a positive time step"
                ));
            }
        }
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return refuse(format!(
                "--duration: {} is not a positive, finite time",
                self.duration
            ));
        }
        if !(self.shortest_step.is_finite() && self.shortest_step > 0.0) {
            return refuse(format!(
                "--shortest-step: {} is not a positive step",
                self.shortest_step
            ));
        }
        // The shortest step a run may take: the smallest fixed one, or the adaptive floor.
        let adaptive = !Courants::all(&self.adaptive).is_empty();
        let fixed = (self.dt_factors.iter()).map(|factor| factor * TIME_STEP);
        let shortest = fixed
            .chain(adaptive.then_some(self.shortest_step))
            .fold(f64::INFINITY, f64::min);
        // A run is a number of steps: no fixed step longer than the run.
        let longest =
            (self.dt_factors.iter()).fold(0.0, |a: f64, factor| a.max(factor * TIME_STEP));
        if longest > self.duration {
            return refuse(format!(
                "--dt-factors: a step of {} s is longer than --duration {} s",
                format_g(longest),
                format_g(self.duration)
            ));
        }
        let steps = self.duration / shortest;
        if steps > MOST_STEPS_TO_GO {
            return refuse(format!(
                "--duration {} s on steps of {} s would take {steps:.3e} steps a run, more \
                 than the {MOST_STEPS_TO_GO:.0e} a run may take",
                format_g(self.duration),
                format_g(shortest)
            ));
        }
        let rules: Vec<TimeStep> = self
            .dt_factors
            .iter()
            .map(|factor| TimeStep::Fixed(factor * TIME_STEP))
            .chain(
                Courants::all(&self.adaptive)
                    .into_iter()
                    .map(|courant| TimeStep::Adaptive { courant }),
            )
            .collect();
        let repeated = [
            ("--ppms", super::repeats(&self.ppms)),
            ("--dt-factors", super::repeats(&self.dt_factors)),
            ("--adaptive", super::repeats(&Courants::all(&self.adaptive))),
            ("--kernels", super::repeats(&self.kernels)),
            ("--integrators", super::repeats(&self.integrators)),
            ("--models", super::repeats(&self.models())),
        ];
        if let Some((flag, _)) = repeated.iter().find(|(_, repeats)| *repeats) {
            return refuse(format!("{flag} names each value once"));
        }
        // Each resolution admits each model's grid (its own cut-off, in the domain run):
        // a usage error before anything is made or submitted.
        for &ppm in &self.ppms {
            let why = |error| UsageError(format!("--ppms {}: {error}", format_g(ppm)));
            let domain = stability::domain(self.dimensions, ppm);
            for model in self.models() {
                let cutoff = model.dynamics().cutoff(ppm);
                check_grid(ppm, cutoff, &domain).map_err(why)?;
            }
        }
        let mut cells = Vec::new();
        for model in self.models() {
            for &kernel in &self.kernels {
                for &integrator in &self.integrators {
                    for &ppm in &self.ppms {
                        for &rule in &rules {
                            cells.push((Method { model, kernel }, integrator, ppm, rule));
                        }
                    }
                }
            }
        }
        Ok(cells)
    }

    /// Watches one run.
    fn watch(&self, (method, integrator, ppm, rule): Cell) -> Result<Outcome, String> {
        stability::watch(
            (self.scene, self.seed, self.dimensions),
            (method, integrator),
            ppm,
            rule,
            self.duration,
            self.shortest_step,
        )
    }

    /// The points a Slurm array runs, one a task: each run of the map.
    pub fn points(&self) -> Result<Vec<String>, Box<dyn Error>> {
        Ok(self
            .cells()?
            .into_iter()
            .map(|(method, integrator, ppm, rule)| {
                format!(
                    "{} {} {}{}, ppm {ppm}, {}",
                    method.model.name(),
                    method.kernel.name(),
                    integrator.name(),
                    if self.dimensions == 2 { " 2-D" } else { "" },
                    rule_name(rule)
                )
            })
            .collect())
    }

    /// Watches point `index` of [`StabilityArgs::points`] alone: its CSV.
    pub fn watch_point(&self, index: usize) -> Result<Vec<u8>, Box<dyn Error>> {
        let cell = *self
            .cells()?
            .get(index)
            .ok_or_else(|| format!("the map has no point {index}"))?;
        let outcome = self.watch(cell)?;
        eprintln!("{}", outcome.summary());
        Ok(format!("{}\n{}\n", stability::CSV_HEADER, outcome.csv_row()).into_bytes())
    }

    /// The folder of the CSV and the map.
    pub fn output_dir(&self) -> &Path {
        &self.output_dir
    }

    /// The stability.csv these arguments write.
    pub fn csv_path(&self) -> PathBuf {
        self.output_dir.join("stability.csv")
    }

    /// The map of `outcomes`, drawn and not yet written into the output folder.
    fn drawn(&self, outcomes: &[Outcome]) -> Result<chart::DrawnChart, Box<dyn Error>> {
        let machine = Machine::this();
        let footer = format!(
            "{}{} seed {}, {} s each; fails on: non-finite values, particles more than h outside the \
             box, energy above 1.5 x the first; commit {}",
            self.scene.name(),
            if self.dimensions == 2 { " (2-D)" } else { "" },
            self.seed,
            self.duration,
            machine.commit
        );
        let map = stability::StabilityMap { outcomes, footer };
        let files = chart::ChartFiles::open(&self.output_dir, chart::Drawing::name(&map))?;
        files.draw(&map, map.size())
    }

    /// Draws the map of `outcomes` into the output folder.
    pub fn draw(
        &self,
        outcomes: &[Outcome],
        stdout: &mut impl Write,
    ) -> Result<(), Box<dyn Error>> {
        for path in self.drawn(outcomes)?.commit()? {
            writeln!(stdout, "wrote {}", path.display())?;
        }
        Ok(())
    }
}

/// Watches every (model, ppm, time step) run and writes the CSV and the map.
pub fn exec(args: StabilityArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let cells = args.cells()?;
    let _folder = super::create_output_dir(&args.output_dir)?;
    // The CSV is opened before the runs, so an unwritable folder fails first.
    let csv_path = args.csv_path();
    let csv_file = OutputFile::create(&csv_path)?;
    let mut rows = format!("{}\n", stability::CSV_HEADER);
    let mut outcomes = Vec::new();
    for cell in cells {
        let outcome = args.watch(cell)?;
        writeln!(stdout, "{}", outcome.summary())?;
        rows.push_str(&outcome.csv_row());
        rows.push('\n');
        outcomes.push(outcome);
    }
    // The map drawn before the CSV is written: a disk too full for it leaves neither.
    let map = args.drawn(&outcomes)?;
    csv_file.commit(rows.as_bytes())?;
    writeln!(stdout, "wrote {}", csv_path.display())?;
    for path in map.commit()? {
        writeln!(stdout, "wrote {}", path.display())?;
    }
    Ok(())
}
