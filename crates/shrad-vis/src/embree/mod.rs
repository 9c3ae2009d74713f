//! Embree 3 backend over a hand-written FFI to the system `libembree3` (only what is used).
//!
//! `unsafe` is allowed in this module only: calling a C library and handing it raw buffers
//! cannot be done without it. Every call's preconditions are local: the handles are owned by
//! [`EmbreeVis`] and released in its `Drop`; ray structures mirror the C layouts of
//! `rtcore_ray.h` / `rtcore_common.h` of Embree 3.13 (checked by the size asserts in `ffi`).
//!
//! Layout: one scene per object (one triangle geometry, built once with high quality) and
//! a top scene of instances (instance geomID = object index, `RTC_SCENE_FLAG_DYNAMIC`).
//! Moving an object updates the instance transform; commit rebuilds the small top level.
//! Excluded objects are dropped by instance ray masks where that is exact: each instance has
//! one mask bit, and a ray that excludes some objects clears their bits, so Embree skips
//! those instances at the top level without entering them. That is exact when no other
//! object shares a cleared bit: always up to 32 objects; beyond, the objects flagged
//! `often_excluded` get the first 31 bits of their own and the rest share the last one.
//! Otherwise, or when the library was built without ray masks, a context filter function
//! rejects hits whose `instID` is in the exclude list. The mask halves the cost of a probe capture taken
//! right next to its own (excluded) object: the filter path pays for every candidate hit
//! on the object before rejecting it.
//!
//! Files: `ffi` (the C declarations), `context` (ray masks and the exclude filter), here
//! (the handles, building, moving and the queries).
#![allow(unsafe_code)]

use std::ffi::c_void;
use std::ptr;

use glam::{Affine3A, Vec3};

use crate::{par_fill, segment, tri_infos, Hit, MeshRef, TriInfo, VisError, Visibility, Xform};

mod context;
mod ffi;

use context::{ExcludeContext, MaskBits};
use ffi::*;

/// Owned Embree handles. Embree scenes are thread-safe for queries after commit; all
/// mutation goes through `&mut EmbreeVis`.
struct Handles {
    device: RTCDevice,
    top: RTCScene,
    blas: Vec<RTCScene>,
    instances: Vec<RTCGeometry>,
}

// SAFETY: the handles are reference-counted Embree objects usable from any thread; queries
// (`rtcIntersect*`, `rtcOccluded*`) on a committed scene may run concurrently, and commits
// only happen through `&mut self`.
unsafe impl Send for Handles {}
// SAFETY: see above.
unsafe impl Sync for Handles {}

impl Drop for Handles {
    fn drop(&mut self) {
        // SAFETY: each handle was created by us and is released exactly once.
        unsafe {
            for &g in &self.instances {
                rtcReleaseGeometry(g);
            }
            if !self.top.is_null() {
                rtcReleaseScene(self.top);
            }
            for &s in &self.blas {
                rtcReleaseScene(s);
            }
            if !self.device.is_null() {
                rtcReleaseDevice(self.device);
            }
        }
    }
}

/// The Embree visibility structure.
pub(crate) struct EmbreeVis {
    h: Handles,
    infos: Vec<Vec<TriInfo>>,
    xforms: Vec<Xform>,
    dirty: bool,
    /// The instances' mask bits, when the library tests ray masks (`EMBREE_RAY_MASK`).
    masks: Option<MaskBits>,
}

/// Embree's RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: the three axes, then the translation.
fn xfm(m: &Affine3A) -> [f32; 12] {
    m.to_cols_array()
}

fn error(device: RTCDevice, what: &str) -> Result<(), VisError> {
    // SAFETY: device is a valid device handle.
    let e = unsafe { rtcGetDeviceError(device) };
    if e == 0 {
        Ok(())
    } else {
        Err(VisError::Invalid(format!("Embree error {e} in {what}")))
    }
}

