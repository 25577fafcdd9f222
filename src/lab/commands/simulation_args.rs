//! The simulation a subcommand runs: its arguments (input, steps, model, kernel, time
//! step), the input placed for it, and a run with its progress that visits chosen steps.

use crate::io::case::{self, Case, CaseError};
use crate::io::fld;
use crate::io::gformat::{format_g, format_shortest};
use crate::io::input::read_regular;
use crate::lab::diagnostics::{Failure, Vitals};
use crate::lab::machine;
use crate::lab::progress::{Goal, Progress};
use crate::lab::scene::{self, Region};
use crate::lab::UsageError;
use crate::sim::kernel::Kernel;
use crate::sim::lists::PairStructure;
use crate::sim::method::Method;
use crate::sim::model::wcsph::{Settings, WallFriction, FACES};
use crate::sim::model::{Dynamics, Model, Wcsph};
use crate::sim::params;
use crate::sim::simulation::Simulation;
use crate::sim::timestep::{is_time, Integrator, Limit, TimeStep};
use clap::Args;
use clap::ValueEnum;
use std::error::Error;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// A simulation to run: input, steps, model and kernel.
#[derive(Debug, Args)]
pub struct SimulationArgs {
    /// Input .fld file (none with --case).
    pub input: Option<PathBuf>,
    /// A case file (TOML, docs/case-files.md): the scene, its model and settings, how far
    /// to run and where to write; a flag given beside it overrides the case's value. With
    /// a case, the command's output is its only positional argument.
    #[arg(long, value_name = "FILE")]
    pub case: Option<PathBuf>,
    /// The case read from --case (by [`SimulationArgs::read_case`]).
    #[arg(skip)]
    pub read: Option<Case>,
    /// Its text.
    #[arg(skip)]
    pub case_text: Option<String>,
    /// Time steps to run (at most 2^63-1, as `fluid` takes) [default: 1]
    #[arg(long, allow_negative_numbers = true, value_parser = parse_steps)]
    pub steps: Option<u64>,
    /// Physical model [default: course]
    #[arg(long, value_enum)]
    pub model: Option<Model>,
    /// Pair-loop implementation [default: the widest f64 lanes the build's CPU has]
    #[arg(long, value_enum)]
    pub kernel: Option<Kernel>,
    /// Time step in seconds (fixed; default: the model's own rule, the course's 1 ms or
    /// the weakly compressible model's CFL step).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_time_step)]
    pub dt: Option<f64>,
    /// Adaptive time step instead of a fixed one: each step C times the shortest of
    /// sqrt(h/|a|), h/(c+|hv|), and the explicit limits of the viscosity and of the
    /// walls (C about 0.2-0.4); for the weakly compressible model its CFL step, the
    /// shorter of sqrt(h/|a|) and h/(c_0+|hv|) (C about 0.2, its default).
    #[arg(long, allow_negative_numbers = true, value_name = "C", conflicts_with = "dt", value_parser = parse_courant)]
    pub adaptive: Option<f64>,
    /// Reuse the cell order and neighbour lists (or tiles) with a skin this
    /// many cut-offs wide, rebuilding them when a particle has moved half the skin (the
    /// pairs closer than the cut-off stay exactly those of a rebuild every step); 0
    /// rebuilds them every step. Default: the weakly compressible model 0.05, whose
    /// short steps it pays for; the course models 0, whose 1 ms steps it does not
    /// (perf/README.md).
    #[arg(long, allow_negative_numbers = true, value_name = "FRACTION_OF_CUTOFF", value_parser = parse_skin)]
    pub skin: Option<f64>,
    /// Axes whose two faces are periodic, x and z, comma-separated (wcsph; over a case's
    /// [domain] periodic) [default: none, or the case's]
    #[arg(long, value_enum, value_delimiter = ',', value_name = "AXES")]
    pub periodic: Option<Vec<PeriodicAxis>>,
    /// The neighbour structure of the SIMD pair loops on dense scenes [default: lists]
    #[arg(long, value_enum)]
    pub pairs: Option<PairStructure>,
    /// How each step advances the state [default: leapfrog]
    #[arg(long, value_enum)]
    pub integrator: Option<Integrator>,
    /// The weakly compressible model's choices.
    #[command(flatten)]
    pub water: WaterArgs,
}

/// An axis `--periodic` takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PeriodicAxis {
    /// Along the flow.
    X,
    /// Across the tank (not in 2-D).
    Z,
}

impl SimulationArgs {
    /// The domain a run takes: `domain` (a case's, or SPEC.md's) with `--periodic`'s axes
    /// if given, refused (a usage error) for a model other than the water model, or along
    /// z in 2-D.
    fn with_periodic(&self, mut domain: params::Domain) -> Result<params::Domain, Box<dyn Error>> {
        if let Some(axes) = &self.periodic {
            if super::repeats(axes) {
                return Err(UsageError("--periodic names each axis once".into()).into());
            }
            if self.model() != Model::Wcsph {
                return Err(UsageError(format!(
                    "--periodic is the water model's (wcsph), not {}'s",
                    self.model().name()
                ))
                .into());
            }
            if domain.planar && axes.contains(&PeriodicAxis::Z) {
                return Err(UsageError("--periodic z: a 2-D case has no z faces".into()).into());
            }
            domain.periodic = [
                axes.contains(&PeriodicAxis::X),
                false,
                axes.contains(&PeriodicAxis::Z),
            ];
        }
        self.check_faces(&domain)?;
        Ok(domain)
    }

