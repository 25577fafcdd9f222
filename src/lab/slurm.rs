//! Slurm job arrays of the workbench's sweeps: a job folder that holds the subcommand and
//! its points, the job script, each task's CSV shard (the subcommand's rows plus the
//! Slurm job id, array index and node) and logs; the merge of the shards, which names the
//! points still missing and why; and Slurm's own energy accounting (`sacct`), a method
//! of its own beside the sweep's RAPL ones.
//!
//! A job folder:
//! - `command`: the subcommand's arguments (NUL-separated bytes), `cwd`: the folder it
//!   was submitted from, which every task runs in;
//! - `points.txt`: one line per point, in array-index order;
//! - `job.sh`: the batch script (its `#SBATCH` lines; the array is given at submission);
//! - `submissions.csv`: each submission's job id and array;
//! - `shards/INDEX.csv`: a finished task's rows, written whole or not at all;
//! - `logs/JOB_INDEX.out`, `.err`: each task's output;
//! - `tasks.csv`: the last merge's account of every point.

use std::collections::{BTreeMap, HashSet};
use std::error::Error;
use std::ffi::OsString;
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// The columns a task adds to every row of its subcommand's CSV.
pub const COLUMNS: [&str; 3] = ["slurm_job_id", "slurm_array_index", "slurm_node"];

/// The energy method name of Slurm's accounting, beside the sweep's RAPL methods.
pub const ENERGY_METHOD: &str = "slurm-sacct";

/// The columns of `tasks.csv`, one row per point.
pub const TASK_COLUMNS: [&str; 9] = [
    "slurm_array_index",
    "point",
    "status",
    "slurm_job_id",
    "slurm_node",
    "rows",
    "energy_j",
    "energy_method",
    "stderr",
];

