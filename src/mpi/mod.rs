//! MPI compute sources (feature `mpi`): machines across a network, the founding design's
//! second kind of computing power source.
//!
//! Under `mpirun -n K raysched render SCENE --sources mpi`, rank 0 runs the scheduler and
//! ranks 1…K−1 render. No shared filesystem is assumed: rank 0 broadcasts the scene text,
//! overrides and mesh bytes with the scene hash ([`scene`]); each worker rebuilds scene and
//! tracer, checks the hash and answers READY ([`worker`]). Items and results travel in the
//! layout of [`crate::sched::wire`] ([`wire`] decodes it), back to back: one ITEM message per
//! hand-out of the master, one RESULT message for whatever results a worker has ready (per-ray
//! Cornell 128², 2 ranks: 32 768 messages → 6 600–14 100; over TCP loopback 0.29–0.30 s →
//! 0.21–0.28 s, over shared memory no change beyond noise). On rank 0 one thread owns MPI
//! ([`hub::Hub`]); the master talks to it through [`source::MpiRankSource`]s.
//!
//! Faults: with `mpirun --enable-recovery` and `MPI_ERRORS_RETURN` ([`comm`]), a rank killed
//! mid-run is noticed (failed call, vanished local pid, or silence), its results fail, and the
//! master's re-queue hands its items to the others; the survivors then exit without
//! `MPI_Finalize`.

pub mod comm;
pub mod experiment;
pub mod hub;
pub mod launch;
pub mod scene;
pub mod source;
pub mod wire;
pub mod worker;

pub use experiment::MpiRemote;
pub use launch::{gather_ready, MpiRanks, ReadyError};
pub use source::MpiRankSource;
