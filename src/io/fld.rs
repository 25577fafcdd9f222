//! The `.fld` file format (SPEC.md section 2): reading a memory-mapped input and validating
//! it (sections 1 and 8) in the contract's order, placing its particles for simulation
//! ([`Scene::into_simulation`]), and writing an output atomically (temporary file +
//! rename). Every failure is a [`FileError`] with the contract's message.

use crate::io::gformat::format_g_exact;
use crate::io::input::open_regular;
use crate::sim::grid::{Grid, GridSizeError};
use crate::sim::method::Method;
use crate::sim::model::Dynamics;
use crate::sim::params::{Domain, Params};
use crate::sim::particles::Particles;
use crate::sim::simulation::Simulation;
use memmap2::Mmap;
use std::ffi::{OsStr, OsString};
use std::fmt;
use std::io::Write;
use std::os::unix::ffi::OsStrExt;
use std::path::Path;

/// Header size: `ppm` f32 and `np` i32.
pub const HEADER_BYTES: usize = 8;
/// Size of one particle record: 9 f32.
pub const RECORD_BYTES: usize = 36;
/// The fields of a record, in file order.
pub const FIELD_NAMES: [&str; 9] = ["px", "py", "pz", "hvx", "hvy", "hvz", "vx", "vy", "vz"];

/// What is wrong with an input or an output file: SPEC.md rules 4 to 7 and section 8.
/// [`FileError::message`] gives the message after `Error: ` with file names as given
/// (`Display` the same, non-UTF-8 bytes replaced); the `fluid` door gives each its exit code.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FileError {
    /// Rule 4: the input file cannot be opened or mapped for reading.
    CannotOpenInput(OsString),
    /// Rule 5: the output file cannot be opened (created) for writing, or its size not
    /// reserved.
    CannotOpenOutput(OsString),
    /// Rule 6: the header's particle count is zero or negative.
    InvalidParticleCount(i32),
    /// Rule 7: the whole records in the body are not as many as the header says.
    ParticleCountMismatch {
        /// Count in the header.
        header: i32,
        /// Whole 36-byte records found after the header.
        found: u64,
    },
    /// Section 8: any other defect of the input file (short header, partial record,
    /// non-finite or out-of-range value, particles per metre that admit no grid).
    InvalidInput {
        /// The input file name as given.
        file: OsString,
        /// What is wrong, without a final period.
        reason: String,
    },
    /// The output could not be written after the simulation (e.g. the disk is full).
    CannotWriteOutput {
        /// The output file name as given.
        file: OsString,
        /// The operating system's reason.
        reason: String,
    },
    /// The final state holds a value the f32 `.fld` format cannot store (beyond
    /// +-3.4e38, or not finite): no output is written.
    Unrepresentable {
        /// The output file name as given.
        file: OsString,
        /// What does not fit: the particle, the field and its value.
        reason: String,
    },
}

impl FileError {
    /// The message after `Error: `, with the file name as given, byte for byte.
    pub fn message(&self) -> Vec<u8> {
        let (before, file, after) = match self {
            Self::CannotOpenInput(file) => ("Cannot open ", Some(file), " for reading".into()),
            Self::CannotOpenOutput(file) => ("Cannot open ", Some(file), " for writing".into()),
            Self::InvalidParticleCount(np) => {
                ("", None, format!("Invalid number of particles: {np}."))
            }
            Self::ParticleCountMismatch { header, found } => (
                "",
                None,
                format!("Number of particles mismatch. Header: {header}, Found: {found}."),
            ),
            Self::InvalidInput { file, reason } => {
                ("Invalid input file ", Some(file), format!(": {reason}."))
            }
            Self::CannotWriteOutput { file, reason } => {
                ("Cannot write ", Some(file), format!(": {reason}."))
            }
            Self::Unrepresentable { file, reason } => (
                "Cannot write ",
                Some(file),
                format!(": {reason}, beyond what the f32 .fld format stores."),
            ),
        };
        let file = file.map_or(&[][..], |file| file.as_bytes());
        [before.as_bytes(), file, after.as_bytes()].concat()
    }
}

