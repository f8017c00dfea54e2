//! What a run writes per view and per scene: planemaps, depth and normal maps (also as
//! COLMAP dense maps), planes.json; and what `--resume` reads back.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{write_err, PipelineError, Prepared, ViewPlanemap};
use crate::io::atomic::write_atomic;
use crate::io::dense::write_dense_map_path;
use crate::io::labelpng::{label_colors, write_label_png};
use crate::io::output_stem;
use crate::io::pfm::write_pfm_path;
use crate::nonplanar::NONPLANAR;
use crate::raster::ImageF32;
use crate::scene::Scene;

/// `OUT/stereo/KIND/IMAGE.geometric.bin` (KIND `depth_maps` or `normal_maps`), IMAGE the
/// view's COLMAP image name, subfolders included, as COLMAP's `stereo_fusion` reads them.
pub(super) fn dense_map_path(out: &Path, kind: &str, view_name: &str) -> PathBuf {
    out.join("stereo")
        .join(kind)
        .join(format!("{view_name}.geometric.bin"))
}

/// `OUT/DIR/STEM.EXT` for a view ([`output_stem`]: the image name without its extension,
/// subfolders kept), creating the folders it needs.
pub(super) fn view_file(
    out: &Path,
    dir: &str,
    view_name: &str,
    suffix: &str,
) -> Result<PathBuf, PipelineError> {
    let path = out
        .join(dir)
        .join(format!("{}{suffix}", output_stem(view_name)));
    ensure_parent(&path)?;
    Ok(path)
}

/// Creates the folder `path` goes into.
fn ensure_parent(path: &Path) -> Result<(), PipelineError> {
    match path.parent() {
        Some(dir) => std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e)),
        None => Ok(()),
    }
}

/// Where the non-planar label's sweep depth maps go (PFM, camera z, 0 = none).
pub const SWEEP_DIR: &str = "sweep";

/// The per-view output folders under a run's output directory.
pub(super) const OUTPUT_DIRS: [&str; 4] = [
    "planemaps",
    "depth",
    "stereo/depth_maps",
    "stereo/normal_maps",
];

