//! `planemap info`: a summary of a COLMAP sparse model and the problems worth knowing about
//! before running the pipeline on it.

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::geometry::{quaternion_norm, Camera, CameraModel};
use crate::io::colmap::{
    find_model, read_model_bin, read_model_text, ColmapError, ColmapImage, ColmapModel, ModelFormat,
};
use crate::scene::SceneError;

/// Errors of model summarising.
#[derive(Debug, Error)]
pub enum InfoError {
    /// The model could not be read.
    #[error(transparent)]
    Colmap(#[from] ColmapError),
}

/// One camera of the model.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSummary {
    /// COLMAP `camera_id`.
    pub camera_id: u32,
    /// Camera model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Number of images taken with it.
    pub num_images: usize,
}

/// Something suspicious about the model (not fatal).
#[derive(Debug, Clone, PartialEq)]
pub enum InfoWarning {
    /// An image listed in the model is not in the images folder.
    MissingImage {
        /// The expected path.
        path: PathBuf,
    },
    /// An image file's header could not be read.
    UnreadableImage {
        /// The image file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// An image file's size disagrees with its camera.
    ImageSizeMismatch {
        /// The image file.
        path: PathBuf,
        /// Size on disk.
        found: (u32, u32),
        /// Size its camera says.
        camera: (u32, u32),
    },
    /// Points seen by only one image (not triangulated; they carry zero confidence).
    SingleViewPoints {
        /// How many.
        count: usize,
    },
    /// An image that sees no 3D point.
    ImageWithoutPoints {
        /// COLMAP `image_id`.
        image_id: u32,
        /// Its name.
        name: String,
    },
    /// A camera no image uses.
    UnusedCamera {
        /// COLMAP `camera_id`.
        camera_id: u32,
    },
    /// The model has no registered images: there is nothing to reconstruct.
    NoImages,
    /// The model has no 3D points: no plane can be found, and `run` would write empty depth
    /// maps.
    NoPoints,
    /// Images whose rotation quaternion is not unit length beyond
    /// [`QUATERNION_WARN_TOLERANCE`]; they are renormalised as COLMAP does (quaternions too
    /// far from unit length are read errors).
    QuaternionsRenormalised {
        /// How many images.
        count: usize,
        /// The image with the largest `|‖q‖ − 1|`.
        worst_image_id: u32,
        /// Its name.
        worst_name: String,
        /// Its quaternion's norm.
        worst_norm: f64,
    },
    /// A camera that cannot be used for reconstruction (a scene cannot be built from it):
    /// invalid parameters, or a principal point absurdly far from the image.
    UnusableCamera {
        /// COLMAP `camera_id`.
        camera_id: u32,
        /// Why.
        message: String,
    },
    /// A camera whose principal point lies outside its image (usable, but unusual: the
    /// optical axis misses the photograph).
    PrincipalPointOutside {
        /// COLMAP `camera_id`.
        camera_id: u32,
        /// Principal point.
        principal_point: (f64, f64),
        /// Image size.
        size: (u32, u32),
    },
    /// A focal length outside COLMAP's plausible range
    /// ([`MIN_FOCAL_LENGTH_RATIO`]–[`MAX_FOCAL_LENGTH_RATIO`] × the larger image side).
    ImplausibleFocalLength {
        /// COLMAP `camera_id`.
        camera_id: u32,
        /// The implausible focal length in pixels (fx, or fy when only fy is).
        focal: f64,
        /// Focal length / larger image side.
        ratio: f64,
    },
}

/// Rotation quaternions whose norm differs from 1 by more than this are reported by `info`
/// ([`InfoWarning::QuaternionsRenormalised`]): full-precision writers (COLMAP, pycolmap,
/// planemap) stay within ~1e-15, so anything beyond 1e-9 lost digits or was edited.
pub const QUATERNION_WARN_TOLERANCE: f64 = 1e-9;
/// COLMAP's `min_focal_length_ratio` (bundle adjustment treats a camera with a smaller
/// focal length / image size ratio as bogus).
pub const MIN_FOCAL_LENGTH_RATIO: f64 = 0.1;
/// COLMAP's `max_focal_length_ratio`.
pub const MAX_FOCAL_LENGTH_RATIO: f64 = 10.0;

impl fmt::Display for InfoWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InfoWarning::MissingImage { path } => {
                write!(f, "image file missing: {}", path.display())
            }
            InfoWarning::UnreadableImage { path, message } => {
                write!(
                    f,
                    "cannot read image header of {}: {message}",
                    path.display()
                )
            }
            InfoWarning::ImageSizeMismatch {
                path,
                found,
                camera,
            } => write!(
                f,
                "{} is {}x{} but its camera says {}x{}",
                path.display(),
                found.0,
                found.1,
                camera.0,
                camera.1
            ),
            InfoWarning::SingleViewPoints { count } => {
                write!(f, "{count} points are seen by only one image")
            }
            InfoWarning::ImageWithoutPoints { image_id, name } => {
                write!(f, "image {image_id} ({name}) sees no 3D points")
            }
            InfoWarning::UnusedCamera { camera_id } => {
                write!(f, "camera {camera_id} is used by no image")
            }
            InfoWarning::NoImages => write!(
                f,
                "the model has no images: there is nothing to reconstruct"
            ),
            InfoWarning::NoPoints => write!(
                f,
                "the model has no 3D points: planes cannot be found and depth maps would be empty"
            ),
            InfoWarning::QuaternionsRenormalised {
                count,
                worst_image_id,
                worst_name,
                worst_norm,
            } => write!(
                f,
                "{count} image(s) have a rotation quaternion that is not unit length (worst: \
                 image {worst_image_id} ({worst_name}), norm {worst_norm:?}); renormalised as \
                 COLMAP does"
            ),
            InfoWarning::UnusableCamera { camera_id, message } => write!(
                f,
                "camera {camera_id} cannot be used for reconstruction: {message}"
            ),
            InfoWarning::PrincipalPointOutside {
                camera_id,
                principal_point: (cx, cy),
                size: (w, h),
            } => write!(
                f,
                "camera {camera_id}: principal point ({cx:?}, {cy:?}) lies outside its {w}x{h} image"
            ),
            InfoWarning::ImplausibleFocalLength {
                camera_id,
                focal,
                ratio,
            } => write!(
                f,
                "camera {camera_id}: focal length {focal:?} px is {ratio:.3} times the larger \
                 image side (COLMAP finds outside {MIN_FOCAL_LENGTH_RATIO}–{MAX_FOCAL_LENGTH_RATIO} implausible)"
            ),
        }
    }
}

