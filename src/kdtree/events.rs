//! Split events (Wald & Havran 2006, §4.2): where a triangle's clipped box starts, ends, or lies
//! flat on one axis, packed into one `u64` so that sorting integers sorts events.
//!
//! Layout, high to low: 32 bits of order-preserving position key, 2 bits of kind
//! ([`END`] < [`PLANAR`] < [`START`]), 30 bits of the triangle's index local to its node.
//! Integer order is therefore (position, kind, index): the order the sweep needs, in which at
//! one position all ends come before the planar events, and those before all starts.

use kdbeam_kernels::Aabb;

/// A packed split event.
pub(super) type Event = u64;

/// The clipped box ends here (the triangle lies below or on this plane).
pub(super) const END: u32 = 0;
/// The clipped box has zero thickness here: the triangle lies in this plane.
pub(super) const PLANAR: u32 = 1;
/// The clipped box starts here (the triangle lies above or on this plane).
pub(super) const START: u32 = 2;

/// Largest node-local triangle index an event can hold.
pub(super) const MAX_LOCAL: u32 = (1 << 30) - 1;

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

/// The event of kind `kind` at position key `pos_key` for node-local triangle `local`.
#[inline(always)]
pub(super) fn event(pos_key: u32, kind: u32, local: u32) -> Event {
    (u64::from(pos_key) << 32) | (u64::from(kind) << 30) | u64::from(local)
}

/// The position key of an event.
#[inline(always)]
pub(super) fn pos_key(e: Event) -> u32 {
    (e >> 32) as u32
}

/// The kind of an event ([`END`], [`PLANAR`] or [`START`]).
#[inline(always)]
pub(super) fn kind(e: Event) -> u32 {
    ((e >> 30) & 3) as u32
}

/// The node-local triangle index of an event.
#[inline(always)]
pub(super) fn local(e: Event) -> u32 {
    (e as u32) & MAX_LOCAL
}

/// The same event for the triangle's index `local` in a child node.
#[inline(always)]
pub(super) fn relocated(e: Event, local: u32) -> Event {
    (e & !u64::from(MAX_LOCAL)) | u64::from(local)
}

/// Appends the events of box `b` of triangle `local` to the three per-axis lists: a planar event
/// on an axis where the box is flat, a start and an end event elsewhere.
#[inline]
pub(super) fn push_box_events(lists: &mut [Vec<Event>; 3], b: &Aabb, local: u32) {
    for (axis, list) in lists.iter_mut().enumerate() {
        let (lo, hi) = (b.min[axis], b.max[axis]);
        if lo == hi {
            list.push(event(key(lo), PLANAR, local));
        } else {
            list.push(event(key(lo), START, local));
            list.push(event(key(hi), END, local));
        }
    }
}

/// Sorts `extra` and merges it into the already sorted `list`, in place, from the back (no
/// third buffer); `extra` is left empty.
///
/// `list` need only be sorted by (position, kind): comparing whole keys respects that order, so
/// the result is sorted by (position, kind) as well.
pub(super) fn merge_into(list: &mut Vec<Event>, extra: &mut Vec<Event>) {
    if extra.is_empty() {
        return;
    }
    extra.sort_unstable();
    let (mut i, mut j) = (list.len(), extra.len());
    list.resize(i + j, 0);
    let mut w = list.len();
    while j > 0 {
        w -= 1;
        if i > 0 && list[i - 1] > extra[j - 1] {
            i -= 1;
            list[w] = list[i];
        } else {
            j -= 1;
            list[w] = extra[j];
        }
    }
    extra.clear();
}

/// The box spanned by the events of a non-empty node, one sorted list per axis: per axis, the
/// first event's position to the last one's. Empty if a list is empty.
pub(super) fn span(lists: &[Vec<Event>; 3]) -> Aabb {
    let mut b = Aabb::EMPTY;
    for (axis, list) in lists.iter().enumerate() {
        if let (Some(&first), Some(&last)) = (list.first(), list.last()) {
            b.min[axis] = unkey(pos_key(first));
            b.max[axis] = unkey(pos_key(last));
        }
    }
    b
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
        let e = event(key(2.5), PLANAR, MAX_LOCAL);
        assert_eq!(
            (unkey(pos_key(e)), kind(e), local(e)),
            (2.5, PLANAR, MAX_LOCAL)
        );
        assert_eq!(local(relocated(e, 7)), 7);
        assert!(event(key(1.0), START, 0) < event(key(2.0), END, 5));
        assert!(event(key(1.0), END, 9) < event(key(1.0), PLANAR, 0));
        assert!(event(key(1.0), PLANAR, 9) < event(key(1.0), START, 0));
    }

    #[test]
    fn merge_keeps_order() {
        let mut list: Vec<Event> = [1u64, 4, 4, 9].iter().map(|&x| x << 32).collect();
        let mut extra: Vec<Event> = [10u64, 0, 4, 5].iter().map(|&x| x << 32).collect();
        merge_into(&mut list, &mut extra);
        let got: Vec<u64> = list.iter().map(|&e| e >> 32).collect();
        assert_eq!(got, [0, 1, 4, 4, 4, 5, 9, 10]);
        assert!(extra.is_empty());
    }
}
