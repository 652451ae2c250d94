//! Predicted against measured: one point per configuration around y = x.

use super::*;

/// One group of a scatter: its name and its points (x, x_lo, x_hi, y).
pub(crate) type ScatterGroup = (String, Vec<(f64, f64, f64, f64)>);

/// Predicted against measured wall time, a point per configuration marked by its scheduler,
/// around the line y = x (dashed: ±25 %). Both axes log when the times span more than 5×.
/// Shared with the simulation's validation plot.
pub(crate) fn scatter_vs<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    (x_desc, y_desc): (&str, &str),
    // (name, [(x, x_lo, x_hi, y)]) per scheduler or group
    groups: &[ScatterGroup],
) -> R {
    let (scale, c0, c1) = square_range(groups);
    let t = |v: f64| scale.to(v);
    let styles = style::for_names(&groups.iter().map(|g| g.0.clone()).collect::<Vec<_>>());
    let mut keys: Vec<(String, Key)> = groups
        .iter()
        .zip(&styles)
        .map(|(g, s)| (g.0.clone(), Key::Point(*s)))
        .collect();
    keys.push(("y = x (exact)".into(), Key::Line(BLACK, Dash::Solid)));
    keys.push((
        "±25 %".into(),
        Key::Line(RGBColor(110, 110, 110), Dash::Dashed),
    ));
    let body = axes::titled(root, title)?;
    let labels: Vec<String> = keys.iter().map(|k| k.0.clone()).collect();
    let (plot, legend_area) = axes::with_legend(&body, &labels);
    let log_note = if scale == Scale::Log10 {
        ", log scale"
    } else {
        ""
    };
    let xs = AxisSpec {
        desc: format!("{x_desc}{log_note}"),
        range: (c0, c1),
        scale,
    };
    let ys = AxisSpec {
        desc: format!("{y_desc}{log_note}"),
        range: (c0, c1),
        scale,
    };
    let mut chart = axes::chart(&plot, &xs, &ys)?;
    ratio_lines(&chart, scale, (c0, c1))?;
    let pa = chart.plotting_area().strip_coord_spec();
    let o = pa.get_base_pixel();
    for ((_, pts), st) in groups.iter().zip(&styles) {
        for &(x, xlo, xhi, y) in pts {
            let (cx, cy) = (t(x), t(y));
            if !cx.is_finite() || !cy.is_finite() {
                continue;
            }
            if t(xlo).is_finite() && t(xhi).is_finite() && xhi > xlo {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(t(xlo).max(c0), cy), (t(xhi).min(c1), cy)],
                        st.colour.stroke_width(1),
                    )))
                    .map_err(e)?;
            }
            let b = chart.backend_coord(&(cx, cy));
            pa.draw(&axes::marker(
                (b.0 - o.0, b.1 - o.1),
                st.marker,
                st.colour,
                5,
            ))
            .map_err(e)?;
        }
    }
    axes::legend(&legend_area, &keys)
}

/// The scale both axes share (log when the values span more than 5×) and the range, in axis
/// coordinates, that holds every finite value of `groups` with a margin.
fn square_range(groups: &[ScatterGroup]) -> (Scale, f64, f64) {
    let vals: Vec<f64> = groups
        .iter()
        .flat_map(|g| g.1.iter())
        .flat_map(|p| [p.0, p.1, p.2, p.3])
        .filter(|v| v.is_finite())
        .collect();
    let scale = axes::auto_scale(vals.iter().copied());
    let (lo, hi) = vals
        .iter()
        .filter(|v| scale != Scale::Log10 || **v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    let (c0, c1) = match scale {
        Scale::Log10 => {
            let (a, b) = (lo.log10(), hi.log10());
            let pad = (b - a) * 0.06;
            (a - pad, b + pad)
        }
        _ => (0.0, hi * 1.08),
    };
    (scale, c0, c1)
}

/// The lines y = x (solid) and y = 1.25·x, y = 0.8·x (dashed), sampled so they are straight
/// on either scale and clipped to the range.
fn ratio_lines<DB: DrawingBackend>(
    chart: &axes::Chart<'_, DB>,
    scale: Scale,
    (c0, c1): (f64, f64),
) -> R {
    let pa = chart.plotting_area().strip_coord_spec();
    let o = pa.get_base_pixel();
    for (k, col, dash) in [
        (1.0, BLACK, Dash::Solid),
        (1.25, RGBColor(110, 110, 110), Dash::Dashed),
        (0.8, RGBColor(110, 110, 110), Dash::Dashed),
    ] {
        let pts: Vec<(i32, i32)> = (0..=40)
            .map(|i| {
                let c = c0 + (c1 - c0) * i as f64 / 40.0;
                let v = match scale {
                    Scale::Log10 => 10f64.powf(c),
                    _ => c,
                };
                (c, scale.to(v * k))
            })
            .filter(|p| p.1.is_finite() && p.1 >= c0 && p.1 <= c1)
            .map(|p| {
                let b = chart.backend_coord(&p);
                (b.0 - o.0, b.1 - o.1)
            })
            .collect();
        for piece in axes::dashed(&pts, dash) {
            pa.draw(&PathElement::new(piece, col.stroke_width(1)))
                .map_err(e)?;
        }
    }
    Ok(())
}

pub(super) fn predicted_vs_measured(out: &mut Drawn, gr: &Group) -> R {
    let mut groups: Vec<ScatterGroup> = Vec::new();
    for s in gr.at_max.iter().copied() {
        let Some(p) = s.row.predicted_wall_s else {
            continue;
        };
        let pt = (s.wall_median, s.wall_median_ci.0, s.wall_median_ci.1, p);
        match groups.iter_mut().find(|g| g.0 == s.row.scheduler) {
            Some(g) => g.1.push(pt),
            None => groups.push((s.row.scheduler.clone(), vec![pt])),
        }
    }
    if groups.is_empty() {
        return Ok(());
    }
    let stem = out.plots.join(format!("predicted_{}", gr.slug));
    let title = format!(
        "Predicted vs measured wall time, {} workers — {}",
        gr.max_w, gr.name
    );
    both!(
        out.bitmap,
        stem,
        (900, 700),
        scatter_vs(
            &title,
            ("measured median wall time (s)", "predicted wall time (s)"),
            &groups
        )
    );
    out.push(&stem, title, "One point per configuration, marked by its scheduler: the cost model's prediction made before the first round against the measured median (horizontal bar: its 95 % interval). Points on the black line y = x are exact; the dashed lines are ±25 %; above the line the model is pessimistic.");
    Ok(())
}
