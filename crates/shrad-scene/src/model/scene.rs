//! A whole scene: its objects, camera and settings.

use glam::{Affine3A, Vec3};

use crate::{Object, Role};

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

    /// A camera that frames the box `(lo, hi)` for scenes that have none: from its front and
    /// above, the +Z side raised by about 27 degrees, looking at its centre. The front, as
    /// glTF has it ("the front of an asset faces +Z"; Blender's front view exported Y-up):
    /// a single-sided model seen from -Z shows only the backs of its faces, which are not
    /// drawn (Khronos' Triangle was a picture of the sky alone). Raised, so that a flat
    /// floor or table top (y up) is seen from above rather than edge-on. The box's
    /// bounding sphere fills the view's height.
    pub fn framing(lo: Vec3, hi: Vec3) -> Self {
        Camera::framing_from(lo, hi, Vec3::Z)
    }

    /// [`Camera::framing`] from the `side` (a horizontal unit vector) instead of +Z.
    pub fn framing_from(lo: Vec3, hi: Vec3, side: Vec3) -> Self {
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length();
        let yfov = 40f32.to_radians();
        // The distance at which the sphere fits the field of view exactly.
        let dist = (radius / (0.5 * yfov).sin()).max(1e-6);
        let towards_eye = (side + Vec3::new(0.0, 0.5, 0.0)).normalize();
        Camera::look_at(centre + towards_eye * dist, centre, yfov)
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
    /// Punctual lights (glTF `KHR_lights_punctual`, the scene file's `[[lights]]`).
    pub lights: Vec<crate::Light>,
    /// The sky (the scene file's `[environment]`, the CLI's `--sky` / `--env`): `None`,
    /// black.
    pub environment: Option<crate::Environment>,
    /// The scene's camera, if it has one (for a camera that moves: its pose at time 0).
    pub camera: Option<Camera>,
    /// What moves the camera: the glTF node holding it, when that node or an ancestor is
    /// animated (`None`: the camera stays where [`Scene::camera`] puts it). Use
    /// [`Scene::camera_at`] for the camera at a time.
    pub camera_animation: Option<crate::NodeAnimation>,
    /// The camera's keyed vertical field of view (radians; glTF `KHR_animation_pointer`
    /// `/cameras/{c}/perspective/yfov`, as Blender writes a keyed focal length): `None`, the
    /// camera's own. [`Scene::camera_at`] applies it.
    pub camera_yfov: Option<crate::Track<f32>>,
    /// Settings from the scene file.
    pub settings: SceneSettings,
    /// Non-fatal problems found while loading (printed by the CLI).
    pub warnings: Vec<String>,
    /// The glTF animations of the file (listed by `shrad info`; empty for other inputs).
    pub animations: Vec<crate::AnimationInfo>,
}

impl Scene {
    /// World bounding box of every object at rest.
    pub fn bounds(&self) -> Option<crate::Aabb> {
        self.objects
            .iter()
            .filter_map(|o| o.world_bounds())
            .reduce(crate::Aabb::union)
    }

    /// The scene's camera at time `t` (seconds): [`Scene::camera`] moved by
    /// [`Scene::camera_animation`] when it has one (the node's world transform at `t`,
    /// scale dropped), else [`Scene::camera`] as it is; its field of view
    /// [`Scene::camera_yfov`]'s at `t` when keyed.
    pub fn camera_at(&self, t: f32) -> Option<Camera> {
        let mut camera = self.camera?;
        if let Some(yfov) = &self.camera_yfov {
            // Kept a perspective one can draw, as the reader keeps the camera's own.
            camera.yfov = yfov.sample(t).clamp(1e-3, 179f32.to_radians());
        }
        let Some(anim) = &self.camera_animation else {
            return Some(camera);
        };
        let (_, rotation, translation) =
            anim.world_from_object_at(t).to_scale_rotation_translation();
        let world_from_camera =
            Affine3A::from_rotation_translation(rotation.normalize(), translation);
        if !world_from_camera.is_finite() {
            // A degenerate (zero-scale) pose of a parent: keep the rest pose.
            return Some(camera);
        }
        Some(Camera {
            world_from_camera,
            ..camera
        })
    }

    /// [`Scene::camera_or_default`] at time `t`: the scene's camera where
    /// [`Scene::camera_at`] puts it, or the default one (which does not move).
    pub fn camera_or_default_at(&self, t: f32) -> Camera {
        self.camera_at(t)
            .unwrap_or_else(|| self.camera_or_default())
    }

    /// The centre of the box of every object that is not boundary (what a room holds), if
    /// there is one.
    pub(crate) fn centre_of_the_held(&self) -> Option<Vec3> {
        let held = (self.objects.iter())
            .filter(|o| o.role != Some(Role::Boundary))
            .filter_map(crate::Object::world_bounds)
            .reduce(crate::Aabb::union)?;
        Some(0.5 * (held.min + held.max))
    }

