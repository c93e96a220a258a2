//! What a bag declares about its cameras, checked before anything is allocated or
//! written: camera infos against their images and the memory budget, their `K` for a
//! usable pinhole, and the frames that came out without any depth.

use super::msg::CameraInfo;
use super::ImportError;
use crate::camera::PinholeIntrinsics;
use crate::io::limits;

fn info_error(topic: &str, reason: String) -> ImportError {
    ImportError::Message {
        what: "sensor_msgs/CameraInfo",
        reason: format!("on {topic}: {reason}"),
    }
}

/// The camera `info` (on `info_topic`) describes for the images of `image_topic`, whose
/// first image is `image_size`; `option` chooses another camera info.
///
/// Refused rather than warned: a camera info whose size is not its images' makes the
/// reprojection allocate what it declares (60000x60000 for an 80x60 image aborted), and
/// one with a non-finite or non-positive focal length gives an `intrinsics.json` that
/// `sense` cannot use, so no usable recording is lost.
pub fn camera(
    info: &CameraInfo,
    info_topic: &str,
    image_topic: &str,
    image_size: [usize; 2],
    option: &str,
) -> Result<PinholeIntrinsics, ImportError> {
    if image_size.contains(&0) {
        return Err(ImportError::Message {
            what: "sensor_msgs/Image",
            reason: format!(
                "on {image_topic}: the first image is {}x{} pixels, with nothing to import: \
                 give the topic of a camera that records images with --depth-topic or \
                 --colour-topic",
                image_size[0], image_size[1]
            ),
        });
    }
    // A camera info of size 0x0 (some drivers leave it unset) takes its image's size.
    let [width, height] = match [info.width as usize, info.height as usize] {
        [0, 0] => image_size,
        size => size,
    };
    if [width, height] != image_size {
        return Err(info_error(
            info_topic,
            format!(
                "says {width}x{height} pixels but the images on {image_topic} are {}x{}: \
                 give the camera info of that camera with {option}, or fix its width and height",
                image_size[0], image_size[1]
            ),
        ));
    }
    // A depth value and an RGB triple per pixel of the written camera.
    limits::check("pixels", (width as u64) * (height as u64), 5)
        .map_err(|e| info_error(info_topic, e.to_string()))?;
    let [fx, fy, cx, cy] = [info.k[0], info.k[4], info.k[2], info.k[5]];
    if !([fx, fy, cx, cy].iter().all(|v| v.is_finite()) && fx > 0.0 && fy > 0.0) {
        return Err(info_error(
            info_topic,
            format!(
                "K gives fx {fx}, fy {fy}, cx {cx}, cy {cy}; they must be finite with fx and fy \
                 positive: calibrate the camera, or give another camera info with {option}"
            ),
        ));
    }
    Ok(PinholeIntrinsics {
        width: width as u32,
        height: height as u32,
        fx,
        fy,
        cx,
        cy,
    })
}

/// The warning naming the written frames without a single valid depth pixel, if any
/// (warned, not refused: the other frames of the recording stay usable).
pub fn no_depth_warning(frames: &[usize], depth_topic: &str) -> Option<String> {
    if frames.is_empty() {
        return None;
    }
    let n: Vec<String> = frames.iter().map(|f| f.to_string()).collect();
    Some(format!(
        "written frames without a valid depth pixel (every pixel 0 after conversion and \
         alignment), in which `sense` finds nothing: frames {} of {depth_topic}; check the \
         depth unit (--depth-unit) and the bag's depth-to-colour transform",
        n.join(", ")
    ))
}
