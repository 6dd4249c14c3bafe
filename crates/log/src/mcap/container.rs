//! The MCAP container as drive-sim writes it: records serialised whole into the open chunk's
//! buffer, and each chunk compressed by one zstd call.
//!
//! Why not the `mcap` crate's writer: it writes every field of a record (opcode, length, the
//! four header fields, the payload) as its own `write` into a streaming zstd encoder, seven
//! calls per message. With nine sub-kB messages per frame, those calls cost more than the
//! compression itself: a callgrind profile of a 30-step Warthog DRIVE with logging put 29 % of
//! all instructions in the crate's `write_record`, 13 % of them in zstd's compression proper
//! (README, "Speed"). This writer produces the same records (the same chunks, message indexes,
//! statistics, chunk and metadata indexes, summary offsets and CRCs the crate writes with our
//! options) and leaves the layout to the MCAP specification (<https://mcap.dev/spec>); the crate
//! stays the reader, which checks every CRC, and the reference this writer is tested against
//! (`Container::Crate` with the `oracle` feature, `tests/quick/mcap_roundtrip.rs`).

use mcap::records::{op, ChunkIndex, MessageHeader, Metadata, MetadataIndex, Statistics};
use mcap::{McapError, McapResult};
use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// The zstd level of drive-sim's chunks. Level -1 (zstd's first "fast" level) compresses the
/// chunks of a 300-step Warthog DRIVE log 1.37x faster than level 1 for a file 2 % larger
/// (`scripts/chunk_compression.py`; README, "Speed"); compression was 17 % of such a run's
/// instructions at level 1. Readers need nothing new: the level is not in the format.
pub const ZSTD_LEVEL: i32 = -1;

/// Which MCAP container writer a log uses (same messages, same records either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Container {
    /// drive-sim's writer (this module): whole records into the chunk buffer, one zstd call
    /// per chunk.
    #[default]
    Chunked,
    /// drive-sim's writer at another zstd level (the benchmarks compare levels with it).
    ChunkedZstd(i32),
    /// The `mcap` crate's writer, the reference the fast one is tested and benchmarked against
    /// (feature `oracle`: tests and benches only).
    #[cfg(feature = "oracle")]
    Crate,
}

/// The MCAP writer of a log: ours or the crate's, with the same options.
pub(super) enum ContainerWriter<W: Write + Seek> {
    /// See [`Container::Chunked`].
    Chunked(Box<ChunkWriter<W>>),
    /// See [`Container::Crate`].
    #[cfg(feature = "oracle")]
    Crate(Box<mcap::Writer<W>>),
}

impl<W: Write + Seek> ContainerWriter<W> {
    /// Starts a file: profile `ros2`, zstd chunks of `chunk_size` uncompressed bytes (level
    /// [`ZSTD_LEVEL`] for ours, 1 for the crate's).
    pub(crate) fn new(container: Container, sink: W, library: &str, chunk_size: u64) -> McapResult<Self> {
        Ok(match container {
            Container::Chunked => Self::Chunked(Box::new(ChunkWriter::new(
                sink, "ros2", library, chunk_size, ZSTD_LEVEL,
            )?)),
            Container::ChunkedZstd(level) => Self::Chunked(Box::new(ChunkWriter::new(
                sink, "ros2", library, chunk_size, level,
            )?)),
            #[cfg(feature = "oracle")]
            Container::Crate => Self::Crate(Box::new(
                mcap::WriteOptions::new()
                    .profile("ros2")
                    .library(library)
                    .compression(Some(mcap::Compression::Zstd))
                    .compression_level(1)
                    .compression_threads(0)
                    .chunk_size(Some(chunk_size))
                    .create(sink)?,
            )),
        })
    }

    /// Adds a schema (deduplicated by content); returns its id.
    pub(crate) fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> McapResult<u16> {
        match self {
            Self::Chunked(w) => w.add_schema(name, encoding, data),
            #[cfg(feature = "oracle")]
            Self::Crate(w) => w.add_schema(name, encoding, data),
        }
    }

