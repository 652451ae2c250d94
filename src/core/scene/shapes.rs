//! Stage two for `[[shapes]]`: each shape checked, placed and moved to render space, its
//! primitives tagged with their material, and emitting shapes gathered into area lights.

use super::check::{Ctx, SceneError};
use super::format::{ScaleSpec, ShapeSpec, TransformStep};
use super::gltf::{read_gltf, MappedSurface};
use super::{generators, Geometry, Light, LoadStats, Material, PrimInfo, Texture, NO_LIGHT};
use crate::core::geometry::{Sphere, Triangle};
use crate::util::hash::Fnv64;
use crate::util::limits::{MAX_GENERATOR_COUNT, MAX_PRIMITIVES};
use glam::{DMat3, DMat4, DVec3, DVec4, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What the shapes of a scene became.
pub(super) struct Shapes {
    /// `info` included: spheres first, then triangles.
    pub geometry: Geometry,
    /// One per emitting shape with a positive area, not yet linked from `geometry.info`.
    pub area_lights: Vec<Light>,
    pub stats: LoadStats,
    /// Materials the model files brought (glTF), ids following the scene file's.
    pub file_materials: Vec<Material>,
    /// What model files hold that is not rendered, as left-out feature names.
    pub ignored: std::collections::BTreeSet<String>,
}

/// Where the shapes go, and what the shape loop needs to know about the scene.
pub(super) struct Builder<'a> {
    pub cx: &'a Ctx<'a>,
    /// World position of render space's origin.
    pub origin: DVec3,
    pub material_ids: &'a BTreeMap<String, u32>,
    /// Folder mesh paths are relative to.
    pub base: &'a Path,
    geometry: Geometry,
    sphere_info: Vec<PrimInfo>,
    tri_info: Vec<PrimInfo>,
    stats: LoadStats,
    /// Per emitting shape: its primitives as (is_sphere, index among its kind), radiance.
    #[allow(clippy::type_complexity)]
    pending_area: Vec<(Vec<(bool, usize)>, Vec3)>,
    /// Primitives counted so far by [`Self::reserve`].
    primitives: u64,
    file_materials: Vec<Material>,
    ignored: std::collections::BTreeSet<String>,
}

impl<'a> Builder<'a> {
    pub(crate) fn new(
        cx: &'a Ctx<'a>,
        origin: DVec3,
        material_ids: &'a BTreeMap<String, u32>,
        base: &'a Path,
    ) -> Self {
        Self {
            cx,
            origin,
            material_ids,
            base,
            geometry: Geometry::default(),
            sphere_info: Vec::new(),
            tri_info: Vec::new(),
            stats: LoadStats::default(),
            pending_area: Vec::new(),
            primitives: 0,
            file_materials: Vec::new(),
            ignored: Default::default(),
        }
    }

    /// Check and add shape `at` (`shapes[i]`); mesh files read are fed to `hash`.
    pub(crate) fn add(
        &mut self,
        at: &str,
        shape: &ShapeSpec,
        hash: &mut Fnv64,
    ) -> Result<(), SceneError> {
        let cx = self.cx;
        let material = match shape.material() {
            Some(name) => Some(*self.material_ids.get(name).ok_or_else(|| {
                cx.err(
                    format!("{at}.material"),
                    format!(
                        "unknown material '{name}'{}",
                        crate::util::suggest::did_you_mean(
                            name,
                            self.material_ids.keys().map(String::as_str)
                        )
                    ),
                )
            })?),
            None => None,
        };
        let emission = match shape.emission() {
            Some(e) => cx.non_negative3(&format!("{at}.emission"), e)?,
            None => DVec3::ZERO,
        };
        let m = placement(cx, at, shape)?;
        if let ShapeSpec::Gltf { path, .. } = shape {
            return self.add_gltf(at, path.as_deref(), material, emission, &m, hash);
        }
        let material = material.expect("only a gltf shape may leave out `material`");
        let info = PrimInfo {
            material,
            light: NO_LIGHT, // set once the light list is final
            flip: matches!(
                shape,
                ShapeSpec::Sphere {
                    flip_normals: Some(true),
                    ..
                }
            ),
        };
        let first = (self.geometry.spheres.len(), self.geometry.triangles.len());
        self.add_primitives(at, shape, &m, hash)?;
        self.tag_since(first, info, emission);
        Ok(())
    }

