//! `fluid-lab slurm`: a sweep, a stability map or an accuracy sweep as a Slurm job
//! array, one point per task (`submit`, `task`), its shards merged into the subcommand's
//! own CSV and charts (`merge`), and the points that failed run again (`resubmit`).

use super::accuracy::AccuracyArgs;
use super::stability::StabilityArgs;
use super::sweep::SweepArgs;
use super::MadeFolder;
use crate::io::output::OutputFile;
use crate::lab::slurm::{self, Job, JobDir, Placement, SlurmEnergy, Submission, TaskPlace};
use crate::lab::stability;
use crate::lab::UsageError;
use crate::lab::{Command as LabCommand, Lab};
use clap::{Args, Parser, Subcommand};
use std::error::Error;
use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `fluid-lab slurm`.
#[derive(Debug, Args)]
pub struct SlurmArgs {
    #[command(subcommand)]
    action: Action,
}

// The actions (a plain comment: clap would take a doc comment as the about).
#[derive(Debug, Subcommand)]
enum Action {
    /// Write the job folder and submit the subcommand after `--` (sweep, stability or
    /// accuracy) as an array, one point per task.
    Submit(SubmitArgs),
    /// Run one point of a job folder and write its shard (what job.sh runs in each task).
    Task(TaskArgs),
    /// Merge the shards into the subcommand's own CSV (plus the Slurm job id, array index
    /// and node of every row) and draw its charts; list the points missing and why.
    Merge(MergeArgs),
    /// Submit again the points that failed or never ran (not those still queued).
    Resubmit(ResubmitArgs),
}

/// Where and how long tasks run.
#[derive(Debug, Args)]
struct PlacementArgs {
    /// The partition (sbatch --partition).
    #[arg(long)]
    partition: Option<String>,
    /// Each task's time limit (sbatch --time, as 30, 1:00:00 or 1-0).
    #[arg(long)]
    time: Option<String>,
    /// The account charged (sbatch --account).
    #[arg(long)]
    account: Option<String>,
}

/// The Slurm programs used.
#[derive(Debug, Args)]
struct Programs {
    /// The sbatch program.
    #[arg(long, default_value = "sbatch")]
    sbatch: PathBuf,
    /// The squeue program.
    #[arg(long, default_value = "squeue")]
    squeue: PathBuf,
}

/// The arguments of `fluid-lab slurm submit`.
#[derive(Debug, Args)]
struct SubmitArgs {
    /// The job folder to create (its command, points, script, shards and logs).
    #[arg(long)]
    job_dir: PathBuf,
    #[command(flatten)]
    placement: PlacementArgs,
    /// Give each task a whole node (the default for sweeps, which time runs).
    #[arg(long, conflicts_with = "shared")]
    exclusive: bool,
    /// Let tasks share nodes (the default for stability maps, which count steps).
    #[arg(long)]
    shared: bool,
    /// Return only when every task has ended (asking squeue every few seconds).
    #[arg(long)]
    wait: bool,
    #[command(flatten)]
    programs: Programs,
    /// The subcommand and its arguments, after `--`: `sweep ...`, `stability ...` or `accuracy ...`.
    #[arg(last = true, required = true)]
    command: Vec<OsString>,
}

/// The arguments of `fluid-lab slurm task`.
#[derive(Debug, Args)]
struct TaskArgs {
    /// The job folder.
    job_dir: PathBuf,
    /// The point's array index.
    #[arg(allow_negative_numbers = true, value_parser = super::whole::<usize>(0, u32::MAX.into()))]
    index: usize,
}

/// The arguments of `fluid-lab slurm merge`.
#[derive(Debug, Args)]
struct MergeArgs {
    /// The job folder.
    job_dir: PathBuf,
    /// Write the CSV and charts of the points there are even when some are missing.
    #[arg(long)]
    partial: bool,
    /// The sacct program, asked for Slurm's energy accounting of each task.
    #[arg(long, default_value = "sacct")]
    sacct: PathBuf,
    /// The squeue program, asked which missing points are still queued.
    #[arg(long, default_value = "squeue")]
    squeue: PathBuf,
}

