//! From MTL materials (and the settings' overrides) to libimap materials.
//!
//! - `Kd` → Lambertian reflectance, `Ks` → mirror reflectance; values outside [0, 1] are
//!   clamped, and where `Kd + Ks` exceeds 1 (3ds Max and assimp exports do this) both are
//!   scaled down to conserve energy; each with one warning per material.
//! - No `Kd` and no texture: grey 0.5, with a warning (black for an emitting material).
//! - Transparency (`d` < 1, `Tr` > 0, or a `Tf` below 1) with `Ni` > 1: a dielectric of
//!   index `Ni` (`Tf` = internal transmittance of 1 m). Exporters write `Ni` on opaque
//!   materials (Blender: 1.45) and `d 0` or `Ni 1` where they mean nothing in particular:
//!   transparency without refraction is read as opaque (a fully transparent black one as
//!   a pass-through interface), each with a warning.
//! - `Ke` above 0 → an emitting surface, exitance `Ke` W/m² per band.
//! - Gloss (`model::Gloss`: glTF roughness/metallic, MTL `Pr`/`Pm`/`Ns`, Radiance's rough
//!   plastic and metal) with GGX α ≥ 0.01 makes a microfacet surface: a metal (metallic ≥
//!   0.5) a conductor whose reflectance at normal incidence is the colour (n = 1, k =
//!   2√(F0 / (1 − F0)) per band), anything else a plastic: the colour under a coat whose
//!   reflectance at normal incidence is the mean `Ks` (index (1 + √F0) / (1 − √F0)), or 4 %
//!   (index 1.5) without a `Ks`. A smoother one keeps the ideal mapping above.
//! - `[materials.NAME]` in the settings overrides any of it: `diffuse`, `specular`,
//!   `transmit`, `emission`, `ior`, `sellmeier`, `absorption_per_m`, `scattering_per_m`,
//!   `phase_g` or `phase_table` (rows of [angle in degrees, value] from 0 to 180: a
//!   dielectric's scattering medium), `fluorescence = { excitation, quantum_yield,
//!   emission }` (spectral runs: a Lambertian surface's, or an absorbing dielectric's
//!   medium's, `excitation` then the share of its absorption that fluoresces),
//!   `dielectric = true/false` to make or
//!   unmake glass, and `kind = "ideal" | "conductor" | "plastic" |
//!   "rough-dielectric"` with `roughness` (α, or [α along the tangent, α across]),
//!   `tangent`, a conductor's `metal` ("aluminium", "silver", "gold", "copper",
//!   "chromium") or `nk` rows [nm, n, k], a plastic's coat `ior` (default 1.5) over
//!   `diffuse`; or `kind = "bsdf-xml"` with `file` (a window BSDF file, LBNL WINDOW /
//!   Radiance XML in a Klems basis, relative to the settings file) and `up` (default +z):
//!   the faces' normals point to the file's front (a window's exterior); or `kind =
//!   "table"` with `grid = [θ in, φ in, θ out, φ out]`, `brdf` and optionally `btdf` (text
//!   files of values in 1/sr, `[band][θi][φi][θo][φo]`, one band's for all or one per
//!   band; docs/materials.md) and `tangent`.

use crate::diag::{printable, Diagnostics};
use crate::model::Mtl;
use crate::settings::{channel, MaterialSettings, RoughnessSetting, Spectrum};
use imap::{ConductorIndex, IorModel, MaterialDesc, Metal, SurfaceModel, TableDesc};

/// A material ready for libimap, with what the outputs need of it.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub desc: MaterialDesc,
    /// Diffuse reflectance per band (for the rendered view).
    pub diffuse: Vec<f64>,
    pub emission: Option<Vec<f64>>,
}

/// What resolving needs of the run's units: each band's luminous efficacy (lm/W) and the
/// scene unit in metres.
pub struct Units<'a> {
    pub efficacy: &'a [f64],
    pub unit_m: f64,
}

/// RGB → per-band values (the band's colour channel by wavelength).
pub fn expand_rgb(rgb: [f64; 3], band_nm: &[f64], is_rgb: bool) -> Vec<f64> {
    if is_rgb {
        return rgb.to_vec();
    }
    band_nm.iter().map(|&nm| rgb[channel(nm)]).collect()
}

