//! The line figures of a group: speedup vs workers, granularity, buffer size.

use super::*;

pub(super) fn speedup_vs_workers(out: &mut Drawn, gr: &Group) -> R {
    let workers: std::collections::BTreeSet<usize> = gr.all.iter().map(|s| s.row.workers).collect();
    if workers.len() <= 1 {
        return Ok(());
    }
    let data = series(
        &gr.all,
        kind,
        |s| Some(s.row.workers as f64),
        speed_ci,
        higher,
    );
    let stem = out.plots.join(format!("speedup_vs_workers_{}", gr.slug));
    let title = format!("Speedup vs workers — {}", gr.name);
    let lines = Lines {
        title: &title,
        x_desc: "worker threads",
        y_desc: "speedup (t_serial / t)",
        x: Scale::Count,
        y: Scale::Linear,
        ideal: true,
        refs: &[(1.0, "speedup 1 (serial)")],
        y_range: None,
        legend_w: 0,
    };
    both!(out.bitmap, stem, SIZE, line_chart(&lines, &data));
    out.push(&stem, title, "Speedup (median serial / median wall, paired by round) of each scheduler's best configuration per worker count, with its 95 % interval; the black diagonal is ideal linear speedup, the dashed grey line speedup 1 (as fast as serial).");
    Ok(())
}

pub(super) fn granularity(out: &mut Drawn, gr: &Group) -> R {
    let chunks: std::collections::BTreeSet<u64> =
        gr.at_max.iter().filter_map(|s| s.row.chunk_px).collect();
    if chunks.len() <= 1 {
        return Ok(());
    }
    let (g, max_w) = (gr.name, gr.max_w);
    // Pixels per work item, as the README's figure says, whatever unit the file wrote.
    let unit = ChunkUnit::Pixels;
    let x = |s: &Summary| unit.x(s);
    let wall = series(&gr.at_max, kind, x, wall_ci, lower);
    let speed = series(&gr.at_max, kind, x, speed_ci, higher);
    let wall_scale = out.wall_scale;
    let ideal_label = format!("ideal (speedup {max_w})");
    let refs = [
        (1.0, "speedup 1 (serial)"),
        (max_w as f64, ideal_label.as_str()),
    ];
    let stem = out.plots.join(format!("granularity_{}", gr.slug));
    let title = format!("Granularity, {max_w} workers — {g}");
    let x_desc = unit.desc(&gr.at_max);
    let top_title = format!("Wall time vs chunk size, {max_w} workers — {g}");
    let top = Lines {
        title: &top_title,
        x_desc: &x_desc,
        y_desc: if wall_scale == Scale::Log10 {
            "median wall time (s), log scale"
        } else {
            "median wall time (s)"
        },
        x: Scale::Log2,
        y: wall_scale,
        ideal: false,
        refs: &[],
        y_range: None,
        legend_w: 0,
    };
    let bottom = Lines {
        title: "Speedup vs chunk size",
        x_desc: &x_desc,
        y_desc: "speedup (t_serial / t)",
        x: Scale::Log2,
        y: Scale::Linear,
        ideal: false,
        refs: &refs,
        y_range: None,
        legend_w: 0,
    };
    both!(
        out.bitmap,
        stem,
        (900, 820),
        two_charts((&top, &wall), (&bottom, &speed))
    );
    let left = "Left end = per-ray items (1 pixel), right end = the whole image as one item.";
    out.push(&stem, title, &format!("{left} Dispatch cost dominates on the left, load imbalance on the right; the best granularity is the valley of the wall-time curve{}. Bars: 95 % intervals of the median (top) and of the paired speedup (bottom).", if wall_scale == Scale::Log10 { " (log scale: equal heights are equal ratios)" } else { "" }));
    Ok(())
}

pub(super) fn buffer_sizes(out: &mut Drawn, gr: &Group) -> R {
    let master: Vec<&Summary> = gr
        .at_max
        .iter()
        .copied()
        .filter(|s| s.row.buffer().is_some())
        .collect();
    let buffers: std::collections::BTreeSet<usize> =
        master.iter().filter_map(|s| s.row.buffer()).collect();
    if buffers.len() <= 1 {
        return Ok(());
    }
    let data = series(
        &master,
        |s| {
            Some(format!(
                "master chunk={}",
                s.row.chunk.clone().unwrap_or_default()
            ))
        },
        |s| s.row.buffer().map(|b| b as f64),
        speed_ci,
        higher,
    );
    let stem = out.plots.join(format!("buffer_{}", gr.slug));
    let title = format!(
        "Master: speedup vs buffer size, {} workers — {}",
        gr.max_w, gr.name
    );
    let lines = Lines {
        title: &title,
        x_desc: "items outstanding per worker, B (log₂)",
        y_desc: "speedup (t_serial / t)",
        x: Scale::Log2,
        y: Scale::Linear,
        ideal: false,
        refs: &[(1.0, "speedup 1 (serial)")],
        y_range: None,
        legend_w: 0,
    };
    both!(out.bitmap, stem, SIZE, line_chart(&lines, &data));
    out.push(&stem, title, "Each line is one chunk size. A small buffer leaves workers waiting for the master; a large one hands out the tail of the image too early.");
    Ok(())
}
