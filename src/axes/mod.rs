//! Dominant axes (the Manhattan frame) from oriented points.
//!
//! Furukawa et al. 2009, §4.1: histogram the normals on the hemisphere (~1000 bins); d1 is the
//! mean normal of the fullest bin; d2 the fullest bin 80°–100° from d1; d3 the fullest bin
//! 80°–100° from both. The axes are not forced to be orthogonal.
//!
//! Our variant: bins are an equal-area "igloo" grid on the hemisphere (`n` and `−n` folded
//! together). Because folding splits a peak lying on the hemisphere's rim between two bins,
//! each of the fullest bins (up to `max_candidates`) proposes its mean normal, and a candidate
//! is scored by its *axial support*: the number of normals within `refine_angle_deg` of it,
//! counting `n` and `−n` alike. The chosen candidate is refined by re-averaging those normals
//! (axially) a few times. Optional: snapping to an orthonormal frame, extra (non-Manhattan)
//! directions for roofs and oblique walls.

use std::f64::consts::PI;

use nalgebra::{DMatrix, Matrix3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::normals::{canonical_sign, OrientedCloud};

/// Errors of the dominant-axes stage.
#[derive(Debug, Error, PartialEq)]
pub enum AxesError {
    /// The configuration is invalid (message says which field and why).
    #[error("invalid axes config: {0}")]
    Config(String),
    /// Normals and confidences differ in length.
    #[error("{normals} normals but {confidence} confidences")]
    Inconsistent {
        /// Number of normals.
        normals: usize,
        /// Number of confidences.
        confidence: usize,
    },
    /// No normal passed the confidence filter.
    #[error("no usable normals (none with confidence ≥ {0})")]
    NoNormals(f64),
    /// Fewer than three directions were found and the config asks for an error.
    #[error("only {found} dominant direction(s) found, 3 required")]
    TooFewAxes {
        /// How many were found.
        found: usize,
    },
}

/// What to do when fewer than three dominant directions exist.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MissingAxes {
    /// Return the directions that exist and a [`AxesWarning::FewerThanThree`] warning.
    #[default]
    Warn,
    /// Fail with [`AxesError::TooFewAxes`].
    Error,
}

/// Configuration of [`dominant_axes`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AxesConfig {
    /// Approximate number of equal-area bins of the normal histogram on the hemisphere
    /// (`n` and `−n` folded), a count ≥ 10: the paper's ~1000.
    pub num_bins: usize,
    /// Half-angle, in degrees in (0, 45), of the cone in which normals score a candidate
    /// direction (its axial support) and are re-averaged to refine it. Not tuned.
    pub refine_angle_deg: f64,
    /// Re-averaging rounds refining each candidate direction (normals within
    /// `refine_angle_deg`), a count; 0 = the bin's mean normal as it is. Not tuned.
    pub refine_iterations: usize,
    /// How many of the fullest histogram bins propose their mean normal as a candidate
    /// direction, a count ≥ 1: a peak on the hemisphere's rim is split between two bins, so
    /// more than the fullest bin must be looked at. Not tuned.
    pub max_candidates: usize,
    /// Lower bound, in degrees in [0, 90], of the angle between d2 and d1, and between d3
    /// and d1, d2: the paper's 80°.
    pub min_orthogonal_deg: f64,
    /// Upper bound, in degrees in [90, 180], of that angle: the paper's 100° (as an axial
    /// angle ≤ 90° this means "within `180 − max` of perpendicular").
    pub max_orthogonal_deg: f64,
    /// Minimum axial support of d1–d3 as a fraction of the usable normals, in [0, 1]; the
    /// larger of this and `min_support` applies. Guards against a handful of stray normals
    /// making an axis.
    pub min_support_fraction: f64,
    /// Minimum axial support of d1–d3 in normals (points), a count; also the support a
    /// completed third axis needs (`complete_frame`). Guards against stray normals.
    pub min_support: usize,
    /// Normals whose confidence (in [0, 1]) is below this are ignored; in [0, 1]. Just
    /// above 0, so that normals whose fit failed (confidence 0) do not vote.
    pub min_confidence: f64,
    /// Replace d1–d3 by an orthonormal frame (how: `snap_sharp_angle_deg`). Off, as in the
    /// paper, which does not force the axes orthogonal; snapping also lost on room
    /// (docs/notes/axes.md).
    pub snap_orthonormal: bool,
    /// How to snap when `snap_orthonormal` is on, in degrees in [0, 45): 0 = the nearest
    /// orthonormal frame (polar decomposition, which spreads every axis' error over all
    /// three); > 0 = of the six frames that keep one axis exactly, make a second orthogonal
    /// to it and take the third as their cross product, the one with most normals within
    /// this many degrees of an axis, so that a direction smeared by small adjacent faces
    /// (stair treads and risers) is fixed by the two crisp ones instead of tilting them.
    /// Only matters when snapping.
    pub snap_sharp_angle_deg: f64,
    /// Extra (non-Manhattan) directions looked for beyond the three axes (roof slopes,
    /// oblique walls), a count; 0 = the paper's Manhattan three. Chosen on the 13 scenes:
    /// pitched roofs and turned wings need their own planes, and no other scene changes
    /// once [`crate::hypotheses::HypothesesConfig::max_shared_fraction`] drops a stair
    /// flight's slope (docs/notes/axes.md).
    pub max_extra_directions: usize,
    /// Minimum axial support of an extra direction, as a fraction of the usable normals,
    /// in [0, 1]: an extra direction needs a real peak. Not tuned.
    pub extra_min_support_fraction: f64,
    /// Minimum angle, in degrees in (0, 90], between an extra direction and every direction
    /// already found: it must be a peak of its own, away from the others. Not tuned.
    pub extra_min_separation_deg: f64,
    /// With exactly two (near-orthogonal) Manhattan directions, take the third as their
    /// cross product (refined by the normals near it) if at least `min_support` normals lie
    /// within `refine_angle_deg` of it; the fractional threshold is waived. On: plain walls
    /// can have too few sparse points for an axis of their own (courtyard's east and west
    /// walls), and the photo-consistency sweep along the completed axis then finds their
    /// planes (docs/notes/axes.md).
    pub complete_frame: bool,
    /// With fewer than three Manhattan directions from the points, complete them with the
    /// cameras' vertical ([`camera_vertical_given`]: read off the image rows, or off the
    /// rows and a wall normal on a walk) and the horizontals across it
    /// ([`DominantAxes::complete_with_vertical`], run by the pipeline); nothing happens when
    /// the cameras were not held upright. On: a lawn or floor seen at grazing angles has
    /// almost no sparse points, yet the sweep along the vertical finds its plane.
    pub camera_vertical: bool,
    /// Level the axes with the cameras' vertical when the cameras give one (held upright:
    /// [`camera_vertical`], or on a walk [`camera_vertical_given`]): the direction within
    /// `level_max_deg` of it becomes it, and every direction within `level_max_deg` of
    /// horizontal is made exactly horizontal ([`DominantAxes::level_to`]), before and after
    /// each refit. Walls of buildings are vertical and floors level; a fit to the sparse
    /// points tilts them by the points' noise and mix (2.4° on a generated street, where
    /// the floor had almost no points). Off: on the generated development scenes it gave
    /// streets +8.8 and +11.7 points within 1 %, but on the test split street-1000 −2.1 and
    /// interior-1000 −2.7 (docs/notes/generalisation.md). A roll common to every camera
    /// tilts the result.
    pub level_to_camera_vertical: bool,
    /// The largest angle, in degrees in [0, 45), by which `level_to_camera_vertical` moves
    /// a direction: a direction further from vertical or horizontal (a roof slope) is kept.
    pub level_max_deg: f64,
    /// What to do when fewer than three Manhattan directions exist: `warn` (go on with the
    /// directions found) or `error` (fail). Fewer than three is worth a warning, not a
    /// failure.
    pub on_missing: MissingAxes,
    /// Refit of the axes from the points on their plane hypotheses (run by the pipeline
    /// after the first hypotheses, [`refine_axes_from_planes`]).
    pub refine: AxisRefineConfig,
}

