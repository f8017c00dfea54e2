//! 3D line segments from the images (Sinha, Steedly & Szeliski, ICCV 2009, §3): line
//! segments per view ([`detect`]), each assigned to the dominant direction whose vanishing
//! point it points at, matched across views and triangulated along that direction
//! ([`triangulate`]). Plain walls carry no sparse point but are bounded by edges; the
//! hypotheses stage turns these 3D lines into planes ([`crate::hypotheses::lines`]).

pub mod detect;
pub mod triangulate;

pub use detect::{detect_segments, DetectParams, Segment};
pub use triangulate::{triangulate_lines, Line3, LineSet};

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::scene::View;

/// Settings of the line stage: detection, vanishing directions, matching.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LinesConfig {
    /// The detector's angle tolerance τ in degrees, in (0, 90): LSD's 22.5°, not tuned.
    pub angle_tolerance_deg: f64,
    /// log10 of the false alarms accepted per image, ≤ 0 is strict: LSD's 0, not tuned.
    pub log_eps: f64,
    /// Segments shorter than this fraction of the image diagonal are not matched, in [0, 1):
    /// short segments are mostly texture (brick joints) and triangulate poorly.
    pub min_length_fraction: f64,
    /// A segment points at a dominant direction's vanishing point when its endpoints are
    /// within this many pixels (> 0) of the line from its midpoint to the vanishing point
    /// ...
    pub vanishing_tolerance_px: f64,
    /// ... or within this angle in degrees (> 0) of it, whichever is looser.
    pub vanishing_tolerance_deg: f64,
    /// A segment with at least `crowd_count` (≥ 1) segments of its direction beside it,
    /// overlapping half its length within `crowd_distance_px` (≥ 0) across, is not matched:
    /// repeated edges (book spines, brick courses) match each other as well as themselves.
    pub crowd_count: usize,
    /// See `crowd_count`.
    pub crowd_distance_px: f64,
    /// Views a segment is matched against: the reference view's best neighbours for
    /// matching ([`crate::photo::select_neighbours`]), a count ≥ 1.
    pub neighbours: usize,
    /// A candidate 3D line is confirmed in a view when its projection lies within this many
    /// pixels (> 0) of a segment of the same direction there.
    pub match_tolerance_px: f64,
    /// Views (the reference and its match included) that must see a 3D line, a count ≥ 2.
    /// A pair of segments of the same direction always triangulates to some line; a third
    /// view is a test, but on the development scenes lines seen in exactly three views were
    /// often wrong (repeated edges): 4 raised the share within 1 % from 41–74 % to 56–100 %
    /// (docs/notes/hypotheses.md#planes-from-3d-lines).
    pub min_views: usize,
    /// ... and at least this fraction (in [0, 1]) of the views it projects into (in front,
    /// long enough to be tested): a wrong pair in a dense grid of parallel edges (window
    /// mullions) lands on some edge in a few views by chance, a true line in most.
    pub min_confirmed_fraction: f64,
    /// Two back-projection planes closer than this angle (degrees, > 0) do not triangulate.
    pub min_angle_deg: f64,
    /// A line whose position standard deviation across the views exceeds this many R
    /// (> 0) is dropped.
    pub max_sigma_r: f64,
}

impl Default for LinesConfig {
    fn default() -> Self {
        LinesConfig {
            angle_tolerance_deg: 22.5,
            log_eps: 0.0,
            min_length_fraction: 0.04,
            vanishing_tolerance_px: 1.0,
            vanishing_tolerance_deg: 1.0,
            crowd_count: 2,
            crowd_distance_px: 6.0,
            neighbours: 6,
            match_tolerance_px: 1.5,
            min_views: 4,
            min_confirmed_fraction: 0.7,
            min_angle_deg: 2.0,
            max_sigma_r: 2.0,
        }
    }
}

impl LinesConfig {
    /// Checks the fields; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.angle_tolerance_deg > 0.0 && self.angle_tolerance_deg < 90.0) {
            return Err(format!(
                "lines.angle_tolerance_deg = {} must be in (0, 90)",
                self.angle_tolerance_deg
            ));
        }
        if !self.log_eps.is_finite() {
            return Err("lines.log_eps must be finite".into());
        }
        if !(0.0..1.0).contains(&self.min_length_fraction) {
            return Err(format!(
                "lines.min_length_fraction = {} must be in [0, 1)",
                self.min_length_fraction
            ));
        }
        for (name, v) in [
            ("vanishing_tolerance_px", self.vanishing_tolerance_px),
            ("vanishing_tolerance_deg", self.vanishing_tolerance_deg),
            ("match_tolerance_px", self.match_tolerance_px),
            ("min_angle_deg", self.min_angle_deg),
            ("max_sigma_r", self.max_sigma_r),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("lines.{name} = {v} must be positive and finite"));
            }
        }
        if self.crowd_count == 0 || self.crowd_distance_px.is_nan() || self.crowd_distance_px < 0.0
        {
            return Err("lines.crowd_count must be ≥ 1 and lines.crowd_distance_px ≥ 0".into());
        }
        if self.neighbours == 0 {
            return Err("lines.neighbours must be ≥ 1".into());
        }
        if !(0.0..=1.0).contains(&self.min_confirmed_fraction) {
            return Err(format!(
                "lines.min_confirmed_fraction = {} must be in [0, 1]",
                self.min_confirmed_fraction
            ));
        }
        if self.min_views < 2 {
            return Err("lines.min_views must be ≥ 2".into());
        }
        Ok(())
    }

    /// The detector's parameters.
    pub fn detect_params(&self) -> DetectParams {
        DetectParams {
            angle_tolerance_deg: self.angle_tolerance_deg,
            log_eps: self.log_eps,
        }
    }
}

