//! Interiors: a rectangular or L-shaped room (4.5–10 × 4–9.5 m, 2.5–3.4 m high, or 4.8–6 m
//! with a mezzanine), doors and windows recessed into the walls, skirting, pictures and
//! notice boards, built-ins against the walls (cabinets, bookshelves, a kitchen unit with
//! worktop, backsplash and wall cabinets, sofas, desks), a table and rug, ceiling beams,
//! light panels, and stairs up to the mezzanine or to a raised platform. Walls are plain
//! paint on 30–70 % of their area, the rest one feature finish (brick, stone, tiles,
//! boards, wallpaper). Views: a walk at eye height round the room (a quarter of the views at
//! crouching or raised heights) and, with a mezzanine, views from it looking down.

use super::builder::{material, plain_walls, Builder, Frame, Opening, ViewRule, UP, V3};
use crate::synth::spec::TextureKind;

/// A wall of the room: its frame (normal into the room), length, openings and the
/// stretches of it already taken (openings, stairs, furniture, pictures).
struct Wall {
    frame: Frame,
    len: f64,
    openings: Vec<Opening>,
    busy: Vec<(f64, f64)>,
    /// Windows may sit between these heights (above a mezzanine on its wall).
    window_z: (f64, f64),
}

impl Wall {
    fn free(&self, a0: f64, a1: f64) -> bool {
        a0 >= 0.15
            && a1 <= self.len - 0.15
            && self
                .busy
                .iter()
                .all(|&(b0, b1)| a1 + 0.1 <= b0 || a0 >= b1 + 0.1)
    }

    /// Stretches of the wall outside its openings reaching down to the floor (doors).
    fn floor_segments(&self) -> Vec<(f64, f64)> {
        let mut cuts: Vec<(f64, f64)> = self
            .openings
            .iter()
            .filter(|o| o.z0 < 0.2)
            .map(|o| (o.a0, o.a1))
            .collect();
        cuts.sort_by(|p, q| p.0.total_cmp(&q.0));
        let mut out = Vec::new();
        let mut at = 0.0;
        for (c0, c1) in cuts {
            if c0 > at + 0.05 {
                out.push((at, c0));
            }
            at = at.max(c1);
        }
        if self.len > at + 0.05 {
            out.push((at, self.len));
        }
        out
    }
}

/// The box face whose outward normal is `n` (an axis direction).
fn face_towards(n: &V3) -> &'static str {
    if n.x > 0.5 {
        "xmax"
    } else if n.x < -0.5 {
        "xmin"
    } else if n.y > 0.5 {
        "ymax"
    } else {
        "ymin"
    }
}

/// A flight of `steps` solid steps between `x0` and `x1`, rising towards +y and ending at
/// `y_top` one `rise` below the level it serves.
#[allow(clippy::too_many_arguments)]
fn stairs(
    b: &mut Builder,
    x0: f64,
    x1: f64,
    y_top: f64,
    steps: usize,
    rise: f64,
    run: f64,
    tread: &str,
    riser: &str,
) {
    for i in 0..steps {
        let y0 = y_top - (steps - i) as f64 * run;
        b.aabox(
            "step",
            V3::new(x0, y0, 0.0),
            V3::new(x1, y_top, (i + 1) as f64 * rise),
            riser,
            &[("zmax", tread)],
        );
    }
    b.solids.push((
        V3::new(x0, y_top - steps as f64 * run, 0.0),
        V3::new(x1, y_top, steps as f64 * rise),
    ));
}

