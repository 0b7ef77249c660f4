//! Simple shading: two-sided Lambert under a key light and a sky fill, tinted by the normal;
//! with shadows from the workload's point light and ambient occlusion when they were traced.

use kdbeam::{Hit, Mesh, Ray, Vec3};

/// What secondary rays found at a pixel, for [`shade_lit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// The point light (the shadow workload's), which replaces the fixed key direction.
    pub position: Vec3,
    /// 1 when the shadow ray reached the light, 0 when it was occluded.
    pub visible: f32,
    /// The share of ambient-occlusion rays that escaped (1 without AO).
    pub ambient: f32,
}

/// The colour seen along `ray` that hit `hit` (a miss shows a sky gradient), lit by a fixed
/// key direction.
///
/// The normal is the geometric normal of the hit triangle, turned to face the ray. Degenerate
/// triangles never produce hits, so the normal is always defined.
pub fn shade(mesh: &Mesh, ray: &Ray, hit: &Hit) -> [f32; 3] {
    shade_lit(mesh, ray, hit, None)
}

/// [`shade`], with the key light at `light.position` dimmed by its visibility and the sky fill
/// by its ambient occlusion when `light` is given.
pub fn shade_lit(mesh: &Mesh, ray: &Ray, hit: &Hit, light: Option<Light>) -> [f32; 3] {
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
    let point = ray.at(hit.t);
    // The fixed key shines from −y, so the fill does from +y; the point light is above the
    // box (+y), so then the sky fill is from +y too.
    let (key, sky, visible, ambient) = match light {
        Some(l) => (
            (l.position - point).normalize_or_zero(),
            Vec3::Y,
            l.visible,
            l.ambient,
        ),
        None => (
            Vec3::new(-0.4, -0.7, -0.6).normalize(),
            Vec3::NEG_Y,
            1.0,
            1.0,
        ),
    };
    let diffuse = n.dot(key).max(0.0) * visible;
    let fill = (0.5 + 0.5 * n.dot(sky).max(-1.0)) * ambient;
    let albedo = Vec3::new(0.75, 0.72, 0.68) * 0.7 + (n.abs() * 0.3);
    (albedo * (0.85 * diffuse + 0.25 * fill)).into()
}
