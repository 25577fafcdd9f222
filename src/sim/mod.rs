//! The model wing: the physical models and everything one time step does, from the cell
//! order to the motion of the particles. It reads and writes no file and parses no
//! argument (its `Model` and `Kernel` only derive `clap::ValueEnum`, so the workbench can
//! offer them by name); [`crate::io`], [`crate::lab`] and the `fluid` door build on it.
//!
//! A step ([`simulation::Simulation::step`]) runs the [`stages`] in order: the [`cells`]
//! sort the particles into cell order, the [`neighbours`] search lists the tiles of
//! candidate slots, the [`model`] runs its pair passes on a [`kernel`] (density,
//! acceleration) and pushes particles off the walls and moves them, for a length
//! [`timestep`] chooses. [`params`] holds the constants, [`method`] which model and
//! kernel run, [`grid`] the blocks of the box and [`particles`] the state as a structure
//! of arrays. The modules sit in layers, each using only those below it
//! (`ARCHITECTURE.md`): constants, state, stages and kernels below the models, the
//! models below the driver ([`simulation`]).

pub mod cells;
pub mod grid;
pub mod isa;
pub mod kernel;
pub mod lists;
pub mod method;
pub mod model;
pub mod neighbours;
pub mod params;
pub mod particles;
pub mod simulation;
pub mod skin;
pub mod stages;
pub mod timestep;

/// The bytes `vector` holds on the heap (its capacity, not its length).
pub(crate) fn heap_bytes<T>(vector: &Vec<T>) -> usize {
    vector.capacity() * std::mem::size_of::<T>()
}
