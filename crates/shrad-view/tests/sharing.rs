//! The viewer shared with hostile clients (issue 19, item 4), on 127.0.0.1 only: requests
//! without the token or with a wrong one, a client over the cap, a watcher that steers,
//! and a flood of error requests while another client drags.
//!
//! As in `server.rs`, nothing here is timed: waits are bounded polls with generous limits,
//! and what is checked is counted (frames received, moves applied, replies of each kind).

use std::time::{Duration, Instant};

use serde_json::{json, Value};
use shrad_view::{AccessOptions, Server};
use tokio_tungstenite::tungstenite::{self, Message};

use crate::common;
use common::*;

const TOKEN: &str = "s3cret-token-0123456789";

fn with_token() -> AccessOptions {
    AccessOptions {
        token: Some(TOKEN.to_string()),
        ..AccessOptions::default()
    }
}

/// The status of a WebSocket handshake at `url` that is refused (panics if it succeeds).
async fn refused_handshake(url: &str) -> u16 {
    match tokio_tungstenite::connect_async(url).await {
        Err(tungstenite::Error::Http(response)) => response.status().as_u16(),
        Err(e) => panic!("{url}: {e}"),
        Ok(_) => panic!("{url}: the handshake succeeded"),
    }
}

#[test]
fn without_the_token_or_with_a_wrong_one_the_page_its_files_and_the_websocket_get_401() {
    let s = server_with(with_token());
    assert!(
        s.url().ends_with(&format!("/?token={TOKEN}")),
        "{}",
        s.url()
    );
    runtime().block_on(async {
        let asset = "/vendor/three/build/three.module.js";
        let wrong = "s3cret-token-0123456780";
        for path in ["/", asset, "/ws"] {
            assert_eq!(http_get(&s, path).await, 401, "{path} without a token");
            let bad = format!("{path}?token={wrong}");
            assert_eq!(http_get(&s, &bad).await, 401, "{bad}");
            assert_eq!(http_get(&s, &format!("{path}?token=")).await, 401);
        }
        let cookie = format!("shrad_token_{}", s.addr().port());
        let (code, _) = http_request(&s, asset, &format!("Cookie: {cookie}={wrong}\r\n")).await;
        assert_eq!(code, 401, "a wrong cookie");
        // The page with the token: 200, and the cookie its files then carry.
        let (code, head) = http_request(&s, &format!("/?token={TOKEN}"), "").await;
        assert_eq!(code, 200);
        assert!(
            head.contains(&format!("{cookie}={TOKEN}")),
            "no cookie set: {head}"
        );
        let (code, _) = http_request(&s, asset, &format!("Cookie: {cookie}={TOKEN}\r\n")).await;
        assert_eq!(code, 200, "an asset with the cookie");
        // The WebSocket: refused without, with a wrong token; served with the right one.
        let ws = format!("ws://{}/ws", s.addr());
        assert_eq!(refused_handshake(&ws).await, 401);
        assert_eq!(refused_handshake(&format!("{ws}?token={wrong}")).await, 401);
        assert_eq!(
            refused_handshake(&format!("{ws}?token={TOKEN}x")).await,
            401
        );
        let mut c = connect_url(&format!("{ws}?token={TOKEN}")).await;
        assert_eq!(next_of_type(&mut c, "role").await["role"], "steer");
        ping(&mut c, 1).await;
        colour_frame(&mut c).await;
    });
    s.stop().unwrap();
}

#[test]
fn a_client_over_the_cap_is_told_why_and_the_seat_is_free_again_once_one_leaves() {
    let s = server_with(AccessOptions {
        max_clients: 2,
        ..AccessOptions::default()
    });
    runtime().block_on(async {
        let mut a = connect(&s).await;
        let b = connect(&s).await;
        // The third is upgraded only to be told why, then closed with 1013.
        let mut c = connect(&s).await;
        let (mut refused, mut close) = (None, None);
        let deadline = Instant::now() + Duration::from_secs(30);
        while close.is_none() && Instant::now() < deadline {
            match tokio::time::timeout(Duration::from_secs(30), c.next()).await {
                Ok(Some(Ok(Message::Text(t)))) => {
                    let v: Value = serde_json::from_str(t.as_str()).unwrap();
                    assert_ne!(v["type"], "scene", "the client over the cap got the scene");
                    if v["type"] == "refused" {
                        refused = Some(v);
                    }
                }
                Ok(Some(Ok(Message::Close(f)))) => close = Some(f.map(|f| u16::from(f.code))),
                Ok(Some(Ok(m))) => panic!("the client over the cap got {m:?}"),
                _ => break,
            }
        }
        let refused = refused.expect("no refused message");
        let text = refused["message"].as_str().unwrap();
        assert!(text.contains("--max-clients 2"), "{text}");
        assert_eq!(close, Some(Some(1013)));
        // One leaves: the next is served.
        drop(b);
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut d = loop {
            let mut d = connect(&s).await;
            match tokio::time::timeout(Duration::from_secs(30), d.next()).await {
                Ok(Some(Ok(Message::Text(t)))) if t.as_str().contains("\"scene\"") => break d,
                _ => assert!(Instant::now() < deadline, "no seat within 30 s"),
            }
        };
        ping(&mut d, 2).await;
        ping(&mut a, 3).await;
    });
    s.stop().unwrap();
}

