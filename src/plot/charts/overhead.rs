//! The overhead breakdown: where the workers' time went, per scheduler.

use super::*;

/// Stacked bars: work, imbalance, other idle, dispatch; a dashed line at the serial time.
pub(super) fn overhead_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    bars: &[(String, [f64; 4])],
    serial_s: Option<f64>,
) -> R {
    let parts = [
        "work (Σ busy)",
        "idle: imbalance",
        "idle: other",
        "idle: the master's dispatch",
    ];
    let cols = [
        RGBColor(0, 114, 178),
        RGBColor(230, 159, 0),
        RGBColor(190, 190, 190),
        RGBColor(213, 94, 0),
    ];
    let top = bars
        .iter()
        .map(|(_, v)| v.iter().sum::<f64>())
        .fold(serial_s.unwrap_or(0.0), f64::max)
        * 1.08;
    let n = bars.len().max(1);
    let mut keys: Vec<(String, Key)> = parts
        .iter()
        .zip(cols)
        .map(|(p, c)| (p.to_string(), Key::Box(c)))
        .collect();
    if serial_s.is_some() {
        keys.push((
            "serial median wall time".into(),
            Key::Line(BLACK, Dash::Dashed),
        ));
    }
    let body = axes::titled(root, title)?;
    let labels: Vec<String> = keys.iter().map(|k| k.0.clone()).collect();
    let (plot, legend_area) = axes::with_legend(&body, &labels);
    // Schedulers down the y axis: sixteen names fit one under another, not side by side.
    let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    let xs = AxisSpec {
        desc: "Σ over workers of wall-clock spans (s)".into(),
        range: (0.0, top.max(1e-9)),
        scale: Scale::Linear,
    };
    let ys = AxisSpec {
        desc: String::new(),
        range: (-0.5, n as f64 - 0.5),
        scale: Scale::Linear,
    };
    let label_w = names
        .iter()
        .map(|s| axes::text_size(s, axes::TICK_FONT).0)
        .max()
        .unwrap_or(0)
        + 12;
    let (labels_area, chart_area) =
        plot.split_horizontally(label_w.min(plot.dim_in_pixel().0 as i32 / 3));
    let mut chart = axes::chart_without_y_ticks(&chart_area, &xs, &ys)?;
    bar_labels(&labels_area, &chart, &names)?;
    for (p, &c) in cols.iter().enumerate() {
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                let x0: f64 = v[..p].iter().sum();
                Rectangle::new(
                    [(x0, i as f64 - 0.35), (x0 + v[p], i as f64 + 0.35)],
                    c.filled(),
                )
            }))
            .map_err(e)?;
    }
    if let Some(serial_s) = serial_s {
        dashed_vertical(&chart, serial_s, n)?;
    }
    axes::legend(&legend_area, &keys)
}

/// The bars' names right-aligned beside the chart, every k-th where rows are thinner than a
/// line of text.
fn bar_labels<DB: DrawingBackend>(
    labels_area: &DrawingArea<DB, Shift>,
    chart: &axes::Chart<'_, DB>,
    names: &[String],
) -> R {
    let row_h = {
        let a = chart.backend_coord(&(0.0, 0.0)).1;
        let b = chart.backend_coord(&(0.0, 1.0)).1;
        (a - b).abs()
    };
    let need = axes::text_size("Ag", axes::TICK_FONT).1 + 2;
    let every = ((need + row_h - 1) / row_h.max(1)).max(1) as usize;
    let base = labels_area.get_base_pixel();
    let lw = labels_area.dim_in_pixel().0 as i32;
    for (i, name) in names.iter().enumerate().step_by(every) {
        let y = chart.backend_coord(&(0.0, i as f64)).1 - base.1;
        labels_area
            .draw(&Text::new(
                axes::fit_text(name, axes::TICK_FONT, lw - 8),
                (lw - 4, y),
                ("sans-serif", axes::TICK_FONT)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(e)?;
    }
    Ok(())
}

/// A dashed vertical line at `x` across all `n` bars (the serial median).
fn dashed_vertical<DB: DrawingBackend>(chart: &axes::Chart<'_, DB>, x: f64, n: usize) -> R {
    let (a, b) = (
        chart.backend_coord(&(x, -0.5)),
        chart.backend_coord(&(x, n as f64 - 0.5)),
    );
    let pa = chart.plotting_area().strip_coord_spec();
    let o = pa.get_base_pixel();
    for piece in axes::dashed(
        &[(a.0 - o.0, a.1 - o.1), (b.0 - o.0, b.1 - o.1)],
        Dash::Dashed,
    ) {
        pa.draw(&PathElement::new(piece, BLACK.stroke_width(2)))
            .map_err(e)?;
    }
    Ok(())
}

/// Each scheduler kind's fastest configuration (median wall time), in the registry's order.
pub(super) fn best_per_scheduler<'a>(at_max: &[&'a Summary]) -> Vec<&'a Summary> {
    let mut best: Vec<&Summary> = Vec::new();
    for s in at_max {
        match best.iter_mut().find(|b| b.row.scheduler == s.row.scheduler) {
            Some(b) if s.wall_median < b.wall_median => *b = s,
            Some(_) => {}
            None => best.push(s),
        }
    }
    best.sort_by_key(|s| registry_rank(&s.row.scheduler));
    best
}

pub(super) fn overhead(out: &mut Drawn, gr: &Group, best: &[&Summary]) -> R {
    let serial_s = gr.serial.map(|s| s.wall_median);
    let bars: Vec<(String, [f64; 4])> = best
        .iter()
        .map(|s| (s.row.scheduler.clone(), s.lanes.parts()))
        .collect();
    let stem = out.plots.join(format!("overhead_{}", gr.slug));
    let title = format!("Where the time goes, {} workers — {}", gr.max_w, gr.name);
    both!(
        out.bitmap,
        stem,
        SIZE,
        overhead_chart(&title, &bars, serial_s)
    );
    let drawn: Vec<String> = best.iter().map(|s| format!("`{}`", s.row.label)).collect();
    let caption = format!("Each bar is workers × median wall time of the scheduler's fastest configuration, split by the median shares of its runs: Σ busy, idle from uneven work (imbalance), idle the master's dispatch explains (at most the idle left after imbalance), other idle (`lanes_*_s` in summary.csv). The dashed line is the serial median wall time: work above it is work the parallel run did beyond the serial one. Drawn: {}.", drawn.join(", "));
    out.push(&stem, title, &caption);
    Ok(())
}
