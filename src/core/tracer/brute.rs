//! Brute force: every primitive for every ray. Only a reference for testing the others.

use super::Tracer;
use crate::core::geometry::{Hit, Ray};
use crate::core::scene::Geometry;

/// Tests every primitive, in id order, for every query: no acceleration structure.
pub struct BruteTracer {
    geometry: Geometry,
}

impl BruteTracer {
    /// A tracer over a copy of `geometry`.
    pub fn new(geometry: &Geometry) -> Self {
        Self {
            geometry: geometry.clone(),
        }
    }
}

impl Tracer for BruteTracer {
    fn id(&self) -> &'static str {
        super::TracerKind::Brute.id()
    }
    fn accelerated(&self) -> bool {
        false
    }
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_max = t_max;
        for p in 0..self.geometry.len() as u32 {
            if let Some(h) = self.geometry.intersect_prim(p, ray, t_max) {
                t_max = h.t;
                best = Some(h);
            }
        }
        best
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        (0..self.geometry.len() as u32)
            .any(|p| self.geometry.intersect_prim(p, ray, t_max).is_some())
    }
}
