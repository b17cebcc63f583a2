//! The structs a host fills and reads: rays and hits (one ray, 4- and
//! 8-wide packets field for field like Embree 3's `RTCRayHit`,
//! `RTCRayHit4`, `RTCRayHit8` with one instance level), and the build
//! parameters.

/// The id of no triangle, geometry or instance: a miss's `prim_id`,
/// `geom_id` and `inst_id`, and the `inst_id` of a tree's hit (as
/// Embree's `RTC_INVALID_GEOMETRY_ID`).
pub const PACKTRACE_INVALID_ID: u32 = u32::MAX;

/// One ray, `org + t dir` for `tnear < t <= tfar` (the ray policy: a
/// zero direction component is allowed, a zero direction is not; NaN or
/// infinite coordinates and NaN bounds are refused). Layout of Embree 3's
/// `RTCRay`; `time`, `id` and `flags` are the host's and never read.
/// `mask` is read by scene queries only (an instance is traced when its
/// mask and the ray's share a bit).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PacktraceRay {
    /// Origin, x.
    pub org_x: f32,
    /// Origin, y.
    pub org_y: f32,
    /// Origin, z.
    pub org_z: f32,
    /// Exclusive lower bound of the hit distance.
    pub tnear: f32,
    /// Direction, x (need not be normalised; `t` is in units of it).
    pub dir_x: f32,
    /// Direction, y.
    pub dir_y: f32,
    /// Direction, z.
    pub dir_z: f32,
    /// Not read (motion blur is not supported).
    pub time: f32,
    /// Inclusive upper bound of the hit distance; an intersect query sets
    /// it to the hit's `t`, an occluded query to `-inf` when the ray is
    /// occluded (as Embree).
    pub tfar: f32,
    /// The ray's mask (scene queries).
    pub mask: u32,
    /// Not read: the host's.
    pub id: u32,
    /// Not read: the host's.
    pub flags: u32,
}

/// A hit, as an intersect query writes it. Layout of Embree 3's `RTCHit`
/// with one instance level. On a miss `prim_id`, `geom_id` and `inst_id`
/// are `PACKTRACE_INVALID_ID` and the rest is unchanged.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PacktraceHit {
    /// Geometric normal, x: unit length (Embree's is not normalised), in
    /// world space for a scene's hit.
    pub ng_x: f32,
    /// Geometric normal, y.
    pub ng_y: f32,
    /// Geometric normal, z.
    pub ng_z: f32,
    /// Barycentric weight of the triangle's second vertex.
    pub u: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub v: f32,
    /// The triangle's index in its mesh.
    pub prim_id: u32,
    /// The geometry's id in its scene (0 for a tree's hit).
    pub geom_id: u32,
    /// The instance's id in its scene (`PACKTRACE_INVALID_ID` for a
    /// tree's hit).
    pub inst_id: u32,
}

/// A ray and the hit an intersect query writes (`RTCRayHit`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PacktraceRayHit {
    /// The ray (its `tfar` becomes the hit's `t`).
    pub ray: PacktraceRay,
    /// The hit.
    pub hit: PacktraceHit,
}

// Written out, not made by a macro: cbindgen does not expand macros.

/// 4 rays in SoA form, field for field like Embree 3's `RTCRayHit4` ray
/// part (see `PacktraceRay`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacktraceRay4 {
    /// Origins, x.
    pub org_x: [f32; 4],
    /// Origins, y.
    pub org_y: [f32; 4],
    /// Origins, z.
    pub org_z: [f32; 4],
    /// Exclusive lower bounds.
    pub tnear: [f32; 4],
    /// Directions, x.
    pub dir_x: [f32; 4],
    /// Directions, y.
    pub dir_y: [f32; 4],
    /// Directions, z.
    pub dir_z: [f32; 4],
    /// Not read.
    pub time: [f32; 4],
    /// Inclusive upper bounds; set to the hit's `t` (intersect) or `-inf`
    /// (occluded lanes).
    pub tfar: [f32; 4],
    /// Ray masks (scene queries).
    pub mask: [u32; 4],
    /// Not read.
    pub id: [u32; 4],
    /// Not read.
    pub flags: [u32; 4],
}

