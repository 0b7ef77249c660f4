//! No ray passes between triangles that share an edge or a vertex: rays aimed exactly at the
//! edges and vertices of a height-field grid and of a closed sphere, near the origin and far from
//! it (where `f32` spacing is 1/64), must hit something, through the single-ray watertight test
//! and its lane form on every ISA. Kensler–Shirley's leaks on the same rays are printed for
//! comparison (it is not watertight, and is not asserted on).
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::{gather, Rng};
use kdbeam_kernels::intersect::kensler_shirley;
use kdbeam_kernels::intersect::watertight::{WatertightLanes, WatertightRay};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Isa, KsTriangle, LaneMask, LaneTask, Lanes, Ray, Triangle, Vec3};

/// Far from the origin: `f32` spacing is 2^-6 in x and z there.
const FAR: Vec3 = Vec3::new(148376.0, 1234.0, -223423.0);

/// Rays per mesh and placement.
const RAYS: usize = 100_000;

/// An indexed mesh: shared vertices are bitwise identical in every triangle using them.
struct Mesh {
    vertices: Vec<Vec3>,
    triangles: Vec<[usize; 3]>,
}

impl Mesh {
    fn triangles(&self) -> Vec<Triangle> {
        self.triangles
            .iter()
            .map(|t| {
                Triangle::new(
                    self.vertices[t[0]],
                    self.vertices[t[1]],
                    self.vertices[t[2]],
                )
            })
            .collect()
    }
}

/// An `n × n` height field of unit quads at `offset`, heights in `[0, 0.5]`, each quad split
/// along an alternating diagonal.
fn height_field(rng: &mut Rng, n: usize, offset: Vec3) -> Mesh {
    let index = |i: usize, j: usize| i * (n + 1) + j;
    let mut vertices = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            vertices.push(offset + Vec3::new(i as f32, j as f32, rng.range(0.0, 0.5)));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let [a, b, c, d] = [
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            ];
            if (i + j) % 2 == 0 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// A closed UV sphere: two poles, `stacks − 1` rings of `slices` vertices, pole fans and split
/// quads.
fn sphere(center: Vec3, radius: f32, slices: usize, stacks: usize) -> Mesh {
    let mut vertices = vec![center + Vec3::Z * radius, center - Vec3::Z * radius];
    for s in 1..stacks {
        let theta = std::f32::consts::PI * s as f32 / stacks as f32;
        for k in 0..slices {
            let phi = std::f32::consts::TAU * k as f32 / slices as f32;
            let unit = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            vertices.push(center + unit * radius);
        }
    }
    let ring = |s: usize, k: usize| 2 + (s - 1) * slices + k % slices;
    let mut triangles = Vec::new();
    for k in 0..slices {
        triangles.push([0, ring(1, k), ring(1, k + 1)]);
        triangles.push([1, ring(stacks - 1, k + 1), ring(stacks - 1, k)]);
        for s in 1..stacks - 1 {
            let [a, b, c, d] = [
                ring(s, k),
                ring(s + 1, k),
                ring(s + 1, k + 1),
                ring(s, k + 1),
            ];
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// A point exactly at a vertex or on an edge (up to the rounding of `a + (b − a)·s`) of one of
/// `candidates`.
fn edge_or_vertex(rng: &mut Rng, mesh: &Mesh, candidates: &[[usize; 3]]) -> Vec3 {
    let tri = candidates[rng.below(candidates.len())];
    let (a, b) = (
        mesh.vertices[tri[rng.below(3)]],
        mesh.vertices[tri[rng.below(3)]],
    );
    if rng.chance(0.3) {
        a
    } else {
        a + (b - a) * rng.range(0.0, 1.0)
    }
}

/// Rays from above or below the height field through its interior edges and vertices (those of
/// quads at least one cell from the border). Rays are steeper than any slope of the surface, so
/// each crosses it exactly once, near its target.
fn height_field_rays(rng: &mut Rng, n: usize, mesh: &Mesh) -> Vec<Ray> {
    let interior: Vec<[usize; 3]> = mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(t, _)| {
            let (i, j) = (t / 2 / n, t / 2 % n);
            (1..n - 1).contains(&i) && (1..n - 1).contains(&j)
        })
        .map(|(_, t)| *t)
        .collect();
    (0..RAYS)
        .map(|_| {
            let target = edge_or_vertex(rng, mesh, &interior);
            let up = rng.range(1.0, 10.0) * if rng.chance(0.5) { 1.0 } else { -1.0 };
            let side = Vec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), 0.0) * up.abs();
            let origin = target + side + Vec3::Z * up;
            Ray::new(origin, target - origin)
        })
        .collect()
}

/// Rays through the sphere's edges and vertices, from inside (its centre or anywhere within half
/// the radius) or from outside (moving inwards).
fn sphere_rays(rng: &mut Rng, mesh: &Mesh, center: Vec3, radius: f32) -> Vec<Ray> {
    (0..RAYS)
        .map(|_| {
            let target = edge_or_vertex(rng, mesh, &mesh.triangles);
            let origin = match rng.below(3) {
                0 => center,
                1 => center + rng.on_sphere() * rng.range(0.0, 0.5 * radius),
                _ => {
                    let out = (target - center).normalize();
                    target + (out * 2.0 + rng.in_cube(0.5)) * radius
                }
            };
            Ray::new(origin, target - origin)
        })
        .collect()
}

/// Counts the rays that hit no triangle, `WIDTH` at a time through the lane form.
struct CountLaneLeaks<'a> {
    tris: &'a [Triangle],
    rays: &'a [Ray],
}

