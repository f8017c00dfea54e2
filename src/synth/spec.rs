//! The scene description read from TOML: camera, lighting, materials, objects, camera rigs
//! and the parameters of the SfM-like sparse sampling. `scenes/README.md` documents the
//! format with examples; every field here says its unit and default.
//!
//! World frame: metres, z up. Directions need not be unit (they are normalised).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::SynthError;

/// Largest image side the renderer accepts, in pixels (spec or `--width`/`--height`). The
/// largest photographs taken are ~14k px wide; beyond 16384 a size is a typo, and refusing
/// it is better than an allocation failure that aborts the process.
pub const MAX_IMAGE_SIDE: u32 = 16_384;
/// Largest image the renderer accepts, in pixels (2^26 ≈ 67 Mpx, e.g. 8192×8192). Rendering
/// keeps about 52 bytes per pixel (image, clean images, depth, normals, plane ids, texture
/// mask), so one such view takes ~3.5 GB.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 26;
/// Most views a scene may have (all rigs together). The benchmark scenes have ≤ 22; real SfM
/// datasets a few thousand. Each view is rendered and kept in memory.
pub const MAX_VIEWS: usize = 10_000;
/// Most pixels over all views (2^27 ≈ 134 Mpx, ~7 GB of render buffers), since every view's
/// buffers are kept until the workspace is written.
pub const MAX_TOTAL_PIXELS: u64 = 1 << 27;

/// Checks an image size and view count against [`MAX_IMAGE_SIDE`], [`MAX_IMAGE_PIXELS`] and
/// [`MAX_TOTAL_PIXELS`]. `field` names where the size came from (`camera` or the render
/// option) for the message.
pub(crate) fn check_render_size(
    width: u32,
    height: u32,
    views: usize,
    field: &str,
) -> Result<(), String> {
    for (name, v) in [("width", width), ("height", height)] {
        if v > MAX_IMAGE_SIDE {
            return Err(format!(
                "{field}{name} {v} exceeds the limit of {MAX_IMAGE_SIDE} pixels"
            ));
        }
    }
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_IMAGE_PIXELS {
        return Err(format!(
            "{field}width x {field}height = {width}x{height} = {pixels} pixels exceeds the \
             limit of {MAX_IMAGE_PIXELS} pixels per image"
        ));
    }
    let total = pixels.saturating_mul(views as u64);
    if total > MAX_TOTAL_PIXELS {
        return Err(format!(
            "{views} views of {width}x{height} are {total} pixels, over the limit of \
             {MAX_TOTAL_PIXELS} pixels for all views together (reduce {field}width/{field}height \
             or the rigs' counts)"
        ));
    }
    Ok(())
}

/// A whole synthetic scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Scene name (used for output folders and reports).
    pub name: String,
    /// Free text: what the scene tests.
    #[serde(default)]
    pub description: String,
    /// Benchmark category (`planemap bench --scenes CATEGORY`), e.g. "manhattan-interior",
    /// "non-manhattan", "hard"; free text, not used by the renderer (and not written when
    /// empty, so existing scenes serialise as before).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub category: String,
    /// Seed of every random choice (textures, noise, exposures, sparse points).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Intrinsics shared by all views.
    pub camera: CameraSpec,
    /// Sun, ambient light and sky.
    #[serde(default)]
    pub lighting: LightingSpec,
    /// Antialiasing, image noise, exposure changes, plane merging.
    #[serde(default)]
    pub render: RenderSpec,
    /// SfM-like sparse point sampling.
    #[serde(default)]
    pub sparse: SparseSpec,
    /// Materials by name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// The geometry.
    #[serde(default)]
    pub objects: Vec<ObjectSpec>,
    /// Camera rigs; their views are concatenated in order.
    #[serde(default)]
    pub rigs: Vec<RigSpec>,
}

fn default_seed() -> u64 {
    1
}

/// Intrinsics: size and either a horizontal field of view or a focal length.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Image width in pixels (default 320).
    #[serde(default = "default_width")]
    pub width: u32,
    /// Image height in pixels (default 240).
    #[serde(default = "default_height")]
    pub height: u32,
    /// Horizontal field of view in degrees (used when `focal_px` is absent; default 70).
    #[serde(default)]
    pub hfov_deg: Option<f64>,
    /// Focal length in pixels (square pixels); overrides `hfov_deg`.
    #[serde(default)]
    pub focal_px: Option<f64>,
    /// SIMPLE_RADIAL coefficient `k` (COLMAP); 0 renders through a SIMPLE_PINHOLE camera.
    #[serde(default)]
    pub radial_k: f64,
}

fn default_width() -> u32 {
    320
}
fn default_height() -> u32 {
    240
}

