//! Hand-written bindings to the part of Embree 3's C API (Debian's `libembree-dev` 3.13.5) that
//! raysched uses. Layouts and enum values are copied from `/usr/include/embree3/*.h`
//! (`RTC_MAX_INSTANCE_LEVEL_COUNT` = 1, `RTC_MIN_WIDTH` = 0 in that build) and checked against a C
//! program compiled with those headers; tests assert the sizes and offsets.
//!
//! No bindgen: the API surface is ~20 functions, and a build without the header must still work.

#![allow(
    missing_docs,
    reason = "raw bindings: each item mirrors its namesake in Embree 3's rtcore*.h"
)]
#![allow(non_camel_case_types, clippy::upper_case_acronyms)]

use std::ffi::{c_char, c_int, c_uint, c_void};

pub type RTCDevice = *mut c_void;
pub type RTCScene = *mut c_void;
pub type RTCGeometry = *mut c_void;

/// `RTC_INVALID_GEOMETRY_ID`.
pub const INVALID_ID: c_uint = u32::MAX;

// enum RTCError
pub const RTC_ERROR_NONE: c_int = 0;
// enum RTCGeometryType
pub const RTC_GEOMETRY_TYPE_TRIANGLE: c_int = 0;
pub const RTC_GEOMETRY_TYPE_USER: c_int = 120;
// enum RTCBufferType
pub const RTC_BUFFER_TYPE_INDEX: c_int = 0;
pub const RTC_BUFFER_TYPE_VERTEX: c_int = 1;
// enum RTCFormat
pub const RTC_FORMAT_UINT3: c_int = 0x5003;
pub const RTC_FORMAT_FLOAT3: c_int = 0x9003;
// enum RTCSceneFlags
pub const RTC_SCENE_FLAG_NONE: c_int = 0;
pub const RTC_SCENE_FLAG_ROBUST: c_int = 1 << 2;
// enum RTCIntersectContextFlags
pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_int = 0;

/// `struct RTCRay` (48 bytes, `RTC_ALIGN(16)`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub time: f32,
    pub tfar: f32,
    pub mask: c_uint,
    pub id: c_uint,
    pub flags: c_uint,
}

/// `struct RTCHit` (32 bytes, `RTC_ALIGN(16)`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCHit {
    pub ng_x: f32,
    pub ng_y: f32,
    pub ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub prim_id: c_uint,
    pub geom_id: c_uint,
    pub inst_id: [c_uint; 1],
}

/// `struct RTCRayHit` (80 bytes, the hit at offset 48).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

/// `RTCFilterFunctionN`; raysched installs none.
pub type RTCFilterFunctionN = Option<unsafe extern "C" fn(args: *const c_void)>;

/// `struct RTCIntersectContext` (24 bytes). `rtcInitIntersectContext` is an inline header
/// function, not an exported symbol, so [`RTCIntersectContext::new`] does its work.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RTCIntersectContext {
    pub flags: c_int,
    pub filter: RTCFilterFunctionN,
    pub inst_id: [c_uint; 1],
}

impl RTCIntersectContext {
    /// What `rtcInitIntersectContext` does for `RTC_MAX_INSTANCE_LEVEL_COUNT` = 1.
    pub const fn new() -> Self {
        Self {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: None,
            inst_id: [INVALID_ID],
        }
    }
}

impl Default for RTCIntersectContext {
    fn default() -> Self {
        Self::new()
    }
}

/// `struct RTCBounds` (32 bytes, `RTC_ALIGN(16)`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct RTCBounds {
    pub lower_x: f32,
    pub lower_y: f32,
    pub lower_z: f32,
    pub align0: f32,
    pub upper_x: f32,
    pub upper_y: f32,
    pub upper_z: f32,
    pub align1: f32,
}

/// `struct RTCBoundsFunctionArguments` (24 bytes).
#[repr(C)]
pub struct RTCBoundsFunctionArguments {
    pub geometry_user_ptr: *mut c_void,
    pub prim_id: c_uint,
    pub time_step: c_uint,
    pub bounds_o: *mut RTCBounds,
}

