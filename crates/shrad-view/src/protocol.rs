//! The viewer's wire protocol, version [`VERSION`] (docs/viewer-protocol.md): JSON control
//! messages from the page, JSON replies and statistics from the server, and binary frames
//! for geometry and per-vertex colours.
//!
//! Binary messages start with a 16-byte little-endian header: magic `SHRV`, the protocol
//! version (u16), a kind (u8) and a channel (u8), the frame number (u32) and a kind-specific
//! u32. Colours are linear radiance as IEEE half floats times a power-of-two scale that the
//! header carries, so any scene's range fits and the page hands the halves to the GPU as they
//! come.

use glam::{Affine3A, Mat4, Vec3};
use serde::Deserialize;
use serde_json::{json, Value};

use shrad::view_data::{Channel, DisplayMesh};

/// Protocol version: every message carries it as `"v"`.
pub const VERSION: u32 = 1;

/// The largest control message the protocol accepts (bytes); a larger one gets an error
/// reply and is ignored.
pub const MAX_MESSAGE_BYTES: usize = 64 * 1024;

/// The largest message the WebSocket layer reads at all: beyond it the connection is closed
/// with status 1009 (message too big). Between the two limits the reply is an error.
pub const MAX_WIRE_BYTES: usize = 1024 * 1024;

/// Bytes of frame messages (`frame`, `probes`, colour frames) a client may have received
/// from the server and not yet acknowledged (`ack`); one frame is always allowed, however
/// large. Frames that cannot go are not queued: the client gets the newest once it has
/// caught up. 192 KiB is one colour frame of the 20k-patch Cornell box (about 0.13 MB; the
/// 77k room's 0.5 MB go alone): with either, one frame is in flight at a time, and the
/// next to go is the newest. A small scene's frames go several at a time.
pub const MAX_IN_FLIGHT_BYTES: usize = 192 * 1024;

/// "SHRV", little-endian.
pub const MAGIC: u32 = u32::from_le_bytes(*b"SHRV");

/// Binary message kinds.
pub const KIND_COLOURS: u8 = 1;
/// Geometry: every object's vertices (local frame) and triangles.
pub const KIND_GEOMETRY: u8 = 2;
/// The sky's equirectangular map (once, after the geometry, when the sky is a map).
pub const KIND_SKY: u8 = 3;

/// How a request names an object or a punctual light: its index, or its name.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(
    untagged,
    expecting = "an index (a non-negative integer) or a name (a string)"
)]
pub enum ObjectRef {
    /// Scene index.
    Index(usize),
    /// Name in the scene.
    Name(String),
}

