//! The log-log plot of a convergence CSV: one panel per scene, one line per (tracer,
//! scheduler, workers) with its fitted slope in the legend, and the dashed slope −½ guide.

use super::{config_key, fitted_slope, summarise, ConvergenceRow};
use crate::plot::font::register_font;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

const PANEL: (u32, u32) = (1000, 560);

/// Why a convergence plot was not drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Nothing to draw on log axes.
    #[error("no rows with positive wall time and error to plot")]
    NoRows,
    /// Creating the plot's folder.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The drawing backend, as its text.
    #[error("{0}")]
    Draw(String),
}

/// Log-log plot of RMSE against wall time, one panel per scene and one series per
/// configuration (the same colour in every panel), each with its fitted slope in the legend,
/// plus a dashed −½ guide through the final point of the scene's lowest-error configuration.
/// `.svg` for SVG, anything else PNG.
///
/// # Errors
/// Drawing errors, or no rows with positive time and error.
pub fn plot(path: &Path, rows: &[ConvergenceRow]) -> Result<(), PlotError> {
    register_font();
    let usable = |r: &&ConvergenceRow| r.wall_s > 0.0 && r.rmse > 0.0;
    if !rows.iter().any(|r| usable(&r)) {
        return Err(PlotError::NoRows);
    }
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

fn e<E: std::fmt::Display>(err: E) -> PlotError {
    PlotError::Draw(err.to_string())
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    rows: &[ConvergenceRow],
    scenes: &[&str],
) -> Result<(), PlotError> {
    use crate::plot::axes::{self, AxisSpec, Key, Scale};
    use crate::plot::style::{self, Dash};
    root.fill(&WHITE).map_err(e)?;
    let mut configs: Vec<String> = rows.iter().map(|r| config_key(r).1).collect();
    configs.sort();
    configs.dedup();
    let styles = style::for_names(&configs);
    let summary = summarise(rows);
    let usable = |r: &&ConvergenceRow| r.wall_s > 0.0 && r.rmse > 0.0;
    // One x and one y range for every panel, so panels compare at a glance.
    let (x0, x1, y0, y1) = rows.iter().filter(usable).fold(
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
    let (cx0, cx1) = ((x0 / 1.3).log10(), (x1 * 1.3).log10());
    let (cy0, cy1) = ((y0 / 1.3).log10(), (y1 * 1.3).log10());
    for (panel, scene) in root.split_evenly((scenes.len(), 1)).iter().zip(scenes) {
        let mut groups: BTreeMap<String, Vec<&ConvergenceRow>> = BTreeMap::new();
        for r in rows.iter().filter(|r| r.scene == *scene).filter(usable) {
            groups.entry(config_key(r).1).or_default().push(r);
        }
        let mut keys: Vec<(String, Key)> = Vec::new();
        for (config, g) in &groups {
            let k = configs.iter().position(|c| c == config).unwrap_or(0);
            let owned: Vec<ConvergenceRow> = g.iter().map(|r| (*r).clone()).collect();
            let slope = fitted_slope(&owned).map_or("n/a".into(), |s| format!("{s:.2}"));
            keys.push((format!("{config}: slope {slope}"), Key::Series(styles[k])));
        }
        keys.push(("slope −½ guide".into(), Key::Line(BLACK, Dash::Dashed)));
        let body = axes::titled(panel, &format!("RMSE vs wall time: {scene}")).map_err(e)?;
        let labels: Vec<String> = keys.iter().map(|k| k.0.clone()).collect();
        let (plot, legend_area) = axes::with_legend(&body, &labels);
        let xs = AxisSpec {
            desc: "wall time (s), log scale".into(),
            range: (cx0, cx1),
            scale: Scale::Log10,
        };
        let ys = AxisSpec {
            desc: "RMSE, log scale".into(),
            range: (cy0, cy1),
            scale: Scale::Log10,
        };
        let mut chart = axes::chart(&plot, &xs, &ys).map_err(e)?;
        for (config, g) in &groups {
            let k = configs.iter().position(|c| c == config).unwrap_or(0);
            let pts: Vec<(f64, f64)> = g
                .iter()
                .map(|r| (r.wall_s.log10(), r.rmse.log10()))
                .collect();
            axes::draw_line(&mut chart, &pts, styles[k], 2).map_err(e)?;
        }
        // The −½ guide through the final point of the scene's lowest-error configuration.
        let best = summary
            .iter()
            .find(|s| s.scene == *scene)
            .and_then(|s| groups.get(&s.config))
            .and_then(|g| g.last());
        if let Some(anchor) = best {
            let (gx, gy) = (anchor.wall_s, anchor.rmse);
            let pa = chart.plotting_area().strip_coord_spec();
            let o = pa.get_base_pixel();
            let guide: Vec<(i32, i32)> = (0..=20)
                .map(|i| {
                    let x = x0 * (x1 / x0).powf(i as f64 / 20.0);
                    (x.log10(), (gy * (x / gx).powf(-0.5)).log10())
                })
                .filter(|&(_, y)| y >= cy0 && y <= cy1)
                .map(|p| {
                    let b = chart.backend_coord(&p);
                    (b.0 - o.0, b.1 - o.1)
                })
                .collect();
            for piece in axes::dashed(&guide, Dash::Dashed) {
                pa.draw(&PathElement::new(piece, BLACK.stroke_width(1)))
                    .map_err(e)?;
            }
        }
        axes::legend(&legend_area, &keys).map_err(e)?;
    }
    root.present().map_err(e)?;
    Ok(())
}
