//! Radiance scene files (`.rad`): the primitives Honeybee and most daylighting users write.
//!
//! A primitive is `modifier type identifier`, then its string, integer and real arguments,
//! each list preceded by its count; tokens are free format across lines, `#` starts a
//! comment. Read:
//! - surfaces: `polygon` (cut by ear clipping like every polygon here), and tessellated
//!   `sphere`/`bubble`, `cone`/`cup`, `cylinder`/`tube`, `ring` (bubble, cup and tube face
//!   inward). Tessellations keep the true area (their radii are scaled), so an emitting
//!   sphere gives the flux Radiance gives it;
//! - materials: `plastic` (diffuse colour·(1 − spec), white mirror spec), `metal` (its
//!   mirror part coloured), `trans` (Rd = colour·(1 − spec)·(1 − trans), Td =
//!   colour·(1 − spec)·trans·(1 − tspec), Ts the rest of trans, read as diffuse with a
//!   warning), `mirror`, `glass` (a pane: see below), `dielectric` (a solid of index n),
//!   `light` and `glow` (emitters of radiance L: exitance πL with the luminance Radiance
//!   gives, 179 lm/W × (0.265 R + 0.670 G + 0.065 B)), `illum` (a Radiance computing aid:
//!   read as the material it names, or as nothing), `alias`;
//! - `glass` is a thin pane in Radiance (one surface, two interfaces, transmissivity tn
//!   per pass at normal incidence, index 1.52 or the fourth argument). Each glass polygon
//!   becomes a closed slab (its back face a thousandth of the model's size behind it) of
//!   that index whose internal transmittance at normal incidence is tn: the same Fresnel
//!   reflections, path lengths at oblique incidence and inter-reflections.
//!
//! A rough `plastic` or `metal` (roughness ≥ 0.01 and spec > 0) is a microfacet surface
//! (`model::Gloss`, GGX α = Radiance's rms slope): plastic its colour under a coat whose
//! reflectance at normal incidence is `spec`, metal a conductor whose reflectance at normal
//! incidence is the colour. A rough `trans`'s specular part stays a mirror, said once per
//! material. Patterns and textures are left out with a warning.
//! `!` commands, `xform`, `instance`, `mesh` and distant `source`s are refused with a
//! message that says what to do instead; unknown material types are grey 0.5 with a
//! warning that names the `[materials.NAME]` override.

use crate::diag::{decode, printable, Diagnostics};
use crate::model::Model;
use crate::model::Mtl;
use crate::model::Object;
use glam::DVec3;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

/// Radiance's luminous efficacy of its RGB (lm/W) and the luminance weights of R, G, B.
const WHITE_EFFICACY: f64 = 179.0;
const LUMINANCE_RGB: [f64; 3] = [0.265, 0.670, 0.065];

/// Segments around a tessellated round surface, and rows of a sphere.
const SEGMENTS: usize = 32;
const SPHERE_ROWS: usize = 16;

/// A glass pane's slab is this share of the model's bounding diagonal thick.
const PANE_SHARE: f64 = 1e-3;

/// What a modifier name stands for.
#[derive(Clone, Debug)]
enum Modifier {
    /// `model.materials[i]`.
    Material(usize),
    /// Surfaces with it are left out (an `illum` with no alternate, `antimatter`).
    Nothing,
    /// A pattern or texture: left out of the materials it modifies.
    Pattern,
}

struct Primitive {
    line: usize,
    modifier: String,
    kind: String,
    id: String,
    strings: Vec<String>,
    reals: Vec<f64>,
}

/// The file's tokens, each with its line; `!` command lines are errors.
fn tokens(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let text = decode(raw.strip_suffix(b"\r").unwrap_or(raw));
        let trimmed = text.trim_start();
        if let Some(command) = trimmed.strip_prefix('!') {
            diag.error(
                path,
                i + 1,
                format!(
                    "'{}' runs a command, which imap does not do: run it yourself and give its output as a file (for example: {} > part.rad)",
                    trimmed.chars().take(60).collect::<String>(),
                    command.trim().chars().take(60).collect::<String>()
                ),
            );
            continue;
        }
        for w in text.split_whitespace() {
            if w.starts_with('#') {
                break;
            }
            out.push((i + 1, w.to_string()));
        }
    }
    out
}

/// A word of the file for a message: printable, and at most 40 characters.
fn shown(w: &str) -> String {
    let mut s: String = w.chars().take(40).collect();
    if w.chars().count() > 40 {
        s.push('…');
    }
    printable(&s)
}

