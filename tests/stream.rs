//! Issue 13: the streamed Allan variance from files gives exactly the in-memory results, for
//! every kind of source (raw f64 mapped in place; other types, interleaved channels and a scale
//! decoded by groups of channels; gzip and standard input decoded once) and for any thread
//! count; and `fit` and `analyze`, which
//! read raw binary files through the same sources, give exactly what the in-memory reader's
//! tables give.

use avar::{AvarConfig, CiMethod};
use imunoise::Ui;
use imunoise::io::{self, BinaryType, Column, ReadOptions, Table};
use imunoise::pipeline::estimate::{avar_streamed, compute};
use imunoise::pipeline::read::Input;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

mod live_common;
use live_common::run_ok;

/// Rows: above the kernel's streaming threshold (2^22), not a multiple of any chunk.
const N: usize = (1 << 22) + 12_345;

/// Channel c at row r: a random walk plus white noise around an offset (xorshift, fixed seed).
fn channels(n: usize, k: usize) -> Vec<Vec<f64>> {
    (0..k)
        .map(|c| {
            let mut s = 0x2545_F491_4F6C_DD1Du64 ^ ((c as u64 + 1) << 40);
            let mut walk = 0.0;
            (0..n)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    walk += 1e-3 * u;
                    100.0 * (c as f64 + 1.0) + u + walk
                })
                .collect()
        })
        .collect()
}

/// Interleaves the channels as raw little-endian values of `kind`.
fn raw(cols: &[Vec<f64>], kind: BinaryType) -> Vec<u8> {
    let mut out = Vec::with_capacity(cols.len() * cols[0].len() * kind.size());
    for r in 0..cols[0].len() {
        for c in cols {
            let v = c[r];
            match kind {
                BinaryType::F64 => out.extend_from_slice(&v.to_le_bytes()),
                BinaryType::F32 => out.extend_from_slice(&(v as f32).to_le_bytes()),
                BinaryType::I16 => out.extend_from_slice(&((v * 100.0) as i16).to_le_bytes()),
                BinaryType::I32 => out.extend_from_slice(&((v * 1e6) as i32).to_le_bytes()),
            }
        }
    }
    out
}

fn no_ci() -> AvarConfig {
    AvarConfig {
        ci: CiMethod::None,
        ..AvarConfig::default()
    }
}

/// The table of the in-memory reader ([`io::read_table`], which parses the whole file), with the
/// scale, names and rate applied as the command applies them: the reference of every source.
fn in_memory(input: &Input) -> Table {
    let opts = ReadOptions {
        binary: input.binary,
        channels: input.channels,
        scale: None,
        columns: input
            .columns
            .as_deref()
            .map(|c| io::parse_columns(c).unwrap()),
        names: None,
    };
    let mut t = io::read_table(&input.file, &opts).unwrap();
    if let Some(s) = input.scale {
        for c in &mut t.columns {
            c.to_mut().iter_mut().for_each(|v| *v *= s);
        }
    }
    if let Some(n) = &input.names {
        t.names = n.split(',').map(|v| v.trim().to_string()).collect();
    }
    t.rate_hz = input.rate;
    t
}

/// The streamed path against the in-memory one (the reference table), with one and with two
/// threads; and the table `Input::read` gives (through the sources) equals the reference.
fn check(input: &Input, config: &AvarConfig) {
    let quiet = Ui::quiet();
    let table = in_memory(input);
    assert_eq!(
        input.read(&quiet).unwrap(),
        table,
        "{}",
        input.file.display()
    );
    let mem = compute(&table, table.rate().unwrap(), config, &quiet).unwrap();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let streamed = pool.install(|| avar_streamed(input, config, &quiet).unwrap());
        assert_eq!(
            streamed,
            mem,
            "{} with {threads} threads",
            input.file.display()
        );
    }
}

