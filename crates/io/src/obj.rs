//! Wavefront OBJ files as triangle meshes (through `tobj`), with texture coordinates `vt` and
//! vertex normals `vn` when the file has them. Records are checked before the reader sees them,
//! so every error names the file and the line: non-finite or missing coordinates, face corners
//! that refer to records not yet defined, faces with and without `vt`/`vn` mixed.

use fiberlab_geometry::shapes::TriangleMesh;
use fiberlab_math::DVec3;
use std::path::Path;

/// Error reading an OBJ file: the file and what was wrong (with its line where there is one).
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ObjError {
    /// File path.
    pub path: std::path::PathBuf,
    /// What went wrong.
    pub message: String,
}

/// Loads every object of a Wavefront OBJ file (triangulated), scaled and translated.
pub fn read_obj(path: &Path, scale: f64, translate: DVec3) -> Result<TriangleMesh, ObjError> {
    let text =
        crate::input_file::read_text(path).map_err(|e| ObjError { path: path.into(), message: without_path(&e) })?;
    parse_obj(&text, path, scale, translate)
}

/// An input error's message without the leading `PATH: ` (the OBJ error adds it).
fn without_path(e: &crate::input_file::InputError) -> String {
    let text = e.to_string();
    let prefix = format!("{}:", e.path().display());
    text.strip_prefix(&prefix).map_or(text.clone(), |rest| rest.trim_start().to_string())
}

/// Parses OBJ text (`path` names it in errors; nothing is read from the file system:
/// `mtllib` lines are ignored, as materials come from the scene file).
pub fn parse_obj(text: &str, path: &Path, scale: f64, translate: DVec3) -> Result<TriangleMesh, ObjError> {
    // Vertex and normal records are checked here, with their line numbers (the OBJ reader
    // does not report lines, and would pass NaN coordinates on), in the single precision the
    // reader stores them in (where 1e39 is infinite).
    check_faces(text, path)?;
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some("vt") = words.clone().next() {
            let ok = words
                .clone()
                .skip(1)
                .take(2)
                .map(|w| w.parse::<f32>())
                .filter(|x| matches!(x, Ok(v) if v.is_finite()))
                .count();
            if ok != 2 {
                return Err(ObjError {
                    path: path.into(),
                    message: format!("line {}: expected two finite texture coordinates, got `{}`", n + 1, line.trim()),
                });
            }
        }
        if matches!(words.next(), Some("v" | "vn")) {
            let ok = words.take(3).map(|w| w.parse::<f32>()).filter(|x| matches!(x, Ok(v) if v.is_finite())).count();
            if ok != 3 {
                return Err(ObjError {
                    path: path.into(),
                    message: format!("line {}: expected three finite coordinates, got `{}`", n + 1, line.trim()),
                });
            }
        }
    }
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, no_materials)
        .map_err(|e| ObjError { path: path.into(), message: located(text, &opts, e) })?;
    let (mut triangles, mut uvs, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    for m in models {
        let p = &m.mesh.positions;
        let vertex = |i: u32| {
            let i = 3 * i as usize;
            DVec3::new(p[i].into(), p[i + 1].into(), p[i + 2].into()) * scale + translate
        };
        let (tc, nv) = (&m.mesh.texcoords, &m.mesh.normals);
        let uv = |i: u32| {
            let i = 2 * i as usize;
            [f64::from(tc[i]), f64::from(tc[i + 1])]
        };
        // A scale keeps normals; negative scales are refused by the scene file.
        let normal = |i: u32| {
            let i = 3 * i as usize;
            DVec3::new(nv[i].into(), nv[i + 1].into(), nv[i + 2].into())
        };
        // Every index is within its array (checked, not assumed: a reader that mixes lines
        // and faces could hand back indices of one array for another).
        let fits = |len: usize, width: usize| m.mesh.indices.iter().all(|&i| (i as usize + 1) * width <= len);
        if !fits(p.len(), 3) || (!tc.is_empty() && !fits(tc.len(), 2)) || (!nv.is_empty() && !fits(nv.len(), 3)) {
            return Err(ObjError {
                path: path.into(),
                message: format!("object `{}`: an index is out of range", m.name),
            });
        }
        for t in m.mesh.indices.chunks_exact(3) {
            triangles.push([vertex(t[0]), vertex(t[1]), vertex(t[2])]);
            if !tc.is_empty() {
                uvs.push([uv(t[0]), uv(t[1]), uv(t[2])]);
            }
            if !nv.is_empty() {
                normals.push([normal(t[0]), normal(t[1]), normal(t[2])]);
            }
        }
    }
    // Faces all have vt (vn) or none do (`check_faces`), but one model of several may lack
    // them: then the mesh has none.
    if uvs.len() != triangles.len() {
        uvs.clear();
    }
    if normals.len() != triangles.len() {
        normals.clear();
    }
    if triangles.is_empty() {
        return Err(ObjError { path: path.into(), message: "no triangles".into() });
    }
    if let Some(t) = triangles.iter().position(|t| !t.iter().all(|v| v.is_finite())) {
        return Err(ObjError {
            path: path.into(),
            message: format!("triangle {t}: a vertex is not finite after scale = {scale:?}, translate = {translate}"),
        });
    }
    Ok(TriangleMesh::with_attributes(triangles, uvs, normals))
}

