//! Real-world inputs through the `imap` command: each reading heuristic with its
//! own test, the other model formats (glTF, PLY, STL), the default camera of a Z-up model,
//! and `imap render`.

mod common;

use common::{imap, run_photons, stderr, write};

use std::path::Path;

/// A point light of 10 W per band half a metre above the floor's centre, seed fixed.
const LIGHT: &str =
    "[run]\nseed = 5\n[[light]]\nkind = \"point\"\nposition = [0.0, 0.0, 0.5]\npower = 10\n";

/// Runs `model` with `settings` for 200 000 photons on 2 threads; returns the report and
/// stderr.
fn run(dir: &Path, model: &str, settings: &str, tag: &str) -> (serde_json::Value, String) {
    let toml = write(dir, &format!("{tag}.toml"), settings);
    let out = dir.join(format!("out-{tag}"));
    let o = run_photons(model, &toml, &out, 200_000);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (report, stderr(&o))
}

fn absorbed(r: &serde_json::Value) -> f64 {
    r["energy_w"]["absorbed"].as_f64().unwrap()
}

/// A floor [−1, 1]² at z = 0 (normals +z) of n × n cells with texture coordinates; the
/// material of each triangle from `material(i, j)` (cell column and row); `header` first.
fn floor_obj(n: usize, header: &str, material: impl Fn(usize, usize) -> &'static str) -> String {
    let mut s = header.to_string();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            s += &format!("v {} {} 0\nvt {u} {v}\n", 2.0 * u - 1.0, 2.0 * v - 1.0);
        }
    }
    s += "o floor\n";
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 2, a + n + 1);
            s += &format!(
                "usemtl {}\nf {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}\n",
                material(i, j)
            );
        }
    }
    s
}

/// `Kd + Ks > 1` (every 3ds Max and assimp export): scaled to conserve energy, one warning
/// for the material however many triangles use it. A floor alone under a light then
/// reflects everything it receives: nothing is absorbed.
#[test]
fn kd_plus_ks_over_one_is_scaled_with_one_warning() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "m.mtl",
        "newmtl shiny\nKd 0.7 0.7 0.7\nKs 0.4 0.4 0.4\n",
    );
    let obj = write(
        d.path(),
        "f.obj",
        floor_obj(4, "mtllib m.mtl\n", |_, _| "shiny"),
    );
    let (r, err) = run(d.path(), &obj, LIGHT, "kdks");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("Kd + Ks")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(
        warnings[0].contains("m.mtl:1") && warnings[0].contains("0.9091"),
        "{err}"
    );
    assert!(absorbed(&r).abs() < 1e-12, "{}", absorbed(&r));
    assert!(r["energy_w"]["escaped"].as_f64().unwrap() > 0.0);
}

/// `Ni 1` with `d 0` (an exporter's "nothing in particular"): opaque, as the Kd says, with a
/// warning, never index-1 glass; and the settings override any property of the file.
#[test]
fn transparency_heuristic_and_settings_overrides() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "m.mtl",
        "newmtl teapot\nKd 0.8 0.8 0.8\nNi 1\nd 0\n",
    );
    let obj = write(
        d.path(),
        "f.obj",
        floor_obj(4, "mtllib m.mtl\n", |_, _| "teapot"),
    );
    let (opaque, err) = run(d.path(), &obj, LIGHT, "opaque");
    assert!(err.contains("read as opaque"), "{err}");
    let (grey, _) = run(
        d.path(),
        &obj,
        &format!("{LIGHT}[materials.teapot]\ndiffuse = 0.3\n"),
        "override",
    );
    // The same photons reach the floor: absorbed ∝ 1 − ρ.
    let ratio = absorbed(&grey) / absorbed(&opaque);
    assert!((ratio / 3.5 - 1.0).abs() < 0.05, "{ratio}");
    // Glass on request: a clear slab surface absorbs nothing.
    let (glass, _) = run(
        d.path(),
        &obj,
        &format!("{LIGHT}[materials.teapot]\ndielectric = true\nior = 1.5\n"),
        "glass",
    );
    assert!(absorbed(&glass).abs() < 1e-12, "{}", absorbed(&glass));
}

