//! Reference images: analytic where the scene has a closed form (the furnaces and the point
//! light of docs/conventions.md, and a few stability cases), otherwise a high-spp render
//! cached under `results/runs/refs/` (the `converge` command; an experiment uses `<out>/refs/`) keyed by the scene hash.
//!
//! Analytic kinds recognised structurally (not by name), so the transformed variants of the
//! stability suite are recognised too:
//! - *interior*: the camera inside one inward-facing emitting diffuse sphere, no other light:
//!   every pixel `Le·(1 − a^d)/(1 − a)`.
//! - *environment over convex diffuse*: only an environment light, every surface diffuse with a
//!   constant albedo, and every surface sees the whole environment above it (a convex object,
//!   a plane, stacked planes): a pixel is the coverage-weighted mean of `E` (miss), `a·E`
//!   (front hit, max_depth ≥ 2) and `0` (back hit). Coverage and normals come from an f64
//!   query over every primitive ([`super::exact`]), never from the tracer under test. Pixels
//!   whose sub-pixel grid disagrees are *mixed*; their value is a grid estimate.
//! - *plane under point lights*: one diffuse rectangle seen straight on, point lights (and
//!   tiny downward area lights treated as Lambertian points): exact per-pixel integrals
//!   (solid angle of a rectangle for points, the point-to-rectangle form factor for
//!   Lambertian points).

use super::exact::ExactHit;
use crate::core::geometry::Ray;
use crate::core::render::{render_moments, Image, WorkItem};
use crate::core::scene::{Light, Material, Scene, Texture};
use crate::core::tracer::Tracer;
use glam::{DVec3, Vec3};
use std::path::{Path, PathBuf};

/// A reference image and how exact each pixel is.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The reference radiance, linear RGB, the scene's size.
    pub image: Image,
    /// `true` where the value is exact (analytic); mixed edge pixels and rendered references
    /// are `false`.
    pub exact: Vec<bool>,
    /// Where the image came from.
    pub kind: ReferenceKind,
    /// Environment references: sub-pixel rays whose closed form is undefined (an outline edge
    /// or a tangent, where an f32 tracer may decide either way) or that reach a surface hidden
    /// from the sky. Their pixels are not exact.
    pub ambiguous: u64,
    /// Mean over pixels and channels of the variance of the reference's own pixel means (0 for
    /// analytic references): the part of a measured mean squared error that is the
    /// reference's noise, not the estimate's error.
    pub noise_mse: f64,
}

/// How a reference image was obtained (the analytic kinds are described in the module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum ReferenceKind {
    /// Analytic: the camera inside an emitting diffuse sphere.
    Interior,
    /// Analytic: an environment light over convex diffuse surfaces.
    EnvironmentConvex,
    /// Analytic: a diffuse rectangle under point lights.
    PlanePointLights,
    /// Rendered by raysched with this many samples per pixel (cached at `path`).
    Rendered {
        /// Samples per pixel; 0 when unknown (an image supplied from outside).
        spp: u32,
        /// The EXR file it was read from or cached to; `None` when it was never on disk.
        path: Option<PathBuf>,
    },
}

impl ReferenceKind {
    /// The label written in [`super::ConvergenceRow::reference`], e.g. `analytic_interior` or
    /// `rendered_4096spp`.
    pub fn label(&self) -> String {
        match self {
            Self::Interior => "analytic_interior".into(),
            Self::EnvironmentConvex => "analytic_environment".into(),
            Self::PlanePointLights => "analytic_point_plane".into(),
            Self::Rendered { spp, .. } => format!("rendered_{spp}spp"),
        }
    }
}

/// Sub-pixel grid side used for coverage of the environment reference.
const GRID: u32 = 16;

/// The analytic reference of `scene`, if it has one.
pub fn analytic(scene: &Scene) -> Option<Reference> {
    interior(scene)
        .or_else(|| plane_point_lights(scene))
        .or_else(|| environment_convex(scene))
}

fn constant_albedo(scene: &Scene, material: u32) -> Option<Vec3> {
    match scene.materials[material as usize] {
        Material::Diffuse {
            reflectance: Texture::Constant(c),
        } => Some(c),
        _ => None,
    }
}

