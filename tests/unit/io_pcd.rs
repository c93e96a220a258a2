//! PCD reader and writer: hand-written files in each encoding, round trips, real data.

use proptest::prelude::*;
use softsense::cloud::{PointCloud, Viewpoint};
use softsense::io::pcd::{self, lzf, DataEncoding, PcdError, ScalarType};
use softsense::io::Encoding;

const ENCODINGS: [Encoding; 3] = [
    Encoding::Ascii,
    Encoding::Binary,
    Encoding::BinaryCompressed,
];

fn header(fields: &str, size: &str, ty: &str, count: &str, w: u32, h: u32, data: &str) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\n\
         TYPE {ty}\nCOUNT {count}\nWIDTH {w}\nHEIGHT {h}\nVIEWPOINT 1 2 3 0 1 0 0\nPOINTS {}\nDATA {data}\n",
        w * h
    )
}

/// An organized 3x2 cloud with a NaN point, colour given as a float-typed rgb.
fn organized_ascii() -> String {
    // 4.2108e+06 as f32 has bits 0x4A808080 -> a=0x4A r=0x80 g=0x80 b=0x80.
    header(
        "x y z rgb _ intensity",
        "4 4 4 4 1 4",
        "F F F F U F",
        "1 1 1 1 3 1",
        3,
        2,
        "ascii",
    ) + "0 0 1 4.2108e+06 1 2 3 0.5\n\
           0.1 0 1 4.2108e+06 1 2 3 0.5\n\
           nan nan nan 4.2108e+06 1 2 3 0.5\n\
           \n\
           0 0.1 1 4.2108e+06 1 2 3 0.5\n\
           0.1 0.1 1 4.2108e+06 1 2 3 0.5\n\
           0.2 0.1 1e-30 4.2108e+06 1 2 3 0.5\n"
}

#[test]
fn ascii_organized_cloud_keeps_shape_nan_viewpoint_and_float_rgb() {
    let c = pcd::parse_pcd(organized_ascii().as_bytes()).unwrap();
    assert_eq!((c.width, c.height, c.len()), (3, 2, 6));
    assert!(c.positions[2].iter().all(|v| v.is_nan()));
    assert_eq!(c.positions[1], [0.1, 0.0, 1.0]);
    assert_eq!(c.positions[5][2], 1e-30);
    let bits = 4.2108e+06f32.to_bits();
    let rgb = [(bits >> 16) as u8, (bits >> 8) as u8, bits as u8];
    assert_eq!(c.colors.as_ref().unwrap()[0], rgb);
    assert!(c.alpha.is_none(), "an `rgb` field gives no alpha column");
    assert_eq!(
        c.viewpoint,
        Viewpoint {
            origin: [1.0, 2.0, 3.0],
            orientation: [0.0, 1.0, 0.0, 0.0]
        }
    );
    assert!(c.normals.is_none() && c.labels.is_none());
}

/// Points (r, g, b, a) = (255, 0, 1, 7) as TYPE U rgba, plus normals, curvature, label.
fn full_cloud() -> PointCloud {
    let mut c = PointCloud::from_positions(vec![
        [1.5, -2.25, 1_000.000_06],
        [f32::NAN, f32::NAN, f32::NAN],
        [f32::MIN_POSITIVE, -0.0, 3.0e38],
        [0.1, 0.2, 0.3],
        [1e-7, 123456.79, -5.0],
        [0.0, 0.0, 0.0],
    ]);
    c.width = 3;
    c.height = 2;
    c.colors = Some(vec![
        [255, 0, 1],
        [0, 0, 0],
        [1, 2, 3],
        [4, 5, 6],
        [7, 8, 9],
        [10, 11, 12],
    ]);
    c.alpha = Some(vec![7, 0, 255, 128, 1, 2]);
    c.normals = Some(vec![[0.0, 0.0, 1.0]; 6]);
    c.normals.as_mut().unwrap()[1] = [f32::NAN; 3];
    c.curvature = Some(vec![0.0, f32::NAN, 0.5, 0.25, 1e-9, 1.0]);
    c.labels = Some(vec![0, 1, 2, u32::MAX, 7, 8]);
    c.viewpoint = Viewpoint {
        origin: [0.5, -1.0, 2.0],
        orientation: [0.0, 1.0, 0.0, 0.0],
    };
    c
}