/// The arguments of `fluid-lab slurm resubmit`.
#[derive(Debug, Args)]
struct ResubmitArgs {
    /// The job folder.
    job_dir: PathBuf,
    /// Options that override the job script's for these tasks (a longer --time, say).
    #[command(flatten)]
    placement: PlacementArgs,
    /// Return only when every task has ended.
    #[arg(long)]
    wait: bool,
    #[command(flatten)]
    programs: Programs,
}

/// Runs the action.
pub fn exec(args: SlurmArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    match args.action {
        Action::Submit(args) => submit(args, stdout),
        Action::Task(args) => task(args),
        Action::Merge(args) => merge(args, stdout),
        Action::Resubmit(args) => resubmit(args, stdout),
    }
}

/// The job folder's file of the fingerprint of the files its points read ([`Tool::scene`]).
const SCENE_FILE: &str = "scene";

/// A subcommand whose points a job array runs.
enum Tool {
    Sweep(SweepArgs),
    Stability(StabilityArgs),
    Accuracy(AccuracyArgs),
}

impl Tool {
    /// The subcommand of `command` (its name first), an accuracy sweep's case read; a
    /// command line it cannot run is a usage error, in one line.
    fn parse(command: &[OsString]) -> Result<Tool, Box<dyn Error>> {
        let words = std::iter::once(OsString::from("fluid-lab")).chain(command.iter().cloned());
        let lab = Lab::try_parse_from(words).map_err(|error| {
            // clap's message without its usage lines and its own "error: ".
            let text = error.to_string();
            let lines = text.lines().take_while(|line| !line.starts_with("Usage:"));
            let words: Vec<&str> = lines.map(str::trim).filter(|l| !l.is_empty()).collect();
            let message = words.join(" ");
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            UsageError(format!("the subcommand after --: {message}"))
        })?;
        match lab.command {
            LabCommand::Sweep(args) => Ok(Tool::Sweep(args)),
            LabCommand::Stability(args) => Ok(Tool::Stability(args)),
            LabCommand::Accuracy(mut args) => {
                args.read_case()?;
                Ok(Tool::Accuracy(args))
            }
            _ => Err(UsageError(format!(
                "fluid-lab slurm runs sweep, stability and accuracy, not {}",
                command[0].to_string_lossy()
            ))
            .into()),
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Tool::Sweep(_) => "sweep",
            Tool::Stability(_) => "stability",
            Tool::Accuracy(_) => "accuracy",
        }
    }

    /// Whether its points are timings (a sweep's wall times, the accuracy sweep's CPU
    /// seconds), which need a node each.
    fn times(&self) -> bool {
        matches!(self, Tool::Sweep(_) | Tool::Accuracy(_))
    }

    fn points(&self) -> Result<Vec<String>, Box<dyn Error>> {
        match self {
            Tool::Sweep(args) => args.points(),
            Tool::Stability(args) => args.points(),
            Tool::Accuracy(args) => args.points(),
        }
    }

    /// The points of `count` in the stages they run in, each stage after the one before
    /// has succeeded: the accuracy sweep's methods, then its reference.
    fn stages(&self, count: usize) -> Vec<Vec<usize>> {
        match self {
            Tool::Accuracy(_) => vec![(0..count - 1).collect(), vec![count - 1]],
            _ => vec![(0..count).collect()],
        }
    }

    /// The order in which the merge takes the points' shards: the accuracy sweep's
    /// reference first, as its own CSV has it.
    fn merge_order(&self, count: usize) -> Vec<usize> {
        match self {
            Tool::Accuracy(_) => std::iter::once(count - 1).chain(0..count - 1).collect(),
            _ => (0..count).collect(),
        }
    }

