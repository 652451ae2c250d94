//! Paired per-sample checks: every camera sample the renderer takes is compared with the
//! closed form of the same camera ray (same seed, pixel, sample, hence the same jitter), so
//! the tolerance is the size of the actual per-sample difference (f32 rounding) rather than
//! the Monte Carlo spread of the image. A 1 % bias in next-event estimation or emission is
//! hundreds of σ away; an independent-render comparison of the same scenes needs 11–77 %.

use super::{verdict, Budget, CaseResult};
use crate::core::geometry::Ray;
use crate::core::render::sample_pixel;
use crate::core::scene::{Light, Material, Scene, Texture, NO_LIGHT};
use crate::core::tracer::Tracer;
use crate::studies::converge::exact::{closest, ExactHit};
use crate::util::rng::Sampler;
use glam::DVec3;

/// The closed-form radiance (channel mean) of a camera ray; `None` where it is undefined for
/// an f32 renderer (an outline edge, a tangent), and the sample is left out of both sides.
pub type ClosedForm<'a> = dyn Fn(&Ray) -> Option<f64> + Sync + 'a;

/// Per-sample comparison of a render with a closed form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Paired {
    /// Samples compared.
    pub samples: u64,
    /// Samples left out (closed form undefined).
    pub skipped: u64,
    /// Mean rendered value over the compared samples.
    pub rendered: f64,
    /// Mean closed-form value over the same samples.
    pub closed: f64,
    /// Standard error of the mean per-sample difference.
    pub sigma: f64,
    /// Mean per-sample relative difference `(rendered − closed)/closed` over samples with a
    /// positive closed form: a bias of the renderer by a factor shows here whole, whatever the
    /// heavy tail of the values (a point light's samples near its foot dominate the absolute
    /// mean and its rounding).
    pub rel_mean: f64,
    /// Standard error of [`Paired::rel_mean`].
    pub rel_sigma: f64,
    /// Samples whose closed form is 0 but whose rendered value is not.
    pub zero_mismatches: u64,
    /// Variance of the rendered image mean from per-pixel sample variances (the Monte Carlo
    /// spread an independent comparison would face).
    pub mc_var: f64,
    /// NaN/Inf rendered samples (left out, counted).
    pub nonfinite: u64,
}

#[derive(Default)]
struct Acc {
    n: u64,
    skipped: u64,
    nonfinite: u64,
    sum_r: f64,
    sum_c: f64,
    sum_d: f64,
    sum_d2: f64,
    rel_n: u64,
    sum_rel: f64,
    sum_rel2: f64,
    zero_mismatches: u64,
    pixel_var: f64,
}

