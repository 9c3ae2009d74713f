//! Light probes for dynamic objects in other engines (issue 19, item 2): the dispersive
//! solver's corner probes (8 per interior object, paper 2.3.3 Step 2) as three.js's
//! `LightProbe` takes them, for `shrad bake --probes corners` (JSON) and Python's
//! `engine.probes()`.
//!
//! **Coefficient order and convention.** Each probe has 9 RGB coefficients (3 bands), in
//! the order `(l, m)` = (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2):
//! the order of three.js's `SphericalHarmonics3.coefficients`. They are the coefficients of
//! the *radiance* the probe sees in the real orthonormal basis whose functions are positive
//! multiples of 1, y, z, x, xy, yz, 3z²-1, xz, x²-y² (world axes; glTF's and three.js's
//! +Y is up), which is both shrad-sh's convention and the basis three.js's shader
//! `shGetIrradianceAt` evaluates: three.js turns them into irradiance on a surface of
//! normal `n` itself, with the clamped-cosine factors (π, 2π/3, π/4) folded into its
//! constants ([`three_js_irradiance`] is that function). So `probe.sh.coefficients[k]
//! .fromArray(coefficients[k])` loads a probe as it is. [`ExportedProbe::irradiance_sh`]
//! has the same coefficients with those factors applied, for engines that evaluate
//! irradiance as a plain SH sum (`E(n) = Σ_k c_k Y_k(n)`).
//!
//! The probes' fourth band (shrad keeps 16 coefficients) is dropped: its clamped-cosine
//! factor is 0, so the irradiance of the 9 is that of the 16 (shrad-sh, `convolve.rs`). In
//! the dispersive default the probes carry reflected light only, as Step 2 uses them: the
//! direct light of the scene's lights on an object is computed apart; an engine that lights
//! dynamic objects from these probes adds its own direct lights (the paper's preset,
//! `--preset paper`, bakes direct light into the probes too).

use glam::Vec3;
use serde_json::{json, Value};

use crate::dispersive::inspect::ProbeState;
use crate::engine::Engine;

/// Bands of an exported probe (9 coefficients: three.js's `SphericalHarmonics3`).
pub const BANDS: usize = 3;

/// One corner probe, ready for three.js.
#[derive(Clone, Debug)]
pub struct ExportedProbe {
    /// The object it belongs to (scene index).
    pub object: usize,
    /// Corner of the object's probe box (bit 0: x, bit 1: y, bit 2: z, object frame).
    pub corner: usize,
    /// World position.
    pub position: Vec3,
    /// Valid, repaired (moved inward) or invalid (it sees too many back faces).
    pub state: ProbeState,
    /// Radiance SH, 9 RGB coefficients in three.js's order (module docs).
    pub sh: [Vec3; 9],
}

impl ExportedProbe {
    /// The same coefficients times the clamped-cosine factor of their band: irradiance SH,
    /// `E(n) = Σ_k c_k Y_k(n)`.
    pub fn irradiance_sh(&self) -> [Vec3; 9] {
        std::array::from_fn(|k| {
            let l = if k == 0 {
                0
            } else if k < 4 {
                1
            } else {
                2
            };
            self.sh[k] * shrad_sh::cosine_lobe(l)
        })
    }
}

/// The corner probes of every interior object as they stand now (captured from the current
/// radiosity: 8 cube maps per object); `None` when the solver has no per-object probes
/// (the grid, the reference).
pub fn corner_probes(engine: &Engine) -> Option<Vec<ExportedProbe>> {
    let views = crate::view_data::probes(engine)?;
    Some(
        views
            .into_iter()
            .map(|v| ExportedProbe {
                object: v.object,
                corner: v.corner,
                position: v.position,
                state: v.state,
                sh: std::array::from_fn(|k| v.sh.coeffs().get(k).copied().unwrap_or(Vec3::ZERO)),
            })
            .collect(),
    )
}

/// Irradiance on a surface of unit normal `n` from three.js-ordered radiance SH, as
/// three.js's shader `shGetIrradianceAt` (`lights_pars_begin.glsl.js`) computes it, its
/// constants as written there: what a `LightProbe` loaded with [`ExportedProbe::sh`] gives.
pub fn three_js_irradiance(sh: &[Vec3; 9], n: Vec3) -> Vec3 {
    let (x, y, z) = (n.x, n.y, n.z);
    let mut e = sh[0] * 0.886227;
    e += sh[1] * (2.0 * 0.511664 * y);
    e += sh[2] * (2.0 * 0.511664 * z);
    e += sh[3] * (2.0 * 0.511664 * x);
    e += sh[4] * (2.0 * 0.429043 * x * y);
    e += sh[5] * (2.0 * 0.429043 * y * z);
    e += sh[6] * (0.743125 * z * z - 0.247708);
    e += sh[7] * (2.0 * 0.429043 * x * z);
    e += sh[8] * (0.429043 * (x * x - y * y));
    e
}

