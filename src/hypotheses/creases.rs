//! Crease hypotheses: planes through dominant image lines lifted onto labelled planes.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::{HypothesesError, PlaneHypothesis};
use crate::axes::DominantAxes;
use crate::geometry::Plane;
use crate::scene::Scene;

/// Settings of [`crease_hypotheses`], a third source of plane hypotheses for plain surfaces
/// that neither the points nor the photo-consistency sweep can place (a ceiling, the side
/// faces of a table or a cabinet).
///
/// A dominant line (an image edge toward a vanishing point, [`crate::planemap::lines`]) is
/// most often a crease or an occluding edge between two planes. Where the first labelling
/// puts one of those planes, the line's pixels lifted onto it are 3D points of the crease;
/// the other plane passes through them, and in a Manhattan scene its normal is one of the
/// other dominant axes. Each such pixel votes for the offset `d_k · X` of every axis `d_k`
/// not parallel to its plane's normal; an offset with enough votes from enough views that is
/// not already a hypothesis becomes one, and every view is labelled again with it (Sinha et
/// al. 2009 lift 3D line segments to planes in the same spirit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CreaseHypothesesConfig {
    /// Look for crease hypotheses (needs the images; costs a second labelling of every view
    /// when any is found). On: plain ceilings and cabinet faces, which neither the points
    /// nor the sweep can place, were the largest error left (docs/notes/hypotheses.md).
    pub enabled: bool,
    /// Votes an offset needs, as a multiple of the image width (a line's length grows with
    /// the resolution), > 0. Offsets are binned at R; a peak pools its bin and the two
    /// beside it. Lower thresholds found more planes for little gain at 2–3× the time.
    pub min_votes_per_width: f64,
    /// ... from at least this many views that see it (`min_view_votes_per_width`), a count
    /// ≥ 1: a crease must be seen from more than one view.
    pub min_views: usize,
    /// An axis votes only if |d_k · n| is at most this for the labelled plane's normal n,
    /// a cosine in [0, 1): a crease joins planes of different orientation, here ≈ 45° apart
    /// or more.
    pub max_normal_cos: f64,
    /// A candidate within this many R (≥ 0) of an existing hypothesis of the same direction
    /// is that hypothesis.
    pub merge_r: f64,
    /// A view *sees* a crease hypothesis when it cast at least this many votes for it, as a
    /// multiple of its image width, ≥ 0; only those views count for `min_views`, and only
    /// they are offered the hypothesis as a label (the rest keep their first labelling
    /// there). Offered everywhere, a textured room carried over a hundred crease planes per
    /// view at 10× the solve time; the default is the largest value that keeps every
    /// Manhattan scene's accuracy (docs/notes/hypotheses.md).
    pub min_view_votes_per_width: f64,
    /// At most this many crease hypotheses are offered to one view, those it cast the most
    /// votes for, a count; 0 = no cap. A bound on the second labelling's time, which is
    /// linear in the labels: castle-P19's window reveals offered 33–146 per view. The most
    /// any view was offered elsewhere is 51 on the 13 scenes (thin) and 77 on the generated
    /// development and test scenes (hall-1; plaza-1000 76), so the default changes none of
    /// them (docs/notes/real-photographs.md).
    pub max_per_view: usize,
}

impl Default for CreaseHypothesesConfig {
    fn default() -> Self {
        CreaseHypothesesConfig {
            enabled: true,
            min_votes_per_width: 1.25,
            min_views: 2,
            max_normal_cos: 0.7,
            merge_r: 3.0,
            min_view_votes_per_width: 0.25,
            max_per_view: 80,
        }
    }
}