#[test]
fn every_binary_source_matches_the_in_memory_path() {
    let dir = tempfile::tempdir().unwrap();
    let cols = channels(N, 3);
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    // one f64 channel: mapped in place
    let p = write("one.f64", &raw(&cols[..1], BinaryType::F64));
    let one = Input {
        binary: Some(BinaryType::F64),
        rate: Some(200.0),
        ..Input::new(&p)
    };
    check(&one, &no_ci());
    // far scales that are not whole class steps of the far walk (here 2^17 samples): their
    // lagged blocks are read from the file into the walk's window (the dyadic ones come from
    // its ring of lane copies), from the chunk of their first term on
    check(
        &one,
        &AvarConfig {
            scales: avar::Scales::Explicit(vec![70_001, 150_000, 333_333, 1_000_003]),
            ..no_ci()
        },
    );
    // three interleaved f64 channels, two selected and renamed: decoded in one pass
    let p = write("three.f64", &raw(&cols, BinaryType::F64));
    check(
        &Input {
            binary: Some(BinaryType::F64),
            channels: Some(3),
            columns: Some("3,1".into()),
            names: Some("gz,gx".into()),
            rate: Some(200.0),
            ..Input::new(&p)
        },
        &no_ci(),
    );
    // five interleaved f64 channels, all selected in another order: decoded two channels per
    // pass into the same buffers (`source::group_size`), three groups
    let five = channels(N, 5);
    let p = write("five.f64", &raw(&five, BinaryType::F64));
    drop(five);
    check(
        &Input {
            binary: Some(BinaryType::F64),
            channels: Some(5),
            columns: Some("5,2,4,1,3".into()),
            rate: Some(200.0),
            ..Input::new(&p)
        },
        &no_ci(),
    );
    // i16 counts with a scale, two channels
    let p = write("counts.i16", &raw(&cols[..2], BinaryType::I16));
    check(
        &Input {
            binary: Some(BinaryType::I16),
            channels: Some(2),
            scale: Some(1.0 / 131.0),
            rate: Some(100.0),
            ..Input::new(&p)
        },
        &no_ci(),
    );
    // f32, gzip-compressed
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&raw(&cols[1..2], BinaryType::F32)).unwrap();
    let p = write("one.f32.gz", &gz.finish().unwrap());
    check(
        &Input {
            binary: Some(BinaryType::F32),
            rate: Some(100.0),
            ..Input::new(&p)
        },
        &no_ci(),
    );
    // the chi-square CI (the in-memory estimator on the mapped samples)
    check(&one, &AvarConfig::default());
}

/// `fit` and `analyze` on raw binary files read through the sources (one f64 channel mapped in
/// place, interleaved i16 counts with a scale and a column selection decoded in one pass): the
/// same tables, fits and results.json as from the in-memory reader's tables.
#[test]
fn fit_and_analyze_read_binary_files_through_the_sources() {
    use imunoise::pipeline::{analyze, fit};
    let dir = tempfile::tempdir().unwrap();
    let cols = channels(1 << 15, 3);
    let quiet = Ui::quiet();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let one = write("one.f64", &raw(&cols[..1], BinaryType::F64));
    let counts = write("counts.i16", &raw(&cols, BinaryType::I16));
    let inputs = [
        Input {
            binary: Some(BinaryType::F64),
            rate: Some(200.0),
            ..Input::new(&one)
        },
        Input {
            binary: Some(BinaryType::I16),
            channels: Some(3),
            columns: Some("3,1".into()),
            names: Some("gyro_z,gyro_x".into()),
            scale: Some(1.0 / 131.0),
            rate: Some(100.0),
            ..Input::new(&counts)
        },
    ];
    for input in &inputs {
        let name = input.file.display().to_string();
        let table = input.read(&quiet).unwrap();
        let reference = in_memory(input);
        assert_eq!(table, reference, "{name}");
        assert!(
            table.columns.iter().all(|c| matches!(c, Column::Mapped(_))),
            "{name}: read through a source"
        );
        let units = input.units(&table).unwrap();
        let settings = fit::FitSettings {
            model: "WN+RW".into(),
            ..Default::default()
        };
        let fits = |t: &Table| {
            let f = fit::fit_table(t, &units, &settings, None, &quiet).unwrap();
            serde_json::to_string(&f).unwrap()
        };
        assert_eq!(fits(&table), fits(&reference), "{name}: fit");
        let results = |t: Table| {
            let a = analyze::analyze(t, units.clone(), &Default::default(), &quiet).unwrap();
            a.results_json().unwrap().to_string()
        };
        assert_eq!(results(table), results(reference), "{name}: analyze");
    }
}