impl Default for AxesConfig {
    fn default() -> Self {
        AxesConfig {
            num_bins: 1000,
            refine_angle_deg: 5.0,
            refine_iterations: 3,
            max_candidates: 64,
            min_orthogonal_deg: 80.0,
            max_orthogonal_deg: 100.0,
            min_support_fraction: 0.02,
            min_support: 10,
            min_confidence: 1e-3,
            snap_orthonormal: false,
            snap_sharp_angle_deg: 2.0,
            max_extra_directions: 2,
            extra_min_support_fraction: 0.05,
            extra_min_separation_deg: 20.0,
            complete_frame: true,
            camera_vertical: true,
            level_to_camera_vertical: false,
            level_max_deg: 5.0,
            on_missing: MissingAxes::Warn,
            refine: AxisRefineConfig::default(),
        }
    }
}

impl AxesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), AxesError> {
        let bad = |m: String| Err(AxesError::Config(m));
        let r = &self.refine;
        let refine_ok = r.inlier_r > 0.0
            && r.inlier_r.is_finite()
            && (0.0..=90.0).contains(&r.max_change_deg)
            && r.normal_tolerance_deg > 0.0
            && r.normal_tolerance_deg < 90.0;
        if !refine_ok {
            return bad(format!(
                "refine: inlier_r = {} must be > 0, max_change_deg = {} in [0, 90], \
                 normal_tolerance_deg = {} in (0, 90)",
                r.inlier_r, r.max_change_deg, r.normal_tolerance_deg
            ));
        }
        if self.num_bins < 10 {
            return bad(format!("num_bins = {} must be ≥ 10", self.num_bins));
        }
        if !(self.snap_sharp_angle_deg >= 0.0 && self.snap_sharp_angle_deg < 45.0) {
            return bad(format!(
                "snap_sharp_angle_deg = {} must be in [0, 45)",
                self.snap_sharp_angle_deg
            ));
        }
        if !(self.level_max_deg >= 0.0 && self.level_max_deg < 45.0) {
            return bad(format!(
                "level_max_deg = {} must be in [0, 45)",
                self.level_max_deg
            ));
        }
        if !(self.refine_angle_deg > 0.0 && self.refine_angle_deg < 45.0) {
            return bad(format!(
                "refine_angle_deg = {} must be in (0, 45)",
                self.refine_angle_deg
            ));
        }
        if self.max_candidates == 0 {
            return bad("max_candidates must be ≥ 1".into());
        }
        if !(0.0..=90.0).contains(&self.min_orthogonal_deg)
            || !(90.0..=180.0).contains(&self.max_orthogonal_deg)
        {
            return bad(format!(
                "orthogonality window [{}, {}] must satisfy 0 ≤ min ≤ 90 ≤ max ≤ 180",
                self.min_orthogonal_deg, self.max_orthogonal_deg
            ));
        }
        for (name, v) in [
            ("min_support_fraction", self.min_support_fraction),
            (
                "extra_min_support_fraction",
                self.extra_min_support_fraction,
            ),
            ("min_confidence", self.min_confidence),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        if !(self.extra_min_separation_deg > 0.0 && self.extra_min_separation_deg <= 90.0) {
            return bad(format!(
                "extra_min_separation_deg = {} must be in (0, 90]",
                self.extra_min_separation_deg
            ));
        }
        Ok(())
    }
}