/// Fill the object scene `scene` with the triangles of `m` (object `o`, for messages) and
/// commit it.
///
/// # Safety
/// `device` and `scene` are live Embree handles; the geometry buffers Embree returns are
/// sized for the item counts given and written within them.
unsafe fn build_object(
    device: RTCDevice,
    scene: RTCScene,
    m: &MeshRef<'_>,
    o: usize,
) -> Result<(), VisError> {
    // ROBUST: watertight triangle tests (no rays slipping between neighbours).
    // (Measured: no throughput cost here; without it a closed room leaks ~0.5%.)
    // CONTEXT_FILTER_FUNCTION: lets the exclude filter run on this scene's hits.
    rtcSetSceneFlags(
        scene,
        RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION,
    );
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    if !m.triangles.is_empty() {
        let g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
        let vb = rtcSetNewGeometryBuffer(
            g,
            RTC_BUFFER_TYPE_VERTEX,
            0,
            RTC_FORMAT_FLOAT3,
            12,
            m.positions.len(),
        ) as *mut [f32; 3];
        let ib = rtcSetNewGeometryBuffer(
            g,
            RTC_BUFFER_TYPE_INDEX,
            0,
            RTC_FORMAT_UINT3,
            12,
            m.triangles.len(),
        ) as *mut [u32; 3];
        if vb.is_null() || ib.is_null() {
            rtcReleaseGeometry(g);
            error(device, "buffer allocation")?;
            return Err(VisError::Invalid(format!(
                "Embree could not allocate buffers for object {o}"
            )));
        }
        for (i, p) in m.positions.iter().enumerate() {
            vb.add(i).write(p.to_array());
        }
        for (i, t) in m.triangles.iter().enumerate() {
            ib.add(i).write(*t);
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(scene, g, 0);
        rtcReleaseGeometry(g); // the scene holds it
    }
    rtcCommitScene(scene);
    error(device, "object build")
}

/// An instance of the object scene `scene` at `transform` with ray mask `mask`, attached
/// to `top` as geometry `o`; the caller keeps it to release.
///
/// # Safety
/// `device`, `top` and `scene` are live Embree handles.
unsafe fn instance(
    device: RTCDevice,
    top: RTCScene,
    scene: RTCScene,
    transform: &Affine3A,
    mask: u32,
    o: usize,
) -> RTCGeometry {
    let inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(inst, scene);
    let x = xfm(transform);
    rtcSetGeometryTransform(
        inst,
        0,
        RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
        x.as_ptr() as *const c_void,
    );
    rtcSetGeometryMask(inst, mask);
    rtcCommitGeometry(inst);
    rtcAttachGeometryByID(top, inst, o as u32);
    inst
}

impl EmbreeVis {
    pub(crate) fn new(
        meshes: &[MeshRef<'_>],
        transforms: &[Affine3A],
    ) -> Result<EmbreeVis, VisError> {
        // SAFETY: plain FFI calls with valid handles; buffers returned by
        // rtcSetNewGeometryBuffer are Embree-owned, sized for `item_count` items of
        // `byte_stride` bytes (plus Embree's padding), and written within those bounds.
        unsafe {
            let device = rtcNewDevice(ptr::null());
            if device.is_null() {
                return Err(VisError::Unavailable(
                    "Embree device creation failed (unsupported CPU?)",
                ));
            }
            let mut h = Handles {
                device,
                top: ptr::null_mut(),
                blas: Vec::new(),
                instances: Vec::new(),
            };
            let bits = MaskBits::new(&meshes.iter().map(|m| m.often_excluded).collect::<Vec<_>>());
            let top = rtcNewScene(device);
            h.top = top;
            rtcSetSceneFlags(
                top,
                RTC_SCENE_FLAG_DYNAMIC | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION,
            );
            rtcSetSceneBuildQuality(top, RTC_BUILD_QUALITY_LOW);
            for (o, m) in meshes.iter().enumerate() {
                let scene = rtcNewScene(device);
                h.blas.push(scene);
                build_object(device, scene, m, o)?;
                h.instances.push(instance(
                    device,
                    top,
                    scene,
                    &transforms[o],
                    bits.mask(o),
                    o,
                ));
            }
            rtcCommitScene(top);
            error(device, "top-level build")?;
            Ok(EmbreeVis {
                h,
                infos: meshes.iter().map(tri_infos).collect(),
                xforms: transforms.iter().map(|&m| Xform::new(m)).collect(),
                dirty: false,
                masks: (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED) != 0)
                    .then_some(bits),
            })
        }
    }

    fn context(&self, flags: u32, exclude: &[u32]) -> ExcludeContext {
        ExcludeContext::new(flags, exclude, self.masks.as_ref())
    }

    /// Shadow rays with the context `make` gives (one per chunk of rays).
    fn occluded_with(
        &self,
        from: &[Vec3],
        to: &[Vec3],
        eps: f32,
        out: &mut [bool],
        make: impl Fn() -> ExcludeContext + Sync,
    ) {
        assert_eq!(from.len(), to.len());
        assert_eq!(from.len(), out.len());
        par_fill(out, |base, chunk| {
            let mut ctx = make();
            if packets() {
                for (p, out) in chunk.chunks_mut(16).enumerate() {
                    let at = base + p * 16;
                    self.occluded16(&mut ctx, eps, out, |k| (from[at + k], to[at + k]));
                }
                return;
            }
            for (k, b) in chunk.iter_mut().enumerate() {
                let (f, t) = (from[base + k], to[base + k]);
                let Some((d, len)) = segment(f, t, eps) else {
                    *b = false;
                    continue;
                };
                let mut ray = RTCRay {
                    org_x: f.x,
                    org_y: f.y,
                    org_z: f.z,
                    tnear: eps,
                    dir_x: d.x,
                    dir_y: d.y,
                    dir_z: d.z,
                    time: 0.0,
                    tfar: len - eps,
                    mask: ctx.ray_mask,
                    id: 0,
                    flags: 0,
                };
                // SAFETY: committed scene, valid context and ray of the C layout.
                unsafe { rtcOccluded1(self.h.top, ctx.as_ptr(), &mut ray) };
                // Embree sets tfar to -inf when the segment is blocked.
                *b = ray.tfar == f32::NEG_INFINITY;
            }
        });
    }

    #[inline]
    fn hit(&self, geom_id: u32, inst_id: u32, prim_id: u32, t: f32, dir: Vec3) -> Hit {
        if geom_id == RTC_INVALID_GEOMETRY_ID || inst_id == RTC_INVALID_GEOMETRY_ID {
            return Hit::MISS;
        }
        let info = self.infos[inst_id as usize][prim_id as usize];
        Hit {
            id: info.id,
            object: inst_id,
            t,
            front: self.xforms[inst_id as usize].front(info.n, dir),
        }
    }

    fn closest1(
        &self,
        ctx: &mut ExcludeContext,
        o: Vec3,
        d: Vec3,
        (t_min, t_max): (f32, f32),
    ) -> Hit {
        if !(o.is_finite() && d.is_finite()) {
            return Hit::MISS;
        }
        let mut rh = RTCRayHit {
            ray: RTCRay {
                org_x: o.x,
                org_y: o.y,
                org_z: o.z,
                tnear: t_min,
                dir_x: d.x,
                dir_y: d.y,
                dir_z: d.z,
                time: 0.0,
                tfar: t_max,
                mask: ctx.ray_mask,
                id: 0,
                flags: 0,
            },
            hit: RTCHit {
                ng_x: 0.0,
                ng_y: 0.0,
                ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID; MAX_INST],
            },
        };
        // SAFETY: committed scene, valid context and ray/hit of the C layout.
        unsafe { rtcIntersect1(self.h.top, ctx.as_ptr(), &mut rh) };
        self.hit(
            rh.hit.geom_id,
            rh.hit.inst_id[0],
            rh.hit.prim_id,
            rh.ray.tfar,
            d,
        )
    }

    /// Up to 16 shadow rays as one packet (`rtcOccluded16`); `out.len() <= 16`, segment `k`
    /// from `seg(k)`; a segment shorter than `2 eps` is free.
    fn occluded16(
        &self,
        ctx: &mut ExcludeContext,
        eps: f32,
        out: &mut [bool],
        seg: impl Fn(usize) -> (Vec3, Vec3),
    ) {
        debug_assert!(out.len() <= 16);
        let mut valid = Valid16([0; 16]);
        // SAFETY: all-zero is a valid bit pattern for this plain-number struct.
        let mut r: RTCRay16 = unsafe { std::mem::zeroed() };
        for k in 0..out.len() {
            let (f, t) = seg(k);
            let Some((d, len)) = segment(f, t, eps) else {
                continue;
            };
            valid.0[k] = -1;
            r.org_x[k] = f.x;
            r.org_y[k] = f.y;
            r.org_z[k] = f.z;
            r.tnear[k] = eps;
            r.dir_x[k] = d.x;
            r.dir_y[k] = d.y;
            r.dir_z[k] = d.z;
            r.tfar[k] = len - eps;
            r.mask[k] = ctx.ray_mask;
        }
        // SAFETY: committed scene, valid context, 64-byte aligned mask and packet.
        unsafe { rtcOccluded16(valid.0.as_ptr(), self.h.top, ctx.as_ptr(), &mut r) };
        for (k, b) in out.iter_mut().enumerate() {
            // Embree sets tfar to -inf where the segment is blocked.
            *b = valid.0[k] != 0 && r.tfar[k] == f32::NEG_INFINITY;
        }
    }

    /// Up to 16 rays as one packet; `out.len() <= 16`, ray `k` from `ray(k)`, each from
    /// `t_min` to `t_max`.
    fn closest16(
        &self,
        ctx: &mut ExcludeContext,
        (t_min, t_max): (f32, f32),
        out: &mut [Hit],
        ray: impl Fn(usize) -> (Vec3, Vec3),
    ) {
        debug_assert!(out.len() <= 16);
        let mut valid = Valid16([0; 16]);
        // SAFETY: all-zero is a valid bit pattern for these plain-number structs.
        let mut rh: RTCRayHit16 = unsafe { std::mem::zeroed() };
        let mut dirs = [Vec3::ZERO; 16];
        for k in 0..out.len() {
            let (o, d) = ray(k);
            dirs[k] = d;
            rh.hit.geom_id[k] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.inst_id[0][k] = RTC_INVALID_GEOMETRY_ID;
            if !(o.is_finite() && d.is_finite()) {
                continue;
            }
            valid.0[k] = -1;
            let r = &mut rh.ray;
            r.org_x[k] = o.x;
            r.org_y[k] = o.y;
            r.org_z[k] = o.z;
            r.tnear[k] = t_min;
            r.dir_x[k] = d.x;
            r.dir_y[k] = d.y;
            r.dir_z[k] = d.z;
            r.tfar[k] = t_max;
            r.mask[k] = ctx.ray_mask;
        }
        // SAFETY: committed scene, valid context, 64-byte aligned mask and packet.
        unsafe { rtcIntersect16(valid.0.as_ptr(), self.h.top, ctx.as_ptr(), &mut rh) };
        for (k, h) in out.iter_mut().enumerate() {
            *h = self.hit(
                rh.hit.geom_id[k],
                rh.hit.inst_id[0][k],
                rh.hit.prim_id[k],
                rh.ray.tfar[k],
                dirs[k],
            );
        }
    }
}