/// The index of the direction in `directions` (unit, world frame) whose vanishing point in
/// `view` segment `s` points at, if any (the closest within the tolerances). A direction
/// that a camera looks along has its vanishing point in the image; one parallel to the image
/// plane has it at infinity, and the test compares directions there.
pub fn vanishing_direction(
    view: &View,
    s: &Segment,
    directions: &[Vector3<f64>],
    cfg: &LinesConfig,
) -> Option<usize> {
    let k = view.camera.k_matrix();
    let r = view.cam_from_world.rotation;
    let m = s.midpoint();
    let half = 0.5 * s.length();
    if half <= 0.0 {
        return None;
    }
    let seg_dir = [
        (s.b[0] - s.a[0]) / (2.0 * half),
        (s.b[1] - s.a[1]) / (2.0 * half),
    ];
    let tol = (cfg.vanishing_tolerance_px / half)
        .atan()
        .max(cfg.vanishing_tolerance_deg.to_radians());
    let mut best: Option<(usize, f64)> = None;
    for (i, d) in directions.iter().enumerate() {
        let v = k * (r * d);
        // Direction from the midpoint toward the vanishing point (v.z = 0: at infinity).
        let (dx, dy) = (v.x - v.z * m[0], v.y - v.z * m[1]);
        let n = dx.hypot(dy);
        if n < 1e-12 {
            continue;
        }
        let sin = ((seg_dir[0] * dy - seg_dir[1] * dx) / n).abs();
        let angle = sin.clamp(0.0, 1.0).asin();
        if angle <= tol && best.is_none_or(|(_, a)| angle < a) {
            best = Some((i, angle));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};

    #[test]
    fn segments_are_assigned_to_the_direction_they_point_at() {
        let view = View {
            id: 1,
            name: "v".into(),
            camera: Camera::pinhole(320, 240, 300.0, 300.0, 160.0, 120.0),
            cam_from_world: look_at(
                &Vector3::new(1.0, -8.0, 1.5),
                &Vector3::new(3.0, 0.0, 1.5),
                &Vector3::z(),
            ),
            image_path: None,
        };
        let dirs = [Vector3::x(), Vector3::y(), Vector3::z()];
        let cfg = LinesConfig::default();
        for (k, d) in dirs.iter().enumerate() {
            // A 3D segment along d at a point in view, projected.
            let p = Vector3::new(3.0, 0.0, 1.0);
            let (a, _) = view.project(&(p - 0.5 * d)).unwrap();
            let (b, _) = view.project(&(p + 0.5 * d)).unwrap();
            let s = Segment {
                a: [a.x, a.y],
                b: [b.x, b.y],
                width: 1.0,
                significance: 10.0,
                gradient: 0.2,
            };
            assert_eq!(vanishing_direction(&view, &s, &dirs, &cfg), Some(k), "{d}");
            // Turned by 5° in the image: no direction.
            let (c, sn) = (5f64.to_radians().cos(), 5f64.to_radians().sin());
            let m = s.midpoint();
            let (hx, hy) = (s.b[0] - m[0], s.b[1] - m[1]);
            let turned = Segment {
                a: [m[0] - (c * hx - sn * hy), m[1] - (sn * hx + c * hy)],
                b: [m[0] + (c * hx - sn * hy), m[1] + (sn * hx + c * hy)],
                ..s
            };
            // (Short segments near their vanishing point keep a wider tolerance.)
            if s.length() > 40.0 {
                assert_ne!(vanishing_direction(&view, &turned, &dirs, &cfg), Some(k));
            }
        }
    }

    #[test]
    fn invalid_settings_are_named() {
        let mut c = LinesConfig::default();
        assert!(c.validate().is_ok());
        c.min_views = 1;
        assert!(c.validate().unwrap_err().contains("min_views"));
        let c = LinesConfig {
            match_tolerance_px: 0.0,
            ..LinesConfig::default()
        };
        assert!(c.validate().unwrap_err().contains("match_tolerance_px"));
    }
}
