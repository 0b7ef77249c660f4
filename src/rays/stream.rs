//! Ray streams sorted for packets: by direction octant, then along a Morton curve through the
//! origins, so that consecutive rays share their direction signs and start close together.
//!
//! This is how a renderer batches rays that come from no pixel tile (or whose tiles scatter):
//! sort the whole stream, cut it into packets of consecutive rays, trace them. The sort is part
//! of the work, and of the time a benchmark reports for a stream.

use kdbeam_kernels::{Aabb, Hit, HitPacket, Ray, RayPacket};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use crate::trace::PacketCounters;
use crate::{Error, Result, Tracer};

/// Bits per axis of the Morton code: 9, so that the octant and three axes fit the high half of
/// a `u64` key whose low half is the ray's index.
const MORTON_BITS: u32 = 9;

/// The indices of `rays` in stream order: by the octant of the direction's signs (x, y, z
/// bits, a negative component sets its bit; −0 counts as negative), then by the 27-bit Morton
/// code of the origin quantised to a 512³ grid over `bounds` (origins outside are clamped to
/// it, NaN to its low corner), then by index — a total order, the same on every platform.
///
/// ```
/// use kdbeam::rays::stream::sorted_order;
/// use kdbeam::{Aabb, Ray, Vec3};
///
/// let bounds = Aabb::from_points([Vec3::ZERO, Vec3::ONE]);
/// let rays = [
///     Ray::new(Vec3::splat(0.9), Vec3::X),
///     Ray::new(Vec3::splat(0.1), Vec3::NEG_X),
///     Ray::new(Vec3::splat(0.1), Vec3::X),
/// ];
/// assert_eq!(sorted_order(&rays, &bounds), [2, 0, 1]);
/// ```
#[must_use]
pub fn sorted_order(rays: &[Ray], bounds: &Aabb) -> Vec<u32> {
    let (lo, scale) = if bounds.is_empty() {
        (glam::Vec3::ZERO, glam::Vec3::ZERO)
    } else {
        let cells = (1u32 << MORTON_BITS) as f32;
        (
            bounds.min,
            cells / bounds.extent().max(glam::Vec3::splat(f32::MIN_POSITIVE)),
        )
    };
    let key = |(i, r): (usize, &Ray)| {
        let octant = (0..3).fold(0u64, |o, a| {
            o | u64::from(r.direction[a].is_sign_negative()) << a
        });
        let cell = |a: usize| {
            let c = ((r.origin[a] - lo[a]) * scale[a]).clamp(0.0, ((1 << MORTON_BITS) - 1) as f32);
            // NaN fails the clamp's comparisons and casts to 0.
            c as u32
        };
        let morton = spread(cell(0)) | spread(cell(1)) << 1 | spread(cell(2)) << 2;
        (octant << 59) | (u64::from(morton) << 32) | i as u64
    };
    let mut keys: Vec<u64> = rays.iter().enumerate().map(key).collect();
    #[cfg(feature = "parallel")]
    keys.par_sort_unstable();
    #[cfg(not(feature = "parallel"))]
    keys.sort_unstable();
    keys.into_iter().map(|k| k as u32).collect()
}

/// The 9 low bits of `x` spread to every third bit (bit `i` to bit `3i`).
fn spread(x: u32) -> u32 {
    let mut x = x & 0x1ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    (x | x << 2) & 0x0924_9249
}

/// Closest hits of every ray of `rays` as a sorted stream: [`sorted_order`] over `bounds`,
/// packets of the tracer's packet size of consecutive sorted rays, traced with
/// [`Tracer::intersect_packet`]; `hits[i]` is the hit of `rays[i]`, the same as
/// [`Tracer::intersect`] gives it. Parallel over packets with the `parallel` feature. Returns
/// the work done.
///
/// ```
/// use kdbeam::rays::{random_rays, stream::intersect_sorted};
/// use kdbeam::{scene::procedural, BuildParams, Hit, KdTree, Tracer};
///
/// let mesh = procedural::builtin("icosphere")?;
/// let tree = KdTree::build(&mesh, &BuildParams::default())?;
/// let tracer = Tracer::new(&tree);
/// let rays = random_rays(&tree.bounds(), 500, 3);
/// let mut hits = vec![Hit::NONE; rays.len()];
/// intersect_sorted(&tracer, &rays, &tree.bounds(), &mut hits)?;
/// assert!(rays.iter().zip(&hits).all(|(r, h)| tracer.intersect(r) == *h));
/// # Ok::<(), kdbeam::Error>(())
/// ```
///
/// # Errors
/// [`Error::InvalidParameter`] when `hits.len() != rays.len()`.
pub fn intersect_sorted(
    tracer: &Tracer<'_>,
    rays: &[Ray],
    bounds: &Aabb,
    hits: &mut [Hit],
) -> Result<PacketCounters> {
    trace_sorted(
        tracer,
        rays,
        bounds,
        hits,
        Hit::NONE,
        |packet, out, counters| {
            let mut hp = HitPacket::default();
            tracer.intersect_packet_counted(packet, packet.full_mask(), &mut hp, counters);
            for (j, h) in out.iter_mut().enumerate() {
                *h = hp.hit(j);
            }
        },
    )
}

