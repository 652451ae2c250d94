//! An 8-wide BVH with uncompressed `f32` child boxes, collapsed by SAH ([`Collapse`]) from the
//! binary BVH that `obvhs` builds (PLOC + reinsertion), traversed nearest child first.
//!
//! Why not obvhs' own CWBVH traversal: its child boxes are 8-bit quantised, and decoding them
//! (byte → f32 per plane) dominated a CPU ray; it also starts every node test at a fixed
//! `t ≥ 1e-4`, which forced a rescaling of every ray. Here one node test is 6 subtract-multiplies
//! and a min/max tree over eight children in one AVX register per plane (`tracer::simd`,
//! where the CPU has AVX2) or two SSE ones (glam), and the slab test is conservative by pbrt's
//! bound (`t_far · (1 + 2γ₃)`), with no epsilon.
//!
//! Eight children rather than four (with the inline stack and the inlined leaf tests below):
//! faster on primary and incoherent rays of the 1 M-triangle scene. Measured: M-021.

use super::wide::{Entered, Isa, Leaves, Node, NodeTest, RaySlabs, Traverse, EMPTY, WIDTH};
use crate::core::geometry::{Hit, Ray};
use glam::Vec4;
use obvhs::bvh2::{builder::build_bvh2, Bvh2};
use obvhs::{Boundable, BvhBuildParams};
use smallvec::{smallvec, SmallVec};
use std::ops::Range;
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
/// The scene id of a padding slot in [`WideBvh::order`].
pub const PAD: u32 = u32::MAX;

/// From this many bytes of nodes and leaf packets on, a traversal asks for the cache lines of
/// every child it enters as soon as the node test has found them ([`super::simd::prefetch`]),
/// so that the memory of the farther ones, popped later, arrives while the nearest is
/// traversed. A tree below it (about an L2 cache) stays cached, and the hints only cost.
/// Measured: M-107.
pub const PREFETCH_FROM_BYTES: usize = 1 << 20;

/// An 8-wide BVH flattened from an obvhs binary BVH; leaves index packets of
/// [`WideBvh::order`].
pub struct WideBvh {
    nodes: Vec<Node>,
    /// What the traversal starts from: node 0, or a single leaf when the tree is one leaf.
    root: u32,
    /// Scene primitive ids in leaf order, each leaf padded with [`PAD`] to whole packets:
    /// packet `k` is slots `PACKET·k .. PACKET·(k+1)`, a leaf a range of packets.
    pub order: Vec<u32>,
    /// The node and leaf tests this CPU runs best: AVX-512 or AVX2 test nodes 8 lanes at once.
    isa: Isa,
    /// Set (x86-64) where the tree has [`PREFETCH_FROM_BYTES`] or more: traversals then ask
    /// for the cache lines of the children they find.
    prefetch: bool,
}

impl WideBvh {
    /// Build over primitives `prims` (indexed by scene primitive id; only their boxes are
    /// read, once, as obvhs makes its leaves), collapsing the binary
    /// tree into wide nodes and leaves by the SAH [`Collapse`] with `costs`, or, without
    /// costs, greedily: obvhs' leaves kept, each node opening its largest inner child until
    /// [`WIDTH`] children (or only leaves) remain.
    pub fn build(
        prims: &[impl Boundable],
        params: BvhBuildParams,
        costs: Option<CollapseCosts>,
    ) -> Self {
        let mut params = params;
        params.max_prims_per_leaf = params.max_prims_per_leaf.clamp(1, MAX_LEAF_PRIMS);
        let bvh2 = build_bvh2(prims, params, &mut Duration::default());
        let mut out = Self {
            nodes: Vec::with_capacity(bvh2.nodes.len() / 4 + 1),
            root: 0,
            order: Vec::new(),
            isa: Isa::detect(),
            prefetch: false,
        };
        let plan = costs.map(|c| Collapse::plan(&bvh2, c));
        out.root = out.child(&bvh2, plan.as_ref(), 0);
        out.prefetch = cfg!(target_arch = "x86_64") && out.bytes() >= PREFETCH_FROM_BYTES;
        out
    }

