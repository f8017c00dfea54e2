//! PMVS / CMVS workspaces: oriented patches (`models/*.patch`), projection matrices
//! (`txt/%08d.txt`) and images (`visualize/%08d.jpg|ppm|png`). PMVS (Furukawa & Ponce) is the
//! oriented-point input of Manhattan-world stereo (Furukawa et al. CVPR 2009, §3).
//!
//! Formats, checked against PMVS2/CMVS `patch.cc` (`operator<<` / `operator>>` of `Cpatch`)
//! and the PMVS2 documentation:
//! - `.patch`: `PATCHES`, the patch count, then per patch the token `PATCHS` (or `PATCHA`,
//!   which carries 5 extra numbers after the scores that we skip), the homogeneous position
//!   `x y z w`, the normal `nx ny nz 0`, `score debug1 debug2` (score = mean NCC), the count
//!   and list of images the patch is visible in, the count and list of images it is
//!   "possibly visible" in. Reading is token based (line breaks are not significant), like
//!   PMVS's own `istream >>` reader; errors name the line.
//! - `txt/%08d.txt`: the word `CONTOUR` then the 12 entries of the 3×4 projection matrix `P`
//!   row by row, `P` defined up to scale (of either sign).
//!
//! Pixel convention: PMVS puts pixel centres at integer coordinates; planemap (like COLMAP)
//! at `+0.5`. So `x_planemap = x_pmvs + 0.5`, applied as `P' = T·P` with
//! `T = [[1,0,½],[0,1,½],[0,0,1]]` on read and `T⁻¹` on write.

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::{self, BufReader, Read, Write};
use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Matrix3x4, Rotation3, Translation3, UnitQuaternion, Vector3};
use thiserror::Error;

use crate::geometry::{Camera, Rigid3};
use crate::io::atomic::write_atomic;
use crate::scene::{Scene, SparseCloud, View};

const STREAM: &str = "<stream>";
/// Dropping a skew `s` moves a pixel by at most `|s|·height/fy` pixels; above this many
/// pixels the projection matrix is rejected rather than silently approximated.
pub const MAX_SKEW_SHIFT_PX: f64 = 0.01;
/// Colour given to PMVS points (the `.patch` format stores none): mid grey.
pub const PATCH_COLOR: [u8; 3] = [128, 128, 128];
/// Image extensions looked for in `visualize/`, in order.
const IMAGE_EXTENSIONS: [&str; 6] = ["jpg", "JPG", "jpeg", "png", "ppm", "pgm"];
/// How much of an image file is read to find its size.
const MAX_IMAGE_HEADER: u64 = 1 << 24;

/// Errors reading or writing PMVS workspaces.
#[derive(Debug, Error)]
pub enum PmvsError {
    /// A file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        source: io::Error,
    },
    /// A text file is malformed.
    #[error("{file}: line {line}: {message}")]
    Format {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What was expected.
        message: String,
    },
    /// An image's size could not be read from its header.
    #[error("{file}: byte {offset}: {message}")]
    Image {
        /// The image file.
        file: String,
        /// Byte offset of the problem.
        offset: u64,
        /// What was expected.
        message: String,
    },
    /// A projection matrix is not a finite-camera pinhole projection (or a camera cannot be
    /// written as one).
    #[error("{file}: {message}")]
    Camera {
        /// The file (or view) concerned.
        file: String,
        /// Why.
        message: String,
    },
}

impl PmvsError {
    fn in_file(self, path: &Path) -> Self {
        let file = path.display().to_string();
        match self {
            PmvsError::Io { source, .. } => PmvsError::Io { file, source },
            PmvsError::Format { line, message, .. } => PmvsError::Format {
                file,
                line,
                message,
            },
            PmvsError::Image {
                offset, message, ..
            } => PmvsError::Image {
                file,
                offset,
                message,
            },
            PmvsError::Camera { message, .. } => PmvsError::Camera { file, message },
        }
    }
}

impl From<io::Error> for PmvsError {
    fn from(source: io::Error) -> Self {
        PmvsError::Io {
            file: STREAM.into(),
            source,
        }
    }
}

fn format_err(line: usize, message: impl Into<String>) -> PmvsError {
    PmvsError::Format {
        file: STREAM.into(),
        line,
        message: message.into(),
    }
}

fn camera_err(message: impl Into<String>) -> PmvsError {
    PmvsError::Camera {
        file: STREAM.into(),
        message: message.into(),
    }
}

