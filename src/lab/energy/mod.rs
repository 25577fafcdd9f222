//! Energy of a measured window: RAPL counters read through `perf stat -a`, else through the
//! powercap files in sysfs, else a stated reason why neither is readable. Nothing here ever
//! reports an energy it did not read: a domain that was not measured is `None`, never 0.

pub mod perf;
pub mod powercap;

use std::fmt;
use std::path::{Path, PathBuf};

/// A RAPL energy domain, named as `perf` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    /// The whole package (socket).
    Pkg,
    /// The cores of the package.
    Cores,
    /// The uncore / integrated GPU (powercap's `uncore`).
    Gpu,
    /// The memory (powercap's `dram`).
    Ram,
    /// The platform (SoC and more), on client Intel parts.
    Psys,
}

impl Domain {
    /// Every domain, in the order of the CSV columns.
    pub const ALL: [Domain; 5] = [
        Domain::Pkg,
        Domain::Cores,
        Domain::Gpu,
        Domain::Ram,
        Domain::Psys,
    ];

    /// The domain's short name (`pkg`, `cores`, `gpu`, `ram`, `psys`).
    pub fn name(self) -> &'static str {
        match self {
            Domain::Pkg => "pkg",
            Domain::Cores => "cores",
            Domain::Gpu => "gpu",
            Domain::Ram => "ram",
            Domain::Psys => "psys",
        }
    }

    /// The domain of a perf RAPL event (`power/energy-pkg/` or `energy-pkg`).
    pub fn of_perf_event(event: &str) -> Option<Domain> {
        let name = event.trim_matches('/');
        let name = name.strip_prefix("power/").unwrap_or(name);
        match name.strip_prefix("energy-")? {
            "pkg" => Some(Domain::Pkg),
            "cores" => Some(Domain::Cores),
            "gpu" => Some(Domain::Gpu),
            "ram" => Some(Domain::Ram),
            "psys" => Some(Domain::Psys),
            _ => None,
        }
    }

    /// The domain of a powercap zone name (`package-0`, `core`, `uncore`, `dram`, `psys`).
    pub fn of_powercap_zone(name: &str) -> Option<Domain> {
        match name {
            "core" => Some(Domain::Cores),
            "uncore" => Some(Domain::Gpu),
            "dram" => Some(Domain::Ram),
            "psys" => Some(Domain::Psys),
            _ if name.starts_with("package-") => Some(Domain::Pkg),
            _ => None,
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Joules per domain over one window; `None` for a domain that was not measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy([Option<f64>; 5]);

impl Energy {
    /// The joules of `domain`, if measured.
    pub fn joules(&self, domain: Domain) -> Option<f64> {
        self.0[domain.index()]
    }

    /// Adds `joules` to `domain` (packages of one domain add up).
    pub fn add(&mut self, domain: Domain, joules: f64) {
        let slot = &mut self.0[domain.index()];
        *slot = Some(slot.unwrap_or(0.0) + joules);
    }

    /// Whether any domain was measured.
    pub fn is_measured(&self) -> bool {
        self.0.iter().any(Option::is_some)
    }
}

/// Why a measurement failed.
#[derive(Debug)]
pub struct MeasureError(pub String);

impl fmt::Display for MeasureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for MeasureError {}

/// Where the counters live: the real sysfs, or a fixture tree in tests.
#[derive(Clone, Debug)]
pub struct Sources {
    /// perf's PMU folder (`/sys/bus/event_source/devices`).
    pub pmus: PathBuf,
    /// The powercap folder (`/sys/class/powercap`).
    pub powercap: PathBuf,
    /// The `perf` program.
    pub perf: PathBuf,
}

impl Default for Sources {
    fn default() -> Self {
        Sources {
            pmus: PathBuf::from("/sys/bus/event_source/devices"),
            powercap: PathBuf::from("/sys/class/powercap"),
            perf: PathBuf::from("perf"),
        }
    }
}

/// How energy is measured on this machine.
#[derive(Debug)]
pub enum EnergyMethod {
    /// `perf stat -a` over the RAPL events that counted in a probe.
    Perf {
        /// The `perf` program.
        program: PathBuf,
        /// Events such as `power/energy-pkg/`.
        events: Vec<String>,
    },
    /// The powercap zones' `energy_uj` counters, sampled so that wraparound is seen.
    Powercap(Vec<powercap::Zone>),
    /// Neither is readable.
    Unavailable {
        /// Why, for each method tried.
        reason: String,
    },
}

impl EnergyMethod {
    /// Finds the first method that works here: perf RAPL events (probed with a short
    /// window), then powercap, else the reasons both failed.
    pub fn detect(sources: &Sources) -> EnergyMethod {
        let perf_reason = match perf::usable_events(&sources.perf, &sources.pmus) {
            Ok(events) => {
                return EnergyMethod::Perf {
                    program: sources.perf.clone(),
                    events,
                }
            }
            Err(reason) => reason,
        };
        let powercap_reason = match powercap::zones(&sources.powercap) {
            Ok(zones) => return EnergyMethod::Powercap(zones),
            Err(reason) => reason,
        };
        let mut reason = format!("perf: {perf_reason}; powercap: {powercap_reason}");
        if is_virtual_machine(Path::new("/proc/cpuinfo")) {
            reason.push_str("; the CPU flags say this is a virtual machine, which hides RAPL");
        }
        EnergyMethod::Unavailable { reason }
    }

    /// The method's CSV name: `perf`, `powercap` or `none`.
    pub fn name(&self) -> &'static str {
        match self {
            EnergyMethod::Perf { .. } => "perf",
            EnergyMethod::Powercap(_) => "powercap",
            EnergyMethod::Unavailable { .. } => "none",
        }
    }

    /// One line saying what is read, or why nothing is.
    pub fn describe(&self) -> String {
        match self {
            EnergyMethod::Perf { program, events } => {
                format!("{} stat -a -e {}", program.display(), events.join(","))
            }
            EnergyMethod::Powercap(zones) => {
                let names: Vec<String> = zones.iter().map(powercap::Zone::describe).collect();
                format!("powercap energy_uj of {}", names.join(", "))
            }
            EnergyMethod::Unavailable { reason } => format!("not available ({reason})"),
        }
    }

    /// Starts counting; [`Window::stop`] gives the energy since.
    pub fn start(&self) -> Result<Window, MeasureError> {
        Ok(match self {
            EnergyMethod::Perf { program, events } => {
                Window::Perf(perf::Counting::start(program, events)?)
            }
            EnergyMethod::Powercap(zones) => Window::Powercap(powercap::Sampling::start(
                zones.clone(),
                powercap::SAMPLE_PERIOD,
            )?),
            EnergyMethod::Unavailable { .. } => Window::Unavailable,
        })
    }
}

/// A window being counted.
pub enum Window {
    /// A `perf stat` process counting.
    Perf(perf::Counting),
    /// A thread sampling powercap counters.
    Powercap(powercap::Sampling),
    /// Nothing is counted.
    Unavailable,
}

impl Window {
    /// Stops counting and returns the energy of the window (all `None` when unavailable).
    pub fn stop(self) -> Result<Energy, MeasureError> {
        match self {
            Window::Perf(counting) => perf::energy_of(&counting.stop()?),
            Window::Powercap(sampling) => sampling.stop(),
            Window::Unavailable => Ok(Energy::default()),
        }
    }
}

/// Whether `/proc/cpuinfo` lists the `hypervisor` flag.
fn is_virtual_machine(cpuinfo: &Path) -> bool {
    std::fs::read_to_string(cpuinfo).is_ok_and(|text| {
        text.lines()
            .filter(|line| line.starts_with("flags"))
            .any(|line| line.split_whitespace().any(|flag| flag == "hypervisor"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perf_events_and_powercap_zones_name_their_domains() {
        assert_eq!(
            Domain::of_perf_event("power/energy-pkg/"),
            Some(Domain::Pkg)
        );
        assert_eq!(Domain::of_perf_event("energy-cores"), Some(Domain::Cores));
        assert_eq!(
            Domain::of_perf_event("power/energy-ram/"),
            Some(Domain::Ram)
        );
        assert_eq!(
            Domain::of_perf_event("power/energy-gpu/"),
            Some(Domain::Gpu)
        );
        assert_eq!(
            Domain::of_perf_event("power/energy-psys/"),
            Some(Domain::Psys)
        );
        assert_eq!(Domain::of_perf_event("cpu-clock"), None);
        assert_eq!(Domain::of_powercap_zone("package-1"), Some(Domain::Pkg));
        assert_eq!(Domain::of_powercap_zone("dram"), Some(Domain::Ram));
        assert_eq!(Domain::of_powercap_zone("uncore"), Some(Domain::Gpu));
        assert_eq!(Domain::of_powercap_zone("mmio"), None);
    }

    #[test]
    fn energy_adds_packages_and_keeps_unmeasured_domains_empty() {
        let mut energy = Energy::default();
        assert!(!energy.is_measured());
        energy.add(Domain::Pkg, 1.5);
        energy.add(Domain::Pkg, 2.0);
        assert_eq!(energy.joules(Domain::Pkg), Some(3.5));
        assert_eq!(energy.joules(Domain::Ram), None);
        assert!(energy.is_measured());
    }

    #[test]
    fn nothing_readable_gives_both_reasons_and_no_energy() {
        let empty = tempfile::tempdir().unwrap();
        let sources = Sources {
            pmus: empty.path().join("devices"),
            powercap: empty.path().join("powercap"),
            perf: PathBuf::from("perf"),
        };
        let method = EnergyMethod::detect(&sources);
        assert_eq!(method.name(), "none");
        let text = method.describe();
        assert!(text.starts_with("not available (perf: "), "{text}");
        assert!(text.contains("; powercap: "), "{text}");
        let energy = method.start().unwrap().stop().unwrap();
        assert!(!energy.is_measured());
    }

    #[test]
    fn the_hypervisor_flag_marks_a_virtual_machine() {
        let dir = tempfile::tempdir().unwrap();
        let cpuinfo = dir.path().join("cpuinfo");
        std::fs::write(
            &cpuinfo,
            "model name\t: X\nflags\t\t: fpu sse2 hypervisor avx2\n",
        )
        .unwrap();
        assert!(is_virtual_machine(&cpuinfo));
        std::fs::write(&cpuinfo, "flags\t\t: fpu sse2 avx2\n").unwrap();
        assert!(!is_virtual_machine(&cpuinfo));
    }
}
