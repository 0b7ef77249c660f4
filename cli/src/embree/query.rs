//! Closest-hit and any-hit queries: kdbeam rays into Embree's ray layouts, rtcIntersect and
//! rtcOccluded 1/4/8/16 and the stream calls rtcIntersect1M/rtcOccluded1M in a chosen intersect
//! context, and Embree's answers back into kdbeam [`Hit`]s and occlusion flags.

use embree::sys;
use kdbeam::kernels::lanes::with_flush_to_zero;
use kdbeam::trace::is_traceable;
use kdbeam::{Error, Hit, Ray, Result};
use rayon::prelude::*;

use super::EmbreeScene;

/// The packet widths [`EmbreeRays::new`] accepts: rtcIntersect1, 4, 8 and 16.
pub const QUERY_WIDTHS: [usize; 4] = [1, 4, 8, 16];

/// Rays per unit of parallel work: a multiple of every width, so packets never straddle two.
const CHUNK: usize = 1024;

/// Embree's `RTC_INVALID_GEOMETRY_ID`: "no hit" in `geomID`.
const INVALID_ID: u32 = u32::MAX;

/// The intersect context flag, which decides how Embree 3's packet kernels traverse.
///
/// With [`Context::Coherent`] rtcIntersect4/8/16 take their frustum path (the packet's bounds
/// tested against a node's child boxes at once), made for camera packets; with
/// [`Context::Incoherent`] (`rtcInitIntersectContext`'s default) they trace lane by lane,
/// which suits random and secondary rays. A comparison of camera packets against the
/// incoherent context slows Embree down, so every Embree figure names its context.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Context {
    /// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`.
    Coherent,
    /// `RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT`.
    Incoherent,
}

impl Context {
    /// Both, coherent first.
    pub const ALL: [Context; 2] = [Context::Coherent, Context::Incoherent];

    /// `coherent` or `incoherent`.
    pub fn name(self) -> &'static str {
        match self {
            Context::Coherent => "coherent",
            Context::Incoherent => "incoherent",
        }
    }

    fn flags(self) -> sys::RTCIntersectContextFlags {
        match self {
            Context::Coherent => sys::RTCIntersectContextFlags::COHERENT,
            Context::Incoherent => sys::RTCIntersectContextFlags::INCOHERENT,
        }
    }

    /// A context with these flags, no filter and no instance, as `rtcInitIntersectContext`
    /// makes it.
    fn context(self) -> sys::RTCIntersectContext {
        sys::RTCIntersectContext {
            flags: self.flags(),
            filter: None,
            instID: [INVALID_ID],
        }
    }
}

/// Rays converted into Embree's ray-and-hit layout for one query: packets of `width` rays
/// (consecutive rays, or given groups of at most `width`; partly filled packets have inactive
/// lanes), each with its valid mask, or one array of `RTCRayHit` for the stream calls.
///
/// Made once, so that a benchmark times only the queries: tracing writes the hits into the
/// layout (and shortens each ray's `tfar`), so a repeated measurement traces a fresh copy
/// ([`Clone::clone_from`] of the untraced layout, a copy of plain memory).
///
/// Rays kdbeam cannot trace (non-finite or zero direction, non-finite origin, `tmin > tmax`,
/// NaN `tmax`) and rays Embree cannot (`tmin < 0`) are inactive lanes (`valid = 0`) and get
/// [`Hit::NONE`]; so do directions whose components are all denormal, which are zero under
/// denormals-are-zero.
#[derive(Clone)]
pub struct EmbreeRays {
    len: usize,
    layout: Layout,
}

#[derive(Clone)]
enum Layout {
    W1(Packets<sys::RTCRayHit>),
    W4(Packets<sys::RTCRayHit4>),
    W8(Packets<sys::RTCRayHit8>),
    W16(Packets<sys::RTCRayHit16>),
    Stream(Stream),
}

/// Packets of one width with their valid masks.
#[derive(Clone)]
struct Packets<P: RayHitPacket> {
    packets: Vec<P>,
    valid: Vec<P::Valid>,
    /// The rays in each packet (its first lanes; the others are inactive).
    counts: Vec<u8>,
}

/// Rays for rtcIntersect1M/rtcOccluded1M: one `RTCRayHit` per ray, in the order of the rays.
#[derive(Clone)]
struct Stream {
    rays: Vec<sys::RTCRayHit>,
    /// Rays that are traced; the others are disabled (`tnear = +inf > tfar = −inf`, which
    /// Embree skips) and read back as misses, never as occluded.
    active: Vec<bool>,
}

