//! Past PCL 1.13 / Open3D 0.20 answers on the project's own synthetic clouds
//! (`tests/fixtures/filter/golden.json`), so that plain `cargo test` checks oracle
//! agreement without the oracles installed. Regenerate with
//! `SOFTSENSE_REGEN_GOLDEN=1 cargo test --test oracle golden` (needs both oracles).

use serde_json::Value;
use softsense::features::{estimate_normals, Neighbourhood, NormalParams};
use softsense::filter::*;

#[path = "filter_golden_data.rs"]
pub(crate) mod data;
use data::*;

fn golden() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/filter/golden.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).expect("golden.json")).expect("golden JSON")
}

fn f32s(v: &Value) -> Vec<f32> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number") as f32)
        .collect()
}

#[test]
fn filters_reproduce_stored_pcl_and_open3d_answers_on_synthetic_clouds() {
    let g = golden();
    for (case, &(seed, n)) in g["cases"].as_array().expect("cases").iter().zip(&CASES) {
        assert_eq!(case["seed"].as_u64(), Some(seed));
        let cloud = synthetic_cloud(seed, n);
        let idx = |out: FilterOutput| mask_hex(&out.indices, n);
        let pt = pass_through(
            &cloud,
            &PassThroughParams::new(Field::Z, PASS_Z.0, PASS_Z.1),
        )
        .unwrap();
        assert_eq!(
            idx(pt),
            case["passthrough_pcl"],
            "seed {seed}: pass-through"
        );
        for (mode, key) in [
            (OutlierMode::Pcl, "ror_pcl"),
            (OutlierMode::Open3d, "ror_open3d"),
        ] {
            let p = RadiusOutlierParams {
                radius: ROR.0,
                min_neighbors: ROR.1,
                mode,
                ..Default::default()
            };
            assert_eq!(
                idx(radius_outlier_removal(&cloud, &p).unwrap()),
                case[key],
                "seed {seed}: {key}"
            );
        }
        for (mode, k, key) in [
            (OutlierMode::Pcl, SOR.0, "sor_pcl"),
            (OutlierMode::Open3d, SOR.0 + 1, "sor_open3d"),
        ] {
            let p = StatisticalOutlierParams {
                k,
                std_ratio: SOR.1,
                mode,
                ..Default::default()
            };
            assert_eq!(
                idx(statistical_outlier_removal(&cloud, &p).unwrap()),
                case[key],
                "seed {seed}: {key}"
            );
        }
        // PCL voxel grid: same voxels in the same order, centroids 1e-5 m, colours 1.
        let v = voxel_grid(&cloud, &VoxelGridParams::new(LEAF)).unwrap();
        let (pos, col) = (
            f32s(&case["voxel_pcl"]["xyz"]),
            f32s(&case["voxel_pcl"]["rgb"]),
        );
        assert_eq!(v.cloud.len() * 3, pos.len(), "seed {seed}: PCL voxel count");
        for (k, p) in v.cloud.positions.iter().enumerate() {
            let c = v.cloud.colors.as_ref().unwrap()[k];
            for a in 0..3 {
                assert!(
                    (p[a] - pos[3 * k + a]).abs() <= 1e-5,
                    "seed {seed}: voxel {k}"
                );
                assert!(
                    (c[a] as f32 - col[3 * k + a]).abs() <= 1.0,
                    "seed {seed}: voxel colour {k}"
                );
            }
        }
        // Open3D voxel grid: same count; centroids sorted by (z, y, x) within 1e-5 m.
        let o = voxel_grid(
            &cloud,
            &VoxelGridParams {
                mode: VoxelMode::Open3d,
                ..VoxelGridParams::new(LEAF)
            },
        )
        .unwrap();
        let want = f32s(&case["voxel_open3d"]["xyz_sorted"]);
        let mut ours = o.cloud.positions.clone();
        ours.sort_by(|a, b| (a[2], a[1], a[0]).partial_cmp(&(b[2], b[1], b[0])).unwrap());
        assert_eq!(
            ours.len() * 3,
            want.len(),
            "seed {seed}: Open3D voxel count"
        );
        for (k, p) in ours.iter().enumerate() {
            assert!(
                (0..3).all(|a| (p[a] - want[3 * k + a]).abs() <= 1e-5),
                "seed {seed}: Open3D voxel {k}"
            );
        }
        // PCL normals (k-NN) on the stored points: 1 degree, curvature 1e-4.
        let nrm = estimate_normals(
            &cloud,
            &NormalParams {
                neighbourhood: Neighbourhood::Knn(NORMALS_K),
                ..NormalParams::knn(1)
            },
        )
        .unwrap();
        let want = f32s(&case["normals_pcl"]);
        for i in 0..NORMALS_STORED {
            let (a, w) = (nrm.normals[i], &want[4 * i..4 * i + 4]);
            let dot = a[0] * w[0] + a[1] * w[1] + a[2] * w[2];
            assert!(
                dot > 1.0f32.to_radians().cos(),
                "seed {seed}: normal {i}: {a:?} vs {w:?}"
            );
            assert!(
                (nrm.curvature[i] - w[3]).abs() <= 1e-4,
                "seed {seed}: curvature {i}"
            );
        }
    }
}
