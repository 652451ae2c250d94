//! Axes, legends and titles laid out by hand from the font's metrics: plotters places tick
//! labels wherever its tick finder puts them, so long or many labels overlap. Here every label
//! is measured first and only as many are drawn as fit.

use super::style::{Dash, Marker, SeriesStyle};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::{DynElement, EmptyElement, IntoDynElement, PathElement, Polygon};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Tick label size (px).
pub const TICK_FONT: u32 = 14;
/// Axis description size (px).
pub const DESC_FONT: u32 = 16;
/// Legend text size (px).
pub const LEGEND_FONT: u32 = 13;
/// Title size (px) when it fits; smaller down to [`TITLE_MIN`] when not.
pub const TITLE_FONT: u32 = 20;
/// See [`TITLE_FONT`].
pub const TITLE_MIN: u32 = 13;
/// Space between the plot and the tick labels, and between neighbouring labels (px).
const GAP: i32 = 6;

pub(crate) fn e<T: std::fmt::Display>(err: T) -> String {
    err.to_string()
}

/// (width, height) of `text` in the bundled font at `size` px.
pub fn text_size(text: &str, size: u32) -> (i32, i32) {
    super::font::register_font();
    ("sans-serif", size).into_font().box_size(text).map_or(
        (
            text.chars().count() as i32 * size as i32 * 6 / 10,
            size as i32,
        ),
        |(w, h)| (w as i32, h as i32),
    )
}

/// `text`, shortened with "…" at its end until it is at most `max_w` px wide at `size`.
pub fn fit_text(text: &str, size: u32, max_w: i32) -> String {
    if text_size(text, size).0 <= max_w {
        return text.to_string();
    }
    let chars: Vec<char> = text.chars().collect();
    for n in (0..chars.len()).rev() {
        let t: String = chars[..n].iter().collect::<String>() + "…";
        if text_size(&t, size).0 <= max_w {
            return t;
        }
    }
    String::new()
}

/// A title that fits `max_w`: its size reduced down to [`TITLE_MIN`], then shortened.
pub fn fit_title(text: &str, max_w: i32) -> (String, u32) {
    for size in (TITLE_MIN..=TITLE_FONT).rev() {
        if text_size(text, size).0 <= max_w {
            return (text.to_string(), size);
        }
    }
    (fit_text(text, TITLE_MIN, max_w), TITLE_MIN)
}

/// Draw `title` centred at the top of `area`; returns the area below it.
pub fn titled<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<DrawingArea<DB, Shift>, String> {
    let w = area.dim_in_pixel().0 as i32;
    // A margin of 4 gaps each side: a title that fills the width reads as touching the edges.
    let (t, size) = fit_title(title, w - 8 * GAP);
    area.titled(&t, ("sans-serif", size)).map_err(e)
}

/// How an axis maps values: the chart's coordinates are already transformed (log₂ or log₁₀
/// of the value), the scale says how to label them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Values as they are.
    Linear,
    /// Values as they are, ticks at whole numbers only: worker counts, buffer sizes.
    Count,
    /// log₂ of the value; ticks at powers of two.
    Log2,
    /// log₁₀ of the value; ticks at 1, 2, 5 × 10ᵏ (or sparser).
    Log10,
}

impl Scale {
    /// The coordinate of value `v` (NaN where the scale cannot show it).
    pub fn to(self, v: f64) -> f64 {
        match self {
            Scale::Linear | Scale::Count => v,
            _ if v <= 0.0 => f64::NAN,
            Scale::Log2 => v.log2(),
            Scale::Log10 => v.log10(),
        }
    }
}

/// Log₁₀ where the positive values `vals` span more than 5×, else linear: a wall-time curve
/// from a 0.26 s per-ray master down to 10 ms keeps its valley visible.
pub fn auto_scale(vals: impl IntoIterator<Item = f64>) -> Scale {
    let (lo, hi) = vals
        .into_iter()
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() && hi / lo > 5.0 {
        Scale::Log10
    } else {
        Scale::Linear
    }
}