fn depth_sum(a: f64, max_depth: i32) -> f64 {
    // Unlimited paths stop at the hard cap: (1 − a^cap)/(1 − a), within 1e-300 of 1/(1 − a)
    // for the albedos this reference accepts.
    let max_depth = if max_depth < 0 {
        crate::util::limits::MAX_DEPTH as i32
    } else {
        max_depth
    };
    if a == 1.0 {
        max_depth as f64
    } else {
        (1.0 - a.powi(max_depth)) / (1.0 - a)
    }
}

fn interior(scene: &Scene) -> Option<Reference> {
    let g = &scene.geometry;
    if g.spheres.len() != 1 || !g.triangles.is_empty() || scene.lights.len() != 1 {
        return None;
    }
    let info = g.info[0];
    let s = g.spheres[0];
    let Light::Area { radiance, .. } = &scene.lights[0] else {
        return None;
    };
    if !info.flip || s.center.length() >= s.radius {
        return None;
    }
    let a = constant_albedo(scene, info.material)?;
    if scene.settings.max_depth < 0 && a.max_element() >= 1.0 {
        return None; // infinite radiance
    }
    let v: [f32; 3] = std::array::from_fn(|c| {
        (radiance[c] as f64 * depth_sum(a[c] as f64, scene.settings.max_depth)) as f32
    });
    Some(Reference {
        image: Image {
            width: scene.width(),
            height: scene.height(),
            data: vec![v; scene.pixel_count()],
        },
        exact: vec![true; scene.pixel_count()],
        kind: ReferenceKind::Interior,
        ambiguous: 0,
        noise_mse: 0.0,
    })
}

fn environment_convex(scene: &Scene) -> Option<Reference> {
    let e = match scene.lights.as_slice() {
        [Light::Environment { radiance }] => *radiance,
        _ => return None,
    };
    let g = &scene.geometry;
    // Each shape must be convex or a plane; we accept a single sphere, or triangles only.
    if g.spheres.len() > 1 || (g.spheres.len() == 1 && !g.triangles.is_empty()) {
        return None;
    }
    if g.spheres.len() == 1 && g.info[0].flip {
        return None;
    }
    let mut albedo = Vec::with_capacity(g.info.len());
    for info in &g.info {
        albedo.push(constant_albedo(scene, info.material)?);
    }
    // A triangle sees the whole sky when every vertex of the scene is on or behind its plane
    // (convex solids, planes on top of a stack). Only such triangles may be hit.
    let verts: Vec<Vec3> = g.triangles.iter().flat_map(|t| t.vertices()).collect();
    let extent = verts
        .iter()
        .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
    let open_sky: Vec<bool> = g
        .triangles
        .iter()
        .map(|t| {
            let n = t.normal();
            verts.iter().all(|v| n.dot(*v - t.v0) <= 1e-5 * extent)
        })
        .collect();
    let ns = g.spheres.len() as u32;
    let lit = scene.settings.max_depth >= 2 || scene.settings.max_depth < 0;
    let (w, h) = (scene.width(), scene.height());
    let mut image = Image::new(w, h);
    let mut exact = vec![true; scene.pixel_count()];
    let mut ambiguous = 0u64;
    for py in 0..h {
        for px in 0..w {
            let mut sum = Vec3::ZERO;
            let mut first: Option<Vec3> = None;
            let mut mixed = false;
            for k in 0..GRID * GRID {
                let (jx, jy) = (
                    ((k % GRID) as f32 + 0.5) / GRID as f32,
                    ((k / GRID) as f32 + 0.5) / GRID as f32,
                );
                let ray = scene.camera.pixel_ray(px, py, jx, jy);
                let v = match super::exact::closest(scene, &ray) {
                    ExactHit::Miss => e,
                    ExactHit::Ambiguous => {
                        ambiguous += 1;
                        mixed = true;
                        e
                    }
                    ExactHit::Hit { prim, n, .. } => {
                        if prim >= ns && !open_sky[(prim - ns) as usize] {
                            ambiguous += 1;
                            mixed = true;
                        }
                        if ray.d.as_dvec3().dot(n) < 0.0 && lit {
                            albedo[prim as usize] * e
                        } else {
                            Vec3::ZERO
                        }
                    }
                };
                sum += v;
                match first {
                    None => first = Some(v),
                    Some(f) if f != v => mixed = true,
                    _ => {}
                }
            }
            let i = (py * w + px) as usize;
            image.data[i] = (sum / (GRID * GRID) as f32).to_array();
            exact[i] = !mixed;
        }
    }
    Some(Reference {
        image,
        exact,
        kind: ReferenceKind::EnvironmentConvex,
        ambiguous,
        noise_mse: 0.0,
    })
}

