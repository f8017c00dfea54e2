//! Photo-consistency sweep hypotheses: planes the sparse points are too few to propose.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::{
    HypothesesConfig, HypothesesError, HypothesesInput, PlaneHypothesis, MIN_SUPPORT_FLOOR,
};
use crate::geometry::Plane;
use crate::photo::{plane_cost_volume, select_neighbours, texture_mask};
use crate::raster::ImageF32;
use crate::scene::{Scene, View};

/// Settings of [`sweep_hypotheses`], a second source of plane hypotheses for planes with
/// too few sparse points (a plain wall whose only texture is a door seen by few views).
///
/// Every view sweeps planes along each Manhattan axis (Gallup et al. 2007) at offsets
/// spaced `step_r · R` apart; each textured pixel votes for the (axis, offset) of its
/// clearly best photo-consistent plane; an offset with enough votes from enough views,
/// not already a hypothesis, becomes one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SweepHypothesesConfig {
    /// Run the sweep (needs the images). On: a plain wall with few sparse points gets no
    /// point hypothesis and needs another source of planes (docs/notes/hypotheses.md).
    pub enabled: bool,
    /// Width of the sweep's offset bins along each axis, in units of R (full-resolution R),
    /// > 0: as wide as the point hypotheses' mean-shift bandwidth.
    pub step_r: f64,
    /// At most this many offset bins per axis, a count ≥ 2; the step grows beyond `step_r`
    /// for larger ranges. Bounds the sweep's time.
    pub max_planes_per_axis: usize,
    /// Sweep each offset bin at several evenly spaced sub-planes (a bin scores its
    /// cheapest) until consecutive sub-planes move a pixel at most this far in the
    /// neighbours: pixels of the reduced images, the `step_quantile` over a view's pixels
    /// and plane pairs, median over the views ([`crate::photo::family_step_px`]); ≥ 0,
    /// 0 = one plane per bin. Bins, margins and peaks stay those of the `step_r` grid; a
    /// hypothesis' offset is the mean of its voters' best sub-planes. Why: a plane seen at
    /// a grazing angle (a lawn from eye height) moves pixels several pixels per bin,
    /// further than the 5×5 NCC basin is wide, and then gets no votes; a finer bound
    /// costs much more time for little gain (docs/notes/hypotheses.md).
    pub max_step_px: f64,
    /// Quantile, in [0, 1], of the pixel steps over a view that `max_step_px` bounds.
    /// Gallup et al. 2007 bound the largest; the 90th percentile ignores the planes grazing
    /// the camera, which would ask for a step no sweep can pay.
    pub step_quantile: f64,
    /// Sub-planes are never closer than this many R (> 0) ...
    pub min_step_r: f64,
    /// ... and an axis never has more than this many, a count ≥ 1: the sweep's time grows
    /// with them.
    pub max_fine_planes: usize,
    /// Sweep on images reduced by this integer factor (box filter), in 1..=8; 1 = full
    /// resolution ...
    pub downsample: u32,
    /// ... or by more, so that the reduced images are at most this many pixels wide; 0 = no
    /// limit. The sweep's cost grows with the pixel count, and 160 pixels across were
    /// enough on every scene (at 640×480 this means 4×).
    pub max_width: u32,
    /// A pixel votes only if its best cost (the NCC cost) is at most this, in [0, 1] ...
    pub max_cost: f64,
    /// ... and the next best plane (another axis, or the same axis more than two steps
    /// away) costs at least this much more (cost units, in [0, 1]) ...
    pub min_margin: f64,
    /// ... and its grey-level standard deviation over the matching window (grey levels in
    /// [0, 1]) is at least this, in [0, 1]. With the two above: only good, unambiguous
    /// matches on texture vote; not tuned.
    pub texture_threshold: f64,
    /// An offset becomes a hypothesis with at least this many votes in total, as a fraction
    /// of one (reduced) view's pixels, in (0, 1] ...
    pub min_vote_fraction: f64,
    /// ... from at least this many views, a count ≥ 1 (each contributing at least a tenth
    /// of the votes threshold): a plane needs votes from more than one view. Not tuned.
    pub min_views: usize,
    /// How the sweep scores a pixel on a plane: 5×5 NCC against 3 neighbour views, the best
    /// 2 averaged; not tuned.
    pub photo: crate::photo::PhotoConfig,
    /// Snap a sweep plane to a concentration of sparse points near it: within ±1.5
    /// sub-plane steps of the sweep's offset, the densest window `snap_window_r` R wide is
    /// taken if it holds at least [`MIN_SUPPORT_FLOOR`] points and `snap_density` times the
    /// points a uniform spread over the range would put there; the plane moves to the
    /// median offset of those points (normals are not used). In R, ≥ 0; 0 = off. Why: the
    /// sweep's offsets are only as fine as its step, while a small plane whose points got
    /// edge-like normals (a stair riser's nosing strip, whose PCA neighbourhoods reach into
    /// the tread) has its points at one offset (docs/notes/hypotheses.md).
    pub snap_window_r: f64,
    /// Density ratio the snap requires (see `snap_window_r`), ≥ 1 (1 = any window at least
    /// as dense as a uniform spread).
    pub snap_density: f64,
}

