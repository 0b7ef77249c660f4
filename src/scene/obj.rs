//! Wavefront OBJ loading, plain or gzip-compressed, into one validated [`Mesh`].
//!
//! kdbeam needs positions and faces only, and must say on which line a file goes wrong, so it
//! reads OBJ itself in one streaming pass rather than through `tobj` (whose errors carry no line,
//! and which also builds normals, texture coordinates and materials that kdbeam would discard).
//! Recognised statements: `v x y z [w | r g b]` and `f a b c …` with `i`, `i/t`, `i//n` or `i/t/n`
//! references. Everything else (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, `p`, unknown
//! keywords) is skipped without being read, so a missing `.mtl` file is no concern. `#` starts a
//! comment; lines may end in `\r\n`; backslash line continuation is not supported.

use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;
use glam::Vec3;

use crate::{Error, Mesh, Result};

/// Loads every face of an OBJ file (`.obj`, or gzip-compressed when the name ends in `.gz`) into
/// one mesh.
///
/// All objects and groups are merged, triangle ids following the order of the file. A polygon
/// `f v₀ v₁ … vₖ` becomes the fan (v₀, v₁, v₂), (v₀, v₂, v₃), …, (v₀, vₖ₋₁, vₖ): k − 1 triangles.
/// Positive indices count from 1 and may refer to vertices defined later in the file; negative
/// indices count back from the last vertex defined before the face (−1 is that vertex).
/// Materials, normals and texture coordinates are ignored.
///
/// # Errors
/// - [`Error::Io`]: the file cannot be opened or read.
/// - [`Error::Parse`] with the 1-based line: a malformed number, a vertex with fewer than three
///   coordinates, a face with fewer than three vertices, a malformed vertex reference, index 0.
///   Corrupt or truncated gzip data is also [`Error::Parse`], with line 0 (the fault is in the
///   compressed stream, not in a line) and the last complete line in the message.
/// - [`Error::NonFinite`]: a coordinate is NaN or infinite (including numbers too large for `f32`,
///   such as `1e39`), with the 0-based vertex.
/// - [`Error::IndexOutOfRange`]: a reference past the last vertex of the file, or a negative
///   reference reaching before the first vertex. `face` is the 0-based triangle (after fan
///   triangulation), `index` the reference as written without its sign, and `vertex_count` the
///   vertices of the file (for a negative reference: those defined before its face).
/// - [`Error::NoTriangles`]: the file holds no face.
/// - [`Error::MalformedMesh`]: more vertices than `u32` indices can address.
///
/// ```no_run
/// let mesh = kdbeam::scene::load_obj("scenes/sponza_dabrovic/sponza.obj.gz")?;
/// println!("{} triangles", mesh.triangle_count());
/// # Ok::<(), kdbeam::Error>(())
/// ```
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| Error::Io {
        path: path.into(),
        source,
    })?;
    let gzip = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    if gzip {
        parse(MultiGzDecoder::new(file), path, Compression::Gzip)
    } else {
        parse(file, path, Compression::None)
    }
}

impl Mesh {
    /// Loads a scene by name: `builtin:NAME` for a procedural scene
    /// ([`crate::scene::procedural::builtin`]), anything else as an OBJ file ([`load_obj`]).
    ///
    /// # Errors
    /// As [`load_obj`] and [`crate::scene::procedural::builtin`].
    ///
    /// ```
    /// let mesh = kdbeam::Mesh::load("builtin:icosphere:2")?;
    /// assert_eq!(mesh.triangle_count(), 20 * 4 * 4);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    pub fn load(path: impl AsRef<Path>) -> Result<Mesh> {
        let path = path.as_ref();
        match path.to_str().and_then(|p| p.strip_prefix("builtin:")) {
            Some(name) => crate::scene::procedural::builtin(name),
            None => load_obj(path),
        }
    }
}

/// How the bytes of the file are stored: decides whether a read failure is an I/O fault or
/// corrupt data.
#[derive(Clone, Copy)]
enum Compression {
    None,
    Gzip,
}

/// Reads and parses a whole OBJ stream, line by line, with one reused line buffer.
fn parse(source: impl Read, path: &Path, compression: Compression) -> Result<Mesh> {
    let mut reader = BufReader::with_capacity(1 << 16, source);
    let mut parser = ObjParser::new(path);
    let mut line = Vec::with_capacity(256);
    let mut number = 0usize;
    loop {
        line.clear();
        let read = reader
            .read_until(b'\n', &mut line)
            .map_err(|source| read_error(source, path, compression, number))?;
        if read == 0 {
            break;
        }
        number += 1;
        parser.statement(&line, number)?;
    }
    parser.finish()
}

