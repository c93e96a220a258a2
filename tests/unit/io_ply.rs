//! PLY reader and writer, and the XYZ text format.

use softsense::cloud::PointCloud;
use softsense::io::ply::{self, PlyError, PlyFormat};
use softsense::io::{xyz, Encoding};

const FORMATS: [PlyFormat; 3] = [
    PlyFormat::Ascii,
    PlyFormat::BinaryLittleEndian,
    PlyFormat::BinaryBigEndian,
];

fn full_cloud() -> PointCloud {
    let mut c =
        PointCloud::from_positions(vec![[0.1, -2.0, 1e-30], [f32::NAN; 3], [3.0e38, 0.0, -0.0]]);
    c.normals = Some(vec![[0.0, 0.0, 1.0], [f32::NAN; 3], [1.0, 0.0, 0.0]]);
    c.colors = Some(vec![[255, 0, 1], [2, 3, 4], [0, 0, 0]]);
    c.alpha = Some(vec![1, 2, 3]);
    c.curvature = Some(vec![0.5, 0.25, 0.0]);
    c.labels = Some(vec![0, 7, u32::MAX]);
    c
}

#[test]
fn every_format_round_trips_every_attribute() {
    let c = full_cloud();
    for f in FORMATS {
        let back =
            ply::parse_ply(&ply::to_ply_bytes_with(&c, f)).unwrap_or_else(|e| panic!("{f:?}: {e}"));
        let bits = |c: &PointCloud| {
            c.positions
                .iter()
                .map(|p| p.map(|v| if v.is_nan() { 0x7fc0_0000 } else { v.to_bits() }))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&c), bits(&back), "{f:?}");
        assert_eq!(c.colors, back.colors);
        assert_eq!(c.alpha, back.alpha);
        assert_eq!(c.labels, back.labels);
        assert_eq!(c.curvature, back.curvature);
        assert_eq!(back.normals.as_ref().unwrap()[2], [1.0, 0.0, 0.0]);
        assert!(back.normals.as_ref().unwrap()[1][0].is_nan());
    }
}

#[test]
fn writer_uses_open3d_property_names() {
    let mut c = PointCloud::from_positions(vec![[1.0, 2.0, 3.0]]);
    c.normals = Some(vec![[0.0, 0.0, 1.0]]);
    c.colors = Some(vec![[10, 20, 30]]);
    let bytes = ply::to_ply_bytes(&c, Encoding::Binary);
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(
        text.contains(
            "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
        ),
        "{text}"
    );
    assert!(bytes.ends_with(&[0, 0, 0x80, 0x3f, 10, 20, 30]));
}

/// A mesh in the style of other tools: double coordinates, float colours, an extra
/// property, a list property on the vertex and a face element after it.
const MESH_ASCII: &str = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info x\r\n\
element vertex 3\nproperty double x\nproperty double y\nproperty double z\n\
property float intensity\nproperty list uchar int tags\nproperty float red\nproperty float green\n\
property float blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
0.1 0.2 0.3 9 2 5 6 1.0 0.5 0\n1 2 3 9 0 0 0 0\n-1 -2 -3 9 1 7 0.2 0.2 0.2\n3 0 1 2\n";

#[test]
fn ascii_mesh_with_lists_float_colours_and_faces_reads_vertices() {
    let c = ply::parse_ply(MESH_ASCII.as_bytes()).unwrap();
    assert_eq!(
        c.positions,
        vec![
            [0.1f64 as f32, 0.2f64 as f32, 0.3f64 as f32],
            [1.0, 2.0, 3.0],
            [-1.0, -2.0, -3.0]
        ]
    );
    assert_eq!(
        c.colors.unwrap(),
        vec![[255, 128, 0], [0, 0, 0], [51, 51, 51]]
    );
    assert!(c.normals.is_none() && c.alpha.is_none());
}

#[test]
fn big_endian_mesh_with_faces_before_vertices_reads() {
    let mut file = b"ply\nformat binary_big_endian 1.0\nelement face 2\nproperty list uchar int vertex_indices\n\
element vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty short extra\nend_header\n".to_vec();
    for face in [[0i32, 1, 1], [1, 0, 0]] {
        file.push(3);
        for v in face {
            file.extend(v.to_be_bytes());
        }
    }
    for (p, extra) in [([1.0f32, 2.0, 3.0], -1i16), ([4.0, 5.0, 6.0], 2)] {
        for v in p {
            file.extend(v.to_be_bytes());
        }
        file.extend(extra.to_be_bytes());
    }
    let c = ply::parse_ply(&file).unwrap();
    assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
}

#[test]
fn missing_z_and_truncated_bodies_are_typed_errors() {
    let no_z = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n";
    assert_eq!(
        ply::parse_ply(no_z.as_bytes()),
        Err(PlyError::MissingProperty { property: "z" })
    );
    let short = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
    assert!(matches!(
        ply::parse_ply(short.as_bytes()),
        Err(PlyError::TooManyElements { .. } | PlyError::Truncated { index: 1, .. })
    ));
    let c = full_cloud();
    let bytes = ply::to_ply_bytes_with(&c, PlyFormat::BinaryLittleEndian);
    assert!(matches!(
        ply::parse_ply(&bytes[..bytes.len() - 1]),
        Err(PlyError::Truncated { index: 2, .. })
    ));
}

#[test]
fn xyz_reads_comments_extra_columns_and_writes_round_trip_text() {
    let c = xyz::parse_xyz(b"# header\n\n0.1 0.2 0.3 255 0 0\n1e-30\t-0 nan\r\n").unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!(c.positions[0], [0.1, 0.2, 0.3]);
    assert!(c.positions[1][2].is_nan());
    let back = xyz::parse_xyz(&xyz::to_xyz_bytes(&c)).unwrap();
    assert_eq!(back.positions[0], c.positions[0]);
    assert_eq!(back.positions[1][0].to_bits(), 1e-30f32.to_bits());
    assert_eq!(back.positions[1][1].to_bits(), (-0.0f32).to_bits());
}

#[test]
fn xyz_rejects_short_rows_and_words() {
    assert_eq!(
        xyz::parse_xyz(b"1 2 3\n4 5\n"),
        Err(xyz::XyzError::TooFewValues { line: 2, found: 2 })
    );
    assert!(matches!(
        xyz::parse_xyz(b"1 two 3\n"),
        Err(xyz::XyzError::NotANumber { line: 1, .. })
    ));
}

#[test]
fn real_clouds_round_trip_through_ply_and_xyz() {
    let Some(path) = crate::common::data_file("real_ply_round_trip", "pcl/colored_cloud.pcd")
    else {
        return;
    };
    let c = softsense::io::pcd::read_pcd(&path).unwrap();
    for f in FORMATS {
        let back = ply::parse_ply(&ply::to_ply_bytes_with(&c, f)).unwrap();
        assert_eq!(back.positions, c.positions);
        assert_eq!(back.colors, c.colors);
        assert_eq!(back.normals, c.normals);
    }
    let back = xyz::parse_xyz(&xyz::to_xyz_bytes(&c)).unwrap();
    assert_eq!(back.positions, c.positions);
}
