//! The raw scene file as written by a user (stage one of loading). Every struct rejects unknown
//! fields; nothing here is validated yet: [`super::load`] turns it into a [`super::Scene`].
//!
//! ```toml
//! [camera]
//! origin = [0, 0, 4]
//! target = [0, 0, 0]
//! up = [0, 1, 0]
//! fov_deg = 40
//! width = 64
//! height = 64
//!
//! [render]
//! spp = 16
//! max_depth = 8     # path segments; -1 = unlimited
//! seed = 1
//!
//! [materials.white]
//! type = "diffuse"
//! reflectance = [0.8, 0.8, 0.8]
//!
//! [[shapes]]
//! type = "rectangle"
//! material = "white"
//! emission = [4, 4, 4]                  # optional: makes the shape an area light
//! transform = [{ translate = [0, 1, 0] }, { rotate = { axis = [1, 0, 0], deg = 90 } }, { scale = 0.5 }]
//!
//! [[lights]]
//! type = "environment"
//! radiance = [1, 1, 1]
//!
//! # optional: an animation. `[camera]` is the pose of frame 0; each key sets the pose at its
//! # frame (fields it leaves out keep the previous key's value); frames between keys are
//! # linear interpolations, frames after the last key hold it.
//! [animation]
//! frames = 8
//! [[animation.keys]]
//! frame = 7
//! origin = [0, 0, 2.9]
//! ```

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A scene file as parsed from TOML, before validation.
#[derive(Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Scene name; when absent, the loader's default name (the file's stem).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// `[camera]`: the view of a static scene, and frame 0's pose in an animation.
    pub camera: CameraSpec,
    /// `[render]`: sampling settings (defaults when absent).
    #[serde(default)]
    pub render: RenderSpec,
    /// `[materials.NAME]` by name; a material's id is its index in name order.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// `[[shapes]]`, in file order.
    #[serde(default, deserialize_with = "shapes_by_index")]
    pub shapes: Vec<ShapeSpec>,
    /// `[[lights]]`: point and environment lights (area lights come from emitting shapes).
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    /// `[animation]`: a camera path; absent for a static scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation: Option<AnimationSpec>,
}

// By hand, not derived: the scene hash is FNV over this text, and a scene without
// `[animation]` must keep the hash it had before animations existed (results CSVs key on it).
impl std::fmt::Debug for SceneFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("SceneFile");
        d.field("name", &self.name)
            .field("camera", &self.camera)
            .field("render", &self.render)
            .field("materials", &self.materials)
            .field("shapes", &self.shapes)
            .field("lights", &self.lights);
        if let Some(a) = &self.animation {
            d.field("animation", a);
        }
        d.finish()
    }
}

/// A camera path: `frames` frames, frame 0 posed by `[camera]`, later poses by `keys`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AnimationSpec {
    /// Number of frames, 1 to [`super::load::MAX_FRAMES`].
    pub frames: u32,
    /// Camera keys after frame 0, in increasing frame order.
    #[serde(default)]
    pub keys: Vec<CameraKeySpec>,
}

/// The camera pose at frame `frame`; a field left out keeps the previous key's value (the
/// first key's previous is `[camera]`).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKeySpec {
    /// The frame this key poses: after the previous key's, before `frames`.
    pub frame: u32,
    /// Camera position in world space.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "exactly_3_opt"
    )]
    pub origin: Option<[f64; 3]>,
    /// Point looked at, in world space.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "exactly_3_opt"
    )]
    pub target: Option<[f64; 3]>,
    /// Up direction.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "exactly_3_opt"
    )]
    pub up: Option<[f64; 3]>,
    /// Field of view in degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov_deg: Option<f64>,
}

