//! Portable Float Map (`.pfm`): 32-bit float images with 1 (`Pf`) or 3 (`PF`) channels.
//!
//! Layout: an ASCII header `PF`/`Pf`, `width height`, `scale` (each token followed by one
//! whitespace byte; we write newlines), then `width·height·channels` raw `f32`s. The sign of
//! `scale` gives the byte order (negative = little-endian, positive = big-endian); its
//! magnitude is ignored here. Rows are stored **bottom to top** (the first row in the file is
//! the last image row), channels interleaved; we flip on read and write so that
//! [`ImageF32`] stays top-to-bottom. Values are not range-checked: PFM is used for depths and
//! costs as well as colours, and may hold NaN/∞ on purpose.

use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::Path;

use thiserror::Error;

use crate::io::atomic::write_atomic;
use crate::raster::ImageF32;

/// Name used in errors from stream readers before a path wrapper sets the file name.
const STREAM: &str = "<stream>";
/// Longest header token accepted (guards against reading a binary file as a header).
const MAX_TOKEN: usize = 32;

/// Errors reading or writing PFM files.
#[derive(Debug, Error)]
pub enum PfmError {
    /// The file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        source: io::Error,
    },
    /// The bytes are not a valid PFM file.
    #[error("{file}: byte {offset}: {message}")]
    Format {
        /// The file.
        file: String,
        /// Byte offset where the problem was found.
        offset: u64,
        /// What was expected.
        message: String,
    },
    /// The image cannot be written as PFM.
    #[error("{file}: cannot write PFM: {message}")]
    Unsupported {
        /// The file.
        file: String,
        /// Why.
        message: String,
    },
}

impl PfmError {
    fn in_file(self, path: &Path) -> Self {
        let file = path.display().to_string();
        match self {
            PfmError::Io { source, .. } => PfmError::Io { file, source },
            PfmError::Format {
                offset, message, ..
            } => PfmError::Format {
                file,
                offset,
                message,
            },
            PfmError::Unsupported { message, .. } => PfmError::Unsupported { file, message },
        }
    }
}

impl From<io::Error> for PfmError {
    fn from(source: io::Error) -> Self {
        PfmError::Io {
            file: STREAM.into(),
            source,
        }
    }
}

fn format_err(offset: u64, message: impl Into<String>) -> PfmError {
    PfmError::Format {
        file: STREAM.into(),
        offset,
        message: message.into(),
    }
}

/// Reads one whitespace-terminated header token starting at `*offset`, consuming the single
/// whitespace byte after it. Returns the token and its start offset.
fn read_token<R: Read>(r: &mut R, offset: &mut u64, what: &str) -> Result<(String, u64), PfmError> {
    let start = *offset;
    let mut token = Vec::new();
    let mut byte = [0u8; 1];
    loop {
        let n = r.read(&mut byte)?;
        if n == 0 {
            return Err(format_err(
                *offset,
                format!("file ends inside the header, expected {what}"),
            ));
        }
        *offset += 1;
        if byte[0].is_ascii_whitespace() {
            if token.is_empty() {
                return Err(format_err(
                    *offset - 1,
                    format!("expected {what}, found whitespace"),
                ));
            }
            break;
        }
        token.push(byte[0]);
        if token.len() > MAX_TOKEN {
            return Err(format_err(
                start,
                format!("expected {what}, found a long run of bytes"),
            ));
        }
    }
    let token = String::from_utf8(token)
        .map_err(|_| format_err(start, format!("expected {what}, found non-ASCII bytes")))?;
    Ok((token, start))
}

