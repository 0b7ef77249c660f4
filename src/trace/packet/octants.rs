//! Which rays of a packet can be traced, and their split by octant of direction signs.

use kdbeam_kernels::groups::{group_count, lane_rays};
use kdbeam_kernels::{LaneF32, LaneMask, Lanes, RayPacket};

/// Rays of `active` that can be traced (see [`is_traceable`](super::single::is_traceable)), a group of lanes at a time:
/// finite origin and direction (`|x| < inf`, false for NaN), a direction that is not zero on
/// every axis, and `tmin <= tmax` (false when either is NaN).
#[inline(always)]
pub(crate) fn traceable_mask<L: Lanes>(l: L, p: &RayPacket, active: u64) -> u64 {
    let (inf, zero) = (l.splat(f32::INFINITY), l.splat(0.0));
    let mut traceable = 0u64;
    for g in 0..group_count::<L>(p.len()) {
        let b = g * L::WIDTH;
        let rays = lane_rays(l, p, g);
        // No closures here: inside the ISA's `#[target_feature]` entry they are not inlined.
        let mut finite = l.load(&p.tmin[b..]).le(l.load(&p.tmax[b..]));
        let mut zero_direction = !l.mask_from_bits(0);
        for a in 0..3 {
            finite = finite & rays.origin[a].abs().lt(inf) & rays.direction[a].abs().lt(inf);
            zero_direction = zero_direction & rays.direction[a].eq(zero);
        }
        traceable |= u64::from(finite.and_not(zero_direction).bits()) << b;
    }
    traceable & active & p.full_mask()
}

/// The rays of `mask` sorted by the sign bits of their direction: one mask per octant, bit `a`
/// of the octant set for a sign bit on axis `a` (`-0.0` counts as negative, as its reciprocal
/// is `-inf`).
///
/// The sign bits are gathered into one packet mask per axis first, so that the split costs
/// three sign extractions per group and a few word operations per octant, whatever the number
/// of groups: a camera packet, whose rays all share one octant, pays it on every trace.
#[inline(always)]
pub(crate) fn octant_masks<L: Lanes>(l: L, p: &RayPacket, mask: u64) -> [u64; 8] {
    let mut negative = [0u64; 3];
    for g in 0..group_count::<L>(p.len()) {
        let b = g * L::WIDTH;
        for (a, axis) in negative.iter_mut().enumerate() {
            *axis |= u64::from(l.load(&p.direction[a][b..]).sign_bits()) << b;
        }
    }
    let mut octants = [0u64; 8];
    for (o, octant) in octants.iter_mut().enumerate() {
        let mut lanes = mask;
        for (a, &sign) in negative.iter().enumerate() {
            lanes &= if o >> a & 1 != 0 { sign } else { !sign };
        }
        *octant = lanes;
    }
    octants
}
