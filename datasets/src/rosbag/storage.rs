//! The two rosbag2 storages, read into one list of topics and messages: MCAP (the default
//! since ROS 2 Iron) through the `mcap` crate, sqlite3 (`.db3`, the default before) through
//! `rusqlite`. A bag directory's `metadata.yaml` names its files.

use std::path::{Path, PathBuf};

use crate::DatasetError;

/// A topic of a bag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topic {
    /// Topic name, e.g. `/scan`.
    pub name: String,
    /// Message type, e.g. `sensor_msgs/msg/LaserScan`.
    pub ty: String,
    /// Serialization, `cdr` for ROS 2.
    pub encoding: String,
}

/// Whether a topic holds the static transforms: a `TFMessage` topic named `tf_static` (in any
/// namespace, `/tf_static`, `/robot/tf_static`).
pub fn is_tf_static(topic: &Topic) -> bool {
    topic.ty == super::messages::TF_MESSAGE && topic.name.rsplit('/').next() == Some("tf_static")
}

/// Whether a topic's messages are kept: those of the types the loader reads (scans,
/// references and static transforms); the rest of a bag (images, point clouds, dynamic tf) is
/// skipped while reading.
fn wanted(topic: &Topic) -> bool {
    topic.ty == super::messages::LASER_SCAN
        || super::messages::REFERENCE_TYPES.contains(&topic.ty.as_str())
        || is_tf_static(topic)
}

/// One message: its topic (an index into [`Bag::topics`]) and its serialized bytes.
#[derive(Clone, Debug)]
pub struct Message {
    /// Index of the topic in [`Bag::topics`].
    pub topic: usize,
    /// The serialized message.
    pub data: Vec<u8>,
}

/// A bag's topics (all of them) and the messages of the wanted ones, in storage order.
#[derive(Clone, Debug, Default)]
pub struct Bag {
    /// The topics (deduplicated by name and type over the bag's files).
    pub topics: Vec<Topic>,
    /// The messages.
    pub messages: Vec<Message>,
    /// The files read, in order.
    pub files: Vec<PathBuf>,
}

impl Bag {
    /// The index of a topic, added if new.
    fn topic_index(&mut self, topic: Topic) -> usize {
        match self.topics.iter().position(|t| *t == topic) {
            Some(i) => i,
            None => {
                self.topics.push(topic);
                self.topics.len() - 1
            }
        }
    }
}

fn storage_error(path: &Path, what: impl std::fmt::Display) -> DatasetError {
    DatasetError::BagStorage {
        path: path.to_path_buf(),
        what: what.to_string(),
    }
}

/// The storage files of a bag: `path` itself when it is a file, else the files a bag
/// directory's `metadata.yaml` lists under `relative_file_paths` (or, when it lists none, its
/// `.mcap` and `.db3` files by name).
pub fn bag_files(path: &Path) -> Result<Vec<PathBuf>, DatasetError> {
    let io = |source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    let yaml_path = path.join("metadata.yaml");
    let yaml = std::fs::read_to_string(&yaml_path).map_err(|source| DatasetError::Io {
        path: yaml_path.clone(),
        source,
    })?;
    let mut files: Vec<PathBuf> = relative_file_paths(&yaml)
        .into_iter()
        .map(|f| path.join(f))
        .collect();
    if files.is_empty() {
        let entries = std::fs::read_dir(path).map_err(io)?;
        for entry in entries {
            let p = entry.map_err(io)?.path();
            if p.extension().is_some_and(|e| e == "mcap" || e == "db3") {
                files.push(p);
            }
        }
        files.sort();
    }
    if files.is_empty() {
        return Err(storage_error(
            &yaml_path,
            "lists no storage file (relative_file_paths) and the directory holds no .mcap or .db3",
        ));
    }
    Ok(files)
}

/// The entries of the `relative_file_paths:` block of a rosbag2 `metadata.yaml` (a YAML list
/// of plain or quoted scalars, one per line, as rosbag2 and `rosbags` write it).
fn relative_file_paths(yaml: &str) -> Vec<String> {
    let mut lines = yaml.lines();
    let mut out = Vec::new();
    let Some(key_line) = lines.find(|l| l.trim_start().starts_with("relative_file_paths:")) else {
        return out;
    };
    let key_indent = key_line.len() - key_line.trim_start().len();
    for line in lines {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match trimmed.strip_prefix("- ") {
            Some(item) if indent >= key_indent => {
                out.push(
                    item.trim()
                        .trim_matches(|c| c == '"' || c == '\'')
                        .to_owned(),
                );
            }
            _ => break,
        }
    }
    out
}

/// Reads every file of the bag at `path` (a bag directory or one storage file).
pub fn read(path: &Path) -> Result<Bag, DatasetError> {
    let mut bag = Bag::default();
    for file in bag_files(path)? {
        let head = read_head(&file)?;
        if head.starts_with(MCAP_MAGIC) {
            read_mcap(&file, &mut bag)?;
        } else if head.starts_with(SQLITE_MAGIC) {
            read_sqlite(&file, &mut bag)?;
        } else {
            return Err(storage_error(
                &file,
                "neither an MCAP file nor an sqlite3 database (by its first bytes); a \
                 compressed bag file (.zstd) must be decompressed first",
            ));
        }
        bag.files.push(file);
    }
    Ok(bag)
}

const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";

