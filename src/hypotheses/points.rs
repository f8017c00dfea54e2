//! Plane hypotheses from the sparse points: 1D mean-shift of the offsets along each dominant
//! direction.
//!
//! Cost: offsets are sorted once per direction; with the flat kernel each mean-shift step is
//! two binary searches on prefix sums (O(log n)), so seeding from every point costs
//! O(n log n · iterations). The Gaussian kernel sums a ±3σ window per step and seeds from the
//! points thinned to one per quarter bandwidth, which keeps it near-linear.

use rayon::prelude::*;

use super::{HypothesesConfig, HypothesesError, HypothesesInput, Kernel, PlaneHypothesis};
use crate::geometry::Plane;

/// Sorted 1D samples with prefix sums for O(log n) window statistics.
pub(super) struct Offsets {
    x: Vec<f64>,
    prefix: Vec<f64>,
}

impl Offsets {
    pub(super) fn new(mut x: Vec<f64>) -> Self {
        x.sort_unstable_by(f64::total_cmp);
        let mut prefix = Vec::with_capacity(x.len() + 1);
        let mut s = 0.0;
        prefix.push(0.0);
        for v in &x {
            s += v;
            prefix.push(s);
        }
        Offsets { x, prefix }
    }

    /// Index range of the samples in `[lo, hi]`.
    fn range(&self, lo: f64, hi: f64) -> (usize, usize) {
        (
            self.x.partition_point(|&v| v < lo),
            self.x.partition_point(|&v| v <= hi),
        )
    }

    fn count(&self, c: f64, h: f64) -> usize {
        let (a, b) = self.range(c - h, c + h);
        b - a
    }

    /// One mean-shift step from `c`; `None` if the window is empty.
    fn shift(&self, c: f64, h: f64, kernel: Kernel) -> Option<f64> {
        match kernel {
            Kernel::Flat => {
                let (a, b) = self.range(c - h, c + h);
                (b > a).then(|| (self.prefix[b] - self.prefix[a]) / (b - a) as f64)
            }
            Kernel::Gaussian => {
                let (a, b) = self.range(c - 3.0 * h, c + 3.0 * h);
                let inv = 1.0 / (2.0 * h * h);
                let (mut w, mut s) = (0.0, 0.0);
                for &v in &self.x[a..b] {
                    let k = (-(v - c) * (v - c) * inv).exp();
                    w += k;
                    s += k * v;
                }
                (w > 0.0).then(|| s / w)
            }
        }
    }
}

/// The modes of the offset density with their supports (sorted by offset).
pub(super) fn mean_shift_modes(
    off: &Offsets,
    h: f64,
    kernel: Kernel,
    max_iter: usize,
) -> Vec<(f64, usize)> {
    if off.x.is_empty() {
        return Vec::new();
    }
    // Seeds: every point (flat) or points thinned to one per h/4 cell (Gaussian).
    let seeds: Vec<f64> = match kernel {
        Kernel::Flat => {
            let mut s = off.x.clone();
            s.dedup();
            s
        }
        Kernel::Gaussian => {
            let cell = h / 4.0;
            let mut s: Vec<f64> = Vec::new();
            let mut last = f64::NEG_INFINITY;
            for &v in &off.x {
                if v >= last + cell {
                    s.push(v);
                    last = v;
                }
            }
            s
        }
    };
    let tol = 1e-6 * h;
    let mut modes: Vec<f64> = seeds
        .par_iter()
        .map(|&s| {
            let mut c = s;
            for _ in 0..max_iter {
                match off.shift(c, h, kernel) {
                    Some(next) => {
                        let done = (next - c).abs() <= tol;
                        c = next;
                        if done {
                            break;
                        }
                    }
                    None => break,
                }
            }
            c
        })
        .collect();
    modes.sort_unstable_by(f64::total_cmp);
    // Dedupe: modes within h/2 of the first mode of a group are one peak; keep the member
    // with the largest support (ties: smallest offset).
    let mut out: Vec<(f64, usize)> = Vec::new();
    let mut i = 0;
    while i < modes.len() {
        let start = modes[i];
        let mut best = (start, off.count(start, h));
        let mut j = i + 1;
        let mut prev = start;
        while j < modes.len() && modes[j] - start <= h / 2.0 {
            if modes[j] != prev {
                let s = off.count(modes[j], h);
                if s > best.1 {
                    best = (modes[j], s);
                }
                prev = modes[j];
            }
            j += 1;
        }
        out.push(best);
        i = j;
    }
    out
}

