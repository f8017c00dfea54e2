//! Free planes: hypotheses of any orientation, fitted by sequential RANSAC to the sparse
//! points that no axis hypothesis explains (Gallup, Frahm & Pollefeys, CVPR 2010, fit their
//! planes this way; Sinha et al. 2009 keep "segments plus points" planes off the vanishing
//! directions for the same reason).
//!
//! The axis hypotheses ([`super::plane_hypotheses`]) only take the dominant directions. A
//! courtyard's paving that falls half a degree to a drain, a roof at a pitch no other surface
//! shares, or a wing turned a few degrees then has no plane of its own, and the photo term
//! has no evidence for any offered label there (docs/notes/real-photographs.md). This stage
//! looks at the rest:
//!
//! 1. the *residual* points: normal confidence ≥ `min_confidence`, and not within the
//!    bandwidth `h` of an axis hypothesis with a normal within `normal_tolerance_deg` of it;
//! 2. a sample is a residual point and two of its `neighbours` nearest residual points (so
//!    that the three lie on one surface); its plane's inliers are the residual points within
//!    `h` whose normals agree within `normal_tolerance_deg`;
//! 3. the best of `samples` samples is refit to its inliers by total least squares; with
//!    fewer than the axis hypotheses' minimum support the search ends. Its inliers leave the
//!    residual set either way;
//! 4. it becomes a hypothesis (snapped to a dominant direction within `snap_deg`) unless it
//!    duplicates one, runs along edges (`max_edge_fraction`, `max_overlap_fraction`: PCA
//!    normals bisect at edges, so edge points agree with a plane between two real ones) or is
//!    too narrow (`min_spread_r`: caps of spheres, strips down columns). The search repeats,
//!    up to `max_planes` planes, and stops after 4 rejections in a row.
//!
//! Deterministic: the samples come from a fixed-seed generator and the best one is chosen by
//! count, then by sample order, whatever the thread count.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::num::NonZeroUsize;

use super::{HypothesesConfig, HypothesesError, HypothesesInput, PlaneHypothesis};
use crate::geometry::Plane;

/// Configuration of [`free_plane_hypotheses`] (`[hypotheses.free]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FreePlanesConfig {
    /// Fit free planes to the points the axis hypotheses leave unexplained.
    pub enabled: bool,
    /// At most this many free planes, a count (0 = none). A bound on the labelling's
    /// label count, not tuned: the generated and real development sets found at most 9
    /// (docs/notes/hypotheses.md).
    pub max_planes: usize,
    /// RANSAC samples per plane, ≥ 1. With the samples drawn among a point's nearest
    /// neighbours, a plane carrying 1 % of the residual points is sampled about
    /// `samples / 100` times; 400 finds it with near certainty.
    pub samples: usize,
    /// The two other points of a sample are drawn among this many nearest residual points
    /// of the first, ≥ 2.
    pub neighbours: usize,
    /// A free plane within this angle (degrees) of a dominant direction is dropped: the axis
    /// hypotheses already propose planes there, and a near-axis plane fitted to the points
    /// they leave out is their noise. 0 keeps every free plane.
    pub min_angle_to_axes_deg: f64,
    /// A free plane is dropped when more than this fraction of its points lie within the
    /// bandwidth of an axis hypothesis (their normals disagree with it, or they would not be
    /// residual): PCA normals bisect at edges and corners, so points along an edge or a
    /// stair's nosings make a "plane" between two real ones. In [0, 1]. Chosen between what
    /// was measured on the development data: real walls and roofs of the two real sets share
    /// 0–41 % of their points (one of 25 shares 85 %), the edge planes of the hand-written
    /// stairs and occlusion scenes 53–100 % (docs/notes/hypotheses.md).
    pub max_edge_fraction: f64,
    /// A free plane is dropped when more than this fraction of all the points within its
    /// bandwidth (whatever their normals) lie within the bandwidth of an axis hypothesis: a
    /// stair flight's slope passes through the treads' and risers' points along every
    /// nosing, a roof or a turned wall meets the other planes along a few lines. In [0, 1].
    /// Measured on the development data: the real sets' walls and roofs 2–62 %, the stairs
    /// scene's slopes 76–100 %, a plane across gable's roofs 81 % (docs/notes/hypotheses.md).
    pub max_overlap_fraction: f64,
    /// The smaller in-plane standard deviation of a free plane's points must reach this many
    /// sampling scales `R` (about 10 pixels at the points' depth: a plane under ~35 pixels
    /// across is left to the other labels), ≥ 0. Caps of spheres and strips along columns
    /// are narrower: on the hand-written scenes their spread was 0.8–10 R, the real sets'
    /// walls and roofs 10–120 R (docs/notes/hypotheses.md).
    pub min_spread_r: f64,
    /// A free plane within this angle (degrees) of a dominant direction takes that
    /// direction as its normal (offset: its points' mean along it) and the direction's
    /// axis: the axis planes beside it are exact, and a wall fitted 0.5° off its axis loses
    /// to them at the image's far side. In [0, 90); 0 never snaps.
    pub snap_deg: f64,
}

