//! Applying what the clients asked, at the start of a frame: each request to the engine's
//! own setter (moves, lights, time, solver, settings), its reply to the client's queue.

use std::sync::atomic::Ordering;
use std::time::Instant;

use serde_json::{json, Value};
use shrad::scene::Role;

use super::jobs::option_text;
use super::{EngineLoop, Steering};
use crate::inbox::{Batch, Pending};
use crate::protocol::{self, ObjectRef, Request};
use crate::solvers;

/// How the engine's lookups take a name or an index: as text ("3" is index 3 unless
/// something is called "3").
fn ref_text(r: &ObjectRef) -> String {
    match r {
        ObjectRef::Index(i) => i.to_string(),
        ObjectRef::Name(n) => n.clone(),
    }
}

impl EngineLoop {
    /// Apply what the clients asked since the last frame (in order: each key's newest).
    pub(super) fn apply(&mut self, batch: Batch) {
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
        // Its place in the client's queue was taken when the server read it: no waiting.
        reply.send(answer);
    }

    fn object(&self, r: &ObjectRef) -> Result<usize, String> {
        self.engine.object(&ref_text(r)).map_err(|e| e.to_string())
    }

    fn light(&self, r: &ObjectRef) -> Result<usize, String> {
        self.engine.light(&ref_text(r)).map_err(|e| e.to_string())
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
            Request::SetEmission { .. } | Request::SetReflectance { .. } => {
                self.set_surface(request)
            }
            Request::SetLightTransform { .. } | Request::SetLightIntensity { .. } => {
                self.steer_light(request)
            }
            Request::SetTime { t } => {
                if !t.is_finite() {
                    return Err(format!("time {t} is not a finite number"));
                }
                self.playing = false;
                let duration = self.duration();
                // A still scene's animation is the instant 0 (1e30 was echoed back).
                let t = t.clamp(0.0, duration.max(0.0)) + 0.0; // (-0 is 0)
                let t = protocol::single(t, "time")?;
                self.engine.set_time(t).map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({ "time": self.engine.time() }))
            }
            Request::Play { playing, speed } => {
                if let Some(s) = speed {
                    if !(s.is_finite() && s > 0.0 && s <= 100.0) {
                        return Err(format!("speed {s} must be in (0, 100]"));
                    }
                    self.speed = s;
                }
                if playing && self.duration() <= 0.0 {
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

    /// A surface's emission or reflectance (the engine checks the values and names the
    /// object in its error).
    fn set_surface(&mut self, request: Request) -> Result<Value, String> {
        match request {
            Request::SetEmission { object, radiance } => {
                let o = self.object(&object)?;
                let l = protocol::single3(radiance, "radiance")?;
                if !l.is_finite() {
                    return Err(format!("radiance {radiance:?} is not finite"));
                }
                self.engine.set_emission(o, l).map_err(|e| e.to_string())?;
            }
            Request::SetReflectance {
                object,
                reflectance,
            } => {
                let o = self.object(&object)?;
                let rho = protocol::single3(reflectance, "reflectance")?;
                self.engine
                    .set_reflectance(o, rho)
                    .map_err(|e| e.to_string())?;
            }
            _ => unreachable!("`handle` sends only emission and reflectance here"),
        }
        self.changed();
        Ok(json!({}))
    }

    /// A punctual light's move or its colour and intensity, through [`Engine::set_light`]
    /// (what the request leaves out stays as the engine has it).
    ///
    /// [`Engine::set_light`]: shrad::engine::Engine::set_light
    fn steer_light(&mut self, request: Request) -> Result<Value, String> {
        match request {
            Request::SetLightTransform { light, matrix } => {
                let l = self.light(&light)?;
                let m = protocol::affine_from_columns(&matrix)?;
                let now = self.engine.world().scene.lights[l].at(self.engine.time());
                let (color, intensity) = (now.color, now.intensity);
                self.engine
                    .set_light(l, m, color, intensity)
                    .map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({}))
            }
            Request::SetLightIntensity {
                light,
                color,
                intensity,
            } => {
                let l = self.light(&light)?;
                let m = self.engine.light_transform(l).map_err(|e| e.to_string())?;
                let c = protocol::single3(color, "color")?;
                let intensity = protocol::single(intensity, "intensity")?;
                self.engine
                    .set_light(l, m, c, intensity)
                    .map_err(|e| e.to_string())?;
                self.changed();
                Ok(json!({}))
            }
            _ => Err(format!("{} is not a light's request", request.kind())),
        }
    }
}