/// [`to_json`] as indented text (what `shrad bake --probes` writes).
pub fn to_json_text(engine: &Engine, probes: &[ExportedProbe]) -> String {
    let value = to_json(engine, probes);
    // A `Value` always serialises.
    serde_json::to_string_pretty(&value).unwrap_or_else(|_| value.to_string())
}

/// The probes as the JSON `shrad bake --probes` writes (fields in `docs/python.md`, "Probes").
pub fn to_json(engine: &Engine, probes: &[ExportedProbe]) -> Value {
    let names = &engine.world().scene.objects;
    let list: Vec<Value> = probes
        .iter()
        .map(|p| {
            json!({
                "object": names[p.object].name,
                "object_index": p.object,
                "corner": p.corner,
                "position": p.position.to_array(),
                "state": p.state,
                "coefficients": p.sh.iter().map(|c| c.to_array()).collect::<Vec<_>>(),
                "irradiance_coefficients":
                    p.irradiance_sh().iter().map(|c| c.to_array()).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "format": "shrad-probes",
        "version": 1,
        "source": engine.world().scene.source,
        "time": engine.world().time,
        "solver": engine.solver_choice().name(),
        "bands": BANDS,
        "order": ["0,0", "1,-1", "1,0", "1,1", "2,-2", "2,-1", "2,0", "2,1", "2,2"],
        "coefficients_are": "radiance SH (real orthonormal basis, three.js LightProbe.sh order and convention: the shader applies the cosine factors)",
        "irradiance_coefficients_are": "the coefficients times pi, 2pi/3, pi/4 by band: E(n) = sum c_k Y_k(n)",
        "probes": list,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::SolverChoice;
    use crate::PatchSizing;

    /// 26 directions: the cube's faces, edges and corners.
    fn normals() -> Vec<Vec3> {
        let mut out = Vec::new();
        for x in -1..=1 {
            for y in -1..=1 {
                for z in -1..=1 {
                    if (x, y, z) != (0, 0, 0) {
                        out.push(Vec3::new(x as f32, y as f32, z as f32).normalize());
                    }
                }
            }
        }
        out
    }

    #[test]
    fn three_js_evaluating_the_exported_probes_gives_the_engine_s_irradiance_within_2_percent() {
        for preset in ["default", "paper"] {
            let mut engine = Engine::new(
                shrad_scene::cornell_box(),
                PatchSizing::Count(1500),
                shrad_vis::Backend::Auto,
                SolverChoice::preset("dispersive", preset).unwrap(),
            )
            .unwrap();
            engine.converge(2);
            let probes = corner_probes(&engine).unwrap();
            let views = crate::view_data::probes(&engine).unwrap();
            assert_eq!(probes.len(), 16, "2 interior objects, 8 corners each");
            let mut lit = 0;
            for (p, v) in probes.iter().zip(&views) {
                assert_eq!(
                    (p.object, p.corner, p.position),
                    (v.object, v.corner, v.position)
                );
                // The engine's irradiance at the probe: its own 16-coefficient SH.
                let want: Vec<Vec3> = normals()
                    .iter()
                    .map(|n| shrad_sh::irradiance(&v.sh, *n))
                    .collect();
                let scale = want.iter().map(|e| e.max_element()).fold(0.0f32, f32::max);
                if scale <= 0.0 {
                    continue;
                }
                lit += 1;
                for (n, w) in normals().iter().zip(&want) {
                    let got = three_js_irradiance(&p.sh, *n).max(Vec3::ZERO);
                    let irr = shrad_sh::ShRgb::from_coeffs(p.irradiance_sh().to_vec());
                    let plain = irr.eval(*n).max(Vec3::ZERO);
                    for e in [got, plain] {
                        let d = (e - *w).abs().max_element() / scale;
                        assert!(
                            d < 0.02,
                            "{preset}: probe {}/{} at {n}: {e} vs {w}",
                            p.object,
                            p.corner
                        );
                    }
                }
            }
            assert!(lit >= 8, "{preset}: only {lit} probes see any light");
            let json = to_json(&engine, &probes);
            assert_eq!(json["probes"].as_array().unwrap().len(), 16);
            assert_eq!(
                json["probes"][0]["coefficients"].as_array().unwrap().len(),
                9
            );
        }
    }

    #[test]
    fn a_probe_lit_from_above_is_brighter_facing_up_in_three_js_s_axes() {
        // Radiance 1 from the upper hemisphere (+Y) only: L00 = sqrt(pi), L1,-1 (y) =
        // sqrt(3 pi) / 2, the rest of the first 9 zero.
        let pi = std::f32::consts::PI;
        let mut sh = [Vec3::ZERO; 9];
        sh[0] = Vec3::splat(pi.sqrt());
        sh[1] = Vec3::splat((3.0 * pi).sqrt() / 2.0);
        let up = three_js_irradiance(&sh, Vec3::Y).x;
        let down = three_js_irradiance(&sh, -Vec3::Y).x;
        // Exactly: E(up) = pi; facing down, 0 (here within the 9 coefficients' ringing).
        assert!((up - pi).abs() / pi < 0.02, "{up}");
        assert!(down.abs() < 0.02 * pi, "{down}");
    }
}
