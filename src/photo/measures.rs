//! Photo-consistency measures between a reference patch and a warped patch (tutorial §2.1).
//!
//! A patch is the support window around a pixel, `(2r+1)²` pixels stored row-major with
//! `channels` interleaved values per pixel. A sample that is not available — the window
//! reached outside the reference image, or the warped pixel fell outside the neighbour image
//! or behind its camera — is stored as `NaN` and left out of every measure, so a partial
//! window is scored on the pixels it has. A measure returns `None` when too little is left
//! to score (or, for NCC, a patch has no texture): that is "no evidence", which
//! [`Normalization`](super::Normalization) turns into the outlier cost 1.
//!
//! | measure | support window? | invariant to (tutorial table) |
//! |---|---|---|
//! | SSD, SAD | no | nothing |
//! | NCC | yes | gain and bias |
//! | Census | yes | any strictly increasing map (so gain and bias) |
//! | Rank | yes | any strictly increasing map |
//! | MI | yes | any bijection of the quantised grey levels |
//!
//! Every function here returns a *dissimilarity*-style raw score through [`raw_cost`]
//! (0 = identical), the form the normalisations expect.

use serde::{Deserialize, Serialize};

/// Per-sample variance (in squared intensity units, intensities in `[0, 1]`) below which a
/// patch counts as textureless for NCC: `1e-6` is a standard deviation of 0.001 ≈ a quarter
/// of one 8-bit grey level. NCC of such a patch is dominated by quantisation noise.
pub const NCC_MIN_VARIANCE: f64 = 1e-6;

/// Largest number of grey-level bins mutual information may use (its joint histogram lives
/// on the stack: `MAX_MI_BINS²` counters).
pub const MAX_MI_BINS: usize = 32;

/// The photo-consistency measures of the tutorial's table (§2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Measure {
    /// Sum of squared differences, reported as the mean over samples (so thresholds do not
    /// depend on the window size); units: squared intensity.
    Ssd,
    /// Sum of absolute differences, reported as the mean over samples; units: intensity
    /// (`1/255` = one 8-bit level).
    Sad,
    /// Normalised cross-correlation; raw cost `1 − NCC ∈ [0, 2]`.
    Ncc,
    /// Census transform (bit string "darker than the centre pixel") compared by Hamming
    /// distance; raw cost = fraction of differing bits, in `[0, 1]`.
    Census,
    /// Rank: every sample replaced by its rank within its window, compared by mean absolute
    /// rank difference (Spearman's footrule); raw cost in `[0, 1]`.
    Rank,
    /// Mutual information of the quantised intensities; raw cost
    /// `1 − 2·MI/(H(a)+H(b)) ∈ [0, 1]` (one minus the symmetric uncertainty).
    MutualInformation,
}

impl Measure {
    /// Whether the dense sweep evaluates this measure from box sums in O(1) per pixel
    /// (SSD, SAD, NCC) rather than by visiting every window sample.
    pub fn is_box_decomposable(self) -> bool {
        matches!(self, Measure::Ssd | Measure::Sad | Measure::Ncc)
    }
}

/// Mean squared difference over the samples present in both patches.
pub fn ssd(a: &[f32], b: &[f32]) -> Option<f32> {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        if x.is_finite() && y.is_finite() {
            let d = (x - y) as f64;
            sum += d * d;
            n += 1;
        }
    }
    (n > 0).then(|| (sum / n as f64) as f32)
}

/// Mean absolute difference over the samples present in both patches.
pub fn sad(a: &[f32], b: &[f32]) -> Option<f32> {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        if x.is_finite() && y.is_finite() {
            sum += (x - y).abs() as f64;
            n += 1;
        }
    }
    (n > 0).then(|| (sum / n as f64) as f32)
}

/// Whether every channel of pixel `i` is present in both patches.
#[inline]
fn pixel_present(a: &[f32], b: &[f32], i: usize, channels: usize) -> bool {
    (0..channels).all(|c| a[i * channels + c].is_finite() && b[i * channels + c].is_finite())
}