/// `[camera]`: a pinhole camera at `origin` looking at `target`, in world space.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Camera position; it becomes the render-space origin.
    #[serde(deserialize_with = "exactly_3")]
    pub origin: [f64; 3],
    /// Point looked at; must differ from `origin`.
    #[serde(deserialize_with = "exactly_3")]
    pub target: [f64; 3],
    /// Up direction; must not be zero or parallel to the view direction.
    #[serde(deserialize_with = "exactly_3")]
    pub up: [f64; 3],
    /// Field of view in degrees, in (0, 180), across the smaller film side.
    pub fov_deg: f64,
    /// Image width in pixels (≥ 1).
    pub width: u32,
    /// Image height in pixels (≥ 1).
    pub height: u32,
}

/// A vector of exactly 3 numbers: serde reads a plain struct field `[f64; 3]` from a longer
/// TOML array without a word (tagged enums already check the length).
fn exactly_3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    let n = v.len();
    <[f64; 3]>::try_from(v)
        .map_err(|_| serde::de::Error::invalid_length(n, &"an array of exactly 3 numbers"))
}

fn exactly_3_opt<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    exactly_3(d).map(Some)
}

/// `[render]`: sampling and transport settings.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Samples per pixel (≥ 1; default 16).
    #[serde(default = "default_spp")]
    pub spp: u32,
    /// Maximum path segments, the one reaching an emitter included; −1 = unlimited (default 8).
    #[serde(default = "default_max_depth")]
    pub max_depth: i32,
    /// Seed of every random number of the render (default 0).
    #[serde(default)]
    pub seed: u64,
}

const fn default_spp() -> u32 {
    16
}
const fn default_max_depth() -> i32 {
    8
}

impl Default for RenderSpec {
    fn default() -> Self {
        Self {
            spp: default_spp(),
            max_depth: default_max_depth(),
            seed: 0,
        }
    }
}

/// `[materials.NAME]`, by `type`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialSpec {
    /// Lambertian, one-sided; exactly one of `reflectance` and `checker`.
    Diffuse {
        /// Constant albedo, each channel in [0, 1].
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reflectance: Option<[f64; 3]>,
        /// A checkerboard albedo.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        checker: Option<CheckerSpec>,
    },
    /// Perfect specular reflection, one-sided.
    Mirror {
        /// Reflected fraction, each channel in [0, 1] (default 1).
        #[serde(default = "one3")]
        reflectance: [f64; 3],
    },
    /// Smooth dielectric (two-sided).
    Dielectric {
        /// Interior index of refraction (> 0); the exterior's is 1.
        ior: f64,
    },
}

fn one3() -> [f64; 3] {
    [1.0; 3]
}

/// `even` where ⌊x/size⌋ + ⌊y/size⌋ is even (world x, y), else `odd`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerSpec {
    /// Albedo of the even cells, each channel in [0, 1].
    pub even: [f64; 3],
    /// Albedo of the odd cells, each channel in [0, 1].
    pub odd: [f64; 3],
    /// Cell edge length in world units (> 0).
    pub size: f64,
}

