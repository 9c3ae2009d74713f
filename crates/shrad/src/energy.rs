//! The energy meter (spec 2 and 4.6) shared by every solver: flux emitted, received,
//! absorbed and reflected over *all* patches — the lights included, which absorb what falls
//! on them — and the bound no steady state may exceed.
//!
//! With every `rho < 1`, a steady state reflects at most `emitted * max rho / (1 - max rho)`
//! (the reflected flux `R = sum rho E A <= max rho * sum E A`, and `sum E A` is at most what
//! leaves the surfaces, `emitted + R`). A solver state beyond that bound is divergence, not
//! light; see [`Divergence`] for what the solvers report and do about it (they damp the
//! state back to the bound).
//!
//! A solver that does not compute the irradiance of some patches (the dispersive solver's
//! lights, which it keeps at their emission) measures it with an [`IncidentMeter`]:
//! cosine-weighted rays from those patches, traced once (again when something moves), whose
//! mean seen radiosity is the irradiance (`E = pi * mean L` under cosine sampling).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;
use shrad_vis::Hit;

use crate::segments::{self, Offsets, LANES};
use crate::World;

/// Flux bookkeeping of one state (W, i.e. radiometric units x area; RGB averaged).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EnergyBalance {
    /// Emitted by lights: `sum M A` of the light surfaces, plus what the punctual lights
    /// deliver to the patches (a point light's flux that reaches no patch never enters the
    /// scene).
    pub emitted: f64,
    /// Of `emitted`, the punctual lights' part: `sum E_punctual A`.
    pub punctual: f64,
    /// Arriving on all patches, lights included: `sum E A`.
    pub received: f64,
    /// Absorbed by all patches, lights included: `sum (1 - rho) E A` (`rho` taken as 0 for
    /// lights a solver keeps at their emission). In a closed scene this equals `emitted`.
    pub absorbed: f64,
    /// Reflected: `sum rho E A`.
    pub reflected: f64,
    /// The most a steady state can reflect: `emitted * max rho / (1 - max rho)`.
    pub reflected_bound: f64,
    /// Sent to the boundary by the dispersive solver's object emitters this frame.
    pub object_emitters: f64,
}

impl EnergyBalance {
    /// `absorbed / emitted` (1 in a closed scene at steady state; 0 without light).
    pub fn closure(&self) -> f64 {
        if self.emitted > 0.0 {
            self.absorbed / self.emitted
        } else {
            0.0
        }
    }
    /// `reflected / reflected_bound` (above 1: the state diverged).
    pub fn bound_ratio(&self) -> f64 {
        if self.reflected_bound > 0.0 {
            self.reflected / self.reflected_bound
        } else if self.reflected > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

fn avg(v: Vec3) -> f64 {
    v.element_sum() as f64 / 3.0
}

/// Flux that leaves the scene through its openings (W, RGB averaged): what each patch sends
/// out, `B A`, times the open part of its cosine-weighted hemisphere, measured with `rays`
/// cosine rays from points of its footprint (none blocked: open). At rest, in any scene,
/// `absorbed + escaped = emitted`; a closed scene lets nothing out.
pub fn escaped(world: &World, radiosity: &[Vec3], rays: u32) -> f64 {
    use crate::sampling::{hammersley, hash, square_to_cosine_hemisphere, unit};
    let p = &world.patches;
    let rays = rays.max(1);
    let (eps, far) = (world.eps, world.far());
    let senders: Vec<usize> = (0..p.len())
        .filter(|&i| radiosity.get(i).is_some_and(|b| b.max_element() > 0.0))
        .collect();
    let (from, to): (Vec<Vec3>, Vec<Vec3>) = senders
        .par_iter()
        .flat_map_iter(|&i| {
            let seed = hash(i as u32 ^ 0x0e5c_a9ed);
            (0..rays).map(move |j| {
                let (u, v) = hammersley(j, rays, (unit(seed), unit(hash(seed))));
                let x = p.sample_point(i, u, v);
                let d = square_to_cosine_hemisphere(unit(hash(seed ^ j)), v, p.normal[i]);
                (x + p.normal[i] * eps, x + d * far)
            })
        })
        .unzip();
    let mut blocked = vec![false; from.len()];
    world.vis.occluded(&from, &to, eps, &[], &mut blocked);
    senders
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            let open = blocked[k * rays as usize..(k + 1) * rays as usize]
                .iter()
                .filter(|b| !**b)
                .count() as f64
                / rays as f64;
            avg(radiosity[i]) * p.area[i] as f64 * open
        })
        .sum()
}