/// How the array's tasks are placed: the `sbatch` options the job script carries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Placement {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time`, the limit of each task.
    pub time: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--exclusive`: a whole node for each task.
    pub exclusive: bool,
}

/// A job folder.
#[derive(Clone, Debug, PartialEq)]
pub struct JobDir {
    /// Its absolute path.
    pub path: PathBuf,
}

/// What a job folder records of its job.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// The subcommand's arguments, its name first.
    pub command: Vec<OsString>,
    /// The folder it was submitted from.
    pub cwd: PathBuf,
    /// The points, in array-index order.
    pub points: Vec<String>,
}

/// One submission of the array: its job id and the array indices it ran.
#[derive(Clone, Debug, PartialEq)]
pub struct Submission {
    /// Slurm's job id of the array.
    pub job_id: String,
    /// The indices submitted.
    pub indices: Vec<usize>,
}

/// Where a task ran: the values of [`COLUMNS`].
#[derive(Clone, Debug, PartialEq)]
pub struct TaskPlace {
    /// The array's job id.
    pub job_id: String,
    /// The array index.
    pub index: usize,
    /// The node's name.
    pub node: String,
}

impl TaskPlace {
    /// The place of the running array task, from Slurm's environment
    /// (`SLURM_ARRAY_JOB_ID`, `SLURM_ARRAY_TASK_ID`, `SLURMD_NODENAME`).
    pub fn from_environment() -> Result<TaskPlace, String> {
        let variable = |name: &str| {
            std::env::var(name).map_err(|_| {
                format!("not in a Slurm array task: {name} is not set (tasks are run by job.sh)")
            })
        };
        let index = variable("SLURM_ARRAY_TASK_ID")?;
        Ok(TaskPlace {
            job_id: variable("SLURM_ARRAY_JOB_ID")?,
            index: index
                .parse()
                .map_err(|_| format!("SLURM_ARRAY_TASK_ID {index:?} is not an index"))?,
            node: variable("SLURMD_NODENAME")?,
        })
    }
}

impl JobDir {
    /// The job folder at `path` (made absolute, so that tasks and merges find it from
    /// any folder).
    pub fn at(path: &Path) -> Result<JobDir, String> {
        let path =
            std::path::absolute(path).map_err(|error| format!("{}: {error}", path.display()))?;
        Ok(JobDir { path })
    }

    /// Creates the folder for a new job and records `job` in it; a folder that already
    /// holds a job is refused.
    pub fn create(&self, job: &Job) -> Result<(), String> {
        if self.file("command").exists() {
            return Err(format!(
                "{} already holds a job: merge or resubmit it, or choose another --job-dir",
                self.path.display()
            ));
        }
        for dir in [self.path.clone(), self.file("shards"), self.file("logs")] {
            std::fs::create_dir_all(&dir)
                .map_err(|error| format!("cannot create {}: {error}", dir.display()))?;
        }
        let mut command = Vec::new();
        for arg in &job.command {
            if arg.as_bytes().contains(&0) {
                return Err("an argument holds a NUL byte".into());
            }
            command.extend_from_slice(arg.as_bytes());
            command.push(0);
        }
        let points: String = job
            .points
            .iter()
            .map(|point| format!("{point}\n"))
            .collect();
        self.write("points.txt", points.as_bytes())?;
        self.write("cwd", job.cwd.as_os_str().as_bytes())?;
        self.write("submissions.csv", b"slurm_job_id,array\n")?;
        // Written last: its presence says the folder holds a job.
        self.write("command", &command)
    }

    /// The job this folder records.
    pub fn job(&self) -> Result<Job, String> {
        let command = self.read("command")?;
        let command = command
            .strip_suffix(&[0])
            .unwrap_or(&command)
            .split(|&byte| byte == 0)
            .map(|arg| OsString::from_vec(arg.to_vec()))
            .collect();
        let points = String::from_utf8(self.read("points.txt")?)
            .map_err(|_| format!("{}: not UTF-8", self.file("points.txt").display()))?;
        Ok(Job {
            command,
            cwd: PathBuf::from(OsString::from_vec(self.read("cwd")?)),
            points: points.lines().map(String::from).collect(),
        })
    }

    /// The path of `name` in the folder.
    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// Point `index`'s shard.
    pub fn shard(&self, index: usize) -> PathBuf {
        self.file("shards").join(format!("{index}.csv"))
    }

    /// The folder where point `index` leaves states for later points and the merge.
    pub fn states(&self, index: usize) -> PathBuf {
        self.file("states").join(index.to_string())
    }

    /// Task `index`'s standard error in job `job_id`.
    pub fn stderr(&self, job_id: &str, index: usize) -> PathBuf {
        self.file("logs").join(format!("{job_id}_{index}.err"))
    }

    /// Writes `script` ([`job_script`]) as the folder's executable `job.sh`.
    pub fn write_script(&self, script: &str) -> Result<(), String> {
        self.write("job.sh", script.as_bytes())?;
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(self.file("job.sh"), std::fs::Permissions::from_mode(0o755))
            .map_err(|error| format!("{}: {error}", self.file("job.sh").display()))
    }

    /// Appends a submission to `submissions.csv`.
    pub fn record(&self, submission: &Submission) -> Result<(), String> {
        let mut text = self.read("submissions.csv")?;
        text.extend_from_slice(
            format!(
                "{},{}\n",
                submission.job_id,
                array_spec(&submission.indices)
            )
            .as_bytes(),
        );
        self.write("submissions.csv", &text)
    }

    /// The submissions so far, oldest first.
    pub fn submissions(&self) -> Result<Vec<Submission>, String> {
        let text = String::from_utf8(self.read("submissions.csv")?)
            .map_err(|_| "submissions.csv is not UTF-8".to_string())?;
        text.lines()
            .skip(1)
            .map(|line| {
                let (job_id, array) = line
                    .split_once(',')
                    .ok_or_else(|| format!("submissions.csv: bad line {line:?}"))?;
                Ok(Submission {
                    job_id: job_id.to_string(),
                    indices: parse_array_spec(array)
                        .ok_or_else(|| format!("submissions.csv: bad array {array:?}"))?,
                })
            })
            .collect()
    }

    /// Writes `bytes` as the folder's `name`, whole or not at all.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<(), String> {
        crate::io::output::OutputFile::create(&self.file(name))
            .and_then(|file| file.commit(bytes))
            .map_err(|error| error.to_string())
    }

    fn read(&self, name: &str) -> Result<Vec<u8>, String> {
        crate::io::input::read_regular(&self.file(name)).map_err(|error| {
            format!(
                "{}: {error} (is {} a job folder of fluid-lab slurm submit?)",
                self.file(name).display(),
                self.path.display()
            )
        })
    }
}

/// Single-quotes `text` for `sh`.
fn shell_quoted(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// A path `#SBATCH` lines can carry: UTF-8, without whitespace, quotes, backslashes or
/// `%` (which `--output` would expand).
fn sbatch_path(path: &Path) -> Result<&str, String> {
    path.to_str()
        .filter(|text| {
            !text
                .chars()
                .any(|c| c.is_whitespace() || matches!(c, '"' | '\'' | '\\' | '%'))
        })
        .ok_or_else(|| {
            format!(
                "{}: #SBATCH lines cannot hold this path (whitespace, quotes, \\ or %); use another folder",
                path.display()
            )
        })
}