/// Lambertian lighting: a directional sun plus ambient light, and the sky colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LightingSpec {
    /// Direction the sunlight travels (world frame; default `[0.4, 0.25, -1]`).
    pub sun_direction: [f64; 3],
    /// Sun irradiance factor (default 0.6).
    pub sun_intensity: f64,
    /// Ambient factor (default 0.45).
    pub ambient: f64,
    /// Background colour, linear RGB in [0, 1] (default light blue).
    pub sky_color: [f64; 3],
}

impl Default for LightingSpec {
    fn default() -> Self {
        LightingSpec {
            sun_direction: [0.4, 0.25, -1.0],
            sun_intensity: 0.6,
            ambient: 0.45,
            sky_color: [0.62, 0.75, 0.92],
        }
    }
}

/// Rendering options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSpec {
    /// Subsamples per pixel along each axis (n×n regular grid; default 2; 1 = centre only).
    pub antialias: u32,
    /// σ of the additive Gaussian image noise, in [0, 1] intensity units (default 0.01).
    pub image_noise: f64,
    /// Per-view exposure factor drawn uniformly from `[1 − j, 1 + j]` (default 0.08).
    pub exposure_jitter: f64,
    /// Faces whose planes differ by at most this angle (degrees; default 0.05)…
    pub plane_merge_angle_deg: f64,
    /// …and this offset (metres; default 0.002) share one ground-truth plane id. Merged faces
    /// are snapped onto the shared plane.
    pub plane_merge_distance: f64,
}

impl Default for RenderSpec {
    fn default() -> Self {
        RenderSpec {
            antialias: 2,
            image_noise: 0.01,
            exposure_jitter: 0.08,
            plane_merge_angle_deg: 0.05,
            plane_merge_distance: 0.002,
        }
    }
}

/// Parameters of the SfM-like sparse points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SparseSpec {
    /// Most corner features detected per view (default 300).
    pub max_features_per_view: usize,
    /// Side of the non-maximum-suppression cell in pixels (default 6).
    pub cell_px: u32,
    /// Minimum Shi–Tomasi response (smaller eigenvalue of the 5×5 structure tensor of the
    /// noise-free grey image, gradients in intensity per pixel; default 0.002).
    pub min_corner_response: f64,
    /// Minimum albedo contrast of the surface texture within the pixel footprint for a
    /// feature to be detected or matched (default 0.03); plain paint has 0.
    pub min_texture_contrast: f64,
    /// Views whose line of sight to a point is more oblique than this (degrees from the
    /// surface normal) do not match it (default 75).
    pub max_view_angle_deg: f64,
    /// Views where the point's pixel footprint is more than this factor larger or smaller
    /// than in the detecting view do not match it (default 3).
    pub max_scale_ratio: f64,
    /// Minimum track length (default 2, at least 2).
    pub min_track: usize,
    /// σ of the Gaussian noise on 2D observations, pixels (default 0.5).
    pub pixel_noise: f64,
    /// Fraction of all points that are outliers off the surfaces (default 0.02).
    pub outlier_fraction: f64,
    /// Whether points carry PMVS-like normals (default true).
    pub normals: bool,
    /// σ of the angular noise on those normals, degrees (default 5).
    pub normal_noise_deg: f64,
}

impl Default for SparseSpec {
    fn default() -> Self {
        SparseSpec {
            max_features_per_view: 300,
            cell_px: 6,
            min_corner_response: 0.002,
            min_texture_contrast: 0.03,
            max_view_angle_deg: 75.0,
            max_scale_ratio: 3.0,
            min_track: 2,
            pixel_noise: 0.5,
            outlier_fraction: 0.02,
            normals: true,
            normal_noise_deg: 5.0,
        }
    }
}

/// Procedural texture kinds, from none to strong.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextureKind {
    /// Constant albedo `color`: no texture at all.
    Paint,
    /// Fractal value noise (fBm) between `color` and `color2`, feature size `scale`.
    Noise,
    /// Checkerboard of squares of side `scale`.
    Checker,
    /// Running-bond bricks `brick_size`, mortar `mortar` in `color2`, per-brick tint.
    Bricks,
    /// Stripes of period `scale` along the surface's first axis.
    Stripes,
    /// Plain `color` with random textured rectangles ("posters") on a grid of cells of
    /// side `scale`, each cell holding one with probability `density`.
    Posters,
}

