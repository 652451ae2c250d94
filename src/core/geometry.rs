//! Rays, primitives and their exact intersection routines, shared by every tracer so that
//! `bvh`, `brute` (and `embree` for spheres) compute bit-identical `t` for the same primitive.
//!
//! Self-intersection is avoided by construction, as in pbrt-v4: every hit point carries a
//! conservative bound on its floating-point error, and secondary rays start from a point pushed
//! just outside that error box ([`offset_ray_origin`]). No fixed epsilon is involved, so the same
//! code works for scenes of size 1e-6 and 1e6.
//!
//! Spheres go further: a ray leaving a sphere carries its origin as an f32 pair `o + o_lo`
//! (the f64 surface point to ~1e-15), and [`Sphere::intersect`] recognises an origin on its
//! own surface from that exact point, so a second sphere 1e-7 away, below one f32 ulp of the
//! coordinates, is still found on the right side. `o` alone is pushed to the ray's side of the
//! surface ([`Sphere::spawn_origin`]) for tests that see only f32 (traversal, triangles,
//! Embree's callbacks, whose ray layout has no room for `o_lo`).

use glam::{DVec3, Vec3, Vec4};

/// A ray `o + t·d`. `d` need not be normalised (shadow rays use the segment to the light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin (its f32 rounding when `o_lo` is not zero).
    pub o: Vec3,
    /// Direction; `t` is measured in units of its length.
    pub d: Vec3,
    /// Low part of the origin: the exact origin is `o + o_lo`, evaluated in f64 by the sphere
    /// test only. Zero except for rays leaving a sphere; triangle tests and traversal use `o`.
    pub o_lo: Vec3,
}

impl Ray {
    /// The ray from `o` along `d`.
    pub const fn new(o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            o_lo: Vec3::ZERO,
        }
    }
    /// The ray from the f64 point `exact` along `d`, with `o` the f32 point traversal and
    /// triangle tests start from (near `exact`, on the side `d` points to) and `o + o_lo` equal
    /// to `exact` to ~1e-15 relative.
    pub fn leaving(exact: DVec3, o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            o_lo: (exact - o.as_dvec3()).as_vec3(),
        }
    }
    /// The origin in f64, `o + o_lo`.
    pub fn origin_f64(&self) -> DVec3 {
        self.o.as_dvec3() + self.o_lo.as_dvec3()
    }
    /// The point at parameter `t`: `o + t·d`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Closest-hit record from a tracer: which primitive, where along the ray, and (for triangles)
/// the barycentric coordinates of vertices 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the ray direction's length.
    pub t: f32,
    /// Primitive id in the scene's numbering (spheres first, then triangles).
    pub prim: u32,
    /// Barycentric coordinate of vertex 1 (0 for a sphere).
    pub b1: f32,
    /// Barycentric coordinate of vertex 2 (0 for a sphere).
    pub b2: f32,
}

/// `gamma(n)` of pbrt: a bound on the relative error of `n` chained f32 roundings.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// The next representable f32 above `v` (+∞ stays; both zeros step to the smallest positive
/// subnormal).
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The next representable f32 below `v` (−∞ stays; both zeros step to the negative subnormal
/// nearest zero).
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

/// Push `p` (with absolute error bound `p_err`) along the geometric normal `n` to the side `w`
/// points to, far enough that the new origin is certainly on that side of the surface.
#[inline]
pub fn offset_ray_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let dist = n.abs().dot(p_err);
    let mut offset = n * dist;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    // Arrays, not `Vec3` indexing (a `match` per access).
    let (off, po) = (offset.to_array(), (p + offset).to_array());
    Vec3::from_array(std::array::from_fn(|i| {
        if off[i] > 0.0 {
            next_float_up(po[i])
        } else if off[i] < 0.0 {
            next_float_down(po[i])
        } else {
            po[i]
        }
    }))
}