/// Reads the primitives; errors (bad counts, numbers) go to `diag` with their line.
fn primitives(path: &Path, toks: &[(usize, String)], diag: &mut Diagnostics) -> Vec<Primitive> {
    let mut out = Vec::new();
    let mut i = 0;
    let end_line = toks.last().map_or(0, |t| t.0);
    while i < toks.len() {
        let line = toks[i].0;
        let word = |k: usize| toks.get(k).map(|t| t.1.as_str());
        let (Some(modifier), Some(kind), Some(id)) = (word(i), word(i + 1), word(i + 2)) else {
            diag.error(
                path,
                line,
                "a primitive needs a modifier, a type and an identifier",
            );
            return out;
        };
        let kind_s = shown(kind);
        let mut k = i + 3;
        let count = |k: &mut usize, what: &str, diag: &mut Diagnostics| -> Option<usize> {
            let (l, w) = match toks.get(*k) {
                Some((l, w)) => (*l, w.as_str()),
                None => {
                    diag.error(
                        path,
                        end_line,
                        format!(
                            "{kind_s} '{}': the file ends before its {what} count",
                            shown(id)
                        ),
                    );
                    return None;
                }
            };
            *k += 1;
            match w.parse::<usize>() {
                Ok(n) => Some(n),
                _ => {
                    diag.error(
                        path,
                        l,
                        format!(
                            "{kind_s} '{}': '{}' is not a count of {what} arguments",
                            shown(id),
                            shown(w)
                        ),
                    );
                    None
                }
            }
        };
        let Some(ns) = count(&mut k, "string", diag) else {
            return out;
        };
        if ns > toks.len() - k {
            diag.error(
                path,
                end_line,
                format!(
                    "{kind_s} '{}': the file ends inside its string arguments",
                    shown(id)
                ),
            );
            return out;
        }
        let strings: Vec<String> = toks[k..k + ns].iter().map(|t| t.1.clone()).collect();
        k += ns;
        let Some(ni) = count(&mut k, "integer", diag) else {
            return out;
        };
        if ni > toks.len() - k {
            diag.error(
                path,
                end_line,
                format!(
                    "{kind_s} '{}': the file ends inside its integer arguments",
                    shown(id)
                ),
            );
            return out;
        }
        k += ni;
        let Some(nr) = count(&mut k, "real", diag) else {
            return out;
        };
        if nr > toks.len() - k {
            diag.error(
                path,
                end_line,
                format!(
                    "{kind_s} '{}': the file ends inside its real arguments",
                    shown(id)
                ),
            );
            return out;
        }
        let mut reals = Vec::with_capacity(nr);
        for (l, w) in &toks[k..k + nr] {
            match w.parse::<f64>() {
                Ok(x) if x.is_finite() && x.abs() <= crate::model::MAX_COORDINATE => reals.push(x),
                _ => {
                    diag.error(
                        path,
                        *l,
                        format!(
                            "{kind_s} '{}': '{}' is not a finite number",
                            shown(id),
                            shown(w)
                        ),
                    );
                    reals.push(0.0);
                }
            }
        }
        k += nr;
        out.push(Primitive {
            line,
            modifier: modifier.to_string(),
            kind: kind.to_string(),
            id: id.to_string(),
            strings,
            reals,
        });
        i = k;
    }
    out
}

/// The reader's state: the model being built and the names defined so far.
struct Reader<'a> {
    path: &'a Path,
    model: Model,
    names: HashMap<String, Modifier>,
    objects: HashMap<String, usize>,
    /// Glass polygons, made into slabs once the model's size is known: (object, corners,
    /// material).
    panes: Vec<(usize, Vec<DVec3>, usize)>,
    faces: crate::readers::polygon::Faces,
    /// Counts for the warnings given once.
    rough: Vec<String>,
    left_out: HashMap<String, (usize, usize)>,
}

