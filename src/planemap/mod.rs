//! Per-view energy of Manhattan-world stereo (Furukawa, Curless, Seitz, Szeliski, CVPR 2009).
//!
//! For a target view t, every pixel p gets a label h_p: one of the global plane hypotheses.
//! The energy minimised by α-expansion is
//!
//! ```text
//! E = Σ_p D_p(h_p) + λ Σ_(p,q)∈N w_pq V_pq(h_p, h_q)
//! ```
//!
//! - [`data`]: D, visibility conflicts between X_p^h = ray(p) ∩ h and the sparse points
//!   (the paper's three cases), confidence-weighted and truncated.
//! - [`smooth`]: V, the 3D gap between the two planes along the ray through the midpoint of
//!   p and q, in units of the scene scale R, truncated.
//! - [`lines`]: w_pq, lowered on dominant lines (image edges aligned with a vanishing
//!   direction of one of the dominant axes).
//! - [`prune`]: which plane hypotheses are worth offering as labels in this view.
//! - [`energy`]: [`PlanemapEnergy`], the bundle handed to the solver.
//!
//! Everything here takes plain data (views, image, cloud, planes, directions, scale) through
//! [`ViewInputs`]; the camera must be undistorted (PINHOLE or SIMPLE_PINHOLE).

pub mod data;
pub mod energy;
pub mod lines;
pub mod prune;
pub mod smooth;

#[cfg(test)]
pub(crate) mod testutil;

pub use data::data_costs;
pub use energy::PlanemapEnergy;
pub use lines::{dominant_line_weights, vanishing_points, EdgeWeights};
pub use prune::{prune_labels, LabelSupport};
pub use smooth::Smoothness;

use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::geometry::{Camera, Plane};
use crate::photo::PhotoConfig;
use crate::raster::ImageF32;
use crate::scene::{SparseCloud, View};

/// Errors of building a view's planemap energy.
#[derive(Debug, Error)]
pub enum PlanemapError {
    /// A configuration value is out of range.
    #[error("planemap config: `{field}` {message}")]
    Config {
        /// The offending field.
        field: &'static str,
        /// What was expected.
        message: String,
    },
    /// The inputs are inconsistent (message says how).
    #[error("planemap input: {0}")]
    Input(String),
    /// No plane hypothesis is in front of the target camera, so no label can be offered.
    #[error("planemap: none of the {0} planes is in front of view {1}")]
    NoLabels(usize, usize),
}

