//! RAPL through powercap (`/sys/class/powercap/intel-rapl:*`, which AMD parts use too):
//! the zones, counters that wrap at `max_energy_range_uj`, and a sampling thread that reads
//! them often enough to see every wrap.

use super::{Domain, Energy, MeasureError};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

/// How often a window reads its counters. A 32-bit RAPL counter spans at least 65 kJ, so
/// two wraps between readings a second apart would need more than 65 kW: a window sees
/// every wrap.
pub const SAMPLE_PERIOD: Duration = Duration::from_secs(1);

/// One powercap zone with an energy counter.
#[derive(Clone, Debug)]
pub struct Zone {
    /// The zone's folder, e.g. `/sys/class/powercap/intel-rapl:0`.
    pub path: PathBuf,
    /// The zone's own name, e.g. `package-0` or `dram`.
    pub name: String,
    /// The domain the zone counts.
    pub domain: Domain,
    /// The counter's range: it wraps to 0 after this value.
    pub max_range_uj: u64,
}

impl Zone {
    /// `intel-rapl:0 (package-0)`.
    pub fn describe(&self) -> String {
        let folder = self.path.file_name().unwrap_or_default().to_string_lossy();
        format!("{folder} ({})", self.name)
    }

    fn read_uj(&self) -> Result<u64, MeasureError> {
        read_number(&self.path.join("energy_uj")).map_err(MeasureError)
    }
}

fn read_number(path: &Path) -> Result<u64, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|error| format!("{} is not readable ({error})", path.display()))?;
    text.trim()
        .parse()
        .map_err(|_| format!("{} holds no number: {:?}", path.display(), text.trim()))
}

