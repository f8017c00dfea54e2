//! The scene as ray-traceable primitives: rectangles and discs (planar, each snapped onto a
//! shared global plane), spheres and cylinder sides (non-planar), in a small BVH.

use nalgebra::{Rotation3, Vector3};

use super::spec::{polygon_normal, ObjectSpec, SceneSpec, BOX_FACES};
use super::texture::{mix64, Material};
use crate::geometry::Plane;

type V3 = Vector3<f64>;

/// Shape of one primitive.
#[derive(Debug, Clone)]
pub(crate) enum Shape {
    /// Rectangle centred at `center` with in-plane unit axes `u`, `v` (u × v = outward
    /// normal) and half sizes `hu`, `hv`.
    Rect {
        center: V3,
        u: V3,
        v: V3,
        hu: f64,
        hv: f64,
    },
    /// Disc with in-plane axes for texture coordinates.
    Disc {
        center: V3,
        u: V3,
        v: V3,
        radius: f64,
    },
    /// Sphere.
    Sphere { center: V3, radius: f64 },
    /// Triangle `a b c` (counter-clockwise seen from the outward side) of a polygon whose
    /// texture coordinates are measured from `origin` along the in-plane unit axes `u`, `v`.
    Triangle {
        a: V3,
        b: V3,
        c: V3,
        origin: V3,
        u: V3,
        v: V3,
    },
    /// Open cylinder side from `base` along unit `axis` for `height`; `e1`, `e2` span the
    /// cross-section.
    CylinderSide {
        base: V3,
        axis: V3,
        e1: V3,
        e2: V3,
        height: f64,
        radius: f64,
    },
}

/// One traceable primitive.
#[derive(Debug, Clone)]
pub(crate) struct Primitive {
    pub shape: Shape,
    /// Index into `World::planes` for planar primitives.
    pub plane: Option<usize>,
    /// +1 when the outward normal equals the global plane's normal, −1 when opposite.
    pub side: f64,
    /// Visible from behind too.
    pub two_sided: bool,
    pub material: usize,
    /// Object index: wins ties against coplanar primitives of earlier objects (decals).
    pub priority: u32,
    pub lo: V3,
    pub hi: V3,
}

/// A merged ground-truth plane and the faces it came from.
#[derive(Debug, Clone)]
pub(crate) struct WorldPlane {
    pub plane: Plane,
    pub labels: Vec<String>,
}

/// The result of tracing a ray.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Hit {
    /// Ray parameter (equals camera depth for rays with unit depth step).
    pub t: f64,
    pub prim: u32,
}

/// Surface details at a hit point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Surface {
    pub point: V3,
    /// Unit normal facing the ray origin.
    pub normal: V3,
    /// Texture coordinates in metres.
    pub s: f64,
    pub t: f64,
}

#[derive(Debug, Clone)]
struct Node {
    lo: V3,
    hi: V3,
    /// Leaf: first primitive index; inner: index of the left child (right = left + 1).
    start: u32,
    /// Leaf: number of primitives (> 0); inner: 0.
    count: u32,
}

/// Everything the renderer and the sparse sampler need about the geometry.
#[derive(Debug, Clone)]
pub(crate) struct World {
    pub prims: Vec<Primitive>,
    pub planes: Vec<WorldPlane>,
    pub materials: Vec<Material>,
    nodes: Vec<Node>,
}

/// Smallest ray parameter accepted as a hit (metres along a unit-depth ray).
pub(crate) const T_MIN: f64 = 1e-6;
const LEAF_SIZE: usize = 4;

fn any_perpendicular(n: &V3) -> V3 {
    let helper = if n.z.abs() < 0.9 { V3::z() } else { V3::x() };
    helper.cross(n).normalize()
}

struct PlaneMerger {
    planes: Vec<WorldPlane>,
    cos_tol: f64,
    dist_tol: f64,
}

impl PlaneMerger {
    /// Index of the global plane for a face through `point` with outward `normal`, and the
    /// sign relating them; creates a new plane when none is within tolerance.
    fn assign(&mut self, point: &V3, normal: &V3, label: String) -> (usize, f64) {
        for (i, p) in self.planes.iter_mut().enumerate() {
            let c = p.plane.normal.dot(normal);
            if c.abs() >= self.cos_tol && p.plane.signed_distance(point).abs() <= self.dist_tol {
                if p.labels.len() < 8 && !p.labels.contains(&label) {
                    p.labels.push(label);
                }
                return (i, c.signum());
            }
        }
        self.planes.push(WorldPlane {
            plane: Plane::through(point, normal),
            labels: vec![label],
        });
        (self.planes.len() - 1, 1.0)
    }
}

