//! ROS 2 SQLite bags (`.db3`, the default storage before Iron) with `rusqlite` (SQLite
//! bundled, so nothing to install). The tables are rosbag2's `topics(id, name, type,
//! serialization_format, …)` and `messages(id, topic_id, timestamp, data)`; messages are
//! read in insertion order with one statement, page by page, and decoded as CDR
//! ([`super::imu_msg::decode_cdr`]). The file is opened read-only.

use super::imu_msg::{decode_cdr, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, TopicInfo};
use crate::error::{Error, Result};
use rusqlite::{Connection, OpenFlags};
use std::path::Path;

/// An open `.db3` bag.
///
/// ```
/// use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
/// // a rosbag2 SQLite file (written with `rusqlite`): /imu0 with 100 messages at 100 Hz
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("run.db3");
/// let db = rusqlite::Connection::open(&path)?;
/// db.execute_batch(
///     "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
///        serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
///      CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
///        timestamp INTEGER NOT NULL, data BLOB NOT NULL);
///      INSERT INTO topics VALUES (1, '/imu0', 'sensor_msgs/msg/Imu', 'cdr', '');",
/// )?;
/// for i in 0..100i64 {
///     let (gyro, acc) = ([0.0, 0.0, 0.125], [0.0, 0.0, 9.81]);
///     let s = ImuSample { stamp_ns: 10_000_000 * i, gyro, acc };
///     db.execute(
///         "INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?1, ?2)",
///         rusqlite::params![s.stamp_ns, encode_cdr(&s, "imu_link")],
///     )?;
/// }
/// drop(db);
/// use imunoise::logs::{LogReader, db3::Db3Reader};
/// let reader = Db3Reader::open(&path)?;
/// let t = &reader.topics()?[0];
/// assert_eq!((t.name.as_str(), t.count, t.is_imu), ("/imu0", 100, true));
/// let s = reader.read_imu("/imu0")?;
/// assert_eq!(imunoise::logs::rate_from_stamps(&s.stamps_ns), Some(100.0));
/// assert_eq!(s.columns[2][99], 0.125); // gyro_z_rads
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Db3Reader {
    file: String,
    conn: Connection,
}

impl Db3Reader {
    /// Opens `path` read-only and checks that it is an SQLite rosbag2 file.
    ///
    /// ```
    /// # use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
    /// # let dir = tempfile::tempdir()?;
    /// # let path = dir.path().join("run.db3");
    /// # let db = rusqlite::Connection::open(&path)?;
    /// # db.execute_batch(
    /// #     "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
    /// #        serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
    /// #      CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
    /// #        timestamp INTEGER NOT NULL, data BLOB NOT NULL);
    /// #      INSERT INTO topics VALUES (1, '/imu0', 'sensor_msgs/msg/Imu', 'cdr', '');",
    /// # )?;
    /// # for i in 0..100i64 {
    /// #     let (gyro, acc) = ([0.0, 0.0, 0.125], [0.0, 0.0, 9.81]);
    /// #     let s = ImuSample { stamp_ns: 10_000_000 * i, gyro, acc };
    /// #     db.execute(
    /// #         "INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?1, ?2)",
    /// #         rusqlite::params![s.stamp_ns, encode_cdr(&s, "imu_link")],
    /// #     )?;
    /// # }
    /// # drop(db);
    /// // `path`: a rosbag2 SQLite file with 100 IMU messages at 100 Hz on /imu0
    /// use imunoise::logs::db3::Db3Reader;
    /// assert!(Db3Reader::open(&path).is_ok());
    /// let csv = dir.path().join("imu.db3");
    /// std::fs::write(&csv, "gx,gy\n1,2\n")?;
    /// let e = Db3Reader::open(&csv).err().unwrap();
    /// assert!(e.to_string().ends_with("not an SQLite (.db3) file"));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        // Opening does not read the file; check the magic so that a missing or foreign file
        // gets a clear message.
        let head = {
            use std::io::Read;
            let mut f = std::fs::File::open(path).map_err(|e| Error::io(&file, e))?;
            let mut h = [0u8; 16];
            let n = f.read(&mut h).map_err(|e| Error::io(&file, e))?;
            h[..n].to_vec()
        };
        if head != b"SQLite format 3\0" {
            return Err(Error::File {
                file,
                message: "not an SQLite (.db3) file".to_string(),
            });
        }
        let conn = Connection::open_with_flags(
            path,
            OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
        )
        .map_err(|e| Error::File {
            file: file.clone(),
            message: format!("cannot open as SQLite: {e}"),
        })?;
        Ok(Db3Reader { file, conn })
    }

    fn corrupt(&self, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated, corrupt or not a rosbag2 .db3 file: {e}"),
        }
    }
}

impl LogReader for Db3Reader {
    fn format(&self) -> LogFormat {
        LogFormat::Db3
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let mut st = self
            .conn
            .prepare(
                "SELECT t.name, t.type, t.serialization_format, \
                 (SELECT COUNT(*) FROM messages m WHERE m.topic_id = t.id) \
                 FROM topics t ORDER BY t.name",
            )
            .map_err(|e| self.corrupt(e))?;
        let rows = st
            .query_map([], |r| {
                let name: String = r.get(0)?;
                let tp: String = r.get(1)?;
                let ser: String = r.get(2)?;
                let count: i64 = r.get(3)?;
                Ok(TopicInfo {
                    name,
                    is_imu: is_imu_type(&tp) && ser == "cdr",
                    msg_type: tp,
                    count: count.max(0) as u64,
                })
            })
            .map_err(|e| self.corrupt(e))?;
        let mut out: Vec<TopicInfo> = Vec::new();
        for r in rows {
            let t = r.map_err(|e| self.corrupt(e))?;
            // The same topic can appear once per type; merge counts by name.
            match out.iter_mut().find(|o| o.name == t.name) {
                Some(o) => o.count += t.count,
                None => out.push(t),
            }
        }
        Ok(out)
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        let n: i64 = self
            .conn
            .query_row(
                "SELECT COUNT(*) FROM messages m JOIN topics t ON m.topic_id = t.id WHERE t.name = ?1",
                [topic],
                |r| r.get(0),
            )
            .map_err(|e| self.corrupt(e))?;
        let mut out = ImuSeries::with_capacity((n.max(0) as usize).min(1 << 28));
        let mut st = self
            .conn
            .prepare(
                "SELECT m.data FROM messages m JOIN topics t ON m.topic_id = t.id \
                 WHERE t.name = ?1 ORDER BY m.id",
            )
            .map_err(|e| self.corrupt(e))?;
        let mut rows = st.query([topic]).map_err(|e| self.corrupt(e))?;
        while let Some(row) = rows.next().map_err(|e| self.corrupt(e))? {
            let data = row.get_ref(0).map_err(|e| self.corrupt(e))?;
            let bytes = data.as_blob().map_err(|e| self.corrupt(e))?;
            let s = decode_cdr(bytes).map_err(|why| Error::File {
                file: self.file.clone(),
                message: format!(
                    "message {} on {topic} is not a valid sensor_msgs/Imu: {why}",
                    out.stamps_ns.len() + 1
                ),
            })?;
            out.push(&s);
        }
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}
