//! The scene sampling scale `R` and the robust scene extent.
//!
//! Manhattan-world stereo (Furukawa et al. 2009) measures every 3D tolerance in units of `R`,
//! "the scene's sampling scale": mean-shift bandwidths (R or 2R), the data-term margin
//! (γ ≈ 10R), the smoothness normalisation. We define it from the data as the **median, over
//! all observations (point P, view j in P's track), of the 3D size of one pixel at P's depth**
//! in view j: `depth_j(P) / f_j` with `f_j = sqrt(fx·fy)` in pixels. Units: world units.

use nalgebra::Vector3;
use thiserror::Error;

use crate::scene::Scene;

/// Errors of the scale computation.
#[derive(Debug, Error, PartialEq)]
pub enum ScaleError {
    /// The cloud has no points.
    #[error("the sparse cloud has no points: cannot define the sampling scale")]
    NoPoints,
    /// No point is observed (with positive depth) by any view.
    #[error("no sparse point has a track with a view seeing it in front of the camera")]
    NoTracks,
    /// A point track names a view that does not exist.
    #[error("point {point} is seen by view index {view}, but there are {num_views} views")]
    BadTrack {
        /// Point index.
        point: usize,
        /// The bad view index.
        view: u32,
        /// Number of views.
        num_views: usize,
    },
    /// The resulting scale is not a positive finite number.
    #[error("sampling scale is {0}, expected a positive finite number")]
    Degenerate(f64),
}

/// Fraction of points ignored at each end of every axis by [`robust_extent`].
pub const ROBUST_EXTENT_QUANTILE: f64 = 0.02;

/// The scene sampling scale `R` (world units): the median of `depth / sqrt(fx·fy)` over all
/// observations of all sparse points, i.e. the typical 3D footprint of one pixel on the
/// scene. Observations behind the camera are skipped. The median of an even count is the
/// lower middle value (deterministic, an actual observation).
pub fn sampling_scale(scene: &Scene) -> Result<f64, ScaleError> {
    let cloud = &scene.cloud;
    if cloud.positions.is_empty() {
        return Err(ScaleError::NoPoints);
    }
    let centers: Vec<Vector3<f64>> = scene.views.iter().map(|v| v.center()).collect();
    let mut sizes = Vec::new();
    for (i, p) in cloud.positions.iter().enumerate() {
        let Some(track) = cloud.tracks.get(i) else {
            continue;
        };
        for &v in track {
            let view = scene.views.get(v as usize).ok_or(ScaleError::BadTrack {
                point: i,
                view: v,
                num_views: scene.views.len(),
            })?;
            let rot = view.cam_from_world.rotation;
            // Camera-frame z of P: the third row of R applied to (P − C).
            let depth = (rot * (p - centers[v as usize])).z;
            let f = (view.camera.fx() * view.camera.fy()).sqrt();
            if depth > 0.0 && f > 0.0 && depth.is_finite() {
                sizes.push(depth / f);
            }
        }
    }
    if sizes.is_empty() {
        return Err(ScaleError::NoTracks);
    }
    let mid = (sizes.len() - 1) / 2;
    let (_, &mut r, _) = sizes.select_nth_unstable_by(mid, f64::total_cmp);
    if r > 0.0 && r.is_finite() {
        Ok(r)
    } else {
        Err(ScaleError::Degenerate(r))
    }
}

/// A robust axis-aligned bounding box of the sparse points (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneExtent {
    /// Lower corner: per axis, the [`ROBUST_EXTENT_QUANTILE`] quantile.
    pub lo: Vector3<f64>,
    /// Upper corner: per axis, the `1 − ROBUST_EXTENT_QUANTILE` quantile.
    pub hi: Vector3<f64>,
}

impl SceneExtent {
    /// Length of the box diagonal (world units): the robust size of the scene.
    pub fn diagonal(&self) -> f64 {
        (self.hi - self.lo).norm()
    }
}

