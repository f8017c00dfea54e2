//! COLMAP sparse models (`cameras`, `images`, `points3D`), text and binary, and their
//! conversion to and from planemap's [`Scene`].
//!
//! [`ColmapModel`] is a faithful in-memory copy of the three files: records keep their file
//! order and ids, so binary write → read → write is byte-identical and text write → read is
//! exact. Readers take a stream; the path functions ([`read_model`], [`read_model_bin`],
//! [`read_model_text`], [`write_model_bin`], [`write_model_text`]) add the file name to errors.
//!
//! Newer COLMAP / pycolmap (3.12+) also write `rigs.{bin,txt}` and `frames.{bin,txt}`. Their
//! `images` file still holds each image's `cam_from_world`, which is all planemap needs, so
//! rigs and frames are ignored when present (and not written).
//!
//! Errors name the file and the line (text) or byte offset (binary) and what was expected;
//! no input makes a reader panic or allocate more than the input could describe.

mod binary;
mod text;

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use thiserror::Error;

use crate::geometry::{
    colmap_rotation, rigid_from_colmap, rigid_to_colmap, Camera, CameraError, PoseError,
};
use crate::scene::{Scene, SceneError, SparseCloud, View};

pub use binary::{
    read_cameras_bin, read_images_bin, read_points3d_bin, write_cameras_bin, write_images_bin,
    write_points3d_bin,
};
pub use text::{
    read_cameras_text, read_images_text, read_points3d_text, write_cameras_text, write_images_text,
    write_points3d_text,
};

/// Where in a file something went wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// 1-based line number (text files).
    Line(usize),
    /// Byte offset from the start of the file (binary files).
    Offset(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Offset(o) => write!(f, "byte offset {o}"),
        }
    }
}

