//! Step 4 of the frame (paper 2.3.5, "绘制"): each boundary patch's radiosity is its own
//! exitance plus what it reflects of the light it received, `B = M + ρ (E_direct + Σ_o E_o +
//! E_walls)`. The wall term is beyond the paper: boundary-to-boundary light through sparse
//! precomputed form factors among the boundary patches, one Jacobi sweep per frame over a
//! moving window of rows, with the rows re-traced where a mover passed.
//!
//! Then the frame's energy meter (`crate::energy`: emitted, absorbed, reflected against the
//! bound the lights can sustain) and the guard that never publishes a diverged state.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Role;

use super::setup::receives_as_boundary;
use super::{Dispersive, Divergence, EnergyBalance, FrameStats};
use crate::energy::CHUNK;
use crate::World;

/// Wall-exchange rows gathered per frame (Step 4's Jacobi window): at most this many, so a
/// frame's cost does not grow with the boundary beyond it (the 77k room sweeps all its rows
/// every frame, a 1M-patch room in 13 frames; a window of 32k rows made the 77k room's
/// same-frames error 4.6 % instead of 4.4 %). Re-tracing rows where a mover passed is
/// bounded apart, by [`super::WALL_RETRACE_SHARE`] and `WALL_RETRACE_MAX` (`wall_rows`).
pub const WALL_ROWS_PER_FRAME: usize = 1 << 16;

/// Wall-exchange rows gathered in a frame where an object moved: a moving frame must cost
/// what moved, and the walls' exchange among themselves changes little between two frames
/// of a drag (the mover's own light on the walls is Step 3's, every frame). The 77k room's
/// 64k rows are then swept in 64 frames while it moves, and whole again once it rests.
/// The error of the last moving frame hardly depends on it: 4.33 % with 16k rows a frame,
/// 4.34 % with 8k (0.9 ms less); then, at 20 frames of the bench's motion, 3.603 / 3.554 /
/// 3.599 % with 4k / 1k / 256 rows, and after a steady drag of a fifth of the room's width
/// over 32 frames 4.484 / 4.444 / 4.477 % (objects-8 and -128 rooms: the same to 0.006):
/// docs/results.md §5.
pub const WALL_ROWS_WHILE_MOVING: usize = 1 << 10;

/// Wall-exchange rows gathered in a frame where the walls doze (`sleep.rs`: the objects
/// settle after a mover stopped, and the light the rows read changed by less than the sleep
/// tolerance since their last whole window).
pub const WALL_ROWS_DOZING: usize = 1 << 12;

impl Dispersive {
    /// The energy meter, and the guard that never publishes a diverged state: fills
    /// `stats.energy` (keeping the Step 3 flux already in it) and `stats.diverged`.
    pub(super) fn meter_and_guard(&mut self, world: &World, stats: &mut FrameStats) {
        // The meter's rays a mover may have changed were traced again beside Step 1
        // (`Dispersive::direct_beside_first_object`).
        let t = std::time::Instant::now();
        stats.energy = EnergyBalance {
            object_emitters: stats.energy.object_emitters,
            ..self.energy(world)
        };
        super::tr("  energy", t);
        let earlier = (!self.step_warnings.is_empty()).then(|| Divergence {
            message: std::mem::take(&mut self.step_warnings).join("; "),
            non_finite: 0,
        });
        if let Some(d) = self.guard(world, &stats.energy, earlier, &stats.objects_updated) {
            self.touched.everything();
            stats.energy = EnergyBalance {
                object_emitters: stats.energy.object_emitters,
                ..self.energy(world)
            };
            stats.diverged = Some(d);
        }
        self.light_held.note(&stats.energy);
        self.touched.clear();
    }