    /// Runs point `index` of the job in `dir`: its CSV.
    fn run_point(
        &self,
        index: usize,
        dir: &JobDir,
        count: usize,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        match self {
            Tool::Sweep(args) => args.measure_point(index),
            Tool::Stability(args) => args.watch_point(index),
            Tool::Accuracy(args) if index + 1 < count => {
                args.run_method_point(index, &dir.states(index))
            }
            Tool::Accuracy(args) => {
                let methods: Vec<usize> = (0..index).collect();
                let merged = slurm::merge(dir, &methods)?;
                if !merged.missing.is_empty() {
                    return Err(format!(
                        "the reference needs every method's times, and points {} have no shard",
                        slurm::array_spec(&merged.missing)
                    )
                    .into());
                }
                args.run_reference_point(std::str::from_utf8(&merged.csv)?, &dir.states(index))
            }
        }
    }

    /// The merged CSV of `count` points completed: the accuracy sweep's errors, from the
    /// points' states.
    fn complete(
        &self,
        merged: Vec<u8>,
        dir: &JobDir,
        count: usize,
    ) -> Result<Vec<u8>, Box<dyn Error>> {
        match self {
            Tool::Accuracy(args) => args.fill_errors(&merged, &dir.file("states"), count - 1),
            _ => Ok(merged),
        }
    }

    /// Refuses what an array of the subcommand could not run, before it is submitted.
    fn check_submittable(&self) -> Result<(), Box<dyn Error>> {
        match self {
            Tool::Sweep(args) => Ok(args.check_submittable()?),
            Tool::Accuracy(args) => args.check_submittable(),
            Tool::Stability(_) => Ok(()),
        }
    }

    /// The fingerprint of the files the points read ([`SCENE_FILE`]): an accuracy
    /// sweep's case or input, a sweep's inputs (a stability map's scenes are made).
    fn scene(&self) -> Result<Option<String>, Box<dyn Error>> {
        match self {
            Tool::Accuracy(args) => args.scene_fingerprint().map(Some),
            Tool::Sweep(args) => args.inputs_fingerprint().map(Some),
            Tool::Stability(_) => Ok(None),
        }
    }

    /// Refuses to go on when the job folder's command no longer gives the points it was
    /// submitted with (`points`, from points.txt), or when the scene's file changed
    /// since: its points would measure two things.
    fn check_job(&self, dir: &JobDir, points: &[String]) -> Result<(), Box<dyn Error>> {
        if self.points()? != points {
            return Err(format!(
                "{}: its command no longer gives the points in points.txt (was the job \
                 folder edited?); submit the job again",
                dir.path.display()
            )
            .into());
        }
        self.check_scene(dir)
    }

    /// Refuses to go on when the scene's file changed since the job was submitted: its
    /// points would measure two scenes (a job folder from before fingerprints passes).
    fn check_scene(&self, dir: &JobDir) -> Result<(), Box<dyn Error>> {
        let (Some(now), true) = (self.scene()?, dir.file(SCENE_FILE).is_file()) else {
            return Ok(());
        };
        let then = crate::io::input::read_regular_text(&dir.file(SCENE_FILE))?;
        if then.trim_end() != now {
            return Err(format!(
                "the scene changed since the job was submitted ({} then, {now} now): its \
                 points would measure two; submit the job again",
                then.trim_end()
            )
            .into());
        }
        Ok(())
    }

    /// The CSV the subcommand writes, which the merge writes.
    fn csv_path(&self) -> PathBuf {
        match self {
            Tool::Sweep(args) => args.csv_path().to_path_buf(),
            Tool::Stability(args) => args.csv_path(),
            Tool::Accuracy(args) => args.csv_path(),
        }
    }

    /// Makes the folder of its CSV, as the subcommand does.
    fn create_folder(&self) -> Result<Option<MadeFolder>, String> {
        match self {
            Tool::Sweep(_) => Ok(None),
            Tool::Stability(args) => super::create_output_dir(args.output_dir()).map(Some),
            Tool::Accuracy(args) => super::create_output_dir(args.output_dir()).map(Some),
        }
    }

