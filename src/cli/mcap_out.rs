//! `--format mcap`: one MCAP file per recording, to open in Foxglove beside
//! (or, with `--include-images`, instead of) the recording:
//!
//! - `<topic>/lfast/keypoints`: `foxglove.ImageAnnotations` (protobuf, the
//!   Foxglove SDK's schema), one circle per keypoint, coloured by pyramid
//!   level as `--draw` colours them, stamped with the image's own time stamp
//!   so that Foxglove's Image panel draws them over the image topic;
//! - `<topic>/lfast/features`: `lfast.Features` (protobuf, [`FEATURES_PROTO`]):
//!   the keypoints as float32 N x 7 and the descriptors as uint8 N x 32;
//! - `<topic>` with `--include-images`: the images (an MCAP topic's messages
//!   copied as they are; a video's frames as `foxglove.RawImage` mono8).
//!
//! Every message's log time is its image's. The file is written to a
//! temporary file and renamed when the recording ends, also when it ends at
//! damage (it then holds every frame before it): never a partial file.

use crate::image::Plane;
use crate::io::AtomicFile;
use crate::{Descriptor, KeyPoint};
use foxglove::Encode;
use foxglove::schemas::{CircleAnnotation, Color, ImageAnnotations, Point2, RawImage, Timestamp};
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

/// The schema of `<topic>/lfast/features`, as a `.proto` file.
pub const FEATURES_PROTO: &str = r#"syntax = "proto3";
package lfast;

// One frame's keypoints and descriptors, written by `lfast detect --format mcap`.
message Features {
  uint64 time_ns = 1;     // the image message's log time (video: presentation time), ns
  uint64 stamp_ns = 2;    // the image's own time stamp (header.stamp, timestamp), ns
  uint64 frame = 3;       // index of the frame among all frames of its topic or video
  uint32 width = 4;       // image size, pixels
  uint32 height = 5;
  bytes keypoints = 6;    // float32 little-endian, N x 7: x, y, size, angle, response, octave, class_id
  bytes descriptors = 7;  // uint8, N x 32: row i describes keypoint i (ORB rBRIEF, byte 0 first)
}
"#;

/// `lfast.Features` (see [`FEATURES_PROTO`]).
#[derive(Clone, PartialEq, prost::Message)]
pub struct FeaturesMsg {
    /// Log time, ns.
    #[prost(uint64, tag = "1")]
    pub time_ns: u64,
    /// Image stamp, ns.
    #[prost(uint64, tag = "2")]
    pub stamp_ns: u64,
    /// Frame index.
    #[prost(uint64, tag = "3")]
    pub frame: u64,
    /// Width.
    #[prost(uint32, tag = "4")]
    pub width: u32,
    /// Height.
    #[prost(uint32, tag = "5")]
    pub height: u32,
    /// float32 N x 7.
    #[prost(bytes = "vec", tag = "6")]
    pub keypoints: Vec<u8>,
    /// uint8 N x 32.
    #[prost(bytes = "vec", tag = "7")]
    pub descriptors: Vec<u8>,
}

/// The `FileDescriptorSet` of [`FEATURES_PROTO`], the schema data protobuf readers need.
fn features_descriptor() -> Vec<u8> {
    use prost::Message;
    use prost_types::field_descriptor_proto::{Label, Type};
    use prost_types::{DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet};
    let field = |name: &str, number: i32, ty: Type| FieldDescriptorProto {
        name: Some(name.into()),
        number: Some(number),
        label: Some(Label::Optional as i32),
        r#type: Some(ty as i32),
        json_name: Some(name.into()),
        ..Default::default()
    };
    let msg = DescriptorProto {
        name: Some("Features".into()),
        field: vec![
            field("time_ns", 1, Type::Uint64),
            field("stamp_ns", 2, Type::Uint64),
            field("frame", 3, Type::Uint64),
            field("width", 4, Type::Uint32),
            field("height", 5, Type::Uint32),
            field("keypoints", 6, Type::Bytes),
            field("descriptors", 7, Type::Bytes),
        ],
        ..Default::default()
    };
    let file = FileDescriptorProto {
        name: Some("lfast/Features.proto".into()),
        package: Some("lfast".into()),
        message_type: vec![msg],
        syntax: Some("proto3".into()),
        ..Default::default()
    };
    FileDescriptorSet { file: vec![file] }.encode_to_vec()
}

/// What `--include-images` copies.
pub enum ImageCopy<'a> {
    /// Nothing.
    None,
    /// The recording's messages, with their channel's schema.
    Messages(&'a crate::recording::SchemaInfo),
    /// A video's frames, as `foxglove.RawImage`.
    Frames,
}