/// Render every sample of `scene` and compare it with `closed` of the same camera ray.
pub fn paired<T: Tracer + ?Sized>(
    scene: &Scene,
    tracer: &T,
    closed: &ClosedForm,
    threads: usize,
) -> Paired {
    use rayon::prelude::*;
    let (w, h, spp) = (scene.width(), scene.height(), scene.settings.spp);
    let row = |y: u32| {
        let mut acc = Acc::default();
        let mut rays = 0u64;
        for x in 0..w {
            let idx = y * w + x;
            let (mut ps, mut ps2, mut pn) = (0.0f64, 0.0f64, 0u32);
            for k in 0..spp {
                let mut s = Sampler::new(scene.settings.seed, idx as u64, k as u64);
                let (jx, jy) = s.next2();
                let ray = scene.camera.pixel_ray(x, y, jx, jy);
                let Some(c) = closed(&ray) else {
                    acc.skipped += 1;
                    continue;
                };
                let v = sample_pixel(scene, tracer, idx, k, &mut rays);
                if !v.is_finite() {
                    acc.nonfinite += 1;
                    continue;
                }
                let r = (v.x as f64 + v.y as f64 + v.z as f64) / 3.0;
                let d = r - c;
                acc.n += 1;
                acc.sum_r += r;
                acc.sum_c += c;
                acc.sum_d += d;
                acc.sum_d2 += d * d;
                if c > 0.0 {
                    let rel = d / c;
                    acc.rel_n += 1;
                    acc.sum_rel += rel;
                    acc.sum_rel2 += rel * rel;
                } else if r != 0.0 {
                    acc.zero_mismatches += 1;
                }
                ps += r;
                ps2 += r * r;
                pn += 1;
            }
            if pn > 1 {
                let n = pn as f64;
                acc.pixel_var += ((ps2 / n - (ps / n).powi(2)).max(0.0)) / (n - 1.0);
            }
        }
        acc
    };
    let run = || (0..h).into_par_iter().map(row).collect::<Vec<_>>();
    let parts = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(pool) => pool.install(run),
        Err(_) => (0..h).map(row).collect(),
    };
    let mut t = Acc::default();
    for p in parts {
        t.n += p.n;
        t.skipped += p.skipped;
        t.nonfinite += p.nonfinite;
        t.sum_r += p.sum_r;
        t.sum_c += p.sum_c;
        t.sum_d += p.sum_d;
        t.sum_d2 += p.sum_d2;
        t.rel_n += p.rel_n;
        t.sum_rel += p.sum_rel;
        t.sum_rel2 += p.sum_rel2;
        t.zero_mismatches += p.zero_mismatches;
        t.pixel_var += p.pixel_var;
    }
    let se = |sum: f64, sum2: f64, n: u64| {
        let k = n.max(1) as f64;
        let m = sum / k;
        let var = ((sum2 / k - m * m).max(0.0)) * k / (k - 1.0).max(1.0);
        (m, (var / k).sqrt())
    };
    let (rel_mean, rel_sigma) = se(t.sum_rel, t.sum_rel2, t.rel_n);
    let n = t.n.max(1) as f64;
    let (_, sigma) = se(t.sum_d, t.sum_d2, t.n);
    let pixels = (w * h).max(1) as f64;
    Paired {
        samples: t.n,
        skipped: t.skipped,
        rendered: t.sum_r / n,
        closed: t.sum_c / n,
        sigma,
        rel_mean,
        rel_sigma,
        zero_mismatches: t.zero_mismatches,
        mc_var: t.pixel_var / (pixels * pixels),
        nonfinite: t.nonfinite,
    }
}

/// Relative tolerance of a paired comparison on top of 3σ: the f32 path against the f64 closed
/// form differs by ~1e-6 per sample; 1e-4 keeps a 1 % bias 100× outside.
pub const PAIRED_REL_TOL: f64 = 1e-4;

/// A paired case as a row of the table: expected = closed form over the compared samples,
/// measured = the render over the same samples, σ = standard error of their difference. It
/// passes when the mean difference and the mean relative difference are both within 3σ (+
/// [`PAIRED_REL_TOL`]) and no sample the closed form calls dark is lit.
pub fn paired_case<T: Tracer + ?Sized>(
    group: &str,
    case: &str,
    scene: &Scene,
    tracer: &T,
    closed: &ClosedForm,
    budget: &Budget,
) -> (CaseResult, Paired) {
    let p = paired(scene, tracer, closed, budget.threads);
    let mut r = verdict(
        group,
        case,
        p.closed,
        p.rendered,
        p.sigma,
        p.nonfinite,
        0,
        scene.pixel_count(),
        format!(
            "paired per sample vs closed form: {} samples ({} on outlines left out), \
             relative difference {:.1e} ± {:.1e}, {} dark samples lit; Monte Carlo σ of the \
             image {:.2e}",
            p.samples,
            p.skipped,
            p.rel_mean,
            p.rel_sigma,
            p.zero_mismatches,
            p.mc_var.sqrt()
        ),
    );
    let diff = (p.rendered - p.closed).abs();
    r.pass = p.samples > 0
        && p.nonfinite == 0
        && p.zero_mismatches == 0
        && diff <= 3.0 * p.sigma + PAIRED_REL_TOL * p.closed.abs() + 1e-12
        && p.rel_mean.abs() <= 3.0 * p.rel_sigma + PAIRED_REL_TOL;
    (r, p)
}

fn constant_albedo(scene: &Scene, material: u32) -> Option<DVec3> {
    match scene.materials.get(material as usize)? {
        Material::Diffuse {
            reflectance: Texture::Constant(c),
        } => Some(c.as_dvec3()),
        _ => None,
    }
}

