//! The viewer's lights without a surface: the `scene` message lists the punctual lights and
//! the sky; a point light moved through the protocol lights the scene as the same scene
//! loaded with the light there; bad light requests are errors naming what is wrong. The
//! courtyard of `scenes/courtyard.toml` (sky, sun, lamp, spot) on 127.0.0.1, port 0.
//!
//! The reference solver (fast preset) solves each frame's state from scratch and
//! deterministically, so two servers that reach one state show the same colours; waits are
//! bounded polls (30 s each), nothing is timed.

use std::time::{Duration, Instant};

use serde_json::{json, Value};
use shrad_view::{ServeOptions, Server};
use tokio_tungstenite::tungstenite::Message;

use crate::common;
use common::*;

fn courtyard() -> shrad::scene::Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/courtyard.toml");
    shrad::scene::load(&path, &Default::default()).unwrap()
}

fn server_of(scene: shrad::scene::Scene) -> Server {
    let mut o = ServeOptions::new(scene);
    o.sizing = shrad::PatchSizing::Count(1500);
    o.solver = "reference".to_string();
    o.preset = "fast".to_string();
    o.port = 0;
    o.web_root = web_root();
    Server::start(o).unwrap()
}

/// Read until a converged `frame` numbered at least `from`, then its colour frame: the
/// linear radiance of every vertex (3 numbers each).
async fn converged_colours(ws: &mut Ws, from: u64) -> Vec<f32> {
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut want: Option<u64> = None;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let m = tokio::time::timeout(left, ws.next())
            .await
            .expect("no converged frame within 60 s")
            .expect("connection closed")
            .expect("read error");
        match m {
            Message::Text(t) => {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["type"] == "frame" {
                    let f = v["frame"].as_u64().unwrap();
                    want = (v["converged"] == true && f >= from).then_some(f);
                }
            }
            Message::Binary(b) if b[6] == shrad_view::protocol::KIND_COLOURS => {
                let frame = u32::from_le_bytes(b[8..12].try_into().unwrap()) as u64;
                if want == Some(frame) {
                    return radiance(&b);
                }
            }
            _ => {}
        }
    }
}

/// The radiance of a colour frame's vertices: halves times the scale.
fn radiance(b: &[u8]) -> Vec<f32> {
    let n = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let scale = f32::from_le_bytes(b[16..20].try_into().unwrap());
    b[24 + 64 * n..]
        .chunks(2)
        .map(|h| half::f16::from_le_bytes([h[0], h[1]]).to_f32() * scale)
        .collect()
}

/// The largest difference between two frames' values over the largest value of `b`.
fn difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    let max = b.iter().fold(0.0f32, |m, x| m.max(*x));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max)
        / max
}

/// Whether the JSON numbers `v` are `want` (to f32's precision).
fn close(v: &Value, want: [f64; 3]) -> bool {
    let got: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    got.len() == 3 && got.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6)
}

#[test]
fn a_point_light_moved_through_the_viewer_lights_the_scene_as_one_loaded_there() {
    let scene = courtyard();
    let lamp = scene.lights.iter().position(|l| l.name == "lamp").unwrap();
    let rest = scene.lights[lamp].world_from_light;
    let moved = glam::Affine3A::from_translation(glam::Vec3::new(-2.0, 0.8, 2.5)) * rest;
    let s = server_of(scene);
    let before = runtime().block_on(async {
        let mut ws = connect(&s).await;
        let intro = next_of_type(&mut ws, "scene").await;
        let lights = intro["lights"].as_array().unwrap();
        let kinds: Vec<&str> = lights.iter().map(|l| l["kind"].as_str().unwrap()).collect();
        assert_eq!(kinds, ["point", "spot", "directional"], "{intro}");
        let units: Vec<&str> = lights.iter().map(|l| l["unit"].as_str().unwrap()).collect();
        assert_eq!(units, ["cd", "cd", "lx"]);
        // 60 W of a point lamp: 60 / (4 pi) W/sr, 683 times that in candela.
        let w_per_sr = 60.0 / (4.0 * std::f64::consts::PI);
        let cd = lights[lamp]["intensity"].as_f64().unwrap();
        assert!((cd - 683.0 * w_per_sr).abs() < 1e-3 * cd, "{cd} cd");
        assert!(lights[1]["cone"]["outer"].as_f64().unwrap() > 0.5);
        assert_eq!(lights[1]["cone"]["falloff"], "gltf");
        assert_eq!(intro["sky"]["kind"], "uniform");
        assert!(
            close(&intro["sky"]["radiance"], [0.35, 0.5, 0.9]),
            "{intro}"
        );
        let before = converged_colours(&mut ws, 1).await;
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "set_light_transform", "light": "lamp", "id": 1,
                "matrix": glam::Mat4::from(moved).to_cols_array()}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        let after = converged_colours(&mut ws, r["frame"].as_u64().unwrap()).await;
        (before, after)
    });
    s.stop().unwrap();
    let (before, after) = before;
    // The same scene, loaded with the lamp there.
    let mut there = courtyard();
    there.lights[lamp].world_from_light = moved;
    let s = server_of(there);
    let loaded = runtime().block_on(async {
        let mut ws = connect(&s).await;
        converged_colours(&mut ws, 1).await
    });
    s.stop().unwrap();
    let d = difference(&after, &loaded);
    let changed = difference(&before, &loaded);
    eprintln!("moved vs loaded: {d:.2e} of the brightest; before vs loaded: {changed:.3}");
    // (Halves keep 11 bits: 5e-4 of a value.)
    assert!(
        d < 2e-3,
        "moved and loaded differ by {:.4} of the brightest",
        d
    );
    assert!(
        changed > 0.05,
        "moving the lamp changed the colours by {changed} only"
    );
}

#[test]
fn bad_light_requests_are_errors_that_say_why() {
    let s = server_of(courtyard());
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        let identity = glam::Mat4::IDENTITY.to_cols_array();
        for (request, needles) in [
            (
                json!({"v": 1, "type": "set_light_transform", "light": 7, "matrix": identity}),
                vec!["set_light_transform:", "no light '7'", "lamp, spot, sun"],
            ),
            (
                json!({"v": 1, "type": "set_light_intensity", "light": "moon", "color": [1, 1, 1], "intensity": 1}),
                vec!["set_light_intensity:", "no light 'moon'"],
            ),
            (
                json!({"v": 1, "type": "set_light_intensity", "light": 0, "color": [1, 1, 1], "intensity": -2}),
                vec!["set_light_intensity:", "'lamp'", "intensity -2"],
            ),
            (
                json!({"v": 1, "type": "set_light_transform", "light": "spot", "matrix": vec![0.0; 16]}),
                vec!["set_light_transform:", "not affine"],
            ),
        ] {
            let r = ask(&mut ws, request.clone()).await;
            assert_eq!(r["type"], "error", "{request}: {r}");
            let message = r["message"].as_str().unwrap();
            for n in needles {
                assert!(message.contains(n), "{request}: '{message}' lacks '{n}'");
            }
        }
        // Refused requests change nothing: the lamp is where it was.
        let f = frame_message(&mut ws).await;
        assert!(close(&f["lights"][0]["position"], [0.6, 1.6, 1.0]), "{f}");
        ping(&mut ws, 3).await;
    });
    s.stop().unwrap();
}
