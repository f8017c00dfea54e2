//! Reading and checking a scene: [`SceneSpec::from_toml_str`] parses the TOML and
//! [`SceneSpec::validate`] checks sizes, counts, finiteness, shapes and material references,
//! each error naming the origin, the line when the text is at hand, and the object, rig or
//! material.

use std::path::Path;

use super::super::SynthError;
use super::{
    check_render_size, polygon_normal, ObjectSpec, RigSpec, SceneSpec, BOX_FACES, MAX_VIEWS,
};

/// 1-based line number of byte offset `pos` in `text`.
pub(crate) fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()[..pos.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Line of the `index`-th `[[header]]` table in `text`, if it can be found.
fn line_of_array_table(text: &str, header: &str, index: usize) -> Option<usize> {
    let want = format!("[[{header}]]");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(&want))
        .nth(index)
        .map(|(i, _)| i + 1)
}

/// Line of the `[materials.name]` table, if it can be found.
fn line_of_material(text: &str, name: &str) -> Option<usize> {
    let want = [
        format!("[materials.{name}]"),
        format!("[materials.\"{name}\"]"),
    ];
    text.lines()
        .position(|l| want.iter().any(|w| l.trim_start().starts_with(w.as_str())))
        .map(|i| i + 1)
}

/// Where a validation problem is, for the error message.
#[derive(Debug, Clone, Copy)]
enum Place<'a> {
    Top,
    Object(usize),
    Rig(usize),
    Material(&'a str),
}

impl SceneSpec {
    /// Parses and validates a scene from TOML text. `origin` names the text in errors (a file
    /// name, or e.g. `"<builtin demo>"`).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<SceneSpec, SynthError> {
        let spec: SceneSpec = toml::from_str(text).map_err(|e| {
            let (line, column) = match e.span() {
                Some(span) => {
                    let line = line_of(text, span.start);
                    let line_start = text[..span.start.min(text.len())]
                        .rfind('\n')
                        .map_or(0, |p| p + 1);
                    (Some(line), Some(span.start - line_start + 1))
                }
                None => (None, None),
            };
            SynthError::Toml {
                origin: origin.to_string(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        spec.validate_with_text(origin, Some(text))?;
        Ok(spec)
    }

    /// Reads, parses and validates a scene file.
    pub fn from_path(path: impl AsRef<Path>) -> Result<SceneSpec, SynthError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SynthError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        SceneSpec::from_toml_str(&text, &path.display().to_string())
    }

    /// Checks sizes, counts, finiteness and material references.
    pub fn validate(&self) -> Result<(), SynthError> {
        self.validate_with_text("<scene>", None)
    }

    fn validate_with_text(&self, origin: &str, text: Option<&str>) -> Result<(), SynthError> {
        let fail = |place: Place, message: String| -> SynthError {
            let (line, prefix) = match place {
                Place::Top => (None, String::new()),
                Place::Object(i) => {
                    let o = &self.objects[i];
                    let label = o.name().map(|n| format!(" {n:?}")).unwrap_or_default();
                    (
                        text.and_then(|t| line_of_array_table(t, "objects", i)),
                        format!("objects[{i}] ({}{label}): ", o.kind()),
                    )
                }
                Place::Rig(i) => (
                    text.and_then(|t| line_of_array_table(t, "rigs", i)),
                    format!("rigs[{i}]: "),
                ),
                Place::Material(name) => (
                    text.and_then(|t| line_of_material(t, name)),
                    format!("materials.{name}: "),
                ),
            };
            SynthError::Invalid {
                origin: origin.to_string(),
                line,
                message: format!("{prefix}{message}"),
            }
        };
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let nonzero = |v: &[f64; 3]| finite(v) && v.iter().map(|x| x * x).sum::<f64>() > 1e-18;

        // Camera.
        let c = &self.camera;
        if c.width == 0 || c.height == 0 {
            return Err(fail(
                Place::Top,
                format!("camera size must be positive, got {}x{}", c.width, c.height),
            ));
        }
        if let Some(f) = c.focal_px {
            if !(f.is_finite() && f > 0.0) {
                return Err(fail(
                    Place::Top,
                    format!("camera.focal_px must be positive, got {f}"),
                ));
            }
        }
        if let Some(h) = c.hfov_deg {
            if !(h.is_finite() && h > 0.0 && h < 179.0) {
                return Err(fail(
                    Place::Top,
                    format!("camera.hfov_deg must be in (0, 179), got {h}"),
                ));
            }
        }
        if !c.radial_k.is_finite() || c.radial_k.abs() > 1.0 {
            return Err(fail(
                Place::Top,
                format!("camera.radial_k must be in [-1, 1], got {}", c.radial_k),
            ));
        }

        // Lighting and render.
        let l = &self.lighting;
        if !nonzero(&l.sun_direction) {
            return Err(fail(
                Place::Top,
                "lighting.sun_direction must be a finite non-zero vector".into(),
            ));
        }
        for (name, v) in [("sun_intensity", l.sun_intensity), ("ambient", l.ambient)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(fail(
                    Place::Top,
                    format!("lighting.{name} must be ≥ 0, got {v}"),
                ));
            }
        }
        check_color(&l.sky_color)
            .map_err(|m| fail(Place::Top, format!("lighting.sky_color {m}")))?;
        let r = &self.render;
        if r.antialias == 0 || r.antialias > 8 {
            return Err(fail(
                Place::Top,
                format!("render.antialias must be 1..=8, got {}", r.antialias),
            ));
        }
        for (name, v, hi) in [
            ("image_noise", r.image_noise, 1.0),
            ("exposure_jitter", r.exposure_jitter, 0.9),
            ("plane_merge_angle_deg", r.plane_merge_angle_deg, 10.0),
            ("plane_merge_distance", r.plane_merge_distance, 1.0),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(fail(
                    Place::Top,
                    format!("render.{name} must be in [0, {hi}], got {v}"),
                ));
            }
        }

        // Sparse.
        let s = &self.sparse;
        if s.min_track < 2 {
            return Err(fail(
                Place::Top,
                format!("sparse.min_track must be ≥ 2, got {}", s.min_track),
            ));
        }
        if s.cell_px == 0 {
            return Err(fail(Place::Top, "sparse.cell_px must be ≥ 1".into()));
        }
        for (name, v, lo, hi) in [
            ("min_corner_response", s.min_corner_response, 0.0, f64::MAX),
            ("min_texture_contrast", s.min_texture_contrast, 0.0, 1.0),
            ("max_view_angle_deg", s.max_view_angle_deg, 1.0, 90.0),
            ("max_scale_ratio", s.max_scale_ratio, 1.0, f64::MAX),
            ("pixel_noise", s.pixel_noise, 0.0, 100.0),
            ("outlier_fraction", s.outlier_fraction, 0.0, 0.9),
            ("normal_noise_deg", s.normal_noise_deg, 0.0, 90.0),
        ] {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(fail(
                    Place::Top,
                    format!("sparse.{name} must be in [{lo}, {hi}], got {v}"),
                ));
            }
        }

