//! `embree` tracer: Intel Embree 3 (Debian's `libembree-dev` 3.13.5) through the hand-written
//! bindings of [`ffi`]; what it shares with `embree4` (error sink, sphere kernels, triangle
//! upload) is in `crate::core::tracer::embree::common`.
//!
//! - Triangles are one `RTC_GEOMETRY_TYPE_TRIANGLE` mesh (geometry id 1) with unshared vertices
//!   `v0, v0+e1, v0+e2`, so Embree's `(u, v)` are our `(b1, b2)`.
//! - Spheres are one user geometry (geometry id 0) whose callbacks run the shared f64
//!   [`Sphere::intersect`], so sphere hits have bit-identical `t` to `bvh`/`brute` (Embree's own
//!   sphere primitive is not exact enough for rays that start on the surface).
//! - Embree accepts hits with `tnear < t ≤ tfar` (robust: `tnear ≤ t`); raysched's contract is
//!   `0 < t < t_max`, so rays go in with `tnear = f32::MIN_POSITIVE`, `tfar = next_float_down(t_max)`.
//! - Threads: the device is created with `threads=N` (the run's thread budget); Embree only uses
//!   them to build (its first commit starts TBB workers). Tracing runs on *our* workers:
//!   `rtcIntersect1` is thread-safe on a committed scene. [`EmbreeTracer::os_threads_after_build`]
//!   records what the process really had, via [`crate::util::host::os_thread_count`].
//! - Robustness: `RTC_SCENE_FLAG_ROBUST` is an option recorded in the tracer id
//!   (`embree_robust`): the default intersector lets a few rays leak through shared edges.
//!
//! An Embree device exists only inside an [`EmbreeTracer`]; a run that uses another tracer never
//! creates one ([`devices_created`] counts them for the test that says so).

pub mod ffi;

use crate::core::geometry::{Hit, Ray};
use crate::core::scene::Geometry;
use crate::core::tracer::embree::common::{
    impl_rtc_ray, on_error, padded_bounds, primitive_counts, primitive_id, rtc_ray, Builder,
    EmbreeError, ErrorSink, SphereData,
};
use std::ffi::{c_int, c_void, CString};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

static DEVICES_CREATED: AtomicUsize = AtomicUsize::new(0);

/// How many Embree devices this process has created so far.
pub fn devices_created() -> usize {
    DEVICES_CREATED.load(Ordering::Relaxed)
}

/// Build options; both are recorded (the thread budget in the run, `robust` in the tracer id).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmbreeOptions {
    /// Embree's own thread budget (device config `threads=N`), used by the BVH build only.
    pub threads: usize,
    /// `RTC_SCENE_FLAG_ROBUST`: watertight-ish traversal and intersection, slower on tiny scenes.
    pub robust: bool,
}

/// Bounds callback for the sphere user geometry ([`padded_bounds`]).
unsafe extern "C" fn sphere_bounds(args: *const ffi::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments; `geometry_user_ptr` is the `SphereData` boxed in
    // `EmbreeTracer`, which outlives the scene; `bounds_o` is valid for writing.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometry_user_ptr, args.prim_id) }) else {
        return;
    };
    let (lo, hi) = padded_bounds(s);
    let out = ffi::RTCBounds {
        lower_x: lo[0],
        lower_y: lo[1],
        lower_z: lo[2],
        align0: 0.0,
        upper_x: hi[0],
        upper_y: hi[1],
        upper_z: hi[2],
        align1: 0.0,
    };
    // SAFETY: see above.
    unsafe { args.bounds_o.write(out) };
}

