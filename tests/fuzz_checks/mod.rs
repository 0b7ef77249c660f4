//! The checks behind the fuzz targets in `fuzz/`, shared with `tests/fuzz_corpus.rs` (which
//! replays the committed corpora through them under `cargo test`) and `tests/bad_input.rs`.
//!
//! Each check takes arbitrary bytes and panics only when kdbeam misbehaves: a panic inside
//! kdbeam, or a broken promise (a loaded mesh that is not valid, a packet result that differs
//! from the scalar path). Bad input itself is fine as long as it comes back as a `kdbeam::Error`.
#![allow(dead_code)] // Each includer uses a subset.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use kdbeam::kernels::intersect::{kensler_shirley, watertight::WatertightRay};
use kdbeam::kernels::KsTriangle;
use kdbeam::trace::Culling;
use kdbeam::{
    BuildParams, Error, Hit, HitPacket, Intersector, Isa, KdTree, Mesh, PacketShape, Ray,
    RayPacket, Tracer, Vec3,
};

/// Writes `bytes` to a fresh file called `name` in a directory unique to this process and call,
/// loads it with [`kdbeam::scene::load_obj`], and removes the directory.
pub fn load_bytes(name: &str, bytes: &[u8]) -> Result<Mesh, Error> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "kdbeam-fuzz-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).expect("create a temporary directory");
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("write a temporary file");
    let out = kdbeam::scene::load_obj(&path);
    // Best effort: a leftover file in the temporary directory is harmless.
    let _ = std::fs::remove_dir_all(&dir);
    out
}

/// `bytes`, gzip-compressed.
fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    encoder.write_all(bytes).expect("compress in memory");
    encoder.finish().expect("compress in memory")
}

/// The kind of a load result, for comparing the plain and the gzip path: the mesh itself, or the
/// error's variant with the line of a parse error (gzip reports the same lines as plain text).
#[derive(Debug, PartialEq)]
enum Outcome {
    Mesh(Mesh),
    Parse(usize),
    NonFinite(usize),
    IndexOutOfRange(usize, u64, usize),
    NoTriangles,
    Other(String),
}

fn outcome(result: Result<Mesh, Error>) -> Outcome {
    match result {
        Ok(mesh) => Outcome::Mesh(mesh),
        Err(Error::Parse { line, .. }) => Outcome::Parse(line),
        Err(Error::NonFinite { vertex, .. }) => Outcome::NonFinite(vertex),
        Err(Error::IndexOutOfRange {
            face,
            index,
            vertex_count,
        }) => Outcome::IndexOutOfRange(face, index, vertex_count),
        Err(Error::NoTriangles { .. }) => Outcome::NoTriangles,
        Err(e) => Outcome::Other(format!("{e:?}")),
    }
}

/// `obj_loader`: `data` as an OBJ file, plain and gzip-compressed, and as a (most likely corrupt)
/// `.gz` file.
///
/// Checks: nothing panics; every error prints; the plain and the compressed file give the same
/// mesh or the same error (variant and line); a loaded mesh is valid (it re-validates to itself
/// and has triangles), builds a kd-tree, and traces one packet equal to the scalar path.
pub fn obj_loader(data: &[u8]) {
    let plain = load_bytes("fuzz.obj", data);
    let compressed = load_bytes("fuzz.obj.gz", &gzip(data));
    if let Err(e) = load_bytes("raw.obj.gz", data) {
        let _ = e.to_string();
    }
    if let Err(e) = &plain {
        assert!(!e.to_string().is_empty());
    }
    let (plain, compressed) = (outcome(plain), outcome(compressed));
    assert_eq!(plain, compressed, "plain and gzip-compressed loads differ");
    if let Outcome::Mesh(mesh) = plain {
        assert!(!mesh.is_empty(), "a loaded mesh has triangles");
        let again = Mesh::from_faces(mesh.positions().to_vec(), mesh.faces().to_vec());
        assert_eq!(again.as_ref().ok(), Some(&mesh), "a loaded mesh is valid");
        let tree = KdTree::build(&mesh, &BuildParams::default()).expect("a valid mesh builds");
        let rays = kdbeam::rays::random_rays(&mesh.bounds(), 16, data.len() as u64);
        packets_equal_scalar(&mesh, &tree, &rays, u64::MAX, Culling::AUTO);
    }
}

