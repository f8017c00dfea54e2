//! Baseline: per-view Delaunay interpolation of the sparse points, the way OpenMVS
//! initialises a depth map before its PatchMatch refinement (`DepthMapsData::InitViews` →
//! `TriangulatePoints2DepthMap`): the sparse points seen by the view are projected, their
//! image positions triangulated (2D Delaunay, spade), and each triangle is rasterised with
//! the 3D plane through its three points. A 3D plane is linear in inverse depth over the
//! image, so this is barycentric interpolation of *inverse* depth; the normal is the
//! triangle's. Pixels outside the convex hull of the projections get no depth.

use nalgebra::Vector3;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

use crate::scene::Scene;

/// A projected sparse point: image position (pixels, centre of pixel (0,0) at (0.5, 0.5))
/// and camera-frame depth z.
#[derive(Debug, Clone, Copy)]
struct Projected {
    xy: Point2<f64>,
    depth: f64,
}

impl HasPosition for Projected {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.xy
    }
}

/// One view's interpolated depth map.
#[derive(Debug, Clone)]
pub struct DelaunayDepth {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Depth (camera z) per pixel, row-major; 0 = outside the triangulation.
    pub depth: Vec<f32>,
    /// Camera-frame unit normal of the pixel's triangle, facing the camera; zero where no
    /// depth.
    pub normals: Vec<[f32; 3]>,
    /// Sparse points triangulated.
    pub points: usize,
    /// Triangles rasterised.
    pub triangles: usize,
}

/// Interpolates view `index` of an undistorted (pinhole) scene from the sparse points
/// whose tracks contain the view and that project in front of it.
pub fn delaunay_view(scene: &Scene, index: usize) -> DelaunayDepth {
    let view = &scene.views[index];
    let (w, h) = (view.camera.width, view.camera.height);
    let mut tri: DelaunayTriangulation<Projected> = DelaunayTriangulation::new();
    let mut points = 0;
    for (p, track) in scene.cloud.positions.iter().zip(&scene.cloud.tracks) {
        if !track.contains(&(index as u32)) {
            continue;
        }
        let Some((xy, z)) = view.project(p) else {
            continue;
        };
        if !(z > 0.0 && xy.x.is_finite() && xy.y.is_finite()) {
            continue;
        }
        // Points slightly outside the frame still help cover its border.
        if tri
            .insert(Projected {
                xy: Point2::new(xy.x, xy.y),
                depth: z,
            })
            .is_ok()
        {
            points += 1;
        }
    }
    let n = (w * h) as usize;
    let mut depth = vec![0f32; n];
    let mut normals = vec![[0f32; 3]; n];
    let mut triangles = 0;
    for face in tri.inner_faces() {
        let v = face.vertices().map(|v| *v.data());
        rasterise(view, &v, w, h, &mut depth, &mut normals);
        triangles += 1;
    }
    DelaunayDepth {
        width: w,
        height: h,
        depth,
        normals,
        points,
        triangles,
    }
}

