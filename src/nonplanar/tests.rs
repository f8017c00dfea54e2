//! Tests of the non-planar label.

use super::*;

/// Exact depth maps of the corner scene's three views (0 where a ray misses the faces).
pub(crate) fn corner_depths() -> (Scene, Vec<Vec<f32>>) {
    use crate::planemap::testutil::{cast, corner_views};
    let views = corner_views();
    let depths = views
        .iter()
        .map(|v| {
            let (w, h) = (v.camera.width, v.camera.height);
            (0..w * h)
                .map(|p| {
                    let xy = nalgebra::Vector2::new((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
                    let (o, d) = v.ray(&xy);
                    cast(&o, &d).map_or(0.0, |(_, x)| v.project(&x).map_or(0.0, |(_, z)| z as f32))
                })
                .collect()
        })
        .collect();
    let scene = Scene {
        views,
        cloud: Default::default(),
    };
    (scene, depths)
}

#[test]
fn the_label_needs_a_sure_sweep_unless_the_classifier_is_sure() {
    let cfg = NonplanarConfig {
        min_confidence: 0.1,
        sure_nonplanar_below: 0.3,
        ..Default::default()
    };
    // A confident sweep: allowed whatever the classifier says.
    assert_eq!(cfg.label_depth(2.0, 0.2, 0.9), 2.0);
    // An ambiguous sweep: only where P(planar) < 0.3.
    assert_eq!(cfg.label_depth(2.0, 0.05, 0.9), 0.0);
    assert_eq!(cfg.label_depth(2.0, 0.05, 0.3), 0.0);
    assert_eq!(cfg.label_depth(2.0, 0.05, 0.29), 2.0);
    // No depth is no depth, however sure anyone is.
    assert_eq!(cfg.label_depth(0.0, 0.5, 0.0), 0.0);
    assert_eq!(cfg.label_depth(f32::NAN, 0.5, 0.0), 0.0);
    // 0 turns the exception off.
    let off = NonplanarConfig {
        sure_nonplanar_below: 0.0,
        ..cfg.clone()
    };
    assert_eq!(off.label_depth(2.0, 0.05, 0.0), 0.0);
    let bad = NonplanarConfig {
        sure_nonplanar_below: 1.5,
        ..cfg
    };
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("sure_nonplanar_below"), "{err}");
}

#[test]
fn only_depths_no_plane_fits_as_well_are_confirmable() {
    let (_, ev) = extended();
    let n = ev.cost.len();
    let textured: Vec<f32> = (0..n).map(|p| if p % 5 == 0 { 0.0 } else { 2.0 }).collect();
    let ev = NonplanarView {
        textured_depth: textured.clone(),
        ..ev
    };
    // No plane costs computed (fit gap off): every textured depth.
    assert_eq!(ev.confirmable_depth(), textured);
    // Sweep cost 0.25: kept where the best plane costs more, dropped where as little.
    let with_planes = NonplanarView {
        best_plane_cost: (0..n).map(|p| [0.35, 0.25, 0.15][p % 3]).collect(),
        ..ev
    };
    for (p, &z) in with_planes.confirmable_depth().iter().enumerate() {
        let expect = if p % 3 == 0 { textured[p] } else { 0.0 };
        assert_eq!(z, expect, "pixel {p}");
    }
}

#[test]
fn sweep_depths_are_confirmed_by_the_views_that_agree() {
    let (scene, depths) = corner_depths();
    let all: Vec<Option<&[f32]>> = depths.iter().map(|d| Some(d.as_slice())).collect();
    let counts = sweep_confirmations(&scene, 0, &all, 0.01, 2);
    let with_depth = depths[0].iter().filter(|&&z| z > 0.0).count();
    let both = counts.iter().filter(|&&c| c == 2).count();
    // Most of the corner is seen by both other views; nothing counts more than 2 or
    // where view 0 has no depth.
    assert!(both * 10 > with_depth * 6, "{both} of {with_depth}");
    assert!(counts.iter().all(|&c| c <= 2));
    assert!(depths[0]
        .iter()
        .zip(&counts)
        .all(|(&z, &c)| z > 0.0 || c == 0));
    // View 1's depths 3 % too far: only view 2 confirms.
    let far: Vec<f32> = depths[1].iter().map(|&z| z * 1.03).collect();
    let some: Vec<Option<&[f32]>> = vec![Some(&depths[0]), Some(&far), Some(&depths[2])];
    let c = sweep_confirmations(&scene, 0, &some, 0.01, 2);
    assert!(c.iter().all(|&n| n <= 1));
    assert_eq!(
        c.iter().filter(|&&n| n == 1).count(),
        sweep_confirmations(
            &scene,
            0,
            &[Some(&depths[0]), None, Some(&depths[2])],
            0.01,
            2
        )
        .iter()
        .filter(|&&n| n == 1)
        .count()
    );
    // No depth of its own, or a view index without one: no counts.
    let none: Vec<Option<&[f32]>> = vec![None, Some(&depths[1]), Some(&depths[2])];
    assert!(sweep_confirmations(&scene, 0, &none, 0.01, 2)
        .iter()
        .all(|&n| n == 0));
}

#[test]
fn pixels_near_a_depth_jump_are_not_confirmed() {
    let (scene, depths) = corner_depths();
    let w = scene.views[0].camera.width as usize;
    // A foreground strip: columns 60..80 of view 0 at 0.8× their depth.
    let mut d0 = depths[0].clone();
    for (p, z) in d0.iter_mut().enumerate() {
        if (60..80).contains(&(p % w)) {
            *z *= 0.8;
        }
    }
    let all: Vec<Option<&[f32]>> = vec![Some(&d0), Some(&depths[1]), Some(&depths[2])];
    let exact: Vec<Option<&[f32]>> = depths.iter().map(|d| Some(d.as_slice())).collect();
    for edge_px in [0usize, 2, 4] {
        let c = sweep_confirmations(&scene, 0, &all, 0.01, edge_px);
        let reference = sweep_confirmations(&scene, 0, &exact, 0.01, 0);
        for (p, (&n, &r)) in c.iter().zip(&reference).enumerate() {
            let x = p % w;
            // Distance in columns to the nearest jump (between 59|60 and 79|80).
            let dist = [
                x.abs_diff(59).min(x.abs_diff(60)),
                x.abs_diff(79).min(x.abs_diff(80)),
            ]
            .into_iter()
            .min()
            .unwrap();
            if (60..80).contains(&x) {
                assert_eq!(n, 0, "the strip's false depth is confirmed at {p}");
            } else if dist <= edge_px && depths[0][p] > 0.0 {
                assert_eq!(n, 0, "x = {x} is within {edge_px} px of the jump");
            } else if dist > edge_px + 1 {
                assert_eq!(n, r, "x = {x}: the jump changed a count far from it");
            }
        }
    }
}

#[test]
fn tiers_counted_together_equal_each_tier_alone() {
    let (scene, depths) = corner_depths();
    // Views 2 % apart in depth, and a jump in view 0: tolerance and edge margin both matter.
    let w = scene.views[0].camera.width as usize;
    let mut d0: Vec<f32> = depths[0].iter().map(|&z| z * 1.02).collect();
    for (p, z) in d0.iter_mut().enumerate() {
        if (60..80).contains(&(p % w)) {
            *z *= 0.8;
        }
    }
    let all: Vec<Option<&[f32]>> = vec![Some(&d0), Some(&depths[1]), Some(&depths[2])];
    let tiers = [(0.01, 2), (0.05, 5), (0.05, 0)];
    let together = sweep_confirmation_tiers(&scene, 0, &all, &tiers);
    assert_eq!(together.len(), 3);
    for (counts, &(tol, edge)) in together.iter().zip(&tiers) {
        assert_eq!(counts, &sweep_confirmations(&scene, 0, &all, tol, edge));
    }
    // The looser tier confirms what the strict one cannot.
    let confirmed = |c: &Vec<u16>| c.iter().filter(|&&n| n == 2).count();
    assert_eq!(confirmed(&together[0]), 0);
    assert!(
        confirmed(&together[1]) > 1000,
        "{}",
        confirmed(&together[1])
    );
    assert!(confirmed(&together[2]) > confirmed(&together[1]));
}

#[test]
fn normals_of_a_fronto_parallel_and_a_slanted_plane() {
    let (w, h) = (8, 6);
    let ray = |x: usize, y: usize| Vector3::new(x as f64 * 0.1 - 0.4, y as f64 * 0.1 - 0.3, 1.0);
    let flat = vec![2.0f32; w * h];
    let n = normals_from_depth(&flat, w, h, ray);
    for v in &n {
        assert!((v[2] + 1.0).abs() < 1e-6 && v[0].abs() < 1e-6, "{v:?}");
    }
    // Plane x + z = 3 in the camera frame: depth = 3 / (rx + 1); normal ∝ (1, 0, 1),
    // facing the camera: −(1, 0, 1)/√2.
    let slanted: Vec<f32> = (0..w * h)
        .map(|i| (3.0 / (ray(i % w, i / w).x + 1.0)) as f32)
        .collect();
    let n = normals_from_depth(&slanted, w, h, ray);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    for v in &n {
        assert!((v[0] + s).abs() < 1e-4 && v[1].abs() < 1e-4 && (v[2] + s).abs() < 1e-4);
    }
    // No depth: no normal.
    let mut holes = flat.clone();
    holes[0] = 0.0;
    assert_eq!(normals_from_depth(&holes, w, h, ray)[0], [0.0; 3]);
}

/// The corner scene's view-0 energy with a non-planar label whose sweep depth is label
/// 0's plane depth on the left half and 1.3× it on the right half.
fn extended() -> (PlanemapEnergy, NonplanarView) {
    use crate::planemap::testutil::corner_scene;
    use crate::planemap::ViewInputs;
    let scene = corner_scene();
    let inputs = ViewInputs {
        photo_planes: &[],
        view_index: 0,
        views: &scene.views,
        image: &scene.images[0],
        cloud: &scene.cloud,
        planes: &scene.planes,
        dominant_directions: &scene.directions,
        scale: scene.scale,
    };
    let energy = PlanemapEnergy::build(&inputs, &PlanemapConfig::default()).unwrap();
    let (w, h) = (energy.width as usize, energy.height as usize);
    let depth: Vec<f32> = (0..w * h)
        .map(|p| {
            let z = energy
                .smoothness
                .depth(&energy.smoothness.pixel_ray(p), 0)
                .unwrap_or(0.0) as f32;
            if p % w < w / 2 {
                z
            } else {
                1.3 * z
            }
        })
        .collect();
    let planarity = PlanarityMap {
        width: w as u32,
        height: h as u32,
        planar: (0..w * h).map(|p| (p % 7) as f32 / 6.0).collect(),
    };
    let cost = vec![0.25; w * h];
    (
        energy,
        NonplanarView {
            planarity,
            textured_depth: depth.clone(),
            depth,
            cost,
            best_plane_cost: Vec::new(),
        },
    )
}

/// The fit-gap cue: where the view's best plane costs more than the sweep's winner, every
/// plane label pays γ·min(1, gap / scale) more; elsewhere, and for the non-planar label,
/// nothing changes.
#[test]
fn fit_gap_charges_the_planes_where_the_sweep_fits_better() {
    let (mut plain, ev) = extended();
    let (mut energy, _) = extended();
    let cfg = NonplanarConfig::default();
    let pm = PlanemapConfig::default();
    let np_plain = add_classifier_costs(&mut plain, &ev, &cfg, &pm).unwrap();
    let n = ev.cost.len();
    // Sweep cost 0.25 everywhere; the best plane costs 0.35 (gap 0.1), 0.75 (gap 0.5,
    // beyond the scale) or 0.15 (the plane fits better) in turn.
    let with_planes = NonplanarView {
        best_plane_cost: (0..n).map(|p| [0.35, 0.75, 0.15][p % 3]).collect(),
        ..ev.clone()
    };
    let np_gapped = add_classifier_costs(&mut energy, &with_planes, &cfg, &pm).unwrap();
    assert_eq!(np_gapped, np_plain);
    let l = energy.num_labels();
    let g = cfg.fit_gap_weight as f32;
    for p in [0usize, 1, 2, 3, 4, 5, 999, 1000, 1001] {
        let want = [0.5 * g, g, 0.0][p % 3];
        for a in 0..l {
            let extra = energy.unary[p * l + a] - plain.unary[p * l + a];
            assert!(
                (extra - want).abs() < 1e-5,
                "pixel {p} label {a}: {extra} vs {want}"
            );
        }
    }
    let off = NonplanarConfig {
        fit_gap_weight: 0.0,
        ..cfg
    };
    assert_eq!(with_planes.fit_gap_cost(1, &off), 0.0);
    assert!(NonplanarConfig {
        fit_gap_scale: 0.0,
        ..NonplanarConfig::default()
    }
    .validate()
    .unwrap_err()
    .to_string()
    .contains("fit_gap_scale"));
}

#[test]
fn classifier_costs_and_dense_layout() {
    let (mut energy, ev) = extended();
    let before = energy.unary.clone();
    let cfg = NonplanarConfig::default();
    let pm = PlanemapConfig::default();
    let np = add_classifier_costs(&mut energy, &ev, &cfg, &pm).unwrap();
    let l = energy.num_labels();
    let costs = ev
        .planarity
        .unary_costs(cfg.beta as f32, cfg.epsilon as f32)
        .unwrap();
    for p in [0, 5, 6, 1234] {
        for a in 0..l {
            let want = before[p * l + a] + costs.planar[p];
            assert!((energy.unary[p * l + a] - want).abs() < 1e-6);
        }
        let want_np = costs.nonplanar[p] + pm.photo_weight as f32 * 0.25;
        assert!((np[p] - want_np).abs() < 1e-6);
    }
    let x = ExtendedEnergy {
        planar: &energy,
        evidence: &ev,
        unary_np: np,
    };
    assert_eq!(x.num_labels(), l + 1);
    let dense = x.dense_unary();
    assert_eq!(dense.len(), energy.unary.len() / l * (l + 1));
    for p in [0, 77, 4000] {
        for a in 0..=l as u32 {
            assert_eq!(dense[p * (l + 1) + a as usize], x.unary(p, a));
        }
    }
}

#[test]
fn pairwise_is_a_truncated_metric_with_the_nonplanar_label() {
    let (energy, ev) = extended();
    let x = ExtendedEnergy {
        planar: &energy,
        evidence: &ev,
        unary_np: vec![0.0; ev.depth.len()],
    };
    let (w, h) = (energy.width as usize, energy.height as usize);
    let np = x.nonplanar_label();
    let n = x.num_labels() as u32;
    let mut checked = 0;
    for y in (0..h - 1).step_by(7) {
        for xx in (0..w - 1).step_by(5) {
            let p = y * w + xx;
            for q in [p + 1, p + w] {
                for a in 0..n {
                    assert_eq!(x.pairwise(p, q, a, a), 0.0);
                    for b in 0..n {
                        let v = x.pairwise(p, q, a, b);
                        assert!(v.is_finite() && v >= 0.0);
                        assert_eq!(v, x.pairwise(p, q, b, a));
                        if a != np && b != np {
                            assert_eq!(v, energy.pairwise(p, q, a, b));
                        }
                        for c in 0..n {
                            let (ac, cb) = (x.pairwise(p, q, a, c), x.pairwise(p, q, c, b));
                            assert!(v <= ac + cb + 1e-3 * (1.0 + v), "{a} {b} via {c}");
                        }
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 500);
    // Left half: the sweep lies on plane 0, so switching there costs only the crease
    // floor (no image edge there); right half: it is 30 % behind, which costs the
    // truncation.
    let (left, right) = (60 * w + 10, 60 * w + w - 12);
    let trunc = energy.lambda * energy.smoothness.truncation();
    let floor = energy.lambda
        * energy.weights.between(left, left + 1)
        * energy.crease_floor(left, left + 1);
    let switch = x.pairwise(left, left + 1, 0, np);
    assert!(
        switch >= floor - 1e-6 && switch < floor + 0.05 * trunc,
        "{switch} vs {floor}"
    );
    let wr = energy.weights.between(right, right + 1);
    assert!((x.pairwise(right, right + 1, 0, np) - trunc * wr).abs() < 1e-4);
    // Energy of a labelling = the sum the solver sees.
    let labels: Vec<u32> = (0..w * h)
        .map(|p| if p % w < w / 2 { 0 } else { np })
        .collect();
    let mut sum = 0.0f64;
    for p in 0..w * h {
        sum += x.unary(p, labels[p]) as f64;
        if p % w + 1 < w {
            sum += x.pairwise(p, p + 1, labels[p], labels[p + 1]) as f64;
        }
        if p / w + 1 < h {
            sum += x.pairwise(p, p + w, labels[p], labels[p + w]) as f64;
        }
    }
    assert!((x.energy(&labels) - sum).abs() < 1e-6 * sum.abs().max(1.0));
}

#[test]
fn config_validation_names_the_field() {
    assert!(NonplanarConfig::default().validate().is_ok());
    let c = NonplanarConfig {
        beta: -1.0,
        ..Default::default()
    };
    assert!(c
        .validate()
        .unwrap_err()
        .to_string()
        .contains("nonplanar.beta"));
    let c = NonplanarConfig {
        epsilon: 0.0,
        ..Default::default()
    };
    assert!(c.validate().unwrap_err().to_string().contains("epsilon"));
    let mut c = NonplanarConfig::default();
    c.sweep.photo.support_sigma_color = f64::NAN;
    let err = c.validate().unwrap_err().to_string();
    assert!(
        err.contains("nonplanar.sweep") && err.contains("support_sigma_color"),
        "{err}"
    );
    let c = NonplanarConfig::default();
    assert!(c.validate().is_ok());
    assert_eq!(c.sweep.photo.support_sigma_color, 0.15);
    assert_eq!((c.sweep.photo.neighbours, c.sweep.photo.best_k), (4, 2));
    for tol in [0.0, 1.0, f64::NAN] {
        let c = NonplanarConfig {
            consistency_tolerance: tol,
            ..Default::default()
        };
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("nonplanar.consistency_tolerance"));
    }
    let c = NonplanarConfig {
        min_confidence: 1.5,
        ..Default::default()
    };
    assert!(c
        .validate()
        .unwrap_err()
        .to_string()
        .contains("min_confidence"));
    let c: NonplanarConfig = toml::from_str("enabled = true\nbeta = 2.5").unwrap();
    assert!(c.enabled && c.beta == 2.5 && c.epsilon == 0.01);
    assert!(toml::from_str::<NonplanarConfig>("betta = 1").is_err());
}
