//! Geometry: cameras, rigid poses, planes, rays and plane-induced homographies.
//!
//! Frames are named: a pose is always `cam_from_world` (x_cam = R·x_world + t), as in COLMAP.
//! Depth is the camera-frame z of a point, not the length of the ray.

mod camera;
mod plane;

pub use camera::{Camera, CameraError, CameraModel, MAX_PRINCIPAL_POINT_OUTSIDE};
pub use plane::Plane;

use nalgebra::{Isometry3, Matrix3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use thiserror::Error;

/// A rigid transform; used as `cam_from_world` throughout.
pub type Rigid3 = Isometry3<f64>;

/// Largest `|‖q‖ − 1|` of a rotation quaternion that is renormalised rather than rejected.
///
/// COLMAP normalises every quaternion it reads (`Image::NormalizeQvec` after parsing), so a
/// quaternion that lost digits on the way (text written with 6 significant digits is off by
/// up to ~1e-6; hand-edited files with 4 decimals by ~1e-4) is read as the rotation it meant.
/// Beyond 1e-3 it is no longer rounding: a zero, scaled or garbled quaternion says the file
/// is not what it claims, and reading it as some rotation would give wrong depths silently.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// Errors of pose construction.
#[derive(Debug, Error, PartialEq)]
pub enum PoseError {
    /// A rotation quaternion is zero, non-finite or too far from unit length.
    #[error(
        "quaternion (qw, qx, qy, qz) = ({:?}, {:?}, {:?}, {:?}) has norm {norm:?}, expected a \
         unit quaternion (norm within {QUATERNION_NORM_TOLERANCE} of 1)",
        qvec[0], qvec[1], qvec[2], qvec[3]
    )]
    NotUnit {
        /// The quaternion as given.
        qvec: [f64; 4],
        /// Its norm.
        norm: f64,
    },
}

/// The norm of COLMAP's `(qw, qx, qy, qz)`.
pub fn quaternion_norm(qvec: [f64; 4]) -> f64 {
    Quaternion::new(qvec[0], qvec[1], qvec[2], qvec[3]).norm()
}

/// The rotation of COLMAP's quaternion `(qw, qx, qy, qz)`, renormalised as COLMAP does when
/// its norm is within [`QUATERNION_NORM_TOLERANCE`] of 1, an error otherwise (zero, NaN,
/// scaled). A quaternion that is unit to rounding (`|‖q‖² − 1| ≤ 4ε`) is kept bit for bit, so
/// that poses written back are identical.
pub fn colmap_rotation(qvec: [f64; 4]) -> Result<UnitQuaternion<f64>, PoseError> {
    let q = Quaternion::new(qvec[0], qvec[1], qvec[2], qvec[3]);
    let norm = q.norm();
    if !(norm.is_finite() && (norm - 1.0).abs() <= QUATERNION_NORM_TOLERANCE) {
        return Err(PoseError::NotUnit { qvec, norm });
    }
    if (q.norm_squared() - 1.0).abs() <= 4.0 * f64::EPSILON {
        Ok(UnitQuaternion::new_unchecked(q))
    } else {
        Ok(UnitQuaternion::new_normalize(q))
    }
}

/// `cam_from_world` from COLMAP's quaternion `(qw, qx, qy, qz)` and translation; the
/// quaternion is checked and renormalised by [`colmap_rotation`].
pub fn rigid_from_colmap(qvec: [f64; 4], tvec: [f64; 3]) -> Result<Rigid3, PoseError> {
    Ok(Isometry3::from_parts(
        Translation3::new(tvec[0], tvec[1], tvec[2]),
        colmap_rotation(qvec)?,
    ))
}

/// COLMAP's `(qw, qx, qy, qz)` and `(tx, ty, tz)` of a `cam_from_world` transform.
pub fn rigid_to_colmap(cam_from_world: &Rigid3) -> ([f64; 4], [f64; 3]) {
    let q = cam_from_world.rotation.quaternion();
    let t = &cam_from_world.translation.vector;
    ([q.w, q.i, q.j, q.k], [t.x, t.y, t.z])
}

/// Camera centre in world coordinates: `-Rᵀ t`.
pub fn camera_center(cam_from_world: &Rigid3) -> Vector3<f64> {
    cam_from_world
        .inverse_transform_point(&Point3::origin())
        .coords
}

/// A `cam_from_world` pose for a camera at `eye` looking at `target`, with image "up"
/// (−y in the image) as close to `up` as possible. Camera frame: x right, y down, z forward.
pub fn look_at(eye: &Vector3<f64>, target: &Vector3<f64>, up: &Vector3<f64>) -> Rigid3 {
    let z = (target - eye).normalize();
    let mut x = z.cross(up);
    if x.norm() < 1e-9 {
        // Looking along `up`: pick any perpendicular.
        x = z.cross(&Vector3::new(1.0, 0.0, 0.0));
        if x.norm() < 1e-9 {
            x = z.cross(&Vector3::new(0.0, 1.0, 0.0));
        }
    }
    let x = x.normalize();
    let y = z.cross(&x);
    // Rows of R are the camera axes in world coordinates.
    let r = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    let rotation =
        UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(r));
    let t = -(rotation * eye);
    Isometry3::from_parts(Translation3::from(t), rotation)
}

