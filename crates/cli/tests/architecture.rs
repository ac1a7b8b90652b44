//! The workspace's shape, checked on every test run:
//! * crate dependencies point one way, along the layers `ARCHITECTURE.md` names;
//! * inside each crate, no module uses another in a cycle (what `cargo modules dependencies
//!   --acyclic` checks, done here from the sources so that CI installs nothing).
//!
//! The module graph is read from the text of the sources: module `a` uses module `b` when a
//! path `crate::b…` (or `super::b…`, `self::b…`) appears in `a`'s non-test code (comments,
//! and so doc links, left out). Items that a
//! parent module re-exports (`pub use child::Item`) are resolved to the child that defines
//! them, as the compiler resolves them. Unit-test modules (from `#[cfg(test)]` on) are left
//! out: tests may use what they test.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

/// The layer of each crate: a crate may depend only on crates of lower layers.
const LAYERS: &[(&str, u32)] = &[
    ("fiberlab-math", 0),
    ("fiberlab-scatter", 1),
    ("fiberlab-geometry", 1),
    ("fiberlab-io", 2),
    ("fiberlab-check", 3),
    ("fiberlab-gonio", 3),
    ("fiberlab-fit", 3),
    ("fiberlab-procedural", 3),
    ("fiberlab-render", 4),
    ("fiberlab-compare", 5),
    ("fiberlab-gpu", 5),
    ("fiberlab-explorer", 6),
    ("fiberlab-cli", 7),
    ("fiberlab-py", 7),
];

fn layer(name: &str) -> u32 {
    LAYERS.iter().find(|(n, _)| *n == name).unwrap_or_else(|| panic!("crate {name} has no layer in LAYERS")).1
}

/// `[dependencies]` of a manifest that are workspace crates.
fn internal_dependencies(manifest: &str) -> Vec<String> {
    let table: toml::Table = manifest.parse().unwrap();
    let deps = table.get("dependencies").and_then(|d| d.as_table()).cloned().unwrap_or_default();
    deps.keys().filter(|k| k.starts_with("fiberlab-")).cloned().collect()
}

#[test]
fn crate_dependencies_point_one_way() {
    let crates = workspace().join("crates");
    let mut seen = 0;
    for entry in std::fs::read_dir(&crates).unwrap() {
        let manifest = entry.unwrap().path().join("Cargo.toml");
        let Ok(text) = std::fs::read_to_string(&manifest) else { continue };
        let table: toml::Table = text.parse().unwrap();
        let name = table["package"]["name"].as_str().unwrap().to_string();
        for dep in internal_dependencies(&text) {
            assert!(
                layer(&dep) < layer(&name),
                "{name} depends on {dep}, which is not below it (layers: {LAYERS:?}); see ARCHITECTURE.md"
            );
        }
        seen += 1;
    }
    assert_eq!(seen, LAYERS.len(), "every crate under crates/ is listed in LAYERS");
}

