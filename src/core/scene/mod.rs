//! The immutable, validated scene every tracer and scheduler shares by reference.
//!
//! Loading has two stages (ripgrep's raw → validated pattern): [`format`] is the TOML as written,
//! [`load`] checks every field and builds a [`Scene`] in *render space*: world coordinates
//! minus the camera origin, computed in f64 and only then rounded to f32. A scene placed at 1e8
//! therefore renders exactly like the same scene at the origin (pbrt-v4's camera-world space).
//!
//! An animated scene (`[animation]`) has one camera per frame over one geometry: render space
//! stays anchored at frame 0's camera and later cameras sit at their offset from it (see
//! `load::animation_cameras`), so frame 0 is bit-identical to the static scene.

pub mod camera;
mod check;
pub mod format;
pub mod generators;
pub mod gltf;
pub mod load;
pub mod ply;
mod shapes;

pub use camera::Camera;
pub use check::toml_error_at;
pub use format::{SceneFile, SceneOverrides};
pub use load::{load_scene, load_scene_str, SceneError};

use crate::core::geometry::{Hit, Ray, Sphere, Triangle};
use glam::{DVec3, Vec3};

/// `light` of a primitive that emits nothing.
pub const NO_LIGHT: u32 = u32::MAX;

/// A diffuse albedo: constant, or a procedural pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    /// The same albedo everywhere.
    Constant(Vec3),
    /// `even` where ⌊x/size⌋ + ⌊y/size⌋ is even, in world coordinates.
    Checker {
        /// Albedo of the even cells.
        even: Vec3,
        /// Albedo of the odd cells.
        odd: Vec3,
        /// Cell edge length in world units.
        size: f64,
    },
}

impl Texture {
    /// `p` is in render space; `origin` turns it back into world space (in f64).
    #[inline]
    pub fn eval(&self, p: Vec3, origin: DVec3) -> Vec3 {
        match *self {
            Texture::Constant(c) => c,
            Texture::Checker { even, odd, size } => {
                let w = p.as_dvec3() + origin;
                let k = (w.x / size).floor() as i64 + (w.y / size).floor() as i64;
                if k.rem_euclid(2) == 0 {
                    even
                } else {
                    odd
                }
            }
        }
    }
}

/// How a surface scatters light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambertian, one-sided: black when seen from behind its normal.
    Diffuse {
        /// Albedo, each channel in [0, 1].
        reflectance: Texture,
    },
    /// Perfect specular reflection, one-sided like diffuse.
    Mirror {
        /// Reflected fraction per channel, in [0, 1].
        reflectance: Vec3,
    },
    /// Smooth dielectric (two-sided), interior index `ior`, exterior 1.
    Dielectric {
        /// Interior index of refraction (> 0).
        ior: f32,
    },
}

/// A light source, in render space.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light, intensity in W/sr.
    Point {
        /// Position in render space.
        position: Vec3,
        /// What `position` lost to f32 rounding (the f64 position minus it). Render space is
        /// f32 around the camera, so a light 1e-4 above a surface 30 units away would sit at
        /// 0.9918e-4: shading adds this to `position − p` (exact for a nearby `p`).
        position_lo: Vec3,
        /// Intensity per channel in W/sr.
        intensity: Vec3,
    },
    /// An emitting shape: its primitives, their area CDF and its radiance (front side only).
    Area {
        /// Primitive ids of the shape.
        prims: Vec<u32>,
        /// Running sum of the primitives' areas in `prims` order (the last is `area`).
        cdf: Vec<f32>,
        /// Total area of the shape.
        area: f32,
        /// Emitted radiance per channel.
        radiance: Vec3,
    },
    /// Constant radiance from every direction at infinity.
    Environment {
        /// Radiance per channel.
        radiance: Vec3,
    },
}

/// Per-primitive data the renderer needs after a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimInfo {
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Index into `Scene::lights` when the primitive emits, else [`NO_LIGHT`].
    pub light: u32,
    /// Spheres only: normals point inwards.
    pub flip: bool,
}

