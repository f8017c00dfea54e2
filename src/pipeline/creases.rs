//! The crease pass between the two labellings: crease hypotheses voted by every view's
//! first labelling, saved for `--resume`.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{label_view, write_err, Config, PipelineError, Prepared, ViewPlanemap};
use crate::hypotheses::{crease_hypotheses, CreaseHypothesis, LabelledView, PlaneHypothesis};
use crate::io::atomic::write_atomic;
use crate::progress::Progress;
use crate::scene::Scene;

/// The crease hypotheses of a run, saved so `--resume` need not repeat the first labelling.
pub(super) const CREASES_FILE: &str = "crease_hypotheses.json";

/// The first labelling pass of [`run`]: every view in `indices` labelled with the sparse and
/// sweep hypotheses, and the crease hypotheses that labelling yields (ids continuing after
/// `prepared.hypotheses`).
pub(super) fn crease_pass(
    scene: &Scene,
    prepared: &Prepared,
    indices: &[usize],
    cfg: &Config,
    progress: &Progress,
) -> Result<(Vec<CreaseHypothesis>, Vec<ViewPlanemap>), PipelineError> {
    let bar = progress.bar(indices.len() as u64, "planemaps (first pass)");
    let pass: Vec<(ViewPlanemap, Vec<bool>)> = indices
        .par_iter()
        .map(|&i| {
            let view = &scene.views[i];
            let image = view.load_undistorted_image()?;
            let result = label_view(scene, prepared, i, &image, cfg)?;
            let lines = crate::planemap::lines::dominant_line_mask(
                &image,
                &view.camera,
                &view.cam_from_world,
                &prepared.axes.directions,
                &cfg.planemap,
            )
            .map_err(|source| PipelineError::Planemap {
                view: view.name.clone(),
                source,
            })?;
            bar.inc(1);
            Ok((result, lines))
        })
        .collect::<Result<_, PipelineError>>()?;
    bar.finish();
    let labelled: Vec<LabelledView> = pass
        .iter()
        .map(|(v, lines)| LabelledView {
            view_index: v.view_index,
            labels: &v.labels,
            depth: &v.depth,
            lines,
        })
        .collect();
    let base = prepared.hypotheses.len();
    let extra = crease_hypotheses(
        scene,
        &prepared.axes,
        &prepared.hypotheses,
        &labelled,
        prepared.scale,
        &cfg.hypotheses.creases,
    )?
    .into_iter()
    .enumerate()
    .map(|(i, mut c)| {
        c.hypothesis.id = (base + i) as u32;
        c
    })
    .collect();
    Ok((extra, pass.into_iter().map(|(v, _)| v).collect()))
}

/// One crease hypothesis in `crease_hypotheses.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct CreaseRecord {
    id: u32,
    normal: [f64; 3],
    offset: f64,
    axis: Option<usize>,
    /// Image names of the views that see it (offered it as a label).
    views: Vec<String>,
}

pub(super) fn write_crease_hypotheses(
    path: &Path,
    scene: &Scene,
    creases: &[CreaseHypothesis],
) -> Result<(), PipelineError> {
    let records: Vec<CreaseRecord> = creases
        .iter()
        .map(|c| {
            let h = &c.hypothesis;
            CreaseRecord {
                id: h.id,
                normal: [h.plane.normal.x, h.plane.normal.y, h.plane.normal.z],
                offset: h.plane.offset,
                axis: h.axis,
                views: c
                    .views
                    .iter()
                    .map(|&v| scene.views[v].name.clone())
                    .collect(),
            }
        })
        .collect();
    let json = serde_json::to_string_pretty(&records).map_err(|e| write_err(path, e))?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
    }
    write_atomic::<std::io::Error, _>(path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, json.as_bytes())
    })
    .map_err(|e| write_err(path, e))
}

/// Saved crease hypotheses for `--resume`, if the file exists, parses, continues the ids
/// of the `base` hypotheses this run prepared and names only views of `scene`; `None`
/// (recompute) otherwise.
pub fn read_crease_hypotheses(
    path: &Path,
    scene: &Scene,
    base: usize,
) -> Option<Vec<CreaseHypothesis>> {
    let text = std::fs::read_to_string(path).ok()?;
    let records: Vec<CreaseRecord> = serde_json::from_str(&text).ok()?;
    records
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let n = Vector3::new(r.normal[0], r.normal[1], r.normal[2]);
            let unit = (n.norm() - 1.0).abs() < 1e-9 && r.offset.is_finite();
            if r.id as usize != base + i || !unit {
                return None;
            }
            let mut views = r
                .views
                .iter()
                .map(|name| scene.views.iter().position(|v| &v.name == name))
                .collect::<Option<Vec<usize>>>()?;
            views.sort_unstable();
            views.dedup();
            Some(CreaseHypothesis {
                hypothesis: PlaneHypothesis {
                    id: r.id,
                    plane: crate::geometry::Plane {
                        normal: n,
                        offset: r.offset,
                    },
                    axis: r.axis,
                    support: 0,
                },
                views,
            })
        })
        .collect()
}
