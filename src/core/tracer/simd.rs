//! The tracer's one module with `unsafe`: the BVH node test on eight child boxes at once in
//! AVX registers, the watertight triangle test on a leaf's eight slots at once, the
//! traversal copies compiled for AVX2 and for AVX-512 (F + VL) that run them, and a cache
//! hint ([`prefetch`], SSE: every x86-64 CPU has it). The code is chosen at run time
//! ([`super::wide::Isa::detect`], `is_x86_feature_detected!`): AVX-512 where the CPU has it,
//! else AVX2, so the shipped build keeps the generic x86-64 target and runs anywhere; without
//! AVX2 the SSE test of [`super::wide`] runs. The AVX-512 copies keep eight lanes (a node
//! has eight children, a leaf at most eight slots): what they add is 32 registers, compares
//! straight into mask registers and the rare exact edge functions redone in eight f64 lanes
//! at once.
//!
//! The AVX test performs, lane by lane, the IEEE operations of the SSE one in the same order
//! (subtract, multiply, `max`/`min` with the same operand order, no fused multiply-add), so
//! both enter the same children in the same order and images do not depend on the CPU.

use super::wide::{Avx2, Avx512, Lanes8, Leaves, Node, NodeTest, RaySlabs, Traverse, Wide, WIDTH};
use crate::core::geometry::{gamma, Hit, Ray, ShearedRay, Triangle4};
use std::arch::x86_64::{
    __m256, _mm256_add_ps, _mm256_and_ps, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_div_ps,
    _mm256_loadu2_m128, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_or_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps,
    _mm256_storeu_ps, _mm256_sub_ps, _mm_prefetch, _CMP_EQ_OQ, _CMP_GT_OS, _CMP_LE_OQ, _CMP_LT_OS,
    _CMP_NEQ_UQ, _MM_HINT_T0,
};
use std::arch::x86_64::{
    _mm256_cmp_ps_mask, _mm256_mask_blend_ps, _mm512_cvtpd_ps, _mm512_cvtps_pd, _mm512_mul_pd,
    _mm512_sub_pd,
};

/// The AVX2 code that the token ([`Avx2`], made by [`Avx2::detect`]) unlocks.
impl Avx2 {
    /// [`super::bvh4::WideBvh::closest`] with the AVX node test.
    #[inline(always)]
    pub(super) fn closest(
        self,
        bvh: &impl Traverse,
        ray: &Ray,
        t_max: f32,
        leaves: &impl Leaves,
    ) -> Option<Hit> {
        // SAFETY: an `Avx2` exists only where `detect` found AVX2, all `closest_avx2` needs.
        unsafe { closest_avx2(bvh, ray, t_max, leaves, self) }
    }

    /// [`Triangle4::intersect_sheared`] on two packets at once, `a` in lanes 0–3 and `b` in
    /// lanes 4–7: every lane runs the same IEEE operations in the same order (compare
    /// predicates as SSE's `cmpps`: `neq` unordered, so a NaN lane agrees too), so a lane's `t`,
    /// barycentrics and verdict are bit-identical to the 4-lane test's.
    #[inline(always)]
    pub(super) fn triangles8(
        self,
        a: &Triangle4,
        b: &Triangle4,
        r: &ShearedRay,
        t_max: f32,
    ) -> Hit8 {
        // SAFETY: the token proves AVX2 (and so AVX).
        unsafe { triangles8(a, b, r, t_max) }
    }

    /// [`super::bvh4::WideBvh::any`] with the AVX node test.
    #[inline(always)]
    pub(super) fn any(
        self,
        bvh: &impl Traverse,
        ray: &Ray,
        t_max: f32,
        leaves: &impl Leaves,
    ) -> bool {
        // SAFETY: as in `closest`: the token proves AVX2.
        unsafe { any_avx2(bvh, ray, t_max, leaves, self) }
    }
}

/// The traversal and leaf tests, inlined into a copy compiled for AVX2.
#[target_feature(enable = "avx2")]
fn closest_avx2(
    bvh: &impl Traverse,
    ray: &Ray,
    t_max: f32,
    leaves: &impl Leaves,
    avx2: Avx2,
) -> Option<Hit> {
    bvh.closest_with(&Slabs8::new(ray, avx2), t_max, leaves)
}

