//! What the two Embree tracers share: `embree` (Embree 3, hand-written bindings) and `embree4`
//! (Embree 4, `embree4-sys` types over a locally opened library) differ in their handle types,
//! argument structs and how a function is called, not in what raysched does with them. Here:
//! the error sink and callback, the sphere user geometry's data and packet kernels, the ray
//! interval, the triangle upload and the primitive ids. Each tracer's callbacks only unpack their
//! own argument struct and call these, so a fix to the sphere kernel reaches both.

use crate::core::geometry::{next_float_down, next_float_up, Ray, Sphere};
use crate::core::scene::Geometry;
use std::ffi::{c_char, c_int, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Mutex;

/// What went wrong creating an Embree device or building its scene: the step, and what Embree
/// reported (its error callback's messages, or the device's error code).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct EmbreeError(pub String);

impl From<String> for EmbreeError {
    fn from(msg: String) -> Self {
        Self(msg)
    }
}

impl From<&str> for EmbreeError {
    fn from(msg: &str) -> Self {
        Self(msg.to_string())
    }
}

/// Geometry id of the sphere user geometry (present when the scene has spheres).
pub(crate) const SPHERE_GEOM: u32 = 0;
/// Geometry id of the triangle mesh (present when the scene has triangles).
pub(crate) const TRIANGLE_GEOM: u32 = 1;

/// Embree's default intersector accepts `t > tnear`, its robust one `t ≥ tnear` (measured with
/// Embree 3: a ray starting on a triangle hits it at t = −0 with `RTC_SCENE_FLAG_ROBUST` and
/// tnear = 0). The smallest normal float excludes t = 0 in both; a real hit below 1.2e-38 would
/// need |d| ≈ 1e38.
pub(crate) const TNEAR: f32 = f32::MIN_POSITIVE;

/// Embree's `tfar` for raysched's `0 < t < t_max` contract (Embree accepts `t ≤ tfar`), or
/// `None` when that interval is empty.
#[inline(always)]
pub(crate) fn tfar_for(t_max: f32) -> Option<f32> {
    if t_max.is_nan() || t_max <= 0.0 {
        return None;
    }
    Some(if t_max.is_finite() {
        next_float_down(t_max)
    } else {
        t_max
    })
}

/// An Embree `RTCRay`: Embree 3's (the hand-written `v3::ffi`) or Embree 4's (`embree4-sys`),
/// the same fields under the same names in both.
pub(crate) trait RtcRay: Sized {
    /// The ray from `o` along `d` over `tnear < t ≤ tfar` at time 0, every mask bit set.
    fn with(o: [f32; 3], d: [f32; 3], tnear: f32, tfar: f32) -> Self;
}

/// [`RtcRay`] for a binding's `RTCRay` type: a macro, because the two bindings' types share
/// their field names but no trait a generic function could construct them through.
macro_rules! impl_rtc_ray {
    ($ty:ty) => {
        impl $crate::core::tracer::embree::common::RtcRay for $ty {
            #[inline(always)]
            fn with(o: [f32; 3], d: [f32; 3], tnear: f32, tfar: f32) -> Self {
                Self {
                    org_x: o[0],
                    org_y: o[1],
                    org_z: o[2],
                    tnear,
                    dir_x: d[0],
                    dir_y: d[1],
                    dir_z: d[2],
                    time: 0.0,
                    tfar,
                    mask: u32::MAX,
                    id: 0,
                    flags: 0,
                }
            }
        }
    };
}
pub(crate) use impl_rtc_ray;

/// An Embree ray for raysched's `0 < t < t_max` contract (`None` when that interval is empty).
#[inline(always)]
pub(crate) fn rtc_ray<R: RtcRay>(ray: &Ray, t_max: f32) -> Option<R> {
    let (o, d) = ([ray.o.x, ray.o.y, ray.o.z], [ray.d.x, ray.d.y, ray.d.z]);
    Some(R::with(o, d, TNEAR, tfar_for(t_max)?))
}

/// Map Embree's (geomID, primID) to a raysched primitive id: spheres first, then triangles.
#[inline(always)]
pub(crate) fn primitive_id(n_spheres: u32, geom: u32, prim: u32) -> u32 {
    if geom == TRIANGLE_GEOM {
        n_spheres + prim
    } else {
        prim
    }
}

/// Triangle and sphere counts as Embree's 32-bit ids, checked before anything is created (the
/// vertex buffer holds three vertices per triangle, indexed by `u32`).
pub(crate) fn primitive_counts(geometry: &Geometry) -> Result<(u32, u32), EmbreeError> {
    let n_tris = u32::try_from(geometry.triangles.len())
        .ok()
        .filter(|n| n.checked_mul(3).is_some())
        .ok_or("too many triangles for Embree's 32-bit indices")?;
    let n_spheres = u32::try_from(geometry.spheres.len()).map_err(|_| "too many spheres")?;
    Ok((n_tris, n_spheres))
}

/// Fill Embree's vertex and index buffers: unshared vertices `v0, v0+e1, v0+e2` per triangle, so
/// Embree's `(u, v)` are raysched's `(b1, b2)`. `verts` holds 3 entries a triangle, `idx` one.
pub(crate) fn fill_triangles(geometry: &Geometry, verts: &mut [[f32; 3]], idx: &mut [[u32; 3]]) {
    let slots = verts.chunks_exact_mut(3).zip(idx.iter_mut());
    for (b, (tri, (v, ix))) in (0u32..)
        .step_by(3)
        .zip(geometry.triangles.iter().zip(slots))
    {
        for (slot, p) in v.iter_mut().zip(tri.vertices()) {
            *slot = p.to_array();
        }
        *ix = [b, b + 1, b + 2];
    }
}

/// The calls of one Embree generation that building a scene takes. The generations differ in
/// their handle types, argument structs and how a function is reached, not in the steps: these
/// are written once ([`Builder::finish`], [`Builder::attach_spheres`],
/// [`Builder::attach_triangles`], [`Builder::check`]) over each tracer's implementation.
pub(crate) trait Builder {
    /// The geometry handle.
    type Geometry: Copy;
    /// The device's current error code.
    fn error_code(&self) -> c_int;
    /// The code that means no error.
    const ERROR_NONE: c_int;
    /// The error sink the device's callback fills.
    fn errors(&self) -> &ErrorSink;
    /// The spheres' callback data and count.
    fn spheres(&self) -> (&SphereData, u32);
    /// Mark the scene robust (`RTC_SCENE_FLAG_ROBUST`) or not.
    ///
    /// # Safety
    /// The scene is valid and not yet committed.
    unsafe fn set_robust(&self, robust: bool);
    /// A new geometry of the device: the spheres' user geometry, or a triangle mesh.
    ///
    /// # Safety
    /// The device is valid.
    unsafe fn new_geometry(&self, user: bool) -> Self::Geometry;
    /// Is `g` null (creation failed)?
    fn is_null(g: Self::Geometry) -> bool;
    /// Give user geometry `g` the sphere callbacks, `count` primitives and `data` as their
    /// user pointer.
    ///
    /// # Safety
    /// `g` is a valid user geometry; `data` is the tracer's `SphereData`, outliving the scene.
    unsafe fn set_sphere_callbacks(&self, g: Self::Geometry, count: u32, data: *mut c_void);
    /// New vertex (float3) and index (uint3) buffers of `n` triangles on mesh `g`, each null
    /// on failure.
    ///
    /// # Safety
    /// `g` is a valid triangle geometry.
    unsafe fn triangle_buffers(
        &self,
        g: Self::Geometry,
        n: usize,
    ) -> (*mut [f32; 3], *mut [u32; 3]);
    /// Commit `g`, attach it to the scene under `id` and drop this reference to it.
    ///
    /// # Safety
    /// `g` is a valid geometry, filled.
    unsafe fn commit_attach(&self, g: Self::Geometry, id: u32);
    /// Drop this reference to `g`.
    ///
    /// # Safety
    /// `g` is a valid geometry.
    unsafe fn release(&self, g: Self::Geometry);
    /// Commit the scene.
    ///
    /// # Safety
    /// The scene is valid and every attached geometry committed.
    unsafe fn commit_scene(&self);

    /// Turn everything Embree reported (callback or error code) into one `Err`.
    fn check(&self, step: &str) -> Result<(), EmbreeError> {
        self.errors()
            .check(step, self.error_code(), Self::ERROR_NONE)
    }

    /// The rest of a build once device and scene exist: the flags, the spheres and triangles
    /// of `geometry` (`n_tris` of them), the commit.
    fn finish(
        &mut self,
        geometry: &Geometry,
        n_tris: u32,
        robust: bool,
    ) -> Result<(), EmbreeError> {
        // SAFETY: the scene is valid (checked by the caller) and not committed yet.
        unsafe { self.set_robust(robust) };
        if self.spheres().1 > 0 {
            self.attach_spheres()?;
        }
        if n_tris > 0 {
            self.attach_triangles(geometry, n_tris)?;
        }
        // SAFETY: the scene is valid and every attached geometry is committed.
        unsafe { self.commit_scene() };
        self.check("rtcCommitScene")
    }

    /// The spheres as one user geometry (id [`SPHERE_GEOM`]) whose callbacks run the shared
    /// f64 kernels.
    fn attach_spheres(&mut self) -> Result<(), EmbreeError> {
        // SAFETY: device and scene are valid; the user pointer is the tracer's boxed
        // `SphereData`, which lives as long as the tracer (the scene is released before it in
        // `Drop`); the callbacks only read it.
        unsafe {
            let g = self.new_geometry(true);
            if Self::is_null(g) {
                return self.check("rtcNewGeometry(USER)");
            }
            let (data, count) = self.spheres();
            self.set_sphere_callbacks(g, count, data.as_user_ptr());
            self.commit_attach(g, SPHERE_GEOM);
        }
        self.check("sphere user geometry")
    }

    /// The triangles as one mesh (id [`TRIANGLE_GEOM`]) with unshared vertices.
    fn attach_triangles(&mut self, geometry: &Geometry, n_tris: u32) -> Result<(), EmbreeError> {
        let n = n_tris as usize;
        // SAFETY: device and scene are valid. Embree's new buffers hold `count × stride` bytes
        // (padded for its SIMD loads), filled completely before the commit; NULL (reported
        // through the error callback) is checked.
        unsafe {
            let g = self.new_geometry(false);
            if Self::is_null(g) {
                return self.check("rtcNewGeometry(TRIANGLE)");
            }
            let (vb, ib) = self.triangle_buffers(g, n);
            if vb.is_null() || ib.is_null() {
                self.release(g);
                self.check("rtcSetNewGeometryBuffer")?;
                return Err("rtcSetNewGeometryBuffer returned NULL".into());
            }
            fill_triangles(
                geometry,
                std::slice::from_raw_parts_mut(vb, 3 * n),
                std::slice::from_raw_parts_mut(ib, n),
            );
            self.commit_attach(g, TRIANGLE_GEOM);
        }
        self.check("triangle mesh")
    }
}

/// Messages from Embree's error callback, collected while building.
#[derive(Default)]
pub(crate) struct ErrorSink(Mutex<Vec<String>>);

impl ErrorSink {
    fn push(&self, msg: String) {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(msg);
    }

    /// Everything reported so far for `step` as one `Err`: the callback's messages, or else the
    /// device's error code when it is not `none`.
    pub(crate) fn check(&self, step: &str, code: c_int, none: c_int) -> Result<(), EmbreeError> {
        let mut msgs = std::mem::take(&mut *self.0.lock().unwrap_or_else(|e| e.into_inner()));
        if code != none && msgs.is_empty() {
            msgs.push(format!("Embree error {code}"));
        }
        if msgs.is_empty() {
            Ok(())
        } else {
            Err(EmbreeError(format!("{step}: {}", msgs.join("; "))))
        }
    }

    /// The pointer both APIs hand back to [`on_error`].
    pub(crate) fn as_user_ptr(&self) -> *mut c_void {
        self as *const ErrorSink as *mut c_void
    }
}

/// Embree's error callback (the same C signature in Embree 3 and 4), with an [`ErrorSink`] as
/// user pointer. It must not unwind into C: everything runs under `catch_unwind`.
pub(crate) unsafe extern "C" fn on_error(user_ptr: *mut c_void, code: c_int, msg: *const c_char) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let text = if msg.is_null() {
            String::from("(no message)")
        } else {
            // SAFETY: Embree passes a NUL-terminated string valid for the duration of the call.
            unsafe { CStr::from_ptr(msg) }
                .to_string_lossy()
                .into_owned()
        };
        if !user_ptr.is_null() {
            // SAFETY: `user_ptr` is the `ErrorSink` boxed in the tracer, which outlives the
            // device (each tracer releases its device first in `Drop`).
            let sink = unsafe { &*(user_ptr as *const ErrorSink) };
            sink.push(format!("Embree error {code}: {text}"));
        }
    }));
}