/// The hits of 4 rays in SoA form (see `PacktraceHit`).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacktraceHit4 {
    /// Geometric normals, x (unit length).
    pub ng_x: [f32; 4],
    /// Geometric normals, y.
    pub ng_y: [f32; 4],
    /// Geometric normals, z.
    pub ng_z: [f32; 4],
    /// Barycentric weights of the second vertex.
    pub u: [f32; 4],
    /// Barycentric weights of the third vertex.
    pub v: [f32; 4],
    /// Triangle indices (`PACKTRACE_INVALID_ID`: no hit).
    pub prim_id: [u32; 4],
    /// Geometry ids.
    pub geom_id: [u32; 4],
    /// Instance ids.
    pub inst_id: [u32; 4],
}

/// A packet of 4 rays and their hits (`RTCRayHit4`), 16-byte aligned.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PacktraceRayHit4 {
    /// The rays.
    pub ray: PacktraceRay4,
    /// The hits.
    pub hit: PacktraceHit4,
}

/// 8 rays in SoA form, field for field like Embree 3's `RTCRayHit8` ray
/// part (see `PacktraceRay`).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacktraceRay8 {
    /// Origins, x.
    pub org_x: [f32; 8],
    /// Origins, y.
    pub org_y: [f32; 8],
    /// Origins, z.
    pub org_z: [f32; 8],
    /// Exclusive lower bounds.
    pub tnear: [f32; 8],
    /// Directions, x.
    pub dir_x: [f32; 8],
    /// Directions, y.
    pub dir_y: [f32; 8],
    /// Directions, z.
    pub dir_z: [f32; 8],
    /// Not read.
    pub time: [f32; 8],
    /// Inclusive upper bounds; set to the hit's `t` (intersect) or `-inf`
    /// (occluded lanes).
    pub tfar: [f32; 8],
    /// Ray masks (scene queries).
    pub mask: [u32; 8],
    /// Not read.
    pub id: [u32; 8],
    /// Not read.
    pub flags: [u32; 8],
}

/// The hits of 8 rays in SoA form (see `PacktraceHit`).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacktraceHit8 {
    /// Geometric normals, x (unit length).
    pub ng_x: [f32; 8],
    /// Geometric normals, y.
    pub ng_y: [f32; 8],
    /// Geometric normals, z.
    pub ng_z: [f32; 8],
    /// Barycentric weights of the second vertex.
    pub u: [f32; 8],
    /// Barycentric weights of the third vertex.
    pub v: [f32; 8],
    /// Triangle indices (`PACKTRACE_INVALID_ID`: no hit).
    pub prim_id: [u32; 8],
    /// Geometry ids.
    pub geom_id: [u32; 8],
    /// Instance ids.
    pub inst_id: [u32; 8],
}

/// A packet of 8 rays and their hits (`RTCRayHit8`), 32-byte aligned.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PacktraceRayHit8 {
    /// The rays.
    pub ray: PacktraceRay8,
    /// The hits.
    pub hit: PacktraceHit8,
}

/// `Default` for a packet width's structs: zero rays with `tfar = +inf`
/// and all-ones masks, no hits.
macro_rules! packet_defaults {
    ($ray:ident, $hit:ident, $w:literal) => {
        impl Default for $ray {
            fn default() -> Self {
                $ray {
                    org_x: [0.0; $w],
                    org_y: [0.0; $w],
                    org_z: [0.0; $w],
                    tnear: [0.0; $w],
                    dir_x: [0.0; $w],
                    dir_y: [0.0; $w],
                    dir_z: [0.0; $w],
                    time: [0.0; $w],
                    tfar: [f32::INFINITY; $w],
                    mask: [u32::MAX; $w],
                    id: [0; $w],
                    flags: [0; $w],
                }
            }
        }

        impl Default for $hit {
            fn default() -> Self {
                $hit {
                    ng_x: [0.0; $w],
                    ng_y: [0.0; $w],
                    ng_z: [0.0; $w],
                    u: [0.0; $w],
                    v: [0.0; $w],
                    prim_id: [PACKTRACE_INVALID_ID; $w],
                    geom_id: [PACKTRACE_INVALID_ID; $w],
                    inst_id: [PACKTRACE_INVALID_ID; $w],
                }
            }
        }
    };
}

