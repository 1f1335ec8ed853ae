//! The module import graph of both crates has no cycles.
//!
//! Every `crate::a::…`, `super::…` and `self::…` path in a module's source (comments and
//! `#[cfg(test)]` code left out) is an edge from that module to the module it names. Two
//! modules depend on each other only through their first differing ancestors, so the edge is
//! kept between those: two top-level modules, or two sibling submodules of one parent (an edge
//! between a module and its own parent or child is not counted). A cycle among those edges
//! means two parts of a crate cannot be read, tested or changed one without the other.
//!
//! The baker library (`baker/src`, the binary's `baker/src/bin` apart), the `facebake` binary's
//! own tree and the runtime are checked.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

/// Every `.rs` file under `root` (leaving out `skip`), as (module path, source).
fn modules(root: &Path, skip: Option<&Path>) -> Vec<(Module, String)> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("source folder reads") {
            let path = entry.expect("entry").path();
            if Some(path.as_path()) == skip {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(root).expect("under root");
                let mut parts: Module = rel
                    .with_extension("")
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if parts.last().is_some_and(|l| l == "mod") {
                    parts.pop();
                }
                if parts.len() == 1 && (parts[0] == "lib" || parts[0] == "main") {
                    parts.clear();
                }
                // A module's `tests.rs` is test code.
                if parts.last().is_some_and(|l| l == "tests") {
                    continue;
                }
                let text = std::fs::read_to_string(&path).expect("source reads");
                out.push((parts, text));
            }
        }
    }
    out
}

/// The code of a file without comments and without what follows its first `#[cfg(test)]`.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Identifiers following `prefix` in `text`: `a::b::c` gives `[a, b, c]`; a `{a, b::c}` group
/// gives one path per member (its first segments).
fn paths_after(text: &str, prefix: &str) -> Vec<Vec<String>> {
    let ident = |s: &str| -> Vec<String> {
        s.split("::")
            .map(|seg| {
                seg.chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect::<String>()
            })
            .take_while(|seg| !seg.is_empty())
            .collect()
    };
    let mut out = Vec::new();
    for (i, _) in text.match_indices(prefix) {
        // `prefix` must start a path, not end an identifier (`mycrate::`).
        let before = text[..i].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let rest = &text[i + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for member in group[..end].split(',') {
                let p = ident(member.trim());
                if !p.is_empty() {
                    out.push(p);
                }
            }
        } else {
            let p = ident(rest);
            if !p.is_empty() {
                out.push(p);
            }
        }
    }
    out
}

/// The edges between top-level modules and between sibling submodules, each with a witness.
fn edges(files: &[(Module, String)]) -> BTreeMap<(Module, Module), String> {
    let known: BTreeSet<Module> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut out = BTreeMap::new();
    for (module, text) in files {
        let text = code(text);
        // A file `a/b.rs` is module `a::b`: its `super` is `a`.
        let parent: Module = module[..module.len().saturating_sub(1)].to_vec();
        let mut targets: Vec<Module> = Vec::new();
        for p in paths_after(&text, "crate::") {
            targets.push(p);
        }
        for p in paths_after(&text, "super::") {
            targets.push(parent.iter().cloned().chain(p).collect());
        }
        for p in paths_after(&text, "self::") {
            targets.push(module.iter().cloned().chain(p).collect());
        }
        for target in targets {
            // The deepest module the path names.
            let Some(target) = (1..=target.len())
                .rev()
                .map(|n| target[..n].to_vec())
                .find(|t| known.contains(t))
            else {
                continue;
            };
            let common = module
                .iter()
                .zip(&target)
                .take_while(|(a, b)| a == b)
                .count();
            if common < module.len() && common < target.len() {
                let from = module[..=common].to_vec();
                let to = target[..=common].to_vec();
                out.entry((from, to))
                    .or_insert_with(|| format!("{} → {}", module.join("::"), target.join("::")));
            }
        }
    }
    out
}