/// As [`closest_avx2`], for occlusion.
#[target_feature(enable = "avx2")]
fn any_avx2(bvh: &impl Traverse, ray: &Ray, t_max: f32, leaves: &impl Leaves, avx2: Avx2) -> bool {
    bvh.any_with(&Slabs8::new(ray, avx2), t_max, leaves)
}

/// What [`Avx2::triangles8`] found: per lane `t` and barycentrics (meaningful where `mask`
/// is set) and the lanes that hit.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Hit8 {
    pub(super) t: [f32; 8],
    pub(super) b1: [f32; 8],
    pub(super) b2: [f32; 8],
    pub(super) mask: u32,
}

/// The body of [`Avx2::triangles8`], op for op [`Triangle4::intersect_sheared`]. Inlined into
/// the AVX2 traversal copies (no call and no `vzeroupper` per leaf) it retires fewer
/// instructions. Whether it is inlined is the optimiser's choice (`#[inline]` is a hint, and
/// `#[inline(always)]` does not combine with `#[target_feature]`); forcing it, or writing it
/// with macros instead of closures, cost more. Measured: M-111.
#[inline]
#[target_feature(enable = "avx2")]
fn triangles8(p: &Triangle4, q: &Triangle4, r: &ShearedRay, t_max: f32) -> Hit8 {
    let [kx, ky, kz] = r.k;
    let splat = |v: f32| _mm256_set1_ps(v);
    // SAFETY (every block below): AVX is enabled in this function; each `loadu2` reads two
    // `Vec4`s (4 f32 each, through their `[f32; 4]` view) and each store writes 8 f32 into an
    // `[f32; 8]`.
    let load = |i: usize, axis: usize| unsafe {
        _mm256_loadu2_m128(
            q.v[i][axis].as_ref().as_ptr(),
            p.v[i][axis].as_ref().as_ptr(),
        )
    };
    let o = [r.o.x, r.o.y, r.o.z].map(splat);
    let (sx, sy, sz) = (splat(r.s.x), splat(r.s.y), splat(r.s.z));
    let sub = |x, y| _mm256_sub_ps(x, y);
    let mul = |x, y| _mm256_mul_ps(x, y);
    let add = |x, y| _mm256_add_ps(x, y);
    let max = |x, y| _mm256_max_ps(x, y);
    let abs = |x| _mm256_and_ps(x, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
    let rel = |i: usize| {
        (
            sub(load(i, kx), o[kx]),
            sub(load(i, ky), o[ky]),
            sub(load(i, kz), o[kz]),
        )
    };
    let (a_x, a_y, a_z) = rel(0);
    let (b_x, b_y, b_z) = rel(1);
    let (c_x, c_y, c_z) = rel(2);
    let (ax, ay) = (sub(a_x, mul(sx, a_z)), sub(a_y, mul(sy, a_z)));
    let (bx, by) = (sub(b_x, mul(sx, b_z)), sub(b_y, mul(sy, b_z)));
    let (cx, cy) = (sub(c_x, mul(sx, c_z)), sub(c_y, mul(sy, c_z)));
    let mut u = sub(mul(cx, by), mul(cy, bx));
    let mut v = sub(mul(ax, cy), mul(ay, cx));
    let mut w = sub(mul(bx, ay), mul(by, ax));
    let zero = _mm256_setzero_ps();
    let eq0 = |x| _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero);
    let exact = _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(eq0(u), eq0(v)), eq0(w)));
    if exact != 0 {
        [u, v, w] = exact_edges(exact as u32, [ax, ay, bx, by, cx, cy], [u, v, w]);
    }
    let lt = |x, y| _mm256_cmp_ps::<_CMP_LT_OS>(x, y);
    let gt = |x, y| _mm256_cmp_ps::<_CMP_GT_OS>(x, y);
    let or3 = |x, y, z| _mm256_or_ps(_mm256_or_ps(x, y), z);
    let neg = or3(lt(u, zero), lt(v, zero), lt(w, zero));
    let pos = or3(gt(u, zero), gt(v, zero), gt(w, zero));
    let det = add(add(u, v), w);
    let mut ok = !_mm256_movemask_ps(_mm256_and_ps(neg, pos))
        & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero))
        & _mm256_movemask_ps(lt(abs(det), splat(f32::INFINITY)));
    ok &= 0xff;
    let mut hit = Hit8::default();
    if ok == 0 {
        return hit;
    }
    let (az, bz, cz) = (mul(a_z, sz), mul(b_z, sz), mul(c_z, sz));
    let t_scaled = add(add(mul(u, az), mul(v, bz)), mul(w, cz));
    let inv_det = _mm256_div_ps(splat(1.0), det);
    let t = mul(t_scaled, inv_det);
    ok &= _mm256_movemask_ps(_mm256_and_ps(gt(t, zero), lt(t, splat(t_max))));
    if ok == 0 {
        return hit;
    }
    let max3 = |x, y, z| max(max(abs(x), abs(y)), abs(z));
    let max_z = max3(az, bz, cz);
    let (max_x, max_y) = (max3(ax, bx, cx), max3(ay, by, cy));
    let max_z_len = max3(a_z, b_z, c_z);
    let delta_z = mul(splat(gamma(3)), max_z);
    let delta_x = mul(splat(gamma(5)), add(max_x, max_z_len));
    let delta_y = mul(splat(gamma(5)), add(max_y, max_z_len));
    let delta_e = mul(
        splat(2.0),
        add(
            add(mul(mul(splat(gamma(2)), max_x), max_y), mul(delta_y, max_x)),
            mul(delta_x, max_y),
        ),
    );
    let max_e = max3(u, v, w);
    let delta_t = mul(
        mul(
            splat(3.0),
            add(
                add(mul(mul(splat(gamma(3)), max_e), max_z), mul(delta_e, max_z)),
                mul(delta_z, max_e),
            ),
        ),
        abs(inv_det),
    );
    ok &= _mm256_movemask_ps(gt(t, delta_t));
    hit.mask = ok as u32;
    if ok != 0 {
        // SAFETY: see above.
        unsafe {
            _mm256_storeu_ps(hit.t.as_mut_ptr(), t);
            _mm256_storeu_ps(hit.b1.as_mut_ptr(), mul(v, inv_det));
            _mm256_storeu_ps(hit.b2.as_mut_ptr(), mul(w, inv_det));
        }
    }
    hit
}

