//! "Perfect splits" (Wald & Havran 2006, §4.3; Havran 2000): the boxes of the parts of a
//! triangle in the two halves of a split cell, by Sutherland–Hodgman clipping of the triangle
//! against the cell's six planes and then against each side of the split plane. Only the faces
//! the triangle's vertex box crosses are clipped against, and the last step, against the split
//! plane, keeps only the span of the points it would make. A triangle inside the cell (about
//! half the calls in a build) skips the clip to the cell altogether: that clip would keep the
//! triangle as it is, since each vertex `v >= min` also has `v >= min - margin` in f64
//! (rounding is monotone and `min` is an f64, so the rounded `min - margin` is at most `min`),
//! and likewise at `max`; the split step then sees the very same vertices.
//!
//! The work is arranged to be cheap, with few branches on the data, in the common cases, with
//! the same f64 operations as that plain clip, and so the same boxes, bit for bit. The vertices a
//! clip keeps of a convex polygon are one run of neighbours: the clip is the two points where
//! the edges leaving and entering the run cross the plane, and the run, found from the bits of
//! the kept vertices ([`Run`]). The polygon lives in an array of a fixed size, one longer at each
//! face, a vertex repeated where a clip left fewer: a repeated vertex adds no point (its edge to
//! itself crosses nothing). The two parts of the split are computed side by side, in the lanes
//! of [`Parts`], and rounded four values at a time. A polygon whose kept vertices are not one
//! run (f64 rounding can make it slightly non-convex) or that crosses more than three faces
//! (rare) takes the plain clip, [`Clip::to_cell_in_general`].
//!
//! The clip runs in f64 against the cell grown by a tiny relative margin, and the result is
//! rounded outward to f32 and then clamped to the cell (clamping is exact). The f32 box therefore
//! contains the exact part of the triangle inside the cell and lies inside the cell: it may be a
//! little loose, never too tight. It is also clamped to the triangle's own vertex box (exact), so
//! a triangle flat on an axis stays exactly flat there.
//!
//! How loose: the grown cell takes in the part of the triangle within the margin of a face, and
//! along an edge that meets the face at a grazing angle (slope `s` = run along another axis over
//! rise across the face) that part reaches `margin · s` further. A slab of the margin's width is
//! what conservativeness costs: the crossings are only known to f64 rounding, and that rounding
//! is amplified by the same slope. Keeping the margin at f64 scale (2⁻⁴⁶ of the magnitude)
//! keeps `margin · s` below one f32 ulp of the magnitude for slopes up to 2²³ (a 2⁻⁴⁰ margin once
//! loosened a Sponza leaf by 3·10⁻⁵ along a wall edge of slope 2·10⁶).

use glam::{DVec2, Vec3A, Vec4, Vec4Swizzles};
use kdbeam_kernels::{Aabb, DVec3, Triangle, Vec3};

/// Vertices a clipped polygon may reach: a convex polygon gains at most one vertex per plane
/// (3 + 6); more than this means rounding made it non-convex, and we fall back to the box.
const MAX_POLYGON: usize = 12;

/// Margin, relative to the largest coordinate involved, by which the cell is grown before
/// clipping: well above the f64 rounding of six clips (each crossing is a convex combination
/// rounded a few times, 2^-53 each, so at most ~20 · 2^-53 in all), so that rounding in the clip
/// can only add, never lose, a sliver; and as small as that allows, since grazing edges amplify
/// it (module docs).
const MARGIN: f64 = 1.0 / (1u64 << 46) as f64;

/// The boxes of `tri ∩ below` and `tri ∩ above`, where `below` and `above` are the halves of
/// `cell` split at `position` on axis `AXIS` (`cell.min[AXIS] <= position <= cell.max[AXIS]`):
/// each conservative in f32 and inside its half, `None` when the triangle does not meet it.
///
/// The triangle is clipped once to the (grown) cell and the polygon then once more to each
/// side of the (grown) plane: the same half-spaces as clipping to each half, in another order.
/// A triangle touching a half only on its boundary gives a flat box on that boundary.
/// Degenerate triangles (segments, points) clip like any other polygon. Coordinates must be
/// finite (a [`Mesh`](crate::scene::Mesh)'s are).
pub(super) fn split_clipped_bounds<const AXIS: usize>(
    tri: &Triangle,
    cell: &Aabb,
    position: f32,
) -> [Option<Aabb>; 2] {
    let (mut below, mut above) = (*cell, *cell);
    below.max[AXIS] = position;
    above.min[AXIS] = position;
    let clip = Clip::new(tri, cell);
    let plane = f64::from(position);
    let planes = [plane + clip.margin, plane - clip.margin];
    let triangle = [tri.v0, tri.v1, tri.v2].map(DVec3::from);
    let spans = if clip.faces == 0 {
        // The clip to the cell would cut nothing off: the same steps on the triangle itself.
        Ok(split_spans::<AXIS, 3>(&triangle, planes))
    } else {
        clip.to_cell::<AXIS>(&triangle, cell, planes)
    };
    match spans {
        Ok(spans) => clip.rounded::<AXIS>(&spans, cell, position),
        Err(Cut::Overflow) => {
            let vertex_box = Aabb::new(clip.lo.into(), clip.hi.into());
            [below, above].map(|half| fallback(&vertex_box, &half))
        }
        // Empty (`to_cell` takes `General` to the general clip).
        Err(_) => [None, None],
    }
}

/// A triangle being clipped to a cell grown by the margin, in f64.
struct Clip {
    /// The least corner of the triangle's own box.
    lo: Vec3A,
    /// The greatest corner of the triangle's own box.
    hi: Vec3A,
    /// The margin: [`MARGIN`] times the largest coordinate of the triangle and the cell.
    margin: f64,
    /// The cell's faces the vertex box crosses, the others being skipped without looking at
    /// the triangle (clipped points lie in the vertex box but for f64 rounding, far smaller
    /// than the margin): bit `2·a` for the face at `min[a]`, bit `2·a + 1` for the one at
    /// `max[a]`, in the order they are clipped against. 0 when the triangle's box lies inside
    /// the cell, so that clipping to the grown cell cuts nothing off.
    faces: u32,
}

/// Why clipping to the cell left no polygon.
enum Cut {
    /// Nothing is left.
    Empty,
    /// Rounding made the polygon non-convex (it outgrew [`MAX_POLYGON`]).
    Overflow,
    /// Not for [`Clip::to_cell_in_runs`]: the kept vertices are not one run, or there are
    /// more than three faces; [`Clip::to_cell_in_general`] must clip.
    General,
}

