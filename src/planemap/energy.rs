//! [`PlanemapEnergy`]: one view's MRF, ready for α-expansion.
//!
//! `E(h) = Σ_p D_p(h_p) + λ Σ_(p,q) w_pq V_pq(h_p, h_q)` over the 4-connected grid (each
//! unordered pair once: right and down neighbours). Labels seen by the solver are *local*
//! indices `0..labels.len()`; `labels[a]` is the global plane index of local label `a`.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::{
    data_costs, dominant_line_weights, prune_labels, EdgeWeights, PlanemapConfig, PlanemapError,
    Smoothness, ViewInputs,
};
use crate::geometry::Plane;

/// One view's energy: unary costs, edge weights and what V needs.
#[derive(Debug, Clone)]
pub struct PlanemapEnergy {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Global plane index of each local label.
    pub labels: Vec<u32>,
    /// Data costs D, `unary[pixel * labels.len() + local_label]`, pixel = y·width + x.
    pub unary: Vec<f32>,
    /// Smoothness weights w_pq (dominant lines).
    pub weights: EdgeWeights,
    /// The smoothness term V (per-label camera-frame planes).
    pub smoothness: Smoothness,
    /// λ, the smoothness weight.
    pub lambda: f32,
    /// World-frame plane of each local label.
    pub planes: Vec<Plane>,
    /// The least V (units of R) of a label change between pixels without an image edge
    /// ([`PlanemapConfig::crease_cost`]).
    pub crease: f32,
}

impl PlanemapEnergy {
    /// Builds the energy of the target view: prunes the labels, computes D, the dominant-line
    /// weights and V's per-label planes.
    pub fn build(inputs: &ViewInputs, config: &PlanemapConfig) -> Result<Self, PlanemapError> {
        let labels = prune_labels(inputs, config)?;
        Self::with_labels(inputs, &labels, config)
    }

    /// Builds the energy for a given label set (global plane indices).
    pub fn with_labels(
        inputs: &ViewInputs,
        labels: &[u32],
        config: &PlanemapConfig,
    ) -> Result<Self, PlanemapError> {
        let unary = data_costs(inputs, labels, config)?;
        let view = inputs.view();
        let weights = dominant_line_weights(
            inputs.image,
            &view.camera,
            &view.cam_from_world,
            inputs.dominant_directions,
            config,
        )?;
        let planes: Vec<Plane> = labels.iter().map(|&l| inputs.planes[l as usize]).collect();
        let smoothness = Smoothness::new(
            &view.camera,
            &view.cam_from_world,
            &planes,
            inputs.scale,
            config.smoothness_truncation,
        );
        Ok(PlanemapEnergy {
            width: view.camera.width,
            height: view.camera.height,
            labels: labels.to_vec(),
            unary,
            weights,
            smoothness,
            lambda: config.lambda as f32,
            planes,
            crease: config.crease_cost as f32,
        })
    }

    /// Number of local labels.
    pub fn num_labels(&self) -> usize {
        self.labels.len()
    }

    /// Number of pixels (`width · height`).
    pub fn num_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// D_p(a) for pixel `p` and local label `a`.
    #[inline]
    pub fn unary(&self, p: usize, a: u32) -> f32 {
        self.unary[p * self.labels.len() + a as usize]
    }

    /// The pairwise term λ·w_pq·max(V_pq(a, b), crease) for 4-neighbours `p`, `q` and
    /// local labels (crease = [`Self::crease_floor`]): the closure to hand to α-expansion.
    /// The floor keeps the term a truncated metric in (a, b) for a fixed pair when it is at
    /// most the truncation: max(d, c) of a metric d and a constant c over distinct labels is
    /// a metric.
    #[inline]
    pub fn pairwise(&self, p: usize, q: usize, a: u32, b: u32) -> f32 {
        if a == b {
            return 0.0;
        }
        let v = self.smoothness.cost(p, q, a, b);
        self.lambda * self.weights.between(p, q) * v.max(self.crease_floor(p, q))
    }

    /// The least V (units of R) a label change between `p` and `q` pays: the crease cost
    /// where no image edge passes through either pixel, 0 where one does.
    #[inline]
    pub fn crease_floor(&self, p: usize, q: usize) -> f32 {
        if self.weights.edge_between(p, q) {
            0.0
        } else {
            self.crease
        }
    }

    /// λ·V_pq(a, b) without the edge weight: the closure for a solver that applies the
    /// weights [`EdgeWeights::interleaved`] itself (then `w · smoothness_term` = `pairwise`
    /// up to f32 rounding).
    #[inline]
    pub fn smoothness_term(&self, p: usize, q: usize, a: u32, b: u32) -> f32 {
        if a == b {
            return 0.0;
        }
        self.lambda
            * self
                .smoothness
                .cost(p, q, a, b)
                .max(self.crease_floor(p, q))
    }

