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
/// `cell` split at `position` on `axis` (`cell.min[axis] <= position <= cell.max[axis]`): each
/// conservative in f32 and inside its half, `None` when the triangle does not meet it.
///
/// The triangle is clipped once to the (grown) cell and the polygon then once more to each
/// side of the (grown) plane: the same half-spaces as clipping to each half, in another order.
/// A triangle touching a half only on its boundary gives a flat box on that boundary.
/// Degenerate triangles (segments, points) clip like any other polygon.
///
/// # Panics
///
/// If `axis` is not 0, 1 or 2.
pub(super) fn split_clipped_bounds(
    tri: &Triangle,
    cell: &Aabb,
    axis: usize,
    position: f32,
) -> [Option<Aabb>; 2] {
    // The axis as a constant, so that coordinates along it are picked without a branch.
    match axis {
        0 => split_clipped_bounds_on::<0>(tri, cell, position),
        1 => split_clipped_bounds_on::<1>(tri, cell, position),
        2 => split_clipped_bounds_on::<2>(tri, cell, position),
        _ => panic!("split axis {axis} is not 0, 1 or 2"),
    }
}

/// [`split_clipped_bounds`] on axis `AXIS`.
fn split_clipped_bounds_on<const AXIS: usize>(
    tri: &Triangle,
    cell: &Aabb,
    position: f32,
) -> [Option<Aabb>; 2] {
    let (mut below, mut above) = (*cell, *cell);
    below.max[AXIS] = position;
    above.min[AXIS] = position;
    let clip = Clip::new(tri, cell);
    let [v0, v1, v2] = [tri.v0, tri.v1, tri.v2].map(DVec3::from);
    let plane = f64::from(position);
    let planes = [plane + clip.margin, plane - clip.margin];
    let mut buffers;
    let spans = if clip.inside(cell) {
        // The clip to the cell would cut nothing off: the same steps on the triangle itself.
        split_spans::<AXIS>(&[v0, v1, v2, v0], planes)
    } else {
        buffers = [[DVec3::ZERO; MAX_POLYGON + 1]; 2];
        match clip.to_cell(&[v0, v1, v2, v0], cell, &mut buffers) {
            Ok(polygon) => split_spans::<AXIS>(polygon, planes),
            Err(Cut::Empty) => return [None, None],
            Err(Cut::Overflow) => {
                return [below, above].map(|half| fallback(&clip.vertex_box, &half));
            }
        }
    };
    [
        spans[0].and_then(|(lo, hi)| clip.rounded(lo, hi, &below)),
        spans[1].and_then(|(lo, hi)| clip.rounded(lo, hi, &above)),
    ]
}

/// A triangle being clipped to a cell grown by the margin, in f64.
struct Clip {
    /// The triangle's own box.
    vertex_box: Aabb,
    /// The margin: [`MARGIN`] times the largest coordinate of the triangle and the cell.
    margin: f64,
}

/// Why clipping to the cell left no polygon.
enum Cut {
    /// Nothing is left.
    Empty,
    /// Rounding made the polygon non-convex (it outgrew [`MAX_POLYGON`]).
    Overflow,
}

/// A convex polygon of at most [`MAX_POLYGON`] vertices being clipped, closed (its first
/// vertex repeated after the last, so that its edges are the pairs of neighbours), with a
/// spare buffer for the next clip to write to.
struct Polygon<'a> {
    verts: &'a mut [DVec3; MAX_POLYGON + 1],
    spare: &'a mut [DVec3; MAX_POLYGON + 1],
    /// The number of vertices, not counting the repeated one.
    len: usize,
}

impl Clip {
    fn new(tri: &Triangle, cell: &Aabb) -> Self {
        let vertex_box = vertex_box(tri);
        // The largest |coordinate| of the vertices is that of their box's corners (exact).
        let magnitude = [vertex_box.min, vertex_box.max, cell.min, cell.max]
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
        let margin = f64::from(magnitude) * MARGIN;
        Clip { vertex_box, margin }
    }

    /// True when the triangle's box lies inside `cell`, so that clipping to the grown cell
    /// cuts nothing off.
    fn inside(&self, cell: &Aabb) -> bool {
        let vb = &self.vertex_box;
        cell.min.cmple(vb.min).all() && vb.max.cmple(cell.max).all()
    }