/// Settings of the per-view energy. Defaults are the paper's start values where they carry
/// over; see each field for what differs and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanemapConfig {
    /// Margin γ of the visibility tests, in units of the sampling scale R, ≥ 0: a plane
    /// point within γ of a sparse point (along the relevant ray) does not conflict with it.
    /// The paper's γ = 10R; tighter margins help courtyard's plain wall but cost the
    /// noisier scenes more (docs/notes/courtyard.md).
    pub margin_factor: f64,
    /// Confidence offset: a conflicting point P adds `max(0, C(P) − offset)` to the data
    /// term, its confidence C in [0, 1] (synthetic, or from COLMAP track length and
    /// reprojection error); any finite value. The paper uses 0.7 on PMVS NCC scores in
    /// [−1, 1]; here any positive offset silences COLMAP's two-view points (C ≈ 0.15),
    /// which are often a wall's only points near a camera (docs/notes/energy.md).
    pub confidence_offset: f64,
    /// Truncation of the data term D, in data-cost units, > 0: the paper's 0.5. Also the
    /// cost of a plane that is behind the camera or parallel to the pixel's ray.
    pub data_truncation: f64,
    /// Half-size in pixels of the square footprint each conflict is splatted to, in
    /// 0..=16 (0 = the pixel itself, 1 = 3×3). The paper's PMVS points are dense enough to
    /// hit every pixel; SfM points are far sparser, so a conflict also counts for the
    /// pixels right around it.
    pub splat_radius: u32,
    /// Truncation of the smoothness term V, in units of R, > 0: the paper's 10.
    pub smoothness_truncation: f64,
    /// λ, the weight of the smoothness term against the data term, ≥ 0 (the paper sets it
    /// per dataset). Tuned on the Manhattan scenes together with `edge_gradient_threshold`
    /// and `crease_cost` (docs/notes/energy.md).
    pub lambda: f64,
    /// The least V, in units of R, that a label change pays between two pixels where no
    /// image edge passes (Sobel magnitude at most `edge_gradient_threshold` at both); in
    /// [0, `smoothness_truncation`], 0 = the paper's V. The paper's V is 0 wherever the two
    /// planes meet on the midpoint ray, so a plane can be continued across a plain region
    /// up to its 3D crease with another at no cost (a table top up the wall behind it),
    /// while real creases between differently oriented surfaces are nearly always image
    /// edges. Lower let the demo's table top climb the wall, higher broke corridor's far
    /// walls (docs/notes/energy.md).
    pub crease_cost: f64,
    /// w_pq, the smoothness weight of a pixel pair across a dominant line, in [0, 1]; 1
    /// elsewhere. The paper's 0.01.
    pub dominant_line_weight: f64,
    /// Sobel gradient magnitude above which a pixel is an image edge, in grey levels (in
    /// [0, 1]) per pixel with the kernel normalised by 1/8 (a unit step gives 0.5); > 0.
    /// About 3.5 σ of the Sobel response to 1 % image noise, since the shading step
    /// between a wall and a ceiling is often only a few grey levels (docs/notes/energy.md).
    pub edge_gradient_threshold: f64,
    /// Largest angle, in degrees in [0, 90), between an image edge's direction and the
    /// direction toward a vanishing point for the edge to count as a dominant line. Not
    /// tuned.
    pub edge_angle_tolerance_deg: f64,
    /// Keep only edge pixels whose gradient magnitude is a local maximum across the edge,
    /// so that dominant lines are one pixel wide. Not tuned.
    pub edge_non_max_suppression: bool,
    /// Label pruning: a plane is offered to the view if at least this many sparse points
    /// seen by the view (their track contains it) lie within γ of it, a count. A low bar
    /// for small clouds (the paper's hypotheses need ≈ 50 points globally).
    pub min_support: usize,
    /// Label pruning: a plane is also offered if at least this many points projecting into
    /// the view's image, seen by it or not, lie within γ of it, a count; 0 = off. SfM
    /// tracks are incomplete, so a view's own points undercount a plane it sees.
    pub min_support_in_frustum: usize,
    /// Label pruning: at most this many labels per view, the best supported first; a
    /// count, 0 = no cap. Bounds the α-expansion cost, which is linear in the number of
    /// labels.
    pub max_labels: usize,
    /// Weight of the photo-consistency data term (Sinha et al. 2009 style), in data-cost
    /// units, ≥ 0, 0 = off: `D_p(h) += photo_weight · c_p(h)`, c the cost in [0, 1] of
    /// pixel p on plane h against the view's neighbours ([`crate::photo`]). It matters most
    /// where sparse points are thin; a weight of 1 was worse on room and stairs
    /// (docs/notes/energy.md).
    pub photo_weight: f64,
    /// How the photo term scores a pixel on a plane: 7×7 NCC against the best 2 of 3
    /// neighbours, with adaptive support weights (Yoon and Kweon 2006; σc 0.15, σs 3 px).
    /// The weights keep a contrasted foreground (a column, a picket) from winning its
    /// background's windows; chosen on the 13 scenes for about 1.1× the run time
    /// (docs/notes/energy.md). `photo.support_sigma_color = 0` gives box windows.
    pub photo: PhotoConfig,
    /// Bound the planes by the scene's vertical extent: along the vertical (the dominant
    /// direction nearest the cameras' mean "up"), a plane point more than
    /// `vertical_extent_margin` of the scene's height below the lowest or above the highest
    /// sparse point or camera centre costs `data_truncation`, as a plane behind the camera
    /// does. Nothing of a building is seen below its floor or ground or above its highest
    /// point, so a wall is not continued over the floor or the ceiling of a view that sees
    /// little else. Off when no direction is within 25° of the cameras' "up".
    pub vertical_extent: bool,
    /// The margin of `vertical_extent`, a fraction ≥ 0 of the height spanned by the sparse
    /// points and camera centres.
    pub vertical_extent_margin: f64,
}

impl Default for PlanemapConfig {
    fn default() -> Self {
        PlanemapConfig {
            margin_factor: 10.0,
            confidence_offset: 0.0,
            data_truncation: 0.5,
            splat_radius: 1,
            smoothness_truncation: 10.0,
            lambda: 0.25,
            crease_cost: 4.0,
            dominant_line_weight: 0.01,
            edge_gradient_threshold: 0.015,
            edge_angle_tolerance_deg: 10.0,
            edge_non_max_suppression: true,
            min_support: 6,
            min_support_in_frustum: 20,
            max_labels: 0,
            photo_weight: 0.3,
            photo: PhotoConfig {
                neighbours: 3,
                support_sigma_color: 0.15,
                ..PhotoConfig::default()
            },
            vertical_extent: false,
            vertical_extent_margin: 0.1,
        }
    }
}

