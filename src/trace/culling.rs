//! Which culling runs when a packet or a single ray enters a leaf.

use std::fmt;
use std::str::FromStr;

use kdbeam_kernels::beam::Stages;
use kdbeam_kernels::{Aabb, Isa, RayPacket};

use super::packet::{
    spread, MAX_BEAM_DIRECTION_SPREAD, MAX_SHARED_WALK_ORIGIN_SPREAD, MIN_BEAM_RAYS,
};
use super::subspace::Subspace;
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

/// A leaf visit of the whole-packet traversal ([`Frustum::Packet`]) with fewer than one in
/// this many of the packet's rays builds its beam around those rays only.
const PACKET_MASKED_SHARE: u32 = 8;

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
    /// `t` (no per-ray masks), and every leaf it enters is culled by the beam of all its rays,
    /// or of the rays that reach the leaf when they are fewer than an eighth of them (a beam of
    /// all would then be mostly space they do not cross, as on a terrain of more triangles than
    /// pixels, each leaf seen by a few rays of a tile). An inner node costs a few scalar
    /// operations instead of one split test per group of lanes; the beam does the per-ray
    /// work. With no planes it is the per-ray traversal.
    ///
    /// **Where its hits may differ from the per-ray path.** A leaf's rays are those whose
    /// segment up to their best hit meets the leaf's box, so a ray is also tested against the
    /// triangles of leaves its own traversal never enters: every test the per-ray path makes is
    /// made, plus some. A ray's closest hit therefore differs from [`Tracer::intersect`]'s only
    /// where such an extra test finds a hit that beats it: a smaller `t`, or the same `t` with a
    /// smaller triangle id (in practice a ray through an edge or vertex shared with a triangle
    /// of a neighbouring leaf, won by rounding or by the tie rule). That hit is exactly what the
    /// intersector reports for that triangle alone, so it is never farther than the per-ray
    /// path's, never a triangle the ray does not hit, and a miss there can only become such a
    /// hit; [`Tracer::occluded_packet`] may likewise report a ray occluded by it. Nothing else
    /// differs. The test `culling_never_changes_a_hit_on_procedural_and_adversarial_scenes`
    /// (`tests/culling_vs_none.rs`) and the fuzz target `culling` check every such difference
    /// with `wins_by_an_extra_test` (`tests/fuzz_checks/mod.rs`).
    ///
    /// [`Tracer::intersect`]: crate::Tracer::intersect
    /// [`Tracer::occluded_packet`]: crate::Tracer::occluded_packet
    Packet,
    /// Chosen per packet from how far apart its rays start and point (four of them compared):
    /// - ray by ray, as below, or as a packet (the per-ray packet traversal, with the beams of
    ///   the two cases after the next), whichever this thread has measured the faster on the
    ///   tree for the kind of query (TSC cycles per ray, the other way retried on 1 packet in
    ///   16 to 1 in 1024, the rarer the slower it is; ray by ray where there is no cycle
    ///   counter), where neighbouring rays reach
    ///   the scene more than 0.55% of its largest extent apart (origins apart, or directions
    ///   apart times the distance to the scene's centre): a mesh seen a few dozen pixels
    ///   wide, such as an instance far from the camera, or a small image, where each ray of a
    ///   tile has leaves of its own; or the shadow rays of a room seen from inside, which
    ///   land apart but end in the first leaf they reach, where the packet's shared descent
    ///   pays. Either way finds the same hits;
    /// - [`Frustum::Packet`] for coherent rays: unit directions within 0.02 of each other on
    ///   every axis, and origins within 1/1024 of the scene's extent (a camera's tiles at 512²
    ///   and above) or a footprint within 2% of it (rays that start apart but run side by
    ///   side, such as a small tile's shadow rays toward a distant light). Such a packet
    ///   builds its beam on every leaf visit, whatever
    ///   [`Culling::min_triangles`] and [`Culling::min_rays`] say (they serve the per-ray
    ///   traversal): there a visit without one tests every triangle against every ray in the
    ///   leaf's box. Hits as [`Frustum::Packet`] documents;
    /// - [`Frustum::Adaptive`] for more than 16 active rays whose unit directions lie within
    ///   0.25 of each other but that are not coherent (shadow rays of a wide tile, or toward a
    ///   light close by): the one interval of the whole-packet traversal would bound their
    ///   segments loosely;
    /// - no beam for at most 16 such rays, whose beam costs more than it culls: the per-ray
    ///   packet traversal, the setting's other stages (ray-box culling) kept;
    /// - measured as in the first case, without beams, for the rest (ambient-occlusion and
    ///   diffuse rays), whose directions differ too much for a beam: ray by ray, each finds
    ///   the hit
    ///   [`Tracer::intersect`](crate::Tracer::intersect) finds, with the setting's single-ray
    ///   stages, through the tree's wide nodes on SIMD lanes. Without a single-ray stage,
    ///   rays whose origins lie within a sixteenth of the scene's extent of each other (a
    ///   tile's secondary rays) walk side by side, a lane each, one vector of rays per child
    ///   box; others go two at a time, their walks interleaved.
    Coherent,
}

