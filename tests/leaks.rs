//! Leak tests through the whole tracer (kd-tree traversal, packets on every ISA and packet shape,
//! single rays): closed meshes — an icosphere of radius 2 centred at (148376, 1234, −223423),
//! where `f32` spacing is 1/64, and closed boxes of quad grids far from and at the origin — and
//! rays aimed exactly at their shared edges and vertices, from inside and from outside.
//!
//! Every ray passes through an interior point `p` and a target on an edge or vertex (the lerp of
//! an edge's two vertices, or a vertex itself): from inside, it starts at `p`; from outside, it
//! starts beyond the target on the line from `p`. The meshes are convex, so the first surface
//! point along the ray is the target, at `t = 1` up to the rounding of the target (under 3% here,
//! see [`T_MAX`]). A *leak* is a ray that misses everything in `[0, T_MAX]`: from inside a closed
//! mesh, or through its surface from outside. The kernel-level leak test
//! (`kernels/tests/watertight_leaks.rs`) checks the triangle tests alone; this one adds the
//! tree, the packet masks and the leaf culling around them.
//!
//! The watertight tracer must leak 0 rays, and does. It did not at first: the kd-tree traversal
//! computed the `t` of each cell boundary on its own, so where a ray meets a shared edge lying on
//! two boundaries at once (a split plane and the root box, as in
//! [`ray_through_an_edge_on_a_split_plane_at_the_root_box_hits`]) one ulp could make it skip the
//! cell whose triangle the watertight test hits. The traversal now widens every cell interval
//! by the rounding its boundaries may carry (`split_intervals` in `src/trace/single.rs`). Every
//! packet path must also leak exactly what the single-ray path leaks (nothing), on every ISA and
//! packet shape, with the default culling. Kensler–Shirley is not watertight: its leak rate on
//! the same rays is measured and printed, not asserted.

use kdbeam::kernels::intersect::watertight::WatertightRay;
use kdbeam::scene::procedural::{closed_grid_box, icosphere};
use kdbeam::scene::rng::Rng;
use kdbeam::{
    BuildParams, HitPacket, Intersector, Isa, KdTree, Mesh, PacketShape, Ray, RayPacket, Tracer,
    Vec3,
};
use rayon::prelude::*;

/// Far from the origin: `f32` spacing is 2⁻⁶ in x and z there.
const FAR: Vec3 = Vec3::new(148376.0, 1234.0, -223423.0);

/// The end of every ray. The target is at `t = 1`; rounding the target to `f32` (1/64 at [`FAR`])
/// over the shortest ray (0.5) moves it by at most 3%, and the next surface point beyond it is at
/// `t ≥ 1.25` (the chord through the inner ball, over the longest outside ray: 1/4), so a ray
/// that passes through the surface at its target ends in empty space.
const T_MAX: f32 = 1.1;

/// Rays in a group that share an interior point and a triangle: one 8×8 packet, or several
/// smaller ones.
const GROUP: usize = 64;

/// A closed convex mesh and a ball inside it.
struct Closed {
    name: &'static str,
    tree: KdTree,
    mesh: Mesh,
    center: Vec3,
    inner_radius: f32,
}

fn closed_meshes() -> Vec<Closed> {
    let closed = |name, mesh: Mesh, center, inner_radius| Closed {
        name,
        tree: KdTree::build(&mesh, &BuildParams::default()).expect("valid mesh"),
        mesh,
        center,
        inner_radius,
    };
    vec![
        closed("icosphere r=2 far", icosphere(FAR, 2.0, 4), FAR, 1.0),
        closed(
            "grid box 8² far",
            closed_grid_box(8, FAR, Vec3::new(2.0, 1.5, 1.0)),
            FAR,
            0.5,
        ),
        closed(
            "grid box 16² at 0",
            closed_grid_box(16, Vec3::ZERO, Vec3::ONE),
            Vec3::ZERO,
            0.5,
        ),
        closed(
            "icosphere r=2 at 0",
            icosphere(Vec3::ZERO, 2.0, 3),
            Vec3::ZERO,
            1.0,
        ),
    ]
}

/// A point exactly at a vertex of `face` (a third of the time) or on one of its edges: the lerp
/// of its two end points, exact up to `f32` rounding.
fn edge_or_vertex(rng: &mut Rng, mesh: &Mesh, face: [u32; 3]) -> Vec3 {
    let k = rng.below(3) as usize;
    let (a, b) = (
        mesh.positions()[face[k] as usize],
        mesh.positions()[face[(k + 1) % 3] as usize],
    );
    if rng.below(3) == 0 {
        a
    } else {
        a.lerp(b, rng.next_f32())
    }
}

