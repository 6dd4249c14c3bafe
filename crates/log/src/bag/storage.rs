//! rosbag2 storage: a bag directory (`metadata.yaml` + files), a sqlite3 `.db3` file or an
//! `.mcap` file, read as raw CDR messages of the topics asked for.
//!
//! Topics nobody asked for are skipped before their payload is touched: the sqlite3 query
//! selects the role topics only (SQLite does not read the blobs of the other rows), and an
//! MCAP file with a summary section is read through its indexes (`mcap_index`): the
//! topic list, counts and time spans come from the summary and the message indexes, and only
//! the role messages are read. An MCAP file without a summary (truncated, or written without
//! one) is streamed whole instead, with a warning saying so.
//!
//! rosbag2 compression (`ros2 bag record --compression-format zstd`) is read in both modes:
//! `file` (each storage file is zstd-compressed whole: a `.db3` is unpacked to a temporary
//! file, since SQLite needs one; an `.mcap` is streamed through the decompressor) and `message`
//! (each message's serialized bytes are zstd-compressed). Other formats are an error.

use super::mcap_index::McapIndex;
use drive_sim_model::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The storage plugins rosbag2 ships and this reader supports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// `sqlite3`: `.db3` files.
    Sqlite3,
    /// `mcap`: `.mcap` files.
    Mcap,
}

impl Storage {
    /// rosbag2's storage identifier.
    pub fn id(self) -> &'static str {
        match self {
            Storage::Sqlite3 => "sqlite3",
            Storage::Mcap => "mcap",
        }
    }
}

/// rosbag2 compression of a bag (`compression_mode` in `metadata.yaml`); only zstd is
/// supported, as `ros2 bag record --compression-format zstd` writes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Not compressed by rosbag2 (an MCAP file's own chunk compression is read as is).
    None,
    /// `file`: every storage file is zstd-compressed whole (`NAME.db3.zstd`, `NAME.mcap.zstd`).
    File,
    /// `message`: every message's serialized bytes are zstd-compressed.
    Message,
}

impl Compression {
    /// As `inspect` shows it.
    pub fn describe(self) -> &'static str {
        match self {
            Compression::None => "none",
            Compression::File => "zstd, file mode",
            Compression::Message => "zstd, message mode",
        }
    }
}

/// One topic of a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicInfo {
    /// Topic name.
    pub name: String,
    /// Message type as recorded, normalised to `pkg/msg/Name`.
    pub msg_type: String,
    /// Serialization format (`cdr`).
    pub encoding: String,
}

/// Message count and time span of one topic.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TopicStats {
    /// Messages.
    pub count: u64,
    /// First receive time, ns since the epoch.
    pub first_ns: u64,
    /// Last receive time, ns since the epoch.
    pub last_ns: u64,
}

/// Receives (index of the topic in the list asked for, receive time ns, CDR payload).
pub type OnMessage<'a> = dyn FnMut(usize, u64, &[u8]) -> Result<()> + 'a;
/// As [`OnMessage`], the index `None` for a topic not asked for.
type OnMaybeMessage<'a> = dyn FnMut(Option<usize>, u64, &[u8]) -> Result<()> + 'a;

/// How one data file of a bag is read.
#[derive(Debug, Clone)]
struct DataFile {
    /// The file as the bag lists it (named in errors).
    shown: PathBuf,
    /// The file to read: `shown`, or its unpacked copy for a file-compressed `.db3`.
    read: PathBuf,
    /// A file-compressed MCAP, streamed through the zstd decompressor.
    zstd_stream: bool,
    /// The MCAP summary and message indexes, when the file has them.
    index: Option<Arc<McapIndex>>,
}

/// An opened bag: where it is, how it is stored, and its topics.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The path the user gave.
    pub path: PathBuf,
    /// Storage plugin.
    pub storage: Storage,
    /// rosbag2 compression.
    pub compression: Compression,
    /// Data files, in recording order.
    pub files: Vec<PathBuf>,
    /// Topics (over all files), by name order.
    pub topics: Vec<TopicInfo>,
    /// How reading differs from the fast path (an MCAP file without a usable summary is
    /// streamed whole); shown with the log's warnings.
    pub warnings: Vec<String>,
    data: Vec<DataFile>,
    /// Counts and time spans found while opening (MCAP: from the indexes, or the streamed scan).
    stats: Option<BTreeMap<String, TopicStats>>,
    /// Unpacked copies of file-compressed `.db3` files, removed with the last clone.
    _unpacked: Option<Arc<tempfile::TempDir>>,
}

