//! Stage two of loading: validate every field of a [`SceneFile`] and build the render-space
//! [`Scene`]. Every error names the file and the field (and the line for TOML syntax errors).

use super::check::Ctx;
pub use super::check::SceneError;
use super::format::{AnimationSpec, CameraSpec, LightSpec, MaterialSpec, RenderSpec, SceneFile};
use super::shapes::{Builder, Shapes};
use super::{
    Camera, Features, Geometry, Light, Material, RenderSettings, Scene, SceneOverrides, Texture,
};
use crate::util::hash::Fnv64;
pub use crate::util::limits::MAX_FRAMES;
use crate::util::limits::{MAX_DEPTH, MAX_IMAGE_SIDE, MAX_PIXELS, MAX_SAMPLES, MAX_SPP};
use glam::{DVec3, Vec3};
use std::collections::BTreeMap;
use std::path::Path;

/// Load and validate a scene file; meshes are read relative to its folder.
///
/// # Errors
/// A [`SceneError`] naming the file and field for unreadable files, TOML syntax errors, unknown
/// fields and every out-of-range or non-finite value.
pub fn load_scene(path: &Path, overrides: &SceneOverrides) -> Result<Scene, SceneError> {
    let display = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        path: display.clone(),
        line: None,
        field: String::new(),
        msg: format!("cannot read scene file: {e}"),
    })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    load_scene_str(&text, &display, &base, &stem, overrides)
}

/// Parse scene text (`display` names it in errors, `base` resolves mesh paths).
pub fn load_scene_str(
    text: &str,
    display: &str,
    base: &Path,
    default_name: &str,
    overrides: &SceneOverrides,
) -> Result<Scene, SceneError> {
    let toml_error = |e: toml::de::Error| {
        let (at, key, msg) = super::check::toml_error_at(text, &e);
        // The message of a shape error already names `shapes[i].field`.
        let key = if msg.starts_with("shapes[") {
            String::new()
        } else {
            key
        };
        SceneError {
            path: display.to_string(),
            line: at.map(|(line, _)| line),
            field: key,
            msg,
        }
    };
    // Syntax first, then vector lengths (serde would cut or blame the table), then types.
    let raw: toml::Value = toml::from_str(text).map_err(toml_error)?;
    // An experiment file where a scene is expected: say so, not `unknown field 'scenes'`.
    let has = |k: &str| raw.get(k).is_some();
    if (has("scenes") || has("schedulers")) && !has("camera") {
        return Err(SceneError {
            path: display.to_string(),
            line: None,
            field: String::new(),
            msg: "is an experiment file, not a scene: measure it with `raysched run`, or give \
                  one of its [[scenes]] paths here"
                .into(),
        });
    }
    super::check::vector_lengths(&raw, "").map_err(|(field, msg)| SceneError {
        path: display.to_string(),
        line: None,
        field,
        msg,
    })?;
    let mut file: SceneFile = toml::from_str(text).map_err(toml_error)?;
    overrides.apply(&mut file);
    build_scene(&file, display, base, default_name)
}

/// The steps of stage two, in the order their errors are reported.
fn build_scene(
    file: &SceneFile,
    display: &str,
    base: &Path,
    default_name: &str,
) -> Result<Scene, SceneError> {
    let cx = Ctx { path: display };
    // 1. The hash: the canonical text here, every mesh file as its shape reads it.
    let mut hash = Fnv64::default();
    hash.write(format!("{file:?}").as_bytes());
    // 2. Cameras; render space is world space minus frame 0's camera origin.
    let (origin, cameras) = cameras(&cx, file)?;
    // 3. Render settings, and the render's size against the limits.
    let settings = render_settings(&cx, &file.render)?;
    check_size(&cx, &file.camera, cameras.len() as u64, settings.spp)?;
    // 4. Materials, in name order so ids are stable.
    let (material_ids, materials) = materials(&cx, &file.materials)?;
    // 5. Shapes, placed in render space; emitting ones become area lights.
    let mut builder = Builder::new(&cx, origin, &material_ids, base);
    for (i, shape) in file.shapes.iter().enumerate() {
        builder.add(&format!("shapes[{i}]"), shape, &mut hash)?;
    }
    let Shapes {
        mut geometry,
        area_lights: mut lights,
        stats,
        file_materials,
        ignored,
    } = builder.finish();
    let mut materials = materials;
    materials.extend(file_materials);
    // 6. The file's lights after the area lights; each emitting primitive points at its light.
    let environment = file_lights(&cx, &file.lights, origin, &mut lights)?;
    link_area_lights(&mut geometry, &lights);
    // 7. What the scene uses, for the renderer and the CSV.
    let features = analyse(&geometry, &materials, &lights);
    Ok(Scene {
        name: file
            .name
            .clone()
            .unwrap_or_else(|| default_name.to_string()),
        hash: hash.finish(),
        origin,
        camera: cameras[0],
        cameras,
        settings,
        materials,
        tri_normals: geometry.triangles.iter().map(|t| t.normal()).collect(),
        geometry,
        lights,
        environment,
        features,
        ignored_input: ignored.into_iter().collect(),
        load_stats: stats,
    })
}

