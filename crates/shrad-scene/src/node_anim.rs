//! Node animation imported from glTF: the node hierarchy with each node's rest transform and
//! sampled translation / rotation / scale channels (glTF 2.0, "Animations" and Appendix C).
//! An [`Object`](crate::Object) instanced by an animated node (or by a descendant of one)
//! holds a [`NodeAnimation`]: the shared [`NodeGraph`] and its node, enough to compose the
//! node's world transform at any time.

use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3, Vec4};

/// How a channel's keys are interpolated (glTF `sampler.interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Linear (slerp for rotations).
    Linear,
    /// Each key holds until the next.
    Step,
    /// Cubic Hermite spline with in / out tangents per key.
    CubicSpline,
}

impl Interpolation {
    /// The glTF spelling.
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Linear => "LINEAR",
            Interpolation::Step => "STEP",
            Interpolation::CubicSpline => "CUBICSPLINE",
        }
    }
}

/// A value a channel animates: translation or scale ([`Vec3`]), rotation ([`Quat`]), or a
/// light's or material's property (`property_tracks`: [`Vec3`] colours, `f32` scalars).
pub trait TrackValue: Copy + Default {
    /// Linear interpolation (slerp for quaternions) at `s` in [0, 1].
    fn interpolate(a: Self, b: Self, s: f32) -> Self;
    /// Cubic Hermite: values `v0`, `v1`, tangents `m0`, `m1` already scaled by the interval.
    fn hermite(v0: Self, m0: Self, v1: Self, m1: Self, s: f32) -> Self;
    /// The value (a tangent) times `k`.
    fn scaled(self, k: f32) -> Self;
}

fn hermite4(v0: Vec4, m0: Vec4, v1: Vec4, m1: Vec4, s: f32) -> Vec4 {
    let (s2, s3) = (s * s, s * s * s);
    v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
        + m0 * (s3 - 2.0 * s2 + s)
        + v1 * (-2.0 * s3 + 3.0 * s2)
        + m1 * (s3 - s2)
}

impl TrackValue for Vec3 {
    fn interpolate(a: Self, b: Self, s: f32) -> Self {
        a.lerp(b, s)
    }
    fn hermite(v0: Self, m0: Self, v1: Self, m1: Self, s: f32) -> Self {
        hermite4(
            v0.extend(0.0),
            m0.extend(0.0),
            v1.extend(0.0),
            m1.extend(0.0),
            s,
        )
        .truncate()
    }
    fn scaled(self, k: f32) -> Self {
        self * k
    }
}

impl TrackValue for f32 {
    fn interpolate(a: Self, b: Self, s: f32) -> Self {
        a + (b - a) * s
    }
    fn hermite(v0: Self, m0: Self, v1: Self, m1: Self, s: f32) -> Self {
        hermite4(
            Vec4::new(v0, 0.0, 0.0, 0.0),
            Vec4::new(m0, 0.0, 0.0, 0.0),
            Vec4::new(v1, 0.0, 0.0, 0.0),
            Vec4::new(m1, 0.0, 0.0, 0.0),
            s,
        )
        .x
    }
    fn scaled(self, k: f32) -> Self {
        self * k
    }
}

impl TrackValue for Quat {
    fn interpolate(a: Self, b: Self, s: f32) -> Self {
        a.slerp(b, s).normalize()
    }
    fn hermite(v0: Self, m0: Self, v1: Self, m1: Self, s: f32) -> Self {
        let q = hermite4(
            Vec4::from(v0),
            Vec4::from(m0),
            Vec4::from(v1),
            Vec4::from(m1),
            s,
        );
        Quat::from_vec4(q).normalize()
    }
    fn scaled(self, k: f32) -> Self {
        Quat::from_vec4(Vec4::from(self) * k)
    }
}