/// `pkg/Name` or `pkg/msg/Name` -> `pkg/msg/Name`.
pub fn normalize_type(t: &str) -> String {
    let parts: Vec<&str> = t.split('/').collect();
    match parts.as_slice() {
        [pkg, name] => format!("{pkg}/msg/{name}"),
        _ => t.to_string(),
    }
}

const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
const ZSTD_MAGIC: &[u8] = b"\x28\xb5\x2f\xfd";

fn storage_of_head(head: &[u8]) -> Option<Storage> {
    if head.starts_with(SQLITE_MAGIC) {
        Some(Storage::Sqlite3)
    } else if head.starts_with(MCAP_MAGIC) {
        Some(Storage::Mcap)
    } else {
        None
    }
}

/// The storage of a data file, and whether it is zstd-compressed whole (rosbag2 file mode).
fn storage_of_file(file: &Path) -> Result<(Storage, bool)> {
    use std::io::Read;
    let mut head = [0u8; 16];
    let mut f = std::fs::File::open(file).map_err(|e| Error::io(file, e))?;
    let n = f.read(&mut head).map_err(|e| Error::io(file, e))?;
    if let Some(s) = storage_of_head(&head[..n]) {
        return Ok((s, false));
    }
    if head[..n].starts_with(ZSTD_MAGIC) {
        let f = std::fs::File::open(file).map_err(|e| Error::io(file, e))?;
        let mut inner = Vec::new();
        zstd::stream::Decoder::new(f)
            .and_then(|d| d.take(16).read_to_end(&mut inner))
            .map_err(|e| Error::log(file, "zstd", format!("does not unpack: {e}")))?;
        return match storage_of_head(&inner) {
            Some(s) => Ok((s, true)),
            None => Err(Error::log(
                file,
                "storage",
                "a zstd file holding neither a sqlite3 database nor an MCAP file",
            )),
        };
    }
    Err(Error::log(
        file,
        "storage",
        "neither a sqlite3 database nor an MCAP file (the rosbag2 storages this reader supports), \
         nor one compressed with zstd",
    ))
}

/// What `metadata.yaml` says about the storage.
struct Metadata {
    storage: Storage,
    compression: Compression,
    files: Vec<PathBuf>,
}

fn read_metadata_yaml(dir: &Path) -> Result<Metadata> {
    let file = dir.join("metadata.yaml");
    let text = std::fs::read_to_string(&file).map_err(|e| Error::io(&file, e))?;
    let docs =
        yaml_rust2::YamlLoader::load_from_str(&text).map_err(|e| Error::log(&file, "YAML", e.to_string()))?;
    let info = docs
        .first()
        .map(|d| &d["rosbag2_bagfile_information"])
        .filter(|i| !i.is_badvalue())
        .ok_or_else(|| {
            Error::log(
                &file,
                "rosbag2_bagfile_information",
                "missing: not a rosbag2 metadata file",
            )
        })?;
    let storage = match info["storage_identifier"].as_str() {
        Some("sqlite3") => Storage::Sqlite3,
        Some("mcap") => Storage::Mcap,
        Some(other) => {
            return Err(Error::log(
                &file,
                "storage_identifier",
                format!("`{other}` is not supported; expected `sqlite3` or `mcap`"),
            ))
        }
        None => return Err(Error::log(&file, "storage_identifier", "missing")),
    };
    let format = info["compression_format"].as_str().unwrap_or("");
    let mode = info["compression_mode"].as_str().unwrap_or("");
    let compression = match (format, mode.to_ascii_lowercase().as_str()) {
        ("", _) | (_, "none") => Compression::None,
        ("zstd", "file") => Compression::File,
        ("zstd", "message") => Compression::Message,
        ("zstd", other) => {
            return Err(Error::log(
                &file,
                "compression_mode",
                format!("`{other}` is not a rosbag2 compression mode; expected `file` or `message`"),
            ))
        }
        (other, _) => {
            return Err(Error::log(
                &file,
                "compression_format",
                format!(
                    "`{other}` (mode {mode}) is not supported; supported: `zstd` in `file` or \
                     `message` mode, or an uncompressed bag (`ros2 bag convert` writes one)"
                ),
            ))
        }
    };
    let files: Vec<PathBuf> = info["relative_file_paths"]
        .as_vec()
        .map(|v| v.iter().filter_map(|p| p.as_str()).map(|p| dir.join(p)).collect())
        .unwrap_or_default();
    if files.is_empty() {
        return Err(Error::log(&file, "relative_file_paths", "no data file listed"));
    }
    for f in &files {
        if !f.is_file() {
            return Err(Error::log(
                &file,
                "relative_file_paths",
                format!("{} does not exist", f.display()),
            ));
        }
    }
    Ok(Metadata {
        storage,
        compression,
        files,
    })
}

