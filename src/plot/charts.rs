//! The figures: speedup vs workers, granularity (wall and speedup vs chunk size), buffer size,
//! overhead breakdown and Gantt timelines.

use super::axes::{self, AxisSpec, Key, Scale};
use super::style::{self, Dash};
use crate::experiment::run::{slug, timeline_path};
use crate::experiment::summary::Summary;
use crate::metrics::MASTER_LANE;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// A drawn figure: `file` is the PNG relative to the experiment folder (an SVG lies beside it).
#[derive(Clone, Debug)]
pub struct Figure {
    /// The PNG's path relative to the experiment folder (`plots/….png`).
    pub file: String,
    /// The heading it gets in `report.md`.
    pub title: String,
    /// How to read it, one sentence.
    pub caption: String,
}

type R = Result<(), String>;

fn e<T: std::fmt::Display>(err: T) -> String {
    err.to_string()
}

const SIZE: (u32, u32) = (900, 560);

/// Draw `$f(&root, args…)` on an SVG backend and, where `$bitmap` holds, on a PNG one (a
/// PNG rasterised from the SVG afterwards, at `--png-scale`, is not drawn twice).
macro_rules! both {
    ($bitmap:expr, $stem:expr, $size:expr, $f:ident ( $($arg:expr),* )) => {{
        let png = $stem.with_extension("png");
        if $bitmap {
            let root = BitMapBackend::new(&png, $size).into_drawing_area();
            root.fill(&WHITE).map_err(e)?;
            $f(&root, $($arg),*)?;
            root.present().map_err(|err| format!("{}: {err}", png.display()))?;
        }
        let svg = $stem.with_extension("svg");
        {
            let root = SVGBackend::new(&svg, $size).into_drawing_area();
            root.fill(&WHITE).map_err(e)?;
            $f(&root, $($arg),*)?;
            root.present().map_err(|err| format!("{}: {err}", svg.display()))?;
        }
    }};
}

/// Line `i`'s colour ([`style::nth`]).
pub fn palette(i: usize) -> RGBColor {
    style::nth(i).colour
}

/// One point of a line: x, y and the 95 % interval of y (both equal to y without one), in the
/// values' own units (the chart applies its scales).
type Pt = (f64, f64, f64, f64);

/// (name, points) lines: for each scheduler kind, the best config at each x.
pub(crate) type Series = Vec<(String, Vec<Pt>)>;

/// A value without an interval.
fn point(y: f64) -> (f64, f64, f64) {
    (y, y, y)
}

/// Median wall time with its bootstrap interval.
fn wall_ci(s: &Summary) -> (f64, f64, f64) {
    (s.wall_median, s.wall_median_ci.0, s.wall_median_ci.1)
}

/// Speedup (paired ratio of medians) with its interval, else the median of row speedups.
fn speed_ci(s: &Summary) -> (f64, f64, f64) {
    match &s.speedup {
        Some(r) => (r.value, r.lo, r.hi),
        None => point(s.speedup_median),
    }
}

/// The unit of a granularity chart's x axis: the one its configurations are written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ChunkUnit {
    /// `chunk = "4"`: a 4 × 4 tile; x is the side.
    Side,
    /// Rows, frames and w×h tiles only: x is pixels per item.
    Pixels,
}

impl ChunkUnit {
    /// Side where any configuration names a square tile by its side, else pixels.
    pub(crate) fn of(sums: &[&Summary]) -> Self {
        let square = |s: &&&Summary| {
            s.row
                .chunk
                .as_deref()
                .is_some_and(|c| c.parse::<u64>().is_ok())
        };
        if sums.iter().any(|s| square(&s)) {
            Self::Side
        } else {
            Self::Pixels
        }
    }

    /// The x value of a configuration: its tile side (√ pixels for rows and frames).
    pub(crate) fn x(self, s: &Summary) -> Option<f64> {
        let px = s.row.chunk_px? as f64;
        Some(match self {
            Self::Side => px.sqrt(),
            Self::Pixels => px,
        })
    }

    /// The axis description, said once.
    pub(crate) fn desc(self, sums: &[&Summary]) -> String {
        let other = sums.iter().any(|s| {
            s.row
                .chunk
                .as_deref()
                .is_some_and(|c| c.parse::<u64>().is_err())
        });
        match (self, other) {
            (Self::Side, false) => "chunk: tile side in px (an item is side × side), log₂".into(),
            (Self::Side, true) => {
                "chunk: tile side in px (rows, frame: √ of their pixels), log₂".into()
            }
            (Self::Pixels, _) => "chunk: pixels per item, log₂".into(),
        }
    }
}

/// `better` of [`series`] for speedup and throughput.
fn higher(a: f64, b: f64) -> bool {
    a > b
}

