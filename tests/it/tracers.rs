//! `bvh` agrees with `brute` on the closest hit for thousands of random rays over random
//! scenes: rays from inside boxes, grazing rays, rays that miss everything.

use crate::support::{CAMERA_4X4, GREY_M};
use glam::Vec3;
use raysched::geometry::{Ray, ShearedRay, Triangle, Triangle4};
use raysched::rng::Sampler;
use raysched::scene::Scene;
use raysched::tracer::{BruteTracer, BvhTracer, Tracer};

/// A random scene: cubes, random triangles and spheres from one seed.
fn random_scene(seed: u64) -> Scene {
    let mut s = Sampler::new(seed, 0, 0);
    let mut r = move || s.next() as f64;
    let mut text = format!("{CAMERA_4X4}{GREY_M}");
    for _ in 0..4 {
        text += &format!(
            "[[shapes]]\ntype = \"cube\"\nmaterial = \"m\"\ntransform = [{{ translate = [{}, {}, {}] }}, {{ rotate = {{ axis = [{}, 1, {}], deg = {} }} }}, {{ scale = [{}, {}, {}] }}]\n",
            r() * 6.0 - 3.0, r() * 6.0 - 3.0, r() * 6.0 - 3.0,
            r(), r(), r() * 360.0,
            0.2 + r(), 0.2 + r(), 0.2 + r()
        );
    }
    for _ in 0..3 {
        text +=
            &format!(
            "[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [{}, {}, {}]\nradius = {}\n",
            r() * 6.0 - 3.0, r() * 6.0 - 3.0, r() * 6.0 - 3.0, 0.1 + r()
        );
    }
    text += &format!(
        "[[shapes]]\ntype = \"random_triangles\"\nmaterial = \"m\"\ncount = 300\ntriangle_size = 0.6\nseed = {seed}\ntransform = [{{ scale = 3 }}]\n"
    );
    crate::support::load_str(&text)
}

