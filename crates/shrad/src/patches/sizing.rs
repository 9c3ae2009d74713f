//! How big the patches are: the one rule every front end (the CLI, the viewer, Python)
//! applies to what its caller and the scene file say.

use shrad_scene::SceneSettings;

use super::PatchSizing;
use crate::Error;

impl PatchSizing {
    /// How a scene is cut when neither the caller nor the scene says.
    pub const DEFAULT: PatchSizing = PatchSizing::Count(20_000);
    /// Most patches a caller may ask for by count.
    pub const MAX_COUNT: usize = 50_000_000;

    /// The caller's `size` wins, then its `count`, then the scene's settings (size, then
    /// count), then [`PatchSizing::DEFAULT`]. `names` spell the caller's two options in
    /// errors (`["--patch-size", "--patches"]`).
    pub fn choose(
        size: Option<f32>,
        count: Option<usize>,
        scene: &SceneSettings,
        names: [&str; 2],
    ) -> Result<PatchSizing, Error> {
        let [size_name, count_name] = names;
        if let Some(h) = size {
            if !(h.is_finite() && h > 0.0) {
                return Err(Error::Invalid(format!(
                    "{size_name} must be a positive number, got {h}"
                )));
            }
            return Ok(PatchSizing::Size(h));
        }
        if let Some(n) = count {
            if n == 0 || n > Self::MAX_COUNT {
                return Err(Error::Invalid(format!(
                    "{count_name} must be between 1 and {}, got {n}",
                    Self::MAX_COUNT
                )));
            }
            return Ok(PatchSizing::Count(n));
        }
        Ok(match (scene.patch_size, scene.patches) {
            (Some(h), _) => PatchSizing::Size(h),
            (None, Some(n)) => PatchSizing::Count(n),
            (None, None) => PatchSizing::DEFAULT,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAMES: [&str; 2] = ["--patch-size", "--patches"];

    #[test]
    fn the_caller_wins_then_the_scene_then_the_default() {
        let scene = SceneSettings {
            patch_size: None,
            patches: Some(700),
            ..Default::default()
        };
        let choose = |h, n, s: &SceneSettings| PatchSizing::choose(h, n, s, NAMES).unwrap();
        assert_eq!(choose(Some(0.1), Some(5), &scene), PatchSizing::Size(0.1));
        assert_eq!(choose(None, Some(5), &scene), PatchSizing::Count(5));
        assert_eq!(choose(None, None, &scene), PatchSizing::Count(700));
        let sized = SceneSettings {
            patch_size: Some(0.2),
            ..scene.clone()
        };
        assert_eq!(choose(None, None, &sized), PatchSizing::Size(0.2));
        assert_eq!(
            choose(None, None, &SceneSettings::default()),
            PatchSizing::Count(20_000)
        );
    }

    #[test]
    fn bad_requests_name_the_option() {
        let none = SceneSettings::default();
        let e = PatchSizing::choose(Some(-1.0), None, &none, NAMES).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--patch-size must be a positive number, got -1"
        );
        let e = PatchSizing::choose(None, Some(0), &none, ["patch_size", "patches"]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "patches must be between 1 and 50000000, got 0"
        );
        assert!(PatchSizing::choose(None, Some(50_000_001), &none, NAMES).is_err());
    }
}
