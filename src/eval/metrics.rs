//! Benchmark metrics against synthetic ground truth: per-pixel depth accuracy at relative
//! thresholds, completeness, normal angular error, plane segmentation after matching, and
//! ETH3D-style point-cloud accuracy / completeness / F-score against the ground-truth mesh.
//!
//! All counters are integers or sums accumulated in a fixed order, so pooled results are
//! bit-identical for any thread count.

use std::collections::{BTreeMap, HashMap};

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::Vector3;
use serde::Serialize;

/// Relative depth-error thresholds reported (0.005 = 0.5%).
pub const DEPTH_THRESHOLDS: [f64; 3] = [0.005, 0.01, 0.02];

/// Depth and normal counters of one view (or several pooled).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DepthCounts {
    /// Pixels with ground-truth depth.
    pub gt_pixels: u64,
    /// Of those, pixels the method gave a depth (finite, > 0).
    pub predicted: u64,
    /// Of the ground-truth pixels, those with |z − z_gt| ≤ t·z_gt for each of
    /// [`DEPTH_THRESHOLDS`] (a pixel without a prediction counts as wrong).
    pub within: [u64; 3],
    /// Sum of |z − z_gt| (scene units) over predicted ground-truth pixels.
    pub abs_error_sum: f64,
    /// Sum of |z − z_gt| / z_gt over predicted ground-truth pixels.
    pub rel_error_sum: f64,
    /// Pixels with both a predicted and a ground-truth normal.
    pub normal_pixels: u64,
    /// Sum of the angles (degrees) between predicted and ground-truth normals.
    pub normal_error_sum_deg: f64,
    /// Of `normal_pixels`, those within 10° of the ground truth.
    pub normal_within_10deg: u64,
    /// Pixels without a ground-truth surface (the sky, or the background beyond the scene).
    pub empty_pixels: u64,
    /// Of those, pixels the method gave a depth anyway.
    pub empty_predicted: u64,
}

impl DepthCounts {
    /// Adds another view's counters.
    pub fn add(&mut self, o: &DepthCounts) {
        self.gt_pixels += o.gt_pixels;
        self.predicted += o.predicted;
        for k in 0..3 {
            self.within[k] += o.within[k];
        }
        self.abs_error_sum += o.abs_error_sum;
        self.rel_error_sum += o.rel_error_sum;
        self.normal_pixels += o.normal_pixels;
        self.empty_pixels += o.empty_pixels;
        self.empty_predicted += o.empty_predicted;
        self.normal_error_sum_deg += o.normal_error_sum_deg;
        self.normal_within_10deg += o.normal_within_10deg;
    }

    /// Share of ground-truth pixels within threshold `k` of [`DEPTH_THRESHOLDS`].
    pub fn accuracy(&self, k: usize) -> f64 {
        self.within[k] as f64 / self.gt_pixels.max(1) as f64
    }

    /// Share of the pixels without a ground-truth surface (sky, background) given a depth
    /// (0 when there are none).
    pub fn empty_with_depth(&self) -> f64 {
        self.empty_predicted as f64 / self.empty_pixels.max(1) as f64
    }

    /// Share of ground-truth pixels given a depth.
    pub fn completeness(&self) -> f64 {
        self.predicted as f64 / self.gt_pixels.max(1) as f64
    }

    /// Mean absolute depth error (scene units) over predicted pixels; NaN if none.
    pub fn mean_abs_error(&self) -> f64 {
        if self.predicted == 0 {
            f64::NAN
        } else {
            self.abs_error_sum / self.predicted as f64
        }
    }

    /// Mean normal angle error (degrees); NaN if no normals.
    pub fn mean_normal_error_deg(&self) -> f64 {
        if self.normal_pixels == 0 {
            f64::NAN
        } else {
            self.normal_error_sum_deg / self.normal_pixels as f64
        }
    }
}

/// A depth is usable if finite and positive (methods mark "none" with 0 or NaN).
#[inline]
pub fn has_depth(z: f32) -> bool {
    z.is_finite() && z > 0.0
}