impl FileError {
    /// The error for a command that names its files (the workbench's): the course's count
    /// messages (SPEC.md rules 6 and 7) name none, so `file`'s name goes before them; the
    /// others, which name it, are left as they are.
    pub fn naming(self, file: &std::path::Path) -> Box<dyn std::error::Error> {
        match self {
            Self::InvalidParticleCount(_) | Self::ParticleCountMismatch { .. } => {
                format!("{}: {self}", file.display()).into()
            }
            other => other.into(),
        }
    }
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&String::from_utf8_lossy(&self.message()))
    }
}

impl std::error::Error for FileError {}

/// The contents of a valid `.fld` file.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Particles per metre, as stored.
    pub ppm: f32,
    /// The particles in file (id) order; density and acceleration are zero.
    pub particles: Particles,
}

impl Scene {
    /// The simulation of these particles with `method`. Particles per metre that admit no
    /// grid make the input invalid (exit 251 for `fluid`); `file` names it in the message.
    pub fn into_simulation(
        self,
        method: Method,
        file: &(impl AsRef<OsStr> + ?Sized),
    ) -> Result<Simulation, FileError> {
        self.into_simulation_with(method, method.model.dynamics(), Domain::COURSE, file)
    }

    /// As [`Self::into_simulation`], with `dynamics`, the model `method` names with
    /// choices of its own ([`Simulation::with_dynamics`]), in `domain` (SPEC.md's box, or
    /// the workbench's with periodic axes).
    pub fn into_simulation_with(
        self,
        method: Method,
        dynamics: Box<dyn Dynamics>,
        domain: Domain,
        file: &(impl AsRef<OsStr> + ?Sized),
    ) -> Result<Simulation, FileError> {
        let ppm = self.ppm;
        Simulation::with_dynamics(ppm.into(), domain, self.particles, method, dynamics)
            .map_err(|e| invalid_ppm(ppm, file.as_ref(), e))
    }
}

/// The header of a valid `.fld` file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    /// Particles per metre, as stored.
    pub ppm: f32,
    /// Number of particles.
    pub particles: usize,
}

impl Header {
    /// The parameters and grid of these particles per metre, with the error of
    /// [`Scene::into_simulation`] if they admit no grid.
    pub fn grid(&self, file: &(impl AsRef<OsStr> + ?Sized)) -> Result<(Params, Grid), FileError> {
        let params = Params::new(self.ppm.into());
        let grid = Grid::new(params.h, &params.domain)
            .map_err(|e| invalid_ppm(self.ppm, file.as_ref(), e))?;
        Ok((params, grid))
    }
}

/// The error of particles per metre `ppm` in `file` that admit no grid.
fn invalid_ppm(ppm: f32, file: &OsStr, error: GridSizeError) -> FileError {
    invalid(
        file,
        format!("particles per meter {} gives {error}", format_g_exact(ppm)),
    )
}

/// Opens and memory-maps an input file (rule 4: any failure is "cannot open"). Only a
/// regular file is read; the open does not wait (for a FIFO without a writer).
pub fn map_input(path: &Path) -> Result<Mmap, FileError> {
    let cannot_open = || FileError::CannotOpenInput(path.as_os_str().to_owned());
    let file = open_regular(path).map_err(|_| cannot_open())?;
    // SAFETY: the map is read-only and dropped once parsed (or, for 0 steps, written); as with any memory map,
    // another process truncating the file meanwhile is outside what we can guard against.
    unsafe { Mmap::map(&file) }.map_err(|_| cannot_open())
}

/// Maps and parses the input file at `path`, named as given in messages (for callers that
/// need no other check between the two, unlike `fluid`'s contract).
pub fn read(path: &Path) -> Result<Scene, FileError> {
    parse(&map_input(path)?, path)
}

