//! A hand-built Manhattan scene for the tests: the inside of a room corner (walls x = 0 and
//! y = 0, floor z = 0, each a 4×4 square), three pinhole views looking into it, sparse points
//! sampled on the faces, distractor planes, and rendered grey images with a painted stripe.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::geometry::{look_at, Camera, Plane};
use crate::raster::ImageF32;
use crate::scene::{SparseCloud, View};

/// Side of each face square.
pub const FACE: f64 = 4.0;
/// Stripe painted on the wall x = 0: centre (y, z), in-plane direction angle (radians from
/// +y toward +z), half-width.
pub const STRIPE_CENTRE: (f64, f64) = (2.2, 1.8);
/// Direction angle of the stripe (137°: in view 0 its image direction is ≥ 35° away from
/// the direction toward every vanishing point).
pub const STRIPE_ANGLE: f64 = 137.0 * std::f64::consts::PI / 180.0;
/// Stripe half-width.
pub const STRIPE_HALF_WIDTH: f64 = 0.12;

pub struct CornerScene {
    pub views: Vec<View>,
    pub images: Vec<ImageF32>,
    pub cloud: SparseCloud,
    /// 0: x = 0, 1: y = 0, 2: z = 0 (true); then distractors; the last is behind all
    /// cameras.
    pub planes: Vec<Plane>,
    /// True plane index of each point.
    pub true_label: Vec<usize>,
    pub scale: f64,
    pub directions: Vec<Vector3<f64>>,
}

pub fn corner_views() -> Vec<View> {
    let cam = Camera::pinhole(160, 120, 130.0, 130.0, 80.0, 60.0);
    let target = Vector3::new(1.2, 1.2, 1.0);
    [
        Vector3::new(7.0, 5.5, 3.5),
        Vector3::new(5.0, 7.5, 3.0),
        Vector3::new(8.0, 4.0, 4.5),
    ]
    .iter()
    .enumerate()
    .map(|(i, eye)| View {
        id: i as u32 + 1,
        name: format!("v{i}.png"),
        camera: cam.clone(),
        cam_from_world: look_at(eye, &target, &Vector3::z()),
        image_path: None,
    })
    .collect()
}

/// The face (0, 1, 2) hit first by the world ray `origin + t·dir`, with its hit point.
pub fn cast(origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<(usize, Vector3<f64>)> {
    let mut best: Option<(f64, usize)> = None;
    for axis in 0..3 {
        if dir[axis].abs() < 1e-12 {
            continue;
        }
        let t = -origin[axis] / dir[axis];
        if t <= 0.0 {
            continue;
        }
        let x = origin + dir * t;
        let inside = (0..3)
            .filter(|&k| k != axis)
            .all(|k| x[k] >= 0.0 && x[k] <= FACE);
        if inside && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, axis));
        }
    }
    best.map(|(t, axis)| (axis, origin + dir * t))
}

/// Whether a point of the wall x = 0 lies on the painted stripe.
pub fn on_stripe(x: &Vector3<f64>) -> bool {
    let (cy, cz) = STRIPE_CENTRE;
    // In-plane normal of the stripe direction (cos a, sin a) in (y, z).
    let (ny, nz) = (-STRIPE_ANGLE.sin(), STRIPE_ANGLE.cos());
    ((x.y - cy) * ny + (x.z - cz) * nz).abs() < STRIPE_HALF_WIDTH
}

/// Grey rendering with 4×4 supersampling: faces 0.3 / 0.55 / 0.8, stripe 1.0, sky 0.05.
pub fn render(view: &View) -> ImageF32 {
    const SS: u32 = 4;
    let (w, h) = (view.camera.width, view.camera.height);
    let mut img = ImageF32::filled(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for sy in 0..SS {
                for sx in 0..SS {
                    let u = x as f64 + (sx as f64 + 0.5) / SS as f64;
                    let v = y as f64 + (sy as f64 + 0.5) / SS as f64;
                    let (o, d) = view.ray(&nalgebra::Vector2::new(u, v));
                    sum += match cast(&o, &d) {
                        Some((0, p)) if on_stripe(&p) => 1.0,
                        Some((face, _)) => [0.3, 0.55, 0.8][face],
                        None => 0.05,
                    };
                }
            }
            img.pixel_mut(x, y)[0] = sum / (SS * SS) as f32;
        }
    }
    img
}

pub fn corner_scene() -> CornerScene {
    let views = corner_views();
    let images = views.iter().map(render).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut cloud = SparseCloud::default();
    let mut true_label = Vec::new();
    for face in 0..3 {
        for _ in 0..150 {
            let mut p = Vector3::zeros();
            for k in 0..3 {
                if k != face {
                    p[k] = rng.random_range(0.05..FACE - 0.05);
                }
            }
            // Concave corner seen from inside: visible wherever it projects into the image.
            let track: Vec<u32> = views
                .iter()
                .enumerate()
                .filter(|(_, v)| {
                    v.project(&p)
                        .is_some_and(|(xy, z)| z > 0.0 && v.camera.contains(&xy))
                })
                .map(|(i, _)| i as u32)
                .collect();
            if track.is_empty() {
                continue;
            }
            cloud.positions.push(p);
            cloud.colors.push([128; 3]);
            cloud.tracks.push(track);
            cloud.errors.push(0.5);
            cloud.confidence.push(rng.random_range(0.5..1.0));
            true_label.push(face);
        }
    }
    let planes = vec![
        Plane::new(Vector3::x(), 0.0),
        Plane::new(Vector3::y(), 0.0),
        Plane::new(Vector3::z(), 0.0),
        Plane::new(Vector3::x(), 2.0),
        Plane::new(Vector3::y(), 1.5),
        Plane::new(Vector3::z(), 1.7),
        Plane::new(Vector3::x(), -1.0),
        Plane::new(Vector3::x(), 30.0),
    ];
    CornerScene {
        views,
        images,
        cloud,
        planes,
        true_label,
        scale: 0.02,
        directions: vec![Vector3::x(), Vector3::y(), Vector3::z()],
    }
}
