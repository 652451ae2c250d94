//! Native tracer: an `obvhs` compressed wide BVH (CWBVH, Ylitie et al. 2017) over every
//! primitive's bounds; leaves test triangles and analytic spheres exactly with the shared
//! routines of [`crate::geometry`], so hits agree bit for bit with `brute`.

use super::Tracer;
use crate::geometry::{Hit, Ray, Sphere, Triangle};
use crate::scene::Geometry;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::BvhBuildParams;
use std::time::Duration;

/// A primitive stored in BVH leaf order, so a leaf test touches contiguous memory.
#[derive(Clone, Copy)]
enum LeafPrim {
    Sphere(Sphere),
    Triangle(Triangle),
}

pub struct BvhTracer {
    bvh: Option<CwBvh>,
    prims: Vec<LeafPrim>,
    /// Scene primitive id of each leaf slot.
    ids: Vec<u32>,
    pub build_time: Duration,
}

impl BvhTracer {
    pub fn new(geometry: &Geometry) -> Self {
        Self::with_params(geometry, BvhBuildParams::medium_build())
    }

    pub fn with_params(geometry: &Geometry, params: BvhBuildParams) -> Self {
        let start = std::time::Instant::now();
        if geometry.is_empty() {
            return Self {
                bvh: None,
                prims: Vec::new(),
                ids: Vec::new(),
                build_time: start.elapsed(),
            };
        }
        let aabbs: Vec<Aabb> = (0..geometry.len() as u32)
            .map(|p| {
                let (lo, hi) = geometry.prim_bounds(p);
                Aabb::new(lo.into(), hi.into())
            })
            .collect();
        let bvh = build_cwbvh(&aabbs, params, &mut Duration::default());
        let ns = geometry.spheres.len() as u32;
        let ids = bvh.primitive_indices.clone();
        let prims = ids
            .iter()
            .map(|&p| {
                if p < ns {
                    LeafPrim::Sphere(geometry.spheres[p as usize])
                } else {
                    LeafPrim::Triangle(geometry.triangles[(p - ns) as usize])
                }
            })
            .collect();
        Self {
            bvh: Some(bvh),
            prims,
            ids,
            build_time: start.elapsed(),
        }
    }

    #[inline(always)]
    fn leaf(&self, slot: usize, ray: &Ray, t_max: f32) -> Option<Hit> {
        let prim = self.ids[slot];
        match &self.prims[slot] {
            LeafPrim::Sphere(s) => s.intersect(ray, t_max).map(|t| Hit {
                t,
                prim,
                b1: 0.0,
                b2: 0.0,
            }),
            LeafPrim::Triangle(tri) => tri
                .intersect(ray, t_max)
                .map(|(t, b1, b2)| Hit { t, prim, b1, b2 }),
        }
    }
}

fn to_obvhs(ray: &Ray, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(ray.o.into(), ray.d.into(), 0.0, t_max)
}

impl Tracer for BvhTracer {
    fn id(&self) -> &'static str {
        "bvh"
    }

    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let mut best: Option<Hit> = None;
        let mut rh = obvhs::ray::RayHit::none();
        bvh.ray_traverse(to_obvhs(ray, t_max), &mut rh, |r, slot| {
            match self.leaf(slot, ray, r.tmax) {
                Some(h) => {
                    best = Some(h);
                    h.t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        !bvh.ray_traverse_miss(to_obvhs(ray, t_max), |_, slot| {
            self.leaf(slot, ray, t_max).map_or(f32::INFINITY, |h| h.t)
        })
    }
}