fn read_f32(bytes: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

/// Validates the bytes of an `.fld` file named `file` (for messages) without decoding
/// them. Checks, in order: header length, np > 0 (rule 6), whole records == np (rule 7),
/// no partial record, finite ppm > 0, finite fields (section 8).
pub fn validate(bytes: &[u8], file: &(impl AsRef<OsStr> + ?Sized)) -> Result<Header, FileError> {
    let file = file.as_ref();
    let header = check_header(bytes, file)?;
    for (id, record) in bytes[HEADER_BYTES..].chunks_exact(RECORD_BYTES).enumerate() {
        check_record(id, record, file)?;
    }
    Ok(header)
}

/// Validates (as [`validate`]) and decodes the bytes of an `.fld` file named `file`.
pub fn parse(bytes: &[u8], file: &(impl AsRef<OsStr> + ?Sized)) -> Result<Scene, FileError> {
    let file = file.as_ref();
    let header = check_header(bytes, file)?;
    let mut particles = Particles::zeroed(header.particles);
    for (id, record) in bytes[HEADER_BYTES..].chunks_exact(RECORD_BYTES).enumerate() {
        let values = check_record(id, record, file)?;
        for axis in 0..3 {
            particles.p[axis][id] = values[axis].into();
            particles.hv[axis][id] = values[3 + axis].into();
            particles.v[axis][id] = values[6 + axis].into();
        }
    }
    Ok(Scene {
        ppm: header.ppm,
        particles,
    })
}

/// The input-file error of `file` for `reason`.
fn invalid(file: &OsStr, reason: String) -> FileError {
    FileError::InvalidInput {
        file: file.to_owned(),
        reason,
    }
}

/// The header of the bytes of an `.fld` file named `file`, with [`validate`]'s checks
/// of all but the fields: the particle count a reader can act on before decoding them.
pub fn header(bytes: &[u8], file: &(impl AsRef<OsStr> + ?Sized)) -> Result<Header, FileError> {
    check_header(bytes, file.as_ref())
}

/// The header checks of [`validate`], all but the fields'.
fn check_header(bytes: &[u8], file: &OsStr) -> Result<Header, FileError> {
    if bytes.len() < HEADER_BYTES {
        let size = bytes.len();
        return Err(invalid(
            file,
            format!("it is {size} bytes long, shorter than the {HEADER_BYTES}-byte header"),
        ));
    }
    let ppm = read_f32(bytes, 0);
    let np = i32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    if np <= 0 {
        return Err(FileError::InvalidParticleCount(np));
    }
    let body = &bytes[HEADER_BYTES..];
    let found = body.len() / RECORD_BYTES;
    if found != np as usize {
        return Err(FileError::ParticleCountMismatch {
            header: np,
            found: found as u64,
        });
    }
    let extra = body.len() % RECORD_BYTES;
    if extra != 0 {
        return Err(invalid(
            file,
            format!(
                "{extra} stray bytes after the last of its {np} {RECORD_BYTES}-byte particle records"
            ),
        ));
    }
    if !(ppm.is_finite() && ppm > 0.0) {
        return Err(invalid(
            file,
            format!(
                "particles per meter is {}, not a finite number > 0",
                format_g_exact(ppm)
            ),
        ));
    }
    Ok(Header {
        ppm,
        particles: found,
    })
}

/// The nine values of particle `id`'s record, or the error of its first non-finite one.
#[inline(always)]
fn check_record(id: usize, record: &[u8], file: &OsStr) -> Result<[f32; 9], FileError> {
    let values: [f32; 9] = std::array::from_fn(|field| read_f32(record, 4 * field));
    if let Some(field) = values.iter().position(|value| !value.is_finite()) {
        let (name, value) = (FIELD_NAMES[field], values[field]);
        return Err(invalid(
            file,
            format!("particle {id} has a non-finite {name} ({value})"),
        ));
    }
    Ok(values)
}

/// The size in bytes of an `.fld` file of `particles` particles.
pub fn file_size(particles: usize) -> u64 {
    (HEADER_BYTES + particles * RECORD_BYTES) as u64
}

/// A value of a state that an `.fld` file cannot store: beyond the f32 range, or not
/// finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unstorable {
    /// The particle's id.
    pub id: u32,
    /// The field, as [`FIELD_NAMES`] names it.
    pub field: &'static str,
    /// The f64 value.
    pub value: f64,
}

impl Unstorable {
    /// The error of writing this state to the output named `file`.
    pub fn for_output(self, file: &OsStr) -> FileError {
        FileError::Unrepresentable {
            file: file.to_owned(),
            reason: self.to_string(),
        }
    }
}