fn io_in(path: &Path) -> impl Fn(io::Error) -> PmvsError + '_ {
    move |e| PmvsError::from(e).in_file(path)
}

/// One PMVS oriented patch, as stored in a `.patch` file.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Centre (world frame), after dividing by the homogeneous `w`.
    pub position: Vector3<f64>,
    /// Unit normal (world frame), pointing towards the cameras that see the patch.
    pub normal: Vector3<f64>,
    /// Photo-consistency score: mean NCC over the visible images, in `[-1, 1]`.
    pub score: f64,
    /// The two debug numbers after the score (PMVS's depth and angle scales).
    pub debug: [f64; 2],
    /// Image numbers the patch is visible in (first = reference image).
    pub visible: Vec<u32>,
    /// Image numbers the patch is possibly visible in (textureless there; not matched).
    pub possibly_visible: Vec<u32>,
}

/// Whitespace tokens with their 1-based line numbers.
struct Tokens<'a> {
    iter: Box<dyn Iterator<Item = (usize, &'a str)> + 'a>,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str) -> Self {
        let last_line = text.lines().count().max(1);
        Tokens {
            iter: Box::new(
                text.lines()
                    .enumerate()
                    .flat_map(|(i, l)| l.split_ascii_whitespace().map(move |t| (i + 1, t))),
            ),
            last_line,
        }
    }

    fn next(&mut self, what: &str) -> Result<(usize, &'a str), PmvsError> {
        self.iter
            .next()
            .ok_or_else(|| format_err(self.last_line, format!("file ends early, expected {what}")))
    }

    fn word(&mut self, want: &str) -> Result<usize, PmvsError> {
        let (line, tok) = self.next(&format!("{want:?}"))?;
        if tok != want {
            return Err(format_err(
                line,
                format!("expected {want:?}, found {tok:?}"),
            ));
        }
        Ok(line)
    }

    fn float(&mut self, what: &str) -> Result<(usize, f64), PmvsError> {
        let (line, tok) = self.next(what)?;
        match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((line, v)),
            _ => Err(format_err(
                line,
                format!("expected {what} (a finite number), found {tok:?}"),
            )),
        }
    }

    fn count(&mut self, what: &str) -> Result<(usize, u32), PmvsError> {
        let (line, tok) = self.next(what)?;
        tok.parse::<u32>().map(|v| (line, v)).map_err(|_| {
            format_err(
                line,
                format!("expected {what} (a non-negative integer), found {tok:?}"),
            )
        })
    }
}

fn read_text<R: Read>(mut r: R) -> Result<String, PmvsError> {
    let mut bytes = Vec::new();
    r.read_to_end(&mut bytes)?;
    String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        format_err(line, "expected ASCII text, found invalid UTF-8")
    })
}

fn image_list(t: &mut Tokens, what: &str) -> Result<Vec<u32>, PmvsError> {
    let (_, n) = t.count(&format!("the number of {what} images"))?;
    let mut list = Vec::with_capacity((n as usize).min(1024));
    for _ in 0..n {
        list.push(t.count(&format!("a {what} image number"))?.1);
    }
    Ok(list)
}