/// The span `(min, max)` of part of a polygon; `(+∞, −∞)` when there is nothing in it.
type Span = (DVec3, DVec3);

/// A value for each part of the split: below (`x`), above (`y`).
type Parts = DVec2;

/// The spans of the parts of a polygon below and above the split plane, per coordinate; `+∞`
/// and `−∞` for a part with nothing in it.
struct SplitSpans {
    min: [Parts; 3],
    max: [Parts; 3],
}

impl From<[Span; 2]> for SplitSpans {
    fn from([below, above]: [Span; 2]) -> Self {
        let parts = |b: DVec3, a: DVec3| [0, 1, 2].map(|c| Parts::new(b[c], a[c]));
        SplitSpans {
            min: parts(below.0, above.0),
            max: parts(below.1, above.1),
        }
    }
}

impl Clip {
    /// `tri` about to be clipped to `cell`.
    fn new(tri: &Triangle, cell: &Aabb) -> Self {
        let [v0, v1, v2] = [tri.v0, tri.v1, tri.v2].map(Vec3A::from);
        let (lo, hi) = (v0.min(v1).min(v2), v0.max(v1).max(v2));
        let (cell_lo, cell_hi) = (Vec3A::from(cell.min), Vec3A::from(cell.max));
        // The largest |coordinate| of the vertices is that of their box's corners (exact).
        let magnitude = (lo.abs().max(hi.abs()))
            .max(cell_lo.abs().max(cell_hi.abs()))
            .max_element();
        let margin = f64::from(magnitude) * MARGIN;
        // Bit `a` of a mask to bit `2·a`.
        const SPREAD: [u32; 8] = [0b0, 0b1, 0b100, 0b101, 0b10000, 0b10001, 0b10100, 0b10101];
        let spread = |bits: u32| SPREAD[bits as usize & 7];
        let faces = spread(lo.cmplt(cell_lo).bitmask()) | spread(hi.cmpgt(cell_hi).bitmask()) << 1;
        Clip {
            lo,
            hi,
            margin,
            faces,
        }
    }

    /// The plane of face `face` (as in [`Clip::faces`]) of the grown `cell`: its axis, position,
    /// and whether the side above it is kept.
    fn face(&self, cell: &Aabb, face: u32) -> (usize, f64, bool) {
        let axis = (face / 2) as usize;
        if face & 1 == 0 {
            (axis, f64::from(cell.min[axis]) - self.margin, true)
        } else {
            (axis, f64::from(cell.max[axis]) + self.margin, false)
        }
    }

    /// The spans of `triangle` clipped to the grown `cell`, split by `planes` as in
    /// [`split_spans`].
    #[inline(always)]
    fn to_cell<const AXIS: usize>(
        &self,
        triangle: &[DVec3; 3],
        cell: &Aabb,
        planes: [f64; 2],
    ) -> Result<SplitSpans, Cut> {
        // Past three faces (rare), the runs would only find out late that they cannot go on.
        let without_lowest = |faces: u32| faces & faces.wrapping_sub(1);
        let spans = if without_lowest(without_lowest(without_lowest(self.faces))) == 0 {
            self.to_cell_in_runs::<AXIS>(triangle, cell, planes)
        } else {
            Err(Cut::General)
        };
        match spans {
            Err(Cut::General) => self.to_cell_in_general::<AXIS>(triangle, cell, planes),
            spans => spans,
        }
    }

    /// [`Clip::to_cell`] while the kept vertices are one run at every face, through at most
    /// three faces; else [`Cut::General`].
    ///
    /// Each face cuts a polygon of a fixed number of vertices, some of them repeated, into
    /// one more: the same points as one Sutherland–Hodgman step ([`cut`]).
    fn to_cell_in_runs<const AXIS: usize>(
        &self,
        triangle: &[DVec3; 3],
        cell: &Aabb,
        planes: [f64; 2],
    ) -> Result<SplitSpans, Cut> {
        let mut faces = self.faces;
        // The next face, and whether it is the last.
        let mut next = || {
            let face = faces.trailing_zeros();
            faces &= faces - 1;
            (face, faces == 0)
        };
        let m = self.margin;
        let (face, last) = next();
        let quad = cut_by::<3, 4>(triangle, face, cell, m)?;
        if last {
            return Ok(split_spans::<AXIS, 4>(&quad, planes));
        }
        let (face, last) = next();
        let pentagon = cut_by::<4, 5>(&quad, face, cell, m)?;
        if last {
            return Ok(split_spans::<AXIS, 5>(&pentagon, planes));
        }
        let (face, last) = next();
        let hexagon = cut_by::<5, 6>(&pentagon, face, cell, m)?;
        if last {
            return Ok(split_spans::<AXIS, 6>(&hexagon, planes));
        }
        Err(Cut::General)
    }

    /// [`Clip::to_cell`] for any polygon: Sutherland–Hodgman steps ([`clip_polygon`]) on a
    /// polygon of up to [`MAX_POLYGON`] vertices. Rare, so kept out of line.
    #[inline(never)]
    fn to_cell_in_general<const AXIS: usize>(
        &self,
        triangle: &[DVec3; 3],
        cell: &Aabb,
        planes: [f64; 2],
    ) -> Result<SplitSpans, Cut> {
        // The polygon in one buffer, the next step writing to the other.
        let mut buffers = [[DVec3::ZERO; MAX_POLYGON]; 2];
        buffers[0][..3].copy_from_slice(triangle);
        let (mut len, mut current) = (3, 0);
        let mut faces = self.faces;
        while faces != 0 {
            let (axis, plane, keep_above) = self.face(cell, faces.trailing_zeros());
            faces &= faces - 1;
            let [first, second] = &mut buffers;
            let (v, out) = if current == 0 {
                (&first[..len], second)
            } else {
                (&second[..len], first)
            };
            let cut = match axis {
                0 => clip_polygon::<0>(v, out, plane, keep_above),
                1 => clip_polygon::<1>(v, out, plane, keep_above),
                _ => clip_polygon::<2>(v, out, plane, keep_above),
            }?;
            if let Some(cut) = cut {
                (len, current) = (cut, 1 - current);
            }
        }
        let v = &buffers[current][..len];
        let mut d = [[0.0; MAX_POLYGON]; 2];
        for (i, &p) in v.iter().enumerate() {
            d[0][i] = inside::<AXIS>(p, planes[0], false);
            d[1][i] = inside::<AXIS>(p, planes[1], true);
        }
        Ok(SplitSpans::from([
            part_span::<AXIS>(v, &d[0][..len], planes[0]),
            part_span::<AXIS>(v, &d[1][..len], planes[1]),
        ]))
    }

