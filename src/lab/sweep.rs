//! Iteration sweeps of a `fluid` binary: every (input, iterations) point run several times,
//! each run's wall, user and system time, peak memory and energy recorded, plus idle
//! windows as a separate baseline, written as one tidy CSV (one row per run).

use crate::io::signals;
use crate::lab::energy::{Domain, Energy, EnergyMethod, MeasureError};
use crate::lab::machine::Machine;
use crate::lab::UsageError;
use std::collections::HashSet;
use std::error::Error;
use std::io::{self, Read, Seek, Write};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The iteration counts a sweep runs when none are given.
pub const DEFAULT_ITERATIONS: [u64; 8] = [0, 1, 10, 100, 250, 500, 1000, 2000];

/// The CSV columns, in order. Energies are joules over the run's window, powers are those
/// joules over `wall_s`; both are empty (never 0) where not measured.
pub const COLUMNS: [&str; 28] = [
    "kind",
    "input",
    "particles",
    "iterations",
    "repeat",
    "wall_s",
    "user_s",
    "sys_s",
    "max_rss_kib",
    "energy_pkg_j",
    "energy_cores_j",
    "energy_gpu_j",
    "energy_ram_j",
    "energy_psys_j",
    "power_pkg_w",
    "power_cores_w",
    "power_gpu_w",
    "power_ram_w",
    "power_psys_w",
    "energy_method",
    "energy_detail",
    "time_method",
    "program",
    "host",
    "cpu_model",
    "cpus",
    "kernel",
    "commit",
];

/// How times and memory are measured (the `time_method` column).
pub const TIME_METHOD: &str = "wall: monotonic clock around spawn and wait4; user, sys, \
                               max_rss: wait4 rusage of the run";

/// What a sweep runs.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The program run as `program ITERATIONS INPUT /dev/null`.
    pub program: PathBuf,
    /// The input files.
    pub inputs: Vec<PathBuf>,
    /// The iteration counts.
    pub iterations: Vec<u64>,
    /// Runs per point.
    pub repeats: usize,
    /// Idle-baseline windows, measured before the runs.
    pub idle_windows: usize,
    /// The length of each idle window.
    pub idle: Duration,
}

/// Time and memory of one finished process.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Usage {
    /// Wall-clock time from spawn to reaping.
    pub wall: Duration,
    /// CPU time in user mode.
    pub user: Duration,
    /// CPU time in the kernel.
    pub system: Duration,
    /// Peak resident set size in KiB.
    pub max_rss_kib: u64,
}

/// Runs `command` to completion and measures it with `wait4(2)`.
pub fn run_measured(command: &mut Command) -> io::Result<(ExitStatus, Usage)> {
    let started = Instant::now();
    let child = command.spawn()?;
    let pid = child.id() as libc::pid_t;
    // A signal that stops the sweep stops the run it measures too.
    let _forwarding = signals::Forwarding::to(pid);
    let mut status = 0;
    // SAFETY: rusage is plain integers, for which all-zero bytes are a valid value.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: `status` and `usage` are live locals borrowed only for the call, and
        // `pid` is our child, not yet reaped (std's `Child` never waits on drop).
        let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if reaped == pid {
            break;
        }
        let error = io::Error::last_os_error();
        if error.kind() != io::ErrorKind::Interrupted {
            return Err(error);
        }
    }
    let wall = started.elapsed();
    let seconds = |time: libc::timeval| {
        Duration::from_secs(time.tv_sec as u64) + Duration::from_micros(time.tv_usec as u64)
    };
    let usage = Usage {
        wall,
        user: seconds(usage.ru_utime),
        system: seconds(usage.ru_stime),
        max_rss_kib: usage.ru_maxrss as u64,
    };
    Ok((ExitStatus::from_raw(status), usage))
}

/// One measurement: a run of the program, or an idle window.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The input's file name, or `None` for an idle window.
    pub input: Option<String>,
    /// The input's particle count.
    pub particles: Option<usize>,
    /// The iterations run.
    pub iterations: Option<u64>,
    /// Which repeat of its point (from 1).
    pub repeat: usize,
    /// Wall time of the window.
    pub wall: Duration,
    /// The run's process usage (`None` for idle windows).
    pub usage: Option<Usage>,
    /// The window's energy.
    pub energy: Energy,
}

