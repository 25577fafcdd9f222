//! Where methods fail: a scene run over a grid of time steps and resolutions, each run
//! checked after every step (non-finite values, particles more than h outside the box,
//! kinetic plus potential energy above 1.5 times the first) until it fails or reaches the
//! simulated time asked for; and the map of the outcomes.

use crate::lab::chart::Drawing;
use crate::lab::diagnostics::{Checks, Failure, Vitals};
use crate::lab::scene::{self, SceneKind};
use crate::sim::method::{Kernel, Method, Model};
use crate::sim::params::Params;
use crate::sim::simulation::Simulation;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::error::Error;

/// The CSV header of [`Outcome::csv_row`].
pub const CSV_HEADER: &str =
    "scene,model,ppm,dt_s,particles,steps,failed_step,failed_time_s,reason,detail";

/// How one run ended.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The scene run.
    pub scene: SceneKind,
    /// The model.
    pub model: Model,
    /// Particles per metre.
    pub ppm: f64,
    /// Time step.
    pub dt: f64,
    /// Particles in the scene.
    pub particles: usize,
    /// Steps asked for.
    pub steps: u64,
    /// The step after which the run failed, and why; `None` if it ran to the end.
    pub failure: Option<(u64, Failure)>,
}

impl Outcome {
    /// One CSV row, in the order of [`CSV_HEADER`].
    pub fn csv_row(&self) -> String {
        let (step, time, reason, detail) = match &self.failure {
            Some((step, failure)) => (
                step.to_string(),
                format!("{:.6}", *step as f64 * self.dt),
                failure.name(),
                failure.to_string(),
            ),
            None => (String::new(), String::new(), "stable", String::new()),
        };
        format!(
            "{},{},{},{},{},{},{step},{time},{reason},{detail}",
            self.scene.name(),
            self.model.name(),
            self.ppm,
            self.dt,
            self.particles,
            self.steps
        )
    }

    /// One line for people: `course, ppm 150, dt 0.001 s: failed at step 3 (0.003 s): ...`.
    pub fn summary(&self) -> String {
        let run = format!("{}, ppm {}, dt {} s", self.model.name(), self.ppm, self.dt);
        match &self.failure {
            Some((step, failure)) => format!(
                "{run}: failed at step {step} ({:.3} s): {failure}",
                *step as f64 * self.dt
            ),
            None => format!(
                "{run}: stable for {} steps ({:.3} s)",
                self.steps,
                self.steps as f64 * self.dt
            ),
        }
    }
}

/// Runs `scene` (seed `seed`) at `ppm` with `model` on the SIMD kernel and time step `dt`
/// for `duration` simulated seconds, checking every step.
pub fn watch(
    scene: SceneKind,
    seed: u64,
    model: Model,
    ppm: f64,
    dt: f64,
    duration: f64,
) -> Result<Outcome, String> {
    let particles = scene::generate(scene, ppm, seed, None)?;
    let count = particles.len();
    let method = Method {
        model,
        kernel: Kernel::Simd,
    };
    let params = Params::new(ppm).with_time_step(dt);
    let mut simulation =
        Simulation::with_params(params, particles, method).map_err(|error| error.to_string())?;
    let checks = Checks::from(&Vitals::of(&simulation));
    let steps = (duration / dt).round() as u64;
    let mut failure = None;
    for step in 1..=steps {
        simulation.step();
        if let Some(reason) = checks.failure(&Vitals::of(&simulation)) {
            failure = Some((step, reason));
            break;
        }
    }
    Ok(Outcome {
        scene,
        model,
        ppm,
        dt,
        particles: count,
        steps,
        failure,
    })
}

/// Pixel size of the map.
pub const SIZE: (u32, u32) = (1100, 520);

