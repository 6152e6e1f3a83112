//! The Cornell box (Cornell University's published geometry, in millimetres, and the usual
//! reflectances) as OBJ + MTL text, each wall subdivided so the map resolves the light.

use std::fmt::Write;

/// A quad given by its corners in order, subdivided n × n; its normal is turned to face
/// `towards` (a point on the side the quad faces).
fn quad(obj: &mut String, nv: &mut usize, c: [[f64; 3]; 4], n: usize, towards: [f64; 3]) {
    let p = |s: f64, t: f64| -> [f64; 3] {
        [0, 1, 2].map(|k| {
            (1.0 - s) * (1.0 - t) * c[0][k]
                + s * (1.0 - t) * c[1][k]
                + s * t * c[2][k]
                + (1.0 - s) * t * c[3][k]
        })
    };
    let u = [0, 1, 2].map(|k| c[1][k] - c[0][k]);
    let v = [0, 1, 2].map(|k| c[3][k] - c[0][k]);
    let normal = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let centre = p(0.5, 0.5);
    let to = [0, 1, 2].map(|k| towards[k] - centre[k]);
    let flip = normal[0] * to[0] + normal[1] * to[1] + normal[2] * to[2] < 0.0;
    let base = *nv + 1;
    for j in 0..=n {
        for i in 0..=n {
            let q = p(i as f64 / n as f64, j as f64 / n as f64);
            writeln!(obj, "v {} {} {}", q[0], q[1], q[2]).unwrap();
        }
    }
    *nv += (n + 1) * (n + 1);
    for j in 0..n {
        for i in 0..n {
            let a = base + j * (n + 1) + i;
            let (b, cc, d) = (a + 1, a + n + 2, a + n + 1);
            if flip {
                writeln!(obj, "f {a} {cc} {b}\nf {a} {d} {cc}").unwrap();
            } else {
                writeln!(obj, "f {a} {b} {cc}\nf {a} {cc} {d}").unwrap();
            }
        }
    }
}

/// (OBJ text, MTL text) of the box; the OBJ names `mtl_file`.
pub fn cornell_box(mtl_file: &str) -> (String, String) {
    let mut obj = format!("# The Cornell box (geometry in mm)\nmtllib {mtl_file}\n");
    let mut nv = 0;
    let inside = [278.0, 274.4, 279.6];
    let walls: [(&str, &str, [[f64; 3]; 4]); 5] = [
        (
            "floor",
            "white",
            [
                [552.8, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 559.2],
                [549.6, 0.0, 559.2],
            ],
        ),
        (
            "ceiling",
            "white",
            [
                [556.0, 548.8, 0.0],
                [556.0, 548.8, 559.2],
                [0.0, 548.8, 559.2],
                [0.0, 548.8, 0.0],
            ],
        ),
        (
            "back_wall",
            "white",
            [
                [549.6, 0.0, 559.2],
                [0.0, 0.0, 559.2],
                [0.0, 548.8, 559.2],
                [556.0, 548.8, 559.2],
            ],
        ),
        (
            "green_wall",
            "green",
            [
                [0.0, 0.0, 559.2],
                [0.0, 0.0, 0.0],
                [0.0, 548.8, 0.0],
                [0.0, 548.8, 559.2],
            ],
        ),
        (
            "red_wall",
            "red",
            [
                [552.8, 0.0, 0.0],
                [549.6, 0.0, 559.2],
                [556.0, 548.8, 559.2],
                [556.0, 548.8, 0.0],
            ],
        ),
    ];
    for (name, mat, c) in walls {
        writeln!(obj, "o {name}\nusemtl {mat}").unwrap();
        quad(&mut obj, &mut nv, c, 24, inside);
    }
    // The lamp, 0.5 mm below the ceiling, facing down.
    writeln!(obj, "o light\nusemtl light").unwrap();
    quad(
        &mut obj,
        &mut nv,
        [
            [343.0, 548.3, 227.0],
            [343.0, 548.3, 332.0],
            [213.0, 548.3, 332.0],
            [213.0, 548.3, 227.0],
        ],
        2,
        [278.0, 0.0, 279.5],
    );
    let blocks: [(&str, f64, [[f64; 2]; 4]); 2] = [
        (
            "short_block",
            165.0,
            [[130.0, 65.0], [82.0, 225.0], [240.0, 272.0], [290.0, 114.0]],
        ),
        (
            "tall_block",
            330.0,
            [
                [423.0, 247.0],
                [265.0, 296.0],
                [314.0, 456.0],
                [472.0, 406.0],
            ],
        ),
    ];
    for (name, h, f) in blocks {
        writeln!(obj, "o {name}\nusemtl white").unwrap();
        let cx = f.iter().map(|p| p[0]).sum::<f64>() / 4.0;
        let cz = f.iter().map(|p| p[1]).sum::<f64>() / 4.0;
        let top = f.map(|p| [p[0], h, p[1]]);
        quad(&mut obj, &mut nv, top, 8, [cx, h + 1.0, cz]);
        for i in 0..4 {
            let (a, b) = (f[i], f[(i + 1) % 4]);
            let mid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
            let out = [2.0 * mid[0] - cx, h / 2.0, 2.0 * mid[1] - cz];
            quad(
                &mut obj,
                &mut nv,
                [
                    [a[0], 0.0, a[1]],
                    [b[0], 0.0, b[1]],
                    [b[0], h, b[1]],
                    [a[0], h, a[1]],
                ],
                8,
                out,
            );
        }
    }
    let mtl = "\
# Cornell box materials: the usual RGB reflectances; the lamp emits Ke W/m² per band
newmtl white
Kd 0.73 0.73 0.73
newmtl red
Kd 0.63 0.065 0.05
newmtl green
Kd 0.14 0.45 0.09
newmtl light
Kd 0.78 0.78 0.78
Ke 1000 800 600
"
    .to_string();
    (obj, mtl)
}
