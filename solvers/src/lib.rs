//! `planemap-solvers`: discrete optimisation for labelling problems.
//!
//! Max-flow / min-cut (Boykov–Kolmogorov, [`maxflow`]; [`maxflow::GridMaxFlow`] specialised
//! to 4-connected grids) and α-expansion graph cuts ([`Mrf::expansion`]), with α-β swap ([`Mrf::swap`]) and ICM ([`Mrf::icm`]) as baselines,
//! and the `.npy` exchange format ([`exchange`]) shared with other solvers. No geometry and
//! no images: usable by anyone labelling a graph.
//!
//! Costs are generic over [`Cost`] (`i32`, `i64`, `f32`, `f64`): integers are exact and
//! fastest; see [`cost`] for the trade-off and the scale convention.
//!
//! # Example: a plane-labelling grid
//!
//! A 4-connected `W × H` grid, `L` plane hypotheses, real-valued data costs pre-scaled to
//! integers, a label feasible only on part of the image, and a pixel-pair–dependent,
//! non-metric smoothness given as a closure.
//!
//! ```
//! use planemap_solvers::{Connectivity, DataCost, ExpansionConfig, Mrf, Smoothness};
//!
//! const SCALE: f64 = 1000.0; // integer cost units per unit of real cost
//! let (w, h, l) = (8usize, 6usize, 3usize);
//! // Real data costs: label 0 on the left half, 1 on the right, 2 nowhere good.
//! let data: Vec<i32> = (0..w * h)
//!     .flat_map(|p| {
//!         let left = p % w < w / 2;
//!         [if left { 0.1 } else { 0.9 }, if left { 0.9 } else { 0.1 }, 0.5]
//!     })
//!     .map(|c: f64| (c * SCALE).round() as i32)
//!     .collect();
//! // A truncated, non-metric "gap between planes" depending on the pixel pair.
//! let smooth = |p: usize, _q: usize, a: u32, b: u32| -> i32 {
//!     if a == b { 0 } else { ((0.3 + 0.01 * (p % 3) as f64).min(0.4) * SCALE) as i32 }
//! };
//! // Label 2 allowed on the top row only.
//! let top_row: Vec<u32> = (0..w as u32).collect();
//! let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))?
//!     .with_smoothness(Smoothness::Fn(Box::new(smooth)))?
//!     .with_feasible_sites(2, &top_row)?;
//! let initial = vec![2u32; w].into_iter().chain(vec![0; w * (h - 1)]).collect::<Vec<_>>();
//! let sol = mrf.expansion(&ExpansionConfig::default(), Some(&initial))?;
//! assert_eq!(sol.energy, mrf.energy(&sol.labels)?.total); // exact for integer costs
//! assert!(sol.energy <= sol.initial_energy);
//! assert_eq!(sol.labels[0], 0);
//! assert_eq!(sol.labels[w * h - 1], 1);
//! println!("energy {} in {} cycles", sol.energy as f64 / SCALE, sol.cycles.len());
//! # Ok::<(), planemap_solvers::MrfError>(())
//! ```
#![deny(missing_docs)]

pub mod cost;
pub mod exchange;
pub mod expansion;
mod icm;
pub mod maxflow;
mod moves;
pub mod mrf;
pub mod npy;
pub mod pyramid;
mod swap;

pub use cost::Cost;
pub use expansion::{ExpansionConfig, LabelOrder};
pub use maxflow::{Connectivity, GraphBuilder, MaxFlow};
pub use moves::{CycleStats, Solution};
pub use mrf::{DataCost, Energy, Mrf, MrfError, Smoothness};
pub use pyramid::{CoarseToFine, PyramidStats};