impl Default for SweepHypothesesConfig {
    fn default() -> Self {
        SweepHypothesesConfig {
            enabled: true,
            step_r: 2.0,
            max_planes_per_axis: 160,
            max_step_px: 2.0,
            step_quantile: 0.9,
            min_step_r: 0.5,
            max_fine_planes: 1024,
            downsample: 2,
            max_width: 160,
            max_cost: 0.25,
            min_margin: 0.1,
            texture_threshold: 0.02,
            min_vote_fraction: 0.004,
            min_views: 2,
            photo: crate::photo::PhotoConfig {
                neighbours: 3,
                window_radius: 2,
                ..Default::default()
            },
            snap_window_r: 1.0,
            snap_density: 4.0,
        }
    }
}

impl SweepHypothesesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(format!("sweep.{m}")));
        if !(self.step_r > 0.0 && self.step_r.is_finite()) {
            return bad(format!("step_r = {} must be positive", self.step_r));
        }
        if self.max_planes_per_axis < 2 || self.photo.neighbours == 0 || self.min_views == 0 {
            return bad("max_planes_per_axis ≥ 2, neighbours ≥ 1, min_views ≥ 1 expected".into());
        }
        let fine_ok = self.max_step_px >= 0.0
            && self.max_step_px.is_finite()
            && (0.0..=1.0).contains(&self.step_quantile)
            && self.min_step_r > 0.0
            && self.min_step_r.is_finite()
            && self.max_fine_planes >= 1;
        if !fine_ok {
            return bad(format!(
                "max_step_px = {} must be ≥ 0, step_quantile = {} in [0, 1], min_step_r = {} \
                 > 0, max_fine_planes = {} ≥ 1",
                self.max_step_px, self.step_quantile, self.min_step_r, self.max_fine_planes
            ));
        }
        if !(1..=8).contains(&self.downsample) {
            return bad(format!("downsample = {} must be in 1..=8", self.downsample));
        }
        for (name, v) in [
            ("max_cost", self.max_cost),
            ("min_margin", self.min_margin),
            ("texture_threshold", self.texture_threshold),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        let snap_ok = self.snap_window_r >= 0.0
            && self.snap_window_r.is_finite()
            && self.snap_density >= 1.0
            && self.snap_density.is_finite();
        if !snap_ok {
            return bad(format!(
                "snap_window_r = {} must be ≥ 0 and snap_density = {} ≥ 1",
                self.snap_window_r, self.snap_density
            ));
        }
        if !(self.min_vote_fraction > 0.0 && self.min_vote_fraction <= 1.0) {
            return bad(format!(
                "min_vote_fraction = {} must be in (0, 1]",
                self.min_vote_fraction
            ));
        }
        self.photo
            .validate()
            .map_err(|e| HypothesesError::Config(format!("sweep.photo: {e}")))
    }
}

