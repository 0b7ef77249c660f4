//! What a scene query returns, and what it is asked with.

use super::ids::{GeometryId, InstanceId};

/// The closest hit of a ray in a [`super::Scene`].
///
/// `t` is the world ray's parameter; `u`, `v` and `triangle` are those of the mesh
/// ([`crate::Hit`]'s), whatever the instance's transform. A miss is [`SceneHit::NONE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// Ray parameter of the hit (`+inf` for a miss).
    pub t: f32,
    /// Barycentric weight of the triangle's `v1`.
    pub u: f32,
    /// Barycentric weight of the triangle's `v2`.
    pub v: f32,
    /// Index of the triangle in its mesh (`u32::MAX` for a miss).
    pub triangle: u32,
    /// The mesh ([`GeometryId::NONE`] for a miss).
    pub geometry: GeometryId,
    /// The instance ([`InstanceId::NONE`] for a miss, and for a mesh traced as it is).
    pub instance: InstanceId,
}

impl SceneHit {
    /// No hit.
    pub const NONE: SceneHit = SceneHit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
        triangle: u32::MAX,
        geometry: GeometryId::NONE,
        instance: InstanceId::NONE,
    };

    /// Did the ray hit anything?
    #[inline]
    #[must_use]
    pub fn is_hit(&self) -> bool {
        self.triangle != u32::MAX
    }

    /// Is `other` closer? Ties in `t` go to the smaller instance id (a mesh traced as it is
    /// last), then the smaller geometry id, then the smaller triangle id, so that the closest
    /// hit is unique whatever order instances are visited in.
    #[inline]
    #[must_use]
    pub fn is_beaten_by(&self, other: &SceneHit) -> bool {
        other.t < self.t
            || (other.t == self.t
                && (other.instance, other.geometry, other.triangle)
                    < (self.instance, self.geometry, self.triangle))
    }
}

/// A filter of candidate hits: `true` accepts the hit, `false` rejects it and the ray goes on
/// (alpha-tested foliage, shadow rays through glass). Called from any thread.
pub type HitFilter<'a> = dyn Fn(&SceneHit) -> bool + Sync + 'a;

/// How a scene query runs: which instances the ray sees, and which hits it accepts.
///
/// ```
/// use kdbeam::scene::world::{Query, SceneHit};
/// let opaque = |h: &SceneHit| h.u + h.v < 0.5;
/// let q = Query { mask: 0b10, filter: Some(&opaque) };
/// assert_eq!(Query::default().mask, u32::MAX);
/// # let _ = q;
/// ```
#[derive(Clone, Copy)]
pub struct Query<'f> {
    /// The ray's mask: an instance is seen when `instance mask & mask != 0`. Meshes traced as
    /// they are have the mask `u32::MAX`, so every non-zero mask sees them.
    pub mask: u32,
    /// Hits this rejects are ignored: a closest-hit query returns the closest accepted hit, an
    /// any-hit query stops at the first accepted one. A rejected hit never shortens the ray.
    pub filter: Option<&'f HitFilter<'f>>,
}

impl Default for Query<'_> {
    /// Every instance, every hit.
    fn default() -> Self {
        Query {
            mask: u32::MAX,
            filter: None,
        }
    }
}

impl std::fmt::Debug for Query<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Query")
            .field("mask", &format_args!("{:#x}", self.mask))
            .field("filter", &self.filter.is_some())
            .finish()
    }
}
