//! OBJ loading: every malformed input is a typed error naming the file
//! and, where the fault is in one line, the line; never a panic. Valid
//! input is fan-triangulated in file order.

mod common;

use glam::Vec3;
use packtrace::{LoadError, Mesh, load_obj, parse_obj_bytes};
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
        assert_eq!(e.path(), f.0);
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
        // The bad vertex is on line 3, after a comment and a blank line.
        let text = format!("# header\n\n{line}\n{TRI}f 2 3 4\n");
        match parse(text.as_bytes()) {
            Err(e @ LoadError::Parse { .. }) => {
                let LoadError::Parse {
                    line: at, message, ..
                } = &e
                else {
                    unreachable!()
                };
                assert_eq!(*at, 3, "{line}: {e}");
                assert!(!message.is_empty(), "{line}");
                assert!(e.to_string().starts_with("<memory>:3: "), "{e}");
            }
            other => panic!("{line:?}: expected Parse, got {other:?}"),
        }
    }
}

#[test]
fn vertex_lines_with_w_or_colour_load() {
    // `x y z w` divides by w (as tobj does); `x y z r g b` ignores the colour.
    let text = "v 2 0 0 2\nv 0 1 0 0.5 0.5 0.5\nv 0 0 1\nf 1 2 3\n";
    let m = parse(text.as_bytes()).unwrap();
    assert_eq!(corners(&m), vec![[Vec3::X, Vec3::Y, Vec3::Z]]);
    // Some vertices with a colour and some without is fine too.
    let text = "v 1 0 0 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n";
    assert_eq!(parse(text.as_bytes()).unwrap().triangle_count(), 1);
}

#[test]
fn bad_face_lines_are_errors_naming_the_line() {
    // Indices that are integers but name no vertex (`Some(index)`), and
    // corners that are not indices at all (`None`).
    for (face, bad_index) in [
        ("f 1 2 99", Some(99)),
        ("f 1 2 4", Some(4)),
        ("f 0 1 2", Some(0)),
        ("f 1 2 x", None),
        ("f 1 2 3.5", None),
        ("f -1 -2 -4", Some(-4)),
        ("f -4 1 2", Some(-4)),
        ("f 1 2 -99", Some(-99)),
        ("f 99999999999999999999 1 2", None),
        ("f 1/1 2 /3", None),
        ("f 1//2 2 3/x", None),
        ("f 1/2/3/4 2 3", None),
        ("f", None),
        // A point or line is ignored, but its indices must still be valid.
        ("f 7 1", Some(7)),
    ] {
        // The face is on line 5 (a comment before the vertices).
        let text = format!("# tri\n{TRI}{face}\n");
        let e = parse(text.as_bytes()).unwrap_err();
        assert_eq!(e.line(), Some(5), "{face:?}: {e}");
        assert!(e.to_string().starts_with("<memory>:5: "), "{face:?}: {e}");
        match (bad_index, &e) {
            (
                Some(want),
                LoadError::IndexOutOfRange {
                    path,
                    line: 5,
                    index,
                    vertex_count: 3,
                },
            ) => {
                assert_eq!(*index, want, "{face:?}");
                assert_eq!(path, &PathBuf::from("<memory>"));
            }
            (None, LoadError::Parse { line: 5, .. }) => {}
            _ => panic!("{face:?}: expected {bad_index:?}, got {e:?}"),
        }
    }
}