/// Predicted and ground-truth normals of a view (world frame, row-major).
pub type NormalPair<'a> = (&'a [[f32; 3]], &'a [[f32; 3]]);

/// Scores one view's depth (and optionally normals; both world frame, unit) against ground
/// truth. Slices are row-major and of equal length; ground-truth depth ≤ 0 means "no surface".
pub fn depth_counts(
    pred_depth: &[f32],
    gt_depth: &[f32],
    normals: Option<NormalPair<'_>>,
) -> DepthCounts {
    let mut c = DepthCounts::default();
    for (p, (&z, &gz)) in pred_depth.iter().zip(gt_depth).enumerate() {
        if !has_depth(gz) {
            // A NaN or infinite prediction is no depth, as elsewhere.
            if gz == 0.0 {
                c.empty_pixels += 1;
                c.empty_predicted += has_depth(z) as u64;
            }
            continue;
        }
        c.gt_pixels += 1;
        if !has_depth(z) {
            continue;
        }
        c.predicted += 1;
        let (z, gz) = (z as f64, gz as f64);
        let err = (z - gz).abs();
        for (k, t) in DEPTH_THRESHOLDS.iter().enumerate() {
            if err <= t * gz {
                c.within[k] += 1;
            }
        }
        c.abs_error_sum += err;
        c.rel_error_sum += err / gz;
        if let Some((pn, gn)) = normals {
            let (a, b) = (pn[p], gn[p]);
            let na = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            let nb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
            if na > 0.5 && nb > 0.5 {
                let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) as f64
                    / ((na as f64).sqrt() * (nb as f64).sqrt());
                let deg = dot.clamp(-1.0, 1.0).acos().to_degrees();
                c.normal_pixels += 1;
                c.normal_error_sum_deg += deg;
                if deg <= 10.0 {
                    c.normal_within_10deg += 1;
                }
            }
        }
    }
    c
}

/// Plane segmentation scores after matching predicted labels to ground-truth planes.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Segmentation {
    /// Planar ground-truth pixels (id > 0).
    pub planar_pixels: u64,
    /// Of those, pixels whose label maps to their ground-truth plane.
    pub correct: u64,
    /// Ground-truth planes split over several labels: at least two labels each cover
    /// ≥ [`SEGMENT_SHARE`] of the plane's labelled pixels.
    pub over_segmented: u32,
    /// Labels spanning several ground-truth planes: at least two planes each take
    /// ≥ [`SEGMENT_SHARE`] of the label's planar pixels.
    pub under_segmented: u32,
    /// Ground-truth planes with at least [`SEGMENT_MIN_PIXELS`] labelled pixels (the
    /// population the two counts above are drawn from).
    pub planes_considered: u32,
    /// Labels with at least [`SEGMENT_MIN_PIXELS`] planar pixels.
    pub labels_considered: u32,
}

/// Share of a region another region must take to count in over/under-segmentation.
pub const SEGMENT_SHARE: f64 = 0.1;
/// Regions smaller than this (pixels, pooled over views) are not counted as split/merged.
pub const SEGMENT_MIN_PIXELS: u64 = 50;

impl Segmentation {
    /// Pixel accuracy on planar pixels.
    pub fn accuracy(&self) -> f64 {
        self.correct as f64 / self.planar_pixels.max(1) as f64
    }
}

