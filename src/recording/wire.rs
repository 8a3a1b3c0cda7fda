//! The few message types a recording's image topic can have, read field by
//! field from their wire formats: CDR (ROS 2: `sensor_msgs/msg/Image`,
//! `CompressedImage`, `CameraInfo`, and `foxglove_msgs/msg/RawImage`,
//! `CompressedImage`) and protobuf (`foxglove.RawImage`,
//! `foxglove.CompressedImage`).
//!
//! Hand-written rather than a serde CDR crate or prost: five fixed layouts of
//! a dozen fields, read without copying the pixel data, each error naming the
//! field where the message ends too early. The decoders are checked against
//! messages written by Python's `mcap-ros2-support` and `rosbags` and by the
//! foxglove crate's protobuf encoder.

/// Where a message's fields come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MessageKind {
    /// `sensor_msgs/msg/Image` (CDR).
    RosImage,
    /// `sensor_msgs/msg/CompressedImage` (CDR).
    RosCompressed,
    /// `foxglove_msgs/msg/RawImage` (CDR).
    RosFoxgloveRaw,
    /// `foxglove_msgs/msg/CompressedImage` (CDR).
    RosFoxgloveCompressed,
    /// `foxglove.RawImage` (protobuf).
    ProtoRaw,
    /// `foxglove.CompressedImage` (protobuf).
    ProtoCompressed,
}

impl MessageKind {
    /// The kind of a channel's schema name and message encoding; `None` when
    /// it is not an image.
    pub fn of(schema: &str, message_encoding: &str) -> Option<Self> {
        Some(match (schema, message_encoding) {
            ("sensor_msgs/msg/Image", "cdr") => Self::RosImage,
            ("sensor_msgs/msg/CompressedImage", "cdr") => Self::RosCompressed,
            ("foxglove_msgs/msg/RawImage", "cdr") => Self::RosFoxgloveRaw,
            ("foxglove_msgs/msg/CompressedImage", "cdr") => Self::RosFoxgloveCompressed,
            ("foxglove.RawImage", "protobuf") => Self::ProtoRaw,
            ("foxglove.CompressedImage", "protobuf") => Self::ProtoCompressed,
            _ => return None,
        })
    }

    /// Whether `schema` names an image type whatever its encoding.
    pub fn is_image_schema(schema: &str) -> bool {
        matches!(
            schema,
            "sensor_msgs/msg/Image"
                | "sensor_msgs/msg/CompressedImage"
                | "foxglove_msgs/msg/RawImage"
                | "foxglove_msgs/msg/CompressedImage"
                | "foxglove.RawImage"
                | "foxglove.CompressedImage"
        )
    }
}

/// An image message's fields, borrowing its pixel bytes.
#[derive(Debug, PartialEq)]
pub enum ImageMsg<'a> {
    /// Uncompressed pixels.
    Raw {
        /// The image's own time stamp (header.stamp, timestamp), ns.
        stamp_ns: u64,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Pixel encoding, e.g. `mono8`, `bgr8`.
        encoding: &'a str,
        /// Multi-byte samples stored big-endian.
        big_endian: bool,
        /// Bytes from one row to the next.
        step: u32,
        /// The pixels.
        data: &'a [u8],
    },
    /// A compressed image file (PNG, JPEG).
    Compressed {
        /// The image's own time stamp, ns.
        stamp_ns: u64,
        /// The format string, e.g. `png`, `jpeg`, `bgr8; jpeg compressed bgr8`.
        format: &'a str,
        /// The file's bytes.
        data: &'a [u8],
    },
}

/// The pinhole intrinsics of a `sensor_msgs/msg/CameraInfo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraInfo {
    /// Image width the calibration is for.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The row-major 3x3 K (fx 0 cx; 0 fy cy; 0 0 1).
    pub k: [f64; 9],
    /// The row-major 3x4 projection P of the rectified image.
    pub p: [f64; 12],
}

fn stamp(sec: i64, nsec: u64) -> u64 {
    (sec.max(0) as u64).saturating_mul(1_000_000_000).saturating_add(nsec)
}

/// A CDR reader (XCDR1 and plain XCDR2, either byte order) over one message.
struct Cdr<'a> {
    body: &'a [u8],
    pos: usize,
    le: bool,
    /// The largest alignment: 8 in XCDR1, 4 in XCDR2.
    max_align: usize,
}