/// The edge functions `[u, v, w]` recomputed in f64 in the `lanes` (a bit mask) where one of
/// them came out exactly 0 in f32, from the sheared vertices `[ax, ay, bx, by, cx, cy]`: the
/// rare path of [`triangles8`], kept out of its body.
#[cold]
#[target_feature(enable = "avx2")]
fn exact_edges(mut lanes: u32, xy: [__m256; 6], uvw: [__m256; 3]) -> [__m256; 3] {
    let arr = |x| {
        let mut a = [0.0f32; 8];
        // SAFETY: AVX is enabled in this function; the store writes 8 f32 into an `[f32; 8]`.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), x) };
        a
    };
    let [ax_, ay_, bx_, by_, cx_, cy_] = xy.map(arr);
    let [mut ua, mut va, mut wa] = uvw.map(arr);
    let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
    while lanes != 0 {
        let l = lanes.trailing_zeros() as usize;
        lanes &= lanes - 1;
        ua[l] = f(cx_[l], by_[l], cy_[l], bx_[l]);
        va[l] = f(ax_[l], cy_[l], ay_[l], cx_[l]);
        wa[l] = f(bx_[l], ay_[l], by_[l], ax_[l]);
    }
    // SAFETY: AVX is enabled in this function; each load reads 8 f32 from an `[f32; 8]`.
    unsafe {
        [
            _mm256_loadu_ps(ua.as_ptr()),
            _mm256_loadu_ps(va.as_ptr()),
            _mm256_loadu_ps(wa.as_ptr()),
        ]
    }
}

/// A ray's slabs with every coordinate broadcast to eight AVX lanes. Made only inside
/// [`closest_avx2`] and [`any_avx2`], so its methods run only where AVX is present.
///
/// The slab test stays subtract then multiply: one fused `b·inv − o·inv` per plane (AVX2 +
/// FMA, o·inv rounded outward so that no box is culled) ran slower. Measured: M-112.
struct Slabs8(RaySlabs<__m256>, Avx2);

impl Slabs8 {
    #[inline(always)]
    fn new(ray: &Ray, avx2: Avx2) -> Self {
        // SAFETY: called only from the AVX2 copies above (see the type's note).
        Self(RaySlabs::with(ray, |v| unsafe { _mm256_set1_ps(v) }), avx2)
    }
}

