//! The tracer seam: paired closest-hit and occlusion queries (pbrt's `Intersect`/`IntersectP`).
//!
//! A tracer is built once per scene, is immutable afterwards and is shared by reference across
//! all workers. Rendering is generic over `T: Tracer`; [`AnyTracer`] is the one place that maps a
//! tracer id to a type, with static dispatch.

pub mod brute;
pub mod bvh;
pub mod bvh4;

pub use brute::BruteTracer;
pub use bvh::BvhTracer;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

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

/// The tracer ids this build knows, feature-gated ones included (with their feature).
/// `embree_robust` is Embree with `RTC_SCENE_FLAG_ROBUST` (fewer leaks through shared edges).
pub const TRACER_IDS: [(&str, Option<&str>); 4] = [
    ("bvh", None),
    ("brute", None),
    ("embree", Some("embree")),
    ("embree_robust", Some("embree")),
];

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TracerError {
    #[error("unknown tracer '{0}' (expected one of: bvh, brute, embree, embree_robust)")]
    Unknown(String),
    #[error("tracer '{id}' needs cargo feature '{feature}', which this build was compiled without (rebuild with --features {feature})")]
    FeatureOff { id: String, feature: String },
    #[error("tracer '{id}' failed to build: {msg}")]
    Build { id: String, msg: String },
}

/// Check a tracer id without building anything (plans validate before timing starts).
pub fn check_tracer_id(id: &str) -> Result<(), TracerError> {
    match TRACER_IDS.iter().find(|(name, _)| *name == id) {
        None => Err(TracerError::Unknown(id.to_string())),
        Some((_, Some(feature))) if !feature_enabled(feature) => Err(TracerError::FeatureOff {
            id: id.to_string(),
            feature: feature.to_string(),
        }),
        Some(_) => Ok(()),
    }
}

fn feature_enabled(feature: &str) -> bool {
    feature == "embree" && cfg!(feature = "embree")
}

/// OS threads of the whole process right now (`Threads:` of /proc/self/status; `None` where that
/// file does not exist). Embree and rayon both own pools: a benchmark records this number so it
/// measures what it says.
pub fn os_thread_count() -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("Threads:"))
        .and_then(|v| v.trim().parse().ok())
}

/// Every tracer behind one enum: static dispatch, one `match` per query.
pub enum AnyTracer {
    Bvh(BvhTracer),
    Brute(BruteTracer),
    #[cfg(feature = "embree")]
    Embree(crate::embree::EmbreeTracer),
}

impl AnyTracer {
    /// Build tracer `id` for `scene`. `threads` is the build's thread budget (Embree only).
    pub fn build(id: &str, scene: &Scene, threads: usize) -> Result<Self, TracerError> {
        check_tracer_id(id)?;
        let _ = threads;
        match id {
            "bvh" => Ok(Self::Bvh(BvhTracer::new(&scene.geometry))),
            "brute" => Ok(Self::Brute(BruteTracer::new(&scene.geometry))),
            #[cfg(feature = "embree")]
            "embree" | "embree_robust" => crate::embree::EmbreeTracer::with_options(
                &scene.geometry,
                crate::embree::EmbreeOptions {
                    threads,
                    robust: id == "embree_robust",
                },
            )
            .map(Self::Embree)
            .map_err(|msg| TracerError::Build {
                id: id.to_string(),
                msg,
            }),
            other => Err(TracerError::Unknown(other.to_string())),
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
        }
    }
    fn id(&self) -> &'static str {
        match self {
            Self::Bvh(t) => t.id(),
            Self::Brute(t) => t.id(),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.id(),
        }
    }
    #[inline]
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        match self {
            Self::Bvh(t) => t.intersect(ray, t_max),
            Self::Brute(t) => t.intersect(ray, t_max),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.intersect(ray, t_max),
        }
    }
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        match self {
            Self::Bvh(t) => t.occluded(ray, t_max),
            Self::Brute(t) => t.occluded(ray, t_max),
            #[cfg(feature = "embree")]
            Self::Embree(t) => t.occluded(ray, t_max),
        }
    }
}
