//! Bad scenes and flags: a one-line error naming the file and the field, exit code 2, no panic,
//! no output file written.

use std::path::Path;
use std::process::Command;

const GOOD: &str = concat!(
    crate::support::sphere_scene_8x8!(),
    r#"
[[shapes]]
type = "mesh"
material = "glass"
path = "tri.obj"
"#
);

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn run(dir: &Path, scene_text: &str, extra: &[&str]) -> (i32, String, bool) {
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let out = dir.join("out.exr");
    let _ = std::fs::remove_file(&out);
    let output = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--threads")
        .arg("1")
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    (output.status.code().unwrap_or(-1), stderr, out.exists())
}

#[test]
fn the_good_scene_renders() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), OBJ).unwrap();
    let (code, stderr, written) = run(dir.path(), GOOD, &[]);
    assert_eq!(code, 0, "{stderr}");
    assert!(written);
    assert!(dir.path().join("out.png").exists());
}

#[test]
fn each_bad_scene_is_a_one_line_error_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), OBJ).unwrap();
    let cases: &[(&str, String, &str)] = &[
        (
            "malformed toml",
            GOOD.replace("fov_deg = 40", "fov_deg = = 40"),
            "scene.toml:6:",
        ),
        (
            "unknown field",
            GOOD.replace("spp = 1", "spp = 1\nsamples = 4"),
            "unknown field `samples`",
        ),
        (
            "missing obj",
            GOOD.replace("tri.obj", "nope.obj"),
            "shapes[1].path",
        ),
        (
            "nan",
            GOOD.replace("radius = 1", "radius = nan"),
            "shapes[0].radius",
        ),
        (
            // No silent default for a shape's size.
            "sphere without radius",
            GOOD.replace("radius = 1\n", ""),
            "shapes[0].radius: missing",
        ),
        (
            "misspelt material",
            GOOD.replace("material = \"white\"", "material = \"whte\""),
            "unknown material 'whte', did you mean white?",
        ),
        (
            "inf",
            GOOD.replace("origin = [0, 0, 4]", "origin = [0, 0, inf]"),
            "camera.origin",
        ),
        (
            "width 0",
            GOOD.replace("width = 8", "width = 0"),
            "camera.width",
        ),
        (
            "height 0",
            GOOD.replace("height = 8", "height = 0"),
            "camera.height",
        ),
        (
            "fov 0",
            GOOD.replace("fov_deg = 40", "fov_deg = 0"),
            "camera.fov_deg",
        ),
        (
            "fov 180",
            GOOD.replace("fov_deg = 40", "fov_deg = 180"),
            "camera.fov_deg",
        ),
        (
            "radius 0",
            GOOD.replace("radius = 1", "radius = 0"),
            "shapes[0].radius",
        ),
        (
            "radius < 0",
            GOOD.replace("radius = 1", "radius = -2"),
            "shapes[0].radius",
        ),
        (
            "ior 0",
            GOOD.replace("ior = 1.5", "ior = 0"),
            "materials.glass.ior",
        ),
        (
            "target = origin",
            GOOD.replace("target = [0, 0, 0]", "target = [0, 0, 4]"),
            "camera.target",
        ),
        (
            "up parallel",
            GOOD.replace("up = [0, 1, 0]", "up = [0, 0, -3]"),
            "camera.up",
        ),
        (
            "unknown material",
            GOOD.replace("material = \"white\"", "material = \"chalk\""),
            "shapes[0].material",
        ),
        ("spp 0", GOOD.replace("spp = 1", "spp = 0"), "render.spp"),
        (
            "scale 0",
            GOOD.replace("radius = 1", "radius = 1\ntransform = [{ scale = 0 }]"),
            "shapes[0].transform",
        ),
        (
            "field of another shape type",
            GOOD.replace("path = \"tri.obj\"", "path = \"tri.obj\"\nradius = 2"),
            "shapes[1].radius",
        ),
        (
            "animation frames 0",
            format!("{GOOD}\n[animation]\nframes = 0\n"),
            "animation.frames",
        ),
        (
            "animation key out of range",
            format!("{GOOD}\n[animation]\nframes = 2\n[[animation.keys]]\nframe = 2\n"),
            "animation.keys[0].frame",
        ),
    ];
    for (what, text, needle) in cases {
        let (code, stderr, written) = run(dir.path(), text, &[]);
        assert_eq!(code, 2, "{what}: exit code, stderr: {stderr}");
        assert!(!written, "{what}: an output file was written");
        assert!(
            stderr.contains("scene.toml"),
            "{what}: file not named: {stderr}"
        );
        assert!(
            stderr.contains(needle),
            "{what}: '{needle}' not in: {stderr}"
        );
        assert_eq!(
            stderr.trim_end().lines().count(),
            1,
            "{what}: not one line: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{what}: panicked");
    }
}

