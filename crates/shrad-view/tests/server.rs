//! The viewer server as a service: two clients at once, a client that vanishes in the middle
//! of a frame, 1,000 random or malformed messages, oversized messages, a client that never
//! reads, 500 moves of one object as fast as they can be written; after each, the server
//! still answers. A small Cornell box (2,000 patches) on 127.0.0.1, port 0.
//!
//! No assertion here depends on how fast the machine is: waits are bounded polls with
//! generous limits (30 s and more), and what is checked is counted, not timed.

use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use shrad_view::{ServeOptions, Server};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

use crate::common;
use common::*;

#[test]
fn two_clients_share_one_scene() {
    let s = server();
    runtime().block_on(async {
        let mut a = connect(&s).await;
        let mut b = connect(&s).await;
        let (_, before) = colour_frame(&mut b).await;
        colour_frame(&mut a).await;
        // A moves the short block 0.1 along x; B sees it in a later frame.
        let (o, mut matrix) = short_block(&before);
        matrix[12] += 0.1;
        let request = json!({"v": 1, "type": "set_transform", "object": "short_block", "id": 1,
            "matrix": matrix});
        a.send(Message::Text(request.to_string().into()))
            .await
            .unwrap();
        let r = reply(&mut a).await;
        assert_eq!(r["type"], "ok", "{r}");
        let shown = r["frame"].as_u64().unwrap() as u32;
        loop {
            let (f, m) = colour_frame(&mut b).await;
            if f >= shown {
                let dx = m[16 * o + 12] - before[16 * o + 12];
                assert!((dx - 0.1).abs() < 1e-4, "B saw the block move by {dx}");
                break;
            }
        }
        ping(&mut a, 1).await;
        ping(&mut b, 2).await;
        // A still scene's time is 0, whatever is asked.
        let r = ask(&mut a, json!({"v": 1, "type": "set_time", "t": 1e30})).await;
        assert_eq!(r["time"], 0.0, "{r}");
    });
    s.stop().unwrap();
}

/// A client joining a running server is told its role before any frame (step 2 of the
/// protocol's connection): the first frame out went ahead of the `role` already queued.
#[test]
fn a_joining_client_learns_its_role_before_its_first_frame() {
    let s = server();
    runtime().block_on(async {
        let mut first = connect(&s).await;
        colour_frame(&mut first).await; // frames are out
        let mut late = connect_raw(&s).await;
        let mut kinds = Vec::new();
        while kinds.len() < 3 {
            let m = tokio::time::timeout(Duration::from_secs(30), late.next())
                .await
                .expect("a message within 30 s")
                .unwrap()
                .unwrap();
            match m {
                Message::Text(t) => {
                    let v: Value = serde_json::from_str(t.as_str()).unwrap();
                    kinds.push(v["type"].as_str().unwrap_or("?").to_string());
                }
                Message::Binary(_) => kinds.push("binary".to_string()),
                _ => {}
            }
        }
        assert_eq!(
            kinds,
            ["scene", "binary", "role"],
            "the geometry, then the role"
        );
    });
    s.stop().unwrap();
}

#[test]
fn a_client_that_vanishes_mid_frame_breaks_nothing() {
    let s = server();
    runtime().block_on(async {
        let mut keep = connect(&s).await;
        keep.send(Message::Text(json!({"v": 1, "type": "run", "continuous": true}).to_string().into()))
            .await
            .unwrap();
        for round in 0..5 {
            // A raw WebSocket handshake, a few bytes of the stream (the scene, the geometry,
            // a frame), then the socket dropped while the server writes.
            let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
            tcp.write_all(
                format!(
                    "GET /ws HTTP/1.1\r\nHost: {}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
                    s.addr()
                )
                .as_bytes(),
            )
            .await
            .unwrap();
            let mut buf = vec![0u8; 4096 + 997 * round];
            let mut got = 0;
            while got < buf.len() {
                let n = tcp.read(&mut buf[got..]).await.unwrap();
                assert!(n > 0);
                got += n;
            }
            drop(tcp);
        }
        // A websocket client that disconnects after its first colour frame, too.
        let mut c = connect(&s).await;
        colour_frame(&mut c).await;
        drop(c);
        let (f0, _) = colour_frame(&mut keep).await;
        let (f1, _) = colour_frame(&mut keep).await;
        assert!(f1 > f0);
        ping(&mut keep, 9).await;
    });
    runtime().block_on(still_answers(&s));
    s.stop().unwrap();
}