    /// The f32 boxes of `spans` rounded outward by the margin, each within the triangle's own
    /// box and its half of the cell (split at `position` on `AXIS`); `None` if empty.
    #[inline(always)]
    fn rounded<const AXIS: usize>(
        &self,
        spans: &SplitSpans,
        cell: &Aabb,
        position: f32,
    ) -> [Option<Aabb>; 2] {
        let m = self.margin;
        let (u, w) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
        let (lo, hi) = (&spans.min, &spans.max);
        // Four lanes at a time, so that the rounding is vectorized: the minima off the axis,
        // the maxima, and along the axis the minima and (negated, to round down) the maxima.
        let down = |p: [f64; 4]| Vec4::from_array(p.map(|p| round_down(p - m)));
        let up = |p: [f64; 4]| Vec4::from_array(p.map(|p| round_up(p + m)));
        let mins = down([lo[u].x, lo[u].y, lo[w].x, lo[w].y]);
        let maxs = up([hi[u].x, hi[u].y, hi[w].x, hi[w].y]);
        let axial = Vec4::from_array(
            [
                lo[AXIS].x - m,
                lo[AXIS].y - m,
                -(hi[AXIS].x + m),
                -(hi[AXIS].y + m),
            ]
            .map(round_down),
        ) * Vec4::new(1.0, 1.0, -1.0, -1.0);
        // Clamped to the triangle's box ∩ the half, which takes over only where strictly
        // tighter: on a tie the rounded value stays, and with it its sign of zero (as in
        // `f32::max(rounded, bound)` and `min` on x86, which this replaces; no NaN reaches here).
        let exact_min = self.lo.max(cell.min.into());
        let exact_max = self.hi.min(cell.max.into());
        let mins = Vec4::new(exact_min[u], exact_min[u], exact_min[w], exact_min[w]).max(mins);
        let maxs = Vec4::new(exact_max[u], exact_max[u], exact_max[w], exact_max[w]).min(maxs);
        let (lo_axial, hi_axial) = (self.lo[AXIS], self.hi[AXIS]);
        let axial = Vec4::new(
            exact_min[AXIS],
            if lo_axial > position {
                lo_axial
            } else {
                position
            },
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        )
        .max(axial);
        let axial = Vec4::new(
            f32::INFINITY,
            f32::INFINITY,
            if hi_axial < position {
                hi_axial
            } else {
                position
            },
            exact_max[AXIS],
        )
        .min(axial);
        // Bits 0 and 2 (below) and 1 and 3 (above) off the axis, 0 and 1 along it.
        let empty = mins.cmpgt(maxs).bitmask() | axial.cmpgt(axial.zwxy()).bitmask() & 0b11;
        let corner = |along: f32, off: [f32; 2]| {
            let mut p = Vec3::ZERO;
            (p[AXIS], p[u], p[w]) = (along, off[0], off[1]);
            p
        };
        [
            (empty & 0b0101 == 0).then(|| {
                Aabb::new(
                    corner(axial.x, [mins.x, mins.z]),
                    corner(axial.z, [maxs.x, maxs.z]),
                )
            }),
            (empty & 0b1010 == 0).then(|| {
                Aabb::new(
                    corner(axial.y, [mins.y, mins.w]),
                    corner(axial.w, [maxs.y, maxs.w]),
                )
            }),
        ]
    }
}

/// The distance of `p` inside the half-space `p[AXIS] >= plane` (`keep_above`) or `<= plane`.
#[inline(always)]
fn inside<const AXIS: usize>(p: DVec3, plane: f64, keep_above: bool) -> f64 {
    if keep_above {
        p[AXIS] - plane
    } else {
        plane - p[AXIS]
    }
}

/// The bits of the vertices kept by a clip: those at a distance `d >= 0` inside it.
#[inline(always)]
fn kept(d: &[f64]) -> u32 {
    d.iter()
        .enumerate()
        .fold(0, |bits, (i, &d)| bits | u32::from(d >= 0.0) << i)
}

/// Where the vertices of a polygon kept by a clip lie, when they are one run of neighbours.
#[derive(Clone, Copy)]
struct Run {
    /// The first vertex of the run.
    first: usize,
    /// The vertex before the first (not kept).
    before: usize,
    /// The last vertex of the run.
    last: usize,
    /// The vertex after the last (not kept).
    after: usize,
}

impl Run {
    /// The run of the `n`-gon's vertices in `kept` (bit `i` for vertex `i`), or `None` if
    /// they are none, all, or more than one run (which only rounding in a clip can make).
    #[inline(always)]
    const fn of(kept: u32, n: usize) -> Option<Run> {
        let all = (1 << n) - 1;
        // Bit `i`: vertex `i − 1`, and `i + 1`, is kept.
        let previous = (kept << 1 | kept >> (n - 1)) & all;
        let next = (kept >> 1 | kept << (n - 1)) & all;
        let (starts, ends) = (kept & !previous, kept & !next);
        if starts == 0 || starts & (starts - 1) != 0 {
            return None;
        }
        let (first, last) = (
            starts.trailing_zeros() as usize,
            ends.trailing_zeros() as usize,
        );
        Some(Run {
            first,
            before: if first == 0 { n - 1 } else { first - 1 },
            last,
            after: if last == n - 1 { 0 } else { last + 1 },
        })
    }

    /// [`Run::of`] an `N`-gon, looked up.
    #[inline(always)]
    fn of_polygon<const N: usize>(kept: u32) -> Option<Run> {
        /// [`Run::of`] every `kept` of an `N`-gon (`SIZE = 2^N`).
        const fn table<const N: usize, const SIZE: usize>() -> [Option<Run>; SIZE] {
            let mut runs = [None; SIZE];
            let mut kept = 0;
            while kept < SIZE {
                runs[kept] = Run::of(kept as u32, N);
                kept += 1;
            }
            runs
        }
        const RUNS: [&[Option<Run>]; 7] = [
            &[],
            &[],
            &[],
            &table::<3, 8>(),
            &table::<4, 16>(),
            &table::<5, 32>(),
            &table::<6, 64>(),
        ];
        RUNS[N][kept as usize & ((1 << N) - 1)]
    }

