//! PLY point clouds and triangle meshes.
//!
//! Writers produce `binary_little_endian 1.0` with `float x y z`, optional `float nx ny nz`,
//! optional `uchar red green blue` — the vertex layout of COLMAP's `fused.ply`, which MeshLab,
//! Open3D, CloudCompare and trimesh open — and, for meshes, `element face` with
//! `property list uchar int vertex_indices`. Positions and normals are stored as `f32`.
//!
//! Readers accept `ascii`, `binary_little_endian` and `binary_big_endian`; every scalar type
//! (`char uchar short ushort int uint float double` and the `int8 … float64` aliases);
//! unknown elements and properties (scalar or list, any count/item types) are skipped. Errors
//! name the file and the line (header, ASCII body) or byte offset (binary body) and say what
//! was expected. Malformed input never panics and never makes the reader allocate more than
//! the file's own size (counts from the header are not trusted for allocation).

use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::Path;

use nalgebra::Vector3;
use thiserror::Error;

use crate::io::atomic::write_atomic;

const STREAM: &str = "<stream>";
/// Longest header line accepted.
const MAX_HEADER_LINE: u64 = 4096;
/// Most header lines accepted (guards against reading a huge non-PLY file as a header).
const MAX_HEADER_LINES: usize = 10_000;
/// Largest up-front reservation, in elements, whatever the header's counts say.
const MAX_RESERVE: usize = 1 << 16;

/// Where in a file a problem is: a line (header, ASCII body) or a byte offset (binary body).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// 1-based line number.
    Line(usize),
    /// 0-based byte offset.
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
        }
    }
}

/// Errors reading or writing PLY files.
#[derive(Debug, Error)]
pub enum PlyError {
    /// The file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The OS error.
        source: io::Error,
    },
    /// The file is malformed or lacks what the reader needs.
    #[error("{file}: {location}: {message}")]
    Format {
        /// The file.
        file: String,
        /// Where.
        location: Location,
        /// What was expected.
        message: String,
    },
    /// The data given to a writer is inconsistent (e.g. 10 positions but 9 colours).
    #[error("{file}: cannot write PLY: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// Why.
        message: String,
    },
}

impl PlyError {
    fn in_file(self, path: &Path) -> Self {
        let file = path.display().to_string();
        match self {
            PlyError::Io { source, .. } => PlyError::Io { file, source },
            PlyError::Format {
                location, message, ..
            } => PlyError::Format {
                file,
                location,
                message,
            },
            PlyError::Invalid { message, .. } => PlyError::Invalid { file, message },
        }
    }
}

impl From<io::Error> for PlyError {
    fn from(source: io::Error) -> Self {
        PlyError::Io {
            file: STREAM.into(),
            source,
        }
    }
}

fn format_err(location: Location, message: impl Into<String>) -> PlyError {
    PlyError::Format {
        file: STREAM.into(),
        location,
        message: message.into(),
    }
}

fn invalid(message: impl Into<String>) -> PlyError {
    PlyError::Invalid {
        file: STREAM.into(),
        message: message.into(),
    }
}

/// An oriented, coloured point cloud (e.g. COLMAP's `fused.ply`, planemap's fused output).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlyPoints {
    /// Positions (world frame; stored as `f32`).
    pub positions: Vec<Vector3<f64>>,
    /// Normals, one per point, if any.
    pub normals: Option<Vec<Vector3<f64>>>,
    /// 8-bit RGB colours, one per point, if any.
    pub colors: Option<Vec<[u8; 3]>>,
}

/// A triangle mesh (e.g. planemap's planar mesh).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlyMesh {
    /// Vertex positions (world frame; stored as `f32`).
    pub vertices: Vec<Vector3<f64>>,
    /// Triangles as indices into `vertices`.
    pub faces: Vec<[u32; 3]>,
    /// 8-bit RGB colour per vertex, if any.
    pub vertex_colors: Option<Vec<[u8; 3]>>,
}

