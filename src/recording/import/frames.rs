//! From a bag's messages to frames: choosing the topics, pairing depth with colour,
//! converting pixels and writing the recording (the rules are in the module docs above).

use super::msg::{self, CameraInfo};
use super::{align, checks};
use super::{Bag, BagMessage, ImportError};
use crate::camera::PinholeIntrinsics;
use crate::recording::RecordingWriter;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

const DEPTH_ENCODINGS: &str = "16UC1, mono16, 32FC1";
const COLOUR_ENCODINGS: &str = "rgb8, bgr8, rgba8, bgra8, mono8";

/// How a bag is imported.
#[derive(Clone, Debug, Default)]
pub struct ImportParams {
    /// Depth image topic [default: the one `sensor_msgs/Image` topic with a depth encoding].
    pub depth_topic: Option<String>,
    /// Colour image topic [default: the one with a colour encoding; none: depth only].
    pub colour_topic: Option<String>,
    /// Depth camera's `CameraInfo` topic [default: the one nearest the depth topic's name].
    pub depth_info_topic: Option<String>,
    /// Colour camera's `CameraInfo` topic [default: the one nearest the colour topic's name].
    pub colour_info_topic: Option<String>,
    /// Largest stamp difference of a depth-colour pair, seconds [default: half the median
    /// depth frame period].
    pub pair_tolerance: Option<f64>,
    /// Metres per raw unit of 16-bit depth [default: the RealSense `Depth Units` option,
    /// else 0.001].
    pub depth_unit: Option<f64>,
    /// Metres per written unit for float (`32FC1`) depth [default 0.0001].
    pub float_depth_unit: Option<f64>,
}

/// What an import did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ImportSummary {
    /// The depth topic read.
    pub depth_topic: String,
    /// The colour topic read, if any.
    pub colour_topic: Option<String>,
    /// Depth messages in the bag.
    pub depth_frames: usize,
    /// Colour messages in the bag.
    pub colour_frames: usize,
    /// Frames written.
    pub frames_written: usize,
    /// Frames written with colour.
    pub paired: usize,
    /// Frame numbers of depth frames not written (no colour partner in a coloured bag).
    pub dropped_depth: Vec<usize>,
    /// Colour frames that no depth frame took.
    pub unused_colour: usize,
    /// The pairing tolerance used, seconds.
    pub pair_tolerance: f64,
    /// Metres per unit of the written depth images.
    pub depth_unit: f64,
    /// Whether depth was reprojected into the colour camera.
    pub aligned: bool,
    /// Things the user should know (depth-only recording, guesses made).
    pub warnings: Vec<String>,
}

/// What the first pass learns: topics, stamps, camera infos, the depth unit.
#[derive(Default)]
struct Scan {
    topics: BTreeMap<String, String>,
    encodings: HashMap<String, String>,
    /// Each image topic's first image size.
    sizes: HashMap<String, [usize; 2]>,
    stamps: HashMap<String, Vec<i64>>,
    infos: HashMap<String, CameraInfo>,
    realsense_depth_unit: Option<f32>,
    /// RealSense stream extrinsics (`<stream>/tf/<reference>`), by topic.
    tfs: HashMap<String, msg::Transform>,
}

fn scan(bag: &Bag) -> Result<Scan, ImportError> {
    let wire = bag.wire();
    let mut s = Scan::default();
    bag.for_each(&mut |m: BagMessage<'_>| {
        let ty = m.short_type();
        s.topics.entry(m.topic.to_string()).or_insert(ty.clone());
        match ty.as_str() {
            "sensor_msgs/Image" => {
                let im = msg::image(m.data, wire).map_err(|e| in_topic(m.topic, e))?;
                let size = [im.width as usize, im.height as usize];
                s.sizes.entry(m.topic.into()).or_insert(size);
                s.encodings.entry(m.topic.into()).or_insert(im.encoding);
                s.stamps
                    .entry(m.topic.into())
                    .or_default()
                    .push(im.stamp_ns);
            }
            "sensor_msgs/CameraInfo" if !s.infos.contains_key(m.topic) => {
                let info = msg::camera_info(m.data, wire).map_err(|e| in_topic(m.topic, e))?;
                s.infos.insert(m.topic.into(), info);
            }
            // RealSense: /device_0/sensor_0/option/Depth Units/value, metres per unit.
            "std_msgs/Float32" if m.topic.ends_with("/Depth Units/value") => {
                s.realsense_depth_unit = Some(msg::float32(m.data, wire)?);
            }
            "geometry_msgs/Transform" if m.topic.contains("/tf/") => {
                let t = msg::transform(m.data, wire).map_err(|e| in_topic(m.topic, e))?;
                s.tfs.entry(m.topic.into()).or_insert(t);
            }
            _ => {}
        }
        Ok(())
    })?;
    Ok(s)
}