/// Geometry in render space. Primitive id `p` is sphere `p` when `p < spheres.len()`, else
/// triangle `p − spheres.len()`; every tracer reports hits with these ids.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// Spheres: primitive ids `0..spheres.len()`.
    pub spheres: Vec<Sphere>,
    /// Triangles: primitive ids from `spheres.len()` on.
    pub triangles: Vec<Triangle>,
    /// Per-primitive data, indexed by primitive id.
    pub info: Vec<PrimInfo>,
}

impl Geometry {
    /// Number of primitives (spheres and triangles).
    pub fn len(&self) -> usize {
        self.spheres.len() + self.triangles.len()
    }
    /// Whether there is no primitive at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Intersect one primitive by id: the single routine every tracer uses for a leaf test.
    #[inline(always)]
    pub fn intersect_prim(&self, prim: u32, ray: &Ray, t_max: f32) -> Option<Hit> {
        let ns = self.spheres.len() as u32;
        if prim < ns {
            self.spheres[prim as usize]
                .intersect(ray, t_max)
                .map(|t| Hit {
                    t,
                    prim,
                    b1: 0.0,
                    b2: 0.0,
                })
        } else {
            self.triangles[(prim - ns) as usize]
                .intersect(ray, t_max)
                .map(|(t, b1, b2)| Hit { t, prim, b1, b2 })
        }
    }
    /// Axis-aligned bounds of one primitive.
    pub fn prim_bounds(&self, prim: u32) -> (Vec3, Vec3) {
        let ns = self.spheres.len() as u32;
        if prim < ns {
            self.spheres[prim as usize].bounds()
        } else {
            self.triangles[(prim - ns) as usize].bounds()
        }
    }
}

/// The sampling and transport settings of a render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Samples per pixel.
    pub spp: u32,
    /// Path segments, the one reaching an emitter included (docs/conventions.md); −1 = unlimited.
    pub max_depth: i32,
    /// Seed of every random number of the render.
    pub seed: u64,
}

/// What a scene needs; the renderer and tracer build nothing for what it does not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// Some triangle.
    pub triangles: bool,
    /// Some sphere.
    pub spheres: bool,
    /// Some emitting shape of positive area.
    pub area_lights: bool,
    /// Some point light.
    pub point_lights: bool,
    /// An environment light.
    pub environment: bool,
    /// Some primitive has a dielectric material.
    pub refraction: bool,
    /// Some primitive has a mirror material.
    pub mirrors: bool,
    /// Some primitive has a checker texture.
    pub textures: bool,
}

impl Features {
    /// The feature names as written to CSV, in field order.
    pub const NAMES: [&'static str; 8] = [
        "triangles",
        "spheres",
        "area_lights",
        "point_lights",
        "environment",
        "refraction",
        "mirrors",
        "textures",
    ];
    fn flags(&self) -> [bool; 8] {
        [
            self.triangles,
            self.spheres,
            self.area_lights,
            self.point_lights,
            self.environment,
            self.refraction,
            self.mirrors,
            self.textures,
        ]
    }
    /// Shadow rays are needed only when there is a light to connect to and a diffuse surface.
    pub fn shadow_rays(&self) -> bool {
        self.area_lights || self.point_lights || self.environment
    }
    /// `(features_used, features_left_out)` as written to `RunStats` and CSV: the scene
    /// features plus `shadow_rays` and `bvh` (`accelerated` = the tracer built one).
    pub fn report(&self, accelerated: bool) -> (Vec<String>, Vec<String>) {
        let mut used = Vec::new();
        let mut left_out = Vec::new();
        let extra = [("bvh", accelerated), ("shadow_rays", self.shadow_rays())];
        for (name, on) in Self::NAMES.iter().copied().zip(self.flags()).chain(extra) {
            if on {
                used.push(name.to_string());
            } else {
                left_out.push(name.to_string());
            }
        }
        (used, left_out)
    }
    /// Names of the features the scene uses (`used = true`) or leaves out.
    pub fn names(&self, used: bool) -> Vec<&'static str> {
        Self::NAMES
            .iter()
            .zip(self.flags())
            .filter(|(_, f)| *f == used)
            .map(|(n, _)| *n)
            .collect()
    }
}

/// Counts made while loading (what was dropped, what was built).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadStats {
    /// Zero-area triangles skipped at load: they can never be hit and would give NaN normals.
    pub degenerate_triangles: u64,
}

