//! The README's and docs' commands still run.
//!
//! - Every `imunoise …` line of a ```` ```sh ```` block in `README.md` and `docs/*.md` is
//!   accepted by the command's argument parser (subcommand, flags and their values).
//! - The blocks marked `<!-- runs in tests/readme.rs -->` (the five-minute tour) run as they
//!   are, in a fresh folder holding a `run.mcap` written here from simulated data, and produce
//!   what the README says they do.
//! - The README has at most 300 lines, and every relative link of the README and `docs/`
//!   (file and heading) resolves.
//!
//! (The README's Python blocks run in `python/tests/test_readme.py`.)
#![cfg(feature = "mcap")]

use clap::Parser;
use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const MARK: &str = "<!-- runs in tests/readme.rs -->";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The ```` ```sh ```` blocks of a Markdown text, each with whether the line before it is
/// [`MARK`].
fn sh_blocks(text: &str) -> Vec<(bool, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim() == "```sh" {
            let marked = i > 0 && lines[i - 1].trim() == MARK;
            let mut body = String::new();
            i += 1;
            while i < lines.len() && lines[i].trim() != "```" {
                body.push_str(lines[i]);
                body.push('\n');
                i += 1;
            }
            out.push((marked, body));
        }
        i += 1;
    }
    out
}

/// The command lines of a block: continuation lines joined, `# comments` dropped, words split
/// as a POSIX shell splits them (single and double quotes, no expansions).
fn commands(block: &str) -> Vec<Vec<String>> {
    let joined = block.replace("\\\n", " ");
    let mut out = Vec::new();
    for line in joined.lines() {
        let mut words = Vec::new();
        let mut word = String::new();
        let mut in_word = false;
        let mut chars = line.chars();
        while let Some(c) = chars.next() {
            match c {
                '\'' | '"' => {
                    in_word = true;
                    for q in chars.by_ref() {
                        if q == c {
                            break;
                        }
                        word.push(q);
                    }
                }
                '#' if !in_word => break,
                c if c.is_whitespace() => {
                    if in_word {
                        words.push(std::mem::take(&mut word));
                        in_word = false;
                    }
                }
                c => {
                    in_word = true;
                    word.push(c);
                }
            }
        }
        if in_word {
            words.push(word);
        }
        if !words.is_empty() {
            out.push(words);
        }
    }
    out
}

#[test]
fn the_block_reader_splits_as_a_shell_does() {
    let text = "x\n```sh\nimunoise fit a.csv --model \"WN + RW\" # c\n\
                imunoise simulate --model 'WN(sigma2=1)' \\\n  -n 10 -o s.csv\n```\n\
                <!-- runs in tests/readme.rs -->\n```sh\nimunoise topics run.mcap\n```\n";
    let b = sh_blocks(text);
    assert_eq!(b.len(), 2);
    assert!(!b[0].0 && b[1].0);
    assert_eq!(
        commands(&b[0].1),
        vec![
            vec!["imunoise", "fit", "a.csv", "--model", "WN + RW"],
            vec![
                "imunoise",
                "simulate",
                "--model",
                "WN(sigma2=1)",
                "-n",
                "10",
                "-o",
                "s.csv"
            ],
        ]
    );
}

/// Every Markdown file with commands for users: the README and `docs/`.
fn documents() -> Vec<(PathBuf, String)> {
    let mut paths = vec![root().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .expect("docs/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    paths.extend(docs);
    paths
        .into_iter()
        .map(|p| {
            let t = std::fs::read_to_string(&p).unwrap();
            (p, t)
        })
        .collect()
}

#[test]
fn every_documented_command_line_parses() {
    let mut checked = 0;
    for (path, text) in documents() {
        for (_, block) in sh_blocks(&text) {
            for words in commands(&block) {
                if words[0] != "imunoise" {
                    continue; // cargo, bash, python3, pip: not ours to parse
                }
                if let Err(e) = imunoise::cli::Cli::try_parse_from(&words) {
                    panic!(
                        "{}: `{}` does not parse:\n{e}",
                        path.display(),
                        words.join(" ")
                    );
                }
                checked += 1;
            }
        }
    }
    // the README alone shows a dozen (the tour, the commands); a change that hid them all
    // from this test would be caught here
    assert!(checked >= 12, "only {checked} imunoise command lines found");
}

/// Six channels of WN + RW at `rate` (gyro in rad/s, acc in m/s² around g) as an MCAP bag with
/// one `sensor_msgs/msg/Imu` topic `/imu0`. The random walks dominate the white noise from
/// m ≈ √(3σ²/γ²) ≈ 170 (gyro) and 110 (acc) samples on, well inside a short record, so the
/// fit estimates both terms.
fn write_bag(path: &Path, n: usize, rate: f64) {
    let gyro: imunoise::processes::Model = "WN(sigma2=1e-6)+RW(gamma2=1e-10)".parse().unwrap();
    let acc: imunoise::processes::Model = "WN(sigma2=4e-4)+RW(gamma2=1e-7)".parse().unwrap();
    let mut c = imunoise::pipeline::simulate::simulate_channels(&gyro, n, rate, 21, 3).unwrap();
    let mut a = imunoise::pipeline::simulate::simulate_channels(&acc, n, rate, 22, 3).unwrap();
    a[2].iter_mut().for_each(|v| *v += 9.80665);
    c.append(&mut a);
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").create(f).unwrap();
    let s = w
        .add_schema("sensor_msgs/msg/Imu", "ros2msg", b"(definition omitted)")
        .unwrap();
    let ch = w.add_channel(s, "/imu0", "cdr", &BTreeMap::new()).unwrap();
    let dt = (1e9 / rate).round() as i64;
    for (i, &gyro_x) in c[0].iter().enumerate() {
        let stamp_ns = 1_700_000_000_000_000_000 + i as i64 * dt;
        let sample = ImuSample {
            stamp_ns,
            gyro: [gyro_x, c[1][i], c[2][i]],
            acc: [c[3][i], c[4][i], c[5][i]],
        };
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: ch,
                sequence: i as u32,
                log_time: stamp_ns as u64,
                publish_time: stamp_ns as u64,
            },
            &encode_cdr(&sample, "imu_link"),
        )
        .unwrap();
    }
    w.finish().unwrap();
}

