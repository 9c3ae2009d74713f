//! The engine's own thread: at the start of each frame it takes what the clients asked
//! (the [`Inbox`]: the newest state of each object, light and setting, never a queue of
//! older ones), applies it, steps, and publishes the frame into a latest-value slot
//! (`tokio::sync::watch`). A client that reads slowly only ever sees the newest frame;
//! nothing it does can make this thread wait.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use glam::Vec3;
use serde_json::{json, Value};
use shrad::engine::Engine;
use shrad::scene::Role;
use shrad::view_data::{self, Channel, DisplayMesh};
use tokio::sync::watch;

use crate::inbox::{Batch, Inbox, Pending};
use crate::protocol::{self, Request};
use crate::{probe_sphere, solvers};

mod jobs;
use jobs::option_text;

/// Shadow rays per (patch, light) when the viewer computes the direct channel itself.
const DIRECT_SAMPLES: u32 = 16;
/// Probes are captured again at most this often while a client shows them.
const PROBE_PERIOD: Duration = Duration::from_millis(400);
/// A frame is calm when the radiosity changed by less than this fraction (sum over patches
/// and channels of the absolute change over the sum of the values).
const CALM: f64 = 2e-4;

/// State shared between the engine thread and the clients.
pub struct Shared {
    /// Clients that want each channel (total, direct, indirect).
    pub channel_clients: [AtomicUsize; 3],
    /// Clients that show the probes.
    pub probe_clients: AtomicUsize,
    /// Clients connected.
    pub clients: AtomicUsize,
    /// Set when the server stops.
    pub stop: AtomicBool,
    /// What the clients asked of the engine, waiting for the next frame.
    pub inbox: Inbox,
    /// The newest frame published (what a job's reply counts frames with).
    pub published: std::sync::atomic::AtomicU64,
}

impl Shared {
    pub(crate) fn new() -> Shared {
        Shared {
            channel_clients: Default::default(),
            probe_clients: AtomicUsize::new(0),
            clients: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            inbox: Inbox::default(),
            published: Default::default(),
        }
    }
}

/// One published frame: its statistics message and, per channel, its colour frame (only the
/// channels some client wants); the latest probes.
#[derive(Default)]
pub struct Frame {
    /// Frame number (since the server started).
    pub seq: u64,
    /// The `frame` JSON message.
    pub stats: String,
    /// Binary colour frames by channel index.
    pub colours: [Option<Bytes>; 3],
    /// The latest `probes` message and its number (changes when they are captured again).
    pub probes: Option<(u64, Arc<String>)>,
}

/// What the clients are told at connect (the `scene` message and the geometry).
pub struct Intro {
    /// The `scene` JSON message.
    pub scene: String,
    /// The binary geometry message.
    pub geometry: Bytes,
    /// The objects' names, by scene index (requests name objects either way).
    pub objects: Vec<String>,
}

/// What the engine took from the inbox at the start of the frame being computed (the
/// `steering` part of the `frame` message).
#[derive(Clone, Copy, Default)]
struct Steering {
    /// Requests applied at the start of this frame.
    applied: usize,
    /// The most frames any of them waited: frames published between the server reading it
    /// and the engine stepping the frame that has it (1 or 2 when all is well: the frame
    /// being computed when it arrived, then the next one).
    waited_frames: u64,
    /// Requests that waited longer than that (0 when all is well).
    backlog: usize,
    /// The longest any of them waited (ms).
    queued_ms: f64,
}

