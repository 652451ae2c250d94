//! The wide node and what a traversal of it is made of: the node's layout, the node test and
//! the leaves' tests as traits, the ray's slabs, the traversal itself as a trait, and the token
//! that proves AVX2. The tree ([`super::bvh4`]) and the AVX2 code ([`super::simd`]) both build
//! on these, so neither imports the other's insides: the tree calls the SIMD module, and the
//! SIMD module runs the tree's traversal through [`Traverse`].

use crate::core::geometry::{gamma, Hit, Ray};
use glam::Vec4;
use obvhs::aabb::Aabb;
use std::ops::Range;

/// Children per inner node.
pub(super) const WIDTH: usize = 8;
/// An unused child slot.
pub(super) const EMPTY: u32 = u32::MAX;

/// One inner node: [`WIDTH`] child boxes side by side (one lane per child, eight `f32` per
/// plane: one AVX register or two SSE ones) and the children. Plane `a` (x, y, z) holds the
/// lower bounds on axis `a`, plane `3 + a` the upper ones; an empty lane holds an inverted box
/// (+∞ … −∞) and is never entered. 224 bytes of boxes and children, padded to 256 to start on
/// a cache line.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Node {
    pub(super) planes: [[f32; WIDTH]; 6],
    pub(super) child: [u32; WIDTH],
}

impl Node {
    pub(super) const EMPTY: Self = Self {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY; WIDTH],
    };

    pub(super) fn set(&mut self, lane: usize, aabb: &Aabb) {
        for a in 0..3 {
            self.planes[a][lane] = aabb.min[a];
            self.planes[3 + a][lane] = aabb.max[a];
        }
    }
}

/// A ray's slab test against the eight child boxes of a node: the portable one below
/// ([`RaySlabs`], SSE through glam) or the AVX one of [`super::simd`], which computes the same
/// IEEE operations lane by lane, so both enter the same children in the same order.
pub(super) trait NodeTest {
    /// Entry distance of every child and the mask of those entered before `t_max`.
    fn hit(&self, n: &Node, t_max: f32) -> Entered;
    /// The 8-lane leaf test's token where this test runs in a traversal compiled for AVX2.
    fn wide(&self) -> Wide {
        None
    }
}

/// What [`NodeTest::hit`] finds: each child's entry distance and the mask of the children
/// entered.
pub(super) type Entered = ([f32; WIDTH], u32);

/// Proof that an 8-lane leaf test of [`super::simd`] may run (x86-64 with AVX2, and which of
/// its two: AVX2 or AVX-512); `None` elsewhere, where leaves are tested four lanes at a time.
#[cfg(target_arch = "x86_64")]
pub(super) type Wide = Option<Lanes8>;

/// Which 8-lane leaf test runs: a traversal's node test names it ([`NodeTest::wide`]), and as
/// each traversal copy's node test is one type, the choice is made once per copy, not per leaf.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(super) enum Lanes8 {
    /// Compares into vector masks, then `movemask` (AVX2).
    Avx2(Avx2),
    /// Compares into mask registers, the rare exact edge functions redone in eight f64 lanes
    /// at once (AVX-512 F + VL).
    Avx512(Avx512),
}
/// No 8-lane leaf test off x86-64.
#[cfg(not(target_arch = "x86_64"))]
pub(super) type Wide = Option<std::convert::Infallible>;

/// The traversal-side copy of a ray: origin, reciprocal direction, the reciprocal direction
/// scaled by [`FAR_SCALE`] for the far planes, and per axis the plane entered first (`near`:
/// the upper one where the direction is negative) and the one left by.
pub(super) struct RaySlabs<V> {
    pub(super) o: [V; 3],
    pub(super) inv: [V; 3],
    /// `inv · FAR_SCALE`: the far distances come out scaled, one multiply fewer on the path
    /// from a node's memory to its mask. Measured: M-106.
    pub(super) inv_far: [V; 3],
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
}

/// `t_far` is scaled by this so that rounding in the slab test never culls a box the ray
/// touches (pbrt-v4, `Bounds3::IntersectP`). Folded into the reciprocal direction
/// ([`RaySlabs::inv_far`]): `(far − o) · (inv · s)` rounds four times, as `((far − o) · inv) · s`
/// did, so the bound holds alike; the two can differ only on a box the ray passes within the
/// margin.
pub(super) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl<V> RaySlabs<V> {
    /// The slabs of `ray`, each origin and reciprocal direction coordinate broadcast by
    /// `splat` to the lanes of `V`.
    #[inline(always)]
    pub(super) fn with(ray: &Ray, splat: impl Fn(f32) -> V) -> Self {
        // A zero (or subnormal) component would make 1/d infinite and 0·∞ a NaN in the slab
        // test; 1e-30 keeps every product finite or ±∞ and moves the ray by < 1e-30·t.
        let inv = [ray.d.x, ray.d.y, ray.d.z].map(|d| {
            1.0 / if d.abs() < 1e-30 {
                1e-30f32.copysign(d)
            } else {
                d
            }
        });
        // Indexing by a per-ray plane instead of branching per node: the index is `a` or
        // `3 + a`, which the compiler sees, so the plane lookups carry no bounds check.
        let neg = inv.map(|i| i < 0.0);
        Self {
            o: [ray.o.x, ray.o.y, ray.o.z].map(&splat),
            inv: inv.map(&splat),
            inv_far: inv.map(|i| splat(i * FAR_SCALE)),
            near: [0, 1, 2].map(|a| if neg[a] { 3 + a } else { a }),
            far: [0, 1, 2].map(|a| if neg[a] { a } else { 3 + a }),
        }
    }
}

