//! The module graph of every crate in the workspace has no cycle beyond the known ones.
//!
//! A node is a module (a file: `src/a/b.rs` and `src/a/b/mod.rs` are `a::b`); the crate root
//! (`lib.rs`, `main.rs`) is left out, being the crate's facade of re-exports. An edge M → N is a
//! path in M's code (a `use`, or a path in an expression or a type) that names N: `crate::n…`,
//! `super::n…`, `self::n…`, or a child module of M by its name (`n::item`). Such a path is
//! resolved to the longest prefix that is a module of the crate. A path to M itself or to one
//! of M's ancestors (`super::Item` in a child, an item of the root) is no edge: a module lives
//! in its ancestors' namespace, while a parent that calls into a child does depend on it.
//! Code under `#[cfg(test)]` does not count (tests may reach anywhere), nor do comments and
//! string literals.
//!
//! A cycle is a strongly connected component (Tarjan) of two or more modules. The test fails
//! when a crate has a cycle that is not in [`KNOWN`] exactly as listed: a new cycle, a known one
//! that grew, and a known one that shrank or went (so that the list only ever shrinks: edit it
//! to what the message prints). Each known cycle is one that issue 30 asks to remove.
//!
//! It also fails when library code names the command ([`COMMAND`]: the umbrella's `cli`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates checked: (name in messages, source folder relative to the workspace root).
const CRATES: &[(&str, &str)] = &[
    ("imunoise", "src"),
    ("processes", "crates/processes/src"),
    ("spectral", "crates/spectral/src"),
    ("avar", "crates/avar/src"),
    ("gmwm-prep", "crates/gmwm-prep/src"),
    ("xtask", "xtask/src"),
    ("python", "python/src"),
];

/// The cycles that exist today and that issue 30 asks to remove: (crate, the modules of one
/// strongly connected component). Remove an entry when its cycle is gone; never add one.
const KNOWN: &[(&str, &[&str])] = &[];

/// The command's modules: (crate, module). No module outside one of them (library code) may
/// name it or anything inside it.
const COMMAND: &[(&str, &str)] = &[("imunoise", "cli")];

/// The edges from outside `top` (and its descendants) into it.
fn into_command(g: &Graph, top: &Module) -> Vec<(Module, Module)> {
    let mut out = Vec::new();
    for (m, targets) in g {
        if m.starts_with(top) {
            continue;
        }
        for t in targets.iter().filter(|t| t.starts_with(top)) {
            out.push((m.clone(), t.clone()));
        }
    }
    out
}

/// A module path: its segments below the crate root (the root itself is the empty path).
type Module = Vec<String>;

/// Edges of one crate's module graph: module → the modules its code names.
type Graph = BTreeMap<Module, BTreeSet<Module>>;

fn name(m: &Module) -> String {
    m.join("::")
}

/// The module a source file is, from its path below the crate's `src` folder; `None` for a
/// crate root.
fn module_of(rel: &Path) -> Option<Module> {
    let mut segs: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    let last = segs.pop()?;
    let stem = last.strip_suffix(".rs")?;
    if segs.is_empty() && (stem == "lib" || stem == "main") {
        return None;
    }
    if stem != "mod" {
        segs.push(stem.to_string());
    }
    Some(segs)
}

/// Every `.rs` file below `src` (except `src/bin`, other crates) with its module.
fn read_crate(src: &Path) -> BTreeMap<Module, String> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<Module, String>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for p in entries {
            let rel = p.strip_prefix(root).expect("below the root");
            if p.is_dir() {
                if rel != Path::new("bin") {
                    walk(&p, root, out);
                }
            } else if p.extension().is_some_and(|e| e == "rs")
                && let Some(m) = module_of(rel)
            {
                let text = std::fs::read_to_string(&p)
                    .unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()));
                out.insert(m, text);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, src, &mut out);
    out
}

