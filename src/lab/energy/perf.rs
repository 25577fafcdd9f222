//! RAPL through `perf stat -a`: which events the kernel offers, a counting window driven
//! over perf's control descriptors, and the parser of perf's CSV (`-x,`) output.
//!
//! The window is exact: perf starts with its events disabled (`-D -1`), and
//! `--control fd:0,1` lets this process enable and disable them (perf acknowledges each
//! command) right around the measured run. System-wide counting (`-a`) is what RAPL
//! needs; the window therefore also holds whatever else the machine does meanwhile.

use super::{Domain, Energy, MeasureError};
use std::io::{Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use tempfile::TempPath;

/// One counter line of `perf stat -x,` output.
#[derive(Debug, PartialEq)]
pub struct Count {
    /// The event as perf prints it, e.g. `power/energy-pkg/`.
    pub event: String,
    /// The unit, e.g. `Joules` (perf has already applied the event's scale).
    pub unit: String,
    /// The value, or perf's reason for having none (`<not supported>`, `<not counted>`).
    pub value: Result<f64, String>,
}

/// Parses `perf stat -x,` output: comment and blank lines are skipped, each other line is
/// `value,unit,event,...`.
pub fn parse_csv(text: &str) -> Result<Vec<Count>, MeasureError> {
    let mut counts = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        let [value, unit, event, ..] = fields[..] else {
            return Err(MeasureError(format!("unreadable perf stat line: {line}")));
        };
        let value = if value.starts_with('<') {
            Err(value.to_string())
        } else {
            Ok(value
                .parse::<f64>()
                .map_err(|_| MeasureError(format!("unreadable perf stat value: {line}")))?)
        };
        counts.push(Count {
            event: event.to_string(),
            unit: unit.to_string(),
            value,
        });
    }
    Ok(counts)
}

/// The energy of RAPL counts; a count perf could not give leaves its domain unmeasured.
pub fn energy_of(counts: &[Count]) -> Result<Energy, MeasureError> {
    let mut energy = Energy::default();
    for count in counts {
        let Some(domain) = Domain::of_perf_event(&count.event) else {
            continue;
        };
        if count.unit != "Joules" {
            return Err(MeasureError(format!(
                "perf reported {} in {:?}, not Joules",
                count.event, count.unit
            )));
        }
        if let Ok(joules) = count.value {
            energy.add(domain, joules);
        }
    }
    Ok(energy)
}

/// The RAPL events of the `power` PMU under `pmus` (`/sys/bus/event_source/devices`),
/// as perf event names (`power/energy-pkg/`), or why there are none.
pub fn rapl_events(pmus: &Path) -> Result<Vec<String>, String> {
    let folder = pmus.join("power").join("events");
    let entries = std::fs::read_dir(&folder)
        .map_err(|_| format!("no RAPL PMU ({} is absent)", folder.display()))?;
    let mut events: Vec<String> = entries
        .filter_map(|entry| entry.ok()?.file_name().into_string().ok())
        .filter(|name| name.starts_with("energy-") && !name.contains('.'))
        .map(|name| format!("power/{name}/"))
        .collect();
    events.sort();
    if events.is_empty() {
        return Err(format!("no energy events in {}", folder.display()));
    }
    Ok(events)
}

/// How long [`usable_events`] counts: RAPL counters advance every millisecond or so,
/// so a working one reads more than 0 J over it.
const PROBE: std::time::Duration = std::time::Duration::from_millis(20);

/// The RAPL events that `program` can count system-wide here, probed with a window of
/// 20 ms (`PROBE`), or why none can.
pub fn usable_events(program: &Path, pmus: &Path) -> Result<Vec<String>, String> {
    let events = rapl_events(pmus)?;
    let counts = Counting::start(program, &events)
        .and_then(|counting| {
            std::thread::sleep(PROBE);
            counting.stop()
        })
        .map_err(|error| error.0)?;
    advancing_events(&counts).map_err(|reason| format!("{reason} (of {})", events.join(",")))
}

/// The RAPL events of a probe's `counts` that counted more than 0 J, or why none did:
/// some virtual machines offer a RAPL event that never advances, which would put a
/// made-up 0 J in every measurement.
fn advancing_events(counts: &[Count]) -> Result<Vec<String>, String> {
    let rapl = counts
        .iter()
        .filter(|count| Domain::of_perf_event(&count.event).is_some());
    let usable: Vec<String> = rapl
        .clone()
        .filter(|count| count.value.as_ref().is_ok_and(|&joules| joules > 0.0))
        .map(|count| count.event.clone())
        .collect();
    if !usable.is_empty() {
        return Ok(usable);
    }
    if rapl.clone().any(|count| count.value.is_ok()) {
        Err(format!(
            "perf's RAPL events read 0 J over a {} ms probe: they do not advance here",
            PROBE.as_millis()
        ))
    } else {
        Err("perf counted no RAPL event".to_string())
    }
}

/// A `perf stat -a` process counting between [`Counting::start`] and [`Counting::stop`].
pub struct Counting {
    child: Child,
    control: ChildStdin,
    acks: ChildStdout,
    output: TempPath,
    finished: bool,
}