    /// Checks the merged CSV `rows` as the subcommand's charts read them, before they are
    /// written: a shard edited by hand may hold what no run writes.
    fn check(&self, rows: &[u8], csv: &Path) -> Result<(), Box<dyn Error>> {
        let text =
            std::str::from_utf8(rows).map_err(|_| format!("{}: not UTF-8", csv.display()))?;
        let named = |error: Box<dyn Error>| format!("{}: {error}", csv.display());
        match self {
            Tool::Sweep(_) => crate::lab::chart::SweepTable::parse(text)
                .map(drop)
                .map_err(named)?,
            Tool::Stability(_) => stability::read_csv(text)
                .map(drop)
                .map_err(|error| named(error.into()))?,
            Tool::Accuracy(args) => args.check_csv(text).map_err(named)?,
        }
        Ok(())
    }

    /// Draws its charts from the merged CSV at `csv`.
    fn chart(&self, csv: &Path, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
        match self {
            Tool::Sweep(_) => {
                let folder = csv.parent().map(PathBuf::from).unwrap_or_default();
                super::chart::draw(&super::chart::read(csv)?, &folder, stdout)
            }
            Tool::Stability(args) => {
                let text = crate::io::input::read_regular_text(csv)
                    .map_err(|error| format!("cannot read {}: {error}", csv.display()))?;
                let outcomes = stability::read_csv(&text)
                    .map_err(|error| format!("{}: {error}", csv.display()))?;
                args.draw(&outcomes, stdout)
            }
            Tool::Accuracy(args) => args.chart(csv, stdout),
        }
    }
}

impl PlacementArgs {
    fn placement(&self, exclusive: bool) -> Placement {
        Placement {
            partition: self.partition.clone(),
            time: self.time.clone(),
            account: self.account.clone(),
            exclusive,
        }
    }
}

/// Submits the array of every point.
fn submit(args: SubmitArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let tool = Tool::parse(&args.command)?;
    tool.check_submittable()?;
    let points = tool.points()?;
    if points.is_empty() {
        return Err(format!("the {} has no points to run", tool.name()).into());
    }
    let exclusive = match (args.exclusive, args.shared) {
        (true, _) => true,
        (_, true) => false,
        _ => tool.times(),
    };
    let dir = JobDir::at(&args.job_dir)?;
    let cwd = std::env::current_dir()?;
    let placement = args.placement.placement(exclusive);
    // The script is made (and so checked) before the folder is.
    let script = slurm::job_script(
        &std::env::current_exe()?,
        &cwd,
        &dir.path,
        tool.name(),
        &placement,
    )?;
    // The merged CSV's place must take it, as the subcommand's own run checks first; it
    // may be in the job folder, made here (and removed again if the check fails).
    let job_folder = super::create_output_dir(&dir.path)?;
    let tool_folder = tool.create_folder()?;
    drop(OutputFile::create(&tool.csv_path())?);
    // The job folder stays whatever happens next (a failed sbatch leaves it to
    // resubmit); the subcommand's, only once the job is submitted (the merge makes it).
    job_folder.keep();
    let count = points.len();
    dir.create(&Job {
        command: args.command,
        cwd: cwd.clone(),
        points,
    })?;
    if let Some(scene) = tool.scene()? {
        dir.write(SCENE_FILE, format!("{scene}\n").as_bytes())?;
    }
    dir.write_script(&script)?;
    let mut job_ids: Vec<String> = Vec::new();
    for stage in tool.stages(count) {
        let after = job_ids.last().cloned().into_iter().collect::<Vec<_>>();
        let job_id = submit_and_record(&dir, &args.programs, &stage, &Placement::default(), &after)
            .map_err(|error| {
                format!(
                    "{error}; the job folder is kept, and fluid-lab slurm resubmit {} submits \
                     its points once sbatch works",
                    dir.path.display()
                )
            })?;
        writeln!(
            stdout,
            "submitted job {job_id}: {} points {} of {count} as array tasks ({}){}; folder {}",
            tool.name(),
            slurm::array_spec(&stage),
            if exclusive {
                "a node each"
            } else {
                "nodes shared"
            },
            match after.first() {
                Some(before) => format!(", after job {before} has succeeded"),
                None => String::new(),
            },
            dir.path.display()
        )?;
        job_ids.push(job_id);
    }
    if let Some(folder) = tool_folder {
        folder.keep();
    }
    finish(&dir, &args.programs, &job_ids, args.wait, stdout)
}

