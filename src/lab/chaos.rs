//! Chaos: how far a run's outputs scatter when its input moves by one ulp, and whether
//! another run's output lies within that scatter.
//!
//! The course model is unstable: after a few hundred steps its particles' paths depend
//! on every rounding, so a change of the order of a sum changes the output's bytes. Such a
//! change is no bigger than chaos when the statistics of its output lie within those of an
//! ensemble of runs of the previous revision on the input and on copies of it with one
//! coordinate of one particle moved by one ulp (of the file's f32): within the ensemble's
//! range widened by its standard deviation on each side.

use crate::io::fld::{self, FileError, HEADER_BYTES, RECORD_BYTES};
use crate::lab::diagnostics::{self, Vitals};
use crate::sim::method::Method;
use crate::sim::particles::vector_at;
use crate::sim::simulation::Simulation;
use std::fmt::Write;

/// The upper edges of the speed histogram's bins (m/s), one bin per decade from 0.01 to
/// 100,000 m/s, with one below the first and one above the last: the course model's
/// speeds span that range once it has blown up.
const SPEED_EDGES: [f64; 8] = [1e-2, 1e-1, 1e0, 1e1, 1e2, 1e3, 1e4, 1e5];

/// The most copies of an input of `particles` particles that [`perturbed`] makes, each
/// moving another coordinate: 3 per particle.
pub fn most_copies(particles: usize) -> usize {
    3 * particles
}

/// Copy `copy` of the `.fld` input `bytes` with one coordinate of one particle moved up
/// by one ulp of its f32: copies 0, 1, 2, ... move x, y, z, x, ... of particles spread
/// evenly over the ids (of `copies` in all, at most [`most_copies`], so that no two
/// copies are alike). Returns the copy, and which particle and axis moved.
pub fn perturbed(
    bytes: &[u8],
    copy: usize,
    copies: usize,
    file: &str,
) -> Result<(Vec<u8>, usize, usize), FileError> {
    let header = fld::validate(bytes, file)?;
    let n = header.particles;
    assert!(
        copy < copies && copies <= most_copies(n),
        "copy {copy} of {copies}"
    );
    // Copies k and k + 3 m share an axis; their particles differ as 2 m n / (2 copies)
    // >= 1 while copies <= 3 n.
    let (id, axis) = ((2 * copy + 1) * n / (2 * copies), copy % 3);
    let at = HEADER_BYTES + RECORD_BYTES * id + 4 * axis;
    let value = f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let moved = value.next_up();
    if !moved.is_finite() {
        return Err(FileError::InvalidInput {
            file: file.into(),
            reason: format!("particle {id}'s coordinate {axis} has no finite f32 above it"),
        });
    }
    let mut copy = bytes.to_vec();
    copy[at..at + 4].copy_from_slice(&moved.to_le_bytes());
    Ok((copy, id, axis))
}

/// The statistics of a state compared across runs, each with its name.
#[derive(Debug, Clone, PartialEq)]
pub struct Statistics(pub Vec<(String, f64)>);

impl Statistics {
    /// The statistics of the state of `simulation` (the course model's parameters, its
    /// densities computed afresh): the particle count, mean and RMS speed, kinetic energy,
    /// mean density, centre of mass, the fraction inside the box, the fraction with a
    /// partner closer than h, and the fraction of particles in each decade of speed.
    pub fn of(simulation: &Simulation) -> Statistics {
        let copy = simulation.with_fresh_densities();
        let (params, particles) = (copy.params(), copy.particles());
        let kinetic = Vitals::of(&copy).kinetic;
        let n = particles.len();
        let count = n.max(1) as f64;
        let (mut speed_sum, mut square_sum, mut centre) = (0.0, 0.0, [0.0; 3]);
        let (mut inside, mut bins) = (0usize, [0usize; SPEED_EDGES.len() + 1]);
        let domain = params.domain;
        for slot in 0..n {
            let (position, velocity) =
                (vector_at(&particles.p, slot), vector_at(&particles.v, slot));
            let speed = velocity.length();
            speed_sum += speed;
            square_sum += speed * speed;
            for (sum, p) in centre.iter_mut().zip(position.to_array()) {
                *sum += p;
            }
            inside +=
                usize::from(position.cmpge(domain.min).all() && position.cmple(domain.max).all());
            bins[SPEED_EDGES.partition_point(|&edge| edge <= speed)] += 1;
        }
        let density: f64 = particles.rho[..n].iter().sum();
        let mut statistics = vec![
            ("particles".to_string(), n as f64),
            ("mean speed (m/s)".to_string(), speed_sum / count),
            ("RMS speed (m/s)".to_string(), (square_sum / count).sqrt()),
            ("kinetic energy (J)".to_string(), kinetic),
            ("mean density (kg/m3)".to_string(), density / count),
        ];
        for (axis, sum) in ["x", "y", "z"].iter().zip(centre) {
            statistics.push((format!("centre of mass {axis} (m)"), sum / count));
        }
        statistics.push(("fraction inside the box".to_string(), inside as f64 / count));
        statistics.push((
            "fraction with a partner closer than h".to_string(),
            diagnostics::partnered(&copy) as f64 / count,
        ));
        for (bin, &in_bin) in bins.iter().enumerate() {
            let name = match bin {
                0 => format!("fraction at speeds < {:e} m/s", SPEED_EDGES[0]),
                k if k == SPEED_EDGES.len() => {
                    format!("fraction at speeds >= {:e} m/s", SPEED_EDGES[k - 1])
                }
                k => format!(
                    "fraction at speeds {:e} to {:e} m/s",
                    SPEED_EDGES[k - 1],
                    SPEED_EDGES[k]
                ),
            };
            statistics.push((name, in_bin as f64 / count));
        }
        Statistics(statistics)
    }

