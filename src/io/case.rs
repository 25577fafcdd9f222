//! Case files: a scene and how to run it, described in TOML (`docs/case-files.md` is the
//! reference of every key, its unit and its default). A case names its domain box and
//! gravity, the
//! fluid's fills (boxes and spheres on a lattice of so many particles per metre), the
//! model with every setting the command lines give, and how far to run and where to
//! write. Reading one checks it whole: unknown keys, wrong types and values out of range
//! are refused, each with the file, the line and the column of the value at fault.

use crate::io::gformat::format_shortest;
use crate::sim::params::{self, BOX_MAX, BOX_MIN, GRAVITY};
use crate::sim::timestep::is_time;
use clap::ValueEnum;
use glam::DVec3;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// A case file's scene and run, as read (values the file leaves out are `None` or
/// empty: their defaults are the command line's).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// The box the particles live in, and gravity.
    #[serde(default)]
    pub domain: Domain,
    /// Where the fluid is at the start.
    pub fluid: Fluid,
    /// The model and its settings.
    #[serde(default)]
    pub model: ModelSettings,
    /// How far to run.
    #[serde(default)]
    pub run: RunSettings,
    /// Where the outputs go.
    #[serde(default, skip_serializing_if = "OutputSettings::is_empty")]
    pub output: OutputSettings,
    /// What is measured where, and how often.
    #[serde(default, skip_serializing_if = "Gauges::is_empty")]
    pub gauges: Gauges,
}

/// The gauges: point gauges (pressure, velocity and density at a point) and height
/// gauges (the free surface along a vertical line), read every `interval_s`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Gauges {
    /// Simulated seconds between readings (the first at the start); required with gauges.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interval_s: Option<Spanned<f64>>,
    /// Point gauges.
    #[serde(default, rename = "point", skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<Spanned<PointGauge>>,
    /// Height gauges.
    #[serde(default, rename = "height", skip_serializing_if = "Vec::is_empty")]
    pub heights: Vec<Spanned<HeightGauge>>,
}

impl Gauges {
    /// Whether it has no gauge and no interval.
    pub fn is_empty(&self) -> bool {
        *self == Gauges::default()
    }
}

/// A point gauge.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointGauge {
    /// The prefix of its columns (letters, digits, `-` and `_`).
    pub name: String,
    /// The point (m).
    #[serde(deserialize_with = "exactly")]
    pub at_m: [f64; 3],
}

/// A height gauge: the vertical line through a point of the floor.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HeightGauge {
    /// The prefix of its column (letters, digits, `-` and `_`).
    pub name: String,
    /// The line's x and z (m).
    #[serde(deserialize_with = "exactly")]
    pub at_m: [f64; 2],
}

/// The domain: the box whose walls hold the particles, and the gravity on them.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// 2 for a scene in the x-y plane (its points as [x, y], its height gauges' lines as
    /// [x]), or 3, the default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dimensions: Option<Spanned<u64>>,
    /// The axes whose two faces are periodic ("x", "y", "z"): none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periodic: Option<Spanned<Vec<String>>>,
    /// The box's low corner (m), SPEC.md's by default.
    #[serde(default = "course_min", deserialize_with = "exactly_spanned")]
    pub box_min_m: Spanned<[f64; 3]>,
    /// The box's high corner (m), SPEC.md's by default.
    #[serde(default = "course_max", deserialize_with = "exactly_spanned")]
    pub box_max_m: Spanned<[f64; 3]>,
    /// Gravity (m/s^2), SPEC.md's by default.
    #[serde(
        default = "course_gravity",
        deserialize_with = "exactly_spanned",
        skip_serializing_if = "is_course_gravity"
    )]
    pub gravity_m_s2: Spanned<[f64; 3]>,
}

/// The strongest gravity a case may give (m/s^2): about 100 g.
const MAX_GRAVITY: f64 = 1e3;

/// SPEC.md's low corner, where a case gives none.
fn course_min() -> Spanned<[f64; 3]> {
    Spanned::new(0..0, BOX_MIN.to_array())
}

/// SPEC.md's high corner, where a case gives none.
fn course_max() -> Spanned<[f64; 3]> {
    Spanned::new(0..0, BOX_MAX.to_array())
}

/// SPEC.md's gravity, where a case gives none.
fn course_gravity() -> Spanned<[f64; 3]> {
    Spanned::new(0..0, GRAVITY.to_array())
}

/// Whether `gravity` is SPEC.md's (a case written need not say so).
fn is_course_gravity(gravity: &Spanned<[f64; 3]>) -> bool {
    *gravity.get_ref() == GRAVITY.to_array()
}

impl Default for Domain {
    fn default() -> Domain {
        Domain {
            dimensions: None,
            periodic: None,
            box_min_m: course_min(),
            box_max_m: course_max(),
            gravity_m_s2: course_gravity(),
        }
    }
}

impl Domain {
    /// The box and gravity the simulation runs in.
    pub fn simulated(&self) -> params::Domain {
        let vector = |value: &Spanned<[f64; 3]>| DVec3::from_array(*value.get_ref());
        params::Domain {
            min: vector(&self.box_min_m),
            max: vector(&self.box_max_m),
            gravity: vector(&self.gravity_m_s2),
            planar: self.is_planar(),
            periodic: self.periodic_axes(),
        }
    }

    /// Which axes are periodic ([`Self::periodic`]; names other than x, y and z are
    /// refused by the checks).
    pub fn periodic_axes(&self) -> [bool; 3] {
        let named = |axis: &str| {
            self.periodic
                .as_ref()
                .is_some_and(|axes| axes.get_ref().iter().any(|name| name == axis))
        };
        ["x", "y", "z"].map(named)
    }

    /// Whether the scene is two-dimensional (`dimensions = 2`).
    pub fn is_planar(&self) -> bool {
        self.dimensions.as_ref().is_some_and(|d| *d.get_ref() == 2)
    }
}

/// The fluid at the start: lattice points at `particles_per_m` inside any of the fills.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    /// Particles per metre: the lattice spacing is its inverse, and the particle mass gives
    /// the rest density at it.
    pub particles_per_m: Spanned<f64>,
    /// The seed of the lattice's jitter.
    #[serde(default)]
    pub seed: u64,
    /// Boxes of fluid.
    #[serde(default, rename = "box", skip_serializing_if = "Vec::is_empty")]
    pub boxes: Vec<Spanned<BoxFill>>,
    /// Spheres of fluid.
    #[serde(default, rename = "sphere", skip_serializing_if = "Vec::is_empty")]
    pub spheres: Vec<Spanned<SphereFill>>,
}

/// A box of fluid: the lattice points p with min <= p < max on every axis.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoxFill {
    /// The low corner (m).
    #[serde(deserialize_with = "exactly")]
    pub min_m: [f64; 3],
    /// The high corner (m).
    #[serde(deserialize_with = "exactly")]
    pub max_m: [f64; 3],
}

/// A sphere of fluid: the lattice points closer than the radius to the centre.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SphereFill {
    /// The centre (m).
    #[serde(deserialize_with = "exactly")]
    pub centre_m: [f64; 3],
    /// The radius (m).
    pub radius_m: f64,
}

