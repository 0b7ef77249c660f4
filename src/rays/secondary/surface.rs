//! Where a secondary ray starts: the primary hit point, pushed off the surface.

use glam::Vec3;
use kdbeam_kernels::{Hit, Ray};

use crate::Mesh;

/// A primary hit as the start of secondary rays: the offset origin and the geometric normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// The hit point moved by the offset along [`Surface::normal`].
    pub origin: Vec3,
    /// The unit geometric normal of the hit triangle, turned towards the incoming ray
    /// (`normal · direction < 0`).
    pub normal: Vec3,
    /// The hit triangle.
    pub triangle: u32,
}

impl Surface {
    /// The surface `ray` reached at `hit` on `mesh`, its origin `offset` along the normal.
    ///
    /// The hit point is interpolated from the barycentrics, `(1 − u − v)·v0 + u·v1 + v·v2`
    /// (it lies on the triangle up to rounding, whatever the ray's length), and the normal is
    /// `normalize((v1 − v0) × (v2 − v0))`, flipped when it faces away from the ray's origin. A
    /// ray that grazes the plane exactly (`normal · direction = 0`) keeps the unflipped normal.
    /// `None` for a miss, a triangle id outside the mesh, or a triangle with no normal (never
    /// hit: degenerate triangles produce no hits).
    #[must_use]
    pub fn at(mesh: &Mesh, ray: &Ray, hit: &Hit, offset: f32) -> Option<Surface> {
        if !hit.is_hit() || hit.triangle as usize >= mesh.triangle_count() {
            return None;
        }
        let tri = mesh.triangle(hit.triangle as usize);
        let mut normal = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize_or_zero();
        if normal == Vec3::ZERO {
            return None;
        }
        if normal.dot(ray.direction) > 0.0 {
            normal = -normal;
        }
        let point = tri.v0 * (1.0 - hit.u - hit.v) + tri.v1 * hit.u + tri.v2 * hit.v;
        Some(Surface {
            origin: point + normal * offset,
            normal,
            triangle: hit.triangle,
        })
    }
}
