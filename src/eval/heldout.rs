//! Scores on real photographs, where the only ground truth is sparse: 3D points held out of
//! the input model (`heldout.json` beside a real set's `sparse/`), and what depth maps of
//! neighbouring views say about each other.
//!
//! - [`read_heldout`]: the held-out points, `[{id, xyz, obs: [[image, x, y], …]}]`, `x, y`
//!   in COLMAP pixel coordinates (the top-left pixel's centre at (0.5, 0.5));
//! - [`view_errors`]: each held-out observation's relative depth error in one view, read at
//!   the pixel that contains it (no interpolation: a depth edge must not blend two surfaces);
//! - [`HeldoutScores`]: within 1, 2 and 5 % and the median error, an observation without a
//!   depth counting as a miss (every held-out point lies on a surface);
//! - [`agreement`]: the share of the overlap of two views' depth maps where they agree;
//! - [`horizontal_share`]: the share of an image band (the bottom rows: paving) whose normals
//!   are horizontal planes', for the vertical [`crate::sky::scene_vertical`] gives.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use super::metrics::has_depth;
use super::EvalError;
use crate::scene::{Scene, View};

/// Relative depth thresholds of [`HeldoutScores::within`].
pub const HELDOUT_THRESHOLDS: [f64; 3] = [0.01, 0.02, 0.05];

/// A 3D point held out of the input model, with the images that observe it.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
pub struct HeldoutPoint {
    /// The point's id in the full model.
    pub id: u64,
    /// World position.
    pub xyz: [f64; 3],
    /// Observations: image name and COLMAP pixel coordinates.
    pub obs: Vec<(String, f64, f64)>,
}

