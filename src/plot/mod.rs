//! Plots drawn from `runs.csv` (and `timelines/*.csv`) alone, never from in-memory state, so any
//! old run can be re-plotted with `raysched plot results/<experiment>`. Every figure is written
//! as PNG (bitmap backend) and SVG, with the bundled DejaVu Sans (no system fonts needed).

mod charts;

pub use charts::{mpi_line, throughput, Figure};

use crate::experiment::summary::Summary;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

/// Register the bundled font as "sans-serif" (once per process).
pub fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .unwrap_or_else(|_| panic!("the bundled DejaVuSans.ttf is a valid font"));
    });
}

/// Draw every figure the data supports into `dir/plots/`; returns them for `report.md`.
pub fn draw_all(dir: &Path, sums: &[Summary]) -> Result<Vec<Figure>, String> {
    register_font();
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).map_err(|e| format!("{}: {e}", plots.display()))?;
    charts::draw_all(dir, &plots, sums)
}
