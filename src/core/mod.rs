//! The core: what renders and what a run measures. Geometry, the immutable scene, the
//! tracers over it, the pure per-item render (and the GPU's), and the run's metrics. Nothing
//! here knows who hands out work: scheduling (`crate::sched`) and the sources
//! (`crate::source`) build on it, never the reverse (`tests/it/layers.rs`).

pub mod geometry;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod metrics;
pub mod render;
pub mod scene;
pub mod tracer;