    /// Bytes of the nodes and of the leaf packets' triangles.
    fn bytes(&self) -> usize {
        self.nodes.len() * size_of::<Node>()
            + self.order.len() / PACKET * size_of::<crate::core::geometry::Triangle4>()
    }

    /// The reference of binary node `b` as one child of a wide node: a leaf of every primitive
    /// below it, or a wide node (appended, with its subtree), as `plan` decided.
    fn child(&mut self, bvh2: &Bvh2, plan: Option<&Collapse>, b: usize) -> u32 {
        let leaf = match plan {
            Some(plan) => plan.is_leaf(bvh2, b),
            None => bvh2.nodes[b].prim_count > 0,
        };
        if !leaf {
            return self.collapse(bvh2, plan, b);
        }
        let first = self.order.len() / PACKET;
        // On the call stack: a leaf has at most `MAX_LEAF_PRIMS` primitives, so fewer pending
        // nodes than this; a heap `Vec` per leaf and per node cost ~4 % of a build's
        // instructions. Measured: M-166.
        let mut pending: SmallVec<[usize; 16]> = smallvec![b];
        while let Some(i) = pending.pop() {
            let n = &bvh2.nodes[i];
            if n.prim_count > 0 {
                let prims =
                    &bvh2.primitive_indices[n.first_index as usize..][..n.prim_count as usize];
                self.order.extend_from_slice(prims);
            } else {
                pending.extend([n.first_index as usize + 1, n.first_index as usize]);
            }
        }
        while !self.order.len().is_multiple_of(PACKET) {
            self.order.push(PAD);
        }
        let packets = self.order.len() / PACKET - first;
        debug_assert!(packets <= (MAX_LEAF_PRIMS as usize).div_ceil(PACKET));
        debug_assert!(first < (1 << (31 - LEAF_BITS)));
        LEAF | (first as u32) << LEAF_BITS | packets as u32
    }

    /// Append the wide node for binary inner node `b` (and, recursively, its subtree): its
    /// children are the roots `plan` chose below `b`, or the greedy ones.
    fn collapse(&mut self, bvh2: &Bvh2, plan: Option<&Collapse>, b: usize) -> u32 {
        let mut kids: SmallVec<[usize; WIDTH]> = SmallVec::new();
        let l = bvh2.nodes[b].first_index as usize;
        if let Some(plan) = plan {
            let k = plan.split[b][0] as usize;
            plan.roots(bvh2, l, k, &mut kids);
            plan.roots(bvh2, l + 1, WIDTH - k, &mut kids);
        } else {
            let area = |i: usize| bvh2.nodes[i].aabb().half_area();
            kids.extend([l, l + 1]);
            while kids.len() < WIDTH {
                let open = (0..kids.len())
                    .filter(|&k| bvh2.nodes[kids[k]].prim_count == 0)
                    .max_by(|&x, &y| area(kids[x]).total_cmp(&area(kids[y])));
                let Some(k) = open else { break };
                let f = bvh2.nodes[kids[k]].first_index as usize;
                kids[k] = f;
                kids.insert(k + 1, f + 1);
            }
        }
        let me = self.nodes.len();
        self.nodes.push(Node::EMPTY);
        let mut node = Node::EMPTY;
        for (lane, &k) in kids.iter().enumerate() {
            node.set(lane, bvh2.nodes[k].aabb());
            node.child[lane] = self.child(bvh2, plan, k);
        }
        self.nodes[me] = node;
        me as u32
    }

    /// The same tree with the portable node test only (to check that both tests agree).
    #[cfg(test)]
    pub(super) fn without_simd(self) -> Self {
        self.with_isa(Isa::Portable)
    }