    /// Refuses a face's friction (from the case, at its key, or --face) where `domain`
    /// has no wall: along a periodic axis, or along z in 2-D; and --face naming a face
    /// twice.
    fn check_faces(&self, domain: &params::Domain) -> Result<(), Box<dyn Error>> {
        let flags = &self.water.faces;
        let named: Vec<usize> = flags.iter().map(|&(face, _)| face).collect();
        if super::repeats(&named) {
            return Err(UsageError("--face names each face once".into()).into());
        }
        let why_not = |face: usize| {
            let axis = face / 2;
            let why = match (domain.periodic[axis], domain.planar && axis == 2) {
                (true, _) => "is periodic",
                (false, true) => "is not in a 2-D scene",
                (false, false) => return None,
            };
            Some(format!(
                "the face {} {why}: it has no wall to choose",
                FACES[face]
            ))
        };
        let case_faces = self
            .read
            .iter()
            .filter_map(|case| case.model.faces.as_ref());
        for (name, kind) in case_faces.flat_map(|faces| faces.get_ref()) {
            let face = FACES.iter().position(|known| known == name);
            if let Some(why) = face.and_then(why_not) {
                return Err(self.at_key(kind.span(), why));
            }
        }
        match flags.iter().find_map(|&(face, _)| why_not(face)) {
            Some(why) => Err(UsageError(why).into()),
            None => Ok(()),
        }
    }
}

/// The weakly compressible model's choices (`--model wcsph`), each defaulting to the
/// validated setting.
#[derive(Debug, Clone, Default, PartialEq, Args)]
pub struct WaterArgs {
    /// The walls' friction in the viscous terms (wcsph) [default: the validated one]
    #[arg(long, value_enum)]
    pub walls: Option<WallFriction>,
    /// Monaghan's artificial viscosity alpha (wcsph) [default: the validated one]
    #[arg(long, value_name = "ALPHA", allow_negative_numbers = true, value_parser = super::number)]
    pub artificial_viscosity: Option<f64>,
    /// Kinematic viscosity of the laminar term in m^2/s, 0 for none; water's is 1e-6
    /// (wcsph) [default: the validated one]
    #[arg(long, value_name = "NU", allow_negative_numbers = true, value_parser = super::number)]
    pub laminar_viscosity: Option<f64>,
    /// Smoothing length h in lattice spacings, 0.5 to 26 (wcsph) [default: the validated
    /// one]
    #[arg(long, value_name = "SPACINGS", allow_negative_numbers = true, value_parser = super::number)]
    pub smoothing: Option<f64>,
    /// Sound speed over sqrt(2 g H), H the fluid's height at the start, 1 to 1000 (wcsph)
    /// [default: the validated one]
    #[arg(long, value_name = "FACTOR", allow_negative_numbers = true, value_parser = super::number)]
    pub sound_speed: Option<f64>,
    /// delta-SPH density diffusion coefficient (wcsph) [default: the validated one]
    #[arg(long, value_name = "DELTA", allow_negative_numbers = true, value_parser = super::number)]
    pub density_diffusion: Option<f64>,
    /// One face's friction, FACE=KIND (x_low, x_high, y_low, y_high, z_low or z_high;
    /// free-slip or no-slip), repeatable or comma-separated (wcsph) [default: --walls']
    #[arg(long = "face", value_name = "FACE=KIND", value_delimiter = ',', value_parser = parse_face)]
    pub faces: Vec<(usize, WallFriction)>,
    /// The faces a case gives (`[model] faces`), which --face's override.
    #[arg(skip)]
    pub case_faces: Vec<(usize, WallFriction)>,
}

/// Parses `FACE=KIND`: a face of [`FACES`] and a friction.
fn parse_face(text: &str) -> Result<(usize, WallFriction), String> {
    use clap::ValueEnum;
    let (face, kind) = text
        .split_once('=')
        .ok_or_else(|| format!("{text} is not FACE=KIND (y_high=free-slip, say)"))?;
    let face = FACES
        .iter()
        .position(|&name| name == face)
        .ok_or_else(|| format!("{face:?} is not a face: {}", FACES.join(", ")))?;
    let kind = WallFriction::from_str(kind, false)
        .map_err(|_| format!("{kind} is not a wall: free-slip or no-slip"))?;
    Ok((face, kind))
}

impl WaterArgs {
    /// Whether any choice was given (every field is `None` when none is).
    pub fn any(&self) -> bool {
        *self != WaterArgs::default()
    }

    /// The settings asked for, the validated ones where none is given.
    pub fn settings(&self) -> Result<Settings, String> {
        let default = Settings::default();
        let settings = Settings {
            walls: self.walls.unwrap_or(default.walls),
            artificial_viscosity: self
                .artificial_viscosity
                .unwrap_or(default.artificial_viscosity),
            laminar_viscosity: self.laminar_viscosity.unwrap_or(default.laminar_viscosity),
            smoothing: self.smoothing.unwrap_or(default.smoothing),
            sound_speed_factor: self.sound_speed.unwrap_or(default.sound_speed_factor),
            density_diffusion: self.density_diffusion.unwrap_or(default.density_diffusion),
            faces: std::array::from_fn(|face| {
                // A flag's over the case's.
                (self.case_faces.iter().chain(&self.faces).rev())
                    .find_map(|&(f, kind)| (f == face).then_some(kind))
            }),
        };
        // A value out of its range is said at its flag (a case's were checked at their keys).
        let alone = [
            (
                "--artificial-viscosity",
                self.artificial_viscosity.map(|v| Settings {
                    artificial_viscosity: v,
                    ..default
                }),
            ),
            (
                "--laminar-viscosity",
                self.laminar_viscosity.map(|v| Settings {
                    laminar_viscosity: v,
                    ..default
                }),
            ),
            (
                "--smoothing",
                self.smoothing.map(|v| Settings {
                    smoothing: v,
                    ..default
                }),
            ),
            (
                "--sound-speed",
                self.sound_speed.map(|v| Settings {
                    sound_speed_factor: v,
                    ..default
                }),
            ),
            (
                "--density-diffusion",
                self.density_diffusion.map(|v| Settings {
                    density_diffusion: v,
                    ..default
                }),
            ),
        ];
        for (flag, one) in alone {
            if let Some(Err(error)) = one.map(|one| one.check()) {
                return Err(format!("{flag}: {error}"));
            }
        }
        settings
            .check()
            .map(|()| settings)
            .map_err(|error| format!("--model wcsph: {error}"))
    }

