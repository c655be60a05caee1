//! The crate graph keeps its layers (docs/architecture.md, "The crate graph"): read from every
//! crate's manifest, the kernel depends on no study, a study on no other study and not on the
//! crate above the studies, the library crates on no study, and nothing but the front ends on
//! the front ends.

use std::collections::BTreeMap;
use std::path::Path;

const KERNEL: &str = "grainwave-study";
const STUDIES: &[&str] = &["grainwave-simulation", "grainwave-e1", "grainwave-e2", "grainwave-e3"];
const LIBRARIES: &[&str] = &["grainwave-core", "grainwave-io", "grainwave-linear", "grainwave-analysis"];
const ABOVE: &str = "grainwave-experiments";
const FRONT_ENDS: &[&str] = &["grainwave-cli", "grainwave-py"];

/// The grainwave crates each workspace crate depends on (normal and dev dependencies).
fn edges() -> BTreeMap<String, Vec<String>> {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut graph = BTreeMap::new();
    for entry in std::fs::read_dir(&crates).unwrap() {
        let manifest = entry.unwrap().path().join("Cargo.toml");
        let Ok(text) = std::fs::read_to_string(&manifest) else { continue };
        let table: toml::Table = toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", manifest.display()));
        let name = table["package"]["name"].as_str().unwrap().to_string();
        let mut deps = Vec::new();
        for section in ["dependencies", "dev-dependencies", "build-dependencies"] {
            if let Some(t) = table.get(section).and_then(|v| v.as_table()) {
                deps.extend(t.keys().filter(|k| k.starts_with("grainwave-")).cloned());
            }
        }
        graph.insert(name, deps);
    }
    graph
}

#[test]
fn the_crate_graph_keeps_its_layers() {
    let graph = edges();
    // every crate of the layering is in the workspace (a renamed crate must be renamed here too)
    for name in STUDIES.iter().chain(LIBRARIES).chain(FRONT_ENDS).chain([&KERNEL, &ABOVE]) {
        assert!(graph.contains_key(*name), "crate {name} not found among {:?}", graph.keys().collect::<Vec<_>>());
    }
    let mut wrong = Vec::new();
    for (name, deps) in &graph {
        for d in deps {
            let bad = if name == KERNEL {
                STUDIES.contains(&d.as_str()) || d == ABOVE || FRONT_ENDS.contains(&d.as_str())
            } else if STUDIES.contains(&name.as_str()) {
                STUDIES.contains(&d.as_str()) || d == ABOVE || FRONT_ENDS.contains(&d.as_str())
            } else if LIBRARIES.contains(&name.as_str()) {
                d == KERNEL || STUDIES.contains(&d.as_str()) || d == ABOVE || FRONT_ENDS.contains(&d.as_str())
            } else if name == ABOVE {
                FRONT_ENDS.contains(&d.as_str())
            } else {
                false
            };
            if bad {
                wrong.push(format!("{name} → {d}"));
            }
        }
    }
    assert!(wrong.is_empty(), "edges against the layering of docs/architecture.md: {wrong:?}");
    // the studies stand on the kernel
    for s in STUDIES {
        assert!(graph[*s].iter().any(|d| d == KERNEL), "{s} does not depend on {KERNEL}");
    }
}

/// The modules of the crate whose sources are in `src` (`crate`, `e2`, `e2::outputs`, …) with
/// the text of each, comments and `#[cfg(test)] mod tests` left out.
fn modules(src: &Path) -> BTreeMap<String, String> {
    fn walk(dir: &Path, src: &Path, out: &mut BTreeMap<String, String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, src, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let rel = rel.to_str().unwrap().trim_end_matches("/mod").replace('/', "::");
                let name = if rel == "lib" || rel == "main" { "crate".to_string() } else { rel };
                let text = std::fs::read_to_string(&path).unwrap();
                let text = text.split("#[cfg(test)]\nmod tests").next().unwrap();
                let code: Vec<&str> = text.lines().map(|l| l.split("//").next().unwrap()).collect();
                out.insert(name, code.join("\n"));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, src, &mut out);
    out
}

/// The module graph of one crate: an edge from a module to every other module of the crate a
/// `crate::…` or `super::…` path in it names (the longest module prefix of the path).
fn module_graph(src: &Path) -> BTreeMap<String, Vec<String>> {
    let mods = modules(src);
    let mut graph = BTreeMap::new();
    for (m, text) in &mods {
        let parent = m.rsplit_once("::").map_or("crate", |(p, _)| p);
        let mut edges = Vec::new();
        for (base, from) in [("crate::", "crate"), ("super::", parent)] {
            for (at, _) in text.match_indices(base) {
                let before = text[..at].chars().next_back();
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                    continue;
                }
                let rest = &text[at + base.len()..];
                let path: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':').collect();
                let mut cand = if from == "crate" { String::new() } else { format!("{from}::") };
                let mut best = None;
                for seg in path.split("::").filter(|s| !s.is_empty()) {
                    cand.push_str(seg);
                    if mods.contains_key(&cand) {
                        best = Some(cand.clone());
                    }
                    cand.push_str("::");
                }
                if let Some(b) = best.filter(|b| b != m) {
                    edges.push(b);
                }
            }
        }
        edges.sort();
        edges.dedup();
        graph.insert(m.clone(), edges);
    }
    graph
}

/// The circles of a graph: its strongly connected components of more than one node.
fn circles(graph: &BTreeMap<String, Vec<String>>) -> Vec<Vec<String>> {
    // reachability by depth-first search from every node (the graphs have tens of nodes)
    let reach = |from: &str| {
        let mut seen = vec![from.to_string()];
        let mut stack = vec![from.to_string()];
        while let Some(v) = stack.pop() {
            for w in graph.get(&v).into_iter().flatten() {
                if !seen.contains(w) {
                    seen.push(w.clone());
                    stack.push(w.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, Vec<String>> = graph.keys().map(|v| (v, reach(v))).collect();
    let mut out: Vec<Vec<String>> = Vec::new();
    for v in graph.keys() {
        let mut comp: Vec<String> = graph.keys().filter(|w| *w != v && reached[v].contains(w) && reached[*w].contains(v)).cloned().collect();
        if !comp.is_empty() {
            comp.push(v.clone());
            comp.sort();
            if !out.contains(&comp) {
                out.push(comp);
            }
        }
    }
    out
}

#[test]
fn no_import_circles_between_the_modules_of_the_studies_and_the_kernel() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // the finder finds a circle where there is one
    let toy: BTreeMap<String, Vec<String>> =
        [("a", vec!["b"]), ("b", vec!["c"]), ("c", vec!["a"]), ("d", vec!["a"])].into_iter().map(|(k, v)| (k.to_string(), v.into_iter().map(String::from).collect())).collect();
    assert_eq!(circles(&toy), vec![vec!["a".to_string(), "b".to_string(), "c".to_string()]]);
    let mut found = Vec::new();
    for name in STUDIES.iter().chain([&KERNEL, &ABOVE]) {
        let graph = module_graph(&crates.join(name).join("src"));
        assert!(graph.len() > 1, "{name}: modules not found");
        for c in circles(&graph) {
            found.push(format!("{name}: {}", c.join(" ↔ ")));
        }
    }
    assert!(found.is_empty(), "import circles between modules: {found:?}");
}
