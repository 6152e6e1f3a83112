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
//! - `[materials.NAME]` in the settings overrides any of it: `diffuse`, `specular`,
//!   `transmit`, `emission`, `ior`, `sellmeier`, `absorption_per_m`, and `dielectric =
//!   true/false` to make or unmake glass.

use crate::diag::{printable, Diagnostics};
use crate::model::Mtl;
use crate::settings::{channel, MaterialSettings, Spectrum};
use imap::{IorModel, MaterialDesc};

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
    Resolved {
        desc: MaterialDesc {
            diffuse_reflect: diffuse.clone(),
            specular_reflect: if dielectric { vec![] } else { specular },
            diffuse_transmit: if dielectric { vec![] } else { transmit },
            ior: model,
            absorption_per_m: if dielectric { absorption } else { vec![] },
        },
        diffuse,
        emission,
    }
}
