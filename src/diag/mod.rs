//! Audits (`planemap diag …`): tools that explain *why* a result is what it is, on a
//! `planemap synth` workspace (images, COLMAP model and ground truth):
//!
//! - [`energy`]: planemap's labelling against the best ground-truth-correct labelling under
//!   the same energy, split into visibility, photo and smoothness;
//! - [`heldout`]: existing runs scored on a real set's held-out points (the one audit on
//!   real photographs rather than a synthetic workspace);
//! - [`nonplanar`]: the data costs of the non-planar label against the cheapest plane on
//!   non-planar pixels whose sweep depth is right;
//! - [`sweep`]: the plane-sweep baseline's families and where its winner is wrong;
//! - [`votes`]: where the photo-consistency sweep for plane hypotheses votes;
//! - [`pixel`]: every offered label's data costs at chosen pixels (no ground truth needed);
//! - [`sky`]: the sky stage's mask against the ground truth's empty pixels;
//! - [`split`]: depth maps scored on planar and non-planar pixels, optionally inside a box.
//!
//! Each takes its options as a `clap` argument struct, loads the workspace with
//! [`Workspace::open`], and prints its findings to standard output.

pub mod energy;
pub mod heldout;
pub mod lines;
pub mod nonplanar;
pub mod pixel;
pub mod sky;
pub mod split;
pub mod sweep;
pub mod votes;

use std::path::{Path, PathBuf};

use crate::io::colmap::read_model;
use crate::io::output_stem;
use crate::io::pfm::{read_pfm_path, PfmError};
use crate::raster::ImageF32;
use crate::scene::{Scene, SceneError};

/// What an audit returns: any error, with its message naming what failed.
pub type DiagResult<T = ()> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// A `planemap synth` workspace as the audits read it: `sparse/`, `images/`, `gt/`.
pub struct Workspace {
    /// The workspace folder.
    pub root: PathBuf,
    /// Its model, undistorted, with image paths.
    pub scene: Scene,
}

impl Workspace {
    /// Reads `root/sparse` with the images in `root/images` and undistorts it.
    pub fn open(root: &Path) -> DiagResult<Workspace> {
        let scene = read_model(&root.join("sparse"))?
            .to_scene(Some(&root.join("images")))?
            .undistorted();
        Ok(Workspace {
            root: root.to_path_buf(),
            scene,
        })
    }

    /// The ground-truth folder.
    pub fn gt(&self) -> PathBuf {
        self.root.join("gt")
    }

    /// The views to audit: `views`, or all when empty; an index out of range is an error.
    pub fn views(&self, views: &[usize]) -> DiagResult<Vec<usize>> {
        let n = self.scene.views.len();
        if let Some(&bad) = views.iter().find(|&&v| v >= n) {
            return Err(format!("view {bad} out of range: the model has {n} views").into());
        }
        Ok(if views.is_empty() {
            (0..n).collect()
        } else {
            views.to_vec()
        })
    }

    /// Every view's image, undistorted.
    pub fn images(&self) -> Result<Vec<ImageF32>, SceneError> {
        self.scene
            .views
            .iter()
            .map(|v| v.load_undistorted_image())
            .collect()
    }

    /// `gt/KIND/STEM.pfm` of view `v` (`KIND`: depth or normals).
    pub fn gt_pfm(&self, kind: &str, v: usize) -> Result<ImageF32, PfmError> {
        let stem = output_stem(&self.scene.views[v].name);
        read_pfm_path(&self.gt().join(kind).join(format!("{stem}.pfm")))
    }

    /// `gt/planes.json`: the ground-truth planes.
    pub fn gt_planes(&self) -> DiagResult<Vec<crate::workspace::GtPlaneRecord>> {
        let path = self.gt().join("planes.json");
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?)
    }

    /// `gt/planes/STEM.png` of view `v`: the ground-truth plane id per pixel (0 = non-planar).
    pub fn gt_plane_ids(&self, v: usize) -> DiagResult<Vec<u16>> {
        let stem = output_stem(&self.scene.views[v].name);
        let (_, _, ids) = crate::io::labelpng::read_label_png(
            &self.gt().join("planes").join(format!("{stem}.png")),
        )?;
        Ok(ids)
    }
}
