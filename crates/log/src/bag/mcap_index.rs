//! Indexed reading of a rosbag2 MCAP file: the summary section gives the topics, and the
//! chunk and message indexes give each topic's count and time span and where every message
//! lies, so the role topics are read without scanning the data section.
//!
//! A chunk holding no role message is never read. Inside an uncompressed chunk only the role
//! messages are read (the byte ranges the message indexes point to, neighbours merged into one
//! read), so large messages of other topics (point clouds, images) are never read at all. A
//! compressed chunk (zstd, lz4: MCAP's own chunk compression) is read whole and unpacked by
//! the `mcap` crate, with its CRC checked. The role messages of an uncompressed chunk are not
//! CRC-checked (the chunk's CRC covers the whole chunk); their CDR decoding checks their shape.

use crate::mcap::read::RECORD_LENGTH_LIMIT;
use drive_sim_model::error::{Error, Result};
use mcap::records::{ChunkIndex, MessageIndexEntry, Record};
use std::collections::BTreeMap;
use std::os::unix::fs::FileExt;
use std::path::Path;

use super::storage::{OnMessage, TopicInfo, TopicStats};

/// Two role messages closer than this in an uncompressed chunk are read with one read.
const MERGE_GAP: u64 = 16 << 10;

/// The summary and message indexes of one MCAP file.
#[derive(Debug, Clone)]
pub(crate) struct McapIndex {
    /// Topics by channel id: (topic, schema name, message encoding).
    pub channels: BTreeMap<u16, (String, String, String)>,
    /// Chunks in time order, each with its message indexes by channel id.
    chunks: Vec<(ChunkIndex, BTreeMap<u16, Vec<MessageIndexEntry>>)>,
}

/// Why a file has no usable index (the reader then streams the whole file).
pub(crate) type NoIndex = String;

fn read_at(file: &std::fs::File, path: &Path, offset: u64, len: u64, what: &str) -> Result<Vec<u8>> {
    if len > RECORD_LENGTH_LIMIT as u64 {
        return Err(Error::log(
            path,
            format!("MCAP {what} at byte {offset}"),
            format!("{len} bytes long, more than the {RECORD_LENGTH_LIMIT}-byte limit (a damaged index?)"),
        ));
    }
    let mut buf = vec![0u8; len as usize];
    file.read_exact_at(&mut buf, offset).map_err(|e| {
        Error::log(
            path,
            format!("MCAP {what} at byte {offset} ({len} bytes)"),
            format!("{e} (a truncated file, or an index that points past its end)"),
        )
    })?;
    Ok(buf)
}

impl McapIndex {
    /// Reads the summary section and every chunk's message indexes; `Ok(Err(why))` when the
    /// file has no usable index (no summary, a truncated file, chunks without message indexes).
    pub(crate) fn open(path: &Path) -> Result<std::result::Result<McapIndex, NoIndex>> {
        use mcap::sans_io::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
        use std::io::{Read, Seek};
        let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut reader = SummaryReader::new_with_options(
            SummaryReaderOptions::default()
                .with_file_size(len)
                .with_record_length_limit(RECORD_LENGTH_LIMIT),
        );
        while let Some(event) = reader.next_event() {
            let step = match event {
                Ok(SummaryReadEvent::ReadRequest(n)) => {
                    f.read(reader.insert(n)).map(|r| reader.notify_read(r))
                }
                Ok(SummaryReadEvent::SeekRequest(to)) => f.seek(to).map(|p| reader.notify_seeked(p)),
                Err(e) => {
                    return Ok(Err(format!(
                        "its summary section does not read ({e}): truncated or damaged?"
                    )))
                }
            };
            step.map_err(|e| Error::io(path, e))?;
        }
        let Some(summary) = reader.finish() else {
            return Ok(Err("it has no summary section (written without one)".into()));
        };
        let n_chunks = summary.stats.as_ref().map_or(0, |s| s.chunk_count as usize);
        if summary.chunk_indexes.is_empty() && n_chunks > 0 {
            return Ok(Err("its summary has no chunk indexes".into()));
        }
        let mut channels = BTreeMap::new();
        for (id, c) in &summary.channels {
            let schema = c.schema.as_ref().map(|s| s.name.clone()).unwrap_or_default();
            channels.insert(*id, (c.topic.clone(), schema, c.message_encoding.clone()));
        }
        let mut chunk_indexes = summary.chunk_indexes.clone();
        chunk_indexes.sort_by_key(|c| (c.message_start_time, c.chunk_start_offset));
        let mut chunks = Vec::with_capacity(chunk_indexes.len());
        for ci in chunk_indexes {
            if ci.message_index_offsets.is_empty() && ci.message_index_length == 0 {
                return Ok(Err(format!(
                    "the chunk at byte {} has no message indexes",
                    ci.chunk_start_offset
                )));
            }
            let start = ci.chunk_start_offset.saturating_add(ci.chunk_length);
            if start.saturating_add(ci.message_index_length) > len {
                return Ok(Err(format!(
                    "the message indexes of the chunk at byte {} lie past the end of the file",
                    ci.chunk_start_offset
                )));
            }
            let buf = read_at(&f, path, start, ci.message_index_length, "message indexes")?;
            let mut by_channel: BTreeMap<u16, Vec<MessageIndexEntry>> = BTreeMap::new();
            for rec in mcap::read::LinearReader::sans_magic(&buf) {
                match rec {
                    Ok(Record::MessageIndex(m)) => {
                        by_channel.entry(m.channel_id).or_default().extend(m.records);
                    }
                    Ok(_) => {}
                    Err(e) => {
                        return Err(Error::log(
                            path,
                            format!("MCAP message indexes at byte {start}"),
                            format!("{e} (a damaged file?)"),
                        ))
                    }
                }
            }
            for ch in ci.message_index_offsets.keys() {
                if !by_channel.contains_key(ch) {
                    return Ok(Err(format!(
                        "the chunk at byte {} lists channel {ch} without its message index",
                        ci.chunk_start_offset
                    )));
                }
            }
            chunks.push((ci, by_channel));
        }
        Ok(Ok(McapIndex { channels, chunks }))
    }