impl NodeTest for Slabs8 {
    #[inline(always)]
    fn wide(&self) -> Wide {
        Some(Lanes8::Avx2(self.1))
    }

    #[inline(always)]
    fn hit(&self, n: &Node, t_max: f32) -> ([f32; WIDTH], u32) {
        let s = &self.0;
        let mut entry = [0.0; WIDTH];
        // SAFETY: AVX is present (a `Slabs8` exists only inside the AVX2 copies); each load
        // reads one plane, `WIDTH` = 8 f32, and the store writes `entry`'s 8 f32.
        let mask = unsafe {
            let mut t0 = _mm256_setzero_ps();
            let mut t1 = _mm256_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let near = _mm256_loadu_ps(n.planes[s.near[a]].as_ptr());
                let far = _mm256_loadu_ps(n.planes[s.far[a]].as_ptr());
                t0 = _mm256_max_ps(t0, _mm256_mul_ps(_mm256_sub_ps(near, s.o[a]), s.inv[a]));
                t1 = _mm256_min_ps(t1, _mm256_mul_ps(_mm256_sub_ps(far, s.o[a]), s.inv_far[a]));
            }
            let far = _mm256_min_ps(t1, _mm256_set1_ps(t_max));
            _mm256_storeu_ps(entry.as_mut_ptr(), t0);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, far)) as u32
        };
        (entry, mask)
    }
}

impl Lanes8 {
    /// The 8-lane leaf test of the traversal copy that holds this token: bit for bit the same
    /// in either arm.
    #[inline(always)]
    pub(super) fn triangles8(
        self,
        a: &Triangle4,
        b: &Triangle4,
        r: &ShearedRay,
        t_max: f32,
    ) -> Hit8 {
        match self {
            Self::Avx2(t) => t.triangles8(a, b, r, t_max),
            Self::Avx512(t) => t.triangles8(a, b, r, t_max),
        }
    }
}

/// The AVX-512 code that the token ([`Avx512`], made by [`Avx512::detect`]) unlocks: the
/// traversal of [`Avx2`] compiled with AVX-512 F + VL (32 vector registers, compares into
/// mask registers), and its own node and leaf tests. Every lane runs the IEEE operations of
/// the AVX2 (and so of the SSE) test in the same order, so hits are bit-identical.
impl Avx512 {
    /// [`super::bvh4::WideBvh::closest`] with the AVX-512 node test.
    #[inline(always)]
    pub(super) fn closest(
        self,
        bvh: &impl Traverse,
        ray: &Ray,
        t_max: f32,
        leaves: &impl Leaves,
    ) -> Option<Hit> {
        // SAFETY: an `Avx512` exists only where `detect` found AVX2, AVX-512 F and VL.
        unsafe { closest_avx512(bvh, ray, t_max, leaves, self) }
    }

    /// [`super::bvh4::WideBvh::any`] with the AVX-512 node test.
    #[inline(always)]
    pub(super) fn any(
        self,
        bvh: &impl Traverse,
        ray: &Ray,
        t_max: f32,
        leaves: &impl Leaves,
    ) -> bool {
        // SAFETY: as in `closest`.
        unsafe { any_avx512(bvh, ray, t_max, leaves, self) }
    }

    /// [`Avx2::triangles8`] with compares into mask registers.
    #[inline(always)]
    pub(super) fn triangles8(
        self,
        a: &Triangle4,
        b: &Triangle4,
        r: &ShearedRay,
        t_max: f32,
    ) -> Hit8 {
        // SAFETY: the token proves AVX-512 F and VL (and AVX2).
        unsafe { triangles8_avx512(a, b, r, t_max) }
    }
}

/// The traversal and leaf tests, inlined into a copy compiled for AVX-512.
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn closest_avx512(
    bvh: &impl Traverse,
    ray: &Ray,
    t_max: f32,
    leaves: &impl Leaves,
    isa: Avx512,
) -> Option<Hit> {
    bvh.closest_with(&Slabs8x::new(ray, isa), t_max, leaves)
}

/// As [`closest_avx512`], for occlusion.
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn any_avx512(
    bvh: &impl Traverse,
    ray: &Ray,
    t_max: f32,
    leaves: &impl Leaves,
    isa: Avx512,
) -> bool {
    bvh.any_with(&Slabs8x::new(ray, isa), t_max, leaves)
}

