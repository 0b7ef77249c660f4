//! OBJ loading: every kind of bad input gives its own `kdbeam::Error`, never a panic; good input,
//! plain or gzip-compressed, gives the right triangles; the shared scenes load with their counts.

use std::io::Write;

use flate2::write::GzEncoder;
use kdbeam::scene::load_obj;
use kdbeam::{Error, Mesh};

mod common;
use common::scenes::{scenes_dir, shared_scene, SHARED_SCENES};
use common::TempFile;

fn load_text(text: &str) -> Result<Mesh, Error> {
    load_obj(TempFile::with_bytes("test.obj", text.as_bytes()))
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = GzEncoder::new(Vec::new(), flate2::Compression::default());
    encoder.write_all(bytes).expect("compress in memory");
    encoder.finish().expect("compress in memory")
}

/// The 1-based line of a parse error, or a failure naming the error actually returned.
fn parse_line(result: Result<Mesh, Error>) -> usize {
    match result {
        Err(Error::Parse { line, .. }) => line,
        other => panic!("expected Error::Parse, got {other:?}"),
    }
}

/// (face, index, vertex_count) of an out-of-range error, or a failure naming the error returned.
fn out_of_range(result: Result<Mesh, Error>) -> (usize, u64, usize) {
    match result {
        Err(Error::IndexOutOfRange {
            face,
            index,
            vertex_count,
        }) => (face, index, vertex_count),
        other => panic!("expected Error::IndexOutOfRange, got {other:?}"),
    }
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

/// A plain OBJ with many lines, big enough that truncating its gzip cuts the deflate stream.
fn big_obj() -> String {
    let mut text = String::new();
    for k in 0..3000 {
        text += &format!("v {k}.25 {}.5 -{k}.75\n", k * 7 % 13);
    }
    for k in 1..=2998 {
        text += &format!("f {k} {} {}\n", k + 1, k + 2);
    }
    text
}

#[test]
fn missing_file_is_an_io_error_naming_the_file() {
    let path = std::env::temp_dir().join("kdbeam-loader-no-such-dir/none.obj");
    match load_obj(&path) {
        Err(Error::Io { path: p, source }) => {
            assert_eq!(p, path);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("expected Error::Io, got {other:?}"),
    }
}

#[test]
fn malformed_vertex_number_reports_its_line() {
    let text = "# header\nv 0 0 0\n\nv 1 0 0\nv 0 1.0.0 0\nf 1 2 3\n";
    assert_eq!(parse_line(load_text(text)), 5);
    // The message quotes the offending token and the error prints as path:line.
    let err = load_text(text).unwrap_err().to_string();
    assert!(err.contains(":5:") && err.contains("1.0.0"), "{err}");
}

#[test]
fn vertex_with_too_few_coordinates_is_a_parse_error() {
    assert_eq!(parse_line(load_text("v 0 0 0\nv 1 0\nf 1 2 1\n")), 2);
}

#[test]
fn bad_face_tokens_are_parse_errors_with_their_line() {
    for face in [
        "f 1 2 x",
        "f 1 2 3.0",
        "f 1/x 2 3",
        "f 1/2/3/4 2 3",
        "f /1 2 3",
        "f 1 2",
        "f",
    ] {
        let text = format!("{TRIANGLE}f 1 2 3\n{face}\n");
        assert_eq!(parse_line(load_text(&text)), 5, "{face}");
    }
}

#[test]
fn zero_index_is_a_parse_error() {
    assert_eq!(parse_line(load_text(&format!("{TRIANGLE}f 0 1 2\n"))), 4);
}

#[test]
fn nan_and_infinite_vertices_are_non_finite_errors() {
    for (coordinate, is_nan) in [
        ("nan", true),
        ("inf", false),
        ("-infinity", false),
        ("1e39", false),
    ] {
        let text = format!("v 0 0 0\nv 1 {coordinate} 0\nv 0 1 0\nf 1 2 3\n");
        match load_text(&text) {
            Err(Error::NonFinite { vertex, position }) => {
                assert_eq!(vertex, 1, "{coordinate}");
                assert_eq!(position[0], 1.0);
                assert_eq!(position[1].is_nan(), is_nan, "{coordinate}");
                assert!(!position[1].is_finite(), "{coordinate}");
            }
            other => panic!("{coordinate}: expected Error::NonFinite, got {other:?}"),
        }
    }
}

#[test]
fn positive_index_out_of_range_names_face_and_index() {
    // The second face (triangle 1) refers to vertex 4 of 3.
    let result = load_text(&format!("{TRIANGLE}f 1 2 3\nf 1 2 4\n"));
    assert_eq!(out_of_range(result), (1, 4, 3));
}

#[test]
fn negative_index_reaching_before_the_first_vertex_is_out_of_range() {
    // Only two vertices exist when the face is read, though a third follows it.
    let result = load_text("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
    assert_eq!(out_of_range(result), (0, 3, 2));
}

#[test]
fn absurd_indices_are_out_of_range_not_panics() {
    for (token, expected) in [
        ("99999999999", 99_999_999_999u64),
        ("4294967296", 4_294_967_296),
        ("4294967295", 4_294_967_295),
        ("99999999999999999999999999", u64::MAX),
        ("-99999999999", 99_999_999_999),
    ] {
        let result = load_text(&format!("{TRIANGLE}f 1 2 {token}\n"));
        assert_eq!(out_of_range(result), (0, expected, 3), "{token}");
    }
}

#[test]
fn files_without_faces_have_no_triangles() {
    for text in [
        "",
        "# only a comment\n",
        TRIANGLE,
        "v 0 0 0\nvn 0 0 1\nl 1 1\n",
    ] {
        assert!(
            matches!(load_text(text), Err(Error::NoTriangles { .. })),
            "{text:?}"
        );
    }
}

#[test]
fn truncated_gzip_is_a_parse_error() {
    let compressed = gzip(big_obj().as_bytes());
    // Cut inside the deflate stream, and cut only the 8-byte trailer (CRC and size).
    for keep in [compressed.len() / 2, compressed.len() - 8, 5] {
        match load_obj(TempFile::with_bytes("cut.obj.gz", &compressed[..keep])) {
            Err(Error::Parse {
                line: 0, message, ..
            }) => {
                assert!(message.contains("gzip"), "{message}")
            }
            other => panic!("keeping {keep} bytes: expected Error::Parse, got {other:?}"),
        }
    }
}

#[test]
fn plain_text_named_gz_is_a_parse_error() {
    let path = TempFile::with_bytes("plain.obj.gz", format!("{TRIANGLE}f 1 2 3\n").as_bytes());
    assert_eq!(parse_line(load_obj(path)), 0);
}

#[test]
fn gzip_loads_the_same_mesh_as_plain_text() -> Result<(), Error> {
    let text = big_obj();
    let plain = load_obj(TempFile::with_bytes("big.obj", text.as_bytes()))?;
    let compressed = load_obj(TempFile::with_bytes("big.obj.GZ", &gzip(text.as_bytes())))?;
    assert_eq!(plain.triangle_count(), 2998);
    assert_eq!(plain, compressed);
    Ok(())
}

#[test]
fn objects_and_groups_merge_in_file_order_and_missing_mtl_is_ignored() -> Result<(), Error> {
    let text = "mtllib missing.mtl\no first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\ns 1\n\
                f 1 2 3\ng second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvn 0 0 1\n\
                f -4/1/1 -3/1/1 -2/1/1 -1/1/1\n";
    let mesh = load_text(text)?;
    assert_eq!(mesh.faces(), &[[0, 1, 2], [3, 4, 5], [3, 5, 6]]);
    assert_eq!(mesh.triangle(2).v2, glam::Vec3::new(0.0, 1.0, 1.0));
    Ok(())
}

#[test]
fn mesh_load_reads_files_and_builtin_names() -> Result<(), Error> {
    let file = Mesh::load(TempFile::with_bytes(
        "one.obj",
        format!("{TRIANGLE}f 1 2 3\n").as_bytes(),
    ))?;
    assert_eq!(file.triangle_count(), 1);
    assert_eq!(Mesh::load("builtin:soup:12")?.triangle_count(), 12);
    assert!(matches!(
        Mesh::load("builtin:teapot"),
        Err(Error::UnknownScene(_))
    ));
    Ok(())
}

#[test]
fn shared_scenes_load_with_their_triangle_counts() -> Result<(), Error> {
    if let Err(why) = scenes_dir() {
        println!("skipped: the shared scenes: {why}");
        return Ok(());
    }
    // Triangles after fan triangulation (all four files hold only triangles).
    let triangles = [8_316, 66_454, 69_451, 100_000];
    for ((name, _), triangles) in SHARED_SCENES.into_iter().zip(triangles) {
        let mesh = load_obj(shared_scene(name).expect("the file exists"))?;
        assert_eq!(mesh.triangle_count(), triangles, "{name}");
        // Every scene spans some volume (the smallest, the bunny, is 0.15 units across).
        assert!(mesh.bounds().extent().min_element() > 0.1, "{name}");
    }
    assert!(shared_scene("teapot").is_err());
    Ok(())
}
