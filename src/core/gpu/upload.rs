//! The scene as the kernel reads it: byte images of every storage buffer of `path.wgsl`, built
//! on the CPU (no device needed, so the layout is unit-tested everywhere).
//!
//! Two BVH layouts ([`BvhLayout`]), both from the native tracer's build parameters:
//! - [`BvhLayout::Wide`] (the default): obvhs' binary build with one primitive per leaf
//!   ([`BUILD_PARAMS_LARGE`]), collapsed by obvhs into a compressed 8-wide BVH (Ylitie et al.
//!   2017: 80-byte nodes, child boxes quantised to 8 bits against the node's origin and
//!   power-of-two scales, children placed by ray octant, leaves of at most 3 primitives), the
//!   primitives gathered into its leaf order. Traversed by `cwbvh.wgsl`.
//! - [`BvhLayout::Binary`]: `build_bvh2` with [`BUILD_PARAMS`], leaves capped at
//!   [`MAX_LEAF_PRIMS`] as `Bvh4` caps them, 32-byte nodes: the baseline, traversed by
//!   `trace_binary` in `path.wgsl`.

use super::GpuError;
use crate::core::scene::{Light, Material, Scene, Texture, NO_LIGHT};
use crate::core::tracer::bvh::{BUILD_PARAMS, BUILD_PARAMS_LARGE};
use crate::core::tracer::bvh4::MAX_LEAF_PRIMS;
use crate::util::hash::mix64;
use crate::util::rng::frame_seed;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use std::time::Duration;

/// Entries of the kernel's traversal stack (`STACK` in `path.wgsl`): a BVH deeper than this is
/// refused, since the kernel would silently drop subtrees.
pub const STACK_DEPTH: usize = 64;

/// Entries of the wide traversal's stack (`WSTACK` in `cwbvh.wgsl`, 8 bytes each): it holds
/// at most one group per inner level below the root, so a wide BVH deeper than this is refused.
pub const WIDE_STACK_DEPTH: usize = 24;

/// Bytes of one binary node (`Node` of `path.wgsl`).
pub const BINARY_NODE_BYTES: usize = 32;
/// Bytes of one wide node (`WNode` of `cwbvh.wgsl`, obvhs' `CwBvhNode`).
pub const WIDE_NODE_BYTES: usize = 80;
/// Invocations in a workgroup of every entry point of the kernel.
pub const WORKGROUP_LANES: usize = 64;
/// Wide nodes a workgroup copies into workgroup memory before it traces (`WCACHE` of
/// `cwbvh.wgsl`): nodes 0 .. 8, the root and, as obvhs numbers them, its up to eight inner
/// children. Nearly every ray reads the root and one or two of those; each lane below this
/// copies one node, 80 bytes shared by the workgroup's 64 rays (M-140).
pub const WIDE_CACHE_NODES: usize = 9;
/// Bytes of one primitive (`Prim` of `path.wgsl`).
pub const PRIM_BYTES: usize = 48;
/// Bytes of one primitive of the wide walk (`wtris` of `cwbvh.wgsl`): geometry only.
pub const WIDE_PRIM_BYTES: usize = 36;
/// `wtris` word 4 of a sphere: a NaN, which no triangle's v1.y is.
pub const SPHERE_TAG: u32 = 0xffff_ffff;

/// Which BVH the kernel traverses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BvhLayout {
    /// The binary BVH, 32-byte nodes: the baseline.
    Binary,
    /// The compressed 8-wide BVH, 80-byte nodes.
    #[default]
    Wide,
}

impl BvhLayout {
    /// Both layouts, baseline first.
    pub const ALL: [BvhLayout; 2] = [BvhLayout::Binary, BvhLayout::Wide];