/// A tick label: "0.001", "12", "1.5k"-free plain numbers with at most 3 significant digits.
pub fn tidy(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    if v.abs() >= 1e6 || v.abs() < 1e-4 {
        let t = format!("{v:.1e}");
        return t.replace(".0e", "e");
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    let t = format!("{v:.digits$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// Candidate tick sets for the coordinate range `lo..hi`, densest first: (coordinate, label).
fn candidates(scale: Scale, lo: f64, hi: f64) -> Vec<Vec<(f64, String)>> {
    let mut out = Vec::new();
    match scale {
        Scale::Log2 => {
            let (a, b) = (lo.ceil() as i64, hi.floor() as i64);
            for stride in 1..=16i64 {
                let t: Vec<(f64, String)> = (a..=b)
                    .filter(|k| k.rem_euclid(stride) == 0)
                    .map(|k| (k as f64, tidy(2f64.powi(k as i32))))
                    .collect();
                out.push(t);
            }
        }
        Scale::Log10 => {
            let (a, b) = (lo.floor() as i64 - 1, hi.ceil() as i64 + 1);
            let sets: [&[f64]; 3] = [&[1.0, 2.0, 5.0], &[1.0, 3.0], &[1.0]];
            for m in sets {
                let mut t = Vec::new();
                for d in a..=b {
                    for &f in m {
                        let v = f * 10f64.powi(d as i32);
                        let c = v.log10();
                        if c >= lo - 1e-9 && c <= hi + 1e-9 {
                            t.push((c, tidy(v)));
                        }
                    }
                }
                out.push(t);
            }
            for stride in 2..=12i64 {
                let t = (a..=b)
                    .filter(|d| d.rem_euclid(stride) == 0)
                    .map(|d| (d as f64, tidy(10f64.powi(d as i32))))
                    .filter(|(c, _)| *c >= lo - 1e-9 && *c <= hi + 1e-9)
                    .collect();
                out.push(t);
            }
            // A narrow range holds fewer than two of those: plain steps in the value.
            if out.iter().all(|t| t.len() < 2) {
                let (vlo, vhi) = (10f64.powf(lo), 10f64.powf(hi));
                out = candidates(Scale::Linear, vlo, vhi)
                    .into_iter()
                    .map(|t| t.into_iter().map(|(v, s)| (v.log10(), s)).collect())
                    .collect();
            }
        }
        Scale::Count => {
            // Linear sets whose step is a whole number: no tick at 1.5 workers.
            out = candidates(Scale::Linear, lo, hi)
                .into_iter()
                .filter(|t| t.iter().all(|(v, _)| v.fract() == 0.0))
                .collect();
        }
        Scale::Linear => {
            let span = (hi - lo).abs().max(1e-300);
            let mut step = 10f64.powf((span / 40.0).log10().floor());
            let mut k = 0;
            while out.len() < 24 {
                let s = step * [1.0, 2.0, 2.5, 5.0][k % 4];
                let first = (lo / s).ceil() as i64;
                let last = (hi / s).floor() as i64;
                if last - first <= 200 {
                    out.push(
                        (first..=last)
                            .map(|i| {
                                let v = i as f64 * s;
                                // −0.0 and 1e-17 print as 0.
                                let v = if v.abs() < s * 1e-9 { 0.0 } else { v };
                                (v, tidy(v))
                            })
                            .collect(),
                    );
                }
                k += 1;
                if k % 4 == 0 {
                    step *= 10.0;
                }
            }
        }
    }
    // A set whose rounded labels repeat ("0.1", "0.1") says nothing more than a sparser one.
    out.retain(|t| t.windows(2).all(|w| w[0].1 != w[1].1));
    out
}

/// The densest candidate tick set whose labels, placed at `px(coordinate)`, leave [`GAP`] px
/// between neighbours along an axis `horizontal` or not; at least one label where any fits.
pub fn fit_ticks(
    scale: Scale,
    (lo, hi): (f64, f64),
    horizontal: bool,
    px: impl Fn(f64) -> i32,
) -> Vec<(f64, String)> {
    let extent = |s: &str| {
        let (w, h) = text_size(s, TICK_FONT);
        // Room to breathe: a label's width plus a gap across, two lines' height down.
        if horizontal {
            w + 2 * GAP
        } else {
            2 * h
        }
    };
    let fits = |t: &[(f64, String)]| {
        let mut placed: Vec<(i32, i32)> = t.iter().map(|(c, s)| (px(*c), extent(s))).collect();
        placed.sort_by_key(|p| p.0);
        placed
            .windows(2)
            .all(|w| (w[1].0 - w[0].0).abs() >= (w[0].1 + w[1].1) / 2 + GAP)
    };
    let cands = candidates(scale, lo, hi);
    if let Some(t) = cands.iter().find(|t| t.len() >= 2 && fits(t)) {
        return t.clone();
    }
    // Not two labels fit: the middle one of the densest set.
    cands
        .into_iter()
        .find(|t| !t.is_empty())
        .map(|t| vec![t[t.len() / 2].clone()])
        .unwrap_or_default()
}

/// A chart over transformed coordinates (see [`Scale`]).
pub type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// What an axis shows.
#[derive(Clone, Debug)]
pub struct AxisSpec {
    /// Its description, said once.
    pub desc: String,
    /// The coordinate range.
    pub range: (f64, f64),
    /// How coordinates are labelled.
    pub scale: Scale,
}

/// Width of the y label area: the widest label any candidate tick set could draw, the gap and
/// the rotated description.
fn y_area_width(y: &AxisSpec) -> i32 {
    let widest = candidates(y.scale, y.range.0, y.range.1)
        .iter()
        .flatten()
        .map(|(_, s)| text_size(s, TICK_FONT).0)
        .max()
        .unwrap_or(20);
    widest + 2 * GAP + text_size("Ag", DESC_FONT).1 + GAP
}

/// X label area height: a label row and the description below it.
const X_AREA: i32 = 48;
const MARGIN: i32 = 10;

/// Build a chart on `area` with hand-placed ticks on both axes, a frame, faint grid lines and
/// both descriptions.
pub fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    x: &AxisSpec,
    y: &AxisSpec,
) -> Result<Chart<'a, DB>, String> {
    chart_with(area, x, y, true)
}

/// [`chart`] without y ticks, grid lines or description (the caller labels the rows).
pub fn chart_without_y_ticks<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    x: &AxisSpec,
    y: &AxisSpec,
) -> Result<Chart<'a, DB>, String> {
    chart_with(area, x, y, false)
}

