//! [`ChunkCones`]: cached rays that share an apex, grouped so that a mover's box rejects a
//! group with one cone test before any of its rays is tested (`stale.rs`).
//!
//! A group is a square tile of a cube map's texels ([`ChunkCones::tiles`]: a probe's or a
//! splat emitter's), or the rays whose directions fall in one tile of a cube around the apex
//! ([`ChunkCones::by_direction`]: a gather emitter's entries, whose order is the boundary's
//! and stays so).

use glam::Vec3;
use rayon::prelude::*;

/// The cone of directions of each chunk of rays that share an apex (a probe's
/// texels from its centre, an emitter's texels or gather entries from the emitter): a
/// mover's bounding sphere outside a chunk's cone meets none of its rays, one test for
/// the chunk's 32-64 rays. Rays that converge to or leave one point are far better bounded
/// by a cone than by a box (a row of texels spans the room, so its box meets almost every
/// mover).
#[derive(Default)]
pub(super) struct ChunkCones {
    /// Per chunk: the cone's axis and half-angle (radians; `PI` when it covers everything).
    axis: Vec<Vec3>,
    half_angle: Vec<f32>,
    /// The rays of chunk `c` are `members[starts[c]..starts[c + 1]]`.
    members: Vec<u32>,
    starts: Vec<u32>,
    /// Chunks in groups that lie together (a cube face's tiles, a block of 4 x 4 tiles of
    /// directions): group `g` is chunks `group_starts[g]..group_starts[g + 1]`, with the cone
    /// of all their rays, tested first ([`ChunkCones::meeting`]).
    group_starts: Vec<u32>,
    group_axis: Vec<Vec3>,
    group_half_angle: Vec<f32>,
}

/// A mover's bounding sphere seen from an apex: direction and angular radius, or `None`
/// when the apex is inside it (every chunk may meet it).
pub(super) type SeenSphere = Option<(Vec3, f32)>;

impl ChunkCones {
    /// The cones of `n` directions (`dir(i)`, any length) grouped by the tile of a cube
    /// around the apex they point into, about [`DIRECTION_TILE`] rays a tile on average when
    /// the directions cover the sphere, in any order: each group is as narrow as the tile
    /// whatever the rays' order. Runs of 64 boundary patches in the boundary's order made
    /// cones so wide that a small box dragged near an object passed a quarter of them: the
    /// stale test of a gather emitter's 30k entries tested 8k segments (the 40k objects-8
    /// room: 0.6-1.4 ms a frame for the object updated beside the mover).
    pub(super) fn by_direction(n: usize, dir: impl Fn(usize) -> Vec3 + Sync) -> Self {
        let side = ((n as f64 / (6 * DIRECTION_TILE) as f64).sqrt().ceil() as usize).clamp(1, 64);
        let side = side.next_multiple_of(BLOCK);
        let tile: Vec<u32> = (0..n)
            .into_par_iter()
            .map(|i| cube_tile(dir(i), side))
            .collect();
        // A counting sort by tile: members ascend within a tile; empty tiles are dropped, and
        // a group is the tiles of one block.
        let mut count = vec![0u32; 6 * side * side];
        tile.iter().for_each(|&t| count[t as usize] += 1);
        let (mut starts, mut group_starts) = (vec![0u32], Vec::new());
        // Where tile `t`'s next member goes in `members`.
        let mut at = vec![0u32; count.len()];
        let mut block = usize::MAX;
        for (t, &c) in count.iter().enumerate().filter(|(_, &c)| c > 0) {
            if t / (BLOCK * BLOCK) != block {
                block = t / (BLOCK * BLOCK);
                group_starts.push(starts.len() as u32 - 1);
            }
            let start = *starts.last().unwrap_or(&0);
            at[t] = start;
            starts.push(start + c);
        }
        group_starts.push(starts.len() as u32 - 1);
        let mut members = vec![0u32; n];
        for (i, &t) in tile.iter().enumerate() {
            members[at[t as usize] as usize] = i as u32;
            at[t as usize] += 1;
        }
        ChunkCones::of_groups(members, (starts, group_starts), dir)
    }