/// A cursor over the fuzz input that yields zeros once the input runs out, so that every input
/// decodes to something.
struct Bytes<'a> {
    data: &'a [u8],
}

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    fn u64(&mut self) -> u64 {
        (0..8).fold(0, |x, _| x << 8 | u64::from(self.u8()))
    }

    fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// A coordinate on a lattice of step `scale / 8` around `offset`: coarse enough that shared
    /// edges, coplanar and degenerate triangles and rays through vertices are common.
    fn lattice(&mut self, scale: f32, offset: f32) -> f32 {
        offset + f32::from(self.u8() as i8) * 0.125 * scale
    }
}

/// Offsets that move the geometry to where `f32` spacing is coarse (1/64 at 148376).
const OFFSETS: [f32; 4] = [0.0, -1000.0, 1.0e5, 148_376.0];

/// Decodes a small scene and a ray set: a scale 2^(−20…19) and an offset; up to 24 lattice
/// vertices; up to 40 triangles (indices modulo the vertex count, so repeated vertices make
/// degenerate triangles); build parameters; then rays until the input runs out (at most 200),
/// each with a flag byte that can make it axis-parallel, give it a NaN, infinite or zero
/// component, or an empty or inverted `[tmin, tmax]`.
fn decode_scene(data: &[u8]) -> (Mesh, BuildParams, Vec<Ray>, u64) {
    let mut b = Bytes { data };
    let scale = 2f32.powi(i32::from(b.u8() % 40) - 20);
    let offset = OFFSETS[usize::from(b.u8() % 4)];
    let vertex_count = usize::from(b.u8() % 22) + 3;
    let positions: Vec<[f32; 3]> = (0..vertex_count)
        .map(|_| [(); 3].map(|_| b.lattice(scale, offset)))
        .collect();
    let triangle_count = usize::from(b.u8() % 40) + 1;
    let indices: Vec<u32> = (0..3 * triangle_count)
        .map(|_| u32::from(b.u8()) % vertex_count as u32)
        .collect();
    let mesh = Mesh::from_indexed(&positions, &indices).expect("lattice coordinates are finite");
    let p = b.u8();
    let params = BuildParams::default()
        .with_ci_over_ct([0.1, 1.0, 1.5, 10.0][usize::from(p & 3)])
        .with_leaf_size(u32::from(p >> 2 & 3) + 1)
        .with_max_depth((p & 0x80 != 0).then_some(u32::from(p >> 4 & 7)));
    let active = b.u64();
    let mut rays = Vec::new();
    while !b.is_empty() && rays.len() < 200 {
        let flags = b.u8();
        let origin = Vec3::from([(); 3].map(|_| b.lattice(scale, offset)));
        let mut direction = Vec3::from([(); 3].map(|_| f32::from(b.u8() as i8)));
        let mut ray = Ray::new(origin, direction);
        match flags & 7 {
            1 => ray.origin[usize::from(flags >> 3) % 3] = f32::NAN,
            2 => direction[usize::from(flags >> 3) % 3] = f32::INFINITY,
            3 => {
                // Axis-parallel, with signed zeros elsewhere.
                let axis = usize::from(flags >> 3) % 3;
                direction = Vec3::splat(if flags & 0x40 != 0 { -0.0 } else { 0.0 });
                direction[axis] = if flags & 0x80 != 0 { -1.0 } else { 1.0 };
            }
            4 => (ray.tmin, ray.tmax) = (1.0, 0.5),
            5 => (ray.tmin, ray.tmax) = (0.5, 0.5),
            6 => ray.tmax = f32::NAN,
            _ => {}
        }
        ray.direction = direction;
        rays.push(ray);
    }
    (mesh, params, rays, active)
}