    fn add_primitives(
        &mut self,
        at: &str,
        shape: &ShapeSpec,
        m: &DMat4,
        hash: &mut Fnv64,
    ) -> Result<(), SceneError> {
        let cx = self.cx;
        let field = |f: &str| format!("{at}.{f}");
        match shape {
            ShapeSpec::Sphere { center, radius, .. } => {
                let center = cx.vec3(&field("center"), center.unwrap_or([0.0; 3]))?;
                // No default: a sphere's size is the scene's to state (a missing radius once
                // rendered a unit sphere the author had not asked for).
                let Some(radius) = *radius else {
                    return Err(cx.err(
                        field("radius"),
                        "missing (a sphere needs its radius, > 0, in local units)",
                    ));
                };
                let radius = cx.positive(&field("radius"), radius)?;
                let what = "a sphere's placement must be rotation, uniform scale and translation";
                let scale = similarity_scale(cx, at, m, what)?;
                self.reserve(&field("type"), 1)?;
                self.push_sphere(at, m.transform_point3(center), radius * scale)?;
            }
            ShapeSpec::Rectangle { .. } => {
                let tris = rectangle_triangles();
                self.reserve(&field("type"), tris.len() as u64)?;
                self.push_triangles(at, m, &tris)?
            }
            ShapeSpec::Cube { .. } => {
                let tris = cube_triangles();
                self.reserve(&field("type"), tris.len() as u64)?;
                self.push_triangles(at, m, &tris)?
            }
            ShapeSpec::Mesh { path, .. } => {
                let tris = load_mesh(cx, at, path.as_deref(), self.base, hash)?;
                self.reserve(&field("path"), tris.len() as u64)?;
                self.push_triangles(at, m, &tris)?;
            }
            ShapeSpec::Ply { path, .. } => {
                let full = model_path(cx, at, path.as_deref(), self.base, "a PLY file")?;
                let tris = super::ply::read_ply(&full, hash)
                    .map_err(|e| cx.err(field("path"), format!("'{}': {e}", full.display())))?;
                self.reserve(&field("path"), tris.len() as u64)?;
                self.push_triangles(at, m, &tris)?;
            }
            ShapeSpec::Gltf { .. } => unreachable!("gltf shapes are added by add_gltf"),
            ShapeSpec::DisplacedSphere {
                count,
                displacement,
                ..
            } => {
                let count = generator_count(cx, at, *count)?;
                self.reserve(&field("count"), count)?;
                let d = cx.finite(&field("displacement"), displacement.unwrap_or(0.1))?;
                self.push_triangles(at, m, &generators::displaced_sphere(count, d))?;
            }
            ShapeSpec::RandomTriangles {
                count,
                triangle_size,
                seed,
                ..
            } => {
                let count = generator_count(cx, at, *count)?;
                self.reserve(&field("count"), count)?;
                let size = cx.positive(&field("triangle_size"), triangle_size.unwrap_or(0.05))?;
                let tris = generators::random_triangles(count, size, seed.unwrap_or(0));
                self.push_triangles(at, m, &tris)?;
            }
            ShapeSpec::SphereGrid { count, .. } => {
                let count = generator_count(cx, at, *count)?;
                self.reserve(&field("count"), count)?;
                let what = "sphere_grid needs rotation, uniform scale and translation";
                let scale = similarity_scale(cx, at, m, what)?;
                for (c, r) in generators::sphere_grid(count) {
                    self.push_sphere(at, m.transform_point3(c), r * scale)?;
                }
            }
        }
        Ok(())
    }

