//! The few ROS messages an import reads, decoded through serde by the field's maintained
//! crates: ROS 2 CDR by `cdr-encoding` (RustDDS's; it borrows the pixels), ROS 1
//! serialisation by `roslibrust_serde_rosmsg` (roslibrust's). Only the message layouts are
//! ours: each struct lists every field of the message in wire order, because both formats
//! are positional.

use super::ImportError;
use serde::de::{Deserializer, Visitor};
use serde::Deserialize;
use std::borrow::Cow;

/// How a message's bytes are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// ROS 1 serialisation (rosbag v1).
    Ros1,
    /// ROS 2 CDR, little-endian (`rmw` default, MCAP `cdr`).
    Cdr,
}

/// `sensor_msgs/Image`, borrowing its pixels where the wire allows (CDR).
#[derive(Clone, Debug, PartialEq)]
pub struct Image<'a> {
    /// Header stamp, nanoseconds.
    pub stamp_ns: i64,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pixel encoding (`16UC1`, `rgb8`, ...).
    pub encoding: String,
    /// Whether multi-byte pixels are big-endian.
    pub big_endian: bool,
    /// Bytes per row.
    pub step: u32,
    /// Row-major pixels.
    pub data: Cow<'a, [u8]>,
}

/// The parts of `sensor_msgs/CameraInfo` an import uses.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraInfo {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Row-major 3x3 intrinsic matrix `K`.
    pub k: [f64; 9],
}

/// `geometry_msgs/Transform`: `p_child = R(rotation) p_parent + translation`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Transform {
    /// Translation, metres.
    pub translation: [f64; 3],
    /// Rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

/// A header's stamp in nanoseconds, whichever wire it came from.
trait Stamp {
    fn stamp_ns(&self) -> i64;
}

/// ROS 1 `std_msgs/Header`: unsigned seconds.
#[derive(Deserialize)]
struct Ros1Header {
    _seq: u32,
    sec: u32,
    nsec: u32,
    _frame_id: String,
}

impl Stamp for Ros1Header {
    fn stamp_ns(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nsec)
    }
}

/// ROS 2 `std_msgs/msg/Header`: signed seconds, no sequence number.
#[derive(Deserialize)]
struct Ros2Header {
    sec: i32,
    nanosec: u32,
    _frame_id: String,
}

impl Stamp for Ros2Header {
    fn stamp_ns(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }
}

/// A `uint8[]` read in one piece: serde's `Vec<u8>` would take ROS 1 bytes one at a time.
struct ByteBuf(Vec<u8>);

impl<'de> Deserialize<'de> for ByteBuf {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Bytes;
        impl Visitor<'_> for Bytes {
            type Value = ByteBuf;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a uint8 array")
            }
            fn visit_byte_buf<E>(self, v: Vec<u8>) -> Result<ByteBuf, E> {
                Ok(ByteBuf(v))
            }
            fn visit_bytes<E>(self, v: &[u8]) -> Result<ByteBuf, E> {
                Ok(ByteBuf(v.to_vec()))
            }
        }
        d.deserialize_byte_buf(Bytes)
    }
}

#[derive(Deserialize)]
struct ImageMsg<H, D> {
    header: H,
    height: u32,
    width: u32,
    encoding: String,
    is_bigendian: u8,
    step: u32,
    data: D,
}

#[derive(Deserialize)]
struct RegionOfInterest {
    _x_offset: u32,
    _y_offset: u32,
    _height: u32,
    _width: u32,
    _do_rectify: bool,
}

#[derive(Deserialize)]
struct CameraInfoMsg<H> {
    _header: H,
    height: u32,
    width: u32,
    _distortion_model: String,
    _d: Vec<f64>,
    k: [f64; 9],
    _r: [f64; 9],
    _p: [f64; 12],
    _binning_x: u32,
    _binning_y: u32,
    _roi: RegionOfInterest,
}

