//! Procedural textures: pure functions of surface coordinates `(s, t)` in metres and a seed,
//! so a surface point has the same albedo in every view and on every thread.

use super::spec::{MaterialSpec, TextureKind};

/// A material ready for evaluation.
#[derive(Debug, Clone)]
pub(crate) struct Material {
    pub kind: TextureKind,
    pub color: [f64; 3],
    pub color2: [f64; 3],
    pub scale: f64,
    pub strength: f64,
    pub octaves: u32,
    pub brick: [f64; 2],
    pub mortar: f64,
    pub row_offset: f64,
    pub density: f64,
    pub seed: u64,
}

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of an integer lattice point, uniform in `[0, 1)`.
#[inline]
fn hash2(ix: i64, iy: i64, seed: u64) -> f64 {
    let h = mix64(seed ^ mix64((ix as u64).wrapping_mul(0x1656_67B1) ^ mix64(iy as u64)));
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Smoothly interpolated value noise in `[0, 1)`, lattice spacing 1.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let (u, v) = (x - fx, y - fy);
    // Quintic fade: C2-continuous, so the image gradient has no lattice seams.
    let fade = |w: f64| w * w * w * (w * (w * 6.0 - 15.0) + 10.0);
    let (a, b) = (fade(u), fade(v));
    let n00 = hash2(ix, iy, seed);
    let n10 = hash2(ix + 1, iy, seed);
    let n01 = hash2(ix, iy + 1, seed);
    let n11 = hash2(ix + 1, iy + 1, seed);
    let top = n00 + (n10 - n00) * a;
    let bottom = n01 + (n11 - n01) * a;
    top + (bottom - top) * b
}

/// Fractal Brownian motion: octaves of value noise, halving amplitude and doubling
/// frequency; normalised to `[0, 1]`.
fn fbm(x: f64, y: f64, octaves: u32, seed: u64) -> f64 {
    let (mut sum, mut amp, mut freq, mut norm) = (0.0, 1.0, 1.0, 0.0);
    for o in 0..octaves {
        sum += amp * value_noise(x * freq, y * freq, seed.wrapping_add(o as u64 * 7919));
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    // Stretch the fBm's narrow distribution around 0.5 so contrast is visible.
    (((sum / norm) - 0.5) * 2.2 + 0.5).clamp(0.0, 1.0)
}

#[inline]
fn lerp3(a: &[f64; 3], b: &[f64; 3], w: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * w,
        a[1] + (b[1] - a[1]) * w,
        a[2] + (b[2] - a[2]) * w,
    ]
}

#[inline]
fn luminance(c: &[f64; 3]) -> f64 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

impl Material {
    /// Builds a material; `seed` decorrelates materials of the same kind.
    pub fn new(spec: &MaterialSpec, seed: u64) -> Material {
        let c = spec.color;
        Material {
            kind: spec.texture,
            color: c,
            color2: spec
                .color2
                .unwrap_or([c[0] * 0.45, c[1] * 0.45, c[2] * 0.45]),
            scale: spec.scale,
            strength: spec.strength,
            octaves: spec.octaves,
            brick: spec.brick_size,
            mortar: spec.mortar,
            row_offset: spec.row_offset,
            density: spec.density,
            seed,
        }
    }

    /// Whether the material has any texture at all.
    pub fn is_plain(&self) -> bool {
        self.kind == TextureKind::Paint || self.strength == 0.0
    }

    /// Albedo (linear RGB in [0, 1]) at surface coordinates `(s, t)` in metres.
    pub fn albedo(&self, s: f64, t: f64) -> [f64; 3] {
        if self.is_plain() {
            return self.color;
        }
        let textured = match self.kind {
            TextureKind::Paint => self.color,
            TextureKind::Noise => {
                let w = fbm(s / self.scale, t / self.scale, self.octaves, self.seed);
                lerp3(&self.color, &self.color2, w)
            }
            TextureKind::Checker => {
                let i = (s / self.scale).floor() as i64 + (t / self.scale).floor() as i64;
                if i.rem_euclid(2) == 0 {
                    self.color
                } else {
                    self.color2
                }
            }
            TextureKind::Stripes => {
                if (s / self.scale).rem_euclid(1.0) < 0.5 {
                    self.color
                } else {
                    self.color2
                }
            }
            TextureKind::Bricks => self.bricks(s, t),
            TextureKind::Posters => self.posters(s, t),
        };
        let c = lerp3(&self.color, &textured, self.strength);
        [
            c[0].clamp(0.0, 1.0),
            c[1].clamp(0.0, 1.0),
            c[2].clamp(0.0, 1.0),
        ]
    }

    fn bricks(&self, s: f64, t: f64) -> [f64; 3] {
        let px = self.brick[0] + self.mortar;
        let py = self.brick[1] + self.mortar;
        let row = (t / py).floor();
        let shift = if (row as i64).rem_euclid(2) == 1 {
            self.row_offset * px
        } else {
            0.0
        };
        let x = s + shift;
        let col = (x / px).floor();
        let (fx, fy) = (x - col * px, t - row * py);
        if fx < self.mortar || fy < self.mortar {
            return self.color2;
        }
        let tint = 0.75 + 0.5 * hash2(col as i64, row as i64, self.seed);
        let grain = 0.85 + 0.3 * fbm(s / 0.03, t / 0.03, 2, self.seed ^ 0xB1);
        let k = tint * grain;
        [self.color[0] * k, self.color[1] * k, self.color[2] * k]
    }