/// Closed form of a camera ray over diffuse, constant-albedo surfaces lit only by point lights
/// with nothing between them (one plane, say): the hit's direct light `ρ/π · I · cosθ / d²`
/// from each light on its front side. Needs `max_depth ≥ 2`; deeper bounces add nothing when
/// no surface sees another (checked: at most one plane, i.e. coplanar triangles).
pub fn point_lit_plane(scene: &Scene) -> Option<Box<ClosedForm<'_>>> {
    let g = &scene.geometry;
    let lights: Vec<(DVec3, f64)> = scene
        .lights
        .iter()
        .map(|l| match l {
            Light::Point {
                position,
                position_lo,
                intensity,
            } => Some((
                position.as_dvec3() + position_lo.as_dvec3(),
                intensity.as_dvec3(),
            )),
            _ => None,
        })
        .collect::<Option<Vec<_>>>()?
        .into_iter()
        .map(|(p, i)| (p, i.element_sum() / 3.0))
        .collect();
    let plane_ok = g.spheres.is_empty()
        && !g.triangles.is_empty()
        && g.triangles.windows(2).all(|w| {
            (w[0].normal().as_dvec3() - w[1].normal().as_dvec3()).length() < 1e-9
                && w[0].normal().dot(w[1].v0 - w[0].v0).abs() <= 1e-6 * w[0].e1().length()
        });
    let depth_ok = scene.settings.max_depth < 0 || scene.settings.max_depth >= 2;
    if lights.is_empty() || !plane_ok || !depth_ok {
        return None;
    }
    let albedo: Vec<DVec3> = g
        .info
        .iter()
        .map(|i| constant_albedo(scene, i.material))
        .collect::<Option<_>>()?;
    // Per channel ρ·I would be exact; the lights here are grey, so the channel mean of ρ times
    // the mean intensity is the channel mean of the product. Anything else is refused.
    if scene.lights.iter().any(|l| match l {
        Light::Point { intensity, .. } => intensity.max_element() != intensity.min_element(),
        _ => true,
    }) {
        return None;
    }
    Some(Box::new(move |ray: &Ray| match closest(scene, ray) {
        ExactHit::Miss => Some(0.0),
        ExactHit::Ambiguous => None,
        ExactHit::Hit { prim, t, n } => {
            let d = ray.d.as_dvec3();
            if d.dot(n) >= 0.0 {
                return Some(0.0); // one-sided: the back of a surface is black
            }
            let p = ray.o.as_dvec3() + d * t;
            let rho = albedo[prim as usize].element_sum() / 3.0;
            let l: f64 = lights
                .iter()
                .map(|&(pos, i)| {
                    let wi = pos - p;
                    let d2 = wi.length_squared();
                    let cos = n.dot(wi) / d2.sqrt();
                    if cos > 0.0 {
                        rho * std::f64::consts::FRAC_1_PI * i * cos / d2
                    } else {
                        0.0
                    }
                })
                .sum();
            Some(l)
        }
    }))
}

/// Closed form of a camera ray where every surface is black and only area lights shine: the
/// radiance of the emitter hit on its front side, else 0.
pub fn emitters_on_black(scene: &Scene) -> Option<Box<ClosedForm<'_>>> {
    let g = &scene.geometry;
    let black = g
        .info
        .iter()
        .all(|i| constant_albedo(scene, i.material).is_some_and(|a| a == DVec3::ZERO));
    let area_only = scene.lights.iter().all(|l| matches!(l, Light::Area { .. }));
    if !black || !area_only || scene.settings.max_depth == 0 {
        return None;
    }
    Some(Box::new(move |ray: &Ray| match closest(scene, ray) {
        ExactHit::Miss => Some(0.0),
        ExactHit::Ambiguous => None,
        ExactHit::Hit { prim, n, .. } => {
            let info = g.info[prim as usize];
            if info.light == NO_LIGHT || ray.d.as_dvec3().dot(n) >= 0.0 {
                return Some(0.0);
            }
            match &scene.lights[info.light as usize] {
                Light::Area { radiance, .. } => Some(radiance.as_dvec3().element_sum() / 3.0),
                _ => None,
            }
        }
    }))
}