/// What identifies a record within a sweep: input (none for idle), iterations, repeat.
pub type RecordKey = (Option<String>, Option<u64>, usize);

/// An input of a sweep: its path, the name its rows give it, and its particle count.
pub type Input<'a> = (&'a PathBuf, String, usize);

/// What receives all the records measured so far, after each one.
pub type Save<'a> = dyn FnMut(&[Record]) -> Result<(), Box<dyn Error>> + 'a;

impl Record {
    /// This record's place in the sweep.
    pub fn key(&self) -> RecordKey {
        (self.input.clone(), self.iterations, self.repeat)
    }
}

/// The keys of the records in a sweep CSV's text, for a sweep that goes on from it.
pub fn measured_keys(text: &str) -> Result<HashSet<RecordKey>, Box<dyn Error>> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let headers = reader.headers()?;
    if headers.iter().ne(COLUMNS) {
        let merged = (headers.iter().skip(COLUMNS.len())).eq(crate::lab::slurm::COLUMNS);
        return Err(
            match merged && headers.iter().take(COLUMNS.len()).eq(COLUMNS) {
                true => "it is a Slurm array's merged CSV: the array goes on with fluid-lab \
                     slurm resubmit"
                    .into(),
                false => "its columns are not those of this version's sweep".into(),
            },
        );
    }
    let mut keys = HashSet::new();
    for (line, record) in reader.records().enumerate() {
        let record = record?;
        let bad = || format!("row {}: not a sweep record", line + 2);
        let iterations = match &record[3] {
            "" => None,
            text => Some(text.parse().map_err(|_| bad())?),
        };
        let input = match &record[0] {
            "run" => Some(record[1].to_string()),
            "idle" => None,
            _ => return Err(bad().into()),
        };
        keys.insert((input, iterations, record[4].parse().map_err(|_| bad())?));
    }
    Ok(keys)
}

/// A sweep ready to run: its plan, how energy is measured, and the machine.
pub struct Sweep {
    /// What to run.
    pub plan: Plan,
    /// How energy is measured.
    pub energy: EnergyMethod,
    /// Where.
    pub machine: Machine,
}