fn chart_with<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    x: &AxisSpec,
    y: &AxisSpec,
    y_ticks: bool,
) -> Result<Chart<'a, DB>, String> {
    let yw = if y_ticks { y_area_width(y) } else { 1 };
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN as u32)
        .x_label_area_size(X_AREA as u32)
        .y_label_area_size(yw as u32)
        .build_cartesian_2d(x.range.0..x.range.1, y.range.0..y.range.1)
        .map_err(e)?;
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let base = area.get_base_pixel();
    let to_area = |p: (i32, i32)| (p.0 - base.0, p.1 - base.1);
    let xt = fit_ticks(x.scale, x.range, true, |c| {
        chart.backend_coord(&(c, y.range.0)).0
    });
    let yt = if y_ticks {
        fit_ticks(y.scale, y.range, false, |c| {
            chart.backend_coord(&(x.range.0, c)).1
        })
    } else {
        vec![]
    };
    let grid = RGBColor(0, 0, 0).mix(0.12);
    for (c, _) in &xt {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(*c, y.range.0), (*c, y.range.1)],
                grid,
            )))
            .map_err(e)?;
    }
    for (c, _) in &yt {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x.range.0, *c), (x.range.1, *c)],
                grid,
            )))
            .map_err(e)?;
    }
    let font = |size: u32| ("sans-serif", size).into_font().color(&BLACK);
    for (c, s) in &xt {
        let p = to_area(chart.backend_coord(&(*c, y.range.0)));
        area.draw(&PathElement::new(vec![(p.0, p.1), (p.0, p.1 + 4)], BLACK))
            .map_err(e)?;
        let style = font(TICK_FONT).pos(Pos::new(HPos::Center, VPos::Top));
        area.draw(&Text::new(s.clone(), (p.0, p.1 + GAP), style))
            .map_err(e)?;
    }
    for (c, s) in &yt {
        let p = to_area(chart.backend_coord(&(x.range.0, *c)));
        area.draw(&PathElement::new(vec![(p.0 - 4, p.1), (p.0, p.1)], BLACK))
            .map_err(e)?;
        let style = font(TICK_FONT).pos(Pos::new(HPos::Right, VPos::Center));
        area.draw(&Text::new(s.clone(), (p.0 - GAP, p.1), style))
            .map_err(e)?;
    }
    let (l, r) = (xr.start - base.0, xr.end - base.0);
    let (t, b) = (yr.start - base.1, yr.end - base.1);
    area.draw(&PathElement::new(
        vec![(l, t), (r, t), (r, b), (l, b), (l, t)],
        BLACK,
    ))
    .map_err(e)?;
    let tick_h = text_size("0", TICK_FONT).1;
    let xd = fit_text(&x.desc, DESC_FONT, r - l);
    area.draw(&Text::new(
        xd,
        ((l + r) / 2, b + GAP + tick_h + GAP),
        font(DESC_FONT).pos(Pos::new(HPos::Center, VPos::Top)),
    ))
    .map_err(e)?;
    let yd = fit_text(&y.desc, DESC_FONT, b - t);
    if !y_ticks {
        return Ok(chart);
    }
    area.draw(&Text::new(
        yd,
        (l - yw + MARGIN.min(2), (t + b) / 2),
        font(DESC_FONT)
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Top)),
    ))
    .map_err(e)?;
    Ok(chart)
}

