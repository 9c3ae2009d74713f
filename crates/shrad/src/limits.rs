//! Limits checked before anything is allocated: a patch size, patch count or image size
//! that would need more memory than the machine has is an error that says how much it would
//! need, instead of an abort inside the allocator.
//!
//! The per-item costs are measured peaks, rounded up: the 1M-patch room peaks at 1129 MiB
//! with the dispersive default (about 1.1 KiB per patch, patches + visibility + solver
//! state), and the reference solver's form-factor rows at 100k patches take 463 MiB (4.6 KiB
//! per patch). A picture keeps an origin, a direction and a hit per sample (about 64 bytes)
//! plus 12 bytes per pixel.

use crate::patches::PatchPlan;
use crate::Error;
use shrad_scene::Scene;

/// Bytes one patch costs at peak (patches, visibility, the heaviest solver), rounded up.
pub const BYTES_PER_PATCH: u64 = 5 * 1024;
/// Bytes one camera sample costs while a picture is rendered.
pub const BYTES_PER_SAMPLE: u64 = 64;
/// The longest side of a picture, in pixels, for every command and front end (beyond it a
/// picture is a mistake before it is a memory problem).
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// The most frames a sequence (a bake's files, an animation's pictures) may have: one a
/// second for a day and more, and each frame's time and statistics kept within reach.
pub const MAX_FRAMES: usize = 100_000;
/// Patch ids are `u32`, and one value marks "no patch".
pub const MAX_PATCHES: u64 = u32::MAX as u64 - 1;

/// Memory this process may still use: `MemAvailable` of `/proc/meminfo`, or 16 GiB where
/// that cannot be read.
pub fn available_bytes() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
        })
        .map_or(16 << 30, |kib| kib * 1024)
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// Refuse a patch plan that needs more memory than is available, or more patches than ids.
/// Where one object's own patch size makes most of them, the error names it and its size.
pub fn check_patches(scene: &Scene, plan: PatchPlan) -> Result<(), Error> {
    check_patches_within(scene, plan, available_bytes())
}

/// [`check_patches`] against a given budget in bytes.
pub fn check_patches_within(scene: &Scene, plan: PatchPlan, budget: u64) -> Result<(), Error> {
    let source = &scene.source;
    if !(plan.patch_size.is_finite() && plan.patch_size > 0.0) {
        return Err(Error::Invalid(format!(
            "{source}: patch size {} must be a positive number",
            plan.patch_size
        )));
    }
    let count = plan.count as u64;
    let need = count.saturating_mul(BYTES_PER_PATCH);
    if count <= MAX_PATCHES && need <= budget {
        return Ok(());
    }
    // The object whose own size makes at least half the patches is the one to change.
    let culprit = (plan.heaviest_own).filter(|own| own.count >= plan.count / 2);
    let (whose, size, fix) = match culprit {
        Some(own) => (
            format!(
                "object {} '{}': its own patch_size",
                own.object, scene.objects[own.object].name
            ),
            own.patch_size,
            "give it a larger patch_size",
        ),
        None => (
            "patch size".to_string(),
            plan.patch_size,
            "use a larger --patch-size or a smaller --patches",
        ),
    };
    Err(Error::Invalid(format!(
        "{source}: {whose} {size:.3e} would make {} patches, needing about {} of memory \
         ({} available{}); {fix}",
        if plan.count == usize::MAX {
            "more than 1.8e19".to_string()
        } else {
            format!("{:.3e}", plan.count as f64)
        },
        gib(need),
        gib(budget),
        if count > MAX_PATCHES {
            ", and more than the 4.3e9 patch ids"
        } else {
            ""
        }
    )))
}

/// Refuse a picture of `width` x `height` pixels with `spp` samples each that needs more
/// memory than is available.
pub fn check_image(width: u32, height: u32, spp: u32) -> Result<(), Error> {
    check_image_within(width, height, spp, available_bytes())
}

