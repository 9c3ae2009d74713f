//! Each solver's typed settings read and written key by key (the values already checked
//! against the key's range).

use super::keys::{DEFAULT_BUDGET_MS, DEFAULT_MAX_STALENESS, DEFAULT_PER_FRAME};
use super::Value;
use crate::dispersive::{DispersiveOptions, ProbeRepair, Schedule, ToBoundary};
use crate::grid::GridOptions;
use crate::reference::ReferenceOptions;

/// The keys of one solver's typed settings, read and written as [`Value`]s.
pub(super) trait Keyed {
    fn read(&self, key: &str) -> Value;
    /// `value` is already checked against the key's range.
    fn write(&mut self, key: &str, value: Value) -> Result<(), String>;
}

pub(super) fn as_int(v: Value) -> u64 {
    match v {
        Value::Int(v) => v,
        _ => unreachable!("value checked against an integer range"),
    }
}

pub(super) fn as_usize(v: Value) -> usize {
    usize::try_from(as_int(v)).unwrap_or(usize::MAX)
}

pub(super) fn as_u32(v: Value) -> u32 {
    u32::try_from(as_int(v)).unwrap_or(u32::MAX)
}

pub(super) fn as_f32(v: Value) -> f32 {
    match v {
        Value::Float(v) => v as f32,
        _ => unreachable!("value checked against a number range"),
    }
}

pub(super) fn as_bool(v: Value) -> bool {
    match v {
        Value::Bool(v) => v,
        _ => unreachable!("value checked as true|false"),
    }
}

pub(super) fn as_choice(v: Value) -> &'static str {
    match v {
        Value::Choice(v) => v,
        _ => unreachable!("value checked against a list of names"),
    }
}

