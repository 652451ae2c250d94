//! Linear f32 RGB images: EXR or PFM (the data) chosen by extension, plus an sRGB PNG preview.

use super::WorkItem;
use crate::util::hash::Fnv64;
use std::path::{Path, PathBuf};

/// A linear RGB image, row-major: pixel (x, y) is `data[y·width + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width, in pixels.
    pub width: u32,
    /// Height, in pixels.
    pub height: u32,
    /// Row 0 is the top row.
    pub data: Vec<[f32; 3]>,
}

/// Why an image could not be saved or loaded.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: unsupported image extension (use .exr or .pfm)")]
    /// The path's extension names no supported data format; nothing was written.
    Extension {
        /// The path as given.
        path: String,
    },
    #[error("{path}: {msg}")]
    /// Reading, writing or encoding a file failed.
    Io {
        /// The file concerned.
        path: String,
        /// The underlying error's message.
        msg: String,
    },
}

impl Image {
    /// A black image of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            data: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Write an item's pixels (in the item's order) into the image.
    pub fn put(&mut self, item: &WorkItem, pixels: &[[f32; 3]]) {
        for (idx, px) in item.pixels(self.width).zip(pixels) {
            self.data[idx as usize] = *px;
        }
    }

    /// Frames stacked top to bottom into one film strip (frame k = rows k·h .. (k+1)·h): how a
    /// single-image API (experiment hashes, saved images) carries an animation. One frame is
    /// returned as it is.
    ///
    /// # Panics
    /// If `frames` is empty or the frames differ in size.
    pub fn stack(mut frames: Vec<Image>) -> Image {
        if frames.len() == 1 {
            return frames.pop().expect("one frame");
        }
        let (width, height) = (frames[0].width, frames[0].height);
        assert!(frames
            .iter()
            .all(|f| f.width == width && f.height == height));
        Image {
            width,
            height: height * frames.len() as u32,
            data: frames.into_iter().flat_map(|f| f.data).collect(),
        }
    }

    /// Inverse of [`Image::stack`]: cut a film strip into `n` frames.
    ///
    /// # Panics
    /// If `n` is 0 or does not divide the height.
    pub fn unstack(&self, n: u32) -> Vec<Image> {
        assert!(
            n > 0 && self.height.is_multiple_of(n),
            "{n} frames in {} rows",
            self.height
        );
        let h = self.height / n;
        let len = (self.width * h) as usize;
        self.data
            .chunks_exact(len)
            .map(|c| Image {
                width: self.width,
                height: h,
                data: c.to_vec(),
            })
            .collect()
    }

