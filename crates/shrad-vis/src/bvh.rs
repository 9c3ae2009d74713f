//! Pure-Rust backend: one compressed wide BVH (obvhs CWBVH) per object in its own frame, and
//! a top-level CWBVH over the instances' world boxes, rebuilt at [`Visibility::commit`]
//! (cheap: one box per object). Rays are taken into each instance's frame with the inverse
//! transform, without renormalising the direction, so `t` is the same in both frames.

use std::time::Duration;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    cwbvh::{builder::build_cwbvh, CwBvh},
    ray::{Ray, RayHit},
    triangle::Triangle,
    BvhBuildParams,
};
use rayon::prelude::*;

use crate::{par_fill, segment, tri_infos, Hit, MeshRef, TriInfo, Visibility, Xform};

/// A triangle's vertices, exactly as given (watertightness needs shared vertices to be
/// bit-identical, so no edge vectors).
#[derive(Clone, Copy, Debug)]
struct RtTri {
    v: [Vec3A; 3],
}

/// Per-ray set-up of the watertight test (Woop, Benthin, Wald 2013): the ray's dominant axis
/// `kz`, the other two `kx`, `ky` (swapped to keep the winding), and the shear.
struct WRay {
    org: Vec3A,
    k: [usize; 3],
    s: [f32; 3],
}

impl WRay {
    #[inline(always)]
    fn new(ray: &Ray) -> WRay {
        let d = ray.direction;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WRay {
            org: ray.origin,
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        }
    }

    /// Watertight ray/triangle distance, both faces; `t` in `[tmin, tmax]` or infinity.
    #[inline(always)]
    fn intersect(&self, tri: &RtTri, tmin: f32, tmax: f32) -> f32 {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let a = tri.v[0] - self.org;
        let b = tri.v[1] - self.org;
        let c = tri.v[2] - self.org;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // On an edge in single precision: decide in double, as the paper does.
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return f32::INFINITY;
        }
        let det = u + v + w;
        if det == 0.0 {
            return f32::INFINITY;
        }
        let t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
        if t >= tmin && t <= tmax {
            t
        } else {
            f32::INFINITY
        }
    }
}

/// One object's bottom level, in its own frame.
struct Blas {
    bvh: CwBvh,
    /// Triangles in BVH order (`bvh.primitive_indices`).
    tris: Vec<RtTri>,
    /// Original triangle index of `tris[k]`.
    orig: Vec<u32>,
    bounds: Aabb,
}

impl Blas {
    fn new(m: &MeshRef<'_>) -> Option<Blas> {
        if m.triangles.is_empty() {
            return None;
        }
        let tris: Vec<Triangle> = m
            .triangles
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.map(|i| Vec3A::from(m.positions[i as usize]));
                Triangle { v0, v1, v2 }
            })
            .collect();
        let mut bounds = Aabb::empty();
        for t in &tris {
            bounds.extend(t.v0).extend(t.v1).extend(t.v2);
        }
        // Build over slightly padded triangle boxes: flat nodes (a floor's zero height) give
        // a single-valued slab interval that rounding in the quantised node test can miss,
        // letting rays slip through. The padding makes every interval non-empty.
        let pad = (bounds.max - bounds.min).length() * 1e-5 + 1e-7;
        let boxes: Vec<Aabb> = tris
            .iter()
            .map(|t| {
                let b = t.aabb();
                Aabb::new(b.min - Vec3A::splat(pad), b.max + Vec3A::splat(pad))
            })
            .collect();
        let bvh = build_cwbvh(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let orig = bvh.primitive_indices.clone();
        let tris = orig
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                RtTri {
                    v: [t.v0, t.v1, t.v2],
                }
            })
            .collect();
        Some(Blas {
            bvh,
            tris,
            orig,
            bounds,
        })
    }

    /// Nearest hit in the object frame: (t, index into `tris`).
    #[inline]
    fn closest(&self, ray: Ray) -> Option<(f32, u32)> {
        let mut hit = RayHit::none();
        let w = WRay::new(&ray);
        if self.bvh.ray_traverse(ray, &mut hit, |r, i| {
            w.intersect(&self.tris[i], r.tmin, r.tmax)
        }) {
            Some((hit.t, hit.primitive_id))
        } else {
            None
        }
    }

    #[inline]
    fn any(&self, ray: Ray) -> bool {
        let w = WRay::new(&ray);
        !self
            .bvh
            .ray_traverse_miss(ray, |r, i| w.intersect(&self.tris[i], r.tmin, r.tmax))
    }
}

/// The pure-Rust visibility structure.
pub(crate) struct BvhVis {
    blas: Vec<Option<Blas>>,
    infos: Vec<Vec<TriInfo>>,
    xforms: Vec<Xform>,
    /// Top level over the non-empty objects; `None` when there are none.
    tlas: Option<CwBvh>,
    /// Object index of each top-level primitive, in the top level's primitive order.
    tlas_objects: Vec<u32>,
    dirty: bool,
}

/// A ray with `-0.0` direction components made `+0.0`: obvhs takes the octant from the
/// comparison `d < 0` but the reciprocal from the sign bit, and the two must agree.
#[inline(always)]
fn mk_ray(origin: Vec3A, dir: Vec3A, tmin: f32, tmax: f32) -> Ray {
    Ray::new(origin, dir + Vec3A::ZERO, tmin, tmax)
}

fn world_box(b: &Aabb, m: &Affine3A) -> Aabb {
    let mut out = Aabb::empty();
    for i in 0..8 {
        let p = Vec3A::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        );
        out.extend(m.transform_point3a(p));
    }
    // Pad a little so rays grazing a flat object still enter its box after rounding.
    let pad = (out.max - out.min).max_element() * 1e-6 + 1e-7;
    out.min -= Vec3A::splat(pad);
    out.max += Vec3A::splat(pad);
    out
}

