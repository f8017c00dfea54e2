//! The scene model: calibrated views and the sparse SfM / MVS point cloud.
//!
//! Every stage reads a [`Scene`]. Views index into `Scene::views`; point tracks hold those
//! indices (not COLMAP image ids). Distorted cameras are turned into undistorted PINHOLE
//! cameras when a scene is loaded (see [`Scene::undistorted`] and [`undistort_image`]).

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};
use nalgebra::{Point3, Vector2, Vector3};
use thiserror::Error;

use crate::geometry::{camera_center, Camera, Rigid3};
use crate::raster::{png_can_hold, ImageF32};

/// Errors of scene assembly and image loading.
#[derive(Debug, Error)]
pub enum SceneError {
    /// An image file is missing or unreadable.
    #[error("{path}: cannot read image: {message}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The image on disk does not have the size its camera says.
    #[error("{path}: image is {got_w}x{got_h} but its camera says {want_w}x{want_h}")]
    ImageSize {
        /// The image file.
        path: PathBuf,
        /// Width found.
        got_w: u32,
        /// Height found.
        got_h: u32,
        /// Width expected.
        want_w: u32,
        /// Height expected.
        want_h: u32,
    },
    /// A view has no image path.
    #[error("view {0:?} has no image file")]
    NoImage(String),
    /// The model is inconsistent (message says how).
    #[error("inconsistent scene: {0}")]
    Inconsistent(String),
}

/// One calibrated photograph.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// The id the input model gave this view (COLMAP `image_id`).
    pub id: u32,
    /// Image file name as in the model (relative to the images folder).
    pub name: String,
    /// Intrinsics.
    pub camera: Camera,
    /// World → camera transform (x_cam = R·x_world + t).
    pub cam_from_world: Rigid3,
    /// Where the image file is, if known. Loaded on demand by [`View::load_image`].
    pub image_path: Option<PathBuf>,
}

impl View {
    /// Camera centre in world coordinates.
    pub fn center(&self) -> Vector3<f64> {
        camera_center(&self.cam_from_world)
    }

    /// Projects a world point: image coordinates and depth (camera z). `None` behind the camera.
    pub fn project(&self, x_world: &Vector3<f64>) -> Option<(Vector2<f64>, f64)> {
        let x_cam = self.cam_from_world * Point3::from(*x_world);
        let xy = self.camera.project(&x_cam.coords)?;
        Some((xy, x_cam.z))
    }

    /// World-frame ray through image coordinates `xy`: origin (camera centre) and direction
    /// scaled so that a step of 1 along it increases depth by 1.
    pub fn ray(&self, xy: &Vector2<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let dir_cam = self.camera.unproject(xy);
        (
            self.center(),
            self.cam_from_world.rotation.inverse() * dir_cam,
        )
    }

    /// Loads the image as RGB in `[0, 1]` with [`load_image_file`], checking its size against
    /// the camera before any pixel is decoded (a small file declaring a huge image costs
    /// nothing) and detecting the format from the content (a JPEG named `.png` loads).
    pub fn load_image(&self) -> Result<ImageF32, SceneError> {
        let path = self
            .image_path
            .as_ref()
            .ok_or_else(|| SceneError::NoImage(self.name.clone()))?;
        load_image_file(path, Some((self.camera.width, self.camera.height)))
    }

    /// Loads the image and, for a distorted camera, resamples it to [`Camera::undistorted`].
    pub fn load_undistorted_image(&self) -> Result<ImageF32, SceneError> {
        let img = self.load_image()?;
        if self.camera.model.has_distortion() {
            Ok(undistort_image(&img, &self.camera).1)
        } else {
            Ok(img)
        }
    }
}

/// A reader for an image file whose format is detected from its first bytes, falling back
/// to the extension: photographs are often renamed (a JPEG saved as `.png`).
fn image_reader(path: &Path) -> Result<ImageReader<BufReader<File>>, SceneError> {
    let err = |e: std::io::Error| SceneError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    ImageReader::open(path)
        .map_err(err)?
        .with_guessed_format()
        .map_err(err)
}

