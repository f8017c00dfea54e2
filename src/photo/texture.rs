//! Texture read off an image: the windowed standard deviation of the grey level, and the
//! mask of pixels where it reaches a threshold — what counts as "textured" as a stereo
//! method would see it.

use crate::raster::ImageF32;

/// Per-pixel texture mask: the grey level's standard deviation over a `(2r+1)²` window is at
/// least `threshold` (in [0, 1] units). What counts as "textured" is read off the image, as
/// a stereo method would see it.
pub fn texture_mask(image: &ImageF32, radius: u32, threshold: f32) -> Vec<bool> {
    local_std(image, radius)
        .into_iter()
        .map(|s| s >= threshold as f64)
        .collect()
}

/// Per pixel, the standard deviation of the grey level over the `(2r+1)²` window around it
/// (clipped at the image border), in [0, 1] units.
pub fn local_std(image: &ImageF32, radius: u32) -> Vec<f64> {
    let grey = image.to_gray();
    let (w, h) = (grey.width as usize, grey.height as usize);
    // Integral images of v and v² (f64 for exactness over large images).
    let mut s1 = vec![0.0f64; (w + 1) * (h + 1)];
    let mut s2 = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let (mut r1, mut r2) = (0.0, 0.0);
        for x in 0..w {
            let v = grey.data[y * w + x] as f64;
            r1 += v;
            r2 += v * v;
            s1[(y + 1) * (w + 1) + x + 1] = s1[y * (w + 1) + x + 1] + r1;
            s2[(y + 1) * (w + 1) + x + 1] = s2[y * (w + 1) + x + 1] + r2;
        }
    }
    let r = radius as usize;
    let mut std = vec![0.0f64; w * h];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let n = ((y1 - y0) * (x1 - x0)) as f64;
            let sum = |s: &[f64]| {
                s[y1 * (w + 1) + x1] - s[y0 * (w + 1) + x1] - s[y1 * (w + 1) + x0]
                    + s[y0 * (w + 1) + x0]
            };
            let mean = sum(&s1) / n;
            std[y * w + x] = (sum(&s2) / n - mean * mean).max(0.0).sqrt();
        }
    }
    std
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_mask_separates_plain_from_checker() {
        let mut img = ImageF32::filled(20, 10, 1, 0.5);
        for y in 0..10 {
            for x in 10..20 {
                img.pixel_mut(x, y)[0] = if (x + y) % 2 == 0 { 0.2 } else { 0.8 };
            }
        }
        let m = texture_mask(&img, 2, 0.02);
        assert!(!m[5 * 20 + 2] && !m[5 * 20 + 7]);
        assert!(m[5 * 20 + 12] && m[5 * 20 + 17]);
    }
}