/// Fills the pixels whose centres lie in the triangle (edges inclusive; a shared edge is
/// written by both faces with the same plane, so the order does not matter beyond rounding
/// and the face order is deterministic).
fn rasterise(
    view: &crate::scene::View,
    v: &[Projected; 3],
    w: u32,
    h: u32,
    depth: &mut [f32],
    normals: &mut [[f32; 3]],
) {
    let [a, b, c] = v;
    let det = (b.xy.x - a.xy.x) * (c.xy.y - a.xy.y) - (c.xy.x - a.xy.x) * (b.xy.y - a.xy.y);
    if det.abs() < 1e-12 {
        return;
    }
    // Camera-frame 3D points and the triangle's normal, facing the camera.
    let cam = |p: &Projected| -> Vector3<f64> {
        view.camera
            .unproject(&nalgebra::Vector2::new(p.xy.x, p.xy.y))
            .scale(p.depth)
    };
    let (pa, pb, pc) = (cam(a), cam(b), cam(c));
    let mut nrm = (pb - pa).cross(&(pc - pa));
    let len = nrm.norm();
    // Also rejects NaN.
    if len.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return;
    }
    nrm /= len;
    if nrm.dot(&pa) > 0.0 {
        nrm = -nrm;
    }
    let nf = [nrm.x as f32, nrm.y as f32, nrm.z as f32];
    let inv = [1.0 / a.depth, 1.0 / b.depth, 1.0 / c.depth];
    let min_x = a.xy.x.min(b.xy.x).min(c.xy.x);
    let max_x = a.xy.x.max(b.xy.x).max(c.xy.x);
    let min_y = a.xy.y.min(b.xy.y).min(c.xy.y);
    let max_y = a.xy.y.max(b.xy.y).max(c.xy.y);
    // Pixel x covers centre x + 0.5.
    let x0 = (min_x - 0.5).ceil().max(0.0) as i64;
    let x1 = ((max_x - 0.5).floor() as i64).min(w as i64 - 1);
    let y0 = (min_y - 0.5).ceil().max(0.0) as i64;
    let y1 = ((max_y - 0.5).floor() as i64).min(h as i64 - 1);
    const EPS: f64 = -1e-9;
    for y in y0..=y1 {
        let py = y as f64 + 0.5;
        for x in x0..=x1 {
            let px = x as f64 + 0.5;
            let l1 = ((px - a.xy.x) * (c.xy.y - a.xy.y) - (c.xy.x - a.xy.x) * (py - a.xy.y)) / det;
            let l2 = ((b.xy.x - a.xy.x) * (py - a.xy.y) - (px - a.xy.x) * (b.xy.y - a.xy.y)) / det;
            let l0 = 1.0 - l1 - l2;
            if l0 < EPS || l1 < EPS || l2 < EPS {
                continue;
            }
            let inv_z = l0 * inv[0] + l1 * inv[1] + l2 * inv[2];
            if inv_z > 0.0 {
                let p = (y as u32 * w + x as u32) as usize;
                depth[p] = (1.0 / inv_z) as f32;
                normals[p] = nf;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera, CameraModel, Plane};
    use crate::scene::{SparseCloud, View};

    fn scene_with_plane(plane: &Plane) -> Scene {
        let camera =
            Camera::new(CameraModel::Pinhole, 64, 48, vec![50.0, 50.0, 32.0, 24.0]).unwrap();
        let cam_from_world = look_at(
            &Vector3::new(0.0, 0.0, 0.0),
            &Vector3::new(0.0, 0.0, 5.0),
            &Vector3::new(0.0, -1.0, 0.0),
        );
        let view = View {
            id: 1,
            name: "v.png".into(),
            camera,
            cam_from_world,
            image_path: None,
        };
        // Points on the plane along the rays of a 5×5 grid of image positions spanning
        // (and slightly exceeding) the frame.
        let mut positions = Vec::new();
        for j in 0..5 {
            for i in 0..5 {
                let xy = nalgebra::Vector2::new(-2.0 + 17.0 * i as f64, -2.0 + 13.0 * j as f64);
                let ray = view.camera.unproject(&xy);
                let world_dir = cam_from_world.rotation.inverse() * ray;
                let origin = view.center();
                let t = (plane.offset - plane.normal.dot(&origin)) / plane.normal.dot(&world_dir);
                positions.push(origin + world_dir * t);
            }
        }
        let n = positions.len();
        Scene {
            views: vec![view],
            cloud: SparseCloud {
                positions,
                colors: vec![[0, 0, 0]; n],
                normals: None,
                tracks: vec![vec![0]; n],
                errors: vec![0.0; n],
                confidence: vec![1.0; n],
            },
        }
    }

    #[test]
    fn slanted_plane_is_reproduced_exactly() {
        // Interpolating inverse depth over the triangulation of points on one plane
        // reproduces that plane at every pixel (linear interpolation of depth would not).
        let plane = Plane::new(Vector3::new(0.3, 0.2, 1.0).normalize(), 4.0);
        let scene = scene_with_plane(&plane);
        let d = delaunay_view(&scene, 0);
        assert_eq!(d.points, 25);
        let view = &scene.views[0];
        let mut covered = 0;
        for y in 0..48u32 {
            for x in 0..64u32 {
                let p = (y * 64 + x) as usize;
                assert!(d.depth[p] > 0.0, "pixel ({x},{y}) not covered");
                covered += 1;
                let ray = view.camera.pixel_ray(x, y);
                let world_dir = view.cam_from_world.rotation.inverse() * ray;
                let o = view.center();
                let t = (plane.offset - plane.normal.dot(&o)) / plane.normal.dot(&world_dir);
                // ray has unit z, so t is the depth.
                assert!(
                    ((d.depth[p] as f64) - t).abs() < 1e-4 * t,
                    "{} vs {t}",
                    d.depth[p]
                );
                let n_cam = view.cam_from_world.rotation * plane.normal;
                let nd = Vector3::new(
                    d.normals[p][0] as f64,
                    d.normals[p][1] as f64,
                    d.normals[p][2] as f64,
                );
                assert!(nd.dot(&n_cam).abs() > 0.9999);
            }
        }
        assert_eq!(covered, 64 * 48);
    }

    #[test]
    fn outside_the_hull_has_no_depth() {
        let plane = Plane::new(Vector3::new(0.0, 0.0, 1.0), 5.0);
        let mut scene = scene_with_plane(&plane);
        // Keep only the 4 points of the top-left 2×2 grid cell.
        let keep = [0usize, 1, 5, 6];
        let c = &mut scene.cloud;
        c.positions = keep.iter().map(|&i| c.positions[i]).collect();
        c.tracks = vec![vec![0]; 4];
        c.colors.truncate(4);
        c.errors.truncate(4);
        c.confidence.truncate(4);
        let d = delaunay_view(&scene, 0);
        assert_eq!(d.triangles, 2);
        assert!(d.depth[0] > 0.0);
        assert_eq!(d.depth[(47 * 64 + 63) as usize], 0.0);
        assert!((d.depth[0] - 5.0).abs() < 1e-4);
    }
}
