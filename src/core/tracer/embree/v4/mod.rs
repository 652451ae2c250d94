//! `embree4` tracer: Intel Embree 4 through `embree4-sys`, beside Embree 3 (`crate::core::tracer::embree::v3`).
//! The library is found by `build/embree4.rs`: the system's, `EMBREE4_DIR`, or the PyPI `embreex`
//! wheel `.ci/fetch-embree4` unpacks (Embree 4.4.0 with its own TBB).
//!
//! **Why not the `embree4-rs` wrapper (0.0.16, the newest published).** It keeps its device and scene handles private, so nothing it lacks can be added beside it,
//! and it lacks what this tracer needs: an error callback (it polls `rtcGetDeviceError` after each
//! call, once per ray in `intersect_1`), occlusion queries (no `rtcOccluded1`), a user geometry
//! with more than one primitive and an occlusion callback (its `UserGeometry` has one primitive,
//! no occluded function, and `ptr::read`s the user data by value in every callback), and a device
//! configuration string that is NUL-terminated (`Device::try_new` passes `str::as_bytes`).
//! Its `intersect_1` also hands Embree a 4.2-sized `RTCRayHit`, which Embree 4.4 overruns (see
//! [`ffi`]). So the tracer uses `embree4-sys`'s types and looks Embree 4's functions up in a
//! library opened locally, so that it can live beside Embree 3 in one process ([`ffi`] says
//! why and what is taken from `embree4-sys`).
//!
//! The tracer itself follows the Embree 3 one:
//! - Triangles are one `RTC_GEOMETRY_TYPE_TRIANGLE` mesh (geometry id 1) with unshared vertices
//!   `v0, v0+e1, v0+e2`, so Embree's `(u, v)` are our `(b1, b2)`.
//! - Spheres are one user geometry (geometry id 0) whose callbacks run the shared f64
//!   [`Sphere::intersect`], so sphere hits have bit-identical `t` to `bvh`/`brute`.
//! - raysched's contract is `0 < t < t_max`: rays go in with `tnear = f32::MIN_POSITIVE`,
//!   `tfar = next_float_down(t_max)`. Queries pass no `RTCIntersectArguments` (Embree's defaults:
//!   incoherent, every feature), so no struct whose layout changed within 4.x crosses the FFI.
//! - Threads: the device is created with `threads=N` (the run's thread budget); Embree uses them
//!   only to build. Tracing runs on raysched's workers (`rtcIntersect1` is thread-safe on a
//!   committed scene). [`Embree4Tracer::os_threads_after_build`] records what the process had.
//! - Errors: Embree's error callback collects messages, which become the `Err` of the build.
//!   Callbacks never unwind into C: the error callback runs under `catch_unwind`, the geometry
//!   callbacks cannot panic (no indexing, no allocation), and a Rust panic in an `extern "C"`
//!   function aborts the process rather than unwinding.
//!
//! An Embree 4 device exists only inside an [`Embree4Tracer`] ([`devices_created`] counts them).

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

/// How many Embree 4 devices this process has created so far.
pub fn devices_created() -> usize {
    DEVICES_CREATED.load(Ordering::Relaxed)
}

pub use ffi::LIBRARY;

/// Build options; both are recorded (the thread budget in the run, `robust` in the tracer id).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Embree4Options {
    /// Embree's own thread budget (device config `threads=N`), used by the BVH build only.
    pub threads: usize,
    /// `RTC_SCENE_FLAG_ROBUST`: robust traversal and intersection, fewer leaks through edges.
    pub robust: bool,
}

/// Bounds callback for the sphere user geometry ([`padded_bounds`]).
unsafe extern "C" fn sphere_bounds(args: *const ffi::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments; `geometryUserPtr` is the `SphereData` boxed in
    // `Embree4Tracer`, which outlives the scene.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometryUserPtr, args.primID) }) else {
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
    // SAFETY: `bounds_o` is valid for writing one `RTCBounds`.
    unsafe { args.bounds_o.write(out) };
}