    /// `binary` or `wide`.
    pub fn id(self) -> &'static str {
        match self {
            BvhLayout::Binary => "binary",
            BvhLayout::Wide => "wide",
        }
    }

    /// Bytes one node fetch reads.
    pub fn node_bytes(self) -> usize {
        match self {
            BvhLayout::Binary => BINARY_NODE_BYTES,
            BvhLayout::Wide => WIDE_NODE_BYTES,
        }
    }
}

/// Bytes of one `PixelOut` of the kernel.
pub const PIXEL_OUT_BYTES: u64 = 32;

const MAT_DIFFUSE: u32 = 0;
const MAT_CHECKER: u32 = 1;
const MAT_MIRROR: u32 = 2;
const MAT_DIELECTRIC: u32 = 3;
const LIGHT_POINT: u32 = 0;
const LIGHT_AREA: u32 = 1;
const LIGHT_ENV: u32 = 2;

/// The golden-ratio increment of SplitMix64, as in `rng.rs`.
const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;

/// Every buffer of the kernel's bind group except the per-dispatch ones, as bytes.
#[derive(Clone, Debug, Default)]
pub struct SceneBuffers {
    /// The layout of `nodes` and of the primitive order.
    pub layout: BvhLayout,
    /// `array<Node>` (binary) or `array<WNode>` (wide); empty geometry: none.
    pub nodes: Vec<u8>,
    /// `array<Prim>` in leaf-slot order.
    pub prims: Vec<u8>,
    /// Wide layout: `wtris`, the primitives' geometry alone in the same slots (empty for the
    /// binary layout).
    pub wide_prims: Vec<u8>,
    /// `array<Material>`.
    pub materials: Vec<u8>,
    /// `array<Light>`.
    pub lights: Vec<u8>,
    /// `array<vec2<u32>>`: area-light entries (leaf slot, running area as f32 bits).
    pub light_prims: Vec<u8>,
    /// `array<Cam>`: one per frame, with its mixed seed.
    pub cams: Vec<u8>,
    /// BVH nodes (the kernel's `params.n_nodes`).
    pub n_nodes: u32,
    /// Depth of the BVH in inner nodes (≤ [`STACK_DEPTH`], wide: ≤ [`WIDE_STACK_DEPTH`]).
    pub depth: usize,
    /// Lights (`params.n_lights`).
    pub n_lights: u32,
}

fn f(v: &mut Vec<u8>, x: f32) {
    v.extend_from_slice(&x.to_le_bytes());
}
fn u(v: &mut Vec<u8>, x: u32) {
    v.extend_from_slice(&x.to_le_bytes());
}
fn v4(v: &mut Vec<u8>, a: [f32; 3], w: f32) {
    for x in a {
        f(v, x);
    }
    f(v, w);
}

/// `mix64(seed ^ golden)` of `Sampler::new`, split into (low, high) words: the part of a
/// sample's key that depends on the seed alone, computed once per frame on the CPU.
pub fn seed_mix(seed: u64) -> [u32; 2] {
    let m = mix64(seed ^ GOLDEN);
    [m as u32, (m >> 32) as u32]
}

/// Lay `scene` out for the kernel with the binary BVH (the baseline layout).
pub fn scene_buffers(scene: &Scene) -> Result<SceneBuffers, GpuError> {
    scene_buffers_with(scene, BvhLayout::Binary)
}

