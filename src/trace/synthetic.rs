//! The synthetic benchmark: the leaf kernel of [`super::leaf`] timed on a
//! [`SyntheticCell`] (Alexander Reshetov, *Faster Ray Packets – Triangle Intersection through
//! Vertex Culling*, IEEE Symposium on Interactive Ray Tracing (RT07), 2007, section 3.1: cycles
//! per ray–triangle test).

use kdbeam_kernels::lanes::{tsc, Dispatch};
use kdbeam_kernels::HitPacket;

use super::culling::Culling;
use super::leaf::{trace_leaf, Leaf};
use crate::kdtree::LeafTriangles;
use crate::scene::synthetic::SyntheticCell;

impl<'a> From<&'a SyntheticCell> for Leaf<'a> {
    /// The cell as one kd-tree leaf: its triangles, the cell as the leaf box, its scene bound.
    fn from(cell: &'a SyntheticCell) -> Self {
        Leaf {
            triangles: LeafTriangles::new(&cell.blocks, cell.triangles.len()),
            bounds: &cell.bounds,
            scene_bound: cell.scene_bound,
        }
    }
}

/// One culling setting measured on one ISA.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// Median over the repetitions of TSC reference cycles per potential ray–triangle test
    /// (cycles / (rays × triangles)); NaN where there is no TSC (targets other than x86-64).
    pub cycles_per_test: f64,
    /// Ray–triangle tests performed per repetition (rays × surviving triangles).
    pub tests: u64,
    /// Ray–triangle tests without culling (rays × triangles).
    pub potential_tests: u64,
    /// Rays with a hit.
    pub hit_rays: u64,
}

impl Measurement {
    /// Share of the potential tests culling eliminated, in percent.
    #[must_use]
    pub fn eliminated_percent(&self) -> f64 {
        100.0 * (1.0 - self.tests as f64 / self.potential_tests.max(1) as f64)
    }
}

/// Traces every packet of `cell` with `culling` on `dispatch`'s ISA `reps` times (at least
/// once) and reports the median cycles per test, with the closest hits of the last repetition in
/// `hits` (resized to one per packet).
pub fn measure(
    cell: &SyntheticCell,
    dispatch: Dispatch,
    culling: Culling,
    reps: usize,
    hits: &mut Vec<HitPacket>,
) -> Measurement {
    hits.resize(cell.packets.len(), HitPacket::default());
    let leaf = Leaf::from(cell);
    let potential = (cell.rays() * cell.triangles.len()) as u64;
    let mut cycles = Vec::with_capacity(reps.max(1));
    let mut tests = 0;
    for _ in 0..reps.max(1) {
        let start = tsc();
        tests = trace_leaf(dispatch, culling, leaf, &cell.packets, hits);
        let per_test = match (start, tsc()) {
            (Some(a), Some(b)) => b.wrapping_sub(a) as f64 / potential.max(1) as f64,
            _ => f64::NAN,
        };
        cycles.push(per_test);
    }
    cycles.sort_by(f64::total_cmp);
    let hit_rays = hits
        .iter()
        .zip(&cell.packets)
        .map(|(h, p)| {
            h.triangle[..p.len()]
                .iter()
                .filter(|&&id| id != u32::MAX)
                .count() as u64
        })
        .sum();
    Measurement {
        cycles_per_test: cycles[cycles.len() / 2],
        tests,
        potential_tests: potential,
        hit_rays,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::synthetic::{generate, SyntheticParams};
    use crate::trace::Planes;

    /// Every ray's closest hit with culling is the unculled one: same triangle, same `t`,
    /// `u` and `v` bit for bit (the same Kensler–Shirley arithmetic runs on the survivors, so
    /// no tolerance).
    #[test]
    fn culling_keeps_every_closest_hit() {
        let cullings = [
            Culling::planes(Planes::Four, false),
            Culling::planes(Planes::Six, false),
            Culling::planes(Planes::Four, true),
            Culling::FULL,
            Culling::FULL.with_aperture_first(false),
        ];
        let mut eliminated = 0.0f64;
        for (ratio, packet_n, jitter) in [
            (1.0, 8, 0.04),
            (4.0, 8, 0.04),
            (10.0, 8, 0.01),
            (4.0, 2, 0.04),
            (4.0, 4, 0.3),
            (2.0, 16, 1.0),
        ] {
            let p = SyntheticParams {
                ratio,
                packet_n,
                jitter,
                packets: 64,
                seed: 9,
                ..Default::default()
            };
            let cell = generate(&p).unwrap();
            for dispatch in Dispatch::available() {
                let mut base = Vec::new();
                let b = measure(&cell, dispatch, Culling::NONE, 1, &mut base);
                assert_eq!(b.tests, b.potential_tests);
                assert!(b.hit_rays > 0, "{p:?}");
                for c in cullings {
                    let mut culled = Vec::new();
                    let m = measure(&cell, dispatch, c, 1, &mut culled);
                    eliminated = eliminated.max(m.eliminated_percent());
                    for (k, (x, y)) in base.iter().zip(&culled).enumerate() {
                        for i in 0..cell.packets[k].len() {
                            let what = format!("{p:?} {dispatch} {c} packet {k} ray {i}");
                            assert_eq!(x.triangle[i], y.triangle[i], "{what}");
                            assert_eq!(x.t[i].to_bits(), y.t[i].to_bits(), "{what}");
                            assert_eq!(x.u[i].to_bits(), y.u[i].to_bits(), "{what}");
                            assert_eq!(x.v[i].to_bits(), y.v[i].to_bits(), "{what}");
                        }
                    }
                }
            }
        }
        // The culling did cull (small triangles, narrow packets: most of them).
        assert!(eliminated > 50.0, "{eliminated}");
    }
}