    fn posters(&self, s: f64, t: f64) -> [f64; 3] {
        let (ci, cj) = ((s / self.scale).floor(), (t / self.scale).floor());
        let (i, j) = (ci as i64, cj as i64);
        if hash2(i, j, self.seed) >= self.density {
            return self.color;
        }
        // Poster rectangle inside the cell, margins 8–30 % on each side.
        let h = |k: u64| hash2(i, j, self.seed.wrapping_add(k * 0x9E37));
        let (u, v) = (s / self.scale - ci, t / self.scale - cj);
        let (u0, u1) = (0.08 + 0.22 * h(1), 0.92 - 0.22 * h(2));
        let (v0, v1) = (0.08 + 0.22 * h(3), 0.92 - 0.22 * h(4));
        if u < u0 || u > u1 || v < v0 || v > v1 {
            return self.color;
        }
        let ca = [0.15 + 0.8 * h(5), 0.15 + 0.8 * h(6), 0.15 + 0.8 * h(7)];
        let cb = [0.1 + 0.5 * h(8), 0.1 + 0.5 * h(9), 0.1 + 0.5 * h(10)];
        let feature = self.scale * (0.04 + 0.08 * h(11));
        let w = match (h(12) * 3.0) as u32 {
            0 => fbm(
                s / feature,
                t / feature,
                self.octaves,
                self.seed ^ mix64(i as u64 ^ (j as u64) << 20),
            ),
            1 => {
                let k = (s / feature).floor() as i64 + (t / feature).floor() as i64;
                0.15 + 0.7 * (k.rem_euclid(2) as f64)
                    + 0.15 * value_noise(s / feature * 3.0, t / feature * 3.0, self.seed)
            }
            _ => {
                // A "photo": blobs of noise with a frame.
                let frame = (u - u0).min(u1 - u).min(v - v0).min(v1 - v) < 0.03;
                if frame {
                    0.05
                } else {
                    value_noise(s / (feature * 2.0), t / (feature * 2.0), self.seed ^ 0x51)
                }
            }
        };
        lerp3(&ca, &cb, w)
    }

    /// Largest luminance difference between the albedo at `(s, t)` and at eight points at
    /// distance `radius` and `radius / 2` around it: how much texture a feature detector
    /// working at that scale could see. Exactly 0 for plain paint.
    pub fn contrast(&self, s: f64, t: f64, radius: f64) -> f64 {
        if self.is_plain() {
            return 0.0;
        }
        let c0 = luminance(&self.albedo(s, t));
        let mut best: f64 = 0.0;
        const H: f64 = std::f64::consts::FRAC_1_SQRT_2;
        const DIRS: [(f64, f64); 4] = [(1.0, 0.0), (0.0, 1.0), (H, H), (H, -H)];
        for r in [radius, 0.5 * radius] {
            for (dx, dy) in DIRS {
                for sign in [1.0, -1.0] {
                    let c = luminance(&self.albedo(s + sign * r * dx, t + sign * r * dy));
                    best = best.max((c - c0).abs());
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(kind: TextureKind) -> MaterialSpec {
        MaterialSpec {
            texture: kind,
            color: [0.8, 0.7, 0.6],
            color2: Some([0.2, 0.25, 0.3]),
            scale: 0.2,
            strength: 1.0,
            octaves: 4,
            brick_size: [0.24, 0.08],
            mortar: 0.012,
            row_offset: 0.5,
            density: 0.5,
        }
    }

    #[test]
    fn paint_has_no_contrast_and_textures_do() {
        let paint = Material::new(&spec(TextureKind::Paint), 3);
        assert_eq!(paint.contrast(0.31, 0.77, 0.05), 0.0);
        assert_eq!(paint.albedo(5.0, -2.0), [0.8, 0.7, 0.6]);
        for kind in [
            TextureKind::Noise,
            TextureKind::Checker,
            TextureKind::Bricks,
        ] {
            let m = Material::new(&spec(kind), 3);
            // Average contrast over a grid of points must be clearly non-zero.
            let mut sum = 0.0;
            for i in 0..100 {
                sum += m.contrast(i as f64 * 0.037, i as f64 * 0.071, 0.03);
            }
            assert!(
                sum / 100.0 > 0.03,
                "{kind:?}: mean contrast {}",
                sum / 100.0
            );
        }
        let mut weak = spec(TextureKind::Noise);
        weak.strength = 0.0;
        assert_eq!(Material::new(&weak, 3).contrast(0.2, 0.3, 0.05), 0.0);
    }

    #[test]
    fn posters_cover_about_density_of_cells_and_leave_paint_between() {
        let m = Material::new(&spec(TextureKind::Posters), 11);
        let mut plain = 0;
        let n = 400;
        for i in 0..n {
            let s = (i % 20) as f64 * 0.2 + 0.1;
            let t = (i / 20) as f64 * 0.2 + 0.1;
            if m.albedo(s, t) == m.color {
                plain += 1;
            }
        }
        let frac = 1.0 - plain as f64 / n as f64;
        assert!((0.3..0.7).contains(&frac), "poster fraction {frac}");
    }

    #[test]
    fn noise_is_deterministic_and_seed_dependent() {
        let a = Material::new(&spec(TextureKind::Noise), 1);
        let b = Material::new(&spec(TextureKind::Noise), 2);
        assert_eq!(a.albedo(0.123, 4.56), a.albedo(0.123, 4.56));
        assert_ne!(a.albedo(0.123, 4.56), b.albedo(0.123, 4.56));
    }
}
