//! Native tracer: `obvhs` builds a binary BVH over every primitive's bounds (PLOC, reinsertion),
//! [`WideBvh`] collapses it by SAH into 8-wide nodes and leaves and traverses it; leaves
//! hold their triangles in packets of four ([`Triangle4`]) tested at once (a leaf of two
//! packets in one 8-lane test where the CPU has AVX2), and analytic spheres
//! one by one, with the shared routines of [`crate::core::geometry`], so hits agree bit for bit with
//! `brute`.

use super::bvh4::{CollapseCosts, WideBvh, PACKET, PAD};
use super::wide::{Isa, Leaves, Wide};
use super::Tracer;
use crate::core::geometry::{Hit, Hit4, Ray, ShearedRay, Sphere, Triangle, Triangle4};
use crate::core::scene::Geometry;
use obvhs::aabb::Aabb;
use obvhs::{Boundable, BvhBuildParams};
use std::time::Duration;

/// Four leaf slots: their triangles side by side and their scene primitive ids (spheres come
/// first in id order, so a slot holds a sphere where its id is below the sphere count).
///
/// The ids sit in the packet, on the cache lines its test has just read, so a hit needs no
/// second, scattered load from a slot-to-id table. 144 + 16 bytes: the same 160 as the sphere
/// mask they replace, padding included. Measured: M-101.
#[derive(Clone, Copy)]
struct Packet {
    tris: Triangle4,
    /// Scene primitive id per slot ([`PAD`] for an empty one).
    ids: [u32; PACKET],
}

impl Default for Packet {
    fn default() -> Self {
        Self {
            tris: Triangle4::default(),
            ids: [PAD; PACKET],
        }
    }
}

/// A triangle's box as obvhs reads it: [`Triangle::bounds`], as [`Geometry::prim_bounds`]
/// gives it.
impl Boundable for Triangle {
    #[inline(always)]
    fn aabb(&self) -> Aabb {
        let (lo, hi) = self.bounds();
        Aabb::new(lo.into(), hi.into())
    }
}

/// Below this many primitives a BVH costs more than it saves: the tracer then tests every
/// primitive in id order (exactly `brute`) and builds nothing. Above it the tree pays even on
/// the Cornell box's 36 triangles. Measured: M-102.
pub const BVH_MIN_PRIMS: usize = 4;

/// obvhs' `medium_build` (PLOC, reinsertion, leaves of ≤ 8 by SAH collapse) with the collapse's
/// node-to-primitive cost lowered from 3 to 2.5: our node test is cheap, and at 3 the Cornell
/// box's large overlapping triangles merged into big leaves. Merging a wide node's sibling
/// leaves into one packet did not pay and is not kept. Measured: M-103.
pub const BUILD_PARAMS: BvhBuildParams = {
    let mut p = BvhBuildParams::medium_build();
    p.collapse_traversal_cost = 2.5;
    p
};

/// From this many primitives on, [`BUILD_PARAMS_LARGE`]. Measured at the two ends only (36 and
/// 998 002 triangles); a scene between them takes the large-scene setting from here on.
pub const LARGE_SCENE_PRIMS: usize = 10_000;

/// [`BUILD_PARAMS`] with one primitive per binary leaf and no leaf collapse in obvhs (nor the
/// reinsertion pass after it): the SAH collapse into wide nodes ([`COLLAPSE_COSTS`]) then forms
/// the leaves too, which traces faster on the 1 M-triangle scene. Measured: M-104.
pub const BUILD_PARAMS_LARGE: BvhBuildParams = {
    let mut p = BUILD_PARAMS;
    p.max_prims_per_leaf = 1;
    p.post_collapse_reinsertion_batch_ratio_multiplier = 0.0;
    p
};

/// The SAH costs of the collapse into wide nodes and leaves (per unit of half area), used
/// where obvhs makes one-primitive leaves (the large scenes): a node test twice a leaf
/// packet's, two packets (one 8-lane test) 1.3×. The small scenes keep obvhs' leaves and the
/// greedy collapse, which renders the Cornell box faster. Measured: M-105.
pub const COLLAPSE_COSTS: CollapseCosts = CollapseCosts {
    node: 2.0,
    packet: 1.0,
    two_packets: 1.3,
};