/// `groups` groups of [`GROUP`] rays aimed at the edges and vertices of one random triangle
/// each, through one interior point; even groups from inside, odd ones from outside (0.5 to 4
/// units beyond the target).
fn rays(c: &Closed, groups: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let faces = c.mesh.faces();
    let mut out = Vec::with_capacity(groups * GROUP);
    for g in 0..groups {
        let face = faces[rng.below(faces.len() as u32) as usize];
        let inner = c.center + rng.unit_vector() * c.inner_radius * rng.next_f32();
        for _ in 0..GROUP {
            let target = edge_or_vertex(&mut rng, &c.mesh, face);
            let origin = if g % 2 == 0 {
                inner
            } else {
                target + (target - inner).normalize() * rng.range(0.5, 4.0)
            };
            let mut ray = Ray::new(origin, target - origin);
            ray.tmax = T_MAX;
            out.push(ray);
        }
    }
    out
}

/// Which rays of `rays` leak through `tracer`'s single-ray path: (closest hit, any hit).
fn single_ray_leaks(tracer: &Tracer<'_>, rays: &[Ray]) -> Vec<(bool, bool)> {
    rays.par_iter()
        .map(|r| (!tracer.intersect(r).is_hit(), !tracer.occluded(r)))
        .collect()
}

/// Which rays of `rays` leak through `tracer`'s packet path, cut into packets of its shape, all
/// rays active: (closest hit, any hit).
fn packet_leaks(tracer: &Tracer<'_>, rays: &[Ray]) -> Vec<(bool, bool)> {
    rays.par_chunks(tracer.packet().ray_count())
        .flat_map_iter(|chunk| {
            let p = RayPacket::from_rays(chunk);
            let mut hits = HitPacket::default();
            tracer.intersect_packet(&p, p.full_mask(), &mut hits);
            let occluded = tracer.occluded_packet(&p, p.full_mask());
            (0..chunk.len()).map(move |j| (!hits.hit(j).is_hit(), occluded >> j & 1 == 0))
        })
        .collect()
}

/// Does the watertight triangle test, on its own, hit some triangle of `mesh` with `ray`?
fn intersector_hits(mesh: &Mesh, ray: &Ray) -> bool {
    let w = WatertightRay::new(ray);
    mesh.triangles()
        .any(|tri| w.intersect(&tri, ray.tmin, ray.tmax).is_some())
}

/// Leak counts of one path: (closest hit, any hit).
type Leaks = (usize, usize);

fn count(leaks: &[(bool, bool)]) -> Leaks {
    leaks.iter().fold((0, 0), |(c, a), &(lc, la)| {
        (c + usize::from(lc), a + usize::from(la))
    })
}