/// One frame's image, for `--include-images`.
pub enum FrameImage<'a> {
    /// The recording's message as read.
    Message(&'a [u8]),
    /// A decoded frame.
    Gray(&'a Plane<u8>),
}

/// One frame for the file.
pub struct FrameOut<'a> {
    /// Log time, ns.
    pub time_ns: u64,
    /// The image's own stamp (`None`: the log time).
    pub stamp_ns: Option<u64>,
    /// Frame index.
    pub index: u64,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// Keypoints.
    pub kps: &'a [KeyPoint],
    /// Descriptors.
    pub desc: &'a [Descriptor],
    /// The image, when it is copied.
    pub image: Option<FrameImage<'a>>,
}

type McapWriter = mcap::Writer<BufWriter<std::fs::File>>;

/// The MCAP file of one recording, being written.
pub struct AnnotationWriter {
    file: Option<AtomicFile>,
    w: McapWriter,
    annotations: u16,
    features: u16,
    images: Option<u16>,
    seq: u32,
    buf: Vec<u8>,
}

fn mcap_err(path: &Path, e: mcap::McapError) -> crate::Error {
    match e {
        mcap::McapError::Io(source) => crate::Error::Io { path: path.to_path_buf(), source },
        e => crate::Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) },
    }
}

fn stamp(ns: u64) -> Timestamp {
    let sec = (ns / 1_000_000_000).min(u32::MAX as u64) as u32;
    Timestamp::new(sec, (ns % 1_000_000_000) as u32)
}

/// The colour of pyramid level `octave` (the `--draw` palette), opaque.
fn level_colour(octave: i32) -> Color {
    let c = super::draw::level_colour(octave).0;
    Color { r: c[0] as f64 / 255.0, g: c[1] as f64 / 255.0, b: c[2] as f64 / 255.0, a: 1.0 }
}

/// One frame's circles: at each keypoint (pixel centres are at +0.5 in
/// Foxglove's image coordinates, whose origin is the top-left pixel's
/// corner), the keypoint's size as diameter, outlined in its level's colour.
pub fn annotations(kps: &[KeyPoint], stamp_ns: u64) -> ImageAnnotations {
    let t = stamp(stamp_ns);
    let circles = kps
        .iter()
        .map(|k| CircleAnnotation {
            timestamp: Some(t),
            position: Some(Point2 { x: k.pt.x as f64 + 0.5, y: k.pt.y as f64 + 0.5 }),
            diameter: k.size as f64,
            thickness: 1.0,
            fill_color: Some(Color { r: 0.0, g: 0.0, b: 0.0, a: 0.0 }),
            outline_color: Some(level_colour(k.octave)),
            metadata: Vec::new(),
        })
        .collect();
    ImageAnnotations { timestamp: Some(t), circles, ..Default::default() }
}