pub(crate) fn random_dir(s: &mut Sampler) -> Vec3 {
    let z = 1.0 - 2.0 * s.next();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * s.next();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Closest hits agree: same primitive and t within 1e-5 relative. Where the primitives differ,
/// both must be hit at the same t (a tie on a shared edge), which brute force confirms.
pub(crate) fn assert_agree(
    scene: &Scene,
    bvh: &BvhTracer,
    brute: &BruteTracer,
    ray: &Ray,
    what: &str,
) {
    let a = bvh.intersect(ray, f32::INFINITY);
    let b = brute.intersect(ray, f32::INFINITY);
    match (a, b) {
        (None, None) => {}
        (Some(a), Some(b)) => {
            assert!(
                (a.t - b.t).abs() <= 1e-5 * b.t.abs(),
                "{what}: t {} vs {}",
                a.t,
                b.t
            );
            if a.prim != b.prim {
                let other = scene
                    .geometry
                    .intersect_prim(a.prim, ray, f32::INFINITY)
                    .unwrap();
                // A tie: the bvh's primitive really is hit at the t it reported, which matched
                // brute force's above (coplanar overlapping triangles, as a fan over a concave
                // polygon makes, differ there in the last bits).
                assert_eq!(
                    other.t, a.t,
                    "{what}: prim {} vs {} is not a tie",
                    a.prim, b.prim
                );
            }
        }
        _ => panic!("{what}: bvh {a:?} vs brute {b:?}"),
    }
    assert_eq!(
        bvh.occluded(ray, f32::INFINITY),
        b.is_some(),
        "{what}: occluded disagrees with intersect"
    );
    if let Some(b) = b {
        // Nothing before the closest hit.
        assert!(
            !bvh.occluded(ray, b.t * 0.999),
            "{what}: occluded before the closest hit"
        );
    }
}

#[test]
fn bvh_matches_brute_force_on_random_scenes() {
    let mut hits = 0;
    let mut total = 0;
    for seed in 0..6 {
        let scene = random_scene(seed);
        let bvh = BvhTracer::new(&scene.geometry);
        let brute = BruteTracer::new(&scene.geometry);
        let mut s = Sampler::new(seed, 1, 1);
        for i in 0..1500 {
            // Origins anywhere in a box around the scene (often inside cubes and spheres).
            let o = Vec3::new(s.next(), s.next(), s.next()) * 10.0
                - Vec3::splat(5.0)
                - scene.origin.as_vec3();
            let ray = Ray::new(o, random_dir(&mut s));
            assert_agree(&scene, &bvh, &brute, &ray, &format!("seed {seed} ray {i}"));
            hits += brute.intersect(&ray, f32::INFINITY).is_some() as u32;
            total += 1;
        }
        // Rays that miss everything: from far away, pointing away.
        for i in 0..100 {
            let d = random_dir(&mut s);
            let ray = Ray::new(d * 100.0, d);
            assert!(bvh.intersect(&ray, f32::INFINITY).is_none(), "miss {i}");
            assert!(!bvh.occluded(&ray, f32::INFINITY));
        }
    }
    // The sample must contain both hits and misses to mean anything.
    assert!(hits > total / 10 && hits < total * 9 / 10, "{hits}/{total}");
}

#[test]
fn grazing_rays_and_rays_along_box_edges_agree() {
    let scene = crate::support::load_str(&format!(
        "{CAMERA_4X4}{GREY_M}\
         [[shapes]]\ntype = \"cube\"\nmaterial = \"m\"\n\
         [[shapes]]\ntype = \"rectangle\"\nmaterial = \"m\"\ntransform = [{{ translate = [0, -1.01, 0] }}, {{ rotate = {{ axis = [1, 0, 0], deg = -90 }} }}, {{ scale = 5 }}]\n"
    ));
    let bvh = BvhTracer::new(&scene.geometry);
    let brute = BruteTracer::new(&scene.geometry);
    let off = -scene.origin.as_vec3();
    let mut s = Sampler::new(9, 9, 9);
    for i in 0..2000 {
        // Nearly parallel to the floor and to the cube faces, aimed at edges.
        let y = [-1.0f32, 1.0, -1.01][i % 3] + (s.next() - 0.5) * 1e-3;
        let o = Vec3::new(-4.0, y, (s.next() - 0.5) * 2.2) + off;
        let d = Vec3::new(1.0, (s.next() - 0.5) * 1e-3, (s.next() - 0.5) * 0.1).normalize();
        assert_agree(
            &scene,
            &bvh,
            &brute,
            &Ray::new(o, d),
            &format!("grazing {i}"),
        );
    }
}

#[test]
fn empty_scene_never_hits() {
    let scene = crate::support::load_str(CAMERA_4X4);
    let bvh = BvhTracer::new(&scene.geometry);
    let ray = Ray::new(Vec3::ZERO, Vec3::Z);
    assert!(bvh.intersect(&ray, f32::INFINITY).is_none());
    assert!(!bvh.occluded(&ray, f32::INFINITY));
}

#[test]
fn four_wide_test_is_bit_identical_to_the_one_triangle_test() {
    // A small counter-based generator: random triangles and rays; in half the cases every
    // coordinate is on a coarse grid, so lanes share vertices and edges, and a third of the
    // rays aim at a grid point (a vertex or edge: zero edge functions, the f64 path).
    let mut state = 1u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    let mut hits = 0;
    for case in 0..4000 {
        let grid = case % 2 == 0;
        let mut p = || {
            let v = Vec3::new(next(), next(), next());
            if grid {
                (v * 4.0).round() / 4.0
            } else {
                v
            }
        };
        let tris: Vec<Triangle> = (0..4).map(|_| Triangle::new(p(), p(), p())).collect();
        let mut t4 = Triangle4::default();
        for (l, t) in tris.iter().enumerate().take(3 + case % 2) {
            t4.set(l, t);
        }
        let o = p() * 3.0;
        let d = if case % 3 == 0 { p() - o } else { p() };
        let ray = Ray::new(o, d);
        let sr = ShearedRay::new(&ray);
        let t_max = [f32::INFINITY, 1.0, 0.5][case % 3];
        let h = t4.intersect_sheared(&sr, t_max);
        for (l, tri) in tris.iter().enumerate() {
            let one = if l < 3 + case % 2 {
                tri.intersect_sheared(&sr, t_max)
            } else {
                None
            };
            let four = if h.mask & (1 << l) != 0 {
                Some((h.t[l], h.b1[l], h.b2[l]))
            } else {
                None
            };
            let bits = |x: Option<(f32, f32, f32)>| {
                x.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()))
            };
            assert_eq!(bits(one), bits(four), "case {case} lane {l}");
            hits += one.is_some() as u32;
        }
    }
    assert!(hits > 400, "only {hits} hits: the sample tests little");
}
