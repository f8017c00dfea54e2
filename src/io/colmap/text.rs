//! COLMAP's text sparse model: `cameras.txt`, `images.txt`, `points3D.txt`.
//!
//! Lines starting with `#` and blank lines are skipped, except that in `images.txt` every
//! image takes two lines and the second (its 2D points) may be empty. Fields are separated by
//! whitespace (COLMAP writes single spaces). The invalid point3D id is written `-1`.
//!
//! Floats are written with Rust's shortest round-trip formatting (`{:?}`: `0.1`, `1e-7`), so
//! text written by planemap reads back bit-exactly; COLMAP's `std::stold` parses it too.

use std::fmt::Write as _;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::str::FromStr;

use crate::geometry::{colmap_rotation, Camera, CameraModel};

use super::{
    ColmapCamera, ColmapError, ColmapImage, ColmapPoint3D, Location, Point2D, TrackElement,
};

/// One data line: its 1-based number and whitespace-separated fields.
struct Line<'a> {
    file: &'static str,
    number: usize,
    fields: Vec<&'a str>,
}

impl Line<'_> {
    fn at(&self) -> Location {
        Location::Line(self.number)
    }

    /// Field `k` (0-based) parsed as `T`; `what` names it in the error (1-based field).
    fn get<T: FromStr>(&self, k: usize, what: &str, kind: &str) -> Result<T, ColmapError> {
        let raw = self.fields.get(k).ok_or_else(|| ColmapError::Parse {
            file: PathBuf::from(self.file),
            line: self.number,
            field: k + 1,
            expected: format!("{what} ({kind})"),
            got: "end of line".into(),
        })?;
        raw.parse::<T>().map_err(|_| ColmapError::Parse {
            file: PathBuf::from(self.file),
            line: self.number,
            field: k + 1,
            expected: format!("{what} ({kind})"),
            got: format!("{raw:?}"),
        })
    }

    fn float(&self, k: usize, what: &str) -> Result<f64, ColmapError> {
        let v: f64 = self.get(k, what, "a number")?;
        if !v.is_finite() {
            return Err(ColmapError::NonFinite {
                file: PathBuf::from(self.file),
                at: self.at(),
                what: format!("{what} (field {})", k + 1),
                value: v,
            });
        }
        Ok(v)
    }
}

fn io_err(file: &'static str) -> impl Fn(std::io::Error) -> ColmapError {
    move |source| ColmapError::Io {
        path: PathBuf::from(file),
        source,
    }
}

/// The UTF-8 byte order mark some Windows editors put at the start of a text file.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// Reads all lines (`\n` or `\r\n` endings), after a leading UTF-8 byte order mark if any;
/// a line that is not UTF-8 is an error naming it.
fn read_lines(mut r: impl BufRead, file: &'static str) -> Result<Vec<String>, ColmapError> {
    let mut bytes = Vec::new();
    r.read_to_end(&mut bytes).map_err(io_err(file))?;
    let bytes = bytes.strip_prefix(UTF8_BOM).unwrap_or(&bytes);
    let mut lines = Vec::new();
    let body = bytes.strip_suffix(b"\n").unwrap_or(bytes);
    if body.is_empty() && bytes.is_empty() {
        return Ok(lines);
    }
    for (i, raw) in body.split(|&b| b == b'\n').enumerate() {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let line = std::str::from_utf8(raw).map_err(|e| ColmapError::Invalid {
            file: PathBuf::from(file),
            at: Location::Line(i + 1),
            message: format!("not valid UTF-8 (at byte {} of the line)", e.valid_up_to()),
        })?;
        lines.push(line.to_string());
    }
    Ok(lines)
}

fn is_skipped(line: &str) -> bool {
    let t = line.trim();
    t.is_empty() || t.starts_with('#')
}

/// Reads `cameras.txt`: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...` per line.
pub fn read_cameras_text(r: impl BufRead) -> Result<Vec<ColmapCamera>, ColmapError> {
    const FILE: &str = "cameras.txt";
    let lines = read_lines(r, FILE)?;
    let mut cameras = Vec::new();
    for (i, raw) in lines.iter().enumerate() {
        if is_skipped(raw) {
            continue;
        }
        let line = Line {
            file: FILE,
            number: i + 1,
            fields: raw.split_whitespace().collect(),
        };
        let camera_id: u32 = line.get(0, "CAMERA_ID", "an unsigned 32-bit integer")?;
        let model_name: String = line.get(1, "MODEL", "a camera model name")?;
        let model = CameraModel::from_name(&model_name).map_err(|_| ColmapError::UnknownModel {
            file: PathBuf::from(FILE),
            at: line.at(),
            model: model_name.clone(),
            expected: format!(
                "one of {}",
                CameraModel::ALL.map(CameraModel::name).join(", ")
            ),
        })?;
        let width: u32 = line.get(2, "WIDTH", "an unsigned 32-bit integer")?;
        let height: u32 = line.get(3, "HEIGHT", "an unsigned 32-bit integer")?;
        let got = line.fields.len().saturating_sub(4);
        if got != model.num_params() {
            return Err(ColmapError::ParamCount {
                file: PathBuf::from(FILE),
                at: line.at(),
                model: model.name(),
                expected: model.num_params(),
                got,
            });
        }
        let mut params = Vec::with_capacity(got);
        for (k, name) in model.param_names().iter().enumerate() {
            params.push(line.float(4 + k, &format!("camera parameter {name}"))?);
        }
        let camera =
            Camera::new(model, width, height, params).map_err(|e| ColmapError::BadCamera {
                file: PathBuf::from(FILE),
                at: line.at(),
                camera_id,
                source: e,
            })?;
        cameras.push(ColmapCamera { camera_id, camera });
    }
    Ok(cameras)
}