/// The build parameters for a scene of `prims` primitives.
pub fn build_params(prims: usize) -> BvhBuildParams {
    if prims >= LARGE_SCENE_PRIMS {
        BUILD_PARAMS_LARGE
    } else {
        BUILD_PARAMS
    }
}

/// The native tracer: a [`WideBvh`] over the scene's primitives, or (from [`BvhTracer::new`], below
/// [`BVH_MIN_PRIMS`]) a linear list.
pub struct BvhTracer {
    bvh: Option<WideBvh>,
    /// Spheres in the scene: ids below it are spheres (0 for triangles only).
    sphere_count: u32,
    /// Set when the scene is below [`BVH_MIN_PRIMS`]: primitives tested linearly instead.
    linear: Option<Geometry>,
    /// The BVH's leaf slots four by four.
    packets: Vec<Packet>,
    /// The scene's spheres, by id (a slot's id below [`Self::sphere_count`]).
    spheres: Vec<Sphere>,
    /// Wall time of the build (zero for the linear list of [`BvhTracer::new`]).
    pub build_time: Duration,
}

impl BvhTracer {
    /// A BVH when the scene has at least [`BVH_MIN_PRIMS`] primitives, else a linear list.
    pub fn new(geometry: &Geometry) -> Self {
        if geometry.len() < BVH_MIN_PRIMS {
            return Self {
                bvh: None,
                sphere_count: 0,
                linear: Some(geometry.clone()),
                packets: Vec::new(),
                spheres: Vec::new(),
                build_time: Duration::ZERO,
            };
        }
        Self::with_params(geometry, build_params(geometry.len()))
    }

    /// Always a BVH, whatever the primitive count (for measuring the crossover).
    pub fn forced(geometry: &Geometry) -> Self {
        Self::with_params(geometry, build_params(geometry.len()))
    }

    /// Whether a BVH was built (false: too few primitives to be worth it, or none at all).
    pub fn uses_bvh(&self) -> bool {
        self.bvh.is_some()
    }

    /// Step the tree's node and leaf tests down to `isa` (`avx2` or `sse`) to compare paths in
    /// one process (the hits are the same bits: see the tests below); false where this CPU
    /// does not run `isa`, no tree was built, or `isa` names no path.
    pub fn step_down(&mut self, isa: &str) -> bool {
        let Some(bvh) = self.bvh.take() else {
            return false;
        };
        let to = match (isa, bvh.isa()) {
            ("sse", _) => Some(Isa::Portable),
            #[cfg(target_arch = "x86_64")]
            ("avx2", Isa::Avx512(t)) => Some(Isa::Avx2(t.0)),
            #[cfg(target_arch = "x86_64")]
            ("avx2", Isa::Avx2(t)) => Some(Isa::Avx2(t)),
            _ => None,
        };
        self.bvh = Some(match to {
            Some(to) => bvh.with_isa(to),
            None => bvh,
        });
        to.is_some()
    }

