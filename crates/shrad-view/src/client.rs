//! One WebSocket client: a reader and a writer on the two halves of its socket, so that
//! reading the client's steering never waits behind a frame being written.
//!
//! - The reader answers what the client's own task can (channel, probes, malformed
//!   messages, acknowledgements) and puts the rest into the engine's [`Inbox`], where a
//!   newer request of the same key (an object's transform...) replaces an older one; the one
//!   replaced is answered at once (`ok`, `"superseded": true`).
//! - The writer sends replies first, then the newest frame: never a queue of frames. At most
//!   [`protocol::MAX_IN_FLIGHT_BYTES`] of frame messages are unacknowledged (the client
//!   sends `ack` with the count it has received), so the socket's buffers never hold
//!   seconds of old frames ahead of a reply or of the frame that has the client's move.
//!
//! [`Inbox`]: crate::inbox::Inbox

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::extract::ws::{CloseFrame, Message, WebSocket};
use futures_util::stream::{SplitSink, SplitStream};
use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use tokio::sync::{mpsc, Notify};

use crate::access::{RateLimit, Seat, EXPENSIVE_BURST, EXPENSIVE_EVERY_S};
use crate::engine_loop::{Frame, Shared};
use crate::http::App;
use crate::inbox::{Key, Pending, Refusal, Reply, ReplyTo, CAPACITY};
use crate::protocol::{self, Request};

/// Replies waiting for one client at most, those the engine owes included (each request
/// handed to the engine holds its reply's place): beyond, this client's reader waits for
/// room, and so stops reading a client that reads nothing.
const REPLIES: usize = 64;

/// What one client has asked to receive, its seat (role) and its allowance of expensive
/// requests; undone when it leaves, however it leaves.
struct Subscription {
    shared: Arc<Shared>,
    channel: AtomicUsize,
    probes: AtomicBool,
    seat: Seat,
    expensive: Mutex<RateLimit>,
}

impl Subscription {
    fn new(shared: Arc<Shared>, seat: Seat) -> Subscription {
        shared.clients.fetch_add(1, Ordering::Relaxed);
        shared.channel_clients[0].fetch_add(1, Ordering::Relaxed);
        Subscription {
            shared,
            channel: AtomicUsize::new(0),
            probes: AtomicBool::new(false),
            seat,
            expensive: Mutex::new(RateLimit::default()),
        }
    }

    fn channel(&self) -> usize {
        self.channel.load(Ordering::Relaxed)
    }

    fn probes(&self) -> bool {
        self.probes.load(Ordering::Relaxed)
    }

    fn set_channel(&self, c: usize) {
        let old = self.channel.swap(c, Ordering::Relaxed);
        self.shared.channel_clients[old].fetch_sub(1, Ordering::Relaxed);
        self.shared.channel_clients[c].fetch_add(1, Ordering::Relaxed);
    }

    fn set_probes(&self, on: bool) {
        if self.probes.swap(on, Ordering::Relaxed) != on {
            if on {
                self.shared.probe_clients.fetch_add(1, Ordering::Relaxed);
            } else {
                self.shared.probe_clients.fetch_sub(1, Ordering::Relaxed);
            }
        }
    }
}

