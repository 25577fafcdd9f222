//! `fluid-lab slurm` on the real binaries: a job folder submitted, its tasks run, their
//! shards merged into the subcommand's own CSV and charts (equal to a run without Slurm),
//! missing and failed points named, failed points resubmitted, and the accuracy sweep's
//! reference run after its methods. The first two tests stand in for Slurm's programs
//! (`sbatch`, `squeue`, `sacct`) and run everywhere; the last two need a Slurm that
//! answers (scripts/slurm-local.sh start), and skip with a message where there is none,
//! unless FLUID_REQUIRE_SLURM=1 (as in CI) makes that a failure.

mod common;

use common::{exit_code, run_lab, run_lab_with, stderr, stdout};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Writes an executable shell script.
fn script(path: &Path, body: &str) {
    std::fs::write(path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// Slurm's programs, stood in for: `sbatch` appends its arguments to a file and answers
/// job 77, `squeue` holds nothing, `sacct` runs `sacct_body`.
struct FakeSlurm {
    bin: PathBuf,
    calls: PathBuf,
}

impl FakeSlurm {
    fn in_folder(folder: &Path, sacct_body: &str) -> FakeSlurm {
        let bin = folder.join("bin");
        std::fs::create_dir(&bin).unwrap();
        let calls = folder.join("sbatch.args");
        script(
            &bin.join("sbatch"),
            &format!("echo \"$@\" >> {}\necho 77", calls.display()),
        );
        script(&bin.join("squeue"), "exit 0");
        script(&bin.join("sacct"), sacct_body);
        FakeSlurm { bin, calls }
    }

    /// `--NAME PATH` for each of `programs`.
    fn options(&self, programs: &[&str]) -> Vec<std::ffi::OsString> {
        programs
            .iter()
            .flat_map(|name| [format!("--{name}").into(), self.bin.join(name).into()])
            .collect()
    }

    /// Each call of sbatch, its arguments on one line.
    fn sbatch_calls(&self) -> Vec<String> {
        read(&self.calls).lines().map(String::from).collect()
    }

    /// `fluid-lab slurm merge DIR` with these sacct and squeue.
    fn merge(&self, job_dir: &Path, more: &[&str]) -> std::process::Output {
        let mut args: Vec<std::ffi::OsString> =
            vec!["slurm".into(), "merge".into(), job_dir.into()];
        args.extend(more.iter().map(Into::into));
        args.extend(self.options(&["sacct", "squeue"]));
        run_lab(&args)
    }
}

/// Runs `fluid-lab slurm task DIR INDEX` as array task INDEX of job 77 on `node`.
fn task_of_job_77(job_dir: &Path, index: &str, node: &str) -> std::process::Output {
    let vars = [
        ("SLURM_ARRAY_JOB_ID", "77"),
        ("SLURM_ARRAY_TASK_ID", index),
        ("SLURMD_NODENAME", node),
    ];
    let args = [
        "slurm".as_ref(),
        "task".as_ref(),
        job_dir.as_os_str(),
        index.as_ref(),
    ];
    run_lab_with(&args, &vars)
}

/// The rows of a CSV (header first) with the Slurm columns dropped.
fn without_slurm_columns(text: &str) -> Vec<Vec<String>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(text.as_bytes());
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    let keep: Vec<usize> = (0..rows[0].len())
        .filter(|&k| !rows[0][k].starts_with("slurm_"))
        .collect();
    rows.iter()
        .map(|row| keep.iter().map(|&k| row[k].to_string()).collect())
        .collect()
}

/// A column of a CSV's rows, by name.
fn column(text: &str, name: &str) -> Vec<String> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let k = reader
        .headers()
        .unwrap()
        .iter()
        .position(|h| h == name)
        .unwrap();
    reader
        .records()
        .map(|r| r.unwrap()[k].to_string())
        .collect()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

const STABILITY: [&str; 11] = [
    "stability",
    "--models",
    "course",
    "--ppms",
    "100",
    "--dt-factors",
    "1,4",
    "--adaptive",
    "",
    "--duration",
    "0.02",
];

#[test]
fn an_array_merges_into_the_subcommands_own_csv_and_names_what_is_missing() {
    let temp = tempfile::tempdir().unwrap();
    // Slurm's energy accounting as sacct prints it where acct_gather_energy is set.
    let slurm = FakeSlurm::in_folder(
        temp.path(),
        "printf '77_0|120\\n77_0.batch|119\\n77_1|0\\n'",
    );
    let job_dir = temp.path().join("job");
    let out = temp.path().join("map");
    let mut submit: Vec<std::ffi::OsString> =
        ["slurm", "submit", "--job-dir"].map(Into::into).to_vec();
    submit.push(job_dir.clone().into());
    for arg in ["--partition", "debug", "--time", "10", "--account", "acct"] {
        submit.push(arg.into());
    }
    submit.extend(slurm.options(&["sbatch", "squeue"]));
    submit.push("--".into());
    submit.extend(STABILITY.map(Into::into));
    submit.push("--output-dir".into());
    submit.push(out.clone().into());
    let output = run_lab(&submit);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert!(
        stdout(&output).starts_with(
            "submitted job 77: stability points 0-1 of 2 as array tasks (nodes shared)"
        ),
        "{}",
        stdout(&output)
    );
    assert!(slurm.sbatch_calls()[0].starts_with("--parsable --array=0-1 "));
    let job_script = read(&job_dir.join("job.sh"));
    for line in [
        "#SBATCH --partition=debug",
        "#SBATCH --time=10",
        "#SBATCH --account=acct",
    ] {
        assert!(
            job_script.lines().any(|l| l == line),
            "{line}\n{job_script}"
        );
    }
    assert!(!job_script.contains("--exclusive"), "{job_script}");
    assert_eq!(
        read(&job_dir.join("points.txt")),
        "course simd8 leapfrog, ppm 100, 0.001\ncourse simd8 leapfrog, ppm 100, 0.004\n"
            .replace("simd8", fluid::Kernel::NATIVE.name())
    );
    // The same folder takes no second job.
    let again = run_lab(&submit);
    assert_eq!(exit_code(&again), 1);
    assert!(
        stderr(&again).contains("already holds a job"),
        "{}",
        stderr(&again)
    );

    let merge = |partial: bool| match partial {
        true => slurm.merge(&job_dir, &["--partial"]),
        false => slurm.merge(&job_dir, &[]),
    };
    let none = merge(false);
    assert_eq!(exit_code(&none), 1);
    assert!(
        stdout(&none).contains("2 of 2 points missing:\n  0 (course"),
        "{}",
        stdout(&none)
    );
    assert!(
        stdout(&none).contains("never started (no log"),
        "{}",
        stdout(&none)
    );
    assert!(
        stderr(&none).contains("was not written"),
        "{}",
        stderr(&none)
    );
    assert!(!out.join("stability.csv").exists());
    // Nor with --partial: there is nothing to write.
    let nothing = merge(true);
    assert_eq!(exit_code(&nothing), 1);
    assert!(
        stderr(&nothing).contains("no point has finished, so")
            && stderr(&nothing).contains("stability.csv was not written"),
        "{}",
        stderr(&nothing)
    );
    assert!(!out.join("stability.csv").exists());

    let task = |index: &str, vars: &[(&str, &str)]| {
        run_lab_with(
            &[
                "slurm".as_ref(),
                "task".as_ref(),
                job_dir.as_os_str(),
                index.as_ref(),
            ],
            vars,
        )
    };
    let outside = task("1", &[]);
    assert_eq!(exit_code(&outside), 1);
    assert!(
        stderr(&outside).contains("not in a Slurm array task"),
        "{}",
        stderr(&outside)
    );
    let as_task_1 = [
        ("SLURM_ARRAY_JOB_ID", "77"),
        ("SLURM_ARRAY_TASK_ID", "1"),
        ("SLURMD_NODENAME", "node-b"),
    ];
    let wrong = task("0", &as_task_1);
    assert!(
        stderr(&wrong).contains("index 0 is not this array task's (1)"),
        "{}",
        stderr(&wrong)
    );
    let second = task_of_job_77(&job_dir, "1", "node-b");
    assert_eq!(exit_code(&second), 0, "{}", stderr(&second));
    assert!(stderr(&second).starts_with("fluid-lab slurm: job 77 task 1 on node-b: course"));
    // Point 0 failed: its log is there, its shard is not.
    std::fs::write(
        job_dir.join("logs/77_0.err"),
        "Error: the node caught fire\n",
    )
    .unwrap();
    let one = merge(false);
    assert_eq!(exit_code(&one), 1);
    assert!(
        stdout(&one).contains("1 of 2 points missing:\n  0 (course"),
        "{}",
        stdout(&one)
    );
    assert!(
        stdout(&one).contains("failed in job 77"),
        "{}",
        stdout(&one)
    );
    assert!(
        stdout(&one).contains("      Error: the node caught fire"),
        "{}",
        stdout(&one)
    );
    let tasks = read(&job_dir.join("tasks.csv"));
    assert_eq!(column(&tasks, "status"), ["failed", "done"]);
    let partial = merge(true);
    assert_eq!(exit_code(&partial), 0, "{}", stderr(&partial));
    assert_eq!(read(&out.join("stability.csv")).lines().count(), 2);

    let first = task_of_job_77(&job_dir, "0", "node-a");
    assert_eq!(exit_code(&first), 0, "{}", stderr(&first));
    let all = merge(false);
    assert_eq!(exit_code(&all), 0, "{}", stderr(&all));
    assert!(
        stdout(&all).contains("(2 rows of 2 points)"),
        "{}",
        stdout(&all)
    );
    let merged = read(&out.join("stability.csv"));
    assert_eq!(column(&merged, "slurm_job_id"), ["77", "77"]);
    assert_eq!(column(&merged, "slurm_array_index"), ["0", "1"]);
    assert_eq!(column(&merged, "slurm_node"), ["node-a", "node-b"]);
    let tasks = read(&job_dir.join("tasks.csv"));
    assert_eq!(column(&tasks, "status"), ["done", "done"]);
    assert_eq!(column(&tasks, "energy_j"), ["120", ""]);
    assert!(column(&tasks, "energy_method")[0].starts_with("slurm-sacct: ConsumedEnergyRaw"));

    // The same map without Slurm: the same rows, and the same picture.
    let local = temp.path().join("local");
    let mut args: Vec<std::ffi::OsString> = STABILITY.map(Into::into).to_vec();
    args.push("--output-dir".into());
    args.push(local.clone().into());
    let output = run_lab(&args);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    assert_eq!(
        without_slurm_columns(&merged),
        without_slurm_columns(&read(&local.join("stability.csv")))
    );
    assert_eq!(
        std::fs::read(out.join("stability-map.png")).unwrap(),
        std::fs::read(local.join("stability-map.png")).unwrap()
    );

    let unsupported = run_lab(&["slurm", "submit", "--job-dir", "x", "--", "run", "in.fld"]);
    assert_eq!(exit_code(&unsupported), 2);
    assert!(
        stderr(&unsupported).contains("runs sweep, stability and accuracy, not run"),
        "{}",
        stderr(&unsupported)
    );
    // The subcommand's own usage errors: exit 2, one line, no folder made.
    let job = temp.path().join("refused");
    let job = job.to_str().unwrap();
    for (command, message) in [
        (
            ["stability", "--bogus"].as_slice(),
            "fluid-lab: error: the subcommand after --: unexpected argument '--bogus' found\n",
        ),
        (
            ["accuracy"].as_slice(),
            "fluid-lab: error: the subcommand after --: the following required arguments \
             were not provided: --output-dir <OUTPUT_DIR> <INPUT>\n",
        ),
    ] {
        let mut args = vec!["slurm", "submit", "--job-dir", job, "--"];
        args.extend(command);
        let refused = run_lab(&args);
        assert_eq!(exit_code(&refused), 2, "{}", stderr(&refused));
        assert_eq!(stderr(&refused), message);
        assert!(!Path::new(job).exists());
    }
}

#[test]
fn an_accuracy_array_runs_its_reference_after_the_methods_and_merges_as_the_sweep_does() {
    let temp = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(
        temp.path(),
        "echo 'Slurm accounting storage is disabled' >&2; exit 1",
    );
    let job_dir = temp.path().join("job");
    let out = temp.path().join("accuracy");
    let small = common::input("small");
    let kernels = format!("{},mixed", fluid::Kernel::NATIVE.name());
    let accuracy = |output_dir: &Path| -> Vec<std::ffi::OsString> {
        let mut args: Vec<std::ffi::OsString> = vec!["accuracy".into(), small.clone().into()];
        for arg in [
            "--kernels",
            &kernels,
            "--dt-factors",
            "1,2",
            "--adaptive",
            "",
            "--integrators",
            "leapfrog,verlet",
            "--times",
            "0.002,0.004",
            "--budget",
            "0.5h",
            "--output-dir",
        ] {
            args.push(arg.into());
        }
        args.push(output_dir.into());
        args
    };
    let mut submit: Vec<std::ffi::OsString> = vec![
        "slurm".into(),
        "submit".into(),
        "--job-dir".into(),
        job_dir.clone().into(),
    ];
    submit.extend(slurm.options(&["sbatch", "squeue"]));
    submit.push("--".into());
    submit.extend(accuracy(&out));
    let output = run_lab(&submit);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let said = stdout(&output);
    assert!(
        said.contains(
            "submitted job 77: accuracy points 0-7 of 9 as array tasks (a node each); folder"
        ),
        "{said}"
    );
    assert!(said.contains("submitted job 77: accuracy points 8 of 9 as array tasks (a node each), after job 77 has succeeded"), "{said}");
    let calls = slurm.sbatch_calls();
    assert!(calls[0].starts_with("--parsable --array=0-7 "), "{calls:?}");
    assert!(
        calls[1]
            .starts_with("--parsable --array=8 --dependency=afterok:77 --kill-on-invalid-dep=yes "),
        "{calls:?}"
    );
    assert!(read(&job_dir.join("points.txt"))
        .lines()
        .last()
        .unwrap()
        .starts_with("the reference"));

    let task = |index: &str| task_of_job_77(&job_dir, index, "node-a");
    for index in ["0", "1", "2", "3", "4", "5", "6"] {
        let output = task(index);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    }
    let early = task("8");
    assert_eq!(exit_code(&early), 1);
    assert!(
        stderr(&early)
            .contains("the reference needs every method's times, and points 7 have no shard"),
        "{}",
        stderr(&early)
    );
    for index in ["7", "8"] {
        let output = task(index);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    }
    // The merge makes the subcommand's folder where it is gone, as the subcommand would.
    std::fs::remove_dir(&out).unwrap();
    let merged = slurm.merge(&job_dir, &[]);
    assert_eq!(exit_code(&merged), 0, "{}", stderr(&merged));
    let report = stdout(&merged);
    assert!(
        report.contains(
            "(energy: slurm-sacct not available: sacct: Slurm accounting storage is disabled)"
        ),
        "{report}"
    );
    assert!(
        report.contains("budget 0.5h = 4.154e-3 m (median error): "),
        "{report}"
    );
    for name in [
        "accuracy-speed.png",
        "accuracy-speed.svg",
        "error-time.png",
        "error-time.svg",
    ] {
        assert!(
            report.contains(&format!("{}\n", out.join(name).display())),
            "{report}"
        );
    }

    // The same sweep without Slurm: the same rows, errors to the last bit, but for the
    // CPU times each measured.
    let local = temp.path().join("local");
    let output = run_lab(&accuracy(&local));
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let ours = read(&out.join("accuracy.csv"));
    assert_eq!(
        column(&ours, "slurm_array_index")[0],
        "8",
        "the reference first"
    );
    let theirs = read(&local.join("accuracy.csv"));
    let measured = |rows: Vec<Vec<String>>| -> Vec<Vec<String>> {
        let header = rows[0].clone();
        rows.into_iter()
            .map(|row| {
                row.into_iter()
                    .zip(&header)
                    .filter(|(_, name)| !name.starts_with("cpu_s"))
                    .map(|(cell, _)| cell)
                    .collect()
            })
            .collect()
    };
    let ours = measured(without_slurm_columns(&ours));
    let theirs = measured(without_slurm_columns(&theirs));
    assert_eq!(ours.len(), 1 + 9 * 2);
    assert_eq!(ours, theirs);
}

/// Whether a Slurm answers here (`sinfo` sees a node that takes jobs); where none does,
/// the reason, and a failure if FLUID_REQUIRE_SLURM=1.
fn slurm_answers() -> bool {
    let answer = Command::new("sinfo")
        .args(["--noheader", "--format=%T"])
        .output();
    let up = answer.as_ref().is_ok_and(|output| {
        let states = String::from_utf8_lossy(&output.stdout);
        output.status.success()
            && states
                .lines()
                .any(|s| ["idle", "mixed", "allocated"].contains(&s.trim()))
    });
    if !up {
        let why = match &answer {
            Err(error) => format!("no sinfo ({error})"),
            Ok(output) => {
                let said = String::from_utf8_lossy(&output.stderr);
                said.lines().last().unwrap_or("").trim().to_string()
            }
        };
        assert!(
            std::env::var("FLUID_REQUIRE_SLURM").as_deref() != Ok("1"),
            "FLUID_REQUIRE_SLURM=1 but no Slurm answers: {why}"
        );
        // Written to the stream itself, which the test harness does not capture, so that
        // the skip shows in every run.
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "SKIPPED: no Slurm answers here ({why}); start one with scripts/slurm-local.sh \
             start and export the SLURM_CONF it prints"
        );
    }
    up
}