/// Frame 0's camera origin (the render-space origin) and one camera per frame.
fn cameras(cx: &Ctx, file: &SceneFile) -> Result<(DVec3, Vec<Camera>), SceneError> {
    let (pose0, camera) = first_camera(cx, &file.camera)?;
    let cameras = match &file.animation {
        None => vec![camera],
        Some(a) => animation_cameras(cx, a, pose0, camera)?,
    };
    Ok((pose0.origin, cameras))
}

/// `[camera]`: the pose of frame 0 as written and its camera.
fn first_camera(cx: &Ctx, cam: &CameraSpec) -> Result<(Pose, Camera), SceneError> {
    let origin = cx.vec3("camera.origin", cam.origin)?;
    let target = cx.vec3("camera.target", cam.target)?;
    let up = cx.vec3("camera.up", cam.up)?;
    let fov = cx.finite("camera.fov_deg", cam.fov_deg)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(cx.err("camera.fov_deg", format!("must be in (0, 180) (got {fov})")));
    }
    for (field, v) in [("camera.width", cam.width), ("camera.height", cam.height)] {
        if !(1..=MAX_IMAGE_SIDE).contains(&v) {
            return Err(cx.err(field, format!("must be in 1..={MAX_IMAGE_SIDE} (got {v})")));
        }
    }
    let forward = target - origin;
    if forward.length() == 0.0 {
        return Err(cx.err("camera.target", "equals camera.origin: no view direction"));
    }
    if up.length() == 0.0 || forward.normalize().cross(up.normalize()).length() < 1e-9 {
        return Err(cx.err("camera.up", "is parallel to the view direction (or zero)"));
    }
    let camera = Camera::new(forward, up, fov, cam.width, cam.height);
    let pose = Pose {
        origin,
        target,
        up,
        fov,
    };
    Ok((pose, camera))
}

/// Pixels (every frame) and samples of the render within [`MAX_PIXELS`] and [`MAX_SAMPLES`],
/// so the image and its work items can be allocated.
fn check_size(cx: &Ctx, cam: &CameraSpec, frames: u64, spp: u32) -> Result<(), SceneError> {
    let pixels = cam.width as u64 * cam.height as u64 * frames;
    if pixels > MAX_PIXELS {
        return Err(cx.err(
            "camera.width",
            format!(
                "width × height × frames = {} × {} × {frames} = {pixels} pixels is more than \
                 the limit of {MAX_PIXELS}",
                cam.width, cam.height
            ),
        ));
    }
    let samples = pixels * spp as u64; // ≤ 2²⁵ · 2²⁰: no overflow
    if samples > MAX_SAMPLES {
        return Err(cx.err(
            "render.spp",
            format!(
                "pixels × spp = {pixels} × {spp} = {samples} samples is more than the limit \
                 of {MAX_SAMPLES}"
            ),
        ));
    }
    Ok(())
}

fn render_settings(cx: &Ctx, r: &RenderSpec) -> Result<RenderSettings, SceneError> {
    if !(1..=MAX_SPP).contains(&r.spp) {
        return Err(cx.err(
            "render.spp",
            format!("must be in 1..={MAX_SPP} (got {})", r.spp),
        ));
    }
    if r.max_depth == 0 || r.max_depth < -1 || r.max_depth as i64 > MAX_DEPTH as i64 {
        return Err(cx.err(
            "render.max_depth",
            format!(
                "must be in 1..={MAX_DEPTH}, or −1 for unlimited (Russian roulette ends the \
                 path, at {MAX_DEPTH} segments at the latest) (got {})",
                r.max_depth
            ),
        ));
    }
    Ok(RenderSettings {
        spp: r.spp,
        max_depth: r.max_depth,
        seed: r.seed,
    })
}

/// Each material's id (its index in name order) and the materials in that order.
fn materials(
    cx: &Ctx,
    specs: &BTreeMap<String, MaterialSpec>,
) -> Result<(BTreeMap<String, u32>, Vec<Material>), SceneError> {
    let mut ids = BTreeMap::new();
    let mut materials = Vec::new();
    for (name, spec) in specs {
        ids.insert(name.clone(), materials.len() as u32);
        materials.push(material(cx, name, spec)?);
    }
    Ok((ids, materials))
}