impl BvhVis {
    pub(crate) fn new(meshes: &[MeshRef<'_>], transforms: &[Affine3A]) -> BvhVis {
        let blas: Vec<Option<Blas>> = meshes.par_iter().map(Blas::new).collect();
        let infos = meshes.iter().map(tri_infos).collect();
        let xforms = transforms.iter().map(|&m| Xform::new(m)).collect();
        let mut v = BvhVis {
            blas,
            infos,
            xforms,
            tlas: None,
            tlas_objects: Vec::new(),
            dirty: true,
        };
        v.commit();
        v
    }

    fn rebuild_tlas(&mut self) {
        let mut boxes = Vec::new();
        self.tlas_objects.clear();
        for (o, b) in self.blas.iter().enumerate() {
            if let Some(b) = b {
                boxes.push(world_box(&b.bounds, &self.xforms[o].world_from_object));
                self.tlas_objects.push(o as u32);
            }
        }
        self.tlas = if boxes.is_empty() {
            None
        } else {
            let tlas = build_cwbvh(
                &boxes,
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            );
            // Traversal reports positions in `primitive_indices`: index objects the same way.
            self.tlas_objects = tlas
                .primitive_indices
                .iter()
                .map(|&i| self.tlas_objects[i as usize])
                .collect();
            Some(tlas)
        };
    }

    /// Object `p` of the TLAS, its BLAS and the ray `(o, d)` over `r`'s interval in its
    /// frame; `None` when the object is in `exclude` (transparent).
    #[inline]
    fn enter(
        &self,
        p: usize,
        exclude: &[u32],
        (o, d): (Vec3A, Vec3A),
        r: &Ray,
    ) -> Option<(u32, &Blas, Ray)> {
        let obj = self.tlas_objects[p];
        if exclude.contains(&obj) {
            return None;
        }
        let blas = self.blas[obj as usize]
            .as_ref()
            .expect("tlas holds non-empty objects");
        Some((
            obj,
            blas,
            self.local_ray(obj as usize, o, d, r.tmin, r.tmax),
        ))
    }

    #[inline]
    fn local_ray(&self, o: usize, origin: Vec3A, dir: Vec3A, tmin: f32, tmax: f32) -> Ray {
        let m = &self.xforms[o].object_from_world;
        mk_ray(
            m.transform_point3a(origin),
            m.transform_vector3a(dir),
            tmin,
            tmax,
        )
    }

    fn trace(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32, exclude: &[u32]) -> Hit {
        let Some(tlas) = &self.tlas else {
            return Hit::MISS;
        };
        let (o, d) = (Vec3A::from(origin), Vec3A::from(dir));
        if !(o.is_finite() && d.is_finite()) {
            return Hit::MISS;
        }
        let ray = mk_ray(o, d, t_min, t_max);
        let mut best: Option<(u32, u32)> = None;
        let mut top = RayHit::none();
        tlas.ray_traverse(ray, &mut top, |r, p| {
            let Some((obj, blas, local)) = self.enter(p, exclude, (o, d), r) else {
                return f32::INFINITY;
            };
            match blas.closest(local) {
                Some((t, k)) if t < r.tmax => {
                    best = Some((obj, blas.orig[k as usize]));
                    t
                }
                _ => f32::INFINITY,
            }
        });
        match best {
            Some((obj, tri)) => {
                let info = self.infos[obj as usize][tri as usize];
                Hit {
                    id: info.id,
                    object: obj,
                    t: top.t,
                    front: self.xforms[obj as usize].front(info.n, dir),
                }
            }
            None => Hit::MISS,
        }
    }

    fn blocked(&self, from: Vec3, to: Vec3, eps: f32, exclude: &[u32]) -> bool {
        let Some(tlas) = &self.tlas else { return false };
        let Some((d, len)) = segment(from, to, eps) else {
            return false;
        };
        let (o, d) = (Vec3A::from(from), Vec3A::from(d));
        let ray = mk_ray(o, d, eps, len - eps);
        !tlas.ray_traverse_miss(ray, |r, p| match self.enter(p, exclude, (o, d), r) {
            Some((_, blas, local)) if blas.any(local) => f32::NEG_INFINITY,
            _ => f32::INFINITY,
        })
    }
}

impl Visibility for BvhVis {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn object_count(&self) -> usize {
        self.blas.len()
    }

    fn set_transform(&mut self, object: usize, world_from_object: Affine3A) {
        self.xforms[object] = Xform::new(world_from_object);
        self.dirty = true;
    }

    fn commit(&mut self) {
        if self.dirty {
            self.rebuild_tlas();
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
        (t_min, t_max): (f32, f32),
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        assert_eq!(origins.len(), directions.len());
        assert_eq!(origins.len(), out.len());
        par_fill(out, |base, chunk| {
            for (k, h) in chunk.iter_mut().enumerate() {
                *h = self.trace(
                    origins[base + k],
                    directions[base + k],
                    t_min,
                    t_max,
                    exclude,
                );
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
            for (k, h) in chunk.iter_mut().enumerate() {
                let i = base + k;
                *h = self.trace(
                    points[i / nd],
                    directions[i % nd],
                    t_min,
                    f32::INFINITY,
                    exclude,
                );
            }
        });
    }

    fn occluded(&self, from: &[Vec3], to: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]) {
        assert_eq!(from.len(), to.len());
        assert_eq!(from.len(), out.len());
        par_fill(out, |base, chunk| {
            for (k, b) in chunk.iter_mut().enumerate() {
                *b = self.blocked(from[base + k], to[base + k], eps, exclude);
            }
        });
    }
}
