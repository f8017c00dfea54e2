//! Normals for sparse points that have none (COLMAP), by local PCA.
//!
//! Manhattan-world stereo (Furukawa et al. 2009) starts from *oriented* points (PMVS patches).
//! A COLMAP cloud has positions only, so each point gets the normal of the plane fitted to its
//! `k` nearest neighbours (within a radius: the larger of a multiple of the sampling scale `R`
//! and a multiple of the cloud's median distance to its k-th neighbour): the eigenvector
//! of the neighbourhood covariance with the smallest eigenvalue, oriented towards the cameras
//! that see the point. Its confidence is the cloud's confidence times the neighbourhood's
//! planarity `1 − λmin/λmid`. PMVS normals are used as given.

use std::num::NonZeroUsize;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::scale::{sampling_scale, ScaleError};
use crate::scene::{Scene, SceneError};

/// Extra neighbours fetched beyond `k` so distance ties are broken by point index.
const KNN_TIE_SLACK: usize = 4;

/// Errors of normal estimation.
#[derive(Debug, Error)]
pub enum NormalsError {
    /// The configuration is invalid (message says which field and why).
    #[error("invalid normals config: {0}")]
    Config(String),
    /// The cloud is inconsistent.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The sampling scale could not be computed.
    #[error(transparent)]
    Scale(#[from] ScaleError),
    /// A given (PMVS) normal is zero or not finite.
    #[error("point {0}: given normal is zero or not finite")]
    BadNormal(usize),
    /// The k-d tree could not be built.
    #[error("cannot build the neighbour index: {0}")]
    Index(String),
}

/// Configuration of [`estimate_normals`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NormalsConfig {
    /// Nearest neighbours in each point's PCA plane fit, the point itself included; a count
    /// ≥ 3. A start value, not tuned (docs/notes/axes.md).
    pub k: usize,
    /// Neighbours farther than this many sampling scales `R` are left out of the fit
    /// (unless `density_radius` allows more), > 0. A start value, not tuned.
    pub max_radius_r: f64,
    /// Floor of the neighbour radius, as a multiple of the cloud's median distance from a
    /// point to its k-th nearest neighbour; ≥ 0, 0 = off. R is a pixel footprint and
    /// shrinks with the image resolution while SfM point spacing does not: at high
    /// resolutions `max_radius_r · R` alone holds too few neighbours for any normal. At 1
    /// it leaves the scenes at their own sizes alone, where `max_radius_r · R` is the
    /// larger radius (docs/notes/axes.md).
    pub density_radius: f64,
    /// Fewer neighbours than this (within the radius, the point included) make the normal
    /// unreliable: the point gets the direction towards its cameras and confidence 0. A
    /// count in `3..=k`; a start value, not tuned.
    pub min_neighbors: usize,
    /// Use the cloud's own normals when it has them (PMVS) instead of re-estimating them
    /// by PCA: PMVS's normals are the better ones (docs/notes/axes.md).
    pub use_given_normals: bool,
}

impl Default for NormalsConfig {
    fn default() -> Self {
        NormalsConfig {
            k: 16,
            max_radius_r: 30.0,
            density_radius: 1.0,
            min_neighbors: 6,
            use_given_normals: true,
        }
    }
}

impl NormalsConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), NormalsError> {
        if self.k < 3 {
            return Err(NormalsError::Config(format!("k = {} must be ≥ 3", self.k)));
        }
        if !(self.max_radius_r > 0.0 && self.max_radius_r.is_finite()) {
            return Err(NormalsError::Config(format!(
                "max_radius_r = {} must be positive and finite",
                self.max_radius_r
            )));
        }
        if !(self.density_radius >= 0.0 && self.density_radius.is_finite()) {
            return Err(NormalsError::Config(format!(
                "density_radius = {} must be non-negative and finite",
                self.density_radius
            )));
        }
        if self.min_neighbors < 3 || self.min_neighbors > self.k {
            return Err(NormalsError::Config(format!(
                "min_neighbors = {} must be in 3..=k ({})",
                self.min_neighbors, self.k
            )));
        }
        Ok(())
    }
}

/// Unit normals and per-point confidence, parallel to `Scene::cloud.positions`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OrientedCloud {
    /// Unit normal of each point (world frame), oriented towards the cameras that see it.
    /// Never NaN: unreliable points carry their viewing direction and confidence 0.
    pub normals: Vec<Vector3<f64>>,
    /// Confidence in `[0, 1]`: cloud confidence × planarity (`1 − λmin/λmid`) for estimated
    /// normals, the cloud confidence for given ones, 0 where no normal could be estimated.
    pub confidence: Vec<f64>,
    /// Whether the normals were estimated here (true) or taken from the cloud (false).
    pub estimated: bool,
}

