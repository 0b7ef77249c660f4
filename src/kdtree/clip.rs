//! "Perfect splits" (Wald & Havran 2006, §4.3; Havran 2000): the boxes of the parts of a
//! triangle in the two halves of a split cell, by Sutherland–Hodgman clipping of the triangle
//! against the cell's six planes and then against each side of the split plane. Only the faces
//! the triangle's vertex box crosses are clipped against (none for a triangle inside the cell,
//! the common case), and the last step, against the split plane, keeps only the span of the
//! points it would make.
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

use kdbeam_kernels::{Aabb, DVec3, Triangle};

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
pub(super) fn split_clipped_bounds(
    tri: &Triangle,
    cell: &Aabb,
    axis: usize,
    position: f32,
) -> [Option<Aabb>; 2] {
    let (mut below, mut above) = (*cell, *cell);
    below.max[axis] = position;
    above.min[axis] = position;
    let clip = Clip::new(tri, cell);
    let triangle = [tri.v0, tri.v1, tri.v2].map(DVec3::from);
    // The common case is a triangle inside the cell: the clip to the cell is a no-op.
    let poly = match clip.to_cell(&triangle, cell) {
        None => return [None, None],
        Some(Err(Overflow)) => return [fallback(tri, &below), fallback(tri, &above)],
        Some(Ok(None)) => None,
        Some(Ok(Some(poly))) => Some(poly),
    };
    let verts = poly.as_ref().map_or(&triangle[..], |p| &p.verts[..p.len]);
    let plane = f64::from(position);
    let [below_span, above_span] =
        split_spans(verts, axis, plane + clip.margin, plane - clip.margin);
    [
        below_span.and_then(|(lo, hi)| clip.rounded(lo, hi, &below)),
        above_span.and_then(|(lo, hi)| clip.rounded(lo, hi, &above)),
    ]
}

/// A triangle being clipped to a cell grown by the margin, in f64.
struct Clip {
    /// The triangle's own box.
    vertex_box: Aabb,
    /// The margin: [`MARGIN`] times the largest coordinate of the triangle and the cell.
    margin: f64,
    /// The grown cell's corners.
    lo: DVec3,
    hi: DVec3,
}

/// A convex polygon of at most [`MAX_POLYGON`] vertices.
#[derive(Clone, Copy)]
struct Polygon {
    verts: [DVec3; MAX_POLYGON],
    len: usize,
}

/// Rounding made a clipped polygon non-convex (it outgrew [`MAX_POLYGON`]).
struct Overflow;

impl Clip {
    fn new(tri: &Triangle, cell: &Aabb) -> Self {
        let vertex_box = vertex_box(tri);
        // The largest |coordinate| of the vertices is that of their box's corners (exact).
        let magnitude = [vertex_box.min, vertex_box.max, cell.min, cell.max]
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
        let margin = f64::from(magnitude) * MARGIN;
        let (cmin, cmax) = (DVec3::from(cell.min), DVec3::from(cell.max));
        Clip {
            vertex_box,
            margin,
            lo: cmin - margin,
            hi: cmax + margin,
        }
    }

    /// The triangle clipped to the grown `cell`: `None` if nothing is left, `Err` on overflow,
    /// `Ok(None)` if the triangle lies inside `cell` (no vertex is cut off).
    ///
    /// A face the triangle's box does not cross is skipped without looking at the polygon:
    /// clipped points lie in that box but for f64 rounding, far smaller than the margin.
    fn to_cell(
        &self,
        triangle: &[DVec3; 3],
        cell: &Aabb,
    ) -> Option<Result<Option<Polygon>, Overflow>> {
        let vb = &self.vertex_box;
        if cell.min.cmple(vb.min).all() && vb.max.cmple(cell.max).all() {
            return Some(Ok(None));
        }
        let mut poly = Polygon {
            verts: [DVec3::ZERO; MAX_POLYGON],
            len: 3,
        };
        poly.verts[..3].copy_from_slice(triangle);
        for axis in 0..3 {
            let faces = [
                (self.lo[axis], true, vb.min[axis] < cell.min[axis]),
                (self.hi[axis], false, vb.max[axis] > cell.max[axis]),
            ];
            for (plane, keep_above, crossed) in faces {
                if !crossed {
                    continue;
                }
                if let Err(overflow) = poly.clip(axis, plane, keep_above) {
                    return Some(Err(overflow));
                }
                if poly.len == 0 {
                    return None;
                }
            }
        }
        Some(Ok(Some(poly)))
    }

    /// The f32 box of `[pmin, pmax]` rounded outward by the margin, within the triangle's own
    /// box and `cell`; `None` if empty.
    fn rounded(&self, pmin: DVec3, pmax: DVec3, cell: &Aabb) -> Option<Aabb> {
        let exact = self.vertex_box.intersection(*cell);
        let mut b = Aabb::EMPTY;
        for axis in 0..3 {
            b.min[axis] = round_down(pmin[axis] - self.margin).max(exact.min[axis]);
            b.max[axis] = round_up(pmax[axis] + self.margin).min(exact.max[axis]);
        }
        (!b.is_empty()).then_some(b)
    }
}

