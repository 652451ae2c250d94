//! An f64 closest-hit query over every primitive of a scene, for analytic references: no
//! acceleration structure and no code shared with the tracers, so a reference built on it is
//! independent of the tracer it judges. A ray that passes within a relative margin of an edge
//! or grazes a sphere is *ambiguous*: f32 tracers may legitimately decide it either way, and
//! a reference must not count it as exact.

use crate::core::geometry::{Ray, Sphere, Triangle};
use crate::core::scene::Scene;
use glam::DVec3;

/// Barycentric margin (relative to the triangle) inside which an edge decision is ambiguous:
/// f32 vertices and f32 rays decide edges to ~1e-7 of a triangle's size, this is 100× that.
const EDGE_MARGIN: f64 = 1e-5;

/// Relative distance inside which two surfaces along a ray tie: ten f32 ulps of the distance,
/// so planes 1e-5 apart seen from 5 units (the stability suite's coincident case) stay apart.
const T_MARGIN: f64 = 1e-6;

/// Outcome of [`closest`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExactHit {
    /// The ray leaves the scene.
    Miss,
    /// The nearest surface: primitive id, distance along the ray's direction, and the oriented
    /// geometric normal (spheres flipped by their `flip` flag, as the renderer does).
    Hit {
        /// Primitive id (spheres first, then triangles).
        prim: u32,
        /// Distance in units of the direction's length.
        t: f64,
        /// Unit normal.
        n: DVec3,
    },
    /// An f32 tracer may decide this ray either way (edge, tangent, two surfaces at one t).
    Ambiguous,
}

/// A candidate surface along the ray, with its own ambiguity.
#[derive(Clone, Copy)]
struct Candidate {
    t: f64,
    n: DVec3,
    prim: u32,
    ambiguous: bool,
}

