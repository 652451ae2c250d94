//! # raysched
//!
//! A research harness that answers, with measurements, *at what granularity should parallel
//! ray-tracing work be handed out, and by whom?*
//!
//! - [`scene`]: TOML scenes, validated into an immutable, `Sync` [`scene::Scene`].
//! - [`tracer`]: the [`tracer::Tracer`] seam (closest hit + occlusion): `bvh` (built by obvhs,
//!   flattened to an 8-wide BVH traversed here), `brute` (reference), `embree` (feature
//!   `embree`, Embree 3), `embree4` (feature `embree4`).
//! - `gpu` (feature `gpu`): the path tracer ported to WGSL, run through wgpu on Vulkan.
//! - [`render`]: the path tracer and [`render::render_item`], a pure function of
//!   (scene, tracer, item, seed), so every scheduler produces bit-identical images.
//!
//! ```
//! use raysched::{render, scene, tracer::{AnyTracer, TracerKind}};
//! let text = r#"
//! [camera]
//! origin = [0, 0, 4]
//! target = [0, 0, 0]
//! up = [0, 1, 0]
//! fov_deg = 40
//! width = 8
//! height = 8
//! [render]
//! spp = 4
//! [materials.white]
//! type = "diffuse"
//! reflectance = [0.8, 0.8, 0.8]
//! [[shapes]]
//! type = "sphere"
//! material = "white"
//! radius = 1
//! [[lights]]
//! type = "environment"
//! radiance = [1, 1, 1]
//! "#;
//! let scene = scene::load_scene_str(text, "doc", std::path::Path::new("."), "doc",
//!     &Default::default()).unwrap();
//! let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
//! let (image, counters) = render::render_serial(&scene, &tracer);
//! assert_eq!(image.data.len(), 64);
//! assert!(counters.rays > 0);
//! ```

pub mod core;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod plot;
pub mod reference;
pub mod sched;
pub mod source;
pub mod studies;
pub mod util;

// The paths before the layout (issue 59): `raysched::scene`, `raysched::experiment`, … name
// the same modules, so code written against them builds unchanged.
#[cfg(feature = "gpu")]
pub use crate::core::gpu;
pub use crate::core::{geometry, metrics, render, scene, tracer};
#[cfg(feature = "simgrid")]
pub use studies::simulate::simgrid;
pub use studies::{converge, experiment, model, profile, simulate, stability};
pub use util::{hash, limits, provenance, rng};