impl EmbreeRays {
    /// `rays` in packets of `width` rays.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `width` is not 1, 4, 8 or 16.
    pub fn new(rays: &[Ray], width: usize) -> Result<EmbreeRays> {
        let groups: Vec<&[Ray]> = rays.chunks(width.max(1)).collect();
        EmbreeRays::from_groups(&groups, width)
    }

    /// One packet of `width` lanes per group of `groups` (kdbeam's packets of the same rays,
    /// say), its rays in the first lanes and the rest inactive; the rays read back in the
    /// order of the groups.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `width` is not 1, 4, 8 or 16, or a group holds more
    /// than `width` rays.
    pub fn from_groups(groups: &[&[Ray]], width: usize) -> Result<EmbreeRays> {
        if let Some(g) = groups.iter().find(|g| g.len() > width) {
            return Err(Error::InvalidParameter {
                name: "embree packet",
                message: format!("a group of {} rays for rtcIntersect{width}", g.len()),
            });
        }
        let layout = match width {
            1 => Layout::W1(Packets::new(groups)),
            4 => Layout::W4(Packets::new(groups)),
            8 => Layout::W8(Packets::new(groups)),
            16 => Layout::W16(Packets::new(groups)),
            _ => {
                return Err(Error::InvalidParameter {
                    name: "embree width",
                    message: format!("must be 1, 4, 8 or 16, got {width}"),
                })
            }
        };
        Ok(EmbreeRays {
            len: groups.iter().map(|g| g.len()).sum(),
            layout,
        })
    }

    /// `rays` for the stream calls rtcIntersect1M and rtcOccluded1M, in their order.
    pub fn stream(rays: &[Ray]) -> EmbreeRays {
        let mut out = Stream {
            rays: Vec::with_capacity(rays.len()),
            active: Vec::with_capacity(rays.len()),
        };
        for ray in rays {
            let mut r = <sys::RTCRayHit as RayHitPacket>::empty();
            let active = is_active(ray);
            if active {
                r.set_ray(0, ray);
            } else {
                (r.ray.tnear, r.ray.tfar) = (f32::INFINITY, f32::NEG_INFINITY);
            }
            out.rays.push(r);
            out.active.push(active);
        }
        EmbreeRays {
            len: rays.len(),
            layout: Layout::Stream(out),
        }
    }

    /// How many rays.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Are there no rays?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The closest hit of each ray after [`EmbreeScene::trace`], in the order of the rays
    /// ([`Hit::NONE`] for an inactive lane or a miss, and for every ray before tracing). A hit
    /// gives Embree's `t`, barycentrics `(u, v)` (weights of the second and third vertex, as
    /// in kdbeam) and primitive id as the triangle.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `hits.len()` is not the number of rays.
    pub fn hits(&self, hits: &mut [Hit]) -> Result<()> {
        check_outputs(hits.len(), self.len)?;
        match &self.layout {
            Layout::W1(p) => p.read(hits, Hit::NONE, P1::hit),
            Layout::W4(p) => p.read(hits, Hit::NONE, P4::hit),
            Layout::W8(p) => p.read(hits, Hit::NONE, P8::hit),
            Layout::W16(p) => p.read(hits, Hit::NONE, P16::hit),
            Layout::Stream(s) => {
                for ((h, r), &active) in hits.iter_mut().zip(&s.rays).zip(&s.active) {
                    *h = if active { r.hit(0) } else { Hit::NONE };
                }
            }
        }
        Ok(())
    }

    /// The top-level instance of each ray's hit (Embree's `instID[0]`: the geometry id of the
    /// instance in the top-level scene), in the order of the rays; `u32::MAX` for a miss, an
    /// inactive lane, a hit outside any instance, and every ray before tracing.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `instances.len()` is not the number of rays.
    pub fn instances(&self, instances: &mut [u32]) -> Result<()> {
        check_outputs(instances.len(), self.len)?;
        match &self.layout {
            Layout::W1(p) => p.read(instances, INVALID_ID, P1::instance),
            Layout::W4(p) => p.read(instances, INVALID_ID, P4::instance),
            Layout::W8(p) => p.read(instances, INVALID_ID, P8::instance),
            Layout::W16(p) => p.read(instances, INVALID_ID, P16::instance),
            Layout::Stream(s) => {
                for ((o, r), &active) in instances.iter_mut().zip(&s.rays).zip(&s.active) {
                    *o = if active { r.instance(0) } else { INVALID_ID };
                }
            }
        }
        Ok(())
    }

