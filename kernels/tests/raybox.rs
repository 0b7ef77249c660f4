//! Ray-box culling (Nah et al.): every ISA against a scalar reference, special floats (NaN
//! keeps a triangle), and no hit of the Kensler–Shirley and watertight tests ever culled when
//! the segment ends at the hit's own `t` or holds it.
#![cfg(feature = "std")] // `Dispatch::available` detects the CPU.

mod common;

use common::{barycentric_point, Rng, SPECIALS};
use kdbeam_kernels::intersect::{kensler_shirley, watertight::WatertightRay};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::raybox::{overlapping, segment_box, BoxBlock};
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, KsTriangle, LaneTask, Lanes, Ray, Triangle, TriangleBlock, Vec3};

/// The lanes of every vector of `boxes` that overlap `segment`, as one `BLOCK`-bit mask.
struct Overlap<'a> {
    segment: &'a Aabb,
    boxes: &'a BoxBlock,
}

impl LaneTask for Overlap<'_> {
    type Output = u32;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> u32 {
        (0..BLOCK)
            .step_by(L::WIDTH)
            .map(|first| overlapping(l, self.segment, self.boxes, first) << first)
            .fold(0, |a, b| a | b)
    }
}

/// The rule written with Rust's comparisons: kept unless strictly apart on an axis.
fn reference(segment: &Aabb, boxes: &BoxBlock) -> u32 {
    (0..BLOCK)
        .filter(|&i| {
            !(0..3).any(|a| boxes.min[a][i] > segment.max[a] || boxes.max[a][i] < segment.min[a])
        })
        .fold(0, |m, i| m | 1 << i)
}

fn coordinate(rng: &mut Rng) -> f32 {
    if rng.chance(0.1) {
        SPECIALS[rng.below(SPECIALS.len())]
    } else {
        rng.range(-2.0, 2.0)
    }
}

fn point(rng: &mut Rng) -> Vec3 {
    Vec3::new(coordinate(rng), coordinate(rng), coordinate(rng))
}

#[test]
fn every_isa_equals_the_scalar_rule_with_special_floats() {
    let mut rng = Rng::new(20);
    for _ in 0..3000 {
        let mut boxes = BoxBlock::EMPTY;
        for lane in 0..BLOCK {
            if rng.chance(0.9) {
                let (p, q) = (point(&mut rng), point(&mut rng));
                boxes.set(lane, &Aabb::new(p.min(q), p.max(q)));
            }
        }
        let segment = segment_box(
            point(&mut rng),
            point(&mut rng),
            coordinate(&mut rng),
            coordinate(&mut rng),
        );
        let want = reference(&segment, &boxes);
        for d in Dispatch::available() {
            let got = d.run(Overlap {
                segment: &segment,
                boxes: &boxes,
            });
            assert_eq!(got, want, "{:?} {segment:?}", d.isa());
        }
    }
}

#[test]
fn nan_and_infinite_segments_keep_every_triangle() {
    let mut boxes = BoxBlock::EMPTY;
    for lane in 0..BLOCK {
        let c = Vec3::splat(lane as f32);
        boxes.set(lane, &Aabb::new(c, c + 0.5));
    }
    let all = (1u32 << BLOCK) - 1;
    for (o, d, t0, t1) in [
        (Vec3::ZERO, Vec3::X, 0.0, f32::NAN),
        (Vec3::ZERO, Vec3::X, f32::NEG_INFINITY, 1.0),
        (Vec3::ZERO, Vec3::ZERO, 0.0, f32::INFINITY),
        (Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, 0.0, 1.0),
        (Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), 0.0, 1.0),
    ] {
        let segment = segment_box(o, d, t0, t1);
        for dispatch in Dispatch::available() {
            let got = dispatch.run(Overlap {
                segment: &segment,
                boxes: &boxes,
            });
            assert_eq!(got, all, "{:?} {o} {d} {t0} {t1}", dispatch.isa());
        }
    }
    // A NaN bound of a triangle's box keeps it for any segment.
    let mut nan = BoxBlock::EMPTY;
    nan.set(3, &Aabb::new(Vec3::splat(f32::NAN), Vec3::splat(f32::NAN)));
    let far = segment_box(Vec3::ZERO, Vec3::X, 0.0, 1.0);
    for dispatch in Dispatch::available() {
        let got = dispatch.run(Overlap {
            segment: &far,
            boxes: &nan,
        });
        assert_eq!(got, 1 << 3, "{:?}", dispatch.isa());
    }
}

#[test]
fn touching_boxes_and_axis_parallel_segments_are_kept() {
    let mut boxes = BoxBlock::EMPTY;
    boxes.set(
        0,
        &Aabb::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 1.0)),
    );
    boxes.set(
        1,
        &Aabb::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
    );
    boxes.set(
        2,
        &Aabb::new(Vec3::new(1.5, 1.5, 1.5), Vec3::new(2.0, 2.0, 2.0)),
    );
    // Along x on the plane y = 0, z = 0, ending exactly at x = 1: touches boxes 0 and 1.
    for (d, t1) in [(Vec3::X, 1.0), (Vec3::new(-0.0, 0.0, 0.0) + Vec3::X, 1.0)] {
        let segment = segment_box(Vec3::ZERO, d, 0.0, t1);
        assert_eq!(reference(&segment, &boxes), 0b11);
        for dispatch in Dispatch::available() {
            let got = dispatch.run(Overlap {
                segment: &segment,
                boxes: &boxes,
            });
            assert_eq!(got, 0b11, "{:?}", dispatch.isa());
        }
    }
}

