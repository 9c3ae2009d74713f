//! What a client is told once, at connect: the `scene` message (objects, camera, lights,
//! sky, solvers, limits), the geometry, and the sky's map when there is one.

use axum::body::Bytes;
use glam::Vec3;
use serde_json::{json, Value};

use super::{EngineLoop, Intro};
use crate::inbox::Names;
use crate::{protocol, solvers};

impl EngineLoop {
    /// The intro every client gets.
    pub(super) fn intro(&self, probe_triangles: &[[u32; 3]]) -> Intro {
        let scene = &self.engine.world().scene;
        Intro {
            scene: self.scene_message(probe_triangles),
            geometry: Bytes::from(protocol::geometry(&self.mesh)),
            sky: scene
                .environment
                .as_ref()
                .and_then(crate::lights::sky_map)
                .map(Bytes::from),
            names: Names {
                objects: scene.objects.iter().map(|o| o.name.clone()).collect(),
                lights: scene.lights.iter().map(|l| l.name.clone()).collect(),
            },
        }
    }

    fn scene_message(&self, probe_triangles: &[[u32; 3]]) -> String {
        let world = self.engine.world();
        let p = &world.patches;
        let objects: Vec<Value> = world
            .scene
            .objects
            .iter()
            .enumerate()
            .map(|(o, object)| {
                let lfo = glam::Affine3A::from_mat3(p.local_from_object[o]);
                json!({
                    "name": object.name,
                    "role": p.object_role[o].name(),
                    "local_from_object": protocol::columns(lfo),
                    "emission": object.material.emitted_radiance.to_array(),
                    "reflectance": object.material.reflectance.to_array(),
                    "patches": p.range(o).len(),
                    "first_vertex": self.mesh.objects[o].first_vertex,
                })
            })
            .collect();
        let camera = world.scene.camera_or_default();
        let shrad::scene::Aabb { min: lo, max: hi } = world
            .scene
            .bounds()
            .unwrap_or(shrad::scene::Aabb::new(Vec3::ZERO, Vec3::ONE));
        protocol::message(
            "scene",
            json!({
                "source": world.scene.source,
                "patches": p.len(),
                "vertices": self.mesh.vertex_count(),
                "objects": objects,
                "camera": {
                    "world_from_camera": protocol::columns(camera.world_from_camera),
                    "yfov": camera.yfov,
                },
                "bounds": [lo.to_array(), hi.to_array()],
                "duration": self.duration(),
                "lights": crate::lights::lights_json(&self.engine),
                "sky": crate::lights::sky_json(world.scene.environment.as_ref()),
                "solvers": shrad::settings::SOLVERS,
                "presets": solvers::presets_json(),
                "probe_sphere": {
                    "directions": self.probe_dirs.iter().map(|d| d.to_array()).collect::<Vec<_>>(),
                    "triangles": probe_triangles,
                },
                "limits": {
                    "max_message_bytes": protocol::MAX_MESSAGE_BYTES,
                    "max_wire_bytes": protocol::MAX_WIRE_BYTES,
                    "max_in_flight_bytes": protocol::MAX_IN_FLIGHT_BYTES,
                },
            }),
        )
    }
}