/// The spheres handed to the user geometry's callbacks (their user pointer).
pub(crate) struct SphereData {
    pub(crate) spheres: Vec<Sphere>,
}

impl SphereData {
    /// The pointer both APIs hand to the callbacks.
    pub(crate) fn as_user_ptr(&self) -> *mut c_void {
        self as *const SphereData as *mut c_void
    }

    /// Sphere `prim` behind a callback's user pointer.
    ///
    /// # Safety
    /// `user` must be the pointer of a live `SphereData` ([`Self::as_user_ptr`]).
    #[inline(always)]
    pub(crate) unsafe fn sphere<'a>(user: *const c_void, prim: u32) -> Option<&'a Sphere> {
        // SAFETY: guaranteed by the caller.
        let data = unsafe { &*(user as *const SphereData) };
        data.spheres.get(prim as usize)
    }
}

/// A sphere's box padded one ulp outwards, so the f64 hit test never finds a hit outside the box
/// Embree traverses: `(lower, upper)`.
pub(crate) fn padded_bounds(s: &Sphere) -> ([f32; 3], [f32; 3]) {
    let (lo, hi) = s.bounds();
    (
        [lo.x, lo.y, lo.z].map(next_float_down),
        [hi.x, hi.y, hi.z].map(next_float_up),
    )
}

