//! Wavefront OBJ, read here rather than with `tobj`: tobj panics on short MTL colour lines
//! (`Kd 0.5`), cannot say on which line a problem is, reads coordinates as f32 by default
//! and renumbers vertices per object. This reader keeps every coordinate in f64 and every
//! vertex's index in the file, reports every problem with its line, reads names in UTF-8 or
//! Latin-1, and drops (and counts) triangles that repeat a vertex.
//!
//! Statements read: `v` (x y z, and r g b vertex colours in [0, 1], sRGB, when every vertex
//! has them; a lone w is ignored), `vt`,
//! `vn` (checked only), `f` (v, v/vt, v//vn, v/vt/vn; negative indices count back;
//! polygons are split into a fan from their first vertex), `o` and `g` (each name is a
//! mesh), `usemtl`, `mtllib`. Others (`s`, `l`, `p`, curves) are skipped.

use crate::diag::{logical_lines, Diagnostics};
use crate::model::{Object, MAX_COORDINATE};
use std::path::{Path, PathBuf};

/// A parsed OBJ file.
#[derive(Debug, Default)]
pub struct Obj {
    /// Every `v`, in the file's order, as written (f64).
    pub positions: Vec<[f64; 3]>,
    pub texcoords: Vec<[f64; 2]>,
    /// Linear vertex colours, when every `v` gives r g b.
    pub colours: Option<Vec<[f64; 3]>>,
    pub objects: Vec<Object>,
    /// Material names in order of first `usemtl`, with that line.
    pub material_names: Vec<String>,
    pub material_lines: Vec<usize>,
    /// The `mtllib` files, resolved against the OBJ's directory, with the line naming them.
    pub mtllibs: Vec<(PathBuf, usize)>,
    /// Triangles dropped because they repeat a vertex.
    pub degenerate: usize,
    /// What cutting polygons into triangles found.
    pub faces: crate::readers::polygon::Faces,
}

fn number(word: &str) -> Option<f64> {
    word.parse::<f64>().ok()
}

