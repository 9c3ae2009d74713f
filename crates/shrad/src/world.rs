//! The patched scene at one moment: scene description, patches, visibility, current
//! materials. All three solvers read it; only [`World::set_time`] changes it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::{Affine3A, Vec3};
use rayon::prelude::*;
use shrad_scene::Scene;
use shrad_vis::{Backend, Hit, MeshRef, Visibility};

use crate::patches::{PatchSizing, Patches, NO_PATCH};
use crate::solid_core::SolidCores;
use crate::Error;

/// A scene ready for solving.
pub struct World {
    /// The scene description.
    pub scene: Scene,
    /// Its patches.
    pub patches: Patches,
    /// Visibility over the patches' triangles (payload = patch id).
    pub vis: Box<dyn Visibility>,
    /// Reflectance of each patch: the area average of the material's reflectance field
    /// over the patch (textures and vertex colours, [`crate::surface`]).
    pub reflectance: Vec<Vec3>,
    /// Area average of the emissive texture over each patch (the exitance is the
    /// material's times this); empty when no material has an emissive texture.
    pub emission_texture: Vec<Vec3>,
    /// Emitted exitance `M` of each patch at the current time.
    pub exitance: Vec<Vec3>,
    /// The scene's punctual lights at the current time (`None`: a light whose transform
    /// collapses it, dark), aligned with `scene.lights`.
    pub lights: Vec<Option<crate::lights::LightState>>,
    /// The sky (`scene.environment`), if any ([`crate::sky`]).
    pub sky: Option<Arc<crate::sky::Sky>>,
    /// Current time (seconds).
    pub time: f32,
    /// Ray offset off surfaces (scene units): 1e-5 of the scene's diagonal (`ray_offset`).
    pub eps: f32,
    /// Rays `vis` has cast (shared with the counting wrapper around the backend).
    rays_cast: Arc<AtomicU64>,
}

/// A visibility backend that counts the rays it casts (one atomic add per batch, so the
/// count costs nothing next to the rays), and casts no shadow ray among some objects that
/// passes through one's solid core ([`SolidCores`]): those are blocked for sure.
struct Counted {
    inner: Box<dyn Visibility>,
    rays: Arc<AtomicU64>,
    cores: SolidCores,
}

impl Counted {
    fn add(&self, rays: usize) {
        self.rays.fetch_add(rays as u64, Ordering::Relaxed);
    }
}

impl Visibility for Counted {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn object_count(&self) -> usize {
        self.inner.object_count()
    }
    fn set_transform(&mut self, object: usize, world_from_object: Affine3A) {
        self.cores.place(object, world_from_object);
        self.inner.set_transform(object, world_from_object)
    }
    fn commit(&mut self) {
        self.inner.commit()
    }
    fn closest(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        self.add(out.len());
        self.inner.closest(origins, directions, t_min, exclude, out)
    }
    fn closest_within(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        t: (f32, f32),
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        self.add(out.len());
        self.inner
            .closest_within(origins, directions, t, exclude, out)
    }
    fn capture(
        &self,
        points: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        self.add(out.len());
        self.inner.capture(points, directions, t_min, exclude, out)
    }
    fn occluded(&self, from: &[Vec3], to: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]) {
        self.add(out.len());
        self.inner.occluded(from, to, eps, exclude, out)
    }

    fn occluded_among(
        &self,
        from: &[Vec3],
        to: &[Vec3],
        eps: f32,
        among: &[u32],
        out: &mut [bool],
    ) {
        if !self.cores.any(among) {
            self.add(out.len());
            return self.inner.occluded_among(from, to, eps, among, out);
        }
        // Those through a core are blocked; the backend traces the rest.
        (out.par_iter_mut().enumerate().with_min_len(512))
            .for_each(|(r, b)| *b = self.cores.blocks(among, from[r], to[r], eps));
        let rest: Vec<usize> = (0..out.len()).filter(|&r| !out[r]).collect();
        let rest_from: Vec<Vec3> = rest.iter().map(|&r| from[r]).collect();
        let rest_to: Vec<Vec3> = rest.iter().map(|&r| to[r]).collect();
        let mut blocked = vec![false; rest.len()];
        self.add(rest.len());
        (self.inner).occluded_among(&rest_from, &rest_to, eps, among, &mut blocked);
        for (&r, b) in rest.iter().zip(blocked) {
            out[r] = b;
        }
    }
}

