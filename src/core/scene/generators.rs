//! Procedural shapes with one size knob (`count`), so a scene family spans 10 to 10 M
//! primitives without a big file in git. All output is in local space, inside [−1,1]³.

use crate::util::rng::Sampler;
use glam::DVec3;

/// A UV sphere of about `count` triangles (never fewer than 8) whose radius is modulated by a
/// smooth, deterministic bump pattern of relative amplitude `displacement`.
pub fn displaced_sphere(count: u64, displacement: f64) -> Vec<[DVec3; 3]> {
    // 2·rings·segments triangles with segments = 2·rings  →  rings = sqrt(count / 4).
    let rings = ((count as f64 / 4.0).sqrt().round() as usize).max(2);
    let segments = 2 * rings;
    let radius = |theta: f64, phi: f64| {
        let bump = (7.0 * theta).sin() * (5.0 * phi).cos() + 0.5 * (17.0 * theta + 3.0 * phi).sin();
        (1.0 + displacement * bump / 1.5) / (1.0 + displacement.abs())
    };
    let vertex = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        // A pole is one point: without this the bump moved each pole vertex along the axis
        // with φ and the caps were open slivers (the watertight stability case found it).
        let j = if i == 0 || i == rings { 0 } else { j };
        let phi = std::f64::consts::TAU * (j % segments) as f64 / segments as f64;
        let r = radius(theta, phi);
        DVec3::new(
            r * theta.sin() * phi.cos(),
            r * theta.cos(),
            r * theta.sin() * phi.sin(),
        )
    };
    let mut tris = Vec::with_capacity(2 * rings * segments);
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            // Counter-clockwise seen from outside: normals point outwards. The pole rows give
            // zero-area triangles, which the loader drops and counts.
            tris.push([a, d, c]);
            tris.push([a, c, b]);
        }
    }
    tris
}

/// `count` random triangles in [−1,1]³, each with edges of about `size`.
pub fn random_triangles(count: u64, size: f64, seed: u64) -> Vec<[DVec3; 3]> {
    (0..count)
        .map(|i| {
            let mut s = Sampler::new(seed, i, 0);
            let mut v = || DVec3::new(s.next() as f64, s.next() as f64, s.next() as f64);
            let c = v() * 2.0 - DVec3::ONE;
            let a = c + (v() - DVec3::splat(0.5)) * size;
            let b = c + (v() - DVec3::splat(0.5)) * size;
            let d = c + (v() - DVec3::splat(0.5)) * size;
            [a, b, d].map(|p| p.clamp(DVec3::splat(-1.0), DVec3::ONE))
        })
        .collect()
}

/// About `count` spheres on a k×k×k lattice filling [−1,1]³ (k = ⌈∛count⌉, the first `count`).
pub fn sphere_grid(count: u64) -> Vec<(DVec3, f64)> {
    let k = ((count as f64).cbrt().ceil() as u64).max(1);
    let spacing = 2.0 / k as f64;
    let r = 0.35 * spacing;
    (0..count)
        .map(|i| {
            let (x, y, z) = (i % k, (i / k) % k, i / (k * k));
            let c = |n: u64| -1.0 + spacing * (n as f64 + 0.5);
            (DVec3::new(c(x), c(y), c(z)), r)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_knob_controls_primitive_count() {
        for n in [10u64, 1000, 100_000] {
            let t = displaced_sphere(n, 0.1).len() as f64;
            assert!(t / n as f64 > 0.5 && t / (n as f64) < 2.0, "{n} → {t}");
            assert_eq!(random_triangles(n, 0.1, 1).len() as u64, n);
            assert_eq!(sphere_grid(n).len() as u64, n);
        }
    }

    #[test]
    fn displaced_sphere_stays_in_unit_box_and_faces_out() {
        for tri in displaced_sphere(2000, 0.2) {
            for v in tri {
                assert!(v.abs().max_element() <= 1.0 + 1e-12);
            }
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            let c = (tri[0] + tri[1] + tri[2]) / 3.0;
            assert!(n.dot(c) >= -1e-12, "inward-facing triangle");
        }
    }
}
