//! Tests of the chain.

use super::label::add_photo_term;
use super::*;
use crate::nonplanar::tests::corner_depths;
use crate::nonplanar::{NonplanarConfig, NONPLANAR};
use crate::planemap::{PlanemapConfig, PlanemapEnergy};

/// Views of `scene` labelled 0 with depth `label(view, pixel, truth)` and the given
/// sweep depths.
fn labelled(
    scene: &Scene,
    truth: &[Vec<f32>],
    sweeps: &[Vec<f32>],
    label: impl Fn(usize, usize, f32) -> f32,
) -> Vec<ViewPlanemap> {
    truth
        .iter()
        .zip(sweeps)
        .enumerate()
        .map(|(i, (d, sweep))| {
            let w = scene.views[i].camera.width as usize;
            ViewPlanemap {
                view_index: i,
                width: w as u32,
                height: (d.len() / w) as u32,
                labels: vec![0; d.len()],
                depth: d.iter().enumerate().map(|(p, &z)| label(i, p, z)).collect(),
                normals: vec![[0.0, 0.0, -1.0]; d.len()],
                candidate_labels: 1,
                energy: (0.0, 0.0),
                cycles: 0,
                seconds: (0.0, 0.0),
                planarity: None,
                sweep_depth: Some(sweep.clone()),
            }
        })
        .collect()
}

#[test]
fn the_photo_term_is_the_cost_volume_with_the_configured_support_weights() {
    let corner = crate::planemap::testutil::corner_scene();
    let scene = Scene {
        views: corner.views.clone(),
        cloud: corner.cloud.clone(),
    };
    let inputs = crate::planemap::ViewInputs {
        photo_planes: &[],
        view_index: 0,
        views: &corner.views,
        image: &corner.images[0],
        cloud: &corner.cloud,
        planes: &corner.planes,
        dominant_directions: &corner.directions,
        scale: corner.scale,
    };
    let photo_costs = |sigma: f64| {
        let mut cfg = PlanemapConfig::default();
        cfg.photo.support_sigma_color = sigma;
        let mut energy = PlanemapEnergy::build(&inputs, &cfg).unwrap();
        let before = energy.unary.clone();
        add_photo_term(
            &scene,
            0,
            &corner.images[0],
            &corner.images,
            &mut energy,
            &cfg,
        )
        .unwrap();
        // Against the cost volume computed directly with σc = sigma.
        let nb = crate::photo::select_neighbours(&scene, 0, cfg.photo.neighbours).unwrap();
        assert!(!nb.is_empty());
        let neighbours: Vec<_> = nb
            .iter()
            .map(|&j| (&scene.views[j], &corner.images[j]))
            .collect();
        let volume = crate::photo::plane_cost_volume(
            &scene.views[0],
            &corner.images[0],
            &neighbours,
            &energy.planes,
            &crate::photo::PhotoConfig {
                neighbours: 3,
                support_sigma_color: sigma,
                ..Default::default()
            },
        )
        .unwrap();
        let added: Vec<f32> = energy
            .unary
            .iter()
            .zip(&before)
            .map(|(a, b)| a - b)
            .collect();
        assert_eq!(added.len(), volume.costs.len());
        for (a, c) in added.iter().zip(&volume.costs) {
            assert!((a - cfg.photo_weight as f32 * c).abs() < 1e-5, "{a} vs {c}");
        }
        added
    };
    let boxed = photo_costs(0.0);
    let weighted = photo_costs(0.15);
    // The weights change the windows that straddle the corner's creases and the stripe.
    let changed = boxed
        .iter()
        .zip(&weighted)
        .filter(|(a, b)| (*a - *b).abs() > 0.01)
        .count();
    assert!(
        changed * 100 > boxed.len(),
        "only {changed} of {} costs changed",
        boxed.len()
    );
    let mut bad = PlanemapConfig::default();
    bad.photo.support_sigma_color = -0.1;
    assert!(bad.validate().is_err_and(
        |e| e.to_string().contains("photo") && e.to_string().contains("support_sigma_color")
    ));
}

