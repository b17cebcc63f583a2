//! OBJ files for hosts without a loader of their own (and the examples):
//! the mesh as arrays to build a tree from, and the shading helpers of
//! the Rust `ObjMesh` (interpolated normals and texture coordinates).
// `#[unsafe(no_mangle)]` on the exported functions is all the unsafe
// code here; raw pointers are turned into references in `ptr.rs` only.
#![allow(unsafe_code)]

use crate::ptr::{self, Kind};
use crate::status::{Error, PacktraceStatus, guard};
use crate::tree::put3;
use packtrace::{Hit, ObjMesh, load_obj_with_shading};
use std::ffi::c_char;
use std::path::PathBuf;

/// A loaded OBJ file (opaque): its mesh, normals, texture coordinates and
/// materials. Immutable: any number of threads may read it at once.
pub struct PacktraceObj {
    _opaque: [u8; 0],
}

impl Kind for ObjMesh {
    type Opaque = PacktraceObj;
    const MAGIC: u32 = 0x5054_4f42; // "PTOB"
    const NAME: &'static str = "OBJ";
}

fn obj_ref<'a>(p: *const PacktraceObj) -> Result<&'a ObjMesh, Error> {
    ptr::handle::<ObjMesh>(p, "obj")
}

/// The file's path from the host's bytes.
fn path(bytes: &[u8]) -> Result<PathBuf, Error> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        Ok(std::ffi::OsStr::from_bytes(bytes).into())
    }
    #[cfg(not(unix))]
    {
        std::str::from_utf8(bytes)
            .map(PathBuf::from)
            .map_err(|_| Error::invalid("`path` is not UTF-8"))
    }
}

/// Loads the OBJ file at `path` (a NUL-terminated string) with its
/// shading data (`vn`, `vt`, `usemtl` and the `mtllib` files' diffuse
/// colours): polygons fan-triangulated in file order. `LOAD` with the
/// file, line and reason when it cannot be read or parsed.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_obj_load(
    path: *const c_char,
    out_obj: *mut *mut PacktraceObj,
) -> PacktraceStatus {
    guard(|| {
        let out = ptr::write(out_obj, "out_obj")?;
        let p = self::path(ptr::c_str(path, "path")?)?;
        *out = ptr::new_handle(load_obj_with_shading(p)?);
        Ok(())
    })
}

/// Releases an OBJ (NULL: nothing to do); the arrays of
/// `packtrace_obj_mesh` die with it.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_obj_release(obj: *mut PacktraceObj) -> PacktraceStatus {
    guard(|| ptr::release::<ObjMesh>(obj, "obj"))
}

/// The OBJ's mesh as arrays to pass to `packtrace_tree_new`: positions
/// (three floats per vertex, stride 12) and triangles (three `uint32_t`
/// per triangle, stride 12), owned by the OBJ and valid until its
/// release. Any output may be NULL.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_obj_mesh(
    obj: *const PacktraceObj,
    out_positions: *mut *const f32,
    out_vertex_count: *mut usize,
    out_indices: *mut *const u32,
    out_triangle_count: *mut usize,
) -> PacktraceStatus {
    guard(|| {
        let m = obj_ref(obj)?.mesh();
        let set = |p: *mut usize, v: usize, name: &str| -> Result<(), Error> {
            if !p.is_null() {
                *ptr::write(p, name)? = v;
            }
            Ok(())
        };
        if !out_positions.is_null() {
            *ptr::write(out_positions, "out_positions")? = m.positions().as_ptr().cast();
        }
        if !out_indices.is_null() {
            *ptr::write(out_indices, "out_indices")? = m.triangles().as_ptr().cast();
        }
        set(out_vertex_count, m.positions().len(), "out_vertex_count")?;
        set(out_triangle_count, m.triangle_count(), "out_triangle_count")
    })
}

/// The hit of `prim_id`, `u`, `v` on the OBJ's mesh, checked.
fn hit(o: &ObjMesh, prim_id: u32, u: f32, v: f32) -> Result<Hit, Error> {
    let n = o.mesh().triangle_count();
    if prim_id as usize >= n {
        return Err(Error::invalid(format!(
            "prim_id {prim_id} is not a triangle of the OBJ (it has {n})"
        )));
    }
    if !(u.is_finite() && v.is_finite()) {
        return Err(Error::invalid(format!(
            "barycentrics ({u}, {v}) are not finite"
        )));
    }
    Ok(Hit {
        t: 0.0,
        prim: prim_id,
        u,
        v,
    })
}

/// The unit shading normal at a hit (triangle `prim_id`, barycentrics
/// `u`, `v`): the corners' `vn` normals interpolated and normalised, or
/// the geometric normal where the triangle has none (or they cancel
/// out); written to `out_normal` (three floats).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_obj_shading_normal(
    obj: *const PacktraceObj,
    prim_id: u32,
    u: f32,
    v: f32,
    out_normal: *mut f32,
) -> PacktraceStatus {
    guard(|| {
        let o = obj_ref(obj)?;
        put3(out_normal, o.shading_normal(&hit(o, prim_id, u, v)?))
    })
}

/// The texture coordinate at a hit, interpolated from the corners' `vt`:
/// `*out_found` is 1 and `out_uv` (two floats) set, or 0 and `out_uv`
/// untouched when the triangle has none.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_obj_texcoord(
    obj: *const PacktraceObj,
    prim_id: u32,
    u: f32,
    v: f32,
    out_uv: *mut f32,
    out_found: *mut u32,
) -> PacktraceStatus {
    guard(|| {
        let o = obj_ref(obj)?;
        let h = hit(o, prim_id, u, v)?;
        let found = ptr::write(out_found, "out_found")?;
        let uv = ptr::slice_mut(out_uv, 2, "out_uv")?;
        match o.texcoord(&h) {
            Some(t) => {
                uv.copy_from_slice(&t.to_array());
                *found = 1;
            }
            None => *found = 0,
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_pass_through_as_bytes() {
        assert_eq!(path(b"a/b.obj").unwrap(), PathBuf::from("a/b.obj"));
        let _ = PacktraceStatus::Load;
    }
}