/// One shape, by `type`; each type takes exactly its fields. Every type has `material`, an
/// optional `emission` (making it an area light) and an optional placement (`transform` or
/// `matrix`); a field left out is `None` (defaults are the loader's). `None` fields are not
/// written back (TOML has no null).
#[derive(Clone, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// Centre `[0, 0, 0]` unless given, `radius` required; `flip_normals` points normals inwards.
    Sphere {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// Centre in local space (default `[0, 0, 0]`).
        center: Option<[f64; 3]>,
        /// Radius in local units (> 0; required).
        radius: Option<f64>,
        /// Normals point inwards (default false).
        flip_normals: Option<bool>,
    },
    /// The square [−1,1]² at z = 0, facing +z.
    Rectangle {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
    },
    /// The cube [−1,1]³, facing out.
    Cube {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
    },
    /// The triangles of an OBJ file, `path` relative to the scene file.
    Mesh {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// The OBJ file, relative to the scene file's folder (required).
        path: Option<String>,
    },
    /// The triangles of a glTF 2.0 file (`.gltf` with its buffers, or `.glb`), `path` relative
    /// to the scene file: the default scene's nodes with their transforms, under this shape's
    /// own placement. Materials come from the file ([`super::gltf`] states the mapping) unless
    /// `material` overrides them all.
    Gltf {
        /// Name of a `[materials]` entry that replaces every material of the file; `None`
        /// maps the file's own materials.
        material: Option<String>,
        /// Radiance from the front side (each channel ≥ 0); makes the whole shape one area
        /// light, replacing the file's emissive materials.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// The `.gltf` or `.glb` file, relative to the scene file's folder (required).
        path: Option<String>,
    },
    /// The faces of a PLY file (ASCII or binary), `path` relative to the scene file; polygons
    /// are split into triangle fans ([`super::ply`]).
    Ply {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// The PLY file, relative to the scene file's folder (required).
        path: Option<String>,
    },
    /// [`super::generators::displaced_sphere`]: about `count` triangles.
    DisplacedSphere {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// Approximate triangle count (required, ≥ 1).
        count: Option<u64>,
        /// Relative amplitude of the radial bumps (default 0.1).
        displacement: Option<f64>,
    },
    /// [`super::generators::random_triangles`]: `count` triangles.
    RandomTriangles {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// Number of triangles (required, ≥ 1).
        count: Option<u64>,
        /// Approximate edge length in local units (> 0; default 0.05).
        triangle_size: Option<f64>,
        /// Seed of the triangles' placement (default 0).
        seed: Option<u64>,
    },
    /// [`super::generators::sphere_grid`]: `count` spheres.
    SphereGrid {
        /// Name of a `[materials]` entry.
        material: String,
        /// Radiance from the front side (each channel ≥ 0); makes the shape an area light.
        emission: Option<[f64; 3]>,
        /// Placement as steps multiplied left to right, so the last applies first (`T·R·S`).
        transform: Option<Vec<TransformStep>>,
        /// Placement as a row-major 4×4 affine matrix (last row `[0, 0, 0, 1]`).
        matrix: Option<[[f64; 4]; 4]>,
        /// Number of spheres (required, ≥ 1).
        count: Option<u64>,
    },
}

/// `$body` over the fields every shape type has, bound by name whatever the variant.
macro_rules! common_fields {
    ($shape:expr, $($field:ident),+ => $body:expr) => {
        match $shape {
            ShapeSpec::Sphere { $($field,)+ .. }
            | ShapeSpec::Rectangle { $($field,)+ .. }
            | ShapeSpec::Cube { $($field,)+ .. }
            | ShapeSpec::Mesh { $($field,)+ .. }
            | ShapeSpec::Gltf { $($field,)+ .. }
            | ShapeSpec::Ply { $($field,)+ .. }
            | ShapeSpec::DisplacedSphere { $($field,)+ .. }
            | ShapeSpec::RandomTriangles { $($field,)+ .. }
            | ShapeSpec::SphereGrid { $($field,)+ .. } => $body,
        }
    };
}

/// Every shape `type`, in declaration order.
pub const SHAPE_TYPES: &[&str] = &[
    "sphere",
    "rectangle",
    "cube",
    "mesh",
    "gltf",
    "ply",
    "displaced_sphere",
    "random_triangles",
    "sphere_grid",
];

