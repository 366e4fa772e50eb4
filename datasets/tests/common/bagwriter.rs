//! Writes ROS 2 bags for the tests: CDR messages (little-endian XCDR1, written here
//! independently of the loader's reader), MCAP files through the `mcap` crate's writer, and
//! sqlite3 files in the rosbag2 schema (`schema`, `metadata`, `topics`, `messages`, as
//! rosbag2's `SqliteStorage` creates them since schema version 4).

use std::collections::BTreeMap;
use std::path::Path;

/// A CDR message under construction (encapsulation `00 01 00 00`, little-endian).
pub struct Cdr {
    buf: Vec<u8>,
}

impl Default for Cdr {
    fn default() -> Self {
        Self {
            buf: vec![0, 1, 0, 0],
        }
    }
}

impl Cdr {
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - 4).is_multiple_of(n) {
            self.buf.push(0);
        }
    }
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.align(2);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.u32(v as u32)
    }
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.u32(v.to_bits())
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        self.u32(v.len() as u32);
        for &x in v {
            self.f32(x);
        }
        self
    }
    /// `std_msgs/Header` at `t_s` (split into whole seconds and nanoseconds).
    pub fn header(&mut self, t_s: f64, frame: &str) -> &mut Self {
        let (sec, nanosec) = stamp(t_s);
        self.i32(sec).u32(nanosec).string(frame)
    }
    /// `geometry_msgs/Pose` in the plane, orientation `yaw` about `+z`.
    pub fn pose(&mut self, x: f64, y: f64, yaw: f64) -> &mut Self {
        self.f64(x).f64(y).f64(0.0);
        self.f64(0.0)
            .f64(0.0)
            .f64((yaw / 2.0).sin())
            .f64((yaw / 2.0).cos())
    }
    pub fn bytes(&self) -> Vec<u8> {
        self.buf.clone()
    }
}

/// `t_s` as ROS `(sec, nanosec)`.
pub fn stamp(t_s: f64) -> (i32, u32) {
    let sec = t_s.floor();
    let mut nanosec = ((t_s - sec) * 1e9).round();
    let mut sec = sec as i32;
    if nanosec >= 1e9 {
        sec += 1;
        nanosec -= 1e9;
    }
    (sec, nanosec as u32)
}

/// A `LaserScan`.
pub struct LaserScanMsg<'a> {
    pub t_s: f64,
    pub angle_min: f32,
    pub angle_increment: f32,
    /// Time between two readings, s (0: the driver does not say).
    pub time_increment: f32,
    pub range_min: f32,
    pub range_max: f32,
    pub ranges: &'a [f32],
}

pub fn laser_scan(m: &LaserScanMsg<'_>) -> Vec<u8> {
    let n = m.ranges.len() as f32;
    Cdr::default()
        .header(m.t_s, "laser")
        .f32(m.angle_min)
        .f32(m.angle_min + (n - 1.0) * m.angle_increment)
        .f32(m.angle_increment)
        .f32(m.time_increment)
        .f32(0.1)
        .f32(m.range_min)
        .f32(m.range_max)
        .f32s(m.ranges)
        .f32s(&vec![100.0; m.ranges.len()])
        .bytes()
}

pub fn odometry(t_s: f64, x: f64, y: f64, yaw: f64) -> Vec<u8> {
    let mut c = Cdr::default();
    c.header(t_s, "odom").string("base_link").pose(x, y, yaw);
    for _ in 0..36 {
        c.f64(0.0);
    }
    c.f64(0.1).f64(0.0).f64(0.0).f64(0.0).f64(0.0).f64(0.01);
    for _ in 0..36 {
        c.f64(0.0);
    }
    c.bytes()
}

pub fn pose_stamped(t_s: f64, x: f64, y: f64, yaw: f64) -> Vec<u8> {
    Cdr::default().header(t_s, "map").pose(x, y, yaw).bytes()
}

pub fn pose_with_covariance_stamped(t_s: f64, x: f64, y: f64, yaw: f64) -> Vec<u8> {
    let mut c = Cdr::default();
    c.header(t_s, "map").pose(x, y, yaw);
    for k in 0..36 {
        c.f64(if k % 7 == 0 { 0.01 } else { 0.0 });
    }
    c.bytes()
}

