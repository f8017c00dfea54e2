//! The baselines planemap is compared with, used by the benchmark and the CLI only:
//!
//! - [`sweep`]: per-view plane-sweep stereo, winner takes all, over fronto-parallel planes
//!   and one family per dominant axis (Gallup et al. 2007) — the ordinary stereo that fails
//!   on texture-poor walls;
//! - [`delaunay`]: per-view Delaunay interpolation of the sparse points (OpenMVS's depth-map
//!   initialisation).

pub mod delaunay;
pub mod sweep;

pub use sweep::{scene_axes, sweep_view, sweep_view_with_axes};

use thiserror::Error;

use crate::photo::PhotoError;
use crate::scene::SceneError;

/// Errors of the baselines.
#[derive(Debug, Error)]
pub enum BaselineError {
    /// Photo-consistency failed.
    #[error("view {view:?}: {source}")]
    Photo {
        /// The view's image name.
        view: String,
        /// What failed.
        source: PhotoError,
    },
    /// An image could not be loaded.
    #[error(transparent)]
    Image(#[from] SceneError),
    /// A bad setting or inconsistent input (message says which).
    #[error("sweep baseline: {0}")]
    Config(String),
}

#[cfg(test)]
mod tests;