fn material(cx: &Ctx, name: &str, spec: &MaterialSpec) -> Result<Material, SceneError> {
    let f = |s: &str| format!("materials.{name}.{s}");
    Ok(match spec {
        MaterialSpec::Diffuse {
            reflectance,
            checker,
        } => {
            let tex = match (reflectance, checker) {
                (Some(c), None) => Texture::Constant(albedo(cx, &f("reflectance"), *c)?),
                (None, Some(ch)) => Texture::Checker {
                    even: albedo(cx, &f("checker.even"), ch.even)?,
                    odd: albedo(cx, &f("checker.odd"), ch.odd)?,
                    size: cx.positive(&f("checker.size"), ch.size)?,
                },
                _ => {
                    return Err(cx.err(
                        format!("materials.{name}"),
                        "a diffuse material needs exactly one of `reflectance` or `checker`",
                    ))
                }
            };
            Material::Diffuse { reflectance: tex }
        }
        MaterialSpec::Mirror { reflectance } => Material::Mirror {
            reflectance: albedo(cx, &f("reflectance"), *reflectance)?,
        },
        MaterialSpec::Dielectric { ior } => Material::Dielectric {
            ior: cx.positive(&f("ior"), *ior)? as f32,
        },
    })
}

/// Append the `[[lights]]` to `lights`; the index of the environment light, if any.
fn file_lights(
    cx: &Ctx,
    specs: &[LightSpec],
    origin: DVec3,
    lights: &mut Vec<Light>,
) -> Result<Option<u32>, SceneError> {
    let mut environment = None;
    for (i, l) in specs.iter().enumerate() {
        let at = format!("lights[{i}]");
        match l {
            LightSpec::Point {
                position,
                intensity,
            } => {
                let field = format!("{at}.position");
                let p = cx.vec3(&field, *position)?;
                let i = cx.non_negative3(&format!("{at}.intensity"), *intensity)?;
                let position = cx.placed(&field, p - origin)?;
                lights.push(Light::Point {
                    position,
                    position_lo: (p - origin - position.as_dvec3()).as_vec3(),
                    intensity: i.as_vec3(),
                });
            }
            LightSpec::Environment { radiance } => {
                if environment.is_some() {
                    return Err(cx.err(at, "a second environment light (only one is allowed)"));
                }
                let r = cx.non_negative3(&format!("{at}.radiance"), *radiance)?;
                environment = Some(lights.len() as u32);
                lights.push(Light::Environment {
                    radiance: r.as_vec3(),
                });
            }
        }
    }
    Ok(environment)
}

/// Point each emitting primitive at its area light.
fn link_area_lights(g: &mut Geometry, lights: &[Light]) {
    for (li, l) in lights.iter().enumerate() {
        if let Light::Area { prims, .. } = l {
            for &p in prims {
                g.info[p as usize].light = li as u32;
            }
        }
    }
}

/// A camera pose in world space (f64), as written in the scene.
#[derive(Clone, Copy, Debug)]
struct Pose {
    origin: DVec3,
    target: DVec3,
    up: DVec3,
    fov: f64,
}

impl Pose {
    /// `a·(1−t) + b·t` per field: exactly `a` at t = 0 and exactly `b` at t = 1.
    fn lerp(a: &Pose, b: &Pose, t: f64) -> Pose {
        let l3 = |x: DVec3, y: DVec3| x * (1.0 - t) + y * t;
        Pose {
            origin: l3(a.origin, b.origin),
            target: l3(a.target, b.target),
            up: l3(a.up, b.up),
            fov: a.fov * (1.0 - t) + b.fov * t,
        }
    }

    /// Why this pose has no camera (`None` when it is fine).
    fn problem(&self) -> Option<String> {
        let forward = self.target - self.origin;
        if !(self.fov > 0.0 && self.fov < 180.0) {
            Some(format!("fov_deg must be in (0, 180) (got {})", self.fov))
        } else if forward.length() == 0.0 {
            Some("target equals origin: no view direction".into())
        } else if self.up.length() == 0.0
            || forward.normalize().cross(self.up.normalize()).length() < 1e-9
        {
            Some("up is parallel to the view direction (or zero)".into())
        } else {
            None
        }
    }
}

