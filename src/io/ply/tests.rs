use super::*;
use proptest::prelude::*;

fn sample_points() -> PlyPoints {
    PlyPoints {
        positions: vec![
            Vector3::new(1.5, -2.25, 3.0),
            Vector3::new(0.1f32 as f64, 1e-3f32 as f64, -7.0),
        ],
        normals: Some(vec![
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.6f32 as f64, 0.8f32 as f64, 0.0),
        ]),
        colors: Some(vec![[255, 0, 7], [1, 2, 3]]),
    }
}

fn sample_mesh() -> PlyMesh {
    PlyMesh {
        vertices: vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(1.0, 1.0, 0.0),
            Vector3::new(0.0, 1.0, 0.5),
        ],
        faces: vec![[0, 1, 2], [0, 2, 3]],
        vertex_colors: Some(vec![[9, 8, 7], [6, 5, 4], [3, 2, 1], [0, 0, 0]]),
    }
}

#[test]
fn points_round_trip_exact_and_byte_identical() -> Result<(), PlyError> {
    for normals in [false, true] {
        for colors in [false, true] {
            let mut pts = sample_points();
            if !normals {
                pts.normals = None;
            }
            if !colors {
                pts.colors = None;
            }
            let mut bytes = Vec::new();
            write_ply_points(&mut bytes, &pts)?;
            let back = read_ply_points(&bytes[..])?;
            assert_eq!(back, pts);
            let mut again = Vec::new();
            write_ply_points(&mut again, &back)?;
            assert_eq!(again, bytes);
        }
    }
    Ok(())
}

#[test]
fn header_matches_colmap_fused_layout() -> Result<(), PlyError> {
    let mut bytes = Vec::new();
    write_ply_points(&mut bytes, &sample_points())?;
    let expected = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
        property float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\n\
        property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
    assert!(bytes.starts_with(expected.as_bytes()));
    assert_eq!(bytes.len(), expected.len() + 2 * 27);
    Ok(())
}

#[test]
fn mesh_round_trip() -> Result<(), PlyError> {
    let mesh = sample_mesh();
    let mut bytes = Vec::new();
    write_ply_mesh(&mut bytes, &mesh)?;
    let back = read_ply_mesh(&bytes[..])?;
    assert_eq!(back, mesh);
    let mut again = Vec::new();
    write_ply_mesh(&mut again, &back)?;
    assert_eq!(again, bytes);
    Ok(())
}

#[test]
fn ascii_with_extra_properties_lists_and_quads() -> Result<(), PlyError> {
    let text = "ply\r\nformat ascii 1.0\ncomment hi\nelement vertex 4\n\
        property double x\nproperty int16 y\nproperty float32 z\nproperty uint8 alpha\n\
        property list uint short tags\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
        element face 1\nproperty list uchar uint vertex_index\nproperty float quality\n\
        end_header\n\
        0.5 1 2 255 2 7 8 10 20 30\n1 2 3 0 0 1 2 3\n4 5 6 0 1 -3 4 5 6\n7 8 9 0 0 7 8 9\n\
        4 0 1 2 3 0.5\n";
    let mesh = read_ply_mesh(text.as_bytes())?;
    assert_eq!(mesh.vertices[0], Vector3::new(0.5, 1.0, 2.0));
    assert_eq!(mesh.vertex_colors.as_ref().unwrap()[0], [10, 20, 30]);
    assert_eq!(mesh.vertices[3], Vector3::new(7.0, 8.0, 9.0));
    assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3]]);
    let pts = read_ply_points(text.as_bytes())?;
    assert_eq!(pts.positions.len(), 4);
    assert!(pts.normals.is_none());
    Ok(())
}

#[test]
fn big_endian_and_all_types() -> Result<(), PlyError> {
    let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 1\n\
        property char a\nproperty ushort b\nproperty uint c\nproperty double x\n\
        property int y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
        property float red\nproperty float green\nproperty float blue\nend_header\n"
        .to_vec();
    bytes.push(0xff);
    bytes.extend_from_slice(&7u16.to_be_bytes());
    bytes.extend_from_slice(&9u32.to_be_bytes());
    bytes.extend_from_slice(&(-1.25f64).to_be_bytes());
    bytes.extend_from_slice(&(-3i32).to_be_bytes());
    for v in [0.75f32, 0.0, 1.0, 0.0, 1.0, 0.5, 0.0] {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let pts = read_ply_points(&bytes[..])?;
    assert_eq!(pts.positions, vec![Vector3::new(-1.25, -3.0, 0.75)]);
    assert_eq!(pts.normals, Some(vec![Vector3::new(0.0, 1.0, 0.0)]));
    assert_eq!(pts.colors, Some(vec![[255, 128, 0]]));
    Ok(())
}

#[test]
fn errors_name_line_or_byte() {
    let err = read_ply_points(
        &b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n"[..],
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("line 4") && err.contains("\"flot\""), "{err}");
    let err = read_ply_points(&b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 x 6\n"[..])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("line 9") && err.contains("\"y\" of vertex 1"),
        "{err}"
    );
    let mut bytes = Vec::new();
    write_ply_points(&mut bytes, &sample_points()).unwrap();
    let header = bytes.len() - 2 * 27;
    let err = read_ply_points(&bytes[..bytes.len() - 5])
        .unwrap_err()
        .to_string();
    assert!(err.contains(&format!("byte {}", header + 27 + 20)), "{err}");
    let mut nan = bytes.clone();
    nan[header + 27 + 4..header + 27 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
    let err = read_ply_points(&nan[..]).unwrap_err().to_string();
    assert!(
        err.contains(&format!("byte {}", header + 27)) && err.contains("finite"),
        "{err}"
    );
}

#[test]
fn mesh_index_out_of_range() {
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 0 5\n";
    let err = read_ply_mesh(text.as_bytes()).unwrap_err().to_string();
    assert!(err.contains("line 11") && err.contains("0..1"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    #[test]
    fn mutated_files_never_panic(
        ascii in any::<bool>(),
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in any::<prop::sample::Index>(),
        truncate in any::<bool>(),
    ) {
        let mut bytes = Vec::new();
        if ascii {
            bytes.extend_from_slice(b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int l\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n1 2 3 2 4 5\n4 5 6 0\n3 0 1 1\n");
        } else {
            write_ply_mesh(&mut bytes, &sample_mesh()).unwrap();
        }
        for (at, b) in edits {
            let i = at.index(bytes.len());
            bytes[i] = b;
        }
        if truncate {
            bytes.truncate(cut.index(bytes.len() + 1));
        }
        let _ = read_ply_points(&bytes[..]);
        let _ = read_ply_mesh(&bytes[..]);
    }
}