/// The code with comments, string and character literals blanked (newlines kept).
fn strip_literals(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        if at(i) == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if at(i) == '/' && at(i + 1) == '*' {
            let mut depth = 0usize;
            loop {
                if i >= c.len() {
                    break;
                }
                if at(i) == '/' && at(i + 1) == '*' {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if at(i) == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if (at(i) == 'r' || (at(i) == 'b' && at(i + 1) == 'r'))
            && !at(i.wrapping_sub(1)).is_alphanumeric()
            && {
                let mut k = i + if at(i) == 'b' { 2 } else { 1 };
                while at(k) == '#' {
                    k += 1;
                }
                at(k) == '"'
            }
        {
            // raw string r#"…"#
            let mut k = i + if at(i) == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while at(k) == '#' {
                hashes += 1;
                k += 1;
            }
            k += 1;
            loop {
                if k >= c.len() {
                    break;
                }
                if c[k] == '"' && (1..=hashes).all(|h| at(k + h) == '#') {
                    k += 1 + hashes;
                    break;
                }
                k += 1;
            }
            for &ch in &c[i..k.min(c.len())] {
                blank(&mut out, ch);
            }
            i = k;
        } else if at(i) == '"' {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            for &ch in &c[i..(k + 1).min(c.len())] {
                blank(&mut out, ch);
            }
            i = k + 1;
        } else if at(i) == '\'' && (at(i + 1) == '\\' || at(i + 2) == '\'') {
            // a character literal (a lifetime 'a has no closing quote after one character)
            let mut k = i + 1;
            if at(k) == '\\' {
                k += 2;
            } else {
                k += 1;
            }
            while k < c.len() && c[k] != '\'' {
                k += 1;
            }
            for &ch in &c[i..(k + 1).min(c.len())] {
                blank(&mut out, ch);
            }
            i = k + 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    Path, // ::
    Punct(char),
}

fn tokens(code: &str) -> Vec<Tok> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch.is_alphabetic() || ch == '_' {
            let s = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok::Ident(c[s..i].iter().collect()));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok::Punct('0'));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push(Tok::Path);
            i += 2;
        } else if ch.is_whitespace() {
            i += 1;
        } else {
            out.push(Tok::Punct(ch));
            i += 1;
        }
    }
    out
}

/// The tokens without the items under `#[cfg(test)]` (a `mod tests { … }`, a `use …;`, a
/// `fn … { … }`).
fn without_test_items(t: Vec<Tok>) -> Vec<Tok> {
    let pat = [
        Tok::Punct('#'),
        Tok::Punct('['),
        Tok::Ident("cfg".into()),
        Tok::Punct('('),
        Tok::Ident("test".into()),
        Tok::Punct(')'),
        Tok::Punct(']'),
    ];
    let mut out = Vec::with_capacity(t.len());
    let mut i = 0;
    while i < t.len() {
        if t[i..].starts_with(&pat) {
            // skip to the end of the item: a `;` or the `}` matching its first `{`, at depth 0
            let mut k = i + pat.len();
            let mut depth = 0i64;
            let mut bracket = 0i64;
            while k < t.len() {
                match t[k] {
                    Tok::Punct('[') | Tok::Punct('(') => bracket += 1,
                    Tok::Punct(']') | Tok::Punct(')') => bracket -= 1,
                    Tok::Punct('{') => depth += 1,
                    Tok::Punct('}') => {
                        depth -= 1;
                        if depth == 0 {
                            k += 1;
                            break;
                        }
                    }
                    Tok::Punct(';') if depth == 0 && bracket == 0 => {
                        k += 1;
                        break;
                    }
                    _ => {}
                }
                k += 1;
            }
            i = k;
        } else {
            out.push(t[i].clone());
            i += 1;
        }
    }
    out
}

