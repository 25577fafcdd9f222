//! The files wing: what goes in and out of the simulation as bytes. [`fld`] is the
//! course's particle file (memory-mapped input, validation, encoding), [`output`] writes
//! any output file whole or not at all, [`trace`] reads the course's per-stage traces,
//! [`export`] writes a state as VTK or CSV, [`checkpoint`] a run's full state to resume
//! from, and [`gformat`] prints numbers as C++ does. It builds on [`crate::sim`] only.

pub mod checkpoint;
pub mod export;
pub mod fld;
pub mod gformat;
pub mod output;
pub mod trace;