/// Read ray `i` of an SOA packet of `n` rays (`RTCRayN` layout) and its `tfar`.
///
/// # Safety
/// `packet` must point to an `RTCRayN`/`RTCRayHitN` packet of `n` rays and `i < n`.
#[inline(always)]
unsafe fn packet_ray(packet: *const f32, n: usize, i: usize) -> (Ray, f32) {
    // SAFETY: guaranteed by the caller: rows 0..12 of ray `i` are inside the packet.
    let f = |k: usize| unsafe { *packet.add(k * n + i) };
    let o = glam::Vec3::new(f(0), f(1), f(2));
    let d = glam::Vec3::new(f(4), f(5), f(6));
    (Ray::new(o, d), f(8))
}

/// The sphere user geometry's closest-hit kernel over a packet: Embree's `t ≤ tfar` becomes
/// raysched's `t < next_float_up(tfar)`; a hit writes `tfar`, the normal, `u = v = 0` and the
/// ids. Infallible (no indexing that can panic), so nothing can unwind into Embree.
///
/// # Safety
/// `valid` has `n` entries and `rayhit` is an `RTCRayHitN` packet of `n` rays (rows of `n`
/// values: tfar is row 8, the hit starts at row 12 with Ng xyz, u, v, primID, geomID,
/// instID[0]); rows past instID[0] are left as Embree set them.
#[inline(always)]
pub(crate) unsafe fn intersect_packet(
    s: &Sphere,
    ids: [u32; 3],
    valid: *const c_int,
    rayhit: *mut f32,
    n: usize,
) {
    let [prim, geom, inst] = ids;
    for i in 0..n {
        // SAFETY: `i < n` entries of `valid`.
        if unsafe { *valid.add(i) } == 0 {
            continue;
        }
        // SAFETY: `rayhit` is a packet of `n` rays and `i < n`.
        let (ray, tfar) = unsafe { packet_ray(rayhit, n, i) };
        if let Some(t) = s.intersect(&ray, next_float_up(tfar)) {
            let ng = ray.at(t) - s.center;
            // SAFETY: rows 8 and 12..20 of ray `i` are inside the packet (see above).
            unsafe {
                *rayhit.add(8 * n + i) = t;
                *rayhit.add(12 * n + i) = ng.x;
                *rayhit.add(13 * n + i) = ng.y;
                *rayhit.add(14 * n + i) = ng.z;
                *rayhit.add(15 * n + i) = 0.0;
                *rayhit.add(16 * n + i) = 0.0;
                let id_rows = rayhit as *mut u32;
                *id_rows.add(17 * n + i) = prim;
                *id_rows.add(18 * n + i) = geom;
                *id_rows.add(19 * n + i) = inst;
            }
        }
    }
}