/// A marker of `style` at `at`, `size` px from its centre to its edge.
pub fn marker<'a, DB: DrawingBackend + 'a, C: Clone + 'a>(
    at: C,
    m: Marker,
    colour: RGBColor,
    size: i32,
) -> DynElement<'a, DB, C> {
    let fill = colour.filled();
    let s = size;
    match m {
        Marker::Circle => (EmptyElement::at(at) + Circle::new((0, 0), s, fill)).into_dyn(),
        Marker::Square => (EmptyElement::at(at)
            + Rectangle::new([(-s + 1, -s + 1), (s - 1, s - 1)], fill))
        .into_dyn(),
        Marker::TriangleUp => (EmptyElement::at(at)
            + Polygon::new(vec![(0, -s - 1), (s + 1, s - 1), (-s - 1, s - 1)], fill))
        .into_dyn(),
        Marker::Diamond => (EmptyElement::at(at)
            + Polygon::new(vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0)], fill))
        .into_dyn(),
        Marker::Cross => (EmptyElement::at(at)
            + PathElement::new(vec![(-s, -s), (s, s)], colour.stroke_width(3))
            + PathElement::new(vec![(-s, s), (s, -s)], colour.stroke_width(3)))
        .into_dyn(),
    }
}

/// The on/off lengths (px) of a dash pattern; `None` for a solid line.
fn pattern(d: Dash) -> Option<(i32, i32)> {
    match d {
        Dash::Solid => None,
        Dash::Dashed => Some((9, 5)),
        Dash::Dotted => Some((2, 4)),
        Dash::Long => Some((18, 6)),
        Dash::Sparse => Some((2, 10)),
    }
}

