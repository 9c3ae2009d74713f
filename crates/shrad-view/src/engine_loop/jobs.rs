//! Expensive requests off the frame loop: the error against the reference (a converged
//! solve: seconds), a solver switch, a preset change and a setting that needs
//! precomputation run on a worker thread of their own, so the engine goes on stepping and
//! publishing frames (and applying moves) while they run.
//!
//! **Why a second world, and what it costs.** Both jobs read a [`World`] (patches and
//! visibility) in the state the request saw, while the engine keeps changing its own:
//! a drag moves objects every frame. The worker therefore keeps one copy of the world,
//! built once from the scene on the first expensive request (not before: a server nobody
//! asks for an error pays nothing) and brought to each job's state by setting the objects'
//! transforms and the lights' exitance: a refit of the visibility's top level, no rebuild.
//! That copy holds patches and visibility only, no solver, no caches, no form factors
//! beyond those the job itself needs (the reference's, freed when it ends, which the engine
//! thread used to allocate just as well). Cloning the engine instead would double the
//! solver's caches too, its largest part; pausing the moves while a job reads the one
//! world would stop the scene, which is what this is for.
//!
//! A finished solver comes back to the engine thread, which installs it
//! ([`Engine::install_solver`]) with what moved and changed since its state as the first
//! frame's changes. Per client at most one job waits or runs (`Busy`), and at most
//! [`QUEUE`] wait in all; beyond, the request is refused with a message saying so.

use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use glam::{Affine3A, Vec3};
use serde_json::{json, Value};
use shrad::engine::Engine;
use shrad::frame::Changes;
use shrad::lights::LightState;
use shrad::reference::ReferenceOptions;
use shrad::scene::Scene;
use shrad::solver::{Solver, SolverChoice};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

use super::{EngineLoop, Shared};
use crate::inbox::Pending;
use crate::protocol::{self, Request};
use crate::solvers;

/// Jobs waiting for the worker at most (beside the one it runs).
pub const QUEUE: usize = 2;

/// The world's state a job works on: the one the request saw.
pub struct State {
    world_from_local: Vec<Affine3A>,
    exitance: Vec<Vec3>,
    /// The punctual lights' states.
    lights: Vec<Option<LightState>>,
    time: f32,
    frame: u64,
}

impl State {
    fn of(world: &World, frame: u64) -> State {
        State {
            world_from_local: world.patches.world_from_local.clone(),
            exitance: world.exitance.clone(),
            lights: world.lights.clone(),
            time: world.time,
            frame,
        }
    }

    /// What differs between this state and `world`'s: as a frame's changes.
    fn changes_to(&self, world: &World) -> Changes {
        let p = &world.patches;
        let moved = (0..p.world_from_local.len())
            .filter(|&o| self.world_from_local[o] != p.world_from_local[o])
            .collect();
        let relit = (0..p.world_from_local.len())
            .filter(|&o| {
                let r = p.range(o);
                self.exitance[r.clone()] != world.exitance[r]
            })
            .collect();
        let lights = (0..world.lights.len())
            .filter(|&l| self.lights.get(l) != world.lights.get(l))
            .collect();
        Changes {
            moved,
            relit,
            lights,
        }
    }

    /// Bring `world` (a copy with the same patches) to this state.
    fn apply_to(&self, world: &mut World) -> Result<(), String> {
        if world.exitance.len() != self.exitance.len() {
            return Err(format!(
                "the worker's world has {} patches, the engine's {}",
                world.exitance.len(),
                self.exitance.len()
            ));
        }
        let mut moved = false;
        for (o, xf) in self.world_from_local.iter().enumerate() {
            if world.patches.world_from_local[o] != *xf {
                world.patches.set_transform(o, *xf);
                world.vis.set_transform(o, *xf);
                moved = true;
            }
        }
        if moved {
            world.vis.commit();
        }
        world.exitance.clone_from(&self.exitance);
        world.lights.clone_from(&self.lights);
        world.time = self.time;
        Ok(())
    }
}

/// What a job does.
enum Work {
    /// The error of `radiosity` (the engine's at the state) against a reference solve.
    Error {
        radiosity: Vec<Vec3>,
        reference: ReferenceOptions,
        solver: String,
        preset: String,
        epoch: u64,
    },
    /// Precompute `choice`; `option`: the setting that asked.
    Solver {
        choice: SolverChoice,
        option: Option<String>,
    },
}