    /// Where the edges leaving and entering the run cross the plane of the clip (at
    /// distances `d` inside it, on `AXIS`).
    #[inline(always)]
    fn crossings<const AXIS: usize>(&self, v: &[DVec3], d: &[f64], plane: f64) -> [DVec3; 2] {
        let Run {
            first,
            before,
            last,
            after,
        } = *self;
        [
            crossing::<AXIS>(v[last], v[after], d[last], d[after], plane),
            crossing::<AXIS>(v[before], v[first], d[before], d[first], plane),
        ]
    }
}

/// Where edge `a → b`, at distances `da` and `db` inside a clip plane (of opposite signs),
/// crosses it: a Sutherland–Hodgman point, with its `AXIS` coordinate set to `plane` exactly.
#[inline(always)]
fn crossing<const AXIS: usize>(a: DVec3, b: DVec3, da: f64, db: f64, plane: f64) -> DVec3 {
    let mut p = a + (b - a) * (da / (da - db));
    p[AXIS] = plane;
    p
}

/// Polygon `v` (in either orientation; a vertex may stand twice in a row) cut by the
/// half-space `p[AXIS] >= plane` (`keep_above`) or `<= plane` as one Sutherland–Hodgman step
/// ([`clip_polygon`]) cuts it: the same points, from the same edges in the same direction, in
/// a rotated order, in `M = N + 1` slots, a vertex repeated where fewer are left.
///
/// [`Cut::Empty`] if nothing is left, [`Cut::General`] if the kept vertices are not one run.
#[inline(always)]
fn cut<const AXIS: usize, const N: usize, const M: usize>(
    v: &[DVec3; N],
    plane: f64,
    keep_above: bool,
) -> Result<[DVec3; M], Cut> {
    let d = v.map(|p| inside::<AXIS>(p, plane, keep_above));
    let kept = kept(&d);
    // Filled in place, not by `array::from_fn`, whose closure stays out of line (with a bounds
    // check per vertex).
    if kept == (1 << N) - 1 {
        let mut polygon = [v[N - 1]; M];
        polygon[..N].copy_from_slice(v);
        return Ok(polygon);
    }
    let run =
        Run::of_polygon::<N>(kept).ok_or(if kept == 0 { Cut::Empty } else { Cut::General })?;
    let [out, back] = run.crossings::<AXIS>(v, &d, plane);
    // The run (its last vertex repeated), then the crossings.
    let len = if run.last >= run.first {
        run.last - run.first
    } else {
        run.last + N - run.first
    };
    let mut polygon = [out; M];
    for (k, p) in polygon[..M - 2].iter_mut().enumerate() {
        let i = run.first + k.min(len);
        *p = v[if i < N { i } else { i - N }];
    }
    polygon[M - 1] = back;
    Ok(polygon)
}

/// [`cut`] by face `face` (as in [`Clip::faces`]) of `cell` grown by `margin`: one branch to
/// the face, the axis and side then constants.
#[inline(always)]
fn cut_by<const N: usize, const M: usize>(
    v: &[DVec3; N],
    face: u32,
    cell: &Aabb,
    margin: f64,
) -> Result<[DVec3; M], Cut> {
    let (min, max) = (
        DVec3::from(cell.min) - margin,
        DVec3::from(cell.max) + margin,
    );
    match face {
        0 => cut::<0, N, M>(v, min.x, true),
        1 => cut::<0, N, M>(v, max.x, false),
        2 => cut::<1, N, M>(v, min.y, true),
        3 => cut::<1, N, M>(v, max.y, false),
        4 => cut::<2, N, M>(v, min.z, true),
        _ => cut::<2, N, M>(v, max.z, false),
    }
}

/// One Sutherland–Hodgman step: polygon `v` cut by the half-space `p[AXIS] >= plane`
/// (`keep_above`) or `<= plane`, written to `out`. Returns the number of vertices left, or
/// `None` when every vertex is inside (the polygon is left as it is, not copied).
fn clip_polygon<const AXIS: usize>(
    v: &[DVec3],
    out: &mut [DVec3; MAX_POLYGON],
    plane: f64,
    keep_above: bool,
) -> Result<Option<usize>, Cut> {
    let d = |i: usize| inside::<AXIS>(v[i], plane, keep_above);
    if (0..v.len()).all(|i| d(i) >= 0.0) {
        return Ok(None);
    }
    let mut len = 0;
    for i in 0..v.len() {
        let j = if i + 1 == v.len() { 0 } else { i + 1 };
        let (di, dj) = (d(i), d(j));
        if di >= 0.0 {
            *out.get_mut(len).ok_or(Cut::Overflow)? = v[i];
            len += 1;
        }
        if (di >= 0.0) != (dj >= 0.0) {
            *out.get_mut(len).ok_or(Cut::Overflow)? = crossing::<AXIS>(v[i], v[j], di, dj, plane);
            len += 1;
        }
    }
    if len == 0 {
        return Err(Cut::Empty);
    }
    Ok(Some(len))
}

