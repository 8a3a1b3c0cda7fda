//! MCAP input: the messages of one topic, streamed.
//!
//! With a summary (an intact file), the chunk indexes give the chunks that
//! hold the topic; they are read one at a time, their CRC checked, and their
//! messages merged in log-time order (a chunk is loaded once no pending
//! message is earlier than its first), so memory holds the chunks whose time
//! ranges overlap, not the file. Without one (a truncated file, or one written
//! without a summary) the file is read linearly in file order by
//! [`mcap::io::MessageReader`], chunk CRCs checked before any of a chunk's
//! messages is used. Either way the first damaged record ends the stream with
//! an error that says where reading stopped.

use super::wire::MessageKind;
use mcap::records::ChunkIndex;
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader};
use std::cmp::{Ordering, Reverse};
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering as AtomicOrdering};

/// The largest record read (a chunk, a message): 1 GiB.
const RECORD_LIMIT: usize = 1 << 30;

/// One image topic of a file: its name, schema and message count.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicInfo {
    /// The topic.
    pub topic: String,
    /// The schema name of its channel.
    pub schema: String,
    /// Its message encoding.
    pub encoding: String,
    /// Messages on it.
    pub messages: u64,
}

/// A channel's schema, to copy the topic into another file.
#[derive(Clone, Debug)]
pub struct SchemaInfo {
    /// Schema name.
    pub name: String,
    /// Schema encoding (`ros2msg`, `protobuf`).
    pub encoding: String,
    /// Schema data.
    pub data: Vec<u8>,
    /// The channel's message encoding (`cdr`, `protobuf`).
    pub message_encoding: String,
}

/// One message of the topic.
pub struct RawMessage {
    /// Log time, ns.
    pub log_time: u64,
    /// Its type.
    pub kind: Option<MessageKind>,
    /// The serialised message.
    pub data: Vec<u8>,
}

/// Reads the summary section, `None` when the file has none or it cannot be read.
fn summary(file: &mut std::fs::File) -> Option<mcap::Summary> {
    let mut r = SummaryReader::new();
    while let Some(event) = r.next_event() {
        match event.ok()? {
            SummaryReadEvent::ReadRequest(need) => {
                let n = file.read(r.insert(need)).ok()?;
                r.notify_read(n);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let pos = file.seek(to).ok()?;
                r.notify_seeked(pos);
            }
        }
    }
    r.finish()
}

/// A `Read` that counts the bytes it has handed out.
struct Counting<R> {
    inner: R,
    count: Arc<AtomicU64>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.fetch_add(n as u64, AtomicOrdering::Relaxed);
        Ok(n)
    }
}

type Linear = mcap::io::MessageReader<Counting<BufReader<std::fs::File>>>;

fn linear(path: &Path) -> std::io::Result<(Linear, Arc<AtomicU64>)> {
    let file = std::fs::File::open(path)?;
    let count = Arc::new(AtomicU64::new(0));
    let src = Counting { inner: BufReader::with_capacity(1 << 20, file), count: count.clone() };
    let opts = mcap::sans_io::LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_record_length_limit(RECORD_LIMIT);
    Ok((mcap::io::MessageReader::new_with_options(src, opts), count))
}

/// A pending message of the log-time merge: earliest log time first, then file order.
struct Pending(RawMessage, u64);

impl PartialEq for Pending {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    fn cmp(&self, o: &Self) -> Ordering {
        (self.0.log_time, self.1).cmp(&(o.0.log_time, o.1))
    }
}

/// The chunk-by-chunk, log-time ordered reader of a file with a summary.
struct Indexed {
    file: std::fs::File,
    channels: BTreeMap<u16, Option<MessageKind>>,
    chunks: Vec<ChunkIndex>,
    next_chunk: usize,
    pending: BinaryHeap<Reverse<Pending>>,
    seq: u64,
    buf: Vec<u8>,
}