impl World {
    /// Subdivide `scene` into patches and build its visibility.
    pub fn new(scene: Scene, sizing: PatchSizing, backend: Backend) -> Result<World, Error> {
        let plan = Patches::plan(&scene, sizing);
        crate::limits::check_patches(&scene, plan)?;
        // A scene without patches (a valid glTF with nothing to light loads empty) is a
        // world too: every solver, picture and bake of it is empty or the background.
        let mut patches = Patches::build(&scene, PatchSizing::Size(plan.patch_size));
        // The backend copies the patch meshes into its own structure; the world keeps none
        // (at 1M patches they were about 80 MB of a peak that must stay under 1.5 GiB).
        let patch_meshes = std::mem::take(&mut patches.meshes);
        let meshes: Vec<MeshRef<'_>> = patch_meshes
            .iter()
            .zip(&patches.object_role)
            .map(|(m, role)| MeshRef {
                positions: &m.positions,
                triangles: &m.triangles,
                ids: &m.triangle_patch,
                // The dispersive solver's probes and emitters see through their own object.
                often_excluded: *role == shrad_scene::Role::Interior,
            })
            .collect();
        let inner = shrad_vis::build(backend, &meshes, &patches.world_from_local)
            .map_err(|e| Error::Invalid(e.to_string()))?;
        // Interior objects move (the dispersive solver's objects); their cores spare the
        // rays a move sends through them again. Whether one closes a solid is read from its
        // own mesh (its patches split its edges), the core from what the backend traces.
        let mesh_parts: Vec<_> = (meshes.iter())
            .map(|m| (m.positions, m.triangles))
            .collect();
        let role = &patches.object_role;
        let cores = SolidCores::new(&mesh_parts, &patches.world_from_local, |o| {
            let mesh = &scene.objects[o].mesh;
            role[o] == shrad_scene::Role::Interior
                && crate::solid_core::closed(&mesh.positions, &mesh.triangles)
        });
        drop(mesh_parts);
        drop(meshes);
        drop(patch_meshes);
        let rays_cast = Arc::new(AtomicU64::new(0));
        let vis = Box::new(Counted {
            inner,
            rays: rays_cast.clone(),
            cores,
        });
        let (reflectance, emission_texture) = crate::surface::patch_fields(&scene, &patches);
        let mut world = World {
            eps: ray_offset(scene.bounds()),
            exitance: vec![Vec3::ZERO; patches.len()],
            lights: crate::lights::states_at(&scene.lights, 0.0),
            sky: scene
                .environment
                .as_ref()
                .map(|e| Arc::new(crate::sky::Sky::new(e))),
            scene,
            patches,
            vis,
            reflectance,
            emission_texture,
            time: f32::NAN,
            rays_cast,
        };
        world.set_time(0.0)?;
        Ok(world)
    }

    /// Rays cast through [`World::vis`] since the world was made (every solver, picture and
    /// error measurement; a frame's own count is the difference, `FrameStats::rays_cast`).
    pub fn rays_cast(&self) -> u64 {
        self.rays_cast.load(Ordering::Relaxed)
    }

    /// Move animated objects and update emission and base colour to time `t`. Returns the
    /// objects whose transform changed, and those whose emission or reflectance changed.
    /// A pose or an emission at `t` that no solver can take (an animation that flattens an
    /// object, throws it beyond the coordinates 32-bit floats can hold, or makes it emit
    /// more than [`shrad_scene::MAX_RADIANCE`]) is an error naming the object and the time,
    /// and nothing changes.
    pub fn set_time(&mut self, t: f32) -> Result<(Vec<usize>, Vec<usize>), Error> {
        self.check_time(t)?;
        Ok(self.go_to_time(t))
    }

    /// Whether every animated object's pose and emission at `t` can be taken
    /// ([`World::set_time`]'s error if not); a command that plays an animation checks every
    /// frame's time before it writes anything.
    pub fn check_time(&self, t: f32) -> Result<(), Error> {
        for (o, object) in self.scene.objects.iter().enumerate() {
            let animated = object.animation.is_some()
                || object.node_animation.is_some()
                || object.material_tracks.is_some();
            if !animated {
                continue;
            }
            let xf = self
                .patches
                .local_transform_for(o, object.world_from_object_at(t));
            let problem = shrad_scene::placement_problem(xf, self.patches.shape_bounds(o))
                .or_else(|| shrad_scene::emission_problem(object.material_at(t).emitted_radiance));
            if let Some(why) = problem {
                return Err(Error::Invalid(format!(
                    "{}: {}: its animation at time {t} s cannot be taken: {why}",
                    self.scene.source,
                    self.object_label(o)?
                )));
            }
        }
        Ok(())
    }

