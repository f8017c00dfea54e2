//! Urban buildings for streets and plazas: a shell of walls and a flat roof behind a
//! facade of storeys with windows recessed 0.1–0.3 m (reveals in the wall's finish), shop
//! fronts with signs and canopies, balconies with railings, cornices, and sometimes a top
//! storey set back behind a terrace.

use super::builder::{material, Builder, Frame, Opening, UP};
use crate::synth::spec::TextureKind;

/// What is drawn for a building before its finish is chosen (its facade area decides
/// whether it is painted: see [`super::builder::plain_walls`]).
#[derive(Debug, Clone)]
pub(super) struct Plan {
    pub width: f64,
    pub depth: f64,
    pub storeys: usize,
    pub ground_storey: f64,
    pub storey: f64,
    /// Top storey set back by this much behind a terrace.
    pub setback: Option<f64>,
    pub shop: bool,
    pub balconies: bool,
    pub cornice: bool,
}

impl Plan {
    /// Height of the main block (without a set-back top storey).
    pub fn main_height(&self) -> f64 {
        let upper = self.storeys - 1 - usize::from(self.setback.is_some());
        self.ground_storey + upper as f64 * self.storey
    }

    /// Height to the highest roof.
    pub fn height(&self) -> f64 {
        self.main_height()
            + if self.setback.is_some() {
                self.storey
            } else {
                0.0
            }
    }

    /// Facade area of the main block.
    pub fn facade_area(&self) -> f64 {
        self.width * self.main_height()
    }
}

/// Draws a plan: `storeys` in `lo..=hi`, shops on the ground floor when `shops`.
pub(super) fn plan(
    b: &mut Builder,
    width: f64,
    depth: f64,
    lo: usize,
    hi: usize,
    shops: bool,
) -> Plan {
    let storeys = b.int(lo, hi);
    let ground_storey = b.mm(3.6, 4.5);
    let storey = b.mm(2.8, 3.4);
    let setback = (storeys >= 3 && b.chance(0.25)).then(|| b.mm(1.5, 2.5));
    let shop = shops && b.chance(0.7);
    let balconies = storeys >= 2 && b.chance(0.5);
    let cornice = b.chance(0.5);
    Plan {
        width,
        depth,
        storeys,
        ground_storey,
        storey,
        setback,
        shop,
        balconies,
        cornice,
    }
}

/// Shared materials of a row of buildings.
pub(super) struct Shared {
    pub roof: String,
    pub canopy: String,
    pub rail: String,
    pub trim: String,
}

impl Shared {
    pub fn new(b: &mut Builder) -> Shared {
        let roof = b.noise("roof_gravel", [0.5, 0.49, 0.46], 0.08, 0.9);
        let stripe = b.pick(&[[0.7, 0.15, 0.12], [0.12, 0.35, 0.2], [0.15, 0.2, 0.45]]);
        let mut canopy = material(TextureKind::Stripes, stripe);
        canopy.color2 = Some([0.92, 0.9, 0.85]);
        canopy.scale = 0.5;
        let canopy = b.add_material("canopy", canopy);
        let mut rail = material(TextureKind::Stripes, [0.18, 0.18, 0.2]);
        rail.color2 = Some([0.75, 0.75, 0.72]);
        rail.scale = 0.12;
        let rail = b.add_material("railing", rail);
        let trim_colour = b.tint([0.9, 0.9, 0.87], 0.05);
        let trim = b.paint("trim", trim_colour);
        Shared {
            roof,
            canopy,
            rail,
            trim,
        }
    }
}

/// What was built, for the scene's description.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Built {
    pub windows: usize,
    pub balconies: usize,
    pub canopies: usize,
}