pub fn nav_sat_fix(t_s: f64, status: i8, lat_deg: f64, lon_deg: f64, alt_m: f64) -> Vec<u8> {
    let mut c = Cdr::default();
    c.header(t_s, "gps").u8(status as u8).u16(1);
    c.f64(lat_deg).f64(lon_deg).f64(alt_m);
    for _ in 0..9 {
        c.f64(0.0);
    }
    c.u8(0).bytes()
}

/// One `geometry_msgs/TransformStamped`: parent frame, child frame, translation (m) and
/// quaternion (x, y, z, w).
pub type TfDef<'a> = (&'a str, &'a str, [f64; 3], [f64; 4]);

/// The quaternion (x, y, z, w) of a turn by `yaw` about `+z`.
pub fn yaw_quaternion(yaw: f64) -> [f64; 4] {
    [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()]
}

/// A `tf2_msgs/TFMessage` of `transforms`, stamped `t_s`.
pub fn tf_message(t_s: f64, transforms: &[TfDef<'_>]) -> Vec<u8> {
    let mut c = Cdr::default();
    c.u32(transforms.len() as u32);
    for (parent, child, xyz, q) in transforms {
        c.header(t_s, parent).string(child);
        for v in xyz.iter().chain(q) {
            c.f64(*v);
        }
    }
    c.bytes()
}

/// A topic: name and type.
pub type TopicDef<'a> = (&'a str, &'a str);

/// A message: topic index, receive time (ns) and bytes.
pub type Msg = (usize, u64, Vec<u8>);

/// Writes an MCAP bag file as rosbag2 does (profile `ros2`, schemas `ros2msg`, `cdr`).
pub fn write_mcap(path: &Path, topics: &[TopicDef<'_>], messages: &[Msg]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(file)
        .unwrap();
    let channels: Vec<u16> = topics
        .iter()
        .map(|(name, ty)| {
            let schema = w
                .add_schema(ty, "ros2msg", b"# definition not needed")
                .unwrap();
            w.add_channel(schema, name, "cdr", &BTreeMap::new())
                .unwrap()
        })
        .collect();
    for (seq, (topic, t_ns, data)) in messages.iter().enumerate() {
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channels[*topic],
                sequence: seq as u32,
                log_time: *t_ns,
                publish_time: *t_ns,
            },
            data,
        )
        .unwrap();
    }
    w.finish().unwrap();
}

/// Writes an sqlite3 bag file in the rosbag2 schema.
pub fn write_db3(path: &Path, topics: &[TopicDef<'_>], messages: &[Msg]) {
    let _ = std::fs::remove_file(path);
    let db = rusqlite::Connection::open(path).unwrap();
    db.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         INSERT INTO schema VALUES (4, 'jazzy');
         CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL,
                               metadata TEXT NOT NULL);
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                             serialization_format TEXT NOT NULL,
                             offered_qos_profiles TEXT NOT NULL,
                             type_description_hash TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
                               timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )
    .unwrap();
    for (k, (name, ty)) in topics.iter().enumerate() {
        db.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '', '')",
            rusqlite::params![k as i64 + 1, name, ty],
        )
        .unwrap();
    }
    let tx = db.unchecked_transaction().unwrap();
    for (topic, t_ns, data) in messages {
        tx.execute(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![*topic as i64 + 1, *t_ns as i64, data],
        )
        .unwrap();
    }
    tx.commit().unwrap();
}

/// Which storage to write.
#[derive(Clone, Copy, Debug)]
pub enum Storage {
    Mcap,
    Sqlite,
}

pub const STORAGES: [Storage; 2] = [Storage::Mcap, Storage::Sqlite];

/// Writes a bag file `stem.mcap` / `stem.db3` in `dir`; returns its path.
pub fn write(
    dir: &Path,
    stem: &str,
    storage: Storage,
    topics: &[TopicDef<'_>],
    messages: &[Msg],
) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    match storage {
        Storage::Mcap => {
            let p = dir.join(format!("{stem}.mcap"));
            write_mcap(&p, topics, messages);
            p
        }
        Storage::Sqlite => {
            let p = dir.join(format!("{stem}.db3"));
            write_db3(&p, topics, messages);
            p
        }
    }
}

/// A fresh scratch directory under the target directory.
pub fn scratch(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("rosbag")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