/// One sampled channel: strictly increasing key times and their values. For
/// [`Interpolation::CubicSpline`] `values` holds three per key: in-tangent, value,
/// out-tangent (as glTF stores them).
#[derive(Clone, Debug, PartialEq)]
pub struct Track<T> {
    /// Key times in seconds, strictly increasing, at least one.
    pub times: Vec<f32>,
    /// Values (three per key for cubic splines).
    pub values: Vec<T>,
    /// Interpolation between keys.
    pub interpolation: Interpolation,
}

impl<T: TrackValue> Track<T> {
    fn value(&self, k: usize) -> T {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The value at time `t`; before the first key and after the last the end keys hold.
    pub fn sample(&self, t: f32) -> T {
        let n = self.times.len();
        if n == 0 || self.values.is_empty() {
            // Never built so (the reader refuses empty channels); no panic regardless.
            return T::default();
        }
        if t.is_nan() || t <= self.times[0] {
            return self.value(0);
        }
        if t >= self.times[n - 1] {
            return self.value(n - 1);
        }
        let i = self.times.partition_point(|&x| x <= t).clamp(1, n - 1);
        let (t0, t1) = (self.times[i - 1], self.times[i]);
        let td = t1 - t0;
        let s = ((t - t0) / td).clamp(0.0, 1.0);
        match self.interpolation {
            Interpolation::Step => self.value(i - 1),
            Interpolation::Linear => T::interpolate(self.value(i - 1), self.value(i), s),
            Interpolation::CubicSpline => {
                let out0 = self.values[3 * (i - 1) + 2];
                let in1 = self.values[3 * i];
                T::hermite(
                    self.value(i - 1),
                    out0.scaled(td),
                    self.value(i),
                    in1.scaled(td),
                    s,
                )
            }
        }
    }

    /// Time of the last key.
    pub fn end(&self) -> f32 {
        self.times.last().copied().unwrap_or(0.0)
    }
}

/// A node's rest transform: a matrix (kept as written when the node is not animated) or
/// translation, rotation and scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeRest {
    /// `matrix` of the glTF node.
    Matrix(Affine3A),
    /// `translation`, `rotation`, `scale` of the glTF node.
    Trs {
        /// Translation.
        translation: Vec3,
        /// Rotation (unit quaternion).
        rotation: Quat,
        /// Scale.
        scale: Vec3,
    },
}

/// One node of the hierarchy: its parent, rest transform and animated channels.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphNode {
    /// glTF node name.
    pub name: Option<String>,
    /// Parent node.
    pub parent: Option<usize>,
    /// Rest local transform.
    pub rest: NodeRest,
    /// Translation channel (replaces the rest translation).
    pub translation: Option<Track<Vec3>>,
    /// Rotation channel.
    pub rotation: Option<Track<Quat>>,
    /// Scale channel.
    pub scale: Option<Track<Vec3>>,
}

impl GraphNode {
    /// A node with no channel.
    pub fn new(parent: Option<usize>, rest: NodeRest) -> Self {
        GraphNode {
            name: None,
            parent,
            rest,
            translation: None,
            rotation: None,
            scale: None,
        }
    }

    /// Has it a channel?
    pub fn is_animated(&self) -> bool {
        self.translation.is_some() || self.rotation.is_some() || self.scale.is_some()
    }

    /// The local transform (parent from node) at time `t`.
    pub fn local_at(&self, t: f32) -> Affine3A {
        let (t0, r0, s0) = match self.rest {
            NodeRest::Matrix(m) if !self.is_animated() => return m,
            NodeRest::Matrix(m) => {
                let (s, r, t) = m.to_scale_rotation_translation();
                (t, r.normalize(), s)
            }
            NodeRest::Trs {
                translation,
                rotation,
                scale,
            } => (translation, rotation, scale),
        };
        let t_ = self.translation.as_ref().map_or(t0, |c| c.sample(t));
        let r = self.rotation.as_ref().map_or(r0, |c| c.sample(t));
        // Keys with a zero component were raised to 1e-4 at load; between keys of opposite
        // signs (a mirror animated) the interpolated scale passes through 0, and is raised
        // the same way there (a surface of no area, which the solvers cannot take).
        let s = (self.scale.as_ref()).map_or(s0, |c| raise_collapsed(c.sample(t)));
        Affine3A::from_scale_rotation_translation(s, r, t_)
    }