impl Default for FreePlanesConfig {
    fn default() -> Self {
        FreePlanesConfig {
            enabled: true,
            max_planes: 16,
            samples: 400,
            neighbours: 12,
            min_angle_to_axes_deg: 0.0,
            max_edge_fraction: 0.5,
            max_overlap_fraction: 0.7,
            min_spread_r: 10.0,
            snap_deg: 1.0,
        }
    }
}

impl FreePlanesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(format!("free: {m}")));
        if self.samples == 0 {
            return bad("samples must be ≥ 1".into());
        }
        if self.neighbours < 2 {
            return bad(format!("neighbours = {} must be ≥ 2", self.neighbours));
        }
        if !(0.0..90.0).contains(&self.min_angle_to_axes_deg) {
            return bad(format!(
                "min_angle_to_axes_deg = {} must be in [0, 90)",
                self.min_angle_to_axes_deg
            ));
        }
        for (name, v) in [
            ("max_edge_fraction", self.max_edge_fraction),
            ("max_overlap_fraction", self.max_overlap_fraction),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        if !(0.0..90.0).contains(&self.snap_deg) {
            return bad(format!("snap_deg = {} must be in [0, 90)", self.snap_deg));
        }
        if !(self.min_spread_r >= 0.0 && self.min_spread_r.is_finite()) {
            return bad(format!(
                "min_spread_r = {} must be finite and ≥ 0",
                self.min_spread_r
            ));
        }
        Ok(())
    }
}

/// Fixed seed of the sample generator (any constant; determinism is the point).
const SEED: u64 = 0x706c_616e_656d_6170;

