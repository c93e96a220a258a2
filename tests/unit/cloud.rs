use softsense::cloud::{complement, remap, CloudError, PointCloud};

#[test]
fn select_carries_every_attribute_in_order() {
    let mut c = PointCloud::from_positions(vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]);
    c.colors = Some(vec![[1, 2, 3], [4, 5, 6], [7, 8, 9]]);
    c.labels = Some(vec![10, 11, 12]);
    let s = c.select(&[2, 0]);
    assert_eq!(s.positions, vec![[2.0, 2.0, 2.0], [0.0, 0.0, 0.0]]);
    assert_eq!(s.colors.unwrap(), vec![[7, 8, 9], [1, 2, 3]]);
    assert_eq!(s.labels.unwrap(), vec![12, 10]);
    assert_eq!((s.width, s.height), (2, 1));
}

#[test]
fn try_select_rejects_out_of_range_indices() {
    let c = PointCloud::from_positions(vec![[0.0; 3]]);
    assert_eq!(
        c.try_select(&[1]).unwrap_err(),
        CloudError::IndexOutOfRange { index: 1, len: 1 }
    );
}

#[test]
fn complement_and_remap_compose() {
    assert_eq!(complement(&[3, 1], 5), vec![0, 2, 4]);
    assert_eq!(remap(&[0, 2, 4], &[2, 0]), vec![4, 0]);
}

#[test]
fn remove_non_finite_keeps_organization_only_when_nothing_is_removed() {
    let mut c = PointCloud::from_positions(vec![[0.0; 3], [1.0; 3], [2.0; 3], [3.0; 3]]);
    c.width = 2;
    c.height = 2;
    let (same, idx) = c.remove_non_finite();
    assert_eq!((same.width, same.height, idx.len()), (2, 2, 4));
    c.positions[1] = [f32::NAN, 0.0, 0.0];
    let (dense, idx) = c.remove_non_finite();
    assert_eq!(idx, vec![0, 2, 3]);
    assert_eq!((dense.width, dense.height), (3, 1));
    assert!(dense.is_dense());
}

#[test]
fn validate_catches_attribute_length_and_organization_mismatch() {
    let mut c = PointCloud::from_positions(vec![[0.0; 3]; 4]);
    assert!(c.validate().is_ok());
    c.height = 3;
    assert!(matches!(
        c.validate(),
        Err(CloudError::BadOrganization { .. })
    ));
    c.height = 1;
    c.colors = Some(vec![[0; 3]; 3]);
    assert!(matches!(
        c.validate(),
        Err(CloudError::LengthMismatch { field: "rgb", .. })
    ));
}

#[test]
fn bounds_ignore_nan_points_and_are_none_for_all_nan() {
    let c = PointCloud::from_positions(vec![[f32::NAN; 3], [1.0, -2.0, 3.0], [-1.0, 2.0, 0.5]]);
    assert_eq!(c.bounds(), Some(([-1.0, -2.0, 0.5], [1.0, 2.0, 3.0])));
    assert_eq!(
        PointCloud::from_positions(vec![[f32::NAN; 3]]).bounds(),
        None
    );
}