impl LaneTask for CountLaneLeaks<'_> {
    type Output = usize;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> usize {
        let (tmin, tmax) = (l.splat(0.0), l.splat(f32::INFINITY));
        let none = l.mask_from_bits(0);
        self.rays
            .chunks_exact(L::WIDTH)
            .map(|group| {
                let prepared = WatertightLanes::new(l, &gather(l, group));
                let hit = self.tris.iter().fold(none, |m, tri| {
                    m | prepared.intersect(l, tri, tmin, tmax).mask
                });
                L::WIDTH - hit.bits().count_ones() as usize
            })
            .sum()
    }
}

fn assert_no_leaks(name: &str, mesh: &Mesh, rays: &[Ray]) {
    let tris = mesh.triangles();
    let leaks = |hits: &dyn Fn(&Ray, &Triangle) -> bool| {
        rays.iter()
            .filter(|r| !tris.iter().any(|t| hits(r, t)))
            .count()
    };
    let ks_tris: Vec<KsTriangle> = tris.iter().map(KsTriangle::from).collect();
    let ks_leaks = rays
        .iter()
        .filter(|r| {
            !ks_tris
                .iter()
                .any(|t| kensler_shirley::intersect(r, t, 0.0, f32::INFINITY).is_some())
        })
        .count();
    let single = leaks(&|r, t| {
        WatertightRay::new(r)
            .intersect(t, 0.0, f32::INFINITY)
            .is_some()
    });
    println!("{name}: {} rays, {} triangles: watertight leaks {single}, Kensler–Shirley leaks {ks_leaks}", rays.len(), tris.len());
    assert_eq!(single, 0, "{name}: single-ray watertight leaks");
    for isa in Isa::available() {
        let lane_leaks = Dispatch::new(isa)
            .expect("available ISA runs")
            .run(CountLaneLeaks { tris: &tris, rays });
        assert_eq!(lane_leaks, 0, "{name}: {isa} lanes leak");
    }
}

#[test]
fn no_ray_passes_between_the_triangles_of_a_height_field() {
    let mut rng = Rng::new(11);
    for (name, offset) in [("near", Vec3::ZERO), ("far", FAR)] {
        let n = 8;
        let mesh = height_field(&mut rng, n, offset);
        let rays = height_field_rays(&mut rng, n, &mesh);
        assert_no_leaks(&format!("height field {name}"), &mesh, &rays);
    }
}

#[test]
fn no_ray_passes_between_the_triangles_of_a_closed_sphere() {
    let mut rng = Rng::new(12);
    for (name, center, radius) in [("unit", Vec3::ZERO, 1.0), ("far", FAR, 10.0)] {
        let mesh = sphere(center, radius, 16, 8);
        let rays = sphere_rays(&mut rng, &mesh, center, radius);
        assert_no_leaks(&format!("sphere {name}"), &mesh, &rays);
    }
}