/// A named material: albedo and a procedural texture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Texture kind (default paint).
    #[serde(default = "default_texture")]
    pub texture: TextureKind,
    /// Base albedo, RGB in [0, 1].
    pub color: [f64; 3],
    /// Second albedo (noise/checker/stripes/mortar; default `color` × 0.45).
    #[serde(default)]
    pub color2: Option<[f64; 3]>,
    /// Texture period or feature size in metres (default 0.2).
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Texture contrast in [0, 1]: 0 = plain `color` (default 1).
    #[serde(default = "default_strength")]
    pub strength: f64,
    /// fBm octaves (default 4).
    #[serde(default = "default_octaves")]
    pub octaves: u32,
    /// Brick width and height in metres (default `[0.24, 0.08]`).
    #[serde(default = "default_brick")]
    pub brick_size: [f64; 2],
    /// Mortar width in metres (default 0.012).
    #[serde(default = "default_mortar")]
    pub mortar: f64,
    /// Horizontal shift of every other brick row as a fraction of a brick (0.5 bricks, 0
    /// tiles).
    #[serde(default = "default_row_offset")]
    pub row_offset: f64,
    /// Posters: probability that a cell holds a poster (default 0.35).
    #[serde(default = "default_density")]
    pub density: f64,
}

fn default_texture() -> TextureKind {
    TextureKind::Paint
}
fn default_scale() -> f64 {
    0.2
}
fn default_strength() -> f64 {
    1.0
}
fn default_octaves() -> u32 {
    4
}
fn default_brick() -> [f64; 2] {
    [0.24, 0.08]
}
fn default_mortar() -> f64 {
    0.012
}
fn default_row_offset() -> f64 {
    0.5
}
fn default_density() -> f64 {
    0.35
}

/// Faces of a box by the axis of their outward normal (in the box's own frame).
pub const BOX_FACES: [&str; 6] = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];

/// One object of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ObjectSpec {
    /// A box: axis-aligned by `min`/`max`, or `center`/`size` with `rotation_deg`.
    Box {
        /// Label prefix of its planes.
        #[serde(default)]
        name: Option<String>,
        /// Material of all faces not in `face_materials`.
        material: String,
        /// Per-face materials, keys `xmin xmax ymin ymax zmin zmax`.
        #[serde(default)]
        face_materials: BTreeMap<String, String>,
        /// Lower corner (axis-aligned form).
        #[serde(default)]
        min: Option<[f64; 3]>,
        /// Upper corner (axis-aligned form).
        #[serde(default)]
        max: Option<[f64; 3]>,
        /// Centre (oriented form).
        #[serde(default)]
        center: Option<[f64; 3]>,
        /// Edge lengths along the box's own axes (oriented form).
        #[serde(default)]
        size: Option<[f64; 3]>,
        /// Rotation about the world x, y, z axes in degrees, applied x first (R = Rz·Ry·Rx).
        #[serde(default)]
        rotation_deg: [f64; 3],
        /// Render the inside faces (a room) instead of the outside.
        #[serde(default)]
        inside: bool,
    },
    /// A rectangle with any orientation.
    Quad {
        /// Label of its plane.
        #[serde(default)]
        name: Option<String>,
        /// Material.
        material: String,
        /// Centre.
        center: [f64; 3],
        /// Width (along the first axis) and height (along `up` projected into the plane).
        size: [f64; 2],
        /// Normal of the visible side.
        normal: [f64; 3],
        /// Direction of the rectangle's height (default world z, or y for a horizontal quad).
        #[serde(default)]
        up: Option<[f64; 3]>,
        /// Visible from both sides.
        #[serde(default)]
        two_sided: bool,
    },
    /// A sphere (non-planar).
    Sphere {
        /// Label.
        #[serde(default)]
        name: Option<String>,
        /// Material.
        material: String,
        /// Centre.
        center: [f64; 3],
        /// Radius in metres.
        radius: f64,
    },
    /// A finite cylinder (non-planar side, planar caps).
    Cylinder {
        /// Label.
        #[serde(default)]
        name: Option<String>,
        /// Material.
        material: String,
        /// Centre of the bottom cap.
        base: [f64; 3],
        /// Axis direction (default z).
        #[serde(default = "default_axis")]
        axis: [f64; 3],
        /// Length along the axis, metres.
        height: f64,
        /// Radius in metres.
        radius: f64,
        /// Close the ends with discs (default true).
        #[serde(default = "default_true")]
        caps: bool,
    },
    /// A flat convex polygon (a gable end, a roof face, a floor of any outline), visible
    /// from the side where its vertices run counter-clockwise.
    Polygon {
        /// Label of its plane.
        #[serde(default)]
        name: Option<String>,
        /// Material.
        material: String,
        /// At least 3 coplanar vertices of a convex polygon, counter-clockwise seen from the
        /// visible side. Texture coordinates are metres along the plane's horizontal and its
        /// upward (for a horizontal polygon, world y) directions.
        vertices: Vec<[f64; 3]>,
        /// Visible from both sides.
        #[serde(default)]
        two_sided: bool,
    },
}

