//! How a line looks: every scheduler kind has its own colour, marker and dash, so two kinds
//! stay apart in print, in grey and with colour blindness.

use crate::sched::SchedulerKind;
use plotters::style::RGBColor;

/// Colour-blind-safe colours: Okabe–Ito without its yellow (too pale on white) and black (the
/// reference lines' colour), then two of Paul Tol's muted scheme.
pub const COLOURS: [RGBColor; 8] = [
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 114, 178),   // blue
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(51, 34, 136),   // Tol indigo
    RGBColor(153, 153, 51),  // Tol olive
];

/// A point's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Marker {
    /// Filled circle.
    Circle,
    /// Filled square.
    Square,
    /// Filled triangle, point up.
    TriangleUp,
    /// Filled diamond.
    Diamond,
    /// Diagonal cross (stroked).
    Cross,
}

/// A line's stroke pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dash {
    /// Unbroken.
    Solid,
    /// 8 px dashes.
    Dashed,
    /// 2 px dots.
    Dotted,
    /// 18 px dashes.
    Long,
    /// 2 px dots, far apart.
    Sparse,
}

/// Markers and dashes in the order styles cycle through them.
pub const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::Cross,
];
/// See [`MARKERS`].
pub const DASHES: [Dash; 5] = [
    Dash::Solid,
    Dash::Dashed,
    Dash::Dotted,
    Dash::Long,
    Dash::Sparse,
];

/// One line's look.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeriesStyle {
    /// Stroke and fill colour.
    pub colour: RGBColor,
    /// The shape at each point.
    pub marker: Marker,
    /// The line's pattern.
    pub dash: Dash,
}

/// The `i`-th style. Colours cycle by 8, markers and dashes by 5 (coprime to 8), so the first
/// 40 styles differ pairwise, and two of them that share a colour (i ≡ j mod 8) differ in
/// marker and dash too.
pub fn nth(i: usize) -> SeriesStyle {
    SeriesStyle {
        colour: COLOURS[i % COLOURS.len()],
        marker: MARKERS[i % MARKERS.len()],
        dash: DASHES[i % DASHES.len()],
    }
}

/// A scheduler kind's style, the same in every figure.
pub fn of_kind(kind: SchedulerKind) -> SeriesStyle {
    let i = SchedulerKind::ALL
        .iter()
        .position(|k| *k == kind)
        .unwrap_or(0);
    nth(i)
}

/// The style of a scheduler kind by id; `None` for `serial` and unknown ids.
pub fn of_id(id: &str) -> Option<SeriesStyle> {
    SchedulerKind::ALL
        .iter()
        .find(|k| k.id() == id)
        .map(|k| of_kind(*k))
}

/// Styles for lines named `names`: each by its scheduler kind (the first word of its name)
/// where every line is of a different kind, else by position, so no two lines look alike.
pub fn for_names<S: AsRef<str>>(names: &[S]) -> Vec<SeriesStyle> {
    let kinds: Vec<Option<SeriesStyle>> = names
        .iter()
        .map(|n| of_id(n.as_ref().split_whitespace().next().unwrap_or("")))
        .collect();
    let distinct = kinds
        .iter()
        .enumerate()
        .all(|(i, a)| a.is_some() && kinds[..i].iter().all(|b| b != a));
    if distinct {
        kinds.into_iter().flatten().collect()
    } else {
        (0..names.len()).map(nth).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scheduler_kind_differs_in_colour_marker_and_dash_triple() {
        let all: Vec<SeriesStyle> = SchedulerKind::ALL.iter().map(|k| of_kind(*k)).collect();
        assert_eq!(all.len(), SchedulerKind::ALL.len());
        for (i, a) in all.iter().enumerate() {
            for (j, b) in all.iter().enumerate().skip(i + 1) {
                let (ka, kb) = (SchedulerKind::ALL[i].id(), SchedulerKind::ALL[j].id());
                assert_ne!(a, b, "{ka} and {kb} look the same");
                if a.colour == b.colour {
                    assert!(
                        a.marker != b.marker && a.dash != b.dash,
                        "{ka} and {kb} share a colour and a marker or dash"
                    );
                }
            }
        }
    }

    #[test]
    fn lines_of_one_kind_fall_back_to_distinct_styles_by_position() {
        let by_kind = for_names(&["master", "static"]);
        assert_eq!(by_kind[0], of_kind(SchedulerKind::Master));
        let same = for_names(&["master chunk=1", "master chunk=4", "serial"]);
        assert_eq!(same, vec![nth(0), nth(1), nth(2)]);
        assert!(same
            .iter()
            .enumerate()
            .all(|(i, a)| same[..i].iter().all(|b| b != a)));
    }
}
