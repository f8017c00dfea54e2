//! A small reader and writer for NumPy `.npy` files (format versions 1–3, little-endian,
//! C order), enough for the solver exchange format.
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 6] = b"\x93NUMPY";

/// Errors of the `.npy` reader and writer.
#[derive(Debug, thiserror::Error)]
pub enum NpyError {
    /// An I/O failure.
    #[error("i/o error: {0}")]
    Io(#[from] std::io::Error),
    /// The header is malformed.
    #[error("byte {offset}: {message}")]
    Header {
        /// Byte offset in the file where the problem was found.
        offset: usize,
        /// What was expected.
        message: String,
    },
    /// The element type is not supported.
    #[error("unsupported dtype {0:?} (expected one of <f4 <f8 <i1..<i8 <u1..<u8 |b1, C order)")]
    Dtype(String),
    /// The payload is shorter than the shape says.
    #[error("byte {offset}: data truncated, expected {expected} bytes of array data, got {got}")]
    Truncated {
        /// Offset of the payload.
        offset: usize,
        /// Bytes expected.
        expected: usize,
        /// Bytes present.
        got: usize,
    },
    /// Values cannot be represented in the requested type.
    #[error("value {value} at index {index} is not a valid {wanted}")]
    Value {
        /// Flat index of the value.
        index: usize,
        /// The value.
        value: f64,
        /// The type wanted.
        wanted: &'static str,
    },
    /// An error in a named file.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: Box<NpyError>,
    },
}

impl NpyError {
    fn in_file(self, path: &Path) -> NpyError {
        NpyError::File {
            path: path.to_path_buf(),
            source: Box::new(self),
        }
    }
}

/// Element types read from `.npy` files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    /// `<f4`
    F32,
    /// `<f8`
    F64,
    /// Signed integer of this many bytes.
    Int(u8),
    /// Unsigned integer (or bool) of this many bytes.
    UInt(u8),
}

impl Dtype {
    fn parse(s: &str) -> Option<Dtype> {
        let (endian, rest) = s.split_at(1);
        let single = matches!(rest, "b1" | "u1" | "i1");
        if !(endian == "<" || (endian == "|" && single)) {
            return None;
        }
        Some(match rest {
            "f4" => Dtype::F32,
            "f8" => Dtype::F64,
            "i1" => Dtype::Int(1),
            "i2" => Dtype::Int(2),
            "i4" => Dtype::Int(4),
            "i8" => Dtype::Int(8),
            "u1" | "b1" => Dtype::UInt(1),
            "u2" => Dtype::UInt(2),
            "u4" => Dtype::UInt(4),
            "u8" => Dtype::UInt(8),
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Dtype::F32 => 4,
            Dtype::F64 => 8,
            Dtype::Int(b) | Dtype::UInt(b) => b as usize,
        }
    }
}

/// An array read from a `.npy` file: its shape, element type and raw little-endian bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// Shape (C order).
    pub shape: Vec<usize>,
    /// Element type.
    pub dtype: Dtype,
    bytes: Vec<u8>,
}

impl NpyArray {
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }
    /// Whether the array has no elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Element `i` as `f64` (64-bit integers above 2^53 lose precision).
    fn get(&self, i: usize) -> f64 {
        let s = self.dtype.size();
        let b = &self.bytes[i * s..(i + 1) * s];
        let mut w = [0u8; 8];
        w[..s].copy_from_slice(b);
        match self.dtype {
            Dtype::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Dtype::F64 => f64::from_le_bytes(w),
            Dtype::UInt(_) => u64::from_le_bytes(w) as f64,
            Dtype::Int(n) => {
                let shift = 64 - 8 * n as u32;
                ((i64::from_le_bytes(w) << shift) >> shift) as f64
            }
        }
    }
    /// All elements as `f64`.
    pub fn to_f64(&self) -> Vec<f64> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }
    /// All elements as `u32`; fails on negative, fractional or too large values.
    pub fn to_u32(&self) -> Result<Vec<u32>, NpyError> {
        (0..self.len())
            .map(|i| {
                let v = self.get(i);
                if v >= 0.0 && v <= u32::MAX as f64 && v.fract() == 0.0 {
                    Ok(v as u32)
                } else {
                    Err(NpyError::Value {
                        index: i,
                        value: v,
                        wanted: "u32",
                    })
                }
            })
            .collect()
    }
}

