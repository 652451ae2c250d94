// The traversals of the GPU kernel, appended to path.wgsl when the pipelines are built:
// `trace` picks the compressed 8-wide BVH (WIDE, the default) or the binary baseline
// (`trace_binary` in path.wgsl). The wide traversal follows Ylitie et al. 2017 as obvhs lays
// it out (`traverse!` in obvhs' cwbvh): a group is (child or primitive base, hit bits); inner
// children are visited front to back by ray octant, one 8-byte stack entry per partly visited
// node. `src/gpu/counters.rs` runs the same algorithm on the CPU: keep the two in step.

// The layout of the nodes bound (set per pipeline): true = `wnodes`, false = `nodes`.
override WIDE: bool = true;
// The debug variant: tally per-ray traversal work into `ctr` (folds away when false).
override COUNT: bool = false;

const WSTACK: u32 = 24u;
const WNODE_BYTES: u32 = 80u;
const NODE_BYTES: u32 = 32u;
const PRIM_BYTES: u32 = 48u;

// obvhs' CwBvhNode: p = origin; e_imask = exponents of x, y, z (bytes 0-2) and the inner-child
// mask (byte 3); cm (child meta; `meta` is reserved): per child slot, 0 = empty, leaf = (unary
// count << 5) | offset from prim_base, inner = 0b001_11xxx (24 + slot); q: per axis (min
// bytes, max bytes) of the 8 slots.
struct WNode {
    p: vec3<f32>,
    e_imask: u32,
    child_base: u32,
    prim_base: u32,
    cm: vec2<u32>,
    q: array<vec4<u32>, 3>,
}

@group(0) @binding(9) var<storage, read> wnodes: array<WNode>;

// The top of the wide BVH in workgroup memory: nodes 0 .. WCACHE - 1, the root and then (obvhs
// numbers them next) its inner children, which nearly every ray of a workgroup reads. Lanes
// 0 .. WCACHE - 1 copy one node each at the start of an entry point (`fill_wcache`); the walk
// reads those nodes from here. The counters charge each copy's 80 bytes to the lane that made
// it, so a workgroup's rays together pay for the fill once (WIDE_CACHE_NODES in upload.rs).
const WCACHE: u32 = 9u;
var<workgroup> wcache: array<WNode, WCACHE>;
// The wide walk's primitives, in the same slots as `prims` but geometry only (36 bytes):
// a triangle's v0, v1, v2; a sphere's centre, radius, then SPHERE_TAG (a NaN no vertex has).
@group(0) @binding(10) var<storage, read> wtris: array<u32>;

const SPHERE_TAG: u32 = 0xffffffffu;
const WTRI_BYTES: u32 = 36u;

struct Counters {
    nodes: u32,
    bytes: u32,
    boxes: u32,
    tris: u32,
    stack: u32,
}

var<private> ctr: Counters;

fn count_node(bytes: u32) {
    ctr.nodes += 1u;
    ctr.bytes += bytes;
}

fn count_prim(bytes: u32) {
    ctr.tris += 1u;
    ctr.bytes += bytes;
}

fn wtri_vec(at: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(wtris[at]), bitcast<f32>(wtris[at + 1u]), bitcast<f32>(wtris[at + 2u]));
}

// `prim_hit` over `wtris`.
fn wprim_hit(slot: u32, o: vec3<f32>, d: vec3<f32>, sh: Sheared, t_max: f32) -> vec4<f32> {
    let at = 9u * slot;
    if wtris[at + 4u] == SPHERE_TAG {
        let t = sphere_hit(wtri_vec(at), bitcast<f32>(wtris[at + 3u]), o, d, t_max);
        return vec4<f32>(t, 0.0, 0.0, select(0.0, 1.0, t > 0.0));
    }
    return tri_hit(sh, wtri_vec(at), wtri_vec(at + 3u), wtri_vec(at + 6u), t_max);
}

// Copy the top of the tree into `wcache`; every lane of the workgroup must call it, before any
// lane returns (it ends in a barrier).
fn fill_wcache(lane: u32) {
    if WIDE && lane < min(params.n_nodes, WCACHE) {
        wcache[lane] = wnodes[lane];
        if COUNT {
            ctr.bytes += WNODE_BYTES;
        }
    }
    workgroupBarrier();
}

fn count_stack(depth: u32) {
    ctr.stack = max(ctr.stack, depth);
}

// Closest hit (shadow = false) or any hit (shadow = true) with 0 < t < t_max; slot = NO_LIGHT: none.
fn trace(o: vec3<f32>, d: vec3<f32>, t_max: f32, shadow: bool) -> Hit {
    if !WIDE {
        return trace_binary(o, d, t_max, shadow);
    }
    if shadow {
        return occluded_wide(o, d, t_max);
    }
    return closest_wide(o, d, t_max);
}

