//! Tests of the plane sweep: families, neighbours, the cost volume, winner-takes-all and
//! sub-plane refinement.

use super::families::*;
use super::neighbours::*;
use super::sweep::*;
use super::volume::*;
use super::*;
use crate::geometry::{look_at, Camera};
use crate::geometry::{plane_homography, Plane};
use crate::photo::Aggregation;
use crate::raster::ImageF32;
use crate::scene::SparseCloud;
use crate::scene::{Scene, View};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const FOCAL: f64 = 150.0;

/// Deterministic hash of a lattice point to `[0, 1)`.
fn lattice(i: i64, j: i64, salt: u64) -> f64 {
    let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ salt.wrapping_mul(0x1656_67B1_9E37_79F9);
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Smoothly interpolated value noise with lattice spacing `cell` (scene units).
fn value_noise(s: f64, t: f64, cell: f64, salt: u64) -> f64 {
    let (fs, ft) = (s / cell, t / cell);
    let (i, j) = (fs.floor() as i64, ft.floor() as i64);
    let smooth = |a: f64| a * a * (3.0 - 2.0 * a);
    let (a, b) = (smooth(fs - i as f64), smooth(ft - j as f64));
    let top = lattice(i, j, salt) * (1.0 - a) + lattice(i + 1, j, salt) * a;
    let bottom = lattice(i, j + 1, salt) * (1.0 - a) + lattice(i + 1, j + 1, salt) * a;
    top * (1.0 - b) + bottom * b
}

/// Camera `i` of the test rigs: a `WIDTH`×`HEIGHT` pinhole at `eye` looking at `target`.
fn test_view(i: usize, eye: &Vector3<f64>, target: &Vector3<f64>) -> View {
    View {
        id: i as u32 + 1,
        name: format!("cam{i}"),
        camera: Camera::pinhole(
            WIDTH,
            HEIGHT,
            FOCAL,
            FOCAL,
            WIDTH as f64 / 2.0,
            HEIGHT as f64 / 2.0,
        ),
        cam_from_world: look_at(eye, target, &Vector3::z()),
        image_path: None,
    }
}

/// Ray-cast render of `view` (RGB) with 2×2 supersampling, ±0.5/255 noise and 8-bit
/// quantisation; `shade` gives the colour seen along a ray (origin, direction).
fn ray_cast(
    view: &View,
    seed: u64,
    shade: impl Fn(&Vector3<f64>, &Vector3<f64>) -> [f32; 3],
) -> ImageF32 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut img = ImageF32::filled(WIDTH, HEIGHT, 3, 0.0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let mut acc = [0.0f32; 3];
            for (ox, oy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let (o, d) = view.ray(&Vector2::new(x as f64 + ox, y as f64 + oy));
                let c = shade(&o, &d);
                for k in 0..3 {
                    acc[k] += 0.25 * c[k];
                }
            }
            for (k, out) in img.pixel_mut(x, y).iter_mut().enumerate() {
                let noisy = acc[k] + (rng.random::<f32>() - 0.5) / 255.0;
                *out = (noisy.clamp(0.0, 1.0) * 255.0).round() / 255.0;
            }
        }
    }
    img
}

/// A plane textured on its `s < 0` half and plain paint on `s ≥ 0`, seen by a reference
/// camera and two neighbours ~11° to either side.
struct TestScene {
    plane: Plane,
    u: Vector3<f64>,
    v: Vector3<f64>,
    views: Vec<View>,
    images: Vec<ImageF32>,
}

impl TestScene {
    fn texture(&self, x: &Vector3<f64>) -> [f32; 3] {
        let (s, t) = (self.u.dot(x), self.v.dot(x));
        if s >= 0.0 {
            return [0.55, 0.5, 0.45];
        }
        let g = 0.15 + 0.5 * value_noise(s, t, 0.06, 1) + 0.3 * value_noise(s, t, 0.21, 2);
        [g as f32, (0.9 * g + 0.05) as f32, (g * g + 0.1) as f32]
    }

    /// [`ray_cast`] of the plane.
    fn render(&self, view: &View, seed: u64) -> ImageF32 {
        ray_cast(view, seed, |o, d| {
            let t = self
                .plane
                .intersect_ray(o, d)
                .expect("plane fills the view");
            self.texture(&(o + d * t))
        })
    }

    fn new() -> Self {
        let normal = Vector3::new(0.15, -1.0, 0.1).normalize();
        let plane = Plane::through(&Vector3::zeros(), &normal);
        let u = normal.cross(&Vector3::z()).normalize();
        let v = normal.cross(&u);
        let eyes = [
            Vector3::new(0.0, -5.0, 0.2),
            Vector3::new(-1.0, -5.1, 0.35),
            Vector3::new(1.0, -4.9, 0.0),
        ];
        let views = eyes
            .iter()
            .enumerate()
            .map(|(i, eye)| test_view(i, eye, &Vector3::new(0.0, 0.0, 0.1)))
            .collect();
        let mut scene = TestScene {
            plane,
            u,
            v,
            views,
            images: Vec::new(),
        };
        scene.images = (0..3)
            .map(|i| scene.render(&scene.views[i], 100 + i as u64))
            .collect();
        scene
    }

    fn neighbours(&self) -> Vec<(&View, &ImageF32)> {
        vec![
            (&self.views[1], &self.images[1]),
            (&self.views[2], &self.images[2]),
        ]
    }

    /// The homography of `plane` from the reference to neighbour 1 (pixel coordinates).
    fn homography(&self, plane: &Plane) -> Matrix3<f64> {
        let (a, b) = (&self.views[0], &self.views[1]);
        plane_homography(
            &a.camera,
            &a.cam_from_world,
            &b.camera,
            &b.cam_from_world,
            plane,
        )
        .unwrap()
    }