/// A non-fatal finding of the axes stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AxesWarning {
    /// Only this many Manhattan directions were found (e.g. all points on one or two planes).
    FewerThanThree(usize),
    /// Snapping was requested but needs at least two directions.
    SnapSkipped,
    /// d3 was taken as d1 × d2 (`complete_frame`); this many normals lie near it.
    CompletedThird(usize),
    /// This many Manhattan directions were added from the cameras' vertical
    /// ([`DominantAxes::complete_with_vertical`]).
    CompletedWithVertical(usize),
}

/// The dominant directions of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DominantAxes {
    /// Unit directions (world frame): d1, d2, d3 (those found), then any extra directions.
    /// Sign: in the hemisphere z > 0 (ties: y > 0, then x > 0).
    pub directions: Vec<Vector3<f64>>,
    /// Axial support of each direction: normals within `refine_angle_deg` of it.
    pub support: Vec<usize>,
    /// For each pair `i < j`, the acute angle (degrees, in [0, 90]) between the directions.
    pub pairwise_angles_deg: Vec<(usize, usize, f64)>,
    /// How many of `directions` are Manhattan axes (d1–d3); the rest are extra directions.
    pub num_manhattan: usize,
    /// Non-fatal findings.
    pub warnings: Vec<AxesWarning>,
}

/// Equal-area "igloo" binning of the upper hemisphere: bands of equal polar width, each
/// split into azimuth cells whose number is proportional to the band's area.
struct HemisphereGrid {
    /// Band `b` covers polar angles [b·Δθ, (b+1)·Δθ].
    dtheta: f64,
    /// Azimuth cells per band.
    cells: Vec<usize>,
    /// First bin index of each band.
    start: Vec<usize>,
    total: usize,
}

impl HemisphereGrid {
    fn new(target_bins: usize) -> Self {
        let target_area = 2.0 * PI / target_bins as f64;
        // Square-ish cells: band width ≈ sqrt(cell area).
        let bands = ((PI / 2.0) / target_area.sqrt()).round().max(1.0) as usize;
        let dtheta = (PI / 2.0) / bands as f64;
        let mut cells = Vec::with_capacity(bands);
        let mut start = Vec::with_capacity(bands);
        let mut total = 0;
        for b in 0..bands {
            let area = 2.0 * PI * ((b as f64 * dtheta).cos() - ((b + 1) as f64 * dtheta).cos());
            let c = (area / target_area).round().max(1.0) as usize;
            start.push(total);
            cells.push(c);
            total += c;
        }
        HemisphereGrid {
            dtheta,
            cells,
            start,
            total,
        }
    }

    /// Bin of a unit vector already folded into the upper hemisphere.
    fn bin(&self, n: &Vector3<f64>) -> usize {
        let theta = n.z.clamp(-1.0, 1.0).acos();
        let b = ((theta / self.dtheta) as usize).min(self.cells.len() - 1);
        let phi = n.y.atan2(n.x).rem_euclid(2.0 * PI);
        let c = ((phi / (2.0 * PI) * self.cells[b] as f64) as usize).min(self.cells[b] - 1);
        self.start[b] + c
    }
}

/// Acute angle in degrees between two unit axes (sign-free).
pub(crate) fn axial_angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.dot(b).abs().clamp(0.0, 1.0).acos().to_degrees()
}

/// Axial support and axial mean of the normals within `cos_tol` of `d`.
fn axial_stats(normals: &[Vector3<f64>], d: &Vector3<f64>, cos_tol: f64) -> (usize, Vector3<f64>) {
    let mut count = 0;
    let mut sum = Vector3::zeros();
    for n in normals {
        let c = n.dot(d);
        if c.abs() >= cos_tol {
            count += 1;
            sum += if c < 0.0 { -n } else { *n };
        }
    }
    (count, sum)
}

/// Refines `d` by re-averaging (axially) the normals within `cos_tol`; returns the direction
/// and its final support.
fn refine(
    normals: &[Vector3<f64>],
    d: Vector3<f64>,
    cos_tol: f64,
    iters: usize,
) -> (Vector3<f64>, usize) {
    let mut d = d;
    for _ in 0..iters {
        let (count, sum) = axial_stats(normals, &d, cos_tol);
        let len = sum.norm();
        if count == 0 || len == 0.0 {
            break;
        }
        d = sum / len;
    }
    let (count, _) = axial_stats(normals, &d, cos_tol);
    (canonical_sign(d), count)
}