    /// `model` with these choices: the weakly compressible model's settings, refused for
    /// another model (a usage error, as a setting out of its range).
    pub fn dynamics(&self, model: Model) -> Result<Box<dyn Dynamics>, UsageError> {
        match model {
            Model::Wcsph => Ok(Box::new(Wcsph::unprepared(
                self.settings().map_err(UsageError)?,
            ))),
            _ if self.any() => Err(UsageError(format!(
                "--walls, --face, --artificial-viscosity, --laminar-viscosity, --smoothing, \
                 --sound-speed and --density-diffusion are the weakly compressible \
                 model's; --model {} takes none",
                model.name()
            ))),
            _ => Ok(model.dynamics()),
        }
    }
}

impl SimulationArgs {
    /// The simulation of the case at `path`, with no flag beside it.
    pub fn of_case(path: &Path) -> SimulationArgs {
        SimulationArgs {
            input: None,
            case: Some(path.to_path_buf()),
            read: None,
            case_text: None,
            steps: None,
            model: None,
            kernel: None,
            dt: None,
            adaptive: None,
            skin: None,
            periodic: None,
            pairs: None,
            integrator: None,
            water: WaterArgs::default(),
        }
    }

    /// The time-step rule the arguments ask for, or the model's own.
    pub fn time_step(&self) -> TimeStep {
        asked_time_step(self.adaptive, self.dt).unwrap_or(self.model().default_time_step())
    }

    /// The model asked for.
    pub fn model(&self) -> Model {
        self.model.unwrap_or(Model::Course)
    }

    /// The kernel asked for.
    pub fn kernel(&self) -> Kernel {
        self.kernel.unwrap_or(Kernel::NATIVE)
    }

    /// The neighbour structure asked for.
    pub fn pairs(&self) -> PairStructure {
        self.pairs.unwrap_or_default()
    }

    /// The integrator asked for.
    pub fn integrator(&self) -> Integrator {
        self.integrator.unwrap_or_default()
    }

    /// How far to run: `until` (the command's `--until`), else `--steps`, else the case's
    /// steps or time, else 1 step.
    ///
    /// # Errors
    /// A run to a time on fixed steps that would take more than [`MOST_STEPS_TO_GO`]
    /// steps (the limit an adaptive step has): at the case's key that sets the step (or
    /// the time), else as a usage error.
    pub fn extent(&self, until: Option<f64>) -> Result<Extent, Box<dyn Error>> {
        let run = self.read.as_ref().map(|case| &case.run);
        let extent = match (until, self.steps, run) {
            (Some(end), _, _) => Extent::Until(end),
            (None, Some(steps), _) => Extent::Steps(steps),
            (None, None, Some(run)) => match (&run.until_s, &run.steps) {
                (Some(end), _) => Extent::Until(*end.get_ref()),
                (None, Some(steps)) => Extent::Steps(*steps.get_ref()),
                (None, None) => Extent::Steps(1),
            },
            (None, None, None) => Extent::Steps(1),
        };
        let (Extent::Until(end), TimeStep::Fixed(dt)) = (extent, self.time_step()) else {
            return Ok(extent);
        };
        let Some(steps) = steps_beyond_limit(end, dt) else {
            return Ok(extent);
        };
        // Each of the two named as it was given: a case's key, a flag, or the model's.
        let case = self.read.as_ref();
        fn given(key: Option<&toml::Spanned<f64>>, value: f64) -> Option<&toml::Spanned<f64>> {
            key.filter(|key| *key.get_ref() == value)
        }
        let dt_key = given(case.and_then(|c| c.model.time_step_s.as_ref()), dt);
        let end_key =
            given(case.and_then(|c| c.run.until_s.as_ref()), end).filter(|_| until.is_none());
        let (dt, end) = (format_g(dt), format_g(end));
        let step = match (dt_key, self.dt) {
            (Some(_), _) => format!("time_step_s = {dt} s"),
            (None, Some(_)) => format!("--dt {dt}"),
            (None, None) => format!("the model's time step of {dt} s"),
        };
        let time = match end_key {
            Some(_) => format!("until_s = {end} s"),
            None => format!("--until {end}"),
        };
        // A count past the largest f64 is said as that: more than can be counted.
        let steps = match steps.is_finite() {
            true => format!("{steps:.3e} steps"),
            false => "more steps than an f64 counts".into(),
        };
        let message = format!(
            "{step} would take {steps} to {time}, more than the {MOST_STEPS_TO_GO:.0e} a run \
             to a time may take (give steps for a longer run)"
        );
        Err(match dt_key.or(end_key) {
            Some(key) => self.at_key(key.span(), message),
            None => Box::new(UsageError(message)),
        })
    }

    /// The error `message` at the key of the case at byte span `span` of its text.
    pub fn at_key(&self, span: Range<usize>, message: String) -> Box<dyn Error> {
        let text = self.case_text.as_deref().unwrap_or_default();
        let name = self.source().display().to_string();
        Box::new(CaseError::at_span(text, &name, span, message))
    }

