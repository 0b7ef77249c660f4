//! Split events (Wald & Havran 2006, §4.2): where a triangle's clipped box starts, ends, or lies
//! flat on one axis, packed into one `u64` so that sorting integers sorts events.
//!
//! Layout, high to low: 32 bits of order-preserving position key, then the kind
//! ([`END`] < [`PLANAR`] < [`START`]). Integer order is therefore (position, kind): the order the
//! sweep needs, in which at one position all ends come before the planar events, and those
//! before all starts. Which triangle an event belongs to is not needed: the sweep only counts.

use kdbeam_kernels::Aabb;

/// A packed split event.
pub(super) type Event = u64;

/// The clipped box ends here (the triangle lies below or on this plane).
pub(super) const END: u32 = 0;
/// The clipped box has zero thickness here: the triangle lies in this plane.
pub(super) const PLANAR: u32 = 1;
/// The clipped box starts here (the triangle lies above or on this plane).
pub(super) const START: u32 = 2;

const SIGN: u32 = 1 << 31;

/// An order-preserving key of a finite `x`: `key(a) < key(b)` exactly when `a < b`.
///
/// `-0.0` is first turned into `+0.0` (`-0.0 + 0.0 = +0.0`), so that equal positions have equal
/// keys and the sweep groups them together.
#[inline(always)]
pub(super) fn key(x: f32) -> u32 {
    let bits = (x + 0.0).to_bits();
    if bits & SIGN != 0 {
        !bits
    } else {
        bits | SIGN
    }
}

/// The position whose [`key`] is `k`.
#[inline(always)]
pub(super) fn unkey(k: u32) -> f32 {
    f32::from_bits(if k & SIGN != 0 { k & !SIGN } else { !k })
}

/// The event of kind `kind` at position key `pos_key`.
#[inline(always)]
pub(super) fn event(pos_key: u32, kind: u32) -> Event {
    (u64::from(pos_key) << 32) | u64::from(kind)
}

/// The position key of an event.
#[inline(always)]
pub(super) fn pos_key(e: Event) -> u32 {
    (e >> 32) as u32
}

/// The kind of an event ([`END`], [`PLANAR`] or [`START`]).
#[inline(always)]
pub(super) fn kind(e: Event) -> u32 {
    (e & 3) as u32
}

/// Appends the events of box `b` to the three per-axis lists: a planar event on an axis where
/// the box is flat, a start and an end event elsewhere.
#[inline]
pub(super) fn push_box_events(lists: &mut [Vec<Event>; 3], b: &Aabb) {
    for (axis, list) in lists.iter_mut().enumerate() {
        let (lo, hi) = (b.min[axis], b.max[axis]);
        if lo == hi {
            list.push(event(key(lo), PLANAR));
        } else {
            list.push(event(key(lo), START));
            list.push(event(key(hi), END));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_preserve_order_and_round_trip() {
        let xs = [
            f32::MIN,
            -1e30,
            -1.5,
            -f32::MIN_POSITIVE,
            -0.0,
            0.0,
            1e-40,
            1.0,
            3e38,
            f32::MAX,
        ];
        for w in xs.windows(2) {
            assert!(key(w[0]) <= key(w[1]), "{} vs {}", w[0], w[1]);
            assert_eq!(key(w[0]) == key(w[1]), w[0] == w[1]);
        }
        for &x in &xs {
            assert_eq!(unkey(key(x)), x + 0.0);
        }
    }

    #[test]
    fn packed_fields_round_trip_and_sort_by_position_then_kind() {
        let e = event(key(2.5), PLANAR);
        assert_eq!((unkey(pos_key(e)), kind(e)), (2.5, PLANAR));
        assert!(event(key(1.0), START) < event(key(2.0), END));
        assert!(event(key(1.0), END) < event(key(1.0), PLANAR));
        assert!(event(key(1.0), PLANAR) < event(key(1.0), START));
    }
}