    /// The closed `triangle` clipped to the grown `cell`, in one of `buffers`, closed.
    ///
    /// A face the triangle's box does not cross is skipped without looking at the polygon:
    /// clipped points lie in that box but for f64 rounding, far smaller than the margin.
    fn to_cell<'a>(
        &self,
        triangle: &[DVec3; 4],
        cell: &Aabb,
        buffers: &'a mut [[DVec3; MAX_POLYGON + 1]; 2],
    ) -> Result<&'a [DVec3], Cut> {
        let [verts, spare] = buffers.each_mut();
        verts[..4].copy_from_slice(triangle);
        let mut poly = Polygon {
            verts,
            spare,
            len: 3,
        };
        self.to_faces::<0>(&mut poly, cell)?;
        self.to_faces::<1>(&mut poly, cell)?;
        self.to_faces::<2>(&mut poly, cell)?;
        let Polygon { verts, len, .. } = poly;
        Ok(&verts[..=len])
    }

    /// Clips `poly` to the grown cell's faces across `AXIS` that the triangle's box crosses.
    fn to_faces<const AXIS: usize>(&self, poly: &mut Polygon<'_>, cell: &Aabb) -> Result<(), Cut> {
        if self.vertex_box.min[AXIS] < cell.min[AXIS] {
            poly.clip::<AXIS>(f64::from(cell.min[AXIS]) - self.margin, true)?;
        }
        if self.vertex_box.max[AXIS] > cell.max[AXIS] {
            poly.clip::<AXIS>(f64::from(cell.max[AXIS]) + self.margin, false)?;
        }
        Ok(())
    }

    /// The f32 box of `[pmin, pmax]` rounded outward by the margin, within the triangle's own
    /// box and `cell`; `None` if empty.
    fn rounded(&self, pmin: DVec3, pmax: DVec3, cell: &Aabb) -> Option<Aabb> {
        let exact = self.vertex_box.intersection(*cell);
        let m = self.margin;
        let lo = [pmin.x - m, pmin.y - m, pmin.z - m].map(round_down);
        let hi = [pmax.x + m, pmax.y + m, pmax.z + m].map(round_up);
        // `f32::max` and `min`, which ignore a NaN, not glam's.
        let b = Aabb::new(
            Vec3::new(
                lo[0].max(exact.min.x),
                lo[1].max(exact.min.y),
                lo[2].max(exact.min.z),
            ),
            Vec3::new(
                hi[0].min(exact.max.x),
                hi[1].min(exact.max.y),
                hi[2].min(exact.max.z),
            ),
        );
        (!b.is_empty()).then_some(b)
    }
}

impl Polygon<'_> {
    /// Clips to the half-space `p[AXIS] >= plane` (`keep_above`) or `<= plane`; a no-op when
    /// every vertex is inside.
    fn clip<const AXIS: usize>(&mut self, plane: f64, keep_above: bool) -> Result<(), Cut> {
        let inside = |p: DVec3| {
            if keep_above {
                p[AXIS] - plane
            } else {
                plane - p[AXIS]
            }
        };
        if !self.verts[..self.len].iter().all(|&p| inside(p) >= 0.0) {
            let closed = &self.verts[..=self.len];
            self.len =
                clip_polygon::<AXIS>(closed, self.spare, plane, inside).ok_or(Cut::Overflow)?;
            std::mem::swap(&mut self.verts, &mut self.spare);
        }
        if self.len == 0 {
            return Err(Cut::Empty);
        }
        Ok(())
    }
}

/// The spans of the parts of closed convex polygon `verts` (the first vertex repeated after the
/// last) where `p[AXIS] <= below_plane` and where
/// `p[AXIS] >= above_plane` (`planes = [below_plane, above_plane]`): two Sutherland–Hodgman
/// steps of [`clip_polygon`] in one pass, with their points computed the same way but only
/// their spans kept; `None` for a part with nothing left.
///
/// Always inlined, so that for a triangle the loop is unrolled.
#[inline(always)]
fn split_spans<const AXIS: usize>(
    verts: &[DVec3],
    planes: [f64; 2],
) -> [Option<(DVec3, DVec3)>; 2] {
    let [below_plane, above_plane] = planes;
    // Signed distances inside each half-space.
    let inside = |p: DVec3| [below_plane - p[AXIS], p[AXIS] - above_plane];
    let mut spans = [(DVec3::INFINITY, DVec3::NEG_INFINITY); 2];
    let mut any = [false; 2];
    for edge in verts.windows(2) {
        let (a, b) = (edge[0], edge[1]);
        let (da, db) = (inside(a), inside(b));
        for side in 0..2 {
            let (span, da, db) = (&mut spans[side], da[side], db[side]);
            if da >= 0.0 {
                *span = (span.0.min(a), span.1.max(a));
                any[side] = true;
            }
            if (da >= 0.0) != (db >= 0.0) {
                let mut p = a + (b - a) * (da / (da - db));
                p[AXIS] = planes[side];
                *span = (span.0.min(p), span.1.max(p));
                any[side] = true;
            }
        }
    }
    [0, 1].map(|side| any[side].then_some(spans[side]))
}

