//! Small bags built byte by byte for the import tests: ROS 1 and CDR messages, rosbag v1
//! and MCAP files (the layouts `softsense import`'s readers must undo).

use softsense::recording::import::msg::Wire;

/// Little-endian writer of ROS 1 (packed) or CDR (aligned, after a 4-byte header) fields.
pub struct Ser {
    /// The bytes so far.
    pub buf: Vec<u8>,
    wire: Wire,
}

impl Ser {
    pub fn new(wire: Wire) -> Self {
        let buf = match wire {
            Wire::Ros1 => vec![],
            Wire::Cdr => vec![0, 1, 0, 0],
        };
        Self { buf, wire }
    }
    pub fn align(&mut self, n: usize) {
        if self.wire == Wire::Cdr {
            while (self.buf.len() - 4) % n != 0 {
                self.buf.push(0);
            }
        }
    }
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend(v.to_le_bytes());
        self
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend(v.to_le_bytes());
        self
    }
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.buf.extend(v.to_le_bytes());
        self
    }
    pub fn string(&mut self, s: &str) -> &mut Self {
        let nul = usize::from(self.wire == Wire::Cdr);
        self.u32((s.len() + nul) as u32);
        self.buf.extend(s.as_bytes());
        if nul == 1 {
            self.buf.push(0);
        }
        self
    }
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.u32(b.len() as u32);
        self.buf.extend(b);
        self
    }
    pub fn header(&mut self, stamp_ns: i64, frame: &str) -> &mut Self {
        if self.wire == Wire::Ros1 {
            self.u32(7);
        }
        self.u32((stamp_ns / 1_000_000_000) as u32);
        self.u32((stamp_ns % 1_000_000_000) as u32);
        self.string(frame)
    }
}

pub fn image_msg(
    wire: Wire,
    stamp_ns: i64,
    size: [u32; 2],
    encoding: &str,
    data: &[u8],
) -> Vec<u8> {
    let mut s = Ser::new(wire);
    let step = data.len() as u32 / size[1];
    s.header(stamp_ns, "cam")
        .u32(size[1])
        .u32(size[0])
        .string(encoding);
    s.u8(0).u32(step).bytes(data);
    s.buf
}

pub fn info_msg(wire: Wire, size: [u32; 2], k: [f64; 9]) -> Vec<u8> {
    let mut s = Ser::new(wire);
    // A 1-character frame id puts the doubles off their 8-byte alignment in CDR.
    s.header(0, "c")
        .u32(size[1])
        .u32(size[0])
        .string("plumb_bob");
    s.u32(5);
    for _ in 0..5 {
        s.f64(0.0);
    }
    for v in k.into_iter().chain([0.0; 21]) {
        s.f64(v);
    }
    s.u32(0).u32(0).u32(0).u32(0).u32(0).u32(0).u8(0);
    s.buf
}

pub fn pixels_u16(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

pub fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = ((name.len() + 1 + value.len()) as u32)
        .to_le_bytes()
        .to_vec();
    f.extend(name.as_bytes());
    f.push(b'=');
    f.extend(value);
    f
}

pub fn record(fields: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
    let header: Vec<u8> = fields.concat();
    let mut r = (header.len() as u32).to_le_bytes().to_vec();
    r.extend(header);
    r.extend((data.len() as u32).to_le_bytes());
    r.extend(data);
    r
}

/// A rosbag v1 with one chunk (`compression`) of `messages` (topic, type, stamp, data).
pub fn rosbag1(messages: &[(&str, &str, Vec<u8>)], compression: &str) -> Vec<u8> {
    let mut topics: Vec<(&str, &str)> = vec![];
    let mut chunk = vec![];
    for (topic, ty, data) in messages {
        let conn = match topics.iter().position(|t| t == &(*topic, *ty)) {
            Some(c) => c,
            None => {
                topics.push((topic, ty));
                let c = topics.len() - 1;
                let inner = [
                    field("topic", topic.as_bytes()),
                    field("type", ty.as_bytes()),
                ];
                chunk.extend(record(
                    &[
                        field("op", &[7]),
                        field("conn", &(c as u32).to_le_bytes()),
                        field("topic", topic.as_bytes()),
                    ],
                    &inner.concat(),
                ));
                c
            }
        };
        chunk.extend(record(
            &[
                field("op", &[2]),
                field("conn", &(conn as u32).to_le_bytes()),
                field("time", &[0; 8]),
            ],
            data,
        ));
    }
    let size = chunk.len() as u32;
    let chunk = match compression {
        "lz4" => lz4_frame(&chunk),
        _ => chunk,
    };
    let mut bag = b"#ROSBAG V2.0\n".to_vec();
    bag.extend(record(
        &[field("op", &[3]), field("index_pos", &[0; 8])],
        &[b' '; 16],
    ));
    bag.extend(record(
        &[
            field("op", &[5]),
            field("compression", compression.as_bytes()),
            field("size", &size.to_le_bytes()),
        ],
        &chunk,
    ));
    bag
}

