//! What a measurement ran on: host, CPU model, logical CPUs, kernel, and the git commit of
//! the code measured, so that every row of a results file says where it came from.

use std::path::Path;
use std::process::Command;

/// The machine and code a measurement ran on.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// The host name.
    pub host: String,
    /// The CPU model as `/proc/cpuinfo` names it.
    pub cpu_model: String,
    /// Logical CPUs available to this process.
    pub cpus: usize,
    /// The kernel release (`uname -r`).
    pub kernel: String,
    /// `git rev-parse --short=12 HEAD` of the current folder, `-dirty` when tracked files
    /// differ from it, or `unknown` outside a git work tree.
    pub commit: String,
}

impl Machine {
    /// Reads this machine's description (`unknown` for what cannot be read).
    pub fn this() -> Machine {
        let read = |path: &str| {
            std::fs::read_to_string(path)
                .map(|text| text.trim().to_string())
                .unwrap_or_else(|_| "unknown".to_string())
        };
        Machine {
            host: read("/proc/sys/kernel/hostname"),
            cpu_model: cpu_model(&read("/proc/cpuinfo")).unwrap_or_else(|| "unknown".into()),
            cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            kernel: read("/proc/sys/kernel/osrelease"),
            commit: commit(Path::new(".")).unwrap_or_else(|| "unknown".into()),
        }
    }
}

/// The first `model name` of a `/proc/cpuinfo` text.
fn cpu_model(cpuinfo: &str) -> Option<String> {
    cpuinfo.lines().find_map(|line| {
        let (key, value) = line.split_once(':')?;
        (key.trim() == "model name").then(|| value.trim().to_string())
    })
}

/// The commit checked out in `folder`, with `-dirty` when tracked files were changed.
fn commit(folder: &Path) -> Option<String> {
    let git = |args: &[&str]| {
        let output = Command::new("git")
            .arg("-C")
            .arg(folder)
            .args(args)
            .output()
            .ok()?;
        output
            .status
            .success()
            .then(|| String::from_utf8_lossy(&output.stdout).trim().to_string())
    };
    let head = git(&["rev-parse", "--short=12", "HEAD"])?;
    let changes = git(&["status", "--porcelain", "--untracked-files=no"])?;
    Some(if changes.is_empty() {
        head
    } else {
        format!("{head}-dirty")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cpu_model_is_the_first_model_name() {
        let cpuinfo = "processor\t: 0\nvendor_id\t: AuthenticAMD\n\
                       model name\t: AMD EPYC 9B45 128-Core Processor\nprocessor\t: 1\n\
                       model name\t: AMD EPYC 9B45 128-Core Processor\n";
        assert_eq!(
            cpu_model(cpuinfo).as_deref(),
            Some("AMD EPYC 9B45 128-Core Processor")
        );
        assert_eq!(cpu_model("processor\t: 0\nBogoMIPS\t: 50.00\n"), None);
    }

    #[test]
    fn the_commit_names_head_and_says_when_tracked_files_changed() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(commit(dir.path()), None);
        let git = |args: &[&str]| {
            let status = Command::new("git")
                .arg("-C")
                .arg(dir.path())
                .args(["-c", "user.name=t", "-c", "user.email=t@t"])
                .args(args)
                .output()
                .unwrap()
                .status;
            assert!(status.success(), "git {args:?}");
        };
        git(&["init", "-q"]);
        std::fs::write(dir.path().join("file"), "one").unwrap();
        git(&["add", "file"]);
        git(&["commit", "-q", "-m", "one"]);
        let clean = commit(dir.path()).unwrap();
        assert_eq!(clean.len(), 12, "{clean}");
        assert!(clean.chars().all(|c| c.is_ascii_hexdigit()), "{clean}");
        std::fs::write(dir.path().join("untracked"), "x").unwrap();
        assert_eq!(commit(dir.path()).unwrap(), clean);
        std::fs::write(dir.path().join("file"), "two").unwrap();
        assert_eq!(commit(dir.path()).unwrap(), format!("{clean}-dirty"));
    }
}
