//! A lighting engineer's day through the `imap` command, on the kinds of models nobody here
//! made: walls written as one polygon around their windows, grids that meet outside walls,
//! meshes wound inside out, emissive textures, skies seen by the camera, region targets and
//! progress that must not claim what they do not know. Each test fails on a model that
//! gave a wrong number without a warning.

mod common;

use common::{imap, run_photons, stderr, write};
use std::path::Path;

/// A 4 × 4 × 3 m room (Z up) whose front wall (y = 0) is one polygon going round a
/// window (x 1–3 m, z 1–2 m) and back along a seam, as building exporters write it; the
/// other surfaces are quads. Grey 0.5 everywhere.
fn room(dir: &Path) -> String {
    write(dir, "room.mtl", "newmtl wall\nKd 0.5 0.5 0.5\n");
    write(
        dir,
        "room.obj",
        "mtllib room.mtl\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv 0 0 3\nv 4 0 3\nv 4 4 3\nv 0 4 3\n\
         v 1 0 1\nv 3 0 1\nv 3 0 2\nv 1 0 2\nusemtl wall\no floor\nf 1 2 3 4\no ceiling\nf 5 8 7 6\n\
         o back\nf 4 3 7 8\no left\nf 1 4 8 5\no right\nf 2 6 7 3\no front\nf 1 5 6 2 1 9 10 11 12 9\n",
    )
}

/// A point light outside the window, and settings for the room.
const OUTSIDE: &str = "up_axis = \"z\"\nrecord = [\"floor\"]\n[run]\nseed = 1\n\
    [[light]]\nkind = \"point\"\nposition = [2, -2, 1.5]\npower = 100\n";

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// A concave wall is cut by ear clipping, not a fan: the window stays open and light
/// through it reaches the floor (a fan from the first corner covered the window: the floor
/// read 0 lx).
#[test]
fn walls_around_windows_keep_their_windows_open() {
    let d = tempfile::tempdir().unwrap();
    let obj = room(d.path());
    let toml = write(d.path(), "s.toml", OUTSIDE);
    let out = d.path().join("out");
    let o = run_photons(&obj, &toml, &out, 300_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let floor = r["meshes"][0]["illuminance_lx"]["mean"].as_f64().unwrap();
    assert!(floor > 10.0, "the floor reads {floor} lx");
    // A warped or self-crossing face is said, with its line.
    let warped = write(
        d.path(),
        "warped.obj",
        "mtllib room.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0.3\nv 0 1 0\nv 2 0 0\nv 3 1 0\nv 3 0 0\nv 2 1 0\n\
         usemtl wall\no a\nf 1 2 3 4\no b\nf 5 6 7 8\n",
    );
    let o = imap(&["info", &warped]);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let w = info["warnings"].to_string();
    assert!(w.contains("warped.obj:12") && w.contains("not flat"), "{w}");
    assert!(
        w.contains("warped.obj:14") && w.contains("cross themselves"),
        "{w}"
    );
}

/// A grid that meets an outside wall: its guard ring stops at the wall, so the edge
/// points read the light on their side of it. Here the window's direct light falls on the
/// 0.8 m plane only from y = 0.8 m on: the edge row (y = 0.25 m) gets reflected light
/// alone, less than the row next in (a ring outside the wall read the lamp directly, and
/// edge points 820–960 lx beside inner ones of 150–215 in a real building).
#[test]
fn grid_edges_read_only_their_side_of_the_wall() {
    let d = tempfile::tempdir().unwrap();
    let obj = room(d.path());
    let toml = write(
        d.path(),
        "g.toml",
        format!(
            "{OUTSIDE}[[grid]]\nname = \"plane\"\norigin = [0, 0, 0.8]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [4, 4]\nspacing = 0.5\n"
        ),
    );
    let out = d.path().join("out");
    let o = run_photons(&obj, &toml, &out, 1_000_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("grid_plane.csv")).unwrap();
    let rows: Vec<(usize, usize, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].parse().unwrap(),
                f[1].parse().unwrap(),
                f[5].parse().unwrap(),
            )
        })
        .collect();
    let row = |j: usize| -> Vec<f64> { rows.iter().filter(|r| r.1 == j).map(|r| r.2).collect() };
    let (edge, next) = (row(0), row(2));
    for i in 0..8 {
        assert!(
            edge[i] < next[i],
            "point {i} of the edge row reads {} lx, the row inside {} lx",
            edge[i],
            next[i]
        );
    }
    let r = report(&out);
    assert!(
        r["grids"][0]["guard_vertices_at_surfaces"]
            .as_u64()
            .unwrap()
            >= 10
    );
}

