//! Build parameters: the presets as the plain C struct, and the struct
//! checked and turned into the library's parameters. The structure kind
//! (`PacktraceAccel`) is parsed here, in one match: a new structure is one
//! arm here and one in `tree.rs`'s build.

use crate::status::{Error, PacktraceStatus};
use crate::types::{
    PACKTRACE_ACCEL_RESERVED_BVH8, PacktraceAccel, PacktraceBuildParams, PacktraceDepthRule,
    PacktracePreset,
};
use packtrace::{BuildError, DepthLimit, KdBuildParams};

/// The C struct of a kd-tree preset.
pub(crate) fn from_kd(p: &KdBuildParams) -> PacktraceBuildParams {
    let (depth_rule, depth_base, depth_slope, depth_fixed) = match p.max_depth {
        DepthLimit::Log2 { base, slope } => (PacktraceDepthRule::Log2, base, slope, 0),
        DepthLimit::Fixed(d) => (PacktraceDepthRule::Fixed, 0.0, 0.0, d),
    };
    PacktraceBuildParams {
        accel: PacktraceAccel::KdTree as u32,
        traversal_cost: p.traversal_cost,
        intersection_cost: p.intersection_cost,
        empty_bonus: p.empty_bonus,
        depth_rule: depth_rule as u32,
        depth_base,
        depth_slope,
        depth_fixed,
        max_bad_refines: p.max_bad_refines,
        max_leaf_size: p.max_leaf_size,
        exact_below: p.exact_below,
        bins: p.bins,
        split_clipping: u32::from(p.split_clipping),
        memory_budget: p.memory_budget.unwrap_or(0),
        threads: p.threads.map_or(0, |n| n as u32),
    }
}

impl Default for PacktraceBuildParams {
    /// The default preset (`packtrace_build_params_default`).
    fn default() -> Self {
        from_kd(&KdBuildParams::default())
    }
}

/// The preset numbered `preset` (a `PacktracePreset`).
pub(crate) fn preset(preset: u32) -> Result<PacktraceBuildParams, Error> {
    let kd = match preset {
        p if p == PacktracePreset::Default as u32 => KdBuildParams::packtrace(),
        p if p == PacktracePreset::Dynamic as u32 => KdBuildParams::dynamic(),
        p if p == PacktracePreset::Pbrt as u32 => KdBuildParams::pbrt(),
        p if p == PacktracePreset::Mitsuba as u32 => KdBuildParams::mitsuba(),
        p if p == PacktracePreset::FastBuild as u32 => KdBuildParams::fast_build(),
        p => {
            return Err(Error::invalid(format!(
                "preset {p} is not a PacktracePreset (0 to 4)"
            )));
        }
    };
    Ok(from_kd(&kd))
}

/// The structure a tree is built as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Accel {
    KdTree,
}

impl Accel {
    /// The kind `raw` names (`PacktraceBuildParams::accel`).
    pub(crate) fn from_raw(raw: u32) -> Result<Accel, Error> {
        match raw {
            r if r == PacktraceAccel::KdTree as u32 => Ok(Accel::KdTree),
            PACKTRACE_ACCEL_RESERVED_BVH8 => Err(Error::new(
                PacktraceStatus::Unsupported,
                "accel 1 is reserved for the 8-wide BVH, which this version of packtrace \
                 does not have yet (use PACKTRACE_ACCEL_KD_TREE)",
            )),
            r => Err(BuildError::InvalidParams(format!(
                "accel = {r} (must be a PacktraceAccel value)"
            ))
            .into()),
        }
    }
}

/// The kd-tree's parameters of the C struct, checked as
/// `KdBuildParams::validate` checks them, and the fields the Rust struct
/// types itself (`depth_rule`, `split_clipping`).
pub(crate) fn kd(p: &PacktraceBuildParams) -> Result<KdBuildParams, Error> {
    let bad = |field: &str, value: u32, rule: &str| -> Error {
        BuildError::InvalidParams(format!("{field} = {value} ({rule})")).into()
    };
    let max_depth = match p.depth_rule {
        r if r == PacktraceDepthRule::Log2 as u32 => DepthLimit::Log2 {
            base: p.depth_base,
            slope: p.depth_slope,
        },
        r if r == PacktraceDepthRule::Fixed as u32 => DepthLimit::Fixed(p.depth_fixed),
        r => return Err(bad("depth_rule", r, "must be 0 (LOG2) or 1 (FIXED)")),
    };
    let split_clipping = match p.split_clipping {
        0 => false,
        1 => true,
        v => return Err(bad("split_clipping", v, "must be 0 or 1")),
    };
    let kd = KdBuildParams {
        traversal_cost: p.traversal_cost,
        intersection_cost: p.intersection_cost,
        empty_bonus: p.empty_bonus,
        max_depth,
        max_bad_refines: p.max_bad_refines,
        max_leaf_size: p.max_leaf_size,
        exact_below: p.exact_below,
        bins: p.bins,
        split_clipping,
        memory_budget: (p.memory_budget != 0).then_some(p.memory_budget),
        threads: (p.threads != 0).then_some(p.threads as usize),
    };
    kd.validate()?;
    Ok(kd)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_goes_there_and_back() {
        for (i, (_, p)) in KdBuildParams::presets().iter().enumerate() {
            let c = preset(i as u32).unwrap();
            assert_eq!(kd(&c).unwrap(), *p);
        }
        assert_eq!(
            preset(5).unwrap_err().message,
            "preset 5 is not a PacktracePreset (0 to 4)"
        );
    }

    #[test]
    fn bad_fields_are_named() {
        let base = preset(0).unwrap();
        let e = kd(&PacktraceBuildParams {
            traversal_cost: f32::NAN,
            ..base
        })
        .unwrap_err();
        assert_eq!(e.status, PacktraceStatus::InvalidParams);
        assert_eq!(
            e.message,
            "invalid kd-tree build parameters: traversal_cost = NaN (must be finite and > 0)"
        );
        let e = kd(&PacktraceBuildParams {
            split_clipping: 2,
            ..base
        })
        .unwrap_err();
        assert_eq!(
            e.message,
            "invalid kd-tree build parameters: split_clipping = 2 (must be 0 or 1)"
        );
        assert_eq!(
            Accel::from_raw(1).unwrap_err().status,
            PacktraceStatus::Unsupported
        );
        assert_eq!(
            Accel::from_raw(7).unwrap_err().status,
            PacktraceStatus::InvalidParams
        );
    }
}
