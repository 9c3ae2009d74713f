//! Read-only views of the dispersive solver's state for a viewer (`shrad view`): every
//! interior object's 8 corner probes (paper 2.3.3 Step 2) where they stand now, with the SH
//! radiance they see and whether they are valid, repaired (moved inward, spec 4.6) or
//! invalid; and the direct irradiance of Step 1 (2.3.2), for the "direct only" channel.
//! Nothing here changes the solver.

use glam::Vec3;
use shrad_sh::ShRgb;

use super::Dispersive;
use crate::World;

/// What a probe's capture found (spec 4.6, probe validity).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ProbeState {
    /// At its corner, and it sees few enough back faces.
    Valid,
    /// Moved inward from its corner by the repair, and valid there.
    Repaired,
    /// It sees more back faces than `invalid_back_fraction` allows (inside or behind
    /// geometry): dropped, or used as is when the repair is off.
    Invalid,
}

/// One of an interior object's 8 corner probes, as it stands now.
#[derive(Clone, Debug)]
pub struct ProbeView {
    /// The object (scene index).
    pub object: usize,
    /// Corner of the probe box (bit 0: x, bit 1: y, bit 2: z, object frame).
    pub corner: usize,
    /// World position.
    pub position: Vec3,
    /// SH of the radiance the probe sees (world frame; reflected light only when direct
    /// light on interior objects is computed apart, as in the default).
    pub sh: ShRgb,
    /// Valid, repaired or invalid.
    pub state: ProbeState,
}

impl Dispersive {
    /// Capture every interior object's 8 probes at their current places from the current
    /// radiosity, as Step 2 does (the same cube-map resolution, exclusions and shading):
    /// 8 cube maps per interior object, so a viewer asks for this now and then, not every
    /// frame.
    pub fn probe_views(&self, world: &World) -> Vec<ProbeView> {
        let p = &world.patches;
        let limit = self.options.invalid_back_fraction;
        let mut out = Vec::with_capacity(8 * self.objects.len());
        for (k, ob) in self.objects.iter().enumerate() {
            let o = ob.object;
            let m = p.world_from_local[o];
            let exclude = self.probes_see_through(world, k);
            let points: Vec<Vec3> = (0..8)
                .map(|c| m.transform_point3(ob.probe_local(c)))
                .collect();
            let captured = self.camera.capture(world, &points, &exclude, |h| {
                self.shade_probe_texel(world, h, o as u32)
            });
            for (c, (sh, back)) in captured
                .sh
                .into_iter()
                .zip(captured.back_fraction)
                .enumerate()
            {
                let state = if back > limit {
                    ProbeState::Invalid
                } else if ob.probe_scale[c].min_element() < 1.0 {
                    ProbeState::Repaired
                } else {
                    ProbeState::Valid
                };
                out.push(ProbeView {
                    object: o,
                    corner: c,
                    position: points[c],
                    sh,
                    state,
                });
            }
        }
        out
    }

    /// Step 1's direct irradiance of every patch, when the solver holds it for all of them
    /// (direct light on interior objects computed apart, and Step 1 run at least once);
    /// `None` otherwise (the paper's preset lights interior objects' direct light through
    /// their probes).
    pub fn direct_irradiance(&self) -> Option<&[Vec3]> {
        (self.options.direct_on_interior && self.direct_valid).then_some(&self.direct[..])
    }
}