/// ∫∫ h/(h²+x²+y²)^{3/2} over [0,x]×[0,y] (signed): the solid angle of that rectangle.
fn solid_angle_corner(x: f64, y: f64, h: f64) -> f64 {
    (x * y / (h * (h * h + x * x + y * y).sqrt())).atan()
}

/// ∫∫ h²/(h²+x²+y²)² over [0,x]×[0,y] (signed): π × the parallel point-to-rectangle form factor.
fn form_factor_corner(x: f64, y: f64, h: f64) -> f64 {
    let (a, b) = (x / h, y / h);
    let sa = (1.0 + a * a).sqrt();
    let sb = (1.0 + b * b).sqrt();
    0.5 * (a / sa * (b / sa).atan() + b / sb * (a / sb).atan())
}

/// Integral of `f` over the rectangle [x0,x1]×[y0,y1] from its corner primitive.
fn rect_integral(f: impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)
}

/// A light of [`plane_point_lights`]: (position, kind, strength) with kind 0 an isotropic
/// point, 1 a Lambertian point.
type PointSource = (DVec3, u8, DVec3);

/// The scene's lights as points over the plane of normal `n` through `p0`; `None` when one is
/// not a point (an environment, an emitter not small or not facing the plane head-on).
fn point_sources(scene: &Scene, n: DVec3, p0: DVec3) -> Option<Vec<PointSource>> {
    let g = &scene.geometry;
    let mut sources: Vec<PointSource> = Vec::new();
    for l in &scene.lights {
        match l {
            Light::Point {
                position,
                position_lo,
                intensity,
            } => sources.push((
                position.as_dvec3() + position_lo.as_dvec3(),
                0,
                intensity.as_dvec3(),
            )),
            Light::Area {
                prims,
                area,
                radiance,
                ..
            } => {
                let ns = g.spheres.len();
                let tri = g.triangles[prims[0] as usize - ns];
                if (tri.normal().as_dvec3() + n).length() > 1e-6 {
                    return None; // must face the plane head-on
                }
                let c: DVec3 = prims
                    .iter()
                    .flat_map(|&p| g.triangles[p as usize - ns].vertices())
                    .map(|v| v.as_dvec3())
                    .sum::<DVec3>()
                    / (3 * prims.len()) as f64;
                let h = n.dot(c - p0);
                let size = area.sqrt() as f64;
                if size > 1e-3 * h {
                    return None; // not small enough to be a point
                }
                sources.push((c, 1, radiance.as_dvec3() * *area as f64));
            }
            Light::Environment { .. } => return None,
        }
    }
    Some(sources)
}

/// One rectangle (two coplanar triangles) of one constant diffuse material, and that
/// material; other triangles may exist only as tiny emitters (handled as Lambertian points).
fn plane_of(
    g: &crate::core::scene::Geometry,
) -> Option<(Vec<crate::core::geometry::Triangle>, u32)> {
    let mut plane_tris = Vec::new();
    let mut material = 0;
    for (k, t) in g.triangles.iter().enumerate() {
        if g.info[k].light == crate::core::scene::NO_LIGHT {
            plane_tris.push(*t);
            material = g.info[k].material;
        }
    }
    (plane_tris.len() == 2).then_some((plane_tris, material))
}