    /// The instruction set the tree's node and leaf tests run in (`avx512`, `avx2` or `sse`,
    /// chosen at build from the CPU), or `linear` where no tree was built.
    pub fn isa(&self) -> &'static str {
        self.bvh.as_ref().map_or("linear", |b| b.isa().id())
    }

    /// Always a BVH (none for empty geometry), built with obvhs parameters `params`.
    pub fn with_params(geometry: &Geometry, params: BvhBuildParams) -> Self {
        let start = std::time::Instant::now();
        if geometry.is_empty() {
            return Self {
                bvh: None,
                sphere_count: 0,
                linear: None,
                packets: Vec::new(),
                spheres: Vec::new(),
                build_time: start.elapsed(),
            };
        }
        let costs = (params.max_prims_per_leaf == 1).then_some(COLLAPSE_COSTS);
        // A scene of triangles only hands obvhs its triangles, whose boxes it reads once: no
        // array of boxes (32 bytes a primitive) lives through the build's peak. Measured: M-166.
        let bvh = if geometry.spheres.is_empty() {
            WideBvh::build(&geometry.triangles, params, costs)
        } else {
            let aabbs: Vec<Aabb> = (0..geometry.len() as u32)
                .map(|p| {
                    let (lo, hi) = geometry.prim_bounds(p);
                    Aabb::new(lo.into(), hi.into())
                })
                .collect();
            WideBvh::build(&aabbs, params, costs)
        };
        let ns = geometry.spheres.len() as u32;
        let packets = bvh
            .order
            .chunks_exact(PACKET)
            .map(|slots| {
                let mut packet = Packet::default();
                for (lane, &p) in slots.iter().enumerate() {
                    packet.ids[lane] = p;
                    if p != PAD && p >= ns {
                        packet
                            .tris
                            .set(lane, &geometry.triangles[(p - ns) as usize]);
                    }
                }
                packet
            })
            .collect();
        Self {
            bvh: Some(bvh),
            sphere_count: ns,
            linear: None,
            packets,
            spheres: geometry.spheres.clone(),
            build_time: start.elapsed(),
        }
    }

    /// The lanes of packet `p` that hold spheres (none, without a look at the ids, in a scene
    /// of triangles only).
    #[inline(always)]
    fn sphere_lanes(&self, p: &Packet) -> u32 {
        if self.sphere_count == 0 {
            return 0;
        }
        (0..PACKET).fold(0, |m, lane| {
            m | u32::from(p.ids[lane] < self.sphere_count) << lane
        })
    }

    /// Hits of packet `k` below `t_max`: per lane `t` (and barycentrics) and the mask of
    /// lanes that hit. Sphere lanes are tested one by one.
    #[inline(always)]
    fn packet(&self, k: usize, ray: &Ray, sheared: &ShearedRay, t_max: f32) -> Hit4 {
        let p = &self.packets[k];
        let mut h = p.tris.intersect_sheared(sheared, t_max);
        let mut spheres = self.sphere_lanes(p);
        while spheres != 0 {
            let lane = spheres.trailing_zeros() as usize;
            spheres &= spheres - 1;
            if let Some(t) = self.spheres[p.ids[lane] as usize].intersect(ray, t_max) {
                h.t[lane] = t;
                h.b1[lane] = 0.0;
                h.b2[lane] = 0.0;
                h.mask |= 1 << lane;
            }
        }
        h
    }

    /// Packets `k` and `k + 1` (a leaf of five to eight slots) in one 8-lane test: lanes 0–3
    /// are packet `k`'s. Against two 4-lane tests in a row (whose second one sees the first's
    /// nearest hit as `t_max`) the nearest lane, first of equals, is the same hit: a lane's
    /// result does not depend on `t_max` except through `t < t_max`. It pays with the bigger
    /// leaves of [`BUILD_PARAMS_LARGE`] (bvh/Embree 1024² primary 0.98–1.00 against 0.92–0.95
    /// without it); at cost 2.5, where few leaves have two packets, it was within noise.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn packets8(
        &self,
        lanes: super::wide::Lanes8,
        k: usize,
        ray: &Ray,
        sheared: &ShearedRay,
        t_max: f32,
    ) -> super::simd::Hit8 {
        let (p, q) = (&self.packets[k], &self.packets[k + 1]);
        let mut h = lanes.triangles8(&p.tris, &q.tris, sheared, t_max);
        let mut spheres = self.sphere_lanes(p) | self.sphere_lanes(q) << PACKET;
        while spheres != 0 {
            let lane = spheres.trailing_zeros() as usize;
            spheres &= spheres - 1;
            if let Some(t) = self.spheres[id8(p, q, lane) as usize].intersect(ray, t_max) {
                h.t[lane] = t;
                h.b1[lane] = 0.0;
                h.b2[lane] = 0.0;
                h.mask |= 1 << lane;
            }
        }
        h
    }
}

/// The scene id in lane `lane` of the eight lanes of packets `p` (lanes 0–3) and `q`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn id8(p: &Packet, q: &Packet, lane: usize) -> u32 {
    if lane < PACKET {
        p.ids[lane]
    } else {
        q.ids[lane - PACKET]
    }
}