/// The cycles of the graph: its strongly connected components of more than one module.
fn cycles(edges: &BTreeMap<(Module, Module), String>) -> Vec<Vec<Module>> {
    let mut graph: BTreeMap<&Module, Vec<&Module>> = BTreeMap::new();
    for (a, b) in edges.keys() {
        graph.entry(a).or_default().push(b);
        graph.entry(b).or_default();
    }
    // Kosaraju: finishing order on the graph, then components on the reversed graph.
    let mut order = Vec::new();
    let mut seen = BTreeSet::new();
    for &start in graph.keys() {
        if seen.contains(start) {
            continue;
        }
        let mut stack = vec![(start, 0usize)];
        seen.insert(start);
        while let Some((v, i)) = stack.pop() {
            if let Some(&w) = graph[v].get(i) {
                stack.push((v, i + 1));
                if seen.insert(w) {
                    stack.push((w, 0));
                }
            } else {
                order.push(v);
            }
        }
    }
    let mut reverse: BTreeMap<&Module, Vec<&Module>> = BTreeMap::new();
    for (a, bs) in &graph {
        for b in bs {
            reverse.entry(b).or_default().push(a);
        }
    }
    let mut assigned = BTreeSet::new();
    let mut out = Vec::new();
    for &v in order.iter().rev() {
        if !assigned.insert(v) {
            continue;
        }
        let mut component = vec![v.clone()];
        let mut stack = vec![v];
        while let Some(x) = stack.pop() {
            for &w in reverse.get(x).map(Vec::as_slice).unwrap_or(&[]) {
                if assigned.insert(w) {
                    component.push(w.clone());
                    stack.push(w);
                }
            }
        }
        if component.len() > 1 {
            component.sort();
            out.push(component);
        }
    }
    out
}

/// The cycles of the crate rooted at `root`, described with a witness per edge.
fn describe(root: &Path, skip: Option<&Path>) -> (usize, Vec<String>) {
    let files = modules(root, skip);
    let edges = edges(&files);
    let found = cycles(&edges)
        .into_iter()
        .map(|c| {
            let members: BTreeSet<&Module> = c.iter().collect();
            let witnesses: Vec<&str> = edges
                .iter()
                .filter(|((a, b), _)| members.contains(a) && members.contains(b))
                .map(|(_, w)| w.as_str())
                .collect();
            format!(
                "cycle among {{{}}}: {}",
                c.iter()
                    .map(|m| m.join("::"))
                    .collect::<Vec<_>>()
                    .join(", "),
                witnesses.join("; ")
            )
        })
        .collect();
    (edges.len(), found)
}

fn source(crate_dir: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(crate_dir)
        .join("src")
}

#[test]
fn the_baker_library_has_no_import_cycles() {
    let root = source("baker");
    let (count, found) = describe(&root, Some(&root.join("bin")));
    println!("baker library: {count} edges");
    assert!(count > 20, "the graph was read: {count} edges");
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_facebake_binary_has_no_import_cycles() {
    let (count, found) = describe(&source("baker").join("bin").join("facebake"), None);
    println!("facebake binary: {count} edges");
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_runtime_has_no_import_cycles() {
    let (count, found) = describe(&source("runtime"), None);
    println!("runtime: {count} edges");
    assert!(count > 5, "the graph was read: {count} edges");
    assert!(found.is_empty(), "{}", found.join("\n"));
}

/// The checker itself finds a cycle and ignores parent–child and commented references.
#[test]
fn the_checker_finds_a_planted_cycle() {
    let file = |m: &[&str], text: &str| {
        (
            m.iter().map(|s| s.to_string()).collect::<Module>(),
            text.to_string(),
        )
    };
    let files = vec![
        file(&[], "pub mod a; pub mod b; pub mod c;"),
        file(
            &["a"],
            "use crate::b::X;\n// use crate::c::Y;\npub mod x; pub mod y;",
        ),
        file(&["a", "x"], "use super::y::Z; use super::Thing;"),
        file(&["a", "y"], "use crate::a::x::W;"),
        file(&["b"], "use crate::{c::Q, a};"),
        file(
            &["c"],
            "fn f() { let _ = 1; }\n#[cfg(test)]\nmod t { use crate::a::X; }",
        ),
    ];
    let e = edges(&files);
    let found = cycles(&e);
    let mut names: Vec<Vec<String>> = found
        .iter()
        .map(|c| c.iter().map(|m| m.join("::")).collect())
        .collect();
    names.sort();
    assert_eq!(
        names,
        vec![
            vec!["a".to_string(), "b".to_string()],
            vec!["a::x".to_string(), "a::y".to_string()]
        ],
        "{e:?}"
    );
}
