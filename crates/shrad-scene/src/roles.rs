//! Role inference for imported meshes that carry none (spec section 3).

use crate::{Role, Scene};

/// Give every object without a role one: emissive objects are lights; an object whose
/// bounding box touches the scene's box and spans at least half of it on two axes is
/// boundary (a wall, floor or ceiling); the rest are interior. Returns how many were inferred.
pub fn infer_roles(scene: &mut Scene) -> usize {
    let Some(crate::Aabb { min: lo, max: hi }) = scene.bounds() else {
        return 0;
    };
    let ext = (hi - lo).max(glam::Vec3::splat(f32::MIN_POSITIVE));
    let touch = 0.01 * ext.length();
    let mut inferred = 0;
    for o in &mut scene.objects {
        if o.role.is_some() {
            continue;
        }
        inferred += 1;
        if o.material.is_emissive() {
            o.role = Some(Role::Light);
            continue;
        }
        let Some(crate::Aabb { min: olo, max: ohi }) = o.world_bounds() else {
            o.role = Some(Role::Interior);
            continue;
        };
        let touches = (olo - lo).min_element() <= touch || (hi - ohi).min_element() <= touch;
        let span = (ohi - olo) / ext;
        let wide_axes = span.to_array().iter().filter(|&&s| s >= 0.5).count();
        o.role = Some(if touches && wide_axes >= 2 {
            Role::Boundary
        } else {
            Role::Interior
        });
    }
    inferred
}

/// Warn of every single-sided boundary object that holds the other objects but whose
/// faces turn, on the whole, away from them: a room modelled as a closed box with its
/// normals out (Blender's default cube scaled up). Light inside meets the backs of its
/// faces, which absorb it and show black: the picture is black and the energy line says that
/// almost nothing is absorbed. A closed object with nothing inside (a model seen from
/// outside, a pedestal) is not warned of. Nothing is changed (which side is meant is the
/// author's to say).
pub fn warn_faces_turned_away(scene: &mut Scene) {
    let Some(centre) = scene.centre_of_the_held() else {
        return;
    };
    let holds = |o: &crate::Object| crate::model::holds(o, centre);
    let turned: Vec<String> = (scene.objects.iter().enumerate())
        .filter(|(_, o)| o.role == Some(Role::Boundary) && !o.material.double_sided)
        .filter(|(_, o)| holds(o) && !crate::model::faces_towards(o, centre))
        .map(|(i, o)| {
            format!(
                "object {i} '{}' is boundary (a wall, floor or ceiling) and holds the other \
                 objects, but its faces turn away from them: light inside meets their backs, \
                 which absorb it and show black; flip its normals (Blender: Mesh > Normals > \
                 Flip, or Recalculate Inside) or make its material double-sided",
                o.name
            )
        })
        .collect();
    scene.warnings.extend(turned);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A room as a closed box: its faces turned inwards, outwards, or outwards but
    /// double-sided, and mirrored (which turns a mesh's front); with a small box inside.
    fn room(inward: bool, double_sided: bool, mirrored: bool) -> Scene {
        let mut scene = crate::cornell_box();
        scene.objects.retain(|o| o.role == Some(Role::Interior));
        let mut room = scene.objects[0].clone();
        room.name = "room".into();
        room.role = Some(Role::Boundary);
        room.mesh = crate::builtin::box_mesh(glam::Vec3::splat(1000.0), inward != mirrored);
        if mirrored {
            room.world_from_object = glam::Affine3A::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0));
        } else {
            room.world_from_object = glam::Affine3A::IDENTITY;
        }
        room.material.double_sided = double_sided;
        scene.objects.push(room);
        scene
    }

    fn turned_away_warnings(mut scene: Scene) -> Vec<String> {
        warn_faces_turned_away(&mut scene);
        scene.warnings
    }

    #[test]
    fn a_room_whose_faces_turn_out_is_warned_of() {
        let warnings = turned_away_warnings(room(false, false, false));
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("'room'") && warnings[0].contains("flip its normals"));
        // Mirrored, an outward mesh faces in (and an inward one out).
        assert_eq!(turned_away_warnings(room(false, false, true)).len(), 0);
        assert_eq!(turned_away_warnings(room(true, false, true)).len(), 1);
    }

    #[test]
    fn an_inward_or_double_sided_room_and_the_builtins_are_not_warned_of() {
        assert!(turned_away_warnings(room(true, false, false)).is_empty());
        assert!(turned_away_warnings(room(false, true, false)).is_empty());
        // A closed object alone (a model seen from outside) holds nothing.
        let mut lone = room(false, false, false);
        lone.objects.retain(|o| o.role == Some(Role::Boundary));
        assert!(turned_away_warnings(lone).is_empty());
        // Nor a closed box under the others (a pedestal, its faces out as they should be).
        let mut pedestal = room(false, false, false);
        let base = pedestal.objects.last_mut().unwrap();
        base.mesh = crate::builtin::box_mesh(glam::Vec3::new(1000.0, 50.0, 1000.0), false);
        base.world_from_object = glam::Affine3A::from_translation(glam::Vec3::new(0.0, -50.0, 0.0));
        assert!(turned_away_warnings(pedestal).is_empty());
        for name in crate::builtin_names() {
            let scene = crate::builtin(name).unwrap();
            assert!(turned_away_warnings(scene).is_empty(), "{name}");
        }
    }

    #[test]
    fn cornell_roles_inferred_as_given() {
        let given = crate::cornell_box();
        let mut stripped = given.clone();
        for o in &mut stripped.objects {
            o.role = None;
        }
        infer_roles(&mut stripped);
        for (a, b) in given.objects.iter().zip(&stripped.objects) {
            assert_eq!(a.role, b.role, "object {}", a.name);
        }
    }
}
