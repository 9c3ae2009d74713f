//! Per-object comparison of the dispersive default with the reference on any scene file (a
//! diagnostic aid): mean radiosity of each object under both, their error, and whatever the
//! energy guard reported. `cargo run --release --example object_errors -- SCENE [patches]`.
use glam::Vec3;
use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::reference::{solve, ReferenceOptions};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("usage: object_errors SCENE [patches]");
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let mut scene = shrad::scene::load(std::path::Path::new(&path), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    shrad::scene::infer_roles(&mut scene);
    let world = World::new(scene, PatchSizing::Count(patches), Backend::Auto).expect("world");
    let (reference, _) = solve(&world, &ReferenceOptions::fast(), &NoProgress);
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    for s in d.converge(&world, 8) {
        if let Some(div) = s.diverged {
            println!("frame {}: {}", s.frame, div.message);
        }
    }
    let b = d.radiosity();
    let p = &world.patches;
    println!(
        "{:<24} {:<9} {:>12} {:>12} {:>8}",
        "object", "role", "mean ref", "mean disp", "error %"
    );
    for (o, object) in world.scene.objects.iter().enumerate() {
        let twins = p
            .range(o)
            .filter(|&i| p.twin[i] != shrad::patches::NO_PATCH && p.twin[i] < i as u32)
            .count();
        if twins > 0 {
            let centre = world.scene.objects[o].world_bounds().unwrap().centre();
            let (mut fi, mut fo) = (Vec3::ZERO, Vec3::ZERO);
            for i in p.range(o) {
                let inward = p.normal[i].dot(centre - p.centre[i]) > 0.0;
                if inward {
                    fi += reference[i] * p.area[i]
                } else {
                    fo += reference[i] * p.area[i]
                }
            }
            println!(
                "  {}: {twins} twins; reference flux on inward-facing {:.3}, outward-facing {:.3}",
                object.name,
                fi.element_sum(),
                fo.element_sum()
            );
        }
        let (mut a, mut sr, mut sd, mut num, mut den) = (0.0, Vec3::ZERO, Vec3::ZERO, 0.0, 0.0);
        for i in p.range(o) {
            let w = p.area[i];
            a += w;
            sr += reference[i] * w;
            sd += b[i] * w;
            num += w * (b[i] - reference[i]).length_squared();
            den += w * reference[i].length_squared();
        }
        println!(
            "{:<24} {:<9} {:>12.4} {:>12.4} {:>8.2}",
            object.name,
            p.object_role[o].name(),
            (sr / a).element_sum() / 3.0,
            (sd / a).element_sum() / 3.0,
            100.0 * (num / den.max(f32::MIN_POSITIVE)).sqrt()
        );
    }
}