/// Reads `heldout.json`. A malformed file is an error naming it, with the line and column
/// where the JSON parser stopped.
pub fn read_heldout(path: &Path) -> Result<Vec<HeldoutPoint>, EvalError> {
    let err = |message: String| EvalError::Heldout {
        path: path.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let points: Vec<HeldoutPoint> = serde_json::from_str(&text).map_err(|e| {
        err(format!(
            "expected a list of {{\"id\", \"xyz\": [x, y, z], \"obs\": [[image, x, y], …]}}: {e}"
        ))
    })?;
    for p in &points {
        if !p.xyz.iter().all(|c| c.is_finite())
            || !p.obs.iter().all(|(_, x, y)| x.is_finite() && y.is_finite())
        {
            return Err(err(format!("point {}: a coordinate is not finite", p.id)));
        }
    }
    Ok(points)
}

/// One held-out observation in a view: the world point and its COLMAP pixel coordinates.
pub type Observation = (Vector3<f64>, Vector2<f64>);

/// The held-out observations of each view of `scene` (by view index): world point and
/// pixel coordinates. Observations in images the scene does not have are counted in the
/// second value and left out.
pub fn observations_by_view(
    scene: &Scene,
    points: &[HeldoutPoint],
) -> (Vec<Vec<Observation>>, usize) {
    let index: HashMap<&str, usize> = scene
        .views
        .iter()
        .enumerate()
        .map(|(i, v)| (v.name.as_str(), i))
        .collect();
    let mut by_view = vec![Vec::new(); scene.views.len()];
    let mut unknown = 0;
    for p in points {
        let xyz = Vector3::from(p.xyz);
        for (name, x, y) in &p.obs {
            match index.get(name.as_str()) {
                Some(&i) => by_view[i].push((xyz, Vector2::new(*x, *y))),
                None => unknown += 1,
            }
        }
    }
    (by_view, unknown)
}

/// Relative depth error `|d − z| / z` of each observation in `view`, `z` the held-out
/// point's camera-frame depth and `d` the depth map's value at the pixel containing the
/// observation; `None` where the map has no depth there (or the observation falls outside
/// the image or behind the camera).
pub fn view_errors(view: &View, depth: &[f32], observations: &[Observation]) -> Vec<Option<f64>> {
    let (w, h) = (view.camera.width, view.camera.height);
    observations
        .iter()
        .map(|(xyz, xy)| {
            let z = (view.cam_from_world * Point3::from(*xyz)).z;
            if z <= 0.0 || !view.camera.contains(xy) {
                return None;
            }
            let (x, y) = (xy.x.floor() as u32, xy.y.floor() as u32);
            let d = *depth.get((y.min(h - 1) * w + x.min(w - 1)) as usize)?;
            has_depth(d).then(|| (d as f64 - z).abs() / z)
        })
        .collect()
}

/// Held-out observations scored at [`HELDOUT_THRESHOLDS`].
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct HeldoutScores {
    /// Observations scored.
    pub observations: usize,
    /// … of which the depth map gives a depth.
    pub with_depth: usize,
    /// … within each threshold of [`HELDOUT_THRESHOLDS`].
    pub within: [usize; 3],
    /// Median relative error over all observations, a missing depth counting as infinite
    /// (`None` when over half have none, or there are none).
    pub median_error: Option<f64>,
}

impl HeldoutScores {
    /// Scores a list of errors ([`view_errors`], possibly of several views).
    pub fn from_errors(errors: &[Option<f64>]) -> Self {
        let mut sorted: Vec<f64> = errors.iter().map(|e| e.unwrap_or(f64::INFINITY)).collect();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied();
        let mut within = [0; 3];
        for e in errors.iter().flatten() {
            for (k, t) in HELDOUT_THRESHOLDS.iter().enumerate() {
                within[k] += (*e <= *t) as usize;
            }
        }
        HeldoutScores {
            observations: errors.len(),
            with_depth: errors.iter().filter(|e| e.is_some()).count(),
            within,
            median_error: median.filter(|m| m.is_finite()),
        }
    }

    /// Share of the observations within threshold `k` of [`HELDOUT_THRESHOLDS`].
    pub fn share(&self, k: usize) -> f64 {
        self.within[k] as f64 / self.observations.max(1) as f64
    }
}

/// Pairs of neighbouring views, `(i, j)` with `i < j`: for each view the `k` views that
/// share the most sparse points with it (at least one), deduplicated.
pub fn neighbour_pairs(scene: &Scene, k: usize) -> Vec<(usize, usize)> {
    let n = scene.views.len();
    let mut shared = vec![0usize; n * n];
    for track in &scene.cloud.tracks {
        for (a, &i) in track.iter().enumerate() {
            for &j in &track[a + 1..] {
                let (i, j) = (i as usize, j as usize);
                if i < n && j < n && i != j {
                    shared[i * n + j] += 1;
                    shared[j * n + i] += 1;
                }
            }
        }
    }
    let mut pairs = std::collections::BTreeSet::new();
    for i in 0..n {
        let mut others: Vec<usize> = (0..n)
            .filter(|&j| j != i && shared[i * n + j] > 0)
            .collect();
        others.sort_by(|&a, &b| shared[i * n + b].cmp(&shared[i * n + a]).then(a.cmp(&b)));
        for &j in others.iter().take(k) {
            pairs.insert((i.min(j), i.max(j)));
        }
    }
    pairs.into_iter().collect()
}

/// How far two views' depth maps agree.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Agreement {
    /// Pixels of one view with a depth whose 3D point projects into the other view onto a
    /// pixel with a depth (both directions counted).
    pub overlap: u64,
    /// … of which the other view's depth there is within the tolerance of the point's depth
    /// in that view.
    pub agree: u64,
}

impl Agreement {
    /// `agree / overlap` (0 without overlap).
    pub fn share(&self) -> f64 {
        self.agree as f64 / self.overlap.max(1) as f64
    }
}

impl std::ops::Add for Agreement {
    type Output = Agreement;

    fn add(self, o: Agreement) -> Agreement {
        Agreement {
            overlap: self.overlap + o.overlap,
            agree: self.agree + o.agree,
        }
    }
}