/// A crate's modules: path (`["hair", "longitudinal"]`) → non-test source text.
fn modules(src: &Path) -> BTreeMap<Vec<String>, String> {
    fn walk(dir: &Path, prefix: &[String], out: &mut BTreeMap<Vec<String>, String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                let mut p = prefix.to_vec();
                p.push(stem);
                walk(&path, &p, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let mut module = prefix.to_vec();
                if !matches!(stem.as_str(), "lib" | "main" | "mod") {
                    module.push(stem);
                }
                let text = std::fs::read_to_string(&path).unwrap();
                // Comments (doc links included) are not uses; a test module (`#[cfg(test)]`
                // then `mod … {`) ends what counts; `#[cfg(test)] mod x;` is skipped.
                let mut code = String::new();
                let mut lines = text.lines().map(|l| l.find("//").map_or(l, |at| &l[..at])).peekable();
                while let Some(line) = lines.next() {
                    if line.trim() == "#[cfg(test)]" {
                        match lines.peek() {
                            Some(next) if next.trim_start().starts_with("mod ") && next.contains('{') => break,
                            Some(next) if next.trim_start().starts_with("mod ") => {
                                lines.next();
                                continue;
                            }
                            _ => {}
                        }
                    }
                    code.push_str(line);
                    code.push('\n');
                }
                out.entry(module).or_default().push_str(&code);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, &[], &mut out);
    out
}

/// The `path::segments` that follow `lead` (e.g. `crate::`) in `code`, including those inside
/// `{…}` groups of a `use` (`use crate::{a::X, b}` yields `a::X` and `b`).
fn paths_after(code: &str, lead: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find(lead) {
        let before = rest[..at].chars().next_back();
        rest = &rest[at + lead.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        out.extend(expand(rest));
    }
    out
}

/// Paths at the start of `text`: `a::b::{c, d::e}` → `[a,b,c]`, `[a,b,d,e]`.
fn expand(text: &str) -> Vec<Vec<String>> {
    let ident: String = text.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
    if ident.is_empty() {
        if let Some(inner) = text.strip_prefix('{') {
            let mut depth = 0;
            let mut end = inner.len();
            for (i, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        end = i;
                        break;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            let mut items = Vec::new();
            let (mut depth, mut start) = (0, 0);
            let group = &inner[..end];
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        items.extend(expand(group[start..i].trim_start()));
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            items.extend(expand(group[start..].trim_start()));
            return items;
        }
        return Vec::new();
    }
    let rest = &text[ident.len()..];
    match rest.strip_prefix("::") {
        Some(more) => expand(more)
            .into_iter()
            .map(|mut p| {
                p.insert(0, ident.clone());
                p
            })
            .chain(std::iter::once(vec![ident.clone()]).filter(|_| expand(more).is_empty()))
            .collect(),
        None => vec![vec![ident]],
    }
}

/// Where the item at `path` (absolute, from the crate root) is defined: the longest module
/// prefix, then through that module's `pub use` re-exports of its children.
fn resolve(mods: &BTreeMap<Vec<String>, String>, path: &[String]) -> Option<Vec<String>> {
    let mut module: Vec<String> = Vec::new();
    for seg in path {
        let mut next = module.clone();
        next.push(seg.clone());
        if mods.contains_key(&next) {
            module = next;
            continue;
        }
        // `seg` is an item of `module`: defined there, or re-exported from a child.
        for reexport in paths_after(&mods[&module], "pub use ") {
            if reexport.last() == Some(seg) && reexport.len() > 1 {
                let mut target = module.clone();
                let start = usize::from(reexport[0] == "self" || reexport[0] == "crate");
                if reexport[0] == "crate" {
                    target.clear();
                }
                target.extend(reexport[start..reexport.len() - 1].iter().cloned());
                if mods.contains_key(&target) && target != module {
                    return resolve(mods, &[target, vec![seg.clone()]].concat());
                }
            }
        }
        break;
    }
    Some(module)
}

/// Edges `a → b` (module a uses module b), without self-edges.
fn module_edges(mods: &BTreeMap<Vec<String>, String>) -> BTreeSet<(Vec<String>, Vec<String>)> {
    let mut edges = BTreeSet::new();
    for (module, code) in mods {
        let mut targets = Vec::new();
        for p in paths_after(code, "crate::") {
            targets.push(p);
        }
        let parent: Vec<String> = module[..module.len().saturating_sub(1)].to_vec();
        for p in paths_after(code, "super::") {
            targets.push([parent.clone(), p].concat());
        }
        for p in paths_after(code, "self::") {
            targets.push([module.clone(), p].concat());
        }
        for t in targets {
            if let Some(target) = resolve(mods, &t)
                && &target != module
            {
                edges.insert((module.clone(), target));
            }
        }
    }
    edges
}

/// A cycle in the graph, if any (depth-first search).
fn find_cycle(edges: &BTreeSet<(Vec<String>, Vec<String>)>) -> Option<Vec<Vec<String>>> {
    let nodes: BTreeSet<&Vec<String>> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    let mut state: BTreeMap<&Vec<String>, u8> = nodes.iter().map(|n| (*n, 0u8)).collect();
    fn visit<'a>(
        n: &'a Vec<String>,
        edges: &'a BTreeSet<(Vec<String>, Vec<String>)>,
        state: &mut BTreeMap<&'a Vec<String>, u8>,
        stack: &mut Vec<&'a Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        state.insert(n, 1);
        stack.push(n);
        for (_, m) in edges.iter().filter(|(a, _)| a == n) {
            match state[m] {
                1 => {
                    let at = stack.iter().position(|x| *x == m).unwrap();
                    return Some(stack[at..].iter().map(|x| (*x).clone()).chain([m.clone()]).collect());
                }
                0 => {
                    if let Some(c) = visit(m, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n, 2);
        None
    }
    for n in nodes {
        if state[n] == 0
            && let Some(c) = visit(n, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn no_crate_has_a_module_cycle() {
    let crates = workspace().join("crates");
    let (mut checked, mut cycles) = (0, Vec::new());
    for entry in std::fs::read_dir(&crates).unwrap() {
        let src = entry.unwrap().path().join("src");
        if !src.is_dir() {
            continue;
        }
        let mods = modules(&src);
        let edges = module_edges(&mods);
        if let Some(cycle) = find_cycle(&edges) {
            let shown: Vec<String> =
                cycle.iter().map(|m| if m.is_empty() { "crate".to_string() } else { m.join("::") }).collect();
            cycles.push(format!("{}: modules use each other in a cycle: {}", src.display(), shown.join(" → ")));
        }
        checked += 1;
    }
    assert!(cycles.is_empty(), "{}", cycles.join("\n"));
    assert!(checked >= LAYERS.len());
}

/// The checker itself finds a cycle where there is one and resolves re-exports.
#[test]
fn the_cycle_check_sees_cycles_and_re_exports() {
    let m = |pairs: &[(&str, &str)]| -> BTreeMap<Vec<String>, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.split("::").filter(|s| !s.is_empty()).map(String::from).collect(), v.to_string()))
            .collect()
    };
    let cyclic = m(&[("", "mod a; mod b;"), ("a", "use crate::b::X;"), ("b", "use crate::a::{Y, Z};")]);
    assert!(find_cycle(&module_edges(&cyclic)).is_some());
    // `a` uses `Model`, re-exported by the root from `b`: an edge a → b, not a → root.
    let through_root =
        m(&[("", "mod a; mod b; pub use b::Model;"), ("a", "use crate::Model;"), ("b", "pub struct Model;")]);
    let edges = module_edges(&through_root);
    assert!(edges.contains(&(vec!["a".into()], vec!["b".into()])), "{edges:?}");
    assert!(find_cycle(&edges).is_none());
    // Siblings through `super::`.
    let siblings =
        m(&[("", "mod h;"), ("h", "mod x; mod y;"), ("h::x", "use super::y::F;"), ("h::y", "use super::x::G;")]);
    assert!(find_cycle(&module_edges(&siblings)).is_some());
}
