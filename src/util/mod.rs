//! Small helpers that belong to no one domain module and that domain modules of every layer use:
//! they import nothing of the crate, so any module may import them without closing a circle.

pub mod cpu_time;
pub mod csv_out;
#[cfg(any(feature = "embree4", feature = "simgrid"))]
pub mod dl;
pub mod fs;
pub mod hash;
pub mod host;
pub mod limits;
pub mod one_line;
pub mod provenance;
pub mod rng;
pub mod staging;
pub mod suggest;
pub mod text;
