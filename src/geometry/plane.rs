//! Planes `n·X = d` with unit normal `n` in world coordinates, and ray intersection.

use nalgebra::{Isometry3, Vector3};
use serde::{Deserialize, Serialize};

/// A plane `normal · X = offset`, `normal` a unit vector in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    /// Unit normal (world frame).
    pub normal: Vector3<f64>,
    /// Offset `d` in `n·X = d`: the signed distance of the plane from the origin along `n`.
    pub offset: f64,
}

impl Plane {
    /// A plane from a (not necessarily unit, non-zero) normal and offset; both are scaled so
    /// the stored normal is unit.
    pub fn new(normal: Vector3<f64>, offset: f64) -> Self {
        let len = normal.norm();
        Plane {
            normal: normal / len,
            offset: offset / len,
        }
    }

    /// The plane through `point` with normal `normal`.
    pub fn through(point: &Vector3<f64>, normal: &Vector3<f64>) -> Self {
        let n = normal.normalize();
        Plane {
            normal: n,
            offset: n.dot(point),
        }
    }

    /// Signed distance of `x` from the plane (positive on the side `normal` points to).
    pub fn signed_distance(&self, x: &Vector3<f64>) -> f64 {
        self.normal.dot(x) - self.offset
    }

    /// Ray parameter `t` where `origin + t·dir` meets the plane; `None` for a ray parallel to
    /// the plane (|n·dir| below `1e-12·|dir|`) or a non-finite result.
    pub fn intersect_ray(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<f64> {
        let denom = self.normal.dot(dir);
        if denom.abs() <= 1e-12 * dir.norm() {
            return None;
        }
        let t = (self.offset - self.normal.dot(origin)) / denom;
        t.is_finite().then_some(t)
    }

    /// The same plane expressed in a camera frame: `n_c·X_c = d_c`.
    pub fn in_camera(&self, cam_from_world: &Isometry3<f64>) -> Plane {
        let n_c = cam_from_world.rotation * self.normal;
        // X_w = R^T (X_c - t)  =>  n·R^T X_c - n·R^T t = d  =>  n_c·X_c = d + n_c·t
        Plane {
            normal: n_c,
            offset: self.offset + n_c.dot(&cam_from_world.translation.vector),
        }
    }

    /// Depth (camera z) at which the camera-frame ray `ray_cam` (z = 1) meets this plane given
    /// in the camera frame. `None` when parallel or behind the camera.
    pub fn depth_along(&self, ray_cam: &Vector3<f64>) -> Option<f64> {
        let denom = self.normal.dot(ray_cam);
        if denom.abs() <= 1e-12 {
            return None;
        }
        let z = self.offset / denom;
        (z.is_finite() && z > 0.0).then_some(z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    #[test]
    fn intersection_lands_on_plane() {
        let p = Plane::new(Vector3::new(0.0, 0.0, 2.0), 6.0);
        assert!((p.offset - 3.0).abs() < 1e-15);
        let o = Vector3::new(1.0, 2.0, 0.0);
        let d = Vector3::new(0.1, -0.2, 1.0);
        let t = p.intersect_ray(&o, &d).unwrap();
        assert!(p.signed_distance(&(o + d * t)).abs() < 1e-12);
        assert!(p.intersect_ray(&o, &Vector3::new(1.0, 0.0, 0.0)).is_none());
    }

    #[test]
    fn camera_frame_plane_agrees_with_world() {
        let p = Plane::through(&Vector3::new(0.3, -1.0, 4.0), &Vector3::new(0.2, 0.1, -1.0));
        let cam_from_world = Isometry3::from_parts(
            Translation3::new(0.5, -0.2, 1.0),
            UnitQuaternion::from_euler_angles(0.1, -0.3, 0.7),
        );
        let pc = p.in_camera(&cam_from_world);
        for x in [Vector3::new(1.0, 2.0, 3.0), Vector3::new(-4.0, 0.5, 9.0)] {
            let xc = cam_from_world * nalgebra::Point3::from(x);
            assert!((p.signed_distance(&x) - pc.signed_distance(&xc.coords)).abs() < 1e-12);
        }
    }
}