/// The sweep plane's offset `offset` along `d`, moved to the median offset of the densest
/// window of `window` width among the points within `reach` of it, if that window holds at
/// least [`MIN_SUPPORT_FLOOR`] points and `density` times a uniform share of the points in
/// reach (see [`SweepHypothesesConfig::snap_window_r`]); unchanged otherwise.
pub(super) fn snap_to_points(
    positions: &[Vector3<f64>],
    d: &Vector3<f64>,
    offset: f64,
    reach: f64,
    window: f64,
    density: f64,
) -> f64 {
    if window <= 0.0 || reach <= 0.0 {
        return offset;
    }
    let mut near: Vec<f64> = positions
        .iter()
        .map(|p| d.dot(p))
        .filter(|o| o.is_finite() && (o - offset).abs() <= reach)
        .collect();
    near.sort_unstable_by(f64::total_cmp);
    // Densest window: for each start point, the points within `window` after it (ties: the
    // first, so the result does not depend on anything but the sorted offsets).
    let (mut best, mut best_start) = (0usize, 0usize);
    let mut end = 0;
    for start in 0..near.len() {
        end = end.max(start);
        while end < near.len() && near[end] - near[start] <= window {
            end += 1;
        }
        if end - start > best {
            (best, best_start) = (end - start, start);
        }
    }
    let uniform = near.len() as f64 * window / (2.0 * reach);
    if best < MIN_SUPPORT_FLOOR || (best as f64) < density * uniform {
        return offset;
    }
    let w = &near[best_start..best_start + best];
    if w.len() % 2 == 1 {
        w[w.len() / 2]
    } else {
        0.5 * (w[w.len() / 2 - 1] + w[w.len() / 2])
    }
}

/// Box-filter downsampling by an integer factor (the rescaled camera's rays through the
/// new pixel centres pass through the centres of the averaged blocks).
fn downsample_image(img: &ImageF32, f: u32) -> ImageF32 {
    if f == 1 {
        return img.clone();
    }
    let (w, h, c) = (img.width / f, img.height / f, img.channels as usize);
    let mut out = ImageF32::filled(w, h, img.channels, 0.0);
    let norm = 1.0 / (f * f) as f32;
    for y in 0..h {
        for x in 0..w {
            let o = out.index(x, y);
            for dy in 0..f {
                for dx in 0..f {
                    let i = img.index(x * f + dx, y * f + dy);
                    for k in 0..c {
                        out.data[o + k] += img.data[i + k] * norm;
                    }
                }
            }
        }
    }
    out
}

/// The range of `d·X` over the view's frustum between the 5th and 95th percentile depth of
/// the points it sees (widened ×0.7 / ×1.5); `None` if it sees fewer than 3 points.
fn frustum_offset_range(scene: &Scene, view_index: usize, d: &Vector3<f64>) -> Option<(f64, f64)> {
    let view = &scene.views[view_index];
    let mut depths: Vec<f64> = scene
        .cloud
        .positions
        .iter()
        .zip(&scene.cloud.tracks)
        .filter(|(_, t)| t.contains(&(view_index as u32)))
        .filter_map(|(p, _)| view.project(p).map(|(_, z)| z))
        .filter(|z| z.is_finite() && *z > 0.0)
        .collect();
    if depths.len() < 3 {
        return None;
    }
    depths.sort_unstable_by(f64::total_cmp);
    let q = |f: f64| depths[((depths.len() - 1) as f64 * f).round() as usize];
    let (near, far) = (0.7 * q(0.05), 1.5 * q(0.95));
    let (w, h) = (view.camera.width as f64, view.camera.height as f64);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for xy in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h), (0.5 * w, 0.5 * h)] {
        let (o, dir) = view.ray(&nalgebra::Vector2::new(xy.0, xy.1));
        for z in [near, far] {
            let v = d.dot(&(o + dir * z));
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (hi > lo).then_some((lo, hi))
}

/// What [`sweep_hypotheses`] found, per axis, for reports and tests.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepVotes {
    /// Offset step per Manhattan axis (world units): the width of a vote bin.
    pub step: Vec<f64>,
    /// Sub-planes swept per bin and axis (`max_step_px`).
    pub sub_planes: Vec<usize>,
    /// Per axis: (offset of the bin, total votes, views voting) for every bin with votes.
    pub bins: Vec<Vec<(f64, u32, u32)>>,
}