/// The default material: Lambertian grey 0.5.
pub fn default_grey(bands: usize) -> Resolved {
    Resolved {
        desc: MaterialDesc {
            diffuse_reflect: vec![0.5; bands],
            ..Default::default()
        },
        diffuse: vec![0.5; bands],
        emission: None,
    }
}

/// Maps MTL material `m` with the settings' overrides `o`.
pub fn resolve(
    m: &Mtl,
    o: Option<&MaterialSettings>,
    settings_at: &(std::path::PathBuf, usize),
    band_nm: &[f64],
    rgb: bool,
    units: &Units,
    diag: &mut Diagnostics,
) -> Resolved {
    let nb = band_nm.len();
    let name = printable(&m.name);
    let o = o.cloned().unwrap_or_default();
    let (file, line) = (&m.at.0, m.at.1);
    let per_band = |s: &Spectrum, what: &str, diag: &mut Diagnostics| -> Vec<f64> {
        let v = s.values();
        match v.len() {
            1 => vec![v[0]; nb],
            n if n == nb => v,
            n => {
                diag.error(
                    &settings_at.0,
                    settings_at.1,
                    format!(
                        "[materials.{name}] {what} has {n} values; give 1 or {nb} (one per band)"
                    ),
                );
                vec![0.0; nb]
            }
        }
    };
    let clamp = |c: [f64; 3], what: &str, diag: &mut Diagnostics| -> [f64; 3] {
        if c.iter().any(|x| !(0.0..=1.0).contains(x)) {
            diag.warn(format!(
                "{}:{line}: material '{name}': {what} {c:?} clamped to [0, 1]",
                file.display()
            ));
        }
        c.map(|x| x.clamp(0.0, 1.0))
    };

    // Transparency and refraction.
    let opacity = m.d.unwrap_or(1.0).clamp(0.0, 1.0);
    let tf = m.tf.map(|t| t.map(|x| x.clamp(0.0, 1.0)));
    let transparent = opacity < 1.0 || tf.is_some_and(|t| t.iter().any(|&x| x < 1.0));
    let refractive = m.ni.is_some_and(|n| n > 1.0 + 1e-6);
    let black = m.kd.is_none_or(|k| k.iter().all(|&x| x <= 0.0))
        && m.map_kd.is_none()
        && m.texture.is_none();
    let mut ior = None;
    if transparent && refractive {
        ior = m.ni;
    } else if transparent && opacity == 0.0 && black {
        // Fully transparent and nothing else: a pass-through interface.
        ior = Some(1.0);
    } else if transparent {
        diag.warn(format!(
            "{}:{line}: material '{name}': transparency (d {opacity}) without refraction (Ni {}) is read as opaque",
            file.display(),
            m.ni.map_or("not given".into(), |n| n.to_string())
        ));
    }
    if let Some(n) = o.ior {
        ior = Some(n);
    }
    let mut model = ior.map(IorModel::Constant);
    if let Some([b, c]) = o.sellmeier {
        model = Some(IorModel::Sellmeier { b, c });
    }
    match o.dielectric {
        Some(false) => model = None,
        Some(true) if model.is_none() => {
            model = Some(IorModel::Constant(m.ni.filter(|&n| n > 1.0).unwrap_or(1.5)))
        }
        _ => {}
    }
    let dielectric = model.is_some();

    // Reflectances.
    let emits = match &o.emission {
        Some(s) => s.values().iter().any(|&x| x != 0.0),
        None => m.ke.is_some_and(|k| k.iter().any(|&x| x > 0.0)),
    };
    let kd = match (m.kd, &m.map_kd) {
        (Some(k), _) => Some(clamp(k, "Kd", diag)),
        (None, Some(_)) => None,
        // A lamp without a Kd: it emits and absorbs.
        (None, None) if emits => Some([0.0; 3]),
        (None, None) => {
            if !dielectric && o.diffuse.is_none() && !m.implicit {
                diag.warn(format!(
                    "{}:{line}: material '{name}' has no Kd and no texture: grey 0.5",
                    file.display()
                ));
            }
            Some([0.5; 3])
        }
    };
    let ks = m.ks.map(|k| clamp(k, "Ks", diag)).unwrap_or([0.0; 3]);
    let zero = vec![0.0; nb];
    let (mut diffuse, mut specular) = if dielectric {
        (zero.clone(), zero.clone())
    } else {
        (
            expand_rgb(kd.unwrap_or([0.5; 3]), band_nm, rgb),
            expand_rgb(ks, band_nm, rgb),
        )
    };
    if let Some(s) = &o.diffuse {
        diffuse = per_band(s, "diffuse", diag);
    }
    if let Some(s) = &o.specular {
        specular = per_band(s, "specular", diag);
    }
    let mut transmit = match (&o.transmit, m.kt) {
        (Some(s), _) => per_band(s, "transmit", diag),
        (None, Some(t)) if !dielectric => expand_rgb(clamp(t, "transmission", diag), band_nm, rgb),
        _ => zero.clone(),
    };
    // Energy: an opaque surface cannot reflect more than it receives.
    if !dielectric {
        let worst = (0..nb)
            .map(|b| diffuse[b] + specular[b] + transmit[b])
            .fold(0.0, f64::max);
        if worst > 1.0 {
            let k = 1.0 / worst;
            diag.warn(format!(
                "{}:{line}: material '{name}': Kd + Ks = {worst:.4} reflects more than it receives; both scaled by {k:.4}",
                file.display()
            ));
            for v in [&mut diffuse, &mut specular, &mut transmit] {
                v.iter_mut().for_each(|x| *x *= k);
            }
        }
    }
    let absorption = match (&o.absorption_per_m, tf) {
        (Some(s), _) => per_band(s, "absorption_per_m", diag),
        (None, Some(t)) if dielectric => {
            // Tf is the internal transmittance of 1 m, or of a pane's thickness.
            let metres = m.pane.map_or(1.0, |t| t * units.unit_m);
            expand_rgb(t.map(|x| -(x.max(1e-12)).ln() / metres), band_nm, rgb)
        }
        _ => vec![],
    };
    let emission = match (&o.emission, m.ke) {
        // `emission = 0` in the settings turns a file's emission off.
        (Some(s), _) => Some(per_band(s, "emission", diag)).filter(|e| e.iter().any(|&x| x != 0.0)),
        (None, Some(k)) if k.iter().any(|&x| x > 0.0) => {
            let mut e = expand_rgb(k.map(|x| x.max(0.0)), band_nm, rgb);
            if let Some(l) = m.ke_luminance {
                // Exitance π L in lumens, whatever the bands.
                let lm: f64 = e.iter().zip(units.efficacy).map(|(x, k)| x * k).sum();
                if lm > 0.0 {
                    let k = std::f64::consts::PI * l / lm;
                    e.iter_mut().for_each(|x| *x *= k);
                }
            }
            Some(e)
        }
        _ => None,
    };
    let desc = MaterialDesc {
        diffuse_reflect: diffuse.clone(),
        specular_reflect: if dielectric { vec![] } else { specular },
        diffuse_transmit: if dielectric { vec![] } else { transmit },
        ior: model,
        absorption_per_m: if dielectric { absorption } else { vec![] },
        // Given to any material: the library refuses a medium outside a dielectric, naming
        // it, rather than the settings losing it.
        scattering_per_m: o
            .scattering_per_m
            .as_ref()
            .map_or(vec![], |s| per_band(s, "scattering_per_m", diag)),
        phase_g: o
            .phase_g
            .as_ref()
            .map_or(vec![], |s| per_band(s, "phase_g", diag)),
        fluorescence: o.fluorescence.as_ref().map_or(vec![], |f| {
            fluorescence_matrix(
                &per_band(&f.excitation, "fluorescence.excitation", diag),
                f.quantum_yield,
                &per_band(&f.emission, "fluorescence.emission", diag),
                band_nm,
            )
        }),
        phase_angles_deg: o
            .phase_table
            .as_ref()
            .map_or(vec![], |t| t.iter().map(|r| r[0]).collect()),
        phase_values: o
            .phase_table
            .as_ref()
            .map_or(vec![], |t| t.iter().map(|r| r[1]).collect()),
        ..Default::default()
    };
    let desc = glossy(desc, m, &o, kd, band_nm, rgb, settings_at, diag);
    Resolved {
        desc,
        diffuse,
        emission,
    }
}

