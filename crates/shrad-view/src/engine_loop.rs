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
use serde_json::Value;
use shrad::engine::Engine;
use shrad::view_data::DisplayMesh;
use tokio::sync::watch;

use crate::inbox::{Inbox, Names};
use crate::probe_sphere;

mod handle;
mod intro;
mod jobs;
mod publish;

/// Shadow rays per (patch, light) when the viewer computes the direct channel itself.
const DIRECT_SAMPLES: u32 = 16;
/// Probes are captured again at most this often while a client shows them.
const PROBE_PERIOD: Duration = Duration::from_millis(400);
/// A frame is calm when the radiosity changed by less than this fraction (sum over patches
/// and channels of the absolute change over the sum of the values).
const CALM: f64 = 2e-4;
/// The frames after a drag (or any change) stops that run under a budget
/// (`EngineLoop::step_engine`): enough for a mover's full update at rest to be prepared.
const SETTLE_FRAMES: usize = 60;
/// Stepped continuously (`run`), a frame in which everything slept is followed by the next
/// no sooner than this, unless a request comes: a settled scene's empty frames at a
/// display's rate, not as fast as a core allows (80k a second were seen, a core spent on
/// nothing, and the binary header's u32 frame number would have wrapped within a day).
const ASLEEP_FRAME_PERIOD: Duration = Duration::from_millis(16);

/// The budget of the frames after a change stops (`EngineLoop::step_engine`): twice what a
/// frame cost while it went on (`drag_ms`), within 8-50 ms.
pub fn settle_budget_ms(drag_ms: f64) -> f32 {
    (2.0 * drag_ms).clamp(8.0, 50.0) as f32
}

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

/// What the clients are told at connect (the `scene` message, the geometry, the sky's map).
pub struct Intro {
    /// The `scene` JSON message.
    pub scene: String,
    /// The binary geometry message.
    pub geometry: Bytes,
    /// The binary sky message, when the sky is a map.
    pub sky: Option<Bytes>,
    /// The objects' and punctual lights' names, by index (requests name them either way).
    pub names: Names,
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

/// The engine loop's state. What the engine knows (the time, the solver and its preset,
/// the lights) is read from it, never kept beside it.
pub struct EngineLoop {
    engine: Engine,
    mesh: DisplayMesh,
    frames: watch::Sender<Arc<Frame>>,
    shared: Arc<Shared>,
    seq: u64,
    playing: bool,
    speed: f64,
    continuous: bool,
    /// The last frame did nothing: everything slept (`DispersiveStats::asleep`).
    asleep: bool,
    /// Frames since anything changed (the engine idles once the scene has converged).
    quiet_frames: usize,
    /// Consecutive frames whose radiosity changed by less than [`CALM`].
    calm_frames: usize,
    /// What a frame cost while something changed (ms, a running mean; 0: none yet).
    drag_ms: f64,
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
    /// Wrap `engine`; `patching`: how its world was patched, on which backend (the job
    /// worker's copy is made alike).
    pub fn new(
        engine: Engine,
        shared: Arc<Shared>,
        patching: (shrad::PatchSizing, shrad::vis::Backend),
    ) -> (EngineLoop, Intro, watch::Receiver<Arc<Frame>>) {
        let mesh = DisplayMesh::new(engine.world());
        let (frames, rx) = watch::channel(Arc::new(Frame::default()));
        let (probe_dirs, probe_triangles) = probe_sphere::probe_sphere(probe_sphere::SPLITS);
        let me = EngineLoop {
            jobs: jobs::Jobs::start(patching.0, patching.1, shared.clone()),
            solver_epoch: 0,
            engine,
            mesh,
            frames,
            shared,
            seq: 0,
            playing: false,
            speed: 1.0,
            continuous: false,
            asleep: false,
            quiet_frames: 0,
            calm_frames: 0,
            drag_ms: 0.0,
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
        let intro = me.intro(&probe_triangles);
        (me, intro, rx)
    }

    /// The solver in use: `dispersive`, `grid` or `reference`.
    fn solver_name(&self) -> &'static str {
        self.engine.solver_choice().name()
    }

    /// The preset the solver's settings are, or `custom` once a setting differs from each.
    fn preset(&self) -> &'static str {
        self.engine
            .solver_choice()
            .preset_name()
            .unwrap_or("custom")
    }

    /// The length of the scene's animation (s; 0: none).
    fn duration(&self) -> f64 {
        self.engine.world().scene.duration() as f64
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
            } else if self.asleep && !self.playing {
                // Stepped continuously, but the last frame found nothing to do.
                self.shared.inbox.wait(ASLEEP_FRAME_PERIOD)
            } else {
                self.shared.inbox.take()
            };
            self.finish_jobs();
            self.apply(batch);
            if self.playing {
                self.advance_time();
            }
            let start = Instant::now();
            if let Some(t) = self.last_step.replace(start) {
                self.loop_ms = start.duration_since(t).as_secs_f64() * 1e3;
            }
            let stats = self.step_engine();
            self.asleep = stats.dispersive().is_some_and(|d| d.asleep);
            self.quiet_frames += 1;
            self.note_change_of_radiosity();
            self.publish(Some(&stats));
        }
        self.shared.inbox.close();
    }

    /// One frame of the engine. The [`SETTLE_FRAMES`] frames after a change stops run under a
    /// budget of twice what a frame cost while it went on ([`settle_budget_ms`]): a mover's first
    /// full update at rest (its near field, probes and emitters at full resolution) is then
    /// prepared a piece a frame (`shrad`'s `dispersive/prepare.rs`) instead of stalling the
    /// view for one frame (the Cornell box at 20k patches: 42 ms after frames of 8.8 ms,
    /// `examples/engine_rate.rs`). While something changes, and after, a frame is the
    /// engine's own.
    fn step_engine(&mut self) -> shrad::frame::FrameStats {
        let changing = self.quiet_frames == 0;
        let settling = !changing && self.quiet_frames <= SETTLE_FRAMES && self.drag_ms > 0.0;
        let stats = match settling {
            true => self.engine.step_within(settle_budget_ms(self.drag_ms)).ok(),
            false => None,
        }
        .unwrap_or_else(|| self.engine.step());
        if changing {
            self.drag_ms = match self.drag_ms > 0.0 {
                true => 0.8 * self.drag_ms + 0.2 * stats.frame_ms,
                false => stats.frame_ms,
            };
        }
        stats
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

    /// Move the animation on by the wall time since the last frame (times the speed),
    /// wrapping at its end.
    fn advance_time(&mut self) {
        let now = Instant::now();
        let dt = now.duration_since(self.last_tick).as_secs_f64() * self.speed;
        self.last_tick = now;
        let mut t = self.engine.time() as f64 + dt;
        if self.duration() > 0.0 {
            t = t.rem_euclid(self.duration());
        }
        if self.engine.set_time(t as f32).is_ok() {
            self.changed();
        }
    }

    fn changed(&mut self) {
        self.quiet_frames = 0;
        self.calm_frames = 0;
        self.direct = None;
    }

    fn probes_due(&self) -> bool {
        self.probes_at.is_none_or(|t| t.elapsed() >= PROBE_PERIOD)
    }
}
