//! Renders compared with the analytic answers of docs/conventions.md, each within 3σ
//! of the estimate's own standard error.

use crate::support::{estimate, load};
use glam::Vec3;
use raysched::geometry::Sphere;
use raysched::scene::SceneOverrides;
use raysched::tracer::{AnyTracer, TracerKind};

fn overrides(max_depth: i32, width: u32) -> SceneOverrides {
    SceneOverrides {
        max_depth: Some(max_depth),
        width: Some(width),
        height: Some(width),
        ..Default::default()
    }
}

/// Pixels whose four corners all hit (`true`) or all miss (`false`) the unit sphere at the origin.
fn furnace_pixels(scene: &raysched::scene::Scene, covered: bool) -> Vec<u32> {
    // Render space is camera-relative: the sphere sits at −origin.
    let sphere = Sphere {
        center: (-scene.origin).as_vec3(),
        radius: 1.0,
    };
    let (w, h) = (scene.width(), scene.height());
    (0..w * h)
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .all(|&(dx, dy)| {
                    let ray = scene.camera.pixel_ray(x, y, dx, dy);
                    sphere.intersect(&ray, f32::INFINITY).is_some() == covered
                })
        })
        .collect()
}

#[test]
fn furnace_covered_pixels_equal_albedo_and_background_is_one() {
    for (file, a) in [("furnace.toml", 1.0), ("furnace_a08.toml", 0.8)] {
        for max_depth in [1, 2, 64] {
            let scene = load(file, overrides(max_depth, 24));
            let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
            let covered = furnace_pixels(&scene, true);
            let background = furnace_pixels(&scene, false);
            assert!(covered.len() > 30 && background.len() > 100);
            let expected = if max_depth == 1 { 0.0 } else { a };
            for c in 0..3 {
                estimate(&scene, &tracer, &covered, 16, c)
                    .assert_within_3se(expected, &format!("{file} d={max_depth} covered"));
                estimate(&scene, &tracer, &background, 2, c)
                    .assert_within_3se(1.0, &format!("{file} d={max_depth} background"));
            }
        }
    }
}

#[test]
fn interior_emitting_sphere_follows_the_geometric_series() {
    for a in [0.5f64, 0.8] {
        for d in [1, 2, 3, 8, -1] {
            let text = std::fs::read_to_string(crate::support::scene_path("interior_sphere.toml"))
                .unwrap()
                .replace(
                    "reflectance = [0.5, 0.5, 0.5]",
                    &format!("reflectance = [{a}, {a}, {a}]"),
                );
            let o = overrides(d, 8);
            let scene = raysched::scene::load_scene_str(
                &text,
                "interior",
                std::path::Path::new("."),
                "interior",
                &o,
            )
            .unwrap();
            let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
            let expected = if d < 0 {
                1.0 / (1.0 - a)
            } else {
                (1.0 - a.powi(d)) / (1.0 - a)
            };
            let pixels: Vec<u32> = (0..64).collect();
            estimate(&scene, &tracer, &pixels, 16, 0)
                .assert_within_3se(expected, &format!("interior a={a} d={d}"));
        }
    }
}

/// Mean of L(x,y) = (ρ/π)·I·h/(h² + x² + y²)^{3/2} over the centre pixel's footprint, by a
/// 400×400 midpoint rule (its error is far below the test's tolerance).
fn point_plane_centre_pixel() -> f64 {
    let (rho, i, h) = (0.5f64, 10.0f64, 2.0f64);
    let side = 2.0 * 5.0 * (30.0f64).to_radians().tan() / 65.0;
    let n = 400;
    let mut sum = 0.0;
    for a in 0..n {
        for b in 0..n {
            let x = (a as f64 + 0.5) / n as f64 * side - side / 2.0;
            let y = (b as f64 + 0.5) / n as f64 * side - side / 2.0;
            sum += rho / std::f64::consts::PI * i * h / (h * h + x * x + y * y).powf(1.5);
        }
    }
    sum / (n * n) as f64
}

#[test]
fn point_light_over_plane_centre_pixel_matches_the_integral() {
    let scene = load("point_plane.toml", SceneOverrides::default());
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let centre = 32 * 65 + 32;
    let expected = point_plane_centre_pixel();
    // ≈ 0.398: (ρ/π)·I/h² at the axis.
    assert!((expected - 0.5 / std::f64::consts::PI * 10.0 / 4.0).abs() < 0.01);
    for c in 0..3 {
        estimate(&scene, &tracer, &[centre], 4096, c)
            .assert_within_3se(expected, "point_plane centre");
    }
}