    /// Ground-truth depth and the in-plane `s` coordinate of a reference pixel.
    fn truth(&self, x: u32, y: u32) -> (f64, f64) {
        let view = &self.views[0];
        let xw = pixel_on_plane(view, x, y, &self.plane).unwrap();
        (view.project(&xw).unwrap().1, self.u.dot(&xw))
    }
}

/// Fraction of pixels within 1% of the true depth and median confidence, over the
/// textured (`s < −margin`) and plain (`s > margin`) parts away from the image border.
fn score(scene: &TestScene, result: &SweepResult, margin: f64) -> ((f64, f32), (f64, f32)) {
    let border = 8;
    let mut stats = [(0usize, 0usize, Vec::new()), (0usize, 0usize, Vec::new())];
    for y in border..HEIGHT - border {
        for x in border..WIDTH - border {
            let (z, s) = scene.truth(x, y);
            let which = if s < -margin {
                0
            } else if s > margin {
                1
            } else {
                continue;
            };
            let p = (y * WIDTH + x) as usize;
            let d = result.depth[p] as f64;
            let st = &mut stats[which];
            st.0 += usize::from(d.is_finite() && ((d - z) / z).abs() <= 0.01);
            st.1 += 1;
            st.2.push(result.confidence[p]);
        }
    }
    let summarise = |st: &mut (usize, usize, Vec<f32>)| {
        st.2.sort_by(f32::total_cmp);
        (st.0 as f64 / st.1 as f64, st.2[st.2.len() / 2])
    };
    let [mut a, mut b] = stats;
    (summarise(&mut a), summarise(&mut b))
}

#[test]
fn fronto_parallel_sweep_finds_textured_depth_and_fails_on_plain_paint() {
    let scene = TestScene::new();
    // True depths span about 4.6–5.4 here; 96 planes over [4, 6.5] are ~0.5% apart.
    let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 96).unwrap();
    let cfg = SweepConfig::default();
    let result = plane_sweep(
        &scene.views[0],
        &scene.images[0],
        &scene.neighbours(),
        &planes,
        &cfg,
    )
    .unwrap();
    let ((tex_ok, tex_conf), (plain_ok, plain_conf)) = score(&scene, &result, 0.15);
    eprintln!("fronto NCC 7x7: textured {:.1}% within 1% (median conf {tex_conf:.3}); plain {:.1}% (median conf {plain_conf:.3})", 100.0 * tex_ok, 100.0 * plain_ok);
    assert!(tex_ok >= 0.9, "textured: {tex_ok}");
    assert!(
        plain_ok < 0.3,
        "plain paint should defeat photo-consistency: {plain_ok}"
    );
    assert!(
        plain_conf < 0.05 && tex_conf > 0.1,
        "confidence {plain_conf} vs {tex_conf}"
    );
}

#[test]
fn sweep_along_the_plane_normal_recovers_the_plane() {
    let scene = TestScene::new();
    let offsets: Vec<f64> = (-20..=20).map(|i| i as f64 * 0.02).collect();
    let planes = axis_planes(&[scene.plane.normal], &offsets).unwrap();
    let cfg = SweepConfig {
        photo: PhotoConfig {
            color: ColorMode::Color,
            ..Default::default()
        },
        ..Default::default()
    };
    let result = plane_sweep(
        &scene.views[0],
        &scene.images[0],
        &scene.neighbours(),
        &planes,
        &cfg,
    )
    .unwrap();
    let (mut exact, mut total) = (0, 0);
    for y in 8..HEIGHT - 8 {
        for x in 8..WIDTH - 8 {
            if scene.truth(x, y).1 < -0.15 {
                total += 1;
                exact += usize::from(result.plane_index[(y * WIDTH + x) as usize] == 20);
            }
        }
    }
    let frac = exact as f64 / total as f64;
    eprintln!(
        "axis sweep, colour NCC: {:.1}% pick the true plane",
        100.0 * frac
    );
    assert!(frac > 0.9, "{frac}");
    let winner = result.plane_index.iter().position(|&k| k == 20).unwrap();
    let n = result.normal(winner, &planes).unwrap();
    assert!((n - scene.plane.normal).norm() < 1e-12);
    let none = result
        .plane_index
        .iter()
        .position(|&k| k == NO_PLANE)
        .unwrap();
    assert!(result.normal(none, &planes).is_none() && result.depth[none].is_nan());
}

