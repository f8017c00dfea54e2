//! Streets: three to five adjoining buildings (5–11 m wide, 2–6 storeys) along the north
//! side of a street and, with probability 0.55, a row along the south side; each building
//! line set back 0.3–1.5 m with probability 0.4; facades of plain render, brick, stone,
//! tiles or concrete (plain on 30–70 % of the facade area) with windows recessed 0.1–0.3 m,
//! shop fronts, signs, canopies, balconies, cornices and set-back top storeys (see
//! `buildings`); raised pavements with kerbs, an asphalt road with lane markings and
//! sometimes a zebra crossing, lamp posts and street trees. Views: a walk along the
//! opposite pavement looking at the facades at eye height (some crouching or from a step),
//! views along the street from the near pavement, views of the south row, and drone views
//! 8–20 m up.

use super::builder::{material, plain_walls, Builder, Frame, ViewRule, V3};
use super::buildings::{self, Shared};
use crate::synth::spec::TextureKind;

/// Pavement height above the road (kerb), metres.
const KERB: f64 = 0.15;

pub(super) fn build(b: &mut Builder) -> String {
    let pw = b.mm(2.5, 4.0);
    let rw = b.mm(6.0, 9.0);
    let has_south = b.chance(0.55);
    let pw2 = b.mm(2.5, 4.0);
    let (ambient, intensity) = (b.uni(0.35, 0.5), b.uni(0.5, 0.7));
    b.sun(25.0, 65.0, ambient, intensity);
    let shared = Shared::new(b);

    // Plans of both rows.
    let mut rows: Vec<(bool, f64, f64, f64, buildings::Plan)> = Vec::new(); // (north, x0, width, setback, plan)
    let n_north = b.int(3, 5);
    let mut x = 0.0;
    for _ in 0..n_north {
        let width = b.mm(5.0, 11.0);
        let setback = if b.chance(0.4) { b.mm(0.3, 1.5) } else { 0.0 };
        let depth = b.mm(10.0, 14.0);
        let p = buildings::plan(b, width, depth, 2, 6, true);
        rows.push((true, x, width, setback, p));
        x += width;
    }
    let length = x;
    if has_south {
        let mut x = b.mm(-4.0, 0.0);
        while x < length {
            let width = b.mm(5.0, 11.0).min(length + 4.0 - x).max(4.0);
            let setback = if b.chance(0.4) { b.mm(0.3, 1.5) } else { 0.0 };
            let depth = b.mm(10.0, 14.0);
            let p = buildings::plan(b, width, depth, 2, 5, true);
            rows.push((false, x, width, setback, p));
            x += width;
        }
    }
    let plain_share = b.uni(0.3, 0.7);
    let areas: Vec<f64> = rows.iter().map(|r| r.4.facade_area()).collect();
    let (plain, painted) = plain_walls(b, &areas, plain_share);

    // Ground: fields beyond, the road, its markings, and raised pavements.
    let (x_lo, x_hi) = (-60.0, length + 60.0);
    let field = b.noise("ground", [0.45, 0.45, 0.4], 0.4, 0.8);
    b.ground_rect(
        "ground",
        (x_lo, -rw - pw2 - 60.0),
        (x_hi, pw + 60.0),
        0.0,
        &field,
    );
    let asphalt = b.noise("asphalt", [0.3, 0.3, 0.31], 0.25, 0.6);
    b.ground_rect("road", (x_lo, -rw), (x_hi, 0.0), 0.0, &asphalt);
    let white = b.paint("marking", [0.9, 0.9, 0.88]);
    let mut mx = x_lo + 2.0;
    while mx < x_hi - 3.0 {
        b.ground_rect(
            "lane_marking",
            (mx, -rw / 2.0 - 0.06),
            (mx + 3.0, -rw / 2.0 + 0.06),
            0.0,
            &white,
        );
        mx += 9.0;
    }
    if b.chance(0.4) {
        let mut m = material(TextureKind::Stripes, [0.9, 0.9, 0.88]);
        m.color2 = Some([0.3, 0.3, 0.31]);
        m.scale = 1.0;
        let zebra = b.add_material("zebra", m);
        let zx = b.mm(0.2 * length, 0.8 * length);
        b.ground_rect("crossing", (zx - 1.5, -rw), (zx + 1.5, 0.0), 0.0, &zebra);
    }
    let paving = b.tiles(0.3, 0.5);
    let kerb = b.stone();
    let concrete = b.noise("concrete", [0.62, 0.62, 0.6], 0.3, 0.4);
    let k = b.aabox(
        "pavement",
        V3::new(x_lo, 0.0, 0.0),
        V3::new(x_hi, pw + 2.0, KERB),
        &concrete,
        &[("zmax", paving.as_str()), ("ymin", kerb.as_str())],
    );
    b.ground.push(k);
    let k = b.aabox(
        "pavement",
        V3::new(x_lo, -rw - pw2 - 2.0, 0.0),
        V3::new(x_hi, -rw, KERB),
        &concrete,
        &[("zmax", paving.as_str()), ("ymax", kerb.as_str())],
    );
    b.ground.push(k);

    // The buildings.
    let mut built = buildings::Built::default();
    for ((north, x0, width, setback, p), &is_plain) in rows.iter().zip(&plain) {
        let f = if *north {
            Frame::new(V3::new(*x0, pw + setback, 0.0), V3::x(), -V3::y())
        } else {
            Frame::new(
                V3::new(x0 + width, -rw - pw2 - setback, 0.0),
                -V3::x(),
                V3::y(),
            )
        };
        let r = buildings::build(b, &f, p, is_plain, KERB, &shared);
        built.windows += r.windows;
        built.balconies += r.balconies;
        built.canopies += r.canopies;
    }

    // Street furniture: lamp posts on the north kerb, trees on the south one.
    let metal = b.paint("metal", [0.2, 0.21, 0.22]);
    if b.chance(0.7) {
        let spacing = b.uni(12.0, 20.0);
        let mut lx = b.uni(0.0, spacing);
        while lx < length {
            b.cylinder("lamp_post", V3::new(lx, 0.4, KERB), 5.0, 0.07, &metal);
            b.aabox(
                "lamp",
                V3::new(lx - 0.15, 0.25, 5.0 + KERB),
                V3::new(lx + 0.15, 0.9, 5.2 + KERB),
                &metal,
                &[],
            );
            lx += spacing;
        }
    }
    let mut trees = 0;
    if b.chance(0.35) {
        let bark = b.noise("bark", [0.35, 0.28, 0.2], 0.05, 1.0);
        let leaves = b.noise("foliage", [0.25, 0.42, 0.18], 0.12, 1.0);
        for _ in 0..b.int(2, 4) {
            let tx = b.uni(2.0, length - 2.0);
            let th = b.mm(2.2, 3.0);
            let r = b.mm(1.2, 2.0);
            let ty = -rw - 0.8;
            b.cylinder("tree_trunk", V3::new(tx, ty, KERB), th, 0.15, &bark);
            b.sphere(
                "tree_crown",
                V3::new(tx, ty - 0.2, KERB + th + 0.7 * r),
                r,
                &leaves,
            );
            trees += 1;
        }
    }

    // Views.
    let mean_h = rows
        .iter()
        .filter(|r| r.0)
        .map(|r| r.4.height())
        .sum::<f64>()
        / n_north as f64;
    let count = b.int(12, 20);
    let along = count / 7;
    let south_views = if has_south { count / 7 } else { 0 };
    let drone = count / 5;
    let walk = count - along - south_views - drone;
    let rule = ViewRule {
        min_surface: 0.6,
        min_building: 0.3,
        near: 1.0,
        max_near_share: 0.1,
    };
    let y_walk = if has_south {
        -rw - pw2 / 2.0
    } else {
        -rw * 0.75
    };
    b.add_views(walk, &rule, &mut |b, i, attempt| {
        let x = -2.0
            + (length + 4.0) * (i as f64 + 0.5) / walk as f64
            + b.uni(-0.5, 0.5) * attempt as f64;
        let z = if b.chance(0.8) {
            b.uni(1.5, 1.7)
        } else if b.chance(0.5) {
            b.uni(1.0, 1.3)
        } else {
            b.uni(2.5, 3.5)
        };
        let p = V3::new(x, y_walk + b.uni(-0.4, 0.4), z + KERB);
        let yaw = b.uni(-45.0, 45.0).to_radians();
        let dy = pw - p.y;
        let zt = b.uni(1.5, (0.6 * mean_h).max(2.0));
        (p, V3::new(x + dy * yaw.tan(), pw + 0.5, zt))
    });
    b.add_views(along, &rule, &mut |b, _, _| {
        let p = V3::new(
            b.uni(0.0, length),
            b.uni(0.6, pw - 0.6),
            KERB + b.uni(1.5, 1.7),
        );
        let dir = if b.chance(0.5) { 1.0 } else { -1.0 };
        let yaw = b.uni(20.0, 40.0).to_radians();
        let t = p + V3::new(dir * yaw.cos(), yaw.sin(), 0.0) * 10.0;
        (p, V3::new(t.x, t.y, b.uni(2.0, 5.0)))
    });
    b.add_views(south_views, &rule, &mut |b, _, _| {
        let p = V3::new(
            b.uni(0.0, length),
            b.uni(0.6, pw - 0.6),
            KERB + b.uni(1.5, 1.7),
        );
        let t = V3::new(p.x + b.uni(-6.0, 6.0), -rw - pw2, b.uni(2.0, 5.0));
        (p, t)
    });
    b.add_views(drone, &rule, &mut |b, _, _| {
        let p = V3::new(b.uni(0.0, length), -rw - b.uni(2.0, 10.0), b.uni(8.0, 20.0));
        let t = V3::new(
            p.x + b.uni(-5.0, 5.0),
            pw + b.uni(0.0, 4.0),
            b.uni(0.0, 0.6 * mean_h),
        );
        (p, t)
    });
    format!(
        "{n_north} buildings on the north side{}, street {length:.1} m long ({rw:.1} m road, pavements \
         {pw:.1} and {pw2:.1} m); plain render on {:.0} % of the facade area; {} openings, {} balconies, \
         {} canopies, {trees} trees; {count} views ({walk} walking, {along} along the street, \
         {south_views} of the south row, {drone} from a drone)",
        if has_south {
            format!(" and {} on the south side", rows.len() - n_north)
        } else {
            String::new()
        },
        100.0 * painted,
        built.windows,
        built.balconies,
        built.canopies
    )
}