impl Drop for Subscription {
    fn drop(&mut self) {
        self.set_probes(false);
        self.shared.channel_clients[self.channel()].fetch_sub(1, Ordering::Relaxed);
        self.shared.clients.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Flow control between the two halves: frame messages the writer has sent, and the
/// count the client says it has received.
#[derive(Default)]
struct Flow {
    sent: AtomicU64,
    acked: AtomicU64,
    wake: Notify,
    /// Keepalive periods that passed since the client last sent anything (a pong too).
    silent: AtomicU64,
}

impl Flow {
    /// The client has received `received` frame messages (a count that goes back is
    /// ignored: the newest acknowledgement stands).
    fn ack(&self, received: u64) -> Result<(), String> {
        let sent = self.sent.load(Ordering::Acquire);
        if received > sent {
            return Err(format!(
                "{received} frame messages acknowledged, but {sent} were sent"
            ));
        }
        self.acked.fetch_max(received, Ordering::Release);
        self.wake.notify_one();
        Ok(())
    }
}

/// The sizes of the frame messages sent and not yet acknowledged.
#[derive(Default)]
struct InFlight {
    sizes: VecDeque<usize>,
    bytes: usize,
    acked: u64,
}

impl InFlight {
    fn release(&mut self, acked: u64) {
        while self.acked < acked {
            let Some(b) = self.sizes.pop_front() else {
                break;
            };
            self.bytes -= b;
            self.acked += 1;
        }
    }

    /// Whether `bytes` more may go now: within the bound, or nothing in flight.
    fn has_room_for(&self, bytes: usize) -> bool {
        self.bytes == 0 || self.bytes + bytes <= protocol::MAX_IN_FLIGHT_BYTES
    }

    fn sent(&mut self, bytes: usize) {
        self.sizes.push_back(bytes);
        self.bytes += bytes;
    }
}

/// What of the published frames this client has been sent.
#[derive(Default)]
struct Sent {
    stats: Option<Arc<Frame>>,
    colours: Option<(u64, usize)>,
    probes: Option<u64>,
}

impl Sent {
    /// The messages of `frame` this client has not had, and what it will have had once
    /// they are sent.
    fn missing(&self, frame: &Arc<Frame>, sub: &Subscription) -> (Vec<Message>, Sent) {
        let mut out = Vec::new();
        let mut next = Sent {
            stats: self.stats.clone(),
            colours: self.colours,
            probes: self.probes,
        };
        if frame.seq == 0 {
            return (out, next);
        }
        if !self.stats.as_ref().is_some_and(|f| Arc::ptr_eq(f, frame)) {
            out.push(Message::Text(frame.stats.clone().into()));
            next.stats = Some(frame.clone());
        }
        let channel = sub.channel();
        if let Some(bytes) = &frame.colours[channel] {
            if self.colours != Some((frame.seq, channel)) {
                out.push(Message::Binary(bytes.clone()));
                next.colours = Some((frame.seq, channel));
            }
        }
        if sub.probes() {
            if let Some((seq, text)) = &frame.probes {
                if self.probes != Some(*seq) {
                    out.push(Message::Text(text.to_string().into()));
                    next.probes = Some(*seq);
                }
            }
        }
        (out, next)
    }
}

fn size(m: &Message) -> usize {
    match m {
        Message::Text(t) => t.len(),
        Message::Binary(b) => b.len(),
        _ => 0,
    }
}

/// Tell a client over the cap why it is refused, and close (1013: try again later).
pub async fn refuse(mut socket: WebSocket, message: String) {
    let text = protocol::message("refused", json!({ "message": message }));
    let _ = socket.send(Message::Text(text.into())).await;
    let reason: String = message.chars().take(60).collect();
    let close = CloseFrame {
        code: 1013,
        reason: reason.into(),
    };
    let _ = socket.send(Message::Close(Some(close))).await;
}

/// Serve one client until it leaves or the server stops.
pub async fn serve(socket: WebSocket, app: Arc<App>, seat: Seat) {
    let sub = Subscription::new(app.shared.clone(), seat);
    let (mut sink, mut stream) = socket.split();
    let limit = send_limit(&app);
    let intro = [
        Some(Message::Text(app.intro.scene.clone().into())),
        Some(Message::Binary(app.intro.geometry.clone())),
        app.intro.sky.clone().map(Message::Binary),
    ];
    for m in intro.into_iter().flatten() {
        if send_within(&mut sink, m, limit).await.is_none() {
            return;
        }
    }
    // The engine may be idle: have it publish the channels this client now wants.
    app.shared.inbox.refresh();
    let flow = Flow::default();
    let (reply_tx, replies) = mpsc::channel::<String>(REPLIES);
    // Steers if nobody does; its `role` message goes first.
    sub.seat.join(reply_tx.clone());
    let close = tokio::select! {
        c = read(&mut stream, &app, &sub, &flow, &reply_tx) => c,
        c = write(&mut sink, &app, &sub, &flow, replies) => c,
    };
    // Not waited for longer than a send: a client that reads nothing never takes it.
    let _ = tokio::time::timeout(limit, async {
        match close {
            Some(frame) => {
                let _ = sink.send(Message::Close(Some(frame))).await;
            }
            // The client closed (or went): the close it sent is answered as the closing
            // handshake asks (a client saw 1006, an abnormal closure, when it was not).
            None => {
                let _ = sink.close().await;
            }
        }
    })
    .await;
    drop(sub);
    app.shared.inbox.refresh();
}

/// How long one message may take to go: three keepalive periods, as long as a client may
/// leave the pings unanswered. A client that sends and never reads filled its socket, and
/// the send that waited for room held its seat (and the steering) for as long as it stayed
/// connected: the keepalive's check runs between sends.
fn send_limit(app: &App) -> std::time::Duration {
    3 * app.access.options().keepalive
}

/// The slowest link a large message is given time for, on top of [`send_limit`] (bytes/s):
/// each MB of a scene's geometry may take 16 s more.
const SLOWEST_LINK: f64 = 64.0 * 1024.0;

/// Send `m`, unless it cannot go within `limit` ([`send_limit`]) and the time its size
/// takes at [`SLOWEST_LINK`]; `None` when it did not go (the client is gone, or reads
/// nothing).
async fn send_within(
    sink: &mut SplitSink<WebSocket, Message>,
    m: Message,
    limit: std::time::Duration,
) -> Option<()> {
    let limit = limit + std::time::Duration::from_secs_f64(size(&m) as f64 / SLOWEST_LINK);
    tokio::time::timeout(limit, sink.send(m)).await.ok()?.ok()
}

/// The close code (RFC 6455, 7.4.1) for what broke the stream: 1009 for a message over the
/// limit, 1007 for text that is not UTF-8, 1002 for a frame against the protocol (masking,
/// reserved bits, opcodes), 1011 for anything else. (Every one was 1009.)
fn close_code(e: axum::Error) -> u16 {
    use tungstenite::Error as Ws;
    match e.into_inner().downcast_ref::<Ws>() {
        Some(Ws::Capacity(_)) => 1009,
        Some(Ws::Utf8(_)) => 1007,
        Some(Ws::Protocol(_)) => 1002,
        _ => 1011,
    }
}

/// Read the client's messages until it leaves; the close frame to send, if any.
async fn read(
    stream: &mut SplitStream<WebSocket>,
    app: &App,
    sub: &Subscription,
    flow: &Flow,
    reply: &ReplyTo,
) -> Option<CloseFrame> {
    loop {
        let message = match stream.next().await {
            None => return None,
            // A message over the wire limit, a frame against the protocol, or a broken
            // stream: say why if we still can.
            Some(Err(e)) => {
                let reason = format!("{e}").chars().take(100).collect::<String>();
                return Some(CloseFrame {
                    code: close_code(e),
                    reason: reason.into(),
                });
            }
            Some(Ok(m)) => m,
        };
        flow.silent.store(0, Ordering::Release);
        let answer = match message {
            Message::Text(text) => handle(app, sub, flow, text.as_str(), reply).await,
            Message::Binary(b) => Some(protocol::error(
                None,
                &format!(
                    "binary message of {} bytes refused: clients send JSON text (protocol v{})",
                    b.len(),
                    protocol::VERSION
                ),
            )),
            Message::Close(_) => return None,
            Message::Ping(_) | Message::Pong(_) => None,
        };
        if let Some(a) = answer {
            if reply.send(a).await.is_err() {
                return None;
            }
        }
    }
}

/// Send replies, then the newest frame whenever there is one this client has not had and
/// room in flight for it. Returns the close frame to send, if any.
async fn write(
    sink: &mut SplitSink<WebSocket, Message>,
    app: &App,
    sub: &Subscription,
    flow: &Flow,
    mut replies: mpsc::Receiver<String>,
) -> Option<CloseFrame> {
    let mut frames = app.frames.clone();
    let mut stop = app.stop.clone();
    let mut in_flight = InFlight::default();
    let mut sent = Sent::default();
    let period = app.access.options().keepalive;
    let mut keepalive = tokio::time::interval_at(tokio::time::Instant::now() + period, period);
    let limit = send_limit(app);
    // What is already queued (the `role` message of `Seat::join`) goes ahead of the first
    // frame, as the protocol says: the frame went first, as the loop looks at frames first.
    while let Ok(reply) = replies.try_recv() {
        send_within(sink, Message::Text(reply.into()), limit).await?;
    }
    // A frame may be out that this client has not had.
    let mut newer = true;
    loop {
        in_flight.release(flow.acked.load(Ordering::Acquire));
        if newer {
            let frame = frames.borrow_and_update().clone();
            let (messages, next) = sent.missing(&frame, sub);
            let bytes: usize = messages.iter().map(size).sum();
            if messages.is_empty() {
                newer = false;
            } else if in_flight.has_room_for(bytes) {
                for m in messages {
                    in_flight.sent(size(&m));
                    // Counted before it goes: the client may acknowledge it at once.
                    flow.sent.fetch_add(1, Ordering::Release);
                    send_within(sink, m, limit).await?;
                }
                sent = next;
                newer = false;
            }
        }
        tokio::select! {
            // Replies first: the engine queues a request's reply before it steps the frame
            // that has the change, and the page learns from the reply which frame that is.
            biased;
            Some(reply) = replies.recv() => {
                send_within(sink, Message::Text(reply.into()), limit).await?;
            }
            _ = flow.wake.notified() => {}
            changed = frames.changed(), if !newer => {
                changed.ok()?;
                newer = true;
            }
            _ = stopped(&mut stop) => {
                return Some(CloseFrame { code: 1001, reason: "server stopping".into() });
            }
            _ = keepalive.tick() => {
                if flow.silent.fetch_add(1, Ordering::AcqRel) >= 3 {
                    return Some(CloseFrame { code: 1001, reason: "no answer to pings".into() });
                }
                send_within(sink, Message::Ping(Default::default()), limit).await?;
            }
        }
    }
}

/// Resolves once the server is stopping.
async fn stopped(stop: &mut tokio::sync::watch::Receiver<bool>) {
    let _ = stop.wait_for(|s| *s).await;
}

/// A text message: answered here (channel, probes, acknowledgements, malformed), or put
/// into the engine's inbox (answering the older request it replaces).
async fn handle(
    app: &App,
    sub: &Subscription,
    flow: &Flow,
    text: &str,
    reply: &ReplyTo,
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
                    app.shared.inbox.refresh();
                    ok(id, "set_channel", json!({ "channel": channel }))
                }
                Err(e) => protocol::error(id, &format!("set_channel: {e}")),
            });
        }
        Request::Probes { on } => {
            sub.set_probes(*on);
            app.shared.inbox.refresh();
            return Some(ok(id, "probes", json!({ "on": on })));
        }
        Request::Ack { received } => {
            return flow
                .ack(*received)
                .err()
                .map(|e| protocol::error(id, &format!("ack: {e}")));
        }
        Request::TakeSteering {} => {
            return Some(match sub.seat.take_steering() {
                Ok(()) => ok(id, "take_steering", json!({ "role": "steer" })),
                Err(e) => protocol::error(id, &format!("take_steering: {e}")),
            });
        }
        Request::ReleaseSteering {} => {
            return Some(match sub.seat.release_steering() {
                Ok(()) => ok(id, "release_steering", json!({ "role": "watch" })),
                Err(e) => protocol::error(id, &format!("release_steering: {e}")),
            });
        }
        _ => {}
    }
    let kind = envelope.request.kind();
    if let Some(refusal) = refused(sub, &envelope.request) {
        return Some(protocol::error(id, &format!("{kind}: {refusal}")));
    }
    // The client has gone if there is no place for the reply.
    let place = Reply::reserve(reply).await?;
    let pending = Pending {
        key: Key::of(&envelope.request, &app.intro.names),
        envelope,
        reply: place,
        received: Instant::now(),
        received_at_frame: app.frames.borrow().seq,
        client: sub.seat.id,
    };
    match app.shared.inbox.push(pending) {
        Ok(None) => None,
        Ok(Some(older)) => {
            superseded(older, id, reply);
            None
        }
        Err(Refusal::Full) => Some(protocol::error(
            id,
            &format!(
                "{kind}: the engine is busy ({CAPACITY} requests waiting); request dropped, send it again"
            ),
        )),
        Err(Refusal::Stopped) => Some(protocol::error(
            id,
            &format!("{kind}: the engine has stopped"),
        )),
    }
}