// ---------------------------------------------------------------------------------------
// Header

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }

    fn range(self) -> (i64, i64) {
        match self {
            Scalar::I8 => (i8::MIN as i64, i8::MAX as i64),
            Scalar::U8 => (0, u8::MAX as i64),
            Scalar::I16 => (i16::MIN as i64, i16::MAX as i64),
            Scalar::U16 => (0, u16::MAX as i64),
            Scalar::I32 => (i32::MIN as i64, i32::MAX as i64),
            Scalar::U32 => (0, u32::MAX as i64),
            Scalar::F32 | Scalar::F64 => (i64::MIN, i64::MAX),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Header line declaring it.
    line: usize,
}

impl Element {
    fn find(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

#[derive(Debug)]
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Number of header lines (the `end_header` line's number).
    lines: usize,
    /// Header size in bytes (offset of the body).
    bytes: u64,
}

fn read_header<R: BufRead>(r: &mut R) -> Result<Header, PlyError> {
    let mut line_no = 0usize;
    let mut bytes = 0u64;
    let mut buf = Vec::new();
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        buf.clear();
        let n = r
            .by_ref()
            .take(MAX_HEADER_LINE)
            .read_until(b'\n', &mut buf)?;
        line_no += 1;
        let here = Location::Line(line_no);
        if n == 0 {
            return Err(format_err(
                here,
                "file ends inside the header, expected \"end_header\"",
            ));
        }
        if buf.last() != Some(&b'\n') {
            return Err(format_err(
                here,
                if n as u64 >= MAX_HEADER_LINE {
                    "header line too long".to_string()
                } else {
                    "file ends inside the header, expected \"end_header\"".to_string()
                },
            ));
        }
        if line_no > MAX_HEADER_LINES {
            return Err(format_err(here, "header too long, expected \"end_header\""));
        }
        bytes += n as u64;
        let text = std::str::from_utf8(&buf)
            .map_err(|_| format_err(here, "header line is not ASCII text"))?;
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if line_no == 1 {
            if words != ["ply"] {
                return Err(format_err(
                    here,
                    format!("expected \"ply\", found {:?}", text.trim_end()),
                ));
            }
            continue;
        }
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if words.len() != 3 || words[2] != "1.0" {
                    return Err(format_err(
                        here,
                        format!(
                            "expected \"format <encoding> 1.0\", found {:?}",
                            text.trim_end()
                        ),
                    ));
                }
                encoding = Some(match words[1] {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::LittleEndian,
                    "binary_big_endian" => Encoding::BigEndian,
                    other => {
                        return Err(format_err(
                            here,
                            format!("expected ascii, binary_little_endian or binary_big_endian, found {other:?}"),
                        ))
                    }
                });
            }
            Some("element") => {
                let count = match (
                    words.len(),
                    words.get(2).and_then(|c| c.parse::<u64>().ok()),
                ) {
                    (3, Some(c)) => c,
                    _ => {
                        return Err(format_err(
                            here,
                            format!(
                                "expected \"element <name> <count>\", found {:?}",
                                text.trim_end()
                            ),
                        ))
                    }
                };
                elements.push(Element {
                    name: words[1].to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            Some("property") => {
                let element = elements.last_mut().ok_or_else(|| {
                    format_err(here, "expected \"element\" before the first \"property\"")
                })?;
                let ty = |name: &str| {
                    Scalar::parse(name).ok_or_else(|| {
                        format_err(here, format!("expected a scalar type (char, uchar, short, ushort, int, uint, float, double or int8..float64), found {name:?}"))
                    })
                };
                let (kind, name) = match words.as_slice() {
                    [_, "list", count, item, name] => {
                        let count = ty(count)?;
                        if count.is_float() {
                            return Err(format_err(here, "expected an integer list count type, found a float type"));
                        }
                        (Kind::List { count, item: ty(item)? }, name)
                    }
                    [_, t, name] if *t != "list" => (Kind::Scalar(ty(t)?), name),
                    _ => {
                        return Err(format_err(
                            here,
                            format!("expected \"property <type> <name>\" or \"property list <count type> <item type> <name>\", found {:?}", text.trim_end()),
                        ))
                    }
                };
                element.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(format_err(
                    here,
                    format!(
                    "expected format, element, property, comment or end_header, found {other:?}"
                ),
                ))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| {
        format_err(
            Location::Line(line_no),
            "no \"format\" line before \"end_header\"",
        )
    })?;
    Ok(Header {
        encoding,
        elements,
        lines: line_no,
        bytes,
    })
}

// ---------------------------------------------------------------------------------------
// Body readers

/// What is being read, for error messages (formatted only on error).
struct Ctx<'a> {
    element: &'a str,
    row: u64,
    prop: &'a str,
}

impl fmt::Display for Ctx<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "property {:?} of {} {}",
            self.prop, self.element, self.row
        )
    }
}

trait Body {
    fn location(&self) -> Location;
    /// Location of the next value (ASCII: skips blank space and line breaks first).
    fn next_location(&mut self) -> Result<Location, PlyError> {
        Ok(self.location())
    }
    fn scalar(&mut self, ty: Scalar, ctx: &Ctx) -> Result<f64, PlyError>;
}

struct AsciiBody<R> {
    r: R,
    line: usize,
    buf: Vec<u8>,
    pos: usize,
}

impl<R: BufRead> AsciiBody<R> {
    /// Moves to the next token; `false` at end of file.
    fn skip_space(&mut self) -> Result<bool, PlyError> {
        loop {
            while self.pos < self.buf.len() && self.buf[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if self.pos < self.buf.len() {
                return Ok(true);
            }
            self.buf.clear();
            self.pos = 0;
            if self.r.read_until(b'\n', &mut self.buf)? == 0 {
                return Ok(false);
            }
            self.line += 1;
        }
    }
}

impl<R: BufRead> Body for AsciiBody<R> {
    fn location(&self) -> Location {
        Location::Line(self.line)
    }

    fn next_location(&mut self) -> Result<Location, PlyError> {
        self.skip_space()?;
        Ok(Location::Line(self.line))
    }

    fn scalar(&mut self, ty: Scalar, ctx: &Ctx) -> Result<f64, PlyError> {
        if !self.skip_space()? {
            return Err(format_err(
                Location::Line(self.line),
                format!("file ends early, expected {} {ctx}", ty.name()),
            ));
        }
        let start = self.pos;
        while self.pos < self.buf.len() && !self.buf[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let here = Location::Line(self.line);
        let token = std::str::from_utf8(&self.buf[start..self.pos]).unwrap_or("<non-ASCII>");
        let bad = || {
            format_err(
                here,
                format!("expected {} {ctx}, found {token:?}", ty.name()),
            )
        };
        if ty.is_float() {
            token.parse::<f64>().map_err(|_| bad())
        } else {
            let (lo, hi) = ty.range();
            match token.parse::<i64>() {
                Ok(v) if v >= lo && v <= hi => Ok(v as f64),
                _ => Err(bad()),
            }
        }
    }
}

struct BinaryBody<R> {
    r: R,
    offset: u64,
    big: bool,
}

impl<R: Read> Body for BinaryBody<R> {
    fn location(&self) -> Location {
        Location::Byte(self.offset)
    }

    fn scalar(&mut self, ty: Scalar, ctx: &Ctx) -> Result<f64, PlyError> {
        let n = ty.size();
        let mut b = [0u8; 8];
        if let Err(e) = self.r.read_exact(&mut b[..n]) {
            return Err(if e.kind() == io::ErrorKind::UnexpectedEof {
                format_err(
                    Location::Byte(self.offset),
                    format!("file ends early, expected {} {ctx}", ty.name()),
                )
            } else {
                e.into()
            });
        }
        self.offset += n as u64;
        if self.big {
            b[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// Which properties of an element a reader wants: `slots[p] = Some(k)` stores scalar property
/// `p` in `row[k]`; `list` is the one list property whose items are kept.
struct Wanted {
    slots: Vec<Option<usize>>,
    num_slots: usize,
    list: Option<usize>,
}

impl Wanted {
    fn none(el: &Element) -> Self {
        Wanted {
            slots: vec![None; el.props.len()],
            num_slots: 0,
            list: None,
        }
    }

    /// Wants the scalar properties `names` (in that slot order).
    fn scalars(el: &Element, names: &[usize]) -> Self {
        let mut w = Wanted::none(el);
        for (k, &p) in names.iter().enumerate() {
            w.slots[p] = Some(k);
        }
        w.num_slots = names.len();
        w
    }
}

/// Reads every row of `el`, calling `on_row(row_index, scalars, list_items, row_start)`.
fn read_element<B: Body>(
    body: &mut B,
    el: &Element,
    wanted: &Wanted,
    mut on_row: impl FnMut(u64, &[f64], &[f64], Location) -> Result<(), PlyError>,
) -> Result<(), PlyError> {
    if el.props.is_empty() {
        // Rows without properties occupy no bytes: nothing to read, whatever the count.
        return Ok(());
    }
    let mut row = vec![0f64; wanted.num_slots];
    let mut items = Vec::new();
    for i in 0..el.count {
        let start = body.next_location()?;
        items.clear();
        for (p, prop) in el.props.iter().enumerate() {
            let ctx = Ctx {
                element: &el.name,
                row: i,
                prop: &prop.name,
            };
            match prop.kind {
                Kind::Scalar(ty) => {
                    let v = body.scalar(ty, &ctx)?;
                    if let Some(k) = wanted.slots[p] {
                        row[k] = v;
                    }
                }
                Kind::List { count, item } => {
                    let at = body.location();
                    let n = body.scalar(count, &ctx)?;
                    if n < 0.0 {
                        return Err(format_err(
                            at,
                            format!("expected a non-negative list length for {ctx}, found {n}"),
                        ));
                    }
                    let keep = wanted.list == Some(p);
                    for _ in 0..n as u64 {
                        let v = body.scalar(item, &ctx)?;
                        if keep {
                            items.push(v);
                        }
                    }
                }
            }
        }
        on_row(i, &row, &items, start)?;
    }
    Ok(())
}

/// Finds a scalar property, or an error naming the element's header line.
fn require(el: &Element, name: &str) -> Result<usize, PlyError> {
    match el.find(name) {
        Some(p) if matches!(el.props[p].kind, Kind::Scalar(_)) => Ok(p),
        Some(_) => Err(format_err(
            Location::Line(el.line),
            format!(
                "expected property {name:?} of element {:?} to be a scalar, found a list",
                el.name
            ),
        )),
        None => Err(format_err(
            Location::Line(el.line),
            format!("expected element {:?} to have a property {name:?}", el.name),
        )),
    }
}

/// Finds all of `names` or none of them (an error if only some are present).
fn optional_group(el: &Element, names: [&str; 3]) -> Result<Option<[usize; 3]>, PlyError> {
    let found = names.map(|n| el.find(n));
    if found.iter().all(Option::is_none) {
        return Ok(None);
    }
    let mut out = [0; 3];
    for (k, n) in names.iter().enumerate() {
        out[k] = require(el, n)?;
    }
    Ok(Some(out))
}

/// The first present trio of colour property names.
/// Property indices of a colour trio and their types.
type ColorProps = ([usize; 3], [Scalar; 3]);

fn color_group(el: &Element) -> Result<Option<ColorProps>, PlyError> {
    for names in [
        ["red", "green", "blue"],
        ["diffuse_red", "diffuse_green", "diffuse_blue"],
    ] {
        if let Some(idx) = optional_group(el, names)? {
            let types = idx.map(|p| match el.props[p].kind {
                Kind::Scalar(t) => t,
                Kind::List { item, .. } => item,
            });
            return Ok(Some((idx, types)));
        }
    }
    Ok(None)
}

/// Integer colours are clamped to 0..=255; float colours are taken as [0, 1] and scaled.
fn to_u8(v: f64, ty: Scalar) -> u8 {
    let v = if ty.is_float() { v * 255.0 } else { v };
    if v.is_nan() {
        0
    } else {
        v.round().clamp(0.0, 255.0) as u8
    }
}

fn ascii_body<R: BufRead>(r: R, header: &Header) -> AsciiBody<R> {
    AsciiBody {
        r,
        line: header.lines,
        buf: Vec::new(),
        pos: 0,
    }
}

fn binary_body<R: BufRead>(r: R, header: &Header) -> BinaryBody<R> {
    BinaryBody {
        r,
        offset: header.bytes,
        big: header.encoding == Encoding::BigEndian,
    }
}

fn finite3(
    v: [f64; 3],
    what: &str,
    el: &Element,
    row: u64,
    at: Location,
) -> Result<Vector3<f64>, PlyError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vector3::new(v[0], v[1], v[2]))
    } else {
        Err(format_err(
            at,
            format!(
                "expected a finite {what} for {} {row}, found {v:?}",
                el.name
            ),
        ))
    }
}

/// Vertex positions and optional colours (and normals if `with_normals`) of `vertex`.
struct VertexData {
    positions: Vec<Vector3<f64>>,
    normals: Option<Vec<Vector3<f64>>>,
    colors: Option<Vec<[u8; 3]>>,
}

fn read_vertices<B: Body>(
    body: &mut B,
    el: &Element,
    with_normals: bool,
) -> Result<VertexData, PlyError> {
    let xyz = [require(el, "x")?, require(el, "y")?, require(el, "z")?];
    let nrm = if with_normals {
        optional_group(el, ["nx", "ny", "nz"])?
    } else {
        None
    };
    let rgb = color_group(el)?;
    let mut names = xyz.to_vec();
    if let Some(n) = nrm {
        names.extend(n);
    }
    if let Some((c, _)) = rgb {
        names.extend(c);
    }
    let wanted = Wanted::scalars(el, &names);
    let reserve = (el.count as usize).min(MAX_RESERVE);
    let mut out = VertexData {
        positions: Vec::with_capacity(reserve),
        normals: nrm.map(|_| Vec::with_capacity(reserve)),
        colors: rgb.map(|_| Vec::with_capacity(reserve)),
    };
    read_element(body, el, &wanted, |i, row, _, at| {
        out.positions
            .push(finite3([row[0], row[1], row[2]], "position", el, i, at)?);
        let mut k = 3;
        if let Some(normals) = out.normals.as_mut() {
            normals.push(finite3([row[3], row[4], row[5]], "normal", el, i, at)?);
            k = 6;
        }
        if let (Some(colors), Some((_, types))) = (out.colors.as_mut(), rgb) {
            colors.push([
                to_u8(row[k], types[0]),
                to_u8(row[k + 1], types[1]),
                to_u8(row[k + 2], types[2]),
            ]);
        }
        Ok(())
    })?;
    Ok(out)
}

/// Reads a PLY point cloud from a stream: element `vertex` with `x y z`, optional
/// `nx ny nz` and `red green blue` (or `diffuse_*`). Other elements (e.g. faces) and
/// properties are skipped. Non-finite positions or normals are errors.
pub fn read_ply_points<R: BufRead>(mut r: R) -> Result<PlyPoints, PlyError> {
    let header = read_header(&mut r)?;
    // One monomorphised reader per encoding: no dynamic dispatch per value.
    match header.encoding {
        Encoding::Ascii => points_body(&header, ascii_body(r, &header)),
        _ => points_body(&header, binary_body(r, &header)),
    }
}

fn points_body<B: Body>(header: &Header, mut body: B) -> Result<PlyPoints, PlyError> {
    if !header.elements.iter().any(|e| e.name == "vertex") {
        return Err(format_err(
            Location::Line(header.lines),
            "expected an element \"vertex\" in the header",
        ));
    }
    let mut points = None;
    for el in &header.elements {
        if el.name == "vertex" && points.is_none() {
            let v = read_vertices(&mut body, el, true)?;
            points = Some(PlyPoints {
                positions: v.positions,
                normals: v.normals,
                colors: v.colors,
            });
        } else {
            read_element(&mut body, el, &Wanted::none(el), |_, _, _, _| Ok(()))?;
        }
    }
    points.ok_or_else(|| format_err(Location::Line(header.lines), "no vertex element"))
}

/// Reads a PLY point cloud file; errors name the file.
pub fn read_ply_points_path(path: &Path) -> Result<PlyPoints, PlyError> {
    let file = File::open(path).map_err(|e| PlyError::from(e).in_file(path))?;
    read_ply_points(BufReader::new(file)).map_err(|e| e.in_file(path))
}

/// Reads a PLY mesh from a stream: element `vertex` (`x y z`, optional colours) and element
/// `face` with a list property `vertex_indices` (or `vertex_index`). Polygons with more than
/// three corners are split into a triangle fan around their first corner; faces with fewer
/// than three corners, or indices outside the vertex list, are errors.
pub fn read_ply_mesh<R: BufRead>(mut r: R) -> Result<PlyMesh, PlyError> {
    let header = read_header(&mut r)?;
    match header.encoding {
        Encoding::Ascii => mesh_body(&header, ascii_body(r, &header)),
        _ => mesh_body(&header, binary_body(r, &header)),
    }
}

fn mesh_body<B: Body>(header: &Header, mut body: B) -> Result<PlyMesh, PlyError> {
    let vertex_el = header
        .elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or_else(|| {
            format_err(
                Location::Line(header.lines),
                "expected an element \"vertex\" in the header",
            )
        })?;
    let face_el = header
        .elements
        .iter()
        .find(|e| e.name == "face")
        .ok_or_else(|| {
            format_err(
                Location::Line(header.lines),
                "expected an element \"face\" in the header",
            )
        })?;
    let list_prop = ["vertex_indices", "vertex_index"]
        .iter()
        .find_map(|n| face_el.find(n))
        .filter(|&p| matches!(face_el.props[p].kind, Kind::List { .. }))
        .ok_or_else(|| {
            format_err(
                Location::Line(face_el.line),
                "expected element \"face\" to have a list property \"vertex_indices\"",
            )
        })?;
    let num_vertices = vertex_el.count;
    let mut mesh = PlyMesh::default();
    let (mut seen_vertex, mut seen_face) = (false, false);
    for el in &header.elements {
        if el.name == "vertex" && !seen_vertex {
            seen_vertex = true;
            let v = read_vertices(&mut body, el, false)?;
            mesh.vertices = v.positions;
            mesh.vertex_colors = v.colors;
        } else if el.name == "face" && !seen_face {
            seen_face = true;
            let mut wanted = Wanted::none(el);
            wanted.list = Some(list_prop);
            mesh.faces.reserve((el.count as usize).min(MAX_RESERVE));
            let faces = &mut mesh.faces;
            read_element(&mut body, el, &wanted, |i, _, items, at| {
                if items.len() < 3 {
                    return Err(format_err(
                        at,
                        format!(
                            "expected at least 3 vertex indices for face {i}, found {}",
                            items.len()
                        ),
                    ));
                }
                let mut idx = [0u32; 3];
                let get = |k: usize| -> Result<u32, PlyError> {
                    let v = items[k];
                    if v >= 0.0 && v < num_vertices as f64 && v.fract() == 0.0 {
                        Ok(v as u32)
                    } else {
                        Err(format_err(at, format!("expected vertex indices in 0..{num_vertices} for face {i}, found {v}")))
                    }
                };
                idx[0] = get(0)?;
                for k in 1..items.len() - 1 {
                    idx[1] = get(k)?;
                    idx[2] = get(k + 1)?;
                    faces.push(idx);
                }
                Ok(())
            })?;
        } else {
            read_element(&mut body, el, &Wanted::none(el), |_, _, _, _| Ok(()))?;
        }
    }
    Ok(mesh)
}

/// Reads a PLY mesh file; errors name the file.
pub fn read_ply_mesh_path(path: &Path) -> Result<PlyMesh, PlyError> {
    let file = File::open(path).map_err(|e| PlyError::from(e).in_file(path))?;
    read_ply_mesh(BufReader::new(file)).map_err(|e| e.in_file(path))
}

mod write;
pub use write::{write_ply_mesh, write_ply_mesh_path, write_ply_points, write_ply_points_path};

#[cfg(test)]
mod tests;