/// Agreement of view `a`'s depth map with view `b`'s, one way: each pixel of `a` with a
/// depth is lifted to 3D and projected into `b`; where `b` has a depth at that pixel, they
/// agree when it is within `tolerance` (relative) of the point's depth in `b`. An occluded
/// point counts as disagreement: neighbouring views of a building see mostly the same
/// surfaces, and a depth map that agrees with none of its neighbours is wrong somewhere.
pub fn agreement_one_way(
    scene: &Scene,
    a: usize,
    depth_a: &[f32],
    b: usize,
    depth_b: &[f32],
    tolerance: f64,
) -> Agreement {
    let (va, vb) = (&scene.views[a], &scene.views[b]);
    let (wb, hb) = (vb.camera.width, vb.camera.height);
    let world_from_a = va.cam_from_world.inverse();
    let mut out = Agreement::default();
    for y in 0..va.camera.height {
        for x in 0..va.camera.width {
            let z = depth_a[(y * va.camera.width + x) as usize];
            if !has_depth(z) {
                continue;
            }
            let p = world_from_a * Point3::from(va.camera.pixel_ray(x, y) * z as f64);
            let Some((xy, zb)) = vb.project(&p.coords) else {
                continue;
            };
            if !vb.camera.contains(&xy) {
                continue;
            }
            let (u, v) = (
                (xy.x.floor() as u32).min(wb - 1),
                (xy.y.floor() as u32).min(hb - 1),
            );
            let d = depth_b[(v * wb + u) as usize];
            if !has_depth(d) {
                continue;
            }
            out.overlap += 1;
            out.agree += ((d as f64 - zb).abs() <= tolerance * zb) as u64;
        }
    }
    out
}

/// [`agreement_one_way`] both ways, summed.
pub fn agreement(
    scene: &Scene,
    a: usize,
    depth_a: &[f32],
    b: usize,
    depth_b: &[f32],
    tolerance: f64,
) -> Agreement {
    agreement_one_way(scene, a, depth_a, b, depth_b, tolerance)
        + agreement_one_way(scene, b, depth_b, a, depth_a, tolerance)
}

/// [`agreement`] summed over `pairs` of views, skipping pairs where either view has no
/// depth map (`depths[i]` is view `i`'s, or `None`). Pairs are scored in parallel; the sum
/// does not depend on the thread count.
pub fn pooled_agreement(
    scene: &Scene,
    pairs: &[(usize, usize)],
    depths: &[Option<&[f32]>],
    tolerance: f64,
) -> Agreement {
    use rayon::prelude::*;
    pairs
        .par_iter()
        .filter_map(|&(a, b)| Some(agreement(scene, a, depths[a]?, b, depths[b]?, tolerance)))
        .reduce(Agreement::default, |x, y| x + y)
}

/// Largest angle between a pixel's normal and the vertical for it to count as horizontal in
/// [`horizontal_share`], degrees: paving slopes to drain, and cameras pitch.
pub const HORIZONTAL_MAX_DEG: f64 = 15.0;

