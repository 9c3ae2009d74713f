//! HTTP and WebSocket (axum): the page's files, three.js from `web/node_modules`, and one
//! task per client at `/ws`.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::Arc;

use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::json;
use tokio::sync::{mpsc, watch};

use crate::engine_loop::{Command, Frame, Intro, Shared};
use crate::protocol::{self, Request};

/// What every connection shares.
pub struct App {
    pub web_root: PathBuf,
    pub intro: Intro,
    pub frames: watch::Receiver<Arc<Frame>>,
    pub commands: SyncSender<Command>,
    pub shared: Arc<Shared>,
    pub stop: watch::Receiver<bool>,
}

/// Serve until `stop` turns true.
pub async fn run(
    listener: tokio::net::TcpListener,
    app: Arc<App>,
    mut stop: watch::Receiver<bool>,
) -> std::io::Result<()> {
    let router = Router::new()
        .route("/ws", get(websocket))
        .fallback(get(file))
        .with_state(app);
    axum::serve(listener, router)
        .with_graceful_shutdown(async move {
            let _ = stop.wait_for(|s| *s).await;
        })
        .await
}

/// A file of the page: `/` is `web/src/index.html`, `/vendor/three/...` is three.js's
/// `build/` and `examples/jsm/` in `web/node_modules/three`, anything else is `web/src/...`.
/// Only plain names (letters, digits, `.`, `_`, `-`, no leading dot) and known types.
async fn file(State(app): State<Arc<App>>, uri: Uri) -> Response {
    let path = uri.path();
    let Some(file) = resolve(&app.web_root, path) else {
        return (StatusCode::NOT_FOUND, format!("{path}: not found\n")).into_response();
    };
    let Some(kind) = content_type(&file) else {
        return (StatusCode::NOT_FOUND, format!("{path}: not found\n")).into_response();
    };
    match tokio::fs::read(&file).await {
        Ok(bytes) => (
            [
                (header::CONTENT_TYPE, kind),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            bytes,
        )
            .into_response(),
        Err(_) => (StatusCode::NOT_FOUND, format!("{path}: not found\n")).into_response(),
    }
}

fn resolve(root: &Path, path: &str) -> Option<PathBuf> {
    let path = if path == "/" { "/index.html" } else { path };
    let parts: Vec<&str> = path.trim_start_matches('/').split('/').collect();
    let plain = |s: &&str| {
        !s.is_empty()
            && !s.starts_with('.')
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
    };
    if !parts.iter().all(plain) {
        return None;
    }
    let (base, rest): (PathBuf, &[&str]) = match parts.as_slice() {
        ["vendor", "three", "build", ..] => (root.join("node_modules/three"), &parts[2..]),
        ["vendor", "three", "examples", "jsm", ..] => {
            (root.join("node_modules/three"), &parts[2..])
        }
        ["vendor", ..] => return None,
        _ => (root.join("src"), &parts[..]),
    };
    Some(rest.iter().fold(base, |p, s| p.join(s)))
}

fn content_type(p: &Path) -> Option<&'static str> {
    Some(match p.extension()?.to_str()? {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" => "application/json",
        "png" => "image/png",
        "svg" => "image/svg+xml",
        _ => return None,
    })
}

/// The WebSocket endpoint. A page of another origin is refused (a site the user visits must
/// not steer a local server).
async fn websocket(
    ws: WebSocketUpgrade,
    headers: HeaderMap,
    State(app): State<Arc<App>>,
) -> Response {
    if let Some(origin) = headers.get(header::ORIGIN) {
        let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
        let origin_host = origin
            .to_str()
            .ok()
            .and_then(|o| o.split_once("://"))
            .map(|(_, h)| h);
        if host.is_none() || origin_host != host {
            return (
                StatusCode::FORBIDDEN,
                "WebSocket from another origin refused\n",
            )
                .into_response();
        }
    }
    ws.max_message_size(protocol::MAX_WIRE_BYTES)
        .max_frame_size(protocol::MAX_WIRE_BYTES)
        .on_upgrade(move |socket| client(socket, app))
}

/// What one client has asked to receive; undone when it leaves, however it leaves.
struct Subscription {
    shared: Arc<Shared>,
    channel: usize,
    probes: bool,
}

impl Subscription {
    fn new(shared: Arc<Shared>) -> Subscription {
        shared.clients.fetch_add(1, Ordering::Relaxed);
        shared.channel_clients[0].fetch_add(1, Ordering::Relaxed);
        Subscription {
            shared,
            channel: 0,
            probes: false,
        }
    }

    fn set_channel(&mut self, c: usize) {
        self.shared.channel_clients[self.channel].fetch_sub(1, Ordering::Relaxed);
        self.shared.channel_clients[c].fetch_add(1, Ordering::Relaxed);
        self.channel = c;
    }

    fn set_probes(&mut self, on: bool) {
        if on != self.probes {
            if on {
                self.shared.probe_clients.fetch_add(1, Ordering::Relaxed);
            } else {
                self.shared.probe_clients.fetch_sub(1, Ordering::Relaxed);
            }
            self.probes = on;
        }
    }
}