/// The engine loop's state.
pub struct EngineLoop {
    engine: Engine,
    mesh: DisplayMesh,
    frames: watch::Sender<Arc<Frame>>,
    shared: Arc<Shared>,
    seq: u64,
    solver_name: String,
    preset: String,
    playing: bool,
    speed: f64,
    time: f64,
    duration: f64,
    continuous: bool,
    /// Frames since anything changed (the engine idles once the scene has converged).
    quiet_frames: usize,
    /// Consecutive frames whose radiosity changed by less than [`CALM`].
    calm_frames: usize,
    /// The radiosity of the previous frame.
    previous: Vec<Vec3>,
    /// Frame start instants of the last second (GI updates per second).
    recent: VecDeque<Instant>,
    direct: Option<Vec<Vec3>>,
    probes: Option<(u64, Arc<String>)>,
    probes_at: Option<Instant>,
    probe_dirs: Vec<Vec3>,
    last_error: Option<Value>,
    last_tick: Instant,
    publish_ms: f64,
    loop_ms: f64,
    last_step: Option<Instant>,
    steering: Steering,
    /// The worker that runs expensive requests beside the frames (`jobs.rs`).
    jobs: jobs::Jobs,
    /// Counts solver switches: an error measured before the last one is not shown.
    solver_epoch: u64,
}

impl EngineLoop {
    /// Wrap `engine`; `solver_name` / `preset` say how its solver was chosen; `patching`:
    /// how its world was patched, on which backend (the job worker's copy is made alike).
    pub fn new(
        engine: Engine,
        solver_name: String,
        preset: String,
        shared: Arc<Shared>,
        patching: (shrad::PatchSizing, shrad::vis::Backend),
    ) -> (EngineLoop, Intro, watch::Receiver<Arc<Frame>>) {
        let mesh = DisplayMesh::new(engine.world());
        let (frames, rx) = watch::channel(Arc::new(Frame::default()));
        let duration = engine.world().scene.duration() as f64;
        let (probe_dirs, probe_triangles) = probe_sphere::probe_sphere(probe_sphere::SPLITS);
        let me = EngineLoop {
            jobs: jobs::Jobs::start(patching.0, patching.1, shared.clone()),
            solver_epoch: 0,
            engine,
            mesh,
            frames,
            shared,
            seq: 0,
            solver_name,
            preset,
            playing: false,
            speed: 1.0,
            time: 0.0,
            duration,
            continuous: false,
            quiet_frames: 0,
            calm_frames: 0,
            previous: Vec::new(),
            recent: VecDeque::new(),
            direct: None,
            probes: None,
            probes_at: None,
            probe_dirs,
            last_error: None,
            last_tick: Instant::now(),
            publish_ms: 0.0,
            loop_ms: 0.0,
            last_step: None,
            steering: Steering::default(),
        };
        let intro = Intro {
            scene: me.scene_message(&probe_triangles),
            geometry: Bytes::from(protocol::geometry(&me.mesh)),
            objects: me
                .engine
                .world()
                .scene
                .objects
                .iter()
                .map(|o| o.name.clone())
                .collect(),
        };
        (me, intro, rx)
    }

    fn scene_message(&self, probe_triangles: &[[u32; 3]]) -> String {
        let world = self.engine.world();
        let p = &world.patches;
        let objects: Vec<Value> = world
            .scene
            .objects
            .iter()
            .enumerate()
            .map(|(o, object)| {
                let lfo = glam::Affine3A::from_mat3(p.local_from_object[o]);
                json!({
                    "name": object.name,
                    "role": p.object_role[o].name(),
                    "local_from_object": protocol::columns(lfo),
                    "emission": object.material.emitted_radiance.to_array(),
                    "patches": p.range(o).len(),
                    "first_vertex": self.mesh.objects[o].first_vertex,
                })
            })
            .collect();
        let camera = world.scene.camera_or_default();
        let shrad::scene::Aabb { min: lo, max: hi } = world
            .scene
            .bounds()
            .unwrap_or(shrad::scene::Aabb::new(Vec3::ZERO, Vec3::ONE));
        protocol::message(
            "scene",
            json!({
                "source": world.scene.source,
                "patches": p.len(),
                "vertices": self.mesh.vertex_count(),
                "objects": objects,
                "camera": {
                    "world_from_camera": protocol::columns(camera.world_from_camera),
                    "yfov": camera.yfov,
                },
                "bounds": [lo.to_array(), hi.to_array()],
                "duration": self.duration,
                "solvers": shrad::settings::SOLVERS,
                "presets": solvers::presets_json(),
                "probe_sphere": {
                    "directions": self.probe_dirs.iter().map(|d| d.to_array()).collect::<Vec<_>>(),
                    "triangles": probe_triangles,
                },
                "limits": {
                    "max_message_bytes": protocol::MAX_MESSAGE_BYTES,
                    "max_wire_bytes": protocol::MAX_WIRE_BYTES,
                    "max_in_flight_bytes": protocol::MAX_IN_FLIGHT_BYTES,
                },
            }),
        )
    }

