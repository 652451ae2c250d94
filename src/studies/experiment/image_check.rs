//! The image check of rows with a GPU source. The GPU kernel draws the same random numbers
//! as the CPU but rounds differently (see `crate::core::gpu`), so its image is never bit-identical
//! to the serial one; it must agree in mean: over every channel of every pixel, the mean of
//! the paired differences (this image − the serial image, the same samples on both sides)
//! lies within 3 standard errors of zero.

use crate::core::render::Image;

/// How an image compares with the serial image, pixel by pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agreement {
    /// Mean of the per-channel differences.
    pub mean: f64,
    /// Its standard error (spread of the differences / √n).
    pub se: f64,
    /// `mean / se` (0 for two equal images, infinite for a constant non-zero difference).
    pub z: f64,
    /// |mean| ≤ 3·se plus a floor of 1e-6 of the serial image's mean magnitude (f32 rounding
    /// of equal images).
    pub agrees: bool,
}

/// Compare `image` with `serial`; images of different sizes never agree.
pub fn compare(image: &Image, serial: &Image) -> Agreement {
    let values =
        |img: &Image| -> Vec<f64> { img.data.iter().flatten().map(|&v| f64::from(v)).collect() };
    let (a, b) = (values(image), values(serial));
    if a.len() != b.len()
        || a.len() < 2
        || (image.width, image.height) != (serial.width, serial.height)
    {
        return Agreement {
            mean: f64::NAN,
            se: f64::NAN,
            z: f64::NAN,
            agrees: false,
        };
    }
    let n = a.len() as f64;
    let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    let scale = b.iter().map(|v| v.abs()).sum::<f64>() / n;
    let z = if se > 0.0 {
        mean / se
    } else if mean == 0.0 {
        0.0
    } else {
        f64::INFINITY.copysign(mean)
    };
    Agreement {
        mean,
        se,
        z,
        agrees: mean.is_finite() && mean.abs() <= 3.0 * se + 1e-6 * scale.max(1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(f: impl Fn(usize) -> f32) -> Image {
        let mut img = Image::new(16, 16);
        for (i, px) in img.data.iter_mut().enumerate() {
            *px = [f(i), f(i + 7), f(i + 13)];
        }
        img
    }

    /// ±1 alternating: mean 0 over every channel (a stand-in for rounding noise).
    fn noise(i: usize) -> f32 {
        if i.is_multiple_of(2) {
            1.0
        } else {
            -1.0
        }
    }

    #[test]
    fn equal_and_noisy_images_agree_and_a_bias_of_one_percent_does_not() {
        let serial = image(|i| 0.5 + 0.01 * (i % 5) as f32);
        let same = compare(&serial, &serial);
        assert!(same.agrees && same.z == 0.0, "{same:?}");
        // Zero-mean differences of 1e-3: agree.
        let noisy = image(|i| 0.5 + 0.01 * (i % 5) as f32 + 1e-3 * noise(i));
        let n = compare(&noisy, &serial);
        assert!(n.agrees, "{n:?}");
        // The same noise plus a 1 % bias: hundreds of σ off.
        let biased = image(|i| (0.5 + 0.01 * (i % 5) as f32) * 1.01 + 1e-3 * noise(i));
        let b = compare(&biased, &serial);
        assert!(!b.agrees && b.z > 10.0, "{b:?}");
        assert!(!compare(&Image::new(4, 4), &serial).agrees);
    }
}
