//! PLY (ASCII and binary, with the `ply-rs-bw` crate) and STL (ASCII and binary, with
//! `stl_io`): triangle meshes without materials, so every triangle gets the default grey
//! (overridable as `[materials.default]`), or its vertices' colours when a PLY gives them.
//!
//! PLY: `vertex` x y z (any numeric type, kept in f64 when the file has doubles); colours
//! from `red green blue` or `diffuse_red diffuse_green diffuse_blue` (8-bit, or floats in
//! [0, 1]; sRGB); `face` lists named `vertex_indices` or `vertex_index` (polygons cut by ear clipping,
//! `polygon`). Other elements (edges, materials) are skipped. STL: one object per file (binary STL
//! has f32 coordinates by the format's definition); its vertices are merged by position.

use crate::diag::{printable, Diagnostics};
use crate::model::Mtl;
use crate::model::Object;
use crate::model::{push_triangle, srgb_to_linear, Model};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::path::Path;

/// The material of meshes that name none.
pub fn default_material(path: &Path) -> Mtl {
    Mtl {
        name: "default".into(),
        at: (path.to_path_buf(), 0),
        kd: Some([0.5; 3]),
        implicit: true,
        ..Default::default()
    }
}

fn object_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into())
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x as f64,
        Property::UChar(x) => x as f64,
        Property::Short(x) => x as f64,
        Property::UShort(x) => x as f64,
        Property::Int(x) => x as f64,
        Property::UInt(x) => x as f64,
        Property::Float(x) => x as f64,
        Property::Double(x) => x,
        _ => return None,
    })
}

fn list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&x| x as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&x| x as i64).collect(),
        _ => return None,
    })
}

/// A colour channel in [0, 1]: 8-bit integers are divided by 255.
fn channel(p: &Property) -> Option<f64> {
    match p {
        Property::Float(_) | Property::Double(_) => scalar(p),
        _ => scalar(p).map(|x| x / 255.0),
    }
}

/// The header with lines that are no PLY keyword made comments: Blender 2.4x wrote its
/// "Created by Blender" line without `comment`.
fn lenient_header(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    const END: &[u8] = b"end_header";
    let Some(end) = bytes.windows(END.len()).position(|w| w == END) else {
        return bytes.into();
    };
    let keywords: [&[u8]; 7] = [
        b"ply",
        b"format",
        b"comment",
        b"obj_info",
        b"element",
        b"property",
        b"end_header",
    ];
    let header = &bytes[..end];
    let stray = header.split(|&b| b == b'\n').any(|l| {
        let l = l.trim_ascii();
        !l.is_empty() && !keywords.iter().any(|k| l.starts_with(k))
    });
    if !stray {
        return bytes.into();
    }
    let mut out = Vec::with_capacity(bytes.len() + 64);
    for l in header.split(|&b| b == b'\n') {
        let t = l.trim_ascii();
        if !t.is_empty() && !keywords.iter().any(|k| t.starts_with(k)) {
            out.extend_from_slice(b"comment ");
        }
        out.extend_from_slice(l);
        out.push(b'\n');
    }
    out.pop();
    out.extend_from_slice(&bytes[end..]);
    out.into()
}