    /// Run until the server stops.
    pub fn run(mut self) {
        while !self.shared.stop.load(Ordering::Relaxed) {
            let idle = self.shared.clients.load(Ordering::Relaxed) == 0
                || (!self.playing && !self.continuous && self.converged());
            // The newest state the clients asked for, all of it, at the start of the frame.
            let batch = if idle {
                // Nothing to compute: wait for a request (or look at the stop flag again).
                let batch = self.shared.inbox.wait(Duration::from_millis(100));
                if batch.requests.is_empty() && !batch.refresh {
                    // Probes asked for after the scene settled still get captured.
                    if self.shared.probe_clients.load(Ordering::Relaxed) > 0 && self.probes_due() {
                        self.publish(None);
                    }
                    continue;
                }
                batch
            } else {
                self.shared.inbox.take()
            };
            self.finish_jobs();
            self.apply(batch);
            if self.playing {
                let now = Instant::now();
                let dt = now.duration_since(self.last_tick).as_secs_f64() * self.speed;
                self.last_tick = now;
                self.time += dt;
                if self.duration > 0.0 {
                    self.time = self.time.rem_euclid(self.duration);
                }
                if self.engine.set_time(self.time as f32).is_ok() {
                    self.changed();
                }
            }
            let start = Instant::now();
            if let Some(t) = self.last_step.replace(start) {
                self.loop_ms = start.duration_since(t).as_secs_f64() * 1e3;
            }
            let stats = self.engine.step();
            self.quiet_frames += 1;
            self.note_change_of_radiosity();
            self.publish(Some(&stats));
        }
        self.shared.inbox.close();
    }

    /// Every object updated twice since the last change, and a whole pass of frames in which
    /// the radiosity changed by less than [`CALM`] (relative, L1); or a long time without
    /// change.
    fn converged(&self) -> bool {
        let pass = self.engine.frames_to_converge(1).max(1);
        (self.quiet_frames >= 2 * pass && self.calm_frames >= pass) || self.quiet_frames >= 5000
    }

    fn note_change_of_radiosity(&mut self) {
        let b = self.engine.radiosity();
        let calm = if self.previous.len() == b.len() {
            let (mut diff, mut total) = (0.0f64, 0.0f64);
            for (x, y) in b.iter().zip(&self.previous) {
                diff += (*x - *y).abs().element_sum() as f64;
                total += x.abs().element_sum() as f64;
            }
            diff <= CALM * total
        } else {
            false
        };
        self.calm_frames = if calm { self.calm_frames + 1 } else { 0 };
        self.previous.clear();
        self.previous.extend_from_slice(b);
    }

    fn changed(&mut self) {
        self.quiet_frames = 0;
        self.calm_frames = 0;
        self.direct = None;
    }

    fn probes_due(&self) -> bool {
        self.probes_at.is_none_or(|t| t.elapsed() >= PROBE_PERIOD)
    }

