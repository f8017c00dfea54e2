//! planemap: piecewise-planar / Manhattan-world multi-view stereo for buildings.
//!
//! Calibrated photographs and sparse 3D points in; per-view planemaps (a plane label per
//! pixel), depth and normal maps, the list of planes and fused points out. It follows the
//! Manhattan-world stereo of Furukawa, Curless, Seitz and Szeliski (CVPR 2009), chapter 4 of
//! Furukawa & Hernández's *Multi-View Stereo: A Tutorial*; `papers.md` maps each paper to
//! its module.
//!
//! # Data flow
//!
//! ```text
//!  COLMAP model / PMVS ─► io ─► Scene { views, cloud }            (synth renders scenes
//!                                  │                               with ground truth)
//!                                  ▼
//!            scale R ─► normals ─► axes (dominant directions)
//!                                  ▼
//!            hypotheses: points (mean-shift) + photo sweep ─► plane list
//!                                  ▼   per view, in parallel
//!            planemap energy: data (visibility conflicts + photo) + smoothness (lines)
//!            [+ classify / nonplanar: the non-planar label]
//!                                  ▼
//!            α-expansion (planemap-solvers) ─► labels ─► depth / normal maps
//!                                  ▼
//!            hypotheses::creases ─► second labelling ─► pipeline::fuse ─► fused points
//! ```
//!
//! [`pipeline`] chains the stages ([`pipeline::prepare`], [`pipeline::label_view`],
//! [`pipeline::run`]); the command line calls the same functions.
//!
//! # Layout
//!
//! The modules come in three groups, in this order: the **core** every stage shares, the
//! **stages** in pipeline order, and the **harness** (scenes, scores, baselines, benchmark,
//! audits). A module imports only its own group and those before it, and there is no
//! import cycle (`tests/architecture.rs` checks both).
#![deny(missing_docs)]

// Core: the data every stage shares.
pub mod geometry;
pub mod raster;
pub mod scene;
pub mod io;
pub mod config;
pub mod progress;

// Stages, in pipeline order.
pub mod scale;
pub mod normals;
pub mod axes;
pub mod photo;
pub mod lines;
pub mod hypotheses;
pub mod planemap;
pub mod classify;
pub mod nonplanar;
pub mod sky;
pub mod pipeline;

// Harness: scenes, scores, baselines, the benchmark and audits; never imported by a stage.
pub mod synth;
pub mod workspace;
pub mod eval;
pub mod baselines;
pub mod bench;
pub mod info;
pub mod diag;

pub use geometry::{Camera, CameraModel, Plane, Rigid3};
pub use raster::ImageF32;
pub use scene::{Scene, SparseCloud, View};