/// The excitation–emission matrix of an excitation share a_i per band, a quantum yield Φ
/// and an emission spectrum in photons e_j: m_ij = a_i Φ ê_ij λ_i / λ_j, where ê_ij is e
/// over the bands longer than band i, normalised there (light is re-emitted at longer
/// wavelengths only; the photon's energy scales by λ_i / λ_j). The library checks it.
fn fluorescence_matrix(a: &[f64], q: f64, e: &[f64], nm: &[f64]) -> Vec<f64> {
    let nb = nm.len();
    let mut m = vec![0.0; nb * nb];
    for i in 0..nb {
        let longer: f64 = (0..nb).filter(|&j| nm[j] > nm[i]).map(|j| e[j]).sum();
        if longer <= 0.0 {
            continue;
        }
        for j in (0..nb).filter(|&j| nm[j] > nm[i]) {
            m[i * nb + j] = a[i] * q * e[j] / longer * nm[i] / nm[j];
        }
    }
    m
}

/// The first optical field the settings give (coefficients, index, metal, roughness),
/// which a table or a window BSDF file does not take.
fn optics_given(o: &MaterialSettings) -> Option<&'static str> {
    [
        ("roughness", o.roughness.is_some()),
        ("metal", o.metal.is_some()),
        ("nk", o.nk.is_some()),
        ("ior", o.ior.is_some() || o.sellmeier.is_some()),
        ("dielectric", o.dielectric == Some(true)),
        ("diffuse", o.diffuse.is_some()),
        ("specular", o.specular.is_some()),
        ("transmit", o.transmit.is_some()),
        ("absorption_per_m", o.absorption_per_m.is_some()),
        ("scattering_per_m", o.scattering_per_m.is_some()),
        ("phase_g", o.phase_g.is_some()),
        ("phase_table", o.phase_table.is_some()),
        ("fluorescence", o.fluorescence.is_some()),
    ]
    .into_iter()
    .find_map(|(field, given)| given.then_some(field))
}