/// Builds `p` with its facade in frame `f` (origin at the facade's bottom-left corner, the
/// building behind it, i.e. at negative `n`), the street level at `z_street`.
pub(super) fn build(
    b: &mut Builder,
    f: &Frame,
    p: &Plan,
    plain: bool,
    z_street: f64,
    shared: &Shared,
) -> Built {
    let mut built = Built::default();
    let wall = if plain {
        let c = b.wall_colour();
        b.paint("render", c)
    } else {
        b.wall_texture(false)
    };
    let glazing = {
        let (pw, ph) = (b.mm(0.4, 0.7), b.mm(0.5, 0.9));
        b.glazing(pw, ph)
    };
    let recess = b.mm(0.1, 0.3);
    let h1 = p.main_height();
    let mut openings = Vec::new();

    // Ground storey: a shop front (door, display windows, sign, canopy) or a door and windows.
    let door_w = b.mm(1.0, 1.4);
    let door_a = b.mm(0.4, (p.width - door_w - 0.4).max(0.41));
    let leaf = b.door();
    let door_top = z_street + b.mm(2.3, 2.6);
    openings.push(Opening {
        a0: door_a,
        a1: door_a + door_w,
        z0: z_street,
        z1: door_top,
        depth: b.mm(0.2, 0.4),
        material: leaf,
    });
    let (mut shop_lo, mut shop_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let display = if p.shop {
        b.posters("display", 0.6, 0.7)
    } else {
        glazing.clone()
    };
    let (z0, z1) = if p.shop {
        (
            z_street + b.mm(0.3, 0.6),
            (z_street + b.mm(2.6, 3.0)).min(p.ground_storey - 0.5),
        )
    } else {
        (
            z_street + b.mm(0.8, 1.0),
            (z_street + b.mm(2.2, 2.6)).min(p.ground_storey - 0.5),
        )
    };
    let mut add_row = |b: &mut Builder, lo: f64, hi: f64, openings: &mut Vec<Opening>| {
        let bays = ((hi - lo) / if p.shop { 3.0 } else { 2.2 }).floor() as usize;
        for i in 0..bays {
            let bay = (hi - lo) / bays as f64;
            let ww = if p.shop {
                bay - 0.5
            } else {
                b.mm(0.9, (bay - 0.7).min(1.6))
            };
            if ww < 0.6 {
                continue;
            }
            let c = lo + bay * (i as f64 + 0.5);
            openings.push(Opening {
                a0: c - ww / 2.0,
                a1: c + ww / 2.0,
                z0,
                z1,
                depth: recess,
                material: display.clone(),
            });
            shop_lo = shop_lo.min(c - ww / 2.0);
            shop_hi = shop_hi.max(c + ww / 2.0);
        }
    };
    add_row(b, 0.2, door_a - 0.3, &mut openings);
    add_row(b, door_a + door_w + 0.3, p.width - 0.2, &mut openings);

    // Upper storeys; balconies in front of some bays (their windows become doors).
    let bays = (p.width / b.uni(2.0, 3.0)).floor().max(1.0) as usize;
    let bay = p.width / bays as f64;
    let ww = b.mm(0.9, (bay - 0.7).clamp(0.91, 1.6));
    let wh = b.mm(1.3, (p.storey - 1.1).clamp(1.31, 1.9));
    let sill = b.mm(0.8, 1.0);
    let pattern = b.int(0, 2); // every bay, every other bay, the middle bay
    let projection = b.mm(0.8, 1.4);
    let upper = p.storeys - 1 - usize::from(p.setback.is_some());
    let mut balcony_at = Vec::new();
    for s in 0..upper {
        let base = p.ground_storey + s as f64 * p.storey;
        for i in 0..bays {
            let c = bay * (i as f64 + 0.5);
            let balcony = p.balconies
                && match pattern {
                    0 => true,
                    1 => i % 2 == 0,
                    _ => i == bays / 2,
                };
            let (z0, z1) = if balcony {
                (base, base + (p.storey - 0.45).min(2.3))
            } else {
                (base + sill, base + sill + wh)
            };
            openings.push(Opening {
                a0: c - ww / 2.0,
                a1: c + ww / 2.0,
                z0,
                z1,
                depth: recess,
                material: glazing.clone(),
            });
            if balcony {
                balcony_at.push((c, base));
            }
        }
    }
    b.wall("facade", f, p.width, h1, &wall, &openings);
    built.windows = openings.len();

    // Shop sign and canopy.
    if p.shop && shop_hi > shop_lo {
        let top = p.ground_storey - 0.1;
        if top - z1 > 0.35 {
            let sign = b.posters("sign", 0.5, 1.0);
            let zc = (z1 + top) / 2.0 + 0.05;
            b.decal(
                "sign",
                f,
                (shop_lo + shop_hi) / 2.0,
                zc,
                shop_hi - shop_lo,
                (top - z1 - 0.1).min(0.7),
                &sign,
            );
        }
        if b.chance(0.4) {
            let cd = b.mm(1.0, 1.8);
            b.solid(
                "canopy",
                f.at(shop_lo - 0.2, cd, z1 + 0.05),
                f.at(shop_hi + 0.2, 0.0, z1 + 0.17),
                &shared.canopy,
                &[],
            );
            built.canopies += 1;
        }
    }
    // Balconies: a slab and three railings.
    let bw = ww + b.mm(0.6, 1.2);
    for &(c, base) in &balcony_at {
        let (a0, a1) = (c - bw / 2.0, c + bw / 2.0);
        b.solid(
            "balcony",
            f.at(a0, projection, base - 0.15),
            f.at(a1, 0.0, base),
            &shared.trim,
            &[],
        );
        b.aabox(
            "railing",
            f.at(a0, projection - 0.04, base),
            f.at(a1, projection, base + 1.0),
            &shared.rail,
            &[],
        );
        b.aabox(
            "railing",
            f.at(a0, 0.0, base),
            f.at(a0 + 0.04, projection - 0.04, base + 1.0),
            &shared.rail,
            &[],
        );
        b.aabox(
            "railing",
            f.at(a1 - 0.04, 0.0, base),
            f.at(a1, projection - 0.04, base + 1.0),
            &shared.rail,
            &[],
        );
        built.balconies += 1;
    }
    if p.cornice {
        let (cp, ch) = (b.mm(0.2, 0.45), b.mm(0.3, 0.5));
        b.aabox(
            "cornice",
            f.at(0.0, cp, h1 - ch),
            f.at(p.width, 0.0, h1),
            &shared.trim,
            &[],
        );
    }

    // The shell: sides, back and roof.
    shell(b, f, p.width, -p.depth, 0.0, 0.0, h1, &wall, &shared.roof);
    if let Some(sb) = p.setback {
        let top_frame = Frame::new(f.at(0.0, -sb, h1), f.along, f.normal);
        let tall = b.mm(1.8, (p.storey - 0.4).min(2.4));
        let panes = (p.width / 2.5).floor().max(1.0) as usize;
        let openings: Vec<Opening> = (0..panes)
            .map(|i| {
                let c = p.width * (i as f64 + 0.5) / panes as f64;
                Opening {
                    a0: c - 0.9,
                    a1: c + 0.9,
                    z0: 0.1,
                    z1: 0.1 + tall,
                    depth: 0.15,
                    material: glazing.clone(),
                }
            })
            .collect();
        b.wall(
            "top_storey",
            &top_frame,
            p.width,
            p.storey,
            &wall,
            &openings,
        );
        shell(
            b,
            &top_frame,
            p.width,
            -(p.depth - sb - 1.0),
            0.0,
            0.0,
            p.storey,
            &wall,
            &shared.roof,
        );
        b.aabox(
            "terrace_rail",
            f.at(0.0, -0.05, h1),
            f.at(p.width, 0.0, h1 + 1.0),
            &shared.rail,
            &[],
        );
    }
    if b.chance(0.4) {
        let (uw, ud, uh) = (b.mm(1.0, 2.5), b.mm(1.0, 2.0), b.mm(0.8, 1.6));
        let a = b.mm(0.5, (p.width - uw - 0.5).max(0.51));
        let (front, depth) = match p.setback {
            Some(sb) => (sb, p.depth - sb - 1.0),
            None => (0.0, p.depth),
        };
        let n = -front - b.mm(0.8, (depth - ud - 0.5).max(0.81));
        let unit = b.noise("rooftop_unit", [0.7, 0.72, 0.74], 0.1, 0.5);
        b.aabox(
            "rooftop_unit",
            f.at(a, n, p.height()),
            f.at(a + uw, n - ud, p.height() + uh),
            &unit,
            &[],
        );
    }
    // The block only: balconies and canopies are solids of their own.
    let lo = f.at(0.0, 0.0, 0.0);
    let hi = f.at(p.width, -p.depth, p.height());
    b.solids.push((lo.inf(&hi), lo.sup(&hi)));
    built
}

/// The closed sides, back and roof of a block behind a facade of `width` in frame `f`,
/// from `n = n_front` back to `n_back`, between heights `z0` and `z1` (frame-local).
#[allow(clippy::too_many_arguments)]
fn shell(
    b: &mut Builder,
    f: &Frame,
    width: f64,
    n_back: f64,
    n_front: f64,
    z0: f64,
    z1: f64,
    wall: &str,
    roof: &str,
) {
    let (nm, zm, depth, height) = (
        (n_front + n_back) / 2.0,
        (z0 + z1) / 2.0,
        n_front - n_back,
        z1 - z0,
    );
    b.quad("side", f.at(0.0, nm, zm), -f.along, UP, depth, height, wall);
    b.quad(
        "side",
        f.at(width, nm, zm),
        f.along,
        UP,
        depth,
        height,
        wall,
    );
    b.quad(
        "back",
        f.at(width / 2.0, n_back, zm),
        -f.normal,
        UP,
        width,
        height,
        wall,
    );
    b.quad(
        "roof",
        f.at(width / 2.0, nm, z1),
        UP,
        f.normal,
        width,
        depth,
        roof,
    );
}