/// The value of `key: value` in a YAML file written by `imunoise export`.
fn yaml_value(path: &Path, key: &str) -> f64 {
    let text = std::fs::read_to_string(path).unwrap();
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{key}:")))
        .unwrap_or_else(|| panic!("no {key} in {}:\n{text}", path.display()));
    line.split(':')
        .nth(1)
        .unwrap()
        .split('#')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn the_readme_tour_runs_on_a_bag() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let tour: Vec<Vec<String>> = sh_blocks(&readme)
        .into_iter()
        .filter(|(marked, _)| *marked)
        .flat_map(|(_, b)| commands(&b))
        .collect();
    assert!(
        tour.len() >= 3,
        "the README's marked blocks hold {} commands",
        tour.len()
    );
    let dir = tempfile::tempdir().unwrap();
    // 2^14 samples at 200 Hz (82 s): enough scales for a fit, cheap in CI
    write_bag(&dir.path().join("run.mcap"), 1 << 14, 200.0);
    for words in &tour {
        assert_eq!(
            words[0], "imunoise",
            "a tour command that is not imunoise: {words:?}"
        );
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_imunoise"))
            .args(&words[1..])
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "`{}` failed:\n{}",
            words.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        if words[1] == "topics" {
            let text = String::from_utf8_lossy(&out.stdout);
            assert!(text.contains("/imu0") && text.contains("200"), "{text}");
        }
    }
    // what the README says the tour leaves behind
    let report = dir.path().join("report");
    for f in [
        "report.html",
        "results.json",
        "avar.csv",
        "adev_gyro_x_rads.svg",
    ] {
        assert!(report.join(f).exists(), "report/{f} missing");
    }
    for f in [
        "imu.yaml",
        "kalibr_imu_chain.yaml",
        "orbslam3_imu.yaml",
        "vins_imu.yaml",
    ] {
        assert!(report.join(f).exists(), "report/{f} missing (--export all)");
    }
    assert!(report.join("basalt_imu.json").exists());
    // `export --inflate-noise 2 --inflate-walk 10`: the VIO configs are the report's scaled by
    // exactly those factors. Both files print 7 significant digits (relative rounding ≤ 5e-7
    // each), so the ratio is the factor within 1e-6 plus the f64 product's rounding: 1.5e-6.
    let vio = dir.path().join("vio");
    for (key, factor) in [
        ("gyroscope_noise_density", 2.0),
        ("accelerometer_noise_density", 2.0),
        ("gyroscope_random_walk", 10.0),
        ("accelerometer_random_walk", 10.0),
    ] {
        let base = yaml_value(&report.join("imu.yaml"), key);
        let scaled = yaml_value(&vio.join("imu.yaml"), key);
        assert!(base > 0.0, "{key} = {base}");
        assert!(
            (scaled / (factor * base) - 1.0).abs() < 1.5e-6,
            "{key}: {scaled} is not {factor} × {base}"
        );
    }
    assert!(vio.join("vins_imu.yaml").exists());
    assert!(
        !vio.join("basalt_imu.json").exists(),
        "--to kalibr,vins wrote basalt"
    );
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, other punctuation dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

#[test]
fn the_readme_is_short_and_its_links_and_the_docs_links_resolve() {
    let docs = documents();
    let readme = &docs[0].1;
    let lines = readme.lines().count();
    assert!(
        lines <= 300,
        "README.md has {lines} lines (at most 300: details go to docs/)"
    );
    let anchors = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.starts_with('#'))
            .map(|l| slug(l.trim_start_matches('#')))
            .collect()
    };
    let mut checked = 0;
    for (path, text) in &docs {
        let dir = path.parent().unwrap();
        let mut rest = text.as_str();
        while let Some(k) = rest.find("](") {
            rest = &rest[k + 2..];
            let Some(end) = rest.find(')') else { break };
            let target = &rest[..end];
            if target.starts_with("http") || target.contains(' ') {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
            let file_path = if file.is_empty() {
                path.clone()
            } else {
                dir.join(file)
            };
            assert!(
                file_path.exists(),
                "{}: link to {target}: no such file",
                path.display()
            );
            if !anchor.is_empty() {
                let t = std::fs::read_to_string(&file_path).unwrap();
                assert!(
                    anchors(&t).iter().any(|a| a == anchor),
                    "{}: link to {target}: no such heading",
                    path.display()
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} links found");
}
