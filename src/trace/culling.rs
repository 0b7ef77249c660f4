//! Which culling runs when a packet enters a leaf.

use std::fmt;
use std::str::FromStr;

use kdbeam_kernels::beam::Stages;

use crate::{Error, Result};

/// The frustum planes a beam checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Planes {
    /// No beam: every active ray is tested against every triangle (the Kensler–Shirley
    /// baseline when the intersector is Kensler–Shirley).
    None,
    /// The four side planes (Reshetov's vertex culling).
    Four,
    /// The side planes and the near and far planes.
    Six,
}

/// Which rays a beam is built around.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Frustum {
    /// Every ray of the packet (cheaper to reason about; looser deep in the tree).
    Maskless,
    /// Only the rays active in the leaf (tighter when few remain).
    Masked,
    /// Masked when fewer than half of the packet's rays are active in the leaf, else maskless.
    Adaptive,
    /// The whole packet, all the way down: the packet traverses the tree as one interval of
    /// `t` (no per-ray masks; see `traverse_octant_interval`), and every leaf it enters is
    /// culled by the beam of all its rays. An inner node costs a few scalar operations instead
    /// of one split test per group of lanes; the beam does the per-ray work. With no planes it
    /// is the per-ray traversal.
    Packet,
}

/// Culling in the leaves: which planes, the aperture test, which rays, in which order, and
/// which leaves skip it.
///
/// Every stage is conservative: the closest hit of every ray, its `t` and its triangle id are
/// the same as without culling (the differential tests check this on every ISA and packet
/// size).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Culling {
    /// Frustum planes.
    pub planes: Planes,
    /// The corner-ray aperture test (and the far plane of an occluder every ray hits).
    pub aperture: bool,
    /// Which rays the beam bounds.
    pub frustum: Frustum,
    /// Aperture before the near/far planes (real scenes) or after (synthetic data).
    pub aperture_first: bool,
    /// Leaves with fewer triangles are tested unculled.
    pub min_triangles: u32,
    /// Leaf visits with fewer active rays are tested unculled.
    pub min_rays: u32,
}

impl Culling {
    /// No culling.
    pub const NONE: Culling = Culling {
        planes: Planes::None,
        aperture: false,
        frustum: Frustum::Maskless,
        aperture_first: true,
        min_triangles: 0,
        min_rays: 0,
    };

    /// Every stage, on every leaf visit: the fixed setting the benchmarks compare against.
    pub const FULL: Culling = Culling {
        planes: Planes::Six,
        aperture: true,
        frustum: Frustum::Maskless,
        aperture_first: true,
        min_triangles: 1,
        min_rays: 1,
    };

    /// The default: the 6-plane frustum, skipped where it cannot pay (leaves of fewer than 3
    /// triangles, visits with a single active ray), masked when fewer than half the packet's
    /// rays remain. No aperture test: on the bunny it culls about 1% more tests than the planes
    /// and costs more than that saves (`kdbeam render bunny --culling …`).
    pub const AUTO: Culling = Culling {
        planes: Planes::Six,
        aperture: false,
        frustum: Frustum::Adaptive,
        aperture_first: true,
        min_triangles: 3,
        min_rays: 2,
    };

