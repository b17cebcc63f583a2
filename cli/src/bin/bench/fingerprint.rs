//! Which rays a JSON line was traced on, as one number: the scene's
//! triangles, the primary rays (so the camera and the image size), the
//! light and the workload. Two lines with equal fingerprints traced the
//! same protocol rays (shadow and ao rays derive from each engine's own
//! primary hits, so only their recipe is the same); `--check` and
//! `bench report` refuse to compare lines whose fingerprints differ.

use packtrace::Mesh;
use packtrace::glam::Vec3;
use packtrace::protocol::workload::{RaySet, Workload};

/// 64-bit FNV-1a over 32-bit words (not cryptographic: a guard against
/// comparing runs of different scenes, cameras or sizes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fingerprint(u64);

impl Fingerprint {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    fn words(mut self, words: impl IntoIterator<Item = u32>) -> Self {
        for w in words {
            self.0 = (self.0 ^ u64::from(w)).wrapping_mul(Self::PRIME);
        }
        self
    }

    /// The fingerprint of a scene's rays before the workload is chosen:
    /// its triangles, its primary rays, its light.
    pub fn of_scene(mesh: &Mesh, primary: &RaySet, light: Vec3) -> Fingerprint {
        let corner = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        Fingerprint(Self::OFFSET)
            .words(mesh.positions().iter().flat_map(|&p| corner(p)))
            .words(mesh.triangles().iter().flatten().copied())
            .words(primary.rays.iter().flat_map(|r| {
                let [ox, oy, oz] = corner(r.origin());
                let [dx, dy, dz] = corner(r.dir());
                [
                    ox,
                    oy,
                    oz,
                    dx,
                    dy,
                    dz,
                    r.t_min().to_bits(),
                    r.t_max().to_bits(),
                ]
            }))
            .words(corner(light))
    }

    /// The fingerprint of one workload of the scene.
    #[must_use]
    pub fn workload(self, w: Workload) -> Fingerprint {
        self.words(w.name().bytes().map(u32::from))
    }

    /// As the JSON writes it: 16 hex digits.
    pub fn hex(self) -> String {
        format!("{:016x}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use packtrace::protocol::camera::Camera;
    use packtrace::protocol::{SceneFrame, generate, workload};

    #[test]
    fn any_change_of_scene_camera_size_light_or_workload_shows() {
        let mesh = generate::sphere(200);
        let frame = SceneFrame::of(&mesh);
        let camera = Camera::auto(&frame.bounds);
        let p = workload::primary(&camera, 16, 16).unwrap();
        let base = Fingerprint::of_scene(&mesh, &p, Vec3::ONE);
        assert_eq!(base, Fingerprint::of_scene(&mesh, &p, Vec3::ONE));
        let wider = workload::primary(&camera, 32, 16).unwrap();
        let other = generate::sphere(300);
        assert_ne!(base, Fingerprint::of_scene(&mesh, &wider, Vec3::ONE));
        assert_ne!(base, Fingerprint::of_scene(&other, &p, Vec3::ONE));
        assert_ne!(base, Fingerprint::of_scene(&mesh, &p, Vec3::X));
        assert_ne!(
            base.workload(Workload::Primary),
            base.workload(Workload::Random)
        );
        assert_eq!(base.hex().len(), 16);
    }
}
