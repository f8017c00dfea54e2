//! Output file names derived from COLMAP image names.
//!
//! A COLMAP image name is a relative path under the images folder and may hold subfolders
//! (`cam0/frame_0001.png`, the usual multi-camera layout). planemap's outputs keep it:
//!
//! - under `stereo/` the whole name, as COLMAP's `stereo_fusion` expects
//!   (`stereo/depth_maps/cam0/frame_0001.png.geometric.bin`);
//! - elsewhere the name without its extension, subfolders kept ([`output_stem`]:
//!   `depth/cam0/frame_0001.pfm`).
//!
//! [`check_image_names`] rejects, before any work, a name that would leave the output folder
//! (absolute, or holding `..`) and two names that would map to one output (`x.png` beside
//! `x.jpg`).

use std::collections::BTreeMap;
use std::path::{Component, Path};

use thiserror::Error;

/// A set of image names that cannot be turned into output names.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum NameError {
    /// A name that is empty, absolute or climbs out of its folder.
    #[error("image name {0:?} is not a relative path inside the images folder (no `..`, no root)")]
    NotRelative(String),
    /// Two names that map to the same output files.
    #[error(
        "images {first:?} and {second:?} would both be written as {stem:?} (depth/{stem}.pfm, \
         planemaps/{stem}.png): rename one of them"
    )]
    Collision {
        /// The first image (in model order).
        first: String,
        /// The second.
        second: String,
        /// The output name they share.
        stem: String,
    },
}

/// The output name of an image: its name without the extension, subfolders kept, with `/`
/// separators (`cam0/frame.png` → `cam0/frame`; `x.png` → `x`).
pub fn output_stem(name: &str) -> String {
    let path = Path::new(name);
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.to_string());
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(parent) => {
            let parts: Vec<String> = parent
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            format!("{}/{stem}", parts.join("/"))
        }
        None => stem,
    }
}

/// Whether `name` is a relative path that stays inside its folder.
fn is_relative_inside(name: &str) -> bool {
    let path = Path::new(name);
    !name.is_empty()
        && !name.contains('\0')
        && path.file_name().is_some()
        && path
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// Checks that every name is a relative path inside the images folder and that no two map
/// to the same output name; the error names the offending images.
pub fn check_image_names<'a>(names: impl IntoIterator<Item = &'a str>) -> Result<(), NameError> {
    let mut seen: BTreeMap<String, &str> = BTreeMap::new();
    for name in names {
        if !is_relative_inside(name) {
            return Err(NameError::NotRelative(name.to_string()));
        }
        let stem = output_stem(name);
        if let Some(first) = seen.insert(stem.clone(), name) {
            return Err(NameError::Collision {
                first: first.to_string(),
                second: name.to_string(),
                stem,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_keep_subfolders_and_drop_the_extension() {
        assert_eq!(output_stem("view_000.png"), "view_000");
        assert_eq!(output_stem("cam0/frame.png"), "cam0/frame");
        assert_eq!(output_stem("a/b/c.d.jpg"), "a/b/c.d");
        assert_eq!(output_stem("noext"), "noext");
    }

    #[test]
    fn collisions_and_escapes_are_named() {
        check_image_names(["cam0/frame.png", "cam1/frame.png", "x.png"]).unwrap();
        let err = check_image_names(["x.png", "y.png", "x.jpg"]).unwrap_err();
        assert_eq!(
            err,
            NameError::Collision {
                first: "x.png".into(),
                second: "x.jpg".into(),
                stem: "x".into()
            }
        );
        assert!(err.to_string().contains("rename one"), "{err}");
        for bad in ["../x.png", "/abs/x.png", "", "a/../../x.png"] {
            assert_eq!(
                check_image_names([bad]).unwrap_err(),
                NameError::NotRelative(bad.to_string()),
                "{bad:?}"
            );
        }
    }
}