    /// The same tree with the node and leaf tests of `isa` (one this CPU runs: an `Isa` is
    /// made only by detection or from a detected token).
    pub(super) fn with_isa(mut self, isa: Isa) -> Self {
        self.isa = isa;
        self
    }

    /// The same tree with the cache hints of [`PREFETCH_FROM_BYTES`] on or off, whatever its
    /// size (to check that they change no result).
    #[cfg(test)]
    pub(super) fn with_prefetch(mut self, on: bool) -> Self {
        self.prefetch = on && cfg!(target_arch = "x86_64");
        self
    }

    /// The node and leaf tests queries run.
    pub(super) fn isa(&self) -> Isa {
        self.isa
    }

    /// Closest hit below `t_max`, the leaves tested by `leaves`: with the AVX node test where
    /// the CPU has AVX2 (the traversal then runs from a copy compiled for it), else SSE. With
    /// it (and the two-hit shortcut of `push_sorted`) against the SSE-only binary: bvh rate
    /// 1.10× on 1 M triangles at 1024², primary and diffuse (medians of 5 alternated runs;
    /// 1.05–1.07× at 256²), bvh/Embree 0.76 → 0.83 primary and 0.58 → 0.65 diffuse
    /// (`examples/tracer_ab`, quiet 2-core Intel Xeon); Cornell render 0.98× (0.93–1.01).
    #[inline(always)]
    pub(super) fn closest(&self, ray: &Ray, t_max: f32, leaves: &impl Leaves) -> Option<Hit> {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512(t) => t.closest(self, ray, t_max, leaves),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2(t) => t.closest(self, ray, t_max, leaves),
            Isa::Portable => self.closest_with(&RaySlabs::with(ray, Vec4::splat), t_max, leaves),
        }
    }

    /// Whether anything blocks the ray below `t_max` (node test chosen as in
    /// [`Self::closest`]).
    #[inline(always)]
    pub(super) fn any(&self, ray: &Ray, t_max: f32, leaves: &impl Leaves) -> bool {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512(t) => t.any(self, ray, t_max, leaves),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2(t) => t.any(self, ray, t_max, leaves),
            Isa::Portable => self.any_with(&RaySlabs::with(ray, Vec4::splat), t_max, leaves),
        }
    }

    /// Ask for the cache lines of child `c`: a node's planes, a leaf's packets. A hint only:
    /// no result depends on it.
    #[inline(always)]
    fn prefetch_child(&self, c: u32, leaves: &impl Leaves) {
        if c & LEAF != 0 {
            leaves.prefetch(leaf_range(c));
        } else {
            #[cfg(target_arch = "x86_64")]
            super::simd::prefetch(&self.nodes[c as usize]);
        }
    }

    /// [`Self::prefetch_child`] for every child of `n` in `mask`.
    #[inline(always)]
    fn prefetch_children(&self, n: &Node, mut mask: u32, leaves: &impl Leaves) {
        while mask != 0 {
            self.prefetch_child(n.child[mask.trailing_zeros() as usize], leaves);
            mask &= mask - 1;
        }
    }
}

