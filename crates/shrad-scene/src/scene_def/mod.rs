//! The scene definition: one set of serde types for both syntaxes of a scene, the TOML
//! scene file (docs/scene-format.md, read by `scene_file.rs`) and Python's
//! `shrad.load_dict` (a dict turned into a [`Value`] tree, its numpy meshes into
//! [`ObjectDef::mesh_data`]), and the one [`SceneBuilder`] that checks them and makes the
//! [`Scene`] (punctual lights too: [`LightDef`]). A key therefore means the same, and is
//! refused with the same words, whichever syntax gave it (Mitsuba's XML and `load_dict`
//! share their plugin constructors likewise).

mod mesh_file;
mod object;
mod transform;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Deserialize;

use crate::{Camera, Mesh, Role, Scene, SceneError, SceneSettings};

pub use crate::scene_lights::LightDef;

/// The value tree a definition is read from; what a front end other than the TOML file
/// (Python's dicts) converts its data into.
pub use toml::{Table, Value};

/// `[camera]`: where the camera is and where it looks.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct CameraDef {
    /// Eye position.
    pub eye: [f32; 3],
    /// The point looked at.
    pub target: [f32; 3],
    /// Vertical field of view in degrees (default 40).
    pub yfov_deg: Option<f32>,
    /// Width over height of the picture (default: the picture's own).
    pub aspect_ratio: Option<f32>,
}

/// `[settings]`: how the scene is cut into patches, and solver settings for the CLI.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct SettingsDef {
    /// Patch edge length in scene units.
    pub patch_size: Option<f32>,
    /// About this many patches in all (instead of `patch_size`).
    pub patches: Option<usize>,
    /// `[settings.solver]`: the CLI's solver options by name.
    #[serde(default)]
    pub solver: BTreeMap<String, Value>,
}

/// `[environment]` (Python: `"environment"`): the sky, a uniform `radiance` or a map `file`.
#[derive(Deserialize, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentDef {
    /// Uniform radiance (linear RGB, W / (m^2 sr)).
    pub radiance: Option<[f32; 3]>,
    /// An equirectangular map (linear `.exr` or `.hdr`, top row +Y), relative to the scene
    /// file (Python: to the working directory).
    pub file: Option<String>,
    /// Rotation of the map about +Y in degrees (default 0).
    pub rotate_deg: Option<f32>,
    /// Factor on the radiance (default 1).
    pub scale: Option<f32>,
}

/// What an object is made from.
#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// Four `corners`.
    Quad,
    /// An axis-aligned box of `size`, faces out (or `inward`).
    Box,
    /// A UV sphere of `radius` with `segments`.
    Sphere,
    /// A glTF / OBJ / TOML `file`, or mesh data from a front end.
    Mesh,
}

/// How keyframes are interpolated.
#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
pub enum KeyInterpolation {
    /// Straight (translation), shortest arc (rotation), straight (emission).
    Linear,
    /// Each key holds until the next.
    Step,
}

/// `scale`: one factor or one per axis.
#[derive(Deserialize, Clone, Copy, Debug)]
#[serde(untagged, expecting = "a number or [x, y, z]")]
pub enum Scale {
    /// The same factor on every axis.
    Uniform(f32),
    /// A factor per axis.
    Axes([f32; 3]),
}