impl PlanemapConfig {
    /// Checks every value's range.
    pub fn validate(&self) -> Result<(), PlanemapError> {
        fn positive(field: &'static str, v: f64) -> Result<(), PlanemapError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PlanemapError::Config {
                    field,
                    message: format!("must be a finite number > 0, got {v}"),
                })
            }
        }
        fn non_negative(field: &'static str, v: f64) -> Result<(), PlanemapError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(PlanemapError::Config {
                    field,
                    message: format!("must be a finite number ≥ 0, got {v}"),
                })
            }
        }
        non_negative("margin_factor", self.margin_factor)?;
        if !self.confidence_offset.is_finite() {
            return Err(PlanemapError::Config {
                field: "confidence_offset",
                message: format!("must be finite, got {}", self.confidence_offset),
            });
        }
        positive("data_truncation", self.data_truncation)?;
        positive("smoothness_truncation", self.smoothness_truncation)?;
        non_negative("lambda", self.lambda)?;
        non_negative("crease_cost", self.crease_cost)?;
        if self.crease_cost > self.smoothness_truncation {
            return Err(PlanemapError::Config {
                field: "crease_cost",
                message: format!(
                    "must be at most smoothness_truncation ({}), got {}",
                    self.smoothness_truncation, self.crease_cost
                ),
            });
        }
        non_negative("photo_weight", self.photo_weight)?;
        non_negative("vertical_extent_margin", self.vertical_extent_margin)?;
        self.photo.validate().map_err(|e| PlanemapError::Config {
            field: "photo",
            message: e.to_string(),
        })?;
        if !(self.dominant_line_weight.is_finite()
            && self.dominant_line_weight >= 0.0
            && self.dominant_line_weight <= 1.0)
        {
            return Err(PlanemapError::Config {
                field: "dominant_line_weight",
                message: format!("must be in [0, 1], got {}", self.dominant_line_weight),
            });
        }
        positive("edge_gradient_threshold", self.edge_gradient_threshold)?;
        if !(self.edge_angle_tolerance_deg.is_finite()
            && self.edge_angle_tolerance_deg >= 0.0
            && self.edge_angle_tolerance_deg < 90.0)
        {
            return Err(PlanemapError::Config {
                field: "edge_angle_tolerance_deg",
                message: format!("must be in [0, 90), got {}", self.edge_angle_tolerance_deg),
            });
        }
        if self.splat_radius > MAX_SPLAT_RADIUS {
            return Err(PlanemapError::Config {
                field: "splat_radius",
                message: format!(
                    "must be at most {MAX_SPLAT_RADIUS}, got {}",
                    self.splat_radius
                ),
            });
        }
        Ok(())
    }
}

/// Largest accepted [`PlanemapConfig::splat_radius`] (a 33×33 footprint is already far
/// beyond "the pixels around a point").
pub const MAX_SPLAT_RADIUS: u32 = 16;

/// Everything one view's energy is built from, as plain data.
#[derive(Debug, Clone, Copy)]
pub struct ViewInputs<'a> {
    /// Index of the target view in `views` (and in the cloud's tracks).
    pub view_index: usize,
    /// All views of the scene (camera centres are needed for conflict case 3).
    pub views: &'a [View],
    /// The target view's image (undistorted, any channel count), same size as its camera.
    pub image: &'a ImageF32,
    /// The sparse points: positions, tracks (indices into `views`), confidence in [0, 1].
    pub cloud: &'a SparseCloud,
    /// Global plane hypotheses, world frame; the index is the global label.
    pub planes: &'a [Plane],
    /// Dominant (Manhattan) directions, world frame, any length > 0; their vanishing points
    /// define dominant lines.
    pub dominant_directions: &'a [Vector3<f64>],
    /// Scene scale R: the 3D size of a pixel at the points' depths (world units).
    pub scale: f64,
    /// Global plane indices proposed by the photo-consistency sweep: offered as labels
    /// wherever they are in front of the camera, whatever their sparse support.
    pub photo_planes: &'a [u32],
}

