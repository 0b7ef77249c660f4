//! Procedural scenes: spheres, grids, random soups, hair, terrain, and the default picture.
//!
//! Every generator is deterministic: the same arguments (and seed) give the same mesh, bit for
//! bit, on one platform. The generators return a [`Mesh`] rather than a `Result`: sizes beyond the
//! documented maxima are clamped to them, and parameters that would put a non-finite coordinate
//! in the mesh (a NaN or infinite centre, radius or extent) give an empty mesh. [`builtin`], the
//! entry point for user input, rejects both with an error instead.

use std::collections::HashMap;

use glam::Vec3;

use super::rng::Rng;
use crate::{Error, Mesh, Result};

/// The names [`builtin`] accepts, each optionally followed by `:SIZE`.
pub const BUILTIN_NAMES: &[&str] = &["default", "icosphere", "grid", "soup", "hair", "terrain"];

/// The largest icosphere subdivision level: 20·4¹² = 335,544,320 triangles.
pub const MAX_SUBDIVISIONS: u32 = 12;

/// The largest side, in quads, of [`quad_grid`], [`closed_grid_box`] and [`terrain`]:
/// 2·32768² ≈ 2.1 billion triangles for a square grid, with vertex indices well inside `u32`.
pub const MAX_GRID_SIDE: u32 = 32_768;

/// The largest triangle count of [`triangle_soup`] and [`hair`] (3 vertices per triangle must fit
/// `u32` indices).
pub const MAX_RANDOM_TRIANGLES: u32 = 1 << 28;

/// The seed [`builtin`] passes to the seeded generators.
pub const BUILTIN_SEED: u64 = 1;

/// A built-in scene by name: `NAME` or `NAME:SIZE`.
///
/// | name | generator | SIZE means | default SIZE | triangles |
/// |---|---|---|---|---|
/// | `default` | [`default_scene`] | (no size) | | 243,712 |
/// | `icosphere` | [`icosphere`] at the origin, radius 1 | subdivisions | 5 | 20·4^SIZE |
/// | `grid` | [`quad_grid`] over [−1, 1]² in the plane z = 0 | quads per side | 256 | 2·SIZE² |
/// | `soup` | [`triangle_soup`] | triangles | 100,000 | SIZE |
/// | `hair` | [`hair`] | strands | 100,000 | SIZE |
/// | `terrain` | [`terrain`] | quads per side | 512 | 2·SIZE² |
///
/// Seeded generators use [`BUILTIN_SEED`].
///
/// # Errors
/// [`Error::UnknownScene`] for a name not in [`BUILTIN_NAMES`]; [`Error::InvalidParameter`] for a
/// size that is not an integer, is 0, exceeds the generator's maximum, or is given to `default`.
///
/// ```
/// let terrain = kdbeam::scene::procedural::builtin("terrain:100")?;
/// assert_eq!(terrain.triangle_count(), 2 * 100 * 100);
/// assert!(kdbeam::scene::procedural::builtin("teapot").is_err());
/// # Ok::<(), kdbeam::Error>(())
/// ```
pub fn builtin(name: &str) -> Result<Mesh> {
    let (base, size_text) = match name.split_once(':') {
        Some((base, size)) => (base, Some(size)),
        None => (name, None),
    };
    let size = |default: u32, max: u32| -> Result<u32> {
        let Some(text) = size_text else {
            return Ok(default);
        };
        match text.parse::<u32>() {
            Ok(n) if (1..=max).contains(&n) => Ok(n),
            _ => Err(Error::InvalidParameter {
                name: "built-in scene size",
                message: format!("{name:?}: the size of {base} must be an integer in 1..={max}"),
            }),
        }
    };
    match base {
        "default" if size_text.is_none() => Ok(default_scene()),
        "default" => Err(Error::InvalidParameter {
            name: "built-in scene size",
            message: format!("{name:?}: the default scene takes no size"),
        }),
        "icosphere" => Ok(icosphere(Vec3::ZERO, 1.0, size(5, MAX_SUBDIVISIONS)?)),
        "grid" => {
            let n = size(256, MAX_GRID_SIDE)?;
            Ok(quad_grid(
                n,
                n,
                Vec3::new(-1.0, -1.0, 0.0),
                2.0 * Vec3::X,
                2.0 * Vec3::Y,
            ))
        }
        "soup" => Ok(triangle_soup(
            size(100_000, MAX_RANDOM_TRIANGLES)?,
            BUILTIN_SEED,
        )),
        "hair" => Ok(hair(size(100_000, MAX_RANDOM_TRIANGLES)?, BUILTIN_SEED)),
        "terrain" => Ok(terrain(size(512, MAX_GRID_SIDE)?, BUILTIN_SEED)),
        _ => Err(Error::UnknownScene(name.to_string())),
    }
}