impl<'a> Cdr<'a> {
    fn new(msg: &'a [u8]) -> Result<Self, String> {
        if msg.len() < 4 {
            return Err(format!("a CDR message of {} bytes has no encapsulation header", msg.len()));
        }
        let (le, max_align) = match (msg[0], msg[1]) {
            (0, 0) => (false, 8),
            (0, 1) => (true, 8),
            (0, 6) | (0, 10) => (false, 4),
            (0, 7) | (0, 11) => (true, 4),
            (a, b) => {
                return Err(format!("CDR representation 0x{a:02x}{b:02x} is not supported (plain CDR or XCDR2 only)"));
            }
        };
        Ok(Cdr { body: &msg[4..], pos: 0, le, max_align })
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], String> {
        let left = self.body.len() - self.pos;
        if n > left {
            return Err(format!(
                "the message ends inside `{field}` (it needs {n} bytes at offset {}, {left} are left)",
                self.pos + 4
            ));
        }
        let s = &self.body[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn align(&mut self, n: usize) {
        let n = n.min(self.max_align);
        self.pos = self.pos.div_ceil(n) * n;
        self.pos = self.pos.min(self.body.len());
    }

    fn u8(&mut self, field: &str) -> Result<u8, String> {
        Ok(self.take(1, field)?[0])
    }

    fn u32(&mut self, field: &str) -> Result<u32, String> {
        self.align(4);
        let b: [u8; 4] = self.take(4, field)?.try_into().expect("4 bytes");
        Ok(if self.le { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) })
    }

    fn f64(&mut self, field: &str) -> Result<f64, String> {
        self.align(8);
        let b: [u8; 8] = self.take(8, field)?.try_into().expect("8 bytes");
        Ok(if self.le { f64::from_le_bytes(b) } else { f64::from_be_bytes(b) })
    }

    fn bytes(&mut self, field: &str) -> Result<&'a [u8], String> {
        let n = self.u32(field)? as usize;
        self.take(n, field)
    }

    fn string(&mut self, field: &str) -> Result<&'a str, String> {
        let b = self.bytes(field)?;
        // CDR strings count their terminating NUL
        let b = b.strip_suffix(&[0]).unwrap_or(b);
        std::str::from_utf8(b).map_err(|_| format!("`{field}` is not UTF-8"))
    }

    /// builtin_interfaces/Time.
    fn time(&mut self, field: &str) -> Result<u64, String> {
        let sec = self.u32(field)? as i32;
        let nsec = self.u32(field)?;
        Ok(stamp(sec as i64, nsec as u64))
    }

    /// std_msgs/Header: the stamp (frame_id skipped).
    fn header(&mut self) -> Result<u64, String> {
        let t = self.time("header.stamp")?;
        self.string("header.frame_id")?;
        Ok(t)
    }
}

/// Protobuf wire format: the fields of one message, in order.
struct Proto<'a> {
    buf: &'a [u8],
    pos: usize,
}

/// One protobuf field's value.
enum Value<'a> {
    Varint(u64),
    Fixed32(u32),
    /// A 64-bit fixed value (no field read here has one).
    Fixed64,
    Bytes(&'a [u8]),
}

impl<'a> Proto<'a> {
    fn varint(&mut self) -> Result<u64, String> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let Some(&b) = self.buf.get(self.pos) else {
                return Err(format!("the message ends inside a varint at offset {}", self.pos));
            };
            self.pos += 1;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(format!("a varint longer than 10 bytes at offset {}", self.pos))
    }

    fn take(&mut self, n: usize, tag: u64) -> Result<&'a [u8], String> {
        if n > self.buf.len() - self.pos {
            return Err(format!(
                "the message ends inside field {tag} (it needs {n} bytes at offset {}, {} are left)",
                self.pos,
                self.buf.len() - self.pos
            ));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// The next field: (tag, value), or `None` at the end.
    fn next(&mut self) -> Result<Option<(u64, Value<'a>)>, String> {
        if self.pos >= self.buf.len() {
            return Ok(None);
        }
        let key = self.varint()?;
        let tag = key >> 3;
        let v = match key & 7 {
            0 => Value::Varint(self.varint()?),
            1 => {
                self.take(8, tag)?;
                Value::Fixed64
            }
            2 => {
                let n = self.varint()? as usize;
                Value::Bytes(self.take(n, tag)?)
            }
            5 => Value::Fixed32(u32::from_le_bytes(self.take(4, tag)?.try_into().expect("4 bytes"))),
            w => return Err(format!("field {tag} has wire type {w}, which protobuf 3 does not use")),
        };
        Ok(Some((tag, v)))
    }
}

