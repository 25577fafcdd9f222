//! The files wing: what goes in and out of the simulation as bytes. [`fld`] is the
//! course's particle file (memory-mapped input, validation, atomic output), [`trace`]
//! reads the course's per-stage traces, [`export`] writes a state as VTK or CSV, and
//! [`gformat`] prints numbers as C++ does. It builds on [`crate::sim`] only.

pub mod export;
pub mod fld;
pub mod gformat;
pub mod trace;
