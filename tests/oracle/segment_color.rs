//! The colour model's sRGB -> CIELAB against OpenCV's float path
//! (`tools/oracle/opencv_lab.py`) on all 2^24 8-bit colours, within 1 unit per channel.

use crate::common::{self, oracle};
use softsense::segment::color::rgb_to_lab;
use std::process::Command;

/// True when `python3 -c "import cv2"` works; otherwise a SKIPPED line, or a panic with
/// SOFTSENSE_ORACLES=1 (the same policy as `common::oracle::available`).
fn opencv_available(test: &str) -> bool {
    let ok = Command::new(oracle::python())
        .args(["-c", "import cv2"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("SOFTSENSE_ORACLES").is_none_or(|v| v != "1"),
            "{test}: SOFTSENSE_ORACLES=1 but OpenCV (cv2) is not importable"
        );
        common::skipped(
            test,
            "OpenCV is not importable; run tools/oracle/install.sh",
        );
    }
    ok
}

#[test]
fn rgb_to_lab_agrees_with_opencv_float_path_on_all_colours() {
    let test = "rgb_to_lab vs OpenCV";
    if !opencv_available(test) {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let input = dir.path().join("rgb.bin");
    let output = dir.path().join("lab.bin");
    let n = 1usize << 24;
    let mut rgb = Vec::with_capacity(3 * n);
    for c in 0..n as u32 {
        rgb.extend_from_slice(&[(c >> 16) as u8, (c >> 8) as u8, c as u8]);
    }
    std::fs::write(&input, &rgb).expect("write colours");
    let script = common::project_root().join("tools/oracle/opencv_lab.py");
    let out = Command::new(oracle::python())
        .arg(&script)
        .arg(&input)
        .arg(&output)
        .output()
        .expect("run opencv_lab.py");
    assert!(
        out.status.success(),
        "opencv_lab.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&output).expect("read lab");
    assert_eq!(bytes.len(), 12 * n);
    let mut worst = [0f64; 3];
    let mut worst_at = [0u32; 3];
    for c in 0..n {
        let px = [rgb[3 * c], rgb[3 * c + 1], rgb[3 * c + 2]];
        let ours = rgb_to_lab(px);
        for k in 0..3 {
            let o = 12 * c + 4 * k;
            let cv = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
            let d = (ours[k] - cv as f64).abs();
            if d > worst[k] {
                worst[k] = d;
                worst_at[k] = c as u32;
            }
        }
    }
    println!(
        "OpenCV {}: max |ΔL| {:.2e} (at #{:06x}), |Δa| {:.2e} (#{:06x}), |Δb| {:.2e} (#{:06x})",
        String::from_utf8_lossy(&out.stdout).trim(),
        worst[0],
        worst_at[0],
        worst[1],
        worst_at[1],
        worst[2],
        worst_at[2]
    );
    assert!(
        worst.iter().all(|&w| w <= 1.0),
        "max difference {worst:?} > 1"
    );
}
