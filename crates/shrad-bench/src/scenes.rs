//! The benchmark scenes: the built-in `room` at the paper's patch counts, for Tables 1-2
//! (8 interior objects, growing patch count) and Table 3 (one interior object grows), and
//! the room at a fixed patch count with more and more objects (issue 24: a moving frame
//! should not grow with the number of objects).

use serde::Serialize;
use shrad::scene::{room, RoomParams};
use shrad::vis::Backend;
use shrad::{Error, PatchSizing, World};

/// Which table of the paper a scene belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Table {
    /// Tables 1-2 (and the paper's Figure 3): 8 interior objects, growing patch count.
    Scaling,
    /// Table 3 (and the paper's Figure 2): one interior object grows.
    BigObject,
    /// Not in the paper: [`OBJECTS_PATCHES`] patches, [`OBJECT_COUNTS`] interior objects,
    /// the smallest box moving; the dispersive default only.
    Objects,
}

/// Interior objects of the [`Table::Objects`] scenes.
pub const OBJECT_COUNTS: [usize; 3] = [8, 32, 128];
/// Target patches of the [`Table::Objects`] scenes.
pub const OBJECTS_PATCHES: usize = 40_000;

/// The [`Table::Objects`] scenes: `objects-8`, `objects-32`, `objects-128`.
pub fn object_scenes() -> Vec<SceneSpec> {
    OBJECT_COUNTS
        .iter()
        .map(|&objects| SceneSpec {
            name: format!("objects-{objects}"),
            table: Table::Objects,
            params: RoomParams {
                objects,
                patches: OBJECTS_PATCHES,
                big_object_patches: None,
            },
        })
        .collect()
}

/// One benchmark scene: the built-in room with these parameters.
#[derive(Clone, Debug)]
pub struct SceneSpec {
    /// Short name used in the results.
    pub name: String,
    /// Table of the paper it reproduces.
    pub table: Table,
    /// Room parameters.
    pub params: RoomParams,
}

#[cfg(test)]
impl SceneSpec {
    /// A small room of `objects` objects and about `patches` patches, for tests.
    pub(crate) fn tiny(table: Table, objects: usize, patches: usize) -> SceneSpec {
        SceneSpec {
            name: "tiny".into(),
            table,
            params: RoomParams {
                objects,
                patches,
                big_object_patches: None,
            },
        }
    }
}

/// The scenes of the full run (`quick == false`: Tables 1-2, Table 3, the objects scenes)
/// or of `--quick` (the Tables 1-2 row nearest 75k patches and the objects scenes).
pub fn scenes(quick: bool) -> Vec<SceneSpec> {
    let scaling = [12_000, 26_000, 37_000, 63_000, 77_000, 129_000];
    // (total patches, patches of the big object): the paper's Table 3 range.
    let big: [(usize, usize); 5] = [
        (18_500, 280),
        (26_000, 4_000),
        (37_000, 16_000),
        (55_000, 32_000),
        (75_000, 64_000),
    ];
    let mut v: Vec<SceneSpec> = scaling
        .iter()
        .map(|&n| SceneSpec {
            name: format!("room-{}k", n / 1000),
            table: Table::Scaling,
            params: RoomParams {
                objects: 8,
                patches: n,
                big_object_patches: None,
            },
        })
        .collect();
    if quick {
        v.retain(|s| s.params.patches == 77_000);
        v.extend(object_scenes());
        return v;
    }
    v.extend(big.iter().map(|&(n, b)| SceneSpec {
        name: format!("big-{:.1}k-{}", n as f32 / 1000.0, b),
        table: Table::BigObject,
        // The target count is the scene's total, the big object's patches included.
        params: RoomParams {
            objects: 8,
            patches: n,
            big_object_patches: Some(b),
        },
    }));
    v.extend(object_scenes());
    v
}

/// Build a scene's world.
pub fn build_world(spec: &SceneSpec, backend: Backend) -> Result<World, Error> {
    let scene = room(&spec.params);
    let n = scene.settings.patches.unwrap_or(spec.params.patches);
    World::new(scene, PatchSizing::Count(n), backend)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shrad::scene::Role;

    #[test]
    fn quick_is_one_scene_near_75k_and_the_objects_scenes() {
        let s = scenes(true);
        assert_eq!(s.len(), 1 + OBJECT_COUNTS.len());
        assert_eq!(s[0].params.patches, 77_000);
        assert!(s[1..].iter().all(|s| s.table == Table::Objects));
        assert_eq!(scenes(false).len(), 11 + OBJECT_COUNTS.len());
    }

    /// The objects scenes have the counts asked for, at the same patch count, and each has
    /// a box to move.
    #[test]
    fn object_scenes_have_the_counts_asked_for() {
        let specs = object_scenes();
        let counts: Vec<usize> = specs.iter().map(|s| s.params.objects).collect();
        assert_eq!(counts, vec![8, 32, 128]);
        for spec in &specs {
            assert_eq!(spec.params.patches, 40_000);
            let scene = room(&spec.params);
            let interior: Vec<_> = scene
                .objects
                .iter()
                .filter(|o| o.role == Some(Role::Interior))
                .collect();
            assert_eq!(interior.len(), spec.params.objects, "{}", spec.name);
            assert!(interior.iter().any(|o| o.name.starts_with("box_")));
            assert_eq!(scene.settings.patches, Some(40_000));
        }
    }
}
