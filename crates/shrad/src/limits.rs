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

/// Bytes one patch costs at peak (patches, visibility, the heaviest solver), rounded up.
pub const BYTES_PER_PATCH: u64 = 5 * 1024;
/// Bytes one camera sample costs while a picture is rendered.
pub const BYTES_PER_SAMPLE: u64 = 64;
/// The longest side of a picture, in pixels, for every command and front end (beyond it a
/// picture is a mistake before it is a memory problem).
pub const MAX_IMAGE_SIDE: u32 = 16384;
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
pub fn check_patches(source: &str, plan: PatchPlan) -> Result<(), Error> {
    check_patches_within(source, plan, available_bytes())
}

/// [`check_patches`] against a given budget in bytes.
pub fn check_patches_within(source: &str, plan: PatchPlan, budget: u64) -> Result<(), Error> {
    if !(plan.patch_size.is_finite() && plan.patch_size > 0.0) {
        return Err(Error::Invalid(format!(
            "{source}: patch size {} must be a positive number",
            plan.patch_size
        )));
    }
    let count = plan.count as u64;
    let need = count.saturating_mul(BYTES_PER_PATCH);
    if count > MAX_PATCHES || need > budget {
        return Err(Error::Invalid(format!(
            "{source}: patch size {:.3e} would make {} patches, needing about {} of memory \
             ({} available{}); use a larger --patch-size or a smaller --patches",
            plan.patch_size,
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
        )));
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_plans_are_refused_with_the_memory_they_need() {
        let plan = PatchPlan {
            patch_size: 1e-9,
            count: 3_000_000_000_000,
        };
        let e = check_patches_within("cornell", plan, 24 << 30)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cornell") && e.contains("GiB") && e.contains("3.000e12"),
            "{e}"
        );
        let fine = PatchPlan {
            patch_size: 0.05,
            count: 20_000,
        };
        check_patches_within("cornell", fine, 24 << 30).unwrap();
        let nan = PatchPlan {
            patch_size: f32::NAN,
            count: 1,
        };
        assert!(check_patches_within("x", nan, 24 << 30).is_err());
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
        assert!(check_patches_within("cornell", plan, 24 << 30).is_err());
    }
}
