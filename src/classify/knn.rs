//! k-nearest-neighbour planar / non-planar classifier (one of the two classifiers Gallup et
//! al., CVPR 2010, §4 report as working alike).
//!
//! The model keeps a (deterministically subsampled) set of standardised training feature
//! vectors and their labels in a k-d tree (kiddo); the probability of "non-planar" for a query
//! is the fraction of non-planar labels among its `k` nearest training vectors (Euclidean in
//! standardised feature space). Ties at equal distance are broken by training index, so the
//! answer does not depend on the tree's traversal order.

use std::num::NonZeroUsize;

use kiddo::{ImmutableKdTree, SquaredEuclidean};

use super::features::FEATURE_DIM;
use super::ClassifyError;

/// Extra neighbours asked of the tree so that ties at the k-th distance are broken by index.
const TIE_SLACK: usize = 4;

/// A kNN classifier over standardised feature vectors.
pub struct KnnClassifier {
    /// Number of neighbours that vote.
    pub k: u32,
    /// Training vectors, `labels.len() × FEATURE_DIM`, row-major, already standardised.
    pub samples: Vec<f32>,
    /// 1 = non-planar, 0 = planar, one per training vector.
    pub labels: Vec<u8>,
    tree: ImmutableKdTree<f32, FEATURE_DIM>,
}

impl std::fmt::Debug for KnnClassifier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KnnClassifier")
            .field("k", &self.k)
            .field("samples", &self.labels.len())
            .finish()
    }
}

impl Clone for KnnClassifier {
    fn clone(&self) -> Self {
        // The tree is a pure function of the samples.
        KnnClassifier::new(self.k, self.samples.clone(), self.labels.clone())
            .expect("a valid classifier clones into a valid one")
    }
}

impl PartialEq for KnnClassifier {
    fn eq(&self, other: &Self) -> bool {
        self.k == other.k && self.labels == other.labels && self.samples == other.samples
    }
}

impl KnnClassifier {
    /// Builds the classifier (and its k-d tree) from standardised samples and 0/1 labels.
    pub fn new(k: u32, samples: Vec<f32>, labels: Vec<u8>) -> Result<Self, ClassifyError> {
        if k == 0 {
            return Err(ClassifyError::InvalidConfig("knn k = 0 (want ≥ 1)".into()));
        }
        if labels.is_empty() || samples.len() != labels.len() * FEATURE_DIM {
            return Err(ClassifyError::InvalidInput(format!(
                "knn: {} samples values for {} labels (want labels × {FEATURE_DIM}, ≥ 1 label)",
                samples.len(),
                labels.len()
            )));
        }
        if let Some(i) = labels.iter().position(|&l| l > 1) {
            return Err(ClassifyError::InvalidInput(format!(
                "knn: label {} at sample {i} (want 0 or 1)",
                labels[i]
            )));
        }
        if samples.iter().any(|v| !v.is_finite()) {
            return Err(ClassifyError::InvalidInput(
                "knn: non-finite training value".into(),
            ));
        }
        let points: Vec<[f32; FEATURE_DIM]> = samples
            .chunks_exact(FEATURE_DIM)
            .map(|c| {
                let mut p = [0.0f32; FEATURE_DIM];
                p.copy_from_slice(c);
                p
            })
            .collect();
        let tree = ImmutableKdTree::new_from_slice(&points)
            .map_err(|e| ClassifyError::InvalidInput(format!("knn tree: {e}")))?;
        Ok(KnnClassifier {
            k,
            samples,
            labels,
            tree,
        })
    }

    /// Number of training vectors.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// No training vectors (never true for a constructed classifier).
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// The `k` nearest training indices of `z` (standardised), nearest first, ties by index.
    pub fn neighbours(&self, z: &[f32; FEATURE_DIM]) -> Vec<(f32, u32)> {
        let k = (self.k as usize).min(self.len());
        let want = NonZeroUsize::new(k + TIE_SLACK).unwrap_or(NonZeroUsize::MIN);
        let mut nbrs: Vec<(f32, u32)> = self
            .tree
            .query(z)
            .nearest_n::<SquaredEuclidean<f32>>(want)
            .execute()
            .into_iter()
            .map(|q| (q.distance, q.item))
            .collect();
        nbrs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        nbrs.truncate(k);
        nbrs
    }

    /// Probability of "non-planar": fraction of non-planar labels among the `k` nearest.
    pub fn probability(&self, z: &[f32; FEATURE_DIM]) -> f32 {
        let nbrs = self.neighbours(z);
        let votes = nbrs
            .iter()
            .filter(|(_, i)| self.labels[*i as usize] == 1)
            .count();
        votes as f32 / nbrs.len().max(1) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn brute_force(samples: &[f32], z: &[f32], k: usize) -> Vec<(f32, u32)> {
        let mut all: Vec<(f32, u32)> = samples
            .chunks_exact(FEATURE_DIM)
            .enumerate()
            .map(|(i, s)| {
                let d: f32 = s.iter().zip(z).map(|(a, b)| (a - b) * (a - b)).sum();
                (d, i as u32)
            })
            .collect();
        all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        all.truncate(k);
        all
    }

    #[test]
    fn knn_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 600;
        let samples: Vec<f32> = (0..n * FEATURE_DIM)
            .map(|_| rng.random_range(-2.0f32..2.0))
            .collect();
        let labels: Vec<u8> = (0..n).map(|i| (i % 3 == 0) as u8).collect();
        let knn = KnnClassifier::new(9, samples.clone(), labels.clone()).unwrap();
        for _ in 0..40 {
            let mut z = [0.0f32; FEATURE_DIM];
            z.iter_mut()
                .for_each(|v| *v = rng.random_range(-2.0f32..2.0));
            let got = knn.neighbours(&z);
            let want = brute_force(&samples, &z, 9);
            let got_idx: Vec<u32> = got.iter().map(|g| g.1).collect();
            let want_idx: Vec<u32> = want.iter().map(|g| g.1).collect();
            assert_eq!(got_idx, want_idx);
            for (g, w) in got.iter().zip(&want) {
                assert!((g.0 - w.0).abs() <= 1e-4 * w.0.max(1.0));
            }
            let p = knn.probability(&z);
            let votes = want_idx
                .iter()
                .filter(|&&i| labels[i as usize] == 1)
                .count();
            assert_eq!(p, votes as f32 / 9.0);
        }
    }

    #[test]
    fn ties_are_broken_by_index() {
        // Four identical samples: the 2 nearest must be indices 0 and 1.
        let samples = vec![1.0f32; 4 * FEATURE_DIM];
        let knn = KnnClassifier::new(2, samples, vec![1, 1, 0, 0]).unwrap();
        let z = [1.0f32; FEATURE_DIM];
        let n: Vec<u32> = knn.neighbours(&z).iter().map(|x| x.1).collect();
        assert_eq!(n, vec![0, 1]);
        assert_eq!(knn.probability(&z), 1.0);
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(KnnClassifier::new(0, vec![0.0; FEATURE_DIM], vec![0]).is_err());
        assert!(KnnClassifier::new(3, vec![0.0; FEATURE_DIM + 1], vec![0]).is_err());
        assert!(KnnClassifier::new(3, vec![0.0; FEATURE_DIM], vec![2]).is_err());
        assert!(KnnClassifier::new(3, vec![], vec![]).is_err());
    }
}
