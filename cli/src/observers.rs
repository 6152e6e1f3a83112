//! Observers (`[[observer]]`): a sensor at each eye facing its view (it changes no light
//! path), read after the run for the vertical illuminance Ev with its error, and the
//! glare the library computes from it (`imap::glare`): UGR with the luminaires in view,
//! the background luminance and DGPs. Written to `observers.csv`, report.json and the
//! terminal.

use crate::error::{fail, CliError, Result};
use crate::settings::Settings;
use imap::glare::{AlphaOpic, Glare, Observer, SourceKind};
use imap::photometry::alpha_opic::ALPHA_OPIC_NAMES;
use imap::Context;
use std::io::Write;
use std::path::Path;

/// An observer as added: its name, frame and sensor.
#[derive(Clone, Debug)]
pub struct ObserverEntry {
    pub name: String,
    pub observer: Observer,
    pub mesh: u32,
}

/// Adds every `[[observer]]`'s sensor to `ctx`; errors name the settings' line.
pub fn add(ctx: &mut Context, settings: &Settings) -> Result<Vec<ObserverEntry>> {
    let unit_m = settings.unit_m.unwrap_or(1.0);
    let up = settings.up()?;
    let mut out: Vec<ObserverEntry> = Vec::new();
    for (k, o) in settings.observers.iter().enumerate() {
        let (file, line) = settings.locate_nth("[[observer]]", k);
        let what = format!("{}:{line}: [[observer]]", file.display());
        let name = o
            .name
            .clone()
            .unwrap_or_else(|| format!("observer{}", k + 1));
        crate::grids::check_name(&what, &name)?;
        if out.iter().any(|e| e.name == name) {
            fail!("{what}: two observers are named '{name}'");
        }
        let observer = Observer {
            eye: o.eye,
            view: o.view,
            up: o.up.unwrap_or(up),
        };
        let radius = o.radius.unwrap_or(0.05 / unit_m);
        let mesh = ctx
            .add_observer_sensor(&observer, radius)
            .map_err(|e| CliError(format!("{what} '{name}': {}", e.message)))?;
        out.push(ObserverEntry {
            name,
            observer,
            mesh,
        });
    }
    Ok(out)
}

/// A command that reports no observers drops them (their sensors would cost it work for
/// nothing), saying so once.
pub fn not_here(settings: &mut Settings, command: &str) {
    if !settings.observers.is_empty() {
        eprintln!(
            "imap: warning: [[observer]] is reported by imap run only: ignored by imap {command}"
        );
        settings.observers.clear();
    }
}

/// An observer's figures after the run.
pub struct ObserverResult {
    pub glare: Glare,
    /// The α-opic light at the eye (spectral runs; None in RGB).
    pub alpha_opic: Option<AlphaOpic>,
}

/// Reads every observer's Ev, rates its glare and, in spectral runs, its α-opic light.
pub fn read(ctx: &mut Context, entries: &[ObserverEntry]) -> Result<Vec<ObserverResult>> {
    let spectral = !ctx.config().bands.rgb;
    entries
        .iter()
        .map(|e| {
            let what = |x: imap::Error| CliError(format!("observer '{}': {}", e.name, x.message));
            let (ev, sigma) = ctx.observer_ev(e.mesh).map_err(what)?;
            let glare = ctx.observer_glare(&e.observer, ev, sigma).map_err(what)?;
            if let Some(m) = glare.enclosed_by {
                eprintln!(
                    "imap: warning: observer '{}': every line of sight from its eye leaves through the back faces of mesh {m}: the eye is inside a solid object (no light arrives there), or in a room drawn with its normals out (flip_normals mends its recording)",
                    e.name
                );
            }
            let alpha_opic = if spectral {
                Some(ctx.observer_alpha_opic(e.mesh).map_err(what)?)
            } else {
                None
            };
            Ok(ObserverResult { glare, alpha_opic })
        })
        .collect()
}