fn default_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}
fn default_true() -> bool {
    true
}

impl ObjectSpec {
    /// The object's name if given.
    pub fn name(&self) -> Option<&str> {
        match self {
            ObjectSpec::Box { name, .. }
            | ObjectSpec::Quad { name, .. }
            | ObjectSpec::Sphere { name, .. }
            | ObjectSpec::Cylinder { name, .. }
            | ObjectSpec::Polygon { name, .. } => name.as_deref(),
        }
    }

    /// The kind as written in TOML.
    pub fn kind(&self) -> &'static str {
        match self {
            ObjectSpec::Box { .. } => "box",
            ObjectSpec::Quad { .. } => "quad",
            ObjectSpec::Sphere { .. } => "sphere",
            ObjectSpec::Cylinder { .. } => "cylinder",
            ObjectSpec::Polygon { .. } => "polygon",
        }
    }
}

/// A camera position and look-at target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewSpec {
    /// Camera centre.
    pub position: [f64; 3],
    /// Point the optical axis goes through.
    pub target: [f64; 3],
}

/// A camera rig: a recipe for a sequence of poses. Image "up" follows `up` (default z).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum RigSpec {
    /// `count` cameras on a horizontal circle (or arc) around `center`, looking at `look_at`.
    Orbit {
        /// Circle centre (its z is ignored: cameras are at `height`).
        center: [f64; 3],
        /// Circle radius, metres.
        radius: f64,
        /// Camera height (world z).
        height: f64,
        /// Number of views.
        count: usize,
        /// Target (default `center`).
        #[serde(default)]
        look_at: Option<[f64; 3]>,
        /// Angle of the first camera, degrees from +x (default 0).
        #[serde(default)]
        start_deg: f64,
        /// Arc covered, degrees (default 360: the last camera does not repeat the first).
        #[serde(default = "default_arc")]
        arc_deg: f64,
        /// Up direction.
        #[serde(default = "default_axis")]
        up: [f64; 3],
    },
    /// A walk-through: explicit `positions` with `targets` (one each, or one shared), or a
    /// polyline `path` sampled at `count` equally spaced points looking at `target` or, when
    /// absent, ahead along the path.
    Walk {
        /// Camera centres.
        #[serde(default)]
        positions: Vec<[f64; 3]>,
        /// Targets, as many as `positions` or exactly one.
        #[serde(default)]
        targets: Vec<[f64; 3]>,
        /// Polyline to sample.
        #[serde(default)]
        path: Vec<[f64; 3]>,
        /// Views along `path`.
        #[serde(default)]
        count: usize,
        /// Fixed target for `path` views.
        #[serde(default)]
        target: Option<[f64; 3]>,
        /// Up direction.
        #[serde(default = "default_axis")]
        up: [f64; 3],
    },
    /// `count` cameras evenly spaced from `start` to `end`, all looking along `facing`
    /// (towards the facade), aimed `distance` metres ahead.
    Facade {
        /// First camera centre.
        start: [f64; 3],
        /// Last camera centre.
        end: [f64; 3],
        /// Number of views.
        count: usize,
        /// Viewing direction.
        facing: [f64; 3],
        /// Distance to the aim point along `facing` (default 5 m).
        #[serde(default = "default_distance")]
        distance: f64,
        /// Up direction.
        #[serde(default = "default_axis")]
        up: [f64; 3],
    },
    /// Explicit poses.
    List {
        /// The views.
        views: Vec<ViewSpec>,
        /// Up direction.
        #[serde(default = "default_axis")]
        up: [f64; 3],
    },
}

fn default_arc() -> f64 {
    360.0
}
fn default_distance() -> f64 {
    5.0
}

/// 1-based line number of byte offset `pos` in `text`.
pub(crate) fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()[..pos.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Line of the `index`-th `[[header]]` table in `text`, if it can be found.
fn line_of_array_table(text: &str, header: &str, index: usize) -> Option<usize> {
    let want = format!("[[{header}]]");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(&want))
        .nth(index)
        .map(|(i, _)| i + 1)
}

/// Line of the `[materials.name]` table, if it can be found.
fn line_of_material(text: &str, name: &str) -> Option<usize> {
    let want = [
        format!("[materials.{name}]"),
        format!("[materials.\"{name}\"]"),
    ];
    text.lines()
        .position(|l| want.iter().any(|w| l.trim_start().starts_with(w.as_str())))
        .map(|i| i + 1)
}

/// Where a validation problem is, for the error message.
#[derive(Debug, Clone, Copy)]
enum Place<'a> {
    Top,
    Object(usize),
    Rig(usize),
    Material(&'a str),
}