/// The command streams binary from a file and from standard input (decoded once into a
/// temporary file) with the same output as the library's in-memory path, whatever the
/// number of threads (RAYON_NUM_THREADS).
#[test]
fn command_file_and_stdin_match_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let cols = channels(N, 1);
    let p = dir.path().join("w.f64");
    std::fs::write(&p, raw(&cols, BinaryType::F64)).unwrap();
    let quiet = Ui::quiet();
    let input = Input {
        binary: Some(BinaryType::F64),
        rate: Some(50.0),
        ..Input::new(&p)
    };
    let table = input.read(&quiet).unwrap();
    let mem = compute(&table, 50.0, &no_ci(), &quiet).unwrap();
    let expected = serde_json::to_string(&imunoise::pipeline::estimate::to_json(&mem)).unwrap();
    // the output, and the notes on stderr
    let run_notes = |from_stdin: bool, threads: &str| -> (String, String) {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_imunoise"));
        cmd.arg("avar")
            .arg(if from_stdin { Path::new("-") } else { &p })
            .args([
                "--binary", "f64", "--rate", "50", "--ci", "none", "--format", "json",
            ])
            .env("RAYON_NUM_THREADS", threads)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        if from_stdin {
            cmd.stdin(std::fs::File::open(&p).unwrap());
        }
        let out = run_ok(&mut cmd);
        (
            String::from_utf8(out.stdout)
                .unwrap()
                .trim_end()
                .to_string(),
            String::from_utf8(out.stderr).unwrap(),
        )
    };
    let run = |from_stdin: bool, threads: &str| -> String { run_notes(from_stdin, threads).0 };
    for threads in ["1", "2"] {
        assert_eq!(run(false, threads), expected, "file, {threads} threads");
        assert_eq!(run(true, threads), expected, "stdin, {threads} threads");
    }
    // standard input cannot be read by position: the command says where it goes; a regular
    // file gets no such note
    let (_, notes) = run_notes(true, "2");
    assert!(
        notes.contains("standard input cannot be read by position")
            && notes.contains("temporary files"),
        "{notes}"
    );
    assert!(!run_notes(false, "2").1.contains("cannot be read"));
    // text from standard input is read whole into memory, and the note says so (`fit` and
    // `analyze` read every input this way)
    let out = run_ok(
        Command::new(env!("CARGO_BIN_EXE_imunoise"))
            .args([
                "avar", "-", "--rate", "50", "--ci", "none", "--format", "csv",
            ])
            .stdin(std::fs::File::open(write_csv(dir.path(), &cols[0][..4096])).unwrap()),
    );
    let notes = String::from_utf8_lossy(&out.stderr);
    assert!(
        notes.contains("standard input cannot be read by position: it is read whole into memory"),
        "{notes}"
    );
}

/// `x` as a one-column CSV file with a header, in `dir`.
fn write_csv(dir: &Path, x: &[f64]) -> std::path::PathBuf {
    let p = dir.join("one.csv");
    let body: String = x.iter().map(|v| format!("{v}\n")).collect();
    std::fs::write(&p, format!("gx\n{body}")).unwrap();
    p
}