/// Fronto-parallel planes (a wrong slant for this tilted surface) plus a family along
/// the true normal: the slanted family must win on the textured half, the result must
/// be the per-pixel minimum over the two families, and the plane index must point into
/// the concatenated list.
#[test]
fn multi_family_sweep_keeps_the_cheaper_family_per_pixel() {
    let scene = TestScene::new();
    let fronto = PlaneFamily {
        planes: fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 32).unwrap(),
        spacing: Spacing::InverseDepth,
    };
    let offsets: Vec<f64> = (-16..=16).map(|i| i as f64 * 0.025 + 0.005).collect();
    let slanted = PlaneFamily {
        planes: axis_planes(&[scene.plane.normal], &offsets).unwrap(),
        spacing: Spacing::Offset,
    };
    let cfg = SweepConfig::default();
    let nbrs = scene.neighbours();
    let families = [fronto.clone(), slanted.clone()];
    let multi = multi_family_sweep(
        &scene.views[0],
        &scene.images[0],
        &nbrs,
        &families,
        &cfg,
        true,
    )
    .unwrap();
    let single = |f: &PlaneFamily| {
        let v = plane_cost_volume(
            &scene.views[0],
            &scene.images[0],
            &nbrs,
            &f.planes,
            &cfg.photo,
        )
        .unwrap();
        let mut r =
            winner_takes_all(&v, &scene.views[0], &f.planes, cfg.confidence_exclusion).unwrap();
        refine_subplane(&v, &mut r, &scene.views[0], &f.planes, f.spacing);
        r
    };
    let (a, b) = (single(&fronto), single(&slanted));
    let (mut slanted_wins, mut textured) = (0, 0);
    for p in 0..multi.family.len() {
        let want = if b.plane_index[p] != NO_PLANE && b.cost[p] < a.cost[p] {
            1
        } else {
            0
        };
        let from = if want == 1 { &b } else { &a };
        if from.plane_index[p] == NO_PLANE {
            assert_eq!(multi.family[p], u32::MAX);
            continue;
        }
        assert_eq!(multi.family[p], want, "pixel {p}");
        assert_eq!(multi.sweep.cost[p].to_bits(), from.cost[p].to_bits());
        assert_eq!(multi.sweep.depth[p].to_bits(), from.depth[p].to_bits());
        assert_eq!(
            multi.sweep.plane_index[p],
            from.plane_index[p] + want * fronto.planes.len() as u32
        );
        let (x, y) = ((p % WIDTH as usize) as u32, (p / WIDTH as usize) as u32);
        if x >= 8 && y >= 8 && x < WIDTH - 8 && y < HEIGHT - 8 && scene.truth(x, y).1 < -0.15 {
            textured += 1;
            slanted_wins += want as usize;
        }
    }
    let share = slanted_wins as f64 / textured as f64;
    let ((acc, _), _) = score(&scene, &multi.sweep, 0.15);
    eprintln!(
        "slanted family wins on {:.1}% of textured pixels; {acc:.3} within 1%",
        100.0 * share
    );
    assert!(share > 0.6, "{share}");
    assert!(acc > 0.9, "{acc}");
    assert!(multi_family_sweep(&scene.views[0], &scene.images[0], &nbrs, &[], &cfg, true).is_err());
}

/// With the semi-global paths on, the sub-plane fit on the local costs
/// (`sgm.subplane_on_local`) lands nearer the true depth than the fit on the aggregated
/// sums, whose min-plus-penalty flattens the curve about the winner; the winners are the
/// same either way.
#[test]
fn subplane_fit_on_local_costs_beats_the_aggregated_fit() {
    let scene = TestScene::new();
    let family = PlaneFamily {
        planes: fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 24).unwrap(),
        spacing: Spacing::InverseDepth,
    };
    let nbrs = scene.neighbours();
    let run = |local: bool| {
        let cfg = SweepConfig {
            sgm: crate::photo::SgmConfig {
                paths: 8,
                subplane_on_local: local,
                ..Default::default()
            },
            ..Default::default()
        };
        let families = [family.clone()];
        multi_family_sweep(
            &scene.views[0],
            &scene.images[0],
            &nbrs,
            &families,
            &cfg,
            true,
        )
        .unwrap()
    };
    let (local, aggregated) = (run(true), run(false));
    assert_eq!(local.sweep.plane_index, aggregated.sweep.plane_index);
    let errors = |r: &FamilySweepResult| {
        let mut e = Vec::new();
        for y in 8..HEIGHT - 8 {
            for x in 8..WIDTH - 8 {
                let (z, s) = scene.truth(x, y);
                if s < -0.15 {
                    let d = r.sweep.depth[(y * WIDTH + x) as usize] as f64;
                    e.push(((d - z) / z).abs());
                }
            }
        }
        e.sort_by(f64::total_cmp);
        (e[e.len() / 2], e.iter().sum::<f64>() / e.len() as f64)
    };
    let ((lm, la), (am, aa)) = (errors(&local), errors(&aggregated));
    eprintln!("relative depth error median / mean: local fit {lm:.5} / {la:.5}, aggregated fit {am:.5} / {aa:.5}");
    assert!(lm < am && la < aa, "{lm} {la} vs {am} {aa}");
}

/// A neighbour that looks away from the surface gives no evidence: with
/// `min_evidence = 1` the cost is the seeing neighbour's alone; requiring two leaves
/// every pixel at 1.
#[test]
fn neighbours_without_evidence_are_left_out_of_best_k() {
    let scene = TestScene::new();
    let mut away = scene.views[2].clone();
    let eye = away.center();
    away.cam_from_world = look_at(&eye, &(eye * 2.0), &Vector3::z());
    let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 4).unwrap();
    let run = |nbrs: &[(&View, &ImageF32)], best_k: usize, min_evidence: usize| {
        let cfg = PhotoConfig {
            best_k,
            min_evidence,
            ..Default::default()
        };
        plane_cost_volume(&scene.views[0], &scene.images[0], nbrs, &planes, &cfg).unwrap()
    };
    let one = run(&[(&scene.views[1], &scene.images[1])], 1, 1);
    let pair = [
        (&scene.views[1], &scene.images[1]),
        (&away, &scene.images[2]),
    ];
    let lenient = run(&pair, 2, 1);
    assert_eq!(one.costs, lenient.costs);
    assert!(one.costs.iter().filter(|&&c| c < 0.5).count() > 1000);
    let strict = run(&pair, 2, 2);
    assert!(strict.costs.iter().all(|&c| c == 1.0));
}

