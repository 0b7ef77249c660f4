//! Accuracy against the f64 oracle, and run time next to it: hit/miss disagreements, wrong
//! triangle ids, edge ties (reported, not counted as errors) and the relative error of `t`.
//!
//! [`reference_hits`] computes the exact closest hits of a ray set once (the kd-tree with the
//! f64 watertight oracle in its leaves, [`kdbeam::trace::reference::kd_oracle`]); [`compare`]
//! scores any tracer's hits against them; [`Workload::measure`] times a tracer on the rays and
//! scores its hits in one call.

use std::time::Instant;

use kdbeam::kernels::intersect::oracle::OracleRay;
use kdbeam::rays::secondary::SecondaryRays;
use kdbeam::trace::reference::{kd_oracle, ReferenceHit};
use kdbeam::trace::{Culling, Frustum, Planes, Tracer};
use kdbeam::{Camera, Error, Hit, HitPacket, KdTree, Mesh, Ray, Result};
use rayon::prelude::*;

use crate::render::{self, RaySet, Rays};

/// Relative part of the edge-tie tolerance on `t`: f32 carries 24 bits (6e-8 relative) and a
/// ray–triangle test's few products lose up to ~3 orders of magnitude on grazing rays (the
/// same bound as `tests/kdtree_vs_brute_force.rs`).
pub const TIE_REL_TOLERANCE: f64 = 1e-4;

/// Absolute part of the edge-tie tolerance on `t`, as a fraction of the scene's diagonal: it
/// covers hits near the ray origin, where a relative bound is meaningless.
pub const TIE_DIAG_TOLERANCE: f64 = 1e-6;

/// The culling modes of the run-time-against-error table: none, the four vertex planes, the
/// full frustum (six planes and the aperture test) maskless and masked, and the default.
/// Culling never changes a hit, so their errors are equal and only their run times differ.
pub const CULLINGS: [Culling; 5] = [
    Culling::NONE,
    Culling::planes(Planes::Four, false),
    Culling::FULL,
    Culling::FULL.with_frustum(Frustum::Masked),
    Culling::AUTO,
];

/// How a set of hits differs from the oracle's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Accuracy {
    /// Rays compared.
    pub rays: u64,
    /// Rays that both the tracer and the oracle hit.
    pub both_hit: u64,
    /// Hit/miss disagreements: rays that one side hits and the other misses.
    pub disagreements: u64,
    /// Rays hit by both with a different triangle that is not an edge tie.
    pub wrong_ids: u64,
    /// Edge ties: rays hit by both with a different triangle that the oracle also hits, at the
    /// reference `t` within [`TIE_REL_TOLERANCE`]`·t + `[`TIE_DIAG_TOLERANCE`]`·diagonal` (the
    /// ray crosses a shared edge or vertex). Reported, not errors.
    pub ties: u64,
    /// Median of `|t − t_ref| / t_ref` over the rays hit by both (NaN when there are none).
    pub t_rel_err_median: f64,
    /// 99th percentile (nearest rank) of the same.
    pub t_rel_err_p99: f64,
    /// Largest of the same.
    pub t_rel_err_max: f64,
}

impl Accuracy {
    /// Hit/miss disagreements per million rays (0 for no rays).
    pub fn disagreements_per_million(&self) -> f64 {
        1e6 * self.disagreements as f64 / self.rays.max(1) as f64
    }
}

/// The f64 oracle's closest hit of every ray (on the current rayon pool): `None`
/// for a miss or a ray that cannot be traced.
pub fn reference_hits(tree: &KdTree, rays: &[Ray]) -> Vec<Option<ReferenceHit>> {
    rays.par_iter().map(|r| kd_oracle(tree, r)).collect()
}