/// `better` of [`series`] for wall time.
fn lower(a: f64, b: f64) -> bool {
    a < b
}

fn series(
    sums: &[&Summary],
    key: impl Fn(&Summary) -> Option<String>,
    x: impl Fn(&Summary) -> Option<f64>,
    y: impl Fn(&Summary) -> (f64, f64, f64),
    better: impl Fn(f64, f64) -> bool,
) -> Series {
    let mut out: Series = Vec::new();
    for s in sums {
        let (Some(k), Some(xv)) = (key(s), x(s)) else {
            continue;
        };
        if !xv.is_finite() {
            continue;
        }
        let (yv, lo, hi) = y(s);
        if !yv.is_finite() {
            continue;
        }
        let (lo, hi) = if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (yv, yv)
        };
        let line = match out.iter_mut().position(|(n, _)| *n == k) {
            Some(i) => &mut out[i].1,
            None => {
                out.push((k, vec![]));
                &mut out.last_mut().expect("just pushed").1
            }
        };
        match line.iter_mut().find(|p| p.0 == xv) {
            Some(p) if better(yv, p.1) => *p = (xv, yv, lo, hi),
            Some(_) => {}
            None => line.push((xv, yv, lo, hi)),
        }
    }
    for (_, l) in &mut out {
        l.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    out
}

/// The (min, max) of `f` over every finite point, `None` without one.
fn range_of(data: &Series, f: impl Fn(&Pt) -> f64) -> Option<(f64, f64)> {
    let (lo, hi) = data
        .iter()
        .flat_map(|(_, l)| l.iter().map(&f))
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    lo.is_finite().then_some((lo, hi))
}

/// A line chart: its title, axes, scales and reference lines.
#[derive(Clone, Copy)]
pub(crate) struct Lines<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    /// Linear or log₂.
    pub x: Scale,
    /// Linear or log₁₀.
    pub y: Scale,
    /// Draw the diagonal y = x (ideal speedup).
    pub ideal: bool,
    /// Horizontal reference lines (value, legend text).
    pub refs: &'a [(f64, &'a str)],
    /// The y range in values, shared by the panels of one figure; `None`: from the data.
    pub y_range: Option<(f64, f64)>,
    /// The legend's width, so stacked panels line up; 0: from its labels.
    pub legend_w: i32,
}

/// The y range a chart of `data` under `scale` shows, in values: from 0 (linear) or just
/// below the lowest interval end (log), to just above the highest one and the references.
pub(crate) fn y_extent(data: &Series, scale: Scale, refs: &[(f64, &str)]) -> (f64, f64) {
    let pos = |v: f64| scale != Scale::Log10 || v > 0.0;
    let lo = range_of(data, |p| if pos(p.2) { p.2 } else { p.1 }).map_or(1.0, |r| r.0);
    let hi = range_of(data, |p| p.3).map_or(1.0, |r| r.1);
    let hi = refs.iter().map(|r| r.0).fold(hi, f64::max);
    match scale {
        Scale::Log10 => {
            let lo = refs
                .iter()
                .map(|r| r.0)
                .filter(|v| *v > 0.0)
                .fold(lo, f64::min);
            let (l, h) = (lo.max(1e-300).log10(), hi.max(1e-300).log10());
            let pad = ((h - l) * 0.06).max(0.02);
            (10f64.powf(l - pad), 10f64.powf(h + pad))
        }
        _ => (0.0f64.min(lo), (hi * 1.08).max(1e-9)),
    }
}