/// Scores label maps (global label ids, `None` = no label at that pixel) against
/// ground-truth plane ids (0 = non-planar), pooled over views. Each label is matched to the
/// ground-truth plane it overlaps most (many-to-one; ties to the smaller id), so renaming
/// labels never changes the score.
pub fn segmentation<'a>(
    views: impl Iterator<Item = (&'a [Option<u32>], &'a [u16])> + Clone,
) -> Segmentation {
    let mut overlap: BTreeMap<(u32, u16), u64> = BTreeMap::new();
    let mut planar = 0u64;
    for (labels, gt) in views.clone() {
        for (l, &g) in labels.iter().zip(gt) {
            if g == 0 {
                continue;
            }
            planar += 1;
            if let Some(l) = l {
                *overlap.entry((*l, g)).or_default() += 1;
            }
        }
    }
    // Best plane per label.
    let mut best: BTreeMap<u32, (u16, u64)> = BTreeMap::new();
    let mut label_total: BTreeMap<u32, u64> = BTreeMap::new();
    let mut plane_total: BTreeMap<u16, u64> = BTreeMap::new();
    for (&(l, g), &n) in &overlap {
        let b = best.entry(l).or_insert((g, 0));
        if n > b.1 {
            *b = (g, n);
        }
        *label_total.entry(l).or_default() += n;
        *plane_total.entry(g).or_default() += n;
    }
    let correct = best.values().map(|&(_, n)| n).sum();
    let mut seg = Segmentation {
        planar_pixels: planar,
        correct,
        ..Default::default()
    };
    let mut labels_per_plane: BTreeMap<u16, u32> = BTreeMap::new();
    let mut planes_per_label: BTreeMap<u32, u32> = BTreeMap::new();
    for (&(l, g), &n) in &overlap {
        let (lt, pt) = (label_total[&l], plane_total[&g]);
        if pt >= SEGMENT_MIN_PIXELS && n as f64 >= SEGMENT_SHARE * pt as f64 {
            *labels_per_plane.entry(g).or_default() += 1;
        }
        if lt >= SEGMENT_MIN_PIXELS && n as f64 >= SEGMENT_SHARE * lt as f64 {
            *planes_per_label.entry(l).or_default() += 1;
        }
    }
    seg.planes_considered = plane_total
        .values()
        .filter(|&&n| n >= SEGMENT_MIN_PIXELS)
        .count() as u32;
    seg.labels_considered = label_total
        .values()
        .filter(|&&n| n >= SEGMENT_MIN_PIXELS)
        .count() as u32;
    seg.over_segmented = labels_per_plane.values().filter(|&&k| k >= 2).count() as u32;
    seg.under_segmented = planes_per_label.values().filter(|&&k| k >= 2).count() as u32;
    seg
}

/// A view has collapsed when one plane label covers more than this share of its pixels …
pub const COLLAPSE_LABEL_SHARE: f64 = 0.8;
/// … while its ground truth shows at least [`COLLAPSE_GT_PLANES`] planes that each cover more
/// than this share of the view (issue 35: "no single plane labels more than 80 % of a view
/// whose ground truth shows three or more planes of over 5 % each").
pub const COLLAPSE_GT_PLANE_SHARE: f64 = 0.05;
/// Ground-truth planes (each over [`COLLAPSE_GT_PLANE_SHARE`]) a view must show to be checked
/// for a collapse.
pub const COLLAPSE_GT_PLANES: usize = 3;

/// Views checked for a collapse ([`view_collapsed`]) and those that collapsed.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Collapses {
    /// Views whose ground truth shows at least [`COLLAPSE_GT_PLANES`] planes of over
    /// [`COLLAPSE_GT_PLANE_SHARE`] of the view each.
    pub checked: u32,
    /// Of those, the views (names) where one label covers over [`COLLAPSE_LABEL_SHARE`] of
    /// the view.
    pub collapsed: Vec<String>,
}

impl Collapses {
    /// Adds another set of views, their names prefixed with `prefix` (e.g. `SCENE/`).
    pub fn add(&mut self, o: &Collapses, prefix: &str) {
        self.checked += o.checked;
        self.collapsed
            .extend(o.collapsed.iter().map(|v| format!("{prefix}{v}")));
    }
}