/// Axis-aligned box in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingBox {
    /// Minimum corner.
    pub min: [f64; 3],
    /// Maximum corner.
    pub max: [f64; 3],
}

/// Lower percentile of the robust bounding box.
pub const ROBUST_BOX_LOW_PERCENTILE: f64 = 2.0;
/// Upper percentile of the robust bounding box.
pub const ROBUST_BOX_HIGH_PERCENTILE: f64 = 98.0;

/// Summary of a COLMAP sparse model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// Directory the model files are in (after the `sparse/`, `sparse/0/` search).
    pub model_dir: PathBuf,
    /// Binary or text.
    pub format: ModelFormat,
    /// Cameras in file order.
    pub cameras: Vec<CameraSummary>,
    /// Number of registered images.
    pub num_images: usize,
    /// Number of 3D points.
    pub num_points: usize,
    /// Number of track elements over all points.
    pub num_observations: usize,
    /// Mean number of track elements per point (0 without points).
    pub mean_track_length: f64,
    /// Mean reprojection error in pixels over points whose error is known (≥ 0); `None` when
    /// no point has one.
    pub mean_reprojection_error: Option<f64>,
    /// Bounding box of all points; `None` without points.
    pub bbox: Option<BoundingBox>,
    /// Per-axis [`ROBUST_BOX_LOW_PERCENTILE`]–[`ROBUST_BOX_HIGH_PERCENTILE`] percentile box,
    /// insensitive to a few stray points.
    pub robust_bbox: Option<BoundingBox>,
    /// Problems found.
    pub warnings: Vec<InfoWarning>,
}

