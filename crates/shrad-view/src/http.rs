//! HTTP and WebSocket (axum): the page's files, three.js from `web/node_modules`, and one
//! task per client at `/ws` (`client.rs`). Every request passes the token check first
//! (`access.rs`); the WebSocket also the origin check and the cap on clients.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::WebSocketUpgrade;
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode, Uri};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use hyper::server::conn::http1::Builder;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::sync::{watch, OwnedSemaphorePermit, Semaphore};
use tokio::task::JoinSet;

use crate::access::Access;
use crate::engine_loop::{Frame, Intro, Shared};
use crate::protocol;

/// What every connection shares.
pub struct App {
    pub web_root: PathBuf,
    pub intro: Intro,
    pub frames: watch::Receiver<Arc<Frame>>,
    pub shared: Arc<Shared>,
    pub stop: watch::Receiver<bool>,
    pub access: Arc<Access>,
    /// The cookie that carries the token once the page was loaded with it (named for the
    /// port: browsers share cookies between a host's ports).
    pub cookie: String,
}

/// How long a client may take to send a request's headers (and a kept-alive connection to
/// start its next request): a client that sends half a request and trickles the rest
/// (slowloris) was held open forever, and 20,000 of them made the server unreachable.
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(10);

/// The most connections open at once (page loads, assets and WebSockets; the WebSockets
/// have their own, smaller cap): beyond it the next waits in the listener's queue.
pub const MAX_CONNECTIONS: usize = 512;

/// Serve until `stop` turns true, then let the open connections finish (the clients' tasks
/// close their WebSockets when they see `stop`). axum's own `serve` has no header timeout:
/// this is its loop with one.
pub async fn run(
    listener: tokio::net::TcpListener,
    app: Arc<App>,
    mut stop: watch::Receiver<bool>,
) -> std::io::Result<()> {
    let router = Router::new()
        .route("/ws", get(websocket))
        .fallback(get(file))
        .layer(middleware::from_fn_with_state(app.clone(), token_check))
        .with_state(app);
    let places = Arc::new(Semaphore::new(MAX_CONNECTIONS));
    let mut connections = JoinSet::new();
    loop {
        let Ok(place) = places.clone().acquire_owned().await else {
            break;
        };
        let accepted = tokio::select! {
            accepted = listener.accept() => accepted,
            _ = stop.wait_for(|s| *s) => break,
        };
        while connections.try_join_next().is_some() {}
        // A failed accept (out of descriptors, a reset) is the client's, not the server's.
        let Ok((socket, _)) = accepted else {
            continue;
        };
        let service = TowerToHyperService::new(router.clone());
        let stop = stop.clone();
        connections.spawn(serve_connection(socket, service, stop, place));
    }
    while connections.join_next().await.is_some() {}
    Ok(())
}

/// One connection, with [`HEADER_TIMEOUT`]; shut down gracefully when `stop` turns true.
async fn serve_connection(
    socket: tokio::net::TcpStream,
    service: TowerToHyperService<Router>,
    mut stop: watch::Receiver<bool>,
    _place: OwnedSemaphorePermit,
) {
    // HTTP/1 only (a browser speaks it to a plain-HTTP server, and upgrades it to the
    // WebSocket): hyper-util's `auto` builder first waited, without a timeout, for the bytes
    // that tell HTTP/1 from HTTP/2, so a connection that sent nothing (or only HTTP/2's
    // preface) was never closed, and 520 of them made the server unreachable. hyper's own
    // HTTP/1 connection starts the header timeout at once.
    let mut builder = Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(HEADER_TIMEOUT);
    let connection = builder
        .serve_connection(TokioIo::new(socket), service)
        .with_upgrades();
    let mut connection = std::pin::pin!(connection);
    tokio::select! {
        _ = connection.as_mut() => return,
        _ = stop.wait_for(|s| *s) => connection.as_mut().graceful_shutdown(),
    }
    let _ = connection.await;
}

