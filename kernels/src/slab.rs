//! Ray and packet × box clipping by slabs (Kay & Kajiya), robust to zero direction components.
//!
//! Callers pass `inv_direction = 1 / direction` per component (`Vec3::recip`, or `l.splat(1.0) / d` per
//! lane): a zero component gives `±inf`, which is exactly what this code expects, so no "safe
//! reciprocal" is needed or wanted (replacing `1/0` by a large finite number makes rays that
//! start just outside a slab enter it).
//!
//! Per axis, the plane the ray enters through is `min` when `inv_direction >= 0` and `max` when
//! `inv_direction < 0` (`inv_direction = ±inf` for `d = ±0`, so the sign of the zero picks the planes), and
//! `t_enter = (enter − o)·inv`, `t_exit = (exit − o)·inv`. Choosing the planes by sign, instead of
//! taking `min(t0, t1)`/`max(t0, t1)`, keeps entry and exit apart even when one of them is NaN.
//!
//! **Zero components.** With `d = ±0` and the origin strictly inside the slab, the products are
//! `−inf` (enter) and `+inf` (exit): no constraint; strictly outside, one is `+inf` or `−inf` and
//! the interval is empty. With the origin **exactly on** a plane, `0·inf = NaN`: the ray lies in
//! the plane, which the closed box contains, so that plane must constrain nothing. The running
//! interval is therefore updated as `tnear = t_enter.max(tnear)` and `tfar = t_exit.min(tfar)`
//! with the new value as the **first** operand: [`LaneF32::min`]/[`LaneF32::max`] (x86
//! `minps`/`maxps`) return their second operand when either is NaN, so a NaN plane distance is
//! discarded. The same rule makes an axis whose origin or `inv_direction` component is NaN constrain
//! nothing (such a ray must be rejected by the triangle test, which every intersector does);
//! a NaN `tmin` or `tmax` gives no interval.
//!
//! [`ray_box`] and [`slab_lanes`] share this code, so every lane of every ISA computes exactly
//! what the single-ray form does.

use glam::{Vec3, Vec3A};

use crate::aabb::Aabb;
use crate::intersect::splat3;
use crate::lanes::{LaneF32, Lanes};
use crate::ray::Ray;

/// Clips `[near, far]` by the three slabs of `[lo, hi]` (see the module documentation).
#[inline(always)]
fn clip<F: LaneF32>(
    origin: &[F; 3],
    inv_direction: &[F; 3],
    [lo, hi]: [[F; 3]; 2],
    zero: F,
    near: F,
    far: F,
) -> (F, F) {
    let (mut enter, mut exit) = (lo, hi);
    for k in 0..3 {
        let backwards = inv_direction[k].lt(zero);
        enter[k] = F::select(backwards, hi[k], lo[k]);
        exit[k] = F::select(backwards, lo[k], hi[k]);
    }
    clip_planes(origin, inv_direction, enter, exit, near, far)
}

/// Clips `[near, far]` by three slabs given as the planes the ray enters and leaves them by:
/// per axis `k`, `enter[k]` is the box's `min` where `inv_direction[k] >= 0` (`+0` included)
/// and its `max` where it is negative (`−0` included), `exit[k]` the other.
///
/// This is the module's slab code after the choice of planes, for a caller that knows the
/// signs already: one ray, its signs fixed, against a vector of boxes. It returns `(tnear,
/// tfar)`; the boxes with `tnear <= tfar` are entered, with the module's rules for zero
/// components, an origin on a plane and NaN. A lane whose box is empty as `min = +inf`,
/// `max = −inf` gets `tnear = +inf` from any finite origin, so it is never entered.
#[inline(always)]
#[must_use]
pub fn clip_planes<F: LaneF32>(
    origin: &[F; 3],
    inv_direction: &[F; 3],
    enter: [F; 3],
    exit: [F; 3],
    mut near: F,
    mut far: F,
) -> (F, F) {
    for k in 0..3 {
        near = ((enter[k] - origin[k]) * inv_direction[k]).max(near);
        far = ((exit[k] - origin[k]) * inv_direction[k]).min(far);
    }
    (near, far)
}

/// [`clip_planes`] with each plane's distance as one multiply-add, `plane·inv + offset`, for a
/// caller that widens the interval it gets: one operation off the chain of a box test.
///
/// `offset` is [`fused_offsets`] of the ray. Each distance then differs from the exact
/// `(plane − o)·inv` by at most about 2⁻²³·(|t| + |o·inv|): the rounding of the product `o·inv`
/// and of the sum, and on ISAs without FMA of the product `plane·inv` (at most `|t| + |o·inv|`
/// in size), where [`clip_planes`] differs by about 2⁻²³·|t|. A caller that widens each entry
/// and exit by more than that, relative to the largest finite `|o·inv|` of the ray, enters
/// every box the ray meets.
///
/// Zero components: the distance is either the one [`clip_planes`] computes (`±inf`) or NaN,
/// which, as there, leaves the axis unconstrained, so the result holds [`clip_planes`]'s
/// interval. The same NaN stands for an axis whose `o·inv` overflows ([`fused_offsets`]).
#[inline(always)]
#[must_use]
pub fn clip_planes_fused<F: LaneF32>(
    offset: &[F; 3],
    inv_direction: &[F; 3],
    enter: [F; 3],
    exit: [F; 3],
    mut near: F,
    mut far: F,
) -> (F, F) {
    for k in 0..3 {
        near = enter[k].mul_add(inv_direction[k], offset[k]).max(near);
        far = exit[k].mul_add(inv_direction[k], offset[k]).min(far);
    }
    (near, far)
}