fn in_topic(topic: &str, e: ImportError) -> ImportError {
    match e {
        ImportError::Message { what, reason } => ImportError::Message {
            what,
            reason: format!("on {topic}: {reason}"),
        },
        e => e,
    }
}

impl Scan {
    fn present(&self) -> Vec<(String, String)> {
        self.topics
            .iter()
            .map(|(a, b)| (a.clone(), b.clone()))
            .collect()
    }

    fn topic_error(&self, problem: String) -> ImportError {
        ImportError::Topic {
            problem,
            present: self.present(),
        }
    }

    /// The image topic `given`, else the one whose encoding is in `encodings`; of several,
    /// those not `mono8`, then the one whose name holds one of `hints`. (A RealSense bag
    /// may hold infrared streams, `mono8` or `mono16`, beside colour and depth.)
    fn image_topic(
        &self,
        given: Option<&str>,
        encodings: &str,
        hints: &[&str],
        kind: &str,
        option: &str,
    ) -> Result<Option<String>, ImportError> {
        if let Some(t) = given {
            if !self.stamps.contains_key(t) {
                return Err(
                    self.topic_error(format!("{option} {t}: no sensor_msgs/Image topic {t}"))
                );
            }
            // A depth topic given for colour (or the reverse) pairs a stream with itself
            // and writes no frame; say so here, naming the encoding.
            let encoding = self.encodings.get(t).map_or("", |e| e.as_str());
            if !encodings.split(", ").any(|x| x == encoding) {
                return Err(self.topic_error(format!(
                    "{option} {t}: its images are `{encoding}`, not a {kind} encoding \
                     ({encodings}): give the {kind} image topic"
                )));
            }
            return Ok(Some(t.to_string()));
        }
        let mut found: Vec<&String> = (self.encodings.iter())
            .filter(|(_, e)| encodings.split(", ").any(|x| x == e.as_str()))
            .map(|(t, _)| t)
            .collect();
        found.sort();
        let narrow = |found: &mut Vec<&String>, keep: &dyn Fn(&str) -> bool, alone: bool| {
            let kept: Vec<&String> = found.iter().copied().filter(|t| keep(t)).collect();
            if found.len() > 1 && !kept.is_empty() && (!alone || kept.len() == 1) {
                *found = kept;
            }
        };
        narrow(&mut found, &|t| self.encodings[t] != "mono8", false);
        let named = |t: &str| hints.iter().any(|h| t.to_ascii_lowercase().contains(h));
        narrow(&mut found, &named, true);
        match found[..] {
            [] => Ok(None),
            [one] => Ok(Some(one.clone())),
            _ => Err(self.topic_error(format!(
                "several {kind} image topics ({}): choose one with {option}",
                found
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        }
    }

    /// The camera info `given`, else the one sharing the longest name prefix with `image`.
    fn info_topic(
        &self,
        given: Option<&str>,
        image: &str,
        option: &str,
    ) -> Result<(&str, &CameraInfo), ImportError> {
        if let Some(t) = given {
            return (self.infos.get_key_value(t))
                .map(|(t, i)| (t.as_str(), i))
                .ok_or_else(|| self.topic_error(format!("no sensor_msgs/CameraInfo topic {t}")));
        }
        let common = |t: &str| {
            t.bytes()
                .zip(image.bytes())
                .take_while(|(a, b)| a == b)
                .count()
        };
        let best = self
            .infos
            .iter()
            .max_by_key(|(t, _)| (common(t), std::cmp::Reverse(t.to_string())));
        best.map(|(t, i)| (t.as_str(), i)).ok_or_else(|| {
            self.topic_error(format!(
                "no sensor_msgs/CameraInfo for {image} (the intrinsics): give {option}"
            ))
        })
    }
}

/// The median difference of consecutive sorted stamps, nanoseconds.
fn median_period(stamps: &[i64]) -> Option<i64> {
    let mut s = stamps.to_vec();
    s.sort_unstable();
    let mut d: Vec<i64> = s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d > 0)
        .collect();
    d.sort_unstable();
    d.get(d.len() / 2).copied()
}

/// For each depth message (file order), its partner colour message (file order), if any.
/// Each depth frame takes the nearest colour stamp within `tolerance_ns`; a colour frame
/// claimed twice goes to the nearer depth frame (the earlier on a tie).
pub fn pair(depth: &[i64], colour: &[i64], tolerance_ns: i64) -> Vec<Option<usize>> {
    let mut order: Vec<usize> = (0..colour.len()).collect();
    order.sort_by_key(|&j| colour[j]);
    let nearest = |t: i64| -> Option<(usize, i64)> {
        let k = order.partition_point(|&j| colour[j] < t);
        let cands = [k.checked_sub(1), Some(k)].into_iter().flatten();
        let cands = cands
            .filter_map(|k| order.get(k))
            .map(|&j| (j, (colour[j] - t).abs()));
        cands
            .min_by_key(|&(_, d)| d)
            .filter(|&(_, d)| d <= tolerance_ns)
    };
    let claims: Vec<Option<(usize, i64)>> = depth.iter().map(|&t| nearest(t)).collect();
    let mut winner: HashMap<usize, (i64, usize)> = HashMap::new();
    for (i, c) in claims.iter().enumerate() {
        if let Some((j, d)) = *c {
            let w = winner.entry(j).or_insert((d, i));
            if d < w.0 {
                *w = (d, i);
            }
        }
    }
    (claims.iter().enumerate())
        .map(|(i, c)| c.and_then(|(j, _)| (winner[&j].1 == i).then_some(j)))
        .collect()
}

/// The metres-per-unit of a RealSense Float32 option as the decimal it was meant to be
/// (0.001f32 is 0.0010000000475; its shortest decimal, 0.001, gives a depth scale of
/// exactly 1000).
fn decimal_of(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(f64::from(v))
}

/// Refuses rows shorter than `width` pixels of `bytes` bytes.
fn check_step(im: &msg::Image<'_>, topic: &str, bytes: usize) -> Result<(), ImportError> {
    match (im.step as usize) < im.width as usize * bytes {
        true => Err(image_error(
            topic,
            format!(
                "{} bytes per row for {} {} pixels",
                im.step, im.width, im.encoding
            ),
        )),
        false => Ok(()),
    }
}

fn image_error(topic: &str, reason: String) -> ImportError {
    ImportError::Message {
        what: "sensor_msgs/Image",
        reason: format!("on {topic}: {reason}"),
    }
}

/// Refuses an image whose size is not its camera's.
fn check_size(im: &msg::Image<'_>, topic: &str, [w, h]: [usize; 2]) -> Result<(), ImportError> {
    match [im.width as usize, im.height as usize] == [w, h] {
        true => Ok(()),
        false => Err(image_error(
            topic,
            format!(
                "{}x{} image, its camera info says {w}x{h}",
                im.width, im.height
            ),
        )),
    }
}

/// The depth image as 16-bit raw units of `unit` metres (float depth in metres rounded;
/// beyond the 16-bit range, NaN or not positive: 0, no measurement).
fn depth_pixels(im: &msg::Image<'_>, topic: &str, unit: f64) -> Result<Vec<u16>, ImportError> {
    let (w, h, step) = (im.width as usize, im.height as usize, im.step as usize);
    let row = |v: usize| &im.data[v * step..];
    let bytes = if im.encoding == "32FC1" { 4 } else { 2 };
    check_step(im, topic, bytes)?;
    let mut out = Vec::with_capacity(w * h);
    match im.encoding.as_str() {
        "16UC1" | "mono16" => {
            for v in 0..h {
                let r = row(v);
                out.extend((0..w).map(|u| {
                    let b = [r[2 * u], r[2 * u + 1]];
                    if im.big_endian {
                        u16::from_be_bytes(b)
                    } else {
                        u16::from_le_bytes(b)
                    }
                }));
            }
        }
        "32FC1" => {
            for v in 0..h {
                let r = row(v);
                out.extend((0..w).map(|u| {
                    let b: [u8; 4] = r[4 * u..4 * u + 4].try_into().expect("4 bytes");
                    let z = if im.big_endian {
                        f32::from_be_bytes(b)
                    } else {
                        f32::from_le_bytes(b)
                    };
                    let raw = (f64::from(z) / unit).round();
                    if raw.is_finite() && raw >= 1.0 && raw <= f64::from(u16::MAX) {
                        raw as u16
                    } else {
                        0
                    }
                }));
            }
        }
        e => {
            return Err(ImportError::Encoding {
                topic: topic.into(),
                encoding: e.into(),
                expected: DEPTH_ENCODINGS,
            })
        }
    }
    Ok(out)
}

/// The colour image as RGB.
fn colour_pixels(im: &msg::Image<'_>, topic: &str) -> Result<Vec<[u8; 3]>, ImportError> {
    let (channels, order): (usize, [usize; 3]) = match im.encoding.as_str() {
        "rgb8" => (3, [0, 1, 2]),
        "bgr8" => (3, [2, 1, 0]),
        "rgba8" => (4, [0, 1, 2]),
        "bgra8" => (4, [2, 1, 0]),
        "mono8" => (1, [0, 0, 0]),
        e => {
            return Err(ImportError::Encoding {
                topic: topic.into(),
                encoding: e.into(),
                expected: COLOUR_ENCODINGS,
            })
        }
    };
    let (w, h, step) = (im.width as usize, im.height as usize, im.step as usize);
    check_step(im, topic, channels)?;
    let mut out = Vec::with_capacity(w * h);
    for v in 0..h {
        let r = &im.data[v * step..];
        out.extend((0..w).map(|u| order.map(|c| r[u * channels + c])));
    }
    Ok(out)
}

/// The camera the recording is written in, and how depth gets there.
struct Plan {
    depth_topic: String,
    colour_topic: Option<String>,
    /// The depth camera, and the colour one when depth is reprojected into it.
    depth_camera: PinholeIntrinsics,
    align_to: Option<PinholeIntrinsics>,
    /// The bag's depth-to-colour extrinsic [identity when it has none].
    colour_from_depth: Option<nalgebra::Isometry3<f64>>,
    /// Depth message (file order) → (frame number, colour message).
    frames: Vec<(usize, Option<usize>)>,
    raw_unit: f64,
    written_unit: f64,
}

fn plan(s: &Scan, p: &ImportParams, summary: &mut ImportSummary) -> Result<Plan, ImportError> {
    let depth_topic = s.image_topic(
        p.depth_topic.as_deref(),
        DEPTH_ENCODINGS,
        &["depth"],
        "depth",
        "--depth-topic",
    )?;
    let depth_topic = depth_topic.ok_or_else(|| {
        s.topic_error(format!(
            "no depth image topic (sensor_msgs/Image with encoding {DEPTH_ENCODINGS}): give --depth-topic"
        ))
    })?;
    let colour_topic = s.image_topic(
        p.colour_topic.as_deref(),
        COLOUR_ENCODINGS,
        &["color", "colour", "rgb"],
        "colour",
        "--colour-topic",
    )?;
    let (depth_info_topic, depth_info) = s.info_topic(
        p.depth_info_topic.as_deref(),
        &depth_topic,
        "--depth-info-topic",
    )?;
    let depth_stamps = &s.stamps[&depth_topic];
    let tolerance = match p.pair_tolerance {
        Some(t) => t,
        None => median_period(depth_stamps).map_or(1.0 / 60.0, |d| d as f64 * 0.5e-9),
    };
    summary.pair_tolerance = tolerance;
    summary.depth_frames = depth_stamps.len();
    // Frame numbers: places in stamp order (a stable sort keeps file order on ties).
    let mut by_stamp: Vec<usize> = (0..depth_stamps.len()).collect();
    by_stamp.sort_by_key(|&i| depth_stamps[i]);
    let mut number = vec![0; depth_stamps.len()];
    for (n, &i) in by_stamp.iter().enumerate() {
        number[i] = n;
    }
    let partners = match &colour_topic {
        Some(c) => {
            let colour = &s.stamps[c];
            summary.colour_frames = colour.len();
            pair(depth_stamps, colour, (tolerance * 1e9).round() as i64)
        }
        None => vec![None; depth_stamps.len()],
    };
    let frames: Vec<(usize, Option<usize>)> = number.into_iter().zip(partners).collect();
    let depth_encoding = &s.encodings[&depth_topic];
    let float_depth = depth_encoding == "32FC1";
    let raw_unit = match (float_depth, p.depth_unit, s.realsense_depth_unit) {
        (true, _, _) => 1.0,
        (false, Some(u), _) => u,
        (false, None, Some(u)) => decimal_of(u),
        (false, None, None) => 0.001,
    };
    let written_unit = match float_depth {
        true => p.float_depth_unit.unwrap_or(1e-4),
        false => raw_unit,
    };
    if !(written_unit > 0.0 && written_unit.is_finite()) {
        return Err(ImportError::Params(format!(
            "depth unit {written_unit} m: must be positive"
        )));
    }
    let depth_camera = checks::camera(
        depth_info,
        depth_info_topic,
        &depth_topic,
        s.sizes[&depth_topic],
        "--depth-info-topic",
    )?;
    let (mut align_to, mut colour_from_depth) = (None, None);
    if let Some(c) = &colour_topic {
        let option = "--colour-info-topic";
        let (info_topic, colour_info) = s.info_topic(p.colour_info_topic.as_deref(), c, option)?;
        let colour_camera = checks::camera(colour_info, info_topic, c, s.sizes[c], option)?;
        // An implausible extrinsic is warned and replaced by the identity, as a bag without
        // one is: the images are intact, the streams of one device sit centimetres apart,
        // and no option supplies the transform, so refusing would lose the recording.
        colour_from_depth = align::realsense_colour_from_depth(&s.tfs, &depth_topic, c)
            .unwrap_or_else(|problem| {
                summary.warnings.push(format!(
                    "{problem}: it was ignored and depth and colour taken as one camera \
                     (identity extrinsic); re-export the bag to keep the true transform"
                ));
                None
            });
        let moved = colour_from_depth.is_some_and(|x| !align::is_identity(&x));
        if colour_camera != depth_camera || moved {
            align_to = Some(colour_camera);
        }
    }
    Ok(Plan {
        depth_topic,
        colour_topic,
        depth_camera,
        align_to,
        colour_from_depth,
        frames,
        raw_unit,
        written_unit,
    })
}

/// Writes frames as their depth and colour images arrive; images wait for their partner
/// (the bag's order keeps the waiting few).
struct FrameWriter<'a> {
    plan: &'a Plan,
    writer: RecordingWriter,
    size: [usize; 2],
    /// Colour message → its depth message.
    depth_of: HashMap<usize, usize>,
    waiting_depth: HashMap<usize, Vec<u16>>,
    waiting_colour: HashMap<usize, Vec<[u8; 3]>>,
    depth_seen: usize,
    colour_seen: usize,
    /// Written frames without a valid depth pixel.
    no_depth: Vec<usize>,
}

impl FrameWriter<'_> {
    fn write(
        &mut self,
        number: usize,
        depth: Vec<u16>,
        rgb: Option<&[[u8; 3]]>,
        summary: &mut ImportSummary,
    ) -> Result<(), ImportError> {
        let [w, h] = self.size.map(|x| x as u32);
        if depth.iter().all(|&d| d == 0) {
            self.no_depth.push(number);
        }
        match rgb {
            Some(rgb) => {
                self.writer.write_frame(number, [w, h], depth, rgb)?;
                summary.paired += 1;
            }
            None => self.writer.write_depth(number, [w, h], depth)?,
        }
        summary.frames_written += 1;
        Ok(())
    }