/// `struct RTCIntersectFunctionNArguments` (48 bytes). `rayhit` points to an SOA packet of `n`
/// rays: float field `k` of ray `i` is at `((float*)rayhit)[k*n + i]`, the hit starts at `12*n`.
#[repr(C)]
pub struct RTCIntersectFunctionNArguments {
    pub valid: *mut c_int,
    pub geometry_user_ptr: *mut c_void,
    pub prim_id: c_uint,
    pub context: *mut RTCIntersectContext,
    pub rayhit: *mut c_void,
    pub n: c_uint,
    pub geom_id: c_uint,
}

/// `struct RTCOccludedFunctionNArguments` (48 bytes); `ray` is an SOA packet as above.
#[repr(C)]
pub struct RTCOccludedFunctionNArguments {
    pub valid: *mut c_int,
    pub geometry_user_ptr: *mut c_void,
    pub prim_id: c_uint,
    pub context: *mut RTCIntersectContext,
    pub ray: *mut c_void,
    pub n: c_uint,
    pub geom_id: c_uint,
}

pub type RTCErrorFunction =
    Option<unsafe extern "C" fn(user_ptr: *mut c_void, code: c_int, msg: *const c_char)>;
pub type RTCBoundsFunction = Option<unsafe extern "C" fn(args: *const RTCBoundsFunctionArguments)>;
pub type RTCIntersectFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCIntersectFunctionNArguments)>;
pub type RTCOccludedFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCOccludedFunctionNArguments)>;

#[link(name = "embree3")]
extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceError(device: RTCDevice) -> c_int;
    pub fn rtcSetDeviceErrorFunction(device: RTCDevice, f: RTCErrorFunction, user_ptr: *mut c_void);

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: c_int);
    pub fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, geom_id: c_uint);
    pub fn rtcCommitScene(scene: RTCScene);

    pub fn rtcNewGeometry(device: RTCDevice, kind: c_int) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcCommitGeometry(geometry: RTCGeometry);
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcSetGeometryUserPrimitiveCount(geometry: RTCGeometry, count: c_uint);
    pub fn rtcSetGeometryUserData(geometry: RTCGeometry, ptr: *mut c_void);
    pub fn rtcSetGeometryBoundsFunction(
        geometry: RTCGeometry,
        f: RTCBoundsFunction,
        user_ptr: *mut c_void,
    );
    pub fn rtcSetGeometryIntersectFunction(geometry: RTCGeometry, f: RTCIntersectFunctionN);
    pub fn rtcSetGeometryOccludedFunction(geometry: RTCGeometry, f: RTCOccludedFunctionN);

    pub fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{align_of, offset_of, size_of};

    /// The numbers printed by a C program compiled against /usr/include/embree3 (3.13.5).
    #[test]
    fn layouts_match_the_c_headers() {
        assert_eq!((size_of::<RTCRay>(), align_of::<RTCRay>()), (48, 16));
        assert_eq!((size_of::<RTCHit>(), align_of::<RTCHit>()), (32, 16));
        assert_eq!(size_of::<RTCRayHit>(), 80);
        assert_eq!(offset_of!(RTCRayHit, hit), 48);
        assert_eq!(offset_of!(RTCRay, tfar), 32);
        assert_eq!(offset_of!(RTCHit, prim_id), 20);
        assert_eq!(offset_of!(RTCHit, inst_id), 28);
        assert_eq!(size_of::<RTCIntersectContext>(), 24);
        assert_eq!(offset_of!(RTCIntersectContext, filter), 8);
        assert_eq!(offset_of!(RTCIntersectContext, inst_id), 16);
        assert_eq!((size_of::<RTCBounds>(), align_of::<RTCBounds>()), (32, 16));
        assert_eq!(size_of::<RTCBoundsFunctionArguments>(), 24);
        assert_eq!(offset_of!(RTCBoundsFunctionArguments, bounds_o), 16);
        assert_eq!(size_of::<RTCIntersectFunctionNArguments>(), 48);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, context), 24);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, rayhit), 32);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, n), 40);
        assert_eq!(offset_of!(RTCIntersectFunctionNArguments, geom_id), 44);
        assert_eq!(size_of::<RTCOccludedFunctionNArguments>(), 48);
        assert_eq!(offset_of!(RTCOccludedFunctionNArguments, ray), 32);
    }
}
