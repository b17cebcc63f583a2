//! The layers of `src/`, checked from the source text (issue 14): the
//! tracing core imports nothing from the protocol or the renderer, the
//! protocol nothing from the renderer, and no modules import each other in
//! a circle. Test modules (`#[cfg(test)]`) may use any layer.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Module path (`kdtree::scalar`) of each library file, and its source
/// without the test module.
fn modules() -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let rel = p
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if rel.starts_with("bin") {
                continue; // the binaries sit on top of everything
            }
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            let name = rel
                .trim_end_matches(".rs")
                .trim_end_matches("/mod")
                .replace('/', "::");
            if name == "lib" {
                continue;
            }
            let text = std::fs::read_to_string(&p).unwrap();
            let code = match text.find("#[cfg(test)]\nmod tests") {
                Some(i) => text[..i].to_string(),
                None => text,
            };
            // Doc comments may name any module.
            let code: String = code
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            out.insert(name, code);
        }
    }
    out
}

/// The modules `code` (in module `me`) refers to: `crate::a::b`, and
/// `super::x` / `use super::{x, y}` from a child module.
fn imports(me: &str, code: &str, all: &BTreeSet<String>) -> BTreeSet<String> {
    let resolve = |path: &str| -> Option<String> {
        let parts: Vec<&str> = path.split("::").collect();
        (1..=parts.len())
            .rev()
            .map(|n| parts[..n].join("::"))
            .find(|p| all.contains(p))
    };
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
            .collect()
    };
    let parent = me.rsplit_once("::").map(|(p, _)| p.to_string());
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        let rest = ident(&code[i + 7..]);
        if let Some(m) = resolve(&rest) {
            out.insert(m);
        }
    }
    for (i, _) in code.match_indices("super::") {
        let after = &code[i + 7..];
        let names: Vec<String> = if let Some(list) = after.strip_prefix('{') {
            list[..list.find('}').unwrap()]
                .split(',')
                .map(|n| ident(n.trim()))
                .collect()
        } else {
            vec![ident(after)]
        };
        for n in names {
            let full = match &parent {
                Some(p) => format!("{p}::{n}"),
                None => n,
            };
            if let Some(m) = resolve(&full) {
                out.insert(m);
            }
        }
    }
    out.remove(me);
    out
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let mods = modules();
    let all: BTreeSet<String> = mods.keys().cloned().collect();
    mods.iter()
        .map(|(m, code)| (m.clone(), imports(m, code, &all)))
        .collect()
}

fn layer(m: &str) -> u8 {
    if m == "render" || m.starts_with("render::") {
        2
    } else if m == "protocol" || m.starts_with("protocol::") {
        1
    } else {
        0
    }
}

type Graph = BTreeMap<String, BTreeSet<String>>;

/// Every import of a higher layer.
fn upward_imports(g: &Graph) -> Vec<String> {
    let mut bad = Vec::new();
    for (m, deps) in g {
        for d in deps {
            if layer(d) > layer(m) {
                bad.push(format!(
                    "{m} (layer {}) imports {d} (layer {})",
                    layer(m),
                    layer(d)
                ));
            }
        }
    }
    bad
}

/// A circle of imports, if any. A parent module that declares or
/// re-exports its children does not import them.
fn find_cycle(g: &Graph) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        g: &Graph,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == m) {
            let mut cycle = path[i..].to_vec();
            cycle.push(m.to_string());
            return Some(cycle);
        }
        if done.contains(m) {
            return None;
        }
        path.push(m.to_string());
        for d in g.get(m).into_iter().flatten() {
            if d.starts_with(&format!("{m}::")) {
                continue;
            }
            if let Some(c) = visit(d, g, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(m.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys()
        .find_map(|m| visit(m, g, &mut Vec::new(), &mut done))
}

#[test]
fn every_layer_imports_only_layers_below_it() {
    let g = graph();
    assert!(
        g.contains_key("kdtree::scalar") && g.contains_key("protocol::workload"),
        "{g:?}"
    );
    let bad = upward_imports(&g);
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn no_modules_import_each_other_in_a_circle() {
    if let Some(cycle) = find_cycle(&graph()) {
        panic!("import cycle: {}", cycle.join(" -> "));
    }
}

/// The checks catch what they are for: the import graph of commit 23dd94f
/// in miniature (camera and workload importing each other, a core module
/// importing the protocol), parsed from source text.
#[test]
fn the_checks_catch_a_circle_and_an_upward_import() {
    let all: BTreeSet<String> = [
        "camera",
        "workload",
        "packet",
        "kdtree",
        "kdtree::scalar",
        "protocol",
        "protocol::generate",
    ]
    .map(String::from)
    .into();
    let src = [
        ("camera", "use crate::workload::SceneFrame;"),
        ("workload", "use crate::camera::{Camera, ImagePlane};"),
        (
            "packet",
            "use crate::kdtree::NO_PRIM;\nlet m = crate::protocol::generate::sphere(9);",
        ),
        ("kdtree", "mod scalar;\npub(crate) use scalar::NO_PRIM;"),
        ("kdtree::scalar", "use super::{KdTree, layout};"),
    ];
    let g: Graph = src
        .iter()
        .map(|(m, code)| (m.to_string(), imports(m, code, &all)))
        .collect();
    assert_eq!(
        g["packet"],
        ["kdtree", "protocol::generate"].map(String::from).into()
    );
    assert_eq!(g["kdtree::scalar"], ["kdtree"].map(String::from).into());
    let cycle = find_cycle(&g).expect("camera <-> workload");
    assert!(cycle.contains(&"camera".to_string()) && cycle.contains(&"workload".to_string()));
    assert_eq!(
        upward_imports(&g),
        ["packet (layer 0) imports protocol::generate (layer 1)"]
    );
}
