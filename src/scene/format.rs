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

#[derive(Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub camera: CameraSpec,
    #[serde(default)]
    pub render: RenderSpec,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    #[serde(default)]
    pub shapes: Vec<ShapeSpec>,
    #[serde(default)]
    pub lights: Vec<LightSpec>,
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
    pub frames: u32,
    #[serde(default)]
    pub keys: Vec<CameraKeySpec>,
}

/// The camera pose at frame `frame`; a field left out keeps the previous key's value (the
/// first key's previous is `[camera]`).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKeySpec {
    pub frame: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov_deg: Option<f64>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub origin: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    #[serde(default = "default_spp")]
    pub spp: u32,
    #[serde(default = "default_max_depth")]
    pub max_depth: i32,
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

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialSpec {
    Diffuse {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reflectance: Option<[f64; 3]>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        checker: Option<CheckerSpec>,
    },
    Mirror {
        #[serde(default = "one3")]
        reflectance: [f64; 3],
    },
    Dielectric {
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
    pub even: [f64; 3],
    pub odd: [f64; 3],
    pub size: f64,
}

/// One shape. Which fields apply depends on `type`; a field that does not apply is an error.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeSpec {
    #[serde(rename = "type")]
    pub kind: String,
    pub material: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emission: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Vec<TransformStep>>,
    /// Row-major 4×4 placement matrix, an alternative to `transform`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<[[f64; 4]; 4]>,
    // sphere
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip_normals: Option<bool>,
    // mesh
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    // generators: the size knob and their parameters
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangle_size: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TransformStep {
    Translate([f64; 3]),
    Rotate { axis: [f64; 3], deg: f64 },
    Scale(ScaleSpec),
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    Uniform(f64),
    PerAxis([f64; 3]),
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightSpec {
    /// Intensity in W/sr: irradiance I·cosθ/r².
    Point {
        position: [f64; 3],
        intensity: [f64; 3],
    },
    /// Uniform radiance from every direction at infinity.
    Environment { radiance: [f64; 3] },
}

/// Changes an experiment applies on top of a scene file.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneOverrides {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<i32>,
    pub seed: Option<u64>,
    /// Replaces `count` of every generator shape.
    pub generator_count: Option<u64>,
}

impl SceneOverrides {
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
            for shape in &mut file.shapes {
                if super::generators::is_generator(&shape.kind) {
                    shape.count = Some(n);
                }
            }
        }
    }
}
