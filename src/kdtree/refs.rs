//! The build's triangle references: a triangle's box clipped to its node's cell, with its mesh
//! id, packed as Embree packs its `PrimRef`.

use glam::{Vec3A, Vec4};
use kdbeam_kernels::Aabb;

/// A triangle reference: the box of the triangle's part in a node's cell, and its mesh id, in
/// two 16-byte vectors `[min.x, min.y, min.z, id]` and `[max.x, max.y, max.z, 0]`.
///
/// So a reference is one 32-byte record (one store to move it), a union of boxes is one `min`
/// and one `max` ([`Bounds`]), and the binning reads a corner in one load. The id rides in the
/// spare lane as the bits of an f32, tagged with [`ID_TAG`]: the lane goes through the vector
/// arithmetic of the binning (its result unused), and the tag keeps it a normal number there,
/// never a subnormal, whose arithmetic can take a slow microcode path.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct Ref {
    lo: Vec4,
    hi: Vec4,
}

/// Set in the bits of a [`Ref`]'s id lane: ids are below 2³⁰, so the lane's exponent is at
/// least 128 (a number of at least 2, or a NaN for the largest ids; never subnormal).
const ID_TAG: u32 = 1 << 30;

impl Ref {
    /// The reference of triangle `id` (below 2³⁰) with box `b`.
    #[inline(always)]
    pub fn new(id: u32, b: &Aabb) -> Ref {
        debug_assert!(id < ID_TAG);
        Ref {
            lo: b.min.extend(f32::from_bits(id | ID_TAG)),
            hi: b.max.extend(0.0),
        }
    }

    /// The mesh id.
    #[inline(always)]
    pub fn id(&self) -> u32 {
        self.lo.w.to_bits() & !ID_TAG
    }

    /// The box's lower corner.
    #[inline(always)]
    pub fn lo(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo)
    }

    /// The box's upper corner.
    #[inline(always)]
    pub fn hi(&self) -> Vec3A {
        Vec3A::from_vec4(self.hi)
    }

    /// The box's span `(min, max)` on `axis` (0, 1 or 2).
    #[inline(always)]
    pub fn span(&self, axis: usize) -> (f32, f32) {
        // Axis 3 would read the spare lanes, not panic.
        debug_assert!(axis < 3);
        let faces: &[f32; 8] = bytemuck::cast_ref(self);
        (faces[axis], faces[axis + 4])
    }

    /// The box.
    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }
}

/// The union of references' boxes, accumulated in two vectors.
#[derive(Clone, Copy)]
pub(super) struct Bounds {
    lo: Vec3A,
    hi: Vec3A,
}

impl Bounds {
    /// The empty union.
    pub const EMPTY: Bounds = Bounds {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
    };

    /// Takes in `r`'s box. (`min` and `max` of the lanes: boxes hold no NaN.)
    #[inline(always)]
    pub fn add(&mut self, r: &Ref) {
        self.lo = self.lo.min(r.lo());
        self.hi = self.hi.max(r.hi());
    }

    /// The union as a box.
    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.into(), self.hi.into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_reference_keeps_its_box_and_id() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 0.5, 2.0));
        for id in [0, 1, 12345, (1 << 23) - 1, 1 << 23, (1 << 30) - 1] {
            let r = Ref::new(id, &b);
            assert_eq!((r.id(), r.aabb()), (id, b));
            assert_eq!(
                [r.span(0), r.span(1), r.span(2)],
                [(-1.0, 3.0), (0.0, 0.5), (2.0, 2.0)]
            );
            // The id lane is a normal number or a NaN, never subnormal.
            assert!(r.lo.w.is_normal() || r.lo.w.is_nan(), "{id}");
        }
        let mut u = Bounds::EMPTY;
        u.add(&Ref::new(0, &b));
        u.add(&Ref::new(
            1,
            &Aabb::new(Vec3::splat(-2.0), Vec3::splat(1.0)),
        ));
        assert_eq!(
            u.aabb(),
            Aabb::new(Vec3::new(-2.0, -2.0, -2.0), Vec3::new(3.0, 1.0, 2.0))
        );
    }
}