    /// Where the model's cut-off leaves `domain` no grid at `ppm` (`error`) at a smoothing
    /// length given (by --smoothing, or the case's smoothing_spacings) where its default
    /// would leave one: the refusal, said at the flag or key that set it, not at the
    /// resolution or the input.
    fn wide_smoothing(
        &self,
        error: &dyn std::fmt::Display,
        (ppm, domain): (f64, &params::Domain),
    ) -> Option<Box<dyn Error>> {
        let smoothing = self.water.smoothing?;
        let default_cutoff = self.model().dynamics().cutoff(ppm);
        crate::sim::grid::Grid::new(default_cutoff, domain).ok()?;
        let shown = format_shortest(smoothing);
        let why = format!(
            "the water model's cut-off at h = {shown} spacings leaves the box no grid ({error})"
        );
        let key = (self.read.as_ref())
            .and_then(|case| case.model.smoothing_spacings.as_ref())
            .filter(|key| *key.get_ref() == smoothing);
        Some(match key {
            Some(key) => self.at_key(key.span(), format!("smoothing_spacings = {shown}: {why}")),
            None => UsageError(format!("--smoothing {shown}: {why}")).into(),
        })
    }

    /// The file the scene comes from: the case, or the input.
    pub fn source(&self) -> &Path {
        self.case
            .as_deref()
            .or(self.input.as_deref())
            .expect("an input or a case (clap requires one)")
    }

    /// Reads --case, if given, and takes from it every setting the command line leaves
    /// out. With a case, the one positional argument clap gave the input is the command's
    /// `output`, which it moves there.
    ///
    /// # Errors
    /// A case that cannot be read, or is refused ([`CaseError`]).
    pub fn read_case(&mut self, output: &mut Option<PathBuf>) -> Result<(), Box<dyn Error>> {
        let Some(path) = &self.case else {
            return match self.input {
                Some(_) => Ok(()),
                None => Err(UsageError("give an input .fld file or --case FILE".into()).into()),
            };
        };
        let shown = path.display().to_string();
        let bytes = read_regular(path).map_err(|error| format!("cannot read {shown}: {error}"))?;
        // No output of the command replaces it, whatever its name.
        crate::io::output::keep_intact(path);
        let text = String::from_utf8(bytes)
            .map_err(|error| CaseError::not_utf8(error.as_bytes(), &shown, error.utf8_error()))?;
        self.take_case(text, &shown, output)
    }

    /// Keeps the input file, if any, from being replaced by an output of the command (as
    /// [`Self::read_case`] keeps the case): for the commands whose outputs are not a
    /// final state, which `run` may write over its input as `fluid` does.
    pub fn keep_input_intact(&self) {
        if let Some(input) = &self.input {
            crate::io::output::keep_intact(input);
        }
    }

    /// Takes `text`, the case file `name` (read from it, or kept by a checkpoint), as
    /// [`Self::read_case`] does.
    pub fn take_case(
        &mut self,
        text: String,
        name: &str,
        output: &mut Option<PathBuf>,
    ) -> Result<(), Box<dyn Error>> {
        if let Some(given) = self.input.take() {
            if output.is_some() {
                return Err(UsageError(
                    "with --case, give only the output (the case makes the scene)".into(),
                )
                .into());
            }
            *output = Some(given);
        }
        if self.case.is_none() {
            self.case = Some(PathBuf::from(name));
        }
        let case = case::parse(&text, name)?;
        let settings = &case.model;
        self.model = self.model.or(named(&settings.name));
        // The water model's settings, refused at their key for the model that runs (the
        // case's, or --model's over it).
        let model = self.model.unwrap_or(Model::Course);
        if let Some((key, span)) = settings.first_water_setting() {
            if model != Model::Wcsph {
                let message = format!(
                    "{key} is the weakly compressible model's (name = \"wcsph\"); the {} \
                     model takes none",
                    model.name()
                );
                self.read = Some(case.clone());
                self.case_text = Some(text.clone());
                return Err(self.at_key(span, message));
            }
        }
        self.kernel = self.kernel.or(named(&settings.kernel));
        self.integrator = self.integrator.or(named(&settings.integrator));
        self.pairs = self.pairs.or(named(&settings.pairs));
        if self.dt.is_none() && self.adaptive.is_none() {
            self.dt = settings.time_step_s.as_ref().map(|dt| *dt.get_ref());
            self.adaptive = settings.adaptive_courant.as_ref().map(|c| *c.get_ref());
        }
        self.skin = self
            .skin
            .or(settings.skin_cutoffs.as_ref().map(|skin| *skin.get_ref()));
        let water = &mut self.water;
        water.walls = water.walls.or(named(&settings.walls));
        // The case's faces first: a flag's for the same face comes later and wins.
        let faces = settings.faces.iter().flat_map(|faces| faces.get_ref());
        let from_case = faces.filter_map(|(face, kind)| {
            let face = FACES.iter().position(|name| name == face)?;
            Some((face, named(&Some(kind.clone()))?))
        });
        water.case_faces = from_case.collect();
        let number = |value: &Option<toml::Spanned<f64>>| value.as_ref().map(|v| *v.get_ref());
        water.artificial_viscosity = water
            .artificial_viscosity
            .or(number(&settings.artificial_viscosity));
        water.laminar_viscosity = water
            .laminar_viscosity
            .or(number(&settings.laminar_viscosity_m2_s));
        water.smoothing = water.smoothing.or(number(&settings.smoothing_spacings));
        water.sound_speed = water.sound_speed.or(number(&settings.sound_speed_factor));
        water.density_diffusion = water
            .density_diffusion
            .or(number(&settings.density_diffusion));
        self.read = Some(case);
        self.case_text = Some(text);
        Ok(())
    }
}