/// The numbers of a table file (separated by spaces, commas or line ends; `#` starts a
/// comment), or the line and what is wrong.
fn read_values(path: &std::path::Path) -> Result<Vec<f64>, (usize, String)> {
    let text = std::fs::read_to_string(path).map_err(|e| (1, format!("cannot read it: {e}")))?;
    let mut values = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        for tok in line.split(|c: char| c == ',' || c.is_whitespace()) {
            if tok.is_empty() {
                continue;
            }
            match tok.parse::<f64>() {
                Ok(v) if v.is_finite() => values.push(v),
                _ => {
                    return Err((
                        i + 1,
                        format!("'{}' is not a finite number", printable(tok)),
                    ))
                }
            }
        }
    }
    if values.is_empty() {
        return Err((1, "holds no values".into()));
    }
    Ok(values)
}

/// Rows (nm, n, k) with n = 1 and k per band such that the reflectance at normal incidence
/// is `f0[b]` at band b's wavelength (sorted, padded by a nanometre at each end).
fn colour_conductor(f0: &[f64], band_nm: &[f64]) -> Vec<[f64; 3]> {
    let mut rows: Vec<[f64; 3]> = band_nm
        .iter()
        .zip(f0)
        .map(|(&nm, &f)| {
            let f = f.clamp(0.0, 0.999);
            [nm, 1.0, 2.0 * (f / (1.0 - f)).sqrt()]
        })
        .collect();
    rows.sort_by(|a, b| a[0].total_cmp(&b[0]));
    rows.dedup_by(|a, b| a[0] == b[0]);
    let (first, last) = (rows[0], rows[rows.len() - 1]);
    rows.insert(0, [first[0] - 1.0, first[1], first[2]]);
    rows.push([last[0] + 1.0, last[1], last[2]]);
    rows
}