/// A file's fingerprint as a job folder records it (the files its points read): its
/// path as given and the CRC-32 of `bytes`, its contents.
pub fn fingerprint(path: &Path, bytes: &[u8]) -> String {
    format!("{} {:08x}", path.display(), crc32fast::hash(bytes))
}

/// The fingerprint of the file at `path`, read.
pub fn file_fingerprint(path: &Path) -> Result<String, String> {
    let bytes = crate::io::input::read_regular(path)
        .map_err(|error| format!("cannot read {}: {error}", path.display()))?;
    Ok(fingerprint(path, &bytes))
}

/// The batch script: the placement's `#SBATCH` lines, logs in `dir/logs`, the task run
/// in `cwd` as `lab slurm task DIR $SLURM_ARRAY_TASK_ID`.
pub fn job_script(
    lab: &Path,
    cwd: &Path,
    dir: &Path,
    name: &str,
    placement: &Placement,
) -> Result<String, String> {
    let (cwd_text, dir_text) = (sbatch_path(cwd)?, sbatch_path(dir)?);
    let lab = lab
        .to_str()
        .ok_or_else(|| format!("{}: not UTF-8", lab.display()))?;
    let option = |text: &Option<String>, what: &str| -> Result<(), String> {
        match text {
            Some(value)
                if value.is_empty()
                    || value.chars().any(|c| c.is_whitespace() || c.is_control()) =>
            {
                Err(format!("--{what} {value:?} is not a Slurm {what}"))
            }
            _ => Ok(()),
        }
    };
    option(&placement.partition, "partition")?;
    option(&placement.time, "time")?;
    option(&placement.account, "account")?;
    let mut lines = vec![
        "#!/bin/sh".to_string(),
        format!("# fluid-lab {name} as a Slurm array: one point per task (points.txt)."),
        format!("#SBATCH --job-name=fluid-lab-{name}"),
        format!("#SBATCH --chdir={cwd_text}"),
        format!("#SBATCH --output={dir_text}/logs/%A_%a.out"),
        format!("#SBATCH --error={dir_text}/logs/%A_%a.err"),
        "#SBATCH --ntasks=1".to_string(),
    ];
    if placement.exclusive {
        lines.push("#SBATCH --exclusive".into());
    }
    for (what, value) in [
        ("partition", &placement.partition),
        ("time", &placement.time),
        ("account", &placement.account),
    ] {
        if let Some(value) = value {
            lines.push(format!("#SBATCH --{what}={value}"));
        }
    }
    lines.push(format!(
        "exec {} slurm task {} \"$SLURM_ARRAY_TASK_ID\"",
        shell_quoted(lab),
        shell_quoted(dir_text)
    ));
    Ok(lines.join("\n") + "\n")
}