/// The robust extent of a point set: per-axis quantiles that ignore the outer
/// [`ROBUST_EXTENT_QUANTILE`] of the points on each side, so stray outliers do not inflate
/// the scene size.
pub fn robust_extent(positions: &[Vector3<f64>]) -> Result<SceneExtent, ScaleError> {
    if positions.is_empty() {
        return Err(ScaleError::NoPoints);
    }
    let n = positions.len();
    let lo_k = ((n - 1) as f64 * ROBUST_EXTENT_QUANTILE).floor() as usize;
    let hi_k = ((n - 1) as f64 * (1.0 - ROBUST_EXTENT_QUANTILE)).ceil() as usize;
    let mut lo = Vector3::zeros();
    let mut hi = Vector3::zeros();
    let mut coord = vec![0.0; n];
    for axis in 0..3 {
        for (c, p) in coord.iter_mut().zip(positions) {
            *c = p[axis];
        }
        coord.sort_unstable_by(f64::total_cmp);
        lo[axis] = coord[lo_k];
        hi[axis] = coord[hi_k.min(n - 1)];
    }
    Ok(SceneExtent { lo, hi })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};
    use crate::scene::{SparseCloud, View};

    fn view(eye: Vector3<f64>, f: f64) -> View {
        View {
            id: 0,
            name: "v".into(),
            camera: Camera::pinhole(640, 480, f, f, 320.0, 240.0),
            cam_from_world: look_at(&eye, &Vector3::zeros(), &Vector3::z()),
            image_path: None,
        }
    }

    #[test]
    fn scale_is_median_pixel_footprint() {
        // Camera 10 units away, f = 500 px: one pixel is 0.02 units at the origin.
        let views = vec![
            view(Vector3::new(10.0, 0.0, 0.0), 500.0),
            view(Vector3::new(0.0, 20.0, 0.0), 500.0),
        ];
        let positions = vec![Vector3::zeros(); 3];
        let cloud = SparseCloud {
            colors: vec![[0; 3]; 3],
            normals: None,
            tracks: vec![vec![0], vec![0, 1], vec![0]],
            errors: vec![0.0; 3],
            confidence: vec![1.0; 3],
            positions,
        };
        let scene = Scene { views, cloud };
        let r = sampling_scale(&scene).unwrap();
        // Observations: 0.02, 0.02, 0.04, 0.02 → median 0.02.
        assert!((r - 0.02).abs() < 1e-12, "{r}");
    }

    #[test]
    fn scale_errors_on_empty_and_trackless() {
        let scene = Scene::default();
        assert_eq!(sampling_scale(&scene), Err(ScaleError::NoPoints));
        let mut scene = Scene {
            views: vec![view(Vector3::new(10.0, 0.0, 0.0), 500.0)],
            cloud: SparseCloud {
                positions: vec![Vector3::zeros()],
                colors: vec![[0; 3]],
                normals: None,
                tracks: vec![vec![]],
                errors: vec![0.0],
                confidence: vec![1.0],
            },
        };
        assert_eq!(sampling_scale(&scene), Err(ScaleError::NoTracks));
        scene.cloud.tracks = vec![vec![3]];
        assert!(matches!(
            sampling_scale(&scene),
            Err(ScaleError::BadTrack { view: 3, .. })
        ));
    }

    #[test]
    fn extent_ignores_outliers() {
        let mut pts: Vec<Vector3<f64>> = (0..1000)
            .map(|i| Vector3::new((i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64))
            .collect();
        pts[0] = Vector3::new(1e6, -1e6, 1e6);
        let e = robust_extent(&pts).unwrap();
        assert!(e.hi.x <= 9.0 && e.lo.y >= 0.0 && e.hi.z <= 9.0, "{e:?}");
        assert!(e.diagonal() > 10.0 && e.diagonal() < 16.0);
        assert_eq!(robust_extent(&[]), Err(ScaleError::NoPoints));
    }
}