fn header_err(offset: usize, message: impl Into<String>) -> NpyError {
    NpyError::Header {
        offset,
        message: message.into(),
    }
}

/// Extracts the value text after `'key':` in the header dict.
fn dict_value<'h>(header: &'h str, key: &str, base: usize) -> Result<&'h str, NpyError> {
    let pat = format!("'{key}':");
    let at = header
        .find(&pat)
        .ok_or_else(|| header_err(base, format!("header has no '{key}' entry")))?;
    Ok(header[at + pat.len()..].trim_start())
}

/// Reads one array from a stream.
pub fn read_npy(mut r: impl Read) -> Result<NpyArray, NpyError> {
    let mut pre = [0u8; 8];
    r.read_exact(&mut pre)?;
    if &pre[..6] != MAGIC {
        return Err(header_err(0, "not a .npy file (bad magic)"));
    }
    let major = pre[6];
    let hlen = match major {
        1 => {
            let mut b = [0u8; 2];
            r.read_exact(&mut b)?;
            u16::from_le_bytes(b) as usize
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            r.read_exact(&mut b)?;
            u32::from_le_bytes(b) as usize
        }
        v => return Err(header_err(6, format!("unsupported format version {v}"))),
    };
    let base = if major == 1 { 10 } else { 12 };
    let mut hb = vec![0u8; hlen];
    r.read_exact(&mut hb)?;
    let header = String::from_utf8(hb).map_err(|_| header_err(base, "header is not text"))?;
    let descr = dict_value(&header, "descr", base)?;
    let descr = descr
        .strip_prefix('\'')
        .and_then(|d| d.split('\'').next())
        .ok_or_else(|| header_err(base, "descr is not a quoted string"))?;
    let dtype = Dtype::parse(descr).ok_or_else(|| NpyError::Dtype(descr.to_string()))?;
    let fortran = dict_value(&header, "fortran_order", base)?;
    if !fortran.starts_with("False") {
        return Err(NpyError::Dtype(format!("{descr} in Fortran order")));
    }
    let shape_txt = dict_value(&header, "shape", base)?;
    let inner = shape_txt
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| header_err(base, "shape is not a tuple"))?;
    let shape = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.trim_end_matches('L')
                .parse::<usize>()
                .map_err(|_| header_err(base, format!("bad shape entry {s:?}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let n: usize = shape.iter().product();
    let expected = n * dtype.size();
    let mut bytes = Vec::with_capacity(expected);
    r.take(expected as u64).read_to_end(&mut bytes)?;
    if bytes.len() != expected {
        return Err(NpyError::Truncated {
            offset: base + hlen,
            expected,
            got: bytes.len(),
        });
    }
    Ok(NpyArray {
        shape,
        dtype,
        bytes,
    })
}

/// Reads a `.npy` file; errors name the file.
pub fn read_npy_path(path: &Path) -> Result<NpyArray, NpyError> {
    let f = File::open(path).map_err(|e| NpyError::from(e).in_file(path))?;
    read_npy(BufReader::new(f)).map_err(|e| e.in_file(path))
}

/// Element types the writer supports.
pub trait NpyElement: Copy {
    /// The `descr` string, e.g. `<f8`.
    const DESCR: &'static str;
    /// Appends the little-endian bytes.
    fn put(self, out: &mut Vec<u8>);
}
macro_rules! elem {
    ($t:ty, $d:expr) => {
        impl NpyElement for $t {
            const DESCR: &'static str = $d;
            fn put(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
        }
    };
}
elem!(f32, "<f4");
elem!(f64, "<f8");
elem!(i32, "<i4");
elem!(i64, "<i8");
elem!(u32, "<u4");

/// Writes an array (format version 1.0, C order). Panics if `shape` does not match the data
/// length (a programming error).
pub fn write_npy<E: NpyElement>(
    mut w: impl Write,
    shape: &[usize],
    data: &[E],
) -> Result<(), NpyError> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "shape does not match data"
    );
    let shape_txt = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}",
        E::DESCR,
        shape_txt
    );
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for &v in data {
        v.put(&mut out);
    }
    w.write_all(&out)?;
    Ok(())
}