pub(crate) fn line_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: &Lines,
    data: &Series,
) -> R {
    let (sx, sy) = (c.x, c.y);
    let tx = |v: f64| sx.to(v);
    let ty = |v: f64| sy.to(v);
    let (x0, x1) = range_of(data, |p| tx(p.0)).unwrap_or((0.0, 1.0));
    let (v0, v1) = c.y_range.unwrap_or_else(|| {
        let mut refs: Vec<(f64, &str)> = c.refs.to_vec();
        if c.ideal {
            refs.push((range_of(data, |p| p.0).map_or(1.0, |r| r.1), ""));
        }
        y_extent(data, sy, &refs)
    });
    let (y0, y1) = (ty(v0), ty(v1));
    let (y0, y1) = if y0.is_finite() && y1.is_finite() && y1 > y0 {
        (y0, y1)
    } else {
        (0.0, 1.0)
    };
    let pad = match sx {
        Scale::Linear => ((x1 - x0) * 0.04).max(0.5),
        _ => ((x1 - x0) * 0.04).max(0.3),
    };
    let mut names: Vec<String> = data.iter().map(|d| d.0.clone()).collect();
    let styles = style::for_names(&names);
    let mut keys: Vec<(String, Key)> = names
        .iter()
        .cloned()
        .zip(styles.iter().map(|s| Key::Series(*s)))
        .collect();
    if c.ideal {
        keys.push((
            "ideal (speedup = workers)".into(),
            Key::Line(BLACK, Dash::Solid),
        ));
    }
    for (k, (_, name)) in c.refs.iter().enumerate() {
        let col = if k == 0 {
            RGBColor(110, 110, 110)
        } else {
            BLACK
        };
        keys.push((name.to_string(), Key::Line(col, Dash::Dashed)));
    }
    names = keys.iter().map(|k| k.0.clone()).collect();
    let body = axes::titled(area, c.title)?;
    let (plot, legend_area) = if c.legend_w > 0 {
        let w = body.dim_in_pixel().0 as i32;
        body.split_horizontally(w - c.legend_w.min(w / 3))
    } else {
        axes::with_legend(&body, &names)
    };
    let xs = AxisSpec {
        desc: c.x_desc.into(),
        range: (x0 - pad, x1 + pad),
        scale: sx,
    };
    let ys = AxisSpec {
        desc: c.y_desc.into(),
        range: (y0, y1),
        scale: sy,
    };
    let mut chart = axes::chart(&plot, &xs, &ys)?;
    if c.ideal {
        let top = range_of(data, |p| p.0).map_or(1.0, |r| r.1);
        let ideal = [(tx(1.0), ty(1.0)), (tx(top), ty(top))];
        chart
            .draw_series(std::iter::once(PathElement::new(
                ideal.to_vec(),
                BLACK.stroke_width(1),
            )))
            .map_err(e)?;
    }
    for (k, &(y, _)) in c.refs.iter().enumerate() {
        let col = if k == 0 {
            RGBColor(110, 110, 110)
        } else {
            BLACK
        };
        let (a, b) = (
            chart.backend_coord(&(x0 - pad, ty(y))),
            chart.backend_coord(&(x1 + pad, ty(y))),
        );
        let pa = chart.plotting_area().strip_coord_spec();
        let base = pa.get_base_pixel();
        if ty(y).is_finite() && ty(y) >= y0 && ty(y) <= y1 {
            for piece in axes::dashed(
                &[(a.0 - base.0, a.1 - base.1), (b.0 - base.0, b.1 - base.1)],
                Dash::Dashed,
            ) {
                pa.draw(&PathElement::new(piece, col.stroke_width(1)))
                    .map_err(e)?;
            }
        }
    }
    for ((_, pts), st) in data.iter().zip(&styles) {
        let t: Vec<Pt> = pts
            .iter()
            .map(|p| (tx(p.0), ty(p.1), ty(p.2), ty(p.3)))
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        // 95 % intervals, where the summary has them.
        chart
            .draw_series(
                t.iter()
                    .filter(|p| p.2.is_finite() && p.3.is_finite() && p.3 > p.2)
                    .map(|&(x, _, lo, hi)| {
                        PathElement::new(
                            vec![(x, lo.max(y0)), (x, hi.min(y1))],
                            st.colour.stroke_width(1),
                        )
                    }),
            )
            .map_err(e)?;
        let xy: Vec<(f64, f64)> = t.iter().map(|p| (p.0, p.1)).collect();
        axes::draw_line(&mut chart, &xy, *st, 2)?;
    }
    axes::legend(&legend_area, &keys)
}

/// Two charts over one x axis, one above the other.
fn two_charts<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    top: (&Lines, &Series),
    bottom: (&Lines, &Series),
) -> R {
    let (upper, lower) = root.split_vertically(root.dim_in_pixel().1 as i32 / 2);
    // One legend width for both, so their x axes line up.
    let mut labels: Vec<String> = [top.1, bottom.1]
        .iter()
        .flat_map(|d| d.iter().map(|l| l.0.clone()))
        .collect();
    for c in [top.0, bottom.0] {
        labels.extend(c.refs.iter().map(|r| r.1.to_string()));
        if c.ideal {
            labels.push("ideal (speedup = workers)".into());
        }
    }
    let w = axes::legend_width(&labels, root.dim_in_pixel().0 as i32 / 3);
    line_chart(
        &upper,
        &Lines {
            legend_w: w,
            ..*top.0
        },
        top.1,
    )?;
    line_chart(
        &lower,
        &Lines {
            legend_w: w,
            ..*bottom.0
        },
        bottom.1,
    )
}

