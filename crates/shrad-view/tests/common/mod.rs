//! What the server tests share: a page folder, a small server on 127.0.0.1, clients that
//! acknowledge frames as the page does, and bounded waits for replies and frames.
#![allow(dead_code)]

use std::net::{IpAddr, Ipv4Addr};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use shrad_view::{ServeOptions, Server};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

pub type RawWs =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// A client that acknowledges every frame message it reads (`ack`, as the page does), so the
/// server keeps sending it frames.
pub struct Ws {
    pub inner: RawWs,
    pub received: u64,
}

/// Whether the server counts `m` as a frame message (`frame`, `probes`, colours).
pub fn is_frame_message(m: &Message) -> bool {
    match m {
        Message::Text(t) => serde_json::from_str::<Value>(t.as_str())
            .is_ok_and(|v| v["type"] == "frame" || v["type"] == "probes"),
        Message::Binary(b) => b.len() >= 16 && b[6] == 1,
        _ => false,
    }
}

impl Ws {
    pub async fn next(&mut self) -> Option<Result<Message, tokio_tungstenite::tungstenite::Error>> {
        let m = self.inner.next().await;
        if let Some(Ok(message)) = &m {
            if is_frame_message(message) {
                self.received += 1;
                let ack = json!({"v": 1, "type": "ack", "received": self.received});
                let _ = self.inner.send(Message::Text(ack.to_string().into())).await;
            }
        }
        m
    }

    pub async fn send(&mut self, m: Message) -> Result<(), tokio_tungstenite::tungstenite::Error> {
        self.inner.send(m).await
    }
}

/// A page folder with the two files the server checks for (the tests need no npm).
pub fn web_root() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shrad-view-test-web-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("src")).unwrap();
    std::fs::create_dir_all(dir.join("node_modules/three/build")).unwrap();
    std::fs::write(
        dir.join("src/index.html"),
        "<!doctype html><title>test page</title>",
    )
    .unwrap();
    std::fs::write(
        dir.join("node_modules/three/build/three.module.js"),
        "export {};",
    )
    .unwrap();
    dir
}

pub fn server() -> Server {
    let mut o = ServeOptions::new(shrad::scene::cornell_box());
    o.sizing = shrad::PatchSizing::Count(2000);
    o.host = IpAddr::V4(Ipv4Addr::LOCALHOST);
    o.port = 0;
    o.web_root = web_root();
    Server::start(o).unwrap()
}

pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
}

pub async fn connect(s: &Server) -> Ws {
    Ws {
        inner: connect_raw(s).await,
        received: 0,
    }
}

/// A client that acknowledges nothing.
pub async fn connect_raw(s: &Server) -> RawWs {
    let (ws, _) = tokio_tungstenite::connect_async(format!("ws://{}/ws", s.addr()))
        .await
        .unwrap();
    ws
}

/// The next text message that is not a `frame` or `probes` broadcast.
pub async fn reply(ws: &mut Ws) -> Value {
    next_text(ws, "reply", |v| {
        !["frame", "probes", "scene", "role"].contains(&v["type"].as_str().unwrap_or(""))
    })
    .await
}

/// The next text message that is `wanted` (within 30 s; `what` names it in the failure).
async fn next_text(ws: &mut Ws, what: &str, wanted: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let m = tokio::time::timeout(left, ws.next())
            .await
            .unwrap_or_else(|_| panic!("no {what} within 30 s"))
            .expect("connection closed")
            .expect("read error");
        if let Message::Text(t) = m {
            let v: Value = serde_json::from_str(t.as_str()).unwrap();
            if wanted(&v) {
                return v;
            }
        }
    }
}

pub async fn ping(ws: &mut Ws, id: u64) {
    ws.send(Message::Text(
        json!({"v": 1, "type": "ping", "id": id}).to_string().into(),
    ))
    .await
    .unwrap();
    let r = reply(ws).await;
    assert_eq!(r["type"], "pong", "{r}");
    assert_eq!(r["id"], id);
}