    /// Step 4 (paper 2.3.5): boundary radiosity from direct, object and wall light.
    ///
    /// The boundary's own exchange takes one Jacobi sweep per frame over at most
    /// [`WALL_ROWS_PER_FRAME`] rows (a window that moves round the boundary, so the cost of a
    /// frame stays bounded on large scenes: the dispersive idea applied to the walls), or
    /// `sweeps` full sweeps when the light changed (the walls then converge in that frame).
    /// Returns the relative change of the boundary's radiosity over the frame (area
    /// weighted, summed over the channels: `sum A |dB| / sum A B`), which tells the sleep
    /// of the walls and objects (`sleep.rs`).
    /// Under a budget's deadline the window is at most `window` rows (what fits). Rows the
    /// wall rows rebuilt since the last frame (a mover's re-traced rays) are gathered beside
    /// a window that misses them. The first sweep's gather may come `gathered` already
    /// ([`Dispersive::gather_walls`], beside Step 1).
    pub(super) fn assemble(
        &mut self,
        world: &World,
        (sweeps, window): (usize, Option<usize>),
        gathered: Option<WallGather>,
    ) -> f64 {
        let start = std::time::Instant::now();
        let p = &world.patches;
        let mut rows_gathered = 0;
        let (mut changed, mut total) = (0f64, 0f64);
        let mut gathered = gathered;
        for _ in 0..sweeps.max(1) {
            if self.wall_rows.is_some() {
                // A row's cost (`row_ms`, a budget's window) is measured only where Step 4
                // gathers itself (a frame without a budget may gather beside Step 1).
                let g = match gathered.take() {
                    Some(g) => g,
                    None => {
                        let g = self.gather_walls(world, sweeps, window);
                        rows_gathered += g.ks.len();
                        g
                    }
                };
                self.store_wall(&g.ks, g.wall, p);
            }
            (changed, total) = self.boundary_radiosity(world);
            if self.wall_rows.is_none() {
                break;
            }
        }
        // Lights that reflect nothing are their emission (reflective ones are boundary).
        for (o, role) in p.object_role.iter().enumerate() {
            if *role == Role::Light {
                for i in p.range(o).filter(|&i| !receives_as_boundary(world, i)) {
                    self.radiosity[i] = world.exitance[i];
                }
            }
        }
        if rows_gathered > 0 {
            self.row_ms = super::ms(start) / rows_gathered as f64;
        }
        if total > 0.0 {
            changed / total
        } else {
            0.0
        }
    }

    /// Step 4's gather of one sweep: the wall light of the rows in this frame's window (all
    /// of them with several `sweeps`, else at most [`WALL_ROWS_PER_FRAME`] and `window`) and of
    /// the rows rebuilt since the last frame that it misses, from the boundary's reflected
    /// light. It reads only boundary patches' radiosity, which nothing before Step 4's store
    /// writes, so a frame may gather before Steps 2 and 3 (`Dispersive::frame`).
    pub(super) fn gather_walls(
        &mut self,
        world: &World,
        sweeps: usize,
        window: Option<usize>,
    ) -> WallGather {
        let p = &world.patches;
        let n = self.boundary_patches.len();
        let Some(rows) = self.wall_rows.as_mut() else {
            return WallGather::default();
        };
        let rebuilt = rows.take_rebuilt();
        let rows = &*rows;
        let window = if sweeps > 1 {
            n
        } else {
            n.min(WALL_ROWS_PER_FRAME).min(window.unwrap_or(usize::MAX))
        };
        let start = self.wall_cursor % n.max(1);
        let mut ks: Vec<usize> = (0..window).map(|k| (start + k) % n).collect();
        self.wall_cursor = (start + window) % n.max(1);
        if window < n {
            ks.extend(rebuilt.iter().filter(|&&k| (k + n - start) % n >= window));
        }
        // Reflected light of every patch first when the window reads each twice or more
        // (one random read per row entry), else as each entry is read: a moving frame's
        // window of 1k rows reads 65k entries, and a pass over every patch (a fresh array
        // each frame) cost more than it, in the 40k rooms (objects-128: Step 4 0.22 ->
        // 0.18 ms on one thread) as in the 1M room. A dozing window of 4k rows reads 262k:
        // in the 77k room a pass first is cheaper (its frames without rays 0.15 ms longer
        // when each entry read two arrays).
        let (b, m) = (&self.radiosity, &world.exitance);
        let reflected: Vec<Vec3> = match window * rows.rays() >= 2 * p.len() {
            true => b.par_iter().zip(m).map(|(b, e)| *b - *e).collect(),
            false => Vec::new(),
        };
        let reflected_at = |j: usize| match reflected.is_empty() {
            true => b[j] - m[j],
            false => reflected[j],
        };
        let wall: Vec<Vec3> = ks
            .par_iter()
            .map(|&k| {
                rows.row(k)
                    .iter()
                    .map(|&(j, f)| reflected_at(j as usize) * f)
                    .sum()
            })
            .collect();
        WallGather { ks, wall }
    }