/// [`check_image`] against a given budget in bytes.
pub fn check_image_within(width: u32, height: u32, spp: u32, budget: u64) -> Result<(), Error> {
    if width == 0 || height == 0 || spp == 0 {
        return Err(Error::Invalid(format!(
            "image size {width}x{height} with {spp} samples per pixel: each must be at least 1"
        )));
    }
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(Error::Invalid(format!(
            "image size {width}x{height}: a side may be at most {MAX_IMAGE_SIDE} pixels"
        )));
    }
    let pixels = width as u64 * height as u64;
    let need = pixels
        .saturating_mul(spp as u64)
        .saturating_mul(BYTES_PER_SAMPLE)
        .saturating_add(pixels.saturating_mul(12));
    if need > budget || pixels > u32::MAX as u64 {
        return Err(Error::Invalid(format!(
            "image {width}x{height} with {spp} samples per pixel would need about {} of memory \
             ({} available)",
            gib(need),
            gib(budget)
        )));
    }
    Ok(())
}

/// Bytes a lightmap bake holds per texel of its atlas at its peak (the texels' patches,
/// samples and light, the EXR's and PNGs' pixels): measured with `/usr/bin/time -f %M` on
/// the Cornell box (2026-12-07), 0.47 GB at 2048^2 and 1.6 GB at 4096^2, i.e. about 90
/// bytes a texel over the solve's own.
const LIGHTMAP_TEXEL_BYTES: u64 = 96;

/// Refuse a lightmap atlas of `width` x `height` texels that needs more memory than is
/// available (16384^2, in range, needed about 24 GiB).
pub fn check_lightmap(width: u32, height: u32) -> Result<(), Error> {
    let need = (width as u64 * height as u64).saturating_mul(LIGHTMAP_TEXEL_BYTES);
    let budget = available_bytes();
    if need <= budget {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "a lightmap atlas of {width}x{height} texels needs about {} of memory ({} \
         available): give a smaller resolution or a larger texel size",
        gib(need),
        gib(budget)
    )))
}

/// Bytes the probes' cube maps cost at their peak, per texel of a face resolution's 6 res^2:
/// `CUBE_TEXEL_BYTES` plus `COEFF_TEXEL_BYTES` per SH coefficient for the probes' camera
/// (its directions, the capture's rays and hits, and the projector's weights, with the
/// coarse camera's quarter), `EMITTER_TEXEL_BYTES` plus as much per coefficient for Step 3's.
/// Measured on the Cornell box (`/usr/bin/time -f %M`, 2026-12-07): `cube_res` 512 with 2 /
/// 4 / 8 bands peaks at 420 / 606 / 1355 MB, 1024 with 4 bands at 2.35 GB; `emitter_res`
/// 512 and 1024 at 335 MB and 1.11 GB (79 MB at the defaults).
const CUBE_TEXEL_BYTES: u64 = 176;
/// See [`CUBE_TEXEL_BYTES`].
const COEFF_TEXEL_BYTES: u64 = 10;
/// See [`CUBE_TEXEL_BYTES`].
const EMITTER_TEXEL_BYTES: u64 = 20;

/// What the probes' cube maps of face resolution `cube` (and Step 3's of `emitter`, for
/// the dispersive solver) with `coefficients` SH coefficients cost at their peak (bytes).
pub fn cube_map_bytes(cube: usize, emitter: Option<usize>, coefficients: usize) -> u64 {
    let texels = |res: usize| 6 * (res as u64).saturating_mul(res as u64);
    let per_coeff = COEFF_TEXEL_BYTES * coefficients as u64;
    let probes = texels(cube).saturating_mul(CUBE_TEXEL_BYTES + per_coeff);
    let splat = emitter.map_or(0, |e| {
        texels(e).saturating_mul(EMITTER_TEXEL_BYTES + per_coeff)
    });
    probes.saturating_add(splat)
}

/// Refuse cube maps (see [`cube_map_bytes`]) that need more memory than is available: a
/// `cube_res` of 2048 with 8 bands would take about 20 GiB, and the allocator's abort was
/// the only message.
pub fn check_cube_maps(
    cube: usize,
    emitter: Option<usize>,
    coefficients: usize,
) -> Result<(), Error> {
    check_cube_maps_within(cube, emitter, coefficients, available_bytes())
}

