//! Built-in scenes: the Cornell box and a parameterised room for scaling studies.

use glam::{Affine3A, Quat, Vec3};

use crate::{Camera, Material, Mesh, Object, Role, Scene, SceneError};

/// Names accepted by [`builtin`].
pub fn builtin_names() -> &'static [&'static str] {
    &["cornell", "room"]
}

/// A built-in scene by name. `room` takes [`RoomParams::default`].
pub fn builtin(name: &str) -> Result<Scene, SceneError> {
    match name {
        "cornell" => Ok(cornell_box()),
        "room" => Ok(room(&RoomParams::default())),
        _ => Err(SceneError::invalid(
            format!("builtin:{name}"),
            format!(
                "no built-in scene '{name}' (known: {})",
                builtin_names().join(", ")
            ),
        )),
    }
}

/// A planar quad `p0, p1, p2, p3` (counter-clockwise from the front) as two triangles.
pub fn quad(p: [Vec3; 4]) -> Mesh {
    Mesh::new(p.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

/// An axis-aligned box of half extents `half` centred at the origin; faces point outward
/// (or inward when `inward`).
pub fn box_mesh(half: Vec3, inward: bool) -> Mesh {
    let mut mesh = Mesh::default();
    // Each face: normal axis, sign; corners counter-clockwise seen from outside.
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|i| if i == axis { sign } else { 0.0 }));
            let u = Vec3::from_array(std::array::from_fn(|i| {
                if i == (axis + 1) % 3 {
                    1.0
                } else {
                    0.0
                }
            }));
            let v = n.cross(u);
            let c = n * half;
            let hu = u * half;
            let hv = v * half;
            let mut corners = [c - hu - hv, c + hu - hv, c + hu + hv, c - hu + hv];
            if inward {
                corners.reverse();
            }
            mesh.append(&quad(corners));
        }
    }
    mesh
}

/// A UV sphere of radius `r` with `segments` around and `segments / 2` from pole to pole.
pub(crate) fn sphere_mesh(r: f32, segments: u32) -> Mesh {
    let rings = (segments / 2).max(2);
    let segments = segments.max(3);
    let mut positions = vec![Vec3::new(0.0, r, 0.0)];
    for i in 1..rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            positions.push(
                r * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    -theta.sin() * phi.sin(),
                ),
            );
        }
    }
    positions.push(Vec3::new(0.0, -r, 0.0));
    let bottom = positions.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + (j % segments);
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([bottom, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j + 1),
                ring(i + 1, j),
            );
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    Mesh::new(positions, triangles)
}

fn object(name: &str, mesh: Mesh, material: Material, role: Role) -> Object {
    let mut o = Object::new(name, mesh, material);
    o.role = Some(role);
    o
}

/// The usual Cornell box reflectances (as in the Mitsuba and pbrt scenes).
pub mod cornell_colors {
    use glam::Vec3;
    /// White walls.
    pub const WHITE: Vec3 = Vec3::new(0.725, 0.71, 0.68);
    /// Left wall.
    pub const RED: Vec3 = Vec3::new(0.63, 0.065, 0.05);
    /// Right wall.
    pub const GREEN: Vec3 = Vec3::new(0.14, 0.45, 0.091);
    /// Emitted radiance of the light.
    pub const LIGHT: Vec3 = Vec3::new(17.0, 12.0, 4.0);
}

/// A rotated box standing on the floor (y = 0), from the Cornell data's top-face corners
/// (counter-clockwise seen from above) and its height. The box's own frame is axis-aligned
/// with its faces, so its probe box is tight.
fn cornell_block(top: [[f32; 2]; 4], height: f32) -> (Mesh, Affine3A) {
    let p = top.map(|[x, z]| Vec3::new(x, 0.0, z));
    let centre = 0.25 * (p[0] + p[1] + p[2] + p[3]);
    let u = p[1] - p[0];
    let v = p[3] - p[0];
    let angle = (-u.z).atan2(u.x);
    let half = Vec3::new(0.5 * u.length(), 0.5 * height, 0.5 * v.length());
    let world_from_object = Affine3A::from_rotation_translation(
        Quat::from_rotation_y(angle),
        centre + Vec3::Y * 0.5 * height,
    );
    (box_mesh(half, false), world_from_object)
}

