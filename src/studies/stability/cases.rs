//! The cases of the stability suite, each a small scene written out here in TOML.

use super::paired::{emitters_on_black, paired_case, point_lit_plane};
use super::transform::load_transformed;
use super::{
    against_reference, against_scene, count_case, equal_power, failed, Budget, CaseResult,
};
use crate::core::render::Image;
use crate::core::scene::{load_scene_str, Scene, SceneOverrides};
use crate::core::tracer::{AnyTracer, TracerKind};
use crate::studies::converge::reference::{analytic, Reference, ReferenceKind};
use std::path::Path;

const FURNACE: &str = include_str!("../../../scenes/furnace_a08.toml");
const CORNELL: &str = include_str!("../../../scenes/cornell_box.toml");
const GLASS_CHECKER: &str = include_str!("../../../scenes/glass_checker.toml");

fn overrides(b: &Budget, spp: u32) -> SceneOverrides {
    SceneOverrides {
        width: Some(b.size),
        height: Some(b.size),
        spp: Some(spp),
        ..Default::default()
    }
}

fn load(text: &str, name: &str, o: &SceneOverrides) -> Result<Scene, String> {
    load_scene_str(text, name, Path::new("."), name, o).map_err(|e| e.to_string())
}

fn tracer(scene: &Scene) -> Result<AnyTracer, String> {
    AnyTracer::build(TracerKind::Bvh, scene, 1).map_err(|e| e.to_string())
}

/// A case against the scene's analytic reference.
fn analytic_case(
    group: &str,
    case: &str,
    text: &str,
    o: &SceneOverrides,
    b: &Budget,
) -> CaseResult {
    let run = || -> Result<CaseResult, String> {
        let scene = load(text, case, o)?;
        let t = tracer(&scene)?;
        let r = analytic(&scene).ok_or("the scene has no analytic reference")?;
        let mut res = against_reference(group, case, &scene, &t, &r, b);
        if r.ambiguous > 0 {
            res.note = format!(
                "{}; {} sub-pixel rays on an outline or hidden surface",
                res.note, r.ambiguous
            );
        }
        Ok(res)
    };
    run().unwrap_or_else(|e| failed(group, case, e))
}

/// A case whose every pixel must equal `value` (energy tests).
fn constant_case(group: &str, case: &str, text: &str, value: f32, b: &Budget) -> CaseResult {
    let run = || -> Result<CaseResult, String> {
        let scene = load(text, case, &overrides(b, b.spp * 2))?;
        let t = tracer(&scene)?;
        let r = Reference {
            image: Image {
                width: scene.width(),
                height: scene.height(),
                data: vec![[value; 3]; scene.pixel_count()],
            },
            exact: vec![true; scene.pixel_count()],
            kind: ReferenceKind::Interior,
            ambiguous: 0,
            noise_mse: 0.0,
        };
        let mut res = against_reference(group, case, &scene, &t, &r, b);
        res.note = format!("every pixel = {value}; {}", res.note);
        Ok(res)
    };
    run().unwrap_or_else(|e| failed(group, case, e))
}

/// The transforms `(s, t, required)` of the scale group.
pub fn transforms(quick: bool) -> Vec<(f64, f64, bool)> {
    if quick {
        return vec![
            (1e-6, 0.0, true),
            (1e6, 0.0, true),
            (1.0, 1e6, true),
            (1e-6, 1e6, true),
        ];
    }
    let mut v = Vec::new();
    for s in [1e-6, 1e-3, 1.0, 1e3, 1e6] {
        for t in [0.0, 1e3, 1e6] {
            if !(s == 1.0 && t == 0.0) {
                v.push((s, t, true));
            }
        }
    }
    // At t = 1e8 an f64 input coordinate resolves 1.5e-8: a scene of size 1e-6 is quantised to
    // 1.5 % of its extent before anything is rendered, which no renderer can undo (reported
    // only). Scales 1 and 1e6 keep their precision and are required.
    v.extend([(1.0, 1e8, true), (1e-6, 1e8, false), (1e6, 1e8, true)]);
    v
}