/// Submits `indices` of the job folder's script and records the submission.
fn submit_and_record(
    dir: &JobDir,
    programs: &Programs,
    indices: &[usize],
    overrides: &Placement,
    after: &[String],
) -> Result<String, String> {
    let job_id = slurm::submit(
        &programs.sbatch,
        &dir.file("job.sh"),
        indices,
        overrides,
        after,
    )?;
    dir.record(&Submission {
        job_id: job_id.clone(),
        indices: indices.to_vec(),
    })?;
    Ok(job_id)
}

/// With `wait`, waits for the jobs `job_ids` and says how many points have a shard;
/// without, says how to merge.
fn finish(
    dir: &JobDir,
    programs: &Programs,
    job_ids: &[String],
    wait: bool,
    stdout: &mut impl Write,
) -> Result<(), Box<dyn Error>> {
    let merge = format!("fluid-lab slurm merge {}", dir.path.display());
    if !wait {
        writeln!(stdout, "when it has ended: {merge}")?;
        return Ok(());
    }
    slurm::wait(&programs.squeue, job_ids)?;
    let job = dir.job()?;
    let done = (0..job.points.len())
        .filter(|&i| dir.shard(i).is_file())
        .count();
    writeln!(
        stdout,
        "job {} has ended: {done} of {} points done; {merge}",
        job_ids.join(", "),
        job.points.len()
    )?;
    if done < job.points.len() {
        return Err(format!(
            "{} of {} points have no shard; {merge} lists why",
            job.points.len() - done,
            job.points.len()
        )
        .into());
    }
    Ok(())
}

/// Runs one point inside its array task and writes its shard.
fn task(args: TaskArgs) -> Result<(), Box<dyn Error>> {
    let dir = JobDir::at(&args.job_dir)?;
    let job = dir.job()?;
    let place = TaskPlace::from_environment()?;
    if place.index != args.index {
        return Err(format!(
            "index {} is not this array task's ({})",
            args.index, place.index
        )
        .into());
    }
    let point = job.points.get(args.index).ok_or_else(|| {
        format!(
            "the job has no point {} ({} points)",
            args.index,
            job.points.len()
        )
    })?;
    eprintln!(
        "fluid-lab slurm: job {} task {} on {}: {point}",
        place.job_id, place.index, place.node
    );
    std::env::set_current_dir(&job.cwd)
        .map_err(|error| format!("cannot enter {}: {error}", job.cwd.display()))?;
    let tool = Tool::parse(&job.command)?;
    tool.check_job(&dir, &job.points)?;
    let shard = OutputFile::create(&dir.shard(args.index))?;
    let rows = tool.run_point(args.index, &dir, job.points.len())?;
    shard.commit(&slurm::with_place(&rows, &place)?)?;
    Ok(())
}

/// What became of a point.
enum Status {
    Done { rows: usize, place: TaskPlace },
    Queued { job_id: String },
    Failed { job_id: String },
    NotRun,
}