/// A control message from a client (without its envelope `v` and `id`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    /// Put an interior object at `matrix` (world from object, 16 numbers, column-major
    /// 4x4 with last row 0 0 0 1, as three.js's `Matrix4.elements`).
    SetTransform {
        /// The object.
        object: ObjectRef,
        /// World-from-object matrix.
        matrix: Vec<f64>,
    },
    /// Set a light's emitted radiance (linear RGB; zero switches it off).
    SetEmission {
        /// The light.
        object: ObjectRef,
        /// `L_e`, linear RGB.
        radiance: [f64; 3],
    },
    /// Set an object's reflectance factor (linear RGB, each in [0, 1]; its texture and
    /// vertex colours multiply it): a surface painted another colour.
    SetReflectance {
        /// The object.
        object: ObjectRef,
        /// The factor, linear RGB.
        reflectance: [f64; 3],
    },
    /// Put punctual light `light` at `matrix` (world from light, as `set_transform`'s; it
    /// shines along that frame's -Z), keeping its colour and intensity.
    SetLightTransform {
        /// The light (index or name in the `scene` message's `lights`).
        light: ObjectRef,
        /// World-from-light matrix.
        matrix: Vec<f64>,
    },
    /// Set punctual light `light`'s colour and intensity, keeping it where it is.
    SetLightIntensity {
        /// The light.
        light: ObjectRef,
        /// Linear RGB.
        color: [f64; 3],
        /// Photometric, as glTF's `KHR_lights_punctual`: candela for a point or spot light,
        /// lux for a directional one.
        intensity: f64,
    },
    /// Go to `t` seconds on the scene's animation (pauses playback).
    SetTime {
        /// Seconds.
        t: f64,
    },
    /// Play or pause the animation.
    Play {
        /// Play (true) or pause.
        playing: bool,
        /// Speed factor (1: real time).
        #[serde(default)]
        speed: Option<f64>,
    },
    /// Switch the solver (precomputes again).
    SetSolver {
        /// `dispersive`, `grid` or `reference`.
        solver: String,
        /// A preset of that solver (`default`, `paper`...).
        #[serde(default)]
        preset: Option<String>,
    },
    /// Change one setting of the solver in use by name.
    SetOption {
        /// The setting's key.
        key: String,
        /// Its new value (a string or a number).
        value: Value,
    },
    /// Compute the error of the current state against a reference solve.
    ComputeError {},
    /// Which channel this client's colour frames carry.
    SetChannel {
        /// `total`, `direct` or `indirect`.
        channel: String,
    },
    /// Receive (or stop receiving) the dispersive solver's probes.
    Probes {
        /// On or off.
        on: bool,
    },
    /// Keep stepping after the scene has converged (else the engine idles until a change).
    Run {
        /// Step continuously.
        continuous: bool,
    },
    /// Answered by `pong` with the same `id`.
    Ping {},
    /// Become the client that steers, if nobody does (`access.rs`).
    TakeSteering {},
    /// Hand steering over: nobody steers until a client takes it.
    ReleaseSteering {},
    /// Flow control (no reply): the client has received `received` frame messages
    /// (`frame`, `probes` and colour frames) since it connected. The server keeps at most
    /// [`MAX_IN_FLIGHT_BYTES`] of them unacknowledged per client (and always one).
    Ack {
        /// Frame messages received so far.
        received: u64,
    },
}

impl Request {
    /// The message's `type`, for replies.
    pub fn kind(&self) -> &'static str {
        match self {
            Request::SetTransform { .. } => "set_transform",
            Request::SetEmission { .. } => "set_emission",
            Request::SetReflectance { .. } => "set_reflectance",
            Request::SetLightTransform { .. } => "set_light_transform",
            Request::SetLightIntensity { .. } => "set_light_intensity",
            Request::SetTime { .. } => "set_time",
            Request::Play { .. } => "play",
            Request::SetSolver { .. } => "set_solver",
            Request::SetOption { .. } => "set_option",
            Request::ComputeError {} => "compute_error",
            Request::SetChannel { .. } => "set_channel",
            Request::Probes { .. } => "probes",
            Request::Run { .. } => "run",
            Request::Ping {} => "ping",
            Request::Ack { .. } => "ack",
            Request::TakeSteering {} => "take_steering",
            Request::ReleaseSteering {} => "release_steering",
        }
    }

    /// Whether the request changes what everyone sees (only the client that steers may
    /// send it). Watching requests (channel, probes, acknowledgements, ping, the error
    /// against the reference, which changes nothing) are anyone's.
    pub fn is_steering(&self) -> bool {
        matches!(
            self,
            Request::SetTransform { .. }
                | Request::SetEmission { .. }
                | Request::SetReflectance { .. }
                | Request::SetLightTransform { .. }
                | Request::SetLightIntensity { .. }
                | Request::SetTime { .. }
                | Request::Play { .. }
                | Request::SetSolver { .. }
                | Request::SetOption { .. }
                | Request::Run { .. }
        )
    }
}

/// A parsed control message: the request and the client's optional `id` (echoed in the
/// reply).
#[derive(Clone, Debug, PartialEq)]
pub struct Envelope {
    /// The client's id for this message, if any.
    pub id: Option<u64>,
    /// What it asks.
    pub request: Request,
}

/// Why a message was refused: the text of the `error` reply, and the id if one was found.
#[derive(Clone, Debug, PartialEq)]
pub struct Refused {
    /// The message's `id`, when it could be read.
    pub id: Option<u64>,
    /// What is wrong.
    pub message: String,
}