    /// The topics, one per channel.
    pub(crate) fn topics(&self) -> Vec<TopicInfo> {
        self.channels
            .values()
            .map(|(name, ty, enc)| TopicInfo {
                name: name.clone(),
                msg_type: super::storage::normalize_type(ty),
                encoding: enc.clone(),
            })
            .collect()
    }

    /// Count and time span of every topic, from the message indexes.
    pub(crate) fn stats(&self) -> BTreeMap<String, TopicStats> {
        let mut out: BTreeMap<String, TopicStats> = BTreeMap::new();
        for (_, by_channel) in &self.chunks {
            for (ch, entries) in by_channel {
                let Some((topic, _, _)) = self.channels.get(ch) else {
                    continue;
                };
                let Some(lo) = entries.iter().map(|e| e.log_time).min() else {
                    continue;
                };
                let hi = entries.iter().map(|e| e.log_time).max().unwrap_or(lo);
                let e = out.entry(topic.clone()).or_insert(TopicStats {
                    count: 0,
                    first_ns: lo,
                    last_ns: hi,
                });
                e.count += entries.len() as u64;
                e.first_ns = e.first_ns.min(lo);
                e.last_ns = e.last_ns.max(hi);
            }
        }
        out
    }

    /// Calls `f(index in wanted, log time ns, payload)` for every message of the `wanted`
    /// topics; chunks without one are not read, and only the wanted messages of an
    /// uncompressed chunk are.
    pub(crate) fn read(&self, path: &Path, wanted: &[&str], f: &mut OnMessage<'_>) -> Result<()> {
        let want: BTreeMap<u16, usize> = self
            .channels
            .iter()
            .filter_map(|(id, (topic, _, _))| wanted.iter().position(|w| w == topic).map(|i| (*id, i)))
            .collect();
        if want.is_empty() {
            return Ok(());
        }
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        for (ci, by_channel) in &self.chunks {
            if !by_channel.keys().any(|c| want.contains_key(c)) {
                continue;
            }
            if ci.compression.is_empty() {
                read_uncompressed(&file, path, ci, by_channel, &want, f)?;
            } else {
                read_compressed(&file, path, ci, &want, f)?;
            }
        }
        Ok(())
    }
}

fn bad_chunk(path: &Path, ci: &ChunkIndex, m: impl Into<String>) -> Error {
    Error::log(path, format!("MCAP chunk at byte {}", ci.chunk_start_offset), m)
}