/// One expensive request.
pub struct Job {
    pending: Pending,
    state: State,
    work: Work,
    /// The scene, with the first job (the worker builds its world from it).
    scene: Option<Box<Scene>>,
}

/// What comes back to the engine thread.
enum Done {
    Error { value: Value, epoch: u64 },
    Solver(Box<SolverDone>),
}

struct SolverDone {
    solver: Solver,
    choice: SolverChoice,
    option: Option<String>,
    state: State,
    pending: Pending,
    precompute_ms: f64,
}

/// The clients with a job waiting or running.
type Busy = Arc<Mutex<HashSet<u64>>>;

fn lock(busy: &Busy) -> std::sync::MutexGuard<'_, HashSet<u64>> {
    busy.lock().unwrap_or_else(|e| e.into_inner())
}

/// The engine thread's end of the worker.
pub struct Jobs {
    queue: SyncSender<Job>,
    done: Receiver<Done>,
    busy: Busy,
    scene_sent: bool,
    /// The worker, joined when the server stops (a job left running inside Embree while
    /// the process exits aborts it in Embree's static destructors).
    worker: Option<std::thread::JoinHandle<()>>,
    /// Set when the server stops: the worker finishes the job it runs and skips the rest.
    stopping: Arc<AtomicBool>,
}

impl Drop for Jobs {
    fn drop(&mut self) {
        self.stopping.store(true, Ordering::Relaxed);
        // Hang up the queue (the worker's loop ends once it is drained), then wait.
        drop(std::mem::replace(&mut self.queue, mpsc::sync_channel(0).0));
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}

impl Jobs {
    /// Start the worker; its world is patched as `sizing` says on `backend` (as the
    /// engine's); `shared` is woken when a job is done.
    pub fn start(sizing: PatchSizing, backend: Backend, shared: Arc<Shared>) -> Jobs {
        let (queue, jobs) = mpsc::sync_channel(QUEUE);
        let (done_tx, done) = mpsc::channel();
        let busy = Busy::default();
        let b = busy.clone();
        let stopping = Arc::new(AtomicBool::new(false));
        let stop = stopping.clone();
        let spawned = std::thread::Builder::new()
            .name("shrad-jobs".to_string())
            .spawn(move || work(jobs, done_tx, b, (sizing, backend), shared, stop));
        let worker = spawned
            .map_err(|e| {
                // The queue's receiver is gone with the closure: every job is refused.
                eprintln!("warning: cannot start the viewer's job thread: {e}");
            })
            .ok();
        Jobs {
            queue,
            done,
            busy,
            scene_sent: false,
            worker,
            stopping,
        }
    }

