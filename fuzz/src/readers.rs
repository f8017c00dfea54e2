//! The byte-level entry point of every planemap reader, as the fuzz targets drive it.
//!
//! Shared, through `#[path]`, by the fuzz targets (`fuzz/fuzz_targets/*.rs`) and by the
//! regular test `tests/fuzz_corpus.rs`, which replays every committed corpus and crasher file
//! through the same functions, so CI guards them without a fuzzer.
//!
//! Each function feeds `data` to a reader and returns `Ok(())` or the reader's error
//! message. A panic (including an `assert!` below on what an accepted input promises) is a
//! bug.

use planemap::io::colmap::{
    read_cameras_bin, read_cameras_text, read_images_bin, read_images_text, read_points3d_bin,
    read_points3d_text,
};

/// What one reader made of an input: accepted, or its error message.
pub type Outcome = Result<(), String>;

/// A reader entry point.
pub type Reader = fn(&[u8]) -> Outcome;

/// Every target: its name (the `fuzz/corpus/<name>/` folder) and its entry point.
pub const TARGETS: &[(&str, Reader)] = &[
    ("colmap_bin_cameras", colmap_bin_cameras),
    ("colmap_bin_images", colmap_bin_images),
    ("colmap_bin_points3d", colmap_bin_points3d),
    ("colmap_text_cameras", colmap_text_cameras),
    ("colmap_text_images", colmap_text_images),
    ("colmap_text_points3d", colmap_text_points3d),
    ("pmvs_patch", pmvs_patch),
    ("pmvs_camera", pmvs_camera),
    ("pmvs_image_header", pmvs_image_header),
    ("ply", ply),
    ("pfm", pfm),
    ("dense_map", dense_map),
    ("label_png", label_png),
    ("scene_toml", scene_toml),
    ("config_toml", config_toml),
    ("classifier_model", classifier_model),
];

fn msg(e: impl std::fmt::Display) -> String {
    e.to_string()
}

fn cameras(cams: &[planemap::io::colmap::ColmapCamera]) {
    for c in cams {
        // Accepted records are valid cameras; usability may still fail, by error.
        assert!(c.camera.validate().is_ok(), "{:?}", c.camera);
        let _ = c.camera.check_usable();
        let _ = c.camera.undistorted();
    }
}

fn images(images: &[planemap::io::colmap::ColmapImage]) {
    for im in images {
        // The reader checked the quaternion: the pose must build.
        let pose = planemap::geometry::rigid_from_colmap(im.qvec, im.tvec);
        assert!(pose.is_ok(), "accepted image {} has {pose:?}", im.image_id);
    }
}

/// `cameras.bin`.
pub fn colmap_bin_cameras(data: &[u8]) -> Outcome {
    cameras(&read_cameras_bin(data).map_err(msg)?);
    Ok(())
}

/// `images.bin`.
pub fn colmap_bin_images(data: &[u8]) -> Outcome {
    images(&read_images_bin(data).map_err(msg)?);
    Ok(())
}

/// `points3D.bin`.
pub fn colmap_bin_points3d(data: &[u8]) -> Outcome {
    read_points3d_bin(data).map_err(msg)?;
    Ok(())
}

/// `cameras.txt`.
pub fn colmap_text_cameras(data: &[u8]) -> Outcome {
    cameras(&read_cameras_text(data).map_err(msg)?);
    Ok(())
}

/// `images.txt`.
pub fn colmap_text_images(data: &[u8]) -> Outcome {
    images(&read_images_text(data).map_err(msg)?);
    Ok(())
}

/// `points3D.txt`.
pub fn colmap_text_points3d(data: &[u8]) -> Outcome {
    read_points3d_text(data).map_err(msg)?;
    Ok(())
}

/// PMVS `.patch`.
pub fn pmvs_patch(data: &[u8]) -> Outcome {
    let patches = planemap::io::pmvs::read_patches(data).map_err(msg)?;
    for p in &patches {
        assert!(p.position.iter().all(|v| v.is_finite()), "{p:?}");
        assert!((p.normal.norm() - 1.0).abs() < 1e-9, "{p:?}");
    }
    Ok(())
}

/// PMVS camera file (`txt/%08d.txt`), then the camera it describes for a 640x480 image.
pub fn pmvs_camera(data: &[u8]) -> Outcome {
    let p = planemap::io::pmvs::read_projection(data).map_err(msg)?;
    let (camera, _) = planemap::io::pmvs::camera_from_projection(&p, 640, 480).map_err(msg)?;
    assert!(camera.check_usable().is_ok(), "{camera:?}");
    Ok(())
}

/// The image-header size reader PMVS workspaces use (`visualize/`).
pub fn pmvs_image_header(data: &[u8]) -> Outcome {
    let (w, h) = planemap::io::pmvs::image_size(data).map_err(msg)?;
    assert!(w > 0 && h > 0);
    Ok(())
}

/// PLY, as a point cloud and as a mesh.
pub fn ply(data: &[u8]) -> Outcome {
    let points = planemap::io::ply::read_ply_points(data).map(|p| {
        let n = p.positions.len();
        assert!(p.normals.as_ref().is_none_or(|v| v.len() == n));
        assert!(p.colors.as_ref().is_none_or(|v| v.len() == n));
    });
    let mesh = planemap::io::ply::read_ply_mesh(data).map(|m| {
        let n = m.vertices.len();
        assert!(m.faces.iter().flatten().all(|&i| (i as usize) < n));
        assert!(m.vertex_colors.as_ref().is_none_or(|v| v.len() == n));
    });
    match (points, mesh) {
        (Err(a), Err(b)) => Err(format!("{a}; {b}")),
        _ => Ok(()),
    }
}

/// PFM.
pub fn pfm(data: &[u8]) -> Outcome {
    let img = planemap::io::pfm::read_pfm(data).map_err(msg)?;
    assert_eq!(
        img.data.len(),
        img.width as usize * img.height as usize * img.channels as usize
    );
    Ok(())
}

/// COLMAP dense depth / normal map (`.bin`).
pub fn dense_map(data: &[u8]) -> Outcome {
    let img = planemap::io::dense::read_dense_map(data).map_err(msg)?;
    assert_eq!(
        img.data.len(),
        img.width as usize * img.height as usize * img.channels as usize
    );
    Ok(())
}

/// 16-bit label PNG.
pub fn label_png(data: &[u8]) -> Outcome {
    let map = planemap::io::labelpng::read_label_png_from(data).map_err(msg)?;
    assert_eq!(map.labels.len(), map.width as usize * map.height as usize);
    Ok(())
}

/// Scene TOML (`planemap synth`); an accepted scene has a bounded number of views.
pub fn scene_toml(data: &[u8]) -> Outcome {
    let text = std::str::from_utf8(data).map_err(msg)?;
    let spec = planemap::synth::SceneSpec::from_toml_str(text, "fuzz.toml").map_err(msg)?;
    let views = planemap::synth::spec_view_count(&spec);
    assert!((1..=planemap::synth::MAX_VIEWS).contains(&views), "{views}");
    Ok(())
}

/// Run configuration TOML (`planemap run --config`).
pub fn config_toml(data: &[u8]) -> Outcome {
    let text = std::str::from_utf8(data).map_err(msg)?;
    let cfg = planemap::pipeline::Config::from_toml_str(text, "fuzz.toml").map_err(msg)?;
    cfg.validate().map_err(msg)?;
    Ok(())
}

/// Planarity classifier model (`model.bin`).
pub fn classifier_model(data: &[u8]) -> Outcome {
    planemap::classify::model_from_bytes(data).map_err(msg)?;
    Ok(())
}