#[test]
fn every_measure_and_aggregation_sweeps_the_texture() {
    let scene = TestScene::new();
    // 24 planes ~1.2% apart over the true range (4.6–5.4): debug builds stay quick.
    let planes = fronto_parallel_planes(&scene.views[0], 4.4, 5.8, 24).unwrap();
    let cases: Vec<(Measure, Aggregation, f64)> = vec![
        (Measure::Sad, Aggregation::Box { radius: 3 }, 0.95),
        (
            Measure::Ssd,
            Aggregation::Guided {
                radius: 3,
                eps: 1e-3,
            },
            0.95,
        ),
        (Measure::Census, Aggregation::None, 0.95),
        (Measure::Rank, Aggregation::None, 0.95),
        (
            Measure::MutualInformation,
            Aggregation::Bilateral {
                radius: 3,
                sigma_space: 2.0,
                sigma_color: 0.1,
            },
            0.9,
        ),
        (
            Measure::Ncc,
            Aggregation::WeightedMedian {
                radius: 2,
                sigma_space: 2.0,
                sigma_color: 0.1,
            },
            0.95,
        ),
    ];
    for (measure, aggregation, want) in cases {
        let cfg = SweepConfig {
            photo: PhotoConfig {
                measure,
                aggregation,
                window_radius: if measure == Measure::MutualInformation {
                    5
                } else {
                    3
                },
                ..Default::default()
            },
            ..Default::default()
        };
        let result = plane_sweep(
            &scene.views[0],
            &scene.images[0],
            &scene.neighbours(),
            &planes,
            &cfg,
        )
        .unwrap();
        // Within 2%: the nearest plane or its neighbour.
        let (mut ok, mut total) = (0, 0);
        for y in (8..HEIGHT - 8).step_by(2) {
            for x in (8..WIDTH - 8).step_by(2) {
                let (z, s) = scene.truth(x, y);
                if s < -0.15 {
                    let d = result.depth[(y * WIDTH + x) as usize] as f64;
                    ok += usize::from(((d - z) / z).abs() <= 0.02);
                    total += 1;
                }
            }
        }
        let frac = ok as f64 / total as f64;
        eprintln!(
            "{measure:?} + {aggregation:?}: {:.1}% within 2%",
            100.0 * frac
        );
        assert!(frac >= want, "{measure:?}: {frac}");
    }
}

/// The box-sum NCC path against the patch function on explicitly warped windows,
/// including windows that reach outside either image.
#[test]
fn box_sum_costs_match_patch_measures() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 3).unwrap();
    let nbr = [(&scene.views[1], &scene.images[1])];
    for (measure, color) in [
        (Measure::Ncc, ColorMode::Color),
        (Measure::Ncc, ColorMode::Gray),
        (Measure::Sad, ColorMode::Color),
        (Measure::Ssd, ColorMode::Gray),
    ] {
        let cfg = PhotoConfig {
            measure,
            color,
            best_k: 1,
            window_radius: 2,
            ..Default::default()
        };
        let volume =
            plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
        let (r, ch) = (2i64, if color == ColorMode::Color { 3 } else { 1 });
        let ref_img = if ch == 3 {
            scene.images[0].clone()
        } else {
            scene.images[0].to_gray()
        };
        let nbr_img = if ch == 3 {
            scene.images[1].clone()
        } else {
            scene.images[1].to_gray()
        };
        let norm = cfg.effective_normalization();
        let mut checked_partial = 0;
        for (k, plane) in planes.iter().enumerate() {
            let h = scene.homography(plane);
            for &(x, y) in &[
                (0i64, 0i64),
                (1, 60),
                (80, 60),
                (159, 119),
                (158, 3),
                (5, 117),
                (40, 20),
            ] {
                let (mut a, mut b) = (Vec::new(), Vec::new());
                let (mut inside, mut both) = (0, 0);
                for qy in y - r..=y + r {
                    for qx in x - r..=x + r {
                        let q_in = qx >= 0 && qy >= 0 && qx < WIDTH as i64 && qy < HEIGHT as i64;
                        let mut px = [f32::NAN; 3];
                        let mut ok = false;
                        if q_in {
                            let hx = h * Vector3::new(qx as f64 + 0.5, qy as f64 + 0.5, 1.0);
                            ok = hx.z > 0.0
                                && nbr_img.sample_bilinear(hx.x / hx.z, hx.y / hx.z, &mut px[..ch]);
                        }
                        inside += usize::from(q_in);
                        both += usize::from(ok);
                        for (c, &v) in px.iter().enumerate().take(ch) {
                            a.push(if q_in {
                                ref_img.get(qx as u32, qy as u32, c as u32)
                            } else {
                                f32::NAN
                            });
                            b.push(if ok { v } else { f32::NAN });
                        }
                    }
                }
                checked_partial += usize::from(both < inside && both > 0);
                let want = if both as f32 >= 0.5 * inside as f32 && both >= 2 {
                    norm.cost(raw_cost(measure, &a, &b, ch, 8))
                } else {
                    1.0
                };
                let got = volume.cost(x as usize, y as usize, k);
                assert!(
                    (got - want).abs() < 1e-4,
                    "{measure:?} {color:?} plane {k} ({x},{y}): {got} vs {want}"
                );
            }
        }
        assert!(
            checked_partial > 0,
            "no window was partly outside the neighbour"
        );
    }
}

/// A neighbour at the reference pose warps every pixel (identity homography): the box
/// path then reuses the reference's own integral tables; it must still match the patch
/// measure, window clipping at the image border included.
#[test]
fn fully_visible_warp_matches_patch_measures() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 2).unwrap();
    // The reference under a gain, a bias and noise: NCC costs land on the ramp.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut noisy = scene.images[0].clone();
    noisy
        .data
        .iter_mut()
        .for_each(|v| *v = 0.7 * *v + 0.1 + 0.04 * rng.random::<f32>());
    let other = &noisy;
    let nbr = [(&scene.views[0], other)];
    let mut on_ramp = 0;
    // Border pixels (clipped windows) and four pixels on the textured half.
    let mut pixels = vec![(0i64, 0i64), (2, 50), (159, 119), (100, 118)];
    let textured = (10..110)
        .step_by(23)
        .flat_map(|y| (10..150).step_by(31).map(move |x| (x, y)))
        .filter(|&(x, y)| scene.truth(x, y).1 < -0.2)
        .take(4);
    pixels.extend(textured.map(|(x, y)| (x as i64, y as i64)));
    assert_eq!(pixels.len(), 8);
    for color in [ColorMode::Gray, ColorMode::Color] {
        let cfg = PhotoConfig {
            color,
            best_k: 1,
            ..Default::default()
        };
        let volume =
            plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
        let ch = if color == ColorMode::Color { 3 } else { 1 };
        let (a_img, b_img) = if ch == 3 {
            (scene.images[0].clone(), other.clone())
        } else {
            (scene.images[0].to_gray(), other.to_gray())
        };
        let r = cfg.window_radius as i64;
        for &(x, y) in &pixels {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for qy in y - r..=y + r {
                for qx in x - r..=x + r {
                    let inside = qx >= 0 && qy >= 0 && qx < WIDTH as i64 && qy < HEIGHT as i64;
                    for c in 0..ch as u32 {
                        let get = |img: &ImageF32| {
                            if inside {
                                img.get(qx as u32, qy as u32, c)
                            } else {
                                f32::NAN
                            }
                        };
                        a.push(get(&a_img));
                        b.push(get(&b_img));
                    }
                }
            }
            let want = cfg
                .effective_normalization()
                .cost(raw_cost(Measure::Ncc, &a, &b, ch, 8));
            on_ramp += usize::from(want > 0.0 && want < 1.0);
            for k in 0..planes.len() {
                let got = volume.cost(x as usize, y as usize, k);
                assert!(
                    (got - want).abs() < 1e-4,
                    "{color:?} ({x},{y}): {got} vs {want}"
                );
            }
        }
    }
    assert!(on_ramp >= 8, "only {on_ramp} costs strictly inside (0, 1)");
}