    /// Queue `job` for `client`; else why not (the caller replies).
    /// Queue `job`, or answer it with why not.
    fn submit(&mut self, mut job: Job, engine: &Engine) {
        let client = job.pending.client;
        if !lock(&self.busy).insert(client) {
            return job.pending.refuse(
                "rate limited: this client's previous expensive request (error, solver or precomputed setting) is still running; send it again once its reply has come",
            );
        }
        if !self.scene_sent {
            job.scene = Some(Box::new(engine.world().scene.clone()));
        }
        let had_scene = job.scene.is_some();
        match self.queue.try_send(job) {
            Ok(()) => self.scene_sent |= had_scene,
            Err(e) => {
                lock(&self.busy).remove(&client);
                match e {
                    TrySendError::Full(job) => job.pending.refuse(&format!(
                        "the queue of expensive requests is full ({QUEUE} waiting beside the one running); send it again later"
                    )),
                    TrySendError::Disconnected(job) => {
                        job.pending.refuse("the job worker has stopped")
                    }
                }
            }
        }
    }
}

/// The worker: one job after the other on its own copy of the world.
fn work(
    jobs: Receiver<Job>,
    done: mpsc::Sender<Done>,
    busy: Busy,
    (sizing, backend): (PatchSizing, Backend),
    shared: Arc<Shared>,
    stopping: Arc<AtomicBool>,
) {
    let mut world: Option<World> = None;
    for job in jobs {
        if stopping.load(Ordering::Relaxed) {
            break;
        }
        let client = job.pending.client;
        if let Some(d) = run(&mut world, job, sizing, backend, &shared) {
            let _ = done.send(d);
        }
        lock(&busy).remove(&client);
        // The engine may be idle: have it take the result and publish.
        shared.inbox.refresh();
    }
}

/// Do `job` (its reply sent, or a failure answered); what the engine thread takes in.
fn run(
    world: &mut Option<World>,
    job: Job,
    sizing: PatchSizing,
    backend: Backend,
    shared: &Shared,
) -> Option<Done> {
    let Job {
        pending,
        state,
        work,
        scene,
    } = job;
    let w = match world_at(world, scene, &state, sizing, backend) {
        Ok(w) => w,
        Err(e) => {
            pending.refuse(&e);
            return None;
        }
    };
    let t = Instant::now();
    match work {
        Work::Error {
            radiosity,
            reference,
            solver,
            preset,
            epoch,
        } => {
            let (r, _) = shrad::reference::solve(w, &reference, &NoProgress);
            let e = shrad::metrics::relative_error(&w.patches, &radiosity, &r);
            let value = json!({
                "overall": e.overall,
                "boundary": e.boundary,
                "interior": e.interior,
                "ms": t.elapsed().as_secs_f64() * 1e3,
                "at_frame": state.frame,
                "solver": solver,
                "preset": preset,
            });
            let mut body = value.clone();
            body["id"] = json!(pending.envelope.id);
            body["request"] = json!("compute_error");
            body["frame"] = json!(state.frame);
            body["received_at_frame"] = json!(pending.received_at_frame);
            // The frames the engine published while this ran (none if it had waited).
            let now = shared.published.load(std::sync::atomic::Ordering::Relaxed);
            body["frames_meanwhile"] = json!(now.saturating_sub(state.frame));
            pending.answer(protocol::message("ok", body));
            Some(Done::Error { value, epoch })
        }
        Work::Solver { choice, option } => match Solver::new(w, choice) {
            Ok(solver) => Some(Done::Solver(Box::new(SolverDone {
                solver,
                choice,
                option,
                state,
                pending,
                precompute_ms: t.elapsed().as_secs_f64() * 1e3,
            }))),
            Err(e) => {
                pending.refuse(&e.to_string());
                None
            }
        },
    }
}

/// The worker's world, built from `scene` the first time, in `state`.
fn world_at<'w>(
    world: &'w mut Option<World>,
    scene: Option<Box<Scene>>,
    state: &State,
    sizing: PatchSizing,
    backend: Backend,
) -> Result<&'w mut World, String> {
    if world.is_none() {
        let scene = scene.ok_or("the worker has no scene")?;
        *world = Some(World::new(*scene, sizing, backend).map_err(|e| e.to_string())?);
    }
    let w = world.as_mut().ok_or("the worker has no world")?;
    state.apply_to(w)?;
    Ok(w)
}

/// A setting's value as the engine reads it (a string, a number or a boolean).
pub(super) fn option_text(key: &str, value: &Value) -> Result<String, String> {
    let text = match value {
        Value::String(s) => s.clone(),
        Value::Number(n) => n.to_string(),
        Value::Bool(b) => b.to_string(),
        other => {
            return Err(format!(
                "value of '{key}' must be a string or a number, got {other}"
            ))
        }
    };
    crate::solvers::interactive(key, &text)?;
    Ok(text)
}

impl EngineLoop {
    /// Send `p` to the worker if it is expensive (`None`: it is handled, its reply comes
    /// later or has gone); `Some(p)`: the engine applies it now.
    pub(super) fn defer(&mut self, p: Pending) -> Option<Pending> {
        let work = match &p.envelope.request {
            Request::ComputeError {} => Work::Error {
                radiosity: self.engine.radiosity().to_vec(),
                reference: *self.engine.reference_options(),
                solver: self.solver_name().to_string(),
                preset: self.preset().to_string(),
                epoch: self.solver_epoch,
            },
            Request::SetSolver { solver, preset } => {
                let preset = preset.clone().unwrap_or_else(|| "default".to_string());
                match solvers::choice(solver, &preset) {
                    Ok(choice) => Work::Solver {
                        choice,
                        option: None,
                    },
                    // Refused at once, by the engine's own path.
                    Err(_) => return Some(p),
                }
            }
            Request::SetOption { key, value } => {
                let mut next = self.engine.solver_choice();
                match option_text(key, value).map(|v| next.set(key, &v).map(|s| s.rebuilds)) {
                    Ok(Ok(true)) => Work::Solver {
                        choice: next,
                        option: Some(key.clone()),
                    },
                    _ => return Some(p),
                }
            }
            _ => return Some(p),
        };
        let job = Job {
            state: State::of(self.engine.world(), self.seq),
            pending: p,
            work,
            scene: None,
        };
        self.jobs.submit(job, &self.engine);
        None
    }

