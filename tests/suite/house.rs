//! The code's house (ARCHITECTURE.md): no two files import each other, directly or round a longer
//! circle, in any language. A file "imports" another when it names an item of it:
//! - Rust (each crate's src/): `crate::a::b`, `super::x` and `child::x` paths (a module it declares),
//!   outside `mod` lines and the `#[cfg(test)]` module at a file's end, resolved to the file of the
//!   longest module path that exists; a module's references to its parent module (the mod.rs that
//!   declares it) and back are not counted, as `farm-studio look` does not draw them;
//! - JavaScript: `import`/`export ... from './x.js'`;
//! - Python: `import x`, `from x import`, `from .x import` of a module in the same folder or package.

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Graph = BTreeMap<PathBuf, BTreeSet<PathBuf>>;

/// Files under `dir` (recursively) ending in `ext`, skipping build and environment folders.
fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if p.is_dir() && !["target", ".venv", "node_modules", ".git", "__pycache__"].contains(&name.as_str()) {
            out.extend(files(&p, ext));
        } else if name.ends_with(ext) {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// A file's text without its `#[cfg(test)]` module (the last item of a file, by the house's style) and
/// its comments.
fn rust_code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or(text);
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// The module path of a crate's source file: src/a/b.rs and src/a/b/mod.rs are ["a", "b"].
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().to_string()).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// Rust: one crate's files and the files each names items of.
fn rust_graph(src: &Path) -> Graph {
    let all = files(src, ".rs");
    let by_module: BTreeMap<Vec<String>, PathBuf> = all.iter().map(|f| (module_of(src, f), f.clone())).collect();
    let resolve = |path: &[String]| -> Option<PathBuf> {
        (1..=path.len()).rev().find_map(|n| by_module.get(&path[..n]).cloned())
    };
    let mut graph = Graph::new();
    for file in &all {
        let here = module_of(src, file);
        let code = rust_code(&std::fs::read_to_string(file).unwrap());
        // a module and its own parent (mod.rs or lib.rs, which declares it and hands its names on) are one
        // concept's face and rooms: their references either way are not an import between rooms
        let family = |t: &PathBuf| {
            let there = module_of(src, t);
            (!here.is_empty() && there == here[..here.len() - 1])
                || (!there.is_empty() && here == there[..there.len() - 1])
        };
        let mut targets = BTreeSet::new();
        // the modules this file declares: `child::item` names an item of the child's file
        let children: Vec<String> = code
            .lines()
            .filter_map(|l| l.trim().strip_suffix(';')?.rsplit_once("mod ").map(|(_, name)| name.trim().to_string()))
            .collect();
        for line in code.lines().filter(|l| !l.trim_start().starts_with("mod ") && !l.contains(" mod ")) {
            for child in &children {
                for (start, _) in line.match_indices(&format!("{child}::")) {
                    let before = line[..start].chars().next_back();
                    if before.is_none_or(|c| !(c.is_alphanumeric() || c == '_' || c == ':')) {
                        let mut path = here.clone();
                        path.push(child.clone());
                        let next: String = line[start + child.len() + 2..]
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        path.push(next);
                        if let Some(target) = resolve(&path).filter(|t| t != file && !family(t)) {
                            targets.insert(target);
                        }
                    }
                }
            }
            for (start, _) in line.match_indices("crate::").chain(line.match_indices("super::")) {
                let rest = &line[start..];
                let segments: Vec<String> = rest
                    .split("::")
                    .map(|s| s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>())
                    .take_while(|s| !s.is_empty())
                    .collect();
                let mut path = if rest.starts_with("crate::") { Vec::new() } else { here.clone() };
                let mut segs = segments.iter().skip(1).peekable();
                if rest.starts_with("super::") {
                    // super of a file's module is its parent module
                    path.pop();
                    while segs.peek().map(|s| s.as_str()) == Some("super") {
                        segs.next();
                        path.pop();
                    }
                }
                // a brace group (`use super::{a, b}`) names several modules
                let brace = rest.find("::{").filter(|&b| rest[..b].split("::").count() == segments.len());
                path.extend(segs.cloned());
                let mut paths = vec![path.clone()];
                if let Some(b) = brace {
                    let group = rest[b + 3..].split('}').next().unwrap_or("");
                    paths = group
                        .split(',')
                        .map(|item| {
                            let name: String =
                                item.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                            let mut p = path.clone();
                            p.push(name);
                            p
                        })
                        .collect();
                }
                for p in paths {
                    if let Some(target) = resolve(&p).filter(|t| t != file && !family(t)) {
                        targets.insert(target);
                    }
                }
            }
        }
        graph.insert(file.clone(), targets);
    }
    graph
}

/// JavaScript: `from './x.js'` in the same folder tree.
fn js_graph(dir: &Path) -> Graph {
    let mut graph = Graph::new();
    for file in files(dir, ".js") {
        let text = std::fs::read_to_string(&file).unwrap();
        let mut targets = BTreeSet::new();
        for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for quote in ["from '", "from \""] {
                if let Some(i) = line.find(quote) {
                    let rest = &line[i + quote.len()..];
                    let name = rest.split(['\'', '"']).next().unwrap_or("");
                    if name.starts_with('.') {
                        targets.insert(normalise(&file.parent().unwrap().join(name)));
                    }
                }
            }
        }
        graph.insert(file, targets);
    }
    graph
}

fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// Python: imports of modules of the same folder (`import x`, `from x import`, `from .x import`).
fn python_graph(dir: &Path) -> Graph {
    let mut graph = Graph::new();
    for file in files(dir, ".py") {
        let folder = file.parent().unwrap();
        let text = std::fs::read_to_string(&file).unwrap();
        let mut targets = BTreeSet::new();
        for line in text.lines() {
            let line = line.trim_start();
            let names: Vec<String> = if let Some(rest) = line.strip_prefix("from ") {
                let module = rest.split_whitespace().next().unwrap_or("");
                let module = module.trim_start_matches('.');
                vec![module.split('.').next_back().unwrap_or("").to_string()]
            } else if let Some(rest) = line.strip_prefix("import ") {
                rest.split(',').map(|m| m.split_whitespace().next().unwrap_or("").to_string()).collect()
            } else {
                continue;
            };
            for name in names {
                let target = folder.join(format!("{name}.py"));
                if target.is_file() && target != file {
                    targets.insert(target);
                }
            }
        }
        graph.insert(file, targets);
    }
    graph
}

/// Every circle of `graph` (each once, from its smallest file), as paths relative to `root`.
fn circles(graph: &Graph, root: &Path) -> Vec<String> {
    let mut found = BTreeSet::new();
    for start in graph.keys() {
        // depth-first from `start`, through files after it in order only, back to `start`
        let mut stack = vec![(start.clone(), vec![start.clone()])];
        while let Some((at, path)) = stack.pop() {
            for next in graph.get(&at).into_iter().flatten() {
                if next == start {
                    let names: Vec<String> =
                        path.iter().map(|p| p.strip_prefix(root).unwrap_or(p).display().to_string()).collect();
                    found.insert(names.join(" -> ") + " -> (back)");
                } else if next > start && !path.contains(next) && path.len() < 12 {
                    let mut longer = path.clone();
                    longer.push(next.clone());
                    stack.push((next.clone(), longer));
                }
            }
        }
    }
    found.into_iter().collect()
}

/// No circle in the repository's Rust crates, JavaScript modules or Python folders.
#[test]
fn no_import_circles() {
    let root = common::repo_root();
    let mut found = Vec::new();
    for krate in files(&root.join("pipeline"), "Cargo.toml") {
        let src = krate.parent().unwrap().join("src");
        found.extend(circles(&rust_graph(&src), &root));
    }
    found.extend(circles(&js_graph(&root.join("runtimes")), &root));
    found.extend(circles(&python_graph(&root), &root));
    assert!(found.is_empty(), "import circles:\n{}", found.join("\n"));
}

/// The checker finds a circle in each language (and a clean chain is none): small trees written here.
#[test]
fn the_circle_check_finds_circles() {
    let work = common::tempdir();
    let write = |rel: &str, text: &str| {
        let p = work.path().join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write("rs/src/lib.rs", "mod a;\nmod b;\nmod c;\n");
    write("rs/src/a.rs", "use crate::b::B;\npub struct A;\n");
    write("rs/src/b.rs", "use crate::c::{C, D};\npub struct B;\n#[cfg(test)]\nmod tests {\n    use crate::a::A;\n}\n");
    write("rs/src/c.rs", "pub struct C;\npub struct D;\n");
    write("rs/src/d/mod.rs", "mod e;\npub struct D;\n");
    write("rs/src/d/e.rs", "use super::D;\n");
    write("js/x.js", "import { y } from './y.js';\n");
    write("js/y.js", "// import { x } from './x.js';\nexport const y = 1;\n");
    write("py/p.py", "import q\n");
    write("py/q.py", "import os\n");
    let clean = |dir: &str, graph: Graph| assert!(circles(&graph, work.path()).is_empty(), "{dir}: {graph:?}");
    clean("rs", rust_graph(&work.path().join("rs/src")));
    clean("js", js_graph(&work.path().join("js")));
    clean("py", python_graph(&work.path().join("py")));
    // now close each circle
    write("rs/src/c.rs", "use super::a::A;\npub struct C;\npub struct D;\n");
    write("js/y.js", "export { x } from \"./x.js\";\n");
    write("py/q.py", "from p import f\n");
    let rs = circles(&rust_graph(&work.path().join("rs/src")), work.path());
    assert_eq!(rs, ["rs/src/a.rs -> rs/src/b.rs -> rs/src/c.rs -> (back)"]);
    assert_eq!(circles(&js_graph(&work.path().join("js")), work.path()), ["js/x.js -> js/y.js -> (back)"]);
    assert_eq!(circles(&python_graph(&work.path().join("py")), work.path()), ["py/p.py -> py/q.py -> (back)"]);
}

/// ARCHITECTURE.md's arrow into `ship/`: the shipping code reads what builders wrote, and no file of
/// twoscale-generate outside `ship/` names an item of it (the crate root's `mod` line aside).
#[test]
fn no_builder_imports_ship() {
    let src = common::repo_root().join("pipeline/generate/src");
    let ship = src.join("ship");
    let graph = rust_graph(&src);
    assert!(graph.keys().any(|f| f.starts_with(&ship)), "no ship/ module found under {}", src.display());
    let wrong: Vec<String> = graph
        .iter()
        .filter(|(from, _)| !from.starts_with(&ship))
        .flat_map(|(from, to)| {
            to.iter().filter(|t| t.starts_with(&ship)).map(move |t| format!("{} -> {}", from.display(), t.display()))
        })
        .collect();
    assert!(wrong.is_empty(), "builders import ship/:\n{}", wrong.join("\n"));
}