/// Traces `groups_per_mesh` groups of rays per closed mesh (in batches of `batch` groups) on
/// every path: the single-ray path and each ISA × packet shape, watertight, and the single-ray
/// path with Kensler–Shirley. Prints every count and returns the watertight leaks per path.
///
/// Checks on the way, whatever the leak counts: every path leaks exactly the rays the
/// single-ray path leaks (closest and any hit), and the watertight triangle test alone, over
/// every triangle of the mesh, hits every ray that leaks (so any leak comes from the traversal,
/// not from the intersector).
fn leak_test(groups_per_mesh: usize, batch: usize) -> Vec<(String, Leaks)> {
    let meshes = closed_meshes();
    let mut rays_per_path = 0;
    let mut totals = std::collections::BTreeMap::<String, Leaks>::new();
    let mut add = |path: String, (c, a): Leaks| {
        let e = totals.entry(path).or_default();
        *e = (e.0 + c, e.1 + a);
    };
    for (m, c) in meshes.iter().enumerate() {
        for b in 0..groups_per_mesh.div_ceil(batch) {
            let groups = batch.min(groups_per_mesh - b * batch);
            let rays = rays(c, groups, (m * 1000 + b) as u64);
            rays_per_path += rays.len();
            let tracer = Tracer::new(&c.tree).with_intersector(Intersector::Watertight);
            let scalar = tracer
                .with_isa(Isa::Scalar)
                .expect("scalar runs everywhere");
            let single = single_ray_leaks(&scalar, &rays);
            add("watertight single ray".into(), count(&single));
            for (r, _) in rays.iter().zip(&single).filter(|(_, l)| l.0 || l.1) {
                assert!(
                    intersector_hits(&c.mesh, r),
                    "{}: the watertight test misses {r:?}",
                    c.name
                );
            }
            for isa in Isa::available() {
                for shape in PacketShape::ALL {
                    let t = tracer.with_isa(isa).expect("available").with_packet(shape);
                    let packet = packet_leaks(&t, &rays);
                    let first_difference = (0..rays.len()).find(|&i| packet[i] != single[i]);
                    assert_eq!(
                        first_difference.map(|i| (rays[i], packet[i], single[i])),
                        None,
                        "{}: {isa} {shape:?} leaks other rays than the single-ray path",
                        c.name
                    );
                    add(format!("watertight {isa} {shape:?}"), count(&packet));
                }
            }
            let ks = scalar.with_intersector(Intersector::KenslerShirley);
            add(
                "kensler_shirley single ray".into(),
                count(&single_ray_leaks(&ks, &rays)),
            );
        }
    }
    eprintln!(
        "leaks (closest hit, any hit) over {rays_per_path} rays per path, {} meshes:",
        meshes.len()
    );
    for (path, (closest, any)) in &totals {
        eprintln!(
            "  {path:>26}: {closest} {any} (rate {:.2e})",
            *closest as f64 / rays_per_path as f64
        );
    }
    totals
        .into_iter()
        .filter(|(path, _)| path.starts_with("watertight"))
        .collect()
}

/// Groups per mesh for 10⁶ rays per path, a quarter on each of the four meshes.
const MILLION: usize = 1_000_000 / GROUP / 4 + 1;

/// Batches of this many groups bound the memory of the 10⁷-ray test.
const BATCH: usize = 1 << 12;

/// 10⁶ rays per path: the watertight tracer leaks none.
#[test]
fn watertight_tracer_leaks_no_ray_through_closed_meshes() {
    let leaking: Vec<_> = leak_test(MILLION, BATCH)
        .into_iter()
        .filter(|(_, (c, a))| c + a > 0)
        .collect();
    assert!(leaking.is_empty(), "watertight leaks: {leaking:?}");
}

/// A minimal leak: a ray from outside the closed grid box through the shared edge of triangles
/// 280/281 (the cell y ≥ 0.5) and 278/279 (y ≤ 0.5) on the face x = −1, which lies in the
/// kd-tree's split plane y = 0.5. The watertight test hits triangle 281; the traversal enters the
/// box at t = 1 (the face x = −1), computes t = 0.99999994 for the split plane y = 0.5, and so
/// visited only the cell y ≤ 0.5, whose triangles the ray misses by an ulp, until the cell
/// intervals were widened.
#[test]
fn ray_through_an_edge_on_a_split_plane_at_the_root_box_hits() {
    let mesh = closed_grid_box(16, Vec3::ZERO, Vec3::ONE);
    let tree = KdTree::build(&mesh, &BuildParams::default()).expect("valid mesh");
    let ray = Ray {
        origin: Vec3::new(-3.8276753, 2.2654428, 1.4012221),
        direction: Vec3::new(2.8276753, -1.7654428, -1.2842267),
        tmin: 0.0,
        tmax: 1.1,
    };
    assert!(
        intersector_hits(&mesh, &ray),
        "the intersector is watertight here"
    );
    for isa in Isa::available() {
        let tracer = Tracer::new(&tree)
            .with_intersector(Intersector::Watertight)
            .with_isa(isa)
            .expect("available");
        assert!(tracer.intersect(&ray).is_hit(), "single ray leaks");
        let p = RayPacket::from_rays(&[ray; 4]);
        assert_eq!(
            tracer.occluded_packet(&p, p.full_mask()),
            0b1111,
            "{isa} packet leaks"
        );
    }
}

/// 10⁷ rays per path: the watertight tracer leaks none.
#[test]
#[ignore = "long: 10^7 rays per path, several minutes"]
fn watertight_tracer_leaks_no_ray_in_ten_million() {
    let leaking: Vec<_> = leak_test(10 * MILLION, BATCH)
        .into_iter()
        .filter(|(_, (c, a))| c + a > 0)
        .collect();
    assert!(leaking.is_empty(), "watertight leaks: {leaking:?}");
}