fn proto_str<'a>(b: &'a [u8], field: &str) -> Result<&'a str, String> {
    std::str::from_utf8(b).map_err(|_| format!("`{field}` is not UTF-8"))
}

/// google.protobuf.Timestamp / foxglove.Timestamp: seconds (1), nanoseconds (2).
fn proto_time(b: &[u8]) -> Result<u64, String> {
    let mut p = Proto { buf: b, pos: 0 };
    let (mut sec, mut nsec) = (0i64, 0u64);
    while let Some((tag, v)) = p.next()? {
        match (tag, v) {
            (1, Value::Varint(s)) => sec = s as i64,
            (2, Value::Varint(n)) => nsec = n & 0xffff_ffff,
            _ => {}
        }
    }
    Ok(stamp(sec, nsec))
}

/// Reads an image message of `kind`.
pub fn image(kind: MessageKind, msg: &[u8]) -> Result<ImageMsg<'_>, String> {
    match kind {
        MessageKind::RosImage => {
            let mut c = Cdr::new(msg)?;
            let stamp_ns = c.header()?;
            let height = c.u32("height")?;
            let width = c.u32("width")?;
            let encoding = c.string("encoding")?;
            let big_endian = c.u8("is_bigendian")? != 0;
            let step = c.u32("step")?;
            let data = c.bytes("data")?;
            Ok(ImageMsg::Raw { stamp_ns, width, height, encoding, big_endian, step, data })
        }
        MessageKind::RosCompressed => {
            let mut c = Cdr::new(msg)?;
            let stamp_ns = c.header()?;
            let format = c.string("format")?;
            let data = c.bytes("data")?;
            Ok(ImageMsg::Compressed { stamp_ns, format, data })
        }
        MessageKind::RosFoxgloveRaw => {
            let mut c = Cdr::new(msg)?;
            let stamp_ns = c.time("timestamp")?;
            c.string("frame_id")?;
            let width = c.u32("width")?;
            let height = c.u32("height")?;
            let encoding = c.string("encoding")?;
            let step = c.u32("step")?;
            let data = c.bytes("data")?;
            Ok(ImageMsg::Raw { stamp_ns, width, height, encoding, big_endian: false, step, data })
        }
        MessageKind::RosFoxgloveCompressed => {
            let mut c = Cdr::new(msg)?;
            let stamp_ns = c.time("timestamp")?;
            c.string("frame_id")?;
            let data = c.bytes("data")?;
            let format = c.string("format")?;
            Ok(ImageMsg::Compressed { stamp_ns, format, data })
        }
        MessageKind::ProtoRaw => {
            let mut p = Proto { buf: msg, pos: 0 };
            let (mut stamp_ns, mut width, mut height, mut step) = (0, 0, 0, 0);
            let (mut encoding, mut data) = ("", &[][..]);
            while let Some((tag, v)) = p.next()? {
                match (tag, v) {
                    (1, Value::Bytes(b)) => stamp_ns = proto_time(b)?,
                    (2, Value::Fixed32(v)) => width = v,
                    (3, Value::Fixed32(v)) => height = v,
                    (4, Value::Bytes(b)) => encoding = proto_str(b, "encoding")?,
                    (5, Value::Fixed32(v)) => step = v,
                    (6, Value::Bytes(b)) => data = b,
                    _ => {}
                }
            }
            Ok(ImageMsg::Raw { stamp_ns, width, height, encoding, big_endian: false, step, data })
        }
        MessageKind::ProtoCompressed => {
            let mut p = Proto { buf: msg, pos: 0 };
            let (mut stamp_ns, mut format, mut data) = (0, "", &[][..]);
            while let Some((tag, v)) = p.next()? {
                match (tag, v) {
                    (1, Value::Bytes(b)) => stamp_ns = proto_time(b)?,
                    (2, Value::Bytes(b)) => data = b,
                    (3, Value::Bytes(b)) => format = proto_str(b, "format")?,
                    _ => {}
                }
            }
            Ok(ImageMsg::Compressed { stamp_ns, format, data })
        }
    }
}