/// The model and every setting the command lines give; each left out takes the command
/// line's default.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSettings {
    /// The model's name, as `--model` takes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<Spanned<String>>,
    /// The pair-loop implementation, as `--kernel` takes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel: Option<Spanned<String>>,
    /// A fixed time step (s), as `--dt`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_step_s: Option<Spanned<f64>>,
    /// An adaptive time step's Courant number, as `--adaptive`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive_courant: Option<Spanned<f64>>,
    /// The integrator, as `--integrator` takes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator: Option<Spanned<String>>,
    /// The skin of kept neighbour lists, in cut-offs, as `--skin`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub skin_cutoffs: Option<Spanned<f64>>,
    /// The neighbour structure, as `--pairs` takes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pairs: Option<Spanned<String>>,
    /// The weakly compressible model's walls, as `--walls` takes them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub walls: Option<Spanned<String>>,
    /// Faces whose friction is not `walls`', by name (x_low, ..., z_high), as `--face`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub faces: Option<Spanned<std::collections::BTreeMap<String, Spanned<String>>>>,
    /// Monaghan's artificial viscosity alpha, as `--artificial-viscosity`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub artificial_viscosity: Option<Spanned<f64>>,
    /// The laminar term's kinematic viscosity (m^2/s), as `--laminar-viscosity`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub laminar_viscosity_m2_s: Option<Spanned<f64>>,
    /// The smoothing length in lattice spacings, as `--smoothing`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub smoothing_spacings: Option<Spanned<f64>>,
    /// The sound speed over sqrt(2 g H), as `--sound-speed`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sound_speed_factor: Option<Spanned<f64>>,
    /// The delta-SPH density diffusion coefficient, as `--density-diffusion`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_diffusion: Option<Spanned<f64>>,
}

/// How far to run: a number of steps or a physical time (not both).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSettings {
    /// Time steps to run, as `--steps`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steps: Option<Spanned<u64>>,
    /// The physical time to run to (s), as `--until`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub until_s: Option<Spanned<f64>>,
}

/// Where the outputs go.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSettings {
    /// The final state's `.fld` file (relative to the current folder), if it is written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub final_state: Option<Spanned<String>>,
    /// The folder of the gauges' CSV and charts (relative to the current folder).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub folder: Option<Spanned<String>>,
    /// Simulated seconds between the frames `export` and `render` write, as
    /// `--frame-every`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_interval_s: Option<Spanned<f64>>,
}

impl OutputSettings {
    /// Whether it names no output.
    fn is_empty(&self) -> bool {
        *self == OutputSettings::default()
    }
}

/// Exactly `N` numbers (serde's arrays would take the first `N` of a longer list).
fn exactly<'de, D: Deserializer<'de>, const N: usize>(
    deserializer: D,
) -> Result<[f64; N], D::Error> {
    let numbers = Vec::<f64>::deserialize(deserializer)?;
    let count = numbers.len();
    numbers
        .try_into()
        .map_err(|_| D::Error::invalid_length(count, &format!("a list of {N} numbers").as_str()))
}

/// The same, with where they are.
fn exactly_spanned<'de, D: Deserializer<'de>, const N: usize>(
    deserializer: D,
) -> Result<Spanned<[f64; N]>, D::Error> {
    let numbers = Spanned::<Vec<f64>>::deserialize(deserializer)?;
    let span = numbers.span();
    let count = numbers.get_ref().len();
    let array = numbers
        .into_inner()
        .try_into()
        .map_err(|_| D::Error::invalid_length(count, &format!("a list of {N} numbers").as_str()))?;
    Ok(Spanned::new(span, array))
}

/// What is wrong with a case file, and where: one line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaseError {
    /// The file as given.
    pub file: String,
    /// The line and column of the fault (1-based), where the file has one.
    pub at: Option<(usize, usize)>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for CaseError {
    /// One line: control characters escaped, a message of more than [`LONGEST`]
    /// characters (a long name echoed) cut short.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut message: String = self
            .message
            .chars()
            .flat_map(|c| match c.is_control() {
                true => c.escape_default().collect::<Vec<char>>(),
                false => vec![c],
            })
            .collect();
        if let Some((cut, _)) = message.char_indices().nth(LONGEST) {
            message.truncate(cut);
            message.push_str("...");
        }
        match self.at {
            Some((line, column)) => write!(f, "{}:{line}:{column}: {message}", self.file),
            None => write!(f, "{}: {message}", self.file),
        }
    }
}

/// The most characters of a message a [`CaseError`] shows.
const LONGEST: usize = 300;

/// A number as a message shows it: plain, or in exponent form beyond 1e6 or below 1e-4.
fn shown(x: f64) -> String {
    match x != 0.0 && x.is_finite() && !(1e-4..1e6).contains(&x.abs()) {
        true => format!("{x:e}"),
        false => format!("{x}"),
    }
}

impl CaseError {
    /// The error `message` at byte span `span` of `text`, the contents of `file`.
    pub fn at_span(text: &str, file: &str, span: Range<usize>, message: String) -> CaseError {
        CaseError {
            file: file.to_string(),
            at: Some(line_and_column(text, span.start)),
            message,
        }
    }

    /// The error of `bytes`, the contents of `file`, that are not UTF-8: at the first
    /// byte that is not.
    pub fn not_utf8(bytes: &[u8], file: &str, error: std::str::Utf8Error) -> CaseError {
        let valid = std::str::from_utf8(&bytes[..error.valid_up_to()]).unwrap_or_default();
        CaseError::at_span(
            valid,
            file,
            valid.len()..valid.len(),
            "not UTF-8 text".into(),
        )
    }
}

impl std::error::Error for CaseError {}

/// The most particles a case's fills may hold: what the `.fld` format and the memory of a
/// workstation allow (1.8 GB of state at this count).
pub const MAX_PARTICLES: f64 = 50_000_000.0;

/// Reads a case from `text`, the contents of `file`, and checks it whole.
pub fn parse(text: &str, file: &str) -> Result<Case, CaseError> {
    let error_at = |span: Option<Range<usize>>, message: String| match span {
        Some(span) => CaseError::at_span(text, file, span, message),
        None => CaseError {
            file: file.to_string(),
            at: None,
            message,
        },
    };
    // The document is parsed once; text that is not TOML is left to the reader, whose
    // message says why.
    let document = toml::de::DeTable::parse(text).ok();
    let zs = match &document {
        Some(document) => {
            if let Some((span, message)) = misshapen(document) {
                return Err(error_at(Some(span), message));
            }
            planar_zs(document).map_err(|(span, message)| error_at(Some(span), message))?
        }
        None => Vec::new(),
    };
    let read = match document {
        Some(document) if !zs.is_empty() => {
            let mut document = document;
            in_the_plane(&mut document, &zs)
                .map_err(|(span, message)| error_at(Some(span), message))?;
            Case::deserialize(toml::de::Deserializer::from(document))
        }
        _ => toml::from_str(text),
    };
    let case: Case = read.map_err(|error| {
        // toml's message may run over lines (a snippet of the file): its first line.
        let message = error
            .message()
            .lines()
            .next()
            .unwrap_or("not a case")
            .trim();
        let mut message = in_case_words(message);
        // "duplicate key": which one (the text at the span: a key, or a table's name
        // after its opening bracket).
        if let Some(span) = error.span().filter(|_| message == "duplicate key") {
            let table = text
                .get(..span.start)
                .is_some_and(|before| before.ends_with('['));
            let name = text.get(span).unwrap_or("").trim();
            message = match (table, name.is_empty()) {
                (_, true) => message,
                (true, false) => format!("duplicate table [{name}]: each table once"),
                (false, false) => format!("duplicate key `{name}`: each key once in its table"),
            };
        }
        error_at(error.span(), message)
    })?;
    case.check()
        .map_err(|(span, message)| error_at(Some(span), message))?;
    Ok(case)
}