impl World {
    /// Builds primitives, merges coplanar faces and builds the BVH.
    pub fn build(spec: &SceneSpec, seed: u64) -> World {
        let material_names: Vec<String> = spec.materials.keys().cloned().collect();
        let materials: Vec<Material> = spec
            .materials
            .iter()
            .enumerate()
            .map(|(i, (_, m))| Material::new(m, mix64(seed ^ mix64(i as u64 + 1))))
            .collect();
        let mat_index = |name: &str| {
            material_names
                .iter()
                .position(|n| n == name)
                .expect("materials validated")
        };
        let mut merger = PlaneMerger {
            planes: Vec::new(),
            cos_tol: spec.render.plane_merge_angle_deg.to_radians().cos(),
            dist_tol: spec.render.plane_merge_distance,
        };
        let mut prims = Vec::new();

        // Adds a planar rectangle, snapping it onto its merged plane.
        let add_rect = |prims: &mut Vec<Primitive>,
                        merger: &mut PlaneMerger,
                        center: V3,
                        u: V3,
                        v: V3,
                        hu: f64,
                        hv: f64,
                        two_sided: bool,
                        material: usize,
                        priority: u32,
                        label: String| {
            let n = u.cross(&v).normalize();
            let (pi, side) = merger.assign(&center, &n, label);
            let gp = merger.planes[pi].plane;
            let n2 = gp.normal * side;
            let c2 = center - gp.normal * gp.signed_distance(&center);
            let u2 = (u - n2 * n2.dot(&u)).normalize();
            let v2 = n2.cross(&u2);
            prims.push(Primitive {
                shape: Shape::Rect {
                    center: c2,
                    u: u2,
                    v: v2,
                    hu,
                    hv,
                },
                plane: Some(pi),
                side,
                two_sided,
                material,
                priority,
                lo: V3::zeros(),
                hi: V3::zeros(),
            });
        };

        for (oi, obj) in spec.objects.iter().enumerate() {
            let prio = oi as u32;
            let base_label = obj
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("objects[{oi}]"));
            match obj {
                ObjectSpec::Box {
                    material,
                    face_materials,
                    min,
                    max,
                    center,
                    size,
                    rotation_deg,
                    inside,
                    ..
                } => {
                    let (c, sz) = match (min, max, center, size) {
                        (Some(lo), Some(hi), _, _) => (
                            (V3::from(*lo) + V3::from(*hi)) * 0.5,
                            V3::from(*hi) - V3::from(*lo),
                        ),
                        (_, _, Some(c), Some(s)) => (V3::from(*c), V3::from(*s)),
                        _ => unreachable!("validated"),
                    };
                    let r = Rotation3::from_euler_angles(
                        rotation_deg[0].to_radians(),
                        rotation_deg[1].to_radians(),
                        rotation_deg[2].to_radians(),
                    );
                    let axes = [r * V3::x(), r * V3::y(), r * V3::z()];
                    let half = sz * 0.5;
                    for (fi, face) in BOX_FACES.iter().enumerate() {
                        let k = fi / 2;
                        let sign = if fi % 2 == 0 { -1.0 } else { 1.0 };
                        let outward = axes[k] * sign;
                        // In-plane axes: z is "up" on side faces (textures stand upright);
                        // u is flipped so that u × v is the visible normal.
                        let (ua, va) = match k {
                            0 => (1, 2),
                            1 => (0, 2),
                            _ => (0, 1),
                        };
                        let mut u = axes[ua];
                        let v = axes[va];
                        let n_face = if *inside { -outward } else { outward };
                        if u.cross(&v).dot(&n_face) < 0.0 {
                            u = -u;
                        }
                        let m = face_materials
                            .get(*face)
                            .map(|s| mat_index(s))
                            .unwrap_or_else(|| mat_index(material));
                        add_rect(
                            &mut prims,
                            &mut merger,
                            c + outward * half[k],
                            u,
                            v,
                            half[ua],
                            half[va],
                            false,
                            m,
                            prio,
                            format!("{base_label}.{face}"),
                        );
                    }
                }
                ObjectSpec::Quad {
                    material,
                    center,
                    size,
                    normal,
                    up,
                    two_sided,
                    ..
                } => {
                    let n = V3::from(*normal).normalize();
                    let up = up.map(V3::from).unwrap_or_else(|| {
                        if n.z.abs() < 0.9 {
                            V3::z()
                        } else {
                            V3::y()
                        }
                    });
                    let v = (up - n * n.dot(&up)).normalize();
                    let u = v.cross(&n);
                    add_rect(
                        &mut prims,
                        &mut merger,
                        V3::from(*center),
                        u,
                        v,
                        size[0] * 0.5,
                        size[1] * 0.5,
                        *two_sided,
                        mat_index(material),
                        prio,
                        base_label.clone(),
                    );
                }
                ObjectSpec::Sphere {
                    material,
                    center,
                    radius,
                    ..
                } => prims.push(Primitive {
                    shape: Shape::Sphere {
                        center: V3::from(*center),
                        radius: *radius,
                    },
                    plane: None,
                    side: 1.0,
                    two_sided: false,
                    material: mat_index(material),
                    priority: prio,
                    lo: V3::zeros(),
                    hi: V3::zeros(),
                }),
                ObjectSpec::Cylinder {
                    material,
                    base,
                    axis,
                    height,
                    radius,
                    caps,
                    ..
                } => {
                    let a = V3::from(*axis).normalize();
                    let e1 = any_perpendicular(&a);
                    let e2 = a.cross(&e1);
                    let b = V3::from(*base);
                    let m = mat_index(material);
                    prims.push(Primitive {
                        shape: Shape::CylinderSide {
                            base: b,
                            axis: a,
                            e1,
                            e2,
                            height: *height,
                            radius: *radius,
                        },
                        plane: None,
                        side: 1.0,
                        two_sided: false,
                        material: m,
                        priority: prio,
                        lo: V3::zeros(),
                        hi: V3::zeros(),
                    });
                    if *caps {
                        for (c, n, name) in [(b, -a, "bottom"), (b + a * *height, a, "top")] {
                            let (pi, side) = merger.assign(&c, &n, format!("{base_label}.{name}"));
                            let gp = merger.planes[pi].plane;
                            let n2 = gp.normal * side;
                            let u = (e1 - n2 * n2.dot(&e1)).normalize();
                            prims.push(Primitive {
                                shape: Shape::Disc {
                                    center: c - gp.normal * gp.signed_distance(&c),
                                    u,
                                    v: n2.cross(&u),
                                    radius: *radius,
                                },
                                plane: Some(pi),
                                side,
                                two_sided: false,
                                material: m,
                                priority: prio,
                                lo: V3::zeros(),
                                hi: V3::zeros(),
                            });
                        }
                    }
                }
                ObjectSpec::Polygon {
                    material,
                    vertices,
                    two_sided,
                    ..
                } => {
                    let n = polygon_normal(vertices).expect("polygons validated");
                    let pts: Vec<V3> = vertices.iter().map(|v| V3::from(*v)).collect();
                    let centroid = pts.iter().sum::<V3>() / pts.len() as f64;
                    let (pi, side) = merger.assign(&centroid, &n, base_label.clone());
                    let gp = merger.planes[pi].plane;
                    let n2 = gp.normal * side;
                    let snapped: Vec<V3> = pts
                        .iter()
                        .map(|p| p - gp.normal * gp.signed_distance(p))
                        .collect();
                    // Texture axes as a quad's: v up the plane (world z, or y when the
                    // polygon is horizontal), u = v × n; s and t from the lowest corner.
                    let up = if n2.z.abs() < 0.9 { V3::z() } else { V3::y() };
                    let v = (up - n2 * n2.dot(&up)).normalize();
                    let u = v.cross(&n2);
                    let s0 = snapped
                        .iter()
                        .map(|p| p.dot(&u))
                        .fold(f64::INFINITY, f64::min);
                    let t0 = snapped
                        .iter()
                        .map(|p| p.dot(&v))
                        .fold(f64::INFINITY, f64::min);
                    let origin = u * s0 + v * t0;
                    for k in 1..snapped.len() - 1 {
                        prims.push(Primitive {
                            shape: Shape::Triangle {
                                a: snapped[0],
                                b: snapped[k],
                                c: snapped[k + 1],
                                origin,
                                u,
                                v,
                            },
                            plane: Some(pi),
                            side,
                            two_sided: *two_sided,
                            material: mat_index(material),
                            priority: prio,
                            lo: V3::zeros(),
                            hi: V3::zeros(),
                        });
                    }
                }
            }
        }
        for p in &mut prims {
            let (lo, hi) = bounds(&p.shape);
            p.lo = lo;
            p.hi = hi;
        }
        let mut world = World {
            prims,
            planes: merger.planes,
            materials,
            nodes: Vec::new(),
        };
        world.build_bvh();
        world
    }

    fn build_bvh(&mut self) {
        let n = self.prims.len();
        let mut order: Vec<usize> = (0..n).collect();
        let mut nodes = vec![Node {
            lo: V3::zeros(),
            hi: V3::zeros(),
            start: 0,
            count: 0,
        }];
        // Iterative build: (node index, range) work list.
        let mut work = vec![(0usize, 0usize, n)];
        while let Some((ni, a, b)) = work.pop() {
            let mut lo = V3::repeat(f64::INFINITY);
            let mut hi = V3::repeat(f64::NEG_INFINITY);
            for &i in &order[a..b] {
                lo = lo.inf(&self.prims[i].lo);
                hi = hi.sup(&self.prims[i].hi);
            }
            nodes[ni].lo = lo;
            nodes[ni].hi = hi;
            if b - a <= LEAF_SIZE {
                nodes[ni].start = a as u32;
                nodes[ni].count = (b - a) as u32;
                continue;
            }
            let ext = hi - lo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let prims = &self.prims;
            order[a..b].sort_by(|&i, &j| {
                let ci = prims[i].lo[axis] + prims[i].hi[axis];
                let cj = prims[j].lo[axis] + prims[j].hi[axis];
                ci.total_cmp(&cj).then(i.cmp(&j))
            });
            let mid = (a + b) / 2;
            let left = nodes.len();
            nodes.push(Node {
                lo,
                hi,
                start: 0,
                count: 0,
            });
            nodes.push(Node {
                lo,
                hi,
                start: 0,
                count: 0,
            });
            nodes[ni].start = left as u32;
            nodes[ni].count = 0;
            work.push((left, a, mid));
            work.push((left + 1, mid, b));
        }
        // Reorder primitives to leaf order.
        let reordered: Vec<Primitive> = order.iter().map(|&i| self.prims[i].clone()).collect();
        self.prims = reordered;
        self.nodes = nodes;
    }

    /// The nearest front-facing surface along `origin + t·dir`, `t > T_MIN`. Exactly equal
    /// `t` (coplanar primitives snapped onto one plane) goes to the later object.
    pub fn trace(&self, origin: &V3, dir: &V3) -> Option<Hit> {
        if self.nodes.is_empty() || self.prims.is_empty() {
            return None;
        }
        let inv = V3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        let mut best: Option<Hit> = None;
        let mut best_t = f64::INFINITY;
        let mut best_prio = 0u32;
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if !slab(&node.lo, &node.hi, origin, &inv, best_t) {
                continue;
            }
            if node.count == 0 {
                stack[sp] = node.start;
                stack[sp + 1] = node.start + 1;
                sp += 2;
                continue;
            }
            let start = node.start as usize;
            for (k, p) in self.prims[start..start + node.count as usize]
                .iter()
                .enumerate()
            {
                if let Some(t) = self.intersect(p, origin, dir) {
                    if t < best_t || (t == best_t && p.priority > best_prio) {
                        best_t = t;
                        best_prio = p.priority;
                        best = Some(Hit {
                            t,
                            prim: (start + k) as u32,
                        });
                    }
                }
            }
        }
        best
    }

    /// Ray parameter where `p` is hit from its visible side, if it is.
    #[inline]
    fn intersect(&self, p: &Primitive, o: &V3, d: &V3) -> Option<f64> {
        match &p.shape {
            Shape::Rect {
                center,
                u,
                v,
                hu,
                hv,
            } => {
                let t = self.plane_t(p, o, d)?;
                let q = o + d * t - center;
                let eps = 1e-9;
                ((q.dot(u)).abs() <= hu + eps && (q.dot(v)).abs() <= hv + eps).then_some(t)
            }
            Shape::Disc { center, radius, .. } => {
                let t = self.plane_t(p, o, d)?;
                let q = o + d * t - center;
                (q.norm_squared() <= radius * radius).then_some(t)
            }
            Shape::Triangle { a, b, c, .. } => {
                let t = self.plane_t(p, o, d)?;
                let x = o + d * t;
                // Inside when x is on the inner side of all three edges (the fan's shared
                // edges get a little slack, so no ray slips between two triangles).
                let n = (b - a).cross(&(c - a));
                let eps = -1e-9 * n.norm();
                ((b - a).cross(&(x - a)).dot(&n) >= eps
                    && (c - b).cross(&(x - b)).dot(&n) >= eps
                    && (a - c).cross(&(x - c)).dot(&n) >= eps)
                    .then_some(t)
            }
            Shape::Sphere { center, radius } => {
                let oc = o - center;
                let a = d.norm_squared();
                let b = oc.dot(d);
                let c = oc.norm_squared() - radius * radius;
                let disc = b * b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                let t0 = (-b - sq) / a;
                let t1 = (-b + sq) / a;
                if t0 > T_MIN {
                    Some(t0)
                } else if t1 > T_MIN {
                    Some(t1)
                } else {
                    None
                }
            }
            Shape::CylinderSide {
                base,
                axis,
                height,
                radius,
                ..
            } => {
                let oc = o - base;
                let dp = d - axis * axis.dot(d);
                let op = oc - axis * axis.dot(&oc);
                let a = dp.norm_squared();
                if a < 1e-18 {
                    return None;
                }
                let b = op.dot(&dp);
                let c = op.norm_squared() - radius * radius;
                let disc = b * b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                for t in [(-b - sq) / a, (-b + sq) / a] {
                    if t > T_MIN {
                        let h = axis.dot(&(oc + d * t));
                        if (0.0..=*height).contains(&h) {
                            return Some(t);
                        }
                    }
                }
                None
            }
        }
    }

    /// Intersection with the global plane of a planar primitive, from its visible side.
    #[inline]
    fn plane_t(&self, p: &Primitive, o: &V3, d: &V3) -> Option<f64> {
        let gp = &self.planes[p.plane?].plane;
        let denom = gp.normal.dot(d);
        // Front-facing: the ray travels against the outward normal (side · n).
        if !p.two_sided && denom * p.side >= 0.0 {
            return None;
        }
        if denom.abs() < 1e-14 {
            return None;
        }
        let t = (gp.offset - gp.normal.dot(o)) / denom;
        (t > T_MIN).then_some(t)
    }

    /// Point, camera-facing normal and texture coordinates of a hit.
    pub fn surface(&self, hit: &Hit, origin: &V3, dir: &V3) -> Surface {
        let p = &self.prims[hit.prim as usize];
        let x = origin + dir * hit.t;
        let (normal, s, t) = match &p.shape {
            Shape::Rect {
                center,
                u,
                v,
                hu,
                hv,
            } => {
                let q = x - center;
                let n = self.planes[p.plane.expect("planar")].plane.normal * p.side;
                (n, q.dot(u) + hu, q.dot(v) + hv)
            }
            Shape::Disc { center, u, v, .. } => {
                let q = x - center;
                let n = self.planes[p.plane.expect("planar")].plane.normal * p.side;
                (n, q.dot(u), q.dot(v))
            }
            Shape::Triangle { origin, u, v, .. } => {
                let n = self.planes[p.plane.expect("planar")].plane.normal * p.side;
                (n, x.dot(u) - origin.dot(u), x.dot(v) - origin.dot(v))
            }
            Shape::Sphere { center, radius } => {
                let n = (x - center) / *radius;
                let lon = n.y.atan2(n.x);
                let lat = n.z.clamp(-1.0, 1.0).asin();
                (n.normalize(), lon * radius, lat * radius)
            }
            Shape::CylinderSide {
                base,
                axis,
                e1,
                e2,
                radius,
                ..
            } => {
                let q = x - base;
                let h = axis.dot(&q);
                let radial = q - axis * h;
                let ang = radial.dot(e2).atan2(radial.dot(e1));
                (radial.normalize(), ang * radius, h)
            }
        };
        let normal = if normal.dot(dir) > 0.0 {
            -normal
        } else {
            normal
        };
        Surface {
            point: x,
            normal,
            s,
            t,
        }
    }

    /// Triangle mesh of all primitives (world frame) with the global plane index + 1 of
    /// each triangle (0 for non-planar). Triangles wind counter-clockwise seen from the
    /// visible side.
    pub fn mesh(&self) -> (Vec<V3>, Vec<[u32; 3]>, Vec<u16>) {
        const SEGMENTS: usize = 24;
        let mut verts: Vec<V3> = Vec::new();
        let mut tris = Vec::new();
        let mut ids = Vec::new();
        for p in &self.prims {
            let id = p.plane.map_or(0, |i| (i + 1) as u16);
            let base = verts.len() as u32;
            match &p.shape {
                Shape::Rect {
                    center,
                    u,
                    v,
                    hu,
                    hv,
                } => {
                    for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                        verts.push(center + u * (a * hu) + v * (b * hv));
                    }
                    tris.push([base, base + 1, base + 2]);
                    tris.push([base, base + 2, base + 3]);
                    ids.extend([id, id]);
                }
                Shape::Disc {
                    center,
                    u,
                    v,
                    radius,
                } => {
                    verts.push(*center);
                    for k in 0..SEGMENTS {
                        let a = k as f64 / SEGMENTS as f64 * std::f64::consts::TAU;
                        verts.push(center + (u * a.cos() + v * a.sin()) * *radius);
                    }
                    for k in 0..SEGMENTS as u32 {
                        let next = (k + 1) % SEGMENTS as u32;
                        tris.push([base, base + 1 + k, base + 1 + next]);
                        ids.push(id);
                    }
                }
                Shape::Triangle { a, b, c, .. } => {
                    verts.extend([*a, *b, *c]);
                    tris.push([base, base + 1, base + 2]);
                    ids.push(id);
                }
                Shape::Sphere { center, radius } => {
                    let rings = SEGMENTS / 2;
                    for i in 0..=rings {
                        let lat = -std::f64::consts::FRAC_PI_2
                            + std::f64::consts::PI * i as f64 / rings as f64;
                        for k in 0..SEGMENTS {
                            let lon = k as f64 / SEGMENTS as f64 * std::f64::consts::TAU;
                            verts.push(
                                center
                                    + V3::new(
                                        lat.cos() * lon.cos(),
                                        lat.cos() * lon.sin(),
                                        lat.sin(),
                                    ) * *radius,
                            );
                        }
                    }
                    let s = SEGMENTS as u32;
                    for i in 0..rings as u32 {
                        for k in 0..s {
                            let a = base + i * s + k;
                            let b = base + i * s + (k + 1) % s;
                            tris.push([a, b, b + s]);
                            tris.push([a, b + s, a + s]);
                            ids.extend([0, 0]);
                        }
                    }
                }
                Shape::CylinderSide {
                    base: b0,
                    axis,
                    e1,
                    e2,
                    height,
                    radius,
                } => {
                    for k in 0..SEGMENTS {
                        let a = k as f64 / SEGMENTS as f64 * std::f64::consts::TAU;
                        let r = (e1 * a.cos() + e2 * a.sin()) * *radius;
                        verts.push(b0 + r);
                        verts.push(b0 + r + axis * *height);
                    }
                    let s = SEGMENTS as u32;
                    for k in 0..s {
                        let (a0, a1) = (base + 2 * k, base + 2 * k + 1);
                        let (b0i, b1) = (base + 2 * ((k + 1) % s), base + 2 * ((k + 1) % s) + 1);
                        tris.push([a0, b0i, b1]);
                        tris.push([a0, b1, a1]);
                        ids.extend([0, 0]);
                    }
                }
            }
        }
        (verts, tris, ids)
    }
}