/// `trace_packets`: a small scene decoded from `data` (see [`decode_scene`]).
///
/// Checks: the build succeeds; on every ISA this CPU runs, every packet shape and both
/// intersectors, closest and any hit of each packet (with an active mask from the input) and of
/// the streams equal the scalar single-ray path bit for bit.
pub fn trace_packets(data: &[u8]) {
    let (mesh, params, rays, active) = decode_scene(data);
    let tree = KdTree::build(&mesh, &params).expect("valid parameters build");
    packets_equal_scalar(&mesh, &tree, &rays, active, Culling::NONE);
}

/// The `culling` target: the scene and rays of [`trace_packets`], traced with the culling
/// setting the input's last byte chooses.
///
/// Checks: every single-ray, packet and stream path with culling equals the unculled scalar
/// path bit for bit: no culling stage ever changes a hit. The whole-packet traversal
/// ([`Culling::may_traverse_whole_packets`]) makes more tests than the scalar path: where it
/// differs, its hit must win by [`wins_by_an_extra_test`].
pub fn culling(data: &[u8]) {
    let (mesh, params, rays, active) = decode_scene(data);
    let tree = KdTree::build(&mesh, &params).expect("valid parameters build");
    let settings = Culling::VARIANTS;
    let choice = settings[usize::from(data.last().copied().unwrap_or(0)) % settings.len()];
    packets_equal_scalar(&mesh, &tree, &rays, active, choice);
}

/// Is `got` (from a traversal that makes a superset of the scalar path's tests: the packet
/// traversal) a hit that the scalar path's `want` loses to, found by a test the scalar path did
/// not make? It must be closer, or as close with a smaller id (the tie rule), and the
/// intersector, run alone on that triangle of `mesh`, must report exactly `got`.
pub fn wins_by_an_extra_test(
    mesh: &Mesh,
    intersector: Intersector,
    ray: &Ray,
    got: &Hit,
    want: &Hit,
) -> bool {
    let beats = got.t < want.t || (got.t == want.t && got.triangle < want.triangle);
    if !got.is_hit() || !beats || got.triangle as usize >= mesh.triangle_count() {
        return false;
    }
    let tri = mesh.triangle(got.triangle as usize);
    let hit = match intersector {
        Intersector::KenslerShirley => {
            kensler_shirley::intersect(ray, &KsTriangle::from(&tri), ray.tmin, ray.tmax)
        }
        Intersector::Watertight => WatertightRay::new(ray).intersect(&tri, ray.tmin, ray.tmax),
    };
    hit.is_some_and(|h| {
        (h.t.to_bits(), h.u.to_bits(), h.v.to_bits())
            == (got.t.to_bits(), got.u.to_bits(), got.v.to_bits())
    })
}

