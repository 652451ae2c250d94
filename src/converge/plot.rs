//! The log-log plot of a convergence CSV: one panel per scene, one line per (tracer,
//! scheduler, workers) with its fitted slope in the legend, and the dashed slope −½ guide.

use super::{config_key, fitted_slope, summarise, ConvergenceRow};
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

static FONT: std::sync::Once = std::sync::Once::new();

fn register_font() {
    FONT.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            include_bytes!("../../assets/fonts/DejaVuSans.ttf"),
        );
    });
}

/// Strong, distinct colours (matplotlib's tab10): Palette99's first entries are too pale to
/// tell apart on white.
const COLOURS: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

const PANEL: (u32, u32) = (1000, 560);

/// Log-log plot of RMSE against wall time, one panel per scene and one series per
/// configuration (the same colour in every panel), each with its fitted slope in the legend,
/// plus a dashed −½ guide through the final point of the scene's lowest-error configuration.
/// `.svg` for SVG, anything else PNG.
///
/// # Errors
/// Drawing errors, or no rows with positive time and error.
pub fn plot(path: &Path, rows: &[ConvergenceRow]) -> anyhow::Result<()> {
    register_font();
    let usable = |r: &&ConvergenceRow| r.wall_s > 0.0 && r.rmse > 0.0;
    anyhow::ensure!(
        rows.iter().any(|r| usable(&r)),
        "no rows with positive wall time and error to plot"
    );
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    let mut scenes: Vec<&str> = rows
        .iter()
        .filter(usable)
        .map(|r| r.scene.as_str())
        .collect();
    scenes.sort_unstable();
    scenes.dedup();
    let size = (PANEL.0, PANEL.1 * scenes.len() as u32);
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => draw(
            SVGBackend::new(path, size).into_drawing_area(),
            rows,
            &scenes,
        ),
        _ => draw(
            BitMapBackend::new(path, size).into_drawing_area(),
            rows,
            &scenes,
        ),
    }
}

fn e<E: std::fmt::Display>(err: E) -> anyhow::Error {
    anyhow::anyhow!("{err}")
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    rows: &[ConvergenceRow],
    scenes: &[&str],
) -> anyhow::Result<()> {
    root.fill(&WHITE).map_err(e)?;
    let mut configs: Vec<String> = rows.iter().map(|r| config_key(r).1).collect();
    configs.sort();
    configs.dedup();
    let summary = summarise(rows);
    for (panel, scene) in root.split_evenly((scenes.len(), 1)).iter().zip(scenes) {
        let mut groups: BTreeMap<String, Vec<&ConvergenceRow>> = BTreeMap::new();
        for r in rows
            .iter()
            .filter(|r| r.scene == *scene && r.wall_s > 0.0 && r.rmse > 0.0)
        {
            groups.entry(config_key(r).1).or_default().push(r);
        }
        let all = groups.values().flatten();
        let (x0, x1, y0, y1) = all.fold(
            (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64),
            |(a, b, c, d), r| {
                (
                    a.min(r.wall_s),
                    b.max(r.wall_s),
                    c.min(r.rmse),
                    d.max(r.rmse),
                )
            },
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("RMSE vs wall time: {scene}"), ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (x0 / 1.5..x1 * 1.5).log_scale(),
                (y0 / 1.5..y1 * 1.5).log_scale(),
            )
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("wall time [s]")
            .y_desc("RMSE")
            .x_label_formatter(&|v| format!("{v:.2e}"))
            .y_label_formatter(&|v| format!("{v:.2e}"))
            .draw()
            .map_err(e)?;
        for (config, g) in &groups {
            let k = configs.iter().position(|c| c == config).unwrap_or(0);
            let (r, gr, b) = COLOURS[k % COLOURS.len()];
            let colour = RGBColor(r, gr, b);
            let series: Vec<(f64, f64)> = g.iter().map(|r| (r.wall_s, r.rmse)).collect();
            let owned: Vec<ConvergenceRow> = g.iter().map(|r| (*r).clone()).collect();
            let slope = fitted_slope(&owned).map_or("n/a".into(), |s| format!("{s:.2}"));
            let style = colour.stroke_width(2);
            let label = format!("{config}: slope {slope}");
            // Past ten configurations the colours repeat; dash the second round.
            if k < COLOURS.len() {
                chart
                    .draw_series(LineSeries::new(series.clone(), style))
                    .map_err(e)?
                    .label(label)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], style));
            } else {
                chart
                    .draw_series(DashedLineSeries::new(series.clone(), 4, 3, style))
                    .map_err(e)?
                    .label(label)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], style));
            }
            chart
                .draw_series(series.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(e)?;
        }
        // The −½ guide through the final point of the scene's lowest-error configuration.
        let best = summary
            .iter()
            .find(|s| s.scene == *scene)
            .and_then(|s| groups.get(&s.config))
            .and_then(|g| g.last());
        if let Some(anchor) = best {
            let (gx, gy) = (anchor.wall_s, anchor.rmse);
            let guide: Vec<(f64, f64)> = (0..=20)
                .map(|i| {
                    let x = x0 * (x1 / x0).powf(i as f64 / 20.0);
                    (x, gy * (x / gx).powf(-0.5))
                })
                .filter(|&(_, y)| y >= y0 / 1.5 && y <= y1 * 1.5)
                .collect();
            chart
                .draw_series(DashedLineSeries::new(guide, 6, 4, BLACK.stroke_width(1)))
                .map_err(e)?
                .label("slope −½ guide")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(e)?;
    }
    root.present().map_err(e)?;
    Ok(())
}