/// Finds the dominant directions of the oriented cloud (see the module doc).
pub fn dominant_axes(
    cloud: &OrientedCloud,
    config: &AxesConfig,
) -> Result<DominantAxes, AxesError> {
    config.validate()?;
    if cloud.normals.len() != cloud.confidence.len() {
        return Err(AxesError::Inconsistent {
            normals: cloud.normals.len(),
            confidence: cloud.confidence.len(),
        });
    }
    let normals: Vec<Vector3<f64>> = cloud
        .normals
        .iter()
        .zip(&cloud.confidence)
        .filter(|(n, &c)| c >= config.min_confidence && c > 0.0 && n.iter().all(|v| v.is_finite()))
        .filter_map(|(n, _)| {
            let len = n.norm();
            (len > 0.0).then(|| canonical_sign(n / len))
        })
        .collect();
    if normals.is_empty() {
        return Err(AxesError::NoNormals(config.min_confidence));
    }

    // Histogram: count and (folded) vector sum per bin.
    let grid = HemisphereGrid::new(config.num_bins);
    let mut count = vec![0usize; grid.total];
    let mut sum = vec![Vector3::zeros(); grid.total];
    for n in &normals {
        let b = grid.bin(n);
        count[b] += 1;
        sum[b] += n;
    }
    let mut bins: Vec<usize> = (0..grid.total).filter(|&b| count[b] > 0).collect();
    bins.sort_by(|&a, &b| count[b].cmp(&count[a]).then(a.cmp(&b)));
    bins.truncate(config.max_candidates);

    let cos_tol = config.refine_angle_deg.to_radians().cos();
    // Candidates: each bin's mean normal, refined and scored by axial support.
    let mut candidates: Vec<(Vector3<f64>, usize)> = bins
        .par_iter()
        .map(|&b| {
            refine(
                &normals,
                sum[b].normalize(),
                cos_tol,
                config.refine_iterations,
            )
        })
        .collect();
    // Highest support first; ties by bin order (already deterministic).
    candidates.sort_by_key(|c| std::cmp::Reverse(c.1));

    let min_support = config
        .min_support
        .max((config.min_support_fraction * normals.len() as f64).ceil() as usize)
        .max(1);
    let ortho_ok = |a: &Vector3<f64>, b: &Vector3<f64>| {
        let ang = a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
        ang >= config.min_orthogonal_deg && ang <= config.max_orthogonal_deg
            || (180.0 - ang) >= config.min_orthogonal_deg
                && (180.0 - ang) <= config.max_orthogonal_deg
    };

    let mut directions: Vec<Vector3<f64>> = Vec::new();
    let mut support: Vec<usize> = Vec::new();
    // Prefer the mutually orthogonal triple with the largest total support over the greedy
    // pick: a smeared fullest bin (e.g. the mean of stair treads and risers) can be the most
    // supported single direction yet leave no room for a third axis within the window.
    let strong: Vec<&(Vector3<f64>, usize)> =
        candidates.iter().filter(|c| c.1 >= min_support).collect();
    let mut best: Option<(usize, [usize; 3])> = None;
    for a in 0..strong.len() {
        for b in a + 1..strong.len() {
            if !ortho_ok(&strong[a].0, &strong[b].0) {
                continue;
            }
            for c in b + 1..strong.len() {
                if ortho_ok(&strong[a].0, &strong[c].0) && ortho_ok(&strong[b].0, &strong[c].0) {
                    let total = strong[a].1 + strong[b].1 + strong[c].1;
                    if best.is_none_or(|(t, _)| total > t) {
                        best = Some((total, [a, b, c]));
                    }
                }
            }
        }
    }
    if let Some((_, idx)) = best {
        for i in idx {
            directions.push(strong[i].0);
            support.push(strong[i].1);
        }
    }
    for _ in directions.len()..3 {
        let pick = candidates
            .iter()
            .find(|(d, s)| *s >= min_support && directions.iter().all(|e| ortho_ok(d, e)));
        match pick {
            Some(&(d, s)) => {
                directions.push(d);
                support.push(s);
            }
            None => break,
        }
    }
    let mut warnings = Vec::new();
    if directions.len() == 2 && config.complete_frame {
        let cross = directions[0].cross(&directions[1]);
        if cross.norm() > 1e-9 {
            let c = cross.normalize();
            let (refined, n_near) = refine(&normals, c, cos_tol, config.refine_iterations);
            // Keep the refined direction only if still orthogonal enough to both.
            let d = if n_near > 0 && directions.iter().all(|e| ortho_ok(&refined, e)) {
                refined
            } else {
                c
            };
            let n = axial_stats(&normals, &d, cos_tol).0;
            // Some normals must confirm it (the absolute `min_support`, not the fraction):
            // a corridor seen along its length has no wall across it, and the sweep then
            // finds ghost planes across the corridor.
            if n >= config.min_support {
                directions.push(d);
                support.push(n);
                warnings.push(AxesWarning::CompletedThird(n));
            }
        }
    }
    let num_manhattan = directions.len();
    if num_manhattan < 3 {
        if config.on_missing == MissingAxes::Error {
            return Err(AxesError::TooFewAxes {
                found: num_manhattan,
            });
        }
        warnings.push(AxesWarning::FewerThanThree(num_manhattan));
    }

    if config.snap_orthonormal && config.snap_sharp_angle_deg > 0.0 && num_manhattan == 3 {
        let cos_sharp = config.snap_sharp_angle_deg.to_radians().cos();
        // Each ordering keeps one axis exactly, makes the next orthogonal to it and takes the
        // third as their cross product; the frame that puts most normals within the sharp
        // cone of one of its axes wins (ties: the first ordering).
        let frame = |o: [usize; 3]| {
            let a = directions[o[0]].normalize();
            let b = (directions[o[1]] - a * a.dot(&directions[o[1]])).normalize();
            let mut c = a.cross(&b);
            if c.dot(&directions[o[2]]) < 0.0 {
                c = -c;
            }
            let mut f = [Vector3::zeros(); 3];
            f[o[0]] = a;
            f[o[1]] = b;
            f[o[2]] = c;
            f
        };
        let score = |f: &[Vector3<f64>; 3]| {
            normals
                .iter()
                .filter(|n| f.iter().any(|d| n.dot(d).abs() >= cos_sharp))
                .count()
        };
        let mut best: Option<(usize, [Vector3<f64>; 3])> = None;
        for o in [
            [0, 1, 2],
            [1, 0, 2],
            [0, 2, 1],
            [2, 0, 1],
            [1, 2, 0],
            [2, 1, 0],
        ] {
            let f = frame(o);
            let sc = score(&f);
            if best.is_none_or(|(b, _)| sc > b) {
                best = Some((sc, f));
            }
        }
        if let Some((_, f)) = best {
            for (d, s) in directions.iter_mut().zip(f) {
                *d = canonical_sign(s);
            }
        }
    } else if config.snap_orthonormal {
        if num_manhattan >= 2 {
            // Nearest matrix with orthonormal columns: U Vᵀ of the SVD (polar decomposition).
            let m = DMatrix::from_fn(3, num_manhattan, |r, c| directions[c][r]);
            let svd = m.svd(true, true);
            if let (Some(u), Some(vt)) = (svd.u, svd.v_t) {
                let q = u * vt;
                for (c, d) in directions.iter_mut().enumerate() {
                    let col = Vector3::new(q[(0, c)], q[(1, c)], q[(2, c)]);
                    *d = canonical_sign(col.normalize());
                }
            }
        } else {
            warnings.push(AxesWarning::SnapSkipped);
        }
    }

    let extra_min =
        ((config.extra_min_support_fraction * normals.len() as f64).ceil() as usize).max(1);
    for _ in 0..config.max_extra_directions {
        let pick = candidates.iter().find(|(d, s)| {
            *s >= extra_min
                && directions
                    .iter()
                    .all(|e| axial_angle_deg(d, e) >= config.extra_min_separation_deg)
        });
        match pick {
            Some(&(d, s)) => {
                directions.push(d);
                support.push(s);
            }
            None => break,
        }
    }
    // Supports are recounted for the final (possibly snapped) directions.
    for (d, s) in directions.iter().zip(support.iter_mut()) {
        *s = axial_stats(&normals, d, cos_tol).0;
    }
    Ok(DominantAxes {
        pairwise_angles_deg: pairwise_angles(&directions),
        directions,
        support,
        num_manhattan,
        warnings,
    })
}

