//! Triangle meshes in Wavefront OBJ: read (through `tobj`) as an object for the polygonal
//! baseline ([`tracker::TriMesh`], thesis Fig. 2.1.2 (b)), and written from a tessellated NURBS
//! surface so that the same object can be felt both ways, or opened elsewhere.
//!
//! An OBJ written here has one `v` line per vertex (the shortest decimal that reads back as
//! the same `f32`), one `vt` line with the vertex's surface parameters `(u, v)` and one
//! `f a/a b/b c/c` line per triangle, oriented like the surface (`S_u × S_v` outward).

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use nurbs::Vec3;
use tracker::TriMesh;

use crate::Scene;

/// Why an OBJ file could not be opened. The message names the file and, where the problem
/// is on one line, the line.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: io::Error,
    },
    /// A line is not valid OBJ (or not what a mesh for haptics may hold).
    #[error("{}:{line}: {message}: {text:?}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line (1-based).
        line: usize,
        /// What is wrong.
        message: String,
        /// The line's text (its first [`EXCERPT_CHARS`] characters and its length, when
        /// longer).
        text: String,
    },
    /// No triangle of nonzero area.
    #[error("{}: no triangle of nonzero area (faces need at least 3 vertices)", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
}

/// The characters of a line an error quotes; a longer line is cut there, its length given.
pub const EXCERPT_CHARS: usize = 80;

/// A mesh read from an OBJ file.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjMesh {
    /// The first object's name in the file, or the file's stem.
    pub name: String,
    /// The triangles (polygons fanned into triangles), with the `vt` coordinates as their
    /// surface parameters where the file has them.
    pub mesh: TriMesh,
}

/// Reads the OBJ file at `path`.
pub fn load_obj(path: &Path) -> Result<ObjMesh, ObjError> {
    let text = std::fs::read_to_string(path).map_err(|error| ObjError::Read {
        path: path.to_owned(),
        error,
    })?;
    parse_obj(&text, path)
}

