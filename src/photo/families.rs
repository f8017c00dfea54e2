//! Plane families to sweep: fronto-parallel planes spaced in inverse depth, and parallel
//! planes along a direction spaced in offset (Gallup et al. CVPR 2007 sweep along the
//! scene's dominant axes).

use nalgebra::{Vector2, Vector3};

use super::PhotoError;
use crate::geometry::Plane;
use crate::scene::View;

/// The depths of a fronto-parallel sweep: `n` depths from `near` to `far` (scene units)
/// spaced uniformly in inverse depth, so consecutive planes are about equally far apart in
/// disparity (pixels) in every neighbour. `n = 1` gives the inverse-depth midpoint.
pub fn fronto_parallel_depths(near: f64, far: f64, n: usize) -> Result<Vec<f64>, PhotoError> {
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) || n == 0 {
        return Err(PhotoError::InvalidInput(format!(
            "fronto-parallel sweep needs 0 < near < far and n ≥ 1, got near {near}, far {far}, n {n}"
        )));
    }
    let (a, b) = (1.0 / near, 1.0 / far);
    if n == 1 {
        return Ok(vec![2.0 / (a + b)]);
    }
    Ok((0..n)
        .map(|i| 1.0 / (a + (b - a) * i as f64 / (n - 1) as f64))
        .collect())
}

/// Fronto-parallel planes of `view` (normal = its optical axis, in world coordinates) at
/// the depths of [`fronto_parallel_depths`].
pub fn fronto_parallel_planes(
    view: &View,
    near: f64,
    far: f64,
    n: usize,
) -> Result<Vec<Plane>, PhotoError> {
    let axis = view.cam_from_world.rotation.inverse() * Vector3::z();
    // Camera z of X is axis·X + t_z, and axis·C = −t_z.
    let axis_dot_centre = axis.dot(&view.center());
    Ok(fronto_parallel_depths(near, far, n)?
        .into_iter()
        .map(|z| Plane {
            normal: axis,
            offset: axis_dot_centre + z,
        })
        .collect())
}

/// Planes `u·X = d` for every (unit) direction `u` and every offset `d` (scene units along
/// `u`), direction-major: planes of the dominant axes, or any given normals and offsets.
pub fn axis_planes(directions: &[Vector3<f64>], offsets: &[f64]) -> Result<Vec<Plane>, PhotoError> {
    let mut planes = Vec::with_capacity(directions.len() * offsets.len());
    for dir in directions {
        let len = dir.norm();
        if !(len.is_finite() && len > 1e-12) {
            return Err(PhotoError::InvalidInput(format!(
                "plane direction {dir:?} is not a usable normal"
            )));
        }
        for &d in offsets {
            if !d.is_finite() {
                return Err(PhotoError::InvalidInput(format!(
                    "plane offset {d} is not finite"
                )));
            }
            planes.push(Plane {
                normal: dir / len,
                offset: d,
            });
        }
    }
    Ok(planes)
}

/// Sweeps along each of `directions` (e.g. the three Manhattan axes, Gallup et al. 2007):
/// `n` planes per direction, offsets uniform over the range that the view's frustum between
/// depths `near` and `far` spans along that direction. Direction-major order, so the planes
/// of one sweep are consecutive.
pub fn axis_sweep_planes(
    view: &View,
    directions: &[Vector3<f64>],
    near: f64,
    far: f64,
    n: usize,
) -> Result<Vec<Plane>, PhotoError> {
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) || n == 0 {
        return Err(PhotoError::InvalidInput(format!(
            "axis sweep needs 0 < near < far and n ≥ 1, got near {near}, far {far}, n {n}"
        )));
    }
    let (w, h) = (view.camera.width as f64, view.camera.height as f64);
    let mut corners = Vec::with_capacity(8);
    for xy in [
        Vector2::new(0.0, 0.0),
        Vector2::new(w, 0.0),
        Vector2::new(0.0, h),
        Vector2::new(w, h),
    ] {
        let (origin, dir) = view.ray(&xy);
        corners.push(origin + dir * near);
        corners.push(origin + dir * far);
    }
    let mut planes = Vec::with_capacity(directions.len() * n);
    for dir in directions {
        let len = dir.norm();
        if !(len.is_finite() && len > 1e-12) {
            return Err(PhotoError::InvalidInput(format!(
                "plane direction {dir:?} is not a usable normal"
            )));
        }
        let u = dir / len;
        let (lo, hi) = corners
            .iter()
            .map(|c| u.dot(c))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            });
        let offsets: Vec<f64> = if n == 1 {
            vec![0.5 * (lo + hi)]
        } else {
            (0..n)
                .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
                .collect()
        };
        planes.extend(axis_planes(&[u], &offsets)?);
    }
    Ok(planes)
}

/// How the consecutive planes of one sweep family are spaced, which fixes how a fractional
/// plane index maps to a depth along a pixel's ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// Parallel planes evenly spaced in inverse depth ([`fronto_parallel_planes`]): the
    /// inverse depth is interpolated linearly in the index.
    InverseDepth,
    /// Parallel planes evenly spaced in offset ([`axis_sweep_planes`]): the
    /// depth along a ray is `d / (n·ray)`, so it is interpolated linearly in the index.
    Offset,
}

/// One family of parallel planes in sweep order, with how they are spaced: what
/// [`super::refine_subplane`] needs to interpolate between neighbouring planes.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFamily {
    /// The planes, consecutive in sweep order.
    pub planes: Vec<Plane>,
    /// Their spacing.
    pub spacing: Spacing,
}