    /// Take in the jobs that have finished: the last error, a new solver.
    pub(super) fn finish_jobs(&mut self) {
        while let Ok(done) = self.jobs.done.try_recv() {
            match done {
                Done::Error { value, epoch } => {
                    if epoch == self.solver_epoch {
                        self.last_error = Some(value);
                    }
                }
                Done::Solver(d) => self.install(*d),
            }
        }
    }

    fn install(&mut self, d: SolverDone) {
        let changes = d.state.changes_to(self.engine.world());
        let (id, kind) = (d.pending.envelope.id, d.pending.envelope.request.kind());
        match self.engine.install_solver(d.solver, d.choice, changes) {
            Ok(()) => {
                self.solver_epoch += 1;
                self.last_error = None;
                self.changed();
                let mut body = json!({
                    "id": id,
                    "request": kind,
                    "precompute_ms": d.precompute_ms,
                    "frame": self.seq + 1,
                    "received_at_frame": d.pending.received_at_frame,
                    "queued_ms": d.pending.received.elapsed().as_secs_f64() * 1e3,
                });
                if let Some(key) = d.option {
                    body["value"] = json!(self.engine.option(&key).unwrap_or_default());
                    body["key"] = json!(key);
                }
                d.pending.answer(protocol::message("ok", body));
            }
            Err(e) => d.pending.refuse(&e.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inbox::Reply;
    use crate::protocol;

    fn world() -> World {
        World::new(
            shrad::scene::cornell_box(),
            PatchSizing::Count(300),
            Backend::Auto,
        )
        .unwrap()
    }

    #[test]
    fn a_copy_brought_to_a_state_has_its_transforms_and_exitance() {
        let mut live = world();
        let mut copy = world();
        let o = live
            .scene
            .objects
            .iter()
            .position(|o| o.name == "short_block")
            .unwrap();
        let at = Affine3A::from_translation(Vec3::new(0.1, 0.0, 0.0));
        live.move_object(o, at).unwrap();
        live.set_emission(0, Vec3::splat(2.0)).unwrap();
        let s = State::of(&live, 7);
        assert_eq!(s.changes_to(&copy).moved, [o]);
        assert!(s.changes_to(&copy).relit.contains(&0));
        s.apply_to(&mut copy).unwrap();
        assert_eq!(copy.patches.world_from_local, live.patches.world_from_local);
        assert_eq!(copy.patches.centre, live.patches.centre);
        assert_eq!(copy.exitance, live.exitance);
        let none = s.changes_to(&copy);
        assert!(none.moved.is_empty() && none.relit.is_empty());
    }

    #[test]
    fn one_job_per_client_and_a_bounded_queue() {
        // No worker: the queue fills and stays full.
        let (queue, _jobs) = mpsc::sync_channel(QUEUE);
        let (_done_tx, done) = mpsc::channel();
        let mut jobs = Jobs {
            queue,
            done,
            busy: Busy::default(),
            scene_sent: false,
            worker: None,
            stopping: Arc::default(),
        };
        let engine = Engine::new(
            shrad::scene::cornell_box(),
            PatchSizing::Count(300),
            Backend::Auto,
            SolverChoice::preset("dispersive", "default").unwrap(),
        )
        .unwrap();
        let (tx, mut rx) = tokio::sync::mpsc::channel(4);
        let job = |client| Job {
            pending: Pending {
                envelope: protocol::parse(r#"{"v":1,"type":"compute_error"}"#).unwrap(),
                key: None,
                reply: Reply::try_reserve(&tx).unwrap(),
                received: Instant::now(),
                received_at_frame: 0,
                client,
            },
            state: State::of(engine.world(), 0),
            work: Work::Error {
                radiosity: Vec::new(),
                reference: ReferenceOptions::fast(),
                solver: String::new(),
                preset: String::new(),
                epoch: 0,
            },
            scene: None,
        };
        // The answer a submitted job got at once, if any.
        let mut submit = |client| {
            jobs.submit(job(client), &engine);
            rx.try_recv().ok()
        };
        assert_eq!(submit(1), None);
        let again = submit(1).unwrap();
        assert!(again.contains("rate limited"), "{again}");
        assert_eq!(submit(2), None);
        let full = submit(3).unwrap();
        assert!(
            full.contains("queue of expensive requests is full"),
            "{full}"
        );
        assert!(jobs.scene_sent, "the first job carries the scene");
        // Refused, client 3 holds no place: once there is room it may try again.
        assert!(!lock(&jobs.busy).contains(&3));
    }
}