    /// The cones of a cube map's texels in square tiles of 8 x 8 per face: a tile's cone is
    /// about an eighth of a face wide, where 64 consecutive texels (two rows) span the
    /// face, so a small mover meets far fewer chunks.
    pub(super) fn tiles(cube: &shrad_sh::CubeMap) -> Self {
        const SIDE: usize = 8;
        let res = cube.res();
        let (mut members, mut starts, mut group_starts) = (Vec::new(), vec![0u32], Vec::new());
        for face in shrad_sh::CubeFace::ALL {
            group_starts.push(starts.len() as u32 - 1);
            for row0 in (0..res).step_by(SIDE) {
                for col0 in (0..res).step_by(SIDE) {
                    for row in row0..(row0 + SIDE).min(res) {
                        for col in col0..(col0 + SIDE).min(res) {
                            members.push(cube.texel_index(face, row, col) as u32);
                        }
                    }
                    starts.push(members.len() as u32);
                }
            }
        }
        group_starts.push(starts.len() as u32 - 1);
        ChunkCones::of_groups(members, (starts, group_starts), |t| cube.directions[t])
    }

    /// The cones of the chunks `members[starts[c]..starts[c + 1]]` of rays, ray `i` along
    /// `dir(i)`, and of the groups of chunks `group_starts[g]..group_starts[g + 1]`.
    fn of_groups(
        members: Vec<u32>,
        (starts, group_starts): (Vec<u32>, Vec<u32>),
        dir: impl Fn(usize) -> Vec3 + Sync,
    ) -> Self {
        let cones =
            |bounds: &[u32], rays_from: &(dyn Fn(u32) -> u32 + Sync)| -> (Vec<Vec3>, Vec<f32>) {
                (0..bounds.len().saturating_sub(1))
                    .into_par_iter()
                    .map(|c| {
                        let (lo, hi) = (rays_from(bounds[c]), rays_from(bounds[c + 1]));
                        let rays = &members[lo as usize..hi as usize];
                        cone_of(rays.iter().map(|&i| dir(i as usize)))
                    })
                    .unzip()
            };
        let (axis, half_angle) = cones(&starts, &|c| c);
        let (group_axis, group_half_angle) = cones(&group_starts, &|c| starts[c as usize]);
        ChunkCones {
            axis,
            half_angle,
            members,
            starts,
            group_starts,
            group_axis,
            group_half_angle,
        }
    }

    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        let cones = (self.axis.len() + self.group_axis.len()) * 16;
        cones + (self.members.len() + self.starts.len() + self.group_starts.len()) * 4
    }

    /// The chunks whose rays may meet one of the `seen` spheres: a group's cone first, then
    /// its chunks' (a small mover seen from an emitter meets one group or two of a hundred).
    pub(super) fn meeting<'a>(
        &'a self,
        seen: &'a [SeenSphere],
    ) -> impl Iterator<Item = usize> + 'a {
        (0..self.group_axis.len())
            .filter(move |&g| cone_meets(self.group_axis[g], self.group_half_angle[g], seen))
            .flat_map(move |g| {
                let chunks = self.group_starts[g] as usize..self.group_starts[g + 1] as usize;
                chunks.filter(move |&c| self.may_meet(c, seen))
            })
    }

    /// Number of chunks.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.axis.len()
    }

    /// The ray indices of chunk `c`.
    pub(super) fn chunk(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let rays = &self.members[self.starts[c] as usize..self.starts[c + 1] as usize];
        rays.iter().map(|&t| t as usize)
    }

    /// `spheres` (centre, radius) as seen from `apex`.
    pub(super) fn seen_from(apex: Vec3, spheres: &[(Vec3, f32)]) -> Vec<SeenSphere> {
        spheres
            .iter()
            .map(|&(c, r)| {
                let v = c - apex;
                let d = v.length();
                (d > r).then(|| (v / d, (r / d).clamp(0.0, 1.0).asin()))
            })
            .collect()
    }

    /// Whether a ray of chunk `c` may meet one of the `seen` spheres.
    pub(super) fn may_meet(&self, c: usize, seen: &[SeenSphere]) -> bool {
        cone_meets(self.axis[c], self.half_angle[c], seen)
    }
}

/// Whether a ray in the cone (`axis`, `half` angle) may meet one of the `seen` spheres.
fn cone_meets(axis: Vec3, half: f32, seen: &[SeenSphere]) -> bool {
    seen.iter().any(|s| match *s {
        None => true,
        Some((u, alpha)) => {
            let reach = half + alpha;
            reach >= std::f32::consts::PI || u.dot(axis) >= reach.cos()
        }
    })
}

/// Rays a tile of [`ChunkCones::by_direction`] holds on average.
pub(super) const DIRECTION_TILE: usize = 32;

/// Tiles of [`ChunkCones::by_direction`] a group's side (a group is a block of 4 x 4).
const BLOCK: usize = 4;

