//! The `imap` command end to end: argument and input errors, outputs that exist and
//! parse, the PLY's values against libimap's own map, validate and demo.

mod common;

use common::{imap, run_photons, stderr, write};

use std::f64::consts::FRAC_PI_2;
use std::path::Path;

/// A black triangle far below the origin, in `dir`: a model that lights nothing, so that
/// grids at the origin read their lights unobstructed. Returns the OBJ's path.
fn far_triangle(dir: &Path) -> String {
    write(dir, "far.mtl", "newmtl black\nKd 0 0 0\n");
    write(
        dir,
        "far.obj",
        "mtllib far.mtl\no far\nusemtl black\nv 50 50 -50\nv 51 50 -50\nv 50 51 -50\nf 1 2 3\n",
    )
}

/// Runs imap expecting failure; returns its one-line message.
fn fails(args: &[&str]) -> String {
    let o = imap(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "not one line: {e}");
    e
}

const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n";

/// A 4×4-cell floor and a small lamp above it facing down (coordinates exact in f32, as
/// OBJ loaders hold them).
/// Vertex positions and triangle indices of one object.
type Part = (Vec<[f64; 3]>, Vec<u32>);

fn scene_obj() -> (String, Part, Part) {
    let mut floor = Vec::new();
    let mut fi = Vec::new();
    let n = 4;
    for j in 0..=n {
        for i in 0..=n {
            floor.push([i as f64 * 0.5, j as f64 * 0.5, 0.0]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            fi.extend([
                a,
                a + 1,
                a + n as u32 + 2,
                a,
                a + n as u32 + 2,
                a + n as u32 + 1,
            ]);
        }
    }
    let lamp = vec![
        [0.75, 0.75, 1.5],
        [1.25, 0.75, 1.5],
        [1.25, 1.25, 1.5],
        [0.75, 1.25, 1.5],
    ];
    let li = vec![0, 2, 1, 0, 3, 2];
    let mut obj = String::from("mtllib scene.mtl\no floor\nusemtl grey\n");
    for p in &floor {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in fi.chunks(3) {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    obj += "o lamp\nusemtl lamp\n";
    for p in &lamp {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in li.chunks(3) {
        let b = floor.len() as u32 + 1;
        obj += &format!("f {} {} {}\n", t[0] + b, t[1] + b, t[2] + b);
    }
    (obj, (floor, fi), (lamp, li))
}

/// The report.json a run wrote into `out`.
fn read_report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

#[test]
fn bad_input_is_one_line_naming_file_and_line() {
    let d = tempfile::tempdir().unwrap();
    let e = fails(&["run", "/no/such/scene.obj", "--photons", "10"]);
    assert!(e.contains("/no/such/scene.obj"), "{e}");

    write(d.path(), "scene.mtl", MTL);
    let bad = write(d.path(), "bad.obj", "mtllib scene.mtl\nv 0 0 0\nv 1 x 0\n");
    let e = fails(&["run", &bad, "--photons", "10"]);
    assert!(e.contains("bad.obj:3") && e.contains("'x'"), "{e}");

    let nan = write(
        d.path(),
        "nan.obj",
        "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n",
    );
    let e = fails(&["run", &nan, "--photons", "10"]);
    assert!(e.contains("nan.obj:3"), "{e}");

    let idx = write(d.path(), "idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    let e = fails(&["run", &idx, "--photons", "10"]);
    assert!(e.contains("idx.obj:4") && e.contains("out of range"), "{e}");

    // An unknown material is a warning (default grey), not an error.
    let unknown = write(
        d.path(),
        "unknown.obj",
        "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl marble\nf 1 2 3\n",
    );
    let lit = write(
        d.path(),
        "lit.toml",
        "[[light]]\nkind = \"point\"\nposition = [0.2, 0.2, 1]\npower = 1\n",
    );
    let out = d.path().join("unknown-out");
    let o = imap(&[
        "run",
        &unknown,
        "--config",
        &lit,
        "--photons",
        "1000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let w = stderr(&o);
    assert!(
        w.contains("warning") && w.contains("unknown.obj:5") && w.contains("marble"),
        "{w}"
    );

    write(d.path(), "badmtl.mtl", "newmtl a\nKd 0.5 inf 0.5\n");
    let m = write(d.path(), "m.obj", "mtllib badmtl.mtl\nv 0 0 0\n");
    let e = fails(&["run", &m, "--photons", "10"]);
    assert!(e.contains("badmtl.mtl:2"), "{e}");

    let (obj, ..) = scene_obj();
    let good = write(d.path(), "good.obj", &obj);
    let toml = write(d.path(), "s.toml", "[run]\nphotons = 10\nphtons = 3\n");
    let e = fails(&["run", &good, "--config", &toml]);
    assert!(e.contains("s.toml:3") && e.contains("phtons"), "{e}");
    let toml = write(
        d.path(),
        "l.toml",
        "[[light]]\nkind = \"laser\"\nposition = [0, 0, 1]\npower = 1\n",
    );
    let e = fails(&["run", &good, "--config", &toml, "--photons", "10"]);
    assert!(e.contains("laser"), "{e}");
    let e = fails(&[
        "run",
        &good,
        "--photons",
        "0",
        "--time",
        "0",
        "--target-error",
        "0",
    ]);
    assert!(e.contains("no stop criterion"), "{e}");
    let e = fails(&["run", &good, "--photons", "10", "--scheduler", "fast"]);
    assert!(e.contains("fast"), "{e}");
    // Clap's own usage errors exit non-zero too.
    assert_ne!(imap(&["run"]).status.code(), Some(0));
    assert_ne!(imap(&["frobnicate"]).status.code(), Some(0));
}

#[test]
fn outputs_exist_parse_and_the_ply_holds_libimap_s_map() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, (floor, fi), (lamp, li)) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let out = d.path().join("out");
    let photons = 200_000u64;
    let o = imap(&[
        "run",
        &path,
        "--out",
        out.to_str().unwrap(),
        "--photons",
        &photons.to_string(),
        "--time",
        "0",
        "--target-error",
        "0",
        "--seed",
        "5",
        "--threads",
        "2",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    // report.json
    let report = read_report(&out);
    assert_eq!(report["photons"], photons);
    assert_eq!(report["meshes"].as_array().unwrap().len(), 2);
    assert_eq!(report["meshes"][1]["emitting"], true);
    // Emitters are not recorded unless named in `record`.
    assert_eq!(report["meshes"][1]["recorded"], false);
    assert!(!report["history"].as_array().unwrap().is_empty());
    let e = &report["energy_w"];
    let balance = e["absorbed"].as_f64().unwrap() + e["escaped"].as_f64().unwrap();
    assert!((balance - e["emitted"].as_f64().unwrap()).abs() < 1e-9 * balance);
    // The lamp: Ke 10 W/m² per band over 0.25 m², one side.
    assert!((e["emitted"].as_f64().unwrap() - 3.0 * 10.0 * 0.25).abs() < 1e-12);

    // The same scene through libimap directly, same seed and photon count.
    let mut ctx = imap::Context::new(imap::Config {
        seed: 5,
        threads: 1,
        ..Default::default()
    })
    .unwrap();
    let grey = ctx
        .add_material(&imap::MaterialDesc {
            diffuse_reflect: vec![0.5],
            ..Default::default()
        })
        .unwrap();
    let black = ctx
        .add_material(&imap::MaterialDesc {
            diffuse_reflect: vec![0.0],
            ..Default::default()
        })
        .unwrap();
    let fp: Vec<f64> = floor.iter().flatten().copied().collect();
    let lp: Vec<f64> = lamp.iter().flatten().copied().collect();
    let fid = ctx.add_mesh(&imap::MeshDesc::new(&fp, &fi, grey)).unwrap();
    ctx.add_mesh(&imap::MeshDesc {
        exitance: Some(&[10.0]),
        ..imap::MeshDesc::new(&lp, &li, black)
    })
    .unwrap();
    ctx.run(&mut imap::RunParams {
        photons,
        progress_interval_s: 1.0,
        ..Default::default()
    })
    .unwrap();
    let mut mean = vec![0.0; floor.len()];
    let mut e = vec![0.0; floor.len()];
    for b in 0..3 {
        ctx.irradiance(fid, 0, b, &mut e).unwrap();
        for v in 0..floor.len() {
            mean[v] += e[v] / 3.0;
        }
    }
    let mut rel = vec![0.0; floor.len()];
    ctx.rel_error(fid, 0, &mut rel).unwrap();
    let mut lux = vec![0.0; floor.len()];
    ctx.illuminance(fid, 0, &mut lux).unwrap();

    // PLY: header, then vertices matched by position.
    let ply = std::fs::read_to_string(out.join("irradiance.ply")).unwrap();
    let (header, body) = ply.split_once("end_header\n").unwrap();
    assert!(header.starts_with("ply\nformat ascii 1.0\n"));
    let nv = floor.len();
    assert!(
        header.contains(&format!("element vertex {nv}\n")),
        "{header}"
    );
    assert!(header.contains("element face 32\n"), "{header}");
    let mut matched = 0;
    for line in body.lines().take(nv) {
        let f: Vec<f64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(f.len(), 9, "{line}");
        if let Some(v) = floor
            .iter()
            .position(|p| (0..3).all(|k| (p[k] - f[k]).abs() < 1e-6))
        {
            assert_eq!(f[6] as f32, mean[v] as f32, "vertex {v}: PLY vs libimap");
            assert_eq!(f[7] as f32, rel[v] as f32, "vertex {v}: error");
            assert_eq!(f[8] as f32, lux[v] as f32, "vertex {v}: lux");
            matched += 1;
        }
    }
    assert_eq!(matched, floor.len());
    // The floor is lit: every vertex got light.
    assert!(mean.iter().all(|&x| x > 0.0));

    // CSV: header and one row per recorded vertex.
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "mesh,vertex,x,y,z,E_r,E_g,E_b,rel_error,lux"
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), nv);
    for r in &rows {
        let f: Vec<&str> = r.split(',').collect();
        assert_eq!(f.len(), 10);
        assert!(f[5..].iter().all(|x| x.parse::<f64>().unwrap().is_finite()));
    }

    // The pictures decode.
    for (name, w, h) in [("view.png", 640, 640), ("convergence.png", 800, 560)] {
        let dec = png::Decoder::new(std::fs::File::open(out.join(name)).unwrap());
        let reader = dec.read_info().unwrap();
        let info = reader.info();
        assert_eq!((info.width, info.height), (w, h), "{name}");
    }
}

#[test]
fn mtl_materials_map_to_libimap_materials() {
    // Kd → diffuse, Ke → emission, Ni with d < 1 → dielectric (a glass block between the
    // lamp and the floor lets light through: the floor under it is lit).
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "scene.mtl",
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\nnewmtl glass\nKd 0.5 0.5 0.5\nNi 1.5\nd 0.1\n",
    );
    let (mut obj, (floor, _), _) = scene_obj();
    // A glass slab 0.1 m thick at z = 0.5–0.6 covering the whole floor.
    obj += "o glass\nusemtl glass\n";
    let b = floor.len() + 4 + 1;
    for z in [0.5, 0.6] {
        for (x, y) in [(-1.0, -1.0), (3.0, -1.0), (3.0, 3.0), (-1.0, 3.0)] {
            obj += &format!("v {x} {y} {z}\n");
        }
    }
    for f in [
        [0, 2, 1],
        [0, 3, 2],
        [4, 5, 6],
        [4, 6, 7],
        [0, 1, 5],
        [0, 5, 4],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 0, 4],
        [3, 4, 7],
    ] {
        obj += &format!("f {} {} {}\n", f[0] + b, f[1] + b, f[2] + b);
    }
    let path = write(d.path(), "scene.obj", &obj);
    let toml = write(d.path(), "s.toml", "record = [\"floor\"]\n");
    let out = d.path().join("out");
    let o = imap(&[
        "run",
        &path,
        "--config",
        &toml,
        "--out",
        out.to_str().unwrap(),
        "--photons",
        "100000",
        "--time",
        "0",
        "--target-error",
        "0",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&out);
    let meshes = report["meshes"].as_array().unwrap();
    assert_eq!(meshes.len(), 3);
    assert_eq!(meshes[0]["recorded"], true);
    assert_eq!(meshes[2]["recorded"], false);
    // Read as Lambertian (Kd 0.5) the slab would be opaque and the floor dark; as a clear
    // dielectric it passes ~92 % at normal incidence and the floor is lit everywhere.
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    let lit: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(5).unwrap().parse::<f64>().unwrap())
        .collect();
    assert_eq!(lit.len(), 25, "only the floor is recorded");
    assert!(
        lit.iter().all(|&e| e > 0.0),
        "the floor is dark under the glass: {lit:?}"
    );
    let e = &report["energy_w"];
    let (em, ab, esc) = (
        e["emitted"].as_f64().unwrap(),
        e["absorbed"].as_f64().unwrap(),
        e["escaped"].as_f64().unwrap(),
    );
    assert!((ab + esc - em).abs() < 1e-9 * em);
}

#[test]
fn validate_passes_every_analytic_case() {
    let o = imap(&["validate", "--photons", "300000"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", stderr(&o));
    assert_eq!(text.matches(" pass").count(), 4, "{text}");
}

#[test]
fn demo_writes_a_cornell_box_with_colour_bleeding() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("demo");
    let o = imap(&[
        "demo",
        "--out",
        out.to_str().unwrap(),
        "--target-error",
        "0.04",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "irradiance.csv",
        "irradiance.ply",
        "report.json",
        "convergence.png",
        "view.png",
        "cornell_box.obj",
        "cornell_box.mtl",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    // The floor's irradiance is redder near the red wall (x = 550 mm) than near the green
    // one (x = 0), and greener near the green one.
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    let (mut near_red, mut near_green) = ([0.0; 3], [0.0; 3]);
    for l in csv.lines().skip(1).filter(|l| l.starts_with("floor,")) {
        let f: Vec<f64> = l.split(',').skip(2).map(|x| x.parse().unwrap()).collect();
        let (x, z) = (f[0], f[2]);
        if z > 100.0 && z < 500.0 {
            let e = [f[3], f[4], f[5]];
            if x > 500.0 {
                (0..3).for_each(|k| near_red[k] += e[k]);
            } else if x < 50.0 {
                (0..3).for_each(|k| near_green[k] += e[k]);
            }
        }
    }
    let rg = |c: [f64; 3]| c[0] / c[1];
    assert!(
        rg(near_red) > 1.1 * rg(near_green),
        "red/green near the red wall {:.3}, near the green wall {:.3}",
        rg(near_red),
        rg(near_green)
    );
}

/// A cosine IES file: I0 `i0` cd, γ in 1° steps, named TILT file or none.
fn cosine_ies(i0: f64, tilt: &str) -> String {
    let mut s =
        format!("IESNA:LM-63-2002\n[TEST] cosine\nTILT={tilt}\n1 -1 1 91 1 1 2 0 0 0\n1 1 10\n");
    for g in 0..=90 {
        s.push_str(&format!("{g} "));
    }
    s.push_str("\n0\n");
    for g in 0..=90 {
        s.push_str(&format!("{} ", i0 * (g as f64).to_radians().cos()));
    }
    s.push('\n');
    s
}

#[test]
fn luminaires_and_photometric_lights_report_lumens_and_lux() {
    // A black 6 × 6 m floor (12 × 12 cells) under two cosine luminaires 3 m up, one with a
    // TILT file beside it (aimed 20° off nadir: factor 0.9), and a 500 lm point light. The
    // floor's area-weighted mean illuminance × its area is the flux it receives, the
    // integral of I cos θ / r² over it (hat functions sum to one).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut obj = String::from("mtllib floor.mtl\no floor\nusemtl black\n");
    let n = 12;
    for j in 0..=n {
        for i in 0..=n {
            obj.push_str(&format!(
                "v {} {} 0\n",
                -3.0 + 0.5 * i as f64,
                -3.0 + 0.5 * j as f64
            ));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            obj.push_str(&format!(
                "f {} {} {}\nf {} {} {}\n",
                a,
                a + 1,
                a + n + 2,
                a,
                a + n + 2,
                a + n + 1
            ));
        }
    }
    let o = write(d, "floor.obj", &obj);
    write(d, "floor.mtl", "newmtl black\nKd 0 0 0\n");
    write(d, "plain.ies", cosine_ies(1000.0, "NONE"));
    write(d, "tilted.ies", cosine_ies(1000.0, "tilted.tlt"));
    write(d, "tilted.tlt", "1\n3\n0 20 90\n1 0.9 0.5\n");
    let t = 20f64.to_radians();
    let settings = format!(
        r#"
[run]
photons = 4000000
seed = 3
[[luminaire]]
file = "plain.ies"
positions = [[-1, 0, 3]]
spectrum = "3000K"
[[luminaire]]
file = "tilted.ies"
position = [1, 0, 3]
aim = [{}, 0, {}]
[[light]]
kind = "point"
position = [0, 0, 2]
amount = 500
unit = "lm"
spectrum = "D65"
"#,
        t.sin(),
        -t.cos()
    );
    let s = write(d, "settings.toml", &settings);
    let out = d.join("out");
    let o = imap(&[
        "run",
        &o,
        "--config",
        &s,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&out);
    let lights = report["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 3);
    let lm: Vec<f64> = lights
        .iter()
        .map(|l| l["lumens"].as_f64().unwrap())
        .collect();
    let pi = std::f64::consts::PI;
    // [[light]] tables first, then [[luminaire]] tables, each in file order.
    assert!((lm[0] - 500.0).abs() < 1e-9, "{lm:?}");
    assert!((lm[1] / (pi * 1000.0) - 1.0).abs() < 1e-3, "{lm:?}");
    assert!((lm[2] / (0.9 * pi * 1000.0) - 1.0).abs() < 1e-3, "{lm:?}");
    let emitted = report["luminous_lm"]["emitted"].as_f64().unwrap();
    assert!(
        (emitted / lm.iter().sum::<f64>() - 1.0).abs() < 0.01,
        "{emitted}"
    );
    // The flux onto the floor, by quadrature: cosine sources (one tilted) and the point.
    let flux_from = |pos: [f64; 3], aim: [f64; 3], i0: f64, cosine: bool| {
        let m = 600;
        let mut sum = 0.0;
        for a in 0..m {
            for b in 0..m {
                let x = -3.0 + 6.0 * (a as f64 + 0.5) / m as f64;
                let y = -3.0 + 6.0 * (b as f64 + 0.5) / m as f64;
                let v = [x - pos[0], y - pos[1], -pos[2]];
                let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let cos_floor = pos[2] / r;
                let i = if cosine {
                    i0 * ((v[0] * aim[0] + v[1] * aim[1] + v[2] * aim[2]) / r).max(0.0)
                } else {
                    i0
                };
                sum += i * cos_floor / (r * r) * (6.0 / m as f64).powi(2);
            }
        }
        sum
    };
    let expected = flux_from([-1.0, 0.0, 3.0], [0.0, 0.0, -1.0], 1000.0, true)
        + flux_from([1.0, 0.0, 3.0], [t.sin(), 0.0, -t.cos()], 900.0, true)
        + flux_from([0.0, 0.0, 2.0], [0.0; 3], 500.0 / (4.0 * pi), false);
    let floor = &report["meshes"][0]["illuminance_lx"];
    let got = floor["mean"].as_f64().unwrap() * 36.0;
    eprintln!("flux onto the floor: {got:.2} lm, expected {expected:.2} lm");
    assert!((got / expected - 1.0).abs() < 0.005, "{got} vs {expected}");
    // The CSV's lux column is the libimap illuminance; the light's colour is reported.
    let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",rel_error,lux"));
    assert!(
        report["light_on_recorded_surfaces"]["cct_k"]
            .as_f64()
            .unwrap()
            > 3000.0
    );

    // A EULUMDAT file placed as a 2 × 3 array: six luminaires at the array's positions.
    let g: Vec<f64> = (0..=18).map(|i| i as f64 * 10.0).collect();
    let c: Vec<f64> = (0..12).map(|i| i as f64 * 30.0).collect();
    let row: Vec<f64> = g
        .iter()
        .map(|a| if *a <= 90.0 { 300.0 } else { 0.0 })
        .collect();
    write(
        d,
        "down.ldt",
        imap::photometry::ldt::write(1, &c, &g, &[row], 1200.0),
    );
    let s = write(
        d,
        "array.toml",
        "[run]\nphotons = 20000\n[[luminaire]]\nfile = \"down.ldt\"\nrotation_deg = 90\narray = { start = [-2, -2, 3], count = [2, 3], step_a = [4, 0, 0], step_b = [0, 2, 0] }\n",
    );
    let o2 = imap(&[
        "run",
        &o_path(d),
        "--config",
        &s,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o2.status.success(), "{}", stderr(&o2));
    let report = read_report(&out);
    let lights = report["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 6);
    assert_eq!(lights[5]["position"], serde_json::json!([2.0, 2.0, 3.0]));
    // 300 cd/klm × 1.2 klm to γ = 90°, falling linearly to 0 at 100°.
    let m = 100_000;
    let table: f64 = (0..m)
        .map(|k| {
            let th = (k as f64 + 0.5) / m as f64 * pi;
            let deg = th.to_degrees();
            let i = if deg <= 90.0 {
                360.0
            } else {
                (360.0 * (1.0 - (deg - 90.0) / 10.0)).max(0.0)
            };
            2.0 * pi * i * th.sin() * pi / m as f64
        })
        .sum();
    for l in lights {
        let lm = l["lumens"].as_f64().unwrap();
        assert!((lm / table - 1.0).abs() < 1e-4, "{lm} vs {table}");
    }

    // A malformed file: one line naming the settings entry, the file and its line.
    write(
        d,
        "bad.ies",
        cosine_ies(1000.0, "NONE").replace("0 1 2 3", "0 2 1 3"),
    );
    let s = write(
        d,
        "bad.toml",
        "[[luminaire]]\nfile = \"bad.ies\"\nposition = [0, 0, 3]\n",
    );
    let e = fails(&[
        "run",
        &o_path(d),
        "--config",
        &s,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        e.contains("luminaire 1") && e.contains("bad.ies") && e.contains("IES line 6"),
        "{e}"
    );
}

fn o_path(d: &Path) -> String {
    d.join("floor.obj").to_string_lossy().into_owned()
}

#[test]
fn grids_measure_a_point_light_and_stop_on_their_error() {
    // A 1000 lm point light 2 m above the centre of a 2 × 2 m calculation grid with 0.25 m
    // spacing (8 × 8 points at the cells' centres); the only surface is a small black
    // triangle far away. Each point reads I cos θ / r² (averaged over its neighbourhood:
    // within 2 %), the grid's Eavg is I × the solid angle of the square the points span
    // over its area, and the run stops on the largest point error.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = far_triangle(d);
    let s = write(
        d,
        "settings.toml",
        r#"
[run]
time_s = 120
seed = 5
threads = 2
[[light]]
kind = "point"
position = [0, 0, 2]
amount = 1000
unit = "lm"
[[grid]]
name = "floor"
origin = [-1, -1, 0]
u = [1, 0, 0]
v = [0, 1, 0]
size = [2, 2]
spacing = 0.25
"#,
    );
    let out = d.join("out");
    let r = imap(&[
        "run",
        &o,
        "--config",
        &s,
        "--out",
        out.to_str().unwrap(),
        "--until-grid-error",
        "0.02",
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(
        stdout.contains("grid 'floor' (8 × 8 points): Eavg"),
        "{stdout}"
    );
    let report = read_report(&out);
    assert_eq!(report["stop"], "RegionTarget");
    let i = 1000.0 / (4.0 * std::f64::consts::PI);
    let h = 2.0;
    let csv = std::fs::read_to_string(out.join("grid_floor.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 64);
    let mut min_truth = f64::INFINITY;
    for row in &rows {
        let (ii, jj, x, y, z, lux, sigma, rel) = (
            row[0], row[1], row[2], row[3], row[4], row[5], row[6], row[7],
        );
        assert!((x - (-1.0 + 0.25 * (ii + 0.5))).abs() < 1e-12, "{row:?}");
        assert!((y - (-1.0 + 0.25 * (jj + 0.5))).abs() < 1e-12, "{row:?}");
        assert_eq!(z, 0.0);
        assert!(rel <= 0.02 * 1.05, "point error {rel} above the target");
        let truth = i * h / (x * x + y * y + h * h).powf(1.5);
        min_truth = min_truth.min(truth);
        assert!(
            (lux - truth).abs() <= 3.0 * sigma + 0.02 * truth,
            "point ({x}, {y}): {lux} ± {sigma} lx, expected {truth}"
        );
    }
    let g = &report["grids"][0];
    // The square through the outer points: half side 0.875 m.
    let a: f64 = 0.875;
    let omega = 4.0 * (a * a / (a * a + h * h)).asin();
    let eavg = i * omega / (4.0 * a * a);
    let (avg, avg_sigma) = (
        g["average_lx"]["value"].as_f64().unwrap(),
        g["average_lx"]["sigma"].as_f64().unwrap(),
    );
    assert!(
        (avg - eavg).abs() < 4.0 * avg_sigma,
        "Eavg {avg} ± {avg_sigma}, expected {eavg}"
    );
    assert!((g["area_m2"].as_f64().unwrap() - 4.0 * a * a).abs() < 1e-9);
    let (u0, u0_sigma) = (
        g["u0"]["value"].as_f64().unwrap(),
        g["u0"]["sigma"].as_f64().unwrap(),
    );
    let u0_truth = min_truth / eavg;
    assert!(
        (u0 - u0_truth).abs() <= 3.0 * u0_sigma + 0.02 * u0_truth,
        "U0 {u0} ± {u0_sigma}, expected {u0_truth}"
    );
    assert!(out.join("grid_floor.png").exists());

    // Bad grids are refused before any work, naming the grid.
    let bad = write(
        d,
        "bad.toml",
        "[run]\nphotons = 1000\n[[grid]]\nname = \"desk\"\norigin = [0, 0, 0]\nu = [1, 0, 0]\nv = [1, 1, 0]\nsize = [1, 1]\n",
    );
    let e = fails(&["run", &o, "--config", &bad, "--out", out.to_str().unwrap()]);
    assert!(
        e.contains("grid 'desk'") && e.contains("perpendicular"),
        "{e}"
    );
    let e = fails(&[
        "run",
        &o,
        "--until-grid-error",
        "0.02",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(e.contains("[[grid]]"), "{e}");
}

#[test]
fn a_sky_and_the_sun_light_an_open_plane_by_their_horizontal_amounts() {
    // A CIE clear sky of 10 000 lx horizontal and the sun at 60° from the zenith with
    // 80 000 lx normal to it: an open black plane reads 10 000 + 40 000 lx everywhere.
    // The sun by date and place: Berlin at 13:00 CEST on 21 June stands 29.1° from the
    // zenith, nearly due south. Bad daylight settings are one line naming the field.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obj = write(
        d,
        "plane.obj",
        "mtllib p.mtl\nusemtl black\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n",
    );
    write(d, "p.mtl", "newmtl black\nKd 0 0 0\n");
    let toml = write(
        d,
        "sky.toml",
        "up_axis = \"z\"\n[sky]\nkind = \"cie\"\ncie_type = 12\nhorizontal_illuminance = 10000\n\
         [sun]\nazimuth_deg = 200\nzenith_deg = 60\nnormal_illuminance = 80000\n",
    );
    let out = d.join("out");
    let o = common::run_photons(&obj, &toml, &out, 40_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&out);
    let lux = &report["meshes"][0]["illuminance_lx"];
    let mean = lux["mean"].as_f64().unwrap();
    assert!((mean / 50_000.0 - 1.0).abs() < 0.01, "{mean}");
    let lights = report["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 2);
    assert!((lights[1]["lumens"].as_f64().unwrap() - 40_000.0).abs() < 1e-6);
    assert_eq!(lights[1]["distant"], true);

    // An hour of weather: a Perez sky of its irradiances and the sun at its date take the
    // Perez efficacies' illuminances; the open plane reads E_dh + E_dn cos Z.
    let toml = write(
        d,
        "perez.toml",
        "up_axis = \"z\"\n[sky]\nkind = \"perez\"\ndirect_normal_irradiance = 600\n\
         diffuse_horizontal_irradiance = 150\ndew_point_c = 14\n\
         [sun]\ndate = \"2026-06-21 13:00\"\nutc_offset_hours = 2\nlatitude_deg = 52.52\n\
         longitude_deg = 13.40\n",
    );
    let o = common::run_photons(&obj, &toml, &d.join("perez"), 40_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&d.join("perez"));
    let z = imap::sun_position(&imap::SunTime {
        year: 2026,
        month: 6,
        day: 21,
        hour: 13,
        minute: 0,
        second: 0.0,
        utc_offset_hours: 2.0,
        latitude_deg: 52.52,
        longitude_deg: 13.40,
        elevation_m: 0.0,
    })
    .unwrap()
    .1;
    let p = imap::perez_sky(600.0, 150.0, z, 172, imap::precipitable_water(14.0))
        .unwrap()
        .unwrap();
    let want = p.diffuse_horizontal_lx + p.direct_normal_lx * z.to_radians().cos();
    let mean = report["meshes"][0]["illuminance_lx"]["mean"]
        .as_f64()
        .unwrap();
    assert!((mean / want - 1.0).abs() < 0.01, "{mean} vs {want}");
    let lights = report["lights"].as_array().unwrap();
    // A distant light's lumens are its horizontal illuminance.
    let sun_lx = p.direct_normal_lx * z.to_radians().cos();
    assert!((lights[1]["lumens"].as_f64().unwrap() / sun_lx - 1.0).abs() < 1e-9);
    assert!((lights[0]["lumens"].as_f64().unwrap() / p.diffuse_horizontal_lx - 1.0).abs() < 1e-9);
    // An overcast hour (no direct light) adds no sun.
    let toml = write(
        d,
        "overcast.toml",
        "up_axis = \"z\"\n[sky]\nkind = \"perez\"\ndirect_normal_irradiance = 0\n\
         diffuse_horizontal_irradiance = 90\n[sun]\ndate = \"2026-12-21 12:00\"\n\
         latitude_deg = 52.52\nlongitude_deg = 13.40\nutc_offset_hours = 1\n",
    );
    let o = common::run_photons(&obj, &toml, &d.join("overcast"), 10_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&d.join("overcast"));
    assert_eq!(report["lights"].as_array().unwrap().len(), 1);

    // An hour of an EPW file: the same sky and sun, placed by the file's site.
    let epw = "LOCATION,Berlin,BE,DEU,TMY,103840,52.52,13.40,1.0,34.0\n\
        DESIGN CONDITIONS,0\nTYPICAL/EXTREME PERIODS,0\nGROUND TEMPERATURES,0\n\
        HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0\nCOMMENTS 1,x\nCOMMENTS 2,y\n\
        DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n\
        2005,6,21,12,60,x,20,14.0,60,100000,0,0,300,700,600,150,0,0,0,0,180,3\n\
        2005,6,21,13,60,x,20,14.0,60,100000,0,0,300,700,9999,150,0,0,0,0,180,3\n";
    write(d, "w.epw", epw);
    let toml = write(
        d,
        "epw.toml",
        "up_axis = \"z\"\n[sky]\nkind = \"perez\"\nweather = \"w.epw\"\nweather_hour = \"06-21 12\"\n[sun]\n",
    );
    let o = common::run_photons(&obj, &toml, &d.join("epw"), 40_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let w = imap::weather::read_epw(&d.join("w.epw")).unwrap();
    let (_, z) = w.hours[0].sun_position(&w.site).unwrap();
    let p = w.hours[0].perez_sky(z).unwrap().unwrap();
    let want = p.diffuse_horizontal_lx + p.direct_normal_lx * z.to_radians().cos();
    let report = read_report(&d.join("epw"));
    let mean = report["meshes"][0]["illuminance_lx"]["mean"]
        .as_f64()
        .unwrap();
    assert!((mean / want - 1.0).abs() < 0.01, "{mean} vs {want}");
    assert_eq!(report["lights"].as_array().unwrap().len(), 2);
    for (bad, says) in [
        ("[sky]\nkind = \"perez\"\nweather = \"w.epw\"\nweather_hour = \"06-21 13\"\n", "missing"),
        ("[sky]\nkind = \"perez\"\nweather = \"w.epw\"\nweather_hour = \"06-22 12\"\n", "no such hour"),
        ("[sky]\nkind = \"perez\"\nweather = \"w.epw\"\nweather_hour = \"21.6. 12\"\n", "MM-DD HH"),
        ("[sky]\nkind = \"perez\"\nweather = \"w.epw\"\n", "weather_hour"),
        ("[sky]\nkind = \"cie\"\ncie_type = 1\nluminance = 1\nweather = \"w.epw\"\nweather_hour = \"06-21 12\"\n", "kind = \"perez\""),
        ("[sky]\nkind = \"perez\"\nweather = \"nowhere.epw\"\nweather_hour = \"06-21 12\"\n", "nowhere.epw"),
    ] {
        let toml = write(d, "badw.toml", bad);
        let e = fails(&["run", &obj, "--config", &toml, "--photons", "100"]);
        assert!(e.contains(says), "{bad}: {e}");
    }

    let toml = write(
        d,
        "date.toml",
        "up_axis = \"z\"\n[sun]\ndate = \"2026-06-21 13:00\"\nutc_offset_hours = 2\nlatitude_deg = 52.52\n\
         longitude_deg = 13.40\nnormal_irradiance = 800\n",
    );
    let o = common::run_photons(&obj, &toml, &d.join("out2"), 10_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&d.join("out2"));
    let name = report["lights"][0]["name"].as_str().unwrap().to_string();
    assert!(name.contains("zenith 29.1"), "{name}");
    // A y-up model (the default up_axis): the sky's zenith is +y.
    let obj_y = write(
        d,
        "plane_y.obj",
        "mtllib p.mtl\nusemtl black\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nf 1 2 3\nf 1 3 4\n",
    );
    let toml = write(
        d,
        "uniform.toml",
        "[sky]\nkind = \"uniform\"\nluminance = 1000\n",
    );
    let o = common::run_photons(&obj_y, &toml, &d.join("out3"), 20_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_report(&d.join("out3"));
    let mean = report["meshes"][0]["illuminance_lx"]["mean"]
        .as_f64()
        .unwrap();
    assert!(
        (mean / (1000.0 * std::f64::consts::PI) - 1.0).abs() < 0.01,
        "{mean}"
    );
    for (bad, says) in [
        ("[sun]\ndate = \"21.6.2026 13:00\"\nlatitude_deg = 1\nlongitude_deg = 1\nnormal_illuminance = 1\n", "YYYY-MM-DD"),
        ("[sun]\nazimuth_deg = 1\nzenith_deg = 1\n", "normal_illuminance"),
        ("[sky]\nkind = \"cie\"\ncie_type = 12\nluminance = 1000\n", "needs its sun"),
        ("[sky]\nkind = \"perez\"\nluminance = 1000\n", "perez"),
        ("[sky]\nkind = \"perez\"\nsun_azimuth_deg = 1\nsun_zenith_deg = 30\nluminance = 1000\n", "clearness and brightness"),
        ("[sky]\nkind = \"perez\"\nsun_azimuth_deg = 1\nsun_zenith_deg = 30\ndirect_normal_irradiance = 1\ndiffuse_horizontal_irradiance = 100\n", "day_of_year"),
        ("[sky]\nkind = \"perez\"\nsun_azimuth_deg = 1\nsun_zenith_deg = 30\nday_of_year = 5\ndirect_normal_irradiance = 1\ndiffuse_horizontal_irradiance = 0\n", "no sky"),
        ("[sky]\nkind = \"perez\"\nsun_azimuth_deg = 1\nsun_zenith_deg = 30\nday_of_year = 5\ndirect_normal_irradiance = -1\ndiffuse_horizontal_irradiance = 10\n", "direct_normal_irradiance"),
        ("[sky]\nkind = \"perez\"\nsun_azimuth_deg = 1\nsun_zenith_deg = 30\nclearness = 0.5\nbrightness = 0.1\nluminance = 1\n", "clearness"),
        ("[environment]\nfile = \"nowhere.hdr\"\nscale = 1\n", "nowhere.hdr"),
    ] {
        let toml = write(d, "bad.toml", bad);
        let e = fails(&["run", &obj, "--config", &toml, "--photons", "100"]);
        assert!(e.contains(says), "{bad}: {e}");
    }
}

/// Runs the model at `model` for 20 000 photons with settings `settings` written to
/// `dir/NAME.toml`, into `dir/NAME`: the command's output and the output folder.
fn run_with_settings(
    dir: &Path,
    model: &str,
    name: &str,
    settings: &str,
) -> (std::process::Output, std::path::PathBuf) {
    let toml = write(dir, &format!("{name}.toml"), settings);
    let out = dir.join(name);
    (run_photons(model, &toml, &out, 20_000), out)
}

/// The share of the emitted power the scene absorbed, from a run's report.
fn absorbed_share(out: &Path) -> f64 {
    let r = read_report(out);
    let e = &r["energy_w"];
    e["absorbed"].as_f64().unwrap() / e["emitted"].as_f64().unwrap()
}

/// `[materials.NAME] kind = ...` makes rough surfaces: a rough aluminium floor reflects
/// more than a grey one and absorbs less, a plastic runs too, and a kind without its
/// roughness, a roughness out of (0, 1] or an unknown kind or metal is one line naming
/// the material.
#[test]
fn rough_materials_from_the_settings() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, _, _) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let run = |name: &str, settings: &str| run_with_settings(d.path(), &path, name, settings);
    let (o, grey) = run("grey", "");
    assert!(o.status.success(), "{}", stderr(&o));
    let (o, metal) = run(
        "metal",
        "[materials.grey]\nkind = \"conductor\"\nmetal = \"aluminium\"\nroughness = 0.3\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Aluminium absorbs ~10 % of what it receives, the grey floor 50 %.
    assert!(
        absorbed_share(&metal) < 0.4 * absorbed_share(&grey) && absorbed_share(&metal) > 0.0,
        "{} vs {}",
        absorbed_share(&metal),
        absorbed_share(&grey)
    );
    let (o, _) = run(
        "plastic",
        "[materials.grey]\nkind = \"plastic\"\ndiffuse = 0.5\nior = 1.5\nroughness = [0.1, 0.3]\ntangent = [1, 0, 0]\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for (name, settings, word) in [
        (
            "noalpha",
            "[materials.grey]\nkind = \"conductor\"\nmetal = \"gold\"\n",
            "roughness",
        ),
        (
            "zero",
            "[materials.grey]\nkind = \"conductor\"\nmetal = \"gold\"\nroughness = 0\n",
            "roughness",
        ),
        (
            "velvet",
            "[materials.grey]\nkind = \"velvet\"\nroughness = 0.2\n",
            "velvet",
        ),
        (
            "tin",
            "[materials.grey]\nkind = \"conductor\"\nmetal = \"tin\"\nroughness = 0.2\n",
            "tin",
        ),
        ("loose", "[materials.grey]\nroughness = 0.2\n", "kind"),
    ] {
        let (o, _) = run(name, settings);
        let e = stderr(&o);
        assert!(!o.status.success(), "{name}: {e}");
        assert!(e.contains(word) && e.contains("grey"), "{name}: {e}");
    }
}

/// `scattering_per_m` and `phase_g` in `[materials.NAME]` reach the library: on the
/// scene's open floor made a dielectric they are refused (a medium needs a closed mesh),
/// on a material that is not a dielectric, or with g out of range, they are errors naming
/// the material and the field. A closed box of haze reports what its medium absorbed, and
/// with `[materials.NAME.fluorescence]` in a spectral run it fluoresces.
#[test]
fn a_scattering_medium_from_the_settings() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, _, _) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let run = |name: &str, settings: &str| run_with_settings(d.path(), &path, name, settings);
    let (o, _) = run(
        "opal",
        "[materials.grey]\ndielectric = true\nior = 1.5\nscattering_per_m = 50\nphase_g = 0.5\n",
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("not closed"), "{e}");
    let (o, _) = run("lambert", "[materials.grey]\nscattering_per_m = 50\n");
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("grey") && e.contains("scattering_per_m"), "{e}");
    let (o, _) = run(
        "badg",
        "[materials.grey]\ndielectric = true\nior = 1.5\nscattering_per_m = 50\nphase_g = 1.5\n",
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("grey") && e.contains("phase_g"), "{e}");
    // A closed box of haze under the lamp: report.json gives what its medium absorbed,
    // per band and in lm with errors; the floor, which holds none, has no such entry.
    let (obj, _, _) = scene_obj();
    let mut obj = obj;
    let base = obj.lines().filter(|l| l.starts_with("v ")).count();
    obj.push_str("o haze\nusemtl opal\n");
    for z in [0.2, 1.0] {
        for (x, y) in [(0.5, 0.5), (1.5, 0.5), (1.5, 1.5), (0.5, 1.5)] {
            obj.push_str(&format!("v {x} {y} {z}\n"));
        }
    }
    // Outward faces of the box (vertices 1–4 below, 5–8 above, counted from `base`).
    for f in [
        [1, 3, 2],
        [1, 4, 3],
        [5, 6, 7],
        [5, 7, 8],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 4, 8],
        [3, 8, 7],
        [4, 1, 5],
        [4, 5, 8],
    ] {
        let [a, b, c] = f.map(|i| i + base);
        obj.push_str(&format!("f {a} {b} {c}\n"));
    }
    write(
        d.path(),
        "scene.mtl",
        format!("{MTL}newmtl opal\nKd 0 0 0\n"),
    );
    let path = write(d.path(), "haze.obj", &obj);
    let (o, out) = run_with_settings(
        d.path(),
        &path,
        "haze",
        "[materials.opal]\ndielectric = true\nior = 1.0\nabsorption_per_m = 1\nscattering_per_m = 4\nphase_table = [[0, 3], [90, 1], [180, 1]]\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_report(&out);
    let meshes = r["meshes"].as_array().unwrap();
    let haze = meshes
        .iter()
        .find(|m| m["name"] == "haze")
        .expect("the haze mesh");
    let a = &haze["medium_absorbed"];
    let (lm, sigma) = (a["lm"].as_f64().unwrap(), a["lm_sigma"].as_f64().unwrap());
    // About half the lamp's light enters the box (its top half a metre below the lamp,
    // as wide as it is far) and crosses 0.8 m of haze absorbing 1/m and scattering
    // 4/m: a good part of that is absorbed there (a fifth of the lamp's output).
    let emitted = r["luminous_lm"]["emitted"].as_f64().unwrap();
    assert!(
        lm > 0.1 * emitted && lm < 0.5 * emitted,
        "{lm} of {emitted} lm"
    );
    assert!(sigma > 0.0 && sigma < 0.05 * lm, "σ {sigma} of {lm}");
    assert_eq!(a["w_per_band"].as_array().unwrap().len(), 3);
    // A phase table that stops short of 180°: one line naming the material and why.
    let (o, _) = run_with_settings(
        d.path(),
        &path,
        "short",
        "[materials.opal]\ndielectric = true\nior = 1.0\nscattering_per_m = 4\nphase_table = [[0, 3], [90, 1]]\n",
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("opal") && e.contains("from 0 to 180"), "{e}");
    let floor = meshes
        .iter()
        .find(|m| m["medium_absorbed"].is_null())
        .expect("a mesh without a medium");
    assert_ne!(floor["name"], "haze");
    // The same box fluorescing in a spectral run: it re-emits at longer wavelengths what
    // its medium absorbs at shorter ones, and the balance holds.
    let (o, out) = run_with_settings(
        d.path(),
        &path,
        "glowing",
        "[spectral]\nbands = 5\n[materials.opal]\ndielectric = true\nior = 1.0\nabsorption_per_m = [4, 2, 0, 0, 0]\nscattering_per_m = 1\n[materials.opal.fluorescence]\nexcitation = [1, 1, 0, 0, 0]\nquantum_yield = 0.8\nemission = [0, 0, 1, 2, 1]\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_report(&out);
    let e = &r["energy_w"];
    let f = |k: &str| e[k].as_f64().unwrap();
    assert!(f("fluoresced") > 0.02 * f("emitted"), "{e}");
    let off = f("emitted") + f("fluoresced") - f("absorbed") - f("escaped") - f("dropped");
    assert!(off.abs() < 1e-9 * f("emitted"), "balance off by {off}");
}

/// `[materials.NAME.fluorescence]`: a spectral run's floor re-emits at longer wavelengths
/// what it absorbs at shorter ones (report.json's `fluoresced`, per band only above the
/// first band, and the balance emitted + fluoresced = absorbed + escaped + dropped); an RGB
/// run refuses it naming the material and spectral bands.
#[test]
fn a_fluorescent_floor_from_the_settings() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, _, _) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let fl = "[materials.grey.fluorescence]\nexcitation = [0.8, 0.4, 0, 0, 0]\nquantum_yield = 0.9\nemission = [0, 0, 1, 2, 1]\n";
    let (o, out) = run_with_settings(
        d.path(),
        &path,
        "spectral",
        &format!("[spectral]\nbands = 5\n[materials.grey]\ndiffuse = 0.1\n{fl}"),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_report(&out);
    let e = &r["energy_w"];
    let f = |k: &str| e[k].as_f64().unwrap();
    assert!(f("fluoresced") > 0.02 * f("emitted"), "{e}");
    let off = f("emitted") + f("fluoresced") - f("absorbed") - f("escaped") - f("dropped");
    assert!(off.abs() < 1e-9 * f("emitted"), "balance off by {off}");
    let per_band: Vec<f64> = r["energy_w_per_band"]["fluoresced"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(per_band[0], 0.0, "{per_band:?}");
    assert!(
        per_band[3] > per_band[2] && per_band[3] > per_band[4],
        "{per_band:?}"
    );
    let grey =
        "[materials.grey.fluorescence]\nexcitation = 0.5\nquantum_yield = 0.9\nemission = 1\n";
    let (o, _) = run_with_settings(d.path(), &path, "rgb", grey);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(e.contains("grey") && e.contains("spectral"), "{e}");
}

/// `kind = "bsdf-xml"`: a window BSDF file (Klems quarter basis) that reflects 0.2
/// diffusely from its front makes the floor absorb 0.8 of what it receives against the
/// grey floor's 0.5, and so does `kind = "table"` with the same law in a values file; a
/// missing file, a bad value (file and line), a wrong count and stray fields are errors.
#[test]
fn a_window_bsdf_file_from_the_settings() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, _, _) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let value = 0.2 / std::f64::consts::PI;
    let data: Vec<String> = (0..41 * 41).map(|_| format!("{value}")).collect();
    let xml = format!(
        "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>\n<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>\n<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength>\n<WavelengthDataBlock><WavelengthDataDirection>Reflection Front</WavelengthDataDirection>\n<ColumnAngleBasis>LBNL/Klems Quarter</ColumnAngleBasis><RowAngleBasis>LBNL/Klems Quarter</RowAngleBasis>\n<ScatteringData>{}</ScatteringData></WavelengthDataBlock></WavelengthData></Layer></Optical></WindowElement>\n",
        data.join(",\n")
    );
    std::fs::create_dir(d.path().join("bsdf")).unwrap();
    write(&d.path().join("bsdf"), "matte.xml", &xml);
    let run = |name: &str, settings: &str| run_with_settings(d.path(), &path, name, settings);
    let (o, grey) = run("grey", "");
    assert!(o.status.success(), "{}", stderr(&o));
    let (o, xml) = run(
        "xml",
        "[materials.grey]\nkind = \"bsdf-xml\"\nfile = \"bsdf/matte.xml\"\nup = [0, 1, 0]\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The lamp (black) takes back some of what the floor reflects: 1.6 less a little.
    let ratio = absorbed_share(&xml) / absorbed_share(&grey);
    assert!((1.45..1.65).contains(&ratio), "absorbed ratio {ratio}");
    // The same matte floor as a measured table read from a file (3 × 1 × 4 × 6 values).
    let lambert: Vec<String> = (0..72).map(|_| format!("{value}")).collect();
    write(
        &d.path().join("bsdf"),
        "matte.txt",
        format!("# rho 0.2\n{}\n", lambert.join(" ")),
    );
    let (o, tab) = run(
        "table",
        "[materials.grey]\nkind = \"table\"\ngrid = [3, 1, 4, 6]\nbrdf = \"bsdf/matte.txt\"\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let table_ratio = absorbed_share(&tab) / absorbed_share(&grey);
    assert!(
        (1.45..1.65).contains(&table_ratio),
        "table: absorbed ratio {table_ratio}"
    );
    write(&d.path().join("bsdf"), "bad.txt", "0.1 0.1\n0.1 zero\n");
    for (name, settings, word) in [
        (
            "missing",
            "[materials.grey]\nkind = \"bsdf-xml\"\nfile = \"nothing.xml\"\n",
            "nothing.xml",
        ),
        ("nofile", "[materials.grey]\nkind = \"bsdf-xml\"\n", "file"),
        (
            "stray",
            "[materials.grey]\nkind = \"bsdf-xml\"\nfile = \"bsdf/matte.xml\"\nroughness = 0.2\n",
            "roughness",
        ),
        (
            "noxml",
            "[materials.grey]\nfile = \"bsdf/matte.xml\"\n",
            "bsdf-xml",
        ),
        (
            "badtable",
            "[materials.grey]\nkind = \"table\"\ngrid = [3, 1, 4, 6]\nbrdf = \"bsdf/bad.txt\"\n",
            "bad.txt:2: [materials.grey] 'zero'",
        ),
        (
            "shorttable",
            "[materials.grey]\nkind = \"table\"\ngrid = [3, 1, 4, 7]\nbrdf = \"bsdf/matte.txt\"\n",
            "84",
        ),
        (
            "nogrid",
            "[materials.grey]\nkind = \"table\"\nbrdf = \"bsdf/matte.txt\"\n",
            "grid",
        ),
    ] {
        let (o, _) = run(name, settings);
        let e = stderr(&o);
        assert!(!o.status.success(), "{name}: {e}");
        assert!(e.contains(word), "{name}: {e}");
    }
}

/// `[medium]`: haze around the model absorbs light (report.json says how much, with its
/// error, and the balance holds with it; a clear scene's report has none); a medium without
/// coefficients and a wrong count name `[medium]` and its line.
#[test]
fn a_hazy_scene_from_the_settings() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "scene.mtl", MTL);
    let (obj, _, _) = scene_obj();
    let path = write(d.path(), "scene.obj", &obj);
    let run = |name: &str, settings: &str| run_with_settings(d.path(), &path, name, settings);
    let (o, clear) = run("clear", "");
    assert!(o.status.success(), "{}", stderr(&o));
    let (o, hazy) = run(
        "hazy",
        "[medium]\nabsorption_per_m = 0.2\nscattering_per_m = [0.5, 0.4, 0.3]\nphase_g = 0.6\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (c, h) = (read_report(&clear), read_report(&hazy));
    assert!(
        c["scene_medium_absorbed"].is_null(),
        "{}",
        c["scene_medium_absorbed"]
    );
    let a = &h["scene_medium_absorbed"];
    let lm = a["lm"].as_f64().unwrap();
    assert!(
        lm > 0.0 && a["lm_sigma"].as_f64().unwrap() < 0.1 * lm,
        "{a}"
    );
    let e = &h["energy_w"];
    let f = |k: &str| e[k].as_f64().unwrap();
    let off = f("emitted") - f("absorbed") - f("escaped") - f("dropped");
    assert!(off.abs() < 1e-9 * f("emitted"), "balance off by {off}");
    let haze_w: f64 = a["w_per_band"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .sum();
    assert!(
        haze_w > 0.0 && haze_w < f("absorbed"),
        "{haze_w} of {}",
        f("absorbed")
    );
    for (settings, want) in [
        (
            "[medium]\nphase_g = 0.5\n",
            "neither absorption_per_m nor scattering_per_m",
        ),
        (
            "[medium]\nabsorption_per_m = [1, 2]\n",
            "absorption_per_m has 2 values",
        ),
        ("[medium]\nscattering_per_m = -1\n", "scattering_per_m[0]"),
    ] {
        let (o, _) = run("bad", settings);
        let e = stderr(&o);
        assert!(!o.status.success(), "{settings}: {e}");
        assert!(
            e.contains("bad.toml:1: [medium]") && e.contains(want),
            "{e}"
        );
    }
}

/// A .wea file (48° N, 11° E) of `rows` ("month day hour DNI DHI" lines) in `d`, and each
/// row's sky-vector horizontal illuminance (Tregenza patches, the sun in its patch).
fn overcast_hours(d: &Path, rows: &str) -> (String, Vec<f64>) {
    let wea = write(
        d,
        "w.wea",
        format!(
            "place Test\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
             weather_data_file_units 1\n{rows}"
        ),
    );
    let weather = imap::weather::read_wea(Path::new(&wea)).unwrap();
    let sky = imap::annual::AnnualSky::from_weather(
        &weather,
        1,
        imap::annual::SunInVectors::InItsPatch,
        0.2,
    )
    .unwrap();
    let ps = &sky.patches;
    let e = (0..sky.hours.len())
        .map(|h| {
            let v = sky.vector(h);
            (1..ps.count()).map(|p| v[p] * ps.horizontal(p)).sum()
        })
        .collect();
    (wea, e)
}

#[test]
fn annual_electric_light_dims_with_the_daylight_to_the_energy_it_leaves() {
    // The open grid of the test below under four overcast hours (occupied), and a point
    // light of 2000 cd 2 m above its middle: E_el = I z / d³ at each point. The target is
    // the first hour's daylight plus half the electric light, so in that hour the lights
    // dim to half output and in the three brighter hours to their minimum (or off).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A black triangle beside and below the grid: a small scene, whose sky photons land
    // densely on the grid.
    write(d, "near.mtl", "newmtl black\nKd 0 0 0\n");
    let o = write(
        d,
        "near.obj",
        "mtllib near.mtl\no near\nusemtl black\nv 2 2 -1\nv 2.1 2 -1\nv 2 2.1 -1\nf 1 2 3\n",
    );
    let grid = "[[grid]]\nname = \"open\"\norigin = [-1, -1, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [2, 2]\nspacing = 1\n";
    let s = write(
        d,
        "settings.toml",
        format!("up_axis = \"z\"\n[run]\nseed = 5\n[[light]]\nkind = \"point\"\nposition = [0, 0, 2]\namount = 2000\nunit = \"cd\"\n{grid}"),
    );
    let (wea, e) = overcast_hours(
        d,
        "6 21 9.5 0 10\n6 21 10.5 0 50\n6 21 11.5 0 100\n6 21 12.5 0 200\n",
    );
    // Every point is as far from the light: 2 m up, 0.5 m off in x and y. A grid point
    // reads its vertex's share of the mesh, I z / d³ weighted by the vertex's hat function
    // over the neighbouring cells (±1 spacing): integrated here (bilinear hat, 1 %).
    let el = {
        let n = 200;
        let (mut sum, mut weights) = (0.0, 0.0);
        for i in 0..n {
            for j in 0..n {
                let (u, v) = (
                    (i as f64 + 0.5) / n as f64 * 2.0 - 1.0,
                    (j as f64 + 0.5) / n as f64 * 2.0 - 1.0,
                );
                let w = (1.0 - u.abs()) * (1.0 - v.abs());
                let (x, y) = (0.5 + u, 0.5 + v);
                sum += w * 2000.0 * 2.0 / (x * x + y * y + 4.0).powf(1.5);
                weights += w;
            }
        }
        sum / weights
    };
    let target = e[0] + 0.5 * el;
    assert!(e[1] > target + el, "{e:?}");
    // EnergyPlus's continuous dimming at its defaults (20 % output at 30 % power): half
    // output draws 0.3 + 0.7 · 0.3 / 0.8 of 1000 W, the minimum 0.3.
    let half = 0.3 + 0.7 * 0.3 / 0.8;
    for (control, want) in [
        ("continuous", half + 3.0 * 0.3),
        ("continuous-off", half),
        ("stepped:4", 0.5),
    ] {
        let out = d.join(control.replace(':', "_"));
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &wea,
            "--photons",
            "1000000",
            "--lighting-target",
            &target.to_string(),
            "--lighting-power",
            "1000",
            "--lighting-control",
            control,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        assert!(
            String::from_utf8_lossy(&r.stdout).contains("grid open: electric light to"),
            "{}",
            String::from_utf8_lossy(&r.stdout)
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap())
                .unwrap();
        let l = &json["grids"][0]["lighting"];
        let f = |v: &serde_json::Value| v.as_f64().unwrap();
        // The electric light the photosensor reads, within its error of I z / d³, and the
        // energy within its stated error of the exact year's (4 kWh undimmed).
        let sensor = l["sensor"].as_u64().unwrap() as usize;
        assert!(sensor < 4, "{l}");
        assert!(
            (f(&l["electric_lx_at_sensor"]) - el).abs() < 0.02 * el,
            "{el}: {l}"
        );
        let energy = &l["energy_kwh"];
        let (kwh, sigma) = (f(&energy["value"]), f(&energy["sigma"]));
        assert!(
            sigma > 0.0 && (kwh - want).abs() < 4.0 * sigma + 1e-3,
            "{control}: {l}"
        );
        assert!(
            f(&energy["interval_95"][0]) <= kwh && kwh <= f(&energy["interval_95"][1]),
            "{l}"
        );
        assert_eq!(f(&l["full_kwh"]), 4.0, "{l}");
        // Daylight and the dimmed light reach the target at every point in every hour
        // (the points are alike), except where the lights switch off.
        let at = f(&l["mean_at_target"]);
        if control == "continuous-off" {
            assert_eq!(l["hours_off"], 3, "{l}");
        }
        assert!(at > 0.74, "{control}: {l}");
        let csv = std::fs::read_to_string(out.join("annual_open.csv")).unwrap();
        assert!(
            csv.lines()
                .next()
                .unwrap()
                .ends_with(",electric_lx,electric_sigma,at_target"),
            "{csv}"
        );
        let report = std::fs::read_to_string(out.join("annual_report.md")).unwrap();
        assert!(report.contains("Electric light with daylight"), "{report}");
    }
    // Lights without --lighting-target, and a zone without its power or photosensor, are
    // named.
    let common = [
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        &wea,
        "--photons",
        "1000",
    ];
    for (extra, text) in [
        (vec![], "give --lighting-target and --lighting-power"),
        (vec!["--lighting-target", "500"], "needs --lighting-power"),
        (
            vec![
                "--lighting-target",
                "500",
                "--lighting-power",
                "100",
                "--lighting-sensor",
                "4",
            ],
            "--lighting-sensor 4: grid open has 4 points",
        ),
        (
            vec![
                "--lighting-target",
                "500",
                "--lighting-power",
                "100",
                "--lighting-control",
                "dim",
            ],
            "--lighting-control \"dim\"",
        ),
        (
            vec!["--lighting-target=-5", "--lighting-power", "100"],
            "--lighting-target -5",
        ),
    ] {
        let mut args: Vec<&str> = common.to_vec();
        args.extend(extra);
        let out = d.join("bad");
        let out = out.to_str().unwrap();
        args.extend(["--out", out, "--quiet"]);
        let e = fails(&args);
        assert!(e.contains(text), "{e}");
    }
}

#[test]
fn annual_metrics_of_an_open_grid_follow_the_hours_light() {
    // An open horizontal grid under four overcast hours of 10–200 W/m² diffuse light:
    // each point's coefficient for patch p is ∫_p cos dω, so each hour reads the sky
    // vector's horizontal illuminance, and DA at a threshold counts the hours above it.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = far_triangle(d);
    let s = write(
        d,
        "settings.toml",
        "up_axis = \"z\"\n[run]\nseed = 3\n[[grid]]\nname = \"open\"\norigin = [-1, -1, 0]\n\
         u = [1, 0, 0]\nv = [0, 1, 0]\nsize = [2, 2]\nspacing = 1\n",
    );
    let (wea, e) = overcast_hours(
        d,
        "6 21 3.5 0 0\n6 21 9.5 0 10\n6 21 10.5 0 50\n6 21 11.5 0 100\n6 21 12.5 0 200\n",
    );
    assert!(e[0] == 0.0 && e[1] > 500.0 && e[4] > 3.0 * e[2], "{e:?}");
    for (threshold, da) in [
        (0.5 * (e[2] + e[3]), 0.5),
        (0.5 * (e[1] + e[2]), 0.75),
        (2.0 * e[4], 0.0),
    ] {
        let out = d.join(format!("out{threshold:.0}"));
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &wea,
            "--photons",
            "2000000",
            "--threshold",
            &threshold.to_string(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap())
                .unwrap();
        let g = &json["grids"][0];
        assert_eq!(g["occupied_hours"], 4, "{json}");
        // The two brightest of the five hours are EN 17037's daylight hours, 6–12 klx on
        // the open grid: the high level.
        assert_eq!(g["en17037"]["daylight_hours"], 2, "{json}");
        assert_eq!(g["en17037"]["level"], "high", "{json}");
        let sda = g["sda"]["value"].as_f64().unwrap();
        assert_eq!(sda, if da >= 0.5 { 1.0 } else { 0.0 }, "{json}");
        let interval = &g["sda"]["interval_95"];
        assert!(interval[0].as_f64().unwrap() <= sda && sda <= interval[1].as_f64().unwrap());
        let csv = std::fs::read_to_string(out.join("annual_open.csv")).unwrap();
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 4);
        // The pictures: each metric on the grid, and the temporal map (366 days × 2 px
        // by 24 hours × 10 px and the colour bar).
        for name in ["da", "sda_probability", "udi_useful", "df", "ase_hours"] {
            let p = out.join(format!("annual_open_{name}.png"));
            assert!(
                std::fs::metadata(&p)
                    .map(|m| m.len() > 100)
                    .unwrap_or(false),
                "{p:?}"
            );
        }
        // The report: the grid's metrics with their intervals, EN 17037's table, the
        // pictures.
        let report = std::fs::read_to_string(out.join("annual_report.md")).unwrap();
        for want in [
            "## Grid open: 4 points, 4 occupied hours",
            "| sDA",
            "EN 17037 over 2 daylight hours: level **high**",
            "![DA](annual_open_da.png)",
        ] {
            assert!(report.contains(want), "{want}: {report}");
        }
        let png = std::fs::read(out.join("annual_open_temporal.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let (w, h) = (
            u32::from_be_bytes(png[16..20].try_into().unwrap()),
            u32::from_be_bytes(png[20..24].try_into().unwrap()),
        );
        assert_eq!((w, h), (732, 240 + 82), "temporal map {w} × {h}");
        for row in &rows {
            assert_eq!(row[3], da, "threshold {threshold}: {csv}");
            // An open point's daylight factor is 100 %, within its stated error.
            let (df, sigma) = (row[10], row[11]);
            assert!(sigma > 0.0 && (df - 1.0).abs() < 4.0 * sigma, "{csv}");
        }
    }
    // Too few photons: the command and the report say that the points' light is poorly
    // known (a point no photon reached reads 0 with an error of 0).
    let out = d.join("few");
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        &wea,
        "--photons",
        "2000",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(
        stderr(&r).contains("their metrics are not to be trusted"),
        "{}",
        stderr(&r)
    );
    let report = std::fs::read_to_string(out.join("annual_report.md")).unwrap();
    assert!(report.contains("**Warning**"), "{report}");
    // Reinhart MF:2's 577 patches and the ground, traced in three runs of light groups:
    // the same hours' light, so the same DA, and an open point's daylight factor 100 %.
    let out = d.join("mf2");
    let threshold = 0.5 * (e[1] + e[2]);
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        &wea,
        "--photons",
        "1000000",
        "--mf",
        "2",
        "--threshold",
        &threshold.to_string(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap()).unwrap();
    assert_eq!(json["patches"], "Reinhart MF:2 (577 + ground)", "{json}");
    let csv = std::fs::read_to_string(out.join("annual_open.csv")).unwrap();
    for row in csv.lines().skip(1) {
        let row: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(row[3], 0.75, "{csv}");
        let (df, sigma) = (row[10], row[11]);
        assert!(sigma > 0.0 && (df - 1.0).abs() < 4.0 * sigma, "{csv}");
    }
    for (mf, text) in [("0", "mf = 0"), ("17", "mf = 17")] {
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &wea,
            "--photons",
            "1000",
            "--mf",
            mf,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(
            !r.status.success() && stderr(&r).contains(text),
            "{}",
            stderr(&r)
        );
    }
    let read = |out: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap()).unwrap()
    };
    // One sunny hour: every point has the sun's E_n cos Z, over 1000 lx, in its one
    // occupied hour; ASE counts the points with more such hours than --ase-hours.
    let sunny = write(
        d,
        "sun.wea",
        "place Test\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
         weather_data_file_units 1\n6 21 12.5 600 100\n",
    );
    for (ase_hours, ase_lx, want) in [("0", "1000", 1.0), ("1", "1000", 0.0), ("0", "1e6", 0.0)] {
        let out = d.join(format!("ase{ase_hours}-{ase_lx}"));
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &sunny,
            "--photons",
            "200000",
            "--ase-hours",
            ase_hours,
            "--ase-lx",
            ase_lx,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap())
                .unwrap();
        assert_eq!(json["grids"][0]["ase"]["value"], want, "{json}");
        let csv = std::fs::read_to_string(out.join("annual_open.csv")).unwrap();
        for line in csv.lines().skip(1) {
            let hours: usize = line.split(',').nth(9).unwrap().parse().unwrap();
            assert_eq!(hours, usize::from(ase_lx == "1000"), "{csv}");
        }
    }
    // --target-sda: at 300 lx every point passes once its coefficients are known to a few
    // tens of per cent (a few rounds of doubling photons); at a threshold between two
    // hours' illuminance the points sit on sDA's 50 % and two seconds cannot pin it to
    // ± 1 %: rounds until the time is out.
    for (threshold, target, time, reached) in [
        ("300".to_string(), "0.05", "20", true),
        ((0.5 * (e[2] + e[3])).to_string(), "0.01", "2", false),
    ] {
        let out = d.join(format!("target{reached}"));
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &wea,
            "--photons",
            "50000",
            "--time",
            time,
            "--target-sda",
            target,
            "--threshold",
            &threshold,
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        let json = read(&out);
        let t = &json["target_sda"];
        assert_eq!(t["reached"], reached, "{json}");
        let rounds = t["rounds"].as_u64().unwrap();
        let photons = json["photons"].as_u64().unwrap();
        // Each round doubles the photons; the time's end may cut the last short.
        assert!(
            rounds == 1 || photons > 50_000 << rounds.saturating_sub(2),
            "{json}"
        );
        assert!(photons <= 50_000 << (rounds - 1), "{json}");
        let i = &json["grids"][0]["sda"]["interval_95"];
        let half = 0.5 * (i[1].as_f64().unwrap() - i[0].as_f64().unwrap());
        if reached {
            assert!(half <= 0.05, "{json}");
        } else {
            assert!(rounds >= 2 && half > 0.01, "{json}");
        }
    }
    // --target-en17037: one lit hour (the daylight hour: the brightest half of two) whose
    // open points read 2000 lx meets every level once the points' coefficients are known
    // to some tens of per cent (a few rounds); at 750 lx, the high level's target, half
    // the points fall short in each draw and the target share is 0 or 1: the rounds go
    // on until --time.
    let lit_hour = |w: f64| {
        format!(
            "place Test\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
             weather_data_file_units 1\n6 21 2.5 0 0\n6 21 11.5 0 {w}\n"
        )
    };
    let e_h = |w: f64| {
        let weather = imap::weather::parse_wea(&lit_hour(w), "t.wea").unwrap();
        let sky = imap::annual::AnnualSky::from_weather(
            &weather,
            1,
            imap::annual::SunInVectors::Left,
            0.2,
        )
        .unwrap();
        sky.hours[1].diffuse_horizontal_lx
    };
    for (lx, reached) in [(2000.0, true), (750.0, false)] {
        // The diffuse irradiance that gives `lx` (the Perez efficacy depends on it).
        let (mut lo, mut hi) = (0.1, 100.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if e_h(mid) < lx {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        assert!((e_h(hi) / lx - 1.0).abs() < 1e-6, "{}", e_h(hi));
        let w = write(d, &format!("en{lx}.wea"), lit_hour(hi));
        let out = d.join(format!("en{lx}"));
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &w,
            "--photons",
            "50000",
            "--time",
            "3",
            "--target-en17037",
            "0.1",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        let json = read(&out);
        let t = &json["target_en17037"];
        assert_eq!(t["reached"], reached, "{json}");
        let rounds = t["rounds"].as_u64().unwrap();
        let high = &json["grids"][0]["en17037"]["levels"][2];
        assert_eq!(high["name"], "high", "{json}");
        let i = &high["target_interval_95"];
        let half = 0.5 * (i[1].as_f64().unwrap() - i[0].as_f64().unwrap());
        if reached {
            assert!(half <= 0.1, "{json}");
        } else {
            assert!(rounds >= 2 && half > 0.1, "{json}");
        }
    }
    // --target-udi: the hour at 2000 lx is useful daylight at every point, far enough
    // from 100 and 3000 lx that the draws rarely cross: the bands' intervals close.
    let out = d.join("udi");
    let w = d.join("en2000.wea");
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        w.to_str().unwrap(),
        "--photons",
        "50000",
        // (Reached in about 3 s on two free cores; the rest is for cores shared with the
        // other tests: the rounds stop as soon as it is.)
        "--time",
        "12",
        "--target-udi",
        "0.1",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let json = read(&out);
    assert_eq!(json["target_udi"]["reached"], true, "{json}");
    let g = &json["grids"][0];
    let (u, i) = (&g["mean_udi"], &g["mean_udi_interval_95"]);
    for b in 0..3 {
        let (lo, hi, x) = (
            i[b][0].as_f64().unwrap(),
            i[b][1].as_f64().unwrap(),
            u[b].as_f64().unwrap(),
        );
        assert!(lo <= x && x <= hi && hi - lo <= 0.2, "{json}");
    }
    assert!(u[1].as_f64().unwrap() > 0.9, "{json}");
    // LM-83's blinds: with a blinds-closed model (here the same settings, so the same
    // coefficients), the sunny hour has every point in the sun: the blinds close in it,
    // and the metrics are those without blinds.
    let mut runs = Vec::new();
    for shaded in [false, true] {
        let out = d.join(format!("blinds{shaded}"));
        let mut args = vec![
            "annual",
            &o,
            "--config",
            &s,
            "--weather",
            &sunny,
            "--photons",
            "100000",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ];
        if shaded {
            args.extend(["--shaded", &s]);
        }
        let r = imap(&args);
        assert!(r.status.success(), "{}", stderr(&r));
        runs.push(read(&out));
    }
    assert_eq!(
        runs[0]["grids"][0]["blinds_closed_hours"],
        serde_json::Value::Null
    );
    assert_eq!(runs[1]["grids"][0]["blinds_closed_hours"], 1, "{}", runs[1]);
    // (Their draws differ: the closed hour's coefficients are drawn on their own.)
    assert_eq!(
        runs[0]["grids"][0]["sda"]["value"],
        runs[1]["grids"][0]["sda"]["value"]
    );
    assert_eq!(
        runs[0]["grids"][0]["mean_da"],
        runs[1]["grids"][0]["mean_da"]
    );
    // With a target, both models' runs trace their rounds.
    let out = d.join("blinds-target");
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        &sunny,
        "--shaded",
        &s,
        "--photons",
        "20000",
        "--target-udi",
        "0.001",
        "--time",
        "3",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let t = read(&out);
    assert!(t["target_udi"]["rounds"].as_u64().unwrap() >= 2, "{t}");
    assert_eq!(t["grids"][0]["blinds_closed_hours"], 1, "{t}");
    // Bad inputs, one line each.
    let with_light = write(d, "light.toml", "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\npower = 1\n[[grid]]\norigin = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [1, 1]\n");
    let no_grid = write(d, "nogrid.toml", "up_axis = \"z\"\n");
    let bad_wea = write(d, "bad.wea", "place x\nlatitude 48\nlongitude 0\ntime_zone 0\nsite_elevation 0\nweather_data_file_units 1\n6 31 12 0 10\n");
    for (args, says) in [
        (
            vec![
                "annual",
                &o,
                "--config",
                &with_light,
                "--weather",
                &wea,
                "--photons",
                "10",
            ],
            "leave them out",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &no_grid,
                "--weather",
                &wea,
                "--photons",
                "10",
            ],
            "[[grid]]",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &bad_wea,
                "--photons",
                "10",
            ],
            "bad.wea:7",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &wea,
                "--photons",
                "10",
                "--occupied",
                "18-8",
            ],
            "--occupied",
        ),
        (
            vec!["annual", &o, "--config", &s, "--weather", &wea],
            "--photons or --time",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &wea,
                "--photons",
                "10",
                "--target-sda",
                "0.01",
            ],
            "--target-sda needs --time",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &wea,
                "--time",
                "1",
                "--target-sda",
                "2",
            ],
            "--target-sda 2",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &wea,
                "--photons",
                "1000",
                "--shaded",
                &no_grid,
            ],
            "[[grid]]",
        ),
        (
            vec![
                "annual",
                &o,
                "--config",
                &s,
                "--weather",
                &wea,
                "--photons",
                "10",
                "--ase-lx=-5",
            ],
            "--ase-lx",
        ),
    ] {
        let e = fails(&args);
        assert!(e.contains(says), "{args:?}: {e}");
    }
}

/// A 4 × 4 × 3 m room (z up) lit through two 1 m skylights, each an object of its own
/// drawn as an opening (a pass-through surface): "sky_a" at x 0.5–1.5, y 1–2 and "sky_b"
/// at x 2.5–3.5, y 3–3.8, the ceiling drawn round them; walls 0.5, floor 0.2.
fn skylit_room(d: &Path) -> String {
    write(
        d,
        "room.mtl",
        "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl floor\nKd 0.2 0.2 0.2\nnewmtl open\nKd 0 0 0\nd 0\n",
    );
    let mut v = Vec::new();
    let mut f = String::new();
    let mut quad = |name: &str, mtl: &str, p: [[f64; 3]; 4]| {
        f += &format!("o {name}\nusemtl {mtl}\n");
        let base = v.len() + 1;
        v.extend(p);
        f += &format!("f {} {} {} {}\n", base, base + 1, base + 2, base + 3);
    };
    // The ceiling (facing down) in rectangles round the two openings.
    let ceiling = |x0: f64, x1: f64, y0: f64, y1: f64| {
        [[x0, y0, 3.0], [x0, y1, 3.0], [x1, y1, 3.0], [x1, y0, 3.0]]
    };
    for (i, r) in [
        (0.0, 4.0, 0.0, 1.0),
        (0.0, 0.5, 1.0, 2.0),
        (1.5, 4.0, 1.0, 2.0),
        (0.0, 4.0, 2.0, 3.0),
        (0.0, 2.5, 3.0, 3.8),
        (3.5, 4.0, 3.0, 3.8),
        (0.0, 4.0, 3.8, 4.0),
    ]
    .iter()
    .enumerate()
    {
        quad(&format!("ceiling{i}"), "wall", ceiling(r.0, r.1, r.2, r.3));
    }
    quad("sky_a", "open", ceiling(0.5, 1.5, 1.0, 2.0));
    quad("sky_b", "open", ceiling(2.5, 3.5, 3.0, 3.8));
    let (o, x, t) = (0.0, 4.0, 3.0);
    for (name, mtl, p) in [
        (
            "floor",
            "floor",
            [[o, o, o], [x, o, o], [x, x, o], [o, x, o]],
        ),
        (
            "south",
            "wall",
            [[o, o, o], [o, o, t], [x, o, t], [x, o, o]],
        ),
        (
            "north",
            "wall",
            [[o, x, o], [x, x, o], [x, x, t], [o, x, t]],
        ),
        ("west", "wall", [[o, o, o], [o, x, o], [o, x, t], [o, o, t]]),
        ("east", "wall", [[x, o, o], [x, o, t], [x, x, t], [x, x, o]]),
    ] {
        quad(name, mtl, p);
    }
    let mut obj = String::from("mtllib room.mtl\n");
    for p in &v {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    obj += &f;
    write(d, "room.obj", obj)
}

#[test]
fn annual_window_groups_add_up_and_follow_their_rules() {
    // The skylit room under two overcast hours and one sunny one (June 21 at 12:30, the
    // sun about 26° from the zenith toward SSW): A's sun falls on four of the 64 points
    // (more than LM-83's 2 %), B's on the north wall.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = skylit_room(d);
    let grid =
        "up_axis = \"z\"\n[run]\nseed = 5\n[[grid]]\nname = \"desk\"\norigin = [0, 0, 0.85]\n\
                u = [1, 0, 0]\nv = [0, 1, 0]\nsize = [4, 4]\nspacing = 0.5\n\
                [materials.diffuser]\ndiffuse = 0.1\ntransmit = 0.4\n";
    let group = |name: &str, rule: &str| {
        format!(
            "[[window_group]]\nname = \"{name}\"\nobjects = [\"sky_{name}\"]\nstates = [\"as-drawn\", \"diffuser\"]\n{rule}"
        )
    };
    let plain = write(d, "plain.toml", grid);
    let both = write(
        d,
        "both.toml",
        format!(
            "{grid}{}{}",
            group("a", ""),
            group("b", "rule = \"direct-sun\"\n")
        ),
    );
    let wea = write(
        d,
        "w.wea",
        "place Test\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
         weather_data_file_units 1\n6 21 3.5 0 0\n6 21 9.5 0 60\n6 21 10.5 0 120\n6 21 12.5 600 100\n",
    );
    let run = |settings: &str, out: &str| -> Result<serde_json::Value, String> {
        let out = d.join(out);
        let r = imap(&[
            "annual",
            &o,
            "--config",
            settings,
            "--weather",
            &wea,
            "--photons",
            "100000",
            "--threshold",
            "3000",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        if !r.status.success() {
            return Err(stderr(&r));
        }
        let csv = std::fs::read_to_string(out.join("annual_desk.csv")).unwrap();
        let mut json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap())
                .unwrap();
        json["csv"] = serde_json::Value::String(csv);
        Ok(json)
    };
    let whole = run(&plain, "plain").unwrap();
    let grouped = run(&both, "groups").unwrap();
    // Each group follows its own sun: A closes in the sunny hour, B stays open.
    let g = &grouped["grids"][0];
    let hours = |w: usize| -> Vec<u64> {
        g["window_groups"][w]["states"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["occupied_hours"].as_u64().unwrap())
            .collect()
    };
    assert_eq!(hours(0), vec![2, 1], "{g}");
    assert_eq!(hours(1), vec![3, 0], "{g}");
    // The groups' states 0 add up to the whole model: the daylight factor point by point
    // within the two runs' errors.
    let df = |j: &serde_json::Value| -> Vec<(f64, f64)> {
        let csv = j["csv"].as_str().unwrap();
        let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let (i, s) = (
            head.iter().position(|h| *h == "df").unwrap(),
            head.iter().position(|h| *h == "df_sigma").unwrap(),
        );
        csv.lines()
            .skip(1)
            .map(|l| {
                let x: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                (x[i], x[s])
            })
            .collect()
    };
    let (a, b) = (df(&whole), df(&grouped));
    assert_eq!(a.len(), 64);
    let z: Vec<f64> = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x.0 - y.0) / (x.1 * x.1 + y.1 * y.1).sqrt())
        .collect();
    let worst = z.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mean_z2 = z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64;
    let (sa, sb) = (
        a.iter().map(|x| x.0).sum::<f64>(),
        b.iter().map(|x| x.0).sum::<f64>(),
    );
    let rel = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x.0 - y.0).abs() / x.0.max(1e-12))
        .fold(0.0f64, f64::max);
    eprintln!("daylight factor, whole vs groups: sums {sa:.5} {sb:.5}, worst |z| {worst:.2}, mean z² {mean_z2:.2}, largest relative difference {rel:.1e}");
    assert!(
        worst < 4.5 && mean_z2 < 2.0,
        "worst |z| {worst}, mean z² {mean_z2}"
    );
    assert!((sa / sb - 1.0).abs() < 0.03, "{sa} {sb}");
    // A schedule keeps B closed; a window in no group is refused, named.
    let schedule = write(d, "b.txt", "# B's state per weather row\n1\n1\n1\n1\n");
    let sched = write(
        d,
        "sched.toml",
        format!(
            "{grid}{}{}",
            group("a", ""),
            group("b", "rule = \"schedule\"\nschedule = \"b.txt\"\n")
        ),
    );
    assert!(schedule.ends_with("b.txt"));
    let s = run(&sched, "sched").unwrap();
    let sh = &s["grids"][0]["window_groups"][1]["states"];
    assert_eq!(sh[1]["occupied_hours"], 3, "{s}");
    let cda = |j: &serde_json::Value| j["grids"][0]["mean_cda"].as_f64().unwrap();
    eprintln!(
        "mean cDA at 3000 lx: B as drawn {:.4}, B's diffuser {:.4}",
        cda(&grouped),
        cda(&s)
    );
    assert!(
        cda(&s) < 0.97 * cda(&grouped) && cda(&grouped) < 0.99,
        "B's diffuser lets less light through"
    );
    // --target-udi with window groups: every state's run traces as many photons again
    // each round (a target too fine to reach in the time).
    let out = d.join("target");
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &both,
        "--weather",
        &wea,
        "--photons",
        "20000",
        "--threshold",
        "3000",
        "--target-udi",
        "0.001",
        "--time",
        "6",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap()).unwrap();
    // A second round whenever the first left time (a loaded machine may spend the 6 s on
    // the first), which traces more (the time's end may cut it short of as many again).
    let rounds = t["target_udi"]["rounds"].as_u64().unwrap();
    let seconds = t["target_udi"]["seconds"].as_f64().unwrap();
    let photons = t["photons"].as_u64().unwrap();
    assert!(
        (rounds >= 2 && photons > 20000 && photons <= 20000 << (rounds - 1))
            || (rounds == 1 && seconds >= 6.0),
        "{t}"
    );
    assert_eq!(
        t["grids"][0]["window_groups"][0]["states"][1]["occupied_hours"], 1,
        "{t}"
    );
    let only_a = write(d, "only_a.toml", format!("{grid}{}", group("a", "")));
    let e = run(&only_a, "only_a").unwrap_err();
    assert!(e.contains("openings in no [[window_group]]"), "{e}");
    // Bad groups, each named.
    for (extra, says) in [
        (group("a", "rule = \"glare\"\n"), "rule = \"glare\""),
        (group("a", "rule = \"illuminance\"\n"), "needs rule_lx"),
        (group("a", "rule = \"schedule\"\n"), "needs schedule"),
        (
            format!("{}{}", group("a", ""), group("a", "")),
            "a name of its own",
        ),
        (
            "[[window_group]]\nname = \"x\"\nobjects = [\"sky_c\"]\nstates = [\"as-drawn\"]\n"
                .into(),
            "'sky_c' is no object",
        ),
        (
            "[[window_group]]\nname = \"x\"\nobjects = [\"sky_a\"]\nstates = [\"lace\"]\n".into(),
            "material 'lace'",
        ),
    ] {
        let s = write(d, "bad.toml", format!("{grid}{extra}"));
        let e = run(&s, "bad").unwrap_err();
        assert!(e.contains(says), "{extra}: {e}");
    }
    let short = write(d, "short.txt", "0\n1\n");
    assert!(short.ends_with("short.txt"));
    let s = write(
        d,
        "short.toml",
        format!(
            "{grid}{}{}",
            group("a", ""),
            group("b", "rule = \"schedule\"\nschedule = \"short.txt\"\n")
        ),
    );
    let e = run(&s, "short").unwrap_err();
    assert!(e.contains("2 states for the weather file's 4 rows"), "{e}");
}

/// `[[observer]]`: a 0.5 m square Lambertian panel of 4000 cd/m² seen 30° above an eye's
/// line of sight, 2 m away, under a uniform sky of 2000 lx over a black ground: the
/// observer's Ev is half the sky's light and the panel's, and its UGR is CIE 117's formula
/// by hand; observers.csv, report.json and the terminal say so. Bad observers are refused
/// naming their line.
#[test]
fn observers_report_ev_and_ugr_by_cie_117() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = far_triangle(d);
    // I(γ) = 1000 cos γ cd, a 0.5 m square opening (LM-63: width, length in metres).
    let cd: Vec<String> = (0..=18)
        .map(|k| {
            let g = 10.0 * k as f64;
            format!(
                "{}",
                if g <= 90.0 {
                    (1000.0 * g.to_radians().cos()).max(0.0)
                } else {
                    0.0
                }
            )
        })
        .collect();
    let angles: Vec<String> = (0..=18).map(|k| format!("{}", 10 * k)).collect();
    write(
        d,
        "panel.ies",
        format!(
            "IESNA:LM-63-2002\n[TEST] panel\nTILT=NONE\n1 -1 1 19 1 1 2 0.5 0.5 0\n1 1 100\n{}\n0\n{}\n",
            angles.join(" "),
            cd.join(" ")
        ),
    );
    let s = write(
        d,
        "settings.toml",
        r#"
up_axis = "z"
[run]
seed = 3
estimator = "gather"
[sky]
kind = "uniform"
horizontal_illuminance = 2000
[[luminaire]]
file = "panel.ies"
position = [1.7320508075688772, 0, 2.2]
[[observer]]
name = "desk"
eye = [0, 0, 1.2]
view = [1, 0, 0]
[[observer]]
name = "away"
eye = [0, 0, 1.2]
view = [-1, 0, 0]
"#,
    );
    let out = d.join("out");
    let r = run_photons(&model, &s, &out, 200_000);
    assert!(r.status.success(), "{}", stderr(&r));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(stdout.contains("observer desk: Ev "), "{stdout}");
    assert!(
        stdout.contains("observer away: Ev ") && stdout.contains("UGR < 10 (0 sources"),
        "{stdout}"
    );
    let report = read_report(&out);
    let o = &report["observers"][0];
    assert_eq!(o["name"], "desk");
    let (ev, ev_sigma) = (
        o["ev_lx"].as_f64().unwrap(),
        o["ev_sigma_lx"].as_f64().unwrap(),
    );
    let direct = 500.0 * 30f64.to_radians().cos() / 4.0;
    assert!(
        (ev - (1000.0 + direct)).abs() < 4.0 * ev_sigma + 1e-3 * ev,
        "Ev {ev} ± {ev_sigma}"
    );
    let p = ((35.2 - 1.22) * 1e-3 * 30.0 + 21e-5 * 900.0f64).exp();
    let exact = 8.0
        * (0.25 / (1000.0 / std::f64::consts::PI) * 4000.0 * 4000.0 * 0.03125 / (p * p)).log10();
    let (ugr, ugr_sigma) = (o["ugr"].as_f64().unwrap(), o["ugr_sigma"].as_f64().unwrap());
    assert!(
        (ugr - exact).abs() < 4.0 * ugr_sigma + 0.01,
        "UGR {ugr} ± {ugr_sigma} vs {exact}"
    );
    let src = &o["sources"][0];
    assert!(src["name"].as_str().unwrap().contains("panel.ies"), "{src}");
    assert!((src["luminance_cd_m2"].as_f64().unwrap() - 4000.0).abs() < 1e-3);
    assert_eq!(
        report["observers"][1]["sources"].as_array().unwrap().len(),
        0
    );
    let csv = std::fs::read_to_string(out.join("observers.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 3, "{csv}");
    assert!(rows[0].starts_with("name,eye_x") && rows[1].starts_with("desk,0,0,1.2,1,0,0,"));
    let cols: Vec<&str> = rows[1].split(',').collect();
    assert!((cols[12].parse::<f64>().unwrap() - ugr).abs() < 1e-9);

    // In RGB there is no melanopic light to give: its columns are empty.
    assert!(rows[1].ends_with(",,"), "{}", rows[1]);
    assert!(o["alpha_opic"].is_null());
    // A spectral run under a D65 sky (the default colour): its melanopic EDI is Ev.
    let spectral = write(
        d,
        "spectral.toml",
        "up_axis = \"z\"\n[spectral]\nbands = 81\nmin_nm = 380\nmax_nm = 780\n[run]\nseed = 4\n\
         [sky]\nkind = \"uniform\"\nhorizontal_illuminance = 1000\n\
         [[observer]]\nname = \"up\"\neye = [0, 0, 1]\nview = [0, 0, 1]\nup = [1, 0, 0]\n",
    );
    let out2 = d.join("out2");
    let r = run_photons(&model, &spectral, &out2, 50_000);
    assert!(r.status.success(), "{}", stderr(&r));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(stdout.contains("melanopic EDI"), "{stdout}");
    let o = &read_report(&out2)["observers"][0];
    let ev = o["ev_lx"].as_f64().unwrap();
    let mel = o["alpha_opic"]["melanopic_edi_lx"].as_f64().unwrap();
    assert!((mel / ev - 1.0).abs() < 1e-3, "m-EDI {mel}, Ev {ev}");

    // An eye in a box drawn with its normals out is rated, with a warning naming the box.
    let cube = write(
        d,
        "cube.obj",
        "o cube\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\nv -2 -2 3\nv 2 -2 3\nv 2 2 3\nv -2 2 3\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    );
    let inside = write(
        d,
        "inside.toml",
        "up_axis = \"z\"\n[[light]]\nkind = \"point\"\nposition = [0, 0, 2.5]\namount = 1000\nunit = \"lm\"\n\
         [[observer]]\nname = \"boxed\"\neye = [0, 0, 1.2]\nview = [1, 0, 0]\n",
    );
    let r = run_photons(&cube, &inside, &d.join("out3"), 20_000);
    assert!(r.status.success(), "{}", stderr(&r));
    let e = stderr(&r);
    assert!(
        e.contains("observer 'boxed'") && e.contains("back faces of mesh"),
        "{e}"
    );
    assert!(read_report(&d.join("out3"))["observers"][0]["enclosed_by_mesh"].is_u64());

    // A zero view, and an unknown key, are refused naming the line.
    let bad = write(
        d,
        "bad.toml",
        "up_axis = \"z\"\n[run]\nphotons = 1000\n[[observer]]\neye = [0, 0, 1]\nview = [0, 0, 0]\n",
    );
    let e = fails(&[
        "run",
        &model,
        "--config",
        &bad,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        e.contains("bad.toml:4: [[observer]]") && e.contains("observer.view"),
        "{e}"
    );
    let bad = write(
        d,
        "bad2.toml",
        "[[observer]]\neye = [0, 0, 1]\nview = [1, 0, 0]\nfov = 3\n",
    );
    let e = fails(&[
        "run",
        &model,
        "--config",
        &bad,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(e.contains("fov"), "{e}");
}

/// `imap ugr-table FILE`: the CIE 190 table as a catalogue prints it, and as CSV with the
/// values eulumdat-ugr gives (tests/data/eulumdat_ugr.txt) to 0.1.
#[test]
fn ugr_table_prints_the_cie_190_table() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let file = root.join("tests/data/ugr_panel.ldt");
    let o = imap(&["ugr-table", file.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("3200 lm per luminaire") && text.contains("2H × 2H   23.6 25.1"),
        "{text}"
    );
    let o = imap(&["ugr-table", file.to_str().unwrap(), "--csv"]);
    let csv = String::from_utf8_lossy(&o.stdout).into_owned();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 20, "{csv}");
    let reference = std::fs::read_to_string(root.join("tests/data/eulumdat_ugr.txt")).unwrap();
    for (row, want) in rows[1..]
        .iter()
        .zip(reference.lines().filter(|l| l.starts_with("ugr_panel.ldt")))
    {
        let ours: Vec<f64> = row.split(',').skip(2).map(|x| x.parse().unwrap()).collect();
        let theirs: Vec<f64> = want
            .split_whitespace()
            .skip(2)
            .map(|x| x.parse().unwrap())
            .collect();
        assert!(
            ours.iter().zip(&theirs).all(|(a, b)| (a - b).abs() < 0.1),
            "{row} vs {want}"
        );
    }
    // A file without a luminous area has no luminance to rate.
    let dir = tempfile::tempdir().unwrap();
    let point =
        std::fs::read_to_string(&file)
            .unwrap()
            .replacen("\r\n600\r\n600\r\n", "\r\n0\r\n0\r\n", 1);
    let p = write(dir.path(), "point.ldt", point);
    let e = fails(&["ugr-table", &p]);
    assert!(
        e.contains("point.ldt") && e.contains("luminous area"),
        "{e}"
    );
}

#[test]
fn a_fisheye_render_rates_its_dgp_and_outlines_its_sources() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = far_triangle(d);
    // Looking up at a uniform sky of 2000 lx: luminance 637 cd/m², no glare source at
    // evalglare's 2000 cd/m²; Ev = 2000 lx.
    let s = write(
        d,
        "settings.toml",
        r#"
up_axis = "z"
[sky]
kind = "uniform"
horizontal_illuminance = 2000
[camera]
position = [0, 0, 1.2]
look_at = [0, 0, 2]
up = [1, 0, 0]
projection = "angular"
fov_deg = 180
width = 48
height = 48
"#,
    );
    let out = d.join("out");
    let o = imap(&[
        "render",
        &model,
        "--config",
        &s,
        "--passes",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("DGP 0.27"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("render.json")).unwrap()).unwrap();
    let g = &json["glare"];
    let ev = g["ev_lx"].as_f64().unwrap();
    assert!((ev / 2000.0 - 1.0).abs() < 0.01, "{g}");
    assert!((g["dgp"].as_f64().unwrap() - (5.87e-5 * ev + 0.16)).abs() < 1e-9);
    assert_eq!(g["sources"].as_array().unwrap().len(), 0);
    assert!(out.join("glare.png").exists());
    // A bright patch overhead: one labelled source, outlined on glare.png.
    let s2 = write(
        d,
        "bright.toml",
        std::fs::read_to_string(&s).unwrap().replace(
            "horizontal_illuminance = 2000",
            "horizontal_illuminance = 20000",
        ),
    );
    let out2 = d.join("out2");
    let o = imap(&[
        "render",
        &model,
        "--config",
        &s2,
        "--passes",
        "2",
        "--quiet",
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out2.join("render.json")).unwrap()).unwrap();
    let src = json["glare"]["sources"].as_array().unwrap();
    assert_eq!(src.len(), 1, "{}", json["glare"]);
    assert_eq!(src[0]["label"], 1);
    // A fisheye narrower than the hemisphere renders, with a warning and no DGP.
    let s3 = write(
        d,
        "narrow.toml",
        std::fs::read_to_string(&s)
            .unwrap()
            .replace("fov_deg = 180", "fov_deg = 120"),
    );
    let out3 = d.join("out3");
    let o = imap(&[
        "render",
        &model,
        "--config",
        &s3,
        "--passes",
        "1",
        "--quiet",
        "--out",
        out3.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no DGP of this picture")
            && stderr(&o).contains("whole front hemisphere")
    );
    assert!(!out3.join("glare.png").exists());
    // An unknown projection is refused by name.
    let s4 = write(
        d,
        "bad.toml",
        std::fs::read_to_string(&s)
            .unwrap()
            .replace("\"angular\"", "\"fisheye\""),
    );
    let e = fails(&[
        "render", &model, "--config", &s4, "--passes", "1", "--quiet",
    ]);
    assert!(e.contains("projection = \"fisheye\""), "{e}");
}

/// ∫ max(0, d·v) dω over sky patch `p` (16 × 16 points of equal solid angle), d from
/// altitude and azimuth (from north, +y, toward east, +x; up +z).
fn patch_ev(ps: &imap::SkyPatches, p: usize, v: [f64; 3]) -> f64 {
    let (lo, hi, a0, w) = ps.bounds(p);
    let n = 16;
    let mut sum = 0.0;
    for i in 0..n {
        // Equal steps of sin(altitude): equal solid angle.
        let s = lo.sin() + (hi.sin() - lo.sin()) * (i as f64 + 0.5) / n as f64;
        let c = (1.0 - s * s).max(0.0).sqrt();
        for j in 0..n {
            let az = a0 + w * (j as f64 + 0.5) / n as f64;
            let d = [c * az.sin(), c * az.cos(), s];
            sum += (d[0] * v[0] + d[1] * v[1] + d[2] * v[2]).max(0.0);
        }
    }
    sum / (n * n) as f64 * ps.solid_angle(p)
}

#[test]
fn annual_observers_read_the_vertical_illuminance_of_the_open_sky_and_its_glare() {
    // Observers on an open field, one looking up and one east, under three overcast hours
    // and a sunny one: each hour's Ev is Σ_p L_p ∫_p max(0, d·v) dω over the sky vector,
    // the ground's glow (ρ E_h / π over the lower half) and the sun's E_n max(0, s·v).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = far_triangle(d);
    let s = write(
        d,
        "settings.toml",
        "up_axis = \"z\"\n[run]\nseed = 3\n[[grid]]\nname = \"open\"\norigin = [-1, -1, 0]\n\
         u = [1, 0, 0]\nv = [0, 1, 0]\nsize = [2, 2]\nspacing = 1\n\
         [[observer]]\nname = \"up\"\neye = [0, 0, 1.2]\nview = [0, 0, 1]\nup = [0, 1, 0]\n\
         [[observer]]\nname = \"east\"\neye = [0.5, 0, 1.2]\nview = [2, 0, 0]\n",
    );
    let (wea, _) = overcast_hours(
        d,
        "6 21 9.5 0 15\n6 21 10.5 0 40\n6 21 11.5 0 100\n6 21 12.5 500 100\n",
    );
    let out = d.join("out");
    let r = imap(&[
        "annual",
        &o,
        "--config",
        &s,
        "--weather",
        &wea,
        "--photons",
        "2000000",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let weather = imap::weather::read_wea(Path::new(&wea)).unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.2)
            .unwrap();
    let ps = &sky.patches;
    let want = |h: usize, v: [f64; 3]| -> f64 {
        let l = sky.vector(h);
        let ground = if v[2] == 0.0 { FRAC_PI_2 } else { 0.0 };
        let a = &sky.hours[h];
        let (z, az) = (
            a.sun_zenith_deg.to_radians(),
            a.sun_azimuth_deg.to_radians(),
        );
        let sun = [z.sin() * az.sin(), z.sin() * az.cos(), z.cos()];
        let direct = a.direct_normal_lx * (sun[0] * v[0] + sun[1] * v[1] + sun[2] * v[2]).max(0.0);
        l[0] * ground
            + (1..ps.count())
                .map(|p| l[p] * patch_ev(ps, p, v))
                .sum::<f64>()
            + direct
    };
    let csv = std::fs::read_to_string(out.join("annual_observers.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(
        head,
        [
            "month",
            "day",
            "hour",
            "occupied",
            "up_ev_lx",
            "up_ev_sigma",
            "up_dgps",
            "east_ev_lx",
            "east_ev_sigma",
            "east_dgps"
        ]
    );
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap()).unwrap();
    for (i, v) in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]].into_iter().enumerate() {
        let mut above = [0u64; 3];
        for (h, row) in rows.iter().enumerate() {
            let (ev, sigma, dgps) = (row[4 + 3 * i], row[5 + 3 * i], row[6 + 3 * i]);
            let w = want(h, v);
            eprintln!("observer {i} hour {h}: Ev {ev:.1} ± {sigma:.1} lx, want {w:.1}");
            assert!(
                sigma > 0.0 && (ev - w).abs() < 4.0 * sigma + 1e-3 * w,
                "observer {i} hour {h}: {ev} ± {sigma}, want {w}"
            );
            assert!((dgps - (6.22e-5 * ev + 0.184).min(1.0)).abs() < 1e-4);
            for (c, t) in [0.35, 0.40, 0.45].iter().enumerate() {
                if 6.22e-5 * ev + 0.184 >= *t {
                    above[c] += 1;
                }
            }
        }
        let j = &json["observers"][i];
        assert_eq!(j["occupied_hours"], 4, "{j}");
        for c in 0..3 {
            let k = &j["dgps_classes"][c];
            assert_eq!(k["hours"], above[c], "{j}");
            let (lo, hi) = (
                k["interval_95"][0].as_f64().unwrap(),
                k["interval_95"][1].as_f64().unwrap(),
            );
            let share = k["share"].as_f64().unwrap();
            assert!(lo <= share && share <= hi, "{j}");
        }
    }
    // The sunny hour's sun stands south: the east observer sees none of its disc's light
    // beyond the sky's, the one looking up most of it.
    assert!(rows[3][4] > 3.0 * rows[3][7], "{csv}");
    let report = std::fs::read_to_string(out.join("annual_report.md")).unwrap();
    assert!(
        report.contains("## Observers") && report.contains("| east |"),
        "{report}"
    );
    // A glare rule without observers, an unknown observer, a DGPs out of range: refused,
    // named.
    for (extra, says) in [
        ("rule_dgp = 0.1\n", "rule_dgp = 0.1"),
        ("observers = [\"nobody\"]\n", "'nobody' is no [[observer]]"),
    ] {
        let bad = write(
            d,
            "bad.toml",
            format!(
                "{}[[window_group]]\nname = \"g\"\nobjects = [\"far\"]\nstates = [\"as-drawn\"]\nrule = \"glare\"\n{extra}",
                std::fs::read_to_string(&s).unwrap()
            ),
        );
        let e = fails(&[
            "annual",
            &o,
            "--config",
            &bad,
            "--weather",
            &wea,
            "--photons",
            "1000",
        ]);
        assert!(e.contains(says), "{e}");
    }
}

#[test]
fn annual_glare_rule_closes_a_skylight_in_the_hours_its_observer_would_be_dazzled() {
    // An observer 0.3 m below skylight A, looking up at it: the group's glare rule closes
    // A (its diffuser) in exactly the hours in which the observer's DGPs with A open
    // (the first run's, with the same photons) is above 0.40, and the grid reads A in
    // those states.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = skylit_room(d);
    let grid = "up_axis = \"z\"\n[run]\nseed = 5\n[[grid]]\nname = \"desk\"\norigin = [0, 0, 0.85]\n\
                u = [1, 0, 0]\nv = [0, 1, 0]\nsize = [4, 4]\nspacing = 0.5\n\
                [materials.diffuser]\ndiffuse = 0.1\ntransmit = 0.1\n\
                [[observer]]\nname = \"reader\"\neye = [1, 1.5, 2.7]\nview = [0, 0, 1]\nup = [0, 1, 0]\n";
    let group = |name: &str, rule: &str| {
        format!(
            "[[window_group]]\nname = \"{name}\"\nobjects = [\"sky_{name}\"]\nstates = [\"as-drawn\", \"diffuser\"]\n{rule}"
        )
    };
    let wea = write(
        d,
        "w.wea",
        "place Test\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
         weather_data_file_units 1\n6 21 8.5 0 10\n6 21 9.5 0 60\n6 21 10.5 0 120\n6 21 12.5 600 100\n",
    );
    let schedule = write(d, "open.txt", "0\n0\n0\n0\n");
    assert!(schedule.ends_with("open.txt"));
    let run = |rule: &str, out: &str| -> serde_json::Value {
        let settings = write(
            d,
            &format!("{out}.toml"),
            format!(
                "{grid}{}{}",
                group("a", rule),
                group("b", "rule = \"schedule\"\nschedule = \"open.txt\"\n")
            ),
        );
        let out = d.join(out);
        let r = imap(&[
            "annual",
            &o,
            "--config",
            &settings,
            "--weather",
            &wea,
            "--photons",
            "100000",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        let mut json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("annual.json")).unwrap())
                .unwrap();
        json["csv"] = std::fs::read_to_string(out.join("annual_observers.csv"))
            .unwrap()
            .into();
        json
    };
    let ev = |j: &serde_json::Value| -> Vec<f64> {
        j["csv"]
            .as_str()
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
            .collect()
    };
    let open = run("rule = \"schedule\"\nschedule = \"open.txt\"\n", "open");
    let glare = run("rule = \"glare\"\nrule_dgp = 0.40\n", "glare");
    let open_ev = ev(&open);
    eprintln!(
        "Ev with A open: {open_ev:?}; with the glare rule: {:?}",
        ev(&glare)
    );
    let dazzled = open_ev
        .iter()
        .filter(|&&e| 6.22e-5 * e + 0.184 > 0.40)
        .count() as u64;
    // The test's hours: some dazzle, some do not.
    assert!((1..4).contains(&dazzled), "{open_ev:?}");
    let states = &glare["grids"][0]["window_groups"][0];
    assert_eq!(
        states["rule"], "glare: DGPs above 0.4 at reader",
        "{states}"
    );
    assert_eq!(states["states"][1]["occupied_hours"], dazzled, "{states}");
    assert_eq!(
        states["states"][0]["occupied_hours"],
        4 - dazzled,
        "{states}"
    );
    // In the closed hours the observer gets the diffuser's light (in the sunny hour still
    // above 0.40: the last state, the most closed); in the others, as open.
    for (h, (a, b)) in open_ev.iter().zip(ev(&glare)).enumerate() {
        if 6.22e-5 * a + 0.184 > 0.40 {
            assert!(b < 0.75 * a, "hour {h}: {a} → {b}");
        } else {
            assert_eq!(*a, b, "hour {h}");
        }
    }
    let fewer = |j: &serde_json::Value| j["observers"][0]["dgps_classes"][1]["hours"].as_u64();
    assert!(
        fewer(&glare) < fewer(&open),
        "{} {}",
        open["observers"],
        glare["observers"]
    );
}