/// Settings of [`refine_axes_from_planes`]: a second estimate of each Manhattan axis from
/// the *positions* of the points lying on its plane hypotheses, which is far less noisy
/// than the PCA normals the histogram sees (small adjacent faces, stair treads and risers,
/// smear the normals and tilt an axis by several degrees).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AxisRefineConfig {
    /// Refit rounds (each: hypotheses → axes → hypotheses), a count; 0 = off. Each round
    /// starts from hypotheses found along the previous round's axes, so a tilt shrinks
    /// round by round; four bring the stairs' vertical within a degree
    /// (docs/notes/axes.md).
    pub iterations: usize,
    /// A point is an inlier of its axis' nearest plane if within this many R of it (> 0),
    /// as wide as the hypotheses' mean-shift bandwidth ...
    pub inlier_r: f64,
    /// ... and its normal within this many degrees of the axis, in (0, 90): tighter than
    /// the hypotheses' `normal_tolerance_deg`, because points on an edge between two faces
    /// (a stair nosing) have smeared normals and, on the wrong face, tilt the fit.
    pub normal_tolerance_deg: f64,
    /// A refit direction is accepted only if it moves by at most this many degrees, in
    /// [0, 90]: a larger move is a wrong fit, not a correction.
    pub max_change_deg: f64,
    /// After the refit, make the axes orthogonal: the axis whose refit direction is best
    /// determined (least angular uncertainty, see [`refine_axes_from_planes`]) is kept, the
    /// next best is made orthogonal to it, the third is their cross product. So an axis fit
    /// to a few points, or to points along a line (a road seen along a street), cannot tilt
    /// the others: it becomes the cross product of the two well-determined ones.
    pub orthogonalize: bool,
}

impl Default for AxisRefineConfig {
    fn default() -> Self {
        AxisRefineConfig {
            iterations: 4,
            inlier_r: 2.0,
            normal_tolerance_deg: 10.0,
            max_change_deg: 20.0,
            orthogonalize: false,
        }
    }
}