/// The z values the points of a 2-D case's `document` are completed with, as TOML
/// numbers: none for a case that is not 2-D (`[domain] dimensions = 2`; a number other than 2 or 3 is
/// refused), else the plane, z = 0, and the two
/// faces of the slab one lattice spacing deep around it (a spacing of 1 m where the
/// particles per metre are not a number > 0, which the checks then refuse).
fn planar_zs(document: &toml::Spanned<toml::de::DeTable>) -> Result<Vec<String>, Fault> {
    use toml::de::DeValue;
    // Any other number of dimensions is refused before the points are read.
    // (A value that is no whole number, 2.0 or "2", is refused here too, at its key.)
    let given = document.get_ref().get("domain").and_then(|domain| {
        let value = domain.get_ref().as_table()?.get("dimensions")?;
        let whole = value.get_ref().as_integer();
        Some((value.span(), whole.map(|n| n.as_str().parse::<u64>())))
    });
    match given {
        Some((_, Some(Ok(2)))) => {}
        Some((span, dimensions)) if !matches!(dimensions, Some(Ok(3))) => {
            return Err((span, "dimensions must be 2 or 3".into()));
        }
        _ => return Ok(Vec::new()),
    }
    let fluid = document
        .get_ref()
        .get("fluid")
        .and_then(|f| f.get_ref().as_table());
    let ppm = match fluid
        .and_then(|fluid| fluid.get("particles_per_m"))
        .map(|v| v.get_ref())
    {
        Some(DeValue::Integer(value)) => value.as_str().parse::<f64>().ok(),
        Some(DeValue::Float(value)) => value.as_str().parse::<f64>().ok(),
        _ => None,
    };
    let ppm = ppm.filter(|ppm| ppm.is_finite() && *ppm > 0.0);
    let half = 0.5 * (1.0 / ppm.unwrap_or(1.0));
    Ok([0.0, -half, half].map(|z| format!("{z:?}")).to_vec())
}

/// A 2-D case's points, each checked to have its 2 numbers (x, y; a height gauge's line
/// its 1, x), completed with their z from `zs` ([`planar_zs`]): 0 for a point or a vector,
/// the slab's faces for the corners of the box and of its fills. The case is then read
/// and checked as the 3-D case of the slab, whose particles all lie at z = 0.
fn in_the_plane<'i>(
    document: &mut toml::Spanned<toml::de::DeTable<'i>>,
    zs: &'i [String],
) -> Result<(), Fault> {
    use toml::de::DeValue;
    let [plane, low, high] = [0, 1, 2].map(|k| DeValue::parse(&zs[k]).expect("a number"));
    // Each vector's key, its table (or list of tables), and its z.
    let vectors = [
        ("domain", None, "box_min_m", &low, 2),
        ("domain", None, "box_max_m", &high, 2),
        ("domain", None, "gravity_m_s2", &plane, 2),
        ("fluid", Some("box"), "min_m", &low, 2),
        ("fluid", Some("box"), "max_m", &high, 2),
        ("fluid", Some("sphere"), "centre_m", &plane, 2),
        ("gauges", Some("point"), "at_m", &plane, 2),
        ("gauges", Some("height"), "at_m", &plane, 1),
    ];
    let root = document.get_mut();
    let dimensions = root
        .get("domain")
        .and_then(|domain| domain.get_ref().as_table()?.get("dimensions"))
        .map(|value| value.span())
        .unwrap_or_default();
    for corner in ["box_min_m", "box_max_m"] {
        let given = root
            .get("domain")
            .and_then(|domain| domain.get_ref().as_table()?.get(corner))
            .is_some();
        if !given {
            return Err((
                dimensions.clone(),
                format!("a 2-D case gives its box: {corner} = [x, y]"),
            ));
        }
    }
    for (table, list, key, z, count) in vectors {
        let Some(DeValue::Table(table)) = root.get_mut(table).map(|t| t.get_mut()) else {
            continue;
        };
        let mut items: Vec<&mut toml::de::DeTable<'i>> = match list {
            None => vec![table],
            Some(list) => match table.get_mut(list).map(|l| l.get_mut()) {
                Some(DeValue::Array(items)) => items
                    .iter_mut()
                    .filter_map(|item| match item.get_mut() {
                        DeValue::Table(table) => Some(table),
                        _ => None,
                    })
                    .collect(),
                _ => continue,
            },
        };
        for item in &mut items {
            let Some(value) = item.get_mut(key) else {
                continue;
            };
            let span = value.span();
            let DeValue::Array(numbers) = value.get_mut() else {
                continue;
            };
            if numbers.len() != count {
                let what = match count {
                    1 => "its 1 number, x (the vertical line through it)",
                    _ => "its 2 numbers, x and y",
                };
                let has = match numbers.len() {
                    1 => "1 number".to_string(),
                    n => format!("{n} numbers"),
                };
                return Err((
                    span,
                    format!("{key} has {has}, but in a 2-D case (dimensions = 2) it takes {what}"),
                ));
            }
            numbers.push(z.clone());
        }
    }
    Ok(())
}

/// The tables of a case (`[model]`), and the tables of its lists of tables
/// (`[[fluid.box]]`): the TOML reader would take a list for a table, its items as the
/// table's fields in order.
const TABLES: [&str; 6] = ["domain", "fluid", "model", "run", "output", "gauges"];
/// Its lists of tables, by their table's name.
const LISTS_OF_TABLES: [(&str, [&str; 2]); 2] = [
    ("fluid", ["box", "sphere"]),
    ("gauges", ["point", "height"]),
];

/// The first value of `document` of a kind no case takes where it stands: a date (no key
/// takes one; the TOML reader calls it a table), or a list where a case takes a table (or
/// a list of tables, a table in it). Its span and what was expected.
fn misshapen(document: &toml::Spanned<toml::de::DeTable>) -> Option<(Range<usize>, String)> {
    use toml::de::DeValue;
    // Depth first, in the file's order.
    fn first_date(value: &toml::Spanned<DeValue>) -> Option<Range<usize>> {
        match value.get_ref() {
            DeValue::Datetime(_) => Some(value.span()),
            DeValue::Array(items) => items.iter().find_map(first_date),
            DeValue::Table(table) => table.values().find_map(first_date),
            _ => None,
        }
    }
    if let Some(span) = document.get_ref().values().find_map(first_date) {
        let message = "a date and time, which no key of a case takes".to_string();
        return Some((span, message));
    }
    let not_a_table = |value: &toml::Spanned<DeValue>, name: String| {
        let kind = match value.get_ref() {
            DeValue::Array(items) if items.len() == 1 => "a list of 1 item".to_string(),
            DeValue::Array(items) => format!("a list of {} items", items.len()),
            _ => return None,
        };
        Some((value.span(), format!("{name} is {kind}, expected a table")))
    };
    for (key, value) in document.get_ref() {
        let name = key.get_ref().as_ref();
        if !TABLES.contains(&name) {
            continue;
        }
        if let Some(found) = not_a_table(value, format!("[{name}]")) {
            return Some(found);
        }
        let lists = LISTS_OF_TABLES.iter().find(|(table, _)| *table == name);
        let (Some(table), Some((_, lists))) = (value.get_ref().as_table(), lists) else {
            continue;
        };
        for (key, value) in table {
            let list = key.get_ref().as_ref();
            let items = value.get_ref().as_array().filter(|_| lists.contains(&list));
            for item in items.into_iter().flatten() {
                if let Some(found) = not_a_table(item, format!("an item of {name}.{list}")) {
                    return Some(found);
                }
            }
        }
    }
    None
}

