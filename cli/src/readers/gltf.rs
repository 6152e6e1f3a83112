//! glTF 2.0 (`.gltf` with its buffers and images, or `.glb`), with the `gltf` crate.
//!
//! The default scene (or the first) is walked from its root nodes; each node's mesh is
//! placed by the product of the node transforms (in f64; a mirroring transform keeps the
//! front faces by reversing the winding) and becomes an object named after the node (or
//! its mesh). Primitives in triangle, strip and fan modes are read; points and lines are
//! skipped with a warning. Materials (metallic-roughness):
//! - baseColorFactor × baseColorTexture (sRGB, averaged over each triangle's UV footprint)
//!   → the colour; roughness and metallic (their factors times the metallic-roughness
//!   texture's mean green and blue over its image, with a warning that their variation is
//!   left out) → a microfacet surface (`model::Gloss`, GGX α = roughness²): a metal (metallic ≥ 0.5) whose reflectance at normal incidence is the
//!   colour, or the colour under a dielectric coat of index 1.5 (4 % at normal incidence,
//!   glTF's dielectric); a smooth one (α < 0.01) is a mirror or a Lambertian surface;
//! - emissiveFactor × KHR_materials_emissive_strength × emissiveTexture (averaged over
//!   each triangle's UV footprint, like the base colour) → an emitting surface of that
//!   exitance, W/m² per band (as an MTL `Ke`); triangles whose texels are black emit
//!   nothing;
//! - a primitive without a material gets the default grey. Transparency (alpha,
//!   KHR_materials_transmission) is not read: make glass with `[materials.NAME]`.

use crate::diag::{printable, Diagnostics};
use crate::model::Mtl;
use crate::model::Object;
use crate::model::{push_triangle, Model, Texture};
use glam::{DMat4, DVec3};
use gltf::mesh::Mode;
use std::path::Path;
use std::sync::Arc;

/// Deepest node nesting followed (a cyclic file would otherwise never end).
const MAX_DEPTH: usize = 64;

/// Bytes per texel, and its RGB.
type TexelReader = (usize, fn(&[u8]) -> [u8; 3]);

fn rgb8(data: &gltf::image::Data) -> Option<Vec<u8>> {
    use gltf::image::Format::*;
    let p = &data.pixels;
    let (step, take): TexelReader = match data.format {
        R8 => (1, |c| [c[0]; 3]),
        R8G8 => (2, |c| [c[0]; 3]),
        R8G8B8 => (3, |c| [c[0], c[1], c[2]]),
        R8G8B8A8 => (4, |c| [c[0], c[1], c[2]]),
        // 16-bit channels, little-endian: the high byte.
        R16 => (2, |c| [c[1]; 3]),
        R16G16 => (4, |c| [c[1]; 3]),
        R16G16B16 => (6, |c| [c[1], c[3], c[5]]),
        R16G16B16A16 => (8, |c| [c[1], c[3], c[5]]),
        _ => return None,
    };
    Some(p.chunks_exact(step).flat_map(take).collect())
}

/// Whether a file that failed to load is glTF 1.0: a binary container of version 1, or
/// JSON whose asset.version starts with 1.
fn is_gltf1(b: &[u8]) -> bool {
    if b.starts_with(b"glTF") {
        return b.get(4..8) == Some(&1u32.to_le_bytes()[..]);
    }
    // glTF 1.0 has no required asset.version, but keeps its objects in maps by name where
    // 2.0 has arrays.
    serde_json::from_slice::<serde_json::Value>(b).is_ok_and(|v| {
        v.pointer("/asset/version")
            .and_then(|v| v.as_str())
            .is_some_and(|v| v.starts_with('1'))
            || ["accessors", "meshes", "nodes"]
                .iter()
                .any(|k| v.get(*k).is_some_and(|x| x.is_object()))
    })
}

/// Checks a binary container's sizes against the file: the header's total and each
/// chunk's length must fit what is there (a 50-byte file claiming 4 GiB is refused, not
/// allocated).
fn check_glb(b: &[u8]) -> Result<(), String> {
    if !b.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |at: usize| {
        b.get(at..at + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]) as usize)
    };
    let total = word(8).ok_or("a GLB file shorter than its 12-byte header")?;
    if total > b.len() {
        return Err(format!(
            "the GLB header says {total} bytes, but the file has {}",
            b.len()
        ));
    }
    let mut at = 12;
    while at + 8 <= total {
        let len = word(at).unwrap_or(0);
        if len > total - at - 8 {
            return Err(format!(
                "a GLB chunk at byte {at} claims {len} bytes, but only {} follow it",
                total - at - 8
            ));
        }
        at += 8 + len;
    }
    Ok(())
}