/// A small deterministic generator (xorshift).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// A random or malformed control message.
fn malformed(r: &mut Rng) -> Message {
    let templates = [
        r#"{"v":1,"type":"set_transform","object":"short_block","matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0.1,0,0,1]}"#,
        r#"{"v":1,"type":"set_emission","object":"light","radiance":[1,2,3]}"#,
        r#"{"v":1,"type":"set_reflectance","object":"short_block","reflectance":[0.2,0.4,0.8]}"#,
        r#"{"v":1,"type":"set_time","t":0.5}"#,
        r#"{"v":1,"type":"set_option","key":"per_frame","value":"2"}"#,
        r#"{"v":1,"type":"set_channel","channel":"direct"}"#,
        r#"{"v":1,"type":"probes","on":true}"#,
        r#"{"v":1,"type":"play","playing":true}"#,
        r#"{"v":1,"type":"ping"}"#,
    ];
    let junk = [
        "", "{", "}", "null", "[]", "1e999", "\"x\"", "{\"v\":1}", "{\"type\":\"ping\"}",
        "{\"v\":\"1\",\"type\":\"ping\"}", "{\"v\":1,\"type\":7}", "{\"v\":1,\"type\":\"set_transform\",\"object\":99,\"matrix\":[]}",
        "{\"v\":1,\"type\":\"set_transform\",\"object\":\"floor\",\"matrix\":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}",
        "{\"v\":1,\"type\":\"set_transform\",\"object\":\"short_block\",\"matrix\":[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,1]}",
        "{\"v\":1,\"type\":\"set_transform\",\"object\":\"short_block\",\"matrix\":[1e300,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}",
        "{\"v\":1,\"type\":\"set_emission\",\"object\":0,\"radiance\":[-1,0,0]}",
        "{\"v\":1,\"type\":\"set_reflectance\",\"object\":0,\"reflectance\":[0.5,1.5,0]}",
        "{\"v\":1,\"type\":\"set_reflectance\",\"object\":0,\"reflectance\":[0.5]}",
        "{\"v\":1,\"type\":\"set_solver\",\"solver\":\"magic\"}",
        "{\"v\":1,\"type\":\"set_solver\",\"solver\":\"grid\",\"preset\":\"nope\"}",
        "{\"v\":1,\"type\":\"set_option\",\"key\":\"per_frame\",\"value\":\"-3\"}",
        "{\"v\":1,\"type\":\"set_option\",\"key\":\"budget_ms\",\"value\":\"NaN\"}",
        "{\"v\":1,\"type\":\"set_option\",\"key\":\"cube_res\",\"value\":[1]}",
        "{\"v\":1,\"type\":\"set_channel\",\"channel\":\"ultraviolet\"}",
        "{\"v\":1,\"type\":\"play\",\"playing\":true,\"speed\":-1}",
        "{\"v\":1,\"type\":\"ping\",\"id\":1.5}",
        "\u{0}\u{1}\u{2}",
    ];
    match r.below(5) {
        0 => Message::Text(junk[r.below(junk.len())].to_string().into()),
        1 => {
            // A template cut short.
            let t = templates[r.below(templates.len())];
            Message::Text(t[..r.below(t.len())].to_string().into())
        }
        2 => {
            // A template with a few bytes replaced by random printable ones.
            let mut t = templates[r.below(templates.len())].as_bytes().to_vec();
            for _ in 0..1 + r.below(4) {
                let i = r.below(t.len());
                let pool = b" \"{}[]:,0123456789aez-.";
                t[i] = pool[r.below(pool.len())];
            }
            Message::Text(String::from_utf8_lossy(&t).into_owned().into())
        }
        3 => {
            // Random bytes as a binary message.
            let n = r.below(200);
            Message::Binary((0..n).map(|_| r.next() as u8).collect::<Vec<u8>>().into())
        }
        _ => {
            // Deeply nested or oddly typed JSON.
            let depth = 1 + r.below(300);
            Message::Text(
                format!(
                    "{{\"v\":1,\"type\":\"set_time\",\"t\":{}1{}}}",
                    "[".repeat(depth),
                    "]".repeat(depth)
                )
                .into(),
            )
        }
    }
}

