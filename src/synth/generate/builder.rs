//! The tools every kind builds with: seeded draws, a palette of real building materials,
//! objects in the scene format, walls with recessed openings, and views kept only when they
//! look at the scene.

use std::collections::BTreeMap;

use nalgebra::Vector3;
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::super::render::build_camera;
use super::super::spec::{
    CameraSpec, LightingSpec, MaterialSpec, ObjectSpec, RenderSpec, RigSpec, SceneSpec, SparseSpec,
    TextureKind, ViewSpec,
};
use super::super::world::World;
use super::super::RenderOptions;
use crate::geometry::{look_at, Camera};

pub(super) type V3 = Vector3<f64>;

/// World up.
pub(super) const UP: V3 = V3::new(0.0, 0.0, 1.0);

/// Rounds a coordinate to 0.1 mm (a colour or an angle to 10⁻⁴): scene.toml stays readable,
/// and geometry drawn on a millimetre grid ([`Builder::mm`]) is kept exactly.
pub(super) fn r4(x: f64) -> f64 {
    let y = (x * 1e4).round() / 1e4;
    if y == 0.0 {
        0.0 // no "-0.0" in the file
    } else {
        y
    }
}

pub(super) fn a3(v: V3) -> [f64; 3] {
    [r4(v.x), r4(v.y), r4(v.z)]
}

fn c3(c: [f64; 3]) -> [f64; 3] {
    c.map(|x| ((x.clamp(0.0, 1.0)) * 1e3).round() / 1e3)
}

/// A material with the scene format's defaults (those of `[materials.NAME]`).
pub(super) fn material(texture: TextureKind, color: [f64; 3]) -> MaterialSpec {
    MaterialSpec {
        texture,
        color: c3(color),
        color2: None,
        scale: 0.2,
        strength: 1.0,
        octaves: 4,
        brick_size: [0.24, 0.08],
        mortar: 0.012,
        row_offset: 0.5,
        density: 0.35,
    }
}

/// What a view must see to be kept (see [`Builder::choose_views`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct ViewRule {
    /// Least share of rays hitting any surface (the rest is sky).
    pub min_surface: f64,
    /// Least share of rays hitting something other than the ground objects.
    pub min_building: f64,
    /// Rays hitting closer than this (metres)…
    pub near: f64,
    /// …may be at most this share: a view is not a close-up of one cabinet.
    pub max_near_share: f64,
}

/// What the probe rays of one view saw.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Probe {
    pub surface: f64,
    pub building: f64,
    pub near: f64,
    pub nonplanar: f64,
}

impl Probe {
    fn passes(&self, r: &ViewRule) -> bool {
        self.surface >= r.min_surface
            && self.building >= r.min_building
            && self.near <= r.max_near_share
    }

    /// How far from passing (for the fallback when no attempt passes): higher is better.
    fn score(&self, r: &ViewRule) -> f64 {
        (self.surface - r.min_surface).min(0.0)
            + (self.building - r.min_building).min(0.0)
            + (r.max_near_share - self.near).min(0.0)
    }
}

/// Probe grid of a view: coarse enough to be cheap, fine enough for shares within a few %.
const PROBE_SIZE: (u32, u32) = (40, 30);
/// Attempts at a view before the best one is taken.
const VIEW_ATTEMPTS: usize = 16;

/// An opening cut into a wall: `a` along the wall from its origin, `z` up from its base,
/// closed `depth` metres behind the wall face by `material` (glass, a door leaf), its four
/// reveals in the wall's material.
#[derive(Debug, Clone)]
pub(super) struct Opening {
    pub a0: f64,
    pub a1: f64,
    pub z0: f64,
    pub z1: f64,
    pub depth: f64,
    pub material: String,
}

/// A vertical wall face: world point of local `(a, n, z)` = `origin + a·along + n·normal +
/// z·up`, `normal` pointing out of the wall towards the viewer.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub origin: V3,
    pub along: V3,
    pub normal: V3,
}

impl Frame {
    pub fn new(origin: V3, along: V3, normal: V3) -> Frame {
        Frame {
            origin,
            along: along.normalize(),
            normal: normal.normalize(),
        }
    }

    pub fn at(&self, a: f64, n: f64, z: f64) -> V3 {
        self.origin + self.along * a + self.normal * n + UP * z
    }
}

