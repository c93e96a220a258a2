//! The few ROS messages an import reads, decoded by hand from ROS 1 serialisation
//! (little-endian, packed, `u32`-length-prefixed strings and arrays) or ROS 2 CDR (a 4-byte
//! encapsulation header, then little-endian fields each aligned to its own size, counted
//! from after the header; strings carry a trailing NUL).

use super::ImportError;

/// How a message's bytes are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// ROS 1 serialisation (rosbag v1).
    Ros1,
    /// ROS 2 CDR, little-endian (`rmw` default, MCAP `cdr`).
    Cdr,
}

/// `sensor_msgs/Image`, borrowing its pixels.
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
    pub data: &'a [u8],
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

/// A cursor over one message's bytes.
pub struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    wire: Wire,
    what: &'static str,
}

impl<'a> Cursor<'a> {
    /// A cursor over `buf` (a CDR message starts with its encapsulation header, which is
    /// checked and skipped); `what` names the message type in errors.
    pub fn new(buf: &'a [u8], wire: Wire, what: &'static str) -> Result<Self, ImportError> {
        let mut c = Self {
            buf,
            pos: 0,
            wire,
            what,
        };
        if wire == Wire::Cdr {
            let head = c.take(4)?;
            // 0x0001 is CDR little-endian; 0x0000 (big-endian) is never written by ROS 2.
            if head[..2] != [0, 1] {
                return Err(ImportError::Message {
                    what,
                    reason: format!(
                        "CDR encapsulation {:02x}{:02x}: only little-endian CDR (0001) is read",
                        head[0], head[1]
                    ),
                });
            }
            c.buf = &buf[4..];
            c.pos = 0;
        }
        Ok(c)
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], ImportError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len());
        let Some(end) = end else {
            return Err(ImportError::Message {
                what: self.what,
                reason: format!(
                    "truncated: {n} bytes wanted at byte {} of {}",
                    self.pos,
                    self.buf.len()
                ),
            });
        };
        let s = &self.buf[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn align(&mut self, n: usize) -> Result<(), ImportError> {
        if self.wire == Wire::Cdr {
            let pad = (n - self.pos % n) % n;
            self.take(pad)?;
        }
        Ok(())
    }

    fn fixed<const N: usize>(&mut self) -> Result<[u8; N], ImportError> {
        self.align(N)?;
        Ok(self.take(N)?.try_into().expect("take returned N bytes"))
    }

    /// A `uint8`/`bool`.
    pub fn u8(&mut self) -> Result<u8, ImportError> {
        Ok(self.take(1)?[0])
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> Result<u32, ImportError> {
        Ok(u32::from_le_bytes(self.fixed()?))
    }

    /// A `float32`.
    pub fn f32(&mut self) -> Result<f32, ImportError> {
        Ok(f32::from_le_bytes(self.fixed()?))
    }

    /// A `float64`.
    pub fn f64(&mut self) -> Result<f64, ImportError> {
        Ok(f64::from_le_bytes(self.fixed()?))
    }

    /// A `uint8[]` (length-prefixed).
    pub fn bytes(&mut self) -> Result<&'a [u8], ImportError> {
        let n = self.u32()? as usize;
        self.take(n)
    }

    /// A `string` (CDR: the length counts a trailing NUL, which is dropped).
    pub fn string(&mut self) -> Result<String, ImportError> {
        let mut raw = self.bytes()?;
        if self.wire == Wire::Cdr {
            raw = raw.strip_suffix(&[0]).unwrap_or(raw);
        }
        Ok(String::from_utf8_lossy(raw).into_owned())
    }

    /// A `float64[]` (length-prefixed).
    pub fn f64_seq(&mut self) -> Result<Vec<f64>, ImportError> {
        let n = self.u32()? as usize;
        // A corrupt length must not allocate gigabytes before the bytes run out.
        if n > self.buf.len() / 8 {
            return Err(ImportError::Message {
                what: self.what,
                reason: format!("array of {n} float64 in a {}-byte message", self.buf.len()),
            });
        }
        (0..n).map(|_| self.f64()).collect()
    }

    /// `std_msgs/Header`: the stamp in nanoseconds (the frame id is skipped).
    pub fn header(&mut self) -> Result<i64, ImportError> {
        if self.wire == Wire::Ros1 {
            self.u32()?; // seq
        }
        let sec = self.u32()?;
        let nsec = self.u32()?;
        self.string()?;
        // ROS 1 stamps are unsigned seconds, ROS 2 signed.
        let sec = match self.wire {
            Wire::Ros1 => i64::from(sec),
            Wire::Cdr => i64::from(sec as i32),
        };
        Ok(sec * 1_000_000_000 + i64::from(nsec))
    }
}

/// Decodes a `sensor_msgs/Image`.
pub fn image(buf: &[u8], wire: Wire) -> Result<Image<'_>, ImportError> {
    let mut c = Cursor::new(buf, wire, "sensor_msgs/Image")?;
    let stamp_ns = c.header()?;
    let height = c.u32()?;
    let width = c.u32()?;
    let encoding = c.string()?;
    let big_endian = c.u8()? != 0;
    let step = c.u32()?;
    let data = c.bytes()?;
    let rows_fit = (step as u64) * (height as u64) <= data.len() as u64;
    if !rows_fit {
        return Err(ImportError::Message {
            what: "sensor_msgs/Image",
            reason: format!(
                "{width}x{height} image with {step} bytes per row holds only {} bytes",
                data.len()
            ),
        });
    }
    Ok(Image {
        stamp_ns,
        width,
        height,
        encoding,
        big_endian,
        step,
        data,
    })
}

/// Decodes a `sensor_msgs/CameraInfo` (size and `K`).
pub fn camera_info(buf: &[u8], wire: Wire) -> Result<CameraInfo, ImportError> {
    let mut c = Cursor::new(buf, wire, "sensor_msgs/CameraInfo")?;
    c.header()?;
    let height = c.u32()?;
    let width = c.u32()?;
    c.string()?; // distortion model
    c.f64_seq()?; // D
    let mut k = [0.0; 9];
    for v in &mut k {
        *v = c.f64()?;
    }
    Ok(CameraInfo { width, height, k })
}

/// Decodes a `std_msgs/Float32`.
pub fn float32(buf: &[u8], wire: Wire) -> Result<f32, ImportError> {
    Cursor::new(buf, wire, "std_msgs/Float32")?.f32()
}

/// `geometry_msgs/Transform`: `p_child = R(rotation) p_parent + translation`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    /// Translation, metres.
    pub translation: [f64; 3],
    /// Rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

/// Decodes a `geometry_msgs/Transform`.
pub fn transform(buf: &[u8], wire: Wire) -> Result<Transform, ImportError> {
    let mut c = Cursor::new(buf, wire, "geometry_msgs/Transform")?;
    let mut translation = [0.0; 3];
    for v in &mut translation {
        *v = c.f64()?;
    }
    let mut rotation = [0.0; 4];
    for v in &mut rotation {
        *v = c.f64()?;
    }
    Ok(Transform {
        translation,
        rotation,
    })
}