    /// Each boundary patch's radiosity from its irradiance, `B = M + ρ (E_direct + Σ E_o +
    /// E_walls)`, in the chunks of patches touched this frame (`touched.rs`: every chunk
    /// when nothing moves), in parallel, then stored. Returns the change `sum A |dB|` and the
    /// total `sum A B` over the boundary (the untouched chunks' totals as they were).
    fn boundary_radiosity(&mut self, world: &World) -> (f64, f64) {
        let p = &world.patches;
        let this = &*self;
        let boundary = &this.boundary_patches;
        let chunks: Vec<_> = (this.touched.chunks().into_par_iter())
            .map(|c| {
                let lo = boundary.partition_point(|&j| (j as usize) < c * CHUNK);
                let hi = boundary.partition_point(|&j| (j as usize) < (c + 1) * CHUNK);
                let (mut change, mut total) = (0.0, 0.0);
                let b: Vec<Vec3> = (boundary[lo..hi].iter())
                    .map(|&j| {
                        let j = j as usize;
                        // The sums are kept by taking an update's old share off and
                        // putting its new one on: where they cancel, rounding can leave
                        // -1e-11 (the bench's 129k room, paper preset, while moving).
                        let e = this.direct[j] + this.indirect[j] + this.wall[j];
                        let b = world.exitance[j] + world.reflectance[j] * e.max(Vec3::ZERO);
                        let a = p.area[j] as f64;
                        change += a * (b - this.radiosity[j]).abs().element_sum() as f64;
                        total += a * b.element_sum() as f64;
                        b
                    })
                    .collect();
                (c, lo, b, change, total)
            })
            .collect();
        let mut changed = 0.0;
        for (c, lo, b, change, total) in chunks {
            for (k, b) in (lo..).zip(b) {
                self.radiosity[self.boundary_patches[k] as usize] = b;
            }
            changed += change;
            self.boundary_chunks[c] = total;
        }
        (changed, self.boundary_chunks.iter().sum())
    }

    /// Store the wall gathers of rows `ks`: as they are, or with `wall_smoothing` each
    /// averaged over its patch's neighbourhood (area weighted, each neighbour by
    /// [`step_weight`]) from the latest gathers of the neighbours (rows outside this frame's
    /// window keep their last gather).
    fn store_wall(&mut self, ks: &[usize], wall: Vec<Vec3>, p: &crate::Patches) {
        for &k in ks {
            self.touched.patch(self.boundary_patches[k] as usize);
        }
        if !self.options.wall_smoothing {
            for (&k, w) in ks.iter().zip(wall) {
                self.wall[self.boundary_patches[k] as usize] = w;
            }
            return;
        }
        for (&k, w) in ks.iter().zip(wall) {
            self.wall_gathered[self.boundary_patches[k] as usize] = w;
        }
        let (near, gathered) = (&self.neighbours, &self.wall_gathered);
        let smoothed: Vec<Vec3> = ks
            .par_iter()
            .map(|&k| {
                let j = self.boundary_patches[k] as usize;
                let own = gathered[j].element_sum();
                let (sum, weight) = (near.of(j).iter()).fold((Vec3::ZERO, 0.0), |(s, w), &i| {
                    let g = gathered[i as usize];
                    let a = p.area[i as usize] * step_weight(own, g.element_sum());
                    (s + g * a, w + a)
                });
                match weight > 0.0 {
                    true => sum / weight,
                    false => gathered[j],
                }
            })
            .collect();
        for (&k, w) in ks.iter().zip(smoothed) {
            self.wall[self.boundary_patches[k] as usize] = w;
        }
    }

    /// Flux balance of the current state, the lights' absorption included: the sums of the
    /// chunks of patches touched this frame again (`touched.rs`), the others' as they were.
    pub(super) fn energy(&mut self, world: &World) -> EnergyBalance {
        let p = &world.patches;
        // The lights that reflect nothing are metered by rays (`IncidentMeter`), every frame.
        let metered = self.light_meter.measure(&self.radiosity);
        for &(i, _) in &metered {
            self.touched.patch(i as usize);
        }
        let irradiance = |i: usize| match p.role(i) {
            // Step 1 leaves `direct` 0 where it does not light (`direct_on_interior`).
            Role::Interior => self.probe_irradiance[i] + self.direct[i],
            Role::Light if !metered.is_empty() => metered
                .binary_search_by_key(&(i as u32), |&(j, _)| j)
                .map_or(self.direct[i] + self.indirect[i] + self.wall[i], |k| {
                    metered[k].1
                }),
            _ => self.direct[i] + self.indirect[i] + self.wall[i],
        };
        let reflects = |i: usize| p.role(i) != Role::Light || receives_as_boundary(world, i);
        let punctual = self.punctual_irradiance();
        let chunks = self.touched.chunks();
        let metered_now = chunks.len();
        let sums: Vec<(usize, crate::energy::Sums)> = (chunks.into_par_iter())
            .map(|c| {
                let s = crate::energy::chunk_sums(world, &irradiance, punctual, &reflects, c);
                (c, s)
            })
            .collect();
        for (c, s) in sums {
            self.energy_chunks[c] = s;
        }
        self.chunks_metered = metered_now;
        crate::energy::balance_of(&self.energy_chunks)
    }

