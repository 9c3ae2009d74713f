//! The default scene's node hierarchy walked into objects: each node's accumulated
//! transform, its animation, the first perspective camera (and what moves it), its punctual
//! light (see `lights`), and its mesh (see `mesh`).

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Affine3A, Mat4};
use serde_json::Value;

use super::PartNames;
use crate::{Camera, Material, NodeGraph, Object, Scene, SceneError, TextureImage};

/// Deepest node hierarchy accepted (guards against cyclic node graphs).
const MAX_DEPTH: usize = 512;

/// What the walk reads from and what it builds.
pub(super) struct Walk<'a> {
    /// The node hierarchy with the animations that play (None: nothing moves).
    pub(super) graph: Option<Arc<NodeGraph>>,
    /// `[l]`: the animated properties of the file's light `l` (`KHR_animation_pointer`).
    pub(super) light_tracks: Vec<crate::LightTracks>,
    /// `[m]`: the animated emission of the file's material `m` (`KHR_animation_pointer`).
    pub(super) material_tracks: Vec<crate::MaterialTracks>,
    /// Camera `c`'s keyed `yfov` (`KHR_animation_pointer`), by `c`.
    pub(super) camera_yfov: HashMap<usize, crate::Track<f32>>,
    pub(super) path: &'a Path,
    pub(super) base: &'a Path,
    pub(super) doc: &'a gltf::Document,
    /// The accessors, bufferViews and textures of the raw JSON (checked by [`super::validate::check_json`]).
    pub(super) json: &'a Value,
    pub(super) buffers: &'a [gltf::buffer::Data],
    pub(super) scene: Scene,
    pub(super) names: Vec<PartNames>,
    /// Each image source decoded once (None: could not be loaded), shared by the materials.
    pub(super) textures: HashMap<super::material::ImageSource, Option<Arc<TextureImage>>>,
    /// What the file's textures may still decode to.
    pub(super) texels: crate::texture::TexelBudget,
    /// Each material once converted (None: the default material).
    pub(super) materials: HashMap<Option<usize>, Material>,
    /// The images an `alphaMode: MASK` material uses as its base colour: decoded with their
    /// alpha plane (see `cutout`).
    pub(super) mask_images: std::collections::HashSet<super::material::ImageSource>,
    /// Triangles the MASK cut-outs may still add ([`crate::cutout::MAX_ADDED`] at first).
    pub(super) cutout_left: usize,
    /// Whether that cap was reached (warned once).
    pub(super) cutout_capped: bool,
    /// The file's punctual lights and which node instances which.
    pub(super) file_lights: super::lights::FileLights,
    /// The file's skins and each node's, with every node's rest transform.
    pub(super) skins: super::skin::FileSkins,
    /// The instanced nodes' instances (`EXT_mesh_gpu_instancing`, see `instancing`).
    pub(super) instances: super::instancing::FileInstances,
    /// Each node's own `visible` (`KHR_node_visibility`, see `visibility`).
    pub(super) visible: Vec<bool>,
    /// What the walk skipped, for the message when nothing is left to light.
    pub(super) skipped: Skipped,
}

/// Primitives and triangles a walk left out (each with a warning).
#[derive(Debug, Default)]
pub(super) struct Skipped {
    /// Primitives of points or lines.
    pub not_triangles: usize,
    /// Zero-area triangles dropped.
    pub zero_area_triangles: usize,
    /// Primitives all of whose triangles have zero area.
    pub zero_area_primitives: usize,
    /// Primitives without POSITION (in the file: the gltf crate never sees them).
    pub no_position: usize,
    /// Primitives whose data is not in the file (a buffer without data).
    pub no_data: usize,
}