/// Free planes for the points `existing` leaves unexplained (see the module doc), with ids
/// after `existing`'s; `axis: None` unless snapped to a dominant direction
/// ([`FreePlanesConfig::snap_deg`]). `config.free` says how.
pub fn free_plane_hypotheses(
    input: &HypothesesInput<'_>,
    existing: &[PlaneHypothesis],
    config: &HypothesesConfig,
) -> Result<Vec<PlaneHypothesis>, HypothesesError> {
    let free = &config.free;
    free.validate()?;
    if !free.enabled || free.max_planes == 0 {
        return Ok(Vec::new());
    }
    let h = config.bandwidth_r * input.scale;
    let cos_tol = config.normal_tolerance_deg.to_radians().cos();
    let min_support = config.effective_min_support(input.positions.len());
    let on = |plane: &Plane, i: usize| is_inlier(input, plane, i, h, cos_tol);
    // Within the bandwidth of an axis hypothesis, whatever the normal.
    let on_existing = |p: &Vector3<f64>| {
        existing
            .iter()
            .any(|e| (e.plane.normal.dot(p) - e.plane.offset).abs() <= h)
    };
    let mut residual: Vec<usize> = (0..input.positions.len())
        .filter(|&i| {
            input.confidence[i] >= config.min_confidence
                && input.positions[i].iter().all(|v| v.is_finite())
                && input.normals[i].iter().all(|v| v.is_finite())
                && !existing.iter().any(|e| on(&e.plane, i))
        })
        .collect();
    let cos_axes = free.min_angle_to_axes_deg.to_radians().cos();
    let cos_snap = free.snap_deg.to_radians().cos();
    let cos_merge = config.merge_angle_deg.to_radians().cos();
    let merge_tol = config.merge_offset_r * input.scale;
    let mut out: Vec<PlaneHypothesis> = Vec::new();
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    // A few rejected fits in a row (near an axis, duplicates, edges, too narrow) end it too.
    let mut rejected = 0;
    while out.len() < free.max_planes && residual.len() >= min_support.max(3) && rejected < 4 {
        let Some(plane) = best_sample(input, &residual, &on, free, &mut rng) else {
            break;
        };
        // Refit to the inliers, twice (the inlier set moves with the plane).
        let mut plane = plane;
        for _ in 0..2 {
            let inliers: Vec<usize> = residual
                .iter()
                .copied()
                .filter(|&i| on(&plane, i))
                .collect();
            match fit_plane(input.positions, &inliers) {
                Some(p) => plane = p,
                None => break,
            }
        }
        let inliers: Vec<usize> = residual
            .iter()
            .copied()
            .filter(|&i| on(&plane, i))
            .collect();
        if inliers.len() < min_support {
            break;
        }
        residual.retain(|i| inliers.binary_search(i).is_err());
        let snap = input
            .axes
            .directions
            .iter()
            .enumerate()
            .map(|(k, d)| (k, d.normalize()))
            .filter(|(_, d)| free.snap_deg > 0.0 && d.dot(&plane.normal).abs() >= cos_snap)
            .max_by(|a, b| {
                a.1.dot(&plane.normal)
                    .abs()
                    .total_cmp(&b.1.dot(&plane.normal).abs())
            });
        let mut axis = None;
        if let Some((k, d)) = snap {
            let mean = inliers
                .iter()
                .map(|&i| d.dot(&input.positions[i]))
                .sum::<f64>()
                / inliers.len() as f64;
            plane = Plane {
                normal: d,
                offset: mean,
            };
            axis = Some(k);
        }
        let near_axis = free.min_angle_to_axes_deg > 0.0
            && input
                .axes
                .directions
                .iter()
                .any(|d| (d.normalize().dot(&plane.normal)).abs() >= cos_axes);
        let duplicate = existing.iter().chain(&out).any(|e| {
            let c = e.plane.normal.dot(&plane.normal);
            c.abs() >= cos_merge && (e.plane.offset - c.signum() * plane.offset).abs() < merge_tol
        });
        let (major, minor) = in_plane_spread(input.positions, &inliers, &plane);
        // Points on an existing plane whose normals disagree with it are its edge and
        // corner points (PCA normals bisect there): a "plane" of them runs along an edge.
        let shared = inliers
            .iter()
            .filter(|&&i| on_existing(&input.positions[i]))
            .count();
        // Every point within the bandwidth, whatever its normal: on a stair flight's slope
        // most are tread and riser points near the nosings.
        let (mut near, mut near_shared) = (0usize, 0usize);
        for p in input.positions {
            if (plane.normal.dot(p) - plane.offset).abs() <= h {
                near += 1;
                near_shared += usize::from(on_existing(p));
            }
        }
        let edge = shared as f64 > free.max_edge_fraction * inliers.len() as f64
            || near_shared as f64 > free.max_overlap_fraction * near as f64;
        let narrow = minor < free.min_spread_r * input.scale;
        tracing::debug!(
            "free plane n = ({:.3}, {:.3}, {:.3}) d = {:.3}: {} points ({shared} on other \
             planes; {near_shared} of all {near} within h), spread {:.1} × {:.1} h{}",
            plane.normal.x,
            plane.normal.y,
            plane.normal.z,
            plane.offset,
            inliers.len(),
            major / h,
            minor / h,
            if near_axis {
                ", near an axis"
            } else if duplicate {
                ", a duplicate"
            } else if edge {
                ", along edges"
            } else if narrow {
                ", too narrow"
            } else {
                ""
            }
        );
        if near_axis || duplicate || edge || narrow {
            rejected += 1;
            continue;
        }
        rejected = 0;
        out.push(PlaneHypothesis {
            id: 0,
            plane,
            axis,
            support: inliers.len(),
        });
    }
    for (k, hyp) in out.iter_mut().enumerate() {
        hyp.id = (existing.len() + k) as u32;
    }
    Ok(out)
}