/// A read failure: corrupt data for a gzip stream (invalid header, bad deflate data, truncation,
/// CRC mismatch), an I/O fault otherwise.
fn read_error(
    source: std::io::Error,
    path: &Path,
    compression: Compression,
    lines_read: usize,
) -> Error {
    let corrupt = matches!(
        source.kind(),
        ErrorKind::InvalidInput | ErrorKind::InvalidData | ErrorKind::UnexpectedEof
    );
    match compression {
        Compression::Gzip if corrupt => Error::Parse {
            path: path.into(),
            line: 0,
            message: format!("corrupt or truncated gzip data after line {lines_read}: {source}"),
        },
        _ => Error::Io {
            path: path.into(),
            source,
        },
    }
}

/// The state of one parse: vertices and triangles so far.
struct ObjParser<'p> {
    path: &'p Path,
    positions: Vec<Vec3>,
    faces: Vec<[u32; 3]>,
    /// The current polygon's vertex slots, reused between faces.
    polygon: Vec<u32>,
    /// The first positive reference too large for `u32` (triangle, reference as written). Such
    /// references are stored as `u32::MAX`, always out of range, and reported from here.
    first_oversized: Option<(usize, u64)>,
}

impl<'p> ObjParser<'p> {
    fn new(path: &'p Path) -> Self {
        ObjParser {
            path,
            positions: Vec::new(),
            faces: Vec::new(),
            polygon: Vec::with_capacity(8),
            first_oversized: None,
        }
    }

    fn error(&self, line: usize, message: String) -> Error {
        Error::Parse {
            path: self.path.into(),
            line,
            message,
        }
    }

    /// Parses one line (with its `\n`, if any).
    fn statement(&mut self, text: &[u8], line: usize) -> Result<()> {
        let code = text.split(|&b| b == b'#').next().unwrap_or_default();
        let mut tokens = code
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        match tokens.next() {
            Some(b"v") => self.vertex(tokens, line),
            Some(b"f") => self.face(tokens, line),
            _ => Ok(()),
        }
    }

    /// `v x y z`, ignoring anything after the third coordinate (a `w`, or vertex colours).
    fn vertex<'t>(
        &mut self,
        mut tokens: impl Iterator<Item = &'t [u8]>,
        line: usize,
    ) -> Result<()> {
        let mut p = [0.0f32; 3];
        for (found, c) in p.iter_mut().enumerate() {
            let token = tokens.next().ok_or_else(|| {
                self.error(line, format!("a vertex needs 3 coordinates, found {found}"))
            })?;
            *c = std::str::from_utf8(token)
                .ok()
                .and_then(|s| s.parse::<f32>().ok())
                .ok_or_else(|| self.error(line, format!("malformed number {}", quoted(token))))?;
        }
        if !p.iter().all(|c| c.is_finite()) {
            return Err(Error::NonFinite {
                vertex: self.positions.len(),
                position: p,
            });
        }
        self.positions.push(Vec3::from(p));
        Ok(())
    }

    /// `f a b c …`, triangulated as a fan around the first vertex.
    fn face<'t>(&mut self, tokens: impl Iterator<Item = &'t [u8]>, line: usize) -> Result<()> {
        let first_triangle = self.faces.len();
        self.polygon.clear();
        for (k, token) in tokens.enumerate() {
            // Vertex k of the polygon first appears in fan triangle max(0, k − 2).
            let triangle = first_triangle + k.saturating_sub(2);
            let slot = self.vertex_slot(token, triangle, line)?;
            self.polygon.push(slot);
        }
        if self.polygon.len() < 3 {
            return Err(self.error(
                line,
                format!(
                    "a face needs at least 3 vertices, found {}",
                    self.polygon.len()
                ),
            ));
        }
        let v0 = self.polygon[0];
        self.faces
            .extend(self.polygon.windows(2).skip(1).map(|w| [v0, w[0], w[1]]));
        Ok(())
    }

    /// The 0-based vertex slot of one face reference `i[/t][/n]`; `t` and `n` are checked for
    /// syntax only, since kdbeam reads no texture coordinates or normals.
    fn vertex_slot(&mut self, token: &[u8], triangle: usize, line: usize) -> Result<u32> {
        let malformed = || self.error(line, format!("malformed face vertex {}", quoted(token)));
        let mut parts = token.split(|&b| b == b'/');
        let (negative, magnitude) = parts.next().and_then(parse_index).ok_or_else(malformed)?;
        let mut extra = 0;
        for part in parts {
            extra += 1;
            if extra > 2 || (!part.is_empty() && parse_index(part).is_none()) {
                return Err(malformed());
            }
        }
        if magnitude == 0 {
            return Err(self.error(
                line,
                format!(
                    "face vertex {} is index 0; OBJ indices start at 1",
                    quoted(token)
                ),
            ));
        }
        let count = self.positions.len();
        if negative {
            // Relative: −1 is the last vertex defined so far.
            let back = usize::try_from(magnitude)
                .ok()
                .filter(|&m| m <= count)
                .ok_or(Error::IndexOutOfRange {
                    face: triangle,
                    index: magnitude,
                    vertex_count: count,
                })?;
            // count ≤ u32::MAX is checked when the mesh is built; saturate until then.
            Ok(u32::try_from(count - back).unwrap_or(u32::MAX))
        } else {
            // Absolute, possibly a forward reference: checked against the final count in `finish`.
            match u32::try_from(magnitude - 1) {
                Ok(slot) if slot != u32::MAX => Ok(slot),
                _ => {
                    self.first_oversized.get_or_insert((triangle, magnitude));
                    Ok(u32::MAX)
                }
            }
        }
    }

    /// Checks every reference against the final vertex count and builds the mesh.
    fn finish(self) -> Result<Mesh> {
        if self.faces.is_empty() {
            return Err(Error::NoTriangles {
                path: self.path.into(),
            });
        }
        let count = self.positions.len();
        let first_bad = self.faces.iter().enumerate().find_map(|(face, f)| {
            f.iter()
                .find(|&&slot| slot as usize >= count)
                .map(|&slot| (face, slot))
        });
        if let Some((face, slot)) = first_bad {
            let (face, index) = match self.first_oversized {
                // The first saturated reference of the file is the first one of any triangle.
                Some(oversized) if slot == u32::MAX => oversized,
                _ => (face, u64::from(slot) + 1),
            };
            return Err(Error::IndexOutOfRange {
                face,
                index,
                vertex_count: count,
            });
        }
        Mesh::from_faces(self.positions, self.faces)
    }
}

