//! Where methods fail: a scene run over a grid of time steps and resolutions, each run
//! checked after every step (non-finite values, particles more than h outside the box,
//! kinetic plus potential energy above 1.5 times the first) until it fails or reaches the
//! simulated time asked for; and the map of the outcomes.

use crate::lab::chart::Drawing;
use crate::lab::diagnostics::{self, Checks, Failure, Vitals};
use crate::lab::scene::{self, SceneKind};
use crate::sim::method::Method;
use crate::sim::params::Domain;
use crate::sim::simulation::Simulation;
use crate::sim::timestep::{Integrator, TimeStep};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::error::Error;

/// The CSV header of [`Outcome::csv_row`] (a CSV without its last column, `dimensions`,
/// was written before 2-D runs and reads as 3-D).
pub const CSV_HEADER: &str = "scene,model,kernel,ppm,time_step,dt_s,courant,particles,\
                              duration_s,steps,failed_step,failed_time_s,reason,detail,\
                              integrator,dimensions";

/// How one run ended.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The scene run.
    pub scene: SceneKind,
    /// The model and kernel.
    pub method: Method,
    /// Particles per metre.
    pub ppm: f64,
    /// How its steps' lengths were chosen.
    pub time_step: TimeStep,
    /// How its steps advanced the state.
    pub integrator: Integrator,
    /// Particles in the scene.
    pub particles: usize,
    /// Simulated seconds asked for.
    pub duration: f64,
    /// Steps run.
    pub steps: u64,
    /// The step after which the run failed, its time, and why; `None` if it ran to the end.
    pub failure: Option<(u64, f64, Failure)>,
    /// 2 for the scene's section in the plane (the water model's), or 3.
    pub dimensions: usize,
}

/// A time-step rule's short name: `0.001` (seconds) or `C 0.3`.
pub fn rule_name(time_step: TimeStep) -> String {
    match time_step {
        TimeStep::Fixed(dt) => format!("{dt}"),
        TimeStep::Adaptive { courant } => format!("C {courant}"),
    }
}

impl Outcome {
    /// One CSV row, in the order of [`CSV_HEADER`].
    pub fn csv_row(&self) -> String {
        let (step, time, reason, detail) = match &self.failure {
            Some((step, time, failure)) => (
                step.to_string(),
                format!("{time:.6}"),
                failure.name(),
                failure.to_string(),
            ),
            None => (String::new(), String::new(), "stable", String::new()),
        };
        let rule = match self.time_step {
            TimeStep::Fixed(dt) => format!("fixed,{dt},"),
            TimeStep::Adaptive { courant } => format!("adaptive,,{courant}"),
        };
        format!(
            "{},{},{},{},{rule},{},{},{},{step},{time},{reason},{detail},{},{}",
            self.scene.name(),
            self.method.model.name(),
            self.method.kernel.name(),
            self.ppm,
            self.particles,
            self.duration,
            self.steps,
            self.integrator.name(),
            self.dimensions
        )
    }

    /// One line for people: `course simd leapfrog, ppm 150, dt 0.001: failed at step 3
    /// (0.003 s): ...` (`wcsph simd8 leapfrog 2-D, ...` in the plane).
    pub fn summary(&self) -> String {
        let plane = if self.dimensions == 2 { " 2-D" } else { "" };
        let run = format!(
            "{} {} {}{plane}, ppm {}, {}",
            self.method.model.name(),
            self.method.kernel.name(),
            self.integrator.name(),
            self.ppm,
            match self.time_step {
                TimeStep::Fixed(dt) => format!("dt {dt} s"),
                TimeStep::Adaptive { courant } => format!("adaptive C {courant}"),
            }
        );
        match &self.failure {
            Some((step, time, failure)) => {
                format!("{run}: failed at step {step} ({time:.3} s): {failure}")
            }
            None => format!(
                "{run}: stable for {} steps ({:.3} s)",
                self.steps, self.duration
            ),
        }
    }
}

