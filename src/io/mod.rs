//! The files wing: what goes in and out of the simulation as bytes. [`fld`] is the
//! course's particle file (memory-mapped input, validation, encoding), [`input`] opens
//! only regular files, [`output`] writes
//! any output file whole or not at all (and [`signals`] cleans up after one that a signal
//! stops), [`trace`] reads the course's per-stage traces,
//! [`export`] writes a state as VTK or CSV, [`checkpoint`] a run's full state to resume
//! from, [`case`] reads case files (a scene and how to run it, in TOML), and [`gformat`]
//! prints numbers as C++ does; [`allocator`] ends the process with one line, its
//! unfinished outputs removed, where memory runs out. It builds on [`crate::sim`] only.

pub mod allocator;
pub mod case;
pub mod checkpoint;
pub mod export;
pub mod fld;
pub mod gformat;
pub mod input;
pub mod output;
pub mod signals;
pub mod trace;
