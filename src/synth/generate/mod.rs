//! Procedural scenes: data planemap was never tuned on.
//!
//! [`generate`] draws a whole scene of a [`Kind`] — geometry, materials, lighting and camera
//! paths — from a ChaCha stream keyed by the kind and a seed, and returns it in the ordinary
//! scene format ([`SceneSpec`], and its TOML text), so it renders, caches and scores exactly
//! like a hand-written scene, and `planemap synth DIR/scene.toml` reproduces it.
//!
//! - [`Kind`]: interiors, halls, streets, pavilions, plazas; what each draws is in its module
//!   (`interior`, `hall`, `street`, `pavilion`, `plaza`) and in `scenes/README.md`.
//! - `builder`: seeded draws, a palette of real building materials (plain paint on 30–70 %
//!   of the wall area, brick, stone, tiles, boards, glazing, posters), walls with recessed
//!   openings, and views kept only when their probe rays see the scene (`ViewRule` checks:
//!   a view looking at sky or into a cabinet is drawn again).
//! - [`split`]: the held-out protocol. Seeds below [`TEST_SEEDS`]`.start` are for
//!   development and tuning; seeds in [`TEST_SEEDS`] are the test split, reported and never
//!   tuned on.

mod builder;
mod buildings;
mod hall;
mod interior;
mod pavilion;
mod plaza;
mod street;

use std::ops::Range;
use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{SceneSpec, SynthError, SynthScene};

/// Bumped whenever the same (kind, seed) would draw a different scene: the version is
/// written into every generated scene's description, so results name the generator that
/// made their scenes. 2: plazas keep placing objects until the non-planar band is reached.
pub const GENERATOR_VERSION: u32 = 2;

/// Seeds of the test split: reported, never tuned on. Seeds below are for development.
pub const TEST_SEEDS: Range<u64> = 1000..2000;

/// The split a seed belongs to: `"development"` (below 1000), `"test"` (1000–1999) or
/// `"reserved"` (from 2000: neither, kept for a later split).
pub fn split(seed: u64) -> &'static str {
    if seed < TEST_SEEDS.start {
        "development"
    } else if TEST_SEEDS.contains(&seed) {
        "test"
    } else {
        "reserved"
    }
}

/// What a generated scene is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Rooms and L-shaped rooms: mezzanines, stairs, beams, cabinets and kitchen units,
    /// doors and windows; a walk at eye height.
    Interior,
    /// A tall atrium: square pillars, galleries at several heights, views looking up and
    /// down from the galleries.
    Hall,
    /// Adjoining facades along a street: setbacks, balconies, canopies, windows recessed
    /// 0.1–0.3 m, pavement and road; walks along the pavements and drone views.
    Street,
    /// Buildings with walls at arbitrary angles and pitched roofs at arbitrary pitches;
    /// orbits at eye height and from a drone.
    Pavilion,
    /// Facades around a square with trees, statues, spheres and columns in front covering
    /// 10–35 % of the pixels.
    Plaza,
}

impl Kind {
    /// Every kind, in report order.
    pub const ALL: [Kind; 5] = [
        Kind::Interior,
        Kind::Hall,
        Kind::Street,
        Kind::Pavilion,
        Kind::Plaza,
    ];

    /// The name used on the command line and in scene names.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Interior => "interior",
            Kind::Hall => "hall",
            Kind::Street => "street",
            Kind::Pavilion => "pavilion",
            Kind::Plaza => "plaza",
        }
    }

    /// Parses a [`Kind::name`].
    pub fn from_name(s: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == s.trim())
    }

    /// The benchmark category of the hand-written scenes this kind resembles.
    pub fn category(self) -> &'static str {
        match self {
            Kind::Interior | Kind::Hall => "manhattan-interior",
            Kind::Street => "manhattan-exterior",
            Kind::Pavilion => "non-manhattan",
            Kind::Plaza => "mixed",
        }
    }

    /// Range of the share of all pixels on ground-truth planes the kind is drawn to have
    /// (the rest is non-planar surface or sky); the tests hold every kind to it.
    pub fn planar_range(self) -> Range<f64> {
        match self {
            Kind::Interior | Kind::Hall => 0.9..1.0001,
            Kind::Street | Kind::Pavilion => 0.55..1.0001,
            Kind::Plaza => 0.3..0.9,
        }
    }

    /// Range of the share of all pixels on non-planar surfaces (trees, statues, spheres,
    /// cylinder sides) the kind is drawn to have.
    pub fn nonplanar_range(self) -> Range<f64> {
        match self {
            Kind::Interior | Kind::Hall => 0.0..0.1,
            Kind::Street | Kind::Pavilion => 0.0..0.15,
            Kind::Plaza => 0.1..0.35,
        }
    }
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Settings of [`generate`] that are not drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GenerateOptions {
    /// Image width in pixels, written into the scene's `[camera]` (default 320).
    pub width: u32,
    /// Image height in pixels (default 240).
    pub height: u32,
}

impl Default for GenerateOptions {
    fn default() -> Self {
        GenerateOptions {
            width: 320,
            height: 240,
        }
    }
}

/// A generated scene: the spec and the TOML text it was parsed back from.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedScene {
    /// The kind.
    pub kind: Kind,
    /// The seed.
    pub seed: u64,
    /// The scene, as parsed from [`GeneratedScene::toml`].
    pub spec: SceneSpec,
    /// `scene.toml`: a comment header (kind, seed, split, generator version, how to
    /// reproduce) and the scene in the ordinary format.
    pub toml: String,
}

