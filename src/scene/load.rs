//! Stage two of loading: validate every field of a [`SceneFile`] and build the render-space
//! [`Scene`]. Every error names the file and the field (and the line for TOML syntax errors).

use super::format::{
    AnimationSpec, LightSpec, MaterialSpec, ScaleSpec, SceneFile, ShapeSpec, TransformStep,
};
use super::generators::{self, Generated, GeneratorParams};
use super::{
    Camera, Features, Geometry, Light, LoadStats, Material, PrimInfo, RenderSettings, Scene,
    SceneOverrides, Texture, NO_LIGHT,
};
use crate::geometry::{Sphere, Triangle};
use crate::hash::Fnv64;
use glam::{DMat3, DMat4, DVec3, DVec4, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A bad scene: which file, which field (or line), and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}{}: {field}{}{msg}", line.map(|l| format!(":{l}")).unwrap_or_default(), if field.is_empty() { "" } else { ": " })]
pub struct SceneError {
    pub path: String,
    pub line: Option<usize>,
    pub field: String,
    pub msg: String,
}

struct Ctx<'a> {
    path: &'a str,
}

impl Ctx<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
        SceneError {
            path: self.path.to_string(),
            line: None,
            field: field.into(),
            msg: msg.into(),
        }
    }
    fn finite(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, format!("must be a finite number (got {v})")))
        }
    }
    fn vec3(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        for x in v {
            self.finite(field, x)?;
        }
        Ok(DVec3::from_array(v))
    }
    fn non_negative3(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let d = self.vec3(field, v)?;
        if d.min_element() < 0.0 {
            return Err(self.err(field, format!("must be ≥ 0 (got {v:?})")));
        }
        Ok(d)
    }
    fn positive(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        self.finite(field, v)?;
        if v <= 0.0 {
            return Err(self.err(field, format!("must be > 0 (got {v})")));
        }
        Ok(v)
    }
}

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
    let mut file: SceneFile = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        SceneError {
            path: display.to_string(),
            line,
            field: String::new(),
            msg: e.message().replace('\n', " "),
        }
    })?;
    overrides.apply(&mut file);
    build_scene(&file, display, base, default_name)
}