impl AnnotationWriter {
    /// Starts `path` for the image topic `topic`.
    pub fn create(path: &Path, topic: &str, copy: ImageCopy<'_>) -> crate::Result<Self> {
        let mut file = AtomicFile::create(path)?;
        let out = file.file().try_clone().map_err(|source| crate::Error::Io { path: path.to_path_buf(), source })?;
        let err = |e| mcap_err(path, e);
        let mut w = mcap::WriteOptions::new()
            .library(format!("lfast {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            // the detector has the cores
            .compression_threads(0)
            .create(BufWriter::with_capacity(1 << 20, out))
            .map_err(err)?;
        let none = BTreeMap::new();
        let schema = <ImageAnnotations as Encode>::get_schema().expect("foxglove schemas have one");
        let sid = w.add_schema(&schema.name, &schema.encoding, &schema.data).map_err(err)?;
        let annotations = w.add_channel(sid, &format!("{topic}/lfast/keypoints"), "protobuf", &none).map_err(err)?;
        let fid = w.add_schema("lfast.Features", "protobuf", &features_descriptor()).map_err(err)?;
        let features = w.add_channel(fid, &format!("{topic}/lfast/features"), "protobuf", &none).map_err(err)?;
        // the .proto text of lfast.Features, for readers without the descriptor tools
        let meta = mcap::records::Metadata {
            name: "lfast".into(),
            metadata: BTreeMap::from([("features.proto".to_string(), FEATURES_PROTO.to_string())]),
        };
        w.write_metadata(&meta).map_err(err)?;
        let images = match copy {
            ImageCopy::None => None,
            ImageCopy::Messages(s) => {
                let id = w.add_schema(&s.name, &s.encoding, &s.data).map_err(err)?;
                Some(w.add_channel(id, topic, &s.message_encoding, &none).map_err(err)?)
            }
            ImageCopy::Frames => {
                let s = <RawImage as Encode>::get_schema().expect("foxglove schemas have one");
                let id = w.add_schema(&s.name, &s.encoding, &s.data).map_err(err)?;
                Some(w.add_channel(id, topic, "protobuf", &none).map_err(err)?)
            }
        };
        Ok(AnnotationWriter { file: Some(file), w, annotations, features, images, seq: 0, buf: Vec::new() })
    }

    fn put(&mut self, channel_id: u16, time_ns: u64) -> crate::Result<()> {
        self.seq = self.seq.wrapping_add(1);
        let h =
            mcap::records::MessageHeader { channel_id, sequence: self.seq, log_time: time_ns, publish_time: time_ns };
        let path = self.file.as_ref().map(|f| f.path().to_path_buf()).unwrap_or_default();
        self.w.write_to_known_channel(&h, &self.buf).map_err(|e| mcap_err(&path, e))
    }

    /// Writes one frame's messages.
    pub fn write(&mut self, f: &FrameOut<'_>) -> crate::Result<()> {
        let stamp_ns = f.stamp_ns.unwrap_or(f.time_ns);
        if let (Some(id), Some(img)) = (self.images, &f.image) {
            self.buf.clear();
            match img {
                FrameImage::Message(m) => self.buf.extend_from_slice(m),
                FrameImage::Gray(p) => {
                    let raw = RawImage {
                        timestamp: Some(stamp(stamp_ns)),
                        frame_id: "video".into(),
                        width: p.width,
                        height: p.height,
                        encoding: "mono8".into(),
                        step: p.width,
                        data: p.data.clone().into(),
                    };
                    raw.encode(&mut self.buf).map_err(|e| crate::Error::Unsupported { reason: e.to_string() })?;
                }
            }
            self.put(id, f.time_ns)?;
        }
        self.buf.clear();
        annotations(f.kps, stamp_ns)
            .encode(&mut self.buf)
            .map_err(|e| crate::Error::Unsupported { reason: e.to_string() })?;
        self.put(self.annotations, f.time_ns)?;
        let mut kp = Vec::with_capacity(f.kps.len() * 28);
        for k in f.kps {
            for v in [k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave as f32, k.class_id as f32] {
                kp.extend_from_slice(&v.to_le_bytes());
            }
        }
        let m = FeaturesMsg {
            time_ns: f.time_ns,
            stamp_ns,
            frame: f.index,
            width: f.width,
            height: f.height,
            keypoints: kp,
            descriptors: f.desc.as_flattened().to_vec(),
        };
        self.buf.clear();
        prost::Message::encode(&m, &mut self.buf).map_err(|e| crate::Error::Unsupported { reason: e.to_string() })?;
        self.put(self.features, f.time_ns)
    }

    /// Ends the file (summary, footer) and puts it in place.
    pub fn finish(mut self) -> crate::Result<()> {
        let file = self.file.take().expect("finished once");
        let path = file.path().to_path_buf();
        self.w.finish().map_err(|e| mcap_err(&path, e))?;
        let mut inner = self.w.into_inner();
        std::io::Write::flush(&mut inner).map_err(|source| crate::Error::Io { path: path.clone(), source })?;
        drop(inner);
        file.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_circle_per_keypoint_at_the_pixel_centre_in_the_level_colour() {
        let mut a = KeyPoint::new(10.0, 20.0, 31.0);
        a.octave = 0;
        let mut b = KeyPoint::new(3.5, 4.25, 37.2);
        b.octave = 1;
        let ann = annotations(&[a, b], 1_500_000_007);
        assert_eq!(ann.circles.len(), 2);
        let c = &ann.circles[1];
        assert_eq!(c.position, Some(Point2 { x: 4.0, y: 4.75 }));
        assert_eq!(c.diameter, 37.2f32 as f64);
        let green = level_colour(1);
        assert_eq!(c.outline_color, Some(green));
        assert_eq!(c.fill_color.map(|f| f.a), Some(0.0));
        assert_eq!(ann.timestamp, Some(Timestamp::new(1, 500_000_007)));
    }

    #[test]
    fn the_features_descriptor_is_a_file_descriptor_set_naming_every_field() {
        use prost::Message;
        let set = prost_types::FileDescriptorSet::decode(features_descriptor().as_slice()).unwrap();
        let m = &set.file[0].message_type[0];
        assert_eq!(set.file[0].package.as_deref(), Some("lfast"));
        let names: Vec<&str> = m.field.iter().map(|f| f.name()).collect();
        assert_eq!(names, ["time_ns", "stamp_ns", "frame", "width", "height", "keypoints", "descriptors"]);
        for (i, f) in m.field.iter().enumerate() {
            assert!(FEATURES_PROTO.contains(&format!("{} = {};", f.name(), i + 1)), "{}", f.name());
        }
    }
}
