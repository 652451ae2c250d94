//! Every chart kind rendered with many series, long names and wide ranges on an audit
//! canvas: no two labels may overlap and none may leave the canvas.
use super::*;
use crate::plot::audit::check;
use crate::sched::SchedulerKind;
use crate::studies::experiment::results::RunRow;
use crate::studies::experiment::summary::summarize;

const SCENE: &str = "a_scene_whose_name_goes_on_and_on_and_on";

fn row(kind: &str, chunk: &str, px: u64, workers: usize, rep: u32, wall: f64) -> RunRow {
    let mut r = RunRow::example();
    r.experiment = "layout".into();
    r.scene = SCENE.into();
    r.width = 256;
    r.height = 256;
    r.spp = 8;
    r.tracer = "bvh".into();
    r.config = format!("{kind} {chunk} {workers}");
    r.scheduler = kind.into();
    r.label = format!("{kind} chunk={chunk} order=scatter_with_a_long_name");
    r.chunk = (kind != "serial").then(|| chunk.to_string());
    r.chunk_px = (kind != "serial").then_some(px);
    r.workers = workers;
    r.repetition = rep;
    r.wall_s = wall * (1.0 + 0.01 * rep as f64);
    r.serial_s = 2.0;
    r.rays = 1_000_000;
    r.items = 65536 / px.max(1);
    r.work_s = 1.9 * workers as f64;
    r.idle_s = 0.1;
    r.predicted_wall_s = Some(wall * 1.2);
    r
}

/// Every kind × 17 chunk sizes (1 to 65536 px) at 64 workers, 7 worker counts at one chunk,
/// and the serial baseline; wall times over three decades.
fn sums() -> Vec<Summary> {
    let mut rows = Vec::new();
    for rep in 0..3 {
        rows.push(row("serial", "", 0, 1, rep, 2.0));
        for (k, kind) in SchedulerKind::ALL.iter().enumerate() {
            for p in 0..=8u32 {
                let side = 1u64 << p;
                let wall = 0.03 + 3.0 / (side * side) as f64 + 0.001 * (side * k as u64) as f64;
                rows.push(row(
                    kind.id(),
                    &side.to_string(),
                    side * side,
                    64,
                    rep,
                    wall,
                ));
            }
            for w in [1, 2, 4, 8, 16, 32] {
                rows.push(row(kind.id(), "16", 256, w, rep, 2.0 / w as f64));
            }
        }
    }
    summarize(&rows)
}