impl Sweep {
    /// Each input with the name its rows give it and its particle count (which also
    /// checks that it is an `.fld` file). Two inputs of the same file name are refused:
    /// the CSV's `input` column would not tell them apart.
    pub fn inputs(&self) -> Result<Vec<Input<'_>>, Box<dyn Error>> {
        let mut inputs: Vec<Input<'_>> = Vec::new();
        for path in &self.plan.inputs {
            let name = file_name(path);
            if let Some((other, ..)) = inputs.iter().find(|(_, seen, _)| *seen == name) {
                return Err(UsageError(format!(
                    "{} and {} share the name {name}, which the CSV's input column would \
                     not tell apart",
                    other.display(),
                    path.display()
                ))
                .into());
            }
            inputs.push((path, name, particle_count(path)?));
        }
        Ok(inputs)
    }

    /// The keys of the rows of `text` (a sweep CSV) that this sweep would measure again,
    /// after checking that they were measured as it measures: by the same program on the
    /// same host, and with the particle count each input of that name has now.
    pub fn resumable(&self, text: &str) -> Result<HashSet<RecordKey>, Box<dyn Error>> {
        let keys = measured_keys(text)?;
        let inputs = self.inputs()?;
        let column = |name: &str| COLUMNS.iter().position(|c| *c == name).expect("a column");
        let (input, particles) = (column("input"), column("particles"));
        let (program, host) = (column("program"), column("host"));
        let (our_program, our_host) = (self.plan.program.display().to_string(), &self.machine.host);
        for record in csv::Reader::from_reader(text.as_bytes()).records() {
            let record = record?;
            if record[program] != our_program || record[host] != *our_host {
                return Err(format!(
                    "its rows were measured by {} on {}, this sweep runs {our_program} on \
                     {our_host}",
                    &record[program], &record[host]
                )
                .into());
            }
            let ours = inputs.iter().find(|(_, name, _)| *name == record[input]);
            if let Some((path, _, count)) = ours {
                if record[particles] != count.to_string() {
                    return Err(format!(
                        "its {} has {} particles, {} has {count}",
                        &record[input],
                        &record[particles],
                        path.display()
                    )
                    .into());
                }
            }
        }
        Ok(keys)
    }

    /// Measures the idle baseline (`idle_windows` windows), then every point `repeats` times (all points once per
    /// round, so slow drifts spread over all points), after one unrecorded warm-up run per
    /// input. Records go to `records` as they are measured, and `save` gets them all after
    /// each one (so a failure or a signal keeps them), except those whose key is in
    /// `done`. Progress goes to `log`, one line per record.
    pub fn measure(
        &self,
        log: &mut impl Write,
        done: &HashSet<RecordKey>,
        records: &mut Vec<Record>,
        save: &mut Save<'_>,
    ) -> Result<(), Box<dyn Error>> {
        let plan = &self.plan;
        // The inputs checked before the notes: a refused sweep prints its error alone.
        let inputs = self.inputs()?;
        writeln!(log, "time: {TIME_METHOD}")?;
        writeln!(log, "energy: {}", self.energy.describe())?;
        for repeat in 1..=plan.idle_windows {
            if done.contains(&(None, None, repeat)) {
                continue;
            }
            let window = self.energy.start()?;
            let started = Instant::now();
            std::thread::sleep(plan.idle);
            let wall = started.elapsed();
            let record = Record {
                input: None,
                particles: None,
                iterations: None,
                repeat,
                wall,
                usage: None,
                energy: window.stop()?,
            };
            writeln!(log, "{}", summary(&record))?;
            records.push(record);
            save(records)?;
        }
        let first = plan.iterations.iter().copied().min().unwrap_or(0);
        for (path, name, _) in &inputs {
            self.run_once(path, first)?;
            writeln!(log, "warm-up: {name}, {first} iterations (not recorded)")?;
        }
        for repeat in 1..=plan.repeats {
            for (path, name, particles) in &inputs {
                for &iterations in &plan.iterations {
                    if done.contains(&(Some(name.clone()), Some(iterations), repeat)) {
                        continue;
                    }
                    let window = self.energy.start()?;
                    let usage = self.run_once(path, iterations)?;
                    let record = Record {
                        input: Some(name.clone()),
                        particles: Some(*particles),
                        iterations: Some(iterations),
                        repeat,
                        wall: usage.wall,
                        usage: Some(usage),
                        energy: window.stop()?,
                    };
                    writeln!(log, "{}", summary(&record))?;
                    records.push(record);
                    save(records)?;
                }
            }
        }
        Ok(())
    }

    /// Runs the program once; a failed run is an error naming the command and its stderr.
    fn run_once(&self, input: &Path, iterations: u64) -> Result<Usage, Box<dyn Error>> {
        let program = &self.plan.program;
        let mut stderr = tempfile::tempfile()?;
        let mut command = Command::new(program);
        command
            .arg(iterations.to_string())
            .arg(input)
            .arg("/dev/null")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr.try_clone()?);
        let shown = format!(
            "{} {iterations} {} /dev/null",
            program.display(),
            input.display()
        );
        let (status, usage) = run_measured(&mut command)
            .map_err(|error| MeasureError(format!("cannot run {shown}: {error}")))?;
        if !status.success() {
            let mut message = String::new();
            stderr.seek(io::SeekFrom::Start(0))?;
            stderr.read_to_string(&mut message)?;
            // Its last line, which says why (the error stays one line).
            let lines: Vec<&str> = message
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            let said = match lines.as_slice() {
                [] => String::new(),
                [only] => format!(": {only}"),
                [.., last] => format!(": {last} (the last of {} lines on its stderr)", lines.len()),
            };
            return Err(MeasureError(format!("{shown} failed ({status}){said}")).into());
        }
        Ok(usage)
    }

    /// The sweep's records as CSV text, one row per record, with [`COLUMNS`].
    pub fn csv(&self, records: &[Record]) -> Result<Vec<u8>, Box<dyn Error>> {
        let mut writer = csv::Writer::from_writer(Vec::new());
        writer.write_record(COLUMNS)?;
        let machine = &self.machine;
        for record in records {
            let seconds = |duration: Duration| format!("{:.6}", duration.as_secs_f64());
            let optional = |value: Option<String>| value.unwrap_or_default();
            let usage = record.usage.as_ref();
            let mut row = vec![
                if record.input.is_some() {
                    "run"
                } else {
                    "idle"
                }
                .to_string(),
                optional(record.input.clone()),
                optional(record.particles.map(|n| n.to_string())),
                optional(record.iterations.map(|n| n.to_string())),
                record.repeat.to_string(),
                seconds(record.wall),
                optional(usage.map(|usage| seconds(usage.user))),
                optional(usage.map(|usage| seconds(usage.system))),
                optional(usage.map(|usage| usage.max_rss_kib.to_string())),
            ];
            let wall = record.wall.as_secs_f64();
            for domain in Domain::ALL {
                row.push(optional(
                    record.energy.joules(domain).map(|j| format!("{j:.6}")),
                ));
            }
            for domain in Domain::ALL {
                row.push(optional(
                    record
                        .energy
                        .joules(domain)
                        .map(|j| format!("{:.6}", j / wall)),
                ));
            }
            row.extend([
                self.energy.name().to_string(),
                self.energy.describe(),
                TIME_METHOD.to_string(),
                self.plan.program.display().to_string(),
                machine.host.clone(),
                machine.cpu_model.clone(),
                machine.cpus.to_string(),
                machine.kernel.clone(),
                machine.commit.clone(),
            ]);
            writer.write_record(&row)?;
        }
        Ok(writer.into_inner().map_err(|error| error.into_error())?)
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .unwrap_or(path.as_os_str())
        .to_string_lossy()
        .into_owned()
}

