//! Planemaps as 16-bit greyscale PNG label maps, and their colour visualisation.
//!
//! A label map stores one `u16` per pixel (a plane id, row-major, top row first). 16-bit PNG
//! keeps up to 65 535 labels losslessly and opens in any image viewer (as a dark image — use
//! [`label_colors`] for something a person can read).

use std::fs::File;
use std::io::{self, BufWriter, Cursor, Read, Write};
use std::path::Path;

use image::codecs::png::{PngDecoder, PngEncoder};
use image::{DynamicImage, ImageBuffer, ImageDecoder, Luma, Rgb, RgbImage};
use thiserror::Error;

use crate::io::atomic::write_atomic;
use crate::raster::{png_can_hold, png_min_inflated_bytes, DEFLATE_MAX_RATIO};

const STREAM: &str = "<stream>";

/// Errors reading or writing label PNGs.
#[derive(Debug, Error)]
pub enum LabelPngError {
    /// The file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        source: io::Error,
    },
    /// The PNG decoder or encoder failed (message from the `image` crate).
    #[error("{file}: not a readable PNG label map: {message}")]
    Png {
        /// The file.
        file: String,
        /// The decoder's message.
        message: String,
    },
    /// The PNG is valid but not a label map (wrong colour type), or the labels do not fit
    /// the size.
    #[error("{file}: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Why.
        message: String,
    },
}

impl LabelPngError {
    fn in_file(self, path: &Path) -> Self {
        let file = path.display().to_string();
        match self {
            LabelPngError::Io { source, .. } => LabelPngError::Io { file, source },
            LabelPngError::Png { message, .. } => LabelPngError::Png { file, message },
            LabelPngError::Invalid { message, .. } => LabelPngError::Invalid { file, message },
        }
    }
}

impl From<io::Error> for LabelPngError {
    fn from(source: io::Error) -> Self {
        LabelPngError::Io {
            file: STREAM.into(),
            source,
        }
    }
}

/// A label map: `width × height` labels, row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One label per pixel.
    pub labels: Vec<u16>,
}

/// Writes labels as a 16-bit greyscale PNG to a stream.
pub fn write_label_png_to<W: Write>(
    w: W,
    width: u32,
    height: u32,
    labels: &[u16],
) -> Result<(), LabelPngError> {
    let buf: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_raw(width, height, labels.to_vec()).ok_or_else(|| {
            LabelPngError::Invalid {
                file: STREAM.into(),
                message: format!(
                    "{} labels do not fill a {width}x{height} image",
                    labels.len()
                ),
            }
        })?;
    if width == 0 || height == 0 || labels.len() != width as usize * height as usize {
        return Err(LabelPngError::Invalid {
            file: STREAM.into(),
            message: format!("{} labels for a {width}x{height} image", labels.len()),
        });
    }
    DynamicImage::ImageLuma16(buf)
        .write_with_encoder(PngEncoder::new(w))
        .map_err(|e| LabelPngError::Png {
            file: STREAM.into(),
            message: e.to_string(),
        })
}

/// Writes labels as a 16-bit greyscale PNG file, atomically; errors name the file.
pub fn write_label_png(
    path: &Path,
    width: u32,
    height: u32,
    labels: &[u16],
) -> Result<(), LabelPngError> {
    write_atomic(path, |w: &mut BufWriter<File>| {
        write_label_png_to(w, width, height, labels)
    })
    .map_err(|e| e.in_file(path))
}

/// Reads a label PNG from a stream. 16-bit greyscale is read as is; 8-bit greyscale is
/// widened (labels 0..=255). Any other colour type (RGB, alpha, …) is an error naming it.
/// A header declaring more pixels than the file's bytes could inflate to is an error before
/// anything of that size is allocated.
pub fn read_label_png_from<R: Read>(mut r: R) -> Result<LabelMap, LabelPngError> {
    let mut bytes = Vec::new();
    r.read_to_end(&mut bytes)?;
    let png = |e: image::ImageError| LabelPngError::Png {
        file: STREAM.into(),
        message: e.to_string(),
    };
    let file_len = bytes.len() as u64;
    let decoder = PngDecoder::new(Cursor::new(bytes)).map_err(png)?;
    let (width, height) = decoder.dimensions();
    let bits = decoder.original_color_type().bits_per_pixel();
    if !png_can_hold(width, height, bits, file_len) {
        return Err(LabelPngError::Invalid {
            file: STREAM.into(),
            message: format!(
                "header declares {width}x{height} pixels of {bits} bits ({} bytes once \
                 inflated), but the file's {file_len} bytes inflate to at most {}: truncated \
                 or corrupt",
                png_min_inflated_bytes(width, height, bits),
                file_len.saturating_mul(DEFLATE_MAX_RATIO)
            ),
        });
    }
    let img = DynamicImage::from_decoder(decoder).map_err(png)?;
    let (width, height) = (img.width(), img.height());
    let labels = match img {
        DynamicImage::ImageLuma16(buf) => buf.into_raw(),
        DynamicImage::ImageLuma8(buf) => buf.into_raw().into_iter().map(u16::from).collect(),
        other => {
            return Err(LabelPngError::Invalid {
                file: STREAM.into(),
                message: format!(
                    "expected a 16-bit (or 8-bit) greyscale PNG, found colour type {:?}",
                    other.color()
                ),
            })
        }
    };
    Ok(LabelMap {
        width,
        height,
        labels,
    })
}

