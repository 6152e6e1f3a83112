//! The corpus test: every OBJ, glTF, PLY and STL model of Debian's `assimp-testmodels`
//! (third-party files, many of them deliberately broken) through `imap info` and
//! `imap run`. Each model either runs a short job and gives finite maps that are non-zero
//! on its lit surfaces, or is refused with a one-line reason per problem (exit status 2);
//! nothing panics, hangs or dies of a signal. The models known to be readable must stay
//! readable. `scripts/setup-system.sh` installs the package.

mod common;

use common::{imap, run_photons};

use std::path::{Path, PathBuf};
use std::time::Instant;

const CORPUS: &str = "/usr/share/assimp/models";

/// Models that must load and run (relative to CORPUS): every format and the heuristics
/// they exercise (UTF-16, Blender 2.4 PLY headers, vertex colours, textures, tab after
/// `solid`, node transforms, strips and fans, degenerate triangles).
const MUST_RUN: &[&str] = &[
    "OBJ/WusonOBJ.obj",
    "OBJ/box.obj",
    "OBJ/box_UTF16BE.obj",
    "OBJ/box_longline.obj",
    "OBJ/box_mat_with_spaces.obj",
    "OBJ/box_without_lineending.obj",
    "OBJ/concave_polygon.obj",
    "OBJ/cube_usemtl.obj",
    "OBJ/cube_with_vertexcolors.obj",
    "OBJ/cube_with_vertexcolors_uni.obj",
    "OBJ/empty_mat.obj",
    "OBJ/multiple_spaces.obj",
    "OBJ/regr01.obj",
    "OBJ/regr_3429812.obj",
    "OBJ/space_in_material_name.obj",
    "OBJ/spider.obj",
    "OBJ/testmixed.obj",
    "PLY/Wuson.ply",
    "PLY/cube.ply",
    "PLY/cube_binary.ply",
    "PLY/cube_uv.ply",
    "PLY/float-color.ply",
    "STL/3DSMaxExport.STL",
    "STL/Spider_ascii.stl",
    "STL/Spider_binary.stl",
    "STL/Wuson.stl",
    "STL/sphereWithHole.stl",
    "STL/triangle.stl",
    "STL/triangle_with_two_solids.stl",
    "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
    "glTF2/BoxTextured-glTF/BoxTextured.gltf",
    "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
    "glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf",
    "glTF2/ClearCoat-glTF/ClearCoatTest.gltf",
    "glTF2/cameras/Cameras.gltf",
    "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_04.gltf",
    "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_05.gltf",
    "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_06.gltf",
    "glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf",
];

fn models(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().collect();
    entries.sort_by_key(|e| e.path());
    for e in entries {
        let p = e.path();
        if p.is_dir() {
            models(&p, out);
        } else if let Some(x) = p.extension().and_then(|x| x.to_str()) {
            if ["obj", "gltf", "glb", "ply", "stl"].contains(&x.to_ascii_lowercase().as_str()) {
                out.push(p);
            }
        }
    }
}

/// A refusal: exit status 2, every line of stderr an `imap:` message, no panic.
fn refused_cleanly(o: &std::process::Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{what}: {err}");
    assert!(
        err.lines().all(|l| l.starts_with("imap: ")) && !err.contains("panicked"),
        "{what}: {err}"
    );
    err.lines()
        .find(|l| l.starts_with("imap: error"))
        .unwrap_or("")
        .to_string()
}

#[test]
fn third_party_models_run_or_are_refused_with_a_reason() {
    let root = Path::new(CORPUS);
    assert!(
        root.is_dir(),
        "{CORPUS} is missing: install Debian's assimp-testmodels (scripts/setup-system.sh)"
    );
    let mut all = Vec::new();
    for sub in ["OBJ", "PLY", "STL", "glTF", "glTF2", "invalid"] {
        if root.join(sub).is_dir() {
            models(&root.join(sub), &mut all);
        }
    }
    assert!(all.len() >= 50, "only {} models under {CORPUS}", all.len());
    let tmp = tempfile::tempdir().unwrap();
    let mut ran = Vec::new();
    let mut table = Vec::new();
    for (k, path) in all.iter().enumerate() {
        let rel = path
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let p = path.to_str().unwrap();
        let info = imap(&["info", p]);
        if !info.status.success() {
            let why = refused_cleanly(&info, &rel);
            table.push(format!("{rel:<80} refused  {why}"));
            continue;
        }
        let j: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        let b = &j["bounds"];
        let lo: Vec<f64> = (0..3).map(|i| b[0][i].as_f64().unwrap()).collect();
        let hi: Vec<f64> = (0..3).map(|i| b[1][i].as_f64().unwrap()).collect();
        let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max).max(1e-3);
        let c: Vec<f64> = (0..3).map(|i| 0.5 * (lo[i] + hi[i])).collect();
        // A 1000 lm point light above the model and off its axes (so that no face of an
        // axis-aligned model holds it in its plane), both sides recorded.
        let light = [c[0] + 0.5 * size, hi[1] + size, c[2] + 0.7 * size];
        let toml = tmp.path().join(format!("{k}.toml"));
        std::fs::write(
            &toml,
            format!(
                "two_sided = true\n[run]\nseed = 1\n[[light]]\nkind = \"point\"\nposition = {light:?}\namount = 1000\nunit = \"lm\"\n"
            ),
        )
        .unwrap();
        let out = tmp.path().join(format!("out{k}"));
        let t0 = Instant::now();
        let o = run_photons(p, toml.to_str().unwrap(), &out, 100_000);
        let secs = t0.elapsed().as_secs_f64();
        if !o.status.success() {
            let why = refused_cleanly(&o, &rel);
            table.push(format!("{rel:<80} refused  {why}"));
            continue;
        }
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        let meshes = report["meshes"].as_array().unwrap();
        let mut lit = false;
        for m in meshes.iter().filter(|m| m["recorded"] == true) {
            let lux = &m["illuminance_lx"];
            for s in ["min", "mean", "max"] {
                let x = lux[s].as_f64();
                assert!(x.is_some_and(f64::is_finite), "{rel}: {s} lux {lux}");
            }
            lit |= lux["max"].as_f64().unwrap() > 0.0;
            let back = lux["back"]["max"].as_f64();
            assert!(back.is_some_and(f64::is_finite), "{rel}: back side {lux}");
            lit |= back.unwrap() > 0.0;
        }
        assert!(lit, "{rel}: no recorded surface received light");
        let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
        assert!(
            csv.lines().skip(1).all(|l| l
                .split(',')
                .skip(2)
                .all(|x| x.parse::<f64>().is_ok_and(f64::is_finite))),
            "{rel}: a non-finite value in irradiance.csv"
        );
        table.push(format!(
            "{rel:<80} ran      {} triangles, {secs:.2} s, estimated error {:.1} %",
            j["triangles"],
            100.0 * report["rel_error"].as_f64().unwrap()
        ));
        ran.push(rel);
    }
    println!("{}", table.join("\n"));
    for m in MUST_RUN {
        assert!(
            ran.iter().any(|r| r == m),
            "{m} no longer runs:\n{}",
            table.join("\n")
        );
    }
}