/// Parses a use tree / path from `t[i]` (an identifier) with `cur` the module so far, pushing
/// every full path it names; returns the index after it.
fn parse_tree(t: &[Tok], mut i: usize, mut cur: Module, out: &mut Vec<Module>) -> usize {
    loop {
        match t.get(i) {
            Some(Tok::Ident(s)) => {
                match s.as_str() {
                    "super" => {
                        cur.pop();
                    }
                    "self" => {}
                    "crate" => cur.clear(),
                    _ => cur.push(s.clone()),
                }
                i += 1;
            }
            Some(Tok::Punct('{')) => {
                i += 1;
                loop {
                    match t.get(i) {
                        Some(Tok::Punct('}')) | None => return i + 1,
                        Some(Tok::Punct(',')) => i += 1,
                        Some(Tok::Ident(_)) => i = parse_tree(t, i, cur.clone(), out),
                        Some(_) => i += 1, // `*`, `as` renames end in an identifier: harmless
                    }
                }
            }
            _ => {
                out.push(cur);
                return i;
            }
        }
        if t.get(i) == Some(&Tok::Path) {
            i += 1;
        } else {
            out.push(cur);
            return i;
        }
    }
}

/// The crate's module graph from its modules' sources.
fn graph(sources: &BTreeMap<Module, String>) -> Graph {
    let modules: BTreeSet<Module> = sources.keys().cloned().collect();
    let mut g = Graph::new();
    for (m, text) in sources {
        let t = without_test_items(tokens(&strip_literals(text)));
        let mut paths = Vec::new();
        for i in 0..t.len() {
            let Tok::Ident(s) = &t[i] else { continue };
            if t.get(i + 1) != Some(&Tok::Path) {
                continue;
            }
            if i > 0 && matches!(t[i - 1], Tok::Path | Tok::Punct('$')) {
                continue;
            }
            let start = match s.as_str() {
                "crate" => Some(Vec::new()),
                "super" | "self" => Some(m.clone()),
                _ => {
                    let mut child = m.clone();
                    child.push(s.clone());
                    modules.contains(&child).then(|| m.clone())
                }
            };
            if let Some(base) = start {
                parse_tree(&t, i, base, &mut paths);
            }
        }
        let edges = g.entry(m.clone()).or_default();
        for p in paths {
            let target = (0..=p.len())
                .rev()
                .map(|k| p[..k].to_vec())
                .find(|q| modules.contains(q));
            // a module lives in its ancestors' namespace: naming them is no edge
            if let Some(q) = target
                && !m.starts_with(&q)
            {
                edges.insert(q);
            }
        }
    }
    g
}

/// The strongly connected components of two or more nodes (Tarjan), each sorted.
fn cycles(g: &Graph) -> Vec<BTreeSet<Module>> {
    struct T<'a> {
        g: &'a Graph,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        on: BTreeSet<&'a Module>,
        stack: Vec<&'a Module>,
        out: Vec<BTreeSet<Module>>,
    }
    fn visit<'a>(s: &mut T<'a>, v: &'a Module) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on.insert(v);
        if let Some(ws) = s.g.get(v) {
            for w in ws {
                if !s.index.contains_key(w) {
                    visit(s, w);
                    let lw = s.low[w];
                    let lv = s.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(lw);
                } else if s.on.contains(w) {
                    let iw = s.index[w];
                    let lv = s.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(iw);
                }
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = BTreeSet::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.insert(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                s.out.push(comp);
            }
        }
    }
    let mut s = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        on: BTreeSet::new(),
        stack: Vec::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// The edges inside one cycle, for the message.
fn describe(g: &Graph, comp: &BTreeSet<Module>) -> String {
    let mut lines = Vec::new();
    for m in comp {
        let inside: Vec<String> = g[m]
            .iter()
            .filter(|n| comp.contains(*n))
            .map(name)
            .collect();
        lines.push(format!("    {} -> {}", name(m), inside.join(", ")));
    }
    lines.join("\n")
}