impl ShapeSpec {
    /// The `type` as written in the file.
    pub fn type_name(&self) -> &'static str {
        match self {
            ShapeSpec::Sphere { .. } => "sphere",
            ShapeSpec::Rectangle { .. } => "rectangle",
            ShapeSpec::Cube { .. } => "cube",
            ShapeSpec::Mesh { .. } => "mesh",
            ShapeSpec::Gltf { .. } => "gltf",
            ShapeSpec::Ply { .. } => "ply",
            ShapeSpec::DisplacedSphere { .. } => "displaced_sphere",
            ShapeSpec::RandomTriangles { .. } => "random_triangles",
            ShapeSpec::SphereGrid { .. } => "sphere_grid",
        }
    }
    /// The `material` field, whatever the type; `None` only for a `gltf` shape that keeps
    /// the file's own materials.
    pub fn material(&self) -> Option<&str> {
        match self {
            ShapeSpec::Gltf { material, .. } => material.as_deref(),
            ShapeSpec::Sphere { material, .. }
            | ShapeSpec::Rectangle { material, .. }
            | ShapeSpec::Cube { material, .. }
            | ShapeSpec::Mesh { material, .. }
            | ShapeSpec::Ply { material, .. }
            | ShapeSpec::DisplacedSphere { material, .. }
            | ShapeSpec::RandomTriangles { material, .. }
            | ShapeSpec::SphereGrid { material, .. } => Some(material),
        }
    }
    /// The file a shape reads (`mesh`, `gltf`, `ply`), as written; `None` for the others.
    pub fn path(&self) -> Option<&str> {
        match self {
            ShapeSpec::Mesh { path, .. }
            | ShapeSpec::Gltf { path, .. }
            | ShapeSpec::Ply { path, .. } => path.as_deref(),
            _ => None,
        }
    }
    /// The `emission` field, whatever the type.
    pub fn emission(&self) -> Option<[f64; 3]> {
        common_fields!(self, emission => *emission)
    }
    /// The `transform` field, whatever the type.
    pub fn transform(&self) -> Option<&[TransformStep]> {
        common_fields!(self, transform => transform.as_deref())
    }
    /// The `matrix` field, whatever the type.
    pub fn matrix(&self) -> Option<&[[f64; 4]; 4]> {
        common_fields!(self, matrix => matrix.as_ref())
    }
    /// `(transform, matrix)`, to rewrite the placement.
    pub fn placement_mut(
        &mut self,
    ) -> (&mut Option<Vec<TransformStep>>, &mut Option<[[f64; 4]; 4]>) {
        common_fields!(self, transform, matrix => (transform, matrix))
    }
    /// The `count` of a generator shape (`None` for the other types).
    pub fn generator_count_mut(&mut self) -> Option<&mut Option<u64>> {
        match self {
            ShapeSpec::DisplacedSphere { count, .. }
            | ShapeSpec::RandomTriangles { count, .. }
            | ShapeSpec::SphereGrid { count, .. } => Some(count),
            ShapeSpec::Sphere { .. }
            | ShapeSpec::Rectangle { .. }
            | ShapeSpec::Cube { .. }
            | ShapeSpec::Mesh { .. }
            | ShapeSpec::Gltf { .. }
            | ShapeSpec::Ply { .. } => None,
        }
    }
}

/// The type-specific fields of every shape type side by side, as shapes were before they
/// were typed: see the `Debug` impl.
#[derive(Default)]
struct FlatFields<'a> {
    center: Option<[f64; 3]>,
    radius: Option<f64>,
    flip_normals: Option<bool>,
    path: Option<&'a str>,
    count: Option<u64>,
    displacement: Option<f64>,
    triangle_size: Option<f64>,
    seed: Option<u64>,
}

// By hand, not derived: the scene hash is FNV over `{SceneFile:?}`, and every scene must keep
// the hash it had when a shape was one flat struct (results CSVs key on it), so this prints
// that struct's text.
impl std::fmt::Debug for ShapeSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let flat = match self {
            ShapeSpec::Sphere {
                center,
                radius,
                flip_normals,
                ..
            } => FlatFields {
                center: *center,
                radius: *radius,
                flip_normals: *flip_normals,
                ..Default::default()
            },
            ShapeSpec::Rectangle { .. } | ShapeSpec::Cube { .. } => FlatFields::default(),
            ShapeSpec::Mesh { path, .. }
            | ShapeSpec::Gltf { path, .. }
            | ShapeSpec::Ply { path, .. } => FlatFields {
                path: path.as_deref(),
                ..Default::default()
            },
            ShapeSpec::DisplacedSphere {
                count,
                displacement,
                ..
            } => FlatFields {
                count: *count,
                displacement: *displacement,
                ..Default::default()
            },
            ShapeSpec::RandomTriangles {
                count,
                triangle_size,
                seed,
                ..
            } => FlatFields {
                count: *count,
                triangle_size: *triangle_size,
                seed: *seed,
                ..Default::default()
            },
            ShapeSpec::SphereGrid { count, .. } => FlatFields {
                count: *count,
                ..Default::default()
            },
        };
        f.debug_struct("ShapeSpec")
            .field("kind", &self.type_name())
            // A shape without `material` (a gltf keeping the file's) prints "": no earlier
            // scene had one, so no earlier hash changes.
            .field("material", &self.material().unwrap_or(""))
            .field("emission", &self.emission())
            .field("transform", &self.transform())
            .field("matrix", &self.matrix())
            .field("center", &flat.center)
            .field("radius", &flat.radius)
            .field("flip_normals", &flat.flip_normals)
            .field("path", &flat.path)
            .field("count", &flat.count)
            .field("displacement", &flat.displacement)
            .field("triangle_size", &flat.triangle_size)
            .field("seed", &flat.seed)
            .finish()
    }
}