impl NodeTest for RaySlabs<Vec4> {
    /// Two 4-lane halves per plane.
    #[inline(always)]
    fn hit(&self, n: &Node, t_max: f32) -> ([f32; WIDTH], u32) {
        let mut t0 = [Vec4::ZERO; 2];
        let mut t1 = [Vec4::INFINITY; 2];
        for a in 0..3 {
            let (near, far) = (&n.planes[self.near[a]], &n.planes[self.far[a]]);
            for h in 0..2 {
                let (near, far) = (
                    Vec4::from_slice(&near[4 * h..]),
                    Vec4::from_slice(&far[4 * h..]),
                );
                t0[h] = t0[h].max((near - self.o[a]) * self.inv[a]);
                t1[h] = t1[h].min((far - self.o[a]) * self.inv_far[a]);
            }
        }
        let t_max = Vec4::splat(t_max);
        let inside = |h: usize| t0[h].cmple(t1[h].min(t_max)).bitmask();
        let mut entry = [0.0; WIDTH];
        t0[0].write_to_slice(&mut entry[..4]);
        t0[1].write_to_slice(&mut entry[4..]);
        (entry, inside(0) | inside(1) << 4)
    }
}

/// What a traversal asks of the leaves: the caller's primitive tests on a leaf's packets
/// (packet `k` holds slots `PACKET·k ..` of [`super::bvh4::WideBvh::order`]). A trait rather than a closure
/// so that `#[inline(always)]` puts the tests into the traversal loop (and into its AVX2 copy).
/// `wide` is [`NodeTest::wide`] of the traversal's node test.
pub(super) trait Leaves {
    /// The nearest hit below `t_max` among the packets `packets`.
    fn closest(&self, packets: Range<usize>, t_max: f32, wide: Wide) -> Option<Hit>;
    /// Whether a primitive of the packets `packets` blocks the ray.
    fn any(&self, packets: Range<usize>, wide: Wide) -> bool;
    /// Ask for the packets' cache lines ahead of their test (see [`super::bvh4::PREFETCH_FROM_BYTES`]).
    fn prefetch(&self, _packets: Range<usize>) {}
}

/// Proof that this CPU has AVX2 (and so AVX): only [`Avx2::detect`] makes one. The code it
/// unlocks is [`super::simd`]'s; the token lives beside [`Wide`], which names it.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx2(());

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// `Some` where the CPU (and OS) support AVX2.
    pub(super) fn detect() -> Option<Self> {
        is_x86_feature_detected!("avx2").then_some(Self(()))
    }
}

/// Proof that this CPU has AVX-512 F and VL (and so AVX2): only [`Avx512::detect`] makes one.
/// The code it unlocks is [`super::simd`]'s: the same traversal and tests as [`Avx2`]'s, with
/// the same IEEE operations lane by lane, compiled with the AVX-512 registers and masks.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx512(pub(super) Avx2);

#[cfg(target_arch = "x86_64")]
impl Avx512 {
    /// `Some` where the CPU (and OS) support AVX2, AVX-512 F and AVX-512 VL.
    pub(super) fn detect() -> Option<Self> {
        let wide = is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl");
        Avx2::detect().filter(|_| wide).map(Self)
    }
}

/// The node and leaf tests a [`super::bvh4::WideBvh`] runs: chosen once, at build, from what
/// the CPU has; tests may step down to compare the paths.
#[derive(Clone, Copy, Debug)]
pub(super) enum Isa {
    /// SSE through glam (any CPU): four lanes per half node, four per leaf packet.
    Portable,
    /// AVX2: eight lanes per node and per two-packet leaf.
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
    /// AVX-512 F + VL: as AVX2, with mask registers.
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
}

impl Isa {
    /// The widest this CPU runs.
    pub(super) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(t) = Avx512::detect() {
                return Self::Avx512(t);
            }
            if let Some(t) = Avx2::detect() {
                return Self::Avx2(t);
            }
        }
        Self::Portable
    }

    /// Its name, as the peers' bench prints it.
    pub(super) fn id(self) -> &'static str {
        match self {
            Self::Portable => "sse",
            #[cfg(target_arch = "x86_64")]
            Self::Avx2(_) => "avx2",
            #[cfg(target_arch = "x86_64")]
            Self::Avx512(_) => "avx512",
        }
    }
}

/// A wide tree's traversals with a given node test: what [`super::simd`] compiles a copy of
/// for AVX2. A trait, so that the SIMD module runs the tree's traversal without importing the
/// tree; its `#[inline(always)]` implementation is inlined into that copy as a method was
/// (render time unchanged: M-160).
pub(super) trait Traverse {
    /// The closest hit below `t_max`, the nodes tested by `slabs`, the leaves by `leaves`.
    fn closest_with(&self, slabs: &impl NodeTest, t_max: f32, leaves: &impl Leaves) -> Option<Hit>;
    /// Whether anything blocks the ray below `t_max`, tested as in [`Self::closest_with`].
    fn any_with(&self, slabs: &impl NodeTest, t_max: f32, leaves: &impl Leaves) -> bool;
}