/// Sum of unit directions from `p` to the centres of the views in `track` (zero if none).
fn view_direction(p: &Vector3<f64>, track: &[u32], centers: &[Vector3<f64>]) -> Vector3<f64> {
    let mut s = Vector3::zeros();
    for &v in track {
        if let Some(c) = centers.get(v as usize) {
            let d = c - p;
            let len = d.norm();
            if len > 0.0 {
                s += d / len;
            }
        }
    }
    s
}

/// A fixed sign for an unorientable unit vector: the hemisphere z > 0 (then y, then x).
pub(crate) fn canonical_sign(n: Vector3<f64>) -> Vector3<f64> {
    let flip = if n.z != 0.0 {
        n.z < 0.0
    } else if n.y != 0.0 {
        n.y < 0.0
    } else {
        n.x < 0.0
    };
    if flip {
        -n
    } else {
        n
    }
}

/// The cloud's own normals (PMVS), unit-normalised, when it has them and
/// `use_given_normals` allows; `None` otherwise.
fn given_normals(
    scene: &Scene,
    config: &NormalsConfig,
) -> Result<Option<OrientedCloud>, NormalsError> {
    if config.use_given_normals {
        if let Some(given) = &scene.cloud.normals {
            let mut normals = Vec::with_capacity(given.len());
            for (i, n) in given.iter().enumerate() {
                let len = n.norm();
                if !(len > 0.0 && len.is_finite()) {
                    return Err(NormalsError::BadNormal(i));
                }
                normals.push(n / len);
            }
            return Ok(Some(OrientedCloud {
                normals,
                confidence: scene
                    .cloud
                    .confidence
                    .iter()
                    .map(|c| c.clamp(0.0, 1.0))
                    .collect(),
                estimated: false,
            }));
        }
    }
    Ok(None)
}

/// Normals for the scene's cloud: given normals if present (and allowed), else PCA normals
/// with the sampling scale computed by [`sampling_scale`].
pub fn estimate_normals(
    scene: &Scene,
    config: &NormalsConfig,
) -> Result<OrientedCloud, NormalsError> {
    config.validate()?;
    scene.cloud.validate(scene.views.len())?;
    if let Some(given) = given_normals(scene, config)? {
        return Ok(given);
    }
    let r = sampling_scale(scene)?;
    estimate_normals_with_scale(scene, r, config)
}

