//! The model readers: OBJ with its MTL libraries (`obj`, `mtl`), glTF and GLB (`gltf`),
//! PLY and STL (`ply_stl`) and Radiance scenes (`rad`), each into a `Model`; `polygon`
//! triangulates the faces they give. `load` picks the reader by the file's extension.

pub mod gltf;
pub mod mtl;
pub mod obj;
pub mod ply_stl;
pub mod polygon;
pub mod rad;

use crate::diag::{printable, Diagnostics};
use crate::model::{Model, Mtl, Texture};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The formats `imap` reads, by file extension.
pub const FORMATS: &str = ".obj (with .mtl), .gltf, .glb, .ply, .stl, .rad";

/// Reads a model of any supported format; problems go to `diag`. A model without
/// triangles is an error; triangles that repeat a vertex are left out with one warning.
pub fn load(path: &Path, diag: &mut Diagnostics) -> Result<Model, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let bytes = crate::diag::read_input;
    let model = match ext.as_str() {
        "obj" => from_obj(path, &utf16_to_utf8(bytes(path)?), diag),
        "gltf" | "glb" => gltf::load(path, diag)?,
        "ply" => ply_stl::load_ply(path, &bytes(path)?, diag)?,
        "stl" => ply_stl::load_stl(path, &bytes(path)?)?,
        "rad" => rad::load(path, &bytes(path)?, diag),
        _ => {
            return Err(format!(
                "{}: unknown model format '.{}' (imap reads {FORMATS})",
                printable(&path.display().to_string()),
                printable(&ext)
            ))
        }
    };
    if ext != "obj" && ext != "rad" {
        model.check_positions(path, diag);
    }
    if model.objects.is_empty() && !diag.has_errors() {
        diag.error(path, 0, "no triangles");
    }
    if model.degenerate > 0 {
        diag.warn(format!(
            "{}: {} triangle(s) repeat a vertex and were left out",
            path.display(),
            model.degenerate
        ));
    }
    Ok(model)
}

/// A text file in UTF-16 (with its byte-order mark) as UTF-8; anything else unchanged.
pub fn utf16_to_utf8(b: Vec<u8>) -> Vec<u8> {
    let be = match b.get(..2) {
        Some([0xFE, 0xFF]) => true,
        Some([0xFF, 0xFE]) => false,
        _ => return b,
    };
    let units = b[2..].chunks_exact(2).map(|c| {
        if be {
            u16::from_be_bytes([c[0], c[1]])
        } else {
            u16::from_le_bytes([c[0], c[1]])
        }
    });
    char::decode_utf16(units)
        .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
        .collect::<String>()
        .into_bytes()
}

/// An OBJ and its MTL libraries; each distinct `map_Kd` image is decoded once.
fn from_obj(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Model {
    let mut o = obj::parse(path, bytes, diag);
    let mut mtls: Vec<Mtl> = Vec::new();
    for (lib, line) in &o.mtllibs {
        match crate::diag::read_input(lib) {
            Ok(b) => mtls.extend(mtl::parse(lib, &utf16_to_utf8(b), diag)),
            Err(e) => diag.error(path, *line, format!("material library {e}")),
        }
    }
    let mut textures: HashMap<PathBuf, Option<Arc<Texture>>> = HashMap::new();
    for m in &mut mtls {
        let Some(p) = m.map_kd.clone() else { continue };
        let t = textures.entry(p.clone()).or_insert_with(|| match Texture::load(&p) {
            Ok(t) => Some(Arc::new(t)),
            Err(e) => {
                diag.warn(format!(
                    "{}:{}: map_Kd texture not read ({e}): material '{}' uses its Kd (grey 0.5 without one)",
                    m.at.0.display(),
                    m.at.1,
                    printable(&m.name)
                ));
                None
            }
        });
        m.texture = t.clone();
    }
    // usemtl names → materials (unknown ones: the default grey, with a warning).
    let of_usemtl: Vec<Option<usize>> = o
        .material_names
        .iter()
        .zip(&o.material_lines)
        .map(|(n, line)| {
            let i = mtls.iter().position(|m| &m.name == n);
            if i.is_none() {
                let why = if o.mtllibs.is_empty() {
                    "is used but no mtllib is given"
                } else {
                    "is in no material library"
                };
                diag.warn(format!(
                    "{}:{line}: material '{}' {why}: default grey 0.5",
                    path.display(),
                    printable(n)
                ));
            }
            i
        })
        .collect();
    for ob in &mut o.objects {
        for t in &mut ob.triangles {
            t.material = t.material.and_then(|u| of_usemtl[u]);
        }
    }
    Model {
        positions: o.positions,
        texcoords: o.texcoords,
        colours: o.colours,
        objects: o.objects,
        materials: mtls,
        format: "OBJ",
        degenerate: o.degenerate,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{colour_key, key_colour, linear_to_srgb, srgb_to_linear};

    #[test]
    fn one_warning_for_degenerate_triangles_and_an_error_for_none_left() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.obj");
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\nf 2 2 3\n").unwrap();
        let mut diag = Diagnostics::default();
        let m = load(&p, &mut diag).unwrap();
        assert_eq!((m.triangles(), m.degenerate), (1, 2));
        assert!(diag.errors.is_empty(), "{:?}", diag.errors);
        assert_eq!(diag.warnings.len(), 1, "{:?}", diag.warnings);
        assert!(diag.warnings[0].contains("2 triangle(s) repeat a vertex"));
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nf 1 1 2\n").unwrap();
        let mut diag = Diagnostics::default();
        load(&p, &mut diag).unwrap();
        assert_eq!(diag.errors.len(), 1);
        assert!(
            diag.errors[0].ends_with("no triangles"),
            "{:?}",
            diag.errors
        );
    }

    #[test]
    fn texels_footprints_and_colour_keys() {
        // 2 × 2: top row red, white; bottom row black, mid grey (sRGB 188 ≈ linear 0.5).
        let t = Texture::from_rgb8(
            "t".into(),
            2,
            2,
            vec![255, 0, 0, 255, 255, 255, 0, 0, 0, 188, 188, 188],
        )
        .unwrap();
        assert_eq!(t.texel(0.25, 0.75), [1.0, 0.0, 0.0]); // v up: the top row
        assert_eq!(t.texel(0.25, 0.25), [0.0; 3]);
        assert_eq!(t.texel(1.25, -0.75), [0.0; 3]); // repeats
        assert!((t.texel(0.75, 0.25)[0] - 0.5).abs() < 0.005);
        let avg = (1.0 + 1.0 + 0.0 + srgb_to_linear(188.0 / 255.0)) / 4.0;
        assert!((t.average[0] - avg).abs() < 1e-12);
        // A triangle inside the white texel sees white only.
        let f = t.footprint([[0.55, 0.55], [0.95, 0.55], [0.95, 0.95]]);
        assert_eq!(f, [1.0; 3]);
        // Keys: 6 bits of sRGB; the colour a key stands for is within one step.
        for c in [0.0, 0.003, 0.05, 0.18, 0.5, 0.93, 1.0] {
            let back = key_colour(colour_key([c; 3]))[0];
            assert!(
                (linear_to_srgb(back) - linear_to_srgb(c)).abs() <= 0.5 / 63.0 + 1e-12,
                "{c} → {back}"
            );
        }
        assert!(Texture::from_rgb8("e".into(), 0, 0, vec![]).is_err());
    }
}