/// Reads a PFM image from a stream. Errors name the byte offset; the file is `<stream>`
/// (use [`read_pfm_path`] for file names in errors).
pub fn read_pfm<R: Read>(mut r: R) -> Result<ImageF32, PfmError> {
    let mut offset = 0u64;
    let (magic, at) = read_token(&mut r, &mut offset, "\"PF\" or \"Pf\"")?;
    let channels = match magic.as_str() {
        "PF" => 3,
        "Pf" => 1,
        _ => {
            return Err(format_err(
                at,
                format!("expected \"PF\" or \"Pf\", found {magic:?}"),
            ))
        }
    };
    let mut dim = |what: &str| -> Result<u32, PfmError> {
        let (tok, at) = read_token(&mut r, &mut offset, what)?;
        match tok.parse::<u32>() {
            Ok(v) if v > 0 => Ok(v),
            _ => Err(format_err(
                at,
                format!("expected {what} (a positive integer), found {tok:?}"),
            )),
        }
    };
    let width = dim("width")?;
    let height = dim("height")?;
    let (tok, at) = read_token(&mut r, &mut offset, "scale")?;
    let scale: f64 = match tok.parse::<f64>() {
        Ok(s) if s.is_finite() && s != 0.0 => s,
        _ => {
            return Err(format_err(
                at,
                format!("expected a non-zero scale (its sign gives the byte order), found {tok:?}"),
            ))
        }
    };
    let little = scale < 0.0;
    let count = (width as u64)
        .checked_mul(height as u64)
        .and_then(|n| n.checked_mul(channels as u64))
        .filter(|&n| n <= usize::MAX as u64 / 4)
        .ok_or_else(|| format_err(at, format!("image {width}x{height} is too large")))?;
    let want = count * 4;
    // `take` + `read_to_end` grows with the data actually present, so a garbled header with
    // a huge size cannot make us allocate it up front.
    let mut bytes = Vec::new();
    r.by_ref().take(want).read_to_end(&mut bytes)?;
    if (bytes.len() as u64) < want {
        return Err(format_err(
            offset + bytes.len() as u64,
            format!(
                "file is truncated: expected {want} bytes of pixel data for {width}x{height}x{channels}, found {}",
                bytes.len()
            ),
        ));
    }
    let mut extra = [0u8; 1];
    if r.read(&mut extra)? != 0 {
        return Err(format_err(
            offset + want,
            "expected end of file after the pixel data",
        ));
    }
    let row_len = width as usize * channels as usize;
    let mut data = vec![0f32; count as usize];
    // File row i is image row height-1-i.
    for (i, file_row) in bytes.chunks_exact(row_len * 4).enumerate() {
        let y = height as usize - 1 - i;
        let out = &mut data[y * row_len..(y + 1) * row_len];
        for (o, b) in out.iter_mut().zip(file_row.chunks_exact(4)) {
            let b = [b[0], b[1], b[2], b[3]];
            *o = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(ImageF32 {
        width,
        height,
        channels,
        data,
    })
}

/// Reads a PFM file; errors name the file.
pub fn read_pfm_path(path: &Path) -> Result<ImageF32, PfmError> {
    let file = File::open(path).map_err(|e| PfmError::from(e).in_file(path))?;
    read_pfm(BufReader::new(file)).map_err(|e| e.in_file(path))
}

/// Writes `img` (1 or 3 channels) as little-endian PFM (`scale = -1`), rows bottom to top.
pub fn write_pfm<W: Write>(mut w: W, img: &ImageF32) -> Result<(), PfmError> {
    let magic = match img.channels {
        1 => "Pf",
        3 => "PF",
        c => {
            return Err(PfmError::Unsupported {
                file: STREAM.into(),
                message: format!("PFM holds 1 or 3 channels, the image has {c}"),
            })
        }
    };
    let row_len = img.width as usize * img.channels as usize;
    if img.width == 0 || img.height == 0 || img.data.len() != row_len * img.height as usize {
        return Err(PfmError::Unsupported {
            file: STREAM.into(),
            message: format!(
                "image {}x{}x{} has {} values",
                img.width,
                img.height,
                img.channels,
                img.data.len()
            ),
        });
    }
    write!(w, "{magic}\n{} {}\n-1\n", img.width, img.height)?;
    let mut buf = Vec::with_capacity(row_len * 4);
    for row in img.data.chunks_exact(row_len).rev() {
        buf.clear();
        for v in row {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Writes a PFM file atomically (temp name + rename); errors name the file.
pub fn write_pfm_path(path: &Path, img: &ImageF32) -> Result<(), PfmError> {
    write_atomic(path, |w| write_pfm(w, img)).map_err(|e| e.in_file(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: u32, h: u32, c: u32) -> ImageF32 {
        let mut img = ImageF32::filled(w, h, c, 0.0);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = i as f32 * 0.25 - 3.0;
        }
        img
    }

    #[test]
    fn round_trip_is_byte_identical() -> Result<(), PfmError> {
        for c in [1, 3] {
            let img = ramp(5, 3, c);
            let mut bytes = Vec::new();
            write_pfm(&mut bytes, &img)?;
            let back = read_pfm(&bytes[..])?;
            assert_eq!(back, img);
            let mut again = Vec::new();
            write_pfm(&mut again, &back)?;
            assert_eq!(again, bytes);
        }
        Ok(())
    }

    #[test]
    fn rows_are_stored_bottom_to_top() -> Result<(), PfmError> {
        let img = ramp(2, 3, 1);
        let mut bytes = Vec::new();
        write_pfm(&mut bytes, &img)?;
        let header = b"Pf\n2 3\n-1\n".len();
        let first = f32::from_le_bytes(bytes[header..header + 4].try_into().unwrap());
        // The first stored value is pixel (0, height-1).
        assert_eq!(first, img.get(0, 2, 0));
        Ok(())
    }

    #[test]
    fn reads_big_endian() -> Result<(), PfmError> {
        let mut bytes = b"PF\n1 2\n1.0\n".to_vec();
        // bottom row first: pixel (0,1) then (0,0)
        for v in [4.0f32, 5.0, 6.0, 1.0, 2.0, 3.0] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        let img = read_pfm(&bytes[..])?;
        assert_eq!(img.channels, 3);
        assert_eq!(img.pixel(0, 0), &[1.0, 2.0, 3.0]);
        assert_eq!(img.pixel(0, 1), &[4.0, 5.0, 6.0]);
        Ok(())
    }

    #[test]
    fn errors_name_offsets() {
        let err = read_pfm(&b"P7\n1 1\n-1\n"[..]).unwrap_err().to_string();
        assert!(err.contains("byte 0") && err.contains("\"P7\""), "{err}");
        let err = read_pfm(&b"Pf\n1 x\n-1\n"[..]).unwrap_err().to_string();
        assert!(err.contains("byte 5") && err.contains("height"), "{err}");
        let err = read_pfm(&b"Pf\n1 1\n0\n"[..]).unwrap_err().to_string();
        assert!(err.contains("byte 7") && err.contains("scale"), "{err}");
        let err = read_pfm(&b"Pf\n2 1\n-1\n\0\0\0\0\0"[..])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("byte 15") && err.contains("truncated"),
            "{err}"
        );
    }

    #[test]
    fn rejects_two_channels() {
        let img = ImageF32::filled(1, 1, 2, 0.0);
        assert!(write_pfm(Vec::new(), &img).is_err());
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
            let mut bytes = { let mut v = Vec::new(); write_pfm(&mut v, &ramp(3, 2, 3)).unwrap(); v };
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            bytes.truncate(cut.index(bytes.len() + 1).max(bytes.len() / 2));
            let _ = read_pfm(&bytes[..]);
        }
    }
}
