//! Synthetic scenes with exact ground truth: scene specs (TOML), a ray-casting renderer and
//! SfM-like sparse sampling.
//!
//! A [`SceneSpec`] (see `scenes/README.md` for the format) describes boxes, rectangles,
//! spheres and cylinders with procedurally textured materials, a sun, and camera rigs.
//! [`render`] ray-casts every view and returns, per pixel, the image and the exact depth
//! (camera z), normal and ground-truth plane id at the pixel-centre ray; plus a sparse point
//! cloud that mimics structure-from-motion: points only where the surface is textured,
//! tracks from visibility, pixel noise and a few outliers. Coplanar faces of different
//! objects share one plane id (faces are merged within a tolerance and snapped onto the
//! shared plane), so the planes are what the Manhattan-world stereo of Furukawa et al.
//! (CVPR 2009) should recover.
//!
//! Everything is a pure function of the spec and the seed: images, ground truth and points
//! are bit-identical for any number of threads.

pub mod generate;
mod render;
mod sparse;
mod spec;
mod texture;
mod world;

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

pub use spec::{
    CameraSpec, LightingSpec, MaterialSpec, ObjectSpec, RenderSpec, RigSpec, SceneSpec, SparseSpec,
    TextureKind, ViewSpec, BOX_FACES, MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_TOTAL_PIXELS,
    MAX_VIEWS,
};

use crate::geometry::Plane;
use crate::raster::ImageF32;
use crate::scene::{SparseCloud, View};

/// Errors of scene parsing, validation and rendering.
#[derive(Debug, Error)]
pub enum SynthError {
    /// The TOML text does not parse or does not match the format.
    #[error("{origin}{}: {message}", fmt_line(*line, *column))]
    Toml {
        /// File name or other origin of the text.
        origin: String,
        /// 1-based line, when known.
        line: Option<usize>,
        /// 1-based column, when known.
        column: Option<usize>,
        /// What was wrong.
        message: String,
    },
    /// The scene parses but a value is invalid.
    #[error("{origin}{}: {message}", fmt_line(*line, None))]
    Invalid {
        /// File name or other origin of the text.
        origin: String,
        /// 1-based line of the table holding the bad value, when known.
        line: Option<usize>,
        /// What was wrong and where (e.g. `objects[3] (box "desk"): unknown material`).
        message: String,
    },
    /// The scene file cannot be read.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's message.
        message: String,
    },
}

fn fmt_line(line: Option<usize>, column: Option<usize>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(":{l}:{c}"),
        (Some(l), None) => format!(":{l}"),
        _ => String::new(),
    }
}

/// Overrides applied at render time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels; intrinsics are scaled to match (height follows the aspect
    /// ratio when not given).
    pub width: Option<u32>,
    /// Image height in pixels.
    pub height: Option<u32>,
    /// Replaces the scene's seed.
    pub seed_override: Option<u64>,
}

/// A ground-truth plane: one or more coplanar faces of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GtPlane {
    /// Plane id as used in [`RenderedView::plane_id`] and [`SynthScene::mesh_plane_ids`]
    /// (≥ 1; 0 means non-planar or background).
    pub id: u16,
    /// The plane `n·X = d` (world frame); `n` is the first merged face's visible normal.
    pub plane: Plane,
    /// Names of the faces merged into it (`object.face`), `+`-joined.
    pub label: String,
    /// Number of pixels labelled with this plane over all views (0: never visible).
    pub pixels: u64,
}

/// One rendered view with exact per-pixel ground truth at the pixel-centre rays.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedView {
    /// Camera and pose (id from 1, name `view_0000.png`, no image path).
    pub view: View,
    /// RGB image in [0, 1]: antialiased, exposure-scaled, with Gaussian noise.
    pub image: ImageF32,
    /// Camera-frame z of the surface hit by the pixel-centre ray; 0 = background.
    pub depth: Vec<f32>,
    /// Unit world-frame normal of that surface, facing the camera; zeros on background.
    pub normals: Vec<[f32; 3]>,
    /// Global plane id of that surface (see [`GtPlane`]); 0 = non-planar or background.
    pub plane_id: Vec<u16>,
    /// That surface is textured at this view's pixel scale: its albedo varies by at least
    /// `[sparse] min_texture_contrast` within two pixel footprints (what the SfM sampler
    /// needs for a feature). False on plain paint and background. The ground truth of
    /// "textured surface", where an image-based mask also counts plain paint next to a
    /// poster edge or a shading crease.
    pub textured: Vec<bool>,
    /// Exposure factor applied to this view.
    pub exposure: f64,
}

/// A rendered synthetic scene: views, sparse points and ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthScene {
    /// Scene name.
    pub name: String,
    /// The views, in rig order.
    pub views: Vec<RenderedView>,
    /// SfM-like sparse points (tracks index `views`; noisy positions).
    pub cloud: SparseCloud,
    /// `observations[i][k]`: noisy image coordinates of point `i` in view
    /// `cloud.tracks[i][k]`.
    pub observations: Vec<Vec<[f64; 2]>>,
    /// Ground-truth planes.
    pub planes: Vec<GtPlane>,
    /// Ground-truth mesh vertices (world frame).
    pub mesh_vertices: Vec<Vector3<f64>>,
    /// Ground-truth mesh triangles (counter-clockwise seen from the visible side).
    pub mesh_triangles: Vec<[u32; 3]>,
    /// Plane id of each triangle (0 = non-planar).
    pub mesh_plane_ids: Vec<u16>,
    /// Plane id of the surface each sparse point was sampled on (0 = non-planar/outlier).
    pub point_plane_ids: Vec<u16>,
    /// Whether each sparse point is a deliberate outlier (off every surface).
    pub point_is_outlier: Vec<bool>,
    /// Noise-free position of each sparse point.
    pub point_true_positions: Vec<Vector3<f64>>,
}

