//! Publishing a frame: the colours of each channel some client wants, the probes when due,
//! and the `frame` message (statistics, steering, the solver and the lights as the engine
//! has them), into the latest-value slot the clients read.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use glam::Vec3;
use serde_json::{json, Value};
use shrad::view_data::{self, Channel};

use super::{EngineLoop, Frame, DIRECT_SAMPLES};
use crate::{probe_sphere, protocol, solvers};

impl EngineLoop {
    /// Publish the state after a frame (`stats`), or again without one.
    pub(super) fn publish(&mut self, stats: Option<&shrad::frame::FrameStats>) {
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
                probe_sphere::message(&self.engine, &self.probe_dirs, self.seq, self.solver_name());
            self.probes = Some((self.seq, Arc::new(message)));
        }
        let message = self.frame_message(stats);
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

    /// The `frame` message after a frame (`stats`), or of the state published again.
    fn frame_message(&self, stats: Option<&shrad::frame::FrameStats>) -> String {
        let stats_json = stats.map_or(Value::Null, |s| {
            serde_json::to_value(s).unwrap_or(Value::Null)
        });
        protocol::message(
            "frame",
            json!({
                "frame": self.seq,
                "solver": self.solver_name(),
                "preset": self.preset(),
                "settings": solvers::settings(&self.engine),
                "time": self.engine.time(),
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
                // Where each punctual light is now, its colour and intensity.
                "lights": crate::lights::states_json(&self.engine),
            }),
        )
    }
}