/// Scores `hits[i]` (a tracer's closest hit of `rays[i]`) against `reference[i]` (the oracle's,
/// from [`reference_hits`]) on the triangles of `mesh`.
///
/// A different triangle id is an edge tie when the oracle hits that triangle too, at the
/// reference `t` within the tie tolerance (see [`Accuracy::ties`]); otherwise — including a
/// triangle id outside the mesh — it is a wrong id. The relative `t` error is taken over every
/// ray hit by both, ties and wrong ids included; a reference `t` of exactly 0 (a ray starting
/// on a surface) gives an error of 0 when the tracer's `t` is 0 too, `+inf` otherwise (JSON
/// `null`). Rays starting on a surface count as disagreements when the sides differ: there
/// hit/miss is decided by rounding alone.
///
/// ```
/// use kdbeam_cli::report::accuracy::{compare, reference_hits};
/// use kdbeam::{BuildParams, KdTree, Mesh, Ray, Tracer, Vec3};
/// let mesh = Mesh::from_indexed(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], &[0, 1, 2])?;
/// let tree = KdTree::build(&mesh, &BuildParams::default())?;
/// let rays = [0.1f32, 0.3, 0.9].map(|x| Ray::new(Vec3::new(x, 0.2, 0.0), Vec3::Z));
/// let reference = reference_hits(&tree, &rays);
/// let hits = rays.map(|r| Tracer::new(&tree).intersect(&r));
/// let acc = compare(&mesh, &rays, &reference, &hits)?;
/// assert_eq!((acc.both_hit, acc.disagreements, acc.wrong_ids), (2, 0, 0));
/// assert_eq!(acc.t_rel_err_max, 0.0); // t = 1 is exact in f32
/// # Ok::<(), kdbeam::Error>(())
/// ```
///
/// # Errors
/// [`Error::InvalidParameter`] when the three slices differ in length.
pub fn compare(
    mesh: &Mesh,
    rays: &[Ray],
    reference: &[Option<ReferenceHit>],
    hits: &[Hit],
) -> Result<Accuracy> {
    if rays.len() != reference.len() || rays.len() != hits.len() {
        return Err(Error::InvalidParameter {
            name: "hits",
            message: format!(
                "{} rays, {} reference hits and {} hits: the lengths must match",
                rays.len(),
                reference.len(),
                hits.len()
            ),
        });
    }
    let diag = f64::from(mesh.bounds().extent().length());
    let mut acc = Accuracy {
        rays: rays.len() as u64,
        both_hit: 0,
        disagreements: 0,
        wrong_ids: 0,
        ties: 0,
        t_rel_err_median: f64::NAN,
        t_rel_err_p99: f64::NAN,
        t_rel_err_max: f64::NAN,
    };
    let mut errors = Vec::new();
    for ((ray, want), got) in rays.iter().zip(reference).zip(hits) {
        let want = match (got.is_hit(), want) {
            (false, None) => continue,
            (true, Some(w)) => w,
            _ => {
                acc.disagreements += 1;
                continue;
            }
        };
        acc.both_hit += 1;
        let t = f64::from(got.t);
        errors.push(relative_error(t, want.t));
        if got.triangle == want.triangle {
            continue;
        }
        let tol = TIE_REL_TOLERANCE * want.t + TIE_DIAG_TOLERANCE * diag;
        let picked = (got.triangle as usize) < mesh.triangle_count();
        let oracle_t = picked
            .then(|| {
                let tri = mesh.triangle(got.triangle as usize);
                OracleRay::new(ray).intersect(&tri, f64::from(ray.tmin), f64::INFINITY)
            })
            .flatten()
            .map(|h| h.t);
        match oracle_t {
            Some(ot) if (ot - want.t).abs() <= tol => acc.ties += 1,
            _ => acc.wrong_ids += 1,
        }
    }
    if !errors.is_empty() {
        errors.sort_by(f64::total_cmp);
        acc.t_rel_err_median = nearest_rank(&errors, 0.5);
        acc.t_rel_err_p99 = nearest_rank(&errors, 0.99);
        acc.t_rel_err_max = errors[errors.len() - 1];
    }
    Ok(acc)
}

/// `|t − reference| / reference`, with 0/0 = 0 (see [`compare`]).
fn relative_error(t: f64, reference: f64) -> f64 {
    let diff = (t - reference).abs();
    if diff == 0.0 {
        0.0
    } else {
        diff / reference.abs()
    }
}

/// The nearest-rank `q`-quantile of sorted, non-empty `sorted`.
fn nearest_rank(sorted: &[f64], q: f64) -> f64 {
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// A ray set to measure on: the rays, and for primary rays the camera whose 8×8 (or the
/// tracer's) pixel tiles they are traced in.
#[derive(Clone, Debug)]
pub struct Workload {
    /// Which set.
    pub set: RaySet,
    /// The standard camera of the scene at the requested size.
    pub camera: Camera,
    /// The rays, in the order the hits are returned (row by row for primary rays, pixel by
    /// pixel for secondary ones).
    pub rays: Vec<Ray>,
    /// The secondary rays with their pixels, for the secondary sets.
    secondary: Option<SecondaryRays>,
}

/// One tracer timed and scored on a [`Workload`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Measurement {
    /// Median wall-clock nanoseconds per ray over the timed repetitions.
    pub ns_per_ray: f64,
    /// The hits compared with the oracle.
    pub accuracy: Accuracy,
}