/// The scene under construction and the random stream it is drawn from.
pub(super) struct Builder {
    pub spec: SceneSpec,
    pub rng: ChaCha8Rng,
    /// Axis-aligned boxes cameras must stay out of (furniture, pillars, buildings).
    pub solids: Vec<(V3, V3)>,
    /// Object indices that are ground, not building (for [`ViewRule::min_building`]).
    pub ground: Vec<usize>,
    names: BTreeMap<String, usize>,
}

impl Builder {
    pub fn new(spec: SceneSpec, rng: ChaCha8Rng) -> Builder {
        Builder {
            spec,
            rng,
            solids: Vec::new(),
            ground: Vec::new(),
            names: BTreeMap::new(),
        }
    }

    /// The empty scene of a kind: camera, default render and sparse settings.
    pub fn empty_spec(name: String, width: u32, height: u32, hfov_deg: f64) -> SceneSpec {
        SceneSpec {
            name,
            description: String::new(),
            category: String::new(),
            seed: 1,
            camera: CameraSpec {
                width,
                height,
                hfov_deg: Some(r4(hfov_deg)),
                focal_px: None,
                radial_k: 0.0,
            },
            lighting: LightingSpec::default(),
            render: RenderSpec::default(),
            sparse: SparseSpec::default(),
            materials: BTreeMap::new(),
            objects: Vec::new(),
            rigs: Vec::new(),
        }
    }

    // ---- draws -------------------------------------------------------------------------

    /// Uniform in `[lo, hi)` (`lo` when the range is empty).
    pub fn uni(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.rng.random::<f64>()
    }

    /// Uniform in `[lo, hi)` on a millimetre grid: walls drawn this way meet exactly.
    pub fn mm(&mut self, lo: f64, hi: f64) -> f64 {
        (self.uni(lo, hi) * 1e3).round() / 1e3
    }

    /// An integer in `lo..=hi`.
    pub fn int(&mut self, lo: usize, hi: usize) -> usize {
        self.rng.random_range(lo..=hi.max(lo))
    }

    pub fn chance(&mut self, p: f64) -> bool {
        self.rng.random::<f64>() < p
    }

