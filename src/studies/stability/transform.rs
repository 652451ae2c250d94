//! The extreme-scale variant of a scene (docs/conventions.md): every placement and the
//! camera left-multiplied by `M = T(t,t,t)·S(s)`, built from the scene text so that tests and
//! the `stability` command load exactly the same thing.

use crate::core::scene::format::{LightSpec, ScaleSpec, SceneFile, TransformStep};
use crate::core::scene::{load_scene_str, Scene, SceneError, SceneOverrides};
use glam::{DMat4, DVec3};
use std::path::Path;

/// `M = T(t,t,t)·S(s)`.
pub fn placement_matrix(s: f64, t: f64) -> DMat4 {
    DMat4::from_translation(DVec3::splat(t)) * DMat4::from_scale(DVec3::splat(s))
}

/// Apply `M = T(t,t,t)·S(s)` to a parsed scene: each shape's placement is left-multiplied by
/// `M` (two steps prepended to `transform`, or `M·matrix`), the camera origin and target and
/// every point light move by `M`. Point intensities are scaled by `s²` so irradiance, and
/// hence the image, is unchanged; radiances (area, environment) are scale-free already.
/// Checker textures are in world units and are *not* adjusted: use scenes without them.
pub fn transform_file(file: &mut SceneFile, s: f64, t: f64) {
    let m = placement_matrix(s, t);
    let apply = |p: [f64; 3]| m.transform_point3(DVec3::from_array(p)).to_array();
    for shape in &mut file.shapes {
        let (transform, matrix) = shape.placement_mut();
        if let Some(rows) = matrix {
            let local = DMat4::from_cols_array_2d(rows).transpose();
            *rows = (m * local).transpose().to_cols_array_2d();
        } else {
            let mut steps = vec![
                TransformStep::Translate([t; 3]),
                TransformStep::Scale(ScaleSpec::Uniform(s)),
            ];
            steps.extend(transform.take().unwrap_or_default());
            *transform = Some(steps);
        }
    }
    file.camera.origin = apply(file.camera.origin);
    file.camera.target = apply(file.camera.target);
    for key in file.animation.iter_mut().flat_map(|a| &mut a.keys) {
        key.origin = key.origin.map(apply);
        key.target = key.target.map(apply);
    }
    for light in &mut file.lights {
        if let LightSpec::Point {
            position,
            intensity,
        } = light
        {
            *position = apply(*position);
            *intensity = intensity.map(|i| i * s * s);
        }
    }
}

/// Load `text` transformed by `T(t,t,t)·S(s)` (see [`transform_file`]); `base` resolves meshes.
///
/// # Errors
/// The scene's own errors, or a TOML error if the text does not parse.
pub fn load_transformed(
    text: &str,
    display: &str,
    base: &Path,
    s: f64,
    t: f64,
    overrides: &SceneOverrides,
) -> Result<Scene, SceneError> {
    let mut file: SceneFile = toml::from_str(text).map_err(|e| SceneError {
        path: display.to_string(),
        line: None,
        field: String::new(),
        msg: e.message().replace('\n', " "),
    })?;
    transform_file(&mut file, s, t);
    let text = toml::to_string(&file).map_err(|e| SceneError {
        path: display.to_string(),
        line: None,
        field: String::new(),
        msg: format!("cannot re-serialise the transformed scene: {e}"),
    })?;
    load_scene_str(&text, display, base, "transformed", overrides)
}