impl Visibility for EmbreeVis {
    fn name(&self) -> &'static str {
        "embree"
    }

    fn object_count(&self) -> usize {
        self.xforms.len()
    }

    fn set_transform(&mut self, object: usize, world_from_object: Affine3A) {
        self.xforms[object] = Xform::new(world_from_object);
        let x = xfm(&world_from_object);
        // SAFETY: valid instance handle; Embree copies the 12 floats.
        unsafe {
            let g = self.h.instances[object];
            rtcSetGeometryTransform(
                g,
                0,
                RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                x.as_ptr() as *const c_void,
            );
            rtcCommitGeometry(g);
        }
        self.dirty = true;
    }

    fn commit(&mut self) {
        if self.dirty {
            // SAFETY: valid scene; no queries run concurrently (we hold `&mut self`).
            unsafe { rtcCommitScene(self.h.top) };
            self.dirty = false;
        }
    }

    fn closest(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        self.closest_within(origins, directions, (t_min, f32::INFINITY), exclude, out)
    }

    fn closest_within(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        t: (f32, f32),
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        assert_eq!(origins.len(), directions.len());
        assert_eq!(origins.len(), out.len());
        par_fill(out, |base, chunk| {
            let mut ctx = self.context(RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, exclude);
            if packets() {
                for (p, out) in chunk.chunks_mut(16).enumerate() {
                    let at = base + p * 16;
                    self.closest16(&mut ctx, t, out, |k| (origins[at + k], directions[at + k]));
                }
                return;
            }
            for (k, h) in chunk.iter_mut().enumerate() {
                *h = self.closest1(&mut ctx, origins[base + k], directions[base + k], t);
            }
        });
    }

    fn capture(
        &self,
        points: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        let nd = directions.len();
        assert_eq!(out.len(), points.len() * nd);
        if nd == 0 {
            return;
        }
        par_fill(out, |base, chunk| {
            let mut ctx = self.context(RTC_INTERSECT_CONTEXT_FLAG_COHERENT, exclude);
            for (p, packet) in chunk.chunks_mut(16).enumerate() {
                let first = base + p * 16;
                self.closest16(&mut ctx, (t_min, f32::INFINITY), packet, |k| {
                    let i = first + k;
                    (points[i / nd], directions[i % nd])
                });
            }
        });
    }

    fn occluded(&self, from: &[Vec3], to: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]) {
        self.occluded_with(from, to, eps, out, || {
            self.context(RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, exclude)
        });
    }

    fn occluded_among(
        &self,
        from: &[Vec3],
        to: &[Vec3],
        eps: f32,
        among: &[u32],
        out: &mut [bool],
    ) {
        // Only the instances whose mask bits are in the ray's are entered at all.
        match self.masks.as_ref().and_then(|b| b.only(among)) {
            Some(mask) => self.occluded_with(from, to, eps, out, || {
                ExcludeContext::masked(RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, mask)
            }),
            None => {
                let others: Vec<u32> = (0..self.object_count() as u32)
                    .filter(|o| !among.contains(o))
                    .collect();
                self.occluded(from, to, eps, &others, out)
            }
        }
    }
}

/// Whether shadow and closest-hit rays go as 16-wide packets (`SHRAD_PACKETS=0` turns them
/// off: single rays, for comparison).
fn packets() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var("SHRAD_PACKETS").map_or(true, |v| v != "0"))
}