fn read_head(file: &Path) -> Result<Vec<u8>, DatasetError> {
    use std::io::Read;
    let mut head = Vec::with_capacity(16);
    std::fs::File::open(file)
        .and_then(|f| f.take(16).read_to_end(&mut head))
        .map_err(|source| DatasetError::Io {
            path: file.to_path_buf(),
            source,
        })?;
    Ok(head)
}

#[cfg(feature = "rosbag-mcap")]
fn read_mcap(file: &Path, bag: &mut Bag) -> Result<(), DatasetError> {
    let bytes = std::fs::read(file).map_err(|source| DatasetError::Io {
        path: file.to_path_buf(),
        source,
    })?;
    mcap_into(file, &bytes, bag)
}

/// The topics and messages of MCAP bytes; `file` names them in errors.
#[cfg(feature = "rosbag-mcap")]
pub fn mcap_from_bytes(file: &Path, bytes: &[u8]) -> Result<Bag, DatasetError> {
    let mut bag = Bag::default();
    mcap_into(file, bytes, &mut bag)?;
    Ok(bag)
}

#[cfg(feature = "rosbag-mcap")]
fn mcap_into(file: &Path, bytes: &[u8], bag: &mut Bag) -> Result<(), DatasetError> {
    let stream = mcap::MessageStream::new(bytes)
        .map_err(|e| storage_error(file, format!("unreadable MCAP: {e}")))?;
    // Channels listed in the summary, so that a topic without messages is still named (the
    // stream below yields messages only). A damaged summary is left to the stream to report.
    if let Ok(Some(summary)) = mcap::Summary::read(bytes) {
        let mut channels: Vec<_> = summary.channels.values().collect();
        channels.sort_by_key(|c| c.id);
        for c in channels {
            bag.topic_index(Topic {
                name: c.topic.clone(),
                ty: c
                    .schema
                    .as_ref()
                    .map_or_else(String::new, |s| s.name.clone()),
                encoding: c.message_encoding.clone(),
            });
        }
    }
    for message in stream {
        let message = message.map_err(|e| storage_error(file, format!("unreadable MCAP: {e}")))?;
        let ty = message
            .channel
            .schema
            .as_ref()
            .map_or_else(String::new, |s| s.name.clone());
        let topic = bag.topic_index(Topic {
            name: message.channel.topic.clone(),
            ty,
            encoding: message.channel.message_encoding.clone(),
        });
        if wanted(&bag.topics[topic]) {
            bag.messages.push(Message {
                topic,
                data: message.data.into_owned(),
            });
        }
    }
    Ok(())
}

#[cfg(not(feature = "rosbag-mcap"))]
fn read_mcap(file: &Path, _bag: &mut Bag) -> Result<(), DatasetError> {
    Err(storage_error(
        file,
        "an MCAP bag, but datasets was built without the rosbag-mcap feature",
    ))
}

#[cfg(feature = "rosbag-sqlite")]
fn read_sqlite(file: &Path, bag: &mut Bag) -> Result<(), DatasetError> {
    use rusqlite::{Connection, OpenFlags};
    let sql = |e: rusqlite::Error| storage_error(file, format!("sqlite3: {e}"));
    let db = Connection::open_with_flags(file, OpenFlags::SQLITE_OPEN_READ_ONLY).map_err(sql)?;
    let mut ids = std::collections::HashMap::new();
    {
        let mut stmt = db
            .prepare("SELECT id, name, type, serialization_format FROM topics")
            .map_err(sql)?;
        let rows = stmt
            .query_map([], |row| {
                Ok((
                    row.get::<_, i64>(0)?,
                    Topic {
                        name: row.get(1)?,
                        ty: row.get(2)?,
                        encoding: row.get(3)?,
                    },
                ))
            })
            .map_err(sql)?;
        for row in rows {
            let (id, topic) = row.map_err(sql)?;
            ids.insert(id, bag.topic_index(topic));
        }
    }
    let mut stmt = db
        .prepare("SELECT topic_id, data FROM messages ORDER BY timestamp, id")
        .map_err(sql)?;
    let mut rows = stmt.query([]).map_err(sql)?;
    while let Some(row) = rows.next().map_err(sql)? {
        let id: i64 = row.get(0).map_err(sql)?;
        let topic = *ids.get(&id).ok_or_else(|| {
            storage_error(
                file,
                format!("a message of topic id {id}, which the topics table lacks"),
            )
        })?;
        if wanted(&bag.topics[topic]) {
            let data: Vec<u8> = row.get(1).map_err(sql)?;
            bag.messages.push(Message { topic, data });
        }
    }
    Ok(())
}

#[cfg(not(feature = "rosbag-sqlite"))]
fn read_sqlite(file: &Path, _bag: &mut Bag) -> Result<(), DatasetError> {
    Err(storage_error(
        file,
        "an sqlite3 bag, but datasets was built without the rosbag-sqlite feature",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_file_paths_of_a_rosbag2_metadata_yaml() {
        let yaml = "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  \
                    relative_file_paths:\n    - run_0.mcap\n    - \"run_1.mcap\"\n  \
                    starting_time:\n    nanoseconds_since_epoch: 1\n";
        assert_eq!(relative_file_paths(yaml), ["run_0.mcap", "run_1.mcap"]);
        assert!(relative_file_paths("files: []\n").is_empty());
    }
}