/// A triangle stored as its three vertices, exactly as the scene placed them: triangles that
/// share a vertex hold the same f32 value for it, which the watertight test needs.
/// The geometric normal `e1 × e2` follows the winding (counter-clockwise seen from the front).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertex 0.
    pub v0: Vec3,
    /// Vertex 1.
    pub v1: Vec3,
    /// Vertex 2.
    pub v2: Vec3,
}

/// A ray prepared for the watertight triangle test (Woop, Benthin, Wald 2013, JCGT 2(1)): the
/// axis where the direction is largest becomes z, and the shear that maps the direction to
/// (0, 0, 1). Computed once per query and shared by every triangle it meets.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    /// The ray's origin.
    pub(crate) o: Vec3,
    /// The axes that become x, y and z.
    pub(crate) k: [usize; 3],
    /// The shear: `d[kx]/d[kz]`, `d[ky]/d[kz]`, `1/d[kz]`.
    pub(crate) s: Vec3,
}

impl ShearedRay {
    /// The shear of `ray` (a zero direction yields a ray that hits nothing).
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        // Arrays, not `Vec3` indexing (a `match` per access): 945 → 936 instructions per
        // primary ray of the native tracer (callgrind, 100 k triangles, 256²).
        let d = ray.d.to_array();
        let a = d.map(f32::abs);
        let kz = if a[0] > a[1] {
            if a[0] > a[2] {
                0
            } else {
                2
            }
        } else if a[1] > a[2] {
            1
        } else {
            2
        };
        let next = |k: usize| if k == 2 { 0 } else { k + 1 };
        let (mut kx, mut ky) = (next(kz), next(next(kz)));
        // Keep the winding: a negative z direction mirrors, so x and y swap.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        Self {
            o: ray.o,
            k: [kx, ky, kz],
            s: Vec3::new(d[kx] * sz, d[ky] * sz, sz),
        }
    }
}