/// How a packet's rays are traced ([`Culling::for_packet`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum PacketTrace {
    /// Through the packet traversal, culled as this setting says.
    Packet(Culling),
    /// One by one, as single rays with the tracer's single-ray stages; with `together`, a
    /// group of lanes' rays at a time walks the wide nodes side by side, a vector of rays per
    /// box test (when no single-ray stage culls).
    RayByRay {
        /// Do the rays start close enough together to share their walk's nodes?
        together: bool,
    },
    /// Ray by ray as [`PacketTrace::RayByRay`] with `together`, or through the packet
    /// traversal culled as `packet` says, whichever this thread has measured the faster for the
    /// tree and the kind of query ([`super::measured_choice`]).
    Measured {
        /// Do the rays start close enough together to share their walk's nodes?
        together: bool,
        /// The culling of the packet traversal (an exact one: never the whole-packet walk).
        packet: Culling,
    },
}

/// Where ray-box culling (Nah et al.; [`Culling::with_raybox`]) runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayBoxes {
    /// Nowhere.
    Off,
    /// Where it pays: packets' leaf visits of a few rays and no beam, and single rays on the
    /// scalar ISA. With a vector of lanes, one ray tests as many triangles per instruction as
    /// the stage tests boxes, so it cannot save a single ray more than it costs; a packet's
    /// few rays share one box test over every lane, and the scalar ISA tests one triangle at a
    /// time.
    Auto,
    /// Every leaf visit it can serve: every single-ray leaf, and packets' leaf visits of a few
    /// rays and no beam (the setting of Nah et al.'s experiments).
    On,
}

impl RayBoxes {
    /// Its value in the culling grammar's `/raybox=` option: `off`, `auto`, `on`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RayBoxes::Off => "off",
            RayBoxes::Auto => "auto",
            RayBoxes::On => "on",
        }
    }
}

