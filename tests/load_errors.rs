//! OBJ loading: every malformed input is a typed error naming the file,
//! never a panic; valid input is fan-triangulated in file order.

mod common;

use glam::Vec3;
use packtrace::{LoadError, Mesh, MeshError, load_obj, parse_obj_bytes};
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};

/// `parse_obj_bytes`, with a panic turned into a test failure that shows
/// the input.
fn parse(text: &[u8]) -> Result<Mesh, LoadError> {
    match std::panic::catch_unwind(|| parse_obj_bytes(text)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!(
                "parse_obj_bytes panicked ({msg}) on {:?}",
                String::from_utf8_lossy(text)
            )
        }
    }
}

/// A unique temporary file holding `text`, removed on drop.
struct TempObj(PathBuf);

impl TempObj {
    fn new(text: &[u8]) -> TempObj {
        static N: AtomicU32 = AtomicU32::new(0);
        let name = format!(
            "packtrace-load-errors-{}-{}.obj",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        );
        let path = std::env::temp_dir().join(name);
        std::fs::write(&path, text).unwrap();
        TempObj(path)
    }
}

impl Drop for TempObj {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Corner positions of every triangle, in order.
fn corners(m: &Mesh) -> Vec<[Vec3; 3]> {
    (0..m.triangle_count()).map(|i| *m.corners(i)).collect()
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn missing_file_is_io_error_naming_the_path() {
    let path = std::env::temp_dir().join("packtrace-no-such-dir/missing-file.obj");
    let e = load_obj(&path).unwrap_err();
    match &e {
        LoadError::Io { path: p, source } => {
            assert_eq!(p, &path);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("expected Io, got {other:?}"),
    }
    assert!(e.to_string().contains(&*path.to_string_lossy()), "{e}");
    assert!(std::error::Error::source(&e).is_some());
    // A directory is not a readable file either.
    let dir = std::env::temp_dir();
    assert!(matches!(load_obj(&dir), Err(LoadError::Io { .. })));
}

#[test]
fn errors_from_files_name_the_file() {
    for text in [
        &b""[..],
        b"v 1 x 0\n",
        b"v 0 0 0\nf 1 2 3\n",
        b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    ] {
        let f = TempObj::new(text);
        let e = load_obj(&f.0).unwrap_err();
        assert!(e.to_string().contains(&*f.0.to_string_lossy()), "{e}");
        let path = match &e {
            LoadError::Io { path, .. }
            | LoadError::Parse { path, .. }
            | LoadError::NoTriangles { path }
            | LoadError::Mesh { path, .. } => path,
        };
        assert_eq!(path, &f.0);
    }
    // In memory the name is `<memory>`.
    assert!(parse(b"").unwrap_err().to_string().contains("<memory>"));
}

#[test]
fn a_valid_file_loads_like_the_same_bytes() {
    let text = format!("{TRI}v 1 1 0\nf 1 2 3\nf 2 4 3\n");
    let f = TempObj::new(text.as_bytes());
    let from_file = load_obj(&f.0).unwrap();
    let from_bytes = parse(text.as_bytes()).unwrap();
    assert_eq!(from_file.triangle_count(), 2);
    assert_eq!(corners(&from_file), corners(&from_bytes));
}

#[test]
fn bad_numbers_in_vertex_lines_are_parse_errors() {
    for line in [
        "v 1 abc 0",
        "v 1 2",
        "v",
        "v 1,5 2 3",
        "v 0x10 0 0",
        "v 1 2 3 0",
        "v 1 2 3 4 5",
        "v 1 2 3 a b",
    ] {
        let text = format!("{line}\n{TRI}f 2 3 4\n");
        match parse(text.as_bytes()) {
            Err(LoadError::Parse { message, .. }) => assert!(!message.is_empty(), "{line}"),
            // `v 1 2 3 a b` style colour lines may be tolerated; then the
            // mesh must still be valid.
            Ok(m) if line.ends_with("a b") => assert_eq!(m.triangle_count(), 1),
            other => panic!("{line:?}: expected Parse, got {other:?}"),
        }
    }
}

#[test]
fn bad_face_lines_are_errors() {
    for face in [
        "f 1 2 99",
        "f 1 2 4",
        "f 0 1 2",
        "f 1 2 x",
        "f 1 2 3.5",
        "f -1 -2 -4",
        "f -4 1 2",
        "f 1 2 -99",
        "f 99999999999999999999 1 2",
    ] {
        let text = format!("{TRI}{face}\n");
        match parse(text.as_bytes()) {
            Err(LoadError::Parse { .. }) => {}
            Err(LoadError::Mesh {
                source: MeshError::IndexOutOfRange { .. },
                ..
            }) => {}
            other => panic!("{face:?}: expected an index error, got {other:?}"),
        }
    }
}

#[test]
fn relative_indices_in_range_work() {
    let m = parse(format!("{TRI}f -3 -2 -1\n").as_bytes()).unwrap();
    assert_eq!(corners(&m), vec![[Vec3::ZERO, Vec3::X, Vec3::Y]]);
}

#[test]
fn files_without_faces_have_no_triangles() {
    for text in [
        "",
        "\n\n   \n",
        "# only a comment\n",
        TRI,
        // Points and lines are ignored.
        &format!("{TRI}f 1\n"),
        &format!("{TRI}f 1 2\n"),
        &format!("{TRI}l 1 2 3\n"),
        &format!("{TRI}o empty\ng group\n"),
    ] {
        match parse(text.as_bytes()) {
            Err(LoadError::NoTriangles { path }) => assert_eq!(path, PathBuf::from("<memory>")),
            other => panic!("{text:?}: expected NoTriangles, got {other:?}"),
        }
    }
}

#[test]
fn non_finite_vertices_are_typed_errors() {
    for v in [
        "v nan 0 0",
        "v NaN 0 0",
        "v inf 0 0",
        "v -inf 0 0",
        "v 0 infinity 0",
        "v 1e39 0 0",
        "v 0 0 -3.5e38",
        "v 1 1 1 1e-45",
    ] {
        let text = format!("{v}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        match parse(text.as_bytes()) {
            Err(LoadError::Mesh {
                source: MeshError::NonFiniteVertex { value, .. },
                ..
            }) => assert!(!value.is_finite(), "{v}"),
            Err(LoadError::Parse { .. }) => {}
            other => panic!("{v:?}: expected a typed error, got {other:?}"),
        }
    }
    // An unused non-finite vertex is ignored (mesh policy).
    let m = parse(format!("v nan 0 0\n{TRI}f 2 3 4\n").as_bytes()).unwrap();
    assert!(corners(&m).iter().flatten().all(|p| p.is_finite()));
}

/// The error's vertex number should name the vertex in the file.
#[test]
#[ignore = "known limit: tobj renumbers vertices by first use, so the error names the mesh's vertex, not the file's (README, Known limits)"]
fn non_finite_vertex_error_names_the_file_vertex() {
    // The bad vertex is the file's third (index 2), first used by the face.
    let text = b"v 0 0 0\nv 1 0 0\nv nan 0 0\nf 3 1 2\n";
    match parse(text) {
        Err(LoadError::Mesh {
            source: MeshError::NonFiniteVertex { vertex, .. },
            ..
        }) => assert_eq!(vertex, 2, "the file's vertex 3 (0-based 2) is the NaN one"),
        other => panic!("expected NonFiniteVertex, got {other:?}"),
    }
}

#[test]
fn polygons_are_fan_triangulated_in_file_order() {
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(2.0, 1.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
        Vec3::new(0.0, 1.5, 0.0),
        Vec3::new(5.0, 5.0, 5.0),
    ];
    let mut text = String::new();
    for v in &p {
        text += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    // A quad, a pentagon, then a triangle, with vertices not in index order.
    text += "f 1 2 3 4\nf 2 3 4 5 1\nf 6 1 3\n";
    let m = parse(text.as_bytes()).unwrap();
    let expect = vec![
        [p[0], p[1], p[2]],
        [p[0], p[2], p[3]],
        [p[1], p[2], p[3]],
        [p[1], p[3], p[4]],
        [p[1], p[4], p[0]],
        [p[5], p[0], p[2]],
    ];
    assert_eq!(corners(&m), expect);
}

#[test]
fn objects_and_groups_are_concatenated_in_file_order() {
    let text = "\
o a
v 0 0 0
v 1 0 0
v 0 1 0
f 1 2 3
o b
v 0 0 1
v 1 0 1
v 0 1 1
f 4 5 6
f 1 5 6
g c
usemtl none
f 3 2 1
usemtl other
mtllib missing.mtl
f -1 -2 -3
";
    let m = parse(text.as_bytes()).unwrap();
    let z = Vec3::Z;
    assert_eq!(
        corners(&m),
        vec![
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [z, Vec3::X + z, Vec3::Y + z],
            [Vec3::ZERO, Vec3::X + z, Vec3::Y + z],
            [Vec3::Y, Vec3::X, Vec3::ZERO],
            [Vec3::Y + z, Vec3::X + z, z],
        ]
    );
}

#[test]
fn vertex_attributes_are_ignored() {
    let text = format!(
        "{TRI}vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nf 1//1 2//1 3//1\nf 1/1 2/2 3/3\n"
    );
    let m = parse(text.as_bytes()).unwrap();
    assert_eq!(corners(&m), vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 3]);
}

/// Texture and normal indices are not used, but a bad one must still be an
/// error, not a panic (tobj computes `vt * 2 + 1` and `vn * 3 + 2`
/// unchecked; index 0 or a too-negative index becomes `usize::MAX`).
#[test]
fn bad_attribute_indices_do_not_panic() {
    for face in [
        "f 1/0 2/0 3/0",
        "f 1/-9 2/1 3/1",
        "f 1//0 2//1 3//1",
        "f 1//-9 2//1 3//1",
        "f 1/99 2/1 3/1",
        "f 1//99 2//1 3//1",
    ] {
        let text = format!("{TRI}vt 0 0\nvn 0 0 1\n{face}\n");
        match parse(text.as_bytes()) {
            Err(LoadError::Parse { .. }) | Ok(_) => {}
            other => panic!("{face:?}: {other:?}"),
        }
    }
}

#[test]
fn invalid_utf8_is_a_parse_error() {
    let mut text = TRI.as_bytes().to_vec();
    text.extend_from_slice(b"f 1 2 3\n\xff\xfe garbage\n");
    assert!(matches!(parse(&text), Err(LoadError::Parse { .. })));
}

#[test]
fn cornell_box_has_36_triangles() {
    let Some(dir) = std::env::var_os("PACKTRACE_SCENES") else {
        eprintln!("PACKTRACE_SCENES not set: skipping the Cornell box");
        return;
    };
    let m = load_obj(PathBuf::from(dir).join("cornell_box.obj")).unwrap();
    assert_eq!(m.triangle_count(), 36);
    assert!((0..36).all(|i| !m.is_degenerate(i)));
}

/// One line of OBJ-like text: mostly well-formed statements with random
/// tokens (numbers, indices with `/`, negative and zero indices, NaN, huge
/// values), plus keywords without arguments and junk.
fn obj_line() -> impl Strategy<Value = String> {
    let num = prop_oneof![
        (-3i32..4).prop_map(|i| i.to_string()),
        any::<f32>().prop_map(|f| f.to_string()),
        prop::sample::select(&["nan", "inf", "-inf", "1e39", "1e-45", "", "x", "0.5"][..])
            .prop_map(str::to_string),
    ];
    let index = prop_oneof![
        6 => (-6i64..8).prop_map(|i| i.to_string()),
        1 => any::<i64>().prop_map(|i| i.to_string()),
        1 => Just("18446744073709551617".to_string()),
    ];
    let vertex_ref = (
        index.clone(),
        prop::option::of(prop::option::of(index.clone())),
        prop::option::of(index),
    )
        .prop_map(|(v, vt, vn)| match (vt, vn) {
            (None, None) => v,
            (Some(vt), None) => format!("{v}/{}", vt.unwrap_or_default()),
            (vt, Some(vn)) => format!("{v}/{}/{vn}", vt.flatten().unwrap_or_default()),
        });
    let good = (-3i32..4).prop_map(|i| i.to_string());
    prop_oneof![
        4 => prop::collection::vec(good.clone(), 3).prop_map(|n| format!("v {}", n.join(" "))),
        2 => prop::collection::vec(num.clone(), 0..6).prop_map(|n| format!("v {}", n.join(" "))),
        1 => prop::collection::vec(good.clone(), 2).prop_map(|n| format!("vt {}", n.join(" "))),
        1 => prop::collection::vec(good, 3).prop_map(|n| format!("vn {}", n.join(" "))),
        1 => prop::collection::vec(num.clone(), 0..4).prop_map(|n| format!("vt {}", n.join(" "))),
        1 => prop::collection::vec(num, 0..4).prop_map(|n| format!("vn {}", n.join(" "))),
        6 => prop::collection::vec(vertex_ref, 0..7).prop_map(|r| format!("f {}", r.join(" "))),
        1 => prop::sample::select(&["o", "o x", "g", "g y", "usemtl", "usemtl m", "mtllib", "mtllib a.mtl", "s 1", "#", "", "l 1 2", "junk 1 2 3"][..]).prop_map(str::to_string),
    ]
}

proptest! {
    #![proptest_config(common::config(2000))]

    /// Arbitrary OBJ-like text never panics: a mesh or a typed error.
    #[test]
    fn random_obj_text_never_panics(lines in prop::collection::vec(obj_line(), 0..16)) {
        let text = lines.join("\n");
        let r = std::panic::catch_unwind(|| parse_obj_bytes(text.as_bytes()));
        prop_assert!(r.is_ok(), "panicked on {:?}", text);
        if let Ok(Ok(m)) = r {
            prop_assert!(m.triangle_count() > 0);
            for i in 0..m.triangle_count() {
                prop_assert!(m.corners(i).iter().all(|p| p.is_finite()));
            }
        }
    }

    /// Arbitrary bytes never panic.
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let r = std::panic::catch_unwind(|| parse_obj_bytes(&bytes));
        prop_assert!(r.is_ok(), "panicked on {:?}", bytes);
    }
}