    /// Adds a channel; returns its id.
    pub(crate) fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        message_encoding: &str,
        metadata: &BTreeMap<String, String>,
    ) -> McapResult<u16> {
        match self {
            Self::Chunked(w) => w.add_channel(schema_id, topic, message_encoding, metadata),
            #[cfg(feature = "oracle")]
            Self::Crate(w) => w.add_channel(schema_id, topic, message_encoding, metadata),
        }
    }

    /// Writes a metadata record (outside any chunk).
    pub(crate) fn write_metadata(&mut self, metadata: &Metadata) -> McapResult<()> {
        match self {
            Self::Chunked(w) => w.write_metadata(metadata),
            #[cfg(feature = "oracle")]
            Self::Crate(w) => w.write_metadata(metadata),
        }
    }

    /// Writes one message on a channel added before.
    pub(crate) fn write_message(&mut self, header: &MessageHeader, data: &[u8]) -> McapResult<()> {
        match self {
            Self::Chunked(w) => w.write_message(header, data),
            #[cfg(feature = "oracle")]
            Self::Crate(w) => w.write_to_known_channel(header, data),
        }
    }

    /// Writes the data end, the summary and the footer; returns the sink.
    pub(crate) fn finish(self) -> McapResult<W> {
        match self {
            Self::Chunked(w) => w.finish(),
            #[cfg(feature = "oracle")]
            Self::Crate(mut w) => {
                w.finish()?;
                Ok(w.into_inner())
            }
        }
    }
}

/// A schema as the summary repeats it.
struct SchemaRec {
    id: u16,
    name: String,
    encoding: String,
    data: Vec<u8>,
}

/// A channel as the summary repeats it.
struct ChannelRec {
    id: u16,
    schema_id: u16,
    topic: String,
    message_encoding: String,
    metadata: BTreeMap<String, String>,
}

/// Writes a chunked, zstd-compressed, indexed MCAP file (see the [module docs](self)).
pub(super) struct ChunkWriter<W: Write + Seek> {
    out: W,
    /// Bytes written to `out` so far: the file offset of the next record.
    pos: u64,
    /// CRC-32 of the data section (from the magic up to the data end record).
    data_crc: crc32fast::Hasher,
    /// Uncompressed size past which the open chunk is closed.
    chunk_size: usize,
    zstd: zstd::bulk::Compressor<'static>,
    /// Records of the open chunk, uncompressed.
    chunk: Vec<u8>,
    /// The compressed chunk (kept to reuse its allocation).
    compressed: Vec<u8>,
    /// Log times of the open chunk's first and last messages (min, max).
    chunk_times: Option<(u64, u64)>,
    /// The open chunk's message index: per channel, (log time, offset in the chunk).
    chunk_messages: BTreeMap<u16, Vec<(u64, u64)>>,
    /// Scratch buffer for records written outside chunks.
    rec: Vec<u8>,
    schemas: Vec<SchemaRec>,
    channels: Vec<ChannelRec>,
    chunk_indexes: Vec<ChunkIndex>,
    metadata_indexes: Vec<MetadataIndex>,
    /// Messages: count, time span, count per channel (the statistics record's other counts are
    /// those of `schemas`, `channels`, `metadata_indexes`, `chunk_indexes`).
    stats: Statistics,
}

impl<W: Write + Seek> ChunkWriter<W> {
    /// Starts a file on `out` (which must be empty): magic and header record.
    pub(crate) fn new(
        out: W,
        profile: &str,
        library: &str,
        chunk_size: u64,
        zstd_level: i32,
    ) -> McapResult<Self> {
        let mut w = Self {
            out,
            pos: 0,
            data_crc: crc32fast::Hasher::new(),
            chunk_size: usize::try_from(chunk_size).unwrap_or(usize::MAX),
            zstd: zstd::bulk::Compressor::new(zstd_level)?,
            chunk: Vec::new(),
            compressed: Vec::new(),
            chunk_times: None,
            chunk_messages: BTreeMap::new(),
            rec: Vec::new(),
            schemas: Vec::new(),
            channels: Vec::new(),
            chunk_indexes: Vec::new(),
            metadata_indexes: Vec::new(),
            stats: Statistics::default(),
        };
        w.emit_data(mcap::MAGIC)?;
        let mut rec = Vec::new();
        record(&mut rec, op::HEADER, |b| {
            put_str(b, profile);
            put_str(b, library);
        });
        w.emit_data(&rec)?;
        w.rec = rec;
        Ok(w)
    }