/// The part of `[tmin, tmax]` over which `o + t·d` lies in the closed box `b`, in `f64` with the
/// true `1/d`: the reference the `f32` clips are checked against. `d = ±0` gives `±inf`
/// distances, and a NaN distance (`0·inf`, an origin on a plane the ray lies in) constrains
/// nothing; `None` when the interval is empty.
///
/// ```
/// use kdbeam_kernels::slab::exact_interval;
/// use kdbeam_kernels::{Aabb, Ray, Vec3};
///
/// let ray = Ray::new(Vec3::new(0.0, 0.5, 0.5), Vec3::new(3.0, 0.0, 0.0));
/// let unit = Aabb::new(Vec3::ZERO, Vec3::ONE);
/// assert_eq!(exact_interval(&ray, &unit), Some((0.0, 1.0 / 3.0)));
/// ```
#[must_use]
pub fn exact_interval(ray: &Ray, b: &Aabb) -> Option<(f64, f64)> {
    let (mut n, mut f) = (f64::from(ray.tmin), f64::from(ray.tmax));
    for k in 0..3 {
        let (o, inv) = (f64::from(ray.origin[k]), 1.0 / f64::from(ray.direction[k]));
        let (lo, hi) = (f64::from(b.min[k]), f64::from(b.max[k]));
        let (enter, exit) = if inv < 0.0 { (hi, lo) } else { (lo, hi) };
        let (te, tx) = ((enter - o) * inv, (exit - o) * inv);
        if !te.is_nan() {
            n = n.max(te);
        }
        if !tx.is_nan() {
            f = f.min(tx);
        }
    }
    (n <= f).then_some((n, f))
}

/// The offsets of [`clip_planes_fused`]: `−o·inv` per axis, NaN where `inv` is finite and the
/// product overflows (an origin far out along an axis the ray barely moves on), which leaves
/// that axis unconstrained rather than closing every box with `∓inf`.
///
/// ```
/// use kdbeam_kernels::slab::fused_offsets;
/// use kdbeam_kernels::Vec3;
///
/// let o = fused_offsets(Vec3::new(1.0, 2.0, 1e30), Vec3::new(2.0, f32::INFINITY, 1e10));
/// assert_eq!(&o[..2], &[-2.0, f32::NEG_INFINITY]);
/// assert!(o[2].is_nan());
/// ```
#[inline(always)]
#[must_use]
pub fn fused_offsets(origin: Vec3, inv_direction: Vec3) -> [f32; 3] {
    let inv = Vec3A::from(inv_direction);
    let p = Vec3A::from(origin) * inv;
    let kept = p.is_finite_mask() | !inv.is_finite_mask();
    Vec3A::select(kept, -p, Vec3A::NAN).to_array()
}

/// The part `[tnear, tfar]` of `[tmin, tmax]` where the ray `origin + t·d` is inside the closed
/// box `b`, given `inv_direction = 1 / d` per component; `None` when it is empty.
///
/// Zero direction components (`inv_direction = ±inf`) are exact, including an origin on a face plane
/// (the ray then lies in the face: inside). An empty box ([`Aabb::EMPTY`]) gives `None` for any
/// direction without NaN or infinite components. NaN in
/// `tmin`/`tmax` gives `None`; NaN in an origin or `inv_direction` component leaves that axis
/// unconstrained.
#[inline(always)]
#[must_use]
pub fn ray_box(
    origin: Vec3,
    inv_direction: Vec3,
    tmin: f32,
    tmax: f32,
    b: &Aabb,
) -> Option<(f32, f32)> {
    let (near, far) = clip(
        &origin.to_array(),
        &inv_direction.to_array(),
        [b.min.to_array(), b.max.to_array()],
        0.0,
        tmin,
        tmax,
    );
    (near <= far).then_some((near, far))
}

/// [`ray_box`] for `WIDTH` rays with per-lane `[tmin, tmax]`: `(mask, tnear, tfar)`.
///
/// Lane `i` is set in the mask when [`ray_box`] returns `Some` for ray `i`, and then `tnear`,
/// `tfar` equal its result bit for bit; in the other lanes they are unspecified.
#[inline(always)]
pub fn slab_lanes<L: Lanes>(
    l: L,
    origin: &[L::F32; 3],
    inv_direction: &[L::F32; 3],
    tmin: L::F32,
    tmax: L::F32,
    b: &Aabb,
) -> (L::Mask, L::F32, L::F32) {
    let bounds = [splat3(l, b.min), splat3(l, b.max)];
    let (near, far) = clip(origin, inv_direction, bounds, l.splat(0.0), tmin, tmax);
    (near.le(far), near, far)
}
