//! What makes `--resume` safe: a fingerprint of a run's inputs and configuration.
//!
//! A run writes `fingerprint.json` (and `config.toml`) before any other output. `--resume`
//! refuses an output folder whose fingerprint is not this run's — other inputs, or another
//! configuration, whose changed keys the error lists — instead of reusing results made
//! with them. Each view's outputs carry their own fingerprint (`planemaps/STEM.fingerprint`,
//! written just before the label map that marks the view complete): it adds the crease
//! hypotheses the view was labelled with, so a view labelled when other views voted the
//! creases (`--views 0,1` then `--resume`) is labelled again, not reloaded.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{write_err, Config, PipelineError};
use crate::io::output_stem;
use crate::scene::Scene;

/// The fingerprint file of a run's output folder.
pub const FINGERPRINT_FILE: &str = "fingerprint.json";

/// 64-bit FNV-1a: a stable, dependency-free hash (not a cryptographic one: it guards
/// against mistakes, not attacks).
#[derive(Debug, Clone, Copy)]
pub(super) struct Fnv(u64);

impl Fnv {
    pub(super) fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    pub(super) fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        // The length too, so that ("ab", "c") and ("a", "bc") differ.
        for b in (bytes.len() as u64).to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }

    pub(super) fn f64s(&mut self, values: impl IntoIterator<Item = f64>) -> &mut Self {
        let bytes: Vec<u8> = values.into_iter().flat_map(|v| v.to_le_bytes()).collect();
        self.bytes(&bytes)
    }

    pub(super) fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// A run's fingerprint: hashes of its inputs (model, cameras, poses, points, image bytes)
/// and of its configuration.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// planemap's version that wrote it.
    pub planemap: String,
    /// Hash of the scene: views (names, cameras, poses), sparse points, image file bytes.
    pub inputs: String,
    /// Hash of the effective configuration.
    pub config: String,
    /// The views whose first labelling voted the saved crease hypotheses (image names),
    /// once the crease pass has run; `--resume` reloads those hypotheses only for the same
    /// views.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crease_voters: Option<Vec<String>>,
}

impl Fingerprint {
    /// The fingerprint of running `cfg` on `scene` (reads every image file once).
    pub fn of(scene: &Scene, cfg: &Config) -> Result<Fingerprint, PipelineError> {
        let mut h = Fnv::new();
        for v in &scene.views {
            h.bytes(v.name.as_bytes());
            h.bytes(format!("{:?}", v.camera).as_bytes());
            let q = v.cam_from_world.rotation.quaternion();
            let t = v.cam_from_world.translation.vector;
            h.f64s([q.w, q.i, q.j, q.k, t.x, t.y, t.z]);
            if let Some(path) = &v.image_path {
                let bytes = std::fs::read(path).map_err(|e| write_err(path, e))?;
                h.bytes(&bytes);
            }
        }
        let cloud = &scene.cloud;
        h.f64s(cloud.positions.iter().flat_map(|p| [p.x, p.y, p.z]));
        h.f64s(cloud.confidence.iter().copied());
        for t in &cloud.tracks {
            let bytes: Vec<u8> = t.iter().flat_map(|v| v.to_le_bytes()).collect();
            h.bytes(&bytes);
        }
        if let Some(normals) = &cloud.normals {
            h.f64s(normals.iter().flat_map(|n| [n.x, n.y, n.z]));
        }
        let text = toml::to_string(cfg)
            .map_err(|e| PipelineError::Config(format!("cannot serialise the config: {e}")))?;
        let mut c = Fnv::new();
        c.bytes(text.as_bytes());
        Ok(Fingerprint {
            planemap: env!("CARGO_PKG_VERSION").to_string(),
            inputs: h.hex(),
            config: c.hex(),
            crease_voters: None,
        })
    }

    /// What a view's outputs were made from: this run plus the crease hypotheses offered.
    pub(super) fn view_key(&self, creases: &str) -> String {
        let mut h = Fnv::new();
        h.bytes(self.inputs.as_bytes())
            .bytes(self.config.as_bytes())
            .bytes(creases.as_bytes());
        h.hex()
    }

    /// Writes `out/fingerprint.json`.
    pub fn write(&self, out: &Path) -> Result<(), PipelineError> {
        let path = out.join(FINGERPRINT_FILE);
        let json = serde_json::to_string_pretty(self).map_err(|e| write_err(&path, e))?;
        crate::io::atomic::write_atomic::<std::io::Error, _>(&path, |f| {
            std::io::Write::write_all(f, json.as_bytes())
        })
        .map_err(|e| write_err(&path, e))
    }