    /// Publish the state after a frame (`stats`), or again without one.
    fn publish(&mut self, stats: Option<&shrad::dispersive::FrameStats>) {
        let now = Instant::now();
        if stats.is_some() {
            self.seq += 1;
            self.recent.push_back(now);
        }
        while self
            .recent
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.recent.pop_front();
        }
        let wanted: [bool; 3] =
            std::array::from_fn(|c| self.shared.channel_clients[c].load(Ordering::Relaxed) > 0);
        let channels = [Channel::Total, Channel::Direct, Channel::Indirect];
        if (wanted[1] || wanted[2]) && self.direct.is_none() {
            self.direct =
                Some(view_data::direct_irradiance(&self.engine, DIRECT_SAMPLES).into_owned());
        }
        let world_from_local = &self.engine.world().patches.world_from_local;
        let frame32 = self.seq as u32;
        let colours = std::array::from_fn(|c| {
            wanted[c].then(|| {
                let per_patch = view_data::channel_radiosity(
                    &self.engine,
                    channels[c],
                    self.direct.as_deref().unwrap_or(&[]),
                );
                let per_vertex = shrad::render::vertex_radiosity(self.engine.world(), &per_patch);
                let radiance: Vec<Vec3> = self
                    .mesh
                    .gather(&per_vertex)
                    .into_iter()
                    .map(|b| b * std::f32::consts::FRAC_1_PI)
                    .collect();
                Bytes::from(protocol::colour_frame(
                    frame32,
                    channels[c],
                    world_from_local,
                    &radiance,
                ))
            })
        });
        if self.shared.probe_clients.load(Ordering::Relaxed) > 0 && self.probes_due() {
            self.probes_at = Some(now);
            let message =
                probe_sphere::message(&self.engine, &self.probe_dirs, self.seq, &self.solver_name);
            self.probes = Some((self.seq, Arc::new(message)));
        }
        let stats_json = stats.map_or(Value::Null, |s| {
            serde_json::to_value(s).unwrap_or(Value::Null)
        });
        let message = protocol::message(
            "frame",
            json!({
                "frame": self.seq,
                "solver": self.solver_name,
                "preset": self.preset,
                "settings": solvers::settings(&self.engine),
                "time": self.time,
                "playing": self.playing,
                "continuous": self.continuous,
                "converged": self.converged(),
                "gi_updates_per_s": self.recent.len(),
                // Wall time of the previous publication (colours, probes, messages).
                "publish_ms": self.publish_ms,
                // Wall time between the starts of the last two frames.
                "loop_ms": self.loop_ms,
                // What the engine applied at the start of this frame, and what waits now.
                "steering": {
                    "applied": self.steering.applied,
                    "waited_frames": self.steering.waited_frames,
                    "queued_ms": self.steering.queued_ms,
                    "backlog": self.steering.backlog,
                    "pending": self.shared.inbox.len(),
                    "superseded": self.shared.inbox.counts().superseded,
                },
                "stats": stats_json,
                "error": self.last_error,
            }),
        );
        self.publish_ms = now.elapsed().as_secs_f64() * 1e3;
        let frame = Frame {
            seq: self.seq,
            stats: message,
            colours,
            probes: self.probes.clone(),
        };
        self.frames.send_replace(Arc::new(frame));
        self.shared.published.store(self.seq, Ordering::Relaxed);
    }

    /// Apply what the clients asked since the last frame (in order: each key's newest).
    fn apply(&mut self, batch: Batch) {
        if batch.refresh && self.seq > 0 {
            self.publish(None);
        }
        let frame = self.seq + 1;
        let mut steering = Steering::default();
        for p in batch.requests {
            let waited = frame.saturating_sub(p.received_at_frame);
            steering.applied += 1;
            steering.waited_frames = steering.waited_frames.max(waited);
            steering.backlog += usize::from(waited > 2);
            let queued_ms = p.received.elapsed().as_secs_f64() * 1e3;
            steering.queued_ms = steering.queued_ms.max(queued_ms);
            self.apply_one(p, queued_ms);
        }
        self.steering = steering;
    }

    fn apply_one(&mut self, p: Pending, queued_ms: f64) {
        // Expensive requests run beside the frames (`jobs.rs`).
        let Some(p) = self.defer(p) else {
            return;
        };
        let Pending {
            envelope,
            reply,
            received_at_frame,
            ..
        } = p;
        if matches!(envelope.request, Request::SetTransform { .. }) {
            self.shared
                .inbox
                .counters
                .transforms_applied
                .fetch_add(1, Ordering::Relaxed);
        }
        let id = envelope.id;
        let kind = envelope.request.kind();
        let answer = match self.handle(envelope.request) {
            Ok(body) => {
                let mut body = body;
                if let Value::Object(m) = &mut body {
                    m.insert("id".into(), json!(id));
                    m.insert("request".into(), json!(kind));
                    // The first frame that shows the change.
                    m.insert("frame".into(), json!(self.seq + 1));
                    // The newest frame when the server read the request, and how long it
                    // waited for this frame to start.
                    m.insert("received_at_frame".into(), json!(received_at_frame));
                    m.insert("queued_ms".into(), json!(queued_ms));
                }
                protocol::message(if kind == "ping" { "pong" } else { "ok" }, body)
            }
            Err(message) => protocol::error(id, &format!("{kind}: {message}")),
        };
        // A client whose queue is full loses the reply; the engine never waits for one.
        let _ = reply.try_send(answer);
    }

    fn object(&self, r: &protocol::ObjectRef) -> Result<usize, String> {
        match r {
            protocol::ObjectRef::Index(o) => self
                .engine
                .object(&o.to_string())
                .map_err(|e| e.to_string()),
            protocol::ObjectRef::Name(n) => self.engine.object(n).map_err(|e| e.to_string()),
        }
    }

    fn handle(&mut self, request: Request) -> Result<Value, String> {
        match request {
            Request::SetTransform { object, matrix } => {
                let o = self.object(&object)?;
                let role = self.engine.roles()[o];
                if role != Role::Interior {
                    return Err(format!(
                        "object '{}' is {}: only interior objects can be moved",
                        self.engine.world().scene.objects[o].name,
                        role.name()
                    ));
                }
                let m = protocol::affine_from_columns(&matrix)?;
                self.engine.set_transform(o, m).map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({}))
            }
            Request::SetEmission { object, radiance } => {
                let o = self.object(&object)?;
                let l = Vec3::new(radiance[0] as f32, radiance[1] as f32, radiance[2] as f32);
                if !l.is_finite() {
                    return Err(format!("radiance {radiance:?} is not finite"));
                }
                self.engine.set_emission(o, l).map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({}))
            }
            Request::SetTime { t } => {
                if !t.is_finite() {
                    return Err(format!("time {t} is not a finite number"));
                }
                self.playing = false;
                self.time = if self.duration > 0.0 {
                    t.clamp(0.0, self.duration)
                } else {
                    t.max(0.0)
                };
                self.engine
                    .set_time(self.time as f32)
                    .map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({ "time": self.time }))
            }
            Request::Play { playing, speed } => {
                if let Some(s) = speed {
                    if !(s.is_finite() && s > 0.0 && s <= 100.0) {
                        return Err(format!("speed {s} must be in (0, 100]"));
                    }
                    self.speed = s;
                }
                if playing && self.duration <= 0.0 {
                    return Err("the scene has no animation to play".to_string());
                }
                self.playing = playing;
                self.last_tick = Instant::now();
                self.changed();
                Ok(json!({ "playing": playing }))
            }
            Request::SetSolver { solver, preset } => {
                let preset = preset.unwrap_or_else(|| "default".to_string());
                let choice = solvers::choice(&solver, &preset)?;
                let rebuilt = self.engine.set_solver(choice).map_err(|e| e.to_string())?;
                self.solver_name = solver;
                self.preset = preset;
                self.solver_epoch += 1;
                self.last_error = None;
                self.changed();
                Ok(json!({ "precompute_ms": rebuilt.precompute_ms }))
            }
            Request::SetOption { key, value } => {
                let value = option_text(&key, &value)?;
                let detail = solvers::set_option(&mut self.engine, &key, &value)?;
                self.changed();
                Ok(detail)
            }
            // Run by the job worker (`defer`); never applied here.
            Request::ComputeError {} => Err("the error is computed beside the frames".into()),
            Request::Run { continuous } => {
                self.continuous = continuous;
                Ok(json!({ "continuous": continuous }))
            }
            Request::Ping {} => Ok(json!({})),
            // Handled by the client's own task; never sent here.
            Request::SetChannel { .. }
            | Request::Probes { .. }
            | Request::Ack { .. }
            | Request::TakeSteering {}
            | Request::ReleaseSteering {} => Ok(json!({})),
        }
    }
}
