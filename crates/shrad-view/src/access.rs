//! Who may use the server, how many at once, and who steers (issue 19, item 4: a viewer
//! safe to share).
//!
//! - **Token.** A server bound to anything but loopback needs a token, as Jupyter's does:
//!   generated from the OS's randomness (24 bytes, 48 hex digits) unless `--token` gives
//!   one, and printed in the URL as `?token=...`. Every request (page, asset, WebSocket)
//!   must carry it, in the query or in the cookie the server sets when the page is loaded
//!   with a good one; else 401. It is compared in constant time. On loopback the server
//!   stays open unless a token is given.
//! - **A cap on clients** ([`DEFAULT_MAX_CLIENTS`] unless `--max-clients`): a seat is taken
//!   before the WebSocket upgrade, so the count cannot race past the cap; the client over it
//!   is told why and closed (status 1013, "try again later").
//! - **One steerer, the others watch.** The first client steers; the others watch until it
//!   hands over (`release_steering`) or leaves, then any of them can `take_steering`.
//!   `--watch-only` makes everyone a watcher. Every change of who steers is sent to every
//!   client (`role`), so a page can offer "take steering" only when it is free.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use serde_json::json;

use crate::inbox::ReplyTo;
use crate::protocol;

/// Clients at once unless `--max-clients` says otherwise: a few people looking at one
/// scene. Each costs its share of the frames' bandwidth and of the I/O thread.
pub const DEFAULT_MAX_CLIENTS: usize = 8;

/// Bytes of randomness in a generated token (as Jupyter's: 48 hex digits).
const TOKEN_BYTES: usize = 24;

/// The shortest token `--token` accepts: a short one could be guessed.
pub const MIN_TOKEN_CHARS: usize = 16;

/// A new token: `TOKEN_BYTES` from the operating system's randomness, in hex.
pub fn generate_token() -> Result<String, String> {
    let mut bytes = [0u8; TOKEN_BYTES];
    getrandom::fill(&mut bytes)
        .map_err(|e| format!("cannot read the system's randomness for a token: {e}"))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Whether `token` can be used: long enough, and only characters a URL carries as they are.
pub fn check_token(token: &str) -> Result<(), String> {
    if token.chars().count() < MIN_TOKEN_CHARS {
        return Err(format!(
            "the token must have at least {MIN_TOKEN_CHARS} characters (a short one can be guessed)"
        ));
    }
    if let Some(c) = token
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || "-._~".contains(*c)))
    {
        return Err(format!(
            "the token may hold only letters, digits and - . _ ~ (it goes into a URL as it is), not {c:?}"
        ));
    }
    Ok(())
}

/// `a == b` in a time that depends only on their lengths, not on where they first differ
/// (the token's length is no secret).
pub fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let diff = a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y));
    std::hint::black_box(diff) == 0
}

/// The sharing rules a server runs with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AccessOptions {
    /// The token every request must carry; `None`: open (loopback only).
    pub token: Option<String>,
    /// Clients at once.
    pub max_clients: usize,
    /// Nobody steers: every client watches.
    pub watch_only: bool,
    /// How often a client is pinged; one that has sent nothing (not even the pong a
    /// browser sends by itself) for three of these is closed, and its seat freed.
    pub keepalive: std::time::Duration,
}

/// [`AccessOptions::keepalive`] unless set: a vanished peer (its machine asleep, its
/// network gone) held its seat until TCP noticed, which may be never.
pub const DEFAULT_KEEPALIVE: std::time::Duration = std::time::Duration::from_secs(20);

impl Default for AccessOptions {
    fn default() -> AccessOptions {
        AccessOptions {
            token: None,
            max_clients: DEFAULT_MAX_CLIENTS,
            watch_only: false,
            keepalive: DEFAULT_KEEPALIVE,
        }
    }
}

#[derive(Default)]
struct Seats {
    next_id: u64,
    /// Seats taken (connected or being upgraded).
    taken: usize,
    /// The clients that have joined, with where their messages go.
    joined: Vec<(u64, ReplyTo)>,
    /// The client that steers.
    steerer: Option<u64>,
}

/// The server's sharing rules and who holds which seat.
pub struct Access {
    options: AccessOptions,
    seats: Mutex<Seats>,
}

/// One client's place; given back when it is dropped, however the client leaves.
pub struct Seat {
    access: Arc<Access>,
    /// This client's number (also the key of its expensive jobs, `jobs.rs`).
    pub id: u64,
}

