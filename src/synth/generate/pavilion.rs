//! Pavilions: buildings whose walls meet at arbitrary angles under pitched roofs of
//! arbitrary pitch. Either a polygonal pavilion (the convex hull of five to eight points
//! round an ellipse, so every wall has its own direction) under a pyramid roof whose apex
//! is off centre (every face its own pitch) or a flat roof; or a gabled main wing (8–14 ×
//! 5–8 m, turned anywhere, pitch 15–55°) with a second gabled wing joined at 30°, 45°, 60°
//! or a random 15–75° (its own pitch), and sometimes a lean-to with a 8–25° mono-pitch roof.
//! Walls are plain render on 30–70 % of their area, else boards, brick or stone; roofs are
//! tiles, slate or standing-seam metal; windows and doors on the walls; a grass ground with a
//! gravel path, a deck and a garden wall at their own angles. Views: an orbit at eye height
//! (some from 2.5–4 m) and a drone orbit 8–15 m up looking down at the roofs.

use super::builder::{material, plain_walls, Builder, Frame, ViewRule, UP, V3};
use crate::synth::spec::TextureKind;

/// A wall to build: its bottom edge `p → q` (outside on the right, seen from above) and
/// its height at `p` and `q` (a lean-to's side walls are trapezoids).
struct WallPlan {
    p: V3,
    q: V3,
    h_p: f64,
    h_q: f64,
}

impl WallPlan {
    fn area(&self) -> f64 {
        (self.q - self.p).norm() * 0.5 * (self.h_p + self.h_q)
    }

    fn frame(&self) -> Frame {
        let along = self.q - self.p;
        Frame::new(self.p, along, V3::new(along.y, -along.x, 0.0))
    }
}