#[test]
fn a_thousand_random_or_malformed_messages_get_replies_and_nothing_breaks() {
    let s = server();
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        let mut rng = Rng(0x9e3779b97f4a7c15);
        let mut replies = 0usize;
        let mut errors = 0usize;
        for _ in 0..1000 {
            ws.send(malformed(&mut rng)).await.unwrap();
            let r = reply(&mut ws).await;
            replies += 1;
            match r["type"].as_str() {
                Some("error") => {
                    errors += 1;
                    assert!(!r["message"].as_str().unwrap().is_empty());
                }
                Some("ok") | Some("pong") => {}
                other => panic!("unexpected reply {other:?}: {r}"),
            }
        }
        assert_eq!(replies, 1000);
        assert!(
            errors > 700,
            "only {errors} errors among 1000 mostly malformed messages"
        );
        ping(&mut ws, 77).await;
    });
    runtime().block_on(still_answers(&s));
    s.stop().unwrap();
}

#[test]
fn oversized_messages_get_an_error_or_a_close_and_the_server_goes_on() {
    let s = server();
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        // Over the protocol's limit, under the wire's: an error, and the connection stays.
        let big = json!({"v": 1, "type": "ping", "pad": "x".repeat(100_000)}).to_string();
        ws.send(Message::Text(big.into())).await.unwrap();
        let r = reply(&mut ws).await;
        assert_eq!(r["type"], "error");
        assert!(
            r["message"].as_str().unwrap().contains("larger than"),
            "{r}"
        );
        ping(&mut ws, 5).await;
        // Over the wire's limit: the connection is closed (status 1009), nothing else.
        let huge = "y".repeat(2 * 1024 * 1024);
        let _ = ws.send(Message::Text(huge.into())).await;
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut closed = false;
        while Instant::now() < deadline {
            match tokio::time::timeout(Duration::from_secs(10), ws.next()).await {
                Ok(Some(Ok(Message::Close(frame)))) => {
                    if let Some(f) = frame {
                        assert_eq!(u16::from(f.code), 1009);
                    }
                    closed = true;
                    break;
                }
                Ok(Some(Ok(_))) => continue,
                Ok(Some(Err(_))) | Ok(None) => {
                    closed = true;
                    break;
                }
                Err(_) => break,
            }
        }
        assert!(closed, "a 2 MiB message did not close the connection");
    });
    runtime().block_on(still_answers(&s));
    s.stop().unwrap();
}

#[test]
fn a_client_that_never_reads_does_not_stall_the_engine() {
    let s = server();
    runtime().block_on(async {
        // Never read from, nor acknowledging: the server sends it one frame and then waits
        // for it, while the engine goes on for the others.
        // (The first client steers.)
        let mut ws = connect(&s).await;
        let _sleeper = connect_raw(&s).await;
        ws.send(Message::Text(
            json!({"v": 1, "type": "run", "continuous": true})
                .to_string()
                .into(),
        ))
        .await
        .unwrap();
        let (f0, _) = colour_frame(&mut ws).await;
        // 200 engine frames later (each read within 30 s; no rate is asserted).
        let mut f = f0;
        while f < f0 + 200 {
            f = colour_frame(&mut ws).await.0;
        }
        ping(&mut ws, 3).await;
    });
    s.stop().unwrap();
}

