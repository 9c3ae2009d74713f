//! The engine's inbox: what the clients ask of the engine thread, waiting for the start of
//! the next frame. Steering never queues behind itself: a request that sets a state (an
//! object's transform, a light's emission, a setting, the time, the solver...) replaces an
//! older one of the same key that the engine has not applied yet, so the engine applies only
//! the newest state, once, at the start of each frame. The one replaced is answered at once
//! (`ok` with `"superseded": true`). Requests without a state (`ping`, `compute_error`) wait
//! in order, at most [`CAPACITY`] of them.
//!
//! The order of what remains is the order of arrival of each key's newest request: applying
//! them in that order gives the state that applying every request in turn would give.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use tokio::sync::mpsc;

use crate::protocol::{self, Envelope, ObjectRef, Request};

/// Requests waiting for the engine at most (a key's newest request replaces its older one,
/// so this bounds the keyless ones and the number of distinct keys); beyond, a request is
/// refused with an error.
pub const CAPACITY: usize = 256;

/// What a request sets: two requests of one key set the same state, so only the newer one
/// matters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Key {
    /// An object's transform (by scene index).
    Transform(usize),
    /// A light surface's emission (by scene index).
    Emission(usize),
    /// An object's reflectance (by scene index).
    Reflectance(usize),
    /// A punctual light's transform (by index in the scene's lights).
    LightTransform(usize),
    /// A punctual light's colour and intensity (by index).
    LightIntensity(usize),
    /// A solver setting (by key).
    Setting(String),
    /// The animation's time.
    Time,
    /// Playing or paused (and speed).
    Play,
    /// Continuous stepping.
    Run,
    /// The solver.
    Solver,
}

/// The names requests may use for what they set: the scene's objects and punctual lights,
/// by index.
#[derive(Clone, Debug, Default)]
pub struct Names {
    /// The objects' names.
    pub objects: Vec<String>,
    /// The punctual lights' names.
    pub lights: Vec<String>,
}

/// The index `r` names among `names`, as the engine resolves it (`Engine::object`): a name
/// to its index, else a number written as text ("6", "+6", "06": three moves of one object
/// that did not share its key, so none replaced another).
fn index_of(r: &ObjectRef, names: &[String]) -> Option<usize> {
    match r {
        ObjectRef::Index(o) => (*o < names.len()).then_some(*o),
        ObjectRef::Name(n) => (names.iter().position(|m| m == n))
            .or_else(|| n.parse::<usize>().ok().filter(|&o| o < names.len())),
    }
}

impl Key {
    /// The key of `request`; `names` are the scene's (a name resolves to its index, so that
    /// a move by name and one by index share their key). `None`: the request sets nothing
    /// (or names nothing that exists) and waits in order.
    pub fn of(request: &Request, names: &Names) -> Option<Key> {
        let object = |r: &ObjectRef| index_of(r, &names.objects);
        let light = |r: &ObjectRef| index_of(r, &names.lights);
        match request {
            Request::SetTransform { object: o, .. } => object(o).map(Key::Transform),
            Request::SetEmission { object: o, .. } => object(o).map(Key::Emission),
            Request::SetReflectance { object: o, .. } => object(o).map(Key::Reflectance),
            Request::SetLightTransform { light: l, .. } => light(l).map(Key::LightTransform),
            Request::SetLightIntensity { light: l, .. } => light(l).map(Key::LightIntensity),
            Request::SetOption { key, .. } => Some(Key::Setting(key.clone())),
            Request::SetTime { .. } => Some(Key::Time),
            Request::Play { .. } => Some(Key::Play),
            Request::Run { .. } => Some(Key::Run),
            Request::SetSolver { .. } => Some(Key::Solver),
            Request::ComputeError {}
            | Request::Ping {}
            | Request::SetChannel { .. }
            | Request::Probes { .. }
            | Request::Ack { .. }
            | Request::TakeSteering {}
            | Request::ReleaseSteering {} => None,
        }
    }
}

/// A client's reply queue (bounded: a client that reads nothing stops being read).
pub type ReplyTo = mpsc::Sender<String>;

/// The place a request's reply holds in its client's reply queue, taken when the server
/// read the request: the engine answers without waiting, and no answer is lost however
/// slowly the client reads (a full queue only stops the server reading that client).
pub struct Reply {
    slot: mpsc::OwnedPermit<String>,
    to: ReplyTo,
}