/// Stacked bars: work, imbalance, other idle, dispatch; a dashed line at the serial time.
fn overhead_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    bars: &[(String, [f64; 4])],
    serial_s: f64,
) -> R {
    let parts = [
        "work (Σ busy)",
        "idle: imbalance",
        "idle: other",
        "dispatch (master)",
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
        .fold(serial_s, f64::max)
        * 1.08;
    let n = bars.len().max(1);
    let mut keys: Vec<(String, Key)> = parts
        .iter()
        .zip(cols)
        .map(|(p, c)| (p.to_string(), Key::Box(c)))
        .collect();
    keys.push((
        "serial time (no overhead)".into(),
        Key::Line(BLACK, Dash::Dashed),
    ));
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
    let row_h = {
        let a = chart.backend_coord(&(0.0, 0.0)).1;
        let b = chart.backend_coord(&(0.0, 1.0)).1;
        (a - b).abs()
    };
    // Every k-th name where rows are thinner than a line of text.
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
    let (a, b) = (
        chart.backend_coord(&(serial_s, -0.5)),
        chart.backend_coord(&(serial_s, n as f64 - 0.5)),
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
    axes::legend(&legend_area, &keys)
}

/// One line of a timeline file (`source` is absent in files written before it).
#[derive(serde::Deserialize)]
struct SpanLine {
    worker: u32,
    item: u32,
    start_ns: u64,
    end_ns: u64,
    #[serde(default)]
    source: String,
}

/// (worker, item, start_ns, end_ns) rows of a timeline file, and each worker's kind of
/// source where the file records it.
fn read_timeline(path: &Path) -> Result<Timeline, String> {
    let mut rdr =
        csv::Reader::from_path(path).map_err(|err| format!("{}: {err}", path.display()))?;
    let mut out = Timeline::default();
    for r in rdr.deserialize::<SpanLine>() {
        let l = r.map_err(|err| format!("{}: {err}", path.display()))?;
        if !l.source.is_empty()
            && l.worker != MASTER_LANE
            && !out.kinds.iter().any(|k| k.0 == l.worker)
        {
            out.kinds.push((l.worker, l.source));
        }
        out.spans.push((l.worker, l.item, l.start_ns, l.end_ns));
    }
    Ok(out)
}

/// A run's spans and the kind of source of each worker (empty for files without it).
#[derive(Default)]
struct Timeline {
    spans: Vec<(u32, u32, u64, u64)>,
    kinds: Vec<(u32, String)>,
}

/// The Gantt chart's lanes, bottom to top: workers grouped by kind of source (threads, then
/// GPU, then MPI ranks, in `SourceKind::ALL` order; workers of no recorded kind first), by id
/// within a group, then the master. Each lane is (worker, label); also the lane index where
/// each group after the first starts.
fn gantt_lanes(tl: &Timeline) -> (Vec<(u32, String)>, Vec<usize>) {
    let kind_of = |w: u32| {
        tl.kinds
            .iter()
            .find(|k| k.0 == w)
            .map_or("", |k| k.1.as_str())
    };
    let rank = |kind: &str| {
        crate::sched::SourceKind::ALL
            .iter()
            .position(|k| k.id() == kind)
            .map_or(0, |p| p + 1)
    };
    let mut workers: Vec<u32> = tl
        .spans
        .iter()
        .map(|s| s.0)
        .filter(|&w| w != MASTER_LANE)
        .collect();
    workers.sort_unstable_by_key(|&w| (rank(kind_of(w)), w));
    workers.dedup();
    let mut lanes = Vec::new();
    let mut starts = Vec::new();
    for w in workers {
        let kind = kind_of(w);
        if let Some((prev, _)) = lanes.last() {
            if kind_of(*prev) != kind {
                starts.push(lanes.len());
            }
        }
        let label = if kind.is_empty() {
            format!("worker {w}")
        } else {
            format!("{kind} {w}")
        };
        lanes.push((w, label));
    }
    if tl.spans.iter().any(|s| s.0 == MASTER_LANE) {
        starts.push(lanes.len());
        lanes.push((MASTER_LANE, "master".to_string()));
    }
    (lanes, starts)
}

fn gantt_chart<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, title: &str, tl: &Timeline) -> R {
    let spans = &tl.spans[..];
    let (lane_list, group_starts) = gantt_lanes(tl);
    let lanes = lane_list.len().max(1);
    let lane = |w: u32| lane_list.iter().position(|l| l.0 == w).unwrap_or(0) as f64;
    let end_ms = spans.iter().map(|s| s.3).max().unwrap_or(1) as f64 / 1e6;
    // Colour = the item's duration, in five bins of a colour-blind-safe sequential scale
    // (viridis), log-spaced when durations spread over more than a decade.
    const BINS: [RGBColor; 5] = [
        RGBColor(68, 1, 84),
        RGBColor(59, 82, 139),
        RGBColor(33, 145, 140),
        RGBColor(94, 201, 98),
        RGBColor(253, 231, 37),
    ];
    let dur = |s: &(u32, u32, u64, u64)| (s.3.saturating_sub(s.2)).max(1) as f64 / 1e6;
    let (dmin, dmax) = spans
        .iter()
        .map(dur)
        .fold((f64::INFINITY, 0.0f64), |(a, b), d| (a.min(d), b.max(d)));
    let log = dmax > 10.0 * dmin;
    let scale = |d: f64| if log { d.ln() } else { d };
    let bin_of = |d: f64| {
        let span = scale(dmax) - scale(dmin);
        if span.is_nan() || span <= 0.0 {
            return 0;
        }
        (((scale(d) - scale(dmin)) / span * 5.0) as usize).min(4)
    };
    let edge = |k: usize| {
        let v = scale(dmin) + (scale(dmax) - scale(dmin)) * k as f64 / 5.0;
        if log {
            v.exp()
        } else {
            v
        }
    };
    let used: Vec<usize> = (0..5)
        .filter(|k| spans.iter().any(|s| bin_of(dur(s)) == *k))
        .collect();
    let keys: Vec<(String, Key)> = used
        .iter()
        .map(|&k| {
            (
                format!(
                    "item {}–{} ms",
                    axes::tidy(edge(k)),
                    axes::tidy(edge(k + 1))
                ),
                Key::Box(BINS[k]),
            )
        })
        .collect();
    let body = axes::titled(root, title)?;
    let labels: Vec<String> = keys.iter().map(|k| k.0.clone()).collect();
    let (plot, legend_area) = axes::with_legend(&body, &labels);
    let label_w = lane_list
        .iter()
        .map(|l| axes::text_size(&l.1, axes::TICK_FONT).0)
        .max()
        .unwrap_or(0)
        + 12;
    let (labels_area, chart_area) =
        plot.split_horizontally(label_w.min(plot.dim_in_pixel().0 as i32 / 4));
    let xs = AxisSpec {
        desc: "time since the run started (ms)".into(),
        range: (0.0, end_ms * 1.02),
        scale: Scale::Linear,
    };
    let ys = AxisSpec {
        desc: String::new(),
        range: (-0.5, lanes as f64 - 0.5),
        scale: Scale::Linear,
    };
    let mut chart = axes::chart_without_y_ticks(&chart_area, &xs, &ys)?;
    // Lane labels, every k-th where 64 workers' labels would not fit one per lane.
    let row_h = (chart.backend_coord(&(0.0, 0.0)).1 - chart.backend_coord(&(0.0, 1.0)).1).abs();
    let need = axes::text_size("Ag", axes::TICK_FONT).1 + 2;
    let every = (need + row_h - 1) / row_h.max(1);
    let base = labels_area.get_base_pixel();
    let lw = labels_area.dim_in_pixel().0 as i32;
    let font = ("sans-serif", axes::TICK_FONT)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Right, VPos::Center));
    let n = lane_list.len();
    let mut shown: Vec<usize> = (0..n).step_by(every.max(1) as usize).collect();
    // The master's lane (the top one) is always named; its labelled neighbour gives way.
    if lane_list.last().is_some_and(|l| l.0 == MASTER_LANE) && shown.last() != Some(&(n - 1)) {
        if shown.last().is_some_and(|&l| n - 1 - l < every as usize) {
            shown.pop();
        }
        shown.push(n - 1);
    }
    for i in shown {
        let label = &lane_list[i].1;
        let y = chart.backend_coord(&(0.0, i as f64)).1 - base.1;
        labels_area
            .draw(&Text::new(
                axes::fit_text(label, axes::TICK_FONT, lw - 8),
                (lw - 4, y),
                font.clone(),
            ))
            .map_err(axes::e)?;
    }
    // A line between lane groups: threads below, the GPU above, the master on top.
    for &g in &group_starts {
        let y = g as f64 - 0.5;
        chart
            .draw_series(LineSeries::new(
                [(0.0, y), (end_ms * 1.02, y)],
                BLACK.mix(0.6).stroke_width(1),
            ))
            .map_err(e)?;
    }
    for (k, &c) in BINS.iter().enumerate() {
        let mine: Vec<_> = spans.iter().filter(|s| bin_of(dur(s)) == k).collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(mine.into_iter().map(|&(w, _, s, t)| {
                let y = lane(w);
                Rectangle::new(
                    [(s as f64 / 1e6, y - 0.38), (t as f64 / 1e6, y + 0.38)],
                    c.filled(),
                )
            }))
            .map_err(e)?;
    }
    axes::legend(&legend_area, &keys)
}