/// The outcomes of a stability CSV (its columns by name, so that further columns, such
/// as a Slurm array's, are let be), in its order.
pub fn read_csv(text: &str) -> Result<Vec<Outcome>, String> {
    use clap::ValueEnum;
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let headers = reader.headers().map_err(|error| error.to_string())?.clone();
    // Every column but the last, `dimensions`, which older CSVs lack.
    let dimensions = headers.iter().position(|header| header == "dimensions");
    let columns: Vec<usize> = CSV_HEADER
        .split(',')
        .filter(|&name| name != "dimensions")
        .map(|name| {
            headers
                .iter()
                .position(|header| header == name)
                .ok_or_else(|| format!("the stability CSV has no column {name}"))
        })
        .collect::<Result<_, _>>()?;
    let mut outcomes = Vec::new();
    for (line, record) in reader.records().enumerate() {
        let record = record.map_err(|error| error.to_string())?;
        let bad = |what: &str| format!("row {}: {what}", line + 2);
        let cell = |k: usize| &record[columns[k]];
        // A resolution, step, Courant number, duration or time: a finite number >= 0.
        let number = |k: usize| -> Result<f64, String> {
            match cell(k).parse::<f64>() {
                Ok(value) if value.is_finite() && value >= 0.0 => Ok(value),
                Ok(_) => Err(bad(&format!(
                    "{} is {}, not a finite number >= 0",
                    &headers[columns[k]],
                    cell(k)
                ))),
                Err(_) => Err(bad(&format!("{:?} is not a number", cell(k)))),
            }
        };
        let named = |k: usize| bad(&format!("unknown {} {:?}", &headers[columns[k]], cell(k)));
        let scene = SceneKind::from_str(cell(0), false).map_err(|_| named(0))?;
        let model = crate::sim::model::Model::from_str(cell(1), false).map_err(|_| named(1))?;
        let kernel = crate::sim::kernel::Kernel::from_str(cell(2), false).map_err(|_| named(2))?;
        let time_step = match cell(4) {
            "fixed" => TimeStep::Fixed(number(5)?),
            "adaptive" => TimeStep::Adaptive {
                courant: number(6)?,
            },
            _ => return Err(named(4)),
        };
        let count = |k: usize| -> Result<u64, String> {
            cell(k)
                .parse()
                .map_err(|_| bad(&format!("{:?} is not a count", cell(k))))
        };
        let failure = match cell(12) {
            "stable" => None,
            reason => Some((
                count(10)?,
                number(11)?,
                Failure::parse(reason, cell(13)).ok_or_else(|| named(12))?,
            )),
        };
        let integrator = Integrator::from_str(cell(14), false).map_err(|_| named(14))?;
        let dimensions = match dimensions.map(|k| &record[k]) {
            None | Some("3") => 3,
            Some("2") => 2,
            Some(other) => return Err(bad(&format!("dimensions is {other:?}, not 2 or 3"))),
        };
        outcomes.push(Outcome {
            scene,
            method: Method { model, kernel },
            ppm: number(3)?,
            time_step,
            integrator,
            particles: count(7)? as usize,
            duration: number(8)?,
            steps: count(9)?,
            failure,
            dimensions,
        });
    }
    Ok(outcomes)
}

/// The box a scene runs in: the course's, or in 2 `dimensions` its section at `ppm`.
pub fn domain(dimensions: usize, ppm: f64) -> Domain {
    match dimensions {
        2 => Domain::COURSE.section(ppm),
        _ => Domain::COURSE,
    }
}

