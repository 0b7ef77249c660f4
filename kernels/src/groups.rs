//! A packet of up to 64 rays as groups of `L::WIDTH` lanes: the bits of a packet mask that one
//! group holds, how many groups cover a packet, and a group's rays as vectors.
//!
//! Ray `i` of a packet is lane `i % WIDTH` of group `i / WIDTH`, and bit `i` of a `u64` packet
//! mask; every packet kernel and traversal walks its rays this way.

use crate::intersect::LaneRays;
use crate::{Lanes, RayPacket, MAX_PACKET_RAYS};

/// The lanes of group `g` in `mask`, as the low `L::WIDTH` bits. `g · L::WIDTH` must be below 64
/// (a group of the packet).
#[inline(always)]
#[must_use]
pub fn group_bits<L: Lanes>(mask: u64, g: usize) -> u32 {
    let lanes = if L::WIDTH >= 64 {
        u64::MAX
    } else {
        (1u64 << L::WIDTH) - 1
    };
    ((mask >> (g * L::WIDTH)) & lanes) as u32
}

/// The index of the lowest group of lanes that holds a bit of `rest`, whose bits it clears from
/// `rest`. `rest` must not be 0.
///
/// `while rest != 0 { let g = take_group::<L>(&mut rest); … }` visits the groups of a mask that
/// hold a ray, lowest first, at a cost per occupied group rather than per group of the packet:
/// deep in a tree, and in the rays a packet brings into an instance, most groups are empty.
#[inline(always)]
pub fn take_group<L: Lanes>(rest: &mut u64) -> usize {
    let g = rest.trailing_zeros() as usize / L::WIDTH;
    let lanes = if L::WIDTH >= 64 {
        u64::MAX
    } else {
        (1u64 << L::WIDTH) - 1
    };
    *rest &= !(lanes << (g * L::WIDTH));
    g
}

/// Groups of `L::WIDTH` lanes that cover `len` rays.
#[inline(always)]
#[must_use]
pub fn group_count<L: Lanes>(len: usize) -> usize {
    len.div_ceil(L::WIDTH)
}

/// Lanes `b..b + L::WIDTH` of three per-axis columns (origins, directions or reciprocals).
/// Panics if `b + L::WIDTH > 64`.
#[inline(always)]
#[must_use]
pub fn load_axes<L: Lanes>(l: L, columns: &[[f32; MAX_PACKET_RAYS]; 3], b: usize) -> [L::F32; 3] {
    [
        l.load(&columns[0][b..]),
        l.load(&columns[1][b..]),
        l.load(&columns[2][b..]),
    ]
}

/// The rays of group `g` of `p` (origins and directions). Panics if the group lies past the
/// packet's 64 lanes.
#[inline(always)]
#[must_use]
pub fn lane_rays<L: Lanes>(l: L, p: &RayPacket, g: usize) -> LaneRays<L> {
    let b = g * L::WIDTH;
    LaneRays::new(load_axes(l, &p.origin, b), load_axes(l, &p.direction, b))
}
