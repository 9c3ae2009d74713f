//! SH light probes: capture a cube map of what a point sees, project it to SH (paper 2.3.3
//! Steps 2-3). Shared by the dispersive solver (8 probes at each object's box corners) and
//! the grid baseline (a uniform grid of probes).

use glam::Vec3;
use rayon::prelude::*;
use shrad_sh::{CubeMap, ShProjector, ShRgb};
use shrad_vis::Hit;

use crate::World;

/// What a texel of a probe's cube map sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Seen {
    /// Radiance arriving from that direction.
    Radiance(Vec3),
    /// The back of a single-sided surface: radiance 0, and a sign that the probe may be
    /// inside or behind geometry (spec 4.6, probe validity).
    BackFace,
}

/// The most bytes of hits [`ProbeCamera::capture`] holds at once.
pub const CAPTURE_BYTES: usize = 256 << 20;

/// A cube-map resolution with its SH projector, built once per solver.
pub struct ProbeCamera {
    /// Texel directions and solid angles.
    pub cube: CubeMap,
    /// Precomputed `Y_k(w_t) dW_t`.
    pub projector: ShProjector,
}

/// The result of capturing some probes.
pub struct Captured {
    /// SH radiance of each probe.
    pub sh: Vec<ShRgb>,
    /// Fraction of each probe's sphere (by solid angle) that sees back faces.
    pub back_fraction: Vec<f32>,
}

impl ProbeCamera {
    /// Cube maps of `res` x `res` texels per face, SH of `bands` bands.
    pub fn new(res: usize, bands: usize) -> Self {
        let cube = CubeMap::new(res.max(1));
        let projector = ShProjector::new(bands, &cube);
        ProbeCamera { cube, projector }
    }

    /// Number of texels per probe.
    pub fn texels(&self) -> usize {
        self.cube.directions.len()
    }

    /// The raw hits of a cube map at each of `points` (objects in `exclude` are transparent),
    /// `texels()` per point, for a caller that keeps them (the dispersive Step 2 cache).
    pub fn capture_hits(&self, world: &World, points: &[Vec3], exclude: &[u32]) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; points.len() * self.texels()];
        world
            .vis
            .capture(points, &self.cube.directions, 0.0, exclude, &mut hits);
        hits
    }

    /// Capture a cube map of ids at each of `points` (objects in `exclude` are transparent),
    /// turn every hit into radiance with `shade`, and project to SH. The points are taken
    /// in batches whose hits fit [`CAPTURE_BYTES`]: a grid's probes were captured in one
    /// allocation (64^3 probes at `cube_res` 32 asked 412 GB, and the process aborted).
    pub fn capture(
        &self,
        world: &World,
        points: &[Vec3],
        exclude: &[u32],
        shade: impl Fn(&Hit) -> Seen + Sync,
    ) -> Captured {
        self.capture_within(world, (points, exclude), shade, CAPTURE_BYTES)
    }

    /// [`ProbeCamera::capture`] with at most `bytes` of hits at once.
    fn capture_within(
        &self,
        world: &World,
        (points, exclude): (&[Vec3], &[u32]),
        shade: impl Fn(&Hit) -> Seen + Sync,
        bytes: usize,
    ) -> Captured {
        let n = self.texels();
        let batch = (bytes / (n * std::mem::size_of::<Hit>()).max(1)).max(1);
        let mut results: Vec<(ShRgb, f32)> = Vec::with_capacity(points.len());
        for some in points.chunks(batch) {
            let hits = self.capture_hits(world, some, exclude);
            results.par_extend(hits.par_chunks(n).map(|h| {
                let mut back = 0.0;
                let sh = self.projector.project_indexed(|t| match shade(&h[t]) {
                    Seen::Radiance(l) => l,
                    Seen::BackFace => {
                        back += self.cube.solid_angles[t];
                        Vec3::ZERO
                    }
                });
                (sh, back / (4.0 * std::f32::consts::PI))
            }));
        }
        let (sh, back_fraction) = results.into_iter().unzip();
        Captured { sh, back_fraction }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Probes captured in batches (a few at a time) are the probes captured at once.
    #[test]
    fn batched_captures_are_the_same_probes() {
        let scene = shrad_scene::cornell_box();
        let world = World::new(scene, crate::PatchSizing::Count(500), Default::default());
        let world = world.expect("the Cornell box at 500 patches");
        let camera = ProbeCamera::new(8, 3);
        let points: Vec<Vec3> = (0..7)
            .map(|k| Vec3::new(100.0 + 50.0 * k as f32, 300.0, 250.0))
            .collect();
        let shade = |h: &Hit| match world.seen_patch(h) {
            Some(i) => Seen::Radiance(Vec3::splat(i as f32)),
            None => Seen::Radiance(Vec3::ZERO),
        };
        let whole = camera.capture(&world, &points, &[], shade);
        let two_at_a_time = 2 * camera.texels() * std::mem::size_of::<Hit>();
        let batched = camera.capture_within(&world, (&points, &[]), shade, two_at_a_time);
        assert_eq!(whole.sh.len(), 7);
        assert_eq!(whole.sh, batched.sh);
        assert_eq!(whole.back_fraction, batched.back_fraction);
    }
}
