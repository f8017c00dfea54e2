//! Matching segments across views and triangulating 3D lines along dominant directions.
//!
//! A segment of view i that points at the vanishing point of direction d back-projects to a
//! plane through the camera centre that contains d. In the 2D space orthogonal to d, that
//! plane is a line, and the 3D line (parallel to d) is a point q: two views' segments give
//! q as the intersection of their 2D lines, further views refine it by weighted least
//! squares, with each view's line weighted by its pixel's size at that depth, so q comes
//! with a covariance. A candidate pair (segments of the same direction in the reference
//! view and a neighbour, in front of both, overlapping along d) is kept when its line
//! projects onto a segment of the same direction in further views; the reference segment
//! keeps the candidate seen in the most views. Lines found from several reference views are
//! merged. Ideas after Sinha et al. 2009 and Schindler et al. (3DPVT 2006); our own code.

use nalgebra::{Matrix2, Vector2, Vector3};
use rayon::prelude::*;

use super::{detect_segments, vanishing_direction, LinesConfig, Segment};
use crate::photo::select_neighbours;
use crate::raster::ImageF32;
use crate::scene::Scene;

/// One view's segments and the direction each points at.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewLines {
    /// Segments found ([`detect_segments`]).
    pub segments: Vec<Segment>,
    /// Per segment: index of the dominant direction whose vanishing point it points at.
    pub direction: Vec<Option<usize>>,
}

/// A 3D line segment parallel to a dominant direction.
#[derive(Debug, Clone, PartialEq)]
pub struct Line3 {
    /// Index into the dominant directions.
    pub direction: usize,
    /// The point of the (infinite) line closest to the world origin.
    pub point: Vector3<f64>,
    /// Extent along the direction from `point`: the segment is `point + t·d`, t in
    /// `[extent.0, extent.1]`.
    pub extent: (f64, f64),
    /// Standard deviation of the position across the direction (world units), the larger
    /// axis of the least-squares covariance with the segments located to 0.5 px.
    pub sigma: f64,
    /// Views whose segments support it, ascending.
    pub views: Vec<usize>,
}

impl Line3 {
    /// Length of the segment.
    pub fn length(&self) -> f64 {
        self.extent.1 - self.extent.0
    }

    /// The segment's midpoint, given the direction vector it was built with.
    pub fn midpoint(&self, d: &Vector3<f64>) -> Vector3<f64> {
        self.point + 0.5 * (self.extent.0 + self.extent.1) * d
    }
}

/// Every view's segments and the merged 3D lines.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineSet {
    /// Per view, in scene order.
    pub views: Vec<ViewLines>,
    /// Triangulated lines, ordered by direction, then position (deterministic).
    pub lines: Vec<Line3>,
}

/// Position accuracy assumed for a segment across its length, in pixels (LSD's sub-pixel
/// fit on rendered and photographed edges).
const SEGMENT_SIGMA_PX: f64 = 0.5;

/// A matchable segment: direction, back-projection plane and image line.
struct Obs {
    dir: usize,
    /// Unit normal of the back-projection plane (world frame).
    normal: Vector3<f64>,
    /// Image line `l·(x, y, 1) = 0` with `(l0, l1)` unit.
    line: [f64; 3],
    a: Vector2<f64>,
    b: Vector2<f64>,
}

/// An orthonormal basis of the plane orthogonal to unit `d`.
fn basis(d: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if d.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = d.cross(&helper).normalize();
    (e1, d.cross(&e1))
}

/// The back-projection plane of `o` in view `v` as a 2D line `n·q = c` in the basis
/// orthogonal to the direction; `None` when the plane does not contain the direction.
fn line2(
    o: &Obs,
    centre: &Vector3<f64>,
    e: &(Vector3<f64>, Vector3<f64>),
) -> Option<(Vector2<f64>, f64)> {
    let n = Vector2::new(o.normal.dot(&e.0), o.normal.dot(&e.1));
    let s = n.norm();
    if s < 0.9 {
        return None;
    }
    let n = n / s;
    Some((n, n.dot(&Vector2::new(centre.dot(&e.0), centre.dot(&e.1)))))
}

