//! HTTP and WebSocket (axum): the page's files, three.js from `web/node_modules`, and one
//! task per client at `/ws` (`client.rs`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use axum::extract::ws::WebSocketUpgrade;
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use tokio::sync::watch;

use crate::engine_loop::{Frame, Intro, Shared};
use crate::protocol;

/// What every connection shares.
pub struct App {
    pub web_root: PathBuf,
    pub intro: Intro,
    pub frames: watch::Receiver<Arc<Frame>>,
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
        .on_upgrade(move |socket| crate::client::serve(socket, app))
}