impl Counting {
    /// Starts `program stat -a` on `events`, enabled when this returns.
    pub fn start(program: &Path, events: &[String]) -> Result<Counting, MeasureError> {
        let output = tempfile::NamedTempFile::new()
            .map_err(|error| MeasureError(format!("cannot create perf's output file: {error}")))?
            .into_temp_path();
        let mut child = Command::new(program)
            .args([
                "stat",
                "-a",
                "-x",
                ",",
                "-D",
                "-1",
                "--control",
                "fd:0,1",
                "-o",
            ])
            .arg(&output)
            .arg("-e")
            .arg(events.join(","))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|error| match error.kind() {
                std::io::ErrorKind::NotFound => {
                    MeasureError(format!("{} is not installed", program.display()))
                }
                _ => MeasureError(format!("cannot start {}: {error}", program.display())),
            })?;
        let (Some(control), Some(acks)) = (child.stdin.take(), child.stdout.take()) else {
            unreachable!("stdin and stdout are piped");
        };
        let mut counting = Counting {
            child,
            control,
            acks,
            output,
            finished: false,
        };
        counting.command("enable")?;
        Ok(counting)
    }

    /// Stops counting and returns perf's counts for the window.
    pub fn stop(mut self) -> Result<Vec<Count>, MeasureError> {
        self.command("disable")?;
        let pid = self.child.id() as libc::pid_t;
        // SAFETY: kill(2) takes plain integers and touches no memory of this process; the
        // pid is our own child, which has not been waited for, so it cannot be reused.
        unsafe { libc::kill(pid, libc::SIGINT) };
        let status = self
            .child
            .wait()
            .map_err(|error| MeasureError(format!("cannot wait for perf: {error}")))?;
        self.finished = true;
        use std::os::unix::process::ExitStatusExt;
        if !status.success() && status.signal() != Some(libc::SIGINT) {
            return Err(self.failure());
        }
        let text = std::fs::read_to_string(&self.output)
            .map_err(|error| MeasureError(format!("cannot read perf's output: {error}")))?;
        parse_csv(&text)
    }

    /// Sends a control command and waits for perf's `ack`.
    fn command(&mut self, word: &str) -> Result<(), MeasureError> {
        if writeln!(self.control, "{word}")
            .and_then(|()| self.control.flush())
            .is_err()
        {
            return Err(self.failure());
        }
        // perf writes "ack\n" followed by a NUL byte; skip the NULs.
        let mut seen = Vec::new();
        let mut byte = [0u8];
        while !seen.ends_with(b"ack\n") {
            match self.acks.read(&mut byte) {
                Ok(1) if byte[0] != 0 => seen.push(byte[0]),
                Ok(1) => {}
                _ => return Err(self.failure()),
            }
        }
        Ok(())
    }

    /// The error of a perf that stopped answering: the first line of its stderr.
    fn failure(&mut self) -> MeasureError {
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.finished = true;
        let mut stderr = String::new();
        if let Some(mut pipe) = self.child.stderr.take() {
            let _ = pipe.read_to_string(&mut stderr);
        }
        let first = stderr.lines().find(|line| !line.trim().is_empty());
        MeasureError(format!(
            "perf stat failed: {}",
            first.unwrap_or("it exited without a message").trim()
        ))
    }
}

