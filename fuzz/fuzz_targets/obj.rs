//! Fuzz target: arbitrary bytes -> `packtrace::parse_obj_bytes`. It must
//! return a valid mesh or a typed `LoadError` naming `<memory>` (and a
//! line, for a parse error), never panic (a panic inside `tobj` is a
//! finding too). A mesh it returns has every index in range and every used
//! vertex finite, and builds a tree that validates.

#![no_main]

use libfuzzer_sys::fuzz_target;
use packtrace::{KdBuildParams, KdTree, LoadError};

fuzz_target!(|data: &[u8]| {
    match packtrace::parse_obj_bytes(data) {
        Ok(mesh) => {
            assert!(!mesh.is_empty(), "Ok with no triangle");
            let n = mesh.positions().len();
            for t in mesh.triangles() {
                for &i in t {
                    assert!((i as usize) < n, "index {i} of {n} vertices");
                    assert!(mesh.positions()[i as usize].is_finite());
                }
            }
            if mesh.triangle_count() <= 512 {
                let tree = KdTree::build(mesh, &KdBuildParams::default()).expect("builds");
                tree.validate().expect("validates");
            }
        }
        Err(e) => {
            assert!(e.to_string().contains("<memory>"), "{e}");
            match e {
                // The loader's own pass blames a line for every malformed
                // input; a line-less Parse means tobj rejected a file the
                // pass accepted.
                LoadError::Parse { line, .. } => assert!(line.is_some(), "no line: {e}"),
                LoadError::IndexOutOfRange { .. } | LoadError::NonFiniteVertex { .. } => {}
                LoadError::NoTriangles { .. } | LoadError::Mesh { .. } => {}
                LoadError::Io { .. } => panic!("I/O error from memory: {e}"),
            }
        }
    }
});