    /// Whether each ray was found occluded by [`EmbreeScene::occlude`], in the order of the
    /// rays (`false` for an inactive lane, and for every ray before tracing): Embree marks an
    /// occluded ray by setting its `tfar` to −inf.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `occluded.len()` is not the number of rays.
    pub fn occluded(&self, occluded: &mut [bool]) -> Result<()> {
        check_outputs(occluded.len(), self.len)?;
        match &self.layout {
            Layout::W1(p) => p.read(occluded, false, P1::occluded),
            Layout::W4(p) => p.read(occluded, false, P4::occluded),
            Layout::W8(p) => p.read(occluded, false, P8::occluded),
            Layout::W16(p) => p.read(occluded, false, P16::occluded),
            Layout::Stream(s) => {
                for ((o, r), &active) in occluded.iter_mut().zip(&s.rays).zip(&s.active) {
                    *o = active && r.occluded(0);
                }
            }
        }
        Ok(())
    }
}

type P1 = sys::RTCRayHit;
type P4 = sys::RTCRayHit4;
type P8 = sys::RTCRayHit8;
type P16 = sys::RTCRayHit16;

impl<P: RayHitPacket> Packets<P> {
    fn new(groups: &[&[Ray]]) -> Self {
        let mut packets = Vec::with_capacity(groups.len());
        let mut valid = Vec::with_capacity(groups.len());
        let mut counts = Vec::with_capacity(groups.len());
        for group in groups {
            let mut packet = P::empty();
            let mut mask = P::Valid::default();
            for (lane, ray) in group.iter().enumerate() {
                if is_active(ray) {
                    packet.set_ray(lane, ray);
                    mask.as_mut()[lane] = -1;
                }
            }
            packets.push(packet);
            valid.push(mask);
            counts.push(group.len() as u8);
        }
        Packets {
            packets,
            valid,
            counts,
        }
    }

    /// `answer` of every ray in order, `none` for an inactive lane.
    fn read<T: Copy>(&self, out: &mut [T], none: T, answer: fn(&P, usize) -> T) {
        let mut out = out.iter_mut();
        for ((packet, valid), &count) in self.packets.iter().zip(&self.valid).zip(&self.counts) {
            for (lane, o) in out.by_ref().take(count as usize).enumerate() {
                *o = if valid.as_ref()[lane] == 0 {
                    none
                } else {
                    answer(packet, lane)
                };
            }
        }
    }

    /// Traces every packet (rtcOccluded when `any`, rtcIntersect otherwise), in parallel over
    /// chunks of [`CHUNK`] rays on the current rayon pool, each chunk with flush-to-zero and
    /// denormals-are-zero set, as Embree expects.
    fn trace(&mut self, scene: &impl Committed, context: Context, any: bool) {
        let per_chunk = CHUNK / P::WIDTH;
        self.packets
            .par_chunks_mut(per_chunk)
            .zip(self.valid.par_chunks(per_chunk))
            .for_each(|(packets, valid)| {
                with_flush_to_zero(|| {
                    let mut context = context.context();
                    for (packet, valid) in packets.iter_mut().zip(valid) {
                        // SAFETY: the scene is committed and alive for `&scene`; `context`,
                        // `packet` and `valid` are initialised, and aligned to the packet
                        // width as Embree requires.
                        unsafe {
                            if any {
                                P::occlude(valid, scene.handle(), &mut context, packet)
                            } else {
                                P::intersect(valid, scene.handle(), &mut context, packet)
                            }
                        };
                    }
                })
            });
    }
}

impl Stream {
    /// rtcOccluded1M (when `any`) or rtcIntersect1M on chunks of [`CHUNK`] rays, in parallel
    /// on the current rayon pool, with flush-to-zero and denormals-are-zero set.
    fn trace(&mut self, scene: &impl Committed, context: Context, any: bool) {
        let stride = std::mem::size_of::<sys::RTCRayHit>();
        self.rays.par_chunks_mut(CHUNK).for_each(|chunk| {
            with_flush_to_zero(|| {
                let mut context = context.context();
                let m = chunk.len() as u32;
                // SAFETY: the scene is committed and alive for `&scene`; `chunk` holds `m`
                // initialised, 16-byte aligned `RTCRayHit`s `stride` bytes apart, and an
                // `RTCRayHit` starts with its `RTCRay`, so the same array serves
                // rtcOccluded1M, which reads and writes only the rays.
                unsafe {
                    if any {
                        let rays = chunk.as_mut_ptr().cast::<sys::RTCRay>();
                        sys::rtcOccluded1M(scene.handle(), &mut context, rays, m, stride);
                    } else {
                        let rays = chunk.as_mut_ptr();
                        sys::rtcIntersect1M(scene.handle(), &mut context, rays, m, stride);
                    }
                }
            })
        });
    }
}

