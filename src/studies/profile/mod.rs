//! Where the work is: the cost of every pixel and of every work item at a given granularity,
//! measured from the timeline of a per-pixel render on one worker (each one-pixel item's span
//! is that pixel's cost, one clock read per item included), and drawn as a heat map.
//!
//! Every choice of granularity depends on this distribution: hand-out cost matters against the
//! mean item cost, imbalance against its spread and its largest items.

use crate::core::render::WorkItem;
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::sched::{
    decompose, render_scene, Chunk, Order, RenderOn, RunOptions, SchedError, SchedulerKind,
    SchedulerSpec,
};
use std::sync::Arc;

/// Summary of a set of costs (seconds).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CostStats {
    /// How many costs.
    pub n: usize,
    /// Their mean μ.
    pub mean: f64,
    /// Their standard deviation σ (population).
    pub sd: f64,
    /// The largest.
    pub max: f64,
    /// Their sum.
    pub total: f64,
}

impl CostStats {
    /// The statistics of `costs`.
    pub fn of(costs: &[f64]) -> Self {
        let n = costs.len();
        if n == 0 {
            return Self::default();
        }
        let total: f64 = costs.iter().sum();
        let mean = total / n as f64;
        let var = costs.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / n as f64;
        Self {
            n,
            mean,
            sd: var.sqrt(),
            max: costs.iter().copied().fold(0.0, f64::max),
            total,
        }
    }

    /// Coefficient of variation σ/μ.
    pub fn cv(&self) -> f64 {
        if self.mean > 0.0 {
            self.sd / self.mean
        } else {
            0.0
        }
    }

    /// The largest cost over the mean.
    pub fn max_over_mean(&self) -> f64 {
        if self.mean > 0.0 {
            self.max / self.mean
        } else {
            0.0
        }
    }
}

/// Per-pixel costs of frame 0 of a scene.
#[derive(Clone, Debug)]
pub struct Profile {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Seconds per pixel, index y·width + x.
    pub pixel_s: Vec<f64>,
}

/// Why the heat map was not written: drawing or writing its file failed (one line, naming it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct HeatMapError(pub String);

