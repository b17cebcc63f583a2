//! Every C call equals brute force, bit for bit (`t`, triangle, `u`, `v`,
//! occlusion), over the integration suites' random meshes and rays
//! (`tests/common`: shared vertices and split planes on a grid,
//! degenerate and duplicate triangles, axis-parallel rays with signed
//! zeros, origins on split planes, box faces and corners, rays aimed at
//! edges, vertices and centroids, intervals ending at a hit): the tree
//! built by `packtrace_tree_new` from an interleaved vertex buffer, then
//! `packtrace_intersect1`/`occluded1`, both packet widths with random
//! `valid` lanes, and the streams; and a scene of instances with masks
//! against `BruteScene`.

#[path = "../../tests/common/mod.rs"]
mod common;

use common::*;
use glam::{Affine3A, Vec3};
use packtrace::scene::{BruteScene, Query, Scene, SceneQuery};
use packtrace::{BruteForce, Hit, KdBuildParams, KdTree, Mesh, Ray, RayQuery};
use packtrace_c::*;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A tree built through the C API from `mesh`'s positions interleaved
/// with a NaN attribute (stride 16), released on drop.
struct CTree(*mut PacktraceTree);

impl CTree {
    fn new(mesh: &Mesh, preset: u32) -> CTree {
        let interleaved: Vec<[f32; 4]> = mesh
            .positions()
            .iter()
            .map(|p| [p.x, p.y, p.z, f32::NAN])
            .collect();
        let mut params = PacktraceBuildParams::default();
        assert_eq!(
            packtrace_build_params_preset(preset, &mut params),
            PacktraceStatus::Ok
        );
        let mut t = std::ptr::null_mut();
        let s = packtrace_tree_new(
            interleaved.as_ptr().cast(),
            interleaved.len(),
            16,
            mesh.triangles().as_ptr().cast(),
            mesh.triangle_count(),
            12,
            &params,
            &mut t,
        );
        assert_eq!(s, PacktraceStatus::Ok);
        CTree(t)
    }
}

impl Drop for CTree {
    fn drop(&mut self) {
        assert_eq!(packtrace_tree_release(self.0), PacktraceStatus::Ok);
    }
}

fn c_ray(r: &Ray, mask: u32) -> PacktraceRay {
    PacktraceRay {
        org_x: r.origin().x,
        org_y: r.origin().y,
        org_z: r.origin().z,
        tnear: r.t_min(),
        dir_x: r.dir().x,
        dir_y: r.dir().y,
        dir_z: r.dir().z,
        time: 0.0,
        tfar: r.t_max(),
        mask,
        id: 0,
        flags: 0,
    }
}

/// The C answer as a `Hit`: `tfar` and the hit record.
fn hit_of(tfar: f32, prim: u32, u: f32, v: f32) -> Option<Hit> {
    (prim != PACKTRACE_INVALID_ID).then_some(Hit {
        t: tfar,
        prim,
        u,
        v,
    })
}

fn fail(what: &str, i: usize, r: &Ray, got: Option<Hit>, want: Option<Hit>) -> TestCaseError {
    TestCaseError::fail(format!(
        "{what}, ray {i} {}: C {got:?}, brute force {want:?}",
        ray_literal(r)
    ))
}