/// 401 unless the request carries the token (when there is one): `?token=` in its query,
/// or the cookie set when the page was loaded with it. A good token in the query sets the
/// cookie, so the page's own files and modules (which the page cannot add a query to)
/// follow.
/// Without a token (a server on loopback), a request must name this machine as loopback in
/// its `Host`: a site whose name a rebinding DNS points at 127.0.0.1 sends its own name there
/// (and the same one in `Origin`, so the WebSocket's origin check alone let it steer).
async fn token_check(State(app): State<Arc<App>>, request: Request, next: Next) -> Response {
    if app.access.options().token.is_none() {
        let host = request.headers().get(header::HOST);
        let host = host.map(|h| h.to_str().unwrap_or("(not text)"));
        if let Some(host) = host.filter(|h| !is_loopback_host(h)) {
            let message = format!(
                "403: Host '{host}' refused: a viewer without a token answers only to \
                 127.0.0.1, localhost or [::1] (another site's name pointed at this machine, \
                 DNS rebinding, must not steer it); open the URL `shrad view` printed, or give \
                 --token\n"
            );
            return (StatusCode::FORBIDDEN, message).into_response();
        }
        return next.run(request).await;
    }
    let from_query = request.uri().query().and_then(|q| {
        q.split('&')
            .filter_map(|kv| kv.split_once('='))
            .find(|(k, _)| *k == "token")
            .map(|(_, v)| v.to_string())
    });
    let from_cookie = request
        .headers()
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|h| h.to_str().ok())
        .flat_map(|h| h.split(';'))
        .filter_map(|kv| kv.trim().split_once('='))
        .find(|(k, _)| *k == app.cookie)
        .map(|(_, v)| v.to_string());
    let query_ok = app.access.allows(from_query.as_deref());
    if !(query_ok || app.access.allows(from_cookie.as_deref())) {
        return (
            StatusCode::UNAUTHORIZED,
            "401: this viewer needs its token: open the URL `shrad view` printed (it ends in ?token=...)\n",
        )
            .into_response();
    }
    let mut response = next.run(request).await;
    if let (true, Some(t)) = (query_ok, from_query) {
        let cookie = format!("{}={t}; Path=/; HttpOnly; SameSite=Strict", app.cookie);
        if let Ok(v) = HeaderValue::from_str(&cookie) {
            response.headers_mut().append(header::SET_COOKIE, v);
        }
    }
    response
}

/// Whether a `Host` header (a name or address, with or without a port) names this machine
/// by loopback: `localhost`, `127.x.x.x` or `[::1]`.
fn is_loopback_host(host: &str) -> bool {
    // The name, then nothing or a port (digits only: "127.0.0.1:80@evil.com" passed).
    let (name, port) = match host.strip_prefix('[') {
        Some(v6) => match v6.split_once(']') {
            Some((a, rest)) => (a, rest),
            None => return false,
        },
        None => match host.rsplit_once(':') {
            Some((a, _)) => (a, &host[a.len()..]),
            None => (host, ""),
        },
    };
    let port_ok = match port.strip_prefix(':') {
        Some(digits) => !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()),
        None => port.is_empty(),
    };
    port_ok
        && (name.eq_ignore_ascii_case("localhost")
            || name
                .parse::<std::net::IpAddr>()
                .is_ok_and(|ip| ip.is_loopback()))
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
    // The seat is taken before the upgrade, so that clients connecting at once cannot
    // pass the cap; one over it is upgraded to be told why (a page cannot read the body of
    // a refused handshake).
    let seat = app.access.admit();
    let ws = ws
        .max_message_size(protocol::MAX_WIRE_BYTES)
        .max_frame_size(protocol::MAX_WIRE_BYTES);
    match seat {
        Ok(seat) => ws.on_upgrade(move |socket| crate::client::serve(socket, app, seat)),
        Err(message) => ws.on_upgrade(move |socket| crate::client::refuse(socket, message)),
    }
}

#[cfg(test)]
mod tests {
    use super::is_loopback_host;

    #[test]
    fn loopback_hosts_are_named_by_loopback_only() {
        for ok in [
            "127.0.0.1:8080",
            "127.0.0.1",
            "localhost:1",
            "LOCALHOST",
            "[::1]:9",
            "[::1]",
            "127.1.2.3:5",
        ] {
            assert!(is_loopback_host(ok), "{ok}");
        }
        for no in [
            "evil.com:8080",
            "evil.com",
            "10.0.0.1:80",
            "[::2]:9",
            "localhost.evil.com",
            "",
            "127.0.0.1.evil.com:80",
            // A port that is not one (a browser never sends these; a script may).
            "127.0.0.1:18777@evil.com",
            "localhost:",
            "[::1]x",
            "[::1]:9@evil.com",
            "[::1",
        ] {
            assert!(!is_loopback_host(no), "{no}");
        }
    }
}