/// The plane of the best of `free.samples` local 3-point samples of `residual` (most
/// inliers; ties: the earlier sample), or `None` when no sample is usable.
fn best_sample(
    input: &HypothesesInput<'_>,
    residual: &[usize],
    on: &(impl Fn(&Plane, usize) -> bool + Sync),
    free: &FreePlanesConfig,
    rng: &mut ChaCha8Rng,
) -> Option<Plane> {
    let coords: Vec<[f64; 3]> = residual
        .iter()
        .map(|&i| {
            let p = input.positions[i];
            [p.x, p.y, p.z]
        })
        .collect();
    let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(&coords).ok()?;
    let k = NonZeroUsize::new(free.neighbours + 1)?;
    // The samples are drawn in sequence (deterministic), then scored in parallel.
    let samples: Vec<[usize; 3]> = (0..free.samples)
        .filter_map(|_| {
            let a = rng.random_range(0..residual.len());
            let mut nbrs: Vec<(f64, usize)> = tree
                .query(&coords[a])
                .nearest_n::<SquaredEuclidean<f64>>(k)
                .execute()
                .into_iter()
                .map(|q| (q.distance, q.item as usize))
                .filter(|&(_, j)| j != a)
                .collect();
            nbrs.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            if nbrs.len() < 2 {
                return None;
            }
            let b = rng.random_range(0..nbrs.len());
            let mut c = rng.random_range(0..nbrs.len() - 1);
            if c >= b {
                c += 1;
            }
            Some([a, nbrs[b].1, nbrs[c].1])
        })
        .collect();
    let scored: Vec<(usize, usize, Plane)> = samples
        .par_iter()
        .enumerate()
        .filter_map(|(s, idx)| {
            let [p, q, r] = idx.map(|j| input.positions[residual[j]]);
            let n = (q - p).cross(&(r - p));
            let len = n.norm();
            // Near-collinear samples (sine of the angle at p below ~0.1) give no plane.
            if len.is_nan() || len <= 0.1 * (q - p).norm() * (r - p).norm() {
                return None;
            }
            let plane = Plane {
                normal: n / len,
                offset: (n / len).dot(&p),
            };
            // The sample's own points (on the plane by construction) must be its inliers:
            // their normals agree with it.
            if !idx.iter().all(|&j| on(&plane, residual[j])) {
                return None;
            }
            let count = residual.iter().filter(|&&i| on(&plane, i)).count();
            Some((count, s, plane))
        })
        .collect();
    scored
        .into_iter()
        .max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1)))
        .map(|(_, _, p)| p)
}

/// Whether point `i` lies within `h` of `plane` with a normal within the angle whose cosine
/// is `cos_tol`: a plane's inlier, and what "explained" means for the axis hypotheses.
fn is_inlier(input: &HypothesesInput<'_>, plane: &Plane, i: usize, h: f64, cos_tol: f64) -> bool {
    (plane.normal.dot(&input.positions[i]) - plane.offset).abs() <= h
        && input.normals[i].dot(&plane.normal).abs() >= cos_tol
}

/// The standard deviations of the points `idx` along the two in-plane principal directions
/// of `plane` (larger first).
fn in_plane_spread(positions: &[Vector3<f64>], idx: &[usize], plane: &Plane) -> (f64, f64) {
    if idx.is_empty() {
        return (0.0, 0.0);
    }
    let n = plane.normal;
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&helper).normalize();
    let v = n.cross(&u);
    let inv = 1.0 / idx.len() as f64;
    let (mut su, mut sv) = (0.0, 0.0);
    for &i in idx {
        su += u.dot(&positions[i]);
        sv += v.dot(&positions[i]);
    }
    let (mu, mv) = (su * inv, sv * inv);
    let (mut cuu, mut cuv, mut cvv) = (0.0, 0.0, 0.0);
    for &i in idx {
        let (a, b) = (u.dot(&positions[i]) - mu, v.dot(&positions[i]) - mv);
        cuu += a * a;
        cuv += a * b;
        cvv += b * b;
    }
    let (cuu, cuv, cvv) = (cuu * inv, cuv * inv, cvv * inv);
    let mean = 0.5 * (cuu + cvv);
    let dev = (0.25 * (cuu - cvv).powi(2) + cuv * cuv).sqrt();
    ((mean + dev).max(0.0).sqrt(), (mean - dev).max(0.0).sqrt())
}

