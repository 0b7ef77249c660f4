//! SoA ray packets of up to 64 rays, and their hits.

use crate::ray::{Hit, Ray};

/// Most rays in one packet.
pub const MAX_PACKET_RAYS: usize = 64;

/// The packet shapes kdbeam traces: pixel tiles of 2×2, 4×2, 4×4 and 8×8 rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PacketShape {
    /// 4 rays.
    P2x2,
    /// 8 rays.
    P4x2,
    /// 16 rays.
    P4x4,
    /// 64 rays.
    P8x8,
}

impl PacketShape {
    /// Every shape, smallest first.
    pub const ALL: [PacketShape; 4] = [
        PacketShape::P2x2,
        PacketShape::P4x2,
        PacketShape::P4x4,
        PacketShape::P8x8,
    ];

    /// Tile width in pixels.
    #[must_use]
    pub const fn width(self) -> usize {
        match self {
            PacketShape::P2x2 => 2,
            PacketShape::P4x2 | PacketShape::P4x4 => 4,
            PacketShape::P8x8 => 8,
        }
    }

    /// Tile height in pixels.
    #[must_use]
    pub const fn height(self) -> usize {
        match self {
            PacketShape::P2x2 | PacketShape::P4x2 => 2,
            PacketShape::P4x4 => 4,
            PacketShape::P8x8 => 8,
        }
    }

    /// Rays per packet: 4, 8, 16 or 64.
    #[must_use]
    pub const fn ray_count(self) -> usize {
        self.width() * self.height()
    }

    /// The shape with `n` rays, if there is one.
    #[must_use]
    pub const fn from_len(n: usize) -> Option<PacketShape> {
        match n {
            4 => Some(PacketShape::P2x2),
            8 => Some(PacketShape::P4x2),
            16 => Some(PacketShape::P4x4),
            64 => Some(PacketShape::P8x8),
            _ => None,
        }
    }
}

/// Up to 64 rays in structure-of-arrays layout: `origin[axis][ray]`, `direction[axis][ray]`.
///
/// Lanes past [`RayPacket::len`] hold zeros and are never traced. Every array is 64-byte
/// aligned so that a group of 4 or 8 lanes is one aligned load.
#[repr(C, align(64))]
#[derive(Clone, Debug, PartialEq)]
pub struct RayPacket {
    /// Origins, by axis then ray.
    pub origin: [[f32; MAX_PACKET_RAYS]; 3],
    /// Directions, by axis then ray.
    pub direction: [[f32; MAX_PACKET_RAYS]; 3],
    /// Smallest accepted `t` per ray.
    pub tmin: [f32; MAX_PACKET_RAYS],
    /// Largest accepted `t` per ray.
    pub tmax: [f32; MAX_PACKET_RAYS],
    len: usize,
}

impl RayPacket {
    /// A packet of the rays in `rays`; panics if there are more than 64.
    #[must_use]
    pub fn from_rays(rays: &[Ray]) -> Self {
        assert!(
            rays.len() <= MAX_PACKET_RAYS,
            "a packet holds at most 64 rays"
        );
        let mut p = RayPacket {
            origin: [[0.0; MAX_PACKET_RAYS]; 3],
            direction: [[0.0; MAX_PACKET_RAYS]; 3],
            tmin: [0.0; MAX_PACKET_RAYS],
            tmax: [0.0; MAX_PACKET_RAYS],
            len: rays.len(),
        };
        for (i, r) in rays.iter().enumerate() {
            p.set(i, r);
        }
        p
    }

    /// Makes the packet `len` rays long in place, for callers that write the public arrays
    /// directly (no 2 KiB packet built and moved per call, as [`RayPacket::from_rays`] does).
    ///
    /// Lanes below `len` keep their contents, for the caller to overwrite; lanes from `len` on
    /// are zeroed, as the layout requires. Panics if `len > 64`.
    pub fn set_len(&mut self, len: usize) {
        assert!(len <= MAX_PACKET_RAYS, "a packet holds at most 64 rays");
        for a in 0..3 {
            self.origin[a][len..].fill(0.0);
            self.direction[a][len..].fill(0.0);
        }
        self.tmin[len..].fill(0.0);
        self.tmax[len..].fill(0.0);
        self.len = len;
    }

    /// Number of rays.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True for a packet of no rays.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bit `i` set for every ray `i < len`.
    #[inline]
    #[must_use]
    pub fn full_mask(&self) -> u64 {
        if self.len == MAX_PACKET_RAYS {
            u64::MAX
        } else {
            (1u64 << self.len) - 1
        }
    }

    /// Ray `i`. Panics if `i >= len`.
    #[inline]
    #[must_use]
    pub fn ray(&self, i: usize) -> Ray {
        assert!(i < self.len);
        Ray {
            origin: [self.origin[0][i], self.origin[1][i], self.origin[2][i]].into(),
            direction: [
                self.direction[0][i],
                self.direction[1][i],
                self.direction[2][i],
            ]
            .into(),
            tmin: self.tmin[i],
            tmax: self.tmax[i],
        }
    }

    /// Sets ray `i`. Panics if `i >= len`.
    #[inline]
    pub fn set(&mut self, i: usize, r: &Ray) {
        assert!(i < self.len);
        for a in 0..3 {
            self.origin[a][i] = r.origin[a];
            self.direction[a][i] = r.direction[a];
        }
        self.tmin[i] = r.tmin;
        self.tmax[i] = r.tmax;
    }
}

/// The hits of a packet, SoA: a miss has `t = +inf`, `triangle = u32::MAX` (as [`Hit::NONE`]).
#[repr(C, align(64))]
#[derive(Clone, Debug, PartialEq)]
pub struct HitPacket {
    /// Hit distance per ray.
    pub t: [f32; MAX_PACKET_RAYS],
    /// Barycentric `u` per ray.
    pub u: [f32; MAX_PACKET_RAYS],
    /// Barycentric `v` per ray.
    pub v: [f32; MAX_PACKET_RAYS],
    /// Triangle id per ray.
    pub triangle: [u32; MAX_PACKET_RAYS],
    /// Ray–triangle tests performed for each ray (after culling): heat maps.
    pub tests: [u32; MAX_PACKET_RAYS],
}

impl Default for HitPacket {
    fn default() -> Self {
        HitPacket {
            t: [f32::INFINITY; MAX_PACKET_RAYS],
            u: [0.0; MAX_PACKET_RAYS],
            v: [0.0; MAX_PACKET_RAYS],
            triangle: [u32::MAX; MAX_PACKET_RAYS],
            tests: [0; MAX_PACKET_RAYS],
        }
    }
}

impl HitPacket {
    /// The hit of ray `i`. Panics if `i >= 64`.
    #[inline]
    #[must_use]
    pub fn hit(&self, i: usize) -> Hit {
        Hit {
            t: self.t[i],
            u: self.u[i],
            v: self.v[i],
            triangle: self.triangle[i],
        }
    }
}
