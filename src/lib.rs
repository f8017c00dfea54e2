//! planemap: piecewise-planar / Manhattan-world multi-view stereo.
//!
//! Calibrated photographs and sparse 3D points in; per-view planemaps (a plane label per
//! pixel), depth and normal maps, the list of planes and a planar mesh out. See `DESIGN.md`
//! in the project's shared notes for the data flow and conventions, and `papers.md` for the
//! papers each module implements.
#![deny(missing_docs)]

pub mod axes;
pub mod baseline;
pub mod bench;
pub mod classify;
pub mod eval;
pub mod geometry;
pub mod hypotheses;
pub mod info;
pub mod io;
pub mod normals;
pub mod photo;
pub mod pipeline;
pub mod planemap;
pub mod progress;
pub mod raster;
pub mod scale;
pub mod scene;
pub mod synth;
pub mod workspace;

pub use geometry::{Camera, CameraModel, Plane, Rigid3};
pub use raster::ImageF32;
pub use scene::{Scene, SparseCloud, View};
