//! Writes a rendered synthetic scene as a COLMAP-style workspace with ground truth:
//!
//! ```text
//! DIR/images/view_0000.png …        rendered photographs (8-bit RGB)
//! DIR/sparse/{cameras,images,points3D}.{bin,txt}   the SfM-like sparse model, both formats
//! DIR/pmvs/{txt,models,visualize}/  the same views with oriented (PMVS-like) points, when the
//!                                   scene asks for normals
//! DIR/gt/depth/view_0000.pfm        camera-z depth at pixel centres (0 = background)
//! DIR/gt/normals/view_0000.pfm      world-frame unit normals (3 channels)
//! DIR/gt/planes/view_0000.png       16-bit global plane id per pixel (0 = non-planar)
//! DIR/gt/texture/view_0000.png      16-bit, 1 where the surface is textured at the pixel's
//!                                   scale, 0 on plain paint and background
//!                                   ([`crate::synth::RenderedView::textured`])
//! DIR/gt/planes.json                the global planes (id, normal, offset, label)
//! DIR/gt/mesh.ply                   the scene's triangle mesh
//! DIR/gt/scene.toml                 the scene description used
//! ```

use std::fmt;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use thiserror::Error;

use crate::io::atomic::write_atomic;
use crate::io::colmap::{write_model_bin, write_model_text, ColmapError, ColmapModel};
use crate::io::labelpng::{write_label_png, LabelPngError};
use crate::io::pfm::{write_pfm_path, PfmError};
use crate::io::ply::{write_ply_mesh_path, PlyError, PlyMesh};
use crate::io::pmvs::{write_pmvs, PmvsError};
use crate::progress::Progress;
use crate::raster::ImageF32;
use crate::synth::{render, RenderOptions, SceneSpec, SynthError, SynthScene};

