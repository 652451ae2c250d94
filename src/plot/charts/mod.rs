//! The figures: speedup vs workers, granularity (wall and speedup vs chunk size), buffer size,
//! overhead breakdown and Gantt timelines.

use super::axes::{self, AxisSpec, Key, Scale};
use super::style::{self, Dash};
use crate::core::metrics::MASTER_LANE;
use crate::studies::experiment::results::timeline_path;
use crate::studies::experiment::summary::Summary;
use crate::util::text::slug;
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

/// Speedup (paired ratio of medians) with its interval: [`Summary::speedup_ci`], the one the
/// report's tables state.
fn speed_ci(s: &Summary) -> (f64, f64, f64) {
    let r = s.speedup_ci();
    (r.value, r.lo, r.hi)
}

/// Where `name` (a scheduler id, or a line named after one: "master · MPI …") comes in the
/// registry, [`crate::sched::SchedulerKind::ALL`]; names of no kind after every kind. Every
/// legend, bar list and table lists schedulers in this order.
pub(crate) fn registry_rank(name: &str) -> usize {
    let id = name.split([' ', '·']).next().unwrap_or(name);
    crate::sched::SchedulerKind::ALL
        .iter()
        .position(|k| k.id() == id)
        .unwrap_or(usize::MAX)
}

mod figures;
mod gantt;
#[cfg(test)]
mod layout_tests;
mod lines;
mod mpi;
mod overhead;
mod scatter;

use figures::*;
use gantt::*;
pub(crate) use lines::*;
use mpi::*;
use overhead::*;
pub(crate) use scatter::*;

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
    let names = group_names(sums);
    let groups: Vec<Group> = names.iter().filter_map(|g| Group::of(g, sums)).collect();
    let mut out = Drawn {
        dir,
        plots,
        final_plots,
        bitmap,
        figs: Vec::new(),
        missing: MissingTimelines::default(),
        wall_scale: wall_scale(&groups),
        durations: gantt_durations(dir, &groups)?,
    };
    for g in &group_names(sums) {
        if let Some(f) = mpi_throughput(dir, plots, final_plots, bitmap, g, &slug(g), sums)? {
            out.figs.push(f);
        }
        // The figures below compare thread schedulers; MPI rows have their own figure.
        let Some(group) = groups.iter().find(|gr| gr.name == g.as_str()) else {
            continue;
        };
        speedup_vs_workers(&mut out, group)?;
        granularity(&mut out, group)?;
        predicted_vs_measured(&mut out, group)?;
        buffer_sizes(&mut out, group)?;
        let best = best_per_scheduler(&group.at_max);
        overhead(&mut out, group, &best)?;
        gantt_charts(&mut out, group, &best)?;
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
    /// The wall-time axis of every granularity chart of the experiment: log₁₀ where any
    /// scene's times span more than 5×, so two scenes' charts read alike.
    wall_scale: Scale,
    /// The shortest and longest item of every Gantt chart of the experiment: one colour scale
    /// for them all (`None`: no timeline).
    durations: Option<DurScale>,
}

/// The experiment's wall-time scale (see [`Drawn::wall_scale`]).
fn wall_scale(groups: &[Group]) -> Scale {
    let per_group = groups.iter().map(|gr| {
        axes::auto_scale(
            gr.at_max
                .iter()
                .flat_map(|s| [s.wall_median, s.wall_median_ci.0, s.wall_median_ci.1]),
        )
    });
    if per_group.into_iter().any(|s| s == Scale::Log10) {
        Scale::Log10
    } else {
        Scale::Linear
    }
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
    /// The group's serial baseline, where it ran: the overhead chart's reference.
    serial: Option<&'a Summary>,
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
            serial: sums.iter().find(|s| s.group() == name && s.row.is_serial()),
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