    /// Pixel (x, y), row 0 at the top. `x` must be below `width` (not checked).
    ///
    /// # Panics
    /// If `y·width + x` is past the last pixel.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.data[(y * self.width + x) as usize]
    }

    /// FNV-1a over the exact f32 bits: equal hashes mean bit-identical images.
    pub fn hash(&self) -> u64 {
        let mut h = Fnv64::default();
        h.write(&self.width.to_le_bytes());
        h.write(&self.height.to_le_bytes());
        for p in &self.data {
            for c in p {
                h.write(&c.to_bits().to_le_bytes());
            }
        }
        h.finish()
    }

    /// Write the data file (`.exr` or `.pfm`) and an sRGB `.png` preview beside it, creating the
    /// folder; returns the preview's path. Nothing is written if the extension is not supported.
    pub fn save_with_preview(&self, path: &Path) -> Result<PathBuf, ImageError> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let io = |e: &dyn std::fmt::Display| ImageError::Io {
            path: path.display().to_string(),
            msg: e.to_string(),
        };
        if matches!(ext.as_str(), "exr" | "pfm") {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| io(&e))?;
            }
        }
        match ext.as_str() {
            "exr" => self.save_exr(path).map_err(|e| io(&e))?,
            "pfm" => std::fs::write(path, self.pfm_bytes()).map_err(|e| io(&e))?,
            _ => {
                return Err(ImageError::Extension {
                    path: path.display().to_string(),
                })
            }
        }
        let png = path.with_extension("png");
        self.save_png(&png).map_err(|e| ImageError::Io {
            path: png.display().to_string(),
            msg: e.to_string(),
        })?;
        Ok(png)
    }

    fn save_exr(&self, path: &Path) -> image::ImageResult<()> {
        let flat: Vec<f32> = self.data.iter().flatten().copied().collect();
        let img = image::Rgb32FImage::from_raw(self.width, self.height, flat)
            .expect("buffer length matches width·height·3");
        img.save_with_format(path, image::ImageFormat::OpenExr)
    }

    /// Portable float map: little-endian, rows stored bottom to top.
    pub fn pfm_bytes(&self) -> Vec<u8> {
        let mut out = format!("PF\n{} {}\n-1.0\n", self.width, self.height).into_bytes();
        for y in (0..self.height).rev() {
            for x in 0..self.width {
                for c in self.get(x, y) {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        out
    }

    /// sRGB-encoded, clamped 8-bit preview.
    pub fn save_png(&self, path: &Path) -> image::ImageResult<()> {
        let bytes: Vec<u8> = self
            .data
            .iter()
            .flatten()
            .map(|&v| (srgb_encode(v) * 255.0 + 0.5) as u8)
            .collect();
        image::RgbImage::from_raw(self.width, self.height, bytes)
            .expect("buffer length matches width·height·3")
            .save_with_format(path, image::ImageFormat::Png)
    }

    /// Read an EXR written by [`Image::save_with_preview`] (or any RGB EXR).
    pub fn load_exr(path: &Path) -> Result<Self, ImageError> {
        let img = image::open(path).map_err(|e| ImageError::Io {
            path: path.display().to_string(),
            msg: e.to_string(),
        })?;
        let rgb = img.to_rgb32f();
        Ok(Self {
            width: rgb.width(),
            height: rgb.height(),
            data: rgb.pixels().map(|p| p.0).collect(),
        })
    }
}

/// Linear value to sRGB-encoded in [0, 1]: clamped first, NaN and infinities give 0.
pub fn srgb_encode(v: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> Image {
        let mut img = Image::new(5, 3);
        for (i, p) in img.data.iter_mut().enumerate() {
            *p = [i as f32 * 0.25, 1.0 / (i as f32 + 1.0), 3.5];
        }
        img
    }

    #[test]
    fn exr_round_trip_is_exact_and_png_preview_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.exr");
        let img = gradient();
        let png = img.save_with_preview(&path).unwrap();
        assert!(png.exists());
        assert_eq!(Image::load_exr(&path).unwrap(), img);
    }

    #[test]
    fn pfm_stores_rows_bottom_up_little_endian() {
        let img = gradient();
        let bytes = img.pfm_bytes();
        let header = b"PF\n5 3\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        let first = f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(
            first,
            img.get(0, 2)[0],
            "first stored pixel is the bottom-left one"
        );
        assert_eq!(bytes.len(), header.len() + 5 * 3 * 12);
    }

    #[test]
    fn unsupported_extension_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.jpg");
        assert!(matches!(
            gradient().save_with_preview(&path),
            Err(ImageError::Extension { .. })
        ));
        assert!(!path.exists() && !dir.path().join("x.png").exists());
    }

    #[test]
    fn stack_and_unstack_are_inverse_and_one_frame_is_unchanged() {
        let (a, mut b) = (gradient(), gradient());
        b.data[0] = [9.0; 3];
        let strip = Image::stack(vec![a.clone(), b.clone()]);
        assert_eq!((strip.width, strip.height), (5, 6));
        assert_eq!(strip.get(0, 3), [9.0; 3], "frame 1 starts at row 3");
        assert_eq!(strip.unstack(2), vec![a.clone(), b]);
        assert_eq!(Image::stack(vec![a.clone()]), a);
    }

    #[test]
    fn srgb_preview_encoding_clamps_and_handles_nan() {
        assert_eq!(srgb_encode(-1.0), 0.0);
        assert!((srgb_encode(2.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert!((srgb_encode(0.5) - 0.7354).abs() < 1e-3);
    }
}