impl Indexed {
    fn load(&mut self, c: &ChunkIndex) -> Result<(), String> {
        let at = c.chunk_start_offset;
        let len = c.chunk_length as usize;
        let place = || {
            format!(
                "the chunk at byte {at} ({} bytes, log times {} to {})",
                len, c.message_start_time, c.message_end_time
            )
        };
        if !(9..=RECORD_LIMIT).contains(&len) {
            return Err(format!("{}: a chunk record of {len} bytes", place()));
        }
        self.buf.resize(len, 0);
        self.file
            .seek(SeekFrom::Start(at))
            .and_then(|_| self.file.read_exact(&mut self.buf))
            .map_err(|e| format!("{}: {e}", place()))?;
        if self.buf[0] != mcap::records::op::CHUNK {
            return Err(format!("{}: opcode 0x{:02x} where a chunk should be", place(), self.buf[0]));
        }
        let (header, data) = match mcap::read::parse_record(mcap::records::op::CHUNK, &self.buf[9..]) {
            Ok(mcap::records::Record::Chunk { header, data }) => (header, data),
            Ok(_) => return Err(format!("{}: not a chunk record", place())),
            Err(e) => return Err(format!("{}: {e}", place())),
        };
        let mut found = Vec::new();
        let records = mcap::read::ChunkReader::new(header, &data).map_err(|e| format!("{}: {e}", place()))?;
        // the chunk's CRC is checked after its last record: nothing of it is used before
        for r in records {
            match r.map_err(|e| format!("{}: {e}", place()))? {
                mcap::records::Record::Message { header, data } => {
                    if let Some(kind) = self.channels.get(&header.channel_id) {
                        found.push(RawMessage { log_time: header.log_time, kind: *kind, data: data.into_owned() });
                    }
                }
                _ => continue,
            }
        }
        for m in found {
            self.seq += 1;
            self.pending.push(Reverse(Pending(m, self.seq)));
        }
        Ok(())
    }

    fn next(&mut self) -> Option<Result<RawMessage, String>> {
        loop {
            let earliest = self.pending.peek().map(|p| p.0.0.log_time);
            let Some(c) = self.chunks.get(self.next_chunk) else { break };
            if earliest.is_some_and(|t| t < c.message_start_time) {
                break;
            }
            let c = c.clone();
            self.next_chunk += 1;
            if let Err(e) = self.load(&c) {
                self.chunks.clear();
                self.pending.clear();
                return Some(Err(e));
            }
        }
        self.pending.pop().map(|p| Ok(p.0.0))
    }
}

/// The linear reader of a file without a summary, and the bytes it has read.
struct LinearMode {
    reader: Linear,
    count: Arc<AtomicU64>,
    done: bool,
}

enum Mode {
    Indexed(Box<Indexed>),
    Linear(Box<LinearMode>),
}

/// The messages of one topic of an MCAP file.
pub struct McapSource {
    /// The topic read.
    pub topic: String,
    /// Its messages, when the file says (its summary, or a scan of a file without one).
    pub total: Option<u64>,
    /// The schema of its channel.
    pub schema: Option<SchemaInfo>,
    file_len: u64,
    mode: Mode,
}

/// The message kind of a channel.
fn kind_of(ch: &mcap::Channel<'_>) -> Option<MessageKind> {
    MessageKind::of(ch.schema.as_ref().map_or("", |s| s.name.as_str()), &ch.message_encoding)
}

fn schema_info(ch: &mcap::Channel<'_>) -> Option<SchemaInfo> {
    ch.schema.as_ref().map(|s| SchemaInfo {
        name: s.name.clone(),
        encoding: s.encoding.clone(),
        data: s.data.to_vec(),
        message_encoding: ch.message_encoding.clone(),
    })
}

/// Image topics of a summary, with their message counts, by topic name.
fn topics_of_summary(s: &mcap::Summary) -> Vec<TopicInfo> {
    let counts = s.stats.as_ref().map(|st| st.channel_message_counts.clone()).unwrap_or_default();
    let mut by_topic: BTreeMap<String, TopicInfo> = BTreeMap::new();
    for (id, ch) in &s.channels {
        let schema = ch.schema.as_ref().map_or(String::new(), |s| s.name.clone());
        let t = by_topic.entry(ch.topic.clone()).or_insert_with(|| TopicInfo {
            topic: ch.topic.clone(),
            schema,
            encoding: ch.message_encoding.clone(),
            messages: 0,
        });
        t.messages += counts.get(id).copied().unwrap_or(0);
    }
    by_topic.into_values().collect()
}

