//! Unidirectional path tracer: next-event estimation and BSDF sampling combined by multiple
//! importance sampling (power heuristic), unbiased Russian roulette from segment 5 on.
//!
//! `max_depth` counts path *segments*; the segment that reaches an emitter, or the shadow
//! connection, counts (docs/conventions.md): 1 = emitters seen directly, 2 = plus direct light.

use crate::core::geometry::{basis, gamma, offset_ray_origin, Hit, Ray, Sphere};
use crate::core::scene::{Light, Material, Scene, NO_LIGHT};
use crate::core::tracer::Tracer;
use crate::util::rng::Sampler;
use glam::{DVec3, Vec3};
use std::cell::Cell;
use std::f32::consts::{FRAC_1_PI, PI};

/// The scene features a specialised [`radiance_with`] keeps. Each flag is a constant, so a
/// feature the scene lacks is compiled out of the per-ray loop (no branch, no match arm).
/// [`feature_flags`] picks the set once per item (`render_item`, `render_moments`), never per ray.
pub trait FeatureSet {
    /// An environment light.
    const ENV: bool;
    /// Area lights (emissive primitives).
    const AREA: bool;
    /// Point lights.
    const POINT: bool;
    /// Mirrors or dielectrics (the specular bounces).
    const SPECULAR: bool;
}

/// A feature set as const generics: `Feats<ENV, AREA, POINT, SPECULAR>`.
pub struct Feats<const E: bool, const A: bool, const P: bool, const S: bool>;

impl<const E: bool, const A: bool, const P: bool, const S: bool> FeatureSet for Feats<E, A, P, S> {
    const ENV: bool = E;
    const AREA: bool = A;
    const POINT: bool = P;
    const SPECULAR: bool = S;
}

/// Every feature on: the forced-full path.
pub type FullFeatures = Feats<true, true, true, true>;

/// Which `Feats` flags a scene needs: (environment, area lights, point lights, specular).
pub fn feature_flags(scene: &Scene) -> [bool; 4] {
    let f = &scene.features;
    [
        f.environment,
        f.area_lights,
        f.point_lights,
        f.mirrors || f.refraction,
    ]
}

/// Segments before Russian roulette may end a path.
const RR_START: u32 = 5;
/// Shadow rays stop this fraction short of the (offset) light point, as pbrt's ShadowEpsilon.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// Where a ray hit, in the form shading needs.
pub struct Interaction {
    /// Hit point, in the scene geometry's (render-space) coordinates.
    pub p: Vec3,
    /// Per-axis bound on the floating-point error of `p`, for offsetting spawned rays.
    pub p_err: Vec3,
    /// Geometric normal: triangle winding, or sphere outward (inward when flipped).
    pub n: Vec3,
    /// Index into `Scene::materials` of the primitive hit.
    pub material: u32,
    /// Index into `Scene::lights` when the primitive hit emits, else [`NO_LIGHT`].
    pub light: u32,
    /// For a sphere hit, the sphere and `p` to f64 precision: rays leave from that point
    /// ([`Ray::leaving`]).
    pub sphere: Option<(Sphere, DVec3)>,
    /// A triangle hit's offset origin on the front side of `n`, computed on first use: a
    /// diffuse vertex's shadow ray and its next segment both start there. (`offset_ray_origin`
    /// was 7.1 % of the Cornell render in `perf`, three calls per diffuse vertex; now two.)
    front: Cell<Option<Vec3>>,
}

impl Interaction {
    /// A ray leaving this hit along `w`, its direction `d(origin)` (`w` itself, or the segment
    /// to a target from the ray's start). Triangle hits offset the start past `p`'s error box;
    /// sphere hits start at the exact surface point, which the sphere test recognises (and, for
    /// f32-only tests, from [`Sphere::spawn_origin`]).
    #[inline]
    pub fn spawn(&self, w: Vec3, d: impl FnOnce(Vec3) -> Vec3) -> Ray {
        let offset = || offset_ray_origin(self.p, self.p_err, self.n, w);
        match self.sphere {
            Some((sphere, exact)) => {
                let o = sphere.spawn_origin(self.p, w).unwrap_or_else(offset);
                Ray::leaving(exact, o, d(o))
            }
            None => {
                // `offset_ray_origin` reads `w` only through `w·n < 0`: every other `w` gets
                // the front origin, the same bits as `w = n`.
                let o = if w.dot(self.n) < 0.0 {
                    offset()
                } else {
                    self.front.get().unwrap_or_else(|| {
                        let o = offset_ray_origin(self.p, self.p_err, self.n, self.n);
                        self.front.set(Some(o));
                        o
                    })
                };
                Ray::new(o, d(o))
            }
        }
    }
}