/// Normalised cross-correlation in `[-1, 1]` over the pixels present (all channels) in both
/// patches. Colour follows the tutorial: the mean is subtracted per channel, but the
/// channels are concatenated into one vector for the variance, so a gain must be common to
/// all channels while a bias may differ per channel. `None` with fewer than two pixels or
/// when either patch is textureless (per-sample variance below [`NCC_MIN_VARIANCE`]).
pub fn ncc(a: &[f32], b: &[f32], channels: usize) -> Option<f32> {
    if channels == 0 || channels > 4 {
        return None;
    }
    let npix = a.len().min(b.len()) / channels;
    let mut sa = [0.0f64; 4];
    let mut sb = [0.0f64; 4];
    let mut n = 0usize;
    for i in 0..npix {
        if pixel_present(a, b, i, channels) {
            for c in 0..channels {
                sa[c] += a[i * channels + c] as f64;
                sb[c] += b[i * channels + c] as f64;
            }
            n += 1;
        }
    }
    if n < 2 {
        return None;
    }
    let inv_n = 1.0 / n as f64;
    let (mut cov, mut va, mut vb) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..npix {
        if pixel_present(a, b, i, channels) {
            for c in 0..channels {
                let da = a[i * channels + c] as f64 - sa[c] * inv_n;
                let db = b[i * channels + c] as f64 - sb[c] * inv_n;
                cov += da * db;
                va += da * da;
                vb += db * db;
            }
        }
    }
    ncc_from_moments(cov, va, vb, n * channels)
}

/// NCC from centred second moments summed over `samples` values; shared by the patch
/// function and the box-sum path so both apply the same texture threshold.
#[inline]
pub(crate) fn ncc_from_moments(cov: f64, va: f64, vb: f64, samples: usize) -> Option<f32> {
    ncc_from_weighted_moments(cov, va, vb, samples as f64)
}

/// [`ncc_from_moments`] for weighted moments: `weight` is the samples' total weight (the
/// weighted path's texture threshold is the same per unit of weight).
#[inline]
pub(crate) fn ncc_from_weighted_moments(cov: f64, va: f64, vb: f64, weight: f64) -> Option<f32> {
    let min = NCC_MIN_VARIANCE * weight;
    if !(va > min && vb > min) {
        return None;
    }
    Some((cov / (va * vb).sqrt()).clamp(-1.0, 1.0) as f32)
}

/// Census: for each channel, each window pixel contributes the bit "darker than the centre
/// pixel"; the score is the fraction of bits that differ between the patches, over the pixels
/// present in both. `None` if a centre value is missing or nothing is left to compare.
/// The patch must be square with an odd side (the centre is pixel `len/2`).
pub fn census(a: &[f32], b: &[f32], channels: usize) -> Option<f32> {
    if channels == 0 {
        return None;
    }
    let npix = a.len().min(b.len()) / channels;
    let centre = npix / 2;
    let (mut differ, mut total) = (0usize, 0usize);
    for c in 0..channels {
        let ca = a[centre * channels + c];
        let cb = b[centre * channels + c];
        if !(ca.is_finite() && cb.is_finite()) {
            return None;
        }
        for i in (0..npix).filter(|&i| i != centre) {
            let (x, y) = (a[i * channels + c], b[i * channels + c]);
            if x.is_finite() && y.is_finite() {
                differ += usize::from((x < ca) != (y < cb));
                total += 1;
            }
        }
    }
    (total > 0).then(|| differ as f32 / total as f32)
}

/// Rank: within each patch and channel, each sample present in both patches is replaced by
/// the number of such samples strictly below it, divided by `count − 1`; the score is the
/// mean absolute difference of these ranks (Spearman's footrule), in `[0, 1]`. Only the
/// order of intensities matters, so any strictly increasing map leaves it unchanged.
/// `None` with fewer than two common samples in every channel.
pub fn rank(a: &[f32], b: &[f32], channels: usize) -> Option<f32> {
    if channels == 0 {
        return None;
    }
    let npix = a.len().min(b.len()) / channels;
    let (mut sum, mut terms) = (0.0f64, 0usize);
    for c in 0..channels {
        let present = |i: usize| a[i * channels + c].is_finite() && b[i * channels + c].is_finite();
        let count = (0..npix).filter(|&i| present(i)).count();
        if count < 2 {
            continue;
        }
        let scale = 1.0 / (count - 1) as f64;
        for i in (0..npix).filter(|&i| present(i)) {
            let (x, y) = (a[i * channels + c], b[i * channels + c]);
            let (mut ra, mut rb) = (0usize, 0usize);
            for j in (0..npix).filter(|&j| present(j)) {
                ra += usize::from(a[j * channels + c] < x);
                rb += usize::from(b[j * channels + c] < y);
            }
            sum += (ra as f64 - rb as f64).abs() * scale;
            terms += 1;
        }
    }
    (terms > 0).then(|| (sum / terms as f64) as f32)
}

