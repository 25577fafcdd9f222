//! How far a long run has come, on stderr: a bar where stderr is a terminal, else (a CI
//! or Slurm log) a plain line at a steady interval of wall time, with the steps, the
//! simulated time, the rate and the time left; nothing with `--quiet`.

use crate::io::gformat::format_g;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How progress is shown, for the whole process ([`configure`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// No bar and no lines.
    pub quiet: bool,
    /// Wall time between two plain lines.
    pub every: Duration,
}

/// The interval of plain lines unless set otherwise.
pub const DEFAULT_EVERY: Duration = Duration::from_secs(10);

impl Default for Settings {
    fn default() -> Self {
        Settings {
            quiet: false,
            every: DEFAULT_EVERY,
        }
    }
}

static SETTINGS: OnceLock<Settings> = OnceLock::new();

/// Sets how every later [`Progress`] shows itself (once per process; the first call wins).
pub fn configure(settings: Settings) {
    let _ = SETTINGS.set(settings);
}

/// Where a command's lines of progress go (a sweep's line per record): stderr, or
/// nowhere with `--quiet`.
pub fn lines() -> Box<dyn std::io::Write> {
    match settings().quiet {
        true => Box::new(std::io::sink()),
        false => Box::new(std::io::stderr()),
    }
}

fn settings() -> Settings {
    SETTINGS.get().copied().unwrap_or_default()
}

/// Where a run is going: a number of steps, or a physical time (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Goal {
    /// This many steps.
    Steps(u64),
    /// This physical time, in seconds.
    Until(f64),
}

/// The progress of one run; [`Progress::finish`] clears its bar.
#[derive(Debug)]
pub struct Progress {
    goal: Goal,
    shown: Shown,
    started: Instant,
    /// What runs, where one command runs several (its lines name it).
    label: Option<String>,
}

#[derive(Debug)]
enum Shown {
    Nothing,
    Bar(ProgressBar),
    /// Plain lines, the next due at this instant, one each `every`.
    Lines {
        next: Instant,
        every: Duration,
    },
}

impl Progress {
    /// The progress of a run towards `goal`, shown as the process's settings and stderr
    /// allow.
    pub fn towards(goal: Goal) -> Progress {
        let Settings { quiet, every } = settings();
        let started = Instant::now();
        let shown = if quiet || goal == Goal::Steps(0) {
            Shown::Nothing
        } else if std::io::stderr().is_terminal() {
            Shown::Bar(bar(goal))
        } else {
            Shown::Lines {
                next: started + every,
                every,
            }
        };
        Progress {
            goal,
            shown,
            started,
            label: None,
        }
    }

    /// The same, its lines naming the run `label` (one of several a command runs).
    pub fn labelled(mut self, label: String) -> Progress {
        self.label = Some(label);
        self
    }

    /// Records that the run has taken `step` steps and reached physical time `time` (s).
    pub fn show(&mut self, step: u64, time: f64) {
        match &mut self.shown {
            Shown::Nothing => {}
            Shown::Bar(bar) => bar.set_position(match self.goal {
                Goal::Steps(_) => step,
                Goal::Until(_) => (time * 1e6) as u64,
            }),
            Shown::Lines { next, every } => {
                let now = Instant::now();
                if now >= *next {
                    *next = now + *every;
                    let line = line(self.goal, step, time, now - self.started);
                    let label = self
                        .label
                        .as_ref()
                        .map_or(String::new(), |l| format!("{l}: "));
                    let _ = writeln!(
                        std::io::stderr().lock(),
                        "fluid-lab: progress: {label}{line}"
                    );
                }
            }
        }
    }

    /// Clears the bar, if any (plain lines stay in the log).
    pub fn finish(&self) {
        if let Shown::Bar(bar) = &self.shown {
            bar.finish_and_clear();
        }
    }
}

/// A bar over the steps, or over the simulated microseconds, with its rate.
fn bar(goal: Goal) -> ProgressBar {
    let (template, length) = match goal {
        Goal::Steps(steps) => ("{bar:30} {pos}/{len} steps  {per_sec}  eta {eta}", steps),
        Goal::Until(end) => (
            "{bar:30} {pos}/{len} simulated us  {per_sec}  eta {eta}",
            (end * 1e6).ceil() as u64,
        ),
    };
    let style = ProgressStyle::with_template(template).expect("a valid template");
    ProgressBar::with_draw_target(Some(length), ProgressDrawTarget::stderr()).with_style(style)
}

/// One plain line's news: `step` steps and physical time `time` (s) after `elapsed` of wall time.
fn line(goal: Goal, step: u64, time: f64, elapsed: Duration) -> String {
    let seconds = elapsed.as_secs_f64().max(1e-9);
    let rate = step as f64 / seconds;
    // The fraction done, and the goal after the steps or after the time.
    let (done, of, goal_time) = match goal {
        Goal::Steps(steps) => (
            step as f64 / steps as f64,
            format!(" of {steps}"),
            String::new(),
        ),
        Goal::Until(end) => (time / end, String::new(), format!(" of {}", format_g(end))),
    };
    let left = match done {
        done if done > 0.0 => format!("about {} left", duration(seconds * (1.0 - done) / done)),
        _ => "time left unknown".to_string(),
    };
    format!(
        "step {step}{of}, t = {time:.6}{goal_time} s ({:.0}%), {rate:.1} steps/s, {left}",
        100.0 * done
    )
}

/// A duration for people: seconds under two minutes, minutes under two hours, else hours.
fn duration(seconds: f64) -> String {
    match seconds {
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s if s < 3.6e9 => format!("{:.1} h", s / 3600.0),
        s => format!("{:.1e} h", s / 3600.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_gives_steps_time_rate_and_time_left() {
        let text = line(Goal::Steps(400), 100, 0.025, Duration::from_secs(20));
        assert_eq!(
            text,
            "step 100 of 400, t = 0.025000 s (25%), 5.0 steps/s, about 60 s left"
        );
        let text = line(Goal::Until(2.0), 3000, 0.5, Duration::from_secs(600));
        assert_eq!(
            text,
            "step 3000, t = 0.500000 of 2 s (25%), 5.0 steps/s, about 30 min left"
        );
    }

    #[test]
    fn a_line_before_any_progress_says_the_time_left_is_unknown() {
        let text = line(Goal::Until(1.0), 0, 0.0, Duration::from_secs(1));
        assert!(text.ends_with("0.0 steps/s, time left unknown"), "{text}");
    }

    #[test]
    fn durations_read_in_seconds_minutes_or_hours() {
        assert_eq!(duration(59.4), "59 s");
        assert_eq!(duration(600.0), "10 min");
        assert_eq!(duration(36_000.0), "10.0 h");
        assert_eq!(duration(3.6e300), "1.0e297 h");
    }
}