/// One plane for [`refine_axes_from_planes`]: its axis index and offset along it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisPlane {
    /// Index into `DominantAxes::directions`.
    pub axis: usize,
    /// Offset `d_axis · X` of the plane (with the direction as stored in the axes).
    pub offset: f64,
}

/// Refits each Manhattan axis as the direction of least spread of the points on its planes,
/// each plane's points centred on their own mean (one normal shared by parallel planes,
/// free offsets: the pooled scatter's smallest eigenvector). A point joins the plane of
/// its axis nearest to it if within `inlier_r · scale` and its normal is within
/// `normal_tolerance_deg` of the axis. Axes with fewer than 3 inliers, or whose refit moves
/// more than `max_change_deg`, keep their direction. Returns the refit axes (extra
/// directions unchanged, pairwise angles recomputed).
///
/// The angular uncertainty of an axis's refit is `sqrt(max(λ₁, n σ²) / (λ₂ (n − 3)))`
/// radians, with `λ₁ ≤ λ₂` the two smallest eigenvalues of its pooled scatter, `n` its
/// inliers and `σ²` the median over the axes of `λ₁ / n` (the points' noise): the spread of
/// the residuals against the spread of the points along their least-extended in-plane
/// direction. `orthogonalize` keeps the axes in order of it.
// `k` indexes the axes and the per-axis RMS alike.
#[allow(clippy::needless_range_loop)]
pub fn refine_axes_from_planes(
    axes: &DominantAxes,
    positions: &[Vector3<f64>],
    normals: &[Vector3<f64>],
    planes: &[AxisPlane],
    scale: f64,
    cfg: &AxisRefineConfig,
) -> DominantAxes {
    let cos_normal = cfg.normal_tolerance_deg.to_radians().cos();
    type Stats = (usize, Vector3<f64>, Matrix3<f64>);
    let mut out = axes.clone();
    let m = axes.num_manhattan.min(axes.directions.len());
    let band = cfg.inlier_r * scale;
    // Per axis: the two smallest eigenvalues of the pooled scatter and the inlier count of
    // an accepted refit, then the angular uncertainty of the direction (radians; ∞ = not
    // refit).
    let mut spread: Vec<Option<(f64, f64, usize)>> = vec![None; m];
    let mut uncertainty = vec![f64::INFINITY; m];
    for k in 0..m {
        let d = axes.directions[k].normalize();
        let mut offs: Vec<f64> = planes
            .iter()
            .filter(|p| p.axis == k)
            .map(|p| p.offset)
            .collect();
        offs.sort_unstable_by(f64::total_cmp);
        if offs.is_empty() {
            continue;
        }
        // Per plane: count, sum and sum of outer products of its inliers (positions are
        // taken relative to the first point to keep the sums well conditioned).
        let origin = positions.first().copied().unwrap_or_else(Vector3::zeros);
        let mut stats: Vec<Stats> = vec![(0, Vector3::zeros(), Matrix3::zeros()); offs.len()];
        for (p, n) in positions.iter().zip(normals) {
            if n.dot(&d).abs() < cos_normal {
                continue;
            }
            let o = d.dot(p);
            let i = offs.partition_point(|&x| x < o);
            let nearest = [i.wrapping_sub(1), i]
                .into_iter()
                .filter(|&j| j < offs.len())
                .min_by(|&a, &b| (offs[a] - o).abs().total_cmp(&(offs[b] - o).abs()));
            if let Some(j) = nearest {
                if (offs[j] - o).abs() <= band {
                    let q = p - origin;
                    let s = &mut stats[j];
                    s.0 += 1;
                    s.1 += q;
                    s.2 += q * q.transpose();
                }
            }
        }
        let mut scatter = Matrix3::<f64>::zeros();
        let mut count = 0;
        for (c, sum, outer) in &stats {
            if *c >= 3 {
                let mean = sum / *c as f64;
                scatter += outer - mean * mean.transpose() * *c as f64;
                count += c;
            }
        }
        if count < 3 {
            continue;
        }
        let eig = scatter.symmetric_eigen();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let imin = order[0];
        let (l1, l2) = (
            eig.eigenvalues[order[0]].max(0.0),
            eig.eigenvalues[order[1]],
        );
        spread[k] = Some((l1, l2, count));
        let mut e: Vector3<f64> = eig.eigenvectors.column(imin).into_owned();
        if e.dot(&d) < 0.0 {
            e = -e;
        }
        if e.iter().all(|v| v.is_finite()) && axial_angle_deg(&e, &d) <= cfg.max_change_deg {
            out.directions[k] = e.normalize();
        } else {
            spread[k] = None;
        }
    }
    // A plane's points cannot fit it better than the points' own noise, which the typical
    // (median) residual variance of the refit axes measures: a few points that happen to
    // lie on one plane (or were picked from two) are not a precise direction.
    let mut variances: Vec<f64> = spread
        .iter()
        .flatten()
        .map(|&(l1, _, n)| l1 / n as f64)
        .collect();
    variances.sort_by(f64::total_cmp);
    let floor = variances.get(variances.len() / 2).copied().unwrap_or(0.0);
    for k in 0..m {
        if let Some((l1, l2, n)) = spread[k] {
            if l2 > 0.0 && n > 3 {
                uncertainty[k] = (l1.max(n as f64 * floor) / (l2 * (n - 3) as f64)).sqrt();
            }
        }
    }
    if cfg.orthogonalize && m == 3 {
        let mut order: Vec<usize> = (0..3).collect();
        order.sort_by(|&a, &b| uncertainty[a].total_cmp(&uncertainty[b]).then(a.cmp(&b)));
        let a = out.directions[order[0]];
        let b = out.directions[order[1]];
        let b2 = (b - a * a.dot(&b)).normalize();
        let mut c = a.cross(&b2);
        if c.dot(&out.directions[order[2]]) < 0.0 {
            c = -c;
        }
        out.directions[order[1]] = b2;
        out.directions[order[2]] = c;
    }
    out.pairwise_angles_deg = pairwise_angles(&out.directions);
    out
}

