//! Animations: a camera path over N frames, frames as work items.
//!
//! - every scheduler × chunk {1 px, 16², whole frames} gives frames bit-identical to a serial
//!   per-frame render, and the frames differ;
//! - frame 0 is the static scene bit for bit; a keyframe equals the static scene with that
//!   camera and the frame's seed (bit for bit when the camera only turns, within rounding when
//!   it moves: render space stays anchored at frame 0's camera);
//! - bad `[animation]` input is a one-line error naming file and field;
//! - `raysched render` writes `name_fNNNN.exr/png` per frame.

use raysched::render::{render_serial, render_serial_frames, Image};
use raysched::rng::frame_seed;
use raysched::scene::{load_scene_str, Scene, SceneOverrides};
use raysched::sched::{
    decompose_frames, render_scene, Chunk, Order, RenderOn, RunOptions, SchedulerKind,
    SchedulerSpec,
};
use raysched::tracer::{AnyTracer, TracerKind};
use std::path::Path;
use std::process::Command;
use std::sync::Arc;

/// scenes/cornell_dolly.toml at 32×24, 1 spp, cut to 4 frames (key at frame 3).
fn dolly_text() -> String {
    let text = std::fs::read_to_string(crate::support::scene_path("cornell_dolly.toml")).unwrap();
    assert!(text.contains("frames = 8") && text.contains("frame = 7"));
    text.replace("frames = 8", "frames = 4")
        .replace("frame = 7", "frame = 3")
}

fn small() -> SceneOverrides {
    SceneOverrides {
        width: Some(32),
        height: Some(24),
        spp: Some(1),
        ..Default::default()
    }
}