#[test]
fn glass_sphere_alone_in_uniform_environment_is_one() {
    let scene = load("glass_alone.toml", overrides(64, 16));
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let all: Vec<u32> = (0..256).collect();
    for c in 0..3 {
        estimate(&scene, &tracer, &all, 64, c).assert_within_3se(1.0, "glass alone");
    }
}

#[test]
fn cornell_box_is_lit_and_coloured_as_specified() {
    // Not analytic: a sanity check of orientation (red wall left, green right) and light.
    let scene = load(
        "cornell_box.toml",
        SceneOverrides {
            width: Some(32),
            height: Some(32),
            spp: Some(16),
            ..Default::default()
        },
    );
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    let (img, counters) = raysched::render::render_serial(&scene, &tracer);
    assert_eq!(counters.nonfinite, 0);
    let left = Vec3::from(img.get(1, 16));
    let right = Vec3::from(img.get(30, 16));
    assert!(left.x > 2.0 * left.y, "left wall should be red: {left}");
    assert!(
        right.y > 2.0 * right.x,
        "right wall should be green: {right}"
    );
    // The light (y = 0.99, z ∈ [−0.18, 0.20]) projects to v ∈ [0.125, 0.160]: rows 4–5 of 32.
    let top = Vec3::from(img.get(16, 4)).max(Vec3::from(img.get(16, 5)));
    assert!(
        top.x > 5.0,
        "light should be visible at the top centre: {top}"
    );
    let above = Vec3::from(img.get(16, 2));
    assert!(
        above.x < 2.0,
        "ceiling above the light should be dim: {above}"
    );
}

/// Solid angle of the rectangle `[x0,x1]×[y0,y1]` of the plane z = 0 seen from `(0, 0, h)`:
/// ∫∫ h/(h² + x² + y²)^{3/2} dx dy, from the antiderivative atan(xy / (h·√(h² + x² + y²))).
pub(crate) fn rectangle_solid_angle(h: f64, x: [f64; 2], y: [f64; 2]) -> f64 {
    let f = |x: f64, y: f64| (x * y / (h * (h * h + x * x + y * y).sqrt())).atan();
    f(x[1], y[1]) - f(x[0], y[1]) - f(x[1], y[0]) + f(x[0], y[0])
}