/// One `[[object]]` (Python: one entry of `objects`).
#[derive(Deserialize, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct ObjectDef {
    /// Its name (default `object<index>`).
    pub name: Option<String>,
    /// Boundary, interior or light (default: inferred).
    pub role: Option<Role>,
    /// What it is made from.
    pub shape: Option<Shape>,
    /// Quad: the four corners, counter-clockwise seen from the front.
    pub corners: Option<Vec<[f32; 3]>>,
    /// Box: width, height, depth.
    pub size: Option<[f32; 3]>,
    /// Box: faces point in (a room).
    pub inward: Option<bool>,
    /// Sphere: radius.
    pub radius: Option<f32>,
    /// Sphere: segments around (3..=512, default 32).
    pub segments: Option<u32>,
    /// Mesh: the file, relative to the scene file (Python: to the working directory).
    pub file: Option<String>,
    /// Mesh file: keep only the parts of this glTF node.
    pub node: Option<String>,
    /// Mesh file: keep only the parts of this mesh.
    pub mesh: Option<String>,
    /// Mesh file: play this glTF animation.
    pub animation: Option<String>,
    /// Diffuse reflectance (replaces a file's, texture included).
    pub reflectance: Option<[f32; 3]>,
    /// Emitted radiance (replaces a file's).
    pub emission: Option<[f32; 3]>,
    /// Lit and emitting on both sides.
    pub double_sided: Option<bool>,
    /// Rest transform: translation.
    pub position: Option<[f32; 3]>,
    /// Rest transform: rotation about X, then Y, then Z in degrees.
    pub rotation_deg: Option<[f32; 3]>,
    /// Rest transform: rotation as a quaternion `[x, y, z, w]`.
    pub rotation_quat: Option<[f32; 4]>,
    /// Rest transform: scale.
    pub scale: Option<Scale>,
    /// Rest transform as one affine 4x4 matrix (rows), instead of position / rotation /
    /// scale.
    pub transform: Option<[[f32; 4]; 4]>,
    /// This object's patch edge length (overrides the scene's).
    pub patch_size: Option<f32>,
    /// How its keys are interpolated.
    pub interpolation: Option<KeyInterpolation>,
    /// `[[object.key]]`: keyframes of its motion.
    #[serde(default)]
    pub key: Vec<KeyDef>,
    /// `[[object.emission_key]]`: keyframes of its emission.
    #[serde(default)]
    pub emission_key: Vec<EmissionKeyDef>,
    /// `[[object.reflectance_key]]`: keyframes of its reflectance (a surface painted).
    #[serde(default)]
    pub reflectance_key: Vec<ReflectanceKeyDef>,
    /// A mesh given as data by a front end instead of a `file` (Python's numpy
    /// `positions`, `triangles` and `colors`); no key of the TOML file.
    #[serde(skip)]
    pub mesh_data: Option<Mesh>,
}

/// One keyframe of an object's motion (on top of its rest transform).
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct KeyDef {
    /// Seconds.
    pub time: f32,
    /// Translation at this time (default 0).
    pub translation: Option<[f32; 3]>,
    /// Rotation at this time, degrees about X, then Y, then Z.
    pub rotation_deg: Option<[f32; 3]>,
    /// Rotation at this time as `[x, y, z, w]`.
    pub rotation_quat: Option<[f32; 4]>,
}

/// One keyframe of an object's emission.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct EmissionKeyDef {
    /// Seconds.
    pub time: f32,
    /// Emitted radiance at this time.
    pub emission: [f32; 3],
}

/// One keyframe of an object's reflectance.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct ReflectanceKeyDef {
    /// Seconds.
    pub time: f32,
    /// Reflectance factor at this time, each channel in [0, 1] (1 is read as 0.999).
    pub reflectance: [f32; 3],
}

/// A definition read from a value tree; a wrong key or type is an error that names its
/// key path (`"key.rotation_deg: invalid length 2, expected an array of length 3"`).
pub fn from_value<T: DeserializeOwned>(value: Value) -> Result<T, String> {
    T::deserialize(value).map_err(|e| {
        // The key path is in the error's text only ("message\nin `a.b`").
        let text = e.to_string();
        match text.trim_end().rsplit_once("\nin `") {
            Some((_, path)) => format!("{}: {}", path.trim_end_matches('`'), e.message()),
            None => e.message().to_string(),
        }
    })
}

/// Most triangles the primitive shapes (quads, boxes, spheres) of one scene may make
/// together: sixteen 512-segment spheres. Each sphere is bounded by its `segments` limit; this
/// bounds a small file repeating them (a 64 KB file holds a thousand such spheres).
const MAX_SHAPE_TRIANGLES: usize = 16 * 261_120;