/// Merges the shards, writes tasks.csv, and the CSV and charts if every point is there
/// (or `--partial`).
fn merge(args: MergeArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let dir = JobDir::at(&args.job_dir)?;
    let job = dir.job()?;
    // A job folder edited by hand may list none: nothing to merge, nothing written.
    if job.points.is_empty() {
        return Err(format!("{}: the job lists no points", dir.path.display()).into());
    }
    // The subcommand's paths are the submitter's, as they are its tasks'.
    std::env::set_current_dir(&job.cwd)
        .map_err(|error| format!("cannot enter {}: {error}", job.cwd.display()))?;
    let tool = Tool::parse(&job.command)?;
    tool.check_job(&dir, &job.points)?;
    let merged = slurm::merge(&dir, &tool.merge_order(job.points.len()))?;
    let submissions = dir.submissions()?;
    let job_ids: Vec<String> = submissions.iter().map(|s| s.job_id.clone()).collect();
    let queued = match merged.missing.is_empty() {
        true => Default::default(),
        false => slurm::queued(&args.squeue, &job_ids).unwrap_or_else(|error| {
            eprintln!("warning: {error}; queued points are counted as not run");
            Default::default()
        }),
    };
    let energy = SlurmEnergy::of(&args.sacct, &job_ids);
    let statuses: Vec<Status> = (0..job.points.len())
        .map(|index| {
            if let Some((rows, place)) = merged.done.get(&index) {
                return Status::Done {
                    rows: *rows,
                    place: place.clone(),
                };
            }
            let latest = submissions
                .iter()
                .rev()
                .find(|s| s.indices.contains(&index));
            match latest {
                Some(s) if queued.contains(&(s.job_id.clone(), index)) => Status::Queued {
                    job_id: s.job_id.clone(),
                },
                Some(s) if dir.stderr(&s.job_id, index).exists() => Status::Failed {
                    job_id: s.job_id.clone(),
                },
                _ => Status::NotRun,
            }
        })
        .collect();
    write_tasks(&dir, &job, &statuses, &energy)?;
    writeln!(
        stdout,
        "wrote {} (energy: {})",
        dir.file("tasks.csv").display(),
        energy.describe()
    )?;
    let missing = merged.missing.len();
    if missing > 0 {
        writeln!(stdout, "{missing} of {} points missing:", job.points.len())?;
        for index in &merged.missing {
            let point = &job.points[*index];
            match &statuses[*index] {
                Status::Queued { job_id } => {
                    writeln!(stdout, "  {index} ({point}): still queued in job {job_id}")?
                }
                Status::NotRun => writeln!(
                    stdout,
                    "  {index} ({point}): never started (no log: cancelled, or an earlier stage failed)"
                )?,
                Status::Failed { job_id } => {
                    let log = dir.stderr(job_id, *index);
                    writeln!(
                        stdout,
                        "  {index} ({point}): failed in job {job_id}; {}:",
                        log.display()
                    )?;
                    let text = std::fs::read_to_string(&log).unwrap_or_default();
                    let lines: Vec<&str> = text.lines().collect();
                    for line in &lines[lines.len().saturating_sub(5)..] {
                        writeln!(stdout, "      {line}")?;
                    }
                }
                Status::Done { .. } => {}
            }
        }
        let resubmit = format!("fluid-lab slurm resubmit {}", dir.path.display());
        if merged.done.is_empty() {
            return Err(format!(
                "no point has finished, so {} was not written; {resubmit} runs the failed ones \
                 again",
                tool.csv_path().display()
            )
            .into());
        }
        if !args.partial {
            return Err(format!(
                "{missing} of {} points missing, so {} was not written; {resubmit} runs the \
                 failed ones again, and merge --partial writes what there is",
                job.points.len(),
                tool.csv_path().display()
            )
            .into());
        }
        writeln!(
            stdout,
            "partial: {missing} of {} points left out; {resubmit} runs the failed ones again",
            job.points.len()
        )?;
    }
    let csv_path = tool.csv_path();
    // The subcommand's folder, made if it is not there (removed again if the merge fails).
    let folder = tool.create_folder()?;
    let rows = tool.complete(merged.csv, &dir, job.points.len())?;
    tool.check(&rows, &csv_path)?;
    OutputFile::create(&csv_path)?.commit(&rows)?;
    folder.into_iter().for_each(MadeFolder::keep);
    writeln!(
        stdout,
        "wrote {} ({} rows of {} points)",
        csv_path.display(),
        merged.done.values().map(|(rows, _)| rows).sum::<usize>(),
        merged.done.len()
    )?;
    tool.chart(&csv_path, stdout)
}