impl Walk<'_> {
    /// Node `n`'s name, or `node{n}`.
    pub(super) fn node_name(&self, n: usize) -> String {
        let node = self.doc.nodes().nth(n);
        (node.and_then(|node| node.name().map(str::to_string))).unwrap_or(format!("node{n}"))
    }

    /// Give `object`, drawn by node `node` (at `inner` in the node's frame: an instance's
    /// own transform, else the identity), its node animation if the node or an ancestor is
    /// animated; its rest transform becomes its pose at time 0.
    pub(super) fn animate(&self, object: &mut Object, node: usize, inner: Affine3A) {
        if let Some(graph) = self.graph.as_ref().filter(|g| g.moves(node)) {
            let anim = crate::NodeAnimation {
                graph: graph.clone(),
                node,
                outer: Affine3A::IDENTITY,
                inner,
            };
            object.world_from_object = anim.world_from_object_at(0.0);
            object.node_animation = Some(anim);
        }
    }

    /// When the camera's node `node` or an ancestor is animated, the scene's camera follows
    /// it: [`Scene::camera_animation`] holds the node and the camera becomes its pose at
    /// time 0, as an animated object's rest transform does.
    fn animate_camera(&mut self, node: usize) {
        let Some(graph) = self.graph.as_ref().filter(|g| g.moves(node)) else {
            return;
        };
        self.scene.camera_animation = Some(crate::NodeAnimation {
            graph: graph.clone(),
            node,
            outer: Affine3A::IDENTITY,
            inner: Affine3A::IDENTITY,
        });
        self.scene.camera = self.scene.camera_at(0.0);
    }

    /// Put light `l` of the file on node `node` (world transform `world`), following the
    /// node's animation when it or an ancestor is animated, and its animated properties.
    fn light(&mut self, l: usize, node: usize, world: Mat4) {
        let Some(mut light) = self.file_lights.lights[l].clone() else {
            return;
        };
        light.world_from_light = Affine3A::from_mat4(world);
        light.tracks = self.light_tracks.get(l).filter(|k| !k.is_empty()).cloned();
        if let Some(graph) = self.graph.as_ref().filter(|g| g.moves(node)) {
            let anim = crate::NodeAnimation {
                graph: graph.clone(),
                node,
                outer: Affine3A::IDENTITY,
                inner: Affine3A::IDENTITY,
            };
            light.world_from_light = anim.world_from_object_at(0.0);
            light.node_animation = Some(anim);
        }
        self.scene.lights.push(light);
    }

    /// Whether a node's `world` transform flattens its mesh to a plane, a line or a point
    /// (a scale of zero is how glTF, and Blender's exporter, hide a node): then its mesh is
    /// left out, with a warning, rather than the whole file refused.
    fn hidden(&mut self, world: &Mat4, node_label: &str) -> bool {
        let m = glam::Mat3::from_mat4(*world);
        if !crate::model::is_singular(&m) {
            return false;
        }
        self.scene.warnings.push(format!(
            "{node_label}: its scale is zero, or all but, along some axis (a hidden node): its mesh is left out"
        ));
        true
    }

    /// Walk `node` (child of `parent_node`, whose world transform is `parent`; `shown`:
    /// whether the parent is visible, `KHR_node_visibility`) and its descendants.
    pub(super) fn node(
        &mut self,
        node: gltf::Node,
        parent_node: Option<&gltf::Node>,
        (parent, shown): (Mat4, bool),
        depth: usize,
    ) -> Result<(), SceneError> {
        if depth > MAX_DEPTH {
            return Err(SceneError::invalid(
                self.path,
                format!("nodes[{}]: hierarchy deeper than {MAX_DEPTH}", node.index()),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_label = match node.name() {
            Some(n) => format!("nodes[{}] '{n}'", node.index()),
            None => format!("nodes[{}]", node.index()),
        };
        if !world.is_finite() {
            return Err(SceneError::invalid(
                self.path,
                format!("{node_label}: transform is not finite"),
            ));
        }
        // Cameras are not hidden (KHR_node_visibility); meshes and lights are.
        self.camera(&node, world, &node_label);
        let visible = shown && self.visible.get(node.index()).copied().unwrap_or(true);
        if shown && !visible {
            self.scene.warnings.push(format!(
                "{node_label}: hidden ({}): its meshes and lights, and its descendants', are left out",
                super::visibility::EXTENSION
            ));
        }
        if let Some(&Some(l)) = self
            .file_lights
            .node_light
            .get(node.index())
            .filter(|_| visible)
        {
            self.light(l, node.index(), world);
        }
        if let Some(mesh) = node.mesh().filter(|_| visible) {
            self.node_mesh(&node, parent_node, &mesh, world, node_label)?;
        }
        for child in node.children() {
            self.node(child, Some(&node), (world, visible), depth + 1)?;
        }
        Ok(())
    }

    /// The scene's camera from `node` (world transform `world`), if it has the first
    /// perspective camera of the walk.
    fn camera(&mut self, node: &gltf::Node, world: Mat4, node_label: &str) {
        let Some(cam) = node.camera().filter(|_| self.scene.camera.is_none()) else {
            return;
        };
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let (_, r, t) = world.to_scale_rotation_translation();
                self.scene.camera = Some(Camera {
                    world_from_camera: Affine3A::from_rotation_translation(r.normalize(), t),
                    // A yfov of pi or more is allowed (warned about by `validate`); a
                    // perspective picture needs less.
                    yfov: p.yfov().min(179f32.to_radians()),
                    aspect_ratio: p.aspect_ratio(),
                });
                self.scene.camera_yfov = self.camera_yfov.get(&cam.index()).cloned();
                self.animate_camera(node.index());
            }
            gltf::camera::Projection::Orthographic(_) => self
                .scene
                .warnings
                .push(format!("{node_label}: orthographic camera ignored")),
        }
    }
}