fn byte8(v: vec2<u32>, c: u32) -> u32 {
    return (select(v.x, v.y, c >= 4u) >> ((c & 3u) * 8u)) & 0xffu;
}

// Ray octant as obvhs' `oct_inv4` byte: 4 / 2 / 1 where x / y / z point the positive way.
fn octant_inv(inv: vec3<f32>) -> u32 {
    return select(4u, 0u, inv.x < 0.0) | select(2u, 0u, inv.y < 0.0) | select(1u, 0u, inv.z < 0.0);
}

struct WideHits {
    bits: u32,
    // Nearest entry distance of the inner children hit (inf: none).
    t_in: f32,
}

// The hit bits of node n's children: inner children at bit 24 + (slot ^ octant), leaves their
// primitives' bits (offset .. offset + count) in the low 24.
fn wide_hits(n: WNode, o: vec3<f32>, inv: vec3<f32>, oct: u32, t_max: f32) -> WideHits {
    let e = vec3<f32>(
        bitcast<f32>((n.e_imask & 0xffu) << 23u),
        bitcast<f32>(((n.e_imask >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((n.e_imask >> 16u) & 0xffu) << 23u),
    );
    // t of plane q: (p + q·e − o) · inv = q · (e · inv) + (p − o) · inv; e is a power of two.
    let adj_inv = e * inv;
    let adj_o = (n.p - o) * inv;
    var hits = 0u;
    var t_in = inf();
    for (var c = 0u; c < 8u; c++) {
        let cm = byte8(n.cm, c);
        if cm == 0u {
            continue;
        }
        if COUNT {
            ctr.boxes += 1u;
        }
        let lo = vec3<f32>(f32(byte8(n.q[0].xy, c)), f32(byte8(n.q[1].xy, c)), f32(byte8(n.q[2].xy, c)));
        let hi = vec3<f32>(f32(byte8(n.q[0].zw, c)), f32(byte8(n.q[1].zw, c)), f32(byte8(n.q[2].zw, c)));
        let ta = fma(lo, adj_inv, adj_o);
        let tb = fma(hi, adj_inv, adj_o);
        let near = min(ta, tb);
        let far = max(ta, tb);
        let t0 = max(max(near.x, near.y), max(near.z, 0.0));
        let t1 = min(min(far.x, far.y) * FAR_SCALE, min(far.z * FAR_SCALE, t_max));
        if t0 <= t1 {
            if (cm & 0x18u) == 0x18u {
                hits |= 1u << (24u + ((cm & 7u) ^ oct));
                t_in = min(t_in, t0);
            } else {
                hits |= (cm >> 5u) << (cm & 0x1fu);
            }
        }
    }
    return WideHits(hits, t_in);
}

// group: (first child node, inner hit bits << 24 | inner mask) with t_in, the nearest entry
// of those children: a group entered beyond the closest hit so far is dropped unfetched.
// prims: (first primitive, hit primitive bits).
struct Walk {
    group: vec2<u32>,
    t_in: f32,
    prims: vec2<u32>,
}

struct Stack {
    group: array<vec2<u32>, WSTACK>,
    t_in: array<f32, WSTACK>,
}

// Take the next inner child of w.group (pushing what remains), fetch it and test its children.
fn wide_step(w: ptr<function, Walk>, stack: ptr<function, Stack>, sp: ptr<function, u32>,
             o: vec3<f32>, inv: vec3<f32>, oct: u32, t_max: f32) {
    let hits = (*w).group.y;
    let bit = firstLeadingBit(hits & 0xff000000u);
    (*w).group.y &= ~(1u << bit);
    if ((*w).group.y & 0xff000000u) != 0u {
        (*stack).group[*sp] = (*w).group;
        (*stack).t_in[*sp] = (*w).t_in;
        *sp += 1u;
        if COUNT {
            count_stack(*sp);
        }
    }
    let slot = (bit - 24u) ^ oct;
    let index = (*w).group.x + countOneBits(hits & ~(0xffffffffu << slot));
    var n: WNode;
    if index < WCACHE {
        n = wcache[index];
        if COUNT {
            count_node(0u);
        }
    } else {
        n = wnodes[index];
        if COUNT {
            count_node(WNODE_BYTES);
        }
    }
    let h = wide_hits(n, o, inv, oct, t_max);
    (*w).group = vec2<u32>(n.child_base, (h.bits & 0xff000000u) | (n.e_imask >> 24u));
    (*w).t_in = h.t_in;
    (*w).prims = vec2<u32>(n.prim_base, h.bits & 0x00ffffffu);
}

fn closest_wide(o: vec3<f32>, d: vec3<f32>, t_max0: f32) -> Hit {
    var best = Hit(0.0, NO_LIGHT, 0.0, 0.0);
    if params.n_nodes == 0u {
        return best;
    }
    let sh = shear(o, d);
    let inv = safe_inv(d);
    let oct = octant_inv(inv);
    var t_max = t_max0;
    var stack: Stack;
    var sp = 0u;
    // The root as the one inner child of a virtual group based at node 0.
    var w = Walk(vec2<u32>(0u, 0x80000000u), 0.0, vec2<u32>(0u, 0u));
    loop {
        while w.prims.y != 0u {
            let k = firstLeadingBit(w.prims.y);
            w.prims.y &= ~(1u << k);
            let slot = w.prims.x + k;
            if COUNT {
                count_prim(WTRI_BYTES);
            }
            let h = wprim_hit(slot, o, d, sh, t_max);
            if h.w > 0.0 {
                best = Hit(h.x, slot, h.y, h.z);
                t_max = h.x;
            }
        }
        if (w.group.y & 0xff000000u) != 0u && w.t_in <= t_max {
            wide_step(&w, &stack, &sp, o, inv, oct, t_max);
        } else {
            w.group = vec2<u32>(0u, 0u);
        }
        if w.prims.y == 0u && (w.group.y & 0xff000000u) == 0u {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            w.group = stack.group[sp];
            w.t_in = stack.t_in[sp];
        }
    }
    return best;
}

// Any hit: the first primitive found ends the walk; no barycentrics are kept.
fn occluded_wide(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Hit {
    if params.n_nodes == 0u {
        return Hit(0.0, NO_LIGHT, 0.0, 0.0);
    }
    let sh = shear(o, d);
    let inv = safe_inv(d);
    let oct = octant_inv(inv);
    var stack: Stack;
    var sp = 0u;
    var w = Walk(vec2<u32>(0u, 0x80000000u), 0.0, vec2<u32>(0u, 0u));
    loop {
        while w.prims.y != 0u {
            let k = firstLeadingBit(w.prims.y);
            w.prims.y &= ~(1u << k);
            let slot = w.prims.x + k;
            if COUNT {
                count_prim(WTRI_BYTES);
            }
            let h = wprim_hit(slot, o, d, sh, t_max);
            if h.w > 0.0 {
                return Hit(h.x, slot, 0.0, 0.0);
            }
        }
        if (w.group.y & 0xff000000u) != 0u && w.t_in <= t_max {
            wide_step(&w, &stack, &sp, o, inv, oct, t_max);
        } else {
            w.group = vec2<u32>(0u, 0u);
        }
        if w.prims.y == 0u && (w.group.y & 0xff000000u) == 0u {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            w.group = stack.group[sp];
            w.t_in = stack.t_in[sp];
        }
    }
    return Hit(0.0, NO_LIGHT, 0.0, 0.0);
}

// The debug entry (pipeline with COUNT = true): one ray per task from the CPU, as four
// vec2<u32> of f32 bits: (o.x, o.y), (o.z, t_max), (d.x, d.y), (d.z, shadow flag). Out:
// sum = (t, slot + 1 or 0 for a miss, 0), then node fetches, bytes, box tests, primitive
// tests, deepest stack. Lanes 0 .. WCACHE - 1 carry the workgroup's fill of `wcache` in bytes.
@compute @workgroup_size(64)
fn count_rays(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
              @builtin(local_invocation_index) lane: u32) {
    ctr = Counters(0u, 0u, 0u, 0u, 0u);
    fill_wcache(lane);
    let i = task_index(gid, nwg);
    if i >= params.n_tasks {
        return;
    }
    let a = tasks[4u * i];
    let b = tasks[4u * i + 1u];
    let c = tasks[4u * i + 2u];
    let e = tasks[4u * i + 3u];
    let o = vec3<f32>(bitcast<f32>(a.x), bitcast<f32>(a.y), bitcast<f32>(b.x));
    let d = vec3<f32>(bitcast<f32>(c.x), bitcast<f32>(c.y), bitcast<f32>(e.x));
    let h = trace(o, d, bitcast<f32>(b.y), e.y != 0u);
    var t = 0.0;
    var id = 0.0;
    if h.slot != NO_LIGHT {
        t = h.t;
        id = f32(h.slot + 1u);
    }
    results[i] = PixelOut(vec3<f32>(t, id, 0.0), ctr.nodes, ctr.bytes, ctr.boxes, ctr.tris, ctr.stack);
}