/// The compression `metadata.yaml` beside a data file declares for it, if any.
fn sibling_compression(file: &Path) -> Option<Compression> {
    let dir = file.parent()?;
    let m = read_metadata_yaml(dir).ok()?;
    let name = file.file_name()?;
    m.files
        .iter()
        .any(|f| f.file_name() == Some(name))
        .then_some(m.compression)
}

impl Bag {
    /// Opens a bag directory, a `.db3` or a rosbag2 `.mcap` file (either possibly
    /// zstd-compressed whole) and lists its topics.
    pub fn open(path: &Path) -> Result<Bag> {
        let (storage, compression, files) = if path.is_dir() {
            if path.join("metadata.yaml").is_file() {
                let m = read_metadata_yaml(path)?;
                (m.storage, m.compression, m.files)
            } else {
                return Err(Error::log(
                    path,
                    "metadata.yaml",
                    "missing: a rosbag2 directory has one (or pass the .db3 / .mcap file itself)",
                ));
            }
        } else {
            let (storage, zstd) = storage_of_file(path)?;
            let compression = if zstd {
                Compression::File
            } else {
                sibling_compression(path)
                    .filter(|c| *c == Compression::Message)
                    .unwrap_or(Compression::None)
            };
            (storage, compression, vec![path.to_path_buf()])
        };
        let mut unpacked: Option<tempfile::TempDir> = None;
        let mut warnings = Vec::new();
        let mut data = Vec::new();
        let mut stats: BTreeMap<String, TopicStats> = BTreeMap::new();
        let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for f in &files {
            let (found, zstd) = storage_of_file(f)?;
            if found != storage {
                return Err(Error::log(
                    f,
                    "storage",
                    format!("a {} file in a bag of storage {}", found.id(), storage.id()),
                ));
            }
            if zstd && compression != Compression::File {
                return Err(Error::log(
                    f,
                    "compression",
                    "compressed with zstd, but metadata.yaml declares no file compression",
                ));
            }
            let mut d = DataFile {
                shown: f.clone(),
                read: f.clone(),
                zstd_stream: false,
                index: None,
            };
            let list = match storage {
                Storage::Sqlite3 => {
                    if zstd {
                        if unpacked.is_none() {
                            unpacked =
                                Some(tempfile::tempdir().map_err(|e| Error::io(std::env::temp_dir(), e))?);
                        }
                        let dir = unpacked.as_ref().expect("just made").path();
                        d.read = dir.join(format!("{}.db3", data.len()));
                        unpack(f, &d.read)?;
                    }
                    sqlite_topics(&d.read, f)?
                }
                Storage::Mcap => {
                    d.zstd_stream = zstd;
                    let index = if zstd {
                        None
                    } else {
                        match McapIndex::open(f)? {
                            Ok(i) => Some(i),
                            Err(why) => {
                                warnings.push(format!(
                                    "{}: no usable MCAP index, {why}: the whole file is streamed \
                                     (every chunk read and checked) instead of reading the role \
                                     messages only",
                                    f.display()
                                ));
                                None
                            }
                        }
                    };
                    match index {
                        Some(i) => {
                            for (name, s) in i.stats() {
                                add_stats(&mut stats, &name, s);
                            }
                            let t = i.topics();
                            d.index = Some(Arc::new(i));
                            t
                        }
                        None => {
                            let (list, r) = mcap_scan(&d, &mut stats);
                            match r {
                                // Nothing to show: the error is the whole story.
                                Err(e) if list.is_empty() => return Err(e),
                                // A damaged file still lists what came before the damage;
                                // reading its messages fails there again, with this error.
                                Err(e) => warnings.push(format!("{e}: its topics and counts stop there")),
                                Ok(()) => {}
                            }
                            list
                        }
                    }
                }
            };
            for t in list {
                if let Some(old) = topics.get(&t.name) {
                    if old.msg_type != t.msg_type {
                        return Err(Error::log(
                            f,
                            format!("topic {}", t.name),
                            format!("type {} here, {} in an earlier file", t.msg_type, old.msg_type),
                        ));
                    }
                }
                topics.insert(t.name.clone(), t);
            }
            data.push(d);
        }
        Ok(Bag {
            path: path.to_path_buf(),
            storage,
            compression,
            files,
            topics: topics.into_values().collect(),
            warnings,
            data,
            stats: (storage == Storage::Mcap).then_some(stats),
            _unpacked: unpacked.map(Arc::new),
        })
    }