/// Parameter t along the line `p + t·d` of the point nearest the ray `c + s·r`, and the ray
/// parameter s (the depth for a camera ray with z = 1); `None` when they are parallel.
fn nearest_on_line(
    p: &Vector3<f64>,
    d: &Vector3<f64>,
    c: &Vector3<f64>,
    r: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let w0 = p - c;
    let (b, rr) = (d.dot(r), r.dot(r));
    let (dd, e) = (d.dot(&w0), r.dot(&w0));
    let denom = rr - b * b;
    if denom < 1e-6 * rr {
        return None;
    }
    Some(((b * e - rr * dd) / denom, (e - b * dd) / denom))
}

/// The extent along the line of a segment's two endpoint rays, if both are in front.
fn extent_of(
    scene: &Scene,
    v: usize,
    o: &Obs,
    p: &Vector3<f64>,
    d: &Vector3<f64>,
) -> Option<(f64, f64, f64)> {
    let view = &scene.views[v];
    let (c, ra) = view.ray(&o.a);
    let (_, rb) = view.ray(&o.b);
    let (ta, sa) = nearest_on_line(p, d, &c, &ra)?;
    let (tb, sb) = nearest_on_line(p, d, &c, &rb)?;
    if sa <= 0.0 || sb <= 0.0 {
        return None;
    }
    Some((ta.min(tb), ta.max(tb), 0.5 * (sa + sb)))
}

/// Distance in pixels of point `x` from the image line `l`.
fn line_dist(l: &[f64; 3], x: &Vector2<f64>) -> f64 {
    (l[0] * x.x + l[1] * x.y + l[2]).abs()
}

/// Whether view `v` shows a segment of direction `k` along the 3D segment `p + t·d`,
/// t in `ext`: both projected endpoints within the tolerance of its image line, and the
/// two overlapping along it. `Some((residual, index into obs))` of the closest if so, `None`
/// if not; the view does not count (outer `None`) when the segment projects behind it or
/// shorter than `min_len` pixels.
fn confirm(
    scene: &Scene,
    v: usize,
    obs: &[Obs],
    seg: &Seg3<'_>,
    cfg: &LinesConfig,
    min_len: f64,
) -> Option<Option<(f64, usize)>> {
    let (p, d, ext, k) = (seg.point, seg.dir, seg.extent, seg.class);
    let view = &scene.views[v];
    let (a, _) = view.project(&(p + ext.0 * d))?;
    let (b, _) = view.project(&(p + ext.1 * d))?;
    let len = (b - a).norm();
    if len < min_len || !(view.camera.contains(&a) || view.camera.contains(&b)) {
        return None;
    }
    let u = (b - a) / len;
    let mut best: Option<(f64, usize)> = None;
    for (oi, o) in obs.iter().enumerate().filter(|(_, o)| o.dir == k) {
        let (da, db) = (line_dist(&o.line, &a), line_dist(&o.line, &b));
        if da > cfg.match_tolerance_px || db > cfg.match_tolerance_px {
            continue;
        }
        let (s0, s1) = ((o.a - a).dot(&u), (o.b - a).dot(&u));
        let overlap = s0.max(s1).min(len) - s0.min(s1).max(0.0);
        let shorter = len.min((o.b - o.a).norm());
        if overlap < 0.3 * shorter {
            continue;
        }
        let res = da + db;
        if best.is_none_or(|(r, _)| res < r) {
            best = Some((res, oi));
        }
    }
    Some(best)
}

/// A 3D segment `point + t·dir`, t in `extent`, of direction index `class`.
struct Seg3<'a> {
    point: &'a Vector3<f64>,
    dir: &'a Vector3<f64>,
    extent: (f64, f64),
    class: usize,
}

/// A line seen from one reference segment, before merging.
struct Candidate {
    dir: usize,
    q: Vector2<f64>,
    cov: Matrix2<f64>,
    extent: (f64, f64),
    views: Vec<usize>,
}