    /// Time of the last key of its channels (0 without any).
    pub fn end(&self) -> f32 {
        let a = self.translation.as_ref().map_or(0.0, Track::end);
        let b = self.rotation.as_ref().map_or(0.0, Track::end);
        let c = self.scale.as_ref().map_or(0.0, Track::end);
        a.max(b).max(c)
    }
}

/// `s` with every component under 1e-4 in size raised to 1e-4, keeping its sign.
fn raise_collapsed(s: Vec3) -> Vec3 {
    let floor = Vec3::splat(1e-4).copysign(s);
    Vec3::select(s.abs().cmplt(Vec3::splat(1e-4)), floor, s)
}

/// A glTF file's node hierarchy with the channels of the animations that play.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeGraph {
    /// Nodes, indexed as in the file.
    pub nodes: Vec<GraphNode>,
}

impl NodeGraph {
    /// World transform (scene from node) of node `n` at time `t`: the local transforms at
    /// `t` composed from the root down.
    pub fn world_at(&self, n: usize, t: f32) -> Affine3A {
        let mut m = Affine3A::IDENTITY;
        let mut at = Some(n);
        // The hierarchy is a set of trees (checked by the reader); the bound is a guard.
        let mut steps = 0;
        while let Some(i) = at {
            let Some(node) = self.nodes.get(i) else { break };
            m = node.local_at(t) * m;
            at = node.parent;
            steps += 1;
            if steps > self.nodes.len() {
                break;
            }
        }
        m
    }

    /// Does node `n` or one of its ancestors have a channel?
    pub fn moves(&self, n: usize) -> bool {
        self.chain(n).any(GraphNode::is_animated)
    }

    /// Last key time over node `n` and its ancestors.
    pub fn end(&self, n: usize) -> f32 {
        self.chain(n).map(GraphNode::end).fold(0.0, f32::max)
    }

    fn chain(&self, n: usize) -> impl Iterator<Item = &GraphNode> {
        let mut at = Some(n);
        let mut steps = 0;
        std::iter::from_fn(move || {
            let node = self.nodes.get(at?)?;
            steps += 1;
            at = if steps > self.nodes.len() {
                None
            } else {
                node.parent
            };
            Some(node)
        })
    }
}

/// What moves an object imported from an animated glTF node:
/// `world_from_object(t) = outer · graph.world_at(node, t) · inner`.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeAnimation {
    /// The file's node hierarchy (shared by every object of the file).
    pub graph: Arc<NodeGraph>,
    /// The node that instances the object.
    pub node: usize,
    /// Applied on top (a scene file's rest transform of the object; identity for a glTF
    /// read on its own).
    pub outer: Affine3A,
    /// Applied first, in the node's frame (an instance's own transform, when the node draws
    /// its mesh by `EXT_mesh_gpu_instancing`; else the identity).
    pub inner: Affine3A,
}

impl NodeAnimation {
    /// The object's world transform at time `t` (before any scene-file keys).
    pub fn world_from_object_at(&self, t: f32) -> Affine3A {
        self.outer * self.graph.world_at(self.node, t) * self.inner
    }

    /// Time of the last key that moves the object.
    pub fn duration(&self) -> f32 {
        self.graph.end(self.node)
    }
}

/// One glTF animation as listed by `shrad info`.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationInfo {
    /// Index in the file.
    pub index: usize,
    /// Name (`animation<N>` when it has none).
    pub name: String,
    /// Channels that play (translation, rotation, scale of a node).
    pub channels: usize,
    /// Channels ignored (morph weights, pointers, no target node).
    pub ignored: usize,
    /// First and last key time (seconds) of its playing channels.
    pub start: f32,
    /// Last key time.
    pub end: f32,
    /// Selected to play (every animation by default).
    pub playing: bool,
}