/// The spans of the parts of polygon `v` where `p[AXIS] <= below_plane` and where
/// `p[AXIS] >= above_plane` (`planes = [below_plane, above_plane]`): two Sutherland–Hodgman
/// steps of [`clip_polygon`], with their points computed the same way but only their spans
/// kept.
///
/// Both parts at once, lane by lane, when the kept vertices are one run on each side; else
/// each by [`part_span`]. Always inlined, so that the sizes are constants.
///
/// Where points tie, a span may hold a zero of the other sign than the plain clip's (the
/// values are the same): harmless, as the margin subtracted or added in [`Clip::rounded`]
/// makes both the same. The margin is 0 only for a triangle and cell all at the origin, whose
/// vertices are all kept on both sides and taken in the plain clip's order ([`part_span`]).
#[inline(always)]
fn split_spans<const AXIS: usize, const N: usize>(v: &[DVec3; N], planes: [f64; 2]) -> SplitSpans {
    let [below_plane, above_plane] = planes;
    let below_d = v.map(|p| inside::<AXIS>(p, below_plane, false));
    let above_d = v.map(|p| inside::<AXIS>(p, above_plane, true));
    let kept = [kept(&below_d), kept(&above_d)];
    let (Some(below), Some(above)) = (Run::of_polygon::<N>(kept[0]), Run::of_polygon::<N>(kept[1]))
    else {
        return SplitSpans::from([
            part_span::<AXIS>(v, &below_d, below_plane),
            part_span::<AXIS>(v, &above_d, above_plane),
        ]);
    };
    let ends = |end: fn(&Run) -> usize| (end(&below), end(&above));
    let at = |(b, a): (usize, usize), c: usize| Parts::new(v[b][c], v[a][c]);
    let distance = |(b, a): (usize, usize)| Parts::new(below_d[b], above_d[a]);
    let (first, before) = (ends(|r| r.first), ends(|r| r.before));
    let (last, after) = (ends(|r| r.last), ends(|r| r.after));
    // The crossings of the edges leaving and entering the runs, as in `crossing`.
    let t_out = distance(last) / (distance(last) - distance(after));
    let t_back = distance(before) / (distance(before) - distance(first));
    let mut spans = SplitSpans {
        min: [Parts::ZERO; 3],
        max: [Parts::ZERO; 3],
    };
    for c in [(AXIS + 1) % 3, (AXIS + 2) % 3] {
        let out = at(last, c) + (at(after, c) - at(last, c)) * t_out;
        let back = at(before, c) + (at(first, c) - at(before, c)) * t_back;
        spans.min[c] = at(first, c).min(at(last, c)).min(out.min(back));
        spans.max[c] = at(first, c).max(at(last, c)).max(out.max(back));
    }
    // Along the axis: the crossings are on the planes, beyond the kept vertices, and the
    // lowest vertex is kept below, the highest above.
    let (lowest, highest) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[AXIS]), hi.max(p[AXIS]))
        });
    spans.min[AXIS] = Parts::new(lowest, above_plane);
    spans.max[AXIS] = Parts::new(below_plane, highest);
    // Vertices inside the runs (a triangle's have none): the first without a branch (else the
    // run's first vertex once more), the others, past a quad, in turn.
    if N > 3 {
        let inner = [(below, kept[0]), (above, kept[1])]
            .map(|(run, kept)| kept & !(1 << run.first | 1 << run.last));
        let next = |inner: u32, first: usize| {
            if inner == 0 {
                first
            } else {
                inner.trailing_zeros() as usize
            }
        };
        let mid = (next(inner[0], below.first), next(inner[1], above.first));
        for c in [(AXIS + 1) % 3, (AXIS + 2) % 3] {
            spans.min[c] = spans.min[c].min(at(mid, c));
            spans.max[c] = spans.max[c].max(at(mid, c));
        }
        if N > 4 {
            for (side, mut inner) in inner.into_iter().enumerate() {
                inner &= inner.wrapping_sub(1);
                while inner != 0 {
                    let p = v[inner.trailing_zeros() as usize];
                    inner &= inner - 1;
                    for c in [(AXIS + 1) % 3, (AXIS + 2) % 3] {
                        spans.min[c][side] = spans.min[c][side].min(p[c]);
                        spans.max[c][side] = spans.max[c][side].max(p[c]);
                    }
                }
            }
        }
    }
    spans
}

/// The span of the part of polygon `v` where the distances `d` inside a plane at `plane` on
/// `AXIS` are `>= 0`: of its vertices there and of the points where its edges cross the
/// plane.
#[inline(always)]
fn part_span<const AXIS: usize>(v: &[DVec3], d: &[f64], plane: f64) -> Span {
    let n = v.len();
    let kept = kept(d);
    let include = |(lo, hi): Span, p: DVec3| (lo.min(p), hi.max(p));
    let Some(run) = Run::of(kept, n) else {
        // None, all, or several runs: every edge in turn.
        let mut span = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for i in 0..n {
            let j = if i + 1 == n { 0 } else { i + 1 };
            if d[i] >= 0.0 {
                span = include(span, v[i]);
            }
            if (d[i] >= 0.0) != (d[j] >= 0.0) {
                span = include(span, crossing::<AXIS>(v[i], v[j], d[i], d[j], plane));
            }
        }
        return span;
    };
    let [out, back] = run.crossings::<AXIS>(v, d, plane);
    let mut span = include(include((v[run.first], v[run.first]), v[run.last]), out);
    span = include(span, back);
    // A triangle's run has no vertices but its ends.
    if n > 3 {
        let mut inner = kept & !(1 << run.first | 1 << run.last);
        while inner != 0 {
            span = include(span, v[inner.trailing_zeros() as usize]);
            inner &= inner - 1;
        }
    }
    span
}

/// The triangle's box ∩ the cell: conservative when the clip cannot be trusted.
fn fallback(vertex_box: &Aabb, cell: &Aabb) -> Option<Aabb> {
    let b = vertex_box.intersection(*cell);
    (!b.is_empty()).then_some(b)
}

/// The largest f32 `<= x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    let bits = f.to_bits();
    // One step toward −∞ where rounding went up: the magnitude's bits down one for a positive
    // `f`, up one for a negative one. Rounding a negative `x` gives a negative `f` (−0 for a
    // tiny one, which steps to the least negative f32): `f` is never +0 here.
    let step = if (bits as i32) < 0 { 1 } else { u32::MAX };
    let up = f64::from(f) > x;
    f32::from_bits(bits.wrapping_add(if up { step } else { 0 }))
}

