//! Line charts: series of the best configuration per x, their axes and reference lines.

use super::*;

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
            (Self::Pixels, _) => "pixels per work item (log₂)".into(),
        }
    }
}

/// `better` of [`series`] for speedup and throughput.
pub(super) fn higher(a: f64, b: f64) -> bool {
    a > b
}

/// `better` of [`series`] for wall time.
pub(super) fn lower(a: f64, b: f64) -> bool {
    a < b
}

pub(super) fn series(
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
    // Legends list schedulers in the registry's order, whatever order the rows came in.
    out.sort_by_key(|(name, _)| registry_rank(name));
    out
}

/// The (min, max) of `f` over every finite point, `None` without one.
pub(super) fn range_of(data: &Series, f: impl Fn(&Pt) -> f64) -> Option<(f64, f64)> {
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

/// A reference line's colour: the first (speedup 1) pale, so a series drawn on it, dotted
/// or dashed, stays visible over it; the others darker.
fn ref_colour(k: usize) -> RGBColor {
    if k == 0 {
        RGBColor(185, 185, 185)
    } else {
        RGBColor(80, 80, 80)
    }
}

/// The legend of a line chart: its series in order, then the ideal line and the references.
fn line_keys(c: &Lines, names: &[String], styles: &[style::SeriesStyle]) -> Vec<(String, Key)> {
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
        keys.push((name.to_string(), Key::Line(ref_colour(k), Dash::Dashed)));
    }
    keys
}

/// The y range of a line chart in coordinates: `c.y_range`, else from the data and references.
fn y_coords(c: &Lines, data: &Series) -> (f64, f64) {
    let (v0, v1) = c.y_range.unwrap_or_else(|| {
        let mut refs: Vec<(f64, &str)> = c.refs.to_vec();
        if c.ideal {
            refs.push((range_of(data, |p| p.0).map_or(1.0, |r| r.1), ""));
        }
        y_extent(data, c.y, &refs)
    });
    let (y0, y1) = (c.y.to(v0), c.y.to(v1));
    if y0.is_finite() && y1.is_finite() && y1 > y0 {
        (y0, y1)
    } else {
        (0.0, 1.0)
    }
}

/// The ideal diagonal and the dashed horizontal references, below the series.
fn draw_refs<DB: DrawingBackend>(
    chart: &mut axes::Chart<DB>,
    c: &Lines,
    data: &Series,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> R {
    let (tx, ty) = (|v: f64| c.x.to(v), |v: f64| c.y.to(v));
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
        if !(ty(y).is_finite() && ty(y) >= y0 && ty(y) <= y1) {
            continue;
        }
        let (a, b) = (
            chart.backend_coord(&(x0, ty(y))),
            chart.backend_coord(&(x1, ty(y))),
        );
        let pa = chart.plotting_area().strip_coord_spec();
        let base = pa.get_base_pixel();
        for piece in axes::dashed(
            &[(a.0 - base.0, a.1 - base.1), (b.0 - base.0, b.1 - base.1)],
            Dash::Dashed,
        ) {
            pa.draw(&PathElement::new(piece, ref_colour(k).stroke_width(1)))
                .map_err(e)?;
        }
    }
    Ok(())
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
    let (y0, y1) = y_coords(c, data);
    let pad = match sx {
        Scale::Linear | Scale::Count => ((x1 - x0) * 0.04).max(0.5),
        _ => ((x1 - x0) * 0.04).max(0.3),
    };
    let names: Vec<String> = data.iter().map(|d| d.0.clone()).collect();
    let styles = style::for_names(&names);
    let keys = line_keys(c, &names, &styles);
    let labels: Vec<String> = keys.iter().map(|k| k.0.clone()).collect();
    let body = axes::titled(area, c.title)?;
    let (plot, legend_area) = if c.legend_w > 0 {
        let w = body.dim_in_pixel().0 as i32;
        body.split_horizontally(w - c.legend_w.min(w / 3))
    } else {
        axes::with_legend(&body, &labels)
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
    draw_refs(&mut chart, c, data, (x0 - pad, x1 + pad), (y0, y1))?;
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
pub(super) fn two_charts<DB: DrawingBackend>(
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
