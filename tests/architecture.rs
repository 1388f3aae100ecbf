//! The layers of ARCHITECTURE.md, checked on the source: every `crate::`
//! path in the library's non-test code points to a module of the same or a
//! lower layer, the modules' import graph has no cycle, nor do the files
//! within each module folder, the command line stays small, and no library
//! file outside tests grows past about 900 lines.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, top first. A module may import from its own layer (without
/// a cycle) and from any layer below.
const LAYERS: &[&[&str]] = &[
    &["cli"],
    &["pipeline", "batch", "study", "compare", "stats", "error"],
    &["post", "sim", "io"],
    &["stress", "geometry", "bridge"],
    &["mesh", "scene"],
    &["math"],
];

/// Most lines of a library source file (tests excluded).
const MAX_FILE_LINES: usize = 900;

/// Largest share of `src/` the command line may have.
const MAX_CLI_SHARE: f64 = 0.12;

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The file's text without its `#[cfg(test)]` module and line comments.
fn code_of(text: &str) -> String {
    let cut = text.find("#[cfg(test)]\nmod ").unwrap_or(text.len());
    text[..cut]
        .lines()
        .map(|l| match l.find("//") {
            Some(k) => &l[..k],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The top-level modules a piece of code names through `crate::`,
/// including those inside `use crate::{a::x, b::{y, z}}` groups.
fn crate_refs(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(k) = rest.find("crate::") {
        let after = &rest[k + "crate::".len()..];
        if let Some(group) = after.strip_prefix('{') {
            // The top-level names of the brace group.
            let (mut depth, mut item, mut end) = (0usize, String::new(), group.len());
            for (i, c) in group.char_indices() {
                match c {
                    '{' => {
                        depth += 1;
                        item.push(c);
                    }
                    '}' if depth == 0 => {
                        end = i;
                        break;
                    }
                    '}' => {
                        depth -= 1;
                        item.push(c);
                    }
                    ',' if depth == 0 => {
                        out.insert(first_segment(&item));
                        item.clear();
                    }
                    _ => item.push(c),
                }
            }
            out.insert(first_segment(&item));
            rest = &group[end..];
        } else {
            out.insert(first_segment(after));
            rest = after;
        }
    }
    out.retain(|s| !s.is_empty() && s != "self");
    // `crate::Error` and `crate::Result` are the error module's.
    out.into_iter()
        .map(|s| match s.as_str() {
            "Error" | "Result" => "error".to_string(),
            _ => s,
        })
        .collect()
}

fn first_segment(s: &str) -> String {
    s.trim()
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect()
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `src/`, in path order: its path relative to
/// `src/` and its text.
fn source_files() -> Vec<(PathBuf, String)> {
    let src = src_dir();
    let mut files = Vec::new();
    rs_files(&src, &mut files);
    files
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(&f).expect("readable");
            (
                f.strip_prefix(&src).expect("inside src").to_path_buf(),
                text,
            )
        })
        .collect()
}

/// Top-level module of a library file (`None` for the crate roots).
fn module_of(rel: &Path) -> Option<String> {
    let first = rel.components().next()?.as_os_str().to_string_lossy();
    let m = first.trim_end_matches(".rs").to_string();
    (m != "main" && m != "lib").then_some(m)
}

/// Module -> (imported module -> files that import it).
fn import_graph() -> BTreeMap<String, BTreeMap<String, Vec<String>>> {
    let mut graph: BTreeMap<String, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    for (rel, text) in source_files() {
        let Some(module) = module_of(&rel) else {
            continue;
        };
        if rel.to_string_lossy().ends_with("_tests.rs") {
            continue;
        }
        let entry = graph.entry(module.clone()).or_default();
        for r in crate_refs(&code_of(&text)) {
            if r != module {
                entry.entry(r).or_default().push(rel.display().to_string());
            }
        }
    }
    graph
}

#[test]
fn the_parser_finds_grouped_and_nested_imports() {
    let code = "use crate::{math::{v3, Sym3}, mesh::SimMesh};\nlet x = crate::io::read(p);\nuse crate::{self as c};";
    let refs: Vec<String> = crate_refs(code).into_iter().collect();
    assert_eq!(refs, ["io", "math", "mesh"]);
    assert_eq!(
        code_of("use crate::a; // crate::b\n#[cfg(test)]\nmod tests { crate::c }"),
        "use crate::a; "
    );
}

#[test]
fn every_module_has_a_layer_and_imports_point_down() {
    let graph = import_graph();
    let mut wrong = Vec::new();
    for (module, imports) in &graph {
        let Some(from) = layer_of(module) else {
            wrong.push(format!("{module}: in no layer of ARCHITECTURE.md"));
            continue;
        };
        for (target, files) in imports {
            match layer_of(target) {
                None => wrong.push(format!("{module} -> {target}: {target} is in no layer")),
                Some(to) if to < from => wrong.push(format!(
                    "{module} (layer {from}) imports {target} (layer {to}, above it) in {}",
                    files.join(", ")
                )),
                Some(_) => {}
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layers:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_module_graph_has_no_cycle() {
    let graph = import_graph();
    // Depth-first search with colours; a grey target is a cycle.
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeMap<String, Vec<String>>>,
        colour: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        colour.insert(m.to_string(), 1);
        path.push(m.to_string());
        for t in graph.get(m).map(|i| i.keys()).into_iter().flatten() {
            match colour.get(t.as_str()).copied().unwrap_or(0) {
                1 => {
                    let k = path.iter().position(|p| p == t).unwrap_or(0);
                    let mut cycle = path[k..].to_vec();
                    cycle.push(t.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(t, graph, colour, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        colour.insert(m.to_string(), 2);
        None
    }
    let mut colour = BTreeMap::new();
    for m in graph.keys() {
        if colour.get(m.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(m, &graph, &mut colour, &mut Vec::new()) {
                panic!("import cycle: {}", c.join(" -> "));
            }
        }
    }
    // The graph is not empty: the check saw the library.
    assert!(graph.get("pipeline").is_some_and(|i| i.contains_key("sim")));
}

#[test]
fn the_command_line_is_small_and_library_files_are_readable() {
    let files = source_files();
    let (mut cli, mut total) = (0usize, 0usize);
    let mut long = Vec::new();
    for (rel, text) in &files {
        let lines = text.lines().count();
        total += lines;
        if rel.starts_with("cli") || rel == Path::new("main.rs") {
            cli += lines;
        }
        let name = rel.to_string_lossy();
        let code_lines = code_of(text).lines().count();
        if !name.ends_with("_tests.rs") && code_lines > MAX_FILE_LINES {
            long.push(format!("{name}: {code_lines} lines before its tests"));
        }
    }
    let share = cli as f64 / total as f64;
    assert!(
        share < MAX_CLI_SHARE,
        "the command line is {cli} of {total} lines ({:.1}%), above {:.0}%",
        100.0 * share,
        100.0 * MAX_CLI_SHARE
    );
    assert!(
        long.is_empty(),
        "files too long to read in one sitting:\n{}",
        long.join("\n")
    );
}

/// Most lines of one library function (ARCHITECTURE.md: about 150).
const MAX_FUNCTION_LINES: usize = 160;

/// `(name, lines)` of every function in `code`: from its `fn` line to the
/// closing brace at the same indentation.
fn function_lengths(code: &str) -> Vec<(String, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = l.len() - t.len();
        let t = t
            .strip_prefix("pub(in crate::sim) ")
            .or_else(|| t.strip_prefix("pub(crate) "))
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        let close = format!("{}}}", " ".repeat(indent));
        if let Some(k) = lines[i + 1..]
            .iter()
            .position(|m| m.starts_with(&close) && m.len() == close.len())
        {
            out.push((name, k + 2));
        }
    }
    out
}

/// Every function of the library and the command line, tests left out.
/// Until the functions outside `src/sim` were split, this guarded `sim/`
/// alone (`build_document` had 444 lines, `post::apply` 274).
#[test]
fn no_function_is_longer_than_about_150_lines() {
    assert_eq!(
        function_lengths("fn a() {\n    x;\n}\n    fn b() {\n        y;\n        z;\n    }\n"),
        [("a".to_string(), 3), ("b".to_string(), 4)]
    );
    let files = source_files();
    let mut long = Vec::new();
    for (rel, text) in &files {
        let rel = rel.display().to_string();
        if rel.ends_with("_tests.rs") {
            continue;
        }
        for (name, n) in function_lengths(&code_of(text)) {
            if n > MAX_FUNCTION_LINES {
                long.push(format!("{rel}: {name} has {n} lines"));
            }
        }
    }
    assert!(files.len() > 100, "the source files were not found");
    assert!(long.is_empty(), "functions too long:\n{}", long.join("\n"));
}

/// What reads or writes a file.
const FILE_IO: &[&str] = &[
    "std::fs::",
    "File::",
    "write_output(",
    "crate::io::read",
    "crate::io::write",
    "read_capped(",
];

/// The body of function `name` in `code` (from its `fn` line to the brace
/// closing it at the same indentation).
fn function_body<'a>(code: &'a str, name: &str) -> Option<String> {
    let lines: Vec<&'a str> = code.lines().collect();
    let head = format!("fn {name}(");
    let i = lines.iter().position(|l| l.contains(&head))?;
    let indent = lines[i].len() - lines[i].trim_start().len();
    let close = format!("{}}}", " ".repeat(indent));
    let k = lines[i + 1..]
        .iter()
        .position(|m| m.starts_with(&close) && m.len() == close.len())?;
    Some(lines[i..=i + 1 + k].join("\n"))
}

/// `pipeline::run` does no I/O (ARCHITECTURE.md): it reads nothing and
/// writes nothing, frames included (they reach the run's observer, and
/// `crack_file` writes them). Only `pipeline/output.rs` and `crack_file` /
/// `read_crackable` in `pipeline/run.rs` touch files. Before frames left
/// through the observer, `frames.rs` and `tear.rs` wrote them from inside
/// `run`, and this failed.
#[test]
fn the_pipeline_run_reads_and_writes_no_file() {
    let dir = src_dir().join("pipeline");
    let mut files = Vec::new();
    rs_files(&dir, &mut files);
    let mut found = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let code = code_of(&std::fs::read_to_string(f).expect("readable"));
        let parts: Vec<(String, String)> = match name.as_str() {
            "output.rs" => continue,
            "run.rs" => ["run", "tear_run", "prepare", "simulate"]
                .iter()
                .map(|n| {
                    let body = function_body(&code, n)
                        .unwrap_or_else(|| panic!("pipeline/run.rs has no fn {n}"));
                    (format!("run.rs: fn {n}"), body)
                })
                .collect(),
            _ => vec![(name.clone(), code)],
        };
        for (where_, body) in parts {
            for pat in FILE_IO {
                if body.contains(pat) {
                    found.push(format!("{where_}: {pat}"));
                }
            }
        }
    }
    assert!(files.len() > 10, "the pipeline's files were not found");
    // The check sees file I/O where it is allowed.
    let run = code_of(&std::fs::read_to_string(dir.join("run.rs")).unwrap());
    let crack_file = function_body(&run, "crack_file").expect("fn crack_file");
    assert!(FILE_IO.iter().any(|p| crack_file.contains(p)));
    assert!(
        found.is_empty(),
        "file I/O inside the run:\n{}",
        found.join("\n")
    );
}

/// The files of `src/sim` as modules (`driver`, `integrate::rkl`...) and
/// the sibling modules each names through `crate::sim::` (names re-exported
/// by `sim/mod.rs` count as their defining module).
fn sim_file_graph() -> BTreeMap<String, BTreeSet<String>> {
    let sim = src_dir().join("sim");
    let mod_rs = std::fs::read_to_string(sim.join("mod.rs")).expect("sim/mod.rs");
    // `pub use module::{A, b};` -> name -> module
    let mut reexport: BTreeMap<String, String> = BTreeMap::new();
    for stmt in mod_rs.split(';') {
        let s = stmt.trim();
        let Some(rest) = s.strip_prefix("pub use ") else {
            continue;
        };
        let Some((module, names)) = rest.split_once("::") else {
            continue;
        };
        for n in names.trim_matches(|c| c == '{' || c == '}').split(',') {
            let n = n.trim();
            if !n.is_empty() {
                reexport.insert(n.to_string(), module.to_string());
            }
        }
    }
    let mut files = Vec::new();
    rs_files(&sim, &mut files);
    let mut graph = BTreeMap::new();
    for f in files {
        let rel = f
            .strip_prefix(&sim)
            .expect("inside sim")
            .to_string_lossy()
            .into_owned();
        if rel == "mod.rs" || rel.ends_with("_tests.rs") {
            continue;
        }
        let name = rel
            .trim_end_matches(".rs")
            .trim_end_matches("/mod")
            .replace('/', "::");
        let code = code_of(&std::fs::read_to_string(&f).expect("readable"));
        let mut deps = BTreeSet::new();
        let mut rest = code.as_str();
        while let Some(k) = rest.find("crate::sim::") {
            rest = &rest[k + "crate::sim::".len()..];
            let mut items: Vec<String> = Vec::new();
            if let Some(group) = rest.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                items.extend(group[..end].split(',').map(|s| s.trim().to_string()));
            } else {
                items.push(
                    rest.chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == ':')
                        .collect(),
                );
            }
            for item in items {
                let mut parts = item.split("::").filter(|p| !p.is_empty());
                let Some(first) = parts.next() else { continue };
                let module = if first == "integrate" {
                    match parts.next() {
                        Some(p)
                            if p.chars().next().is_some_and(|c| c.is_ascii_lowercase())
                                && !p.contains('(') =>
                        {
                            let candidate = format!("integrate::{p}");
                            if sim.join("integrate").join(format!("{p}.rs")).exists() {
                                candidate
                            } else {
                                "integrate".to_string()
                            }
                        }
                        _ => "integrate".to_string(),
                    }
                } else if let Some(m) = reexport.get(first) {
                    m.clone()
                } else {
                    first.to_string()
                };
                if module != name {
                    deps.insert(module);
                }
            }
        }
        graph.insert(name, deps);
    }
    graph
}

#[test]
fn the_simulation_files_import_each_other_without_a_cycle() {
    let graph = sim_file_graph();
    assert!(
        graph
            .get("driver")
            .is_some_and(|d| d.contains("integrate") && d.contains("state")),
        "the file graph missed the driver's imports: {graph:?}"
    );
    let cyclic = on_a_cycle(&graph);
    assert!(
        cyclic.is_empty(),
        "files on an import cycle: {cyclic:?}\n{graph:#?}"
    );
}

/// The nodes of `graph` on a cycle or reached from one (Kahn's algorithm:
/// what is left over); empty when it has none.
fn on_a_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let mut indegree: BTreeMap<&str, usize> = graph.keys().map(|k| (k.as_str(), 0)).collect();
    for deps in graph.values() {
        for d in deps {
            if let Some(n) = indegree.get_mut(d.as_str()) {
                *n += 1;
            }
        }
    }
    let mut ready: Vec<&str> = indegree
        .iter()
        .filter(|(_, &n)| n == 0)
        .map(|(k, _)| *k)
        .collect();
    while let Some(m) = ready.pop() {
        for d in &graph[m] {
            if let Some(n) = indegree.get_mut(d.as_str()) {
                *n -= 1;
                if *n == 0 {
                    ready.push(d.as_str());
                }
            }
        }
    }
    indegree
        .iter()
        .filter(|(_, &n)| n > 0)
        .map(|(k, _)| k.to_string())
        .collect()
}

/// The files directly in `src/<dir>` as modules and the siblings each
/// names through `super::` or `crate::<dir>::` (comments and tests left
/// out).
fn sibling_file_graph(dir: &str) -> BTreeMap<String, BTreeSet<String>> {
    let root = src_dir().join(dir);
    let names: BTreeSet<String> = std::fs::read_dir(&root)
        .expect("readable")
        .filter_map(|e| {
            let p = e.ok()?.path();
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            (p.extension().is_some_and(|x| x == "rs") || p.is_dir()).then_some(stem)
        })
        .filter(|n| n != "mod" && !n.ends_with("_tests"))
        .collect();
    let mut graph = BTreeMap::new();
    for name in &names {
        let file = root.join(format!("{name}.rs"));
        let file = if file.is_file() {
            file
        } else {
            root.join(name).join("mod.rs")
        };
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue;
        };
        let code = code_of(&text);
        let own = format!("crate::{dir}::");
        let deps: BTreeSet<String> = code
            .match_indices("super::")
            .chain(code.match_indices(own.as_str()))
            .map(|(k, m)| first_segment(&code[k + m.len()..]))
            .filter(|d| d != name && names.contains(d))
            .collect();
        graph.insert(name.clone(), deps);
    }
    graph
}

/// The files of every module folder import each other without a cycle
/// (in the pipeline: the run calls the tearing and the time-lapse, which
/// do not call back into it; in the stress terms: the field builds the
/// impact's star and the masks' coordinates, which do not call back).
#[test]
fn the_files_of_each_module_import_each_other_without_a_cycle() {
    let pipeline = sibling_file_graph("pipeline");
    assert!(
        pipeline
            .get("run")
            .is_some_and(|d| d.contains("tear") && d.contains("frames")),
        "the file graph missed the run's imports: {pipeline:?}"
    );
    let mut dirs: Vec<String> = std::fs::read_dir(src_dir())
        .expect("readable")
        .filter_map(|e| {
            let p = e.ok()?.path();
            p.is_dir()
                .then(|| p.file_name().map(|n| n.to_string_lossy().into_owned()))?
        })
        .collect();
    dirs.sort();
    assert!(dirs.len() >= 10, "module folders: {dirs:?}");
    let mut cycles = Vec::new();
    for dir in &dirs {
        let graph = sibling_file_graph(dir);
        let cyclic = on_a_cycle(&graph);
        if !cyclic.is_empty() {
            cycles.push(format!("{dir}: {cyclic:?}\n{graph:#?}"));
        }
    }
    assert!(
        cycles.is_empty(),
        "files on an import cycle:\n{}",
        cycles.join("\n")
    );
}

/// Every `Result<..., String>` in `code`: a `Result` whose last type
/// argument is `String`, its brackets matched (nested and multi-line ones
/// count, `->` inside it is no bracket).
fn string_results(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("Result<") {
        let open = from + k + "Result<".len();
        let (mut depth, mut last_arg, mut end) = (1, open, None);
        let mut prev = ' ';
        for (i, c) in code[open..].char_indices() {
            match c {
                '<' | '(' | '[' => depth += 1,
                '>' if prev == '-' => {}
                '>' | ')' | ']' => {
                    depth -= 1;
                    if depth == 0 {
                        end = Some(open + i);
                        break;
                    }
                }
                ',' if depth == 1 => last_arg = open + i + 1,
                _ => {}
            }
            prev = c;
        }
        if let Some(end) = end {
            let last = code[last_arg..end].trim();
            if last_arg > open && (last == "String" || last == "std::string::String") {
                let text = &code[from + k..=end];
                found.push(text.split_whitespace().collect::<Vec<_>>().join(" "));
            }
        }
        from = open;
    }
    found
}

/// No error is a plain `String`: each layer's error is a type whose
/// variants carry what went wrong (ARCHITECTURE.md, Errors), tests
/// included.
#[test]
fn no_result_has_a_string_error() {
    assert_eq!(
        string_results(
            "fn a() -> Result<Vec<(u8, u8)>,\n    String> {}\nfn b() -> Result<(), Error> {}\n\
             fn c(f: impl Fn() -> Result<u8, String>) -> std::result::Result<Option<Result<u8, String>>, E> {}\n\
             fn d() -> Result<String> {}"
        ),
        [
            "Result<Vec<(u8, u8)>, String>",
            "Result<u8, String>",
            "Result<u8, String>"
        ]
    );
    let files = source_files();
    let mut found = Vec::new();
    for (rel, text) in &files {
        let rel = rel.display();
        let code: Vec<&str> = text
            .lines()
            .map(|l| l.find("//").map_or(l, |k| &l[..k]))
            .collect();
        for r in string_results(&code.join("\n")) {
            found.push(format!("{rel}: {r}"));
        }
    }
    assert!(files.len() > 100, "the source files were not found");
    assert!(
        found.is_empty(),
        "errors that are plain strings ({}):\n{}",
        found.len(),
        found.join("\n")
    );
}

/// Every tuple variant of an error enum (one deriving `thiserror::Error`,
/// or named `...Error`) in `code` whose fields are all `String`, as
/// `Enum::Variant`: a preformatted message where the error should carry
/// what went wrong as typed fields.
fn string_variants(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("enum ") {
        let at = from + k;
        from = at + "enum ".len();
        if at > 0 && code[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let name: String = code[from..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let attributes = &code[code[..at].rfind(['}', ';']).map_or(0, |j| j + 1)..at];
        if name.is_empty() || !(name.ends_with("Error") || attributes.contains("thiserror::Error"))
        {
            continue;
        }
        let Some(open) = code[from..].find('{').map(|j| from + j + 1) else {
            break;
        };
        let mut depth = 1;
        let mut end = code.len();
        for (i, c) in code[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + i;
                        break;
                    }
                }
                _ => {}
            }
        }
        for line in code[open..end].lines() {
            let t = line.trim().trim_end_matches(',');
            let Some((variant, rest)) = t.split_once('(') else {
                continue;
            };
            let Some(fields) = rest.strip_suffix(')') else {
                continue;
            };
            let is_ident = variant.starts_with(|c: char| c.is_ascii_uppercase())
                && variant.chars().all(|c| c.is_alphanumeric() || c == '_');
            let all_strings = fields
                .split(',')
                .map(str::trim)
                .filter(|f| !f.is_empty())
                .all(|f| f == "String" || f == "std::string::String");
            if is_ident && !fields.trim().is_empty() && all_strings {
                found.push(format!("{name}::{variant}"));
            }
        }
        from = end.min(code.len());
    }
    found
}

/// Error variants that still carry only a `String` (the list only shrinks;
/// none is left: the mesh's invariant faults and the OBJ reader's line
/// faults are typed, a line's own text a named field).
const STRING_VARIANTS_LEFT: &[&str] = &[];

/// No error variant is a bare `(String)`: the library's errors carry what
/// went wrong as typed fields, and wrap the layer's own error where there
/// is one (ARCHITECTURE.md, Errors).
#[test]
fn no_error_variant_is_a_bare_string() {
    assert_eq!(
        string_variants(
            "#[derive(Debug, thiserror::Error)]\npub enum Fault {\n    #[error(\"{0}\")]\n    Usage(String),\n    \
             Path { path: String },\n    Two(String, std::string::String),\n    Typed(Box<Fault>),\n}\n\
             pub enum Plain { A(String) }\npub enum OtherError {\n    Message(String),\n}\n"
        ),
        ["Fault::Usage", "Fault::Two", "OtherError::Message"]
    );
    let files = source_files();
    let mut found = Vec::new();
    for (rel, text) in &files {
        let rel = rel.display().to_string();
        for v in string_variants(&code_of(text)) {
            found.push((v, rel.clone()));
        }
    }
    assert!(files.len() > 100, "the source files were not found");
    let new: Vec<String> = found
        .iter()
        .filter(|(v, _)| !STRING_VARIANTS_LEFT.contains(&v.as_str()))
        .map(|(v, f)| format!("{f}: {v}"))
        .collect();
    assert!(
        new.is_empty(),
        "error variants that carry only a String ({}); give them typed fields:\n{}",
        new.len(),
        new.join("\n")
    );
    let gone: Vec<&&str> = STRING_VARIANTS_LEFT
        .iter()
        .filter(|v| !found.iter().any(|(f, _)| f == *v))
        .collect();
    assert!(
        gone.is_empty(),
        "no longer String variants; remove them from STRING_VARIANTS_LEFT: {gone:?}"
    );
}

/// The machinery's modules are private without the `internals` feature
/// (`internal!` in lib.rs), and the library's example and its front-door
/// tests reach the crate through the public items only: no
/// `crackle::<machinery module>` path in them.
#[test]
fn the_library_example_uses_the_front_door_only() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).expect("lib.rs");
    let start = lib
        .find("internal!(")
        .expect("the internal! list in lib.rs")
        + 10;
    let end = start + lib[start..].find(')').expect("closed");
    let internal: Vec<&str> = lib[start..end].split(',').map(str::trim).collect();
    assert!(
        internal.contains(&"sim") && internal.contains(&"io"),
        "{internal:?}"
    );
    // No machinery module is declared public outside the macro.
    for m in &internal {
        assert!(
            !lib.contains(&format!("\npub mod {m};")),
            "lib.rs: pub mod {m}"
        );
    }
    let mut wrong = Vec::new();
    for rel in ["examples/library.rs", "tests/library.rs"] {
        let text = std::fs::read_to_string(root.join(rel)).expect(rel);
        for m in &internal {
            if text.contains(&format!("crackle::{m}::")) {
                wrong.push(format!("{rel}: crackle::{m}::"));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "machinery reached from the front door: {wrong:?}"
    );
}