    /// The pixels where local label `a` is feasible (its plane in front of the camera),
    /// sorted; `None` when it is feasible everywhere.
    pub fn feasible_sites(&self, a: u32) -> Option<Vec<u32>> {
        let sites: Vec<u32> = (0..self.num_pixels())
            .filter(|&p| self.feasible(p, a))
            .map(|p| p as u32)
            .collect();
        (sites.len() < self.num_pixels()).then_some(sites)
    }

    /// Whether local label `a`'s plane is in front of the camera at pixel `p` (otherwise its
    /// data cost is the truncation and it yields no depth).
    #[inline]
    pub fn feasible(&self, p: usize, a: u32) -> bool {
        self.smoothness
            .depth(&self.smoothness.pixel_ray(p), a)
            .is_some()
    }

    /// A starting labelling: per pixel, the local label of least data cost among the feasible
    /// ones (ties: lowest index; label 0 if none is feasible).
    pub fn initial_labels(&self) -> Vec<u32> {
        let l = self.labels.len();
        (0..self.num_pixels())
            .into_par_iter()
            .map(|p| {
                let row = &self.unary[p * l..(p + 1) * l];
                let mut best: Option<(f32, u32)> = None;
                for (a, &c) in row.iter().enumerate() {
                    let a = a as u32;
                    if self.feasible(p, a) && best.is_none_or(|(bc, _)| c < bc) {
                        best = Some((c, a));
                    }
                }
                best.map_or(0, |(_, a)| a)
            })
            .collect()
    }