/// The readable RAPL zones under `powercap` (`/sys/class/powercap`), or why there are none.
pub fn zones(powercap: &Path) -> Result<Vec<Zone>, String> {
    let entries =
        std::fs::read_dir(powercap).map_err(|_| format!("{} is absent", powercap.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok())
        .filter(|entry| {
            entry
                .file_name()
                .to_string_lossy()
                .starts_with("intel-rapl:")
        })
        .map(|entry| entry.path())
        .collect();
    folders.sort();
    let mut zones = Vec::new();
    for path in folders {
        let name = std::fs::read_to_string(path.join("name")).unwrap_or_default();
        let name = name.trim().to_string();
        let Some(domain) = Domain::of_powercap_zone(&name) else {
            continue;
        };
        let max_range_uj = read_number(&path.join("max_energy_range_uj"))?;
        let zone = Zone {
            path,
            name,
            domain,
            max_range_uj,
        };
        zone.read_uj().map_err(|error| {
            format!("{error}; energy_uj is readable by root only since Linux 5.10")
        })?;
        zones.push(zone);
    }
    if zones.is_empty() {
        return Err(format!("no intel-rapl zones in {}", powercap.display()));
    }
    Ok(zones)
}

/// The energy counted from `before` to `after` by a counter that wraps to 0 after
/// `max_range_uj`, assuming it wrapped at most once.
pub fn wrapped_delta_uj(before: u64, after: u64, max_range_uj: u64) -> u64 {
    if after >= before {
        after - before
    } else {
        max_range_uj - before + after + 1
    }
}

/// Running totals of the zones' counters, read at successive times.
struct Accumulator {
    zones: Vec<Zone>,
    last_uj: Vec<u64>,
    total_uj: Vec<u64>,
}

impl Accumulator {
    fn new(zones: Vec<Zone>, first_uj: Vec<u64>) -> Accumulator {
        let total_uj = vec![0; zones.len()];
        Accumulator {
            zones,
            last_uj: first_uj,
            total_uj,
        }
    }

    fn read(&self) -> Result<Vec<u64>, MeasureError> {
        self.zones.iter().map(Zone::read_uj).collect()
    }

    fn update(&mut self, readings_uj: Vec<u64>) {
        for ((zone, total), (last, now)) in self
            .zones
            .iter()
            .zip(&mut self.total_uj)
            .zip(self.last_uj.iter().zip(&readings_uj))
        {
            *total += wrapped_delta_uj(*last, *now, zone.max_range_uj);
        }
        self.last_uj = readings_uj;
    }

    fn energy(&self) -> Energy {
        let mut energy = Energy::default();
        for domain in Domain::ALL {
            let mut micro_joules = None;
            for (zone, total) in self.zones.iter().zip(&self.total_uj) {
                if zone.domain == domain {
                    *micro_joules.get_or_insert(0) += total;
                }
            }
            if let Some(micro_joules) = micro_joules {
                energy.add(domain, micro_joules as f64 / 1e6);
            }
        }
        energy
    }
}

/// A window over powercap counters: read at the start, every `period` by a thread, and at
/// the stop.
pub struct Sampling {
    stop: mpsc::Sender<()>,
    thread: JoinHandle<Result<Energy, MeasureError>>,
}

impl Sampling {
    /// Reads the counters and starts the sampling thread.
    pub fn start(zones: Vec<Zone>, period: Duration) -> Result<Sampling, MeasureError> {
        let mut accumulator = Accumulator::new(zones, Vec::new());
        accumulator.last_uj = accumulator.read()?;
        let (stop, stopped) = mpsc::channel();
        let thread = std::thread::spawn(move || loop {
            let last = !matches!(
                stopped.recv_timeout(period),
                Err(mpsc::RecvTimeoutError::Timeout)
            );
            accumulator.update(accumulator.read()?);
            if last {
                return Ok(accumulator.energy());
            }
        });
        Ok(Sampling { stop, thread })
    }

    /// Reads the counters a last time and returns the window's energy.
    pub fn stop(self) -> Result<Energy, MeasureError> {
        let _ = self.stop.send(());
        self.thread
            .join()
            .map_err(|_| MeasureError("the powercap sampling thread panicked".to_string()))?
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes a powercap zone folder as the kernel lays it out.
    fn zone(root: &Path, folder: &str, name: &str, max_uj: u64, energy_uj: u64) -> PathBuf {
        let path = root.join(folder);
        std::fs::create_dir_all(&path).unwrap();
        std::fs::write(path.join("name"), format!("{name}\n")).unwrap();
        std::fs::write(path.join("max_energy_range_uj"), format!("{max_uj}\n")).unwrap();
        std::fs::write(path.join("energy_uj"), format!("{energy_uj}\n")).unwrap();
        path
    }

    #[test]
    fn an_intel_tree_gives_one_zone_per_counter() {
        let root = tempfile::tempdir().unwrap();
        let max = 262_143_328_850;
        zone(root.path(), "intel-rapl:0", "package-0", max, 1);
        zone(root.path(), "intel-rapl:0:0", "core", max, 2);
        zone(root.path(), "intel-rapl:0:1", "uncore", max, 3);
        zone(root.path(), "intel-rapl:0:2", "dram", max, 4);
        zone(root.path(), "intel-rapl:1", "psys", max, 5);
        zone(root.path(), "intel-rapl-mmio:0", "package-0", max, 6);
        std::fs::create_dir(root.path().join("intel-rapl")).unwrap();
        let zones = zones(root.path()).unwrap();
        let names: Vec<String> = zones.iter().map(Zone::describe).collect();
        assert_eq!(
            names,
            [
                "intel-rapl:0 (package-0)",
                "intel-rapl:0:0 (core)",
                "intel-rapl:0:1 (uncore)",
                "intel-rapl:0:2 (dram)",
                "intel-rapl:1 (psys)"
            ]
        );
        assert_eq!(zones[3].domain, Domain::Ram);
        assert!(zones.iter().all(|zone| zone.max_range_uj == max));
    }

    #[test]
    fn an_amd_tree_gives_the_package() {
        let root = tempfile::tempdir().unwrap();
        zone(root.path(), "intel-rapl:0", "package-0", 65_712_999_613, 7);
        let zones = zones(root.path()).unwrap();
        assert_eq!(zones.len(), 1);
        assert_eq!(zones[0].domain, Domain::Pkg);
    }

    #[test]
    fn missing_or_unreadable_counters_are_explained() {
        let root = tempfile::tempdir().unwrap();
        let absent = root.path().join("powercap");
        assert_eq!(
            zones(&absent).unwrap_err(),
            format!("{} is absent", absent.display())
        );
        std::fs::create_dir(&absent).unwrap();
        assert!(zones(&absent)
            .unwrap_err()
            .starts_with("no intel-rapl zones"));
        let package = zone(&absent, "intel-rapl:0", "package-0", 1000, 1);
        std::fs::remove_file(package.join("energy_uj")).unwrap();
        let reason = zones(&absent).unwrap_err();
        assert!(reason.contains("energy_uj is not readable"), "{reason}");
        assert!(reason.contains("root only"), "{reason}");
    }

    #[test]
    fn a_wrapped_counter_counts_through_the_top() {
        assert_eq!(wrapped_delta_uj(100, 350, 1000), 250);
        assert_eq!(wrapped_delta_uj(900, 100, 1000), 201);
        assert_eq!(wrapped_delta_uj(1000, 0, 1000), 1);
        assert_eq!(wrapped_delta_uj(5, 5, 1000), 0);
    }

    #[test]
    fn successive_readings_add_up_across_wraps_per_domain() {
        let package = |name: &str, domain| Zone {
            path: PathBuf::from(name),
            name: name.to_string(),
            domain,
            max_range_uj: 1_000_000,
        };
        let zones = vec![
            package("package-0", Domain::Pkg),
            package("package-1", Domain::Pkg),
            package("dram", Domain::Ram),
        ];
        let mut accumulator = Accumulator::new(zones, vec![900_000, 10, 999_999]);
        accumulator.update(vec![100_000, 20, 499_999]); // package-0 and dram wrap
        accumulator.update(vec![600_000, 30, 500_000]);
        let energy = accumulator.energy();
        // package-0: 200_001 + 500_000; package-1: 20; dram: 500_001 + 1.
        assert_eq!(energy.joules(Domain::Pkg), Some(0.700_021));
        assert_eq!(energy.joules(Domain::Ram), Some(0.500_002));
        assert_eq!(energy.joules(Domain::Cores), None);
    }

    #[test]
    fn a_window_reads_at_start_and_stop() {
        let root = tempfile::tempdir().unwrap();
        let max = 262_143_328_850;
        let package = zone(
            root.path(),
            "intel-rapl:0",
            "package-0",
            max,
            max - 1_000_000,
        );
        let zones = zones(root.path()).unwrap();
        let sampling = Sampling::start(zones, Duration::from_secs(600)).unwrap();
        std::fs::write(package.join("energy_uj"), "2499999\n").unwrap();
        let energy = sampling.stop().unwrap();
        assert_eq!(energy.joules(Domain::Pkg), Some(3.5));
    }
}
