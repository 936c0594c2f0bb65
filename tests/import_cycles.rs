//! No import circle among the modules of `src/` (issue 30, acceptance 2).
//!
//! The test reads the `mod` lines (which files are modules, and where) and the `use` lines of
//! every file under `src/`, with the qualified paths in code (`crate::scene::geometry::f(…)`,
//! `super::transition::mat_vec(…)`), and draws an edge from a file to the file that defines
//! what it imports. An import through a re-export (`pub use child::Item` in a `mod.rs`) is
//! followed to the file that defines the item, so a facade neither hides a circle nor makes
//! one: a child importing its parent's re-export of a sibling is an edge to that sibling, and
//! the re-export itself is no edge. A `mod` line is containment, not an edge, and so is a
//! file's use of its ancestors' items (`super::Item` defined in the parent's `mod.rs`): a
//! module's files are one unit whose face is its `mod.rs`. Test-only imports (`#[cfg(test)] mod … { … }`) are left out: they do not shape the
//! layers. Any strongly connected set of two or more files fails the test, with the edges that
//! close it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module: its path from the crate root (`["scene", "validate"]`) and its file.
struct Module {
    file: String,
    /// The statements of its `use` lines (without `pub`, `use` and `;`), and whether each is
    /// a re-export (`pub use`).
    uses: Vec<(String, bool)>,
    /// The names it declares with `mod` (children).
    children: BTreeSet<String>,
}