#[test]
fn each_error_kind_from_a_file_names_file_and_line() {
    let cases: [(&[u8], usize); 8] = [
        // Parse: a bad coordinate, w = 0, too many values, a bad index, a
        // face without corners, usemtl without a name, not UTF-8.
        (b"v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n", 3),
        (b"v 0 0 0\nv 1 0 0 0\nv 0 1 0\nf 1 2 3\n", 2),
        (b"v 0 0 0 1 1\n", 1),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\n\nf 1 2 three\n", 6),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n", 5),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n", 4),
        (b"v 0 0 0\nv 1 0 0\r\nv 0 1 0\nf 1 2 3\n# caf\xe9\n", 5),
        // Non-UTF-8 in the middle of a line counts lines up to it.
        (b"v 0 0 0\n\xc3(\n", 2),
    ];
    for (text, want) in cases {
        let f = TempObj::new(text);
        let e = load_obj(&f.0).unwrap_err();
        match &e {
            LoadError::Parse {
                path,
                line,
                message,
            } => {
                assert_eq!(path, &f.0);
                assert_eq!(*line, want, "{e}");
                assert!(!message.is_empty());
            }
            other => panic!(
                "{:?}: expected Parse, got {other:?}",
                String::from_utf8_lossy(text)
            ),
        }
        let prefix = format!("{}:{want}: ", f.0.display());
        assert!(e.to_string().starts_with(&prefix), "{e}");
    }

    // IndexOutOfRange: the face line, the index as written, the vertices
    // defined above it.
    let f = TempObj::new(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 -4\n");
    let e = load_obj(&f.0).unwrap_err();
    match &e {
        LoadError::IndexOutOfRange {
            path,
            line,
            index,
            vertex_count,
        } => {
            assert_eq!((path, *line, *index, *vertex_count), (&f.0, 5, -4, 3));
        }
        other => panic!("expected IndexOutOfRange, got {other:?}"),
    }
    assert_eq!(
        e.to_string(),
        format!(
            "{}:5: relative face index -4 reaches before the first vertex: \
             3 vertices are defined above this line",
            f.0.display()
        )
    );

    // NonFiniteVertex: the `v` line, the file's vertex number (1-based),
    // the value and the face line using it.
    let f = TempObj::new(b"v 0 0 0\n# note\nv 1 0 0\nv 0 inf 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\n");
    let e = load_obj(&f.0).unwrap_err();
    match &e {
        LoadError::NonFiniteVertex {
            path,
            line,
            vertex,
            value,
            face_line,
        } => {
            assert_eq!((path, *line, *vertex, *face_line), (&f.0, 4, 3, 7));
            assert_eq!(*value, Vec3::new(0.0, f32::INFINITY, 0.0));
        }
        other => panic!("expected NonFiniteVertex, got {other:?}"),
    }
    assert_eq!(e.line(), Some(4));
    assert_eq!(
        e.to_string(),
        format!(
            "{}:4: vertex 3 has a non-finite coordinate (y = inf), used by the face on line 7",
            f.0.display()
        )
    );

    // Errors with no line to name say so.
    let f = TempObj::new(b"v 0 0 0\n");
    let e = load_obj(&f.0).unwrap_err();
    assert!(matches!(&e, LoadError::NoTriangles { path } if path == &f.0));
    assert_eq!(e.line(), None);
    assert_eq!(
        e.to_string(),
        format!("{}: the file holds no triangle", f.0.display())
    );
}

#[test]
fn the_first_bad_line_is_reported() {
    // Two bad lines: the earlier one (a face index) wins over the later one.
    let text = format!("{TRI}f 1 2 9\nv x 0 0\n");
    assert!(matches!(
        parse(text.as_bytes()),
        Err(LoadError::IndexOutOfRange {
            line: 4,
            index: 9,
            ..
        })
    ));
    // A face may only use vertices defined above it.
    let text = "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n";
    assert!(matches!(
        parse(text.as_bytes()),
        Err(LoadError::IndexOutOfRange {
            line: 3,
            index: 3,
            vertex_count: 2,
            ..
        })
    ));
}

#[test]
fn index_error_messages_read_well() {
    let msg = |face: &str| {
        parse(format!("{TRI}{face}\n").as_bytes())
            .unwrap_err()
            .to_string()
    };
    assert_eq!(
        msg("f 0 1 2"),
        "<memory>:4: face index 0 is invalid (OBJ indices start at 1)"
    );
    assert_eq!(
        msg("f 1 2 4"),
        "<memory>:4: face index 4 names no vertex: 3 vertices are defined above this line"
    );
    assert_eq!(
        parse(b"v 0 0 0\nf 1 1 2\n").unwrap_err().to_string(),
        "<memory>:2: face index 2 names no vertex: 1 vertex is defined above this line"
    );
    assert_eq!(
        msg("f 1 2 x"),
        "<memory>:4: face corner `x`: `x` is not a vertex index"
    );
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
            Err(LoadError::NonFiniteVertex {
                line: 1,
                vertex: 1,
                value,
                face_line: 4,
                ..
            }) => assert!(!value.is_finite(), "{v}"),
            other => panic!("{v:?}: expected NonFiniteVertex, got {other:?}"),
        }
    }
    // An unused non-finite vertex is ignored (mesh policy), also when only
    // a point or line face (ignored) names it.
    let m = parse(format!("v nan 0 0\n{TRI}f 2 3 4\nf 1 2\n").as_bytes()).unwrap();
    assert!(corners(&m).iter().flatten().all(|p| p.is_finite()));
}

