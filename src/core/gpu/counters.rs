//! Per-ray traversal work, counted the same way on any machine: node fetches, bytes fetched
//! (nodes and primitives), box tests, primitive tests and the deepest traversal stack.
//!
//! Two counters of one algorithm: the kernel's debug pipeline (`count_rays` in `cwbvh.wgsl`,
//! compiled with `COUNT = true`; the render pipeline has it false) and [`CpuTraversal`], which
//! walks the same uploaded bytes ([`SceneBuffers`]) with the same f32 arithmetic (explicit
//! fused multiply-adds where the kernel has `fma`). For the same rays both give the same counts
//! and hits (tested on lavapipe), so the CPU path measures the design without a device.
//!
//! What counts as a fetch is what the kernel reads: the binary walk reads the node it stands
//! on and then both children to test their boxes (three 32-byte reads per inner node, one per
//! leaf); the wide walk reads one 80-byte node and tests its (at most 8) quantised child boxes.
//! Each primitive test reads one primitive: 48 bytes binary (`prims`, with material and light
//! ids), 36 wide (`wtris`, geometry alone). Shading reads are not traversal and are not counted.
//! The wide walk also drops a stacked group unfetched once the closest hit so far lies before
//! its children's nearest entry (a distance kept beside each stack entry).

use super::upload::{
    BvhLayout, SceneBuffers, PRIM_BYTES, SPHERE_TAG, WIDE_CACHE_NODES, WIDE_NODE_BYTES,
    WIDE_PRIM_BYTES, WORKGROUP_LANES,
};
use super::wgsl_math::{box_hit, safe_inv, shear, sphere_hit, tri_hit, Sheared, FAR_SCALE};
use crate::core::scene::Scene;
use crate::util::rng::{frame_seed, Sampler};

/// What one ray's traversal did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Node reads.
    pub node_fetches: u32,
    /// Bytes read: nodes and primitives.
    pub bytes: u32,
    /// Child boxes tested.
    pub box_tests: u32,
    /// Primitives tested (triangles and spheres).
    pub tri_tests: u32,
    /// Deepest the traversal stack got (entries: 4 bytes binary, 8 bytes wide).
    pub max_stack: u32,
}

/// One ray for the counting traversals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CountRay {
    /// Origin.
    pub o: [f32; 3],
    /// Direction (t in its units).
    pub d: [f32; 3],
    /// Hits count for 0 < t < t_max.
    pub t_max: f32,
    /// Any hit (shadow ray) rather than the closest.
    pub shadow: bool,
}

impl CountRay {
    /// The four (u32, u32) task words `count_rays` reads.
    pub fn words(&self) -> [[u32; 2]; 4] {
        let b = |x: f32| x.to_bits();
        [
            [b(self.o[0]), b(self.o[1])],
            [b(self.o[2]), b(self.t_max)],
            [b(self.d[0]), b(self.d[1])],
            [b(self.d[2]), self.shadow as u32],
        ]
    }
}

/// One ray's counts and hit: (t, leaf slot) of the hit, `None` for a miss.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counted {
    /// The work.
    pub counts: RayCounts,
    /// (t, primitive slot in the layout's order).
    pub hit: Option<(f32, u32)>,
}

impl Counted {
    /// Same counts, same primitive hit, and hit distances within 1e-5 relative: the kernel's
    /// compiler may fuse a multiply and an add that the CPU rounds apart, which moves t by an
    /// ulp or so without changing the walk.
    pub fn agrees(&self, other: &Counted) -> bool {
        self.counts == other.counts
            && match (self.hit, other.hit) {
                (None, None) => true,
                (Some((ta, a)), Some((tb, b))) => {
                    a == b && (ta - tb).abs() <= 1e-5 * ta.abs().max(tb.abs())
                }
                _ => false,
            }
    }
}

/// The primary rays of frame `frame`: one per pixel, sample 0's jitter, in pixel order.
pub fn primary_rays(scene: &Scene, frame: u32) -> Vec<CountRay> {
    let cam = &scene.cameras[frame as usize];
    let seed = frame_seed(scene.settings.seed, frame);
    let (w, h) = (scene.width(), scene.height());
    let mut out = Vec::with_capacity((w * h) as usize);
    for p in 0..w * h {
        let mut s = Sampler::new(seed, p as u64, 0);
        let (jx, jy) = s.next2();
        let r = cam.pixel_ray(p % w, p / w, jx, jy);
        out.push(CountRay {
            o: r.o.to_array(),
            d: r.d.to_array(),
            t_max: f32::INFINITY,
            shadow: false,
        });
    }
    out
}