fn scale_cases(name: &str, text: &str, o: &SceneOverrides, b: &Budget, out: &mut Vec<CaseResult>) {
    let base = match load(text, name, o).and_then(|s| tracer(&s).map(|t| (s, t))) {
        Ok(x) => x,
        Err(e) => return out.push(failed("scale", name, e)),
    };
    for (s, t, required) in transforms(b.quick) {
        let case = format!("{name} s={s:e} t={t:e}");
        let r = load_transformed(text, name, Path::new("."), s, t, o)
            .map_err(|e| e.to_string())
            .and_then(|sc| tracer(&sc).map(|tr| (sc, tr)));
        let mut res = match r {
            Ok((sc, tr)) => against_scene("scale", &case, &sc, &tr, &base.0, &base.1, b),
            Err(e) => failed("scale", &case, e),
        };
        res.required = required;
        if !required {
            res.note += "; report only: the f64 input quantises this scene to 1.5 % of its size";
        }
        out.push(res);
    }
}

fn env_scene(camera: &str, materials: &str, shapes: &str, max_depth: i32) -> String {
    format!(
        "[camera]\n{camera}\nwidth = 32\nheight = 32\n[render]\nspp = 8\nmax_depth = {max_depth}\nseed = 3\n\
         {materials}\n{shapes}\n[[lights]]\ntype = \"environment\"\nradiance = [1, 1, 1]\n"
    )
}

const GREY: &str = "[materials.grey]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n";

fn geometry_cases(b: &Budget, out: &mut Vec<CaseResult>) {
    let o = overrides(b, b.spp);
    let plane = "[[shapes]]\ntype = \"rectangle\"\nmaterial = \"grey\"\ntransform = [{ rotate = { axis = [1, 0, 0], deg = -90 } }, { scale = [1000, 1000, 1] }]\n";
    let grazing = env_scene(
        "origin = [0, 0.01, 0]\ntarget = [0, 0, -10]\nup = [0, 1, 0]\nfov_deg = 20",
        GREY,
        plane,
        8,
    );
    out.push(analytic_case(
        "grazing",
        "plane seen at grazing angles",
        &grazing,
        &o,
        b,
    ));
    let cube = "[[shapes]]\ntype = \"cube\"\nmaterial = \"grey\"\n";
    let edge = env_scene(
        "origin = [1, 1, 6]\ntarget = [1, 1, 0]\nup = [0, 1, 0]\nfov_deg = 30",
        GREY,
        cube,
        8,
    );
    out.push(analytic_case(
        "grazing",
        "rays along a box edge",
        &edge,
        &o,
        b,
    ));
    for gap in [0.01, 1e-5] {
        let shapes = format!(
            "{plane_top}[[shapes]]\ntype = \"rectangle\"\nmaterial = \"bright\"\ntransform = [{{ translate = [0, {y}, 0] }}, {{ rotate = {{ axis = [1, 0, 0], deg = -90 }} }}, {{ scale = 3 }}]\n",
            plane_top = "[[shapes]]\ntype = \"rectangle\"\nmaterial = \"grey\"\ntransform = [{ rotate = { axis = [1, 0, 0], deg = -90 } }, { scale = 3 }]\n",
            y = -gap
        );
        let mats = format!(
            "{GREY}[materials.bright]\ntype = \"diffuse\"\nreflectance = [0.9, 0.9, 0.9]\n"
        );
        let text = env_scene(
            "origin = [0, 1.5, 2]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40",
            &mats,
            &shapes,
            8,
        );
        out.push(analytic_case(
            "coincident",
            &format!("plane {gap:e} above another"),
            &text,
            &o,
            b,
        ));
    }
    let vertex_out = env_scene(
        "origin = [1, 1, 1]\ntarget = [2, 2, 3]\nup = [0, 1, 0]\nfov_deg = 40",
        GREY,
        cube,
        8,
    );
    out.push(analytic_case(
        "edge_vertex",
        "camera on a vertex, looking out",
        &vertex_out,
        &o,
        b,
    ));
    let vertex_in = env_scene(
        "origin = [1, 1, 1]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40",
        GREY,
        cube,
        8,
    );
    out.push(analytic_case(
        "edge_vertex",
        "camera on a vertex, looking in (black)",
        &vertex_in,
        &o,
        b,
    ));
    let edge_mid = env_scene(
        "origin = [1, 1, 0]\ntarget = [2, 2, 0.5]\nup = [0, 0, 1]\nfov_deg = 60",
        GREY,
        cube,
        8,
    );
    out.push(analytic_case(
        "edge_vertex",
        "camera on an edge, looking out",
        &edge_mid,
        &o,
        b,
    ));
    degenerate_cases(b, out);
}