        // Materials.
        for (name, m) in &self.materials {
            let place = Place::Material(name);
            check_color(&m.color).map_err(|e| fail(place, format!("color {e}")))?;
            if let Some(c2) = &m.color2 {
                check_color(c2).map_err(|e| fail(place, format!("color2 {e}")))?;
            }
            for (field, v) in [
                ("scale", m.scale),
                ("brick_size[0]", m.brick_size[0]),
                ("brick_size[1]", m.brick_size[1]),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(fail(place, format!("{field} must be positive, got {v}")));
                }
            }
            for (field, v) in [
                ("strength", m.strength),
                ("density", m.density),
                ("row_offset", m.row_offset),
            ] {
                if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                    return Err(fail(place, format!("{field} must be in [0, 1], got {v}")));
                }
            }
            if !(m.mortar.is_finite() && m.mortar >= 0.0) {
                return Err(fail(place, format!("mortar must be ≥ 0, got {}", m.mortar)));
            }
            if m.octaves == 0 || m.octaves > 10 {
                return Err(fail(
                    place,
                    format!("octaves must be 1..=10, got {}", m.octaves),
                ));
            }
        }

        // Objects.
        if self.objects.is_empty() {
            return Err(fail(Place::Top, "the scene has no objects".into()));
        }
        let known = |name: &str| self.materials.contains_key(name);
        let material_list = || {
            let names: Vec<&str> = self.materials.keys().map(String::as_str).collect();
            if names.is_empty() {
                "none are defined".to_string()
            } else {
                format!("known: {}", names.join(", "))
            }
        };
        for (i, o) in self.objects.iter().enumerate() {
            let place = Place::Object(i);
            let check_material = |m: &str| {
                if known(m) {
                    Ok(())
                } else {
                    Err(fail(
                        place,
                        format!("unknown material {m:?} ({})", material_list()),
                    ))
                }
            };
            match o {
                ObjectSpec::Box {
                    material,
                    face_materials,
                    min,
                    max,
                    center,
                    size,
                    rotation_deg,
                    ..
                } => {
                    check_material(material)?;
                    for (face, m) in face_materials {
                        if !BOX_FACES.contains(&face.as_str()) {
                            return Err(fail(
                                place,
                                format!(
                                    "unknown face {face:?} in face_materials (faces: {})",
                                    BOX_FACES.join(", ")
                                ),
                            ));
                        }
                        check_material(m)?;
                    }
                    match (min, max, center, size) {
                        (Some(lo), Some(hi), None, None) => {
                            if !finite(lo) || !finite(hi) {
                                return Err(fail(place, "min/max must be finite".into()));
                            }
                            if (0..3).any(|k| hi[k] <= lo[k]) {
                                return Err(fail(
                                    place,
                                    format!("max {hi:?} must exceed min {lo:?} on every axis"),
                                ));
                            }
                        }
                        (None, None, Some(c), Some(sz)) => {
                            if !finite(c) || !finite(sz) || sz.iter().any(|&v| v <= 0.0) {
                                return Err(fail(
                                    place,
                                    format!("size must be positive and finite, got {sz:?}"),
                                ));
                            }
                        }
                        _ => {
                            return Err(fail(
                                place,
                                "give either min and max, or center and size".into(),
                            ))
                        }
                    }
                    if !finite(rotation_deg) {
                        return Err(fail(place, "rotation_deg must be finite".into()));
                    }
                    if min.is_some() && rotation_deg.iter().any(|&a| a != 0.0) {
                        return Err(fail(
                            place,
                            "rotation_deg needs the center/size form".into(),
                        ));
                    }
                }
                ObjectSpec::Quad {
                    material,
                    center,
                    size,
                    normal,
                    up,
                    ..
                } => {
                    check_material(material)?;
                    if !finite(center) {
                        return Err(fail(place, "center must be finite".into()));
                    }
                    if !(finite(size) && size[0] > 0.0 && size[1] > 0.0) {
                        return Err(fail(place, format!("size must be positive, got {size:?}")));
                    }
                    if !nonzero(normal) {
                        return Err(fail(place, "normal must be a non-zero vector".into()));
                    }
                    if let Some(u) = up {
                        let n = nalgebra::Vector3::from(*normal).normalize();
                        let uv = nalgebra::Vector3::from(*u);
                        if !nonzero(u) || (uv - n * n.dot(&uv)).norm() < 1e-6 * uv.norm() {
                            return Err(fail(
                                place,
                                "up must be non-zero and not parallel to normal".into(),
                            ));
                        }
                    }
                }
                ObjectSpec::Sphere {
                    material,
                    center,
                    radius,
                    ..
                } => {
                    check_material(material)?;
                    if !(finite(center) && radius.is_finite() && *radius > 0.0) {
                        return Err(fail(
                            place,
                            format!("radius must be positive, got {radius}"),
                        ));
                    }
                }
                ObjectSpec::Cylinder {
                    material,
                    base,
                    axis,
                    height,
                    radius,
                    ..
                } => {
                    check_material(material)?;
                    if !finite(base) || !nonzero(axis) {
                        return Err(fail(place, "base must be finite, axis non-zero".into()));
                    }
                    if !(height.is_finite() && *height > 0.0 && radius.is_finite() && *radius > 0.0)
                    {
                        return Err(fail(
                            place,
                            format!("height and radius must be positive, got {height}, {radius}"),
                        ));
                    }
                }
                ObjectSpec::Polygon {
                    material, vertices, ..
                } => {
                    check_material(material)?;
                    if vertices.len() < 3 || !vertices.iter().all(|v| finite(v)) {
                        return Err(fail(
                            place,
                            format!(
                                "vertices must be at least 3 finite points, got {}",
                                vertices.len()
                            ),
                        ));
                    }
                    polygon_normal(vertices).map_err(|m| fail(place, m))?;
                }
            }
        }

        // Rigs.
        if self.rigs.is_empty() {
            return Err(fail(
                Place::Top,
                "no camera rigs: the scene has zero views".into(),
            ));
        }
        let mut views = 0usize;
        for (i, rig) in self.rigs.iter().enumerate() {
            let place = Place::Rig(i);
            let bad = |m: &str| Err(fail(place, m.to_string()));
            let (field, n) = match rig {
                RigSpec::Orbit { count, .. } | RigSpec::Facade { count, .. } => ("count", *count),
                RigSpec::Walk {
                    positions, count, ..
                } if positions.is_empty() => ("count", *count),
                RigSpec::Walk { positions, .. } => ("positions", positions.len()),
                RigSpec::List { views, .. } => ("views", views.len()),
            };
            if n > MAX_VIEWS {
                return bad(&format!(
                    "{field} gives {n} views, over the limit of {MAX_VIEWS} views per scene"
                ));
            }
            views += n;
            if views > MAX_VIEWS {
                return bad(&format!(
                    "{field} brings the scene to {views} views, over the limit of {MAX_VIEWS}"
                ));
            }
            match rig {
                RigSpec::Orbit {
                    center,
                    radius,
                    height,
                    count,
                    look_at,
                    start_deg,
                    arc_deg,
                    up,
                } => {
                    if *count == 0 {
                        return bad("count must be ≥ 1 (zero views)");
                    }
                    if !(radius.is_finite() && *radius > 0.0) {
                        return bad(&format!("radius must be positive, got {radius}"));
                    }
                    if !finite(center)
                        || !height.is_finite()
                        || !start_deg.is_finite()
                        || !arc_deg.is_finite()
                        || !look_at.is_none_or(|t| finite(&t))
                        || !nonzero(up)
                    {
                        return bad("all values must be finite, up non-zero");
                    }
                }
                RigSpec::Walk {
                    positions,
                    targets,
                    path,
                    count,
                    target,
                    up,
                } => {
                    if !nonzero(up) {
                        return bad("up must be non-zero");
                    }
                    let all_finite = positions
                        .iter()
                        .chain(targets)
                        .chain(path)
                        .chain(target)
                        .all(|p| finite(p));
                    if !all_finite {
                        return bad("all points must be finite");
                    }
                    match (positions.is_empty(), path.is_empty()) {
                        (false, true) => {
                            if targets.len() != positions.len() && targets.len() != 1 {
                                return bad(&format!(
                                    "{} positions need as many targets or one, got {}",
                                    positions.len(),
                                    targets.len()
                                ));
                            }
                            for (k, p) in positions.iter().enumerate() {
                                let t = if targets.len() == 1 {
                                    &targets[0]
                                } else {
                                    &targets[k]
                                };
                                if dist2(p, t) < 1e-12 {
                                    return bad(&format!("positions[{k}] equals its target"));
                                }
                            }
                        }
                        (true, false) => {
                            if *count == 0 {
                                return bad("count must be ≥ 1 (zero views)");
                            }
                            match target {
                                None if path.len() < 2 => {
                                    return bad("a path needs ≥ 2 points, or a target");
                                }
                                None if path.windows(2).any(|w| dist2(&w[0], &w[1]) < 1e-12) => {
                                    return bad(
                                        "path has repeated consecutive points (no view direction)",
                                    );
                                }
                                Some(t) if path.iter().any(|p| dist2(p, t) < 1e-12) => {
                                    return bad("a path point equals the target");
                                }
                                _ => {}
                            }
                        }
                        _ => return bad("give either positions (+ targets) or path (+ count)"),
                    }
                }
                RigSpec::Facade {
                    start,
                    end,
                    count,
                    facing,
                    distance,
                    up,
                } => {
                    if *count == 0 {
                        return bad("count must be ≥ 1 (zero views)");
                    }
                    if !finite(start) || !finite(end) || !nonzero(facing) || !nonzero(up) {
                        return bad("start/end must be finite, facing and up non-zero");
                    }
                    if !(distance.is_finite() && *distance > 0.0) {
                        return bad(&format!("distance must be positive, got {distance}"));
                    }
                }
                RigSpec::List { views, up } => {
                    if views.is_empty() {
                        return bad("views is empty (zero views)");
                    }
                    if !nonzero(up) {
                        return bad("up must be non-zero");
                    }
                    for (k, v) in views.iter().enumerate() {
                        if !finite(&v.position) || !finite(&v.target) {
                            return bad(&format!("views[{k}] must be finite"));
                        }
                        let d: f64 = (0..3).map(|a| (v.target[a] - v.position[a]).powi(2)).sum();
                        if d < 1e-12 {
                            return bad(&format!("views[{k}]: target equals position"));
                        }
                    }
                }
            }
        }
        check_render_size(c.width, c.height, views, "camera.").map_err(|m| fail(Place::Top, m))?;
        Ok(())
    }
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum()
}

fn check_color(c: &[f64; 3]) -> Result<(), String> {
    if c.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) {
        Ok(())
    } else {
        Err(format!("must have components in [0, 1], got {c:?}"))
    }
}
