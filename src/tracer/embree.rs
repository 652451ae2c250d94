//! The `embree` and `embree_robust` tracers: [`EmbreeTracer`] behind the [`Tracer`] seam (the
//! `embree` module itself knows only Embree, so the dependency runs one way).

use super::{Tracer, TracerError, TracerKind};
use crate::embree::{EmbreeOptions, EmbreeTracer};
use crate::geometry::{Hit, Ray};
use crate::scene::Geometry;

pub(super) fn build(
    kind: TracerKind,
    geometry: &Geometry,
    threads: usize,
) -> Result<EmbreeTracer, TracerError> {
    let options = EmbreeOptions {
        threads,
        robust: kind == TracerKind::EmbreeRobust,
    };
    EmbreeTracer::with_options(geometry, options).map_err(|msg| TracerError::Build {
        id: kind.id().to_string(),
        msg,
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