/// Read until a colour frame; returns its frame number and the matrices.
pub async fn colour_frame(ws: &mut Ws) -> (u32, Vec<f32>) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let m = tokio::time::timeout(left, ws.next())
            .await
            .expect("no frame within 30 s");
        if let Some(Ok(Message::Binary(b))) = m {
            assert_eq!(&b[0..4], b"SHRV");
            if b[6] != 1 {
                continue;
            }
            let frame = u32::from_le_bytes(b[8..12].try_into().unwrap());
            let n = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
            let vertices = u32::from_le_bytes(b[20..24].try_into().unwrap()) as usize;
            assert_eq!(b.len(), 24 + 64 * n + 6 * vertices);
            let m: Vec<f32> = b[24..24 + 64 * n]
                .chunks(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect();
            return (frame, m);
        }
    }
}

/// A plain HTTP GET; the status line's code.
pub async fn http_get(s: &Server, path: &str) -> u16 {
    http_request(s, path, "").await.0
}

pub async fn still_answers(s: &Server) {
    let mut ws = connect(s).await;
    ping(&mut ws, 4242).await;
    colour_frame(&mut ws).await;
    assert_eq!(http_get(s, "/").await, 200);
}

/// Ask the engine to step without end (`run`, `continuous`), and that it agrees.
pub async fn keep_stepping(ws: &mut Ws) {
    let request = json!({"v": 1, "type": "run", "continuous": true, "id": 0});
    assert_eq!(ask(ws, request).await["type"], "ok");
}

/// The Cornell box's short block: its index among the objects, and its matrix (16 floats)
/// in a colour frame's `matrices`.
pub fn short_block(matrices: &[f32]) -> (usize, Vec<f32>) {
    let o = shrad::scene::cornell_box()
        .objects
        .iter()
        .position(|o| o.name == "short_block")
        .unwrap();
    (o, matrices[16 * o..16 * o + 16].to_vec())
}

/// Send a move of `object` to `matrix` with `id`.
pub fn move_message(object: &str, matrix: &[f32], id: u64) -> Message {
    let request =
        json!({"v": 1, "type": "set_transform", "object": object, "id": id, "matrix": matrix});
    Message::Text(request.to_string().into())
}

/// Send a request and return its reply (skipping broadcasts).
pub async fn ask(ws: &mut Ws, request: Value) -> Value {
    ws.send(Message::Text(request.to_string().into()))
        .await
        .unwrap();
    reply(ws).await
}

/// The next `frame` message.
pub async fn frame_message(ws: &mut Ws) -> Value {
    next_of_type(ws, "frame").await
}

/// A plain HTTP GET with `extra` header lines; the status code and the whole response head.
pub async fn http_request(s: &Server, path: &str, extra: &str) -> (u16, String) {
    let mut tcp = tokio::net::TcpStream::connect(s.addr()).await.unwrap();
    tcp.write_all(
        format!(
            "GET {path} HTTP/1.1\r\nHost: {}\r\n{extra}Connection: close\r\n\r\n",
            s.addr()
        )
        .as_bytes(),
    )
    .await
    .unwrap();
    let mut out = Vec::new();
    tcp.read_to_end(&mut out).await.unwrap();
    let text = String::from_utf8_lossy(&out).into_owned();
    let code = text.split_whitespace().nth(1).unwrap().parse().unwrap();
    (code, text)
}

/// The next text message of type `kind` (others skipped), within 30 s.
pub async fn next_of_type(ws: &mut Ws, kind: &str) -> Value {
    next_text(ws, &format!("{kind} message"), |v| v["type"] == kind).await
}

/// The small Cornell box on 127.0.0.1 (any port) with the sharing rules `access`.
pub fn options_with(access: shrad_view::AccessOptions) -> ServeOptions {
    let mut o = ServeOptions::new(shrad::scene::cornell_box());
    o.sizing = shrad::PatchSizing::Count(2000);
    o.host = IpAddr::V4(Ipv4Addr::LOCALHOST);
    o.port = 0;
    o.web_root = web_root();
    o.access = access;
    o
}

/// A server on [`options_with`] `access`.
pub fn server_with(access: shrad_view::AccessOptions) -> Server {
    Server::start(options_with(access)).unwrap()
}

/// A client at `url` (a `ws://` URL with whatever query it needs).
pub async fn connect_url(url: &str) -> Ws {
    let (inner, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    Ws { inner, received: 0 }
}
