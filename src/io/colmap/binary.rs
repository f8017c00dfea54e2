//! COLMAP's binary sparse model: `cameras.bin`, `images.bin`, `points3D.bin`.
//!
//! Layouts (all little-endian), as COLMAP's `reconstruction_io_binary.cc` writes them:
//!
//! - `cameras.bin`: `u64 num_cameras`, then per camera `u32 camera_id`, `i32 model_id`,
//!   `u64 width`, `u64 height`, `f64 params[num_params(model)]`.
//! - `images.bin`: `u64 num_images`, then per image `u32 image_id`, `f64 qw qx qy qz`,
//!   `f64 tx ty tz`, `u32 camera_id`, name bytes + `\0`, `u64 num_points2D`, then per 2D point
//!   `f64 x`, `f64 y`, `u64 point3D_id` (`u64::MAX` = none).
//! - `points3D.bin`: `u64 num_points`, then per point `u64 point3D_id`, `f64 x y z`,
//!   `u8 r g b`, `f64 error`, `u64 track_length`, then per element `u32 image_id`,
//!   `u32 point2D_idx`.
//!
//! The whole stream is read into memory first so that every count can be checked against the
//! bytes that remain before anything is allocated.

use std::io::{Read, Write};
use std::path::PathBuf;

use crate::geometry::{colmap_rotation, Camera, CameraModel};

use super::{ColmapCamera, ColmapError, ColmapImage, ColmapPoint3D, Location, Point2D};

/// Smallest possible camera record: id, model, width, height (no params).
const MIN_CAMERA_BYTES: u64 = 4 + 4 + 8 + 8;
/// Smallest possible image record: id, pose, camera id, empty name, point count.
const MIN_IMAGE_BYTES: u64 = 4 + 7 * 8 + 4 + 1 + 8;
/// Bytes of one 2D point: x, y, point3D id.
const POINT2D_BYTES: u64 = 8 + 8 + 8;
/// Smallest possible 3D point record: id, xyz, rgb, error, track length.
const MIN_POINT3D_BYTES: u64 = 8 + 3 * 8 + 3 + 8 + 8;
/// Bytes of one track element: image id, point2D index.
const TRACK_ELEMENT_BYTES: u64 = 4 + 4;

/// A bounds-checked little-endian cursor over a whole file, reporting byte offsets.
struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
    file: &'static str,
}

impl<'a> Cursor<'a> {
    fn new(data: &'a [u8], file: &'static str) -> Self {
        Cursor { data, pos: 0, file }
    }

    fn remaining(&self) -> u64 {
        (self.data.len() - self.pos) as u64
    }