/// The problems of one crate against the known list: unknown or changed cycles, and known
/// ones that went.
fn check(krate: &str, g: &Graph, known: &[(&str, &[&str])]) -> Vec<String> {
    let found = cycles(g);
    let known: Vec<BTreeSet<String>> = known
        .iter()
        .filter(|(k, _)| *k == krate)
        .map(|(_, ms)| ms.iter().map(|s| s.to_string()).collect())
        .collect();
    let mut problems = Vec::new();
    let mut matched = vec![false; known.len()];
    for comp in &found {
        let names: BTreeSet<String> = comp.iter().map(name).collect();
        if let Some(k) = known.iter().position(|k| *k == names) {
            matched[k] = true;
        } else {
            problems.push(format!(
                "{krate}: a module cycle that is not in KNOWN as it stands: {{{}}}\n{}",
                names.iter().cloned().collect::<Vec<_>>().join(", "),
                describe(g, comp)
            ));
        }
    }
    for (k, m) in known.iter().zip(&matched) {
        if !m {
            problems.push(format!(
                "{krate}: the known cycle {{{}}} is no longer a cycle as listed: remove its \
                 entry from KNOWN (and list the cycles above, if any are left of it, only \
                 as they are now)",
                k.iter().cloned().collect::<Vec<_>>().join(", ")
            ));
        }
    }
    problems
}

#[test]
fn no_module_cycles_beyond_the_known_ones() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut problems = Vec::new();
    let mut report = Vec::new();
    for (krate, dir) in CRATES {
        let sources = read_crate(&root.join(dir));
        assert!(
            !sources.is_empty() || *krate == "python",
            "no modules read in {dir}"
        );
        let g = graph(&sources);
        for comp in cycles(&g) {
            report.push(format!("{krate}:\n{}", describe(&g, &comp)));
        }
        problems.extend(check(krate, &g, KNOWN));
        for (k, top) in COMMAND.iter().filter(|(k, _)| k == krate) {
            for (from, to) in into_command(&g, &m(top)) {
                problems.push(format!(
                    "{k}: library module {} names the command's {}",
                    name(&from),
                    name(&to)
                ));
            }
        }
    }
    // The current cycles, printed for `--nocapture` readers and for the failure message.
    println!(
        "module cycles now ({}):\n{}",
        report.len(),
        report.join("\n")
    );
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
    for (krate, _) in KNOWN {
        assert!(
            CRATES.iter().any(|(k, _)| k == krate),
            "KNOWN names an unknown crate {krate}"
        );
    }
}

// ---- the check checks: synthetic crates ----

fn synthetic(files: &[(&str, &str)]) -> BTreeMap<Module, String> {
    files
        .iter()
        .map(|(p, src)| {
            (
                module_of(Path::new(p)).expect("not a root"),
                src.to_string(),
            )
        })
        .collect()
}

fn m(s: &str) -> Module {
    s.split("::").map(String::from).collect()
}

#[test]
fn a_two_module_cycle_is_found_and_fails_the_check() {
    let g = graph(&synthetic(&[
        ("kernel.rs", "use crate::source::Source;\npub fn k() {}"),
        (
            "source.rs",
            "pub trait Source {}\nfn f() { crate::kernel::k() }",
        ),
        ("range.rs", "use crate::{kernel, source::Source};"),
    ]));
    let c = cycles(&g);
    assert_eq!(c, vec![BTreeSet::from([m("kernel"), m("source")])]);
    assert_eq!(check("x", &g, &[]).len(), 1);
    // listed exactly: passes; listed larger or on another crate: fails
    assert!(check("x", &g, &[("x", &["kernel", "source"])]).is_empty());
    assert_eq!(
        check("x", &g, &[("x", &["kernel", "source", "range"])]).len(),
        2
    );
    assert_eq!(check("x", &g, &[("y", &["kernel", "source"])]).len(), 1);
}