/// A message of the TOML reader in a case's words: the kinds of value a case file holds
/// (a number, a whole number, text, a list, a table) for Rust's (`f64`, `u64`, a string,
/// a sequence, a map, a struct).
fn in_case_words(message: &str) -> String {
    let mut words = message.to_string();
    // "invalid length 4, expected ...": the list given.
    if let Some(rest) = words.strip_prefix("invalid length ") {
        if let Some((count, expected)) = rest.split_once(", ") {
            let items = if count == "1" { "item" } else { "items" };
            words = format!("a list of {count} {items}, {expected}");
        }
    }
    // "integer `99999999999999999999` as i128, expected u64": a whole number past the
    // largest the key takes.
    if let Some(rest) = words.strip_prefix("invalid type: integer `") {
        if let Some((number, expected)) = rest.split_once("` as i128, expected ") {
            let largest = match expected {
                "u32" => u32::MAX.to_string(),
                "i64" => i64::MAX.to_string(),
                _ => u64::MAX.to_string(),
            };
            return format!("the whole number {number} is too large: at most {largest}");
        }
    }
    // "expected struct PointGauge": a table.
    if let Some(at) = words.find("expected struct ") {
        let rest = &words[at + "expected struct ".len()..];
        let name_end = rest
            .find(|c: char| !c.is_alphanumeric())
            .unwrap_or(rest.len());
        words = format!("{}expected a table{}", &words[..at], &rest[name_end..]);
    }
    // "a table with 13 elements": a table.
    if let Some(at) = words.find("a table with ") {
        let rest = &words[at + "a table with ".len()..];
        if let Some(end) = rest.find(" elements") {
            words = format!(
                "{}a table{}",
                &words[..at],
                &rest[end + " elements".len()..]
            );
        }
    }
    // serde's fields are a case's keys, and its tables; TOML's bare words are quoted.
    if let Some(rest) = words.strip_prefix("missing field `") {
        let name = rest.trim_end_matches('`');
        return match TABLES.contains(&name) {
            true => format!("missing table [{name}]"),
            false => format!("missing key `{name}`"),
        };
    }
    if words.starts_with("invalid boolean") || words.starts_with("string values must be quoted") {
        return "text must be in quotes (\"...\"); true and false are the only bare words"
            .to_string();
    }
    words = words.replace("unknown field `", "unknown key `");
    const WORDS: [(&str, &str); 17] = [
        ("expected f64", "expected a number"),
        ("expected f32", "expected a number"),
        ("expected u64", "expected a whole number, 0 or more"),
        ("expected u32", "expected a whole number, 0 or more"),
        ("expected usize", "expected a whole number, 0 or more"),
        ("expected i64", "expected a whole number"),
        ("expected a string", "expected text in quotes"),
        ("expected a boolean", "expected true or false"),
        ("expected a sequence", "expected a list"),
        ("expected a map", "expected a table"),
        ("invalid type: map", "invalid type: a table"),
        ("invalid type: sequence", "invalid type: a list"),
        ("invalid type: string", "invalid type: text"),
        ("invalid type: integer", "invalid type: the whole number"),
        ("invalid type: floating point", "invalid type: the number"),
        ("invalid type: boolean", "invalid type:"),
        ("invalid value: integer", "invalid value:"),
    ];
    for (rust, case) in WORDS {
        words = words.replace(rust, case);
    }
    words
}

/// The line and column (1-based, in characters) of byte `offset` of `text`.
fn line_and_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..text.floor_char_boundary(offset.min(text.len()))];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rsplit('\n')
        .next()
        .map_or(0, |last| last.chars().count())
        + 1;
    (line, column)
}

/// A fault in a case: where (a span of its text) and what.
type Fault = (Range<usize>, String);

/// Whether `name` is one of `T`'s command-line names; the fault lists them if not.
pub fn choice<T: ValueEnum>(name: &Spanned<String>, key: &str) -> Result<T, Fault> {
    T::from_str(name.get_ref(), false).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|value| value.to_possible_value())
            .map(|value| value.get_name().to_string())
            .collect();
        (
            name.span(),
            format!(
                "{key} = \"{}\" is none of {}",
                name.get_ref(),
                names.join(", ")
            ),
        )
    })
}

impl Case {
    /// This case at `ppm` particles per metre: in 2-D its slab, the box's and the boxes
    /// of fluid's z, one lattice spacing deep at the new spacing.
    pub fn at_particles_per_m(&self, ppm: f64) -> Case {
        let mut case = self.clone();
        let span = case.fluid.particles_per_m.span();
        case.fluid.particles_per_m = Spanned::new(span, ppm);
        if case.domain.is_planar() {
            let half = 0.5 * (1.0 / ppm);
            let set = |corner: &mut [f64; 3], z: f64| corner[2] = z;
            set(case.domain.box_min_m.get_mut(), -half);
            set(case.domain.box_max_m.get_mut(), half);
            for fill in &mut case.fluid.boxes {
                let fill = fill.get_mut();
                set(&mut fill.min_m, -half);
                set(&mut fill.max_m, half);
            }
        }
        case
    }

    /// About the most particles the fills hold: their volumes (overlaps counted twice)
    /// times the particles per cubic metre.
    pub fn particles_at_most(&self) -> f64 {
        let fluid = &self.fluid;
        let boxes = fluid.boxes.iter().map(|fill| {
            let BoxFill { min_m, max_m } = fill.get_ref();
            (0..3)
                .map(|axis| max_m[axis] - min_m[axis])
                .product::<f64>()
        });
        // In 2-D, boxes one spacing deep and discs, their spheres' sections.
        let planar = self.domain.is_planar();
        let spheres = fluid.spheres.iter().map(|fill| {
            let r = fill.get_ref().radius_m;
            match planar {
                true => std::f64::consts::PI * r * r / fluid.particles_per_m.get_ref(),
                false => 4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
            }
        });
        boxes.chain(spheres).sum::<f64>() * fluid.particles_per_m.get_ref().powi(3)
    }