impl Reader<'_> {
    fn object(&mut self, name: &str) -> usize {
        if let Some(&o) = self.objects.get(name) {
            return o;
        }
        self.model.objects.push(Object {
            name: name.to_string(),
            triangles: Vec::new(),
        });
        let o = self.model.objects.len() - 1;
        self.objects.insert(name.to_string(), o);
        o
    }

    fn add_triangles(&mut self, o: usize, corners: &[DVec3], tris: &[[usize; 3]], material: usize) {
        let base = self.model.positions.len() as u32;
        self.model
            .positions
            .extend(corners.iter().map(|p| p.to_array()));
        // A BSDF surface's normal faces Radiance's front, which is WINDOW's back (libBSDF
        // swaps them when it reads the file): libimap's faces the file's front.
        let flip = self.model.materials[material].window_bsdf.is_some();
        for t in tris {
            let t = if flip { [t[0], t[2], t[1]] } else { *t };
            crate::model::push_triangle(
                &mut self.model.objects[o].triangles,
                &mut self.model.degenerate,
                t.map(|k| base + k as u32),
                None,
                Some(material),
            );
        }
    }

    fn note_left_out(&mut self, what: &str, line: usize) {
        let e = self.left_out.entry(what.to_string()).or_insert((0, line));
        e.0 += 1;
    }

    /// The material a surface's modifier names, resolving aliases; None: leave it out.
    fn material_of(&mut self, p: &Primitive, diag: &mut Diagnostics) -> Option<usize> {
        match self.names.get(&p.modifier) {
            Some(Modifier::Material(i)) => Some(*i),
            Some(Modifier::Nothing) => {
                self.note_left_out(
                    "surfaces of an illum without an alternate material or of antimatter",
                    p.line,
                );
                None
            }
            Some(Modifier::Pattern) => {
                diag.error(
                    self.path,
                    p.line,
                    format!(
                        "{} '{}': its modifier '{}' is a pattern or texture, not a material",
                        p.kind,
                        printable(&p.id),
                        printable(&p.modifier)
                    ),
                );
                None
            }
            None if p.modifier == "void" => {
                self.note_left_out("surfaces with the void modifier", p.line);
                None
            }
            None => {
                diag.error(
                    self.path,
                    p.line,
                    format!(
                        "{} '{}': modifier '{}' is not defined before it (Radiance reads files in order; exporters such as Honeybee write the modifiers to a separate .mat file: put it first, e.g. cat model.mat model.rad > all.rad)",
                        p.kind,
                        printable(&p.id),
                        printable(&p.modifier)
                    ),
                );
                None
            }
        }
    }

    fn define_material(&mut self, p: &Primitive, diag: &mut Diagnostics) {
        let path = self.path;
        let need = |n: usize, diag: &mut Diagnostics| -> bool {
            if p.reals.len() < n {
                diag.error(
                    path,
                    p.line,
                    format!(
                        "{} '{}' needs {n} real arguments, found {}",
                        p.kind,
                        printable(&p.id),
                        p.reals.len()
                    ),
                );
                false
            } else {
                true
            }
        };
        if !matches!(p.modifier.as_str(), "void") {
            match self.names.get(&p.modifier) {
                Some(Modifier::Pattern) => diag.warn(format!(
                    "{}:{}: material '{}' is modified by pattern or texture '{}', which imap leaves out (the material's plain colour is used)",
                    path.display(), p.line, printable(&p.id), printable(&p.modifier)
                )),
                Some(_) => {}
                None => diag.error(path, p.line, format!("material '{}': modifier '{}' is not defined before it", printable(&p.id), printable(&p.modifier))),
            }
        }
        let mut m = Mtl {
            name: p.id.clone(),
            at: (path.to_path_buf(), p.line),
            ..Default::default()
        };
        if p.kind == "BSDF" || p.kind == "aBSDF" {
            // BSDF: thick file ux uy uz funcfile [transform]; aBSDF: the same without the
            // thickness. Read when the up vector is three numbers and no function file or
            // transform changes it.
            let s = &p.strings[usize::from(p.kind == "BSDF")..];
            let at = |i: usize| s.get(i).and_then(|x| x.parse::<f64>().ok());
            let thick = if p.kind == "BSDF" {
                p.strings.first().and_then(|x| x.parse::<f64>().ok())
            } else {
                Some(0.0)
            };
            if s.get(4).is_some_and(|f| f != ".") || s.len() > 5 {
                return unsupported_material(
                    self,
                    p,
                    diag,
                    "its up vector comes from a function file or a transform",
                );
            }
            let (Some(thick), Some(file), Some(ux), Some(uy), Some(uz)) =
                (thick, s.first(), at(1), at(2), at(3))
            else {
                return unsupported_material(
                    self,
                    p,
                    diag,
                    "its arguments are not a thickness (BSDF), a file and an up vector of numbers",
                );
            };
            if thick != 0.0 {
                diag.warn(format!(
                    "{}:{}: BSDF '{}': its thickness {thick} is left out (the surface scatters where it is; geometry it would hide is traced)",
                    path.display(), p.line, printable(&p.id)
                ));
            }
            if p.reals.iter().any(|&x| x != 0.0) {
                diag.warn(format!(
                    "{}:{}: BSDF '{}': its added diffuse reflectance and transmittance ({} reals) are left out: the file's data alone",
                    path.display(), p.line, printable(&p.id), p.reals.len()
                ));
            }
            let dir = path.parent().unwrap_or(Path::new("."));
            m.kd = Some([0.0; 3]);
            m.window_bsdf = Some((dir.join(file), [ux, uy, uz]));
            self.model.materials.push(m);
            self.names.insert(
                p.id.clone(),
                Modifier::Material(self.model.materials.len() - 1),
            );
            return;
        }
        let rgb = |r: &[f64]| [r[0], r[1], r[2]];
        let scaled = |c: [f64; 3], k: f64| c.map(|x| x * k);
        match p.kind.as_str() {
            "plastic" | "metal" => {
                if !need(5, diag) {
                    return;
                }
                let (c, spec, rough) = (rgb(&p.reals), p.reals[3], p.reals[4]);
                m.kd = Some(scaled(c, 1.0 - spec));
                m.ks = Some(if p.kind == "metal" {
                    scaled(c, spec)
                } else {
                    [spec; 3]
                });
                // (Below α = 0.01 the ideal mapping above stands: a mirror.)
                if spec > 0.0 && rough >= 0.01 {
                    if p.kind == "metal" {
                        m.kd = Some(c);
                    }
                    m.gloss = Some(crate::model::Gloss {
                        alpha: rough.min(1.0),
                        metallic: if p.kind == "metal" { 1.0 } else { 0.0 },
                    });
                }
            }
            "trans" => {
                if !need(7, diag) {
                    return;
                }
                let (c, spec, rough, trans, tspec) = (
                    rgb(&p.reals),
                    p.reals[3],
                    p.reals[4],
                    p.reals[5],
                    p.reals[6],
                );
                m.kd = Some(scaled(c, (1.0 - spec) * (1.0 - trans)));
                m.ks = Some([spec; 3]);
                m.kt = Some(scaled(c, (1.0 - spec) * trans));
                if spec > 0.0 && rough > 0.0 {
                    self.rough.push(format!(
                        "'{}' (line {}, roughness {rough})",
                        printable(&p.id),
                        p.line
                    ));
                }
                if trans > 0.0 && tspec > 0.0 {
                    diag.warn(format!(
                        "{}:{}: trans '{}': its specular transmission ({:.3} of what it transmits) is read as diffuse transmission (libimap has no straight-through transmission yet): light through it spreads instead of passing as a beam",
                        path.display(), p.line, printable(&p.id), tspec
                    ));
                }
            }
            "mirror" => {
                if !need(3, diag) {
                    return;
                }
                m.kd = Some([0.0; 3]);
                m.ks = Some(rgb(&p.reals));
            }
            "glass" => {
                if !need(3, diag) {
                    return;
                }
                let n = p.reals.get(3).copied().unwrap_or(1.52);
                m.tf = Some(rgb(&p.reals).map(|x| x.clamp(0.0, 1.0)));
                m.ni = Some(n.max(1.0 + 1e-3));
                m.d = Some(0.0);
                m.pane = Some(0.0); // its thickness is set with the model's size
            }
            "dielectric" => {
                if !need(4, diag) {
                    return;
                }
                m.ni = Some(p.reals[3].max(1.0 + 1e-3));
                m.d = Some(0.0);
                let tn = rgb(&p.reals);
                if tn.iter().any(|&t| t < 1.0) {
                    diag.warn(format!(
                        "{}:{}: dielectric '{}': its transmission per unit length {:?} is left out (the solid is clear); give absorption_per_m in [materials.{}]",
                        path.display(), p.line, printable(&p.id), tn, printable(&p.id)
                    ));
                }
            }
            "light" | "glow" | "spotlight" => {
                if !need(3, diag) {
                    return;
                }
                let c = rgb(&p.reals).map(|x| x.max(0.0));
                let l = WHITE_EFFICACY * (0..3).map(|k| LUMINANCE_RGB[k] * c[k]).sum::<f64>();
                m.kd = Some([0.0; 3]);
                if l > 0.0 {
                    m.ke = Some(c.map(|x| x * PI));
                    m.ke_luminance = Some(l);
                }
                if p.kind == "spotlight" {
                    diag.warn(format!(
                        "{}:{}: spotlight '{}' is read as a light that emits in every direction of its front side (its cone is left out)",
                        path.display(), p.line, printable(&p.id)
                    ));
                }
            }
            _ => unreachable!(),
        }
        self.model.materials.push(m);
        self.names.insert(
            p.id.clone(),
            Modifier::Material(self.model.materials.len() - 1),
        );
    }

    fn surface(&mut self, p: &Primitive, diag: &mut Diagnostics) {
        let path = self.path;
        let bad = |diag: &mut Diagnostics, why: &str| {
            diag.error(
                path,
                p.line,
                format!("{} '{}': {why}", p.kind, printable(&p.id)),
            );
        };
        let Some(material) = self.material_of(p, diag) else {
            return;
        };
        let v = |k: usize| DVec3::new(p.reals[k], p.reals[k + 1], p.reals[k + 2]);
        match p.kind.as_str() {
            "polygon" => {
                if p.reals.len() < 9 || p.reals.len() % 3 != 0 {
                    return bad(
                        diag,
                        &format!(
                            "a polygon needs 3 or more corners (9, 12, … reals), found {} reals",
                            p.reals.len()
                        ),
                    );
                }
                let corners: Vec<DVec3> = (0..p.reals.len() / 3).map(|k| v(3 * k)).collect();
                let o = self.object(&p.id);
                if self.model.materials[material].pane.is_some() {
                    self.panes.push((o, corners, material));
                    return;
                }
                let tris = if corners.len() == 3 {
                    vec![[0, 1, 2]]
                } else {
                    let cut = crate::readers::polygon::triangulate(&corners, &[]);
                    self.faces.note(&cut, p.line);
                    cut.triangles
                };
                self.add_triangles(o, &corners, &tris, material);
            }
            "sphere" | "bubble" => {
                if p.reals.len() != 4 || p.reals[3] == 0.0 {
                    return bad(
                        diag,
                        "a sphere needs 4 reals: centre x y z and a radius other than 0",
                    );
                }
                let inward = (p.kind == "bubble") != (p.reals[3] < 0.0);
                let (corners, tris) = sphere(v(0), p.reals[3].abs(), inward);
                let o = self.object(&p.id);
                self.add_triangles(o, &corners, &tris, material);
            }
            "cone" | "cup" | "cylinder" | "tube" => {
                let cone = matches!(p.kind.as_str(), "cone" | "cup");
                let (r0, r1) = match (cone, p.reals.len()) {
                    (true, 8) => (p.reals[6], p.reals[7]),
                    (false, 7) => (p.reals[6], p.reals[6]),
                    _ => {
                        return bad(
                            diag,
                            if cone {
                                "a cone needs 8 reals: two end points and two radii"
                            } else {
                                "a cylinder needs 7 reals: two end points and a radius"
                            },
                        )
                    }
                };
                let (a, b) = (v(0), v(3));
                if (b - a).length() == 0.0 || r0 < 0.0 || r1 < 0.0 || (r0 == 0.0 && r1 == 0.0) {
                    return bad(
                        diag,
                        "its ends coincide or its radii are negative or both 0",
                    );
                }
                let inward = matches!(p.kind.as_str(), "cup" | "tube");
                let (corners, tris) = frustum(a, b, r0, r1, inward);
                let o = self.object(&p.id);
                self.add_triangles(o, &corners, &tris, material);
            }
            "ring" => {
                if p.reals.len() != 8 {
                    return bad(diag, "a ring needs 8 reals: centre, normal and two radii");
                }
                let (c, n) = (v(0), v(3));
                let (r0, r1) = (p.reals[6].min(p.reals[7]), p.reals[6].max(p.reals[7]));
                let Some(n) = n.try_normalize() else {
                    return bad(diag, "its normal is zero");
                };
                if r0 < 0.0 || r1 <= r0 {
                    return bad(diag, "its radii must be 0 ≤ r0 < r1");
                }
                let (corners, tris) = ring(c, n, r0, r1);
                let o = self.object(&p.id);
                self.add_triangles(o, &corners, &tris, material);
            }
            _ => unreachable!(),
        }
    }
}