pub fn mcap_record(op: u8, content: &[u8]) -> Vec<u8> {
    let mut r = vec![op];
    r.extend((content.len() as u64).to_le_bytes());
    r.extend(content);
    r
}

pub fn mstr(s: &str) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend(s.as_bytes());
    v
}

/// An MCAP file with one chunk of `messages`, compressed with `compression` (`lz4` and
/// `zstd` compress; any other name is written on uncompressed records).
pub fn mcap(messages: &[(&str, &str, Vec<u8>)], compression: &str) -> Vec<u8> {
    let mut topics: Vec<(&str, &str)> = vec![];
    let mut inner = vec![];
    for (topic, ty, data) in messages {
        let id = match topics.iter().position(|t| t == &(*topic, *ty)) {
            Some(c) => c as u16 + 1,
            None => {
                topics.push((topic, ty));
                let id = topics.len() as u16;
                let schema = [
                    id.to_le_bytes().to_vec(),
                    mstr(ty),
                    mstr("ros2msg"),
                    mstr(""),
                ]
                .concat();
                inner.extend(mcap_record(3, &schema));
                let channel = [
                    id.to_le_bytes().to_vec(),
                    id.to_le_bytes().to_vec(),
                    mstr(topic),
                    mstr("cdr"),
                    vec![0; 4],
                ]
                .concat();
                inner.extend(mcap_record(4, &channel));
                id
            }
        };
        let msg = [id.to_le_bytes().to_vec(), vec![0; 4 + 8 + 8], data.clone()].concat();
        inner.extend(mcap_record(5, &msg));
    }
    let size = inner.len() as u64;
    // A CRC of 0 means "not computed" in MCAP: readers skip the check.
    let records = match compression {
        "lz4" => lz4_frame(&inner),
        "zstd" => zstd::bulk::compress(&inner, 3).unwrap(),
        _ => inner,
    };
    let chunk = [
        vec![0; 16],
        size.to_le_bytes().to_vec(),
        vec![0; 4],
        mstr(compression),
        (records.len() as u64).to_le_bytes().to_vec(),
        records,
    ]
    .concat();
    let mut file = b"\x89MCAP0\r\n".to_vec();
    file.extend(mcap_record(1, &[mstr("ros2"), mstr("test")].concat()));
    file.extend(mcap_record(6, &chunk));
    file.extend(mcap_record(0x0F, &[0; 4]));
    file.extend(mcap_record(2, &[0; 20]));
    file.extend(b"\x89MCAP0\r\n");
    file
}

pub fn transform_msg(translation: [f64; 3], rotation: [f64; 4]) -> Vec<u8> {
    let mut s = Ser::new(Wire::Ros1);
    for v in translation.into_iter().chain(rotation) {
        s.f64(v);
    }
    s.buf
}

/// The two RealSense image messages (ROS 1) of one 4x3 frame: depth 1000 everywhere and
/// colour 5.
pub fn realsense_4x3_frame() -> Vec<(&'static str, &'static str, Vec<u8>)> {
    let w = Wire::Ros1;
    vec![
        (
            "/device_0/sensor_0/Depth_0/image/data",
            "sensor_msgs/Image",
            image_msg(w, 0, [4, 3], "16UC1", &pixels_u16(&[1000; 12])),
        ),
        (
            "/device_0/sensor_1/Color_0/image/data",
            "sensor_msgs/Image",
            image_msg(w, 0, [4, 3], "rgb8", &[5; 36]),
        ),
    ]
}

/// A ROS 2 sqlite3 bag holding `messages`, with rosbag2's schema, at `path`.
pub fn db3(path: &std::path::Path, messages: &[(&str, &str, Vec<u8>)]) {
    let db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
             timestamp INTEGER NOT NULL, data BLOB NOT NULL);",
    )
    .unwrap();
    let mut topics: Vec<&str> = vec![];
    for (i, (topic, ty, data)) in messages.iter().enumerate() {
        let id = match topics.iter().position(|t| t == topic) {
            Some(p) => p + 1,
            None => {
                topics.push(topic);
                db.execute(
                    "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
                    rusqlite::params![topics.len(), topic, ty],
                )
                .unwrap();
                topics.len()
            }
        };
        db.execute(
            "INSERT INTO messages(topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![id, i, data],
        )
        .unwrap();
    }
}

/// `data` as one LZ4 frame (the `lz4` chunks of rosbag v1 and MCAP).
fn lz4_frame(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = lz4_flex::frame::FrameEncoder::new(vec![]);
    e.write_all(data).unwrap();
    e.finish().unwrap()
}