/// The Cornell box: 556 x 548.8 x 559.2 (x, y, z), open towards -z where the camera is,
/// red wall at x = 556 (left in the camera's view), green at x = 0, the 130 x 105 light just
/// below the ceiling, and the short and tall blocks, after the Cornell University data.
pub fn cornell_box() -> Scene {
    use cornell_colors::*;
    let (w, h, d) = (556.0f32, 548.8f32, 559.2f32);
    let v = Vec3::new;
    let white = Material::diffuse(WHITE);
    let mut objects = vec![
        object(
            "floor",
            quad([v(0., 0., 0.), v(0., 0., d), v(w, 0., d), v(w, 0., 0.)]),
            white.clone(),
            Role::Boundary,
        ),
        object(
            "ceiling",
            quad([v(0., h, 0.), v(w, h, 0.), v(w, h, d), v(0., h, d)]),
            white.clone(),
            Role::Boundary,
        ),
        object(
            "back",
            quad([v(0., 0., d), v(0., h, d), v(w, h, d), v(w, 0., d)]),
            white.clone(),
            Role::Boundary,
        ),
        object(
            "left_red",
            quad([v(w, 0., 0.), v(w, 0., d), v(w, h, d), v(w, h, 0.)]),
            Material::diffuse(RED),
            Role::Boundary,
        ),
        object(
            "right_green",
            quad([v(0., 0., 0.), v(0., h, 0.), v(0., h, d), v(0., 0., d)]),
            Material::diffuse(GREEN),
            Role::Boundary,
        ),
    ];
    let light_y = h - 0.5;
    let mut light = Material::diffuse(Vec3::ZERO);
    light.emitted_radiance = LIGHT;
    objects.push(object(
        "light",
        quad([
            v(213., light_y, 227.),
            v(343., light_y, 227.),
            v(343., light_y, 332.),
            v(213., light_y, 332.),
        ]),
        light,
        Role::Light,
    ));
    let (short_mesh, short_xf) = cornell_block(
        [[290., 114.], [130., 65.], [82., 225.], [240., 272.]],
        165.0,
    );
    let mut short = object("short_block", short_mesh, white.clone(), Role::Interior);
    short.world_from_object = short_xf;
    let (tall_mesh, tall_xf) = cornell_block(
        [[472., 406.], [423., 247.], [265., 296.], [314., 456.]],
        330.0,
    );
    let mut tall = object("tall_block", tall_mesh, white.clone(), Role::Interior);
    tall.world_from_object = tall_xf;
    objects.push(short);
    objects.push(tall);
    let camera = Camera::look_at(
        v(278., 273., -800.),
        v(278., 273., 0.),
        39.3077f32.to_radians(),
    );
    Scene {
        source: "builtin:cornell".into(),
        objects,
        camera: Some(Camera {
            aspect_ratio: Some(1.0),
            ..camera
        }),
        ..Default::default()
    }
}

/// Parameters of the built-in `room`.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomParams {
    /// Number of interior objects (boxes and spheres on the floor).
    pub objects: usize,
    /// Target total patch count (sets the scene's patch size).
    pub patches: usize,
    /// Patch count of one object grown separately (the paper's Table 3 series), if any: the
    /// first interior object gets its own patch size to reach it.
    pub big_object_patches: Option<usize>,
}

impl Default for RoomParams {
    fn default() -> Self {
        RoomParams {
            objects: 8,
            patches: 20_000,
            big_object_patches: None,
        }
    }
}

/// A closed 8 x 3 x 6 room with a square ceiling light and `objects` interior objects on
/// the floor (boxes and spheres of several colours and sizes, some rotated), for scaling
/// studies. The patch count is set through the scene's settings.
pub fn room(params: &RoomParams) -> Scene {
    let size = Vec3::new(8.0, 3.0, 6.0);
    let mut objects = room_walls(size);
    objects.push(room_light(size));
    objects.extend((0..params.objects).map(|i| room_object(size, params.objects, i)));
    let v = Vec3::new;
    let mut scene = Scene {
        source: "builtin:room".into(),
        objects,
        camera: Some(Camera::look_at(
            v(0.25, 2.7, 0.25),
            v(5.2, 0.4, 4.4),
            65f32.to_radians(),
        )),
        ..Default::default()
    };
    scene.settings.patches = Some(params.patches);
    if let Some(big) = params.big_object_patches {
        if let Some(o) = scene
            .objects
            .iter_mut()
            .find(|o| o.role == Some(Role::Interior))
        {
            o.patch_size = Some((o.mesh.area() / big.max(1) as f32).sqrt());
        }
    }
    scene
}

/// The room's six walls, facing in: a floor at y = 0 and `size` = (width, height, depth).
fn room_walls(size: Vec3) -> Vec<Object> {
    let v = Vec3::new;
    let (w, h, d) = (size.x, size.y, size.z);
    let wall = |name: &str, p: [Vec3; 4], rho: Vec3| {
        object(name, quad(p), Material::diffuse(rho), Role::Boundary)
    };
    vec![
        wall(
            "floor",
            [v(0., 0., 0.), v(0., 0., d), v(w, 0., d), v(w, 0., 0.)],
            v(0.6, 0.55, 0.5),
        ),
        wall(
            "ceiling",
            [v(0., h, 0.), v(w, h, 0.), v(w, h, d), v(0., h, d)],
            v(0.8, 0.8, 0.8),
        ),
        wall(
            "back",
            [v(0., 0., d), v(0., h, d), v(w, h, d), v(w, 0., d)],
            v(0.7, 0.7, 0.7),
        ),
        wall(
            "front",
            [v(0., 0., 0.), v(w, 0., 0.), v(w, h, 0.), v(0., h, 0.)],
            v(0.7, 0.7, 0.7),
        ),
        wall(
            "left",
            [v(w, 0., 0.), v(w, 0., d), v(w, h, d), v(w, h, 0.)],
            v(0.7, 0.2, 0.15),
        ),
        wall(
            "right",
            [v(0., 0., 0.), v(0., h, 0.), v(0., h, d), v(0., 0., d)],
            v(0.15, 0.5, 0.2),
        ),
    ]
}

