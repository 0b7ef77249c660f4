//! Bad input gives a typed `kdbeam::Error`, never a panic, where `tests/loader.rs` does not
//! already cover it: random byte mutations of a valid OBJ (plain and gzip-compressed), malformed
//! `Mesh` constructor input, `BuildParams` at the ends of their ranges, unavailable ISAs, bad intersector names and
//! stream outputs of the wrong length.

mod fuzz_checks;

use kdbeam::scene::rng::Rng;
use kdbeam::{BuildParams, Error, Hit, Intersector, Isa, KdTree, Mesh, Ray, Tracer, Vec3};

/// A valid OBJ with every statement kind the loader reads or skips.
const VALID_OBJ: &str = "# a cube corner\nmtllib a.mtl\no corner\nv 0 0 0\nv 1 0 0\nv 1 1 0\n\
v 0 1 0\nv 0 0 1 1.0\nvt 0.5 0.5\nvn 0 0 1\ng faces\nusemtl m\ns off\nf 1 2 3 4\n\
f 1/1 5/1 2/1\nf -5//1 -1//1 -2//1\nf 1/1/1 4/1/1 5/1/1\nl 1 2\n";

/// 1000 random mutations of [`VALID_OBJ`] (byte flips, bytes from a set of OBJ-significant
/// characters, insertions, deletions, truncations), each loaded plain, gzip-compressed and as
/// raw `.gz` by the `obj_loader` fuzz check: no panic, the same result both ways, and any mesh
/// valid and traceable.
#[test]
fn random_mutations_of_a_valid_obj_never_panic() {
    fuzz_checks::obj_loader(VALID_OBJ.as_bytes());
    let mut rng = Rng::new(6);
    let significant = b" \n\r\t/-+.0123456789eEfvn#\0\xff";
    let mut results = [0usize; 2];
    for _ in 0..1000 {
        let mut bytes = VALID_OBJ.as_bytes().to_vec();
        for _ in 0..=rng.below(4) {
            let at = rng.below(bytes.len() as u32 + 1) as usize;
            let byte = if rng.below(2) == 0 {
                significant[rng.below(significant.len() as u32) as usize]
            } else {
                rng.next_u32() as u8
            };
            match rng.below(5) {
                0 if at < bytes.len() => bytes[at] ^= 1 << rng.below(8),
                1 if at < bytes.len() => bytes[at] = byte,
                2 => bytes.insert(at, byte),
                3 if at < bytes.len() => {
                    bytes.remove(at);
                }
                _ => bytes.truncate(at),
            }
        }
        fuzz_checks::obj_loader(&bytes);
        results[usize::from(fuzz_checks::load_bytes("m.obj", &bytes).is_ok())] += 1;
    }
    eprintln!(
        "{} mutations loaded, {} were errors",
        results[1], results[0]
    );
    assert!(
        results[0] > 0 && results[1] > 0,
        "mutations should both load and fail"
    );
}

#[test]
fn mesh_constructors_reject_malformed_input() {
    let p = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    for indices in [&[0u32, 1][..], &[0, 1, 2, 0], &[0]] {
        assert!(
            matches!(
                Mesh::from_indexed(&p, indices),
                Err(Error::MalformedMesh(_))
            ),
            "{indices:?}"
        );
    }
    for (indices, face, index) in [
        (&[0u32, 1, 3][..], 0, 3),
        (&[0, 1, 2, 2, u32::MAX, 0], 1, u64::from(u32::MAX)),
    ] {
        match Mesh::from_indexed(&p, indices) {
            Err(Error::IndexOutOfRange {
                face: f,
                index: i,
                vertex_count: 3,
            }) => assert_eq!((f, i), (face, index)),
            other => panic!("{indices:?}: expected IndexOutOfRange, got {other:?}"),
        }
    }
    // Any index into no vertices is out of range.
    assert!(matches!(
        Mesh::from_indexed(&[], &[0, 0, 0]),
        Err(Error::IndexOutOfRange {
            vertex_count: 0,
            ..
        })
    ));
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut q = p;
        q[2][1] = bad;
        match Mesh::from_indexed(&q, &[0, 1, 2]) {
            Err(Error::NonFinite {
                vertex: 2,
                position,
            }) => {
                assert_eq!(position[1].to_bits(), bad.to_bits())
            }
            other => panic!("{bad}: expected NonFinite, got {other:?}"),
        }
        assert!(matches!(
            Mesh::from_soup(&q),
            Err(Error::NonFinite { vertex: 2, .. })
        ));
        assert!(matches!(
            Mesh::from_faces(q.iter().map(|&v| Vec3::from(v)).collect(), vec![[0, 1, 2]]),
            Err(Error::NonFinite { vertex: 2, .. })
        ));
    }
    assert!(matches!(
        Mesh::from_soup(&p[..2]),
        Err(Error::MalformedMesh(_))
    ));
    assert!(matches!(
        Mesh::from_faces(vec![Vec3::ZERO], vec![[0, 0, 1]]),
        Err(Error::IndexOutOfRange {
            face: 0,
            index: 1,
            vertex_count: 1
        })
    ));
    // A non-finite vertex no face uses is still rejected: the mesh promises finite positions.
    assert!(matches!(
        Mesh::from_indexed(&[p[0], p[1], p[2], [f32::NAN; 3]], &[0, 1, 2]),
        Err(Error::NonFinite { vertex: 3, .. })
    ));
}

