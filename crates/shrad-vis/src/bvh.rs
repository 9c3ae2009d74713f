//! Pure-Rust backend: one compressed wide BVH (obvhs CWBVH) per object in its own frame, and
//! a top-level CWBVH over the instances' world boxes, rebuilt at [`Visibility::commit`]
//! (cheap: one box per object). Rays are taken into each instance's frame with the inverse
//! transform, without renormalising the direction, so `t` is the same in both frames.

use std::time::Duration;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    cwbvh::{
        builder::{build_cwbvh, build_cwbvh_from_tris},
        CwBvh,
    },
    ray::{Ray, RayHit},
    triangle::Triangle,
    BvhBuildParams,
};
use rayon::prelude::*;

use crate::{segment, tri_infos, Hit, MeshRef, TriInfo, Visibility, Xform, CHUNK};

/// A triangle laid out for intersection: base vertex and the two edges.
#[derive(Clone, Copy, Debug)]
struct RtTri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

impl RtTri {
    /// Möller–Trumbore, both faces; `t` in `[tmin, tmax]` or infinity.
    #[inline(always)]
    fn intersect(&self, ray: &Ray) -> f32 {
        let p = ray.direction.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 {
            return f32::INFINITY;
        }
        let inv = 1.0 / det;
        let s = ray.origin - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return f32::INFINITY;
        }
        let q = s.cross(self.e1);
        let v = ray.direction.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return f32::INFINITY;
        }
        let t = self.e2.dot(q) * inv;
        if t >= ray.tmin && t <= ray.tmax {
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
        let bvh = build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let mut bounds = Aabb::empty();
        for t in &tris {
            bounds.extend(t.v0).extend(t.v1).extend(t.v2);
        }
        let orig = bvh.primitive_indices.clone();
        let tris = orig
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                RtTri {
                    v0: t.v0,
                    e1: t.v1 - t.v0,
                    e2: t.v2 - t.v0,
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
        if self
            .bvh
            .ray_traverse(ray, &mut hit, |r, i| self.tris[i].intersect(r))
        {
            Some((hit.t, hit.primitive_id))
        } else {
            None
        }
    }

    #[inline]
    fn any(&self, ray: Ray) -> bool {
        !self
            .bvh
            .ray_traverse_miss(ray, |r, i| self.tris[i].intersect(r))
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
            let obj = self.tlas_objects[p];
            if exclude.contains(&obj) {
                return f32::INFINITY;
            }
            let blas = self.blas[obj as usize]
                .as_ref()
                .expect("tlas holds non-empty objects");
            match blas.closest(self.local_ray(obj as usize, o, d, r.tmin, r.tmax)) {
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
        !tlas.ray_traverse_miss(ray, |r, p| {
            let obj = self.tlas_objects[p];
            if exclude.contains(&obj) {
                return f32::INFINITY;
            }
            let blas = self.blas[obj as usize]
                .as_ref()
                .expect("tlas holds non-empty objects");
            if blas.any(self.local_ray(obj as usize, o, d, r.tmin, r.tmax)) {
                f32::NEG_INFINITY
            } else {
                f32::INFINITY
            }
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
        assert_eq!(origins.len(), directions.len());
        assert_eq!(origins.len(), out.len());
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| {
                let base = c * CHUNK;
                for (k, h) in chunk.iter_mut().enumerate() {
                    *h = self.trace(
                        origins[base + k],
                        directions[base + k],
                        t_min,
                        f32::INFINITY,
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
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| {
                let base = c * CHUNK;
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
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| {
                let base = c * CHUNK;
                for (k, b) in chunk.iter_mut().enumerate() {
                    *b = self.blocked(from[base + k], to[base + k], eps, exclude);
                }
            });
    }
}