/// Per segment: whether `crowd_count` or more segments of its direction run beside it
/// (overlapping half its length, within `crowd_distance_px` across): book spines, brick
/// courses, railings. Such repeated edges match each other across views as readily as
/// themselves.
fn crowded(vl: &ViewLines, cfg: &LinesConfig) -> Vec<bool> {
    let segs = &vl.segments;
    (0..segs.len())
        .map(|i| {
            let Some(k) = vl.direction[i] else {
                return false;
            };
            let s = &segs[i];
            let len = s.length();
            if len <= 0.0 {
                return false;
            }
            let u = [(s.b[0] - s.a[0]) / len, (s.b[1] - s.a[1]) / len];
            let beside = (0..segs.len())
                .filter(|&j| j != i && vl.direction[j] == Some(k))
                .filter(|&j| {
                    let t = &segs[j];
                    let along = |p: [f64; 2]| (p[0] - s.a[0]) * u[0] + (p[1] - s.a[1]) * u[1];
                    let across =
                        |p: [f64; 2]| (-(p[0] - s.a[0]) * u[1] + (p[1] - s.a[1]) * u[0]).abs();
                    let (t0, t1) = (along(t.a).min(along(t.b)), along(t.a).max(along(t.b)));
                    let overlap = t1.min(len) - t0.max(0.0);
                    overlap >= 0.5 * len.min(t.length())
                        && across(t.midpoint()) <= cfg.crowd_distance_px
                })
                .count();
            beside >= cfg.crowd_count
        })
        .collect()
}

/// The depths at which view `v` may see a line: from half the 5th percentile to twice the
/// 95th percentile of its sparse points' depths (all depths when it has none). A wrong
/// pair of segments can meet anywhere, often just in front of the cameras, and still
/// project onto some segment of a third view.
fn depth_range(scene: &Scene, v: usize) -> (f64, f64) {
    let me = v as u32;
    let mut z: Vec<f64> = scene
        .cloud
        .positions
        .iter()
        .zip(&scene.cloud.tracks)
        .filter(|(_, t)| t.contains(&me))
        .filter_map(|(p, _)| scene.views[v].project(p).map(|(_, z)| z))
        .collect();
    if z.is_empty() {
        return (0.0, f64::INFINITY);
    }
    z.sort_by(f64::total_cmp);
    let q = |f: f64| z[((z.len() - 1) as f64 * f).round() as usize];
    (0.5 * q(0.05), 2.0 * q(0.95))
}

/// Weighted least-squares point of 2D lines `(n, c, weight)`, with its covariance.
fn solve_lines(lines: &[(Vector2<f64>, f64, f64)]) -> Option<(Vector2<f64>, Matrix2<f64>)> {
    let mut a = Matrix2::zeros();
    let mut rhs = Vector2::zeros();
    for (n, c, w) in lines {
        a += *w * n * n.transpose();
        rhs += *w * *c * n;
    }
    let inv = a.try_inverse()?;
    Some((inv * rhs, inv))
}

/// Detects segments in every view, assigns them to `directions` (unit, world frame), and
/// triangulates the lines seen in at least `cfg.min_views` views. `scene` must be
/// undistorted and `images[i]` view i's image. Deterministic for any thread count.
pub fn triangulate_lines(
    scene: &Scene,
    images: &[ImageF32],
    directions: &[Vector3<f64>],
    scale: f64,
    cfg: &LinesConfig,
) -> LineSet {
    let params = cfg.detect_params();
    let views: Vec<ViewLines> = scene
        .views
        .par_iter()
        .zip(images.par_iter())
        .map(|(view, img)| {
            let segments = detect_segments(&img.to_gray(), &params);
            let direction = segments
                .iter()
                .map(|s| vanishing_direction(view, s, directions, cfg))
                .collect();
            ViewLines {
                segments,
                direction,
            }
        })
        .collect();
    let lines = lines_from_segments(scene, &views, directions, scale, cfg);
    LineSet { views, lines }
}