impl SceneSpec {
    /// Parses and validates a scene from TOML text. `origin` names the text in errors (a file
    /// name, or e.g. `"<builtin demo>"`).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<SceneSpec, SynthError> {
        let spec: SceneSpec = toml::from_str(text).map_err(|e| {
            let (line, column) = match e.span() {
                Some(span) => {
                    let line = line_of(text, span.start);
                    let line_start = text[..span.start.min(text.len())]
                        .rfind('\n')
                        .map_or(0, |p| p + 1);
                    (Some(line), Some(span.start - line_start + 1))
                }
                None => (None, None),
            };
            SynthError::Toml {
                origin: origin.to_string(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        spec.validate_with_text(origin, Some(text))?;
        Ok(spec)
    }

    /// Reads, parses and validates a scene file.
    pub fn from_path(path: impl AsRef<Path>) -> Result<SceneSpec, SynthError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SynthError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        SceneSpec::from_toml_str(&text, &path.display().to_string())
    }

    /// Checks sizes, counts, finiteness and material references.
    pub fn validate(&self) -> Result<(), SynthError> {
        self.validate_with_text("<scene>", None)
    }

    fn validate_with_text(&self, origin: &str, text: Option<&str>) -> Result<(), SynthError> {
        let fail = |place: Place, message: String| -> SynthError {
            let (line, prefix) = match place {
                Place::Top => (None, String::new()),
                Place::Object(i) => {
                    let o = &self.objects[i];
                    let label = o.name().map(|n| format!(" {n:?}")).unwrap_or_default();
                    (
                        text.and_then(|t| line_of_array_table(t, "objects", i)),
                        format!("objects[{i}] ({}{label}): ", o.kind()),
                    )
                }
                Place::Rig(i) => (
                    text.and_then(|t| line_of_array_table(t, "rigs", i)),
                    format!("rigs[{i}]: "),
                ),
                Place::Material(name) => (
                    text.and_then(|t| line_of_material(t, name)),
                    format!("materials.{name}: "),
                ),
            };
            SynthError::Invalid {
                origin: origin.to_string(),
                line,
                message: format!("{prefix}{message}"),
            }
        };
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let nonzero = |v: &[f64; 3]| finite(v) && v.iter().map(|x| x * x).sum::<f64>() > 1e-18;

        // Camera.
        let c = &self.camera;
        if c.width == 0 || c.height == 0 {
            return Err(fail(
                Place::Top,
                format!("camera size must be positive, got {}x{}", c.width, c.height),
            ));
        }
        if let Some(f) = c.focal_px {
            if !(f.is_finite() && f > 0.0) {
                return Err(fail(
                    Place::Top,
                    format!("camera.focal_px must be positive, got {f}"),
                ));
            }
        }
        if let Some(h) = c.hfov_deg {
            if !(h.is_finite() && h > 0.0 && h < 179.0) {
                return Err(fail(
                    Place::Top,
                    format!("camera.hfov_deg must be in (0, 179), got {h}"),
                ));
            }
        }
        if !c.radial_k.is_finite() || c.radial_k.abs() > 1.0 {
            return Err(fail(
                Place::Top,
                format!("camera.radial_k must be in [-1, 1], got {}", c.radial_k),
            ));
        }

        // Lighting and render.
        let l = &self.lighting;
        if !nonzero(&l.sun_direction) {
            return Err(fail(
                Place::Top,
                "lighting.sun_direction must be a finite non-zero vector".into(),
            ));
        }
        for (name, v) in [("sun_intensity", l.sun_intensity), ("ambient", l.ambient)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(fail(
                    Place::Top,
                    format!("lighting.{name} must be ≥ 0, got {v}"),
                ));
            }
        }
        check_color(&l.sky_color)
            .map_err(|m| fail(Place::Top, format!("lighting.sky_color {m}")))?;
        let r = &self.render;
        if r.antialias == 0 || r.antialias > 8 {
            return Err(fail(
                Place::Top,
                format!("render.antialias must be 1..=8, got {}", r.antialias),
            ));
        }
        for (name, v, hi) in [
            ("image_noise", r.image_noise, 1.0),
            ("exposure_jitter", r.exposure_jitter, 0.9),
            ("plane_merge_angle_deg", r.plane_merge_angle_deg, 10.0),
            ("plane_merge_distance", r.plane_merge_distance, 1.0),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(fail(
                    Place::Top,
                    format!("render.{name} must be in [0, {hi}], got {v}"),
                ));
            }
        }

        // Sparse.
        let s = &self.sparse;
        if s.min_track < 2 {
            return Err(fail(
                Place::Top,
                format!("sparse.min_track must be ≥ 2, got {}", s.min_track),
            ));
        }
        if s.cell_px == 0 {
            return Err(fail(Place::Top, "sparse.cell_px must be ≥ 1".into()));
        }
        for (name, v, lo, hi) in [
            ("min_corner_response", s.min_corner_response, 0.0, f64::MAX),
            ("min_texture_contrast", s.min_texture_contrast, 0.0, 1.0),
            ("max_view_angle_deg", s.max_view_angle_deg, 1.0, 90.0),
            ("max_scale_ratio", s.max_scale_ratio, 1.0, f64::MAX),
            ("pixel_noise", s.pixel_noise, 0.0, 100.0),
            ("outlier_fraction", s.outlier_fraction, 0.0, 0.9),
            ("normal_noise_deg", s.normal_noise_deg, 0.0, 90.0),
        ] {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(fail(
                    Place::Top,
                    format!("sparse.{name} must be in [{lo}, {hi}], got {v}"),
                ));
            }
        }

