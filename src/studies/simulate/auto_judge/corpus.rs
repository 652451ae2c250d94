//! The corpus: per-pixel cost maps (synthetic or measured) and the cells that pair a map with
//! a fleet and a link.

use super::config::{Fleet, Link, LINKS};
use std::fmt::Write as _;

/// Per-pixel costs of one image, scanline order, relative (mean 1).
#[derive(Clone, Debug, PartialEq)]
pub struct CostMap {
    /// What it is (a scene and its size, or a synthetic shape).
    pub name: String,
    /// Width = height, a power of two (the stratified order needs a square).
    pub side: u32,
    /// Cost of each pixel, mean 1.
    pub cost: Vec<f64>,
}

/// A deterministic uniform in [0, 1) from a pixel index (splitmix64).
fn hash01(i: u64, salt: u64) -> f64 {
    let mut z = i
        .wrapping_add(salt.wrapping_mul(0x9e37_79b9_7f4a_7c15))
        .wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The synthetic shapes of the corpus.
pub const SYNTHETIC: [&str; 7] = [
    "uniform",
    "hot_x10",
    "hot_x1000",
    "gradient",
    "bimodal",
    "heavy_tailed",
    "hot_corner_x1000",
];

impl CostMap {
    /// Costs scaled to mean 1.
    pub fn normalised(name: String, side: u32, mut cost: Vec<f64>) -> Self {
        let mean = cost.iter().sum::<f64>() / cost.len().max(1) as f64;
        if mean > 0.0 {
            for c in &mut cost {
                *c /= mean;
            }
        }
        Self { name, side, cost }
    }

    /// A synthetic map (one of [`SYNTHETIC`]) of `side`² pixels.
    pub fn synthetic(shape: &str, side: u32) -> Option<Self> {
        let s = f64::from(side);
        let px = |f: &dyn Fn(f64, f64, u64) -> f64| -> Vec<f64> {
            (0..side * side)
                .map(|i| {
                    let (x, y) = (f64::from(i % side) + 0.5, f64::from(i / side) + 0.5);
                    f(x / s, y / s, u64::from(i))
                })
                .collect()
        };
        // A disc of radius 1/8 of the side at (1/3, 1/3): about 5 % of the pixels.
        let disc = |x: f64, y: f64| (x - 1.0 / 3.0).powi(2) + (y - 1.0 / 3.0).powi(2) < 1.0 / 64.0;
        let cost = match shape {
            "uniform" => vec![1.0; (side * side) as usize],
            "hot_x10" => px(&|x, y, _| if disc(x, y) { 10.0 } else { 1.0 }),
            "hot_x1000" => px(&|x, y, _| if disc(x, y) { 1000.0 } else { 1.0 }),
            // One corner block of 1/16 of the side (1/256 of the pixels) at ×1000: the last
            // items of a scanline order.
            "hot_corner_x1000" => px(&|x, y, _| {
                if x > 15.0 / 16.0 && y > 15.0 / 16.0 {
                    1000.0
                } else {
                    1.0
                }
            }),
            "gradient" => px(&|_, y, _| 1.0 + 9.0 * y),
            "bimodal" => px(&|_, _, i| if hash01(i, 1) < 0.5 { 1.0 } else { 10.0 }),
            // Pareto, α = 1.5 (finite mean, infinite variance), capped at 10⁴.
            "heavy_tailed" => px(&|_, _, i| (1.0 - hash01(i, 2)).powf(-1.0 / 1.5).min(1e4)),
            _ => return None,
        };
        Some(Self::normalised(format!("{shape}_{side}"), side, cost))
    }

    /// Read a map written by [`Self::to_text`]: a `side` line, then one cost per line.
    pub fn from_text(name: &str, text: &str) -> Result<Self, MapError> {
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        let side: u32 = lines
            .next()
            .and_then(|l| l.trim().strip_prefix("side "))
            .and_then(|v| v.trim().parse().ok())
            .ok_or_else(|| MapError::NoSide(name.to_string()))?;
        let cost: Vec<f64> = lines
            .map(|l| {
                l.trim().parse::<f64>().map_err(|err| MapError::Cost {
                    name: name.to_string(),
                    err,
                })
            })
            .collect::<Result<_, _>>()?;
        if !side.is_power_of_two() || cost.len() != (side * side) as usize {
            return Err(MapError::Size {
                name: name.to_string(),
                count: cost.len(),
                side,
            });
        }
        Ok(Self::normalised(name.to_string(), side, cost))
    }

    /// The map as text: `side N`, then one relative cost per line (4 significant digits).
    pub fn to_text(&self) -> String {
        let mut s = format!("side {}\n", self.side);
        for c in &self.cost {
            let _ = writeln!(s, "{c:.4e}");
        }
        s
    }
}

/// A cost map's text that does not read ([`CostMap::from_text`]).
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The first line is not `side N`.
    #[error("{0}: first line must be `side N`")]
    NoSide(String),
    /// A cost is not a number.
    #[error("{name}: {err}")]
    Cost {
        /// The map's name.
        name: String,
        /// Why the number did not parse.
        err: std::num::ParseFloatError,
    },
    /// The side is no power of two, or the costs are not side² many.
    #[error("{name}: {count} costs for side {side} (a power of two, side² costs)")]
    Size {
        /// The map's name.
        name: String,
        /// The costs read.
        count: usize,
        /// The side read.
        side: u32,
    },
}

/// One cell of the corpus.
#[derive(Clone, Debug)]
pub struct Cell<'a> {
    /// The costs.
    pub map: &'a CostMap,
    /// The workers.
    pub fleet: Fleet,
    /// Workers (17 for [`Fleet::ThreadsGpu`]).
    pub p: usize,
    /// The hand-out cost.
    pub link: Link,
    /// Seconds of one unit of cost on a full-speed thread (the map's mean pixel).
    pub unit_s: f64,
}

impl Cell<'_> {
    /// `map fleet P link`.
    pub fn label(&self) -> String {
        format!(
            "{} {} P={} {}",
            self.map.name,
            self.fleet.name(),
            self.p,
            self.link.name
        )
    }
}

/// The cells of the corpus over `maps`: each fleet at each of `ps` (the GPU fleet at its 17
/// workers), each link.
pub fn cells<'a>(maps: &'a [CostMap], ps: &[usize], unit_s: f64) -> Vec<Cell<'a>> {
    let mut out = Vec::new();
    for map in maps {
        for link in LINKS {
            for fleet in [Fleet::Equal, Fleet::OneSlow, Fleet::SlowsHalfway] {
                for &p in ps {
                    out.push(Cell {
                        map,
                        fleet,
                        p,
                        link,
                        unit_s,
                    });
                }
            }
            out.push(Cell {
                map,
                fleet: Fleet::ThreadsGpu,
                p: 17,
                link,
                unit_s,
            });
        }
    }
    out
}