/// Every steering request, each with `id`.
fn steering_requests() -> Vec<Value> {
    let m = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.1, 0.0, 0.0, 1.0,
    ];
    vec![
        json!({"v": 1, "type": "set_transform", "object": "short_block", "matrix": m}),
        json!({"v": 1, "type": "set_emission", "object": "light", "radiance": [0, 0, 0]}),
        json!({"v": 1, "type": "set_time", "t": 0.5}),
        json!({"v": 1, "type": "play", "playing": true}),
        json!({"v": 1, "type": "set_solver", "solver": "grid"}),
        json!({"v": 1, "type": "set_option", "key": "per_frame", "value": "3"}),
        json!({"v": 1, "type": "run", "continuous": true}),
    ]
}

#[test]
fn a_watcher_that_steers_is_refused_until_it_takes_steering_from_a_steerer_that_handed_over() {
    let s = server();
    runtime().block_on(async {
        let mut a = connect(&s).await;
        assert_eq!(next_of_type(&mut a, "role").await["role"], "steer");
        let mut b = connect(&s).await;
        let role = next_of_type(&mut b, "role").await;
        assert_eq!(role["role"], "watch", "{role}");
        assert_eq!(role["steering_free"], false, "{role}");
        let before = s.inbox_counts().received;
        for (id, mut r) in steering_requests().into_iter().enumerate() {
            r["id"] = json!(id);
            let kind = r["type"].as_str().unwrap().to_string();
            let answer = ask(&mut b, r).await;
            assert_eq!(answer["type"], "error", "{answer}");
            assert_eq!(answer["id"], id);
            let text = answer["message"].as_str().unwrap();
            assert!(
                text.starts_with(&format!("{kind}: refused: this client watches")),
                "{text}"
            );
        }
        assert_eq!(
            s.inbox_counts().received,
            before,
            "a watcher's steering reached the engine"
        );
        // Watching is still allowed.
        let r = ask(
            &mut b,
            json!({"v": 1, "type": "set_channel", "channel": "direct"}),
        )
        .await;
        assert_eq!(r["type"], "ok", "{r}");
        let r = ask(&mut b, json!({"v": 1, "type": "take_steering"})).await;
        assert!(
            r["message"]
                .as_str()
                .unwrap()
                .contains("another client steers"),
            "{r}"
        );
        // A hands over; B is told steering is free, takes it and moves the block.
        let r = ask(&mut a, json!({"v": 1, "type": "release_steering"})).await;
        assert_eq!(r["type"], "ok", "{r}");
        let role = next_of_type(&mut b, "role").await;
        assert_eq!(role["steering_free"], true, "{role}");
        let r = ask(&mut b, json!({"v": 1, "type": "take_steering"})).await;
        assert_eq!(
            (&r["type"], &r["role"]),
            (&json!("ok"), &json!("steer")),
            "{r}"
        );
        let moved = ask(&mut b, steering_requests().remove(0)).await;
        assert_eq!(moved["type"], "ok", "{moved}");
        let refused = ask(&mut a, steering_requests().remove(0)).await;
        assert!(
            refused["message"].as_str().unwrap().contains("watches"),
            "{refused}"
        );
        // B leaves: steering is free for A again.
        drop(b);
        let role = next_of_type(&mut a, "role").await;
        assert_eq!(role["steering_free"], true, "{role}");
        let r = ask(&mut a, json!({"v": 1, "type": "take_steering"})).await;
        assert_eq!(r["type"], "ok", "{r}");
    });
    s.stop().unwrap();
}

