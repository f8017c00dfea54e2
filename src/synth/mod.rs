//! Synthetic scenes with exact ground truth: scene specs (TOML), a ray-casting renderer and
//! SfM-like sparse sampling.
