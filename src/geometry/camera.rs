//! Camera intrinsics with the COLMAP camera models and their lens distortion.
//!
//! Image coordinates follow COLMAP: the centre of pixel `(0, 0)` is at `(0.5, 0.5)`, x to the
//! right, y down. `project` maps a point in the camera frame (z forward) to image coordinates;
//! `unproject` maps image coordinates to a ray direction with z = 1 in the camera frame.

use nalgebra::{Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of camera construction.
#[derive(Debug, Error, PartialEq)]
pub enum CameraError {
    /// The model name is not one we support.
    #[error("unknown camera model {0:?} (supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV)")]
    UnknownModel(String),
    /// The numeric COLMAP model id is not one we support.
    #[error("unknown camera model id {0} (expected {ids})", ids = CameraModel::id_list())]
    UnknownModelId(i32),
    /// The number of parameters does not match the model.
    #[error("camera model {model} takes {expected} parameters, got {got}")]
    ParamCount {
        /// Model name.
        model: &'static str,
        /// Parameters the model takes.
        expected: usize,
        /// Parameters given.
        got: usize,
    },
    /// A parameter is NaN, infinite, or a focal length is not positive.
    #[error("camera parameter {index} ({name}) is {value:?}, expected {expected}")]
    BadParam {
        /// Index into the parameter vector.
        index: usize,
        /// Parameter name (e.g. "fx").
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the parameter should be.
        expected: &'static str,
    },
    /// The principal point is so far outside the image that no pixel sees what the camera
    /// looks at: a corrupt value, not a lens ([`Camera::check_usable`]).
    #[error("principal point ({cx:?}, {cy:?}) is more than {limit} image sizes outside the {width}x{height} image")]
    PrincipalPoint {
        /// Principal point x.
        cx: f64,
        /// Principal point y.
        cy: f64,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// [`MAX_PRINCIPAL_POINT_OUTSIDE`].
        limit: f64,
    },
    /// Width or height is zero.
    #[error("camera size {width}x{height} is invalid: both must be positive")]
    BadSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
}

/// How far outside the image (in image widths for x, heights for y) a principal point may
/// lie before [`Camera::check_usable`] rejects it. Real lenses put it near the image centre;
/// shift lenses and crops move it by at most about one image size. Ten sizes leaves room for
/// any crop a user might make, while values like 1e300 (which make every ray miss the scene
/// and the depth maps all zero) are refused.
pub const MAX_PRINCIPAL_POINT_OUTSIDE: f64 = 10.0;

/// The COLMAP camera models planemap reads. Ids and parameter orders are COLMAP's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum CameraModel {
    /// `f, cx, cy`
    SimplePinhole,
    /// `fx, fy, cx, cy`
    Pinhole,
    /// `f, cx, cy, k`
    SimpleRadial,
    /// `f, cx, cy, k1, k2`
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`
    Opencv,
}

impl CameraModel {
    /// All supported models.
    pub const ALL: [CameraModel; 5] = [
        CameraModel::SimplePinhole,
        CameraModel::Pinhole,
        CameraModel::SimpleRadial,
        CameraModel::Radial,
        CameraModel::Opencv,
    ];

    /// COLMAP's numeric model id (as stored in `cameras.bin`).
    pub fn colmap_id(self) -> i32 {
        match self {
            CameraModel::SimplePinhole => 0,
            CameraModel::Pinhole => 1,
            CameraModel::SimpleRadial => 2,
            CameraModel::Radial => 3,
            CameraModel::Opencv => 4,
        }
    }

    /// Model from COLMAP's numeric id.
    pub fn from_colmap_id(id: i32) -> Result<Self, CameraError> {
        Self::ALL
            .into_iter()
            .find(|m| m.colmap_id() == id)
            .ok_or(CameraError::UnknownModelId(id))
    }

    /// The supported numeric ids with their names, for messages: `0–4: 0 SIMPLE_PINHOLE, …`.
    pub fn id_list() -> String {
        let ids: Vec<String> = Self::ALL
            .iter()
            .map(|m| format!("{} {}", m.colmap_id(), m.name()))
            .collect();
        let first = Self::ALL[0].colmap_id();
        let last = Self::ALL[Self::ALL.len() - 1].colmap_id();
        format!("{first}–{last}: {}", ids.join(", "))
    }

    /// COLMAP's model name (as in `cameras.txt`).
    pub fn name(self) -> &'static str {
        match self {
            CameraModel::SimplePinhole => "SIMPLE_PINHOLE",
            CameraModel::Pinhole => "PINHOLE",
            CameraModel::SimpleRadial => "SIMPLE_RADIAL",
            CameraModel::Radial => "RADIAL",
            CameraModel::Opencv => "OPENCV",
        }
    }

    /// Model from COLMAP's name.
    pub fn from_name(name: &str) -> Result<Self, CameraError> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| CameraError::UnknownModel(name.to_string()))
    }

    /// Parameter names in COLMAP order.
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            CameraModel::SimplePinhole => &["f", "cx", "cy"],
            CameraModel::Pinhole => &["fx", "fy", "cx", "cy"],
            CameraModel::SimpleRadial => &["f", "cx", "cy", "k"],
            CameraModel::Radial => &["f", "cx", "cy", "k1", "k2"],
            CameraModel::Opencv => &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
        }
    }

    /// Number of parameters.
    pub fn num_params(self) -> usize {
        self.param_names().len()
    }

    /// Whether the model has lens distortion.
    pub fn has_distortion(self) -> bool {
        !matches!(self, CameraModel::SimplePinhole | CameraModel::Pinhole)
    }
}

/// Intrinsics of one camera: model, image size and COLMAP-ordered parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// The camera model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Parameters in COLMAP order (see [`CameraModel::param_names`]).
    pub params: Vec<f64>,
}

impl Camera {
    /// A camera, checked: parameter count, finite values, positive focal lengths and size.
    pub fn new(
        model: CameraModel,
        width: u32,
        height: u32,
        params: Vec<f64>,
    ) -> Result<Self, CameraError> {
        let cam = Camera {
            model,
            width,
            height,
            params,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// An undistorted pinhole camera.
    pub fn pinhole(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Camera {
            model: CameraModel::Pinhole,
            width,
            height,
            params: vec![fx, fy, cx, cy],
        }
    }

    /// Checks parameter count, finiteness, focal lengths and size.
    pub fn validate(&self) -> Result<(), CameraError> {
        let names = self.model.param_names();
        if self.params.len() != names.len() {
            return Err(CameraError::ParamCount {
                model: self.model.name(),
                expected: names.len(),
                got: self.params.len(),
            });
        }
        if self.width == 0 || self.height == 0 {
            return Err(CameraError::BadSize {
                width: self.width,
                height: self.height,
            });
        }
        for (index, (&value, &name)) in self.params.iter().zip(names).enumerate() {
            let focal = name.starts_with('f');
            if !value.is_finite() || (focal && value <= 0.0) {
                let expected = if focal {
                    "a positive, finite focal length in pixels"
                } else {
                    "a finite number"
                };
                return Err(CameraError::BadParam {
                    index,
                    name,
                    value,
                    expected,
                });
            }
        }
        Ok(())
    }

    /// [`Camera::validate`] plus what a reconstruction needs beyond a well-formed record: the
    /// principal point within [`MAX_PRINCIPAL_POINT_OUTSIDE`] image sizes of the image.
    /// Scene loaders call it; readers do not, so that `planemap info` can still show and
    /// warn about such a model.
    pub fn check_usable(&self) -> Result<(), CameraError> {
        self.validate()?;
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let k = MAX_PRINCIPAL_POINT_OUTSIDE;
        let inside = |c: f64, size: f64| c >= -k * size && c <= (1.0 + k) * size;
        if !(inside(self.cx(), w) && inside(self.cy(), h)) {
            return Err(CameraError::PrincipalPoint {
                cx: self.cx(),
                cy: self.cy(),
                width: self.width,
                height: self.height,
                limit: k,
            });
        }
        Ok(())
    }

    /// Focal length in x (pixels).
    pub fn fx(&self) -> f64 {
        self.params[0]
    }

    /// Focal length in y (pixels).
    pub fn fy(&self) -> f64 {
        match self.model {
            CameraModel::Pinhole | CameraModel::Opencv => self.params[1],
            _ => self.params[0],
        }
    }

    /// Principal point x (image coordinates, pixel centres at +0.5).
    pub fn cx(&self) -> f64 {
        match self.model {
            CameraModel::Pinhole | CameraModel::Opencv => self.params[2],
            _ => self.params[1],
        }
    }

    /// Principal point y.
    pub fn cy(&self) -> f64 {
        match self.model {
            CameraModel::Pinhole | CameraModel::Opencv => self.params[3],
            _ => self.params[2],
        }
    }

    /// The calibration matrix K (ignores distortion).
    pub fn k_matrix(&self) -> Matrix3<f64> {
        Matrix3::new(
            self.fx(),
            0.0,
            self.cx(),
            0.0,
            self.fy(),
            self.cy(),
            0.0,
            0.0,
            1.0,
        )
    }

    /// Adds the model's distortion to normalised coordinates `(u, v)` (COLMAP's formulas).
    pub fn distort(&self, u: f64, v: f64) -> (f64, f64) {
        let (du, dv) = self.distortion_delta(u, v);
        (u + du, v + dv)
    }

    fn distortion_delta(&self, u: f64, v: f64) -> (f64, f64) {
        let p = &self.params;
        let r2 = u * u + v * v;
        match self.model {
            CameraModel::SimplePinhole | CameraModel::Pinhole => (0.0, 0.0),
            CameraModel::SimpleRadial => {
                let radial = p[3] * r2;
                (u * radial, v * radial)
            }
            CameraModel::Radial => {
                let radial = p[3] * r2 + p[4] * r2 * r2;
                (u * radial, v * radial)
            }
            CameraModel::Opencv => {
                let (k1, k2, p1, p2) = (p[4], p[5], p[6], p[7]);
                let uv = u * v;
                let radial = k1 * r2 + k2 * r2 * r2;
                (
                    u * radial + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u),
                    v * radial + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v),
                )
            }
        }
    }

    /// Removes distortion from distorted normalised coordinates by Newton iteration
    /// (numerical Jacobian, as COLMAP does). Converges for the distortion real lenses have.
    pub fn undistort_normalized(&self, ud: f64, vd: f64) -> (f64, f64) {
        if !self.model.has_distortion() {
            return (ud, vd);
        }
        const MAX_ITERS: usize = 100;
        const STEP_EPS: f64 = 1e-10;
        const H: f64 = 1e-7;
        let (mut u, mut v) = (ud, vd);
        for _ in 0..MAX_ITERS {
            let (fu, fv) = self.distort(u, v);
            let (ru, rv) = (fu - ud, fv - vd);
            let (fu_du, fv_du) = self.distort(u + H, v);
            let (fu_dv, fv_dv) = self.distort(u, v + H);
            let j00 = (fu_du - fu) / H;
            let j10 = (fv_du - fv) / H;
            let j01 = (fu_dv - fu) / H;
            let j11 = (fv_dv - fv) / H;
            let det = j00 * j11 - j01 * j10;
            if det.abs() < 1e-15 {
                break;
            }
            let step_u = (j11 * ru - j01 * rv) / det;
            let step_v = (-j10 * ru + j00 * rv) / det;
            u -= step_u;
            v -= step_v;
            if step_u.abs() < STEP_EPS && step_v.abs() < STEP_EPS {
                break;
            }
        }
        (u, v)
    }

    /// Projects a camera-frame point to image coordinates. `None` behind or on the camera plane.
    pub fn project(&self, p_cam: &Vector3<f64>) -> Option<Vector2<f64>> {
        if p_cam.z <= 0.0 {
            return None;
        }
        let (u, v) = self.distort(p_cam.x / p_cam.z, p_cam.y / p_cam.z);
        Some(Vector2::new(
            self.fx() * u + self.cx(),
            self.fy() * v + self.cy(),
        ))
    }

    /// Ray direction (camera frame, z = 1) through image coordinates `xy`.
    pub fn unproject(&self, xy: &Vector2<f64>) -> Vector3<f64> {
        let ud = (xy.x - self.cx()) / self.fx();
        let vd = (xy.y - self.cy()) / self.fy();
        let (u, v) = self.undistort_normalized(ud, vd);
        Vector3::new(u, v, 1.0)
    }

    /// Ray direction (z = 1) through the centre of integer pixel `(x, y)`.
    pub fn pixel_ray(&self, x: u32, y: u32) -> Vector3<f64> {
        self.unproject(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5))
    }

    /// Whether image coordinates fall inside the image.
    pub fn contains(&self, xy: &Vector2<f64>) -> bool {
        xy.x >= 0.0 && xy.y >= 0.0 && xy.x < self.width as f64 && xy.y < self.height as f64
    }

    /// The same camera for an image resized to `width` x `height` (intrinsics scaled so
    /// that the image borders map to the same rays).
    pub fn rescaled(&self, width: u32, height: u32) -> Camera {
        let sx = width as f64 / self.width as f64;
        let sy = height as f64 / self.height as f64;
        let mut params = self.params.clone();
        match self.model {
            CameraModel::Pinhole | CameraModel::Opencv => {
                params[0] *= sx;
                params[1] *= sy;
                params[2] *= sx;
                params[3] *= sy;
            }
            _ => {
                // Single focal length: keep it square using the mean scale.
                params[0] *= 0.5 * (sx + sy);
                params[1] *= sx;
                params[2] *= sy;
            }
        }
        Camera {
            model: self.model,
            width,
            height,
            params,
        }
    }

    /// The undistorted PINHOLE camera planemap works with: same size, focal lengths and
    /// principal point; distortion removed. Images are resampled to it by
    /// [`crate::scene::undistort_image`].
    pub fn undistorted(&self) -> Camera {
        Camera::pinhole(
            self.width,
            self.height,
            self.fx(),
            self.fy(),
            self.cx(),
            self.cy(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cameras() -> Vec<Camera> {
        vec![
            Camera::new(
                CameraModel::SimplePinhole,
                640,
                480,
                vec![500.0, 320.0, 240.0],
            )
            .unwrap(),
            Camera::new(
                CameraModel::Pinhole,
                640,
                480,
                vec![500.0, 510.0, 321.0, 239.0],
            )
            .unwrap(),
            Camera::new(
                CameraModel::SimpleRadial,
                640,
                480,
                vec![500.0, 320.0, 240.0, -0.05],
            )
            .unwrap(),
            Camera::new(
                CameraModel::Radial,
                640,
                480,
                vec![500.0, 320.0, 240.0, -0.1, 0.02],
            )
            .unwrap(),
            Camera::new(
                CameraModel::Opencv,
                640,
                480,
                vec![500.0, 505.0, 320.0, 240.0, -0.1, 0.01, 0.001, -0.002],
            )
            .unwrap(),
        ]
    }

    #[test]
    fn project_unproject_round_trip_all_models() {
        for cam in cameras() {
            for &(x, y) in &[(0.5, 0.5), (320.0, 240.0), (639.5, 479.5), (100.25, 400.75)] {
                let xy = Vector2::new(x, y);
                let ray = cam.unproject(&xy);
                assert!((ray.z - 1.0).abs() < 1e-15);
                let back = cam.project(&(ray * 3.7)).unwrap();
                assert!(
                    (back - xy).norm() < 1e-6,
                    "{:?}: {xy:?} -> {back:?}",
                    cam.model
                );
            }
        }
    }

    #[test]
    fn principal_point_ray_is_optical_axis() {
        for cam in cameras() {
            let ray = cam.unproject(&Vector2::new(cam.cx(), cam.cy()));
            assert!(ray.x.abs() < 1e-12 && ray.y.abs() < 1e-12);
        }
    }

    #[test]
    fn behind_camera_does_not_project() {
        let cam = &cameras()[0];
        assert!(cam.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
        assert!(cam.project(&Vector3::new(1.0, 0.0, 0.0)).is_none());
    }

    #[test]
    fn model_ids_and_names_round_trip() {
        for m in CameraModel::ALL {
            assert_eq!(CameraModel::from_colmap_id(m.colmap_id()).unwrap(), m);
            assert_eq!(CameraModel::from_name(m.name()).unwrap(), m);
        }
        assert!(matches!(
            CameraModel::from_name("FISHEYE"),
            Err(CameraError::UnknownModel(_))
        ));
        let err = CameraModel::from_colmap_id(99).unwrap_err().to_string();
        assert_eq!(
            err,
            "unknown camera model id 99 (expected 0–4: 0 SIMPLE_PINHOLE, 1 PINHOLE, \
             2 SIMPLE_RADIAL, 3 RADIAL, 4 OPENCV)"
        );
    }

    #[test]
    fn usable_cameras_have_a_principal_point_near_the_image() {
        let ok = Camera::new(
            CameraModel::Pinhole,
            64,
            48,
            vec![50.0, 50.0, -100.0, 200.0],
        );
        assert!(ok.unwrap().check_usable().is_ok());
        for (cx, cy) in [(1e300, 24.0), (32.0, -1e6), (64.0 * 11.5, 24.0)] {
            let cam = Camera::new(CameraModel::Pinhole, 64, 48, vec![50.0, 50.0, cx, cy]).unwrap();
            let err = cam.check_usable().unwrap_err();
            assert!(matches!(err, CameraError::PrincipalPoint { .. }), "{err:?}");
            assert!(err.to_string().contains("principal point"), "{err}");
        }
        // A record that does not validate is not usable either.
        let mut bad = Camera::pinhole(64, 48, 50.0, 50.0, 32.0, 24.0);
        bad.params[0] = -1.0;
        let err = bad.check_usable().unwrap_err().to_string();
        assert!(err.contains("(fx) is -1.0, expected a positive"), "{err}");
    }

    #[test]
    fn validation_rejects_bad_params() {
        assert!(matches!(
            Camera::new(CameraModel::Pinhole, 10, 10, vec![1.0, 1.0, 5.0]),
            Err(CameraError::ParamCount {
                expected: 4,
                got: 3,
                ..
            })
        ));
        assert!(matches!(
            Camera::new(CameraModel::Pinhole, 10, 10, vec![f64::NAN, 1.0, 5.0, 5.0]),
            Err(CameraError::BadParam { index: 0, .. })
        ));
        assert!(matches!(
            Camera::new(CameraModel::SimplePinhole, 10, 10, vec![-3.0, 5.0, 5.0]),
            Err(CameraError::BadParam { name: "f", .. })
        ));
        assert!(matches!(
            Camera::new(CameraModel::SimplePinhole, 0, 10, vec![3.0, 5.0, 5.0]),
            Err(CameraError::BadSize { .. })
        ));
    }

    #[test]
    fn rescaling_keeps_border_rays() {
        let cam = &cameras()[1];
        let half = cam.rescaled(320, 240);
        let a = cam.unproject(&Vector2::new(0.0, 0.0));
        let b = half.unproject(&Vector2::new(0.0, 0.0));
        assert!((a - b).norm() < 1e-12);
        let a = cam.unproject(&Vector2::new(640.0, 480.0));
        let b = half.unproject(&Vector2::new(320.0, 240.0));
        assert!((a - b).norm() < 1e-12);
    }
}