/// [`nearest`] over the eight lanes of two packets `p` (lanes 0–3) and `q`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn nearest8(h: &super::simd::Hit8, p: &Packet, q: &Packet) -> Hit {
    let lane = nearest_lane(h.mask, &h.t);
    Hit {
        t: h.t[lane],
        prim: id8(p, q, lane),
        b1: h.b1[lane],
        b2: h.b2[lane],
    }
}

/// The nearest lane of `h` (the first of equals, as a one-by-one test in slot order keeps the
/// first of equal hits), as a hit on its scene primitive.
#[inline(always)]
fn nearest(h: &Hit4, packet: &Packet) -> Hit {
    let lane = nearest_lane(h.mask, h.t.as_ref());
    Hit {
        t: h.t[lane],
        prim: packet.ids[lane],
        b1: h.b1[lane],
        b2: h.b2[lane],
    }
}

/// The lane of `mask` (not empty) with the smallest `t`, the lowest of equals.
#[inline(always)]
fn nearest_lane(mask: u32, t: &[f32]) -> usize {
    let mut m = mask;
    let mut lane = m.trailing_zeros() as usize;
    m &= m - 1;
    while m != 0 {
        let l = m.trailing_zeros() as usize;
        m &= m - 1;
        if t[l] < t[lane] {
            lane = l;
        }
    }
    lane
}

impl Tracer for BvhTracer {
    fn id(&self) -> &'static str {
        super::TracerKind::Bvh.id()
    }
    fn accelerated(&self) -> bool {
        self.uses_bvh()
    }

    #[inline]
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if let Some(g) = &self.linear {
            return linear_intersect(g, ray, t_max);
        }
        self.intersect_tree(ray, t_max)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if let Some(g) = &self.linear {
            return (0..g.len() as u32).any(|p| g.intersect_prim(p, ray, t_max).is_some());
        }
        self.occluded_tree(ray, t_max)
    }
}

/// One query's view of the leaves: the ray, its shear and the tracer's packets.
struct Query<'a> {
    tracer: &'a BvhTracer,
    ray: &'a Ray,
    sheared: ShearedRay,
    /// The query's `t_max` (occlusion tests against it; closest hit passes its own).
    t_max: f32,
}

impl Leaves for Query<'_> {
    #[inline(always)]
    fn prefetch(&self, packets: std::ops::Range<usize>) {
        #[cfg(target_arch = "x86_64")]
        for k in packets {
            super::simd::prefetch(&self.tracer.packets[k]);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = packets;
    }

    #[inline(always)]
    fn closest(&self, packets: std::ops::Range<usize>, mut t_max: f32, wide: Wide) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let (Some(lanes), 2) = (wide, packets.len()) {
            let h = self
                .tracer
                .packets8(lanes, packets.start, self.ray, &self.sheared, t_max);
            let k = packets.start;
            return (h.mask != 0)
                .then(|| nearest8(&h, &self.tracer.packets[k], &self.tracer.packets[k + 1]));
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = wide;
        let mut best = None;
        for k in packets {
            let h = self.tracer.packet(k, self.ray, &self.sheared, t_max);
            if h.mask != 0 {
                let hit = nearest(&h, &self.tracer.packets[k]);
                t_max = hit.t;
                best = Some(hit);
            }
        }
        best
    }

    #[inline(always)]
    fn any(&self, packets: std::ops::Range<usize>, wide: Wide) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let (Some(lanes), 2) = (wide, packets.len()) {
            let h = self
                .tracer
                .packets8(lanes, packets.start, self.ray, &self.sheared, self.t_max);
            return h.mask != 0;
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = wide;
        for k in packets {
            let h = self.tracer.packet(k, self.ray, &self.sheared, self.t_max);
            if h.mask != 0 {
                return true;
            }
        }
        false
    }
}

impl BvhTracer {
    #[inline(always)]
    fn query<'a>(&'a self, ray: &'a Ray, t_max: f32) -> Query<'a> {
        Query {
            tracer: self,
            ray,
            sheared: ShearedRay::new(ray),
            t_max,
        }
    }