/// Parse a text message: size, JSON, envelope (`v`, `id`), then the request.
pub fn parse(text: &str) -> Result<Envelope, Refused> {
    let refuse = |id, message: String| Refused { id, message };
    if text.len() > MAX_MESSAGE_BYTES {
        return Err(refuse(
            None,
            format!(
                "message of {} bytes is larger than the limit of {MAX_MESSAGE_BYTES} bytes",
                text.len()
            ),
        ));
    }
    let value: Value =
        serde_json::from_str(text).map_err(|e| refuse(None, format!("not JSON: {e}")))?;
    let Value::Object(mut map) = value else {
        return Err(refuse(None, "a message must be a JSON object".to_string()));
    };
    let id = match map.remove("id") {
        None | Some(Value::Null) => None,
        Some(v) => Some(v.as_u64().ok_or_else(|| {
            refuse(
                None,
                format!("\"id\" must be a non-negative integer, got {v}"),
            )
        })?),
    };
    match map.remove("v") {
        Some(v) if v.as_u64() == Some(VERSION as u64) => {}
        Some(v) => {
            return Err(refuse(
                id,
                format!("protocol version {v} is not supported (this server speaks {VERSION})"),
            ))
        }
        None => {
            return Err(refuse(
                id,
                format!("missing \"v\" (the protocol version, {VERSION})"),
            ))
        }
    }
    if !map.get("type").is_some_and(Value::is_string) {
        return Err(refuse(id, "missing \"type\" (a string)".to_string()));
    }
    let request: Request = serde_json::from_value(Value::Object(map))
        .map_err(|e| refuse(id, format!("bad message: {e}")))?;
    Ok(Envelope { id, request })
}

/// `x` as the engine's 32-bit float, or an error naming `what` when it is beyond their
/// range (1e39 became `inf`, and the engine's error said the client sent "inf").
pub fn single(x: f64, what: &str) -> Result<f32, String> {
    match x.abs() <= f64::from(f32::MAX) || x.is_nan() {
        true => Ok(x as f32),
        false => Err(format!(
            "{what} {x:e} is beyond the range of 32-bit floats (at most {:.1e})",
            f32::MAX
        )),
    }
}

/// `single` of each of three numbers.
pub fn single3(c: [f64; 3], what: &str) -> Result<glam::Vec3, String> {
    Ok(glam::Vec3::new(
        single(c[0], what)?,
        single(c[1], what)?,
        single(c[2], what)?,
    ))
}

/// The world-from-object affine map of a 16-number column-major matrix; an error unless its
/// last row is 0 0 0 1 and every number is finite.
pub fn affine_from_columns(m: &[f64]) -> Result<Affine3A, String> {
    if m.len() != 16 {
        return Err(format!("\"matrix\" needs 16 numbers, got {}", m.len()));
    }
    if let Some(x) = m.iter().find(|x| !(x.is_finite() && x.abs() < 1e30)) {
        return Err(format!("\"matrix\" holds {x}, not a finite number"));
    }
    let last_row = [m[3], m[7], m[11], m[15]];
    if (last_row[0].abs() + last_row[1].abs() + last_row[2].abs() + (last_row[3] - 1.0).abs())
        > 1e-6
    {
        return Err(format!(
            "\"matrix\" is not affine: its last row is {last_row:?}, not [0, 0, 0, 1]"
        ));
    }
    let cols: Vec<f32> = m.iter().map(|&x| x as f32).collect();
    Ok(Affine3A::from_mat4(Mat4::from_cols_slice(&cols)))
}

/// The column-major 4x4 of an affine map (16 numbers, as three.js's `Matrix4.elements`).
pub fn columns(a: Affine3A) -> [f32; 16] {
    Mat4::from(a).to_cols_array()
}

/// Parse a channel name.
pub fn channel(name: &str) -> Result<Channel, String> {
    match name {
        "total" => Ok(Channel::Total),
        "direct" => Ok(Channel::Direct),
        "indirect" => Ok(Channel::Indirect),
        _ => Err(format!(
            "unknown channel '{name}' (channels: total, direct, indirect)"
        )),
    }
}

/// Index of a channel in the colour frame's header.
pub fn channel_index(c: Channel) -> u8 {
    match c {
        Channel::Total => 0,
        Channel::Direct => 1,
        Channel::Indirect => 2,
    }
}