    /// Writes bytes of the data section.
    fn emit_data(&mut self, bytes: &[u8]) -> McapResult<()> {
        self.out.write_all(bytes)?;
        self.data_crc.update(bytes);
        self.pos += bytes.len() as u64;
        Ok(())
    }

    /// Compresses and writes the open chunk, then its message indexes; nothing if it is empty.
    fn close_chunk(&mut self) -> McapResult<()> {
        if self.chunk.is_empty() {
            return Ok(());
        }
        // A chunk of schemas and channels only (a log closed before its first message) is
        // still written, so that a reader of the data section alone sees the channels.
        let (start, end) = self.chunk_times.take().unwrap_or((0, 0));
        let uncompressed_crc = crc32fast::hash(&self.chunk);
        self.compressed.clear();
        self.compressed
            .reserve(zstd::zstd_safe::compress_bound(self.chunk.len()));
        let n = self
            .zstd
            .compress_to_buffer(&self.chunk[..], &mut self.compressed)?;
        debug_assert_eq!(n, self.compressed.len());
        let chunk_start_offset = self.pos;
        let mut rec = std::mem::take(&mut self.rec);
        rec.clear();
        record(&mut rec, op::CHUNK, |b| {
            put_u64(b, start);
            put_u64(b, end);
            put_u64(b, self.chunk.len() as u64);
            b.extend_from_slice(&uncompressed_crc.to_le_bytes());
            put_str(b, "zstd");
            put_u64(b, self.compressed.len() as u64);
        });
        // The compressed bytes are the record's tail: patch the length, write them unbuffered.
        let len = (rec.len() - 9 + self.compressed.len()) as u64;
        rec[1..9].copy_from_slice(&len.to_le_bytes());
        self.emit_data(&rec)?;
        let compressed = std::mem::take(&mut self.compressed);
        self.emit_data(&compressed)?;
        self.compressed = compressed;
        let chunk_length = self.pos - chunk_start_offset;

        let index_start = self.pos;
        let mut message_index_offsets = BTreeMap::new();
        let messages = std::mem::take(&mut self.chunk_messages);
        for (channel, entries) in &messages {
            message_index_offsets.insert(*channel, self.pos);
            rec.clear();
            record(&mut rec, op::MESSAGE_INDEX, |b| {
                put_u16(b, *channel);
                put_u32(b, (entries.len() * 16) as u32);
                for (t, offset) in entries {
                    put_u64(b, *t);
                    put_u64(b, *offset);
                }
            });
            self.emit_data(&rec)?;
        }
        self.rec = rec;
        self.chunk_indexes.push(ChunkIndex {
            message_start_time: start,
            message_end_time: end,
            chunk_start_offset,
            chunk_length,
            message_index_offsets,
            message_index_length: self.pos - index_start,
            compression: "zstd".into(),
            compressed_size: self.compressed.len() as u64,
            uncompressed_size: self.chunk.len() as u64,
        });
        self.chunk.clear();
        Ok(())
    }