fn triangle(tri: &Triangle, o: DVec3, d: DVec3, prim: u32) -> Option<Candidate> {
    let [v0, v1, v2] = tri.vertices().map(|v| v.as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v0;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    let w = 1.0 - u - v;
    let t = e2.dot(q) * inv;
    let lo = -EDGE_MARGIN;
    if u < lo || v < lo || w < lo || t <= 0.0 {
        return None;
    }
    let ambiguous = u < EDGE_MARGIN || v < EDGE_MARGIN || w < EDGE_MARGIN;
    let n = e1.cross(e2).normalize();
    Some(Candidate {
        t,
        n,
        prim,
        ambiguous,
    })
}

fn sphere(s: &Sphere, flip: bool, o: DVec3, d: DVec3, prim: u32) -> Option<Candidate> {
    let c = s.center.as_dvec3();
    let r = s.radius as f64;
    let oc = o - c;
    let a = d.dot(d);
    let b = oc.dot(d);
    let disc = b * b - a * (oc.dot(oc) - r * r);
    // Tangent within a relative margin: the f32 test may miss or hit.
    let margin = EDGE_MARGIN * a * r * r;
    if disc < -margin {
        return None;
    }
    let root = disc.max(0.0).sqrt();
    let t = [(-b - root) / a, (-b + root) / a]
        .into_iter()
        .find(|t| *t > 1e-9 * r)?;
    let n = (o + d * t - c) / r;
    Some(Candidate {
        t,
        n: if flip { -n } else { n },
        prim,
        ambiguous: disc <= margin,
    })
}

/// The nearest surface along `ray` among every primitive of `scene`, in f64.
pub fn closest(scene: &Scene, ray: &Ray) -> ExactHit {
    let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
    let g = &scene.geometry;
    let ns = g.spheres.len() as u32;
    let spheres = g
        .spheres
        .iter()
        .enumerate()
        .filter_map(|(i, s)| sphere(s, g.info[i].flip, o, d, i as u32));
    let tris = g
        .triangles
        .iter()
        .enumerate()
        .filter_map(|(i, t)| triangle(t, o, d, ns + i as u32));
    let all: Vec<Candidate> = spheres.chain(tris).collect();
    let Some(best) = all.iter().copied().min_by(|a, b| a.t.total_cmp(&b.t)) else {
        return ExactHit::Miss;
    };
    // Other surfaces at the same distance: the same surface continued across a shared edge
    // (same normal, material and light) is benign; anything else makes the winner undefined.
    let same_surface = |c: &Candidate| {
        let (a, b) = (g.info[c.prim as usize], g.info[best.prim as usize]);
        c.n.dot(best.n) >= 1.0 - 1e-9 && a.material == b.material && a.light == b.light
    };
    let close: Vec<&Candidate> = all
        .iter()
        .filter(|c| c.prim != best.prim && (c.t - best.t).abs() <= T_MARGIN * best.t)
        .collect();
    if close.iter().any(|c| !same_surface(c)) {
        return ExactHit::Ambiguous;
    }
    // Near an edge with no continuation of the surface beyond it: the outline.
    if best.ambiguous && close.is_empty() {
        return ExactHit::Ambiguous;
    }
    ExactHit::Hit {
        prim: best.prim,
        t: best.t,
        n: best.n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::scene::SceneOverrides;
    use glam::Vec3;

    fn scene(text: &str) -> Scene {
        crate::core::scene::load_scene_str(
            text,
            "t",
            std::path::Path::new("."),
            "t",
            &SceneOverrides::default(),
        )
        .unwrap()
    }

    const HEAD: &str = "[camera]\norigin = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n\
                        fov_deg = 40\nwidth = 4\nheight = 4\n[render]\nspp = 1\n\
                        [materials.m]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n";

    #[test]
    fn sphere_hit_distance_and_normal_are_exact() {
        let s = scene(&format!(
            "{HEAD}[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\nradius = 1\n"
        ));
        let c = s.geometry.spheres[0].center;
        let ray = Ray::new(c + Vec3::new(0.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -1.0));
        match closest(&s, &ray) {
            ExactHit::Hit { prim, t, n } => {
                assert_eq!(prim, 0);
                assert!((t - 3.0).abs() < 1e-6, "t = {t}");
                assert!((n - DVec3::Z).length() < 1e-6);
            }
            other => panic!("{other:?}"),
        }
        // Tangent to the sphere: ambiguous; clearly beside it: a miss.
        let graze = Ray::new(c + Vec3::new(1.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(closest(&s, &graze), ExactHit::Ambiguous);
        let miss = Ray::new(c + Vec3::new(1.01, 0.0, 4.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(closest(&s, &miss), ExactHit::Miss);
    }

    #[test]
    fn a_rectangle_diagonal_is_one_surface_and_its_outline_is_ambiguous() {
        let s = scene(&format!(
            "{HEAD}[[shapes]]\ntype = \"rectangle\"\nmaterial = \"m\"\n"
        ));
        let [a, b, _] = s.geometry.triangles[0].vertices();
        let mid = (a + b) * 0.5;
        let t1 = s.geometry.triangles[1].vertices();
        let shared = a == t1[0] || a == t1[1] || a == t1[2];
        let down = Vec3::new(0.0, 0.0, -1.0);
        let at = |p: Vec3| closest(&s, &Ray::new(p + Vec3::new(0.0, 0.0, 2.0), down));
        // The mid-point of an edge: on the outline (ambiguous) or on the shared diagonal (a hit).
        let on_diagonal = shared && t1.contains(&b);
        match at(mid) {
            ExactHit::Hit { .. } => assert!(on_diagonal),
            ExactHit::Ambiguous => assert!(!on_diagonal),
            ExactHit::Miss => panic!("edge mid-point missed"),
        }
        let centre = s
            .geometry
            .triangles
            .iter()
            .flat_map(|t| t.vertices())
            .sum::<Vec3>()
            / 6.0;
        assert!(matches!(at(centre), ExactHit::Hit { .. }));
        assert_eq!(at(centre + Vec3::new(5.0, 0.0, 0.0)), ExactHit::Miss);
    }
}