    /// Checks that `out` holds a run of these inputs and this configuration, for
    /// `--resume`, and returns that run's fingerprint. The error says what differs: the
    /// inputs, or the configuration keys that changed (read from the folder's `config.toml`),
    /// with their old and new values.
    pub fn check_resumable(&self, out: &Path, cfg: &Config) -> Result<Fingerprint, PipelineError> {
        let path = out.join(FINGERPRINT_FILE);
        let refuse = |why: String| {
            PipelineError::Config(format!(
                "--resume: {why}; run without --resume to start over in {}, or write to \
                 another folder",
                out.display()
            ))
        };
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(refuse(format!(
                    "{} has no {FINGERPRINT_FILE}: nothing a run of this version can resume",
                    out.display()
                )))
            }
            Err(e) => return Err(write_err(&path, e)),
        };
        let before: Fingerprint = serde_json::from_str(&text)
            .map_err(|e| refuse(format!("{}: unreadable ({e})", path.display())))?;
        if before.inputs != self.inputs {
            return Err(refuse(
                "the inputs (model, cameras, points or image files) differ from the run there"
                    .into(),
            ));
        }
        if before.config != self.config {
            let changed = Config::from_path(&out.join("config.toml"))
                .map(|old| changed_keys(&old, cfg))
                .unwrap_or_default();
            return Err(refuse(if changed.is_empty() {
                "the configuration differs from the run there".into()
            } else {
                format!(
                    "the configuration differs from the run there: {}",
                    changed.join(", ")
                )
            }));
        }
        Ok(before)
    }
}

/// `key: old → new` for every key whose value differs between two configurations.
pub fn changed_keys(old: &Config, new: &Config) -> Vec<String> {
    fn walk(a: &toml::Value, b: &toml::Value, path: &str, out: &mut Vec<String>) {
        match (a, b) {
            (toml::Value::Table(x), toml::Value::Table(y)) => {
                let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
                for k in keys {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    match (x.get(k), y.get(k)) {
                        (Some(u), Some(v)) => walk(u, v, &p, out),
                        (u, v) => out.push(format!(
                            "{p}: {} → {}",
                            u.map_or("(unset)".into(), |u| u.to_string()),
                            v.map_or("(unset)".into(), |v| v.to_string())
                        )),
                    }
                }
            }
            (u, v) if u != v => out.push(format!("{path}: {u} → {v}")),
            _ => {}
        }
    }
    let (Ok(a), Ok(b)) = (toml::Value::try_from(old), toml::Value::try_from(new)) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    walk(&a, &b, "", &mut out);
    out
}

/// The key of the plane hypotheses a view is offered (every hypothesis, crease ones
/// included): part of what its outputs were made from.
pub(super) fn hypotheses_key(hypotheses: &[crate::hypotheses::PlaneHypothesis]) -> String {
    let mut h = Fnv::new();
    h.f64s(hypotheses.iter().flat_map(|p| {
        let n = p.plane.normal;
        [
            n.x,
            n.y,
            n.z,
            p.plane.offset,
            p.axis.map_or(-1.0, |a| a as f64),
        ]
    }));
    h.hex()
}

/// Writes the key a view's outputs are being made with (before the label map that marks
/// them complete).
pub(super) fn write_view_key(out: &Path, view_name: &str, key: &str) -> Result<(), PipelineError> {
    let path = view_key_path(out, view_name);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
    }
    crate::io::atomic::write_atomic::<std::io::Error, _>(&path, |f| {
        std::io::Write::write_all(f, key.as_bytes())
    })
    .map_err(|e| write_err(&path, e))
}

/// `out/planemaps/STEM.fingerprint`: the key a view's outputs were made with.
pub(super) fn view_key_path(out: &Path, view_name: &str) -> PathBuf {
    out.join("planemaps")
        .join(format!("{}.fingerprint", output_stem(view_name)))
}

/// Whether the view's outputs in `out` were made with `key`.
pub(super) fn view_key_matches(out: &Path, view_name: &str, key: &str) -> bool {
    std::fs::read_to_string(view_key_path(out, view_name)).is_ok_and(|k| k.trim() == key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_is_the_reference_hash_and_length_separated() {
        // FNV-1a of the empty input, before the length: the published offset basis.
        assert_eq!(Fnv::new().hex(), "cbf29ce484222325");
        let mut a = Fnv::new();
        a.bytes(b"ab").bytes(b"c");
        let mut b = Fnv::new();
        b.bytes(b"a").bytes(b"bc");
        assert_ne!(a.hex(), b.hex());
    }

    #[test]
    fn changed_keys_name_old_and_new_values() {
        let old = Config::default();
        let mut new = old.clone();
        new.planemap.lambda = 0.5;
        new.nonplanar.model = Some("m.bin".into());
        let changed = changed_keys(&old, &new);
        assert_eq!(
            changed,
            vec![
                "nonplanar.model: (unset) → \"m.bin\"".to_string(),
                "planemap.lambda: 0.25 → 0.5".to_string()
            ]
        );
        assert!(changed_keys(&old, &old).is_empty());
    }
}