/// A closed cube wound inside out (its normals point inward), lit from outside.
fn inward_cube(dir: &Path) -> String {
    write(dir, "c.mtl", "newmtl grey\nKd 0.5 0.5 0.5\n");
    // Outward winding of a unit cube, then each face reversed.
    let faces = [
        [1, 4, 3, 2],
        [5, 6, 7, 8],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 4, 8, 7],
        [4, 1, 5, 8],
    ];
    let mut s = String::from(
        "mtllib c.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nusemtl grey\no cube\n",
    );
    for f in faces {
        s += &format!("f {} {} {} {}\n", f[3], f[2], f[1], f[0]);
    }
    write(dir, "cube.obj", s)
}

/// A mesh wound inside out is found and said, before and after the run, with its numbers,
/// and `flip_normals` mends it (the Stanford bunny's map read 0.0006 lx on average, with
/// no warning).
#[test]
fn inside_out_meshes_are_found_and_flipped_on_request() {
    let d = tempfile::tempdir().unwrap();
    let obj = inward_cube(d.path());
    let o = imap(&["info", &obj]);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["objects"][0]["normals"], "inward", "{info}");
    assert!(
        info["warnings"].to_string().contains("point inward"),
        "{info}"
    );
    let light = "up_axis = \"z\"\n[run]\nseed = 2\n[[light]]\nkind = \"point\"\nposition = [0.5, 0.5, 3]\npower = 10\n";
    let toml = write(d.path(), "s.toml", light);
    let out = d.path().join("out");
    let o = run_photons(&obj, &toml, &out, 200_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("point inward"), "{e}");
    assert!(e.contains("arrives on its back"), "{e}");
    let r = report(&out);
    assert!(r["warnings"].to_string().contains("arrives on its back"));
    let dark = r["meshes"][0]["illuminance_lx"]["mean"].as_f64().unwrap();
    let toml = write(
        d.path(),
        "f.toml",
        format!("flip_normals = [\"cube\"]\n{light}"),
    );
    let out = d.path().join("flipped");
    let o = run_photons(&obj, &toml, &out, 200_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        !e.contains("point inward") && !e.contains("arrives on its back"),
        "{e}"
    );
    let lit = report(&out)["meshes"][0]["illuminance_lx"]["mean"]
        .as_f64()
        .unwrap();
    assert!(
        lit > 100.0 * dark.max(1e-9) && lit > 1.0,
        "{dark} lx inward, {lit} lx flipped"
    );
    let toml = write(d.path(), "n.toml", "flip_normals = [\"ball\"]\n");
    let o = imap(&["run", &obj, "--config", &toml, "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("n.toml:1:"), "{}", stderr(&o));
}

fn base64(b: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() {
                A[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}

/// A 2 × 1 PNG: black on the left, white on the right.
fn half_black_png() -> Vec<u8> {
    let mut png = Vec::new();
    {
        let mut e = png::Encoder::new(&mut png, 2, 1);
        e.set_color(png::ColorType::Rgb);
        let mut w = e.write_header().unwrap();
        w.write_image_data(&[0, 0, 0, 255, 255, 255]).unwrap();
    }
    png
}

/// A glTF lamp with an emission texture, black on its left half: only its right half
/// emits (the texture was ignored: the whole surface glowed, and the DamagedHelmet became
/// a 10.7 klm lamp), and `emission = 0` in the settings turns the emission off.
#[test]
fn emission_textures_are_read_and_emission_can_be_turned_off() {
    let d = tempfile::tempdir().unwrap();
    // The lamp: two 0.5 m² quads side by side at z = 1, facing down, u 0–0.5 and 0.5–1.
    let pos: [f32; 18] = [
        0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.5, 1.0, 1.0, // left, two triangles
        0.5, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0,
    ];
    let uv: [f32; 12] = [0.0, 0.5, 0.0, 0.5, 0.5, 0.5, 0.5, 0.5, 1.0, 0.5, 1.0, 0.5];
    let idx: [u16; 12] = [0, 1, 2, 0, 2, 3, 3, 2, 5, 3, 5, 4];
    let mut bin: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(uv.iter().flat_map(|x| x.to_le_bytes()));
    bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    let png = half_black_png();
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "lamp"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{
            "name": "glow",
            "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1.0]},
            "emissiveFactor": [1.0, 1.0, 1.0],
            "emissiveTexture": {"index": 0},
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10.0}}
        }],
        "textures": [{"source": 0}],
        "images": [{"uri": format!("data:image/png;base64,{}", base64(&png))}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3", "min": [0, 0, 1], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5126, "count": 6, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 12, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteLength": 72}, {"buffer": 0, "byteOffset": 72, "byteLength": 48},
            {"buffer": 0, "byteOffset": 120, "byteLength": 24}
        ],
        "buffers": [{"byteLength": 144, "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}]
    });
    let model = write(d.path(), "lamp.gltf", serde_json::to_vec(&gltf).unwrap());
    let toml = write(d.path(), "s.toml", "up_axis = \"z\"\n");
    let out = d.path().join("out");
    let o = run_photons(&model, &toml, &out, 10_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    // 10 W/m² per band over the white half (0.5 m²), three bands.
    let w = r["energy_w"]["emitted"].as_f64().unwrap();
    assert!((w - 15.0).abs() < 1e-6, "{w} W emitted");
    // Turned off (with a point light, so the scene has one).
    let toml = write(
        d.path(),
        "off.toml",
        "up_axis = \"z\"\n[materials.glow]\nemission = 0\n[[light]]\nkind = \"point\"\nposition = [0.5, 0.5, 0]\npower = 1\n",
    );
    let out = d.path().join("off");
    let o = run_photons(&model, &toml, &out, 10_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let w = report(&out)["energy_w"]["emitted"].as_f64().unwrap();
    assert!(
        (w - 3.0).abs() < 1e-6,
        "{w} W emitted: the point light's alone"
    );
}

/// A floor lit from above with a closed box standing on it, and a grid over the floor at
/// 0.1 m: some of its points lie inside the box, where no light reaches.
fn floor_and_box(dir: &Path) -> String {
    write(dir, "f.mtl", "newmtl grey\nKd 0.5 0.5 0.5\n");
    let mut s = String::from("mtllib f.mtl\nusemtl grey\no floor\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\no box\n");
    // A 1 × 1 × 0.5 m box at x, y 1.5–2.5, outward normals.
    for (x, y, z) in [
        (1.5, 1.5, 0.0),
        (2.5, 1.5, 0.0),
        (2.5, 2.5, 0.0),
        (1.5, 2.5, 0.0),
        (1.5, 1.5, 0.5),
        (2.5, 1.5, 0.5),
        (2.5, 2.5, 0.5),
        (1.5, 2.5, 0.5),
    ] {
        s += &format!("v {x} {y} {z}\n");
    }
    for f in [
        [5, 8, 7, 6],
        [9, 10, 11, 12],
        [5, 6, 10, 9],
        [6, 7, 11, 10],
        [7, 8, 12, 11],
        [8, 5, 9, 12],
    ] {
        s += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    write(dir, "fb.obj", s)
}

const ABOVE: &str = "up_axis = \"z\"\nrecord = [\"floor\"]\n[run]\nseed = 3\ntime_s = 60\n\
    [[light]]\nkind = \"point\"\nposition = [2, 2, 2.5]\npower = 50\n\
    [[grid]]\nname = \"g\"\norigin = [0, 0, 0.1]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [4, 4]\nspacing = 0.25\n";

/// A target on the grid points' errors ends though some points lie inside a box: they
/// received nothing at all, are left out and said (the target never ended: a point that no
/// light reaches keeps its error at 100 %).
#[test]
fn grid_targets_end_with_points_no_light_reaches_and_say_so() {
    let d = tempfile::tempdir().unwrap();
    let obj = floor_and_box(d.path());
    let toml = write(d.path(), "g.toml", ABOVE);
    let out = d.path().join("out");
    let o = imap(&[
        "run",
        &obj,
        "--config",
        &toml,
        "--until-grid-error",
        "0.1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    assert_eq!(r["stop"], "RegionTarget", "{}", r["stop"]);
    let unlit = r["grids"][0]["unlit_points"].as_u64().unwrap();
    // The box covers 4 × 4 points; the 2 × 2 inner ones average light over triangles
    // that stay inside it (the outer ring's reach past its walls, and it is warned about).
    assert_eq!(unlit, 4, "{}", r["grids"][0]);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("4 point(s) received no light"), "{s}");
    assert!(
        stderr(&o).contains("cross the model's surfaces"),
        "{}",
        stderr(&o)
    );
    assert!(r["run_s"].as_f64().unwrap() < 30.0);
}

/// A target on the grid's average ends only once the grid's other figures are estimates:
/// Emin, Emax and U0 known to 25 %, Emin ≤ Eavg ≤ Emax and U0 ≤ 1 within their errors
/// (a stop at 0.3 s reported U0 = 1.18 ± 0.58).
#[test]
fn a_stop_on_the_grid_average_reports_sane_figures() {
    let d = tempfile::tempdir().unwrap();
    let obj = floor_and_box(d.path());
    // Many points, photons only, a loose target: the average (summed photon by photon) is
    // known long before the points are.
    for seed in 0..4 {
        let toml = write(
            d.path(),
            &format!("a{seed}.toml"),
            ABOVE
                .replace(
                    "seed = 3\n",
                    &format!("seed = {seed}\ngrid_error = 0.1\ngrid_error_measure = \"average\"\nestimator = \"photons\"\n"),
                )
                .replace("spacing = 0.25", "spacing = 0.1"),
        );
        let out = d.path().join(format!("a{seed}"));
        let o = imap(&[
            "run",
            &obj,
            "--config",
            &toml,
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let g = &report(&out)["grids"][0];
        let v = |k: &str| {
            (
                g[k]["value"].as_f64().unwrap(),
                g[k]["sigma"].as_f64().unwrap(),
            )
        };
        let ((avg, _), (min, smin), (max, smax), (u0, su0)) =
            (v("average_lx"), v("min_lx"), v("max_lx"), v("u0"));
        // The target required 25 % (`MAX_FIGURE_ERROR`) at the check that stopped the
        // run; the photons in flight then may move the minimum to another point (here a
        // 1 lx point in the box's penumbra), so the report may read a little above it.
        assert!(
            smin <= 0.3 * min && smax <= 0.3 * max && su0 <= 0.3 * u0,
            "{g}"
        );
        assert!(
            min <= avg + 2.0 * smin && max >= avg - 2.0 * smax && u0 <= 1.0 + 2.0 * su0,
            "{g}"
        );
        // The report says what the stop on Eavg left: Emin's and U0's errors.
        assert_eq!(report(&out)["stop"], "RegionTarget");
        let note = g["note"].as_str().unwrap_or_default();
        let emin = format!("Emin is still at ± {:.1} %", 100.0 * smin / min);
        let uni = format!("U0 at ± {:.1} %", 100.0 * su0 / u0);
        assert!(note.contains(&emin) && note.contains(&uni), "{note}");
    }
}

/// A 6000 × 4000 × 3000 room in millimetres, Z up, with a glazed window material whose
/// transparency has no refraction (read as opaque: said by `run` and `info` alike).
fn room_mm(dir: &Path) -> String {
    write(
        dir,
        "mm.mtl",
        "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl pane\nKd 0.1 0.1 0.1\nd 0.5\n",
    );
    write(
        dir,
        "mm.obj",
        "mtllib mm.mtl\nv 0 0 0\nv 6000 0 0\nv 6000 4000 0\nv 0 4000 0\nv 0 0 3000\nv 6000 0 3000\n\
         v 6000 4000 3000\nv 0 4000 3000\nusemtl wall\no floor\nf 1 2 3 4\no ceiling\nf 5 8 7 6\n\
         o back\nf 4 3 7 8\no left\nf 1 4 8 5\no right\nf 2 6 7 3\nusemtl pane\no front\nf 1 5 6 2\n",
    )
}

/// A model drawn in millimetres and read in metres gets a millionth of its illuminance,
/// and a Z-up model read Y-up gets its sky from the side: with no `unit_m` or `up_axis`,
/// `info` and `run` say what the geometry looks like, and `info` gives the material
/// warnings `run` gives. Settings that choose say nothing.
#[test]
fn units_up_axis_and_materials_are_checked_by_info_and_run() {
    let d = tempfile::tempdir().unwrap();
    let obj = room_mm(d.path());
    let o = imap(&["info", &obj]);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let w = info["warnings"].to_string();
    assert!(
        w.contains("looks drawn in millimetres (6.0 × 4.0 × 3.0 m): set unit_m = 0.001"),
        "{w}"
    );
    assert!(
        w.contains("looks z-up") && w.contains("up_axis = \\\"z\\\""),
        "{w}"
    );
    assert!(
        w.contains("material 'pane': transparency (d 0.5) without refraction"),
        "{w}"
    );
    assert_eq!(info["units_guess"], "millimetres");
    assert_eq!(info["up_axis_guess"]["axis"], "z");

    let light = "[[light]]\nkind = \"point\"\nposition = [3000, 2000, 2500]\npower = 100\n";
    let bare = write(d.path(), "bare.toml", light);
    let o = run_photons(&obj, &bare, &d.path().join("a"), 20_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("set unit_m = 0.001") && e.contains("looks z-up"),
        "{e}"
    );
    let chosen = write(
        d.path(),
        "chosen.toml",
        format!("unit_m = 0.001\nup_axis = \"z\"\n{light}"),
    );
    let o = run_photons(&obj, &chosen, &d.path().join("b"), 20_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(!e.contains("unit_m") && !e.contains("up_axis"), "{e}");
    // A room in metres: no unit to warn about.
    let o = imap(&["info", &room(d.path())]);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["units_guess"], "metres");
    assert!(!info["warnings"].to_string().contains("unit_m"));
}

/// A 6 × 4 × 3 m room in metres (Z up), every surface a quad, black or grey, with a
/// point light inside.
fn quad_room(dir: &Path, kd: f64) -> String {
    write(dir, "q.mtl", format!("newmtl m\nKd {kd} {kd} {kd}\n"));
    write(
        dir,
        "q.obj",
        "mtllib q.mtl\nv 0 0 0\nv 6 0 0\nv 6 4 0\nv 0 4 0\nv 0 0 3\nv 6 0 3\nv 6 4 3\nv 0 4 3\n\
         usemtl m\no floor\nf 1 2 3 4\no ceiling\nf 5 8 7 6\no back\nf 4 3 7 8\no left\nf 1 4 8 5\n\
         o right\nf 2 6 7 3\no front\nf 1 5 6 2\n",
    )
}

const LAMP_INSIDE: &str =
    "up_axis = \"z\"\n[[light]]\nkind = \"point\"\nposition = [3, 2, 2.5]\npower = 100\n";

fn view_pixels(out: &Path) -> (u32, u32, Vec<u8>) {
    let dec = png::Decoder::new(std::fs::File::open(out.join("view.png")).unwrap());
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// A room lit inside is seen from inside: the default camera of view.png is the one that
/// shows the most lit, recorded surface facing it (from outside, the picture showed the
/// walls' outer faces), and surfaces that cross the camera's near plane are clipped, not
/// dropped (the ceiling over an inside camera was missing).
#[test]
fn the_default_view_looks_at_the_lit_recorded_side() {
    let d = tempfile::tempdir().unwrap();
    let obj = quad_room(d.path(), 0.5);
    let toml = write(d.path(), "v.toml", format!("refine = 0.5\n{LAMP_INSIDE}"));
    let out = d.path().join("v");
    let o = run_photons(&obj, &toml, &out, 100_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let cam = &report(&out)["view_camera"];
    let p: Vec<f64> = (0..3)
        .map(|k| cam["position"][k].as_f64().unwrap())
        .collect();
    assert!(
        p[0] > 0.0 && p[0] < 6.0 && p[1] > 0.0 && p[1] < 4.0 && p[2] > 0.0 && p[2] < 3.0,
        "the camera is outside the room: {cam}"
    );
    // Every pixel above the legend shows a wall, the floor or the ceiling in false colour:
    // none is the background.
    let (w, h, px) = view_pixels(&out);
    let legend = 80;
    let background = (0..(h - legend) * w)
        .filter(|&i| px[3 * i as usize..][..3] == [24, 24, 28])
        .count();
    assert_eq!(background, 0, "{background} pixels show nothing");
}

/// Objects drawn as two triangles get a map of four values; the command says so and
/// `refine` splits them: then a black room's floor reads I/h² under the lamp and I h / r³
/// at (1.5, 1) m, a ratio of 1.874 (the four corners of the coarse floor hold no such point).
#[test]
fn coarse_objects_are_warned_about_and_refine_splits_them() {
    let d = tempfile::tempdir().unwrap();
    let obj = quad_room(d.path(), 0.0);
    let coarse = write(d.path(), "c.toml", LAMP_INSIDE);
    let o = run_photons(&obj, &coarse, &d.path().join("c"), 20_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("6 recorded object(s) have their vertices far apart")
            && e.contains("refine = 0.53"),
        "{e}"
    );
    let fine = write(d.path(), "f.toml", format!("refine = 0.25\n{LAMP_INSIDE}"));
    let out = d.path().join("f");
    let o = run_photons(&obj, &fine, &out, 300_000);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("far apart"), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    let floor: Vec<[f64; 3]> = csv
        .lines()
        .filter(|l| l.starts_with("floor,"))
        .map(|l| {
            let c: Vec<f64> = l.split(',').skip(2).map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[7]]
        })
        .collect();
    assert!(floor.len() > 400, "{} floor vertices", floor.len());
    // The vertices nearest to a point: its position and lux; I h / r³ there (up to I).
    let nearest = |x: f64, y: f64| {
        let v = floor
            .iter()
            .min_by(|a, b| {
                let d = |p: &[f64; 3]| (p[0] - x).powi(2) + (p[1] - y).powi(2);
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        let r2 = (v[0] - 3.0).powi(2) + (v[1] - 2.0).powi(2) + 2.5f64.powi(2);
        (v[2], 2.5 / r2.powf(1.5))
    };
    let ((under, e_under), (off, e_off)) = (nearest(3.0, 2.0), nearest(1.5, 1.0));
    let (ratio, want) = (under / off, e_under / e_off);
    eprintln!("floor under the lamp / at (1.5, 1): {ratio:.3} (I/h² over I h/r³: {want:.3})");
    assert!((ratio / want - 1.0).abs() < 0.03, "{ratio} vs {want}");
    // A refine that would make too many triangles is refused, naming the setting.
    let tiny = write(d.path(), "t.toml", format!("refine = 1e-4\n{LAMP_INSIDE}"));
    let o = run_photons(&obj, &tiny, &d.path().join("t"), 1000);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("refine = 0.0001: it would make more than"),
        "{}",
        stderr(&o)
    );
}

/// photons must not leave a closed box through the edge where two walls
/// meet. A beam 1 µm wide aimed at the edge of a white, flat box: the tracer's f32
/// barycentrics put some hits an ulp beyond the edge, and the reflected ray started on or
/// just behind the other wall (0.46 % of the beam's energy escaped before the fix; one
/// photon in about 10⁸ in a room). Now none does.
#[test]
fn no_photon_leaves_a_closed_box_through_its_edges() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "box.mtl", "newmtl wall\nKd 0.9 0.9 0.9\n");
    let obj = write(
        d.path(),
        "flat.obj",
        "mtllib box.mtl\nusemtl wall\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 0.02\nv 1 0 0.02\nv 1 1 0.02\nv 0 1 0.02\no box\n\
         f 1 2 3\nf 1 3 4\nf 5 8 7\nf 5 7 6\nf 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\nf 3 7 8\nf 3 8 4\nf 4 8 5\nf 4 5 1\n",
    );
    let toml = write(
        d.path(),
        "b.toml",
        "up_axis = \"z\"\ntwo_sided = true\n[run]\nseed = 9\n[[light]]\nkind = \"beam\"\nposition = [0.005, 0.5, 0.005]\ndirection = [-1, 0, -1]\ndiameter = 1e-6\npower = 1\n",
    );
    let out = d.path().join("out");
    let o = run_photons(&obj, &toml, &out, 1_000_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let e = &r["energy_w"];
    assert_eq!(e["escaped"].as_f64(), Some(0.0), "{e}");
    let absorbed = e["absorbed"].as_f64().unwrap();
    assert!((absorbed / 3.0 - 1.0).abs() < 1e-9, "{e}");
}
