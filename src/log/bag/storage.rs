//! rosbag2 storage: a bag directory (`metadata.yaml` + files), a sqlite3 `.db3` file or an
//! `.mcap` file, read as raw CDR messages of the topics asked for.
//!
//! Topics nobody asked for are skipped before their payload is touched: the sqlite3 query
//! selects the role topics only (SQLite does not read the blobs of the other rows), and the
//! MCAP reader drops other channels' messages without decoding them.

use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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

/// An opened bag: where it is, how it is stored, and its topics.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The path the user gave.
    pub path: PathBuf,
    /// Storage plugin.
    pub storage: Storage,
    /// Data files, in recording order.
    pub files: Vec<PathBuf>,
    /// Topics (over all files), by name order.
    pub topics: Vec<TopicInfo>,
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

fn storage_of_file(file: &Path) -> Result<Storage> {
    use std::io::Read;
    let mut head = [0u8; 16];
    let mut f = std::fs::File::open(file).map_err(|e| Error::io(file, e))?;
    let n = f.read(&mut head).map_err(|e| Error::io(file, e))?;
    if head[..n].starts_with(SQLITE_MAGIC) {
        Ok(Storage::Sqlite3)
    } else if head[..n].starts_with(MCAP_MAGIC) {
        Ok(Storage::Mcap)
    } else {
        Err(Error::log(
            file,
            "storage",
            "neither a sqlite3 database nor an MCAP file (the rosbag2 storages this reader supports)",
        ))
    }
}

/// What `metadata.yaml` says about the storage.
fn read_metadata_yaml(dir: &Path) -> Result<(Storage, Vec<PathBuf>)> {
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
    let compression = info["compression_format"].as_str().unwrap_or("");
    if !compression.is_empty() {
        let mode = info["compression_mode"].as_str().unwrap_or("?");
        return Err(Error::log(
            &file,
            "compression_format",
            format!(
                "`{compression}` (mode {mode}) is not supported; expected an uncompressed bag \
                 (`ros2 bag convert` or `ros2 bag decompress` writes one)"
            ),
        ));
    }
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
    Ok((storage, files))
}

