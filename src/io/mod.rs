//! Readers and writers: COLMAP models, PMVS workspaces, PLY, PFM, PNG label maps, COLMAP
//! dense maps. Each reader takes `impl Read` and has a path wrapper beside it; errors name the
//! file and the line or byte offset.

pub mod atomic;
pub mod colmap;
pub mod dense;
pub mod labelpng;
pub mod names;
pub mod pfm;
pub mod ply;
pub mod pmvs;

pub use names::{check_image_names, output_stem, NameError};