impl GeneratedScene {
    /// Writes [`GeneratedScene::toml`] to `path` (atomically).
    pub fn write_toml(&self, path: &Path) -> Result<(), SynthError> {
        crate::io::atomic::write_atomic::<std::io::Error, _>(path, |f| {
            std::io::Write::write_all(f, self.toml.as_bytes())
        })
        .map_err(|e| SynthError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }
}

/// The name of a generated scene: `KIND-SEED` with the seed on four digits.
pub fn scene_name(kind: Kind, seed: u64) -> String {
    format!("{}-{seed:04}", kind.name())
}

/// The random stream of (kind, seed): ChaCha8 keyed by the seed's bytes and the kind's name,
/// so no two kinds share a stream.
fn stream(kind: Kind, seed: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    let name = kind.name().as_bytes();
    key[8..8 + name.len()].copy_from_slice(name);
    ChaCha8Rng::from_seed(key)
}

/// Draws the scene of `kind` and `seed`. The same arguments give the same scene, byte for
/// byte, on every machine and thread count: nothing but the stream is random, and every
/// draw happens in one fixed order.
pub fn generate(
    kind: Kind,
    seed: u64,
    opts: &GenerateOptions,
) -> Result<GeneratedScene, SynthError> {
    let name = scene_name(kind, seed);
    if opts.width == 0 || opts.height == 0 {
        return Err(SynthError::Invalid {
            origin: name,
            line: None,
            message: format!("image size {}x{} must be positive", opts.width, opts.height),
        });
    }
    let mut rng = stream(kind, seed);
    let hfov = 60.0 + 15.0 * rand::Rng::random::<f64>(&mut rng);
    let mut spec = builder::Builder::empty_spec(name.clone(), opts.width, opts.height, hfov);
    spec.category = kind.category().to_string();
    spec.seed = u64::from(rand::Rng::random::<u32>(&mut rng));
    let mut b = builder::Builder::new(spec, rng);
    let what = match kind {
        Kind::Interior => interior::build(&mut b),
        Kind::Hall => hall::build(&mut b),
        Kind::Street => street::build(&mut b),
        Kind::Pavilion => pavilion::build(&mut b),
        Kind::Plaza => plaza::build(&mut b),
    };
    let mut spec = b.spec;
    spec.description = format!(
        "Generated {kind} (generator v{GENERATOR_VERSION}, seed {seed}, {} split): {what}",
        split(seed)
    );
    // Named like the file it becomes (`--width 100000` is refused here, not as "<scene>").
    spec.validate().map_err(|e| match e {
        SynthError::Invalid { line, message, .. } => SynthError::Invalid {
            origin: format!("{name} (generated)"),
            line,
            message,
        },
        e => e,
    })?;
    let body = toml::to_string_pretty(&spec).map_err(|e| SynthError::Invalid {
        origin: name.clone(),
        line: None,
        message: format!("cannot write the generated scene as TOML: {e}"),
    })?;
    let toml = format!(
        "# {name}: a generated {kind} scene (planemap generator v{GENERATOR_VERSION}).\n\
         # Seed {seed} is in the {} split (seeds below {} develop, {}–{} test).\n\
         # Made by `planemap synth --generate {kind} --seed {seed}`; `planemap synth` of this\n\
         # file renders the same workspace. See scenes/README.md, \"Generated scenes\".\n\n{body}",
        split(seed),
        TEST_SEEDS.start,
        TEST_SEEDS.start,
        TEST_SEEDS.end - 1,
    );
    let parsed = SceneSpec::from_toml_str(&toml, &format!("{name}.toml (generated)"))?;
    if parsed != spec {
        return Err(SynthError::Invalid {
            origin: name,
            line: None,
            message: "the generated scene does not survive its TOML round trip".into(),
        });
    }
    Ok(GeneratedScene {
        kind,
        seed,
        spec: parsed,
        toml,
    })
}

/// Figures of a rendered scene that say whether a kind draws what it should.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SceneStats {
    /// Views.
    pub views: usize,
    /// Sparse points.
    pub points: usize,
    /// Share of all pixels showing a surface (the rest is sky).
    pub surface: f64,
    /// Share of all pixels on a ground-truth plane.
    pub planar: f64,
    /// Share of all pixels on a non-planar surface (spheres, cylinder sides).
    pub nonplanar: f64,
    /// Share of all pixels on a surface without texture at the pixel's scale (plain paint;
    /// `gt/texture` = 0 with a depth).
    pub plain: f64,
    /// The smallest share of surface pixels in any one view.
    pub min_view_surface: f64,
}

/// [`SceneStats`] of a rendered scene.
pub fn scene_stats(scene: &SynthScene) -> SceneStats {
    let (mut all, mut surface, mut planar, mut plain) = (0usize, 0usize, 0usize, 0usize);
    let mut min_view = 1.0f64;
    for v in &scene.views {
        let n = v.depth.len();
        let s = v.depth.iter().filter(|&&z| z > 0.0).count();
        all += n;
        surface += s;
        planar += v.plane_id.iter().filter(|&&id| id > 0).count();
        plain += v
            .depth
            .iter()
            .zip(&v.textured)
            .filter(|(&z, &t)| z > 0.0 && !t)
            .count();
        min_view = min_view.min(s as f64 / n.max(1) as f64);
    }
    let all = all.max(1) as f64;
    SceneStats {
        views: scene.views.len(),
        points: scene.cloud.len(),
        surface: surface as f64 / all,
        planar: planar as f64 / all,
        nonplanar: (surface - planar) as f64 / all,
        plain: plain as f64 / all,
        min_view_surface: if scene.views.is_empty() {
            0.0
        } else {
            min_view
        },
    }
}

#[cfg(test)]
mod tests;