/// Every figure of every group (scene + settings + tracer) into `plots`, in a fixed order: MPI
/// throughput, speedup vs workers, granularity, buffer, overhead, then the Gantt timelines.
/// `plots` is where they are written, `final_plots` where they will be (their names in the
/// report, and the charts drawn before that a missing timeline keeps). `bitmap`: draw each
/// PNG too (false where the caller rasterises the SVGs itself).
pub(crate) fn draw_all(
    dir: &Path,
    plots: &Path,
    final_plots: &Path,
    bitmap: bool,
    sums: &[Summary],
) -> Result<Vec<Figure>, String> {
    let mut out = Drawn {
        dir,
        plots,
        final_plots,
        bitmap,
        figs: Vec::new(),
        missing: MissingTimelines::default(),
    };
    for g in &group_names(sums) {
        if let Some(f) = mpi_throughput(dir, plots, final_plots, bitmap, g, &slug(g), sums)? {
            out.figs.push(f);
        }
        // The figures below compare thread schedulers; MPI rows have their own figure.
        let Some(group) = Group::of(g, sums) else {
            continue;
        };
        speedup_vs_workers(&mut out, &group)?;
        granularity(&mut out, &group)?;
        predicted_vs_measured(&mut out, &group)?;
        buffer_sizes(&mut out, &group)?;
        let best = best_per_scheduler(&group.at_max);
        overhead(&mut out, &group, &best)?;
        gantt_charts(&mut out, &group, &best)?;
    }
    out.missing.note(dir);
    Ok(out.figs)
}

