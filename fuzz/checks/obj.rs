//! Fuzz target: arbitrary bytes -> `packtrace::parse_obj_bytes`. It must
//! return a valid mesh or a typed `LoadError` naming `<memory>` (and a
//! line, for a parse error), never panic (the shading loader
//! included). A mesh it returns has every index in range and every used
//! vertex finite, and builds a tree that validates.
//!
//! The body of the `obj` fuzz target (`fuzz_targets/obj.rs`), kept here so
//! that the main crate's `tests/fuzz_corpora.rs` replays the committed
//! corpora through the same checks on every `cargo test`.

use packtrace::{KdBuildParams, KdTree, LoadError};

/// The checks on one input; a failed check panics.
pub fn check(data: &[u8]) {
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
                // input.
                LoadError::Parse { .. } | LoadError::IndexOutOfRange { .. } => {}
                LoadError::AttributeIndexOutOfRange { .. } | LoadError::NonFiniteVertex { .. } => {}
                LoadError::MaterialLibrary { .. } => panic!("material library from memory: {e}"),
                LoadError::NoTriangles { .. } | LoadError::Mesh { .. } => {}
                LoadError::Io { .. } => panic!("I/O error from memory: {e}"),
            }
        }
    }
    // The shading loader never panics either, and where both load, its
    // mesh is the positions-only loader's, and every corner index it
    // reports names a vt / vn line.
    let shaded = packtrace::parse_obj_bytes_with_shading(data);
    if let (Ok(o), Ok(m)) = (&shaded, packtrace::parse_obj_bytes(data)) {
        assert_eq!(o.mesh().triangles(), m.triangles());
        for p in 0..m.triangle_count() as u32 {
            if let Some(i) = o.normal_indices(p) {
                assert!(i.iter().all(|&k| (k as usize) < o.normals().len()));
            }
            if let Some(i) = o.texcoord_indices(p) {
                assert!(i.iter().all(|&k| (k as usize) < o.texcoords().len()));
            }
        }
    }
}