/// Writes tasks.csv: every point's status, where it ran, its rows and its energy.
fn write_tasks(
    dir: &JobDir,
    job: &Job,
    statuses: &[Status],
    energy: &SlurmEnergy,
) -> Result<(), Box<dyn Error>> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    writer.write_record(slurm::TASK_COLUMNS)?;
    let method = energy.describe();
    for (index, (point, status)) in job.points.iter().zip(statuses).enumerate() {
        let (name, job_id, node, rows) = match status {
            Status::Done { rows, place } => (
                "done",
                place.job_id.clone(),
                place.node.clone(),
                rows.to_string(),
            ),
            Status::Queued { job_id } => ("queued", job_id.clone(), String::new(), String::new()),
            Status::Failed { job_id } => ("failed", job_id.clone(), String::new(), String::new()),
            Status::NotRun => ("not-run", String::new(), String::new(), String::new()),
        };
        let joules = energy
            .joules(&job_id, index)
            .map_or(String::new(), |j| j.to_string());
        let stderr = match job_id.is_empty() {
            true => String::new(),
            false => dir.stderr(&job_id, index).display().to_string(),
        };
        writer.write_record([
            index.to_string(),
            point.clone(),
            name.to_string(),
            job_id,
            node,
            rows,
            joules,
            method.clone(),
            stderr,
        ])?;
    }
    dir.write("tasks.csv", &writer.into_inner()?)?;
    Ok(())
}

/// Resubmits the points without a shard that are not queued.
fn resubmit(args: ResubmitArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    let dir = JobDir::at(&args.job_dir)?;
    let job = dir.job()?;
    // The subcommand's paths are the submitter's (an accuracy sweep's case is read, as
    // its resubmitted tasks will read it).
    std::env::set_current_dir(&job.cwd)
        .map_err(|error| format!("cannot enter {}: {error}", job.cwd.display()))?;
    let tool = Tool::parse(&job.command)?;
    let job_ids: Vec<String> = dir.submissions()?.into_iter().map(|s| s.job_id).collect();
    let queued = slurm::queued(&args.programs.squeue, &job_ids)?;
    let is_queued = |index: usize| queued.iter().any(|(_, i)| *i == index);
    let overrides = args.placement.placement(false);
    // A stage runs after the earlier stages' tasks, those submitted now and those queued.
    let mut submitted: Vec<String> = Vec::new();
    let mut before: Vec<String> = Vec::new();
    for stage in tool.stages(job.points.len()) {
        let indices: Vec<usize> = stage
            .iter()
            .copied()
            .filter(|&i| !dir.shard(i).is_file() && !is_queued(i))
            .collect();
        if !indices.is_empty() {
            let job_id = submit_and_record(&dir, &args.programs, &indices, &overrides, &before)?;
            writeln!(
                stdout,
                "submitted job {job_id}: points {} again{}",
                slurm::array_spec(&indices),
                match before.is_empty() {
                    true => String::new(),
                    false => format!(", after job {} has succeeded", before.join(", ")),
                }
            )?;
            submitted.push(job_id.clone());
            before.push(job_id);
        }
        for (job_id, index) in &queued {
            if stage.contains(index) && !before.contains(job_id) {
                before.push(job_id.clone());
            }
        }
    }
    if submitted.is_empty() {
        writeln!(stdout, "nothing to resubmit: every point is done or queued")?;
        return Ok(());
    }
    finish(&dir, &args.programs, &submitted, args.wait, stdout)
}