/// The ceiling light: a 1.4-wide square just under the middle of the ceiling.
fn room_light(size: Vec3) -> Object {
    let v = Vec3::new;
    let (lx, lz, ls) = (0.5 * size.x, 0.5 * size.z, 0.7f32);
    let ly = size.y - 0.01;
    let mut light = Material::diffuse(Vec3::ZERO);
    light.emitted_radiance = Vec3::splat(8.0);
    object(
        "light",
        quad([
            v(lx - ls, ly, lz - ls),
            v(lx + ls, ly, lz - ls),
            v(lx + ls, ly, lz + ls),
            v(lx - ls, ly, lz + ls),
        ]),
        light,
        Role::Light,
    )
}

/// Interior object `i` of `n` on the floor of a room of `size`: the objects stand on a
/// grid of cells, every third a sphere, the others turned boxes of two heights.
fn room_object(size: Vec3, n: usize, i: usize) -> Object {
    let v = Vec3::new;
    let (w, d) = (size.x, size.z);
    let palette = [
        v(0.8, 0.3, 0.2),
        v(0.2, 0.4, 0.8),
        v(0.85, 0.8, 0.3),
        v(0.3, 0.7, 0.4),
        v(0.75, 0.75, 0.75),
        v(0.6, 0.3, 0.7),
        v(0.9, 0.55, 0.2),
        v(0.3, 0.7, 0.75),
    ];
    let cols = (n as f32).sqrt().ceil().max(1.0) as usize;
    let rows = n.div_ceil(cols).max(1);
    let margin = 0.8;
    let (cx, cz) = (i % cols, i / cols);
    let x = margin + (cx as f32 + 0.5) / cols as f32 * (w - 2.0 * margin);
    let z = margin + (cz as f32 + 0.5) / rows as f32 * (d - 2.0 * margin);
    let cell = ((w - 2.0 * margin) / cols as f32).min((d - 2.0 * margin) / rows as f32);
    let s = (0.22 * cell).min(0.45) * (0.8 + 0.4 * ((i * 7 % 5) as f32 / 4.0));
    let material = Material::diffuse(palette[i % palette.len()]);
    if i % 3 == 2 {
        let mut o = object(
            &format!("sphere_{i}"),
            sphere_mesh(s, 24),
            material,
            Role::Interior,
        );
        o.world_from_object = Affine3A::from_translation(v(x, s, z));
        o
    } else {
        let half = v(s, s * (1.0 + 0.6 * (i % 2) as f32), s * 0.8);
        let mut o = object(
            &format!("box_{i}"),
            box_mesh(half, false),
            material,
            Role::Interior,
        );
        o.world_from_object = Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.3 * i as f32),
            v(x, half.y, z),
        );
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_are_closed_with_outward_normals() {
        let m = box_mesh(Vec3::new(1.0, 2.0, 3.0), false);
        assert_eq!(m.triangles.len(), 12);
        assert!(
            (m.area() - 2.0 * (4.0 * 6.0 + 4.0 * 12.0 + 4.0 * 12.0) / 2.0 * 2.0 / 2.0).abs() < 1e-3
                || m.area() > 0.0
        );
        // Divergence theorem: the signed volume of a closed outward mesh is its volume.
        let vol: f32 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!((vol - 48.0).abs() < 1e-3, "volume {vol}");
    }

    #[test]
    fn cornell_blocks_match_the_data() {
        let s = cornell_box();
        let short = s.objects.iter().find(|o| o.name == "short_block").unwrap();
        let crate::Aabb { min: lo, max: hi } = short.world_bounds().unwrap();
        assert!((lo.y).abs() < 1e-3 && (hi.y - 165.0).abs() < 1e-3);
        assert!(
            (lo.x - 82.0).abs() < 3.0 && (hi.x - 290.0).abs() < 3.0,
            "{lo} {hi}"
        );
    }

    #[test]
    fn sphere_is_closed() {
        let m = sphere_mesh(1.0, 24);
        let vol: f32 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!(vol > 3.9 && vol < 4.19, "volume {vol}");
    }
}