/// Reads a `sensor_msgs/msg/CameraInfo` (CDR): its size, K and P.
pub fn camera_info(msg: &[u8]) -> Result<CameraInfo, String> {
    let mut c = Cdr::new(msg)?;
    c.header()?;
    let height = c.u32("height")?;
    let width = c.u32("width")?;
    c.string("distortion_model")?;
    let n = c.u32("d")? as usize;
    for _ in 0..n {
        c.f64("d")?;
    }
    let mut k = [0.0; 9];
    for v in &mut k {
        *v = c.f64("k")?;
    }
    for _ in 0..9 {
        c.f64("r")?;
    }
    let mut p = [0.0; 12];
    for v in &mut p {
        *v = c.f64("p")?;
    }
    Ok(CameraInfo { width, height, k, p })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sensor_msgs/msg/Image in CDR little-endian, laid out by hand:
    /// offsets are from the end of the 4-byte encapsulation header.
    fn ros_image_le() -> Vec<u8> {
        let mut m = vec![0, 1, 0, 0];
        m.extend(7i32.to_le_bytes()); // 0: stamp.sec
        m.extend(500u32.to_le_bytes()); // 4: stamp.nanosec
        m.extend(4u32.to_le_bytes()); // 8: frame_id length, with its NUL
        m.extend(b"cam\0"); // 12
        m.extend(2u32.to_le_bytes()); // 16: height
        m.extend(3u32.to_le_bytes()); // 20: width
        m.extend(6u32.to_le_bytes()); // 24: encoding
        m.extend(b"mono8\0"); // 28..34
        m.push(0); // 34: is_bigendian
        m.push(0xee); // 35: padding to 36
        m.extend(4u32.to_le_bytes()); // 36: step (a padded row)
        m.extend(8u32.to_le_bytes()); // 40: data length
        m.extend([1, 2, 3, 9, 4, 5, 6, 9]); // 44
        m
    }

    #[test]
    fn a_cdr_image_is_read_with_its_alignment_padding() {
        let m = ros_image_le();
        let got = image(MessageKind::RosImage, &m).unwrap();
        let want = ImageMsg::Raw {
            stamp_ns: 7_000_000_500,
            width: 3,
            height: 2,
            encoding: "mono8",
            big_endian: false,
            step: 4,
            data: &[1, 2, 3, 9, 4, 5, 6, 9],
        };
        assert_eq!(got, want);
    }

    #[test]
    fn big_endian_cdr_reads_the_same_fields() {
        let mut m = vec![0, 0, 0, 0];
        m.extend(7i32.to_be_bytes());
        m.extend(500u32.to_be_bytes());
        m.extend(1u32.to_be_bytes());
        m.push(0); // 12: frame_id "", then padding to 16
        m.extend([0; 3]);
        m.extend(2u32.to_be_bytes()); // 16: height
        m.extend(1u32.to_be_bytes()); // 20: width
        m.extend(7u32.to_be_bytes()); // 24: encoding
        m.extend(b"mono16\0"); // 28..35
        m.push(1); // 35: is_bigendian
        m.extend(2u32.to_be_bytes()); // 36: step
        m.extend(4u32.to_be_bytes()); // 40: data
        m.extend([0x12, 0x34, 0xab, 0xcd]);
        let ImageMsg::Raw { stamp_ns, width, height, encoding, big_endian, step, data } =
            image(MessageKind::RosImage, &m).unwrap()
        else {
            panic!("raw")
        };
        assert_eq!((stamp_ns, width, height, encoding, big_endian, step), (7_000_000_500, 1, 2, "mono16", true, 2));
        assert_eq!(data, [0x12, 0x34, 0xab, 0xcd]);
    }

    #[test]
    fn a_message_cut_anywhere_names_the_field_it_ends_in() {
        let m = ros_image_le();
        for cut in 0..m.len() {
            let e = image(MessageKind::RosImage, &m[..cut]).unwrap_err();
            assert!(e.contains("ends inside") || e.contains("no encapsulation header"), "cut {cut}: {e}");
        }
        let e = image(MessageKind::RosImage, &m[..m.len() - 1]).unwrap_err();
        assert!(e.contains("`data`") && e.contains("needs 8 bytes at offset 48, 7 are left"), "{e}");
        let e = image(MessageKind::RosImage, &[0, 2, 0, 0, 0, 0, 0, 0]).unwrap_err();
        assert!(e.contains("0x0002 is not supported"), "{e}");
    }

    #[test]
    fn a_cdr_compressed_image_and_camera_info() {
        let mut m = vec![0, 1, 0, 0];
        m.extend(1i32.to_le_bytes());
        m.extend(2u32.to_le_bytes());
        m.extend(1u32.to_le_bytes());
        m.extend([0, 0, 0, 0]); // "" and padding
        m.extend(4u32.to_le_bytes());
        m.extend(b"png\0");
        m.extend(3u32.to_le_bytes());
        m.extend([7, 8, 9]);
        let want = ImageMsg::Compressed { stamp_ns: 1_000_000_002, format: "png", data: &[7, 8, 9] };
        assert_eq!(image(MessageKind::RosCompressed, &m).unwrap(), want);

        let mut c = vec![0, 1, 0, 0];
        c.extend([0; 8]); // stamp
        c.extend(1u32.to_le_bytes());
        c.extend([0, 0, 0, 0]); // frame_id ""
        c.extend(376u32.to_le_bytes()); // 16: height
        c.extend(1241u32.to_le_bytes()); // 20: width
        c.extend(10u32.to_le_bytes()); // 24: distortion_model
        c.extend(b"plumb_bob\0"); // 28..38
        c.extend([0, 0]); // to 40
        c.extend(1u32.to_le_bytes()); // 40: d, one value
        c.extend([0; 4]); // to 48 (8-byte alignment)
        c.extend(0.5f64.to_le_bytes());
        let k: [f64; 9] = [718.856, 0.0, 607.1928, 0.0, 718.856, 185.2157, 0.0, 0.0, 1.0];
        for v in k {
            c.extend(v.to_le_bytes());
        }
        for v in [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0f64] {
            c.extend(v.to_le_bytes());
        }
        let p: [f64; 12] = [700.0, 0.0, 600.0, 0.0, 0.0, 710.0, 180.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        for v in p {
            c.extend(v.to_le_bytes());
        }
        let info = camera_info(&c).unwrap();
        assert_eq!(info, CameraInfo { width: 1241, height: 376, k, p });
    }

    #[test]
    fn protobuf_raw_and_compressed_images() {
        // foxglove.RawImage: timestamp {sec 3, nsec 4}, width 2, height 1, encoding "mono8", step 2, data [5, 6]
        let m = [
            0x0a, 4, 0x08, 3, 0x10, 4, // 1: timestamp
            0x15, 2, 0, 0, 0, // 2: width (fixed32)
            0x1d, 1, 0, 0, 0, // 3: height
            0x22, 5, b'm', b'o', b'n', b'o', b'8', // 4: encoding
            0x2d, 2, 0, 0, 0, // 5: step
            0x32, 2, 5, 6, // 6: data
            0x3a, 1, b'f', // 7: frame_id
        ];
        let want = ImageMsg::Raw {
            stamp_ns: 3_000_000_004,
            width: 2,
            height: 1,
            encoding: "mono8",
            big_endian: false,
            step: 2,
            data: &[5, 6],
        };
        assert_eq!(image(MessageKind::ProtoRaw, &m).unwrap(), want);
        let e = image(MessageKind::ProtoRaw, &m[..m.len() - 5]).unwrap_err();
        assert!(e.contains("field 6"), "{e}");
        // foxglove.CompressedImage: data (2) and format (3); no timestamp = 0
        let c = [0x12, 2, 0xff, 0xd8, 0x1a, 4, b'j', b'p', b'e', b'g'];
        let want = ImageMsg::Compressed { stamp_ns: 0, format: "jpeg", data: &[0xff, 0xd8] };
        assert_eq!(image(MessageKind::ProtoCompressed, &c).unwrap(), want);
    }

    #[test]
    fn kinds_come_from_the_schema_and_the_encoding() {
        assert_eq!(MessageKind::of("sensor_msgs/msg/Image", "cdr"), Some(MessageKind::RosImage));
        assert_eq!(MessageKind::of("foxglove.RawImage", "protobuf"), Some(MessageKind::ProtoRaw));
        assert_eq!(MessageKind::of("foxglove.RawImage", "json"), None);
        assert!(MessageKind::is_image_schema("foxglove.RawImage"));
        assert!(!MessageKind::is_image_schema("sensor_msgs/msg/CameraInfo"));
    }
}
