//! The tracer's one module with `unsafe`: the BVH node test on eight child boxes at once in
//! AVX registers, and the traversal copies compiled for AVX2 that run it. They are chosen at
//! run time ([`Avx2::detect`], `is_x86_feature_detected!`), so the shipped build keeps the
//! generic x86-64 target and runs anywhere; without AVX2 the SSE test of [`super::bvh4`] runs.
//!
//! The AVX test performs, lane by lane, the IEEE operations of the SSE one in the same order
//! (subtract, multiply, `max`/`min` with the same operand order, no fused multiply-add), so
//! both enter the same children in the same order and images do not depend on the CPU.

use super::bvh4::{Leaves, Node, NodeTest, RaySlabs, WideBvh, FAR_SCALE, WIDTH};
use crate::geometry::{Hit, Ray};
use std::arch::x86_64::{
    __m256, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps, _CMP_LE_OQ,
};

/// Proof that this CPU has AVX2 (and so AVX): only [`Avx2::detect`] makes one.
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx2(());

impl Avx2 {
    /// `Some` where the CPU (and OS) support AVX2.
    pub(super) fn detect() -> Option<Self> {
        is_x86_feature_detected!("avx2").then_some(Self(()))
    }

    /// [`WideBvh::closest`] with the AVX node test.
    #[inline(always)]
    pub(super) fn closest(
        self,
        bvh: &WideBvh,
        ray: &Ray,
        t_max: f32,
        leaves: &impl Leaves,
    ) -> Option<Hit> {
        // SAFETY: an `Avx2` exists only where `detect` found AVX2, all `closest_avx2` needs.
        unsafe { closest_avx2(bvh, ray, t_max, leaves) }
    }

    /// [`WideBvh::any`] with the AVX node test.
    #[inline(always)]
    pub(super) fn any(self, bvh: &WideBvh, ray: &Ray, t_max: f32, leaves: &impl Leaves) -> bool {
        // SAFETY: as in `closest`: the token proves AVX2.
        unsafe { any_avx2(bvh, ray, t_max, leaves) }
    }
}

/// The traversal and leaf tests, inlined into a copy compiled for AVX2.
#[target_feature(enable = "avx2")]
fn closest_avx2(bvh: &WideBvh, ray: &Ray, t_max: f32, leaves: &impl Leaves) -> Option<Hit> {
    bvh.closest_with(&Slabs8::new(ray), t_max, leaves)
}

/// As [`closest_avx2`], for occlusion.
#[target_feature(enable = "avx2")]
fn any_avx2(bvh: &WideBvh, ray: &Ray, t_max: f32, leaves: &impl Leaves) -> bool {
    bvh.any_with(&Slabs8::new(ray), t_max, leaves)
}

/// A ray's slabs with every coordinate broadcast to eight AVX lanes. Made only inside
/// [`closest_avx2`] and [`any_avx2`], so its methods run only where AVX is present.
struct Slabs8(RaySlabs<__m256>);

impl Slabs8 {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        // SAFETY: called only from the AVX2 copies above (see the type's note).
        Self(RaySlabs::with(ray, |v| unsafe { _mm256_set1_ps(v) }))
    }
}

impl NodeTest for Slabs8 {
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
                t1 = _mm256_min_ps(t1, _mm256_mul_ps(_mm256_sub_ps(far, s.o[a]), s.inv[a]));
            }
            let far = _mm256_min_ps(
                _mm256_mul_ps(t1, _mm256_set1_ps(FAR_SCALE)),
                _mm256_set1_ps(t_max),
            );
            _mm256_storeu_ps(entry.as_mut_ptr(), t0);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, far)) as u32
        };
        (entry, mask)
    }
}