/// Reads a `.patch` file from a stream.
pub fn read_patches<R: Read>(r: R) -> Result<Vec<Patch>, PmvsError> {
    let text = read_text(r)?;
    let mut t = Tokens::new(&text);
    t.word("PATCHES")?;
    let (_, n) = t.count("the number of patches")?;
    // A patch takes at least ~30 bytes of text: never trust the count for allocation.
    let mut patches = Vec::with_capacity((n as usize).min(text.len() / 30));
    for _ in 0..n {
        let (line, head) = t.next("\"PATCHS\"")?;
        if head != "PATCHS" && head != "PATCHA" {
            return Err(format_err(
                line,
                format!("expected \"PATCHS\" or \"PATCHA\", found {head:?}"),
            ));
        }
        let mut p = [0f64; 4];
        let mut pos_line = line;
        for (k, v) in p.iter_mut().enumerate() {
            let (l, x) = t.float("a position coordinate (x y z w)")?;
            *v = x;
            if k == 3 {
                pos_line = l;
            }
        }
        if p[3] == 0.0 {
            return Err(format_err(
                pos_line,
                "expected a finite position (homogeneous w ≠ 0), found w = 0",
            ));
        }
        let position = Vector3::new(p[0] / p[3], p[1] / p[3], p[2] / p[3]);
        if !position.iter().all(|v| v.is_finite()) {
            return Err(format_err(
                pos_line,
                format!(
                    "expected a finite position, found ({:?}, {:?}, {:?}) / w = {:?} (overflows)",
                    p[0], p[1], p[2], p[3]
                ),
            ));
        }
        let mut n4 = [0f64; 4];
        let mut nrm_line = pos_line;
        for v in n4.iter_mut() {
            let (l, x) = t.float("a normal coordinate (nx ny nz 0)")?;
            *v = x;
            nrm_line = l;
        }
        let normal = Vector3::new(n4[0], n4[1], n4[2]);
        let norm = normal.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            return Err(format_err(
                nrm_line,
                format!(
                    "expected a non-zero normal of finite length, found ({:?}, {:?}, {:?})",
                    n4[0], n4[1], n4[2]
                ),
            ));
        }
        let (_, score) = t.float("the patch score")?;
        let (_, d1) = t.float("the first debug number")?;
        let (_, d2) = t.float("the second debug number")?;
        if head == "PATCHA" {
            t.count("the PATCHA type")?;
            for _ in 0..4 {
                t.float("a PATCHA direction coordinate")?;
            }
        }
        let visible = image_list(&mut t, "visible")?;
        let possibly_visible = image_list(&mut t, "possibly visible")?;
        patches.push(Patch {
            position,
            normal: normal / norm,
            score,
            debug: [d1, d2],
            visible,
            possibly_visible,
        });
    }
    if let Some((line, tok)) = t.iter.next() {
        return Err(format_err(
            line,
            format!("expected end of file after {n} patches, found {tok:?}"),
        ));
    }
    Ok(patches)
}

/// Reads a `.patch` file; errors name the file.
pub fn read_patches_path(path: &Path) -> Result<Vec<Patch>, PmvsError> {
    let file = File::open(path).map_err(io_in(path))?;
    read_patches(BufReader::new(file)).map_err(|e| e.in_file(path))
}

