//! One object of the scene and its role in the dispersive method.

use glam::{Affine3A, Vec3};

use crate::{Animation, Material, Mesh};

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
    /// Its name, padded as asked (`{:<9}`: `write_str` ignored the width and `shrad info`'s
    /// table lost its columns).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
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
    /// Emission and base colour animated in the file (`KHR_animation_pointer` on its glTF
    /// material; the scene file's emission and reflectance keys go on top).
    pub material_tracks: Option<crate::MaterialTracks>,
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
            material_tracks: None,
            patch_size: None,
        }
    }

    /// The role, `Interior` if none was set or inferred.
    pub fn role(&self) -> Role {
        self.role.unwrap_or(Role::Interior)
    }

    /// World bounding box at rest.
    pub fn world_bounds(&self) -> Option<crate::Aabb> {
        // Point by point: a keyed object asks for it at every pose
        // (`world_from_object_at`), and a transformed copy of the mesh copied its triangles,
        // UVs and colours too.
        let m = self.world_from_object;
        crate::Aabb::from_points(self.mesh.positions.iter().map(|&p| m.transform_point3(p)))
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
        let centre = self.world_bounds().map_or(Vec3::ZERO, |b| b.centre());
        Affine3A::from_translation(translation + centre)
            * Affine3A::from_quat(rotation)
            * Affine3A::from_translation(-centre)
            * base
    }

    /// The material at time `t`: the file's emission and base colour tracks, then the
    /// scene file's emission and reflectance keys applied.
    pub fn material_at(&self, t: f32) -> Material {
        let mut m = self.material.clone();
        if let Some(tracks) = &self.material_tracks {
            m.emitted_radiance = tracks.emitted_radiance_at(t);
            if let Some(rho) = tracks.reflectance_at(t) {
                m.reflectance = rho;
            }
        }
        if let Some(e) = self.animation.as_ref().and_then(|a| a.emission_at(t)) {
            m.emitted_radiance = e;
        }
        if let Some(r) = self.animation.as_ref().and_then(|a| a.reflectance_at(t)) {
            m.reflectance = r.clamp(Vec3::ZERO, Vec3::splat(crate::MAX_REFLECTANCE));
        }
        m
    }

    /// Does anything about this object change over time?
    pub fn is_animated(&self) -> bool {
        self.node_animation.is_some()
            || self.material_tracks.is_some()
            || self.animation.as_ref().is_some_and(|a| {
                a.keys.len() > 1 || a.emission.len() > 1 || a.reflectance.len() > 1
            })
    }

    /// Time of the last key of either animation (0 for a static object).
    pub fn duration(&self) -> f32 {
        let a = self.animation.as_ref().map_or(0.0, Animation::duration);
        let n = self
            .node_animation
            .as_ref()
            .map_or(0.0, crate::NodeAnimation::duration);
        let e = self
            .material_tracks
            .as_ref()
            .map_or(0.0, crate::MaterialTracks::end);
        a.max(n).max(e)
    }
}
