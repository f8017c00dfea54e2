//! Smoothness term V_pq(h_p, h_q) of Manhattan-world stereo.
//!
//! V = 0 for equal labels; otherwise the 3D distance between the points where the ray
//! through the midpoint of p and q meets the two planes, in units of the scene scale R,
//! truncated: `min(trunc, |X_pq^a − X_pq^b| / R)`. A plane behind the camera or parallel to
//! that ray costs `trunc` (the largest value), which keeps V a truncated metric, so
//! α-expansion moves stay exact.
//!
//! The midpoint ray is recomputed from the pixel indices (a handful of flops) and each
//! label's plane is kept in the camera frame, so the depth along a ray r (z = 1) is
//! `d_c / (n_c · r)` and the 3D gap is `|z_a − z_b| · |r|`.

use nalgebra::Vector3;

use super::Pinhole;
use crate::geometry::{Camera, Plane, Rigid3};

/// Evaluates V for one view: per-label camera-frame planes plus the intrinsics.
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothness {
    width: u32,
    pinhole: Pinhole,
    /// Per local label: the plane in the target camera frame, `n_c · X_c = d_c`.
    planes_cam: Vec<Plane>,
    /// 1 / R.
    inv_scale: f64,
    /// Truncation (units of R).
    truncation: f32,
}

impl Smoothness {
    /// V for a view with intrinsics `camera` (undistorted) and pose `cam_from_world`, labels
    /// `planes` (world frame, one per local label), scene scale `scale` = R (world units) and
    /// truncation `truncation` (units of R).
    pub fn new(
        camera: &Camera,
        cam_from_world: &Rigid3,
        planes: &[Plane],
        scale: f64,
        truncation: f64,
    ) -> Self {
        Smoothness {
            width: camera.width,
            pinhole: Pinhole::of(camera),
            planes_cam: planes.iter().map(|p| p.in_camera(cam_from_world)).collect(),
            inv_scale: 1.0 / scale,
            truncation: truncation as f32,
        }
    }

    /// Number of labels.
    pub fn num_labels(&self) -> usize {
        self.planes_cam.len()
    }

    /// 1 / R (per world unit).
    pub fn inv_scale(&self) -> f64 {
        self.inv_scale
    }

    /// The truncation of V (units of R).
    pub fn truncation(&self) -> f32 {
        self.truncation
    }

    /// Local label `a`'s plane in the target camera frame.
    pub fn plane_in_camera(&self, a: u32) -> &Plane {
        &self.planes_cam[a as usize]
    }

    /// Camera-frame ray (z = 1) through the midpoint of the centres of pixels `p` and `q`
    /// (row-major indices `y·width + x`).
    #[inline]
    pub fn midpoint_ray(&self, p: usize, q: usize) -> Vector3<f64> {
        let w = self.width as usize;
        let u = ((p % w) + (q % w)) as f64 * 0.5 + 0.5;
        let v = ((p / w) + (q / w)) as f64 * 0.5 + 0.5;
        self.pinhole.ray(u, v)
    }

    /// Camera-frame ray (z = 1) through the centre of pixel `p`.
    #[inline]
    pub fn pixel_ray(&self, p: usize) -> Vector3<f64> {
        let w = self.width as usize;
        self.pinhole.ray((p % w) as f64 + 0.5, (p / w) as f64 + 0.5)
    }

    /// Depth (camera z) of local label `a` along camera-frame ray `ray` (z = 1); `None`
    /// behind the camera or parallel.
    #[inline]
    pub fn depth(&self, ray: &Vector3<f64>, a: u32) -> Option<f64> {
        self.planes_cam[a as usize].depth_along(ray)
    }

    /// V(a, b) along a given camera-frame ray (z = 1).
    #[inline]
    pub fn cost_on_ray(&self, ray: &Vector3<f64>, a: u32, b: u32) -> f32 {
        if a == b {
            return 0.0;
        }
        match (self.depth(ray, a), self.depth(ray, b)) {
            (Some(za), Some(zb)) => {
                let gap = (za - zb).abs() * ray.norm() * self.inv_scale;
                (gap as f32).min(self.truncation)
            }
            _ => self.truncation,
        }
    }

