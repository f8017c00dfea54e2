//! COLMAP dense maps: `stereo/depth_maps/*.bin` and `stereo/normal_maps/*.bin`.
//!
//! Verified against COLMAP's `src/colmap/mvs/mat.h` / `mat.cc` (`Mat<float>::Read/Write`)
//! and `scripts/python/read_write_dense.py`:
//! - header: ASCII `width&height&channels&` (C++ `file << width_ << "&" << height_ << "&"
//!   << depth_ << "&"`), no newline, immediately followed by the data;
//! - data: `width·height·channels` little-endian `f32`, **channel-planar**: element
//!   `(row, col, slice)` is at `slice·width·height + row·width + col` (`Mat::Get`), rows top
//!   to bottom (row 0 first), no row flip. The Python reader's
//!   `reshape((width, height, channels), order="F")` is the same layout.
//!
//! [`ImageF32`] is interleaved, so we transpose between the two on read and write. Depth maps
//! have 1 channel (camera-frame z, 0 = no depth); normal maps have 3 (unit normals in the
//! camera frame, COLMAP's convention). Values must be finite.

use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::Path;

use thiserror::Error;

use crate::io::atomic::write_atomic;
use crate::raster::ImageF32;

const STREAM: &str = "<stream>";
/// Longest number accepted in the header.
const MAX_DIGITS: usize = 10;

/// Errors reading or writing COLMAP dense maps.
#[derive(Debug, Error)]
pub enum DenseError {
    /// The file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        source: io::Error,
    },
    /// The bytes are not a valid COLMAP dense map.
    #[error("{file}: byte {offset}: {message}")]
    Format {
        /// The file.
        file: String,
        /// Byte offset of the problem.
        offset: u64,
        /// What was expected.
        message: String,
    },
    /// The map is well formed but not what the caller asked for, or cannot be written.
    #[error("{file}: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Why.
        message: String,
    },
}

impl DenseError {
    fn in_file(self, path: &Path) -> Self {
        let file = path.display().to_string();
        match self {
            DenseError::Io { source, .. } => DenseError::Io { file, source },
            DenseError::Format {
                offset, message, ..
            } => DenseError::Format {
                file,
                offset,
                message,
            },
            DenseError::Invalid { message, .. } => DenseError::Invalid { file, message },
        }
    }
}

impl From<io::Error> for DenseError {
    fn from(source: io::Error) -> Self {
        DenseError::Io {
            file: STREAM.into(),
            source,
        }
    }
}

fn format_err(offset: u64, message: impl Into<String>) -> DenseError {
    DenseError::Format {
        file: STREAM.into(),
        offset,
        message: message.into(),
    }
}

fn invalid(message: impl Into<String>) -> DenseError {
    DenseError::Invalid {
        file: STREAM.into(),
        message: message.into(),
    }
}

/// Reads the decimal number before the next `&`.
fn read_field<R: Read>(r: &mut R, offset: &mut u64, what: &str) -> Result<u32, DenseError> {
    let start = *offset;
    let mut digits = String::new();
    let mut byte = [0u8; 1];
    loop {
        if r.read(&mut byte)? == 0 {
            return Err(format_err(
                *offset,
                format!("file ends inside the header, expected {what} followed by '&'"),
            ));
        }
        *offset += 1;
        match byte[0] {
            b'&' => break,
            b'0'..=b'9' if digits.len() < MAX_DIGITS => digits.push(byte[0] as char),
            b => {
                return Err(format_err(
                    *offset - 1,
                    format!(
                        "expected {what} (decimal digits) followed by '&', found byte 0x{b:02x}"
                    ),
                ))
            }
        }
    }
    match digits.parse::<u32>() {
        Ok(v) if v > 0 => Ok(v),
        _ => Err(format_err(
            start,
            format!("expected {what} (a positive integer), found {digits:?}"),
        )),
    }
}

/// Reads a COLMAP dense map (any channel count) from a stream into an interleaved image.
pub fn read_dense_map<R: Read>(mut r: R) -> Result<ImageF32, DenseError> {
    let mut offset = 0u64;
    let width = read_field(&mut r, &mut offset, "width")?;
    let height = read_field(&mut r, &mut offset, "height")?;
    let channels = read_field(&mut r, &mut offset, "channels")?;
    let header_len = offset;
    let plane = width as u64 * height as u64;
    let count = plane
        .checked_mul(channels as u64)
        .filter(|&n| n <= usize::MAX as u64 / 4)
        .ok_or_else(|| format_err(0, format!("map {width}x{height}x{channels} is too large")))?;
    let want = count * 4;
    let mut bytes = Vec::new();
    r.by_ref().take(want).read_to_end(&mut bytes)?;
    if (bytes.len() as u64) < want {
        return Err(format_err(
            header_len + bytes.len() as u64,
            format!(
                "file is truncated: expected {want} bytes of data for {width}x{height}x{channels}, found {}",
                bytes.len()
            ),
        ));
    }
    let mut extra = [0u8; 1];
    if r.read(&mut extra)? != 0 {
        return Err(format_err(
            header_len + want,
            "expected end of file after the data",
        ));
    }
    let (plane, c) = (plane as usize, channels as usize);
    let mut data = vec![0f32; count as usize];
    for (k, b) in bytes.chunks_exact(4).enumerate() {
        let v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        if !v.is_finite() {
            return Err(format_err(
                header_len + 4 * k as u64,
                format!("expected a finite value, found {v}"),
            ));
        }
        let (slice, pixel) = (k / plane, k % plane);
        data[pixel * c + slice] = v;
    }
    Ok(ImageF32 {
        width,
        height,
        channels,
        data,
    })
}