/// Indices as a Slurm array: ascending ranges, `0-3,7,9-10`.
pub fn array_spec(indices: &[usize]) -> String {
    let mut sorted = indices.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    for index in sorted {
        match ranges.last_mut() {
            Some((_, end)) if *end + 1 == index => *end = index,
            _ => ranges.push((index, index)),
        }
    }
    ranges
        .iter()
        .map(|&(start, end)| match start == end {
            true => start.to_string(),
            false => format!("{start}-{end}"),
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// The indices of an [`array_spec`] (ranges and single indices, no steps).
pub fn parse_array_spec(spec: &str) -> Option<Vec<usize>> {
    let mut indices = Vec::new();
    for part in spec.split(',') {
        let (start, end): (usize, usize) = match part.split_once('-') {
            Some((start, end)) => (start.parse().ok()?, end.parse().ok()?),
            None => {
                let index = part.parse().ok()?;
                (index, index)
            }
        };
        if start > end {
            return None;
        }
        indices.extend(start..=end);
    }
    Some(indices)
}

/// `csv` (a subcommand's CSV: header, rows) with [`COLUMNS`] added to its header and
/// `place` to every row.
pub fn with_place(csv: &[u8], place: &TaskPlace) -> Result<Vec<u8>, Box<dyn Error>> {
    let mut reader = csv::ReaderBuilder::new().from_reader(csv);
    let mut writer = csv::Writer::from_writer(Vec::new());
    let mut header = reader.headers()?.clone();
    for column in COLUMNS {
        if header.iter().any(|name| name == column) {
            return Err(format!("the CSV already has a column {column}").into());
        }
        header.push_field(column);
    }
    writer.write_record(&header)?;
    let index = place.index.to_string();
    for record in reader.records() {
        let mut record = record?;
        for value in [&place.job_id, &index, &place.node] {
            record.push_field(value);
        }
        writer.write_record(&record)?;
    }
    Ok(writer.into_inner()?)
}

/// The shards of a job merged: one header, the rows in point order, and the points whose
/// shard is missing.
#[derive(Clone, Debug, PartialEq)]
pub struct Merged {
    /// The merged CSV.
    pub csv: Vec<u8>,
    /// The rows of each point that has a shard, and where it ran.
    pub done: BTreeMap<usize, (usize, TaskPlace)>,
    /// The points without a shard.
    pub missing: Vec<usize>,
}

/// Merges the shards of the points `order` names, in that order; shards must share their
/// header.
pub fn merge(dir: &JobDir, order: &[usize]) -> Result<Merged, Box<dyn Error>> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    let mut header: Option<csv::StringRecord> = None;
    let (mut done, mut missing) = (BTreeMap::new(), Vec::new());
    for &index in order {
        let path = dir.shard(index);
        let bytes = match crate::io::input::read_regular(&path) {
            Ok(bytes) => bytes,
            Err(error) if error.kind() == std::io::ErrorKind::NotFound => {
                missing.push(index);
                continue;
            }
            Err(error) => return Err(format!("{}: {error}", path.display()).into()),
        };
        let shard = |error: &dyn std::fmt::Display| format!("{}: {error}", path.display());
        let mut reader = csv::Reader::from_reader(bytes.as_slice());
        let this = reader.headers().map_err(|e| shard(&e))?.clone();
        match &header {
            None => {
                writer.write_record(&this)?;
                header = Some(this.clone());
            }
            Some(first) if *first != this => {
                return Err(shard(&"its columns differ from the other shards'").into())
            }
            Some(_) => {}
        }
        let column = |name: &str| {
            this.iter()
                .position(|c| c == name)
                .ok_or_else(|| shard(&format!("no column {name}")))
        };
        let (job, at, node) = (
            column(COLUMNS[0])?,
            column(COLUMNS[1])?,
            column(COLUMNS[2])?,
        );
        let mut rows = 0;
        let mut place = None;
        for record in reader.records() {
            let record = record.map_err(|e| shard(&e))?;
            if record[at] != index.to_string() {
                return Err(shard(&format!("a row of array index {}", &record[at])).into());
            }
            place.get_or_insert_with(|| TaskPlace {
                job_id: record[job].to_string(),
                index,
                node: record[node].to_string(),
            });
            writer.write_record(&record)?;
            rows += 1;
        }
        let place = place.ok_or_else(|| shard(&"no rows"))?;
        done.insert(index, (rows, place));
    }
    Ok(Merged {
        csv: writer.into_inner()?,
        done,
        missing,
    })
}

/// Submits `script` as an array of `indices` with `sbatch --parsable` (`overrides`'
/// options, if any, override the script's), after every job of `after` has succeeded
/// (and cancelled if one fails); returns the job id.
pub fn submit(
    sbatch: &Path,
    script: &Path,
    indices: &[usize],
    overrides: &Placement,
    after: &[String],
) -> Result<String, String> {
    let mut command = Command::new(sbatch);
    command
        .arg("--parsable")
        .arg(format!("--array={}", array_spec(indices)));
    if !after.is_empty() {
        command
            .arg(format!("--dependency=afterok:{}", after.join(":")))
            .arg("--kill-on-invalid-dep=yes");
    }
    for (what, value) in [
        ("partition", &overrides.partition),
        ("time", &overrides.time),
        ("account", &overrides.account),
    ] {
        if let Some(value) = value {
            command.arg(format!("--{what}={value}"));
        }
    }
    let output = command
        .arg(script)
        .output()
        .map_err(|error| format!("cannot run {}: {error}", sbatch.display()))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let job_id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if !output.status.success() {
        return Err(format!("sbatch failed: {}", said(&output)));
    }
    if job_id.is_empty() || !job_id.bytes().all(|b| b.is_ascii_digit()) {
        let printed = stdout.trim();
        return Err(match printed.is_empty() {
            true => "sbatch succeeded but printed no job id".to_string(),
            false => format!("sbatch succeeded but printed no job id: {printed:?}"),
        });
    }
    Ok(job_id)
}

/// What a Slurm client that failed said: the last line it wrote to stderr, or its exit
/// status where it wrote none.
fn said(output: &std::process::Output) -> String {
    match last_line(&output.stderr) {
        line if line.is_empty() => format!("{}, with nothing on its stderr", output.status),
        line => line,
    }
}

/// The last line a Slurm client wrote to stderr (the fatal one, after its errors on the
/// way), without the client's `name: ` prefix repeated by the caller's message.
fn last_line(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let line = text
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("");
    let line = line.trim();
    ["sbatch: ", "squeue: ", "sacct: "]
        .iter()
        .find_map(|prefix| line.strip_prefix(prefix))
        .unwrap_or(line)
        .to_string()
}

/// The array indices of `job_ids` that Slurm still holds pending or running (`squeue`),
/// or the reason it could not say.
pub fn queued(squeue: &Path, job_ids: &[String]) -> Result<HashSet<(String, usize)>, String> {
    if job_ids.is_empty() {
        return Ok(HashSet::new());
    }
    let output = Command::new(squeue)
        .args(["--noheader", "--array", "--format=%F %K"])
        .arg(format!("--jobs={}", job_ids.join(",")))
        .output()
        .map_err(|error| format!("cannot run {}: {error}", squeue.display()))?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    // A job Slurm has already forgotten is no longer queued.
    if !output.status.success() && !stderr.contains("Invalid job id") {
        return Err(format!("squeue failed: {}", said(&output)));
    }
    Ok(parse_queued(&String::from_utf8_lossy(&output.stdout)))
}

/// The (job id, index) pairs of `squeue --array --format="%F %K"` lines.
fn parse_queued(text: &str) -> HashSet<(String, usize)> {
    text.lines()
        .filter_map(|line| {
            let (job, index) = line.trim().split_once(' ')?;
            Some((job.to_string(), index.trim().parse().ok()?))
        })
        .collect()
}

/// Waits until no task of `job_ids` is queued, asking `squeue` after 1 s, then at
/// doubling intervals up to 10 s (a light load on the controller).
pub fn wait(squeue: &Path, job_ids: &[String]) -> Result<(), String> {
    let mut every = Duration::from_secs(1);
    while !queued(squeue, job_ids)?.is_empty() {
        std::thread::sleep(every);
        every = (every * 2).min(Duration::from_secs(10));
    }
    Ok(())
}

/// Slurm's energy accounting of an array's tasks: joules per (job id, index), or why
/// there are none.
#[derive(Clone, Debug, PartialEq)]
pub enum SlurmEnergy {
    /// `ConsumedEnergyRaw` of each task that has one above zero.
    Measured(BTreeMap<(String, usize), u64>),
    /// Why no task has one.
    NotAvailable(String),
}

impl SlurmEnergy {
    /// Asks `sacct` for the tasks of `job_ids`.
    pub fn of(sacct: &Path, job_ids: &[String]) -> SlurmEnergy {
        let output = Command::new(sacct)
            .args([
                "--noheader",
                "--parsable2",
                "--format=JobID,ConsumedEnergyRaw",
            ])
            .arg(format!("--jobs={}", job_ids.join(",")))
            .output();
        match output {
            Err(error) => {
                SlurmEnergy::NotAvailable(format!("cannot run {}: {error}", sacct.display()))
            }
            Ok(output) if !output.status.success() => {
                SlurmEnergy::NotAvailable(format!("sacct: {}", said(&output)))
            }
            Ok(output) => SlurmEnergy::parse(&String::from_utf8_lossy(&output.stdout)),
        }
    }

    /// Reads `sacct --parsable2 --format=JobID,ConsumedEnergyRaw` lines: each array
    /// task's own line (`JOB_INDEX`), or where that is empty its batch step's.
    pub fn parse(text: &str) -> SlurmEnergy {
        let mut joules = BTreeMap::new();
        for line in text.lines() {
            let Some((id, energy)) = line.split_once('|') else {
                continue;
            };
            let (task, step) = id.split_once('.').map_or((id, None), |(t, s)| (t, Some(s)));
            let Some((job, index)) = task.split_once('_') else {
                continue;
            };
            let (Ok(index), Ok(energy)) = (index.parse::<usize>(), energy.trim().parse::<u64>())
            else {
                continue;
            };
            if energy == 0 || !matches!(step, None | Some("batch")) {
                continue;
            }
            let key = (job.to_string(), index);
            // The task's own line (the whole allocation) before its batch step's.
            if step.is_none() || !joules.contains_key(&key) {
                joules.insert(key, energy);
            }
        }
        match joules.is_empty() {
            true => SlurmEnergy::NotAvailable(
                "sacct reports no ConsumedEnergyRaw for these tasks (no AcctGatherEnergyType \
                 on their nodes)"
                    .into(),
            ),
            false => SlurmEnergy::Measured(joules),
        }
    }

    /// The method's description for the `energy_method` column.
    pub fn describe(&self) -> String {
        match self {
            SlurmEnergy::Measured(_) => format!(
                "{ENERGY_METHOD}: ConsumedEnergyRaw of the whole array task (all its runs, \
                 warm-up and idle windows), J"
            ),
            SlurmEnergy::NotAvailable(why) => format!("{ENERGY_METHOD} not available: {why}"),
        }
    }

    /// Task (`job_id`, `index`)'s joules, if measured.
    pub fn joules(&self, job_id: &str, index: usize) -> Option<u64> {
        match self {
            SlurmEnergy::Measured(joules) => joules.get(&(job_id.to_string(), index)).copied(),
            SlurmEnergy::NotAvailable(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn place(index: usize) -> TaskPlace {
        TaskPlace {
            job_id: "4242".into(),
            index,
            node: "node-3".into(),
        }
    }

    #[test]
    fn arrays_are_written_as_ranges_and_read_back() {
        assert_eq!(array_spec(&[0, 1, 2, 3, 7, 9, 10]), "0-3,7,9-10");
        assert_eq!(array_spec(&[5, 3, 4, 4]), "3-5");
        assert_eq!(
            parse_array_spec("0-3,7,9-10"),
            Some(vec![0, 1, 2, 3, 7, 9, 10])
        );
        assert_eq!(parse_array_spec("3-1"), None);
        assert_eq!(parse_array_spec("1:2"), None);
        assert_eq!(parse_array_spec(""), None);
    }

    #[test]
    fn the_script_carries_the_placement_and_runs_the_task_in_the_submit_folder() {
        let placement = Placement {
            partition: Some("cpu".into()),
            time: Some("00:30:00".into()),
            account: None,
            exclusive: true,
        };
        let script = job_script(
            Path::new("/opt/it's/fluid-lab"),
            Path::new("/home/u/fluid"),
            Path::new("/scratch/job"),
            "sweep",
            &placement,
        )
        .unwrap();
        for line in [
            "#SBATCH --chdir=/home/u/fluid",
            "#SBATCH --output=/scratch/job/logs/%A_%a.out",
            "#SBATCH --error=/scratch/job/logs/%A_%a.err",
            "#SBATCH --exclusive",
            "#SBATCH --partition=cpu",
            "#SBATCH --time=00:30:00",
            r#"exec '/opt/it'\''s/fluid-lab' slurm task '/scratch/job' "$SLURM_ARRAY_TASK_ID""#,
        ] {
            assert!(script.lines().any(|l| l == line), "{line}\n{script}");
        }
        assert!(!script.contains("--account"));
        let shared = job_script(
            Path::new("/l"),
            Path::new("/c"),
            Path::new("/d"),
            "stability",
            &Placement::default(),
        )
        .unwrap();
        assert!(!shared.contains("--exclusive"));
        let spaced = job_script(
            Path::new("/l"),
            Path::new("/my home"),
            Path::new("/d"),
            "x",
            &placement,
        );
        assert!(spaced.unwrap_err().contains("cannot hold this path"));
        let percent = job_script(
            Path::new("/l"),
            Path::new("/c"),
            Path::new("/d%j"),
            "x",
            &placement,
        );
        assert!(percent.is_err());
        let bad_time = Placement {
            time: Some("1 hour".into()),
            ..Placement::default()
        };
        let refused = job_script(
            Path::new("/l"),
            Path::new("/c"),
            Path::new("/d"),
            "x",
            &bad_time,
        );
        assert!(refused.unwrap_err().contains("--time"));
    }

    #[test]
    fn a_job_folder_keeps_its_command_points_and_submissions() {
        let temp = tempfile::tempdir().unwrap();
        let dir = JobDir::at(&temp.path().join("job")).unwrap();
        let job = Job {
            command: vec![
                "sweep".into(),
                OsString::from_vec(b"odd \xff name".to_vec()),
                "".into(),
            ],
            cwd: temp.path().to_path_buf(),
            points: vec!["idle baseline".into(), "small.fld, 10 iterations".into()],
        };
        dir.create(&job).unwrap();
        assert_eq!(dir.job().unwrap(), job);
        assert!(dir
            .create(&job)
            .unwrap_err()
            .contains("already holds a job"));
        for submission in [
            Submission {
                job_id: "7".into(),
                indices: vec![0, 1],
            },
            Submission {
                job_id: "9".into(),
                indices: vec![1],
            },
        ] {
            dir.record(&submission).unwrap();
        }
        let submissions = dir.submissions().unwrap();
        assert_eq!(submissions.len(), 2);
        assert_eq!(
            (
                submissions[1].job_id.as_str(),
                submissions[1].indices.clone()
            ),
            ("9", vec![1])
        );
        let not_a_job = JobDir::at(temp.path()).unwrap();
        assert!(not_a_job.job().unwrap_err().contains("a job folder"));
    }

    #[test]
    fn shards_merge_in_point_order_and_missing_points_are_named() {
        let temp = tempfile::tempdir().unwrap();
        let dir = JobDir::at(temp.path()).unwrap();
        std::fs::create_dir_all(dir.file("shards")).unwrap();
        for index in [2, 0] {
            let rows = format!("a,b\n{index},\"x,y\"\n{index},z\n");
            let shard = with_place(rows.as_bytes(), &place(index)).unwrap();
            std::fs::write(dir.shard(index), shard).unwrap();
        }
        let merged = merge(&dir, &[0, 1, 2, 3]).unwrap();
        assert_eq!(
            String::from_utf8(merged.csv).unwrap(),
            "a,b,slurm_job_id,slurm_array_index,slurm_node\n\
             0,\"x,y\",4242,0,node-3\n0,z,4242,0,node-3\n\
             2,\"x,y\",4242,2,node-3\n2,z,4242,2,node-3\n"
        );
        assert_eq!(merged.missing, vec![1, 3]);
        assert_eq!(merged.done[&2], (2, place(2)));
        std::fs::write(
            dir.shard(1),
            "a,c,slurm_job_id,slurm_array_index,slurm_node\n1,2,3,1,n\n",
        )
        .unwrap();
        let differ = merge(&dir, &[0, 1, 2, 3]).unwrap_err().to_string();
        assert!(differ.contains("1.csv: its columns differ"), "{differ}");
        std::fs::write(
            dir.shard(1),
            "a,b,slurm_job_id,slurm_array_index,slurm_node\n1,2,3,0,n\n",
        )
        .unwrap();
        let misplaced = merge(&dir, &[0, 1, 2, 3]).unwrap_err().to_string();
        assert!(misplaced.contains("a row of array index 0"), "{misplaced}");
        assert!(with_place(b"slurm_node\nx\n", &place(0)).is_err());
    }

    #[test]
    fn queued_tasks_are_read_from_squeue_lines() {
        let text = "  4242 3\n4242 4\n4250 0\nnot a line\n";
        let queued = parse_queued(text);
        assert_eq!(queued.len(), 3);
        assert!(queued.contains(&("4242".to_string(), 4)));
    }

    #[test]
    fn slurm_energy_is_read_from_sacct_and_its_absence_is_explained() {
        // The shape of `sacct --parsable2 --format=JobID,ConsumedEnergyRaw` on a cluster
        // with acct_gather_energy: the task's line, its batch and extern steps.
        let measured = "4242_0|10450\n4242_0.batch|10448\n4242_0.extern|10450\n\
                        4242_1||\n4242_1.batch|9980\n4242_[2-3]|\n";
        let energy = SlurmEnergy::parse(measured);
        assert_eq!(energy.joules("4242", 0), Some(10450));
        assert_eq!(energy.joules("4242", 1), Some(9980));
        assert_eq!(energy.joules("4242", 2), None);
        assert!(energy
            .describe()
            .starts_with("slurm-sacct: ConsumedEnergyRaw"));
        // Without an energy plugin every task reports 0.
        let zeros = SlurmEnergy::parse("12_0|0\n12_0.batch|0\n");
        assert!(
            matches!(&zeros, SlurmEnergy::NotAvailable(why) if why.contains("AcctGatherEnergyType"))
        );
        assert_eq!(zeros.joules("12", 0), None);
        // What sacct printed, with exit status 1, on the local one-node Slurm of
        // scripts/slurm-local.sh, which has no accounting database.
        let temp = tempfile::tempdir().unwrap();
        let sacct = temp.path().join("sacct");
        std::fs::write(
            &sacct,
            "#!/bin/sh\necho 'Slurm accounting storage is disabled' >&2\nexit 1\n",
        )
        .unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&sacct, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert_eq!(
            SlurmEnergy::of(&sacct, &["1".into()]).describe(),
            "slurm-sacct not available: sacct: Slurm accounting storage is disabled"
        );
        // One that fails without a word (the eighth hostile pass: an empty reason).
        std::fs::write(&sacct, "#!/bin/sh\nexit 3\n").unwrap();
        assert_eq!(
            SlurmEnergy::of(&sacct, &["1".into()]).describe(),
            "slurm-sacct not available: sacct: exit status: 3, with nothing on its stderr"
        );
        let absent = SlurmEnergy::of(&temp.path().join("none"), &["1".into()]);
        assert!(absent
            .describe()
            .starts_with("slurm-sacct not available: cannot run"));
    }
}