/// The time-step rule `--adaptive C` or `--dt DT` ask for (the adaptive one if both are
/// given), if either is.
pub fn asked_time_step(adaptive: Option<f64>, dt: Option<f64>) -> Option<TimeStep> {
    match (adaptive, dt) {
        (Some(courant), _) => Some(TimeStep::Adaptive { courant }),
        (None, Some(dt)) => Some(TimeStep::Fixed(dt)),
        (None, None) => None,
    }
}

/// An input placed for simulation.
pub struct Loaded {
    /// The input's file stem, for output names.
    pub stem: String,
    /// The input's name as given.
    pub name: String,
    /// Particles per metre, as the input stores it.
    pub ppm: f32,
    /// The input's particles, ready to step.
    pub simulation: Simulation,
}

/// The weakest gravity the water model takes (m/s^2): its sound speed, and with it its
/// time step, follows sqrt(g).
const MIN_WATER_GRAVITY: f64 = 0.01;

/// Whether `domain`'s gravity is a body force driving a flow along its periodic axes: it
/// pulls along one, and along none that is not periodic but down y, with a magnitude of
/// at least [`MIN_WATER_GRAVITY`].
fn driven_channel(domain: &params::Domain) -> bool {
    let g = domain.gravity;
    let along_periodic = (g.x != 0.0 && domain.periodic[0]) || (g.z != 0.0 && domain.periodic[2]);
    let only_periodic = (g.x == 0.0 || domain.periodic[0]) && (g.z == 0.0 || domain.periodic[2]);
    along_periodic && only_periodic && g.y <= 0.0 && g.length() >= MIN_WATER_GRAVITY
}

/// What a model asks of a case's domain, or the key that breaks it and why: the course
/// model keeps SPEC.md's box and gravity; the water model's floor is the box's low y
/// wall, so its gravity points down y; only the water model runs in 2-D.
fn check_domain(
    domain: &case::Domain,
    simulated: &params::Domain,
    model: Model,
) -> Result<(), (Range<usize>, String)> {
    let course = params::Domain::COURSE;
    let keys = [
        (&domain.box_min_m, course.min),
        (&domain.box_max_m, course.max),
        (&domain.gravity_m_s2, course.gravity),
    ];
    let differing = keys
        .iter()
        .find(|(key, value)| *key.get_ref() != value.to_array());
    let pull = simulated.downward_pull();
    let periodic = domain.periodic.as_ref();
    if let Some(periodic) = periodic.filter(|_| simulated.periodic.contains(&true)) {
        if model != Model::Wcsph {
            return Err((
                periodic.span(),
                format!(
                    "periodic faces are the water model's (wcsph), not {}'s",
                    model.name()
                ),
            ));
        }
        if simulated.periodic[1] {
            return Err((
                periodic.span(),
                "the water model's floor is the box's low y wall: y cannot be periodic".into(),
            ));
        }
    }
    if let Some(dimensions) = domain.dimensions.as_ref().filter(|_| simulated.planar) {
        if model != Model::Wcsph {
            return Err((
                dimensions.span(),
                format!(
                    "a 2-D case runs the water model (wcsph), not {}",
                    model.name()
                ),
            ));
        }
    }
    match (model, differing) {
        (Model::Course, Some((key, _))) => Err((
            key.span(),
            format!(
                "the course model keeps SPEC.md's box and gravity (box_min_m = {:?}, \
                 box_max_m = {:?}, gravity_m_s2 = {:?}): run this case with fluidanimate or \
                 wcsph",
                course.min.to_array(),
                course.max.to_array(),
                course.gravity.to_array()
            ),
        )),
        (Model::Wcsph, _) if driven_channel(simulated) => Ok(()),
        (Model::Wcsph, _) if !pull.is_some_and(|g| g >= MIN_WATER_GRAVITY) => Err((
            domain.gravity_m_s2.span(),
            format!(
                "the water model's floor is the box's low y wall, and its sound speed \
                     follows g: its gravity_m_s2 is {} with g >= {MIN_WATER_GRAVITY} \
                     m/s^2 (or a body force along periodic axes, at least as strong)",
                match simulated.planar {
                    true => "[0, -g]",
                    false => "[0, -g, 0]",
                }
            ),
        )),
        _ => Ok(()),
    }
}

/// The choice a case names, if any (its names were checked when the case was read).
fn named<T: ValueEnum>(name: &Option<toml::Spanned<String>>) -> Option<T> {
    name.as_ref()
        .map(|name| T::from_str(name.get_ref(), false).expect("a name checked by the case"))
}

/// The output a command needs: the one given, or the one its case names.
pub fn needed(output: Option<PathBuf>, what: &str) -> Result<PathBuf, UsageError> {
    output.ok_or_else(|| UsageError(format!("give the {what}")))
}

/// The memory a run takes per particle (bytes), above [`RUN_BASE_BYTES`]: its address
/// space, which `ulimit -v` limits, not only its resident pages (457 B from 144,000 to
/// 486,000 particles on the water model): a 373,000-particle water run with gauges needed
/// between 400 and 550 MB of address space, about 1.3 kB a particle; with room to spare.
const BYTES_PER_PARTICLE: f64 = 1500.0;

/// The address space of a run with few particles (bytes): the program, its tables, the
/// allocator's arenas.
const RUN_BASE_BYTES: f64 = 64e6;