#[test]
fn no_label_of_any_chart_kind_overlaps_another_or_leaves_the_canvas() {
    let sums = sums();
    let g = crate::studies::experiment::summary::group_of(&sums[0].row);
    let gr = Group::of(&g, &sums).expect("thread rows");
    let unit = ChunkUnit::of(&gr.at_max);
    assert_eq!(unit, ChunkUnit::Side);
    let x = |s: &Summary| unit.x(s);
    let wall = series(&gr.at_max, kind, x, wall_ci, lower);
    let speed = series(&gr.at_max, kind, x, speed_ci, higher);
    let xd = unit.desc(&gr.at_max);
    let scale = axes::auto_scale(wall.iter().flat_map(|l| l.1.iter().map(|p| p.1)));
    assert_eq!(
        scale,
        Scale::Log10,
        "wall times over decades go on a log axis"
    );
    let title = format!("Wall time vs chunk size, 64 workers — {g}");
    let top = Lines {
        title: &title,
        x_desc: &xd,
        y_desc: "median wall time (s), log scale",
        x: Scale::Log2,
        y: scale,
        ideal: false,
        refs: &[],
        y_range: None,
        legend_w: 0,
    };
    let bottom = Lines {
        title: "Speedup vs chunk size",
        x_desc: &xd,
        y_desc: "speedup (t_serial / t)",
        x: Scale::Log2,
        y: Scale::Linear,
        ideal: false,
        refs: &[(1.0, "speedup 1 (serial)"), (64.0, "ideal (speedup 64)")],
        y_range: None,
        legend_w: 0,
    };
    for size in [(900, 820), (640, 600)] {
        check("granularity", size, |a| {
            two_charts(a, (&top, &wall), (&bottom, &speed))
        });
    }
    let by_w = series(
        &gr.all,
        kind,
        |s| Some(s.row.workers as f64),
        speed_ci,
        higher,
    );
    let t = format!("Speedup vs workers — {g}");
    let lines = Lines {
        title: &t,
        x_desc: "worker threads",
        y_desc: "speedup (t_serial / t)",
        x: Scale::Count,
        y: Scale::Linear,
        ideal: true,
        refs: &[(1.0, "speedup 1 (serial)")],
        y_range: None,
        legend_w: 0,
    };
    check("speedup vs workers", SIZE, |a| line_chart(a, &lines, &by_w));
    // Pixels per item from 1 to 65536 on a log₂ axis: "65536" beside "32768".
    let px = series(
        &gr.at_max,
        kind,
        |s| s.row.chunk_px.map(|p| p as f64),
        wall_ci,
        lower,
    );
    let lines = Lines {
        x_desc: "chunk: pixels per item, log₂",
        ..top
    };
    check("pixels axis", (520, 420), |a| line_chart(a, &lines, &px));
    let mut groups: Vec<ScatterGroup> = Vec::new();
    for s in &gr.at_max {
        let pt = (
            s.wall_median,
            s.wall_median_ci.0,
            s.wall_median_ci.1,
            s.row.predicted_wall_s.unwrap_or(0.0),
        );
        match groups.iter_mut().find(|g| g.0 == s.row.scheduler) {
            Some(g) => g.1.push(pt),
            None => groups.push((s.row.scheduler.clone(), vec![pt])),
        }
    }
    check("predicted vs measured", (900, 700), |a| {
        scatter_vs(
            a,
            &format!("Predicted vs measured wall time, 64 workers — {g}"),
            ("measured median wall time (s)", "predicted wall time (s)"),
            &groups,
        )
    });
    let bars: Vec<(String, [f64; 4])> = SchedulerKind::ALL
        .iter()
        .map(|k| (k.id().to_string(), [1.0, 0.2, 0.1, 0.05]))
        .collect();
    for size in [SIZE, (600, 300)] {
        check("overhead", size, |a| {
            overhead_chart(
                a,
                &format!("Where the time goes, 64 workers — {g}"),
                &bars,
                Some(1.0),
            )
        });
    }
    let mut tl = Timeline::default();
    for w in 0..64u32 {
        for i in 0..20u64 {
            tl.spans.push((
                w,
                i as u32,
                i * 1_000_000 * (w as u64 % 7 + 1),
                (i + 1) * 1_000_000 * (w as u64 % 7 + 1),
            ));
        }
        tl.kinds
            .push((w, if w < 60 { "threads" } else { "gpu" }.into()));
    }
    tl.spans.push((MASTER_LANE, 0, 0, 5_000_000));
    check("gantt", SIZE, |a| {
        gantt_chart(
            a,
            &format!("Timeline: {} ×64 — {g}", "x".repeat(120)),
            &tl,
            None,
        )
    });
}

#[test]
#[should_panic(expected = "overlapping labels")]
fn the_audit_catches_plotters_own_crowded_ticks() {
    // What the charts did before: plotters' mesh with 16 x labels on a narrow panel.
    check("plotters mesh", (300, 200), |a| {
        let mut c = ChartBuilder::on(a)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(0.0..16.0, 0.0..1.0)
            .map_err(e)?;
        c.configure_mesh()
            .x_labels(17)
            .x_label_formatter(&|v| format!("{}", 2f64.powf(*v) as u64))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(e)
    });
}

#[test]
#[should_panic(expected = "outside the canvas")]
fn the_audit_catches_a_title_wider_than_the_canvas() {
    check("wide caption", (300, 200), |a| {
        a.titled(&"x".repeat(80), ("sans-serif", 20))
            .map(|_| ())
            .map_err(e)
    });
}