/// Culling in the leaves: which planes, the aperture test, which rays, in which order, and
/// which leaves skip it.
///
/// Every stage is conservative: the closest hit of every ray, its `t` and its triangle id are
/// the same as without culling (the differential tests check this on every ISA and packet
/// size).
///
/// Start from a preset ([`Culling::AUTO`], [`Culling::FULL`], [`Culling::planes`], …) or parse
/// the grammar of its `FromStr`, and change it with the `with_*` methods (the struct is
/// `#[non_exhaustive]`: stages may be added, so it cannot be written as a literal outside this
/// crate); the fields stay public to read and assign.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
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
    /// Where ray-box culling of single rays and of packets' leaf visits of few rays runs (Nah
    /// et al.; [`Culling::with_raybox`]).
    pub raybox: RayBoxes,
    /// Subspace culling of single rays ([`Subspace`]); packets ignore it.
    pub subspace: Option<Subspace>,
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
        raybox: RayBoxes::Off,
        subspace: None,
    };

    /// Every stage, on every leaf visit: the fixed setting the benchmarks compare against.
    pub const FULL: Culling = Culling {
        planes: Planes::Six,
        aperture: true,
        frustum: Frustum::Maskless,
        aperture_first: true,
        min_triangles: 1,
        min_rays: 1,
        raybox: RayBoxes::Off,
        subspace: None,
    };

    /// The default: the 6-plane frustum, skipped where it cannot pay (leaves of fewer than 3
    /// triangles, visits with a single active ray), masked when fewer than half the packet's
    /// rays remain; coherent packets traverse the tree as a whole ([`Frustum::Coherent`]);
    /// ray-box culling where it pays ([`RayBoxes::Auto`]: the leaf visits of a
    /// few rays that build no beam, and single rays on the scalar ISA). No aperture test: on
    /// real scenes it culls few tests beyond the planes, and costs more than that saves
    /// (`kdbeam bench SCENE --culling auto,auto+aperture` compares).
    pub const AUTO: Culling = Culling {
        planes: Planes::Six,
        aperture: false,
        frustum: Frustum::Coherent,
        aperture_first: true,
        min_triangles: 3,
        min_rays: 2,
        raybox: RayBoxes::Auto,
        subspace: None,
    };

    /// The named presets, for tables and sweeps.
    pub const PRESETS: [(&'static str, Culling); 8] = [
        ("none", Culling::NONE),
        ("raybox", Culling::NONE.with_raybox(RayBoxes::On)),
        ("4plane", Culling::planes(Planes::Four, false)),
        ("6plane", Culling::planes(Planes::Six, false)),
        ("4plane+aperture", Culling::planes(Planes::Four, true)),
        ("6plane+aperture", Culling::FULL),
        ("auto", Culling::AUTO),
        ("auto+raybox", Culling::AUTO.with_raybox(RayBoxes::On)),
    ];

    /// Every culling setting worth telling apart (culling on): the presets, the masked frustum
    /// and the distance-first order, ray-box culling alone, with the default and in every leaf
    /// visit it can serve. The differential tests and the fuzzer run each of them.
    pub const VARIANTS: [Culling; 13] = [
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
        Culling::NONE.with_raybox(RayBoxes::On),
        Culling::NONE.with_raybox(RayBoxes::Auto),
        Culling::AUTO.with_raybox(RayBoxes::On),
    ];

    /// Fixed planes and aperture on every leaf visit, maskless.
    #[must_use]
    pub const fn planes(planes: Planes, aperture: bool) -> Culling {
        Culling {
            planes,
            aperture,
            ..Culling::FULL
        }
    }

    /// The same setting with another frustum.
    #[must_use]
    pub const fn with_frustum(self, frustum: Frustum) -> Culling {
        Culling { frustum, ..self }
    }

    /// The same setting with the aperture test before (true) or after the near/far planes.
    #[must_use]
    pub const fn with_aperture_first(self, aperture_first: bool) -> Culling {
        Culling {
            aperture_first,
            ..self
        }
    }

    /// The same setting with another [`min_triangles`](Culling::min_triangles).
    #[must_use]
    pub const fn with_min_triangles(self, min_triangles: u32) -> Culling {
        Culling {
            min_triangles,
            ..self
        }
    }

    /// The same setting with another [`subspace`](Culling::subspace) stage.
    #[must_use]
    pub const fn with_subspace(self, subspace: Option<Subspace>) -> Culling {
        Culling { subspace, ..self }
    }

    /// The same setting with another [`min_rays`](Culling::min_rays).
    #[must_use]
    pub const fn with_min_rays(self, min_rays: u32) -> Culling {
        Culling { min_rays, ..self }
    }

    /// The same setting with ray-box culling off, where it pays, or on: in a leaf of at least
    /// three triangles, a ray's segment there (up to its closest hit so far) is boxed and
    /// tested against a box per triangle clipped to the leaf (Nah, Park, Kang & Han, *Ray-Box
    /// Culling for Tree Structures*, J. Inf. Sci. Eng.), before any ray–triangle test. Single
    /// rays do this in every such leaf (with [`RayBoxes::Auto`], on the scalar ISA only);
    /// packets in the per-ray traversal's leaf visits that build no beam and hold at most four
    /// active rays, with one box around those rays' segments. The tree's boxes are built on
    /// first use ([`crate::KdTree::triangle_boxes`]).
    #[must_use]
    pub const fn with_raybox(self, raybox: RayBoxes) -> Culling {
        Culling { raybox, ..self }
    }

    /// Do single rays traced on `isa` run ray-box culling? [`RayBoxes::Auto`] runs it on
    /// [`Isa::Scalar`] only.
    ///
    /// Two settings whose [`single_ray_stages`](Culling::single_ray_stages) agree on
    /// [`subspace`](Culling::subspace) and on this answer trace single rays on `isa` the
    /// same way.
    ///
    /// ```
    /// use kdbeam::{Culling, Isa};
    ///
    /// assert!(Culling::AUTO.runs_raybox_on_single_rays(Isa::Scalar));
    /// assert!(!Culling::AUTO.runs_raybox_on_single_rays(Isa::Avx2));
    /// assert!(!Culling::NONE.runs_raybox_on_single_rays(Isa::Scalar));
    /// ```
    #[must_use]
    pub fn runs_raybox_on_single_rays(&self, isa: Isa) -> bool {
        match self.raybox {
            RayBoxes::Off => false,
            RayBoxes::Auto => isa == Isa::Scalar,
            RayBoxes::On => true,
        }
    }

    /// Do packets' leaf visits of few rays and no beam run ray-box culling?
    pub(crate) fn raybox_packets(&self) -> bool {
        self.raybox != RayBoxes::Off
    }

    /// The stages single rays run (the rest of the setting is for packets): the
    /// [`raybox`](Culling::raybox) and [`subspace`](Culling::subspace) stages, on
    /// [`Culling::NONE`].
    #[must_use]
    pub const fn single_ray_stages(&self) -> Culling {
        Culling::NONE
            .with_subspace(self.subspace)
            .with_raybox(self.raybox)
    }

    /// Is any beam built at all?
    #[must_use]
    pub fn is_enabled(&self) -> bool {
        self.planes != Planes::None
    }

    /// May a packet traverse the tree as one interval ([`Frustum::Packet`], or
    /// [`Frustum::Coherent`] with coherent rays, with a beam)? Its rays' hits may then differ
    /// from the per-ray path's as [`Frustum::Packet`] documents, where a differential test
    /// must allow it.
    #[must_use]
    pub fn may_traverse_whole_packets(&self) -> bool {
        self.is_enabled() && matches!(self.frustum, Frustum::Packet | Frustum::Coherent)
    }

    /// How the rays `active` of `packet` are traced, in a scene of box `bounds`:
    /// [`Frustum::Coherent`] resolved as it documents; any other setting as a packet with the
    /// setting as it is.
    pub(crate) fn for_packet(self, packet: &RayPacket, active: u64, bounds: &Aabb) -> PacketTrace {
        if self.frustum != Frustum::Coherent || !self.is_enabled() {
            return PacketTrace::Packet(self);
        }
        let s = spread(packet, active, bounds);
        let together = s.origin <= MAX_SHARED_WALK_ORIGIN_SPREAD;
        let rays = (active & packet.full_mask()).count_ones();
        // Beams where the rays point closely enough together to share them and are many
        // enough to pay for them.
        let per_ray = if s.direction <= MAX_BEAM_DIRECTION_SPREAD && rays >= MIN_BEAM_RAYS {
            self.with_frustum(Frustum::Adaptive)
        } else {
            Culling {
                planes: Planes::None,
                ..self
            }
        };
        if s.is_sparse(rays) || s.direction > MAX_BEAM_DIRECTION_SPREAD {
            PacketTrace::Measured {
                together,
                packet: per_ray,
            }
        } else if s.is_coherent() {
            PacketTrace::Packet(Culling {
                frustum: Frustum::Packet,
                min_triangles: 1,
                min_rays: 1,
                ..self
            })
        } else {
            PacketTrace::Packet(per_ray)
        }
    }

    /// Does a packet traverse the tree as one interval ([`Frustum::Packet`] with a beam)?
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
            Frustum::Maskless => packet,
            Frustum::Adaptive | Frustum::Coherent if 2 * n < packet.count_ones() => active,
            Frustum::Packet if n * PACKET_MASKED_SHARE < packet.count_ones() => active,
            Frustum::Adaptive | Frustum::Coherent | Frustum::Packet => packet,
        })
    }

    /// The setting's name in the grammar [`Culling`]'s `FromStr` reads, which parses back to it.
    ///
    /// Of the bases that fit (`none`, `4plane`, `6plane`, `auto`) the one that needs the fewest
    /// options is named (`auto` before `6plane` on a tie), then `+aperture` when the aperture
    /// test is on, then the single-ray stages (`+raybox`, then the subspace stage; on the
    /// `none` base they stand alone: `raybox`, `raybox+subspace`), then, in this order, each
    /// option whose value differs from the base's: the frustum, the order, `min-triangles=N`,
    /// `min-rays=N`, `raybox=off|auto` (ray-box culling on prints as the `+raybox` stage). So
    /// the presets print as their names (`6plane+aperture`, `auto`), and e.g.
    /// [`Culling::FULL`] with the masked frustum and the distance-first order as
    /// `6plane+aperture/masked/distance-first`.
    #[must_use]
    pub fn name(&self) -> String {
        let options = |base: &Culling| {
            let mut options = Vec::new();
            if self.frustum != base.frustum {
                options.push(self.frustum.name().to_string());
            }
            if self.aperture_first != base.aperture_first {
                options.push(order_name(self.aperture_first).to_string());
            }
            if self.min_triangles != base.min_triangles {
                options.push(format!("min-triangles={}", self.min_triangles));
            }
            if self.min_rays != base.min_rays {
                options.push(format!("min-rays={}", self.min_rays));
            }
            if self.raybox != base.raybox && self.raybox != RayBoxes::On {
                options.push(format!("raybox={}", self.raybox.name()));
            }
            options
        };
        let (base_name, options) = BASES
            .iter()
            .filter(|(_, base)| base.planes == self.planes)
            .map(|(name, base)| (*name, options(base)))
            .min_by_key(|(_, options)| options.len())
            .expect("every `Planes` has a base");
        let mut name = base_name.to_string();
        if self.aperture {
            name.push_str("+aperture");
        }
        let single = [
            (self.raybox == RayBoxes::On).then_some("raybox"),
            self.subspace.map(Subspace::name),
        ];
        for stage in single.into_iter().flatten() {
            if name == "none" {
                name.clear();
            } else {
                name.push('+');
            }
            name.push_str(stage);
        }
        for option in options {
            name.push('/');
            name.push_str(&option);
        }
        name
    }
}