fn assert_bitwise_equal(a: &PointCloud, b: &PointCloud) {
    assert_eq!((a.width, a.height, a.len()), (b.width, b.height, b.len()));
    let bits = |c: &PointCloud| -> Vec<[u32; 3]> {
        c.positions.iter().map(|p| p.map(f32::to_bits)).collect()
    };
    assert_eq!(bits(a), bits(b), "positions differ bitwise");
    assert_eq!(a.colors, b.colors);
    assert_eq!(a.alpha, b.alpha);
    assert_eq!(a.labels, b.labels);
    let nbits = |c: &PointCloud| {
        c.normals
            .as_ref()
            .map(|n| n.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>())
    };
    assert_eq!(nbits(a), nbits(b));
    let cbits = |c: &PointCloud| {
        c.curvature
            .as_ref()
            .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
    };
    assert_eq!(cbits(a), cbits(b));
    assert_eq!(a.viewpoint, b.viewpoint);
}

#[test]
fn every_encoding_round_trips_every_attribute_bitwise() {
    let c = full_cloud();
    for enc in ENCODINGS {
        let bytes = pcd::to_pcd_bytes(&c, enc);
        let back = pcd::parse_pcd(&bytes).unwrap_or_else(|e| panic!("{enc:?}: {e}"));
        assert_bitwise_equal(&c, &back);
    }
}

#[test]
fn writer_header_matches_pcl_layout() {
    let bytes = pcd::to_pcd_bytes(&full_cloud(), Encoding::Binary);
    let text = String::from_utf8_lossy(&bytes[..300]);
    assert!(text.contains(
        "FIELDS x y z rgba normal_x normal_y normal_z curvature label\nSIZE 4 4 4 4 4 4 4 4 4\n\
         TYPE F F F U F F F F U\nCOUNT 1 1 1 1 1 1 1 1 1\nWIDTH 3\nHEIGHT 2\n\
         VIEWPOINT 0.5 -1 2 0 1 0 0\nPOINTS 6\nDATA binary\n"
    ), "{text}");
    // PCL's packing: r=255 g=0 b=1 a=7 -> bytes b g r a.
    let h = pcd::PcdHeader::parse(&bytes).unwrap();
    let first = &bytes[h.data_offset..h.data_offset + 16];
    assert_eq!(&first[12..16], &[1, 0, 255, 7]);
}

#[test]
fn rgb_without_alpha_is_written_with_alpha_255() {
    let mut c = PointCloud::from_positions(vec![[0.0; 3]]);
    c.colors = Some(vec![[255, 0, 1]]);
    let text = String::from_utf8(pcd::to_pcd_bytes(&c, Encoding::Ascii)).unwrap();
    assert!(text.contains("FIELDS x y z rgb\n"));
    assert!(text.ends_with("0 0 0 4294901761\n"), "{text}");
}

#[test]
fn ascii_writer_uses_nan_and_shortest_round_trip_digits() {
    let mut c = PointCloud::from_positions(vec![[f32::NAN, 0.1, 1_000.000_06]]);
    c.viewpoint.origin = [0.1, 0.0, 0.0];
    let text = String::from_utf8(pcd::to_pcd_bytes(&c, Encoding::Ascii)).unwrap();
    assert!(text.ends_with("DATA ascii\nnan 0.1 1000.00006\n"), "{text}");
    assert!(text.contains("VIEWPOINT 0.1 0 0 1 0 0 0\n"));
}

fn le_bytes_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// The same 2-point cloud (x y z rgb(U) label) hand-encoded as binary records.
fn binary_records() -> Vec<u8> {
    let mut body = Vec::new();
    for (p, rgb, label) in [
        ([1.0f32, 2.0, 3.0], 0xFF10_2030u32, 5u32),
        ([f32::NAN, 0.5, -1.0], 0x00AA_BBCC, 6),
    ] {
        body.extend(le_bytes_f32(&p));
        body.extend(rgb.to_le_bytes());
        body.extend([9u8, 9]); // two `_` padding bytes
        body.extend(label.to_le_bytes());
    }
    body
}

fn check_two_points(c: &PointCloud) {
    assert_eq!(c.len(), 2);
    assert_eq!(c.positions[0], [1.0, 2.0, 3.0]);
    assert!(c.positions[1][0].is_nan());
    assert_eq!(
        c.colors.as_ref().unwrap(),
        &vec![[0x10, 0x20, 0x30], [0xAA, 0xBB, 0xCC]]
    );
    assert_eq!(c.alpha.as_ref().unwrap(), &vec![0xFF, 0x00]);
    assert_eq!(c.labels.as_ref().unwrap(), &vec![5, 6]);
}

#[test]
fn binary_records_with_padding_and_label_decode() {
    let mut file = header(
        "x y z rgba _ label",
        "4 4 4 4 1 4",
        "F F F U U U",
        "1 1 1 1 2 1",
        2,
        1,
        "binary",
    )
    .into_bytes();
    file.extend(binary_records());
    check_two_points(&pcd::parse_pcd(&file).unwrap());
}