#[test]
fn on_a_watch_only_server_nobody_steers() {
    let s = server_with(AccessOptions {
        watch_only: true,
        ..AccessOptions::default()
    });
    runtime().block_on(async {
        let mut a = connect(&s).await;
        let role = next_of_type(&mut a, "role").await;
        assert_eq!(
            (&role["role"], &role["watch_only"]),
            (&json!("watch"), &json!(true))
        );
        let r = ask(&mut a, steering_requests().remove(0)).await;
        assert!(r["message"].as_str().unwrap().contains("watch-only"), "{r}");
        let r = ask(&mut a, json!({"v": 1, "type": "take_steering"})).await;
        assert!(r["message"].as_str().unwrap().contains("watch-only"), "{r}");
        colour_frame(&mut a).await;
    });
    s.stop().unwrap();
}

#[test]
fn a_flood_of_error_requests_from_a_watcher_leaves_the_drag_of_the_steerer_moving() {
    // A reference of 512 rays a patch: each error takes several of the engine's frames.
    let mut o = options_with(AccessOptions::default());
    o.reference = Some(shrad::reference::ReferenceOptions {
        rays_per_patch: 512,
        ..shrad::reference::ReferenceOptions::fast()
    });
    let s = shrad_view::Server::start(o).unwrap();
    runtime().block_on(async {
        let mut a = connect(&s).await;
        keep_stepping(&mut a).await;
        let (o, mut matrix) = short_block(&colour_frame(&mut a).await.1);
        // The watcher writes 300 error requests, never reading a reply: 100 at once, then
        // 5 before each of the steerer's 40 moves.
        let mut b = connect(&s).await;
        let mut flood = 0u64..300;
        let mut send_errors = async |b: &mut Ws, n: usize| {
            for id in flood.by_ref().take(n) {
                let r = json!({"v": 1, "type": "compute_error", "id": id}).to_string();
                b.send(Message::Text(r.into())).await.unwrap();
            }
        };
        send_errors(&mut b, 100).await;
        // Meanwhile A drags: 40 moves, each waited for, and shown in a frame.
        let (x0, mut frames) = (matrix[12], 0usize);
        for id in 1..=40u64 {
            send_errors(&mut b, 5).await;
            matrix[12] = x0 + 0.002 * id as f32;
            a.send(move_message("short_block", &matrix, id))
                .await
                .unwrap();
            let r = reply(&mut a).await;
            assert_eq!((&r["type"], &r["id"]), (&json!("ok"), &json!(id)), "{r}");
            let shown = r["frame"].as_u64().unwrap();
            loop {
                let (f, m) = colour_frame(&mut a).await;
                frames += 1;
                if u64::from(f) >= shown {
                    let x = m[16 * o + 12];
                    assert!((x - matrix[12]).abs() < 1e-4, "move {id}: x {x}");
                    break;
                }
            }
        }
        assert!(frames >= 40, "{frames} frames for 40 moves");
        // Every error request was answered: a few measured, the rest refused as rate
        // limited or for a full queue, none lost.
        let (mut measured, mut limited, mut meanwhile) = (0, 0, 0);
        for _ in 0..300 {
            let r = reply(&mut b).await;
            assert_eq!(
                r["request"].as_str().unwrap_or("compute_error"),
                "compute_error"
            );
            match r["type"].as_str() {
                Some("ok") => {
                    assert!(r["overall"].as_f64().unwrap().is_finite(), "{r}");
                    meanwhile += r["frames_meanwhile"].as_u64().unwrap();
                    measured += 1;
                }
                Some("error") => {
                    let text = r["message"].as_str().unwrap();
                    assert!(
                        text.starts_with("compute_error: rate limited")
                            || text.contains("queue of expensive requests is full"),
                        "{text}"
                    );
                    limited += 1;
                }
                _ => panic!("{r}"),
            }
        }
        assert!(measured >= 1, "no error was measured");
        assert!(limited >= 250, "only {limited} of 300 were limited");
        // On the frame loop the engine would publish nothing while it solves the reference.
        assert!(
            meanwhile > 0,
            "no frame was published while {measured} errors ran"
        );
        // The last measured error shows in the frames.
        let deadline = Instant::now() + Duration::from_secs(30);
        while frame_message(&mut a).await["error"].is_null() {
            assert!(Instant::now() < deadline, "no frame carries the error");
        }
        ping(&mut a, 99).await;
    });
    s.stop().unwrap();
}

