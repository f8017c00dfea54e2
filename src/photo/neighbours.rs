//! Which views a reference view is matched against: views that share sparse points with it,
//! at a useful baseline angle.

use nalgebra::Vector3;

use super::PhotoError;
use crate::scene::{Scene, View};

/// Triangulation angle (radians) below which a pair of rays gets reduced weight in
/// [`select_neighbours`]: Goesele et al. (ICCV 2007) use 10°.
pub const NEIGHBOUR_MIN_ANGLE: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// Triangulation angle (radians) above which matching degrades (foreshortening,
/// occlusion) and a pair's weight falls off.
pub const NEIGHBOUR_MAX_ANGLE: f64 = 45.0 * std::f64::consts::PI / 180.0;

/// Weight of a triangulation angle: `(θ/θ_min)²` below `θ_min`, 1 up to `θ_max`, then a
/// Gaussian fall-off (σ = 10°).
fn angle_weight(theta: f64) -> f64 {
    if theta < NEIGHBOUR_MIN_ANGLE {
        (theta / NEIGHBOUR_MIN_ANGLE).powi(2)
    } else if theta <= NEIGHBOUR_MAX_ANGLE {
        1.0
    } else {
        let s = 10.0f64.to_radians();
        (-(theta - NEIGHBOUR_MAX_ANGLE).powi(2) / (2.0 * s * s)).exp()
    }
}

/// The `k` best neighbours of view `view_index` for matching (indices into `scene.views`),
/// best first. A candidate scores `Σ w(θ)` over the sparse points both views see, `θ` the
/// triangulation angle at the point (Goesele et al. 2007's global view selection without
/// the scale term): many shared points seen at a useful angle. Views sharing no point are
/// left out, unless the cloud has no tracks at all, in which case the angle between optical
/// axes stands in (weighted the same way). Ties go to the lower index.
pub fn select_neighbours(
    scene: &Scene,
    view_index: usize,
    k: usize,
) -> Result<Vec<usize>, PhotoError> {
    let count = scene.views.len();
    if view_index >= count {
        return Err(PhotoError::ViewIndex {
            index: view_index,
            count,
        });
    }
    let centres: Vec<Vector3<f64>> = scene.views.iter().map(|v| v.center()).collect();
    let mut score = vec![0.0f64; count];
    let mut any_track = false;
    let me = view_index as u32;
    for (point, track) in scene.cloud.positions.iter().zip(&scene.cloud.tracks) {
        if !track.contains(&me) {
            continue;
        }
        any_track = true;
        let ray_ref = centres[view_index] - point;
        for &j in track {
            let j = j as usize;
            if j == view_index || j >= count {
                continue;
            }
            let ray_j = centres[j] - point;
            score[j] += angle_weight(ray_ref.angle(&ray_j));
        }
    }
    if !any_track {
        let axis = |v: &View| v.cam_from_world.rotation.inverse() * Vector3::z();
        let ref_axis = axis(&scene.views[view_index]);
        for (j, v) in scene.views.iter().enumerate() {
            if j != view_index {
                // Optical axes nearly parallel but offset still see the same scene, so a
                // floor keeps them ranked behind useful angles rather than excluded.
                score[j] = angle_weight(ref_axis.angle(&axis(v))).max(1e-3);
            }
        }
    }
    let mut order: Vec<usize> = (0..count)
        .filter(|&j| j != view_index && score[j] > 0.0)
        .collect();
    order.sort_by(|&a, &b| score[b].total_cmp(&score[a]).then(a.cmp(&b)));
    order.truncate(k);
    Ok(order)
}