/// Reads a COLMAP dense map file; errors name the file.
pub fn read_dense_map_path(path: &Path) -> Result<ImageF32, DenseError> {
    let file = File::open(path).map_err(|e| DenseError::from(e).in_file(path))?;
    read_dense_map(BufReader::new(file)).map_err(|e| e.in_file(path))
}

fn expect_channels(img: ImageF32, channels: u32, what: &str) -> Result<ImageF32, DenseError> {
    if img.channels != channels {
        return Err(invalid(format!(
            "expected a {what} with {channels} channel(s), found {}",
            img.channels
        )));
    }
    Ok(img)
}

/// Reads a COLMAP depth map (`depth_maps/*.bin`, 1 channel, camera z; 0 = unknown).
pub fn read_depth_map_path(path: &Path) -> Result<ImageF32, DenseError> {
    read_dense_map_path(path)
        .and_then(|img| expect_channels(img, 1, "depth map").map_err(|e| e.in_file(path)))
}

/// Reads a COLMAP normal map (`normal_maps/*.bin`, 3 channels, camera-frame normals).
pub fn read_normal_map_path(path: &Path) -> Result<ImageF32, DenseError> {
    read_dense_map_path(path)
        .and_then(|img| expect_channels(img, 3, "normal map").map_err(|e| e.in_file(path)))
}

/// Writes `img` in COLMAP's dense-map layout (header, then channel-planar little-endian f32).
pub fn write_dense_map<W: Write>(mut w: W, img: &ImageF32) -> Result<(), DenseError> {
    let (c, plane) = (img.channels as usize, img.len_pixels());
    if img.width == 0 || img.height == 0 || c == 0 || img.data.len() != plane * c {
        return Err(invalid(format!(
            "cannot write a {}x{}x{} map with {} values",
            img.width,
            img.height,
            img.channels,
            img.data.len()
        )));
    }
    if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
        return Err(invalid(format!(
            "value {i} is {}, COLMAP maps hold finite values",
            img.data[i]
        )));
    }
    write!(w, "{}&{}&{}&", img.width, img.height, img.channels)?;
    let mut buf = Vec::with_capacity(plane * 4);
    for slice in 0..c {
        buf.clear();
        for px in img.data.chunks_exact(c) {
            buf.extend_from_slice(&px[slice].to_le_bytes());
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Writes a COLMAP dense map atomically; errors name the file.
pub fn write_dense_map_path(path: &Path, img: &ImageF32) -> Result<(), DenseError> {
    write_atomic(path, |w| write_dense_map(w, img)).map_err(|e| e.in_file(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_channel_planar() -> Result<(), DenseError> {
        // 2x1 image, 3 channels: pixel0 = (1,2,3), pixel1 = (4,5,6).
        let img = ImageF32 {
            width: 2,
            height: 1,
            channels: 3,
            data: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        };
        let mut bytes = Vec::new();
        write_dense_map(&mut bytes, &img)?;
        assert!(bytes.starts_with(b"2&1&3&"));
        let vals: Vec<f32> = bytes[6..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(vals, [1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
        assert_eq!(read_dense_map(&bytes[..])?, img);
        Ok(())
    }

    #[test]
    fn rows_top_to_bottom_and_byte_identical() -> Result<(), DenseError> {
        let mut img = ImageF32::filled(3, 2, 1, 0.0);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = 1.5 + i as f32;
        }
        let mut bytes = Vec::new();
        write_dense_map(&mut bytes, &img)?;
        // Mat::Get(row=1, col=0) = data[1*width + 0] is image pixel (0, 1).
        let at = 6 + 4 * 3;
        assert_eq!(
            f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()),
            img.get(0, 1, 0)
        );
        let back = read_dense_map(&bytes[..])?;
        let mut again = Vec::new();
        write_dense_map(&mut again, &back)?;
        assert_eq!(again, bytes);
        Ok(())
    }

    #[test]
    fn bad_inputs_name_offsets() {
        let err = read_dense_map(&b"3&x&1&"[..]).unwrap_err().to_string();
        assert!(err.contains("byte 2") && err.contains("height"), "{err}");
        let err = read_dense_map(&b"3&0&1&"[..]).unwrap_err().to_string();
        assert!(err.contains("byte 2") && err.contains("positive"), "{err}");
        let err = read_dense_map(&b"2&1&1&\0\0\0\0\0\0"[..])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("byte 12") && err.contains("truncated"),
            "{err}"
        );
        let mut nan = b"1&1&1&".to_vec();
        nan.extend_from_slice(&f32::NAN.to_le_bytes());
        let err = read_dense_map(&nan[..]).unwrap_err().to_string();
        assert!(err.contains("byte 6") && err.contains("finite"), "{err}");
        let err = read_dense_map(&b"99999999999&1&1&"[..])
            .unwrap_err()
            .to_string();
        assert!(err.contains("byte 10") && err.contains("width"), "{err}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        #[test]
        fn mutated_input_never_panics(
            edits in proptest::collection::vec(
                (proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>()),
                1..5,
            ),
            cut in proptest::prelude::any::<proptest::sample::Index>(),
        ) {
            let mut bytes = { let mut v = Vec::new(); write_dense_map(&mut v, &ImageF32::filled(3, 2, 3, 0.5)).unwrap(); v };
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            bytes.truncate(cut.index(bytes.len() + 1).max(bytes.len() / 2));
            let _ = read_dense_map(&bytes[..]);
        }
    }
}
