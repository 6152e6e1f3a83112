//! Radiance scene files through the command: a `light` sphere gives the luminous intensity
//! Radiance gives it, and a side-lit room under a sky reads the same daylight through a
//! `.rad` file (its window a `glass` polygon, its wall one polygon round the opening with a
//! seam, as Honeybee writes them) as through an OBJ of the same room with the pane as a
//! solid of glass.

mod common;

use common::{run_photons, stderr, write};
use std::path::Path;

/// A sphere of `light` radiance 100 and radius 0.1 m, 2 m above a black floor.
const LAMP: &str =
    "void plastic black 0 0 5 0 0 0 0 0\nblack polygon floor 0 0 12 -5 -5 0 5 -5 0 5 5 0 -5 5 0\n\
    void light bulb\n0\n0\n3 100 100 100\nbulb sphere lamp 0 0 4 0 0 2 0.1\n";

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn grid_average(out: &Path) -> (f64, f64) {
    let r = report(out);
    let a = &r["grids"][0]["average_lx"];
    (a["value"].as_f64().unwrap(), a["sigma"].as_f64().unwrap())
}

/// A sphere of `light` radiance 100 (W/(sr m²) in Radiance's RGB) and radius 0.1 m, 1.99 m
/// above a grid on a black floor: Radiance's luminance 179 lm/W × 100 = 17 900 cd/m², an
/// intensity of 17 900 π 0.1² = 562.3 cd, 142.0 lx below it (averaged over the grid,
/// 137.4 lx), in RGB and in spectral runs.
#[test]
fn a_light_sphere_gives_the_intensity_radiance_gives_it() {
    let d = tempfile::tempdir().unwrap();
    let rad = write(d.path(), "lamp.rad", LAMP);
    // E = I h / (h² + r²)^1.5 averaged over the square between the grid's outer points
    // (±0.375 m: what the grid's average covers).
    let (i, h, n) = (17_900.0 * std::f64::consts::PI * 0.01, 1.99f64, 200);
    let mut want = 0.0;
    for a in 0..n {
        for b in 0..n {
            let x = -0.375 + 0.75 * (a as f64 + 0.5) / n as f64;
            let y = -0.375 + 0.75 * (b as f64 + 0.5) / n as f64;
            want += i * h / (h * h + x * x + y * y).powf(1.5) / (n * n) as f64;
        }
    }
    for spectral in ["", "[spectral]\nbands = 16\n"] {
        let toml = write(
            d.path(),
            "s.toml",
            format!(
                "up_axis = \"z\"\n{spectral}[run]\nseed = 3\n[[grid]]\nname = \"g\"\norigin = [-0.5, -0.5, 0.01]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [1, 1]\nspacing = 0.25\n"
            ),
        );
        let out = d.path().join("out");
        let o = run_photons(&rad, &toml, &out, 10_000_000);
        assert!(o.status.success(), "{}", stderr(&o));
        let (e, s) = grid_average(&out);
        eprintln!("{spectral:?}: {e:.2} ± {s:.2} lx, want {want:.2}");
        assert!(
            (e - want).abs() < 3.0 * s + 0.005 * want,
            "{spectral:?}: {e} ± {s} lx, want {want}"
        );
    }
}

/// The room's surfaces as polygons (corners in order, Z up, facing the room), the front
/// wall (y = 0) going round the window (x 1–3, z 1–2) and back along a seam.
const ROOM: [(&str, &[[f64; 3]]); 6] = [
    (
        "floor",
        &[[0., 0., 0.], [4., 0., 0.], [4., 4., 0.], [0., 4., 0.]],
    ),
    (
        "ceiling",
        &[[0., 0., 3.], [0., 4., 3.], [4., 4., 3.], [4., 0., 3.]],
    ),
    (
        "back",
        &[[0., 4., 0.], [4., 4., 0.], [4., 4., 3.], [0., 4., 3.]],
    ),
    (
        "left",
        &[[0., 0., 0.], [0., 4., 0.], [0., 4., 3.], [0., 0., 3.]],
    ),
    (
        "right",
        &[[4., 0., 0.], [4., 0., 3.], [4., 4., 3.], [4., 4., 0.]],
    ),
    (
        "front",
        &[
            [0., 0., 0.],
            [0., 0., 3.],
            [4., 0., 3.],
            [4., 0., 0.],
            [0., 0., 0.],
            [1., 0., 1.],
            [3., 0., 1.],
            [3., 0., 2.],
            [1., 0., 2.],
            [1., 0., 1.],
        ],
    ),
];

