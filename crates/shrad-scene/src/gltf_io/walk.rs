//! The default scene's node hierarchy walked into objects: each node's accumulated
//! transform, its animation, the first perspective camera (and what moves it), and its mesh (see `mesh`).

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
    /// Texels the file's textures may still decode to ([`crate::texture::MAX_FILE_TEXELS`] at first).
    pub(super) texels_left: u64,
    /// Each material once converted (None: the default material).
    pub(super) materials: HashMap<Option<usize>, Material>,
}

impl Walk<'_> {
    /// Give `object`, instanced by node `node`, its node animation if the node or an
    /// ancestor is animated; its rest transform becomes its pose at time 0.
    pub(super) fn animate(&self, object: &mut Object, node: usize) {
        if let Some(graph) = self.graph.as_ref().filter(|g| g.moves(node)) {
            let anim = crate::NodeAnimation {
                graph: graph.clone(),
                node,
                outer: Affine3A::IDENTITY,
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
        });
        self.scene.camera = self.scene.camera_at(0.0);
    }

    pub(super) fn node(
        &mut self,
        node: gltf::Node,
        parent: Mat4,
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
        if let Some(cam) = node.camera() {
            if self.scene.camera.is_none() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => {
                        let (_, r, t) = world.to_scale_rotation_translation();
                        self.scene.camera = Some(Camera {
                            world_from_camera: Affine3A::from_rotation_translation(
                                r.normalize(),
                                t,
                            ),
                            // A yfov of pi or more is allowed (warned about by
                            // `validate`); a perspective picture needs less.
                            yfov: p.yfov().min(179f32.to_radians()),
                            aspect_ratio: p.aspect_ratio(),
                        });
                        self.animate_camera(node.index());
                    }
                    gltf::camera::Projection::Orthographic(_) => self
                        .scene
                        .warnings
                        .push(format!("{node_label}: orthographic camera ignored")),
                }
            }
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(&node, &mesh, world, &node_label)?;
        }
        for child in node.children() {
            self.node(child, world, depth + 1)?;
        }
        Ok(())
    }
}