    pub fn pick<T: Clone>(&mut self, items: &[T]) -> T {
        items[self.rng.random_range(0..items.len())].clone()
    }

    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        items.shuffle(&mut self.rng);
    }

    /// A colour near `base` (each channel ± `jitter`).
    pub fn tint(&mut self, base: [f64; 3], jitter: f64) -> [f64; 3] {
        let k = self.uni(-jitter, jitter);
        base.map(|c| (c + k + self.uni(-0.3, 0.3) * jitter).clamp(0.02, 0.98))
    }

    // ---- names and materials -----------------------------------------------------------

    /// `prefix`, then `prefix_2`, `prefix_3`, …: object names stay unique.
    pub fn name(&mut self, prefix: &str) -> String {
        let n = self.names.entry(prefix.to_string()).or_insert(0);
        *n += 1;
        if *n == 1 {
            prefix.to_string()
        } else {
            format!("{prefix}_{n}")
        }
    }

    /// Registers a material under a fresh name built from `prefix`.
    pub fn add_material(&mut self, prefix: &str, m: MaterialSpec) -> String {
        let mut k = self.spec.materials.len();
        let mut name = prefix.to_string();
        while self.spec.materials.contains_key(&name) {
            k += 1;
            name = format!("{prefix}{k}");
        }
        self.spec.materials.insert(name.clone(), m);
        name
    }

    /// Plain paint: the untextured surface most walls and ceilings are.
    pub fn paint(&mut self, prefix: &str, color: [f64; 3]) -> String {
        self.add_material(prefix, material(TextureKind::Paint, color))
    }

    /// A wall paint colour of real rooms and renders: whites, creams, greys, muted pastels.
    pub fn wall_colour(&mut self) -> [f64; 3] {
        let base = self.pick(&[
            [0.92, 0.91, 0.88],
            [0.9, 0.86, 0.76],
            [0.82, 0.84, 0.86],
            [0.86, 0.8, 0.72],
            [0.74, 0.8, 0.74],
            [0.78, 0.82, 0.9],
            [0.9, 0.8, 0.76],
            [0.7, 0.7, 0.68],
        ]);
        self.tint(base, 0.05)
    }

    /// Clay or concrete bricks in running bond.
    pub fn brick(&mut self) -> String {
        let color = self.pick(&[[0.6, 0.3, 0.22], [0.72, 0.58, 0.4], [0.5, 0.46, 0.44]]);
        let color = self.tint(color, 0.06);
        let mut m = material(TextureKind::Bricks, color);
        m.color2 = Some(c3(self.tint([0.72, 0.7, 0.66], 0.08)));
        let w = self.mm(0.21, 0.29);
        m.brick_size = [w, r4(w / 3.1)];
        m.mortar = r4(self.uni(0.008, 0.014));
        self.add_material("brick", m)
    }

    /// Cut stone blocks (ashlar).
    pub fn stone(&mut self) -> String {
        let color = self.tint([0.74, 0.7, 0.62], 0.07);
        let mut m = material(TextureKind::Bricks, color);
        m.color2 = Some(c3(color.map(|c| c * 0.7)));
        let w = self.mm(0.45, 0.9);
        m.brick_size = [w, r4(w * self.uni(0.4, 0.6))];
        m.mortar = r4(self.uni(0.008, 0.015));
        m.row_offset = r4(self.uni(0.3, 0.5));
        self.add_material("stone", m)
    }

    /// Square or oblong tiles (no offset between rows).
    pub fn tiles(&mut self, min: f64, max: f64) -> String {
        let color = self.pick(&[
            [0.85, 0.85, 0.82],
            [0.6, 0.62, 0.64],
            [0.55, 0.42, 0.34],
            [0.45, 0.55, 0.6],
        ]);
        let color = self.tint(color, 0.05);
        let mut m = material(TextureKind::Bricks, color);
        m.color2 = Some(c3(color.map(|c| c * 0.55)));
        let w = self.mm(min, max);
        let h = if self.chance(0.6) {
            w
        } else {
            self.mm(min, max)
        };
        m.brick_size = [w, h];
        m.mortar = r4(self.uni(0.004, 0.01));
        m.row_offset = 0.0;
        self.add_material("tiles", m)
    }

    /// Wood: boards (stripes) or grain (noise).
    pub fn wood(&mut self) -> String {
        let color = self.tint([0.55, 0.38, 0.22], 0.08);
        let dark = color.map(|c| c * 0.6);
        if self.chance(0.5) {
            let mut m = material(TextureKind::Stripes, color);
            m.color2 = Some(c3(dark));
            m.scale = r4(self.uni(0.1, 0.22));
            self.add_material("boards", m)
        } else {
            let mut m = material(TextureKind::Noise, color);
            m.color2 = Some(c3(dark));
            m.scale = r4(self.uni(0.05, 0.12));
            self.add_material("wood", m)
        }
    }

    /// Parquet or plank floor.
    pub fn parquet(&mut self) -> String {
        let color = self.tint([0.62, 0.45, 0.28], 0.07);
        let mut m = material(TextureKind::Bricks, color);
        m.color2 = Some(c3(color.map(|c| c * 0.55)));
        let l = self.mm(0.4, 1.0);
        m.brick_size = [l, r4(self.uni(0.07, 0.15))];
        m.mortar = 0.004;
        m.row_offset = r4(self.uni(0.25, 0.5));
        self.add_material("parquet", m)
    }

    /// Fractal noise between two colours: concrete, carpet, asphalt, gravel, foliage.
    pub fn noise(&mut self, prefix: &str, color: [f64; 3], scale: f64, strength: f64) -> String {
        let color = self.tint(color, 0.04);
        let mut m = material(TextureKind::Noise, color);
        m.color2 = Some(c3(color.map(|c| c * 0.5)));
        m.scale = r4(scale);
        m.strength = r4(strength);
        self.add_material(prefix, m)
    }

    /// Glazing: panes in frames (a window grid: bricks without row offset).
    pub fn glazing(&mut self, pane_w: f64, pane_h: f64) -> String {
        let glass = self.pick(&[[0.3, 0.4, 0.5], [0.2, 0.26, 0.3], [0.45, 0.55, 0.62]]);
        let glass = self.tint(glass, 0.04);
        let frame = self.pick(&[[0.92, 0.92, 0.9], [0.2, 0.2, 0.22], [0.45, 0.3, 0.18]]);
        let mut m = material(TextureKind::Bricks, glass);
        m.color2 = Some(c3(frame));
        m.brick_size = [r4(pane_w), r4(pane_h)];
        m.mortar = r4(self.uni(0.035, 0.07));
        m.row_offset = 0.0;
        self.add_material("glazing", m)
    }

    /// Posters, notices, shop signs and displays: plain ground with textured rectangles.
    pub fn posters(&mut self, prefix: &str, scale: f64, density: f64) -> String {
        let ground = self.wall_colour();
        let mut m = material(TextureKind::Posters, ground);
        m.scale = r4(scale);
        m.density = r4(density);
        self.add_material(prefix, m)
    }

    /// A door leaf: wood, or paint in a strong colour.
    pub fn door(&mut self) -> String {
        if self.chance(0.6) {
            self.wood()
        } else {
            let c = self.pick(&[
                [0.55, 0.12, 0.1],
                [0.12, 0.25, 0.4],
                [0.15, 0.3, 0.2],
                [0.2, 0.2, 0.2],
            ]);
            let c = self.tint(c, 0.04);
            self.paint("door", c)
        }
    }

    /// A textured wall finish: brick, stone, tiles, boards or wallpaper.
    pub fn wall_texture(&mut self, interior: bool) -> String {
        let k = self.int(0, if interior { 4 } else { 3 });
        match k {
            0 => self.brick(),
            1 => self.stone(),
            2 => self.tiles(0.1, 0.3),
            3 => {
                if interior {
                    self.wood()
                } else {
                    self.noise("concrete", [0.66, 0.66, 0.64], 0.25, 0.7)
                }
            }
            _ => {
                let c = self.wall_colour();
                let mut m = material(TextureKind::Noise, c);
                m.color2 = Some(c3(self.wall_colour().map(|x| x * 0.7)));
                m.scale = r4(self.uni(0.03, 0.08));
                m.strength = r4(self.uni(0.6, 1.0));
                self.add_material("wallpaper", m)
            }
        }
    }

    // ---- objects -----------------------------------------------------------------------

    fn push(&mut self, o: ObjectSpec) -> usize {
        self.spec.objects.push(o);
        self.spec.objects.len() - 1
    }

    /// An axis-aligned box between two corners (in any order), with per-face materials.
    pub fn aabox(&mut self, name: &str, p: V3, q: V3, mat: &str, faces: &[(&str, &str)]) -> usize {
        let lo = p.inf(&q);
        let hi = p.sup(&q);
        let name = self.name(name);
        self.push(ObjectSpec::Box {
            name: Some(name),
            material: mat.to_string(),
            face_materials: faces
                .iter()
                .map(|(f, m)| (f.to_string(), m.to_string()))
                .collect(),
            min: Some(a3(lo)),
            max: Some(a3(hi)),
            center: None,
            size: None,
            rotation_deg: [0.0; 3],
            inside: false,
        })
    }

    /// [`Builder::aabox`] that cameras keep out of (with `margin`).
    pub fn solid(&mut self, name: &str, p: V3, q: V3, mat: &str, faces: &[(&str, &str)]) -> usize {
        let i = self.aabox(name, p, q, mat, faces);
        self.solids.push((p.inf(&q), p.sup(&q)));
        i
    }

    /// A box turned `yaw_deg` about the vertical through its centre.
    pub fn turned_box(
        &mut self,
        name: &str,
        center: V3,
        size: V3,
        yaw_deg: f64,
        mat: &str,
    ) -> usize {
        let name = self.name(name);
        let r = (size.x * size.x + size.y * size.y).sqrt() / 2.0;
        self.solids.push((
            center - V3::new(r, r, size.z / 2.0),
            center + V3::new(r, r, size.z / 2.0),
        ));
        self.push(ObjectSpec::Box {
            name: Some(name),
            material: mat.to_string(),
            face_materials: BTreeMap::new(),
            min: None,
            max: None,
            center: Some(a3(center)),
            size: Some(a3(size)),
            rotation_deg: [0.0, 0.0, r4(yaw_deg)],
            inside: false,
        })
    }

    /// A rectangle: `w` across, `h` along `up` (projected into the plane), seen from `normal`.
    #[allow(clippy::too_many_arguments)]
    pub fn quad(
        &mut self,
        name: &str,
        center: V3,
        normal: V3,
        up: V3,
        w: f64,
        h: f64,
        mat: &str,
    ) -> usize {
        let name = self.name(name);
        let n = normal.normalize();
        let up = (up - n * n.dot(&up)).normalize();
        self.push(ObjectSpec::Quad {
            name: Some(name),
            material: mat.to_string(),
            center: a3(center),
            size: [r4(w), r4(h)],
            normal: a3(n),
            up: Some(a3(up)),
            two_sided: false,
        })
    }

    /// A flat convex polygon, vertices counter-clockwise seen from its visible side.
    pub fn polygon(&mut self, name: &str, vertices: &[V3], mat: &str) -> usize {
        let name = self.name(name);
        self.push(ObjectSpec::Polygon {
            name: Some(name),
            material: mat.to_string(),
            vertices: vertices.iter().map(|v| a3(*v)).collect(),
            two_sided: false,
        })
    }

    pub fn sphere(&mut self, name: &str, center: V3, radius: f64, mat: &str) -> usize {
        let name = self.name(name);
        self.solids
            .push((center - V3::repeat(radius), center + V3::repeat(radius)));
        self.push(ObjectSpec::Sphere {
            name: Some(name),
            material: mat.to_string(),
            center: a3(center),
            radius: r4(radius),
        })
    }

    /// An upright cylinder standing on `base`.
    pub fn cylinder(&mut self, name: &str, base: V3, height: f64, radius: f64, mat: &str) -> usize {
        let name = self.name(name);
        self.solids.push((
            base - V3::new(radius, radius, 0.0),
            base + V3::new(radius, radius, height),
        ));
        self.push(ObjectSpec::Cylinder {
            name: Some(name),
            material: mat.to_string(),
            base: a3(base),
            axis: [0.0, 0.0, 1.0],
            height: r4(height),
            radius: r4(radius),
            caps: true,
        })
    }

    /// A horizontal ground rectangle from `lo` to `hi` (x, y) at height `z`, marked ground.
    pub fn ground_rect(
        &mut self,
        name: &str,
        lo: (f64, f64),
        hi: (f64, f64),
        z: f64,
        mat: &str,
    ) -> usize {
        let c = V3::new((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0, z);
        let i = self.quad(name, c, UP, V3::y(), hi.0 - lo.0, hi.1 - lo.1, mat);
        self.ground.push(i);
        i
    }

    /// A decal on a wall face: a `w × h` rectangle centred at local `(a, z)`.
    #[allow(clippy::too_many_arguments)]
    pub fn decal(
        &mut self,
        name: &str,
        f: &Frame,
        a: f64,
        z: f64,
        w: f64,
        h: f64,
        mat: &str,
    ) -> usize {
        self.quad(name, f.at(a, 0.0, z), f.normal, UP, w, h, mat)
    }

    /// A wall face `width × height` in frame `f`, cut by recessed `openings` (which must not
    /// overlap and must lie inside it): rectangles of wall around the openings, and per
    /// opening its closing pane and four reveals. Returns the object indices.
    pub fn wall(
        &mut self,
        name: &str,
        f: &Frame,
        width: f64,
        height: f64,
        mat: &str,
        openings: &[Opening],
    ) -> Vec<usize> {
        let mut out = Vec::new();
        let mut xs = vec![0.0, width];
        let mut zs = vec![0.0, height];
        for o in openings {
            xs.extend([o.a0, o.a1]);
            zs.extend([o.z0, o.z1]);
        }
        for v in [&mut xs, &mut zs] {
            v.sort_by(f64::total_cmp);
            v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        }
        let inside = |a: f64, z: f64| {
            openings
                .iter()
                .any(|o| a > o.a0 && a < o.a1 && z > o.z0 && z < o.z1)
        };
        // Wall cells merged into maximal runs per band, then runs of equal extent stacked:
        // piers between windows become one rectangle each.
        let mut open: Vec<(f64, f64, f64, f64)> = Vec::new(); // (a0, a1, z0, z1)
        let mut done: Vec<(f64, f64, f64, f64)> = Vec::new();
        for zb in zs.windows(2) {
            let zm = 0.5 * (zb[0] + zb[1]);
            let mut runs: Vec<(f64, f64)> = Vec::new();
            for xb in xs.windows(2) {
                if inside(0.5 * (xb[0] + xb[1]), zm) {
                    continue;
                }
                match runs.last_mut() {
                    Some(r) if (r.1 - xb[0]).abs() < 1e-9 => r.1 = xb[1],
                    _ => runs.push((xb[0], xb[1])),
                }
            }
            let mut next = Vec::new();
            for r in runs {
                if let Some(k) = open
                    .iter()
                    .position(|o| (o.0 - r.0).abs() < 1e-9 && (o.1 - r.1).abs() < 1e-9)
                {
                    let mut o = open.swap_remove(k);
                    o.3 = zb[1];
                    next.push(o);
                } else {
                    next.push((r.0, r.1, zb[0], zb[1]));
                }
            }
            done.append(&mut open);
            open = next;
        }
        done.append(&mut open);
        done.sort_by(|p, q| p.2.total_cmp(&q.2).then(p.0.total_cmp(&q.0)));
        for (a0, a1, z0, z1) in done {
            out.push(self.decal(
                name,
                f,
                0.5 * (a0 + a1),
                0.5 * (z0 + z1),
                a1 - a0,
                z1 - z0,
                mat,
            ));
        }
        let reveal = format!("{name}_reveal");
        for o in openings {
            let (am, zm) = (0.5 * (o.a0 + o.a1), 0.5 * (o.z0 + o.z1));
            let (w, h, d) = (o.a1 - o.a0, o.z1 - o.z0, o.depth);
            out.push(self.quad(
                &format!("{name}_opening"),
                f.at(am, -d, zm),
                f.normal,
                UP,
                w,
                h,
                &o.material,
            ));
            out.push(self.quad(&reveal, f.at(o.a0, -d / 2.0, zm), f.along, UP, d, h, mat));
            out.push(self.quad(&reveal, f.at(o.a1, -d / 2.0, zm), -f.along, UP, d, h, mat));
            out.push(self.quad(&reveal, f.at(am, -d / 2.0, o.z0), UP, f.normal, w, d, mat));
            out.push(self.quad(&reveal, f.at(am, -d / 2.0, o.z1), -UP, f.normal, w, d, mat));
        }
        out
    }

    // ---- views -------------------------------------------------------------------------

    /// The scene's camera at the probe size (the renderer's camera, rescaled).
    fn probe_camera(&self) -> Camera {
        let opts = RenderOptions {
            width: Some(PROBE_SIZE.0),
            height: Some(PROBE_SIZE.1),
            seed_override: None,
        };
        build_camera(&self.spec, &opts).expect("the generated camera is valid")
    }

    /// The world as the renderer will see it (objects so far).
    pub fn world(&self) -> World {
        World::build(&self.spec, self.spec.seed)
    }

    /// Casts the probe grid of the view from `eye` towards `target`.
    pub fn probe(&self, world: &World, eye: &V3, target: &V3, near: f64) -> Probe {
        let cam = self.probe_camera();
        let world_from_cam = look_at(eye, target, &UP).rotation.inverse();
        let (mut surface, mut building, mut close, mut nonplanar) = (0, 0, 0, 0);
        for y in 0..cam.height {
            for x in 0..cam.width {
                let dir = world_from_cam * cam.pixel_ray(x, y);
                if let Some(hit) = world.trace(eye, &dir) {
                    surface += 1;
                    let p = &world.prims[hit.prim as usize];
                    if !self.ground.contains(&(p.priority as usize)) {
                        building += 1;
                    }
                    if hit.t < near {
                        close += 1;
                    }
                    if p.plane.is_none() {
                        nonplanar += 1;
                    }
                }
            }
        }
        let n = (cam.width * cam.height) as f64;
        Probe {
            surface: surface as f64 / n,
            building: building as f64 / n,
            near: close as f64 / n,
            nonplanar: nonplanar as f64 / n,
        }
    }

    /// Whether `p` is inside a solid grown by `margin`.
    pub fn in_solid(&self, p: &V3, margin: f64) -> bool {
        self.solids
            .iter()
            .any(|(lo, hi)| (0..3).all(|k| p[k] > lo[k] - margin && p[k] < hi[k] + margin))
    }

    /// Appends a rig of `count` views: view `i` is drawn by `propose(builder, i, attempt)`
    /// (position, target); an attempt is kept when the camera is out of every solid and
    /// the probe passes `rule`, else the next attempt is drawn; after [`VIEW_ATTEMPTS`] the
    /// best attempt is kept. The world is built once, from the objects added so far.
    pub fn add_views(
        &mut self,
        count: usize,
        rule: &ViewRule,
        propose: &mut dyn FnMut(&mut Builder, usize, usize) -> (V3, V3),
    ) {
        let world = self.world();
        let mut views = Vec::with_capacity(count);
        for i in 0..count {
            let mut best: Option<(f64, V3, V3)> = None;
            for attempt in 0..VIEW_ATTEMPTS {
                let (eye, target) = propose(self, i, attempt);
                if (target - eye).norm() < 1e-3 {
                    continue;
                }
                let inside = self.in_solid(&eye, 0.25);
                let p = self.probe(&world, &eye, &target, rule.near);
                if !inside && p.passes(rule) {
                    best = Some((f64::INFINITY, eye, target));
                    break;
                }
                let score = p.score(rule) - if inside { 10.0 } else { 0.0 };
                if best.as_ref().is_none_or(|b| score > b.0) {
                    best = Some((score, eye, target));
                }
            }
            if let Some((_, eye, target)) = best {
                views.push(ViewSpec {
                    position: a3(eye),
                    target: a3(target),
                });
            }
        }
        if !views.is_empty() {
            self.spec.rigs.push(RigSpec::List {
                views,
                up: [0.0, 0.0, 1.0],
            });
        }
    }

    /// Sun from a random azimuth at `elevation_deg`, with `ambient`.
    pub fn sun(&mut self, elev_lo: f64, elev_hi: f64, ambient: f64, intensity: f64) {
        let az = self.uni(0.0, std::f64::consts::TAU);
        let el = self.uni(elev_lo, elev_hi).to_radians();
        let sky = {
            let w = self.uni(0.0, 1.0);
            let blue = [0.55, 0.7, 0.92];
            let grey = [0.78, 0.8, 0.83];
            [0, 1, 2].map(|k| blue[k] + (grey[k] - blue[k]) * w)
        };
        self.spec.lighting = LightingSpec {
            sun_direction: a3(-V3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())),
            sun_intensity: r4(intensity),
            ambient: r4(ambient),
            sky_color: c3(sky),
        };
    }
}