fn build_scene(
    file: &SceneFile,
    display: &str,
    base: &Path,
    default_name: &str,
) -> Result<Scene, SceneError> {
    let cx = Ctx { path: display };
    let mut hash = Fnv64::default();
    hash.write(format!("{file:?}").as_bytes());

    // Camera.
    let cam = &file.camera;
    let origin = cx.vec3("camera.origin", cam.origin)?;
    let target = cx.vec3("camera.target", cam.target)?;
    let up = cx.vec3("camera.up", cam.up)?;
    let fov = cx.finite("camera.fov_deg", cam.fov_deg)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(cx.err("camera.fov_deg", format!("must be in (0, 180) (got {fov})")));
    }
    if cam.width == 0 || cam.height == 0 {
        let field = if cam.width == 0 {
            "camera.width"
        } else {
            "camera.height"
        };
        return Err(cx.err(field, "must be ≥ 1 (got 0)"));
    }
    let forward = target - origin;
    if forward.length() == 0.0 {
        return Err(cx.err("camera.target", "equals camera.origin: no view direction"));
    }
    if up.length() == 0.0 || forward.normalize().cross(up.normalize()).length() < 1e-9 {
        return Err(cx.err("camera.up", "is parallel to the view direction (or zero)"));
    }
    let camera = Camera::new(forward, up, fov, cam.width, cam.height);
    let pose0 = Pose {
        origin,
        target,
        up,
        fov,
    };
    let cameras = match &file.animation {
        None => vec![camera],
        Some(a) => animation_cameras(&cx, a, pose0, camera)?,
    };

    // Render settings.
    let r = &file.render;
    if r.spp == 0 {
        return Err(cx.err("render.spp", "must be ≥ 1 (got 0)"));
    }
    if r.max_depth == 0 || r.max_depth < -1 {
        return Err(cx.err(
            "render.max_depth",
            format!("must be ≥ 1, or −1 for unlimited (got {})", r.max_depth),
        ));
    }
    let settings = RenderSettings {
        spp: r.spp,
        max_depth: r.max_depth,
        seed: r.seed,
    };

    // Materials, in name order so ids are stable.
    let mut material_ids = BTreeMap::new();
    let mut materials = Vec::new();
    for (name, spec) in &file.materials {
        let f = |s: &str| format!("materials.{name}.{s}");
        let m = match spec {
            MaterialSpec::Diffuse {
                reflectance,
                checker,
            } => {
                let tex =
                    match (reflectance, checker) {
                        (Some(c), None) => Texture::Constant(albedo(&cx, &f("reflectance"), *c)?),
                        (None, Some(ch)) => Texture::Checker {
                            even: albedo(&cx, &f("checker.even"), ch.even)?,
                            odd: albedo(&cx, &f("checker.odd"), ch.odd)?,
                            size: cx.positive(&f("checker.size"), ch.size)?,
                        },
                        _ => return Err(cx.err(
                            format!("materials.{name}"),
                            "a diffuse material needs exactly one of `reflectance` or `checker`",
                        )),
                    };
                Material::Diffuse { reflectance: tex }
            }
            MaterialSpec::Mirror { reflectance } => Material::Mirror {
                reflectance: albedo(&cx, &f("reflectance"), *reflectance)?,
            },
            MaterialSpec::Dielectric { ior } => Material::Dielectric {
                ior: cx.positive(&f("ior"), *ior)? as f32,
            },
        };
        material_ids.insert(name.clone(), materials.len() as u32);
        materials.push(m);
    }

    // Shapes.
    let mut b = Builder {
        origin,
        geometry: Geometry::default(),
        tri_info: Vec::new(),
        stats: LoadStats::default(),
        pending_area: Vec::new(),
    };
    let mut sphere_info = Vec::new();
    for (i, shape) in file.shapes.iter().enumerate() {
        let at = format!("shapes[{i}]");
        let material = *material_ids.get(&shape.material).ok_or_else(|| {
            cx.err(
                format!("{at}.material"),
                format!("unknown material '{}'", shape.material),
            )
        })?;
        let emission = match shape.emission {
            Some(e) => cx.non_negative3(&format!("{at}.emission"), e)?,
            None => DVec3::ZERO,
        };
        check_fields(&cx, &at, shape)?;
        let m = placement(&cx, &at, shape)?;
        let info = PrimInfo {
            material,
            light: NO_LIGHT, // set below once the light list is final
            flip: shape.flip_normals.unwrap_or(false),
        };
        let first_tri = b.geometry.triangles.len();
        let first_sphere = b.geometry.spheres.len();
        match shape.kind.as_str() {
            "sphere" => {
                let center = cx.vec3(&format!("{at}.center"), shape.center.unwrap_or([0.0; 3]))?;
                let radius = cx.positive(&format!("{at}.radius"), shape.radius.unwrap_or(1.0))?;
                let scale = similarity_scale(&m).ok_or_else(|| {
                    cx.err(
                        format!("{at}.transform"),
                        "a sphere's placement must be rotation, uniform scale and translation",
                    )
                })?;
                b.push_sphere(m.transform_point3(center), radius * scale);
            }
            "rectangle" => {
                let q = [
                    DVec3::new(-1.0, -1.0, 0.0),
                    DVec3::new(1.0, -1.0, 0.0),
                    DVec3::new(1.0, 1.0, 0.0),
                    DVec3::new(-1.0, 1.0, 0.0),
                ];
                b.push_triangles(&m, &[[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
            }
            "cube" => b.push_triangles(&m, &cube_triangles()),
            "mesh" => {
                let rel = shape.path.as_deref().ok_or_else(|| {
                    cx.err(format!("{at}.path"), "a mesh needs `path` (an OBJ file)")
                })?;
                let full: PathBuf = base.join(rel);
                let bytes = std::fs::read(&full).map_err(|e| {
                    cx.err(
                        format!("{at}.path"),
                        format!("cannot read '{}': {e}", full.display()),
                    )
                })?;
                hash.write(&bytes);
                let tris = read_obj(&full).map_err(|e| {
                    cx.err(format!("{at}.path"), format!("'{}': {e}", full.display()))
                })?;
                b.push_triangles(&m, &tris);
            }
            kind if generators::is_generator(kind) => {
                let count = shape.count.ok_or_else(|| {
                    cx.err(
                        format!("{at}.count"),
                        "a generator needs `count` (its size)",
                    )
                })?;
                if count == 0 {
                    return Err(cx.err(format!("{at}.count"), "must be ≥ 1 (got 0)"));
                }
                let params = GeneratorParams {
                    count,
                    displacement: cx.finite(
                        &format!("{at}.displacement"),
                        shape.displacement.unwrap_or(0.1),
                    )?,
                    triangle_size: cx.positive(
                        &format!("{at}.triangle_size"),
                        shape.triangle_size.unwrap_or(0.05),
                    )?,
                    seed: shape.seed.unwrap_or(0),
                };
                match generators::generate(kind, &params) {
                    Generated::Triangles(t) => b.push_triangles(&m, &t),
                    Generated::Spheres(s) => {
                        let scale = similarity_scale(&m).ok_or_else(|| {
                            cx.err(
                                format!("{at}.transform"),
                                "sphere_grid needs rotation, uniform scale and translation",
                            )
                        })?;
                        for (c, r) in s {
                            b.push_sphere(m.transform_point3(c), r * scale);
                        }
                    }
                }
            }
            other => {
                return Err(cx.err(
                    format!("{at}.type"),
                    format!(
                        "unknown shape type '{other}' (expected sphere, rectangle, cube, mesh, {})",
                        generators::GENERATORS.join(", ")
                    ),
                ))
            }
        }
        let new_spheres = b.geometry.spheres.len() - first_sphere;
        let new_tris = b.geometry.triangles.len() - first_tri;
        sphere_info.extend(std::iter::repeat_n(info, new_spheres));
        b.tri_info.extend(std::iter::repeat_n(info, new_tris));
        if emission != DVec3::ZERO {
            // Sphere prims are renumbered below (spheres first), so record local indices now.
            let prims: Vec<(bool, usize)> = (first_sphere..first_sphere + new_spheres)
                .map(|s| (true, s))
                .chain((first_tri..first_tri + new_tris).map(|t| (false, t)))
                .collect();
            b.pending_area.push((prims, emission.as_vec3()));
        }
    }
    let Builder {
        geometry: mut g,
        tri_info,
        stats,
        pending_area,
        ..
    } = b;
    g.info = sphere_info.into_iter().chain(tri_info).collect();
    let ns = g.spheres.len();

    let mut lights = Vec::new();
    for (prims, radiance) in pending_area {
        let ids: Vec<u32> = prims
            .iter()
            .map(|&(is_sphere, k)| if is_sphere { k as u32 } else { (ns + k) as u32 })
            .collect();
        let mut cdf = Vec::with_capacity(ids.len());
        let mut total = 0.0f32;
        for &(is_sphere, k) in &prims {
            total += if is_sphere {
                g.spheres[k].area()
            } else {
                g.triangles[k].area()
            };
            cdf.push(total);
        }
        if total > 0.0 {
            lights.push(Light::Area {
                prims: ids,
                cdf,
                area: total,
                radiance,
            });
        }
    }

    let mut environment = None;
    for (i, l) in file.lights.iter().enumerate() {
        let at = format!("lights[{i}]");
        match l {
            LightSpec::Point {
                position,
                intensity,
            } => {
                let p = cx.vec3(&format!("{at}.position"), *position)?;
                let i = cx.non_negative3(&format!("{at}.intensity"), *intensity)?;
                lights.push(Light::Point {
                    position: (p - origin).as_vec3(),
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
    // Point each emitting primitive at its light.
    for (li, l) in lights.iter().enumerate() {
        if let Light::Area { prims, .. } = l {
            for &p in prims {
                g.info[p as usize].light = li as u32;
            }
        }
    }

    let features = analyse(&g, &materials, &lights);
    Ok(Scene {
        name: file
            .name
            .clone()
            .unwrap_or_else(|| default_name.to_string()),
        hash: hash.finish(),
        origin,
        camera,
        cameras,
        settings,
        materials,
        geometry: g,
        lights,
        environment,
        features,
        load_stats: stats,
    })
}

/// The most frames an animation may have (a sanity bound: every frame keeps a camera, and a
/// 1-pixel decomposition makes frames·width·height items).
pub const MAX_FRAMES: u32 = 100_000;

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
        cameras.push(cam.with_eye((pose.origin - pose0.origin).as_vec3()));
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

/// Fields that only some shape types take; anything else set on a shape is an error.
fn check_fields(cx: &Ctx, at: &str, s: &ShapeSpec) -> Result<(), SceneError> {
    let set: [(&str, bool); 8] = [
        ("center", s.center.is_some()),
        ("radius", s.radius.is_some()),
        ("flip_normals", s.flip_normals.is_some()),
        ("path", s.path.is_some()),
        ("count", s.count.is_some()),
        ("displacement", s.displacement.is_some()),
        ("triangle_size", s.triangle_size.is_some()),
        ("seed", s.seed.is_some()),
    ];
    let allowed: &[&str] = match s.kind.as_str() {
        "sphere" => &["center", "radius", "flip_normals"],
        "mesh" => &["path"],
        "displaced_sphere" => &["count", "displacement"],
        "random_triangles" => &["count", "triangle_size", "seed"],
        "sphere_grid" => &["count"],
        _ => &[],
    };
    for (name, is_set) in set {
        if is_set && !allowed.contains(&name) {
            return Err(cx.err(
                format!("{at}.{name}"),
                format!("does not apply to a shape of type '{}'", s.kind),
            ));
        }
    }
    Ok(())
}

/// The shape's placement matrix: `transform` steps multiplied left to right (so the last step
/// applies first, as in `T·R·S`), or an explicit row-major `matrix`.
fn placement(cx: &Ctx, at: &str, s: &ShapeSpec) -> Result<DMat4, SceneError> {
    let m = match (&s.transform, &s.matrix) {
        (Some(_), Some(_)) => {
            return Err(cx.err(
                format!("{at}.matrix"),
                "give either `transform` or `matrix`, not both",
            ))
        }
        (None, Some(rows)) => {
            for (r, row) in rows.iter().enumerate() {
                for x in row {
                    cx.finite(&format!("{at}.matrix[{r}]"), *x)?;
                }
            }
            let m = DMat4::from_cols_array_2d(rows).transpose();
            if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
                return Err(cx.err(format!("{at}.matrix"), "last row must be [0, 0, 0, 1]"));
            }
            m
        }
        (Some(steps), None) => {
            let mut m = DMat4::IDENTITY;
            for (k, step) in steps.iter().enumerate() {
                let f = format!("{at}.transform[{k}]");
                m *= match step {
                    TransformStep::Translate(t) => DMat4::from_translation(cx.vec3(&f, *t)?),
                    TransformStep::Rotate { axis, deg } => {
                        let a = cx.vec3(&format!("{f}.axis"), *axis)?;
                        if a.length() == 0.0 {
                            return Err(cx.err(format!("{f}.axis"), "must be non-zero"));
                        }
                        let d = cx.finite(&format!("{f}.deg"), *deg)?;
                        DMat4::from_axis_angle(a.normalize(), d.to_radians())
                    }
                    TransformStep::Scale(ScaleSpec::Uniform(x)) => {
                        DMat4::from_scale(DVec3::splat(cx.finite(&f, *x)?))
                    }
                    TransformStep::Scale(ScaleSpec::PerAxis(v)) => {
                        DMat4::from_scale(cx.vec3(&f, *v)?)
                    }
                };
            }
            m
        }
        (None, None) => DMat4::IDENTITY,
    };
    let field = if s.matrix.is_some() {
        "matrix"
    } else {
        "transform"
    };
    if m.determinant() == 0.0 || !m.determinant().is_finite() {
        return Err(cx.err(format!("{at}.{field}"), "is singular (a scale of 0?)"));
    }
    Ok(m)
}

/// Uniform scale factor of a rotation·scale·translation matrix, or `None` for shear or
/// non-uniform scale.
fn similarity_scale(m: &DMat4) -> Option<f64> {
    let l = DMat3::from_mat4(*m);
    let (a, b, c) = (l.x_axis, l.y_axis, l.z_axis);
    let s = a.length();
    let tol = 1e-9 * s;
    let ok = (b.length() - s).abs() <= tol
        && (c.length() - s).abs() <= tol
        && a.dot(b).abs() <= tol * s
        && a.dot(c).abs() <= tol * s
        && b.dot(c).abs() <= tol * s;
    ok.then_some(s)
}

fn cube_triangles() -> Vec<[DVec3; 3]> {
    let mut tris = Vec::with_capacity(12);
    // For each axis and sign, a face with outward normal sign·e_axis.
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let n = DVec3::AXES[axis] * sign;
            let u = DVec3::AXES[(axis + 1) % 3];
            let v = n.cross(u); // u × v = n: counter-clockwise seen from outside
            let c = |a: f64, b: f64| n + u * a + v * b;
            let q = [c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0)];
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
    }
    tris
}

fn read_obj(path: &Path) -> Result<Vec<[DVec3; 3]>, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| e.to_string())?;
    let mut tris = Vec::new();
    for m in models {
        let pos = &m.mesh.positions;
        let v = |i: u32| {
            let i = i as usize * 3;
            DVec3::new(pos[i] as f64, pos[i + 1] as f64, pos[i + 2] as f64)
        };
        for f in m.mesh.indices.chunks_exact(3) {
            tris.push([v(f[0]), v(f[1]), v(f[2])]);
        }
    }
    if tris.is_empty() {
        return Err("the OBJ file has no triangles".into());
    }
    Ok(tris)
}

struct Builder {
    origin: DVec3,
    geometry: Geometry,
    tri_info: Vec<PrimInfo>,
    stats: LoadStats,
    #[allow(clippy::type_complexity)]
    pending_area: Vec<(Vec<(bool, usize)>, Vec3)>,
}

impl Builder {
    fn push_sphere(&mut self, center: DVec3, radius: f64) {
        self.geometry.spheres.push(Sphere {
            center: (center - self.origin).as_vec3(),
            radius: radius as f32,
        });
    }

    /// Place local triangles, keep their facing under mirroring transforms, move them to
    /// render space, and drop (and count) those with zero area after rounding to f32.
    fn push_triangles(&mut self, m: &DMat4, tris: &[[DVec3; 3]]) {
        let flip = m.determinant() < 0.0;
        for t in tris {
            let [a, b, c] = t.map(|p| (m.transform_point3(p) - self.origin).as_vec3());
            let tri = if flip {
                Triangle::new(a, c, b)
            } else {
                Triangle::new(a, b, c)
            };
            let area = tri.area();
            if area > 0.0 && area.is_finite() {
                self.geometry.triangles.push(tri);
            } else {
                self.stats.degenerate_triangles += 1;
            }
        }
    }
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
