//! The subcommands of `fluid-lab`, one module each: its arguments and its `exec`.
//! [`simulation_args`] holds what the subcommands that simulate share.

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
