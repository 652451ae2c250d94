//! A 4-wide BVH with uncompressed `f32` child boxes, collapsed from the binary BVH that
//! `obvhs` builds (PLOC + reinsertion + SAH leaf collapse), traversed nearest child first.
//!
//! Why not obvhs' own CWBVH traversal: its child boxes are 8-bit quantised, and decoding them
//! (byte → f32 per plane) dominated a CPU ray; it also starts every node test at a fixed
//! `t ≥ 1e-4`, which forced a rescaling of every ray. Here one node test is 6 `Vec4`
//! subtract-multiplies and a min/max tree over four children (SSE2 through glam, no
//! `unsafe`), and the slab test is conservative by pbrt's bound (`t_far · (1 + 2γ₃)`), with no
//! epsilon. Measured numbers are in `benches/tracers.rs` and the README.

use crate::geometry::{gamma, Hit, Ray};
use glam::Vec4;
use obvhs::aabb::Aabb;
use obvhs::bvh2::{builder::build_bvh2, Bvh2};
use obvhs::BvhBuildParams;
use std::cell::RefCell;
use std::time::Duration;

/// Child reference: an inner node index, or a leaf (high bit) with
/// `first_packet << LEAF_BITS | packets`.
const LEAF: u32 = 1 << 31;
const LEAF_BITS: u32 = 4;
/// Most primitives in one leaf.
pub const MAX_LEAF_PRIMS: u32 = 8;
/// Primitives per packet: a leaf's primitives fill whole packets of this many slots, tested
/// together (the last one padded with [`PAD`]).
pub const PACKET: usize = 4;
/// The scene id of a padding slot in [`Bvh4::order`].
pub const PAD: u32 = u32::MAX;
const EMPTY: u32 = u32::MAX;

/// 112 bytes, aligned to start on a cache line.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node4 {
    /// Child boxes, one lane per child; empty lanes hold an inverted box (+∞ … −∞).
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    child: [u32; 4],
}

impl Node4 {
    const EMPTY: Self = Self {
        lo: [Vec4::INFINITY; 3],
        hi: [Vec4::NEG_INFINITY; 3],
        child: [EMPTY; 4],
    };
}

/// The traversal-side copy of a ray: origin, reciprocal direction, and the lanes holding the
/// near planes per axis (`neg`: the direction is negative, so the near plane is `hi`).
struct RaySlabs {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    neg: [bool; 3],
}

/// `t_far` is scaled by this so that rounding in the slab test never culls a box the ray
/// touches (pbrt-v4, `Bounds3::IntersectP`).
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl RaySlabs {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        // A zero (or subnormal) component would make 1/d infinite and 0·∞ a NaN in the slab
        // test; 1e-30 keeps every product finite or ±∞ and moves the ray by < 1e-30·t.
        let inv = [ray.d.x, ray.d.y, ray.d.z].map(|d| {
            1.0 / if d.abs() < 1e-30 {
                1e-30f32.copysign(d)
            } else {
                d
            }
        });
        Self {
            o: [ray.o.x, ray.o.y, ray.o.z].map(Vec4::splat),
            inv: inv.map(Vec4::splat),
            neg: inv.map(|i| i < 0.0),
        }
    }

    /// Entry distances of the four children and the mask of those entered before `t_max`.
    #[inline(always)]
    fn hit4(&self, n: &Node4, t_max: f32) -> (Vec4, u32) {
        let mut t0 = Vec4::ZERO;
        let mut t1 = Vec4::splat(f32::INFINITY);
        for a in 0..3 {
            let (near, far) = if self.neg[a] {
                (n.hi[a], n.lo[a])
            } else {
                (n.lo[a], n.hi[a])
            };
            t0 = t0.max((near - self.o[a]) * self.inv[a]);
            t1 = t1.min((far - self.o[a]) * self.inv[a]);
        }
        let t1 = (t1 * FAR_SCALE).min(Vec4::splat(t_max));
        (t0, t0.cmple(t1).bitmask())
    }
}

thread_local! {
    /// Traversal stack, reused by every query on this thread: no allocation per ray and no
    /// depth limit.
    static STACK: RefCell<Vec<(u32, f32)>> = const { RefCell::new(Vec::new()) };
}