#[test]
fn confirmed_sweep_depths_replace_the_planes_that_miss_them() {
    let (scene, depths) = corner_depths();
    // Every view labelled with a plane 10 % too far, except view 0's left half, which a
    // plane gets right; the sweep has the truth everywhere.
    let w = scene.views[0].camera.width as usize;
    let views = labelled(&scene, &depths, &depths, |i, p, z| {
        if i == 0 && p % w < w / 2 {
            z
        } else {
            z * 1.1
        }
    });
    let cfg = NonplanarConfig {
        consistent_views: 2,
        ..Default::default()
    };
    let mut out = views.clone();
    let changed = confirm_nonplanar(&scene, &mut out, &cfg);
    let w = scene.views[0].camera.width as usize;
    let counts: Vec<Vec<u16>> = (0..3)
        .map(|i| {
            let all: Vec<Option<&[f32]>> = depths.iter().map(|d| Some(d.as_slice())).collect();
            crate::nonplanar::sweep_confirmations(&scene, i, &all, 0.01, 2)
        })
        .collect();
    for (i, v) in out.iter().enumerate() {
        let mut n = 0;
        for p in 0..v.depth.len() {
            let right_plane = i == 0 && p % w < w / 2;
            if counts[i][p] >= 2 && !right_plane && depths[i][p] > 0.0 {
                assert_eq!(v.labels[p], NONPLANAR);
                assert_eq!(v.depth[p], depths[i][p]);
                assert!(v.normals[p] != [0.0, 0.0, -1.0] || v.normals[p] == [0.0; 3]);
                n += 1;
            } else {
                assert_eq!(v.labels[p], 0);
                assert_eq!(v.depth[p], views[i].depth[p]);
            }
        }
        assert_eq!(changed[i], n);
        assert!(n > 1000, "view {i}: {n}");
    }
    // More confirmations than there are other views: nothing changes; nor without
    // sweep depths.
    let mut out = views.clone();
    let strict = NonplanarConfig {
        consistent_views: 3,
        ..Default::default()
    };
    assert_eq!(confirm_nonplanar(&scene, &mut out, &strict), vec![0, 0, 0]);
    for (a, b) in out.iter().zip(&views) {
        assert_eq!((&a.depth, &a.labels), (&b.depth, &b.labels));
    }
    let mut bare = views.clone();
    for v in &mut bare {
        v.sweep_depth = None;
    }
    assert_eq!(confirm_nonplanar(&scene, &mut bare, &cfg), vec![0, 0, 0]);
}

#[test]
fn the_gross_tier_takes_loosely_confirmed_sweeps_from_planes_far_off() {
    let (scene, depths) = corner_depths();
    // Sweeps 2 % off the truth, view 1 nearer and the others farther: no two views
    // that differ in sign agree within 1 %, all of them within 5 %.
    let sweeps: Vec<Vec<f32>> = depths
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let f = if i == 1 { 0.98 } else { 1.02 };
            d.iter().map(|&z| z * f).collect()
        })
        .collect();
    let cfg = NonplanarConfig {
        consistent_views: 2,
        ..Default::default()
    };
    let off = NonplanarConfig {
        gross_gap: 0.0,
        ..cfg.clone()
    };
    // Planes 30 % too far: only the gross tier changes them, to the sweep's depth.
    let far = labelled(&scene, &depths, &sweeps, |_, _, z| z * 1.3);
    let mut out = far.clone();
    assert_eq!(confirm_nonplanar(&scene, &mut out, &off), vec![0, 0, 0]);
    let changed = confirm_nonplanar(&scene, &mut out, &cfg);
    for (i, (v, before)) in out.iter().zip(&far).enumerate() {
        assert!(changed[i] > 1000, "view {i}: {}", changed[i]);
        let mut n = 0;
        for (p, &z) in sweeps[i].iter().enumerate() {
            if v.labels[p] == NONPLANAR {
                assert_eq!(v.depth[p], z);
                n += 1;
            } else {
                assert_eq!(v.depth[p], before.depth[p]);
            }
        }
        assert_eq!(n, changed[i]);
    }
    // Planes 10 % too far are within the gap: the gross tier leaves them.
    let mut near = labelled(&scene, &depths, &sweeps, |_, _, z| z * 1.1);
    assert_eq!(confirm_nonplanar(&scene, &mut near, &cfg), vec![0, 0, 0]);
    // A looser agreement than the views have is a config error, not a silent change.
    let bad = NonplanarConfig {
        gross_tolerance: 1.5,
        ..cfg.clone()
    };
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("nonplanar.gross_tolerance"));
}