/// Whether one view collapsed to one plane: `None` when its ground-truth plane ids
/// (`gt_planes`, 0 = no plane) show fewer than [`COLLAPSE_GT_PLANES`] planes of over
/// [`COLLAPSE_GT_PLANE_SHARE`] of the view (the view is not checked), else whether one
/// label of `labels` (`None` = no plane at the pixel) covers over [`COLLAPSE_LABEL_SHARE`]
/// of it. Shares are of all the view's pixels, sky included, so a view that is mostly sky
/// cannot collapse on the few planes it shows.
pub fn view_collapsed(labels: &[Option<u32>], gt_planes: &[u16]) -> Option<bool> {
    let n = gt_planes.len().max(1) as f64;
    let mut gt: BTreeMap<u16, u64> = BTreeMap::new();
    for &g in gt_planes.iter().filter(|&&g| g != 0) {
        *gt.entry(g).or_default() += 1;
    }
    let shown = gt
        .values()
        .filter(|&&c| c as f64 > COLLAPSE_GT_PLANE_SHARE * n)
        .count();
    if shown < COLLAPSE_GT_PLANES {
        return None;
    }
    let mut count: HashMap<u32, u64> = HashMap::new();
    for l in labels.iter().flatten() {
        *count.entry(*l).or_default() += 1;
    }
    let largest = count.values().copied().max().unwrap_or(0);
    Some(largest as f64 > COLLAPSE_LABEL_SHARE * n)
}

/// Exact point-to-triangle distances to a mesh, up to a cap: triangles are binned into a
/// uniform grid over their bounding boxes grown by the cap, so a query only tests the
/// triangles of its cell. Distances beyond the cap are reported as the cap.
pub struct MeshDistance {
    tris: Vec<[Vector3<f64>; 3]>,
    cell: f64,
    cap: f64,
    grid: HashMap<[i64; 3], Vec<u32>>,
}

/// At most this many grid cells per triangle: huge ground triangles get a coarser grid.
const MAX_CELLS: f64 = 4.0e6;

impl MeshDistance {
    /// Indexes `triangles` (indices into `vertices`) for distances up to `cap`.
    pub fn new(vertices: &[Vector3<f64>], triangles: &[[u32; 3]], cap: f64) -> MeshDistance {
        let tris: Vec<[Vector3<f64>; 3]> = triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < vertices.len()))
            .map(|t| t.map(|i| vertices[i as usize]))
            .collect();
        let bbox = |t: &[Vector3<f64>; 3]| {
            let lo = t[0].inf(&t[1]).inf(&t[2]).add_scalar(-cap);
            let hi = t[0].sup(&t[1]).sup(&t[2]).add_scalar(cap);
            (lo, hi)
        };
        // Cell size: a few times the cap, grown until the total cell count is bounded.
        let mut cell = (4.0 * cap).max(1e-6);
        loop {
            let total: f64 = tris
                .iter()
                .map(|t| {
                    let (lo, hi) = bbox(t);
                    let e = (hi - lo) / cell;
                    (e.x.floor() + 2.0) * (e.y.floor() + 2.0) * (e.z.floor() + 2.0)
                })
                .sum();
            if total <= MAX_CELLS {
                break;
            }
            cell *= 2.0;
        }
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, t) in tris.iter().enumerate() {
            let (lo, hi) = bbox(t);
            let a = (lo / cell).map(|v| v.floor() as i64);
            let b = (hi / cell).map(|v| v.floor() as i64);
            for x in a.x..=b.x {
                for y in a.y..=b.y {
                    for z in a.z..=b.z {
                        grid.entry([x, y, z]).or_default().push(i as u32);
                    }
                }
            }
        }
        MeshDistance {
            tris,
            cell,
            cap,
            grid,
        }
    }

    /// Distance from `p` to the nearest triangle, or the cap if none is closer.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let key = (p / self.cell).map(|v| v.floor() as i64);
        let mut best = self.cap;
        if let Some(list) = self.grid.get(&[key.x, key.y, key.z]) {
            for &i in list {
                let t = &self.tris[i as usize];
                best = best.min(point_triangle_distance(p, &t[0], &t[1], &t[2]));
            }
        }
        best
    }
}

