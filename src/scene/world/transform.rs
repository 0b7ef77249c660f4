//! Instance transforms: validated once when set, and boxes carried to world space.

use glam::{Affine3A, Vec3A};
use kdbeam_kernels::Aabb;

use crate::{Error, Result};

/// `to_world` and its inverse, or [`Error::InvalidTransform`] when an entry is NaN or infinite
/// or the inverse is (a singular or nearly singular matrix).
pub(super) fn checked_inverse(to_world: &Affine3A) -> Result<Affine3A> {
    if !to_world.is_finite() {
        return Err(Error::InvalidTransform(format!(
            "non-finite entry in {to_world:?}"
        )));
    }
    let det = to_world.matrix3.determinant();
    let inverse = to_world.inverse();
    if det == 0.0 || !det.is_finite() || !inverse.is_finite() {
        return Err(Error::InvalidTransform(format!(
            "{to_world:?} cannot be inverted (determinant {det})"
        )));
    }
    Ok(inverse)
}

/// The world box of an object box under `to_world` (J. Arvo, *Transforming Axis-Aligned
/// Bounding Boxes*, Graphics Gems 1990): the centre is carried over, the half extent by the
/// absolute matrix. Empty stays empty.
#[inline]
pub(super) fn world_box(to_world: &Affine3A, b: &Aabb) -> Aabb {
    if b.is_empty() {
        return Aabb::EMPTY;
    }
    let centre = Vec3A::from((b.min + b.max) * 0.5);
    let half = Vec3A::from((b.max - b.min) * 0.5);
    let m = to_world.matrix3;
    let c = to_world.transform_point3a(centre);
    let e = m.x_axis.abs() * half.x + m.y_axis.abs() * half.y + m.z_axis.abs() * half.z;
    // The rounding of the centre and extent is a few ulps of the coordinates; pad by that so
    // that no ray the instance's tree would hit misses its box.
    let pad = (c.abs() + e) * (4.0 * f32::EPSILON);
    Aabb::new((c - e - pad).into(), (c + e + pad).into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    #[test]
    fn bad_transforms_are_rejected() {
        let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
        assert!(matches!(
            checked_inverse(&nan),
            Err(Error::InvalidTransform(_))
        ));
        let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
        assert!(matches!(
            checked_inverse(&flat),
            Err(Error::InvalidTransform(_))
        ));
        let ok = Affine3A::from_scale_rotation_translation(
            Vec3::splat(2.0),
            Quat::from_rotation_y(0.3),
            Vec3::X,
        );
        let inv = checked_inverse(&ok).unwrap();
        assert!((inv * ok).abs_diff_eq(Affine3A::IDENTITY, 1e-6));
    }

    #[test]
    fn world_box_holds_every_transformed_corner() {
        let t = Affine3A::from_scale_rotation_translation(
            Vec3::new(1.0, 3.0, 0.5),
            Quat::from_euler(glam::EulerRot::XYZ, 0.4, -1.1, 2.0),
            Vec3::new(10.0, -4.0, 2.0),
        );
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 5.0));
        let w = world_box(&t, &b);
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let p = t.transform_point3(corner);
            assert!(
                p.cmpge(w.min).all() && p.cmple(w.max).all(),
                "{p} outside {w:?}"
            );
        }
        assert!(world_box(&t, &Aabb::EMPTY).is_empty());
    }
}
