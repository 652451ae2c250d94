//! The `embree4` and `embree4_robust` tracers: [`Embree4Tracer`] behind the [`Tracer`] seam.

use super::{Tracer, TracerError, TracerKind};
use crate::embree4::{Embree4Options, Embree4Tracer};
use crate::geometry::{Hit, Ray};
use crate::scene::Geometry;

pub(super) fn build(
    kind: TracerKind,
    geometry: &Geometry,
    threads: usize,
) -> Result<Embree4Tracer, TracerError> {
    let options = Embree4Options {
        threads,
        robust: kind == TracerKind::Embree4Robust,
    };
    Embree4Tracer::with_options(geometry, options).map_err(|msg| TracerError::Build {
        id: kind.id().to_string(),
        msg,
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