/// The `frame` number of the next `frame` message, and whether everything slept in it.
async fn frame_number_and_asleep(ws: &mut Ws) -> (u64, bool) {
    let m = frame_message(ws).await;
    (
        m["frame"].as_u64().unwrap(),
        m["stats"]["solver"]["asleep"] == true,
    )
}

#[test]
fn a_settled_scene_stepped_continuously_steps_at_a_display_rate_not_as_fast_as_it_can() {
    let s = server();
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        keep_stepping(&mut ws).await;
        // Until every object sleeps (the Cornell box at 2,000 patches: within a few hundred
        // frames).
        let deadline = Instant::now() + Duration::from_secs(120);
        while !frame_number_and_asleep(&mut ws).await.1 {
            assert!(Instant::now() < deadline, "the scene never slept");
        }
        // Then a second of its frames (no request is sent: a request would wake it).
        let (first, _) = frame_number_and_asleep(&mut ws).await;
        let start = Instant::now();
        let mut last = first;
        while start.elapsed() < Duration::from_secs(1) {
            let (f, asleep) = frame_number_and_asleep(&mut ws).await;
            assert!(asleep, "frame {f} woke with nothing changed");
            last = f;
        }
        let steps = last - first;
        // At most one empty frame per 16 ms (63 a second) and the frame after a wake; stepped
        // as fast as a core allows, thousands.
        assert!(
            steps <= 70,
            "{steps} empty frames in {:.2} s",
            start.elapsed().as_secs_f64()
        );
        assert!(steps > 0, "stepping continuously, the engine stopped");
    });
    s.stop().unwrap();
}

#[test]
fn five_hundred_moves_sent_as_fast_as_possible_leave_one_pending_and_the_last_applied_within_two_frames(
) {
    let s = server();
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        keep_stepping(&mut ws).await;
        let (_, before) = colour_frame(&mut ws).await;
        let (o, mut matrix) = short_block(&before);
        let counts0 = s.inbox_counts();
        // 500 moves of 0.0002 along x, written without reading anything in between.
        let step = 0.0002f32;
        let x0 = matrix[12];
        for id in 1..=500u64 {
            matrix[12] = x0 + step * id as f32;
            ws.send(move_message("short_block", &matrix, id))
                .await
                .unwrap();
        }
        // Every move is answered once: applied (with the frame that shows it) or superseded
        // by a newer one before the engine took it.
        let mut applied = std::collections::BTreeMap::new();
        let mut superseded = 0u64;
        let mut answered = std::collections::BTreeSet::new();
        while answered.len() < 500 {
            let r = reply(&mut ws).await;
            assert_eq!(r["type"], "ok", "{r}");
            assert_eq!(r["request"], "set_transform", "{r}");
            let id = r["id"].as_u64().unwrap();
            assert!(answered.insert(id), "move {id} answered twice: {r}");
            if r["superseded"] == true {
                let by = r["superseded_by"].as_u64().unwrap();
                assert!(by > id, "move {id} superseded by an older one: {r}");
                superseded += 1;
            } else {
                let frame = r["frame"].as_u64().unwrap();
                let received_at = r["received_at_frame"].as_u64().unwrap();
                assert!(
                    frame <= received_at + 2,
                    "move {id} read at frame {received_at} waited until frame {frame}: {r}"
                );
                applied.insert(id, frame);
            }
        }
        // The last move is applied, not superseded; at most one move per frame was applied
        // (the engine never worked through a queue of them).
        let last_frame = *applied.get(&500).expect("the last move was not applied");
        let frames: std::collections::BTreeSet<u64> = applied.values().copied().collect();
        assert_eq!(
            frames.len(),
            applied.len(),
            "two moves applied in one frame"
        );
        let counts = s.inbox_counts();
        assert_eq!(counts.received - counts0.received, 500);
        assert_eq!(counts.superseded - counts0.superseded, superseded);
        assert_eq!(
            counts.transforms_applied - counts0.transforms_applied,
            applied.len() as u64
        );
        assert_eq!(applied.len() as u64 + superseded, 500);
        assert_eq!(
            counts.most_pending_per_key, 1,
            "more than one move of an object waited at once"
        );
        // The frame that has the last move shows the block at the last position.
        loop {
            let (f, m) = colour_frame(&mut ws).await;
            if u64::from(f) >= last_frame {
                let x = m[16 * o + 12];
                let want = before[16 * o + 12] + step * 500.0;
                assert!((x - want).abs() < 1e-4, "the block is at x {x}, not {want}");
                break;
            }
        }
        ping(&mut ws, 501).await;
    });
    s.stop().unwrap();
}

