//! The part of Embree 4's C API that raysched uses. Types, enums and callback argument structs
//! come from `embree4-sys` (bindgen over Embree 4.2.0's headers); the functions are looked up at
//! run time in a library opened with `dlopen(RTLD_LOCAL | RTLD_DEEPBIND)`, not linked.
//!
//! Why not link: Embree 3 and Embree 4 export the same unversioned symbols (`rtcNewDevice`,
//! `rtcIntersect1`, … — `objdump -T` shows `Base` for both), so a binary that links both (every
//! `--all-features` build) would bind each name to whichever library the loader meets first, and
//! one of the two tracers would call the other generation's functions. Opened locally and deep-
//! bound, Embree 4 and its bundled TBB resolve their own symbols, and nothing of theirs enters
//! the global scope Embree 3 is resolved in. `embree4-sys` still asks the linker for
//! `-lembree4`; as no symbol of it is referenced, `--as-needed` drops the library from the
//! binary's `NEEDED` list.
//!
//! Two declarations are made here because the 4.2 headers do not describe every Embree 4
//! library they meet:
//! - [`RayHitSlot`]: Embree ≥ 4.3 built with instance arrays (the PyPI `embreex` 4.4.0 build is)
//!   has an `instPrimID` after `RTCHit::instID`, so its `RTCRayHit` is 96 bytes, not the 80 of the
//!   4.2 header. Measured: `rtcIntersect1` on a triangle wrote `0xffffffff` into the 4 bytes right
//!   after a 4.2-sized `RTCRayHit`. Every ray/hit raysched hands to Embree is a [`RayHitSlot`].
//! - The error code is a plain `c_int`: `embree4-sys` types it as a Rust enum without 4.3's
//!   code 7, which a newer library would make undefined behaviour.

#![allow(
    missing_docs,
    non_snake_case,
    reason = "raw bindings: each item mirrors its namesake in Embree 4's rtcore*.h"
)]

use crate::core::tracer::embree::common::EmbreeError;
use std::ffi::{c_char, c_int, c_uint, c_void};
use std::sync::OnceLock;

pub use embree4_sys::{
    RTCBounds, RTCBoundsFunction, RTCBoundsFunctionArguments, RTCBufferType, RTCDevice,
    RTCDeviceProperty, RTCFormat, RTCGeometry, RTCGeometryType, RTCHit, RTCIntersectArguments,
    RTCIntersectFunctionN, RTCIntersectFunctionNArguments, RTCOccludedArguments,
    RTCOccludedFunctionN, RTCOccludedFunctionNArguments, RTCRay, RTCRayHit, RTCScene,
    RTCSceneFlags, RTC_INVALID_GEOMETRY_ID,
};

/// `RTC_ERROR_NONE`.
pub const ERROR_NONE: c_int = 0;

/// Embree's error callback with the code as a plain integer.
pub type ErrorFunction =
    unsafe extern "C" fn(user_ptr: *mut c_void, code: c_int, msg: *const c_char);

/// The Embree 4 library the build script found (`build/embree4.rs`).
pub const LIBRARY: &str = env!("RAYSCHED_EMBREE4_LIB");