/// Largest mean squared sine of the angle between the cameras' image rows and the vertical
/// for the cameras to count as upright (about 6° of roll, root mean square).
const MAX_MEAN_ROLL_SIN2: f64 = 0.01;

/// The world's vertical as the cameras' orientation tells it, when they were held upright
/// (no roll: every image row horizontal, as photographs of buildings usually are): the
/// direction most nearly perpendicular to every view's image x-axis, signed to agree with
/// the images' "up". `None` for fewer than two views, when the rows are not close to one
/// plane (cameras rolled, or no common vertical), or when they are all nearly parallel (a
/// facade walk: any direction across them would do, and the images' "up" is tilted by the
/// cameras' pitch).
pub fn camera_vertical(views: &[crate::scene::View]) -> Option<Vector3<f64>> {
    if views.len() < 2 {
        return None;
    }
    let (scatter, mean_up, _) = camera_rows(views);
    let n = views.len() as f64;
    let eig = nalgebra::SymmetricEigen::new(scatter);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    if l0 > MAX_MEAN_ROLL_SIN2 || l1 < 4.0 * MAX_MEAN_ROLL_SIN2 {
        return None;
    }
    let up: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let along = up.dot(&mean_up) / n;
    if along.abs() < 0.1 {
        // The images' "up" does not pick a side (cameras looking straight up or down).
        return None;
    }
    Some(if along < 0.0 { -up } else { up })
}

/// The views' image rows (x axes) in world coordinates, their mean scatter `Σ r rᵀ / n`, and
/// the sum of their images' "up" (−y axes): what [`camera_vertical`] and
/// [`camera_vertical_given`] read the vertical from.
fn camera_rows(
    views: &[crate::scene::View],
) -> (nalgebra::Matrix3<f64>, Vector3<f64>, Vec<Vector3<f64>>) {
    let mut scatter = nalgebra::Matrix3::<f64>::zeros();
    let mut up_sum = Vector3::zeros();
    let mut rows = Vec::with_capacity(views.len());
    for v in views {
        let rot = v.cam_from_world.rotation;
        // Rows of R are the camera axes in world coordinates: x right, y down.
        let right = rot.inverse_transform_vector(&Vector3::x());
        scatter += right * right.transpose();
        up_sum -= rot.inverse_transform_vector(&Vector3::y());
        rows.push(right);
    }
    (scatter / views.len().max(1) as f64, up_sum, rows)
}

/// Largest angle (degrees) between the vertical a walk's cameras and a known axis give
/// ([`camera_vertical_given`]) and the images' mean "up": the cameras' largest pitch.
const MAX_WALK_PITCH_DEG: f64 = 30.0;

/// [`camera_vertical`], and where it has no answer because the image rows are too nearly
/// parallel to pin a vertical down (a walk forward along a corridor or along a facade, a
/// slow pan), the vertical the rows and a known Manhattan direction give together. The
/// rows' mean direction `r` is horizontal (upright cameras) and so is any wall normal `d`
/// among `known`: the vertical is then `r × d`, kept only if every row is horizontal for it
/// as [`camera_vertical`] requires (a roll common to every camera cannot be told from a
/// tilted world: upright cameras are the assumption, as there). Which known direction is a
/// wall normal is read off the images' mean "up" `u` (projected across `r`): `r × d` must
/// lie within `MAX_WALK_PITCH_DEG` (30°) of `u` (the best such `d` is taken). `None` when a
/// known direction already lies within that
/// angle of `u` (the vertical is known: nothing to add, and the horizontal across it and a
/// wall normal is then the walk's own direction, whose planes are the hardest to tell
/// apart), or when no known direction qualifies.
pub fn camera_vertical_given(
    views: &[crate::scene::View],
    known: &[Vector3<f64>],
) -> Option<Vector3<f64>> {
    if let Some(up) = camera_vertical(views) {
        return Some(up);
    }
    if views.len() < 2 {
        return None;
    }
    let (scatter, mean_up, rows) = camera_rows(views);
    let eig = nalgebra::SymmetricEigen::new(scatter);
    let top = (0..3)
        .max_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
        .expect("three eigenvalues");
    let r: Vector3<f64> = eig.eigenvectors.column(top).into_owned();
    let u = mean_up - r * r.dot(&mean_up);
    let u = u.try_normalize(1e-9)?;
    let cos_pitch = MAX_WALK_PITCH_DEG.to_radians().cos();
    let unit: Vec<Vector3<f64>> = known
        .iter()
        .filter_map(|d| d.try_normalize(1e-12))
        .collect();
    if unit.iter().any(|d| d.dot(&u).abs() >= cos_pitch) {
        return None;
    }
    unit.iter()
        .filter_map(|d| {
            let v = r.cross(d).try_normalize(1e-6)?;
            let v = if v.dot(&u) < 0.0 { -v } else { v };
            // Every image row must be horizontal for this vertical, as camera_vertical asks.
            let roll = rows.iter().map(|x| x.dot(&v).powi(2)).sum::<f64>() / rows.len() as f64;
            (v.dot(&u) >= cos_pitch && roll <= MAX_MEAN_ROLL_SIN2).then_some(v)
        })
        .max_by(|a, b| a.dot(&u).total_cmp(&b.dot(&u)))
}