/// Decodes one whole message of type `T` (`what` names it in errors).
fn decode<'a, T: Deserialize<'a>>(
    buf: &'a [u8],
    wire: Wire,
    what: &'static str,
) -> Result<T, ImportError> {
    let err = |reason: String| ImportError::Message { what, reason };
    match wire {
        Wire::Ros1 => {
            let len = u32::try_from(buf.len()).map_err(|_| err("over 4 GiB".into()))?;
            roslibrust_serde_rosmsg::from_slice_known_length(buf, len)
                .map_err(|e| err(format!("ROS 1 message: {e}")))
        }
        Wire::Cdr => {
            // 0x0001 is CDR little-endian; 0x0000 (big-endian) is never written by ROS 2.
            match buf.get(..4) {
                Some([0, 1, _, _]) => {}
                Some(head) => {
                    return Err(err(format!(
                        "CDR encapsulation {:02x}{:02x}: only little-endian CDR (0001) is read",
                        head[0], head[1]
                    )))
                }
                None => return Err(err(format!("truncated: {} bytes", buf.len()))),
            }
            // Trailing bytes are allowed: CDR pads a message to a multiple of 4.
            cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(&buf[4..])
                .map(|(v, _)| v)
                .map_err(|e| err(format!("CDR message: {e}")))
        }
    }
}

/// Checks that the rows fit in the pixels and keeps the stamp in nanoseconds.
fn image_from<'a, H: Stamp, D>(
    m: ImageMsg<H, D>,
    pixels: impl FnOnce(D) -> Cow<'a, [u8]>,
) -> Result<Image<'a>, ImportError> {
    let data = pixels(m.data);
    let rows_fit = (m.step as u64) * (m.height as u64) <= data.len() as u64;
    if !rows_fit {
        return Err(ImportError::Message {
            what: "sensor_msgs/Image",
            reason: format!(
                "{}x{} image with {} bytes per row holds only {} bytes",
                m.width,
                m.height,
                m.step,
                data.len()
            ),
        });
    }
    Ok(Image {
        stamp_ns: m.header.stamp_ns(),
        width: m.width,
        height: m.height,
        encoding: m.encoding,
        big_endian: m.is_bigendian != 0,
        step: m.step,
        data,
    })
}

/// Decodes a `sensor_msgs/Image`.
pub fn image(buf: &[u8], wire: Wire) -> Result<Image<'_>, ImportError> {
    const WHAT: &str = "sensor_msgs/Image";
    match wire {
        Wire::Ros1 => {
            let m: ImageMsg<Ros1Header, ByteBuf> = decode(buf, wire, WHAT)?;
            image_from(m, |b| Cow::Owned(b.0))
        }
        Wire::Cdr => {
            let m: ImageMsg<Ros2Header, &[u8]> = decode(buf, wire, WHAT)?;
            image_from(m, Cow::Borrowed)
        }
    }
}

/// Decodes a `sensor_msgs/CameraInfo` (size and `K`).
pub fn camera_info(buf: &[u8], wire: Wire) -> Result<CameraInfo, ImportError> {
    const WHAT: &str = "sensor_msgs/CameraInfo";
    let (width, height, k) = match wire {
        Wire::Ros1 => {
            let m: CameraInfoMsg<Ros1Header> = decode(buf, wire, WHAT)?;
            (m.width, m.height, m.k)
        }
        Wire::Cdr => {
            let m: CameraInfoMsg<Ros2Header> = decode(buf, wire, WHAT)?;
            (m.width, m.height, m.k)
        }
    };
    Ok(CameraInfo { width, height, k })
}

/// Decodes a `std_msgs/Float32`.
pub fn float32(buf: &[u8], wire: Wire) -> Result<f32, ImportError> {
    decode::<(f32,)>(buf, wire, "std_msgs/Float32").map(|(v,)| v)
}

/// Decodes a `geometry_msgs/Transform`.
pub fn transform(buf: &[u8], wire: Wire) -> Result<Transform, ImportError> {
    decode(buf, wire, "geometry_msgs/Transform")
}