impl Triangle {
    /// The triangle with vertices `v0`, `v1`, `v2`, in that winding order.
    pub fn new(v0: Vec3, v1: Vec3, v2: Vec3) -> Self {
        Self { v0, v1, v2 }
    }
    /// The three vertices.
    pub fn vertices(&self) -> [Vec3; 3] {
        [self.v0, self.v1, self.v2]
    }
    /// Edge from vertex 0 to vertex 1.
    pub fn e1(&self) -> Vec3 {
        self.v1 - self.v0
    }
    /// Edge from vertex 0 to vertex 2.
    pub fn e2(&self) -> Vec3 {
        self.v2 - self.v0
    }
    /// Unit geometric normal along `e1 × e2` (zero for a degenerate triangle).
    pub fn normal(&self) -> Vec3 {
        self.e1().cross(self.e2()).normalize_or_zero()
    }
    /// Area, `|e1 × e2| / 2`.
    pub fn area(&self) -> f32 {
        0.5 * self.e1().cross(self.e2()).length()
    }
    /// Axis-aligned bounding box as `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let [a, b, c] = self.vertices();
        (a.min(b).min(c), a.max(b).max(c))
    }

    /// Watertight intersection ([`ShearedRay`]). Returns `(t, b1, b2)` for `0 < t < t_max`;
    /// edges and vertices count as inside.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<(f32, f32, f32)> {
        self.intersect_sheared(&ShearedRay::new(ray), t_max)
    }

    /// [`Triangle::intersect`] with the ray's shear computed beforehand. The edge functions are
    /// evaluated on vertices translated and sheared exactly alike for every triangle, so a ray
    /// through a shared edge or vertex gets the same signs from both sides: no leak. A zero edge
    /// function is recomputed in f64, where the products are exact, so its sign is exact too.
    ///
    /// The shear is computed once per query; the error bound only for candidate hits. Its cost
    /// against the Möller–Trumbore test it replaced: M-114.
    #[inline(always)]
    pub fn intersect_sheared(&self, r: &ShearedRay, t_max: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = r.k;
        let a = self.v0 - r.o;
        let b = self.v1 - r.o;
        let c = self.v2 - r.o;
        let (ax, ay) = (a[kx] - r.s.x * a[kz], a[ky] - r.s.y * a[kz]);
        let (bx, by) = (b[kx] - r.s.x * b[kz], b[ky] - r.s.y * b[kz]);
        let (cx, cy) = (c[kx] - r.s.x * c[kz], c[ky] - r.s.y * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let f =
                |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        // A degenerate triangle, a ray in its plane or a zero direction: no proper hit.
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (az, bz, cz) = (a[kz] * r.s.z, b[kz] * r.s.z, c[kz] * r.s.z);
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        // `t` is a sum of large terms where the triangle is big and the ray's main axis lies in
        // its plane: it can come out positive for a surface just behind the origin. pbrt-v4's
        // bound on its rounding error (`Triangle::Intersect`) decides "certainly ahead".
        let max_z = az.abs().max(bz.abs()).max(cz.abs());
        let max_x = ax.abs().max(bx.abs()).max(cx.abs());
        let max_y = ay.abs().max(by.abs()).max(cy.abs());
        // x and y are lengths; z is in units of `t` (scaled by 1/d_z). pbrt adds the scaled
        // z to the x error, which mixes the two: a shadow ray of length 1e-6 (d ≈ 1e-6, t ≈ 1)
        // then rejected real hits. The shear's error is bounded by the unscaled |z| (|s_x| ≤ 1).
        let max_z_len = a[kz].abs().max(b[kz].abs()).max(c[kz].abs());
        let delta_z = gamma(3) * max_z;
        let delta_x = gamma(5) * (max_x + max_z_len);
        let delta_y = gamma(5) * (max_y + max_z_len);
        let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * inv_det.abs();
        if t <= delta_t {
            return None;
        }
        Some((t, v * inv_det, w * inv_det))
    }

    /// World position of barycentric `(b1, b2)`, `v0 + b1·e1 + b2·e2`, with a conservative bound
    /// on its rounding error. Interpolating from `v0` along the stored edges keeps a coordinate
    /// in which the triangle is flat exact (an axis-aligned plane's hits lie exactly on it);
    /// the barycentric form `b0·p0 + b1·p1 + b2·p2` is off by ulps of |p| there, which is 2 % of
    /// the height of a light 1e-4 above a plane 30 units from the camera.
    pub fn point(&self, b1: f32, b2: f32) -> (Vec3, Vec3) {
        let (e1, e2) = (self.e1(), self.e2());
        let (s1, s2) = (e1 * b1, e2 * b2);
        let p = self.v0 + (s1 + s2);
        let err = (self.v0.abs() + s1.abs() + s2.abs()) * gamma(3);
        (p, err + (e1.abs() + e2.abs()) * gamma(3))
    }
}

/// Four triangles side by side, one per lane (structure of arrays: `v[i][axis]` holds
/// coordinate `axis` of vertex `i` of every lane), for testing a leaf's triangles at once.
/// An unused lane holds NaN vertices and never hits.
#[derive(Clone, Copy, Debug)]
pub struct Triangle4 {
    /// Vertex `i`, coordinate `axis`, one lane per triangle.
    pub v: [[Vec4; 3]; 3],
}

/// What [`Triangle4::intersect_sheared`] found: per lane `t` and the barycentrics, and the
/// lanes that hit (bit `lane`).
#[derive(Clone, Copy, Debug)]
pub struct Hit4 {
    /// Ray parameter per lane (meaningful where `mask` is set).
    pub t: Vec4,
    /// Barycentric coordinate of vertex 1 per lane.
    pub b1: Vec4,
    /// Barycentric coordinate of vertex 2 per lane.
    pub b2: Vec4,
    /// Bit `lane` set where that lane's triangle is hit with `0 < t < t_max`.
    pub mask: u32,
}

impl Default for Triangle4 {
    fn default() -> Self {
        Self {
            v: [[Vec4::NAN; 3]; 3],
        }
    }
}