#[test]
fn bad_flags_exit_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), OBJ).unwrap();
    for (flags, needle) in [
        (vec!["--spp", "0"], "--spp"),
        (vec!["--tracer", "optix"], "unknown tracer"),
        (
            vec!["--scheduler", "master", "--passes", "everyone"],
            "unknown master pass runner 'everyone'",
        ),
        (vec!["--passes", "workers"], "only master takes it"),
    ] {
        let (code, stderr, written) = run(dir.path(), GOOD, &flags);
        assert_eq!(code, 2, "{flags:?}: {stderr}");
        assert!(!written);
        assert!(stderr.contains(needle), "{flags:?}: {stderr}");
    }
    let missing = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args(["render", "/nonexistent/scene.toml", "-o"])
        .arg(dir.path().join("x.exr"))
        .output()
        .unwrap();
    assert_eq!(missing.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/scene.toml"));
}

/// `raysched advise` with `flags` on the good scene: (exit code, stdout, stderr).
fn advise(dir: &Path, scene_text: &str, flags: &[&str]) -> (i32, String, String) {
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .arg("advise")
        .arg(&scene)
        .args(flags)
        .output()
        .unwrap();
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).to_string(),
        String::from_utf8_lossy(&output.stderr).to_string(),
    )
}

#[test]
fn advise_bad_flags_are_one_line_errors_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), OBJ).unwrap();
    for (flags, needle) in [
        (vec!["--workers", "0"], "--workers"),
        (vec!["--spp", "0"], "--spp"),
        (vec!["--probe-spp", "0"], "--probe-spp"),
        (vec!["--scheduler", "fastest"], "unknown scheduler"),
        (vec!["--chunks", "0"], "chunk"),
        (vec!["--buffer", "0"], "--buffer"),
        (vec!["--passes", "all"], "unknown master pass runner 'all'"),
        (vec!["--sources", "mpi"], "--sources mpi"),
        (vec!["--slow", "3:2", "--workers", "2"], "--slow"),
        (vec!["--slow", "1:0.5"], "slow"),
        (vec!["--tolerance-pct", "-1"], "--tolerance-pct"),
        (vec!["--tracer", "optix"], "unknown tracer"),
    ] {
        let (code, _, stderr) = advise(dir.path(), GOOD, &flags);
        assert_eq!(code, 2, "{flags:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{flags:?}: {stderr}");
        assert!(stderr.contains(needle), "{flags:?}: {stderr}");
    }
    let missing = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args(["advise", "/nonexistent/scene.toml"])
        .output()
        .unwrap();
    assert_eq!(missing.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/scene.toml"));
}

/// A file name may hold a newline: an error naming it is still one line, the name escaped
/// (an experiment naming such a scene, a missing scene and a mesh named so, through the
/// library and through the binary).
#[test]
fn file_names_with_control_characters_are_escaped_in_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let exp = dir.path().join("exp.toml");
    std::fs::write(
        &exp,
        "repetitions = 1\nworkers = [1]\ntracers = [\"bvh\"]\n[[scenes]]\npath = \"co\\nell\\t.toml\"\n[[schedulers]]\nkind = \"static\"\nchunk = [\"16\"]\n",
    )
    .unwrap();
    let e = raysched::experiment::load_plan(&exp)
        .err()
        .unwrap()
        .to_string();
    assert!(!e.contains('\n') && !e.contains('\t'), "{e:?}");
    assert!(
        e.contains("co\\nell\\t.toml") && e.contains("scenes[0]"),
        "{e}"
    );

    std::fs::write(dir.path().join("tri.obj"), OBJ).unwrap();
    let mesh = GOOD.replace("path = \"tri.obj\"", "path = \"tri\\n.obj\"");
    let (code, stderr, written) = run(dir.path(), &mesh, &[]);
    assert_eq!(code, 2, "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr:?}");
    assert!(stderr.contains("tri\\n.obj") && !written, "{stderr}");

    let output = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .arg("render")
        .arg(dir.path().join("missing\n.toml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr:?}");
    assert!(stderr.contains("missing\\n.toml"), "{stderr}");
}