/// The sphere user geometry's occlusion kernel over a packet: a hit is reported as
/// `tfar = −∞`.
///
/// # Safety
/// `valid` has `n` entries and `ray` is an `RTCRayN` packet of `n` rays (tfar is row 8).
#[inline(always)]
pub(crate) unsafe fn occluded_packet(s: &Sphere, valid: *const c_int, ray: *mut f32, n: usize) {
    for i in 0..n {
        // SAFETY: `i < n` entries of `valid`.
        if unsafe { *valid.add(i) } == 0 {
            continue;
        }
        // SAFETY: `ray` is a packet of `n` rays and `i < n`.
        let (r, tfar) = unsafe { packet_ray(ray, n, i) };
        if s.intersect(&r, next_float_up(tfar)).is_some() {
            // SAFETY: row 8 of the packet is tfar.
            unsafe { *ray.add(8 * n + i) = f32::NEG_INFINITY };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::geometry::Triangle;
    use glam::Vec3;

    #[test]
    fn the_ray_interval_excludes_t_max_and_empty_intervals() {
        assert_eq!(tfar_for(1.0), Some(next_float_down(1.0)));
        assert_eq!(tfar_for(f32::INFINITY), Some(f32::INFINITY));
        assert_eq!(tfar_for(0.0), None);
        assert_eq!(tfar_for(-1.0), None);
        assert_eq!(tfar_for(f32::NAN), None);
    }

    #[test]
    fn primitive_ids_put_spheres_first() {
        assert_eq!(primitive_id(3, SPHERE_GEOM, 2), 2);
        assert_eq!(primitive_id(3, TRIANGLE_GEOM, 0), 3);
        assert_eq!(primitive_id(0, TRIANGLE_GEOM, 5), 5);
    }

    #[test]
    fn triangles_are_uploaded_with_unshared_vertices_in_order() {
        let t = |z: f32| {
            Triangle::new(
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(0.0, 1.0, z),
            )
        };
        let g = Geometry {
            triangles: vec![t(1.0), t(2.0)],
            ..Default::default()
        };
        let mut verts = vec![[f32::NAN; 3]; 6];
        let mut idx = vec![[u32::MAX; 3]; 2];
        fill_triangles(&g, &mut verts, &mut idx);
        assert_eq!(idx, vec![[0, 1, 2], [3, 4, 5]]);
        for (i, tri) in g.triangles.iter().enumerate() {
            let want: Vec<[f32; 3]> = tri.vertices().iter().map(|v| v.to_array()).collect();
            assert_eq!(&verts[3 * i..3 * i + 3], &want[..]);
        }
    }

    #[test]
    fn the_error_sink_reports_messages_else_the_code_once() {
        let sink = ErrorSink::default();
        assert_eq!(sink.check("step", 0, 0), Ok(()));
        assert_eq!(
            sink.check("step", 3, 0),
            Err(EmbreeError("step: Embree error 3".to_string()))
        );
        let msg = c"bad thing";
        // SAFETY: the sink outlives the call; `msg` is NUL-terminated.
        unsafe { on_error(sink.as_user_ptr(), 2, msg.as_ptr()) };
        assert_eq!(
            sink.check("build", 2, 0),
            Err(EmbreeError("build: Embree error 2: bad thing".to_string()))
        );
        assert_eq!(sink.check("build", 0, 0), Ok(()), "messages are taken once");
    }

    #[test]
    fn the_packet_kernels_write_only_valid_lanes_that_hit() {
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, 5.0),
            radius: 1.0,
        };
        let n = 4;
        // RTCRayHitN of 4 rays: 20 rows (ray 0..12, hit 12..20); lane 2 misses, lane 3 invalid.
        let mut packet = vec![0.0f32; 20 * n];
        let dirs = [
            [0.0, 0.0, 1.0],
            [0.0, 0.1, 1.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        for (i, d) in dirs.iter().enumerate() {
            for k in 0..3 {
                packet[(4 + k) * n + i] = d[k];
            }
            packet[8 * n + i] = f32::INFINITY;
        }
        let valid = [-1, -1, -1, 0];
        let mut occl = packet.clone();
        // SAFETY: `valid` has `n` entries; `packet` has 20 rows of `n`.
        unsafe {
            intersect_packet(
                &s,
                [7, SPHERE_GEOM, 9],
                valid.as_ptr(),
                packet.as_mut_ptr(),
                n,
            )
        };
        let tfar = |p: &[f32], i: usize| p[8 * n + i];
        let id = |p: &[f32], row: usize, i: usize| p[row * n + i].to_bits();
        assert_eq!(tfar(&packet, 0), 4.0);
        assert!(tfar(&packet, 1) > 4.0 && tfar(&packet, 1) < 5.0);
        assert_eq!(tfar(&packet, 2), f32::INFINITY);
        assert_eq!(tfar(&packet, 3), f32::INFINITY);
        assert_eq!(
            (id(&packet, 17, 0), id(&packet, 18, 0), id(&packet, 19, 0)),
            (7, 0, 9)
        );
        assert_eq!(
            packet[14 * n],
            -1.0,
            "normal is the hit point minus the centre"
        );
        assert_eq!(id(&packet, 17, 2), 0, "a miss writes no ids");
        // SAFETY: as above, as an `RTCRayN` (the first 12 rows).
        unsafe { occluded_packet(&s, valid.as_ptr(), occl.as_mut_ptr(), n) };
        let got: Vec<f32> = (0..n).map(|i| tfar(&occl, i)).collect();
        assert_eq!(
            got,
            vec![
                f32::NEG_INFINITY,
                f32::NEG_INFINITY,
                f32::INFINITY,
                f32::INFINITY
            ]
        );
    }
}
