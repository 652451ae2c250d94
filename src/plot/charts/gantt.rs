//! Gantt timelines: one lane per worker, a bar per work item.

use super::*;

/// One line of a timeline file (`source` is absent in files written before it).
#[derive(serde::Deserialize)]
pub(super) struct SpanLine {
    worker: u32,
    item: u32,
    start_ns: u64,
    end_ns: u64,
    #[serde(default)]
    source: String,
}

/// (worker, item, start_ns, end_ns) rows of a timeline file, and each worker's kind of
/// source where the file records it.
pub(super) fn read_timeline(path: &Path) -> Result<Timeline, String> {
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
pub(super) struct Timeline {
    pub(super) spans: Vec<(u32, u32, u64, u64)>,
    pub(super) kinds: Vec<(u32, String)>,
}

/// The Gantt chart's lanes, bottom to top: workers grouped by kind of source (threads, then
/// GPU, then MPI ranks, in `SourceKind::ALL` order; workers of no recorded kind first), by id
/// within a group, then the master. Each lane is (worker, label); also the lane index where
/// each group after the first starts.
pub(super) fn gantt_lanes(tl: &Timeline) -> (Vec<(u32, String)>, Vec<usize>) {
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

/// Colour = the item's duration, in five bins of a colour-blind-safe sequential scale
/// (viridis), log-spaced when durations spread over more than a decade.
const BINS: [RGBColor; 5] = [
    RGBColor(68, 1, 84),
    RGBColor(59, 82, 139),
    RGBColor(33, 145, 140),
    RGBColor(94, 201, 98),
    RGBColor(253, 231, 37),
];

/// A span's duration in ms (at least 1 ns: a pass too short for the clock still happened).
fn dur_ms(s: &(u32, u32, u64, u64)) -> f64 {
    s.3.saturating_sub(s.2).max(1) as f64 / 1e6
}

/// The durations' colour scale, one per experiment: every Gantt chart bins alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DurScale {
    /// Shortest and longest item, ms.
    pub min: f64,
    pub max: f64,
}

impl DurScale {
    /// Over the spans of `tls`; `None` without a span.
    pub(super) fn of<'a>(tls: impl IntoIterator<Item = &'a Timeline>) -> Option<Self> {
        let (min, max) = tls
            .into_iter()
            .flat_map(|t| t.spans.iter().map(dur_ms))
            .fold((f64::INFINITY, 0.0f64), |(a, b), d| (a.min(d), b.max(d)));
        min.is_finite().then_some(Self { min, max })
    }
    fn log(&self) -> bool {
        self.max > 10.0 * self.min
    }
    fn t(&self, d: f64) -> f64 {
        if self.log() {
            d.ln()
        } else {
            d
        }
    }
    fn bin(&self, d: f64) -> usize {
        let span = self.t(self.max) - self.t(self.min);
        if span.is_nan() || span <= 0.0 {
            return 0;
        }
        (((self.t(d) - self.t(self.min)) / span * 5.0).max(0.0) as usize).min(4)
    }
    fn edge(&self, k: usize) -> f64 {
        let v = self.t(self.min) + (self.t(self.max) - self.t(self.min)) * k as f64 / 5.0;
        if self.log() {
            v.exp()
        } else {
            v
        }
    }
}

/// One lane's spans (start, end ns, colour bin) drawn on `cols` pixel columns over
/// `0..end_ns`: runs of columns (first, last, bin, shade) where shade ∈ 1..=4 is the share of
/// the column the spans cover, rounded up to quarters (in full where `any`), and bin the one
/// covering most of it; a column no span touches has no run. A per-ray run's 65 536 sub-pixel
/// bars become a few hundred rectangles (an SVG of kB, not MB), and a worker busy 5 % of the
/// time (a per-ray master's, waiting on its hand-outs) shows as a light shade where it ran and
/// white only where it ran nothing.
pub(super) fn downsample(
    spans: &[(u64, u64, usize)],
    end_ns: u64,
    cols: usize,
    any: bool,
) -> Vec<(usize, usize, usize, u8)> {
    let cols = cols.max(1);
    let w = end_ns.max(1) as f64 / cols as f64;
    let mut cover = vec![[0.0f64; 5]; cols];
    for &(s, t, b) in spans {
        let (s, t) = (s as f64, (t.max(s + 1)) as f64);
        let (c0, c1) = ((s / w) as usize, ((t / w) as usize).min(cols - 1));
        for (c, cell) in cover.iter_mut().enumerate().take(c1 + 1).skip(c0) {
            let (a, z) = (c as f64 * w, (c + 1) as f64 * w);
            cell[b] += (t.min(z) - s.max(a)).max(0.0);
        }
    }
    let mut runs: Vec<(usize, usize, usize, u8)> = Vec::new();
    for (c, cell) in cover.iter().enumerate() {
        let total: f64 = cell.iter().sum();
        let shade = if any && total > 0.0 {
            4
        } else {
            (4.0 * (total / w).min(1.0)).ceil() as u8
        };
        if shade == 0 {
            continue;
        }
        let b = (0..5)
            .max_by(|&x, &y| cell[x].total_cmp(&cell[y]))
            .unwrap_or(0);
        match runs.last_mut() {
            Some(r) if r.1 + 1 == c && r.2 == b && r.3 == shade => r.1 = c,
            _ => runs.push((c, c, b, shade)),
        }
    }
    runs
}

