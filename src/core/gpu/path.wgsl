// The path tracer of render/integrator.rs, ported to WGSL: one invocation per pixel task, every
// sample of that pixel in order. Same random numbers (SplitMix64 emulated in u32 pairs, keyed
// by (frame seed, pixel, sample, dimension)), same max_depth and Russian-roulette rules, same
// watertight triangle test over a BVH of the native tracer's build (traversals: cwbvh.wgsl).
// Spheres are intersected in f32 (the CPU uses f64) and rays leave them through the error-box
// offset, so a GPU pixel estimates the same sample as the CPU pixel without being bit-identical.

const PI: f32 = 3.14159265358979;
const FRAC_1_PI: f32 = 0.318309886183791;
const NO_LIGHT: u32 = 0xffffffffu;
const RR_START: u32 = 5u;
const SHADOW_EPSILON: f32 = 1e-4;
const STACK: u32 = 64u;
// 1 + 2·gamma(3): the slab test's far scale (tracer/bvh4.rs).
const FAR_SCALE: f32 = 1.0000003576278687;

const MAT_DIFFUSE: u32 = 0u;
const MAT_CHECKER: u32 = 1u;
const MAT_MIRROR: u32 = 2u;
const MAT_DIELECTRIC: u32 = 3u;

const LIGHT_POINT: u32 = 0u;
const LIGHT_AREA: u32 = 1u;
const LIGHT_ENV: u32 = 2u;

struct Params {
    width: u32,
    spp: u32,
    max_depth: u32,
    n_tasks: u32,
    n_lights: u32,
    has_env: u32,
    n_nodes: u32,
    rows: u32,
    env: vec4<f32>,
    // World position of the render-space origin, for checker textures.
    origin: vec4<f32>,
}

// Binary BVH node: inner (count = 0): children `a`, `a + 1`; leaf: slots a .. a + count.
struct Node {
    lo: vec3<f32>,
    a: u32,
    hi: vec3<f32>,
    count: u32,
}

// One primitive in leaf-slot order. Triangle: v0, v1, v2. Sphere: v0 = centre, v1.x = radius.
// w lanes (as bits): v0.w = material, v1.w = light, v2.w = flags (1: flip, 2: sphere).
struct Prim {
    v0: vec4<f32>,
    v1: vec4<f32>,
    v2: vec4<f32>,
}

// kind.x: MAT_*; a = albedo (even cells) + checker size in w; b = odd cells + ior in w.
struct Material {
    a: vec4<f32>,
    b: vec4<f32>,
    kind: vec4<u32>,
}

// kind: (LIGHT_*, first light-prim entry, count, 0). Point: p = position, c = intensity, and
// (p.w, c.w, bitcast kind.w) = what the position lost to f32 rounding (Light::Point).
// Area: c = radiance, c.w = area. Environment: c = radiance.
struct Light {
    p: vec4<f32>,
    c: vec4<f32>,
    kind: vec4<u32>,
}

// right.w, up.w = film half-extents; seed = mix64(frame_seed ^ golden) as (lo, hi).
struct Cam {
    right: vec4<f32>,
    up: vec4<f32>,
    fwd: vec4<f32>,
    eye: vec4<f32>,
    seed: vec4<u32>,
}