        // Materials.
        for (name, m) in &self.materials {
            let place = Place::Material(name);
            check_color(&m.color).map_err(|e| fail(place, format!("color {e}")))?;
            if let Some(c2) = &m.color2 {
                check_color(c2).map_err(|e| fail(place, format!("color2 {e}")))?;
            }
            for (field, v) in [
                ("scale", m.scale),
                ("brick_size[0]", m.brick_size[0]),
                ("brick_size[1]", m.brick_size[1]),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(fail(place, format!("{field} must be positive, got {v}")));
                }
            }
            for (field, v) in [
                ("strength", m.strength),
                ("density", m.density),
                ("row_offset", m.row_offset),
            ] {
                if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                    return Err(fail(place, format!("{field} must be in [0, 1], got {v}")));
                }
            }
            if !(m.mortar.is_finite() && m.mortar >= 0.0) {
                return Err(fail(place, format!("mortar must be ≥ 0, got {}", m.mortar)));
            }
            if m.octaves == 0 || m.octaves > 10 {
                return Err(fail(
                    place,
                    format!("octaves must be 1..=10, got {}", m.octaves),
                ));
            }
        }

        // Objects.
        if self.objects.is_empty() {
            return Err(fail(Place::Top, "the scene has no objects".into()));
        }
        let known = |name: &str| self.materials.contains_key(name);
        let material_list = || {
            let names: Vec<&str> = self.materials.keys().map(String::as_str).collect();
            if names.is_empty() {
                "none are defined".to_string()
            } else {
                format!("known: {}", names.join(", "))
            }
        };
        for (i, o) in self.objects.iter().enumerate() {
            let place = Place::Object(i);
            let check_material = |m: &str| {
                if known(m) {
                    Ok(())
                } else {
                    Err(fail(
                        place,
                        format!("unknown material {m:?} ({})", material_list()),
                    ))
                }
            };
            match o {
                ObjectSpec::Box {
                    material,
                    face_materials,
                    min,
                    max,
                    center,
                    size,
                    rotation_deg,
                    ..
                } => {
                    check_material(material)?;
                    for (face, m) in face_materials {
                        if !BOX_FACES.contains(&face.as_str()) {
                            return Err(fail(
                                place,
                                format!(
                                    "unknown face {face:?} in face_materials (faces: {})",
                                    BOX_FACES.join(", ")
                                ),
                            ));
                        }
                        check_material(m)?;
                    }
                    match (min, max, center, size) {
                        (Some(lo), Some(hi), None, None) => {
                            if !finite(lo) || !finite(hi) {
                                return Err(fail(place, "min/max must be finite".into()));
                            }
                            if (0..3).any(|k| hi[k] <= lo[k]) {
                                return Err(fail(
                                    place,
                                    format!("max {hi:?} must exceed min {lo:?} on every axis"),
                                ));
                            }
                        }
                        (None, None, Some(c), Some(sz)) => {
                            if !finite(c) || !finite(sz) || sz.iter().any(|&v| v <= 0.0) {
                                return Err(fail(
                                    place,
                                    format!("size must be positive and finite, got {sz:?}"),
                                ));
                            }
                        }
                        _ => {
                            return Err(fail(
                                place,
                                "give either min and max, or center and size".into(),
                            ))
                        }
                    }
                    if !finite(rotation_deg) {
                        return Err(fail(place, "rotation_deg must be finite".into()));
                    }
                    if min.is_some() && rotation_deg.iter().any(|&a| a != 0.0) {
                        return Err(fail(
                            place,
                            "rotation_deg needs the center/size form".into(),
                        ));
                    }
                }
                ObjectSpec::Quad {
                    material,
                    center,
                    size,
                    normal,
                    up,
                    ..
                } => {
                    check_material(material)?;
                    if !finite(center) {
                        return Err(fail(place, "center must be finite".into()));
                    }
                    if !(finite(size) && size[0] > 0.0 && size[1] > 0.0) {
                        return Err(fail(place, format!("size must be positive, got {size:?}")));
                    }
                    if !nonzero(normal) {
                        return Err(fail(place, "normal must be a non-zero vector".into()));
                    }
                    if let Some(u) = up {
                        let n = nalgebra::Vector3::from(*normal).normalize();
                        let uv = nalgebra::Vector3::from(*u);
                        if !nonzero(u) || (uv - n * n.dot(&uv)).norm() < 1e-6 * uv.norm() {
                            return Err(fail(
                                place,
                                "up must be non-zero and not parallel to normal".into(),
                            ));
                        }
                    }
                }
                ObjectSpec::Sphere {
                    material,
                    center,
                    radius,
                    ..
                } => {
                    check_material(material)?;
                    if !(finite(center) && radius.is_finite() && *radius > 0.0) {
                        return Err(fail(
                            place,
                            format!("radius must be positive, got {radius}"),
                        ));
                    }
                }
                ObjectSpec::Cylinder {
                    material,
                    base,
                    axis,
                    height,
                    radius,
                    ..
                } => {
                    check_material(material)?;
                    if !finite(base) || !nonzero(axis) {
                        return Err(fail(place, "base must be finite, axis non-zero".into()));
                    }
                    if !(height.is_finite() && *height > 0.0 && radius.is_finite() && *radius > 0.0)
                    {
                        return Err(fail(
                            place,
                            format!("height and radius must be positive, got {height}, {radius}"),
                        ));
                    }
                }
                ObjectSpec::Polygon {
                    material, vertices, ..
                } => {
                    check_material(material)?;
                    if vertices.len() < 3 || !vertices.iter().all(|v| finite(v)) {
                        return Err(fail(
                            place,
                            format!(
                                "vertices must be at least 3 finite points, got {}",
                                vertices.len()
                            ),
                        ));
                    }
                    polygon_normal(vertices).map_err(|m| fail(place, m))?;
                }
            }
        }

        // Rigs.
        if self.rigs.is_empty() {
            return Err(fail(
                Place::Top,
                "no camera rigs: the scene has zero views".into(),
            ));
        }
        let mut views = 0usize;
        for (i, rig) in self.rigs.iter().enumerate() {
            let place = Place::Rig(i);
            let bad = |m: &str| Err(fail(place, m.to_string()));
            let (field, n) = match rig {
                RigSpec::Orbit { count, .. } | RigSpec::Facade { count, .. } => ("count", *count),
                RigSpec::Walk {
                    positions, count, ..
                } if positions.is_empty() => ("count", *count),
                RigSpec::Walk { positions, .. } => ("positions", positions.len()),
                RigSpec::List { views, .. } => ("views", views.len()),
            };
            if n > MAX_VIEWS {
                return bad(&format!(
                    "{field} gives {n} views, over the limit of {MAX_VIEWS} views per scene"
                ));
            }
            views += n;
            if views > MAX_VIEWS {
                return bad(&format!(
                    "{field} brings the scene to {views} views, over the limit of {MAX_VIEWS}"
                ));
            }
            match rig {
                RigSpec::Orbit {
                    center,
                    radius,
                    height,
                    count,
                    look_at,
                    start_deg,
                    arc_deg,
                    up,
                } => {
                    if *count == 0 {
                        return bad("count must be ≥ 1 (zero views)");
                    }
                    if !(radius.is_finite() && *radius > 0.0) {
                        return bad(&format!("radius must be positive, got {radius}"));
                    }
                    if !finite(center)
                        || !height.is_finite()
                        || !start_deg.is_finite()
                        || !arc_deg.is_finite()
                        || !look_at.is_none_or(|t| finite(&t))
                        || !nonzero(up)
                    {
                        return bad("all values must be finite, up non-zero");
                    }
                }
                RigSpec::Walk {
                    positions,
                    targets,
                    path,
                    count,
                    target,
                    up,
                } => {
                    if !nonzero(up) {
                        return bad("up must be non-zero");
                    }
                    let all_finite = positions
                        .iter()
                        .chain(targets)
                        .chain(path)
                        .chain(target)
                        .all(|p| finite(p));
                    if !all_finite {
                        return bad("all points must be finite");
                    }
                    match (positions.is_empty(), path.is_empty()) {
                        (false, true) => {
                            if targets.len() != positions.len() && targets.len() != 1 {
                                return bad(&format!(
                                    "{} positions need as many targets or one, got {}",
                                    positions.len(),
                                    targets.len()
                                ));
                            }
                            for (k, p) in positions.iter().enumerate() {
                                let t = if targets.len() == 1 {
                                    &targets[0]
                                } else {
                                    &targets[k]
                                };
                                if dist2(p, t) < 1e-12 {
                                    return bad(&format!("positions[{k}] equals its target"));
                                }
                            }
                        }
                        (true, false) => {
                            if *count == 0 {
                                return bad("count must be ≥ 1 (zero views)");
                            }
                            match target {
                                None if path.len() < 2 => {
                                    return bad("a path needs ≥ 2 points, or a target");
                                }
                                None if path.windows(2).any(|w| dist2(&w[0], &w[1]) < 1e-12) => {
                                    return bad(
                                        "path has repeated consecutive points (no view direction)",
                                    );
                                }
                                Some(t) if path.iter().any(|p| dist2(p, t) < 1e-12) => {
                                    return bad("a path point equals the target");
                                }
                                _ => {}
                            }
                        }
                        _ => return bad("give either positions (+ targets) or path (+ count)"),
                    }
                }
                RigSpec::Facade {
                    start,
                    end,
                    count,
                    facing,
                    distance,
                    up,
                } => {
                    if *count == 0 {
                        return bad("count must be ≥ 1 (zero views)");
                    }
                    if !finite(start) || !finite(end) || !nonzero(facing) || !nonzero(up) {
                        return bad("start/end must be finite, facing and up non-zero");
                    }
                    if !(distance.is_finite() && *distance > 0.0) {
                        return bad(&format!("distance must be positive, got {distance}"));
                    }
                }
                RigSpec::List { views, up } => {
                    if views.is_empty() {
                        return bad("views is empty (zero views)");
                    }
                    if !nonzero(up) {
                        return bad("up must be non-zero");
                    }
                    for (k, v) in views.iter().enumerate() {
                        if !finite(&v.position) || !finite(&v.target) {
                            return bad(&format!("views[{k}] must be finite"));
                        }
                        let d: f64 = (0..3).map(|a| (v.target[a] - v.position[a]).powi(2)).sum();
                        if d < 1e-12 {
                            return bad(&format!("views[{k}]: target equals position"));
                        }
                    }
                }
            }
        }
        check_render_size(c.width, c.height, views, "camera.").map_err(|m| fail(Place::Top, m))?;
        Ok(())
    }
}

