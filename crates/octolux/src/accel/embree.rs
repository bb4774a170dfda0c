//! Embree 3 backend, loaded at run time with `libloading` so that octolux builds and runs on
//! machines without Embree.
//!
//! The shared library is looked up once per process: the path in `OCTOLUX_EMBREE_LIB` if that
//! is set (and only it), else `libembree3.so.3`, then `libembree3.so` (macOS:
//! `libembree3.dylib`, Windows: `embree3.dll`). The library is never unloaded (it lives in a
//! process-wide `OnceLock`).
//!
//! All triangles go into one `RTC_GEOMETRY_TYPE_TRIANGLE` geometry, so Embree's `primID` is the
//! global triangle index and its `(u, v)` follow the octolux convention
//! `p = (1-u-v) p0 + u p1 + v p2`. Vertex and index data are copied into buffers created with
//! `rtcSetNewGeometryBuffer`, which Embree over-allocates so that the 16-byte SSE load of the
//! last `float3` vertex is safe. The scene uses `RTC_SCENE_FLAG_ROBUST` (watertight traversal
//! and Plücker triangle tests: rays through shared edges cannot leak through a closed mesh) and
//! `RTC_BUILD_QUALITY_HIGH` (SAH with spatial splits: slower build, faster traversal).
//!
//! The C structs below replicate `rtcore_ray.h`/`rtcore_common.h` of Embree 3.13 built with the
//! default `RTC_MAX_INSTANCE_LEVEL_COUNT = 1` and `RTC_MIN_WIDTH = 0` (what every distribution
//! ships): `RTCRayHit` is 80 bytes aligned to 16, `RTCIntersectContext` is 24 bytes. The inline
//! `rtcInitIntersectContext` is replicated by `IntersectContext::new`.
//!
//! Thread safety: Embree documents `rtcIntersect1`/`rtcOccluded1` as safe to call concurrently
//! on a committed scene; the scene is never modified after [`EmbreeAccel::build`], hence the
//! `Send`/`Sync` impls. Device and scene are released on `Drop`.

use super::{AccelError, TriHit};
use crate::math::Ray;
use glam::Vec3;
use libloading::Library;
use std::ffi::{c_char, c_uint, c_void, CString};
use std::ptr;
use std::sync::OnceLock;

type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
const RTC_DEVICE_PROPERTY_VERSION: c_uint = 0;
const RTC_GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
const RTC_BUFFER_TYPE_INDEX: c_uint = 0;
const RTC_BUFFER_TYPE_VERTEX: c_uint = 1;
const RTC_FORMAT_UINT3: c_uint = 0x5003;
const RTC_FORMAT_FLOAT3: c_uint = 0x9003;
const RTC_SCENE_FLAG_ROBUST: c_uint = 1 << 2;
const RTC_BUILD_QUALITY_HIGH: c_uint = 2;
const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_uint = 0;

/// `struct RTCRay` (48 bytes, aligned to 16).
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcRay {
    org_x: f32,
    org_y: f32,
    org_z: f32,
    tnear: f32,
    dir_x: f32,
    dir_y: f32,
    dir_z: f32,
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

/// `struct RTCHit` with `RTC_MAX_INSTANCE_LEVEL_COUNT = 1` (32 bytes, aligned to 16).
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcHit {
    ng_x: f32,
    ng_y: f32,
    ng_z: f32,
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 1],
}

/// `struct RTCRayHit` (80 bytes).
#[repr(C)]
#[derive(Clone, Copy)]
struct RtcRayHit {
    ray: RtcRay,
    hit: RtcHit,
}

/// `struct RTCIntersectContext` with one instance level and no min-width (24 bytes).
#[repr(C)]
struct IntersectContext {
    flags: c_uint,
    filter: *const c_void,
    inst_id: [u32; 1],
}

const _: () = assert!(std::mem::size_of::<RtcRay>() == 48 && std::mem::align_of::<RtcRay>() == 16);
const _: () = assert!(std::mem::size_of::<RtcHit>() == 32);
const _: () = assert!(std::mem::size_of::<RtcRayHit>() == 80 && std::mem::align_of::<RtcRayHit>() == 16);
const _: () = assert!(std::mem::size_of::<IntersectContext>() == 24);