/// Lay `scene` out for the kernel with `layout`. Errors (before any device memory is touched):
/// a BVH deeper than the kernel's stack, or a primitive count past the kernel's 32-bit ids.
pub fn scene_buffers_with(scene: &Scene, layout: BvhLayout) -> Result<SceneBuffers, GpuError> {
    let g = &scene.geometry;
    let n = g.len();
    if n >= (u32::MAX as usize) / 2 {
        return Err(GpuError::Unsupported(format!(
            "{n} primitives: more than the kernel's 32-bit slot ids hold"
        )));
    }
    let mut out = SceneBuffers {
        layout,
        ..Default::default()
    };
    // Leaf order: slot k holds scene primitive `order[k]`.
    let aabbs: Vec<Aabb> = (0..n as u32)
        .map(|p| {
            let (lo, hi) = g.prim_bounds(p);
            Aabb::new(lo.into(), hi.into())
        })
        .collect();
    let order = if n > 0 {
        bvh_nodes(&aabbs, layout, &mut out)?
    } else {
        Vec::new()
    };
    let mut slot_of = vec![0u32; n];
    for (slot, &p) in order.iter().enumerate() {
        slot_of[p as usize] = slot as u32;
    }
    prim_bytes(scene, &order, &mut out);
    material_bytes(scene, &mut out);
    light_bytes(scene, &slot_of, &mut out);
    camera_bytes(scene, &mut out);
    // Light ids in primitives refer to `scene.lights`: unchanged. A binding may not be empty.
    for buf in [
        &mut out.nodes,
        &mut out.prims,
        &mut out.wide_prims,
        &mut out.materials,
        &mut out.lights,
        &mut out.light_prims,
        &mut out.cams,
    ] {
        if buf.is_empty() {
            // 480: a whole number of every element size (32, 48, 80, ...).
            buf.resize(480, 0);
        }
    }
    debug_assert!(scene.lights.len() < NO_LIGHT as usize);
    Ok(out)
}

/// Build the BVH of `aabbs` in `layout`, write its nodes, depth and count into `out`; the
/// primitive order of its leaves (slot k holds primitive `order[k]`).
fn bvh_nodes(
    aabbs: &[Aabb],
    layout: BvhLayout,
    out: &mut SceneBuffers,
) -> Result<Vec<u32>, GpuError> {
    if layout == BvhLayout::Wide {
        // obvhs' collapse needs one primitive per binary leaf; it forms leaves of up to 3.
        let bvh2 = build_bvh2(aabbs, BUILD_PARAMS_LARGE, &mut Duration::default());
        let cw = bvh2_to_cwbvh(&bvh2, 3, true, false);
        for node in &cw.nodes {
            out.nodes.extend_from_slice(&wide_node_bytes(node));
        }
        out.n_nodes = cw.nodes.len() as u32;
        out.depth = wide_depth(&cw.nodes);
        if out.depth > WIDE_STACK_DEPTH {
            return Err(GpuError::Unsupported(format!(
                "wide BVH depth {} exceeds the kernel's traversal stack of {WIDE_STACK_DEPTH}",
                out.depth
            )));
        }
        Ok(cw.primitive_indices)
    } else {
        let mut params = BUILD_PARAMS;
        params.max_prims_per_leaf = params.max_prims_per_leaf.clamp(1, MAX_LEAF_PRIMS);
        let bvh2 = build_bvh2(aabbs, params, &mut Duration::default());
        for node in &bvh2.nodes {
            let (lo, hi) = (node.aabb().min, node.aabb().max);
            v4(&mut out.nodes, [lo.x, lo.y, lo.z], 0.0);
            // The w lane of `lo` is the node's `a` (u32): overwrite its bytes.
            let at = out.nodes.len() - 4;
            out.nodes[at..].copy_from_slice(&node.first_index.to_le_bytes());
            v4(&mut out.nodes, [hi.x, hi.y, hi.z], 0.0);
            let at = out.nodes.len() - 4;
            out.nodes[at..].copy_from_slice(&node.prim_count.to_le_bytes());
        }
        out.n_nodes = bvh2.nodes.len() as u32;
        out.depth = inner_depth(&bvh2.nodes);
        if out.depth > STACK_DEPTH {
            return Err(GpuError::Unsupported(format!(
                "BVH depth {} exceeds the kernel's traversal stack of {STACK_DEPTH}",
                out.depth
            )));
        }
        Ok(bvh2.primitive_indices)
    }
}