impl CreaseHypothesesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(format!("creases.{m}")));
        if !(self.min_votes_per_width > 0.0 && self.min_votes_per_width.is_finite()) {
            return bad(format!(
                "min_votes_per_width = {} must be positive",
                self.min_votes_per_width
            ));
        }
        if self.min_views == 0 {
            return bad("min_views must be ≥ 1".into());
        }
        if !(0.0..1.0).contains(&self.max_normal_cos) {
            return bad(format!(
                "max_normal_cos = {} must be in [0, 1)",
                self.max_normal_cos
            ));
        }
        if !(self.merge_r >= 0.0 && self.merge_r.is_finite()) {
            return bad(format!("merge_r = {} must be ≥ 0", self.merge_r));
        }
        if !(self.min_view_votes_per_width >= 0.0 && self.min_view_votes_per_width.is_finite()) {
            return bad(format!(
                "min_view_votes_per_width = {} must be ≥ 0",
                self.min_view_votes_per_width
            ));
        }
        Ok(())
    }
}

/// One view's first labelling, as [`crease_hypotheses`] reads it.
#[derive(Debug, Clone, Copy)]
pub struct LabelledView<'a> {
    /// Index into `Scene::views`.
    pub view_index: usize,
    /// Hypothesis index per pixel (row-major); anything out of range (no plane, the
    /// non-planar label) does not vote.
    pub labels: &'a [u32],
    /// Depth (camera z) per pixel; 0 = none.
    pub depth: &'a [f32],
    /// Dominant-line pixels of the view ([`crate::planemap::lines::dominant_line_mask`]).
    pub lines: &'a [bool],
}

/// A crease hypothesis and the views that see it (cast at least
/// [`CreaseHypothesesConfig::min_view_votes_per_width`] votes for it).
#[derive(Debug, Clone, PartialEq)]
pub struct CreaseHypothesis {
    /// The plane (support 0: no sparse points are counted).
    pub hypothesis: PlaneHypothesis,
    /// Indices into `Scene::views`, ascending.
    pub views: Vec<usize>,
}