impl EmbreeScene {
    /// Traces `rays` with rtcIntersect`width` (the width they were made for; rtcIntersect1M
    /// for a stream) in `context`, writing the closest hits into them ([`EmbreeRays::hits`]
    /// reads them). Tracing rays a second time starts from the hits of the first (each ray's
    /// `tfar` is its hit): trace a fresh copy instead.
    pub fn trace(&self, rays: &mut EmbreeRays, context: Context) {
        query(self, rays, context, false);
    }

    /// Asks whether each ray of `rays` hits anything, with rtcOccluded`width` (rtcOccluded1M
    /// for a stream) in `context` ([`EmbreeRays::occluded`] reads the answers). As with
    /// [`EmbreeScene::trace`], trace a fresh copy to trace again.
    pub fn occlude(&self, rays: &mut EmbreeRays, context: Context) {
        query(self, rays, context, true);
    }

    /// Closest hits of `rays`, written to `hits[i]` for `rays[i]`, traced with
    /// rtcIntersect`width` in `context` on packets of `width` consecutive rays: [`EmbreeRays`]
    /// made, traced and read back in one call. Of two triangles hit at the same `t`, either may
    /// be reported (kdbeam picks the smaller id).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `width` is not 1, 4, 8 or 16 or when
    /// `hits.len() != rays.len()`.
    pub fn intersect_stream(
        &self,
        rays: &[Ray],
        width: usize,
        context: Context,
        hits: &mut [Hit],
    ) -> Result<()> {
        let mut layout = EmbreeRays::new(rays, width)?;
        check_outputs(hits.len(), rays.len())?;
        self.trace(&mut layout, context);
        layout.hits(hits)
    }
}

/// A committed Embree scene, traced through `&self` from any number of threads.
pub(super) trait Committed: Sync {
    /// The committed scene handle.
    fn handle(&self) -> sys::RTCScene;
}

/// Traces `rays` through `scene`: rtcOccluded when `any`, rtcIntersect otherwise.
pub(super) fn query(scene: &impl Committed, rays: &mut EmbreeRays, context: Context, any: bool) {
    match &mut rays.layout {
        Layout::W1(p) => p.trace(scene, context, any),
        Layout::W4(p) => p.trace(scene, context, any),
        Layout::W8(p) => p.trace(scene, context, any),
        Layout::W16(p) => p.trace(scene, context, any),
        Layout::Stream(s) => s.trace(scene, context, any),
    }
}

fn check_outputs(outputs: usize, rays: usize) -> Result<()> {
    if outputs == rays {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name: "stream output",
            message: format!("{outputs} outputs for {rays} rays"),
        })
    }
}

/// Is `ray` traced, or an inactive lane?
#[inline]
fn is_active(ray: &Ray) -> bool {
    is_traceable(ray) && ray.tmin >= 0.0
}

/// An Embree ray-and-hit packet of `WIDTH` lanes (one for rtcIntersect1) with its valid mask.
trait RayHitPacket: Copy + Send + Sync {
    /// Lanes.
    const WIDTH: usize;
    /// The valid mask (-1 traces a lane, 0 skips it), aligned as the packet.
    type Valid: Copy + Default + Send + Sync + AsRef<[i32]> + AsMut<[i32]>;
    /// A packet with every lane empty.
    fn empty() -> Self;
    /// Loads `ray` into `lane` and clears its hit.
    fn set_ray(&mut self, lane: usize, ray: &Ray);
    /// The hit of a traced `lane`.
    fn hit(&self, lane: usize) -> Hit;
    /// The top-level instance of a traced `lane`'s hit (`u32::MAX` for none).
    fn instance(&self, lane: usize) -> u32;
    /// Was `lane` found occluded (its `tfar` set to −inf)?
    fn occluded(&self, lane: usize) -> bool;
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
    /// rtcOccluded`WIDTH`, on the packet's rays.
    ///
    /// # Safety
    /// `scene` must be a live, committed scene.
    unsafe fn occlude(
        valid: &Self::Valid,
        scene: sys::RTCScene,
        context: &mut sys::RTCIntersectContext,
        packet: &mut Self,
    );
}

/// The valid mask of a single ray: rtcIntersect1 takes none, so an inactive ray is not traced.
#[derive(Clone, Copy, Default)]
struct Valid1([i32; 1]);

impl AsRef<[i32]> for Valid1 {
    fn as_ref(&self) -> &[i32] {
        &self.0
    }
}

impl AsMut<[i32]> for Valid1 {
    fn as_mut(&mut self) -> &mut [i32] {
        &mut self.0
    }
}