struct PixelOut {
    sum: vec3<f32>,
    nonfinite: u32,
    rays: u32,
    finite: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> prims: array<Prim>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
// Area-light entries: (leaf slot, running area sum as bits).
@group(0) @binding(5) var<storage, read> light_prims: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read> cams: array<Cam>;
// Tasks: (pixel index, frame). For the RNG probe: (pixel, sample) with frame 0's seed.
@group(0) @binding(7) var<storage, read_write> tasks: array<vec2<u32>>;
@group(0) @binding(8) var<storage, read_write> results: array<PixelOut>;

// ---- SplitMix64 in u32 pairs (x = low word, y = high word) ----

fn mul32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let p = mul32(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// z ^ (z >> s) for 0 < s < 32.
fn xorshr(z: vec2<u32>, s: u32) -> vec2<u32> {
    return z ^ vec2<u32>((z.x >> s) | (z.y << (32u - s)), z.y >> s);
}

fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = mul64(xorshr(z0, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = mul64(xorshr(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return xorshr(z, 31u);
}

const GOLDEN: vec2<u32> = vec2<u32>(0x7f4a7c15u, 0x9e3779b9u);

struct Sampler {
    key: vec2<u32>,
    dim: u32,
}

// Sampler::new with mix64(seed ^ golden) precomputed per frame.
fn sampler(seed_mix: vec2<u32>, pixel: u32, sample: u32) -> Sampler {
    let a = mix64(add64(seed_mix, vec2<u32>(pixel, 0u)));
    let b = mix64(mul64(vec2<u32>(sample, 0u), vec2<u32>(0xd192ed03u, 0xd1b54a32u)));
    return Sampler(add64(a, b), 0u);
}

fn next(s: ptr<function, Sampler>) -> f32 {
    (*s).dim += 1u;
    let bits = mix64(add64((*s).key, mul64(vec2<u32>((*s).dim, 0u), GOLDEN)));
    return f32(bits.y >> 8u) * (1.0 / 16777216.0);
}

fn next2(s: ptr<function, Sampler>) -> vec2<f32> {
    let a = next(s);
    let b = next(s);
    return vec2<f32>(a, b);
}

// ---- floating-point helpers (geometry.rs) ----

fn gamma(n: f32) -> f32 {
    let e = 5.9604645e-8;
    return (n * e) / (1.0 - n * e);
}

fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_finite(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

fn next_up(v: f32) -> f32 {
    let b = bitcast<u32>(v);
    if b == 0x7f800000u {
        return v;
    }
    if b == 0x80000000u || b == 0u {
        return bitcast<f32>(1u);
    }
    if v > 0.0 {
        return bitcast<f32>(b + 1u);
    }
    return bitcast<f32>(b - 1u);
}

fn next_down(v: f32) -> f32 {
    let b = bitcast<u32>(v);
    if b == 0xff800000u {
        return v;
    }
    if b == 0x80000000u || b == 0u {
        return bitcast<f32>(0x80000001u);
    }
    if v > 0.0 {
        return bitcast<f32>(b - 1u);
    }
    return bitcast<f32>(b + 1u);
}

fn offset_ray_origin(p: vec3<f32>, err: vec3<f32>, n: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let dist = dot(abs(n), err);
    var offset = n * dist;
    if dot(w, n) < 0.0 {
        offset = -offset;
    }
    var po = p + offset;
    for (var i = 0u; i < 3u; i++) {
        if offset[i] > 0.0 {
            po[i] = next_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_down(po[i]);
        }
    }
    return po;
}

fn basis_t(n: vec3<f32>, sign: f32) -> vec3<f32> {
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
}

fn basis_b(n: vec3<f32>, sign: f32) -> vec3<f32> {
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sign + n.y * n.y * a, -n.y);
}

fn copysign_one(v: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(v) >> 31u) != 0u);
}

// p·q − r·s with the sign of the exact value (Kahan's difference of products): the CPU
// recomputes a zero edge function in f64; f32 has no wider type, fma gives the same sign.
fn diff_prod(p: f32, q: f32, r: f32, s: f32) -> f32 {
    let w = r * s;
    let e = fma(-r, s, w);
    let f = fma(p, q, -w);
    return f + e;
}

// ---- intersection ----

struct Hit {
    t: f32,
    slot: u32,
    b1: f32,
    b2: f32,
}

struct Sheared {
    o: vec3<f32>,
    kx: u32,
    ky: u32,
    kz: u32,
    s: vec3<f32>,
}

fn shear(o: vec3<f32>, d: vec3<f32>) -> Sheared {
    let a = abs(d);
    var kz = 2u;
    if a.x > a.y {
        if a.x > a.z {
            kz = 0u;
        }
    } else if a.y > a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kz + 2u) % 3u;
    if d[kz] < 0.0 {
        let t = kx;
        kx = ky;
        ky = t;
    }
    let sz = 1.0 / d[kz];
    return Sheared(o, kx, ky, kz, vec3<f32>(d[kx] * sz, d[ky] * sz, sz));
}

// Watertight triangle test (geometry.rs, `Triangle::intersect_sheared`); hit: vec4(t, b1, b2, 1).
fn tri_hit(r: Sheared, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, t_max: f32) -> vec4<f32> {
    let miss = vec4<f32>(0.0, 0.0, 0.0, 0.0);
    let a = v0 - r.o;
    let b = v1 - r.o;
    let c = v2 - r.o;
    let ax = a[r.kx] - r.s.x * a[r.kz];
    let ay = a[r.ky] - r.s.y * a[r.kz];
    let bx = b[r.kx] - r.s.x * b[r.kz];
    let by = b[r.ky] - r.s.y * b[r.kz];
    let cx = c[r.kx] - r.s.x * c[r.kz];
    let cy = c[r.ky] - r.s.y * c[r.kz];
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_prod(cx, by, cy, bx);
        v = diff_prod(ax, cy, ay, cx);
        w = diff_prod(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return miss;
    }
    let det = u + v + w;
    if det == 0.0 || !is_finite(det) {
        return miss;
    }
    let az = a[r.kz] * r.s.z;
    let bz = b[r.kz] * r.s.z;
    let cz = c[r.kz] * r.s.z;
    let t_scaled = u * az + v * bz + w * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > 0.0 && t < t_max) {
        return miss;
    }
    let max_z = max(abs(az), max(abs(bz), abs(cz)));
    let max_x = max(abs(ax), max(abs(bx), abs(cx)));
    let max_y = max(abs(ay), max(abs(by), abs(cy)));
    let max_z_len = max(abs(a[r.kz]), max(abs(b[r.kz]), abs(c[r.kz])));
    let delta_z = gamma(3.0) * max_z;
    let delta_x = gamma(5.0) * (max_x + max_z_len);
    let delta_y = gamma(5.0) * (max_y + max_z_len);
    let delta_e = 2.0 * (gamma(2.0) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = max(abs(u), max(abs(v), abs(w)));
    let delta_t = 3.0 * (gamma(3.0) * max_e * max_z + delta_e * max_z + delta_z * max_e) * abs(inv_det);
    if t <= delta_t {
        return miss;
    }
    return vec4<f32>(t, v * inv_det, w * inv_det, 1.0);
}

// Smallest root with 0 < t < t_max (geometry.rs, `Sphere::intersect`, here in f32); −1: none.
fn sphere_hit(c: vec3<f32>, r: f32, ro: vec3<f32>, d: vec3<f32>, t_max: f32) -> f32 {
    let o = ro - c;
    let a = dot(d, d);
    let b = dot(o, d);
    let closest = o - d * (b / a);
    let disc = r * r - dot(closest, closest);
    if disc < 0.0 {
        return -1.0;
    }
    let root = sqrt(disc * a);
    var q = -b + root;
    if b > 0.0 {
        q = -b - root;
    }
    if q == 0.0 {
        return -1.0;
    }
    let c_term = dot(o, o) - r * r;
    let x = q / a;
    let y = c_term / q;
    let t0 = min(x, y);
    let t1 = max(x, y);
    if t0 > 0.0 && t0 < t_max {
        return t0;
    }
    if t1 > 0.0 && t1 < t_max {
        return t1;
    }
    return -1.0;
}

fn prim_is_sphere(p: Prim) -> bool {
    return (bitcast<u32>(p.v2.w) & 2u) != 0u;
}

// Hit of leaf slot `slot`: vec4(t, b1, b2, 1) or w = 0.
fn prim_hit(slot: u32, o: vec3<f32>, d: vec3<f32>, sh: Sheared, t_max: f32) -> vec4<f32> {
    let p = prims[slot];
    if prim_is_sphere(p) {
        let t = sphere_hit(p.v0.xyz, p.v1.x, o, d, t_max);
        return vec4<f32>(t, 0.0, 0.0, select(0.0, 1.0, t > 0.0));
    }
    return tri_hit(sh, p.v0.xyz, p.v1.xyz, p.v2.xyz, t_max);
}

fn safe_inv(d: vec3<f32>) -> vec3<f32> {
    var r: vec3<f32>;
    for (var i = 0u; i < 3u; i++) {
        var x = d[i];
        if abs(x) < 1e-30 {
            x = select(1e-30, -1e-30, (bitcast<u32>(x) >> 31u) != 0u);
        }
        r[i] = 1.0 / x;
    }
    return r;
}

// Entry distance of box (lo, hi) if entered before t_max, else −1.
fn box_hit(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> f32 {
    let ta = (lo - o) * inv;
    let tb = (hi - o) * inv;
    let near = min(ta, tb);
    let far = max(ta, tb);
    let t0 = max(max(near.x, near.y), max(near.z, 0.0));
    let t1 = min(min(far.x, far.y) * FAR_SCALE, min(far.z * FAR_SCALE, t_max));
    return select(-1.0, t0, t0 <= t1);
}

// The binary baseline of `trace` (cwbvh.wgsl): closest or any hit over `nodes`.
fn trace_binary(o: vec3<f32>, d: vec3<f32>, t_max0: f32, shadow: bool) -> Hit {
    var best = Hit(0.0, NO_LIGHT, 0.0, 0.0);
    if params.n_nodes == 0u {
        return best;
    }
    let sh = shear(o, d);
    let inv = safe_inv(d);
    var t_max = t_max0;
    var stack: array<u32, STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        if COUNT {
            count_node(NODE_BYTES);
        }
        if n.count > 0u {
            for (var k = 0u; k < n.count; k++) {
                if COUNT {
                    count_prim(PRIM_BYTES);
                }
                let h = prim_hit(n.a + k, o, d, sh, t_max);
                if h.w > 0.0 {
                    best = Hit(h.x, n.a + k, h.y, h.z);
                    t_max = h.x;
                    if shadow {
                        return best;
                    }
                }
            }
        } else {
            let l = nodes[n.a];
            let r = nodes[n.a + 1u];
            if COUNT {
                count_node(NODE_BYTES);
                count_node(NODE_BYTES);
                ctr.boxes += 2u;
            }
            let tl = box_hit(l.lo, l.hi, o, inv, t_max);
            let tr = box_hit(r.lo, r.hi, o, inv, t_max);
            if tl >= 0.0 && tr >= 0.0 {
                // Nearest first; the farther child waits on the stack.
                if tl <= tr {
                    stack[sp] = n.a + 1u;
                    node = n.a;
                } else {
                    stack[sp] = n.a;
                    node = n.a + 1u;
                }
                sp += 1u;
                if COUNT {
                    count_stack(sp);
                }
                continue;
            }
            if tl >= 0.0 {
                node = n.a;
                continue;
            }
            if tr >= 0.0 {
                node = n.a + 1u;
                continue;
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        node = stack[sp];
    }
    return best;
}

// ---- shading (render/integrator.rs) ----

struct Inter {
    p: vec3<f32>,
    err: vec3<f32>,
    n: vec3<f32>,
    material: u32,
    light: u32,
}

fn interaction(o: vec3<f32>, d: vec3<f32>, h: Hit) -> Inter {
    let pr = prims[h.slot];
    let flags = bitcast<u32>(pr.v2.w);
    let material = bitcast<u32>(pr.v0.w);
    let light = bitcast<u32>(pr.v1.w);
    if (flags & 2u) != 0u {
        let c = pr.v0.xyz;
        let r = pr.v1.x;
        let q = o + d * h.t;
        let local = (q - c) * (r / length(q - c));
        var n = normalize(local);
        let p = c + local;
        let err = (abs(p) + abs(c) + vec3<f32>(r)) * gamma(6.0);
        if (flags & 1u) != 0u {
            n = -n;
        }
        return Inter(p, err, n, material, light);
    }
    let v0 = pr.v0.xyz;
    let e1 = pr.v1.xyz - v0;
    let e2 = pr.v2.xyz - v0;
    let s1 = e1 * h.b1;
    let s2 = e2 * h.b2;
    let p = v0 + (s1 + s2);
    let err = (abs(v0) + abs(s1) + abs(s2)) * gamma(3.0) + (abs(e1) + abs(e2)) * gamma(3.0);
    let c = cross(e1, e2);
    let len = length(c);
    var n = vec3<f32>(0.0);
    if len > 0.0 {
        n = c / len;
    }
    return Inter(p, err, n, material, light);
}

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if !is_finite(a2) {
        return 1.0;
    }
    return a2 / (a2 + b2);
}

fn cosine_hemisphere(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let sign = copysign_one(n.z);
    let t = basis_t(n, sign);
    let b = basis_b(n, sign);
    let z = sqrt(max(1.0 - u.x, 0.0));
    return normalize(t * (r * cos(phi)) + b * (r * sin(phi)) + n * z);
}

fn uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

fn albedo(m: Material, p: vec3<f32>) -> vec3<f32> {
    if m.kind.x == MAT_CHECKER {
        let w = p + params.origin.xyz;
        let k = i32(floor(w.x / m.a.w)) + i32(floor(w.y / m.a.w));
        return select(m.b.xyz, m.a.xyz, (k & 1) == 0);
    }
    return m.a.xyz;
}

fn is_sphere_slot(slot: u32) -> bool {
    return prim_is_sphere(prims[slot]);
}

// Next-event estimation at a diffuse vertex (integrator.rs, `direct`).
fn direct(it: Inter, f: vec3<f32>, s: ptr<function, Sampler>, rays: ptr<function, u32>) -> vec3<f32> {
    let n_lights = params.n_lights;
    let pick = next(s);
    let u = next2(s);
    let u3 = next(s);
    let idx = min(u32(pick * f32(n_lights)), n_lights - 1u);
    let sel = 1.0 / f32(n_lights);
    let light = lights[idx];
    if light.kind.x == LIGHT_POINT {
        // From the hit point, plus the position's rounding residual (integrator.rs, `direct`).
        let lo = vec3<f32>(light.p.w, light.c.w, bitcast<f32>(light.kind.w));
        let to = (light.p.xyz - it.p) + lo;
        let dist2 = dot(to, to);
        if dist2 == 0.0 {
            return vec3<f32>(0.0);
        }
        let wi = to / sqrt(dist2);
        let cos_s = dot(it.n, wi);
        if cos_s <= 0.0 {
            return vec3<f32>(0.0);
        }
        let o = offset_ray_origin(it.p, it.err, it.n, wi);
        *rays += 1u;
        if trace(o, light.p.xyz - o, 1.0 - SHADOW_EPSILON, true).slot != NO_LIGHT {
            return vec3<f32>(0.0);
        }
        return f * light.c.xyz * (cos_s / (dist2 * sel));
    }
    if light.kind.x == LIGHT_AREA {
        let first = light.kind.y;
        let count = light.kind.z;
        let area = light.c.w;
        let target_area = u3 * area;
        var lo = 0u;
        var hi = count;
        while lo < hi {
            let mid = (lo + hi) / 2u;
            if bitcast<f32>(light_prims[first + mid].y) <= target_area {
                lo = mid + 1u;
            } else {
                hi = mid;
            }
        }
        let slot = light_prims[first + min(lo, count - 1u)].x;
        let pr = prims[slot];
        var lp: vec3<f32>;
        var lerr: vec3<f32>;
        var ln: vec3<f32>;
        if prim_is_sphere(pr) {
            let dir = uniform_sphere(u);
            let c = pr.v0.xyz;
            let r = pr.v1.x;
            lp = c + dir * r;
            ln = select(dir, -dir, (bitcast<u32>(pr.v2.w) & 1u) != 0u);
            lerr = abs(dir * r) * gamma(5.0) + abs(c) * gamma(2.0);
        } else {
            let su = sqrt(u.x);
            let b1 = 1.0 - su;
            let b2 = u.y * su;
            let v0 = pr.v0.xyz;
            let e1 = pr.v1.xyz - v0;
            let e2 = pr.v2.xyz - v0;
            let s1 = e1 * b1;
            let s2 = e2 * b2;
            lp = v0 + (s1 + s2);
            lerr = (abs(v0) + abs(s1) + abs(s2)) * gamma(3.0) + (abs(e1) + abs(e2)) * gamma(3.0);
            let cr = cross(e1, e2);
            let len = length(cr);
            ln = select(vec3<f32>(0.0), cr / len, len > 0.0);
        }
        let to = lp - it.p;
        let dist = length(to);
        if dist == 0.0 {
            return vec3<f32>(0.0);
        }
        let wi = to / dist;
        let cos_s = dot(it.n, wi);
        let cos_l = -dot(ln, wi);
        if cos_s <= 0.0 || cos_l <= 0.0 {
            return vec3<f32>(0.0);
        }
        let light_pdf = sel * dist * dist / (cos_l * area);
        let o = offset_ray_origin(it.p, it.err, it.n, wi);
        let tgt = offset_ray_origin(lp, lerr, ln, -wi);
        *rays += 1u;
        if trace(o, tgt - o, 1.0 - SHADOW_EPSILON, true).slot != NO_LIGHT {
            return vec3<f32>(0.0);
        }
        let w = power_heuristic(light_pdf, cos_s * FRAC_1_PI);
        return f * light.c.xyz * (cos_s * w / light_pdf);
    }
    // Environment.
    let wi = uniform_sphere(u);
    let cos_s = dot(it.n, wi);
    if cos_s <= 0.0 {
        return vec3<f32>(0.0);
    }
    let light_pdf = sel / (4.0 * PI);
    let o = offset_ray_origin(it.p, it.err, it.n, wi);
    *rays += 1u;
    if trace(o, wi, inf(), true).slot != NO_LIGHT {
        return vec3<f32>(0.0);
    }
    let w = power_heuristic(light_pdf, cos_s * FRAC_1_PI);
    return f * light.c.xyz * (cos_s * w / light_pdf);
}

fn area_pdf(light: u32, dist: f32, cos_l: f32) -> f32 {
    let l = lights[light];
    if l.kind.x != LIGHT_AREA {
        return 0.0;
    }
    return dist * dist / (cos_l * l.c.w * f32(params.n_lights));
}

// Radiance along a camera ray (integrator.rs, `radiance_with` with every feature).
fn radiance(o0: vec3<f32>, d0: vec3<f32>, s: ptr<function, Sampler>, rays: ptr<function, u32>) -> vec3<f32> {
    let has_lights = params.n_lights > 0u;
    let env_pdf = 1.0 / (4.0 * PI * f32(max(params.n_lights, 1u)));
    var o = o0;
    var d = d0;
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var depth = 1u;
    var specular = true;
    var bsdf_pdf = 0.0;
    loop {
        *rays += 1u;
        let hit = trace(o, d, inf(), false);
        if hit.slot == NO_LIGHT {
            if params.has_env != 0u {
                var w = 1.0;
                if !specular {
                    w = power_heuristic(bsdf_pdf, env_pdf);
                }
                l += beta * params.env.xyz * w;
            }
            break;
        }
        let it = interaction(o, d, hit);
        let front = dot(d, it.n) < 0.0;
        if it.light != NO_LIGHT && front {
            let lt = lights[it.light];
            if lt.kind.x == LIGHT_AREA {
                var w = 1.0;
                if !specular {
                    let dist = hit.t * length(d);
                    let cos_l = -dot(normalize(d), it.n);
                    w = power_heuristic(bsdf_pdf, area_pdf(it.light, dist, cos_l));
                }
                l += beta * lt.c.xyz * w;
            }
        }
        if depth >= params.max_depth {
            break;
        }
        let wo = -normalize(d);
        let m = materials[it.material];
        var next_dir: vec3<f32>;
        if m.kind.x == MAT_DIFFUSE || m.kind.x == MAT_CHECKER {
            if !front {
                break;
            }
            let a = albedo(m, it.p);
            let f = a * FRAC_1_PI;
            if has_lights {
                l += beta * direct(it, f, s, rays);
            }
            let wi = cosine_hemisphere(it.n, next2(s));
            bsdf_pdf = max(dot(it.n, wi), 0.0) * FRAC_1_PI;
            if bsdf_pdf == 0.0 {
                break;
            }
            beta *= a;
            specular = false;
            next_dir = wi;
        } else if m.kind.x == MAT_MIRROR {
            if !front {
                break;
            }
            beta *= m.a.xyz;
            specular = true;
            next_dir = it.n * (2.0 * dot(wo, it.n)) - wo;
        } else {
            let ior = m.b.w;
            let cos_o = dot(wo, it.n);
            var nf = it.n;
            var eta = ior;
            var cos_i = cos_o;
            if cos_o <= 0.0 {
                nf = -it.n;
                eta = 1.0 / ior;
                cos_i = -cos_o;
            }
            let fr = fresnel_dielectric(cos_i, eta);
            specular = true;
            if next(s) < fr {
                next_dir = nf * (2.0 * cos_i) - wo;
            } else {
                let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
                let cos_t = sqrt(max(1.0 - sin2_t, 0.0));
                beta /= eta * eta;
                next_dir = normalize(-wo / eta + nf * (cos_i / eta - cos_t));
            }
        }
        depth += 1u;
        if depth > RR_START {
            let mx = max(beta.x, max(beta.y, beta.z));
            if mx < 1.0 {
                let q = max(1.0 - mx, 0.0);
                if next(s) < q {
                    break;
                }
                beta /= 1.0 - q;
            }
        }
        o = offset_ray_origin(it.p, it.err, it.n, next_dir);
        d = next_dir;
    }
    return l;
}

fn task_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 64u;
}

@compute @workgroup_size(64)
fn render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lane: u32) {
    fill_wcache(lane);
    let i = task_index(gid, nwg);
    if i >= params.n_tasks {
        return;
    }
    let task = tasks[i];
    let pixel = task.x;
    let cam = cams[task.y];
    let px = pixel % params.width;
    let py = pixel / params.width;
    var sum = vec3<f32>(0.0);
    var rays = 0u;
    var nonfinite = 0u;
    var finite = 0u;
    for (var si = 0u; si < params.spp; si++) {
        var s = sampler(cam.seed.xy, pixel, si);
        let j = next2(&s);
        let u = (f32(px) + j.x) / f32(params.width);
        let v = (f32(py) + j.y) / f32(params.rows);
        let x = (2.0 * u - 1.0) * cam.right.w;
        let y = (1.0 - 2.0 * v) * cam.up.w;
        let d = normalize(cam.right.xyz * x + cam.up.xyz * y + cam.fwd.xyz);
        let l = radiance(cam.eye.xyz, d, &s, &rays);
        if is_finite(l.x) && is_finite(l.y) && is_finite(l.z) {
            sum += l;
            finite += 1u;
        } else {
            nonfinite += 1u;
        }
    }
    results[i] = PixelOut(sum, nonfinite, rays, finite, 0u, 0u);
}

// The first 8 dimensions of the stream (pixel, sample) = tasks[i] under cams[0]'s seed, as f32
// bits in out[i] (sum, nonfinite, rays, finite, pads): the RNG identity test reads them.
@compute @workgroup_size(64)
fn rng_probe(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = task_index(gid, nwg);
    if i >= params.n_tasks {
        return;
    }
    var s = sampler(cams[0].seed.xy, tasks[i].x, tasks[i].y);
    var b: array<u32, 8>;
    for (var k = 0u; k < 8u; k++) {
        b[k] = bitcast<u32>(next(&s));
    }
    results[i] = PixelOut(vec3<f32>(bitcast<f32>(b[0]), bitcast<f32>(b[1]), bitcast<f32>(b[2])), b[3], b[4], b[5], b[6], b[7]);
}

// Nothing at all: what one dispatch costs by itself (submit → result mapped).
@compute @workgroup_size(64)
fn empty(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x == 0xffffffffu {
        results[0].rays = 0u;
    }
}
