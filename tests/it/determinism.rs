//! A pixel's value never depends on which thread renders it, in which order, or with which
//! other pixels: whole-image render vs random pixel subsets in shuffled order on several threads.

use raysched::render::{render_item, render_item_spp, render_serial, Region, WorkItem};
use raysched::rng::Sampler;
use raysched::scene::SceneOverrides;
use raysched::sched::render_parallel;
use raysched::tracer::{AnyTracer, TracerKind};
use std::sync::Arc;

#[test]
fn shuffled_pixel_subsets_on_threads_are_bit_identical_to_the_serial_render() {
    for name in ["cornell_box.toml", "glass_checker.toml", "point_plane.toml"] {
        let scene = Arc::new(crate::support::load(
            name,
            SceneOverrides {
                width: Some(23),
                height: Some(17),
                spp: Some(2),
                ..Default::default()
            },
        ));
        let tracer = Arc::new(AnyTracer::build(TracerKind::Bvh, &scene, 1).unwrap());
        let (reference, _) = render_serial(&scene, &*tracer);

        // Shuffle all pixel indices (Fisher–Yates with the counter-based sampler).
        let n = scene.pixel_count() as u32;
        let mut order: Vec<u32> = (0..n).collect();
        let mut s = Sampler::new(99, 0, 0);
        for i in (1..order.len()).rev() {
            let j = ((s.next() * (i + 1) as f32) as usize).min(i);
            order.swap(i, j);
        }
        // Random subset sizes, rendered on 3 threads, each thread taking every third subset.
        let mut subsets = Vec::new();
        let mut start = 0usize;
        while start < order.len() {
            let len = 1 + (s.next() * 40.0) as usize;
            let end = (start + len).min(order.len());
            subsets.push(WorkItem {
                id: subsets.len() as u32,
                region: Region::Pixels(order[start..end].to_vec()),
                frame: 0,
            });
            start = end;
        }
        let subsets = Arc::new(subsets);
        let handles: Vec<_> = (0..3)
            .map(|t| {
                let (scene, tracer, subsets) = (scene.clone(), tracer.clone(), subsets.clone());
                std::thread::spawn(move || {
                    subsets
                        .iter()
                        .skip(t)
                        .step_by(3)
                        .rev()
                        .map(|item| (item.clone(), render_item(&scene, &*tracer, item)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut image = raysched::render::Image::new(scene.width(), scene.height());
        for h in handles {
            for (item, r) in h.join().unwrap() {
                image.put(&item, &r.pixels);
            }
        }
        assert_eq!(
            image.hash(),
            reference.hash(),
            "{name}: shuffled subsets differ"
        );
        assert!(image.data == reference.data);
        let (parallel, _) = render_parallel(&scene, &tracer, 2).unwrap();
        assert_eq!(
            parallel.hash(),
            reference.hash(),
            "{name}: parallel render differs"
        );
    }
}

#[test]
fn a_different_seed_gives_a_different_image() {
    // Guards the test above against a renderer that ignores its random numbers.
    let o = |seed| SceneOverrides {
        width: Some(8),
        height: Some(8),
        spp: Some(1),
        seed: Some(seed),
        ..Default::default()
    };
    let a = crate::support::load("cornell_box.toml", o(1));
    let b = crate::support::load("cornell_box.toml", o(2));
    let ta = AnyTracer::build(TracerKind::Bvh, &a, 1).unwrap();
    let tb = AnyTracer::build(TracerKind::Bvh, &b, 1).unwrap();
    assert_ne!(
        render_serial(&a, &ta).0.hash(),
        render_serial(&b, &tb).0.hash()
    );
}

/// A probe's short render of a scene in place (`render_item_spp`, the dry run's estimate)
/// renders the samples a copy of the scene with that count renders, bit for bit, and a
/// different count renders other pixels.
#[test]
fn rendering_fewer_samples_in_place_matches_a_scene_of_that_count() {
    let load = |spp| {
        crate::support::load(
            "cornell_box.toml",
            SceneOverrides {
                width: Some(9),
                height: Some(7),
                spp: Some(spp),
                ..Default::default()
            },
        )
    };
    let (full, small) = (load(8), load(3));
    let tracer = AnyTracer::build(TracerKind::Bvh, &full, 1).unwrap();
    for y in 0..full.height() {
        let item = WorkItem::rect(y, 0, y, full.width(), 1);
        let probe = render_item_spp(&full, &tracer, &item, 3);
        assert_eq!(
            probe.pixels,
            render_item(&small, &tracer, &item).pixels,
            "row {y}"
        );
        assert_eq!(
            probe.rays,
            render_item(&small, &tracer, &item).rays,
            "row {y}"
        );
        assert_ne!(
            probe.pixels,
            render_item(&full, &tracer, &item).pixels,
            "row {y}"
        );
    }
}
