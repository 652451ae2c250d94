//! The figures: speedup vs workers, granularity (wall and speedup vs chunk size), buffer size,
//! overhead breakdown and Gantt timelines.

use crate::experiment::run::{slug, timeline_path};
use crate::experiment::summary::Summary;
use crate::metrics::MASTER_LANE;
use crate::sched::SchedulerKind;
use plotters::coord::Shift;
use plotters::prelude::*;
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

/// The Okabe–Ito colours every chart draws its lines in: distinguishable with colour
/// blindness and readable on white.
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(230, 159, 0),
    RGBColor(120, 120, 120),
];

/// Line `i`'s colour, cycling through [`PALETTE`].
pub fn palette(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// A stable colour per scheduler kind (serial and unknown ids get black).
fn colour(kind: &str) -> RGBColor {
    match SchedulerKind::ALL.iter().position(|k| k.id() == kind) {
        Some(i) => palette(i),
        None => BLACK,
    }
}

/// One point of a line: x, y and the 95 % interval of y (both equal to y without one).
type Pt = (f64, f64, f64, f64);

/// (name, points) lines: for each scheduler kind, the best config at each x.
type Series = Vec<(String, Vec<Pt>)>;

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

/// A tick label without exponent clutter: 3 significant digits, trailing zeros dropped.
fn tidy(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    let t = format!("{v:.digits$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// x of the granularity charts: log₂ of the pixels per item.
fn log2_chunk(s: &Summary) -> Option<f64> {
    s.row.chunk_px.map(|c| (c as f64).log2())
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

fn range(series: &Series, f: impl Fn(&Pt) -> f64) -> (f64, f64) {
    let v = series.iter().flat_map(|(_, l)| l.iter().map(&f));
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

fn kind_of(name: &str) -> &str {
    name.split_whitespace().next().unwrap_or(name)
}

fn line_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    data: &Series,
    // (x on a log₂ scale, draw the ideal diagonal, y on a log₁₀ scale)
    (log2_x, ideal, log10_y): (bool, bool, bool),
    refs: &[(f64, &str)],
) -> R {
    // A log y axis is drawn as log₁₀ of the values on a linear axis (labels 10^k): rates that
    // span decades (items/s from per-ray to whole-frame items) stay readable.
    let logged: Series;
    let data = if log10_y {
        let l = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
        logged = data
            .iter()
            .map(|(n, pts)| {
                let pts = pts
                    .iter()
                    .filter(|p| p.1 > 0.0)
                    .map(|p| (p.0, l(p.1), l(p.2.max(p.1 * 1e-3)), l(p.3)))
                    .collect();
                (n.clone(), pts)
            })
            .collect();
        &logged
    } else {
        data
    };
    let (x0, x1) = range(data, |p| p.0);
    let (_, y1) = range(data, |p| p.3);
    let y1 = if ideal { y1.max(x1) } else { y1 };
    let y1 = refs.iter().map(|r| r.0).fold(y1, f64::max);
    let pad = ((x1 - x0) * 0.05).max(0.5);
    let y_range = if log10_y {
        let (y0, _) = range(data, |p| p.2);
        // Head room above the data for the legend: a decade and a half.
        y0.floor()..(y1 + 1.5).ceil()
    } else {
        // Head room above the data for the legend.
        0.0..(y1 * 1.5).max(1e-9)
    };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0 - pad)..(x1 + pad), y_range)
        .map_err(e)?;
    let fmt_y = |v: &f64| {
        if !log10_y {
            tidy(*v)
        } else if (v - v.round()).abs() < 1e-6 {
            tidy(10f64.powf(v.round()))
        } else {
            String::new()
        }
    };
    let fmt_x = |v: &f64| {
        if log2_x {
            if (v - v.round()).abs() < 1e-6 {
                format!("{}", 2f64.powf(v.round()) as u64)
            } else {
                String::new()
            }
        } else if (v - v.round()).abs() < 1e-6 {
            format!("{}", v.round())
        } else {
            format!("{v:.1}")
        }
    };
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&fmt_x)
        .y_label_formatter(&fmt_y)
        .x_labels(((x1 - x0) as usize + 3).min(16))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(e)?;
    if ideal {
        let ideal_pts = vec![(x0.min(1.0), x0.min(1.0)), (x1, x1)];
        chart
            .draw_series(LineSeries::new(ideal_pts, BLACK.stroke_width(1)))
            .map_err(e)?
            .label("ideal (speedup = workers)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    }
    for (k, &(y, name)) in refs.iter().enumerate() {
        let c = if k == 0 {
            RGBColor(120, 120, 120)
        } else {
            BLACK
        };
        chart
            .draw_series(LineSeries::new(
                vec![(x0 - pad, y), (x1 + pad, y)],
                c.stroke_width(1),
            ))
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
    }
    for (i, (name, pts)) in data.iter().enumerate() {
        let mut c = colour(kind_of(name));
        if c == BLACK
            || data
                .iter()
                .filter(|(n, _)| kind_of(n) == kind_of(name))
                .count()
                > 1
        {
            // Several lines of one kind (the buffer plot): tell them apart by index.
            c = colour(SchedulerKind::ALL[i % SchedulerKind::ALL.len()].id());
        }
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>(),
                c.stroke_width(2),
            ))
            .map_err(e)?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        // 95 % intervals, where the summary has them.
        chart
            .draw_series(
                pts.iter().filter(|p| p.3 > p.2).map(|&(x, _, lo, hi)| {
                    PathElement::new(vec![(x, lo), (x, hi)], c.stroke_width(2))
                }),
            )
            .map_err(e)?;
        // A marker shape per line, larger for a line of one point, so none hides another.
        let size = if pts.len() == 1 { 7 } else { 4 };
        let xy = pts.iter().map(|p| (p.0, p.1));
        match i % 3 {
            0 => chart
                .draw_series(xy.map(|p| Circle::new(p, size, c.filled())))
                .map(|_| ()),
            1 => chart
                .draw_series(xy.map(|p| TriangleMarker::new(p, size + 2, c.filled())))
                .map(|_| ()),
            _ => chart
                .draw_series(xy.map(|p| Cross::new(p, size + 1, c.stroke_width(3))))
                .map(|_| ()),
        }
        .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(e)?;
    Ok(())
}

fn two_charts<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    titles: (&str, &str),
    x_desc: &str,
    top: (&str, &Series),
    bottom: (&str, &Series),
    bottom_refs: &[(f64, &str)],
    bottom_log_y: bool,
) -> R {
    let (upper, lower) = root.split_vertically(root.dim_in_pixel().1 as i32 / 2);
    line_chart(
        &upper,
        titles.0,
        x_desc,
        top.0,
        top.1,
        (true, false, false),
        &[],
    )?;
    line_chart(
        &lower,
        titles.1,
        x_desc,
        bottom.0,
        bottom.1,
        (true, false, bottom_log_y),
        bottom_refs,
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
        RGBColor(90, 140, 200),
        RGBColor(230, 150, 60),
        RGBColor(200, 200, 200),
        RGBColor(200, 70, 70),
    ];
    let top = bars
        .iter()
        .map(|(_, v)| v.iter().sum::<f64>())
        .fold(serial_s, f64::max)
        * 1.25;
    let n = bars.len();
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (0..(n as i32 - 1).max(0)).into_segmented(),
            0.0..top.max(1e-9),
        )
        .map_err(e)?;
    let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    let fmt = |v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(i) => names.get(*i as usize).cloned().unwrap_or_default(),
        _ => String::new(),
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc("scheduler (its fastest configuration, named in the caption)")
        .y_desc("Σ over workers of wall-clock spans (s)")
        .x_label_formatter(&fmt)
        .x_labels(n + 1)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(e)?;
    for (p, (&name, &c)) in parts.iter().zip(cols.iter()).enumerate() {
        let rects = bars.iter().enumerate().map(move |(i, (_, v))| {
            let y0: f64 = v[..p].iter().sum();
            let mut r = Rectangle::new(
                [
                    (SegmentValue::Exact(i as i32), y0),
                    (SegmentValue::Exact(i as i32 + 1), y0 + v[p]),
                ],
                c.filled(),
            );
            r.set_margin(0, 0, 12, 12);
            r
        });
        chart
            .draw_series(rects)
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
    }
    chart
        .draw_series(LineSeries::new(
            vec![
                (SegmentValue::Exact(0), serial_s),
                (SegmentValue::Exact(n as i32), serial_s),
            ],
            BLACK.stroke_width(2),
        ))
        .map_err(e)?
        .label("serial time (no overhead)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(e)?;
    Ok(())
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
    let lanes = lane_list.len().max(1) as u32;
    let lane = |w: u32| lane_list.iter().position(|l| l.0 == w).unwrap_or(0) as f64;
    let end_ms = spans.iter().map(|s| s.3).max().unwrap_or(1) as f64 / 1e6;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        // One empty lane of head room at the top for the legend.
        .build_cartesian_2d(0.0..end_ms * 1.02, -0.5..lanes as f64 + 0.5)
        .map_err(e)?;
    let fmt_y = |v: &f64| {
        if (v - v.round()).abs() > 1e-6 || *v < 0.0 {
            String::new()
        } else {
            lane_list
                .get(v.round() as usize)
                .map_or(String::new(), |l| l.1.clone())
        }
    };
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc("time since the run started (ms)")
        .y_desc("lane")
        .y_labels((lanes as usize + 1) * 2 + 1)
        .y_label_formatter(&fmt_y)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(e)?;
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
            .map_err(e)?
            .label(format!("item {}–{} ms", tidy(edge(k)), tidy(edge(k + 1))))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 13))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(e)?;
    Ok(())
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
    both!(
        out.bitmap,
        stem,
        SIZE,
        line_chart(
            &title,
            "worker threads",
            "speedup (t_serial / t)",
            &data,
            (false, true, false),
            &[(1.0, "speedup 1 (serial)")]
        )
    );
    out.push(&stem, title, "Speedup (median serial / median wall, paired by round) of each scheduler's best configuration per worker count, with its 95 % interval; the black diagonal is ideal linear speedup, the grey line speedup 1 (as fast as serial).");
    Ok(())
}