/// Width and height of an image file from its header, without decoding pixels; the format
/// is detected from the content, not the extension.
pub fn image_file_size(path: &Path) -> Result<(u32, u32), SceneError> {
    image_reader(path)?
        .into_dimensions()
        .map_err(|e| SceneError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// Loads an image file as RGB in `[0, 1]`. The format is detected from the content; the size
/// is read from the header first and, when `expected` is given, must equal it before any
/// pixel is decoded; a PNG whose bytes cannot hold the pixels its header declares is refused
/// before the decoder allocates them.
pub fn load_image_file(path: &Path, expected: Option<(u32, u32)>) -> Result<ImageF32, SceneError> {
    let (w, h) = image_file_size(path)?;
    if let Some((want_w, want_h)) = expected {
        if (w, h) != (want_w, want_h) {
            return Err(SceneError::ImageSize {
                path: path.to_path_buf(),
                got_w: w,
                got_h: h,
                want_w,
                want_h,
            });
        }
    }
    let mut reader = image_reader(path)?;
    let is_png = reader.format() == Some(ImageFormat::Png);
    // The header was checked; hold the decoder to it should the file change meanwhile.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    reader.limits(limits);
    let image_err = |e: image::ImageError| SceneError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let decoder = reader.into_decoder().map_err(image_err)?;
    if is_png {
        // A PNG smaller than its pixels could compress to is truncated or forged: refuse it
        // before the decoder allocates the declared size.
        let bits = decoder.original_color_type().bits_per_pixel();
        let file_len = std::fs::metadata(path).map_or(u64::MAX, |m| m.len());
        if !png_can_hold(w, h, bits, file_len) {
            return Err(SceneError::Image {
                path: path.to_path_buf(),
                message: format!(
                    "PNG header declares {w}x{h} pixels of {bits} bits, more than its \
                     {file_len} bytes can inflate to: truncated or corrupt"
                ),
            });
        }
    }
    let img = DynamicImage::from_decoder(decoder).map_err(image_err)?;
    Ok(ImageF32::from_rgb8(&img.to_rgb8()))
}

/// Sparse 3D points (structure-from-motion or PMVS patches), as parallel arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SparseCloud {
    /// Positions (world frame).
    pub positions: Vec<Vector3<f64>>,
    /// Colours, 8-bit RGB.
    pub colors: Vec<[u8; 3]>,
    /// Unit normals when the source has them (PMVS); `None` for COLMAP points.
    pub normals: Option<Vec<Vector3<f64>>>,
    /// For each point, the indices into `Scene::views` of the views that see it (sorted,
    /// unique).
    pub tracks: Vec<Vec<u32>>,
    /// Mean reprojection error in pixels (COLMAP), 0 where unknown.
    pub errors: Vec<f64>,
    /// Confidence in `[0, 1]` (PMVS NCC score, or derived from track length and error).
    pub confidence: Vec<f64>,
}

impl SparseCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Checks that the parallel arrays agree and values are finite. `num_views` bounds the
    /// track indices.
    pub fn validate(&self, num_views: usize) -> Result<(), SceneError> {
        let n = self.positions.len();
        let lens = [
            ("colors", self.colors.len()),
            ("tracks", self.tracks.len()),
            ("errors", self.errors.len()),
            ("confidence", self.confidence.len()),
        ];
        for (name, len) in lens {
            if len != n {
                return Err(SceneError::Inconsistent(format!(
                    "{n} points but {len} {name}"
                )));
            }
        }
        if let Some(normals) = &self.normals {
            if normals.len() != n {
                return Err(SceneError::Inconsistent(format!(
                    "{n} points but {} normals",
                    normals.len()
                )));
            }
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) {
                return Err(SceneError::Inconsistent(format!(
                    "point {i} has a non-finite coordinate"
                )));
            }
            if let Some(&v) = self.tracks[i].iter().find(|&&v| v as usize >= num_views) {
                return Err(SceneError::Inconsistent(format!(
                    "point {i} is seen by view index {v}, but there are {num_views} views"
                )));
            }
        }
        Ok(())
    }
}

/// Views and sparse points: what every stage starts from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    /// The calibrated views.
    pub views: Vec<View>,
    /// The sparse point cloud.
    pub cloud: SparseCloud,
}

impl Scene {
    /// Index of the view with model id `id`.
    pub fn view_index_by_id(&self, id: u32) -> Option<usize> {
        self.views.iter().position(|v| v.id == id)
    }

    /// The scene with every camera replaced by its undistorted PINHOLE camera (images are
    /// resampled when loaded with [`View::load_undistorted_image`]); sparse points are
    /// unchanged, being 3D.
    pub fn undistorted(&self) -> Scene {
        let mut scene = self.clone();
        for v in &mut scene.views {
            v.camera = v.camera.undistorted();
        }
        scene
    }

    /// Sets each view's image path to `images_dir/name`.
    pub fn set_image_dir(&mut self, images_dir: &Path) {
        for v in &mut self.views {
            v.image_path = Some(images_dir.join(&v.name));
        }
    }
}