/// Makes a [`Scene`] from definitions, checking each as it comes. No role inference or
/// validation: that is [`crate::load()`]'s (and `load_dict`'s) job once the scene is whole.
pub struct SceneBuilder {
    scene: Scene,
    base_dir: PathBuf,
    /// The scene files being read, outermost first, this one last (canonical paths): a
    /// file that includes one of them is a cycle.
    including: Vec<PathBuf>,
    shape_triangles: usize,
    /// Why a file a definition names could not be read, when that was the error: the
    /// message is a definition's (`object 2 'chair': ...`), the error a file's.
    unreadable: Option<std::io::ErrorKind>,
    /// The lights' names so far and their indices (a scan of the list for each light made
    /// 200,000 lights take five minutes).
    light_names: std::collections::HashMap<String, usize>,
}

impl SceneBuilder {
    /// An empty scene named `source` whose mesh files are found relative to `base_dir`.
    pub fn new(source: impl Into<String>, base_dir: &Path) -> SceneBuilder {
        SceneBuilder::nested(source, base_dir, Vec::new())
    }

    /// [`SceneBuilder::new`] for a scene file, read inside the scene files `including`
    /// (outermost first, itself last).
    pub(crate) fn nested(
        source: impl Into<String>,
        base_dir: &Path,
        including: Vec<PathBuf>,
    ) -> Self {
        SceneBuilder {
            scene: Scene {
                source: source.into(),
                ..Default::default()
            },
            base_dir: base_dir.to_path_buf(),
            including,
            shape_triangles: 0,
            unreadable: None,
            light_names: Default::default(),
        }
    }

    /// The error for a definition of the scene file `path` that failed with `message`: a
    /// file it names that could not be read stays an unreadable file (not found, permission
    /// denied: Python's `OSError`), anything else is an invalid scene.
    pub fn error(&self, path: &Path, message: String) -> SceneError {
        match self.unreadable {
            Some(kind) => SceneError::Unreadable {
                path: path.to_path_buf(),
                message,
                kind,
            },
            None => SceneError::invalid(path, message),
        }
    }

    /// A file a definition names failed to read with `e`: its message with its causes, and
    /// its kind kept for [`SceneBuilder::error`] when it is the file's OS error.
    fn nested_error(&mut self, e: &SceneError) -> String {
        self.unreadable = match e {
            SceneError::Io { source, .. } => Some(source.kind()),
            SceneError::Unreadable { kind, .. } => Some(*kind),
            _ => None,
        };
        with_causes(e)
    }

    /// Set the camera.
    pub fn camera(&mut self, c: &CameraDef) -> Result<(), String> {
        let eye = transform::finite3(c.eye, "eye")?;
        let target = transform::finite3(c.target, "target")?;
        if (target - eye).length() <= 0.0 {
            return Err("eye and target must differ".into());
        }
        let yfov = c.yfov_deg.unwrap_or(40.0);
        if !(yfov > 0.0 && yfov < 180.0) {
            return Err("yfov_deg must be in (0, 180)".into());
        }
        if c.aspect_ratio.is_some_and(|a| !(a > 0.0 && a.is_finite())) {
            return Err("aspect_ratio must be positive".into());
        }
        let mut cam = Camera::look_at(eye, target, yfov.to_radians());
        cam.aspect_ratio = c.aspect_ratio;
        self.scene.camera = Some(cam);
        Ok(())
    }