/// `BuildParams` at the ends of their ranges (invalid ones are `tests/kdtree_invariants.rs`'s)
/// build trees that trace right.
#[test]
fn build_params_at_the_ends_of_their_ranges_build() {
    let mesh = kdbeam::scene::procedural::icosphere(Vec3::ZERO, 1.0, 2);
    let rays = kdbeam::rays::random_rays(&mesh.bounds(), 200, 3);
    for params in [
        BuildParams::default()
            .with_ci_over_ct(f32::MIN_POSITIVE)
            .with_empty_bonus(0.0)
            .with_max_depth(Some(0))
            .with_leaf_size(1)
            .with_exact_search_max(0),
        BuildParams::default()
            .with_ci_over_ct(f32::MAX)
            .with_empty_bonus(0.999_999)
            .with_max_depth(Some(64))
            .with_leaf_size(u32::MAX)
            .with_exact_search_max(u32::MAX),
    ] {
        let tree = KdTree::build(&mesh, &params).expect("valid parameters");
        let tracer = Tracer::new(&tree).with_intersector(Intersector::Watertight);
        // Random rays in the sphere's box: an edge within a few ulps of one is unlikely in 200,
        // so the closest triangle is the oracle's.
        for r in &rays {
            let want = kdbeam::trace::reference::brute_force(&mesh, r).map(|h| h.triangle);
            let hit = tracer.intersect(r);
            let got = hit.is_hit().then_some(hit.triangle);
            assert_eq!(got, want, "{params:?}: {r:?}");
        }
    }
}

#[test]
fn unavailable_isas_and_unknown_names_are_errors() {
    let mesh = Mesh::default();
    let tree = KdTree::build(&mesh, &BuildParams::default()).expect("the empty mesh builds");
    for isa in Isa::ALL {
        match Tracer::new(&tree).with_isa(isa) {
            Ok(t) => {
                assert!(isa.is_available());
                assert_eq!(t.isa(), isa);
            }
            Err(Error::IsaUnavailable(i)) => {
                assert!(!isa.is_available());
                assert_eq!(i, isa);
            }
            Err(e) => panic!("{isa}: unexpected {e:?}"),
        }
    }
    for name in ["", "avx1024", "sse2", "neon"] {
        assert!(name.parse::<Isa>().is_err(), "{name:?}");
    }
    assert_eq!("avx512".parse::<Isa>(), Ok(Isa::Avx512));
    for name in ["", "fast", "watertight2"] {
        assert!(
            matches!(
                name.parse::<Intersector>(),
                Err(Error::InvalidParameter {
                    name: "intersector",
                    ..
                })
            ),
            "{name:?}"
        );
    }
}

#[test]
fn streams_with_outputs_of_the_wrong_length_are_errors() {
    let mesh = Mesh::from_soup(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        .expect("one triangle");
    let tree = KdTree::build(&mesh, &BuildParams::default()).expect("valid mesh");
    let tracer = Tracer::new(&tree);
    let rays = vec![Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z); 10];
    for n in [0, 9, 11, 100] {
        let mut hits = vec![Hit::NONE; n];
        assert!(
            matches!(
                tracer.intersect_stream(&rays, &mut hits),
                Err(Error::InvalidParameter {
                    name: "stream output",
                    ..
                })
            ),
            "{n} hits for 10 rays"
        );
        assert!(
            hits.iter().all(|h| *h == Hit::NONE),
            "nothing written on error"
        );
        let mut occluded = vec![false; n];
        assert!(
            matches!(
                tracer.occluded_stream(&rays, &mut occluded),
                Err(Error::InvalidParameter {
                    name: "stream output",
                    ..
                })
            ),
            "{n} outputs for 10 rays"
        );
    }
}