    /// [`World::set_time`] once checked.
    fn go_to_time(&mut self, t: f32) -> (Vec<usize>, Vec<usize>) {
        let first = self.time.is_nan();
        let mut moved = Vec::new();
        let mut relit = Vec::new();
        let mut recoloured = Vec::new();
        for (o, object) in self.scene.objects.iter().enumerate() {
            let still = object.animation.is_none()
                && object.node_animation.is_none()
                && object.material_tracks.is_none();
            if !first && still {
                continue;
            }
            let world_from_object = object.world_from_object_at(t);
            // At rest exactly the transform the patches were built with (no float drift).
            let xf = if world_from_object == object.world_from_object {
                crate::patches::split_rest_transform(world_from_object).0
            } else {
                self.patches.local_transform_for(o, world_from_object)
            };
            if xf != self.patches.world_from_local[o] {
                self.patches.set_transform(o, xf);
                self.vis.set_transform(o, xf);
                moved.push(o);
            }
            let material = object.material_at(t);
            let m = material.exitance();
            let r = self.patches.range(o);
            // Per patch: an emissive texture scales the material's exitance.
            let tex = |p: usize| self.emission_texture.get(p).copied().unwrap_or(Vec3::ONE);
            if first || self.exitance[r.start] != m * tex(r.start) {
                for p in r {
                    self.exitance[p] = m * tex(p);
                }
                relit.push(o);
            }
            if material.reflectance != object.material.reflectance {
                recoloured.push((o, material.reflectance));
            }
        }
        for (o, rho) in recoloured {
            self.recolour(o, rho);
            if !relit.contains(&o) {
                relit.push(o);
            }
        }
        if !moved.is_empty() {
            self.vis.commit();
        }
        // Punctual lights follow their nodes; the solvers compare the states they traced
        // with these, so a light's change is seen whoever changed the time.
        for (l, light) in self.scene.lights.iter().enumerate() {
            if first || light.is_animated() {
                self.lights[l] =
                    crate::lights::LightState::new(&light.at(t), &light.world_from_light_at(t));
            }
        }
        self.time = t;
        (moved, relit)
    }

    /// How far a shadow ray towards a directional light reaches: a thousand scene diagonals
    /// (`eps` is 1e-5 of one), beyond anything that can occlude.
    pub fn far(&self) -> f32 {
        1e8 * self.eps
    }

    /// Put punctual light `l` at `world_from_light` (it shines along its -Z) with colour
    /// `color` and photometric `intensity` (candela, or lux for a directional light), until
    /// the next [`World::set_time`] for an animated light. Returns whether it changed; a bad
    /// value is an error naming the light, and changes nothing.
    pub fn set_light(
        &mut self,
        l: usize,
        world_from_light: Affine3A,
        color: Vec3,
        intensity: f32,
    ) -> Result<bool, Error> {
        let n = self.scene.lights.len();
        let Some(light) = self.scene.lights.get(l) else {
            return Err(Error::Invalid(format!(
                "no light {l}: the scene has {n} (0..{n})"
            )));
        };
        let next = shrad_scene::Light {
            world_from_light,
            color,
            intensity,
            ..light.clone()
        };
        if let Some(why) = next.problem() {
            return Err(Error::Invalid(format!("light {l} '{}': {why}", light.name)));
        }
        let state = crate::lights::LightState::new(&next, &world_from_light);
        self.scene.lights[l] = next;
        let changed = state != self.lights[l];
        self.lights[l] = state;
        Ok(changed)
    }

    /// Put the sky `environment` (`None`: none) in place of the scene's. Returns whether it
    /// changed; a bad value is an error and changes nothing.
    pub fn set_sky(
        &mut self,
        environment: Option<shrad_scene::Environment>,
    ) -> Result<bool, Error> {
        if let Some(why) = environment.as_ref().and_then(|e| e.problem()) {
            return Err(Error::Invalid(format!("{}: {why}", self.scene.source)));
        }
        if environment == self.scene.environment {
            return Ok(false);
        }
        self.sky = environment
            .as_ref()
            .map(|e| Arc::new(crate::sky::Sky::new(e)));
        self.scene.environment = environment;
        Ok(true)
    }

    /// The patch whose front a hit sees (a double-sided surface's back is its twin's
    /// front), or `None` for a miss or a single-sided back face (radiance 0, spec 2).
    #[inline]
    pub fn seen_patch(&self, hit: &Hit) -> Option<usize> {
        if !hit.is_hit() {
            return None;
        }
        if hit.front {
            return Some(hit.id as usize);
        }
        let twin = self.patches.twin[hit.id as usize];
        (twin != NO_PATCH).then_some(twin as usize)
    }