    /// The scene's camera, or one that frames the scene. When a boundary object encloses
    /// the scene (a room: its faces look inward, or it is double-sided and holds the other
    /// objects), the camera stands
    /// inside it, near the -Z wall, looking in: from outside it would see only the room's
    /// outer side. A closed object alone (a glTF sample model's box) is framed from outside.
    pub fn camera_or_default(&self) -> Camera {
        self.camera.unwrap_or_else(|| {
            let crate::Aabb { min: lo, max: hi } = self
                .bounds()
                .unwrap_or(crate::Aabb::new(Vec3::splat(-1.0), Vec3::ONE));
            let ext = hi - lo;
            let centre = 0.5 * (lo + hi);
            // A double-sided object is a room only when it holds the others: alone (a
            // glTF model exported double-sided, as Blender does) it is framed from outside.
            let held = self.centre_of_the_held();
            let encloses = self.objects.iter().any(|o| {
                o.role == Some(Role::Boundary)
                    && o.world_bounds().is_some_and(|b| {
                        (b.min - lo).max_element() <= 1e-3 * ext.max_element()
                            && (hi - b.max).max_element() <= 1e-3 * ext.max_element()
                    })
                    && (faces_towards(o, centre)
                        || o.material.double_sided && held.is_some_and(|h| holds(o, h)))
            });
            if encloses {
                let eye = Vec3::new(centre.x, lo.y + 0.55 * ext.y, lo.z + 0.03 * ext.z);
                Camera::look_at(eye, centre, 60f32.to_radians())
            } else {
                Camera::framing_from(lo, hi, self.most_seen_side())
            }
        })
    }

    /// The side (+Z, -Z, +X or -X) from which a camera raised as [`Camera::framing`]'s sees
    /// the most of the faces' fronts less their backs (a back turned to it is a surface it
    /// looks through): +Z (glTF's front) unless another side shows a tenth of the scene's
    /// area more. A room of separate walls open on one side (an OBJ of the Cornell box, open
    /// towards -Z) is seen through its opening, not through the back of a wall; a closed
    /// object or room shows as much from every side and stays framed from +Z.
    fn most_seen_side(&self) -> Vec3 {
        let seen = |side: Vec3| {
            let eye = (side + Vec3::new(0.0, 0.5, 0.0)).normalize();
            (self.objects.iter())
                .map(|o| area_towards(o, eye))
                .sum::<f32>()
        };
        let area: f32 = self.objects.iter().map(world_area).sum();
        let front = seen(Vec3::Z);
        [Vec3::NEG_Z, Vec3::X, Vec3::NEG_X]
            .into_iter()
            .map(|side| (side, seen(side)))
            .filter(|&(_, seen)| seen > front + 0.1 * area)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(Vec3::Z, |(side, _)| side)
    }

    /// Length of the longest animation, the camera's included (0 for a static scene).
    pub fn duration(&self) -> f32 {
        let camera = self
            .camera_animation
            .as_ref()
            .map_or(0.0, crate::NodeAnimation::duration);
        let camera = camera.max(self.camera_yfov.as_ref().map_or(0.0, crate::Track::end));
        let camera = self
            .lights
            .iter()
            .map(crate::Light::duration)
            .fold(camera, f32::max);
        self.objects
            .iter()
            .map(Object::duration)
            .fold(camera, f32::max)
    }

    /// Is there any emitter (an emissive surface or a punctual light of positive strength)?
    pub fn has_emitter(&self) -> bool {
        let punctual = self
            .lights
            .iter()
            .any(|l| l.radiometric().max_element() > 0.0);
        let sky = self.environment.as_ref().is_some_and(|e| !e.is_black());
        punctual
            || sky
            || self.objects.iter().any(|o| {
                o.material.is_emissive()
                    || o.animation.as_ref().is_some_and(|a| {
                        a.emission
                            .iter()
                            .any(|k| k.emitted_radiance.max_element() > 0.0)
                    })
            })
    }
}

/// Whether `point` is strictly inside object `o`'s world box.
pub(crate) fn holds(o: &crate::Object, point: Vec3) -> bool {
    o.world_bounds()
        .is_some_and(|b| b.min.cmplt(point).all() && point.cmplt(b.max).all())
}

/// Whether object `o`'s faces look, on the whole (weighted by area), towards `centre`: a
/// room seen from inside rather than a closed object seen from outside.
pub(crate) fn faces_towards(o: &crate::Object, centre: Vec3) -> bool {
    // Twice the area along the front normal, against the way to the centre.
    let towards: f32 = front_triangles(o)
        .map(|(twice_area, [a, b, c])| twice_area.dot(centre - (a + b + c) / 3.0))
        .sum();
    towards > 0.0
}

/// Object `o`'s triangles in the world: each one's normal scaled by twice its area, towards
/// its front (counter-clockwise in its own frame, so a mirroring transform turns it), and its
/// corners.
fn front_triangles(o: &crate::Object) -> impl Iterator<Item = (Vec3, [Vec3; 3])> + '_ {
    let m = o.world_from_object;
    let side = m.matrix3.determinant().signum();
    let p = move |i: u32| m.transform_point3(o.mesh.positions[i as usize]);
    (o.mesh.triangles.iter()).map(move |t| {
        let [a, b, c] = t.map(p);
        ((b - a).cross(c - a) * side, [a, b, c])
    })
}

/// Object `o`'s area as seen from far along `eye` (a unit vector towards the eye): each
/// triangle's area times the cosine of its front's normal with `eye`, negative where its
/// back is turned to the eye (positive both ways for a double-sided material).
fn area_towards(o: &crate::Object, eye: Vec3) -> f32 {
    front_triangles(o)
        .map(|(twice_area, _)| {
            let seen = 0.5 * twice_area.dot(eye);
            match o.material.double_sided {
                true => seen.abs(),
                false => seen,
            }
        })
        .sum()
}

/// Object `o`'s area in the world.
fn world_area(o: &crate::Object) -> f32 {
    front_triangles(o)
        .map(|(twice_area, _)| 0.5 * twice_area.length())
        .sum()
}