/// Width and height from a PNG / JPEG header, without decoding the pixels; the format is
/// detected from the content, as [`crate::scene::View::load_image`] does.
pub fn image_size(path: &Path) -> Result<(u32, u32), String> {
    crate::scene::image_file_size(path).map_err(|e| match e {
        SceneError::Image { message, .. } => message,
        other => other.to_string(),
    })
}

/// The camera warnings of one camera: unusable, principal point outside, focal ratio.
fn camera_warnings(camera_id: u32, camera: &Camera, warnings: &mut Vec<InfoWarning>) {
    if let Err(e) = camera.check_usable() {
        warnings.push(InfoWarning::UnusableCamera {
            camera_id,
            message: e.to_string(),
        });
        return;
    }
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let (cx, cy) = (camera.cx(), camera.cy());
    if !(0.0..=w).contains(&cx) || !(0.0..=h).contains(&cy) {
        warnings.push(InfoWarning::PrincipalPointOutside {
            camera_id,
            principal_point: (cx, cy),
            size: (camera.width, camera.height),
        });
    }
    let side = w.max(h);
    for focal in [camera.fx(), camera.fy()] {
        let ratio = focal / side;
        if !(MIN_FOCAL_LENGTH_RATIO..=MAX_FOCAL_LENGTH_RATIO).contains(&ratio) {
            warnings.push(InfoWarning::ImplausibleFocalLength {
                camera_id,
                focal,
                ratio,
            });
            break;
        }
    }
}

/// The `p`-th percentile (0..=100) of sorted values, nearest rank.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let idx = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[idx.min(sorted.len() - 1)]
}

impl ModelInfo {
    /// Reads the model in `model_dir` (or its `sparse/`, `sparse/0/`) and summarises it;
    /// with `images_dir`, also checks the image files' presence and header sizes.
    pub fn from_dir(model_dir: &Path, images_dir: Option<&Path>) -> Result<ModelInfo, InfoError> {
        let (dir, format) = find_model(model_dir)?;
        let model = match format {
            ModelFormat::Binary => read_model_bin(&dir)?,
            ModelFormat::Text => read_model_text(&dir)?,
        };
        Ok(Self::from_model(&model, dir, format, images_dir))
    }

