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

/// The memory this process may use, in bytes, and what sets it: its address-space limit
/// (`ulimit -v`) or the memory and swap the machine has available (`/proc/meminfo`),
/// whichever is less; `None` where neither can be read.
pub fn usable_memory() -> Option<(u64, &'static str)> {
    let limit = address_space_limit().map(|bytes| (bytes, "this process's ulimit -v"));
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| available_memory(&text))
        .map(|bytes| (bytes, "the memory and swap this machine has available"));
    [limit, available]
        .into_iter()
        .flatten()
        .min_by_key(|(bytes, _)| *bytes)
}

/// This process's address-space limit (`ulimit -v`) in bytes, if it has one.
fn address_space_limit() -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the limit into `limit`, a plain struct it is given.
    let read = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
    (read && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur)
}

/// `MemAvailable` plus `SwapFree` of a `/proc/meminfo` text, in bytes.
fn available_memory(meminfo: &str) -> Option<u64> {
    let kib = |key: &str| {
        meminfo
            .lines()
            .find_map(|line| line.strip_prefix(key))
            .and_then(|rest| rest.trim().strip_suffix("kB"))
            .and_then(|number| number.trim().parse::<u64>().ok())
    };
    Some((kib("MemAvailable:")? + kib("SwapFree:").unwrap_or(0)) * 1024)
}

/// A number of bytes for people: "512 MB", "2.1 GB" (powers of 1000).
pub fn shown_bytes(bytes: f64) -> String {
    match bytes {
        b if b < 1e6 => format!("{:.0} kB", b / 1e3),
        b if b < 1e9 => format!("{:.0} MB", b / 1e6),
        b => format!("{:.1} GB", b / 1e9),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn available_memory_is_memavailable_and_free_swap() {
        let meminfo = "MemTotal:       16384000 kB\nMemFree:         1000000 kB\n\
                       MemAvailable:    8000000 kB\nSwapTotal:       2000000 kB\n\
                       SwapFree:        1500000 kB\n";
        assert_eq!(available_memory(meminfo), Some(9_500_000 * 1024));
        let no_swap = "MemAvailable:    8000000 kB\n";
        assert_eq!(available_memory(no_swap), Some(8_000_000 * 1024));
        assert_eq!(available_memory("MemTotal: 1 kB\n"), None);
    }

    #[test]
    fn this_process_has_memory_to_use() {
        let (bytes, _) = usable_memory().expect("/proc/meminfo on Linux");
        assert!(bytes > 1 << 20);
    }

    #[test]
    fn bytes_read_in_their_unit() {
        assert_eq!(shown_bytes(512e3), "512 kB");
        assert_eq!(shown_bytes(23.4e6), "23 MB");
        assert_eq!(shown_bytes(2.048e9), "2.0 GB");
    }

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