/// Writes patches in PMVS's `.patch` layout (positions with `w = 1`, normals with `0`).
pub fn write_patches<W: Write>(mut w: W, patches: &[Patch]) -> Result<(), PmvsError> {
    writeln!(w, "PATCHES\n{}", patches.len())?;
    for p in patches {
        let (x, n) = (&p.position, &p.normal);
        writeln!(
            w,
            "PATCHS\n{} {} {} 1\n{} {} {} 0",
            x.x, x.y, x.z, n.x, n.y, n.z
        )?;
        writeln!(w, "{} {} {}", p.score, p.debug[0], p.debug[1])?;
        for list in [&p.visible, &p.possibly_visible] {
            writeln!(w, "{}", list.len())?;
            for i in list {
                write!(w, "{i} ")?;
            }
            writeln!(w)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// Reads a PMVS camera file (`CONTOUR` + 3×4 projection matrix, PMVS pixel convention).
pub fn read_projection<R: Read>(r: R) -> Result<Matrix3x4<f64>, PmvsError> {
    let text = read_text(r)?;
    let mut t = Tokens::new(&text);
    t.word("CONTOUR")?;
    let mut p = Matrix3x4::zeros();
    for i in 0..3 {
        for j in 0..4 {
            p[(i, j)] = t.float(&format!("projection matrix entry ({i}, {j})"))?.1;
        }
    }
    if let Some((line, tok)) = t.iter.next() {
        return Err(format_err(
            line,
            format!("expected end of file after the 12 matrix entries, found {tok:?}"),
        ));
    }
    Ok(p)
}

/// Reads a PMVS camera file; errors name the file.
pub fn read_projection_path(path: &Path) -> Result<Matrix3x4<f64>, PmvsError> {
    let file = File::open(path).map_err(io_in(path))?;
    read_projection(BufReader::new(file)).map_err(|e| e.in_file(path))
}

/// Writes a PMVS camera file.
pub fn write_projection<W: Write>(mut w: W, p: &Matrix3x4<f64>) -> Result<(), PmvsError> {
    writeln!(w, "CONTOUR")?;
    for i in 0..3 {
        writeln!(w, "{} {} {} {}", p[(i, 0)], p[(i, 1)], p[(i, 2)], p[(i, 3)])?;
    }
    Ok(())
}

fn pixel_shift() -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, 0.5, 0.0, 1.0, 0.5, 0.0, 0.0, 1.0)
}

/// Splits a PMVS projection matrix (PMVS pixel convention) into a PINHOLE camera
/// (planemap's convention, pixel centres at +0.5) and `cam_from_world`.
///
/// `P ~ K·[R | t]`: the sign of `P` is fixed so that `det(P₃ₓ₃) > 0` (points in front have
/// positive depth), then an RQ decomposition (Gram–Schmidt on the rows from the last one)
/// gives `K` upper triangular with positive diagonal and `R` a proper rotation;
/// `t = K⁻¹·p₄`. A skew that moves no pixel by more than [`MAX_SKEW_SHIFT_PX`] is dropped;
/// a larger one is an error, as are singular or non-finite matrices.
pub fn camera_from_projection(
    p: &Matrix3x4<f64>,
    width: u32,
    height: u32,
) -> Result<(Camera, Rigid3), PmvsError> {
    if !p.iter().all(|v| v.is_finite()) {
        return Err(camera_err("projection matrix has a non-finite entry"));
    }
    let mut p = pixel_shift() * p;
    let m: Matrix3<f64> = p.fixed_view::<3, 3>(0, 0).into_owned();
    let det = m.determinant();
    let scale = m.norm().powi(3);
    if !det.is_finite() || det.abs() <= 1e-12 * scale {
        return Err(camera_err(format!(
            "projection matrix is singular (det of its left 3x3 = {det:e})"
        )));
    }
    if det < 0.0 {
        p = -p;
    }
    let m: Matrix3<f64> = p.fixed_view::<3, 3>(0, 0).into_owned();
    let rows = [
        m.row(0).transpose(),
        m.row(1).transpose(),
        m.row(2).transpose(),
    ];
    // Rows of M = K R: m3 = k33 r3; m2 = k22 r2 + k23 r3; m1 = k11 r1 + k12 r2 + k13 r3.
    let k33 = rows[2].norm();
    let r3 = rows[2] / k33;
    let k23 = rows[1].dot(&r3);
    let v2 = rows[1] - k23 * r3;
    let k22 = v2.norm();
    let r2 = v2 / k22;
    let k13 = rows[0].dot(&r3);
    let k12 = rows[0].dot(&r2);
    let v1 = rows[0] - k12 * r2 - k13 * r3;
    let k11 = v1.norm();
    let r1 = v1 / k11;
    let rot = Matrix3::from_rows(&[r1.transpose(), r2.transpose(), r3.transpose()]);
    let k_scaled = Matrix3::new(k11, k12, k13, 0.0, k22, k23, 0.0, 0.0, k33);
    let t = k_scaled
        .try_inverse()
        .map(|ki| ki * p.column(3))
        .ok_or_else(|| camera_err("projection matrix is singular"))?;
    let (fx, fy, cx, cy, skew) = (k11 / k33, k22 / k33, k13 / k33, k23 / k33, k12 / k33);
    let shift = skew.abs() * height as f64 / fy;
    if shift > MAX_SKEW_SHIFT_PX {
        return Err(camera_err(format!(
            "projection has skew {skew:e} (moves pixels by up to {shift:.3} px); only zero-skew pinhole cameras are supported"
        )));
    }
    let camera = Camera::new(
        crate::geometry::CameraModel::Pinhole,
        width,
        height,
        vec![fx, fy, cx, cy],
    )
    .map_err(|e| camera_err(format!("invalid camera from projection matrix: {e}")))?;
    camera
        .check_usable()
        .map_err(|e| camera_err(format!("unusable camera from projection matrix: {e}")))?;
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rot));
    let cam_from_world = Rigid3::from_parts(Translation3::from(t), rotation);
    Ok((camera, cam_from_world))
}

/// The PMVS projection matrix (PMVS pixel convention) of an undistorted camera.
pub fn projection_from_camera(
    camera: &Camera,
    cam_from_world: &Rigid3,
) -> Result<Matrix3x4<f64>, PmvsError> {
    if camera.model.has_distortion() {
        return Err(camera_err(format!(
            "PMVS cameras are pinhole; camera model {} has distortion (undistort the scene first)",
            camera.model.name()
        )));
    }
    let mut rt = Matrix3x4::zeros();
    rt.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(cam_from_world.rotation.to_rotation_matrix().matrix());
    rt.set_column(3, &cam_from_world.translation.vector);
    let unshift = Matrix3::new(1.0, 0.0, -0.5, 0.0, 1.0, -0.5, 0.0, 0.0, 1.0);
    Ok(unshift * camera.k_matrix() * rt)
}

fn image_err(offset: u64, message: impl Into<String>) -> PmvsError {
    PmvsError::Image {
        file: STREAM.into(),
        offset,
        message: message.into(),
    }
}