/// The primitives in leaf order: the binary layout's 48-byte records, and the wide layout's
/// 36-byte geometry.
fn prim_bytes(scene: &Scene, order: &[u32], out: &mut SceneBuffers) {
    let g = &scene.geometry;
    let layout = out.layout;
    let ns = g.spheres.len() as u32;
    for &p in order {
        let info = g.info[p as usize];
        let flags = info.flip as u32 | if p < ns { 2 } else { 0 };
        let (a, b, c) = if p < ns {
            let s = g.spheres[p as usize];
            (s.center.to_array(), [s.radius, 0.0, 0.0], [0.0; 3])
        } else {
            let t = g.triangles[(p - ns) as usize];
            (t.v0.to_array(), t.v1.to_array(), t.v2.to_array())
        };
        v4(&mut out.prims, a, f32::from_bits(info.material));
        v4(&mut out.prims, b, f32::from_bits(info.light));
        v4(&mut out.prims, c, f32::from_bits(flags));
        if layout == BvhLayout::Wide {
            let w = &mut out.wide_prims;
            for x in a {
                f(w, x);
            }
            if p < ns {
                f(w, b[0]);
                u(w, SPHERE_TAG);
                for _ in 0..4 {
                    f(w, 0.0);
                }
            } else {
                for x in b.into_iter().chain(c) {
                    f(w, x);
                }
            }
        }
    }
}

/// The materials, 48 bytes each.
fn material_bytes(scene: &Scene, out: &mut SceneBuffers) {
    for m in &scene.materials {
        let (kind, a, b) = match *m {
            Material::Diffuse {
                reflectance: Texture::Constant(c),
            } => (MAT_DIFFUSE, (c, 0.0), ([0.0; 3].into(), 0.0)),
            Material::Diffuse {
                reflectance: Texture::Checker { even, odd, size },
            } => (MAT_CHECKER, (even, size as f32), (odd, 0.0)),
            Material::Mirror { reflectance } => {
                (MAT_MIRROR, (reflectance, 0.0), ([0.0; 3].into(), 0.0))
            }
            Material::Dielectric { ior } => (
                MAT_DIELECTRIC,
                ([0.0; 3].into(), 0.0),
                ([0.0; 3].into(), ior),
            ),
        };
        v4(&mut out.materials, a.0.to_array(), a.1);
        v4(&mut out.materials, b.0.to_array(), b.1);
        for x in [kind, 0, 0, 0] {
            u(&mut out.materials, x);
        }
    }
}

/// The lights, 48 bytes each, and the area lights' primitive entries (slot, cdf).
fn light_bytes(scene: &Scene, slot_of: &[u32], out: &mut SceneBuffers) {
    let mut entries: Vec<u8> = Vec::new();
    let mut n_entries = 0u32;
    for l in &scene.lights {
        // A point light's position residual rides in its unused lanes: p.w, c.w, kind.w.
        let mut lo = glam::Vec3::ZERO;
        let (kind, p, c, first, count) = match l {
            Light::Point {
                position,
                position_lo,
                intensity,
            } => {
                lo = *position_lo;
                (LIGHT_POINT, *position, (*intensity, lo.y), 0, 0)
            }
            Light::Area {
                prims,
                cdf,
                area,
                radiance,
            } => {
                let first = n_entries;
                for (&p, &c) in prims.iter().zip(cdf) {
                    u(&mut entries, slot_of[p as usize]);
                    f(&mut entries, c);
                    n_entries += 1;
                }
                (
                    LIGHT_AREA,
                    glam::Vec3::ZERO,
                    (*radiance, *area),
                    first,
                    prims.len() as u32,
                )
            }
            Light::Environment { radiance } => {
                (LIGHT_ENV, glam::Vec3::ZERO, (*radiance, 0.0), 0, 0)
            }
        };
        v4(&mut out.lights, p.to_array(), lo.x);
        v4(&mut out.lights, c.0.to_array(), c.1);
        for x in [kind, first, count, lo.z.to_bits()] {
            u(&mut out.lights, x);
        }
    }
    out.light_prims = entries;
    out.n_lights = scene.lights.len() as u32;
}

