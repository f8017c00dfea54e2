//! Halls: a tall atrium (14–24 × 10–16 m, 9–15 m high) with galleries at one to three
//! levels (4 m and then every 3.6–4.4 m) along both long walls and, each with probability
//! one half, the end walls; square pillars from floor to roof along the galleries' edges;
//! balustrades (solid, glass-like or balusters); doors at the floor and on every gallery,
//! tall windows and clerestories recessed into the walls; stone cladding, banners, a stone
//! or tiled floor, a skylight or a grid of ceiling beams. Views: a walk across the floor at
//! eye height, views looking up (pitch 25–60°), and views from the galleries looking across
//! and down.

use super::builder::{material, plain_walls, Builder, Frame, Opening, ViewRule, UP, V3};
use crate::synth::spec::TextureKind;

/// Whether two opening rectangles (with a margin) overlap.
fn overlaps(a: &Opening, b: &Opening, margin: f64) -> bool {
    a.a0 < b.a1 + margin && b.a0 < a.a1 + margin && a.z0 < b.z1 + margin && b.z0 < a.z1 + margin
}

pub(super) fn build(b: &mut Builder) -> String {
    let w = b.mm(14.0, 24.0);
    let d = b.mm(10.0, 16.0);
    let h = b.mm(9.0, 15.0);
    let gap = b.mm(3.6, 4.4);
    let max_levels = (((h - 3.0 - 4.0) / gap).floor() as usize + 1).max(1);
    let levels = b.int(1, 3).min(max_levels);
    let gd = b.mm(2.0, 3.0);
    // Sides: 0 south (y = 0), 1 east (x = w), 2 north (y = d), 3 west (x = 0).
    let has = [true, b.chance(0.5), true, b.chance(0.5)];
    let (ambient, intensity) = (b.uni(0.45, 0.6), b.uni(0.35, 0.55));
    b.sun(50.0, 85.0, ambient, intensity);

    // Materials.
    let paint_colour = b.wall_colour();
    let paint = b.paint("wall_paint", paint_colour);
    let feature = b.wall_texture(false);
    let floor = match b.int(0, 2) {
        0 => b.tiles(0.4, 0.8),
        1 => b.stone(),
        _ => b.noise("marble", [0.85, 0.83, 0.8], 0.15, 0.6),
    };
    let slab = b.noise("concrete", [0.7, 0.7, 0.68], 0.3, 0.35);
    let pillar_m = match b.int(0, 2) {
        0 => b.stone(),
        1 => paint.clone(),
        _ => slab.clone(),
    };
    let rail = match b.int(0, 2) {
        0 => {
            let c = b.tint([0.6, 0.7, 0.75], 0.05);
            b.paint("glass_rail", c)
        }
        1 => {
            let mut m = material(TextureKind::Stripes, [0.88, 0.88, 0.86]);
            m.color2 = Some([0.15, 0.15, 0.17]);
            m.scale = 0.14;
            b.add_material("balusters", m)
        }
        _ => paint.clone(),
    };
    let ceiling_colour = b.tint([0.93, 0.93, 0.92], 0.03);
    let ceiling = b.paint("ceiling", ceiling_colour);
    let leaf = b.door();
    let glazing = {
        let (pw, ph) = (b.mm(0.5, 0.9), b.mm(0.6, 1.1));
        b.glazing(pw, ph)
    };

    let frames = [
        Frame::new(V3::new(0.0, 0.0, 0.0), V3::x(), V3::y()),
        Frame::new(V3::new(w, 0.0, 0.0), V3::y(), -V3::x()),
        Frame::new(V3::new(w, d, 0.0), -V3::x(), -V3::y()),
        Frame::new(V3::new(0.0, d, 0.0), -V3::y(), V3::x()),
    ];
    let lens = [w, d, w, d];
    let zs: Vec<f64> = (0..levels).map(|k| 4.0 + k as f64 * gap).collect();
    let z_top = *zs.last().expect("at least one level");

    // Openings: doors at the floor and on the galleries, tall windows, clerestories.
    let mut openings: Vec<Vec<Opening>> = vec![Vec::new(); 4];
    // An opening of `width` somewhere in `lo..hi` along the wall, unless it would overlap.
    let try_add = |b: &mut Builder,
                   list: &mut Vec<Opening>,
                   (lo, hi): (f64, f64),
                   width: f64,
                   z0: f64,
                   z1: f64,
                   depth: f64,
                   mat: &str| {
        if hi - lo < width + 1.0 {
            return false;
        }
        let a0 = b.mm(lo + 0.5, hi - 0.5 - width);
        let o = Opening {
            a0,
            a1: a0 + width,
            z0,
            z1,
            depth,
            material: mat.to_string(),
        };
        if list.iter().any(|p| overlaps(p, &o, 0.4)) {
            return false;
        }
        list.push(o);
        true
    };
    let mut doors = 0;
    for _ in 0..30 {
        if doors >= 2 {
            break;
        }
        let k = b.int(0, 3);
        let (dw, dh, depth) = (b.mm(1.6, 2.6), b.mm(2.4, 3.2), b.mm(0.2, 0.4));
        if try_add(
            b,
            &mut openings[k],
            (0.0, lens[k]),
            dw,
            0.0,
            dh,
            depth,
            &leaf,
        ) {
            doors += 1;
        }
    }
    for (k, &on) in has.iter().enumerate() {
        if !on {
            continue;
        }
        for &z in &zs {
            for _ in 0..b.int(0, 2) {
                let (dw, dh) = (b.mm(1.0, 1.4), b.mm(2.2, 2.4));
                if try_add(
                    b,
                    &mut openings[k],
                    (gd, lens[k] - gd),
                    dw,
                    z,
                    z + dh,
                    0.15,
                    &leaf,
                ) {
                    doors += 1;
                }
            }
        }
    }
    let mut windows = 0;
    for k in 0..4 {
        let (z0, z1) = if has[k] {
            (z_top + 1.6, h - 1.0)
        } else {
            let z0 = b.mm(1.0, 3.0);
            (z0, (z0 + b.mm(3.0, 6.0)).min(h - 1.0))
        };
        if z1 - z0 < 1.2 {
            continue;
        }
        let bays = ((lens[k] - 2.0) / b.uni(3.0, 5.0)).floor().max(1.0) as usize;
        let ww = b.mm(1.0, 2.0);
        let depth = b.mm(0.2, 0.4);
        for i in 0..bays {
            let c = lens[k] * (i as f64 + 0.5) / bays as f64;
            let o = Opening {
                a0: c - ww / 2.0,
                a1: c + ww / 2.0,
                z0,
                z1,
                depth,
                material: glazing.clone(),
            };
            if !openings[k].iter().any(|p| overlaps(p, &o, 0.3)) {
                openings[k].push(o);
                windows += 1;
            }
        }
    }

    // Floor, ceiling, walls.
    let c = V3::new(w / 2.0, d / 2.0, 0.0);
    b.quad("floor", c, UP, V3::y(), w, d, &floor);
    b.quad("ceiling", c + UP * h, -UP, V3::y(), w, d, &ceiling);
    let plain_share = b.uni(0.3, 0.7);
    let areas: Vec<f64> = lens.iter().map(|l| l * h).collect();
    let (plain, painted) = plain_walls(b, &areas, plain_share);
    for k in 0..4 {
        let mat = if plain[k] { &paint } else { &feature };
        b.wall("wall", &frames[k], lens[k], h, mat, &openings[k]);
    }
    // Stone cladding up to the first gallery, and banners, on the plain walls.
    let cladding = b.stone();
    let clad_top = b.mm(2.4, 3.4).min(zs[0] - 0.5);
    for k in 0..4 {
        if !plain[k] {
            continue;
        }
        if b.chance(0.5) {
            let mut at = 0.0;
            let mut cuts: Vec<(f64, f64)> = openings[k]
                .iter()
                .filter(|o| o.z0 < clad_top)
                .map(|o| (o.a0, o.a1))
                .collect();
            cuts.sort_by(|p, q| p.0.total_cmp(&q.0));
            cuts.push((lens[k], lens[k]));
            for (c0, c1) in cuts {
                if c0 > at + 0.1 {
                    b.decal(
                        "cladding",
                        &frames[k],
                        (at + c0) / 2.0,
                        clad_top / 2.0,
                        c0 - at,
                        clad_top,
                        &cladding,
                    );
                }
                at = at.max(c1);
            }
        }
        if b.chance(0.6) {
            let (bw, bh) = (b.mm(1.2, 2.0), b.mm(3.0, 5.0));
            let a = b.mm(gd + 1.0, lens[k] - gd - 1.0);
            let zc = (zs[0] + 1.2 + bh / 2.0).min(h - 0.5 - bh / 2.0);
            let banner = b.posters("banner", bw, 1.0);
            let o = Opening {
                a0: a - bw / 2.0,
                a1: a + bw / 2.0,
                z0: zc - bh / 2.0,
                z1: zc + bh / 2.0,
                depth: 0.0,
                material: String::new(),
            };
            if !openings[k].iter().any(|p| overlaps(p, &o, 0.2)) {
                b.decal("banner", &frames[k], a, zc, bw, bh, &banner);
            }
        }
    }

    // Skylight or beams.
    if b.chance(0.5) {
        let sky = {
            let mut m = material(TextureKind::Bricks, [0.8, 0.88, 0.95]);
            m.color2 = Some([0.3, 0.3, 0.32]);
            m.brick_size = [0.9, 0.9];
            m.mortar = 0.06;
            m.row_offset = 0.0;
            b.add_material("skylight", m)
        };
        let (sw, sd) = (b.mm(0.3 * w, 0.55 * w), b.mm(0.3 * d, 0.55 * d));
        b.quad("skylight", c + UP * h, -UP, V3::y(), sw, sd, &sky);
    } else {
        let beam = if b.chance(0.5) {
            b.wood()
        } else {
            slab.clone()
        };
        let (bw, bh) = (b.mm(0.3, 0.5), b.mm(0.5, 0.9));
        let nx = b.int(3, 6);
        for i in 0..nx {
            let x = w * (i + 1) as f64 / (nx + 1) as f64;
            b.aabox(
                "beam",
                V3::new(x - bw / 2.0, 0.0, h - bh),
                V3::new(x + bw / 2.0, d, h),
                &beam,
                &[],
            );
        }
    }

    // Galleries: slabs, balustrades, and the pillars along their edges.
    let x_lo = if has[3] { gd } else { 0.0 };
    let x_hi = if has[1] { w - gd } else { w };
    let gallery_floor = floor.clone();
    for &z in &zs {
        let top = [("zmax", gallery_floor.as_str())];
        if has[0] {
            b.solid(
                "gallery",
                V3::new(0.0, 0.0, z - 0.35),
                V3::new(w, gd, z),
                &slab,
                &top,
            );
            b.solid(
                "balustrade",
                V3::new(x_lo, gd - 0.08, z),
                V3::new(x_hi, gd, z + 1.05),
                &rail,
                &[],
            );
        }
        if has[2] {
            b.solid(
                "gallery",
                V3::new(0.0, d - gd, z - 0.35),
                V3::new(w, d, z),
                &slab,
                &top,
            );
            b.solid(
                "balustrade",
                V3::new(x_lo, d - gd, z),
                V3::new(x_hi, d - gd + 0.08, z + 1.05),
                &rail,
                &[],
            );
        }
        if has[3] {
            b.solid(
                "gallery",
                V3::new(0.0, 0.0, z - 0.35),
                V3::new(gd, d, z),
                &slab,
                &top,
            );
            b.solid(
                "balustrade",
                V3::new(gd - 0.08, gd, z),
                V3::new(gd, d - gd, z + 1.05),
                &rail,
                &[],
            );
        }
        if has[1] {
            b.solid(
                "gallery",
                V3::new(w - gd, 0.0, z - 0.35),
                V3::new(w, d, z),
                &slab,
                &top,
            );
            b.solid(
                "balustrade",
                V3::new(w - gd, gd, z),
                V3::new(w - gd + 0.08, d - gd, z + 1.05),
                &rail,
                &[],
            );
        }
    }
    let ps = b.mm(0.4, 0.7);
    let spacing = b.uni(3.5, 5.0);
    let mut pillars = 0;
    let nx = ((x_hi - x_lo) / spacing).round().max(1.0) as usize;
    for i in 0..=nx {
        let x = x_lo + (x_hi - x_lo) * i as f64 / nx as f64;
        let x0 = (x - ps / 2.0).clamp(x_lo.max(0.0), x_hi - ps);
        for y0 in [gd - ps, d - gd] {
            b.solid(
                "pillar",
                V3::new(x0, y0, 0.0),
                V3::new(x0 + ps, y0 + ps, h),
                &pillar_m,
                &[],
            );
            pillars += 1;
        }
    }
    let ny = ((d - 2.0 * gd) / spacing).round().max(1.0) as usize;
    for (side, x0) in [(3, gd - ps), (1, w - gd)] {
        if !has[side] {
            continue;
        }
        for i in 1..ny {
            let y = gd + (d - 2.0 * gd) * i as f64 / ny as f64;
            b.solid(
                "pillar",
                V3::new(x0, y - ps / 2.0, 0.0),
                V3::new(x0 + ps, y + ps / 2.0, h),
                &pillar_m,
                &[],
            );
            pillars += 1;
        }
    }

    // Views: the floor at eye height, looking up, and from the galleries.
    let count = b.int(14, 22);
    let up_count = count / 4;
    let gallery_count = count * 3 / 10;
    let floor_count = count - up_count - gallery_count;
    let rule = ViewRule {
        min_surface: 0.98,
        min_building: 0.0,
        near: 0.6,
        max_near_share: 0.2,
    };
    let (fx0, fx1, fy0, fy1) = (x_lo + 0.8, x_hi - 0.8, gd + 0.8, d - gd - 0.8);
    let mut walk_pts: Vec<V3> = (0..4)
        .map(|_| V3::new(b.uni(fx0, fx1), b.uni(fy0, fy1), 0.0))
        .collect();
    let centre = V3::new(w / 2.0, d / 2.0, 0.0);
    walk_pts.sort_by(|p, q| {
        let ap = (p.y - centre.y).atan2(p.x - centre.x);
        let aq = (q.y - centre.y).atan2(q.x - centre.x);
        ap.total_cmp(&aq)
    });
    for (n, look_up) in [(floor_count, false), (up_count, true)] {
        b.add_views(n, &rule, &mut |b, i, attempt| {
            let base = super::interior::along_loop(
                &walk_pts,
                (i as f64 + if look_up { 0.5 } else { 0.0 }) / n as f64,
            );
            let j = 0.4 * attempt as f64;
            let p = V3::new(
                (base.x + b.uni(-j, j)).clamp(fx0, fx1),
                (base.y + b.uni(-j, j)).clamp(fy0, fy1),
                b.uni(1.5, 1.7),
            );
            let yaw = b.uni(0.0, std::f64::consts::TAU);
            let pitch = if look_up {
                b.uni(25.0, 60.0)
            } else {
                b.uni(-5.0, 15.0)
            }
            .to_radians();
            (
                p,
                p + V3::new(
                    yaw.cos() * pitch.cos(),
                    yaw.sin() * pitch.cos(),
                    pitch.sin(),
                ) * 4.0,
            )
        });
    }
    let sides: Vec<usize> = (0..4).filter(|&k| has[k]).collect();
    b.add_views(gallery_count, &rule, &mut |b, _, _| {
        let side = b.pick(&sides);
        let z = zs[b.int(0, zs.len() - 1)] + b.uni(1.5, 1.7);
        let (p, inward) = match side {
            0 => (
                V3::new(b.uni(x_lo + 0.6, x_hi - 0.6), b.uni(0.5, gd - 0.45), z),
                V3::y(),
            ),
            2 => (
                V3::new(
                    b.uni(x_lo + 0.6, x_hi - 0.6),
                    b.uni(d - gd + 0.45, d - 0.5),
                    z,
                ),
                -V3::y(),
            ),
            3 => (
                V3::new(b.uni(0.5, gd - 0.45), b.uni(gd + 0.6, d - gd - 0.6), z),
                V3::x(),
            ),
            _ => (
                V3::new(
                    b.uni(w - gd + 0.45, w - 0.5),
                    b.uni(gd + 0.6, d - gd - 0.6),
                    z,
                ),
                -V3::x(),
            ),
        };
        let yaw = inward.y.atan2(inward.x) + b.uni(-60.0, 60.0).to_radians();
        let pitch = b.uni(-35.0, -5.0).to_radians();
        (
            p,
            p + V3::new(
                yaw.cos() * pitch.cos(),
                yaw.sin() * pitch.cos(),
                pitch.sin(),
            ) * 4.0,
        )
    });
    let sides_txt = ["south", "east", "north", "west"]
        .iter()
        .zip(has)
        .filter(|(_, on)| *on)
        .map(|(s, _)| *s)
        .collect::<Vec<_>>()
        .join("/");
    format!(
        "{w:.1} × {d:.1} m hall, {h:.1} m high; {levels} gallery levels ({sides_txt}), {pillars} pillars; \
         {doors} doors, {windows} windows; plain paint on {:.0} % of the wall area; {count} views \
         ({up_count} looking up, {gallery_count} from galleries)",
        100.0 * painted
    )
}