/// Width and height from the header of a JPEG, PNG or binary/ASCII PNM (PPM/PGM) stream,
/// without decoding pixels.
pub fn image_size<R: Read>(r: R) -> Result<(u32, u32), PmvsError> {
    let mut bytes = Vec::new();
    r.take(MAX_IMAGE_HEADER).read_to_end(&mut bytes)?;
    let b = &bytes[..];
    let be16 =
        |i: usize| -> Option<u32> { Some(u16::from_be_bytes([*b.get(i)?, *b.get(i + 1)?]) as u32) };
    let be32 = |i: usize| -> Option<u32> {
        Some(u32::from_be_bytes([
            *b.get(i)?,
            *b.get(i + 1)?,
            *b.get(i + 2)?,
            *b.get(i + 3)?,
        ]))
    };
    let size = if b.starts_with(b"\x89PNG\r\n\x1a\n") {
        if b.get(12..16) != Some(&b"IHDR"[..]) {
            return Err(image_err(12, "expected the PNG IHDR chunk"));
        }
        (
            be32(16).ok_or_else(|| image_err(16, "PNG ends inside IHDR"))?,
            be32(20).ok_or_else(|| image_err(20, "PNG ends inside IHDR"))?,
        )
    } else if b.starts_with(&[0xff, 0xd8]) {
        let mut i = 2usize;
        loop {
            // Skip to the next marker (0xFF, possibly padded with more 0xFF).
            if b.get(i) != Some(&0xff) {
                return Err(image_err(
                    i as u64,
                    "expected a JPEG marker (0xFF) before the frame header",
                ));
            }
            while b.get(i) == Some(&0xff) {
                i += 1;
            }
            let marker = *b
                .get(i)
                .ok_or_else(|| image_err(i as u64, "JPEG ends before its frame header (SOF)"))?;
            i += 1;
            match marker {
                0xd8 | 0x01 | 0xd0..=0xd7 => continue,
                0xc0..=0xc3 | 0xc5..=0xc7 | 0xc9..=0xcb | 0xcd..=0xcf => {
                    let h = be16(i + 3)
                        .ok_or_else(|| image_err(i as u64, "JPEG ends inside its frame header"))?;
                    let w = be16(i + 5)
                        .ok_or_else(|| image_err(i as u64, "JPEG ends inside its frame header"))?;
                    break (w, h);
                }
                0xd9 | 0xda => {
                    return Err(image_err(
                        i as u64 - 1,
                        "expected a JPEG frame header (SOF) before the scan",
                    ))
                }
                _ => {
                    let len = be16(i)
                        .ok_or_else(|| image_err(i as u64, "JPEG ends inside a segment length"))?;
                    if len < 2 {
                        return Err(image_err(
                            i as u64,
                            format!("bad JPEG segment length {len}"),
                        ));
                    }
                    i += len as usize;
                }
            }
        }
    } else if b.len() >= 2 && b[0] == b'P' && matches!(b[1], b'2' | b'3' | b'5' | b'6') {
        // Tokens after the magic, skipping '#' comments to end of line.
        let mut i = 2usize;
        let mut nums = [0u32; 2];
        for (k, what) in ["width", "height"].iter().enumerate() {
            loop {
                match b.get(i) {
                    Some(c) if c.is_ascii_whitespace() => i += 1,
                    Some(b'#') => {
                        while b.get(i).is_some_and(|&c| c != b'\n') {
                            i += 1;
                        }
                    }
                    _ => break,
                }
            }
            let start = i;
            while b.get(i).is_some_and(u8::is_ascii_digit) {
                i += 1;
            }
            nums[k] = std::str::from_utf8(&b[start..i])
                .ok()
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| image_err(start as u64, format!("expected the PNM {what}")))?;
        }
        (nums[0], nums[1])
    } else {
        return Err(image_err(0, "expected a JPEG, PNG or PPM/PGM image"));
    };
    if size.0 == 0 || size.1 == 0 {
        return Err(image_err(
            0,
            format!("image has zero size {}x{}", size.0, size.1),
        ));
    }
    Ok(size)
}

/// Image size from a file's header; errors name the file.
pub fn image_size_path(path: &Path) -> Result<(u32, u32), PmvsError> {
    let file = File::open(path).map_err(io_in(path))?;
    image_size(BufReader::new(file)).map_err(|e| e.in_file(path))
}