/// Reads a label PNG file: `(width, height, labels)`; errors name the file.
pub fn read_label_png(path: &Path) -> Result<(u32, u32, Vec<u16>), LabelPngError> {
    let file = File::open(path).map_err(|e| LabelPngError::from(e).in_file(path))?;
    let map = read_label_png_from(io::BufReader::new(file)).map_err(|e| e.in_file(path))?;
    Ok((map.width, map.height, map.labels))
}

/// SplitMix64 finaliser: a fixed, well-mixed hash so colours never depend on run or platform.
fn mix(id: u64) -> u64 {
    let mut z = id.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The display colour of label `id`: black for 0 ("no plane"); otherwise a hue from a hash of
/// the id, saturation in [0.55, 1] and value in [0.7, 1], so that neighbouring ids differ and
/// an id has the same colour in every planemap and every run.
pub fn label_color(id: u16) -> [u8; 3] {
    if id == 0 {
        return [0, 0, 0];
    }
    let h = mix(id as u64);
    let hue = (h & 0xffff) as f64 / 65536.0 * 6.0;
    let sat = 0.55 + 0.45 * ((h >> 16) & 0xff) as f64 / 255.0;
    let val = 0.7 + 0.3 * ((h >> 24) & 0xff) as f64 / 255.0;
    let sector = hue.floor();
    let f = hue - sector;
    let (p, q, t) = (
        val * (1.0 - sat),
        val * (1.0 - sat * f),
        val * (1.0 - sat * (1.0 - f)),
    );
    let (r, g, b) = match sector as u32 {
        0 => (val, t, p),
        1 => (q, val, p),
        2 => (p, val, t),
        3 => (p, q, val),
        4 => (t, p, val),
        _ => (val, p, q),
    };
    let q8 = |v: f64| (v * 255.0).round().clamp(0.0, 255.0) as u8;
    [q8(r), q8(g), q8(b)]
}

/// Colour visualisation of a label map (see [`label_color`]). Pixels beyond the end of
/// `labels` (if it is shorter than `width·height`) are black; extra labels are ignored.
pub fn label_colors(labels: &[u16], width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::new(width, height);
    for (px, &id) in img.pixels_mut().zip(labels) {
        *px = Rgb(label_color(id));
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_round_trip() -> Result<(), LabelPngError> {
        let labels: Vec<u16> = (0..12).map(|i| (i * 5471 % 65536) as u16).collect();
        let mut bytes = Vec::new();
        write_label_png_to(&mut bytes, 4, 3, &labels)?;
        let map = read_label_png_from(&bytes[..])?;
        assert_eq!((map.width, map.height), (4, 3));
        assert_eq!(map.labels, labels);
        assert!(labels.iter().any(|&l| l > 255));
        Ok(())
    }

    #[test]
    fn eight_bit_is_widened_and_rgb_rejected() -> Result<(), LabelPngError> {
        let gray = image::GrayImage::from_raw(2, 1, vec![7, 250]).unwrap();
        let mut bytes = Vec::new();
        DynamicImage::ImageLuma8(gray)
            .write_with_encoder(PngEncoder::new(&mut bytes))
            .unwrap();
        assert_eq!(read_label_png_from(&bytes[..])?.labels, vec![7, 250]);
        let rgb = RgbImage::new(2, 1);
        let mut bytes = Vec::new();
        DynamicImage::ImageRgb8(rgb)
            .write_with_encoder(PngEncoder::new(&mut bytes))
            .unwrap();
        let err = read_label_png_from(&bytes[..]).unwrap_err().to_string();
        assert!(err.contains("Rgb8"), "{err}");
        Ok(())
    }

    #[test]
    fn wrong_length_is_an_error() {
        assert!(write_label_png_to(Vec::new(), 3, 3, &[1, 2]).is_err());
    }

    #[test]
    fn colours_are_stable_and_distinct() {
        assert_eq!(label_color(0), [0, 0, 0]);
        let colors: Vec<[u8; 3]> = (1..=64).map(label_color).collect();
        for (i, a) in colors.iter().enumerate() {
            assert_ne!(*a, [0, 0, 0]);
            for b in &colors[i + 1..] {
                assert_ne!(a, b);
            }
        }
        assert_eq!(label_color(17), label_color(17));
        let img = label_colors(&[0, 3, 3, 9], 2, 2);
        assert_eq!(img.get_pixel(1, 0), img.get_pixel(0, 1));
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(1, 1).0, label_color(9));
    }

    #[test]
    fn a_header_larger_than_the_file_could_hold_is_refused_before_decoding() {
        // Found by the label_png fuzzer: 95 bytes declaring 4 x 33554433 16-bit pixels made
        // the decoder allocate 268 MB.
        let mut png = Vec::new();
        write_label_png_to(&mut png, 4, 1, &[1, 2, 3, 4]).unwrap();
        // IHDR height (bytes 20..24) and its CRC (bytes 29..33).
        png[20..24].copy_from_slice(&33_554_433u32.to_be_bytes());
        let crc = crc32fast::hash(&png[12..29]);
        png[29..33].copy_from_slice(&crc.to_be_bytes());
        let err = read_label_png_from(&png[..]).unwrap_err().to_string();
        assert!(
            err.contains("header declares 4x33554433 pixels of 16 bits")
                && err.contains("truncated or corrupt"),
            "{err}"
        );
    }
}