/// A point light `h` = 1e-4 above a diffuse plane, seen from `cam_h` straight above. Each pixel's
/// footprint on the plane is a square, so its exact mean is (ρ/π)·I·Ω/area with Ω the footprint's
/// solid angle from the light. Every pixel but the one under the light is checked, and the pooled relative error of all of
/// them is bounded by its own standard error (≈0.03 %), far below a 1 % bias.
#[test]
fn point_light_just_above_a_plane_matches_the_integral_at_every_pixel() {
    let (rho, intensity, fov, n) = (0.5f64, 1e-6f64, 60.0f64, 33u32);
    for cam_h in [3.0f64, 30.0] {
        let text = format!(
            "[camera]\norigin = [0, 0, {cam_h}]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n\
             fov_deg = {fov}\nwidth = {n}\nheight = {n}\n[render]\nmax_depth = 2\n\
             [materials.plane]\ntype = \"diffuse\"\nreflectance = [{rho}, {rho}, {rho}]\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"plane\"\n\
             transform = [{{ scale = [100, 100, 1] }}]\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 0, 1e-4]\n\
             intensity = [{intensity}, {intensity}, {intensity}]\n"
        );
        let scene = crate::support::load_str(&text);
        let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
        // The light's height as the scene holds it: render space is f32 around the camera, so
        // at 30 units 1e-4 is stored as 0.9918e-4 plus its residual (the plane at −30 is exact).
        let h = match &scene.lights[0] {
            raysched::scene::Light::Point {
                position,
                position_lo,
                ..
            } => position.z as f64 + position_lo.z as f64 - (-cam_h as f32) as f64,
            _ => unreachable!(),
        };
        assert!((h / 1e-4 - 1.0).abs() < 1e-6, "{h}");
        let half = (fov / 2.0).to_radians().tan() * cam_h;
        let side = 2.0 * half / n as f64;
        // The mean of the per-pixel relative errors, and its standard error.
        let (mut wsum, mut wrsum, mut var_sum) = (0.0f64, 0.0f64, 0.0f64);
        let mut worst = (0.0f64, 0u32);
        // The pixel holding the light's foot is left out: its samples are heavy-tailed (a spike
        // of width 1e-4 in a footprint of 0.1 or 1), so its sample σ is no bound on its error.
        for p in (0..n * n).filter(|&p| p != n * n / 2) {
            let (px, py) = ((p % n) as f64, (p / n) as f64);
            let x = [-half + px * side, -half + (px + 1.0) * side];
            let y = [half - (py + 1.0) * side, half - py * side];
            let expected = rho / std::f64::consts::PI * intensity * rectangle_solid_angle(h, x, y)
                / (side * side);
            let e = estimate(&scene, &tracer, &[p], 64, 0);
            assert_eq!(e.nonfinite, 0);
            let rel = e.mean / expected - 1.0;
            let rel_se = e.se / expected + 1e-6;
            // 5 standard errors per pixel: over 1089 pixels a false alarm has p ≈ 6e-4.
            assert!(
                rel.abs() <= 5.0 * rel_se,
                "camera {cam_h}: pixel {p} mean {:.6e} expected {expected:.6e} ({:+.3} %, se {:.3} %)",
                e.mean,
                100.0 * rel,
                100.0 * rel_se
            );
            // Equal weights: weighting by the sampled σ would favour pixels whose samples
            // happened to fall low (skewed estimates), a bias of its own.
            wsum += 1.0;
            wrsum += rel;
            var_sum += rel_se * rel_se;
            if rel.abs() > worst.0.abs() {
                worst = (rel, p);
            }
        }
        let (pooled, pooled_se) = (wrsum / wsum, var_sum.sqrt() / wsum);
        eprintln!(
            "camera {cam_h}: pooled {:+.4} % ± {:.4} %, worst pixel {} {:+.3} %",
            100.0 * pooled,
            100.0 * pooled_se,
            worst.1,
            100.0 * worst.0
        );
        assert!(
            pooled_se < 0.002,
            "camera {cam_h}: pooled se {pooled_se} too wide to see a 1 % bias"
        );
        assert!(
            pooled.abs() <= 4.0 * pooled_se,
            "camera {cam_h}: pooled relative error {:+.4} % (± {:.4} %)",
            100.0 * pooled,
            100.0 * pooled_se
        );
    }
}

/// `glass_checker.toml` at 32², with (when `inner` is given) a sphere of IOR 1 and that radius
/// inside the glass sphere: an interface of relative IOR 1, which must not change the image.
fn glass_checker_with_inner(inner: Option<f64>, env_only: bool) -> raysched::scene::Scene {
    let mut text = std::fs::read_to_string(crate::support::scene_path("glass_checker.toml"))
        .unwrap()
        .replace("width = 128", "width = 32")
        .replace("height = 128", "height = 32");
    if env_only {
        let cut = text.find("[[shapes]]\ntype = \"rectangle\"").unwrap();
        let lights = text.find("[[lights]]").unwrap();
        text.replace_range(cut..lights, "");
    }
    if let Some(r) = inner {
        text.push_str(&format!(
            "[materials.same]\ntype = \"dielectric\"\nior = 1\n\
             [[shapes]]\ntype = \"sphere\"\nmaterial = \"same\"\nradius = {r}\n"
        ));
    }
    crate::support::load_str(&text)
}

/// Inner radii down to a gap of 1e-7 (radius 0.9999999, the f32 next to it being 1 − 1.2e-7):
/// half an f32 ulp of the sphere's far side 5 units from the camera, so the two surfaces' points
/// round to the same f32 positions and only the exact origins of rays leaving a sphere keep them
/// apart.
const INNER_RADII: [f64; 3] = [0.99999, 0.999999, 0.9999999];