/// Plane hypotheses from a photo-consistency sweep along the Manhattan axes (see
/// [`SweepHypothesesConfig`]): returns the new planes (not within the merge tolerance of
/// `existing`, ids continuing after them, `support` = sparse points within the bandwidth)
/// and the votes. `scene` must be undistorted and `images[i]` view i's image.
// Bins index several parallel per-axis arrays (votes, totals, views): ranges read clearer.
#[allow(clippy::needless_range_loop)]
pub fn sweep_hypotheses(
    scene: &Scene,
    images: &[ImageF32],
    input: &HypothesesInput<'_>,
    existing: &[PlaneHypothesis],
    config: &HypothesesConfig,
) -> Result<(Vec<PlaneHypothesis>, SweepVotes), HypothesesError> {
    let sc = &config.sweep;
    sc.validate()?;
    if images.len() != scene.views.len() {
        return Err(HypothesesError::Input(format!(
            "{} images for {} views",
            images.len(),
            scene.views.len()
        )));
    }
    let nax = input.axes.num_manhattan.min(input.axes.directions.len());
    let dirs: Vec<Vector3<f64>> = input.axes.directions[..nax]
        .iter()
        .map(|d| d.normalize())
        .collect();
    let widest_image = images.iter().map(|i| i.width).max().unwrap_or(1);
    let f = if sc.max_width > 0 {
        sc.downsample.max(widest_image.div_ceil(sc.max_width))
    } else {
        sc.downsample
    };
    // Global offset grid per axis: union of the views' frustum ranges, step ≥ step_r·R.
    // Per view and axis: the view's frustum offset range (each scans the cloud once).
    let view_ranges: Vec<Vec<Option<(f64, f64)>>> = (0..scene.views.len())
        .map(|v| {
            dirs.iter()
                .map(|d| frustum_offset_range(scene, v, d))
                .collect()
        })
        .collect();
    let mut ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); nax];
    let mut widest = vec![0.0f64; nax];
    for per_axis in &view_ranges {
        for (k, r) in per_axis.iter().enumerate() {
            if let Some((lo, hi)) = *r {
                ranges[k].0 = ranges[k].0.min(lo);
                ranges[k].1 = ranges[k].1.max(hi);
                widest[k] = widest[k].max(hi - lo);
            }
        }
    }
    let steps: Vec<f64> = (0..nax)
        .map(|k| (sc.step_r * input.scale).max(widest[k] / sc.max_planes_per_axis as f64))
        .collect();
    let nbins: Vec<usize> = (0..nax)
        .map(|k| {
            if ranges[k].1 > ranges[k].0 {
                ((ranges[k].1 - ranges[k].0) / steps[k]).ceil() as usize + 1
            } else {
                0
            }
        })
        .collect();
    let offset_of = |k: usize, i: usize| ranges[k].0 + i as f64 * steps[k];
    let small: Vec<(View, ImageF32)> = scene
        .views
        .iter()
        .zip(images)
        .map(|(v, img)| {
            let mut sv = v.clone();
            let (w, h) = ((img.width / f).max(1), (img.height / f).max(1));
            sv.camera = v.camera.rescaled(w, h);
            (sv, downsample_image(img, f))
        })
        .collect();
    let neighbours_of: Vec<Vec<usize>> = (0..scene.views.len())
        .map(|v| select_neighbours(scene, v, sc.photo.neighbours))
        .collect::<Result<_, _>>()
        .map_err(|e| HypothesesError::Input(e.to_string()))?;
    // Sub-planes per offset bin: where a bin's step moves pixels further than the 5×5 NCC
    // basin is wide, each bin is swept at `sub` evenly spaced offsets and scored by the
    // cheapest of them; bins, margins and peaks stay those of the bin grid.
    let mut subdivision = vec![1usize; nax];
    if sc.max_step_px > 0.0 {
        for k in 0..nax {
            let mut px: Vec<f64> = (0..scene.views.len())
                .filter_map(|v| {
                    let (lo, hi) = view_ranges[v][k]?;
                    let n =
                        (((hi - lo) / steps[k]).ceil() as usize + 1).min(sc.max_planes_per_axis);
                    let planes: Vec<Plane> = (0..n)
                        .map(|i| Plane {
                            normal: dirs[k],
                            offset: lo + i as f64 * steps[k],
                        })
                        .collect();
                    let nbrs: Vec<&View> = neighbours_of[v].iter().map(|&j| &small[j].0).collect();
                    crate::photo::family_step_px(&small[v].0, &nbrs, &planes, sc.step_quantile)
                })
                .collect();
            px.sort_by(f64::total_cmp);
            let Some(&median) = px.get(px.len() / 2) else {
                continue;
            };
            let cap = (sc.max_fine_planes / nbins[k].max(1))
                .min((steps[k] / (sc.min_step_r * input.scale)).floor() as usize)
                .max(1);
            subdivision[k] = ((median / sc.max_step_px).ceil() as usize).clamp(1, cap);
            tracing::debug!(
                axis = k,
                step = steps[k],
                px = median,
                sub = subdivision[k],
                "sweep hypotheses: sub-planes per bin"
            );
        }
    }
    let px_per_view = small.first().map_or(1, |(v, _)| {
        v.camera.width as usize * v.camera.height as usize
    });
    let min_votes = ((sc.min_vote_fraction * px_per_view as f64).ceil() as u32).max(1);
    let min_view_votes = (min_votes / 10).max(1);
    let mut total: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
    // Per bin: the sum of its voters' offsets (their best sub-plane's).
    let mut offset_sum: Vec<Vec<f64>> = nbins.iter().map(|&n| vec![0.0; n]).collect();
    let mut views_voting: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
    for v in 0..scene.views.len() {
        let nb = &neighbours_of[v];
        if nb.is_empty() {
            continue;
        }
        let (ref_view, ref_img) = &small[v];
        let neighbours: Vec<(&View, &ImageF32)> =
            nb.iter().map(|&j| (&small[j].0, &small[j].1)).collect();
        let npx = ref_view.camera.width as usize * ref_view.camera.height as usize;
        // Per axis: best cost, its bin, the best cost more than two bins away, and the
        // offset of the best (sub-)plane.
        let mut best = vec![(1.0f32, u32::MAX, 1.0f32, 0.0f64); npx * nax];
        for (k, d) in dirs.iter().enumerate() {
            let Some((lo, hi)) = view_ranges[v][k] else {
                continue;
            };
            let i0 = ((lo - ranges[k].0) / steps[k]).floor().max(0.0) as usize;
            let i1 = (((hi - ranges[k].0) / steps[k]).ceil() as usize).min(nbins[k] - 1);
            if i1 <= i0 {
                continue;
            }
            let sub = subdivision[k];
            // Sub-plane s of bin i sits at the bin's offset + (s + ½)/sub − ½ steps (the
            // bin's own offset when sub = 1).
            let sub_offset = |j: usize| {
                offset_of(k, i0 + j / sub)
                    + ((j % sub) as f64 + 0.5 - 0.5 * sub as f64) / sub as f64 * steps[k]
            };
            let planes: Vec<Plane> = (0..(i1 - i0 + 1) * sub)
                .map(|j| Plane {
                    normal: *d,
                    offset: sub_offset(j),
                })
                .collect();
            let vol = plane_cost_volume(ref_view, ref_img, &neighbours, &planes, &sc.photo)
                .map_err(|e| HypothesesError::Input(e.to_string()))?;
            let np = planes.len();
            let mut bin_cost = vec![0.0f32; i1 - i0 + 1];
            for p in 0..npx {
                let c = &vol.costs[p * np..(p + 1) * np];
                let (bj, bc) = c
                    .iter()
                    .enumerate()
                    .fold(
                        (0usize, f32::INFINITY),
                        |a, (i, &x)| if x < a.1 { (i, x) } else { a },
                    );
                for (b, chunk) in bin_cost.iter_mut().zip(c.chunks_exact(sub)) {
                    *b = chunk.iter().fold(f32::INFINITY, |a, &x| a.min(x));
                }
                let bi = bj / sub;
                let second = bin_cost
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| i.abs_diff(bi) > 2)
                    .fold(1.0f32, |a, (_, &x)| a.min(x));
                best[p * nax + k] = (bc, (i0 + bi) as u32, second, sub_offset(bj));
            }
        }
        let texture = texture_mask(ref_img, sc.photo.window_radius, sc.texture_threshold as f32);
        let mut votes: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
        for p in 0..npx {
            if !texture[p] {
                continue;
            }
            let row = &best[p * nax..(p + 1) * nax];
            let Some((k, &(bc, bi, second, offset))) = row
                .iter()
                .enumerate()
                .filter(|(_, b)| b.1 != u32::MAX)
                .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            else {
                continue;
            };
            let other = row
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .fold(second, |a, (_, b)| a.min(b.0));
            if bc <= sc.max_cost as f32 && other - bc >= sc.min_margin as f32 {
                votes[k][bi as usize] += 1;
                offset_sum[k][bi as usize] += offset;
            }
        }
        for k in 0..nax {
            for i in 0..nbins[k] {
                total[k][i] += votes[k][i];
                let near: u32 = votes[k][i.saturating_sub(1)..(i + 2).min(nbins[k])]
                    .iter()
                    .sum();
                if near >= min_view_votes {
                    views_voting[k][i] += 1;
                }
            }
        }
    }
    // Peaks of the vote histogram (±1 bin window) that are not existing hypotheses.
    let mut out = Vec::new();
    let h = config.bandwidth_r * input.scale;
    for k in 0..nax {
        let n = nbins[k];
        let win = |i: usize| -> u32 { total[k][i.saturating_sub(1)..(i + 2).min(n)].iter().sum() };
        for i in 0..n {
            let t = win(i);
            if t < min_votes || views_voting[k][i] < sc.min_views as u32 {
                continue;
            }
            let left_ok = i == 0 || win(i - 1) < t;
            let right_ok = i + 1 >= n || win(i + 1) <= t;
            if !(left_ok && right_ok) {
                continue;
            }
            let (mut sw, mut so) = (0.0f64, 0.0f64);
            for j in i.saturating_sub(1)..(i + 2).min(n) {
                sw += total[k][j] as f64;
                so += offset_sum[k][j];
            }
            let d = dirs[k];
            let offset = snap_to_points(
                input.positions,
                &d,
                so / sw,
                1.5 * steps[k] / subdivision[k] as f64,
                sc.snap_window_r * input.scale,
                sc.snap_density,
            );
            let dup = existing
                .iter()
                .chain(out.iter())
                .any(|e: &PlaneHypothesis| {
                    let c = e.plane.normal.dot(&d);
                    c.abs() >= config.merge_angle_deg.to_radians().cos()
                        && (e.plane.offset - c.signum() * offset).abs()
                            < (config.merge_offset_r * input.scale).max(1.5 * steps[k])
                });
            if dup {
                continue;
            }
            let support = input
                .positions
                .iter()
                .filter(|p| (d.dot(p) - offset).abs() <= h)
                .count();
            out.push(PlaneHypothesis {
                id: 0,
                plane: Plane { normal: d, offset },
                axis: Some(k),
                support,
            });
        }
    }
    for (i, hyp) in out.iter_mut().enumerate() {
        hyp.id = (existing.len() + i) as u32;
    }
    let bins = (0..nax)
        .map(|k| {
            (0..nbins[k])
                .filter(|&i| total[k][i] > 0)
                .map(|i| (offset_of(k, i), total[k][i], views_voting[k][i]))
                .collect()
        })
        .collect();
    Ok((
        out,
        SweepVotes {
            step: steps,
            sub_planes: subdivision,
            bins,
        },
    ))
}