/// A JSON message from the server (the envelope added).
pub fn message(kind: &str, mut body: Value) -> String {
    if let Value::Object(map) = &mut body {
        map.insert("v".into(), json!(VERSION));
        map.insert("type".into(), json!(kind));
    }
    body.to_string()
}

/// The `error` reply.
pub fn error(id: Option<u64>, message_text: &str) -> String {
    message("error", json!({ "id": id, "message": message_text }))
}

pub(crate) fn header(out: &mut Vec<u8>, kind: u8, channel: u8, frame: u32, extra: u32) {
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&(VERSION as u16).to_le_bytes());
    out.push(kind);
    out.push(channel);
    out.extend_from_slice(&frame.to_le_bytes());
    out.extend_from_slice(&extra.to_le_bytes());
}

/// The colour frame: header (extra: object count `N`), then `f32` scale, `u32` vertex count
/// `V`, `N` world-from-local matrices (16 `f32` each, column-major), then `V` RGB triples of
/// `f16` whose value times the scale is the linear radiance (W m^-2 sr^-1) of the vertex.
pub fn colour_frame(
    frame: u32,
    channel: Channel,
    world_from_local: &[Affine3A],
    radiance: &[Vec3],
) -> Vec<u8> {
    let n = world_from_local.len();
    let mut out = Vec::with_capacity(24 + 64 * n + 6 * radiance.len());
    header(
        &mut out,
        KIND_COLOURS,
        channel_index(channel),
        frame,
        n as u32,
    );
    let scale = half_scale(radiance);
    out.extend_from_slice(&scale.to_le_bytes());
    out.extend_from_slice(&(radiance.len() as u32).to_le_bytes());
    for m in world_from_local {
        for x in columns(*m) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    push_halves(&mut out, radiance, scale);
    out
}

/// A power of two that brings the largest finite value of `values` to at most 2^14 (of
/// half's 65504): the scale is exact, and values keep half's 11 significant bits.
pub(crate) fn half_scale(values: &[Vec3]) -> f32 {
    let max = values
        .iter()
        .map(|c| c.max_element())
        .filter(|x| x.is_finite())
        .fold(0.0f32, f32::max);
    if max > 0.0 {
        2f32.powi((max.log2() - 14.0).ceil() as i32)
    } else {
        1.0
    }
}

/// `values / scale` as RGB halves (negative and non-finite values as 0).
pub(crate) fn push_halves(out: &mut Vec<u8>, values: &[Vec3], scale: f32) {
    for c in values {
        for x in c.to_array() {
            let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
            out.extend_from_slice(&half::f16::from_f32(x / scale).to_le_bytes());
        }
    }
}

/// The geometry message: header (extra: object count `N`), then per object `u32` vertex
/// count and `u32` triangle count (`2N` numbers), then every object's vertices (`3 f32`
/// each, local frame) one object after the other, then every object's triangles (`3 u32`
/// each, indices within the object).
pub fn geometry(mesh: &DisplayMesh) -> Vec<u8> {
    let n = mesh.objects.len();
    let vertices: usize = mesh.objects.iter().map(|o| o.positions.len()).sum();
    let triangles: usize = mesh.objects.iter().map(|o| o.triangles.len()).sum();
    let mut out = Vec::with_capacity(16 + 8 * n + 12 * (vertices + triangles));
    header(&mut out, KIND_GEOMETRY, 0, 0, n as u32);
    for o in &mesh.objects {
        out.extend_from_slice(&(o.positions.len() as u32).to_le_bytes());
        out.extend_from_slice(&(o.triangles.len() as u32).to_le_bytes());
    }
    for o in &mesh.objects {
        for p in &o.positions {
            for x in p.to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    for o in &mesh.objects {
        for t in &o.triangles {
            for i in t {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A number beyond `f32`'s range is refused as the number the client sent (it became
    /// `inf`, and the message said the client sent "inf"); the largest `f32` passes, and a
    /// NaN is left for the engine's checks.
    /// An object named by neither an index nor a name is told which it may be (it was "data
    /// did not match any variant of untagged enum ObjectRef").
    #[test]
    fn an_object_reference_that_is_neither_says_what_it_may_be() {
        for object in ["-1", "1.5", "null", "[1]"] {
            let m =
                format!(r#"{{"v":1,"type":"set_emission","object":{object},"radiance":[1,1,1]}}"#);
            let e = parse(&m).map(|_| ()).unwrap_err().message;
            assert!(
                e.contains("an index (a non-negative integer) or a name"),
                "{object}: {e}"
            );
        }
    }

    #[test]
    fn numbers_beyond_f32_are_refused_as_sent() {
        let e = single(1e39, "intensity").unwrap_err();
        assert!(e.contains("intensity 1e39") && e.contains("32-bit"), "{e}");
        let e = single3([0.5, -1e300, 0.5], "reflectance").unwrap_err();
        assert!(e.contains("reflectance -1e300"), "{e}");
        assert_eq!(single(f64::from(f32::MAX), "x"), Ok(f32::MAX));
        assert!(single(f64::NAN, "x").unwrap().is_nan());
    }

    #[test]
    fn envelope_and_errors() {
        let e = parse(r#"{"v":1,"type":"ping","id":7}"#).unwrap();
        assert_eq!(e.id, Some(7));
        assert_eq!(e.request, Request::Ping {});
        let e = parse(r#"{"v":1,"type":"set_transform","object":"short_block","matrix":[1,0,0,0,0,1,0,0,0,0,1,0,5,0,0,1]}"#).unwrap();
        let Request::SetTransform { matrix, .. } = e.request else {
            panic!()
        };
        let a = affine_from_columns(&matrix).unwrap();
        assert_eq!(a.translation, glam::Vec3A::new(5.0, 0.0, 0.0));
        let e = parse(r#"{"v":1,"type":"ack","received":12}"#).unwrap();
        assert_eq!(e.request, Request::Ack { received: 12 });
        for (text, needle) in [
            ("nope", "not JSON"),
            ("[1]", "JSON object"),
            (r#"{"type":"ping"}"#, "missing \"v\""),
            (r#"{"v":2,"type":"ping"}"#, "version 2"),
            (r#"{"v":1}"#, "missing \"type\""),
            (r#"{"v":1,"type":"fly"}"#, "unknown variant"),
            (r#"{"v":1,"type":"ping","x":1}"#, "unknown field"),
            (r#"{"v":1,"type":"set_time"}"#, "missing field"),
            (r#"{"v":1,"type":"ping","id":-1}"#, "\"id\""),
            (r#"{"v":1,"type":"ack"}"#, "missing field"),
            (r#"{"v":1,"type":"ack","received":-3}"#, "bad message"),
            (r#"{"v":1,"type":"ack","received":1.5}"#, "bad message"),
        ] {
            let r = parse(text).unwrap_err();
            assert!(r.message.contains(needle), "{text}: {}", r.message);
        }
        let big = format!(
            r#"{{"v":1,"type":"ping","pad":"{}"}}"#,
            "x".repeat(MAX_MESSAGE_BYTES)
        );
        assert!(parse(&big).unwrap_err().message.contains("larger than"));
        assert!(affine_from_columns(&[0.0; 15]).is_err());
        let mut m = [0.0; 16];
        m[3] = 1.0;
        assert!(affine_from_columns(&m).unwrap_err().contains("not affine"));
    }

    #[test]
    fn colours_are_halves_under_a_power_of_two_scale() {
        let radiance = [Vec3::new(1e6, 0.5, 0.0), Vec3::new(1e-3, 3.0, 7.0)];
        let bytes = colour_frame(3, Channel::Direct, &[Affine3A::IDENTITY], &radiance);
        assert_eq!(&bytes[0..4], b"SHRV");
        assert_eq!(bytes[7], 1);
        let scale = f32::from_le_bytes(bytes[16..20].try_into().unwrap());
        assert_eq!(scale.log2().fract(), 0.0);
        let at = 24 + 64;
        let decode = |k: usize| {
            half::f16::from_le_bytes(bytes[at + 2 * k..at + 2 * k + 2].try_into().unwrap()).to_f32()
                * scale
        };
        assert!((decode(0) - 1e6).abs() / 1e6 < 1e-3);
        assert!((decode(5) - 7.0).abs() / 7.0 < 1e-3);
        assert_eq!(bytes.len(), at + 6 * 2);
    }
}