    /// The checks beyond types: sizes, ranges, fills inside the box, names.
    fn check(&self) -> Result<(), Fault> {
        // `dimensions` other than 2 or 3 are refused before the case is read (`planar_zs`).
        if let Some(periodic) = &self.domain.periodic {
            let names = periodic.get_ref();
            let known = names
                .iter()
                .all(|name| ["x", "y", "z"].contains(&name.as_str()));
            let once = (1..names.len()).all(|k| !names[k..].contains(&names[k - 1]));
            if !(known && once) {
                return Err((
                    periodic.span(),
                    "periodic lists axes, each once: \"x\" or \"z\" (\"y\" holds the floor)".into(),
                ));
            }
            if self.domain.is_planar() && names.iter().any(|name| name == "z") {
                return Err((
                    periodic.span(),
                    "a 2-D case has no z faces to make periodic".into(),
                ));
            }
        }
        let (low, high) = (&self.domain.box_min_m, &self.domain.box_max_m);
        // A corner left out has no place of its own: its fault is shown at the other.
        let at = |key: &Spanned<[f64; 3]>, other: &Spanned<[f64; 3]>| match key.span().is_empty() {
            true => other.span(),
            false => key.span(),
        };
        let finite = |corner: &[f64; 3]| corner.iter().all(|x| x.is_finite());
        if !finite(low.get_ref()) {
            return Err((at(low, high), "box_min_m must be finite".into()));
        }
        if !finite(high.get_ref()) {
            return Err((at(high, low), "box_max_m must be finite".into()));
        }
        if (0..3).any(|axis| low.get_ref()[axis] >= high.get_ref()[axis]) {
            return Err((
                at(high, low),
                "box_max_m must exceed box_min_m on every axis".into(),
            ));
        }
        let gravity = &self.domain.gravity_m_s2;
        if !finite(gravity.get_ref()) {
            return Err((gravity.span(), "gravity must be finite".into()));
        }
        // Its length scaled by its largest component, which stays finite where the squares
        // would not (1e308 m/s^2 is not "inf").
        let vector = DVec3::from_array(*gravity.get_ref());
        let largest = vector.abs().max_element();
        let pull = match largest > 0.0 {
            true => largest * (vector / largest).length(),
            false => 0.0,
        };
        if pull > MAX_GRAVITY {
            return Err((
                gravity.span(),
                format!(
                    "gravity must be at most {MAX_GRAVITY} m/s^2, not {}",
                    shown(pull)
                ),
            ));
        }
        let ppm = &self.fluid.particles_per_m;
        let spacing_ok = ppm.get_ref().is_finite()
            && *ppm.get_ref() > 0.0
            && (*ppm.get_ref() as f32).is_normal();
        if !spacing_ok {
            return Err((
                ppm.span(),
                format!(
                    "particles_per_m = {} is not a number > 0 that an f32 holds (the lattice \
                     spacing is its inverse)",
                    shown(*ppm.get_ref())
                ),
            ));
        }
        if self.fluid.boxes.is_empty() && self.fluid.spheres.is_empty() {
            return Err((
                ppm.span(),
                "the fluid has no [[fluid.box]] and no [[fluid.sphere]]".into(),
            ));
        }
        let inside = |point: [f64; 3]| {
            (0..3).all(|axis| {
                low.get_ref()[axis] <= point[axis] && point[axis] <= high.get_ref()[axis]
            })
        };
        for fill in &self.fluid.boxes {
            let BoxFill { min_m, max_m } = fill.get_ref();
            if !(finite(min_m) && finite(max_m)) {
                return Err((fill.span(), "a box's corners must be finite".into()));
            }
            if (0..3).any(|axis| min_m[axis] >= max_m[axis]) {
                return Err((
                    fill.span(),
                    "a box's max_m must exceed its min_m on every axis".into(),
                ));
            }
            if !(inside(*min_m) && inside(*max_m)) {
                return Err((
                    fill.span(),
                    "a box of fluid reaches outside the domain".into(),
                ));
            }
        }
        for fill in &self.fluid.spheres {
            let SphereFill { centre_m, radius_m } = fill.get_ref();
            if !(finite(centre_m) && radius_m.is_finite() && *radius_m > 0.0) {
                return Err((
                    fill.span(),
                    "a sphere needs a finite centre and a radius > 0".into(),
                ));
            }
            // A 2-D case's sphere is the disc of its section by the plane.
            let reach = |axis: usize| match axis == 2 && self.domain.is_planar() {
                true => 0.0,
                false => *radius_m,
            };
            let corner =
                |sign: f64| std::array::from_fn(|axis| centre_m[axis] + sign * reach(axis));
            if !(inside(corner(-1.0)) && inside(corner(1.0))) {
                return Err((
                    fill.span(),
                    "a sphere of fluid reaches outside the domain".into(),
                ));
            }
        }
        let most = self.particles_at_most();
        if most > MAX_PARTICLES {
            return Err((
                ppm.span(),
                format!(
                    "the fills would hold about {most:.3e} particles at {} per metre; the \
                     limit is {MAX_PARTICLES:.0e}",
                    shown(*ppm.get_ref())
                ),
            ));
        }
        // Positions are written as f32: the box must be near enough the origin for them
        // to keep the lattice (1/64 of a spacing, f32's relative precision times the
        // farthest corner's distance).
        let reach = |corner: &Spanned<[f64; 3]>| {
            corner
                .get_ref()
                .map(f64::abs)
                .into_iter()
                .fold(0.0, f64::max)
        };
        let (far, distance) = match reach(high) > reach(low) {
            true => (at(high, low), reach(high)),
            false => (at(low, high), reach(low)),
        };
        let precision = f64::from(f32::EPSILON) * distance;
        if precision > 1.0 / (64.0 * ppm.get_ref()) {
            return Err((
                far,
                format!(
                    "the box reaches {} m from the origin, where the files' f32 positions \
                     are {} m apart, more than 1/64 of the lattice spacing: move the box \
                     nearer the origin",
                    shown(distance),
                    shown(precision)
                ),
            ));
        }
        self.model.check()?;
        let run = &self.run;
        if let (Some(_), Some(until)) = (&run.steps, &run.until_s) {
            return Err((until.span(), "give steps or until_s, not both".into()));
        }
        if let Some(until) = &run.until_s {
            if !is_time(*until.get_ref()) {
                return Err((
                    until.span(),
                    "until_s must be a time > 0 (from 2.2e-308 s)".into(),
                ));
            }
        }
        if let Some(steps) = &run.steps {
            if *steps.get_ref() > i64::MAX as u64 {
                return Err((steps.span(), "steps must be at most 2^63-1".into()));
            }
        }
        if let Some(interval) = &self.output.frame_interval_s {
            if !is_time(*interval.get_ref()) {
                return Err((
                    interval.span(),
                    "frame_interval_s must be a time > 0 (from 2.2e-308 s)".into(),
                ));
            }
        }
        if let Some(path) = &self.output.final_state {
            let name = path.get_ref();
            if name.is_empty() || name.ends_with('/') || Path::new(name).file_name().is_none() {
                return Err((path.span(), "final_state must name a file".into()));
            }
        }
        let paths = [&self.output.final_state, &self.output.folder];
        for path in paths.into_iter().flatten() {
            if path.get_ref().chars().any(char::is_control) {
                return Err((
                    path.span(),
                    "a path must not hold control characters".into(),
                ));
            }
        }
        if let Some(folder) = &self.output.folder {
            if folder.get_ref().is_empty() {
                return Err((
                    folder.span(),
                    "folder must name a folder (\".\" for the current one)".into(),
                ));
            }
        }
        self.check_gauges(inside)
    }