/// Where figures go and what has been drawn so far.
struct Drawn<'a> {
    dir: &'a Path,
    plots: &'a Path,
    final_plots: &'a Path,
    /// Draw the PNGs too, not only the SVGs.
    bitmap: bool,
    figs: Vec<Figure>,
    missing: MissingTimelines,
}

impl Drawn<'_> {
    /// Record the figure drawn at `stem` (its PNG, relative to the experiment folder).
    fn push(&mut self, stem: &Path, title: String, caption: &str) {
        let stem = self
            .final_plots
            .join(stem.strip_prefix(self.plots).unwrap_or(stem));
        let file = stem
            .strip_prefix(self.dir)
            .unwrap_or(&stem)
            .with_extension("png")
            .to_string_lossy()
            .into_owned();
        self.figs.push(Figure {
            file,
            title,
            caption: caption.into(),
        });
    }
}

/// Group names in the order they first appear.
fn group_names(sums: &[Summary]) -> Vec<String> {
    let mut groups: Vec<String> = Vec::new();
    for s in sums {
        if !groups.contains(&s.group()) {
            groups.push(s.group());
        }
    }
    groups
}

/// One group's thread-scheduler rows: all of them, and those at the most workers.
struct Group<'a> {
    name: &'a str,
    slug: String,
    all: Vec<&'a Summary>,
    at_max: Vec<&'a Summary>,
    max_w: usize,
}

impl<'a> Group<'a> {
    /// `None` when the group has no thread-scheduler rows (only serial or MPI ones).
    fn of(name: &'a str, sums: &'a [Summary]) -> Option<Self> {
        let all: Vec<&Summary> = sums
            .iter()
            .filter(|s| s.group() == name && !s.row.is_serial() && !s.row.on_mpi())
            .collect();
        if all.is_empty() {
            return None;
        }
        let max_w = all.iter().map(|s| s.row.workers).max().unwrap_or(1);
        let at_max = all
            .iter()
            .copied()
            .filter(|s| s.row.workers == max_w)
            .collect();
        Some(Self {
            name,
            slug: slug(name),
            all,
            at_max,
            max_w,
        })
    }
}

fn kind(s: &Summary) -> Option<String> {
    Some(s.row.scheduler.clone())
}