/// Why this client may not send `request` now, if it may not: steering from a watcher,
/// or an expensive request beyond its allowance.
fn refused(sub: &Subscription, request: &Request) -> Option<String> {
    if request.is_steering() && !sub.seat.steers() {
        return Some(format!(
            "refused: this client watches ({}); steering messages come from the client that steers",
            sub.seat.why_watching()
        ));
    }
    if matches!(
        request,
        Request::ComputeError {} | Request::SetSolver { .. }
    ) {
        let mut limit = sub.expensive.lock().unwrap_or_else(|e| e.into_inner());
        if let Err(wait) = limit.spend(Instant::now()) {
            return Some(format!(
                "rate limited: a client may ask for {EXPENSIVE_BURST} errors or solver switches at once, then one every {EXPENSIVE_EVERY_S} s; try again in {wait:.1} s"
            ));
        }
    }
    None
}

/// Answer `older`, replaced by request `by` of the client whose replies go to `reply`
/// before the engine applied it: `ok` with `"superseded": true` (and the newer request's
/// id when it is the same client's).
fn superseded(older: Pending, by: Option<u64>, reply: &ReplyTo) {
    let own = older.reply.goes_to(reply);
    let body = json!({
        "superseded": true,
        "superseded_by": if own { json!(by) } else { Value::Null },
    });
    let text = ok(older.envelope.id, older.envelope.request.kind(), body);
    older.answer(text);
}

fn ok(id: Option<u64>, request: &str, mut body: Value) -> String {
    if let Value::Object(m) = &mut body {
        m.insert("id".into(), json!(id));
        m.insert("request".into(), json!(request));
    }
    protocol::message("ok", body)
}