/// `map_Kd`: the texture's colour over each triangle's UV footprint (multiplied by Kd when
/// there is one). A floor textured black on its left half and white on its right absorbs
/// exactly what the same floor with black and white materials absorbs.
#[test]
fn map_kd_textures_colour_each_triangle() {
    let d = tempfile::tempdir().unwrap();
    let mut img = image::RgbImage::new(8, 8);
    for (x, _, p) in img.enumerate_pixels_mut() {
        *p = image::Rgb(if x < 4 { [0, 0, 0] } else { [255, 255, 255] });
    }
    img.save(d.path().join("half.png")).unwrap();
    write(d.path(), "t.mtl", "newmtl tex\nmap_Kd -s 1 1 1 half.png\n");
    let textured = write(
        d.path(),
        "t.obj",
        floor_obj(4, "mtllib t.mtl\n", |_, _| "tex"),
    );
    write(
        d.path(),
        "p.mtl",
        "newmtl black\nKd 0\nnewmtl white\nKd 1\n",
    );
    let plain = write(
        d.path(),
        "p.obj",
        floor_obj(
            4,
            "mtllib p.mtl\n",
            |i, _| if i < 2 { "black" } else { "white" },
        ),
    );
    let (a, err) = run(d.path(), &textured, LIGHT, "textured");
    assert!(!err.contains("no Kd"), "{err}");
    let (b, _) = run(d.path(), &plain, LIGHT, "plain");
    assert!(absorbed(&a) > 0.0);
    assert!(
        (absorbed(&a) - absorbed(&b)).abs() <= 1e-12 * absorbed(&b),
        "{} vs {}",
        absorbed(&a),
        absorbed(&b)
    );
    // A texture that cannot be read: a warning, and the material's Kd.
    write(
        d.path(),
        "m.mtl",
        "newmtl tex\nKd 0.5\nmap_Kd missing.png\n",
    );
    let missing = write(
        d.path(),
        "m.obj",
        floor_obj(2, "mtllib m.mtl\n", |_, _| "tex"),
    );
    let (_, err) = run(d.path(), &missing, LIGHT, "missing");
    assert!(
        err.contains("missing.png") && err.contains("uses its Kd"),
        "{err}"
    );
}

