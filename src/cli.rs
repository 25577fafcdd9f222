//! One run of the `fluid` command, from its arguments to its output file: the checks of
//! SPEC.md section 1 in order, the printed parameters, the simulation and the atomic write.
//! Beyond SPEC.md, the output's room is reserved before simulating (rule 5's error if there
//! is none), and a final state the f32 format cannot store is an error, not an output.

use crate::error::FluidError;
use crate::io::fld;
use crate::io::gformat::format_g;
use crate::io::output::OutputFile;
use crate::progargs::ProgArgs;
use crate::sim::grid::Grid;
use crate::sim::method::Method;
use crate::sim::params::Params;
use std::ffi::{OsStr, OsString};
use std::io::Write;

/// Runs `fluid` with `args` (program name excluded), printing the parameters to `stdout`.
/// A failure to print is ignored: the output file is the result that counts.
pub fn run<I>(args: I, stdout: &mut impl Write) -> Result<(), FluidError>
where
    I: IntoIterator<Item = OsString>,
{
    let args = ProgArgs::parse(args)?;
    let input = fld::map_input(&args.input)?;
    let mut output = OutputFile::create(&args.output)?;
    let input_name = args.input.as_os_str();
    if args.steps == 0 {
        // No step to run: the state after 0 steps is the input's, and a valid input's
        // bytes are its own encoding, so the input is validated, not decoded or placed.
        let header = fld::validate(&input, input_name)?;
        output.reserve(input.len() as u64)?;
        print_report(&header, input_name, stdout)?;
        return Ok(output.commit(&input)?);
    }
    let scene = fld::parse(&input, input_name)?;
    drop(input);
    let ppm = scene.ppm;
    let header = fld::Header {
        ppm,
        particles: scene.particles.len(),
    };
    // The output's room is checked (rule 5) before the report and the simulation.
    output.reserve(fld::file_size(header.particles))?;
    print_report(&header, input_name, stdout)?;
    let mut simulation = scene.into_simulation(Method::default(), input_name)?;
    simulation.run(args.steps);
    let particles = simulation.particles();
    fld::check_storable(particles)
        .map_err(|unstorable| unstorable.for_output(args.output.as_os_str()))?;
    Ok(output.commit_with(|out| fld::write(ppm, particles, out))?)
}

/// Prints the parameter report of a valid input (stdout errors are ignored: the run goes
/// on), or returns the error of particles per metre that admit no grid.
fn print_report(
    header: &fld::Header,
    file: &OsStr,
    stdout: &mut impl Write,
) -> Result<(), FluidError> {
    let (params, grid) = header.grid(file)?;
    let report = parameter_report(&params, &grid, header.particles);
    let _ = stdout.write_all(report.as_bytes());
    let _ = stdout.flush();
    Ok(())
}

/// The seven lines printed before simulating, numbers in C++ default format, for
/// `particles` particles.
pub fn parameter_report(params: &Params, grid: &Grid, particles: usize) -> String {
    let [nx, ny, nz] = grid.dims;
    let [sx, sy, sz] = grid.block_size.to_array().map(format_g);
    format!(
        "Number of particles: {}\n\
         Particles per meter: {}\n\
         Smoothing length: {}\n\
         Particle mass: {}\n\
         Grid size: {nx} x {ny} x {nz}\n\
         Number of blocks: {}\n\
         Block size: {sx} x {sy} x {sz}\n",
        particles,
        format_g(params.ppm),
        format_g(params.h),
        format_g(params.mass),
        grid.block_count(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(ppm: f64, particles: usize) -> String {
        let params = Params::new(ppm);
        parameter_report(
            &params,
            &Grid::new(params.h, &params.domain).unwrap(),
            particles,
        )
    }

    #[test]
    fn report_for_the_small_input() {
        assert_eq!(
            report(204.0, 4800),
            "Number of particles: 4800\nParticles per meter: 204\nSmoothing length: 0.00830882\n\
             Particle mass: 0.00011779\nGrid size: 15 x 21 x 15\nNumber of blocks: 4725\n\
             Block size: 0.00866667 x 0.00857143 x 0.00866667\n"
        );
    }

    #[test]
    fn report_for_the_large_input_uses_scientific_mass() {
        let report = report(292.0, 15138);
        assert!(report.contains("Particle mass: 4.01653e-05\n"), "{report}");
        assert!(report.contains("Smoothing length: 0.00580479\n"));
        assert!(report.contains("Grid size: 22 x 31 x 22\nNumber of blocks: 15004\n"));
        assert!(report.ends_with("Block size: 0.00590909 x 0.00580645 x 0.00590909\n"));
    }

    #[test]
    fn argument_errors_come_before_file_errors() {
        let args = ["x", "/nonexistent/in.fld", "out.fld"].map(OsString::from);
        assert_eq!(run(args, &mut Vec::new()), Err(FluidError::StepsNotNumeric));
    }
}