/// Refuses a case whose particles would need more memory than this process may use (its
/// `ulimit -v`, or the machine's available memory and swap), before any is allocated.
fn check_memory(case: &Case) -> Result<(), String> {
    let most = case.particles_at_most();
    memory_beyond_usable(most).map_err(|(needed, usable)| {
        format!(
            "particles_per_m = {} fills about {most:.3e} particles, which need about \
             {needed}; {usable}",
            case.fluid.particles_per_m.get_ref(),
        )
    })
}

/// The memory `particles` need and what this process may use, shown, where the first is
/// more.
fn memory_beyond_usable(particles: f64) -> Result<(), (String, String)> {
    let needed = RUN_BASE_BYTES + particles * BYTES_PER_PARTICLE;
    match machine::usable_memory() {
        Some((usable, set_by)) if needed > usable as f64 => Err((
            format!("{} of memory", machine::shown_bytes(needed)),
            format!("{set_by} allows {}", machine::shown_bytes(usable as f64)),
        )),
        _ => Ok(()),
    }
}

/// Reads and places the input of `args` (or makes the scene of its case) with its model,
/// kernel and time step.
pub fn load(args: &SimulationArgs) -> Result<Loaded, Box<dyn Error>> {
    let source = args.source();
    let name = source.display().to_string();
    // What is wrong with a case's scene is at the key that makes it so (`args.at_key`).
    let dynamics = args.water.dynamics(args.model())?;
    let method = Method {
        model: args.model(),
        kernel: args.kernel(),
    };
    let (mut simulation, ppm) = match &args.read {
        Some(case) => {
            let spacing = &case.fluid.particles_per_m;
            let ppm = *spacing.get_ref();
            let regions = Region::of_case(&case.fluid);
            // --periodic's axes replace the case's: the domain they make is checked (a
            // fault the flag made is the flag's; the case's own, at its key).
            let domain = args.with_periodic(case.domain.simulated())?;
            if let Err((span, why)) = check_domain(&case.domain, &domain, method.model) {
                let own = check_domain(&case.domain, &case.domain.simulated(), method.model);
                return Err(match (args.periodic.is_some(), own) {
                    (true, Ok(())) => UsageError(format!("with --periodic: {why}")).into(),
                    _ => args.at_key(span, why),
                });
            }
            check_memory(case).map_err(|why| args.at_key(spacing.span(), why))?;
            // An empty fill at its own key (the boxes, then the spheres, as `regions`).
            let fills = case.fluid.boxes.iter().map(|fill| fill.span());
            let fills: Vec<Range<usize>> = fills
                .chain(case.fluid.spheres.iter().map(|fill| fill.span()))
                .collect();
            let particles = scene::filled(ppm, case.fluid.seed, &regions, &domain).map_err(
                |error| match error {
                    scene::FillError::Empty { region, .. } => {
                        args.at_key(fills[region].clone(), error.to_string())
                    }
                    scene::FillError::Other(_) => args.at_key(spacing.span(), error.to_string()),
                },
            )?;
            let shape = domain;
            let simulation = Simulation::with_dynamics(ppm, domain, particles, method, dynamics)
                .map_err(|error| {
                    args.wide_smoothing(&error, (ppm, &shape))
                        .unwrap_or_else(|| {
                            args.at_key(
                                spacing.span(),
                                format!(
                                    "particles_per_m = {ppm} gives {error} for the model's cut-off"
                                ),
                            )
                        })
                })?;
            (simulation, ppm as f32)
        }
        None => {
            // What the particles need is known from the header, before they are decoded.
            let bytes = fld::map_input(source)?;
            let header = fld::header(&bytes, source).map_err(|error| error.naming(source))?;
            let particles = header.particles;
            memory_beyond_usable(particles as f64).map_err(|(needed, usable)| {
                format!("{name}: its {particles} particles need about {needed}; {usable}")
            })?;
            let scene = fld::parse(&bytes, source).map_err(|error| error.naming(source))?;
            drop(bytes);
            let ppm = scene.ppm;
            let domain = args.with_periodic(params::Domain::COURSE)?;
            let shape = (ppm as f64, &domain);
            let simulation = scene
                .into_simulation_with(method, dynamics, domain, &name)
                .map_err(|error| {
                    // Its reason alone: the input is not at fault where the smoothing is.
                    let reason = match &error {
                        fld::FileError::InvalidInput { reason, .. } => reason.clone(),
                        other => other.to_string(),
                    };
                    args.wide_smoothing(&reason, shape)
                        .unwrap_or_else(|| error.into())
                })?;
            (simulation, ppm)
        }
    };
    let stem = source.file_stem().unwrap_or_default();
    simulation.set_time_step(args.time_step());
    simulation.set_integrator(args.integrator());
    simulation.set_pair_structure(args.pairs());
    let h = simulation.params().h;
    if let Some(fraction) = args.skin {
        let shown = format_shortest(fraction);
        let too_wide = |error| format!("--skin {shown}: too wide for the box ({error})");
        let from_case = args
            .read
            .as_ref()
            .and_then(|case| case.model.skin_cutoffs.as_ref());
        simulation
            .set_skin((fraction > 0.0).then_some(fraction * h))
            .map_err(|error| match from_case {
                Some(skin) if *skin.get_ref() == fraction => args.at_key(
                    skin.span(),
                    format!("skin_cutoffs = {shown} is too wide for the box ({error})"),
                ),
                _ => UsageError(too_wide(error)).into(),
            })?;
    }
    // A model that keeps its fluid in cannot start with it out: its first step would be
    // called a blow-up.
    let outside = Vitals::of(&simulation).outside;
    if outside > 0 && args.model().keeps_to_its_box() {
        let particles = match outside {
            1 => "1 particle starts".to_string(),
            count => format!("{count} particles start"),
        };
        return Err(format!(
            "{name}: {particles} more than h outside the box, which the {} model keeps its \
             fluid in",
            args.model().name()
        )
        .into());
    }
    Ok(Loaded {
        stem: stem.to_string_lossy().into_owned(),
        simulation,
        name,
        ppm,
    })
}