/// A literal-only LZF stream, independent of our compressor.
fn lzf_literal(data: &[u8]) -> Vec<u8> {
    data.chunks(32)
        .flat_map(|c| std::iter::once((c.len() - 1) as u8).chain(c.iter().copied()))
        .collect()
}

#[test]
fn binary_compressed_is_field_columnar_without_padding_columns() {
    let mut cols = Vec::new();
    cols.extend(le_bytes_f32(&[1.0, f32::NAN])); // x
    cols.extend(le_bytes_f32(&[2.0, 0.5])); // y
    cols.extend(le_bytes_f32(&[3.0, -1.0])); // z
    cols.extend(0xFF10_2030u32.to_le_bytes());
    cols.extend(0x00AA_BBCCu32.to_le_bytes());
    // No column for the `_` padding field: PCL's compressed layout has none.
    cols.extend(5u32.to_le_bytes());
    cols.extend(6u32.to_le_bytes());
    for stream in [lzf_literal(&cols), lzf::compress(&cols)] {
        let mut file = header(
            "x y z rgba _ label",
            "4 4 4 4 1 4",
            "F F F U U U",
            "1 1 1 1 2 1",
            2,
            1,
            "binary_compressed",
        )
        .into_bytes();
        file.extend((stream.len() as u32).to_le_bytes());
        file.extend((cols.len() as u32).to_le_bytes());
        file.extend(stream);
        check_two_points(&pcd::parse_pcd(&file).unwrap());
    }
}

#[test]
fn double_coordinates_and_short_labels_are_converted() {
    let mut file = header(
        "x y z label",
        "8 8 8 2",
        "F F F I",
        "1 1 1 1",
        1,
        1,
        "binary",
    )
    .into_bytes();
    for v in [0.1f64, 1e300, -2.5] {
        file.extend(v.to_le_bytes());
    }
    file.extend((-3i16).to_le_bytes());
    let c = pcd::parse_pcd(&file).unwrap();
    assert_eq!(c.positions[0], [0.1f32, f32::INFINITY, -2.5]);
    assert_eq!(c.labels.unwrap(), vec![(-3i32) as u32]);
}

#[test]
fn integer_coordinates_are_rejected_with_a_typed_error() {
    let file = header("x y z", "4 4 4", "U F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n";
    assert!(matches!(
        pcd::parse_pcd(file.as_bytes()),
        Err(PcdError::BadFieldType { ref field, ty: ScalarType::U32, .. }) if field == "x"
    ));
}

#[test]
fn old_version_header_without_count_or_viewpoint_reads() {
    let file = "VERSION .5\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6";
    let c = pcd::parse_pcd(file.as_bytes()).unwrap();
    assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
    assert_eq!((c.width, c.height), (2, 1));
    assert_eq!(c.viewpoint, Viewpoint::default());
}

#[test]
fn header_reader_lists_unknown_fields_and_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.pcd");
    std::fs::write(&path, organized_ascii()).unwrap();
    let h = pcd::read_pcd_header(&path).unwrap();
    let names: Vec<&str> = h.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "rgb", "_", "intensity"]);
    assert_eq!(h.fields[4].count, 3);
    assert_eq!(h.encoding, DataEncoding::Ascii);
    assert_eq!((h.width, h.height, h.points), (3, 2, 6));
}

#[test]
fn empty_cloud_round_trips_in_every_encoding() {
    let c = PointCloud::from_positions(vec![]);
    for enc in ENCODINGS {
        let back = pcd::parse_pcd(&pcd::to_pcd_bytes(&c, enc)).unwrap();
        assert_eq!(back.len(), 0);
    }
}

#[test]
fn write_cloud_and_read_cloud_go_through_the_file_system() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.pcd");
    let c = full_cloud();
    softsense::io::write_cloud(&path, &c, Encoding::BinaryCompressed).unwrap();
    assert_bitwise_equal(&c, &softsense::io::read_cloud(&path).unwrap());
}

