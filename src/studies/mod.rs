//! The studies built on the core, the sources and the schedulers: the per-pixel cost profile,
//! the cost model, convergence and stability, the timing experiments and the simulation
//! (SimGrid inside it). They read the layers below and are read only by plots and the
//! command line (`tests/it/layers.rs`).

pub mod converge;
pub mod experiment;
pub mod model;
pub mod profile;
pub mod simulate;
pub mod stability;