#[test]
fn files_are_served_from_the_page_folder_only() {
    let s = server();
    runtime().block_on(async {
        assert_eq!(http_get(&s, "/").await, 200);
        assert_eq!(http_get(&s, "/vendor/three/build/three.module.js").await, 200);
        assert_eq!(http_get(&s, "/../Cargo.toml").await, 404);
        assert_eq!(http_get(&s, "/%2e%2e/Cargo.toml").await, 404);
        assert_eq!(http_get(&s, "/vendor/three/package.json").await, 404);
        assert_eq!(http_get(&s, "/.hidden.js").await, 404);
        // A WebSocket from a page of another origin is refused.
        let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
        tcp.write_all(
            format!(
                "GET /ws HTTP/1.1\r\nHost: {}\r\nOrigin: http://evil.example\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
                s.addr()
            )
            .as_bytes(),
        )
        .await
        .unwrap();
        let mut buf = [0u8; 64];
        let n = tcp.read(&mut buf).await.unwrap();
        assert!(String::from_utf8_lossy(&buf[..n]).contains(" 403 "));
        // Nor a page of a site whose name points at this machine (DNS rebinding): the same
        // name in Host and Origin. Its page is refused too; by address or localhost it is
        // served.
        let port = s.addr().port();
        for (host, path, want) in [
            (format!("evil.example:{port}"), "/ws", " 403 "),
            (format!("evil.example:{port}"), "/", " 403 "),
            (format!("localhost:{port}"), "/", " 200 "),
        ] {
            let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
            let request = format!(
                "GET {path} HTTP/1.1\r\nHost: {host}\r\nOrigin: http://{host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
            );
            tcp.write_all(request.as_bytes()).await.unwrap();
            let n = tcp.read(&mut buf).await.unwrap();
            let answer = String::from_utf8_lossy(&buf[..n]).to_string();
            assert!(answer.contains(want), "{host}{path}: {answer}");
        }
    });
    s.stop().unwrap();
}