/// Parses the OBJ at `path` from `bytes`; problems go to `diag`.
pub fn parse(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Obj {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut obj = Obj::default();
    let mut current: Option<usize> = None;
    // Objects and materials by name (a model of 80 000 objects looks each up in constant time).
    let mut object_index: std::collections::HashMap<String, usize> = Default::default();
    let mut material_index: std::collections::HashMap<String, usize> = Default::default();
    let mut material: Option<usize> = None;
    let mut normals = 0usize;
    let mut colours: Vec<[f64; 3]> = Vec::new();
    let mut all_coloured = true;
    for (line, text) in logical_lines(bytes) {
        let mut words = text.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        match key {
            "v" => {
                if rest.len() < 3 {
                    diag.error(
                        path,
                        line,
                        format!("'v' needs 3 numbers, found {}", rest.len()),
                    );
                    obj.positions.push([0.0; 3]);
                    all_coloured = false;
                    continue;
                }
                let mut p = [0.0; 3];
                for k in 0..3 {
                    match number(rest[k]) {
                        Some(x) if x.is_finite() && x.abs() <= MAX_COORDINATE => p[k] = x,
                        Some(x) if x.is_finite() => diag.error(
                            path,
                            line,
                            format!("coordinate {x:e} is beyond ±1e30 (libimap traces in single precision)"),
                        ),
                        _ => diag.error(path, line, format!("'{}' is not a finite number", rest[k])),
                    }
                }
                obj.positions.push(p);
                let rgb: Vec<f64> = rest[3..].iter().filter_map(|w| number(w)).collect();
                if rest.len() >= 6
                    && rgb.len() >= 3
                    && rgb[..3].iter().all(|c| (0.0..=1.0).contains(c))
                {
                    colours.push([0, 1, 2].map(|k| crate::model::srgb_to_linear(rgb[k])));
                } else {
                    all_coloured = false;
                }
            }
            "vt" => {
                let mut t = [0.0; 2];
                if rest.is_empty() {
                    diag.error(path, line, "'vt' needs at least 1 number");
                }
                for (k, w) in rest.iter().take(2).enumerate() {
                    match number(w) {
                        Some(x) if x.is_finite() => t[k] = x,
                        _ => diag.error(path, line, format!("'{w}' is not a finite number")),
                    }
                }
                obj.texcoords.push(t);
            }
            "vn" => {
                if rest.len() < 3
                    || rest
                        .iter()
                        .take(3)
                        .any(|w| !number(w).is_some_and(f64::is_finite))
                {
                    diag.error(path, line, "'vn' needs 3 finite numbers");
                }
                normals += 1;
            }
            "f" => {
                if rest.len() < 3 {
                    diag.error(
                        path,
                        line,
                        format!("a face needs at least 3 vertices, found {}", rest.len()),
                    );
                    continue;
                }
                let mut corners: Vec<(u32, Option<u32>)> = Vec::with_capacity(rest.len());
                let mut ok = true;
                for w in &rest {
                    let mut parts = w.split('/');
                    let resolve = |s: Option<&str>,
                                   count: usize,
                                   what: &str,
                                   diag: &mut Diagnostics|
                     -> Option<Option<u32>> {
                        let s = match s {
                            None | Some("") => return Some(None),
                            Some(s) => s,
                        };
                        let Ok(i) = s.parse::<i64>() else {
                            diag.error(
                                path,
                                line,
                                format!("'{w}' is not a face vertex (v, v/vt, v//vn or v/vt/vn)"),
                            );
                            return None;
                        };
                        let r = if i < 0 { count as i64 + i } else { i - 1 };
                        if i == 0 || r < 0 || r >= count as i64 {
                            diag.error(
                                path,
                                line,
                                format!("{what} index {i} is out of range (1..={count} so far)"),
                            );
                            return None;
                        }
                        Some(Some(r as u32))
                    };
                    let v = match resolve(parts.next(), obj.positions.len(), "vertex", diag) {
                        Some(Some(v)) => v,
                        Some(None) => {
                            diag.error(path, line, format!("'{w}' has no vertex index"));
                            ok = false;
                            continue;
                        }
                        None => {
                            ok = false;
                            continue;
                        }
                    };
                    let vt = match resolve(
                        parts.next(),
                        obj.texcoords.len(),
                        "texture coordinate",
                        diag,
                    ) {
                        Some(t) => t,
                        None => {
                            ok = false;
                            None
                        }
                    };
                    if resolve(parts.next(), normals, "normal", diag).is_none() {
                        ok = false;
                    }
                    corners.push((v, vt));
                }
                if !ok {
                    continue;
                }
                let o = *current.get_or_insert_with(|| {
                    let next = obj.objects.len();
                    let i = *object_index.entry("default".into()).or_insert(next);
                    if i == next {
                        obj.objects.push(Object {
                            name: "default".into(),
                            triangles: Vec::new(),
                        });
                    }
                    i
                });
                let cut = if corners.len() == 3 {
                    None
                } else {
                    let p: Vec<glam::DVec3> = corners
                        .iter()
                        .map(|c| glam::DVec3::from(obj.positions[c.0 as usize]))
                        .collect();
                    let cut = crate::readers::polygon::triangulate(&p, &[]);
                    obj.faces.note(&cut, line);
                    Some(cut.triangles)
                };
                let tris = cut.unwrap_or_else(|| vec![[0, 1, 2]]);
                for t in tris {
                    let c = t.map(|k| corners[k]);
                    let vt = match c.map(|x| x.1) {
                        [Some(a), Some(b), Some(d)] => Some([a, b, d]),
                        _ => None,
                    };
                    crate::model::push_triangle(
                        &mut obj.objects[o].triangles,
                        &mut obj.degenerate,
                        c.map(|x| x.0),
                        vt,
                        material,
                    );
                }
            }
            "o" | "g" => {
                let name = if rest.is_empty() {
                    "default".to_string()
                } else {
                    rest.join(" ")
                };
                let next = obj.objects.len();
                let i = *object_index.entry(name.clone()).or_insert(next);
                if i == next {
                    obj.objects.push(Object {
                        name,
                        triangles: Vec::new(),
                    });
                }
                current = Some(i);
            }
            "usemtl" => {
                let name = rest.join(" ");
                let next = obj.material_names.len();
                let i = *material_index.entry(name.clone()).or_insert(next);
                if i == next {
                    obj.material_names.push(name);
                    obj.material_lines.push(line);
                }
                material = Some(i);
            }
            "mtllib" => {
                if rest.is_empty() {
                    diag.error(path, line, "'mtllib' names no file");
                }
                for f in rest {
                    obj.mtllibs.push((dir.join(f), line));
                }
            }
            _ => {}
        }
    }
    obj.faces.warn(path, diag);
    obj.objects.retain(|o| !o.triangles.is_empty());
    if all_coloured && !colours.is_empty() {
        obj.colours = Some(colours);
    }
    obj
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_polygons_negative_indices_and_degenerate_triangles() {
        let text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\no quad\nusemtl a\nf -4/1 -3/2 -2/3 -1/1\nf 1 1 2\ng tri\nf 1//1 2//1 3//1\n";
        let mut d = Diagnostics::default();
        // A normal is referenced without a `vn`: an error.
        let obj = parse(Path::new("t.obj"), text, &mut d);
        assert_eq!(d.errors.len(), 1, "{:?}", d.errors);
        assert!(d.errors[0].starts_with("t.obj:13:"), "{:?}", d.errors);
        assert_eq!(obj.objects.len(), 1);
        assert_eq!(obj.objects[0].triangles.len(), 2);
        assert_eq!(obj.objects[0].triangles[1].v, [0, 2, 3]);
        assert_eq!(obj.objects[0].triangles[1].vt, Some([0, 2, 0]));
        assert_eq!(obj.degenerate, 1);
        // Counted here, warned once by the model loader (model.rs).
        assert!(d.warnings.is_empty(), "{:?}", d.warnings);
    }

    #[test]
    fn every_problem_is_reported_with_its_line_and_nothing_raw_is_echoed() {
        let text =
            b"v 0 0 0\nv 1 x 0\nv 1e39 0 0\nv 0 1\nf 1 2 9\nf 1 \x1b[31m 2\nusemtl caf\xe9\n";
        let mut d = Diagnostics::default();
        let obj = parse(Path::new("t.obj"), text, &mut d);
        let lines: Vec<&str> = d.errors.iter().map(|e| &e[..8]).collect();
        assert_eq!(
            lines,
            ["t.obj:2:", "t.obj:3:", "t.obj:4:", "t.obj:5:", "t.obj:6:"],
            "{:?}",
            d.errors
        );
        assert!(d.errors[1].contains("1e39"), "{}", d.errors[1]);
        assert!(
            d.errors.iter().all(|e| !e.contains('\x1b')),
            "{:?}",
            d.errors
        );
        assert_eq!(obj.material_names, ["café"]);
    }
}