impl Drop for Subscription {
    fn drop(&mut self) {
        self.set_probes(false);
        self.shared.channel_clients[self.channel].fetch_sub(1, Ordering::Relaxed);
        self.shared.clients.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Replies waiting for one client at most (more are dropped).
const REPLIES: usize = 64;

/// One client: its requests go to the engine (or are answered here), and it is sent the
/// newest frame whenever there is one it has not seen.
async fn client(mut socket: WebSocket, app: Arc<App>) {
    let mut sub = Subscription::new(app.shared.clone());
    let (reply_tx, mut replies) = mpsc::channel::<String>(REPLIES);
    let mut frames = app.frames.clone();
    let mut stop = app.stop.clone();
    if socket
        .send(Message::Text(app.intro.scene.clone().into()))
        .await
        .is_err()
        || socket
            .send(Message::Binary(app.intro.geometry.clone()))
            .await
            .is_err()
    {
        return;
    }
    // The engine may be idle: have it publish the channels this client now wants.
    refresh(&app);
    frames.mark_changed();
    let mut sent_stats: Option<Arc<Frame>> = None;
    let mut sent_colours: Option<(u64, usize)> = None;
    let mut sent_probes: Option<u64> = None;
    loop {
        tokio::select! {
            // In this order when several are ready: a reply goes out before the frame that
            // follows it (the engine queues a request's reply before it steps the frame that
            // has the change, and the page learns from the reply which frame that is).
            biased;
            Some(reply) = replies.recv() => {
                if socket.send(Message::Text(reply.into())).await.is_err() {
                    break;
                }
            }
            incoming = socket.recv() => {
                let Some(Ok(message)) = incoming else {
                    // Gone, or a message over the wire limit: say why if we still can.
                    if let Some(Err(e)) = incoming {
                        let _ = socket.send(Message::Close(Some(CloseFrame {
                            code: 1009,
                            reason: format!("{e}").chars().take(100).collect::<String>().into(),
                        }))).await;
                    }
                    break;
                };
                let answer = match message {
                    Message::Text(text) => handle(&app, &mut sub, text.as_str(), &reply_tx),
                    Message::Binary(b) => Some(protocol::error(None, &format!(
                        "binary message of {} bytes refused: clients send JSON text (protocol v{})",
                        b.len(), protocol::VERSION
                    ))),
                    Message::Close(_) => break,
                    Message::Ping(_) | Message::Pong(_) => None,
                };
                if let Some(a) = answer {
                    if socket.send(Message::Text(a.into())).await.is_err() {
                        break;
                    }
                }
            }
            changed = frames.changed() => {
                if changed.is_err() {
                    break;
                }
                let frame = frames.borrow_and_update().clone();
                if frame.seq == 0 {
                    continue;
                }
                if !sent_stats.as_ref().is_some_and(|f| Arc::ptr_eq(f, &frame)) {
                    if socket.send(Message::Text(frame.stats.clone().into())).await.is_err() {
                        break;
                    }
                    sent_stats = Some(frame.clone());
                }
                if let Some(bytes) = &frame.colours[sub.channel] {
                    if sent_colours != Some((frame.seq, sub.channel)) {
                        if socket.send(Message::Binary(bytes.clone())).await.is_err() {
                            break;
                        }
                        sent_colours = Some((frame.seq, sub.channel));
                    }
                }
                if sub.probes {
                    if let Some((seq, text)) = &frame.probes {
                        if sent_probes != Some(*seq) {
                            if socket.send(Message::Text(text.to_string().into())).await.is_err() {
                                break;
                            }
                            sent_probes = Some(*seq);
                        }
                    }
                }
            }
            _ = stopped(&mut stop) => {
                let _ = socket.send(Message::Close(Some(CloseFrame {
                    code: 1001,
                    reason: "server stopping".into(),
                }))).await;
                break;
            }
        }
    }
    drop(sub);
    refresh(&app);
}

/// Resolves once the server is stopping.
async fn stopped(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|s| *s).await;
}

/// Ask the engine to publish again (for channels or probes just asked for).
fn refresh(app: &App) {
    let _ = app.commands.try_send(Command::Refresh);
}

/// A text message: answered here (channel, probes, malformed), or queued for the engine.
fn handle(
    app: &App,
    sub: &mut Subscription,
    text: &str,
    reply: &mpsc::Sender<String>,
) -> Option<String> {
    let envelope = match protocol::parse(text) {
        Ok(e) => e,
        Err(r) => return Some(protocol::error(r.id, &r.message)),
    };
    let id = envelope.id;
    match &envelope.request {
        Request::SetChannel { channel } => {
            return Some(match protocol::channel(channel) {
                Ok(c) => {
                    sub.set_channel(protocol::channel_index(c) as usize);
                    refresh(app);
                    ok(id, "set_channel", json!({ "channel": channel }))
                }
                Err(e) => protocol::error(id, &format!("set_channel: {e}")),
            });
        }
        Request::Probes { on } => {
            sub.set_probes(*on);
            refresh(app);
            return Some(ok(id, "probes", json!({ "on": on })));
        }
        _ => {}
    }
    let kind = envelope.request.kind();
    match app.commands.try_send(Command::Request {
        envelope,
        reply: reply.clone(),
    }) {
        Ok(()) => None,
        Err(TrySendError::Full(_)) => Some(protocol::error(
            id,
            &format!(
                "{kind}: the engine is busy ({} requests waiting); request dropped, send it again",
                crate::QUEUE
            ),
        )),
        Err(TrySendError::Disconnected(_)) => Some(protocol::error(
            id,
            &format!("{kind}: the engine has stopped"),
        )),
    }
}

fn ok(id: Option<u64>, request: &str, mut body: serde_json::Value) -> String {
    if let serde_json::Value::Object(m) = &mut body {
        m.insert("id".into(), json!(id));
        m.insert("request".into(), json!(request));
    }
    protocol::message("ok", body)
}