/// A mesh with zero-area triangles (skipped at load, counted) and needles (kept, never NaN).
fn degenerate_cases(b: &Budget, out: &mut Vec<CaseResult>) {
    let run = || -> Result<Vec<CaseResult>, String> {
        let dir = std::env::temp_dir().join(format!("raysched-stab-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
                   v 0 0 0.5\nv 0.5 0 0.5\nv 1 0 0.5\n\
                   v 0 0 0.2\nv 0.8 0 0.2\nv 0.8 1e-7 0.2\nv 0 0 0.3\nv 0.9 0.3 0.3\nv 0.9 0.3 0.30001\n\
                   f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 5 6\nf 8 9 10\nf 11 12 13\n";
        std::fs::write(dir.join("degenerate.obj"), obj).map_err(|e| e.to_string())?;
        let text = env_scene(
            "origin = [0.3, -0.4, 3]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 50",
            GREY,
            "[[shapes]]\ntype = \"mesh\"\nmaterial = \"grey\"\npath = \"degenerate.obj\"\n",
            8,
        );
        let scene = load_scene_str(
            &text,
            "degenerate",
            &dir,
            "degenerate",
            &overrides(b, b.spp),
        )
        .map_err(|e| e.to_string())?;
        let _ = std::fs::remove_dir_all(&dir);
        let t = tracer(&scene)?;
        let mut v = vec![count_case(
            "degenerate",
            "zero-area triangles skipped at load",
            2,
            scene.load_stats.degenerate_triangles,
            "collinear + repeated vertex",
        )];
        let m = crate::studies::converge::reference::image_moments(
            &scene,
            &t,
            0..scene.settings.spp,
            false,
            b.threads,
        );
        let mut r = count_case(
            "degenerate",
            "needle triangles: NaN/Inf samples",
            0,
            m.nonfinite,
            "two needles, widths 1e-7 and 1e-5",
        );
        r.nonfinite = m.nonfinite;
        v.push(r);
        Ok(v)
    };
    match run() {
        Ok(v) => out.extend(v),
        Err(e) => out.push(failed("degenerate", "mesh with degenerate triangles", e)),
    }
}

fn dielectric_cases(b: &Budget, out: &mut Vec<CaseResult>) {
    let glass = |ior: f64| format!("[materials.glass]\ntype = \"dielectric\"\nior = {ior}\n");
    let cam = "origin = [0, 0, 4]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 40";
    let sphere = "[[shapes]]\ntype = \"sphere\"\nmaterial = \"glass\"\nradius = 1\n";
    out.push(constant_case(
        "dielectric",
        "energy: glass sphere alone (IOR 1.5)",
        &env_scene(cam, &glass(1.5), sphere, 64),
        1.0,
        b,
    ));
    let tir_cube = "[[shapes]]\ntype = \"cube\"\nmaterial = \"glass\"\ntransform = [{ rotate = { axis = [0, 1, 0], deg = 30 } }, { rotate = { axis = [1, 0, 0], deg = 20 } }]\n";
    out.push(constant_case(
        "dielectric",
        "total internal reflection: glass cube",
        &env_scene(cam, &glass(1.5), tir_cube, 64),
        1.0,
        b,
    ));
    let nested = format!(
        "{}[materials.bubble]\ntype = \"dielectric\"\nior = 0.6666666666666666\n",
        glass(1.5)
    );
    let nested_shapes = "[[shapes]]\ntype = \"sphere\"\nmaterial = \"glass\"\nradius = 1\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"bubble\"\nradius = 0.5\n";
    out.push(constant_case(
        "dielectric",
        "nested glass: air bubble in a glass sphere",
        &env_scene(cam, &nested, nested_shapes, 64),
        1.0,
        b,
    ));
    // IOR 1.0 must be invisible: glass_checker with IOR 1 against the backdrop alone.
    let o = overrides(b, b.spp * 2);
    let run = || -> Result<CaseResult, String> {
        let with = GLASS_CHECKER.replace("ior = 1.5", "ior = 1.0");
        if with == GLASS_CHECKER {
            return Err("glass_checker.toml has no 'ior = 1.5' to replace".into());
        }
        let mut file: crate::core::scene::SceneFile =
            toml::from_str(GLASS_CHECKER).map_err(|e| e.to_string())?;
        file.shapes
            .retain(|s| !matches!(s, crate::core::scene::format::ShapeSpec::Sphere { .. }));
        let without = toml::to_string(&file).map_err(|e| e.to_string())?;
        let a = load(&with, "ior1", &o)?;
        let bsc = load(&without, "backdrop", &o)?;
        let (ta, tb) = (tracer(&a)?, tracer(&bsc)?);
        Ok(against_scene(
            "dielectric",
            "sphere of IOR 1.0 is invisible",
            &a,
            &ta,
            &bsc,
            &tb,
            b,
        ))
    };
    out.push(run().unwrap_or_else(|e| failed("dielectric", "sphere of IOR 1.0 is invisible", e)));
}

fn stiff_cases(b: &Budget, out: &mut Vec<CaseResult>) {
    let plane_cam = "[camera]\norigin = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 60\nwidth = 33\nheight = 33\n";
    let plane = "[materials.plane]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
                 [[shapes]]\ntype = \"rectangle\"\nmaterial = \"plane\"\ntransform = [{ scale = [1000, 1000, 1] }]\n";
    // Side 1e-4 at height 2, radiance 1e9: the power of a 10 W/sr Lambertian point.
    let tiny = format!(
        "{plane_cam}[render]\nspp = 8\nmax_depth = 8\nseed = 5\n{plane}\
         [[shapes]]\ntype = \"rectangle\"\nmaterial = \"plane\"\nemission = [1e9, 1e9, 1e9]\n\
         transform = [{{ translate = [0, 0, 2] }}, {{ rotate = {{ axis = [1, 0, 0], deg = 180 }} }}, {{ scale = 5e-5 }}]\n"
    );
    let o = SceneOverrides {
        spp: Some(b.spp * 2),
        ..Default::default()
    };
    out.push(analytic_case(
        "stiff",
        "tiny very bright area light (1e-4 side, L=1e9)",
        &tiny,
        &o,
        b,
    ));
    out.extend(equal_power_case(b));
    let heights: &[f64] = if b.quick {
        &[1e-3]
    } else {
        &[1e-2, 1e-3, 1e-4]
    };
    for h in heights {
        let text = format!(
            "{plane_cam}[render]\nspp = 8\nmax_depth = 8\nseed = 5\n{plane}\
             [[lights]]\ntype = \"point\"\nposition = [0.01, 0.02, {h}]\nintensity = [10, 10, 10]\n"
        );
        out.push(point_light_case(
            &format!("point light {h:e} above the plane"),
            &text,
            &o,
            b,
        ));
    }
    let interior = "[camera]\norigin = [0, 0, 0]\ntarget = [0, 0, -1]\nup = [0, 1, 0]\nfov_deg = 90\nwidth = 8\nheight = 8\n\
                    [render]\nspp = 4\nmax_depth = -1\nseed = 7\n\
                    [materials.wall]\ntype = \"diffuse\"\nreflectance = [0.999, 0.999, 0.999]\n\
                    [[shapes]]\ntype = \"sphere\"\nmaterial = \"wall\"\nradius = 1\nflip_normals = true\nemission = [1, 1, 1]\n";
    let spp = if b.quick { 16 } else { 128 };
    let o = SceneOverrides {
        spp: Some(spp),
        ..Default::default()
    };
    out.push(analytic_case(
        "stiff",
        "albedo 0.999, unlimited depth (L = 1000)",
        interior,
        &o,
        b,
    ));
}

/// A tiny, very bright light against a large one of the same power (radiance × area), both
/// facing the camera at the same place: the image mean is the same (a fronto-parallel square
/// projects to the film with its area scaled by a constant), but the tiny light's mean rests
/// on the few samples that hit it. (Seen only through the plane it lights, next-event
/// estimation makes a tiny light easy, not stiff: the direct view is the hard case.)
fn equal_power_case(b: &Budget) -> Vec<CaseResult> {
    // Quick: side 0.02 (≈ 1 % of a pixel's footprint, ≈ 20 hits at 2048 spp); full: side
    // 0.01, 8192 spp (same expected hits, 4× the radiance ratio).
    let (side, spp): (f64, u32) = if b.quick { (0.02, 2048) } else { (0.01, 8192) };
    let large_side = 1.0;
    let large_l = 1000.0;
    let tiny_l = large_l * (large_side / side).powi(2);
    let case =
        format!("equal power: tiny light (side {side}, L={tiny_l:e}) vs large (side 1, L=1e3)");
    let mut paired_rows = Vec::new();
    let mut run = || -> Result<CaseResult, String> {
        let o = SceneOverrides::default();
        let tiny = load(&square_light(side, tiny_l, spp), "tiny_light", &o)?;
        let large = load(&square_light(large_side, large_l, spp), "large_light", &o)?;
        let (tt, tl) = (tracer(&tiny)?, tracer(&large)?);
        for (scene, t, which) in [(&tiny, &tt, "tiny"), (&large, &tl, "large")] {
            let closed = emitters_on_black(scene).ok_or("no closed form for the light")?;
            let name = format!(
                "equal power, {which} light (side {}): rendered vs closed form",
                if which == "tiny" { side } else { large_side }
            );
            paired_rows.push(paired_case("stiff", &name, scene, t, &*closed, b).0);
        }
        let mut r = equal_power("stiff", &case, (&tiny, &tt), (&large, &tl), b);
        // The film spans 2·3·tan 30° at the lights' distance 3.
        let film = (2.0 * 3.0 * 30f64.to_radians().tan()).powi(2);
        r.note += &format!(
            "; analytic mean L·A/film = {:.4}",
            large_l * large_side * large_side / film
        );
        Ok(r)
    };
    let r = run().unwrap_or_else(|e| failed("stiff", &case, e));
    paired_rows.push(r);
    paired_rows
}

/// A point light over a plane: every sample against the closed form of its own camera ray
/// (the required, tight comparison), and the image against the exact pixel integrals (a check
/// of the pixel sampling, within the image's Monte Carlo 3σ). Both must pass.
fn point_light_case(case: &str, text: &str, o: &SceneOverrides, b: &Budget) -> CaseResult {
    let run = || -> Result<CaseResult, String> {
        let scene = load(text, case, o)?;
        let t = tracer(&scene)?;
        let closed = point_lit_plane(&scene).ok_or("the scene has no per-sample closed form")?;
        let (mut r, _) = paired_case("stiff", case, &scene, &t, &*closed, b);
        let reference = analytic(&scene).ok_or("the scene has no analytic reference")?;
        let integral = against_reference("stiff", case, &scene, &t, &reference, b);
        r.pass &= integral.pass;
        r.note = format!(
            "{}; image vs exact pixel integrals {:.6} vs {:.6} (3σ {:.1e}, {})",
            r.note,
            integral.measured,
            integral.expected,
            3.0 * integral.sigma,
            if integral.pass { "pass" } else { "FAIL" }
        );
        Ok(r)
    };
    run().unwrap_or_else(|e| failed("stiff", case, e))
}

/// A square light of side `side` and radiance `l`, 3 units in front of a 17×17 camera with a
/// 60° field of view and facing it, on black (the equal-power case's scenes).
pub fn square_light(side: f64, l: f64, spp: u32) -> String {
    format!(
        "[camera]\norigin = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_deg = 60\nwidth = 17\nheight = 17\n\
         [render]\nspp = {spp}\nmax_depth = 4\nseed = 11\n\
         [materials.black]\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\
         [[shapes]]\ntype = \"rectangle\"\nmaterial = \"black\"\nemission = [{l:e}, {l:e}, {l:e}]\n\
         transform = [{{ translate = [0, 0, 2] }}, {{ scale = {:e} }}]\n",
        side / 2.0
    )
}

/// Run every case (the short list when `budget.quick`).
pub fn run_suite(b: &Budget) -> Vec<CaseResult> {
    let mut out = Vec::new();
    let o = overrides(b, b.spp);
    scale_cases("furnace_a08", FURNACE, &o, b, &mut out);
    let cornell = SceneOverrides {
        width: Some(b.size),
        height: Some(b.size),
        spp: Some(b.spp),
        ..Default::default()
    };
    scale_cases("cornell_box", CORNELL, &cornell, b, &mut out);
    geometry_cases(b, &mut out);
    dielectric_cases(b, &mut out);
    stiff_cases(b, &mut out);
    let mesh = if b.quick { 2_000 } else { 200_000 };
    super::watertight::watertight_cases(mesh, &mut out);
    out
}