/// The reader's error `e` on `text`, with the line it is at: the first line whose prefix of
/// the text the reader refuses (found by bisection: a record's error is its own line's, so a
/// prefix fails exactly when it holds the bad line).
fn located(text: &str, opts: &tobj::LoadOptions, e: tobj::LoadError) -> String {
    let ends: Vec<usize> = text.match_indices('\n').map(|(i, _)| i + 1).chain([text.len()]).collect();
    let fails = |lines: usize| {
        let prefix = &text[..ends[lines - 1]];
        tobj::load_obj_buf(&mut prefix.as_bytes(), opts, |_| Err(tobj::LoadError::OpenFileFailed)).is_err()
    };
    let (mut good, mut bad) = (0, ends.len());
    if !fails(bad) {
        return format!("{e}");
    }
    while bad - good > 1 {
        let mid = (good + bad) / 2;
        if fails(mid) { bad = mid } else { good = mid }
    }
    let line = text[ends.get(bad.wrapping_sub(2)).copied().unwrap_or(0)..ends[bad - 1]].trim();
    format!("line {bad}: {e} (`{line}`)")
}

/// Checks the `f` records of OBJ text: every `vt`/`vn` index refers to a record before it,
/// and every face has texture coordinates (normals) or none does; line (`l`) and point (`p`)
/// elements, which a mesh of triangles cannot hold, are refused. Errors name the line.
fn check_faces(text: &str, path: &Path) -> Result<(), ObjError> {
    let fail =
        |n: usize, message: String| ObjError { path: path.into(), message: format!("line {}: {message}", n + 1) };
    let (mut counts, mut first_with, mut first_without) = ([0i64; 3], [None; 3], [None; 3]);
    const NAMES: [&str; 3] = ["vertex `v`", "texture coordinate `vt`", "normal `vn`"];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kind @ ("l" | "p")) => {
                let what = if kind == "l" { "line" } else { "point" };
                return Err(fail(n, format!("`{kind}` ({what}) elements are not read: a mesh is made of faces (`f`)")));
            }
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                for corner in words {
                    let parts: Vec<&str> = corner.split('/').collect();
                    for k in 0..3 {
                        let Some(&w) = parts.get(k).filter(|w| !w.is_empty()) else {
                            first_without[k].get_or_insert(n);
                            continue;
                        };
                        first_with[k].get_or_insert(n);
                        let Ok(i) = w.parse::<i64>() else {
                            return Err(fail(n, format!("face corner `{corner}`: `{w}` is not an index")));
                        };
                        let resolved = if i < 0 { counts[k] + i + 1 } else { i };
                        if i == 0 || resolved < 1 || resolved > counts[k] {
                            return Err(fail(
                                n,
                                format!(
                                    "face corner `{corner}` refers to {} {i}, but {} are defined before it",
                                    NAMES[k], counts[k]
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for k in 1..3 {
        if let (Some(with), Some(without)) = (first_with[k], first_without[k]) {
            return Err(fail(
                without,
                format!(
                    "a face without a {} while the face at line {} has one; give every face one or none",
                    NAMES[k],
                    with + 1
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_geometry::Ray;

    #[test]
    fn obj_loads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("q.obj");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        let mesh = read_obj(&path, 2.0, DVec3::ZERO).unwrap();
        assert_eq!(mesh.len(), 2);
        let (t, _) = mesh.intersect(&Ray::new(DVec3::new(1.0, 1.0, 3.0), -DVec3::Z)).unwrap();
        assert!((t - 3.0).abs() < 1e-12);
        assert!(read_obj(&dir.path().join("none.obj"), 1.0, DVec3::ZERO).is_err());
        // A NaN or missing coordinate is an error naming its line.
        std::fs::write(&path, "v 0 0 0\nv 1 nan 0\nv 1 1 0\nf 1 2 3\n").unwrap();
        let e = read_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.ends_with("line 2: expected three finite coordinates, got `v 1 nan 0`"), "{e}");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1\nf 1 2 3\n").unwrap();
        assert!(read_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string().contains("line 3"));
        // Normals the same way; a coordinate beyond f32 (which the reader would make ∞) too.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nvn 0 inf 1\nf 1//1 2//1 3//2\n").unwrap();
        let e = read_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.ends_with("line 5: expected three finite coordinates, got `vn 0 inf 1`"), "{e}");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1e39 1 0\nf 1 2 3\n").unwrap();
        let e = read_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.contains("line 3:"), "{e}");
        // Finite vertices that scaling makes infinite.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 3e38 1 0\nf 1 2 3\n").unwrap();
        let e = read_obj(&path, 1e300, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.contains("triangle 0: a vertex is not finite after scale = 1e300"), "{e}");
    }

    /// An error the OBJ reader finds itself (not the checks above) still names its line.
    #[test]
    fn the_readers_own_errors_name_their_line() {
        // `usemtl` without a name, and a vertex with a weight of 0: the reader refuses both.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nusemtl\nf 1 2 3\n";
        let e = parse_obj(text, Path::new("m.obj"), 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.starts_with("m.obj: line 5: ") && e.ends_with("(`usemtl`)"), "{e}");
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0 0\nf 1 2 3\n";
        let e = parse_obj(text, Path::new("m.obj"), 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.starts_with("m.obj: line 3: "), "{e}");
    }

    /// Texture coordinates and normals are interpolated at the hit; the tangent is ∂P/∂u.
    #[test]
    fn obj_uvs_normals_and_tangents() {
        // A unit quad in z = 0 whose u runs along −y and v along +x (a rotated map), with
        // vertex normals tilted toward +x on the right edge.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0 0\n\
                    vn 0 0 1\nvn 1 0 1\nf 1/1/1 2/2/2 3/3/2 4/4/1\n";
        let mesh = parse_obj(text, Path::new("q.obj"), 1.0, DVec3::ZERO).unwrap();
        assert!(mesh.has_uvs());
        let (x, y) = (0.25, 0.6);
        let (t, ng, s) = mesh.intersect_point(&Ray::new(DVec3::new(x, y, 2.0), -DVec3::Z)).unwrap();
        assert!((t - 2.0).abs() < 1e-12 && (ng - DVec3::Z).length() < 1e-12);
        // The map: u = 1 − y, v = x.
        let [u, v] = s.uv.unwrap();
        assert!((u - (1.0 - y)).abs() < 1e-6 && (v - x).abs() < 1e-6, "{u} {v}");
        assert!((s.tangent - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-6, "{}", s.tangent);
        // Normals: (1 − x)·(0,0,1) + x·(1,0,1)/√2, normalized.
        let expected = (DVec3::Z * (1.0 - x) + DVec3::new(1.0, 0.0, 1.0).normalize() * x).normalize();
        assert!((s.normal - expected).length() < 1e-6, "{} vs {expected}", s.normal);
        assert!(s.tangent.dot(s.normal).abs() < 1e-12);
        // Without vt: no uvs.
        let bare = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", Path::new("b.obj"), 1.0, DVec3::ZERO);
        assert!(!bare.unwrap().has_uvs());
    }

    #[test]
    fn faces_referring_to_missing_records_name_the_file_and_line() {
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
                "line 5: face corner `2/2` refers to texture coordinate `vt` 2, but 1 are defined",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//-2\n",
                "line 5: face corner `3//-2` refers to normal `vn` -2",
            ),
            ("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "line 3: face corner `3` refers to vertex `v` 3"),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n",
                "line 6: a face without a texture coordinate `vt` while the face at line 5 has one",
            ),
            ("v 0 0 0\nvt 0 nan\n", "line 2: expected two finite texture coordinates, got `vt 0 nan`"),
            // A line element among faces with texture coordinates (which made the reader's
            // indices run past the arrays): refused at its line.
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\nl 1 2\n",
                "line 8: `l` (line) elements are not read",
            ),
        ];
        for (text, says) in cases {
            let e = parse_obj(text, Path::new("dir/m.obj"), 1.0, DVec3::ZERO).unwrap_err().to_string();
            assert!(e.starts_with("dir/m.obj: ") && e.contains(says), "{e}");
        }
    }
}