/// The image of PMVS image number `index` in `dir/visualize/`, trying the known extensions.
pub fn find_image(dir: &Path, index: u32) -> Option<PathBuf> {
    IMAGE_EXTENSIONS
        .iter()
        .map(|ext| dir.join("visualize").join(format!("{index:08}.{ext}")))
        .find(|p| p.is_file())
}

/// Image numbers present in `dir/txt/` (files named `%08d.txt`), sorted.
fn camera_numbers(dir: &Path) -> Result<Vec<u32>, PmvsError> {
    let txt = dir.join("txt");
    let mut numbers = Vec::new();
    for entry in fs::read_dir(&txt).map_err(io_in(&txt))? {
        let name = entry.map_err(io_in(&txt))?.file_name();
        let name = name.to_string_lossy();
        if let Some(stem) = name.strip_suffix(".txt") {
            if stem.len() == 8 && stem.bytes().all(|c| c.is_ascii_digit()) {
                if let Ok(n) = stem.parse::<u32>() {
                    numbers.push(n);
                }
            }
        }
    }
    numbers.sort_unstable();
    Ok(numbers)
}

/// Reads a PMVS workspace into a [`Scene`].
///
/// Views: one per `txt/%08d.txt`, in number order; `View::id` is the PMVS image number,
/// `name` the image file name and `image_path` its path in `visualize/` (its size, read from
/// the header, sets the camera size; a missing image is an error). Points: all patches of all
/// `models/*.patch` files (CMVS clusters share the image numbering), in file-name order, with
/// unit normals, tracks = the *visible* lists mapped to view indices (sorted, unique),
/// `confidence` = NCC score clamped to `[0, 1]`, `errors` = 0 and colour [`PATCH_COLOR`].
pub fn read_pmvs(dir: &Path) -> Result<Scene, PmvsError> {
    let mut views = Vec::new();
    let mut index_of = HashMap::new();
    for number in camera_numbers(dir)? {
        let txt = dir.join("txt").join(format!("{number:08}.txt"));
        let p = read_projection_path(&txt)?;
        let image = find_image(dir, number).ok_or_else(|| PmvsError::Io {
            file: dir.join("visualize").join(format!("{number:08}.jpg")).display().to_string(),
            source: io::Error::new(
                io::ErrorKind::NotFound,
                "image not found (tried jpg, jpeg, png, ppm, pgm); its size is needed for the camera",
            ),
        })?;
        let (w, h) = image_size_path(&image)?;
        let (camera, cam_from_world) =
            camera_from_projection(&p, w, h).map_err(|e| e.in_file(&txt))?;
        index_of.insert(number, views.len() as u32);
        views.push(View {
            id: number,
            name: image
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            camera,
            cam_from_world,
            image_path: Some(image),
        });
    }
    let models = dir.join("models");
    let mut patch_files: Vec<PathBuf> = fs::read_dir(&models)
        .map_err(io_in(&models))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "patch"))
        .collect();
    patch_files.sort();
    let mut cloud = SparseCloud {
        normals: Some(Vec::new()),
        ..SparseCloud::default()
    };
    for file in &patch_files {
        let text =
            read_text(File::open(file).map_err(io_in(file))?).map_err(|e| e.in_file(file))?;
        let patches = read_patches(text.as_bytes()).map_err(|e| e.in_file(file))?;
        for (k, patch) in patches.iter().enumerate() {
            let mut track = Vec::with_capacity(patch.visible.len());
            for n in &patch.visible {
                let v = index_of.get(n).ok_or_else(|| PmvsError::Format {
                    file: file.display().to_string(),
                    line: patch_line(&text, k),
                    message: format!(
                        "patch {k} is visible in image {n}, but txt/{n:08}.txt does not exist"
                    ),
                })?;
                track.push(*v);
            }
            track.sort_unstable();
            track.dedup();
            cloud.positions.push(patch.position);
            if let Some(normals) = cloud.normals.as_mut() {
                normals.push(patch.normal);
            }
            cloud.colors.push(PATCH_COLOR);
            cloud.tracks.push(track);
            cloud.errors.push(0.0);
            cloud.confidence.push(patch.score.clamp(0.0, 1.0));
        }
    }
    Ok(Scene { views, cloud })
}

/// Line of the `k`-th `PATCHS`/`PATCHA` token (for errors found after parsing).
fn patch_line(text: &str, k: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| matches!(l.trim(), "PATCHS" | "PATCHA"))
        .nth(k)
        .map_or(1, |(i, _)| i + 1)
}

