//! Print-quality PNGs: a figure's SVG rasterised at a scale (resvg), so lines, markers and text
//! stay sharp at 2×–4× where the bitmap backend would only give a bigger canvas with the same
//! pixel-sized fonts.

use std::path::{Path, PathBuf};

/// PNG scales `plot --png-scale` accepts: 8× of the largest figure (900 × 640) is 37 M pixels,
/// 147 MB of pixmap.
pub const PNG_SCALE_RANGE: std::ops::RangeInclusive<f32> = 1.0..=8.0;

/// A PNG scale outside [`PNG_SCALE_RANGE`] (or NaN).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("must be in {lo}–{hi} (got {got})", lo = PNG_SCALE_RANGE.start(), hi = PNG_SCALE_RANGE.end(), got = .0)]
pub struct ScaleError(pub f32);

/// Why an SVG was not rasterised: the file at fault first, on one line.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// Reading the SVG or writing the PNG.
    #[error("{}: {msg}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error's text.
        msg: String,
    },
    /// The SVG does not parse.
    #[error("{}: not a readable SVG ({msg})", path.display())]
    Svg {
        /// The SVG.
        path: PathBuf,
        /// The parser's error.
        msg: String,
    },
    /// The PNG would be empty or too large to allocate.
    #[error("{}: {w} × {h} pixels at scale {scale} is outside 1 … 40 M pixels", path.display())]
    Size {
        /// The SVG.
        path: PathBuf,
        /// Width in pixels.
        w: u32,
        /// Height in pixels.
        h: u32,
        /// The scale asked for.
        scale: f32,
    },
}

/// A PNG scale checked against [`PNG_SCALE_RANGE`] once, where it enters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PngScale(f32);

impl PngScale {
    /// The SVG's own pixel size.
    pub const ONE: Self = Self(1.0);

    /// `scale` if it is in [`PNG_SCALE_RANGE`]; otherwise why not.
    pub fn new(scale: f32) -> Result<Self, ScaleError> {
        if PNG_SCALE_RANGE.contains(&scale) {
            Ok(Self(scale))
        } else {
            Err(ScaleError(scale))
        }
    }

    /// The factor.
    pub fn get(self) -> f32 {
        self.0
    }
}

/// Rasterise `svg` at `scale` into `png` (1 = the SVG's own pixel size), with the bundled
/// DejaVu Sans as the SVG's "sans-serif", the font the PNG backend draws with.
pub fn svg_to_png(svg: &Path, png: &Path, scale: PngScale) -> Result<(), RasterError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |e: std::io::Error| RasterError::Io {
            path,
            msg: e.to_string(),
        }
    };
    let scale = scale.get();
    let text = std::fs::read_to_string(svg).map_err(io(svg))?;
    let mut opt = resvg::usvg::Options::default();
    let db = opt.fontdb_mut();
    db.load_font_data(include_bytes!("../../assets/fonts/DejaVuSans.ttf").to_vec());
    db.set_sans_serif_family("DejaVu Sans");
    opt.font_family = "DejaVu Sans".into();
    let tree = resvg::usvg::Tree::from_str(&text, &opt).map_err(|e| RasterError::Svg {
        path: svg.to_path_buf(),
        msg: e.to_string(),
    })?;
    let size = tree.size();
    let (w, h) = (
        (size.width() * scale).ceil() as u32,
        (size.height() * scale).ceil() as u32,
    );
    // Sizes checked before the pixmap is allocated.
    if w == 0 || h == 0 || u64::from(w) * u64::from(h) > 40_000_000 {
        return Err(RasterError::Size {
            path: svg.to_path_buf(),
            w,
            h,
            scale,
        });
    }
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h).ok_or_else(|| RasterError::Io {
        path: png.to_path_buf(),
        msg: format!("cannot allocate {w} × {h}"),
    })?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    let bytes = pixmap.encode_png().map_err(|e| RasterError::Io {
        path: png.to_path_buf(),
        msg: e.to_string(),
    })?;
    std::fs::write(png, bytes).map_err(io(png))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line and a label, rasterised at 1× and 3×: 3× is three times the size, the text is
    /// drawn (dark pixels where the label is) and the line is as thick in SVG units.
    #[test]
    fn scale_multiplies_the_pixels_and_draws_text() {
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("f.svg");
        std::fs::write(
            &svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="40">
<line x1="0" y1="35" x2="100" y2="35" stroke="black" stroke-width="2"/>
<text x="5" y="20" font-family="sans-serif" font-size="16">Speedup</text></svg>"#,
        )
        .unwrap();
        let dark = |scale: f32| {
            let png = dir.path().join(format!("f{scale}.png"));
            svg_to_png(&svg, &png, PngScale::new(scale).unwrap()).unwrap();
            let img = image::open(&png).unwrap().to_luma8();
            let s = scale as u32;
            assert_eq!((img.width(), img.height()), (100 * s, 40 * s));
            let count = |y0: u32, y1: u32| {
                (y0 * s..y1 * s)
                    .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
                    .filter(|&(x, y)| img.get_pixel(x, y)[0] < 128)
                    .count() as f64
                    / f64::from(s * s)
            };
            (count(0, 25), count(33, 37))
        };
        let (text1, line1) = dark(1.0);
        let (text3, line3) = dark(3.0);
        assert!(text1 > 50.0, "text drawn at 1×: {text1}");
        // Per SVG unit² the ink is the same at both scales, within antialiasing.
        assert!((text3 / text1 - 1.0).abs() < 0.25, "{text1} vs {text3}");
        assert!((line3 / line1 - 1.0).abs() < 0.1, "{line1} vs {line3}");
        assert!(PngScale::new(9.0).is_err() && PngScale::new(0.5).is_err());
        assert!(PngScale::new(f32::NAN).is_err());
    }
}