impl Traverse for WideBvh {
    /// [`Self::closest`] with node test `slabs`.
    #[inline(always)]
    fn closest_with(&self, slabs: &impl NodeTest, t_max: f32, leaves: &impl Leaves) -> Option<Hit> {
        let mut stack = Stack::new();
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
                let hits = slabs.hit(n, t_max);
                if hits.1 == 0 {
                    r = EMPTY;
                    break;
                }
                r = if self.prefetch {
                    push_sorted(&mut stack, n, &hits, |c| self.prefetch_child(c, leaves))
                } else {
                    push_sorted(&mut stack, n, &hits, |_| {})
                };
            }
            if r == EMPTY {
                continue;
            }
            if let Some(h) = leaves.closest(leaf_range(r), t_max, slabs.wide()) {
                t_max = h.t;
                best = Some(h);
            }
        }
        best
    }

    /// [`Self::any`] with node test `slabs`. Children are visited without sorting: a node's
    /// hit leaves are tested at once, in lane order, and of its hit inner children the
    /// highest is entered at once while the others wait on the stack; any blocker ends the
    /// query. Measured: M-108.
    #[inline(always)]
    fn any_with(&self, slabs: &impl NodeTest, t_max: f32, leaves: &impl Leaves) -> bool {
        let mut stack = Stack::new();
        stack.push((self.root, 0.0));
        while let Some((mut r, _)) = stack.pop() {
            loop {
                if r & LEAF != 0 {
                    if leaves.any(leaf_range(r), slabs.wide()) {
                        return true;
                    }
                    break;
                }
                let n = &self.nodes[r as usize];
                let (_, mut mask) = slabs.hit(n, t_max);
                if mask == 0 {
                    break;
                }
                // The hints first, in a pass of their own, so that no leaf test below holds
                // back a later child's hint.
                if self.prefetch {
                    self.prefetch_children(n, mask, leaves);
                }
                // Leaves first: a blocker among them ends the query before any subtree.
                let mut next = EMPTY;
                while mask != 0 {
                    let c = n.child[mask.trailing_zeros() as usize];
                    mask &= mask - 1;
                    if c & LEAF != 0 {
                        if leaves.any(leaf_range(c), slabs.wide()) {
                            return true;
                        }
                    } else {
                        if next != EMPTY {
                            stack.push((next, 0.0));
                        }
                        next = c;
                    }
                }
                if next == EMPTY {
                    break;
                }
                r = next;
            }
        }
        false
    }
}

/// Expected costs of the collapse's SAH, per unit of a box's half area (the chance that a ray
/// enters it).
#[derive(Clone, Copy, Debug)]
pub struct CollapseCosts {
    /// Testing one wide node.
    pub node: f32,
    /// Testing a leaf of one packet (up to four primitives).
    pub packet: f32,
    /// Testing a leaf of two packets (five to eight primitives).
    pub two_packets: f32,
}

/// How the binary tree becomes wide nodes and leaves: the SAH-optimal collapse of Ylitie et
/// al., "Efficient incoherent ray traversal on GPUs through compressed wide BVHs" (2017), with
/// leaf costs of our packet tests. Per binary node and per `j` = 1..=[`WIDTH`], the cheapest
/// way to hang its subtree below a wide node as at most `j` children: one leaf (at most
/// [`MAX_LEAF_PRIMS`] primitives), one wide node, or `j` split between its two children.
pub(super) struct Collapse {
    /// Per binary node and `j + 1` children: 0 where one child (leaf or node) is cheapest,
    /// else how many go to the left child. At `j = 0` (one child, a wide node): how many of
    /// its [`WIDTH`] children come from the left child, or 0 for a leaf.
    split: Vec<[u8; WIDTH]>,
}

/// One binary node as [`Collapse::plan`]'s walk met it.
#[derive(Clone, Copy)]
struct Step {
    /// Its index in the binary tree.
    node: u32,
    /// Its box's half area.
    area: f32,
    /// Its primitives if a leaf, else 0.
    prims: u32,
}