#[test]
fn cost_volume_is_bit_identical_across_thread_counts() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 8).unwrap();
    let cfg = PhotoConfig {
        aggregation: Aggregation::Guided {
            radius: 2,
            eps: 1e-3,
        },
        ..Default::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                plane_cost_volume(
                    &scene.views[0],
                    &scene.images[0],
                    &scene.neighbours(),
                    &planes,
                    &cfg,
                )
                .unwrap()
            })
    };
    let one = run(1);
    let three = run(3);
    assert_eq!(one.costs.len(), (WIDTH * HEIGHT) as usize * 8);
    assert!(one
        .costs
        .iter()
        .zip(&three.costs)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(one.costs.iter().all(|c| (0.0..=1.0).contains(c)));
}

#[test]
fn best_k_ignores_an_occluded_neighbour() {
    let scene = TestScene::new();
    // A third "neighbour" whose image shows something else entirely (an occluder in
    // front of the whole surface).
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut junk = scene.images[2].clone();
    junk.data.iter_mut().for_each(|v| *v = rng.random());
    let mut nbrs = scene.neighbours();
    nbrs.push((&scene.views[2], &junk));
    let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 64).unwrap();
    let run = |nbrs: &[(&View, &ImageF32)], best_k: usize| {
        let cfg = SweepConfig {
            photo: PhotoConfig {
                best_k,
                ..Default::default()
            },
            ..Default::default()
        };
        let r = plane_sweep(&scene.views[0], &scene.images[0], nbrs, &planes, &cfg).unwrap();
        let mut costs: Vec<f32> = Vec::new();
        for y in 8..HEIGHT - 8 {
            for x in 8..WIDTH - 8 {
                if scene.truth(x, y).1 < -0.15 {
                    costs.push(r.cost[(y * WIDTH + x) as usize]);
                }
            }
        }
        costs.sort_by(f32::total_cmp);
        (score(&scene, &r, 0.15).0 .0, costs[costs.len() / 2])
    };
    let (clean_ok, clean_cost) = run(&scene.neighbours(), 2);
    let (robust_ok, robust_cost) = run(&nbrs, 2);
    let (all_ok, all_cost) = run(&nbrs, 3);
    eprintln!(
        "occluded neighbour: clean {clean_ok:.3}/{clean_cost:.3}, best-2 of 3 \
         {robust_ok:.3}/{robust_cost:.3}, all 3 {all_ok:.3}/{all_cost:.3}"
    );
    // Best-2 keeps the matching cost of the clean pair; averaging all three inflates
    // it by the occluded view's outlier cost (what the planemap data term would see).
    assert!(robust_ok >= 0.9, "{robust_ok}");
    assert!(
        (robust_cost - clean_cost).abs() < 0.02,
        "{robust_cost} vs {clean_cost}"
    );
    assert!(all_cost > clean_cost + 0.2, "{all_cost} vs {clean_cost}");
}

#[test]
fn plane_families_have_the_requested_geometry() {
    let scene = TestScene::new();
    let view = &scene.views[0];
    let depths = fronto_parallel_depths(2.0, 8.0, 5).unwrap();
    assert!((depths[0] - 2.0).abs() < 1e-12 && (depths[4] - 8.0).abs() < 1e-12);
    let inv: Vec<f64> = depths.iter().map(|d| 1.0 / d).collect();
    for w in inv.windows(3) {
        assert!(((w[0] - w[1]) - (w[1] - w[2])).abs() < 1e-12);
    }
    let planes = fronto_parallel_planes(view, 2.0, 8.0, 5).unwrap();
    for (plane, &z) in planes.iter().zip(&depths) {
        for (x, y) in [(0, 0), (80, 60), (159, 5)] {
            let xw = pixel_on_plane(view, x, y, plane).unwrap();
            assert!((view.project(&xw).unwrap().1 - z).abs() < 1e-9);
        }
    }
    assert!(fronto_parallel_depths(3.0, 2.0, 4).is_err());
    assert!(fronto_parallel_depths(1.0, 2.0, 0).is_err());
    let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
    let sweep = axis_sweep_planes(view, &axes, 4.0, 6.0, 10).unwrap();
    assert_eq!(sweep.len(), 30);
    // The y sweep (roughly the viewing direction) covers the depth range −6..−4.
    let ys: Vec<f64> = sweep[10..20].iter().map(|p| p.offset).collect();
    assert!(
        ys[0] < -0.3 && ys[9] > 1.0 && ys.windows(2).all(|w| w[1] > w[0]),
        "{ys:?}"
    );
    assert!(axis_planes(&[Vector3::zeros()], &[1.0]).is_err());
}