    fn offset(&self) -> Location {
        Location::Offset(self.pos as u64)
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], ColmapError> {
        if self.data.len() - self.pos < n {
            return Err(ColmapError::Truncated {
                file: PathBuf::from(self.file),
                offset: self.pos as u64,
                expected: format!(
                    "{what} ({n} bytes, only {} left)",
                    self.data.len() - self.pos
                ),
            });
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u8(&mut self, what: &str) -> Result<u8, ColmapError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, ColmapError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn i32(&mut self, what: &str) -> Result<i32, ColmapError> {
        Ok(self.u32(what)? as i32)
    }

    fn u64(&mut self, what: &str) -> Result<u64, ColmapError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }

    /// A finite f64; NaN/inf are an error naming `what` and the offset.
    fn finite_f64(&mut self, what: &str) -> Result<f64, ColmapError> {
        let at = self.offset();
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        let v = f64::from_le_bytes(a);
        if !v.is_finite() {
            return Err(ColmapError::NonFinite {
                file: PathBuf::from(self.file),
                at,
                what: what.to_string(),
                value: v,
            });
        }
        Ok(v)
    }

    /// A record count, checked against the bytes left (each record needs at least
    /// `min_bytes`), so that a corrupt count cannot trigger a huge allocation.
    fn count(&mut self, what: &str, min_bytes: u64) -> Result<usize, ColmapError> {
        let at = self.pos as u64;
        let n = self.u64(what)?;
        let remaining = self.remaining();
        let fits = n
            .checked_mul(min_bytes)
            .is_some_and(|need| need <= remaining);
        if !fits {
            return Err(ColmapError::BadCount {
                file: PathBuf::from(self.file),
                offset: at,
                what: what.to_string(),
                count: n,
                remaining,
                min_bytes,
            });
        }
        Ok(n as usize)
    }

    fn expect_end(&self) -> Result<(), ColmapError> {
        if self.pos != self.data.len() {
            return Err(ColmapError::Invalid {
                file: PathBuf::from(self.file),
                at: self.offset(),
                message: format!(
                    "{} unexpected bytes after the last record",
                    self.data.len() - self.pos
                ),
            });
        }
        Ok(())
    }
}

fn read_all(mut r: impl Read, file: &'static str) -> Result<Vec<u8>, ColmapError> {
    let mut data = Vec::new();
    r.read_to_end(&mut data).map_err(|source| ColmapError::Io {
        path: PathBuf::from(file),
        source,
    })?;
    Ok(data)
}

fn size_u32(c: &Cursor<'_>, v: u64, what: &str) -> Result<u32, ColmapError> {
    u32::try_from(v).map_err(|_| ColmapError::Invalid {
        file: PathBuf::from(c.file),
        at: c.offset(),
        message: format!("{what} {v} does not fit in 32 bits"),
    })
}

/// Reads `cameras.bin` from a stream. Unknown model ids, wrong sizes and invalid parameters
/// are errors naming the byte offset of the camera record.
pub fn read_cameras_bin(r: impl Read) -> Result<Vec<ColmapCamera>, ColmapError> {
    const FILE: &str = "cameras.bin";
    let data = read_all(r, FILE)?;
    let mut c = Cursor::new(&data, FILE);
    let n = c.count("number of cameras", MIN_CAMERA_BYTES)?;
    let mut cameras = Vec::with_capacity(n);
    for _ in 0..n {
        let at = c.offset();
        let camera_id = c.u32("camera_id")?;
        let model_id = c.i32("model_id")?;
        let model =
            CameraModel::from_colmap_id(model_id).map_err(|_| ColmapError::UnknownModel {
                file: PathBuf::from(FILE),
                at,
                model: format!("id {model_id}"),
                expected: CameraModel::id_list(),
            })?;
        let width = c.u64("width")?;
        let width = size_u32(&c, width, "width")?;
        let height = c.u64("height")?;
        let height = size_u32(&c, height, "height")?;
        let mut params = Vec::with_capacity(model.num_params());
        for name in model.param_names() {
            params.push(c.finite_f64(&format!("camera parameter {name}"))?);
        }
        let camera =
            Camera::new(model, width, height, params).map_err(|e| ColmapError::BadCamera {
                file: PathBuf::from(FILE),
                at,
                camera_id,
                source: e,
            })?;
        cameras.push(ColmapCamera { camera_id, camera });
    }
    c.expect_end()?;
    Ok(cameras)
}

/// Reads `images.bin` from a stream.
pub fn read_images_bin(r: impl Read) -> Result<Vec<ColmapImage>, ColmapError> {
    const FILE: &str = "images.bin";
    let data = read_all(r, FILE)?;
    let mut c = Cursor::new(&data, FILE);
    let n = c.count("number of images", MIN_IMAGE_BYTES)?;
    let mut images = Vec::with_capacity(n);
    for _ in 0..n {
        let image_id = c.u32("image_id")?;
        let qvec_at = c.offset();
        let mut qvec = [0.0; 4];
        for (v, name) in qvec.iter_mut().zip(["qw", "qx", "qy", "qz"]) {
            *v = c.finite_f64(name)?;
        }
        let mut tvec = [0.0; 3];
        for (v, name) in tvec.iter_mut().zip(["tx", "ty", "tz"]) {
            *v = c.finite_f64(name)?;
        }
        let camera_id = c.u32("camera_id")?;
        let name_at = c.offset();
        let rest = &data[c.pos..];
        let len = rest
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(|| ColmapError::Truncated {
                file: PathBuf::from(FILE),
                offset: data.len() as u64,
                expected: "the '\\0' ending the image name".into(),
            })?;
        let name = std::str::from_utf8(&rest[..len])
            .map_err(|_| ColmapError::Invalid {
                file: PathBuf::from(FILE),
                at: name_at,
                message: "image name is not valid UTF-8".into(),
            })?
            .to_string();
        c.pos += len + 1;
        colmap_rotation(qvec).map_err(|source| ColmapError::BadQuaternion {
            file: PathBuf::from(FILE),
            at: qvec_at,
            image_id,
            name: name.clone(),
            source,
        })?;
        let np = c.count("number of 2D points", POINT2D_BYTES)?;
        let mut points2d = Vec::with_capacity(np);
        for _ in 0..np {
            let x = c.finite_f64("2D point x")?;
            let y = c.finite_f64("2D point y")?;
            let id = c.u64("point3D_id")?;
            points2d.push(Point2D {
                x,
                y,
                point3d_id: (id != u64::MAX).then_some(id),
            });
        }
        images.push(ColmapImage {
            image_id,
            qvec,
            tvec,
            camera_id,
            name,
            points2d,
        });
    }
    c.expect_end()?;
    Ok(images)
}

/// Reads `points3D.bin` from a stream.
pub fn read_points3d_bin(r: impl Read) -> Result<Vec<ColmapPoint3D>, ColmapError> {
    const FILE: &str = "points3D.bin";
    let data = read_all(r, FILE)?;
    let mut c = Cursor::new(&data, FILE);
    let n = c.count("number of 3D points", MIN_POINT3D_BYTES)?;
    let mut points = Vec::with_capacity(n);
    for _ in 0..n {
        let point3d_id = c.u64("point3D_id")?;
        let mut xyz = [0.0; 3];
        for (v, name) in xyz.iter_mut().zip(["x", "y", "z"]) {
            *v = c.finite_f64(name)?;
        }
        let rgb = [c.u8("red")?, c.u8("green")?, c.u8("blue")?];
        let error = c.finite_f64("reprojection error")?;
        let nt = c.count("track length", TRACK_ELEMENT_BYTES)?;
        let mut track = Vec::with_capacity(nt);
        for _ in 0..nt {
            let image_id = c.u32("track image_id")?;
            let point2d_idx = c.u32("track point2D_idx")?;
            track.push(super::TrackElement {
                image_id,
                point2d_idx,
            });
        }
        points.push(ColmapPoint3D {
            point3d_id,
            xyz,
            rgb,
            error,
            track,
        });
    }
    c.expect_end()?;
    Ok(points)
}

fn io_err(file: &'static str) -> impl Fn(std::io::Error) -> ColmapError {
    move |source| ColmapError::Io {
        path: PathBuf::from(file),
        source,
    }
}

/// Writes `cameras.bin` to a stream.
pub fn write_cameras_bin(mut w: impl Write, cameras: &[ColmapCamera]) -> Result<(), ColmapError> {
    let mut buf = Vec::new();
    buf.extend_from_slice(&(cameras.len() as u64).to_le_bytes());
    for c in cameras {
        buf.extend_from_slice(&c.camera_id.to_le_bytes());
        buf.extend_from_slice(&c.camera.model.colmap_id().to_le_bytes());
        buf.extend_from_slice(&u64::from(c.camera.width).to_le_bytes());
        buf.extend_from_slice(&u64::from(c.camera.height).to_le_bytes());
        for p in &c.camera.params {
            buf.extend_from_slice(&p.to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io_err("cameras.bin"))
}

/// Writes `images.bin` to a stream. A name containing `\0` cannot be stored and is an error.
pub fn write_images_bin(mut w: impl Write, images: &[ColmapImage]) -> Result<(), ColmapError> {
    let mut buf = Vec::new();
    buf.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for im in images {
        if im.name.as_bytes().contains(&0) {
            return Err(ColmapError::Unwritable(format!(
                "image {} name {:?} contains a NUL byte",
                im.image_id, im.name
            )));
        }
        buf.extend_from_slice(&im.image_id.to_le_bytes());
        for v in im.qvec.iter().chain(&im.tvec) {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&im.camera_id.to_le_bytes());
        buf.extend_from_slice(im.name.as_bytes());
        buf.push(0);
        buf.extend_from_slice(&(im.points2d.len() as u64).to_le_bytes());
        for p in &im.points2d {
            buf.extend_from_slice(&p.x.to_le_bytes());
            buf.extend_from_slice(&p.y.to_le_bytes());
            buf.extend_from_slice(&p.point3d_id.unwrap_or(u64::MAX).to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io_err("images.bin"))
}

/// Writes `points3D.bin` to a stream.
pub fn write_points3d_bin(mut w: impl Write, points: &[ColmapPoint3D]) -> Result<(), ColmapError> {
    let mut buf = Vec::new();
    buf.extend_from_slice(&(points.len() as u64).to_le_bytes());
    for p in points {
        buf.extend_from_slice(&p.point3d_id.to_le_bytes());
        for v in &p.xyz {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&p.rgb);
        buf.extend_from_slice(&p.error.to_le_bytes());
        buf.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for t in &p.track {
            buf.extend_from_slice(&t.image_id.to_le_bytes());
            buf.extend_from_slice(&t.point2d_idx.to_le_bytes());
        }
    }
    w.write_all(&buf).map_err(io_err("points3D.bin"))
}
