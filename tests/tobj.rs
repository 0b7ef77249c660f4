//! `Mesh::try_from(&tobj::Mesh)` (the `tobj` feature): the triangles it makes, and a typed
//! error, never a panic, for every malformed input.
#![cfg(feature = "tobj")]

use kdbeam::{Error, Mesh};

fn tobj_mesh(positions: &[f32], indices: &[u32], face_arities: &[u32]) -> tobj::Mesh {
    tobj::Mesh {
        positions: positions.to_vec(),
        indices: indices.to_vec(),
        face_arities: face_arities.to_vec(),
        ..tobj::Mesh::default()
    }
}

const SQUARE: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];

#[test]
fn triangles_and_polygons_become_the_triangles_of_their_fans() -> Result<(), Error> {
    let triangulated = Mesh::try_from(&tobj_mesh(&SQUARE, &[0, 1, 2, 0, 2, 3], &[]))?;
    let fanned = Mesh::try_from(&tobj_mesh(&SQUARE, &[0, 1, 2, 3], &[4]))?;
    assert_eq!(triangulated, fanned);
    assert_eq!(fanned.faces(), &[[0, 1, 2], [0, 2, 3]]);
    let mixed = Mesh::try_from(&tobj_mesh(&SQUARE, &[0, 1, 2, 0, 1, 2, 3], &[3, 4]))?;
    assert_eq!(mixed.faces(), &[[0, 1, 2], [0, 1, 2], [0, 2, 3]]);
    assert_eq!(Mesh::try_from(&tobj::Mesh::default())?.triangle_count(), 0);
    Ok(())
}

#[test]
fn malformed_meshes_are_typed_errors() {
    let cases = [
        (
            tobj_mesh(&SQUARE[..11], &[0, 1, 2], &[]),
            "positions not in threes",
        ),
        (
            tobj_mesh(&SQUARE, &[0, 1, 2, 3], &[]),
            "indices not in threes",
        ),
        (
            tobj_mesh(&SQUARE, &[0, 1, 2, 3], &[2, 2]),
            "a face of two vertices",
        ),
        (
            tobj_mesh(&SQUARE, &[0, 1, 2, 3], &[3]),
            "arities short of the indices",
        ),
        (
            tobj_mesh(&SQUARE, &[0, 1, 2], &[4]),
            "arities past the indices",
        ),
    ];
    for (mesh, what) in cases {
        assert!(
            matches!(Mesh::try_from(&mesh), Err(Error::MalformedMesh(_))),
            "{what}"
        );
    }
    assert!(matches!(
        Mesh::try_from(&tobj_mesh(&SQUARE, &[0, 1, 4], &[])),
        Err(Error::IndexOutOfRange { index: 4, .. })
    ));
    assert!(matches!(
        Mesh::try_from(&tobj_mesh(&SQUARE, &[0, 1, 2, 3], &[4, 0])),
        Err(Error::MalformedMesh(_))
    ));
    let mut nan = SQUARE;
    nan[4] = f32::NAN;
    assert!(matches!(
        Mesh::try_from(&tobj_mesh(&nan, &[0, 1, 2], &[])),
        Err(Error::NonFinite { vertex: 1, .. })
    ));
}