/// Errors of COLMAP model reading, writing and conversion.
#[derive(Debug, Error)]
pub enum ColmapError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// No COLMAP model was found in a directory.
    #[error("{}: no COLMAP model found (looked for cameras/images/points3D .bin or .txt, also in sparse/ and sparse/0/)", dir.display())]
    NoModel {
        /// The directory searched.
        dir: PathBuf,
    },
    /// A binary file ended in the middle of a record.
    #[error("{}: truncated at byte offset {offset}: expected {expected}", file.display())]
    Truncated {
        /// The file.
        file: PathBuf,
        /// Where the data ran out.
        offset: u64,
        /// What was being read.
        expected: String,
    },
    /// A binary count is larger than the rest of the file could hold.
    #[error("{}: byte offset {offset}: {what} is {count}, but only {remaining} bytes follow (each record needs at least {min_bytes})", file.display())]
    BadCount {
        /// The file.
        file: PathBuf,
        /// Offset of the count.
        offset: u64,
        /// Which count.
        what: String,
        /// The count read.
        count: u64,
        /// Bytes left after it.
        remaining: u64,
        /// Minimum bytes per record.
        min_bytes: u64,
    },
    /// A text field could not be parsed.
    #[error("{}: line {line}, field {field}: expected {expected}, got {got}", file.display())]
    Parse {
        /// The file.
        file: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based field (whitespace-separated) in the line.
        field: usize,
        /// What the field should be.
        expected: String,
        /// What was there.
        got: String,
    },
    /// A camera model planemap does not support (name or numeric id).
    #[error("{}: {at}: unknown camera model {model} (expected {expected})", file.display())]
    UnknownModel {
        /// The file.
        file: PathBuf,
        /// Where the camera record is.
        at: Location,
        /// The model name, or `id N` for a numeric id.
        model: String,
        /// The supported names or ids.
        expected: String,
    },
    /// A camera line has the wrong number of parameters for its model.
    #[error("{}: {at}: camera model {model} takes {expected} parameters, got {got}", file.display())]
    ParamCount {
        /// The file.
        file: PathBuf,
        /// Where.
        at: Location,
        /// Model name.
        model: &'static str,
        /// Parameters the model takes.
        expected: usize,
        /// Parameters found.
        got: usize,
    },
    /// A camera record is invalid (size zero, non-positive focal length, ...).
    #[error("{}: {at}: camera {camera_id}: {source}", file.display())]
    BadCamera {
        /// The file.
        file: PathBuf,
        /// Where.
        at: Location,
        /// The camera's id.
        camera_id: u32,
        /// Why.
        source: CameraError,
    },
    /// An image's rotation quaternion is zero, non-finite or far from unit length (a
    /// near-unit one is renormalised as COLMAP does; see
    /// [`crate::geometry::QUATERNION_NORM_TOLERANCE`]).
    #[error("{}: {at}: image {image_id} ({name}): {source}", file.display())]
    BadQuaternion {
        /// The file.
        file: PathBuf,
        /// Where the image record is (its line, or the offset of `qw`).
        at: Location,
        /// The image's id.
        image_id: u32,
        /// The image's name.
        name: String,
        /// The quaternion and its norm.
        source: PoseError,
    },
    /// A camera reads fine but cannot be reconstructed with (see [`Camera::check_usable`]).
    #[error("camera {camera_id} (used by image {image_id}, {name}): {source}")]
    UnusableCamera {
        /// The camera's id.
        camera_id: u32,
        /// The first image using it.
        image_id: u32,
        /// That image's name.
        name: String,
        /// Why.
        source: CameraError,
    },
    /// A NaN or infinite value in a pose, point or parameter.
    #[error("{}: {at}: {what} is {value}, expected a finite number", file.display())]
    NonFinite {
        /// The file.
        file: PathBuf,
        /// Where.
        at: Location,
        /// Which value.
        what: String,
        /// The value.
        value: f64,
    },
    /// Any other malformed record.
    #[error("{}: {at}: {message}", file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// Where.
        at: Location,
        /// What is wrong.
        message: String,
    },
    /// The three files disagree with each other (missing camera/image, bad index, duplicate
    /// id). `file` is the file holding the dangling reference.
    #[error("{}: {message}", file.display())]
    Inconsistent {
        /// The file holding the bad reference.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The model cannot be written in the requested format.
    #[error("cannot write COLMAP model: {0}")]
    Unwritable(String),
    /// Converting to or from a [`Scene`] failed.
    #[error("scene conversion: {0}")]
    Scene(#[from] SceneError),
}

impl ColmapError {
    /// Replaces the bare file name that stream readers report with the full path.
    fn in_file(mut self, path: &Path) -> Self {
        match &mut self {
            ColmapError::Io { path: p, .. } => *p = path.to_path_buf(),
            ColmapError::Truncated { file, .. }
            | ColmapError::BadCount { file, .. }
            | ColmapError::Parse { file, .. }
            | ColmapError::UnknownModel { file, .. }
            | ColmapError::ParamCount { file, .. }
            | ColmapError::BadCamera { file, .. }
            | ColmapError::NonFinite { file, .. }
            | ColmapError::BadQuaternion { file, .. }
            | ColmapError::Invalid { file, .. }
            | ColmapError::Inconsistent { file, .. } => *file = path.to_path_buf(),
            ColmapError::NoModel { .. }
            | ColmapError::Unwritable(_)
            | ColmapError::Scene(_)
            | ColmapError::UnusableCamera { .. } => {}
        }
        self
    }
}

/// One COLMAP camera: its id and intrinsics.
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapCamera {
    /// COLMAP `camera_id`.
    pub camera_id: u32,
    /// Model, size and parameters (validated).
    pub camera: Camera,
}

/// One 2D feature of an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point2D {
    /// Image x in pixels (pixel (0,0)'s centre at 0.5).
    pub x: f64,
    /// Image y in pixels.
    pub y: f64,
    /// The 3D point it observes, if triangulated (`-1` / `u64::MAX` in the files).
    pub point3d_id: Option<u64>,
}