/// Closest-hit callback ([`crate::core::tracer::embree::common::intersect_packet`]).
unsafe extern "C" fn sphere_intersect(args: *const ffi::RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` has `n` entries, `rayhit` is an
    // `RTCRayHitN` of `n` rays, `context` is the caller's context, `geometry_user_ptr` is our
    // `SphereData`.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometry_user_ptr, args.prim_id) }) else {
        return;
    };
    // SAFETY: as above.
    let ids = [args.prim_id, args.geom_id, unsafe {
        (*args.context).inst_id[0]
    }];
    let (valid, rayhit, n) = (args.valid, args.rayhit as *mut f32, args.n as usize);
    // SAFETY: as above.
    unsafe { crate::core::tracer::embree::common::intersect_packet(s, ids, valid, rayhit, n) };
}

/// Occlusion callback ([`crate::core::tracer::embree::common::occluded_packet`]).
unsafe extern "C" fn sphere_occluded(args: *const ffi::RTCOccludedFunctionNArguments) {
    // SAFETY: as in `sphere_intersect`, with `ray` an `RTCRayN` of `n` rays.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometry_user_ptr, args.prim_id) }) else {
        return;
    };
    let (valid, ray, n) = (args.valid, args.ray as *mut f32, args.n as usize);
    // SAFETY: as above.
    unsafe { crate::core::tracer::embree::common::occluded_packet(s, valid, ray, n) };
}

/// An Embree device and committed scene over one scene's geometry; queries take `&self` and
/// may run on any number of threads at once.
pub struct EmbreeTracer {
    device: ffi::RTCDevice,
    scene: ffi::RTCScene,
    /// Kept alive (and at a fixed address) for the error callback.
    errors: Box<ErrorSink>,
    /// Kept alive (and at a fixed address) for the sphere callbacks.
    spheres: Box<SphereData>,
    n_spheres: u32,
    options: EmbreeOptions,
    /// Wall time of device creation, geometry upload and `rtcCommitScene`.
    pub build_time: Duration,
    /// OS threads of the whole process right after the build (`None` off Linux).
    pub os_threads_after_build: Option<usize>,
}

// SAFETY: after `rtcCommitScene` an Embree scene is immutable and `rtcIntersect1`/`rtcOccluded1`
// may be called concurrently from any thread (Embree's documented contract); the device and
// scene handles are only released in `Drop`, which has exclusive access. The boxed callback data
// is only read by the callbacks (the error sink is behind a mutex).
unsafe impl Send for EmbreeTracer {}
// SAFETY: see `Send`.
unsafe impl Sync for EmbreeTracer {}

impl EmbreeTracer {
    /// Non-robust build with `threads` build threads (the `embree` tracer id).
    pub fn new(geometry: &Geometry, threads: usize) -> Result<Self, EmbreeError> {
        Self::with_options(
            geometry,
            EmbreeOptions {
                threads,
                robust: false,
            },
        )
    }

    /// # Errors
    /// `threads == 0`, too many primitives for Embree's 32-bit ids, or any error Embree reports
    /// (through its error callback) while creating the device and building the scene.
    pub fn with_options(geometry: &Geometry, options: EmbreeOptions) -> Result<Self, EmbreeError> {
        if options.threads == 0 {
            return Err("threads: must be ≥ 1 (got 0)".into());
        }
        let config = format!("threads={}", options.threads);
        Self::with_device_config(geometry, &config, options)
    }

    /// Like [`Self::with_options`] with Embree's device configuration string written out (e.g.
    /// `"threads=2,set_affinity=1"`); `options.threads` is only recorded, `config` decides.
    ///
    /// # Errors
    /// As [`Self::with_options`], plus a configuration Embree rejects.
    pub fn with_device_config(
        geometry: &Geometry,
        config: &str,
        options: EmbreeOptions,
    ) -> Result<Self, EmbreeError> {
        let (n_tris, n_spheres) = primitive_counts(geometry)?;
        let start = Instant::now();
        let c_config =
            CString::new(config).map_err(|_| format!("device config {config:?}: contains NUL"))?;
        // SAFETY: `config` is a valid C string for the duration of the call.
        let device = unsafe { ffi::rtcNewDevice(c_config.as_ptr()) };
        if device.is_null() {
            // SAFETY: a NULL device queries the thread-local error of the failed creation.
            let code = unsafe { ffi::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError(format!(
                "rtcNewDevice({config:?}) failed (Embree error {code})"
            )));
        }
        DEVICES_CREATED.fetch_add(1, Ordering::Relaxed);
        let errors = Box::new(ErrorSink::default());
        let spheres = Box::new(SphereData {
            spheres: geometry.spheres.clone(),
        });
        // SAFETY: `device` is valid; the sink outlives it (see `Drop`).
        unsafe { ffi::rtcSetDeviceErrorFunction(device, Some(on_error), errors.as_user_ptr()) };
        // SAFETY: `device` is valid.
        let scene = unsafe { ffi::rtcNewScene(device) };
        // From here on `Drop` releases whatever exists.
        let mut tracer = Self {
            device,
            scene,
            errors,
            spheres,
            n_spheres,
            options,
            build_time: Duration::ZERO,
            os_threads_after_build: None,
        };
        tracer.check("rtcNewScene")?;
        tracer.finish(geometry, n_tris, options.robust)?;
        tracer.build_time = start.elapsed();
        tracer.os_threads_after_build = crate::util::host::os_thread_count();
        Ok(tracer)
    }

    /// The options it was built with.
    pub fn options(&self) -> EmbreeOptions {
        self.options
    }
}

impl_rtc_ray!(ffi::RTCRay);

impl Builder for EmbreeTracer {
    type Geometry = ffi::RTCGeometry;
    const ERROR_NONE: c_int = ffi::RTC_ERROR_NONE;

    fn error_code(&self) -> c_int {
        // SAFETY: `device` is valid.
        unsafe { ffi::rtcGetDeviceError(self.device) }
    }
    fn errors(&self) -> &ErrorSink {
        &self.errors
    }
    fn spheres(&self) -> (&SphereData, u32) {
        (&self.spheres, self.n_spheres)
    }
    unsafe fn set_robust(&self, robust: bool) {
        let flags = if robust {
            ffi::RTC_SCENE_FLAG_ROBUST
        } else {
            ffi::RTC_SCENE_FLAG_NONE
        };
        // SAFETY: `scene` is valid (the caller's contract).
        unsafe { ffi::rtcSetSceneFlags(self.scene, flags) };
    }
    unsafe fn new_geometry(&self, user: bool) -> ffi::RTCGeometry {
        let kind = if user {
            ffi::RTC_GEOMETRY_TYPE_USER
        } else {
            ffi::RTC_GEOMETRY_TYPE_TRIANGLE
        };
        // SAFETY: `device` is valid (the caller's contract).
        unsafe { ffi::rtcNewGeometry(self.device, kind) }
    }
    fn is_null(g: ffi::RTCGeometry) -> bool {
        g.is_null()
    }
    unsafe fn set_sphere_callbacks(&self, g: ffi::RTCGeometry, count: u32, data: *mut c_void) {
        // SAFETY: `g` is a valid user geometry and `data` outlives the scene (the caller's
        // contract); the callbacks have Embree 3's signatures.
        unsafe {
            ffi::rtcSetGeometryUserPrimitiveCount(g, count);
            ffi::rtcSetGeometryUserData(g, data);
            ffi::rtcSetGeometryBoundsFunction(g, Some(sphere_bounds), data);
            ffi::rtcSetGeometryIntersectFunction(g, Some(sphere_intersect));
            ffi::rtcSetGeometryOccludedFunction(g, Some(sphere_occluded));
        }
    }
    unsafe fn triangle_buffers(
        &self,
        g: ffi::RTCGeometry,
        n: usize,
    ) -> (*mut [f32; 3], *mut [u32; 3]) {
        // SAFETY: `g` is a valid triangle geometry (the caller's contract).
        unsafe {
            let vb = ffi::rtcSetNewGeometryBuffer(
                g,
                ffi::RTC_BUFFER_TYPE_VERTEX,
                0,
                ffi::RTC_FORMAT_FLOAT3,
                12,
                3 * n,
            ) as *mut [f32; 3];
            let ib = ffi::rtcSetNewGeometryBuffer(
                g,
                ffi::RTC_BUFFER_TYPE_INDEX,
                0,
                ffi::RTC_FORMAT_UINT3,
                12,
                n,
            ) as *mut [u32; 3];
            (vb, ib)
        }
    }
    unsafe fn commit_attach(&self, g: ffi::RTCGeometry, id: u32) {
        // SAFETY: `g` is a valid, filled geometry and `scene` is valid; the scene holds its
        // own reference once attached.
        unsafe {
            ffi::rtcCommitGeometry(g);
            ffi::rtcAttachGeometryByID(self.scene, g, id);
            ffi::rtcReleaseGeometry(g);
        }
    }
    unsafe fn release(&self, g: ffi::RTCGeometry) {
        // SAFETY: `g` is a valid geometry (the caller's contract).
        unsafe { ffi::rtcReleaseGeometry(g) }
    }
    unsafe fn commit_scene(&self) {
        // SAFETY: `scene` is valid and its geometries committed (the caller's contract).
        unsafe { ffi::rtcCommitScene(self.scene) }
    }
}

// The `Tracer` impl lives in `crate::core::tracer`, which depends on this module, not the reverse.
impl EmbreeTracer {
    /// Closest hit with `0 < t < t_max`, as [`crate::core::tracer::Tracer::intersect`].
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut rh = ffi::RTCRayHit {
            ray: rtc_ray(ray, t_max)?,
            hit: ffi::RTCHit {
                prim_id: ffi::INVALID_ID,
                geom_id: ffi::INVALID_ID,
                inst_id: [ffi::INVALID_ID],
                ..Default::default()
            },
        };
        let mut ctx = ffi::RTCIntersectContext::new();
        // SAFETY: the scene is committed and immutable; `ctx` and `rh` are valid, properly
        // aligned (`align(16)`) locals for the duration of the call.
        unsafe { ffi::rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        if rh.hit.geom_id == ffi::INVALID_ID {
            return None;
        }
        Some(Hit {
            t: rh.ray.tfar,
            prim: primitive_id(self.n_spheres, rh.hit.geom_id, rh.hit.prim_id),
            b1: rh.hit.u,
            b2: rh.hit.v,
        })
    }

    /// Whether anything is hit with `0 < t < t_max`, as [`crate::core::tracer::Tracer::occluded`].
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let Some(mut r) = rtc_ray::<ffi::RTCRay>(ray, t_max) else {
            return false;
        };
        let mut ctx = ffi::RTCIntersectContext::new();
        // SAFETY: as in `intersect`.
        unsafe { ffi::rtcOccluded1(self.scene, &mut ctx, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeTracer {
    fn drop(&mut self) {
        // SAFETY: both handles came from Embree and are released exactly once, the scene (which
        // references the callback data) before the device (which references the error sink);
        // the boxes are dropped only after this function.
        unsafe {
            if !self.scene.is_null() {
                ffi::rtcReleaseScene(self.scene);
            }
            ffi::rtcReleaseDevice(self.device);
        }
    }
}