/// The error's vertex number names the vertex in the file (1-based, as OBJ
/// counts), not the loaded mesh's renumbered one, and its line.
#[test]
fn non_finite_vertex_error_names_the_file_vertex() {
    // The bad vertex is the file's third, first used by the face.
    let text = b"v 0 0 0\nv 1 0 0\nv nan 0 0\nf 3 1 2\n";
    match parse(text) {
        Err(LoadError::NonFiniteVertex {
            line,
            vertex,
            face_line,
            ..
        }) => {
            assert_eq!(vertex, 3, "the file's vertex 3 is the NaN one");
            assert_eq!((line, face_line), (3, 4));
        }
        other => panic!("expected NonFiniteVertex, got {other:?}"),
    }
    // Through a relative index, after comments and other statements.
    let text = b"# a\nv 0 0 0\nvn 0 0 1\nv 1 0 0\no x\nv 0 -inf 0\nv 0 1 0\nf -4 -2 -3\n";
    match parse(text) {
        Err(LoadError::NonFiniteVertex {
            line: 6,
            vertex: 3,
            face_line: 8,
            value,
            ..
        }) => assert_eq!(value.y, f32::NEG_INFINITY),
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

/// The positions-only loader reads texture and normal indices as
/// integers and nothing more (`src/obj/scan.rs`, `Read::Positions`): a
/// face whose `vt` / `vn` index names nothing loads as its positions.
/// The shading loader, which uses them, refuses each with a typed error
/// naming the face's line, the attribute, the index as written and how
/// many are defined above it. (tobj, which once read them, computed
/// `vt * 2 + 1` unchecked: index 0 or a too-negative one panicked.)
#[test]
fn bad_attribute_indices_load_as_positions_and_are_errors_with_shading() {
    use packtrace::obj::Attribute::{Normal, TextureCoordinate as Texcoord};
    for (face, attribute, index) in [
        ("f 1/0 2/0 3/0", Texcoord, 0),
        ("f 1/-9 2/1 3/1", Texcoord, -9),
        ("f 1//0 2//1 3//1", Normal, 0),
        ("f 1//-9 2//1 3//1", Normal, -9),
        ("f 1/99 2/1 3/1", Texcoord, 99),
        ("f 1//99 2//1 3//1", Normal, 99),
    ] {
        // The face is on line 6, below one `vt` and one `vn`.
        let text = format!("{TRI}vt 0 0\nvn 0 0 1\n{face}\n");
        let m = parse(text.as_bytes()).unwrap_or_else(|e| panic!("{face:?}: {e}"));
        assert_eq!(
            corners(&m),
            vec![[Vec3::ZERO, Vec3::X, Vec3::Y]],
            "{face:?}"
        );
        let e =
            std::panic::catch_unwind(|| packtrace::parse_obj_bytes_with_shading(text.as_bytes()))
                .unwrap_or_else(|_| panic!("the shading loader panicked on {face:?}"))
                .err()
                .unwrap_or_else(|| panic!("{face:?}: the shading loader accepted it"));
        match &e {
            LoadError::AttributeIndexOutOfRange {
                path,
                line: 6,
                attribute: a,
                index: i,
                count: 1,
            } => {
                assert_eq!((*a, *i), (attribute, index), "{face:?}");
                assert_eq!(path, &PathBuf::from("<memory>"));
            }
            other => panic!("{face:?}: expected AttributeIndexOutOfRange, got {other:?}"),
        }
        assert!(e.to_string().starts_with("<memory>:6: "), "{face:?}: {e}");
    }
}

#[test]
fn invalid_utf8_is_a_parse_error() {
    let mut text = TRI.as_bytes().to_vec();
    text.extend_from_slice(b"f 1 2 3\n\xff\xfe garbage\n");
    assert!(matches!(
        parse(&text),
        Err(LoadError::Parse { line: 5, .. })
    ));
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn cornell_box_has_36_triangles() {
    let dir = common::scenes::scenes_dir();
    let m = load_obj(common::scenes::scene_file(&dir, "cornell_box.obj")).unwrap();
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
        match r {
            Ok(Ok(m)) => {
                prop_assert!(m.triangle_count() > 0);
                for i in 0..m.triangle_count() {
                    prop_assert!(m.corners(i).iter().all(|p| p.is_finite()));
                }
            }
            // The loader's pass blames a line for every malformed input.
            Ok(Err(e)) => prop_assert!(
                e.line().is_some() || matches!(e, LoadError::NoTriangles { .. }),
                "{e:?} on {:?}", text
            ),
            Err(_) => {}
        }
    }

    /// Arbitrary bytes never panic, and give what the loader promises: a
    /// mesh of finite triangles or an error that names its line (or says
    /// there is no triangle), as for the text above.
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..256)) {
        let r = std::panic::catch_unwind(|| parse_obj_bytes(&bytes));
        prop_assert!(r.is_ok(), "panicked on {:?}", bytes);
        match r {
            Ok(Ok(m)) => {
                prop_assert!(m.triangle_count() > 0);
                for i in 0..m.triangle_count() {
                    prop_assert!(m.corners(i).iter().all(|p| p.is_finite()));
                }
            }
            Ok(Err(e)) => prop_assert!(
                e.line().is_some() || matches!(e, LoadError::NoTriangles { .. }),
                "{e:?} on {:?}", bytes
            ),
            Err(_) => {}
        }
    }
}
