//! The exact search of small nodes: every face of their boxes as a candidate plane, with exact
//! counts, by counting in SIMD lanes or by Wald & Havran's sweep of the sorted events.

use glam::{BVec3A, Vec3A};
use kdbeam_kernels::lanes::{Dispatch, MAX_WIDTH};
use kdbeam_kernels::split_planes::{count_planes, AxisPlanes};
use kdbeam_kernels::{Aabb, LaneTask, Lanes};

use super::cost::{Candidates, Split};
use crate::kdtree::events::{key, kind, pos_key, unkey, Event, END, PLANAR, START};
use crate::kdtree::refs::Ref;
#[cfg(doc)]
use crate::kdtree::BuildParams;

/// Exact searches of nodes of at most this many triangles count their planes in SIMD lanes
/// ([`ExactPlanes::count`]), `O(n²)` but branch-free; larger ones (when
/// [`BuildParams::exact_search_max`] is raised above it) sort and sweep their events. Up to
/// this size counting is no slower than the sweep.
pub(crate) const COUNTED_SEARCH_MAX: usize = 128;

/// Room for the planes of a counted search: a power of two, so that a mask keeps indices in
/// range.
const COUNTED_PLANES: usize = 2 * COUNTED_SEARCH_MAX;
const _: () = assert!(COUNTED_PLANES.is_power_of_two());

/// A small node's candidate planes with exact counts: per axis, every face of its boxes
/// strictly inside the cell, with the boxes below, above and in it. Filled by counting each
/// plane against each box in SIMD lanes ([`ExactPlanes::count`],
/// [`kdbeam_kernels::split_planes`]) or by Wald & Havran's sweep of the sorted events
/// ([`ExactPlanes::sweep`]); either way the same planes and counts, kept across the node's
/// empty-space cuts, which change its cell, not its triangles. The sweep lists a position
/// once; the count once per box face below [`DEDUP_MIN`] triangles, and from there on mostly
/// once (a hash collision can leave a repeat in, with the same counts: harmless).
#[derive(Default)]
pub(crate) struct ExactPlanes {
    axes: [AxisCounts; 3],
    seen: SeenPositions,
}

/// Counted searches of at least this many triangles drop repeated positions
/// ([`ExactPlanes::fill`]). Smaller nodes list few planes per axis, which the repeats seldom
/// push past a multiple of [`MAX_WIDTH`] lanes, so the table's reset and lookups cost more
/// than they spare.
const DEDUP_MIN: usize = 16;

/// Per axis, a direct-mapped table of the positions [`ExactPlanes::fill`] has met in a node,
/// as f32; an empty slot holds [`UNSEEN`]. Allocated at the first call that needs it.
#[derive(Default)]
struct SeenPositions(Option<Box<[[f32; COUNTED_PLANES]; 3]>>);

/// An empty slot of [`SeenPositions`]: a NaN, equal to no position.
const UNSEEN: f32 = f32::NAN;

/// One axis of [`ExactPlanes`]. The buffers only grow; the planes are their first `len`
/// entries.
#[derive(Default)]
struct AxisCounts {
    /// Is some box flat on this axis?
    flat: bool,
    /// The number of planes, then NaN up to a multiple of [`MAX_WIDTH`] lanes.
    len: usize,
    pos: Vec<f32>,
    below: Vec<f32>,
    above: Vec<f32>,
    planar: Vec<f32>,
}

impl ExactPlanes {
    /// Replaces the contents with the planes of the boxes of `refs` strictly inside `cell`,
    /// counted in the lanes of `dispatch`'s ISA. (The empty-space cuts only shrink the cell, so no plane
    /// outside it can come back.)
    ///
    /// # Panics
    /// If `refs` holds more than [`COUNTED_SEARCH_MAX`] references.
    #[inline]
    pub fn count(&mut self, dispatch: Dispatch, refs: &[Ref], cell: &Aabb) {
        self.fill(refs, cell);
        dispatch.run(Count { planes: self, refs });
    }

