//! The integration tests as one binary, one module per theme: the crate is linked once instead
//! of once per test file. `tests/embree_threads.rs` and `tests/embree4_threads.rs` stay binaries of
//! their own: they count the process's OS threads and Embree devices, which tests running beside
//! them would change.

mod support;

mod advise;
mod analytic;
mod animation;
mod bad_input;
mod cli_edges;
mod cli_fuzz;
mod comments;
mod determinism;
mod dls_conformance;
mod docs;
mod embree;
mod embree4;
#[cfg(any(feature = "embree", feature = "embree4"))]
mod embree_contract;
mod experiment;
mod extension;
mod fuzz;
mod getting_started;
mod gpu;
mod hostile;
mod html;
mod layers;
mod models;
mod mpi;
mod readings;
mod reference;
mod schedulers;
mod simulate;
mod stability;
mod tracers;