/// Sums over a set of rays, and their per-ray means.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Rays counted.
    pub rays: u64,
    /// Sum of node fetches.
    pub node_fetches: u64,
    /// Sum of bytes.
    pub bytes: u64,
    /// Sum of box tests.
    pub box_tests: u64,
    /// Sum of primitive tests.
    pub tri_tests: u64,
    /// Sum of each ray's deepest stack.
    pub stack_sum: u64,
    /// Deepest stack of any ray.
    pub max_stack: u32,
    /// Rays that hit.
    pub hits: u64,
}

impl Summary {
    /// Sums over `rays`.
    pub fn of<'a>(rays: impl IntoIterator<Item = &'a Counted>) -> Self {
        let mut s = Self::default();
        for r in rays {
            let c = r.counts;
            s.rays += 1;
            s.node_fetches += c.node_fetches as u64;
            s.bytes += c.bytes as u64;
            s.box_tests += c.box_tests as u64;
            s.tri_tests += c.tri_tests as u64;
            s.stack_sum += c.max_stack as u64;
            s.max_stack = s.max_stack.max(c.max_stack);
            s.hits += r.hit.is_some() as u64;
        }
        s
    }

    fn mean(&self, x: u64) -> f64 {
        x as f64 / self.rays.max(1) as f64
    }

    /// (node fetches, bytes, box tests, primitive tests, stack depth) per ray.
    pub fn per_ray(&self) -> [f64; 5] {
        [
            self.mean(self.node_fetches),
            self.mean(self.bytes),
            self.mean(self.box_tests),
            self.mean(self.tri_tests),
            self.mean(self.stack_sum),
        ]
    }

    /// One line: `rays N node_fetches X bytes Y box_tests Z tri_tests W stack_mean S stack_max M`.
    pub fn line(&self) -> String {
        let [n, b, bx, t, st] = self.per_ray();
        format!(
            "rays {} node_fetches {n:.2} bytes {b:.1} box_tests {bx:.2} tri_tests {t:.2} \
             stack_mean {st:.2} stack_max {} hits {}",
            self.rays, self.max_stack, self.hits
        )
    }
}

#[derive(Clone, Copy)]
struct BinNode {
    lo: [f32; 3],
    a: u32,
    hi: [f32; 3],
    count: u32,
}

#[derive(Clone, Copy)]
struct WideNode {
    p: [f32; 3],
    e: [u8; 3],
    imask: u8,
    child_base: u32,
    prim_base: u32,
    meta: [u8; 8],
    /// min x, max x, min y, max y, min z, max z.
    q: [[u8; 8]; 6],
}

#[derive(Clone, Copy)]
struct Prim {
    v: [[f32; 4]; 3],
}

/// The kernel's traversal of one layout, on the CPU, over the bytes the kernel is given.
pub struct CpuTraversal {
    layout: BvhLayout,
    bin: Vec<BinNode>,
    wide: Vec<WideNode>,
    prims: Vec<Prim>,
    wide_prims: Vec<[f32; 9]>,
}