/// Every C query of `rays` against brute force over `mesh`.
fn check_tree(mesh: &Mesh, rays: &[Ray], lanes_on: u8, preset: u32) -> Result<(), TestCaseError> {
    let tree = CTree::new(mesh, preset);
    let brute = BruteForce::new(mesh);
    let want: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
    let occluded: Vec<bool> = rays.iter().map(|r| brute.occluded(r)).collect();
    // One ray at a time.
    for (i, r) in rays.iter().enumerate() {
        let mut rh = PacktraceRayHit {
            ray: c_ray(r, u32::MAX),
            hit: PacktraceHit::default(),
        };
        prop_assert_eq!(packtrace_intersect1(tree.0, &mut rh), PacktraceStatus::Ok);
        let got = hit_of(rh.ray.tfar, rh.hit.prim_id, rh.hit.u, rh.hit.v);
        if hit_bits(got) != hit_bits(want[i]) {
            return Err(fail("intersect1", i, r, got, want[i]));
        }
        if let Some(h) = got {
            let n = mesh.normal(h.prim as usize);
            prop_assert_eq!([rh.hit.ng_x, rh.hit.ng_y, rh.hit.ng_z], n.to_array());
        } else {
            prop_assert_eq!(rh.ray.tfar.to_bits(), r.t_max().to_bits());
        }
        let mut ray = c_ray(r, u32::MAX);
        prop_assert_eq!(packtrace_occluded1(tree.0, &mut ray), PacktraceStatus::Ok);
        prop_assert_eq!(
            ray.tfar == f32::NEG_INFINITY,
            occluded[i],
            "occluded1, ray {}",
            i
        );
    }
    // 8-wide packets of consecutive rays, lanes switched off by `lanes_on`.
    for (k, chunk) in rays.chunks(8).enumerate() {
        let mut rh = PacktraceRayHit8::default();
        let mut valid = [0; 8];
        for (l, r) in chunk.iter().enumerate() {
            let c = c_ray(r, u32::MAX);
            valid[l] = if (lanes_on >> l) & 1 == 1 { -1 } else { 0 };
            rh.ray.org_x[l] = c.org_x;
            rh.ray.org_y[l] = c.org_y;
            rh.ray.org_z[l] = c.org_z;
            rh.ray.dir_x[l] = c.dir_x;
            rh.ray.dir_y[l] = c.dir_y;
            rh.ray.dir_z[l] = c.dir_z;
            rh.ray.tnear[l] = c.tnear;
            rh.ray.tfar[l] = c.tfar;
        }
        let before = rh;
        let mut occ = rh.ray;
        prop_assert_eq!(
            packtrace_intersect8(valid.as_ptr(), tree.0, &mut rh),
            PacktraceStatus::Ok
        );
        prop_assert_eq!(
            packtrace_occluded8(valid.as_ptr(), tree.0, &mut occ),
            PacktraceStatus::Ok
        );
        for (l, r) in chunk.iter().enumerate() {
            let i = 8 * k + l;
            if valid[l] == 0 {
                // Left alone.
                prop_assert_eq!(rh.ray.tfar[l].to_bits(), before.ray.tfar[l].to_bits());
                prop_assert_eq!(rh.hit.prim_id[l], before.hit.prim_id[l]);
                continue;
            }
            let got = hit_of(rh.ray.tfar[l], rh.hit.prim_id[l], rh.hit.u[l], rh.hit.v[l]);
            if hit_bits(got) != hit_bits(want[i]) {
                return Err(fail("intersect8", i, r, got, want[i]));
            }
            prop_assert_eq!(
                occ.tfar[l] == f32::NEG_INFINITY,
                occluded[i],
                "occluded8 {}",
                i
            );
        }
    }
    // 4-wide packets, all lanes on.
    for (k, chunk) in rays.chunks(4).enumerate() {
        let mut rh = PacktraceRayHit4::default();
        let mut valid = [0; 4];
        for (l, r) in chunk.iter().enumerate() {
            let c = c_ray(r, u32::MAX);
            valid[l] = -1;
            (rh.ray.org_x[l], rh.ray.org_y[l], rh.ray.org_z[l]) = (c.org_x, c.org_y, c.org_z);
            (rh.ray.dir_x[l], rh.ray.dir_y[l], rh.ray.dir_z[l]) = (c.dir_x, c.dir_y, c.dir_z);
            (rh.ray.tnear[l], rh.ray.tfar[l]) = (c.tnear, c.tfar);
        }
        let mut occ = rh.ray;
        prop_assert_eq!(
            packtrace_intersect4(valid.as_ptr(), tree.0, &mut rh),
            PacktraceStatus::Ok
        );
        prop_assert_eq!(
            packtrace_occluded4(valid.as_ptr(), tree.0, &mut occ),
            PacktraceStatus::Ok
        );
        for (l, r) in chunk.iter().enumerate() {
            let i = 4 * k + l;
            let got = hit_of(rh.ray.tfar[l], rh.hit.prim_id[l], rh.hit.u[l], rh.hit.v[l]);
            if hit_bits(got) != hit_bits(want[i]) {
                return Err(fail("intersect4", i, r, got, want[i]));
            }
            prop_assert_eq!(
                occ.tfar[l] == f32::NEG_INFINITY,
                occluded[i],
                "occluded4 {}",
                i
            );
        }
    }
    // Streams.
    let mut rh: Vec<PacktraceRayHit> = rays
        .iter()
        .map(|r| PacktraceRayHit {
            ray: c_ray(r, u32::MAX),
            hit: PacktraceHit::default(),
        })
        .collect();
    let s = packtrace_intersect_stream(
        tree.0,
        rh.as_mut_ptr(),
        rh.len(),
        size_of::<PacktraceRayHit>(),
    );
    prop_assert_eq!(s, PacktraceStatus::Ok);
    let mut occ: Vec<PacktraceRay> = rays.iter().map(|r| c_ray(r, u32::MAX)).collect();
    let s = packtrace_occluded_stream(
        tree.0,
        occ.as_mut_ptr(),
        occ.len(),
        size_of::<PacktraceRay>(),
    );
    prop_assert_eq!(s, PacktraceStatus::Ok);
    for (i, r) in rays.iter().enumerate() {
        let got = hit_of(rh[i].ray.tfar, rh[i].hit.prim_id, rh[i].hit.u, rh[i].hit.v);
        if hit_bits(got) != hit_bits(want[i]) {
            return Err(fail("intersect_stream", i, r, got, want[i]));
        }
        prop_assert_eq!(
            occ[i].tfar == f32::NEG_INFINITY,
            occluded[i],
            "occluded_stream {}",
            i
        );
    }
    Ok(())
}