/// A unit frame around axis `n`.
fn frame(n: DVec3) -> (DVec3, DVec3) {
    let a = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let u = n.cross(a).normalize();
    (u, n.cross(u))
}

/// A UV sphere of the true area (radius scaled), outward unless `inward`.
fn sphere(c: DVec3, r: f64, inward: bool) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let (rows, cols) = (SPHERE_ROWS, SEGMENTS);
    let mut unit = vec![DVec3::Z];
    for i in 1..rows {
        let th = PI * i as f64 / rows as f64;
        for j in 0..cols {
            let ph = 2.0 * PI * j as f64 / cols as f64;
            unit.push(DVec3::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    unit.push(-DVec3::Z);
    let last = unit.len() - 1;
    let at = |i: usize, j: usize| 1 + (i - 1) * cols + j % cols;
    let mut tris = Vec::new();
    for j in 0..cols {
        tris.push([0, at(1, j), at(1, j + 1)]);
        tris.push([last, at(rows - 1, j + 1), at(rows - 1, j)]);
    }
    for i in 1..rows - 1 {
        for j in 0..cols {
            tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let area: f64 = tris
        .iter()
        .map(|t| {
            (unit[t[1]] - unit[t[0]])
                .cross(unit[t[2]] - unit[t[0]])
                .length()
                / 2.0
        })
        .sum();
    let k = r * (4.0 * PI / area).sqrt();
    finish(unit.iter().map(|u| c + *u * k).collect(), tris, inward)
}

/// The side of a cone frustum from `a` (radius r0) to `b` (r1) of the true area.
fn frustum(a: DVec3, b: DVec3, r0: f64, r1: f64, inward: bool) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let axis = b - a;
    let (u, w) = frame(axis.normalize());
    // A regular polygon's perimeter is short of the circle's by sin(π/n)/(π/n): scale the
    // radii so the side's area (½ (P0 + P1) × slant, nearly) matches.
    let s = (PI / SEGMENTS as f64) / (PI / SEGMENTS as f64).sin();
    let dir = |j: usize| {
        let ph = 2.0 * PI * j as f64 / SEGMENTS as f64;
        u * ph.cos() + w * ph.sin()
    };
    let mut corners = Vec::with_capacity(2 * SEGMENTS);
    for j in 0..SEGMENTS {
        corners.push(a + dir(j) * r0 * s);
        corners.push(b + dir(j) * r1 * s);
    }
    let mut tris = Vec::new();
    for j in 0..SEGMENTS {
        let (p0, p1, q0, q1) = (
            2 * j,
            2 * j + 1,
            2 * ((j + 1) % SEGMENTS),
            2 * ((j + 1) % SEGMENTS) + 1,
        );
        // Outward: counter-clockwise seen from outside.
        tris.push([p0, q0, q1]);
        tris.push([p0, q1, p1]);
    }
    finish(corners, tris, inward)
}

/// A ring (a disk when r0 = 0) facing `n`, of the true area.
fn ring(c: DVec3, n: DVec3, r0: f64, r1: f64) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let (u, w) = frame(n);
    let t = PI / SEGMENTS as f64;
    // A regular n-gon's area is n/(2π) sin(2π/n) of the circle's.
    let s = (t / (t.sin() * t.cos())).sqrt();
    let dir = |j: usize| {
        let ph = 2.0 * PI * j as f64 / SEGMENTS as f64;
        u * ph.cos() + w * ph.sin()
    };
    let mut corners = Vec::new();
    let mut tris = Vec::new();
    if r0 == 0.0 {
        corners.push(c);
        for j in 0..SEGMENTS {
            corners.push(c + dir(j) * r1 * s);
        }
        for j in 0..SEGMENTS {
            tris.push([0, 1 + j, 1 + (j + 1) % SEGMENTS]);
        }
    } else {
        for j in 0..SEGMENTS {
            corners.push(c + dir(j) * r0 * s);
            corners.push(c + dir(j) * r1 * s);
        }
        for j in 0..SEGMENTS {
            let (i0, o0, i1, o1) = (
                2 * j,
                2 * j + 1,
                2 * ((j + 1) % SEGMENTS),
                2 * ((j + 1) % SEGMENTS) + 1,
            );
            tris.push([i0, o0, o1]);
            tris.push([i0, o1, i1]);
        }
    }
    (corners, tris)
}

fn finish(
    corners: Vec<DVec3>,
    mut tris: Vec<[usize; 3]>,
    inward: bool,
) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    if inward {
        for t in &mut tris {
            t.swap(1, 2);
        }
    }
    (corners, tris)
}

/// A closed slab of `thickness` behind the polygon `corners` (front: the polygon as wound).
fn slab(corners: &[DVec3], front: &[[usize; 3]], thickness: f64) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let n = crate::readers::polygon::newell(corners).normalize_or_zero();
    let k = corners.len();
    let mut all: Vec<DVec3> = corners.to_vec();
    all.extend(corners.iter().map(|p| *p - n * thickness));
    let mut tris: Vec<[usize; 3]> = front.to_vec();
    tris.extend(front.iter().map(|t| [t[0] + k, t[2] + k, t[1] + k]));
    for i in 0..k {
        let j = (i + 1) % k;
        tris.push([i, i + k, j]);
        tris.push([j, i + k, j + k]);
    }
    (all, tris)
}