#[test]
fn neighbours_prefer_shared_points_at_useful_angles() {
    let cam = Camera::pinhole(64, 48, 60.0, 60.0, 32.0, 24.0);
    let target = Vector3::zeros();
    let view = |i: u32, eye: Vector3<f64>| View {
        id: i,
        name: format!("v{i}"),
        camera: cam.clone(),
        cam_from_world: look_at(&eye, &target, &Vector3::z()),
        image_path: None,
    };
    let views = vec![
        view(0, Vector3::new(0.0, -5.0, 0.0)),
        view(1, Vector3::new(0.05, -5.0, 0.0)), // almost no baseline
        view(2, Vector3::new(1.5, -5.0, 0.0)),  // ~17°: good
        view(3, Vector3::new(-1.5, -5.0, 0.0)), // good, but shares fewer points
        view(4, Vector3::new(-5.0, 0.0, 0.0)),  // 90°: too wide
        view(5, Vector3::new(0.0, -6.0, 0.0)),  // shares nothing
    ];
    let mut cloud = SparseCloud::default();
    for i in 0..40 {
        let p = Vector3::new((i % 7) as f64 * 0.1, 0.0, (i / 7) as f64 * 0.1);
        let track: Vec<u32> = if i < 25 {
            vec![0, 1, 2, 3, 4]
        } else {
            vec![0, 1, 2, 4]
        };
        cloud.positions.push(p);
        cloud.colors.push([0; 3]);
        cloud.tracks.push(track);
        cloud.errors.push(0.0);
        cloud.confidence.push(1.0);
    }
    let scene = Scene { views, cloud };
    assert_eq!(select_neighbours(&scene, 0, 3).unwrap(), vec![2, 3, 1]);
    assert_eq!(select_neighbours(&scene, 0, 10).unwrap(), vec![2, 3, 1, 4]);
    assert!(matches!(
        select_neighbours(&scene, 6, 2),
        Err(PhotoError::ViewIndex { index: 6, count: 6 })
    ));
    // Without tracks the optical-axis angle decides: view 4 (90°) comes last.
    let no_cloud = Scene {
        views: scene.views.clone(),
        cloud: SparseCloud::default(),
    };
    let order = select_neighbours(&no_cloud, 0, 5).unwrap();
    assert_eq!(order.len(), 5);
    // 2 and 3 (~17°) first, then the near-zero baseline 1; the 90° view 4 and the
    // same-axis view 5 both sit on the floor weight, tied, lower index first.
    assert_eq!(order, vec![2, 3, 1, 4, 5]);
}

#[test]
fn bad_inputs_are_errors() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.0, 4).unwrap();
    let cfg = PhotoConfig::default();
    assert!(plane_cost_volume(&scene.views[0], &scene.images[0], &[], &planes, &cfg).is_err());
    assert!(plane_cost_volume(
        &scene.views[0],
        &scene.images[0],
        &scene.neighbours(),
        &[],
        &cfg
    )
    .is_err());
    let small = ImageF32::filled(10, 10, 3, 0.5);
    let err =
        plane_cost_volume(&scene.views[0], &small, &scene.neighbours(), &planes, &cfg).unwrap_err();
    assert!(err.to_string().contains("cam0"), "{err}");
    let mut distorted = scene.views[1].clone();
    distorted.camera = Camera::new(
        crate::geometry::CameraModel::SimpleRadial,
        WIDTH,
        HEIGHT,
        vec![FOCAL, 80.0, 60.0, 0.1],
    )
    .unwrap();
    let err = plane_cost_volume(
        &scene.views[0],
        &scene.images[0],
        &[(&distorted, &scene.images[1])],
        &planes,
        &cfg,
    )
    .unwrap_err();
    assert!(matches!(err, PhotoError::Distorted(_)));
    let volume = plane_cost_volume(
        &scene.views[0],
        &scene.images[0],
        &scene.neighbours(),
        &planes,
        &cfg,
    )
    .unwrap();
    assert!(winner_takes_all(&volume, &scene.views[0], &planes[..2], 1).is_err());
}

/// A textured foreground half-plane (depth 4, bright) in front of a textured background
/// plane (depth 6, dark), seen by a reference camera and two neighbours 0.6 m to either
/// side; returns the views, images and the reference's true depth per pixel.
fn depth_edge_scene() -> (Vec<View>, Vec<ImageF32>, Vec<f64>) {
    occluder_scene(|x| x < 0.0)
}

/// [`depth_edge_scene`] with the foreground (plane y = −1, depth 4) where `front(x)`.
fn occluder_scene(front: impl Fn(f64) -> bool) -> (Vec<View>, Vec<ImageF32>, Vec<f64>) {
    let views: Vec<View> = [-0.6, 0.0, 0.6]
        .iter()
        .enumerate()
        .map(|(i, &dx)| {
            let eye = Vector3::new(dx, -5.0, 0.0);
            test_view(i, &eye, &(eye + Vector3::y()))
        })
        .collect();
    // (grey level, depth along +y from the cameras' plane y = −5) of what a ray sees.
    let hit = |o: &Vector3<f64>, d: &Vector3<f64>| -> (f64, f64) {
        let near = o + d * ((-1.0 - o.y) / d.y);
        if front(near.x) {
            let g = 0.55 + 0.4 * value_noise(near.x, near.z, 0.05, 3);
            return (g, near.y + 5.0);
        }
        let back = o + d * ((1.0 - o.y) / d.y);
        (0.05 + 0.4 * value_noise(back.x, back.z, 0.05, 4), 6.0)
    };
    let images: Vec<ImageF32> = views
        .iter()
        .enumerate()
        .map(|(i, view)| ray_cast(view, 7 + i as u64, |o, d| [hit(o, d).0 as f32; 3]))
        .collect();
    let reference = &views[1];
    let truth = (0..HEIGHT * WIDTH)
        .map(|p| {
            let (o, d) = reference.ray(&Vector2::new(
                (p % WIDTH) as f64 + 0.5,
                (p / WIDTH) as f64 + 0.5,
            ));
            hit(&o, &d).1
        })
        .collect();
    (views, images, truth)
}