impl RayHitPacket for sys::RTCRayHit {
    const WIDTH: usize = 1;
    type Valid = Valid1;

    fn empty() -> Self {
        sys::RTCRayHit {
            ray: sys::RTCRay {
                org_x: 0.0,
                org_y: 0.0,
                org_z: 0.0,
                tnear: 0.0,
                dir_x: 0.0,
                dir_y: 0.0,
                dir_z: 1.0,
                time: 0.0,
                tfar: 0.0,
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
        }
    }

    #[inline]
    fn set_ray(&mut self, _lane: usize, ray: &Ray) {
        let r = &mut self.ray;
        (r.org_x, r.org_y, r.org_z) = (ray.origin.x, ray.origin.y, ray.origin.z);
        (r.dir_x, r.dir_y, r.dir_z) = (ray.direction.x, ray.direction.y, ray.direction.z);
        (r.tnear, r.tfar) = (ray.tmin, ray.tmax);
        (self.hit.primID, self.hit.geomID) = (INVALID_ID, INVALID_ID);
    }

    #[inline]
    fn hit(&self, _lane: usize) -> Hit {
        if self.hit.geomID == INVALID_ID {
            Hit::NONE
        } else {
            Hit {
                t: self.ray.tfar,
                u: self.hit.u,
                v: self.hit.v,
                triangle: self.hit.primID,
            }
        }
    }

    #[inline]
    fn instance(&self, _lane: usize) -> u32 {
        self.hit.instID[0]
    }

    #[inline]
    unsafe fn intersect(
        valid: &Valid1,
        scene: sys::RTCScene,
        context: &mut sys::RTCIntersectContext,
        packet: &mut Self,
    ) {
        if valid.0[0] != 0 {
            // SAFETY: the caller guarantees the scene; `packet` is a live RTCRayHit, which is
            // `align(16)` as rtcIntersect1 requires.
            unsafe { sys::rtcIntersect1(scene, context, packet) }
        }
    }

    #[inline]
    fn occluded(&self, _lane: usize) -> bool {
        self.ray.tfar == f32::NEG_INFINITY
    }

    #[inline]
    unsafe fn occlude(
        valid: &Valid1,
        scene: sys::RTCScene,
        context: &mut sys::RTCIntersectContext,
        packet: &mut Self,
    ) {
        if valid.0[0] != 0 {
            // SAFETY: the caller guarantees the scene; `packet.ray` is a live RTCRay, aligned
            // as its RTCRayHit.
            unsafe { sys::rtcOccluded1(scene, context, &mut packet.ray) }
        }
    }
}

macro_rules! ray_hit_packet {
    ($packet:ident, $ray:ident, $hit:ident, $valid:ident, $align:literal, $n:literal, $f:ident, $o:ident) => {
        #[doc = concat!("A valid mask for rtcIntersect", stringify!($n), ", aligned to the packet as Embree requires (an unaligned mask crashes).")]
        #[repr(C, align($align))]
        #[derive(Clone, Copy, Default)]
        struct $valid([i32; $n]);

        impl AsRef<[i32]> for $valid {
            fn as_ref(&self) -> &[i32] {
                &self.0
            }
        }

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
                r.dir_x[lane] = ray.direction.x;
                r.dir_y[lane] = ray.direction.y;
                r.dir_z[lane] = ray.direction.z;
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
            fn instance(&self, lane: usize) -> u32 {
                self.hit.instID[0][lane]
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

            #[inline]
            fn occluded(&self, lane: usize) -> bool {
                self.ray.tfar[lane] == f32::NEG_INFINITY
            }

            #[inline]
            unsafe fn occlude(
                valid: &$valid,
                scene: sys::RTCScene,
                context: &mut sys::RTCIntersectContext,
                packet: &mut Self,
            ) {
                // SAFETY: as for the intersection; `packet.ray` is the packet's first field,
                // aligned as the packet.
                unsafe { sys::$o(valid.0.as_ptr(), scene, context, &mut packet.ray) }
            }
        }
    };
}

ray_hit_packet!(
    RTCRayHit4,
    RTCRay4,
    RTCHit4,
    Valid4,
    16,
    4,
    rtcIntersect4,
    rtcOccluded4
);
ray_hit_packet!(
    RTCRayHit8,
    RTCRay8,
    RTCHit8,
    Valid8,
    32,
    8,
    rtcIntersect8,
    rtcOccluded8
);
ray_hit_packet!(
    RTCRayHit16,
    RTCRay16,
    RTCHit16,
    Valid16,
    64,
    16,
    rtcIntersect16,
    rtcOccluded16
);
