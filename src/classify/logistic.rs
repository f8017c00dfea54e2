//! L2-regularised logistic regression, the linear classifier of the pair (Gallup et al., CVPR
//! 2010, §4 use a linear SVM; logistic regression gives the same kind of linear decision
//! boundary plus a calibrated probability, which the planemap label costs want).
//!
//! Training minimises the (class-weighted) mean log loss plus `(λ/2)·|w|²` by Newton's method
//! (iteratively reweighted least squares): each step solves `H Δ = g` with a Cholesky
//! factorisation of the `(d+1) × (d+1)` Hessian, with a backtracking line search so the loss
//! never rises. Inputs are standardised feature vectors.
//!
//! The design card names faer for this algebra; with minimal features faer still pulls in
//! gemm / nano-gemm / private-gemm-x86, which took over 12 minutes of a shared 2-core build
//! without finishing, for one `(d+1)²` = 46 × 46 Cholesky per Newton step. nalgebra (already
//! a dependency) factors that in microseconds, so it is used instead.

use nalgebra::{DMatrix, DVector};

use super::ClassifyError;

/// Training options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogisticConfig {
    /// L2 weight λ on the weights (not the bias).
    pub l2: f64,
    /// Maximal Newton iterations.
    pub max_iterations: u32,
    /// Stop when the loss decreases by less than this (relative).
    pub tolerance: f64,
    /// Weight the classes so each contributes half of the loss (for rare non-planar cells).
    pub balance_classes: bool,
}

impl Default for LogisticConfig {
    fn default() -> Self {
        LogisticConfig {
            l2: 1e-3,
            max_iterations: 50,
            tolerance: 1e-9,
            balance_classes: false,
        }
    }
}

/// A trained logistic model: `P(non-planar | z) = σ(w·z + b)`.
#[derive(Debug, Clone, PartialEq)]
pub struct LogisticClassifier {
    /// Weights, one per (standardised) feature.
    pub weights: Vec<f32>,
    /// Bias.
    pub bias: f32,
}

fn sigmoid(t: f64) -> f64 {
    if t >= 0.0 {
        1.0 / (1.0 + (-t).exp())
    } else {
        let e = t.exp();
        e / (1.0 + e)
    }
}

/// `ln(1 + e^t)` without overflow.
fn softplus(t: f64) -> f64 {
    if t > 0.0 {
        t + (-t).exp().ln_1p()
    } else {
        t.exp().ln_1p()
    }
}

impl LogisticClassifier {
    /// Probability of "non-planar" for a standardised feature vector.
    pub fn probability(&self, z: &[f32]) -> f32 {
        let t: f64 = self
            .weights
            .iter()
            .zip(z)
            .map(|(w, x)| *w as f64 * *x as f64)
            .sum::<f64>()
            + self.bias as f64;
        sigmoid(t) as f32
    }
}

/// Result of training: the model and the objective after each accepted Newton step
/// (`losses[0]` is at w = 0, b = 0).
#[derive(Debug, Clone)]
pub struct LogisticFit {
    /// The model.
    pub model: LogisticClassifier,
    /// Objective (weighted mean log loss + L2 term) per iteration.
    pub losses: Vec<f64>,
}

/// Objective at parameters `theta = [w…, b]`.
fn objective(x: &[f32], y: &[u8], sw: &[f64], theta: &[f64], l2: f64) -> f64 {
    let d = theta.len() - 1;
    let mut loss = 0.0;
    for (i, row) in x.chunks_exact(d).enumerate() {
        let t = row
            .iter()
            .zip(theta)
            .map(|(a, w)| *a as f64 * w)
            .sum::<f64>()
            + theta[d];
        // −log σ(t) for y = 1, −log(1 − σ(t)) for y = 0.
        loss += sw[i] * if y[i] == 1 { softplus(-t) } else { softplus(t) };
    }
    loss + 0.5 * l2 * theta[..d].iter().map(|w| w * w).sum::<f64>()
}