crate::util::dl::dl_api! {
    /// Embree 4's functions, resolved in the deep-bound library.
    pub struct Api, abi "C", missing |name| format!("{LIBRARY}: no symbol {name}");
    rtcNewDevice: fn(*const c_char) -> RTCDevice;
    rtcReleaseDevice: fn(RTCDevice);
    rtcGetDeviceError: fn(RTCDevice) -> c_int;
    rtcSetDeviceErrorFunction: fn(RTCDevice, Option<ErrorFunction>, *mut c_void);
    rtcGetDeviceProperty: fn(RTCDevice, RTCDeviceProperty) -> isize;
    rtcNewScene: fn(RTCDevice) -> RTCScene;
    rtcReleaseScene: fn(RTCScene);
    rtcSetSceneFlags: fn(RTCScene, RTCSceneFlags);
    rtcAttachGeometryByID: fn(RTCScene, RTCGeometry, c_uint);
    rtcCommitScene: fn(RTCScene);
    rtcNewGeometry: fn(RTCDevice, RTCGeometryType) -> RTCGeometry;
    rtcReleaseGeometry: fn(RTCGeometry);
    rtcCommitGeometry: fn(RTCGeometry);
    rtcSetNewGeometryBuffer: fn(RTCGeometry, RTCBufferType, c_uint, RTCFormat, usize, usize) -> *mut c_void;
    rtcSetGeometryUserPrimitiveCount: fn(RTCGeometry, c_uint);
    rtcSetGeometryUserData: fn(RTCGeometry, *mut c_void);
    rtcSetGeometryBoundsFunction: fn(RTCGeometry, RTCBoundsFunction, *mut c_void);
    rtcSetGeometryIntersectFunction: fn(RTCGeometry, RTCIntersectFunctionN);
    rtcSetGeometryOccludedFunction: fn(RTCGeometry, RTCOccludedFunctionN);
    rtcIntersect1: fn(RTCScene, *mut RTCRayHit, *mut RTCIntersectArguments);
    rtcOccluded1: fn(RTCScene, *mut RTCRay, *mut RTCOccludedArguments);
}

/// Embree 4's functions, the library opened on first use (the path the build found, else its
/// file name through the rpath and `LD_LIBRARY_PATH`).
///
/// # Errors
/// The library cannot be opened or lacks a function.
pub fn api() -> Result<&'static Api, EmbreeError> {
    static API: OnceLock<Result<Api, EmbreeError>> = OnceLock::new();
    API.get_or_init(|| {
        let file_name = std::path::Path::new(LIBRARY)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let lib = crate::util::dl::Library::open_first(&[LIBRARY.to_string(), file_name])
            .map_err(|e| EmbreeError(format!("cannot open Embree 4: {e}")))?;
        // SAFETY: `lib` is an Embree 4 library (the build script found it by name); it is
        // never closed, so the table stays valid.
        unsafe { Api::resolve(&lib) }.map_err(EmbreeError)
    })
    .as_ref()
    .map_err(Clone::clone)
}

/// An `RTCRayHit` with room for the hit fields an Embree newer than the bound headers writes
/// (`instPrimID`); 96 bytes, the size of 4.4's `RTCRayHit` with one instance level.
#[repr(C, align(16))]
pub struct RayHitSlot {
    pub rayhit: RTCRayHit,
    /// Written by Embree ≥ 4.3 (`instPrimID[0]`), never read.
    pub spare: [u32; 4],
}

impl RayHitSlot {
    /// Ray `ray` with no hit yet.
    #[inline(always)]
    pub fn new(ray: RTCRay) -> Self {
        Self {
            rayhit: RTCRayHit {
                ray,
                hit: RTCHit {
                    Ng_x: 0.0,
                    Ng_y: 0.0,
                    Ng_z: 0.0,
                    u: 0.0,
                    v: 0.0,
                    primID: RTC_INVALID_GEOMETRY_ID,
                    geomID: RTC_INVALID_GEOMETRY_ID,
                    instID: [RTC_INVALID_GEOMETRY_ID],
                },
            },
            spare: [RTC_INVALID_GEOMETRY_ID; 4],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{align_of, offset_of, size_of};

    /// Embree 4's single-ray structs; the slot leaves room for 4.4's larger hit.
    #[test]
    fn layouts_leave_room_for_newer_hits() {
        assert_eq!((size_of::<RTCRay>(), align_of::<RTCRay>()), (48, 16));
        assert_eq!(size_of::<RTCRayHit>(), 80);
        assert_eq!(offset_of!(RTCRayHit, hit), 48);
        assert_eq!(
            (size_of::<RayHitSlot>(), align_of::<RayHitSlot>()),
            (96, 16)
        );
        assert_eq!(offset_of!(RayHitSlot, spare), 80);
        assert_eq!(size_of::<RTCIntersectFunctionNArguments>(), 48);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, rayhit), 32);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, N), 40);
        assert_eq!(offset_of!(RTCOccludedFunctionNArguments, ray), 32);
        assert_eq!(size_of::<RTCBoundsFunctionArguments>(), 24);
        assert_eq!((size_of::<RTCBounds>(), align_of::<RTCBounds>()), (32, 16));
    }
}