/// Coordinates far from the origin keep every digit (f64), the CSV keeps the file's vertex
/// order and numbering, emitters are not recorded by default, degenerate triangles are
/// left out with a count, and Latin-1 material names resolve.
#[test]
fn precision_order_emitters_degenerates_and_latin1() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "m.mtl",
        b"newmtl caf\xe9\nKd 0.5\nnewmtl lamp\nKd 0\nKe 20\n".as_slice(),
    );
    let x0 = 5_000_000.25;
    let mut obj = b"mtllib m.mtl\n".to_vec();
    // The lamp's vertices come first in the file, the floor's after them, in an order
    // that is not the triangles' order.
    for (x, y) in [(-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1)] {
        obj.extend(format!("v {} {} 0.5\n", x0 + x, 1.0 + y).bytes());
    }
    let floor = [(1.0, 1.0), (-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0)];
    for (x, y) in floor {
        obj.extend(format!("v {} {} 0\n", x0 + x, 1.0 + y).bytes());
    }
    obj.extend(b"o lamp\nusemtl lamp\nf 1 4 3\nf 1 3 2\n");
    obj.extend(b"o floor\nusemtl caf\xe9\nf 6 7 5\nf 6 5 8\nf 5 5 6\n");
    let model = write(d.path(), "s.obj", obj);
    let out = d.path().join("out-p");
    let o = imap(&[
        "run",
        &model,
        "--photons",
        "20000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("1 triangle(s) repeat a vertex"), "{err}");
    assert!(
        !err.contains("default grey"),
        "Latin-1 name not resolved: {err}"
    );
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // Only the floor (the lamp emits: not recorded unless named), in file order 5..8.
    let vertex: Vec<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(vertex, ["5", "6", "7", "8"], "{csv}");
    for (r, (x, y)) in rows.iter().zip(floor) {
        assert_eq!(r[2].parse::<f64>().unwrap(), x0 + x);
        assert_eq!(r[3].parse::<f64>().unwrap(), 1.0 + y);
    }
    // The floor sees the lamp.
    assert!(rows
        .iter()
        .all(|r| r[r.len() - 1].parse::<f64>().unwrap() > 0.0));
}

/// Every problem of a file at once, each with its line.
#[test]
fn every_error_of_a_file_is_reported_at_once() {
    let d = tempfile::tempdir().unwrap();
    let obj = write(
        d.path(),
        "bad.obj",
        "v 0 0 0\nv 1 y 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\nvt q\nf 1 2\n",
    );
    let o = imap(&["run", &obj, "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    for line in [2, 5, 6, 7] {
        assert!(err.contains(&format!("bad.obj:{line}:")), "{line}: {err}");
    }
}

/// The fraction of a picture's pixels that are not the background.
fn covered(png: &Path) -> f64 {
    let img = image::open(png).unwrap().to_rgb8();
    let bg = image::Rgb([24u8, 24, 28]);
    img.pixels().filter(|p| **p != bg).count() as f64 / img.pixels().count() as f64
}

/// A Z-up model lit from above: with `up_axis = "z"` the default camera frames it from the
/// lit side; the view shows the whole floor, with its top up.
#[test]
fn z_up_models_get_a_camera_that_frames_them() {
    let d = tempfile::tempdir().unwrap();
    let obj = write(d.path(), "z.obj", floor_obj(8, "", |_, _| "none"));
    let settings = format!("up_axis = \"z\"\n{LIGHT}");
    let (r, _) = run(d.path(), &obj, &settings, "z");
    let cover = covered(&d.path().join("out-z/view.png"));
    assert!(cover > 0.15, "the floor fills {cover} of the view");
    // Lit: the view's colour scale is not empty.
    assert!(r["meshes"][0]["illuminance_lx"]["max"].as_f64().unwrap() > 0.0);
    let bad = write(d.path(), "bad.toml", "up_axis = \"w\"\n");
    let o = imap(&["run", &obj, "--config", &bad, "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("up_axis"), "{}", stderr(&o));
}

/// A glTF 2.0 file with an external buffer: node transforms (translation and scale) place
/// the floor, baseColorFactor is its reflectance, an emissive material makes a lamp of
/// that exitance.
#[test]
fn gltf_nodes_materials_and_emission() {
    let d = tempfile::tempdir().unwrap();
    // Two quads: a floor [−1, 1]² at y = 0 facing +y, and a lamp 0.2 × 0.2 facing −y.
    let floor = [
        [-1.0f32, 0., -1.],
        [-1., 0., 1.],
        [1., 0., 1.],
        [1., 0., -1.],
    ];
    let lamp = [
        [-0.1f32, 0., -0.1],
        [0.1, 0., -0.1],
        [0.1, 0., 0.1],
        [-0.1, 0., 0.1],
    ];
    let mut bin = Vec::new();
    for p in floor.iter().chain(&lamp) {
        for x in p {
            bin.extend(x.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    write(d.path(), "data.bin", &bin);
    let json = r#"{
      "asset": {"version": "2.0"},
      "scene": 0,
      "scenes": [{"nodes": [0, 1]}],
      "nodes": [
        {"name": "floor", "mesh": 0, "translation": [10, 0, 0], "scale": [2, 1, 2]},
        {"name": "lamp", "mesh": 1, "translation": [10, 1, 0]}
      ],
      "meshes": [
        {"primitives": [{"attributes": {"POSITION": 0}, "indices": 2, "material": 0}]},
        {"primitives": [{"attributes": {"POSITION": 1}, "indices": 2, "material": 1}]}
      ],
      "materials": [
        {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.4, 0.4, 1], "metallicFactor": 0}},
        {"name": "glow", "emissiveFactor": [1, 1, 1],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 50}},
         "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}
      ],
      "extensionsUsed": ["KHR_materials_emissive_strength"],
      "buffers": [{"uri": "data.bin", "byteLength": 108}],
      "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 48},
        {"buffer": 0, "byteOffset": 48, "byteLength": 48},
        {"buffer": 0, "byteOffset": 96, "byteLength": 12}
      ],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.1, 0, -0.1], "max": [0.1, 0, 0.1]},
        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
      ]
    }"#;
    let model = write(d.path(), "scene.gltf", json);
    let (r, err) = run(d.path(), &model, "[run]\nseed = 3\n", "gltf");
    assert!(!err.contains("error"), "{err}");
    assert_eq!(r["model"]["format"], "glTF");
    let meshes = r["meshes"].as_array().unwrap();
    assert_eq!(meshes.len(), 2);
    assert_eq!(meshes[1]["emitting"], true);
    assert_eq!(meshes[1]["recorded"], false);
    // 50 W/m² per band from 0.04 m², 3 bands.
    let emitted = r["energy_w"]["emitted"].as_f64().unwrap();
    // (0.1 is an f32 in the file.)
    assert!(
        (emitted / (3.0 * 50.0 * 0.04) - 1.0).abs() < 1e-6,
        "{emitted}"
    );
    // Placed by the node: x in [8, 12], z in [−2, 2].
    let csv = std::fs::read_to_string(d.path().join("out-gltf/irradiance.csv")).unwrap();
    let xs: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(xs.len(), 4);
    assert!(xs.iter().all(|&x| x == 8.0 || x == 12.0), "{xs:?}");
    // The floor (ρ = 0.4) absorbs 60 % of what reaches it; the lamp (black) all that
    // comes back to it: absorbed/escaped is that of ρ = 0.4.
    let esc = r["energy_w"]["escaped"].as_f64().unwrap();
    let ab = absorbed(&r);
    assert!((ab + esc - emitted).abs() < 1e-9 * emitted);
    assert!(
        ab / emitted > 0.3 && ab / emitted < 0.65,
        "{}",
        ab / emitted
    );
}