/// The bound on reflected flux for a world that emits `emitted` (light surfaces and
/// punctual lights) and whose most reflective patch reflects `max_rho` (see the module docs).
pub fn reflected_bound(emitted: f64, max_rho: f32) -> f64 {
    let max_rho = max_rho.min(0.999_999) as f64;
    emitted * max_rho / (1.0 - max_rho)
}

/// Patches a chunk of [`balance`]'s partial sums holds: a solver that knows which chunks a
/// frame changed sums only those again ([`chunk_sums`], [`balance_of`]).
pub const CHUNK: usize = 256;

/// The partial sums of one chunk of patches: [emitted, received, reflected, absorbed,
/// punctual] (W) and the largest reflectance.
pub type Sums = ([f64; 5], f32);

/// The balance of a state with irradiance `irradiance(i)` on every patch `i`, of which
/// `punctual` (per patch, or empty) came straight from the punctual lights: that part is
/// input, counted in `emitted` and in the bound. `reflects(i)`: does patch `i` reflect in
/// this solver (else all that reaches it is absorbed)?
///
/// One parallel pass over the patches (every frame of every solver meters its state), the
/// irradiance taken where it is, not gathered into a vector first.
pub fn balance(
    world: &World,
    irradiance: impl Fn(usize) -> Vec3 + Sync,
    punctual: &[Vec3],
    reflects: impl Fn(usize) -> bool + Sync,
) -> EnergyBalance {
    let chunks: Vec<Sums> = (0..world.patches.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| chunk_sums(world, &irradiance, punctual, &reflects, c))
        .collect();
    balance_of(&chunks)
}

/// [`balance`]'s sums over chunk `c` (patches `c * CHUNK ..`).
pub fn chunk_sums(
    world: &World,
    irradiance: &impl Fn(usize) -> Vec3,
    punctual: &[Vec3],
    reflects: &impl Fn(usize) -> bool,
    c: usize,
) -> Sums {
    let p = &world.patches;
    // Sums of the channels' sums, averaged once at the end (a division a sum a patch was
    // most of the meter's time in a moving frame).
    let mut sums = [0.0; 5];
    let mut max_rho = 0.0f32;
    let sum = |v: Vec3| v.element_sum() as f64;
    for i in c * CHUNK..((c + 1) * CHUNK).min(p.len()) {
        let a = p.area[i] as f64;
        let irr = irradiance(i);
        let rho = world.reflectance[i];
        let (reflected, absorbed) = if reflects(i) {
            (sum(rho * irr) * a, sum((Vec3::ONE - rho) * irr) * a)
        } else {
            (0.0, sum(irr) * a)
        };
        sums[0] += sum(world.exitance[i]) * a;
        sums[1] += sum(irr) * a;
        sums[2] += reflected;
        sums[3] += absorbed;
        sums[4] += punctual.get(i).map_or(0.0, |e| sum(*e) * a);
        max_rho = max_rho.max(rho.max_element());
    }
    (sums.map(|s| s / 3.0), max_rho)
}

/// The balance from every chunk's [`Sums`], in order.
pub fn balance_of(chunks: &[Sums]) -> EnergyBalance {
    let ([emitted, received, reflected, absorbed, punctual_flux], max_rho) =
        chunks.iter().fold(([0.0; 5], 0.0f32), |(a, ra), (b, rb)| {
            (std::array::from_fn(|k| a[k] + b[k]), ra.max(*rb))
        });
    let emitted = punctual_flux + emitted;
    EnergyBalance {
        reflected_bound: reflected_bound(emitted, max_rho),
        emitted,
        punctual: punctual_flux,
        received,
        reflected,
        absorbed,
        ..Default::default()
    }
}

/// Irradiance of a few patches measured by cosine-weighted rays (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct IncidentMeter {
    patches: Vec<u32>,
    rays: usize,
    /// The patch each ray sees (`u32::MAX`: nothing, or a single-sided back).
    seen: Vec<u32>,
    /// Where each ray starts, and where its segment ends (its hit, or far beyond the scene
    /// for a miss): what a mover must meet to change it.
    from: Vec<Vec3>,
    end: Vec<Vec3>,
    /// The object each ray hit (`u32::MAX`: none).
    hit_object: Vec<u32>,
}