/// Parses a point3D id as COLMAP writes it: `-1` (or `u64::MAX`) means none.
fn point3d_id(line: &Line<'_>, k: usize) -> Result<Option<u64>, ColmapError> {
    if line.fields.get(k) == Some(&"-1") {
        return Ok(None);
    }
    let id: u64 = line.get(k, "POINT3D_ID", "an unsigned integer or -1")?;
    Ok((id != u64::MAX).then_some(id))
}

/// Reads `images.txt`: two lines per image, `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`
/// then `X Y POINT3D_ID ...` (possibly empty).
pub fn read_images_text(r: impl BufRead) -> Result<Vec<ColmapImage>, ColmapError> {
    const FILE: &str = "images.txt";
    let lines = read_lines(r, FILE)?;
    let mut images = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if is_skipped(&lines[i]) {
            i += 1;
            continue;
        }
        let line = Line {
            file: FILE,
            number: i + 1,
            fields: lines[i].split_whitespace().collect(),
        };
        let image_id: u32 = line.get(0, "IMAGE_ID", "an unsigned 32-bit integer")?;
        let mut qvec = [0.0; 4];
        for (k, name) in ["QW", "QX", "QY", "QZ"].iter().enumerate() {
            qvec[k] = line.float(1 + k, name)?;
        }
        let mut tvec = [0.0; 3];
        for (k, name) in ["TX", "TY", "TZ"].iter().enumerate() {
            tvec[k] = line.float(5 + k, name)?;
        }
        let camera_id: u32 = line.get(8, "CAMERA_ID", "an unsigned 32-bit integer")?;
        let name: String = line.get(9, "NAME", "an image name")?;
        colmap_rotation(qvec).map_err(|source| ColmapError::BadQuaternion {
            file: PathBuf::from(FILE),
            at: line.at(),
            image_id,
            name: name.clone(),
            source,
        })?;
        if line.fields.len() > 10 {
            return Err(ColmapError::Parse {
                file: PathBuf::from(FILE),
                line: line.number,
                field: 11,
                expected: "end of line after NAME (names with spaces are not supported)".into(),
                got: format!("{:?}", line.fields[10]),
            });
        }
        // The 2D points line always follows, even when empty; a missing one at the end of
        // the file means no points.
        let mut points2d = Vec::new();
        if i + 1 < lines.len() {
            let pl = Line {
                file: FILE,
                number: i + 2,
                fields: lines[i + 1].split_whitespace().collect(),
            };
            if pl.fields.len() % 3 != 0 {
                return Err(ColmapError::Parse {
                    file: PathBuf::from(FILE),
                    line: pl.number,
                    field: pl.fields.len() + 1,
                    expected: "POINTS2D as triples (X, Y, POINT3D_ID)".into(),
                    got: format!("{} fields", pl.fields.len()),
                });
            }
            points2d.reserve(pl.fields.len() / 3);
            for j in 0..pl.fields.len() / 3 {
                points2d.push(Point2D {
                    x: pl.float(3 * j, "X")?,
                    y: pl.float(3 * j + 1, "Y")?,
                    point3d_id: point3d_id(&pl, 3 * j + 2)?,
                });
            }
        }
        images.push(ColmapImage {
            image_id,
            qvec,
            tvec,
            camera_id,
            name,
            points2d,
        });
        i += 2;
    }
    Ok(images)
}