    fn on_depth(
        &mut self,
        im: &msg::Image<'_>,
        topic: &str,
        summary: &mut ImportSummary,
    ) -> Result<(), ImportError> {
        let i = self.depth_seen;
        self.depth_seen += 1;
        let d = &self.plan.depth_camera;
        check_size(im, topic, [d.width as usize, d.height as usize])?;
        let mut depth = depth_pixels(im, topic, self.plan.written_unit / self.plan.raw_unit)?;
        if let Some(to) = &self.plan.align_to {
            let x = self
                .plan
                .colour_from_depth
                .unwrap_or_else(nalgebra::Isometry3::identity);
            depth = align::align(&depth, self.plan.written_unit, d, to, &x);
        }
        let (number, colour) = self.plan.frames[i];
        match (colour, &self.plan.colour_topic) {
            (Some(c), _) => match self.waiting_colour.remove(&c) {
                Some(rgb) => self.write(number, depth, Some(&rgb), summary)?,
                None => {
                    self.waiting_depth.insert(i, depth);
                }
            },
            (None, Some(_)) => summary.dropped_depth.push(number),
            (None, None) => self.write(number, depth, None, summary)?,
        }
        Ok(())
    }

    fn on_colour(
        &mut self,
        im: &msg::Image<'_>,
        topic: &str,
        summary: &mut ImportSummary,
    ) -> Result<(), ImportError> {
        let j = self.colour_seen;
        self.colour_seen += 1;
        let Some(&i) = self.depth_of.get(&j) else {
            summary.unused_colour += 1;
            return Ok(());
        };
        check_size(im, topic, self.size)?;
        let rgb = colour_pixels(im, topic)?;
        match self.waiting_depth.remove(&i) {
            Some(depth) => self.write(self.plan.frames[i].0, depth, Some(&rgb), summary),
            None => {
                self.waiting_colour.insert(j, rgb);
                Ok(())
            }
        }
    }
}