/// The smallest f32 `>= x`.
fn round_up(x: f64) -> f32 {
    -round_down(-x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(min: [f32; 3], max: [f32; 3]) -> Aabb {
        Aabb::new(Vec3::from(min), Vec3::from(max))
    }

    /// [`split_clipped_bounds`] on `axis`.
    fn split(tri: &Triangle, cell: &Aabb, axis: usize, position: f32) -> [Option<Aabb>; 2] {
        match axis {
            0 => split_clipped_bounds::<0>(tri, cell, position),
            1 => split_clipped_bounds::<1>(tri, cell, position),
            _ => split_clipped_bounds::<2>(tri, cell, position),
        }
    }

    /// The box of `tri ∩ cell`: the part below a split at the cell's face.
    fn clipped_bounds(tri: &Triangle, cell: &Aabb) -> Option<Aabb> {
        split(tri, cell, 0, cell.max.x)[0]
    }

    /// One Sutherland–Hodgman step written plainly: the part of polygon `poly` where
    /// `p[axis] >= plane` (`keep_above`) or `<= plane`, crossings set to `plane` on `axis`.
    fn clip_plainly(poly: &[DVec3], axis: usize, plane: f64, keep_above: bool) -> Vec<DVec3> {
        let inside = |p: DVec3| {
            if keep_above {
                p[axis] - plane
            } else {
                plane - p[axis]
            }
        };
        let mut part = Vec::new();
        for (i, &a) in poly.iter().enumerate() {
            let b = poly[(i + 1) % poly.len()];
            let (da, db) = (inside(a), inside(b));
            if da >= 0.0 {
                part.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let mut p = a + (b - a) * (da / (da - db));
                p[axis] = plane;
                part.push(p);
            }
        }
        part
    }

    /// The box of points `part` in the order given (`(+∞, −∞)` for none).
    fn span_of(part: &[DVec3]) -> Span {
        part.iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            })
    }

    /// [`split_clipped_bounds`] as the module docs define it, without its shortcuts: the
    /// triangle clipped in f64 to all six faces of the cell grown by the margin (a polygon
    /// outgrowing [`MAX_POLYGON`] gives the triangle's box ∩ each half), then to each grown side
    /// of the plane; each part's box rounded outward by the margin and clamped to the
    /// triangle's box ∩ its half.
    fn reference(tri: &Triangle, cell: &Aabb, axis: usize, position: f32) -> [Option<Aabb>; 2] {
        let (mut below, mut above) = (*cell, *cell);
        below.max[axis] = position;
        above.min[axis] = position;
        let vertex_box = Aabb::from_points([tri.v0, tri.v1, tri.v2]);
        let magnitude = [vertex_box.min, vertex_box.max, cell.min, cell.max]
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
        let m = f64::from(magnitude) * MARGIN;
        let mut poly = vec![tri.v0, tri.v1, tri.v2];
        let mut poly: Vec<DVec3> = poly.drain(..).map(DVec3::from).collect();
        for a in 0..3 {
            let faces = [
                (f64::from(cell.min[a]) - m, true),
                (f64::from(cell.max[a]) + m, false),
            ];
            for (plane, keep_above) in faces {
                poly = clip_plainly(&poly, a, plane, keep_above);
                if poly.len() > MAX_POLYGON {
                    return [below, above].map(|half| fallback(&vertex_box, &half));
                }
            }
        }
        let plane = f64::from(position);
        let sides = [(below, plane + m, false), (above, plane - m, true)];
        sides.map(|(half, plane, keep_above)| {
            let (lo, hi) = span_of(&clip_plainly(&poly, axis, plane, keep_above));
            let exact = vertex_box.intersection(half);
            // `exact` wins ties, as `f32::max(lo, exact)` and `min` compile on x86.
            let b = Aabb::new(
                exact
                    .min
                    .max(Vec3::from((lo - m).to_array().map(round_down))),
                exact.max.min(Vec3::from((hi + m).to_array().map(round_up))),
            );
            (!b.is_empty()).then_some(b)
        })
    }

    /// The bits of both boxes, so that ±0 compare exactly.
    fn bits(parts: [Option<Aabb>; 2]) -> [Option<[u32; 6]>; 2] {
        parts.map(|part| {
            part.map(|b| {
                let [x0, y0, z0] = b.min.to_array().map(f32::to_bits);
                let [x1, y1, z1] = b.max.to_array().map(f32::to_bits);
                [x0, y0, z0, x1, y1, z1]
            })
        })
    }

    /// A seeded stream of test values (a local xorshift).
    struct Values(u64);

    impl Values {
        fn below(&mut self, n: u64) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0 % n
        }

        /// A coordinate of magnitude about `scale`: zero of either sign, a point of a coarse
        /// grid (so that vertices, faces and planes coincide), or anywhere.
        fn coord(&mut self, scale: f32) -> f32 {
            match self.below(8) {
                0 => 0.0,
                1 => -0.0,
                2 | 3 => (self.below(9) as f32 - 4.0) * 0.25 * scale,
                _ => (self.below(1 << 24) as f32 / (1 << 23) as f32 - 1.0) * scale,
            }
        }

        fn point(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.coord(scale), self.coord(scale), self.coord(scale))
        }

        /// A polygon of `N` points, often not convex.
        fn polygon<const N: usize>(&mut self) -> [DVec3; N] {
            let mut v = [DVec3::ZERO; N];
            for i in 0..N {
                v[i] = if i > 0 && self.below(6) == 0 {
                    v[i - 1]
                } else {
                    DVec3::from(self.point(1.0))
                };
            }
            v
        }
    }

    #[test]
    fn split_clipped_bounds_equals_the_plain_clip() {
        // Random triangles, cells and planes at scales from subnormal to huge, on a grid that
        // makes vertices touch faces and planes, flat, degenerate and all at ±0; and triangles
        // inside the cell: touching its faces, in the split plane, slivers.
        let mut values = Values(0x2545_f491_4f6c_dd1d);
        let mut cases: Vec<(Triangle, Aabb)> = Vec::new();
        for case in 0..200_000 {
            let scale = [1.0, 1e-30, 1e30, 3e-39, 1e6, 1e-3][values.below(6) as usize];
            let scale = if case % 17 == 0 { 0.0 } else { scale };
            let [a, b, c, p, q] = [(); 5].map(|()| values.point(scale));
            let mut tri = Triangle::new(a, b, c);
            let cell = Aabb::new(p.min(q), p.max(q));
            match case % 10 {
                // A segment, a point.
                1 => tri.v1 = tri.v0,
                2 => (tri.v1, tri.v2) = (tri.v0, tri.v0),
                // Flat on a face of the cell.
                3 => [tri.v0.z, tri.v1.z, tri.v2.z] = [cell.min.z; 3],
                // Inside the cell.
                4 | 5 => {
                    let inside = |p: Vec3| p.clamp(cell.min, cell.max);
                    tri = Triangle::new(inside(a), inside(b), inside(c));
                }
                _ => {}
            }
            cases.push((tri, cell));
        }
        let c = cell([-1.0, -0.5, 0.0], [1.0, 1.5, 2.0]);
        let v = Vec3::new;
        let sliver = Triangle::new(
            v(-0.9, 0.2, 0.3),
            v(0.9, 0.2000001, 0.3),
            v(0.1, 0.2, 0.3000001),
        );
        for tri in [
            Triangle::new(v(-1.0, -0.5, 0.0), v(0.5, 0.25, 1.0), v(-0.25, 1.0, 0.5)),
            Triangle::new(v(1.0, 1.5, 2.0), v(0.0, 0.0, 1.0), v(0.5, 1.5, 0.25)),
            Triangle::new(v(-1.0, -0.5, 0.0), v(1.0, 1.5, 2.0), v(1.0, -0.5, 2.0)),
            Triangle::new(v(1.0, 0.0, 0.5), v(1.0, 1.0, 1.5), v(1.0, -0.5, 2.0)),
            Triangle::new(v(-0.0, 0.0, -0.0), v(0.0, -0.0, 0.0), v(0.5, 0.5, 0.0)),
            sliver,
        ] {
            cases.push((tri, c));
        }
        // Cases by the number of faces the triangle's box crosses: 0 (inside), 1, 2 or 3, more.
        let mut paths = [0; 4];
        for (tri, cell) in &cases {
            paths[match Clip::new(tri, cell).faces.count_ones() {
                faces @ 0..=1 => faces as usize,
                2 | 3 => 2,
                _ => 3,
            }] += 1;
            for axis in 0..3 {
                // Splits through the vertices, the cell's faces, its middle and zero.
                let positions = [
                    tri.v0[axis],
                    tri.v1[axis],
                    tri.v2[axis],
                    cell.min[axis],
                    cell.max[axis],
                    cell.center()[axis],
                    0.0,
                ];
                let position = positions[values.below(7) as usize];
                let position = position.clamp(cell.min[axis], cell.max[axis]);
                assert_eq!(
                    bits(split(tri, cell, axis, position)),
                    bits(reference(tri, cell, axis, position)),
                    "{tri:?} {cell:?} {axis} {position:e}"
                );
            }
        }
        assert!(paths.iter().all(|&n| n > 5_000), "{paths:?}");
    }

    /// The points of cyclic sequence `v`, a point repeated right after itself counted once.
    fn cycle(v: &[DVec3]) -> Vec<[u64; 3]> {
        let mut points: Vec<[u64; 3]> = v.iter().map(|p| p.to_array().map(f64::to_bits)).collect();
        points.dedup();
        while points.len() > 1 && points.first() == points.last() {
            points.pop();
        }
        points
    }

    /// Whether cyclic sequences `a` and `b` are the same up to where they start.
    fn same_cycle(a: &[[u64; 3]], b: &[[u64; 3]]) -> bool {
        a.len() == b.len()
            && (a.is_empty() || (0..a.len()).any(|r| a.iter().cycle().skip(r).take(a.len()).eq(b)))
    }

    /// [`cut`] of random polygons of `N` vertices against [`clip_plainly`].
    fn cut_matches_a_clip<const N: usize, const M: usize>(values: &mut Values) -> usize {
        let mut several_runs = 0;
        for _ in 0..20_000 {
            let v = values.polygon::<N>();
            let axis = values.below(3) as usize;
            let keep_above = values.below(2) == 0;
            let plane = f64::from(values.coord(1.0));
            let got = match axis {
                0 => cut::<0, N, M>(&v, plane, keep_above),
                1 => cut::<1, N, M>(&v, plane, keep_above),
                _ => cut::<2, N, M>(&v, plane, keep_above),
            };
            let want = clip_plainly(&v, axis, plane, keep_above);
            let inside = v.map(|p| inside_plainly(p, axis, plane, keep_above) >= 0.0);
            let runs = (0..N)
                .filter(|&i| inside[i] && !inside[(i + N - 1) % N])
                .count();
            match got {
                Ok(cut) => {
                    assert!(runs <= 1, "{v:?} {axis} {plane}");
                    assert!(
                        same_cycle(&cycle(&cut), &cycle(&want)),
                        "{v:?} {axis} {plane}"
                    );
                }
                Err(Cut::Empty) => assert!(want.is_empty(), "{v:?} {axis} {plane}"),
                Err(Cut::General) => {
                    assert!(runs > 1, "{v:?} {axis} {plane}");
                    several_runs += 1;
                }
                Err(Cut::Overflow) => panic!("{v:?} {axis} {plane}"),
            }
        }
        several_runs
    }

    fn inside_plainly(p: DVec3, axis: usize, plane: f64, keep_above: bool) -> f64 {
        if keep_above {
            p[axis] - plane
        } else {
            plane - p[axis]
        }
    }

    #[test]
    fn cut_makes_the_points_of_one_clip_step() {
        // The same points, from the same edges, as one plain step, whatever the polygon (not
        // convex, vertices repeated); several runs of kept vertices are left to the general
        // clip, and do occur in these polygons.
        let mut values = Values(0x9e37_79b9_7f4a_7c15);
        let several_runs = [
            cut_matches_a_clip::<3, 4>(&mut values),
            cut_matches_a_clip::<4, 5>(&mut values),
            cut_matches_a_clip::<5, 6>(&mut values),
        ];
        assert!(several_runs[0] == 0 && several_runs[1..].iter().all(|&n| n > 100));
    }

    /// [`split_spans`] and [`part_span`] of random polygons of `N` vertices against the spans
    /// of the plainly clipped parts (equal values: the sign of a zero differs where points
    /// tie, which the margin then erases).
    fn spans_match_the_clipped_parts<const N: usize>(values: &mut Values) {
        for _ in 0..20_000 {
            let v = values.polygon::<N>();
            let plane = f64::from(values.coord(1.0));
            let planes = [plane + 1e-3, plane - 1e-3];
            let want = [(planes[0], false), (planes[1], true)]
                .map(|(plane, keep_above)| span_of(&clip_plainly(&v, 1, plane, keep_above)));
            let spans = split_spans::<1, N>(&v, planes);
            for (side, (lo, hi)) in want.iter().enumerate() {
                let got_lo = DVec3::from_array(spans.min.map(|c| c[side]));
                let got_hi = DVec3::from_array(spans.max.map(|c| c[side]));
                assert!(got_lo == *lo && got_hi == *hi, "{v:?} {planes:?} {side}");
                let d = v.map(|p| inside_plainly(p, 1, planes[side], side == 1));
                let (lo_part, hi_part) = part_span::<1>(&v, &d, planes[side]);
                assert!(lo_part == *lo && hi_part == *hi, "{v:?} {planes:?} {side}");
            }
        }
    }

    #[test]
    fn split_spans_span_the_clipped_parts() {
        let mut values = Values(0xd1b5_4a32_d192_ed03);
        spans_match_the_clipped_parts::<3>(&mut values);
        spans_match_the_clipped_parts::<4>(&mut values);
        spans_match_the_clipped_parts::<6>(&mut values);
    }

    #[test]
    fn a_polygon_outgrowing_max_polygon_overflows() {
        // A zigzag across x = 0: every edge crosses, so 6 kept vertices and 12 crossings.
        let zigzag: Vec<DVec3> = (0..12)
            .map(|i| DVec3::new(if i % 2 == 0 { 1.0 } else { -1.0 }, f64::from(i), 0.0))
            .collect();
        let mut out = [DVec3::ZERO; MAX_POLYGON];
        assert!(matches!(
            clip_polygon::<0>(&zigzag, &mut out, 0.0, true),
            Err(Cut::Overflow)
        ));
        // Four vertices of it fit: 2 kept, 4 crossings.
        assert!(matches!(
            clip_polygon::<0>(&zigzag[..4], &mut out, 0.0, true),
            Ok(Some(6))
        ));
    }

    #[test]
    fn split_halves_match_clipping_to_each_half() {
        // The triangle x + y <= 1 (z = 0) split at x = 0.5 in a cell that cuts it at y = 0.8:
        // each half's box is what clipping to that half gives.
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let c = cell([-1.0, -1.0, -1.0], [2.0, 0.8, 1.0]);
        let [below, above] = split(&tri, &c, 0, 0.5);
        let below = below.unwrap();
        let above = above.unwrap();
        assert_eq!(
            Some(below),
            clipped_bounds(&tri, &cell([-1.0, -1.0, -1.0], [0.5, 0.8, 1.0]))
        );
        assert_eq!(
            Some(above),
            clipped_bounds(&tri, &cell([0.5, -1.0, -1.0], [2.0, 0.8, 1.0]))
        );
        // Tolerance: a few f32 ulps from the outward rounding.
        assert!((below.max.y - 0.8).abs() < 1e-6 && (above.max.y - 0.5).abs() < 1e-6);
        assert_eq!((below.max.x, above.min.x), (0.5, 0.5));
        // A split beyond the triangle leaves one side empty.
        let [below, above] = split(&tri, &c, 0, 1.5);
        assert!(below.is_some() && above.is_none());
    }

    #[test]
    fn diagonal_triangle_is_clipped_tighter_than_its_box() {
        // The triangle x + y <= 1 (z = 0) against x >= 0.5: the part is x ∈ [0.5, 1],
        // y ∈ [0, 0.5]. Tolerance: a few f32 ulps from the outward rounding.
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let b = clipped_bounds(&tri, &cell([0.5, -1.0, -1.0], [2.0, 2.0, 1.0])).unwrap();
        assert_eq!(b.min.x, 0.5);
        assert!((b.max.y - 0.5).abs() < 1e-6 && b.max.y >= 0.5, "{b:?}");
        assert_eq!((b.min.z, b.max.z), (0.0, 0.0));
    }

    #[test]
    fn a_triangle_beside_the_cell_is_rejected_and_a_touching_one_is_flat() {
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        // Inside the triangle's box but beyond its hypotenuse.
        assert_eq!(
            clipped_bounds(&tri, &cell([0.75, 0.75, -1.0], [1.0, 1.0, 1.0])),
            None
        );
        let b = clipped_bounds(&tri, &cell([1.0, -1.0, -1.0], [2.0, 1.0, 1.0])).unwrap();
        assert_eq!((b.min.x, b.max.x), (1.0, 1.0));
    }

    #[test]
    fn a_grazing_edge_is_clipped_tightly() {
        // A Sponza wall triangle in x = -16.20356 whose edge v1 → v0 rises 1e-6 in y over 2.27
        // in z (slope 2·10⁶), against a cell 3.2e-7 thick in y: the part ends where that edge
        // leaves the cell. Conservative (>=), and loose by less than one f32 ulp of the largest
        // coordinate (16.2: 1.9e-6), as the module docs promise for slopes below 2^23; a 2^-40
        // margin gave 3.3e-5.
        let tri = Triangle::new(
            Vec3::new(-16.20356, 0.093313, 2.266891),
            Vec3::new(-16.20356, 0.093312, 0.00149),
            Vec3::new(-16.20356, 2.693312, 2.26689),
        );
        let c = cell(
            [-16.20356, 0.093312, 0.0014902728],
            [-16.202759, 0.093312316, 5.0],
        );
        let b = clipped_bounds(&tri, &c).unwrap();
        let [v0, v1] = [tri.v0, tri.v1].map(DVec3::from);
        let t = (f64::from(c.max.y) - v1.y) / (v0.y - v1.y);
        let exact = v1.z + (v0.z - v1.z) * t;
        let max_z = f64::from(b.max.z);
        assert!(
            max_z >= exact && max_z - exact < 1.9e-6,
            "{max_z} vs {exact}"
        );
    }

    #[test]
    fn round_down_steps_toward_negative_infinity_exactly_when_rounding_went_up() {
        // Against the definition: the nearest f32, one step down if it is above `x`.
        let reference = |x: f64| {
            let f = x as f32;
            if f64::from(f) > x {
                f.next_down()
            } else {
                f
            }
        };
        let tiny = f64::from(f32::from_bits(1));
        let max = f64::from(f32::MAX);
        let mut xs = vec![
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            tiny,
            -tiny,
            tiny / 3.0,
            -tiny / 3.0,
            0.1,
            -0.1,
            1.0,
            -1.0,
            max,
            -max,
            max * (1.0 + 1e-9),
            -max * (1.0 + 1e-9),
            max * 2.0,
            -max * 2.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
        ];
        // And a spread of magnitudes, each nudged either side of an f32.
        for e in -150..130 {
            let f = 1.37f64 * 2f64.powi(e);
            for x in [f, -f] {
                let r = f64::from(x as f32);
                xs.extend([x, r, r * (1.0 + 1e-12), r * (1.0 - 1e-12)]);
            }
        }
        for x in xs {
            let (got, want) = (round_down(x), reference(x));
            assert_eq!(got.to_bits(), want.to_bits(), "{x:e}: {got:e} vs {want:e}");
            assert_eq!(round_up(x).to_bits(), (-reference(-x)).to_bits(), "{x:e}");
        }
    }

    #[test]
    fn rounding_is_outward() {
        // 0.1f32 is just above 0.1.
        assert_eq!(round_up(0.1), 0.1f32);
        assert_eq!(round_down(0.1), 0.1f32.next_down());
        assert!(f64::from(round_down(0.1)) <= 0.1 && f64::from(round_up(0.1)) >= 0.1);
        assert_eq!(round_down(-0.0), 0.0);
        assert!(round_down(-1e-300) < 0.0 && round_down(-1.0 - 1e-12) < -1.0);
    }
}