    /// Summarises an already-read model.
    pub fn from_model(
        model: &ColmapModel,
        model_dir: PathBuf,
        format: ModelFormat,
        images_dir: Option<&Path>,
    ) -> ModelInfo {
        let mut warnings = Vec::new();
        if model.images.is_empty() {
            warnings.push(InfoWarning::NoImages);
        }
        if model.points3d.is_empty() {
            warnings.push(InfoWarning::NoPoints);
        }
        for c in &model.cameras {
            camera_warnings(c.camera_id, &c.camera, &mut warnings);
        }
        let off_unit: Vec<(&ColmapImage, f64)> = model
            .images
            .iter()
            .map(|im| (im, quaternion_norm(im.qvec)))
            .filter(|(_, n)| !n.is_finite() || (n - 1.0).abs() > QUATERNION_WARN_TOLERANCE)
            .collect();
        if let Some((worst, norm)) = off_unit
            .iter()
            .max_by(|a, b| (a.1 - 1.0).abs().total_cmp(&(b.1 - 1.0).abs()))
        {
            warnings.push(InfoWarning::QuaternionsRenormalised {
                count: off_unit.len(),
                worst_image_id: worst.image_id,
                worst_name: worst.name.clone(),
                worst_norm: *norm,
            });
        }
        let mut uses: HashMap<u32, usize> = HashMap::new();
        for im in &model.images {
            *uses.entry(im.camera_id).or_default() += 1;
        }
        let cameras: Vec<CameraSummary> = model
            .cameras
            .iter()
            .map(|c| CameraSummary {
                camera_id: c.camera_id,
                model: c.camera.model,
                width: c.camera.width,
                height: c.camera.height,
                num_images: uses.get(&c.camera_id).copied().unwrap_or(0),
            })
            .collect();

        if let Some(images_dir) = images_dir {
            for im in &model.images {
                let path = images_dir.join(&im.name);
                if !path.is_file() {
                    warnings.push(InfoWarning::MissingImage { path });
                    continue;
                }
                let Some(cam) = model.camera(im.camera_id) else {
                    continue;
                };
                match image_size(&path) {
                    Ok(found) => {
                        let want = (cam.camera.width, cam.camera.height);
                        if found != want {
                            warnings.push(InfoWarning::ImageSizeMismatch {
                                path,
                                found,
                                camera: want,
                            });
                        }
                    }
                    Err(message) => warnings.push(InfoWarning::UnreadableImage { path, message }),
                }
            }
        }

        let single = model
            .points3d
            .iter()
            .filter(|p| {
                p.track
                    .iter()
                    .map(|t| t.image_id)
                    .collect::<HashSet<_>>()
                    .len()
                    < 2
            })
            .count();
        if single > 0 {
            warnings.push(InfoWarning::SingleViewPoints { count: single });
        }
        let mut seen: HashSet<u32> = HashSet::new();
        for p in &model.points3d {
            seen.extend(p.track.iter().map(|t| t.image_id));
        }
        for im in &model.images {
            if !seen.contains(&im.image_id) {
                warnings.push(InfoWarning::ImageWithoutPoints {
                    image_id: im.image_id,
                    name: im.name.clone(),
                });
            }
        }
        for c in &cameras {
            if c.num_images == 0 {
                warnings.push(InfoWarning::UnusedCamera {
                    camera_id: c.camera_id,
                });
            }
        }

        let num_points = model.points3d.len();
        let num_observations: usize = model.points3d.iter().map(|p| p.track.len()).sum();
        let known: Vec<f64> = model
            .points3d
            .iter()
            .map(|p| p.error)
            .filter(|e| *e >= 0.0)
            .collect();
        let mean_reprojection_error =
            (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64);
        let (bbox, robust_bbox) = if num_points == 0 {
            (None, None)
        } else {
            let mut b = BoundingBox {
                min: [f64::INFINITY; 3],
                max: [f64::NEG_INFINITY; 3],
            };
            let mut r = b;
            for axis in 0..3 {
                let mut v: Vec<f64> = model.points3d.iter().map(|p| p.xyz[axis]).collect();
                v.sort_by(f64::total_cmp);
                b.min[axis] = v[0];
                b.max[axis] = v[v.len() - 1];
                r.min[axis] = percentile(&v, ROBUST_BOX_LOW_PERCENTILE);
                r.max[axis] = percentile(&v, ROBUST_BOX_HIGH_PERCENTILE);
            }
            (Some(b), Some(r))
        };
        ModelInfo {
            model_dir,
            format,
            cameras,
            num_images: model.images.len(),
            num_points,
            num_observations,
            mean_track_length: if num_points == 0 {
                0.0
            } else {
                num_observations as f64 / num_points as f64
            },
            mean_reprojection_error,
            bbox,
            robust_bbox,
            warnings,
        }
    }
}

fn fmt_box(f: &mut fmt::Formatter<'_>, label: &str, b: &Option<BoundingBox>) -> fmt::Result {
    match b {
        Some(b) => writeln!(
            f,
            "{label}: x [{:.4}, {:.4}]  y [{:.4}, {:.4}]  z [{:.4}, {:.4}]",
            b.min[0], b.max[0], b.min[1], b.max[1], b.min[2], b.max[2]
        ),
        None => writeln!(f, "{label}: (no points)"),
    }
}