impl Polygon {
    /// Clips to the half-space `p[axis] >= plane` (`keep_above`) or `<= plane`, in place; a
    /// no-op when every vertex is inside.
    fn clip(&mut self, axis: usize, plane: f64, keep_above: bool) -> Result<(), Overflow> {
        let inside = |p: DVec3| {
            if keep_above {
                p[axis] - plane
            } else {
                plane - p[axis]
            }
        };
        if self.verts[..self.len].iter().all(|&p| inside(p) >= 0.0) {
            return Ok(());
        }
        let mut out = [DVec3::ZERO; MAX_POLYGON];
        let n =
            clip_polygon(&self.verts[..self.len], &mut out, axis, plane, inside).ok_or(Overflow)?;
        self.verts = out;
        self.len = n;
        Ok(())
    }
}

/// The spans of the parts of convex polygon `verts` where `p[axis] <= below_plane` and where
/// `p[axis] >= above_plane`: two Sutherland–Hodgman steps of [`clip_polygon`] in one pass,
/// with their points computed the same way but only their spans kept; `None` for a part with
/// nothing left.
fn split_spans(
    verts: &[DVec3],
    axis: usize,
    below_plane: f64,
    above_plane: f64,
) -> [Option<(DVec3, DVec3)>; 2] {
    let planes = [below_plane, above_plane];
    // Signed distances inside each half-space.
    let inside = |p: DVec3| [below_plane - p[axis], p[axis] - above_plane];
    let mut spans = [(DVec3::INFINITY, DVec3::NEG_INFINITY); 2];
    let mut any = [false; 2];
    for (i, &a) in verts.iter().enumerate() {
        let b = verts[(i + 1) % verts.len()];
        let (da, db) = (inside(a), inside(b));
        for side in 0..2 {
            let (span, da, db) = (&mut spans[side], da[side], db[side]);
            if da >= 0.0 {
                *span = (span.0.min(a), span.1.max(a));
                any[side] = true;
            }
            if (da >= 0.0) != (db >= 0.0) {
                let mut p = a + (b - a) * (da / (da - db));
                p[axis] = planes[side];
                *span = (span.0.min(p), span.1.max(p));
                any[side] = true;
            }
        }
    }
    [0, 1].map(|side| any[side].then_some(spans[side]))
}

/// One Sutherland–Hodgman step: the part of polygon `poly` where `inside(p) >= 0`, written to
/// `out`. Crossing points get their `axis` coordinate set to `plane` exactly. Returns the new
/// vertex count, or `None` if it would not fit `out`.
fn clip_polygon(
    poly: &[DVec3],
    out: &mut [DVec3; MAX_POLYGON],
    axis: usize,
    plane: f64,
    inside: impl Fn(DVec3) -> f64,
) -> Option<usize> {
    let mut n = 0;
    let mut push = |p: DVec3| {
        let slot = out.get_mut(n)?;
        *slot = p;
        n += 1;
        Some(())
    };
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (inside(a), inside(b));
        if da >= 0.0 {
            push(a)?;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let mut p = a + (b - a) * (da / (da - db));
            p[axis] = plane;
            push(p)?;
        }
    }
    Some(n)
}

/// The triangle's box ∩ the cell: conservative when the clip cannot be trusted.
fn fallback(tri: &Triangle, cell: &Aabb) -> Option<Aabb> {
    let b = vertex_box(tri).intersection(*cell);
    (!b.is_empty()).then_some(b)
}

fn vertex_box(tri: &Triangle) -> Aabb {
    Aabb::from_points([tri.v0, tri.v1, tri.v2])
}

/// The largest f32 `<= x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        next_toward_neg_inf(f)
    } else {
        f
    }
}

/// The smallest f32 `>= x`.
fn round_up(x: f64) -> f32 {
    -round_down(-x)
}

/// The next f32 below finite `f` (`f32::next_down` is newer than the crate's MSRV).
fn next_toward_neg_inf(f: f32) -> f32 {
    let bits = f.to_bits();
    if f == 0.0 {
        -f32::from_bits(1)
    } else if f > 0.0 {
        f32::from_bits(bits - 1)
    } else {
        f32::from_bits(bits + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kdbeam_kernels::Vec3;

    fn cell(min: [f32; 3], max: [f32; 3]) -> Aabb {
        Aabb::new(Vec3::from(min), Vec3::from(max))
    }

    /// The box of `tri ∩ cell` by the same steps as [`split_clipped_bounds`], without a split.
    fn clipped_bounds(tri: &Triangle, cell: &Aabb) -> Option<Aabb> {
        let clip = Clip::new(tri, cell);
        let triangle = [tri.v0, tri.v1, tri.v2].map(DVec3::from);
        let verts = match clip.to_cell(&triangle, cell)? {
            Err(Overflow) => return fallback(tri, cell),
            Ok(None) => triangle.to_vec(),
            Ok(Some(poly)) => poly.verts[..poly.len].to_vec(),
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

    #[test]
    fn rounding_is_outward() {
        // 0.1f32 is just above 0.1.
        assert_eq!(round_up(0.1), 0.1f32);
        assert_eq!(round_down(0.1), next_toward_neg_inf(0.1f32));
        assert!(f64::from(round_down(0.1)) <= 0.1 && f64::from(round_up(0.1)) >= 0.1);
        assert_eq!(round_down(-0.0), 0.0);
        assert!(next_toward_neg_inf(0.0) < 0.0 && next_toward_neg_inf(-1.0) < -1.0);
    }
}