impl Reply {
    /// Wait for a place in `to`; `None` if the client has gone.
    pub async fn reserve(to: &ReplyTo) -> Option<Reply> {
        let slot = to.clone().reserve_owned().await.ok()?;
        Some(Reply {
            slot,
            to: to.clone(),
        })
    }

    /// A place in `to` if there is one now (tests).
    #[cfg(test)]
    pub fn try_reserve(to: &ReplyTo) -> Option<Reply> {
        let slot = to.clone().try_reserve_owned().ok()?;
        Some(Reply {
            slot,
            to: to.clone(),
        })
    }

    /// Whether this reply goes to the queue `to`.
    pub fn goes_to(&self, to: &ReplyTo) -> bool {
        self.to.same_channel(to)
    }

    /// Put `text` in its place.
    pub fn send(self, text: String) {
        self.slot.send(text);
    }
}

/// One request waiting for the engine.
pub struct Pending {
    /// What the client asked.
    pub envelope: Envelope,
    /// Its key, if it sets a state.
    pub key: Option<Key>,
    /// Its place in the client's reply queue.
    pub reply: Reply,
    /// When the server read it.
    pub received: Instant,
    /// The newest frame published when the server read it (the engine applies it at the
    /// start of frame `received_at_frame + 2` at the latest).
    pub received_at_frame: u64,
    /// The client's number (its seat, `access.rs`): one expensive job each at a time.
    pub client: u64,
}

impl Pending {
    /// Answer with `text`.
    pub fn answer(self, text: String) {
        self.reply.send(text);
    }

    /// Answer with an error: `message`, after the request's kind.
    pub fn refuse(self, message: &str) {
        let (id, kind) = (self.envelope.id, self.envelope.request.kind());
        self.answer(protocol::error(id, &format!("{kind}: {message}")));
    }
}

/// What the engine takes at the start of a frame.
pub struct Batch {
    /// The requests, in the order to apply them.
    pub requests: Vec<Pending>,
    /// Some client wants the state published again (a channel or the probes asked for).
    pub refresh: bool,
}

/// Why a request was not queued.
pub enum Refusal {
    /// [`CAPACITY`] requests are waiting.
    Full,
    /// The engine has stopped.
    Stopped,
}

#[derive(Default)]
struct Queue {
    items: VecDeque<Pending>,
    refresh: bool,
    stopped: bool,
}

/// Counts of what went through the inbox (for the page's panel, tests and diagnostics).
#[derive(Default)]
pub struct Counters {
    /// Requests queued for the engine.
    pub received: AtomicU64,
    /// Requests replaced by a newer one of their key before the engine applied them.
    pub superseded: AtomicU64,
    /// `set_transform` requests the engine applied.
    pub transforms_applied: AtomicU64,
    /// The most requests of one key ever waiting at once (1 when coalescing works).
    pub most_pending_per_key: AtomicUsize,
    /// The most requests ever waiting at once.
    pub most_pending: AtomicUsize,
}

/// A snapshot of [`Counters`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InboxCounts {
    /// Requests queued for the engine.
    pub received: u64,
    /// Requests replaced by a newer one of their key before the engine applied them.
    pub superseded: u64,
    /// `set_transform` requests the engine applied.
    pub transforms_applied: u64,
    /// The most requests of one key ever waiting at once.
    pub most_pending_per_key: usize,
    /// The most requests ever waiting at once.
    pub most_pending: usize,
}

/// The inbox: a queue under a mutex, and a condition variable the idle engine waits on.
#[derive(Default)]
pub struct Inbox {
    queue: Mutex<Queue>,
    wake: Condvar,
    /// What went through it.
    pub counters: Counters,
}