/// Whether each ray of `rays` hits anything in `[tmin, tmax]`, as a sorted stream (as
/// [`intersect_sorted`], with [`Tracer::occluded_packet`]); `occluded[i]` is the answer for
/// `rays[i]`, [`Tracer::occluded`]'s. Returns the work done.
///
/// # Errors
/// [`Error::InvalidParameter`] when `occluded.len() != rays.len()`.
pub fn occluded_sorted(
    tracer: &Tracer<'_>,
    rays: &[Ray],
    bounds: &Aabb,
    occluded: &mut [bool],
) -> Result<PacketCounters> {
    trace_sorted(
        tracer,
        rays,
        bounds,
        occluded,
        false,
        |packet, out, counters| {
            let bits = tracer.occluded_packet_counted(packet, packet.full_mask(), counters);
            for (j, o) in out.iter_mut().enumerate() {
                *o = bits >> j & 1 != 0;
            }
        },
    )
}

/// Sorts `rays` ([`sorted_order`]), cuts them into packets of the tracer's size, answers each
/// with `query` (the packet, its answers in sorted order from `init`, its counters) and writes
/// `out[i]` for `rays[i]`.
fn trace_sorted<T: Copy + Send + Sync>(
    tracer: &Tracer<'_>,
    rays: &[Ray],
    bounds: &Aabb,
    out: &mut [T],
    init: T,
    query: impl Fn(&RayPacket, &mut [T], &mut PacketCounters) + Sync,
) -> Result<PacketCounters> {
    if rays.len() != out.len() {
        return Err(Error::InvalidParameter {
            name: "stream output",
            message: format!("{} outputs for {} rays", out.len(), rays.len()),
        });
    }
    let order = sorted_order(rays, bounds);
    let n = tracer.packet().ray_count();
    let mut sorted = vec![init; rays.len()];
    let trace = |(chunk, answers): (&[u32], &mut [T])| {
        let mut counters = PacketCounters::default();
        query(&gather(rays, chunk), answers, &mut counters);
        counters
    };
    #[cfg(feature = "parallel")]
    let per_packet: Vec<PacketCounters> = order
        .par_chunks(n)
        .zip(sorted.par_chunks_mut(n))
        .map(trace)
        .collect();
    #[cfg(not(feature = "parallel"))]
    let per_packet: Vec<PacketCounters> = order
        .chunks(n)
        .zip(sorted.chunks_mut(n))
        .map(trace)
        .collect();
    for (&i, answer) in order.iter().zip(&sorted) {
        out[i as usize] = *answer;
    }
    let mut counters = PacketCounters::default();
    per_packet.iter().for_each(|c| counters.add(c));
    Ok(counters)
}

/// The packet of `rays[i]` for each `i` of `chunk` (at most 64).
fn gather(rays: &[Ray], chunk: &[u32]) -> RayPacket {
    let mut packet = RayPacket::from_rays(&[]);
    packet.set_len(chunk.len());
    for (j, &i) in chunk.iter().enumerate() {
        packet.set(j, &rays[i as usize]);
    }
    packet
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_interleaves_the_nine_low_bits() {
        assert_eq!(spread(0b1), 0b1);
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread(0x1ff), 0x0124_9249);
        assert_eq!(spread(0xffff_fe00), 0);
    }

    #[test]
    fn the_order_is_a_permutation_grouped_by_octant() {
        let bounds = Aabb::from_points([glam::Vec3::splat(-1.0), glam::Vec3::splat(2.0)]);
        let rays = crate::rays::random_rays(&bounds, 1000, 5);
        let order = sorted_order(&rays, &bounds);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..1000).collect::<Vec<u32>>());
        let octant = |i: u32| {
            let d = rays[i as usize].direction;
            (d.x < 0.0) as u8 | ((d.y < 0.0) as u8) << 1 | ((d.z < 0.0) as u8) << 2
        };
        assert!(order.windows(2).all(|w| octant(w[0]) <= octant(w[1])));
    }
}
