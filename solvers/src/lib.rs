//! `planemap-solvers`: discrete optimisation for labelling problems.
//!
//! Max-flow / min-cut (Boykov–Kolmogorov) and α-expansion graph cuts, with α-β swap and ICM
//! as baselines. No geometry and no images: usable by anyone labelling a graph.
#![deny(missing_docs)]

pub mod cost;
pub mod maxflow;

pub use cost::Cost;