    /// The summary section's records after `summary_start`, and the summary offsets.
    fn summary(&self, summary_start: u64) -> (Vec<u8>, Vec<u8>) {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        let mut group = |out: &mut Vec<u8>, opcode: u8, write: &dyn Fn(&mut Vec<u8>)| {
            let start = out.len();
            write(out);
            if out.len() > start {
                record(&mut offsets, op::SUMMARY_OFFSET, |b| {
                    b.push(opcode);
                    put_u64(b, summary_start + start as u64);
                    put_u64(b, (out.len() - start) as u64);
                });
            }
        };
        group(&mut out, op::SCHEMA, &|b| {
            for s in &self.schemas {
                schema_record(b, s);
            }
        });
        group(&mut out, op::CHANNEL, &|b| {
            for c in &self.channels {
                channel_record(b, c);
            }
        });
        group(&mut out, op::STATISTICS, &|b| {
            let s = &self.stats;
            record(b, op::STATISTICS, |b| {
                put_u64(b, s.message_count);
                // The counts of what the writer holds (ids fit u16, so the counts fit too).
                put_u16(b, self.schemas.len() as u16);
                put_u32(b, self.channels.len() as u32);
                put_u32(b, 0); // attachments: drive-sim writes none
                put_u32(b, self.metadata_indexes.len() as u32);
                put_u32(b, self.chunk_indexes.len() as u32);
                put_u64(b, s.message_start_time);
                put_u64(b, s.message_end_time);
                put_u32(b, (s.channel_message_counts.len() * 10) as u32);
                for (channel, n) in &s.channel_message_counts {
                    put_u16(b, *channel);
                    put_u64(b, *n);
                }
            });
        });
        group(&mut out, op::CHUNK_INDEX, &|b| {
            for c in &self.chunk_indexes {
                record(b, op::CHUNK_INDEX, |b| {
                    put_u64(b, c.message_start_time);
                    put_u64(b, c.message_end_time);
                    put_u64(b, c.chunk_start_offset);
                    put_u64(b, c.chunk_length);
                    put_u32(b, (c.message_index_offsets.len() * 10) as u32);
                    for (channel, offset) in &c.message_index_offsets {
                        put_u16(b, *channel);
                        put_u64(b, *offset);
                    }
                    put_u64(b, c.message_index_length);
                    put_str(b, &c.compression);
                    put_u64(b, c.compressed_size);
                    put_u64(b, c.uncompressed_size);
                });
            }
        });
        group(&mut out, op::METADATA_INDEX, &|b| {
            for m in &self.metadata_indexes {
                record(b, op::METADATA_INDEX, |b| {
                    put_u64(b, m.offset);
                    put_u64(b, m.length);
                    put_str(b, &m.name);
                });
            }
        });
        (out, offsets)
    }
}

impl<W: Write + Seek> ChunkWriter<W> {
    /// Adds a schema (deduplicated by content); returns its id.
    pub(crate) fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> McapResult<u16> {
        if let Some(s) = self
            .schemas
            .iter()
            .find(|s| s.name == name && s.encoding == encoding && s.data == data)
        {
            return Ok(s.id);
        }
        // Schema id 0 means "no schema": ids start at 1.
        let id = u16::try_from(self.schemas.len() + 1).map_err(|_| McapError::TooManySchemas)?;
        let s = SchemaRec {
            id,
            name: name.into(),
            encoding: encoding.into(),
            data: data.to_vec(),
        };
        schema_record(&mut self.chunk, &s);
        self.schemas.push(s);
        Ok(id)
    }