/// A box that holds part of `t` (a random sub-box of its bounds, grown a little on some sides).
fn leaf_around(rng: &mut Rng, t: &Triangle) -> Aabb {
    let own = Aabb::from_points([t.v0, t.v1, t.v2]);
    let pick = |rng: &mut Rng, lo: f32, hi: f32| {
        let (a, b) = (rng.range(lo - 0.1, hi + 0.1), rng.range(lo - 0.1, hi + 0.1));
        (a.min(b), a.max(b))
    };
    let (x, y, z) = (
        pick(rng, own.min.x, own.max.x),
        pick(rng, own.min.y, own.max.y),
        pick(rng, own.min.z, own.max.z),
    );
    Aabb::new(Vec3::new(x.0, y.0, z.0), Vec3::new(x.1, y.1, z.1))
}

#[test]
fn hits_in_the_leaf_are_never_culled() {
    // A hit at a point of the leaf, found by either intersector: the segment from an earlier
    // `t` to the hit's own `t` (the closest hit so far shrinking the box), and one around it,
    // both keep the triangle. Incidence down to |cos| = 0.02 (the range `SEGMENT_EPS` covers);
    // origins far from the triangle and coordinates offset far from the origin.
    let mut rng = Rng::new(7);
    let mut checked = 0;
    for i in 0..40_000 {
        let offset = if i % 4 == 0 {
            rng.in_cube(1000.0)
        } else {
            Vec3::ZERO
        };
        let scale = [1.0f32, 1e-3, 1e3][i % 3];
        let base = common::well_shaped_triangle(&mut rng);
        let t = Triangle::new(
            base.v0 * scale + offset,
            base.v1 * scale + offset,
            base.v2 * scale + offset,
        );
        let leaf = leaf_around(&mut rng, &Triangle::new(base.v0, base.v1, base.v2));
        let leaf = Aabb::new(leaf.min * scale + offset, leaf.max * scale + offset);
        let (u, v) = (rng.unit(), rng.unit());
        let (u, v) = if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        };
        let target = barycentric_point(&t, u, v);
        if !leaf.contains(target) {
            continue;
        }
        let n = (t.v1 - t.v0).cross(t.v2 - t.v0).normalize();
        let origin = target + rng.on_sphere() * scale * rng.range(0.5, 40.0);
        let direction = (target - origin) * rng.range(0.01, 100.0);
        if n.dot(direction.normalize()).abs() < 0.02 {
            continue;
        }
        let ray = Ray::new(origin, direction);
        let block = TriangleBlock::new(t.v0, [(t, 0)]);
        let boxes = BoxBlock::clipped(&block, 1, &leaf);
        let ks = kensler_shirley::intersect(&ray, &KsTriangle::from(&t), 0.0, f32::INFINITY);
        let wt = WatertightRay::new(&ray).intersect(&t, 0.0, f32::INFINITY);
        for hit_t in [ks.map(|h| h.t), wt.map(|h| h.t)].into_iter().flatten() {
            checked += 1;
            for segment in [
                segment_box(origin, direction, hit_t * rng.range(0.0, 1.0), hit_t),
                segment_box(origin, direction, hit_t, hit_t),
                segment_box(origin, direction, hit_t * 0.999, hit_t * 1.001),
            ] {
                for dispatch in Dispatch::available() {
                    let got = dispatch.run(Overlap {
                        segment: &segment,
                        boxes: &boxes,
                    });
                    assert_eq!(
                        got & 1,
                        1,
                        "{:?} {t:?} {leaf:?} {ray:?} t {hit_t}",
                        dispatch.isa()
                    );
                }
            }
        }
    }
    assert!(checked > 5_000, "{checked}");
}

#[test]
fn clipped_boxes_lie_in_the_widened_leaf_and_padding_is_empty() {
    let mut rng = Rng::new(3);
    for _ in 0..500 {
        let tris: Vec<(Triangle, u32)> = (0..rng.below(BLOCK) + 1)
            .map(|i| (common::well_shaped_triangle(&mut rng), i as u32))
            .collect();
        let leaf = leaf_around(&mut rng, &tris[0].0);
        let block = TriangleBlock::new(tris[0].0.v0, tris.iter().copied());
        let boxes = BoxBlock::clipped(&block, tris.len(), &leaf);
        let slack = (leaf.min.abs().max(leaf.max.abs()) + leaf.extent()) / 16_384.0;
        for lane in 0..BLOCK {
            let b = boxes.get(lane);
            if lane >= tris.len() {
                assert!(b.is_empty() && b.min == Vec3::INFINITY, "{lane}");
                continue;
            }
            let t = tris[lane].0;
            let own = Aabb::from_points([t.v0, t.v1, t.v2]);
            if b.is_empty() {
                assert!(own.intersection(leaf).is_empty());
                continue;
            }
            assert!(own.contains_box(&b), "{own:?} {b:?}");
            assert!(b.min.cmpge(leaf.min - slack).all() && b.max.cmple(leaf.max + slack).all());
        }
    }
}