/// Trains on `x` (`y.len() × dim`, standardised, row-major) with labels `y` (1 = non-planar).
pub fn train_logistic(
    x: &[f32],
    y: &[u8],
    dim: usize,
    config: &LogisticConfig,
) -> Result<LogisticFit, ClassifyError> {
    let n = y.len();
    if n == 0 || dim == 0 || x.len() != n * dim {
        return Err(ClassifyError::InvalidInput(format!(
            "logistic: {} values for {n} labels of dimension {dim}",
            x.len()
        )));
    }
    if !(config.l2.is_finite() && config.l2 >= 0.0) {
        return Err(ClassifyError::InvalidConfig(format!(
            "logistic l2 = {} (want ≥ 0)",
            config.l2
        )));
    }
    let positives = y.iter().filter(|&&v| v == 1).count();
    // Sample weights summing to 1 (mean loss), optionally half per class.
    let sw: Vec<f64> = y
        .iter()
        .map(|&v| {
            if config.balance_classes && positives > 0 && positives < n {
                let count = if v == 1 { positives } else { n - positives };
                0.5 / count as f64
            } else {
                1.0 / n as f64
            }
        })
        .collect();
    let p = dim + 1;
    let mut theta = vec![0.0f64; p];
    let mut loss = objective(x, y, &sw, &theta, config.l2);
    let mut losses = vec![loss];
    for _ in 0..config.max_iterations {
        // Gradient g and Hessian H of the objective (bias = last coordinate, unregularised).
        let mut g = vec![0.0f64; p];
        let mut h = DMatrix::<f64>::zeros(p, p);
        for (i, row) in x.chunks_exact(dim).enumerate() {
            let t = row
                .iter()
                .zip(&theta)
                .map(|(a, w)| *a as f64 * w)
                .sum::<f64>()
                + theta[dim];
            let s = sigmoid(t);
            let r = sw[i] * (s - y[i] as f64);
            let c = sw[i] * s * (1.0 - s);
            for a in 0..p {
                let xa = if a < dim { row[a] as f64 } else { 1.0 };
                g[a] += r * xa;
                for b in 0..=a {
                    let xb = if b < dim { row[b] as f64 } else { 1.0 };
                    h[(a, b)] += c * xa * xb;
                }
            }
        }
        for a in 0..p {
            for b in 0..a {
                h[(b, a)] = h[(a, b)];
            }
        }
        for a in 0..dim {
            g[a] += config.l2 * theta[a];
            h[(a, a)] += config.l2;
        }
        // A tiny ridge keeps the factorisation defined on separable or degenerate data.
        const RIDGE: f64 = 1e-10;
        for a in 0..p {
            h[(a, a)] += RIDGE;
        }
        let llt = h.cholesky().ok_or_else(|| {
            ClassifyError::InvalidInput("logistic Hessian is not positive definite".into())
        })?;
        let step = llt.solve(&DVector::from_vec(g));
        // Backtracking: accept the largest of 1, 1/2, 1/4, … that lowers the objective.
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..30 {
            let cand: Vec<f64> = (0..p).map(|i| theta[i] - alpha * step[i]).collect();
            let l = objective(x, y, &sw, &cand, config.l2);
            if l <= loss {
                accepted = Some((cand, l));
                break;
            }
            alpha *= 0.5;
        }
        let Some((cand, l)) = accepted else { break };
        let converged = loss - l <= config.tolerance * loss.max(1e-300);
        theta = cand;
        loss = l;
        losses.push(loss);
        if converged {
            break;
        }
    }
    Ok(LogisticFit {
        model: LogisticClassifier {
            weights: theta[..dim].iter().map(|&w| w as f32).collect(),
            bias: theta[dim] as f32,
        },
        losses,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Two Gaussian blobs in `dim` dimensions separated along the first axis.
    fn blobs(n: usize, dim: usize, gap: f32, seed: u64) -> (Vec<f32>, Vec<u8>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut x = Vec::with_capacity(n * dim);
        let mut y = Vec::with_capacity(n);
        for i in 0..n {
            let label = (i % 2) as u8;
            for d in 0..dim {
                let noise = rng.random_range(-1.0f32..1.0);
                let centre = if d == 0 {
                    if label == 1 {
                        gap
                    } else {
                        -gap
                    }
                } else {
                    0.0
                };
                x.push(centre + noise);
            }
            y.push(label);
        }
        (x, y)
    }

    #[test]
    fn training_reduces_loss_and_separates_a_separable_set() {
        // Gap 1.5 > noise 1: the classes are separable along axis 0.
        let (x, y) = blobs(400, 5, 1.5, 3);
        let fit = train_logistic(&x, &y, 5, &LogisticConfig::default()).unwrap();
        assert!((fit.losses[0] - std::f64::consts::LN_2).abs() < 1e-12);
        for w in fit.losses.windows(2) {
            assert!(w[1] <= w[0], "loss rose: {:?}", fit.losses);
        }
        assert!(
            *fit.losses.last().unwrap() < 0.1,
            "final loss {:?}",
            fit.losses.last()
        );
        let errors = x
            .chunks_exact(5)
            .zip(&y)
            .filter(|(row, &l)| (fit.model.probability(row) > 0.5) as u8 != l)
            .count();
        assert_eq!(errors, 0);
        // The separating direction is axis 0.
        let w = &fit.model.weights;
        assert!(
            w[0] > 0.0 && w[1..].iter().all(|v| v.abs() < 0.2 * w[0]),
            "{w:?}"
        );
    }

    #[test]
    fn overlapping_classes_give_calibrated_middle_probabilities() {
        // Identical distributions: the model must predict ≈ the base rate everywhere.
        let (x, _) = blobs(1000, 3, 0.0, 5);
        let y: Vec<u8> = (0..1000).map(|i| (i % 4 == 0) as u8).collect();
        let fit = train_logistic(&x, &y, 3, &LogisticConfig::default()).unwrap();
        let p = fit.model.probability(&[0.0, 0.0, 0.0]);
        assert!((p - 0.25).abs() < 0.05, "p = {p}");
        // Balanced weighting moves the base rate to 1/2.
        let cfg = LogisticConfig {
            balance_classes: true,
            ..Default::default()
        };
        let fit = train_logistic(&x, &y, 3, &cfg).unwrap();
        let p = fit.model.probability(&[0.0, 0.0, 0.0]);
        assert!((p - 0.5).abs() < 0.05, "balanced p = {p}");
    }

    #[test]
    fn bad_shapes_are_errors() {
        assert!(train_logistic(&[0.0; 5], &[0, 1], 3, &LogisticConfig::default()).is_err());
        assert!(train_logistic(&[], &[], 3, &LogisticConfig::default()).is_err());
    }
}