/// How far a run of `export` or `render` goes, in physical time if asked, and which of its
/// states it writes besides the last: the options they share beside their `--every`.
#[derive(Debug, Args)]
pub struct Span {
    /// Run to this physical time in seconds instead of --steps (the last step cut short
    /// to land on it).
    #[arg(long, value_name = "SECONDS", conflicts_with = "steps", allow_negative_numbers = true, value_parser = parse_seconds)]
    pub until: Option<f64>,
    /// Also write the state every this many simulated seconds (and at time 0), each at
    /// its time exactly: a step that would pass a frame's time is cut short to land on it.
    #[arg(long, value_name = "SECONDS", conflicts_with = "every", allow_negative_numbers = true, value_parser = parse_seconds)]
    pub frame_every: Option<f64>,
}

impl Span {
    /// Takes a case's frame interval (`[output] frame_interval_s`) where neither
    /// `--frame-every` nor `every` (`--every`) is given.
    pub fn take_case(&mut self, case: Option<&Case>, every: Option<u64>) {
        let interval = case.and_then(|case| case.output.frame_interval_s.as_ref());
        if let (None, None, Some(interval)) = (self.frame_every, every, interval) {
            self.frame_every = Some(*interval.get_ref());
        }
    }

    /// The states written besides the last: `--frame-every`, else every `every` steps.
    pub fn frames(&self, every: Option<u64>) -> Frames {
        match (self.frame_every, every) {
            (Some(interval), _) => Frames::EverySeconds(interval),
            (None, Some(every)) => Frames::EverySteps(every),
            (None, None) => Frames::Last,
        }
    }

    /// Refuses frames in time that a run to `extent` would write more than
    /// [`MOST_STEPS_TO_GO`] of (each frame cuts a step short): at the case's key that sets
    /// them (`args`' case), else as a usage error.
    pub fn check(&self, extent: Extent, args: &SimulationArgs) -> Result<(), Box<dyn Error>> {
        let (Extent::Until(end), Some(interval)) = (extent, self.frame_every) else {
            return Ok(());
        };
        let frames = end / interval;
        if frames <= MOST_STEPS_TO_GO {
            return Ok(());
        }
        let key = (args.read.as_ref())
            .and_then(|case| case.output.frame_interval_s.as_ref())
            .filter(|key| *key.get_ref() == interval);
        let every = format_g(interval);
        let named = match key {
            Some(_) => format!("frame_interval_s = {every} s"),
            None => format!("--frame-every {every}"),
        };
        let message = format!(
            "{named} would write {frames:.3e} frames to {} s, more than the {MOST_STEPS_TO_GO:.0e} \
             a run may take steps for",
            format_g(end)
        );
        Err(match key {
            Some(key) => args.at_key(key.span(), message),
            None => Box::new(UsageError(message)),
        })
    }

    /// Whether states besides the last are written.
    pub fn is_series(&self, every: Option<u64>) -> bool {
        self.frames(every) != Frames::Last
    }
}

/// How far a run goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Extent {
    /// This many steps.
    Steps(u64),
    /// To this physical time (s), the last step cut short to land on it.
    Until(f64),
}

impl Extent {
    /// Whether a run at `simulation`, `step` steps in, has gone this far.
    pub fn is_over(self, simulation: &Simulation, step: u64) -> bool {
        match self {
            Extent::Steps(steps) => step >= steps,
            Extent::Until(end) => simulation.has_reached(end),
        }
    }

    /// Where a run over this extent is going, for its [`Progress`].
    pub fn goal(self) -> Goal {
        match self {
            Extent::Steps(steps) => Goal::Steps(steps),
            Extent::Until(end) => Goal::Until(end),
        }
    }
}

/// Which states of a run are visited besides its last.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Frames {
    /// None.
    Last,
    /// Step 0 and every this many steps.
    EverySteps(u64),
    /// Time 0 and every this many simulated seconds, each landed on exactly.
    EverySeconds(f64),
}

/// The most steps a run to a physical time may take: what it may still need at its
/// current adaptive step before it is taken to have collapsed ([`failure`]), and the
/// limit of every run whose steps are known before it starts (fixed steps, frames,
/// stability's and accuracy's runs).
pub const MOST_STEPS_TO_GO: f64 = 1e7;

/// The steps a run to `end` (s) on fixed steps of `dt` takes, if more than
/// [`MOST_STEPS_TO_GO`].
pub fn steps_beyond_limit(end: f64, dt: f64) -> Option<f64> {
    let steps = (end / dt).ceil();
    (steps > MOST_STEPS_TO_GO).then_some(steps)
}

/// Why a run fails after `step`: a particle that is not finite (NaN or infinities are not
/// drawn, exported or written as if they were a state); on a model that keeps its fluid
/// in the box ([`Model::keeps_to_its_box`]), particles more than h outside it (the run
/// blew up); or, on the way to a physical time, an adaptive step collapsed so far that
/// more than [`MOST_STEPS_TO_GO`] steps would remain.
pub fn failure(simulation: &Simulation, extent: Extent, step: u64) -> Option<String> {
    let vitals = Vitals::of(simulation);
    if let Some(id) = vitals.non_finite {
        return Some(format!(
            "the run failed at step {step}: particle {id} is not finite"
        ));
    }
    if vitals.outside > 0 && simulation.method().model.keeps_to_its_box() {
        let time = format_g(simulation.time());
        let (model, left) = (
            simulation.method().model.name(),
            Failure::LeftBox(vitals.outside),
        );
        return Some(format!(
            "the run blew up at step {step}, t = {time} s: {left} by more than h (the \
             {model} model keeps its fluid in; a shorter time step may)"
        ));
    }
    let Extent::Until(end) = extent else {
        return None;
    };
    let (dt, limit) = simulation.last_step()?;
    let adaptive = !matches!(limit, Limit::Fixed | Limit::Landing);
    let to_go = end - simulation.time();
    (adaptive && dt * MOST_STEPS_TO_GO < to_go).then(|| {
        format!(
            "the run failed at step {step}, t = {} s: its adaptive step of {} s \
             would take more than {MOST_STEPS_TO_GO:.0e} steps for the {} s still to go",
            format_g(simulation.time()),
            format_g(dt),
            format_g(to_go)
        )
    })
}