    /// Closest hit through the tree.
    ///
    /// The node test runs in AVX where the CPU has AVX2 ([`WideBvh::closest`]): compiling the
    /// SSE test a second time for AVX2 alone measured 0.92–1.13×, median 1.03×, of the
    /// portable rate (1 M triangles, 6 runs, quiet 2-core EPYC); one 8-lane register per plane
    /// instead of two 4-lane halves is what pays (measured in `WideBvh::closest`).
    #[inline(always)]
    fn intersect_tree(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        bvh.closest(ray, t_max, &self.query(ray, t_max))
    }

    /// Occlusion through the tree.
    #[inline(always)]
    fn occluded_tree(&self, ray: &Ray, t_max: f32) -> bool {
        self.bvh
            .as_ref()
            .is_some_and(|bvh| bvh.any(ray, t_max, &self.query(ray, t_max)))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::Sampler;
    use glam::Vec3;

    /// The 8-lane leaf test gives, lane by lane, the bits of the 4-lane one on each half: on
    /// triangles with vertices on a coarse grid (shared edges and vertices, rays through them:
    /// zero edge functions and the f64 path) and off it, with empty (NaN) lanes and finite and
    /// infinite `t_max`.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_lane_leaf_test_is_bit_identical_to_two_four_lane_tests() {
        let Some(avx2) = super::super::wide::Avx2::detect() else {
            eprintln!("no AVX2 on this CPU: the 8-lane test never runs here");
            return;
        };
        // The AVX-512 arm is compared where the CPU has it, and only that arm is skipped
        // where it does not.
        let avx512 = super::super::wide::Avx512::detect();
        if avx512.is_none() {
            eprintln!("no AVX-512 F+VL on this CPU: its 8-lane test is not compared here");
        }
        let mut wide_checked = 0;
        let mut s = Sampler::new(11, 0, 0);
        let (mut hits, mut exact) = (0, 0);
        for case in 0..6000 {
            let grid = case % 2 == 0;
            let mut p = || {
                let v = Vec3::new(s.next(), s.next(), s.next()) * 2.0 - Vec3::ONE;
                if grid {
                    (v * 4.0).round() / 4.0
                } else {
                    v
                }
            };
            let (mut a, mut b) = (Triangle4::default(), Triangle4::default());
            let used = 5 + case % 4;
            for lane in 0..used {
                let tri = Triangle::new(p(), p(), p());
                if lane < 4 {
                    a.set(lane, &tri);
                } else {
                    b.set(lane - 4, &tri);
                }
            }
            let o = p() * 3.0;
            let d = if case % 3 == 0 { p() - o } else { p() };
            let ray = Ray::new(o, d);
            let sr = ShearedRay::new(&ray);
            let t_max = [f32::INFINITY, 1.0, 0.5][case % 3];
            let h8 = avx2.triangles8(&a, &b, &sr, t_max);
            if let Some(avx512) = avx512 {
                let h = avx512.triangles8(&a, &b, &sr, t_max);
                assert_eq!(h.mask, h8.mask, "case {case}: AVX-512 against AVX2");
                for l in (0..8).filter(|l| h.mask >> l & 1 == 1) {
                    let bits = |h: &crate::core::tracer::simd::Hit8| {
                        (h.t[l].to_bits(), h.b1[l].to_bits(), h.b2[l].to_bits())
                    };
                    assert_eq!(bits(&h), bits(&h8), "case {case} lane {l}: AVX-512");
                }
                wide_checked += 1;
            }
            for (half, t4) in [a, b].iter().enumerate() {
                let h4 = t4.intersect_sheared(&sr, t_max);
                for lane in 0..4 {
                    let l8 = 4 * half + lane;
                    let bits = |t: f32, b1: f32, b2: f32| (t.to_bits(), b1.to_bits(), b2.to_bits());
                    let four = (h4.mask >> lane & 1 == 1)
                        .then(|| bits(h4.t[lane], h4.b1[lane], h4.b2[lane]));
                    let eight =
                        (h8.mask >> l8 & 1 == 1).then(|| bits(h8.t[l8], h8.b1[l8], h8.b2[l8]));
                    assert_eq!(four, eight, "case {case} lane {l8}");
                    hits += four.is_some() as u32;
                    exact += (grid && four.is_some()) as u32;
                }
            }
        }
        assert!(
            hits > 1000 && exact > 200,
            "{hits} hits, {exact} on the grid"
        );
        assert_eq!(wide_checked, if avx512.is_some() { 6000 } else { 0 });
    }

