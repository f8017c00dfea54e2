//! The PLY writers: binary little-endian points (COLMAP's `fused.ply` layout) and meshes.

use super::*;

fn check_len(what: &str, len: usize, n: usize) -> Result<(), PlyError> {
    if len != n {
        return Err(invalid(format!("{n} vertices but {len} {what}")));
    }
    Ok(())
}

fn check_finite(what: &str, v: &[Vector3<f64>]) -> Result<(), PlyError> {
    if let Some(i) = v.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(invalid(format!("{what} {i} is not finite: {:?}", v[i])));
    }
    Ok(())
}

fn push_f32(buf: &mut Vec<u8>, v: &Vector3<f64>) {
    for x in v.iter() {
        buf.extend_from_slice(&(*x as f32).to_le_bytes());
    }
}

fn vertex_header(n: usize, normals: bool, colors: bool) -> String {
    let mut h = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
    );
    if normals {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if colors {
        h.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    h
}

fn write_vertices<W: Write>(
    w: &mut W,
    positions: &[Vector3<f64>],
    normals: Option<&[Vector3<f64>]>,
    colors: Option<&[[u8; 3]]>,
) -> Result<(), PlyError> {
    let mut buf = Vec::with_capacity(27 * 4096);
    for (i, p) in positions.iter().enumerate() {
        push_f32(&mut buf, p);
        if let Some(n) = normals {
            push_f32(&mut buf, &n[i]);
        }
        if let Some(c) = colors {
            buf.extend_from_slice(&c[i]);
        }
        if buf.len() >= 26 * 4096 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)?;
    Ok(())
}

/// Writes a point cloud as binary little-endian PLY (see the module docs for the layout).
pub fn write_ply_points<W: Write>(mut w: W, points: &PlyPoints) -> Result<(), PlyError> {
    let n = points.positions.len();
    check_finite("position", &points.positions)?;
    if let Some(normals) = &points.normals {
        check_len("normals", normals.len(), n)?;
        check_finite("normal", normals)?;
    }
    if let Some(colors) = &points.colors {
        check_len("colours", colors.len(), n)?;
    }
    let mut header = vertex_header(n, points.normals.is_some(), points.colors.is_some());
    header.push_str("end_header\n");
    w.write_all(header.as_bytes())?;
    write_vertices(
        &mut w,
        &points.positions,
        points.normals.as_deref(),
        points.colors.as_deref(),
    )
}

/// Writes a point cloud PLY file atomically; errors name the file.
pub fn write_ply_points_path(path: &Path, points: &PlyPoints) -> Result<(), PlyError> {
    write_atomic(path, |w| write_ply_points(w, points)).map_err(|e| e.in_file(path))
}

/// Writes a triangle mesh as binary little-endian PLY (`list uchar int vertex_indices`).
pub fn write_ply_mesh<W: Write>(mut w: W, mesh: &PlyMesh) -> Result<(), PlyError> {
    let n = mesh.vertices.len();
    check_finite("vertex", &mesh.vertices)?;
    if let Some(colors) = &mesh.vertex_colors {
        check_len("vertex colours", colors.len(), n)?;
    }
    if n > i32::MAX as usize {
        return Err(invalid(format!("{n} vertices do not fit PLY int indices")));
    }
    if let Some(i) = mesh
        .faces
        .iter()
        .position(|f| f.iter().any(|&v| v as usize >= n))
    {
        return Err(invalid(format!(
            "face {i} {:?} indexes beyond {n} vertices",
            mesh.faces[i]
        )));
    }
    let mut header = vertex_header(n, false, mesh.vertex_colors.is_some());
    header.push_str(&format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.faces.len()
    ));
    w.write_all(header.as_bytes())?;
    write_vertices(&mut w, &mesh.vertices, None, mesh.vertex_colors.as_deref())?;
    let mut buf = Vec::with_capacity(13 * 4096);
    for f in &mesh.faces {
        buf.push(3u8);
        for &v in f {
            buf.extend_from_slice(&(v as i32).to_le_bytes());
        }
        if buf.len() >= 13 * 4095 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)?;
    Ok(())
}

/// Writes a mesh PLY file atomically; errors name the file.
pub fn write_ply_mesh_path(path: &Path, mesh: &PlyMesh) -> Result<(), PlyError> {
    write_atomic(path, |w| write_ply_mesh(w, mesh)).map_err(|e| e.in_file(path))
}