/// [`check_cube_maps`] against a given budget in bytes.
pub fn check_cube_maps_within(
    cube: usize,
    emitter: Option<usize>,
    coefficients: usize,
    budget: u64,
) -> Result<(), Error> {
    let need = cube_map_bytes(cube, emitter, coefficients);
    if need <= budget {
        return Ok(());
    }
    let emitter = emitter.map_or(String::new(), |e| format!(" and emitter_res {e}"));
    Err(Error::Invalid(format!(
        "cube_res {cube}{emitter} with {coefficients} SH coefficients would need about {} of \
         memory for the cube maps ({} available); use a smaller cube_res, emitter_res or bands",
        gib(need),
        gib(budget)
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate meets what was measured (see [`CUBE_TEXEL_BYTES`]; 21.1 GB measured at
    /// `cube_res` 2048 with 8 bands, 8.5 GiB estimated at 2048 with 4), and a budget below it
    /// is refused naming the settings.
    #[test]
    fn cube_maps_beyond_the_memory_are_refused() {
        let gb = |b: u64| b as f64 / 1e9;
        let at = |cube, emitter, n| gb(cube_map_bytes(cube, emitter, n));
        assert!((at(1024, Some(64), 16) - (2.35 - 0.08)).abs() < 0.25);
        assert!((at(512, Some(64), 64) - (1.36 - 0.08)).abs() < 0.15);
        assert!((at(2048, Some(64), 64) - (21.1 - 0.08)).abs() < 1.5);
        let e = check_cube_maps_within(2048, Some(64), 64, 16 << 30)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cube_res 2048") && e.contains("GiB"), "{e}");
        check_cube_maps_within(128, Some(128), 16, 1 << 30).unwrap();
    }

    #[test]
    fn absurd_plans_are_refused_with_the_memory_they_need() {
        let cornell = shrad_scene::cornell_box();
        let plan = PatchPlan {
            patch_size: 1e-9,
            count: 3_000_000_000_000,
            heaviest_own: None,
        };
        let e = check_patches_within(&cornell, plan, 24 << 30)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cornell") && e.contains("GiB") && e.contains("3.000e12"),
            "{e}"
        );
        let fine = PatchPlan {
            patch_size: 0.05,
            count: 20_000,
            heaviest_own: None,
        };
        check_patches_within(&cornell, fine, 24 << 30).unwrap();
        let nan = PatchPlan {
            patch_size: f32::NAN,
            count: 1,
            heaviest_own: None,
        };
        assert!(check_patches_within(&cornell, nan, 24 << 30).is_err());
    }

    #[test]
    fn huge_images_are_refused() {
        let e = check_image_within(16_000, 16_000, 4096, 24 << 30)
            .unwrap_err()
            .to_string();
        assert!(e.contains("GiB"), "{e}");
        check_image_within(512, 512, 4, 24 << 30).unwrap();
        let e = check_image_within(MAX_IMAGE_SIDE + 1, 4, 1, 24 << 30)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at most 16384"), "{e}");
        assert!(check_image_within(0, 512, 1, 24 << 30).is_err());
    }

    #[test]
    fn the_cornell_box_at_a_nanometre_is_refused_before_allocation() {
        let scene = shrad_scene::cornell_box();
        let plan = crate::Patches::plan(&scene, crate::PatchSizing::Size(1e-9));
        assert!(plan.count > 1_000_000_000_000, "{}", plan.count);
        assert!(check_patches_within(&scene, plan, 24 << 30).is_err());
    }

    #[test]
    fn an_objects_own_patch_size_too_small_is_named() {
        let mut scene = shrad_scene::cornell_box();
        let o = scene.objects.iter().position(|o| o.name == "short_block");
        let o = o.expect("the Cornell box has a short block");
        scene.objects[o].patch_size = Some(1e-7);
        let plan = crate::Patches::plan(&scene, crate::PatchSizing::Count(2000));
        let e = check_patches_within(&scene, plan, 24 << 30)
            .unwrap_err()
            .to_string();
        let named = format!("object {o} 'short_block': its own patch_size 1.000e-7");
        assert!(e.contains(&named) && e.contains("give it a larger"), "{e}");
        // A scene size too small is still the scene's.
        scene.objects[o].patch_size = Some(0.1);
        let plan = crate::Patches::plan(&scene, crate::PatchSizing::Size(1e-7));
        let e = check_patches_within(&scene, plan, 24 << 30)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(": patch size 1.000e-7") && e.contains("--patch-size"),
            "{e}"
        );
    }
}