/// Reads `points3D.txt`: `POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)...` per line.
pub fn read_points3d_text(r: impl BufRead) -> Result<Vec<ColmapPoint3D>, ColmapError> {
    const FILE: &str = "points3D.txt";
    let lines = read_lines(r, FILE)?;
    let mut points = Vec::new();
    for (i, raw) in lines.iter().enumerate() {
        if is_skipped(raw) {
            continue;
        }
        let line = Line {
            file: FILE,
            number: i + 1,
            fields: raw.split_whitespace().collect(),
        };
        let point3d_id: u64 = line.get(0, "POINT3D_ID", "an unsigned 64-bit integer")?;
        let xyz = [
            line.float(1, "X")?,
            line.float(2, "Y")?,
            line.float(3, "Z")?,
        ];
        let rgb = [
            line.get(4, "R", "an integer 0..=255")?,
            line.get(5, "G", "an integer 0..=255")?,
            line.get(6, "B", "an integer 0..=255")?,
        ];
        let error = line.float(7, "ERROR")?;
        let rest = line.fields.len().saturating_sub(8);
        if rest % 2 != 0 {
            return Err(ColmapError::Parse {
                file: PathBuf::from(FILE),
                line: line.number,
                field: line.fields.len() + 1,
                expected: "TRACK as pairs (IMAGE_ID, POINT2D_IDX)".into(),
                got: "end of line".into(),
            });
        }
        let mut track = Vec::with_capacity(rest / 2);
        for j in 0..rest / 2 {
            track.push(TrackElement {
                image_id: line.get(8 + 2 * j, "IMAGE_ID", "an unsigned 32-bit integer")?,
                point2d_idx: line.get(9 + 2 * j, "POINT2D_IDX", "an unsigned 32-bit integer")?,
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
    Ok(points)
}

/// Writes `cameras.txt` with COLMAP's header.
pub fn write_cameras_text(mut w: impl Write, cameras: &[ColmapCamera]) -> Result<(), ColmapError> {
    let mut s = String::new();
    s.push_str("# Camera list with one line of data per camera:\n");
    s.push_str("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    let _ = writeln!(s, "# Number of cameras: {}", cameras.len());
    for c in cameras {
        let _ = write!(
            s,
            "{} {} {} {}",
            c.camera_id,
            c.camera.model.name(),
            c.camera.width,
            c.camera.height
        );
        for p in &c.camera.params {
            let _ = write!(s, " {p:?}");
        }
        s.push('\n');
    }
    w.write_all(s.as_bytes()).map_err(io_err("cameras.txt"))
}

/// Writes `images.txt` with COLMAP's header. Names containing whitespace cannot be stored in
/// the text format and are an error.
pub fn write_images_text(mut w: impl Write, images: &[ColmapImage]) -> Result<(), ColmapError> {
    let observations: usize = images
        .iter()
        .map(|im| {
            im.points2d
                .iter()
                .filter(|p| p.point3d_id.is_some())
                .count()
        })
        .sum();
    let mean = if images.is_empty() {
        0.0
    } else {
        observations as f64 / images.len() as f64
    };
    let mut s = String::new();
    s.push_str("# Image list with two lines of data per image:\n");
    s.push_str("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
    s.push_str("#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
    let _ = writeln!(
        s,
        "# Number of images: {}, mean observations per image: {mean}",
        images.len()
    );
    for im in images {
        if im.name.is_empty() || im.name.chars().any(char::is_whitespace) {
            return Err(ColmapError::Unwritable(format!(
                "image {} name {:?} is empty or contains whitespace, which images.txt cannot hold",
                im.image_id, im.name
            )));
        }
        s.push_str(&im.image_id.to_string());
        for v in im.qvec.iter().chain(&im.tvec) {
            let _ = write!(s, " {v:?}");
        }
        let _ = writeln!(s, " {} {}", im.camera_id, im.name);
        let mut first = true;
        for p in &im.points2d {
            if !first {
                s.push(' ');
            }
            first = false;
            let _ = match p.point3d_id {
                Some(id) => write!(s, "{:?} {:?} {id}", p.x, p.y),
                None => write!(s, "{:?} {:?} -1", p.x, p.y),
            };
        }
        s.push('\n');
    }
    w.write_all(s.as_bytes()).map_err(io_err("images.txt"))
}

/// Writes `points3D.txt` with COLMAP's header.
pub fn write_points3d_text(mut w: impl Write, points: &[ColmapPoint3D]) -> Result<(), ColmapError> {
    let elements: usize = points.iter().map(|p| p.track.len()).sum();
    let mean = if points.is_empty() {
        0.0
    } else {
        elements as f64 / points.len() as f64
    };
    let mut s = String::new();
    s.push_str("# 3D point list with one line of data per point:\n");
    s.push_str("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
    let _ = writeln!(
        s,
        "# Number of points: {}, mean track length: {mean}",
        points.len()
    );
    for p in points {
        let _ = write!(
            s,
            "{} {:?} {:?} {:?} {} {} {} {:?}",
            p.point3d_id, p.xyz[0], p.xyz[1], p.xyz[2], p.rgb[0], p.rgb[1], p.rgb[2], p.error
        );
        for t in &p.track {
            let _ = write!(s, " {} {}", t.image_id, t.point2d_idx);
        }
        s.push('\n');
    }
    w.write_all(s.as_bytes()).map_err(io_err("points3D.txt"))
}
