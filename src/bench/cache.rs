//! Rendered-scene cache: a scene is rendered once per (scene file bytes, renderer version,
//! image size) and reused by later benchmark runs.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::progress::Progress;
use crate::synth::{RenderOptions, SceneSpec};
use crate::workspace::render_to_workspace;

use super::BenchError;

/// Bump when the renderer's output changes for the same scene file (textures, sparse
/// sampling, ground-truth formats): cached renders of older versions are then ignored.
pub const RENDERER_VERSION: u32 = 2;

/// Marker written last into a complete cache entry.
const COMPLETE: &str = ".complete";

/// 64-bit FNV-1a: a fixed, documented hash (std's hasher may change between releases).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The cache key of a scene file at a size: the file's bytes, [`RENDERER_VERSION`] and the
/// size override.
pub fn cache_key(scene_bytes: &[u8], size: Option<(u32, u32)>) -> u64 {
    let mut bytes = scene_bytes.to_vec();
    bytes.extend_from_slice(&RENDERER_VERSION.to_le_bytes());
    if let Some((w, h)) = size {
        bytes.extend_from_slice(&w.to_le_bytes());
        bytes.extend_from_slice(&h.to_le_bytes());
    }
    fnv1a64(&bytes)
}

/// A rendered scene on disk.
#[derive(Debug, Clone)]
pub struct CachedScene {
    /// The parsed scene description.
    pub spec: SceneSpec,
    /// The workspace (images/, sparse/, gt/).
    pub dir: PathBuf,
    /// Whether it came from the cache.
    pub hit: bool,
    /// Seconds spent rendering and writing (0 on a hit).
    pub render_seconds: f64,
}

/// Renders `scene_path` into `cache_root/NAME-KEY/` unless a complete entry exists.
pub fn render_cached(
    scene_path: &Path,
    size: Option<(u32, u32)>,
    cache_root: &Path,
    progress: &Progress,
) -> Result<CachedScene, BenchError> {
    let bytes = std::fs::read(scene_path).map_err(|e| BenchError::Io {
        path: scene_path.to_path_buf(),
        message: e.to_string(),
    })?;
    let spec = SceneSpec::from_path(scene_path)?;
    let key = cache_key(&bytes, size);
    let dir = cache_root.join(format!("{}-{key:016x}", spec.name));
    if dir.join(COMPLETE).is_file() {
        return Ok(CachedScene {
            spec,
            dir,
            hit: true,
            render_seconds: 0.0,
        });
    }
    let io = |path: &Path, e: std::io::Error| BenchError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    // Render beside the final name and rename into place, so an interrupted render never
    // looks complete.
    let tmp = cache_root.join(format!(".{}-{key:016x}.tmp", spec.name));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    }
    std::fs::create_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    let t = Instant::now();
    let opts = RenderOptions {
        width: size.map(|s| s.0),
        height: size.map(|s| s.1),
        seed_override: None,
    };
    render_to_workspace(&spec, &opts, &tmp, progress)?;
    std::fs::write(tmp.join(COMPLETE), format!("{key:016x}\n")).map_err(|e| io(&tmp, e))?;
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| io(&dir, e))?;
    }
    std::fs::rename(&tmp, &dir).map_err(|e| io(&dir, e))?;
    Ok(CachedScene {
        spec,
        dir,
        hit: false,
        render_seconds: t.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_reference_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn key_depends_on_bytes_and_size() {
        let a = cache_key(b"name = \"x\"", None);
        assert_ne!(a, cache_key(b"name = \"y\"", None));
        assert_ne!(a, cache_key(b"name = \"x\"", Some((96, 72))));
        assert_eq!(a, cache_key(b"name = \"x\"", None));
    }
}