    /// The topic called `name`.
    pub fn topic(&self, name: &str) -> Option<&TopicInfo> {
        self.topics.iter().find(|t| t.name == name)
    }

    /// Calls `f(index in wanted, receive time ns, CDR payload)` for every message of the
    /// `wanted` topics, file by file. Other topics are not decoded (nor, from an MCAP file with
    /// a summary, read). Messages of message-compressed bags arrive unpacked.
    pub fn read(&self, wanted: &[&str], f: &mut OnMessage<'_>) -> Result<()> {
        let message_mode = self.compression == Compression::Message;
        for d in &self.data {
            let mut buf = Vec::new();
            let mut g = |i: usize, t: u64, data: &[u8]| -> Result<()> {
                if !message_mode {
                    return f(i, t, data);
                }
                buf.clear();
                zstd::stream::copy_decode(data, &mut buf).map_err(|e| {
                    Error::log(
                        &d.shown,
                        format!("topic {} message at t = {:.9} s (epoch)", wanted[i], t as f64 * 1e-9),
                        format!("does not unpack as zstd, as metadata.yaml's compression_mode `message` says: {e}"),
                    )
                })?;
                f(i, t, &buf)
            };
            match (self.storage, &d.index) {
                (Storage::Sqlite3, _) => sqlite_read(&d.read, &d.shown, wanted, &mut g)?,
                (Storage::Mcap, Some(index)) => index.read(&d.shown, wanted, &mut g)?,
                (Storage::Mcap, None) => {
                    mcap_read(d, Some(wanted), &mut |i, t, data| match i {
                        Some(i) => g(i, t, data),
                        None => Ok(()),
                    })
                    .1?
                }
            }
        }
        Ok(())
    }

    /// Message count and time span of every topic (no payload decoded; for MCAP, found when
    /// the bag was opened).
    pub fn stats(&self) -> Result<BTreeMap<String, TopicStats>> {
        if let Some(s) = &self.stats {
            return Ok(s.clone());
        }
        let mut out: BTreeMap<String, TopicStats> = BTreeMap::new();
        for d in &self.data {
            let (file, shown) = (&d.read, &d.shown);
            let db = sqlite_open(file, shown)?;
            let mut q = db
                .prepare(
                    "SELECT t.name, COUNT(*), MIN(m.timestamp), MAX(m.timestamp) \
                     FROM messages m JOIN topics t ON t.id = m.topic_id GROUP BY m.topic_id",
                )
                .map_err(|e| sqlite_err(shown, "messages", e))?;
            let rows = q
                .query_map([], |r| {
                    Ok((
                        r.get::<_, String>(0)?,
                        r.get::<_, i64>(1)?,
                        r.get::<_, i64>(2)?,
                        r.get::<_, i64>(3)?,
                    ))
                })
                .map_err(|e| sqlite_err(shown, "messages", e))?;
            for row in rows {
                let (name, n, a, b) = row.map_err(|e| sqlite_err(shown, "messages", e))?;
                add_stats(
                    &mut out,
                    &name,
                    TopicStats {
                        count: n.max(0) as u64,
                        first_ns: a.max(0) as u64,
                        last_ns: b.max(0) as u64,
                    },
                );
            }
        }
        Ok(out)
    }
}