/// The outcomes as one grid per model (columns: time steps, rows: ppm), each cell green
/// if stable, else red, darker the sooner it failed, with the failure step, time and
/// reason: `stability-map.png` and `.svg` through [`crate::lab::chart::render`].
pub struct StabilityMap<'a> {
    /// The runs.
    pub outcomes: &'a [Outcome],
    /// Where the data come from.
    pub footer: String,
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
    let mut models: Vec<Model> = Vec::new();
    for outcome in outcomes {
        if !models.contains(&outcome.model) {
            models.push(outcome.model);
        }
    }
    let dts = distinct(outcomes.iter().map(|o| o.dt));
    let ppms = distinct(outcomes.iter().map(|o| o.ppm));
    let scene = outcomes.first().map_or("", |o| o.scene.name());
    root.draw(&Text::new(
        format!("Where each model fails: {scene}, by time step and particles per metre"),
        (30, 14),
        ("sans-serif", 22),
    ))?;
    let (left, top, cell_h) = (110, 90, 90.min(340 / ppms.len().max(1) as i32));
    let panel_w = (SIZE.0 as i32 - left - 40) / models.len().max(1) as i32;
    let cell_w = (panel_w - 30) / dts.len().max(1) as i32;
    let centred = Pos::new(HPos::Center, VPos::Center);
    for (m, model) in models.iter().enumerate() {
        let x0 = left + m as i32 * panel_w;
        root.draw(&Text::new(model.name(), (x0, top - 40), ("sans-serif", 18)))?;
        for (c, dt) in dts.iter().enumerate() {
            let x = x0 + c as i32 * cell_w;
            let style = ("sans-serif", 13).into_text_style(root).pos(centred);
            root.draw(&Text::new(
                format!("{dt}"),
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
                let Some(outcome) = outcomes
                    .iter()
                    .find(|o| o.model == *model && o.dt == *dt && o.ppm == *ppm)
                else {
                    continue;
                };
                let (colour, lines) = match &outcome.failure {
                    None => (
                        RGBColor(120, 200, 120),
                        vec!["stable".to_string(), format!("{} steps", outcome.steps)],
                    ),
                    Some((step, failure)) => {
                        let fraction = *step as f64 / outcome.steps.max(1) as f64;
                        let shade = (120.0 + 135.0 * fraction.sqrt()) as u8;
                        (
                            RGBColor(shade.max(150), 60, 50),
                            vec![
                                format!("step {step}"),
                                format!("{:.3} s", *step as f64 * outcome.dt),
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
            "time step dt (s)",
            (x0, bottom),
            ("sans-serif", 14),
        ))?;
    }
    root.draw(&Text::new(
        footer,
        (30, SIZE.1 as i32 - 24),
        ("sans-serif", 12).into_font().color(&BLACK.mix(0.7)),
    ))?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_course_model_fails_where_the_stable_one_does_not() {
        let course = watch(SceneKind::DamBreak, 1, Model::Course, 100.0, 1e-3, 0.05).unwrap();
        let (step, failure) = course.failure.expect("the course model fails");
        assert!(step <= 50, "{}", course.summary());
        assert!(course.summary().contains(&format!("failed at step {step}")));
        assert!(course.csv_row().contains(failure.name()));
        let stable = watch(
            SceneKind::DamBreak,
            1,
            Model::Fluidanimate,
            100.0,
            1e-3,
            0.05,
        )
        .unwrap();
        assert_eq!(stable.failure, None, "{}", stable.summary());
        assert_eq!(stable.steps, 50);
        assert!(
            stable.csv_row().ends_with(",50,,,stable,"),
            "{}",
            stable.csv_row()
        );
        assert_eq!(
            CSV_HEADER.split(',').count(),
            stable.csv_row().split(',').count()
        );
    }

    #[test]
    fn the_map_is_a_valid_png_and_svg() {
        let outcomes: Vec<Outcome> = [1e-3, 2e-3]
            .iter()
            .map(|&dt| watch(SceneKind::DamBreak, 1, Model::Course, 100.0, dt, 0.01).unwrap())
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let map = StabilityMap {
            outcomes: &outcomes,
            footer: "test".into(),
        };
        let [png, svg] = crate::lab::chart::render(&map, dir.path(), SIZE).unwrap();
        let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
        let info = decoder.read_info().unwrap();
        assert_eq!((info.info().width, info.info().height), SIZE);
        let text = std::fs::read_to_string(&svg).unwrap();
        let document = roxmltree::Document::parse(&text).unwrap();
        assert!(document
            .descendants()
            .any(|n| n.text().map(str::trim) == Some("course")));
    }
}