impl IncidentMeter {
    /// A meter on `patches` with `rays` rays each, traced now.
    pub fn new(world: &World, patches: Vec<u32>, rays: usize) -> IncidentMeter {
        let mut m = IncidentMeter {
            patches,
            rays: rays.max(1),
            seen: Vec::new(),
            from: Vec::new(),
            end: Vec::new(),
            hit_object: Vec::new(),
        };
        m.retrace(world);
        m
    }

    /// Trace every ray again.
    pub fn retrace(&mut self, world: &World) {
        let n = self.patches.len() * self.rays;
        self.seen = vec![u32::MAX; n];
        self.from = vec![Vec3::ZERO; n];
        self.end = vec![Vec3::ZERO; n];
        self.hit_object = vec![u32::MAX; n];
        let all: Vec<usize> = (0..self.patches.len()).collect();
        self.trace_patches(world, &all);
    }

    /// Trace again only the rays that objects `moved` (now at their world `boxes`, indexed
    /// by object) may have changed: those that hit one of them, and those whose segment
    /// meets one's box now (a place a mover left cannot matter otherwise: had it been on the
    /// segment, the ray would have hit it). The result is what [`IncidentMeter::retrace`]
    /// gives; a light patch that moved itself is traced again whole. Returns the rays traced.
    pub fn update(&mut self, world: &World, moved: &[usize], boxes: &[Aabb]) -> usize {
        if moved.is_empty() || self.patches.is_empty() {
            return 0;
        }
        let p = &world.patches;
        let padded: Vec<Aabb> = moved
            .iter()
            .map(|&o| boxes[o])
            .filter(|b| !b.is_empty())
            .map(|b| b.padded(Vec3::splat(4.0 * world.eps + 1e-5 * b.diagonal())))
            .collect();
        let rays = self.rays;
        // A metered patch's rays start at points of the patch. Moved to its centre, each
        // segment stays within the patch's radius of where it was, so the boxes grown by
        // that radius meet every segment that meets them: the patch's segments are then
        // tested from one point, 64 at a time (a ray traced again for nothing is never
        // wrong). Rays that hit a mover are traced again too: it may have left them.
        let stale_rays = |k: usize| -> Vec<usize> {
            let i = self.patches[k] as usize;
            let grow = Vec3::splat(p.radius(i) + 2.0 * world.eps);
            let boxes: Vec<Aabb> = padded.iter().map(|b| b.padded(grow)).collect();
            let mut which = Vec::new();
            for j0 in (0..rays).step_by(LANES) {
                let n = (rays - j0).min(LANES);
                let first = k * rays + j0;
                let mut d: Offsets = [[0.0; LANES]; 3];
                for j in 0..n {
                    let offset = self.end[first + j] - self.from[first + j];
                    (0..3).for_each(|a| d[a][j] = offset[a]);
                }
                let mut mask = segments::meeting(p.centre[i], &d, n, &boxes);
                for j in 0..n {
                    let h = self.hit_object[first + j];
                    if h != u32::MAX && moved.contains(&(h as usize)) {
                        mask |= 1 << j;
                    }
                }
                while mask != 0 {
                    which.push(j0 + mask.trailing_zeros() as usize);
                    mask &= mask - 1;
                }
            }
            which
        };
        // Per metered patch, the rays to trace again (all of them when the patch moved).
        let stale: Vec<(usize, Vec<usize>)> = (0..self.patches.len())
            .into_par_iter()
            .filter_map(|k| {
                let i = self.patches[k] as usize;
                if moved.contains(&(p.object[i] as usize)) {
                    return Some((k, (0..rays).collect()));
                }
                let which = stale_rays(k);
                (!which.is_empty()).then_some((k, which))
            })
            .collect();
        self.trace_rays(world, &stale)
    }

    /// Trace every ray of the metered patches `ks`.
    fn trace_patches(&mut self, world: &World, ks: &[usize]) {
        let all: Vec<(usize, Vec<usize>)> =
            ks.iter().map(|&k| (k, (0..self.rays).collect())).collect();
        self.trace_rays(world, &all);
    }