#[test]
fn a_known_cycle_that_went_fails_until_it_is_removed_from_the_list() {
    let g = graph(&synthetic(&[
        ("kernel.rs", "use crate::source::Source;"),
        ("source.rs", "pub trait Source {}"),
    ]));
    assert!(cycles(&g).is_empty());
    assert!(check("x", &g, &[]).is_empty());
    assert_eq!(check("x", &g, &[("x", &["kernel", "source"])]).len(), 1);
}

#[test]
fn super_self_groups_and_child_names_are_edges_but_ancestors_are_not() {
    let g = graph(&synthetic(&[
        ("cli/mod.rs", "pub mod demo; pub fn run() { demo::run() }"),
        (
            "cli/demo.rs",
            "use super::{analyze::num, Ui};\npub fn run() {}",
        ),
        ("cli/analyze.rs", "pub fn num() { self::inner::x() }"),
        (
            "cli/analyze/inner.rs",
            "pub fn x() { super::super::Ui::new(); crate::export::w() }",
        ),
        (
            "export.rs",
            "#[arg(value_parser = crate::cli::parse)]\nstruct A;",
        ),
    ]));
    assert_eq!(g[&m("cli")], BTreeSet::from([m("cli::demo")]));
    // `super::Ui` is the parent's: no edge
    assert_eq!(g[&m("cli::demo")], BTreeSet::from([m("cli::analyze")]));
    assert_eq!(
        g[&m("cli::analyze")],
        BTreeSet::from([m("cli::analyze::inner")])
    );
    assert_eq!(g[&m("cli::analyze::inner")], BTreeSet::from([m("export")]));
    assert_eq!(g[&m("export")], BTreeSet::from([m("cli")]));
    // library code reaching up into the command is flagged on its own, and closes a cycle
    assert_eq!(into_command(&g, &m("cli")), vec![(m("export"), m("cli"))]);
    assert_eq!(
        cycles(&g),
        vec![BTreeSet::from([
            m("cli"),
            m("cli::analyze"),
            m("cli::analyze::inner"),
            m("cli::demo"),
            m("export"),
        ])]
    );
    // a child using its parent alone is no cycle
    let g = graph(&synthetic(&[
        (
            "logs/mod.rs",
            "pub fn read() { mcap::read() } pub struct Stamp;",
        ),
        (
            "logs/mcap.rs",
            "use super::Stamp; use crate::logs::Stamp as S; pub fn read() {}",
        ),
    ]));
    assert_eq!(g[&m("logs")], BTreeSet::from([m("logs::mcap")]));
    assert!(cycles(&g).is_empty());
}

#[test]
fn tests_comments_strings_and_other_crates_are_not_edges() {
    let g = graph(&synthetic(&[
        (
            "a.rs",
            "//! see crate::b::f\n/* crate::b /* nested */ crate::b */\n\
             fn f<'a>(x: &'a str) -> char { let _ = \"crate::b::f\"; \
             let _ = r#\"super::b\"#; avar::b::g(); $crate::b::h(); 'b' }\n\
             #[cfg(test)]\nmod tests { use crate::b::f; }\n\
             #[cfg(test)]\nuse crate::b::g;\n",
        ),
        ("b.rs", "use crate::a::f;"),
    ]));
    assert_eq!(g[&m("a")], BTreeSet::new());
    assert!(cycles(&g).is_empty());
}

#[test]
fn a_longer_cycle_is_one_component_with_its_edges_named() {
    let g = graph(&synthetic(&[
        ("a.rs", "use crate::b::X;"),
        ("b.rs", "use crate::c::Y;"),
        ("c.rs", "use crate::a::Z; use crate::d::W;"),
        ("d.rs", ""),
        ("e.rs", "use crate::d::W;"),
    ]));
    let c = cycles(&g);
    assert_eq!(c, vec![BTreeSet::from([m("a"), m("b"), m("c")])]);
    let d = describe(&g, &c[0]);
    assert!(d.contains("c -> a"), "{d}");
    assert!(!d.contains("-> d"), "{d}");
}