fn load(text: &str, ov: &SceneOverrides) -> Scene {
    load_scene_str(text, "test.toml", Path::new("."), "test", ov).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene text without its `[animation]` (it is the last table in these texts).
fn without_animation(text: &str) -> String {
    text[..text.find("[animation]").expect("animated")].to_string()
}

/// `[camera]`'s pose replaced by the given origin and target.
fn with_camera(text: &str, origin: &str, target: &str) -> String {
    without_animation(text)
        .replace("origin = [0, 0, 3.9]", &format!("origin = {origin}"))
        .replace("target = [0, 0, 0]", &format!("target = {target}"))
}

fn serial_frames(scene: &Scene) -> Vec<Image> {
    let tracer = AnyTracer::build(TracerKind::Bvh, scene, 1).unwrap();
    render_serial_frames(scene, &tracer).0
}

#[test]
fn every_scheduler_and_chunk_gives_the_serial_frames() {
    let scene = Arc::new(load(&dolly_text(), &small()));
    assert_eq!(scene.frames(), 4);
    let tracer = Arc::new(AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap());
    let (serial, _) = render_serial_frames(&scene, &*tracer);
    assert_eq!(serial.len(), 4);
    for k in 1..4 {
        assert_ne!(serial[0], serial[k], "frame {k} equals frame 0");
    }
    let px = 4 * 32 * 24;
    for kind in SchedulerKind::ALL {
        for chunk in ["1", "16", "frames"] {
            let mut spec = SchedulerSpec::new(kind, Chunk::parse(chunk).unwrap(), 2);
            spec.order = Order::Hilbert;
            let what = spec.label();
            let (frames, stats) = render_scene(
                &spec,
                &scene,
                &tracer,
                &RenderOn::threads(),
                &RunOptions::default(),
            )
            .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(frames, serial, "{what}");
            let (c, o) = spec.layout(32, 24);
            let items = decompose_frames(32, 24, 4, c, o).len() as u64;
            assert_eq!(stats.items, items, "{what}");
            if chunk == "frames" && !kind.picks_own_layout() {
                assert_eq!(items, 4, "one item per frame");
            }
            let pixels: u64 = stats.workers.iter().map(|w| w.pixels).sum();
            assert_eq!(pixels, px, "{what}: pixels over all frames");
        }
    }
    // The single-image API carries the frames as a film strip.
    let spec = SchedulerSpec::new(SchedulerKind::Master, Chunk::Frame, 2);
    let (strip, _) = crate::support::render(&spec, &scene, &tracer).unwrap();
    assert_eq!(strip.unstack(4), serial);
    assert_eq!(render_serial(&scene, &*tracer).0, strip);
}

#[test]
fn frame_0_is_the_static_scene_bit_for_bit() {
    let text = dolly_text();
    let animated = serial_frames(&load(&text, &small()));
    let still = serial_frames(&load(&without_animation(&text), &small()));
    assert_eq!(still.len(), 1);
    assert_eq!(animated[0], still[0]);
}

#[test]
fn static_scenes_keep_their_hash_and_image_from_before_animations() {
    // The serial render of simple at 256×256, 8 spp, as results/published/quick/runs.csv first
    // recorded it before animations existed (its snapshot of 2026-12-05 has the same hashes).
    let scene = crate::support::load(
        "simple.toml",
        SceneOverrides {
            width: Some(256),
            height: Some(256),
            spp: Some(8),
            ..Default::default()
        },
    );
    assert_eq!(scene.frames(), 1);
    // The scene's hash moved once when simple.toml came to state its sphere's radius (1, the
    // old silent default; issue 58): the image below is the one it always was.
    assert_eq!(scene.hash, 0x344b_a08b_c9c7_6f6c);
    let tracer = AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap();
    assert_eq!(
        render_serial(&scene, &tracer).0.hash(),
        0x59de_4a86_960f_79b7
    );
}

#[test]
fn a_turning_keyframe_is_the_static_scene_with_that_camera_bit_for_bit() {
    // The camera only turns: frame 3 sits at render-space origin like the static scene.
    let text = dolly_text().replace("origin = [0, 0, 2.9]\n", "");
    let scene = load(&text, &small());
    let frames = serial_frames(&scene);
    let seed = frame_seed(scene.settings.seed, 3);
    let still_text = with_camera(&text, "[0, 0, 3.9]", "[0.15, 0, 0]");
    let still = load(
        &still_text,
        &SceneOverrides {
            seed: Some(seed),
            ..small()
        },
    );
    assert_eq!(scene.frame_camera(3), &still.camera);
    assert_eq!(frames[3], serial_frames(&still)[0]);
    assert_ne!(frames[3], frames[0]);
}

#[test]
fn a_moving_keyframe_matches_the_static_scene_within_rounding() {
    let text = dolly_text();
    let scene = load(&text, &small());
    let frames = serial_frames(&scene);
    let still = load(
        &with_camera(&text, "[0, 0, 2.9]", "[0.15, 0, 0]"),
        &SceneOverrides {
            seed: Some(frame_seed(scene.settings.seed, 3)),
            ..small()
        },
    );
    let cam = scene.frame_camera(3);
    assert_eq!(
        cam.eye(),
        glam::Vec3::new(0.0, 0.0, -1.0),
        "eye = key − frame 0"
    );
    assert_eq!(
        cam.with_eye(glam::Vec3::ZERO),
        still.camera,
        "same basis and film"
    );
    // Same random numbers, geometry rounded from a different origin: nearly every pixel agrees
    // to float rounding; a path that grazes an edge may take another branch.
    let reference = &serial_frames(&still)[0];
    let close = frames[3]
        .data
        .iter()
        .zip(&reference.data)
        .filter(|(a, b)| (0..3).all(|c| (a[c] - b[c]).abs() <= 1e-4 * (1.0 + b[c].abs())))
        .count();
    let n = reference.data.len();
    assert!(close * 100 >= n * 98, "{close} of {n} pixels agree");
    assert_ne!(frames[3], frames[0]);
}

#[test]
fn interpolation_is_linear_and_holds_after_the_last_key() {
    let text = dolly_text().replace("frames = 4", "frames = 6");
    let scene = load(&text, &small());
    assert_eq!(scene.frames(), 6);
    // Dolly from z = 3.9 (frame 0) to 2.9 (frame 3): frame 1 at 3.9 − 1/3.
    let eye1 = scene.frame_camera(1).eye();
    assert!((eye1.z + 1.0 / 3.0).abs() < 1e-6, "{eye1}");
    assert_eq!(scene.frame_camera(4), scene.frame_camera(3));
    assert_eq!(scene.frame_camera(5), scene.frame_camera(3));
}

#[test]
fn bad_animations_are_clear_errors() {
    let base = without_animation(&dolly_text());
    let cases: &[(&str, &str, &str)] = &[
        ("frames 0", "[animation]\nframes = 0\n", "animation.frames"),
        (
            "too many frames",
            "[animation]\nframes = 4000000000\n",
            "animation.frames",
        ),
        (
            "key past the end",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 4\norigin = [0, 0, 3]\n",
            "animation.keys[0].frame",
        ),
        (
            "key at frame 0",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 0\n",
            "animation.keys[0].frame",
        ),
        (
            "keys unsorted",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 3\n[[animation.keys]]\nframe = 2\n",
            "animation.keys[1].frame",
        ),
        (
            "nan origin",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 3\norigin = [0, nan, 3]\n",
            "animation.keys[0].origin",
        ),
        (
            "fov 180",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 3\nfov_deg = 180\n",
            "animation.keys[0]: fov_deg",
        ),
        (
            "key looks at itself",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 3\norigin = [0, 0, 0]\n",
            "animation.keys[0]: target equals origin",
        ),
        (
            // Frame 1 of 3 passes through the target (origin (0,0,0) = target).
            "interpolated frame unusable",
            "[animation]\nframes = 3\n[[animation.keys]]\nframe = 2\norigin = [0, 0, -3.9]\n",
            "frame 1",
        ),
        (
            "unknown key field",
            "[animation]\nframes = 4\n[[animation.keys]]\nframe = 3\nposition = [0, 0, 1]\n",
            "unknown field `position`",
        ),
    ];
    for (what, anim, needle) in cases {
        let text = format!("{base}\n{anim}");
        let err = load_scene_str(&text, "bad.toml", Path::new("."), "bad", &small())
            .expect_err(what)
            .to_string();
        assert!(err.starts_with("bad.toml"), "{what}: {err}");
        assert!(err.contains(needle), "{what}: '{needle}' not in: {err}");
        assert_eq!(err.lines().count(), 1, "{what}: {err}");
    }
}

#[test]
fn render_writes_one_file_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("dolly.toml");
    std::fs::write(&scene, dolly_text()).unwrap();
    let out = dir.path().join("img.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .args([
            "render",
            "--threads",
            "2",
            "--spp",
            "1",
            "--chunk",
            "frames",
        ])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!out.exists(), "no single image for an animation");
    assert!(stdout.contains("× 4 frames"), "{stdout}");
    let loaded = load(
        &dolly_text(),
        &SceneOverrides {
            spp: Some(1),
            ..Default::default()
        },
    );
    let want = serial_frames(&loaded);
    for (k, frame) in want.iter().enumerate() {
        let f = dir.path().join(format!("img_f{k:04}.exr"));
        assert_eq!(&Image::load_exr(&f).unwrap(), frame, "frame {k}");
        assert!(f.with_extension("png").exists());
    }
    assert!(!dir.path().join("img_f0004.exr").exists());
}