/// The bin of intensity `v ∈ [0, 1]` among `bins` equal bins (values outside are clamped).
#[inline]
pub fn mi_bin(v: f32, bins: usize) -> usize {
    ((v * bins as f32) as isize).clamp(0, bins as isize - 1) as usize
}

/// Mutual information (nats) and the two marginal entropies of the quantised intensities
/// over the samples present in both patches (colour channels concatenated into one sample
/// set). `None` with no common samples or `bins` outside `2..=MAX_MI_BINS`.
pub fn mutual_information(a: &[f32], b: &[f32], bins: usize) -> Option<(f32, f32, f32)> {
    if !(2..=MAX_MI_BINS).contains(&bins) {
        return None;
    }
    let mut joint = [0u32; MAX_MI_BINS * MAX_MI_BINS];
    let mut n = 0u32;
    for (&x, &y) in a.iter().zip(b) {
        if x.is_finite() && y.is_finite() {
            joint[mi_bin(x, bins) * bins + mi_bin(y, bins)] += 1;
            n += 1;
        }
    }
    if n == 0 {
        return None;
    }
    let inv_n = 1.0 / n as f64;
    let mut pa = [0.0f64; MAX_MI_BINS];
    let mut pb = [0.0f64; MAX_MI_BINS];
    for i in 0..bins {
        for j in 0..bins {
            let p = joint[i * bins + j] as f64 * inv_n;
            pa[i] += p;
            pb[j] += p;
        }
    }
    let entropy = |p: &[f64]| -> f64 { p.iter().filter(|&&v| v > 0.0).map(|&v| -v * v.ln()).sum() };
    let (ha, hb) = (entropy(&pa[..bins]), entropy(&pb[..bins]));
    let mut mi = 0.0f64;
    for i in 0..bins {
        for j in 0..bins {
            let p = joint[i * bins + j] as f64 * inv_n;
            if p > 0.0 {
                mi += p * (p / (pa[i] * pb[j])).ln();
            }
        }
    }
    Some((mi.max(0.0) as f32, ha as f32, hb as f32))
}