impl Collapse {
    fn plan(bvh2: &Bvh2, c: CollapseCosts) -> Self {
        let n = bvh2.nodes.len();
        let mut split = vec![[0u8; WIDTH]; n];
        // One pre-order walk (no recursion: a degenerate tree may be deep) reads each binary
        // node once and records what the costs need. Read backwards, the records are a
        // post-order (right subtree, left subtree, node), so the costs are computed over them
        // with a stack of the finished subtrees' rows, no per-node array: the second pass
        // reads memory in order where the nodes lie scattered. Measured: M-109.
        let mut walk: Vec<Step> = Vec::with_capacity(n);
        let mut pending = vec![0u32];
        while let Some(i) = pending.pop() {
            let node = &bvh2.nodes[i as usize];
            walk.push(Step {
                node: i,
                area: node.aabb().half_area(),
                prims: node.prim_count,
            });
            if node.prim_count == 0 {
                pending.extend([node.first_index + 1, node.first_index]);
            }
        }
        let leaf_cost = |count: u32, area: f32| match count.div_ceil(PACKET as u32) {
            0 | 1 => area * c.packet,
            2 => area * c.two_packets,
            _ => f32::INFINITY,
        };
        // Per finished subtree: its cost with at most `j + 1` children, and its primitives.
        let mut done: Vec<([f32; WIDTH], u32)> = Vec::new();
        for step in walk.iter().rev() {
            if step.prims > 0 {
                done.push(([leaf_cost(step.prims, step.area); WIDTH], step.prims));
                continue;
            }
            // The left subtree finished last.
            let (Some((cl, pl)), Some((cr, pr))) = (done.pop(), done.pop()) else {
                unreachable!("an inner node has two subtrees below it in the walk");
            };
            let prims = pl.saturating_add(pr);
            let (mut row, mut ks) = ([0.0f32; WIDTH], [0u8; WIDTH]);
            let mut best = (leaf_cost(prims, step.area), 0u8);
            for k in 1..WIDTH {
                let cost = step.area * c.node + cl[k - 1] + cr[WIDTH - k - 1];
                if cost < best.0 {
                    best = (cost, k as u8);
                }
            }
            (row[0], ks[0]) = best;
            for j in 1..WIDTH {
                let mut best = (row[j - 1], 0u8);
                for k in 1..=j {
                    let cost = cl[k - 1] + cr[j - k];
                    if cost < best.0 {
                        best = (cost, k as u8);
                    }
                }
                (row[j], ks[j]) = best;
            }
            done.push((row, prims));
            split[step.node as usize] = ks;
        }
        // Leaves keep an all-zero row of splits: `is_leaf` and `roots` read `prim_count` first.
        Self { split }
    }

    /// Whether binary node `b`, as one child, is a leaf.
    fn is_leaf(&self, bvh2: &Bvh2, b: usize) -> bool {
        bvh2.nodes[b].prim_count > 0 || self.split[b][0] == 0
    }

    /// The children (binary nodes, in tree order) that stand for binary node `b` given room
    /// for `room` of them.
    fn roots(&self, bvh2: &Bvh2, b: usize, room: usize, out: &mut SmallVec<[usize; WIDTH]>) {
        let node = &bvh2.nodes[b];
        let k = self.split[b][room - 1] as usize;
        if node.prim_count > 0 || room == 1 || k == 0 {
            out.push(b);
            return;
        }
        let l = node.first_index as usize;
        self.roots(bvh2, l, k, out);
        self.roots(bvh2, l + 1, room - k, out);
    }
}

/// Entries kept on the call stack before a traversal spills into a `Vec` (allocated only by
/// the rare query that goes deeper): no allocation per ray, no depth limit, and no
/// thread-local lookup, whose closure kept the traversal out of its AVX2 copy (a
/// thread-local `Vec` was 20 % of a 1 M-triangle trace in `perf`).
const INLINE_STACK: usize = 32;