proptest! {
    #[test]
    fn lzf_compress_then_decompress_is_identity(data in prop::collection::vec(prop_oneof![Just(0u8), Just(1), any::<u8>()], 0..3000)) {
        let packed = lzf::compress(&data);
        prop_assert_eq!(lzf::decompress(&packed, data.len()).unwrap(), data);
    }

    #[test]
    fn lzf_round_trips_long_repetitive_runs(byte in any::<u8>(), len in 0usize..20_000, period in 1usize..300) {
        let data: Vec<u8> = (0..len).map(|i| byte.wrapping_add((i % period) as u8)).collect();
        let packed = lzf::compress(&data);
        prop_assert_eq!(lzf::decompress(&packed, data.len()).unwrap(), data);
    }

    #[test]
    fn pcd_round_trip_is_bitwise_for_any_floats(xs in prop::collection::vec(any::<u32>(), 0..60), enc in 0usize..3) {
        let positions: Vec<[f32; 3]> = xs.chunks_exact(3).map(|c| [f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2])]).collect();
        let c = PointCloud::from_positions(positions);
        let back = pcd::parse_pcd(&pcd::to_pcd_bytes(&c, ENCODINGS[enc])).unwrap();
        for (a, b) in c.positions.iter().zip(&back.positions) {
            for k in 0..3 {
                if ENCODINGS[enc] == Encoding::Ascii && a[k].is_nan() {
                    prop_assert!(b[k].is_nan()); // text keeps NaN-ness, not the payload
                } else {
                    prop_assert_eq!(a[k].to_bits(), b[k].to_bits());
                }
            }
        }
    }
}

#[test]
fn every_real_pcd_loads_and_round_trips_losslessly_in_every_encoding() {
    let Some(dir) = crate::common::data_dir("every_real_pcd_round_trips") else {
        return;
    };
    let files = crate::common::pcd_files_under(&dir);
    assert!(
        files.len() >= 20,
        "expected the 23 data files, found {}",
        files.len()
    );
    for path in files {
        let c = pcd::read_pcd(&path).unwrap_or_else(|e| panic!("{e}"));
        let h = pcd::read_pcd_header(&path).unwrap();
        assert_eq!(c.len() as u64, h.points, "{}", path.display());
        assert_eq!((c.width, c.height), (h.width, h.height));
        c.validate().unwrap();
        for enc in ENCODINGS {
            let back = pcd::parse_pcd(&pcd::to_pcd_bytes(&c, enc)).unwrap();
            if enc == Encoding::Ascii {
                let nan_mask = |c: &PointCloud| {
                    c.positions
                        .iter()
                        .map(|p| p.map(f32::is_nan))
                        .collect::<Vec<_>>()
                };
                assert_eq!(nan_mask(&c), nan_mask(&back));
                let mut a = c.clone();
                let mut b = back.clone();
                for p in a.positions.iter_mut().chain(b.positions.iter_mut()) {
                    *p = p.map(|v| if v.is_nan() { f32::NAN } else { v });
                }
                assert_bitwise_equal(&a, &b);
            } else {
                assert_bitwise_equal(&c, &back);
            }
        }
    }
}

#[test]
fn milk_cartoon_has_pcl_shape_and_colours() {
    let Some(path) = crate::common::data_file(
        "milk_cartoon_shape",
        "pcl/milk_cartoon_all_small_clorox.pcd",
    ) else {
        return;
    };
    let c = pcd::read_pcd(&path).unwrap();
    assert_eq!((c.width, c.height, c.len()), (640, 480, 307_200));
    assert!(c.count_finite() > 100_000 && c.count_finite() < 307_200);
    assert!(c.alpha.is_some());
    let colours = c.colors.as_ref().unwrap();
    assert!(colours.iter().any(|rgb| rgb != &[0, 0, 0]));
}

#[test]
fn descriptor_fields_with_large_counts_are_skipped_in_compressed_bodies() {
    // FIELDS x y z fpfh(F4 x 33) intensity(F8) normal_x(only one normal axis: skipped)
    let n = 3usize;
    let mut cols = Vec::new();
    for axis in 0..3 {
        cols.extend(le_bytes_f32(
            &(0..n).map(|i| (i * 3 + axis) as f32).collect::<Vec<_>>(),
        ));
    }
    cols.extend(le_bytes_f32(&vec![7.0; 33 * n]));
    cols.extend((0..n).flat_map(|i| (i as f64).to_le_bytes()));
    cols.extend(le_bytes_f32(&vec![0.5; n]));
    let stream = lzf::compress(&cols);
    let mut file = header(
        "x y z fpfh intensity normal_x",
        "4 4 4 4 8 4",
        "F F F F F F",
        "1 1 1 33 1 1",
        3,
        1,
        "binary_compressed",
    )
    .into_bytes();
    file.extend((stream.len() as u32).to_le_bytes());
    file.extend((cols.len() as u32).to_le_bytes());
    file.extend(stream);
    let c = pcd::parse_pcd(&file).unwrap();
    assert_eq!(
        c.positions,
        vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0], [6.0, 7.0, 8.0]]
    );
    assert!(c.normals.is_none(), "one normal axis alone is not a normal");
    assert_eq!(c.field_names(), ["x", "y", "z"]);
}