    /// The named presets, for tables and sweeps.
    pub const PRESETS: [(&'static str, Culling); 6] = [
        ("none", Culling::NONE),
        ("4plane", Culling::planes(Planes::Four, false)),
        ("6plane", Culling::planes(Planes::Six, false)),
        ("4plane+aperture", Culling::planes(Planes::Four, true)),
        ("6plane+aperture", Culling::FULL),
        ("auto", Culling::AUTO),
    ];

    /// Every culling setting worth telling apart (culling on): the presets, the masked frustum
    /// and the distance-first order. The differential tests and the fuzzer run each of them.
    pub const VARIANTS: [Culling; 10] = [
        Culling::planes(Planes::Four, false),
        Culling::planes(Planes::Six, false),
        Culling::planes(Planes::Four, true),
        Culling::FULL,
        Culling::AUTO,
        Culling::FULL.with_frustum(Frustum::Masked),
        Culling::FULL
            .with_frustum(Frustum::Masked)
            .with_aperture_first(false),
        Culling::FULL.with_aperture_first(false),
        Culling::planes(Planes::Six, false).with_frustum(Frustum::Packet),
        Culling::FULL.with_frustum(Frustum::Packet),
    ];

    /// Fixed planes and aperture on every leaf visit, maskless.
    pub const fn planes(planes: Planes, aperture: bool) -> Culling {
        Culling {
            planes,
            aperture,
            ..Culling::FULL
        }
    }

    /// The same setting with another frustum.
    pub const fn with_frustum(self, frustum: Frustum) -> Culling {
        Culling { frustum, ..self }
    }

    /// The same setting with the aperture test before (true) or after the near/far planes.
    pub const fn with_aperture_first(self, aperture_first: bool) -> Culling {
        Culling {
            aperture_first,
            ..self
        }
    }

    /// Is any beam built at all?
    pub fn is_enabled(&self) -> bool {
        self.planes != Planes::None
    }

    /// Does the packet traverse the tree as one interval ([`Frustum::Packet`] with a beam)?
    pub(crate) fn interval_traversal(&self) -> bool {
        self.is_enabled() && self.frustum == Frustum::Packet
    }

    /// The kernel's stages.
    pub(crate) fn stages(&self) -> Stages {
        Stages {
            distance: self.planes == Planes::Six,
            aperture: self.aperture,
            aperture_first: self.aperture_first,
        }
    }

    /// The rays to build the beam from, or `None` to test this leaf visit unculled.
    #[inline(always)]
    pub(crate) fn beam_rays(&self, triangles: usize, active: u64, packet: u64) -> Option<u64> {
        let n = active.count_ones();
        if !self.is_enabled() || triangles < self.min_triangles as usize || n < self.min_rays {
            return None;
        }
        Some(match self.frustum {
            Frustum::Masked => active,
            Frustum::Maskless | Frustum::Packet => packet,
            Frustum::Adaptive if 2 * n < packet.count_ones() => active,
            Frustum::Adaptive => packet,
        })
    }

    /// The preset's name, or a description of a custom setting.
    pub fn name(&self) -> String {
        let base = Culling::PRESETS
            .iter()
            .find(|(_, c)| {
                Culling {
                    frustum: self.frustum,
                    aperture_first: self.aperture_first,
                    ..*c
                } == *self
            })
            .map(|(n, _)| n.to_string())
            .unwrap_or_else(|| format!("{self:?}"));
        if !self.is_enabled() || *self == Culling::AUTO {
            return base;
        }
        let frustum = match self.frustum {
            Frustum::Maskless => "maskless",
            Frustum::Masked => "masked",
            Frustum::Adaptive => "adaptive",
            Frustum::Packet => "packet",
        };
        let order = if self.aperture && self.planes == Planes::Six && !self.aperture_first {
            ",distance-first"
        } else {
            ""
        };
        format!("{base}/{frustum}{order}")
    }
}

impl Default for Culling {
    fn default() -> Self {
        Culling::AUTO
    }
}

impl fmt::Display for Culling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

impl FromStr for Culling {
    type Err = Error;

    /// Parses a preset (`none`, `4plane`, `6plane`, `4plane+aperture`, `6plane+aperture`,
    /// `auto`), optionally followed by `/masked`, `/maskless`, `/adaptive` or `/packet` and
    /// `,distance-first` or `,aperture-first`: e.g. `6plane+aperture/masked,distance-first`.
    fn from_str(s: &str) -> Result<Culling> {
        let bad = || {
            Error::InvalidParameter {
            name: "culling",
            message: format!(
                "expected none, 4plane, 6plane, 4plane+aperture, 6plane+aperture or auto, \
                 optionally /masked|/maskless|/adaptive|/packet and ,distance-first|,aperture-first; \
                 got {s:?}"
            ),
        }
        };
        let s = s.trim().to_ascii_lowercase();
        let (rest, order) = match s.split_once(',') {
            Some((r, o)) => (r, Some(o)),
            None => (s.as_str(), None),
        };
        let (preset, frustum) = match rest.split_once('/') {
            Some((p, f)) => (p, Some(f)),
            None => (rest, None),
        };
        let mut c = Culling::PRESETS
            .iter()
            .find(|(n, _)| *n == preset)
            .ok_or_else(bad)?
            .1;
        match frustum {
            None => {}
            Some("masked") => c.frustum = Frustum::Masked,
            Some("maskless") => c.frustum = Frustum::Maskless,
            Some("adaptive") => c.frustum = Frustum::Adaptive,
            Some("packet") => c.frustum = Frustum::Packet,
            Some(_) => return Err(bad()),
        }
        match order {
            None => {}
            Some("distance-first") => c.aperture_first = false,
            Some("aperture-first") => c.aperture_first = true,
            Some(_) => return Err(bad()),
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_round_trip_through_their_names() {
        for (name, c) in Culling::PRESETS {
            assert_eq!(name.parse::<Culling>().unwrap(), c);
            // Without a beam the frustum means nothing, so "none" names every frustum.
            if c.is_enabled() {
                let masked = c.with_frustum(Frustum::Masked);
                let parsed = masked.name().parse::<Culling>().unwrap();
                assert_eq!(parsed, masked, "{}", masked.name());
            }
        }
        let c: Culling = "6plane/packet".parse().unwrap();
        assert!(c.interval_traversal() && c.name() == "6plane/packet");
        assert!(!Culling::NONE
            .with_frustum(Frustum::Packet)
            .interval_traversal());
        let c: Culling = "6plane+aperture/masked,distance-first".parse().unwrap();
        assert_eq!((c.frustum, c.aperture_first), (Frustum::Masked, false));
        assert_eq!(c.name().parse::<Culling>().unwrap(), c);
        assert!("7plane".parse::<Culling>().is_err());
        assert!("4plane/sideways".parse::<Culling>().is_err());
    }
}
