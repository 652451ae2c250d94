//! The integration tests as one binary, one module per theme: the crate is linked once instead
//! of once per test file. `tests/embree_threads.rs` stays a binary of its own: it counts the
//! process's OS threads and Embree devices, which tests running beside it would change.

mod support;

mod analytic;
mod animation;
mod bad_input;
mod determinism;
mod embree;
mod experiment;
mod mpi;
mod schedulers;
mod simulate;
mod stability;
mod tracers;