#[test]
fn draw_all_writes_every_chart_kind() {
    let dir = tempfile::tempdir().expect("temp dir");
    let sums = sums();
    crate::plot::register_font();
    let plots = dir.path().join("plots");
    std::fs::create_dir_all(&plots).expect("plots dir");
    let figs = draw_all(dir.path(), &plots, &plots, true, &sums).expect("drawn");
    let names: Vec<&str> = figs.iter().map(|f| f.file.as_str()).collect();
    for want in [
        "speedup_vs_workers_",
        "granularity_",
        "predicted_",
        "overhead_",
    ] {
        assert!(
            names.iter().any(|n| n.contains(want)),
            "{want} missing from {names:?}"
        );
    }
    for f in &figs {
        assert!(dir.path().join(&f.file).exists(), "{}", f.file);
    }
    if let Ok(keep) = std::env::var("RAYSCHED_KEEP_PLOTS") {
        let _ = std::fs::create_dir_all(&keep);
        for f in &figs {
            let _ = std::fs::copy(
                dir.path().join(&f.file),
                Path::new(&keep).join(Path::new(&f.file).file_name().unwrap_or_default()),
            );
        }
    }
}

/// A per-ray run's 65 536 one-pixel items on two workers: drawn at the chart's width, its SVG
/// stays small, every lane is filled where its items ran, and the master's short passes still
/// show on its lane.
#[test]
fn a_gantt_of_many_tiny_items_is_downsampled_to_the_pixel_width() {
    crate::plot::register_font();
    let mut tl = Timeline::default();
    for i in 0..65_536u64 {
        let w = (i % 2) as u32;
        let t = (i / 2) * 3_000 + w as u64 * 700;
        tl.spans.push((w, i as u32, t, t + 2_000 + (i % 5) * 100));
    }
    for p in 0..1_000u64 {
        tl.spans.push((MASTER_LANE, 0, p * 98_000, p * 98_000 + 50));
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let svg = dir.path().join("g.svg");
    {
        let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
        root.fill(&WHITE).expect("filled");
        gantt_chart(&root, "Timeline: per-ray", &tl, None).expect("drawn");
        root.present().expect("written");
    }
    let len = std::fs::metadata(&svg).expect("svg").len();
    assert!(len < 500_000, "{len} bytes");
    let rects = std::fs::read_to_string(&svg)
        .expect("svg")
        .matches("<rect")
        .count();
    assert!(rects < 5_000, "{rects} rectangles");
    // Downsampling itself: a lane busy throughout is one run in full shade; one busy a fifth
    // of each column (a per-ray worker waiting on its master) a quarter shade, not white; the
    // master's passes, each far under a column, in full where `any` says so and in the
    // lightest shade otherwise; an untouched column stays white.
    let busy: Vec<(u64, u64, usize)> = (0..1000u64).map(|i| (i * 10, i * 10 + 10, 2)).collect();
    assert_eq!(downsample(&busy, 10_000, 100, false), [(0, 99, 2, 4)]);
    let quarter: Vec<(u64, u64, usize)> = (0..1000u64).map(|i| (i * 10, i * 10 + 2, 1)).collect();
    assert_eq!(downsample(&quarter, 10_000, 100, false), [(0, 99, 1, 1)]);
    let passes: Vec<(u64, u64, usize)> = (0..10u64).map(|i| (i * 1000, i * 1000 + 1, 0)).collect();
    let full = downsample(&passes, 10_000, 100, true);
    assert_eq!(full.len(), 10);
    assert!(full.iter().all(|r| r.0 == r.1 && r.3 == 4), "{full:?}");
    let light = downsample(&passes, 10_000, 100, false);
    assert!(light.iter().all(|r| r.3 == 1), "{light:?}");
    assert_eq!(
        light.iter().map(|r| r.0).collect::<Vec<_>>(),
        [0, 10, 20, 30, 40, 50, 60, 70, 80, 90]
    );
}