#[test]
fn an_index_matched_sphere_just_inside_glass_is_invisible() {
    let all: Vec<u32> = (0..32 * 32).collect();
    // Alone in the environment every pixel is exactly 1, with or without the inner sphere.
    for r in INNER_RADII {
        let scene = glass_checker_with_inner(Some(r), true);
        let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
        estimate(&scene, &tracer, &all, 16, 0).assert_within_3se(1.0, &format!("inner {r}"));
    }
    // In front of the checker: each 8×8 block against the same block without the inner sphere.
    let plain = glass_checker_with_inner(None, false);
    let plain_tracer = AnyTracer::build(TracerKind::Bvh, &plain, 1).unwrap();
    let blocks: Vec<Vec<u32>> = (0..16)
        .map(|b| {
            let (bx, by) = (b % 4 * 8, b / 4 * 8);
            (0..64).map(|i| (by + i / 8) * 32 + bx + i % 8).collect()
        })
        .collect();
    let refs: Vec<_> = blocks
        .iter()
        .map(|px| estimate(&plain, &plain_tracer, px, 16, 0))
        .collect();
    for r in INNER_RADII {
        let scene = glass_checker_with_inner(Some(r), false);
        let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
        for (px, want) in blocks.iter().zip(&refs) {
            let got = estimate(&scene, &tracer, px, 16, 0);
            let se = (got.se * got.se + want.se * want.se).sqrt();
            // 4σ over 48 independent comparisons: a false alarm has p ≈ 3e-3.
            assert!(
                (got.mean - want.mean).abs() <= 4.0 * se + 1e-6,
                "inner {r}: block at pixel {} is {:.4} without the sphere {:.4} (se {:.4})",
                px[0],
                got.mean,
                want.mean,
                se
            );
        }
    }
}