/// Split the polyline `pts` (pixels) into the visible pieces of `dash`.
pub fn dashed(pts: &[(i32, i32)], dash: Dash) -> Vec<Vec<(i32, i32)>> {
    let Some((on, off)) = pattern(dash) else {
        return vec![pts.to_vec()];
    };
    let mut out: Vec<Vec<(i32, i32)>> = Vec::new();
    let (mut phase, mut drawing) = (0.0f64, true);
    let mut cur: Vec<(i32, i32)> = pts.first().map(|p| vec![*p]).unwrap_or_default();
    for w in pts.windows(2) {
        let (a, b) = (
            (w[0].0 as f64, w[0].1 as f64),
            (w[1].0 as f64, w[1].1 as f64),
        );
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let mut t = 0.0;
        while t < len {
            let left = if drawing { on } else { off } as f64 - phase;
            let step = left.min(len - t);
            t += step;
            phase += step;
            let p = (
                (a.0 + (b.0 - a.0) * t / len.max(1e-9)).round() as i32,
                (a.1 + (b.1 - a.1) * t / len.max(1e-9)).round() as i32,
            );
            if drawing {
                cur.push(p);
            }
            if phase >= if drawing { on } else { off } as f64 - 1e-9 {
                if drawing {
                    out.push(std::mem::take(&mut cur));
                } else {
                    cur = vec![p];
                }
                drawing = !drawing;
                phase = 0.0;
            }
        }
    }
    if drawing && cur.len() > 1 {
        out.push(cur);
    }
    out
}

/// Draw the line through `pts` (chart coordinates) in `style`, `width` px wide, with a marker
/// at each point; a line of one point gets a larger marker.
pub fn draw_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    pts: &[(f64, f64)],
    style: SeriesStyle,
    width: u32,
) -> Result<(), String> {
    let px: Vec<(i32, i32)> = pts.iter().map(|p| chart.backend_coord(p)).collect();
    let area = chart.plotting_area().strip_coord_spec();
    let base = area.get_base_pixel();
    let rel: Vec<(i32, i32)> = px.iter().map(|p| (p.0 - base.0, p.1 - base.1)).collect();
    if rel.len() > 1 {
        for piece in dashed(&rel, style.dash) {
            area.draw(&PathElement::new(piece, style.colour.stroke_width(width)))
                .map_err(e)?;
        }
    }
    let size = if pts.len() == 1 { 6 } else { 4 };
    for p in rel {
        area.draw(&marker(p, style.marker, style.colour, size))
            .map_err(e)?;
    }
    Ok(())
}

/// What a legend row shows beside its text.
#[derive(Clone, Copy, Debug)]
pub enum Key {
    /// A line with its marker.
    Series(SeriesStyle),
    /// A reference line without markers.
    Line(RGBColor, Dash),
    /// A filled box (bars, bins).
    Box(RGBColor),
    /// A marker alone (scatter).
    Point(SeriesStyle),
}

/// Width of a legend holding `labels`, at most `max_w`.
pub fn legend_width(labels: &[String], max_w: i32) -> i32 {
    let widest = labels
        .iter()
        .map(|l| text_size(l, LEGEND_FONT).0)
        .max()
        .unwrap_or(0);
    (widest + 52).min(max_w)
}