impl fmt::Display for ModelInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let format = match self.format {
            ModelFormat::Binary => "binary",
            ModelFormat::Text => "text",
        };
        writeln!(f, "COLMAP model: {} ({format})", self.model_dir.display())?;
        writeln!(f, "cameras: {}", self.cameras.len())?;
        for c in &self.cameras {
            writeln!(
                f,
                "  camera {}: {} {}x{}, {} image(s)",
                c.camera_id,
                c.model.name(),
                c.width,
                c.height,
                c.num_images
            )?;
        }
        writeln!(f, "images: {}", self.num_images)?;
        writeln!(
            f,
            "points: {} ({} observations)",
            self.num_points, self.num_observations
        )?;
        writeln!(f, "mean track length: {:.3}", self.mean_track_length)?;
        match self.mean_reprojection_error {
            Some(e) => writeln!(f, "mean reprojection error: {e:.4} px")?,
            None => writeln!(f, "mean reprojection error: unknown")?,
        }
        fmt_box(f, "bounding box", &self.bbox)?;
        fmt_box(
            f,
            &format!(
                "robust box ({}-{} %)",
                ROBUST_BOX_LOW_PERCENTILE, ROBUST_BOX_HIGH_PERCENTILE
            ),
            &self.robust_bbox,
        )?;
        if self.warnings.is_empty() {
            writeln!(f, "warnings: none")?;
        } else {
            writeln!(f, "warnings: {}", self.warnings.len())?;
            for w in &self.warnings {
                writeln!(f, "  - {w}")?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Camera;
    use crate::io::colmap::{
        write_model_text, ColmapCamera, ColmapImage, ColmapPoint3D, Point2D, TrackElement,
    };

    fn model() -> ColmapModel {
        let cam = |id, w, h| ColmapCamera {
            camera_id: id,
            camera: Camera::pinhole(w, h, 10.0, 10.0, w as f64 / 2.0, h as f64 / 2.0),
        };
        let image = |id, name: &str, n| ColmapImage {
            image_id: id,
            qvec: [1.0, 0.0, 0.0, 0.0],
            tvec: [0.0, 0.0, 0.0],
            camera_id: 1,
            name: name.into(),
            points2d: (0..n)
                .map(|k| Point2D {
                    x: k as f64,
                    y: 0.0,
                    point3d_id: Some(k as u64 + 1),
                })
                .collect(),
        };
        // 100 points along x from 0 to 99 plus one outlier at 1000: the robust box ignores it.
        let mut points3d: Vec<ColmapPoint3D> = (0..101)
            .map(|k| ColmapPoint3D {
                point3d_id: k as u64 + 1,
                xyz: [if k == 100 { 1000.0 } else { k as f64 }, 0.0, 1.0],
                rgb: [0, 0, 0],
                error: if k == 0 { -1.0 } else { 0.5 },
                track: vec![
                    TrackElement {
                        image_id: 1,
                        point2d_idx: k,
                    },
                    TrackElement {
                        image_id: 2,
                        point2d_idx: k,
                    },
                ],
            })
            .collect();
        points3d[3].track.pop(); // seen once
        ColmapModel {
            cameras: vec![cam(1, 8, 6), cam(2, 4, 4)],
            images: vec![
                image(1, "a.png", 101),
                image(2, "b.png", 101),
                image(3, "c.png", 0),
            ],
            points3d,
        }
    }

    #[test]
    fn summary_numbers_and_warnings() {
        let dir = tempfile::tempdir().unwrap();
        let m = model();
        write_model_text(&dir.path().join("sparse"), &m).unwrap();
        let imgs = dir.path().join("images");
        std::fs::create_dir(&imgs).unwrap();
        image::RgbImage::new(8, 6).save(imgs.join("a.png")).unwrap();
        image::RgbImage::new(9, 6).save(imgs.join("b.png")).unwrap();
        let info = ModelInfo::from_dir(dir.path(), Some(&imgs)).unwrap();
        assert_eq!(info.format, ModelFormat::Text);
        assert_eq!(info.num_images, 3);
        assert_eq!(info.num_points, 101);
        assert_eq!(info.num_observations, 201);
        assert!((info.mean_track_length - 201.0 / 101.0).abs() < 1e-12);
        assert_eq!(info.mean_reprojection_error, Some(0.5));
        assert_eq!(info.bbox.unwrap().max[0], 1000.0);
        let r = info.robust_bbox.unwrap();
        assert!(r.max[0] >= 97.0 && r.max[0] <= 99.0, "{r:?}");
        assert!(r.min[0] >= 1.0 && r.min[0] <= 3.0, "{r:?}");
        let w = &info.warnings;
        assert!(
            w.contains(&InfoWarning::MissingImage {
                path: imgs.join("c.png")
            }),
            "{w:?}"
        );
        assert!(w.contains(&InfoWarning::ImageSizeMismatch {
            path: imgs.join("b.png"),
            found: (9, 6),
            camera: (8, 6)
        }));
        assert!(w.contains(&InfoWarning::SingleViewPoints { count: 1 }));
        assert!(w.contains(&InfoWarning::ImageWithoutPoints {
            image_id: 3,
            name: "c.png".into()
        }));
        assert!(w.contains(&InfoWarning::UnusedCamera { camera_id: 2 }));
        assert_eq!(w.len(), 5, "{w:?}");
        let text = info.to_string();
        assert!(text.contains("camera 1: PINHOLE 8x6, 3 image(s)"), "{text}");
        assert!(
            text.contains("b.png is 9x6 but its camera says 8x6"),
            "{text}"
        );
    }

    #[test]
    fn image_size_reads_headers_by_content() {
        let dir = tempfile::tempdir().unwrap();
        let jpeg_as_png = dir.path().join("a.png");
        image::RgbImage::new(7, 5)
            .save_with_format(&jpeg_as_png, image::ImageFormat::Jpeg)
            .unwrap();
        assert_eq!(image_size(&jpeg_as_png), Ok((7, 5)));
        let junk = dir.path().join("b.png");
        std::fs::write(&junk, b"not an image").unwrap();
        assert!(image_size(&junk).is_err());
    }

    #[test]
    fn empty_model_is_warned_about() {
        let empty = ColmapModel::default();
        let info = ModelInfo::from_model(&empty, PathBuf::from("m"), ModelFormat::Text, None);
        assert_eq!(
            info.warnings,
            vec![InfoWarning::NoImages, InfoWarning::NoPoints]
        );
        let text = info.to_string();
        assert!(!text.contains("warnings: none"), "{text}");
        assert!(text.contains("no 3D points"), "{text}");
        // Images but no points.
        let mut m = model();
        m.points3d.clear();
        let info = ModelInfo::from_model(&m, PathBuf::from("m"), ModelFormat::Text, None);
        assert!(info.warnings.contains(&InfoWarning::NoPoints));
        assert!(!info.warnings.contains(&InfoWarning::NoImages));
    }

    #[test]
    fn absurd_intrinsics_are_warned_about() {
        let mut m = model();
        // Camera 1 (8x6, used): principal point 1e300; camera 2 (4x4): focal ≤ 0.
        m.cameras[0].camera.params[2] = 1e300;
        m.cameras[1].camera.params[0] = -5.0;
        let info = ModelInfo::from_model(&m, PathBuf::from("m"), ModelFormat::Text, None);
        let text = info.to_string();
        assert!(
            text.contains(
                "camera 1 cannot be used for reconstruction: principal point (1e300, 3.0)"
            ),
            "{text}"
        );
        assert!(
            text.contains(
                "camera 2 cannot be used for reconstruction: camera parameter 0 (fx) is -5.0"
            ),
            "{text}"
        );
        // Outside the image but not absurd, and a focal 100x the image side.
        let mut m = model();
        m.cameras[0].camera.params[2] = -3.0;
        m.cameras[1].camera.params[0] = 400.0;
        m.cameras[1].camera.params[1] = 400.0;
        let info = ModelInfo::from_model(&m, PathBuf::from("m"), ModelFormat::Text, None);
        assert!(info.warnings.contains(&InfoWarning::PrincipalPointOutside {
            camera_id: 1,
            principal_point: (-3.0, 3.0),
            size: (8, 6)
        }));
        assert!(info
            .warnings
            .contains(&InfoWarning::ImplausibleFocalLength {
                camera_id: 2,
                focal: 400.0,
                ratio: 100.0
            }));
    }

    #[test]
    fn renormalised_quaternions_are_warned_about() {
        let mut m = model();
        m.images[1].qvec = [1.0004, 0.0, 0.0, 0.0];
        m.images[2].qvec = [0.0, 0.0, 0.99995, 0.0];
        let info = ModelInfo::from_model(&m, PathBuf::from("m"), ModelFormat::Text, None);
        assert!(
            info.warnings
                .contains(&InfoWarning::QuaternionsRenormalised {
                    count: 2,
                    worst_image_id: 2,
                    worst_name: "b.png".into(),
                    worst_norm: 1.0004
                }),
            "{:?}",
            info.warnings
        );
        assert!(info
            .to_string()
            .contains("2 image(s) have a rotation quaternion"));
    }
}
