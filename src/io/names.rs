//! Output file names derived from COLMAP image names.

use std::path::Path;

/// `planemaps/NAME.png` etc. use the image name without its extension.
pub fn output_stem(name: &str) -> String {
    Path::new(name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.to_string())
}
