//! The part of Embree 3's C API that shrad calls, declared by hand: handles, enums, the ray
//! and hit structures (mirroring `rtcore_ray.h` / `rtcore_common.h` of Embree 3.13) and the
//! functions.

use std::ffi::{c_char, c_void};

pub type RTCDevice = *mut c_void;
pub type RTCScene = *mut c_void;
pub type RTCGeometry = *mut c_void;

pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

pub const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
pub const RTC_GEOMETRY_TYPE_INSTANCE: u32 = 121;
pub const RTC_BUFFER_TYPE_INDEX: u32 = 0;
pub const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
pub const RTC_FORMAT_UINT3: u32 = 0x5003;
pub const RTC_FORMAT_FLOAT3: u32 = 0x9003;
pub const RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: u32 = 0x9234;
pub const RTC_BUILD_QUALITY_LOW: u32 = 0;
pub const RTC_BUILD_QUALITY_HIGH: u32 = 2;
pub const RTC_SCENE_FLAG_DYNAMIC: u32 = 1 << 0;
pub const RTC_SCENE_FLAG_ROBUST: u32 = 1 << 2;
pub const RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION: u32 = 1 << 3;
pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;
pub const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: u32 = 1;
pub const RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED: u32 = 64;

/// `RTC_MAX_INSTANCE_LEVEL_COUNT` of the Debian build (rtcore_config.h).
pub const MAX_INST: usize = 1;

#[repr(C)]
pub struct RTCFilterFunctionNArguments {
    pub valid: *mut i32,
    pub geometry_user_ptr: *mut c_void,
    pub context: *const RTCIntersectContext,
    pub ray: *mut c_void,
    pub hit: *mut c_void,
    pub n: u32,
}

pub type RTCFilterFunctionN =
    Option<unsafe extern "C" fn(args: *const RTCFilterFunctionNArguments)>;

/// `RTC_MAX_INSTANCE_LEVEL_COUNT == 1` (no instStackSize), `RTC_MIN_WIDTH == 0`.
#[repr(C)]
pub struct RTCIntersectContext {
    pub flags: u32,
    pub filter: RTCFilterFunctionN,
    pub inst_id: [u32; MAX_INST],
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
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
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub struct RTCHit {
    pub ng_x: f32,
    pub ng_y: f32,
    pub ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub prim_id: u32,
    pub geom_id: u32,
    pub inst_id: [u32; MAX_INST],
}

#[repr(C)]
#[derive(Clone, Copy)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct RTCRay16 {
    pub org_x: [f32; 16],
    pub org_y: [f32; 16],
    pub org_z: [f32; 16],
    pub tnear: [f32; 16],
    pub dir_x: [f32; 16],
    pub dir_y: [f32; 16],
    pub dir_z: [f32; 16],
    pub time: [f32; 16],
    pub tfar: [f32; 16],
    pub mask: [u32; 16],
    pub id: [u32; 16],
    pub flags: [u32; 16],
}

#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct RTCHit16 {
    pub ng_x: [f32; 16],
    pub ng_y: [f32; 16],
    pub ng_z: [f32; 16],
    pub u: [f32; 16],
    pub v: [f32; 16],
    pub prim_id: [u32; 16],
    pub geom_id: [u32; 16],
    pub inst_id: [[u32; 16]; MAX_INST],
}

#[repr(C)]
#[derive(Clone, Copy)]
pub struct RTCRayHit16 {
    pub ray: RTCRay16,
    pub hit: RTCHit16,
}

/// The `valid` mask of the 16-wide calls (-1 active, 0 inactive), 64-byte aligned.
#[repr(C, align(64))]
pub struct Valid16(pub [i32; 16]);

const _: () = {
    assert!(size_of::<RTCRay>() == 48);
    assert!(size_of::<RTCHit>() == 32);
    assert!(size_of::<RTCRayHit>() == 80);
    assert!(size_of::<RTCRay16>() == 768);
    assert!(size_of::<RTCHit16>() == 512);
    assert!(size_of::<RTCRayHit16>() == 1280);
    assert!(align_of::<RTCRayHit16>() == 64);
    assert!(size_of::<RTCIntersectContext>() == 24);
};

#[link(name = "embree3")]
extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceError(device: RTCDevice) -> u32;
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: u32) -> isize;
    pub fn rtcSetGeometryMask(geometry: RTCGeometry, mask: u32);
    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: u32);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: u32);
    pub fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, geom_id: u32);
    pub fn rtcCommitScene(scene: RTCScene);
    pub fn rtcNewGeometry(device: RTCDevice, ty: u32) -> RTCGeometry;
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub fn rtcCommitGeometry(geometry: RTCGeometry);
    pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: u32);
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        ty: u32,
        slot: u32,
        format: u32,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcSetGeometryInstancedScene(geometry: RTCGeometry, scene: RTCScene);
    pub fn rtcSetGeometryTransform(
        geometry: RTCGeometry,
        time_step: u32,
        format: u32,
        xfm: *const c_void,
    );
    pub fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub fn rtcIntersect16(
        valid: *const i32,
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit16,
    );
    pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
    pub fn rtcOccluded16(
        valid: *const i32,
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        ray: *mut RTCRay16,
    );
}