/// The sweep baseline's aggregation (5×5 NCC, guided filter over 15×15) against a plain
/// 15×15 NCC window at a depth edge: both are accurate away from it, but the big window
/// drags the foreground's depth over the background beside the edge (fattening) and the
/// edge-aware filter much less.
#[test]
fn guided_aggregation_fattens_depth_edges_less_than_a_big_window() {
    let (views, images, truth) = depth_edge_scene();
    let nbrs = [(&views[0], &images[0]), (&views[2], &images[2])];
    let planes = fronto_parallel_planes(&views[1], 3.5, 7.0, 96).unwrap();
    // Pixels within 7 px (horizontally) of a depth jump, and the rest; border excluded.
    let w = WIDTH as usize;
    let near_edge = |p: usize| {
        let (x, y) = (p % w, p / w);
        (x.saturating_sub(7)..(x + 8).min(w)).any(|q| (truth[y * w + q] - truth[p]).abs() > 0.5)
    };
    let score = |cfg: &PhotoConfig| {
        let sweep = SweepConfig {
            photo: *cfg,
            ..Default::default()
        };
        let r = plane_sweep(&views[1], &images[1], &nbrs, &planes, &sweep).unwrap();
        let (mut near, mut far) = ((0usize, 0usize), (0usize, 0usize));
        for y in 10..HEIGHT as usize - 10 {
            for x in 10..w - 10 {
                let p = y * w + x;
                let ok = ((r.depth[p] as f64 - truth[p]) / truth[p]).abs() <= 0.01;
                let slot = if near_edge(p) { &mut near } else { &mut far };
                slot.0 += usize::from(ok);
                slot.1 += 1;
            }
        }
        (near.0 as f64 / near.1 as f64, far.0 as f64 / far.1 as f64)
    };
    let window = score(&PhotoConfig {
        window_radius: 7,
        ..Default::default()
    });
    let guided = score(&PhotoConfig {
        window_radius: 2,
        aggregation: Aggregation::Guided {
            radius: 7,
            eps: 1e-3,
        },
        ..Default::default()
    });
    eprintln!(
        "near / away from the edge within 1%: 15x15 NCC {window:.3?}, 5x5 + guided {guided:.3?}"
    );
    assert!(
        window.1 >= 0.95 && guided.1 >= 0.95,
        "away from the edge: {window:?} {guided:?}"
    );
    assert!(
        guided.0 >= window.0 + 0.3,
        "near the edge: guided {} vs window {}",
        guided.0,
        window.0
    );
}

/// The window samples of reference pixel `(x, y)` against neighbour `j` on `plane`: the
/// reference's grey value, the warped neighbour's (`NaN` where it does not warp inside)
/// and the support weight, for every window pixel inside the image.
fn window_samples(
    scene: &TestScene,
    plane: &Plane,
    (x, y): (i64, i64),
    r: i64,
    (sigma_color, sigma_space): (f32, f32),
) -> Vec<(f32, f32, f32)> {
    let (ref_grey, nbr_grey) = (scene.images[0].to_gray(), scene.images[1].to_gray());
    let h = scene.homography(plane);
    let colour = |qx: i64, qy: i64| scene.images[0].pixel(qx as u32, qy as u32).to_vec();
    let centre = colour(x, y);
    let mut out = Vec::new();
    for qy in (y - r).max(0)..=(y + r).min(HEIGHT as i64 - 1) {
        for qx in (x - r).max(0)..=(x + r).min(WIDTH as i64 - 1) {
            let d2: f32 = colour(qx, qy)
                .iter()
                .zip(&centre)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>()
                / 3.0;
            let s2 = ((qx - x) * (qx - x) + (qy - y) * (qy - y)) as f32;
            let weight = (-d2 / (2.0 * sigma_color * sigma_color)
                - s2 / (2.0 * sigma_space * sigma_space))
                .exp();
            let hx = h * Vector3::new(qx as f64 + 0.5, qy as f64 + 0.5, 1.0);
            let mut px = [f32::NAN];
            let ok = hx.z > 0.0 && nbr_grey.sample_bilinear(hx.x / hx.z, hx.y / hx.z, &mut px);
            let v = if ok { px[0] } else { f32::NAN };
            out.push((ref_grey.get(qx as u32, qy as u32, 0), v, weight));
        }
    }
    out
}