    /// Takes the planes of the boxes of `refs` (at most [`COUNTED_SEARCH_MAX`]) strictly inside
    /// `cell`: the three axes in one pass, without branches on the data (which planes lie
    /// inside is as good as random). From [`DEDUP_MIN`] boxes on, a position already listed on
    /// its axis is mostly left out.
    ///
    /// Why: a mesh's triangles share vertices, so neighbouring boxes share faces (in a real
    /// mesh many of the positions listed on an axis are repeats), and each plane listed is counted against every box, then costed once per
    /// [`CostModel::best_split`]. Leaving a repeat out changes no split: equal positions have
    /// equal counts, hence equal costs, and are one plane to the cheapest plane's ties, which
    /// go to the lowest position; the first listed stays.
    ///
    /// How: per axis, a table of 2–4 slots per box ([`SeenPositions`]; emptied at each call)
    /// indexed by a Fibonacci hash of the position's bits. A position equal to its slot's is a
    /// repeat; each position then takes its slot. The slot's position came earlier on the axis,
    /// and is listed or (by induction) repeats one listed, so the first of equal positions is
    /// always listed, and the ones listed keep their order. A collision only evicts a position,
    /// so a later repeat of it is listed again. Compared as f32, so −0.0 repeats +0.0: the same
    /// plane, with the same counts.
    fn fill(&mut self, refs: &[Ref], cell: &Aabb) {
        // A loop each, so that small nodes pay nothing per face for the table.
        if refs.len() < DEDUP_MIN {
            self.fill_with::<false>(refs, cell);
        } else {
            self.fill_with::<true>(refs, cell);
        }
    }

    /// [`ExactPlanes::fill`], leaving repeated positions out when `DEDUP`.
    #[inline(always)]
    fn fill_with<const DEDUP: bool>(&mut self, refs: &[Ref], cell: &Aabb) {
        assert!(refs.len() <= COUNTED_SEARCH_MAX);
        let (cell_lo, cell_hi) = (Vec3A::from(cell.min), Vec3A::from(cell.max));
        let [seen_x, seen_y, seen_z] = &mut **self
            .seen
            .0
            .get_or_insert_with(|| Box::new([[UNSEEN; COUNTED_PLANES]; 3]));
        // Slots used: a power of two, from 2 · refs.len() (few collisions for a small table)
        // up to `COUNTED_PLANES`, so `% COUNTED_PLANES` never wraps a slot, and spares the
        // bounds checks.
        let shift = if DEDUP {
            let slots = (2 * refs.len()).next_power_of_two();
            for seen in [&mut *seen_x, &mut *seen_y, &mut *seen_z] {
                seen[..slots].fill(UNSEEN);
            }
            32 - slots.trailing_zeros()
        } else {
            0
        };
        // The top bits of the bits times 2³² / φ (Knuth's multiplicative hashing).
        let slot =
            |p: f32| (p.to_bits().wrapping_mul(0x9e37_79b9) >> shift) as usize % COUNTED_PLANES;
        // Which of the axes `p` is a plane to list on: strictly inside the cell, and when
        // `DEDUP`, not a repeat.
        let mut listed = |p: Vec3A| {
            let inside = p.cmpgt(cell_lo) & p.cmplt(cell_hi);
            if !DEDUP {
                return inside.bitmask() as usize;
            }
            let s = [slot(p.x), slot(p.y), slot(p.z)];
            let seen = Vec3A::new(seen_x[s[0]], seen_y[s[1]], seen_z[s[2]]);
            (seen_x[s[0]], seen_y[s[1]], seen_z[s[2]]) = (p.x, p.y, p.z);
            (inside & p.cmpne(seen)).bitmask() as usize
        };
        let (mut len, mut flat) = ([0; 3], BVec3A::FALSE);
        // The `k`-th plane written goes at an index of at most `k`, below `2 · refs.len()`,
        // which is at most `COUNTED_PLANES`: the mask that spares the bounds checks never wraps.
        let [x, y, z] = &mut self.axes;
        let mut pos = [x.counted_room(), y.counted_room(), z.counted_room()];
        for r in refs {
            let (lo, hi) = (r.lo(), r.hi());
            flat |= lo.cmpeq(hi);
            let lo_listed = listed(lo);
            let hi_listed = listed(hi);
            for (axis, (pos, len)) in pos.iter_mut().zip(&mut len).enumerate() {
                pos[*len % COUNTED_PLANES] = lo[axis];
                *len += (lo_listed >> axis) & 1;
                pos[*len % COUNTED_PLANES] = hi[axis];
                *len += (hi_listed >> axis) & 1;
            }
        }
        for (axis, (a, len)) in self.axes.iter_mut().zip(len).enumerate() {
            a.flat = flat.test(axis);
            a.pad(len);
        }
    }