impl Triangle4 {
    /// Put `tri` into lane `lane` (0…3).
    pub fn set(&mut self, lane: usize, tri: &Triangle) {
        for (i, p) in tri.vertices().iter().enumerate() {
            for (axis, c) in p.to_array().into_iter().enumerate() {
                self.v[i][axis][lane] = c;
            }
        }
    }

    /// [`Triangle::intersect_sheared`] on four triangles at once. Every lane runs the same
    /// sequence of IEEE operations as the one-triangle test (no fused multiply-add; the rare
    /// zero edge function is redone in f64 lane by lane, as there), so a lane's `t`, `b1`, `b2`
    /// and verdict are bit-identical to it: `bvh` and `brute` agree exactly.
    ///
    /// On the Cornell box (128², 1 spp, one thread, callgrind) this took the native tracer's
    /// closest-hit queries from 83.4 M to 67.0 M instructions, its occlusion queries from 26.8 M
    /// to 23.7 M (the render 169.6 M → 148.4 M). Against Embree 3 on the 1 M-triangle displaced
    /// sphere (`examples/tracer_ab`, one thread, best of 5 rounds, old and new binaries
    /// alternated on a quiet 2-core EPYC): bvh/embree primary 0.43–0.44 → 0.47–0.55 at 256²,
    /// 0.42–0.46 → 0.53–0.60 at 1024²; diffuse bounces 0.35 → 0.39–0.42 and 0.29–0.32 →
    /// 0.39–0.42.
    #[inline(always)]
    pub fn intersect_sheared(&self, r: &ShearedRay, t_max: f32) -> Hit4 {
        let [kx, ky, kz] = r.k;
        let o = [r.o.x, r.o.y, r.o.z].map(Vec4::splat);
        let (sx, sy, sz) = (Vec4::splat(r.s.x), Vec4::splat(r.s.y), Vec4::splat(r.s.z));
        let rel = |i: usize| {
            let v = &self.v[i];
            (v[kx] - o[kx], v[ky] - o[ky], v[kz] - o[kz])
        };
        let (a_x, a_y, a_z) = rel(0);
        let (b_x, b_y, b_z) = rel(1);
        let (c_x, c_y, c_z) = rel(2);
        let (ax, ay) = (a_x - sx * a_z, a_y - sy * a_z);
        let (bx, by) = (b_x - sx * b_z, b_y - sy * b_z);
        let (cx, cy) = (c_x - sx * c_z, c_y - sy * c_z);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let exact = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
        if exact != 0 {
            let f =
                |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
            let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
            let mut lanes = exact;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                ua[l] = f(cx[l], by[l], cy[l], bx[l]);
                va[l] = f(ax[l], cy[l], ay[l], cx[l]);
                wa[l] = f(bx[l], ay[l], by[l], ax[l]);
            }
            (u, v, w) = (ua.into(), va.into(), wa.into());
        }
        let neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        let mut ok = !(neg & pos) & det.cmpne(zero) & det.abs().cmplt(Vec4::INFINITY);
        if ok.bitmask() == 0 {
            return Hit4 {
                t: zero,
                b1: zero,
                b2: zero,
                mask: 0,
            };
        }
        let (az, bz, cz) = (a_z * sz, b_z * sz, c_z * sz);
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        ok &= t.cmpgt(zero) & t.cmplt(Vec4::splat(t_max));
        if ok.bitmask() == 0 {
            return Hit4 {
                t,
                b1: zero,
                b2: zero,
                mask: 0,
            };
        }
        // The error bound of the one-triangle test, term by term in the same order.
        let max_z = az.abs().max(bz.abs()).max(cz.abs());
        let max_x = ax.abs().max(bx.abs()).max(cx.abs());
        let max_y = ay.abs().max(by.abs()).max(cy.abs());
        let max_z_len = a_z.abs().max(b_z.abs()).max(c_z.abs());
        let delta_z = Vec4::splat(gamma(3)) * max_z;
        let delta_x = Vec4::splat(gamma(5)) * (max_x + max_z_len);
        let delta_y = Vec4::splat(gamma(5)) * (max_y + max_z_len);
        let delta_e = Vec4::splat(2.0)
            * (Vec4::splat(gamma(2)) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let delta_t = Vec4::splat(3.0)
            * (Vec4::splat(gamma(3)) * max_e * max_z + delta_e * max_z + delta_z * max_e)
            * inv_det.abs();
        ok &= t.cmpgt(delta_t);
        Hit4 {
            t,
            b1: v * inv_det,
            b2: w * inv_det,
            mask: ok.bitmask(),
        }
    }
}