/// Writes a `.npy` file via a temporary name in the same directory, renamed into place.
pub fn write_npy_path<E: NpyElement>(
    path: &Path,
    shape: &[usize],
    data: &[E],
) -> Result<(), NpyError> {
    let tmp = path.with_extension("npy.tmp");
    let go = || -> Result<(), NpyError> {
        let mut f = BufWriter::new(File::create(&tmp)?);
        write_npy(&mut f, shape, data)?;
        f.flush()?;
        drop(f);
        std::fs::rename(&tmp, path)?;
        Ok(())
    };
    go().map_err(|e| e.in_file(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_all_writable_types() -> Result<(), NpyError> {
        let mut buf = Vec::new();
        write_npy(&mut buf, &[2, 3], &[1.5f64, -2.0, 3.0, 4.0, 5.0, 6.25])?;
        assert_eq!((buf.len() - 48) % 64, 0); // header padded to 64 bytes, then 48 data bytes
        let a = read_npy(&buf[..])?;
        assert_eq!(a.shape, vec![2, 3]);
        assert_eq!(a.to_f64(), vec![1.5, -2.0, 3.0, 4.0, 5.0, 6.25]);
        let mut buf = Vec::new();
        write_npy(&mut buf, &[3], &[-7i32, 0, 9])?;
        let a = read_npy(&buf[..])?;
        assert_eq!(a.dtype, Dtype::Int(4));
        assert_eq!(a.to_f64(), vec![-7.0, 0.0, 9.0]);
        assert!(matches!(a.to_u32(), Err(NpyError::Value { index: 0, .. })));
        let mut buf = Vec::new();
        write_npy(&mut buf, &[2], &[1u32, 4_000_000_000])?;
        assert_eq!(read_npy(&buf[..])?.to_u32()?, vec![1, 4_000_000_000]);
        Ok(())
    }

    #[test]
    fn reads_numpy_written_header_and_rejects_garbage() {
        // Exactly what numpy 1.x writes for np.arange(3, dtype='<i8').
        let dict = b"{'descr': '<i8', 'fortran_order': False, 'shape': (3,), }";
        let mut f = b"\x93NUMPY\x01\x00v\x00".to_vec();
        f.extend_from_slice(dict);
        f.extend(std::iter::repeat_n(b' ', 118 - dict.len() - 1));
        f.push(b'\n');
        for v in [0i64, 1, -2] {
            f.extend_from_slice(&v.to_le_bytes());
        }
        let a = read_npy(&f[..]).unwrap();
        assert_eq!(a.to_f64(), vec![0.0, 1.0, -2.0]);
        let short = &f[..f.len() - 3];
        match read_npy(short) {
            Err(NpyError::Truncated {
                offset,
                expected,
                got,
            }) => {
                assert_eq!((offset, expected, got), (128, 24, 21));
            }
            other => panic!("expected truncation, got {other:?}"),
        }
        assert!(matches!(
            read_npy(&b"PK\x03\x04xxxxxxxx"[..]),
            Err(NpyError::Header { offset: 0, .. })
        ));
        let mut fortran = f.clone();
        let at = fortran.windows(5).position(|w| w == b"False").unwrap();
        fortran[at..at + 5].copy_from_slice(b"True ");
        assert!(matches!(read_npy(&fortran[..]), Err(NpyError::Dtype(_))));
    }

    #[test]
    fn path_errors_name_the_file() {
        let e = read_npy_path(Path::new("/nonexistent/x.npy")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/x.npy"));
    }
}
