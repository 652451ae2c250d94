//! One cell's verdict: `auto` against the best fixed configuration in hindsight.

use super::config::{auto_config, Config};
use super::corpus::Cell;
use super::play::play;

/// One cell's verdict.
#[derive(Clone, Debug)]
pub struct Verdict {
    /// The cell's label.
    pub cell: String,
    /// The best fixed configuration and its wall.
    pub best: (Config, f64),
    /// `auto`'s wall.
    pub auto_s: f64,
    /// Every fixed configuration's wall, in [`fixed_grid`]'s order.
    pub fixed_s: Vec<f64>,
}

impl Verdict {
    /// auto / best.
    pub fn ratio(&self) -> f64 {
        self.auto_s / self.best.1
    }
}

/// Judge one cell over `grid`.
pub fn judge(cell: &Cell, grid: &[Config]) -> Verdict {
    let fixed_s: Vec<f64> = grid.iter().map(|&c| play(cell, c)).collect();
    let (i, &best) = fixed_s
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .expect("a grid");
    Verdict {
        cell: cell.label(),
        best: (grid[i], best),
        auto_s: play(cell, auto_config(&cell.link)),
        fixed_s,
    }
}

/// The median of `v` (the mean of the middle two for an even count).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => (s[n / 2 - 1] + s[n / 2]) / 2.0,
    }
}

/// `auto: worst ratio R over N cells (median M)`.
pub fn summary(verdicts: &[Verdict]) -> String {
    let r: Vec<f64> = verdicts.iter().map(Verdict::ratio).collect();
    let worst = r.iter().copied().fold(f64::NAN, f64::max);
    format!(
        "auto: worst ratio {worst:.4} over {} cells (median {:.4})",
        r.len(),
        median(&r)
    )
}