/// The window, its front facing out (−y).
const WINDOW: [[f64; 3]; 4] = [[1., 0., 1.], [3., 0., 1.], [3., 0., 2.], [1., 0., 2.]];

fn poly(name: &str, material: &str, c: &[[f64; 3]]) -> String {
    let mut s = format!("{material} polygon {name}\n0\n0\n{}\n", 3 * c.len());
    for p in c {
        s += &format!("  {} {} {}\n", p[0], p[1], p[2]);
    }
    s
}

/// Glass of transmissivity 0.88 (about 81 % transmittance at normal incidence) in a grey
/// room under a uniform 10 klx sky: the floor grid's average through the `.rad` reader
/// equals the OBJ's, whose pane is a 6 mm solid of index 1.52 absorbing −ln 0.88 per pass.
#[test]
fn a_side_lit_room_reads_the_same_through_rad_and_obj() {
    let d = tempfile::tempdir().unwrap();
    let mut rad = String::from("# Honeybee-like export\nvoid plastic wall_mat\n0\n0\n5 0.5 0.5 0.5 0 0\n\nvoid glass glass_mat\n0\n0\n3 0.88 0.88 0.88\n");
    for (name, c) in ROOM {
        rad += &poly(name, "wall_mat", c);
    }
    rad += &poly("window", "glass_mat", &WINDOW);
    let rad = write(d.path(), "room.rad", rad);
    // The OBJ: the same polygons, the window as a 6 mm slab behind its front face.
    let t = 0.006;
    let mut obj = String::from("mtllib room.mtl\n");
    let mut n = 0;
    let mut face = |obj: &mut String, name: &str, mtl: &str, c: &[[f64; 3]]| {
        *obj += &format!("o {name}\nusemtl {mtl}\n");
        for p in c {
            *obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
        }
        *obj += "f";
        for k in 0..c.len() {
            *obj += &format!(" {}", n + k + 1);
        }
        *obj += "\n";
        n += c.len();
    };
    for (name, c) in ROOM {
        face(&mut obj, name, "wall", c);
    }
    let back: Vec<[f64; 3]> = WINDOW.iter().rev().map(|p| [p[0], t, p[2]]).collect();
    face(&mut obj, "window", "glass", &WINDOW);
    face(&mut obj, "window", "glass", &back);
    for i in 0..4 {
        let (a, b) = (WINDOW[i], WINDOW[(i + 1) % 4]);
        let side = [a, [a[0], t, a[2]], [b[0], t, b[2]], b];
        face(&mut obj, "window", "glass", &side);
    }
    write(
        d.path(),
        "room.mtl",
        "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl glass\nKd 0 0 0\nNi 1.52\nd 0\n",
    );
    let obj = write(d.path(), "room.obj", obj);
    let absorption = -(0.88f64.ln()) / t;
    let grid = "[[grid]]\nname = \"work\"\norigin = [0.2, 0.2, 0.8]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [3.6, 3.6]\nspacing = 0.6\n";
    let sky = "[sky]\nkind = \"uniform\"\nhorizontal_illuminance = 10000\n";
    let mut results = Vec::new();
    for (model, extra) in [
        (&rad, String::new()),
        (
            &obj,
            format!("[materials.glass]\nabsorption_per_m = {absorption}\n"),
        ),
        // The window as a portal: most of the sky's photons come in through it.
        (&rad, "portals = [\"window\"]\n".to_string()),
        // Found as the model's glass.
        (&rad, "glass_portals = true\n".to_string()),
    ] {
        let toml = write(
            d.path(),
            "s.toml",
            if extra.starts_with("portals") || extra.starts_with("glass_portals") {
                format!(
                    "up_axis = \"z\"\nrecord = [\"floor\"]\n{extra}[run]\nseed = 6\n{sky}{grid}"
                )
            } else {
                format!(
                    "up_axis = \"z\"\nrecord = [\"floor\"]\n[run]\nseed = 5\n{sky}{extra}{grid}"
                )
            },
        );
        let out = d.path().join("out");
        let o = run_photons(model, &toml, &out, 3_000_000);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        if model.ends_with(".rad") {
            assert!(
                err.contains("1 glass polygon(s) are read as panes"),
                "{err}"
            );
        }
        results.push(grid_average(&out));
    }
    let ((a, sa), (b, sb), (c, sc)) = (results[0], results[1], results[2]);
    eprintln!("floor grid Eavg: rad {a:.1} ± {sa:.1} lx, obj {b:.1} ± {sb:.1} lx, rad with the window as a portal {c:.1} ± {sc:.1} lx");
    // The glass found as the portal: the same run (to the summation order's last bits).
    assert!(
        (results[3].0 - results[2].0).abs() < 1e-9 * results[2].0,
        "{:?} vs {:?}",
        results[3],
        results[2]
    );
    // The portal: the same light, with far less noise from the same photons.
    assert!(
        (a - c).abs() < 3.0 * (sa * sa + sc * sc).sqrt() + 0.005 * a && sc < 0.5 * sa,
        "without the portal {a} ± {sa} lx, with it {c} ± {sc} lx"
    );
    // Daylight factor 1–5 % (a 2 m² window in a 16 m² room), and the same both ways.
    assert!((100.0..500.0).contains(&a), "rad: {a} lx");
    assert!(
        (a - b).abs() < 3.0 * (sa * sa + sb * sb).sqrt() + 0.005 * b,
        "rad {a} ± {sa} lx, obj {b} ± {sb} lx"
    );
}

