//! planemap: piecewise-planar / Manhattan-world multi-view stereo.
//!
//! Calibrated photographs and sparse 3D points in; per-view planemaps (a plane label per
//! pixel), depth and normal maps, the list of planes and a planar mesh out. See `DESIGN.md`
//! in the project's shared notes for the data flow and conventions, and `papers.md` for the
//! papers each module implements.
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
pub mod hypotheses;
pub mod planemap;
pub mod classify;
pub mod nonplanar;
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