/// Runs `simulation` over `extent`, calling `visit` with the step count at the states of
/// `frames` (step 0 included) and at the last; stops at a [`failure`].
pub fn run_visiting(
    simulation: &mut Simulation,
    extent: Extent,
    frames: Frames,
    mut visit: impl FnMut(&Simulation, u64) -> Result<(), Box<dyn Error>>,
) -> Result<(), Box<dyn Error>> {
    let mut progress = Progress::towards(extent.goal());
    let mut step = 0;
    // Frames in time land on multiples of the interval, counted, not summed.
    let mut frame = 0u64;
    if frames != Frames::Last || extent.is_over(simulation, 0) {
        visit(simulation, 0)?;
    }
    while !extent.is_over(simulation, step) {
        let next_frame = match frames {
            Frames::EverySeconds(interval) => (frame + 1) as f64 * interval,
            _ => f64::INFINITY,
        };
        let end = match extent {
            Extent::Until(end) => end.min(next_frame),
            Extent::Steps(_) => next_frame,
        };
        if simulation.has_reached(end) {
            // A frame closer than a step can land: it is the state at hand, written.
            frame += 1;
            visit(simulation, step)?;
            continue;
        }
        simulation.step_towards(end);
        step += 1;
        progress.show(step, simulation.time());
        if let Some(failure) = failure(simulation, extent, step) {
            progress.finish();
            return Err(failure.into());
        }
        let on_frame = match frames {
            Frames::Last => false,
            Frames::EverySteps(every) => step % every == 0,
            Frames::EverySeconds(_) => simulation.has_reached(next_frame),
        };
        if on_frame && matches!(frames, Frames::EverySeconds(_)) {
            frame += 1;
        }
        if on_frame || extent.is_over(simulation, step) {
            visit(simulation, step)?;
        }
    }
    progress.finish();
    Ok(())
}

/// A run's failure after `written` files of a series of frames, saying that those are
/// kept: the frames before a failure show how it came.
pub fn keeping_frames(error: Box<dyn Error>, written: usize) -> Box<dyn Error> {
    match written {
        0 => error,
        1 => format!("{error}; the frame written before it is kept").into(),
        n => format!("{error}; the {n} frames written before it are kept").into(),
    }
}

/// Parses a physical time in seconds: finite and positive.
pub fn parse_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(seconds) if is_time(seconds) => Ok(seconds),
        _ => Err(format!(
            "{text} is not a positive, finite time in seconds (from 2.2e-308)"
        )),
    }
}

/// Parses particles per metre: finite and positive.
pub fn parse_particles_per_metre(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(ppm) if ppm.is_finite() && ppm > 0.0 => Ok(ppm),
        _ => Err(format!(
            "{text} is not a positive, finite number of particles per metre"
        )),
    }
}

/// Parses a count of time steps: a whole number from 0 to 2^63-1, written out in digits.
pub fn parse_steps(text: &str) -> Result<u64, String> {
    match text.parse::<u64>() {
        Ok(steps) if steps <= i64::MAX as u64 => Ok(steps),
        _ => Err(format!(
            "{text} is not a whole number of steps from 0 to {} in digits",
            i64::MAX
        )),
    }
}

/// Parses a positive, finite time step.
pub fn parse_time_step(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(dt) if is_time(dt) => Ok(dt),
        _ => Err(format!("{text} is not a positive time step")),
    }
}

/// Parses a Courant constant: finite, positive and at most 1 (beyond that a step outruns
/// the time scale it is taken from).
pub fn parse_courant(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(c) if c.is_finite() && c > 0.0 && c <= 1.0 => Ok(c),
        _ => Err(format!("{text} is not a Courant constant in (0, 1]")),
    }
}

/// Courant constants of adaptive time steps, as one comma-separated argument; an empty
/// argument (`--adaptive ""`) is none.
#[derive(Debug, Clone, PartialEq)]
pub struct Courants(pub Vec<f64>);

impl Courants {
    /// The constants of every argument given (`--adaptive 0.2,0.3` or `--adaptive 0.2 0.3`).
    pub fn all(arguments: &[Courants]) -> Vec<f64> {
        arguments.iter().flat_map(|c| c.0.iter().copied()).collect()
    }
}

/// Parses [`Courants`]: Courant constants separated by commas, or nothing.
pub fn parse_courants(text: &str) -> Result<Courants, String> {
    if text.trim().is_empty() {
        return Ok(Courants(Vec::new()));
    }
    text.split(',')
        .map(|c| parse_courant(c.trim()))
        .collect::<Result<_, _>>()
        .map(Courants)
}

/// Parses a skin width in cut-offs: finite and not negative (0: none).
fn parse_skin(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(width) if width.is_finite() && width >= 0.0 => Ok(width),
        _ => Err(format!("{text} is not a skin width (0 or more)")),
    }
}