/// Pending (child reference, entry distance) pairs of a traversal.
struct Stack {
    items: [(u32, f32); INLINE_STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            items: [(0, 0.0); INLINE_STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, e: (u32, f32)) {
        if self.len < INLINE_STACK {
            self.items[self.len] = e;
        } else {
            self.spill.push(e);
        }
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < INLINE_STACK {
            Some(self.items[self.len])
        } else {
            self.spill.pop()
        }
    }
}

#[inline(always)]
fn leaf_range(r: u32) -> Range<usize> {
    let first = ((r & !LEAF) >> LEAF_BITS) as usize;
    first..first + (r & ((1 << LEAF_BITS) - 1)) as usize
}

/// Push the hit children of `n` except the nearest, farthest first, and return the nearest;
/// `hint` sees each hit child as its reference is read (the traversal's cache hints, given
/// here rather than in a loop of their own over the same children; measured: M-110).
/// One child hit (the common case low in the tree) is returned without sorting, two with one
/// comparison; either way equal entry distances leave the higher lane nearer, as the
/// insertion sort does, so every path visits children in one order.
#[inline(always)]
fn push_sorted(stack: &mut Stack, n: &Node, entered: &Entered, hint: impl Fn(u32)) -> u32 {
    let (t0, mask) = (&entered.0, entered.1);
    let a = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        hint(n.child[a]);
        return n.child[a];
    }
    if rest & (rest - 1) == 0 {
        let b = rest.trailing_zeros() as usize;
        hint(n.child[a]);
        hint(n.child[b]);
        let (near, far) = if t0[a] < t0[b] { (a, b) } else { (b, a) };
        stack.push((n.child[far], t0[far]));
        return n.child[near];
    }
    push_insertion_sorted(stack, n, entered, hint)
}