/// Median over the points of the distance to the k-th nearest neighbour (the point itself
/// counts as the first), or 0 for fewer than `k` points. Independent of the thread count.
fn median_kth_distance(tree: &ImmutableKdTree<f64, 3>, coords: &[[f64; 3]], k: usize) -> f64 {
    let Some(kk) = NonZeroUsize::new(k) else {
        return 0.0;
    };
    if coords.len() < k {
        return 0.0;
    }
    let mut d: Vec<f64> = coords
        .par_iter()
        .map(|c| {
            tree.query(c)
                .nearest_n::<SquaredEuclidean<f64>>(kk)
                .execute()
                .into_iter()
                .map(|q| q.distance)
                .fold(0.0f64, f64::max)
                .sqrt()
        })
        .collect();
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Given normals as [`estimate_normals`] takes them, else PCA normals for every point with a
/// known sampling scale `r` (world units). Deterministic
/// and independent of the thread count: each point's result depends only on its
/// neighbourhood, sorted by (distance, index).
pub fn estimate_normals_with_scale(
    scene: &Scene,
    r: f64,
    config: &NormalsConfig,
) -> Result<OrientedCloud, NormalsError> {
    config.validate()?;
    scene.cloud.validate(scene.views.len())?;
    if let Some(given) = given_normals(scene, config)? {
        return Ok(given);
    }
    if !(r > 0.0 && r.is_finite()) {
        return Err(NormalsError::Scale(ScaleError::Degenerate(r)));
    }
    let cloud = &scene.cloud;
    let n = cloud.len();
    if n == 0 {
        return Ok(OrientedCloud {
            estimated: true,
            ..Default::default()
        });
    }
    let centers: Vec<Vector3<f64>> = scene.views.iter().map(|v| v.center()).collect();
    let coords: Vec<[f64; 3]> = cloud.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&coords).map_err(|e| NormalsError::Index(e.to_string()))?;
    // A few spare neighbours so that ties at the k-th distance are broken by point index,
    // not by the tree's traversal order.
    let k_query = NonZeroUsize::new(config.k + KNN_TIE_SLACK)
        .ok_or_else(|| NormalsError::Config("k = 0".into()))?;
    let radius = (config.max_radius_r * r)
        .max(config.density_radius * median_kth_distance(&tree, &coords, config.k));

    let results: Vec<(Vector3<f64>, f64)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let p = cloud.positions[i];
            let mut nbrs: Vec<(f64, u32)> = tree
                .query(&coords[i])
                .nearest_n::<SquaredEuclidean<f64>>(k_query)
                .within(radius * radius)
                .execute()
                .into_iter()
                .map(|q| (q.distance, q.item))
                .collect();
            nbrs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            nbrs.truncate(config.k);
            let towards = view_direction(&p, &cloud.tracks[i], &centers);
            let fallback = || {
                let len = towards.norm();
                let n = if len > 0.0 {
                    towards / len
                } else {
                    Vector3::z()
                };
                (n, 0.0)
            };
            if nbrs.len() < config.min_neighbors {
                return fallback();
            }
            let inv = 1.0 / nbrs.len() as f64;
            let mean = nbrs.iter().fold(Vector3::zeros(), |s, &(_, j)| {
                s + cloud.positions[j as usize]
            }) * inv;
            let mut cov = Matrix3::zeros();
            for &(_, j) in &nbrs {
                let d = cloud.positions[j as usize] - mean;
                cov += d * d.transpose();
            }
            cov *= inv;
            let eig = SymmetricEigen::new(cov);
            let mut order = [0usize, 1, 2];
            order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
            let (l_min, l_mid) = (
                eig.eigenvalues[order[0]].max(0.0),
                eig.eigenvalues[order[1]],
            );
            if !(l_mid > 0.0 && l_mid.is_finite()) {
                // Coincident or collinear neighbours: no plane.
                return fallback();
            }
            let mut normal: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
            let len = normal.norm();
            if !(len > 0.0 && len.is_finite()) {
                return fallback();
            }
            normal /= len;
            let dot = normal.dot(&towards);
            normal = if dot < 0.0 {
                -normal
            } else if dot == 0.0 {
                canonical_sign(normal)
            } else {
                normal
            };
            let planarity = (1.0 - l_min / l_mid).clamp(0.0, 1.0);
            let conf = (cloud.confidence[i].clamp(0.0, 1.0) * planarity).clamp(0.0, 1.0);
            (normal, conf)
        })
        .collect();
    let (normals, confidence) = results.into_iter().unzip();
    Ok(OrientedCloud {
        normals,
        confidence,
        estimated: true,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};
    use crate::scene::{SparseCloud, View};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A view at `eye` looking at the origin, f = 500 px.
    pub(crate) fn test_view(id: u32, eye: Vector3<f64>) -> View {
        View {
            id,
            name: format!("v{id}"),
            camera: Camera::pinhole(640, 480, 500.0, 500.0, 320.0, 240.0),
            cam_from_world: look_at(&eye, &Vector3::zeros(), &Vector3::new(0.3, 0.2, 1.0)),
            image_path: None,
        }
    }

    /// A scene from positions: each point is seen by every view that has it in front.
    pub(crate) fn scene_from(views: Vec<View>, positions: Vec<Vector3<f64>>) -> Scene {
        let n = positions.len();
        let tracks = positions
            .iter()
            .map(|p| {
                (0..views.len() as u32)
                    .filter(|&v| views[v as usize].project(p).is_some())
                    .collect()
            })
            .collect();
        Scene {
            views,
            cloud: SparseCloud {
                positions,
                colors: vec![[0; 3]; n],
                normals: None,
                tracks,
                errors: vec![0.0; n],
                confidence: vec![1.0; n],
            },
        }
    }

    #[test]
    fn pca_normals_on_noisy_plane_point_to_cameras() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Plane through (0.2, 0.1, 0.3) with a tilted normal; cameras on its positive side.
        let nrm = Vector3::new(0.3, -0.5, 0.8).normalize();
        let u = nrm.cross(&Vector3::x()).normalize();
        let w = nrm.cross(&u);
        let o = Vector3::new(0.2, 0.1, 0.3);
        let pts: Vec<Vector3<f64>> = (0..2000)
            .map(|_| {
                let a = rng.random_range(-1.0..1.0);
                let b = rng.random_range(-1.0..1.0);
                let e = rng.random_range(-0.005..0.005);
                o + u * a + w * b + nrm * e
            })
            .collect();
        let views = vec![
            test_view(0, o + nrm * 6.0 + u * 2.0),
            test_view(1, o + nrm * 5.0 - w * 2.0),
        ];
        let scene = scene_from(views, pts);
        let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
        assert!(oc.estimated);
        let mut worst: f64 = 0.0;
        for (n, c) in oc.normals.iter().zip(&oc.confidence) {
            let ang = n.dot(&nrm).clamp(-1.0, 1.0).acos().to_degrees();
            worst = worst.max(ang);
            assert!(*c > 0.8, "planar patch confidence {c}");
        }
        assert!(worst < 5.0, "worst normal error {worst}°");
        // Same with the cameras on the other side: normals flip.
        let views = vec![test_view(0, o - nrm * 6.0), test_view(1, o - nrm * 5.0 + u)];
        let scene2 = scene_from(views, scene.cloud.positions.clone());
        let oc2 = estimate_normals(&scene2, &NormalsConfig::default()).unwrap();
        assert!(oc2.normals.iter().all(|n| n.dot(&nrm) < -0.99));
    }

    #[test]
    fn isolated_and_collinear_points_get_zero_confidence_not_nan() {
        let mut pts: Vec<Vector3<f64>> = (0..20)
            .map(|i| Vector3::new(i as f64 * 0.01, 0.0, 0.0))
            .collect();
        pts.push(Vector3::new(100.0, 100.0, 100.0));
        let views = vec![test_view(0, Vector3::new(0.0, 0.0, 8.0))];
        let scene = scene_from(views, pts);
        let oc = estimate_normals_with_scale(&scene, 0.01, &NormalsConfig::default()).unwrap();
        for (n, c) in oc.normals.iter().zip(&oc.confidence) {
            assert!(n.iter().all(|v| v.is_finite()));
            assert!((n.norm() - 1.0).abs() < 1e-9);
            assert_eq!(*c, 0.0);
        }
    }

    #[test]
    fn radius_follows_point_spacing_when_r_is_a_tiny_pixel_footprint() {
        // A plane z = 0 sampled every 0.2 m (SfM-like spacing) and R = 1 mm (a high-resolution
        // footprint): 30 R holds no neighbour, the density radius holds enough.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let pts: Vec<Vector3<f64>> = (0..400)
            .map(|i| {
                let (x, y) = ((i % 20) as f64 * 0.2 - 2.0, (i / 20) as f64 * 0.2 - 2.0);
                Vector3::new(x, y, rng.random_range(-0.002..0.002))
            })
            .collect();
        let scene = scene_from(vec![test_view(0, Vector3::new(0.3, 0.2, 8.0))], pts);
        let only_r = NormalsConfig {
            density_radius: 0.0,
            ..Default::default()
        };
        let oc = estimate_normals_with_scale(&scene, 0.001, &only_r).unwrap();
        assert!(oc.confidence.iter().all(|&c| c == 0.0));
        let oc = estimate_normals_with_scale(&scene, 0.001, &NormalsConfig::default()).unwrap();
        let good = oc
            .normals
            .iter()
            .zip(&oc.confidence)
            .filter(|(n, &c)| c > 0.5 && n.z > 0.995)
            .count();
        assert!(good >= 390, "{good} of 400 points got the plane's normal");
    }

    #[test]
    fn given_normals_pass_through_and_bad_ones_error() {
        let views = vec![test_view(0, Vector3::new(0.0, 0.0, 8.0))];
        let mut scene = scene_from(views, vec![Vector3::zeros(), Vector3::x()]);
        scene.cloud.normals = Some(vec![
            Vector3::new(0.0, 0.0, 2.0),
            Vector3::new(0.0, 3.0, 0.0),
        ]);
        scene.cloud.confidence = vec![0.9, 0.4];
        let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
        assert!(!oc.estimated);
        assert_eq!(oc.normals, vec![Vector3::z(), Vector3::y()]);
        assert_eq!(oc.confidence, vec![0.9, 0.4]);
        // The pipeline's entry point (scale known) honours them too; switched off, PCA runs.
        let oc = estimate_normals_with_scale(&scene, 0.1, &NormalsConfig::default()).unwrap();
        assert!(!oc.estimated);
        assert_eq!(oc.normals, vec![Vector3::z(), Vector3::y()]);
        let off = NormalsConfig {
            use_given_normals: false,
            ..Default::default()
        };
        assert!(
            estimate_normals_with_scale(&scene, 0.1, &off)
                .unwrap()
                .estimated
        );
        scene.cloud.normals = Some(vec![Vector3::zeros(), Vector3::y()]);
        assert!(matches!(
            estimate_normals(&scene, &NormalsConfig::default()),
            Err(NormalsError::BadNormal(0))
        ));
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let pts: Vec<Vector3<f64>> = (0..3000)
            .map(|_| Vector3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.05))
            .collect();
        let scene = scene_from(vec![test_view(0, Vector3::new(0.5, 0.5, 6.0))], pts);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| estimate_normals(&scene, &NormalsConfig::default()).unwrap())
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn config_validation() {
        let c = NormalsConfig {
            k: 2,
            ..Default::default()
        };
        assert!(c.validate().is_err());
        let c = NormalsConfig {
            max_radius_r: f64::NAN,
            ..Default::default()
        };
        assert!(c.validate().is_err());
        let c = NormalsConfig {
            density_radius: -1.0,
            ..Default::default()
        };
        assert!(c.validate().is_err());
        let c: NormalsConfig = toml::from_str("k = 24").unwrap();
        assert_eq!(c.k, 24);
        assert_eq!(c.min_neighbors, NormalsConfig::default().min_neighbors);
    }
}