/// One camera per frame. Frame 0 is `[camera]` (passed in as `first`, so a static scene and
/// frame 0 of an animation are the same camera bit for bit); later frames interpolate the keys
/// linearly in world space (f64) and sit at `eye` = their origin minus frame 0's, rounded to
/// f32 once: render space stays anchored at frame 0's camera, so one geometry (one BVH) serves
/// every frame, and precision is that of the camera path's extent, not of the world position.
fn animation_cameras(
    cx: &Ctx,
    a: &AnimationSpec,
    pose0: Pose,
    first: Camera,
) -> Result<Vec<Camera>, SceneError> {
    if a.frames == 0 || a.frames > MAX_FRAMES {
        return Err(cx.err(
            "animation.frames",
            format!("must be in 1..={MAX_FRAMES} (got {})", a.frames),
        ));
    }
    let mut keys = vec![(0u32, pose0)];
    for (i, k) in a.keys.iter().enumerate() {
        let at = format!("animation.keys[{i}]");
        let prev = keys.last().expect("frame 0 is a key").1;
        if k.frame <= keys.last().unwrap().0 || k.frame >= a.frames {
            return Err(cx.err(
                format!("{at}.frame"),
                format!(
                    "must be after the previous key's frame {} and < animation.frames = {} \
                     (keys sorted, frame 0 is [camera]; got {})",
                    keys.last().unwrap().0,
                    a.frames,
                    k.frame
                ),
            ));
        }
        let v = |name: &str, v: Option<[f64; 3]>, old: DVec3| match v {
            Some(v) => cx.vec3(&format!("{at}.{name}"), v),
            None => Ok(old),
        };
        let pose = Pose {
            origin: v("origin", k.origin, prev.origin)?,
            target: v("target", k.target, prev.target)?,
            up: v("up", k.up, prev.up)?,
            fov: match k.fov_deg {
                Some(f) => cx.finite(&format!("{at}.fov_deg"), f)?,
                None => prev.fov,
            },
        };
        if let Some(p) = pose.problem() {
            return Err(cx.err(at, p));
        }
        keys.push((k.frame, pose));
    }
    let mut cameras = Vec::with_capacity(a.frames as usize);
    cameras.push(first);
    let mut next = 1; // index of the first key at or after the current frame
    for f in 1..a.frames {
        while next < keys.len() && keys[next].0 < f {
            next += 1;
        }
        let pose = if next == keys.len() {
            keys[next - 1].1 // after the last key: hold it
        } else if keys[next].0 == f {
            keys[next].1 // exactly on a key: no arithmetic at all
        } else {
            let ((fa, pa), (fb, pb)) = (keys[next - 1], keys[next]);
            Pose::lerp(&pa, &pb, (f - fa) as f64 / (fb - fa) as f64)
        };
        if let Some(p) = pose.problem() {
            return Err(cx.err(
                format!("animation.keys[{}]", next - 1),
                format!("the interpolated camera of frame {f} is unusable: {p}"),
            ));
        }
        let cam = Camera::new(
            pose.target - pose.origin,
            pose.up,
            pose.fov,
            first.width,
            first.height,
        );
        let eye = cx.placed(
            &format!("animation.keys[{}]", next - 1),
            pose.origin - pose0.origin,
        )?;
        cameras.push(cam.with_eye(eye));
    }
    Ok(cameras)
}

fn albedo(cx: &Ctx, field: &str, c: [f64; 3]) -> Result<Vec3, SceneError> {
    let v = cx.vec3(field, c)?;
    if v.min_element() < 0.0 || v.max_element() > 1.0 {
        return Err(cx.err(field, format!("reflectance must be in [0, 1] (got {c:?})")));
    }
    Ok(v.as_vec3())
}

/// Which features the scene really uses (materials count only when some primitive uses them).
fn analyse(g: &Geometry, materials: &[Material], lights: &[Light]) -> Features {
    let mut used = vec![false; materials.len()];
    for info in &g.info {
        used[info.material as usize] = true;
    }
    let used_materials = || {
        materials
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(m, _)| m)
    };
    Features {
        triangles: !g.triangles.is_empty(),
        spheres: !g.spheres.is_empty(),
        area_lights: lights.iter().any(|l| matches!(l, Light::Area { .. })),
        point_lights: lights.iter().any(|l| matches!(l, Light::Point { .. })),
        environment: lights
            .iter()
            .any(|l| matches!(l, Light::Environment { .. })),
        refraction: used_materials().any(|m| matches!(m, Material::Dielectric { .. })),
        mirrors: used_materials().any(|m| matches!(m, Material::Mirror { .. })),
        textures: used_materials().any(|m| {
            matches!(
                m,
                Material::Diffuse {
                    reflectance: Texture::Checker { .. }
                }
            )
        }),
    }
}