fn granularity(out: &mut Drawn, gr: &Group) -> R {
    let chunks: std::collections::BTreeSet<u64> =
        gr.at_max.iter().filter_map(|s| s.row.chunk_px).collect();
    if chunks.len() <= 1 {
        return Ok(());
    }
    let (g, max_w) = (gr.name, gr.max_w);
    let wall = series(&gr.at_max, kind, log2_chunk, wall_ci, lower);
    let speed = series(&gr.at_max, kind, log2_chunk, speed_ci, higher);
    let ideal_label = format!("ideal (speedup {max_w})");
    let stem = out.plots.join(format!("granularity_{}", gr.slug));
    let title = format!("Granularity, {max_w} workers — {g}");
    both!(
        out.bitmap,
        stem,
        (900, 820),
        two_charts(
            (
                &format!("Wall time vs chunk size, {max_w} workers — {g}"),
                "Speedup vs chunk size"
            ),
            "pixels per work item (log₂ scale)",
            ("median wall time (s)", &wall),
            ("speedup (t_serial / t)", &speed),
            &[(1.0, "speedup 1 (serial)"), (max_w as f64, &ideal_label)],
            false
        )
    );
    out.push(&stem, title, "Left end = per-ray items (1 pixel), right end = the whole image as one item. Dispatch cost dominates on the left, load imbalance on the right; the best granularity is the valley of the wall-time curve. Bars: 95 % intervals of the median (top) and of the paired speedup (bottom).");
    Ok(())
}