impl Keyed for DispersiveOptions {
    fn read(&self, key: &str) -> Value {
        let (per_frame, max_staleness, budget_ms) = match self.schedule {
            Schedule::RoundRobin { per_frame } => (Some(per_frame), None, None),
            Schedule::Priority {
                per_frame,
                max_staleness,
            } => (Some(per_frame), Some(max_staleness), None),
            Schedule::Budget { ms, max_staleness } => (None, Some(max_staleness), Some(ms)),
            Schedule::Full => (None, None, None),
        };
        let size = |v: usize| Value::Int(v as u64);
        match key {
            "bands" => size(self.bands),
            "cube_res" => size(self.cube_res),
            "emitter_res" => size(self.emitter_res),
            "probe_margin" => Value::Float(self.probe_margin.into()),
            "schedule" => Value::Choice(match self.schedule {
                Schedule::RoundRobin { .. } => "round_robin",
                Schedule::Priority { .. } => "priority",
                Schedule::Budget { .. } => "budget",
                Schedule::Full => "full",
            }),
            "per_frame" => per_frame.map_or(Value::Unused, size),
            "max_staleness" => max_staleness.map_or(Value::Unused, size),
            "budget_ms" => budget_ms.map_or(Value::Unused, |ms| Value::Float(ms.into())),
            "invalid_back_fraction" => Value::Float(self.invalid_back_fraction.into()),
            "repair" => Value::Choice(match self.repair {
                ProbeRepair::None => "none",
                ProbeRepair::Drop => "drop",
                ProbeRepair::MoveInward => "move_inward",
                ProbeRepair::MoveOut => "move_out",
            }),
            "wall_exchange" => Value::Bool(self.wall_exchange),
            "wall_rays" => Value::Int(self.wall_rays.into()),
            "see_through_self" => Value::Bool(self.see_through_self),
            "direct_on_interior" => Value::Bool(self.direct_on_interior),
            "direct_samples" => Value::Int(self.direct_samples.into()),
            "to_boundary" => Value::Choice(match self.to_boundary {
                ToBoundary::Splat => "splat",
                ToBoundary::Gather => "gather",
                ToBoundary::Auto => "auto",
            }),
            "contact_rays" => Value::Int(self.contact_rays.into()),
            "emitter_per_face" => Value::Bool(self.emitter_per_face),
            "emitter_split" => Value::Int(self.emitter_split.into()),
            "self_shadow_rays" => Value::Int(self.self_shadow_rays.into()),
            "splat_smoothing" => Value::Bool(self.splat_smoothing),
            "wall_smoothing" => Value::Bool(self.wall_smoothing),
            "sleep_tolerance" => Value::Float(self.sleep_tolerance.into()),
            "coarse_while_moving" => Value::Bool(self.coarse_while_moving),
            "one_emitter_while_moving" => Value::Bool(self.one_emitter_while_moving),
            "resend_tolerance" => Value::Float(self.resend_tolerance.into()),
            "near_rays" => Value::Int(self.near_rays.into()),
            "near_reach" => Value::Float(self.near_reach.into()),
            "probe_visibility" => Value::Bool(self.probe_visibility),
            "see_through_near" => Value::Bool(self.see_through_near),
            _ => unreachable!("key {key} is in DISPERSIVE_KEYS"),
        }
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        let schedule_name = as_choice(self.read("schedule"));
        let unused = || {
            let users = match key {
                "per_frame" => "round_robin and priority",
                "max_staleness" => "priority and budget",
                _ => "budget",
            };
            format!("{key} is used only by schedule {users}, and the schedule is {schedule_name}; set schedule first")
        };
        match key {
            "bands" => self.bands = as_usize(value),
            "cube_res" => self.cube_res = as_usize(value),
            "emitter_res" => self.emitter_res = as_usize(value),
            "probe_margin" => self.probe_margin = as_f32(value),
            "schedule" => {
                // Parameters the new schedule shares with the old one carry over.
                let old = |k: &str, default: Value| match self.read(k) {
                    Value::Unused => default,
                    v => v,
                };
                let per_frame = as_usize(old("per_frame", Value::Int(DEFAULT_PER_FRAME as u64)));
                let max_staleness = as_usize(old(
                    "max_staleness",
                    Value::Int(DEFAULT_MAX_STALENESS as u64),
                ));
                let ms = as_f32(old("budget_ms", Value::Float(DEFAULT_BUDGET_MS.into())));
                self.schedule = match as_choice(value) {
                    "round_robin" => Schedule::RoundRobin { per_frame },
                    "priority" => Schedule::Priority {
                        per_frame,
                        max_staleness,
                    },
                    "budget" => Schedule::Budget { ms, max_staleness },
                    _ => Schedule::Full,
                };
            }
            "per_frame" => match &mut self.schedule {
                Schedule::RoundRobin { per_frame } | Schedule::Priority { per_frame, .. } => {
                    *per_frame = as_usize(value)
                }
                _ => return Err(unused()),
            },
            "max_staleness" => match &mut self.schedule {
                Schedule::Priority { max_staleness, .. }
                | Schedule::Budget { max_staleness, .. } => *max_staleness = as_usize(value),
                _ => return Err(unused()),
            },
            "budget_ms" => match &mut self.schedule {
                Schedule::Budget { ms, .. } => *ms = as_f32(value),
                _ => return Err(unused()),
            },
            "invalid_back_fraction" => self.invalid_back_fraction = as_f32(value),
            "repair" => {
                self.repair = match as_choice(value) {
                    "none" => ProbeRepair::None,
                    "drop" => ProbeRepair::Drop,
                    "move_inward" => ProbeRepair::MoveInward,
                    _ => ProbeRepair::MoveOut,
                }
            }
            "wall_exchange" => self.wall_exchange = as_bool(value),
            "wall_rays" => self.wall_rays = as_u32(value),
            "see_through_self" => self.see_through_self = as_bool(value),
            "direct_on_interior" => self.direct_on_interior = as_bool(value),
            "direct_samples" => self.direct_samples = as_u32(value),
            "to_boundary" => {
                self.to_boundary = match as_choice(value) {
                    "splat" => ToBoundary::Splat,
                    "gather" => ToBoundary::Gather,
                    _ => ToBoundary::Auto,
                }
            }
            "contact_rays" => self.contact_rays = as_u32(value),
            "emitter_per_face" => self.emitter_per_face = as_bool(value),
            "emitter_split" => self.emitter_split = as_u32(value),
            "self_shadow_rays" => self.self_shadow_rays = as_u32(value),
            "splat_smoothing" => self.splat_smoothing = as_bool(value),
            "wall_smoothing" => self.wall_smoothing = as_bool(value),
            "sleep_tolerance" => self.sleep_tolerance = as_f32(value),
            "coarse_while_moving" => self.coarse_while_moving = as_bool(value),
            "one_emitter_while_moving" => self.one_emitter_while_moving = as_bool(value),
            "resend_tolerance" => self.resend_tolerance = as_f32(value),
            "near_rays" => self.near_rays = as_u32(value),
            "near_reach" => self.near_reach = as_f32(value),
            "probe_visibility" => self.probe_visibility = as_bool(value),
            "see_through_near" => self.see_through_near = as_bool(value),
            _ => unreachable!("key {key} is in DISPERSIVE_KEYS"),
        }
        Ok(())
    }
}

impl Keyed for GridOptions {
    fn read(&self, key: &str) -> Value {
        Value::Int(match key {
            "per_axis" => self.per_axis,
            "cube_res" => self.cube_res,
            "bands" => self.bands,
            _ => unreachable!("key {key} is in GRID_KEYS"),
        } as u64)
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        let v = as_usize(value);
        match key {
            "per_axis" => self.per_axis = v,
            "cube_res" => self.cube_res = v,
            "bands" => self.bands = v,
            _ => unreachable!("key {key} is in GRID_KEYS"),
        }
        Ok(())
    }
}

impl Keyed for ReferenceOptions {
    fn read(&self, key: &str) -> Value {
        match key {
            "rays_per_patch" => Value::Int(self.rays_per_patch.into()),
            "direct_samples" => Value::Int(self.direct_samples.into()),
            "tolerance" => Value::Float(self.tolerance.into()),
            "max_iterations" => Value::Int(self.max_iterations as u64),
            _ => unreachable!("key {key} is in REFERENCE_KEYS"),
        }
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        match key {
            "rays_per_patch" => self.rays_per_patch = as_u32(value),
            "direct_samples" => self.direct_samples = as_u32(value),
            "tolerance" => self.tolerance = as_f32(value),
            "max_iterations" => self.max_iterations = as_usize(value),
            _ => unreachable!("key {key} is in REFERENCE_KEYS"),
        }
        Ok(())
    }
}