/// Directions closer than this (degrees, sign ignored) count as the same sweep direction.
const SAME_DIRECTION_DEG: f64 = 10.0;

/// The directions that complete the Manhattan directions `known` (fewer than three) with
/// the vertical `up` (unit): `up` itself unless a known direction is within
/// `SAME_DIRECTION_DEG` of it, then, while still fewer than three, the horizontal across
/// `up` and each horizontal known direction. Nothing for three or more: the points' own
/// estimate is the finer one.
pub fn vertical_completion(known: &[Vector3<f64>], up: &Vector3<f64>) -> Vec<Vector3<f64>> {
    let mut all: Vec<Vector3<f64>> = known.iter().map(|d| d.normalize()).collect();
    if all.len() >= 3 {
        return Vec::new();
    }
    let is_known = |all: &[Vector3<f64>], d: &Vector3<f64>| {
        all.iter()
            .any(|a| axial_angle_deg(a, d) <= SAME_DIRECTION_DEG)
    };
    if !is_known(&all, up) {
        all.push(*up);
    }
    let horizontal: Vec<Vector3<f64>> = all
        .iter()
        .copied()
        .filter(|a| axial_angle_deg(a, up) >= 90.0 - SAME_DIRECTION_DEG)
        .collect();
    for h in horizontal {
        if all.len() >= 3 {
            break;
        }
        let across = up.cross(&h).normalize();
        if !is_known(&all, &across) {
            all.push(across);
        }
    }
    all.split_off(known.len())
}

impl DominantAxes {
    /// Levels the directions with the vertical `up`: the one nearest `up`, if within
    /// `max_deg` of it, becomes `up` (in the canonical sign); every other one within
    /// `max_deg` of horizontal is projected onto the horizontal plane. Returns how many
    /// directions moved.
    pub fn level_to(&mut self, up: &Vector3<f64>, max_deg: f64) -> usize {
        let Some(up) = up.try_normalize(1e-12) else {
            return 0;
        };
        let sin_max = max_deg.to_radians().sin();
        let vertical = (0..self.directions.len())
            .map(|k| (k, self.directions[k].normalize().dot(&up).abs()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, c)| c >= max_deg.to_radians().cos())
            .map(|(k, _)| k);
        let mut moved = 0;
        for k in 0..self.directions.len() {
            let d = self.directions[k].normalize();
            let new = if Some(k) == vertical {
                canonical_sign(up)
            } else if d.dot(&up).abs() <= sin_max {
                match (d - up * d.dot(&up)).try_normalize(1e-12) {
                    Some(h) => canonical_sign(h),
                    None => continue,
                }
            } else {
                continue;
            };
            if (new - d).norm() > 0.0 {
                moved += 1;
            }
            self.directions[k] = new;
        }
        self.pairwise_angles_deg = pairwise_angles(&self.directions);
        moved
    }

    /// Completes fewer than three Manhattan directions with the vertical `up` and the
    /// horizontals across it ([`vertical_completion`]), inserted after the Manhattan
    /// directions (before any extra one) in the canonical sign, with the axial support of
    /// `normals` within `cone_deg` (the points rarely give any: that is why they were
    /// missing). Returns how many were added; a warning records it.
    pub fn complete_with_vertical(
        &mut self,
        up: &Vector3<f64>,
        normals: &[Vector3<f64>],
        cone_deg: f64,
    ) -> usize {
        let m = self.num_manhattan.min(self.directions.len());
        let added = vertical_completion(&self.directions[..m], &up.normalize());
        if added.is_empty() {
            return 0;
        }
        let cos_tol = cone_deg.to_radians().cos();
        for (i, d) in added.iter().enumerate() {
            let d = canonical_sign(*d);
            let support = axial_stats(normals, &d, cos_tol).0;
            self.directions.insert(m + i, d);
            self.support.insert(m + i, support);
        }
        self.num_manhattan = m + added.len();
        self.pairwise_angles_deg = pairwise_angles(&self.directions);
        self.warnings
            .push(AxesWarning::CompletedWithVertical(added.len()));
        added.len()
    }
}

/// For each pair `i < j` of `directions`, their acute angle in degrees.
fn pairwise_angles(directions: &[Vector3<f64>]) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::new();
    for i in 0..directions.len() {
        for j in i + 1..directions.len() {
            out.push((i, j, axial_angle_deg(&directions[i], &directions[j])));
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests;