/// Random rays over a random mesh, through a tree of a random preset.
fn rays_of(mesh: &Mesh, specs: &[RaySpec]) -> Vec<Ray> {
    specs.iter().map(|s| make_ray(s, mesh)).collect()
}

proptest! {
    #![proptest_config(config(60))]

    #[test]
    fn c_tree_queries_equal_brute_force(
        spec in any_mesh(),
        specs in prop::collection::vec(ray_spec(), 1..20),
        lanes_on in any::<u8>(),
        preset in 0u32..5,
    ) {
        let mesh = spec.mesh();
        check_tree(&mesh, &rays_of(&mesh, &specs), lanes_on, preset)?;
    }

    #[test]
    fn c_tree_queries_equal_brute_force_on_degenerate_meshes(
        spec in with_degenerates(),
        specs in prop::collection::vec(at_hit_ray_spec(), 1..12),
    ) {
        let mesh = spec.mesh();
        check_tree(&mesh, &rays_of(&mesh, &specs), 0xff, 0)?;
    }

    /// A scene of three instances of one mesh (identity, rotated, moved
    /// and scaled) with masks: every C scene query equals `BruteScene`
    /// under the ray's mask.
    #[test]
    fn c_scene_queries_equal_brute_force(
        spec in any_mesh(),
        specs in prop::collection::vec(ray_spec(), 1..16),
        masks in prop::collection::vec(0u32..8, 16),
        angle in -3.0f32..3.0,
    ) {
        let mesh = spec.mesh();
        let rays = rays_of(&mesh, &specs);
        let xfs = [
            Affine3A::IDENTITY,
            Affine3A::from_rotation_y(angle) * Affine3A::from_translation(Vec3::new(0.5, 0.0, -0.25)),
            Affine3A::from_scale(Vec3::new(-1.5, 1.5, 1.5)),
        ];
        // The Rust scene and its oracle.
        let mut scene = Scene::new();
        let g = scene.add_geometry("m", KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap());
        for (k, xf) in xfs.iter().enumerate() {
            let mut e = scene.edit();
            let id = e.add_instance(g, *xf).unwrap();
            e.set_mask(id, 1 << k).unwrap();
        }
        let brute = BruteScene::new(&scene);
        // The C scene.
        let tree = CTree::new(&mesh, 0);
        let mut cs = std::ptr::null_mut();
        prop_assert_eq!(packtrace_scene_new(&mut cs), PacktraceStatus::Ok);
        let mut geom = 0;
        prop_assert_eq!(packtrace_scene_add_geometry(cs, tree.0, &mut geom), PacktraceStatus::Ok);
        for (k, xf) in xfs.iter().enumerate() {
            let c = xf.matrix3.to_cols_array_2d();
            let t = xf.translation;
            let rows = [
                c[0][0], c[1][0], c[2][0], t.x,
                c[0][1], c[1][1], c[2][1], t.y,
                c[0][2], c[1][2], c[2][2], t.z,
            ];
            let mut id = 0;
            prop_assert_eq!(
                packtrace_scene_add_instance(cs, geom, rows.as_ptr(), 1 << k, &mut id),
                PacktraceStatus::Ok
            );
        }
        prop_assert_eq!(packtrace_scene_commit(cs), PacktraceStatus::Ok);
        let mut stream: Vec<PacktraceRayHit> = Vec::new();
        for (i, r) in rays.iter().enumerate() {
            let q = Query::new().with_mask(masks[i]);
            let want = brute.intersect_with(r, &q);
            let mut rh = PacktraceRayHit { ray: c_ray(r, masks[i]), hit: PacktraceHit::default() };
            stream.push(rh);
            prop_assert_eq!(packtrace_scene_intersect1(cs, &mut rh), PacktraceStatus::Ok);
            let got = hit_of(rh.ray.tfar, rh.hit.prim_id, rh.hit.u, rh.hit.v);
            let want_hit = want.map(|h| Hit { t: h.t, prim: h.prim, u: h.u, v: h.v });
            if hit_bits(got) != hit_bits(want_hit) {
                return Err(fail("scene_intersect1", i, r, got, want_hit));
            }
            if let Some(h) = want {
                prop_assert_eq!((rh.hit.geom_id, rh.hit.inst_id), (h.geometry.0, h.instance.0));
            }
            let mut ray = c_ray(r, masks[i]);
            prop_assert_eq!(packtrace_scene_occluded1(cs, &mut ray), PacktraceStatus::Ok);
            prop_assert_eq!(ray.tfar == f32::NEG_INFINITY, brute.occluded_with(r, &q));
        }
        // Packets: lanes with different masks.
        for (k, chunk) in rays.chunks(8).enumerate() {
            let mut rh = PacktraceRayHit8::default();
            let mut valid = [0; 8];
            for (l, r) in chunk.iter().enumerate() {
                let c = c_ray(r, masks[8 * k + l]);
                valid[l] = -1;
                (rh.ray.org_x[l], rh.ray.org_y[l], rh.ray.org_z[l]) = (c.org_x, c.org_y, c.org_z);
                (rh.ray.dir_x[l], rh.ray.dir_y[l], rh.ray.dir_z[l]) = (c.dir_x, c.dir_y, c.dir_z);
                (rh.ray.tnear[l], rh.ray.tfar[l], rh.ray.mask[l]) = (c.tnear, c.tfar, c.mask);
            }
            let mut occ = rh.ray;
            prop_assert_eq!(packtrace_scene_intersect8(valid.as_ptr(), cs, &mut rh), PacktraceStatus::Ok);
            prop_assert_eq!(packtrace_scene_occluded8(valid.as_ptr(), cs, &mut occ), PacktraceStatus::Ok);
            for (l, r) in chunk.iter().enumerate() {
                let i = 8 * k + l;
                let q = Query::new().with_mask(masks[i]);
                let want = brute.intersect_with(r, &q).map(|h| Hit { t: h.t, prim: h.prim, u: h.u, v: h.v });
                let got = hit_of(rh.ray.tfar[l], rh.hit.prim_id[l], rh.hit.u[l], rh.hit.v[l]);
                if hit_bits(got) != hit_bits(want) {
                    return Err(fail("scene_intersect8", i, r, got, want));
                }
                prop_assert_eq!(occ.tfar[l] == f32::NEG_INFINITY, brute.occluded_with(r, &q));
            }
        }
        // A stream of rays with different masks.
        let s = packtrace_scene_intersect_stream(cs, stream.as_mut_ptr(), stream.len(), size_of::<PacktraceRayHit>());
        prop_assert_eq!(s, PacktraceStatus::Ok);
        for (i, r) in rays.iter().enumerate() {
            let q = Query::new().with_mask(masks[i]);
            let want = brute.intersect_with(r, &q).map(|h| Hit { t: h.t, prim: h.prim, u: h.u, v: h.v });
            let got = hit_of(stream[i].ray.tfar, stream[i].hit.prim_id, stream[i].hit.u, stream[i].hit.v);
            if hit_bits(got) != hit_bits(want) {
                return Err(fail("scene_intersect_stream", i, r, got, want));
            }
        }
        prop_assert_eq!(packtrace_scene_release(cs), PacktraceStatus::Ok);
    }
}