/// An OBJ index `[+|-]digits`: its sign and magnitude, the magnitude saturating at `u64::MAX`.
/// `None` when there are no digits or anything else follows them.
fn parse_index(text: &[u8]) -> Option<(bool, u64)> {
    let (negative, digits) = match text.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, text),
    };
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    let magnitude = digits.iter().fold(0u64, |m, &d| {
        m.saturating_mul(10).saturating_add(u64::from(d - b'0'))
    });
    Some((negative, magnitude))
}

/// A token for an error message: quoted, invalid UTF-8 replaced, cut at 40 characters.
fn quoted(token: &[u8]) -> String {
    let text = String::from_utf8_lossy(token);
    match text.char_indices().nth(40) {
        Some((cut, _)) => format!("{:?}…", &text[..cut]),
        None => format!("{text:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_syntax() {
        assert_eq!(parse_index(b"12"), Some((false, 12)));
        assert_eq!(parse_index(b"+3"), Some((false, 3)));
        assert_eq!(parse_index(b"-1"), Some((true, 1)));
        assert_eq!(
            parse_index(b"99999999999999999999999"),
            Some((false, u64::MAX))
        );
        for bad in [&b""[..], b"-", b"1.0", b"1a", b"--1", b" 1"] {
            assert_eq!(parse_index(bad), None, "{bad:?}");
        }
    }

    fn parse_str(text: &str) -> Result<Mesh> {
        parse(text.as_bytes(), Path::new("inline.obj"), Compression::None)
    }

    #[test]
    fn quads_and_pentagons_become_fans_in_file_order() -> Result<()> {
        let mesh = parse_str(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\n\
             o a\nf 1 2 3 4\ng b\nusemtl x\nf 1/1 2/2/2 3//3 4 5\n",
        )?;
        assert_eq!(
            mesh.faces(),
            &[[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3], [0, 3, 4]]
        );
        Ok(())
    }

    #[test]
    fn negative_indices_count_back_from_the_face() -> Result<()> {
        let mesh = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 -2\n")?;
        assert_eq!(mesh.faces(), &[[0, 1, 2], [0, 3, 2]]);
        Ok(())
    }

    #[test]
    fn forward_references_comments_and_crlf_are_accepted() -> Result<()> {
        let mesh = parse_str("f 1 2 3 # early\r\nv 0 0 0\r\nv 1 0 0 1\r\nv 0 1 0 0.5 0.5 0.5\r\n")?;
        assert_eq!(mesh.faces(), &[[0, 1, 2]]);
        assert_eq!(mesh.positions()[1], Vec3::X);
        Ok(())
    }

    #[test]
    fn fan_vertex_errors_name_the_triangle_that_first_uses_it() {
        // Vertex 4 of the pentagon (0-based) first appears in fan triangle 2, after one triangle
        // from the first face: triangle 1 + 2 = 3.
        let err = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3 1 -9\n").unwrap_err();
        assert!(
            matches!(
                err,
                Error::IndexOutOfRange {
                    face: 3,
                    index: 9,
                    vertex_count: 3
                }
            ),
            "{err:?}"
        );
    }
}