/// [`triangles8`] with its compares into mask registers (no `movemask`, no vector `or`/`and`
/// of compare results) and the exact recomputation of zero edge functions in eight f64 lanes
/// at once: `(p·q − r·s)` of f32 inputs in f64, whose products are exact, rounded once to f64
/// and once to f32 (round to nearest, as `as f32`), as the scalar fallback does lane by lane.
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn triangles8_avx512(p: &Triangle4, q: &Triangle4, r: &ShearedRay, t_max: f32) -> Hit8 {
    let [kx, ky, kz] = r.k;
    let splat = |v: f32| _mm256_set1_ps(v);
    // SAFETY (every block below): AVX-512 F + VL is enabled in this function; each `loadu2`
    // reads two `Vec4`s (4 f32 each, through their `[f32; 4]` view) and each store writes 8
    // f32 into an `[f32; 8]`.
    let load = |i: usize, axis: usize| unsafe {
        _mm256_loadu2_m128(
            q.v[i][axis].as_ref().as_ptr(),
            p.v[i][axis].as_ref().as_ptr(),
        )
    };
    let o = [r.o.x, r.o.y, r.o.z].map(splat);
    let (sx, sy, sz) = (splat(r.s.x), splat(r.s.y), splat(r.s.z));
    let sub = |x, y| _mm256_sub_ps(x, y);
    let mul = |x, y| _mm256_mul_ps(x, y);
    let add = |x, y| _mm256_add_ps(x, y);
    let max = |x, y| _mm256_max_ps(x, y);
    let abs = |x| _mm256_and_ps(x, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
    let rel = |i: usize| {
        (
            sub(load(i, kx), o[kx]),
            sub(load(i, ky), o[ky]),
            sub(load(i, kz), o[kz]),
        )
    };
    let (a_x, a_y, a_z) = rel(0);
    let (b_x, b_y, b_z) = rel(1);
    let (c_x, c_y, c_z) = rel(2);
    let (ax, ay) = (sub(a_x, mul(sx, a_z)), sub(a_y, mul(sy, a_z)));
    let (bx, by) = (sub(b_x, mul(sx, b_z)), sub(b_y, mul(sy, b_z)));
    let (cx, cy) = (sub(c_x, mul(sx, c_z)), sub(c_y, mul(sy, c_z)));
    let mut u = sub(mul(cx, by), mul(cy, bx));
    let mut v = sub(mul(ax, cy), mul(ay, cx));
    let mut w = sub(mul(bx, ay), mul(by, ax));
    let zero = _mm256_setzero_ps();
    let eq0 = |x| _mm256_cmp_ps_mask::<_CMP_EQ_OQ>(x, zero);
    let exact = eq0(u) | eq0(v) | eq0(w);
    if exact != 0 {
        let f = |p, q, r, s| {
            let wide = |x| _mm512_cvtps_pd(x);
            let d = _mm512_sub_pd(
                _mm512_mul_pd(wide(p), wide(q)),
                _mm512_mul_pd(wide(r), wide(s)),
            );
            _mm512_cvtpd_ps(d)
        };
        u = _mm256_mask_blend_ps(exact, u, f(cx, by, cy, bx));
        v = _mm256_mask_blend_ps(exact, v, f(ax, cy, ay, cx));
        w = _mm256_mask_blend_ps(exact, w, f(bx, ay, by, ax));
    }
    let lt = |x, y| _mm256_cmp_ps_mask::<_CMP_LT_OS>(x, y);
    let gt = |x, y| _mm256_cmp_ps_mask::<_CMP_GT_OS>(x, y);
    let neg = lt(u, zero) | lt(v, zero) | lt(w, zero);
    let pos = gt(u, zero) | gt(v, zero) | gt(w, zero);
    let det = add(add(u, v), w);
    let mut ok = !(neg & pos)
        & _mm256_cmp_ps_mask::<_CMP_NEQ_UQ>(det, zero)
        & lt(abs(det), splat(f32::INFINITY));
    let mut hit = Hit8::default();
    if ok == 0 {
        return hit;
    }
    let (az, bz, cz) = (mul(a_z, sz), mul(b_z, sz), mul(c_z, sz));
    let t_scaled = add(add(mul(u, az), mul(v, bz)), mul(w, cz));
    let inv_det = _mm256_div_ps(splat(1.0), det);
    let t = mul(t_scaled, inv_det);
    ok &= gt(t, zero) & lt(t, splat(t_max));
    if ok == 0 {
        return hit;
    }
    let max3 = |x, y, z| max(max(abs(x), abs(y)), abs(z));
    let max_z = max3(az, bz, cz);
    let max_x = max3(ax, bx, cx);
    let max_y = max3(ay, by, cy);
    let max_z_len = max3(a_z, b_z, c_z);
    let delta_z = mul(splat(gamma(3)), max_z);
    let delta_x = mul(splat(gamma(5)), add(max_x, max_z_len));
    let delta_y = mul(splat(gamma(5)), add(max_y, max_z_len));
    let delta_e = mul(
        splat(2.0),
        add(
            add(mul(mul(splat(gamma(2)), max_x), max_y), mul(delta_y, max_x)),
            mul(delta_x, max_y),
        ),
    );
    let max_e = max3(u, v, w);
    let delta_t = mul(
        mul(
            splat(3.0),
            add(
                add(mul(mul(splat(gamma(3)), max_e), max_z), mul(delta_e, max_z)),
                mul(delta_z, max_e),
            ),
        ),
        abs(inv_det),
    );
    ok &= gt(t, delta_t);
    hit.mask = u32::from(ok);
    if ok != 0 {
        // SAFETY: see above.
        unsafe {
            _mm256_storeu_ps(hit.t.as_mut_ptr(), t);
            _mm256_storeu_ps(hit.b1.as_mut_ptr(), mul(v, inv_det));
            _mm256_storeu_ps(hit.b2.as_mut_ptr(), mul(w, inv_det));
        }
    }
    hit
}

/// [`Slabs8`] for the AVX-512 copies: the same slab arithmetic, the mask compared straight
/// into a mask register. Made only inside [`closest_avx512`] and [`any_avx512`].
struct Slabs8x(RaySlabs<__m256>, Avx512);

impl Slabs8x {
    #[inline(always)]
    fn new(ray: &Ray, isa: Avx512) -> Self {
        // SAFETY: called only from the AVX-512 copies above (see the type's note).
        Self(RaySlabs::with(ray, |v| unsafe { _mm256_set1_ps(v) }), isa)
    }
}

impl NodeTest for Slabs8x {
    #[inline(always)]
    fn wide(&self) -> Wide {
        Some(Lanes8::Avx512(self.1))
    }

    #[inline(always)]
    fn hit(&self, n: &Node, t_max: f32) -> ([f32; WIDTH], u32) {
        let s = &self.0;
        let mut entry = [0.0; WIDTH];
        // SAFETY: AVX-512 F + VL is present (a `Slabs8x` exists only inside the AVX-512
        // copies); each load reads one plane, `WIDTH` = 8 f32, and the store writes `entry`'s
        // 8 f32.
        let mask = unsafe {
            let mut t0 = _mm256_setzero_ps();
            let mut t1 = _mm256_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let near = _mm256_loadu_ps(n.planes[s.near[a]].as_ptr());
                let far = _mm256_loadu_ps(n.planes[s.far[a]].as_ptr());
                t0 = _mm256_max_ps(t0, _mm256_mul_ps(_mm256_sub_ps(near, s.o[a]), s.inv[a]));
                t1 = _mm256_min_ps(t1, _mm256_mul_ps(_mm256_sub_ps(far, s.o[a]), s.inv_far[a]));
            }
            let far = _mm256_min_ps(t1, _mm256_set1_ps(t_max));
            _mm256_storeu_ps(entry.as_mut_ptr(), t0);
            u32::from(_mm256_cmp_ps_mask::<_CMP_LE_OQ>(t0, far))
        };
        (entry, mask)
    }
}

/// Ask for every cache line of `x` ahead of its use: a hint, which reads nothing, cannot
/// fault and changes no value (SSE, so every x86-64 CPU has it).
#[inline(always)]
pub(super) fn prefetch<T>(x: &T) {
    let p = (x as *const T).cast::<i8>();
    for line in 0..size_of::<T>().div_ceil(64) {
        // SAFETY: a prefetch dereferences nothing; the address lies within `x`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line)) };
    }
}