/// The bases of the grammar, each with the settings it stands for; `auto` before `6plane`, so
/// that [`Culling::name`] prefers it on a tie.
const BASES: [(&str, Culling); 4] = [
    ("none", Culling::NONE),
    ("4plane", Culling::planes(Planes::Four, false)),
    ("auto", Culling::AUTO),
    ("6plane", Culling::planes(Planes::Six, false)),
];

/// The option that sets [`Culling::aperture_first`].
fn order_name(aperture_first: bool) -> &'static str {
    if aperture_first {
        "aperture-first"
    } else {
        "distance-first"
    }
}

impl Frustum {
    /// Every frustum.
    pub const ALL: [Frustum; 5] = [
        Frustum::Maskless,
        Frustum::Masked,
        Frustum::Adaptive,
        Frustum::Packet,
        Frustum::Coherent,
    ];

    /// Its option in the culling grammar, without the `/`: `maskless`, `masked`, `adaptive`,
    /// `packet`, `coherent`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Frustum::Maskless => "maskless",
            Frustum::Masked => "masked",
            Frustum::Adaptive => "adaptive",
            Frustum::Packet => "packet",
            Frustum::Coherent => "coherent",
        }
    }
}

impl Default for Culling {
    fn default() -> Self {
        Culling::AUTO
    }
}