/// The text of a file without its `#[cfg(test)] mod … { … }` blocks and comments.
fn without_tests(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("#[cfg(test)]") {
            if let Some(next) = lines.peek() {
                let next = next.trim_start();
                if (next.starts_with("mod ") || next.starts_with("pub mod ")) && next.ends_with('{')
                {
                    let indent = lines.peek().unwrap().len() - next.len();
                    lines.next();
                    // The block ends at its closing brace at the same indentation.
                    for inner in lines.by_ref() {
                        let inner_trim = inner.trim_start();
                        if inner_trim == "}" && inner.len() - inner_trim.len() == indent {
                            break;
                        }
                    }
                    continue;
                }
            }
        }
        if trimmed.starts_with("//") {
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The `use` statements and `mod` declarations of one file.
fn parse(text: &str) -> (Vec<(String, bool)>, BTreeSet<String>) {
    let text = without_tests(text);
    let mut uses = Vec::new();
    let mut children = BTreeSet::new();
    let mut statement: Option<(String, bool)> = None;
    for line in text.lines() {
        let trimmed = line.trim();
        if let Some((s, _)) = statement.as_mut() {
            s.push(' ');
            s.push_str(trimmed);
        } else {
            let rest = strip_visibility(trimmed);
            if let Some(rest) = rest.strip_prefix("use ") {
                statement = Some((rest.to_string(), rest.len() < trimmed.len() - 4));
            } else if let Some(rest) = rest.strip_prefix("mod ") {
                if let Some(name) = rest.strip_suffix(';') {
                    children.insert(name.trim().to_string());
                }
                continue;
            } else {
                // A qualified path in code (`crate::scene::geometry::bodies(…)`) is an import
                // as much as a `use` line is.
                uses.extend(qualified_paths(trimmed).into_iter().map(|p| (p, false)));
                continue;
            }
        }
        let (s, public) = statement.as_ref().unwrap();
        if let Some(end) = s.find(';') {
            uses.push((s[..end].to_string(), *public));
            statement = None;
        }
    }
    (uses, children)
}

/// The paths starting with `crate::`, `super::` or `self::` in a line of code.
fn qualified_paths(line: &str) -> Vec<String> {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = ["crate::", "super::", "self::"]
        .iter()
        .filter_map(|root| rest.find(root))
        .min()
    {
        let before = rest[..at].chars().next_back();
        let tail = &rest[at..];
        let mut end = 0;
        let mut chars = tail.char_indices().peekable();
        while let Some((i, c)) = chars.next() {
            if ident(c) {
                end = i + c.len_utf8();
            } else if c == ':' && tail[i..].starts_with("::") {
                chars.next();
                let next = tail[i + 2..].chars().next();
                if !next.is_some_and(ident) {
                    break;
                }
            } else {
                break;
            }
        }
        // `Self::`, `my_crate::` and the like are not these roots.
        if !before.is_some_and(ident) {
            out.push(tail[..end].to_string());
        }
        rest = &tail[end.max(1)..];
    }
    out
}

fn strip_visibility(line: &str) -> &str {
    if let Some(rest) = line.strip_prefix("pub ") {
        return rest;
    }
    if line.starts_with("pub(") {
        if let Some(close) = line.find(") ") {
            return &line[close + 2..];
        }
    }
    line
}

/// Expands `a::{b, c::{d, e as f}}` into `a::b`, `a::c::d`, `a::c::e`, each with the name
/// it is visible under (`b`, `d`, `f`).
fn expand(tree: &str) -> Vec<(Vec<String>, String)> {
    let tree: String = tree.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = Vec::new();
    expand_into(&tree, &mut Vec::new(), &mut out);
    out
}

fn expand_into(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
    let tree = tree.trim();
    if let Some(open) = tree.find('{') {
        let head = tree[..open].trim().trim_end_matches("::");
        let inner = &tree[open + 1..tree.rfind('}').unwrap()];
        let depth = prefix.len();
        prefix.extend(
            head.split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_string),
        );
        for part in split_top(inner) {
            expand_into(part, prefix, out);
        }
        prefix.truncate(depth);
        return;
    }
    let mut parts = tree.split(" as ");
    let path = parts.next().unwrap().trim();
    if path.is_empty() {
        return;
    }
    let mut full = prefix.clone();
    full.extend(path.split("::").map(str::to_string));
    // `a::b::{self}` names the module `a::b`.
    if full.last().map(String::as_str) == Some("self") {
        full.pop();
    }
    let name = match parts.next() {
        Some(alias) => alias.trim().to_string(),
        None => full.last().cloned().unwrap_or_default(),
    };
    out.push((full, name));
}

/// Splits at the commas outside braces.
fn split_top(inner: &str) -> Vec<&str> {
    let (mut parts, mut depth, mut start) = (Vec::new(), 0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts.into_iter().filter(|p| !p.trim().is_empty()).collect()
}

/// Every module of the crate rooted at `root` (`lib.rs` or `main.rs`), by module path.
fn crate_modules(src: &Path, root: &str) -> BTreeMap<Vec<String>, Module> {
    let mut modules = BTreeMap::new();
    let mut queue = vec![(Vec::<String>::new(), src.join(root))];
    while let Some((path, file)) = queue.pop() {
        let text = std::fs::read_to_string(&file).unwrap();
        let (uses, children) = parse(&text);
        // The children of `a/b.rs` and `a/b/mod.rs` live in `a/b/`; those of the root in src/.
        let dir: PathBuf = src.join(path.join("/"));
        for child in &children {
            let mut child_path = path.clone();
            child_path.push(child.clone());
            let flat = dir.join(format!("{child}.rs"));
            let nested = dir.join(child).join("mod.rs");
            let child_file = if flat.exists() { flat } else { nested };
            assert!(child_file.exists(), "mod {child} of {}", file.display());
            queue.push((child_path, child_file));
        }
        let name = file
            .strip_prefix(src)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        modules.insert(
            path,
            Module {
                file: name,
                uses,
                children,
            },
        );
    }
    modules
}

/// The file that defines `path` (absolute, from the crate root), following `pub use`
/// re-exports of directory modules.
fn resolve(
    modules: &BTreeMap<Vec<String>, Module>,
    from: &[String],
    path: &[String],
    depth: usize,
) -> Option<String> {
    // The longest prefix that is a module file.
    let mut n = path.len();
    while n > 0 && !modules.contains_key(&path[..n]) {
        n -= 1;
    }
    let module = &modules[&path[..n]];
    if depth < 8 && n < path.len() {
        // An item of a directory module may be a re-export of a child's item.
        let item = &path[n];
        for (statement, public) in &module.uses {
            if !public {
                continue;
            }
            for (target, name) in expand(statement) {
                let glob = name == "*";
                if !(glob || &name == item) {
                    continue;
                }
                let Some(mut absolute) = absolute(modules, &path[..n], &target) else {
                    continue;
                };
                if glob {
                    absolute.pop();
                    absolute.push(item.clone());
                }
                absolute.extend(path[n + 1..].iter().cloned());
                if absolute.as_slice() == path || absolute.as_slice() == from {
                    continue;
                }
                if let Some(file) = resolve(modules, &path[..n], &absolute, depth + 1) {
                    // A glob that does not hold the item leaves it here.
                    if glob && file == module.file {
                        continue;
                    }
                    return Some(file);
                }
            }
        }
    }
    Some(module.file.clone())
}

/// A `use` path made absolute from module `from`; `None` for another crate.
fn absolute(
    modules: &BTreeMap<Vec<String>, Module>,
    from: &[String],
    path: &[String],
) -> Option<Vec<String>> {
    let first = path.first()?.as_str();
    let mut base: Vec<String> = match first {
        "crate" => Vec::new(),
        // The binary reaches the library as `geardyn::`.
        "geardyn" => vec!["<lib>".to_string()],
        "self" => from.to_vec(),
        "super" => {
            let mut base = from.to_vec();
            let mut rest = path;
            while rest.first().map(String::as_str) == Some("super") {
                base.pop();
                rest = &rest[1..];
            }
            base.extend(rest.iter().cloned());
            return Some(base);
        }
        name if modules[from].children.contains(name) => {
            let mut base = from.to_vec();
            base.extend(path.iter().cloned());
            return Some(base);
        }
        _ => return None,
    };
    base.extend(path[1..].iter().cloned());
    Some(base)
}

/// Tarjan's strongly connected components of a graph over file names.
fn components(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on_stack.insert(v);
        if let Some(targets) = s.edges.get(v) {
            for w in targets {
                let w = w.as_str();
                if !s.index.contains_key(w) {
                    visit(s, w);
                    let low = s.low[v].min(s.low[w]);
                    s.low.insert(v, low);
                } else if s.on_stack.contains(w) {
                    let low = s.low[v].min(s.index[w]);
                    s.low.insert(v, low);
                }
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on_stack.remove(w);
                component.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut state = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !state.index.contains_key(v.as_str()) {
            visit(&mut state, v);
        }
    }
    state.out
}

/// The import edges between the files of `src/`.
fn import_edges() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut modules = crate_modules(&src, "lib.rs");
    // The binary (main.rs and cli/) is a crate of its own; its `geardyn::` paths reach the
    // library, mounted here under `<lib>`.
    let lib: Vec<_> = std::mem::take(&mut modules).into_iter().collect();
    for (path, module) in lib {
        let mut mounted = vec!["<lib>".to_string()];
        mounted.extend(path);
        modules.insert(mounted, module);
    }
    for (path, module) in crate_modules(&src, "main.rs") {
        modules.insert(path, module);
    }
    let module_of: BTreeMap<String, Vec<String>> = modules
        .iter()
        .map(|(path, module)| (module.file.clone(), path.clone()))
        .collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (path, module) in &modules {
        let edges_of = edges.entry(module.file.clone()).or_default();
        for (statement, public) in &module.uses {
            // A re-export is the module's face, not a dependency: it is followed when another
            // module imports through it.
            if *public {
                continue;
            }
            for (target, _) in expand(statement) {
                // `crate::` in the library means the library root.
                let crate_root_is_lib = path.first().map(String::as_str) == Some("<lib>");
                let Some(mut absolute) = absolute(&modules, path, &target) else {
                    continue;
                };
                if crate_root_is_lib && target[0] == "crate" {
                    absolute.insert(0, "<lib>".to_string());
                }
                if let Some(file) = resolve(&modules, path, &absolute, 0) {
                    // A file is part of its ancestors' modules: what it takes from them is
                    // containment, like its `mod` line, not an edge.
                    let ancestor = path.starts_with(&module_of[&file]);
                    if file != module.file && !ancestor {
                        edges_of.insert(file);
                    }
                }
            }
        }
    }
    edges
}

#[test]
fn the_modules_of_src_import_each_other_without_circles() {
    let edges = import_edges();
    let files = edges.len();
    let count: usize = edges.values().map(BTreeSet::len).sum();
    assert!(
        files > 150 && count > 300,
        "the parse found {files} files, {count} edges"
    );
    let circles = components(&edges);
    let report: Vec<String> = circles
        .iter()
        .map(|component| {
            let inside: BTreeSet<&String> = component.iter().collect();
            let closing: Vec<String> = component
                .iter()
                .flat_map(|from| {
                    edges[from]
                        .iter()
                        .filter(|to| inside.contains(to))
                        .map(move |to| format!("    {from} → {to}"))
                })
                .collect();
            format!("  {}:\n{}", component.join(", "), closing.join("\n"))
        })
        .collect();
    println!(
        "{files} files, {count} import edges, {} circles",
        circles.len()
    );
    assert!(
        circles.is_empty(),
        "import circles in src/:\n{}",
        report.join("\n")
    );
}

#[test]
fn a_circle_is_found_when_there_is_one() {
    // The detector itself: a → b → c → a is one component, d alone is none.
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (from, to) in [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")] {
        edges
            .entry(from.to_string())
            .or_default()
            .insert(to.to_string());
    }
    edges.entry("d".to_string()).or_default();
    assert_eq!(components(&edges), vec![vec!["a", "b", "c"]]);
    let paths: Vec<Vec<String>> = expand("crate::scene::{spec::{A, B as C}, self, validate}")
        .into_iter()
        .map(|(path, _)| path)
        .collect();
    assert_eq!(
        paths,
        vec![
            vec!["crate", "scene", "spec", "A"],
            vec!["crate", "scene", "spec", "B"],
            vec!["crate", "scene"],
            vec!["crate", "scene", "validate"],
        ]
    );
}