/// Crease hypotheses from labelled views (see [`CreaseHypothesesConfig`]), sorted by axis
/// then offset, ids 0..; the caller renumbers them after the existing `hypotheses`. Only
/// the Manhattan axes (`axes.num_manhattan`) are used. Deterministic: votes are summed in
/// view and pixel order.
pub fn crease_hypotheses(
    scene: &Scene,
    axes: &DominantAxes,
    hypotheses: &[PlaneHypothesis],
    views: &[LabelledView<'_>],
    scale: f64,
    cfg: &CreaseHypothesesConfig,
) -> Result<Vec<CreaseHypothesis>, HypothesesError> {
    cfg.validate()?;
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(HypothesesError::Input(format!(
            "sampling scale {scale} must be positive and finite"
        )));
    }
    let m = axes.num_manhattan.min(axes.directions.len());
    let dirs: Vec<Vector3<f64>> = axes.directions[..m].iter().map(|d| d.normalize()).collect();
    // Per axis: offset bin (units of R) → (votes, sum of offsets, votes per view).
    type Bin = (u64, f64, Vec<u32>);
    let mut votes: Vec<std::collections::BTreeMap<i64, Bin>> = vec![Default::default(); m];
    let mut width = 0u32;
    let min_view_votes: Vec<u32> = scene
        .views
        .iter()
        .map(|v| ((cfg.min_view_votes_per_width * v.camera.width as f64).ceil() as u32).max(1))
        .collect();
    for lv in views {
        let view = scene.views.get(lv.view_index).ok_or_else(|| {
            HypothesesError::Input(format!("view index {} out of range", lv.view_index))
        })?;
        let (w, h) = (view.camera.width, view.camera.height);
        let n = w as usize * h as usize;
        if lv.labels.len() != n || lv.depth.len() != n || lv.lines.len() != n {
            return Err(HypothesesError::Input(format!(
                "view {}: labelling arrays are not {w}x{h}",
                view.name
            )));
        }
        width = width.max(w);
        let world_from_cam = view.cam_from_world.inverse();
        for p in (0..n).filter(|&p| lv.lines[p]) {
            let (label, z) = (lv.labels[p] as usize, lv.depth[p] as f64);
            if label >= hypotheses.len() || !(z > 0.0 && z.is_finite()) {
                continue;
            }
            let normal = hypotheses[label].plane.normal;
            let ray = view.camera.pixel_ray(p as u32 % w, p as u32 / w);
            let x = (world_from_cam * nalgebra::Point3::from(ray * z)).coords;
            for (k, d) in dirs.iter().enumerate() {
                if d.dot(&normal).abs() > cfg.max_normal_cos {
                    continue;
                }
                let o = d.dot(&x);
                let entry = votes[k]
                    .entry((o / scale).round() as i64)
                    .or_insert_with(|| (0, 0.0, vec![0; scene.views.len()]));
                entry.0 += 1;
                entry.1 += o;
                entry.2[lv.view_index] += 1;
            }
        }
    }
    let min_votes = (cfg.min_votes_per_width * width as f64).ceil() as u64;
    let mut out: Vec<CreaseHypothesis> = Vec::new();
    // Each hypothesis's votes per view, for the per-view cap.
    let mut out_votes = Vec::new();
    for (k, map) in votes.iter().enumerate() {
        let count = |b: i64| map.get(&b).map_or(0, |e| e.0);
        for (&b, bin) in map {
            // A local maximum (ties to the left bin) of the pooled three-bin window.
            let pooled = |c: i64| count(c - 1) + count(c) + count(c + 1);
            let here = pooled(b);
            if here < min_votes || pooled(b - 1) > here || pooled(b + 1) >= here {
                continue;
            }
            let mut sum = 0.0;
            let mut per_view = bin.2.clone();
            for e in [b - 1, b + 1].iter().filter_map(|c| map.get(c)) {
                sum += e.1;
                for (s, &t) in per_view.iter_mut().zip(&e.2) {
                    *s += t;
                }
            }
            let seeing: Vec<usize> = (0..per_view.len())
                .filter(|&v| per_view[v] >= min_view_votes[v])
                .collect();
            if seeing.len() < cfg.min_views {
                continue;
            }
            let offset = (sum + bin.1) / here as f64;
            let d = dirs[k];
            let known = hypotheses
                .iter()
                .chain(out.iter().map(|c| &c.hypothesis))
                .any(|h| {
                    let c = h.plane.normal.dot(&d);
                    c.abs() >= 1.0f64.to_radians().cos()
                        && (h.plane.offset - c.signum() * offset).abs() < cfg.merge_r * scale
                });
            if !known {
                out.push(CreaseHypothesis {
                    hypothesis: PlaneHypothesis {
                        id: out.len() as u32,
                        plane: Plane { normal: d, offset },
                        axis: Some(k),
                        support: 0,
                    },
                    views: seeing,
                });
                out_votes.push(per_view);
            }
        }
    }
    Ok(cap_per_view(out, &out_votes, cfg))
}

/// Keeps each view's `cfg.max_per_view` hypotheses with the most votes from it (ties to the
/// lower id), drops the view from the others, then the hypotheses left with fewer than
/// `cfg.min_views` views; ids are renumbered 0.. in order.
fn cap_per_view<T: Copy + Ord>(
    mut out: Vec<CreaseHypothesis>,
    votes: &[Vec<T>],
    cfg: &CreaseHypothesesConfig,
) -> Vec<CreaseHypothesis> {
    let cap = cfg.max_per_view;
    if cap == 0 {
        return out;
    }
    let num_views = votes.first().map_or(0, Vec::len);
    // v indexes both the views' lists and the inner vote vectors.
    (0..num_views).for_each(|v| {
        let mut seen: Vec<usize> = (0..out.len())
            .filter(|&c| out[c].views.binary_search(&v).is_ok())
            .collect();
        if seen.len() <= cap {
            return;
        }
        seen.sort_by(|&a, &b| votes[b][v].cmp(&votes[a][v]).then(a.cmp(&b)));
        for &c in &seen[cap..] {
            out[c].views.retain(|&x| x != v);
        }
    });
    out.retain(|c| c.views.len() >= cfg.min_views);
    for (i, c) in out.iter_mut().enumerate() {
        c.hypothesis.id = i as u32;
    }
    out
}

#[cfg(test)]
mod tests;
