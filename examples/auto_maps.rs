//! Measure the per-pixel cost maps of shipped scenes for `auto`'s judging corpus
//! (`experiments/auto.toml`, `raysched::simulate::auto_judge::CostMap`): one per-pixel render
//! on one worker per repeat, each pixel its cheapest of 3 (`Profile::measure_min`), written as
//! `side N` then one relative cost per line.
//!
//! `cargo run --release --example auto_maps -- OUT_DIR SIDE SPP SCENE.toml…`

use raysched::profile::Profile;
use raysched::scene::{load_scene, SceneOverrides};
use raysched::simulate::auto_judge::CostMap;
use raysched::tracer::{AnyTracer, TracerKind};
use std::path::PathBuf;
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [out, side, spp, scenes @ ..] = args.as_slice() else {
        return Err("usage: auto_maps OUT_DIR SIDE SPP SCENE.toml…".into());
    };
    let (side, spp): (u32, u32) = (side.parse()?, spp.parse()?);
    for s in scenes {
        let path = PathBuf::from(s);
        let overrides = SceneOverrides {
            width: Some(side),
            height: Some(side),
            spp: Some(spp),
            ..Default::default()
        };
        let scene = Arc::new(load_scene(&path, &overrides)?);
        let tracer = Arc::new(AnyTracer::build(TracerKind::Bvh.available()?, &scene, 1)?);
        let p = Profile::measure_min(&scene, &tracer, 3)?;
        let stem = path
            .file_stem()
            .map_or("scene".into(), |x| x.to_string_lossy());
        let name = format!("{stem}_{side}");
        let map = CostMap::normalised(name.clone(), side, p.pixel_s.clone());
        let file = PathBuf::from(out).join(format!("{name}.txt"));
        std::fs::write(&file, map.to_text())?;
        let total: f64 = p.pixel_s.iter().sum();
        println!("{}: {:.3} s, {} px", file.display(), total, p.pixel_s.len());
    }
    Ok(())
}