/// Every topic of a file without a summary, with its message count, from one
/// pass over it (which ends at the first damaged record).
fn topics_by_scan(path: &Path) -> std::io::Result<(Vec<TopicInfo>, Option<SchemaInfo>)> {
    let (reader, _) = linear(path)?;
    let mut by_topic: BTreeMap<String, (TopicInfo, Option<SchemaInfo>)> = BTreeMap::new();
    for m in reader {
        let Ok(m) = m else { break };
        let e = by_topic.entry(m.channel.topic.clone()).or_insert_with(|| {
            let t = TopicInfo {
                topic: m.channel.topic.clone(),
                schema: m.channel.schema.as_ref().map_or(String::new(), |s| s.name.clone()),
                encoding: m.channel.message_encoding.clone(),
                messages: 0,
            };
            (t, schema_info(&m.channel))
        });
        e.0.messages += 1;
    }
    let topics: Vec<TopicInfo> = by_topic.values().map(|(t, _)| t.clone()).collect();
    let first_schema = by_topic.into_values().find_map(|(t, s)| MessageKind::is_image_schema(&t.schema).then_some(s));
    Ok((topics, first_schema.flatten()))
}

fn list(topics: &[&TopicInfo]) -> String {
    topics.iter().map(|t| format!("{} ({}, {} messages)", t.topic, t.schema, t.messages)).collect::<Vec<_>>().join(", ")
}

/// Chooses the topic: `asked`, or the one image topic. Errors list the image
/// topics (or, when there are none, every topic) with their message counts.
fn choose<'t>(topics: &'t [TopicInfo], asked: Option<&str>) -> Result<&'t TopicInfo, String> {
    let images: Vec<&TopicInfo> = topics.iter().filter(|t| MessageKind::is_image_schema(&t.schema)).collect();
    let all: Vec<&TopicInfo> = topics.iter().collect();
    match asked {
        Some(name) => {
            let Some(t) = topics.iter().find(|t| t.topic == name) else {
                return Err(match images.is_empty() {
                    true => format!("no topic `{name}`; the file has no image topic (topics: {})", list(&all)),
                    false => format!("no topic `{name}`; image topics: {}", list(&images)),
                });
            };
            if !MessageKind::is_image_schema(&t.schema) {
                return Err(format!(
                    "topic `{name}` holds {} messages, not images (sensor_msgs/msg/Image, sensor_msgs/msg/CompressedImage, foxglove.RawImage, foxglove.CompressedImage)",
                    if t.schema.is_empty() { "schema-less" } else { &t.schema }
                ));
            }
            Ok(t)
        }
        None => match images.as_slice() {
            [one] => Ok(one),
            [] if all.is_empty() => Err("the file has no messages".into()),
            [] => Err(format!("no image topic (topics: {})", list(&all))),
            several => Err(format!("{} image topics, choose one with --topic: {}", several.len(), list(several))),
        },
    }
}