/// Every packet path with `culling` equals the scalar path on `rays` through `tree` (built over
/// `mesh`), each packet's active rays chosen by `active` (shifted by the packet's place in the
/// stream); streams too.
///
/// Tolerance: none. The lane kernels compute what the scalar ones do, operation for operation,
/// so hits agree to the bit, ids and barycentrics included; but where packets may traverse the
/// tree as a whole ([`Culling::may_traverse_whole_packets`], as the default does for coherent
/// packets), a hit may instead win by [`wins_by_an_extra_test`] on `mesh` (and then also count
/// as occluding).
pub fn packets_equal_scalar(
    mesh: &Mesh,
    tree: &KdTree,
    rays: &[Ray],
    active: u64,
    culling: Culling,
) {
    let relaxed = culling.may_traverse_whole_packets().then_some(mesh);
    for intersector in Intersector::ALL {
        let scalar = Tracer::new(tree)
            .with_isa(Isa::Scalar)
            .expect("scalar runs everywhere")
            .with_intersector(intersector);
        let expected: Vec<Hit> = rays.iter().map(|r| scalar.intersect(r)).collect();
        let expected_occluded: Vec<bool> = rays.iter().map(|r| scalar.occluded(r)).collect();
        for (r, (h, &o)) in rays.iter().zip(expected.iter().zip(&expected_occluded)) {
            assert_eq!(
                h.is_hit(),
                o,
                "{intersector:?}: any hit ≠ closest hit on {r:?}"
            );
            assert!(
                !h.is_hit() || (r.tmin <= h.t && h.t <= r.tmax),
                "{intersector:?}: t outside [tmin, tmax] on {r:?}: {h:?}"
            );
        }
        for isa in Isa::available() {
            // Single rays with the setting (ray-box culling, when it has it) too.
            let single = scalar
                .with_isa(isa)
                .expect("available")
                .with_culling(culling);
            for (k, r) in rays.iter().enumerate() {
                let got = single.intersect(r);
                assert!(
                    same_hit(&got, &expected[k]),
                    "{isa} {intersector:?} {culling}: single ray {k} {r:?}: {got:?}, scalar {:?}",
                    expected[k]
                );
                assert_eq!(
                    single.occluded(r),
                    expected_occluded[k],
                    "{isa} {intersector:?} {culling}: occluded single ray {k} {r:?}"
                );
            }
            for shape in PacketShape::ALL {
                let tracer = scalar
                    .with_isa(isa)
                    .expect("available")
                    .with_packet(shape)
                    .with_culling(culling);
                let n = shape.ray_count();
                let mut hits = HitPacket::default();
                for (c, chunk) in rays.chunks(n).enumerate() {
                    let p = RayPacket::from_rays(chunk);
                    let mask = active.rotate_left(c as u32 * 7) & p.full_mask();
                    tracer.intersect_packet(&p, mask, &mut hits);
                    let occluded = tracer.occluded_packet(&p, mask);
                    for (j, r) in chunk.iter().enumerate() {
                        let on = mask >> j & 1 != 0;
                        let k = c * n + j;
                        let want = if on { expected[k] } else { Hit::NONE };
                        let got = hits.hit(j);
                        let extra = relaxed.is_some_and(|m| {
                            on && wins_by_an_extra_test(m, intersector, r, &got, &want)
                        });
                        assert!(
                            same_hit(&got, &want) || extra,
                            "{isa} {shape:?} {intersector:?}: ray {k} {r:?}: packet {got:?}, scalar {want:?}"
                        );
                        let occ = occluded >> j & 1 != 0;
                        assert!(
                            occ == (on && expected_occluded[k]) || (occ && extra),
                            "{isa} {shape:?} {intersector:?}: occluded, ray {k} {r:?}"
                        );
                    }
                }
                let mut stream = vec![Hit::NONE; rays.len()];
                tracer
                    .intersect_stream(rays, &mut stream)
                    .expect("lengths match");
                let mut stream_occluded = vec![false; rays.len()];
                tracer
                    .occluded_stream(rays, &mut stream_occluded)
                    .expect("lengths match");
                for (k, r) in rays.iter().enumerate() {
                    let extra = relaxed.is_some_and(|m| {
                        wins_by_an_extra_test(m, intersector, r, &stream[k], &expected[k])
                    });
                    assert!(
                        same_hit(&stream[k], &expected[k]) || extra,
                        "{isa} {shape:?} {intersector:?}: stream ray {k} {r:?}: {:?}, scalar {:?}",
                        stream[k],
                        expected[k]
                    );
                    assert!(
                        stream_occluded[k] == expected_occluded[k] || (stream_occluded[k] && extra),
                        "{isa} {shape:?} {intersector:?}: occluded stream, ray {k} {r:?}"
                    );
                }
            }
        }
    }
}

/// Bitwise equality of two hits: `t` and the id always, the barycentrics of a hit.
pub fn same_hit(a: &Hit, b: &Hit) -> bool {
    a.triangle == b.triangle
        && a.t.to_bits() == b.t.to_bits()
        && (!b.is_hit() || (a.u.to_bits(), a.v.to_bits()) == (b.u.to_bits(), b.v.to_bits()))
}