    /// Reset non-finite values and damp a state that breaks the energy bound (spec 2): the
    /// reflected part of every radiosity, and every irradiance that feeds it, is scaled back
    /// to the bound. Returns what diverged, with the largest object emitter named, merged
    /// with `earlier` (what Step 3's own guard found this frame). `updated`: the objects
    /// (scene indices) updated this frame, whose shares are checked for non-finite values.
    pub(super) fn guard(
        &mut self,
        world: &World,
        balance: &EnergyBalance,
        earlier: Option<Divergence>,
        updated: &[usize],
    ) -> Option<Divergence> {
        let non_finite = self.reset_non_finite(balance, updated);
        let scale = crate::energy::over_bound(balance, self.light_held.get());
        if scale.is_none() && non_finite == 0 {
            return earlier;
        }
        let mut message = earlier.map(|d| d.message + "; ").unwrap_or_default();
        if non_finite > 0 {
            message += &format!("{non_finite} non-finite value(s) reset to 0");
        }
        if let Some(s) = scale {
            let largest = self
                .objects
                .iter()
                .map(|ob| {
                    let flux: f64 = ob
                        .to_boundary
                        .iter()
                        .map(|&(j, e)| (e * world.patches.area[j as usize]).element_sum() as f64)
                        .sum();
                    (flux / 3.0, ob.object)
                })
                .max_by(|a, b| a.0.total_cmp(&b.0));
            if non_finite > 0 {
                message += "; ";
            }
            message += &format!(
                "reflected flux {:.4e} exceeds the bound {:.4e} that the lights can sustain",
                balance.reflected, balance.reflected_bound
            );
            if let Some((flux, o)) = largest {
                message += &format!(
                    " (largest object emitter: '{}', {flux:.4e} sent to the boundary)",
                    world.scene.objects[o].name
                );
            }
            message += &format!("; reflected light damped by {s:.3}");
            let s = s as f32;
            // Direct light too (it may be what overshoots, on patches measured wrongly); it
            // is recomputed next frame rather than damped again on top of this.
            self.direct_valid = false;
            for v in [
                &mut self.direct,
                &mut self.probe_irradiance,
                &mut self.indirect,
                &mut self.wall,
                &mut self.wall_gathered,
            ] {
                v.iter_mut().for_each(|e| *e *= s);
            }
            for ob in &mut self.objects {
                ob.to_boundary.iter_mut().for_each(|(_, e)| *e *= s);
            }
            for (i, b) in self.radiosity.iter_mut().enumerate() {
                let m = world.exitance[i];
                *b = m + (*b - m) * s;
            }
        }
        Some(Divergence {
            message,
            non_finite,
        })
    }

    /// Reset the state's non-finite values to 0 (the guard's first half); returns how many.
    /// `updated`: the objects (scene indices) updated this frame, whose shares are checked.
    fn reset_non_finite(&mut self, balance: &EnergyBalance, updated: &[usize]) -> usize {
        let mut non_finite = 0;
        // The balance summed every irradiance the state is made of (direct, objects', walls',
        // probes'; radiosity is made of them): finite sums, a finite state, and no pass over
        // the six arrays.
        let sums_finite = [balance.received, balance.reflected, balance.absorbed]
            .iter()
            .all(|s| s.is_finite());
        let arrays = [
            &mut self.radiosity,
            &mut self.direct,
            &mut self.probe_irradiance,
            &mut self.indirect,
            &mut self.wall,
            &mut self.wall_gathered,
        ];
        if !sums_finite {
            non_finite += arrays
                .into_iter()
                .map(|v| crate::energy::reset_non_finite(v))
                .sum::<usize>();
        }
        if sums_finite {
            // So are the shares the objects sent the boundary this frame: each was added to
            // its patch's irradiance, which the sums hold (a pass over the updated objects'
            // shares was 0.15 ms of the 77k room's moving frame, serial).
            return non_finite;
        }
        // Only the objects updated this frame sent new light (the others were checked when
        // they were: a scene of many objects must not cost a pass over all their shares).
        for ob in self
            .objects
            .iter_mut()
            .filter(|ob| updated.contains(&ob.object))
        {
            for (_, e) in &mut ob.to_boundary {
                if !e.is_finite() {
                    *e = Vec3::ZERO;
                    non_finite += 1;
                }
            }
        }
        non_finite
    }
}

/// The wall rows Step 4 gathered ([`Dispersive::gather_walls`]): their indices among the
/// boundary's rows and the wall light of each, still to be stored.
#[derive(Default)]
pub(super) struct WallGather {
    ks: Vec<usize>,
    wall: Vec<Vec3>,
}

/// How much a neighbour whose wall light is `theirs` counts in the average of a patch whose
/// own is `own` (`wall_smoothing`): fully while the two are within a factor of 2 (the noise
/// of a few-ray row, the blotches, is +60-100 %), not at all from a factor of 4 (a step that
/// is there: the floor under a glowing quad 1 unit above it holds 5 times its neighbours').
fn step_weight(own: f32, theirs: f32) -> f32 {
    let (lo, hi) = (own.min(theirs), own.max(theirs));
    if hi <= 0.0 {
        return 1.0;
    }
    let ratio = hi / lo.max(hi * 1e-6);
    ((4.0 - ratio) / 2.0).clamp(0.0, 1.0)
}