impl Workload {
    /// The rays of `set` for `mesh` and its tree, from the standard camera at
    /// `width × height` ([`Rays::new`]; `width · height` random rays, and `ao_rays` rays per
    /// hit for ambient occlusion).
    ///
    /// # Errors
    /// None for a tree of `mesh` (see [`Rays::new`]).
    pub fn new(
        set: RaySet,
        mesh: &Mesh,
        tree: &KdTree,
        width: u32,
        height: u32,
        ao_rays: u32,
    ) -> Result<Workload> {
        let camera = Camera::standard(&tree.bounds(), width, height);
        let rays = Rays::new(set, mesh, &Tracer::new(tree), &camera, ao_rays)?;
        Ok(Workload {
            set,
            camera,
            rays: rays.rays,
            secondary: rays.secondary,
        })
    }

    /// The closest hits of `tracer` on these rays, and the seconds spent tracing: primary rays
    /// in pixel tiles of the tracer's packet shape ([`render::trace_primary`]), secondary rays
    /// in the packets per pixel tile and sample a renderer makes
    /// ([`SecondaryRays::tile_packets`]), random rays as a stream
    /// ([`Tracer::intersect_stream`]). Shadow and AO rays are traced for their closest hit
    /// too, so that their `t` can be scored: their hit/miss is the occlusion answer. Runs on
    /// the current rayon pool: install a one-thread pool for single-thread figures.
    ///
    /// # Errors
    /// Those of [`Tracer::intersect_stream`] (none for a well-formed workload).
    pub fn trace(&self, tracer: &Tracer<'_>) -> Result<(Vec<Hit>, f64)> {
        if let Some(secondary) = &self.secondary {
            let tiles = secondary.tile_packets(&self.camera, tracer.packet());
            let mut sorted = vec![Hit::NONE; self.rays.len()];
            let start = Instant::now();
            let mut slots = Vec::with_capacity(tiles.packets.len());
            let mut rest = &mut sorted[..];
            for p in &tiles.packets {
                let (slot, tail) = rest.split_at_mut(p.len());
                slots.push(slot);
                rest = tail;
            }
            tiles.packets.par_iter().zip(slots).for_each_init(
                HitPacket::default,
                |hp, (p, slot)| {
                    tracer.intersect_packet(p, p.full_mask(), hp);
                    for (j, h) in slot.iter_mut().enumerate() {
                        *h = hp.hit(j);
                    }
                },
            );
            let seconds = start.elapsed().as_secs_f64();
            let mut hits = vec![Hit::NONE; self.rays.len()];
            for (&i, h) in tiles.rays.iter().zip(&sorted) {
                hits[i as usize] = *h;
            }
            return Ok((hits, seconds));
        }
        match self.set {
            RaySet::Primary => {
                let frame = render::trace_primary(tracer, &self.camera, &|_| {});
                Ok((frame.hits, frame.seconds))
            }
            _ => {
                let mut hits = vec![Hit::NONE; self.rays.len()];
                let start = Instant::now();
                tracer.intersect_stream(&self.rays, &mut hits)?;
                Ok((hits, start.elapsed().as_secs_f64()))
            }
        }
    }

    /// Times `tracer` (one untimed warm-up, then the median of `reps` runs, at least 1) and
    /// scores the warm-up's hits against `reference` (from [`reference_hits`] on
    /// `self.rays`) with [`compare`].
    ///
    /// # Errors
    /// Those of [`Workload::trace`] and [`compare`] (a reference of another length).
    pub fn measure(
        &self,
        tracer: &Tracer<'_>,
        mesh: &Mesh,
        reference: &[Option<ReferenceHit>],
        reps: usize,
    ) -> Result<Measurement> {
        let (hits, _) = self.trace(tracer)?;
        let accuracy = compare(mesh, &self.rays, reference, &hits)?;
        let mut times = Vec::with_capacity(reps.max(1));
        for _ in 0..reps.max(1) {
            times.push(self.trace(tracer)?.1);
        }
        times.sort_by(f64::total_cmp);
        Ok(Measurement {
            ns_per_ray: times[times.len() / 2] * 1e9 / self.rays.len().max(1) as f64,
            accuracy,
        })
    }
}