impl fmt::Display for Culling {
    /// [`Culling::name`].
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// What the culling grammar accepts, for error messages.
const GRAMMAR: &str = "a base (none, 4plane, 6plane or auto), optionally +aperture, +raybox and \
    one of +subspace|+subspace6|+subspace-exact|+subspace6-exact (single-ray stages alone are \
    none with them: raybox, subspace, raybox+subspace), then any of \
    /masked|/maskless|/adaptive|/packet|/coherent, /distance-first|/aperture-first, \
    /min-triangles=N, /min-rays=N, /raybox=off|auto (at most one of each kind, and no /raybox= \
    with +raybox): e.g. 6plane+aperture/masked/distance-first";

impl FromStr for Culling {
    type Err = Error;

    /// Parses the culling grammar, ignoring ASCII case and surrounding whitespace: `+` joins
    /// stages to a base, `/` precedes each option, and nothing contains a comma (so that lists
    /// of settings can be comma separated).
    ///
    /// - The base: `none`, `4plane`, `6plane` (fixed planes on every leaf visit, maskless) or
    ///   `auto` ([`Culling::AUTO`]); then `+aperture` adds the aperture test and `+raybox`
    ///   ray-box culling ([`Culling::with_raybox`]), in either order; `raybox`
    ///   alone is `none+raybox`. Every preset of [`Culling::PRESETS`] is such a name
    ///   (`4plane+aperture`, `6plane+aperture`, `auto+raybox`).
    /// - The options: the frustum (`/maskless`, `/masked`, `/adaptive`, `/packet`,
    ///   `/coherent`), the order (`/aperture-first`, `/distance-first`), the leaves and visits
    ///   that skip culling (`/min-triangles=N`, `/min-rays=N`), and where ray-box culling runs
    ///   when the stage does not say (`/raybox=off`, `/raybox=auto`: [`RayBoxes`]; `auto` has
    ///   it where it pays, the other bases nowhere), at most one of each kind, in any order.
    ///
    /// [`Culling::name`] prints every setting in this grammar, and it parses back to the same
    /// setting.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] named `culling` for anything else: an unknown base, stage or
    /// option, a repeated stage or option kind, an empty part, a comma.
    ///
    /// ```
    /// use kdbeam::trace::{Culling, Frustum};
    /// let c: Culling = "6plane+aperture/masked/distance-first".parse()?;
    /// assert_eq!(c, Culling::FULL.with_frustum(Frustum::Masked).with_aperture_first(false));
    /// assert_eq!(c.to_string(), "6plane+aperture/masked/distance-first");
    /// assert!("6plane,distance-first".parse::<Culling>().is_err());
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    fn from_str(s: &str) -> Result<Culling> {
        let bad = |why: String| Error::InvalidParameter {
            name: "culling",
            message: format!("{why} in {s:?}; expected {GRAMMAR}"),
        };
        let lower = s.trim().to_ascii_lowercase();
        if lower.contains(',') {
            return Err(bad("a comma (options follow a /)".into()));
        }
        let mut parts = lower.split('/');
        let mut stages = parts.next().unwrap_or_default().split('+');
        let base = stages.next().unwrap_or_default();
        let subspace_named = |stage: &str| Subspace::ALL.into_iter().find(|s| s.name() == stage);
        // A single-ray stage may stand as the base: it is then `none` with that stage.
        let (mut c, first) = match BASES.iter().find(|(name, _)| *name == base) {
            Some((_, c)) => (*c, None),
            None if base == "raybox" || subspace_named(base).is_some() => {
                (Culling::NONE, Some(base))
            }
            None => return Err(bad(format!("unknown base {base:?}"))),
        };
        let (mut aperture, mut raybox, mut subspace) = (false, false, None);
        for stage in first.into_iter().chain(stages) {
            let twice = match (stage, subspace_named(stage)) {
                ("aperture", _) => std::mem::replace(&mut aperture, true),
                ("raybox", _) => std::mem::replace(&mut raybox, true),
                (_, Some(s)) => subspace.replace(s).is_some(),
                _ => return Err(bad(format!("unknown stage {stage:?}"))),
            };
            if twice {
                return Err(bad(format!("{stage} twice, or two subspace stages")));
            }
        }
        c.aperture |= aperture;
        if raybox {
            c.raybox = RayBoxes::On;
        }
        c.subspace = subspace;
        let (mut frustum, mut order, mut triangles, mut rays) = (None, None, None, None);
        let mut boxes = None;
        for option in parts {
            let (slot, value) = match option.split_once('=') {
                Some(("min-triangles", n)) => (&mut triangles, n),
                Some(("min-rays", n)) => (&mut rays, n),
                Some(("raybox", v)) => {
                    let value = [RayBoxes::Off, RayBoxes::Auto]
                        .into_iter()
                        .find(|b| b.name() == v)
                        .ok_or_else(|| bad(format!("{option:?}: raybox= takes off or auto")))?;
                    if raybox || boxes.replace(value).is_some() {
                        return Err(bad(format!("{option:?} with another raybox setting")));
                    }
                    c.raybox = value;
                    continue;
                }
                _ => {
                    match Frustum::ALL.into_iter().find(|f| f.name() == option) {
                        Some(f) if frustum.is_none() => frustum = Some(f),
                        Some(_) => return Err(bad("two frustum options".into())),
                        None => {
                            match [true, false].into_iter().find(|&a| order_name(a) == option) {
                                Some(a) if order.is_none() => order = Some(a),
                                Some(_) => return Err(bad("two order options".into())),
                                None => return Err(bad(format!("unknown option {option:?}"))),
                            }
                        }
                    }
                    continue;
                }
            };
            if slot.is_some() {
                return Err(bad(format!("{option:?} repeats its option")));
            }
            let n = value
                .parse::<u32>()
                .map_err(|_| bad(format!("{option:?} needs a count from 0 to 2^32 − 1")))?;
            *slot = Some(n);
        }
        c.frustum = frustum.unwrap_or(c.frustum);
        c.aperture_first = order.unwrap_or(c.aperture_first);
        c.min_triangles = triangles.unwrap_or(c.min_triangles);
        c.min_rays = rays.unwrap_or(c.min_rays);
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use kdbeam_kernels::{Ray, Vec3};

    use super::*;

    #[test]
    fn the_default_resolves_by_how_far_apart_a_packets_rays_are() {
        let packet = |n: usize, ray: &dyn Fn(f32) -> Ray| {
            let rays: Vec<Ray> = (0..n).map(|i| ray(i as f32 / n as f32)).collect();
            RayPacket::from_rays(&rays)
        };
        let unit = Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5));
        let trace = |p: &RayPacket| Culling::AUTO.for_packet(p, p.full_mask(), &unit);
        let resolve = |p: &RayPacket| match trace(p) {
            PacketTrace::Packet(c) => c,
            other => panic!("{p:?}: {other:?}"),
        };
        // Contested: ray by ray or the per-ray packet traversal, as measured.
        let measured = |together: bool, packet: Culling| PacketTrace::Measured { together, packet };
        let unbeamed = Culling {
            planes: Planes::None,
            ..Culling::AUTO
        };
        // A camera's tile: one origin, directions within 0.02.
        let tile = packet(64, &|f| Ray::new(Vec3::ZERO, Vec3::new(f * 0.01, 0.0, 1.0)));
        assert_eq!(resolve(&tile).frustum, Frustum::Packet);
        // The same tile on a scene 100 times farther away: its rays land apart, contested,
        // with beams if traced as a packet.
        let far = Aabb::new(Vec3::new(-0.5, -0.5, 99.5), Vec3::new(0.5, 0.5, 100.5));
        assert_eq!(
            Culling::AUTO.for_packet(&tile, tile.full_mask(), &far),
            measured(true, Culling::AUTO.with_frustum(Frustum::Adaptive))
        );
        // Sixteen of them: without beams.
        let small = packet(16, &|f| Ray::new(Vec3::ZERO, Vec3::new(f * 0.01, 0.0, 1.0)));
        assert_eq!(
            Culling::AUTO.for_packet(&small, small.full_mask(), &far),
            measured(true, unbeamed)
        );
        // A tile's shadow rays: origins 1% of the scene apart, converging on the light.
        let shadow_to = |light: Vec3| {
            move |f: f32| {
                let o = Vec3::new(f * 0.01, 0.0, 0.0);
                Ray::new(o, light - o)
            }
        };
        // To a distant light they run side by side: traversed as a whole.
        let side_by_side = shadow_to(Vec3::new(0.0, 0.0, 10.0));
        for n in [16, 64] {
            assert_eq!(resolve(&packet(n, &side_by_side)).frustum, Frustum::Packet);
        }
        // To a light close by they fan out (directions 0.05 apart): the adaptive beam.
        let fanned = shadow_to(Vec3::new(0.0, 0.0, 0.2));
        let resolved = resolve(&packet(64, &fanned));
        assert_eq!(
            (resolved.frustum, resolved.planes),
            (Frustum::Adaptive, Planes::Six)
        );
        // Sixteen of them: no beam, ray-box culling kept.
        let resolved = resolve(&packet(16, &fanned));
        assert!(!resolved.is_enabled(), "{resolved:?}");
        assert_eq!(resolved.raybox, RayBoxes::Auto);
        // Rays over a hemisphere: contested without beams, however many.
        let hemisphere = |f: f32| Ray::new(Vec3::ZERO, Vec3::new(f - 0.5, 0.3, 1.0 - f));
        for p in [packet(16, &hemisphere), packet(64, &hemisphere)] {
            assert_eq!(trace(&p), measured(true, unbeamed));
        }
        // Rays that start all over the scene: contested, each walking alone ray by ray.
        let scattered = |f: f32| {
            Ray::new(
                Vec3::new(f - 0.5, 0.0, 0.0),
                Vec3::new(f - 0.5, 0.3, 1.0 - f),
            )
        };
        assert_eq!(trace(&packet(64, &scattered)), measured(false, unbeamed));
        // A setting that is not `Coherent` is traced as it is.
        let fixed = Culling::FULL;
        assert_eq!(
            fixed.for_packet(&packet(64, &hemisphere), u64::MAX, &unit),
            PacketTrace::Packet(fixed)
        );
    }

