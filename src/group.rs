//! Ray groups: a screen tile's coherent rays (8 x 8 or 16 x 16 of them,
//! as 8-wide packets) that share an apex, with the group's bounding
//! frustum computed once. [`crate::KdTree::intersect_group`] and
//! [`crate::KdTree::occluded_group`] steer the whole group through the
//! kd-tree with one frustum test per node (docs/groups.md).
//!
//! ```
//! use glam::Vec3;
//! use packtrace::group::{Apex, RayGroup};
//! use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
//!
//! let mesh = Mesh::new(vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::Y], vec![[0, 1, 2]])?;
//! let tree = KdTree::build(mesh, &KdBuildParams::default())?;
//! let eye = Vec3::new(0.0, 0.0, 3.0);
//! // Two 4 x 2 packets of rays from one eye.
//! let packets: Vec<RayPacket8> = (0..2)
//!     .map(|p| RayPacket8::from_fn(|i| {
//!         let (x, y) = ((i % 4) as f32, (i / 4 + 2 * p) as f32);
//!         Ray::new(eye, Vec3::new(0.01 * x, 0.01 * y, -1.0), 0.0, f32::INFINITY).ok()
//!     }))
//!     .collect();
//! let group = RayGroup::new(&packets, eye, Apex::Origin)?;
//! assert!(group.is_coherent());
//! let hits = tree.intersect_group(&group);
//! assert_eq!(hits[1].hit(5), tree.intersect(&packets[1].ray(5).unwrap()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::frustum::Frustum;
use crate::packet::RayPacket8;
use glam::Vec3;
use std::fmt;

pub use crate::frustum::Apex;

/// The most packets a group holds: a 16 x 16 tile of 8-wide packets.
///
/// ```
/// assert_eq!(packtrace::group::MAX_GROUP_PACKETS, 32);
/// ```
pub const MAX_GROUP_PACKETS: usize = 32;

/// Why [`RayGroup::new`] refused its input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GroupError {
    /// More packets than [`MAX_GROUP_PACKETS`] (the number given).
    TooManyPackets(usize),
    /// The apex has a NaN or infinite coordinate.
    NonFiniteApex,
}

impl fmt::Display for GroupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GroupError::TooManyPackets(n) => write!(
                f,
                "a ray group holds at most {MAX_GROUP_PACKETS} packets, got {n}"
            ),
            GroupError::NonFiniteApex => f.write_str("the group's apex is not finite"),
        }
    }
}

impl std::error::Error for GroupError {}

/// Up to [`MAX_GROUP_PACKETS`] 8-wide packets traced together, with the
/// frustum from their common apex that holds every ray's segment.
///
/// A group whose rays do not fit one narrow frustum from the apex (rays
/// starting behind it, directions spreading over more than about 53
/// degrees) is still valid: it is not [coherent](RayGroup::is_coherent),
/// and the group queries trace it packet by packet with the same results.
///
/// ```
/// use glam::Vec3;
/// use packtrace::group::{Apex, GroupError, RayGroup};
/// use packtrace::RayPacket8;
/// let none = [RayPacket8::from_lanes([None; 8]); 40];
/// assert_eq!(RayGroup::new(&none, Vec3::ZERO, Apex::Origin).unwrap_err(), GroupError::TooManyPackets(40));
/// assert!(!RayGroup::new(&none[..2], Vec3::ZERO, Apex::Origin).unwrap().is_coherent());
/// ```
#[derive(Clone, Debug)]
pub struct RayGroup<'a> {
    packets: &'a [RayPacket8],
    frustum: Option<Frustum>,
    leaf_culling: bool,
    entry_handoff: bool,
}

impl<'a> RayGroup<'a> {
    /// The group of `packets` seen from `apex`: the rays' common origin
    /// ([`Apex::Origin`], primary rays of a pinhole camera) or common
    /// target ([`Apex::Target`], shadow rays toward a point light).
    /// Nothing requires the rays to meet the apex exactly: the frustum is
    /// built from their actual segments.
    ///
    /// # Errors
    /// [`GroupError::TooManyPackets`] beyond [`MAX_GROUP_PACKETS`];
    /// [`GroupError::NonFiniteApex`] for an apex with a NaN or infinite
    /// coordinate.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, GroupError, RayGroup};
    /// let e = RayGroup::new(&[], Vec3::NAN, Apex::Target).unwrap_err();
    /// assert_eq!(e, GroupError::NonFiniteApex);
    /// ```
    pub fn new(
        packets: &'a [RayPacket8],
        apex: Vec3,
        kind: Apex,
    ) -> Result<RayGroup<'a>, GroupError> {
        if packets.len() > MAX_GROUP_PACKETS {
            return Err(GroupError::TooManyPackets(packets.len()));
        }
        if !apex.is_finite() {
            return Err(GroupError::NonFiniteApex);
        }
        Ok(RayGroup {
            packets,
            frustum: Frustum::of_packets(packets, apex, kind),
            leaf_culling: false,
            entry_handoff: true,
        })
    }

    /// The group with leaf culling on or off: in each leaf, the triangles
    /// outside the frustum are found once and skipped for every packet.
    /// Off by default: on the protocol's primary and shadow rays it costs
    /// more than it saves (docs/groups.md). It applies to groups
    /// steered to the leaves ([`RayGroup::with_entry_handoff`] off); with
    /// the hand-off, the packets meet the leaves alone. Results are the
    /// same either way.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap().with_leaf_culling(true);
    /// assert!(g.leaf_culling());
    /// ```
    #[must_use]
    pub fn with_leaf_culling(mut self, on: bool) -> RayGroup<'a> {
        self.leaf_culling = on;
        self
    }

    /// Is leaf culling on ([`RayGroup::with_leaf_culling`])?
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// assert!(!RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap().leaf_culling());
    /// ```
    #[must_use]
    pub fn leaf_culling(&self) -> bool {
        self.leaf_culling
    }

    /// The group with the entry hand-off on or off. On (the default), the
    /// group descends as one only to its entry point, the first node both
    /// of whose children meet its frustum, and each packet goes on from
    /// there with the packet traversal. Off, the group is steered as one
    /// down to the leaves, where each packet clips itself to the cell.
    /// The hand-off ran 1.2x faster on the protocol's primary rays
    /// (docs/groups.md). Results are the same either way.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap();
    /// assert!(g.entry_handoff());
    /// assert!(!g.with_entry_handoff(false).entry_handoff());
    /// ```
    #[must_use]
    pub fn with_entry_handoff(mut self, on: bool) -> RayGroup<'a> {
        self.entry_handoff = on;
        self
    }

    /// Is the entry hand-off on ([`RayGroup::with_entry_handoff`])?
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// assert!(RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap().entry_handoff());
    /// ```
    #[must_use]
    pub fn entry_handoff(&self) -> bool {
        self.entry_handoff
    }

    /// The packets, in the order results are returned.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap();
    /// assert!(g.packets().is_empty());
    /// ```
    #[must_use]
    pub fn packets(&self) -> &'a [RayPacket8] {
        self.packets
    }

    /// Does the group have a frustum (and so get traced as one)? If not,
    /// its packets are traced one by one.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// assert!(!RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap().is_coherent());
    /// ```
    #[must_use]
    pub fn is_coherent(&self) -> bool {
        self.frustum.is_some()
    }

    pub(crate) fn frustum(&self) -> Option<&Frustum> {
        self.frustum.as_ref()
    }
}