    /// Replaces the contents with the planes of a node of `n` triangles with sorted per-axis
    /// `events`, at positions strictly inside `cell`.
    ///
    /// One sweep per axis (Algorithm 4): at each distinct position p, with p⁻, p|, p⁺ the
    /// numbers of end, planar and start events there, `N_above −= p⁻ + p|`, the plane is
    /// recorded, then `N_below += p⁺ + p|`. Written as one pass that records where the position
    /// changes, with the counts updated without branches on the event kind.
    #[inline]
    pub fn sweep(&mut self, events: &[Vec<Event>; 3], n: usize, cell: &Aabb) {
        for (axis, (list, out)) in events.iter().zip(&mut self.axes).enumerate() {
            out.make_room(list.len());
            let (lo_key, hi_key) = (key(cell.min[axis]), key(cell.max[axis]));
            let (mut below, mut above) = (0u32, n as u32);
            let (mut planar, mut joining_below) = (0u32, 0u32);
            let (mut len, mut flat) = (0, false);
            for (i, &e) in list.iter().enumerate() {
                let k = kind(e);
                above -= u32::from(k != START);
                planar += u32::from(k == PLANAR);
                joining_below += u32::from(k != END);
                let here = pos_key(e);
                let next = list.get(i + 1).map_or(u32::MAX, |&e| pos_key(e));
                if next == here {
                    continue;
                }
                if here > lo_key && here < hi_key {
                    out.pos[len] = unkey(here);
                    out.below[len] = below as f32;
                    out.above[len] = above as f32;
                    out.planar[len] = planar as f32;
                    flat |= planar != 0;
                    len += 1;
                }
                below += joining_below;
                joining_below = 0;
                planar = 0;
            }
            out.flat = flat;
            out.pad(len);
        }
    }
}

impl ExactPlanes {
    /// Plane `index` of `axis` as a split, its planar boxes below when `planar_below`, its cost
    /// left at 0.
    #[inline(always)]
    pub(super) fn split(&self, axis: usize, index: usize, planar_below: bool) -> Split {
        let counts = &self.axes[axis];
        let planar = counts.planar[index] as u32;
        let (pb, pa) = if planar_below {
            (planar, 0)
        } else {
            (0, planar)
        };
        Split {
            axis,
            pos_key: key(counts.pos[index]),
            planar_below,
            cost: 0.0,
            below_count: counts.below[index] as u32 + pb,
            above_count: counts.above[index] as u32 + pa,
        }
    }
}

impl Candidates for ExactPlanes {
    #[inline(always)]
    fn planes(&self, axis: usize) -> AxisPlanes<'_> {
        let a = &self.axes[axis];
        let len = a.len;
        AxisPlanes {
            pos: &a.pos[..len],
            below: &a.below[..len],
            above: &a.above[..len],
            planar: a.flat.then(|| &a.planar[..len]),
        }
    }
}

impl AxisCounts {
    /// Grows the buffers to hold `planes` planes and their padding, and the [`MAX_WIDTH`] NaNs
    /// [`AxisCounts::pad`] writes.
    fn make_room(&mut self, planes: usize) {
        let room = planes.next_multiple_of(MAX_WIDTH) + MAX_WIDTH;
        if self.pos.len() < room {
            for list in [
                &mut self.pos,
                &mut self.below,
                &mut self.above,
                &mut self.planar,
            ] {
                list.resize(room, 0.0);
            }
        }
    }

    /// Grows the buffers to hold the planes of a counted search; returns its positions. (A
    /// method, not a closure for `array::map`, which would stay out of line.)
    #[inline(always)]
    fn counted_room(&mut self) -> &mut [f32; COUNTED_PLANES] {
        self.make_room(COUNTED_PLANES);
        <&mut [f32; COUNTED_PLANES]>::try_from(&mut self.pos[..COUNTED_PLANES]).unwrap()
    }

    /// Ends the planes at `len`, padded with NaN positions to a multiple of [`MAX_WIDTH`] lanes.
    fn pad(&mut self, len: usize) {
        self.len = len.next_multiple_of(MAX_WIDTH);
        // Always a whole vector, in a store or two: a variable count, in a loop, mispredicted
        // its exit.
        self.pos[len..len + MAX_WIDTH].fill(f32::NAN);
    }
}

/// [`ExactPlanes::count`]'s kernel calls, in one ISA entry point.
struct Count<'a> {
    planes: &'a mut ExactPlanes,
    refs: &'a [Ref],
}

