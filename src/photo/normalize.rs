//! Normalisation of raw photo-consistency scores into costs in `[0, 1]` (tutorial §2.1).
//!
//! The tutorial asks for a sigmoid-like shape: a flat inlier plateau near 0, a steep ramp at
//! the threshold separating inliers from outliers, and a flat outlier plateau at 1, so that
//! measures can be tuned with one parameter and combined with each other (and with the
//! planemap's visibility term). "No evidence" (a measure returning `None`) maps to 1.

use super::measures::Measure;
use super::PhotoError;
use serde::{Deserialize, Serialize};

/// SAD inlier bound of the tutorial: mean absolute differences below 5 levels of 255.
pub const SAD_INLIER: f32 = 5.0 / 255.0;
/// SAD outlier bound of the tutorial: mean absolute differences above 10 levels of 255.
pub const SAD_OUTLIER: f32 = 10.0 / 255.0;
/// NCC below `1/√2` is "not accurate enough and discarded" (tutorial); as a raw cost
/// `1 − NCC` the outlier bound is `1 − 1/√2 ≈ 0.293`.
pub const NCC_OUTLIER: f32 = 1.0 - std::f32::consts::FRAC_1_SQRT_2;

/// A map from a raw dissimilarity (`≥ 0`, 0 = identical) to a cost in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Normalization {
    /// `1 − exp(−raw / scale)`: no hard threshold, `scale` is where the cost reaches
    /// `1 − 1/e ≈ 0.63`.
    Exponential {
        /// Raw score (measure units) at which the cost is `1 − 1/e`; `> 0`.
        scale: f64,
    },
    /// `min(raw / threshold, 1)`: linear up to the outlier bound, then flat.
    TruncatedLinear {
        /// Raw score (measure units) from which a match counts as an outlier (cost 1); `> 0`.
        threshold: f64,
    },
    /// Cost 0 up to `inlier`, 1 from `outlier`, the smooth step `3t² − 2t³` between: the
    /// tutorial's two plateaus and steep ramp.
    SmoothStep {
        /// Raw score (measure units) below which a match is a certain inlier (cost 0); `≥ 0`.
        inlier: f64,
        /// Raw score (measure units) above which a match is a certain outlier (cost 1);
        /// `> inlier`.
        outlier: f64,
    },
}

impl Normalization {
    /// The default for a measure. SAD and SSD use the tutorial's thresholds (inliers below
    /// 5/255, outliers above 10/255, squared for SSD); NCC is truncated linear in `1 − NCC`
    /// at the tutorial's `1/√2`. The tutorial gives no figures for Census, Rank and MI: their
    /// outlier bounds are the raw score of two unrelated random windows (≈ 0.5 of the census
    /// bits flip; mean rank difference ≈ 1/3; symmetric uncertainty ≈ 0 so `1 − SU ≈ 1`),
    /// so a cost below 1 means "better than chance".
    pub fn default_for(measure: Measure) -> Self {
        match measure {
            Measure::Sad => Normalization::SmoothStep {
                inlier: SAD_INLIER as f64,
                outlier: SAD_OUTLIER as f64,
            },
            Measure::Ssd => Normalization::SmoothStep {
                inlier: (SAD_INLIER * SAD_INLIER) as f64,
                outlier: (SAD_OUTLIER * SAD_OUTLIER) as f64,
            },
            Measure::Ncc => Normalization::TruncatedLinear {
                threshold: NCC_OUTLIER as f64,
            },
            Measure::Census => Normalization::TruncatedLinear { threshold: 0.5 },
            Measure::Rank => Normalization::TruncatedLinear {
                threshold: (1.0f32 / 3.0) as f64,
            },
            Measure::MutualInformation => Normalization::TruncatedLinear { threshold: 1.0 },
        }
    }

