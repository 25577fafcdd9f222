//! The subcommands of `fluid-lab`, one module each: its arguments and its `exec`.
//! [`simulation_args`] holds what the subcommands that simulate share, and
//! [`create_output_dir`] the folder every writing subcommand makes.

pub mod accuracy;
pub mod chart;
pub mod compare;
pub mod export;
pub mod render;
pub mod run;
pub mod scene;
pub mod simulation_args;
pub mod stability;
pub mod sweep;

use std::path::Path;

/// Creates `dir` (and its parents) for a subcommand's output files; the error names it.
pub fn create_output_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|error| format!("cannot create {}: {error}", dir.display()))
}