impl LaneTask for Count<'_> {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        for (axis, c) in self.planes.axes.iter_mut().enumerate() {
            let len = c.len;
            count_planes(
                l,
                self.refs.iter().map(|r| r.span(axis)),
                c.flat,
                &c.pos[..len],
                &mut c.below[..len],
                &mut c.above[..len],
                &mut c.planar[..len],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::events::push_box_events;
    use crate::kdtree::sah::boxes_x;
    use kdbeam_kernels::Vec3;

    #[test]
    fn the_sweep_counts_triangles_reaching_each_side_and_lying_in_the_plane() {
        // On x: [0, 1], [1, 2] and one flat at 1, in a cell [-1, 3] (y and z: [0, 1], the
        // cell's own faces, so no candidate there).
        let boxes = boxes_x(&[(0.0, 1.0), (1.0, 2.0), (1.0, 1.0)]);
        let mut events: [Vec<Event>; 3] = Default::default();
        for b in &boxes {
            push_box_events(&mut events, b);
        }
        for list in &mut events {
            list.sort_unstable();
        }
        let cell = Aabb::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0));
        let mut planes = ExactPlanes::default();
        planes.sweep(&events, 3, &cell);
        let listed = |a: &AxisCounts| -> Vec<_> {
            let real = a.pos[..a.len].iter().take_while(|p| !p.is_nan()).count();
            (0..real)
                .map(|i| (a.pos[i], a.below[i], a.above[i], a.planar[i]))
                .collect()
        };
        let x = &planes.axes[0];
        assert_eq!(
            listed(x),
            [
                (0.0, 0.0, 3.0, 0.0),
                (1.0, 1.0, 1.0, 1.0),
                (2.0, 3.0, 0.0, 0.0)
            ]
        );
        assert!(x.flat && x.pos[3..x.len].iter().all(|p| p.is_nan()));
        assert!(listed(&planes.axes[1]).is_empty() && listed(&planes.axes[2]).is_empty());
    }

    #[test]
    fn the_count_lists_each_inside_face_once_with_the_sweeps_counts() {
        // Boxes sharing faces, as a mesh's do, some flat on z; per axis, the listed planes
        // (sorted) with their counts must be the sweep's, each position once from DEDUP_MIN
        // boxes on (no two of these positions collide in the table), and at least once below.
        let f = |k: usize| 0.1 + 0.3 * k as f32;
        let cell = Aabb::new(Vec3::new(f(1), -1.0, -1.0), Vec3::new(f(6), 10.0, 10.0));
        for n in [DEDUP_MIN - 5, DEDUP_MIN, 40] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|i| {
                    let lo = Vec3::new(f(i % 7), f(i % 4), f(i % 3));
                    let hi = Vec3::new(
                        f(i % 7 + 1),
                        f(i % 4 + 2),
                        f(i % 3 + usize::from(i % 5 != 0)),
                    );
                    Aabb::new(lo, hi)
                })
                .collect();
            let refs: Vec<Ref> = boxes
                .iter()
                .zip(0..)
                .map(|(b, id)| Ref::new(id, b))
                .collect();
            let mut events: [Vec<Event>; 3] = Default::default();
            for b in &boxes {
                push_box_events(&mut events, b);
            }
            for list in &mut events {
                list.sort_unstable();
            }
            let mut swept = ExactPlanes::default();
            swept.sweep(&events, n, &cell);
            let listed = |a: &AxisCounts| -> Vec<_> {
                let mut planes: Vec<_> = (0..a.len)
                    .filter(|&i| !a.pos[i].is_nan())
                    .map(|i| (a.pos[i], a.below[i], a.above[i], a.planar[i]))
                    .collect();
                planes.sort_by(|p, q| p.0.total_cmp(&q.0));
                planes
            };
            for dispatch in Dispatch::available() {
                let mut counted = ExactPlanes::default();
                counted.count(dispatch, &refs, &cell);
                for axis in 0..3 {
                    let (mut got, want) = (listed(&counted.axes[axis]), listed(&swept.axes[axis]));
                    assert!(want.len() >= 3, "{n}, axis {axis}");
                    if n >= DEDUP_MIN {
                        assert_eq!(got, want, "{dispatch}, {n} boxes, axis {axis}");
                    } else {
                        assert!(
                            got.len() > want.len(),
                            "{n}: repeats are listed below DEDUP_MIN"
                        );
                        got.dedup();
                        assert_eq!(got, want, "{dispatch}, {n} boxes, axis {axis}");
                    }
                    assert_eq!(counted.axes[axis].flat, swept.axes[axis].flat);
                }
            }
        }
    }
}