/// The homography mapping image coordinates of view `a` to those of view `b` induced by
/// `plane` (world frame), for undistorted cameras: `x_b ~ K_b (R − t nᵀ/d) K_a⁻¹ x_a` with
/// `(R, t)` = `b_from_a` and `(n, d)` the plane in frame `a`. `None` if the plane passes
/// through camera `a`'s centre.
pub fn plane_homography(
    camera_a: &Camera,
    a_from_world: &Rigid3,
    camera_b: &Camera,
    b_from_world: &Rigid3,
    plane: &Plane,
) -> Option<Matrix3<f64>> {
    let plane_a = plane.in_camera(a_from_world);
    if plane_a.offset.abs() < 1e-12 {
        return None;
    }
    let b_from_a = b_from_world * a_from_world.inverse();
    let r = b_from_a.rotation.to_rotation_matrix().into_inner();
    let t = b_from_a.translation.vector;
    // Points on the plane satisfy n·X/d = 1, so X_b = R X + t (n·X)/d.
    let h = r + t * plane_a.normal.transpose() / plane_a.offset;
    let ka_inv = camera_a.k_matrix().try_inverse()?;
    Some(camera_b.k_matrix() * h * ka_inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};

    #[test]
    fn look_at_points_camera_at_target() {
        let eye = Vector3::new(1.0, -2.0, 3.0);
        let target = Vector3::new(0.0, 0.0, 0.0);
        let pose = look_at(&eye, &target, &Vector3::new(0.0, 0.0, 1.0));
        let t_cam = pose * Point3::from(target);
        assert!(t_cam.x.abs() < 1e-12 && t_cam.y.abs() < 1e-12 && t_cam.z > 0.0);
        assert!((camera_center(&pose) - eye).norm() < 1e-12);
        // World up projects upwards in the image (negative y).
        let above = pose * Point3::from(target + Vector3::new(0.0, 0.0, 0.5));
        assert!(above.y < 0.0);
    }

    #[test]
    fn colmap_pose_round_trip_is_exact() {
        let q = [0.7, 0.1, -0.7, 0.1];
        let t = [1.5, -2.25, 0.125];
        let (q2, t2) = rigid_to_colmap(&rigid_from_colmap(q, t).unwrap());
        assert_eq!(q, q2);
        assert_eq!(t, t2);
    }

    #[test]
    fn colmap_quaternions_are_renormalised_or_rejected() {
        // A quarter turn about z, scaled by 1.0005: read as the quarter turn.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let s = 1.0005;
        let r = rigid_from_colmap([h * s, 0.0, 0.0, h * s], [0.0; 3]).unwrap();
        let x = r * Point3::new(1.0, 0.0, 0.0);
        assert!(
            (x.coords - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12,
            "{x}"
        );
        // Zero, NaN and scaled quaternions are errors naming the values and the norm.
        for q in [[0.0; 4], [f64::NAN, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]] {
            let err = rigid_from_colmap(q, [0.0; 3]).unwrap_err();
            assert!(
                err.to_string().contains("expected a unit quaternion"),
                "{err}"
            );
        }
        assert!(rigid_from_colmap([1.002, 0.0, 0.0, 0.0], [0.0; 3]).is_err());
        assert!(rigid_from_colmap([1.0009, 0.0, 0.0, 0.0], [0.0; 3]).is_ok());
    }

    #[test]
    fn plane_homography_maps_plane_points() {
        let cam = Camera::pinhole(640, 480, 500.0, 500.0, 320.0, 240.0);
        let a = look_at(
            &Vector3::new(0.0, -5.0, 1.0),
            &Vector3::zeros(),
            &Vector3::z(),
        );
        let b = look_at(
            &Vector3::new(1.5, -4.5, 1.2),
            &Vector3::zeros(),
            &Vector3::z(),
        );
        let plane = Plane::through(&Vector3::new(0.0, 0.5, 0.0), &Vector3::new(0.1, -1.0, 0.2));
        let h = plane_homography(&cam, &a, &cam, &b, &plane).unwrap();
        for xy in [Vector2::new(100.5, 200.5), Vector2::new(400.0, 300.0)] {
            let ray_a = cam.unproject(&xy);
            let center = camera_center(&a);
            let dir = a.rotation.inverse() * ray_a;
            let t = plane.intersect_ray(&center, &dir).unwrap();
            let x = Point3::from(center + dir * t);
            let expect = cam.project(&(b * x).coords).unwrap();
            let hx = h * Vector3::new(xy.x, xy.y, 1.0);
            let got = Vector2::new(hx.x / hx.z, hx.y / hx.z);
            assert!((got - expect).norm() < 1e-8, "{got:?} vs {expect:?}");
        }
    }
}
