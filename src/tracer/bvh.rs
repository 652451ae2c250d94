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

/// Below this many primitives a BVH costs more than it saves: the tracer then tests every
/// primitive in id order (exactly `brute`) and builds nothing. Measured with
/// `cargo bench --bench features` (see that file for the numbers).
pub const BVH_MIN_PRIMS: usize = 8;

pub struct BvhTracer {
    bvh: Option<CwBvh>,
    /// Set when the scene is below [`BVH_MIN_PRIMS`]: primitives tested linearly instead.
    linear: Option<Geometry>,
    prims: Vec<LeafPrim>,
    /// Scene primitive id of each leaf slot.
    ids: Vec<u32>,
    pub build_time: Duration,
}

impl BvhTracer {
    /// A BVH when the scene has at least [`BVH_MIN_PRIMS`] primitives, else a linear list.
    pub fn new(geometry: &Geometry) -> Self {
        if geometry.len() < BVH_MIN_PRIMS {
            return Self {
                bvh: None,
                linear: Some(geometry.clone()),
                prims: Vec::new(),
                ids: Vec::new(),
                build_time: Duration::ZERO,
            };
        }
        Self::with_params(geometry, BvhBuildParams::medium_build())
    }

    /// Always a BVH, whatever the primitive count (for measuring the crossover).
    pub fn forced(geometry: &Geometry) -> Self {
        Self::with_params(geometry, BvhBuildParams::medium_build())
    }

    /// Whether a BVH was built (false: too few primitives to be worth it, or none at all).
    pub fn uses_bvh(&self) -> bool {
        self.bvh.is_some()
    }

    pub fn with_params(geometry: &Geometry, params: BvhBuildParams) -> Self {
        let start = std::time::Instant::now();
        if geometry.is_empty() {
            return Self {
                bvh: None,
                linear: None,
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
            linear: None,
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
        if let Some(g) = &self.linear {
            return linear_intersect(g, ray, t_max);
        }
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
        if let Some(g) = &self.linear {
            return (0..g.len() as u32).any(|p| g.intersect_prim(p, ray, t_max).is_some());
        }
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        !bvh.ray_traverse_miss(to_obvhs(ray, t_max), |_, slot| {
            self.leaf(slot, ray, t_max).map_or(f32::INFINITY, |h| h.t)
        })
    }
}

/// Closest hit over every primitive in id order (what `brute` does).
#[inline]
fn linear_intersect(g: &Geometry, ray: &Ray, t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut t_max = t_max;
    for p in 0..g.len() as u32 {
        if let Some(h) = g.intersect_prim(p, ray, t_max) {
            t_max = h.t;
            best = Some(h);
        }
    }
    best
}