    /// The gauges: an interval with them, names of their own, places inside the domain,
    /// a folder to write to.
    fn check_gauges(&self, inside: impl Fn([f64; 3]) -> bool) -> Result<(), Fault> {
        let gauges = &self.gauges;
        let points = gauges.points.iter().map(|g| (g.span(), &g.get_ref().name));
        let heights = gauges.heights.iter().map(|g| (g.span(), &g.get_ref().name));
        let named: Vec<_> = points.chain(heights).collect();
        let Some((first, _)) = named.first() else {
            return Ok(());
        };
        let Some(interval) = &gauges.interval_s else {
            return Err((first.clone(), "gauges need [gauges] interval_s".into()));
        };
        if !is_time(*interval.get_ref()) {
            return Err((
                interval.span(),
                "interval_s must be a time > 0 (from 2.2e-308 s)".into(),
            ));
        }
        if self.output.folder.is_none() {
            return Err((
                first.clone(),
                "gauges need [output] folder, where gauges.csv goes".into(),
            ));
        }
        for (index, (span, name)) in named.iter().enumerate() {
            let fits = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
            if name.is_empty() || !name.chars().all(fits) {
                return Err((
                    span.clone(),
                    format!("gauge name \"{name}\" must be letters, digits, - and _"),
                ));
            }
            if named[..index].iter().any(|(_, other)| other == name) {
                return Err((span.clone(), format!("two gauges are named \"{name}\"")));
            }
        }
        // Said at the gauge's table, naming its at_m as given and what is wrong with it.
        let dimensions = if self.domain.is_planar() { 2 } else { 3 };
        let outside = |kind: &str, at: &[f64]| {
            let shown: Vec<String> = at.iter().map(|x| format_shortest(*x)).collect();
            let why = match at.iter().all(|x| x.is_finite()) {
                true => "is outside the domain",
                false => "is not a point (its numbers must be finite)",
            };
            format!("a {kind} gauge's at_m = [{}] {why}", shown.join(", "))
        };
        for gauge in &gauges.points {
            let at = gauge.get_ref().at_m;
            if !inside(at) {
                let given = &at[..dimensions];
                return Err((gauge.span(), outside("point", given)));
            }
        }
        let low = self.domain.box_min_m.get_ref()[1];
        for gauge in &gauges.heights {
            let [x, z] = gauge.get_ref().at_m;
            if !inside([x, low, z]) {
                let given = &[x, z][..dimensions - 1];
                return Err((gauge.span(), outside("height", given)));
            }
        }
        Ok(())
    }
}