    /// Put object `o` at `world_from_object` (any affine map: a scale re-measures its areas),
    /// whatever its animation says, until the next [`World::set_time`]. Returns whether it
    /// moved.
    pub fn move_object(
        &mut self,
        o: usize,
        world_from_object: glam::Affine3A,
    ) -> Result<bool, Error> {
        let name = self.object_label(o)?;
        // Judged as a scene file's transform is (`transform_problem`: singular relative to
        // its own scale; a uniform scale of 1e-4 was refused here), and named as the caller
        // gave it, before it is composed with the object's local frame.
        if let Some(why) = shrad_scene::transform_problem(world_from_object) {
            return Err(Error::Invalid(format!("{name}: {why}")));
        }
        let xf = self.patches.local_transform_for(o, world_from_object);
        if let Some(why) = shrad_scene::placement_problem(xf, self.patches.shape_bounds(o)) {
            return Err(Error::Invalid(format!("{name}: {why}")));
        }
        if xf == self.patches.world_from_local[o] {
            return Ok(false);
        }
        self.patches.set_transform(o, xf);
        self.vis.set_transform(o, xf);
        self.vis.commit();
        Ok(true)
    }

    /// Set object `o`'s emitted radiance `L_e` (linear RGB, W/(m^2 sr); exitance `pi L_e`)
    /// until the next [`World::set_time`]. Returns whether it changed.
    pub fn set_emission(&mut self, o: usize, emitted_radiance: Vec3) -> Result<bool, Error> {
        let name = self.object_label(o)?;
        if let Some(why) = shrad_scene::emission_problem(emitted_radiance) {
            return Err(Error::Invalid(format!("{name}: {why}")));
        }
        let m = emitted_radiance * std::f32::consts::PI;
        let r = self.patches.range(o);
        if self.exitance[r.clone()].iter().all(|e| *e == m) {
            return Ok(false);
        }
        self.exitance[r].fill(m);
        Ok(true)
    }

    /// Set object `o`'s reflectance factor (linear RGB, each in [0, 1]; 1 is read as
    /// [`crate::surface::MAX_REFLECTANCE`]): its material's `reflectance`, which its
    /// base-colour texture and vertex colours multiply, until the next [`World::set_time`]
    /// of an object whose base colour is keyed. Returns whether it changed.
    pub fn set_reflectance(&mut self, o: usize, reflectance: Vec3) -> Result<bool, Error> {
        let name = self.object_label(o)?;
        if !reflectance.is_finite()
            || reflectance.min_element() < 0.0
            || reflectance.max_element() > 1.0
        {
            return Err(Error::Invalid(format!(
                "{name}: reflectance {reflectance} must be finite and within [0, 1]"
            )));
        }
        let rho = reflectance.min(Vec3::splat(crate::surface::MAX_REFLECTANCE));
        if self.scene.objects[o].material.reflectance == rho {
            return Ok(false);
        }
        self.recolour(o, rho);
        Ok(true)
    }

    /// Give object `o`'s material the reflectance factor `rho` and its patches their
    /// reflectance again (textures and vertex colours included, [`crate::surface`]).
    fn recolour(&mut self, o: usize, rho: Vec3) {
        let material = &mut self.scene.objects[o].material;
        material.reflectance = rho;
        let fresh = crate::surface::object_reflectance(material, &self.patches, o);
        self.reflectance[self.patches.range(o)].copy_from_slice(&fresh);
    }

    /// "object 3 'name'", or an error naming the valid range.
    fn object_label(&self, o: usize) -> Result<String, Error> {
        match self.scene.objects.get(o) {
            Some(object) => Ok(format!("object {o} '{}'", object.name)),
            None => Err(Error::Invalid(format!(
                "no object {o}: the scene has {} (0..{})",
                self.scene.objects.len(),
                self.scene.objects.len()
            ))),
        }
    }

    /// Does any object, punctual light or the sky emit at the current time?
    pub fn has_emitter(&self) -> bool {
        self.sky.as_ref().is_some_and(|s| !s.is_black())
            || self.exitance.iter().any(|m| m.max_element() > 0.0)
            || self
                .lights
                .iter()
                .flatten()
                .any(|l| l.strength.max_element() > 0.0)
    }
}

/// How far rays start and stop off the surfaces they leave and reach: 1e-5 of the scene's
/// diagonal, and at least 64 float steps of its farthest coordinate (a scene far from the
/// origin, whose points are that coarse). At 1e-4 of the diagonal a rug 1 mm above the
/// floor of a 10 m room did not shadow the floor (its shadow rays began above the rug: the
/// floor under it was lit in full, against Mitsuba's 0.1 %), nor did a lamp panel 1 mm
/// before a wall shade the wall behind it (which then took more light than the lamp gave).
fn ray_offset(bounds: Option<shrad_scene::Aabb>) -> f32 {
    let Some(b) = bounds else {
        return 1e-5;
    };
    let farthest = b.min.abs().max(b.max.abs()).max_element();
    (1e-5 * b.diagonal())
        .max(64.0 * f32::EPSILON * farthest)
        .max(f32::MIN_POSITIVE)
}
