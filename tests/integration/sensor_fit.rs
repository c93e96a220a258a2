//! The sensor-artefact fit (tools/sensor_fit.py) re-run on the Punyo rest frames: its
//! numbers stay in the ranges docs/sensing.md quotes. Needs SOFTSENSE_DATA and python3
//! with numpy and cv2 (skipped, saying why, without either).

use crate::common;

#[test]
fn the_punyo_rest_frame_fit_gives_the_documented_numbers() {
    let test = "the_punyo_rest_frame_fit_gives_the_documented_numbers";
    let data = std::env::var_os("SOFTSENSE_DATA").unwrap_or_default();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("fit.json");
    let args = [
        "--only".as_ref(),
        "punyo".as_ref(),
        "--data".as_ref(),
        data.as_os_str(),
        "--json".as_ref(),
        json.as_os_str(),
    ];
    let tool = "tools/sensor_fit.py";
    if common::run_data_tool(test, "punyo/depth_0060.png", "cv2, numpy", tool, &args).is_none() {
        return;
    }
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let p = &fit["punyo"];
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    let within = |name: &str, v: f64, lo: f64, hi: f64| {
        assert!((lo..=hi).contains(&v), "{name} = {v}, documented {lo}-{hi}");
    };
    for h in p["holes"]["hole_fraction_per_frame"].as_array().unwrap() {
        within("hole fraction", num(h), 0.28, 0.31);
    }
    within("never valid", num(&p["holes"]["never_valid"]), 0.19, 0.20);
    within("flicker", num(&p["holes"]["flicker"]), 0.125, 0.135);
    within(
        "random dropout",
        num(&p["holes"]["random_dropout_far_from_holes"]),
        0.002,
        0.004,
    );
    within(
        "median sigma",
        num(&p["noise"]["sigma_median_m"]),
        40e-6,
        50e-6,
    );
    within("sigma0", num(&p["noise"]["fit_sigma0_m"]), 30e-6, 40e-6);
    within("k", num(&p["noise"]["fit_k_per_m"]), 1.0e-3, 2.0e-3);
    within(
        "one-unit steps",
        num(&p["quantisation"]["step_raw_share"]["1"]),
        0.99,
        1.0,
    );
    let g = &p["generator"];
    within(
        "flying_probability",
        num(&g["flying_probability"]),
        0.13,
        0.18,
    );
    within("flying_spread", num(&g["flying_spread"]), 0.1, 0.3);
    within(
        "edge_hole_probability",
        num(&g["edge_hole_probability"]),
        0.10,
        0.14,
    );
    within(
        "depth_sigma_floor",
        num(&g["depth_sigma_floor"]),
        33e-6,
        39e-6,
    );
}