fn word(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn fword(b: &[u8], at: usize) -> f32 {
    f32::from_bits(word(b, at))
}

const STACK: usize = super::upload::STACK_DEPTH;
const WSTACK: usize = super::upload::WIDE_STACK_DEPTH;

impl CpuTraversal {
    /// Parse the node and primitive buffers of `bufs` (as uploaded).
    pub fn new(bufs: &SceneBuffers) -> Self {
        let n = bufs.n_nodes as usize;
        let nb = &bufs.nodes;
        let mut bin = Vec::new();
        let mut wide = Vec::new();
        match bufs.layout {
            BvhLayout::Binary => {
                bin = (0..n)
                    .map(|k| {
                        let at = k * 32;
                        BinNode {
                            lo: [fword(nb, at), fword(nb, at + 4), fword(nb, at + 8)],
                            a: word(nb, at + 12),
                            hi: [fword(nb, at + 16), fword(nb, at + 20), fword(nb, at + 24)],
                            count: word(nb, at + 28),
                        }
                    })
                    .collect()
            }
            BvhLayout::Wide => {
                wide = (0..n)
                    .map(|k| {
                        let b = &nb[k * 80..k * 80 + 80];
                        WideNode {
                            p: [fword(b, 0), fword(b, 4), fword(b, 8)],
                            e: [b[12], b[13], b[14]],
                            imask: b[15],
                            child_base: word(b, 16),
                            prim_base: word(b, 20),
                            meta: b[24..32].try_into().expect("8 bytes"),
                            q: std::array::from_fn(|a| {
                                b[32 + 8 * a..40 + 8 * a].try_into().expect("8 bytes")
                            }),
                        }
                    })
                    .collect()
            }
        }
        let prims: Vec<Prim> = (0..bufs.prims.len() / PRIM_BYTES)
            .map(|k| Prim {
                v: std::array::from_fn(|r| {
                    std::array::from_fn(|c| fword(&bufs.prims, k * PRIM_BYTES + 16 * r + 4 * c))
                }),
            })
            .collect();
        let wide_prims = if bufs.layout == BvhLayout::Wide {
            (0..prims.len())
                .map(|k| {
                    std::array::from_fn(|c| fword(&bufs.wide_prims, k * WIDE_PRIM_BYTES + 4 * c))
                })
                .collect()
        } else {
            Vec::new()
        };
        Self {
            layout: bufs.layout,
            bin,
            wide,
            prims,
            wide_prims,
        }
    }

    /// The layout walked.
    pub fn layout(&self) -> BvhLayout {
        self.layout
    }

    /// Bytes lane `lane` of a workgroup reads to fill the workgroup's copy of the top of the
    /// wide tree (`fill_wcache`): one node for each lane below the nodes copied.
    pub fn fill_bytes(&self, lane: usize) -> u32 {
        let copied = match self.layout {
            BvhLayout::Binary => 0,
            BvhLayout::Wide => self.wide.len().min(WIDE_CACHE_NODES),
        };
        if lane < copied {
            WIDE_NODE_BYTES as u32
        } else {
            0
        }
    }

    /// Trace `r` as the kernel's `trace` does, counting; the fill of the workgroup's copy
    /// ([`CpuTraversal::fill_bytes`]) is not included.
    pub fn trace(&self, r: &CountRay) -> Counted {
        let mut c = RayCounts::default();
        let hit = match self.layout {
            BvhLayout::Binary if !self.bin.is_empty() => self.trace_binary(r, &mut c),
            BvhLayout::Wide if !self.wide.is_empty() => self.trace_wide(r, &mut c),
            _ => None,
        };
        Counted { counts: c, hit }
    }

    fn prim_hit(
        &self,
        slot: u32,
        r: &CountRay,
        sh: &Sheared,
        t_max: f32,
        c: &mut RayCounts,
    ) -> Option<f32> {
        c.tri_tests += 1;
        c.bytes += PRIM_BYTES as u32;
        let p = &self.prims[slot as usize].v;
        let xyz = |k: usize| [p[k][0], p[k][1], p[k][2]];
        if p[2][3].to_bits() & 2 != 0 {
            return sphere_hit(xyz(0), p[1][0], r.o, r.d, t_max);
        }
        tri_hit(sh, xyz(0), xyz(1), xyz(2), t_max)
    }

    /// `wprim_hit` of cwbvh.wgsl.
    fn wide_prim_hit(
        &self,
        slot: u32,
        r: &CountRay,
        sh: &Sheared,
        t_max: f32,
        c: &mut RayCounts,
    ) -> Option<f32> {
        c.tri_tests += 1;
        c.bytes += WIDE_PRIM_BYTES as u32;
        let p = &self.wide_prims[slot as usize];
        let v = |k: usize| [p[k], p[k + 1], p[k + 2]];
        if p[4].to_bits() == SPHERE_TAG {
            return sphere_hit(v(0), p[3], r.o, r.d, t_max);
        }
        tri_hit(sh, v(0), v(3), v(6), t_max)
    }

    fn trace_binary(&self, r: &CountRay, c: &mut RayCounts) -> Option<(f32, u32)> {
        let sh = shear(r.o, r.d);
        let inv = safe_inv(r.d);
        let mut t_max = r.t_max;
        let mut best = None;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        let fetch = |c: &mut RayCounts, k: u32| {
            c.node_fetches += 1;
            c.bytes += 32;
            self.bin[k as usize]
        };
        loop {
            let n = fetch(c, node);
            if n.count > 0 {
                for k in 0..n.count {
                    if let Some(t) = self.prim_hit(n.a + k, r, &sh, t_max, c) {
                        best = Some((t, n.a + k));
                        t_max = t;
                        if r.shadow {
                            return best;
                        }
                    }
                }
            } else {
                let l = fetch(c, n.a);
                let rr = fetch(c, n.a + 1);
                c.box_tests += 2;
                let tl = box_hit(l.lo, l.hi, r.o, inv, t_max);
                let tr = box_hit(rr.lo, rr.hi, r.o, inv, t_max);
                match (tl, tr) {
                    (Some(tl), Some(tr)) => {
                        (stack[sp], node) = if tl <= tr {
                            (n.a + 1, n.a)
                        } else {
                            (n.a, n.a + 1)
                        };
                        sp += 1;
                        c.max_stack = c.max_stack.max(sp as u32);
                        continue;
                    }
                    (Some(_), None) => {
                        node = n.a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = n.a + 1;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        best
    }

    /// `wide_hits` of cwbvh.wgsl.
    fn wide_hits(
        n: &WideNode,
        o: [f32; 3],
        inv: [f32; 3],
        oct: u32,
        t_max: f32,
        c: &mut RayCounts,
    ) -> (u32, f32) {
        let e: [f32; 3] = std::array::from_fn(|a| f32::from_bits((n.e[a] as u32) << 23));
        let adj_inv: [f32; 3] = std::array::from_fn(|a| e[a] * inv[a]);
        let adj_o: [f32; 3] = std::array::from_fn(|a| (n.p[a] - o[a]) * inv[a]);
        let mut hits = 0u32;
        let mut t_in = f32::INFINITY;
        for k in 0..8 {
            let meta = n.meta[k] as u32;
            if meta == 0 {
                continue;
            }
            c.box_tests += 1;
            let lo: [f32; 3] = std::array::from_fn(|a| n.q[2 * a][k] as f32);
            let hi: [f32; 3] = std::array::from_fn(|a| n.q[2 * a + 1][k] as f32);
            let ta: [f32; 3] = std::array::from_fn(|a| lo[a].mul_add(adj_inv[a], adj_o[a]));
            let tb: [f32; 3] = std::array::from_fn(|a| hi[a].mul_add(adj_inv[a], adj_o[a]));
            let near: [f32; 3] = std::array::from_fn(|a| ta[a].min(tb[a]));
            let far: [f32; 3] = std::array::from_fn(|a| ta[a].max(tb[a]));
            let t0 = near[0].max(near[1]).max(near[2].max(0.0));
            let t1 = (far[0].min(far[1]) * FAR_SCALE).min((far[2] * FAR_SCALE).min(t_max));
            if t0 <= t1 {
                if meta & 0x18 == 0x18 {
                    hits |= 1 << (24 + ((meta & 7) ^ oct));
                    t_in = t_in.min(t0);
                } else {
                    hits |= (meta >> 5) << (meta & 0x1f);
                }
            }
        }
        (hits, t_in)
    }

    fn trace_wide(&self, r: &CountRay, c: &mut RayCounts) -> Option<(f32, u32)> {
        let sh = shear(r.o, r.d);
        let inv = safe_inv(r.d);
        let oct = (if inv[0] < 0.0 { 0 } else { 4 })
            | (if inv[1] < 0.0 { 0 } else { 2 })
            | (if inv[2] < 0.0 { 0 } else { 1 });
        let mut t_max = r.t_max;
        let mut best = None;
        let mut stack = [([0u32; 2], 0f32); WSTACK];
        let mut sp = 0usize;
        let mut group = [0u32, 0x8000_0000];
        let mut t_in = 0f32;
        let mut prims = [0u32, 0];
        loop {
            while prims[1] != 0 {
                let k = 31 - prims[1].leading_zeros();
                prims[1] &= !(1 << k);
                let slot = prims[0] + k;
                if let Some(t) = self.wide_prim_hit(slot, r, &sh, t_max, c) {
                    best = Some((t, slot));
                    t_max = t;
                    if r.shadow {
                        return best;
                    }
                }
            }
            if group[1] & 0xff00_0000 != 0 && t_in <= t_max {
                let hits = group[1];
                let bit = 31 - (hits & 0xff00_0000).leading_zeros();
                group[1] &= !(1 << bit);
                if group[1] & 0xff00_0000 != 0 {
                    stack[sp] = (group, t_in);
                    sp += 1;
                    c.max_stack = c.max_stack.max(sp as u32);
                }
                let slot = (bit - 24) ^ oct;
                let index = group[0] + (hits & !(u32::MAX << slot)).count_ones();
                let n = &self.wide[index as usize];
                c.node_fetches += 1;
                // The top of the tree is read from the workgroup's copy (`wcache`).
                if index as usize >= WIDE_CACHE_NODES {
                    c.bytes += WIDE_NODE_BYTES as u32;
                }
                let (h, t) = Self::wide_hits(n, r.o, inv, oct, t_max, c);
                group = [n.child_base, (h & 0xff00_0000) | n.imask as u32];
                t_in = t;
                prims = [n.prim_base, h & 0x00ff_ffff];
            } else {
                group = [0, 0];
            }
            if prims[1] == 0 && group[1] & 0xff00_0000 == 0 {
                if sp == 0 {
                    break;
                }
                sp -= 1;
                (group, t_in) = stack[sp];
            }
        }
        best
    }
}

/// The counts of `rays` over `bufs` on the CPU, in ray order, ray k in lane k % 64 of a
/// workgroup as `count_rays` runs them (lanes past the last ray of a partial workgroup copy
/// nodes too, uncounted, as in the kernel).
pub fn cpu_counts(bufs: &SceneBuffers, rays: &[CountRay]) -> Vec<Counted> {
    use rayon::prelude::*;
    let t = CpuTraversal::new(bufs);
    rays.par_iter()
        .enumerate()
        .map(|(k, r)| {
            let mut c = t.trace(r);
            c.counts.bytes += t.fill_bytes(k % WORKGROUP_LANES);
            c
        })
        .collect()
}

/// One layout's counts over the same rays: on the CPU, and from the kernel where a device ran.
#[derive(Clone, Debug)]
pub struct LayoutCounts {
    /// The layout.
    pub layout: BvhLayout,
    /// Its nodes and depth (inner levels).
    pub nodes: u32,
    /// Inner levels on the longest path.
    pub depth: usize,
    /// The CPU traversal's sums.
    pub cpu: Summary,
    /// The kernel's sums (`None`: no device asked).
    pub gpu: Option<Summary>,
    /// Rays whose kernel counts or hit differ from the CPU's ([`Counted::agrees`]).
    pub mismatched: u64,
}

/// Both layouts over the primary rays of a scene's frame 0.
#[derive(Clone, Debug)]
pub struct CounterReport {
    /// Scene name.
    pub scene: String,
    /// Image size (one ray a pixel).
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Binary first, then wide.
    pub layouts: Vec<LayoutCounts>,
}

impl CounterReport {
    /// (wide ÷ binary) of the CPU's per-ray node fetches, bytes, box tests, primitive tests and
    /// mean stack depth.
    pub fn ratios(&self) -> [f64; 5] {
        let b = self.layouts[0].cpu.per_ray();
        let w = self.layouts[1].cpu.per_ray();
        std::array::from_fn(|k| w[k] / b[k].max(f64::MIN_POSITIVE))
    }
}

impl std::fmt::Display for CounterReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = "gpu-counters";
        writeln!(
            f,
            "{p} scene {} {}x{} primary rays (sample 0 of every pixel, frame 0)",
            self.scene, self.width, self.height
        )?;
        for l in &self.layouts {
            let id = l.layout.id();
            writeln!(
                f,
                "{p} {id} nodes {} depth {} node_bytes {}",
                l.nodes,
                l.depth,
                l.layout.node_bytes()
            )?;
            writeln!(f, "{p} {id} cpu {}", l.cpu.line())?;
            if let Some(g) = &l.gpu {
                writeln!(
                    f,
                    "{p} {id} gpu {} mismatched_rays {}",
                    g.line(),
                    l.mismatched
                )?;
            }
        }
        let [n, b, bx, t, st] = self.ratios();
        writeln!(
            f,
            "{p} wide/binary node_fetches {n:.3} bytes {b:.3} box_tests {bx:.3} tri_tests {t:.3} \
             stack_mean {st:.3}"
        )
    }
}

/// The counts of both layouts over the primary rays of `scene` (frame 0) on the CPU, and with
/// `ctx` on its device too (the kernel's debug pipeline), with the rays on which they differ.
pub fn report(
    scene: &Scene,
    ctx: Option<&super::GpuContext>,
) -> Result<CounterReport, super::GpuError> {
    let rays = primary_rays(scene, 0);
    let mut layouts = Vec::new();
    for layout in BvhLayout::ALL {
        let bufs = super::upload::scene_buffers_with(scene, layout)?;
        let cpu = cpu_counts(&bufs, &rays);
        let (gpu, mismatched) = match ctx {
            None => (None, 0),
            Some(ctx) => {
                let r = super::GpuRenderer::with_buffers(ctx.clone(), scene, &bufs)?;
                let g = r.count_rays(&rays)?;
                let bad = g.iter().zip(&cpu).filter(|(a, b)| !a.agrees(b)).count() as u64;
                (Some(Summary::of(&g)), bad)
            }
        };
        layouts.push(LayoutCounts {
            layout,
            nodes: bufs.n_nodes,
            depth: bufs.depth,
            cpu: Summary::of(&cpu),
            gpu,
            mismatched,
        });
    }
    Ok(CounterReport {
        scene: scene.name.clone(),
        width: scene.width(),
        height: scene.height(),
        layouts,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::gpu::upload::{scene_buffers_with, WIDE_STACK_DEPTH};
    use crate::core::scene::{load_scene, SceneOverrides};
    use std::path::Path;

    fn load(name: &str, o: SceneOverrides) -> Scene {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name);
        load_scene(&p, &o).unwrap()
    }

    fn sized(w: u32, count: Option<u64>) -> SceneOverrides {
        SceneOverrides {
            width: Some(w),
            height: Some(w),
            generator_count: count,
            ..Default::default()
        }
    }

    /// Per primary ray, the wide BVH against the binary one on the CPU counting path: node
    /// fetches at most half (measured 0.147) and bytes at most a third (measured 0.296 with the
    /// workgroup's copy of the top of the tree and its fill counted, 0.392 before: M-140). The
    /// 1 M-triangle scene (`complex.toml`) at 256² rays; its 1024² figures are
    /// `raysched render --gpu-counters`'s.
    #[test]
    fn the_wide_bvh_fetches_under_half_the_nodes_and_a_third_of_the_bytes() {
        let scene = load("complex.toml", sized(256, None));
        let r = report(&scene, None).unwrap();
        let [nodes, bytes, ..] = r.ratios();
        assert!(
            nodes <= 0.5,
            "node fetches wide/binary {nodes:.3} > 1/2\n{r}"
        );
        assert!(
            bytes <= 1.0 / 3.0,
            "bytes wide/binary {bytes:.3} > 1/3\n{r}"
        );
        // Both walks found the same surfaces: equal hit counts.
        assert_eq!(r.layouts[0].cpu.hits, r.layouts[1].cpu.hits, "{r}");
        assert!(r.layouts[1].cpu.max_stack as usize <= WIDE_STACK_DEPTH);
    }

    /// Both layouts give every primitive one slot, and closest hits agree on the Cornell box
    /// (same primitive, same t) for every primary ray.
    #[test]
    fn both_layouts_hit_the_same_primitives() {
        for name in ["cornell_box.toml", "glass_checker.toml", "complex.toml"] {
            let scene = load(name, sized(48, Some(20_000)));
            let rays = primary_rays(&scene, 0);
            let hits: Vec<Vec<Option<(f32, u32)>>> = BvhLayout::ALL
                .iter()
                .map(|&l| {
                    let b = scene_buffers_with(&scene, l).unwrap();
                    assert_eq!(b.prims.len(), scene.geometry.len() * PRIM_BYTES, "{name}");
                    // Slot -> the scene primitive: its first vertex (or centre) and material.
                    let t = CpuTraversal::new(&b);
                    cpu_counts(&b, &rays)
                        .iter()
                        .map(|c| {
                            c.hit
                                .map(|(t_hit, s)| (t_hit, t.prims[s as usize].v[0][0].to_bits()))
                        })
                        .collect()
                })
                .collect();
            assert_eq!(hits[0].len(), hits[1].len());
            let same = hits[0].iter().zip(&hits[1]).filter(|(a, b)| a == b).count();
            assert!(hits[0].iter().any(|h| h.is_some()), "{name}: no hits");
            assert_eq!(
                same,
                hits[0].len(),
                "{name}: {} of {} differ",
                hits[0].len() - same,
                hits[0].len()
            );
        }
    }
}