/// A sensor point file (`x y z dx dy dz`, as rtrace reads them) under the light sphere
/// above: each point reads I cos θ / d² toward its own direction, a point facing the black
/// floor reads nothing (and is counted unlit), and the file's mistakes name their line.
#[test]
fn sensor_point_files_give_each_point_its_own_light() {
    let d = tempfile::tempdir().unwrap();
    let rad = write(d.path(), "lamp.rad", LAMP);
    let pts = [
        [0.0, 0.0, 0.01, 0.0, 0.0, 1.0],
        [0.5, 0.0, 0.01, 0.0, 0.0, 1.0],
        [1.0, 1.0, 0.01, 0.0, 0.0, 1.0],
        [1.0, 0.0, 2.0, -1.0, 0.0, 0.0],
        [0.0, 0.7, 1.0, 0.0, 0.0, 1.0],
        [0.3, 0.3, 0.01, 0.0, 0.0, -2.0],
    ];
    let text: String = pts
        .iter()
        .map(|p| format!("{} {} {} {} {} {}\n", p[0], p[1], p[2], p[3], p[4], p[5]))
        .collect();
    write(d.path(), "room.pts", format!("# x y z dx dy dz\n{text}"));
    let toml = write(
        d.path(),
        "s.toml",
        "up_axis = \"z\"\n[run]\nseed = 2\n[[grid]]\nname = \"sensors\"\npoints = \"room.pts\"\nradius = 0.02\n",
    );
    let out = d.path().join("out");
    let o = run_photons(&rad, &toml, &out, 10_000_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("grid_sensors.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), pts.len());
    let i = 17_900.0 * std::f64::consts::PI * 0.01;
    for (p, row) in pts.iter().zip(&rows) {
        let to_lamp = glam::DVec3::new(-p[0], -p[1], 2.0 - p[2]);
        let n = glam::DVec3::new(p[3], p[4], p[5]).normalize();
        let want = i * to_lamp.normalize().dot(n).max(0.0) / to_lamp.length_squared();
        let (e, s) = (row[7], row[8]);
        eprintln!("{p:?}: {e:.2} ± {s:.2} lx, want {want:.2}");
        assert!(
            (e - want).abs() <= 4.0 * s + 0.01 * want,
            "{p:?}: {e} ± {s} lx, want {want}"
        );
    }
    assert_eq!(rows[5][7], 0.0);
    let r = report(&out);
    assert_eq!(r["grids"][0]["unlit_points"].as_u64(), Some(1));
    assert_eq!(r["grids"][0]["points"].as_u64(), Some(6));
    // Mistakes: a short line, a zero direction, points beside a rectangle.
    for (pts, extra, says) in [
        (
            "0 0 1 0 0 1\n0 0 1 0 1\n",
            "",
            "room.pts:2: a sensor point needs six finite numbers",
        ),
        (
            "0 0 1 0 0 0\n",
            "",
            "room.pts:1: the point's direction dx dy dz is zero",
        ),
        (
            "0 0 1 0 0 1\n",
            "size = [1, 1]\n",
            "give either points (a file) or origin, u, v and size",
        ),
    ] {
        write(d.path(), "room.pts", pts);
        let toml = write(
            d.path(),
            "s.toml",
            format!(
                "up_axis = \"z\"\n[[grid]]\nname = \"sensors\"\npoints = \"room.pts\"\n{extra}"
            ),
        );
        let o = run_photons(&rad, &toml, &out, 1000);
        assert!(!o.status.success());
        assert!(stderr(&o).contains(says), "{}", stderr(&o));
    }
}

/// `[sky] ground_reflectance`: a grid facing down over the open ground under a 10 klx
/// uniform sky reads ρ × 10 000 lx; a reflectance beyond 1 is refused.
#[test]
fn the_ground_glows_under_the_sky() {
    let d = tempfile::tempdir().unwrap();
    let rad = write(
        d.path(),
        "far.rad",
        "void plastic black 0 0 5 0 0 0 0 0\nblack polygon far 0 0 9 2 2 3 2.2 2 3 2 2.2 3\n",
    );
    let settings = |rho: f64| {
        format!(
            "up_axis = \"z\"\n[run]\nseed = 4\n[sky]\nkind = \"uniform\"\nhorizontal_illuminance = 10000\nground_reflectance = {rho}\n\
             [[grid]]\nname = \"down\"\norigin = [0, 0, 1]\nu = [1, 0, 0]\nv = [0, -1, 0]\nsize = [1, 1]\nspacing = 0.25\n"
        )
    };
    let toml = write(d.path(), "s.toml", settings(0.2));
    let out = d.path().join("out");
    let o = run_photons(&rad, &toml, &out, 12_000_000);
    assert!(o.status.success(), "{}", stderr(&o));
    let (e, s) = grid_average(&out);
    eprintln!("facing down over a ground of 0.2: {e:.1} ± {s:.1} lx");
    assert!((e - 2000.0).abs() < 4.0 * s + 2.0 && s < 30.0, "{e} ± {s}");
    let r = report(&out);
    assert!(r["lights"].to_string().contains("ground (reflectance 0.2)"));
    write(d.path(), "s.toml", settings(1.5));
    let o = run_photons(&rad, &toml, &out, 1000);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("ground_reflectance = 1.5 must be in [0, 1]"),
        "{}",
        stderr(&o)
    );
}

/// Radiance's `BSDF` material: a floor of a window BSDF file that reflects 0.2 diffusely
/// from WINDOW's front only, under a `light` sphere. Radiance's BSDF surfaces face
/// WINDOW's back (libBSDF swaps the file's front and back): a floor polygon facing the
/// lamp shows the lamp its back and reflects nothing; facing away, its front, and the
/// grid 1 m up, measuring light from below, reads what it reflects — as the same floor
/// given the file through the settings with its normal toward the lamp reads. The `aBSDF`
/// form reads alike; an up vector from a function file is left out with a warning.
#[test]
fn radiance_bsdf_surfaces_face_the_files_back() {
    let d = tempfile::tempdir().unwrap();
    let value = 0.2 / std::f64::consts::PI;
    let data: Vec<String> = (0..41 * 41).map(|_| format!("{value}")).collect();
    let xml = format!(
        "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>\n<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>\n<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength>\n<WavelengthDataBlock><WavelengthDataDirection>Reflection Front</WavelengthDataDirection>\n<ColumnAngleBasis>LBNL/Klems Quarter</ColumnAngleBasis><RowAngleBasis>LBNL/Klems Quarter</RowAngleBasis>\n<ScatteringData>{}</ScatteringData></WavelengthDataBlock></WavelengthData></Layer></Optical></WindowElement>\n",
        data.join(",\n")
    );
    write(d.path(), "matte.xml", &xml);
    let up = "-5 -5 0 5 -5 0 5 5 0 -5 5 0";
    let down = "-5 -5 0 -5 5 0 5 5 0 5 -5 0";
    let lamp = "void light bulb\n0\n0\n3 100 100 100\nbulb sphere lamp 0 0 4 0 0 2 0.1\n";
    let toml = write(
        d.path(),
        "s.toml",
        "up_axis = \"z\"\n[run]\nseed = 4\n[[grid]]\nname = \"g\"\norigin = [-0.5, -0.5, 1]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [1, 1]\nspacing = 0.25\nside = \"back\"\n",
    );
    let read = |name: &str, material: &str, corners: &str, toml: &str| {
        let rad = write(
            d.path(),
            &format!("{name}.rad"),
            format!("{lamp}{material}\nmatte polygon floor 0 0 12 {corners}\n"),
        );
        let out = d.path().join(name);
        let o = run_photons(&rad, toml, &out, 400_000);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        (grid_average(&out), stderr(&o))
    };
    let bsdf = "void BSDF matte\n6 0 matte.xml 0 1 0 .\n0\n0";
    let ((facing, _), _) = read("facing", bsdf, up, &toml);
    let ((away, s_away), _) = read("away", bsdf, down, &toml);
    let ((absdf, s_absdf), _) = read(
        "absdf",
        "void aBSDF matte\n5 matte.xml 0 1 0 .\n0\n0",
        down,
        &toml,
    );
    // The same floor through the settings: its normal (up) toward the file's front.
    let settings = write(
        d.path(),
        "t.toml",
        format!(
            "{}[materials.matte]\nkind = \"bsdf-xml\"\nfile = \"matte.xml\"\nup = [0, 1, 0]\n",
            std::fs::read_to_string(&toml).unwrap()
        ),
    );
    let ((set, s_set), _) = read(
        "settings",
        "void plastic matte\n0\n0\n5 .5 .5 .5 0 0",
        up,
        &settings,
    );
    eprintln!("facing {facing}, away {away} ± {s_away}, aBSDF {absdf} ± {s_absdf}, settings {set} ± {s_set}");
    assert!(
        away > 1.0 && facing < 1e-3 * away,
        "facing {facing}, away {away}"
    );
    for (what, x, s) in [("aBSDF", absdf, s_absdf), ("settings", set, s_set)] {
        assert!(
            (x - away).abs() < 4.0 * s.hypot(s_away),
            "{what} {x} ± {s} against {away} ± {s_away}"
        );
    }
    // An up vector from a function file: left out, named.
    let (_, e) = read(
        "func",
        "void BSDF matte\n6 0 matte.xml up_x up_y up_z dir.cal\n0\n0",
        up,
        &toml,
    );
    assert!(
        e.contains("BSDF 'matte' is not read") && e.contains("function file"),
        "{e}"
    );
}
