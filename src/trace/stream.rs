//! Ray streams: arbitrary slices of rays, cut into packets and traced on all cores.
//!
//! Consecutive rays that share their direction signs (a camera's tile, a batch of coherent
//! shadow rays) are traced as the packets they already are. The rest are sorted by octant and
//! then by direction, so that the packets made of them at least share their near/far order and,
//! as far as the stream allows, their path through the tree.

use kdbeam_kernels::lanes::Scalar;
use kdbeam_kernels::{Hit, HitPacket, Ray, RayPacket};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::packet::{octant_masks, traceable_mask};
use super::{PacketCounters, Tracer};
use crate::{Error, Result};

impl Tracer<'_> {
    /// Closest hits of every ray of `rays`, written to `hits[i]` for `rays[i]`; returns the
    /// work done. Parallel over packets with the `parallel` feature.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `hits.len() != rays.len()`.
    pub fn intersect_stream(&self, rays: &[Ray], hits: &mut [Hit]) -> Result<PacketCounters> {
        check_lengths(rays.len(), hits.len())?;
        let n = self.packet().ray_count();
        let coherent = |(i, (chunk, out)): (usize, (&[Ray], &mut [Hit]))| {
            let p = RayPacket::from_rays(chunk);
            if !is_coherent(&p) {
                return (Some(i), PacketCounters::default());
            }
            let mut hp = HitPacket::default();
            let c = self.intersect_packet(&p, p.full_mask(), &mut hp);
            for (j, h) in out.iter_mut().enumerate() {
                *h = hp.hit(j);
            }
            (None, c)
        };
        #[cfg(feature = "parallel")]
        let first: Vec<_> = rays
            .par_chunks(n)
            .zip(hits.par_chunks_mut(n))
            .enumerate()
            .map(coherent)
            .collect();
        #[cfg(not(feature = "parallel"))]
        let first: Vec<_> = rays
            .chunks(n)
            .zip(hits.chunks_mut(n))
            .enumerate()
            .map(coherent)
            .collect();

        let mut counters = PacketCounters::default();
        let mut rest = Vec::new();
        for (leftover, c) in first {
            counters.add(&c);
            if let Some(i) = leftover {
                rest.extend((i * n..((i + 1) * n).min(rays.len())).map(|r| r as u32));
            }
        }
        sort_incoherent(rays, &mut rest);
        let incoherent = |chunk: &[u32]| {
            let gathered: Vec<Ray> = chunk.iter().map(|&i| rays[i as usize]).collect();
            let p = RayPacket::from_rays(&gathered);
            let mut hp = HitPacket::default();
            let c = self.intersect_packet(&p, p.full_mask(), &mut hp);
            (
                chunk
                    .iter()
                    .enumerate()
                    .map(|(j, &i)| (i, hp.hit(j)))
                    .collect::<Vec<_>>(),
                c,
            )
        };
        #[cfg(feature = "parallel")]
        let second: Vec<_> = rest.par_chunks(n).map(incoherent).collect();
        #[cfg(not(feature = "parallel"))]
        let second: Vec<_> = rest.chunks(n).map(incoherent).collect();
        for (scattered, c) in second {
            counters.add(&c);
            for (i, h) in scattered {
                hits[i as usize] = h;
            }
        }
        Ok(counters)
    }

    /// Whether each ray of `rays` hits anything in `[tmin, tmax]`, written to `occluded[i]`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `occluded.len() != rays.len()`.
    pub fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<()> {
        check_lengths(rays.len(), occluded.len())?;
        let mut order: Vec<u32> = (0..rays.len() as u32).collect();
        sort_incoherent(rays, &mut order);
        let n = self.packet().ray_count();
        let trace = |chunk: &[u32]| {
            let gathered: Vec<Ray> = chunk.iter().map(|&i| rays[i as usize]).collect();
            let p = RayPacket::from_rays(&gathered);
            let bits = self.occluded_packet(&p, p.full_mask());
            chunk
                .iter()
                .enumerate()
                .map(|(j, &i)| (i, bits >> j & 1 != 0))
                .collect::<Vec<_>>()
        };
        #[cfg(feature = "parallel")]
        let results: Vec<_> = order.par_chunks(n).map(trace).collect();
        #[cfg(not(feature = "parallel"))]
        let results: Vec<_> = order.chunks(n).map(trace).collect();
        for (i, o) in results.into_iter().flatten() {
            occluded[i as usize] = o;
        }
        Ok(())
    }
}

fn check_lengths(rays: usize, out: usize) -> Result<()> {
    if rays == out {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name: "stream output",
            message: format!("{out} outputs for {rays} rays"),
        })
    }
}

/// Do the traceable rays of `p` all share their direction signs?
fn is_coherent(p: &RayPacket) -> bool {
    octant_masks(Scalar, p, traceable_mask(Scalar, p, p.full_mask()))
        .iter()
        .filter(|&&m| m != 0)
        .count()
        <= 1
}

/// Sorts ray indices by octant, then by a coarse direction cell, then by origin, so that
/// neighbours in the order make packets that agree in direction signs and roughly in path.
fn sort_incoherent(rays: &[Ray], order: &mut [u32]) {
    let key = |&i: &u32| {
        let r = &rays[i as usize];
        let octant = (0..3).fold(0u32, |o, a| {
            o | (r.direction[a].is_sign_negative() as u32) << a
        });
        let d = r.direction.normalize_or_zero().abs();
        let cell = |x: f32| (x * 7.99).clamp(0.0, 7.0) as u32;
        (octant << 9) | (cell(d.x) << 6) | (cell(d.y) << 3) | cell(d.z)
    };
    #[cfg(feature = "parallel")]
    order.par_sort_by_cached_key(key);
    #[cfg(not(feature = "parallel"))]
    order.sort_by_cached_key(key);
}
