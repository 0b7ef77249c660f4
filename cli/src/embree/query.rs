//! Closest-hit queries: kdbeam rays into Embree's ray layouts, rtcIntersect1/4/8/16, and
//! Embree's hits back into kdbeam [`Hit`]s.

use embree::sys;
use kdbeam::kernels::lanes::with_flush_to_zero;
use kdbeam::trace::is_traceable;
use kdbeam::{Error, Hit, Ray, Result};
use rayon::prelude::*;

use super::EmbreeScene;

/// The packet widths [`EmbreeScene::intersect_stream`] accepts: rtcIntersect1, 4, 8 and 16.
pub const QUERY_WIDTHS: [usize; 4] = [1, 4, 8, 16];

/// Rays per unit of parallel work: a multiple of every width, so packets never straddle two.
const CHUNK: usize = 1024;

/// Embree's `RTC_INVALID_GEOMETRY_ID`: "no hit" in `geomID`.
const INVALID_ID: u32 = u32::MAX;

impl EmbreeScene {
    /// Closest hits of `rays`, written to `hits[i]` for `rays[i]`, traced with
    /// rtcIntersect`width` on packets of `width` consecutive rays (the last one partly filled).
    /// Parallel over chunks of 1024 rays on the current rayon pool; every chunk runs with
    /// flush-to-zero and denormals-are-zero set, as Embree expects.
    ///
    /// A hit gives Embree's `t`, barycentrics `(u, v)` (weights of the second and third vertex,
    /// as in kdbeam) and primitive id as the triangle. Rays kdbeam cannot trace (non-finite or
    /// zero direction, non-finite origin, `tmin > tmax`, NaN `tmax`) and rays Embree cannot
    /// (`tmin < 0`) are inactive lanes (`valid = 0`) and get [`Hit::NONE`]; so do directions
    /// whose components are all denormal, which are zero under denormals-are-zero. Of two
    /// triangles hit at the same `t`, either may be reported (kdbeam picks the smaller id).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `width` is not 1, 4, 8 or 16 or when
    /// `hits.len() != rays.len()`.
    pub fn intersect_stream(&self, rays: &[Ray], width: usize, hits: &mut [Hit]) -> Result<()> {
        if !QUERY_WIDTHS.contains(&width) {
            return Err(Error::InvalidParameter {
                name: "embree width",
                message: format!("must be 1, 4, 8 or 16, got {width}"),
            });
        }
        if rays.len() != hits.len() {
            return Err(Error::InvalidParameter {
                name: "stream output",
                message: format!("{} outputs for {} rays", hits.len(), rays.len()),
            });
        }
        let chunk = |(rays, hits): (&[Ray], &mut [Hit])| {
            with_flush_to_zero(|| match width {
                1 => self.trace_single(rays, hits),
                4 => self.trace_packets::<sys::RTCRayHit4>(rays, hits),
                8 => self.trace_packets::<sys::RTCRayHit8>(rays, hits),
                _ => self.trace_packets::<sys::RTCRayHit16>(rays, hits),
            })
        };
        rays.par_chunks(CHUNK)
            .zip(hits.par_chunks_mut(CHUNK))
            .for_each(chunk);
        Ok(())
    }

    /// rtcIntersect1 on each ray.
    fn trace_single(&self, rays: &[Ray], hits: &mut [Hit]) {
        let mut context = intersect_context();
        for (ray, hit) in rays.iter().zip(hits) {
            if !is_active(ray) {
                *hit = Hit::NONE;
                continue;
            }
            let mut rh = sys::RTCRayHit {
                ray: sys::RTCRay {
                    org_x: ray.origin.x,
                    org_y: ray.origin.y,
                    org_z: ray.origin.z,
                    tnear: ray.tmin,
                    dir_x: ray.dir.x,
                    dir_y: ray.dir.y,
                    dir_z: ray.dir.z,
                    time: 0.0,
                    tfar: ray.tmax,
                    mask: u32::MAX,
                    id: 0,
                    flags: 0,
                },
                hit: sys::RTCHit {
                    Ng_x: 0.0,
                    Ng_y: 0.0,
                    Ng_z: 0.0,
                    u: 0.0,
                    v: 0.0,
                    primID: INVALID_ID,
                    geomID: INVALID_ID,
                    instID: [INVALID_ID],
                },
            };
            // SAFETY: the scene is committed and alive for `&self`; `context` and `rh` are
            // initialised, properly aligned (RTCRayHit is `align(16)`) locals.
            unsafe { sys::rtcIntersect1(self.handle(), &mut context, &mut rh) };
            *hit = if rh.hit.geomID == INVALID_ID {
                Hit::NONE
            } else {
                Hit {
                    t: rh.ray.tfar,
                    u: rh.hit.u,
                    v: rh.hit.v,
                    triangle: rh.hit.primID,
                }
            };
        }
    }

    /// rtcIntersect`P::WIDTH` on packets of consecutive rays.
    fn trace_packets<P: RayHitPacket>(&self, rays: &[Ray], hits: &mut [Hit]) {
        let mut context = intersect_context();
        let mut packet = P::empty();
        let mut valid = P::Valid::default();
        for (rays, hits) in rays.chunks(P::WIDTH).zip(hits.chunks_mut(P::WIDTH)) {
            let lanes = valid.as_mut();
            lanes.fill(0);
            for (lane, ray) in rays.iter().enumerate() {
                if is_active(ray) {
                    packet.set_ray(lane, ray);
                    lanes[lane] = -1;
                }
            }
            // SAFETY: the scene is committed and alive for `&self`; `packet` and `valid` are
            // initialised, and their types are aligned to the packet width (16, 32 or 64
            // bytes) as rtcIntersect4/8/16 require.
            unsafe { P::intersect(&valid, self.handle(), &mut context, &mut packet) };
            for (lane, hit) in hits.iter_mut().enumerate() {
                *hit = if valid.as_mut()[lane] == 0 {
                    Hit::NONE
                } else {
                    packet.hit(lane)
                };
            }
        }
    }
}