/// `[[shapes]]` one by one, so an error names the shape and the field (`shapes[1].radius`):
/// serde alone would say only ``unknown field `radius` `` without saying of which shape.
fn shapes_by_index<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<ShapeSpec>, D::Error> {
    let raw = Vec::<toml::Value>::deserialize(d)?;
    raw.into_iter()
        .enumerate()
        .map(|(i, value)| {
            let kind = value
                .get("type")
                .and_then(|t| t.as_str())
                .map(str::to_owned);
            // Checked first: serde, meeting an unknown tag, may report another field instead.
            match (value.get("type"), kind.as_deref()) {
                (Some(_), None) => {
                    return Err(serde::de::Error::custom(format!(
                        "shapes[{i}].type: must be a string (one of {})",
                        SHAPE_TYPES.join(", ")
                    )))
                }
                (_, Some(k)) if !SHAPE_TYPES.contains(&k) => {
                    return Err(serde::de::Error::custom(format!(
                        "shapes[{i}].type: unknown shape type '{k}' (expected {})",
                        SHAPE_TYPES.join(", ")
                    )))
                }
                _ => {}
            }
            ShapeSpec::deserialize(value)
                .map_err(|e| serde::de::Error::custom(shape_error(i, kind.as_deref(), e.message())))
        })
        .collect()
}

/// serde's message about shape `i` (of type `kind`) in the loader's `field: message` form.
fn shape_error(i: usize, kind: Option<&str>, msg: &str) -> String {
    let at = format!("shapes[{i}]");
    // serde's wording: "unknown field `x`, expected …", "unknown variant `x`, expected …".
    let quoted = |prefix: &str| {
        let rest = msg.strip_prefix(prefix)?;
        let (name, rest) = rest.split_once('`')?;
        Some((name, rest.trim_start_matches(", ")))
    };
    if let (Some((field, expected)), Some(kind)) = (quoted("unknown field `"), kind) {
        format!("{at}.{field}: does not apply to a shape of type '{kind}' ({expected})")
    } else if let Some((kind, expected)) = quoted("unknown variant `") {
        let types = expected
            .trim_start_matches("expected one of ")
            .replace('`', "");
        format!("{at}.type: unknown shape type '{kind}' (expected {types})")
    } else if let Some((field, _)) = quoted("missing field `") {
        format!("{at}.{field}: missing")
    } else {
        format!("{at}: {msg}")
    }
}

/// One step of a shape's `transform`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TransformStep {
    /// Translate by this vector.
    Translate([f64; 3]),
    /// Rotate about `axis` through the origin.
    Rotate {
        /// Rotation axis (non-zero; need not be unit).
        axis: [f64; 3],
        /// Angle in degrees.
        deg: f64,
    },
    /// Scale about the origin.
    Scale(ScaleSpec),
}

/// A scale factor: one for every axis, or one per axis.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    /// The same factor on every axis.
    Uniform(f64),
    /// Factors for x, y and z.
    PerAxis([f64; 3]),
}

