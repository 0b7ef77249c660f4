//! Subspace culling: binary occupancy masks on a uniform grid inside a box, after A. Yoshimura
//! and T. Harada, *Subspace Culling for Ray-Box Intersection* (Proc. ACM on Computer Graphics
//! and Interactive Techniques, 2023).
//!
//! A box is cut into `R × R × R` cells ([`Grid`]); a triangle's *object mask* has the bit of
//! every cell it touches ([`voxelise`]), a ray's *ray mask* the bit of every cell its segment
//! in the box may touch ([`segment`]). When the AND of the two is empty the ray cannot hit the
//! triangle inside the box. Every mask here is conservative: it may hold cells the geometry
//! misses, never lose one it touches.
//!
//! Cell `(x, y, z)` is bit `x + R·(y + R·z)`.

mod grid;
pub mod segment;
pub mod voxelise;

pub use grid::Grid;

/// A set of the `R³` cells of a [`Grid`], one bit per cell.
pub trait VoxelMask: Copy + Eq + core::fmt::Debug + Send + Sync + 'static {
    /// Cells per axis.
    const R: usize;
    /// No cell.
    const EMPTY: Self;
    /// Every cell.
    const FULL: Self;
    /// Cells in both.
    #[must_use]
    fn and(self, o: Self) -> Self;
    /// Cells in either.
    #[must_use]
    fn or(self, o: Self) -> Self;
    /// No cell set?
    fn is_empty(self) -> bool;
    /// This set and cell `i` (`i < R³`).
    #[must_use]
    fn with(self, i: usize) -> Self;
    /// Is cell `i` set? (`false` for `i ≥ R³`.)
    fn contains(self, i: usize) -> bool;
}

/// The `4³ = 64` cells of `R = 4` in one `u64`: the paper's resolution whose mask fits a
/// register.
impl VoxelMask for u64 {
    const R: usize = 4;
    const EMPTY: u64 = 0;
    const FULL: u64 = u64::MAX;

    #[inline(always)]
    fn and(self, o: u64) -> u64 {
        self & o
    }

    #[inline(always)]
    fn or(self, o: u64) -> u64 {
        self | o
    }

    #[inline(always)]
    fn is_empty(self) -> bool {
        self == 0
    }

    #[inline(always)]
    fn with(self, i: usize) -> u64 {
        self | 1 << i
    }

    #[inline(always)]
    fn contains(self, i: usize) -> bool {
        i < 64 && self >> i & 1 == 1
    }
}

/// The `6³ = 216` cells of `R = 6`: bit `i` is bit `i % 64` of word `i / 64`; the top 40 bits
/// of the last word are always clear.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(C, align(32))]
pub struct Mask6(pub [u64; 4]);

impl VoxelMask for Mask6 {
    const R: usize = 6;
    const EMPTY: Mask6 = Mask6([0; 4]);
    const FULL: Mask6 = Mask6([u64::MAX, u64::MAX, u64::MAX, (1 << (216 - 192)) - 1]);

    #[inline(always)]
    fn and(self, o: Mask6) -> Mask6 {
        Mask6(core::array::from_fn(|i| self.0[i] & o.0[i]))
    }

    #[inline(always)]
    fn or(self, o: Mask6) -> Mask6 {
        Mask6(core::array::from_fn(|i| self.0[i] | o.0[i]))
    }

    #[inline(always)]
    fn is_empty(self) -> bool {
        (self.0[0] | self.0[1] | self.0[2] | self.0[3]) == 0
    }

    #[inline(always)]
    fn with(mut self, i: usize) -> Mask6 {
        self.0[i / 64] |= 1 << (i % 64);
        self
    }

    #[inline(always)]
    fn contains(self, i: usize) -> bool {
        i < 216 && self.0[i / 64] >> (i % 64) & 1 == 1
    }
}

/// The index of cell `(x, y, z)` of a grid of `R` cells per axis.
#[inline(always)]
#[must_use]
pub const fn cell_index<const R: usize>(x: usize, y: usize, z: usize) -> usize {
    x + R * (y + R * z)
}

/// A small deterministic generator (xorshift) for the sampling tests of the submodules.
#[cfg(test)]
mod test_rng {
    use glam::Vec3;

    pub(super) struct Rng(pub u64);

    impl Rng {
        /// Uniform in `[0, 1)`, 24 bits.
        pub fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }

        /// Uniform in the cube `[lo, hi)³`.
        pub fn point(&mut self, lo: f32, hi: f32) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + lo
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count<M: VoxelMask>(m: M) -> usize {
        (0..M::R * M::R * M::R).filter(|&i| m.contains(i)).count()
    }

    #[test]
    fn full_holds_every_cell_and_nothing_beyond() {
        assert_eq!(count(<u64 as VoxelMask>::FULL), 64);
        assert_eq!(count(Mask6::FULL), 216);
        assert!(!Mask6::FULL.contains(216));
        let m = Mask6::EMPTY.with(3).with(200);
        assert_eq!(count(m), 2);
        assert!(m.and(Mask6::EMPTY.with(200)).contains(200));
        assert!(m.and(Mask6::EMPTY.with(199)).is_empty());
        assert_eq!(m.or(Mask6::FULL), Mask6::FULL);
    }
}