    /// Every base, with and without the aperture test, ray-box culling and subspace stages.
    fn stage_lists() -> Vec<String> {
        let mut lists: Vec<String> = BASES
            .iter()
            .flat_map(|(name, _)| {
                [
                    name.to_string(),
                    format!("{name}+aperture"),
                    format!("{name}+raybox"),
                    format!("{name}+raybox+aperture"),
                ]
            })
            .chain(["raybox".into(), "raybox+aperture".into()])
            .collect();
        for s in Subspace::ALL {
            lists.push(s.name().to_string());
            lists.push(format!("auto+{}", s.name()));
            lists.push(format!("6plane+aperture+{}", s.name()));
            lists.push(format!("raybox+{}", s.name()));
            lists.push(format!("auto+raybox+{}", s.name()));
        }
        lists
    }

    /// Every combination of options, each kind absent or set to each of its values.
    fn option_lists() -> Vec<String> {
        let frusta = std::iter::once(None).chain(Frustum::ALL.map(|f| Some(f.name())));
        let mut lists = Vec::new();
        for frustum in frusta {
            for order in [None, Some("aperture-first"), Some("distance-first")] {
                for triangles in [None, Some("min-triangles=0"), Some("min-triangles=7")] {
                    for rays in [None, Some("min-rays=1"), Some("min-rays=64")] {
                        let options = [frustum, order, triangles, rays];
                        lists.push(
                            options
                                .into_iter()
                                .flatten()
                                .map(|o| format!("/{o}"))
                                .collect(),
                        );
                    }
                }
            }
        }
        lists
    }