/// An analytic sphere. Intersection runs in f64 so that huge and tiny radii stay exact enough.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Axis-aligned bounding box as `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (
            self.center - Vec3::splat(self.radius),
            self.center + Vec3::splat(self.radius),
        )
    }
    /// Surface area, 4πr².
    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }

    /// Smallest root with `0 < t < t_max`, from the ray's exact origin `o + o_lo`.
    ///
    /// An origin on this sphere's own surface (a ray leaving it) has one root at `t ≈ 0`, the
    /// point it leaves; only the other, `t = −2(o·d)/|d|²`, is a hit. "On the surface" is
    /// decided from `|o − c|² − r²` against [`Sphere::on_surface_tolerance`], 50 times the error
    /// of a spawned origin and 2e4 times below a second surface 1e-7 away at unit radius.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let c = self.center.as_dvec3();
        let o = ray.origin_f64() - c;
        let d = ray.d.as_dvec3();
        let r = self.radius as f64;
        let a = d.length_squared();
        let b = o.dot(d);
        let c_term = o.length_squared() - r * r;
        if c_term.abs() <= self.on_surface_tolerance() {
            let t = -2.0 * b / a;
            let tf = t as f32;
            return (t > 0.0 && tf > 0.0 && tf < t_max).then_some(tf);
        }
        // Robust discriminant (pbrt-v4): distance² of the closest approach, not b² − ac.
        let closest = o - d * (b / a);
        let disc = r * r - closest.length_squared();
        if disc < 0.0 {
            return None;
        }
        let root = (disc * a).sqrt();
        let q = if b > 0.0 { -b - root } else { -b + root };
        if q == 0.0 {
            return None;
        }
        let (t0, t1) = {
            let (x, y) = (q / a, c_term / q);
            (x.min(y), x.max(y))
        };
        for t in [t0, t1] {
            // The contract 0 < t < t_max holds for the f32 `t` returned: a root that rounds to 0
            // is the surface we start on, and one that rounds up to t_max is not before it.
            let tf = t as f32;
            if t > 0.0 && tf > 0.0 && tf < t_max {
                return Some(tf);
            }
        }
        None
    }

    /// Bound on `| |o − c|² − r² |` below which an origin counts as on this surface.
    ///
    /// A spawned origin is the f64 surface point (error ~1e-16 of `|c| + r`) stored as `o +
    /// o_lo`, with `o` at most 8 f32 ulps (1e-6 relative) from it, so `o_lo` rounds with an error
    /// ~6e-14 of `|c| + r` and `|o − c|² − r²` is off by ≲ 2e-13·r·(|c| + r). The bound is 50
    /// times that; a second sphere 1e-7 away at unit size gives 2e-7, 2e4 times more.
    #[inline]
    pub fn on_surface_tolerance(&self) -> f64 {
        let r = self.radius as f64;
        let scale = self.center.abs().max_element() as f64 + r;
        1e-11 * r * scale
    }

    /// Hit point on the surface, in f64 (re-projected) and as its f32 rounding with an error
    /// bound, and the outward normal.
    pub fn point(&self, ray: &Ray, t: f32) -> SpherePoint {
        let c = self.center.as_dvec3();
        let p: DVec3 = ray.origin_f64() + ray.d.as_dvec3() * t as f64;
        let local = p - c;
        let local = local * (self.radius as f64 / local.length());
        let n = local.normalize().as_vec3();
        let exact = c + local;
        let p = exact.as_vec3();
        // `exact` lies on the sphere to f64 precision, so the error of `p` is its one rounding
        // to f32, u·|p|, plus a margin that covers the f64 work many times over.
        let slack = (exact.abs().max_element() + self.radius as f64) * 1e-12;
        let err = p.abs() * gamma(1) + Vec3::splat(slack as f32);
        SpherePoint { exact, p, err, n }
    }
}