#[test]
fn steering_requests_do_what_they_say() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/moving_box.toml");
    let scene = shrad::scene::load(&path, &Default::default()).unwrap();
    let mut o = ServeOptions::new(scene);
    o.sizing = shrad::PatchSizing::Count(1500);
    o.port = 0;
    o.web_root = web_root();
    let s = Server::start(o).unwrap();
    runtime().block_on(async {
        let mut ws = connect(&s).await;
        // The animation: scrub, then play; frames say where it is.
        let r = ask(&mut ws, json!({"v": 1, "type": "set_time", "t": 1.5})).await;
        assert_eq!(r["type"], "ok", "{r}");
        assert_eq!(r["time"], 1.5);
        let r = ask(&mut ws, json!({"v": 1, "type": "set_time", "t": 1e30})).await;
        assert_eq!(r["time"], 4.0, "clamped to the animation's 4 s: {r}");
        let r = ask(&mut ws, json!({"v": 1, "type": "set_time", "t": 1.5})).await;
        assert_eq!(r["time"], 1.5);
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "play", "playing": true, "speed": 2.0}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        let mut last = frame_message(&mut ws).await;
        while last["time"].as_f64().unwrap() <= 1.6 {
            last = frame_message(&mut ws).await;
        }
        assert_eq!(last["playing"], true);
        let r = ask(&mut ws, json!({"v": 1, "type": "play", "playing": false})).await;
        assert_eq!(r["type"], "ok", "{r}");
        // A light switched off.
        let light = r#"{"v":1,"type":"set_emission","object":"light","radiance":[0,0,0]}"#;
        ws.send(Message::Text(light.into())).await.unwrap();
        let r = reply(&mut ws).await;
        assert_eq!(r["type"], "ok", "{r}");
        // A wall painted blue, then a colour that is not a reflectance.
        let paint = |rgb: [f64; 3]| {
            json!({"v": 1, "type": "set_reflectance", "object": "floor", "reflectance": rgb})
        };
        let r = ask(&mut ws, paint([0.1, 0.2, 0.7])).await;
        assert_eq!(r["type"], "ok", "{r}");
        let r = ask(&mut ws, paint([0.5, 1.5, 0.0])).await;
        assert_eq!(r["type"], "error", "{r}");
        let said = r["message"].as_str().unwrap();
        assert!(said.contains("'floor'") && said.contains("within [0, 1]"), "{r}");
        // A live setting, then a solver switch, then a setting the new solver lacks.
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "set_option", "key": "per_frame", "value": "2"}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        assert_eq!(r["value"], "2");
        assert!(r["precompute_ms"].is_null());
        // A resolution that would hold gigabytes and make every frame take seconds, for
        // every client: refused by the viewer, as a number or as text.
        for value in [json!(2048), json!("2048")] {
            let set = json!({"v": 1, "type": "set_option", "key": "cube_res", "value": value});
            let r = ask(&mut ws, set).await;
            assert_eq!(r["type"], "error", "{r}");
            assert!(r["message"].as_str().unwrap().contains("at most 256"), "{r}");
        }
        // So are rays by the ten thousand (a first frame of 6.5 s, 665 MB).
        for key in ["direct_samples", "near_rays", "wall_rays", "self_shadow_rays"] {
            let set = json!({"v": 1, "type": "set_option", "key": key, "value": 65536});
            let r = ask(&mut ws, set).await;
            assert_eq!(r["type"], "error", "{r}");
            assert!(r["message"].as_str().unwrap().contains("at most 1024"), "{r}");
        }
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "set_solver", "solver": "grid", "preset": "paper4"}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        assert!(r["precompute_ms"].as_f64().unwrap() >= 0.0);
        let f = frame_message(&mut ws).await;
        assert_eq!(f["solver"], "grid");
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "set_option", "key": "per_frame", "value": "2"}),
        )
        .await;
        assert_eq!(r["type"], "error", "{r}");
        assert!(r["message"].as_str().unwrap().contains("per_frame"), "{r}");
        // The error against the reference, and a frame that carries it.
        let r = ask(
            &mut ws,
            json!({"v": 1, "type": "set_solver", "solver": "dispersive"}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        // (With the light off the reference is black and the relative error undefined: null.)
        let on =
            json!({"v": 1, "type": "set_emission", "object": "light", "radiance": [17, 12, 4]});
        assert_eq!(ask(&mut ws, on).await["type"], "ok");
        let r = ask(&mut ws, json!({"v": 1, "type": "compute_error"})).await;
        assert_eq!(r["type"], "ok", "{r}");
        let e = r["overall"].as_f64().unwrap();
        assert!(e.is_finite() && e >= 0.0, "{r}");
        // Probes: 8 for the one interior object, each with a radiance per sphere direction.
        let r = ask(&mut ws, json!({"v": 1, "type": "probes", "on": true})).await;
        assert_eq!(r["type"], "ok", "{r}");
        let deadline = Instant::now() + Duration::from_secs(30);
        let probes = loop {
            assert!(Instant::now() < deadline, "no probes within 30 s");
            if let Some(Ok(Message::Text(t))) = ws.next().await {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["type"] == "probes" {
                    break v;
                }
            }
        };
        let list = probes["probes"].as_array().unwrap();
        assert_eq!(list.len(), 8);
        assert!(list
            .iter()
            .all(|p| p["radiance"].as_array().unwrap().len() % 3 == 0));
    });
    s.stop().unwrap();
}