/// PLY with vertex colours and binary STL through the command: they load, run and light.
#[test]
fn ply_vertex_colours_and_stl() {
    let d = tempfile::tempdir().unwrap();
    // A floor of two triangles, its vertices black: it absorbs everything.
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n-1 -1 0 0 0 0\n1 -1 0 0 0 0\n1 1 0 0 0 0\n-1 1 0 0 0 0\n4 0 1 2 3\n";
    let model = write(d.path(), "f.ply", ply);
    let (r, _) = run(d.path(), &model, LIGHT, "ply");
    assert_eq!(r["model"]["format"], "PLY");
    let esc = r["energy_w"]["escaped"].as_f64().unwrap();
    let emitted = r["energy_w"]["emitted"].as_f64().unwrap();
    // Black: what reaches the floor is absorbed, the rest escapes. The floor subtends
    // 4·asin(0.8) sr of the light's 4π: 29.52 % of its flux.
    let share = 4.0 * 0.8f64.asin() / (4.0 * std::f64::consts::PI);
    assert!(
        (absorbed(&r) / emitted - share).abs() < 0.01,
        "{}",
        absorbed(&r) / emitted
    );
    assert!((esc + absorbed(&r) - emitted).abs() < 1e-9 * emitted);
    let grey_esc = {
        let ply = ply.replace(" 0 0 0\n", " 188 188 188\n");
        let m = write(d.path(), "g.ply", ply);
        let (g, _) = run(d.path(), &m, LIGHT, "plyg");
        g["energy_w"]["escaped"].as_f64().unwrap()
    };
    assert!(grey_esc > esc * 1.1, "{grey_esc} vs {esc}");
    // Binary STL: 80-byte header, count, two triangles of the same floor.
    let mut stl = vec![0u8; 80];
    stl.extend(2u32.to_le_bytes());
    for t in [
        [[-1f32, -1., 0.], [1., -1., 0.], [1., 1., 0.]],
        [[-1., -1., 0.], [1., 1., 0.], [-1., 1., 0.]],
    ] {
        stl.extend([0f32, 0., 1.].iter().flat_map(|x| x.to_le_bytes()));
        stl.extend(t.iter().flatten().flat_map(|x| x.to_le_bytes()));
        stl.extend([0, 0]);
    }
    let model = write(d.path(), "f.stl", &stl);
    let (r, _) = run(d.path(), &model, LIGHT, "stl");
    assert_eq!(r["model"]["format"], "STL");
    assert_eq!(r["meshes"][0]["vertices"], 4); // merged by position
    assert!(r["meshes"][0]["illuminance_lx"]["max"].as_f64().unwrap() > 0.0);
    // Unknown formats are named.
    let o = imap(&["run", &write(d.path(), "x.fbx", "x"), "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains(".gltf"), "{}", stderr(&o));
}

/// The mean green radiance of a 33 × 33 render's 3 × 3 centre pixels (the PFM's rows run
/// from the bottom: the centre is the centre either way) and the sum of their relative
/// errors.
fn centre_green(px: &[f32], err: &[f32], w: usize) -> (f64, f64) {
    let (mut sum, mut rel) = (0.0, 0.0);
    for y in 15..18 {
        for x in 15..18 {
            sum += px[3 * (y * w + x) + 1] as f64;
            rel += err[y * w + x] as f64;
        }
    }
    (sum / 9.0, rel)
}

fn read_pfm(path: &Path) -> (usize, usize, usize, Vec<f32>) {
    let b = std::fs::read(path).unwrap();
    let mut lines = b.splitn(4, |&c| c == b'\n');
    let tag = lines.next().unwrap();
    let dims = String::from_utf8(lines.next().unwrap().to_vec()).unwrap();
    let scale: f64 = String::from_utf8(lines.next().unwrap().to_vec())
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(scale < 0.0, "little-endian");
    let mut it = dims.split_whitespace().map(|x| x.parse::<usize>().unwrap());
    let (w, h) = (it.next().unwrap(), it.next().unwrap());
    let c = if tag == b"PF" { 3 } else { 1 };
    let data: Vec<f32> = lines
        .next()
        .unwrap()
        .chunks_exact(4)
        .map(|x| f32::from_le_bytes([x[0], x[1], x[2], x[3]]))
        .collect();
    assert_eq!(data.len(), w * h * c);
    (w, h, c, data)
}

/// `imap render`: a camera straight above a grey floor lit by a point light sees, at the
/// centre, L = ρE/π with E = I/h² (the floor alone: no interreflection); every output is
/// written, the history is in render.json.
#[test]
fn render_writes_png_pfm_and_history_with_the_right_radiance() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "m.mtl", "newmtl grey\nKd 0.5\n");
    let obj = write(
        d.path(),
        "f.obj",
        floor_obj(8, "mtllib m.mtl\n", |_, _| "grey"),
    );
    let settings = "up_axis = \"z\"\n[[light]]\nkind = \"point\"\nposition = [0.0, 0.0, 1.0]\npower = 10\n[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_deg = 40\n[render]\nmethod = \"synchronous\"\n";
    let toml = write(d.path(), "r.toml", settings);
    // 33 × 33 pixels, 256 passes, 2 threads, seed 1, into `out`.
    let render_to = |config: &str, out: &Path| {
        imap(&[
            "render",
            &obj,
            "--config",
            config,
            "--size",
            "33x33",
            "--passes",
            "256",
            "--threads",
            "2",
            "--seed",
            "1",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let out = d.path().join("render");
    let o = render_to(&toml, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "render.png",
        "radiance.pfm",
        "rel_error.pfm",
        "convergence.png",
        "render.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let (w, h, c, px) = read_pfm(&out.join("radiance.pfm"));
    assert_eq!((w, h, c), (33, 33, 3));
    let (_, _, c1, err) = read_pfm(&out.join("rel_error.pfm"));
    assert_eq!(c1, 1);
    let (got, rel) = centre_green(&px, &err, w);
    let expected = 0.5 * 10.0 / (4.0 * std::f64::consts::PI) / std::f64::consts::PI;
    let sigma = expected * rel / 9.0 / 3.0; // the mean of 9 pixels' errors, ~independent
    assert!(
        (got / expected - 1.0).abs() < 0.05 + 4.0 * sigma / expected,
        "{got} vs {expected} (σ {sigma})"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("render.json")).unwrap()).unwrap();
    assert_eq!(report["method"], "Synchronous");
    assert!(!report["history"].as_array().unwrap().is_empty());
    // Final gathering (the default without a [render] method): the same floor, and the
    // map it ran is in the report.
    let plain = write(
        d.path(),
        "fg.toml",
        settings.replace("method = \"synchronous\"\n", ""),
    );
    let fg = d.path().join("fg");
    let o = render_to(&plain, &fg);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fg.join("render.json")).unwrap()).unwrap();
    assert_eq!(report["method"], "FinalGather");
    assert!(report["map_photons"].as_u64().unwrap() > 0);
    let (w, _, _, px) = read_pfm(&fg.join("radiance.pfm"));
    let (_, _, _, err) = read_pfm(&fg.join("rel_error.pfm"));
    let (got, rel) = centre_green(&px, &err, w);
    let sigma = expected * rel / 9.0 / 3.0;
    assert!(
        (got / expected - 1.0).abs() < 0.02 + 4.0 * sigma / expected,
        "final gathering: {got} vs {expected} (σ {sigma})"
    );
    // In haze absorbing 0.5 per metre ([medium]) the centre sees e^(−0.5 (1 + R)) of it:
    // the light's metre to the floor, and the camera's ray from where it enters the haze's
    // ball (radius R = 1.01 √2 about the floor's centre: the camera is outside it).
    let hazy = write(
        d.path(),
        "haze.toml",
        format!("{settings}[medium]\nabsorption_per_m = 0.5\n"),
    );
    let out = d.path().join("haze");
    let o = render_to(&hazy, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let (w, _, _, px) = read_pfm(&out.join("radiance.pfm"));
    let (_, _, _, err) = read_pfm(&out.join("rel_error.pfm"));
    let (got, rel) = centre_green(&px, &err, w);
    let want = expected * (-0.5 * (1.0 + 1.01 * 2f64.sqrt())).exp();
    let sigma = want * rel / 9.0 / 3.0;
    assert!(
        (got / want - 1.0).abs() < 0.05 + 4.0 * sigma / want,
        "haze: {got} vs {want} (σ {sigma})"
    );
    // A bad method and size are named.
    let o = imap(&["render", &obj, "--config", &toml, "--method", "fast"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("fast"));
    let o = imap(&["render", &obj, "--size", "12"]);
    assert_ne!(o.status.code(), Some(0));
}