impl IntersectContext {
    /// Replica of the inline `rtcInitIntersectContext`.
    #[inline(always)]
    fn new() -> Self {
        IntersectContext { flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, filter: ptr::null(), inst_id: [RTC_INVALID_GEOMETRY_ID] }
    }
}

impl RtcRay {
    #[inline(always)]
    fn from_ray(r: &Ray) -> Self {
        RtcRay {
            org_x: r.o.x,
            org_y: r.o.y,
            org_z: r.o.z,
            tnear: r.tmin,
            dir_x: r.d.x,
            dir_y: r.d.y,
            dir_z: r.d.z,
            time: 0.0,
            tfar: r.tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

/// Function table of the loaded library (plain `extern "C"` pointers copied out of the
/// `Library`, which stays loaded for the life of the process).
struct Api {
    new_device: unsafe extern "C" fn(*const c_char) -> RtcDevice,
    release_device: unsafe extern "C" fn(RtcDevice),
    get_device_error: unsafe extern "C" fn(RtcDevice) -> c_uint,
    get_device_property: unsafe extern "C" fn(RtcDevice, c_uint) -> isize,
    new_scene: unsafe extern "C" fn(RtcDevice) -> RtcScene,
    release_scene: unsafe extern "C" fn(RtcScene),
    set_scene_flags: unsafe extern "C" fn(RtcScene, c_uint),
    set_scene_build_quality: unsafe extern "C" fn(RtcScene, c_uint),
    commit_scene: unsafe extern "C" fn(RtcScene),
    new_geometry: unsafe extern "C" fn(RtcDevice, c_uint) -> RtcGeometry,
    release_geometry: unsafe extern "C" fn(RtcGeometry),
    commit_geometry: unsafe extern "C" fn(RtcGeometry),
    set_new_geometry_buffer: unsafe extern "C" fn(RtcGeometry, c_uint, c_uint, c_uint, usize, usize) -> *mut c_void,
    set_geometry_build_quality: unsafe extern "C" fn(RtcGeometry, c_uint),
    attach_geometry: unsafe extern "C" fn(RtcScene, RtcGeometry) -> c_uint,
    intersect1: unsafe extern "C" fn(RtcScene, *mut IntersectContext, *mut RtcRayHit),
    occluded1: unsafe extern "C" fn(RtcScene, *mut IntersectContext, *mut RtcRay),
    _lib: Library,
}

/// Candidate library names, in the order they are tried. A non-empty `OCTOLUX_EMBREE_LIB` is
/// the only candidate (an explicit choice; a wrong path makes Embree unavailable).
fn candidate_paths() -> Vec<String> {
    let mut v = Vec::new();
    if let Some(p) = std::env::var_os("OCTOLUX_EMBREE_LIB").filter(|p| !p.is_empty()) {
        v.push(p.to_string_lossy().into_owned());
        return v;
    }
    if cfg!(target_os = "macos") {
        v.extend(["libembree3.dylib".to_string(), "libembree3.3.dylib".to_string()]);
    } else if cfg!(windows) {
        v.push("embree3.dll".to_string());
    } else {
        v.extend(["libembree3.so.3".to_string(), "libembree3.so".to_string()]);
    }
    v
}

impl Api {
    fn load() -> Result<Api, String> {
        let mut errors = Vec::new();
        for path in candidate_paths() {
            // SAFETY: loading Embree runs its (well-behaved) library initialisers only.
            match unsafe { Library::new(&path) } {
                Ok(lib) => return Api::from_library(lib).map_err(|e| format!("{path}: {e}")),
                Err(e) => errors.push(format!("{path}: {e}")),
            }
        }
        Err(errors.join("; "))
    }

    fn from_library(lib: Library) -> Result<Api, libloading::Error> {
        // SAFETY: the symbol types match the prototypes in rtcore_*.h of Embree 3.
        unsafe {
            macro_rules! sym {
                ($name:literal) => {
                    *lib.get($name)?
                };
            }
            Ok(Api {
                new_device: sym!(b"rtcNewDevice\0"),
                release_device: sym!(b"rtcReleaseDevice\0"),
                get_device_error: sym!(b"rtcGetDeviceError\0"),
                get_device_property: sym!(b"rtcGetDeviceProperty\0"),
                new_scene: sym!(b"rtcNewScene\0"),
                release_scene: sym!(b"rtcReleaseScene\0"),
                set_scene_flags: sym!(b"rtcSetSceneFlags\0"),
                set_scene_build_quality: sym!(b"rtcSetSceneBuildQuality\0"),
                commit_scene: sym!(b"rtcCommitScene\0"),
                new_geometry: sym!(b"rtcNewGeometry\0"),
                release_geometry: sym!(b"rtcReleaseGeometry\0"),
                commit_geometry: sym!(b"rtcCommitGeometry\0"),
                set_new_geometry_buffer: sym!(b"rtcSetNewGeometryBuffer\0"),
                set_geometry_build_quality: sym!(b"rtcSetGeometryBuildQuality\0"),
                attach_geometry: sym!(b"rtcAttachGeometry\0"),
                intersect1: sym!(b"rtcIntersect1\0"),
                occluded1: sym!(b"rtcOccluded1\0"),
                _lib: lib,
            })
        }
    }
}

static API: OnceLock<Result<Api, String>> = OnceLock::new();

fn api() -> Result<&'static Api, AccelError> {
    API.get_or_init(Api::load).as_ref().map_err(|e| AccelError::EmbreeUnavailable(e.clone()))
}

/// Whether the Embree library can be loaded on this machine.
pub fn available() -> bool {
    api().is_ok()
}

fn error_name(code: c_uint) -> &'static str {
    match code {
        0 => "RTC_ERROR_NONE",
        1 => "RTC_ERROR_UNKNOWN",
        2 => "RTC_ERROR_INVALID_ARGUMENT",
        3 => "RTC_ERROR_INVALID_OPERATION",
        4 => "RTC_ERROR_OUT_OF_MEMORY",
        5 => "RTC_ERROR_UNSUPPORTED_CPU",
        6 => "RTC_ERROR_CANCELLED",
        _ => "unknown Embree error code",
    }
}

/// A committed Embree scene holding one triangle geometry.
pub struct EmbreeAccel {
    api: &'static Api,
    device: RtcDevice,
    scene: RtcScene,
    version: String,
}

// SAFETY: the scene is immutable after commit, and Embree documents concurrent
// rtcIntersect1/rtcOccluded1 calls on a committed scene as thread-safe. Release happens once,
// in Drop, with exclusive access.
unsafe impl Send for EmbreeAccel {}
unsafe impl Sync for EmbreeAccel {}

impl EmbreeAccel {
    /// Build an Embree scene. Indices must already be validated (`< vertices.len()`).
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<EmbreeAccel, AccelError> {
        let api = api()?;
        let config = CString::new("").map_err(|e| AccelError::Embree(e.to_string()))?;
        // SAFETY: plain FFI calls following the Embree 3 API contract; every handle is checked
        // before use and released on all paths (the partially built value's Drop runs on error).
        unsafe {
            let device = (api.new_device)(config.as_ptr());
            if device.is_null() {
                return Err(AccelError::Embree("rtcNewDevice failed (unsupported CPU?)".into()));
            }
            let mut acc = EmbreeAccel { api, device, scene: ptr::null_mut(), version: String::new() };
            acc.check("rtcNewDevice")?;
            let v = (api.get_device_property)(device, RTC_DEVICE_PROPERTY_VERSION);
            acc.version = format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100);

            acc.scene = (api.new_scene)(device);
            if acc.scene.is_null() {
                acc.check("rtcNewScene")?;
                return Err(AccelError::Embree("rtcNewScene returned null".into()));
            }
            (api.set_scene_flags)(acc.scene, RTC_SCENE_FLAG_ROBUST);
            (api.set_scene_build_quality)(acc.scene, RTC_BUILD_QUALITY_HIGH);
            acc.check("scene setup")?;

            if !triangles.is_empty() {
                let geom = (api.new_geometry)(device, RTC_GEOMETRY_TYPE_TRIANGLE);
                if geom.is_null() {
                    acc.check("rtcNewGeometry")?;
                    return Err(AccelError::Embree("rtcNewGeometry returned null".into()));
                }
                let res = acc.fill_geometry(geom, vertices, triangles);
                // The scene holds its own reference once attached; drop ours in all cases.
                (api.release_geometry)(geom);
                res?;
            }
            (api.commit_scene)(acc.scene);
            acc.check("rtcCommitScene")?;
            Ok(acc)
        }
    }