/// A 4-wide BVH flattened from an obvhs binary BVH; leaves index packets of [`Bvh4::order`].
pub struct Bvh4 {
    nodes: Vec<Node4>,
    /// What the traversal starts from: node 0, or a single leaf when the tree is one leaf.
    root: u32,
    /// Scene primitive ids in leaf order, each leaf padded with [`PAD`] to whole packets:
    /// packet `k` is slots `PACKET·k .. PACKET·(k+1)`, a leaf a range of packets.
    pub order: Vec<u32>,
    /// The most entries a traversal's stack can hold: 3 per level of inner nodes on the path
    /// (the siblings left behind; `any` pushes all 4 at the deepest), plus one.
    max_stack: usize,
}

impl Bvh4 {
    /// Build over primitive boxes `aabbs` (indexed by scene primitive id).
    pub fn build(aabbs: &[Aabb], params: BvhBuildParams) -> Self {
        let mut params = params;
        params.max_prims_per_leaf = params.max_prims_per_leaf.clamp(1, MAX_LEAF_PRIMS);
        let bvh2 = build_bvh2(aabbs, params, &mut Duration::default());
        let mut out = Self {
            nodes: Vec::with_capacity(bvh2.nodes.len() / 2 + 1),
            root: 0,
            order: Vec::new(),
            max_stack: 1,
        };
        let root = &bvh2.nodes[0];
        if root.prim_count > 0 {
            out.root = out.leaf(&bvh2, 0);
        } else {
            out.collapse(&bvh2, 0, 1);
        }
        out
    }

    /// Append binary leaf `b`'s primitives to [`Self::order`] as whole packets; its reference.
    fn leaf(&mut self, bvh2: &Bvh2, b: usize) -> u32 {
        let n = &bvh2.nodes[b];
        let first = self.order.len() / PACKET;
        let prims = &bvh2.primitive_indices[n.first_index as usize..][..n.prim_count as usize];
        self.order.extend_from_slice(prims);
        while !self.order.len().is_multiple_of(PACKET) {
            self.order.push(PAD);
        }
        let packets = self.order.len() / PACKET - first;
        debug_assert!(packets <= (MAX_LEAF_PRIMS as usize).div_ceil(PACKET));
        debug_assert!(first < (1 << (31 - LEAF_BITS)));
        LEAF | (first as u32) << LEAF_BITS | packets as u32
    }

    /// Append the 4-wide node for binary inner node `b` (and, recursively, its subtree):
    /// open the largest inner child until four children (or only leaves) remain.
    fn collapse(&mut self, bvh2: &Bvh2, b: usize, level: usize) -> u32 {
        self.max_stack = self.max_stack.max(3 * level + 1);
        let area = |i: usize| bvh2.nodes[i].aabb.half_area();
        let first = bvh2.nodes[b].first_index as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < 4 {
            let open = (0..kids.len())
                .filter(|&k| bvh2.nodes[kids[k]].prim_count == 0)
                .max_by(|&x, &y| area(kids[x]).total_cmp(&area(kids[y])));
            let Some(k) = open else { break };
            let f = bvh2.nodes[kids[k]].first_index as usize;
            kids[k] = f;
            kids.insert(k + 1, f + 1);
        }
        let me = self.nodes.len();
        self.nodes.push(Node4::EMPTY);
        let mut node = Node4::EMPTY;
        for (lane, &k) in kids.iter().enumerate() {
            let n = &bvh2.nodes[k];
            for a in 0..3 {
                node.lo[a][lane] = n.aabb.min[a];
                node.hi[a][lane] = n.aabb.max[a];
            }
            node.child[lane] = if n.prim_count > 0 {
                self.leaf(bvh2, k)
            } else {
                self.collapse(bvh2, k, level + 1)
            };
        }
        self.nodes[me] = node;
        me as u32
    }

    /// Closest hit: `leaf(packets, t_max)` tests a leaf's packets (packet `k` holds slots
    /// `PACKET·k ..` of [`Self::order`]) and returns the nearest hit below `t_max`.
    #[inline(always)]
    pub fn closest(
        &self,
        ray: &Ray,
        t_max: f32,
        mut leaf: impl FnMut(std::ops::Range<usize>, f32) -> Option<Hit>,
    ) -> Option<Hit> {
        if self.max_stack <= INLINE_STACK {
            self.closest_in(&mut ArrayStack::new(), ray, t_max, &mut leaf)
        } else {
            STACK.with_borrow_mut(|stack| {
                stack.clear();
                self.closest_in(stack, ray, t_max, &mut leaf)
            })
        }
    }