/// The lane labels, every k-th where 64 workers' labels would not fit one per lane; the
/// master's (the top one) always.
fn lane_labels<DB: DrawingBackend>(
    labels_area: &DrawingArea<DB, Shift>,
    chart: &axes::Chart<DB>,
    lane_list: &[(u32, String)],
) -> R {
    let row_h = (chart.backend_coord(&(0.0, 0.0)).1 - chart.backend_coord(&(0.0, 1.0)).1).abs();
    let need = axes::text_size("Ag", axes::TICK_FONT).1 + 2;
    let every = ((need + row_h - 1) / row_h.max(1)).max(1) as usize;
    let base = labels_area.get_base_pixel();
    let lw = labels_area.dim_in_pixel().0 as i32;
    let font = ("sans-serif", axes::TICK_FONT)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Right, VPos::Center));
    let n = lane_list.len();
    let mut shown: Vec<usize> = (0..n).step_by(every).collect();
    if lane_list.last().is_some_and(|l| l.0 == MASTER_LANE) && shown.last() != Some(&(n - 1)) {
        if shown.last().is_some_and(|&l| n - 1 - l < every) {
            shown.pop();
        }
        shown.push(n - 1);
    }
    for i in shown {
        let y = chart.backend_coord(&(0.0, i as f64)).1 - base.1;
        labels_area
            .draw(&Text::new(
                axes::fit_text(&lane_list[i].1, axes::TICK_FONT, lw - 8),
                (lw - 4, y),
                font.clone(),
            ))
            .map_err(axes::e)?;
    }
    Ok(())
}

/// A Gantt chart of `tl` coloured on the experiment's scale `ds` (`None`: its own).
pub(super) fn gantt_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    tl: &Timeline,
    ds: Option<DurScale>,
) -> R {
    let spans = &tl.spans[..];
    let ds = ds
        .or_else(|| DurScale::of([tl]))
        .unwrap_or(DurScale { min: 1.0, max: 1.0 });
    let (lane_list, group_starts) = gantt_lanes(tl);
    let lanes = lane_list.len().max(1);
    let end_ns = spans.iter().map(|s| s.3).max().unwrap_or(1).max(1);
    let end_ms = end_ns as f64 / 1e6;
    let used: Vec<usize> = (0..5)
        .filter(|k| spans.iter().any(|s| ds.bin(dur_ms(s)) == *k))
        .collect();
    let keys: Vec<(String, Key)> = used
        .iter()
        .map(|&k| {
            let range = format!("{}–{}", axes::tidy(ds.edge(k)), axes::tidy(ds.edge(k + 1)));
            (format!("item {range} ms"), Key::Box(BINS[k]))
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
    lane_labels(&labels_area, &chart, &lane_list)?;
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
    // As many columns as the plot has pixels across the run's span.
    let px = chart.plotting_area().dim_in_pixel().0 as f64 / 1.02;
    let cols = px.max(1.0) as usize;
    let col_ms = end_ms / cols as f64;
    for (i, (w, _)) in lane_list.iter().enumerate() {
        let mine: Vec<(u64, u64, usize)> = spans
            .iter()
            .filter(|s| s.0 == *w)
            .map(|s| (s.2, s.3, ds.bin(dur_ms(s))))
            .collect();
        let runs = downsample(&mine, end_ns, cols, *w == MASTER_LANE);
        let y = i as f64;
        chart
            .draw_series(runs.into_iter().map(|(a, z, b, shade)| {
                Rectangle::new(
                    [
                        (a as f64 * col_ms, y - 0.38),
                        ((z + 1) as f64 * col_ms, y + 0.38),
                    ],
                    BINS[b].mix(f64::from(shade) / 4.0).filled(),
                )
            }))
            .map_err(e)?;
    }
    axes::legend(&legend_area, &keys)
}

/// The Gantt charts of a group: each kind's best run, the per-ray master if there is one, the
/// fastest run of every other set of sources; (file name part, configuration).
pub(super) fn gantt_picks<'a>(gr: &Group<'a>, best: &[&'a Summary]) -> Vec<(String, &'a Summary)> {
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
    picks
}

/// The colour scale of every Gantt chart of the experiment (see [`Drawn::durations`]).
pub(super) fn gantt_durations(dir: &Path, groups: &[Group]) -> Result<Option<DurScale>, String> {
    let mut tls = Vec::new();
    for gr in groups {
        let best = best_per_scheduler(&gr.at_max);
        for (_, s) in gantt_picks(gr, &best) {
            let tl = timeline_path(dir, &s.row.config);
            if tl.exists() {
                tls.push(read_timeline(&tl)?);
            }
        }
    }
    Ok(DurScale::of(&tls))
}

/// Gantt: each kind's best run, plus the per-ray master if there is one.
pub(super) fn gantt_charts(out: &mut Drawn, gr: &Group, best: &[&Summary]) -> R {
    for (name, s) in gantt_picks(gr, best) {
        let stem = out.plots.join(format!("gantt_{}_{name}", gr.slug));
        let title = format!("Timeline: {} ×{} — {}", s.row.label, s.row.workers, gr.name);
        let tl = timeline_path(out.dir, &s.row.config);
        if tl.exists() {
            let timeline = read_timeline(&tl)?;
            let ds = out.durations;
            both!(out.bitmap, stem, SIZE, gantt_chart(&title, &timeline, ds));
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
        out.push(&stem, title, "One lane per worker, grouped by kind of source (threads, GPU, MPI ranks; a line between groups) with the master's passes on its own lane on top; drawn at the chart's pixel width: a column's shade is the share of it that items cover, rounded up to quarters (any pass of the master in full; white: nothing ran), its colour the duration of the items covering most of it, on one scale for every timeline of the experiment (legend); white gaps are idle time.");
    }
    Ok(())
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