/// Convex hull of points in the plane (z ignored), counter-clockwise (Andrew's monotone
/// chain).
fn hull(mut pts: Vec<V3>) -> Vec<V3> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let cross = |o: &V3, a: &V3, b: &V3| (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    let mut lower: Vec<V3> = Vec::new();
    for p in &pts {
        while lower.len() >= 2 && cross(&lower[lower.len() - 2], &lower[lower.len() - 1], p) <= 1e-9
        {
            lower.pop();
        }
        lower.push(*p);
    }
    let mut upper: Vec<V3> = Vec::new();
    for p in pts.iter().rev() {
        while upper.len() >= 2 && cross(&upper[upper.len() - 2], &upper[upper.len() - 1], p) <= 1e-9
        {
            upper.pop();
        }
        upper.push(*p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Rounds a point to 0.1 mm, so that walls and roof faces built from it share it exactly.
fn snap(v: V3) -> V3 {
    V3::from(super::builder::a3(v))
}

/// A rectangular gabled wing: its walls and roof faces (not yet built).
struct Wing {
    /// Corners of the footprint, counter-clockwise from above, at z = 0.
    corners: [V3; 4],
    wall_h: f64,
    ridge_h: f64,
}

impl Wing {
    fn new(centre: V3, yaw: f64, length: f64, width: f64, wall_h: f64, pitch_deg: f64) -> Wing {
        let (c, s) = (yaw.cos(), yaw.sin());
        let at = |x: f64, y: f64| snap(centre + V3::new(c * x - s * y, s * x + c * y, 0.0));
        let (l, w) = (length / 2.0, width / 2.0);
        Wing {
            corners: [at(-l, -w), at(l, -w), at(l, w), at(-l, w)],
            wall_h,
            ridge_h: wall_h + w * pitch_deg.to_radians().tan(),
        }
    }

    fn walls(&self) -> Vec<WallPlan> {
        (0..4)
            .map(|i| WallPlan {
                p: self.corners[i],
                q: self.corners[(i + 1) % 4],
                h_p: self.wall_h,
                h_q: self.wall_h,
            })
            .collect()
    }

    /// Roof slopes (along the long sides 0→1 and 2→3) and gable triangles.
    fn roof(&self, b: &mut Builder, tiles: &str, gable: &str) {
        let [a, bb, c, d] = self.corners;
        let up = |v: V3, h: f64| V3::new(v.x, v.y, h);
        let r0 = snap(up((a + d) / 2.0, self.ridge_h));
        let r1 = snap(up((bb + c) / 2.0, self.ridge_h));
        let h = self.wall_h;
        b.polygon("roof", &[up(a, h), up(bb, h), r1, r0], tiles);
        b.polygon("roof", &[up(c, h), up(d, h), r0, r1], tiles);
        b.polygon("gable", &[up(bb, h), up(c, h), r1], gable);
        b.polygon("gable", &[up(d, h), up(a, h), r0], gable);
    }
}

pub(super) fn build(b: &mut Builder) -> String {
    let (ambient, intensity) = (b.uni(0.35, 0.5), b.uni(0.5, 0.7));
    b.sun(25.0, 65.0, ambient, intensity);
    let roof = match b.int(0, 2) {
        0 => {
            let c = b.tint([0.62, 0.3, 0.2], 0.05);
            let mut m = material(TextureKind::Bricks, c);
            m.color2 = Some([0.35, 0.16, 0.12]);
            m.brick_size = [0.3, 0.2];
            m.mortar = 0.015;
            b.add_material("roof_tiles", m)
        }
        1 => {
            let c = b.tint([0.35, 0.37, 0.42], 0.04);
            let mut m = material(TextureKind::Bricks, c);
            m.color2 = Some([0.2, 0.21, 0.24]);
            m.brick_size = [0.4, 0.25];
            m.mortar = 0.015;
            b.add_material("slate", m)
        }
        _ => {
            let c = b.tint([0.55, 0.57, 0.58], 0.05);
            let mut m = material(TextureKind::Stripes, c);
            m.color2 = Some([0.4, 0.42, 0.43]);
            m.scale = 0.5;
            b.add_material("metal_roof", m)
        }
    };
    let render_colour = b.wall_colour();
    let render = b.paint("render", render_colour);
    let cladding = match b.int(0, 2) {
        0 => b.wood(),
        1 => b.brick(),
        _ => b.stone(),
    };
    let grass = b.noise("grass", [0.35, 0.48, 0.25], 0.3, 0.9);
    b.ground_rect("ground", (-80.0, -80.0), (80.0, 80.0), 0.0, &grass);

    let mut walls: Vec<WallPlan> = Vec::new();
    let mut wings: Vec<Wing> = Vec::new();
    let mut flat_roof: Option<(Vec<V3>, f64)> = None;
    let mut pyramid: Option<(Vec<V3>, f64, V3)> = None;
    let mut what = Vec::new();
    let polygonal = b.chance(0.4);
    if polygonal {
        let r = b.mm(3.5, 6.0);
        let n = b.int(5, 8);
        let turn = b.uni(0.0, std::f64::consts::TAU);
        let step = std::f64::consts::TAU / n as f64;
        let pts: Vec<V3> = (0..n)
            .map(|i| {
                let a = turn + step * (i as f64 + b.uni(-0.3, 0.3));
                let ri = r * b.uni(0.8, 1.2);
                snap(V3::new(ri * a.cos(), ri * a.sin(), 0.0))
            })
            .collect();
        let outline = hull(pts);
        let h = b.mm(3.0, 4.5);
        for i in 0..outline.len() {
            walls.push(WallPlan {
                p: outline[i],
                q: outline[(i + 1) % outline.len()],
                h_p: h,
                h_q: h,
            });
        }
        if b.chance(0.25) {
            what.push(format!(
                "a {}-sided pavilion with a flat roof",
                outline.len()
            ));
            flat_roof = Some((outline, h));
        } else {
            let centroid = outline.iter().sum::<V3>() / outline.len() as f64;
            let pitch = b.uni(20.0, 50.0);
            let apex_xy = centroid + V3::new(b.uni(-0.6, 0.6), b.uni(-0.6, 0.6), 0.0);
            let mean_dist =
                outline.iter().map(|p| (p - apex_xy).norm()).sum::<f64>() / outline.len() as f64;
            let apex = snap(apex_xy + UP * (h + mean_dist * pitch.to_radians().tan()));
            what.push(format!(
                "a {}-sided pavilion under a pyramid roof (mean pitch {pitch:.0}°, apex off centre)",
                outline.len()
            ));
            pyramid = Some((outline, h, apex));
        }
    } else {
        let yaw0 = b.uni(0.0, 180.0).to_radians();
        let (l1, w1, h1, p1) = (
            b.mm(8.0, 14.0),
            b.mm(5.0, 8.0),
            b.mm(2.8, 4.2),
            b.uni(15.0, 55.0),
        );
        let main = Wing::new(V3::zeros(), yaw0, l1, w1, h1, p1);
        let angle = match b.int(0, 3) {
            0 => 30.0,
            1 => 45.0,
            2 => 60.0,
            _ => b.uni(15.0, 75.0),
        };
        let side = if b.chance(0.5) { 1.0 } else { -1.0 };
        let yaw2 =
            yaw0 + side * (90.0 - angle).to_radians() * if b.chance(0.5) { 1.0 } else { -1.0 };
        // The second wing leaves the main one through its long side (`side`), turned so
        // that it meets that wall at `angle`.
        let start = V3::new(b.uni(-l1 / 4.0, l1 / 4.0), side * w1 / 4.0, 0.0);
        let start = V3::new(
            yaw0.cos() * start.x - yaw0.sin() * start.y,
            yaw0.sin() * start.x + yaw0.cos() * start.y,
            0.0,
        );
        let mut dir = V3::new(yaw2.cos(), yaw2.sin(), 0.0);
        let normal = V3::new(-yaw0.sin(), yaw0.cos(), 0.0) * side;
        if dir.dot(&normal) < 0.0 {
            dir = -dir;
        }
        let (l2, w2) = (b.mm(5.0, 9.0) + w1 / 2.0, b.mm(4.0, w1.min(6.0)));
        let h2 = b.mm(2.6, h1);
        let max_tan = ((main.ridge_h - 0.3 - h2) / (w2 / 2.0)).max(0.2);
        let p2 = b.uni(15.0, 55.0).min(max_tan.atan().to_degrees());
        let yaw_dir = dir.y.atan2(dir.x);
        let second = Wing::new(start + dir * (l2 / 2.0), yaw_dir, l2, w2, h2, p2);
        what.push(format!(
            "a {l1:.1} × {w1:.1} m wing with a {p1:.0}° gable roof, a second wing at {angle:.0}° to it with a {p2:.0}° roof"
        ));
        walls.extend(main.walls());
        walls.extend(second.walls());
        if b.chance(0.5) {
            // A lean-to against the main wing's end wall (corners 1 → 2).
            let [_, c1, c2, _] = main.corners;
            let along = (c2 - c1).normalize();
            let out = V3::new(along.y, -along.x, 0.0);
            let lw = b.mm(2.5, (w1 - 0.5).min(4.0));
            let ld = b.mm(1.8, 3.0);
            let h_hi = b.mm(2.2, h1 - 0.2);
            let pitch = b
                .uni(8.0, 25.0)
                .min(((h_hi - 1.9) / ld).atan().to_degrees());
            let h_lo = h_hi - ld * pitch.to_radians().tan();
            let s0 = b.uni(0.2, w1 - lw - 0.2);
            let a = snap(c1 + along * s0);
            let bq = snap(a + along * lw);
            let (a2, b2) = (snap(a + out * ld), snap(bq + out * ld));
            walls.push(WallPlan {
                p: a,
                q: a2,
                h_p: h_hi,
                h_q: h_lo,
            });
            walls.push(WallPlan {
                p: a2,
                q: b2,
                h_p: h_lo,
                h_q: h_lo,
            });
            walls.push(WallPlan {
                p: b2,
                q: bq,
                h_p: h_lo,
                h_q: h_hi,
            });
            let z = |v: V3, h: f64| V3::new(v.x, v.y, h);
            let lean_roof = [z(a, h_hi), z(a2, h_lo), z(b2, h_lo), z(bq, h_hi)];
            what.push(format!("a lean-to with a {pitch:.0}° roof"));
            b.polygon("lean_to_roof", &lean_roof, &roof);
        }
        wings.push(main);
        wings.push(second);
    }

    // Walls: plain render or cladding, by area; windows and a door as decals.
    let plain_share = b.uni(0.3, 0.7);
    let areas: Vec<f64> = walls.iter().map(WallPlan::area).collect();
    let (plain, painted) = plain_walls(b, &areas, plain_share);
    let glazing = {
        let (pw, ph) = (b.mm(0.3, 0.6), b.mm(0.4, 0.7));
        b.glazing(pw, ph)
    };
    let trim_colour = b.tint([0.92, 0.92, 0.9], 0.04);
    let trim = b.paint("trim", trim_colour);
    let leaf = b.door();
    let mut door_done = false;
    let mut windows = 0;
    for (wall, &is_plain) in walls.iter().zip(&plain) {
        let mat = if is_plain { &render } else { &cladding };
        let (p, q) = (wall.p, wall.q);
        b.polygon(
            "wall",
            &[
                p,
                q,
                V3::new(q.x, q.y, wall.h_q),
                V3::new(p.x, p.y, wall.h_p),
            ],
            mat,
        );
    }
    for wall in &walls {
        let f = wall.frame();
        let len = (wall.q - wall.p).norm();
        let h = wall.h_p.min(wall.h_q);
        if len < 2.0 || h < 2.4 {
            continue;
        }
        if !door_done && len > 3.0 {
            let a = b.uni(1.0, len - 1.0);
            b.decal("door_frame", &f, a, 1.08, 1.1, 2.16, &trim);
            b.decal("door", &f, a, 1.05, 0.95, 2.1, &leaf);
            door_done = true;
            continue;
        }
        let n = b.int(0, ((len - 1.0) / 2.0).floor().min(3.0) as usize);
        for i in 0..n {
            let a = len * (i as f64 + 0.5) / n as f64;
            let (ww, wh) = (b.mm(0.8, 1.4), b.mm(1.0, (h - 1.3).clamp(1.01, 1.6)));
            let zc = 0.9 + wh / 2.0;
            b.decal("window_frame", &f, a, zc, ww + 0.12, wh + 0.12, &trim);
            b.decal("window", &f, a, zc, ww, wh, &glazing);
            windows += 1;
        }
    }

    // Roofs.
    for wing in &wings {
        wing.roof(b, &roof, &render);
    }
    if let Some((outline, h)) = &flat_roof {
        let top: Vec<V3> = outline.iter().map(|p| V3::new(p.x, p.y, *h)).collect();
        let gravel = b.noise("roof_gravel", [0.5, 0.49, 0.46], 0.08, 0.9);
        b.polygon("roof", &top, &gravel);
    }
    if let Some((outline, h, apex)) = &pyramid {
        for i in 0..outline.len() {
            let (p, q) = (outline[i], outline[(i + 1) % outline.len()]);
            b.polygon(
                "roof",
                &[V3::new(p.x, p.y, *h), V3::new(q.x, q.y, *h), *apex],
                &roof,
            );
        }
    }
    // Everything above is the building: cameras keep out of its bounding box.
    let mut lo = V3::repeat(f64::INFINITY);
    let mut hi = V3::repeat(f64::NEG_INFINITY);
    for w in &walls {
        for v in [w.p, w.q] {
            lo = lo.inf(&v);
            hi = hi.sup(&v);
        }
    }
    let top = wings
        .iter()
        .map(|w| w.ridge_h)
        .chain(pyramid.as_ref().map(|p| p.2.z))
        .chain(flat_roof.as_ref().map(|f| f.1))
        .fold(4.5, f64::max);
    hi.z = top;
    b.solids.push((lo, hi));
    let centre = (lo + hi) / 2.0;
    let radius = ((hi.x - lo.x).powi(2) + (hi.y - lo.y).powi(2)).sqrt() / 2.0;

    // A gravel path, a deck and a garden wall, each at its own angle.
    let path_yaw = b.uni(0.0, std::f64::consts::TAU);
    let gravel = b.noise("gravel", [0.62, 0.58, 0.52], 0.05, 1.0);
    let dir = V3::new(path_yaw.cos(), path_yaw.sin(), 0.0);
    let path_len = radius + 12.0;
    let k = b.quad(
        "path",
        V3::new(centre.x, centre.y, 0.0) + dir * (path_len / 2.0),
        UP,
        dir,
        1.6,
        path_len,
        &gravel,
    );
    b.ground.push(k);
    if b.chance(0.5) {
        let deck = b.wood();
        let yaw = b.uni(0.0, 180.0);
        let out = V3::new(b.uni(-1.0, 1.0), b.uni(-1.0, 1.0), 0.0).normalize();
        let c = V3::new(centre.x, centre.y, 0.12) + out * (radius + 1.5);
        let size = V3::new(b.mm(2.5, 4.0), b.mm(2.0, 3.0), 0.24);
        b.turned_box("deck", c, size, yaw, &deck);
    }
    if b.chance(0.5) {
        let wall_m = b.stone();
        let yaw = b.uni(0.0, 180.0);
        let out = V3::new(b.uni(-1.0, 1.0), b.uni(-1.0, 1.0), 0.0).normalize();
        let hgt = b.mm(1.2, 2.0);
        let c = V3::new(centre.x, centre.y, hgt / 2.0) + out * (radius + b.uni(3.0, 5.0));
        let size = V3::new(b.mm(4.0, 8.0), 0.25, hgt);
        b.turned_box("garden_wall", c, size, yaw, &wall_m);
    }

    // Views: an orbit at eye height and a drone orbit.
    let count = b.int(10, 20);
    let drone = count * 3 / 10;
    let orbit = count - drone;
    let rule = ViewRule {
        min_surface: 0.6,
        min_building: 0.25,
        near: 1.0,
        max_near_share: 0.1,
    };
    let start = b.uni(0.0, 360.0);
    let arc = b.uni(220.0, 360.0);
    let dist = b.uni(4.0, 8.0);
    b.add_views(orbit, &rule, &mut |b, i, attempt| {
        let a = (start + arc * i as f64 / orbit as f64).to_radians();
        let r = radius + (dist - 0.5 * attempt as f64).max(2.0) + b.uni(-0.5, 0.5);
        let z = if b.chance(0.8) {
            b.uni(1.5, 1.7)
        } else {
            b.uni(2.5, 4.0)
        };
        let p = V3::new(centre.x + r * a.cos(), centre.y + r * a.sin(), z);
        let t = V3::new(
            centre.x + b.uni(-1.0, 1.0),
            centre.y + b.uni(-1.0, 1.0),
            b.uni(1.0, 2.5),
        );
        (p, t)
    });
    b.add_views(drone, &rule, &mut |b, i, _| {
        let a = (start + 360.0 * i as f64 / drone.max(1) as f64 + b.uni(-10.0, 10.0)).to_radians();
        let r = radius + b.uni(5.0, 12.0);
        let p = V3::new(
            centre.x + r * a.cos(),
            centre.y + r * a.sin(),
            b.uni(8.0, 15.0),
        );
        let t = V3::new(
            centre.x + b.uni(-1.0, 1.0),
            centre.y + b.uni(-1.0, 1.0),
            b.uni(0.0, 3.0),
        );
        (p, t)
    });
    what.push(format!(
        "{} walls, plain render on {:.0} % of their area, {windows} windows; {count} views ({drone} from a drone)",
        walls.len(),
        100.0 * painted
    ));
    what.join("; ")
}