/// The cameras (film frame, eye, frame seed), one per frame.
fn camera_bytes(scene: &Scene, out: &mut SceneBuffers) {
    for (k, cam) in scene.cameras.iter().enumerate() {
        let (right, up, fwd, half) = cam.film_frame();
        v4(&mut out.cams, right.to_array(), half.0);
        v4(&mut out.cams, up.to_array(), half.1);
        v4(&mut out.cams, fwd.to_array(), 0.0);
        v4(&mut out.cams, cam.eye().to_array(), 0.0);
        let [lo, hi] = seed_mix(frame_seed(scene.settings.seed, k as u32));
        for x in [lo, hi, 0, 0] {
            u(&mut out.cams, x);
        }
    }
}

/// The 80 bytes of a wide node as `WNode` reads them: p, (e, imask), child and primitive
/// bases, child meta, then the quantised planes (min x, max x, min y, max y, min z, max z).
fn wide_node_bytes(n: &obvhs::cwbvh::node::CwBvhNode) -> [u8; WIDE_NODE_BYTES] {
    let mut b = Vec::with_capacity(WIDE_NODE_BYTES);
    for x in n.p.to_array() {
        f(&mut b, x);
    }
    b.extend_from_slice(&[n.e[0], n.e[1], n.e[2], n.imask]);
    u(&mut b, n.child_base_idx);
    u(&mut b, n.primitive_base_idx);
    b.extend_from_slice(&n.child_meta);
    for q in [
        &n.child_min_x,
        &n.child_max_x,
        &n.child_min_y,
        &n.child_max_y,
        &n.child_min_z,
        &n.child_max_z,
    ] {
        b.extend_from_slice(q);
    }
    b.try_into().expect("80 bytes")
}

/// Inner levels on the longest root-to-leaf path of a wide BVH (the root counts).
fn wide_depth(nodes: &[obvhs::cwbvh::node::CwBvhNode]) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        deepest = deepest.max(d);
        let node = &nodes[i];
        for k in 0..node.imask.count_ones() {
            stack.push((node.child_base_idx as usize + k as usize, d + 1));
        }
    }
    deepest
}

/// Inner nodes on the longest root-to-leaf path of an obvhs binary BVH.
fn inner_depth(nodes: &[obvhs::bvh2::node::Bvh2Node]) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, d)) = stack.pop() {
        let node = &nodes[i];
        if node.prim_count > 0 {
            deepest = deepest.max(d);
            continue;
        }
        let c = node.first_index as usize;
        stack.push((c, d + 1));
        stack.push((c + 1, d + 1));
    }
    deepest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::scene::load_scene;
    use std::path::Path;

    fn load(name: &str) -> Scene {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name);
        load_scene(&p, &Default::default()).unwrap()
    }

    #[test]
    fn every_primitive_has_one_slot_and_the_bvh_fits_the_stack() {
        let scene = load("cornell_box.toml");
        let b = scene_buffers(&scene).unwrap();
        assert_eq!(b.prims.len(), scene.geometry.len() * 48);
        assert!(b.depth >= 1 && b.depth <= STACK_DEPTH);
        // Leaves cover every slot exactly once.
        let mut seen = vec![0u32; scene.geometry.len()];
        for k in 0..b.n_nodes as usize {
            let at = k * 32;
            let word =
                |o: usize| u32::from_le_bytes(b.nodes[at + o..at + o + 4].try_into().unwrap());
            let (a, count) = (word(12), word(28));
            for s in a..a + count {
                seen[s as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
    }

    #[test]
    fn seed_mix_is_the_seed_half_of_the_sampler_key() {
        let m = seed_mix(12345);
        let full = ((m[1] as u64) << 32) | m[0] as u64;
        assert_eq!(full, mix64(12345 ^ GOLDEN));
    }
}