    #[inline(always)]
    fn closest_in(
        &self,
        stack: &mut impl Stack,
        ray: &Ray,
        t_max: f32,
        leaf: &mut impl FnMut(std::ops::Range<usize>, f32) -> Option<Hit>,
    ) -> Option<Hit> {
        let slabs = RaySlabs::new(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = t_max;
        stack.push((self.root, 0.0));
        while let Some((mut r, t_enter)) = stack.pop() {
            if t_enter > t_max {
                continue;
            }
            // Descend nearest-first; the farther children wait on the stack.
            while r & LEAF == 0 {
                let n = &self.nodes[r as usize];
                let (t0, mask) = slabs.hit4(n, t_max);
                if mask == 0 {
                    r = EMPTY;
                    break;
                }
                r = push_sorted(stack, n, t0, mask);
            }
            if r == EMPTY {
                continue;
            }
            if let Some(h) = leaf(leaf_range(r), t_max) {
                t_max = h.t;
                best = Some(h);
            }
        }
        best
    }

    /// Any hit: `leaf(packets)` says whether a primitive of the leaf's packets blocks the ray.
    /// Children are visited in lane order, without sorting: any blocker ends the query.
    #[inline(always)]
    pub fn any(
        &self,
        ray: &Ray,
        t_max: f32,
        mut leaf: impl FnMut(std::ops::Range<usize>) -> bool,
    ) -> bool {
        if self.max_stack <= INLINE_STACK {
            self.any_in(&mut ArrayStack::new(), ray, t_max, &mut leaf)
        } else {
            STACK.with_borrow_mut(|stack| {
                stack.clear();
                self.any_in(stack, ray, t_max, &mut leaf)
            })
        }
    }

    #[inline(always)]
    fn any_in(
        &self,
        stack: &mut impl Stack,
        ray: &Ray,
        t_max: f32,
        leaf: &mut impl FnMut(std::ops::Range<usize>) -> bool,
    ) -> bool {
        let slabs = RaySlabs::new(ray);
        stack.push((self.root, 0.0));
        while let Some((r, _)) = stack.pop() {
            if r & LEAF != 0 {
                if leaf(leaf_range(r)) {
                    return true;
                }
                continue;
            }
            let n = &self.nodes[r as usize];
            let (_, mut mask) = slabs.hit4(n, t_max);
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                stack.push((n.child[lane], 0.0));
            }
        }
        false
    }
}

/// Pending (child reference, entry distance) pairs of a traversal.
trait Stack {
    fn push(&mut self, e: (u32, f32));
    fn pop(&mut self) -> Option<(u32, f32)>;
}

impl Stack for Vec<(u32, f32)> {
    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        Vec::push(self, e);
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        Vec::pop(self)
    }
}

/// Entries of the stack kept on the call stack, used when [`Bvh4::max_stack`] says the tree
/// fits (deeper trees, e.g. 1 M triangles, use the thread-local `Vec`). It does not pay on the
/// closest-hit side: callgrind, Cornell box 128², 1 spp, one thread, render only: occlusion
/// queries 23.7 M → 22.8 M instructions, closest-hit 67.0 M → 68.9 M (zeroing 512 bytes per
/// query costs more than the `Vec`'s capacity checks), the render 148.4 M → 151.0 M (+1.8 %).
/// Kept here only because every wall-clock number in the README was taken with it; the next
/// change to try is the `Vec` for `closest` and this for `any`.
const INLINE_STACK: usize = 64;

struct ArrayStack {
    items: [(u32, f32); INLINE_STACK],
    len: usize,
}

impl ArrayStack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            items: [(0, 0.0); INLINE_STACK],
            len: 0,
        }
    }
}

impl Stack for ArrayStack {
    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        self.items[self.len] = e;
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.items[self.len])
    }
}

#[inline(always)]
fn leaf_range(r: u32) -> std::ops::Range<usize> {
    let first = ((r & !LEAF) >> LEAF_BITS) as usize;
    first..first + (r & ((1 << LEAF_BITS) - 1)) as usize
}

/// Push the hit children of `n` except the nearest, farthest first, and return the nearest.
#[inline(always)]
fn push_sorted(stack: &mut impl Stack, n: &Node4, t0: Vec4, mask: u32) -> u32 {
    let mut hits = [(0u32, 0f32); 4];
    let mut k = 0;
    let mut m = mask;
    while m != 0 {
        let lane = m.trailing_zeros() as usize;
        m &= m - 1;
        // Insertion sort, nearest last.
        let e = (n.child[lane], t0[lane]);
        let mut j = k;
        while j > 0 && hits[j - 1].1 < e.1 {
            hits[j] = hits[j - 1];
            j -= 1;
        }
        hits[j] = e;
        k += 1;
    }
    for &e in &hits[..k - 1] {
        stack.push(e);
    }
    hits[k - 1].0
}
