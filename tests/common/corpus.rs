//! The library's reader for each malformed-corpus folder (tests/fixtures/malformed/<format>),
//! shared by the corpus test (integration) and the mutation test (acceptance).

use std::path::Path;

/// The corpus folders with a file reader; `recording_json` is read through a recording
/// folder by the callers.
pub const FILE_FORMATS: [&str; 16] = [
    "pcd_ascii",
    "pcd_binary",
    "pcd_binary_compressed",
    "ply_ascii",
    "ply_binary",
    "xyz",
    "depth_png",
    "color_png",
    "depth_tiff",
    "intrinsics_json",
    "intrinsics_xml",
    "scene_toml",
    "model_toml",
    "vtu",
    "vtk",
    "msh",
];

/// Reads `path` as `format` (a corpus folder name); `Ok(())` or the error's text.
pub fn read_as(format: &str, path: &Path) -> Result<(), String> {
    use softsense::io;
    fn text<T, E: std::fmt::Display>(r: Result<T, E>) -> Result<(), String> {
        r.map(drop).map_err(|e| e.to_string())
    }
    match format {
        "pcd_ascii"
        | "pcd_binary"
        | "pcd_binary_compressed"
        | "ply_ascii"
        | "ply_binary"
        | "xyz" => text(io::read_cloud(path)),
        "depth_png" | "depth_tiff" => text(io::rgbd::read_depth_image(path)),
        "color_png" => text(io::rgbd::read_color_image(path)),
        "intrinsics_json" | "intrinsics_xml" => text(io::intrinsics::read_camera_model(path)),
        "scene_toml" => text(softsense::scene::Scene::load(path)),
        "model_toml" => text(softsense::fem::model::Model::load(path, None)),
        "vtu" | "vtk" | "msh" => text(softsense::fem::meshio::read_mesh(path)),
        other => panic!("no reader for corpus folder {other}"),
    }
}

/// Opens the recording folder `dir` (one whose JSON file a test has replaced) and reads
/// its optional parts.
pub fn open_recording(dir: &Path) -> Result<(), String> {
    let rec = softsense::recording::Recording::open(dir).map_err(|e| e.to_string())?;
    let _ = rec.truth_of(0);
    let _ = rec.inputs_of(0);
    Ok(())
}