    /// Trace rays `which` of each metered patch `k` (the rays [`patch_rays`] gives, bit for
    /// bit, so a ray traced again alone equals the ray traced with all the others). Returns
    /// the rays traced.
    ///
    /// [`patch_rays`]: crate::form_factors::patch_rays
    fn trace_rays(&mut self, world: &World, stale: &[(usize, Vec<usize>)]) -> usize {
        let n: usize = stale.iter().map(|(_, w)| w.len()).sum();
        if n == 0 {
            return 0;
        }
        let rays = self.rays;
        let mut origins = vec![Vec3::ZERO; n];
        let mut dirs = vec![Vec3::ZERO; n];
        let mut at = 0;
        let mut slices = Vec::with_capacity(stale.len());
        let (mut o_rest, mut d_rest) = (&mut origins[..], &mut dirs[..]);
        for (k, which) in stale {
            let (o, or) = o_rest.split_at_mut(which.len());
            let (d, dr) = d_rest.split_at_mut(which.len());
            slices.push((*k, which, o, d));
            (o_rest, d_rest) = (or, dr);
            at += which.len();
        }
        debug_assert_eq!(at, n);
        slices.into_par_iter().for_each(|(k, which, o, d)| {
            crate::form_factors::some_patch_rays(world, self.patches[k] as usize, rays, which, o, d)
        });
        let mut hits = vec![Hit::MISS; n];
        world.vis.closest(&origins, &dirs, 0.0, &[], &mut hits);
        // A miss reaches any place a mover may go.
        let far = 1e30;
        let mut q = 0;
        for (k, which) in stale {
            for &j in which {
                let r = k * rays + j;
                let h = &hits[q];
                self.seen[r] = world.seen_patch(h).map_or(u32::MAX, |j| j as u32);
                self.from[r] = origins[q];
                let t = if h.is_hit() { h.t } else { far };
                self.end[r] = origins[q] + dirs[q] * t;
                self.hit_object[r] = if h.is_hit() { h.object } else { u32::MAX };
                q += 1;
            }
        }
        n
    }

    /// The measured irradiance of the metered patches: (patch, irradiance), ascending by
    /// patch.
    pub fn measure(&self, radiosity: &[Vec3]) -> Vec<(u32, Vec3)> {
        let mut out: Vec<(u32, Vec3)> = (self.patches.par_iter().enumerate())
            .map(|(k, &i)| {
                let seen = &self.seen[k * self.rays..(k + 1) * self.rays];
                let sum: Vec3 = seen
                    .iter()
                    .filter(|&&j| j != u32::MAX)
                    .map(|&j| radiosity[j as usize])
                    .sum();
                (i, sum / self.rays as f32)
            })
            .collect();
        out.sort_unstable_by_key(|&(i, _)| i);
        out
    }
}

/// What a solver does when its state breaks the energy bound or holds a non-finite value:
/// the state is not published as it is; the offending part is damped or reset and the
/// frame's statistics say what diverged.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Divergence {
    /// What diverged and what was done, for a person.
    pub message: String,
    /// Non-finite values replaced by 0 this frame.
    pub non_finite: usize,
}

/// Tolerance on the bound: approximate solvers may overshoot the exact steady state a little
/// (SH ringing, splat aliasing); a state 5 % beyond the bound is divergence.
pub const BOUND_TOLERANCE: f64 = 1.05;

/// Replace every non-finite component of `values` by 0; returns how many values had one.
pub fn reset_non_finite(values: &mut [Vec3]) -> usize {
    // A parallel read first: a state is finite on every frame but a broken one.
    if values.par_iter().all(|v| v.is_finite()) {
        return 0;
    }
    values
        .par_iter_mut()
        .filter(|v| !v.is_finite())
        .map(|v| *v = Vec3::select(v.is_finite_mask(), *v, Vec3::ZERO))
        .count()
}

/// Checks a state against the bound: `Some(scale)` by which the reflected part must be
/// multiplied to come back within it, or `None` when it is within.
///
/// `held` is the reflected flux of the solver's last frame that was within its bound
/// ([`LightHeld`]; `None` before its first). When a light dims or goes out, a solver that
/// updates over several frames (every solver but the reference) still holds light from
/// before, more than the new light can sustain, and that light drains over the next frames:
/// no divergence. So the limit is the larger of the bound and what was held then (with the
/// same tolerance): a state may drain from there, but not grow past it.
pub fn over_bound(balance: &EnergyBalance, held: Option<f64>) -> Option<f64> {
    if !balance.reflected.is_finite() {
        return Some(0.0);
    }
    let level = balance
        .reflected_bound
        .max(held.filter(|r| r.is_finite()).unwrap_or(0.0));
    (balance.reflected > level * BOUND_TOLERANCE && balance.reflected > 0.0)
        .then(|| level / balance.reflected)
}

