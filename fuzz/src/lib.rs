//! What the fuzz targets share: each reader is driven the way the `imunoise` command drives
//! it, and every `Err` is an accepted answer; only a panic, an abort, a timeout or an
//! allocation over the limit is a finding.

use imunoise::logs::{self, GapPolicy, LogFormat};
use std::path::PathBuf;
use std::sync::OnceLock;

/// A file of this process under the temporary folder, named `x.<ext>` (the readers map files,
/// so the input is written to one and read from there, as the command reads a log).
pub fn scratch(ext: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("imunoise-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("a scratch folder");
        d
    });
    dir.join(format!("x.{ext}"))
}

/// Opens `data` as a log of `format` (written to a file named `x.<ext>`) and does what
/// `imunoise topics` and `imunoise analyze` do: open (with the truncation check), summarize
/// every topic, then read every IMU topic and order its samples by stamp (both gap policies
/// that keep going).
pub fn read_log(format: LogFormat, ext: &str, data: &[u8]) {
    let path = scratch(ext);
    std::fs::write(&path, data).expect("writing the scratch file");
    let ui = imunoise::Ui::quiet();
    let Ok(reader) = logs::open_checked(&path, format, false, &ui) else {
        return;
    };
    let _ = logs::summarize(reader.as_ref());
    let _ = logs::select_topics(reader.as_ref(), "x", &[]);
    let Ok(topics) = reader.topics() else {
        return;
    };
    for t in topics.iter().filter(|t| t.is_imu) {
        let Ok(s) = reader.read_imu(&t.name) else {
            continue;
        };
        assert_eq!(
            s.stamps_ns.len(),
            s.columns[0].len(),
            "{format:?}: ragged series"
        );
        for policy in [GapPolicy::Longest, GapPolicy::Ignore] {
            let _ =
                logs::timing::prepare(s.stamps_ns.clone(), s.columns.clone(), None, policy, "x");
        }
    }
}

/// After a table is read: its rate (from a time column or not), and, with two or more columns,
/// the first taken as a time column in seconds (`--time-column`), ordered by stamp.
pub fn use_table(t: imunoise::io::Table) {
    let _ = t.rate();
    if t.columns.len() >= 2 && t.n_rows() >= 2 {
        let stamps: Vec<i64> = t.columns[0]
            .iter()
            .map(|&v| (v * 1e9).round() as i64)
            .collect();
        let cols: Vec<Vec<f64>> = t.columns[1..].iter().map(|c| c.to_vec()).collect();
        let _ = logs::timing::prepare(stamps, cols, None, GapPolicy::Longest, "x");
    }
}