/// Draw `entries` top-down in `area` (beside the chart, never over the data), each label
/// shortened to fit; rows that do not fit are summed up in a last "… N more" row.
pub fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Key)],
) -> Result<(), String> {
    if entries.is_empty() {
        return Ok(());
    }
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    let row = text_size("Ag", LEGEND_FONT).1 + 6;
    let top = MARGIN + 4;
    let fit_rows = ((h - top - MARGIN) / row).max(1) as usize;
    let (shown, more) = if entries.len() > fit_rows {
        (fit_rows - 1, entries.len() - (fit_rows - 1))
    } else {
        (entries.len(), 0)
    };
    let font = ("sans-serif", LEGEND_FONT)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let key_w = 32;
    for (k, (label, key)) in entries.iter().take(shown).enumerate() {
        let y = top + row * k as i32 + row / 2;
        let x = 4;
        match *key {
            Key::Series(s) | Key::Point(s) => {
                if matches!(key, Key::Series(_)) {
                    for piece in dashed(&[(x, y), (x + key_w - 4, y)], s.dash) {
                        area.draw(&PathElement::new(piece, s.colour.stroke_width(2)))
                            .map_err(e)?;
                    }
                }
                area.draw(&marker((x + (key_w - 4) / 2, y), s.marker, s.colour, 4))
                    .map_err(e)?;
            }
            Key::Line(c, d) => {
                for piece in dashed(&[(x, y), (x + key_w - 4, y)], d) {
                    area.draw(&PathElement::new(piece, c.stroke_width(1)))
                        .map_err(e)?;
                }
            }
            Key::Box(c) => {
                area.draw(&Rectangle::new(
                    [(x + 6, y - 5), (x + key_w - 10, y + 5)],
                    c.filled(),
                ))
                .map_err(e)?;
            }
        }
        let text = fit_text(label, LEGEND_FONT, w - key_w - 8);
        area.draw(&Text::new(text, (x + key_w + 2, y), font.clone()))
            .map_err(e)?;
    }
    if more > 0 {
        let y = top + row * shown as i32 + row / 2;
        area.draw(&Text::new(
            format!("… {more} more"),
            (4 + key_w + 2, y),
            font.clone(),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// Split `area` into the chart (left) and a legend column for `labels` (right, at most a
/// third of the width).
pub fn with_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    labels: &[String],
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let w = area.dim_in_pixel().0 as i32;
    let lw = legend_width(labels, w / 3);
    area.split_horizontally(w - lw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_thin_out_until_labels_fit() {
        // 17 powers of two over 200 px: 12.5 px apart, "65536" needs ~45.
        let t = fit_ticks(Scale::Log2, (0.0, 16.0), true, |c| (c * 12.5) as i32);
        assert!(t.len() >= 2 && t.len() < 17, "{t:?}");
        let px: Vec<i32> = t.iter().map(|(c, _)| (c * 12.5) as i32).collect();
        for (w, l) in px.windows(2).zip(t.windows(2)) {
            let need = (text_size(&l[0].1, TICK_FONT).0 + text_size(&l[1].1, TICK_FONT).0) / 2;
            assert!(w[1] - w[0] >= need, "{t:?}");
        }
        // Over 2000 px every power fits.
        assert_eq!(
            fit_ticks(Scale::Log2, (0.0, 16.0), true, |c| (c * 125.0) as i32).len(),
            17
        );
    }

    #[test]
    fn count_ticks_are_whole_numbers() {
        // 1 and 2 workers on a wide axis: linear ticks would say 1.2, 1.4 …
        let t = fit_ticks(Scale::Count, (0.5, 2.5), true, |c| (c * 400.0) as i32);
        let labels: Vec<&str> = t.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(labels, ["1", "2"]);
        let lin = fit_ticks(Scale::Linear, (0.5, 2.5), true, |c| (c * 400.0) as i32);
        assert!(lin.len() > 2, "{lin:?}");
    }

    #[test]
    fn log10_ticks_are_round_values() {
        let t = fit_ticks(Scale::Log10, (-2.0, 0.5), false, |c| (-c * 200.0) as i32);
        let labels: Vec<&str> = t.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(
            labels,
            ["0.01", "0.02", "0.05", "0.1", "0.2", "0.5", "1", "2"]
        );
        // Under 2× apart, plain steps.
        let t = fit_ticks(
            Scale::Log10,
            (0.1f64.log10(), 0.15f64.log10()),
            false,
            |c| (-c * 2000.0) as i32,
        );
        assert!(t.len() >= 2, "{t:?}");
    }

    #[test]
    fn auto_scale_goes_log_beyond_five_times() {
        assert_eq!(auto_scale([0.26, 0.01]), Scale::Log10);
        assert_eq!(auto_scale([0.1, 0.4]), Scale::Linear);
    }

    #[test]
    fn dashes_alternate() {
        let d = dashed(&[(0, 0), (100, 0)], Dash::Dashed);
        assert!(d.len() >= 6, "{d:?}");
        assert_eq!(d[0], vec![(0, 0), (9, 0)]);
        assert_eq!(dashed(&[(0, 0), (5, 5)], Dash::Solid).len(), 1);
    }

    #[test]
    fn long_titles_shrink_then_shorten() {
        let (t, size) = fit_title("short", 500);
        assert_eq!((t.as_str(), size), ("short", TITLE_FONT));
        let long = "x".repeat(300);
        let (t, size) = fit_title(&long, 500);
        assert_eq!(size, TITLE_MIN);
        assert!(t.ends_with('…') && text_size(&t, size).0 <= 500);
    }
}
