//! Simple shading: two-sided Lambert under a key light and a sky fill, tinted by the normal.

use kdbeam::{Hit, Mesh, Ray, Vec3};

/// The colour seen along `ray` that hit `hit` (a miss shows a sky gradient).
///
/// The normal is the geometric normal of the hit triangle, turned to face the ray. Degenerate
/// triangles never produce hits, so the normal is always defined.
pub fn shade(mesh: &Mesh, ray: &Ray, hit: &Hit) -> [f32; 3] {
    let d = ray.direction.normalize_or_zero();
    if !hit.is_hit() {
        let k = 0.5 * (1.0 - d.y);
        return (Vec3::new(0.55, 0.65, 0.85) * (1.0 - k) + Vec3::new(0.9, 0.92, 0.95) * k).into();
    }
    let tri = mesh.triangle(hit.triangle as usize);
    let mut n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize_or_zero();
    if n.dot(d) > 0.0 {
        n = -n;
    }
    let key = Vec3::new(-0.4, -0.7, -0.6).normalize();
    let diffuse = n.dot(key).max(0.0);
    let fill = 0.5 + 0.5 * n.dot(Vec3::NEG_Y).max(-1.0);
    let albedo = Vec3::new(0.75, 0.72, 0.68) * 0.7 + (n.abs() * 0.3);
    (albedo * (0.85 * diffuse + 0.25 * fill)).into()
}