impl Walk<'_> {
    /// Draw `mesh`, the mesh of `node` (world transform `world`): once, or once per
    /// instance of an instanced node (`instancing`), each at the node's transform times its
    /// own.
    fn node_mesh(
        &mut self,
        node: &gltf::Node,
        parent_node: Option<&gltf::Node>,
        mesh: &gltf::Mesh,
        world: Mat4,
        node_label: String,
    ) -> Result<(), SceneError> {
        // A skinned mesh is placed by its skin, whatever the node's own transform (glTF 2.0,
        // "Skins"): a zero scale there hides nothing, and its instances would all be placed
        // alike (it is drawn once, with a warning).
        let skin = self.skins.of_node(node.index());
        let mut instances = self.instances.of_node(node.index()).map(<[Mat4]>::to_vec);
        if instances.is_some() && skin.is_some() {
            self.scene.warnings.push(format!(
                "{node_label}: a skinned mesh drawn by instances ({}) is drawn once, where its skin puts it",
                super::instancing::EXTENSION
            ));
            instances = None;
        }
        let places: Vec<Option<(usize, Mat4)>> = match instances {
            Some(list) => list.into_iter().enumerate().map(Some).collect(),
            None => vec![None],
        };
        for instance in places {
            let (label, world) = match instance {
                Some((k, m)) => (format!("{node_label} instance {k}"), world * m),
                None => (node_label.clone(), world),
            };
            if skin.is_none() && self.hidden(&world, &label) {
                continue;
            }
            let inst = super::mesh::Instance {
                node: Some(node),
                parent: parent_node,
                world,
                instance,
                skin,
                label,
            };
            self.mesh(&inst, mesh)?;
        }
        Ok(())
    }

    /// Walk the default scene (else the first), or, in a file without scenes, every root
    /// node and then every mesh that no node instances, once at the origin. A scene left
    /// with nothing to light is empty, with a warning saying why.
    pub(super) fn scene(&mut self) -> Result<(), SceneError> {
        let doc = self.doc;
        let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().collect(),
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for c in doc.nodes().flat_map(|n| n.children()) {
                    is_child[c.index()] = true;
                }
                if doc.nodes().len() > 0 {
                    self.scene
                        .warnings
                        .push("glTF has no scene: taking every root node".into());
                }
                doc.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        for node in roots {
            self.node(node, None, (Mat4::IDENTITY, true), 0)?;
        }
        if doc.scenes().len() == 0 {
            self.library_meshes()?;
        }
        // A valid file loads even when nothing in it can be lit, as a viewer opens it
        // empty: the scene is returned without objects, saying why.
        if self.scene.objects.is_empty() {
            let why = self.nothing_to_light();
            self.scene.warnings.push(why);
        }
        Ok(())
    }

    /// glTF 2.0, "Scenes": "A glTF asset that does not contain any scenes SHOULD be treated
    /// as a library of individual entities such as materials or meshes." Such a file is
    /// what a user opens to see its meshes (the validator's own test files are written so,
    /// and exporters of single meshes too); a mesh no node instances is the library's
    /// entity as it is, so it is placed once at the origin, untransformed, with a warning
    /// naming it. A file with a scene draws what its scene says: a mesh outside it stays out.
    fn library_meshes(&mut self) -> Result<(), SceneError> {
        let doc = self.doc;
        let mut used = vec![false; doc.meshes().len()];
        for m in doc.nodes().filter_map(|n| n.mesh()) {
            used[m.index()] = true;
        }
        let free: Vec<gltf::Mesh> = doc.meshes().filter(|m| !used[m.index()]).collect();
        if free.is_empty() {
            return Ok(());
        }
        let names: Vec<String> = free
            .iter()
            .map(|m| match m.name() {
                Some(n) => format!("meshes[{}] '{n}'", m.index()),
                None => format!("meshes[{}]", m.index()),
            })
            .collect();
        self.scene.warnings.push(format!(
            "glTF has no scene (a library of meshes): {} that no node instances placed once at the origin",
            names.join(", ")
        ));
        for m in free {
            let inst = super::mesh::Instance {
                node: None,
                parent: None,
                world: Mat4::IDENTITY,
                instance: None,
                skin: None,
                label: "placed at the origin".into(),
            };
            self.mesh(&inst, &m)?;
        }
        Ok(())
    }

    /// Why a walk that made no object has nothing to light.
    fn nothing_to_light(&self) -> String {
        let n = self.doc.meshes().len();
        let s = &self.skipped;
        let mut parts = Vec::new();
        if s.zero_area_primitives > 0 {
            parts.push(format!(
                "{} triangle(s) of zero area in {} primitive(s)",
                s.zero_area_triangles, s.zero_area_primitives
            ));
        }
        if s.not_triangles > 0 {
            parts.push(format!(
                "{} primitive(s) of points or lines",
                s.not_triangles
            ));
        }
        if s.no_position > 0 {
            parts.push(format!(
                "{} primitive(s) without POSITION in the file",
                s.no_position
            ));
        }
        if s.no_data > 0 {
            parts.push(format!(
                "{} primitive(s) whose data is not in the file",
                s.no_data
            ));
        }
        match parts.len() {
            0 => format!(
                "nothing to light: no node of the scene instances a triangle mesh (the file has {n} mesh(es)); the scene is empty"
            ),
            1 if s.zero_area_primitives > 0 => format!(
                "nothing to light: every triangle the scene draws has zero area ({} triangle(s) in {} primitive(s), dropped); the scene is empty",
                s.zero_area_triangles, s.zero_area_primitives
            ),
            _ => format!(
                "nothing to light: the scene draws no triangle with area (skipped: {}); the scene is empty",
                parts.join(", ")
            ),
        }
    }
}