#[test]
fn a_client_that_does_not_acknowledge_is_sent_a_bounded_number_of_bytes_and_still_gets_its_replies()
{
    let s = server();
    runtime().block_on(async {
        // (The first client steers.)
        let mut ws = connect(&s).await;
        let mut quiet = connect_raw(&s).await;
        keep_stepping(&mut ws).await;
        // The engine steps 300 frames for the client that acknowledges them.
        let (f0, _) = colour_frame(&mut ws).await;
        let mut f = f0;
        while f < f0 + 300 {
            f = colour_frame(&mut ws).await.0;
        }
        // The other has acknowledged nothing: all it was sent before the reply to a ping
        // is within the bound (and one frame beyond it: one frame always goes).
        let ping = json!({"v": 1, "type": "ping", "id": 7}).to_string();
        quiet.send(Message::Text(ping.into())).await.unwrap();
        let (mut frame_bytes, mut largest, mut messages) = (0usize, 0usize, 0u64);
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let m = tokio::time::timeout(left, quiet.next())
                .await
                .expect("no pong within 60 s")
                .expect("connection closed")
                .expect("read error");
            if is_frame_message(&m) {
                let n = match &m {
                    Message::Text(t) => t.len(),
                    Message::Binary(b) => b.len(),
                    _ => 0,
                };
                frame_bytes += n;
                largest = largest.max(n);
                messages += 1;
            } else if let Message::Text(t) = &m {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["type"] == "pong" {
                    assert_eq!(v["id"], 7);
                    break;
                }
            }
        }
        let bound = shrad_view::protocol::MAX_IN_FLIGHT_BYTES;
        assert!(messages > 0, "not even one frame was sent");
        // (300 frames are several times the bound: it was reached.)
        assert!(
            frame_bytes + 2 * largest >= bound,
            "only {frame_bytes} bytes of frames were sent: the bound of {bound} was not reached"
        );
        assert!(
            frame_bytes <= bound + 2 * largest,
            "{frame_bytes} bytes of frames unacknowledged (bound {bound}, largest message {largest})"
        );
        // An acknowledgement of more than was sent is refused; of what was received, it
        // lets the newest frame through.
        let too_many = json!({"v": 1, "type": "ack", "received": messages + 1_000_000, "id": 8});
        quiet
            .send(Message::Text(too_many.to_string().into()))
            .await
            .unwrap();
        let mut quiet = Ws {
            inner: quiet,
            received: messages,
        };
        let r = reply(&mut quiet).await;
        assert_eq!(r["type"], "error", "{r}");
        assert!(r["message"].as_str().unwrap().starts_with("ack:"), "{r}");
        let ack = json!({"v": 1, "type": "ack", "received": messages});
        quiet.send(Message::Text(ack.to_string().into())).await.unwrap();
        let (g, _) = colour_frame(&mut quiet).await;
        assert!(g >= f, "after the acknowledgement: frame {g}, older than {f}");
    });
    s.stop().unwrap();
}

/// A client that closes gets the closing handshake's answer, its own close frame back (not
/// a dropped connection, which a client reports as 1006, an abnormal closure).
#[test]
fn a_client_that_closes_is_answered_with_a_close() {
    let s = server();
    runtime().block_on(async {
        let mut ws = connect_raw(&s).await;
        ws.send(Message::Close(None)).await.unwrap();
        let answered = tokio::time::timeout(Duration::from_secs(10), async {
            while let Some(m) = ws.next().await {
                match m {
                    Ok(Message::Close(_)) => return true,
                    Ok(_) => continue,
                    Err(_) => return false,
                }
            }
            false
        })
        .await;
        assert_eq!(answered, Ok(true), "no close frame came back");
    });
    s.stop().unwrap();
}