/// One Sutherland–Hodgman step: the part of closed polygon `poly` (the first vertex repeated
/// after the last) where `inside(p) >= 0`, written to `out`, closed. Crossing points get their
/// `AXIS` coordinate set to `plane` exactly. Returns the new vertex count (not counting the
/// repeated one), or `None` if it would be more than [`MAX_POLYGON`].
fn clip_polygon<const AXIS: usize>(
    poly: &[DVec3],
    out: &mut [DVec3; MAX_POLYGON + 1],
    plane: f64,
    inside: impl Fn(DVec3) -> f64,
) -> Option<usize> {
    let mut n = 0;
    let mut push = |p: DVec3| {
        let slot = out[..MAX_POLYGON].get_mut(n)?;
        *slot = p;
        n += 1;
        Some(())
    };
    for edge in poly.windows(2) {
        let (a, b) = (edge[0], edge[1]);
        let (da, db) = (inside(a), inside(b));
        if da >= 0.0 {
            push(a)?;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let mut p = a + (b - a) * (da / (da - db));
            p[AXIS] = plane;
            push(p)?;
        }
    }
    out[n] = out[0];
    Some(n)
}

/// The triangle's box ∩ the cell: conservative when the clip cannot be trusted.
fn fallback(vertex_box: &Aabb, cell: &Aabb) -> Option<Aabb> {
    let b = vertex_box.intersection(*cell);
    (!b.is_empty()).then_some(b)
}