/// The matching and triangulation of [`triangulate_lines`] on given segments (`views[i]`
/// for view i, directions already assigned).
pub fn lines_from_segments(
    scene: &Scene,
    views: &[ViewLines],
    directions: &[Vector3<f64>],
    scale: f64,
    cfg: &LinesConfig,
) -> Vec<Line3> {
    let min_len_of = |v: usize| {
        let c = &scene.views[v].camera;
        cfg.min_length_fraction * (c.width as f64).hypot(c.height as f64)
    };
    let obs: Vec<Vec<Obs>> = views
        .iter()
        .enumerate()
        .map(|(v, vl)| {
            let view = &scene.views[v];
            let rot_inv = view.cam_from_world.rotation.inverse();
            let min_len = min_len_of(v);
            let crowded = crowded(vl, cfg);
            vl.segments
                .iter()
                .zip(&vl.direction)
                .zip(crowded)
                .filter_map(|((s, k), crowded)| {
                    let k = (*k)?;
                    if s.length() < min_len || crowded {
                        return None;
                    }
                    let (a, b) = (Vector2::new(s.a[0], s.a[1]), Vector2::new(s.b[0], s.b[1]));
                    let ra = view.camera.unproject(&a);
                    let rb = view.camera.unproject(&b);
                    let normal = (rot_inv * ra.cross(&rb)).normalize();
                    let l = Vector3::new(a.x, a.y, 1.0).cross(&Vector3::new(b.x, b.y, 1.0));
                    let ln = l.x.hypot(l.y);
                    Some(Obs {
                        dir: k,
                        normal,
                        line: [l.x / ln, l.y / ln, l.z / ln],
                        a,
                        b,
                    })
                })
                .collect()
        })
        .collect();
    let dirs: Vec<Vector3<f64>> = directions.iter().map(|d| d.normalize()).collect();
    let bases: Vec<_> = dirs.iter().map(basis).collect();
    let centres: Vec<Vector3<f64>> = scene.views.iter().map(|v| v.center()).collect();
    let ranges: Vec<(f64, f64)> = (0..scene.views.len())
        .map(|v| depth_range(scene, v))
        .collect();
    let sin_min = cfg.min_angle_deg.to_radians().sin();
    let candidates: Vec<Candidate> = (0..scene.views.len())
        .into_par_iter()
        .flat_map_iter(|i| {
            let neighbours = select_neighbours(scene, i, cfg.neighbours).unwrap_or_default();
            let min_len = min_len_of(i);
            let mut out = Vec::new();
            for oi in &obs[i] {
                let (d, e) = (&dirs[oi.dir], &bases[oi.dir]);
                let Some((ni, ci)) = line2(oi, &centres[i], e) else {
                    continue;
                };
                let mut found: Vec<(usize, f64, Candidate)> = Vec::new();
                for &j in &neighbours {
                    for oj in obs[j].iter().filter(|o| o.dir == oi.dir) {
                        let Some((nj, cj)) = line2(oj, &centres[j], e) else {
                            continue;
                        };
                        let det = ni.x * nj.y - ni.y * nj.x;
                        if det.abs() < sin_min {
                            continue;
                        }
                        let q = Vector2::new(
                            (ci * nj.y - cj * ni.y) / det,
                            (ni.x * cj - nj.x * ci) / det,
                        );
                        let p = q.x * e.0 + q.y * e.1;
                        let Some((i0, i1, zi)) = extent_of(scene, i, oi, &p, d) else {
                            continue;
                        };
                        let Some((j0, j1, zj)) = extent_of(scene, j, oj, &p, d) else {
                            continue;
                        };
                        let inside = |v: usize, z: f64| z >= ranges[v].0 && z <= ranges[v].1;
                        if !inside(i, zi) || !inside(j, zj) {
                            continue;
                        }
                        let overlap = i1.min(j1) - i0.max(j0);
                        if overlap <= 0.3 * (i1 - i0).min(j1 - j0) {
                            continue;
                        }
                        let ext = (i0.max(j0), i1.min(j1));
                        let seg = Seg3 {
                            point: &p,
                            dir: d,
                            extent: ext,
                            class: oi.dir,
                        };
                        let mut seen = vec![i, j];
                        let mut residual = 0.0;
                        let weight = |v: usize, z: f64| {
                            (scene.views[v].camera.fx() / (SEGMENT_SIGMA_PX * z)).powi(2)
                        };
                        let mut rows = vec![(ni, ci, weight(i, zi)), (nj, cj, weight(j, zj))];
                        // Views where the line projects long enough to be tested.
                        let mut tested = 2usize;
                        for &m in neighbours.iter().filter(|&&m| m != j) {
                            let Some(found) = confirm(scene, m, &obs[m], &seg, cfg, min_len) else {
                                continue;
                            };
                            tested += 1;
                            let Some((r, om)) = found else {
                                continue;
                            };
                            let om = &obs[m][om];
                            let Some((nm, cm)) = line2(om, &centres[m], e) else {
                                continue;
                            };
                            let z = scene.views[m]
                                .project(&(p + 0.5 * (ext.0 + ext.1) * d))
                                .map_or(zi, |(_, z)| z);
                            seen.push(m);
                            residual += r;
                            rows.push((nm, cm, weight(m, z)));
                        }
                        if seen.len() < cfg.min_views
                            || (seen.len() as f64) < cfg.min_confirmed_fraction * tested as f64
                        {
                            continue;
                        }
                        let Some((q, cov)) = solve_lines(&rows) else {
                            continue;
                        };
                        let candidate = Candidate {
                            dir: oi.dir,
                            q,
                            cov,
                            extent: (i0, i1),
                            views: seen,
                        };
                        found.push((candidate.views.len(), residual, candidate));
                    }
                }
                if let Some(c) = unambiguous(found, scale) {
                    out.push(c);
                }
            }
            out
        })
        .collect();
    merge(candidates, &bases, scale, cfg)
}