/// One registered COLMAP image.
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapImage {
    /// COLMAP `image_id`.
    pub image_id: u32,
    /// Rotation of `cam_from_world` as a quaternion `(w, x, y, z)`, stored as read (so that
    /// files round-trip); readers reject one whose norm is not within
    /// [`crate::geometry::QUATERNION_NORM_TOLERANCE`] of 1, and [`ColmapModel::to_scene`]
    /// renormalises.
    pub qvec: [f64; 4],
    /// Translation of `cam_from_world`.
    pub tvec: [f64; 3],
    /// The camera it was taken with.
    pub camera_id: u32,
    /// File name relative to the images folder.
    pub name: String,
    /// Its 2D features, in file order (a track's `point2d_idx` indexes this list).
    pub points2d: Vec<Point2D>,
}

/// One observation of a 3D point: which image and which of its 2D points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrackElement {
    /// COLMAP `image_id`.
    pub image_id: u32,
    /// Index into that image's `points2d`.
    pub point2d_idx: u32,
}

/// One COLMAP 3D point.
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapPoint3D {
    /// COLMAP `point3D_id`.
    pub point3d_id: u64,
    /// Position in world coordinates.
    pub xyz: [f64; 3],
    /// Colour, 8-bit RGB.
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels (COLMAP writes -1 when unknown).
    pub error: f64,
    /// The images that see it, in file order.
    pub track: Vec<TrackElement>,
}

/// A COLMAP sparse model as stored on disk, in file order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColmapModel {
    /// `cameras.{bin,txt}`.
    pub cameras: Vec<ColmapCamera>,
    /// `images.{bin,txt}`.
    pub images: Vec<ColmapImage>,
    /// `points3D.{bin,txt}`.
    pub points3d: Vec<ColmapPoint3D>,
}

/// The two on-disk encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelFormat {
    /// `cameras.bin`, `images.bin`, `points3D.bin`.
    Binary,
    /// `cameras.txt`, `images.txt`, `points3D.txt`.
    Text,
}

impl ModelFormat {
    /// The file extension without dot.
    pub fn extension(self) -> &'static str {
        match self {
            ModelFormat::Binary => "bin",
            ModelFormat::Text => "txt",
        }
    }
}

/// Number of distinct views at which a point's track-length confidence term saturates to 1.
pub const CONFIDENCE_FULL_TRACK: usize = 5;
/// Reprojection error (pixels) at which the error confidence term has dropped to 1/2.
pub const CONFIDENCE_ERROR_SCALE_PX: f64 = 1.0;

/// Confidence `C(P)` in `[0, 1]` of a sparse point from its track length and reprojection
/// error, used as the weight of the point in the Manhattan-world stereo data term:
///
/// `C = min(1, (L − 1) / (L_full − 1)) · 1 / (1 + (e / e0)²)`
///
/// with `L` the number of distinct views seeing the point, `L_full` =
/// [`CONFIDENCE_FULL_TRACK`], `e` the mean reprojection error in pixels and `e0` =
/// [`CONFIDENCE_ERROR_SCALE_PX`]. A point seen once (not triangulated) has confidence 0; a
/// negative or non-finite error means "unknown" and leaves only the track term.
pub fn point_confidence(track_len: usize, error_px: f64) -> f64 {
    let l = track_len.saturating_sub(1) as f64 / (CONFIDENCE_FULL_TRACK - 1) as f64;
    let track_term = l.min(1.0);
    let error_term = if error_px.is_finite() && error_px >= 0.0 {
        let r = error_px / CONFIDENCE_ERROR_SCALE_PX;
        1.0 / (1.0 + r * r)
    } else {
        1.0
    };
    track_term * error_term
}

impl ColmapModel {
    /// The camera with `camera_id`, if any.
    pub fn camera(&self, camera_id: u32) -> Option<&ColmapCamera> {
        self.cameras.iter().find(|c| c.camera_id == camera_id)
    }

