//! The split-plane counts and costs on every ISA against plain loops over boxes and planes:
//! flat boxes, shared faces, planes on the cell's faces, `±0`, and NaN padding.
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::Rng;
use kdbeam_kernels::lanes::{Dispatch, MAX_WIDTH};
use kdbeam_kernels::split_planes::{
    cheapest_plane, count_planes, AxisCell, AxisPlanes, CheapestPlane,
};
use kdbeam_kernels::{Isa, LaneTask, Lanes};

/// Boxes' faces on one axis, and the planes at those faces (padded with NaN to a multiple
/// of the widest lanes).
struct Case {
    lo: Vec<f32>,
    hi: Vec<f32>,
    flat: bool,
    pos: Vec<f32>,
}

/// `n` boxes with faces on a coarse grid (so that faces are shared), some flat, one at `-0.0`.
fn case(rng: &mut Rng, n: usize) -> Case {
    let grid = |rng: &mut Rng| (rng.below(9) as f32 - 4.0) * 0.25;
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for i in 0..n {
        let (a, b) = (grid(rng), grid(rng));
        let (a, b) = if rng.chance(0.2) {
            (a, a)
        } else {
            (a.min(b), a.max(b))
        };
        let a = if i == 0 { -0.0 } else { a };
        lo.push(a);
        hi.push(b.max(a));
    }
    let flat = lo.iter().zip(&hi).any(|(a, b)| a == b);
    let mut pos: Vec<f32> = lo.iter().chain(&hi).copied().collect();
    pos.resize(pos.len().next_multiple_of(MAX_WIDTH), f32::NAN);
    Case { lo, hi, flat, pos }
}

/// The counts by definition, one plane and one box at a time.
fn reference_counts(c: &Case) -> [Vec<f32>; 3] {
    let count = |f: &dyn Fn(f32, f32, f32) -> bool, p: f32| {
        c.lo.iter()
            .zip(&c.hi)
            .filter(|&(&lo, &hi)| f(lo, hi, p))
            .count() as f32
    };
    let below = c
        .pos
        .iter()
        .map(|&p| count(&|lo, _, p| lo < p, p))
        .collect();
    let above = c
        .pos
        .iter()
        .map(|&p| count(&|_, hi, p| hi > p, p))
        .collect();
    let planar = c
        .pos
        .iter()
        .map(|&p| count(&|lo, hi, p| lo == p && hi == p, p))
        .collect();
    [below, above, planar]
}

/// The cheapest plane by definition: planes in index order, a plane replacing the best when it
/// weighs less, or the same at a lower position (so the first index of a repeated position).
fn reference_cheapest(planes: &AxisPlanes<'_>, cell: &AxisCell) -> Option<CheapestPlane> {
    let weighted = |pb: f32, pa: f32, nb: f32, na: f32| {
        let lambda = if nb == 0.0 || na == 0.0 {
            cell.empty_factor
        } else {
            1.0
        };
        lambda * (pb * nb + pa * na)
    };
    let mut best: Option<(CheapestPlane, f32)> = None;
    for (index, &p) in planes.pos.iter().enumerate() {
        if !(p > cell.lo && p < cell.hi) {
            continue;
        }
        let (pb, pa) = (
            cell.base + cell.slope * (p - cell.lo),
            cell.base + cell.slope * (cell.hi - p),
        );
        let (nb, na, np) = (
            planes.below[index],
            planes.above[index],
            planes.planar.map_or(0.0, |planar| planar[index]),
        );
        let (below, above) = (weighted(pb, pa, nb + np, na), weighted(pb, pa, nb, na + np));
        let (weight, planar_below) = if below <= above {
            (below, true)
        } else {
            (above, false)
        };
        if best.is_none_or(|(b, bp)| weight < b.weight || (weight == b.weight && p < bp)) {
            best = Some((
                CheapestPlane {
                    index,
                    weight,
                    planar_below,
                },
                p,
            ));
        }
    }
    best.map(|(b, _)| b)
}

struct Count<'a>(&'a Case);

impl LaneTask for Count<'_> {
    type Output = [Vec<f32>; 3];
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> [Vec<f32>; 3] {
        let c = self.0;
        let mut out = [(); 3].map(|_| vec![-1.0; c.pos.len()]);
        let [below, above, planar] = &mut out;
        let spans = c.lo.iter().copied().zip(c.hi.iter().copied());
        count_planes(l, spans, c.flat, &c.pos, below, above, planar);
        out
    }
}

struct Cheapest<'a>(AxisPlanes<'a>, AxisCell);

impl LaneTask for Cheapest<'_> {
    type Output = Option<CheapestPlane>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Option<CheapestPlane> {
        cheapest_plane(l, &self.0, &self.1)
    }
}

#[test]
fn every_isa_counts_and_costs_as_the_definitions() {
    let mut rng = Rng::new(11);
    let mut cheapest_found = 0;
    for n in (1..=40).chain([64, 65]) {
        for _ in 0..8 {
            let c = case(&mut rng, n);
            let counts = reference_counts(&c);
            let planes = AxisPlanes {
                pos: &c.pos,
                below: &counts[0],
                above: &counts[1],
                // Both forms when no box is flat: zeros, and none.
                planar: (c.flat || rng.chance(0.5)).then_some(&counts[2][..]),
            };
            // Cells reaching past the boxes, and cells whose faces are box faces (those planes
            // are not strictly inside, so never chosen).
            let (lo, hi) = if rng.chance(0.5) {
                (-1.5, 1.5)
            } else {
                (-0.5, 0.75)
            };
            let cell = AxisCell {
                base: rng.range(0.1, 0.5),
                slope: rng.range(0.1, 1.0),
                lo,
                hi,
                empty_factor: rng.range(0.2, 1.0),
            };
            let expected = reference_cheapest(&planes, &cell);
            cheapest_found += usize::from(expected.is_some());
            for isa in Isa::available() {
                // NaN planes count nothing; without flat boxes, nothing is planar.
                let got = Dispatch::new(isa).unwrap().run(Count(&c));
                assert_eq!(got, counts, "{isa}, {n} boxes");
                // The same plane; with faces on a coarse grid, positions repeat, and which of a
                // position's indices comes back is left open (their counts are the same).
                let plane = |c: Option<CheapestPlane>| {
                    c.map(|c| (planes.pos[c.index], c.weight, c.planar_below))
                };
                let cheapest = Dispatch::new(isa).unwrap().run(Cheapest(planes, cell));
                assert_eq!(plane(cheapest), plane(expected), "{isa}, {n} boxes");
                if let (Some(got), Some(want)) = (cheapest, expected) {
                    for list in &counts {
                        assert_eq!(list[got.index], list[want.index], "{isa}, {n} boxes");
                    }
                }
            }
        }
    }
    assert!(cheapest_found > 200, "{cheapest_found}");
}

#[test]
fn a_span_with_no_plane_strictly_inside_has_no_cheapest() {
    let mut pos = [f32::NAN; MAX_WIDTH];
    pos[..2].copy_from_slice(&[0.0, 1.0]);
    let counts = [1.0; MAX_WIDTH];
    let planes = AxisPlanes {
        pos: &pos,
        below: &counts,
        above: &counts,
        planar: Some(&counts),
    };
    let cell = AxisCell {
        base: 0.5,
        slope: 1.0,
        lo: 0.0,
        hi: 1.0,
        empty_factor: 0.5,
    };
    for isa in Isa::available() {
        assert_eq!(
            Dispatch::new(isa).unwrap().run(Cheapest(planes, cell)),
            None,
            "{isa}"
        );
    }
}