impl Access {
    /// The rules `options`.
    pub fn new(options: AccessOptions) -> Arc<Access> {
        Arc::new(Access {
            options,
            seats: Mutex::new(Seats::default()),
        })
    }

    fn lock(&self) -> MutexGuard<'_, Seats> {
        // Every change under the lock is a few assignments: a panic cannot leave it half done.
        self.seats.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The rules.
    pub fn options(&self) -> &AccessOptions {
        &self.options
    }

    /// Whether a request that carries `token` (from its query or cookie) may go on.
    pub fn allows(&self, token: Option<&str>) -> bool {
        match (&self.options.token, token) {
            (None, _) => true,
            (Some(want), Some(got)) => constant_time_eq(want.as_bytes(), got.as_bytes()),
            (Some(_), None) => false,
        }
    }

    /// A seat, or the message that says why there is none.
    pub fn admit(self: &Arc<Self>) -> Result<Seat, String> {
        let mut s = self.lock();
        if s.taken >= self.options.max_clients {
            return Err(format!(
                "the viewer is full: {} clients are connected, the most it takes (--max-clients {}); try again later",
                s.taken, self.options.max_clients
            ));
        }
        s.taken += 1;
        s.next_id += 1;
        Ok(Seat {
            access: self.clone(),
            id: s.next_id,
        })
    }

    /// The `role` message for client `id`.
    fn role_message(&self, s: &Seats, id: u64) -> String {
        let role = if s.steerer == Some(id) {
            "steer"
        } else {
            "watch"
        };
        protocol::message(
            "role",
            json!({
                "role": role,
                "steering_free": s.steerer.is_none() && !self.options.watch_only,
                "watch_only": self.options.watch_only,
                "clients": s.joined.len(),
                "max_clients": self.options.max_clients,
            }),
        )
    }

    /// Tell every client who steers now (a full queue misses it: the next change tells it).
    fn broadcast(&self, s: &Seats) {
        for (id, to) in &s.joined {
            let _ = to.try_send(self.role_message(s, *id));
        }
    }
}

impl Seat {
    /// The client is connected and its messages go to `to`: it steers if nobody does (and
    /// the server is not watch-only); everyone is told.
    pub fn join(&self, to: ReplyTo) {
        let mut s = self.access.lock();
        s.joined.push((self.id, to));
        if s.steerer.is_none() && !self.access.options.watch_only {
            s.steerer = Some(self.id);
        }
        self.access.broadcast(&s);
    }

    /// Whether this client steers.
    pub fn steers(&self) -> bool {
        self.access.lock().steerer == Some(self.id)
    }

    /// Why this client watches, for a refusal.
    pub fn why_watching(&self) -> &'static str {
        let s = self.access.lock();
        if self.access.options.watch_only {
            "the server is watch-only"
        } else if s.steerer.is_some() {
            "another client steers until it hands over with release_steering or leaves"
        } else {
            "steering is free: send take_steering first"
        }
    }

    /// Take steering if it is free; else why not.
    pub fn take_steering(&self) -> Result<(), String> {
        let mut s = self.access.lock();
        if self.access.options.watch_only {
            return Err("this server is watch-only (--watch-only): nobody steers".to_string());
        }
        match s.steerer {
            Some(id) if id == self.id => Ok(()),
            Some(_) => Err(
                "another client steers: it must hand over (release_steering) or leave first"
                    .to_string(),
            ),
            None => {
                s.steerer = Some(self.id);
                self.access.broadcast(&s);
                Ok(())
            }
        }
    }

    /// Hand steering over (it becomes free); an error if this client does not steer.
    pub fn release_steering(&self) -> Result<(), String> {
        let mut s = self.access.lock();
        if s.steerer != Some(self.id) {
            return Err("this client does not steer: there is nothing to hand over".to_string());
        }
        s.steerer = None;
        self.access.broadcast(&s);
        Ok(())
    }
}

impl Drop for Seat {
    fn drop(&mut self) {
        let mut s = self.access.lock();
        s.taken -= 1;
        s.joined.retain(|(id, _)| *id != self.id);
        if s.steerer == Some(self.id) {
            s.steerer = None;
        }
        self.access.broadcast(&s);
    }
}