    /// Adds a channel; returns its id.
    pub(crate) fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        message_encoding: &str,
        metadata: &BTreeMap<String, String>,
    ) -> McapResult<u16> {
        if schema_id != 0 && !self.schemas.iter().any(|s| s.id == schema_id) {
            return Err(McapError::UnknownSchema(topic.into(), schema_id));
        }
        // Numbered from 1, as the `mcap` crate numbers them.
        let id = u16::try_from(self.channels.len() + 1).map_err(|_| McapError::TooManyChannels)?;
        let c = ChannelRec {
            id,
            schema_id,
            topic: topic.into(),
            message_encoding: message_encoding.into(),
            metadata: metadata.clone(),
        };
        channel_record(&mut self.chunk, &c);
        self.channels.push(c);
        Ok(id)
    }

    /// Writes a metadata record (outside any chunk).
    pub(crate) fn write_metadata(&mut self, metadata: &Metadata) -> McapResult<()> {
        // Metadata records live outside chunks: close the open one first.
        self.close_chunk()?;
        let offset = self.pos;
        let mut rec = std::mem::take(&mut self.rec);
        rec.clear();
        record(&mut rec, op::METADATA, |b| {
            put_str(b, &metadata.name);
            put_str_map(b, &metadata.metadata);
        });
        self.emit_data(&rec)?;
        self.metadata_indexes.push(MetadataIndex {
            offset,
            length: rec.len() as u64,
            name: metadata.name.clone(),
        });
        self.rec = rec;
        Ok(())
    }

    /// Writes one message on a channel added before.
    pub(crate) fn write_message(&mut self, header: &MessageHeader, data: &[u8]) -> McapResult<()> {
        if header.channel_id == 0 || usize::from(header.channel_id) > self.channels.len() {
            return Err(McapError::UnknownChannel(header.sequence, header.channel_id));
        }
        let t = header.log_time;
        self.chunk_messages
            .entry(header.channel_id)
            .or_default()
            .push((t, self.chunk.len() as u64));
        record(&mut self.chunk, op::MESSAGE, |b| {
            put_u16(b, header.channel_id);
            put_u32(b, header.sequence);
            put_u64(b, header.log_time);
            put_u64(b, header.publish_time);
            b.extend_from_slice(data);
        });
        self.chunk_times = Some(match self.chunk_times {
            None => (t, t),
            Some((a, b)) => (a.min(t), b.max(t)),
        });
        let s = &mut self.stats;
        s.message_start_time = if s.message_count == 0 {
            t
        } else {
            s.message_start_time.min(t)
        };
        s.message_end_time = if s.message_count == 0 {
            t
        } else {
            s.message_end_time.max(t)
        };
        s.message_count += 1;
        *s.channel_message_counts.entry(header.channel_id).or_insert(0) += 1;
        if self.chunk.len() > self.chunk_size {
            self.close_chunk()?;
        }
        Ok(())
    }

    /// Writes the data end, the summary and the footer; returns the sink.
    pub(crate) fn finish(mut self) -> McapResult<W> {
        self.close_chunk()?;
        let data_section_crc = std::mem::replace(&mut self.data_crc, crc32fast::Hasher::new()).finalize();
        let mut rec = std::mem::take(&mut self.rec);
        rec.clear();
        record(&mut rec, op::DATA_END, |b| put_u32(b, data_section_crc));
        self.out.write_all(&rec)?;
        self.pos += rec.len() as u64;

        let summary_start = self.pos;
        let (summary, offsets) = self.summary(summary_start);
        let summary_offset_start = summary_start + summary.len() as u64;
        let mut footer = Vec::with_capacity(summary.len() + offsets.len() + 29);
        footer.extend_from_slice(&summary);
        footer.extend_from_slice(&offsets);
        footer.push(op::FOOTER);
        put_u64(&mut footer, 20);
        put_u64(&mut footer, summary_start);
        put_u64(&mut footer, summary_offset_start);
        // The summary CRC runs from the summary's start through the footer's offset field.
        let summary_crc = crc32fast::hash(&footer);
        put_u32(&mut footer, summary_crc);
        footer.extend_from_slice(mcap::MAGIC);
        self.out.write_all(&footer)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Appends one record: opcode, u64 length, then what `body` writes.
fn record(buf: &mut Vec<u8>, opcode: u8, body: impl FnOnce(&mut Vec<u8>)) {
    buf.push(opcode);
    let at = buf.len();
    buf.extend_from_slice(&[0; 8]);
    body(buf);
    let len = (buf.len() - at - 8) as u64;
    buf[at..at + 8].copy_from_slice(&len.to_le_bytes());
}

fn schema_record(b: &mut Vec<u8>, s: &SchemaRec) {
    record(b, op::SCHEMA, |b| {
        put_u16(b, s.id);
        put_str(b, &s.name);
        put_str(b, &s.encoding);
        put_u32(b, s.data.len() as u32);
        b.extend_from_slice(&s.data);
    });
}

fn channel_record(b: &mut Vec<u8>, c: &ChannelRec) {
    record(b, op::CHANNEL, |b| {
        put_u16(b, c.id);
        put_u16(b, c.schema_id);
        put_str(b, &c.topic);
        put_str(b, &c.message_encoding);
        put_str_map(b, &c.metadata);
    });
}

fn put_u16(b: &mut Vec<u8>, v: u16) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_u32(b: &mut Vec<u8>, v: u32) {
    b.extend_from_slice(&v.to_le_bytes());
}
fn put_u64(b: &mut Vec<u8>, v: u64) {
    b.extend_from_slice(&v.to_le_bytes());
}
/// A string: u32 byte length, UTF-8 bytes.
fn put_str(b: &mut Vec<u8>, s: &str) {
    put_u32(b, s.len() as u32);
    b.extend_from_slice(s.as_bytes());
}
/// A string map: u32 byte length of the entries, then key and value strings in key order.
fn put_str_map(b: &mut Vec<u8>, m: &BTreeMap<String, String>) {
    let len: usize = m.iter().map(|(k, v)| 8 + k.len() + v.len()).sum();
    put_u32(b, len as u32);
    for (k, v) in m {
        put_str(b, k);
        put_str(b, v);
    }
}
