//! The kernels' arithmetic in Rust: mirrors of `path.wgsl` / `cwbvh.wgsl` in the same f32
//! operations (explicit fused multiply-adds where the kernel has `fma`), so that
//! [`super::counters::CpuTraversal`] finds the kernel's hits and counts its work.

// 1 + 3·2⁻²³, the f32 the kernel writes out in full.
pub(super) const FAR_SCALE: f32 = 1.0 + 3.0 * f32::EPSILON;

pub(super) fn gamma(n: f32) -> f32 {
    let e = 5.960_464_5e-8_f32;
    (n * e) / (1.0 - n * e)
}

pub(super) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn safe_inv(d: [f32; 3]) -> [f32; 3] {
    d.map(|x| {
        let x = if x.abs() < 1e-30 {
            if x.is_sign_negative() {
                -1e-30
            } else {
                1e-30
            }
        } else {
            x
        };
        1.0 / x
    })
}

/// A ray in the watertight test's sheared frame (`shear` of path.wgsl).
pub(super) struct Sheared {
    pub(super) o: [f32; 3],
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    pub(super) s: [f32; 3],
}

pub(super) fn shear(o: [f32; 3], d: [f32; 3]) -> Sheared {
    let a = d.map(f32::abs);
    let mut kz = 2;
    if a[0] > a[1] {
        if a[0] > a[2] {
            kz = 0;
        }
    } else if a[1] > a[2] {
        kz = 1;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kz + 2) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sz = 1.0 / d[kz];
    Sheared {
        o,
        kx,
        ky,
        kz,
        s: [d[kx] * sz, d[ky] * sz, sz],
    }
}

pub(super) fn diff_prod(p: f32, q: f32, r: f32, s: f32) -> f32 {
    let w = r * s;
    let e = (-r).mul_add(s, w);
    let f = p.mul_add(q, -w);
    f + e
}

/// `tri_hit` of path.wgsl: (t, b1, b2) or none.
pub(super) fn tri_hit(
    r: &Sheared,
    v0: [f32; 3],
    v1: [f32; 3],
    v2: [f32; 3],
    t_max: f32,
) -> Option<f32> {
    let a = sub(v0, r.o);
    let b = sub(v1, r.o);
    let c = sub(v2, r.o);
    let ax = a[r.kx] - r.s[0] * a[r.kz];
    let ay = a[r.ky] - r.s[1] * a[r.kz];
    let bx = b[r.kx] - r.s[0] * b[r.kz];
    let by = b[r.ky] - r.s[1] * b[r.kz];
    let cx = c[r.kx] - r.s[0] * c[r.kz];
    let cy = c[r.ky] - r.s[1] * c[r.kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_prod(cx, by, cy, bx);
        v = diff_prod(ax, cy, ay, cx);
        w = diff_prod(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let az = a[r.kz] * r.s[2];
    let bz = b[r.kz] * r.s[2];
    let cz = c[r.kz] * r.s[2];
    let t_scaled = u * az + v * bz + w * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    let max_z = az.abs().max(bz.abs().max(cz.abs()));
    let max_x = ax.abs().max(bx.abs().max(cx.abs()));
    let max_y = ay.abs().max(by.abs().max(cy.abs()));
    let max_z_len = a[r.kz].abs().max(b[r.kz].abs().max(c[r.kz].abs()));
    let delta_z = gamma(3.0) * max_z;
    let delta_x = gamma(5.0) * (max_x + max_z_len);
    let delta_y = gamma(5.0) * (max_y + max_z_len);
    let delta_e = 2.0 * (gamma(2.0) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = u.abs().max(v.abs().max(w.abs()));
    let delta_t =
        3.0 * (gamma(3.0) * max_e * max_z + delta_e * max_z + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(t)
}

/// `sphere_hit` of path.wgsl.
pub(super) fn sphere_hit(
    c: [f32; 3],
    r: f32,
    ro: [f32; 3],
    d: [f32; 3],
    t_max: f32,
) -> Option<f32> {
    let o = sub(ro, c);
    let a = dot(d, d);
    let b = dot(o, d);
    let k = b / a;
    let closest = [o[0] - d[0] * k, o[1] - d[1] * k, o[2] - d[2] * k];
    let disc = r * r - dot(closest, closest);
    if disc < 0.0 {
        return None;
    }
    let root = (disc * a).sqrt();
    let q = if b > 0.0 { -b - root } else { -b + root };
    if q == 0.0 {
        return None;
    }
    let c_term = dot(o, o) - r * r;
    let x = q / a;
    let y = c_term / q;
    let (t0, t1) = (x.min(y), x.max(y));
    if t0 > 0.0 && t0 < t_max {
        return Some(t0);
    }
    if t1 > 0.0 && t1 < t_max {
        return Some(t1);
    }
    None
}

pub(super) fn box_hit(
    lo: [f32; 3],
    hi: [f32; 3],
    o: [f32; 3],
    inv: [f32; 3],
    t_max: f32,
) -> Option<f32> {
    let ta: [f32; 3] = std::array::from_fn(|i| (lo[i] - o[i]) * inv[i]);
    let tb: [f32; 3] = std::array::from_fn(|i| (hi[i] - o[i]) * inv[i]);
    let near: [f32; 3] = std::array::from_fn(|i| ta[i].min(tb[i]));
    let far: [f32; 3] = std::array::from_fn(|i| ta[i].max(tb[i]));
    let t0 = near[0].max(near[1]).max(near[2].max(0.0));
    let t1 = (far[0].min(far[1]) * FAR_SCALE).min((far[2] * FAR_SCALE).min(t_max));
    (t0 <= t1).then_some(t0)
}