impl fmt::Display for Unstorable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self { id, field, value } = self;
        write!(f, "particle {id} has {field} = {value:e}")
    }
}

/// Encodes particles (in any slot order) as an `.fld` file in memory: see [`write`].
pub fn encode(ppm: f32, particles: &Particles) -> Result<Vec<u8>, Unstorable> {
    check_storable(particles)?;
    let mut bytes = Vec::with_capacity(file_size(particles.len()) as usize);
    write(ppm, particles, &mut bytes).expect("a write to memory succeeds");
    Ok(bytes)
}

/// Fails with the first value (by id and field) that narrows to an infinity or is not
/// finite: such particles have no `.fld` file.
pub fn check_storable(particles: &Particles) -> Result<(), Unstorable> {
    first_unstorable(particles).map_or(Ok(()), Err)
}

/// Records [`write`] encodes at a time.
const RECORDS_PER_WRITE: usize = 4096;

/// Writes particles (in any slot order, ids 0..n each once, every value storable:
/// [`check_storable`]) as an `.fld` file to `out`: the header, then each particle's
/// record in id order, every value narrowed to f32 (round to nearest), a few thousand
/// records per write, so that no copy of the whole file is held.
pub fn write(
    ppm: f32,
    particles: &Particles,
    out: &mut (impl Write + ?Sized),
) -> std::io::Result<()> {
    let n = particles.len();
    let mut slot_of_id = vec![0u32; n];
    for (slot, &id) in particles.id[..n].iter().enumerate() {
        slot_of_id[id as usize] = slot as u32;
    }
    out.write_all(&ppm.to_le_bytes())?;
    out.write_all(&(n as i32).to_le_bytes())?;
    let mut records = Vec::with_capacity(RECORDS_PER_WRITE * RECORD_BYTES);
    for slots in slot_of_id.chunks(RECORDS_PER_WRITE) {
        records.clear();
        for &slot in slots {
            let fields = [&particles.p, &particles.hv, &particles.v]
                .into_iter()
                .flat_map(|arrays| arrays.iter().map(|axis| axis[slot as usize] as f32));
            for value in fields {
                records.extend_from_slice(&value.to_le_bytes());
            }
        }
        out.write_all(&records)?;
    }
    Ok(())
}