/// Ray–box slab test: does the ray enter `[lo, hi]` before `t_max`?
#[inline]
fn slab(lo: &V3, hi: &V3, o: &V3, inv: &V3, t_max: f64) -> bool {
    let mut t0 = T_MIN;
    let mut t1 = t_max;
    for k in 0..3 {
        let a = (lo[k] - o[k]) * inv[k];
        let b = (hi[k] - o[k]) * inv[k];
        let (near, far) = if a <= b { (a, b) } else { (b, a) };
        // NaN (0 · ∞ for a ray in the slab's plane) must not reject: max/min ignore NaN.
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    t0 <= t1 * (1.0 + 1e-12) + 1e-12
}

fn bounds(shape: &Shape) -> (V3, V3) {
    let pad = V3::repeat(1e-7);
    let (lo, hi) = match shape {
        Shape::Rect {
            center,
            u,
            v,
            hu,
            hv,
        } => {
            let e = u.abs() * *hu + v.abs() * *hv;
            (center - e, center + e)
        }
        Shape::Disc {
            center,
            u,
            v,
            radius,
            ..
        } => {
            let e = (u.abs() + v.abs()) * *radius;
            (center - e, center + e)
        }
        Shape::Triangle { a, b, c, .. } => (a.inf(b).inf(c), a.sup(b).sup(c)),
        Shape::Sphere { center, radius } => {
            (center - V3::repeat(*radius), center + V3::repeat(*radius))
        }
        Shape::CylinderSide {
            base,
            axis,
            height,
            radius,
            ..
        } => {
            let top = base + axis * *height;
            let r = V3::repeat(*radius);
            (base.inf(&top) - r, base.sup(&top) + r)
        }
    };
    (lo - pad, hi + pad)
}