impl McapSource {
    /// Opens `path` on `topic` (or its one image topic). Errors are the reason only.
    pub fn open(path: &Path, topic: Option<&str>) -> Result<Self, String> {
        let mut file = std::fs::File::open(path).map_err(|e| e.to_string())?;
        let file_len = file.metadata().map_err(|e| e.to_string())?.len();
        let mut magic = [0u8; 8];
        if file.read_exact(&mut magic).is_err() || magic[..] != *mcap::MAGIC {
            return Err("not an MCAP file (no MCAP magic at the start)".into());
        }
        let sum = summary(&mut file);
        if let Some(s) = sum.as_ref().filter(|s| !s.chunk_indexes.is_empty() && s.stats.is_some()) {
            let topics = topics_of_summary(s);
            let t = choose(&topics, topic)?;
            let channels: BTreeMap<u16, Option<MessageKind>> =
                s.channels.iter().filter(|(_, c)| c.topic == t.topic).map(|(id, c)| (*id, kind_of(c))).collect();
            let mut chunks: Vec<ChunkIndex> = s
                .chunk_indexes
                .iter()
                .filter(|c| {
                    c.message_index_offsets.is_empty()
                        || c.message_index_offsets.keys().any(|k| channels.contains_key(k))
                })
                .cloned()
                .collect();
            chunks.sort_by_key(|c| (c.message_start_time, c.chunk_start_offset));
            let schema = s.channels.values().find(|c| c.topic == t.topic).and_then(|c| schema_info(c));
            let indexed =
                Indexed { file, channels, chunks, next_chunk: 0, pending: BinaryHeap::new(), seq: 0, buf: Vec::new() };
            return Ok(McapSource {
                topic: t.topic.clone(),
                total: Some(t.messages),
                schema,
                file_len,
                mode: Mode::Indexed(Box::new(indexed)),
            });
        }
        // no summary (or no chunk index): linear, in file order
        let (topics, total, schema) = match (&sum, topic) {
            (Some(s), _) => {
                let topics = topics_of_summary(s);
                let t = choose(&topics, topic)?.clone();
                let schema = s.channels.values().find(|c| c.topic == t.topic).and_then(|c| schema_info(c));
                (vec![t.clone()], s.stats.as_ref().map(|_| t.messages), schema)
            }
            (None, _) => {
                let (topics, schema) = topics_by_scan(path).map_err(|e| e.to_string())?;
                let t = choose(&topics, topic)?.clone();
                (vec![t.clone()], Some(t.messages), schema)
            }
        };
        let (reader, count) = linear(path).map_err(|e| e.to_string())?;
        Ok(McapSource {
            topic: topics[0].topic.clone(),
            total,
            schema,
            file_len,
            mode: Mode::Linear(Box::new(LinearMode { reader, count, done: false })),
        })
    }

    /// Whether the messages come in log-time order (the file has a summary).
    pub fn log_time_order(&self) -> bool {
        matches!(self.mode, Mode::Indexed(_))
    }

    /// The next message of the topic; an error (the reason, saying where
    /// reading stopped) ends the stream.
    pub fn next_message(&mut self) -> Option<Result<RawMessage, String>> {
        match &mut self.mode {
            Mode::Indexed(ix) => ix.next(),
            Mode::Linear(l) => {
                let LinearMode { reader, count, done } = &mut **l;
                if *done {
                    return None;
                }
                for m in reader.by_ref() {
                    match m {
                        Ok(m) if m.channel.topic == self.topic => {
                            return Some(Ok(RawMessage {
                                log_time: m.log_time,
                                kind: kind_of(&m.channel),
                                data: m.data.into_owned(),
                            }));
                        }
                        Ok(_) => continue,
                        Err(e) => {
                            *done = true;
                            let at = count.load(AtomicOrdering::Relaxed);
                            let why = match e {
                                mcap::McapError::UnexpectedEof => {
                                    "the file ends inside a record (truncated?)".to_string()
                                }
                                e => e.to_string(),
                            };
                            return Some(Err(format!("reading stopped near byte {at} of {}: {why}", self.file_len)));
                        }
                    }
                }
                *done = true;
                None
            }
        }
    }
}

/// The first message on the topic of schema `schema` nearest `near` (the
/// topic sharing the longest prefix with it), e.g. the `CameraInfo` beside an
/// image topic. `None` when there is none (or the file cannot be read).
pub fn first_message_of(path: &Path, schema: &str, near: &str) -> Option<(String, Vec<u8>)> {
    let mut file = std::fs::File::open(path).ok()?;
    let sum = summary(&mut file);
    let topics: Vec<TopicInfo> = match &sum {
        Some(s) => topics_of_summary(s),
        None => topics_by_scan(path).ok()?.0,
    };
    let common = |t: &str| t.chars().zip(near.chars()).take_while(|(a, b)| a == b).count();
    let t =
        topics.iter().filter(|t| t.schema == schema).max_by_key(|t| (common(&t.topic), Reverse(t.topic.clone())))?;
    let (reader, _) = linear(path).ok()?;
    let set: BTreeSet<&str> = [t.topic.as_str()].into();
    for m in reader {
        let m = m.ok()?;
        if set.contains(m.channel.topic.as_str()) {
            return Some((t.topic.clone(), m.data.into_owned()));
        }
    }
    None
}