/// A point on a sphere as [`Sphere::point`] gives it.
#[derive(Clone, Copy, Debug)]
pub struct SpherePoint {
    /// On the surface to f64 precision: where rays leaving the sphere start ([`Ray::leaving`]).
    pub exact: DVec3,
    /// `exact` rounded to f32.
    pub p: Vec3,
    /// Per-axis bound on the error of `p`.
    pub err: Vec3,
    /// Outward unit normal.
    pub n: Vec3,
}

impl Sphere {
    /// Where a ray leaving this sphere's surface point `p` along `w` starts: the f32 point
    /// nearest `p` that is certainly on the side `w` points to (outside when `w` points away
    /// from the centre), decided exactly in f64 as [`Sphere::intersect`] decides it, so that the
    /// sphere is not hit again at `t ≈ 0` by a test that sees only this f32 origin (Embree's
    /// traversal, the triangle tests) yet a surface more than an ulp away is not jumped over.
    /// `offset_ray_origin`'s error box is several ulps: a dielectric 1e-6 inside this one, 5
    /// units from the camera, would be skipped. `None` if a few ulps do not settle it (the
    /// caller then falls back to the error-box offset). The sphere tests themselves start from
    /// the exact point ([`Ray::leaving`]).
    pub fn spawn_origin(&self, p: Vec3, w: Vec3) -> Option<Vec3> {
        let c = self.center.as_dvec3();
        let r = self.radius as f64;
        let outward = (p.as_dvec3() - c).dot(w.as_dvec3()) > 0.0;
        // |o − c|² − r² is computed to ~1e-16·r²; demand a sign far beyond that.
        let margin = r * r * 1e-12;
        let n = p.as_dvec3() - c;
        let mut o = p;
        for _ in 0..8 {
            let side = (o.as_dvec3() - c).length_squared() - r * r;
            if (outward && side > margin) || (!outward && side < -margin) {
                return Some(o);
            }
            for i in 0..3 {
                let away = n[i] > 0.0;
                if n[i] != 0.0 {
                    o[i] = if away == outward {
                        next_float_up(o[i])
                    } else {
                        next_float_down(o[i])
                    };
                }
            }
        }
        None
    }
}