packet_defaults!(PacktraceRay4, PacktraceHit4, 4);
packet_defaults!(PacktraceRay8, PacktraceHit8, 8);

/// Which acceleration structure `packtrace_tree_new` builds
/// (`PacktraceBuildParams::accel`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacktraceAccel {
    /// The SAH kd-tree of 8-byte nodes (PBRT's layout).
    KdTree = 0,
    // Reserved: 1 for the 8-wide BVH (`PACKTRACE_ACCEL_BVH8`) when the
    // library has it; today a tree of kind 1 is refused with
    // PACKTRACE_STATUS_UNSUPPORTED.
}

/// The value of `PacktraceBuildParams::accel` reserved for the 8-wide
/// BVH: refused with `PACKTRACE_STATUS_UNSUPPORTED` until the library
/// has that structure.
pub const PACKTRACE_ACCEL_RESERVED_BVH8: u32 = 1;

/// The build presets of `packtrace_build_params_preset` (the Rust
/// `KdBuildParams` presets).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacktracePreset {
    /// The default, chosen by measurement on the protocol's rays.
    Default = 0,
    /// For scenes rebuilt every frame: binned sweep, no clipping.
    Dynamic = 1,
    /// PBRT-v3's constants.
    Pbrt = 2,
    /// Mitsuba 0.6's constants.
    Mitsuba = 3,
    /// Binned sweep above 64 triangles, shallower trees.
    FastBuild = 4,
}

/// How `PacktraceBuildParams` gives the depth limit.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacktraceDepthRule {
    /// `round(depth_base + depth_slope * log2 N)` for `N` triangles, at
    /// most 64.
    Log2 = 0,
    /// `depth_fixed` for every mesh, at most 64.
    Fixed = 1,
}

/// Build parameters: fill them with `packtrace_build_params_default` (or
/// `_preset`) and change fields. The kd-tree's fields are those of the
/// Rust `KdBuildParams`, checked the same way
/// (`PACKTRACE_STATUS_INVALID_PARAMS` names the first bad field).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacktraceBuildParams {
    /// The structure: a `PacktraceAccel` value.
    pub accel: u32,
    /// SAH cost of one traversal step, finite and > 0.
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test, finite and > 0.
    pub intersection_cost: f32,
    /// Fraction of the cost waived when one side of a split is empty, in
    /// [0, 1).
    pub empty_bonus: f32,
    /// A `PacktraceDepthRule` value.
    pub depth_rule: u32,
    /// `PACKTRACE_DEPTH_RULE_LOG2`: depth of a one-triangle mesh (finite,
    /// >= 0).
    pub depth_base: f32,
    /// `PACKTRACE_DEPTH_RULE_LOG2`: levels per doubling of the triangle
    /// count (finite, >= 0).
    pub depth_slope: f32,
    /// `PACKTRACE_DEPTH_RULE_FIXED`: the depth, at most 64.
    pub depth_fixed: u32,
    /// Splits costlier than a leaf allowed on one path, >= 1.
    pub max_bad_refines: u32,
    /// Nodes with at most this many triangles become leaves.
    pub max_leaf_size: u32,
    /// Nodes with more triangles than this use the binned sweep
    /// (`SIZE_MAX`: never).
    pub exact_below: usize,
    /// Bins per axis of the binned sweep, in 2..=4096.
    pub bins: u32,
    /// Clip straddling triangles to the child cells: 0 or 1.
    pub split_clipping: u32,
    /// Fail rather than hold more bytes than this during the build (0: no
    /// budget).
    pub memory_budget: usize,
    /// Build threads (0: the library's global pool, one per core).
    pub threads: u32,
}