impl Drop for Counting {
    fn drop(&mut self) {
        if !self.finished {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn fixture(name: &str) -> String {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("perf/fixtures")
            .join(name);
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    #[test]
    fn intel_event_list_gives_every_domain() {
        let counts = parse_csv(&fixture("perf-stat-intel.csv")).unwrap();
        assert_eq!(counts.len(), 5);
        let energy = energy_of(&counts).unwrap();
        assert_eq!(energy.joules(Domain::Pkg), Some(23.47));
        assert_eq!(energy.joules(Domain::Cores), Some(17.92));
        assert_eq!(energy.joules(Domain::Gpu), Some(0.03));
        assert_eq!(energy.joules(Domain::Ram), Some(2.61));
        assert_eq!(energy.joules(Domain::Psys), Some(31.08));
    }

    #[test]
    fn amd_event_list_gives_the_package_only() {
        let energy = energy_of(&parse_csv(&fixture("perf-stat-amd.csv")).unwrap()).unwrap();
        assert_eq!(energy.joules(Domain::Pkg), Some(41.18));
        for domain in [Domain::Cores, Domain::Gpu, Domain::Ram, Domain::Psys] {
            assert_eq!(energy.joules(domain), None, "{domain:?}");
        }
    }

    #[test]
    fn not_supported_and_not_counted_leave_domains_unmeasured_not_zero() {
        let counts = parse_csv(&fixture("perf-stat-not-supported.csv")).unwrap();
        assert_eq!(counts[1].value, Err("<not supported>".to_string()));
        assert_eq!(counts[2].value, Err("<not counted>".to_string()));
        let energy = energy_of(&counts).unwrap();
        assert_eq!(energy.joules(Domain::Pkg), Some(12.05));
        assert_eq!(energy.joules(Domain::Ram), None);
        assert_eq!(energy.joules(Domain::Cores), None);
    }

    #[test]
    fn a_recorded_software_event_output_parses_and_holds_no_energy() {
        // Recorded on the development machine (perf 6.1, no RAPL): the same window code
        // with a software event.
        let counts = parse_csv(&fixture("perf-stat-software.csv")).unwrap();
        assert_eq!(counts.len(), 2);
        assert_eq!(counts[0].event, "cpu-clock");
        assert_eq!(counts[0].unit, "msec");
        assert_eq!(counts[0].value, Ok(604.0));
        assert!(!energy_of(&counts).unwrap().is_measured());
    }

    #[test]
    fn garbage_is_an_error_and_energy_in_other_units_is_refused() {
        assert!(parse_csv("12.3;Joules;power/energy-pkg/\n").is_err());
        assert!(parse_csv("twelve,Joules,power/energy-pkg/,1,100.00,,\n").is_err());
        let counts = parse_csv("12.3,mJ,power/energy-pkg/,1,100.00,,\n").unwrap();
        assert!(energy_of(&counts).is_err());
    }

    #[test]
    fn only_rapl_events_that_advance_are_usable() {
        let stuck = parse_csv(&fixture("perf-stat-psys-stuck.csv")).unwrap();
        assert_eq!(
            advancing_events(&stuck).unwrap_err(),
            "perf's RAPL events read 0 J over a 20 ms probe: they do not advance here"
        );
        let not_counted = parse_csv(&fixture("perf-stat-not-supported.csv")).unwrap();
        let counted: Vec<&Count> = not_counted.iter().filter(|c| c.value.is_ok()).collect();
        assert!(!counted.is_empty() && counted.len() < not_counted.len());
        assert_eq!(
            advancing_events(&not_counted).unwrap(),
            counted.iter().map(|c| c.event.clone()).collect::<Vec<_>>()
        );
        let software = parse_csv(&fixture("perf-stat-software.csv")).unwrap();
        assert_eq!(
            advancing_events(&software).unwrap_err(),
            "perf counted no RAPL event"
        );
        let intel = parse_csv(&fixture("perf-stat-intel.csv")).unwrap();
        assert_eq!(advancing_events(&intel).unwrap().len(), 5);
    }

    #[test]
    fn rapl_events_are_read_from_the_power_pmu() {
        let dir = tempfile::tempdir().unwrap();
        assert!(rapl_events(dir.path()).unwrap_err().contains("is absent"));
        let events = dir.path().join("power/events");
        std::fs::create_dir_all(&events).unwrap();
        assert!(rapl_events(dir.path())
            .unwrap_err()
            .contains("no energy events"));
        for name in [
            "energy-pkg",
            "energy-pkg.scale",
            "energy-pkg.unit",
            "energy-ram",
        ] {
            std::fs::write(events.join(name), "event=0x02\n").unwrap();
        }
        assert_eq!(
            rapl_events(dir.path()).unwrap(),
            ["power/energy-pkg/", "power/energy-ram/"]
        );
    }

    #[test]
    fn a_missing_perf_is_named() {
        let missing = PathBuf::from("/nonexistent/perf");
        let error = Counting::start(&missing, &["cpu-clock".to_string()])
            .err()
            .unwrap();
        assert_eq!(error.0, "/nonexistent/perf is not installed");
    }

    /// The window code against the real perf, with a software event in place of RAPL:
    /// `cpu-clock` counted system-wide over a window of at least 200 ms. Skipped where perf
    /// is absent or may not count system-wide, unless `FLUID_REQUIRE_PERF` is set (CI).
    #[test]
    fn a_window_counts_system_wide_between_start_and_stop() {
        let perf = PathBuf::from("perf");
        let events = ["cpu-clock".to_string()];
        let counting = match Counting::start(&perf, &events) {
            Ok(counting) => counting,
            Err(error) if std::env::var_os("FLUID_REQUIRE_PERF").is_none() => {
                eprintln!("SKIPPED: perf cannot count here: {error}");
                return;
            }
            Err(error) => panic!("FLUID_REQUIRE_PERF is set but {error}"),
        };
        let started = std::time::Instant::now();
        std::thread::sleep(std::time::Duration::from_millis(200));
        let counts = counting.stop().unwrap();
        let window_ms = started.elapsed().as_secs_f64() * 1e3;
        let cpus = std::thread::available_parallelism().unwrap().get() as f64;
        let [count] = &counts[..] else {
            panic!("{counts:?}")
        };
        assert_eq!(
            (count.event.as_str(), count.unit.as_str()),
            ("cpu-clock", "msec")
        );
        let counted_ms = count.value.clone().unwrap();
        // Each CPU's clock runs for the whole window, plus perf's command round trips.
        assert!(
            counted_ms >= 0.95 * 200.0 * cpus && counted_ms <= (window_ms + 50.0) * cpus,
            "{counted_ms} ms counted over a {window_ms} ms window on {cpus} CPUs"
        );
    }
}