impl Profile {
    /// [`Profile::measure`] `passes` times, keeping each pixel's cheapest pass: a pixel whose
    /// worker was preempted on a shared machine costs milliseconds in one pass, not in all.
    pub fn measure_min<T: Tracer + 'static>(
        scene: &Arc<Scene>,
        tracer: &Arc<T>,
        passes: u32,
    ) -> Result<Self, SchedError> {
        let mut best = Self::measure(scene, tracer)?;
        for _ in 1..passes {
            let p = Self::measure(scene, tracer)?;
            for (b, c) in best.pixel_s.iter_mut().zip(p.pixel_s) {
                *b = b.min(c);
            }
        }
        Ok(best)
    }

    /// Render frame 0 of `scene` pixel by pixel on one worker with a timeline and keep each
    /// pixel's span. Frames after the first are rendered too (the scene decides) but not kept.
    pub fn measure<T: Tracer + 'static>(
        scene: &Arc<Scene>,
        tracer: &Arc<T>,
    ) -> Result<Self, SchedError> {
        let (w, h) = (scene.width(), scene.height());
        let mut spec = SchedulerSpec::new(SchedulerKind::Static, Chunk::Tile { w: 1, h: 1 }, 1);
        spec.timeline = true;
        let (_, stats) = render_scene(
            &spec,
            scene,
            tracer,
            &RenderOn::threads(),
            &RunOptions::default(),
        )?;
        let mut pixel_s = vec![0.0; w as usize * h as usize];
        for s in stats.timeline.unwrap_or_default() {
            // Scanline one-pixel items: item id = pixel index within frame 0.
            if let Some(p) = pixel_s.get_mut(s.item as usize) {
                *p = s.end_ns.saturating_sub(s.start_ns) as f64 * 1e-9;
            }
        }
        Ok(Self {
            width: w,
            height: h,
            pixel_s,
        })
    }

    /// The pixels' cost statistics.
    pub fn pixels(&self) -> CostStats {
        CostStats::of(&self.pixel_s)
    }

    /// The cost of every item of `chunk` (in scanline order of items), summed over its pixels.
    pub fn item_costs(&self, chunk: Chunk) -> Vec<f64> {
        decompose(self.width, self.height, chunk, Order::Scanline)
            .iter()
            .map(|it: &WorkItem| {
                it.pixels(self.width)
                    .map(|p| self.pixel_s[p as usize])
                    .sum()
            })
            .collect()
    }

    /// The items' cost statistics at `chunk`.
    pub fn items(&self, chunk: Chunk) -> CostStats {
        CostStats::of(&self.item_costs(chunk))
    }

    /// The mean pixel cost of the costliest `fraction` of the pixels over the median pixel's:
    /// how much dearer a hot spot is than the rest.
    pub fn hot_over_median(&self, fraction: f64) -> f64 {
        let mut v = self.pixel_s.clone();
        v.sort_by(|a, b| b.total_cmp(a));
        let k = ((v.len() as f64 * fraction).ceil() as usize).clamp(1, v.len().max(1));
        let Some(&median) = v.get(v.len() / 2) else {
            return 0.0;
        };
        let hot = v[..k].iter().sum::<f64>() / k as f64;
        if median > 0.0 {
            hot / median
        } else {
            0.0
        }
    }

    /// The share of the total cost in the costliest `fraction` of the pixels.
    pub fn share_of_top(&self, fraction: f64) -> f64 {
        let mut v = self.pixel_s.clone();
        v.sort_by(|a, b| b.total_cmp(a));
        let k = ((v.len() as f64 * fraction).ceil() as usize).min(v.len());
        let total: f64 = v.iter().sum();
        if total > 0.0 {
            v[..k].iter().sum::<f64>() / total
        } else {
            0.0
        }
    }

    /// A heat map of cost per pixel, log scale from the cheapest (black) through red and
    /// yellow to the costliest (white): 8-bit RGB, row 0 at the top.
    pub fn heat_map(&self) -> image::RgbImage {
        let pos: Vec<f64> = self.pixel_s.iter().copied().filter(|c| *c > 0.0).collect();
        let lo = pos.iter().copied().fold(f64::INFINITY, f64::min).max(1e-12);
        let hi = pos.iter().copied().fold(0.0, f64::max).max(lo * 1.000_001);
        let (llo, lhi) = (lo.ln(), hi.ln());
        let mut img = image::RgbImage::new(self.width, self.height);
        for (i, c) in self.pixel_s.iter().enumerate() {
            let t = ((c.max(lo).ln() - llo) / (lhi - llo)).clamp(0.0, 1.0);
            let (x, y) = (i as u32 % self.width, i as u32 / self.width);
            img.put_pixel(x, y, image::Rgb(heat(t)));
        }
        img
    }
}

/// Width of the colour bar's column beside the heat map (px).
const BAR_AREA: u32 = 130;

impl Profile {
    /// The cheapest and costliest positive pixel cost, seconds (the heat map's ends).
    fn cost_range(&self) -> (f64, f64) {
        let pos = self.pixel_s.iter().copied().filter(|c| *c > 0.0);
        let lo = pos.clone().fold(f64::INFINITY, f64::min).max(1e-12);
        let hi = pos.fold(0.0, f64::max).max(lo * 1.000_001);
        (lo, hi)
    }

    /// [`Profile::heat_map`] with a colour bar on its right labelled in µs per pixel (log
    /// scale), enlarged by a whole factor when the image is under 240 px high, as a PNG.
    ///
    /// # Errors
    /// Drawing or writing `path` failed.
    pub fn save_heat_map(&self, path: &std::path::Path) -> Result<(), HeatMapError> {
        self.draw_heat_map(path).map_err(HeatMapError)
    }