/// The raw dissimilarity of `measure` between two patches (0 = identical; see [`Measure`]
/// for each one's range and units). `mi_bins` is only used by mutual information.
pub fn raw_cost(
    measure: Measure,
    a: &[f32],
    b: &[f32],
    channels: usize,
    mi_bins: usize,
) -> Option<f32> {
    match measure {
        Measure::Ssd => ssd(a, b),
        Measure::Sad => sad(a, b),
        Measure::Ncc => ncc(a, b, channels).map(|v| 1.0 - v),
        Measure::Census => census(a, b, channels),
        Measure::Rank => rank(a, b, channels),
        Measure::MutualInformation => {
            let (mi, ha, hb) = mutual_information(a, b, mi_bins)?;
            let h = ha + hb;
            // Two constant patches share no information to measure.
            (h > 0.0).then(|| (1.0 - 2.0 * mi / h).clamp(0.0, 1.0))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_patch(seed: u64, len: usize) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..len).map(|_| rng.random::<f32>()).collect()
    }

    #[test]
    fn ssd_and_sad_are_zero_on_identity_and_see_a_bias() {
        let a = random_patch(1, 49);
        assert_eq!(ssd(&a, &a), Some(0.0));
        assert_eq!(sad(&a, &a), Some(0.0));
        let b: Vec<f32> = a.iter().map(|v| v + 0.1).collect();
        assert!((sad(&a, &b).unwrap() - 0.1).abs() < 1e-6);
        assert!((ssd(&a, &b).unwrap() - 0.01).abs() < 1e-6);
    }

    #[test]
    fn ncc_is_invariant_to_gain_and_bias() {
        let a = random_patch(2, 49);
        let c = random_patch(3, 49);
        let base = ncc(&a, &c, 1).unwrap();
        assert!(base.abs() < 0.9, "unrelated patches correlate: {base}");
        let c2: Vec<f32> = c.iter().map(|v| 0.4 * v + 0.3).collect();
        assert!((ncc(&a, &c2, 1).unwrap() - base).abs() < 1e-5);
        let a2: Vec<f32> = a.iter().map(|v| 1.7 * v - 0.2).collect();
        assert!((ncc(&a2, &a, 1).unwrap() - 1.0).abs() < 1e-6);
        // A negative gain flips the sign.
        let a3: Vec<f32> = a.iter().map(|v| 0.9 - 0.5 * v).collect();
        assert!((ncc(&a3, &a, 1).unwrap() + 1.0).abs() < 1e-6);
    }

    #[test]
    fn colour_ncc_subtracts_per_channel_means_with_one_joint_variance() {
        let a = random_patch(4, 49 * 3);
        let c = random_patch(5, 49 * 3);
        let base = ncc(&a, &c, 3).unwrap();
        // A different bias per channel and one common gain: unchanged.
        let biased: Vec<f32> = c
            .iter()
            .enumerate()
            .map(|(i, v)| 0.5 * v + [0.1, -0.3, 0.25][i % 3])
            .collect();
        assert!((ncc(&a, &biased, 3).unwrap() - base).abs() < 1e-5);
        // A different gain per channel changes the joint variance: not invariant, unlike
        // per-channel NCC averaged (which would be).
        let gains: Vec<f32> = a
            .iter()
            .enumerate()
            .map(|(i, v)| v * [1.0, 0.2, 3.0][i % 3])
            .collect();
        let self_score = ncc(&a, &gains, 3).unwrap();
        assert!(
            self_score < 0.99,
            "per-channel gains left colour NCC at {self_score}"
        );
        // Checked against the formula written out: per-channel means, one joint variance.
        let mut mean = [[0.0f64; 3]; 2];
        for i in 0..49 {
            for ch in 0..3 {
                mean[0][ch] += a[i * 3 + ch] as f64 / 49.0;
                mean[1][ch] += c[i * 3 + ch] as f64 / 49.0;
            }
        }
        let (mut cov, mut va, mut vc) = (0.0, 0.0, 0.0);
        for i in 0..49 {
            for ch in 0..3 {
                let da = a[i * 3 + ch] as f64 - mean[0][ch];
                let dc = c[i * 3 + ch] as f64 - mean[1][ch];
                cov += da * dc;
                va += da * da;
                vc += dc * dc;
            }
        }
        assert!((base as f64 - cov / (va * vc).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn ncc_rejects_textureless_patches() {
        let a = random_patch(6, 49);
        let flat = vec![0.5f32; 49];
        assert_eq!(ncc(&a, &flat, 1), None);
        assert_eq!(raw_cost(Measure::Ncc, &flat, &a, 1, 16), None);
    }

    #[test]
    fn missing_samples_are_left_out() {
        let a = random_patch(7, 49);
        let b = random_patch(8, 49);
        let mut a_holes = a.clone();
        let mut b_holes = b.clone();
        let holes = [0usize, 5, 6, 30, 48];
        for &i in &holes {
            a_holes[i] = f32::NAN;
        }
        b_holes[17] = f32::NAN;
        let keep: Vec<usize> = (0..49).filter(|i| !holes.contains(i) && *i != 17).collect();
        let a_kept: Vec<f32> = keep.iter().map(|&i| a[i]).collect();
        let b_kept: Vec<f32> = keep.iter().map(|&i| b[i]).collect();
        for m in [
            Measure::Ssd,
            Measure::Sad,
            Measure::Ncc,
            Measure::Rank,
            Measure::MutualInformation,
        ] {
            let with_holes = raw_cost(m, &a_holes, &b_holes, 1, 8).unwrap();
            let compact = raw_cost(m, &a_kept, &b_kept, 1, 8).unwrap();
            assert!(
                (with_holes - compact).abs() < 1e-6,
                "{m:?}: {with_holes} vs {compact}"
            );
        }
        // Census needs its centre.
        let mut centre_missing = a.clone();
        centre_missing[24] = f32::NAN;
        assert_eq!(census(&centre_missing, &b, 1), None);
        // Nothing in common: no score at all.
        let none = vec![f32::NAN; 49];
        for m in [
            Measure::Ssd,
            Measure::Sad,
            Measure::Ncc,
            Measure::Census,
            Measure::Rank,
            Measure::MutualInformation,
        ] {
            assert_eq!(raw_cost(m, &a, &none, 1, 8), None, "{m:?}");
        }
    }

    #[test]
    fn census_and_rank_are_invariant_to_monotone_maps() {
        for channels in [1usize, 3] {
            let a = random_patch(9, 49 * channels);
            let b = random_patch(10, 49 * channels);
            let census0 = census(&a, &b, channels).unwrap();
            let rank0 = rank(&a, &b, channels).unwrap();
            assert!(
                census0 > 0.2 && rank0 > 0.1,
                "unrelated patches matched: {census0} {rank0}"
            );
            // Strictly increasing but far from affine (NCC is not invariant to it).
            let warp: Vec<f32> = b.iter().map(|v| 0.05 + 0.9 * v.powi(3)).collect();
            assert_eq!(census(&a, &warp, channels).unwrap(), census0);
            assert_eq!(rank(&a, &warp, channels).unwrap(), rank0);
            let self_warp: Vec<f32> = a.iter().map(|v| v.sqrt() * 0.5 + 0.2).collect();
            assert_eq!(census(&a, &self_warp, channels), Some(0.0));
            assert_eq!(rank(&a, &self_warp, channels), Some(0.0));
            let ncc_raw = raw_cost(
                Measure::Ncc,
                &a,
                &a.iter().map(|v| v.powi(3)).collect::<Vec<_>>(),
                channels,
                16,
            )
            .unwrap();
            assert!(ncc_raw > 1e-3, "NCC should notice a cubic map ({ncc_raw})");
            // A decreasing map inverts every bit / rank.
            let inverted: Vec<f32> = a.iter().map(|v| 1.0 - v).collect();
            assert!(census(&a, &inverted, channels).unwrap() > 0.99);
        }
    }

    #[test]
    fn mutual_information_is_invariant_to_a_bijective_remap() {
        let bins = 8usize;
        let a = random_patch(11, 225);
        // b depends on a (noisy), so MI is clearly positive.
        let noise = random_patch(12, 225);
        let b: Vec<f32> = a
            .iter()
            .zip(&noise)
            .map(|(x, n)| (0.8 * x + 0.2 * n).min(0.999))
            .collect();
        let (mi0, _, _) = mutual_information(&a, &b, bins).unwrap();
        let cost0 = raw_cost(Measure::MutualInformation, &a, &b, 1, bins).unwrap();
        assert!(mi0 > 0.2, "MI {mi0}");
        // Shuffle the grey levels of b: a bijection that is not monotone.
        let perm = [5usize, 2, 7, 0, 3, 6, 1, 4];
        let remapped: Vec<f32> = b
            .iter()
            .map(|&v| (perm[mi_bin(v, bins)] as f32 + 0.5) / bins as f32)
            .collect();
        let (mi1, _, _) = mutual_information(&a, &remapped, bins).unwrap();
        assert!((mi0 - mi1).abs() < 1e-6, "{mi0} vs {mi1}");
        assert!(
            (cost0 - raw_cost(Measure::MutualInformation, &a, &remapped, 1, bins).unwrap()).abs()
                < 1e-6
        );
        // NCC and census are not invariant to it.
        let ncc0 = ncc(&a, &b, 1).unwrap();
        let ncc1 = ncc(&a, &remapped, 1).unwrap();
        assert!((ncc0 - ncc1).abs() > 0.1, "{ncc0} vs {ncc1}");
        // Identical patches: cost 0; independent ones: cost near 1.
        assert!(raw_cost(Measure::MutualInformation, &a, &a, 1, bins).unwrap() < 1e-6);
        assert!(raw_cost(Measure::MutualInformation, &a, &noise, 1, bins).unwrap() > 0.7);
    }
}
