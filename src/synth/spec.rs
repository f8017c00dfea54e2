//! The scene description read from TOML: camera, lighting, materials, objects, camera rigs
//! and the parameters of the SfM-like sparse sampling. `scenes/README.md` documents the
//! format with examples; every field here says its unit and default.
//!
//! World frame: metres, z up. Directions need not be unit (they are normalised).
//!
//! This file holds the format's types and the limits and shape checks the renderer shares;
//! `validate` parses the text and checks a scene ([`SceneSpec::from_toml_str`],
//! [`SceneSpec::validate`]).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

mod validate;

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