/// The first value of `particles` (by id, then field) that narrows to a non-finite f32.
fn first_unstorable(particles: &Particles) -> Option<Unstorable> {
    let fits = |value: f64| (value as f32).is_finite();
    let all_fit = [&particles.p, &particles.hv, &particles.v]
        .iter()
        .flat_map(|arrays| arrays.iter())
        .all(|axis| axis[..particles.len()].iter().all(|&value| fits(value)));
    if all_fit {
        return None;
    }
    (0..particles.len())
        .flat_map(|slot| {
            [&particles.p, &particles.hv, &particles.v]
                .into_iter()
                .flat_map(|arrays| arrays.iter())
                .zip(FIELD_NAMES)
                .map(move |(axis, field)| Unstorable {
                    id: particles.id[slot],
                    field,
                    value: axis[slot],
                })
        })
        .filter(|unstorable| !fits(unstorable.value))
        .min_by_key(|unstorable| unstorable.id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::GRAVITY;

    fn file_bytes(ppm: f32, np: i32, records: &[[f32; 9]]) -> Vec<u8> {
        let mut bytes = Vec::new();
        bytes.extend(ppm.to_le_bytes());
        bytes.extend(np.to_le_bytes());
        for value in records.iter().flatten() {
            bytes.extend(value.to_le_bytes());
        }
        bytes
    }

    fn record(seed: f32) -> [f32; 9] {
        std::array::from_fn(|i| seed + i as f32 * 0.125)
    }

    fn reason(result: Result<Scene, FileError>) -> String {
        match result {
            Err(FileError::InvalidInput { reason, .. }) => reason,
            other => panic!("expected InvalidInput, got {other:?}"),
        }
    }

    #[test]
    fn parses_header_and_records_in_file_order() {
        let bytes = file_bytes(204.0, 2, &[record(1.0), record(-2.0)]);
        let scene = parse(&bytes, "f").unwrap();
        assert_eq!(scene.ppm, 204.0);
        assert_eq!(scene.particles.id, vec![0, 1]);
        assert_eq!(scene.particles.p[0], vec![1.0, -2.0]);
        assert_eq!(scene.particles.hv[2], vec![1.625, -1.375]);
        assert_eq!(scene.particles.v[2], vec![2.0, -1.0]);
    }

    #[test]
    fn encode_round_trips_and_writes_in_id_order() {
        let bytes = file_bytes(292.0, 3, &[record(1.0), record(2.0), record(3.0)]);
        let scene = parse(&bytes, "f").unwrap();
        assert_eq!(encode(scene.ppm, &scene.particles).unwrap(), bytes);
        let mut shuffled = Particles::default();
        shuffled.gather_kinematics(&scene.particles, &[2, 0, 1], GRAVITY);
        assert_eq!(encode(scene.ppm, &shuffled).unwrap(), bytes);
    }

    #[test]
    fn a_file_of_several_writes_holds_every_record_at_its_id() {
        // More records than one write takes, shuffled: the file as its records in order.
        let n = 2 * RECORDS_PER_WRITE + 3;
        let records: Vec<[f32; 9]> = (0..n).map(|k| record(k as f32)).collect();
        let bytes = file_bytes(204.0, n as i32, &records);
        let scene = parse(&bytes, "f").unwrap();
        let order: Vec<u32> = (0..n as u32).map(|k| (k * 7919) % n as u32).collect();
        let mut shuffled = Particles::default();
        shuffled.gather_kinematics(&scene.particles, &order, GRAVITY);
        // Writes of a few bytes at a time land the same bytes.
        struct Trickle(Vec<u8>);
        impl Write for Trickle {
            fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
                let taken = bytes.len().min(5);
                self.0.extend_from_slice(&bytes[..taken]);
                Ok(taken)
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let mut out = Trickle(Vec::new());
        write(204.0, &shuffled, &mut out).unwrap();
        assert!(out.0 == bytes);
        assert!(encode(204.0, &shuffled).unwrap() == bytes);
    }

    #[test]
    fn validation_alone_gives_the_header_and_the_errors_of_parse() {
        let mut files = vec![
            file_bytes(204.0, 2, &[record(1.0), record(-2.0)]),
            file_bytes(204.0, 3, &[record(1.0), record(-2.0)]),
            file_bytes(f32::NAN, 1, &[record(1.0)]),
            file_bytes(204.0, 0, &[]),
            vec![1, 2, 3],
        ];
        let mut bad_field = record(1.0);
        bad_field[4] = f32::INFINITY;
        files.push(file_bytes(204.0, 2, &[record(1.0), bad_field]));
        let mut stray = file_bytes(204.0, 1, &[record(1.0)]);
        stray.push(0);
        files.push(stray);
        for bytes in files {
            let parsed = parse(&bytes, "f.fld").map(|scene| Header {
                ppm: scene.ppm,
                particles: scene.particles.len(),
            });
            assert_eq!(validate(&bytes, "f.fld"), parsed);
        }
        let header = validate(&file_bytes(204.0, 2, &[record(1.0), record(2.0)]), "f");
        assert_eq!(
            header,
            Ok(Header {
                ppm: 204.0,
                particles: 2
            })
        );
    }

    #[test]
    fn every_valid_file_is_its_own_encoding() {
        // fluid 0 writes a valid input's bytes as they are: that is its encoding, because
        // every finite f32 survives the trip through f64.
        let odd = [
            -0.0,
            f32::MIN_POSITIVE / 8.0,
            f32::MAX,
            -f32::MAX,
            1e-30,
            3.3,
        ];
        let mut records: Vec<[f32; 9]> = vec![record(1.0)];
        records.push(std::array::from_fn(|k| odd[k % odd.len()]));
        let mut files = vec![file_bytes(292.0, 2, &records)];
        for input in ["small", "large"] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("data/in/{input}.fld"));
            files.push(std::fs::read(path).unwrap());
        }
        for bytes in files {
            let scene = parse(&bytes, "f").unwrap();
            assert_eq!(encode(scene.ppm, &scene.particles).unwrap(), bytes);
        }
    }

    #[test]
    fn encode_rounds_to_nearest_f32() {
        let mut particles = Particles::zeroed(1);
        particles.p[0][0] = 0.1;
        let bytes = encode(1.0, &particles).unwrap();
        assert_eq!(read_f32(&bytes, 8), 0.1f32);
    }

    #[test]
    fn short_files_are_rejected() {
        assert!(reason(parse(&[], "f")).contains("0 bytes long"));
        assert!(
            reason(parse(&[0; 6], "f")).contains("6 bytes long, shorter than the 8-byte header")
        );
    }

    #[test]
    fn non_positive_particle_counts_are_rule_6() {
        assert_eq!(
            parse(&file_bytes(204.0, 0, &[]), "f"),
            Err(FileError::InvalidParticleCount(0))
        );
        assert_eq!(
            parse(&file_bytes(204.0, -3, &[record(0.0)]), "f"),
            Err(FileError::InvalidParticleCount(-3))
        );
    }

    #[test]
    fn record_count_mismatch_is_rule_7() {
        let bytes = file_bytes(204.0, 3, &[record(0.0), record(1.0)]);
        let expected = FileError::ParticleCountMismatch {
            header: 3,
            found: 2,
        };
        assert_eq!(parse(&bytes, "f"), Err(expected.clone()));
        // A partial record is not counted as found.
        let mut partial = bytes.clone();
        partial.extend([0u8; 35]);
        assert_eq!(parse(&partial, "f"), Err(expected));
    }

    #[test]
    fn stray_bytes_after_the_records_are_rejected() {
        let mut bytes = file_bytes(204.0, 1, &[record(0.0)]);
        bytes.extend([1, 2]);
        assert!(
            reason(parse(&bytes, "f")).contains("2 stray bytes after the last of its 1 36-byte")
        );
    }

    #[test]
    fn invalid_ppm_is_rejected() {
        for ppm in [0.0, -204.0, f32::NAN, f32::INFINITY] {
            let text = reason(parse(&file_bytes(ppm, 1, &[record(0.0)]), "f"));
            assert!(text.starts_with("particles per meter is "), "{text}");
        }
    }

    #[test]
    fn non_finite_fields_name_the_particle_and_field() {
        let mut records = [record(0.0), record(1.0)];
        records[1][7] = f32::NAN;
        let text = reason(parse(&file_bytes(204.0, 2, &records), "f"));
        assert_eq!(text, "particle 1 has a non-finite vy (NaN)");
        records[1][7] = 0.0;
        records[0][3] = f32::NEG_INFINITY;
        let text = reason(parse(&file_bytes(204.0, 2, &records), "f"));
        assert_eq!(text, "particle 0 has a non-finite hvx (-inf)");
    }

    #[test]
    fn a_scene_becomes_a_simulation_unless_its_ppm_admits_no_grid() {
        let bytes = file_bytes(204.0, 2, &[record(0.0), record(1.0)]);
        let simulation = parse(&bytes, "f").unwrap();
        let simulation = simulation.into_simulation(Method::default(), "f").unwrap();
        assert_eq!(simulation.particles().len(), 2);
        assert_eq!(simulation.params().ppm, 204.0);
        let dense = parse(&file_bytes(1e6, 1, &[record(0.0)]), "in.fld").unwrap();
        match dense.into_simulation(Method::default(), "in.fld") {
            Err(FileError::InvalidInput { file, reason }) => {
                assert_eq!(file, "in.fld");
                assert!(
                    reason.starts_with("particles per meter 1e+06 gives "),
                    "{reason}"
                );
            }
            other => panic!("expected InvalidInput, got {other:?}"),
        }
    }

    #[test]
    fn directories_and_missing_files_cannot_be_read() {
        let dir = tempfile::tempdir().unwrap();
        for path in [dir.path().to_path_buf(), dir.path().join("missing.fld")] {
            let err = map_input(&path).unwrap_err();
            assert_eq!(err, FileError::CannotOpenInput(path.into_os_string()));
        }
    }

    #[test]
    fn empty_files_map_to_no_bytes() {
        let file = tempfile::NamedTempFile::new().unwrap();
        assert!(map_input(file.path()).unwrap().is_empty());
    }
}