/// A number for JSON: null where it is not finite (UGR on a black background).
fn num(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// UGR as people read it: "< 10" below CIE 117's scale, "∞" on a black background.
pub fn ugr_text(g: &Glare) -> String {
    if g.ugr_below_10 {
        "< 10".into()
    } else if !g.ugr.is_finite() {
        "∞ (no background light)".into()
    } else {
        format!("{:.2} ± {:.2}", g.ugr, g.ugr_sigma)
    }
}

/// report.json's entry of an observer; `source_name` names a light or an emitting mesh
/// as the scene does.
pub fn json(
    source_name: &dyn Fn(SourceKind) -> String,
    e: &ObserverEntry,
    r: &ObserverResult,
) -> serde_json::Value {
    let g = &r.glare;
    serde_json::json!({
        "name": e.name,
        "eye": e.observer.eye, "view": e.observer.view, "up": e.observer.up,
        "ev_lx": g.ev_lx, "ev_sigma_lx": g.ev_sigma_lx, "direct_lx": g.direct_lx,
        "background_cd_m2": g.background_cd_m2,
        "background_sigma_cd_m2": g.background_sigma_cd_m2,
        "ugr": num(g.ugr), "ugr_sigma": num(g.ugr_sigma), "ugr_below_10": g.ugr_below_10,
        "dgps": g.dgps, "dgps_sigma": g.dgps_sigma,
        // A one-sided mesh whose back faces surround the eye (a warning's subject).
        "enclosed_by_mesh": g.enclosed_by,
        // α-opic light at the eye (CIE S 026), spectral runs only.
        "alpha_opic": r.alpha_opic.map(|a| serde_json::json!({
            "names": ALPHA_OPIC_NAMES,
            "irradiance_w_m2": a.irradiance_w_m2,
            "edi_lx": a.edi_lx, "edi_sigma_lx": a.edi_sigma_lx,
            "melanopic_edi_lx": a.edi_lx[4], "melanopic_edi_sigma_lx": a.edi_sigma_lx[4],
            "melanopic_der": a.melanopic_der
        })),
        "sources": g.sources.iter().map(|s| serde_json::json!({
            "name": source_name(s.kind),
            "direction": s.direction, "distance_m": s.distance_m,
            "intensity_cd": s.intensity_cd, "projected_area_m2": s.projected_area_m2,
            "luminance_cd_m2": s.luminance_cd_m2, "solid_angle_sr": s.solid_angle_sr,
            "position_index": s.position_index, "visible": s.visible,
            "ev_lx": s.ev_lx, "ugr_term": s.term, "small": s.small
        })).collect::<Vec<_>>()
    })
}

/// `observers.csv`: one row per observer.
pub fn write_csv(path: &Path, entries: &[ObserverEntry], results: &[ObserverResult]) -> Result<()> {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(|e| CliError(format!("{}: {e}", path.display())))?,
    );
    let io = |e: std::io::Error| CliError(format!("{}: {e}", path.display()));
    writeln!(
        f,
        "name,eye_x,eye_y,eye_z,view_x,view_y,view_z,ev_lx,ev_sigma_lx,direct_lx,background_cd_m2,background_sigma_cd_m2,ugr,ugr_sigma,ugr_below_10,dgps,dgps_sigma,sources,melanopic_edi_lx,melanopic_edi_sigma_lx,melanopic_der"
    )
    .map_err(io)?;
    for (e, r) in entries.iter().zip(results) {
        let g = &r.glare;
        let [ex, ey, ez] = e.observer.eye;
        let [vx, vy, vz] = e.observer.view;
        // Empty in RGB runs, which have no wavelengths.
        let mel = r.alpha_opic.map_or(",,".to_string(), |a| {
            format!("{},{},{}", a.edi_lx[4], a.edi_sigma_lx[4], a.melanopic_der)
        });
        writeln!(
            f,
            "{},{ex},{ey},{ez},{vx},{vy},{vz},{},{},{},{},{},{},{},{},{},{},{},{mel}",
            e.name,
            g.ev_lx,
            g.ev_sigma_lx,
            g.direct_lx,
            g.background_cd_m2,
            g.background_sigma_cd_m2,
            g.ugr,
            g.ugr_sigma,
            g.ugr_below_10 as u8,
            g.dgps,
            g.dgps_sigma,
            g.sources.len()
        )
        .map_err(io)?;
    }
    f.flush().map_err(io)
}