/// The microfacet surface `desc` becomes, if any: the settings' `kind`, else the file's
/// gloss (module docs).
#[allow(clippy::too_many_arguments)]
fn glossy(
    mut desc: MaterialDesc,
    m: &Mtl,
    o: &MaterialSettings,
    kd: Option<[f64; 3]>,
    band_nm: &[f64],
    rgb: bool,
    settings_at: &(std::path::PathBuf, usize),
    diag: &mut Diagnostics,
) -> MaterialDesc {
    let name = printable(&m.name);
    let error = |diag: &mut Diagnostics, msg: String| {
        diag.error(
            &settings_at.0,
            settings_at.1,
            format!("[materials.{name}] {msg}"),
        )
    };
    let setting = o.roughness.as_ref().map(|r| match r {
        RoughnessSetting::One(a) => [*a, 0.0],
        RoughnessSetting::Two(a) => *a,
    });
    let colour = kd.map(|c| expand_rgb(c, band_nm, rgb));
    let conductor_from = |o: &MaterialSettings, diag: &mut Diagnostics| -> ConductorIndex {
        if let Some(rows) = &o.nk {
            return ConductorIndex::Table(rows.clone());
        }
        match o.metal.as_deref() {
            Some("aluminium") | Some("aluminum") => ConductorIndex::Metal(Metal::Aluminium),
            Some("silver") => ConductorIndex::Metal(Metal::Silver),
            Some("gold") => ConductorIndex::Metal(Metal::Gold),
            Some("copper") => ConductorIndex::Metal(Metal::Copper),
            Some("chromium") => ConductorIndex::Metal(Metal::Chromium),
            Some(other) => {
                error(
                    diag,
                    format!(
                        "metal = '{}' is not one of aluminium, silver, gold, copper, chromium",
                        printable(other)
                    ),
                );
                ConductorIndex::Metal(Metal::Aluminium)
            }
            None => ConductorIndex::Table(colour_conductor(
                colour.as_deref().unwrap_or(&vec![0.9; band_nm.len()]),
                band_nm,
            )),
        }
    };
    let coat_from_ks = || -> f64 {
        let f0 =
            m.ks.map(|k| (k[0] + k[1] + k[2]) / 3.0)
                .filter(|&f| f > 0.0)
                .unwrap_or(0.04)
                .clamp(0.001, 0.9);
        let r = f0.sqrt();
        (1.0 + r) / (1.0 - r)
    };
    let kind = o.kind.as_deref();
    if kind != Some("bsdf-xml") && (o.file.is_some() || o.up.is_some()) {
        error(diag, "file and up need kind = \"bsdf-xml\"".into());
        return desc;
    }
    if kind != Some("table") && (o.grid.is_some() || o.brdf.is_some() || o.btdf.is_some()) {
        error(diag, "grid, brdf and btdf need kind = \"table\"".into());
        return desc;
    }
    if kind.is_none()
        && (o.roughness.is_some() || o.metal.is_some() || o.nk.is_some() || o.tangent.is_some())
    {
        error(
            diag,
            "roughness, metal, nk or tangent need kind = \"conductor\", \"plastic\" or \"rough-dielectric\"".into(),
        );
        return desc;
    }
    let zero = Vec::new;
    // Files the settings name are relative to the settings file.
    let base = settings_at.0.parent().unwrap_or(std::path::Path::new("."));
    match kind {
        Some("ideal") => desc,
        Some("table") => {
            let (Some(grid), Some(brdf)) = (o.grid, &o.brdf) else {
                error(
                    diag,
                    "kind = \"table\" needs grid = [θ in, φ in, θ out, φ out] and brdf = \"…\" (a file of values)".into(),
                );
                return desc;
            };
            if let Some(field) = optics_given(o) {
                error(
                    diag,
                    format!(
                        "{field} is given but kind = \"table\" takes its optics from its values"
                    ),
                );
                return desc;
            }
            let read = |path: &std::path::Path, diag: &mut Diagnostics| {
                let path = base.join(path);
                match read_values(&path) {
                    Ok(v) => Some(v),
                    Err((line, msg)) => {
                        diag.error(&path, line, format!("[materials.{name}] {msg}"));
                        None
                    }
                }
            };
            let Some(brdf) = read(brdf, diag) else {
                return desc;
            };
            let btdf = match &o.btdf {
                Some(p) => match read(p, diag) {
                    Some(v) => v,
                    None => return desc,
                },
                None => Vec::new(),
            };
            let [ti, pi, to, po] = grid.map(|x| x as usize);
            MaterialDesc {
                surface: SurfaceModel::Table(TableDesc {
                    theta_in: ti,
                    phi_in: pi,
                    theta_out: to,
                    phi_out: po,
                    brdf,
                    btdf,
                }),
                tangent: o.tangent,
                ..Default::default()
            }
        }
        Some("bsdf-xml") => {
            let Some(file) = &o.file else {
                error(
                    diag,
                    "kind = \"bsdf-xml\" needs file = \"…\" (a window BSDF XML file)".into(),
                );
                return desc;
            };
            let stray = optics_given(o).or(o.tangent.is_some().then_some("tangent (give up)"));
            if let Some(field) = stray {
                error(
                    diag,
                    format!(
                        "{field} is given but kind = \"bsdf-xml\" takes its optics from the file"
                    ),
                );
                return desc;
            }
            MaterialDesc {
                surface: SurfaceModel::Klems(base.join(file)),
                tangent: o.up,
                ..Default::default()
            }
        }
        Some(k @ ("conductor" | "plastic" | "rough-dielectric")) => {
            let Some(r) = setting.or_else(|| m.gloss.map(|g| [g.alpha, 0.0])) else {
                error(
                    diag,
                    format!("kind = \"{k}\" needs roughness (GGX α in (0, 1])"),
                );
                return desc;
            };
            desc.roughness = r;
            desc.tangent = o.tangent;
            match k {
                "conductor" => {
                    desc.surface = SurfaceModel::Conductor(conductor_from(o, diag));
                    desc.diffuse_reflect = zero();
                    desc.specular_reflect = zero();
                    desc.diffuse_transmit = zero();
                    desc.ior = None;
                    desc.absorption_per_m = zero();
                }
                "plastic" => {
                    desc.surface = SurfaceModel::Plastic;
                    let n = o.ior.unwrap_or_else(coat_from_ks);
                    desc.ior = Some(IorModel::Constant(n));
                    desc.specular_reflect = zero();
                    desc.diffuse_transmit = zero();
                    desc.absorption_per_m = zero();
                }
                _ => {
                    desc.surface = SurfaceModel::RoughDielectric;
                    if desc.ior.is_none() {
                        desc.ior =
                            Some(IorModel::Constant(m.ni.filter(|&n| n > 1.0).unwrap_or(1.5)));
                    }
                    desc.diffuse_reflect = zero();
                    desc.specular_reflect = zero();
                    desc.diffuse_transmit = zero();
                }
            }
            desc
        }
        Some(other) => {
            error(
                diag,
                format!(
                    "kind = '{}' is not one of ideal, conductor, plastic, rough-dielectric, table, bsdf-xml",
                    printable(other)
                ),
            );
            desc
        }
        None => {
            // A window BSDF file the model names (Radiance's BSDF), unless the settings
            // give the surface's optics.
            if let Some((file, up)) = m.window_bsdf.as_ref().filter(|_| optics_given(o).is_none()) {
                return MaterialDesc {
                    surface: SurfaceModel::Klems(file.clone()),
                    tangent: Some(*up),
                    ..Default::default()
                };
            }
            // The file's gloss, unless the settings made it glass or it is smooth.
            let Some(g) = m.gloss.filter(|g| g.alpha >= 0.01) else {
                return desc;
            };
            if desc.ior.is_some() {
                return desc;
            }
            desc.roughness = [g.alpha.min(1.0), 0.0];
            if g.metallic >= 0.5 {
                desc.surface = SurfaceModel::Conductor(conductor_from(o, diag));
                desc.diffuse_reflect = zero();
            } else {
                desc.surface = SurfaceModel::Plastic;
                desc.ior = Some(IorModel::Constant(coat_from_ks()));
            }
            if g.metallic > 0.0 && g.metallic < 1.0 {
                diag.warn(format!(
                    "{}:{}: material '{name}': metallic {} is read as {}",
                    m.at.0.display(),
                    m.at.1,
                    g.metallic,
                    if g.metallic >= 0.5 {
                        "a metal"
                    } else {
                        "a coated (plastic) surface"
                    }
                ));
            }
            desc.specular_reflect = zero();
            desc.diffuse_transmit = zero();
            desc.absorption_per_m = zero();
            desc
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Gloss;

    fn resolved(m: &Mtl, o: Option<&MaterialSettings>) -> (Resolved, Diagnostics) {
        let mut diag = Diagnostics::default();
        let units = Units {
            efficacy: &[683.0; 3],
            unit_m: 1.0,
        };
        let at = (std::path::PathBuf::from("s.toml"), 1);
        let r = resolve(m, o, &at, &[612.0, 549.0, 465.0], true, &units, &mut diag);
        (r, diag)
    }

    /// A file's gloss maps to the microfacet models: a metal to a conductor whose
    /// reflectance at normal incidence is its colour, anything else to a plastic whose coat
    /// reflects `Ks` (or 4 %) at normal incidence; a smooth one keeps the ideal mapping.
    #[test]
    fn gloss_maps_to_conductors_and_plastics() {
        let metal = Mtl {
            kd: Some([0.9, 0.6, 0.3]),
            gloss: Some(Gloss {
                alpha: 0.09,
                metallic: 1.0,
            }),
            ..Default::default()
        };
        let (r, _) = resolved(&metal, None);
        assert_eq!(r.desc.roughness, [0.09, 0.0]);
        let SurfaceModel::Conductor(ConductorIndex::Table(rows)) = &r.desc.surface else {
            panic!("{:?}", r.desc.surface)
        };
        // n = 1, k = 2√(F0 / (1 − F0)) at each band's wavelength: F0 = k² / (4 + k²).
        for (nm, f0) in [(612.0, 0.9), (549.0, 0.6), (465.0, 0.3)] {
            let row = rows.iter().find(|r| r[0] == nm).unwrap();
            let k = row[2];
            assert!((k * k / (4.0 + k * k) - f0).abs() < 1e-12, "{nm}: {row:?}");
        }
        assert!(r.desc.diffuse_reflect.is_empty());

        let plastic = Mtl {
            kd: Some([0.5; 3]),
            ks: Some([0.09; 3]),
            gloss: Some(Gloss {
                alpha: 0.2,
                metallic: 0.0,
            }),
            ..Default::default()
        };
        let (r, _) = resolved(&plastic, None);
        assert_eq!(r.desc.surface, SurfaceModel::Plastic);
        // F0 = 0.09: n = (1 + 0.3) / (1 − 0.3).
        assert_eq!(r.desc.ior, Some(IorModel::Constant(1.3 / 0.7)));
        assert_eq!(r.desc.diffuse_reflect, vec![0.5; 3]);
        assert!(r.desc.specular_reflect.is_empty());

        let smooth = Mtl {
            kd: Some([0.5; 3]),
            ks: Some([0.3; 3]),
            gloss: Some(Gloss {
                alpha: 0.001,
                metallic: 0.0,
            }),
            ..Default::default()
        };
        let (r, _) = resolved(&smooth, None);
        assert_eq!(r.desc.surface, SurfaceModel::Ideal);
        assert_eq!(r.desc.specular_reflect, vec![0.3; 3]);

        // A fractional metallic is said.
        let half = Mtl {
            gloss: Some(Gloss {
                alpha: 0.2,
                metallic: 0.4,
            }),
            ..plastic.clone()
        };
        let (r, diag) = resolved(&half, None);
        assert_eq!(r.desc.surface, SurfaceModel::Plastic);
        assert!(
            diag.warnings.iter().any(|w| w.contains("metallic 0.4")),
            "{:?}",
            diag.warnings
        );
    }

    /// The settings' `kind` wins over the file, with a shipped metal.
    #[test]
    fn the_settings_kind_makes_the_surface() {
        let o = MaterialSettings {
            kind: Some("conductor".into()),
            metal: Some("gold".into()),
            roughness: Some(RoughnessSetting::Two([0.1, 0.3])),
            tangent: Some([0.0, 1.0, 0.0]),
            ..Default::default()
        };
        let m = Mtl {
            kd: Some([0.5; 3]),
            ..Default::default()
        };
        let (r, diag) = resolved(&m, Some(&o));
        assert!(diag.errors.is_empty(), "{:?}", diag.errors);
        assert_eq!(
            r.desc.surface,
            SurfaceModel::Conductor(ConductorIndex::Metal(Metal::Gold))
        );
        assert_eq!(r.desc.roughness, [0.1, 0.3]);
        assert_eq!(r.desc.tangent, Some([0.0, 1.0, 0.0]));
        assert!(r.desc.diffuse_reflect.is_empty());
    }
}