/// Euclidean distance from `p` to the triangle (a, b, c) (Ericson, Real-Time Collision
/// Detection §5.1.5: closest point by Voronoi region).
pub fn point_triangle_distance(
    p: &Vector3<f64>,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> f64 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.norm();
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return bp.norm();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).norm();
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return cp.norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).norm();
    }
    let denom = 1.0 / (va + vb + vc);
    if !denom.is_finite() {
        // Degenerate (zero-area) triangle: nearest of its edges' end points.
        return ap.norm().min(bp.norm()).min(cp.norm());
    }
    let v = vb * denom;
    let w = vc * denom;
    (p - (a + ab * v + ac * w)).norm()
}

/// ETH3D-style point-cloud scores at one tolerance.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CloudScores {
    /// Tolerance (scene units).
    pub tolerance: f64,
    /// Reconstructed points evaluated.
    pub points: u64,
    /// Share of reconstructed points within the tolerance of the ground-truth mesh.
    pub accuracy: f64,
    /// Mean distance of reconstructed points to the mesh, each capped at 10× the tolerance.
    pub mean_distance: f64,
    /// Ground-truth reference points (visible surface, from the ground-truth depth maps).
    pub reference_points: u64,
    /// Share of reference points within the tolerance of a reconstructed point.
    pub completeness: f64,
    /// Harmonic mean of accuracy and completeness.
    pub f_score: f64,
}

/// Scores `points` against the mesh (accuracy) and against `reference` — points on the
/// ground-truth surface that the cameras see (completeness), as ETH3D does with its
/// laser scan restricted to observed parts.
pub fn cloud_scores(
    points: &[Vector3<f64>],
    mesh: &MeshDistance,
    reference: &[Vector3<f64>],
    tolerance: f64,
) -> CloudScores {
    use rayon::prelude::*;
    let cap = 10.0 * tolerance;
    let dists: Vec<f64> = points
        .par_iter()
        .map(|p| mesh.distance(p).min(cap))
        .collect();
    let good = dists.iter().filter(|&&d| d <= tolerance).count();
    let accuracy = good as f64 / points.len().max(1) as f64;
    let mean_distance = if points.is_empty() {
        f64::NAN
    } else {
        dists.iter().sum::<f64>() / points.len() as f64
    };
    let completeness = if points.is_empty() || reference.is_empty() {
        0.0
    } else {
        let coords: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tree: ImmutableKdTree<f64, 3> = match ImmutableKdTree::new_from_slice(&coords) {
            Ok(t) => t,
            Err(_) => return CloudScores::default(),
        };
        let t2 = tolerance * tolerance;
        let covered = reference
            .par_iter()
            .filter(|q| {
                let n = tree
                    .query(&[q.x, q.y, q.z])
                    .nearest_one::<SquaredEuclidean<f64>>()
                    .execute();
                n.distance <= t2
            })
            .count();
        covered as f64 / reference.len() as f64
    };
    let f_score = if accuracy + completeness > 0.0 {
        2.0 * accuracy * completeness / (accuracy + completeness)
    } else {
        0.0
    };
    CloudScores {
        tolerance,
        points: points.len() as u64,
        accuracy,
        mean_distance,
        reference_points: reference.len() as u64,
        completeness,
        f_score,
    }
}