fn plane_point_lights(scene: &Scene) -> Option<Reference> {
    let g = &scene.geometry;
    if !g.spheres.is_empty() || scene.lights.is_empty() || scene.settings.max_depth == 1 {
        return None;
    }
    let (plane_tris, material) = plane_of(g)?;
    let rho = constant_albedo(scene, material)?.as_dvec3();
    let n = plane_tris[0].normal().as_dvec3();
    if (plane_tris[1].normal().as_dvec3() - n).length() > 1e-6 {
        return None;
    }
    // The camera looks straight at the plane (film parallel to it), from its front side.
    let centre = scene.camera.ray(0.5, 0.5).d.as_dvec3();
    if (centre + n).length() > 1e-6 {
        return None;
    }
    let p0 = plane_tris[0].v0.as_dvec3();
    let dist = n.dot(-p0); // camera (render-space origin) height above the plane
    if dist <= 0.0 {
        return None;
    }
    // Plane basis from two camera rays; footprint corners land on axis-aligned rectangles.
    let on_plane = |r: Ray| {
        let d = r.d.as_dvec3();
        d * (dist / -n.dot(d))
    };
    let bounds = plane_tris
        .iter()
        .flat_map(|t| t.vertices())
        .map(|v| v.as_dvec3())
        .collect::<Vec<_>>();
    let x_axis =
        (on_plane(scene.camera.ray(1.0, 0.5)) - on_plane(scene.camera.ray(0.0, 0.5))).normalize();
    let y_axis = n.cross(x_axis);
    let sources = point_sources(scene, n, p0)?;
    let (w, hgt) = (scene.width(), scene.height());
    let mut image = Image::new(w, hgt);
    let mut exact = vec![true; scene.pixel_count()];
    let inside = |p: DVec3| {
        // Inside the rectangle's extent (an axis-aligned bound suffices for a check).
        let (lo, hi) = bounds
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        p.cmpge(lo - 1e-9).all() && p.cmple(hi + 1e-9).all()
    };
    for py in 0..hgt {
        for px in 0..w {
            let c00 = on_plane(scene.camera.pixel_ray(px, py, 0.0, 0.0));
            let c11 = on_plane(scene.camera.pixel_ray(px, py, 1.0, 1.0));
            if !inside(c00) || !inside(c11) {
                return None; // the plane must fill the frame
            }
            let mut l = DVec3::ZERO;
            for &(pos, kind, strength) in &sources {
                let h = n.dot(pos - p0);
                if h <= 0.0 {
                    continue;
                }
                let foot = pos - n * h;
                let (xa, xb) = (x_axis.dot(c00 - foot), x_axis.dot(c11 - foot));
                let (ya, yb) = (y_axis.dot(c00 - foot), y_axis.dot(c11 - foot));
                let (x0, x1) = (xa.min(xb), xa.max(xb));
                let (y0, y1) = (ya.min(yb), ya.max(yb));
                let area = (x1 - x0) * (y1 - y0);
                // The pixel under a point light closer than a pixel's width: its samples have a
                // variance ∝ 1/h² that a few spp cannot estimate (heavy tail). Exact value, but
                // not usable for a 3σ test: marked inexact.
                if kind == 0 && x0 <= 0.0 && 0.0 <= x1 && y0 <= 0.0 && 0.0 <= y1 && h < x1 - x0 {
                    exact[(py * w + px) as usize] = false;
                }
                let integral = if kind == 0 {
                    rect_integral(|x, y| solid_angle_corner(x, y, h), x0, x1, y0, y1)
                } else {
                    rect_integral(|x, y| form_factor_corner(x, y, h), x0, x1, y0, y1)
                };
                l += rho * std::f64::consts::FRAC_1_PI * strength * (integral / area);
            }
            image.data[(py * w + px) as usize] = l.as_vec3().to_array();
        }
    }
    Some(Reference {
        image,
        exact,
        kind: ReferenceKind::PlanePointLights,
        ambiguous: 0,
        noise_mse: 0.0,
    })
}

/// Whole-image per-pixel moments of samples `samples`, rows rendered on `threads` workers.
pub fn image_moments<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    samples: std::ops::Range<u32>,
    full: bool,
    threads: usize,
) -> crate::core::render::Moments {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(pool) => image_moments_in(&pool, scene, tracer, samples, full),
        Err(_) => {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
            match pool {
                Ok(p) => image_moments_in(&p, scene, tracer, samples, full),
                Err(e) => panic!("cannot build a one-thread pool: {e}"),
            }
        }
    }
}

/// [`image_moments`] on an existing pool (a progressive run builds its pool once).
pub fn image_moments_in<T: Tracer + ?Sized>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    tracer: &T,
    samples: std::ops::Range<u32>,
    full: bool,
) -> crate::core::render::Moments {
    use rayon::prelude::*;
    let rows = |y: u32| {
        let item = WorkItem::rect(y, 0, y, scene.width(), 1);
        render_moments(scene, tracer, &item, samples.clone(), full)
    };
    let parts: Vec<crate::core::render::Moments> =
        pool.install(|| (0..scene.height()).into_par_iter().map(rows).collect());
    let mut m = crate::core::render::Moments::default();
    for p in parts {
        m.sums.extend(p.sums);
        m.sq_sums.extend(p.sq_sums);
        m.counts.extend(p.counts);
        m.rays += p.rays;
        m.nonfinite += p.nonfinite;
    }
    m
}