/// Share of the pixels of the bottom `rows_fraction` of a view's rows, among those with a
/// normal, whose world normal is within [`HORIZONTAL_MAX_DEG`] of `up`: how much of the
/// ground (in sets whose bottom rows are paving) is labelled with a horizontal plane.
/// Returns (horizontal, with a normal).
pub fn horizontal_share(
    view: &View,
    normals_cam: &[[f32; 3]],
    up: &Vector3<f64>,
    rows_fraction: f64,
) -> (u64, u64) {
    let (w, h) = (view.camera.width, view.camera.height);
    let first = h - ((h as f64 * rows_fraction).round() as u32).min(h);
    let cos = HORIZONTAL_MAX_DEG.to_radians().cos();
    let world_from_cam = view.cam_from_world.rotation.inverse();
    let (mut horizontal, mut total) = (0, 0);
    for y in first..h {
        for x in 0..w {
            let n = normals_cam[(y * w + x) as usize];
            let n = Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64);
            let Some(n) = n.try_normalize(1e-9) else {
                continue;
            };
            total += 1;
            horizontal += ((world_from_cam * n).dot(up).abs() >= cos) as u64;
        }
    }
    (horizontal, total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Camera, Rigid3};
    use crate::scene::{SparseCloud, View};

    fn scene_of(views: Vec<View>, tracks: Vec<Vec<u32>>) -> Scene {
        let n = tracks.len();
        Scene {
            views,
            cloud: SparseCloud {
                positions: vec![Vector3::zeros(); n],
                colors: vec![[0; 3]; n],
                normals: None,
                tracks,
                errors: vec![0.0; n],
                confidence: vec![1.0; n],
            },
        }
    }

    fn view(name: &str, tx: f64) -> View {
        View {
            id: 1,
            name: name.into(),
            camera: Camera::pinhole(40, 30, 40.0, 40.0, 20.0, 15.0),
            cam_from_world: Rigid3::translation(tx, 0.0, 0.0),
            image_path: None,
        }
    }

    #[test]
    fn an_observation_is_read_at_the_pixel_that_contains_it() {
        let v = view("a.png", 0.0);
        // A wall at z = 4 with one pixel at 4.03 (0.75 % off) and one with no depth.
        let mut depth = vec![4.0f32; 40 * 30];
        depth[10 * 40 + 21] = 4.03;
        depth[20 * 40 + 5] = 0.0;
        let obs = [
            (Vector3::new(0.0, 0.0, 4.0), Vector2::new(20.5, 15.5)), // pixel (20, 15)
            (Vector3::new(0.0, 0.0, 4.0), Vector2::new(21.9, 10.1)), // pixel (21, 10)
            (Vector3::new(0.0, 0.0, 4.0), Vector2::new(5.2, 20.7)),  // no depth
            (Vector3::new(0.0, 0.0, 4.0), Vector2::new(40.2, 3.0)),  // outside
        ];
        let e = view_errors(&v, &depth, &obs);
        assert_eq!(e[0], Some(0.0));
        assert!((e[1].unwrap() - 0.0075).abs() < 1e-6, "{e:?}");
        assert_eq!((e[2], e[3]), (None, None));
        let s = HeldoutScores::from_errors(&e);
        assert_eq!(s.observations, 4);
        assert_eq!(s.with_depth, 2);
        assert_eq!(s.within, [2, 2, 2]);
        // Two of four are missing: the median (index 2) is infinite, so none.
        assert_eq!(s.median_error, None);
        let s = HeldoutScores::from_errors(&e[..3]);
        assert!((s.median_error.unwrap() - 0.0075).abs() < 1e-6);
    }

    #[test]
    fn neighbours_are_the_views_sharing_most_points() {
        let views = vec![view("a", 0.0), view("b", 1.0), view("c", 2.0)];
        let tracks = vec![vec![0, 1], vec![0, 1], vec![1, 2], vec![0, 2]];
        let s = scene_of(views, tracks);
        // View 2 shares one point with each: the tie goes to the lower index.
        assert_eq!(neighbour_pairs(&s, 1), vec![(0, 1), (0, 2)]);
        assert_eq!(neighbour_pairs(&s, 2), vec![(0, 1), (0, 2), (1, 2)]);
    }

    #[test]
    fn two_views_of_one_wall_agree_and_a_wrong_map_does_not() {
        // Camera b is shifted 0.5 to the left of a (x_cam = x_world + tx): both see z = 5.
        let s = scene_of(vec![view("a", 0.0), view("b", 0.5)], vec![]);
        let wall = vec![5.0f32; 40 * 30];
        let a = agreement(&s, 0, &wall, 1, &wall, 0.01);
        assert!(a.overlap > 1500, "{a:?}");
        assert_eq!(a.agree, a.overlap);
        let wrong = vec![5.2f32; 40 * 30];
        let b = agreement(&s, 0, &wall, 1, &wrong, 0.01);
        assert!(b.overlap > 1500);
        assert_eq!(b.agree, 0);
    }

    #[test]
    fn the_ground_is_counted_in_the_bottom_rows() {
        let v = view("a", 0.0);
        let up = Vector3::new(0.0, -1.0, 0.0); // image y points down
        let mut normals = vec![[0.0f32, 0.0, -1.0]; 40 * 30]; // facing the camera: a wall
        for px in &mut normals[27 * 40..28 * 40] {
            *px = [0.0, -1.0, 0.0]; // a floor, one row
        }
        for px in &mut normals[29 * 40..30 * 40] {
            *px = [0.0; 3]; // no normal
        }
        // Bottom 10 %: rows 27, 28, 29.
        assert_eq!(horizontal_share(&v, &normals, &up, 0.1), (40, 80));
    }

    #[test]
    fn a_malformed_heldout_file_names_where() {
        let dir = std::env::temp_dir().join(format!("pm-heldout-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("heldout.json");
        std::fs::write(&path, "[{\"id\": 1, \"xyz\": [1, 2],\n \"obs\": []}]").unwrap();
        let e = read_heldout(&path).unwrap_err().to_string();
        assert!(e.contains("heldout.json") && e.contains("line 1"), "{e}");
        std::fs::write(
            &path,
            "[{\"id\": 1, \"xyz\": [1, 2, 3], \"obs\": [[\"a.jpg\", 1.5, 2]]}]",
        )
        .unwrap();
        let p = read_heldout(&path).unwrap();
        assert_eq!(p[0].obs, vec![("a.jpg".to_string(), 1.5, 2.0)]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
