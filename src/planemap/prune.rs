//! Label pruning: which global plane hypotheses a view's MRF offers as labels.
//!
//! α-expansion costs grow linearly with the number of labels, and a plane nobody in this
//! view supports can only win by accident. A plane h is kept when
//!
//! 1. it is in front of the camera somewhere in the image: depth `d_c / (n_c · r)` > 0 for
//!    some image ray r. `n_c · r` is affine in the image coordinates, so testing the four
//!    image corners decides it exactly; and
//! 2. it is supported: at least `min_support` sparse points whose track contains the view
//!    and which project into the image lie within γ of h, or at least
//!    `min_support_in_frustum` points projecting into the image (seen by the view or not;
//!    SfM tracks miss many observations) do.
//!
//! If `max_labels > 0` only the best-supported ones are kept (ties: lower index). If nothing
//! passes 2, every plane passing 1 is kept (capped the same way), so the label set is never
//! empty while any plane is in front of the camera. The result is sorted by global index.

use nalgebra::Point3;

use super::{Pinhole, PlanemapConfig, PlanemapError, ViewInputs};

/// Why each plane was kept or not, for reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelSupport {
    /// Per global plane: in front of the camera somewhere in the image.
    pub in_front: Vec<bool>,
    /// Per global plane: points seen by the view, projecting into it, within γ.
    pub seen_support: Vec<usize>,
    /// Per global plane: points projecting into the view (seen or not) within γ.
    pub frustum_support: Vec<usize>,
}

/// Support counts and the frustum test for every global plane (see the module doc).
pub fn label_support(
    inputs: &ViewInputs,
    config: &PlanemapConfig,
) -> Result<LabelSupport, PlanemapError> {
    config.validate()?;
    inputs.validate()?;
    let view = inputs.view();
    let pinhole = Pinhole::of(&view.camera);
    let (w, h) = (view.camera.width as f64, view.camera.height as f64);
    let corners = [
        pinhole.ray(0.0, 0.0),
        pinhole.ray(w, 0.0),
        pinhole.ray(0.0, h),
        pinhole.ray(w, h),
    ];
    let in_front = inputs
        .planes
        .iter()
        .map(|pl| {
            let pc = pl.in_camera(&view.cam_from_world);
            corners.iter().any(|r| pc.depth_along(r).is_some())
        })
        .collect();
    let margin = config.margin_factor * inputs.scale;
    let mut seen_support = vec![0usize; inputs.planes.len()];
    let mut frustum_support = vec![0usize; inputs.planes.len()];
    let cloud = inputs.cloud;
    for i in 0..cloud.len() {
        let x = &cloud.positions[i];
        let cam = view.cam_from_world * Point3::from(*x);
        let inside = pinhole
            .project(&cam.coords)
            .is_some_and(|xy| xy.x >= 0.0 && xy.y >= 0.0 && xy.x < w && xy.y < h);
        if !inside {
            continue;
        }
        let seen = cloud.tracks[i].contains(&(inputs.view_index as u32));
        for (k, pl) in inputs.planes.iter().enumerate() {
            if pl.signed_distance(x).abs() <= margin {
                frustum_support[k] += 1;
                if seen {
                    seen_support[k] += 1;
                }
            }
        }
    }
    Ok(LabelSupport {
        in_front,
        seen_support,
        frustum_support,
    })
}

/// The global plane indices offered as labels in the target view, sorted (see the module
/// doc). Errors with [`PlanemapError::NoLabels`] only when no plane is in front of the
/// camera.
pub fn prune_labels(
    inputs: &ViewInputs,
    config: &PlanemapConfig,
) -> Result<Vec<u32>, PlanemapError> {
    let s = label_support(inputs, config)?;
    let n = inputs.planes.len();
    let supported = |k: usize| {
        inputs.photo_planes.contains(&(k as u32))
            || s.seen_support[k] >= config.min_support
            || (config.min_support_in_frustum > 0
                && s.frustum_support[k] >= config.min_support_in_frustum)
    };
    let mut keep: Vec<usize> = (0..n).filter(|&k| s.in_front[k] && supported(k)).collect();
    if keep.is_empty() {
        keep = (0..n).filter(|&k| s.in_front[k]).collect();
    }
    if keep.is_empty() {
        return Err(PlanemapError::NoLabels(n, inputs.view_index));
    }
    if config.max_labels > 0 && keep.len() > config.max_labels {
        // Best supported first; ties by index (sort is stable).
        keep.sort_by(|&a, &b| {
            (s.seen_support[b], s.frustum_support[b])
                .cmp(&(s.seen_support[a], s.frustum_support[a]))
        });
        keep.truncate(config.max_labels);
        keep.sort_unstable();
    }
    Ok(keep.into_iter().map(|k| k as u32).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planemap::testutil::corner_scene;
    use crate::planemap::ViewInputs;

    #[test]
    fn keeps_supported_planes_and_drops_the_rest() {
        let scene = corner_scene();
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: 0,
            views: &scene.views,
            image: &scene.images[0],
            cloud: &scene.cloud,
            planes: &scene.planes,
            dominant_directions: &scene.directions,
            scale: scene.scale,
        };
        let config = PlanemapConfig::default();
        let s = label_support(&inputs, &config).unwrap();
        // The true planes hold ~150 points each; distractors only the points near the
        // lines where they cut the faces (γ = 0.2 → a 0.4-wide band of a 4-wide face).
        for k in 0..3 {
            assert!(s.seen_support[k] > 60, "plane {k}: {:?}", s.seen_support);
        }
        assert!(!s.in_front[7], "x = 30 is behind the view");
        assert_eq!(s.seen_support[6], 0, "x = −1 holds no point");
        let kept = prune_labels(&inputs, &config).unwrap();
        assert!(kept.starts_with(&[0, 1, 2]), "{kept:?}");
        assert!(!kept.contains(&6) && !kept.contains(&7), "{kept:?}");

        // Cap: the three true planes are the best supported.
        let capped = PlanemapConfig {
            max_labels: 3,
            ..Default::default()
        };
        assert_eq!(prune_labels(&inputs, &capped).unwrap(), vec![0, 1, 2]);

        // Fallback: nothing supported → every plane in front of the camera.
        let strict = PlanemapConfig {
            min_support: 100_000,
            min_support_in_frustum: 0,
            ..Default::default()
        };
        assert_eq!(
            prune_labels(&inputs, &strict).unwrap(),
            vec![0, 1, 2, 3, 4, 5, 6]
        );
        // No plane in front at all → an error, not an empty set.
        let behind = [scene.planes[7]];
        let only_behind = ViewInputs {
            photo_planes: &[],
            planes: &behind,
            ..inputs
        };
        assert!(matches!(
            prune_labels(&only_behind, &config),
            Err(PlanemapError::NoLabels(1, 0))
        ));
    }
}