/// Is `ray` traced, or an inactive lane?
#[inline]
fn is_active(ray: &Ray) -> bool {
    is_traceable(ray) && ray.tmin >= 0.0
}

/// Embree's default context (`rtcInitIntersectContext`: incoherent, no filter, no instance).
fn intersect_context() -> sys::RTCIntersectContext {
    sys::RTCIntersectContext {
        flags: sys::RTCIntersectContextFlags::INCOHERENT,
        filter: None,
        instID: [INVALID_ID],
    }
}

/// An Embree SoA ray-and-hit packet of `WIDTH` lanes with its valid mask.
trait RayHitPacket {
    /// Lanes.
    const WIDTH: usize;
    /// The valid mask (-1 traces a lane, 0 skips it), aligned as the packet.
    type Valid: Default + AsMut<[i32]>;
    /// A packet with every lane empty.
    fn empty() -> Self;
    /// Loads `ray` into `lane` and clears its hit.
    fn set_ray(&mut self, lane: usize, ray: &Ray);
    /// The hit of a traced `lane`.
    fn hit(&self, lane: usize) -> Hit;
    /// rtcIntersect`WIDTH`.
    ///
    /// # Safety
    /// `scene` must be a live, committed scene.
    unsafe fn intersect(
        valid: &Self::Valid,
        scene: sys::RTCScene,
        context: &mut sys::RTCIntersectContext,
        packet: &mut Self,
    );
}

macro_rules! ray_hit_packet {
    ($packet:ident, $ray:ident, $hit:ident, $valid:ident, $align:literal, $n:literal, $f:ident) => {
        #[doc = concat!("A valid mask for rtcIntersect", stringify!($n), ", aligned to the packet as Embree requires (an unaligned mask crashes).")]
        #[repr(C, align($align))]
        #[derive(Default)]
        struct $valid([i32; $n]);

        impl AsMut<[i32]> for $valid {
            fn as_mut(&mut self) -> &mut [i32] {
                &mut self.0
            }
        }

        impl RayHitPacket for sys::$packet {
            const WIDTH: usize = $n;
            type Valid = $valid;

            fn empty() -> Self {
                sys::$packet {
                    ray: sys::$ray {
                        org_x: [0.0; $n],
                        org_y: [0.0; $n],
                        org_z: [0.0; $n],
                        tnear: [0.0; $n],
                        dir_x: [0.0; $n],
                        dir_y: [0.0; $n],
                        dir_z: [1.0; $n],
                        time: [0.0; $n],
                        tfar: [0.0; $n],
                        mask: [u32::MAX; $n],
                        id: [0; $n],
                        flags: [0; $n],
                    },
                    hit: sys::$hit {
                        Ng_x: [0.0; $n],
                        Ng_y: [0.0; $n],
                        Ng_z: [0.0; $n],
                        u: [0.0; $n],
                        v: [0.0; $n],
                        primID: [INVALID_ID; $n],
                        geomID: [INVALID_ID; $n],
                        instID: [[INVALID_ID; $n]],
                    },
                }
            }

            #[inline]
            fn set_ray(&mut self, lane: usize, ray: &Ray) {
                let r = &mut self.ray;
                r.org_x[lane] = ray.origin.x;
                r.org_y[lane] = ray.origin.y;
                r.org_z[lane] = ray.origin.z;
                r.tnear[lane] = ray.tmin;
                r.dir_x[lane] = ray.dir.x;
                r.dir_y[lane] = ray.dir.y;
                r.dir_z[lane] = ray.dir.z;
                r.tfar[lane] = ray.tmax;
                self.hit.primID[lane] = INVALID_ID;
                self.hit.geomID[lane] = INVALID_ID;
                self.hit.instID[0][lane] = INVALID_ID;
            }

            #[inline]
            fn hit(&self, lane: usize) -> Hit {
                if self.hit.geomID[lane] == INVALID_ID {
                    Hit::NONE
                } else {
                    Hit {
                        t: self.ray.tfar[lane],
                        u: self.hit.u[lane],
                        v: self.hit.v[lane],
                        triangle: self.hit.primID[lane],
                    }
                }
            }

            #[inline]
            unsafe fn intersect(
                valid: &$valid,
                scene: sys::RTCScene,
                context: &mut sys::RTCIntersectContext,
                packet: &mut Self,
            ) {
                // SAFETY: the caller guarantees the scene; `valid` (repr align) and `packet`
                // (Embree's own aligned SoA type) are live and aligned to the width.
                unsafe { sys::$f(valid.0.as_ptr(), scene, context, packet) }
            }
        }
    };
}

ray_hit_packet!(RTCRayHit4, RTCRay4, RTCHit4, Valid4, 16, 4, rtcIntersect4);
ray_hit_packet!(RTCRayHit8, RTCRay8, RTCHit8, Valid8, 32, 8, rtcIntersect8);
ray_hit_packet!(
    RTCRayHit16,
    RTCRay16,
    RTCHit16,
    Valid16,
    64,
    16,
    rtcIntersect16
);