fn proc_status_bytes(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Peak resident memory of this process (bytes) since the last [`reset_peak_memory`], from
/// `VmHWM` in /proc/self/status; `None` where that file does not exist.
pub fn peak_memory_bytes() -> Option<u64> {
    proc_status_bytes("VmHWM:")
}

/// Current resident memory of this process (bytes), `VmRSS` in /proc/self/status. Memory
/// freed by earlier work often stays resident (the allocator keeps it), so a method's own
/// need is bounded below by its peak minus this value at its start.
pub fn resident_memory_bytes() -> Option<u64> {
    proc_status_bytes("VmRSS:")
}

/// Resets the peak-memory counter to the current resident size (Linux: writing 5 to
/// /proc/self/clear_refs); returns false where unsupported, and the peak is then the
/// process's.
pub fn reset_peak_memory() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_collapses_when_one_label_covers_it_against_three_planes() {
        // 100 pixels: ground-truth planes 1 (50 px), 2 (30), 3 (6) and sky (14).
        let mut gt = vec![0u16; 100];
        gt[..50].fill(1);
        gt[50..80].fill(2);
        gt[80..86].fill(3);
        // 81 pixels of label 7: collapsed (81 > 80 % of all 100 pixels).
        let mut labels: Vec<Option<u32>> = vec![Some(7); 81];
        labels.extend(std::iter::repeat_n(None, 19));
        assert_eq!(view_collapsed(&labels, &gt), Some(true));
        // Exactly 80 %: not over the share.
        labels[80] = Some(9);
        assert_eq!(view_collapsed(&labels, &gt), Some(false));
        // Plane 3 at exactly 5 % is not shown: two planes, the view is not checked.
        gt[85] = 0;
        assert_eq!(view_collapsed(&labels, &gt), None);
        // Sums over views, names prefixed.
        let mut all = Collapses::default();
        let one = Collapses {
            checked: 2,
            collapsed: vec!["v1.png".into()],
        };
        all.add(&one, "a/");
        all.add(&one, "b/");
        assert_eq!(all.checked, 4);
        assert_eq!(all.collapsed, vec!["a/v1.png", "b/v1.png"]);
    }

    #[test]
    fn depth_off_by_exactly_one_percent() {
        // 100 ground-truth pixels at depth 100: 40 exact, 40 off by exactly 1% (101 and
        // 99), 10 off by 1.5%, 5 without prediction; 5 pixels have no ground truth.
        let mut gt = vec![100.0f32; 100];
        let mut pred = vec![100.0f32; 100];
        for (p, z) in pred.iter_mut().enumerate() {
            *z = match p {
                0..40 => 100.0,
                40..60 => 101.0,
                60..80 => 99.0,
                80..90 => 101.5,
                90..95 => 0.0,
                _ => 100.0,
            };
        }
        for g in gt.iter_mut().skip(95) {
            *g = 0.0;
        }
        let c = depth_counts(&pred, &gt, None);
        assert_eq!(c.gt_pixels, 95);
        assert_eq!(c.predicted, 90);
        assert_eq!(c.within, [40, 80, 90]);
        assert_eq!(c.accuracy(1), 80.0 / 95.0);
        assert_eq!(c.completeness(), 90.0 / 95.0);
        assert!((c.mean_abs_error() - (40.0 + 15.0) / 90.0).abs() < 1e-12);
        // A NaN prediction is "no depth", not an error.
        let c2 = depth_counts(&[f32::NAN, 100.0], &[100.0, 100.0], None);
        assert_eq!((c2.gt_pixels, c2.predicted, c2.within), (2, 1, [1, 1, 1]));
    }

    #[test]
    fn normal_errors_in_degrees() {
        let gt = vec![[0.0f32, 0.0, 1.0]; 3];
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let pred = vec![[0.0, 0.0, 1.0], [s, 0.0, s], [0.0, 0.0, 0.0]];
        let c = depth_counts(&[1.0; 3], &[1.0; 3], Some((&pred, &gt)));
        assert_eq!(c.normal_pixels, 2);
        assert!((c.mean_normal_error_deg() - 22.5).abs() < 1e-4);
        assert_eq!(c.normal_within_10deg, 1);
    }

    #[test]
    fn relabelled_planemap_scores_full_after_matching() {
        // Two views; ground truth planes 3 (left) and 7 (right), view 2 also has plane 9
        // at the bottom. The prediction uses arbitrary ids 42, 5, 0 for them.
        let (w, h) = (10usize, 6usize);
        let gt1: Vec<u16> = (0..w * h).map(|p| if p % w < 5 { 3 } else { 7 }).collect();
        let gt2: Vec<u16> = (0..w * h)
            .map(|p| {
                if p / w >= 4 {
                    9
                } else if p % w < 5 {
                    3
                } else {
                    7
                }
            })
            .collect();
        let rename = |g: u16| -> Option<u32> {
            Some(match g {
                3 => 42,
                7 => 5,
                _ => 0,
            })
        };
        let l1: Vec<Option<u32>> = gt1.iter().map(|&g| rename(g)).collect();
        let l2: Vec<Option<u32>> = gt2.iter().map(|&g| rename(g)).collect();
        let views = [
            (l1.as_slice(), gt1.as_slice()),
            (l2.as_slice(), gt2.as_slice()),
        ];
        let s = segmentation(views.iter().copied());
        assert_eq!(s.planar_pixels, 120);
        assert_eq!(s.correct, 120);
        assert_eq!(s.accuracy(), 1.0);
        assert_eq!((s.over_segmented, s.under_segmented), (0, 0));
    }

    #[test]
    fn split_and_merged_planes_are_counted() {
        // Plane 1 (60 px) split into labels 10 and 11 (30 px each); planes 2 and 3 (60 px
        // each) merged into label 12.
        let gt: Vec<u16> = (0..180).map(|p| 1 + (p / 60) as u16).collect();
        let labels: Vec<Option<u32>> = (0..180)
            .map(|p| {
                Some(if p < 30 {
                    10
                } else if p < 60 {
                    11
                } else {
                    12
                })
            })
            .collect();
        let s = segmentation(std::iter::once((labels.as_slice(), gt.as_slice())));
        assert_eq!(s.over_segmented, 1);
        assert_eq!(s.under_segmented, 1);
        // Label 12 maps to plane 2 (tie → smaller id): plane 3's 60 px are wrong; label 10
        // and 11 both map to plane 1.
        assert_eq!(s.correct, 120);
    }

    #[test]
    fn point_to_triangle_distance_by_region() {
        let a = Vector3::new(0.0, 0.0, 0.0);
        let b = Vector3::new(1.0, 0.0, 0.0);
        let c = Vector3::new(0.0, 1.0, 0.0);
        let d =
            |x: f64, y: f64, z: f64| point_triangle_distance(&Vector3::new(x, y, z), &a, &b, &c);
        assert!((d(0.2, 0.2, 0.5) - 0.5).abs() < 1e-12); // face
        assert!((d(-1.0, -1.0, 0.0) - 2f64.sqrt()).abs() < 1e-12); // vertex a
        assert!((d(0.5, -2.0, 0.0) - 2.0).abs() < 1e-12); // edge ab
        assert!((d(1.0, 1.0, 0.0) - 0.5f64.sqrt()).abs() < 1e-12); // edge bc
    }

    #[test]
    fn cloud_scores_on_a_square() {
        // Mesh: the unit square z = 0 (two triangles). Reconstruction: a 10×10 grid on it,
        // half of it lifted 0.05 off. Reference: the same grid on the square.
        let v = vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(1.0, 1.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
        ];
        let mesh = MeshDistance::new(&v, &[[0, 1, 2], [0, 2, 3]], 0.1);
        let grid: Vec<Vector3<f64>> = (0..100)
            .map(|i| {
                Vector3::new(
                    0.05 + 0.1 * (i % 10) as f64,
                    0.05 + 0.1 * (i / 10) as f64,
                    0.0,
                )
            })
            .collect();
        let pts: Vec<Vector3<f64>> = grid
            .iter()
            .enumerate()
            .map(|(i, p)| {
                if i < 50 {
                    *p
                } else {
                    p + Vector3::new(0.0, 0.0, 0.05)
                }
            })
            .collect();
        let s = cloud_scores(&pts, &mesh, &grid, 0.01);
        assert_eq!(s.accuracy, 0.5);
        assert_eq!(s.completeness, 0.5);
        assert_eq!(s.f_score, 0.5);
        assert!((s.mean_distance - 0.025).abs() < 1e-9);
        // Far points are capped at 10× the tolerance.
        assert_eq!(mesh.distance(&Vector3::new(0.5, 0.5, 3.0)), 0.1);
    }
}