    /// Add the triangles of a glTF file: one material per glTF material (or `material` for
    /// all), one area light per emitting part (or one for the whole shape with `emission`).
    fn add_gltf(
        &mut self,
        at: &str,
        path: Option<&str>,
        material: Option<u32>,
        emission: DVec3,
        m: &DMat4,
        hash: &mut Fnv64,
    ) -> Result<(), SceneError> {
        let cx = self.cx;
        let full = model_path(cx, at, path, self.base, "a .gltf or .glb file")?;
        let mesh = read_gltf(&full, hash)
            .map_err(|e| cx.err(format!("{at}.path"), format!("'{}': {e}", full.display())))?;
        self.ignored.extend(mesh.ignored.iter().cloned());
        let base_id = (self.material_ids.len() + self.file_materials.len()) as u32;
        if material.is_some() && mesh.has_materials {
            self.ignored.insert("gltf_materials".into());
        }
        let mut used = vec![None; mesh.materials.len()];
        let shape_first = self.counts();
        for part in &mesh.parts {
            let id = match material {
                Some(id) => id,
                None => *used[part.material].get_or_insert_with(|| {
                    let surface = match mesh.materials[part.material].surface {
                        MappedSurface::Diffuse(c) => Material::Diffuse {
                            reflectance: Texture::Constant(c),
                        },
                        MappedSurface::Mirror(c) => Material::Mirror { reflectance: c },
                        MappedSurface::Dielectric(ior) => Material::Dielectric { ior },
                    };
                    self.file_materials.push(surface);
                    base_id + self.file_materials.len() as u32 - 1
                }),
            };
            let first = self.counts();
            self.reserve(&format!("{at}.path"), part.triangles.len() as u64)?;
            self.push_triangles(at, m, &part.triangles)?;
            let info = PrimInfo {
                material: id,
                light: NO_LIGHT,
                flip: false,
            };
            // The file's emission counts only where neither `material` nor `emission` of the
            // shape replaces it.
            let part_emission = if material.is_none() && emission == DVec3::ZERO {
                mesh.materials[part.material].emission
            } else {
                DVec3::ZERO
            };
            self.tag_since(first, info, part_emission);
        }
        if emission != DVec3::ZERO {
            self.queue_area(shape_first, emission);
        }
        Ok(())
    }

    /// (spheres, triangles) added so far.
    fn counts(&self) -> (usize, usize) {
        (self.geometry.spheres.len(), self.geometry.triangles.len())
    }

    /// Give the primitives added since `first` (spheres, triangles) their `info`, and queue
    /// them as one area light when the shape emits.
    fn tag_since(&mut self, first: (usize, usize), info: PrimInfo, emission: DVec3) {
        let (first_sphere, first_tri) = first;
        let new_spheres = self.geometry.spheres.len() - first_sphere;
        let new_tris = self.geometry.triangles.len() - first_tri;
        self.sphere_info
            .extend(std::iter::repeat_n(info, new_spheres));
        self.tri_info.extend(std::iter::repeat_n(info, new_tris));
        if emission != DVec3::ZERO {
            self.queue_area(first, emission);
        }
    }

    /// Queue the primitives added since `first` as one area light of radiance `emission`.
    fn queue_area(&mut self, first: (usize, usize), emission: DVec3) {
        let (first_sphere, first_tri) = first;
        let new_spheres = self.geometry.spheres.len() - first_sphere;
        let new_tris = self.geometry.triangles.len() - first_tri;
        // Sphere prims are renumbered at the end (spheres first), so record local indices.
        let prims: Vec<(bool, usize)> = (first_sphere..first_sphere + new_spheres)
            .map(|s| (true, s))
            .chain((first_tri..first_tri + new_tris).map(|t| (false, t)))
            .collect();
        self.pending_area.push((prims, emission.as_vec3()));
    }

    /// Count `n` more primitives against [`MAX_PRIMITIVES`] before they are made; an error
    /// on `field` (the size knob) when the scene would exceed it.
    fn reserve(&mut self, field: &str, n: u64) -> Result<(), SceneError> {
        let total = self.primitives.saturating_add(n);
        if total > MAX_PRIMITIVES {
            return Err(self.cx.err(
                field,
                format!(
                    "{n} more primitives would make {total} in the scene, more than the limit \
                 of {MAX_PRIMITIVES}"
                ),
            ));
        }
        self.primitives = total;
        Ok(())
    }

    fn push_sphere(&mut self, at: &str, center: DVec3, radius: f64) -> Result<(), SceneError> {
        let center = self
            .cx
            .placed(&format!("{at}.center"), center - self.origin)?;
        let radius = radius as f32;
        if !(radius.is_finite() && radius > 0.0) {
            return Err(self.cx.err(
                format!("{at}.radius"),
                format!("placed radius {radius} is not a positive f32 (|x| ≤ 3.4e38)"),
            ));
        }
        self.geometry.spheres.push(Sphere { center, radius });
        Ok(())
    }