/// Orthonormal basis around `n` (Duff et al. 2017), used for local shading frames.
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_hit_and_miss() {
        let tri = Triangle::new(
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        );
        assert_eq!(tri.normal(), Vec3::Z);
        let ray = Ray::new(Vec3::new(0.5, -0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, _, _) = tri.intersect(&ray, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        assert!(tri.intersect(&ray, 1.5).is_none());
        let miss = Ray::new(Vec3::new(-0.5, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(tri.intersect(&miss, f32::INFINITY).is_none());
    }

    #[test]
    fn sphere_from_inside_and_outside() {
        let s = Sphere {
            center: Vec3::ZERO,
            radius: 2.0,
        };
        let out = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert!((s.intersect(&out, f32::INFINITY).unwrap() - 3.0).abs() < 1e-6);
        let inside = Ray::new(Vec3::ZERO, Vec3::X);
        assert!((s.intersect(&inside, f32::INFINITY).unwrap() - 2.0).abs() < 1e-6);
        let away = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::Z);
        assert!(s.intersect(&away, f32::INFINITY).is_none());
        // t_max is exclusive for the returned f32: the hit at exactly t is not before t.
        let t = s.intersect(&out, f32::INFINITY).unwrap();
        assert!(s.intersect(&out, t).is_none());
        assert!(s.intersect(&out, next_float_up(t)).is_some());
    }

    #[test]
    fn offset_origin_leaves_the_surface_at_any_scale() {
        for scale in [1e-6f32, 1.0, 1e6] {
            let s = Sphere {
                center: Vec3::splat(0.3 * scale),
                radius: scale,
            };
            let ray = Ray::new(
                s.center + Vec3::new(0.1, 0.2, 3.0) * scale,
                Vec3::new(0.0, 0.0, -1.0),
            );
            let t = s.intersect(&ray, f32::INFINITY).unwrap();
            let sp = s.point(&ray, t);
            // Leave outwards: the sphere must not be hit again.
            let o = offset_ray_origin(sp.p, sp.err, sp.n, sp.n);
            assert!(
                s.intersect(&Ray::new(o, sp.n), f32::INFINITY).is_none(),
                "scale {scale}"
            );
        }
    }

    #[test]
    fn rays_leaving_a_sphere_from_its_exact_point_skip_only_that_point() {
        for scale in [1e-6f32, 1.0, 1e6] {
            // Away from the origin like a camera-relative scene: the hit points' coordinates
            // near 3·scale have an ulp of 2.4e-7·scale, more than the 1e-7·scale gap.
            let c = Vec3::new(0.0, 0.0, -4.0) * scale;
            let outer = Sphere {
                center: c,
                radius: scale,
            };
            let inner = Sphere {
                center: c,
                radius: 0.9999999 * scale,
            };
            let gap = (outer.radius - inner.radius) as f64;
            for k in 0..64 {
                // Camera rays over the near hemisphere.
                let (x, y) = ((k % 8) as f32 / 8.0 - 0.45, (k / 8) as f32 / 8.0 - 0.45);
                let aim = c + Vec3::new(x, y, -0.5) * scale;
                let cam = Ray::new(Vec3::ZERO, aim);
                let t = outer.intersect(&cam, f32::INFINITY).unwrap();
                let sp = outer.point(&cam, t);
                let leave = |d: Vec3| {
                    let o = outer.spawn_origin(sp.p, d).unwrap_or(sp.p);
                    Ray::leaving(sp.exact, o, d)
                };
                // Outwards: the outer sphere is behind, the inner one further behind.
                assert!(outer.intersect(&leave(sp.n), f32::INFINITY).is_none());
                assert!(inner.intersect(&leave(sp.n), f32::INFINITY).is_none());
                // Inwards along a slanted direction: the inner sphere first, about gap/cosθ on.
                let w = (-sp.n + 0.3 * Vec3::X).normalize();
                let cos = (-sp.n).dot(w) as f64;
                let t_in = inner
                    .intersect(&leave(w), f32::INFINITY)
                    .expect("inner sphere") as f64;
                assert!(
                    (t_in * cos - gap).abs() < 1e-3 * gap,
                    "scale {scale} k {k}: {t_in} vs {}",
                    gap / cos
                );
                // …and the outer sphere only at its far side, the chord 2r·cosθ away.
                let t_far = outer.intersect(&leave(w), f32::INFINITY).unwrap() as f64;
                let chord = 2.0 * scale as f64 * cos;
                assert!((t_far - chord).abs() < 1e-5 * chord, "scale {scale} k {k}");
                // Leaving the inner sphere outwards finds the outer one, gap/cosθ away.
                let ip = inner.point(&leave(w), t_in as f32);
                let o = inner.spawn_origin(ip.p, sp.n).unwrap_or(ip.p);
                let out = Ray::leaving(ip.exact, o, sp.n);
                assert!(inner.intersect(&out, f32::INFINITY).is_none());
                let t_out = outer.intersect(&out, f32::INFINITY).expect("outer") as f64;
                let cos_out = ip.n.dot(sp.n) as f64;
                assert!(
                    (t_out * cos_out - gap).abs() < 1e-3 * gap,
                    "scale {scale} k {k}"
                );
            }
        }
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert!(next_float_up(1.0) > 1.0);
        assert!(next_float_down(1.0) < 1.0);
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
    }
}