/// Runs `fluid-lab slurm resubmit --wait DIR`, which must succeed: what it says.
fn resubmit_and_wait(job_dir: &Path) -> String {
    let args = [
        "slurm".as_ref(),
        "resubmit".as_ref(),
        "--wait".as_ref(),
        job_dir.as_os_str(),
    ];
    let output = run_lab(&args);
    assert_eq!(
        exit_code(&output),
        0,
        "{}\n{}",
        stdout(&output),
        stderr(&output)
    );
    stdout(&output)
}

#[test]
fn a_real_slurm_runs_the_sweep_array_and_a_failed_point_is_resubmitted() {
    if !slurm_answers() {
        return;
    }
    let temp = tempfile::tempdir().unwrap();
    let fixed = temp.path().join("fixed");
    let flaky = temp.path().join("flaky-fluid");
    script(
        &flaky,
        &format!(
            "if [ \"$1\" = 3 ] && [ ! -e {} ]; then echo \"flaky: no luck with $1\" >&2; exit 3; fi\nexec {} \"$@\"",
            fixed.display(),
            env!("CARGO_BIN_EXE_fluid")
        ),
    );
    let job_dir = temp.path().join("job");
    let csv_path = temp.path().join("sweep.csv");
    let input = common::input("small");
    let submit = run_lab(&[
        "slurm".as_ref(),
        "submit".as_ref(),
        "--wait".as_ref(),
        "--time".as_ref(),
        "5".as_ref(),
        "--job-dir".as_ref(),
        job_dir.as_os_str(),
        "--".as_ref(),
        "sweep".as_ref(),
        "--program".as_ref(),
        flaky.as_os_str(),
        "--iterations".as_ref(),
        "0,3".as_ref(),
        "--repeats".as_ref(),
        "2".as_ref(),
        "--idle-seconds".as_ref(),
        "0.05".as_ref(),
        "--output".as_ref(),
        csv_path.as_os_str(),
        input.as_os_str(),
    ]);
    assert_eq!(
        exit_code(&submit),
        1,
        "{}\n{}",
        stdout(&submit),
        stderr(&submit)
    );
    assert!(
        stdout(&submit).contains("(a node each)"),
        "{}",
        stdout(&submit)
    );
    assert!(
        stderr(&submit).contains("1 of 3 points have no shard"),
        "{}",
        stderr(&submit)
    );
    let merge = || run_lab(&["slurm".as_ref(), "merge".as_ref(), job_dir.as_os_str()]);
    let failed = merge();
    assert_eq!(exit_code(&failed), 1);
    let listing = stdout(&failed);
    assert!(
        listing.contains(
            "1 of 3 points missing:\n  2 (small.fld, 3 iterations, 2 repeats): failed in job"
        ),
        "{listing}"
    );
    assert!(listing.contains("flaky: no luck with 3"), "{listing}");
    assert!(listing.contains("slurm-sacct"), "{listing}");

    std::fs::write(&fixed, "").unwrap();
    let said = resubmit_and_wait(&job_dir);
    assert!(said.contains(": points 2 again"), "{said}");
    let merged = merge();
    assert_eq!(exit_code(&merged), 0, "{}", stderr(&merged));
    let text = read(&csv_path);
    assert_eq!(
        column(&text, "kind"),
        ["idle", "idle", "run", "run", "run", "run"]
    );
    assert_eq!(column(&text, "iterations"), ["", "", "0", "0", "3", "3"]);
    let jobs = column(&text, "slurm_job_id");
    assert_eq!(jobs[0], jobs[3]);
    assert_ne!(
        jobs[3], jobs[4],
        "the resubmitted point ran in a job of its own"
    );
    assert_eq!(
        column(&text, "slurm_array_index"),
        ["0", "0", "1", "1", "2", "2"]
    );
    let host =
        String::from_utf8(Command::new("hostname").arg("-s").output().unwrap().stdout).unwrap();
    assert!(
        column(&text, "slurm_node")
            .iter()
            .all(|node| node == host.trim()),
        "{text}"
    );
    for name in ["time", "energy", "power"] {
        let png: PathBuf = temp.path().join(format!("{name}.png"));
        let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
        assert!(decoder.read_info().is_ok(), "{}", png.display());
    }
    let tasks = read(&job_dir.join("tasks.csv"));
    assert_eq!(column(&tasks, "status"), ["done", "done", "done"]);
}

