//! The reference implementation of the Punyo protocol (tools/real/punyo_reference.py) keeps
//! the numbers docs/real-data.md quotes. Needs SOFTSENSE_DATA and python3 with numpy, scipy
//! and cv2 (skipped, saying why, without either).

use crate::common;

#[test]
fn the_punyo_reference_protocol_gives_the_documented_numbers() {
    let test = "the_punyo_reference_protocol_gives_the_documented_numbers";
    let dir = tempfile::tempdir().unwrap();
    let tool = "tools/real/punyo_reference.py";
    let args = [dir.path().as_os_str()];
    if common::run_data_tool(test, "punyo/frames.json", "cv2, numpy, scipy", tool, &args).is_none()
    {
        return;
    }
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let frames = summary["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 150, "one entry per frame");
    let get = |f: usize, key: &str| frames[f][key].as_f64().unwrap();
    assert_eq!(
        summary["stiffness"]["tension_n_per_m"].as_f64(),
        Some(400.0)
    );
    let plateau: Vec<usize> = (76..=100).collect();
    let mean = |key: &str| plateau.iter().map(|&f| get(f, key)).sum::<f64>() / 25.0;
    let rel = mean("magnitude") / mean("measured") - 1.0;
    assert!(
        (-0.02..=0.0).contains(&rel),
        "plateau mean off by {rel:+.3}, documented -1.1%"
    );
    let worst = plateau
        .iter()
        .map(|&f| (get(f, "magnitude") / get(f, "measured") - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.06,
        "worst plateau frame {worst:.3}, documented 5.7%"
    );
    let covered = (64..=110)
        .filter(|&f| (get(f, "magnitude") - get(f, "measured")).abs() <= 2.0 * get(f, "sigma"))
        .count();
    assert_eq!(covered, 43, "2 sigma covers 43 of 47 frames (91.5%)");
    let rest_high = (0..=60)
        .chain(115..150)
        .filter(|&f| get(f, "magnitude") > 0.5)
        .count();
    assert_eq!(rest_high, 5, "5 of 96 rest frames read above 0.5 N");
}