/// `[[lights]]`, by `type`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightSpec {
    /// Intensity in W/sr: irradiance I·cosθ/r².
    Point {
        /// Position in world space.
        position: [f64; 3],
        /// Intensity per channel in W/sr (≥ 0).
        intensity: [f64; 3],
    },
    /// Uniform radiance from every direction at infinity.
    Environment {
        /// Radiance per channel (≥ 0).
        radiance: [f64; 3],
    },
}

/// Changes an experiment applies on top of a scene file.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneOverrides {
    /// Replaces `camera.width`.
    pub width: Option<u32>,
    /// Replaces `camera.height`.
    pub height: Option<u32>,
    /// Replaces `render.spp`.
    pub spp: Option<u32>,
    /// Replaces `render.max_depth`.
    pub max_depth: Option<i32>,
    /// Replaces `render.seed`.
    pub seed: Option<u64>,
    /// Replaces `count` of every generator shape.
    pub generator_count: Option<u64>,
}

impl SceneOverrides {
    /// Write these overrides into `file`.
    pub fn apply(&self, file: &mut SceneFile) {
        if let Some(w) = self.width {
            file.camera.width = w;
        }
        if let Some(h) = self.height {
            file.camera.height = h;
        }
        if let Some(s) = self.spp {
            file.render.spp = s;
        }
        if let Some(d) = self.max_depth {
            file.render.max_depth = d;
        }
        if let Some(s) = self.seed {
            file.render.seed = s;
        }
        if let Some(n) = self.generator_count {
            for count in file
                .shapes
                .iter_mut()
                .filter_map(ShapeSpec::generator_count_mut)
            {
                *count = Some(n);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAMERA: &str = "[camera]\norigin = [0, 0, 4]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n\
                          fov_deg = 40\nwidth = 8\nheight = 8\n";

    fn parse(shapes: &str) -> Result<SceneFile, String> {
        toml::from_str(&format!("{CAMERA}{shapes}")).map_err(|e| e.message().to_string())
    }

    #[test]
    fn a_shape_error_names_the_shape_and_the_field() {
        let two = "[[shapes]]\ntype = \"cube\"\nmaterial = \"m\"\n[[shapes]]\ntype = \"mesh\"\n\
                   material = \"m\"\npath = \"a.obj\"\n";
        assert!(parse(two).is_ok());
        let err = parse(&format!("{two}radius = 2\n")).unwrap_err();
        assert!(
            err.starts_with("shapes[1].radius: does not apply to a shape of type 'mesh'"),
            "{err}"
        );
        let err =
            parse("[[shapes]]\ntype = \"torus\"\nmaterial = \"m\"\nradius = 1\n").unwrap_err();
        assert_eq!(
            err,
            "shapes[0].type: unknown shape type 'torus' (expected sphere, rectangle, cube, mesh, \
             gltf, ply, displaced_sphere, random_triangles, sphere_grid)"
        );
        let err = parse("[[shapes]]\nmaterial = \"m\"\n").unwrap_err();
        assert_eq!(err, "shapes[0].type: missing");
        let err = parse("[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\nradius = \"big\"\n")
            .unwrap_err();
        assert!(err.starts_with("shapes[0]: invalid type"), "{err}");
    }

    #[test]
    fn shapes_write_back_only_the_fields_they_have() {
        let text = "[[shapes]]\ntype = \"sphere_grid\"\nmaterial = \"m\"\ncount = 8\n";
        let mut file = parse(text).unwrap();
        SceneOverrides {
            generator_count: Some(27),
            ..Default::default()
        }
        .apply(&mut file);
        let out = toml::to_string(&file).unwrap();
        assert!(
            out.contains("[[shapes]]\ntype = \"sphere_grid\"\nmaterial = \"m\"\ncount = 27\n"),
            "{out}"
        );
        assert_eq!(
            format!("{:?}", file.shapes[0]),
            "ShapeSpec { kind: \"sphere_grid\", material: \"m\", emission: None, transform: None, \
             matrix: None, center: None, radius: None, flip_normals: None, path: None, \
             count: Some(27), displacement: None, triangle_size: None, seed: None }"
        );
    }
}