#[test]
fn a_real_slurm_cancels_the_reference_when_a_method_fails_and_resubmits_both() {
    if !slurm_answers() {
        return;
    }
    let temp = tempfile::tempdir().unwrap();
    let job_dir = temp.path().join("job");
    let out = temp.path().join("accuracy");
    let small = common::input("small");
    let submit = run_lab(&[
        "slurm".as_ref(),
        "submit".as_ref(),
        "--time".as_ref(),
        "5".as_ref(),
        "--job-dir".as_ref(),
        job_dir.as_os_str(),
        "--".as_ref(),
        "accuracy".as_ref(),
        small.as_os_str(),
        "--kernels".as_ref(),
        fluid::Kernel::NATIVE.name().as_ref(),
        "--dt-factors".as_ref(),
        "1,2".as_ref(),
        "--adaptive".as_ref(),
        "".as_ref(),
        "--integrators".as_ref(),
        "leapfrog".as_ref(),
        "--times".as_ref(),
        "0.002".as_ref(),
        "--output-dir".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(exit_code(&submit), 0, "{}", stderr(&submit));
    // The methods are points 0 and 1, the reference 2; point 1 is cancelled at once.
    let methods = read(&job_dir.join("submissions.csv"));
    let job = methods
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    let cancel = Command::new("scancel")
        .arg(format!("{job}_1"))
        .output()
        .unwrap();
    assert!(
        cancel.status.success(),
        "{}",
        String::from_utf8_lossy(&cancel.stderr)
    );
    // Slurm cancels the reference, whose dependency can no longer be met.
    let waited = std::time::Instant::now();
    loop {
        let queue = Command::new("squeue")
            .args(["--noheader", "--jobs", &job])
            .output()
            .unwrap();
        let later = read(&job_dir.join("submissions.csv"));
        let reference = later
            .lines()
            .nth(2)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .to_string();
        let pending = Command::new("squeue")
            .args(["--noheader", "--jobs", &reference])
            .output()
            .unwrap();
        if queue.stdout.is_empty() && pending.stdout.is_empty() {
            break;
        }
        assert!(waited.elapsed().as_secs() < 120, "the jobs did not end");
        std::thread::sleep(std::time::Duration::from_secs(1));
    }
    let merge = || run_lab(&["slurm".as_ref(), "merge".as_ref(), job_dir.as_os_str()]);
    let missing = merge();
    assert_eq!(exit_code(&missing), 1);
    let listing = stdout(&missing);
    assert!(
        listing.contains("2 of 3 points missing:\n  2 (the reference"),
        "{listing}"
    );
    assert!(listing.contains("\n  1 ("), "{listing}");
    let said = resubmit_and_wait(&job_dir);
    assert!(said.contains(": points 1 again\n"), "{said}");
    assert!(said.contains(": points 2 again, after job "), "{said}");
    let merged = merge();
    assert_eq!(exit_code(&merged), 0, "{}", stderr(&merged));
    let text = read(&out.join("accuracy.csv"));
    assert_eq!(column(&text, "slurm_array_index"), ["2", "0", "1"]);
    assert!(
        column(&text, "median_error_m")[1..]
            .iter()
            .all(|e| e.parse::<f64>().unwrap() > 0.0),
        "{text}"
    );
    assert!(out.join("accuracy-speed.png").is_file());
}

#[test]
fn an_sbatch_that_prints_no_job_id_is_said_so() {
    // Exit status 0 and nothing printed: not "sbatch failed (exit status: 0)".
    let dir = tempfile::tempdir().unwrap();
    let sbatch = dir.path().join("sbatch");
    script(&sbatch, "exit 0");
    let job = dir.path().join("job");
    let folder = dir.path().join("st");
    let output = run_lab(&[
        "slurm".as_ref(),
        "submit".as_ref(),
        "--job-dir".as_ref(),
        job.as_os_str(),
        "--sbatch".as_ref(),
        sbatch.as_os_str(),
        "--".as_ref(),
        "stability".as_ref(),
        "--ppms".as_ref(),
        "100".as_ref(),
        "--models".as_ref(),
        "fluidanimate".as_ref(),
        "--output-dir".as_ref(),
        folder.as_os_str(),
    ]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: sbatch succeeded but printed no job id; the job folder is kept, \
             and fluid-lab slurm resubmit {} submits its points once sbatch works\n",
            job.display()
        )
    );
    // The job folder is kept to resubmit; the stability's own folder, made by the merge,
    // is not left empty.
    assert!(job.join("points.txt").exists());
    assert!(!folder.exists());
}

#[test]
fn an_accuracy_array_of_an_input_that_cannot_be_read_is_not_submitted() {
    let dir = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(dir.path(), "exit 0");
    let (job, folder) = (dir.path().join("job"), dir.path().join("acc"));
    let missing = dir.path().join("missing.fld");
    let mut args: Vec<std::ffi::OsString> = vec![
        "slurm".into(),
        "submit".into(),
        "--job-dir".into(),
        job.clone().into(),
    ];
    args.extend(slurm.options(&["sbatch"]));
    args.extend([
        "--".into(),
        "accuracy".into(),
        missing.clone().into(),
        "--output-dir".into(),
        folder.clone().into(),
    ]);
    let output = run_lab(&args);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: Cannot open {} for reading\n",
            missing.display()
        )
    );
    assert!(!job.exists() && !folder.exists() && !slurm.calls.exists());
}