    /// The AVX and the SSE node tests enter the same children in the same order, and the
    /// cache hints of a large tree (forced on here) change nothing: every hit (prim, t,
    /// barycentrics) and occlusion verdict is bit-identical, on random rays and on rays with
    /// zero direction components (the clamped reciprocal), through triangle soup and spheres.
    #[test]
    fn simd_and_portable_node_tests_agree_exactly() {
        let mut s = Sampler::new(7, 0, 0);
        let mut p = move || Vec3::new(s.next(), s.next(), s.next()) * 8.0 - Vec3::splat(4.0);
        let triangles: Vec<Triangle> = (0..3000)
            .map(|_| {
                let c = p();
                Triangle::new(c, c + p() * 0.1, c + p() * 0.1)
            })
            .collect();
        let spheres = (0..40)
            .map(|_| Sphere {
                center: p(),
                radius: 0.05 + p().x.abs() * 0.05,
            })
            .collect();
        let geometry = Geometry {
            spheres,
            triangles,
            info: Vec::new(),
        };
        let simd = BvhTracer::new(&geometry);
        let mut hinted = BvhTracer::new(&geometry);
        hinted.bvh = hinted.bvh.map(|b| b.with_prefetch(true));
        let mut portable = BvhTracer::new(&geometry);
        portable.bvh = portable.bvh.map(WideBvh::without_simd);
        assert!(matches!(
            portable.bvh.as_ref().unwrap().isa(),
            Isa::Portable
        ));
        // Every ISA this CPU runs below its best, each against the best: AVX2 where the best
        // is AVX-512 (skipped only where the CPU lacks AVX-512), and the portable test.
        let mut lower = vec![portable];
        #[cfg(target_arch = "x86_64")]
        if let Isa::Avx512(t) = simd.bvh.as_ref().unwrap().isa() {
            let mut avx2 = BvhTracer::new(&geometry);
            avx2.bvh = avx2.bvh.map(|b| b.with_isa(Isa::Avx2(t.0)));
            lower.push(avx2);
        } else {
            eprintln!("no AVX-512 on this CPU: AVX-512 against AVX2 is not compared here");
        }
        let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let mut q = Sampler::new(8, 0, 0);
        let (mut hits, mut blocked) = (0, 0);
        for i in 0..20_000 {
            let o = p() * 1.5;
            let d = if i % 5 == 0 {
                axis[i % 6]
            } else {
                Vec3::new(q.next() - 0.5, q.next() - 0.5, q.next() - 0.5)
            };
            let ray = Ray::new(o, d);
            let t_max = if i % 3 == 0 {
                f32::INFINITY
            } else {
                4.0 * q.next()
            };
            let a = simd.intersect(&ray, t_max);
            let b = simd.occluded(&ray, t_max);
            for other in &lower {
                let isa = other.bvh.as_ref().unwrap().isa().id();
                assert_eq!(a, other.intersect(&ray, t_max), "ray {i}, {isa}");
                assert_eq!(b, other.occluded(&ray, t_max), "ray {i}, {isa}");
            }
            assert_eq!(a, hinted.intersect(&ray, t_max), "ray {i}");
            assert_eq!(b, hinted.occluded(&ray, t_max), "ray {i}");
            assert_eq!(b, a.is_some(), "ray {i}");
            hits += a.is_some() as u32;
            blocked += b as u32;
        }
        // Both outcomes occur, else the comparison says little.
        assert!(hits > 2000 && hits < 18_000, "{hits}");
        assert_eq!(hits, blocked);
    }
}