    /// Place local triangles, keep their facing under mirroring transforms, move them to
    /// render space, and drop (and count) those with zero area after rounding to f32. A vertex
    /// the placement takes out of f32's range is an error on `at`'s placement.
    fn push_triangles(
        &mut self,
        at: &str,
        m: &DMat4,
        tris: &[[DVec3; 3]],
    ) -> Result<(), SceneError> {
        let flip = m.determinant() < 0.0;
        for t in tris {
            let placed = t.map(|p| m.transform_point3(p) - self.origin);
            let [a, b, c] = placed.map(|p| p.as_vec3());
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                let bad = placed.into_iter().find(|p| !p.as_vec3().is_finite());
                return Err(self.cx.err(
                    format!("{at}.transform"),
                    format!(
                        "places a vertex at {}, outside f32's range (|x| ≤ 3.4e38)",
                        bad.unwrap_or_default()
                    ),
                ));
            }
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
        Ok(())
    }

    /// Number the primitives (spheres first) and turn the emitting shapes into area lights.
    pub(crate) fn finish(self) -> Shapes {
        let mut geometry = self.geometry;
        geometry.info = self.sphere_info.into_iter().chain(self.tri_info).collect();
        let area_lights = self
            .pending_area
            .into_iter()
            .filter_map(|(prims, radiance)| area_light(&geometry, &prims, radiance))
            .collect();
        Shapes {
            geometry,
            area_lights,
            stats: self.stats,
            file_materials: self.file_materials,
            ignored: self.ignored,
        }
    }
}

/// The area light of one emitting shape (`None` when its area is zero).
fn area_light(g: &Geometry, prims: &[(bool, usize)], radiance: Vec3) -> Option<Light> {
    let ns = g.spheres.len();
    let ids: Vec<u32> = prims
        .iter()
        .map(|&(is_sphere, k)| if is_sphere { k as u32 } else { (ns + k) as u32 })
        .collect();
    let mut cdf = Vec::with_capacity(ids.len());
    let mut total = 0.0f32;
    for &(is_sphere, k) in prims {
        total += if is_sphere {
            g.spheres[k].area()
        } else {
            g.triangles[k].area()
        };
        cdf.push(total);
    }
    (total > 0.0).then_some(Light::Area {
        prims: ids,
        cdf,
        area: total,
        radiance,
    })
}

/// The `count` of a generator shape: required, ≥ 1.
fn generator_count(cx: &Ctx, at: &str, count: Option<u64>) -> Result<u64, SceneError> {
    let field = format!("{at}.count");
    match count {
        None => Err(cx.err(field, "a generator needs `count` (its size)")),
        Some(n) if (1..=MAX_GENERATOR_COUNT).contains(&n) => Ok(n),
        Some(n) => Err(cx.err(
            field,
            format!("must be in 1..={MAX_GENERATOR_COUNT} (got {n})"),
        )),
    }
}

/// The file of model shape `at` (`what` names its kind in the error when `path` is missing).
fn model_path(
    cx: &Ctx,
    at: &str,
    path: Option<&str>,
    base: &Path,
    what: &str,
) -> Result<PathBuf, SceneError> {
    let rel = path.ok_or_else(|| cx.err(format!("{at}.path"), format!("needs `path` ({what})")))?;
    Ok(base.join(rel))
}

/// The triangles of mesh `at`'s OBJ file; its bytes are fed to `hash`.
fn load_mesh(
    cx: &Ctx,
    at: &str,
    path: Option<&str>,
    base: &Path,
    hash: &mut Fnv64,
) -> Result<Vec<[DVec3; 3]>, SceneError> {
    let field = format!("{at}.path");
    let rel = path.ok_or_else(|| cx.err(&field, "a mesh needs `path` (an OBJ file)"))?;
    let full: PathBuf = base.join(rel);
    let bytes = std::fs::read(&full)
        .map_err(|e| cx.err(&field, format!("cannot read '{}': {e}", full.display())))?;
    hash.write(&bytes);
    read_obj(&bytes).map_err(|e| cx.err(&field, format!("'{}': {e}", full.display())))
}

/// The shape's placement matrix: `transform` steps multiplied left to right (so the last step
/// applies first, as in `T·R·S`), or an explicit row-major `matrix`.
fn placement(cx: &Ctx, at: &str, s: &ShapeSpec) -> Result<DMat4, SceneError> {
    let m = match (s.transform(), s.matrix()) {
        (Some(_), Some(_)) => {
            return Err(cx.err(
                format!("{at}.matrix"),
                "give either `transform` or `matrix`, not both",
            ))
        }
        (None, Some(rows)) => matrix_placement(cx, at, rows)?,
        (Some(steps), None) => transform_placement(cx, at, steps)?,
        (None, None) => DMat4::IDENTITY,
    };
    let field = if s.matrix().is_some() {
        "matrix"
    } else {
        "transform"
    };
    if m.determinant() == 0.0 || !m.determinant().is_finite() {
        return Err(cx.err(format!("{at}.{field}"), "is singular (a scale of 0?)"));
    }
    Ok(m)
}