fn vertex_box(tri: &Triangle) -> Aabb {
    Aabb::from_points([tri.v0, tri.v1, tri.v2])
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

    /// The closed triangle `tri` in f64.
    fn closed(tri: &Triangle) -> [DVec3; 4] {
        let [v0, v1, v2] = [tri.v0, tri.v1, tri.v2].map(DVec3::from);
        [v0, v1, v2, v0]
    }

    /// The box of `tri ∩ cell` by the same steps as [`split_clipped_bounds`], without a split.
    fn clipped_bounds(tri: &Triangle, cell: &Aabb) -> Option<Aabb> {
        let clip = Clip::new(tri, cell);
        let triangle = closed(tri);
        let mut buffers = [[DVec3::ZERO; MAX_POLYGON + 1]; 2];
        let verts = match clip.to_cell(&triangle, cell, &mut buffers) {
            Ok(closed) => closed,
            Err(Cut::Empty) => return None,
            Err(Cut::Overflow) => return fallback(&clip.vertex_box, cell),
        };
        let lo = verts.iter().fold(DVec3::INFINITY, |m, &v| m.min(v));
        let hi = verts.iter().fold(DVec3::NEG_INFINITY, |m, &v| m.max(v));
        clip.rounded(lo, hi, cell)
    }

    #[test]
    fn split_halves_match_clipping_to_each_half() {
        // The triangle x + y <= 1 (z = 0) split at x = 0.5 in a cell that cuts it at y = 0.8:
        // each half's box is what clipping to that half gives.
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let c = cell([-1.0, -1.0, -1.0], [2.0, 0.8, 1.0]);
        let [below, above] = split_clipped_bounds(&tri, &c, 0, 0.5);
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
        let [below, above] = split_clipped_bounds(&tri, &c, 0, 1.5);
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

    /// [`split_clipped_bounds_on`] without its shortcuts: the triangle is clipped to all six
    /// faces of the grown cell, whether its box crosses them or not.
    fn split_by_clipping_every_face<const AXIS: usize>(
        tri: &Triangle,
        cell: &Aabb,
        position: f32,
    ) -> [Option<Aabb>; 2] {
        fn to_faces<const A: usize>(poly: &mut Polygon<'_>, cell: &Aabb, margin: f64) -> bool {
            poly.clip::<A>(f64::from(cell.min[A]) - margin, true)
                .is_ok()
                && poly
                    .clip::<A>(f64::from(cell.max[A]) + margin, false)
                    .is_ok()
        }
        let (mut below, mut above) = (*cell, *cell);
        below.max[AXIS] = position;
        above.min[AXIS] = position;
        let clip = Clip::new(tri, cell);
        let mut buffers = [[DVec3::ZERO; MAX_POLYGON + 1]; 2];
        let [verts, spare] = buffers.each_mut();
        verts[..4].copy_from_slice(&closed(tri));
        let mut poly = Polygon {
            verts,
            spare,
            len: 3,
        };
        let m = clip.margin;
        if !(to_faces::<0>(&mut poly, cell, m)
            && to_faces::<1>(&mut poly, cell, m)
            && to_faces::<2>(&mut poly, cell, m))
        {
            return [None, None];
        }
        let plane = f64::from(position);
        let spans = split_spans::<AXIS>(&poly.verts[..=poly.len], [plane + m, plane - m]);
        [
            spans[0].and_then(|(lo, hi)| clip.rounded(lo, hi, &below)),
            spans[1].and_then(|(lo, hi)| clip.rounded(lo, hi, &above)),
        ]
    }

    /// The bits of both boxes, so that ±0 and NaNs compare exactly.
    fn bits(parts: [Option<Aabb>; 2]) -> [Option<[u32; 6]>; 2] {
        parts.map(|part| {
            part.map(|b| {
                let [x0, y0, z0] = b.min.to_array().map(f32::to_bits);
                let [x1, y1, z1] = b.max.to_array().map(f32::to_bits);
                [x0, y0, z0, x1, y1, z1]
            })
        })
    }

    #[test]
    fn the_inside_shortcut_equals_clipping_to_every_face() {
        // For a triangle inside the cell, `split_clipped_bounds` skips the clip to the cell.
        // Clipping to all six grown faces instead must give the same boxes bit for bit, for
        // triangles touching the faces, flat, degenerate, in the split plane, with −0.
        let c = cell([-1.0, -0.5, 0.0], [1.0, 1.5, 2.0]);
        let v = Vec3::new;
        let triangles = [
            // General, well inside.
            Triangle::new(v(-0.3, 0.1, 0.2), v(0.7, 0.9, 1.1), v(0.1, -0.2, 1.9)),
            // Touching the min faces, and the max faces.
            Triangle::new(v(-1.0, -0.5, 0.0), v(0.5, 0.25, 1.0), v(-0.25, 1.0, 0.5)),
            Triangle::new(v(1.0, 1.5, 2.0), v(0.0, 0.0, 1.0), v(0.5, 1.5, 0.25)),
            // Spanning the cell corner to corner.
            Triangle::new(v(-1.0, -0.5, 0.0), v(1.0, 1.5, 2.0), v(1.0, -0.5, 2.0)),
            // Flat in z, and flat in x on the cell's face.
            Triangle::new(v(-0.5, 0.0, 1.0), v(0.5, 1.0, 1.0), v(0.25, -0.25, 1.0)),
            Triangle::new(v(1.0, 0.0, 0.5), v(1.0, 1.0, 1.5), v(1.0, -0.5, 2.0)),
            // A segment, a point, and −0 coordinates.
            Triangle::new(v(-0.75, 0.0, 0.5), v(0.75, 1.0, 1.5), v(0.0, 0.5, 1.0)),
            Triangle::new(v(0.3, 0.3, 0.3), v(0.3, 0.3, 0.3), v(0.3, 0.3, 0.3)),
            Triangle::new(v(-0.0, 0.0, -0.0), v(0.0, -0.0, 0.0), v(0.5, 0.5, 0.0)),
            // A sliver with an edge nearly along x.
            Triangle::new(
                v(-0.9, 0.2, 0.3),
                v(0.9, 0.2000001, 0.3),
                v(0.1, 0.2, 0.3000001),
            ),
        ];
        for tri in &triangles {
            let vb = vertex_box(tri);
            assert!(Clip::new(tri, &c).inside(&c), "{tri:?}");
            for axis in 0..3 {
                // Splits through the vertices, the cell's faces, the box's middle and zero;
                // the first puts a triangle flat on `axis` in the split plane.
                let positions = [
                    tri.v0,
                    tri.v1,
                    tri.v2,
                    c.min,
                    c.max,
                    vb.center(),
                    Vec3::ZERO,
                ]
                .map(|p| p[axis].clamp(c.min[axis], c.max[axis]));
                for position in positions {
                    let general = match axis {
                        0 => split_by_clipping_every_face::<0>(tri, &c, position),
                        1 => split_by_clipping_every_face::<1>(tri, &c, position),
                        _ => split_by_clipping_every_face::<2>(tri, &c, position),
                    };
                    let fast = split_clipped_bounds(tri, &c, axis, position);
                    assert_eq!(bits(fast), bits(general), "{tri:?} {axis} {position}");
                }
            }
        }
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