/// Reads a Radiance scene file.
pub fn load(path: &Path, bytes: &[u8], diag: &mut Diagnostics) -> Model {
    let toks = tokens(path, bytes, diag);
    let prims = primitives(path, &toks, diag);
    let mut r = Reader {
        path,
        model: Model {
            format: "Radiance",
            ..Default::default()
        },
        names: HashMap::new(),
        objects: HashMap::new(),
        panes: Vec::new(),
        faces: Default::default(),
        rough: Vec::new(),
        left_out: HashMap::new(),
    };
    for p in &prims {
        match p.kind.as_str() {
            "plastic" | "metal" | "trans" | "mirror" | "glass" | "dielectric" | "light" | "glow" | "spotlight" | "BSDF" | "aBSDF" => {
                r.define_material(p, diag)
            }
            "polygon" | "sphere" | "bubble" | "cone" | "cup" | "cylinder" | "tube" | "ring" => r.surface(p, diag),
            "alias" => match p.strings.first().and_then(|t| r.names.get(t).cloned()) {
                Some(m) => {
                    r.names.insert(p.id.clone(), m);
                }
                None => diag.error(path, p.line, format!("alias '{}' names no material defined before it", printable(&p.id))),
            },
            "illum" => {
                // Radiance's aid to sampling: for light itself, the alternate material.
                let alt = p.strings.first().map(|s| s.as_str());
                let m = match alt {
                    None | Some("void") => Modifier::Nothing,
                    Some(a) => match r.names.get(a) {
                        Some(m) => m.clone(),
                        None => {
                            diag.error(path, p.line, format!("illum '{}': its material '{}' is not defined before it", printable(&p.id), printable(a)));
                            Modifier::Nothing
                        }
                    },
                };
                r.names.insert(p.id.clone(), m);
            }
            "antimatter" => {
                diag.warn(format!("{}:{}: antimatter '{}' is not modelled: surfaces with it are left out, and what it would cut away stays", path.display(), p.line, printable(&p.id)));
                r.names.insert(p.id.clone(), Modifier::Nothing);
            }
            "source" => diag.error(
                path,
                p.line,
                format!("source '{}' is a distant light (a sky or the sun): describe the sky with [sky] and the sun with [sun] in the settings, and leave sky files out of the model", printable(&p.id)),
            ),
            "instance" | "mesh" => diag.error(
                path,
                p.line,
                format!("{} '{}' refers to a compiled {} file, which imap does not read: give its geometry as polygons (obj2rad) or as an OBJ", p.kind, printable(&p.id), if p.kind == "mesh" { "Radiance mesh" } else { "octree" }),
            ),
            "xform" => diag.error(path, p.line, "xform is a command, not a primitive: run it and give its output"),
            "brightfunc" | "colorfunc" | "brightdata" | "colordata" | "colorpict" | "brighttext"
            | "colortext" | "texfunc" | "texdata" | "specfunc" | "specdata" | "specpict" => {
                r.names.insert(p.id.clone(), Modifier::Pattern);
            }
            _ => unsupported(&mut r, p, diag),
        }
    }
    // Glass panes as slabs, now that the model's size is known.
    let panes = std::mem::take(&mut r.panes);
    if !panes.is_empty() {
        let all = r
            .model
            .positions
            .iter()
            .copied()
            .chain(panes.iter().flat_map(|p| p.1.iter().map(|c| c.to_array())));
        let (lo, hi) = crate::model::bounds(all);
        let diag_len = (DVec3::from(hi) - DVec3::from(lo)).length();
        let t = PANE_SHARE * diag_len;
        for (o, corners, material) in &panes {
            let cut = crate::readers::polygon::triangulate(corners, &[]);
            if corners.len() > 3 {
                r.faces.note(&cut, r.model.materials[*material].at.1);
            }
            let (all, tris) = slab(corners, &cut.triangles, t);
            r.add_triangles(*o, &all, &tris, *material);
        }
        for m in r.model.materials.iter_mut().filter(|m| m.pane.is_some()) {
            m.pane = Some(t);
        }
        diag.warn(format!(
            "{}: {} glass polygon(s) are read as panes {:.3e} units thick (a thousandth of the model's size) of the glass's index, with its transmissivity per pass",
            path.display(),
            panes.len(),
            t
        ));
    }
    if !r.rough.is_empty() {
        diag.warn(format!(
            "{}: {} trans material(s) have a rough specular part, read as a mirror: {}",
            path.display(),
            r.rough.len(),
            r.rough
                .iter()
                .take(3)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let mut left: Vec<_> = r.left_out.iter().collect();
    left.sort_by_key(|(_, (_, line))| *line);
    for (what, (n, line)) in left {
        diag.warn(format!(
            "{}:{line}: {n} primitive(s) left out: {what}",
            path.display()
        ));
    }
    r.faces.warn(path, diag);
    r.model
}

/// A material of a type that is read but whose arguments are not (why): grey, as an
/// unread type's.
fn unsupported_material(r: &mut Reader, p: &Primitive, diag: &mut Diagnostics, why: &str) {
    let what = format!(
        "{} '{}' is not read ({why})",
        printable(&p.kind),
        printable(&p.id)
    );
    left_grey(r, p, diag, &what);
}

fn unsupported(r: &mut Reader, p: &Primitive, diag: &mut Diagnostics) {
    let what = format!(
        "material type '{}' ('{}') is not read",
        printable(&p.kind),
        printable(&p.id)
    );
    left_grey(r, p, diag, &what);
}

/// Warns that `p` (`what`) is not read and defines its name as a grey 0.5 material.
fn left_grey(r: &mut Reader, p: &Primitive, diag: &mut Diagnostics, what: &str) {
    diag.warn(format!(
        "{}:{}: {what}: surfaces with it are grey 0.5; describe it with [materials.{}] in the settings",
        r.path.display(),
        p.line,
        printable(&p.id)
    ));
    grey_material(r, p);
}

/// Defines `p`'s name as a grey 0.5 material.
fn grey_material(r: &mut Reader, p: &Primitive) {
    let m = Mtl {
        name: p.id.clone(),
        at: (r.path.to_path_buf(), p.line),
        kd: Some([0.5; 3]),
        ..Default::default()
    };
    r.model.materials.push(m);
    r.names.insert(
        p.id.clone(),
        Modifier::Material(r.model.materials.len() - 1),
    );
}

/// The triangles' vertices as positions (test helper).
#[cfg(test)]
fn area(m: &Model, o: usize) -> f64 {
    m.objects[o]
        .triangles
        .iter()
        .map(|t: &crate::model::Triangle| {
            let [a, b, c] = t.v.map(|v| DVec3::from(m.positions[v as usize]));
            (b - a).cross(c - a).length() / 2.0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> (Model, Diagnostics) {
        let mut d = Diagnostics::default();
        let m = load(Path::new("t.rad"), text.as_bytes(), &mut d);
        (m, d)
    }

    #[test]
    fn materials_follow_radiance_definitions() {
        let (m, d) = read(
            "# a comment\nvoid plastic wall 0 0 5 .6 .5 .4 .05 0\nvoid metal alu\n0\n0\n5 .8 .8 .9 .9 .02\n\
             void trans opal 0 0 7 .6 .6 .6 0 0 1 .1666\nvoid light lamp 0 0 3 10 10 10\n\
             void mirror m 0 0 3 .9 .9 .9\n",
        );
        assert!(d.errors.is_empty(), "{:?}", d.errors);
        let w = &m.materials[0];
        assert_eq!(
            w.kd.unwrap().map(|x| (x * 1000.0).round()),
            [570.0, 475.0, 380.0]
        );
        assert_eq!(w.ks, Some([0.05; 3]));
        let a = &m.materials[1];
        // A rough metal: a conductor whose reflectance at normal incidence is its colour.
        assert_eq!(a.kd, Some([0.8, 0.8, 0.9]));
        assert_eq!(
            a.gloss,
            Some(crate::model::Gloss {
                alpha: 0.02,
                metallic: 1.0
            })
        );
        // Greg Ward's example: 60 % through, one sixth of it as a beam.
        let o = &m.materials[2];
        assert_eq!(o.kd, Some([0.0; 3]));
        assert!((o.kt.unwrap()[0] - 0.6).abs() < 1e-12);
        let l = &m.materials[3];
        assert!((l.ke_luminance.unwrap() - 1790.0).abs() < 1e-9);
        assert!((l.ke.unwrap()[0] - 10.0 * PI).abs() < 1e-12);
        assert_eq!(m.materials[4].ks, Some([0.9; 3]));
        // The rough metal is read without a warning; trans's beam is diffuse, with one.
        assert!(
            !d.warnings.iter().any(|w| w.contains("'alu'")),
            "{:?}",
            d.warnings
        );
        assert!(
            d.warnings
                .iter()
                .any(|w| w.contains("t.rad:7: trans 'opal'")),
            "{:?}",
            d.warnings
        );
    }

    #[test]
    fn tessellations_keep_the_true_area_and_face_the_right_way() {
        let (m, d) = read(
            "void plastic g 0 0 5 .5 .5 .5 0 0\n\
             g sphere s 0 0 4 1 2 3 0.5\ng bubble b 0 0 4 0 0 0 2\n\
             g cylinder c 0 0 7 0 0 0 0 0 2 0.5\ng cone k 0 0 8 0 0 0 0 0 1 1 0\n\
             g ring r 0 0 8 0 0 0 0 0 1 0.5 1\ng ring disk 0 0 8 0 0 0 0 0 -1 0 1\n\
             g polygon p 0 0 12 0 0 0 2 0 0 2 1 0 0 1 0\n",
        );
        assert!(d.errors.is_empty(), "{:?}", d.errors);
        let want = [
            PI,
            16.0 * PI,
            2.0 * PI,
            PI * 2f64.sqrt(),
            PI * 0.75,
            PI,
            2.0,
        ];
        for (o, w) in want.iter().enumerate() {
            let a = area(&m, o);
            assert!(
                (a / w - 1.0).abs() < 2e-3,
                "{}: {a} vs {w}",
                m.objects[o].name
            );
        }
        // Volumes: the sphere's outward (positive), the bubble's inward (negative).
        assert!(m.orientation(0).1 > 0.0 && m.orientation(0).0);
        assert!(m.orientation(1).1 < 0.0 && m.orientation(1).0);
        // The disk faces −z, the polygon +z.
        let normal = |o: usize| {
            let t = &m.objects[o].triangles[0];
            let [a, b, c] = t.v.map(|v| DVec3::from(m.positions[v as usize]));
            (b - a).cross(c - a).normalize()
        };
        assert!((normal(5).z + 1.0).abs() < 1e-9 && (normal(6).z - 1.0).abs() < 1e-9);
    }

    #[test]
    fn glass_becomes_a_closed_slab_and_unread_things_are_named() {
        let (m, d) = read(
            "void glass clear 0 0 3 .96 .96 .96\nclear polygon pane 0 0 12 0 0 0 1 0 0 1 1 0 0 1 0\n\
             void plastic g 0 0 5 .5 .5 .5 0 0\ng polygon floor 0 0 12 -5 -5 -1 5 -5 -1 5 5 -1 -5 5 -1\n\
             void BSDF blind 6 0 blind.xml 0 1 0 . 0 0\nblind polygon b 0 0 9 0 0 0 1 0 0 0 1 0\n\
             void plasfunc pf 2 refl f.cal 0 0\npf polygon c 0 0 9 0 0 0 1 0 0 0 1 0\n",
        );
        // The BSDF: its file beside the scene, its up vector, its surface turned to face
        // the file's front (Radiance's normal +z → −z).
        let blind = m.materials.iter().find(|x| x.name == "blind").unwrap();
        assert_eq!(
            blind.window_bsdf,
            Some((std::path::PathBuf::from("blind.xml"), [0.0, 1.0, 0.0]))
        );
        let b = m.objects.iter().find(|o| o.name == "b").unwrap();
        let [p0, p1, p2] = b.triangles[0]
            .v
            .map(|v| DVec3::from(m.positions[v as usize]));
        assert!(((p1 - p0).cross(p2 - p0).normalize().z + 1.0).abs() < 1e-12);
        assert!(d.errors.is_empty(), "{:?}", d.errors);
        let pane = m.objects.iter().position(|o| o.name == "pane").unwrap();
        let (closed, vol) = m.orientation(pane);
        let t = m.materials[0].pane.unwrap();
        assert!(
            closed && (vol - t).abs() < 1e-9 * t.max(1.0),
            "closed {closed}, volume {vol}, t {t}"
        );
        assert!((t - 1e-3 * (10f64.powi(2) * 2.0 + 1.0).sqrt()).abs() < 1e-12);
        assert!(d.warnings.iter().any(|w| w
            .contains("material type 'plasfunc' ('pf') is not read")
            && w.contains("[materials.pf]")));
        // Refusals say what to do instead, with the line.
        for (text, says) in [
            (
                "!xform -t 1 0 0 chair.rad\n",
                "t.rad:1: '!xform -t 1 0 0 chair.rad' runs a command",
            ),
            (
                "void plastic g 0 0 5 .5 .5 .5 0 0\ng mesh m 1 chair.rtm 0 0\n",
                "t.rad:2: mesh 'm' refers to a compiled Radiance mesh",
            ),
            (
                "void light sun 0 0 3 1 1 1\nsun source s 0 0 4 0 0 1 0.5\n",
                "describe the sky with [sky]",
            ),
            (
                "g polygon p 0 0 9 0 0 0 1 0 0 0 1 0\n",
                "t.rad:1: polygon 'p': modifier 'g' is not defined before it",
            ),
            (
                "void plastic g 0 0 5 .5 .5 .5 0 0\ng polygon p 0 0 8 0 0 0 1 0 0 0 1\n",
                "t.rad:2: polygon 'p': a polygon needs 3 or more corners",
            ),
            (
                "void plastic g 0 0 3 .5 .5 .5\n",
                "plastic 'g' needs 5 real arguments",
            ),
            (
                "void plastic g 0 0 5 .5 .5 .5 0 x\n",
                "t.rad:1: plastic 'g': 'x' is not a finite number",
            ),
            (
                "void plastic g 0 0 9 .5\n",
                "the file ends inside its real arguments",
            ),
        ] {
            let (_, d) = read(text);
            assert!(
                d.errors.iter().any(|e| e.contains(says)),
                "{text:?}: {:?}",
                d.errors
            );
        }
    }
}