fn matrix_placement(cx: &Ctx, at: &str, rows: &[[f64; 4]; 4]) -> Result<DMat4, SceneError> {
    for (r, row) in rows.iter().enumerate() {
        for x in row {
            cx.finite(&format!("{at}.matrix[{r}]"), *x)?;
        }
    }
    let m = DMat4::from_cols_array_2d(rows).transpose();
    if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err(cx.err(format!("{at}.matrix"), "last row must be [0, 0, 0, 1]"));
    }
    Ok(m)
}

fn transform_placement(cx: &Ctx, at: &str, steps: &[TransformStep]) -> Result<DMat4, SceneError> {
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
            TransformStep::Scale(ScaleSpec::PerAxis(v)) => DMat4::from_scale(cx.vec3(&f, *v)?),
        };
    }
    Ok(m)
}

/// Uniform scale factor of a rotation·scale·translation matrix; shear or non-uniform scale is
/// an error on `at.transform` saying `what`.
fn similarity_scale(cx: &Ctx, at: &str, m: &DMat4, what: &str) -> Result<f64, SceneError> {
    let l = DMat3::from_mat4(*m);
    let (a, b, c) = (l.x_axis, l.y_axis, l.z_axis);
    let s = a.length();
    let tol = 1e-9 * s;
    let ok = (b.length() - s).abs() <= tol
        && (c.length() - s).abs() <= tol
        && a.dot(b).abs() <= tol * s
        && a.dot(c).abs() <= tol * s
        && b.dot(c).abs() <= tol * s;
    if ok {
        Ok(s)
    } else {
        Err(cx.err(format!("{at}.transform"), what))
    }
}

fn rectangle_triangles() -> [[DVec3; 3]; 2] {
    let q = [
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 0.0),
    ];
    [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
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

/// OBJ text as tobj reads it: UTF-16 (with its byte-order mark) decoded, invalid UTF-8 replaced
/// (tobj stops at the first undecodable line), and `mtllib`/`usemtl` lines dropped: a mesh
/// shape takes its material from the scene, and a missing `.mtl` file or an empty `usemtl`
/// would otherwise fail the whole file.
fn obj_text(bytes: &[u8]) -> String {
    let utf16 = |be: bool| {
        let units: Vec<u16> = bytes[2..]
            .chunks_exact(2)
            .map(|c| {
                if be {
                    u16::from_be_bytes([c[0], c[1]])
                } else {
                    u16::from_le_bytes([c[0], c[1]])
                }
            })
            .collect();
        String::from_utf16_lossy(&units)
    };
    let text = match bytes {
        [0xFE, 0xFF, ..] => utf16(true),
        [0xFF, 0xFE, ..] => utf16(false),
        _ => String::from_utf8_lossy(bytes).into_owned(),
    };
    text.lines()
        .filter(|l| {
            let w = l.split_whitespace().next();
            w != Some("mtllib") && w != Some("usemtl")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn read_obj(bytes: &[u8]) -> Result<Vec<[DVec3; 3]>, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let text = obj_text(bytes);
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| Ok(Default::default()))
        .map_err(|e| e.to_string())?;
    if models
        .iter()
        .any(|m| m.mesh.positions.iter().any(|x| !x.is_finite()))
    {
        return Err(non_finite_vertex(&text));
    }
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

/// Where an OBJ file's first non-finite vertex is (`line N: …`): tobj reads coordinates as f32
/// without saying where, so a NaN, an infinity or a value beyond f32's range (1e39) is found
/// again here, by line.
fn non_finite_vertex(text: &str) -> String {
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        for w in words.take(3) {
            if !w.parse::<f32>().is_ok_and(f32::is_finite) {
                return format!(
                    "line {}: vertex coordinate '{w}' is not a finite number within f32's range",
                    i + 1
                );
            }
        }
    }
    "a vertex coordinate is not a finite number within f32's range".into()
}