/// The support-weighted NCC path against a naive weighted NCC (weighted means, weighted
/// centred moments, per-weight texture threshold), windows partly outside the neighbour
/// included; and with huge σ it is the box NCC.
#[test]
fn support_weighted_ncc_matches_a_naive_weighted_ncc() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 3).unwrap();
    let nbr = [(&scene.views[1], &scene.images[1])];
    let sigmas = (0.1f32, 2.0f32);
    let cfg = PhotoConfig {
        best_k: 1,
        window_radius: 2,
        support_sigma_color: sigmas.0 as f64,
        support_sigma_space: sigmas.1 as f64,
        ..Default::default()
    };
    let volume = plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
    let norm = cfg.effective_normalization();
    let mut partial = 0;
    for (k, plane) in planes.iter().enumerate() {
        for &(x, y) in &[
            (0i64, 0i64),
            (1, 60),
            (80, 60),
            (159, 119),
            (158, 3),
            (40, 20),
            (75, 61),
        ] {
            let samples = window_samples(&scene, plane, (x, y), 2, sigmas);
            let total: f64 = samples.iter().map(|s| s.2 as f64).sum();
            let valid: Vec<_> = samples.iter().filter(|s| s.1.is_finite()).collect();
            partial += usize::from(valid.len() < samples.len() && !valid.is_empty());
            let wsum: f64 = valid.iter().map(|s| s.2 as f64).sum();
            let want = if wsum > 0.0 && wsum >= 0.5 * total {
                let mean = |f: &dyn Fn(&(f32, f32, f32)) -> f32| {
                    valid.iter().map(|s| s.2 as f64 * f(s) as f64).sum::<f64>() / wsum
                };
                let (mi, mv) = (mean(&|s| s.0), mean(&|s| s.1));
                let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
                for s in &valid {
                    let (di, dv) = (s.0 as f64 - mi, s.1 as f64 - mv);
                    cov += s.2 as f64 * di * dv;
                    va += s.2 as f64 * di * di;
                    vb += s.2 as f64 * dv * dv;
                }
                let min = crate::photo::measures::NCC_MIN_VARIANCE * wsum;
                let score = (va > min && vb > min)
                    .then(|| (cov / (va * vb).sqrt()).clamp(-1.0, 1.0) as f32);
                norm.cost(score.map(|s| 1.0 - s))
            } else {
                1.0
            };
            let got = volume.cost(x as usize, y as usize, k);
            assert!(
                (got - want).abs() < 2e-4,
                "plane {k} ({x},{y}): weighted path {got} vs naive {want}"
            );
        }
    }
    assert!(partial > 0, "no window was partly outside the neighbour");
    // σ → ∞: every weight 1, the box NCC.
    let flat = PhotoConfig {
        support_sigma_color: 1e6,
        support_sigma_space: 1e6,
        ..cfg
    };
    let boxed = PhotoConfig {
        support_sigma_color: 0.0,
        ..cfg
    };
    let a = plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &flat).unwrap();
    let b = plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &boxed).unwrap();
    let worst = a
        .costs
        .iter()
        .zip(&b.costs)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-4,
        "uniform weights differ from the box NCC by {worst}"
    );
}

/// Weighted NCC keeps NCC's invariance: a gain and a bias on the neighbour change no cost.
#[test]
fn support_weighted_ncc_ignores_gain_and_bias() {
    let scene = TestScene::new();
    let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 4).unwrap();
    let cfg = PhotoConfig {
        best_k: 1,
        window_radius: 2,
        support_sigma_color: 0.08,
        support_sigma_space: 2.0,
        ..Default::default()
    };
    let mut dimmed = scene.images[1].clone();
    for v in &mut dimmed.data {
        *v = 0.6 * *v + 0.2;
    }
    let volume = |img: &ImageF32| {
        plane_cost_volume(
            &scene.views[0],
            &scene.images[0],
            &[(&scene.views[1], img)],
            &planes,
            &cfg,
        )
        .unwrap()
    };
    let (a, b) = (volume(&scene.images[1]), volume(&dimmed));
    // On the textured half (on plain paint the gain moves the variance across NCC's
    // texture threshold, as it does for the box NCC).
    let mut checked = 0;
    let mut worst = 0.0f32;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            if scene.truth(x, y).1 > -0.1 {
                continue;
            }
            for k in 0..planes.len() {
                let (ca, cb) = (
                    a.cost(x as usize, y as usize, k),
                    b.cost(x as usize, y as usize, k),
                );
                worst = worst.max((ca - cb).abs());
                checked += usize::from(ca < 1.0);
            }
        }
    }
    assert!(checked > 2_000, "{checked} costs checked");
    assert!(worst < 1e-3, "gain and bias moved a cost by {worst}");
}

/// Bright pickets 0.1 m wide every 0.5 m (about 4 px, every 19 px) in front of a dark
/// textured wall 2 m behind them: with box-weighted 5×5 NCC (then the guided filter, as
/// the sweep baseline) the wall between the pickets takes their depth; with adaptive
/// support weights the wall's pixels match the wall.
#[test]
fn support_weights_keep_a_picket_fence_depth_off_the_wall_behind() {
    let picket = |x: f64| x.rem_euclid(0.5) < 0.1;
    let (views, images, truth) = occluder_scene(picket);
    let nbrs = [(&views[0], &images[0]), (&views[2], &images[2])];
    let planes = fronto_parallel_planes(&views[1], 3.5, 7.0, 96).unwrap();
    let w = WIDTH as usize;
    // Wall pixels within 4 px (horizontally) of a picket, away from the border.
    let beside: Vec<usize> = (10..HEIGHT as usize - 10)
        .flat_map(|y| (10..w - 10).map(move |x| y * w + x))
        .filter(|&p| {
            let (x, y) = (p % w, p / w);
            truth[p] > 5.0 && (x - 4..=x + 4).any(|q| truth[y * w + q] < 5.0)
        })
        .collect();
    let score = |sigma_color: f64| {
        let sweep = SweepConfig {
            photo: PhotoConfig {
                window_radius: 2,
                aggregation: Aggregation::Guided {
                    radius: 7,
                    eps: 1e-3,
                },
                support_sigma_color: sigma_color,
                support_sigma_space: 3.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let r = plane_sweep(&views[1], &images[1], &nbrs, &planes, &sweep).unwrap();
        beside
            .iter()
            .filter(|&&p| ((r.depth[p] as f64 - truth[p]) / truth[p]).abs() <= 0.01)
            .count() as f64
            / beside.len() as f64
    };
    let (boxed, weighted) = (score(0.0), score(0.05));
    eprintln!(
        "wall beside the pickets within 1%: box {boxed:.3}, weighted {weighted:.3} ({} px)",
        beside.len()
    );
    assert!(
        beside.len() > 1000,
        "{} wall pixels beside pickets",
        beside.len()
    );
    assert!(
        weighted >= boxed + 0.2,
        "weighted {weighted} vs box {boxed}"
    );
}