/// [`push_sorted`] for any number of hit children: an insertion sort in lane order. Padding
/// the hits to four or eight and sorting them by a branch-free network instead (5 or 19
/// compare-exchanges) was slower: bvh/Embree best rate on 1 M triangles at 1024², one thread,
/// primary 0.64–0.74 against 0.74–0.79, diffuse 0.62–0.68 against 0.63–0.70 (2-core EPYC,
/// six alternated runs of each binary, `examples/tracer_ab`). So was a per-octant child order
/// stored in each node and applied with AVX2 permutes, no sort: primary 0.76–0.77 against
/// 0.79–0.80, diffuse 0.69 against 0.68–0.69 (another EPYC guest, `benches/peers/results.md`).
#[inline(always)]
fn push_insertion_sorted(
    stack: &mut Stack,
    n: &Node,
    entered: &Entered,
    hint: impl Fn(u32),
) -> u32 {
    let (t0, mask) = (&entered.0, entered.1);
    let mut hits = [(0u32, 0f32); WIDTH];
    let mut k = 0;
    let mut m = mask;
    while m != 0 {
        let lane = m.trailing_zeros() as usize;
        m &= m - 1;
        // Insertion sort, nearest last.
        let e = (n.child[lane], t0[lane]);
        hint(e.0);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::tracer::bvh::{BUILD_PARAMS, BUILD_PARAMS_LARGE, COLLAPSE_COSTS};
    use obvhs::aabb::Aabb;

    /// The cache hints are on exactly from [`PREFETCH_FROM_BYTES`] of tree on (x86-64): off
    /// for a Cornell-sized tree, on for one of ~9 000 leaf packets.
    #[test]
    fn cache_hints_start_at_the_size_threshold() {
        let tree = |n: usize| {
            let aabbs: Vec<Aabb> = (0..n)
                .map(|i| {
                    let p =
                        glam::Vec3A::new((i % 97) as f32, (i / 97 % 89) as f32, (i / 8633) as f32);
                    Aabb::new(p, p + glam::Vec3A::splat(0.5))
                })
                .collect();
            WideBvh::build(&aabbs, BUILD_PARAMS_LARGE, Some(COLLAPSE_COSTS))
        };
        let small = tree(36);
        assert!(small.bytes() < PREFETCH_FROM_BYTES && !small.prefetch);
        let large = tree(30_000);
        assert!(
            large.bytes() >= PREFETCH_FROM_BYTES,
            "{} bytes",
            large.bytes()
        );
        assert_eq!(large.prefetch, cfg!(target_arch = "x86_64"));
    }

    /// Both collapses put every primitive in exactly one leaf of at most [`MAX_LEAF_PRIMS`],
    /// each inside its node lane's box, on a grid of boxes; the SAH one, from one-primitive
    /// binary leaves and from obvhs' leaves, leaves few two-child nodes.
    #[test]
    fn collapse_places_every_primitive_once_and_fills_nodes() {
        let aabbs: Vec<Aabb> = (0..3000)
            .map(|i| {
                let p = glam::Vec3A::new((i % 17) as f32, (i / 17 % 13) as f32, (i / 221) as f32);
                Aabb::new(p, p + glam::Vec3A::splat(0.5 + (i % 3) as f32 * 0.25))
            })
            .collect();
        for (params, costs) in [
            (BUILD_PARAMS, None),
            (BUILD_PARAMS, Some(COLLAPSE_COSTS)),
            (BUILD_PARAMS_LARGE, Some(COLLAPSE_COSTS)),
        ] {
            let bvh = WideBvh::build(&aabbs, params, costs);
            let mut seen = vec![0u32; aabbs.len()];
            for &p in bvh.order.iter().filter(|&&p| p != PAD) {
                seen[p as usize] += 1;
            }
            assert!(
                seen.iter().all(|&n| n == 1),
                "a primitive missing or repeated"
            );
            let (mut two, mut leaves) = (0, 0);
            for n in &bvh.nodes {
                let kids: Vec<usize> = (0..WIDTH).filter(|&l| n.child[l] != EMPTY).collect();
                assert!(kids.len() >= 2);
                two += (kids.len() == 2) as usize;
                for &l in &kids {
                    let c = n.child[l];
                    if c & LEAF == 0 {
                        continue;
                    }
                    leaves += 1;
                    let slots = leaf_range(c).start * PACKET..leaf_range(c).end * PACKET;
                    let prims: Vec<u32> = bvh.order[slots]
                        .iter()
                        .copied()
                        .filter(|&p| p != PAD)
                        .collect();
                    assert!(!prims.is_empty() && prims.len() <= MAX_LEAF_PRIMS as usize);
                    for p in prims {
                        let b = &aabbs[p as usize];
                        for a in 0..3 {
                            assert!(n.planes[a][l] <= b.min[a] && b.max[a] <= n.planes[3 + a][l]);
                        }
                    }
                }
            }
            assert!(leaves * 8 >= aabbs.len(), "{leaves} leaves");
            if costs.is_some() {
                assert!(
                    two * 5 < bvh.nodes.len(),
                    "{two} of {} two-child nodes",
                    bvh.nodes.len()
                );
            }
        }
    }

    /// The two-hit shortcut orders children as the insertion sort does, ties included.
    #[test]
    fn two_hit_shortcut_matches_the_insertion_sort() {
        let mut n = Node::EMPTY;
        n.child = [10, 11, 12, 13, 14, 15, 16, 17];
        for (ta, tb) in [(1.0, 2.0), (2.0, 1.0), (1.5, 1.5), (0.0, 0.0)] {
            for (a, b) in [(0, 1), (2, 7), (3, 4)] {
                let mut t0 = [9.0; WIDTH];
                (t0[a], t0[b]) = (ta, tb);
                let mask = 1 << a | 1 << b;
                let (mut s1, mut s2) = (Stack::new(), Stack::new());
                let near = push_sorted(&mut s1, &n, &(t0, mask), |_| {});
                assert_eq!(
                    near,
                    push_insertion_sorted(&mut s2, &n, &(t0, mask), |_| {})
                );
                assert_eq!(s1.pop(), s2.pop());
                assert_eq!((s1.pop(), s2.pop()), (None, None));
            }
        }
    }

    #[test]
    fn stack_spills_past_its_inline_part_and_pops_in_order() {
        let mut s = Stack::new();
        let n = 3 * INLINE_STACK as u32;
        for i in 0..n {
            s.push((i, i as f32));
        }
        for i in (0..n).rev() {
            assert_eq!(s.pop(), Some((i, i as f32)));
        }
        assert_eq!(s.pop(), None);
    }
}
