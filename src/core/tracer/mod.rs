//! The tracer seam: paired closest-hit and occlusion queries (pbrt's `Intersect`/`IntersectP`).
//!
//! A tracer is built once per scene, is immutable afterwards and is shared by reference across
//! all workers. Rendering is generic over `T: Tracer`; [`AnyTracer`] is the one place that maps a
//! [`TracerKind`] to a type, with static dispatch.

pub mod brute;
pub mod bvh;
pub mod bvh4;
#[cfg(any(feature = "embree", feature = "embree4"))]
pub mod embree;
pub mod kind;
#[cfg(target_arch = "x86_64")]
mod simd;
mod wide;

pub use brute::BruteTracer;
pub use bvh::BvhTracer;
pub use kind::TracerKind;

use crate::core::geometry::{Hit, Ray};
use crate::core::scene::Scene;

/// Closest-hit and occlusion queries over one scene's geometry.
///
/// An implementation is built once per scene and must then be immutable and safe to query from
/// any number of threads at once. Its answer for a ray must depend only on the ray and `t_max`,
/// never on which thread asks or in what order: images are compared bit for bit across
/// schedulers. Hits report raysched's primitive ids (spheres first, then triangles).
pub trait Tracer: Send + Sync {
    /// Stable snake_case id used by the CLI, TOML and CSV.
    fn id(&self) -> &'static str;
    /// Closest hit with `0 < t < t_max` (in units of `ray.d`).
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit>;
    /// Whether anything is hit with `0 < t < t_max`.
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;
    /// Whether an acceleration structure was built (recorded as the `bvh` feature of a run; a
    /// small scene gets none, see [`bvh::BVH_MIN_PRIMS`]).
    fn accelerated(&self) -> bool {
        true
    }
}

/// Why a tracer could not be chosen or built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TracerError {
    #[error("unknown tracer '{0}'{near} (expected one of: {ids})", ids = TracerKind::id_list(),
            near = crate::util::suggest::did_you_mean(.0, TracerKind::ALL.iter().map(|k| k.id())))]
    /// The id names no tracer; holds the id as given.
    Unknown(String),
    #[error("tracer '{id}' needs cargo feature '{feature}', which this build was compiled without (rebuild with --features {feature})")]
    /// The tracer exists but this build was compiled without its cargo feature.
    FeatureOff {
        /// The tracer's id.
        id: String,
        /// The cargo feature it needs.
        feature: String,
    },
    #[error("tracer '{id}' failed to build: {msg}")]
    /// Building the tracer for the scene failed (e.g. an error Embree reported).
    Build {
        /// The tracer's id.
        id: String,
        /// What the library reported.
        msg: String,
    },
}

/// Every tracer behind one enum: static dispatch, one `match` per query.
pub enum AnyTracer {
    /// The native 8-wide BVH.
    Bvh(BvhTracer),
    /// Every primitive per ray.
    Brute(BruteTracer),
    /// Intel Embree, default or robust.
    #[cfg(feature = "embree")]
    Embree(embree::v3::EmbreeTracer),
    /// Intel Embree 4, default or robust.
    #[cfg(feature = "embree4")]
    Embree4(embree::v4::Embree4Tracer),
}

impl AnyTracer {
    /// Build tracer `kind` for `scene`. `threads` is the build's thread budget (Embree 3 and 4
    /// only).
    ///
    /// # Errors
    /// A tracer this build lacks ([`TracerError::FeatureOff`]) or one that fails to build.
    pub fn build(kind: TracerKind, scene: &Scene, threads: usize) -> Result<Self, TracerError> {
        let _ = threads;
        match kind {
            TracerKind::Bvh => Ok(Self::Bvh(BvhTracer::new(&scene.geometry))),
            TracerKind::Brute => Ok(Self::Brute(BruteTracer::new(&scene.geometry))),
            #[cfg(feature = "embree")]
            TracerKind::Embree | TracerKind::EmbreeRobust => {
                embree::build_v3(kind, &scene.geometry, threads).map(Self::Embree)
            }
            #[cfg(not(feature = "embree"))]
            TracerKind::Embree | TracerKind::EmbreeRobust => Err(kind.feature_off()),
            #[cfg(feature = "embree4")]
            TracerKind::Embree4 | TracerKind::Embree4Robust => {
                embree::build_v4(kind, &scene.geometry, threads).map(Self::Embree4)
            }
            #[cfg(not(feature = "embree4"))]
            TracerKind::Embree4 | TracerKind::Embree4Robust => Err(kind.feature_off()),
        }
    }
}

impl Tracer for AnyTracer {
    fn accelerated(&self) -> bool {
        match self {
            Self::Bvh(t) => t.accelerated(),
            Self::Brute(t) => t.accelerated(),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.accelerated(),
            #[cfg(feature = "embree4")]
            Self::Embree4(t) => t.accelerated(),
        }
    }
    fn id(&self) -> &'static str {
        match self {
            Self::Bvh(t) => t.id(),
            Self::Brute(t) => t.id(),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.id(),
            #[cfg(feature = "embree4")]
            Self::Embree4(t) => t.id(),
        }
    }
    #[inline]
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        match self {
            Self::Bvh(t) => t.intersect(ray, t_max),
            Self::Brute(t) => t.intersect(ray, t_max),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.intersect(ray, t_max),
            #[cfg(feature = "embree4")]
            Self::Embree4(t) => t.intersect(ray, t_max),
        }
    }
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        match self {
            Self::Bvh(t) => t.occluded(ray, t_max),
            Self::Brute(t) => t.occluded(ray, t_max),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.occluded(ray, t_max),
            #[cfg(feature = "embree4")]
            Self::Embree4(t) => t.occluded(ray, t_max),
        }
    }
}
