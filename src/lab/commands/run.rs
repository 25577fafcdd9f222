//! `fluid-lab run`: a timed run of a scene with a chosen model, kernel and time step;
//! optionally per-step diagnostics and the final state.

use super::same_file;
use super::simulation_args::{failure, load, parse_seconds, Extent, Loaded, SimulationArgs};
use crate::io::checkpoint::{self, Checkpoint};
use crate::io::fld;
use crate::io::gformat::format_rate;
use crate::io::input::read_regular;
use crate::io::output::OutputFile;
use crate::lab::chart;
use crate::lab::diagnostics::{self, Diagnostics};
use crate::lab::gauges::{self, GaugeTable};
use crate::lab::machine::Machine;
use crate::lab::progress::{Goal, Progress};
use crate::lab::UsageError;
use crate::sim::simulation::Simulation;
use crate::sim::skin::Skin;
use crate::sim::timestep::TimeStep;
use clap::Args;
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The arguments of `fluid-lab run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    #[command(flatten)]
    simulation: SimulationArgs,
    /// Output .fld file for the final state.
    output: Option<PathBuf>,
    /// Write per-step diagnostics (speed, particles outside, energy, density error, pairs)
    /// to this CSV file.
    #[arg(long)]
    diagnostics: Option<PathBuf>,
    /// Diagnose every this many steps (and step 0 and the last).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1, value_parser = super::whole::<u64>(1, i64::MAX as u64))]
    every: u64,
    /// Write the full f64 state to --checkpoint every this many steps (atomically), so a
    /// killed run loses at most this many steps.
    #[arg(long, requires = "checkpoint", allow_negative_numbers = true, value_parser = super::whole::<u64>(1, i64::MAX as u64))]
    checkpoint_every: Option<u64>,
    /// The checkpoint file that --checkpoint-every writes.
    #[arg(long, requires = "checkpoint_every")]
    checkpoint: Option<PathBuf>,
    /// Go on from this checkpoint (of a run of the same input, model, kernel, time step,
    /// integrator, model settings, skin and pair structure) to --steps in all (or to
    /// --until), bit for bit as if never stopped;
    /// diagnostics then start at the checkpoint's step.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Run to this physical time in seconds instead of --steps (the last step cut short
    /// to land on it).
    #[arg(long, value_name = "SECONDS", conflicts_with = "steps", allow_negative_numbers = true, value_parser = parse_seconds)]
    until: Option<f64>,
}

/// Reads the checkpoint at `path`.
fn read_checkpoint(path: &Path) -> Result<Checkpoint, String> {
    let shown = path.display();
    let bytes = read_regular(path).map_err(|error| format!("cannot read {shown}: {error}"))?;
    checkpoint::decode(&bytes).map_err(|error| format!("{shown}: {error}"))
}

/// Checks that `checkpoint`, read from `path`, continues the run `simulation` starts from
/// the input (or the `case`) whose CRC-32 is `input` (same input, model, kernel, time-step
/// rule, integrator, model settings, skin and pair structure).
fn resume(
    path: &Path,
    checkpoint: Checkpoint,
    simulation: &Simulation,
    (input, case): (u32, Option<&Path>),
) -> Result<Checkpoint, String> {
    let shown = path.display();
    let state = &checkpoint.state;
    let differs = if checkpoint.input != input
        || state.ppm != simulation.params().ppm
        || state.particles.len() != simulation.particles().len()
    {
        Some("input")
    } else if state.method != simulation.method() {
        Some("model or kernel")
    } else if state.time_step != simulation.time_step() {
        Some("time step")
    } else if state.integrator != simulation.integrator() {
        Some("integrator")
    } else if !state.model_state.starts_with(&simulation.model_state()) {
        // The same input and model start from the same state, with which what a model
        // keeps begins: the settings differ.
        Some("setting of its model")
    } else if state.skin.as_ref().map(|skin| skin.width) != simulation.skin().map(Skin::width) {
        Some("skin")
    } else if state.structure != simulation.pair_structure() {
        Some("pair structure")
    } else {
        None
    };
    match (differs, case) {
        (Some("input"), Some(case)) => Err(format!(
            "{shown} is not a checkpoint of a run of {}: give --resume alone (a checkpoint \
             of a case keeps it), or the input its run started from",
            case.display()
        )),
        // (The one file given may be meant as the output: say what goes where.)
        (Some("input"), None) => Err(format!(
            "{shown} is a checkpoint of a run from another input: give the input the run \
             started from, then the output"
        )),
        (Some(what), _) => Err(format!(
            "{shown} is a checkpoint of a run with another {what}"
        )),
        (None, _) => Ok(checkpoint),
    }
}

/// Runs the scene, timed, and writes the timing line, the diagnostics and the final state.
pub fn exec(mut args: RunArgs, stdout: &mut impl Write) -> Result<(), Box<dyn Error>> {
    if args.resume.is_some() && args.simulation.periodic.is_some() {
        return Err(UsageError(
            "--periodic: a resumed run keeps its checkpoint's periodic axes".into(),
        )
        .into());
    }
    // A checkpoint of a case carries it: the resume needs nothing else (its one positional
    // argument, if any, is the output). Read here, it is not read again to resume.
    let mut checkpoint = match (&args.resume, &args.simulation.case) {
        (Some(path), None) => Some(read_checkpoint(path)?),
        _ => None,
    };
    let carried = (checkpoint.as_ref()).and_then(|checkpoint| checkpoint.case.clone());
    let carried = carried.map(|text| {
        let path = args.resume.as_ref().expect("a checkpoint");
        (text, format!("{} (its case)", path.display()))
    });
    match carried {
        Some((text, name)) => args.simulation.take_case(text, &name, &mut args.output)?,
        None if args.simulation.input.is_none()
            && args.simulation.case.is_none()
            && args.resume.is_some() =>
        {
            return Err(UsageError(format!(
                "{} is a checkpoint of a run from an input file: give that input",
                args.resume.as_ref().expect("a checkpoint").display()
            ))
            .into());
        }
        _ => args.simulation.read_case(&mut args.output)?,
    }
    // The final state a case names (its folder made once the scene is).
    let mut from_case = false;
    if let (None, Some(case)) = (&args.output, &args.simulation.read) {
        args.output = (case.output.final_state.as_ref())
            .map(|path| super::through_missing_folders(Path::new(path.get_ref())));
        from_case = args.output.is_some();
    }
    check_case_outputs(&args.simulation, from_case)?;
    check_gauge_files(&args.simulation, args.output.as_deref(), from_case)?;
    if let (Some(case), Some(output)) = (&args.simulation.case, &args.output) {
        if same_file(case, output) {
            return Err(UsageError(format!(
                "the output {} is the case file: give it a file of its own",
                output.display()
            ))
            .into());
        }
    }
    let extent = args.simulation.extent(args.until)?;
    let input = &args.simulation.source().to_path_buf();
    // The checkpoint resumed from is read, not written over by the final state or the
    // diagnostics (a new checkpoint may replace it).
    let resumed = args.resume.as_ref();
    let written = [
        ("the output", &args.output),
        ("--diagnostics", &args.diagnostics),
    ];
    for (what, path) in written {
        let (Some(path), Some(resumed)) = (path, resumed) else {
            continue;
        };
        if same_file(path, resumed) {
            return Err(UsageError(format!(
                "{what} {} is the checkpoint resumed from: give it a file of its own",
                path.display()
            ))
            .into());
        }
    }
    // The side files must be files of their own: not the input, the output, the gauges'
    // or each other (the output may be the input, as with `fluid`).
    let sides = [
        ("--diagnostics", &args.diagnostics),
        ("--checkpoint", &args.checkpoint),
    ];
    for (index, (option, side)) in sides.iter().enumerate() {
        let Some(side) = side else { continue };
        let output = match from_case {
            true => "the case's final_state",
            false => "the output",
        };
        let source = match args.simulation.case {
            Some(_) => "the case",
            None => "the input",
        };
        let others = [(source, Some(input)), (output, args.output.as_ref())]
            .into_iter()
            .chain(
                sides[index + 1..]
                    .iter()
                    .map(|(name, other)| (*name, other.as_ref())),
            );
        let mut others = others.filter_map(|(name, other)| Some((name, other?)));
        let other = match others.find(|(_, other)| same_file(side, other)) {
            Some((name, other)) => Some(format!("{name} {}", other.display())),
            None => gauge_file_at(&args.simulation, side).map(|name| format!("the gauges' {name}")),
        };
        if let Some(other) = other {
            return Err(UsageError(format!(
                "{option} {} is also {other}: give it a file of its own",
                side.display(),
            ))
            .into());
        }
    }
    // The case's gauges, and the folder their table and charts go to.
    let case = args.simulation.read.as_ref();
    let mut gauges = case.map_or(GaugeTable::new(Vec::new()), |case| {
        GaugeTable::of_case(&case.gauges)
    });
    let gauge_folder = case.and_then(|case| {
        (case.output.folder.as_ref()).map(|folder| PathBuf::from(folder.get_ref()))
    });
    let interval = case.and_then(|case| case.gauges.interval_s.as_ref().map(|i| *i.get_ref()));
    // Declared before the files that go into them, so dropped after those; the last made
    // first (a vector drops from its front), as one may be inside another.
    let mut made = std::collections::VecDeque::new();
    let open_output = || args.output.as_deref().map(OutputFile::create).transpose();
    let mut output = if from_case { None } else { open_output()? };
    let mut diagnostics_file = args
        .diagnostics
        .as_deref()
        .map(OutputFile::create)
        .transpose()?;
    let Loaded {
        ppm,
        mut simulation,
        ..
    } = load(&args.simulation)?;
    // Made once the scene is: a case refused leaves no folder behind, nor does a run
    // that fails before writing into them (`made`, each removed on return if still empty).
    if from_case {
        let folder = args.output.as_deref().and_then(Path::parent);
        if let Some(folder) = folder.filter(|folder| !folder.as_os_str().is_empty()) {
            made.push_front(super::create_output_dir(folder)?);
        }
        output = open_output()?;
    }
    let gauges_file = match (&gauge_folder, gauges.is_empty()) {
        (Some(folder), false) => {
            made.push_front(super::create_output_dir(folder)?);
            let table = folder.join(gauges::TABLE_FILE);
            // A case run again writes over its last run's readings: said once they are.
            let replaces = table.exists() && args.resume.is_none();
            Some((OutputFile::create(&table)?, folder, replaces))
        }
        _ => None,
    };
    let (mut first, mut builds_before) = (1, 0);
    // A case's CRC is its text's (the bytes of its file, or those a checkpoint kept).
    let case_text = args.simulation.case_text.clone();
    let input_crc = match (
        args.checkpoint.is_some() || args.resume.is_some(),
        &case_text,
    ) {
        (false, _) => 0,
        (true, Some(text)) => crc32fast::hash(text.as_bytes()),
        (true, None) => crc32fast::hash(&read_regular(input)?),
    };
    if let Some(path) = &args.resume {
        let read = match checkpoint.take() {
            Some(read) => read,
            None => read_checkpoint(path)?,
        };
        let case = args.simulation.case.as_deref();
        let checkpoint = resume(path, read, &simulation, (input_crc, case))?;
        let beyond = match extent {
            Extent::Steps(steps) => (checkpoint.step > steps)
                .then(|| format!("step {}, beyond --steps {steps}", checkpoint.step)),
            Extent::Until(end) => {
                let time = checkpoint.state.time;
                (time > end && end - time < -1e-12 * end)
                    .then(|| format!("t = {time} s, beyond --until {end}"))
            }
        };
        if let Some(beyond) = beyond {
            return Err(format!("{} is at {beyond}", path.display()).into());
        }
        first = checkpoint.step + 1;
        // Its gauges go on from the readings the checkpoint kept.
        if !gauges.is_empty() {
            (gauges.resume_readings(checkpoint.readings))
                .map_err(|error| format!("{}: {error}", path.display()))?;
        }
        simulation = Simulation::resume(checkpoint.state).map_err(|error| error.to_string())?;
        // The timing line counts this run's part alone: its steps, seconds and list
        // builds, not those before the checkpoint.
        builds_before = simulation.skin().map_or(0, Skin::builds);
        if let Some(interval) = interval {
            gauges.resume_schedule(&simulation, interval);
        }
    }
    // Every file is tried, and its room reserved, before simulating.
    let particles = simulation.particles().len();
    if let Some(path) = &args.checkpoint {
        let case = case_text.as_ref().map_or(0, String::len);
        let readings = expected_readings(&gauges, interval, extent, &simulation);
        OutputFile::create(path)?.reserve(checkpoint::size_bound(particles, case, readings))?;
    }
    if let Some(output) = &mut output {
        output.reserve(fld::file_size(particles))?;
    }
    if let Some(file) = &mut diagnostics_file {
        // A run to a physical time: its steps are not known before it.
        let rows = match extent {
            Extent::Steps(steps) => (steps + 1 - first) / args.every + 2,
            Extent::Until(_) => 2,
        };
        file.reserve(rows.saturating_mul(DIAGNOSTICS_ROW_BYTES))?;
    }
    let mut rows = String::from(diagnostics::CSV_HEADER);
    rows.push('\n');
    // The first step whose energies pass the largest f64, said once the rows are written.
    let mut overflowed = None;
    let mut diagnose = |simulation: &Simulation, step: u64| {
        let state = Diagnostics::of(simulation, step);
        if state.vitals.energy_overflows() {
            overflowed = overflowed.or(Some(step));
        }
        rows.push_str(&state.csv_row());
        rows.push('\n');
    };
    if diagnostics_file.is_some() {
        diagnose(&simulation, first - 1);
    }
    let start_time = simulation.time();
    // Gauges read at the start and at the first state at or past each interval after,
    // their time counted in the run's.
    let mut gauge_seconds = 0.0;
    let mut read_gauges = |simulation: &Simulation, gauges: &mut GaugeTable| {
        if let Some(interval) = interval.filter(|_| !gauges.is_empty()) {
            let started = Instant::now();
            gauges.read_due(simulation, interval);
            gauge_seconds += started.elapsed().as_secs_f64();
        }
    };
    read_gauges(&simulation, &mut gauges);
    let mut progress = Progress::towards(match extent {
        Extent::Steps(steps) => Goal::Steps(steps + 1 - first),
        Extent::Until(end) => Goal::Until(end),
    });
    let end = match extent {
        Extent::Until(end) => end,
        Extent::Steps(_) => f64::INFINITY,
    };
    let mut seconds = 0.0;
    let mut step = first - 1;
    while !extent.is_over(&simulation, step) {
        step += 1;
        let started = Instant::now();
        simulation.step_towards(end);
        seconds += started.elapsed().as_secs_f64();
        read_gauges(&simulation, &mut gauges);
        progress.show(step + 1 - first, simulation.time());
        // A run that failed (NaN or infinities, a collapsed step) stops here, naming the
        // step, instead of writing its state out; its diagnostics are written.
        if let Some(failure) = failure(&simulation, extent, step) {
            progress.finish();
            if let Some(file) = diagnostics_file {
                diagnose(&simulation, step);
                file.commit(rows.as_bytes())?;
            }
            return Err(failure.into());
        }
        if diagnostics_file.is_some()
            && (step % args.every == 0 || extent.is_over(&simulation, step))
        {
            diagnose(&simulation, step);
        }
        if let (Some(every), Some(path)) = (args.checkpoint_every, &args.checkpoint) {
            if step % every == 0 {
                let (case, readings) = (case_text.clone(), gauges.rows().to_vec());
                write_checkpoint(path, (step, input_crc), (case, readings), &simulation)?;
            }
        }
    }
    progress.finish();
    let particles = simulation.particles().len();
    let run = step + 1 - first;
    let seconds = seconds + gauge_seconds;
    let per_particle_step = match run {
        0 => 0.0,
        run => seconds / (run as f64 * particles as f64),
    };
    let simulated = simulation.time() - start_time;
    let mut builds = simulation.skin().map_or(String::new(), |skin| {
        format!(" list_builds={}", skin.builds() - builds_before)
    });
    if gauges_file.is_some() {
        builds.push_str(&format!(" gauge_seconds={gauge_seconds:.6}"));
    }
    let per_simulated_second = if simulated > 0.0 {
        format_rate(seconds / simulated)
    } else {
        String::from("none")
    };
    // Printed once the outputs are written: standard output failing loses no file.
    let timing = format!(
        "model={} kernel={} particles={particles} steps={run} seconds={seconds:.6} \
         ns_per_particle_step={:.3} simulated_s={} \
         seconds_per_simulated_s={per_simulated_second}{builds}",
        args.simulation.model().name(),
        args.simulation.kernel().name(),
        per_particle_step * 1e9,
        significant(simulated),
    );
    // The gauges' charts are drawn first, none of them written: a disk too full for them
    // fails the run before its state or table replaces anything.
    let machine = Machine::this();
    let footer = format!(
        "{}: {} on {} particles, {} kernel; {}, commit {}",
        args.simulation.source().display(),
        args.simulation.model().name(),
        particles,
        args.simulation.kernel().name(),
        machine.cpu_model,
        machine.commit
    );
    let drawn = match &gauges_file {
        Some((_, folder, _)) => {
            // Every chart's files opened before any is drawn.
            let charts = gauges.charts(&footer);
            let opened = (charts.iter())
                .map(|chart| chart::ChartFiles::open(folder, chart::Drawing::name(chart)))
                .collect::<Result<Vec<_>, _>>()?;
            (charts.iter().zip(opened))
                .map(|(chart, files)| files.draw(chart, (900, 560)))
                .collect::<Result<Vec<_>, _>>()?
        }
        None => Vec::new(),
    };
    // The final state, then the diagnostics, which are written even when the state
    // cannot be.
    let stored = match (output, &args.output) {
        (Some(output), Some(path)) => {
            let particles = simulation.particles();
            fld::check_storable(particles)
                .map_err(|unstorable| unstorable.for_output(path.as_os_str()))
                .and_then(|()| output.commit_with(|out| fld::write(ppm, particles, out)))
        }
        _ => Ok(()),
    };
    let diagnosed = diagnostics_file.map_or(Ok(()), |file| file.commit(rows.as_bytes()));
    stored?;
    diagnosed?;
    if let (Some(step), Some(path)) = (overflowed, &args.diagnostics) {
        eprintln!(
            "fluid-lab: note: the energies pass the largest f64 from step {step} on: inf in {}",
            path.display()
        );
    }
    if let Some((file, folder, replaces)) = gauges_file {
        file.commit(gauges.csv().as_bytes())?;
        for chart in drawn {
            chart.commit()?;
        }
        if replaces {
            let shown = folder.join(gauges::TABLE_FILE);
            let shown = shown.display();
            eprintln!("fluid-lab: note: {shown} and its charts replaced an earlier run's");
        }
    }
    writeln!(stdout, "{timing}")?;
    Ok(())
}

/// Refuses, at its key (exit 2, before anything is made), a place the case names for its
/// outputs that cannot be what it must: a `folder` that is a file or lies under one; a
/// `final_state` (where `used`) that is a folder, lies under a file, or is the case file.
fn check_case_outputs(args: &SimulationArgs, used: bool) -> Result<(), Box<dyn Error>> {
    let Some(case) = &args.read else {
        return Ok(());
    };
    let at = |named: &str, key: &toml::Spanned<String>, why: String| -> Box<dyn Error> {
        args.at_key(
            key.span(),
            format!("{named} = \"{}\" is {why}", key.get_ref()),
        )
    };
    // The nearest of `path` and its folders that exists, if it is not a folder.
    let file_in_the_way = |path: &Path| {
        (path.ancestors())
            .filter(|place| !place.as_os_str().is_empty())
            .find(|place| place.exists())
            .filter(|place| !place.is_dir())
            .map(Path::to_path_buf)
    };
    if let Some(folder) = &case.output.folder {
        match file_in_the_way(Path::new(folder.get_ref())) {
            Some(file) if file == Path::new(folder.get_ref()) => {
                return Err(at("folder", folder, "a file, not a folder".into()))
            }
            Some(file) => {
                return Err(at(
                    "folder",
                    folder,
                    format!("under {}, a file", file.display()),
                ))
            }
            None => {}
        }
    }
    if let Some(state) = case.output.final_state.as_ref().filter(|_| used) {
        let path = Path::new(state.get_ref());
        if path.is_dir() {
            return Err(at(
                "final_state",
                state,
                "a folder: name a .fld file".into(),
            ));
        }
        if let Some(file) = path.parent().and_then(file_in_the_way) {
            return Err(at(
                "final_state",
                state,
                format!("under {}, a file", file.display()),
            ));
        }
        if args
            .case
            .as_deref()
            .is_some_and(|case| same_file(case, path))
        {
            return Err(at(
                "final_state",
                state,
                "the case file: give the state a file of its own".into(),
            ));
        }
        let folder = case.output.folder.as_ref();
        if folder.is_some_and(|folder| {
            Path::new(folder.get_ref())
                .components()
                .eq(path.components())
        }) {
            return Err(at(
                "final_state",
                state,
                "the gauges' folder: name a .fld file".into(),
            ));
        }
    }
    Ok(())
}

/// Refuses a final state that is one of the files the case's gauges write (it would be
/// written over): at `final_state` where the case names it (`from_case`), else as a usage
/// error.
fn check_gauge_files(
    args: &SimulationArgs,
    output: Option<&Path>,
    from_case: bool,
) -> Result<(), Box<dyn Error>> {
    let (Some(case), Some(output)) = (&args.read, output) else {
        return Ok(());
    };
    let Some(name) = gauge_file_at(args, output) else {
        return Ok(());
    };
    let message = format!(
        "the final state {} is the gauges' {name}: give it a file of its own",
        output.display()
    );
    match (from_case, &case.output.final_state) {
        (true, Some(key)) => Err(args.at_key(key.span(), message)),
        _ => Err(UsageError(message).into()),
    }
}

/// The name of the file the case's gauges write at `path`, if it is one: the same file,
/// or (its folder not made yet) the same path.
fn gauge_file_at(args: &SimulationArgs, path: &Path) -> Option<String> {
    let case = args.read.as_ref()?;
    let folder = case.output.folder.as_ref()?;
    if case.gauges.points.is_empty() && case.gauges.heights.is_empty() {
        return None;
    }
    let folder = Path::new(folder.get_ref());
    let charts = (gauges::CHART_NAMES.iter()).flat_map(|name| chart::files(folder, name));
    let mut files = std::iter::once(folder.join(gauges::TABLE_FILE)).chain(charts);
    let file =
        files.find(|file| same_file(path, file) || path.components().eq(file.components()))?;
    Some(
        file.file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned(),
    )
}

/// The bytes a diagnostics row usually takes, for the room reserved before a run.
const DIAGNOSTICS_ROW_BYTES: u64 = 128;

/// `value` in fixed notation with at least 6 decimals and at least 4 significant digits
/// (a run of 2.5e-7 s is `0.0000002500`, not `0.000000`).
fn significant(value: f64) -> String {
    let magnitude = value.abs().log10().floor();
    match magnitude.is_finite() {
        // Beyond 15 decimals, in scientific notation: 5e-324 s is not 327 digits.
        true if magnitude < -12.0 => format!("{value:.3e}"),
        true => {
            let decimals = (3.0 - magnitude).clamp(6.0, 15.0) as usize;
            format!("{value:.decimals$}")
        }
        false => format!("{value:.6}"),
    }
}

/// The gauge values (times included) a checkpoint of a run over `extent` may hold, as far
/// as known before it: its readings every `interval` to its end, where its steps' times
/// are known (a physical end, or fixed steps); none beyond the next where not.
fn expected_readings(
    gauges: &GaugeTable,
    interval: Option<f64>,
    extent: Extent,
    simulation: &Simulation,
) -> usize {
    let (Some(interval), false) = (interval, gauges.is_empty()) else {
        return 0;
    };
    let end = match (extent, simulation.time_step()) {
        (Extent::Until(end), _) => end,
        (Extent::Steps(steps), TimeStep::Fixed(dt)) => steps as f64 * dt,
        (Extent::Steps(_), TimeStep::Adaptive { .. }) => 0.0,
    };
    let rows = (end / interval).ceil().min(1e9) as usize + 2;
    rows.saturating_mul(1 + gauges.columns().len())
}

/// Writes the checkpoint of `simulation` after `step` steps of the run from the input
/// whose CRC-32 is `input` (and the `case` text, if any, with its gauges' `readings`) to
/// `path`, atomically.
fn write_checkpoint(
    path: &Path,
    (step, input): (u64, u32),
    (case, readings): (Option<String>, Vec<checkpoint::Reading>),
    simulation: &Simulation,
) -> Result<(), Box<dyn Error>> {
    let state = simulation.resumable();
    let bytes = checkpoint::encode(&Checkpoint {
        step,
        input,
        case,
        readings,
        state,
    });
    Ok(OutputFile::create(path)?.commit(&bytes)?)
}