impl Bag {
    /// Opens a bag directory, a `.db3` or a rosbag2 `.mcap` file and lists its topics.
    pub fn open(path: &Path) -> Result<Bag> {
        let (storage, files) = if path.is_dir() {
            if path.join("metadata.yaml").is_file() {
                read_metadata_yaml(path)?
            } else {
                return Err(Error::log(
                    path,
                    "metadata.yaml",
                    "missing: a rosbag2 directory has one (or pass the .db3 / .mcap file itself)",
                ));
            }
        } else {
            (storage_of_file(path)?, vec![path.to_path_buf()])
        };
        let mut topics: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for f in &files {
            let list = match storage {
                Storage::Sqlite3 => sqlite_topics(f)?,
                Storage::Mcap => mcap_topics(f)?,
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
        }
        Ok(Bag {
            path: path.to_path_buf(),
            storage,
            files,
            topics: topics.into_values().collect(),
        })
    }

    /// The topic called `name`.
    pub fn topic(&self, name: &str) -> Option<&TopicInfo> {
        self.topics.iter().find(|t| t.name == name)
    }

    /// Calls `f(index in wanted, receive time ns, CDR payload)` for every message of the
    /// `wanted` topics, file by file, in each file's time order. Other topics are not decoded.
    pub fn read(&self, wanted: &[&str], f: &mut OnMessage<'_>) -> Result<()> {
        for file in &self.files {
            match self.storage {
                Storage::Sqlite3 => sqlite_read(file, wanted, f)?,
                Storage::Mcap => {
                    mcap_read(file, Some(wanted), &mut |i, t, d| match i {
                        Some(i) => f(i, t, d),
                        None => Ok(()),
                    })
                    .1?
                }
            }
        }
        Ok(())
    }

    /// Message count and time span of every topic (no payload decoded).
    pub fn stats(&self) -> Result<BTreeMap<String, TopicStats>> {
        let mut out: BTreeMap<String, TopicStats> = BTreeMap::new();
        let mut add = |name: &str, _t: u64, n: u64, first: u64, last: u64| {
            let e = out.entry(name.to_string()).or_insert(TopicStats {
                count: 0,
                first_ns: first,
                last_ns: last,
            });
            e.count += n;
            e.first_ns = e.first_ns.min(first);
            e.last_ns = e.last_ns.max(last);
        };
        for file in &self.files {
            match self.storage {
                Storage::Sqlite3 => {
                    let db = sqlite_open(file)?;
                    let mut q = db
                        .prepare(
                            "SELECT t.name, COUNT(*), MIN(m.timestamp), MAX(m.timestamp) \
                             FROM messages m JOIN topics t ON t.id = m.topic_id GROUP BY m.topic_id",
                        )
                        .map_err(|e| sqlite_err(file, "messages", e))?;
                    let rows = q
                        .query_map([], |r| {
                            Ok((
                                r.get::<_, String>(0)?,
                                r.get::<_, i64>(1)?,
                                r.get::<_, i64>(2)?,
                                r.get::<_, i64>(3)?,
                            ))
                        })
                        .map_err(|e| sqlite_err(file, "messages", e))?;
                    for row in rows {
                        let (name, n, a, b) = row.map_err(|e| sqlite_err(file, "messages", e))?;
                        add(&name, 0, n.max(0) as u64, a.max(0) as u64, b.max(0) as u64);
                    }
                }
                Storage::Mcap => {
                    let names: Vec<String> = self.topics.iter().map(|t| t.name.clone()).collect();
                    let all: Vec<&str> = names.iter().map(String::as_str).collect();
                    mcap_read(file, Some(&all), &mut |i, t, _| {
                        if let Some(i) = i {
                            add(all[i], t, 1, t, t);
                        }
                        Ok(())
                    })
                    .1?;
                }
            }
        }
        Ok(out)
    }
}

fn sqlite_err(file: &Path, what: &str, e: rusqlite::Error) -> Error {
    Error::log(
        file,
        format!("sqlite3 {what}"),
        format!("{e} (a truncated or damaged .db3, or not a rosbag2 database)"),
    )
}

fn sqlite_open(file: &Path) -> Result<rusqlite::Connection> {
    use rusqlite::OpenFlags;
    rusqlite::Connection::open_with_flags(
        file,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| sqlite_err(file, "open", e))
}

fn sqlite_topics(file: &Path) -> Result<Vec<TopicInfo>> {
    let db = sqlite_open(file)?;
    let mut q = db
        .prepare("SELECT name, type, serialization_format FROM topics")
        .map_err(|e| sqlite_err(file, "topics table", e))?;
    let rows = q
        .query_map([], |r| {
            Ok(TopicInfo {
                name: r.get(0)?,
                msg_type: normalize_type(&r.get::<_, String>(1)?),
                encoding: r.get(2)?,
            })
        })
        .map_err(|e| sqlite_err(file, "topics table", e))?;
    rows.collect::<rusqlite::Result<Vec<_>>>()
        .map_err(|e| sqlite_err(file, "topics table", e))
}

fn sqlite_read(file: &Path, wanted: &[&str], f: &mut OnMessage<'_>) -> Result<()> {
    let db = sqlite_open(file)?;
    // topic id -> index in `wanted`
    let mut ids: BTreeMap<i64, usize> = BTreeMap::new();
    {
        let mut q = db
            .prepare("SELECT id, name FROM topics")
            .map_err(|e| sqlite_err(file, "topics table", e))?;
        let rows = q
            .query_map([], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?)))
            .map_err(|e| sqlite_err(file, "topics table", e))?;
        for row in rows {
            let (id, name) = row.map_err(|e| sqlite_err(file, "topics table", e))?;
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
        .map_err(|e| sqlite_err(file, "messages table", e))?;
    let mut rows = q.query([]).map_err(|e| sqlite_err(file, "messages table", e))?;
    let mut n = 0u64;
    while let Some(r) = rows
        .next()
        .map_err(|e| sqlite_err(file, &format!("messages table after {n} role messages"), e))?
    {
        let id: i64 = r.get(0).map_err(|e| sqlite_err(file, "messages.topic_id", e))?;
        let t: i64 = r.get(1).map_err(|e| sqlite_err(file, "messages.timestamp", e))?;
        let data = r
            .get_ref(2)
            .and_then(|v| v.as_blob().map_err(Into::into))
            .map_err(|e| sqlite_err(file, "messages.data", e))?;
        n += 1;
        if let Some(&i) = ids.get(&id) {
            f(i, t.max(0) as u64, data)?;
        }
    }
    Ok(())
}

fn mcap_topics(file: &Path) -> Result<Vec<TopicInfo>> {
    let mut out = Vec::new();
    // Channels come before their first message; reading stops at the first problem and
    // returns what it saw, so a truncated file still lists its topics.
    let (channels, r) = mcap_read(file, None, &mut |_, _, _| Ok(()));
    for (name, ty, enc) in channels {
        out.push(TopicInfo {
            name,
            msg_type: normalize_type(&ty),
            encoding: enc,
        });
    }
    r?;
    Ok(out)
}

/// Reads an MCAP file linearly; calls `f(Some(index in wanted), time, data)` for messages of
/// wanted channels (all channels' messages are skipped when `wanted` is `None`). Returns the
/// channels seen, (topic, schema name, encoding), even when reading stopped at an error.
fn mcap_read(
    file: &Path,
    wanted: Option<&[&str]>,
    f: &mut OnMaybeMessage<'_>,
) -> (Vec<(String, String, String)>, Result<()>) {
    use mcap::records::Record;
    // Streamed from the file: a bag of point clouds is never held in memory.
    let src = match std::fs::File::open(file) {
        Ok(f) => std::io::BufReader::with_capacity(1 << 20, f),
        Err(e) => return (Vec::new(), Err(Error::io(file, e))),
    };
    let mut schemas: BTreeMap<u16, String> = BTreeMap::new();
    let mut channels: BTreeMap<u16, Option<usize>> = BTreeMap::new();
    let mut seen = Vec::new();
    let mut messages = 0u64;
    let mut records = 0u64;
    let mut result = Ok(());
    let r = crate::log::mcap::read::for_each_record(src, &mut |rec| {
        records += 1;
        match rec {
            Record::Schema { header, .. } => {
                schemas.insert(header.id, header.name.clone());
            }
            Record::Channel(c) => {
                let ty = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                seen.push((c.topic.clone(), ty, c.message_encoding.clone()));
                let idx = wanted.and_then(|w| w.iter().position(|t| *t == c.topic));
                channels.insert(c.id, idx);
            }
            Record::Message { header, data } => {
                messages += 1;
                if wanted.is_some() {
                    if let Some(Some(idx)) = channels.get(&header.channel_id) {
                        if let Err(e) = f(Some(*idx), header.log_time, &data) {
                            result = Err(e);
                            return false;
                        }
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
