//! Tests of the crease hypotheses.

use super::*;
use crate::planemap::testutil::corner_views;

/// Per view: labels, depth, dominant-line mask.
type Labelling = (Vec<u32>, Vec<f32>, Vec<bool>);

/// Every pixel of three views labelled with the wall x = 0, and a horizontal line on
/// that wall at z = 0.7 marked as a dominant line: the z axis gets a plane at 0.7.
fn wall_with_line(z_line: f64) -> (Scene, Vec<Labelling>) {
    let views = corner_views();
    let mut labelled = Vec::new();
    for v in &views {
        let (w, h) = (v.camera.width, v.camera.height);
        let world_from_cam = v.cam_from_world.inverse();
        let centre = v.center();
        let mut depth = vec![0.0f32; (w * h) as usize];
        let mut lines = vec![false; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let ray = v.camera.pixel_ray(x, y);
                let dir = world_from_cam.rotation * ray;
                // Camera-z depth where the ray meets x = 0.
                let t = -centre.x / dir.x;
                if t.is_nan() || t <= 0.0 {
                    continue;
                }
                let p = centre + dir * t;
                let i = (y * w + x) as usize;
                depth[i] = t as f32;
                // The line: within half a pixel's footprint of z = z_line.
                lines[i] = (p.z - z_line).abs() < 0.5 * t / v.camera.fx();
            }
        }
        labelled.push((vec![0u32; (w * h) as usize], depth, lines));
    }
    let scene = Scene {
        views,
        cloud: crate::scene::SparseCloud::default(),
    };
    (scene, labelled)
}

fn axes() -> DominantAxes {
    DominantAxes {
        directions: vec![Vector3::x(), Vector3::y(), Vector3::z()],
        support: vec![100; 3],
        pairwise_angles_deg: vec![(0, 1, 90.0), (0, 2, 90.0), (1, 2, 90.0)],
        num_manhattan: 3,
        warnings: Vec::new(),
    }
}

fn wall() -> PlaneHypothesis {
    PlaneHypothesis {
        id: 0,
        plane: Plane {
            normal: Vector3::x(),
            offset: 0.0,
        },
        axis: Some(0),
        support: 50,
    }
}

fn run(
    scene: &Scene,
    labelled: &[Labelling],
    hyps: &[PlaneHypothesis],
    cfg: &CreaseHypothesesConfig,
) -> Vec<CreaseHypothesis> {
    let lv: Vec<LabelledView> = labelled
        .iter()
        .enumerate()
        .map(|(i, (l, d, m))| LabelledView {
            view_index: i,
            labels: l,
            depth: d,
            lines: m,
        })
        .collect();
    crease_hypotheses(scene, &axes(), hyps, &lv, 0.01, cfg).unwrap()
}

#[test]
fn a_line_on_a_labelled_wall_proposes_the_plane_through_it() {
    let (scene, labelled) = wall_with_line(0.7);
    let cfg = CreaseHypothesesConfig {
        min_votes_per_width: 0.5,
        ..Default::default()
    };
    let found = run(&scene, &labelled, &[wall()], &cfg);
    assert_eq!(found.len(), 1, "{found:?}");
    let h = &found[0].hypothesis;
    assert_eq!(h.axis, Some(2));
    assert!((h.plane.offset - 0.7).abs() < 0.01, "{}", h.plane.offset);
    assert_eq!(found[0].views, vec![0, 1, 2]);
    // The wall's own axis never votes (parallel to its normal); nor does y, whose
    // votes spread along the line.
    assert!(found.iter().all(|c| c.hypothesis.axis != Some(0)));
    // A view without the line does not see the crease and is not offered it.
    let mut two = labelled.clone();
    two[1].2.iter_mut().for_each(|m| *m = false);
    let found = run(&scene, &two, &[wall()], &cfg);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].views, vec![0, 2]);
    // A view must cast enough votes to count.
    let picky = CreaseHypothesesConfig {
        min_view_votes_per_width: 50.0,
        ..cfg
    };
    assert!(run(&scene, &labelled, &[wall()], &picky).is_empty());
    // Already a hypothesis: nothing new.
    let mut known = vec![wall()];
    known.push(PlaneHypothesis {
        id: 1,
        plane: Plane {
            normal: -Vector3::z(),
            offset: -0.705,
        },
        axis: Some(2),
        support: 10,
    });
    assert!(run(&scene, &labelled, &known, &cfg).is_empty());
    // More views required than see it, or more votes than the line has: nothing.
    let strict = CreaseHypothesesConfig {
        min_views: 4,
        ..cfg
    };
    assert!(run(&scene, &labelled, &[wall()], &strict).is_empty());
    let long = CreaseHypothesesConfig {
        min_votes_per_width: 50.0,
        ..cfg
    };
    assert!(run(&scene, &labelled, &[wall()], &long).is_empty());
}

#[test]
fn unlabelled_pixels_do_not_vote_and_bad_sizes_are_errors() {
    let (scene, mut labelled) = wall_with_line(0.7);
    for (l, _, _) in &mut labelled {
        l.iter_mut().for_each(|x| *x = 7); // no such hypothesis
    }
    let cfg = CreaseHypothesesConfig {
        min_votes_per_width: 0.5,
        ..Default::default()
    };
    assert!(run(&scene, &labelled, &[wall()], &cfg).is_empty());
    labelled[0].2.pop();
    let lv = [LabelledView {
        view_index: 0,
        labels: &labelled[0].0,
        depth: &labelled[0].1,
        lines: &labelled[0].2,
    }];
    assert!(crease_hypotheses(&scene, &axes(), &[wall()], &lv, 0.01, &cfg).is_err());
}

#[test]
fn each_view_keeps_the_crease_hypotheses_it_voted_for_most() {
    let crease = |id: u32, views: Vec<usize>| CreaseHypothesis {
        hypothesis: PlaneHypothesis {
            id,
            plane: Plane {
                normal: Vector3::z(),
                offset: id as f64,
            },
            axis: Some(2),
            support: 0,
        },
        views,
    };
    let out = vec![
        crease(0, vec![0, 1, 2]),
        crease(1, vec![0, 1]),
        crease(2, vec![1, 2]),
    ];
    // Votes [hypothesis][view].
    let votes = vec![vec![5u32, 1, 9], vec![7, 8, 0], vec![0, 3, 2]];
    let cfg = CreaseHypothesesConfig {
        max_per_view: 1,
        min_views: 1,
        ..CreaseHypothesesConfig::default()
    };
    let capped = cap_per_view(out.clone(), &votes, &cfg);
    // View 0 keeps 1 (7 > 5), view 1 keeps 1 (8), view 2 keeps 0 (9 > 2); 2 has no view.
    let views: Vec<(u32, Vec<usize>)> = capped
        .iter()
        .map(|c| (c.hypothesis.id, c.views.clone()))
        .collect();
    assert_eq!(views, vec![(0, vec![2]), (1, vec![0, 1])]);
    assert_eq!(
        capped[1].hypothesis.plane.offset, 1.0,
        "renumbered in order"
    );
    // No cap, or a cap no view reaches: unchanged.
    let none = CreaseHypothesesConfig {
        max_per_view: 0,
        ..cfg
    };
    assert_eq!(cap_per_view(out.clone(), &votes, &none), out);
    let loose = CreaseHypothesesConfig {
        max_per_view: 3,
        ..cfg
    };
    assert_eq!(cap_per_view(out.clone(), &votes, &loose), out);
}