impl ViewInputs<'_> {
    /// The target view.
    pub fn view(&self) -> &View {
        &self.views[self.view_index]
    }

    /// Checks the inputs fit together: view index, undistorted camera, image size, cloud
    /// arrays and tracks, finite planes and directions, R > 0.
    pub fn validate(&self) -> Result<(), PlanemapError> {
        let bad = |m: String| Err(PlanemapError::Input(m));
        if self.view_index >= self.views.len() {
            return bad(format!(
                "view index {} but there are {} views",
                self.view_index,
                self.views.len()
            ));
        }
        let view = self.view();
        view.camera
            .validate()
            .map_err(|e| PlanemapError::Input(format!("view {:?}: {e}", view.name)))?;
        if view.camera.model.has_distortion() {
            return bad(format!(
                "view {:?} has a {} camera; undistort the scene first (PINHOLE expected)",
                view.name,
                view.camera.model.name()
            ));
        }
        if self.image.width != view.camera.width || self.image.height != view.camera.height {
            return bad(format!(
                "image of view {:?} is {}x{} but its camera is {}x{}",
                view.name,
                self.image.width,
                self.image.height,
                view.camera.width,
                view.camera.height
            ));
        }
        if self.image.data.len() != self.image.len_pixels() * self.image.channels as usize
            || self.image.channels == 0
        {
            return bad(format!(
                "image of view {:?} has {} values for {}x{}x{}",
                view.name,
                self.image.data.len(),
                self.image.width,
                self.image.height,
                self.image.channels
            ));
        }
        self.cloud
            .validate(self.views.len())
            .map_err(|e| PlanemapError::Input(e.to_string()))?;
        for (i, pl) in self.planes.iter().enumerate() {
            let norm = pl.normal.norm();
            if !(pl.offset.is_finite() && norm.is_finite() && (norm - 1.0).abs() < 1e-6) {
                return bad(format!(
                    "plane {i} is not n·X = d with unit n and finite d: {pl:?}"
                ));
            }
        }
        for (k, d) in self.dominant_directions.iter().enumerate() {
            let norm = d.norm();
            if !(norm.is_finite() && norm > 0.0) {
                return bad(format!(
                    "dominant direction {k} is zero or not finite: {d:?}"
                ));
            }
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return bad(format!(
                "scene scale R must be finite and > 0, got {}",
                self.scale
            ));
        }
        Ok(())
    }
}

/// Intrinsics of an undistorted camera, for rays in the camera frame (z = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pinhole {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

impl Pinhole {
    pub fn of(camera: &Camera) -> Self {
        Pinhole {
            fx: camera.fx(),
            fy: camera.fy(),
            cx: camera.cx(),
            cy: camera.cy(),
        }
    }

    /// Camera-frame ray (z = 1) through image coordinates `(u, v)`.
    #[inline]
    pub fn ray(&self, u: f64, v: f64) -> Vector3<f64> {
        Vector3::new((u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0)
    }

    /// Image coordinates of a camera-frame point; `None` at or behind the camera plane.
    #[inline]
    pub fn project(&self, x: &Vector3<f64>) -> Option<Vector2<f64>> {
        if x.z.is_nan() || x.z <= 0.0 {
            return None;
        }
        Some(Vector2::new(
            self.fx * x.x / x.z + self.cx,
            self.fy * x.y / x.z + self.cy,
        ))
    }
}

/// The integer pixel containing image coordinates `xy`, if inside a `width × height` image.
#[inline]
pub(crate) fn pixel_of(xy: &Vector2<f64>, width: u32, height: u32) -> Option<(u32, u32)> {
    if xy.x >= 0.0 && xy.y >= 0.0 && xy.x < width as f64 && xy.y < height as f64 {
        Some((xy.x as u32, xy.y as u32))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_is_valid_and_round_trips_toml() {
        let c = PlanemapConfig::default();
        c.validate().unwrap();
        let text = toml::to_string(&c).unwrap();
        let back: PlanemapConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
        let partial: PlanemapConfig = toml::from_str("lambda = 0.5\n").unwrap();
        assert_eq!(partial.lambda, 0.5);
        assert_eq!(partial.data_truncation, c.data_truncation);
    }

    #[test]
    fn validate_names_the_bad_field() {
        let c = PlanemapConfig {
            dominant_line_weight: 2.0,
            ..Default::default()
        };
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("dominant_line_weight"), "{e}");
        let c = PlanemapConfig {
            data_truncation: f64::NAN,
            ..Default::default()
        };
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("data_truncation"));
    }
}
