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
/// `cargo bench --bench features` (256 camera rays, spheres; other builds running): brute vs
/// bvh 12.8/28.6 µs at 1 prim, 16.1/36.0 at 2, 7.4/19.4 at 4, 14.1/15.1 at 8, 35.1/12.7 at 16.
pub const BVH_MIN_PRIMS: usize = 8;

pub struct BvhTracer {
    bvh: Option<CwBvh>,
    /// Set when the scene is below [`BVH_MIN_PRIMS`]: primitives tested linearly instead.
    linear: Option<Geometry>,
    prims: Vec<LeafPrim>,
    /// Scene primitive id of each leaf slot.
    ids: Vec<u32>,
    pub build_time: Duration,
    /// Power of two mapping render space to the BVH's space (extent ≈ 1): exact scaling.
    k: f32,
}

/// obvhs culls node hits with `t < 1e-4` (a fixed epsilon, `cwbvh::node::EPSILON`) in units
/// of the ray direction, and clamps direction components below f32::EPSILON. So the BVH lives
/// in a space where the scene spans ≈ 2^16 (positions × `k`) and each traversal ray has a
/// direction of length ≈ 1 (× `m`): both powers of two, so exact. The cutoff then lies at
/// ≈ 1.5e-9 of the scene's extent at every scale. Without this a scene of size 1e-6
/// rendered black and, at size 1e6, shadow rays skipped anything within ~100 units.
const BVH_EXTENT_LOG2: f32 = 16.0;

/// Power of two that maps `extent` to about 2^16, clamped to a safe exponent range.
fn normaliser(extent: f32) -> f32 {
    if !(extent.is_finite() && extent > 0.0) {
        return 1.0;
    }
    let e = (BVH_EXTENT_LOG2 - extent.log2().ceil()).clamp(-100.0, 100.0) as i32;
    2f32.powi(e)
}

/// Power of two `m` with `|d|·m` in [1, 2) (by the largest component).
#[inline(always)]
fn unit_scale(d: glam::Vec3) -> f32 {
    let e = d.abs().max_element();
    let exp = ((e.to_bits() >> 23) & 0xff) as i32 - 127;
    if !(-120..=120).contains(&exp) {
        return 1.0;
    }
    f32::from_bits(((127 - exp) as u32) << 23)
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
                k: 1.0,
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
                k: 1.0,
            };
        }
        let extent = (0..geometry.len() as u32).fold(0.0f32, |m, p| {
            let (lo, hi) = geometry.prim_bounds(p);
            m.max(lo.abs().max_element()).max(hi.abs().max_element())
        });
        let k = normaliser(extent);
        let aabbs: Vec<Aabb> = (0..geometry.len() as u32)
            .map(|p| {
                let (lo, hi) = geometry.prim_bounds(p);
                Aabb::new((lo * k).into(), (hi * k).into())
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
            k,
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
            LeafPrim::Triangle(tri) => {
                tri.intersect(ray, t_max)
                    .map(|(t, b1, b2)| Hit { t, prim, b1, b2 })
            }
        }
    }
}

/// The traversal ray (origin × `k`, direction × `m`) and `q = k/m`: its `t` is the real `t`
/// times `q` (exact: powers of two).
#[inline(always)]
fn to_obvhs(ray: &Ray, t_max: f32, k: f32) -> (obvhs::ray::Ray, f32) {
    let m = unit_scale(ray.d);
    let q = k / m;
    let r = obvhs::ray::Ray::new((ray.o * k).into(), (ray.d * m).into(), 0.0, t_max * q);
    (r, q)
}

impl Tracer for BvhTracer {
    fn id(&self) -> &'static str {
        "bvh"
    }
    fn accelerated(&self) -> bool {
        self.uses_bvh()
    }

    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if let Some(g) = &self.linear {
            return linear_intersect(g, ray, t_max);
        }
        let bvh = self.bvh.as_ref()?;
        let mut best: Option<Hit> = None;
        let mut rh = obvhs::ray::RayHit::none();
        let (r, q) = to_obvhs(ray, t_max, self.k);
        bvh.ray_traverse(r, &mut rh, |r, slot| {
            match self.leaf(slot, ray, r.tmax / q) {
                Some(h) => {
                    best = Some(h);
                    h.t * q
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
        let (r, q) = to_obvhs(ray, t_max, self.k);
        !bvh.ray_traverse_miss(r, |_, slot| {
            self.leaf(slot, ray, t_max)
                .map_or(f32::INFINITY, |h| h.t * q)
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