/// A client that sends half a request and no more (slowloris) is dropped once the header
/// timeout passes; it was held open forever, and 20,000 of them made the server
/// unreachable. So is one that sends nothing at all, or only HTTP/2's preface (hyper-util's
/// `auto` builder waited for them without a timeout: 520 made the server unreachable). A
/// whole request on another connection is served meanwhile.
#[test]
fn a_request_left_half_sent_is_dropped_after_the_header_timeout() {
    let s = server();
    runtime().block_on(async {
        let starts: [&[u8]; 3] = [
            b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n",
            b"",
            b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n",
        ];
        let mut sockets = Vec::new();
        for start in starts {
            let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
            tcp.write_all(start).await.unwrap();
            sockets.push(tcp);
        }
        assert_eq!(http_get(&s, "/").await, 200);
        let wait = shrad_view::HEADER_TIMEOUT + Duration::from_secs(20);
        for (tcp, start) in sockets.iter_mut().zip(starts) {
            let mut buf = [0u8; 256];
            let read = tokio::time::timeout(wait, tcp.read(&mut buf)).await;
            // Closed: the end of the stream, or a 408 (or 400 for HTTP/2) before it.
            let start = String::from_utf8_lossy(start);
            let answer = read.unwrap_or_else(|_| panic!("{start:?}: still open"));
            let said = match answer {
                Ok(n) => String::from_utf8_lossy(&buf[..n]).to_string(),
                Err(_) => String::new(),
            };
            let closed = said.is_empty() || said.contains(" 408 ") || said.contains(" 400 ");
            assert!(closed, "{start:?}: {said}");
        }
    });
    s.stop().unwrap();
}

/// The close code the server sends after `frame` on a raw connection: the handshake, then
/// the frame, then the server's frames read (unmasked, as a server's are) until its close.
async fn close_code_after(s: &Server, frame: &[u8]) -> Option<u16> {
    let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
    let hello = format!(
        "GET /ws HTTP/1.1\r\nHost: {}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
        s.addr()
    );
    tcp.write_all(hello.as_bytes()).await.unwrap();
    let mut head = Vec::new();
    while !head.ends_with(b"\r\n\r\n") {
        head.push(tcp.read_u8().await.unwrap());
    }
    assert!(
        head.starts_with(b"HTTP/1.1 101"),
        "{}",
        String::from_utf8_lossy(&head)
    );
    tcp.write_all(frame).await.unwrap();
    let read = async {
        loop {
            let [first, second] = [tcp.read_u8().await.ok()?, tcp.read_u8().await.ok()?];
            let len = match second & 0x7f {
                126 => u64::from(tcp.read_u16().await.ok()?),
                127 => tcp.read_u64().await.ok()?,
                n => u64::from(n),
            };
            let mut payload = vec![0u8; len as usize];
            tcp.read_exact(&mut payload).await.ok()?;
            if first & 0x0f == 0x8 {
                return payload.get(..2).map(|c| u16::from_be_bytes([c[0], c[1]]));
            }
        }
    };
    tokio::time::timeout(Duration::from_secs(20), read)
        .await
        .ok()?
}

/// A frame against the protocol closes the connection with the code that says so (RFC
/// 6455, 7.4.1): every one was 1009, "message too big".
#[test]
fn a_broken_frame_is_closed_with_the_code_that_names_it() {
    let s = server();
    runtime().block_on(async {
        let mask = [0x11u8, 0x22, 0x33, 0x44];
        // A text frame of one byte, 0xff, masked: not UTF-8.
        let not_utf8 = [
            0x81,
            0x81,
            mask[0],
            mask[1],
            mask[2],
            mask[3],
            0xff ^ mask[0],
        ];
        assert_eq!(close_code_after(&s, &not_utf8).await, Some(1007));
        // A client's frame unmasked, and one with a reserved bit set: the protocol.
        assert_eq!(close_code_after(&s, &[0x81, 0x01, b'a']).await, Some(1002));
        let reserved = [
            0xc1,
            0x81,
            mask[0],
            mask[1],
            mask[2],
            mask[3],
            b'a' ^ mask[0],
        ];
        assert_eq!(close_code_after(&s, &reserved).await, Some(1002));
    });
    runtime().block_on(still_answers(&s));
    s.stop().unwrap();
}