/// Validates generated geometry; a non-finite coordinate (from non-finite parameters) gives the
/// empty mesh, as the module documentation promises.
fn validated(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Mesh {
    Mesh::from_faces(positions, faces).unwrap_or_default()
}

/// A closed, watertight sphere: a subdivided icosahedron with shared vertices.
///
/// Each subdivision splits every triangle into four at its edge midpoints, pushed out to the
/// sphere; a midpoint is created once per edge and shared by both triangles of the edge, so every
/// edge belongs to exactly two triangles and no two vertices coincide. Triangles are wound
/// counter-clockwise seen from outside (normals point out).
///
/// Triangles: 20·4^s; vertices: 10·4^s + 2, for s = `subdivisions`, clamped to
/// [`MAX_SUBDIVISIONS`]. A negative radius turns the sphere inside out (normals point in); a
/// non-finite centre or radius gives the empty mesh.
///
/// ```
/// let sphere = kdbeam::scene::procedural::icosphere(glam::Vec3::ZERO, 1.0, 3);
/// assert_eq!(sphere.triangle_count(), 20 * 64);
/// assert_eq!(sphere.positions().len(), 10 * 64 + 2);
/// ```
#[must_use]
pub fn icosphere(center: Vec3, radius: f32, subdivisions: u32) -> Mesh {
    let subdivisions = subdivisions.min(MAX_SUBDIVISIONS);
    // The icosahedron: (0, ±1, ±φ) and its cyclic permutations, normalised.
    let phi = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut unit: Vec<Vec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .into_iter()
    .map(|(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        // Euler: a closed triangle mesh with F faces has 3F/2 edges, one new vertex each.
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(faces.len() * 3 / 2);
        unit.reserve(faces.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (unit[a as usize] + unit[b as usize]).normalize();
                unit.push(m);
                (unit.len() - 1) as u32
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let positions = unit.into_iter().map(|u| center + radius * u).collect();
    validated(positions, faces)
}

/// The vertices and triangles of an `nx` × `ny` grid of quads: vertex (i, j) is `vertex(i, j)`,
/// called for j ∈ 0..=ny, then i ∈ 0..=nx, and stored at index j·(nx + 1) + i.
///
/// Quad (i, j) has corners a = (i, j), b = (i + 1, j), c = (i + 1, j + 1), d = (i, j + 1) and
/// becomes the triangles (a, b, c) and (a, c, d): counter-clockwise when i and j run along the
/// first and second axes of a right-handed frame. Sides are clamped to [`MAX_GRID_SIDE`]; a side
/// of 0 gives no vertices and no triangles.
fn grid<V>(nx: u32, ny: u32, mut vertex: impl FnMut(u32, u32) -> V) -> (Vec<V>, Vec<[u32; 3]>) {
    let (nx, ny) = (nx.min(MAX_GRID_SIDE), ny.min(MAX_GRID_SIDE));
    if nx == 0 || ny == 0 {
        return (Vec::new(), Vec::new());
    }
    let row = nx + 1;
    let mut vertices = Vec::with_capacity(row as usize * (ny as usize + 1));
    for j in 0..=ny {
        vertices.extend((0..=nx).map(|i| vertex(i, j)));
    }
    let mut faces = Vec::with_capacity(2 * nx as usize * ny as usize);
    for j in 0..ny {
        faces.extend((0..nx).flat_map(|i| {
            let a = j * row + i;
            let (b, c, d) = (a + 1, a + row + 1, a + row);
            [[a, b, c], [a, c, d]]
        }));
    }
    (vertices, faces)
}

/// A flat grid of `nx` × `ny` quads, two triangles each, with shared vertices.
///
/// It covers the parallelogram `origin + s·u + t·v` for s, t ∈ [0, 1]; vertex (i, j) is at
/// `origin + (i/nx)·u + (j/ny)·v`. Triangles: 2·nx·ny; vertices: (nx + 1)·(ny + 1). Normals point
/// along u × v. `nx` and `ny` are clamped to [`MAX_GRID_SIDE`]; 0 gives the empty mesh, as do
/// non-finite vectors.
///
/// ```
/// use glam::Vec3;
/// let grid = kdbeam::scene::procedural::quad_grid(4, 3, Vec3::ZERO, Vec3::X, Vec3::Y);
/// assert_eq!(grid.triangle_count(), 2 * 4 * 3);
/// ```
#[must_use]
pub fn quad_grid(nx: u32, ny: u32, origin: Vec3, u: Vec3, v: Vec3) -> Mesh {
    let (sx, sy) = (1.0 / nx.max(1) as f32, 1.0 / ny.max(1) as f32);
    let (positions, faces) = grid(nx, ny, |i, j| {
        origin + (i as f32 * sx) * u + (j as f32 * sy) * v
    });
    validated(positions, faces)
}

/// A closed box whose six faces are `n` × `n` grids of quads, with vertices shared along the box's
/// edges and corners: watertight, every edge in exactly two triangles, normals pointing out.
///
/// It spans `center ± half_extent`. Triangles: 12·n²; vertices: 6·n² + 2. `n` is clamped to
/// [`MAX_GRID_SIDE`]; 0 gives the empty mesh, as do non-finite parameters.
///
/// ```
/// use glam::Vec3;
/// let cube = kdbeam::scene::procedural::closed_grid_box(3, Vec3::ZERO, Vec3::ONE);
/// assert_eq!(cube.triangle_count(), 12 * 9);
/// assert_eq!(cube.positions().len(), 6 * 9 + 2);
/// ```
#[must_use]
pub fn closed_grid_box(n: u32, center: Vec3, half_extent: Vec3) -> Mesh {
    let n = n.min(MAX_GRID_SIDE);
    // Vertices are lattice points (i, j, k) ∈ {0…n}³ on the box's surface, each created once.
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut faces = Vec::with_capacity(12 * (n as usize).pow(2));
    let scale = 2.0 / n.max(1) as f32;
    for axis in 0..3 {
        // The face's grid runs along the next two axes, so (along1 × along2) = +axis.
        let (along1, along2) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n] {
            let (ids, quads) = grid(n, n, |i, j| {
                let mut lattice = [0u32; 3];
                lattice[axis] = side;
                lattice[along1] = i;
                lattice[along2] = j;
                *index.entry(lattice).or_insert_with(|| {
                    let unit = Vec3::from(lattice.map(|c| c as f32)) * scale - Vec3::ONE;
                    positions.push(center + half_extent * unit);
                    (positions.len() - 1) as u32
                })
            });
            faces.extend(quads.iter().map(|q| {
                let [a, b, c] = q.map(|v| ids[v as usize]);
                // The grid winds towards +axis: keep it on the far side, flip it on the near one.
                if side == 0 {
                    [a, c, b]
                } else {
                    [a, b, c]
                }
            }));
        }
    }
    validated(positions, faces)
}

/// `count` random triangles in the unit cube [0, 1)³, sharing no vertices.
///
/// Triangle k: a centre uniform in [0, 1)³ and three vertices at centre + ℓ·(random unit vector),
/// ℓ = ½·count^(−1/3), so triangles are about as large as the spacing between centres. Drawn in
/// that order from [`Rng::new`]`(seed)`. Vertices: 3·count. `count` is clamped to
/// [`MAX_RANDOM_TRIANGLES`].
///
/// ```
/// let soup = kdbeam::scene::procedural::triangle_soup(1000, 7);
/// assert_eq!(soup.triangle_count(), 1000);
/// ```
#[must_use]
pub fn triangle_soup(count: u32, seed: u64) -> Mesh {
    let count = count.min(MAX_RANDOM_TRIANGLES);
    let size = 0.5 / (count.max(1) as f32).cbrt();
    let mut rng = Rng::new(seed);
    let mut positions = Vec::with_capacity(3 * count as usize);
    for _ in 0..count {
        let centre = random_point(&mut rng);
        for _ in 0..3 {
            positions.push(centre + size * rng.unit_vector());
        }
    }
    soup(positions)
}

/// `count` strands of hair: long, thin triangles running diagonally through the unit cube, the
/// worst case for axis-aligned boxes (and the case subspace culling is for).
///
/// Strand k: a root r uniform in [0, 1)³, a direction d = normalize((1, 1, 1) + ¼·(random unit
/// vector)), a sideways unit vector w ⟂ d (d × another random unit vector, normalised), and the
/// triangle (r − 0.001·w, r + 0.001·w, r + 0.5·d): 0.5 long, 0.002 wide at the root. Drawn in that
/// order from [`Rng::new`]`(seed)`. Vertices: 3·count. `count` is clamped to
/// [`MAX_RANDOM_TRIANGLES`].
///
/// ```
/// let hair = kdbeam::scene::procedural::hair(1000, 7);
/// assert_eq!(hair.triangle_count(), 1000);
/// ```
#[must_use]
pub fn hair(count: u32, seed: u64) -> Mesh {
    const LENGTH: f32 = 0.5;
    const HALF_WIDTH: f32 = 0.001;
    let count = count.min(MAX_RANDOM_TRIANGLES);
    let mut rng = Rng::new(seed);
    let mut positions = Vec::with_capacity(3 * count as usize);
    for _ in 0..count {
        let root = random_point(&mut rng);
        let direction = (Vec3::ONE + 0.25 * rng.unit_vector()).normalize();
        // A random vector parallel to d has probability 0; any fixed perpendicular will do then.
        let side = direction
            .cross(rng.unit_vector())
            .try_normalize()
            .unwrap_or_else(|| direction.any_orthonormal_vector());
        positions.extend([
            root - HALF_WIDTH * side,
            root + HALF_WIDTH * side,
            root + LENGTH * direction,
        ]);
    }
    soup(positions)
}

/// A uniform point in [0, 1)³, drawn x, y, z.
fn random_point(rng: &mut Rng) -> Vec3 {
    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
}

/// A mesh whose triangle k is positions 3k, 3k + 1, 3k + 2.
fn soup(positions: Vec<Vec3>) -> Mesh {
    let faces = (0..positions.len() as u32 / 3)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    validated(positions, faces)
}

/// A rolling valley: a heightfield of `resolution` × `resolution` quads (2·resolution² triangles,
/// (resolution + 1)² vertices), open towards −z so the standard camera looks into it.
///
/// It spans x ∈ [−1, 1] and z ∈ [0, 2]; the height is y = [`terrain_height`]`(x, z, seed)`: a
/// floor that rises gently at the sides and steeply at the back, plus fractal value noise. Normals
/// point up (+y). Generation is one pass over the vertices and one over the quads, with no
/// intermediate buffers: 18 bytes per triangle in all (12 for its indices, 6 for its half of a
/// vertex). `resolution` is clamped to [`MAX_GRID_SIDE`]; 0 gives the empty mesh.
///
/// ```
/// let terrain = kdbeam::scene::procedural::terrain(64, 1);
/// assert_eq!(terrain.triangle_count(), 2 * 64 * 64);
/// ```
#[must_use]
pub fn terrain(resolution: u32, seed: u64) -> Mesh {
    let step = 2.0 / resolution.max(1) as f32;
    // i runs along +z and j along +x, so the grid's counter-clockwise side faces +y (z × x = y).
    let (positions, faces) = grid(resolution, resolution, |i, j| {
        let (x, z) = (j as f32 * step - 1.0, i as f32 * step);
        Vec3::new(x, terrain_height(x, z, seed), z)
    });
    validated(positions, faces)
}

/// The height of [`terrain`] at (x, z): the valley's shape plus noise.
///
/// With s = |x| and t = z/2: y = 1.5·t³ + 0.5·s⁴ + 0.12·fbm(2.5·x, 2.5·z), where fbm is four
/// octaves of value noise (each octave twice the frequency and half the amplitude of the one
/// before, values in [−1, 1]) on a lattice hashed with `seed`. Uses only `+`, `×` and `floor`, so
/// it is the same on every platform. Outside the terrain's domain it continues smoothly.
#[must_use]
pub fn terrain_height(x: f32, z: f32, seed: u64) -> f32 {
    let (s, t) = (x.abs(), 0.5 * z);
    let shape = 1.5 * t * t * t + 0.5 * s * s * s * s;
    shape + 0.12 * fbm(2.5 * x, 2.5 * z, seed)
}

/// Fractal value noise: four octaves, in [−1, 1] (the octaves' amplitudes sum to 1).
fn fbm(x: f32, z: f32, seed: u64) -> f32 {
    const OCTAVES: u32 = 4;
    let mut sum = 0.0;
    let mut amplitude = 8.0 / 15.0;
    let mut frequency = 1.0;
    for octave in 0..OCTAVES {
        sum += amplitude * value_noise(x * frequency, z * frequency, seed, octave);
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    sum
}

/// Value noise: random values in [−1, 1] at integer lattice points, blended with the smoothstep
/// 3f² − 2f³ so the surface has continuous slopes.
fn value_noise(x: f32, z: f32, seed: u64, octave: u32) -> f32 {
    let (x0, z0) = (x.floor(), z.floor());
    let (fx, fz) = (x - x0, z - z0);
    let (sx, sz) = (fx * fx * (3.0 - 2.0 * fx), fz * fz * (3.0 - 2.0 * fz));
    // Saturating casts: far outside any sensible domain, the lattice simply stops changing.
    let (ix, iz) = (x0 as i32, z0 as i32);
    let corner =
        |dx: i32, dz: i32| lattice_value(ix.wrapping_add(dx), iz.wrapping_add(dz), seed, octave);
    let near = corner(0, 0) + sx * (corner(1, 0) - corner(0, 0));
    let far = corner(0, 1) + sx * (corner(1, 1) - corner(0, 1));
    near + sz * (far - near)
}

/// A random value in [−1, 1) for a lattice point: its coordinates, the seed and the octave mixed
/// by the SplitMix64 finaliser.
fn lattice_value(ix: i32, iz: i32, seed: u64, octave: u32) -> f32 {
    let mut h = seed
        ^ u64::from(ix as u32)
        ^ (u64::from(iz as u32) << 32)
        ^ u64::from(octave).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    (h >> 40) as f32 * (2.0 / (1u64 << 24) as f32) - 1.0
}

/// The default picture: spheres of several sizes resting in a rolling valley, framed by the
/// standard camera (looking +z into the valley's open front). 243,712 triangles: the terrain at
/// resolution 224 (100,352) and ten icospheres (subdivisions 6, 5, 5, 4, 4, 4, 3, 3, 3, 3).
///
/// Fixed: no seed (the terrain uses [`BUILTIN_SEED`]). Triangle ids: the terrain first, then the
/// spheres from the largest.
#[must_use]
pub fn default_scene() -> Mesh {
    // (x, z, radius, subdivisions): spheres sit on the floor, sunk by a fifth of their radius.
    const SPHERES: [(f32, f32, f32, u32); 10] = [
        (0.22, 0.85, 0.34, 6),
        (-0.48, 0.55, 0.2, 5),
        (-0.12, 1.45, 0.24, 5),
        (0.62, 0.35, 0.11, 4),
        (-0.72, 1.15, 0.13, 4),
        (0.6, 1.5, 0.15, 4),
        (-0.2, 0.25, 0.07, 3),
        (0.05, 0.45, 0.05, 3),
        (0.35, 0.2, 0.06, 3),
        (-0.55, 0.2, 0.06, 3),
    ];
    let mut scene = terrain(224, BUILTIN_SEED);
    for (x, z, radius, subdivisions) in SPHERES {
        let center = Vec3::new(x, terrain_height(x, z, BUILTIN_SEED) + 0.8 * radius, z);
        // Both meshes come from the generators, so their vertex counts fit u32 together.
        if scene
            .append(&icosphere(center, radius, subdivisions))
            .is_err()
        {
            unreachable!("the default scene has fewer than a million vertices");
        }
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How often each directed edge (a → b) occurs in the mesh's triangles.
    fn directed_edges(mesh: &Mesh) -> HashMap<(u32, u32), usize> {
        let mut edges = HashMap::new();
        for &[a, b, c] in mesh.faces() {
            for edge in [(a, b), (b, c), (c, a)] {
                *edges.entry(edge).or_insert(0) += 1;
            }
        }
        edges
    }

    /// Closed and consistently wound: every directed edge occurs once and its reverse once, so
    /// every undirected edge belongs to exactly two triangles, which traverse it in opposite
    /// directions. Also no two vertices coincide, so the closure is not just in the indices.
    fn assert_closed(mesh: &Mesh) {
        let edges = directed_edges(mesh);
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}→{b} occurs {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}→{b} has no twin");
        }
        let mut seen = std::collections::HashSet::new();
        for p in mesh.positions() {
            assert!(
                seen.insert(p.to_array().map(f32::to_bits)),
                "duplicate vertex {p}"
            );
        }
    }

    /// Sum over triangles of ⅓·(area vector)·(centroid − c): the enclosed volume of a closed mesh
    /// whose normals point out (divergence theorem), negative if they point in.
    fn signed_volume(mesh: &Mesh, c: Vec3) -> f32 {
        mesh.triangles()
            .map(|t| {
                (t.v1 - t.v0)
                    .cross(t.v2 - t.v0)
                    .dot((t.v0 + t.v1 + t.v2) / 3.0 - c)
                    / 6.0
            })
            .sum()
    }

    #[test]
    fn icospheres_are_closed_outward_and_match_the_counts() {
        let ball = 4.0 / 3.0 * std::f32::consts::PI * 8.0;
        for s in 0..=4u32 {
            let center = Vec3::new(1.0, -2.0, 3.0);
            let sphere = icosphere(center, 2.0, s);
            assert_eq!(sphere.triangle_count(), 20 * 4usize.pow(s));
            assert_eq!(sphere.positions().len(), 10 * 4usize.pow(s) + 2);
            assert_closed(&sphere);
            for p in sphere.positions() {
                // Normalising and scaling leave a few ulps; 2e-5 is ~40 ulps at radius 2.
                assert!(((*p - center).length() - 2.0).abs() < 2e-5, "{p}");
            }
            // Inscribed in the ball of radius 2: smaller than it, and within 5% from s = 2 on.
            let volume = signed_volume(&sphere, center);
            assert!(volume > 0.0 && volume < ball, "s={s}: {volume}");
            assert!(s < 2 || volume > 0.95 * ball, "s={s}: {volume}");
        }
    }

    #[test]
    fn far_away_icosphere_is_still_closed() {
        // The leak tests' far-away centre, where one ulp is 1/64.
        let sphere = icosphere(Vec3::new(148_376.0, 1234.0, -223_423.0), 100.0, 4);
        assert_eq!(sphere.triangle_count(), 5120);
        assert_closed(&sphere);
    }

    #[test]
    fn closed_grid_box_is_closed_outward_and_matches_the_counts() {
        let (center, half) = (Vec3::splat(10.0), Vec3::new(1.0, 2.0, 0.5));
        for n in 1..=5u32 {
            let n2 = (n * n) as usize;
            let cube = closed_grid_box(n, center, half);
            assert_eq!(cube.triangle_count(), 12 * n2);
            assert_eq!(cube.positions().len(), 6 * n2 + 2);
            assert_closed(&cube);
            // Volume 2·4·1 = 8; the sum of 12n² terms of size ~1 rounds by well under 1e-3.
            let volume = signed_volume(&cube, center);
            assert!((volume - 8.0).abs() < 1e-3, "n={n}: {volume}");
            assert_eq!(cube.bounds().min, center - half);
            assert_eq!(cube.bounds().max, center + half);
        }
    }

    #[test]
    fn quad_grid_matches_its_counts_and_parallelogram() {
        let grid = quad_grid(5, 3, Vec3::ONE, Vec3::X * 10.0, Vec3::Z * 6.0);
        assert_eq!(grid.triangle_count(), 2 * 5 * 3);
        assert_eq!(grid.positions().len(), 6 * 4);
        assert_eq!(grid.bounds().min, Vec3::ONE);
        assert_eq!(grid.bounds().max, Vec3::new(11.0, 1.0, 7.0));
        // 2·15·3 = 90 directed edges; only the 2·(5 + 3) = 16 on the boundary lack a twin.
        let edges = directed_edges(&grid);
        assert_eq!(edges.values().sum::<usize>(), 90);
        let lone = edges.keys().filter(|(a, b)| !edges.contains_key(&(*b, *a)));
        assert_eq!(lone.count(), 16);
        // Normals along u × v = X × Z = −Y.
        assert!(grid
            .triangles()
            .all(|t| (t.v1 - t.v0).cross(t.v2 - t.v0).y < 0.0));
        assert!(quad_grid(0, 4, Vec3::ZERO, Vec3::X, Vec3::Y).is_empty());
    }

    #[test]
    fn seeded_generators_are_deterministic_and_depend_on_the_seed() {
        type Generator = fn(u32, u64) -> Mesh;
        let generators: [(&str, Generator); 3] = [
            ("soup", triangle_soup),
            ("hair", hair),
            ("terrain", terrain),
        ];
        for (name, generate) in generators {
            let a = generate(50, 9);
            assert_eq!(a, generate(50, 9), "{name}");
            assert_ne!(a, generate(50, 10), "{name}");
        }
    }

    #[test]
    fn soup_triangles_sit_in_the_unit_cube_give_or_take_their_size() {
        let soup = triangle_soup(1000, 5);
        assert_eq!(soup.triangle_count(), 1000);
        assert_eq!(soup.positions().len(), 3000);
        // Vertices lie within ℓ = ½·1000^(−1/3) = 0.05 of centres in [0, 1)³ (1e-4: rounding).
        let b = soup.bounds();
        assert!(
            b.min.min_element() >= -0.0501 && b.max.max_element() <= 1.0501,
            "{b:?}"
        );
        assert!(
            b.min.max_element() < 0.05 && b.max.min_element() > 0.95,
            "{b:?}"
        );
    }

    #[test]
    fn hair_strands_are_long_thin_and_diagonal() {
        let hair = hair(1000, 5);
        assert_eq!(hair.triangle_count(), 1000);
        for t in hair.triangles() {
            let root = (t.v0 + t.v1) / 2.0;
            let along = t.v2 - root;
            // Rounding of sums of numbers below 2: a few ulps (~1e-7) each; 1e-5 is generous.
            assert!((along.length() - 0.5).abs() < 1e-5);
            assert!(((t.v1 - t.v0).length() - 0.002).abs() < 1e-5);
            // (1, 1, 1), of length √3, tilted by at most ¼: within asin(¼/√3) ≈ 8.3°, cos ≥ 0.9895.
            assert!(along.normalize().dot(Vec3::ONE.normalize()) > 0.989);
        }
    }

    #[test]
    fn terrain_matches_its_counts_and_domain() {
        for resolution in [1, 2, 37] {
            let t = terrain(resolution, 3);
            let r = resolution as usize;
            assert_eq!(t.triangle_count(), 2 * r * r);
            assert_eq!(t.positions().len(), (r + 1) * (r + 1));
            let b = t.bounds();
            assert_eq!((b.min.x, b.max.x, b.min.z, b.max.z), (-1.0, 1.0, 0.0, 2.0));
            // Shape in [0, 2], noise in [−0.12, 0.12].
            assert!(b.min.y >= -0.12 && b.max.y <= 2.12, "{b:?}");
            assert!(t
                .triangles()
                .all(|t| (t.v1 - t.v0).cross(t.v2 - t.v0).y > 0.0));
        }
        assert!(terrain(0, 3).is_empty());
    }

    #[test]
    fn default_scene_has_the_documented_size_and_extent() {
        let scene = default_scene();
        assert_eq!(scene.triangle_count(), 243_712);
        let b = scene.bounds();
        assert_eq!((b.min.x, b.max.x, b.min.z, b.max.z), (-1.0, 1.0, 0.0, 2.0));
    }

    #[test]
    fn non_finite_parameters_give_the_empty_mesh() {
        assert!(icosphere(Vec3::NAN, 1.0, 2).is_empty());
        assert!(icosphere(Vec3::ZERO, f32::INFINITY, 2).is_empty());
        assert!(quad_grid(2, 2, Vec3::ZERO, Vec3::X, Vec3::INFINITY).is_empty());
        assert!(closed_grid_box(2, Vec3::ZERO, Vec3::NAN).is_empty());
    }

    #[test]
    fn every_builtin_name_loads() {
        for name in BUILTIN_NAMES {
            let mesh = builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(!mesh.is_empty(), "{name}");
        }
    }

    #[test]
    fn builtin_sizes_are_parsed_and_checked() {
        assert_eq!(
            builtin("soup:10").map(|m| m.triangle_count()).ok(),
            Some(10)
        );
        assert_eq!(
            builtin("icosphere:1").map(|m| m.triangle_count()).ok(),
            Some(80)
        );
        for bad in [
            "soup:0",
            "soup:x",
            "soup:",
            "icosphere:13",
            "default:3",
            "terrain:-1",
        ] {
            assert!(
                matches!(builtin(bad), Err(Error::InvalidParameter { .. })),
                "{bad}"
            );
        }
        assert!(matches!(builtin("teapot"), Err(Error::UnknownScene(n)) if n == "teapot"));
        assert!(matches!(builtin(""), Err(Error::UnknownScene(_))));
    }

    #[test]
    fn lattice_values_cover_minus_one_to_one() {
        let values: Vec<f32> = (0..1000).map(|i| lattice_value(i, -i, 3, 0)).collect();
        assert!(values.iter().all(|v| (-1.0..1.0).contains(v)));
        assert!(values.iter().any(|&v| v < -0.9) && values.iter().any(|&v| v > 0.9));
    }
}