/// Expensive requests (the error against the reference, a solver switch) one client may
/// send in a burst; then one per [`EXPENSIVE_EVERY_S`].
pub const EXPENSIVE_BURST: f64 = 3.0;
/// Seconds between a client's expensive requests once its burst is spent.
pub const EXPENSIVE_EVERY_S: f64 = 2.0;

/// A client's allowance of expensive requests (a token bucket: [`EXPENSIVE_BURST`] at
/// most, refilled by one every [`EXPENSIVE_EVERY_S`]).
pub struct RateLimit {
    allowance: f64,
    at: Instant,
}

impl Default for RateLimit {
    fn default() -> RateLimit {
        RateLimit {
            allowance: EXPENSIVE_BURST,
            at: Instant::now(),
        }
    }
}

impl RateLimit {
    /// Spend one at `now`; else the seconds until one is there.
    pub fn spend(&mut self, now: Instant) -> Result<(), f64> {
        let refill = now.saturating_duration_since(self.at).as_secs_f64() / EXPENSIVE_EVERY_S;
        self.allowance = (self.allowance + refill).min(EXPENSIVE_BURST);
        self.at = now;
        if self.allowance >= 1.0 {
            self.allowance -= 1.0;
            Ok(())
        } else {
            Err((1.0 - self.allowance) * EXPENSIVE_EVERY_S)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;
    use tokio::sync::mpsc;

    #[test]
    fn tokens_are_random_long_and_compared_whole() {
        let a = generate_token().unwrap();
        let b = generate_token().unwrap();
        assert_eq!(a.len(), 2 * TOKEN_BYTES);
        assert_ne!(a, b);
        assert!(check_token(&a).is_ok());
        assert!(check_token("short").is_err());
        assert!(check_token("0123456789abcdef&x=1").is_err());
        assert!(constant_time_eq(b"abc", b"abc"));
        assert!(!constant_time_eq(b"abc", b"abd"));
        assert!(!constant_time_eq(b"abc", b"abcd"));
        let access = Access::new(AccessOptions {
            token: Some(a.clone()),
            ..AccessOptions::default()
        });
        assert!(access.allows(Some(&a)));
        assert!(!access.allows(Some(&b)));
        assert!(!access.allows(Some("")));
        assert!(!access.allows(None));
        assert!(Access::new(AccessOptions::default()).allows(None));
    }

    #[test]
    fn the_first_steers_until_it_hands_over_or_leaves_and_the_cap_holds() {
        let access = Access::new(AccessOptions {
            max_clients: 2,
            ..AccessOptions::default()
        });
        let (tx, mut rx) = mpsc::channel(16);
        let a = access.admit().unwrap();
        let b = access.admit().unwrap();
        assert!(access.admit().err().unwrap().contains("--max-clients 2"));
        a.join(tx.clone());
        b.join(tx.clone());
        assert!(a.steers() && !b.steers());
        assert!(b.take_steering().unwrap_err().contains("another client"));
        assert!(b.release_steering().is_err());
        a.release_steering().unwrap();
        b.take_steering().unwrap();
        assert!(b.steers() && !a.steers());
        drop(b);
        // The seat is free again, and so is steering.
        let c = access.admit().unwrap();
        assert!(!a.steers());
        a.take_steering().unwrap();
        drop(c);
        let mut last = String::new();
        while let Ok(m) = rx.try_recv() {
            last = m;
        }
        assert!(last.contains("\"role\":\"steer\""), "{last}");
    }

    #[test]
    fn expensive_requests_come_in_a_burst_then_one_every_few_seconds() {
        let t0 = Instant::now();
        let mut limit = RateLimit::default();
        for _ in 0..EXPENSIVE_BURST as usize {
            assert!(limit.spend(t0).is_ok());
        }
        let wait = limit.spend(t0).unwrap_err();
        assert!((wait - EXPENSIVE_EVERY_S).abs() < 1e-9, "{wait}");
        let later = t0 + Duration::from_secs_f64(EXPENSIVE_EVERY_S);
        assert!(limit.spend(later).is_ok());
        assert!(limit.spend(later).is_err());
    }

    #[test]
    fn watch_only_means_nobody_steers() {
        let access = Access::new(AccessOptions {
            watch_only: true,
            ..AccessOptions::default()
        });
        let (tx, _rx) = mpsc::channel(16);
        let a = access.admit().unwrap();
        a.join(tx);
        assert!(!a.steers());
        assert!(a.take_steering().unwrap_err().contains("watch-only"));
    }
}