fn speedup_vs_workers(out: &mut Drawn, gr: &Group) -> R {
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
        x: Scale::Linear,
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

fn granularity(out: &mut Drawn, gr: &Group) -> R {
    let chunks: std::collections::BTreeSet<u64> =
        gr.at_max.iter().filter_map(|s| s.row.chunk_px).collect();
    if chunks.len() <= 1 {
        return Ok(());
    }
    let (g, max_w) = (gr.name, gr.max_w);
    let unit = ChunkUnit::of(&gr.at_max);
    let x = |s: &Summary| unit.x(s);
    let wall = series(&gr.at_max, kind, x, wall_ci, lower);
    let speed = series(&gr.at_max, kind, x, speed_ci, higher);
    let wall_scale = axes::auto_scale(
        wall.iter()
            .flat_map(|l| l.1.iter().flat_map(|p| [p.1, p.2, p.3])),
    );
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
    let left = match unit {
        ChunkUnit::Side => {
            "Left end = per-ray items (a 1 × 1 tile), right end = the whole image as one item."
        }
        ChunkUnit::Pixels => {
            "Left end = per-ray items (1 pixel), right end = the whole image as one item."
        }
    };
    out.push(&stem, title, &format!("{left} Dispatch cost dominates on the left, load imbalance on the right; the best granularity is the valley of the wall-time curve{}. Bars: 95 % intervals of the median (top) and of the paired speedup (bottom).", if wall_scale == Scale::Log10 { " (log scale: equal heights are equal ratios)" } else { "" }));
    Ok(())
}

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
    let all = groups.iter().flat_map(|g| g.1.iter());
    let vals: Vec<f64> = all
        .flat_map(|p| [p.0, p.1, p.2, p.3])
        .filter(|v| v.is_finite())
        .collect();
    let scale = axes::auto_scale(vals.iter().copied());
    let t = |v: f64| scale.to(v);
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
    let pa = chart.plotting_area().strip_coord_spec();
    let o = pa.get_base_pixel();
    for (k, col, dash) in [
        (1.0, BLACK, Dash::Solid),
        (1.25, RGBColor(110, 110, 110), Dash::Dashed),
        (0.8, RGBColor(110, 110, 110), Dash::Dashed),
    ] {
        // y = k·x sampled, so it is straight on either scale.
        let pts: Vec<(i32, i32)> = (0..=40)
            .map(|i| {
                let c = c0 + (c1 - c0) * i as f64 / 40.0;
                let v = match scale {
                    Scale::Log10 => 10f64.powf(c),
                    _ => c,
                };
                (c, t(v * k))
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

fn predicted_vs_measured(out: &mut Drawn, gr: &Group) -> R {
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

fn buffer_sizes(out: &mut Drawn, gr: &Group) -> R {
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

/// Each scheduler kind's fastest configuration (median wall time), in first-seen order.
fn best_per_scheduler<'a>(at_max: &[&'a Summary]) -> Vec<&'a Summary> {
    let mut best: Vec<&Summary> = Vec::new();
    for s in at_max {
        match best.iter_mut().find(|b| b.row.scheduler == s.row.scheduler) {
            Some(b) if s.wall_median < b.wall_median => *b = s,
            Some(_) => {}
            None => best.push(s),
        }
    }
    best
}

fn overhead(out: &mut Drawn, gr: &Group, best: &[&Summary]) -> R {
    let serial_s = gr.at_max.first().map_or(0.0, |s| s.row.serial_s);
    let bars: Vec<(String, [f64; 4])> = best
        .iter()
        .map(|s| {
            let other_idle = (s.idle_s_median - s.imbalance_s_median).max(0.0);
            (
                s.row.scheduler.clone(),
                [
                    s.work_s_median,
                    s.imbalance_s_median.min(s.idle_s_median),
                    other_idle,
                    s.dispatch_s_median,
                ],
            )
        })
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
    let caption = format!("Medians of wall-clock spans summed over the workers (busy, idle split into imbalance and the rest) plus the master's dispatch time on its own thread; total height ≈ workers × wall time. Everything above the black serial line is overhead. Drawn: {}.", drawn.join(", "));
    out.push(&stem, title, &caption);
    Ok(())
}

/// Gantt: each kind's best run, plus the per-ray master if there is one.
fn gantt_charts(out: &mut Drawn, gr: &Group, best: &[&Summary]) -> R {
    // A best run with a GPU among its sources is named by its set too, so a chart's name
    // says which sources it shows whichever configuration came out fastest.
    let named = |s: &Summary| match s.row.sources.as_str() {
        "local" => s.row.scheduler.clone(),
        set => format!("{}_{}", s.row.scheduler, slug(set)),
    };
    let mut picks: Vec<(String, &Summary)> = best.iter().map(|s| (named(s), *s)).collect();
    if let Some(pr) = gr
        .at_max
        .iter()
        .filter(|s| s.row.buffer().is_some() && s.row.chunk_px == Some(1))
        .min_by(|a, b| a.wall_median.total_cmp(&b.wall_median))
    {
        if !picks.iter().any(|(_, s)| s.row.config == pr.row.config) {
            picks.push(("master_per_ray".into(), *pr));
        }
    }
    // The fastest run of every other set of sources (threads+gpu, gpu): its lanes by kind.
    let mut sets: Vec<&str> = Vec::new();
    for s in &gr.all {
        if !s.row.on_threads_alone() && !sets.contains(&s.row.sources.as_str()) {
            sets.push(&s.row.sources);
        }
    }
    for set in sets {
        let fastest = gr
            .all
            .iter()
            .filter(|s| s.row.sources == set)
            .min_by(|a, b| a.wall_median.total_cmp(&b.wall_median));
        if let Some(f) = fastest {
            if !picks.iter().any(|(_, s)| s.row.config == f.row.config) {
                picks.push((named(f), *f));
            }
        }
    }
    for (name, s) in picks {
        let stem = out.plots.join(format!("gantt_{}_{name}", gr.slug));
        let title = format!("Timeline: {} ×{} — {}", s.row.label, s.row.workers, gr.name);
        let tl = timeline_path(out.dir, &s.row.config);
        if tl.exists() {
            let timeline = read_timeline(&tl)?;
            both!(out.bitmap, stem, SIZE, gantt_chart(&title, &timeline));
        } else if out
            .final_plots
            .join(stem.strip_prefix(out.plots).unwrap_or(&stem))
            .with_extension("png")
            .exists()
        {
            // Timelines stay out of git: keep the chart drawn when the run was made.
            out.missing.kept += 1;
        } else {
            out.missing.skipped += 1;
            continue;
        }
        out.push(&stem, title, "One lane per worker, grouped by kind of source (threads, GPU, MPI ranks; a line between groups) with the master on its own lane on top; each bar is one work item (a GPU's items of one dispatch share its span), coloured by its duration (legend), white gaps are idle time.");
    }
    Ok(())
}

/// Gantt charts whose timeline file is absent (`timelines/` is not kept in git, and an
/// experiment with `timeline = false` records none).
#[derive(Default)]
struct MissingTimelines {
    /// The chart's PNG from an earlier drawing was there and is kept.
    kept: usize,
    /// No PNG either: the chart is left out.
    skipped: usize,
}

impl MissingTimelines {
    /// One line on stderr when a Gantt chart could not be drawn from its timeline.
    fn note(&self, dir: &Path) {
        if self.kept + self.skipped == 0 {
            return;
        }
        eprintln!(
            "note: {} has no timeline for {} Gantt chart(s): kept {} drawn before, skipped {}",
            dir.join("timelines").display(),
            self.kept + self.skipped,
            self.kept,
            self.skipped
        );
    }
}

/// Mrays/s and items/s of a summary's median run.
pub fn throughput(s: &Summary) -> (f64, f64) {
    (
        s.row.rays as f64 / s.wall_median / 1e6,
        s.row.items as f64 / s.wall_median,
    )
}

/// The line an MPI-experiment row belongs to: its transport and launch, or the local threads.
pub fn mpi_line(s: &Summary) -> Option<String> {
    let ranks = s.row.ranks?;
    Some(match (&s.row.sources[..], &s.row.transport) {
        ("mpi", Some(t)) => format!("{} · MPI {t}, {} ranks", s.row.scheduler, ranks),
        _ => format!("{} · local threads ×{}", s.row.scheduler, s.row.workers),
    })
}

/// Throughput vs chunk size, one line per transport (and launch size) and one for the
/// local-thread baseline with as many threads as worker ranks; best buffer at each chunk.
fn mpi_throughput(
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

#[cfg(test)]
mod gantt_tests {
    use super::*;

    #[test]
    fn lanes_group_workers_by_kind_of_source_with_the_master_on_top() {
        let span = |w: u32| (w, 0, 0, 1);
        let tl = Timeline {
            spans: vec![span(2), span(MASTER_LANE), span(0), span(1), span(2)],
            kinds: vec![
                (2, "gpu".into()),
                (0, "threads".into()),
                (1, "threads".into()),
            ],
        };
        let (lanes, starts) = gantt_lanes(&tl);
        let labels: Vec<&str> = lanes.iter().map(|l| l.1.as_str()).collect();
        assert_eq!(labels, ["threads 0", "threads 1", "gpu 2", "master"]);
        assert_eq!(starts, [2, 3]);
        // A file without kinds: one group, as before.
        let old = Timeline {
            spans: tl.spans.clone(),
            kinds: vec![],
        };
        let (lanes, starts) = gantt_lanes(&old);
        let labels: Vec<&str> = lanes.iter().map(|l| l.1.as_str()).collect();
        assert_eq!(labels, ["worker 0", "worker 1", "worker 2", "master"]);
        assert_eq!(starts, [3]);
    }
}

#[cfg(test)]
mod layout_tests {
    //! Every chart kind rendered with many series, long names and wide ranges on an audit
    //! canvas: no two labels may overlap and none may leave the canvas.
    use super::*;
    use crate::experiment::results::RunRow;
    use crate::experiment::summary::summarize;
    use crate::plot::audit::check;
    use crate::sched::SchedulerKind;

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
        let g = crate::experiment::summary::group_of(&sums[0].row);
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
            x: Scale::Linear,
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
                    1.0,
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
            gantt_chart(a, &format!("Timeline: {} ×64 — {g}", "x".repeat(120)), &tl)
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
}