/// Closest-hit callback ([`crate::core::tracer::embree::common::intersect_packet`]). No instances in
/// raysched's scenes, and the context's layout differs within 4.x, so instID[0] is written
/// invalid rather than read from the context.
unsafe extern "C" fn sphere_intersect(args: *const ffi::RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` has `N` entries, `rayhit` is an
    // `RTCRayHitN` of `N` rays, `geometryUserPtr` is our `SphereData`.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometryUserPtr, args.primID) }) else {
        return;
    };
    let ids = [args.primID, args.geomID, ffi::RTC_INVALID_GEOMETRY_ID];
    let (valid, rayhit, n) = (args.valid, args.rayhit as *mut f32, args.N as usize);
    // SAFETY: as above.
    unsafe { crate::core::tracer::embree::common::intersect_packet(s, ids, valid, rayhit, n) };
}

/// Occlusion callback ([`crate::core::tracer::embree::common::occluded_packet`]).
unsafe extern "C" fn sphere_occluded(args: *const ffi::RTCOccludedFunctionNArguments) {
    // SAFETY: as in `sphere_intersect`, with `ray` an `RTCRayN` of `N` rays.
    let args = unsafe { &*args };
    let Some(s) = (unsafe { SphereData::sphere(args.geometryUserPtr, args.primID) }) else {
        return;
    };
    let (valid, ray, n) = (args.valid, args.ray as *mut f32, args.N as usize);
    // SAFETY: as above.
    unsafe { crate::core::tracer::embree::common::occluded_packet(s, valid, ray, n) };
}

/// An Embree 4 device and committed scene over one scene's geometry; queries take `&self` and
/// may run on any number of threads at once.
pub struct Embree4Tracer {
    /// The functions of the deep-bound Embree 4 library.
    api: &'static ffi::Api,
    device: ffi::RTCDevice,
    scene: ffi::RTCScene,
    /// Kept alive (and at a fixed address) for the error callback.
    errors: Box<ErrorSink>,
    /// Kept alive (and at a fixed address) for the sphere callbacks.
    spheres: Box<SphereData>,
    n_spheres: u32,
    options: Embree4Options,
    version: u32,
    /// Wall time of device creation, geometry upload and `rtcCommitScene`.
    pub build_time: Duration,
    /// OS threads of the whole process right after the build (`None` off Linux).
    pub os_threads_after_build: Option<usize>,
}

// SAFETY: after `rtcCommitScene` an Embree scene is immutable and `rtcIntersect1`/`rtcOccluded1`
// may be called concurrently from any thread (Embree's documented contract); the device and
// scene handles are only released in `Drop`, which has exclusive access. The boxed callback data
// is only read by the callbacks (the error sink is behind a mutex).
unsafe impl Send for Embree4Tracer {}
// SAFETY: see `Send`.
unsafe impl Sync for Embree4Tracer {}

impl Embree4Tracer {
    /// # Errors
    /// `threads == 0`, too many primitives for Embree's 32-bit ids, a library that is not
    /// Embree 4, or any error Embree reports (through its error callback) while creating the
    /// device and building the scene.
    pub fn with_options(geometry: &Geometry, options: Embree4Options) -> Result<Self, EmbreeError> {
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
        options: Embree4Options,
    ) -> Result<Self, EmbreeError> {
        let (n_tris, n_spheres) = primitive_counts(geometry)?;
        let api = ffi::api()?;
        let start = Instant::now();
        let c_config =
            CString::new(config).map_err(|_| format!("device config {config:?}: contains NUL"))?;
        // SAFETY: `config` is a valid NUL-terminated C string for the duration of the call.
        let device = unsafe { (api.rtcNewDevice)(c_config.as_ptr()) };
        if device.is_null() {
            // SAFETY: a NULL device queries the thread-local error of the failed creation.
            let code = unsafe { (api.rtcGetDeviceError)(std::ptr::null_mut()) };
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
        unsafe { (api.rtcSetDeviceErrorFunction)(device, Some(on_error), errors.as_user_ptr()) };
        // SAFETY: `device` is valid.
        let version =
            unsafe { (api.rtcGetDeviceProperty)(device, ffi::RTCDeviceProperty::VERSION) };
        // SAFETY: `device` is valid.
        let scene = unsafe { (api.rtcNewScene)(device) };
        // From here on `Drop` releases whatever exists.
        let mut tracer = Self {
            api,
            device,
            scene,
            errors,
            spheres,
            n_spheres,
            options,
            version: u32::try_from(version).unwrap_or(0),
            build_time: Duration::ZERO,
            os_threads_after_build: None,
        };
        tracer.check("rtcNewScene")?;
        if tracer.version / 10_000 != 4 {
            return Err(EmbreeError(format!(
                "{LIBRARY} reports Embree version {version}, not 4.x"
            )));
        }
        tracer.finish(geometry, n_tris, options.robust)?;
        tracer.build_time = start.elapsed();
        tracer.os_threads_after_build = crate::util::host::os_thread_count();
        Ok(tracer)
    }

    /// The options it was built with.
    pub fn options(&self) -> Embree4Options {
        self.options
    }

    /// The library's `RTC_DEVICE_PROPERTY_VERSION` (e.g. 40400 for 4.4.0).
    pub fn version(&self) -> u32 {
        self.version
    }
}

impl_rtc_ray!(ffi::RTCRay);

impl Builder for Embree4Tracer {
    type Geometry = ffi::RTCGeometry;
    const ERROR_NONE: c_int = ffi::ERROR_NONE;

    fn error_code(&self) -> c_int {
        // SAFETY: `device` is valid.
        unsafe { (self.api.rtcGetDeviceError)(self.device) }
    }
    fn errors(&self) -> &ErrorSink {
        &self.errors
    }
    fn spheres(&self) -> (&SphereData, u32) {
        (&self.spheres, self.n_spheres)
    }
    unsafe fn set_robust(&self, robust: bool) {
        let flags = if robust {
            ffi::RTCSceneFlags::ROBUST
        } else {
            ffi::RTCSceneFlags::NONE
        };
        // SAFETY: `scene` is valid (the caller's contract).
        unsafe { (self.api.rtcSetSceneFlags)(self.scene, flags) };
    }
    unsafe fn new_geometry(&self, user: bool) -> ffi::RTCGeometry {
        let kind = if user {
            ffi::RTCGeometryType::USER
        } else {
            ffi::RTCGeometryType::TRIANGLE
        };
        // SAFETY: `device` is valid (the caller's contract).
        unsafe { (self.api.rtcNewGeometry)(self.device, kind) }
    }
    fn is_null(g: ffi::RTCGeometry) -> bool {
        g.is_null()
    }
    unsafe fn set_sphere_callbacks(&self, g: ffi::RTCGeometry, count: u32, data: *mut c_void) {
        // SAFETY: `g` is a valid user geometry and `data` outlives the scene (the caller's
        // contract); the callbacks have Embree 4's signatures.
        unsafe {
            (self.api.rtcSetGeometryUserPrimitiveCount)(g, count);
            (self.api.rtcSetGeometryBoundsFunction)(g, Some(sphere_bounds), data);
            // The intersect and occluded callbacks read the geometry's user pointer.
            (self.api.rtcSetGeometryUserData)(g, data);
            (self.api.rtcSetGeometryIntersectFunction)(g, Some(sphere_intersect));
            (self.api.rtcSetGeometryOccludedFunction)(g, Some(sphere_occluded));
        }
    }
    unsafe fn triangle_buffers(
        &self,
        g: ffi::RTCGeometry,
        n: usize,
    ) -> (*mut [f32; 3], *mut [u32; 3]) {
        // SAFETY: `g` is a valid triangle geometry (the caller's contract).
        unsafe {
            let vb = (self.api.rtcSetNewGeometryBuffer)(
                g,
                ffi::RTCBufferType::VERTEX,
                0,
                ffi::RTCFormat::FLOAT3,
                12,
                3 * n,
            ) as *mut [f32; 3];
            let ib = (self.api.rtcSetNewGeometryBuffer)(
                g,
                ffi::RTCBufferType::INDEX,
                0,
                ffi::RTCFormat::UINT3,
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
            (self.api.rtcCommitGeometry)(g);
            (self.api.rtcAttachGeometryByID)(self.scene, g, id);
            (self.api.rtcReleaseGeometry)(g);
        }
    }
    unsafe fn release(&self, g: ffi::RTCGeometry) {
        // SAFETY: `g` is a valid geometry (the caller's contract).
        unsafe { (self.api.rtcReleaseGeometry)(g) }
    }
    unsafe fn commit_scene(&self) {
        // SAFETY: `scene` is valid and its geometries committed (the caller's contract).
        unsafe { (self.api.rtcCommitScene)(self.scene) }
    }
}

// The `Tracer` impl lives in `crate::core::tracer`, which depends on this module, not the reverse.
impl Embree4Tracer {
    /// Closest hit with `0 < t < t_max`, as [`crate::core::tracer::Tracer::intersect`].
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut slot = ffi::RayHitSlot::new(rtc_ray(ray, t_max)?);
        // SAFETY: the scene is committed and immutable; `slot` is a valid, 16-byte aligned
        // local with room for the largest Embree 4 `RTCRayHit` (see `ffi::RayHitSlot`); NULL
        // arguments select Embree's defaults.
        unsafe {
            (self.api.rtcIntersect1)(
                self.scene,
                (&mut slot as *mut ffi::RayHitSlot).cast(),
                std::ptr::null_mut(),
            )
        };
        let rh = &slot.rayhit;
        if rh.hit.geomID == ffi::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: rh.ray.tfar,
            prim: primitive_id(self.n_spheres, rh.hit.geomID, rh.hit.primID),
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
        // SAFETY: as in `intersect`; `rtcOccluded1` writes only the `RTCRay` (its `tfar`).
        unsafe { (self.api.rtcOccluded1)(self.scene, &mut r, std::ptr::null_mut()) };
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for Embree4Tracer {
    fn drop(&mut self) {
        // SAFETY: both handles came from Embree and are released exactly once, the scene (which
        // references the callback data) before the device (which references the error sink);
        // the boxes are dropped only after this function.
        unsafe {
            if !self.scene.is_null() {
                (self.api.rtcReleaseScene)(self.scene);
            }
            (self.api.rtcReleaseDevice)(self.device);
        }
    }
}