    /// Checks the parameters (finite, positive, ordered).
    pub fn validate(&self) -> Result<(), PhotoError> {
        let bad = |what: &str| Err(PhotoError::InvalidConfig(format!("normalisation: {what}")));
        match *self {
            Normalization::Exponential { scale } if !(scale.is_finite() && scale > 0.0) => bad(
                &format!("exponential scale must be finite and > 0, got {scale}"),
            ),
            Normalization::TruncatedLinear { threshold }
                if !(threshold.is_finite() && threshold > 0.0) =>
            {
                bad(&format!(
                    "truncated-linear threshold must be finite and > 0, got {threshold}"
                ))
            }
            Normalization::SmoothStep { inlier, outlier }
                if !(inlier.is_finite()
                    && outlier.is_finite()
                    && inlier >= 0.0
                    && outlier > inlier) =>
            {
                bad(&format!(
                    "smooth step needs 0 <= inlier < outlier (finite), got {inlier} and {outlier}"
                ))
            }
            _ => Ok(()),
        }
    }

    /// The cost in `[0, 1]` of a raw dissimilarity; `None` (no evidence) and NaN give 1.
    #[inline]
    pub fn cost(&self, raw: Option<f32>) -> f32 {
        match raw {
            Some(r) if !r.is_nan() => self.apply(r),
            _ => 1.0,
        }
    }

    /// The cost in `[0, 1]` of a raw dissimilarity `raw` (negative values count as 0).
    #[inline]
    pub fn apply(&self, raw: f32) -> f32 {
        // The settings are f64 like every setting; the costs are f32.
        let r = raw.max(0.0);
        match *self {
            Normalization::Exponential { scale } => 1.0 - (-r / scale as f32).exp(),
            Normalization::TruncatedLinear { threshold } => (r / threshold as f32).min(1.0),
            Normalization::SmoothStep { inlier, outlier } => {
                let (inlier, outlier) = (inlier as f32, outlier as f32);
                let t = ((r - inlier) / (outlier - inlier)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sad_default_has_the_tutorial_plateaus() {
        let n = Normalization::default_for(Measure::Sad);
        n.validate().unwrap();
        assert_eq!(n.apply(0.0), 0.0);
        assert_eq!(n.apply(4.9 / 255.0), 0.0);
        assert_eq!(n.apply(10.1 / 255.0), 1.0);
        let mid = n.apply(7.5 / 255.0);
        assert!((mid - 0.5).abs() < 1e-5, "ramp midpoint {mid}");
        // Monotone along the ramp.
        let mut last = 0.0;
        for i in 0..=100 {
            let c = n.apply(i as f32 * 0.15 / 255.0);
            assert!(c >= last && (0.0..=1.0).contains(&c));
            last = c;
        }
    }

    #[test]
    fn ncc_default_discards_below_one_over_root_two() {
        let n = Normalization::default_for(Measure::Ncc);
        let cost_of_ncc = |v: f32| n.apply(1.0 - v);
        assert_eq!(cost_of_ncc(1.0), 0.0);
        assert_eq!(cost_of_ncc(0.70), 1.0);
        assert_eq!(cost_of_ncc(-0.5), 1.0);
        assert!(cost_of_ncc(0.72) < 1.0);
        assert!((cost_of_ncc(0.85) - 0.15 / NCC_OUTLIER).abs() < 1e-5);
    }

    #[test]
    fn exponential_and_missing_evidence() {
        let n = Normalization::Exponential { scale: 0.2 };
        assert!((n.apply(0.2) - (1.0 - (-1.0f32).exp())).abs() < 1e-6);
        assert_eq!(n.cost(None), 1.0);
        assert_eq!(n.cost(Some(f32::NAN)), 1.0);
        assert_eq!(n.cost(Some(-1.0)), 0.0);
    }

    #[test]
    fn bad_parameters_are_rejected() {
        assert!(Normalization::Exponential { scale: 0.0 }
            .validate()
            .is_err());
        assert!(Normalization::TruncatedLinear {
            threshold: f64::NAN
        }
        .validate()
        .is_err());
        let err = Normalization::SmoothStep {
            inlier: 0.2,
            outlier: 0.1,
        }
        .validate()
        .unwrap_err();
        assert!(err.to_string().contains("inlier < outlier"), "{err}");
        for m in [
            Measure::Ssd,
            Measure::Sad,
            Measure::Ncc,
            Measure::Census,
            Measure::Rank,
            Measure::MutualInformation,
        ] {
            Normalization::default_for(m).validate().unwrap();
        }
    }
}
