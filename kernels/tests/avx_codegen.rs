//! A kernel compiled through `Avx::run`, for `scripts/check_avx_codegen.sh` to disassemble: its
//! `#[target_feature]` entry point must contain 256-bit (`ymm`) and FMA instructions even though
//! the crate is built for baseline x86-64. The test itself checks the probe computes the right
//! thing on every ISA. This binary defines no other `LaneTask`, so it holds exactly one instance
//! of the entry point.
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::lanes_of;
use kdbeam_kernels::intersect::watertight::WatertightLanes;
use kdbeam_kernels::intersect::LaneRays;
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Isa, LaneF32, LaneTask, Lanes, Triangle, Vec3};

/// `x·y + x` and a watertight test of rays straight down onto the unit triangle.
struct AvxCodegenProbe {
    x: f32,
    y: f32,
}

impl LaneTask for AvxCodegenProbe {
    type Output = (Vec<f32>, Vec<f32>);

    // Inlined into the `#[target_feature]` entry point, as `LaneTask` requires: otherwise it
    // would be compiled for the baseline ISA and call every intrinsic out of line.
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Vec<f32>, Vec<f32>) {
        let x = l.splat(self.x);
        let fma = x.mul_add(l.splat(self.y), x);
        let rays = LaneRays::<L>::new(
            [l.splat(0.25), l.splat(0.25), l.splat(2.0)],
            [l.splat(0.0), l.splat(0.0), l.splat(-1.0)],
        );
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let hits = WatertightLanes::new(l, &rays).intersect(l, &tri, l.splat(0.0), l.splat(9.0));
        let t = L::F32::select(hits.mask, hits.t, l.splat(-1.0));
        (lanes_of(l, fma), lanes_of(l, t))
    }
}

#[test]
fn the_probe_computes_the_same_on_every_isa() {
    for isa in Isa::available() {
        let (fma, t) = Dispatch::new(isa)
            .expect("available")
            .run(AvxCodegenProbe { x: 3.0, y: 0.5 });
        assert_eq!(fma, vec![4.5; isa.width()], "{isa}");
        assert_eq!(t, vec![2.0; isa.width()], "{isa}");
    }
}