/// The total-least-squares plane of the points `idx` (normal: the covariance's smallest
/// eigenvector, sign as [`crate::normals`] orients normals), or `None` for fewer than 3.
fn fit_plane(positions: &[Vector3<f64>], idx: &[usize]) -> Option<Plane> {
    if idx.len() < 3 {
        return None;
    }
    let inv = 1.0 / idx.len() as f64;
    let mean = idx.iter().fold(Vector3::zeros(), |s, &i| s + positions[i]) * inv;
    let mut cov = Matrix3::zeros();
    for &i in idx {
        let d = positions[i] - mean;
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov * inv);
    let k = (0..3).min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))?;
    let n = crate::normals::canonical_sign(eig.eigenvectors.column(k).into_owned().normalize());
    n.iter().all(|v| v.is_finite()).then(|| Plane {
        normal: n,
        offset: n.dot(&mean),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axes::DominantAxes;
    use rand::Rng;

    /// The world axes as the dominant directions, no extras.
    fn world_axes() -> DominantAxes {
        DominantAxes {
            directions: vec![Vector3::x(), Vector3::y(), Vector3::z()],
            support: vec![1; 3],
            pairwise_angles_deg: vec![(0, 1, 90.0), (0, 2, 90.0), (1, 2, 90.0)],
            num_manhattan: 3,
            warnings: Vec::new(),
        }
    }

    /// Points (with normals) on rectangles: `(normal, offset, u, v)` gives the plane
    /// `normal·X = offset` sampled over `origin + s·u + t·v`, s, t ∈ [0, 1].
    struct Cloud {
        positions: Vec<Vector3<f64>>,
        normals: Vec<Vector3<f64>>,
        confidence: Vec<f64>,
    }

    impl Cloud {
        fn new() -> Self {
            Cloud {
                positions: Vec::new(),
                normals: Vec::new(),
                confidence: Vec::new(),
            }
        }

        #[allow(clippy::too_many_arguments)]
        fn patch(
            &mut self,
            rng: &mut ChaCha8Rng,
            origin: Vector3<f64>,
            u: Vector3<f64>,
            v: Vector3<f64>,
            count: usize,
            noise: f64,
            normal_noise: f64,
        ) {
            let n = u.cross(&v).normalize();
            for _ in 0..count {
                let (s, t): (f64, f64) = (rng.random(), rng.random());
                let off = rng.random_range(-noise..=noise);
                self.positions.push(origin + u * s + v * t + n * off);
                let jitter = Vector3::new(
                    rng.random_range(-normal_noise..=normal_noise),
                    rng.random_range(-normal_noise..=normal_noise),
                    rng.random_range(-normal_noise..=normal_noise),
                );
                self.normals.push((n + jitter).normalize());
                self.confidence.push(1.0);
            }
        }

        fn outliers(&mut self, rng: &mut ChaCha8Rng, count: usize) {
            for _ in 0..count {
                let p = Vector3::new(
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-5.0..5.0),
                    rng.random_range(0.0..4.0),
                );
                let n = Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                self.positions.push(p);
                self.normals.push(n.normalize());
                self.confidence.push(1.0);
            }
        }

        fn input<'a>(&'a self, axes: &'a DominantAxes) -> HypothesesInput<'a> {
            HypothesesInput {
                positions: &self.positions,
                normals: &self.normals,
                confidence: &self.confidence,
                axes,
                scale: 0.01,
            }
        }
    }

    /// A box room 10 × 8 × 4 on the world axes: floor, two walls, and `roof` (a pitched
    /// plane of normal `roof_n` through `roof_p`) when given.
    fn house(rng: &mut ChaCha8Rng, roof: Option<(Vector3<f64>, Vector3<f64>)>) -> Cloud {
        let mut c = Cloud::new();
        let o = Vector3::new(-5.0, -4.0, 0.0);
        c.patch(
            rng,
            o,
            Vector3::x() * 10.0,
            Vector3::y() * 8.0,
            800,
            0.005,
            0.05,
        );
        c.patch(
            rng,
            o,
            Vector3::x() * 10.0,
            Vector3::z() * 4.0,
            800,
            0.005,
            0.05,
        );
        c.patch(
            rng,
            o,
            Vector3::y() * 8.0,
            Vector3::z() * 4.0,
            800,
            0.005,
            0.05,
        );
        if let Some((n, p)) = roof {
            // Two in-plane directions of the roof.
            let u = n.cross(&Vector3::x()).normalize();
            let v = n.cross(&u).normalize();
            c.patch(
                rng,
                p - u * 2.0 - v * 2.0,
                u * 4.0,
                v * 4.0,
                300,
                0.005,
                0.05,
            );
        }
        c.outliers(rng, 200);
        c
    }

    fn axis_planes(c: &Cloud, axes: &DominantAxes) -> Vec<PlaneHypothesis> {
        super::super::plane_hypotheses(&c.input(axes), &HypothesesConfig::default()).unwrap()
    }

    #[test]
    fn a_pitched_roof_off_the_axes_gets_its_plane() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        // 23° pitch, its slope turned 17° from the x axis: no dominant direction.
        let pitch = 23f64.to_radians();
        let turn = 17f64.to_radians();
        let n = Vector3::new(
            pitch.sin() * turn.cos(),
            pitch.sin() * turn.sin(),
            pitch.cos(),
        );
        let p = Vector3::new(0.0, 0.0, 5.0);
        let c = house(&mut rng, Some((n, p)));
        let axes = world_axes();
        let existing = axis_planes(&c, &axes);
        assert_eq!(existing.len(), 3, "{existing:#?}");
        let free = free_plane_hypotheses(&c.input(&axes), &existing, &HypothesesConfig::default())
            .unwrap();
        assert_eq!(free.len(), 1, "{free:#?}");
        let f = &free[0];
        let angle = f.plane.normal.dot(&n).abs().min(1.0).acos().to_degrees();
        assert!(angle < 0.5, "roof normal off by {angle}°");
        let c0 = f.plane.normal.dot(&n).signum();
        assert!((f.plane.offset - c0 * n.dot(&p)).abs() < 0.01, "{f:?}");
        assert!(f.support >= 280, "support {}", f.support);
        assert_eq!(f.axis, None);
        assert_eq!(f.id as usize, existing.len());
    }

    #[test]
    fn axis_planes_and_outliers_make_no_free_plane() {
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let c = house(&mut rng, None);
        let axes = world_axes();
        let existing = axis_planes(&c, &axes);
        let free = free_plane_hypotheses(&c.input(&axes), &existing, &HypothesesConfig::default())
            .unwrap();
        assert!(free.is_empty(), "{free:#?}");
    }

    #[test]
    fn points_along_an_edge_make_no_plane() {
        // Floor z = 0 and wall y = −4 of the house, plus 150 points in a band along their
        // edge, within the bandwidth of both, whose PCA normals bisect the two (as at real
        // edges): a "plane" at 45° through the edge holds them all, but every one lies on
        // the floor and the wall.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut c = house(&mut rng, None);
        let bisector = Vector3::new(0.0, 1.0, 1.0).normalize();
        for _ in 0..150 {
            let x = rng.random_range(-5.0..5.0);
            let t: f64 = rng.random_range(0.0..0.015);
            let e = rng.random_range(-0.002..0.002);
            c.positions.push(Vector3::new(x, -4.0 + t + e, 0.015 - t));
            c.normals.push(bisector);
            c.confidence.push(1.0);
        }
        let axes = world_axes();
        let existing = axis_planes(&c, &axes);
        let mut cfg = HypothesesConfig::default();
        let free = free_plane_hypotheses(&c.input(&axes), &existing, &cfg).unwrap();
        assert!(free.is_empty(), "{free:#?}");
        // Without the two tests the edge becomes a plane (and is too narrow to keep unless
        // the width test goes too).
        cfg.free.max_edge_fraction = 1.0;
        cfg.free.max_overlap_fraction = 1.0;
        cfg.free.min_spread_r = 0.0;
        let free = free_plane_hypotheses(&c.input(&axes), &existing, &cfg).unwrap();
        assert_eq!(free.len(), 1, "{free:#?}");
        assert!(free[0].plane.normal.dot(&bisector).abs() > 0.99);
    }

    #[test]
    fn a_plane_near_an_axis_takes_the_axis() {
        // A wall turned 0.6° from the x axis, 3 m in front of the house's: snapped to x.
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        let mut c = house(&mut rng, None);
        let a = 0.6f64.to_radians();
        let n = Vector3::new(a.cos(), a.sin(), 0.0);
        let u = Vector3::new(-a.sin(), a.cos(), 0.0);
        let start = c.positions.len();
        c.patch(
            &mut rng,
            n * 8.0 - u * 3.0,
            u * 6.0,
            Vector3::z() * 4.0,
            200,
            0.005,
            0.05,
        );
        // The x axis' mean-shift finds this wall too: leave its plane out of the existing ones.
        let axes = world_axes();
        let existing: Vec<_> = axis_planes(&c, &axes)
            .into_iter()
            .filter(|h| h.plane.offset.abs() < 7.0)
            .collect();
        assert!(existing.len() >= 3);
        let free = free_plane_hypotheses(&c.input(&axes), &existing, &HypothesesConfig::default())
            .unwrap();
        assert_eq!(free.len(), 1, "{free:#?}");
        assert_eq!(free[0].axis, Some(0));
        assert_eq!(free[0].plane.normal, Vector3::x());
        let mean = c.positions[start..].iter().map(|p| p.x).sum::<f64>() / 200.0;
        assert!((free[0].plane.offset - mean).abs() < 0.02, "{:?}", free[0]);
    }

    #[test]
    fn disabled_capped_and_bad_settings() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = Vector3::new(0.5, 0.0, 1.0).normalize();
        let c = house(&mut rng, Some((n, Vector3::new(0.0, 0.0, 5.0))));
        let axes = world_axes();
        let existing = axis_planes(&c, &axes);
        let mut cfg = HypothesesConfig::default();
        cfg.free.enabled = false;
        assert!(free_plane_hypotheses(&c.input(&axes), &existing, &cfg)
            .unwrap()
            .is_empty());
        cfg.free.enabled = true;
        cfg.free.max_planes = 0;
        assert!(free_plane_hypotheses(&c.input(&axes), &existing, &cfg)
            .unwrap()
            .is_empty());
        // A minimum angle to the axes above the roof's 26.6° drops it.
        cfg.free.max_planes = 16;
        cfg.free.min_angle_to_axes_deg = 30.0;
        assert!(free_plane_hypotheses(&c.input(&axes), &existing, &cfg)
            .unwrap()
            .is_empty());
        cfg.free.neighbours = 1;
        let err = cfg.validate().unwrap_err().to_string();
        assert!(err.contains("free: neighbours = 1"), "{err}");
        cfg.free.neighbours = 12;
        cfg.free.samples = 0;
        assert!(cfg.validate().is_err());
    }

    #[test]
    fn the_same_planes_whatever_the_thread_count() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let n = Vector3::new(0.2, -0.4, 1.0).normalize();
        let c = house(&mut rng, Some((n, Vector3::new(1.0, 0.0, 5.0))));
        let axes = world_axes();
        let existing = axis_planes(&c, &axes);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    free_plane_hypotheses(&c.input(&axes), &existing, &HypothesesConfig::default())
                        .unwrap()
                })
        };
        let one = run(1);
        assert!(!one.is_empty());
        assert_eq!(one, run(3));
    }

    #[test]
    fn total_least_squares_fit() {
        let n = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        let pts: Vec<Vector3<f64>> = (0..20)
            .map(|i| {
                let a = i as f64;
                let u = n.cross(&Vector3::x()).normalize();
                let v = n.cross(&u);
                u * a.sin() * 3.0 + v * (a * 0.7).cos() * 2.0 + n * 4.0
            })
            .collect();
        let idx: Vec<usize> = (0..pts.len()).collect();
        let p = fit_plane(&pts, &idx).unwrap();
        assert!((p.normal - n).norm() < 1e-9, "{p:?}");
        assert!((p.offset - 4.0).abs() < 1e-9);
        assert!(fit_plane(&pts, &idx[..2]).is_none());
    }
}
