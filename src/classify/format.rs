//! The planarity model file (`model.bin`): little-endian, versioned, self-describing.
//!
//! ```text
//! offset  size        field
//! 0       8           magic "PMCLASS\0"
//! 8       2  u16      format version (MODEL_FORMAT_VERSION = 1)
//! 10      1  u8       method: 1 = kNN, 2 = logistic
//! 11      1  u8       reserved, 0
//! 12      2  u16      feature layout version (features::FEATURE_LAYOUT_VERSION)
//! 14      2  u16      feature dimension d (features::FEATURE_DIM)
//! 16      4  u32      FeatureSpec::cell
//! 20      4  u32      FeatureSpec::margin
//! 24      4  f32      FeatureSpec::lbp_threshold
//! 28      4  f32      FeatureSpec::geo_radius_px
//! 32      4  u32      FeatureSpec::geo_min_points
//! 36      4  f32      decision threshold on P(non-planar)
//! 40      4·d f32     standardisation mean
//! …       4·d f32     standardisation scale (z = (x − mean)·scale)
//! kNN:       u32 k, u32 n, n × u8 labels, n·d × f32 samples (standardised)
//! logistic:  f32 bias, d × f32 weights
//! ```
//! Nothing may follow. Every read error names the byte offset and what was expected there.

use std::io::{Read, Write};
use std::path::Path;

use super::features::{FeatureSpec, FEATURE_DIM, FEATURE_LAYOUT_VERSION};
use super::knn::KnnClassifier;
use super::logistic::LogisticClassifier;
use super::{Classifier, ClassifyError, PlanarityModel, Standardizer};
use crate::io::atomic::write_atomic;

/// File magic.
pub const MODEL_MAGIC: [u8; 8] = *b"PMCLASS\0";
/// Current format version.
pub const MODEL_FORMAT_VERSION: u16 = 1;
/// Method byte of a kNN model.
pub const METHOD_KNN: u8 = 1;
/// Method byte of a logistic model.
pub const METHOD_LOGISTIC: u8 = 2;
/// Upper bound on stored kNN samples (refuses absurd counts before allocating).
const MAX_SAMPLES: u32 = 10_000_000;

