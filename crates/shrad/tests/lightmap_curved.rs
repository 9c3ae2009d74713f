//! Lightmaps of curved meshes: charts grown over near-flat neighbours (`lightmap::grow`)
//! against planar charts only (a chart per input triangle), on the built-in room's
//! tessellated spheres. Grown, the spheres have far fewer charts and seams, no two patches
//! of a chart overlap in the atlas, more of the atlas is used, and the lightmap rendered
//! back matches shrad's picture within 2 % as the planar charts do.

use glam::Vec2;
use shrad::engine::Engine;
use shrad::lightmap::grow::{seams, MAX_ANGLE_DEG};
use shrad::lightmap::uv_chart::triangles_overlap;
use shrad::lightmap::view::{block_rmse, render_back};
use shrad::lightmap::{layout, texel, Layout, LightmapOptions};
use shrad::render::{RenderOptions, Shading};
use shrad::solver::SolverChoice;
use shrad::PatchSizing;
use shrad_scene::{room, RoomParams};

const SIDE: u32 = 192;

struct Figures {
    charts: usize,
    sphere_charts: usize,
    seams: usize,
    utilisation: f64,
    rmse: f64,
    layout: Layout,
}

fn figures(e: &Engine, angle: f32) -> Figures {
    let w = e.world();
    let opts = LightmapOptions {
        resolution: Some(1024),
        max_chart_angle: angle,
        ..LightmapOptions::default()
    };
    let l = layout(w, &opts).unwrap();
    let t = texel::bake(w, &shrad::lightmap::output::surface_light(e), &l);
    let camera = w.scene.camera_or_default_at(w.time);
    let options = RenderOptions {
        width: SIDE,
        height: SIDE,
        spp: 1,
        shading: Shading::Smooth,
    };
    let own = e.render(Some(&camera), &options).unwrap();
    let back = render_back(w, &l, &t.irradiance, &camera, SIDE, SIDE);
    let sphere = |o: usize| w.scene.objects[o].name.starts_with("sphere");
    Figures {
        charts: l.charts.len(),
        sphere_charts: l.charts.iter().filter(|c| sphere(c.object)).count(),
        seams: seams(w, &l.chart_of_patch),
        utilisation: t.covered.iter().filter(|&&c| c).count() as f64 / t.covered.len() as f64,
        rmse: block_rmse(&own, &back),
        layout: l,
    }
}

/// No two patches of one chart overlap in the atlas (their triangles' interiors).
fn assert_no_overlap(e: &Engine, l: &Layout) {
    let p = &e.world().patches;
    let tris = |i: usize| -> Vec<[Vec2; 3]> {
        let q = l.corners[i];
        if p.is_quad[i] {
            vec![[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
        } else {
            vec![[q[0], q[1], q[2]]]
        }
    };
    for chart in &l.charts {
        let all: Vec<(usize, [Vec2; 3])> = chart
            .patches
            .iter()
            .flat_map(|&i| tris(i).into_iter().map(move |t| (i, t)))
            .collect();
        for (a, (i, ta)) in all.iter().enumerate() {
            for (j, tb) in &all[..a] {
                assert!(
                    i == j || !triangles_overlap(*ta, *tb, 1e-4),
                    "patches {i} and {j} overlap in the atlas"
                );
            }
        }
    }
}

#[test]
fn grown_charts_on_the_room_s_spheres() {
    let scene = room(&RoomParams {
        objects: 8,
        patches: 3000,
        big_object_patches: None,
    });
    let spheres = scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with("sphere"))
        .map(|o| o.mesh.triangles.len())
        .sum::<usize>();
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(3000),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    let before = figures(&e, 0.0);
    let after = figures(&e, MAX_ANGLE_DEG);
    for (name, f) in [("planar charts", &before), ("grown charts", &after)] {
        println!(
            "room, {} patches, 1024 x 1024, {name}: {} charts ({} on the spheres' {spheres} triangles), {} seams, {:.1} % of the texels used, rendered back vs picture {:.2} %",
            e.world().patches.len(),
            f.charts,
            f.sphere_charts,
            f.seams,
            100.0 * f.utilisation,
            100.0 * f.rmse
        );
    }
    // Planar charts are an input triangle each on a sphere.
    assert!(
        before.sphere_charts >= spheres / 2,
        "{}",
        before.sphere_charts
    );
    assert!(after.sphere_charts * 10 < before.sphere_charts);
    assert!(after.seams < before.seams);
    assert!(after.utilisation > before.utilisation);
    assert!(before.rmse < 0.02, "planar: {:.2} %", 100.0 * before.rmse);
    assert!(after.rmse < 0.02, "grown: {:.2} %", 100.0 * after.rmse);
    assert_no_overlap(&e, &after.layout);
}