/// Reads OBJ text, `path` naming it in errors. Every line is checked first (a vertex of three
/// finite numbers, with a nonzero w or a colour, faces of at least three vertex indices that
/// exist), so that an error says what is wrong on which line; then `tobj` reads the file,
/// triangulating polygons (as fans). Whatever else `tobj` refuses is reported the same way,
/// at the line it stopped on.
pub fn parse_obj(text: &str, path: &Path) -> Result<ObjMesh, ObjError> {
    let line_error = |line: usize, message: String| ObjError::Line {
        path: path.to_owned(),
        line,
        message,
        text: excerpt(text.lines().nth(line - 1).unwrap_or("").trim()),
    };
    check_lines(text).map_err(|(line, message)| line_error(line, message))?;
    let options = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..tobj::LoadOptions::default()
    };
    // Materials (`mtllib`) are not needed for haptics and not read. tobj reads line by line
    // and stops at the line it refuses: what it consumed of `rest` ends with that line.
    let mut rest = text.as_bytes();
    let (models, _) =
        tobj::load_obj_buf(&mut rest, &options, |_| Ok(Default::default())).map_err(|error| {
            let read = &text.as_bytes()[..text.len() - rest.len()];
            let newlines = read.iter().filter(|&&b| b == b'\n').count();
            let line = if read.last().is_none_or(|&b| b != b'\n') {
                newlines + 1
            } else {
                newlines
            };
            line_error(line.max(1), error.to_string())
        })?;
    let (mut vertices, mut params, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
    for model in &models {
        let m = &model.mesh;
        let base = vertices.len() as u32;
        let first = params.len();
        vertices.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        params.resize(vertices.len(), [0.0f32; 2]);
        if m.texcoord_indices.len() == m.indices.len() {
            for (&vi, &ti) in m.indices.iter().zip(&m.texcoord_indices) {
                let (vi, ti) = (vi as usize, ti as usize);
                if let (Some(p), Some(t)) = (
                    params.get_mut(first + vi),
                    m.texcoords.get(2 * ti..2 * ti + 2),
                ) {
                    *p = [t[0], t[1]];
                }
            }
        }
        triangles.extend(
            m.indices
                .chunks_exact(3)
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }
    let mesh = TriMesh::from_triangles(vertices, params, &triangles);
    if mesh.triangles().is_empty() {
        return Err(ObjError::Empty {
            path: path.to_owned(),
        });
    }
    let name = models
        .iter()
        .map(|m| m.name.trim())
        .find(|n| !n.is_empty() && *n != "unnamed_object")
        .map(str::to_owned)
        .or_else(|| path.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "mesh".to_owned());
    Ok(ObjMesh { name, mesh })
}

/// `line`, or its first [`EXCERPT_CHARS`] characters and its length.
fn excerpt(line: &str) -> String {
    match line.char_indices().nth(EXCERPT_CHARS) {
        Some((cut, _)) => format!("{}… ({} bytes)", line[..cut].trim_end(), line.len()),
        None => line.to_owned(),
    }
}

/// The first line (1-based) that is not a valid vertex or face, and why.
fn check_lines(text: &str) -> Result<(), (usize, String)> {
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let numbers = |words: std::str::SplitWhitespace<'_>, want: usize, what: &str| {
            let values: Vec<&str> = words.collect();
            if values.len() < want {
                return Err((
                    line,
                    format!("{what} needs {want} numbers, found {}", values.len()),
                ));
            }
            for w in &values {
                match w.parse::<f32>() {
                    Ok(x) if x.is_finite() => {}
                    Ok(_) => return Err((line, format!("{what}: {w} is not finite"))),
                    Err(_) => return Err((line, format!("{what}: {w:?} is not a number"))),
                }
            }
            Ok(())
        };
        match keyword {
            "v" => {
                // x y z, then nothing, a homogeneous w (dividing x, y, z) or a colour r g b.
                let values: Vec<&str> = words.clone().collect();
                numbers(words, 3, "a vertex (v)")?;
                match values.len() {
                    3 | 6 => {}
                    4 if values[3].parse::<f32>().is_ok_and(|w| w == 0.0) => {
                        return Err((
                            line,
                            "a vertex (v): w = 0 (x, y and z are divided by w)".to_owned(),
                        ));
                    }
                    4 => {}
                    n => {
                        return Err((
                            line,
                            format!(
                                "a vertex (v) takes 3 numbers (x y z), 4 (x y z w) or 6 \
                                 (x y z r g b), found {n}"
                            ),
                        ));
                    }
                }
                v += 1;
            }
            "vt" => {
                numbers(words, 1, "a texture coordinate (vt)")?;
                vt += 1;
            }
            "vn" => {
                numbers(words, 3, "a normal (vn)")?;
                vn += 1;
            }
            "f" => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Err((
                        line,
                        format!(
                            "a face (f) needs at least 3 vertices, found {}",
                            corners.len()
                        ),
                    ));
                }
                for c in corners {
                    if c.split('/').count() > 3 {
                        return Err((
                            line,
                            format!(
                                "face corner {c:?}: a corner is at most vertex/texture \
                                 coordinate/normal (3 indices)"
                            ),
                        ));
                    }
                    for (k, (part, count, what)) in c
                        .split('/')
                        .zip([(v, "vertex"), (vt, "texture coordinate"), (vn, "normal")])
                        .map(|(p, (n, w))| (p, n, w))
                        .enumerate()
                    {
                        if part.is_empty() && k > 0 {
                            continue;
                        }
                        let index: i64 = part.parse().map_err(|_| {
                            (line, format!("face corner {c:?}: {part:?} is not an index"))
                        })?;
                        let count = count as i64;
                        let valid = (1..=count).contains(&index) || (-count..=-1).contains(&index);
                        if !valid {
                            return Err((
                                line,
                                format!(
                                    "face corner {c:?}: {what} {index} does not exist ({count} \
                                     defined above this line)"
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Writes `mesh` as OBJ, object `name`; `comment` goes in a comment line at the top.
pub fn write_obj(mesh: &TriMesh, name: &str, comment: &str, mut out: impl Write) -> io::Result<()> {
    let mut w = io::BufWriter::new(&mut out);
    for line in comment.lines() {
        writeln!(w, "# {line}")?;
    }
    let name: String = name
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    writeln!(w, "o {name}")?;
    // `{:?}` of an f32 is the shortest decimal that parses back to the same f32.
    for p in mesh.vertices() {
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for t in mesh.params() {
        writeln!(w, "vt {:?} {:?}", t[0], t[1])?;
    }
    for t in mesh.triangles() {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(w, "f {a}/{a} {b}/{b} {c}/{c}")?;
    }
    w.flush()
}

/// Writes `mesh` as OBJ to the file `path`.
pub fn save_obj(mesh: &TriMesh, name: &str, comment: &str, path: &Path) -> io::Result<()> {
    let file = std::fs::File::create(path)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    write_obj(mesh, name, comment, file)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))
}

/// Joins tessellations of every surface of object `object` of `scene` at the chordal
/// tolerance `tol_m` into one mesh (for display, export and the polygonal baseline).
pub fn tessellate_object(scene: &Scene, object: usize, tol_m: f32) -> Option<TriMesh> {
    let surfaces = scene.object(object)?.surface_views()?;
    let (mut vertices, mut params, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
    for s in &surfaces {
        let m = TriMesh::tessellate(s, tol_m);
        let base = vertices.len() as u32;
        vertices.extend_from_slice(m.vertices());
        params.extend_from_slice(m.params());
        triangles.extend(m.triangles().iter().map(|t| t.map(|i| i + base)));
    }
    Some(TriMesh::from_triangles(vertices, params, &triangles))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        match parse_obj(text, Path::new("m.obj")) {
            Ok(m) => panic!("accepted: {m:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn invalid_obj_errors_name_the_file_and_line() {
        let ok = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        assert_eq!(
            err(&format!("{ok}v 1 x 0\nf 1 2 3\n")),
            "m.obj:4: a vertex (v): \"x\" is not a number: \"v 1 x 0\""
        );
        assert_eq!(
            err(&format!("{ok}f 1 2 4\n")),
            "m.obj:4: face corner \"4\": vertex 4 does not exist (3 defined above this line): \
             \"f 1 2 4\""
        );
        assert_eq!(
            err(&format!("{ok}f 1 2\n")),
            "m.obj:4: a face (f) needs at least 3 vertices, found 2: \"f 1 2\""
        );
        assert_eq!(
            err(&format!("v 0 0 nan\n{ok}")),
            "m.obj:1: a vertex (v): nan is not finite: \"v 0 0 nan\""
        );
        assert_eq!(
            err(ok),
            "m.obj: no triangle of nonzero area (faces need at least 3 vertices)"
        );
    }

    /// Lines tobj refuses are refused naming the line and what is wrong, like every other
    /// invalid line: a vertex with w = 0, a face corner of four indices, a vertex line of a
    /// megabyte (quoted cut to its first characters), and what only tobj checks (a `vt` of
    /// one number, a `usemtl` with no name) at the line tobj stopped on.
    #[test]
    fn lines_tobj_refuses_name_the_line() {
        let ok = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
        assert_eq!(
            err(&format!("{ok}v 1 1 0 0\nf 1 2 3\n")),
            "m.obj:6: a vertex (v): w = 0 (x, y and z are divided by w): \"v 1 1 0 0\""
        );
        assert_eq!(
            err(&format!("{ok}f 1/1/1/1 2 3\n")),
            "m.obj:6: face corner \"1/1/1/1\": a corner is at most vertex/texture \
             coordinate/normal (3 indices): \"f 1/1/1/1 2 3\""
        );
        let long = format!("v 0 0 0{}", " 1".repeat(500_000));
        let e = err(&format!("{ok}{long}\nf 1 2 3\n"));
        assert!(
            e.starts_with(
                "m.obj:6: a vertex (v) takes 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), \
                 found 500003: \"v 0 0 0 1 1"
            ),
            "{}",
            &e[..200]
        );
        assert!(
            e.ends_with(&format!("1 1… ({} bytes)\"", long.len())),
            "{e}"
        );
        assert!(e.len() < 300, "{e}");
        assert_eq!(
            err(&format!("{ok}vt 0.5\nf 1 2 3\n")),
            "m.obj:6: texcoord parse error: \"vt 0.5\""
        );
        assert_eq!(
            err(&format!("{ok}f 1 2 3\nusemtl\nf 1 2 3")),
            "m.obj:7: material parse error: \"usemtl\""
        );
    }

    /// A quad is fanned into two triangles; negative (relative) indices work; the name is
    /// the file's object name.
    #[test]
    fn a_quad_becomes_two_triangles() {
        let text = "o plate\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n";
        let m = parse_obj(text, Path::new("q.obj")).expect("valid");
        assert_eq!(m.name, "plate");
        assert_eq!(m.mesh.triangles().len(), 2);
        assert!(m.mesh.normals().iter().all(|n| *n == Vec3::Z));
    }
}