/// Serialises a model to bytes.
pub fn model_to_bytes(model: &PlanarityModel) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&MODEL_MAGIC);
    b.extend_from_slice(&MODEL_FORMAT_VERSION.to_le_bytes());
    b.push(match model.classifier {
        Classifier::Knn(_) => METHOD_KNN,
        Classifier::Logistic(_) => METHOD_LOGISTIC,
    });
    b.push(0);
    b.extend_from_slice(&FEATURE_LAYOUT_VERSION.to_le_bytes());
    b.extend_from_slice(&(FEATURE_DIM as u16).to_le_bytes());
    let s = &model.spec;
    b.extend_from_slice(&s.cell.to_le_bytes());
    b.extend_from_slice(&s.margin.to_le_bytes());
    b.extend_from_slice(&s.lbp_threshold.to_le_bytes());
    b.extend_from_slice(&s.geo_radius_px.to_le_bytes());
    b.extend_from_slice(&s.geo_min_points.to_le_bytes());
    b.extend_from_slice(&model.threshold.to_le_bytes());
    for v in model
        .standardizer
        .mean
        .iter()
        .chain(&model.standardizer.scale)
    {
        b.extend_from_slice(&v.to_le_bytes());
    }
    match &model.classifier {
        Classifier::Knn(k) => {
            b.extend_from_slice(&k.k.to_le_bytes());
            b.extend_from_slice(&(k.labels.len() as u32).to_le_bytes());
            b.extend_from_slice(&k.labels);
            for v in &k.samples {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        Classifier::Logistic(l) => {
            b.extend_from_slice(&l.bias.to_le_bytes());
            for v in &l.weights {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    b
}

/// Writes a model to any writer.
pub fn write_model<W: Write>(mut w: W, model: &PlanarityModel) -> Result<(), ClassifyError> {
    w.write_all(&model_to_bytes(model))
        .map_err(|e| ClassifyError::Io {
            file: "<stream>".into(),
            message: e.to_string(),
        })
}

/// Writes a model file atomically (temp name + rename).
pub fn write_model_path(path: &Path, model: &PlanarityModel) -> Result<(), ClassifyError> {
    let bytes = model_to_bytes(model);
    write_atomic(path, |w| std::io::Write::write_all(w, &bytes)).map_err(|e: std::io::Error| {
        ClassifyError::Io {
            file: path.display().to_string(),
            message: e.to_string(),
        }
    })
}

/// A cursor that reports the offset of whatever it failed to read.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], ClassifyError> {
        if self.bytes.len() - self.pos < n {
            return Err(ClassifyError::Format {
                file: String::new(),
                offset: self.pos as u64,
                message: format!(
                    "truncated: expected {what} ({n} bytes), {} bytes left",
                    self.bytes.len() - self.pos
                ),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8, ClassifyError> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16, ClassifyError> {
        let s = self.take(2, what)?;
        Ok(u16::from_le_bytes([s[0], s[1]]))
    }
    fn u32(&mut self, what: &str) -> Result<u32, ClassifyError> {
        let s = self.take(4, what)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
    fn f32(&mut self, what: &str) -> Result<f32, ClassifyError> {
        let at = self.pos;
        let s = self.take(4, what)?;
        let v = f32::from_le_bytes([s[0], s[1], s[2], s[3]]);
        if !v.is_finite() {
            return Err(bad(at, format!("{what} is {v} (want a finite number)")));
        }
        Ok(v)
    }
    fn f32s(&mut self, n: usize, what: &str) -> Result<Vec<f32>, ClassifyError> {
        (0..n).map(|_| self.f32(what)).collect()
    }
}

fn bad(offset: usize, message: String) -> ClassifyError {
    ClassifyError::Format {
        file: String::new(),
        offset: offset as u64,
        message,
    }
}

/// Parses a model from its bytes.
pub fn model_from_bytes(bytes: &[u8]) -> Result<PlanarityModel, ClassifyError> {
    let mut c = Cursor { bytes, pos: 0 };
    let magic = c.take(8, "magic \"PMCLASS\\0\"")?;
    if magic != MODEL_MAGIC {
        return Err(bad(
            0,
            format!("bad magic {magic:02x?}: not a planemap classifier model"),
        ));
    }
    let at = c.pos;
    let version = c.u16("format version")?;
    if version != MODEL_FORMAT_VERSION {
        return Err(bad(
            at,
            format!("format version {version} (this build reads {MODEL_FORMAT_VERSION})"),
        ));
    }
    let at = c.pos;
    let method = c.u8("method byte")?;
    if method != METHOD_KNN && method != METHOD_LOGISTIC {
        return Err(bad(
            at,
            format!("method {method} (want {METHOD_KNN} = knn or {METHOD_LOGISTIC} = logistic)"),
        ));
    }
    let at = c.pos;
    if c.u8("reserved byte")? != 0 {
        return Err(bad(at, "reserved byte is not 0".into()));
    }
    let at = c.pos;
    let layout = c.u16("feature layout version")?;
    if layout != FEATURE_LAYOUT_VERSION {
        return Err(bad(
            at,
            format!(
                "feature layout {layout} (this build computes layout {FEATURE_LAYOUT_VERSION})"
            ),
        ));
    }
    let at = c.pos;
    let dim = c.u16("feature dimension")? as usize;
    if dim != FEATURE_DIM {
        return Err(bad(
            at,
            format!("feature dimension {dim} (want {FEATURE_DIM})"),
        ));
    }
    let at = c.pos;
    let spec = FeatureSpec {
        cell: c.u32("feature cell size")?,
        margin: c.u32("feature margin")?,
        lbp_threshold: c.f32("LBP threshold")?,
        geo_radius_px: c.f32("geometric radius")?,
        geo_min_points: c.u32("geometric minimal points")?,
    };
    spec.validate()
        .map_err(|e| bad(at, format!("feature spec: {e}")))?;
    let at = c.pos;
    let threshold = c.f32("decision threshold")?;
    if !(0.0..=1.0).contains(&threshold) {
        return Err(bad(
            at,
            format!("decision threshold {threshold} (want 0..=1)"),
        ));
    }
    let mean = c.f32s(dim, "standardisation mean")?;
    let scale = c.f32s(dim, "standardisation scale")?;
    let classifier = if method == METHOD_KNN {
        let at = c.pos;
        let k = c.u32("knn k")?;
        if k == 0 {
            return Err(bad(at, "knn k = 0 (want ≥ 1)".into()));
        }
        let at = c.pos;
        let n = c.u32("knn sample count")?;
        if n == 0 || n > MAX_SAMPLES {
            return Err(bad(
                at,
                format!("knn sample count {n} (want 1..={MAX_SAMPLES})"),
            ));
        }
        let at = c.pos;
        let labels = c.take(n as usize, "knn labels")?.to_vec();
        if let Some(i) = labels.iter().position(|&l| l > 1) {
            return Err(bad(
                at + i,
                format!("knn label {} (want 0 or 1)", labels[i]),
            ));
        }
        let need = n as usize * dim * 4;
        if c.bytes.len() - c.pos < need {
            return Err(bad(
                c.pos,
                format!(
                    "truncated: expected {n} knn samples ({need} bytes), {} bytes left",
                    c.bytes.len() - c.pos
                ),
            ));
        }
        let samples = c.f32s(n as usize * dim, "knn sample value")?;
        Classifier::Knn(KnnClassifier::new(k, samples, labels)?)
    } else {
        let bias = c.f32("logistic bias")?;
        let weights = c.f32s(dim, "logistic weight")?;
        Classifier::Logistic(LogisticClassifier { weights, bias })
    };
    if c.pos != bytes.len() {
        return Err(bad(
            c.pos,
            format!("{} trailing bytes after the model", bytes.len() - c.pos),
        ));
    }
    Ok(PlanarityModel {
        spec,
        standardizer: Standardizer { mean, scale },
        threshold,
        classifier,
    })
}

/// Reads a model from any reader (errors name `<stream>`).
pub fn read_model<R: Read>(mut r: R) -> Result<PlanarityModel, ClassifyError> {
    let mut bytes = Vec::new();
    r.read_to_end(&mut bytes).map_err(|e| ClassifyError::Io {
        file: "<stream>".into(),
        message: e.to_string(),
    })?;
    model_from_bytes(&bytes).map_err(|e| e.in_file("<stream>"))
}

/// Reads a model file; errors name the file and the byte offset.
pub fn read_model_path(path: &Path) -> Result<PlanarityModel, ClassifyError> {
    let bytes = std::fs::read(path).map_err(|e| ClassifyError::Io {
        file: path.display().to_string(),
        message: e.to_string(),
    })?;
    model_from_bytes(&bytes).map_err(|e| e.in_file(&path.display().to_string()))
}
