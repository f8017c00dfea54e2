//! A flat, interleaved `f32` image: the one raster type the stages share.
//!
//! Values of colour images are in `[0, 1]`. Pixel `(x, y)` covers image coordinates
//! `[x, x+1) × [y, y+1)`, its centre at `(x + 0.5, y + 0.5)`.

use image::{Rgb, RgbImage};

/// Most bytes one byte of deflate (zlib) data can inflate to: zlib documents a maximum
/// compression factor of 1032:1 (a 258-byte match coded in about 2 bits).
pub const DEFLATE_MAX_RATIO: u64 = 1032;

/// The fewest bytes the pixel data of a `width × height` PNG with `bits_per_pixel` inflates
/// to: rows of ⌈width·bits/8⌉ bytes (filter bytes and interlacing only add to it).
pub fn png_min_inflated_bytes(width: u32, height: u32, bits_per_pixel: u16) -> u64 {
    let row_bits = u64::from(width) * u64::from(bits_per_pixel);
    u64::from(height).saturating_mul(row_bits.div_ceil(8))
}

/// Whether a PNG file of `file_len` bytes can hold the pixels its header declares. A file
/// that cannot is truncated or forged, and is refused before the decoder allocates the
/// declared size (a 100-byte PNG can declare 4 × 33 554 433 16-bit pixels: 268 MB).
pub fn png_can_hold(width: u32, height: u32, bits_per_pixel: u16, file_len: u64) -> bool {
    png_min_inflated_bytes(width, height, bits_per_pixel)
        <= file_len.saturating_mul(DEFLATE_MAX_RATIO)
}

/// A `width × height × channels` image stored row-major, channels interleaved.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageF32 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channels per pixel (1 = grey, 3 = RGB).
    pub channels: u32,
    /// `width * height * channels` values.
    pub data: Vec<f32>,
}

impl ImageF32 {
    /// An image filled with `value`.
    pub fn filled(width: u32, height: u32, channels: u32, value: f32) -> Self {
        ImageF32 {
            width,
            height,
            channels,
            data: vec![value; width as usize * height as usize * channels as usize],
        }
    }

    /// Number of pixels.
    pub fn len_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Index of channel 0 of pixel `(x, y)` in `data`.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y as usize * self.width as usize + x as usize) * self.channels as usize
    }

    /// Value of channel `c` at pixel `(x, y)`.
    #[inline]
    pub fn get(&self, x: u32, y: u32, c: u32) -> f32 {
        self.data[self.index(x, y) + c as usize]
    }

    /// The channels of pixel `(x, y)`.
    #[inline]
    pub fn pixel(&self, x: u32, y: u32) -> &[f32] {
        let i = self.index(x, y);
        &self.data[i..i + self.channels as usize]
    }

    /// Mutable channels of pixel `(x, y)`.
    #[inline]
    pub fn pixel_mut(&mut self, x: u32, y: u32) -> &mut [f32] {
        let i = self.index(x, y);
        let c = self.channels as usize;
        &mut self.data[i..i + c]
    }

    /// Bilinear sample of all channels at image coordinates `(u, v)` (pixel centres at +0.5)
    /// into `out`. Returns `false` (and leaves `out` untouched) outside the image, where
    /// "outside" means the sample would need a pixel beyond the border by more than half a
    /// pixel; border pixels are clamped within that half pixel.
    pub fn sample_bilinear(&self, u: f64, v: f64, out: &mut [f32]) -> bool {
        let (w, h) = (self.width as f64, self.height as f64);
        if !(u >= 0.0 && v >= 0.0 && u <= w && v <= h) {
            return false;
        }
        let fx = (u - 0.5).clamp(0.0, w - 1.0);
        let fy = (v - 0.5).clamp(0.0, h - 1.0);
        let x0 = fx.floor() as u32;
        let y0 = fy.floor() as u32;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let ax = (fx - x0 as f64) as f32;
        let ay = (fy - y0 as f64) as f32;
        let (p00, p10, p01, p11) = (
            self.index(x0, y0),
            self.index(x1, y0),
            self.index(x0, y1),
            self.index(x1, y1),
        );
        for (c, o) in out.iter_mut().enumerate().take(self.channels as usize) {
            let top = self.data[p00 + c] * (1.0 - ax) + self.data[p10 + c] * ax;
            let bottom = self.data[p01 + c] * (1.0 - ax) + self.data[p11 + c] * ax;
            *o = top * (1.0 - ay) + bottom * ay;
        }
        true
    }

    /// Grey version (Rec. 601 luma for 3 channels; a copy for 1 channel).
    pub fn to_gray(&self) -> ImageF32 {
        if self.channels == 1 {
            return self.clone();
        }
        let c = self.channels as usize;
        let data = self
            .data
            .chunks_exact(c)
            .map(|p| 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2])
            .collect();
        ImageF32 {
            width: self.width,
            height: self.height,
            channels: 1,
            data,
        }
    }

    /// From an 8-bit RGB image (values scaled to `[0, 1]`).
    pub fn from_rgb8(img: &RgbImage) -> Self {
        ImageF32 {
            width: img.width(),
            height: img.height(),
            channels: 3,
            data: img.as_raw().iter().map(|&v| v as f32 / 255.0).collect(),
        }
    }

    /// To an 8-bit RGB image (grey is replicated; values clamped to `[0, 1]` and rounded).
    pub fn to_rgb8(&self) -> RgbImage {
        let mut img = RgbImage::new(self.width, self.height);
        let c = self.channels as usize;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        for (i, px) in img.pixels_mut().enumerate() {
            let s = &self.data[i * c..i * c + c];
            *px = if c >= 3 {
                Rgb([q(s[0]), q(s[1]), q(s[2])])
            } else {
                Rgb([q(s[0]); 3])
            };
        }
        img
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_hits_pixel_centres_exactly() {
        let mut img = ImageF32::filled(4, 3, 1, 0.0);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = i as f32;
        }
        let mut out = [0.0f32];
        assert!(img.sample_bilinear(2.5, 1.5, &mut out));
        assert_eq!(out[0], img.get(2, 1, 0));
        assert!(img.sample_bilinear(2.0, 1.5, &mut out));
        assert_eq!(out[0], 0.5 * (img.get(1, 1, 0) + img.get(2, 1, 0)));
        assert!(!img.sample_bilinear(-0.1, 1.0, &mut out));
        assert!(!img.sample_bilinear(1.0, 3.01, &mut out));
    }

    #[test]
    fn rgb8_round_trip() {
        let mut img = RgbImage::new(3, 2);
        for (i, p) in img.pixels_mut().enumerate() {
            *p = Rgb([i as u8 * 40, 255 - i as u8, 7]);
        }
        assert_eq!(ImageF32::from_rgb8(&img).to_rgb8(), img);
    }
}