/// Errors of writing a synthetic workspace.
#[derive(Debug, Error)]
pub enum WorkspaceError {
    /// Rendering failed.
    #[error(transparent)]
    Synth(#[from] SynthError),
    /// Writing the COLMAP model failed.
    #[error(transparent)]
    Colmap(#[from] ColmapError),
    /// Writing a PFM failed.
    #[error(transparent)]
    Pfm(#[from] PfmError),
    /// Writing a label PNG failed.
    #[error(transparent)]
    LabelPng(#[from] LabelPngError),
    /// Writing the mesh failed.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// Writing the PMVS workspace failed.
    #[error(transparent)]
    Pmvs(#[from] PmvsError),
    /// Another file could not be written.
    #[error("{path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn write_err(path: &Path, e: impl fmt::Display) -> WorkspaceError {
    WorkspaceError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Writes a file atomically with an `io::Result` body; errors name the file.
fn write_file(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), WorkspaceError> {
    write_atomic::<std::io::Error, _>(path, body).map_err(|e| write_err(path, e))
}

/// Writes an RGB image as PNG atomically.
fn write_png(path: &Path, img: &image::RgbImage) -> Result<(), WorkspaceError> {
    write_file(path, |f| {
        img.write_to(f, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
}

fn create_dir(path: &Path) -> Result<(), WorkspaceError> {
    std::fs::create_dir_all(path).map_err(|e| write_err(path, e))
}

/// What [`render_to_workspace`] wrote.
#[derive(Debug, Clone, Serialize)]
pub struct WorkspaceSummary {
    /// Scene name.
    pub name: String,
    /// Output directory.
    pub dir: PathBuf,
    /// Number of views.
    pub views: usize,
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Sparse points written.
    pub points: usize,
    /// Mean track length of the sparse points.
    pub mean_track: f64,
    /// Ground-truth planes.
    pub planes: usize,
    /// Share of pixels (all views) on a ground-truth plane.
    pub planar_fraction: f64,
    /// Seconds spent rendering and sampling points.
    pub render_seconds: f64,
    /// Seconds spent writing files.
    pub write_seconds: f64,
    /// Whether a PMVS-like oriented workspace was written too.
    pub pmvs: bool,
}

impl fmt::Display for WorkspaceSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "scene {:?} → {}", self.name, self.dir.display())?;
        writeln!(
            f,
            "  {} views at {}x{}, {} sparse points (mean track {:.2}), {} planes ({:.1}% of pixels planar)",
            self.views,
            self.width,
            self.height,
            self.points,
            self.mean_track,
            self.planes,
            100.0 * self.planar_fraction
        )?;
        write!(
            f,
            "  rendered in {:.2} s, written in {:.2} s{}",
            self.render_seconds,
            self.write_seconds,
            if self.pmvs {
                "; PMVS-like oriented points in pmvs/"
            } else {
                ""
            }
        )
    }
}

/// The demo scene embedded in the binary (`scenes/demo.toml`).
pub const DEMO_SCENE_TOML: &str = include_str!("../scenes/demo.toml");

/// The embedded demo scene, parsed.
pub fn demo_spec() -> Result<SceneSpec, SynthError> {
    SceneSpec::from_toml_str(DEMO_SCENE_TOML, "scenes/demo.toml (embedded)")
}

/// One global plane in `gt/planes.json`.
#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
pub struct GtPlaneRecord {
    /// Plane id as in the `gt/planes/*.png` maps (≥ 1).
    pub id: u16,
    /// Unit normal (world frame).
    pub normal: [f64; 3],
    /// Offset d in n·X = d.
    pub offset: f64,
    /// The scene objects whose faces lie on it.
    pub label: String,
    /// Pixels (all views) showing it.
    pub pixels: u64,
}

/// Renders `spec` and writes the workspace into `dir` (see the module docs for the layout).
pub fn render_to_workspace(
    spec: &SceneSpec,
    opts: &RenderOptions,
    dir: &Path,
    progress: &Progress,
) -> Result<WorkspaceSummary, WorkspaceError> {
    let start = Instant::now();
    let total = 2 * crate::synth::spec_view_count(spec) as u64;
    let bar = progress.bar(total, "render");
    let last = std::sync::atomic::AtomicUsize::new(0);
    let synth = render(spec, opts, &|done, _| {
        let prev = last.fetch_max(done, std::sync::atomic::Ordering::Relaxed);
        if done > prev {
            bar.inc((done - prev) as u64);
        }
    })?;
    bar.finish();
    let render_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let toml_text = toml::to_string_pretty(spec).ok();
    let pmvs = write_synth_workspace(&synth, dir, toml_text.as_deref(), progress)?;
    let pixels: usize = synth.views.iter().map(|v| v.depth.len()).sum();
    let planar: usize = synth
        .views
        .iter()
        .map(|v| v.plane_id.iter().filter(|&&id| id > 0).count())
        .sum();
    let (width, height) = synth
        .views
        .first()
        .map_or((0, 0), |v| (v.view.camera.width, v.view.camera.height));
    let n = synth.cloud.len();
    Ok(WorkspaceSummary {
        name: synth.name.clone(),
        dir: dir.to_path_buf(),
        views: synth.views.len(),
        width,
        height,
        points: n,
        mean_track: if n == 0 {
            0.0
        } else {
            synth.cloud.tracks.iter().map(Vec::len).sum::<usize>() as f64 / n as f64
        },
        planes: synth.planes.len(),
        planar_fraction: planar as f64 / pixels.max(1) as f64,
        render_seconds,
        write_seconds: start.elapsed().as_secs_f64(),
        pmvs,
    })
}

/// Writes an already rendered scene into `dir`. Returns whether a PMVS workspace was written
/// (only when the points carry normals and the cameras are undistorted).
pub fn write_synth_workspace(
    synth: &SynthScene,
    dir: &Path,
    spec_toml: Option<&str>,
    progress: &Progress,
) -> Result<bool, WorkspaceError> {
    let images = dir.join("images");
    let sparse = dir.join("sparse");
    let gt = dir.join("gt");
    for d in [
        &images,
        &sparse,
        &gt.join("depth"),
        &gt.join("normals"),
        &gt.join("planes"),
        &gt.join("texture"),
    ] {
        create_dir(d)?;
    }
    let bar = progress.bar(synth.views.len() as u64, "write views");
    for rv in &synth.views {
        let stem = Path::new(&rv.view.name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| format!("view_{:04}", rv.view.id));
        let (w, h) = (rv.view.camera.width, rv.view.camera.height);
        let path = images.join(&rv.view.name);
        write_png(&path, &rv.image.to_rgb8())?;
        let depth = ImageF32 {
            width: w,
            height: h,
            channels: 1,
            data: rv.depth.clone(),
        };
        write_pfm_path(&gt.join("depth").join(format!("{stem}.pfm")), &depth)?;
        let normals = ImageF32 {
            width: w,
            height: h,
            channels: 3,
            data: rv.normals.iter().flatten().copied().collect(),
        };
        write_pfm_path(&gt.join("normals").join(format!("{stem}.pfm")), &normals)?;
        write_label_png(
            &gt.join("planes").join(format!("{stem}.png")),
            w,
            h,
            &rv.plane_id,
        )?;
        let textured: Vec<u16> = rv.textured.iter().map(|&t| u16::from(t)).collect();
        write_label_png(
            &gt.join("texture").join(format!("{stem}.png")),
            w,
            h,
            &textured,
        )?;
        bar.inc(1);
    }
    bar.finish();

    let scene = synth.to_scene();
    let model = ColmapModel::from_scene(&scene, Some(&synth.observations))?;
    write_model_bin(&sparse, &model)?;
    write_model_text(&sparse, &model)?;

    let records: Vec<GtPlaneRecord> = synth
        .planes
        .iter()
        .map(|p| GtPlaneRecord {
            id: p.id,
            normal: [p.plane.normal.x, p.plane.normal.y, p.plane.normal.z],
            offset: p.plane.offset,
            label: p.label.clone(),
            pixels: p.pixels,
        })
        .collect();
    let json_path = gt.join("planes.json");
    let json = serde_json::to_string_pretty(&records).map_err(|e| write_err(&json_path, e))?;
    write_file(&json_path, |f| {
        std::io::Write::write_all(f, json.as_bytes())
    })?;
    let mesh = PlyMesh {
        vertices: synth.mesh_vertices.clone(),
        faces: synth.mesh_triangles.clone(),
        vertex_colors: None,
    };
    write_ply_mesh_path(&gt.join("mesh.ply"), &mesh)?;
    if let Some(text) = spec_toml {
        let p = gt.join("scene.toml");
        write_file(&p, |f| std::io::Write::write_all(f, text.as_bytes()))?;
    }

    let pmvs = scene.cloud.normals.is_some()
        && scene.views.iter().all(|v| !v.camera.model.has_distortion());
    if pmvs {
        let pmvs_dir = dir.join("pmvs");
        write_pmvs(&pmvs_dir, &scene)?;
        let vis = pmvs_dir.join("visualize");
        create_dir(&vis)?;
        for (i, rv) in synth.views.iter().enumerate() {
            let path = vis.join(format!("{i:08}.png"));
            write_png(&path, &rv.image.to_rgb8())?;
        }
    }
    Ok(pmvs)
}