/// The number of particles in a `.fld` input (which also checks that it is one).
fn particle_count(path: &Path) -> Result<usize, Box<dyn Error>> {
    match crate::io::fld::read(path) {
        Ok(scene) => Ok(scene.particles.len()),
        Err(error) => Err(error.naming(path)),
    }
}

/// One progress line for a record.
fn summary(record: &Record) -> String {
    let what = match (&record.input, record.iterations) {
        (Some(input), Some(iterations)) => format!("{input}, {iterations} iterations"),
        _ => "idle".to_string(),
    };
    let mut line = format!(
        "{what}, repeat {}: {:.4} s",
        record.repeat,
        record.wall.as_secs_f64()
    );
    if let Some(usage) = record.usage {
        line.push_str(&format!(", {} KiB peak", usage.max_rss_kib));
    }
    let measured = Domain::ALL
        .into_iter()
        .find_map(|domain| Some((domain, record.energy.joules(domain)?)));
    match measured {
        Some((domain, joules)) => line.push_str(&format!(", {} {joules:.3} J", domain.name())),
        None => line.push_str(", energy not measured"),
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_reports_its_exit_status_time_and_peak_memory() {
        let (status, usage) = run_measured(Command::new("sh").args(["-c", "exit 3"])).unwrap();
        assert_eq!(status.code(), Some(3));
        assert!(usage.max_rss_kib > 0);

        let (status, usage) = run_measured(Command::new("sleep").arg("0.1")).unwrap();
        assert!(status.success());
        assert!(usage.wall >= Duration::from_millis(100), "{usage:?}");
        assert!(
            usage.user + usage.system < Duration::from_millis(100),
            "{usage:?}"
        );

        // dd holds its whole 64 MiB block in memory.
        let (status, usage) = run_measured(
            Command::new("dd")
                .args(["if=/dev/zero", "of=/dev/null", "bs=64M", "count=2"])
                .stderr(Stdio::null()),
        )
        .unwrap();
        assert!(status.success());
        assert!(usage.max_rss_kib >= 64 * 1024, "{usage:?}");
        assert!(usage.user + usage.system > Duration::ZERO, "{usage:?}");
    }

    fn sweep(energy: EnergyMethod) -> Sweep {
        Sweep {
            plan: Plan {
                program: PathBuf::from("target/release/fluid"),
                inputs: Vec::new(),
                iterations: Vec::new(),
                repeats: 1,
                idle_windows: 1,
                idle: Duration::ZERO,
            },
            energy,
            machine: Machine {
                host: "h".into(),
                cpu_model: "Some CPU, 2 GHz".into(),
                cpus: 2,
                kernel: "6.1.0".into(),
                commit: "0123456789ab".into(),
            },
        }
    }

    fn rows(csv: &[u8]) -> Vec<csv::StringRecord> {
        let mut reader = csv::Reader::from_reader(csv);
        assert_eq!(
            reader.headers().unwrap(),
            &csv::StringRecord::from(&COLUMNS[..])
        );
        reader.records().map(Result::unwrap).collect()
    }

    #[test]
    fn the_csv_has_one_row_per_record_and_leaves_unmeasured_energy_empty() {
        let unavailable = EnergyMethod::Unavailable {
            reason: "no RAPL".into(),
        };
        let sweep = sweep(unavailable);
        let idle = Record {
            input: None,
            particles: None,
            iterations: None,
            repeat: 1,
            wall: Duration::from_millis(500),
            usage: None,
            energy: Energy::default(),
        };
        let run = Record {
            input: Some("small.fld".into()),
            particles: Some(4800),
            iterations: Some(10),
            repeat: 2,
            wall: Duration::from_micros(12_345),
            usage: Some(Usage {
                wall: Duration::from_micros(12_345),
                user: Duration::from_micros(10_000),
                system: Duration::from_micros(2_000),
                max_rss_kib: 5_900,
            }),
            energy: Energy::default(),
        };
        let rows = rows(&sweep.csv(&[idle, run]).unwrap());
        assert_eq!(rows.len(), 2);
        let get = |row: &csv::StringRecord, column: &str| {
            row[COLUMNS.iter().position(|c| *c == column).unwrap()].to_string()
        };
        assert_eq!(get(&rows[0], "kind"), "idle");
        assert_eq!(get(&rows[0], "input"), "");
        assert_eq!(get(&rows[0], "wall_s"), "0.500000");
        assert_eq!(get(&rows[0], "user_s"), "");
        assert_eq!(get(&rows[1], "kind"), "run");
        assert_eq!(get(&rows[1], "input"), "small.fld");
        assert_eq!(get(&rows[1], "particles"), "4800");
        assert_eq!(get(&rows[1], "iterations"), "10");
        assert_eq!(get(&rows[1], "repeat"), "2");
        assert_eq!(get(&rows[1], "wall_s"), "0.012345");
        assert_eq!(get(&rows[1], "user_s"), "0.010000");
        assert_eq!(get(&rows[1], "sys_s"), "0.002000");
        assert_eq!(get(&rows[1], "max_rss_kib"), "5900");
        for row in &rows {
            for column in COLUMNS.iter().filter(|c| c.starts_with("energy_")) {
                let expected = match *column {
                    "energy_method" => "none",
                    "energy_detail" => "not available (no RAPL)",
                    _ => "",
                };
                assert_eq!(get(row, column), expected, "{column}");
            }
            assert_eq!(get(row, "power_pkg_w"), "");
            assert_eq!(get(row, "cpu_model"), "Some CPU, 2 GHz");
            assert_eq!(get(row, "commit"), "0123456789ab");
        }
    }

    #[test]
    fn measured_energy_gives_power_over_the_wall_time() {
        let sweep = sweep(EnergyMethod::Perf {
            program: PathBuf::from("perf"),
            events: vec!["power/energy-pkg/".into()],
        });
        let mut energy = Energy::default();
        energy.add(Domain::Pkg, 3.0);
        let idle = Record {
            input: None,
            particles: None,
            iterations: None,
            repeat: 1,
            wall: Duration::from_millis(250),
            usage: None,
            energy,
        };
        let rows = rows(&sweep.csv(&[idle]).unwrap());
        let column = |name: &str| COLUMNS.iter().position(|c| *c == name).unwrap();
        assert_eq!(&rows[0][column("energy_pkg_j")], "3.000000");
        assert_eq!(&rows[0][column("power_pkg_w")], "12.000000");
        assert_eq!(&rows[0][column("energy_ram_j")], "");
        assert_eq!(&rows[0][column("energy_method")], "perf");
        assert_eq!(
            &rows[0][column("energy_detail")],
            "perf stat -a -e power/energy-pkg/"
        );
    }
}
