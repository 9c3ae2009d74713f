//! Plain-data scene model. Conventions (spec section 2): linear RGB, Lambertian surfaces,
//! reflectance `rho` in [0,1), emitted radiance `L_e` of the front side (exitance
//! `M = pi * L_e`), counter-clockwise triangles seen from the front.

use glam::{Affine3A, Quat, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::Path;

use crate::{SceneError, Texture};

/// What an object does in the dispersive method (paper 2.1, spec section 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Walls, floor, ceiling: enclose the scene, normals inward.
    Boundary,
    /// Everything inside: lit through its 8 corner probes.
    Interior,
    /// Emitters.
    Light,
}

impl Role {
    /// Lower-case name, as in scene files and CSV output.
    pub fn name(self) -> &'static str {
        match self {
            Role::Boundary => "boundary",
            Role::Interior => "interior",
            Role::Light => "light",
        }
    }
}

impl std::fmt::Display for Role {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A Lambertian material. With textures (and vertex colours) the reflectance is a field
/// `rho(x) = reflectance * base_color_texture(uv(x)) * colour(x)` and the emitted radiance
/// `L_e(x) = emitted_radiance * emissive_texture(uv(x))` (spec section 2, "Textures").
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance `rho` (linear RGB, each in [0,1)): the factor the base-colour
    /// texture and the vertex colours multiply.
    pub reflectance: Vec3,
    /// Emitted radiance `L_e` of the front side (linear RGB, W/(m^2 sr)); the emissive
    /// texture multiplies it.
    pub emitted_radiance: Vec3,
    /// Reflects (and emits) on both sides.
    pub double_sided: bool,
    /// Base-colour texture (sRGB-decoded), read through the mesh's `uvs[tex_coord]`.
    pub base_color_texture: Option<Texture>,
    /// Emissive texture (sRGB-decoded), read through the mesh's `uvs[tex_coord]`.
    pub emissive_texture: Option<Texture>,
}

impl Material {
    /// A non-emissive single-sided material.
    pub const fn diffuse(reflectance: Vec3) -> Self {
        Material {
            reflectance,
            emitted_radiance: Vec3::ZERO,
            double_sided: false,
            base_color_texture: None,
            emissive_texture: None,
        }
    }
    /// Is the reflectance a field (a base-colour texture)?
    pub fn is_textured(&self) -> bool {
        self.base_color_texture.is_some() || self.emissive_texture.is_some()
    }
    /// Emitted exitance `M = pi * L_e` (W/m^2).
    pub fn exitance(&self) -> Vec3 {
        self.emitted_radiance * PI
    }
    /// Does it emit at all?
    pub fn is_emissive(&self) -> bool {
        self.emitted_radiance.max_element() > 0.0
    }
}

impl Default for Material {
    fn default() -> Self {
        Material::diffuse(Vec3::splat(0.5))
    }
}

/// An indexed triangle mesh in the object's own (rest) frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise (seen from the front) vertex index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Texture-coordinate sets (glTF `TEXCOORD_n` is `uvs[n]`), each one per vertex;
    /// `(0, 0)` is the image's top-left corner, `v` grows downwards (glTF's convention).
    pub uvs: Vec<Vec<Vec2>>,
    /// Vertex colours (glTF `COLOR_0`, linear RGB in [0, 1], alpha dropped): empty, or one
    /// per vertex. They multiply the material's reflectance.
    pub colors: Vec<Vec3>,
}

impl Mesh {
    /// Axis-aligned bounding box `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))),
        )
    }
    /// Area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.triangles[t].map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }
    /// Total surface area.
    pub fn area(&self) -> f32 {
        (0..self.triangles.len())
            .map(|t| self.triangle_area(t))
            .sum()
    }
    /// A mesh of positions and triangles only.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        Mesh {
            positions,
            triangles,
            ..Default::default()
        }
    }
    /// Append another mesh (texture coordinates a side lacks are 0, colours 1).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        let (n, m) = (self.positions.len(), other.positions.len());
        let sets = self.uvs.len().max(other.uvs.len());
        self.uvs.resize(sets, vec![Vec2::ZERO; n]);
        for (k, set) in self.uvs.iter_mut().enumerate() {
            match other.uvs.get(k) {
                Some(o) => set.extend_from_slice(o),
                None => set.resize(n + m, Vec2::ZERO),
            }
        }
        if !self.colors.is_empty() || !other.colors.is_empty() {
            self.colors.resize(n, Vec3::ONE);
            if other.colors.is_empty() {
                self.colors.resize(n + m, Vec3::ONE);
            } else {
                self.colors.extend_from_slice(&other.colors);
            }
        }
        self.positions.extend_from_slice(&other.positions);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    /// The same mesh with every vertex transformed.
    pub fn transformed(&self, m: Affine3A) -> Mesh {
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|&p| m.transform_point3(p))
                .collect(),
            triangles: self.triangles.clone(),
            uvs: self.uvs.clone(),
            colors: self.colors.clone(),
        }
    }
}