/// Fresnel reflectance of unpolarised light, in f64, written out here independently of the
/// renderer's: `eta` = n_transmitted / n_incident.
fn fresnel_reference(cos_i: f64, eta: f64) -> f64 {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// A single smooth interface of IOR 1.5 (the plane z = 0, glass below) in a uniform environment
/// of radiance 1, looked at from above and from below at several angles. A camera path either
/// reflects (probability R) and escapes on its own side, or refracts and escapes on the other,
/// carrying the radiance scaling 1/η² of crossing: L = R + (1 − R)/η², with η = 1.5 seen from
/// above and 1/1.5 seen from below (total internal reflection beyond 41.8°: L = 1). The
/// expected value averages the closed form over each pixel's footprint.
#[test]
fn dielectric_interface_matches_fresnel_at_several_angles() {
    let ior = 1.5f64;
    for (above, deg) in [
        (true, 0.0f64),
        (true, 45.0),
        (true, 70.0),
        (true, 85.0),
        (false, 0.0),
        (false, 30.0),
        (false, 40.0),
        (false, 60.0),
    ] {
        let (s, c) = deg.to_radians().sin_cos();
        let z = if above { 10.0 * c } else { -10.0 * c };
        let text = format!(
            "[camera]\norigin = [{}, 0, {z}]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 1\n\
             width = 4\nheight = 4\n[render]\nmax_depth = 64\n\
             [materials.glass]\ntype = \"dielectric\"\nior = {ior}\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"glass\"\n\
             transform = [{{ scale = [1000, 1000, 1] }}]\n\
             [[lights]]\ntype = \"environment\"\nradiance = [1, 1, 1]\n",
            10.0 * s
        );
        let scene = crate::support::load_str(&text);
        let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
        let eta = if above { ior } else { 1.0 / ior };
        let k = 8;
        let mut expected = 0.0;
        for p in 0..16u32 {
            for j in 0..k * k {
                let (jx, jy) = ((j % k) as f32 + 0.5, (j / k) as f32 + 0.5);
                let ray = scene
                    .camera
                    .pixel_ray(p % 4, p / 4, jx / k as f32, jy / k as f32);
                let d = ray.d.as_dvec3().normalize();
                let r = fresnel_reference(d.z.abs(), eta);
                expected += r + (1.0 - r) / (eta * eta);
            }
        }
        expected /= (16 * k * k) as f64;
        let pixels: Vec<u32> = (0..16).collect();
        let e = estimate(&scene, &tracer, &pixels, 4096, 0);
        eprintln!(
            "{} {deg}°: mean {:.5} expected {expected:.5} se {:.1e}",
            if above { "above" } else { "below" },
            e.mean,
            e.se
        );
        e.assert_within_3se(expected, &format!("above {above}, {deg}°"));
    }
}

/// The grazing-light class: a point light `h` above a diffuse plane seen from 30 units straight
/// above, at h = 1e-2 … 1e-5. The view is narrowed to ±8h around the light's foot so every pixel
/// is a small piece of the spike with a small σ; the plane spans ±16h so its hit points are
/// interpolated from nearby vertices. Each pixel's exact mean is (ρ/π)·I·Ω/area with the
/// *specified* height: 30 units from the camera f32 alone would round it (1e-4 to 0.9918e-4,
/// 1e-5 to 0.954e-5). The pooled relative error must sit within 4 of its standard errors,
/// held below 0.05 %: the f32-rounded height reads −0.7 % at 1e-4.
#[test]
fn grazing_point_light_matches_the_closed_form_at_every_height() {
    let (rho, cam_h, n, spp) = (0.5f64, 30.0f64, 32u32, 256u32);
    let mut failures = Vec::new();
    for h in [1e-2f64, 1e-3, 1e-4, 1e-5] {
        let half = 8.0 * h;
        let fov = 2.0 * (half / cam_h).atan().to_degrees();
        // Intensity h² keeps radiance near (ρ/π)·I/h² ≈ 0.16 at every height.
        let intensity = h * h;
        let s = 16.0 * h;
        let text = format!(
            "[camera]\norigin = [0, 0, {cam_h:?}]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n\
             fov_deg = {fov:?}\nwidth = {n}\nheight = {n}\n[render]\nmax_depth = 2\n\
             [materials.plane]\ntype = \"diffuse\"\nreflectance = [{rho}, {rho}, {rho}]\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"plane\"\n\
             transform = [{{ scale = [{s:?}, {s:?}, 1] }}]\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 0, {h:?}]\n\
             intensity = [{intensity:?}, {intensity:?}, {intensity:?}]\n"
        );
        let scene = crate::support::load_str(&text);
        let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
        // For the diagnosis: the height f32 alone keeps (the plane at −30 is exact).
        let h_f32 = match &scene.lights[0] {
            raysched::scene::Light::Point { position, .. } => position.z as f64 + cam_h,
            _ => unreachable!(),
        };
        let side = 2.0 * half / n as f64;
        let (mut rsum, mut rsum_f32, mut var_sum) = (0.0f64, 0.0f64, 0.0f64);
        let mut pixel_fail = None;
        for p in 0..n * n {
            let (px, py) = ((p % n) as f64, (p / n) as f64);
            let x = [-half + px * side, -half + (px + 1.0) * side];
            let y = [half - (py + 1.0) * side, half - py * side];
            let mean = |h| {
                rho / std::f64::consts::PI * intensity * rectangle_solid_angle(h, x, y)
                    / (side * side)
            };
            let (expected, expected_f32) = (mean(h), mean(h_f32));
            let e = estimate(&scene, &tracer, &[p], spp, 0);
            assert_eq!(e.nonfinite, 0, "h {h:e}: pixel {p}");
            let rel = e.mean / expected - 1.0;
            let rel_se = e.se / expected + 1e-6;
            // 5 standard errors per pixel: over 4 × 1024 pixels a false alarm has p ≈ 2e-3.
            if rel.abs() > 5.0 * rel_se && pixel_fail.is_none() {
                pixel_fail = Some(format!(
                    "pixel {p} {:+.3} % (se {:.3} %)",
                    100.0 * rel,
                    100.0 * rel_se
                ));
            }
            rsum += rel;
            rsum_f32 += e.mean / expected_f32 - 1.0;
            var_sum += rel_se * rel_se;
        }
        let m = (n * n) as f64;
        let (pooled, pooled_se) = (rsum / m, var_sum.sqrt() / m);
        eprintln!(
            "h {h:e}: pooled {:+.4} % ± {:.4} % against h; {:+.4} % against the f32-rounded \
             height {h_f32:e}",
            100.0 * pooled,
            100.0 * pooled_se,
            100.0 * rsum_f32 / m,
        );
        assert!(
            pooled_se < 5e-4,
            "h {h:e}: pooled se {pooled_se} too wide to see a 0.3 % bias"
        );
        if pooled.abs() > 4.0 * pooled_se {
            failures.push(format!(
                "h {h:e}: pooled relative error {:+.4} % (± {:.4} %)",
                100.0 * pooled,
                100.0 * pooled_se
            ));
        } else if let Some(f) = pixel_fail {
            failures.push(format!("h {h:e}: {f}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}