    /// The full energy `Σ D + λ Σ w V` of a labelling (local labels, one per pixel), summed
    /// in f64 in a fixed order: an independent check of what a solver reports.
    ///
    /// # Panics
    /// If `labels.len()` is not the number of pixels or a label is out of range.
    pub fn energy(&self, labels: &[u32]) -> f64 {
        assert_eq!(labels.len(), self.num_pixels(), "one label per pixel");
        let (w, h) = (self.width as usize, self.height as usize);
        let per_row: Vec<f64> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut e = 0.0f64;
                for x in 0..w {
                    let p = y * w + x;
                    let a = labels[p];
                    assert!((a as usize) < self.labels.len(), "label {a} out of range");
                    e += self.unary(p, a) as f64;
                    if x + 1 < w {
                        e += self.pairwise(p, p + 1, a, labels[p + 1]) as f64;
                    }
                    if y + 1 < h {
                        e += self.pairwise(p, p + w, a, labels[p + w]) as f64;
                    }
                }
                e
            })
            .collect();
        per_row.iter().sum()
    }

    /// Depth (camera z) per pixel of a labelling; 0 where the label's plane is behind the
    /// camera or parallel to the ray (COLMAP's "no depth").
    pub fn depth_for_labels(&self, labels: &[u32]) -> Vec<f32> {
        labels
            .par_iter()
            .enumerate()
            .map(|(p, &a)| {
                self.smoothness
                    .depth(&self.smoothness.pixel_ray(p), a)
                    .map_or(0.0, |z| z as f32)
            })
            .collect()
    }

    /// Unit normal per pixel of a labelling, in the target camera frame, oriented toward the
    /// camera (n · ray < 0, as in COLMAP's normal maps); zero where the plane yields no
    /// depth.
    pub fn normals_for_labels(&self, labels: &[u32]) -> Vec<[f32; 3]> {
        labels
            .par_iter()
            .enumerate()
            .map(|(p, &a)| {
                let ray = self.smoothness.pixel_ray(p);
                if self.smoothness.depth(&ray, a).is_none() {
                    return [0.0; 3];
                }
                let n: Vector3<f64> = self.smoothness.plane_in_camera(a).normal;
                let n = if n.dot(&ray) > 0.0 { -n } else { n };
                [n.x as f32, n.y as f32, n.z as f32]
            })
            .collect()
    }

    /// Global plane index per pixel of a labelling of local labels.
    pub fn global_labels(&self, labels: &[u32]) -> Vec<u32> {
        labels.iter().map(|&a| self.labels[a as usize]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planemap::testutil::{cast, corner_scene};
    use nalgebra::{Point3, Vector2};

    fn build(view: usize) -> (crate::planemap::testutil::CornerScene, PlanemapEnergy) {
        let scene = corner_scene();
        let e = {
            let inputs = ViewInputs {
                photo_planes: &[],
                view_index: view,
                views: &scene.views,
                image: &scene.images[view],
                cloud: &scene.cloud,
                planes: &scene.planes,
                dominant_directions: &scene.directions,
                scale: scene.scale,
            };
            PlanemapEnergy::build(&inputs, &PlanemapConfig::default()).unwrap()
        };
        (scene, e)
    }

    /// The ground-truth labelling (local labels) of the corner scene's view.
    fn truth(
        scene: &crate::planemap::testutil::CornerScene,
        e: &PlanemapEnergy,
        view: usize,
    ) -> Vec<Option<u32>> {
        let v = &scene.views[view];
        (0..e.num_pixels())
            .map(|p| {
                let (x, y) = (p % e.width as usize, p / e.width as usize);
                let (o, d) = v.ray(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
                let (face, _) = cast(&o, &d)?;
                e.labels
                    .iter()
                    .position(|&g| g as usize == face)
                    .map(|a| a as u32)
            })
            .collect()
    }

    #[test]
    fn energy_matches_a_hand_sum_and_truth_beats_a_constant_labelling() {
        let (scene, e) = build(0);
        let n = e.num_pixels();
        let w = e.width as usize;
        // Constant labelling: no pairwise term.
        let zeros = vec![0u32; n];
        let unary0: f64 = (0..n).map(|p| e.unary(p, 0) as f64).sum();
        assert!((e.energy(&zeros) - unary0).abs() < 1e-6 * unary0.max(1.0));
        // Two halves: the pairwise term is the column of right pairs at the split.
        let split = w / 2;
        let halves: Vec<u32> = (0..n).map(|p| u32::from(p % w >= split)).collect();
        let unary: f64 = (0..n).map(|p| e.unary(p, halves[p]) as f64).sum();
        let mut pair = 0.0f64;
        let slots = e.weights.interleaved();
        for y in 0..e.height as usize {
            let p = y * w + split - 1;
            let v = e
                .smoothness
                .cost(p, p + 1, 0, 1)
                .max(e.crease_floor(p, p + 1));
            pair += (e.lambda * e.weights.right[p] * v) as f64;
            let via_slots = slots[2 * p] * e.smoothness_term(p, p + 1, 0, 1);
            assert!((via_slots - e.pairwise(p, p + 1, 0, 1)).abs() <= 1e-6 * via_slots);
        }
        assert!(pair > 0.0);
        let got = e.energy(&halves);
        assert!(
            (got - unary - pair).abs() < 1e-6 * got,
            "{got} vs {}",
            unary + pair
        );

        // Ground truth (background pixels: label 0) beats any constant labelling.
        let t: Vec<u32> = truth(&scene, &e, 0)
            .iter()
            .map(|l| l.unwrap_or(0))
            .collect();
        let e_truth = e.energy(&t);
        for a in 0..e.num_labels() as u32 {
            let c = vec![a; n];
            assert!(
                e_truth < e.energy(&c),
                "label {a}: {} vs truth {e_truth}",
                e.energy(&c)
            );
        }
    }

    #[test]
    fn truth_beats_a_parallel_distractor_and_a_shifted_boundary() {
        let (scene, e) = build(0);
        let t: Vec<u32> = truth(&scene, &e, 0)
            .iter()
            .map(|l| l.unwrap_or(0))
            .collect();
        let local = |g: u32| e.labels.iter().position(|&l| l == g).unwrap() as u32;
        let e_truth = e.energy(&t);
        // The floor (plane 2, z = 0) replaced by the parallel distractor z = 1.7 (plane 5).
        let (floor, raised) = (local(2), local(5));
        let lifted: Vec<u32> = t
            .iter()
            .map(|&a| if a == floor { raised } else { a })
            .collect();
        assert!(
            e.energy(&lifted) > e_truth + 1.0,
            "{} vs {e_truth}",
            e.energy(&lifted)
        );
        // The wall x = 0 grown 3 pixels to the right into the wall y = 0, off the crease.
        let (wx, wy) = (local(0), local(1));
        let w = e.width as usize;
        let mut grown = t.clone();
        for y in 0..e.height as usize {
            let row = &t[y * w..(y + 1) * w];
            if let Some(x) = (1..w).find(|&x| row[x - 1] == wx && row[x] == wy) {
                for g in &mut grown[y * w + x..(y * w + x + 3).min((y + 1) * w)] {
                    *g = wx;
                }
            }
        }
        assert_ne!(grown, t);
        assert!(
            e.energy(&grown) > e_truth,
            "{} vs {e_truth}",
            e.energy(&grown)
        );
    }

    /// A label change pays at least the crease cost between pixels without an image edge,
    /// and exactly the paper's V across an edge; crease_cost 0 is the paper's V everywhere.
    #[test]
    fn crease_floor_applies_only_off_image_edges() {
        let (_, mut e) = build(0);
        let w = e.width as usize;
        e.crease = 3.0;
        let (mut plain, mut edged) = (0, 0);
        for p in (0..e.num_pixels()).filter(|p| p % w + 1 < w) {
            let q = p + 1;
            let v = e.smoothness.cost(p, q, 0, 1);
            let lw = e.lambda * e.weights.between(p, q);
            let got = e.pairwise(p, q, 0, 1);
            if e.weights.edge_between(p, q) {
                assert_eq!(got, lw * v);
                edged += 1;
            } else {
                assert_eq!(got, lw * v.max(3.0));
                plain += 1;
            }
            assert_eq!(e.pairwise(p, q, 1, 1), 0.0);
        }
        assert!(
            plain > 100 && edged > 10,
            "{plain} plain, {edged} edge pairs"
        );
        e.crease = 0.0;
        let p = w * 10 + 10;
        assert_eq!(
            e.pairwise(p, p + 1, 0, 1),
            e.lambda * e.weights.between(p, p + 1) * e.smoothness.cost(p, p + 1, 0, 1)
        );
    }

    #[test]
    fn depth_and_normals_follow_the_labels() {
        let (scene, e) = build(0);
        let view = &scene.views[0];
        let t = truth(&scene, &e, 0);
        let labels: Vec<u32> = t.iter().map(|l| l.unwrap_or(0)).collect();
        let depth = e.depth_for_labels(&labels);
        let normals = e.normals_for_labels(&labels);
        let mut checked = 0;
        for (p, l) in t.iter().enumerate() {
            if l.is_none() {
                continue;
            }
            let (x, y) = (p % e.width as usize, p / e.width as usize);
            let (o, d) = view.ray(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
            let (face, hit) = cast(&o, &d).unwrap();
            let z = (view.cam_from_world * Point3::from(hit)).z;
            assert!(
                (depth[p] as f64 - z).abs() < 1e-4 * z,
                "pixel {p}: {} vs {z}",
                depth[p]
            );
            let n_world = Vector3::ith(face, 1.0); // faces' normals point into the room
            let n_cam = view.cam_from_world.rotation * n_world;
            let got = Vector3::new(normals[p][0], normals[p][1], normals[p][2]).cast::<f64>();
            assert!((got - n_cam).norm() < 1e-5, "{got:?} vs {n_cam:?}");
            checked += 1;
        }
        assert!(checked > 1000);
        assert_eq!(e.global_labels(&labels)[0], e.labels[labels[0] as usize]);
    }

    #[test]
    fn initial_labels_are_feasible_and_mostly_true_at_points() {
        let (scene, e) = build(0);
        let init = e.initial_labels();
        assert!(init.iter().enumerate().all(|(p, &a)| e.feasible(p, a)));
        for a in 0..e.num_labels() as u32 {
            let sites = e.feasible_sites(a);
            let n = sites.as_ref().map_or(e.num_pixels(), |s| s.len());
            let count = (0..e.num_pixels()).filter(|&p| e.feasible(p, a)).count();
            assert_eq!(n, count);
        }
        let t = truth(&scene, &e, 0);
        // At the pixels of points well inside a face, the data term alone picks the face.
        let mut agree = 0;
        let mut total = 0;
        for (i, x) in scene.cloud.positions.iter().enumerate() {
            let face = scene.true_label[i];
            let clear = scene
                .planes
                .iter()
                .enumerate()
                .all(|(k, pl)| k == face || pl.signed_distance(x).abs() > 0.5);
            let Some((xy, _)) = scene.views[0].project(x) else {
                continue;
            };
            if !clear || !scene.views[0].camera.contains(&xy) {
                continue;
            }
            let p = xy.y as usize * e.width as usize + xy.x as usize;
            total += 1;
            if Some(init[p]) == t[p] {
                agree += 1;
            }
        }
        assert!(total > 30 && agree * 10 >= total * 9, "{agree}/{total}");
    }

    #[test]
    fn build_is_identical_across_thread_counts() {
        let run = || build(2).1;
        let many = run();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(run);
        let bits = |v: &[f32]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(many.labels, one.labels);
        assert_eq!(bits(&many.unary), bits(&one.unary));
        assert_eq!(many.weights, one.weights);
        let l = many.initial_labels();
        assert_eq!(many.energy(&l).to_bits(), one.energy(&l).to_bits());
    }
}