    /// The statistics of the `.fld` state `bytes` (named `file` in errors).
    pub fn of_file(bytes: &[u8], file: &str) -> Result<Statistics, FileError> {
        let simulation = fld::parse(bytes, file)?.into_simulation(Method::default(), file)?;
        Ok(Statistics::of(&simulation))
    }
}

/// One statistic of a candidate against the ensemble's.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// The statistic's name.
    pub name: String,
    /// The ensemble's smallest and largest value.
    pub range: (f64, f64),
    /// The ensemble's standard deviation (of a sample: n - 1).
    pub deviation: f64,
    /// The candidate's value.
    pub value: f64,
}

impl Verdict {
    /// Whether the candidate lies within the ensemble's range widened by its standard
    /// deviation on each side (a NaN never does).
    pub fn holds(&self) -> bool {
        let (low, high) = self.range;
        (low - self.deviation..=high + self.deviation).contains(&self.value)
    }
}

/// Each statistic of `candidate` against those of `ensemble` (at least two members, each
/// with the candidate's statistics in the same order).
pub fn judge(ensemble: &[Statistics], candidate: &Statistics) -> Vec<Verdict> {
    assert!(ensemble.len() >= 2, "an ensemble of {}", ensemble.len());
    candidate
        .0
        .iter()
        .enumerate()
        .map(|(k, (name, value))| {
            let values: Vec<f64> = ensemble
                .iter()
                .map(|member| {
                    assert_eq!(&member.0[k].0, name, "statistics in another order");
                    member.0[k].1
                })
                .collect();
            let m = values.len() as f64;
            let mean = values.iter().sum::<f64>() / m;
            let variance = values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0);
            let range = values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            Verdict {
                name: name.clone(),
                range,
                deviation: variance.sqrt(),
                value: *value,
            }
        })
        .collect()
}

/// The calibration of [`judge`] on the ensemble itself: each member judged against the
/// others. Returns how many of the members' statistics fall outside, and how many were
/// judged: the rate at which a run as chaotic as the members fails a statistic.
pub fn leave_one_out(ensemble: &[Statistics]) -> (usize, usize) {
    assert!(ensemble.len() >= 3, "an ensemble of {}", ensemble.len());
    let (mut outside, mut judged) = (0, 0);
    for (k, member) in ensemble.iter().enumerate() {
        let others: Vec<Statistics> = ensemble
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .map(|(_, other)| other.clone())
            .collect();
        let verdicts = judge(&others, member);
        outside += verdicts.iter().filter(|verdict| !verdict.holds()).count();
        judged += verdicts.len();
    }
    (outside, judged)
}