/// The candidate seen in the most views (then the smallest residual), unless another line
/// (more than 3σ or 2 R away) is seen in as many: repeated parallel edges (shelves,
/// window rows) match each other consistently in a few views, and then no match is sure.
fn unambiguous(mut found: Vec<(usize, f64, Candidate)>, scale: f64) -> Option<Candidate> {
    found.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
    let mut it = found.into_iter();
    let (n, _, best) = it.next()?;
    let tol = (3.0 * best.cov.symmetric_eigenvalues().max().max(0.0).sqrt()).max(2.0 * scale);
    let rival = it
        .take_while(|(m, _, _)| *m == n)
        .any(|(_, _, c)| (c.q - best.q).norm() > tol);
    (!rival).then_some(best)
}

/// Merges candidates of the same direction whose positions agree (within 3σ or 2 R) and
/// whose extents overlap or touch; drops lines less certain than `max_sigma_r` R.
fn merge(
    mut cands: Vec<Candidate>,
    bases: &[(Vector3<f64>, Vector3<f64>)],
    scale: f64,
    cfg: &LinesConfig,
) -> Vec<Line3> {
    let sigma = |c: &Candidate| c.cov.symmetric_eigenvalues().max().max(0.0).sqrt();
    cands.sort_by(|a, b| {
        b.views
            .len()
            .cmp(&a.views.len())
            .then(sigma(a).total_cmp(&sigma(b)))
            .then(a.dir.cmp(&b.dir))
            .then(a.q.x.total_cmp(&b.q.x))
            .then(a.q.y.total_cmp(&b.q.y))
    });
    let mut kept: Vec<Candidate> = Vec::new();
    'next: for c in cands {
        let sc = sigma(&c);
        if sc > cfg.max_sigma_r * scale {
            continue;
        }
        for k in kept.iter_mut().filter(|k| k.dir == c.dir) {
            let tol = (3.0 * (sc.powi(2) + sigma(k).powi(2)).sqrt()).max(2.0 * scale);
            let gap = c.extent.0.max(k.extent.0) - c.extent.1.min(k.extent.1);
            if (c.q - k.q).norm() <= tol && gap <= 2.0 * scale {
                k.extent = (k.extent.0.min(c.extent.0), k.extent.1.max(c.extent.1));
                for v in c.views {
                    if !k.views.contains(&v) {
                        k.views.push(v);
                    }
                }
                continue 'next;
            }
        }
        kept.push(c);
    }
    let mut lines: Vec<Line3> = kept
        .into_iter()
        .map(|mut c| {
            c.views.sort_unstable();
            let (e1, e2) = bases[c.dir];
            Line3 {
                direction: c.dir,
                point: c.q.x * e1 + c.q.y * e2,
                extent: c.extent,
                sigma: sigma(&c),
                views: c.views,
            }
        })
        .collect();
    lines.sort_by(|a, b| {
        a.direction
            .cmp(&b.direction)
            .then(a.point.x.total_cmp(&b.point.x))
            .then(a.point.y.total_cmp(&b.point.y))
            .then(a.point.z.total_cmp(&b.point.z))
            .then(a.extent.0.total_cmp(&b.extent.0))
    });
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};
    use crate::lines::vanishing_direction;
    use crate::scene::{SparseCloud, View};

    /// A 3D edge: direction index and endpoints.
    type Edge = (usize, Vector3<f64>, Vector3<f64>);

    /// Six cameras around a 4 × 3 × 2.5 box, and its twelve edges.
    fn setup() -> (Scene, Vec<Edge>) {
        let centre = Vector3::new(2.0, 1.5, 1.25);
        let views: Vec<View> = (0..6)
            .map(|i| {
                let a = -2.2 + 0.25 * i as f64;
                let eye =
                    centre + Vector3::new(9.0 * a.cos(), 9.0 * a.sin(), -0.5 + 1.2 * i as f64);
                View {
                    id: i as u32 + 1,
                    name: format!("v{i}"),
                    camera: Camera::pinhole(320, 240, 260.0, 260.0, 160.0, 120.0),
                    cam_from_world: look_at(&eye, &centre, &Vector3::z()),
                    image_path: None,
                }
            })
            .collect();
        let size = Vector3::new(4.0, 3.0, 2.5);
        let mut edges = Vec::new();
        for k in 0..3 {
            let (u, w) = ((k + 1) % 3, (k + 2) % 3);
            for (a, b) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                let mut p = Vector3::zeros();
                p[u] = a * size[u];
                p[w] = b * size[w];
                let mut q = p;
                q[k] = size[k];
                edges.push((k, p, q));
            }
        }
        let scene = Scene {
            views,
            cloud: SparseCloud::default(),
        };
        (scene, edges)
    }

    /// Every edge projected into every view as a segment (clipped to lie in front).
    fn project(scene: &Scene, edges: &[Edge], noise: f64) -> Vec<ViewLines> {
        let dirs = [Vector3::x(), Vector3::y(), Vector3::z()];
        scene
            .views
            .iter()
            .enumerate()
            .map(|(v, view)| {
                let segments: Vec<Segment> = edges
                    .iter()
                    .enumerate()
                    .filter_map(|(e, (_, p, q))| {
                        let (a, _) = view.project(p)?;
                        let (b, _) = view.project(q)?;
                        // Deterministic sub-pixel jitter across the segment.
                        let n = Vector2::new(a.y - b.y, b.x - a.x).normalize();
                        let j = noise * (((v * 7 + e * 3) % 5) as f64 / 2.0 - 1.0);
                        Some(Segment {
                            a: [a.x + j * n.x, a.y + j * n.y],
                            b: [b.x + j * n.x, b.y + j * n.y],
                            width: 1.0,
                            significance: 10.0,
                            gradient: 0.3,
                        })
                    })
                    .collect();
                let direction = segments
                    .iter()
                    .map(|s| vanishing_direction(view, s, &dirs, &LinesConfig::default()))
                    .collect();
                ViewLines {
                    segments,
                    direction,
                }
            })
            .collect()
    }

    #[test]
    fn box_edges_are_triangulated_where_they_are() {
        let (scene, edges) = setup();
        let dirs = [Vector3::x(), Vector3::y(), Vector3::z()];
        for noise in [0.0, 0.3] {
            let views = project(&scene, &edges, noise);
            let lines = lines_from_segments(&scene, &views, &dirs, 0.03, &LinesConfig::default());
            assert!(
                lines.len() >= 10,
                "noise {noise}: {} lines: {lines:#?}",
                lines.len()
            );
            for l in &lines {
                let d = dirs[l.direction];
                // The edge it is: same direction, nearest.
                let dist = edges
                    .iter()
                    .filter(|(k, _, _)| *k == l.direction)
                    .map(|(_, p, _)| {
                        let w = l.point - p;
                        (w - w.dot(&d) * d).norm()
                    })
                    .fold(f64::MAX, f64::min);
                let tol = if noise == 0.0 { 1e-6 } else { 0.03 };
                assert!(
                    dist < tol,
                    "noise {noise}: line {l:?} is {dist} from every edge"
                );
                assert!(l.views.len() >= 3);
                assert!(l.length() > 1.0, "{l:?}");
            }
            // No edge is found twice.
            for (i, a) in lines.iter().enumerate() {
                for b in &lines[i + 1..] {
                    assert!(
                        a.direction != b.direction || (a.point - b.point).norm() > 0.1,
                        "{a:?} {b:?}"
                    );
                }
            }
        }
    }
}
