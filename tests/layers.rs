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
                continue; // its re-exports: `root_reexports`
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

/// The paths of a `use` tree with the names they bind:
/// `a::{b, c::{d, e as f}, self}` -> `a::b` (`b`), `a::c::d` (`d`),
/// `a::c::e` (`f`), `a` (`a`); also a plain path in code (`a::b::c(..)`).
/// The tree ends at the first text that cannot continue it. Returns the
/// paths and the length of text read.
fn use_tree(text: &str) -> (Vec<(String, String)>, usize) {
    let b = text.as_bytes();
    let is_ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let skip_ws = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        i
    };
    // ` as name` after a path: the name, and where it ends.
    let alias = |i: usize| -> Option<(String, usize)> {
        let j = skip_ws(i);
        if j == i || !text[j..].starts_with("as") {
            return None;
        }
        let k = skip_ws(j + 2);
        let end = (k..b.len()).find(|&e| !is_ident(b[e])).unwrap_or(b.len());
        (k > j + 2 && end > k).then(|| (text[k..end].to_string(), end))
    };
    let mut prefix = String::new();
    let mut i = 0;
    loop {
        if i < b.len() && b[i] == b'{' {
            let mut out = Vec::new();
            i += 1;
            loop {
                while i < b.len() && (b[i].is_ascii_whitespace() || b[i] == b',') {
                    i += 1;
                }
                if i >= b.len() {
                    return (out, i);
                }
                if b[i] == b'}' {
                    return (out, i + 1);
                }
                let (inner, n) = use_tree(&text[i..]);
                if n == 0 {
                    i += 1; // `*` or anything else that is not a path
                    continue;
                }
                i += n;
                for (p, name) in inner {
                    let path = if p == "self" {
                        prefix.trim_end_matches("::").to_string()
                    } else {
                        format!("{prefix}{p}")
                    };
                    let name = if name == "self" {
                        path.rsplit("::").next().unwrap_or("").to_string()
                    } else {
                        name
                    };
                    out.push((path, name));
                }
            }
        }
        let start = i;
        while i < b.len() && is_ident(b[i]) {
            i += 1;
        }
        if i == start {
            // `a::*`: the module `a`.
            let path = prefix.trim_end_matches("::").to_string();
            let name = path.rsplit("::").next().unwrap_or("").to_string();
            return (
                if path.is_empty() {
                    vec![]
                } else {
                    vec![(path, name)]
                },
                i,
            );
        }
        prefix += &text[start..i];
        if text[i..].starts_with("::") {
            prefix += "::";
            i = skip_ws(i + 2);
            continue;
        }
        let name = text[start..i].to_string();
        return match alias(i) {
            Some((alias, end)) => (vec![(prefix, alias)], end),
            None => (vec![(prefix, name)], i),
        };
    }
}

/// The crate root's re-exports (`pub use kdtree::{KdTree, ..}` in
/// `lib.rs`): each name `crate::Name` can refer to, and the path it
/// re-exports (`Camera` -> `protocol::Camera`).
fn root_reexports(lib: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (i, _) in lib.match_indices("pub use ") {
        for (path, name) in use_tree(&lib[i + 8..]).0 {
            out.insert(name, path);
        }
    }
    out
}

/// The modules `code` (in module `me`) refers to: `crate::a::b`, use
/// groups `crate::{a::b, c}`, root re-exports `crate::Name` (through
/// `reexports`), and `super::x` / `use super::{x, y}` from a child module.
fn imports(
    me: &str,
    code: &str,
    all: &BTreeSet<String>,
    reexports: &BTreeMap<String, String>,
) -> BTreeSet<String> {
    let resolve = |path: &str| -> Option<String> {
        let mut parts: Vec<&str> = path.split("::").collect();
        // `crate::Camera`: the path the root re-exports.
        let via;
        if let Some(target) = parts.first().and_then(|p| reexports.get(*p)) {
            via = format!("{target}{}", &path[parts[0].len()..]);
            parts = via.split("::").collect();
        }
        (1..=parts.len())
            .rev()
            .map(|n| parts[..n].join("::"))
            .find(|p| all.contains(p))
    };
    let parent = me.rsplit_once("::").map(|(p, _)| p.to_string());
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        for (p, _) in use_tree(&code[i + 7..]).0 {
            if let Some(m) = resolve(&p) {
                out.insert(m);
            }
        }
    }
    for (i, _) in code.match_indices("super::") {
        for (n, _) in use_tree(&code[i + 7..]).0 {
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
    let lib = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs");
    let reexports = root_reexports(&std::fs::read_to_string(lib).unwrap());
    assert!(
        reexports.get("Camera").map(String::as_str) == Some("protocol::Camera"),
        "the root re-exports as parsed: {reexports:?}"
    );
    mods.iter()
        .map(|(m, code)| (m.clone(), imports(m, code, &all, &reexports)))
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
    let reexports = BTreeMap::new();
    let g: Graph = src
        .iter()
        .map(|(m, code)| (m.to_string(), imports(m, code, &all, &reexports)))
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

/// Use groups and root re-exports are imports too: a core module that
/// writes `use crate::{aabb::Aabb, protocol::camera::Camera}`, a nested
/// group, or `crate::Camera` (the root's re-export of a protocol type)
/// imports the protocol layer; `crate::Mesh` is the core's own.
#[test]
fn groups_and_root_reexports_are_seen() {
    let all: BTreeSet<String> = [
        "aabb",
        "mesh",
        "packet",
        "kdtree",
        "kdtree::scalar",
        "protocol",
        "protocol::camera",
        "render",
    ]
    .map(String::from)
    .into();
    let lib = "pub mod aabb;\npub use mesh::{Mesh, MeshError};\npub use protocol::{\n    Camera, View,\n};\npub use render::Renderer as Shader;\n";
    let reexports = root_reexports(lib);
    assert_eq!(reexports["Camera"], "protocol::Camera");
    assert_eq!(reexports["Mesh"], "mesh::Mesh");
    assert_eq!(reexports["Shader"], "render::Renderer");
    let src = [
        ("aabb", "use crate::{mesh::Mesh, protocol::camera::Camera};"),
        (
            "packet",
            "use crate::{\n    kdtree::{scalar::{self, traverse}, NO_PRIM},\n    render::shade as s,\n};",
        ),
        ("mesh", "use crate::Camera;\nfn f(v: crate::View) {}"),
        ("kdtree", "fn f(s: &crate::Shader) {}"),
        (
            "kdtree::scalar",
            "use crate::{Mesh, aabb::*};\nuse super::{self as kd, NO_PRIM};",
        ),
    ];
    let g: Graph = src
        .iter()
        .map(|(m, code)| (m.to_string(), imports(m, code, &all, &reexports)))
        .collect();
    let set = |v: &[&str]| -> BTreeSet<String> { v.iter().map(|s| s.to_string()).collect() };
    assert_eq!(g["aabb"], set(&["mesh", "protocol::camera"]));
    assert_eq!(g["packet"], set(&["kdtree", "kdtree::scalar", "render"]));
    assert_eq!(g["mesh"], set(&["protocol"]));
    assert_eq!(g["kdtree::scalar"], set(&["aabb", "kdtree", "mesh"]));
    assert_eq!(g["kdtree"], set(&["render"]));
    assert_eq!(
        upward_imports(&g),
        [
            "aabb (layer 0) imports protocol::camera (layer 1)",
            "kdtree (layer 0) imports render (layer 2)",
            "mesh (layer 0) imports protocol (layer 1)",
            "packet (layer 0) imports render (layer 2)",
        ]
    );
}
