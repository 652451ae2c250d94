//! Leaks through shared edges, per tracer: rays from inside a closed, star-shaped mesh aimed at
//! its vertices and edge midpoints must all hit it. `bvh` and `brute` use the watertight triangle
//! test (`geometry::ShearedRay`) behind a conservative slab test, so their rows are required to
//! be 0. Embree's rows (3 and 4, default and `RTC_SCENE_FLAG_ROBUST`) are reported only: its
//! rounding depends on the kernels it picks for the CPU.

use super::{count_case, failed, CaseResult};
use crate::core::geometry::Ray;
use crate::core::scene::{load_scene_str, Scene, SceneOverrides};
use crate::core::tracer::{AnyTracer, Tracer, TracerKind};
use glam::Vec3;
use std::path::Path;

/// A displaced sphere of ~`count` triangles, its centre 1e3 from the camera so render-space
/// vertices carry the rounding of large coordinates.
fn mesh_scene(count: u64) -> Result<Scene, String> {
    let text = format!(
        r#"name = "watertight"
[camera]
origin = [0, 0, 1000]
target = [0, 0, 0]
up = [0, 1, 0]
fov_deg = 1
width = 8
height = 8
[render]
spp = 1
max_depth = 1
seed = 1
[materials.m]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "displaced_sphere"
material = "m"
count = {count}
displacement = 0.1
"#
    );
    load_scene_str(
        &text,
        "watertight",
        Path::new("."),
        "watertight",
        &SceneOverrides::default(),
    )
    .map_err(|e| e.to_string())
}

/// Rays from the mesh's vertex centroid through every vertex and edge midpoint.
fn probe_rays(scene: &Scene) -> Vec<Ray> {
    let tris = &scene.geometry.triangles;
    let verts: Vec<[Vec3; 3]> = tris.iter().map(|t| t.vertices()).collect();
    // In f64: an f32 running sum over 10⁵ vertices 10³ away drifts by whole radii.
    let n = (verts.len() * 3) as f64;
    let sum = verts
        .iter()
        .flatten()
        .fold(glam::DVec3::ZERO, |s, v| s + v.as_dvec3());
    let centre = (sum / n).as_vec3();
    verts
        .iter()
        .flat_map(|[a, b, c]| {
            [
                *a,
                *b,
                *c,
                (*a + *b) * 0.5,
                (*b + *c) * 0.5,
                (*c + *a) * 0.5,
            ]
        })
        .map(|p| Ray::new(centre, p - centre))
        .collect()
}

/// One row per tracer this build has: rays that missed the closed mesh.
pub fn watertight_cases(count: u64, out: &mut Vec<CaseResult>) {
    let case = |id: &str| format!("{id}: rays at vertices and edge midpoints of a closed mesh");
    let scene = match mesh_scene(count) {
        Ok(s) => s,
        Err(e) => return out.push(failed("watertight", &case("all"), e)),
    };
    let rays = probe_rays(&scene);
    for kind in TracerKind::ALL {
        // Brute force tests every triangle per ray; it shares bvh's triangle routine anyway.
        if !kind.compiled_in() || (kind == TracerKind::Brute && count > 5_000) {
            continue;
        }
        let id = kind.id();
        let note = format!(
            "{} triangles, {} rays from inside: each miss is a leak",
            scene.geometry.triangles.len(),
            rays.len()
        );
        let mut row = match AnyTracer::build(kind, &scene, 1) {
            Ok(t) => {
                let leaks = rays
                    .iter()
                    .filter(|r| t.intersect(r, f32::INFINITY).is_none())
                    .count();
                count_case("watertight", &case(id), 0, leaks as u64, &note)
            }
            Err(e) => failed("watertight", &case(id), e.to_string()),
        };
        row.required = matches!(kind, TracerKind::Bvh | TracerKind::Brute);
        out.push(row);
    }
}