/// Imports the bag `bag_path` into a new recording folder `out` (see the module docs for
/// the rules); `progress(done, total)` is called after each depth frame. Every error names
/// the bag.
pub fn import(
    bag_path: &Path,
    out: &Path,
    params: &ImportParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ImportSummary, ImportError> {
    import_bag(bag_path, out, params, progress).map_err(|e| e.in_bag(bag_path))
}

fn import_bag(
    bag_path: &Path,
    out: &Path,
    params: &ImportParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ImportSummary, ImportError> {
    let bag = Bag::open(bag_path)?;
    if crate::recording::list_frames(out).is_ok() {
        return Err(ImportError::OutputHasFrames {
            path: out.to_path_buf(),
        });
    }
    let s = scan(&bag)?;
    let mut summary = ImportSummary::default();
    let plan = plan(&s, params, &mut summary).map_err(|e| match e {
        ImportError::Topic { problem, present } => ImportError::Topic {
            problem: format!("{}: {problem}", bag_path.display()),
            present,
        },
        // The camera checks name the topic; the file is named here.
        ImportError::Message { what, reason } => ImportError::Message {
            what,
            reason: format!("{reason} (in {})", bag_path.display()),
        },
        e => e,
    })?;
    let writer = RecordingWriter::create(out)?;
    let c = plan.align_to.as_ref().unwrap_or(&plan.depth_camera);
    let size = [c.width as usize, c.height as usize];
    writer.write_intrinsics(
        [c.width, c.height],
        [c.fx, c.fy, c.cx, c.cy],
        plan.written_unit,
    )?;
    let mut frames = FrameWriter {
        plan: &plan,
        writer,
        size,
        depth_of: (plan.frames.iter().enumerate())
            .filter_map(|(i, (_, c))| c.map(|c| (c, i)))
            .collect(),
        waiting_depth: HashMap::new(),
        waiting_colour: HashMap::new(),
        depth_seen: 0,
        colour_seen: 0,
        no_depth: Vec::new(),
    };
    let wire = bag.wire();
    bag.for_each(&mut |m: BagMessage<'_>| {
        let depth = m.topic == plan.depth_topic;
        let colour = Some(m.topic) == plan.colour_topic.as_deref();
        if !(depth || colour) || m.short_type() != "sensor_msgs/Image" {
            return Ok(());
        }
        let im = msg::image(m.data, wire).map_err(|e| in_topic(m.topic, e))?;
        match depth {
            true => {
                frames.on_depth(&im, m.topic, &mut summary)?;
                progress(frames.depth_seen, plan.frames.len());
                Ok(())
            }
            false => frames.on_colour(&im, m.topic, &mut summary),
        }
    })?;
    summary.dropped_depth.sort_unstable();
    frames.no_depth.sort_unstable();
    summary.depth_topic = plan.depth_topic.clone();
    summary.colour_topic = plan.colour_topic.clone();
    summary.depth_unit = plan.written_unit;
    summary.aligned = plan.align_to.is_some();
    if summary.colour_topic.is_none() {
        summary.warnings.push(
            "no colour image topic: the recording is depth only, and `sense` finds the robot \
             by its colour, so it reports every frame no_robot"
                .into(),
        );
    }
    summary.warnings.extend(checks::no_depth_warning(
        &frames.no_depth,
        &plan.depth_topic,
    ));
    if summary.aligned && plan.colour_from_depth.is_none() {
        summary.warnings.push(
            "depth and colour cameras differ: depth was reprojected into the colour camera \
             with an identity extrinsic (the bag's depth-to-colour transform is not read)"
                .into(),
        );
    }
    Ok(summary)
}
