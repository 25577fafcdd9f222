//! Checkpoint files: the full f64 state of a run after a number of steps
//! ([`crate::sim::simulation::Resumable`]), from which a resumed run goes on bit for bit.
//!
//! Layout (little-endian): the magic `FLUIDCKB` (version 11); the step count (u64); the CRC-32 of the
//! input file the run started from (u32, so a resume from another input is refused); the
//! case file it started from, if it did (a u8, 0 for none, else 1, then its length, u64,
//! and its UTF-8 text: a resume needs nothing else); its gauges' readings so far (rows,
//! u64, and columns, u64, 0 without rows; then each row's time and values, f64, the
//! canonical NaN where a gauge read nothing), which a resumed run's table goes on from;
//! particles per metre and the time (f64); the box's low and high corners and gravity
//! (x, y, z each, f64) and its shape (u8: bit 0 planar, bits 1-3 the periodic axes x, y,
//! z); the model, kernel, time-step rule, last step's
//! limit, integrator and pair structure (which decides the order of the pair sums) as
//! length-prefixed names (u8 length); the time step's value (f64: dt or the Courant
//! constant), the last step's length (f64, NaN before the first step); what the model
//! keeps of itself ([`crate::sim::model::Dynamics::saved`]: a count, u64, then that many
//! f64; the weakly compressible model's sound speed and settings, and under the velocity
//! Verlet its last density rates; none for the others); the sparse flag (u8); the skin
//! of lists kept over steps ([`crate::sim::skin::KeptSkin`]: a u8, 0 for none, else 1
//! then its width (f64), its builds (u64), how its last sort ran (u8) and whether its
//! last build's positions follow (u8: not before the first build, nor once expired));
//! the particle count n (u64); then n ids (u32) and, per particle field p, hv, v, a (x,
//! y, z) and rho, n f64 each; a built skin's positions at its last build (x, y, z, n f64
//! each); last, the CRC-32 of every byte before it (u32), so a corrupted checkpoint is
//! refused. Versions 1-10 (before the integrators; version 3 before the models kept
//! their own state; version 5 before the skin and the pair structure; version 6 before
//! the case; version 7 before the box and gravity; version 9 before planar and periodic
//! scenes; version 10 before the gauges' readings) are
//! refused, with a message that says so.

use crate::sim::kernel::Kernel;
use crate::sim::lists::PairStructure;
use crate::sim::method::Method;
use crate::sim::model::Model;
use crate::sim::params::Domain;
use crate::sim::particles::{AxisArrays, Particles};
use crate::sim::simulation::Resumable;
use crate::sim::skin::KeptSkin;
use crate::sim::timestep::{Integrator, Limit, TimeStep};
use glam::DVec3;

/// The first bytes of every checkpoint (format version 11, which adds the gauges' readings
/// to version 10, which added the domain's shape, planar and periodic, to version 9;
/// version 8 holds version 9's fields, but its particles were ordered within a cell by the
/// order they came in, not by id, so a resume from it would not go on as its run did).
const MAGIC: &[u8; 8] = b"FLUIDCKB";

/// The first bytes of a checkpoint of an earlier format, which is refused.
const OLDER: [&[u8; 8]; 10] = [
    b"FLUIDCK1",
    b"FLUIDCK2",
    b"FLUIDCK3",
    b"FLUIDCK4",
    b"FLUIDCK5",
    b"FLUIDCK6",
    b"FLUIDCK7",
    b"FLUIDCK8",
    b"FLUIDCK9",
    b"FLUIDCKA",
];

/// A checkpoint's content: the steps run and the state after them.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Steps run so far.
    pub step: u64,
    /// The CRC-32 of the input file's bytes ([`crc32fast::hash`]).
    pub input: u32,
    /// The text of the case file the run started from, if it did.
    pub case: Option<String>,
    /// The readings its gauges took so far: each row's time (s) and values (`None` where
    /// a gauge read nothing), all rows of one length.
    pub readings: Vec<Reading>,
    /// The state to go on from.
    pub state: Resumable,
}

