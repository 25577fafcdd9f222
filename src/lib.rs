//! `fluid`: a sequential smoothed-particle-hydrodynamics simulator of the UC3M course model
//! (derived from PARSEC fluidanimate). The model is specified in `SPEC.md` of the shared
//! folder; this crate reproduces its reference outputs byte for byte.
//!
//! Modules, one per concept: [`progargs`] (arguments), [`fld`] (file format), [`params`]
//! (constants and derived values), [`method`] (model and kernel), [`grid`] (blocks),
//! [`cells`] (cell ordering), [`neighbours`] (pair search), [`particles`]
//! (structure-of-arrays state), [`kernel`] (pair stages), [`stages`] (the other stages),
//! [`simulation`] (driver), [`cli`] (the `fluid` command), [`lab`] (the `fluid-lab`
//! workbench), plus [`gformat`], [`trace`],
//! [`scene`] and [`error`].

pub mod accuracy;
pub mod cells;
pub mod chart;
pub mod cli;
pub mod diagnostics;
pub mod energy;
pub mod error;
pub mod export;
pub mod fld;
pub mod gformat;
pub mod grid;
pub mod kernel;
pub mod lab;
pub mod machine;
pub mod method;
pub mod neighbours;
pub mod params;
pub mod particles;
pub mod progargs;
pub mod render;
pub mod scene;
pub mod simulation;
pub mod stability;
pub mod stages;
pub mod sweep;
pub mod trace;