    #[test]
    fn every_base_stage_and_option_parses_and_prints_back() {
        let (mut names, mut settings) = (HashSet::new(), HashSet::new());
        for stages in stage_lists() {
            for options in option_lists() {
                let text = format!("{stages}{options}");
                let c: Culling = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
                assert_eq!(c.aperture, stages.contains("+aperture"), "{text}");
                assert_eq!(
                    c.raybox == RayBoxes::On,
                    stages.contains("raybox"),
                    "{text}"
                );
                assert_eq!(c.subspace.is_some(), stages.contains("subspace"), "{text}");
                let name = c.to_string();
                assert!(!name.contains(','), "{name}");
                assert_eq!(
                    name.parse::<Culling>().unwrap(),
                    c,
                    "{text} printed as {name}"
                );
                names.insert(name);
                settings.insert(c);
                // Upper case, spaces around, and the options in reverse order: the same setting.
                let mut reversed: Vec<&str> = options.split('/').skip(1).collect();
                reversed.reverse();
                let shuffled = format!(
                    " {} ",
                    [stages.as_str()]
                        .into_iter()
                        .chain(reversed)
                        .collect::<Vec<_>>()
                        .join("/")
                );
                assert_eq!(
                    shuffled.to_uppercase().parse::<Culling>().unwrap(),
                    c,
                    "{shuffled}"
                );
            }
        }
        // One name per setting, and many settings covered.
        assert_eq!(names.len(), settings.len());
        assert!(settings.len() > 600, "{}", settings.len());
    }

