//! Wavefront MTL: the statements libimap can use, each checked with its line.
//!
//! Colours (`Kd`, `Ks`, `Ke`, `Ka`, `Tf`) take one number (grey) or three; `spectral` and
//! `xyz` forms are not supported and are skipped with a warning. Scalars: `Ns`, `Ni`, `d`,
//! `Tr` (= 1 − d), `illum`, and the PBR extension's `Pr` (roughness) and `Pm` (metallic).
//! Gloss (`model::Gloss`): `Pr`/`Pm` when given (GGX α = Pr², default Pr 0.5), else `Ns`
//! when the material has a `Ks` above 0 (α = √(2 / (Ns + 2)), the Phong exponent's
//! equivalent roughness). Textures: `map_Kd` with its options (`-o`, `-s`, `-t`, `-mm`,
//! `-bm`, `-boost`, `-texres`, `-blendu`, `-blendv`, `-cc`, `-clamp`, `-imfchan`) skipped to
//! the file name; other maps are ignored.

use crate::diag::{logical_lines, Diagnostics};
use crate::model::Mtl;
use std::path::Path;

fn colour(rest: &[&str]) -> Result<[f64; 3], String> {
    let nums: Vec<f64> = rest
        .iter()
        .map(|w| match w.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("'{w}' is not a finite number")),
        })
        .collect::<Result<_, _>>()?;
    match nums.len() {
        1 => Ok([nums[0]; 3]),
        3 => Ok([nums[0], nums[1], nums[2]]),
        n => Err(format!("a colour has 1 or 3 numbers, found {n}")),
    }
}

fn scalar(rest: &[&str]) -> Result<f64, String> {
    match rest {
        [w] => match w.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("'{w}' is not a finite number")),
        },
        _ => Err(format!("needs 1 number, found {}", rest.len())),
    }
}

/// The file name of a `map_*` statement after its options.
fn map_file(rest: &[&str]) -> Option<String> {
    let mut i = 0;
    while i < rest.len() {
        let w = rest[i];
        let args = match w {
            "-o" | "-s" | "-t" => {
                // One to three numbers.
                let mut n = 0;
                while n < 3
                    && rest
                        .get(i + 1 + n)
                        .is_some_and(|x| x.parse::<f64>().is_ok())
                {
                    n += 1;
                }
                n
            }
            "-mm" => 2,
            "-bm" | "-boost" | "-texres" | "-blendu" | "-blendv" | "-cc" | "-clamp"
            | "-imfchan" => 1,
            _ => return Some(rest[i..].join(" ")),
        };
        i += 1 + args;
    }
    None
}

/// Parses the MTL at `path` from `bytes`; problems go to `diag`.
pub fn parse(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Vec<Mtl> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out: Vec<Mtl> = Vec::new();
    // Per material: Ns, Pr, Pm as written.
    let mut gloss: Vec<[Option<f64>; 3]> = Vec::new();
    for (line, text) in logical_lines(bytes) {
        let mut words = text.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        if key == "newmtl" {
            gloss.push([None; 3]);
            out.push(Mtl {
                name: rest.join(" "),
                at: (path.to_path_buf(), line),
                ..Default::default()
            });
            continue;
        }
        let Some(([ns, pr, pm], m)) = gloss.last_mut().zip(out.last_mut()) else {
            if matches!(
                key,
                "Kd" | "Ks" | "Ke" | "Ka" | "Tf" | "Ni" | "d" | "Tr" | "illum" | "map_Kd"
            ) {
                diag.error(path, line, format!("'{key}' before any 'newmtl'"));
            }
            continue;
        };
        let col = |slot: &mut Option<[f64; 3]>, diag: &mut Diagnostics| {
            if matches!(rest.first(), Some(&"spectral") | Some(&"xyz")) {
                diag.warn(format!(
                    "{}: '{key} {}' colours are not supported; material '{}' keeps its default",
                    path.display(),
                    rest[0],
                    m.name
                ));
                return;
            }
            match colour(&rest) {
                Ok(c) => *slot = Some(c),
                Err(e) => diag.error(path, line, format!("'{key}': {e}")),
            }
        };
        match key {
            "Kd" => col(&mut m.kd, diag),
            "Ks" => col(&mut m.ks, diag),
            "Ke" => col(&mut m.ke, diag),
            "Tf" => col(&mut m.tf, diag),
            "Ka" => {
                let mut unused = None;
                col(&mut unused, diag);
            }
            "Ni" | "d" | "Tr" | "Ns" | "illum" | "Pr" | "Pm" => match scalar(&rest) {
                Ok(x) => match key {
                    "Ni" => m.ni = Some(x),
                    "d" => m.d = Some(x),
                    "Tr" => m.d = Some(1.0 - x),
                    "illum" => m.illum = Some(x as i64),
                    "Ns" => *ns = Some(x),
                    "Pr" => *pr = Some(x),
                    "Pm" => *pm = Some(x),
                    _ => {}
                },
                Err(e) => diag.error(path, line, format!("'{key}': {e}")),
            },
            "map_Kd" => match map_file(&rest) {
                Some(f) => m.map_kd = Some(dir.join(f)),
                None => diag.error(path, line, "'map_Kd' names no file"),
            },
            _ => {}
        }
    }
    for (m, [ns, pr, pm]) in out.iter_mut().zip(gloss) {
        m.gloss = if pr.is_some() || pm.is_some() {
            let r = pr.unwrap_or(0.5).clamp(0.0, 1.0);
            Some(crate::model::Gloss {
                alpha: r * r,
                metallic: pm.unwrap_or(0.0).clamp(0.0, 1.0),
            })
        } else {
            ns.filter(|_| m.ks.is_some_and(|k| k.iter().any(|&x| x > 0.0)))
                .map(|n| crate::model::Gloss {
                    alpha: (2.0 / (n.max(0.0) + 2.0)).sqrt(),
                    metallic: 0.0,
                })
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_colours_options_and_errors() {
        let text = b"newmtl a\nKd 0.5\nKs 0.1 0.2 0.3\nKe 10 2\nTr 0.25\nmap_Kd -s 2 2 1 -o 0.5 -bm 1 wood grain.png\nnewmtl b\nKd\nKd spectral x.spd\nNi\n";
        let mut d = Diagnostics::default();
        let m = parse(Path::new("/s/m.mtl"), text, &mut d);
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].kd, Some([0.5; 3]));
        assert_eq!(m[0].ks, Some([0.1, 0.2, 0.3]));
        assert_eq!(m[0].ke, None);
        assert_eq!(m[0].d, Some(0.75));
        assert_eq!(m[0].map_kd.as_deref(), Some(Path::new("/s/wood grain.png")));
        let at: Vec<&str> = d.errors.iter().map(|e| &e[..11]).collect();
        assert_eq!(
            at,
            ["/s/m.mtl:4:", "/s/m.mtl:8:", "/s/m.mtl:10"],
            "{:?}",
            d.errors
        );
        assert_eq!(d.warnings.len(), 1);
    }
}