    /// Set the settings.
    pub fn settings(&mut self, s: SettingsDef) -> Result<(), String> {
        if s.patch_size.is_some() && s.patches.is_some() {
            return Err("give patch_size or patches, not both".into());
        }
        if s.patch_size.is_some_and(|h| !(h > 0.0 && h.is_finite())) {
            return Err("patch_size must be positive".into());
        }
        if s.patches == Some(0) {
            return Err("patches must be positive".into());
        }
        // Values as the command line would spell them (the CLI applies them as its options).
        let mut solver = BTreeMap::new();
        for (k, v) in s.solver {
            let v = match v {
                Value::String(s) => s,
                Value::Array(_) | Value::Table(_) => {
                    return Err(format!("solver.{k}: must be a string, number or boolean"))
                }
                other => other.to_string(),
            };
            solver.insert(k, v);
        }
        self.scene.settings = SceneSettings {
            patch_size: s.patch_size,
            patches: s.patches,
            solver,
        };
        Ok(())
    }

    /// Set the sky.
    pub fn environment(&mut self, e: &EnvironmentDef) -> Result<(), String> {
        let mut env = match (&e.radiance, &e.file) {
            (Some(_), Some(_)) => return Err("give radiance or file, not both".into()),
            (None, None) => return Err("needs 'radiance' (R, G, B) or 'file' (a map)".into()),
            (Some(r), None) => crate::Environment::uniform(glam::Vec3::from_array(*r)),
            (None, Some(f)) => {
                let path = self.base_dir.join(f);
                let map = crate::EnvMap::load(&path)
                    .map_err(|e| format!("file: {}", self.nested_error(&e)))?;
                crate::Environment::from_map(map)
            }
        };
        env.rotate_deg = e.rotate_deg.unwrap_or(0.0);
        env.scale = e.scale.unwrap_or(1.0);
        if let Some(p) = env.problem() {
            return Err(p);
        }
        self.scene.environment = Some(env);
        Ok(())
    }

    /// Add the objects one definition stands for (several for a multi-part mesh file);
    /// `index`, its place in the scene's list, names it when it has no name.
    pub fn object(&mut self, index: usize, def: ObjectDef) -> Result<(), String> {
        let shape = def
            .shape
            .ok_or("needs 'shape' (quad, box, sphere or mesh)")?;
        // An object is found by its name (`Engine::object`, Python, the viewer): two of one
        // name made the second unreachable, silently.
        if let Some(name) = def.name.as_deref() {
            if let Some(k) = self.scene.objects.iter().position(|o| o.name == name) {
                return Err(format!(
                    "the name '{name}' is already object {k}'s: names must be unique"
                ));
            }
        }
        let objects = object::build(self, index, shape, def)?;
        if shape != Shape::Mesh {
            self.shape_triangles += objects
                .iter()
                .map(|o| o.mesh.triangles.len())
                .sum::<usize>();
            if self.shape_triangles > MAX_SHAPE_TRIANGLES {
                return Err(format!(
                    "the file's quads, boxes and spheres make {} triangles by here, more than the {MAX_SHAPE_TRIANGLES} a scene file may build (use fewer segments)",
                    self.shape_triangles
                ));
            }
        }
        self.scene.objects.extend(objects);
        Ok(())
    }

    /// Add light `index` of the definition, checked ([`crate::Light::problem`]); its name
    /// must be unique among the lights (`set_light("bulb")` changed the first of two).
    pub fn light(&mut self, index: usize, def: &LightDef) -> Result<(), String> {
        let light = crate::scene_lights::light(def, index)?;
        if let Some(why) = light.problem() {
            return Err(why);
        }
        if let Some(k) = self.light_names.get(&light.name) {
            return Err(format!(
                "the name '{}' is already light {k}'s: names must be unique",
                light.name
            ));
        }
        if !light.name.is_empty() {
            let index = self.scene.lights.len();
            self.light_names.insert(light.name.clone(), index);
        }
        self.scene.lights.push(light);
        Ok(())
    }

    /// Objects added so far.
    pub fn object_count(&self) -> usize {
        self.scene.objects.len()
    }

    /// The scene made.
    pub fn finish(self) -> Scene {
        self.scene
    }
}