    #[test]
    fn presets_and_variants_print_as_their_names() {
        for (name, c) in Culling::PRESETS {
            assert_eq!(name.parse::<Culling>().unwrap(), c);
            assert_eq!(c.to_string(), name);
        }
        for c in Culling::VARIANTS {
            assert_eq!(c.to_string().parse::<Culling>().unwrap(), c, "{c}");
        }
        for s in Subspace::ALL {
            let c = Culling::NONE.with_subspace(Some(s));
            assert_eq!(c.to_string(), s.name());
            assert_eq!(s.name().parse::<Culling>().unwrap(), c);
            assert_eq!(format!("none+{}", s.name()).parse::<Culling>().unwrap(), c);
            let auto = Culling::AUTO.with_subspace(Some(s));
            assert_eq!(auto.to_string(), format!("auto+{}", s.name()));
        }
        let c: Culling = "6plane/packet".parse().unwrap();
        assert!(c.may_traverse_whole_packets() && c.to_string() == "6plane/packet");
        assert!(Culling::AUTO.may_traverse_whole_packets());
        assert!(!Culling::NONE
            .with_frustum(Frustum::Packet)
            .may_traverse_whole_packets());
        assert!(!Culling::AUTO
            .with_frustum(Frustum::Adaptive)
            .may_traverse_whole_packets());
        let c = Culling::FULL
            .with_frustum(Frustum::Masked)
            .with_aperture_first(false);
        assert_eq!(c.to_string(), "6plane+aperture/masked/distance-first");
        assert_eq!(
            Culling::AUTO.with_frustum(Frustum::Masked).to_string(),
            "auto/masked"
        );
        assert_eq!(
            "raybox".parse::<Culling>().unwrap(),
            Culling::NONE.with_raybox(RayBoxes::On)
        );
        assert_eq!(Culling::AUTO.raybox, RayBoxes::Auto);
        for (text, c) in [
            ("auto/raybox=off", Culling::AUTO.with_raybox(RayBoxes::Off)),
            (
                "none/raybox=auto",
                Culling::NONE.with_raybox(RayBoxes::Auto),
            ),
            (
                "6plane+aperture/raybox=auto",
                Culling::FULL.with_raybox(RayBoxes::Auto),
            ),
        ] {
            assert_eq!(text.parse::<Culling>().unwrap(), c, "{text}");
            assert_eq!(c.to_string(), text);
        }
        assert_eq!(
            "none+raybox".parse::<Culling>().unwrap().to_string(),
            "raybox"
        );
        let c: Culling = "raybox+aperture/min-rays=3".parse().unwrap();
        assert!(c.raybox == RayBoxes::On && c.aperture && c.planes == Planes::None);
        assert_eq!(c.min_rays, 3);
        assert_eq!(c.to_string().parse::<Culling>().unwrap(), c, "{c}");
    }

    #[test]
    fn bad_strings_are_invalid_parameters() {
        for bad in [
            "",
            "7plane",
            "4plane/sideways",
            "6plane,distance-first",
            "6plane+aperture/masked,distance-first",
            "6plane+frustum",
            "raybox+raybox",
            "auto+raybox+raybox",
            "auto+raybox/raybox=off",
            "auto/raybox=on",
            "auto/raybox=off/raybox=auto",
            "auto/raybox",
            "none+raybox+aperture+raybox",
            "subspace+subspace6",
            "none+subspace+subspace",
            "subspace7",
            "6plane+subspace-ideal",
            "6plane+aperture+aperture",
            "aperture",
            "6plane/",
            "6plane//masked",
            "6plane/masked/packet",
            "6plane/distance-first/aperture-first",
            "6plane/min-triangles=",
            "6plane/min-triangles=-1",
            "6plane/min-triangles=1/min-triangles=2",
            "6plane/min-rays=x",
            "auto/min-rays",
        ] {
            match bad.parse::<Culling>() {
                Err(Error::InvalidParameter {
                    name: "culling", ..
                }) => {}
                other => panic!("{bad:?}: {other:?}"),
            }
        }
    }
}