/// Runs `scene` (seed `seed`, in `dimensions`: 2 for the section of the course's box in
/// the plane, a lattice scene on the water model) at `ppm` with `method`, `integrator`
/// and `time_step` until it has simulated `duration` seconds (finite and positive),
/// checking every step; an adaptive step below `shortest_step` seconds fails it
/// (step-collapsed).
pub fn watch(
    (scene, seed, dimensions): (SceneKind, u64, usize),
    (method, integrator): (Method, Integrator),
    ppm: f64,
    time_step: TimeStep,
    duration: f64,
    shortest_step: f64,
) -> Result<Outcome, String> {
    if !(duration.is_finite() && duration > 0.0) {
        return Err(format!("a duration of {duration} s is not a run"));
    }
    let domain = domain(dimensions, ppm);
    let particles = match (dimensions, scene.regions()) {
        (2, Some(regions)) => scene::filled(ppm, seed, &regions, &domain)
            .map_err(|error| format!("the {} in 2-D at {ppm} per metre: {error}", scene.name()))?,
        (2, None) => return Err(format!("the {} is no lattice scene for 2-D", scene.name())),
        _ => scene::generate(scene, ppm, seed, None)?,
    };
    let count = particles.len();
    let simulation = match domain.planar {
        true => Simulation::with_dynamics(ppm, domain, particles, method, method.model.dynamics()),
        false => Simulation::with_method(ppm, particles, method),
    };
    let mut simulation = simulation.map_err(|error| error.to_string())?;
    simulation.set_time_step(time_step);
    simulation.set_integrator(integrator);
    let checks = Checks::from(&Vitals::of(&simulation));
    let (mut steps, mut failure) = (0, None);
    while !simulation.has_reached(duration) {
        simulation.step();
        steps += 1;
        if diagnostics::step_collapsed(&simulation, shortest_step) {
            failure = Some((steps, simulation.time(), Failure::StepCollapsed));
            break;
        }
        if let Some(reason) = checks.failure(&Vitals::of(&simulation)) {
            failure = Some((steps, simulation.time(), reason));
            break;
        }
    }
    Ok(Outcome {
        scene,
        method,
        ppm,
        time_step,
        integrator,
        particles: count,
        duration,
        steps,
        failure,
        dimensions: domain.dimensions(),
    })
}

/// Pixel height of the map, and its width per cell column (it is at least 1100 wide).
const HEIGHT: u32 = 520;
const COLUMN_WIDTH: u32 = 72;

/// The outcomes as one grid per model, kernel and integrator (columns: fixed time steps, then
/// adaptive constants; rows: ppm), each cell green if stable, else red, darker the sooner
/// it failed, with the failure step, time and reason: `stability-map.png` and `.svg`
/// through [`crate::lab::chart::render`], [`StabilityMap::size`] pixels.
pub struct StabilityMap<'a> {
    /// The runs.
    pub outcomes: &'a [Outcome],
    /// Where the data come from.
    pub footer: String,
}

impl StabilityMap<'_> {
    /// The map's pixel size: wide enough for every panel's columns.
    pub fn size(&self) -> (u32, u32) {
        let (methods, rules) = (methods(self.outcomes), rules(self.outcomes));
        let width = 150 + methods.len() as u32 * (30 + rules.len() as u32 * COLUMN_WIDTH);
        (width.max(1100), HEIGHT)
    }
}

/// The distinct methods (with their integrators) of `outcomes`, in their order.
fn methods(outcomes: &[Outcome]) -> Vec<(Method, Integrator)> {
    let mut methods: Vec<(Method, Integrator)> = Vec::new();
    for outcome in outcomes {
        if !methods.contains(&(outcome.method, outcome.integrator)) {
            methods.push((outcome.method, outcome.integrator));
        }
    }
    methods
}

/// The distinct time-step rules of `outcomes`: fixed steps ascending, then adaptive
/// constants ascending.
fn rules(outcomes: &[Outcome]) -> Vec<TimeStep> {
    let key = |rule: &TimeStep| match *rule {
        TimeStep::Fixed(dt) => (0, dt),
        TimeStep::Adaptive { courant } => (1, courant),
    };
    let mut rules: Vec<TimeStep> = outcomes.iter().map(|o| o.time_step).collect();
    rules.sort_by(|a, b| key(a).0.cmp(&key(b).0).then(key(a).1.total_cmp(&key(b).1)));
    rules.dedup();
    rules
}