pub(super) fn build(b: &mut Builder) -> String {
    let mezz = b.chance(0.4);
    let l_shape = b.chance(0.4);
    let (w, d) = if mezz {
        (b.mm(6.0, 10.0), b.mm(7.5, 9.5))
    } else {
        (b.mm(4.5, 9.0), b.mm(4.0, 7.5))
    };
    let h = if mezz { b.mm(4.8, 6.0) } else { b.mm(2.5, 3.4) };
    let (cw, cd) = if l_shape {
        (b.mm(0.3 * w, 0.5 * w), b.mm(0.3 * d, 0.45 * d))
    } else {
        (0.0, 0.0)
    };
    let inside = move |x: f64, y: f64, m: f64| {
        x > m && x < w - m && y > m && y < d - m && !(l_shape && x > w - cw - m && y > d - cd - m)
    };
    // Light from above (no shadows): ambient high, as rooms are lit from all sides.
    let (ambient, intensity) = (b.uni(0.45, 0.6), b.uni(0.35, 0.55));
    b.sun(45.0, 80.0, ambient, intensity);

    // Materials.
    let wall_paint_colour = b.wall_colour();
    let paint = b.paint("wall_paint", wall_paint_colour);
    let feature = b.wall_texture(true);
    let plain_share = b.uni(0.3, 0.7);
    let floor = match b.int(0, 3) {
        0 => b.parquet(),
        1 => b.tiles(0.3, 0.6),
        2 => b.noise("carpet", [0.45, 0.4, 0.38], 0.04, 0.8),
        _ => b.noise("concrete", [0.6, 0.6, 0.58], 0.3, 0.5),
    };
    let ceiling = if b.chance(0.2) {
        b.wood()
    } else {
        let c = b.tint([0.93, 0.93, 0.92], 0.03);
        b.paint("ceiling", c)
    };
    let trim_colour = b.tint([0.95, 0.95, 0.93], 0.05);
    let trim = b.paint("trim", trim_colour);

    // The outline, counter-clockwise seen from above; walls face into the room.
    let outline: Vec<(f64, f64)> = if l_shape {
        vec![
            (0.0, 0.0),
            (w, 0.0),
            (w, d - cd),
            (w - cw, d - cd),
            (w - cw, d),
            (0.0, d),
        ]
    } else {
        vec![(0.0, 0.0), (w, 0.0), (w, d), (0.0, d)]
    };
    let n = outline.len();
    let mut walls: Vec<Wall> = (0..n)
        .map(|i| {
            let (p, q) = (outline[i], outline[(i + 1) % n]);
            let along = V3::new(q.0 - p.0, q.1 - p.1, 0.0);
            Wall {
                frame: Frame::new(
                    V3::new(p.0, p.1, 0.0),
                    along,
                    V3::new(-along.y, along.x, 0.0),
                ),
                len: along.norm(),
                openings: Vec::new(),
                busy: Vec::new(),
                window_z: (0.8, h - 0.25),
            }
        })
        .collect();
    let (north, west) = (n - 2, n - 1);
    let mx = w - cw; // the north wall runs from x = mx to 0

    // Mezzanine along the north wall with stairs up the west wall, or a raised platform.
    let mut what = vec![format!(
        "{} {w:.1} × {d:.1} m room, {h:.1} m high",
        if l_shape { "L-shaped" } else { "rectangular" }
    )];
    let tread = if b.chance(0.5) { b.wood() } else { b.stone() };
    let riser = paint.clone();
    let mut mezz_level = None;
    let platform = !mezz && mx >= 2.4 && b.chance(0.35);
    if platform {
        // Nothing on the wall behind the platform.
        let len = walls[north].len;
        walls[north].busy.push((0.0, len));
    }
    if mezz {
        let zm = b.mm(2.6, 2.95);
        let md = b.mm(1.8, 2.4);
        let sw = b.mm(0.9, 1.2);
        let n_rise = (zm / 0.185).ceil() as usize;
        let rise = zm / n_rise as f64;
        let run = ((d - md - 1.0) / (n_rise - 1) as f64).min(0.29);
        // The west wall runs from y = d down to 0: the flight takes a = md … md + length.
        let length = (n_rise - 1) as f64 * run;
        walls[west].busy.push((md - 0.1, md + length + 0.1));
        walls[north].window_z = (zm + 0.9, h - 0.25);
        mezz_level = Some((zm, md, sw, n_rise, rise, run));
        what.push(format!(
            "a mezzanine at {zm:.2} m with {} steps up to it",
            n_rise - 1
        ));
    }

    // Doors and windows.
    let door_count = b.int(1, 2) + usize::from(w * d > 40.0);
    let mut doors = 0;
    for _ in 0..door_count * 10 {
        if doors == door_count {
            break;
        }
        let k = b.int(0, n - 1);
        let dw = if b.chance(0.2) {
            b.mm(1.4, 1.8)
        } else {
            b.mm(0.8, 1.0)
        };
        if walls[k].len < dw + 0.8 {
            continue;
        }
        let len = walls[k].len;
        let a0 = b.mm(0.3, len - 0.3 - dw);
        if !walls[k].free(a0 - 0.1, a0 + dw + 0.1) {
            continue;
        }
        let leaf = b.door();
        let (z1, depth) = (b.mm(2.0, 2.2), b.mm(0.05, 0.12));
        walls[k].openings.push(Opening {
            a0,
            a1: a0 + dw,
            z0: 0.0,
            z1,
            depth,
            material: leaf,
        });
        walls[k].busy.push((a0, a0 + dw));
        doors += 1;
    }
    let window_count = b.int(1, 3) + usize::from(h > 4.0);
    let pane = (b.mm(0.3, 0.6), b.mm(0.4, 0.7));
    let glazing = b.glazing(pane.0, pane.1);
    let mut windows = 0;
    for _ in 0..window_count * 10 {
        if windows == window_count {
            break;
        }
        let k = b.int(0, n - 1);
        let ww = b.mm(0.8, 2.2);
        let (zlo, zhi) = walls[k].window_z;
        if walls[k].len < ww + 0.6 || zhi - zlo < 1.0 {
            continue;
        }
        let len = walls[k].len;
        let a0 = b.mm(0.3, len - 0.3 - ww);
        if !walls[k].free(a0, a0 + ww) {
            continue;
        }
        let z0 = b.mm(zlo, (zlo + 0.2).min(zhi - 1.0));
        let z1 = (z0 + b.mm(1.0, 1.8)).min(zhi);
        let depth = b.mm(0.15, 0.35);
        walls[k].openings.push(Opening {
            a0,
            a1: a0 + ww,
            z0,
            z1,
            depth,
            material: glazing.clone(),
        });
        walls[k].busy.push((a0, a0 + ww));
        windows += 1;
    }
    what.push(format!("{doors} doors, {windows} windows"));

    // Floor, ceiling and walls.
    let mut floor_rects = vec![((0.0, 0.0), (w, d - cd))];
    if l_shape {
        floor_rects.push(((0.0, d - cd), (w - cw, d)));
    }
    for &(lo, hi) in &floor_rects {
        let c = V3::new((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0, 0.0);
        let (sx, sy) = (hi.0 - lo.0, hi.1 - lo.1);
        b.quad("floor", c, UP, V3::y(), sx, sy, &floor);
        b.quad("ceiling", c + UP * h, -UP, V3::y(), sx, sy, &ceiling);
    }
    let areas: Vec<f64> = walls.iter().map(|w| w.len * h).collect();
    let (plain, painted) = plain_walls(b, &areas, plain_share);
    what.push(format!(
        "plain paint on {:.0} % of the wall area",
        100.0 * painted
    ));
    for (wall, &p) in walls.iter().zip(&plain) {
        let mat = if p { &paint } else { &feature };
        b.wall("wall", &wall.frame, wall.len, h, mat, &wall.openings);
    }

    // Skirting and wainscot on the stretches between doors.
    if b.chance(0.6) {
        let sk = b.mm(0.07, 0.14);
        for wall in &walls {
            for (a0, a1) in wall.floor_segments() {
                let f = &wall.frame;
                b.aabox(
                    "skirting",
                    f.at(a0, 0.0, 0.0),
                    f.at(a1, 0.015, sk),
                    &trim,
                    &[],
                );
            }
        }
    }
    if b.chance(0.3) {
        let panel = b.wood();
        let top = b.mm(0.85, 1.2);
        for (wall, &p) in walls.iter().zip(&plain) {
            if !p {
                continue;
            }
            for (a0, a1) in wall.floor_segments() {
                let low_windows = wall
                    .openings
                    .iter()
                    .any(|o| o.z0 > 0.2 && o.z0 < top && o.a1 > a0 && o.a0 < a1);
                if !low_windows {
                    b.decal(
                        "wainscot",
                        &wall.frame,
                        (a0 + a1) / 2.0,
                        top / 2.0,
                        a1 - a0,
                        top,
                        &panel,
                    );
                }
            }
        }
        what.push("wainscot".into());
    }

    // Built-ins against the walls.
    let item_count = b.int(2, 5);
    let mut items = Vec::new();
    let mut kitchen = false;
    for _ in 0..item_count * 12 {
        if items.len() == item_count {
            break;
        }
        let k = b.int(0, n - 1);
        let kind = b.int(0, 4);
        let wi = match kind {
            0 => b.mm(0.5, 1.4),
            1 => b.mm(0.8, 2.0),
            2 => b.mm(1.8, 3.6),
            3 => b.mm(1.6, 2.4),
            _ => b.mm(1.0, 1.6),
        };
        if (kind == 2 && kitchen) || walls[k].len < wi + 0.4 {
            continue;
        }
        let len = walls[k].len;
        let a0 = b.mm(0.2, len - 0.2 - wi);
        if !walls[k].free(a0, a0 + wi) {
            continue;
        }
        walls[k].busy.push((a0, a0 + wi));
        let f = walls[k].frame;
        let front = face_towards(&f.normal);
        let a1 = a0 + wi;
        let name = match kind {
            0 => {
                let (di, hi) = (b.mm(0.4, 0.6), b.mm(0.8, 2.1));
                let m = if b.chance(0.5) {
                    let c = b.wall_colour();
                    b.paint("cabinet", c)
                } else {
                    b.wood()
                };
                b.solid("cabinet", f.at(a0, 0.0, 0.0), f.at(a1, di, hi), &m, &[]);
                "cabinet"
            }
            1 => {
                let (di, hi) = (b.mm(0.28, 0.4), b.mm(1.8, (h - 0.2).min(2.3)));
                let frame = b.wood();
                let spine = b.tint([0.5, 0.35, 0.3], 0.15);
                let mut books = material(TextureKind::Bricks, spine);
                books.color2 = Some([0.12, 0.1, 0.08]);
                books.brick_size = [
                    super::builder::r4(b.uni(0.025, 0.05)),
                    super::builder::r4(b.uni(0.22, 0.32)),
                ];
                books.mortar = super::builder::r4(b.uni(0.008, 0.02));
                books.row_offset = super::builder::r4(b.uni(0.0, 0.5));
                let books = b.add_material("books", books);
                b.solid(
                    "bookshelf",
                    f.at(a0, 0.0, 0.0),
                    f.at(a1, di, hi),
                    &frame,
                    &[(front, books.as_str())],
                );
                "bookshelf"
            }
            2 => {
                kitchen = true;
                let front_m = if b.chance(0.6) {
                    let c = b.wall_colour();
                    b.paint("units", c)
                } else {
                    b.wood()
                };
                let top = if b.chance(0.5) {
                    b.noise("worktop", [0.35, 0.34, 0.33], 0.05, 0.9)
                } else {
                    b.wood()
                };
                b.solid(
                    "kitchen_base",
                    f.at(a0, 0.0, 0.0),
                    f.at(a1, 0.6, 0.86),
                    &front_m,
                    &[],
                );
                b.aabox(
                    "worktop",
                    f.at(a0, 0.0, 0.86),
                    f.at(a1, 0.62, 0.9),
                    &top,
                    &[],
                );
                let splash = b.tiles(0.1, 0.2);
                b.decal("backsplash", &f, (a0 + a1) / 2.0, 1.175, wi, 0.55, &splash);
                if h >= 2.4 {
                    let zt = (h - 0.15).min(2.15);
                    b.aabox(
                        "wall_cabinets",
                        f.at(a0, 0.0, 1.45),
                        f.at(a1, 0.35, zt),
                        &front_m,
                        &[],
                    );
                }
                "kitchen unit"
            }
            3 => {
                let fabric = if b.chance(0.6) {
                    let c = b.tint([0.4, 0.42, 0.5], 0.15);
                    b.noise("fabric", c, 0.03, 0.7)
                } else {
                    let c = b.tint([0.5, 0.45, 0.4], 0.15);
                    b.paint("fabric", c)
                };
                b.solid(
                    "sofa",
                    f.at(a0, 0.0, 0.0),
                    f.at(a1, 0.85, 0.42),
                    &fabric,
                    &[],
                );
                b.aabox(
                    "sofa_back",
                    f.at(a0, 0.0, 0.42),
                    f.at(a1, 0.2, 0.85),
                    &fabric,
                    &[],
                );
                "sofa"
            }
            _ => {
                let (di, zt) = (b.mm(0.6, 0.8), b.mm(0.72, 0.76));
                let top = b.wood();
                b.aabox(
                    "desk",
                    f.at(a0, 0.0, zt - 0.03),
                    f.at(a1, di, zt),
                    &top,
                    &[],
                );
                for (la, ln) in [
                    (a0, 0.0),
                    (a1 - 0.04, 0.0),
                    (a0, di - 0.04),
                    (a1 - 0.04, di - 0.04),
                ] {
                    b.aabox(
                        "desk_leg",
                        f.at(la, ln, 0.0),
                        f.at(la + 0.04, ln + 0.04, zt - 0.03),
                        &trim,
                        &[],
                    );
                }
                b.solids.push((
                    f.at(a0, 0.0, 0.0).inf(&f.at(a1, di, zt)),
                    f.at(a0, 0.0, 0.0).sup(&f.at(a1, di, zt)),
                ));
                "desk"
            }
        };
        items.push(name);
    }
    if !items.is_empty() {
        what.push(items.join(", "));
    }

    // Pictures and notice boards.
    let pictures = b.int(1, 4);
    for _ in 0..pictures * 8 {
        let k = b.int(0, n - 1);
        let (pw, ph) = (b.mm(0.4, 1.2), b.mm(0.4, 1.0));
        let len = walls[k].len;
        if len < pw + 0.6 {
            continue;
        }
        let a0 = b.mm(0.3, len - 0.3 - pw);
        let zc = b.mm(1.4, 1.8).min(h - 0.2 - ph / 2.0);
        let over_opening = walls[k]
            .openings
            .iter()
            .any(|o| o.a1 > a0 - 0.1 && o.a0 < a0 + pw + 0.1 && o.z1 > zc - ph / 2.0);
        if over_opening || !walls[k].free(a0, a0 + pw) {
            continue;
        }
        walls[k].busy.push((a0, a0 + pw));
        let f = walls[k].frame;
        let frame_m = if b.chance(0.5) {
            b.wood()
        } else {
            trim.clone()
        };
        let art = if b.chance(0.5) {
            let cell = b.uni(0.15, 0.3);
            b.posters("notices", cell, 0.6)
        } else {
            let c = b.tint([0.5, 0.45, 0.4], 0.3);
            b.noise("painting", c, 0.08, 1.0)
        };
        let am = a0 + pw / 2.0;
        b.decal("picture_frame", &f, am, zc, pw + 0.06, ph + 0.06, &frame_m);
        b.decal("picture", &f, am, zc, pw, ph, &art);
    }

    // A table and a rug in the room.
    let (tx, ty) = (
        b.mm(0.35 * w, 0.65 * w),
        b.mm(0.3 * (d - cd), 0.6 * (d - cd)),
    );
    if b.chance(0.5) {
        let rug = match b.int(0, 2) {
            0 => b.noise("rug", [0.6, 0.3, 0.25], 0.05, 1.0),
            1 => {
                let c = b.tint([0.7, 0.6, 0.4], 0.1);
                let mut m = material(TextureKind::Stripes, c);
                m.scale = 0.15;
                b.add_material("rug", m)
            }
            _ => {
                let c = b.tint([0.3, 0.35, 0.5], 0.1);
                let mut m = material(TextureKind::Checker, c);
                m.scale = 0.25;
                b.add_material("rug", m)
            }
        };
        let (rw, rd) = (b.mm(1.6, 2.6), b.mm(1.2, 2.0));
        if inside(tx - rw / 2.0, ty - rd / 2.0, 0.1) && inside(tx + rw / 2.0, ty + rd / 2.0, 0.1) {
            b.quad("rug", V3::new(tx, ty, 0.0), UP, V3::y(), rw, rd, &rug);
        }
    }
    if b.chance(0.5) && !mezz {
        let (tw, td, zt) = (b.mm(0.8, 1.6), b.mm(0.7, 1.0), b.mm(0.72, 0.76));
        let top = b.wood();
        let lo = V3::new(tx - tw / 2.0, ty - td / 2.0, zt - 0.04);
        let hi = V3::new(tx + tw / 2.0, ty + td / 2.0, zt);
        b.aabox("table", lo, hi, &top, &[]);
        for (lx, ly) in [
            (lo.x, lo.y),
            (hi.x - 0.05, lo.y),
            (lo.x, hi.y - 0.05),
            (hi.x - 0.05, hi.y - 0.05),
        ] {
            b.aabox(
                "table_leg",
                V3::new(lx, ly, 0.0),
                V3::new(lx + 0.05, ly + 0.05, zt - 0.04),
                &trim,
                &[],
            );
        }
        b.solids.push((V3::new(lo.x, lo.y, 0.0), hi));
        what.push("a table".into());
    }

    // Ceiling beams and light panels.
    if b.chance(0.35) {
        let count = b.int(2, 4);
        let (bw, bh) = (b.mm(0.15, 0.3), b.mm(0.2, 0.4));
        let beam = if b.chance(0.6) {
            b.wood()
        } else {
            ceiling.clone()
        };
        for k in 0..count {
            let x = w * (k + 1) as f64 / (count + 1) as f64;
            let y_end = if l_shape && x > w - cw - bw {
                d - cd
            } else {
                d
            };
            b.aabox(
                "beam",
                V3::new(x - bw / 2.0, 0.0, h - bh),
                V3::new(x + bw / 2.0, y_end, h),
                &beam,
                &[],
            );
        }
        what.push(format!("{count} beams"));
    }
    if b.chance(0.6) {
        let light = {
            let c = b.tint([0.95, 0.95, 0.9], 0.02);
            let mut m = material(TextureKind::Bricks, c);
            m.color2 = Some([0.6, 0.6, 0.6]);
            m.brick_size = [0.3, 0.3];
            m.mortar = 0.02;
            m.row_offset = 0.0;
            b.add_material("light_panel", m)
        };
        for _ in 0..b.int(1, 4) {
            let (lx, ly) = (b.mm(1.0, w - 1.0), b.mm(1.0, d - 1.0));
            if inside(lx, ly, 0.8) {
                b.quad("light", V3::new(lx, ly, h), -UP, V3::y(), 0.6, 0.6, &light);
            }
        }
    }

    // The mezzanine, its columns and balustrade, and its stairs; or a platform.
    if let Some((zm, md, sw, n_rise, rise, run)) = mezz_level {
        let slab = b.noise("concrete", [0.62, 0.62, 0.6], 0.3, 0.4);
        b.solid(
            "mezzanine",
            V3::new(0.0, d - md, zm - 0.25),
            V3::new(mx, d, zm),
            &slab,
            &[("zmax", floor.as_str())],
        );
        let cs = b.mm(0.2, 0.35);
        let count = ((mx - sw) / 3.5).ceil().max(1.0) as usize;
        for k in 0..count {
            let x = sw + 0.5 + (mx - sw - 0.9) * (k as f64 + 0.5) / count as f64;
            b.solid(
                "column",
                V3::new(x - cs / 2.0, d - md, 0.0),
                V3::new(x + cs / 2.0, d - md + cs, zm - 0.25),
                &slab,
                &[],
            );
        }
        let rail = if b.chance(0.5) {
            let c = b.tint([0.2, 0.2, 0.22], 0.05);
            let mut m = material(TextureKind::Stripes, [0.85, 0.85, 0.85]);
            m.color2 = Some(c);
            m.scale = 0.12;
            b.add_material("balusters", m)
        } else {
            trim.clone()
        };
        b.solid(
            "balustrade",
            V3::new(sw, d - md, zm),
            V3::new(mx, d - md + 0.05, zm + 1.0),
            &rail,
            &[],
        );
        if l_shape && md > cd {
            b.solid(
                "balustrade",
                V3::new(mx - 0.05, d - md, zm),
                V3::new(mx, d - cd, zm + 1.0),
                &rail,
                &[],
            );
        }
        stairs(b, 0.0, sw, d - md, n_rise - 1, rise, run, &tread, &riser);
    } else if platform {
        let steps = b.int(2, 4);
        let rise = b.mm(0.15, 0.19);
        let pd = b.mm(1.4, 2.2);
        let sw = b.mm(1.0, 1.8_f64.min(mx - 0.8));
        let x0 = b.mm(0.3, mx - sw - 0.3);
        let run = 0.3;
        let ph = steps as f64 * rise;
        b.solid(
            "platform",
            V3::new(0.0, d - pd, 0.0),
            V3::new(mx, d, ph),
            &riser,
            &[("zmax", floor.as_str())],
        );
        stairs(b, x0, x0 + sw, d - pd, steps - 1, rise, run, &tread, &riser);
        what.push(format!("a {ph:.2} m platform with {} steps", steps - 1));
    }

    // Views: a walk round the room at eye height, and from the mezzanine.
    let count = b.int(10, 20);
    let on_mezz = if mezz { count / 4 } else { 0 };
    let mut loop_pts = Vec::new();
    while loop_pts.len() < 4 {
        let (x, y) = (b.uni(0.0, w), b.uni(0.0, d));
        if inside(x, y, 0.9) && !b.in_solid(&V3::new(x, y, 1.6), 0.3) {
            loop_pts.push(V3::new(x, y, 0.0));
        }
    }
    let centre = loop_pts.iter().sum::<V3>() / 4.0;
    loop_pts.sort_by(|p, q| {
        let ap = (p.y - centre.y).atan2(p.x - centre.x);
        let aq = (q.y - centre.y).atan2(q.x - centre.x);
        ap.total_cmp(&aq)
    });
    let room_centre = V3::new(w / 2.0, (d - cd) / 2.0, 0.0);
    let walk = count - on_mezz;
    let rule = ViewRule {
        min_surface: 0.98,
        min_building: 0.0,
        near: 0.5,
        max_near_share: 0.2,
    };
    b.add_views(walk, &rule, &mut |b, i, attempt| {
        let base = along_loop(&loop_pts, i as f64 / walk as f64);
        let j = 0.25 * attempt as f64;
        let mut p = base + V3::new(b.uni(-j, j), b.uni(-j, j), 0.0);
        if !inside(p.x, p.y, 0.5) {
            p = base;
        }
        p.z = if b.chance(0.75) {
            b.uni(1.5, 1.7)
        } else if b.chance(0.5) {
            b.uni(1.0, 1.3)
        } else {
            b.uni(2.0, 2.3).min(h - 0.3)
        };
        let to = room_centre - p;
        let yaw = to.y.atan2(to.x) + b.uni(-1.0, 1.0) * (60.0 + 10.0 * attempt as f64).to_radians();
        let pitch = b.uni(-15.0, 10.0).to_radians();
        (
            p,
            p + V3::new(
                yaw.cos() * pitch.cos(),
                yaw.sin() * pitch.cos(),
                pitch.sin(),
            ) * 3.0,
        )
    });
    if let Some((zm, md, sw, ..)) = mezz_level {
        b.add_views(on_mezz, &rule, &mut |b, _, _| {
            let p = V3::new(
                b.uni(sw + 0.4, mx - 0.4),
                b.uni(d - md + 0.45, d - 0.35),
                zm + b.uni(1.5, 1.7),
            );
            let yaw = (-90.0 + b.uni(-50.0, 50.0)).to_radians();
            let pitch = b.uni(-35.0, -15.0).to_radians();
            (
                p,
                p + V3::new(
                    yaw.cos() * pitch.cos(),
                    yaw.sin() * pitch.cos(),
                    pitch.sin(),
                ) * 3.0,
            )
        });
    }
    what.push(if mezz {
        format!("{count} views ({on_mezz} from the mezzanine)")
    } else {
        format!("{count} views")
    });
    what.join("; ")
}

/// The point at fraction `f` of the closed polyline through `pts` (by arc length).
pub(super) fn along_loop(pts: &[V3], f: f64) -> V3 {
    let n = pts.len();
    let seg: Vec<f64> = (0..n).map(|i| (pts[(i + 1) % n] - pts[i]).norm()).collect();
    let total: f64 = seg.iter().sum();
    let mut want = f.rem_euclid(1.0) * total;
    for i in 0..n {
        if want <= seg[i] || i == n - 1 {
            let t = if seg[i] > 0.0 {
                (want / seg[i]).min(1.0)
            } else {
                0.0
            };
            return pts[i] + (pts[(i + 1) % n] - pts[i]) * t;
        }
        want -= seg[i];
    }
    pts[0]
}