    /// The image with `image_id`, if any.
    pub fn image(&self, image_id: u32) -> Option<&ColmapImage> {
        self.images.iter().find(|i| i.image_id == image_id)
    }

    /// Checks the cross-references between the three files: unique ids, every image's camera
    /// exists, every track element names an existing image and a valid 2D point index, and
    /// every value is finite. `format` only decides how the files are named in errors.
    pub fn validate(&self, format: ModelFormat) -> Result<(), ColmapError> {
        let ext = format.extension();
        let file = |stem: &str| PathBuf::from(format!("{stem}.{ext}"));
        let mut cams = HashSet::new();
        for c in &self.cameras {
            if !cams.insert(c.camera_id) {
                return Err(ColmapError::Inconsistent {
                    file: file("cameras"),
                    message: format!("camera id {} appears twice", c.camera_id),
                });
            }
            c.camera.validate().map_err(|e| ColmapError::Inconsistent {
                file: file("cameras"),
                message: format!("camera {}: {e}", c.camera_id),
            })?;
        }
        let mut images: HashMap<u32, usize> = HashMap::new();
        for im in &self.images {
            if images.insert(im.image_id, im.points2d.len()).is_some() {
                return Err(ColmapError::Inconsistent {
                    file: file("images"),
                    message: format!("image id {} appears twice", im.image_id),
                });
            }
            if !cams.contains(&im.camera_id) {
                return Err(ColmapError::Inconsistent {
                    file: file("images"),
                    message: format!(
                        "image {} ({}) references camera {}, which is not in cameras.{ext}",
                        im.image_id, im.name, im.camera_id
                    ),
                });
            }
            let finite = im.qvec.iter().chain(&im.tvec).all(|v| v.is_finite())
                && im
                    .points2d
                    .iter()
                    .all(|p| p.x.is_finite() && p.y.is_finite());
            if !finite {
                return Err(ColmapError::Inconsistent {
                    file: file("images"),
                    message: format!("image {} has a non-finite value", im.image_id),
                });
            }
            if let Err(e) = colmap_rotation(im.qvec) {
                return Err(ColmapError::Inconsistent {
                    file: file("images"),
                    message: format!("image {} ({}): {e}", im.image_id, im.name),
                });
            }
        }
        let mut points = HashSet::new();
        for p in &self.points3d {
            if !points.insert(p.point3d_id) {
                return Err(ColmapError::Inconsistent {
                    file: file("points3D"),
                    message: format!("point id {} appears twice", p.point3d_id),
                });
            }
            if !(p.xyz.iter().all(|v| v.is_finite()) && p.error.is_finite()) {
                return Err(ColmapError::Inconsistent {
                    file: file("points3D"),
                    message: format!("point {} has a non-finite value", p.point3d_id),
                });
            }
            for (k, t) in p.track.iter().enumerate() {
                let Some(&n2d) = images.get(&t.image_id) else {
                    return Err(ColmapError::Inconsistent {
                        file: file("points3D"),
                        message: format!(
                            "point {} track element {k} references image {}, which is not in images.{ext}",
                            p.point3d_id, t.image_id
                        ),
                    });
                };
                if t.point2d_idx as usize >= n2d {
                    return Err(ColmapError::Inconsistent {
                        file: file("points3D"),
                        message: format!(
                            "point {} track element {k} references 2D point {} of image {}, which has only {n2d}",
                            p.point3d_id, t.point2d_idx, t.image_id
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Converts to a [`Scene`]: views sorted by `image_id` (so the result does not depend on
    /// file order), cameras copied as they are (still distorted; see
    /// [`Scene::undistorted`]) after [`Camera::check_usable`], rotations renormalised (see
    /// [`colmap_rotation`]), `image_path = images_dir/name` when `images_dir` is given.
    /// Point tracks become sorted, deduplicated view indices; `errors` are COLMAP's
    /// reprojection errors (0 where COLMAP wrote a negative "unknown"); normals are `None`;
    /// confidence is [`point_confidence`].
    pub fn to_scene(&self, images_dir: Option<&Path>) -> Result<Scene, ColmapError> {
        self.validate(ModelFormat::Binary)?;
        let cams: HashMap<u32, &Camera> = self
            .cameras
            .iter()
            .map(|c| (c.camera_id, &c.camera))
            .collect();
        let mut order: Vec<&ColmapImage> = self.images.iter().collect();
        order.sort_by_key(|im| im.image_id);
        let mut view_of_image = HashMap::new();
        let mut views = Vec::with_capacity(order.len());
        for (idx, im) in order.iter().enumerate() {
            view_of_image.insert(im.image_id, idx as u32);
            let camera = cams[&im.camera_id];
            camera
                .check_usable()
                .map_err(|source| ColmapError::UnusableCamera {
                    camera_id: im.camera_id,
                    image_id: im.image_id,
                    name: im.name.clone(),
                    source,
                })?;
            // `validate` checked the quaternion already; keep the error path anyway.
            let cam_from_world =
                rigid_from_colmap(im.qvec, im.tvec).map_err(|e| ColmapError::Inconsistent {
                    file: PathBuf::from("images"),
                    message: format!("image {} ({}): {e}", im.image_id, im.name),
                })?;
            views.push(View {
                id: im.image_id,
                name: im.name.clone(),
                camera: camera.clone(),
                cam_from_world,
                image_path: images_dir.map(|d| d.join(&im.name)),
            });
        }
        let n = self.points3d.len();
        let mut cloud = SparseCloud {
            positions: Vec::with_capacity(n),
            colors: Vec::with_capacity(n),
            normals: None,
            tracks: Vec::with_capacity(n),
            errors: Vec::with_capacity(n),
            confidence: Vec::with_capacity(n),
        };
        for p in &self.points3d {
            let mut track: Vec<u32> = p.track.iter().map(|t| view_of_image[&t.image_id]).collect();
            track.sort_unstable();
            track.dedup();
            let error = if p.error >= 0.0 { p.error } else { 0.0 };
            cloud.positions.push(Vector3::from(p.xyz));
            cloud.colors.push(p.rgb);
            cloud
                .confidence
                .push(point_confidence(track.len(), p.error));
            cloud.tracks.push(track);
            cloud.errors.push(error);
        }
        cloud.validate(views.len())?;
        Ok(Scene { views, cloud })
    }

    /// Builds a COLMAP model from a scene (used by the synthetic-scene writer).
    ///
    /// One COLMAP camera per distinct [`Camera`] (equal cameras share an id; ids 1.. in order
    /// of first use), image ids = view ids (in view order), point ids `1..=N` in cloud order.
    /// `observations[i][k]` is the 2D position of point `i` in view `scene.cloud.tracks[i][k]`;
    /// without it the 3D point is projected. Each observation becomes a 2D point of its image
    /// (in point order), referenced by the point's track, so points2D and tracks agree.
    pub fn from_scene(
        scene: &Scene,
        observations: Option<&[Vec<[f64; 2]>]>,
    ) -> Result<ColmapModel, ColmapError> {
        let cloud = &scene.cloud;
        cloud.validate(scene.views.len())?;
        if let Some(obs) = observations {
            if obs.len() != cloud.len() {
                return Err(SceneError::Inconsistent(format!(
                    "{} points but observations for {}",
                    cloud.len(),
                    obs.len()
                ))
                .into());
            }
        }
        let mut model = ColmapModel::default();
        let mut ids = HashSet::new();
        for view in &scene.views {
            if !ids.insert(view.id) {
                return Err(
                    SceneError::Inconsistent(format!("view id {} appears twice", view.id)).into(),
                );
            }
            let camera_id = match model.cameras.iter().find(|c| c.camera == view.camera) {
                Some(c) => c.camera_id,
                None => {
                    let camera_id = model.cameras.len() as u32 + 1;
                    model.cameras.push(ColmapCamera {
                        camera_id,
                        camera: view.camera.clone(),
                    });
                    camera_id
                }
            };
            let (qvec, tvec) = rigid_to_colmap(&view.cam_from_world);
            model.images.push(ColmapImage {
                image_id: view.id,
                qvec,
                tvec,
                camera_id,
                name: view.name.clone(),
                points2d: Vec::new(),
            });
        }
        for i in 0..cloud.len() {
            let point3d_id = i as u64 + 1;
            let track_views = &cloud.tracks[i];
            if let Some(obs) = observations {
                if obs[i].len() != track_views.len() {
                    return Err(SceneError::Inconsistent(format!(
                        "point {i} has {} track entries but {} observations",
                        track_views.len(),
                        obs[i].len()
                    ))
                    .into());
                }
            }
            let mut track = Vec::with_capacity(track_views.len());
            for (k, &v) in track_views.iter().enumerate() {
                let xy = match observations {
                    Some(obs) => obs[i][k],
                    None => {
                        let (xy, _) = scene.views[v as usize]
                            .project(&cloud.positions[i])
                            .ok_or_else(|| {
                                SceneError::Inconsistent(format!(
                                    "point {i} is behind view {} that sees it",
                                    scene.views[v as usize].id
                                ))
                            })?;
                        [xy.x, xy.y]
                    }
                };
                let image = &mut model.images[v as usize];
                let point2d_idx = u32::try_from(image.points2d.len())
                    .map_err(|_| ColmapError::Unwritable("more than 2^32 2D points".into()))?;
                image.points2d.push(Point2D {
                    x: xy[0],
                    y: xy[1],
                    point3d_id: Some(point3d_id),
                });
                track.push(TrackElement {
                    image_id: image.image_id,
                    point2d_idx,
                });
            }
            let p = &cloud.positions[i];
            model.points3d.push(ColmapPoint3D {
                point3d_id,
                xyz: [p.x, p.y, p.z],
                rgb: cloud.colors[i],
                error: cloud.errors[i],
                track,
            });
        }
        model.validate(ModelFormat::Binary)?;
        Ok(model)
    }
}

/// Finds the model in `dir`, `dir/sparse` or `dir/sparse/0` (first that has one), preferring
/// the binary files when both formats are present.
pub fn find_model(dir: &Path) -> Result<(PathBuf, ModelFormat), ColmapError> {
    for d in [
        dir.to_path_buf(),
        dir.join("sparse"),
        dir.join("sparse").join("0"),
    ] {
        for format in [ModelFormat::Binary, ModelFormat::Text] {
            let ext = format.extension();
            let all = ["cameras", "images", "points3D"]
                .iter()
                .all(|s| d.join(format!("{s}.{ext}")).is_file());
            if all {
                return Ok((d, format));
            }
        }
    }
    Err(ColmapError::NoModel {
        dir: dir.to_path_buf(),
    })
}

/// Reads the model in `dir` (autodetected: see [`find_model`]) and checks it.
pub fn read_model(dir: &Path) -> Result<ColmapModel, ColmapError> {
    let (d, format) = find_model(dir)?;
    match format {
        ModelFormat::Binary => read_model_bin(&d),
        ModelFormat::Text => read_model_text(&d),
    }
}

fn open(path: &Path) -> Result<BufReader<File>, ColmapError> {
    File::open(path)
        .map(BufReader::new)
        .map_err(|source| ColmapError::Io {
            path: path.to_path_buf(),
            source,
        })
}

/// Reads `cameras.bin`, `images.bin`, `points3D.bin` from `dir` and checks them.
pub fn read_model_bin(dir: &Path) -> Result<ColmapModel, ColmapError> {
    let p = dir.join("cameras.bin");
    let cameras = read_cameras_bin(open(&p)?).map_err(|e| e.in_file(&p))?;
    let p = dir.join("images.bin");
    let images = read_images_bin(open(&p)?).map_err(|e| e.in_file(&p))?;
    let p = dir.join("points3D.bin");
    let points3d = read_points3d_bin(open(&p)?).map_err(|e| e.in_file(&p))?;
    let model = ColmapModel {
        cameras,
        images,
        points3d,
    };
    model
        .validate(ModelFormat::Binary)
        .map_err(|e| in_dir(e, dir))?;
    Ok(model)
}

/// Reads `cameras.txt`, `images.txt`, `points3D.txt` from `dir` and checks them.
pub fn read_model_text(dir: &Path) -> Result<ColmapModel, ColmapError> {
    let p = dir.join("cameras.txt");
    let cameras = read_cameras_text(open(&p)?).map_err(|e| e.in_file(&p))?;
    let p = dir.join("images.txt");
    let images = read_images_text(open(&p)?).map_err(|e| e.in_file(&p))?;
    let p = dir.join("points3D.txt");
    let points3d = read_points3d_text(open(&p)?).map_err(|e| e.in_file(&p))?;
    let model = ColmapModel {
        cameras,
        images,
        points3d,
    };
    model
        .validate(ModelFormat::Text)
        .map_err(|e| in_dir(e, dir))?;
    Ok(model)
}

/// Prefixes the bare file name of a validation error with the model directory.
fn in_dir(e: ColmapError, dir: &Path) -> ColmapError {
    match e {
        ColmapError::Inconsistent { file, message } => ColmapError::Inconsistent {
            file: dir.join(file),
            message,
        },
        other => other,
    }
}

/// Writes one file through a temporary name in the same directory, renamed into place.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), ColmapError>,
) -> Result<(), ColmapError> {
    let io = |source| ColmapError::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp).map_err(io)?);
        write(&mut w).map_err(|e| e.in_file(path))?;
        w.into_inner()
            .map_err(|e| io(e.into_error()))?
            .sync_all()
            .map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `cameras.bin`, `images.bin`, `points3D.bin` into `dir` (created if needed), each
/// through a temporary name. The model is validated first.
pub fn write_model_bin(dir: &Path, model: &ColmapModel) -> Result<(), ColmapError> {
    model.validate(ModelFormat::Binary)?;
    std::fs::create_dir_all(dir).map_err(|source| ColmapError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    write_atomically(&dir.join("cameras.bin"), |w| {
        write_cameras_bin(w, &model.cameras)
    })?;
    write_atomically(&dir.join("images.bin"), |w| {
        write_images_bin(w, &model.images)
    })?;
    write_atomically(&dir.join("points3D.bin"), |w| {
        write_points3d_bin(w, &model.points3d)
    })
}

/// Writes `cameras.txt`, `images.txt`, `points3D.txt` into `dir` (created if needed), each
/// through a temporary name. The model is validated first.
pub fn write_model_text(dir: &Path, model: &ColmapModel) -> Result<(), ColmapError> {
    model.validate(ModelFormat::Text)?;
    std::fs::create_dir_all(dir).map_err(|source| ColmapError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    write_atomically(&dir.join("cameras.txt"), |w| {
        write_cameras_text(w, &model.cameras)
    })?;
    write_atomically(&dir.join("images.txt"), |w| {
        write_images_text(w, &model.images)
    })?;
    write_atomically(&dir.join("points3D.txt"), |w| {
        write_points3d_text(w, &model.points3d)
    })
}

/// Writes all three binary files of `model` to memory (cameras, images, points3D): handy for
/// byte-level comparisons.
pub fn model_to_bin_bytes(model: &ColmapModel) -> Result<[Vec<u8>; 3], ColmapError> {
    let mut c = Vec::new();
    let mut i = Vec::new();
    let mut p = Vec::new();
    write_cameras_bin(&mut c, &model.cameras)?;
    write_images_bin(&mut i, &model.images)?;
    write_points3d_bin(&mut p, &model.points3d)?;
    Ok([c, i, p])
}

#[cfg(test)]
mod tests;