    /// Copy the mesh into Embree buffers, commit the geometry and attach it to the scene.
    unsafe fn fill_geometry(&self, geom: RtcGeometry, vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), AccelError> {
        let api = self.api;
        (api.set_geometry_build_quality)(geom, RTC_BUILD_QUALITY_HIGH);
        let vb = (api.set_new_geometry_buffer)(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, vertices.len()) as *mut f32;
        self.check("vertex buffer")?;
        let ib = (api.set_new_geometry_buffer)(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, triangles.len()) as *mut u32;
        self.check("index buffer")?;
        if vb.is_null() || ib.is_null() {
            return Err(AccelError::Embree("rtcSetNewGeometryBuffer returned null".into()));
        }
        // SAFETY: Embree allocated `len * 12` bytes (plus padding) for each buffer.
        let vs = std::slice::from_raw_parts_mut(vb, vertices.len() * 3);
        for (dst, p) in vs.chunks_exact_mut(3).zip(vertices) {
            dst.copy_from_slice(&p.to_array());
        }
        let is = std::slice::from_raw_parts_mut(ib, triangles.len() * 3);
        for (dst, t) in is.chunks_exact_mut(3).zip(triangles) {
            dst.copy_from_slice(t);
        }
        (api.commit_geometry)(geom);
        self.check("rtcCommitGeometry")?;
        let id = (api.attach_geometry)(self.scene, geom);
        self.check("rtcAttachGeometry")?;
        if id != 0 {
            return Err(AccelError::Embree(format!("expected geometry id 0, got {id}")));
        }
        Ok(())
    }