/// Writes one view's planemap, depth and normal maps (creating the folders).
pub fn write_view_outputs(
    out: &Path,
    scene: &Scene,
    result: &ViewPlanemap,
) -> Result<(), PipelineError> {
    let view = &scene.views[result.view_index];
    let (w, h) = (result.width, result.height);
    for d in OUTPUT_DIRS {
        let dir = out.join(d);
        std::fs::create_dir_all(&dir).map_err(|e| write_err(&dir, e))?;
    }
    let ids: Vec<u16> = result
        .labels
        .iter()
        .zip(&result.depth)
        .map(|(&l, &z)| {
            if z > 0.0 && l != NONPLANAR {
                (l + 1).min(u16::MAX as u32) as u16
            } else {
                0
            }
        })
        .collect();
    let vis_path = view_file(out, "planemaps", &view.name, "_vis.png")?;
    let mut vis = label_colors(&ids, w, h);
    // Non-planar pixels (label 0 but a depth) in one fixed colour, unlike "no plane" (black).
    for (i, (&l, &z)) in result.labels.iter().zip(&result.depth).enumerate() {
        if l == NONPLANAR && z > 0.0 {
            vis.put_pixel(i as u32 % w, i as u32 / w, image::Rgb(NONPLANAR_COLOR));
        }
    }
    if let Some(map) = &result.planarity {
        let path = view_file(out, "planarity", &view.name, ".png")?;
        map.write_png(&path).map_err(|e| write_err(&path, e))?;
    }
    write_atomic::<std::io::Error, _>(&vis_path, |f: &mut BufWriter<File>| {
        vis.write_to(f, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .map_err(|e| write_err(&vis_path, e))?;
    let depth = ImageF32 {
        width: w,
        height: h,
        channels: 1,
        data: result.depth.clone(),
    };
    write_pfm_path(&view_file(out, "depth", &view.name, ".pfm")?, &depth)?;
    if let Some(sweep) = &result.sweep_depth {
        let map = ImageF32 {
            width: w,
            height: h,
            channels: 1,
            data: sweep.clone(),
        };
        write_pfm_path(&view_file(out, SWEEP_DIR, &view.name, ".pfm")?, &map)?;
    }
    let dense_depth = dense_map_path(out, "depth_maps", &view.name);
    ensure_parent(&dense_depth)?;
    write_dense_map_path(&dense_depth, &depth)?;
    let normals = ImageF32 {
        width: w,
        height: h,
        channels: 3,
        data: result.normals.iter().flatten().copied().collect(),
    };
    let dense_normals = dense_map_path(out, "normal_maps", &view.name);
    ensure_parent(&dense_normals)?;
    write_dense_map_path(&dense_normals, &normals)?;
    // The label map last: its presence marks the view complete for --resume.
    write_label_png(
        &view_file(out, "planemaps", &view.name, ".png")?,
        w,
        h,
        &ids,
    )?;
    Ok(())
}

/// Colour of non-planar pixels in the `_vis.png` planemaps (label PNG value 0 with a depth).
pub const NONPLANAR_COLOR: [u8; 3] = [255, 0, 255];

/// Reloads a view's outputs for `--resume`; `None` if any is missing or unreadable
/// (including the non-planar label's sweep depth when `need_sweep`).
pub(super) fn load_view_outputs(
    out: &Path,
    scene: &Scene,
    prepared: &Prepared,
    view_index: usize,
    need_sweep: bool,
) -> Option<ViewPlanemap> {
    let view = &scene.views[view_index];
    let stem = output_stem(&view.name);
    let (w, h, ids) =
        crate::io::labelpng::read_label_png(&out.join("planemaps").join(format!("{stem}.png")))
            .ok()?;
    let depth =
        crate::io::pfm::read_pfm_path(&out.join("depth").join(format!("{stem}.pfm"))).ok()?;
    let sweep_depth = if need_sweep {
        let d =
            crate::io::pfm::read_pfm_path(&out.join(SWEEP_DIR).join(format!("{stem}.pfm"))).ok()?;
        if (d.width, d.height, d.channels) != (w, h, 1) {
            return None;
        }
        Some(d.data)
    } else {
        None
    };
    if (w, h) != (view.camera.width, view.camera.height)
        || (depth.width, depth.height) != (w, h)
        || ids
            .iter()
            .any(|&id| id as usize > prepared.hypotheses.len())
    {
        return None;
    }
    // The normals exactly as labelled (planes' facing the camera, non-planar pixels' from
    // the sweep's depth map): the COLMAP normal map, written before the label map.
    let normals =
        crate::io::dense::read_normal_map_path(&dense_map_path(out, "normal_maps", &view.name))
            .ok()
            .filter(|n| (n.width, n.height, n.channels) == (w, h, 3))?
            .data
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
    Some(ViewPlanemap {
        view_index,
        width: w,
        height: h,
        labels: ids
            .iter()
            .zip(&depth.data)
            .map(|(&id, &z)| match (id, z > 0.0) {
                (0, true) => NONPLANAR,
                _ => (id as u32).saturating_sub(1),
            })
            .collect(),
        depth: depth.data,
        normals,
        candidate_labels: 0,
        energy: (0.0, 0.0),
        cycles: 0,
        seconds: (0.0, 0.0),
        planarity: None,
        sweep_depth,
    })
}

/// Where a hypothesis in `planes.json` came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneSource {
    /// The sparse points' mean-shift along a dominant direction
    /// ([`crate::hypotheses::plane_hypotheses`]); files written before `source` existed
    /// read as this.
    #[default]
    Points,
    /// A free plane fitted to the points the axis planes leave unexplained
    /// ([`crate::hypotheses::free_plane_hypotheses`]).
    Free,
    /// The photo-consistency sweep ([`crate::hypotheses::sweep_hypotheses`]).
    Sweep,
    /// Planes spanned by 3D lines ([`crate::hypotheses::line_plane_hypotheses`]).
    Lines,
    /// A crease after the first labelling ([`crate::hypotheses::crease_hypotheses`]).
    Crease,
}

/// One hypothesis in `planes.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlaneRecord {
    /// Hypothesis id (= label − 1 in the planemap PNGs).
    pub id: u32,
    /// Unit normal (world).
    pub normal: [f64; 3],
    /// Offset d in n·X = d.
    pub offset: f64,
    /// The dominant direction it came from.
    pub axis: Option<usize>,
    /// Which stage proposed it.
    #[serde(default)]
    pub source: PlaneSource,
    /// Supporting sparse points.
    pub support: usize,
    /// Image names of the views whose planemap uses it, with pixel counts.
    pub views: Vec<(String, usize)>,
}

pub(super) fn write_planes_json(
    path: &Path,
    scene: &Scene,
    prepared: &Prepared,
    views: &[ViewPlanemap],
) -> Result<(), PipelineError> {
    let mut usage = vec![Vec::new(); prepared.hypotheses.len()];
    for v in views {
        let mut counts = vec![0usize; prepared.hypotheses.len()];
        for (&l, &z) in v.labels.iter().zip(&v.depth) {
            if z > 0.0 && (l as usize) < counts.len() {
                counts[l as usize] += 1;
            }
        }
        for (h, &c) in counts.iter().enumerate() {
            if c > 0 {
                usage[h].push((scene.views[v.view_index].name.clone(), c));
            }
        }
    }
    let creases_start = prepared.hypotheses.len() - prepared.crease_views.len();
    let lines_start = creases_start - prepared.line_hypotheses;
    let sweep_start = lines_start - prepared.sweep_hypotheses;
    let free_start = sweep_start - prepared.free_hypotheses;
    let records: Vec<PlaneRecord> = prepared
        .hypotheses
        .iter()
        .zip(usage)
        .enumerate()
        .map(|(i, (h, views))| PlaneRecord {
            id: h.id,
            normal: [h.plane.normal.x, h.plane.normal.y, h.plane.normal.z],
            offset: h.plane.offset,
            axis: h.axis,
            source: if i >= creases_start {
                PlaneSource::Crease
            } else if i >= lines_start {
                PlaneSource::Lines
            } else if i >= sweep_start {
                PlaneSource::Sweep
            } else if i >= free_start {
                PlaneSource::Free
            } else {
                PlaneSource::Points
            },
            support: h.support,
            views,
        })
        .collect();
    let json = serde_json::to_string_pretty(&records).map_err(|e| write_err(path, e))?;
    write_atomic::<std::io::Error, _>(path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, json.as_bytes())
    })
    .map_err(|e| write_err(path, e))
}