#[test]
fn a_solver_switch_runs_beside_the_frames_and_keeps_a_move_sent_while_it_precomputes() {
    let s = server();
    runtime().block_on(async {
        let mut a = connect(&s).await;
        keep_stepping(&mut a).await;
        let (o, mut matrix) = short_block(&colour_frame(&mut a).await.1);
        let switch = json!({"v": 1, "type": "set_solver", "solver": "grid", "id": 1000});
        a.send(Message::Text(switch.to_string().into()))
            .await
            .unwrap();
        matrix[12] += 0.05;
        a.send(move_message("short_block", &matrix, 1001))
            .await
            .unwrap();
        let (mut switched, mut moved) = (None, None);
        while switched.is_none() || moved.is_none() {
            let r = reply(&mut a).await;
            assert_eq!(r["type"], "ok", "{r}");
            match r["id"].as_u64() {
                Some(1000) => switched = r["frame"].as_u64(),
                Some(1001) => moved = r["frame"].as_u64(),
                _ => panic!("{r}"),
            }
        }
        // Frames after the switch are the grid's, with the block where it was moved.
        let shown = switched.unwrap().max(moved.unwrap());
        let f = loop {
            let f = frame_message(&mut a).await;
            if f["frame"].as_u64().unwrap() >= shown {
                break f;
            }
        };
        assert_eq!(f["solver"], "grid", "{f}");
        let (_, m) = colour_frame(&mut a).await;
        assert!((m[16 * o + 12] - matrix[12]).abs() < 1e-4);
    });
    s.stop().unwrap();
}

/// A server of one seat whose clients are pinged every 0.5 s: long enough that a loaded
/// machine (the suite's other tests) cannot starve a reading client of four periods (2 s).
fn one_seat_server() -> Server {
    server_with(AccessOptions {
        max_clients: 1,
        keepalive: Duration::from_millis(500),
        ..AccessOptions::default()
    })
}

/// A client that gets the seat (its `scene` message) once the one holding it is closed,
/// trying until `within` has passed; `kept` says who kept it when it does not come free.
async fn take_the_seat(s: &Server, within: Duration, kept: &str) -> Ws {
    let deadline = Instant::now() + within;
    loop {
        let mut d = connect(s).await;
        match tokio::time::timeout(Duration::from_secs(30), d.next()).await {
            Ok(Some(Ok(Message::Text(t)))) if t.as_str().contains("\"scene\"") => return d,
            _ => assert!(Instant::now() < deadline, "{kept} kept the seat"),
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// A client that sends and never reads (a ping after another until its socket is full) is
/// closed after a few keepalive periods too, and its seat and steering go to the next: the
/// send that waited for room in its socket held them as long as it stayed connected (over 4
/// minutes when tried), as the keepalive's check runs between sends.
#[test]
fn a_client_that_sends_and_never_reads_loses_its_seat() {
    use futures_util::SinkExt;
    let s = one_seat_server();
    runtime().block_on(async {
        let mut flood = connect_raw(&s).await;
        // Until a send has waited a second: both sockets are full.
        let mut sent = 0u64;
        let message =
            |id: u64| Message::Text(json!({"v": 1, "type": "ping", "id": id}).to_string().into());
        loop {
            let send = tokio::time::timeout(Duration::from_secs(1), flood.send(message(sent)));
            match send.await {
                Ok(Ok(())) => sent += 1,
                Ok(Err(_)) | Err(_) => break,
            }
            assert!(sent < 10_000_000, "the server read everything");
        }
        // The seat comes free while the flood stays connected.
        let flood_of = format!("the flood ({sent} sent)");
        let mut d = take_the_seat(&s, Duration::from_secs(60), &flood_of).await;
        assert_eq!(next_of_type(&mut d, "role").await["role"], "steer");
        ping(&mut d, 1).await;
        drop(flood);
    });
    s.stop().unwrap();
}

/// A client that answers no ping (connected, then never reading: a vanished peer) is closed
/// after a few keepalive periods and its seat is free again; a client that reads answers
/// the pings by itself and keeps its seat however long it stays silent.
#[test]
fn a_client_that_answers_no_ping_is_closed_and_its_seat_freed() {
    let s = one_seat_server();
    runtime().block_on(async {
        let silent = connect_raw(&s).await;
        let mut d = take_the_seat(&s, Duration::from_secs(30), "the silent client").await;
        // Twelve periods, reading (and so answering the pings) but sending nothing.
        let until = Instant::now() + Duration::from_secs(6);
        while Instant::now() < until {
            match tokio::time::timeout(until - Instant::now(), d.next()).await {
                Ok(Some(Ok(Message::Close(f)))) => panic!("closed while reading: {f:?}"),
                Ok(Some(Ok(_))) | Err(_) => {}
                Ok(other) => panic!("the reading client lost its connection: {other:?}"),
            }
        }
        ping(&mut d, 1).await;
        drop(silent);
    });
    s.stop().unwrap();
}