    fn draw_heat_map(&self, path: &std::path::Path) -> Result<(), String> {
        use crate::plot::axes::{self, Scale};
        use plotters::prelude::*;
        use plotters::style::text_anchor::{HPos, Pos, VPos};
        crate::plot::font::register_font();
        let img = self.heat_map();
        let k = 240u32.div_ceil(self.height.max(1)).max(1);
        let (w, h) = (self.width * k, (self.height * k).max(240));
        let root = BitMapBackend::new(path, (w + BAR_AREA, h)).into_drawing_area();
        let e = |err: DrawingAreaErrorKind<_>| format!("{}: {err}", path.display());
        root.fill(&WHITE).map_err(e)?;
        for (x, y, p) in img.enumerate_pixels() {
            let c = RGBColor(p.0[0], p.0[1], p.0[2]);
            let (x0, y0) = ((x * k) as i32, (y * k) as i32);
            root.draw(&Rectangle::new(
                [(x0, y0), (x0 + k as i32, y0 + k as i32)],
                c.filled(),
            ))
            .map_err(e)?;
        }
        // The bar: 16 px wide, costliest at the top, 12 px from the image.
        let (top, bottom) = (16i32, h as i32 - 16);
        let bx = w as i32 + 12;
        for y in top..bottom {
            let t = (bottom - y) as f64 / (bottom - top) as f64;
            let [r, g, b] = heat(t);
            root.draw(&PathElement::new(
                vec![(bx, y), (bx + 16, y)],
                RGBColor(r, g, b),
            ))
            .map_err(e)?;
        }
        root.draw(&PathElement::new(
            vec![
                (bx, top),
                (bx + 16, top),
                (bx + 16, bottom),
                (bx, bottom),
                (bx, top),
            ],
            BLACK,
        ))
        .map_err(e)?;
        let (lo, hi) = self.cost_range();
        let (llo, lhi) = ((lo * 1e6).log10(), (hi * 1e6).log10());
        let py = |c: f64| bottom - ((c - llo) / (lhi - llo) * (bottom - top) as f64).round() as i32;
        let font = ("sans-serif", axes::TICK_FONT)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center));
        for (c, label) in axes::fit_ticks(Scale::Log10, (llo, lhi), false, py) {
            let y = py(c);
            root.draw(&PathElement::new(vec![(bx + 16, y), (bx + 20, y)], BLACK))
                .map_err(e)?;
            root.draw(&Text::new(label, (bx + 23, y), font.clone()))
                .map_err(e)?;
        }
        root.draw(&Text::new(
            "µs per pixel",
            (bx - 4, 1),
            ("sans-serif", 12).into_font().color(&BLACK),
        ))
        .map_err(e)?;
        root.present().map_err(e)
    }
}

/// Black → red → yellow → white over t ∈ [0, 1].
fn heat(t: f64) -> [u8; 3] {
    let ch = |a: f64| (a.clamp(0.0, 1.0) * 255.0).round() as u8;
    [ch(3.0 * t), ch(3.0 * t - 1.0), ch(3.0 * t - 2.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_and_items_by_hand() {
        let s = CostStats::of(&[1.0, 1.0, 1.0, 5.0]);
        assert_eq!((s.n, s.mean, s.max, s.total), (4, 2.0, 5.0, 8.0));
        assert!((s.sd - 3f64.sqrt()).abs() < 1e-12);
        assert!((s.cv() - 3f64.sqrt() / 2.0).abs() < 1e-12);
        assert_eq!(s.max_over_mean(), 2.5);
        // A 4×2 image whose right half costs 3: 2×2 items cost 4 and 12.
        let p = Profile {
            width: 4,
            height: 2,
            pixel_s: vec![1.0, 1.0, 3.0, 3.0, 1.0, 1.0, 3.0, 3.0],
        };
        assert_eq!(p.item_costs(Chunk::Tile { w: 2, h: 2 }), [4.0, 12.0]);
        assert_eq!(p.items(Chunk::Frame).total, 16.0);
        assert_eq!(p.share_of_top(0.5), 0.75);
        // Sorted: 3, 3, 3, 3, 1, 1, 1, 1: the median (index 4) is 1, the costliest half 3.
        assert_eq!(p.hot_over_median(0.5), 3.0);
        assert_eq!(p.hot_over_median(0.25), 3.0);
        let q = Profile {
            width: 4,
            height: 1,
            pixel_s: vec![1.0, 1.0, 1.0, 30.0],
        };
        assert_eq!(q.hot_over_median(0.25), 30.0);
        let img = p.heat_map();
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(3, 1).0, [255, 255, 255]);
    }
}