/// Path of the cached reference of `scene` rendered with `spp` samples (seed + 1 so its noise
/// is independent of the runs it judges). Its noise ([`Reference::noise_mse`]) is kept beside
/// it in a `.noise` file; a cache without one is rendered again.
pub fn cache_path(dir: &Path, scene: &Scene, spp: u32) -> PathBuf {
    dir.join(format!("{}_{:016x}_{spp}spp.exr", scene.name, scene.hash))
}

/// Rounds a rendered reference is split into, so a long one reports progress.
const REFERENCE_ROUNDS: u32 = 16;

/// The analytic reference, or a high-spp render cached in `dir` (read back when present).
/// `progress(done_spp, total_spp)` is called after each round of a render.
///
/// # Errors
/// A message when the cache cannot be written or read.
pub fn reference<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    dir: &Path,
    spp: u32,
    threads: usize,
    progress: &mut dyn FnMut(u32, u32),
) -> Result<Reference, ReferenceError> {
    reference_in(scene, tracer, dir, spp, threads, progress).map_err(ReferenceError)
}

/// Why no reference: the cache could not be written or read back (one line, naming the file).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ReferenceError(pub String);

fn reference_in<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    dir: &Path,
    spp: u32,
    threads: usize,
    progress: &mut dyn FnMut(u32, u32),
) -> Result<Reference, String> {
    if let Some(r) = analytic(scene) {
        return Ok(r);
    }
    let path = cache_path(dir, scene, spp);
    let noise_path = path.with_extension("noise");
    let cached = || -> Option<(Image, f64)> {
        let noise = std::fs::read_to_string(&noise_path)
            .ok()?
            .trim()
            .parse()
            .ok()?;
        Some((Image::load_exr(&path).ok()?, noise))
    };
    let (image, noise_mse) = match cached() {
        Some(c) => c,
        None => {
            let mut s = scene.clone();
            s.settings.seed = s.settings.seed.wrapping_add(1);
            let n = scene.pixel_count();
            let mut sums = vec![[0.0f64; 3]; n];
            let mut sq = vec![[0.0f64; 3]; n];
            let step = spp.div_ceil(REFERENCE_ROUNDS).max(1);
            let mut lo = 0;
            while lo < spp {
                let hi = (lo + step).min(spp);
                let m = image_moments(&s, tracer, lo..hi, false, threads);
                for i in 0..n {
                    for c in 0..3 {
                        sums[i][c] += m.sums[i][c];
                        sq[i][c] += m.sq_sums[i][c];
                    }
                }
                lo = hi;
                progress(lo, spp);
            }
            let k = spp as f64;
            let image = Image {
                width: scene.width(),
                height: scene.height(),
                data: sums.iter().map(|v| v.map(|c| (c / k) as f32)).collect(),
            };
            // Variance of each pixel's mean: sample variance / spp, averaged over channels.
            let var_sum: f64 = sums
                .iter()
                .zip(&sq)
                .flat_map(|(s, q)| (0..3).map(move |c| (s[c], q[c])))
                .map(|(s, q)| ((q / k - (s / k).powi(2)).max(0.0)) / (k - 1.0).max(1.0))
                .sum();
            let noise = var_sum / (3 * n.max(1)) as f64;
            let staging = crate::util::staging::Staging::new(dir)
                .map_err(|e| format!("{}: {e}", dir.display()))?;
            let name = |p: &Path| p.file_name().map(PathBuf::from).unwrap_or_default();
            image
                .save_with_preview(&staging.path(name(&path)))
                .map_err(|e| e.to_string())?;
            std::fs::write(staging.path(name(&noise_path)), format!("{noise:e}\n"))
                .map_err(|e| format!("{}: {e}", noise_path.display()))?;
            staging
                .commit()
                .map_err(|e| format!("{}: {e}", dir.display()))?;
            (image, noise)
        }
    };
    if image.width != scene.width() || image.height != scene.height() {
        return Err(format!("{}: size does not match the scene", path.display()));
    }
    Ok(Reference {
        exact: vec![false; scene.pixel_count()],
        image,
        kind: ReferenceKind::Rendered {
            spp,
            path: Some(path),
        },
        ambiguous: 0,
        noise_mse,
    })
}