/// Shading data for `hit`, a hit of `ray` in `scene`.
#[inline]
pub fn interaction(scene: &Scene, ray: &Ray, hit: &Hit) -> Interaction {
    let g = &scene.geometry;
    let info = g.info[hit.prim as usize];
    let ns = g.spheres.len() as u32;
    let (p, p_err, n, sphere) = if hit.prim < ns {
        let s = g.spheres[hit.prim as usize];
        let sp = s.point(ray, hit.t);
        let n = if info.flip { -sp.n } else { sp.n };
        (sp.p, sp.err, n, Some((s, sp.exact)))
    } else {
        let tri = &g.triangles[(hit.prim - ns) as usize];
        let (p, err) = tri.point(hit.b1, hit.b2);
        (p, err, scene.tri_normals[(hit.prim - ns) as usize], None)
    };
    Interaction {
        p,
        p_err,
        n,
        material: info.material,
        light: info.light,
        sphere,
        front: Cell::new(None),
    }
}

#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        1.0
    } else {
        a2 / (a2 + b2)
    }
}

fn cosine_hemisphere(n: Vec3, u: (f32, f32)) -> Vec3 {
    let r = u.0.sqrt();
    let phi = 2.0 * PI * u.1;
    let (t, b) = basis(n);
    let z = (1.0 - u.0).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

fn uniform_sphere(u: (f32, f32)) -> Vec3 {
    let z = 1.0 - 2.0 * u.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.1;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Unpolarised Fresnel reflectance of a smooth dielectric; `eta` = n_transmitted / n_incident.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

/// A point sampled on an area light, with its facing normal and error bound.
struct LightPoint {
    p: Vec3,
    err: Vec3,
    n: Vec3,
}

#[inline]
fn sample_area(
    scene: &Scene,
    prims: &[u32],
    cdf: &[f32],
    area: f32,
    u: f32,
    v: (f32, f32),
) -> LightPoint {
    let g = &scene.geometry;
    let target = u * area;
    let k = cdf.partition_point(|&c| c <= target).min(prims.len() - 1);
    let prim = prims[k];
    let ns = g.spheres.len() as u32;
    if prim < ns {
        let s = &g.spheres[prim as usize];
        let dir = uniform_sphere(v);
        let p = s.center + dir * s.radius;
        let n = if g.info[prim as usize].flip {
            -dir
        } else {
            dir
        };
        LightPoint {
            p,
            err: (dir * s.radius).abs() * gamma(5) + s.center.abs() * gamma(2),
            n,
        }
    } else {
        let tri = &g.triangles[(prim - ns) as usize];
        let su = v.0.sqrt();
        let (b1, b2) = (1.0 - su, v.1 * su);
        let (p, err) = tri.point(b1, b2);
        LightPoint {
            p,
            err,
            n: scene.tri_normals[(prim - ns) as usize],
        }
    }
}

/// Light-selection probability times the solid-angle density of hitting area light `light`
/// at distance `dist` with cosine `cos_l` at the light.
fn area_pdf(scene: &Scene, light: u32, dist: f32, cos_l: f32) -> f32 {
    match &scene.lights[light as usize] {
        Light::Area { area, .. } => dist * dist / (cos_l * area * scene.lights.len() as f32),
        _ => 0.0,
    }
}

/// Next-event estimation at a diffuse vertex: radiance arriving through one light sample,
/// MIS-weighted against cosine BSDF sampling. `f` is the BSDF value (albedo/π).
fn direct<T: Tracer + ?Sized, F: FeatureSet>(
    scene: &Scene,
    tracer: &T,
    it: &Interaction,
    f: Vec3,
    s: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    let n_lights = scene.lights.len();
    let pick = s.next();
    let u = s.next2();
    let u3 = s.next();
    let idx = ((pick * n_lights as f32) as usize).min(n_lights - 1);
    let sel = 1.0 / n_lights as f32;
    match &scene.lights[idx] {
        Light::Point {
            position,
            position_lo,
            intensity,
        } if F::POINT => {
            // Geometry from the hit point itself: the offset origin is only where the shadow ray
            // starts. Near a light (1e-4 above a plane seen from 30 units) the offset is a few
            // per cent of the distance, so measuring from it would bias cosθ/r². `position − p`
            // is exact there (Sterbenz), and the residual restores the height f32 rounded off.
            let to = (*position - it.p) + *position_lo;
            let dist2 = to.length_squared();
            if dist2 == 0.0 {
                return Vec3::ZERO;
            }
            let wi = to / dist2.sqrt();
            let cos = it.n.dot(wi);
            if cos <= 0.0 {
                return Vec3::ZERO;
            }
            let shadow = it.spawn(wi, |o| *position - o);
            *rays += 1;
            if tracer.occluded(&shadow, 1.0 - SHADOW_EPSILON) {
                return Vec3::ZERO;
            }
            f * *intensity * (cos / (dist2 * sel))
        }
        Light::Area {
            prims,
            cdf,
            area,
            radiance,
        } if F::AREA => {
            let lp = sample_area(scene, prims, cdf, *area, u3, u);
            let to = lp.p - it.p;
            let dist = to.length();
            if dist == 0.0 {
                return Vec3::ZERO;
            }
            let wi = to / dist;
            let cos = it.n.dot(wi);
            let cos_l = -lp.n.dot(wi);
            if cos <= 0.0 || cos_l <= 0.0 {
                return Vec3::ZERO;
            }
            let light_pdf = sel * dist * dist / (cos_l * area);
            let target = offset_ray_origin(lp.p, lp.err, lp.n, -wi);
            let shadow = it.spawn(wi, |o| target - o);
            *rays += 1;
            if tracer.occluded(&shadow, 1.0 - SHADOW_EPSILON) {
                return Vec3::ZERO;
            }
            let w = power_heuristic(light_pdf, cos * FRAC_1_PI);
            f * *radiance * (cos * w / light_pdf)
        }
        Light::Environment { radiance } if F::ENV => {
            let wi = uniform_sphere(u);
            let cos = it.n.dot(wi);
            if cos <= 0.0 {
                return Vec3::ZERO;
            }
            let light_pdf = sel / (4.0 * PI);
            let shadow = it.spawn(wi, |_| wi);
            *rays += 1;
            if tracer.occluded(&shadow, f32::INFINITY) {
                return Vec3::ZERO;
            }
            let w = power_heuristic(light_pdf, cos * FRAC_1_PI);
            f * *radiance * (cos * w / light_pdf)
        }
        // A light kind the feature set leaves out: the scene has none (`feature_flags`).
        _ => Vec3::ZERO,
    }
}

/// Radiance along a camera ray. `rays` counts every tracer query (closest-hit and shadow).
/// The forced-full path: every feature compiled in.
pub fn radiance<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    ray: Ray,
    s: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    radiance_with::<T, FullFeatures>(scene, tracer, ray, s, rays)
}

/// [`radiance`] specialised to feature set `F`. `F` must include every feature of the scene
/// ([`feature_flags`]); then the result is bit-identical to the full path, since the same
/// random numbers are drawn in the same order and only code the scene never reaches is gone.
pub fn radiance_with<T: Tracer + ?Sized, F: FeatureSet>(
    scene: &Scene,
    tracer: &T,
    mut ray: Ray,
    s: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    // Unlimited: Russian roulette ends the path, the hard cap at the latest (a lossless scene
    // would never end otherwise).
    let max_depth = if scene.settings.max_depth < 0 {
        crate::util::limits::MAX_DEPTH
    } else {
        scene.settings.max_depth as u32
    };
    let has_lights = (F::ENV || F::AREA || F::POINT) && !scene.lights.is_empty();
    let env = scene.environment_radiance();
    let env_pdf = 1.0 / (4.0 * PI * scene.lights.len().max(1) as f32);
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut depth = 1u32; // the segment `ray` is about to trace
    let mut specular = true; // camera rays and specular bounces take emission unweighted
    let mut bsdf_pdf = 0.0f32;
    loop {
        *rays += 1;
        let Some(hit) = tracer.intersect(&ray, f32::INFINITY) else {
            if F::ENV && scene.environment.is_some() {
                let w = if specular {
                    1.0
                } else {
                    power_heuristic(bsdf_pdf, env_pdf)
                };
                l += beta * env * w;
            }
            break;
        };
        let it = interaction(scene, &ray, &hit);
        let front = ray.d.dot(it.n) < 0.0;
        if F::AREA && it.light != NO_LIGHT && front {
            if let Light::Area { radiance, .. } = &scene.lights[it.light as usize] {
                let w = if specular {
                    1.0
                } else {
                    let dist = hit.t * ray.d.length();
                    let cos_l = -ray.d.normalize().dot(it.n);
                    power_heuristic(bsdf_pdf, area_pdf(scene, it.light, dist, cos_l))
                };
                l += beta * *radiance * w;
            }
        }
        if depth >= max_depth {
            break;
        }
        let next_dir = match scene.materials[it.material as usize] {
            Material::Diffuse { reflectance } => {
                if !front {
                    break; // one-sided: black from behind
                }
                let albedo = reflectance.eval(it.p, scene.origin);
                let f = albedo * FRAC_1_PI;
                if has_lights {
                    l += beta * direct::<T, F>(scene, tracer, &it, f, s, rays);
                }
                let wi = cosine_hemisphere(it.n, s.next2());
                bsdf_pdf = it.n.dot(wi).max(0.0) * FRAC_1_PI;
                if bsdf_pdf == 0.0 {
                    break;
                }
                beta *= albedo; // f·cos/pdf
                specular = false;
                wi
            }
            Material::Mirror { reflectance } if F::SPECULAR => {
                if !front {
                    break;
                }
                beta *= reflectance;
                specular = true;
                let wo = -ray.d.normalize();
                it.n * (2.0 * wo.dot(it.n)) - wo
            }
            Material::Dielectric { ior } if F::SPECULAR => {
                specular = true;
                dielectric(-ray.d.normalize(), it.n, ior, s, &mut beta)
            }
            // A specular material with SPECULAR off: the scene has none (see `radiance_with`).
            _ => break,
        };
        depth += 1;
        if depth > RR_START && roulette_ends(&mut beta, s) {
            break;
        }
        ray = it.spawn(next_dir, |_| next_dir);
    }
    l
}

/// A dielectric's next direction from outgoing `wo` at normal `n`: reflected with the Fresnel
/// probability, else refracted, `beta` scaled by 1/η² crossing into the denser medium.
#[inline(always)]
fn dielectric(wo: Vec3, n: Vec3, ior: f32, s: &mut Sampler, beta: &mut Vec3) -> Vec3 {
    let cos_o = wo.dot(n);
    let (nf, eta, cos_i) = if cos_o > 0.0 {
        (n, ior, cos_o)
    } else {
        (-n, 1.0 / ior, -cos_o)
    };
    let fr = fresnel_dielectric(cos_i, eta);
    if s.next() < fr {
        nf * (2.0 * cos_i) - wo
    } else {
        let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
        let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
        // Radiance is scaled by 1/η² crossing into the denser medium.
        *beta /= eta * eta;
        (-wo / eta + nf * (cos_i / eta - cos_t)).normalize()
    }
}

/// Russian roulette on throughput `beta`: `true` ends the path; a survivor's `beta` is
/// divided by its survival probability.
#[inline(always)]
fn roulette_ends(beta: &mut Vec3, s: &mut Sampler) -> bool {
    let m = beta.max_element();
    if m < 1.0 {
        let q = (1.0 - m).max(0.0);
        if s.next() < q {
            return true;
        }
        *beta /= 1.0 - q;
    }
    false
}