/// How far (metres) a polygon's vertex may be off the polygon's plane: vertices written to
/// 0.1 mm are off by less; the renderer snaps them onto the plane (as it snaps faces onto
/// merged planes, which are 2 mm apart at most).
pub(crate) const POLYGON_FLATNESS: f64 = 1e-3;

/// Unit normal of the visible side of a polygon (Newell's method: the vertices run
/// counter-clockwise around it), or why the vertices are not a flat convex polygon: a
/// vertex off the plane by more than [`POLYGON_FLATNESS`], a reflex, straight or repeated
/// vertex, or no area.
pub(crate) fn polygon_normal(vertices: &[[f64; 3]]) -> Result<nalgebra::Vector3<f64>, String> {
    use nalgebra::Vector3;
    let p: Vec<Vector3<f64>> = vertices.iter().map(|v| Vector3::from(*v)).collect();
    let n = p.len();
    let mut newell = Vector3::zeros();
    for i in 0..n {
        newell += p[i].cross(&p[(i + 1) % n]);
    }
    let size = (1..n).map(|i| (p[i] - p[0]).norm()).fold(0.0, f64::max);
    if newell.norm() <= 1e-12 * size * size || size == 0.0 {
        return Err("the polygon has no area".into());
    }
    let normal = newell.normalize();
    let centroid = p.iter().sum::<Vector3<f64>>() / n as f64;
    if let Some(k) = p
        .iter()
        .position(|q| (q - centroid).dot(&normal).abs() > POLYGON_FLATNESS)
    {
        return Err(format!("vertices[{k}] is off the polygon's plane"));
    }
    for i in 0..n {
        let (a, b, c) = (p[i], p[(i + 1) % n], p[(i + 2) % n]);
        if (b - a).cross(&(c - b)).dot(&normal) <= 1e-12 * size * size {
            return Err(format!(
                "the polygon is not strictly convex at vertices[{}] (a reflex, straight or repeated vertex)",
                (i + 1) % n
            ));
        }
    }
    Ok(normal)
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum()
}

fn check_color(c: &[f64; 3]) -> Result<(), String> {
    if c.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) {
        Ok(())
    } else {
        Err(format!("must have components in [0, 1], got {c:?}"))
    }
}