/// An error's message with its causes (`cannot read file: No such file or directory`): the
/// nested file's error becomes part of a message, where its cause would be lost.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        message = format!("{message}: {c}");
        cause = c.source();
    }
    message
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn def(text: &str) -> Result<ObjectDef, String> {
        from_value(Value::Table(text.parse::<Table>().unwrap()))
    }

    #[test]
    fn a_wrong_value_is_named_by_its_key_path() {
        let e = def("shape = 'box'\nkey = [{ time = 'soon' }]").unwrap_err();
        assert!(
            e.starts_with("key.time: invalid type: string \"soon\""),
            "{e}"
        );
        let e = def("shape = 'cone'").unwrap_err();
        assert!(e.starts_with("shape: unknown variant `cone`"), "{e}");
        let e = def("shape = 'box'\nscale = 'big'").unwrap_err();
        assert!(
            e.contains("scale: ") && e.contains("a number or [x, y, z]"),
            "{e}"
        );
        let e = def("shape = 'box'\ncolour = [1, 1, 1]").unwrap_err();
        assert!(e.starts_with("unknown field `colour`"), "{e}");
    }

    #[test]
    fn a_transform_is_the_rest_transform_it_spells() {
        let mut b = SceneBuilder::new("t", Path::new(""));
        let parts = "shape = 'box'\nsize = [1, 1, 1]\n";
        b.object(
            0,
            def(&format!("{parts}position = [1, 2, 3]\nscale = [2, 1, 1]")).unwrap(),
        )
        .unwrap();
        let rows = "[[2, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]]";
        b.object(1, def(&format!("{parts}transform = {rows}")).unwrap())
            .unwrap();
        let e = b
            .object(
                2,
                def(&format!("{parts}transform = {rows}\nscale = 2")).unwrap(),
            )
            .unwrap_err();
        assert_eq!(e, "give 'transform' or 'scale', not both");
        let not_affine = "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]";
        let e = b
            .object(3, def(&format!("{parts}transform = {not_affine}")).unwrap())
            .unwrap_err();
        assert!(e.contains("must be affine"), "{e}");
        // A negative scale mirrors, as the same matrix spelled out does; zero is refused.
        let mirror = "[[-2, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]]";
        let at = "position = [1, 2, 3]\nscale = ";
        b.object(4, def(&format!("{parts}{at}[-2, 1, 1]")).unwrap())
            .unwrap();
        b.object(5, def(&format!("{parts}transform = {mirror}")).unwrap())
            .unwrap();
        let e = b
            .object(6, def(&format!("{parts}{at}[2, 0, 1]")).unwrap())
            .unwrap_err();
        assert!(e.contains("non-zero on every axis"), "{e}");
        let scene = b.finish();
        let of = |k: usize| scene.objects[k].world_from_object;
        assert_eq!(of(0), of(1));
        assert_eq!(of(2), of(3));
        assert!(of(2).matrix3.determinant() < 0.0);
    }

    #[test]
    fn mesh_data_is_a_mesh_and_belongs_to_shape_mesh_only() {
        let mesh = crate::box_mesh(Vec3::splat(0.5), false);
        let mut b = SceneBuilder::new("t", Path::new(""));
        let mut with_data = def("shape = 'mesh'").unwrap();
        with_data.mesh_data = Some(mesh.clone());
        b.object(0, with_data.clone()).unwrap();
        let mut on_a_box = def("shape = 'box'\nsize = [1, 1, 1]").unwrap();
        on_a_box.mesh_data = Some(mesh.clone());
        let e = b.object(1, on_a_box).unwrap_err();
        assert_eq!(e, "'positions' does not apply to shape 'box'");
        let mut both = def("shape = 'mesh'\nfile = 'x.obj'").unwrap();
        both.mesh_data = Some(mesh.clone());
        assert!(b.object(2, both).unwrap_err().contains("not both"));
        let e = b.object(3, def("shape = 'mesh'").unwrap()).unwrap_err();
        assert!(e.contains("needs 'file'"), "{e}");
        assert_eq!(b.finish().objects[0].mesh, mesh);
    }
}