/// Writes `scene` as a PMVS workspace in `dir`: `txt/%08d.txt` per view (numbered by view
/// index, so `View::id`s are not kept), `models/option-0000.patch` with one patch per point
/// (track = visible list, score = confidence, no possibly-visible images), and an empty
/// `visualize/` for the caller to put images in (as `%08d.jpg|png|ppm`). Needs undistorted
/// cameras and normals. Every file is written atomically.
pub fn write_pmvs(dir: &Path, scene: &Scene) -> Result<(), PmvsError> {
    let normals = scene
        .cloud
        .normals
        .as_ref()
        .ok_or_else(|| PmvsError::Camera {
            file: dir.display().to_string(),
            message: "PMVS patches need normals, the cloud has none".into(),
        })?;
    let invalid = |message: String| PmvsError::Camera {
        file: dir.display().to_string(),
        message,
    };
    scene
        .cloud
        .validate(scene.views.len())
        .map_err(|e| invalid(e.to_string()))?;
    for sub in ["txt", "models", "visualize"] {
        let d = dir.join(sub);
        fs::create_dir_all(&d).map_err(io_in(&d))?;
    }
    for (i, view) in scene.views.iter().enumerate() {
        let path = dir.join("txt").join(format!("{i:08}.txt"));
        let p = projection_from_camera(&view.camera, &view.cam_from_world)
            .map_err(|e| invalid(format!("view {i} ({}): {e}", view.name)))?;
        write_atomic(&path, |w| write_projection(w, &p)).map_err(|e| e.in_file(&path))?;
    }
    let patches: Vec<Patch> = (0..scene.cloud.len())
        .map(|i| Patch {
            position: scene.cloud.positions[i],
            normal: normals[i],
            score: scene.cloud.confidence[i],
            debug: [0.0, 0.0],
            visible: scene.cloud.tracks[i].clone(),
            possibly_visible: Vec::new(),
        })
        .collect();
    let path = dir.join("models").join("option-0000.patch");
    write_atomic(&path, |w| write_patches(w, &patches)).map_err(|e| e.in_file(&path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::look_at;
    use nalgebra::{Point3, Vector2};

    #[test]
    fn projection_round_trip_projects_identically() -> Result<(), PmvsError> {
        let camera = Camera::pinhole(640, 480, 510.0, 495.0, 321.7, 243.2);
        let pose = look_at(
            &Vector3::new(3.0, -1.0, 2.0),
            &Vector3::new(0.1, 0.2, -0.3),
            &Vector3::new(0.0, 0.0, 1.0),
        );
        let p = projection_from_camera(&camera, &pose)?;
        // Any non-zero scale, including negative, gives the same camera.
        let (cam2, pose2) = camera_from_projection(&(-3.7 * p), 640, 480)?;
        for x in [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.5, -0.4, 0.9)] {
            let a = camera.project(&(pose * Point3::from(x)).coords).unwrap();
            let b = cam2.project(&(pose2 * Point3::from(x)).coords).unwrap();
            assert!((a - b).norm() < 1e-9, "{a} vs {b}");
            // PMVS pixel convention: P x gives planemap coordinates minus 0.5.
            let h = p * x.push(1.0);
            let pm = Vector2::new(h.x / h.z, h.y / h.z);
            assert!((pm + Vector2::new(0.5, 0.5) - a).norm() < 1e-9);
        }
        assert!((cam2.fx() - 510.0).abs() < 1e-9 && (cam2.cy() - 243.2).abs() < 1e-9);
        Ok(())
    }

    #[test]
    fn skew_and_singular_are_rejected() {
        let mut p = Matrix3x4::new(
            500.0, 50.0, 320.0, 0.0, 0.0, 500.0, 240.0, 0.0, 0.0, 0.0, 1.0, 1.0,
        );
        let err = camera_from_projection(&p, 640, 480)
            .unwrap_err()
            .to_string();
        assert!(err.contains("skew"), "{err}");
        p[(0, 1)] = 0.0;
        p.set_row(2, &nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0));
        let err = camera_from_projection(&p, 640, 480)
            .unwrap_err()
            .to_string();
        assert!(err.contains("singular"), "{err}");
    }

    #[test]
    fn absurd_principal_point_is_rejected() {
        // A principal point 12 image widths away: the scene loader refuses the camera.
        let camera = Camera::pinhole(640, 480, 500.0, 500.0, 8000.0, 240.0);
        let p = projection_from_camera(&camera, &Rigid3::identity()).unwrap();
        let err = camera_from_projection(&p, 640, 480)
            .unwrap_err()
            .to_string();
        assert!(err.contains("principal point"), "{err}");
    }

    #[test]
    fn patches_round_trip_and_patcha_is_read() -> Result<(), PmvsError> {
        let text = "PATCHES\n2\nPATCHS\n1 2 3 1\n0 0 2 0\n0.9 0.1 0.2\n2\n4 1 \n1\n7 \n\n\
                    PATCHA\n2 4 6 2\n1 0 0 0\n0.5 0 0\n3 1 0 0 1\n1\n3\n0\n\n";
        let patches = read_patches(text.as_bytes())?;
        assert_eq!(patches.len(), 2);
        assert_eq!(patches[0].normal, Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(patches[0].visible, vec![4, 1]);
        assert_eq!(patches[0].possibly_visible, vec![7]);
        assert_eq!(patches[1].position, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(patches[1].visible, vec![3]);
        let mut out = Vec::new();
        write_patches(&mut out, &patches)?;
        assert_eq!(read_patches(&out[..])?, patches);
        Ok(())
    }

    #[test]
    fn patch_errors_name_lines() {
        let text = "PATCHES\n1\nPATCHS\n1 2 nan 1\n0 0 1 0\n0.9 0 0\n0\n\n0\n\n";
        let err = read_patches(text.as_bytes()).unwrap_err().to_string();
        assert!(err.contains("line 4") && err.contains("finite"), "{err}");
        let text = "PATCHES\n1\nPATCHS\n1 2 3 1\n0 0 0 0\n0.9 0 0\n0\n\n0\n\n";
        let err = read_patches(text.as_bytes()).unwrap_err().to_string();
        assert!(err.contains("line 5") && err.contains("normal"), "{err}");
        let err = read_patches(&b"PATCHES\n3\nPATCHS\n1 2"[..])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("line 4") && err.contains("ends early"),
            "{err}"
        );
    }

    #[test]
    fn overflowing_patch_values_are_rejected() {
        // x / w overflows to infinity: a named error, not a non-finite point in the scene.
        let text = "PATCHES\n1\nPATCHS\n1e300 2 3 1e-300\n0 0 1 0\n0.9 0 0\n0\n\n0\n\n";
        let err = read_patches(text.as_bytes()).unwrap_err().to_string();
        assert!(
            err.contains("line 4") && err.contains("finite position"),
            "{err}"
        );
        let text = "PATCHES\n1\nPATCHS\n1 2 3 1\n1e300 1e300 0 0\n0.9 0 0\n0\n\n0\n\n";
        let err = read_patches(text.as_bytes()).unwrap_err().to_string();
        assert!(
            err.contains("line 5") && err.contains("finite length"),
            "{err}"
        );
    }

    #[test]
    fn image_headers() -> Result<(), PmvsError> {
        // Minimal JPEG: SOI, an APP0 segment, SOF0 with height 480 and width 640.
        let jpeg = [
            0xff, 0xd8, 0xff, 0xe0, 0x00, 0x04, 0x00, 0x00, 0xff, 0xc0, 0x00, 0x0b, 0x08, 0x01,
            0xe0, 0x02, 0x80, 0x01, 0x01, 0x11, 0x00,
        ];
        assert_eq!(image_size(&jpeg[..])?, (640, 480));
        assert_eq!(image_size(&b"P6\n# comment\n 12 7\n255\n"[..])?, (12, 7));
        let mut png = Vec::new();
        image::DynamicImage::ImageLuma8(image::GrayImage::new(5, 3))
            .write_to(&mut io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        assert_eq!(image_size(&png[..])?, (5, 3));
        let err = image_size(&jpeg[..10]).unwrap_err().to_string();
        assert!(err.contains("byte"), "{err}");
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        #[test]
        fn mutated_input_never_panics(
            edits in proptest::collection::vec(
                (proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>()),
                1..5,
            ),
            cut in proptest::prelude::any::<proptest::sample::Index>(),
        ) {
            let mut bytes = b"PATCHES\n2\nPATCHS\n1 2 3 1\n0 0 2 0\n0.9 0.1 0.2\n2\n4 1 \n1\n7 \n\nPATCHA\n2 4 6 2\n1 0 0 0\n0.5 0 0\n3 1 0 0 1\n1\n3\n0\n\n".to_vec();
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            bytes.truncate(cut.index(bytes.len() + 1).max(bytes.len() / 2));
            let _ = read_patches(&bytes[..]);
            let _ = read_projection(&bytes[..]);
            let _ = image_size(&bytes[..]);
        }
    }
}