pub fn load_ply(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Result<Model, String> {
    let name = printable(&path.display().to_string());
    let parser = Parser::<DefaultElement>::new();
    let bytes = lenient_header(bytes);
    let ply = parser.read_ply(&mut &bytes[..]).map_err(|e| {
        format!(
            "{name}: not a readable PLY file ({})",
            printable(&e.to_string())
        )
    })?;
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| format!("{name}: no 'vertex' element"))?;
    let mut model = Model {
        format: "PLY",
        materials: vec![default_material(path)],
        ..Default::default()
    };
    let mut colours = Vec::with_capacity(verts.len());
    for (i, v) in verts.iter().enumerate() {
        let mut p = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            // Checked for range with every format's positions (model::load).
            p[k] = v
                .get(*axis)
                .and_then(scalar)
                .ok_or_else(|| format!("{name}: vertex {i} has no numeric '{axis}'"))?;
        }
        model.positions.push(p);
        let c = ["red", "green", "blue"].map(|c| {
            v.get(c)
                .or_else(|| v.get(&format!("diffuse_{c}")))
                .and_then(channel)
        });
        if let [Some(r), Some(g), Some(b)] = c {
            colours.push([r, g, b].map(|x| srgb_to_linear(x.clamp(0.0, 1.0))));
        }
    }
    if colours.len() == model.positions.len() && !colours.is_empty() {
        model.colours = Some(colours);
    }
    let nv = model.positions.len() as i64;
    let mut object = Object {
        name: object_name(path),
        triangles: Vec::new(),
    };
    let mut bad = 0usize;
    let mut faces = crate::readers::polygon::Faces::default();
    if let Some(face_list) = ply.payload.get("face") {
        for (f, face) in face_list.iter().enumerate() {
            let Some(idx) = face
                .get("vertex_indices")
                .or_else(|| face.get("vertex_index"))
                .and_then(list)
            else {
                return Err(format!(
                    "{name}: face {f} has no 'vertex_indices' (or 'vertex_index') list"
                ));
            };
            if idx.len() < 3 || idx.iter().any(|&i| i < 0 || i >= nv) {
                if bad == 0 {
                    diag.error(
                        path,
                        0,
                        format!(
                            "face {f}: {:?} is not a polygon of vertices 0..{nv}",
                            &idx[..idx.len().min(8)]
                        ),
                    );
                }
                bad += 1;
                continue;
            }
            let tris = if idx.len() == 3 {
                vec![[0, 1, 2]]
            } else {
                let p: Vec<glam::DVec3> = idx
                    .iter()
                    .map(|&i| glam::DVec3::from(model.positions[i as usize]))
                    .collect();
                let cut = crate::readers::polygon::triangulate(&p, &[]);
                faces.note(&cut, 0);
                cut.triangles
            };
            for t in tris {
                push_triangle(
                    &mut object.triangles,
                    &mut model.degenerate,
                    t.map(|k| idx[k] as u32),
                    None,
                    Some(0),
                );
            }
        }
    }
    faces.warn(path, diag);
    if bad > 1 {
        diag.error(
            path,
            0,
            format!("{bad} faces in all are not polygons of the file's vertices"),
        );
    }
    if object.triangles.is_empty() {
        return Err(format!(
            "{name}: no triangles (a point cloud or an empty mesh: libimap needs surfaces)"
        ));
    }
    model.objects.push(object);
    Ok(model)
}

pub fn load_stl(path: &Path, bytes: &[u8]) -> Result<Model, String> {
    let name = printable(&path.display().to_string());
    // ASCII STL with a tab after `solid` (stl_io wants a space to see ASCII).
    let mut fixed;
    let mut bytes = bytes;
    if bytes.starts_with(b"solid\t") {
        fixed = bytes.to_vec();
        fixed[5] = b' ';
        bytes = &fixed;
    }
    let mesh = stl_io::read_stl(&mut std::io::Cursor::new(bytes)).map_err(|e| {
        format!(
            "{name}: not a readable STL file ({})",
            printable(&e.to_string())
        )
    })?;
    let mut model = Model {
        format: "STL",
        materials: vec![default_material(path)],
        ..Default::default()
    };
    model
        .positions
        .extend(mesh.vertices.iter().map(|v| v.0.map(|x| x as f64)));
    let mut object = Object {
        name: object_name(path),
        triangles: Vec::new(),
    };
    for t in &mesh.faces {
        push_triangle(
            &mut object.triangles,
            &mut model.degenerate,
            t.vertices.map(|v| v as u32),
            None,
            Some(0),
        );
    }
    if object.triangles.is_empty() {
        return Err(format!("{name}: no triangles"));
    }
    model.objects.push(object);
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_ply_with_colours_and_polygons() {
        let text = b"ply\nformat ascii 1.0\nelement vertex 5\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n5000000.25 0 0 255 0 0\n5000001.25 0 0 255 0 0\n5000001.25 1 0 255 0 0\n5000000.25 1 0 255 0 0\n0 0 1 0 0 0\n4 0 1 2 3\n3 0 0 4\n";
        let mut d = Diagnostics::default();
        let m = load_ply(Path::new("t.ply"), text, &mut d).unwrap();
        assert!(d.errors.is_empty(), "{:?}", d.errors);
        assert_eq!(m.positions[0], [5000000.25, 0.0, 0.0]); // doubles stay doubles
        assert_eq!(m.objects[0].triangles.len(), 2);
        assert_eq!(m.degenerate, 1);
        assert_eq!(m.colours.as_ref().unwrap()[0], [1.0, 0.0, 0.0]);
        assert_eq!(m.objects[0].name, "t");
    }

    #[test]
    fn binary_and_ascii_stl() {
        // Binary: 80-byte header, count, one triangle.
        let mut b = vec![0u8; 80];
        b.extend(1u32.to_le_bytes());
        for x in [0f32, 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0.] {
            b.extend(x.to_le_bytes());
        }
        b.extend([0, 0]);
        let m = load_stl(Path::new("b.stl"), &b).unwrap();
        assert_eq!(m.objects[0].triangles.len(), 1);
        assert_eq!(m.positions.len(), 3);
        let a = b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n";
        let m = load_stl(Path::new("a.stl"), a).unwrap();
        assert_eq!(m.objects[0].triangles.len(), 1);
        assert!(load_stl(Path::new("x.stl"), b"solid\nfacet").is_err());
    }
}