/// The reflected flux of a solver's last frame within its bound (see [`over_bound`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct LightHeld(Option<f64>);

impl LightHeld {
    /// What [`over_bound`] takes.
    pub fn get(self) -> Option<f64> {
        self.0
    }

    /// Note a published frame's balance: kept when it was within its own bound.
    pub fn note(&mut self, balance: &EnergyBalance) {
        if balance.reflected.is_finite()
            && balance.reflected <= balance.reflected_bound * BOUND_TOLERANCE
        {
            self.0 = Some(balance.reflected);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After moves (a block slid, teleported, the light itself moved), the meter updated
    /// incrementally sees what a meter traced afresh sees, ray by ray.
    #[test]
    fn meter_updated_after_moves_equals_a_fresh_one() {
        use glam::Affine3A;
        let scene = shrad_scene::cornell_box();
        let mut world = World::new(
            scene.clone(),
            crate::PatchSizing::Count(2000),
            shrad_vis::Backend::Auto,
        )
        .unwrap();
        let find = |name: &str| scene.objects.iter().position(|o| o.name == name).unwrap();
        let lights: Vec<u32> = (0..world.patches.len() as u32)
            .filter(|&i| world.patches.role(i as usize) == shrad_scene::Role::Light)
            .collect();
        assert!(!lights.is_empty());
        let mut meter = IncidentMeter::new(&world, lights.clone(), 16);
        let moves = [
            ("tall_block", Vec3::new(0.0, 300.0, 0.0)),
            ("tall_block", Vec3::new(0.0, 120.0, 0.0)),
            ("short_block", Vec3::new(-250.0, 0.0, 150.0)),
            ("light", Vec3::new(30.0, -5.0, 20.0)),
            ("tall_block", Vec3::ZERO),
        ];
        let mut traced = 0;
        for (name, offset) in moves {
            let o = find(name);
            let m = Affine3A::from_translation(offset) * scene.objects[o].world_from_object;
            world.move_object(o, m).unwrap();
            let boxes: Vec<shrad_scene::Aabb> = (0..world.scene.objects.len())
                .map(|o| {
                    world.patches.shapes[o]
                        .bounds()
                        .unwrap()
                        .transformed(world.patches.world_from_local[o])
                })
                .collect();
            traced += meter.update(&world, &[o], &boxes);
            let fresh = IncidentMeter::new(&world, lights.clone(), 16);
            assert_eq!(meter.seen, fresh.seen, "after moving {name}");
        }
        assert!(
            traced < 5 * lights.len() * 16,
            "every move traced everything again: {traced} rays"
        );
    }

    #[test]
    fn bound_and_closure() {
        let b = EnergyBalance {
            emitted: 10.0,
            absorbed: 9.9,
            reflected: 50.0,
            reflected_bound: 40.0,
            ..Default::default()
        };
        assert!((b.closure() - 0.99).abs() < 1e-12);
        assert!((over_bound(&b, None).unwrap() - 0.8).abs() < 1e-12);
        let ok = EnergyBalance {
            reflected: 41.0,
            ..b
        };
        assert_eq!(over_bound(&ok, None), None);
        // The light dimmed: 50 was held before, now 45 against a bound of 4. Draining is
        // no divergence; growing past what was held is, and is brought back to it.
        let dimmed = EnergyBalance {
            reflected: 45.0,
            reflected_bound: 4.0,
            ..b
        };
        assert_eq!(over_bound(&dimmed, Some(50.0)), None);
        assert!((over_bound(&dimmed, Some(40.0)).unwrap() - 40.0 / 45.0).abs() < 1e-12);
        assert!((over_bound(&dimmed, None).unwrap() - 4.0 / 45.0).abs() < 1e-12);
        let nan = EnergyBalance {
            reflected: f64::NAN,
            ..b
        };
        assert_eq!(over_bound(&nan, Some(50.0)), Some(0.0));
        // What is held is the last frame within its own bound.
        let mut held = LightHeld::default();
        held.note(&ok);
        held.note(&dimmed);
        assert_eq!(held.get(), Some(41.0));
        let mut v = vec![Vec3::ONE, Vec3::new(f32::NAN, 1.0, f32::INFINITY)];
        assert_eq!(reset_non_finite(&mut v), 1);
        assert_eq!(v[1], Vec3::new(0.0, 1.0, 0.0));
    }
}