/// Reads the wanted messages of an uncompressed chunk at the offsets its message indexes give.
fn read_uncompressed(
    file: &std::fs::File,
    path: &Path,
    ci: &ChunkIndex,
    by_channel: &BTreeMap<u16, Vec<MessageIndexEntry>>,
    want: &BTreeMap<u16, usize>,
    f: &mut OnMessage<'_>,
) -> Result<()> {
    let base = ci
        .compressed_data_offset()
        .map_err(|e| bad_chunk(path, ci, e.to_string()))?;
    let size = ci.uncompressed_size;
    // Every message's offset in the chunk, to bound each wanted one by the next message.
    let mut all: Vec<(u64, Option<u16>)> = Vec::new();
    for (ch, entries) in by_channel {
        let keep = want.contains_key(ch).then_some(*ch);
        all.extend(entries.iter().map(|e| (e.offset, keep)));
    }
    all.sort_unstable();
    // (start, end, channel) of each wanted message; end bounds the record, its header says more.
    let mut spans: Vec<(u64, u64, u16)> = Vec::new();
    for (k, &(off, keep)) in all.iter().enumerate() {
        let end = all.get(k + 1).map_or(size, |n| n.0);
        if off >= end || end > size {
            return Err(bad_chunk(
                path,
                ci,
                format!("a message index points at offset {off}, outside the chunk's {size} bytes"),
            ));
        }
        if let Some(ch) = keep {
            spans.push((off, end, ch));
        }
    }
    let mut k = 0;
    while k < spans.len() {
        // One read for a run of wanted messages with small gaps between them.
        let mut j = k;
        while j + 1 < spans.len() && spans[j + 1].0 - spans[j].1 <= MERGE_GAP {
            j += 1;
        }
        let (lo, hi) = (spans[k].0, spans[j].1);
        let buf = read_at(file, path, base.saturating_add(lo), hi - lo, "chunk messages")?;
        for &(off, end, ch) in &spans[k..=j] {
            let rec = &buf[(off - lo) as usize..(end - lo) as usize];
            let bad = |m: String| bad_chunk(path, ci, format!("record at chunk offset {off}: {m}"));
            if rec.len() < 9 || rec[0] != mcap::records::op::MESSAGE {
                return Err(bad(
                    "not a message record, though a message index points at it".into()
                ));
            }
            let n = u64::from_le_bytes(rec[1..9].try_into().expect("8 bytes"));
            if n > (rec.len() - 9) as u64 {
                return Err(bad(format!(
                    "{n} bytes long, more than the {} up to the next message",
                    rec.len() - 9
                )));
            }
            match mcap::parse_record(rec[0], &rec[9..9 + n as usize]) {
                Ok(Record::Message { header, data }) if header.channel_id == ch => {
                    f(want[&ch], header.log_time, &data)?;
                }
                Ok(Record::Message { header, .. }) => {
                    return Err(bad(format!(
                        "on channel {}, its message index says channel {ch}",
                        header.channel_id
                    )))
                }
                Ok(_) => return Err(bad("not a message record".into())),
                Err(e) => return Err(bad(e.to_string())),
            }
        }
        k = j + 1;
    }
    Ok(())
}

/// Reads a compressed chunk whole and passes on its wanted messages.
fn read_compressed(
    file: &std::fs::File,
    path: &Path,
    ci: &ChunkIndex,
    want: &BTreeMap<u16, usize>,
    f: &mut OnMessage<'_>,
) -> Result<()> {
    if ci.uncompressed_size > RECORD_LENGTH_LIMIT as u64 {
        return Err(bad_chunk(
            path,
            ci,
            format!(
                "unpacks to {} bytes, more than the {RECORD_LENGTH_LIMIT}-byte limit",
                ci.uncompressed_size
            ),
        ));
    }
    let buf = read_at(file, path, ci.chunk_start_offset, ci.chunk_length, "chunk")?;
    if buf.len() < 9 || buf[0] != mcap::records::op::CHUNK {
        return Err(bad_chunk(
            path,
            ci,
            "the chunk index does not point at a chunk record",
        ));
    }
    let (header, data) = match mcap::parse_record(buf[0], &buf[9..]) {
        Ok(Record::Chunk { header, data }) => (header, data),
        Ok(_) => return Err(bad_chunk(path, ci, "not a chunk record")),
        Err(e) => return Err(bad_chunk(path, ci, e.to_string())),
    };
    let compression = header.compression.clone();
    let reader = mcap::read::ChunkReader::new(header, &data).map_err(|e| {
        bad_chunk(
            path,
            ci,
            format!("compression `{compression}`: {e} (MCAP chunks may be zstd, lz4 or uncompressed)"),
        )
    })?;
    for rec in reader {
        match rec {
            Ok(Record::Message { header, data }) => {
                if let Some(&i) = want.get(&header.channel_id) {
                    f(i, header.log_time, &data)?;
                }
            }
            Ok(_) => {}
            Err(e) => return Err(bad_chunk(path, ci, format!("{compression} chunk: {e}"))),
        }
    }
    Ok(())
}