/// The tile of direction `d` on a cube of `side` x `side` tiles a face (`side` a multiple
/// of [`BLOCK`]): the face of its largest component, then where it meets that face, numbered
/// block by block so that a block's tiles are consecutive (a zero direction: tile 0).
fn cube_tile(d: Vec3, side: usize) -> u32 {
    let a = d.abs();
    let (axis, u, v) = if a.x >= a.y && a.x >= a.z {
        (0, d.y, d.z)
    } else if a.y >= a.z {
        (1, d.z, d.x)
    } else {
        (2, d.x, d.y)
    };
    let major = a[axis];
    if major.is_nan() || major <= 0.0 {
        return 0;
    }
    let face = 2 * axis + usize::from(d[axis] < 0.0);
    let cell = |x: f32| (((x / major + 1.0) * 0.5 * side as f32) as usize).min(side - 1);
    let (cu, cv) = (cell(u), cell(v));
    let block = (cu / BLOCK) * (side / BLOCK) + cv / BLOCK;
    let within = (cu % BLOCK) * BLOCK + cv % BLOCK;
    (face * side * side + block * BLOCK * BLOCK + within) as u32
}

/// The cone (axis, half-angle) of some directions (any length).
fn cone_of(dirs: impl Iterator<Item = Vec3> + Clone) -> (Vec3, f32) {
    let axis = dirs
        .clone()
        .map(|d| d.normalize_or_zero())
        .sum::<Vec3>()
        .normalize_or_zero();
    if axis == Vec3::ZERO {
        return (Vec3::Z, std::f32::consts::PI);
    }
    let min_cos = dirs
        .map(|d| axis.dot(d.normalize_or_zero()))
        .fold(1f32, f32::min);
    // A little slack against rounding.
    (axis, min_cos.clamp(-1.0, 1.0).acos() + 1e-4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shrad_scene::Aabb;

    /// A chunk's cone never rejects a sphere that one of its rays meets (random directions
    /// and spheres), and it does reject spheres well away from every ray.
    #[test]
    fn chunk_cones_reject_only_what_no_ray_meets() {
        let mut rnd = crate::sampling::test_rng(0x2545f491);
        // Square tiles (12^2 faces: tiles of 8 and of 4 texels) and tiles of directions.
        let camera = crate::probes::ProbeCamera::new(12, 2);
        let dirs = &camera.cube.directions;
        let n = dirs.len();
        // By direction, in an order unrelated to it (every 7th texel), and some far from
        // the apex.
        let scrambled: Vec<Vec3> = (0..n)
            .map(|t| dirs[t * 7 % n] * (1.0 + (t % 5) as f32))
            .collect();
        let kinds = [
            ChunkCones::tiles(&camera.cube),
            ChunkCones::by_direction(n, |t| scrambled[t]),
        ];
        let dirs_of = [dirs, &scrambled];
        for cones in &kinds {
            let mut every: Vec<usize> = (0..cones.len()).flat_map(|c| cones.chunk(c)).collect();
            every.sort_unstable();
            assert_eq!(
                every,
                (0..n).collect::<Vec<_>>(),
                "the tiles are not a partition"
            );
        }
        let apex = Vec3::new(0.3, -0.2, 0.1);
        let mut rejected = [0; 2];
        for _ in 0..2000 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
            let r = 0.05 + 0.5 * rnd();
            let b = Aabb::new(c - Vec3::splat(r), c + Vec3::splat(r));
            let seen = ChunkCones::seen_from(apex, &[b.bounding_sphere()]);
            for ((cones, dirs), rejected) in kinds.iter().zip(dirs_of).zip(&mut rejected) {
                for chunk in 0..cones.len() {
                    let any_ray = cones
                        .chunk(chunk)
                        .any(|t| b.meets_ray_within(apex, dirs[t], f32::INFINITY));
                    let may = cones.may_meet(chunk, &seen);
                    assert!(may || !any_ray, "a cone rejected a box its rays meet");
                    *rejected += usize::from(!may);
                }
                // The groups' cones first: some of the chunks every chunk's cone alone
                // passes (a group's cone is tighter than the union of its chunks' cones),
                // and every chunk one of whose rays meets the box.
                let meeting: Vec<usize> = cones.meeting(&seen).collect();
                for chunk in 0..cones.len() {
                    let any_ray = (cones.chunk(chunk))
                        .any(|t| b.meets_ray_within(apex, dirs[t], f32::INFINITY));
                    let passed = meeting.contains(&chunk);
                    assert!(
                        passed || !any_ray,
                        "a group's cone rejected a box its rays meet"
                    );
                    assert!(!passed || cones.may_meet(chunk, &seen));
                }
            }
        }
        assert!(
            rejected.iter().all(|&r| r > 2000),
            "the cones reject almost nothing: {rejected:?}"
        );
    }
}
