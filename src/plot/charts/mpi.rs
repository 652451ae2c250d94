//! MPI ranks against local threads: throughput vs chunk size.

use super::*;

/// Throughput vs chunk size, one line per transport (and launch size) and one for the
/// local-thread baseline with as many threads as worker ranks; best buffer at each chunk.
pub(super) fn mpi_throughput(
    dir: &Path,
    plots: &Path,
    final_plots: &Path,
    bitmap: bool,
    g: &str,
    gs: &str,
    sums: &[Summary],
) -> Result<Option<Figure>, String> {
    let rows: Vec<&Summary> = sums
        .iter()
        .filter(|s| s.group() == g && s.row.ranks.is_some() && s.row.chunk_px.is_some())
        .collect();
    if !rows.iter().any(|s| s.row.on_mpi()) {
        return Ok(None);
    }
    let unit = ChunkUnit::of(&rows);
    let x = |s: &Summary| unit.x(s);
    let rays = series(&rows, mpi_line, x, |s| point(throughput(s).0), higher);
    let items = series(&rows, mpi_line, x, |s| point(throughput(s).1), higher);
    let stem = plots.join(format!("mpi_throughput_{gs}"));
    let title = format!("MPI ranks vs local threads — {g}");
    let x_desc = unit.desc(&rows);
    let top_title = format!("Throughput vs chunk size — {g}");
    let top = Lines {
        title: &top_title,
        x_desc: &x_desc,
        y_desc: "Mrays/s (median run)",
        x: Scale::Log2,
        y: Scale::Linear,
        ideal: false,
        refs: &[],
        y_range: None,
        legend_w: 0,
    };
    let bottom = Lines {
        title: "Items handed out per second vs chunk size",
        x_desc: &x_desc,
        y_desc: "items/s (median run), log scale",
        x: Scale::Log2,
        y: Scale::Log10,
        ideal: false,
        refs: &[],
        y_range: None,
        legend_w: 0,
    };
    both!(
        bitmap,
        stem,
        (900, 820),
        two_charts((&top, &rays), (&bottom, &items))
    );
    let stem = final_plots.join(stem.strip_prefix(plots).unwrap_or(&stem));
    Ok(Some(Figure {
        file: stem
            .strip_prefix(dir)
            .unwrap_or(&stem)
            .with_extension("png")
            .to_string_lossy()
            .into_owned(),
        title,
        caption: "One line per transport (MPI ranks 1…K−1 render, rank 0 schedules) and one for the same scheduler on K−1 local threads; best buffer B at each chunk size. Per-ray items (left) measure the cost of one message round trip per pixel; from 16×16 tiles on, rendering dominates and the lines should meet.".into(),
    }))
}