/// One key of a rigid animation: the motion applied on top of the rest transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f32,
    /// Translation added to the object's rest position (world units).
    pub translation: Vec3,
    /// Rotation about the centre of the object's rest bounding box (world axes).
    pub rotation: Quat,
}

/// A key of an emission change (lights switching colour or intensity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionKey {
    /// Time in seconds.
    pub time: f32,
    /// Emitted radiance `L_e` from this time on (interpolated linearly to the next key).
    pub emitted_radiance: Vec3,
}

/// Keyframed rigid animation: translation interpolated linearly, rotation by slerp; before
/// the first key and after the last the end keys hold.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// Keys sorted by time.
    pub keys: Vec<Keyframe>,
    /// Emission keys sorted by time (empty: the material's emission holds).
    pub emission: Vec<EmissionKey>,
    /// Step (hold each key until the next) instead of linear / slerp interpolation.
    pub step: bool,
}

impl Animation {
    /// `(translation, rotation)` at time `t`.
    pub fn motion_at(&self, t: f32) -> (Vec3, Quat) {
        let (Some(first), Some(last)) = (self.keys.first(), self.keys.last()) else {
            return (Vec3::ZERO, Quat::IDENTITY);
        };
        if t <= first.time {
            return (first.translation, first.rotation);
        }
        if t >= last.time {
            return (last.translation, last.rotation);
        }
        let i = self.keys.partition_point(|k| k.time <= t);
        let (a, b) = (self.keys[i - 1], self.keys[i]);
        if self.step {
            return (a.translation, a.rotation);
        }
        let s = (t - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE);
        (
            a.translation.lerp(b.translation, s),
            a.rotation.slerp(b.rotation, s),
        )
    }

    /// Emitted radiance at time `t`, or `None` when the animation does not change it.
    pub fn emission_at(&self, t: f32) -> Option<Vec3> {
        let first = self.emission.first()?;
        let last = self.emission.last()?;
        if t <= first.time {
            return Some(first.emitted_radiance);
        }
        if t >= last.time {
            return Some(last.emitted_radiance);
        }
        let i = self.emission.partition_point(|k| k.time <= t);
        let (a, b) = (self.emission[i - 1], self.emission[i]);
        if self.step {
            return Some(a.emitted_radiance);
        }
        let s = (t - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE);
        Some(a.emitted_radiance.lerp(b.emitted_radiance, s))
    }

    /// Time of the last key (0 for a static object).
    pub fn duration(&self) -> f32 {
        let k = self.keys.last().map_or(0.0, |k| k.time);
        let e = self.emission.last().map_or(0.0, |k| k.time);
        k.max(e)
    }
}

/// One object of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name (from the file, or generated).
    pub name: String,
    /// The mesh in the object's own frame; its bounding box there is the probe box.
    pub mesh: Mesh,
    /// Material.
    pub material: Material,
    /// Role given by the input; `None` until [`crate::infer_roles`] fills it.
    pub role: Option<Role>,
    /// Rest transform.
    pub world_from_object: Affine3A,
    /// Optional rigid animation and emission keys.
    pub animation: Option<Animation>,
    /// Motion imported from an animated glTF node (the scene file's keys go on top).
    pub node_animation: Option<crate::NodeAnimation>,
    /// Patch size for this object only (overrides the scene's), in scene units.
    pub patch_size: Option<f32>,
}

impl Object {
    /// A static object with no role yet.
    pub fn new(name: impl Into<String>, mesh: Mesh, material: Material) -> Self {
        Object {
            name: name.into(),
            mesh,
            material,
            role: None,
            world_from_object: Affine3A::IDENTITY,
            animation: None,
            node_animation: None,
            patch_size: None,
        }
    }

    /// The role, `Interior` if none was set or inferred.
    pub fn role(&self) -> Role {
        self.role.unwrap_or(Role::Interior)
    }

    /// World bounding box at rest.
    pub fn world_bounds(&self) -> Option<(Vec3, Vec3)> {
        self.mesh.transformed(self.world_from_object).bounds()
    }

    /// The object's world transform at time `t`: the glTF node animation's transform at
    /// `t` (else the rest transform), then the scene-file animation's rotation about the
    /// centre of the rest world box and its translation on top.
    pub fn world_from_object_at(&self, t: f32) -> Affine3A {
        let base = self
            .node_animation
            .as_ref()
            .map_or(self.world_from_object, |n| n.world_from_object_at(t));
        let Some(anim) = self.animation.as_ref().filter(|a| !a.keys.is_empty()) else {
            return base;
        };
        let (translation, rotation) = anim.motion_at(t);
        let centre = self
            .world_bounds()
            .map_or(Vec3::ZERO, |(lo, hi)| 0.5 * (lo + hi));
        Affine3A::from_translation(translation + centre)
            * Affine3A::from_quat(rotation)
            * Affine3A::from_translation(-centre)
            * base
    }

