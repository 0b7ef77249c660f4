//! A leaf visit's rays moved together: few rays spread over many groups of lanes leave most
//! lanes of each ray–triangle test idle, and moved to the first lanes of a packet of their own
//! they fill as few groups as they can.

use kdbeam_kernels::groups::take_group;
use kdbeam_kernels::{HitPacket, Lanes, RayPacket, MAX_PACKET_RAYS};

/// Do the rays of `mask` sit in more groups of `L::WIDTH` lanes than they would fill?
///
/// A leaf's surviving triangles are tested once per group that holds a ray, so a visit whose
/// few rays are scattered over the packet (a tile's rays on a terrain seen at a grazing angle,
/// each leaf reached by a row or two of them) pays for idle lanes in every test.
#[inline(always)]
pub(super) fn is_scattered<L: Lanes>(mask: u64) -> bool {
    let mut rest = mask;
    let mut occupied = 0;
    while rest != 0 {
        take_group::<L>(&mut rest);
        occupied += 1;
    }
    occupied > (mask.count_ones() as usize).div_ceil(L::WIDTH)
}

/// Some rays of a packet in the first lanes of a packet of their own, in order: lane `k` holds
/// ray `index()[k]` of the packet, with its origin, direction, `tmin` and `tmax` unchanged, so
/// that a test of lane `k` is the test of that ray, bit for bit.
pub(super) struct DensePacket {
    rays: RayPacket,
    index: [u8; MAX_PACKET_RAYS],
}

impl DensePacket {
    /// The rays of `mask` of `p` (bits at or past `p.len()` are ignored).
    #[inline(always)]
    pub(super) fn gather(p: &RayPacket, mask: u64) -> Self {
        let mut rest = mask & p.full_mask();
        let mut dense = DensePacket {
            rays: RayPacket::from_rays(&[]),
            index: [0; MAX_PACKET_RAYS],
        };
        dense.rays.set_len(rest.count_ones() as usize);
        let mut k = 0;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            dense.index[k] = i as u8;
            for a in 0..3 {
                dense.rays.origin[a][k] = p.origin[a][i];
                dense.rays.direction[a][k] = p.direction[a][i];
            }
            dense.rays.tmin[k] = p.tmin[i];
            dense.rays.tmax[k] = p.tmax[i];
            k += 1;
        }
        dense
    }

    /// The gathered rays.
    #[inline(always)]
    pub(super) fn rays(&self) -> &RayPacket {
        &self.rays
    }

    /// The packet's index of the ray in each lane.
    #[inline(always)]
    pub(super) fn index(&self) -> &[u8] {
        &self.index[..self.rays.len()]
    }

    /// The closest hits so far of the gathered rays, from the packet's `hits`, in their lanes;
    /// no tests counted yet.
    #[inline(always)]
    pub(super) fn gather_hits(&self, hits: &HitPacket) -> HitPacket {
        let mut d = HitPacket::default();
        for (k, &i) in self.index().iter().enumerate() {
            let i = usize::from(i);
            (d.t[k], d.u[k], d.v[k]) = (hits.t[i], hits.u[i], hits.v[i]);
            d.triangle[k] = hits.triangle[i];
        }
        d
    }

    /// Moves the gathered rays' hits `d` back to their rays in `hits` and adds their tests;
    /// returns the packet's rays that have a hit.
    #[inline(always)]
    pub(super) fn scatter_hits(&self, d: &HitPacket, hits: &mut HitPacket) -> u64 {
        let mut has_hit = 0u64;
        for (k, &i) in self.index().iter().enumerate() {
            let i = usize::from(i);
            (hits.t[i], hits.u[i], hits.v[i]) = (d.t[k], d.u[k], d.v[k]);
            hits.triangle[i] = d.triangle[k];
            hits.tests[i] += d.tests[k];
            has_hit |= u64::from(d.triangle[k] != u32::MAX) << i;
        }
        has_hit
    }
}

#[cfg(test)]
mod tests {
    use kdbeam_kernels::lanes::{Portable, Scalar};
    use kdbeam_kernels::{Ray, Vec3};

    use super::*;

    #[test]
    fn scattered_means_more_groups_than_the_rays_fill() {
        // Four rays, one in each group of four lanes, would fill one group.
        assert!(is_scattered::<Portable>(0b0001_0001_0001_0001));
        assert!(is_scattered::<Portable>(1 | 1 << 63));
        // Rays that fill their groups, or the fewest groups that can hold them.
        assert!(!is_scattered::<Portable>(0b1111));
        assert!(!is_scattered::<Portable>(0b1111_0000));
        assert!(!is_scattered::<Portable>(0b1_1111));
        assert!(is_scattered::<Portable>(0b0111_1000));
        assert!(!is_scattered::<Portable>(0));
        // One lane per group: never scattered.
        assert!(!is_scattered::<Scalar>(0b0001_0001_0001_0001));
    }

    #[test]
    fn gathered_rays_keep_their_values_and_their_place() {
        let rays: Vec<Ray> = (0..40)
            .map(|i| Ray {
                tmin: i as f32 * 0.5,
                tmax: 100.0 + i as f32,
                ..Ray::new(Vec3::new(i as f32, 1.0, 2.0), Vec3::new(0.0, 1.0, i as f32))
            })
            .collect();
        let p = RayPacket::from_rays(&rays);
        let mask = 1 << 3 | 1 << 17 | 1 << 39 | 1 << 50;
        let dense = DensePacket::gather(&p, mask);
        assert_eq!(dense.index(), &[3, 17, 39]);
        assert_eq!(dense.rays().len(), 3);
        for (k, &i) in dense.index().iter().enumerate() {
            assert_eq!(dense.rays().ray(k), p.ray(usize::from(i)));
        }
        // Hits go to the gathered lanes and back to their rays, tests added, others untouched.
        let mut hits = HitPacket::default();
        hits.t[17] = 5.0;
        hits.triangle[17] = 9;
        hits.tests[3] = 2;
        let mut found = dense.gather_hits(&hits);
        assert_eq!((found.t[1], found.triangle[1], found.tests[0]), (5.0, 9, 0));
        found.t[2] = 7.0;
        found.triangle[2] = 4;
        found.tests[0] = 3;
        assert_eq!(dense.scatter_hits(&found, &mut hits), 1 << 17 | 1 << 39);
        assert_eq!((hits.t[39], hits.triangle[39], hits.tests[3]), (7.0, 4, 5));
        assert_eq!((hits.t[50], hits.triangle[50]), (f32::INFINITY, u32::MAX));
    }
}