    fn check(&self, what: &str) -> Result<(), AccelError> {
        // SAFETY: `device` is a live device handle.
        let code = unsafe { (self.api.get_device_error)(self.device) };
        if code == 0 {
            Ok(())
        } else {
            Err(AccelError::Embree(format!("{what}: {} ({code})", error_name(code))))
        }
    }

    pub fn name(&self) -> String {
        format!("embree {}", self.version)
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<TriHit> {
        // Embree's behaviour on invalid rays depends on its build options; answer them here.
        if !(ray.tmin <= ray.tmax) {
            return None;
        }
        let mut rh = RtcRayHit {
            ray: RtcRay::from_ray(ray),
            hit: RtcHit {
                ng_x: 0.0,
                ng_y: 0.0,
                ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                prim_id: 0,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        let mut ctx = IntersectContext::new();
        // SAFETY: committed scene, properly laid out and aligned structs.
        unsafe { (self.api.intersect1)(self.scene, &mut ctx, &mut rh) };
        if rh.hit.geom_id == RTC_INVALID_GEOMETRY_ID {
            None
        } else {
            Some(TriHit { t: rh.ray.tfar, prim: rh.hit.prim_id, u: rh.hit.u, v: rh.hit.v })
        }
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !(ray.tmin <= ray.tmax) {
            return false;
        }
        let mut r = RtcRay::from_ray(ray);
        let mut ctx = IntersectContext::new();
        // SAFETY: as in `intersect`.
        unsafe { (self.api.occluded1)(self.scene, &mut ctx, &mut r) };
        // Embree sets tfar to -inf when an occluder is found.
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeAccel {
    fn drop(&mut self) {
        // SAFETY: handles were created by this value and are released exactly once.
        unsafe {
            if !self.scene.is_null() {
                (self.api.release_scene)(self.scene);
            }
            if !self.device.is_null() {
                (self.api.release_device)(self.device);
            }
        }
    }
}