/// A file a glTF URI names (percent-decoded, relative to `base`); None for data URIs.
fn uri_path(base: &Path, uri: &str) -> Option<std::path::PathBuf> {
    if uri.starts_with("data:") {
        return None;
    }
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[i],
            b.get(i + 1).copied().and_then(hex),
            b.get(i + 2).copied().and_then(hex),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    Some(base.join(String::from_utf8_lossy(&out).as_ref()))
}

/// Checks that every file the document's buffers and images name is a regular file of a
/// readable size, before the `gltf` crate reads them (a URI naming `/dev/zero` would be
/// read until memory runs out).
fn check_uris(doc: &gltf::Document, base: &Path) -> Result<(), String> {
    let root = doc.as_json();
    let uris = root
        .buffers
        .iter()
        .filter_map(|b| b.uri.as_deref())
        .chain(root.images.iter().filter_map(|i| i.uri.as_deref()));
    for uri in uris {
        if let Some(p) = uri_path(base, uri) {
            crate::diag::check_input(&p)?;
        }
    }
    Ok(())
}

/// Checks every index and byte range the meshes read, so that the `gltf` crate's readers
/// (which panic on them) never meet a missing accessor, a stride shorter than its
/// element or a range past its buffer.
fn check_ranges(doc: &gltf::Document, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    use gltf::json::validation::Checked;
    let root = doc.as_json();
    let views = &root.buffer_views;
    for (i, v) in views.iter().enumerate() {
        let b = v.buffer.value();
        let have = buffers.get(b).map(|d| d.0.len() as u64).ok_or_else(|| {
            format!(
                "buffer view {i} names buffer {b}, but there are {}",
                buffers.len()
            )
        })?;
        let end = v
            .byte_offset
            .map_or(0, |o| o.0)
            .saturating_add(v.byte_length.0);
        if end > have {
            return Err(format!(
                "buffer view {i} ends at byte {end}, past its buffer's {have} bytes"
            ));
        }
    }
    let view_room =
        |i: usize, what: &str, view: usize, offset: u64, stride: u64, elem: u64, count: u64| {
            let v = views.get(view).ok_or_else(|| {
                format!(
                    "{what} {i} names buffer view {view}, but there are {}",
                    views.len()
                )
            })?;
            if count == 0 {
                return Ok(());
            }
            let need = offset
                .saturating_add(stride.saturating_mul(count - 1))
                .saturating_add(elem);
            if need > v.byte_length.0 {
                return Err(format!(
                    "{what} {i} reads {need} bytes of buffer view {view}, which has {}",
                    v.byte_length.0
                ));
            }
            Ok(())
        };
    for (i, a) in root.accessors.iter().enumerate() {
        let (Checked::Valid(ct), Checked::Valid(ty)) = (&a.component_type, &a.type_) else {
            return Err(format!(
                "accessor {i} has an unknown component type or type"
            ));
        };
        let elem = (ct.0.size() * ty.multiplicity()) as u64;
        if let Some(view) = a.buffer_view {
            let stride = views
                .get(view.value())
                .and_then(|v| v.byte_stride)
                .map_or(elem, |s| s.0 as u64);
            if stride < elem {
                return Err(format!(
                    "accessor {i}: buffer view {} has a byteStride of {stride}, below the {elem} bytes of one element",
                    view.value()
                ));
            }
            let offset = a.byte_offset.map_or(0, |o| o.0);
            view_room(i, "accessor", view.value(), offset, stride, elem, a.count.0)?;
        }
        if let Some(sp) = &a.sparse {
            let Checked::Valid(ict) = &sp.indices.component_type else {
                return Err(format!("accessor {i}: sparse indices of an unknown type"));
            };
            let isz = ict.0.size() as u64;
            let n = sp.count.0;
            view_room(
                i,
                "sparse accessor",
                sp.indices.buffer_view.value(),
                sp.indices.byte_offset.0,
                isz,
                isz,
                n,
            )?;
            view_room(
                i,
                "sparse accessor",
                sp.values.buffer_view.value(),
                sp.values.byte_offset.0,
                elem,
                elem,
                n,
            )?;
        }
    }
    let n_acc = root.accessors.len();
    for (mi, m) in root.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            let named = p
                .attributes
                .values()
                .map(|a| a.value())
                .chain(p.indices.map(|a| a.value()));
            for a in named {
                if a >= n_acc {
                    return Err(format!(
                        "mesh {mi} primitive {pi} names accessor {a}, but there are {n_acc}"
                    ));
                }
            }
            if let Some(m) = p.material {
                if m.value() >= root.materials.len() {
                    return Err(format!(
                        "mesh {mi} primitive {pi} names material {}, but there are {}",
                        m.value(),
                        root.materials.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Reads a glTF 2.0 model. Panics of the `gltf` crate on inputs its checks let through
/// become errors naming the file (after the checks above, none is known).
pub fn load(path: &Path, diag: &mut Diagnostics) -> Result<Model, String> {
    let name = printable(&path.display().to_string());
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| load_checked(path, diag)));
    std::panic::set_hook(previous);
    r.unwrap_or_else(|p| {
        let why = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!(
            "{name}: the glTF reader failed on this file ({}): it is malformed",
            printable(&why)
        ))
    })
}

fn load_checked(path: &Path, diag: &mut Diagnostics) -> Result<Model, String> {
    let name = printable(&path.display().to_string());
    let bytes = crate::diag::read_input(path)?;
    check_glb(&bytes).map_err(|e| format!("{name}: {e}"))?;
    let g = gltf::Gltf::from_slice(&bytes).map_err(|e| {
        if is_gltf1(&bytes) {
            format!("{name}: a glTF 1.0 file: imap reads glTF 2.0 (convert it, e.g. with gltf-pipeline or Blender)")
        } else {
            format!("{name}: {}", printable(&e.to_string()))
        }
    })?;
    drop(bytes);
    let base = path.parent().unwrap_or(Path::new("."));
    check_uris(&g.document, base)?;
    let buffers = gltf::import_buffers(&g.document, Some(base), g.blob.clone())
        .map_err(|e| format!("{name}: buffers: {}", printable(&e.to_string())))?;
    check_ranges(&g.document, &buffers).map_err(|e| format!("{name}: {}", printable(&e)))?;
    let doc = &g.document;
    let mut model = Model {
        format: "glTF",
        ..Default::default()
    };

    // Images are decoded when a material uses them; one that cannot be read is a warning.
    let mut images: Vec<Option<Option<Arc<Texture>>>> = vec![None; doc.images().count()];
    let mut texture_of = |img: gltf::Image, diag: &mut Diagnostics| -> Option<Arc<Texture>> {
        let i = img.index();
        images[i]
            .get_or_insert_with(|| {
                let label = format!("{name} image {i}");
                let got = gltf::image::Data::from_source(img.source(), Some(base), &buffers)
                    .map_err(|e| e.to_string())
                    .and_then(|d| {
                        let rgb = rgb8(&d).ok_or("unsupported pixel format")?;
                        Texture::from_rgb8(label.clone(), d.width, d.height, rgb)
                    });
                match got {
                    Ok(t) => Some(Arc::new(t)),
                    Err(e) => {
                        diag.warn(format!(
                            "{label} not read ({}): its materials use their base colour factor",
                            printable(&e)
                        ));
                        None
                    }
                }
            })
            .clone()
    };

    // The mean linear value of each channel of an image (a metallic-roughness texture's
    // data is linear, not sRGB), decoded once; None when it cannot be read.
    let mut means: Vec<Option<Option<[f64; 3]>>> = vec![None; doc.images().count()];
    let mut channel_means = |img: gltf::Image| -> Option<[f64; 3]> {
        let i = img.index();
        *means[i].get_or_insert_with(|| {
            let d = gltf::image::Data::from_source(img.source(), Some(base), &buffers).ok()?;
            let rgb = rgb8(&d)?;
            let n = (rgb.len() / 3).max(1) as f64;
            let mut sum = [0.0f64; 3];
            for p in rgb.chunks_exact(3) {
                for k in 0..3 {
                    sum[k] += p[k] as f64;
                }
            }
            Some(sum.map(|x| x / (255.0 * n)))
        })
    };

    // Materials, and the texture coordinate set each reads.
    let mut uv_set = Vec::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _a] = pbr.base_color_factor().map(|x| x as f64);
        let mut metal = (pbr.metallic_factor() as f64).clamp(0.0, 1.0);
        let mut rough = pbr.roughness_factor() as f64;
        // glTF's metallic-roughness texture multiplies the factors (roughness in its green
        // channel, metallic in its blue): read as its mean over the image. Without it, a
        // file that leaves the factors at their default 1 would be read as a rough metal.
        if let Some(t) = pbr.metallic_roughness_texture() {
            let label = m
                .name()
                .map(printable)
                .unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0)));
            match channel_means(t.texture().source()) {
                Some([_, g, b]) => {
                    rough *= g;
                    metal *= b;
                    diag.warn(format!(
                        "{name}: {label}: its metallic-roughness texture is read as its mean over the image (metallic {metal:.3}, roughness {rough:.3}): how they vary over the surface is left out"
                    ));
                }
                None => diag.warn(format!(
                    "{name}: {label}: its metallic-roughness texture could not be read: metallic {metal}, roughness {rough} from the factors alone"
                )),
            }
        }
        let texture = pbr
            .base_color_texture()
            .and_then(|t| texture_of(t.texture().source(), diag));
        let emission_texture = m
            .emissive_texture()
            .and_then(|t| texture_of(t.texture().source(), diag));
        // One set of texture coordinates is read per primitive: the base colour's, else the
        // emission's.
        let set = match (pbr.base_color_texture(), m.emissive_texture()) {
            (Some(b), Some(e)) if b.tex_coord() != e.tex_coord() => {
                diag.warn(format!(
                    "{name}: material {}: its emission texture uses texture coordinates {} and its base colour {}: both are read with set {}",
                    m.index().unwrap_or(0),
                    e.tex_coord(),
                    b.tex_coord(),
                    b.tex_coord()
                ));
                b.tex_coord()
            }
            (Some(b), _) => b.tex_coord(),
            (None, Some(e)) => e.tex_coord(),
            (None, None) => 0,
        };
        uv_set.push(set);
        let base = [r, g, b];
        let gloss = crate::model::Gloss {
            alpha: rough.clamp(0.0, 1.0).powi(2),
            metallic: metal,
        };
        // A smooth one (α < 0.01): its metallic share a mirror, the rest diffuse.
        let mirror = if gloss.alpha < 0.01 { metal } else { 0.0 };
        let strength = m.emissive_strength().unwrap_or(1.0) as f64;
        let ke = m.emissive_factor().map(|x| x as f64 * strength);
        let label = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material{}", m.index().unwrap_or(0)));
        model.materials.push(Mtl {
            name: label,
            at: (path.to_path_buf(), 0),
            kd: Some(base.map(|c| c * (1.0 - mirror))),
            ks: (mirror > 0.0).then(|| base.map(|c| c * mirror)),
            ke: ke.iter().any(|&x| x > 0.0).then_some(ke),
            gloss: Some(gloss),
            texture,
            emission_texture,
            ..Default::default()
        });
    }

    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| format!("{name}: no scene"))?;
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    stack.reverse();
    let mut skipped_modes = 0usize;
    let mut too_deep = false;
    // glTF nodes form trees: a node reached a second time (a file that gives it two
    // parents, or a cycle) is not walked again, so no graph costs more than its nodes.
    let mut visited = vec![false; doc.nodes().count()];
    let mut shared = 0usize;
    while let Some((node, parent, depth)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            shared += 1;
            continue;
        }
        let local =
            DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(|x| x as f64)));
        let world = parent * local;
        if depth >= MAX_DEPTH {
            too_deep = true;
            continue;
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
        let Some(mesh) = node.mesh() else { continue };
        let mirrored = world.determinant() < 0.0;
        let oname = node
            .name()
            .or(mesh.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("node{}", node.index()));
        let mut object = Object {
            name: oname,
            triangles: Vec::new(),
        };
        for prim in mesh.primitives() {
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(pos) = reader.read_positions() else {
                continue;
            };
            let first = model.positions.len() as u32;
            for p in pos {
                let w = world.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                model.positions.push(w.to_array());
            }
            let count = model.positions.len() as u32 - first;
            let material = prim.material().index();
            let set = material.map_or(0, |m| uv_set[m]);
            let uv_first = model.texcoords.len() as u32;
            let has_uv = match reader.read_tex_coords(set) {
                Some(tc) => {
                    let before = model.texcoords.len();
                    // glTF's v points down the image: flipped to the OBJ convention.
                    model
                        .texcoords
                        .extend(tc.into_f32().map(|[u, v]| [u as f64, 1.0 - v as f64]));
                    model.texcoords.len() - before == count as usize
                }
                None => false,
            };
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..count).collect(),
            };
            if let Some(&bad) = idx.iter().find(|&&i| i >= count) {
                diag.error(
                    path,
                    0,
                    format!(
                        "mesh '{}': index {bad} is beyond its {count} vertices",
                        printable(&object.name)
                    ),
                );
                continue;
            }
            let tris: Vec<[u32; 3]> = match prim.mode() {
                Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
                Mode::TriangleStrip => (2..idx.len())
                    .map(|k| {
                        if k % 2 == 0 {
                            [idx[k - 2], idx[k - 1], idx[k]]
                        } else {
                            [idx[k - 1], idx[k - 2], idx[k]]
                        }
                    })
                    .collect(),
                Mode::TriangleFan => (2..idx.len())
                    .map(|k| [idx[0], idx[k - 1], idx[k]])
                    .collect(),
                _ => {
                    skipped_modes += 1;
                    continue;
                }
            };
            for t in tris {
                let t = if mirrored { [t[0], t[2], t[1]] } else { t };
                push_triangle(
                    &mut object.triangles,
                    &mut model.degenerate,
                    t.map(|i| first + i),
                    has_uv.then(|| t.map(|i| uv_first + i)),
                    material,
                );
            }
        }
        if !object.triangles.is_empty() {
            model.objects.push(object);
        }
    }
    if skipped_modes > 0 {
        diag.warn(format!(
            "{name}: {skipped_modes} primitive(s) of points or lines skipped (libimap needs surfaces)"
        ));
    }
    if shared > 0 {
        diag.warn(format!(
            "{name}: {shared} node reference(s) to a node already placed (glTF nodes form trees) were not followed"
        ));
    }
    if too_deep {
        diag.warn(format!(
            "{name}: nodes nested deeper than {MAX_DEPTH} (a cycle?) were not followed"
        ));
    }
    if model.objects.is_empty() && !diag.has_errors() {
        let why = if skipped_modes > 0 {
            format!(" ({skipped_modes} primitive(s) of points or lines: libimap needs surfaces)")
        } else {
            String::new()
        };
        return Err(format!("{name}: the scene has no triangles{why}"));
    }
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle whose material leaves metallic and roughness at their default factors
    /// (1) and gives a metallic-roughness texture of roughness 0.5, metallic 0 (green 128,
    /// blue 0): a rough dielectric-coated surface, α = 0.502², not a rough metal; without
    /// the texture, the factors alone; an unreadable image, the factors with a warning.
    #[test]
    fn the_metallic_roughness_texture_scales_the_factors() {
        let d = tempfile::tempdir().unwrap();
        let pos: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let bin: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(d.path().join("m.bin"), &bin).unwrap();
        let img = image::RgbImage::from_pixel(2, 2, image::Rgb([255, 128, 0]));
        img.save(d.path().join("mr.png")).unwrap();
        let gltf = |pbr: serde_json::Value, image: &str| {
            serde_json::json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": [0]}],
                "nodes": [{"mesh": 0, "name": "tri"}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
                "materials": [{"pbrMetallicRoughness": pbr}],
                "images": [{"uri": image}],
                "textures": [{"source": 0}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
                "bufferViews": [{"buffer": 0, "byteLength": 36}],
                "buffers": [{"byteLength": 36, "uri": "m.bin"}]
            })
            .to_string()
        };
        let read = |text: String| {
            let path = d.path().join("m.gltf");
            std::fs::write(&path, text).unwrap();
            let mut diag = Diagnostics::default();
            let m = load(&path, &mut diag).unwrap();
            (m.materials[0].gloss.unwrap(), diag)
        };
        let textured = serde_json::json!({"metallicRoughnessTexture": {"index": 0}});
        let (g, diag) = read(gltf(textured.clone(), "mr.png"));
        assert_eq!(g.metallic, 0.0);
        assert!((g.alpha - (128.0f64 / 255.0).powi(2)).abs() < 1e-6, "{g:?}");
        assert!(
            diag.warnings
                .iter()
                .any(|w| w.contains("mean over the image")),
            "{:?}",
            diag.warnings
        );
        let (g, _) = read(gltf(serde_json::json!({}), "mr.png"));
        assert_eq!((g.metallic, g.alpha), (1.0, 1.0));
        std::fs::write(d.path().join("junk.png"), b"not an image").unwrap();
        let (g, diag) = read(gltf(textured, "junk.png"));
        assert_eq!((g.metallic, g.alpha), (1.0, 1.0));
        assert!(
            diag.warnings
                .iter()
                .any(|w| w.contains("could not be read")),
            "{:?}",
            diag.warnings
        );
    }
}