/// Plane hypotheses along every dominant direction (see the module doc); those along an
/// extra direction made of points on Manhattan planes are dropped
/// ([`HypothesesConfig::max_shared_fraction`]).
pub fn plane_hypotheses(
    input: &HypothesesInput<'_>,
    config: &HypothesesConfig,
) -> Result<Vec<PlaneHypothesis>, HypothesesError> {
    config.validate()?;
    let n = input.positions.len();
    if input.normals.len() != n || input.confidence.len() != n {
        return Err(HypothesesError::Input(format!(
            "{n} positions, {} normals, {} confidences",
            input.normals.len(),
            input.confidence.len()
        )));
    }
    if !(input.scale > 0.0 && input.scale.is_finite()) {
        return Err(HypothesesError::Input(format!(
            "sampling scale {} must be positive and finite",
            input.scale
        )));
    }
    let h = config.bandwidth_r * input.scale;
    let cos_tol = config.normal_tolerance_deg.to_radians().cos();
    let min_support = config.effective_min_support(n);

    let mut hyps: Vec<PlaneHypothesis> = Vec::new();
    for (k, d) in input.axes.directions.iter().enumerate() {
        let len = d.norm();
        if !(len > 0.0 && len.is_finite()) {
            return Err(HypothesesError::Input(format!(
                "direction {k} is zero or not finite"
            )));
        }
        let d = d / len;
        let completed = k == 2
            && input
                .axes
                .warnings
                .iter()
                .any(|w| matches!(w, crate::axes::AxesWarning::CompletedThird(_)));
        let cos_k = if completed {
            if config.completed_axis_tolerance_deg <= 0.0 {
                continue;
            }
            config.completed_axis_tolerance_deg.to_radians().cos()
        } else {
            cos_tol
        };
        let offsets: Vec<f64> = (0..n)
            .filter(|&i| {
                input.confidence[i] >= config.min_confidence
                    && input.normals[i].dot(&d).abs() >= cos_k
                    && input.positions[i].iter().all(|v| v.is_finite())
            })
            .map(|i| d.dot(&input.positions[i]))
            .collect();
        let off = Offsets::new(offsets);
        for (offset, support) in mean_shift_modes(&off, h, config.kernel, config.max_iterations) {
            if support >= min_support {
                hyps.push(PlaneHypothesis {
                    id: 0,
                    plane: Plane { normal: d, offset },
                    axis: Some(k),
                    support,
                });
            }
        }
    }

    // Merge duplicates (near-identical directions and offsets): keep the better supported.
    let cos_merge = config.merge_angle_deg.to_radians().cos();
    let tol = config.merge_offset_r * input.scale;
    let mut order: Vec<usize> = (0..hyps.len()).collect();
    order.sort_by(|&a, &b| hyps[b].support.cmp(&hyps[a].support).then(a.cmp(&b)));
    let mut kept: Vec<usize> = Vec::new();
    for &i in &order {
        let dup = kept.iter().any(|&j| {
            let c = hyps[i].plane.normal.dot(&hyps[j].plane.normal);
            c.abs() >= cos_merge
                && (hyps[i].plane.offset - c.signum() * hyps[j].plane.offset).abs() < tol
        });
        if !dup {
            kept.push(i);
        }
    }
    kept.sort_unstable();
    let mut out: Vec<PlaneHypothesis> = kept.into_iter().map(|i| hyps[i].clone()).collect();
    if config.max_shared_fraction < 1.0 {
        let m = input.axes.num_manhattan;
        let manhattan: Vec<Plane> = out
            .iter()
            .filter(|h| h.axis.is_some_and(|k| k < m))
            .map(|h| h.plane)
            .collect();
        out.retain(|hyp| {
            if hyp.axis.is_none_or(|k| k < m) {
                return true;
            }
            let (mut own, mut shared) = (0usize, 0usize);
            for (p, nrm) in input.positions.iter().zip(input.normals) {
                let on_it = (hyp.plane.normal.dot(p) - hyp.plane.offset).abs() <= h
                    && nrm.dot(&hyp.plane.normal).abs() >= cos_tol;
                if on_it {
                    own += 1;
                    if manhattan
                        .iter()
                        .any(|q| (q.normal.dot(p) - q.offset).abs() <= h)
                    {
                        shared += 1;
                    }
                }
            }
            own == 0 || (shared as f64) <= config.max_shared_fraction * own as f64
        });
    }
    // Already ordered by direction then offset (modes come sorted per direction).
    for (id, h) in out.iter_mut().enumerate() {
        h.id = id as u32;
    }
    Ok(out)
}