impl SynthScene {
    /// The views and sparse points as the [`crate::scene::Scene`] the pipeline reads.
    pub fn to_scene(&self) -> crate::scene::Scene {
        crate::scene::Scene {
            views: self.views.iter().map(|v| v.view.clone()).collect(),
            cloud: self.cloud.clone(),
        }
    }
}

/// Everything rendered before sparse sampling.
struct Rendered {
    seed: u64,
    world: world::World,
    views: Vec<View>,
    renders: Vec<render::ViewRender>,
    exposures: Vec<f64>,
}

fn render_all(
    spec: &SceneSpec,
    opts: &RenderOptions,
    tick: &(dyn Fn() + Sync),
) -> Result<Rendered, SynthError> {
    spec.validate()?;
    let seed = opts.seed_override.unwrap_or(spec.seed);
    let camera = render::build_camera(spec, opts)?;
    let world = world::World::build(spec, seed);
    if world.planes.len() >= u16::MAX as usize {
        return Err(SynthError::Invalid {
            origin: spec.name.clone(),
            line: None,
            message: format!("{} planes exceed the 65534 plane ids", world.planes.len()),
        });
    }
    let views = render::build_views(spec, &camera);
    let shading = render::Shading::new(spec);
    let mut exposure_rng = ChaCha8Rng::seed_from_u64(texture::mix64(seed ^ 0xE4F0));
    let exposures: Vec<f64> = views
        .iter()
        .map(|_| {
            let j = spec.render.exposure_jitter;
            if j > 0.0 {
                1.0 + exposure_rng.random_range(-j..=j)
            } else {
                1.0
            }
        })
        .collect();
    use rayon::prelude::*;
    let renders: Vec<render::ViewRender> = views
        .par_iter()
        .enumerate()
        .map(|(i, v)| {
            let r = render::render_view(
                &world,
                &shading,
                v,
                spec.render.antialias,
                exposures[i],
                spec.render.image_noise,
                texture::mix64(seed ^ texture::mix64(0xA0000 + i as u64)),
                spec.sparse.min_texture_contrast,
            );
            tick();
            r
        })
        .collect();
    Ok(Rendered {
        seed,
        world,
        views,
        renders,
        exposures,
    })
}

fn rendered_views(
    views: Vec<View>,
    renders: Vec<render::ViewRender>,
    exposures: Vec<f64>,
) -> Vec<RenderedView> {
    views
        .into_iter()
        .zip(renders)
        .zip(exposures)
        .map(|((view, r), exposure)| RenderedView {
            view,
            image: r.image,
            depth: r.depth,
            normals: r.normals,
            plane_id: r.plane_id,
            textured: r.textured,
            exposure,
        })
        .collect()
}

/// Renders the views (images and per-pixel ground truth) without sampling sparse points:
/// the same views, bit for bit, as [`render`] returns.
pub fn render_views(
    spec: &SceneSpec,
    opts: &RenderOptions,
) -> Result<Vec<RenderedView>, SynthError> {
    let r = render_all(spec, opts, &|| {})?;
    Ok(rendered_views(r.views, r.renders, r.exposures))
}

/// Renders every view of `spec` and samples the sparse points. `progress(done, total)` is
/// called as views are rendered and then searched for features (`total` = 2 × views); it
/// may be called from several threads.
pub fn render(
    spec: &SceneSpec,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SynthScene, SynthError> {
    spec.validate()?;
    let total = 2 * spec_view_count(spec);
    let done = AtomicUsize::new(0);
    let tick = || {
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
    };
    let Rendered {
        seed,
        world,
        views,
        renders,
        exposures,
    } = render_all(spec, opts, &tick)?;
    let sparse = sparse::sample(&world, &views, &renders, &spec.sparse, seed, &|_| tick());

    let mut pixels = vec![0u64; world.planes.len()];
    for r in &renders {
        for &id in &r.plane_id {
            if id > 0 {
                pixels[id as usize - 1] += 1;
            }
        }
    }
    let planes = world
        .planes
        .iter()
        .enumerate()
        .map(|(i, p)| GtPlane {
            id: (i + 1) as u16,
            plane: p.plane,
            label: p.labels.join("+"),
            pixels: pixels[i],
        })
        .collect();
    let (mesh_vertices, mesh_triangles, mesh_plane_ids) = world.mesh();
    let views = rendered_views(views, renders, exposures);
    Ok(SynthScene {
        name: spec.name.clone(),
        views,
        cloud: sparse.cloud,
        observations: sparse.observations,
        planes,
        mesh_vertices,
        mesh_triangles,
        mesh_plane_ids,
        point_plane_ids: sparse.plane_ids,
        point_is_outlier: sparse.outlier,
        point_true_positions: sparse.true_positions,
    })
}

/// Number of views the rigs of a validated `spec` produce.
pub fn spec_view_count(spec: &SceneSpec) -> usize {
    render::rig_poses(spec).len()
}

#[cfg(test)]
mod tests;