/// Resamples an image taken with a distorted camera to the undistorted PINHOLE camera with
/// the same size, focal lengths and principal point: for each output pixel, the ray through
/// its centre is distorted and the input sampled bilinearly there. Pixels whose source lies
/// outside the input are black. Returns the new camera and image.
pub fn undistort_image(img: &ImageF32, camera: &Camera) -> (Camera, ImageF32) {
    let pinhole = camera.undistorted();
    let mut out = ImageF32::filled(img.width, img.height, img.channels, 0.0);
    let c = img.channels as usize;
    let mut px = vec![0.0f32; c];
    for y in 0..img.height {
        for x in 0..img.width {
            let ray = pinhole.pixel_ray(x, y);
            if let Some(src) = camera.project(&ray) {
                if img.sample_bilinear(src.x, src.y, &mut px) {
                    out.pixel_mut(x, y).copy_from_slice(&px);
                }
            }
        }
    }
    (pinhole, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, CameraModel};

    #[test]
    fn view_ray_and_projection_agree() {
        let view = View {
            id: 1,
            name: "a.png".into(),
            camera: Camera::new(
                CameraModel::Radial,
                64,
                48,
                vec![50.0, 32.0, 24.0, -0.1, 0.01],
            )
            .unwrap(),
            cam_from_world: look_at(
                &Vector3::new(3.0, 1.0, 2.0),
                &Vector3::zeros(),
                &Vector3::z(),
            ),
            image_path: None,
        };
        let xy = Vector2::new(10.5, 40.5);
        let (o, d) = view.ray(&xy);
        let (back, depth) = view.project(&(o + d * 2.5)).unwrap();
        assert!((back - xy).norm() < 1e-6);
        assert!((depth - 2.5).abs() < 1e-9);
    }

    #[test]
    fn undistorting_an_undistorted_render_is_identity_inside() {
        // A distorted camera viewing a smooth ramp: undistorting must give the pinhole ramp.
        let cam = Camera::new(
            CameraModel::SimpleRadial,
            40,
            30,
            vec![40.0, 20.0, 15.0, -0.05],
        )
        .unwrap();
        let pin = cam.undistorted();
        // Image content defined on normalised coordinates: f(u) = u.
        let mut img = ImageF32::filled(40, 30, 1, 0.0);
        for y in 0..30 {
            for x in 0..40 {
                let ray = cam.pixel_ray(x, y);
                img.pixel_mut(x, y)[0] = ray.x as f32;
            }
        }
        let (_, und) = undistort_image(&img, &cam);
        for y in 5..25 {
            for x in 5..35 {
                let want = pin.pixel_ray(x, y).x as f32;
                assert!((und.get(x, y, 0) - want).abs() < 2e-3);
            }
        }
    }

    fn view_of(path: &Path, w: u32, h: u32) -> View {
        View {
            id: 1,
            name: "v.png".into(),
            camera: Camera::pinhole(w, h, 10.0, 10.0, w as f64 / 2.0, h as f64 / 2.0),
            cam_from_world: Rigid3::identity(),
            image_path: Some(path.to_path_buf()),
        }
    }

    /// A PNG declaring `w`x`h` RGB whose pixel data is a few bytes of an unfinished zlib
    /// stream: what a small file claiming a huge image looks like up to the first IDAT chunk.
    fn png_header_only(w: u32, h: u32) -> Vec<u8> {
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut chunk = |kind: &[u8], data: &[u8]| {
            png.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let body = [kind, data].concat();
            png.extend_from_slice(&body);
            png.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
        };
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
        chunk(b"IHDR", &ihdr);
        chunk(b"IDAT", &[0x78, 0x9c, 0xed, 0xc1, 0x01, 0x0d]);
        chunk(b"IEND", &[]);
        png
    }

    #[test]
    fn oversized_image_is_rejected_from_its_header() {
        // 20000x12000 declared in 72 bytes: the size check must come before decoding
        // (which would want 720 MB, or fail on the missing pixels with a decoder message).
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.png");
        std::fs::write(&path, png_header_only(20_000, 12_000)).unwrap();
        let err = view_of(&path, 64, 48).load_image().unwrap_err();
        assert!(
            matches!(
                err,
                SceneError::ImageSize {
                    got_w: 20_000,
                    got_h: 12_000,
                    want_w: 64,
                    want_h: 48,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("huge.png"), "{err}");
    }

    #[test]
    fn a_png_smaller_than_its_pixels_is_refused_before_decoding() {
        // Header and camera agree on 20000x12000 RGB (720 MB), but 72 bytes cannot hold it.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("forged.png");
        std::fs::write(&path, png_header_only(20_000, 12_000)).unwrap();
        let err = view_of(&path, 20_000, 12_000)
            .load_image()
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("forged.png")
                && err.contains("declares 20000x12000 pixels of 24 bits")
                && err.contains("truncated or corrupt"),
            "{err}"
        );
    }

    #[test]
    fn a_jpeg_named_png_loads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("photo.png");
        let img = image::RgbImage::from_fn(16, 12, |x, y| {
            image::Rgb([(x * 16) as u8, (y * 20) as u8, 90])
        });
        img.save_with_format(&path, image::ImageFormat::Jpeg)
            .unwrap();
        assert_eq!(&std::fs::read(&path).unwrap()[..2], &[0xFF, 0xD8]);
        assert_eq!(image_file_size(&path).unwrap(), (16, 12));
        let loaded = view_of(&path, 16, 12).load_image().unwrap();
        assert_eq!((loaded.width, loaded.height), (16, 12));
        assert_eq!(load_image_file(&path, None).unwrap(), loaded);
        // JPEG is lossy: near, not equal.
        assert!((loaded.get(8, 6, 2) - 90.0 / 255.0).abs() < 0.05);
    }

    #[test]
    fn missing_image_names_the_file() {
        let view = View {
            id: 1,
            name: "nope.png".into(),
            camera: Camera::pinhole(4, 4, 2.0, 2.0, 2.0, 2.0),
            cam_from_world: Rigid3::identity(),
            image_path: Some("/definitely/missing/nope.png".into()),
        };
        let err = view.load_image().unwrap_err().to_string();
        assert!(err.contains("/definitely/missing/nope.png"), "{err}");
    }
}
