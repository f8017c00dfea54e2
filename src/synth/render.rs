//! Camera rigs → views, and the ray-casting renderer with exact per-pixel ground truth.

use nalgebra::{Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::spec::{RigSpec, SceneSpec};
use super::texture::mix64;
use super::world::World;
use super::{RenderOptions, SynthError};
use crate::geometry::{look_at, Camera, CameraModel};
use crate::raster::ImageF32;
use crate::scene::View;

type V3 = Vector3<f64>;

/// The shared camera of a scene, at the requested size.
pub(crate) fn build_camera(spec: &SceneSpec, opts: &RenderOptions) -> Result<Camera, SynthError> {
    let c = &spec.camera;
    let (w0, h0) = (c.width, c.height);
    let f = match (c.focal_px, c.hfov_deg) {
        (Some(f), _) => f,
        (None, h) => {
            let hfov = h.unwrap_or(70.0).to_radians();
            0.5 * w0 as f64 / (0.5 * hfov).tan()
        }
    };
    let (model, params) = if c.radial_k != 0.0 {
        (
            CameraModel::SimpleRadial,
            vec![f, 0.5 * w0 as f64, 0.5 * h0 as f64, c.radial_k],
        )
    } else {
        (
            CameraModel::SimplePinhole,
            vec![f, 0.5 * w0 as f64, 0.5 * h0 as f64],
        )
    };
    let cam = Camera::new(model, w0, h0, params).map_err(|e| SynthError::Invalid {
        origin: spec.name.clone(),
        line: None,
        message: format!("camera: {e}"),
    })?;
    let (w, h) = match (opts.width, opts.height) {
        (None, None) => return Ok(cam),
        (Some(w), None) => (
            w,
            ((w as f64 * h0 as f64 / w0 as f64).round() as u32).max(1),
        ),
        (None, Some(h)) => (
            ((h as f64 * w0 as f64 / h0 as f64).round() as u32).max(1),
            h,
        ),
        (Some(w), Some(h)) => (w, h),
    };
    if w == 0 || h == 0 {
        return Err(SynthError::Invalid {
            origin: spec.name.clone(),
            line: None,
            message: format!("requested image size {w}x{h} must be positive"),
        });
    }
    super::spec::check_render_size(w, h, rig_poses(spec).len(), "requested ").map_err(
        |message| SynthError::Invalid {
            origin: spec.name.clone(),
            line: None,
            message,
        },
    )?;
    Ok(cam.rescaled(w, h))
}

/// Camera centres and targets of all rigs, in order, with their up vectors.
pub(crate) fn rig_poses(spec: &SceneSpec) -> Vec<(V3, V3, V3)> {
    let mut out = Vec::new();
    for rig in &spec.rigs {
        match rig {
            RigSpec::Orbit {
                center,
                radius,
                height,
                count,
                look_at,
                start_deg,
                arc_deg,
                up,
            } => {
                let c = V3::from(*center);
                let target = look_at.map(V3::from).unwrap_or(c);
                // A full circle does not repeat its first camera; an arc includes both ends.
                let full = (arc_deg.abs() - 360.0).abs() < 1e-9;
                let steps = if full || *count == 1 {
                    *count as f64
                } else {
                    (*count - 1) as f64
                };
                for i in 0..*count {
                    let a = (start_deg + arc_deg * i as f64 / steps.max(1.0)).to_radians();
                    let eye = V3::new(c.x + radius * a.cos(), c.y + radius * a.sin(), *height);
                    out.push((eye, target, V3::from(*up)));
                }
            }
            RigSpec::Walk {
                positions,
                targets,
                path,
                count,
                target,
                up,
            } => {
                let up = V3::from(*up);
                if !positions.is_empty() {
                    for (i, p) in positions.iter().enumerate() {
                        let t = if targets.len() == 1 {
                            targets[0]
                        } else {
                            targets[i]
                        };
                        out.push((V3::from(*p), V3::from(t), up));
                    }
                } else {
                    let pts: Vec<V3> = path.iter().map(|p| V3::from(*p)).collect();
                    let seg: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
                    let total: f64 = seg.iter().sum();
                    for i in 0..*count {
                        let want = if *count == 1 {
                            0.0
                        } else {
                            total * i as f64 / (*count - 1) as f64
                        };
                        let (mut acc, mut k) = (0.0, 0);
                        while k + 1 < seg.len() && acc + seg[k] < want {
                            acc += seg[k];
                            k += 1;
                        }
                        let (eye, dir) = if seg.is_empty() {
                            (pts[0], V3::x())
                        } else {
                            let f = if seg[k] > 0.0 {
                                ((want - acc) / seg[k]).clamp(0.0, 1.0)
                            } else {
                                0.0
                            };
                            (pts[k] + (pts[k + 1] - pts[k]) * f, pts[k + 1] - pts[k])
                        };
                        let tgt = target.map(V3::from).unwrap_or(eye + dir);
                        out.push((eye, tgt, up));
                    }
                }
            }
            RigSpec::Facade {
                start,
                end,
                count,
                facing,
                distance,
                up,
            } => {
                let (a, b) = (V3::from(*start), V3::from(*end));
                let dir = V3::from(*facing).normalize();
                for i in 0..*count {
                    let f = if *count == 1 {
                        0.5
                    } else {
                        i as f64 / (*count - 1) as f64
                    };
                    let eye = a + (b - a) * f;
                    out.push((eye, eye + dir * *distance, V3::from(*up)));
                }
            }
            RigSpec::List { views, up } => {
                for v in views {
                    out.push((V3::from(v.position), V3::from(v.target), V3::from(*up)));
                }
            }
        }
    }
    out
}

/// Internal per-view render output; the public [`super::RenderedView`] is built from it.
pub(crate) struct ViewRender {
    pub image: ImageF32,
    /// Noise-free image (exposure applied) used to detect features.
    pub clean_gray: Vec<f32>,
    pub clean_rgb: Vec<f32>,
    pub depth: Vec<f32>,
    pub normals: Vec<[f32; 3]>,
    pub plane_id: Vec<u16>,
    /// Primitive index per pixel, `u32::MAX` for background.
    pub prim: Vec<u32>,
    /// The surface under the pixel centre is textured at the pixel's scale (see
    /// [`render_view`]).
    pub textured: Vec<bool>,
}

/// Shading parameters shared by all pixels of a view.
pub(crate) struct Shading {
    pub sun_to: V3,
    pub sun_intensity: f64,
    pub ambient: f64,
    pub sky: [f64; 3],
}

impl Shading {
    pub fn new(spec: &SceneSpec) -> Shading {
        let l = &spec.lighting;
        Shading {
            sun_to: -V3::from(l.sun_direction).normalize(),
            sun_intensity: l.sun_intensity,
            ambient: l.ambient,
            sky: l.sky_color,
        }
    }
}

/// Colour (before exposure) seen along a ray.
#[inline]
fn radiance(world: &World, shading: &Shading, origin: &V3, dir: &V3) -> [f64; 3] {
    match world.trace(origin, dir) {
        None => shading.sky,
        Some(hit) => {
            let surf = world.surface(&hit, origin, dir);
            let m = &world.materials[world.prims[hit.prim as usize].material];
            let a = m.albedo(surf.s, surf.t);
            let light =
                shading.ambient + shading.sun_intensity * surf.normal.dot(&shading.sun_to).max(0.0);
            [a[0] * light, a[1] * light, a[2] * light]
        }
    }
}

/// Standard normal sample by Box–Muller (keeps only the cosine branch: simple and
/// deterministic per draw).
#[inline]
pub(crate) fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Renders one view: antialiased noisy image, noise-free image, and ground truth at the
/// pixel-centre rays. A pixel's surface counts as textured when its material's albedo
/// contrast within two pixel footprints of the hit is at least `min_texture_contrast` —
/// the test the SfM sampler uses for a feature (`[sparse] min_texture_contrast`), so plain
/// paint never is, whatever its neighbours look like in the image.
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_view(
    world: &World,
    shading: &Shading,
    view: &View,
    antialias: u32,
    exposure: f64,
    noise_sigma: f64,
    noise_seed: u64,
    min_texture_contrast: f64,
) -> ViewRender {
    let cam = &view.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let world_from_cam = view.cam_from_world.rotation.inverse();
    let origin = view.center();
    let n = w * h;
    let mut out = ViewRender {
        image: ImageF32::filled(cam.width, cam.height, 3, 0.0),
        clean_gray: vec![0.0; n],
        clean_rgb: vec![0.0; 3 * n],
        depth: vec![0.0; n],
        normals: vec![[0.0; 3]; n],
        plane_id: vec![0; n],
        prim: vec![u32::MAX; n],
        textured: vec![false; n],
    };
    let focal = cam.fx();
    let aa = antialias.max(1) as usize;
    let inv_samples = 1.0 / (aa * aa) as f64;
    let rows = out
        .image
        .data
        .par_chunks_mut(3 * w)
        .zip(out.clean_rgb.par_chunks_mut(3 * w))
        .zip(out.clean_gray.par_chunks_mut(w))
        .zip(out.depth.par_chunks_mut(w))
        .zip(out.normals.par_chunks_mut(w))
        .zip(out.plane_id.par_chunks_mut(w))
        .zip(out.prim.par_chunks_mut(w))
        .zip(out.textured.par_chunks_mut(w))
        .enumerate();
    rows.for_each(
        |(y, (((((((img, clean), gray), depth), normals), plane_id), prim), textured))| {
            let mut rng = ChaCha8Rng::seed_from_u64(mix64(noise_seed ^ mix64(y as u64)));
            for x in 0..w {
                // Ground truth along the pixel-centre ray (unit depth step ⇒ t = depth).
                let dir = world_from_cam * cam.pixel_ray(x as u32, y as u32);
                if let Some(hit) = world.trace(&origin, &dir) {
                    let surf = world.surface(&hit, &origin, &dir);
                    depth[x] = hit.t as f32;
                    normals[x] = [
                        surf.normal.x as f32,
                        surf.normal.y as f32,
                        surf.normal.z as f32,
                    ];
                    let p = &world.prims[hit.prim as usize];
                    plane_id[x] = p.plane.map_or(0, |i| (i + 1) as u16);
                    prim[x] = hit.prim;
                    let footprint = hit.t / focal;
                    textured[x] =
                        world.materials[p.material].contrast(surf.s, surf.t, 2.0 * footprint)
                            >= min_texture_contrast;
                }
                // Colour: mean over an aa × aa grid of subpixel rays.
                let mut c = [0.0f64; 3];
                for sy in 0..aa {
                    for sx in 0..aa {
                        let xy = Vector2::new(
                            x as f64 + (sx as f64 + 0.5) / aa as f64,
                            y as f64 + (sy as f64 + 0.5) / aa as f64,
                        );
                        let d = world_from_cam * cam.unproject(&xy);
                        let r = radiance(world, shading, &origin, &d);
                        c[0] += r[0];
                        c[1] += r[1];
                        c[2] += r[2];
                    }
                }
                for k in 0..3 {
                    let v = (c[k] * inv_samples * exposure).clamp(0.0, 1.0);
                    clean[3 * x + k] = v as f32;
                    let noisy = if noise_sigma > 0.0 {
                        v + noise_sigma * gaussian(&mut rng)
                    } else {
                        v
                    };
                    img[3 * x + k] = noisy.clamp(0.0, 1.0) as f32;
                }
                gray[x] =
                    0.299 * clean[3 * x] + 0.587 * clean[3 * x + 1] + 0.114 * clean[3 * x + 2];
            }
        },
    );
    out
}

/// Views (ids from 1, names `view_0000.png`) from the rigs.
pub(crate) fn build_views(spec: &SceneSpec, camera: &Camera) -> Vec<View> {
    rig_poses(spec)
        .into_iter()
        .enumerate()
        .map(|(i, (eye, target, up))| View {
            id: i as u32 + 1,
            name: format!("view_{i:04}.png"),
            camera: camera.clone(),
            cam_from_world: look_at(&eye, &target, &up),
            image_path: None,
        })
        .collect()
}