/// The verdicts as a markdown table: statistic, the ensemble's range and deviation, the
/// candidate's value and whether it holds.
pub fn table(verdicts: &[Verdict]) -> String {
    let mut text = String::from(
        "| statistic | ensemble min | ensemble max | ensemble sd | new | within |\n\
         |---|---:|---:|---:|---:|---|\n",
    );
    for verdict in verdicts {
        let (low, high) = verdict.range;
        let _ = writeln!(
            text,
            "| {} | {low:.6e} | {high:.6e} | {:.3e} | {:.6e} | {} |",
            verdict.name,
            verdict.deviation,
            verdict.value,
            if verdict.holds() { "yes" } else { "**NO**" }
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::particles::Particles;

    /// A `.fld` file of `particles` at 204 particles per metre.
    fn file(particles: &Particles) -> Vec<u8> {
        fld::encode(204.0, particles).unwrap()
    }

    fn cloud(n: usize, seed: u64) -> Particles {
        let mut random = fastrand::Rng::with_seed(seed);
        let mut particles = Particles::zeroed(n);
        for axis in 0..3 {
            for slot in 0..n {
                particles.p[axis][slot] = 0.06 * (random.f64() - 0.5);
                particles.v[axis][slot] = 20.0 * (random.f64() - 0.5);
            }
        }
        particles
    }

    #[test]
    fn a_copy_moves_one_coordinate_of_one_particle_by_one_ulp() {
        let bytes = file(&cloud(100, 1));
        let mut moved = Vec::new();
        for copy in 0..8 {
            let (perturbed, id, axis) = perturbed(&bytes, copy, 8, "cloud.fld").unwrap();
            assert_eq!(perturbed.len(), bytes.len());
            let differing: Vec<usize> = (0..bytes.len() / 4)
                .filter(|&w| perturbed[4 * w..4 * w + 4] != bytes[4 * w..4 * w + 4])
                .collect();
            let word = (HEADER_BYTES + RECORD_BYTES * id) / 4 + axis;
            assert_eq!(differing, [word]);
            let read = |b: &[u8]| f32::from_le_bytes(b[4 * word..4 * word + 4].try_into().unwrap());
            assert_eq!(read(&perturbed), read(&bytes).next_up());
            moved.push((id, axis));
        }
        // Eight different particles, every axis.
        let mut ids: Vec<usize> = moved.iter().map(|m| m.0).collect();
        ids.dedup();
        assert_eq!(ids.len(), 8);
        assert!((0..3).all(|axis| moved.iter().any(|m| m.1 == axis)));
        assert!(perturbed(&bytes[..20], 0, 8, "short.fld").is_err());
    }

    #[test]
    fn statistics_measure_the_state() {
        // Two particles at rest inside the box 0.002 m apart (closer than h), one far
        // outside at 30 m/s along x.
        let mut particles = Particles::zeroed(3);
        let points = [[0.0, 0.0, 0.0], [0.002, 0.0, 0.0], [5.0, 1.0, -4.0]];
        for (slot, point) in points.iter().enumerate() {
            for (axis, &x) in particles.p.iter_mut().zip(point) {
                axis[slot] = x;
            }
        }
        particles.v[0][2] = 30.0;
        let statistics = Statistics::of_file(&file(&particles), "three.fld").unwrap();
        let get = |name: &str| {
            statistics
                .0
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v)
                .unwrap()
        };
        assert_eq!(get("particles"), 3.0);
        assert!((get("mean speed (m/s)") - 10.0).abs() < 1e-12);
        assert!((get("RMS speed (m/s)") - (900.0f64 / 3.0).sqrt()).abs() < 1e-12);
        let mass = crate::sim::params::Params::new(204.0).mass;
        assert!((get("kinetic energy (J)") - 0.5 * mass * 900.0).abs() < 1e-15);
        assert!((get("centre of mass x (m)") - 5.002 / 3.0).abs() < 1e-6);
        assert!((get("fraction inside the box") - 2.0 / 3.0).abs() < 1e-12);
        assert!((get("fraction with a partner closer than h") - 2.0 / 3.0).abs() < 1e-12);
        assert!((get("fraction at speeds < 1e-2 m/s") - 2.0 / 3.0).abs() < 1e-12);
        assert!((get("fraction at speeds 1e1 to 1e2 m/s") - 1.0 / 3.0).abs() < 1e-12);
        // The pair's densities exceed a lone particle's.
        assert!(get("mean density (kg/m3)") > 0.0);
        let bins: f64 = statistics
            .0
            .iter()
            .filter(|(n, _)| n.starts_with("fraction at"))
            .map(|s| s.1)
            .sum();
        assert!((bins - 1.0).abs() < 1e-12);
    }

    fn statistics(values: &[f64]) -> Statistics {
        Statistics(
            values
                .iter()
                .enumerate()
                .map(|(k, &v)| (format!("s{k}"), v))
                .collect(),
        )
    }

    #[test]
    fn a_candidate_holds_within_the_range_widened_by_the_deviation() {
        // One statistic: members 1, 2, 3 (sd 1): within [0, 4].
        let ensemble: Vec<Statistics> = [1.0, 2.0, 3.0].map(|v| statistics(&[v])).to_vec();
        for (value, holds) in [
            (2.0, true),
            (0.0, true),
            (4.0, true),
            (-0.01, false),
            (4.01, false),
            (f64::NAN, false),
        ] {
            let verdicts = judge(&ensemble, &statistics(&[value]));
            assert_eq!(verdicts[0].range, (1.0, 3.0));
            assert!((verdicts[0].deviation - 1.0).abs() < 1e-15);
            assert_eq!(verdicts[0].holds(), holds, "{value}");
        }
        // A statistic every member agrees on must be met exactly.
        let same: Vec<Statistics> = [5.0, 5.0].map(|v| statistics(&[v])).to_vec();
        assert!(judge(&same, &statistics(&[5.0]))[0].holds());
        assert!(!judge(&same, &statistics(&[5.0f64.next_up()]))[0].holds());
        let text = table(&judge(&same, &statistics(&[6.0])));
        assert!(text.contains("| s0 |") && text.contains("**NO**"), "{text}");
    }

    #[test]
    fn leave_one_out_counts_the_members_outside_the_others() {
        // Members 0, 1, 2, 10 of two statistics, the second equal for all: 10 against
        // 0, 1, 2 (sd 1) is outside [-1, 3]; 0 against 1, 2, 10 (sd 4.9) is within.
        let ensemble: Vec<Statistics> = [0.0, 1.0, 2.0, 10.0]
            .map(|v| statistics(&[v, 7.0]))
            .to_vec();
        assert_eq!(leave_one_out(&ensemble), (1, 8));
    }
}