/// One row of gauge readings: its time (s) and each column's value, if read.
pub type Reading = (f64, Vec<Option<f64>>);

/// At least the size of a checkpoint of `particles` particles, a case of `case` bytes
/// and `readings` gauge values, times included (for the room reserved before a run): a
/// model may keep a value per particle, a skin 3.
pub fn size_bound(particles: usize, case: usize, readings: usize) -> u64 {
    (256 + case + 8 * readings + particles * (4 + 17 * 8)) as u64
}

/// Encodes a checkpoint.
pub fn encode(checkpoint: &Checkpoint) -> Vec<u8> {
    let state = &checkpoint.state;
    let particles = &state.particles;
    let n = particles.len();
    let case = checkpoint.case.as_deref();
    let columns = checkpoint
        .readings
        .first()
        .map_or(0, |(_, values)| values.len());
    let values = checkpoint.readings.len() * (1 + columns);
    let mut bytes = Vec::with_capacity(size_bound(n, case.map_or(0, str::len), values) as usize);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&checkpoint.step.to_le_bytes());
    bytes.extend_from_slice(&checkpoint.input.to_le_bytes());
    match case {
        Some(text) => {
            bytes.push(1);
            bytes.extend_from_slice(&(text.len() as u64).to_le_bytes());
            bytes.extend_from_slice(text.as_bytes());
        }
        None => bytes.push(0),
    }
    bytes.extend_from_slice(&(checkpoint.readings.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(columns as u64).to_le_bytes());
    for (time, values) in &checkpoint.readings {
        let values = values.iter().map(|value| value.unwrap_or(f64::NAN));
        for value in [*time].into_iter().chain(values) {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
    }
    bytes.extend_from_slice(&state.ppm.to_le_bytes());
    bytes.extend_from_slice(&state.time.to_le_bytes());
    let domain = &state.domain;
    for value in [domain.min, domain.max, domain.gravity]
        .iter()
        .flat_map(|v| v.to_array())
    {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    let periodic = (0..3).fold(0, |bits, axis| {
        bits | u8::from(domain.periodic[axis]) << (axis + 1)
    });
    bytes.push(u8::from(domain.planar) | periodic);
    let (rule, value) = match state.time_step {
        TimeStep::Fixed(dt) => ("fixed", dt),
        TimeStep::Adaptive { courant } => ("adaptive", courant),
    };
    let (last_dt, last_limit) = state
        .last_step
        .map_or((f64::NAN, "none"), |(dt, limit)| (dt, limit.name()));
    for name in [
        state.method.model.name(),
        state.method.kernel.name(),
        rule,
        last_limit,
        state.integrator.name(),
        state.structure.name(),
    ] {
        bytes.push(name.len() as u8);
        bytes.extend_from_slice(name.as_bytes());
    }
    bytes.extend_from_slice(&value.to_le_bytes());
    bytes.extend_from_slice(&last_dt.to_le_bytes());
    bytes.extend_from_slice(&(state.model_state.len() as u64).to_le_bytes());
    for value in &state.model_state {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    bytes.push(u8::from(state.sparse));
    let built = state.skin.as_ref().map_or(&[][..], |skin| {
        let built = !skin.built[0].is_empty();
        bytes.push(1);
        bytes.extend_from_slice(&skin.width.to_le_bytes());
        bytes.extend_from_slice(&skin.builds.to_le_bytes());
        bytes.extend([u8::from(skin.sorted_sparse), u8::from(built)]);
        if built {
            &skin.built[..]
        } else {
            &[]
        }
    });
    if state.skin.is_none() {
        bytes.push(0);
    }
    bytes.extend_from_slice(&(n as u64).to_le_bytes());
    for id in &particles.id {
        bytes.extend_from_slice(&id.to_le_bytes());
    }
    for array in fields(particles).chain(built) {
        for value in &array[..n] {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
    }
    let checksum = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&checksum.to_le_bytes());
    bytes
}

/// The f64 arrays of `particles` in file order: p, hv, v, a (x, y, z each), rho.
fn fields(particles: &Particles) -> impl Iterator<Item = &Vec<f64>> {
    [&particles.p, &particles.hv, &particles.v, &particles.a]
        .into_iter()
        .flatten()
        .chain([&particles.rho])
}

/// Decodes a checkpoint, or says what is wrong with it (never panics).
pub fn decode(bytes: &[u8]) -> Result<Checkpoint, String> {
    let magic = bytes.get(..MAGIC.len());
    if let Some(older) = OLDER.iter().find(|older| magic == Some(&older[..])) {
        return Err(format!(
            "it is a checkpoint of an older fluid (format version {}), which this one \
             does not read: run again from the input",
            older[7] as char
        ));
    }
    if magic != Some(&MAGIC[..]) {
        return Err("it is not a fluid checkpoint (format version 11)".into());
    }
    let (body, checksum) = bytes.split_at(bytes.len().saturating_sub(4).max(MAGIC.len()));
    if checksum.len() != 4 || crc32fast::hash(body).to_le_bytes() != checksum {
        return Err("it is corrupted (its checksum does not match)".into());
    }
    let mut reader = Reader {
        bytes: body,
        at: MAGIC.len(),
    };
    let step = reader.u64()?;
    let input = reader.u32()?;
    let case = match reader.take(1)? {
        [0] => None,
        [1] => {
            let length = usize::try_from(reader.u64()?).map_err(|_| "its case is too long")?;
            let text = std::str::from_utf8(reader.take(length)?)
                .map_err(|_| "its case is not UTF-8 text")?;
            Some(text.to_string())
        }
        _ => return Err("bad case flag".into()),
    };
    let readings = readings(&mut reader)?;
    let ppm = reader.f64()?;
    let time = reader.f64()?;
    let mut vector = || Ok::<_, String>(DVec3::new(reader.f64()?, reader.f64()?, reader.f64()?));
    let (min, max, gravity) = (vector()?, vector()?, vector()?);
    let shape = match reader.take(1)? {
        &[bits] if bits < 16 => bits,
        _ => return Err("bad shape flags".into()),
    };
    let domain = Domain {
        min,
        max,
        gravity,
        planar: shape & 1 != 0,
        periodic: [1, 2, 3].map(|bit| shape & (1 << bit) != 0),
    };
    let corners = [domain.min, domain.max, domain.gravity];
    if !corners.iter().all(|v| v.is_finite()) || !domain.min.cmplt(domain.max).all() {
        return Err("its box or gravity is not a box's or gravity's".into());
    }
    let [model, kernel, rule, limit, integrator, structure] = [(); 6].map(|()| reader.name());
    let structure = structure?;
    let structure = *PairStructure::ALL
        .iter()
        .find(|s| s.name() == structure)
        .ok_or("unknown pair structure")?;
    let integrator = integrator?;
    let integrator = *Integrator::ALL
        .iter()
        .find(|i| i.name() == integrator)
        .ok_or("unknown integrator")?;
    let model = model?;
    let model = *Model::ALL
        .iter()
        .find(|m| m.name() == model)
        .ok_or("unknown model")?;
    let kernel = kernel?;
    let kernel = *Kernel::ALL
        .iter()
        .find(|k| k.name() == kernel)
        .ok_or("unknown kernel")?;
    let value = reader.f64()?;
    let time_step = match rule?.as_str() {
        "fixed" => TimeStep::Fixed(value),
        "adaptive" => TimeStep::Adaptive { courant: value },
        _ => return Err("unknown time-step rule".into()),
    };
    let last_dt = reader.f64()?;
    let kept = reader.u64()?;
    let model_state = (0..kept)
        .map(|_| reader.f64())
        .collect::<Result<Vec<f64>, String>>()?;
    if ppm.is_finite() && ppm > 0.0 {
        model.dynamics().restore(&model.params(ppm), &model_state)?;
    }
    let last_step = match limit?.as_str() {
        "none" => None,
        name => Some((
            last_dt,
            *Limit::ALL
                .iter()
                .find(|limit| limit.name() == name)
                .ok_or("unknown step limit")?,
        )),
    };
    let sparse = match reader.take(1)? {
        [0] => false,
        [1] => true,
        _ => return Err("bad sparse flag".into()),
    };
    let flag = |reader: &mut Reader, what: &str| match reader.take(1)? {
        [0] => Ok(false),
        [1] => Ok(true),
        _ => Err(format!("bad {what} flag")),
    };
    let skin = if flag(&mut reader, "skin")? {
        let (width, builds) = (reader.f64()?, reader.u64()?);
        let sorted_sparse = flag(&mut reader, "sort")?;
        let built = flag(&mut reader, "build")?;
        if !(width.is_finite() && width > 0.0) || (built && builds == 0) {
            return Err("its skin's width or builds are not a skin's".into());
        }
        Some((width, builds, sorted_sparse, built))
    } else {
        None
    };
    let built = skin.is_some_and(|(.., built)| built);
    let n = usize::try_from(reader.u64()?).map_err(|_| "too many particles")?;
    n.checked_mul(4 + 13 * 8 + if built { 3 * 8 } else { 0 })
        .filter(|&body| body == reader.bytes.len() - reader.at)
        .ok_or("its size does not match its particle count")?;
    if n == 0 || n > u32::MAX as usize {
        return Err("its particle count is not in 1..2^32".into());
    }
    let mut particles = Particles::zeroed(n);
    let mut seen = vec![false; n];
    for slot in 0..n {
        let id = reader.u32()?;
        match seen.get_mut(id as usize) {
            Some(seen) if !*seen => *seen = true,
            _ => {
                return Err(format!(
                    "slot {slot} has a repeated or out-of-range id {id}"
                ))
            }
        }
        particles.id[slot] = id;
    }
    let arrays = [
        &mut particles.p,
        &mut particles.hv,
        &mut particles.v,
        &mut particles.a,
    ]
    .into_iter()
    .flatten()
    .chain([&mut particles.rho]);
    for array in arrays {
        for value in array.iter_mut() {
            *value = reader.f64()?;
        }
    }
    let skin = match skin {
        Some((width, builds, sorted_sparse, built)) => {
            let mut positions = AxisArrays::default();
            if built {
                for axis in &mut positions {
                    *axis = (0..n).map(|_| reader.f64()).collect::<Result<_, _>>()?;
                }
            }
            let finite = positions.iter().flatten().all(|x| x.is_finite());
            if !finite {
                return Err("it holds values that are not finite".into());
            }
            Some(KeptSkin {
                width,
                builds,
                sorted_sparse,
                built: positions,
            })
        }
        None => None,
    };
    let finite = fields(&particles).flatten().all(|x| x.is_finite());
    if !(finite && ppm.is_finite() && time.is_finite() && value.is_finite()) {
        return Err("it holds values that are not finite".into());
    }
    let last_is_a_step = last_step.is_none_or(|(dt, _)| dt.is_finite() && dt > 0.0);
    if !(ppm > 0.0 && time >= 0.0 && value > 0.0 && last_is_a_step) {
        return Err("its particles per metre, time or steps are not positive".into());
    }
    Ok(Checkpoint {
        step,
        input,
        case,
        readings,
        state: Resumable {
            ppm,
            domain,
            method: Method { model, kernel },
            time_step,
            integrator,
            structure,
            time,
            last_step,
            sparse,
            model_state,
            particles,
            skin,
        },
    })
}

/// The gauge readings at `reader`: finite times and values, or the canonical NaN for a
/// value not read (so that they encode to the bytes they came from).
fn readings(reader: &mut Reader) -> Result<Vec<Reading>, String> {
    let (rows, columns) = (reader.u64()?, reader.u64()?);
    if rows == 0 && columns != 0 {
        return Err("its gauge readings have columns but no rows".into());
    }
    let columns = usize::try_from(columns).map_err(|_| "too many gauge columns")?;
    let bad = || "its gauge readings hold values that are not finite".to_string();
    let row = |reader: &mut Reader| {
        let time = Some(reader.f64()?)
            .filter(|t| t.is_finite())
            .ok_or_else(bad)?;
        let values = (0..columns).map(|_| match reader.f64()? {
            value if value.is_finite() => Ok(Some(value)),
            value if value.to_bits() == f64::NAN.to_bits() => Ok(None),
            _ => Err(bad()),
        });
        Ok::<_, String>((time, values.collect::<Result<Vec<_>, _>>()?))
    };
    (0..rows).map(|_| row(reader)).collect()
}

/// Reads a checkpoint's bytes in order.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, count: usize) -> Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(count)
            .filter(|&e| e <= self.bytes.len());
        let end = end.ok_or("it is cut short")?;
        let taken = &self.bytes[self.at..end];
        self.at = end;
        Ok(taken)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        Ok(self.take(N)?.try_into().expect("N bytes taken"))
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    fn name(&mut self) -> Result<String, String> {
        let length = self.take(1)?[0] as usize;
        let name = self.take(length)?;
        String::from_utf8(name.to_vec()).map_err(|_| "a name is not text".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::simulation::Simulation;

    fn checkpoint() -> Checkpoint {
        let mut particles = Particles::zeroed(3);
        for slot in 0..3 {
            particles.p[0][slot] = -0.06 + 0.01 * slot as f64;
            particles.v[1][slot] = 0.5 * slot as f64;
        }
        let mut simulation = Simulation::new(204.0, particles).unwrap();
        simulation.set_time_step(TimeStep::Adaptive { courant: 0.3 });
        simulation.run(2);
        Checkpoint {
            step: 2,
            input: 0xdead_beef,
            case: None,
            readings: Vec::new(),
            state: simulation.resumable(),
        }
    }

    #[test]
    fn round_trips_every_field() {
        let checkpoint = checkpoint();
        assert!(checkpoint.state.last_step.is_some());
        assert_eq!(decode(&encode(&checkpoint)).unwrap(), checkpoint);
        let mut fresh = checkpoint.clone();
        fresh.state.last_step = None;
        fresh.state.time_step = TimeStep::Fixed(1e-3);
        assert_eq!(decode(&encode(&fresh)).unwrap(), fresh);
        // With the case it started from, its text whole (empty, or not ASCII).
        for text in ["", "[fluid]\nparticles_per_m = 100 # é\n"] {
            let mut cased = checkpoint.clone();
            cased.case = Some(text.to_string());
            let bytes = encode(&cased);
            assert_eq!(decode(&bytes).unwrap(), cased);
            assert!(bytes.len() as u64 <= size_bound(3, text.len(), 0));
        }
        // With gauge readings, some not read; values beyond finite are refused.
        let mut gauged = checkpoint.clone();
        gauged.readings = vec![(0.0, vec![Some(1.5), None]), (0.01, vec![None, Some(-2.0)])];
        let bytes = encode(&gauged);
        assert_eq!(decode(&bytes).unwrap(), gauged);
        assert!(bytes.len() as u64 <= size_bound(3, 0, 6));
        for bad in [f64::INFINITY, -f64::NAN] {
            let mut unreadable = gauged.clone();
            unreadable.readings[1].1[1] = Some(bad);
            assert_eq!(
                decode(&encode(&unreadable)).unwrap_err(),
                "its gauge readings hold values that are not finite"
            );
        }
    }

    /// A checkpoint of a run keeping its lists with a skin, built or not yet.
    fn skinned(built: bool) -> Checkpoint {
        let mut checkpoint = checkpoint();
        let mut particles = checkpoint.state.particles.clone();
        particles.p[0][1] = -0.041;
        let mut simulation = Simulation::new(204.0, particles).unwrap();
        simulation.set_skin(Some(0.001)).unwrap();
        if built {
            simulation.run(1);
        }
        checkpoint.state = simulation.resumable();
        checkpoint
    }

    #[test]
    fn a_skin_round_trips_and_its_defects_are_errors() {
        for built in [false, true] {
            let checkpoint = skinned(built);
            let skin = checkpoint.state.skin.as_ref().unwrap();
            assert_eq!(skin.builds, u64::from(built));
            assert_eq!(skin.built[0].len(), if built { 3 } else { 0 });
            let bytes = encode(&checkpoint);
            assert_eq!(decode(&bytes).unwrap(), checkpoint);
            assert!(bytes.len() as u64 <= size_bound(3, 0, 0));
            for length in 0..bytes.len() {
                assert!(decode(&bytes[..length]).is_err(), "{length} bytes");
            }
        }
        let mut wider = skinned(true);
        wider.state.skin.as_mut().unwrap().width = 0.0;
        assert_eq!(
            decode(&encode(&wider)).unwrap_err(),
            "its skin's width or builds are not a skin's"
        );
        let mut unbuilt = skinned(true);
        unbuilt.state.skin.as_mut().unwrap().builds = 0;
        assert_eq!(
            decode(&encode(&unbuilt)).unwrap_err(),
            "its skin's width or builds are not a skin's"
        );
        // A flag of 2, resealed: the skin's (after the sparse flag), then its sort's.
        let bytes = encode(&skinned(true));
        let skin_flag = bytes.len() - 4 - 3 * (4 + 13 * 8 + 3 * 8) - 8 - (1 + 8 + 8 + 1 + 1);
        assert_eq!(bytes[skin_flag], 1);
        for (at, message) in [
            (skin_flag, "bad skin flag"),
            (skin_flag + 17, "bad sort flag"),
        ] {
            let mut bad = bytes.clone();
            bad[at] = 2;
            let body = bad.len() - 4;
            let checksum = crc32fast::hash(&bad[..body]);
            bad[body..].copy_from_slice(&checksum.to_le_bytes());
            assert_eq!(decode(&bad).unwrap_err(), message);
        }
        let mut not_finite = skinned(true);
        not_finite.state.skin.as_mut().unwrap().built[2][1] = f64::NAN;
        assert_eq!(
            decode(&encode(&not_finite)).unwrap_err(),
            "it holds values that are not finite"
        );
    }

    #[test]
    fn every_truncation_and_corruption_is_an_error() {
        let bytes = encode(&checkpoint());
        for length in 0..bytes.len() {
            assert!(decode(&bytes[..length]).is_err(), "{length} bytes");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
        let mut wrong_magic = bytes.clone();
        wrong_magic[6] = b'X';
        assert_eq!(
            decode(&wrong_magic).unwrap_err(),
            "it is not a fluid checkpoint (format version 11)"
        );
        let mut older = bytes.clone();
        older[7] = b'3';
        assert_eq!(
            decode(&older).unwrap_err(),
            "it is a checkpoint of an older fluid (format version 3), which this one does \
             not read: run again from the input"
        );
        for at in (8..bytes.len()).step_by(7) {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            assert_eq!(
                decode(&flipped).unwrap_err(),
                "it is corrupted (its checksum does not match)",
                "byte {at}"
            );
        }
        // Defects under a valid checksum (a checkpoint written by another program).
        let resealed = |mut body: Vec<u8>| {
            body.truncate(body.len() - 4);
            let checksum = crc32fast::hash(&body);
            body.extend_from_slice(&checksum.to_le_bytes());
            body
        };
        let ids = bytes.len() - 4 - 3 * (4 + 13 * 8);
        let mut repeated = bytes.clone();
        repeated[ids + 4..ids + 8].copy_from_slice(&bytes[ids..ids + 4]);
        assert!(decode(&resealed(repeated))
            .unwrap_err()
            .contains("repeated or out-of-range id"));
        let mut not_finite = bytes.clone();
        let last = not_finite.len() - 12;
        not_finite[last..last + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(
            decode(&resealed(not_finite)).unwrap_err(),
            "it holds values that are not finite"
        );
    }
}