    /// The material at time `t` (emission keys applied).
    pub fn material_at(&self, t: f32) -> Material {
        let mut m = self.material.clone();
        if let Some(e) = self.animation.as_ref().and_then(|a| a.emission_at(t)) {
            m.emitted_radiance = e;
        }
        m
    }

    /// Does anything about this object change over time?
    pub fn is_animated(&self) -> bool {
        self.node_animation.is_some()
            || self
                .animation
                .as_ref()
                .is_some_and(|a| a.keys.len() > 1 || a.emission.len() > 1)
    }

    /// Time of the last key of either animation (0 for a static object).
    pub fn duration(&self) -> f32 {
        let a = self.animation.as_ref().map_or(0.0, Animation::duration);
        let n = self
            .node_animation
            .as_ref()
            .map_or(0.0, crate::NodeAnimation::duration);
        a.max(n)
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera looks down its -Z axis with +Y up (glTF convention).
    pub world_from_camera: Affine3A,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Width / height; `None`: take the image's.
    pub aspect_ratio: Option<f32>,
}

impl Camera {
    /// A camera at `eye` looking at `target`, with +Y up.
    pub fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - eye).normalize();
        let up = if forward.y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(up).normalize();
        let true_up = right.cross(forward);
        let rot = glam::Mat3::from_cols(right, true_up, -forward);
        Camera {
            world_from_camera: Affine3A::from_mat3_translation(rot, eye),
            yfov,
            aspect_ratio: None,
        }
    }

    /// A camera that frames the box `(lo, hi)` from the front (-Z side looking +Z... the side
    /// towards +Z is the back), for scenes that have none.
    pub fn framing(lo: Vec3, hi: Vec3) -> Self {
        let centre = 0.5 * (lo + hi);
        let ext = hi - lo;
        let yfov = 40f32.to_radians();
        let radius = 0.5 * ext.x.max(ext.y);
        let dist = radius / (0.5 * yfov).tan() + 0.5 * ext.z;
        Camera::look_at(centre - Vec3::Z * dist * 1.05, centre, yfov)
    }
}

/// Solver settings a scene file may carry; the command line overrides them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneSettings {
    /// Patch edge length `h` (scene units).
    pub patch_size: Option<f32>,
    /// Target total patch count (alternative to `patch_size`).
    pub patches: Option<usize>,
    /// Other solver settings as written (key = value), applied by the CLI as its solver options of the same names (the command line wins; an unknown key is an error naming the file).
    pub solver: std::collections::BTreeMap<String, String>,
}

/// A whole scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Where it came from (file path or `builtin:NAME`), for messages.
    pub source: String,
    /// The objects.
    pub objects: Vec<Object>,
    /// The scene's camera, if it has one.
    pub camera: Option<Camera>,
    /// Settings from the scene file.
    pub settings: SceneSettings,
    /// Non-fatal problems found while loading (printed by the CLI).
    pub warnings: Vec<String>,
    /// The glTF animations of the file (listed by `shrad info`; empty for other inputs).
    pub animations: Vec<crate::AnimationInfo>,
}

