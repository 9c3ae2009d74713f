//! The patch size and count known before the patches are made: a size from a target count
//! (bisection) and the count at a size, so that `limits.rs` refuses an absurd size first.

use shrad_scene::{Mesh, Scene};

use super::shape::ShapedObject;
use super::split::{cells_along, Face};
use super::OwnSized;

/// Patch size that gives about `n` patches, by bisection on the count (cheap: no geometry).
pub(super) fn size_for_count(
    scene: &Scene,
    shaped: &[ShapedObject],
    faces: &[Vec<Face>],
    n: usize,
) -> f32 {
    let count = |h: f32| count_patches(scene, shaped, faces, h);
    let total_area: f32 = shaped.iter().map(|(_, _, m)| m.area()).sum();
    if total_area.is_nan() || total_area <= 0.0 {
        // Nothing to cut (an empty scene): any size makes no patch.
        return 1.0;
    }
    let mut lo = (total_area / (n.max(1) as f32) / 50.0).sqrt();
    let mut hi = (total_area / (n.max(1) as f32) * 50.0).sqrt().max(lo * 2.0);
    // Widened until they bracket the target: long slivers are cut into many more cells
    // than their area says (a box with one vertex 1000 away asked 3,000 patches and got
    // 119,031 with the bracket fixed at 50x the area's).
    for _ in 0..64 {
        if count(hi) <= n || !(hi * 2.0).is_finite() {
            break;
        }
        (lo, hi) = (hi, hi * 2.0);
    }
    for _ in 0..64 {
        if count(lo) > n || lo * 0.5 <= f32::MIN_POSITIVE {
            break;
        }
        (lo, hi) = (lo * 0.5, lo);
    }
    for _ in 0..40 {
        let mid = (lo * hi).sqrt();
        if count(mid) > n {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // The coarser of the two brackets never overshoots the target by much.
    let h = if count(lo).abs_diff(n) < count(hi).abs_diff(n) {
        lo
    } else {
        hi
    };
    // Below one patch a face the count stops falling and the bracket grew without end
    // (`info cornell --patches 5` said "patch size: 8.2e22"): no face is longer than the
    // scene's diagonal, so that size already gives the fewest patches there are.
    let diagonal = scene.bounds().map_or(f32::INFINITY, |b| b.diagonal());
    if diagonal > 0.0 && h > diagonal && count(diagonal) == count(h) {
        diagonal
    } else {
        h
    }
}

/// Patches of the whole scene at size `h` (double-sided objects count twice), saturating.
pub(super) fn count_patches(
    scene: &Scene,
    shaped: &[ShapedObject],
    faces: &[Vec<Face>],
    h: f32,
) -> usize {
    (0..scene.objects.len())
        .map(|o| count_object(scene, shaped, faces, o, h))
        .fold(0usize, usize::saturating_add)
}

/// Patches of object `o` at the scene's size `h` (or its own), saturating.
fn count_object(
    scene: &Scene,
    shaped: &[ShapedObject],
    faces: &[Vec<Face>],
    o: usize,
    h: f32,
) -> usize {
    let object = &scene.objects[o];
    let sides = if object.material.double_sided { 2 } else { 1 };
    let oh = object.patch_size.unwrap_or(h);
    count_faces(&shaped[o].2, &faces[o], oh).saturating_mul(sides)
}

/// Of the objects with their own patch size, the one that makes the most patches.
pub(super) fn heaviest_own(
    scene: &Scene,
    shaped: &[ShapedObject],
    faces: &[Vec<Face>],
) -> Option<OwnSized> {
    (scene.objects.iter().enumerate())
        .filter_map(|(o, object)| {
            let patch_size = object.patch_size?;
            let count = count_object(scene, shaped, faces, o, patch_size);
            Some(OwnSized {
                object: o,
                patch_size,
                count,
            })
        })
        .max_by_key(|own| own.count)
}

/// How many cells `faces` (of `mesh`) give at patch size `h`, saturating (no overflow for
/// an absurd `h`): what `split::subdivide` would make, without making it.
pub(super) fn count_faces(mesh: &Mesh, faces: &[Face], h: f32) -> usize {
    let p = |i: u32| mesh.positions[i as usize];
    faces
        .iter()
        .map(|f| match f {
            Face::Quad(c, _) => cells_along((c[1] - c[0]).length(), h)
                .saturating_mul(cells_along((c[3] - c[0]).length(), h)),
            Face::Triangle(t) => {
                let [a, b, c] = t.map(p);
                let n = cells_along(
                    (b - a).length().max((c - b).length()).max((a - c).length()),
                    h,
                );
                n.saturating_mul(n)
            }
        })
        .fold(0usize, usize::saturating_add)
}