impl ModelSettings {
    /// The first of the weakly compressible model's settings the case gives, and where.
    pub fn first_water_setting(&self) -> Option<(&'static str, Range<usize>)> {
        let numbers = [
            ("artificial_viscosity", &self.artificial_viscosity),
            ("laminar_viscosity_m2_s", &self.laminar_viscosity_m2_s),
            ("smoothing_spacings", &self.smoothing_spacings),
            ("sound_speed_factor", &self.sound_speed_factor),
            ("density_diffusion", &self.density_diffusion),
        ];
        let given = numbers
            .into_iter()
            .filter_map(|(key, value)| value.as_ref().map(|value| (key, value.span())));
        let walls = self.walls.as_ref().map(|walls| ("walls", walls.span()));
        let faces = self.faces.as_ref().map(|faces| ("faces", faces.span()));
        let mut found: Vec<(&'static str, Range<usize>)> =
            given.chain(walls).chain(faces).collect();
        found.sort_by_key(|(_, span)| span.start);
        found.into_iter().next()
    }

    /// The weakly compressible model's settings: each in its range (whether the model
    /// run takes them is the command's to say, which knows its --model).
    fn check_water(&self) -> Result<(), Fault> {
        use crate::sim::model::wcsph::{SMOOTHINGS, SOUND_SPEED_FACTORS};
        use crate::sim::model::Model;
        // (The smoothing and the sound speed have ranges of their own, below: a NaN is
        // out of them.)
        let numbers = [
            ("artificial_viscosity", &self.artificial_viscosity),
            ("laminar_viscosity_m2_s", &self.laminar_viscosity_m2_s),
            ("density_diffusion", &self.density_diffusion),
        ];
        if let Some(name) = &self.name {
            choice::<Model>(name, "name")?;
        }
        for (key, value) in numbers {
            let Some(value) = value else { continue };
            let x = *value.get_ref();
            if !x.is_finite() || x < 0.0 {
                let message = format!("{key} must be a finite number, 0 or more");
                return Err((value.span(), message));
            }
        }
        let ranges = [
            ("smoothing_spacings", &self.smoothing_spacings, SMOOTHINGS),
            (
                "sound_speed_factor",
                &self.sound_speed_factor,
                SOUND_SPEED_FACTORS,
            ),
        ];
        for (key, value, range) in ranges {
            let Some(value) = value else { continue };
            if !range.contains(value.get_ref()) {
                return Err((
                    value.span(),
                    format!(
                        "{key} must be between {} and {}",
                        range.start(),
                        range.end()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The names and the numbers' ranges (the model's own checks come when it is made).
    fn check(&self) -> Result<(), Fault> {
        use crate::sim::kernel::Kernel;
        use crate::sim::lists::PairStructure;
        use crate::sim::model::wcsph::WallFriction;
        use crate::sim::model::Model;
        use crate::sim::timestep::Integrator;
        if let Some(name) = &self.name {
            choice::<Model>(name, "name")?;
        }
        if let Some(name) = &self.kernel {
            choice::<Kernel>(name, "kernel")?;
        }
        if let Some(name) = &self.integrator {
            choice::<Integrator>(name, "integrator")?;
        }
        if let Some(name) = &self.pairs {
            choice::<PairStructure>(name, "pairs")?;
        }
        if let Some(name) = &self.walls {
            choice::<WallFriction>(name, "walls")?;
        }
        for (face, kind) in self.faces.iter().flat_map(|faces| faces.get_ref()) {
            use crate::sim::model::wcsph::FACES;
            if !FACES.contains(&face.as_str()) {
                let faces = self.faces.as_ref().expect("a table");
                return Err((
                    faces.span(),
                    format!("{face:?} is not a face: {}", FACES.join(", ")),
                ));
            }
            choice::<WallFriction>(kind, face)?;
        }
        if let (Some(_), Some(courant)) = (&self.time_step_s, &self.adaptive_courant) {
            return Err((
                courant.span(),
                "give time_step_s or adaptive_courant, not both".into(),
            ));
        }
        if let Some(dt) = &self.time_step_s {
            if !is_time(*dt.get_ref()) {
                return Err((
                    dt.span(),
                    "time_step_s must be a time > 0 (from 2.2e-308 s)".into(),
                ));
            }
        }
        if let Some(courant) = &self.adaptive_courant {
            let c = *courant.get_ref();
            if !(c.is_finite() && c > 0.0 && c <= 1.0) {
                return Err((courant.span(), "adaptive_courant must be in (0, 1]".into()));
            }
        }
        if let Some(skin) = &self.skin_cutoffs {
            if !(skin.get_ref().is_finite() && *skin.get_ref() >= 0.0) {
                return Err((
                    skin.span(),
                    "skin_cutoffs must be a finite number, 0 or more".into(),
                ));
            }
        }
        self.check_water()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reader_s_messages_speak_of_what_a_case_holds() {
        let cases = [
            (
                "invalid type: string \"400\", expected f64",
                "invalid type: text \"400\", expected a number",
            ),
            (
                "invalid type: floating point `1.5`, expected u64",
                "invalid type: the number `1.5`, expected a whole number, 0 or more",
            ),
            (
                "invalid length 2, expected a list of 3 numbers",
                "a list of 2 items, expected a list of 3 numbers",
            ),
            (
                "invalid type: map, expected a sequence",
                "invalid type: a table, expected a list",
            ),
            (
                "invalid type: integer `3`, expected a string",
                "invalid type: the whole number `3`, expected text in quotes",
            ),
            (
                "invalid type: string \"free-slip\", expected a map",
                "invalid type: text \"free-slip\", expected a table",
            ),
            (
                "invalid type: string \"x\", expected struct PointGauge",
                "invalid type: text \"x\", expected a table",
            ),
            ("unknown field `speed`", "unknown key `speed`"),
            ("missing field `fluid`", "missing table [fluid]"),
            ("missing field `name`", "missing key `name`"),
            (
                "invalid boolean, expected `false`",
                "text must be in quotes (\"...\"); true and false are the only bare words",
            ),
            (
                "string values must be quoted, expected literal string",
                "text must be in quotes (\"...\"); true and false are the only bare words",
            ),
            (
                "invalid type: integer `99999999999999999999` as i128, expected u64",
                "the whole number 99999999999999999999 is too large: at most 18446744073709551615",
            ),
            (
                "invalid length 1, expected a table with 13 elements",
                "a list of 1 item, expected a table",
            ),
            (
                "invalid length 1, expected struct ModelSettings with 13 elements",
                "a list of 1 item, expected a table",
            ),
        ];
        for (rust, case) in cases {
            assert_eq!(in_case_words(rust), case);
        }
    }

    #[test]
    fn text_that_is_not_utf8_is_refused_at_its_first_bad_byte() {
        let bytes = [&b"[run]\nsteps = 3 # caf\xc3\xa9 "[..], &[0xff], b"\n"].concat();
        let error = std::str::from_utf8(&bytes).unwrap_err();
        let refused = CaseError::not_utf8(&bytes, "c.toml", error);
        assert_eq!(refused.at, Some((2, 18)));
        assert_eq!(refused.to_string(), "c.toml:2:18: not UTF-8 text");
    }

    const DAM: &str = r#"
[domain]
box_min_m = [-0.065, -0.08, -0.065]
box_max_m = [0.065, 0.1, 0.065]

[fluid]
particles_per_m = 200.0

[[fluid.box]]
min_m = [-0.065, -0.08, -0.065]
max_m = [-0.013, 0.046, 0.065]

[model]
name = "wcsph"
walls = "free-slip"

[run]
until_s = 0.01
"#;

    #[test]
    fn a_case_reads_with_its_values() {
        let case = parse(DAM, "dam.toml").unwrap();
        assert_eq!(*case.fluid.particles_per_m.get_ref(), 200.0);
        assert_eq!(case.fluid.boxes.len(), 1);
        assert_eq!(case.fluid.boxes[0].get_ref().max_m, [-0.013, 0.046, 0.065]);
        assert_eq!(case.model.name.as_ref().unwrap().get_ref(), "wcsph");
        assert_eq!(*case.run.until_s.as_ref().unwrap().get_ref(), 0.01);
        assert!(case.run.steps.is_none());
        // Written and read again, the same case.
        let written = toml::to_string(&case).unwrap();
        let again = parse(&written, "again.toml").unwrap();
        assert_eq!(toml::to_string(&again).unwrap(), written);
    }

    #[test]
    fn a_box_of_any_size_and_gravity_are_read() {
        let tank = DAM
            .replace(
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [2.0, 1.0, 0.5]\ngravity_m_s2 = [0.5, -9.81, 0.0]",
            )
            .replace("max_m = [-0.013, 0.046, 0.065]", "max_m = [1.5, 0.5, 0.4]");
        let case = parse(&tank, "tank.toml").unwrap();
        let domain = case.domain.simulated();
        assert_eq!(domain.min, DVec3::new(-0.065, -0.08, -0.065));
        assert_eq!(domain.max, DVec3::new(2.0, 1.0, 0.5));
        assert_eq!(domain.gravity, DVec3::new(0.5, -9.81, 0.0));
        // Gravity is written where it is not SPEC.md's, and read back the same.
        let written = toml::to_string(&case).unwrap();
        assert!(
            written.contains("gravity_m_s2 = [0.5, -9.81, 0.0]"),
            "{written}"
        );
        let course = toml::to_string(&parse(DAM, "dam.toml").unwrap()).unwrap();
        assert!(!course.contains("gravity"), "{course}");
        assert_eq!(
            parse(DAM, "dam.toml").unwrap().domain.simulated(),
            params::Domain::COURSE
        );
    }

    /// `DAM` in 2-D: its points as [x, y], and a height gauge's line as [x].
    const PLANAR_DAM: &str = r#"
[domain]
dimensions = 2
box_min_m = [-0.065, -0.08]
box_max_m = [0.065, 0.1]
gravity_m_s2 = [0.0, -9.81]

[fluid]
particles_per_m = 200.0

[[fluid.box]]
min_m = [-0.065, -0.08]
max_m = [-0.013, 0.046]

[[fluid.sphere]]
centre_m = [0.0, 0.05]
radius_m = 0.01

[model]
name = "wcsph"

[gauges]
interval_s = 0.01

[[gauges.point]]
name = "p"
at_m = [0.0, -0.07]

[[gauges.height]]
name = "h"
at_m = [0.0]

[output]
folder = "out"
"#;

    #[test]
    fn a_planar_case_is_the_slab_one_spacing_deep_at_z_0() {
        let case = parse(PLANAR_DAM, "dam2.toml").unwrap();
        let domain = case.domain.simulated();
        assert!(domain.planar);
        assert_eq!(domain.dimensions(), 2);
        let half = 0.5 * (1.0 / 200.0);
        assert_eq!(domain.min, DVec3::new(-0.065, -0.08, -half));
        assert_eq!(domain.max, DVec3::new(0.065, 0.1, half));
        assert_eq!(domain.gravity, DVec3::new(0.0, -9.81, 0.0));
        let fill = case.fluid.boxes[0].get_ref();
        assert_eq!((fill.min_m[2], fill.max_m[2]), (-half, half));
        assert_eq!(case.fluid.spheres[0].get_ref().centre_m, [0.0, 0.05, 0.0]);
        assert_eq!(case.gauges.points[0].get_ref().at_m, [0.0, -0.07, 0.0]);
        assert_eq!(case.gauges.heights[0].get_ref().at_m, [0.0, 0.0]);
        // Areas, not volumes: the box's 0.052 x 0.126 m and the disc's pi 0.01^2 m^2.
        let area = 0.052 * 0.126 + std::f64::consts::PI * 1e-4;
        let most = case.particles_at_most();
        assert!((most - area * 200.0 * 200.0).abs() < 1e-6 * most, "{most}");
        // A 3-D case is not planar, and says nothing of dimensions when written.
        let course = parse(DAM, "dam.toml").unwrap();
        assert!(!course.domain.simulated().planar);
        assert!(!toml::to_string(&course).unwrap().contains("dimensions"));
    }

    #[test]
    fn a_planar_case_takes_its_points_in_two_numbers_and_gives_its_box() {
        let fault = |from: &str, to: &str| {
            assert!(PLANAR_DAM.contains(from), "{from}");
            let error = parse(&PLANAR_DAM.replacen(from, to, 1), "dam2.toml").unwrap_err();
            (error.at.unwrap(), error.message)
        };
        let (at, message) = fault(
            "\nmin_m = [-0.065, -0.08]",
            "\nmin_m = [-0.065, -0.08, 0.0]",
        );
        assert_eq!(at, (12, 9));
        assert_eq!(
            message,
            "min_m has 3 numbers, but in a 2-D case (dimensions = 2) it takes its 2 numbers, \
             x and y"
        );
        let (at, message) = fault("at_m = [0.0]", "at_m = [0.0, 0.0]");
        assert_eq!(at, (31, 8));
        assert!(message.ends_with("takes its 1 number, x (the vertical line through it)"));
        let (at, message) = fault("box_max_m = [0.065, 0.1]\n", "");
        assert_eq!(at, (3, 14));
        assert_eq!(message, "a 2-D case gives its box: box_max_m = [x, y]");
        // Any other value, a whole number or not, at its key (not at the 2-number box).
        for other in ["4", "2.0", "\"2\"", "[2]"] {
            let (at, message) = fault("dimensions = 2", &format!("dimensions = {other}"));
            assert_eq!(at, (3, 14), "{other}");
            assert_eq!(message, "dimensions must be 2 or 3", "{other}");
        }
        // A sphere is a disc: its radius reaches along x and y only.
        let wide = fault("radius_m = 0.01", "radius_m = 0.07").1;
        assert_eq!(wide, "a sphere of fluid reaches outside the domain");
        parse(
            &PLANAR_DAM.replace("radius_m = 0.01", "radius_m = 0.04"),
            "d.toml",
        )
        .unwrap();
    }

    /// The error of `DAM` with `from` replaced by `to`.
    fn error_of(from: &str, to: &str) -> CaseError {
        assert!(DAM.contains(from), "{from}");
        parse(&DAM.replacen(from, to, 1), "dam.toml").unwrap_err()
    }

    #[test]
    fn each_fault_is_named_with_its_line_and_column() {
        let cases = [
            (
                "until_s = 0.01",
                "until_seconds = 0.01",
                (18, 1),
                "unknown key",
            ),
            (
                "particles_per_m = 200.0",
                "particles_per_m = \"many\"",
                (7, 19),
                "invalid type",
            ),
            (
                "particles_per_m = 200.0",
                "particles_per_m = -5.0",
                (7, 19),
                "not a number > 0",
            ),
            (
                "particles_per_m = 200.0",
                "particles_per_m = 0.0",
                (7, 19),
                "not a number > 0",
            ),
            (
                "max_m = [-0.013, 0.046, 0.065]",
                "max_m = [-0.013, 0.046, 0.2]",
                (9, 1),
                "outside the domain",
            ),
            (
                "max_m = [-0.013, 0.046, 0.065]",
                "max_m = [-0.07, 0.046, 0.065]",
                (9, 1),
                "must exceed",
            ),
            (
                "walls = \"free-slip\"",
                "walls = \"sticky\"",
                (15, 9),
                "none of free-slip, no-slip",
            ),
            (
                "name = \"wcsph\"",
                "name = \"sph\"",
                (14, 8),
                "none of course, fluidanimate, wcsph",
            ),
            (
                "until_s = 0.01",
                "until_s = 0.01\nsteps = 3",
                (18, 11),
                "not both",
            ),
            ("until_s = 0.01", "until_s = -1.0", (18, 11), "time > 0"),
            (
                "particles_per_m = 200.0",
                "particles_per_m = 1e6",
                (7, 19),
                "the limit is",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, 0.1, 0.065]\ngravity_m_s2 = [0.0, -inf, 0.0]",
                (5, 16),
                "gravity must be finite",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, 0.1, 0.065]\ngravity_m_s2 = [0.0, -9.8]",
                (5, 16),
                "a list of 3 numbers",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, 0.1, 0.065]\ngravity_m_s2 = [0.0, -1e4, 0.0]",
                (5, 16),
                "gravity must be at most 1000 m/s^2, not 10000",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, 0.1, 0.065]\ngravity_m_s2 = [0.0, 1e308, 0.0]",
                (5, 16),
                "gravity must be at most 1000 m/s^2, not 1e308",
            ),
            // A corner left out is blamed on the other.
            (
                "box_min_m = [-0.065, -0.08, -0.065]\nbox_max_m = [0.065, 0.1, 0.065]",
                "box_min_m = [0.0, 0.0, 0.1]",
                (3, 13),
                "box_max_m must exceed box_min_m",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, inf, 0.065]",
                (4, 13),
                "box_max_m must be finite",
            ),
            // A box too far from the origin for f32 positions.
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [2000.0, 0.1, 0.065]",
                (4, 13),
                "the box reaches 2000 m from the origin",
            ),
            ("[run]", "[run\n", (17, 5), ""),
            (
                "\nmin_m = [-0.065, -0.08, -0.065]",
                "\nmin_m = [-0.065, -0.08, -0.065, 1.0]",
                (10, 9),
                "a list of 4 items, expected a list of 3 numbers",
            ),
            (
                "box_max_m = [0.065, 0.1, 0.065]",
                "box_max_m = [0.065, 0.1]",
                (4, 13),
                "a list of 2 items, expected a list of 3 numbers",
            ),
        ];
        for (from, to, at, words) in cases {
            let error = error_of(from, to);
            assert_eq!(error.at, Some(at), "{to}: {error}");
            assert!(error.message.contains(words), "{to}: {error}");
            let line = error.to_string();
            assert!(
                line.starts_with(&format!("dam.toml:{}:{}: ", at.0, at.1)),
                "{line}"
            );
            assert!(!line.contains('\n'), "one line: {line}");
        }
    }

    #[test]
    fn lines_and_columns_count_characters() {
        assert_eq!(line_and_column("a = 1\nbé = x", 10), (2, 4));
        assert_eq!(line_and_column("x", 0), (1, 1));
        assert_eq!(line_and_column("x", 99), (1, 2));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
        /// Any text, and any case with bytes changed, reads or is refused in one line:
        /// never a panic.
        #[test]
        fn no_text_panics_the_reader(
            text in ".{0,200}",
            at in 0usize..400,
            byte in proptest::prelude::any::<u8>(),
        ) {
            let mut mutated = DAM.as_bytes().to_vec();
            let at = at % mutated.len();
            mutated[at] = byte;
            for candidate in [text.as_str(), &String::from_utf8_lossy(&mutated)] {
                if let Err(error) = parse(candidate, "fuzz.toml") {
                    proptest::prop_assert!(!error.to_string().contains('\n'));
                }
            }
        }
    }
}