#[test]
fn a_job_folder_that_lists_no_points_merges_nothing() {
    let temp = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(temp.path(), "exit 0");
    let (job_dir, out) = (temp.path().join("job"), temp.path().join("map"));
    let output = submit_stability(&slurm, &job_dir, &out);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    // Edited by hand: no points left.
    std::fs::write(job_dir.join("points.txt"), "").unwrap();
    let output = slurm.merge(&job_dir, &[]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        format!(
            "fluid-lab: error: {}: the job lists no points\n",
            job_dir.display()
        )
    );
    assert!(!out.join("stability.csv").exists());
}

#[test]
fn a_merge_of_shards_no_run_writes_is_refused_before_the_csv_is_written() {
    let temp = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(temp.path(), "exit 0");
    let (job_dir, out) = (temp.path().join("job"), temp.path().join("map"));
    assert_eq!(exit_code(&submit_stability(&slurm, &job_dir, &out)), 0);
    for index in ["0", "1"] {
        let task = task_of_job_77(&job_dir, index, "node-a");
        assert_eq!(exit_code(&task), 0, "{}", stderr(&task));
    }
    // A shard edited by hand: a resolution that is no number.
    let shard = std::fs::read_dir(job_dir.join("shards"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .find(|path| path.extension().is_some_and(|e| e == "csv"))
        .expect("a shard");
    let text = std::fs::read_to_string(&shard).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let ppm = lines[0].split(',').position(|name| name == "ppm").unwrap();
    let mut cells: Vec<String> = lines[1].split(',').map(String::from).collect();
    cells[ppm] = "abc".into();
    lines[1] = cells.join(",");
    std::fs::write(&shard, lines.join("\n") + "\n").unwrap();
    let output = slurm.merge(&job_dir, &[]);
    assert_eq!(exit_code(&output), 1, "{}", stderr(&output));
    assert!(
        stderr(&output).contains("\"abc\" is not a number"),
        "{}",
        stderr(&output)
    );
    assert!(
        !out.join("stability.csv").exists(),
        "no CSV of what no run writes"
    );
}

/// `fluid-lab slurm submit` of the [`STABILITY`] sweep to `job_dir`, its CSV in `out`, on
/// `slurm`'s sbatch and squeue.
fn submit_stability(slurm: &FakeSlurm, job_dir: &Path, out: &Path) -> std::process::Output {
    let mut submit: Vec<std::ffi::OsString> =
        ["slurm", "submit", "--job-dir"].map(Into::into).to_vec();
    submit.push(job_dir.into());
    submit.extend(slurm.options(&["sbatch", "squeue"]));
    submit.push("--".into());
    submit.extend(STABILITY.map(Into::into));
    submit.push("--output-dir".into());
    submit.push(out.into());
    run_lab(&submit)
}

#[test]
fn an_accuracy_array_of_a_case_merges_and_refuses_a_case_edited_while_it_runs() {
    let temp = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(temp.path(), "exit 1");
    let case = temp.path().join("dam.toml");
    let original = read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dam-break-2d.toml"));
    std::fs::write(&case, &original).unwrap();
    let submit_to = |job_dir: &Path, out: &Path| {
        let mut args: Vec<std::ffi::OsString> = vec![
            "slurm".into(),
            "submit".into(),
            "--job-dir".into(),
            job_dir.into(),
        ];
        args.extend(slurm.options(&["sbatch", "squeue"]));
        args.push("--".into());
        for arg in ["accuracy", "--case"] {
            args.push(arg.into());
        }
        args.push(case.clone().into());
        for arg in [
            "--kernels",
            "simd",
            "--integrators",
            "verlet",
            "--adaptive",
            "",
            "--dt-factors",
            "0.1",
            "--times",
            "0.001",
            "--output-dir",
        ] {
            args.push(arg.into());
        }
        args.push(out.into());
        let output = run_lab(&args);
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
        let points = read(&job_dir.join("points.txt")).lines().count();
        (0..points).map(|k| k.to_string()).collect::<Vec<_>>()
    };
    // The case's 2-D column, 128 particles, in every shard: the merge measures them.
    let (job, out) = (temp.path().join("job"), temp.path().join("acc"));
    let points = submit_to(&job, &out);
    for index in &points {
        let output = task_of_job_77(&job, index, "node-a");
        assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    }
    let merged = slurm.merge(&job, &[]);
    assert_eq!(exit_code(&merged), 0, "{}", stderr(&merged));
    let rows = read(&out.join("accuracy.csv"));
    assert!(
        column(&rows, "particles").iter().all(|n| n == "128"),
        "{rows}"
    );
    let errors = column(&rows, "median_error_m");
    assert!(errors
        .iter()
        .any(|e| e.parse::<f64>().is_ok_and(|e| e > 0.0)));
    // A job folder whose command was edited after submit gives other points: refused
    // (the sixth hostile pass merged a 2-D and a 3-D row into one map, exit 0).
    let command = job.join("command");
    let edited = String::from_utf8(std::fs::read(&command).unwrap()).unwrap();
    std::fs::write(&command, edited.replace("verlet", "leapfrog")).unwrap();
    let merged = slurm.merge(&job, &[]);
    assert_eq!(exit_code(&merged), 1, "{}", stderr(&merged));
    assert!(
        stderr(&merged).contains("its command no longer gives the points in points.txt"),
        "{}",
        stderr(&merged)
    );
    // What a local run refuses is not submitted: the 2-D case on another model.
    let mut refused: Vec<std::ffi::OsString> = vec![
        "slurm".into(),
        "submit".into(),
        "--job-dir".into(),
        temp.path().join("job3").into(),
    ];
    refused.extend(slurm.options(&["sbatch", "squeue"]));
    for arg in [
        "--",
        "accuracy",
        "--model",
        "fluidanimate",
        "--output-dir",
        "acc3",
        "--case",
    ] {
        refused.push(arg.into());
    }
    refused.push(case.clone().into());
    let output = run_lab(&refused);
    assert_eq!(exit_code(&output), 2, "{}", stderr(&output));
    assert!(
        stderr(&output).contains("a 2-D case runs the water model (wcsph), not fluidanimate"),
        "{}",
        stderr(&output)
    );
    assert!(!temp.path().join("job3").exists());
    // The case edited between the tasks, its particles the same (the sixth hostile pass
    // merged such a job, exit 0): the later tasks and the merge refuse, nothing written.
    let (job, out) = (temp.path().join("job2"), temp.path().join("acc2"));
    let points = submit_to(&job, &out);
    let first = task_of_job_77(&job, &points[0], "node-a");
    assert_eq!(exit_code(&first), 0, "{}", stderr(&first));
    let stiffer = original.replace(
        "name = \"wcsph\"",
        "name = \"wcsph\"\nsound_speed_factor = 3.0",
    );
    std::fs::write(&case, stiffer).unwrap();
    let changed = "the scene changed since the job was submitted";
    let later = task_of_job_77(&job, &points[1], "node-a");
    assert_eq!(exit_code(&later), 1, "{}", stderr(&later));
    assert!(stderr(&later).contains(changed), "{}", stderr(&later));
    assert!(!job.join("shards").join("1.csv").exists());
    let merged = slurm.merge(&job, &[]);
    assert_eq!(exit_code(&merged), 1, "{}", stderr(&merged));
    assert!(stderr(&merged).contains(changed), "{}", stderr(&merged));
    assert!(!out.join("accuracy.csv").exists());
}

#[test]
fn a_sweep_array_refuses_an_input_changed_between_its_tasks_and_submits_no_resume() {
    // The seventh hostile pass: a sweep's input replaced between tasks was merged (rows of
    // 4800 and 15138 particles under one name, exit 0); --resume and --from-csv were
    // submitted as arrays that ran everything.
    let temp = tempfile::tempdir().unwrap();
    let slurm = FakeSlurm::in_folder(temp.path(), "exit 1");
    let input = temp.path().join("small.fld");
    std::fs::copy(common::input("small"), &input).unwrap();
    let csv = temp.path().join("sweep.csv");
    let submit = |job: &Path, extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec![
            "slurm".into(),
            "submit".into(),
            "--job-dir".into(),
            job.into(),
        ];
        args.extend(slurm.options(&["sbatch", "squeue"]));
        args.push("--".into());
        args.extend(extra.iter().map(Into::into));
        run_lab(&args)
    };
    let sweep = [
        "sweep",
        "--iterations",
        "0",
        "--repeats",
        "1",
        "--idle-seconds",
        "0",
        "--output",
        csv.to_str().unwrap(),
        input.to_str().unwrap(),
    ];
    let job = temp.path().join("job");
    let output = submit(&job, &sweep);
    assert_eq!(exit_code(&output), 0, "{}", stderr(&output));
    let first = task_of_job_77(&job, "0", "node-a");
    assert_eq!(exit_code(&first), 0, "{}", stderr(&first));
    std::fs::copy(common::input("large"), &input).unwrap();
    let changed = "the scene changed since the job was submitted";
    let later = task_of_job_77(&job, "1", "node-a");
    assert_eq!(exit_code(&later), 1, "{}", stderr(&later));
    assert!(stderr(&later).contains(changed), "{}", stderr(&later));
    let merged = slurm.merge(&job, &[]);
    assert_eq!(exit_code(&merged), 1, "{}", stderr(&merged));
    assert!(stderr(&merged).contains(changed), "{}", stderr(&merged));
    assert!(!csv.exists());
    // What runs nothing, or goes on from its own CSV, is no job array.
    let resumed = [&sweep[..], &["--resume"]].concat();
    let accuracy = [
        "accuracy",
        input.to_str().unwrap(),
        "--output-dir",
        "acc",
        "--from-csv",
        "acc/accuracy.csv",
    ];
    for (args, said) in [
        (
            &resumed[..],
            "--resume: a sweep run as a job array goes on with fluid-lab slurm resubmit",
        ),
        (
            &accuracy[..],
            "--from-csv runs nothing to submit: run fluid-lab accuracy --from-csv itself",
        ),
    ] {
        let job = temp.path().join("refused");
        let output = submit(&job, args);
        assert_eq!(exit_code(&output), 2, "{}", stderr(&output));
        assert!(stderr(&output).contains(said), "{}", stderr(&output));
        assert!(!job.exists());
    }
}