/// A loaded scene: immutable after [`load_scene`], `Sync`, shared by `&`/`Arc` across workers.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Scene name: the file's `name`, else its stem.
    pub name: String,
    /// FNV-1a of the canonical scene text (after overrides) and every mesh file it reads.
    pub hash: u64,
    /// World position of the render-space origin (the camera position of frame 0).
    pub origin: DVec3,
    /// The camera of frame 0 (of the only frame of a static scene).
    pub camera: Camera,
    /// One camera per frame (≥ 1); `cameras[0] == camera`.
    pub cameras: Vec<Camera>,
    /// Sampling and transport settings.
    pub settings: RenderSettings,
    /// Materials, indexed by material id (name order).
    pub materials: Vec<Material>,
    /// Every primitive, in render space.
    pub geometry: Geometry,
    /// Unit geometric normal of each triangle ([`crate::core::geometry::Triangle::normal`]), by
    /// triangle index, computed once at load: shading reads one per hit and per light sample.
    /// With the cached front origin of `Interaction` and the shading helpers inlined: Cornell
    /// box 128², 64 spp, one thread, new/old wall 0.81 (0.78–0.84, 7 alternated pairs, quiet
    /// 2-core EPYC), images bit-identical on every shipped scene.
    pub tri_normals: Vec<Vec3>,
    /// Area lights (one per emitting shape of positive area), then the file's lights in order.
    pub lights: Vec<Light>,
    /// Index of the environment light in `lights`, if any.
    pub environment: Option<u32>,
    /// What the scene uses.
    pub features: Features,
    /// What its model files hold that is not rendered (`gltf_textures`, …), sorted; reported
    /// among the left-out features by [`Scene::feature_report`].
    pub ignored_input: Vec<String>,
    /// Counts made while loading.
    pub load_stats: LoadStats,
}

impl Scene {
    /// A warning for a render whose paths may run to the hard cap: `max_depth = -1` with a
    /// material that loses no energy in some channel, where Russian roulette may never end a
    /// path (docs/conventions.md, `max_depth`).
    pub fn depth_warning(&self) -> Option<String> {
        if self.settings.max_depth >= 0 {
            return None;
        }
        let lossless = |m: &Material| match m {
            Material::Dielectric { .. } => true,
            Material::Mirror { reflectance } => reflectance.max_element() >= 1.0,
            Material::Diffuse {
                reflectance: Texture::Constant(c),
            } => c.max_element() >= 1.0,
            Material::Diffuse {
                reflectance: Texture::Checker { even, odd, .. },
            } => even.max_element().max(odd.max_element()) >= 1.0,
        };
        let used = |id: usize| self.geometry.info.iter().any(|i| i.material as usize == id);
        (0..self.materials.len()).find(|&i| used(i) && lossless(&self.materials[i]))?;
        Some(format!(
            "render.max_depth = -1 with a lossless material (reflectance 1 or a dielectric): \
             a path Russian roulette does not end stops at the hard cap of {} segments",
            crate::util::limits::MAX_DEPTH
        ))
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.camera.width
    }
    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.camera.height
    }
    /// Pixels of one frame.
    pub fn pixel_count(&self) -> usize {
        self.camera.width as usize * self.camera.height as usize
    }
    /// Frames of the animation (1 for a static scene).
    pub fn frames(&self) -> u32 {
        self.cameras.len() as u32
    }
    /// The camera of frame `frame`.
    ///
    /// # Panics
    /// If `frame ≥ frames()` (items come from a decomposition of this scene).
    pub fn frame_camera(&self, frame: u32) -> &Camera {
        &self.cameras[frame as usize]
    }
    /// `(features_used, features_left_out)` for `RunStats` and CSV: [`Features::report`], with
    /// what the model files hold and the renderer ignores appended to the left-out list.
    pub fn feature_report(&self, accelerated: bool) -> (Vec<String>, Vec<String>) {
        let (used, mut left_out) = self.features.report(accelerated);
        left_out.extend(self.ignored_input.iter().cloned());
        (used, left_out)
    }
    /// Radiance of the environment in direction-independent form (zero without one).
    pub fn environment_radiance(&self) -> Vec3 {
        match self.environment.map(|i| &self.lights[i as usize]) {
            Some(Light::Environment { radiance }) => *radiance,
            _ => Vec3::ZERO,
        }
    }
}