impl Inbox {
    fn lock(&self) -> MutexGuard<'_, Queue> {
        // A panic while holding the lock cannot leave the queue inconsistent (every change is
        // one push or one drain): go on with it.
        self.queue.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queue `p`; returns the older request of its key that it replaces, if any (the caller
    /// answers it).
    pub fn push(&self, p: Pending) -> Result<Option<Pending>, Refusal> {
        let mut q = self.lock();
        if q.stopped {
            return Err(Refusal::Stopped);
        }
        let older = p
            .key
            .as_ref()
            .and_then(|k| q.items.iter().position(|i| i.key.as_ref() == Some(k)))
            .and_then(|at| q.items.remove(at));
        if older.is_none() && q.items.len() >= CAPACITY {
            return Err(Refusal::Full);
        }
        let key = p.key.clone();
        q.items.push_back(p);
        let c = &self.counters;
        c.received.fetch_add(1, Ordering::Relaxed);
        if older.is_some() {
            c.superseded.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(k) = key {
            let same = q
                .items
                .iter()
                .filter(|i| i.key.as_ref() == Some(&k))
                .count();
            c.most_pending_per_key.fetch_max(same, Ordering::Relaxed);
        }
        c.most_pending.fetch_max(q.items.len(), Ordering::Relaxed);
        drop(q);
        self.wake.notify_one();
        Ok(older)
    }

    /// Ask the engine to publish again.
    pub fn refresh(&self) {
        self.lock().refresh = true;
        self.wake.notify_one();
    }

    /// Requests waiting now.
    pub fn len(&self) -> usize {
        self.lock().items.len()
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Take everything waiting (the engine, at the start of a frame).
    pub fn take(&self) -> Batch {
        let mut q = self.lock();
        Batch {
            requests: q.items.drain(..).collect(),
            refresh: std::mem::take(&mut q.refresh),
        }
    }

    /// Wait until something is waiting or `timeout` has passed, then take it.
    pub fn wait(&self, timeout: Duration) -> Batch {
        let q = self.lock();
        let (mut q, _) = self
            .wake
            .wait_timeout_while(q, timeout, |q| q.items.is_empty() && !q.refresh)
            .unwrap_or_else(|e| e.into_inner());
        Batch {
            requests: q.items.drain(..).collect(),
            refresh: std::mem::take(&mut q.refresh),
        }
    }

    /// Refuse requests from now on (the engine has stopped); those waiting are dropped.
    pub fn close(&self) {
        let mut q = self.lock();
        q.stopped = true;
        q.items.clear();
    }

    /// A snapshot of the counters.
    pub fn counts(&self) -> InboxCounts {
        let c = &self.counters;
        InboxCounts {
            received: c.received.load(Ordering::Relaxed),
            superseded: c.superseded.load(Ordering::Relaxed),
            transforms_applied: c.transforms_applied.load(Ordering::Relaxed),
            most_pending_per_key: c.most_pending_per_key.load(Ordering::Relaxed),
            most_pending: c.most_pending.load(Ordering::Relaxed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol;

    fn pending(text: &str, reply: &ReplyTo) -> Pending {
        let envelope = protocol::parse(text).unwrap();
        let names = Names {
            objects: vec!["floor".to_string(), "short_block".to_string()],
            lights: vec!["bulb".to_string()],
        };
        Pending {
            key: Key::of(&envelope.request, &names),
            envelope,
            reply: Reply::try_reserve(reply).unwrap(),
            received: Instant::now(),
            received_at_frame: 0,
            client: 1,
        }
    }

    /// A request of type `kind` that moves `field` `target` to `x` along x.
    fn translation(kind: &str, field: &str, id: u64, target: &str, x: f64) -> String {
        format!(
            r#"{{"v":1,"id":{id},"type":"{kind}","{field}":{target},"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,{x},0,0,1]}}"#
        )
    }

    fn moved(id: u64, object: &str, x: f64) -> String {
        translation("set_transform", "object", id, object, x)
    }

    /// Push `text`, which the inbox accepts; the id of the request it replaced, if one.
    fn push(inbox: &Inbox, text: &str, reply: &ReplyTo) -> Option<Option<u64>> {
        let replaced = inbox.push(pending(text, reply)).ok().unwrap();
        replaced.map(|p| p.envelope.id)
    }

    /// The ids of the requests the inbox hands over, in order.
    fn taken_ids(inbox: &Inbox) -> Vec<Option<u64>> {
        inbox
            .take()
            .requests
            .iter()
            .map(|p| p.envelope.id)
            .collect()
    }

    #[test]
    fn a_newer_move_of_one_object_replaces_the_older_and_keeps_the_order_of_arrival() {
        let (tx, _rx) = mpsc::channel(2 * CAPACITY);
        let inbox = Inbox::default();
        assert_eq!(push(&inbox, &moved(1, "1", 0.1), &tx), None);
        assert_eq!(push(&inbox, r#"{"v":1,"id":2,"type":"ping"}"#, &tx), None);
        // The same object by name: the same key.
        let older = push(&inbox, &moved(3, "\"short_block\"", 0.3), &tx);
        assert_eq!(older, Some(Some(1)));
        // By its index written as text, as the engine reads it too: the same key.
        let older = push(&inbox, &moved(5, "\"+1\"", 0.5), &tx);
        assert_eq!(older, Some(Some(3)));
        let older = push(&inbox, &moved(6, "\"01\"", 0.6), &tx);
        assert_eq!(older, Some(Some(5)));
        // Another object: its own key.
        assert_eq!(push(&inbox, &moved(4, "0", 0.4), &tx), None);
        assert_eq!(taken_ids(&inbox), [Some(2), Some(6), Some(4)]);
        let c = inbox.counts();
        assert_eq!(
            (c.received, c.superseded, c.most_pending_per_key),
            (6, 3, 1)
        );
        assert!(inbox.is_empty());
    }

    #[test]
    fn keyless_requests_wait_in_order_up_to_the_capacity() {
        let (tx, _rx) = mpsc::channel(2 * CAPACITY);
        let inbox = Inbox::default();
        assert!(inbox.push(pending(&moved(0, "1", 0.1), &tx)).is_ok());
        for id in 1..CAPACITY {
            let ping = format!(r#"{{"v":1,"id":{id},"type":"ping"}}"#);
            assert!(inbox.push(pending(&ping, &tx)).is_ok());
        }
        let one_more = pending(r#"{"v":1,"type":"ping"}"#, &tx);
        assert!(matches!(inbox.push(one_more), Err(Refusal::Full)));
        assert!(matches!(
            inbox.push(pending(&moved(999, "0", 0.1), &tx)),
            Err(Refusal::Full)
        ));
        // Full, a move still replaces the older one of its object (and goes last).
        let older = inbox.push(pending(&moved(CAPACITY as u64, "1", 0.2), &tx));
        assert_eq!(older.ok().flatten().map(|p| p.envelope.id), Some(Some(0)));
        let ids = taken_ids(&inbox);
        assert_eq!(ids, (1..=CAPACITY as u64).map(Some).collect::<Vec<_>>());
        inbox.close();
        assert!(matches!(
            inbox.push(pending(r#"{"v":1,"type":"ping"}"#, &tx)),
            Err(Refusal::Stopped)
        ));
    }

    #[test]
    fn moves_of_one_punctual_light_replace_each_other_and_its_colour_has_its_own_key() {
        let (tx, _rx) = mpsc::channel(2 * CAPACITY);
        let inbox = Inbox::default();
        let light =
            |id: u64, l: &str, x: f64| translation("set_light_transform", "light", id, l, x);
        assert_eq!(push(&inbox, &light(1, "0", 0.1), &tx), None);
        let colour = r#"{"v":1,"id":2,"type":"set_light_intensity","light":"bulb","color":[1,1,1],"intensity":3}"#;
        assert_eq!(push(&inbox, colour, &tx), None);
        // The same light by name; an object of the same index is another key.
        let older = push(&inbox, &light(3, "\"bulb\"", 0.2), &tx);
        assert_eq!(older, Some(Some(1)));
        assert_eq!(push(&inbox, &moved(4, "0", 0.4), &tx), None);
        assert_eq!(taken_ids(&inbox), [Some(2), Some(3), Some(4)]);
        // A light that does not exist has no key: the engine refuses it.
        let names = Names::default();
        let r = protocol::parse(&light(5, "0", 0.0)).unwrap().request;
        assert_eq!(Key::of(&r, &names), None);
    }

    #[test]
    fn an_unknown_object_has_no_key_and_is_left_to_the_engine_to_refuse() {
        let names = Names {
            objects: vec!["floor".to_string()],
            lights: Vec::new(),
        };
        let r = protocol::parse(&moved(1, "\"nowhere\"", 0.0))
            .unwrap()
            .request;
        assert_eq!(Key::of(&r, &names), None);
        let r = protocol::parse(&moved(1, "7", 0.0)).unwrap().request;
        assert_eq!(Key::of(&r, &names), None);
        let r = protocol::parse(&moved(1, "0", 0.0)).unwrap().request;
        assert_eq!(Key::of(&r, &names), Some(Key::Transform(0)));
    }
}