/// One panel per scheduler with predictions: measured median wall (with its interval) and the
/// cost model's prediction against chunk size.
fn prediction_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    g: &str,
    panels: &[(String, Series)],
) -> R {
    let cols = panels.len().clamp(1, 3);
    let rows = panels.len().div_ceil(cols);
    let areas = root.split_evenly((rows, cols));
    for ((name, data), area) in panels.iter().zip(areas.iter()) {
        line_chart(
            area,
            &format!("{name} — {g}"),
            "pixels per item (log₂)",
            "wall time (s)",
            data,
            (true, false, false),
            &[],
        )?;
    }
    Ok(())
}

fn predicted_vs_measured(out: &mut Drawn, gr: &Group) -> R {
    let with: Vec<&Summary> = gr
        .at_max
        .iter()
        .copied()
        .filter(|s| s.row.predicted_wall_s.is_some())
        .collect();
    let mut kinds: Vec<String> = Vec::new();
    for s in &with {
        if !kinds.contains(&s.row.scheduler) {
            kinds.push(s.row.scheduler.clone());
        }
    }
    if kinds.is_empty() {
        return Ok(());
    }
    let panels: Vec<(String, Series)> = kinds
        .iter()
        .map(|k| {
            let of: Vec<&Summary> = with
                .iter()
                .copied()
                .filter(|s| &s.row.scheduler == k)
                .collect();
            let mut data = series(&of, |_| Some("measured".into()), log2_chunk, wall_ci, lower);
            data.extend(series(
                &of,
                |_| Some("predicted".into()),
                log2_chunk,
                |s| point(s.row.predicted_wall_s.unwrap_or(f64::NAN)),
                lower,
            ));
            (k.clone(), data)
        })
        .collect();
    let cols = panels.len().clamp(1, 3) as u32;
    let rows = panels.len().div_ceil(3) as u32;
    let stem = out.plots.join(format!("predicted_{}", gr.slug));
    let title = format!(
        "Predicted vs measured wall time, {} workers — {}",
        gr.max_w, gr.name
    );
    both!(
        out.bitmap,
        stem,
        (520 * cols, 420 * rows),
        prediction_panels(gr.name, &panels)
    );
    out.push(&stem, title, "One panel per scheduler: the measured median wall time (with its 95 % interval) and the cost model's prediction made before the first round, against pixels per item; where a scheduler has several configurations at one chunk, the fastest of each.");
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
        |s| s.row.buffer().map(|b| (b as f64).log2()),
        speed_ci,
        higher,
    );
    let stem = out.plots.join(format!("buffer_{}", gr.slug));
    let title = format!(
        "Master: speedup vs buffer size, {} workers — {}",
        gr.max_w, gr.name
    );
    both!(
        out.bitmap,
        stem,
        SIZE,
        line_chart(
            &title,
            "items outstanding per worker, B (log₂ scale)",
            "speedup (t_serial / t)",
            &data,
            (true, false, false),
            &[(1.0, "speedup 1 (serial)")]
        )
    );
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
    let rays = series(
        &rows,
        mpi_line,
        log2_chunk,
        |s| point(throughput(s).0),
        higher,
    );
    let items = series(
        &rows,
        mpi_line,
        log2_chunk,
        |s| point(throughput(s).1),
        higher,
    );
    let stem = plots.join(format!("mpi_throughput_{gs}"));
    let title = format!("MPI ranks vs local threads — {g}");
    both!(
        bitmap,
        stem,
        (900, 820),
        two_charts(
            (
                &format!("Throughput vs chunk size — {g}"),
                "Items handed out per second vs chunk size"
            ),
            "pixels per work item (log₂ scale)",
            ("Mrays/s (median run)", &rays),
            ("items/s (median run, log scale)", &items),
            &[],
            true
        )
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