impl Drawing for StabilityMap<'_> {
    fn name(&self) -> &str {
        "stability-map"
    }

    fn draw_on<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, Shift>,
    ) -> Result<(), Box<dyn Error>>
    where
        DB::ErrorType: 'static,
    {
        draw_map(&root, self.outcomes, &self.footer)
    }
}

/// The distinct values of `values`, ascending.
fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut values: Vec<f64> = values.collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    values
}

fn draw_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    outcomes: &[Outcome],
    footer: &str,
) -> Result<(), Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (width, height) = root.dim_in_pixel();
    let (methods, rules) = (methods(outcomes), rules(outcomes));
    let ppms = distinct(outcomes.iter().map(|o| o.ppm));
    let scene = outcomes.first().map_or("", |o| o.scene.name());
    root.draw(&Text::new(
        format!("Where each method fails: {scene}, by time step and particles per metre"),
        (30, 14),
        ("sans-serif", 22),
    ))?;
    let (left, top, cell_h) = (110, 90, 90.min(340 / ppms.len().max(1) as i32));
    let panel_w = (width as i32 - left - 40) / methods.len().max(1) as i32;
    let cell_w = (panel_w - 30) / rules.len().max(1) as i32;
    let centred = Pos::new(HPos::Center, VPos::Center);
    for (m, &(method, integrator)) in methods.iter().enumerate() {
        let x0 = left + m as i32 * panel_w;
        let title = format!(
            "{} {} {}",
            method.model.name(),
            method.kernel.name(),
            integrator.name()
        );
        root.draw(&Text::new(title, (x0, top - 40), ("sans-serif", 18)))?;
        for (c, rule) in rules.iter().enumerate() {
            let x = x0 + c as i32 * cell_w;
            let style = ("sans-serif", 13).into_text_style(root).pos(centred);
            root.draw(&Text::new(
                rule_name(*rule),
                (x + cell_w / 2, top - 14),
                style,
            ))?;
            for (r, ppm) in ppms.iter().rev().enumerate() {
                let y = top + r as i32 * cell_h;
                if m == 0 && c == 0 {
                    let style = ("sans-serif", 13).into_text_style(root).pos(centred);
                    root.draw(&Text::new(
                        format!("ppm {ppm}"),
                        (left - 50, y + cell_h / 2),
                        style,
                    ))?;
                }
                let Some(outcome) = outcomes.iter().find(|o| {
                    (o.method, o.integrator) == (method, integrator)
                        && o.time_step == *rule
                        && o.ppm == *ppm
                }) else {
                    continue;
                };
                let (colour, lines) = match &outcome.failure {
                    None => (
                        RGBColor(120, 200, 120),
                        vec!["stable".to_string(), format!("{} steps", outcome.steps)],
                    ),
                    Some((step, time, failure)) => {
                        let fraction = time / outcome.duration;
                        let shade = (120.0 + 135.0 * fraction.sqrt()) as u8;
                        (
                            RGBColor(shade.max(150), 60, 50),
                            vec![
                                format!("step {step}"),
                                format!("{time:.3} s"),
                                failure.name().to_string(),
                            ],
                        )
                    }
                };
                root.draw(&Rectangle::new(
                    [(x + 1, y + 1), (x + cell_w - 1, y + cell_h - 1)],
                    colour.filled(),
                ))?;
                let count = lines.len() as i32;
                for (k, line) in lines.iter().enumerate() {
                    let dy = (2 * k as i32 - count + 1) * 8;
                    let style = ("sans-serif", 12)
                        .into_text_style(root)
                        .pos(centred)
                        .color(&WHITE);
                    root.draw(&Text::new(
                        line.clone(),
                        (x + cell_w / 2, y + cell_h / 2 + dy),
                        style,
                    ))?;
                }
            }
        }
        let bottom = top + ppms.len() as i32 * cell_h + 18;
        root.draw(&Text::new(
            "time step: dt (s), or adaptive C",
            (x0, bottom),
            ("sans-serif", 14),
        ))?;
    }
    root.draw(&Text::new(
        footer,
        (30, height as i32 - 24),
        ("sans-serif", 12).into_font().color(&BLACK.mix(0.7)),
    ))?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::kernel::Kernel;
    use crate::sim::model::Model;

    const SIMD: Method = Method {
        model: Model::Course,
        kernel: Kernel::Simd,
    };
    const LEAPFROG: Integrator = Integrator::Leapfrog;

    #[test]
    fn the_course_model_fails_where_the_stable_one_does_not() {
        let fixed = TimeStep::Fixed(1e-3);
        let course = watch(
            (SceneKind::DamBreak, 1, 3),
            (SIMD, LEAPFROG),
            100.0,
            fixed,
            0.05,
            1e-5,
        )
        .unwrap();
        let (step, time, failure) = course.failure.expect("the course model fails");
        assert!(step <= 50, "{}", course.summary());
        assert!((time - step as f64 * 1e-3).abs() < 1e-12);
        assert!(course.summary().contains(&format!("failed at step {step}")));
        assert!(course.csv_row().contains(failure.name()));
        let stable_method = Method {
            model: Model::Fluidanimate,
            ..SIMD
        };
        let stable = watch(
            (SceneKind::DamBreak, 1, 3),
            (stable_method, LEAPFROG),
            100.0,
            fixed,
            0.05,
            1e-5,
        )
        .unwrap();
        assert_eq!(stable.failure, None, "{}", stable.summary());
        assert_eq!(stable.steps, 50);
        assert!(
            stable.csv_row().ends_with(",0.05,50,,,stable,,leapfrog,3"),
            "{}",
            stable.csv_row()
        );
        assert_eq!(
            CSV_HEADER.split(',').count(),
            stable.csv_row().split(',').count()
        );
    }

    #[test]
    fn adaptive_runs_step_until_the_duration_and_bad_durations_are_refused() {
        let adaptive = TimeStep::Adaptive { courant: 0.3 };
        let method = Method {
            model: Model::Fluidanimate,
            ..SIMD
        };
        let outcome = watch(
            (SceneKind::DamBreak, 1, 3),
            (method, LEAPFROG),
            100.0,
            adaptive,
            0.02,
            1e-5,
        )
        .unwrap();
        assert_eq!(outcome.failure, None, "{}", outcome.summary());
        assert!(outcome.steps > 1, "{}", outcome.summary());
        assert!(outcome.summary().contains("adaptive C 0.3"));
        assert!(outcome.csv_row().contains(",adaptive,,0.3,"));
        for duration in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(watch(
                (SceneKind::DamBreak, 1, 3),
                (method, LEAPFROG),
                100.0,
                adaptive,
                duration,
                1e-5
            )
            .is_err());
        }
        // A step longer than the duration is still one step, judged as any other.
        let once = watch(
            (SceneKind::DamBreak, 1, 3),
            (method, LEAPFROG),
            100.0,
            TimeStep::Fixed(1e3),
            0.5,
            1e-5,
        );
        assert_eq!(once.unwrap().steps, 1);
        // An adaptive step below the limit: the course model's viscosity at 100 particles
        // per metre allows 0.12 ms at C 0.3, so a limit of 1 ms fails it at once.
        let short = watch(
            (SceneKind::DamBreak, 1, 3),
            (SIMD, LEAPFROG),
            100.0,
            adaptive,
            0.01,
            1e-3,
        )
        .unwrap();
        let (step, _, failure) = short.failure.expect("the step is below the limit");
        assert_eq!(
            (step, failure),
            (1, Failure::StepCollapsed),
            "{}",
            short.summary()
        );
    }

    #[test]
    fn the_map_is_a_valid_png_and_svg() {
        let outcomes: Vec<Outcome> = [TimeStep::Fixed(1e-3), TimeStep::Adaptive { courant: 0.5 }]
            .iter()
            .map(|&rule| {
                watch(
                    (SceneKind::DamBreak, 1, 3),
                    (SIMD, LEAPFROG),
                    100.0,
                    rule,
                    0.01,
                    1e-5,
                )
                .unwrap()
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let map = StabilityMap {
            outcomes: &outcomes,
            footer: "test".into(),
        };
        let size = map.size();
        let [png, svg] = crate::lab::chart::render(&map, dir.path(), size).unwrap();
        let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
        let info = decoder.read_info().unwrap();
        assert_eq!((info.info().width, info.info().height), size);
        let text = std::fs::read_to_string(&svg).unwrap();
        let document = roxmltree::Document::parse(&text).unwrap();
        for label in ["course simd leapfrog", "C 0.5", "0.001"] {
            assert!(
                document
                    .descendants()
                    .any(|n| n.text().map(str::trim) == Some(label)),
                "{label}"
            );
        }
    }

    #[test]
    fn outcomes_read_back_from_their_csv_rows_with_columns_added() {
        let outcome = |model, ppm, time_step, failure| Outcome {
            scene: SceneKind::Drop,
            method: Method {
                model,
                kernel: Kernel::Mixed,
            },
            ppm,
            time_step,
            integrator: Integrator::Verlet,
            particles: 1234,
            duration: 0.5,
            steps: 77,
            failure,
            dimensions: if model == Model::Wcsph { 2 } else { 3 },
        };
        let outcomes = [
            outcome(Model::Course, 150.0, TimeStep::Fixed(2.5e-4), None),
            outcome(
                Model::Wcsph,
                300.0,
                TimeStep::Adaptive { courant: 0.3 },
                Some((76, 0.012345, Failure::LeftBox(3))),
            ),
            outcome(
                Model::Fluidanimate,
                100.0,
                TimeStep::Fixed(4e-3),
                Some((5, 0.02, Failure::EnergyGrew(2.5))),
            ),
        ];
        let mut text = format!("{CSV_HEADER},slurm_node\n");
        for outcome in &outcomes {
            text.push_str(&format!("{},node-7\n", outcome.csv_row()));
        }
        assert_eq!(read_csv(&text).unwrap(), outcomes);
        // A CSV from before 2-D runs, without the dimensions column, reads as 3-D.
        let older: String = text
            .lines()
            .map(|line| {
                let (kept, _) = line.rsplit_once(',').unwrap();
                let (kept, _) = kept.rsplit_once(',').unwrap();
                format!("{kept}\n")
            })
            .collect();
        let read = read_csv(&older).unwrap();
        assert!(read.iter().all(|outcome| outcome.dimensions == 3));
        assert_eq!(read[0], outcomes[0]);
        let odd = text.replacen(",2,node-7", ",4,node-7", 1);
        assert_eq!(
            read_csv(&odd).unwrap_err(),
            "row 3: dimensions is \"4\", not 2 or 3"
        );
        let renamed = text.replacen("reason", "why", 1);
        assert_eq!(
            read_csv(&renamed).unwrap_err(),
            "the stability CSV has no column reason"
        );
        let broken = text.replacen("left-box", "melted", 1);
        assert!(read_csv(&broken)
            .unwrap_err()
            .starts_with("row 3: unknown reason"));
        // A step, a duration or a time that is no finite number >= 0 (a shard edited by
        // hand): refused at its row, where it was merged as it was.
        let fixed = text.lines().nth(3).unwrap();
        for bad in ["nan", "inf", "-0.004"] {
            let edited = text.replacen(fixed, &fixed.replacen("0.004", bad, 1), 1);
            assert_eq!(
                read_csv(&edited).unwrap_err(),
                format!("row 4: dt_s is {bad}, not a finite number >= 0"),
                "{edited}"
            );
        }
    }
}