/// Plain paint covers between these shares of the wall area in every generated scene
/// (when the walls allow it).
pub(super) const PLAIN_SHARE: (f64, f64) = (0.3, 0.7);

/// Splits walls (by area) into plain paint and texture: of the ways to paint some walls
/// and not others (at least one of each when there are two walls or more), the one whose
/// painted share of the area is closest to `target` among those within [`PLAIN_SHARE`] (or
/// closest overall when none is). Up to 16 walls are tried exhaustively, in a random order
/// so that equal walls are picked at random; more walls are assigned greedily. Returns
/// `true` for the painted walls, and the painted share.
pub(super) fn plain_walls(b: &mut Builder, areas: &[f64], target: f64) -> (Vec<bool>, f64) {
    let n = areas.len();
    let total: f64 = areas.iter().sum::<f64>().max(1e-9);
    let mut order: Vec<usize> = (0..n).collect();
    b.shuffle(&mut order);
    let mut plain = vec![false; n];
    if n == 0 {
        return (plain, 0.0);
    }
    if n == 1 {
        plain[0] = true;
        return (plain, 1.0);
    }
    if n <= 16 {
        let mut best: Option<(bool, f64, u32)> = None; // (in range, distance, mask)
        for mask in 1..(1u32 << n) - 1 {
            let share: f64 = (0..n)
                .filter(|k| mask & (1 << k) != 0)
                .map(|k| areas[order[k]])
                .sum::<f64>()
                / total;
            let in_range = share >= PLAIN_SHARE.0 && share <= PLAIN_SHARE.1;
            let dist = (share - target).abs();
            let better = match best {
                None => true,
                Some((r, d, _)) => (in_range && !r) || (in_range == r && dist < d),
            };
            if better {
                best = Some((in_range, dist, mask));
            }
        }
        let mask = best.map_or(1, |b| b.2);
        for k in 0..n {
            plain[order[k]] = mask & (1 << k) != 0;
        }
    } else {
        let mut painted = 0.0;
        for &i in &order {
            if (painted + areas[i] - target * total).abs() < (painted - target * total).abs() {
                plain[i] = true;
                painted += areas[i];
            }
        }
    }
    let painted: f64 = areas
        .iter()
        .zip(&plain)
        .filter(|(_, &p)| p)
        .map(|(a, _)| a)
        .sum();
    (plain, painted / total)
}