fn add_stats(out: &mut BTreeMap<String, TopicStats>, name: &str, s: TopicStats) {
    let e = out.entry(name.to_string()).or_insert(TopicStats {
        count: 0,
        first_ns: s.first_ns,
        last_ns: s.last_ns,
    });
    e.count += s.count;
    e.first_ns = e.first_ns.min(s.first_ns);
    e.last_ns = e.last_ns.max(s.last_ns);
}

/// Unpacks a file-compressed (zstd) storage file to `to`.
fn unpack(from: &Path, to: &Path) -> Result<()> {
    let src = std::fs::File::open(from).map_err(|e| Error::io(from, e))?;
    let dst = std::fs::File::create(to).map_err(|e| Error::io(to, e))?;
    zstd::stream::copy_decode(src, std::io::BufWriter::new(dst)).map_err(|e| {
        Error::log(
            from,
            "zstd",
            format!("does not unpack ({e}): a truncated or damaged compressed file?"),
        )
    })
}

fn sqlite_err(file: &Path, what: &str, e: rusqlite::Error) -> Error {
    Error::log(
        file,
        format!("sqlite3 {what}"),
        format!("{e} (a truncated or damaged .db3, or not a rosbag2 database)"),
    )
}

/// Opens `file` read-only; errors name `shown` (the bag's file, when `file` is its unpacked copy).
fn sqlite_open(file: &Path, shown: &Path) -> Result<rusqlite::Connection> {
    use rusqlite::OpenFlags;
    rusqlite::Connection::open_with_flags(
        file,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| sqlite_err(shown, "open", e))
}

fn sqlite_topics(file: &Path, shown: &Path) -> Result<Vec<TopicInfo>> {
    let db = sqlite_open(file, shown)?;
    let mut q = db
        .prepare("SELECT name, type, serialization_format FROM topics")
        .map_err(|e| sqlite_err(shown, "topics table", e))?;
    let rows = q
        .query_map([], |r| {
            Ok(TopicInfo {
                name: r.get(0)?,
                msg_type: normalize_type(&r.get::<_, String>(1)?),
                encoding: r.get(2)?,
            })
        })
        .map_err(|e| sqlite_err(shown, "topics table", e))?;
    rows.collect::<rusqlite::Result<Vec<_>>>()
        .map_err(|e| sqlite_err(shown, "topics table", e))
}

fn sqlite_read(file: &Path, shown: &Path, wanted: &[&str], f: &mut OnMessage<'_>) -> Result<()> {
    let db = sqlite_open(file, shown)?;
    // topic id -> index in `wanted`
    let mut ids: BTreeMap<i64, usize> = BTreeMap::new();
    {
        let mut q = db
            .prepare("SELECT id, name FROM topics")
            .map_err(|e| sqlite_err(shown, "topics table", e))?;
        let rows = q
            .query_map([], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?)))
            .map_err(|e| sqlite_err(shown, "topics table", e))?;
        for row in rows {
            let (id, name) = row.map_err(|e| sqlite_err(shown, "topics table", e))?;
            if let Some(i) = wanted.iter().position(|w| *w == name) {
                ids.insert(id, i);
            }
        }
    }
    if ids.is_empty() {
        return Ok(());
    }
    let list: Vec<String> = ids.keys().map(|i| i.to_string()).collect();
    // Only the role topics' rows are fetched: the other topics' blobs (point clouds) stay on disk.
    let sql = format!(
        "SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({}) ORDER BY timestamp, id",
        list.join(",")
    );
    let mut q = db
        .prepare(&sql)
        .map_err(|e| sqlite_err(shown, "messages table", e))?;
    let mut rows = q.query([]).map_err(|e| sqlite_err(shown, "messages table", e))?;
    let mut n = 0u64;
    while let Some(r) = rows
        .next()
        .map_err(|e| sqlite_err(shown, &format!("messages table after {n} role messages"), e))?
    {
        let id: i64 = r.get(0).map_err(|e| sqlite_err(shown, "messages.topic_id", e))?;
        let t: i64 = r.get(1).map_err(|e| sqlite_err(shown, "messages.timestamp", e))?;
        let data = r
            .get_ref(2)
            .and_then(|v| v.as_blob().map_err(Into::into))
            .map_err(|e| sqlite_err(shown, "messages.data", e))?;
        n += 1;
        if let Some(&i) = ids.get(&id) {
            f(i, t.max(0) as u64, data)?;
        }
    }
    Ok(())
}

