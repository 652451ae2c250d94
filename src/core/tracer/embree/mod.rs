//! The one home of the Embree tracers: `v3` (Embree 3, hand-written bindings to Debian's
//! libembree) and `v4` (Embree 4, `embree4-sys` types over a locally opened library), what
//! they share (`common`), and both behind the [`Tracer`] seam here (`v3` and `v4` know only
//! Embree, so the dependency runs one way).

mod common;

pub use common::EmbreeError;
#[cfg(feature = "embree")]
pub mod v3;
#[cfg(feature = "embree4")]
pub mod v4;

#[cfg(feature = "embree")]
pub(super) use seam3::build as build_v3;
#[cfg(feature = "embree4")]
pub(super) use seam4::build as build_v4;

/// The `embree` and `embree_robust` tracers: [`v3::EmbreeTracer`] behind the seam.
#[cfg(feature = "embree")]
mod seam3 {
    use super::super::{Tracer, TracerError, TracerKind};
    use super::v3::{EmbreeOptions, EmbreeTracer};
    use crate::core::geometry::{Hit, Ray};
    use crate::core::scene::Geometry;

    pub(in crate::core::tracer) fn build(
        kind: TracerKind,
        geometry: &Geometry,
        threads: usize,
    ) -> Result<EmbreeTracer, TracerError> {
        let options = EmbreeOptions {
            threads,
            robust: kind == TracerKind::EmbreeRobust,
        };
        EmbreeTracer::with_options(geometry, options).map_err(|e| TracerError::Build {
            id: kind.id().to_string(),
            msg: e.0,
        })
    }

    impl Tracer for EmbreeTracer {
        fn id(&self) -> &'static str {
            if self.options().robust {
                TracerKind::EmbreeRobust.id()
            } else {
                TracerKind::Embree.id()
            }
        }

        #[inline]
        fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
            EmbreeTracer::intersect(self, ray, t_max)
        }

        #[inline]
        fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
            EmbreeTracer::occluded(self, ray, t_max)
        }
    }
}

/// The `embree4` and `embree4_robust` tracers: [`v4::Embree4Tracer`] behind the seam.
#[cfg(feature = "embree4")]
mod seam4 {
    use super::super::{Tracer, TracerError, TracerKind};
    use super::v4::{Embree4Options, Embree4Tracer};
    use crate::core::geometry::{Hit, Ray};
    use crate::core::scene::Geometry;

    pub(in crate::core::tracer) fn build(
        kind: TracerKind,
        geometry: &Geometry,
        threads: usize,
    ) -> Result<Embree4Tracer, TracerError> {
        let options = Embree4Options {
            threads,
            robust: kind == TracerKind::Embree4Robust,
        };
        Embree4Tracer::with_options(geometry, options).map_err(|e| TracerError::Build {
            id: kind.id().to_string(),
            msg: e.0,
        })
    }

    impl Tracer for Embree4Tracer {
        fn id(&self) -> &'static str {
            if self.options().robust {
                TracerKind::Embree4Robust.id()
            } else {
                TracerKind::Embree4.id()
            }
        }

        #[inline]
        fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
            Embree4Tracer::intersect(self, ray, t_max)
        }

        #[inline]
        fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
            Embree4Tracer::occluded(self, ray, t_max)
        }
    }
}
