//! Log reading speed: a 3-hour 1 kHz ROS 2 MCAP bag (1.08·10^7 `sensor_msgs/msg/Imu`
//! messages, target ≥ 3·10^6 messages/s), read into stamped columns, then ordered and
//! checked by the timing layer.
//!
//! The bag is written once into `target/bench-data/` (about 3.9 GB: chunked, uncompressed,
//! as rosbag2's default MCAP preset writes it; zstd with `IMUNOISE_BENCH_ZSTD=1`). With
//! `IMUNOISE_BENCH_SMALL=1` it has 10^6 messages. The path is printed so that the same
//! file can be read by other tools (`benches/rosbags_read.py` for Python `rosbags`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
use imunoise::logs::{LogReader, timing};
use std::hint::black_box;
use std::path::PathBuf;

fn bench_file() -> (PathBuf, usize) {
    let small = std::env::var_os("IMUNOISE_BENCH_SMALL").is_some();
    let zstd = std::env::var_os("IMUNOISE_BENCH_ZSTD").is_some();
    let n = if small { 1_000_000 } else { 3 * 3600 * 1000 };
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-data");
    let path = dir.join(format!(
        "imu_{n}_1khz{}.mcap",
        if zstd { "_zstd" } else { "" }
    ));
    if path.exists() {
        return (path, n);
    }
    std::fs::create_dir_all(&dir).expect("bench-data folder");
    eprintln!("writing {} ({n} messages) …", path.display());
    let gyro: imunoise::processes::Model = "WN(sigma2=1e-6)+RW(gamma2=1e-13)".parse().unwrap();
    let acc: imunoise::processes::Model = "WN(sigma2=4e-4)+RW(gamma2=1e-10)".parse().unwrap();
    let g = imunoise::cli::simulate::simulate_channels(&gyro, n, 1000.0, 1, 3).unwrap();
    let a = imunoise::cli::simulate::simulate_channels(&acc, n, 1000.0, 2, 3).unwrap();
    let tmp = path.with_extension("part");
    let f = std::io::BufWriter::with_capacity(1 << 22, std::fs::File::create(&tmp).unwrap());
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .compression(if zstd {
            Some(mcap::Compression::Zstd)
        } else {
            None
        })
        .create(f)
        .unwrap();
    let schema = w
        .add_schema("sensor_msgs/msg/Imu", "ros2msg", b"(definition omitted)")
        .unwrap();
    let ch = w
        .add_channel(schema, "/imu0", "cdr", &Default::default())
        .unwrap();
    let t0: i64 = 1_700_000_000_000_000_000;
    for i in 0..n {
        let st = t0 + i as i64 * 1_000_000;
        let s = ImuSample {
            stamp_ns: st,
            gyro: [g[0][i], g[1][i], g[2][i]],
            acc: [a[0][i], a[1][i], a[2][i] + 9.80665],
        };
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: ch,
                sequence: i as u32,
                log_time: st as u64,
                publish_time: st as u64,
            },
            &encode_cdr(&s, "imu_link"),
        )
        .unwrap();
    }
    w.finish().unwrap();
    drop(w);
    std::fs::rename(&tmp, &path).unwrap();
    (path, n)
}

fn bench(c: &mut Criterion) {
    let (path, n) = bench_file();
    eprintln!(
        "bench file: {} ({:.2} GB)",
        path.display(),
        std::fs::metadata(&path).map_or(0, |m| m.len()) as f64 / 1e9
    );
    let mut g = c.benchmark_group("mcap");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function(format!("read_imu/{n}"), |b| {
        b.iter(|| {
            let r = imunoise::logs::mcap::McapReader::open(&path).unwrap();
            let s = r.read_imu("/imu0").unwrap();
            assert_eq!(s.stamps_ns.len(), n);
            black_box(s)
        })
    });
    g.bench_function(format!("read_imu_and_timing/{n}"), |b| {
        b.iter(|| {
            let r = imunoise::logs::mcap::McapReader::open(&path).unwrap();
            let s = r.read_imu("/imu0").unwrap();
            let (cols, t) = timing::prepare(
                s.stamps_ns,
                s.columns,
                None,
                timing::GapPolicy::Refuse,
                "bench",
            )
            .unwrap();
            assert_eq!(t.rate_hz, 1000.0);
            black_box(cols)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