    /// V_pq(a, b) for pixels `p`, `q` (row-major indices, normally 4-neighbours) and local
    /// labels `a`, `b`. Symmetric in (p, q) and in (a, b); 0 iff `a == b` or the planes meet
    /// on the midpoint ray.
    #[inline]
    pub fn cost(&self, p: usize, q: usize, a: u32, b: u32) -> f32 {
        if a == b {
            return 0.0;
        }
        self.cost_on_ray(&self.midpoint_ray(p, q), a, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::look_at;

    fn setup() -> (Camera, Rigid3) {
        let cam = Camera::pinhole(80, 60, 70.0, 70.0, 40.0, 30.0);
        let pose = look_at(
            &Vector3::new(3.0, -4.0, 2.0),
            &Vector3::new(0.0, 0.0, 0.5),
            &Vector3::z(),
        );
        (cam, pose)
    }

    #[test]
    fn parallel_planes_gap_is_offset_difference_over_cosine() {
        let (cam, pose) = setup();
        let n = Vector3::new(0.3, -0.8, 0.2).normalize();
        let planes = [Plane::new(n, 0.1), Plane::new(n, 0.16), Plane::new(n, -3.0)];
        let scale = 0.01;
        let s = Smoothness::new(&cam, &pose, &planes, scale, 10.0);
        let world_from_cam = pose.inverse();
        let mut checked = 0;
        for (p, q) in [
            (0usize, 1usize),
            (25 * 80 + 40, 26 * 80 + 40),
            (59 * 80 + 78, 59 * 80 + 79),
        ] {
            let ray_cam = s.midpoint_ray(p, q);
            let dir_world = (world_from_cam.rotation * ray_cam).normalize();
            let cos = n.dot(&dir_world).abs();
            let want = (0.06 / cos / scale) as f32;
            let got = s.cost(p, q, 0, 1);
            assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
            assert_eq!(s.cost(q, p, 1, 0), got, "symmetric");
            assert_eq!(s.cost(p, q, 0, 0), 0.0);
            // Far apart: truncated.
            assert_eq!(s.cost(p, q, 0, 2), 10.0);
            checked += 1;
        }
        assert_eq!(checked, 3);
    }

    #[test]
    fn crossing_planes_cost_nothing_on_their_intersection() {
        let (cam, pose) = setup();
        // Two planes through the point the midpoint ray of pixels (40,30)-(41,30) hits at
        // depth 5, with different normals.
        let s0 = Smoothness::new(&cam, &pose, &[], 1.0, 10.0);
        let ray = s0.midpoint_ray(30 * 80 + 40, 30 * 80 + 41);
        let x_cam = ray * 5.0;
        let x_world = pose
            .inverse_transform_point(&nalgebra::Point3::from(x_cam))
            .coords;
        let planes = [
            Plane::through(&x_world, &Vector3::x()),
            Plane::through(&x_world, &Vector3::new(0.2, 1.0, 0.3)),
        ];
        let s = Smoothness::new(&cam, &pose, &planes, 0.01, 10.0);
        assert!(s.cost(30 * 80 + 40, 30 * 80 + 41, 0, 1) < 1e-6);
        // One row down the planes have separated.
        assert!(s.cost(31 * 80 + 40, 31 * 80 + 41, 0, 1) > 0.01);
    }

    #[test]
    fn missing_intersections_cost_the_truncation_without_nan() {
        let cam = Camera::pinhole(40, 30, 40.0, 40.0, 20.0, 15.0);
        let pose = Rigid3::identity();
        let planes = [
            Plane::new(Vector3::z(), 5.0),
            Plane::new(Vector3::z(), -5.0), // behind
            Plane::new(Vector3::x(), 0.0),  // through the centre
            Plane::new(Vector3::y(), 1.0),  // parallel to the rays of the centre row
        ];
        let s = Smoothness::new(&cam, &pose, &planes, 0.1, 7.0);
        for p in 0..40 * 29 {
            for (a, b) in [(0, 1), (0, 2), (1, 2), (0, 3), (2, 3)] {
                let right = s.cost(p, p + 1, a, b);
                let down = s.cost(p, p + 40, a, b);
                assert!(right.is_finite() && (0.0..=7.0).contains(&right));
                assert!(down.is_finite() && (0.0..=7.0).contains(&down));
            }
            assert_eq!(s.cost(p, p + 1, 0, 1), 7.0);
        }
    }
}