impl Scene {
    /// World bounding box of every object at rest.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.objects
            .iter()
            .filter_map(|o| o.world_bounds())
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }

    /// The scene's camera, or one that frames the scene. When a boundary object encloses
    /// the scene (a room), the camera stands inside it, near the -Z wall, looking in: from
    /// outside it would see only the room's outer side.
    pub fn camera_or_default(&self) -> Camera {
        self.camera.unwrap_or_else(|| {
            let (lo, hi) = self.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::ONE));
            let ext = hi - lo;
            let encloses = self.objects.iter().any(|o| {
                o.role == Some(Role::Boundary)
                    && o.world_bounds().is_some_and(|(a, b)| {
                        (a - lo).max_element() <= 1e-3 * ext.max_element()
                            && (hi - b).max_element() <= 1e-3 * ext.max_element()
                    })
            });
            if encloses {
                let centre = 0.5 * (lo + hi);
                let eye = Vec3::new(centre.x, lo.y + 0.55 * ext.y, lo.z + 0.03 * ext.z);
                Camera::look_at(eye, centre, 60f32.to_radians())
            } else {
                Camera::framing(lo, hi)
            }
        })
    }

    /// Length of the longest animation (0 for a static scene).
    pub fn duration(&self) -> f32 {
        self.objects
            .iter()
            .map(Object::duration)
            .fold(0.0, f32::max)
    }

    /// Is there any emitter?
    pub fn has_emitter(&self) -> bool {
        self.objects.iter().any(|o| {
            o.material.is_emissive()
                || o.animation.as_ref().is_some_and(|a| {
                    a.emission
                        .iter()
                        .any(|k| k.emitted_radiance.max_element() > 0.0)
                })
        })
    }

    /// Check what every solver relies on: finite positions and transforms, indices in range,
    /// reflectance in [0,1), finite non-negative emission, no zero-area triangles (or drop them
    /// when `drop_degenerate`), at least one triangle. Errors name `path` and the object.
    pub fn validate(&mut self, path: &Path, drop_degenerate: bool) -> Result<(), SceneError> {
        if self.objects.is_empty() {
            return Err(SceneError::invalid(path, "the scene has no objects"));
        }
        for (oi, o) in self.objects.iter_mut().enumerate() {
            let who = format!("object {oi} '{}'", o.name);
            if let Some(i) = o.mesh.positions.iter().position(|p| !p.is_finite()) {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: vertex {i} is not finite ({})", o.mesh.positions[i]),
                ));
            }
            let n = o.mesh.positions.len() as u32;
            if let Some(t) = o
                .mesh
                .triangles
                .iter()
                .position(|t| t.iter().any(|&i| i >= n))
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: triangle {t} has vertex index out of range ({:?}, {n} vertices)",
                        o.mesh.triangles[t]
                    ),
                ));
            }
            let m = o.world_from_object;
            if !(m.matrix3.is_finite() && m.translation.is_finite())
                || m.matrix3.determinant().abs() < 1e-12
            {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: transform is not finite or is singular"),
                ));
            }
            if let Some(k) = o
                .mesh
                .uvs
                .iter()
                .position(|s| s.len() != o.mesh.positions.len())
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: texture coordinate set {k} has {} entries for {n} vertices",
                        o.mesh.uvs[k].len()
                    ),
                ));
            }
            let colors = o.mesh.colors.len();
            if colors != 0 && colors != o.mesh.positions.len() {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: {colors} vertex colours for {n} vertices"),
                ));
            }
            if let Some(i) = o
                .mesh
                .colors
                .iter()
                .position(|c| !c.is_finite() || c.min_element() < 0.0 || c.max_element() > 1.0)
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: vertex colour {i} ({}) must be in [0, 1]",
                        o.mesh.colors[i]
                    ),
                ));
            }
            for (what, t) in [
                ("base colour", &o.material.base_color_texture),
                ("emissive", &o.material.emissive_texture),
            ] {
                if let Some(t) = t {
                    if t.tex_coord as usize >= o.mesh.uvs.len() {
                        return Err(SceneError::invalid(
                            path,
                            format!(
                                "{who}: the {what} texture reads TEXCOORD_{} but the mesh has {} texture coordinate set(s)",
                                t.tex_coord,
                                o.mesh.uvs.len()
                            ),
                        ));
                    }
                }
            }
            let r = o.material.reflectance;
            if !r.is_finite() || r.min_element() < 0.0 || r.max_element() >= 1.0 {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: reflectance {r} must be in [0, 1) (energy conservation)"),
                ));
            }
            let e = o.material.emitted_radiance;
            if !e.is_finite() || e.min_element() < 0.0 {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: emitted radiance {e} must be finite and >= 0"),
                ));
            }
            let scale = o.mesh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
            let eps = 1e-10 * scale * scale;
            let degenerate: Vec<usize> = (0..o.mesh.triangles.len())
                .filter(|&t| {
                    o.mesh.triangle_area(t).partial_cmp(&eps) != Some(std::cmp::Ordering::Greater)
                })
                .collect();
            if !degenerate.is_empty() {
                if !drop_degenerate {
                    return Err(SceneError::invalid(
                        path,
                        format!(
                            "{who}: {} zero-area triangle(s), first is triangle {} {:?} (use --drop-degenerate to skip them)",
                            degenerate.len(),
                            degenerate[0],
                            o.mesh.triangles[degenerate[0]]
                        ),
                    ));
                }
                self.warnings.push(format!(
                    "{who}: dropped {} zero-area triangle(s)",
                    degenerate.len()
                ));
                let mut k = 0;
                o.mesh.triangles.retain(|_| {
                    let keep = degenerate.binary_search(&k).is_err();
                    k += 1;
                    keep
                });
            }
            if o.mesh.triangles.is_empty() {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: has no triangles"),
                ));
            }
        }
        if !self.has_emitter() {
            self.warnings
                .push("the scene has no emitter: every result will be black".to_string());
        }
        Ok(())
    }
}