/// The terminal's line of an observer.
pub fn summary(e: &ObserverEntry, r: &ObserverResult) -> String {
    let g = &r.glare;
    let mel = r.alpha_opic.map_or(String::new(), |a| {
        format!(
            ", melanopic EDI {:.1} ± {:.1} lx (DER {:.3})",
            a.edi_lx[4], a.edi_sigma_lx[4], a.melanopic_der
        )
    });
    format!(
        "observer {}: Ev {:.1} ± {:.1} lx, UGR {} ({} source{} in view, background {:.1} cd/m²), DGPs {:.3}{mel}",
        e.name,
        g.ev_lx,
        g.ev_sigma_lx,
        ugr_text(g),
        g.sources.len(),
        if g.sources.len() == 1 { "" } else { "s" },
        g.background_cd_m2,
        g.dgps
    )
}

/// `imap ugr-table FILE`: the luminaire file's CIE 190 table on stdout, as a catalogue
/// prints it (or CSV).
pub fn ugr_table_cmd(file: &Path, csv: bool) -> Result<()> {
    use imap::photometry::ugr_table::{ugr_table_ies, ugr_table_ldt, REFLECTANCES, ROOMS};
    let bytes = crate::diag::read_input(file).map_err(CliError)?;
    let text = crate::diag::decode(&bytes);
    let ldt = file
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("ldt"));
    let t = if ldt {
        ugr_table_ldt(&text)
    } else {
        ugr_table_ies(&text)
    }
    .map_err(|e| CliError(format!("{}: {}", file.display(), e.message)))?;
    let flux = t.flux_lm;
    let cell = |v: f64| {
        if v.is_finite() {
            format!("{v:.1}")
        } else {
            "-".into()
        }
    };
    let mut out = String::new();
    if csv {
        out.push_str("x_h,y_h");
        for view in ["crosswise", "endwise"] {
            for (c, w, f) in REFLECTANCES {
                out.push_str(&format!(",{view}_{c}_{w}_{f}"));
            }
        }
        out.push('\n');
        for (r, (x, y)) in ROOMS.iter().enumerate() {
            let v: Vec<String> = t.crosswise[r]
                .iter()
                .chain(&t.endwise[r])
                .map(|v| {
                    if v.is_finite() {
                        format!("{v:.2}")
                    } else {
                        String::new()
                    }
                })
                .collect();
            out.push_str(&format!("{x},{y},{}\n", v.join(",")));
        }
    } else {
        out.push_str(&format!(
            "UGR table (CIE 117 / CIE 190) of {}: {flux:.0} lm per luminaire, spacing 0.25 H, H = 2 m\n",
            file.display()
        ));
        out.push_str("ceiling      0.7  0.7  0.5  0.5  0.3 |  0.7  0.7  0.5  0.5  0.3\n");
        out.push_str("walls        0.5  0.3  0.5  0.3  0.3 |  0.5  0.3  0.5  0.3  0.3\n");
        out.push_str("floor        0.2  0.2  0.2  0.2  0.2 |  0.2  0.2  0.2  0.2  0.2\n");
        out.push_str("room X × Y       crosswise           |        endwise\n");
        for (r, (x, y)) in ROOMS.iter().enumerate() {
            let c: Vec<String> = t.crosswise[r]
                .iter()
                .map(|v| format!("{:>4}", cell(*v)))
                .collect();
            let e: Vec<String> = t.endwise[r]
                .iter()
                .map(|v| format!("{:>4}", cell(*v)))
                .collect();
            out.push_str(&format!(
                "{:>4}H × {:<4} {} | {}\n",
                x,
                format!("{y}H"),
                c.join(" "),
                e.join(" ")
            ));
        }
    }
    print!("{out}");
    Ok(())
}
