//! `fluid`: a sequential smoothed-particle-hydrodynamics simulator of the UC3M course model
//! (derived from PARSEC fluidanimate). The model is specified in `SPEC.md` of the shared
//! folder; this crate reproduces its reference outputs byte for byte.
//!
//! Three wings, each building only on those before it (`ARCHITECTURE.md` has the map):
//! - [`sim`]: the model and what one time step does;
//! - [`io`]: files in and out (`.fld`, traces, VTK and CSV exports);
//! - [`lab`]: the `fluid-lab` workbench (scenes, diagnostics, accuracy, stability, sweeps,
//!   energy, charts, pictures).
//!
//! At the door, the `fluid` command's fixed contract: [`progargs`] (its arguments),
//! [`cli`] (one run) and [`error`] (its messages and exit codes).

pub mod io;
pub mod lab;
pub mod sim;

pub mod cli;
pub mod error;
pub mod progargs;

pub use sim::kernel::Kernel;
pub use sim::method::Method;
pub use sim::model::Model;
pub use sim::particles::Particles;
pub use sim::simulation::Simulation;