/// Text parsed in windows into temporary files (`avar_text_streamed`, what `imunoise avar`
/// does with text files of 256 MiB and more) gives the in-memory path's curves bit for bit,
/// with a column selection, a scale and names, on 1 and 2 threads, and its errors: a bad
/// value in a later window and a scale that overflows name the same line, column and row.
#[test]
fn text_parsed_in_windows_matches_the_in_memory_path() {
    use imunoise::pipeline::estimate::avar_text_streamed;
    let dir = tempfile::tempdir().unwrap();
    let rows = 100_003;
    let cols = channels(rows, 3);
    let mut text = String::from("# a comment line\ngx,gy,gz\n");
    for ((a, b), c) in cols[0].iter().zip(&cols[1]).zip(&cols[2]) {
        // shortest round-trip form: the f64 values exactly
        text.push_str(&format!("{a:e},{b:e},{c:e}\r\n"));
    }
    let p = dir.path().join("three.csv");
    std::fs::write(&p, &text).unwrap();
    let quiet = Ui::quiet();
    let input = Input {
        rate: Some(200.0),
        columns: Some("gz,gx".into()),
        scale: Some(1.0 / 131.0),
        names: Some("z,x".into()),
        ..Input::new(&p)
    };
    let table = input.read(&quiet).unwrap();
    assert_eq!(table.names, ["z", "x"]);
    for config in [no_ci(), AvarConfig::default()] {
        let mem = compute(&table, 200.0, &config, &quiet).unwrap();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            // windows of 64 KiB: about 60 of them, cut inside the CRLF rows
            let streamed = pool
                .install(|| avar_text_streamed(&input, &config, 1 << 16, &quiet))
                .unwrap();
            assert_eq!(streamed, mem, "{threads} threads");
        }
    }
    // a bad value far past the first window: the same located error
    let bad_row = 90_000;
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    let broken = lines[2 + bad_row].replacen(',', ",1.5x", 1);
    lines[2 + bad_row] = &broken;
    let pb = dir.path().join("bad.csv");
    std::fs::write(&pb, lines.concat()).unwrap();
    let bad = Input {
        rate: Some(200.0),
        ..Input::new(&pb)
    };
    let want = bad.read(&quiet).unwrap_err().to_string();
    assert!(want.contains(&format!(":{}:", bad_row + 3)), "{want}");
    let got = avar_text_streamed(&bad, &no_ci(), 1 << 16, &quiet)
        .unwrap_err()
        .to_string();
    assert_eq!(got, want);
    // a scale beyond f64 for one column: the same message (channel and row)
    let mut text2 = String::from("a,b\n");
    for r in 0..50_000 {
        let big = if r == 40_000 { "1e300" } else { "1" };
        text2.push_str(&format!("2,{big}\n"));
    }
    let p2 = dir.path().join("scale.csv");
    std::fs::write(&p2, text2).unwrap();
    let over = Input {
        rate: Some(1.0),
        scale: Some(1e10),
        ..Input::new(&p2)
    };
    let want = over.read(&quiet).unwrap_err().to_string();
    let got = avar_text_streamed(&over, &no_ci(), 1 << 12, &quiet)
        .unwrap_err()
        .to_string();
    assert_eq!(got, want);
    assert!(want.contains("\"b\" at row 40001"), "{want}");
    // gzip-compressed text is not parsed in windows (it is read whole): refused, not misread
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(b"a\n1\n2\n3\n").unwrap();
    let pz = dir.path().join("x.csv.gz");
    std::fs::write(&pz, gz.finish().unwrap()).unwrap();
    let err = avar_text_streamed(
        &Input {
            rate: Some(1.0),
            ..Input::new(&pz)
        },
        &no_ci(),
        1 << 12,
        &quiet,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("gzip-compressed"), "{err}");
}

/// Errors name the file and, for a bad value, its row and channel; a partial row is named.
#[test]
fn streamed_errors_are_located() {
    let dir = tempfile::tempdir().unwrap();
    let quiet = Ui::quiet();
    let mut vals = vec![1.0f64; 64];
    vals[41] = f64::INFINITY;
    let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    let p = dir.path().join("bad.f64");
    std::fs::write(&p, &bytes).unwrap();
    let two = Input {
        binary: Some(BinaryType::F64),
        channels: Some(2),
        rate: Some(1.0),
        ..Input::new(&p)
    };
    let e = avar_streamed(&two, &no_ci(), &quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("row 21 channel 2"), "{e}");
    let p = dir.path().join("partial.f64");
    std::fs::write(&p, &bytes[..20]).unwrap();
    let one = Input {
        binary: Some(BinaryType::F64),
        rate: Some(1.0),
        ..Input::new(&p)
    };
    let e = avar_streamed(&one, &no_ci(), &quiet)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("partial.f64") && e.contains("4 bytes left over"),
        "{e}"
    );
    // in place, a non-finite sample is named by its index
    let p = dir.path().join("inf.f64");
    std::fs::write(&p, &bytes).unwrap();
    let e = avar_streamed(&Input { file: p, ..one }, &no_ci(), &quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("41"), "{e}");
}