/// Lists the topics of an MCAP file by streaming it whole, counting every topic's messages on
/// the way. Channels come before their first message, and reading stops at the first problem:
/// a truncated file still lists the topics it reached, with the error.
fn mcap_scan(d: &DataFile, stats: &mut BTreeMap<String, TopicStats>) -> (Vec<TopicInfo>, Result<()>) {
    let mut per_channel: BTreeMap<usize, TopicStats> = BTreeMap::new();
    let (channels, r) = mcap_read(d, None, &mut |i, t, _| {
        if let Some(i) = i {
            add_stats_idx(&mut per_channel, i, t);
        }
        Ok(())
    });
    for (i, s) in per_channel {
        add_stats(stats, &channels[i].0, s);
    }
    let out = channels
        .into_iter()
        .map(|(name, ty, enc)| TopicInfo {
            name,
            msg_type: normalize_type(&ty),
            encoding: enc,
        })
        .collect();
    (out, r)
}

fn add_stats_idx(m: &mut BTreeMap<usize, TopicStats>, i: usize, t: u64) {
    let e = m.entry(i).or_insert(TopicStats {
        count: 0,
        first_ns: t,
        last_ns: t,
    });
    e.count += 1;
    e.first_ns = e.first_ns.min(t);
    e.last_ns = e.last_ns.max(t);
}

/// Streams an MCAP file (through the zstd decompressor for a file-compressed one). With
/// `wanted`, calls `f(Some(index in wanted), time, data)` for messages of wanted channels and
/// skips the others without a copy; without, calls `f(Some(index in the returned channels),
/// time, &[])` for every message (counting). Returns the channels seen, (topic, schema name,
/// encoding), even when reading stopped at an error.
fn mcap_read(
    d: &DataFile,
    wanted: Option<&[&str]>,
    f: &mut OnMaybeMessage<'_>,
) -> (Vec<(String, String, String)>, Result<()>) {
    use mcap::records::Record;
    let file = &d.shown;
    // Streamed from the file: a bag of point clouds is never held in memory.
    let src: Box<dyn std::io::Read> = match std::fs::File::open(&d.read) {
        Ok(f) if d.zstd_stream => match zstd::stream::Decoder::new(f) {
            Ok(z) => Box::new(z),
            Err(e) => return (Vec::new(), Err(Error::io(file, e))),
        },
        Ok(f) => Box::new(std::io::BufReader::with_capacity(1 << 20, f)),
        Err(e) => return (Vec::new(), Err(Error::io(file, e))),
    };
    let mut schemas: BTreeMap<u16, String> = BTreeMap::new();
    let mut channels: BTreeMap<u16, Option<usize>> = BTreeMap::new();
    let mut seen = Vec::new();
    let mut messages = 0u64;
    let mut records = 0u64;
    let mut result = Ok(());
    let r = crate::mcap::read::for_each_record(src, &mut |rec| {
        records += 1;
        match rec {
            Record::Schema { header, .. } => {
                schemas.insert(header.id, header.name.clone());
            }
            Record::Channel(c) => {
                let ty = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                let idx = match wanted {
                    Some(w) => w.iter().position(|t| *t == c.topic),
                    None => Some(seen.len()),
                };
                seen.push((c.topic.clone(), ty, c.message_encoding.clone()));
                channels.insert(c.id, idx);
            }
            Record::Message { header, data } => {
                messages += 1;
                if let Some(Some(idx)) = channels.get(&header.channel_id) {
                    let data: &[u8] = if wanted.is_some() { &data } else { &[] };
                    if let Err(e) = f(Some(*idx), header.log_time, data) {
                        result = Err(e);
                        return false;
                    }
                }
            }
            _ => {}
        }
        true
    });
    if let Err(e) = r {
        result = Err(Error::log(
            file,
            format!("MCAP record {records} (after {messages} messages)"),
            format!("{e} (a truncated or damaged file?)"),
        ));
    }
    (seen, result)
}
