//! Light at the eye and glare: observers (an eye, a view direction and an up), the unified
//! glare rating UGR (CIE 117:1995, with CIE 147:2002's rule for small sources) and the
//! simplified daylight glare probability DGPs (Wienold 2009).
//!
//! An observer's vertical illuminance Ev is measured like any sensor's: a small sensor at
//! the eye facing the view (`Context::add_observer_sensor`), read after a run with its
//! standard error, by whichever estimator made the map. The sensor changes no light path,
//! so no other result changes by a bit. `Context::observer_glare` then adds what the
//! observer sees of every light source: for each luminaire (and emitting mesh) in front of
//! the eye, its luminance toward the eye, its solid angle, Guth's position index and its
//! direct share of Ev. The background luminance is the rest of Ev over π, the indirect
//! illuminance at the eye as CIE 117 defines it, and UGR follows with its error. The
//! luminaires' terms are computed, not sampled: UGR's only noise is the background's.

mod picture;

pub use picture::{dgp, picture_glare, PictureGlare, PictureSource, SourceRules};

use crate::context::{Context, Sight};
use crate::error::{bail, check_coordinates, Result};
use crate::photometry::alpha_opic::{alpha_opic_per_band, D65_EFFICACY_MW_PER_LM};
use crate::scene::light::{Light, LightShape};
use crate::scene::MeshDesc;
use glam::DVec3;
use std::f64::consts::PI;

/// An eye in the scene: where it is (scene units), where it looks, and which way is up
/// (any vector not parallel to the view; only its part across the view counts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observer {
    pub eye: [f64; 3],
    pub view: [f64; 3],
    pub up: [f64; 3],
}

/// An observer's orthonormal frame.
#[derive(Clone, Copy, Debug)]
struct Frame {
    eye: DVec3,
    view: DVec3,
    up: DVec3,
}

impl Observer {
    fn frame(&self) -> Result<Frame> {
        check_coordinates("observer.eye", &self.eye)?;
        check_coordinates("observer.view", &self.view)?;
        check_coordinates("observer.up", &self.up)?;
        let Some(view) = DVec3::from(self.view).try_normalize() else {
            bail!(
                ImapErrInvalidArgument,
                "observer.view = {:?} is zero: give the direction the observer looks in",
                self.view
            );
        };
        let up = DVec3::from(self.up);
        let across = up - view * up.dot(view);
        if across.length() <= 1e-6 * up.length() || up.length() == 0.0 {
            bail!(
                ImapErrInvalidArgument,
                "observer.up = {:?} is zero or parallel to observer.view = {:?}: give the observer's up",
                self.up,
                self.view
            );
        }
        Ok(Frame {
            eye: DVec3::from(self.eye),
            view,
            up: across.normalize(),
        })
    }
}

/// Guth's position index of a source seen in unit direction `d` by an eye looking along
/// unit `view` with unit `up` (perpendicular to it), or None behind the eye (90° or more
/// off the line of sight). Above the line of sight, the Luckiesh–Guth index as the IES
/// handbook writes it in the angle σ from the line of sight and the angle τ of the
/// source's plane from the vertical (degrees); below it, evalglare's modified Iwata
/// index. At most 16 (evalglare's cap).
pub fn position_index(view: DVec3, up: DVec3, d: DVec3) -> Option<f64> {
    let c = d.dot(view);
    if c <= 0.0 {
        return None;
    }
    let sigma = c.min(1.0).acos();
    let across = d - view * c;
    let tau = match across.try_normalize() {
        Some(a) => a.dot(up).clamp(-1.0, 1.0).acos(),
        None => 0.0,
    };
    let p = if d.dot(up) >= 0.0 {
        let (s, t) = (sigma.to_degrees(), tau.to_degrees());
        ((35.2 - 0.31889 * t - 1.22 * (-2.0 * t / 9.0).exp()) * 1e-3 * s
            + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * s * s)
            .exp()
    } else {
        let beta = (sigma.tan() * (1.0 + 0.3225 * tau.cos().powi(2)).sqrt())
            .atan()
            .to_degrees();
        (6.49e-3 * beta + 21e-5 * beta * beta).exp()
    };
    Some(p.min(16.0))
}

/// CIE 147's limit: a source of smaller projected area (m²) is a small source, whose term
/// is 200 I² / (r² p²) in place of L² ω / p².
pub const SMALL_SOURCE_M2: f64 = 0.005;

/// UGR of the sources' summed terms Σ L² ω / p² (cd²/m⁴·sr) over a background of luminance
/// `background` (cd/m²): 8 log10(0.25 Σ / Lb). +∞ on a black background.
pub fn ugr(terms: f64, background: f64) -> f64 {
    if background > 0.0 {
        8.0 * (0.25 * terms / background).log10()
    } else {
        f64::INFINITY
    }
}

/// The simplified daylight glare probability of a vertical illuminance at the eye, lx
/// (Wienold 2009): 6.22·10⁻⁵ Ev + 0.184. It ignores the contrast of the sources: it holds
/// when no sun (nor a specular reflection of it) is in view.
pub fn dgps(ev_lx: f64) -> f64 {
    DGPS_PER_LX * ev_lx + DGPS_AT_DARK
}

/// The vertical illuminance at which `dgps` reaches `dgp`, lx (negative below
/// `DGPS_AT_DARK`).
pub fn dgps_ev(dgp: f64) -> f64 {
    (dgp - DGPS_AT_DARK) / DGPS_PER_LX
}

/// DGPs' slope, per lx of vertical illuminance (`dgps`).
pub const DGPS_PER_LX: f64 = 6.22e-5;
/// DGPs at Ev = 0 (`dgps`).
pub const DGPS_AT_DARK: f64 = 0.184;

/// What a glare source is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceKind {
    /// A light (its id): a luminaire, point, spot or cosine light.
    Light(u32),
    /// An emitting mesh (its id), summed over its triangles.
    Mesh(u32),
}

/// A light source as an observer sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlareSource {
    pub kind: SourceKind,
    /// From the eye toward the source (unit; for a mesh, its solid-angle-weighted mean).
    pub direction: [f64; 3],
    /// From the eye, m.
    pub distance_m: f64,
    /// Intensity toward the eye, cd.
    pub intensity_cd: f64,
    /// The luminous area it shows the eye, m² (0 for a point light).
    pub projected_area_m2: f64,
    /// Its luminance toward the eye, cd/m² (0 for a point light).
    pub luminance_cd_m2: f64,
    /// Its solid angle at the eye, sr (the visible part).
    pub solid_angle_sr: f64,
    /// Guth's position index (`position_index`; for a mesh, the one that gives its sum).
    pub position_index: f64,
    /// The share of it the eye sees (points of its luminous area with a clear line).
    pub visible: f64,
    /// Its direct vertical illuminance at the eye, lx.
    pub ev_lx: f64,
    /// Its UGR term: L² ω / p², or 200 I² / (r² p²) for a small source.
    pub term: f64,
    /// Taken as a small source (projected area below `SMALL_SOURCE_M2`).
    pub small: bool,
}

/// An observer's light and glare.
#[derive(Clone, Debug, PartialEq)]
pub struct Glare {
    /// The vertical illuminance at the eye and its standard error, lx (as given).
    pub ev_lx: f64,
    pub ev_sigma_lx: f64,
    /// What the luminaires in view give the eye directly, lx.
    pub direct_lx: f64,
    /// The background luminance, (Ev − direct) / π, and its standard error, cd/m².
    pub background_cd_m2: f64,
    pub background_sigma_cd_m2: f64,
    /// UGR and its standard error (0 with `ugr_below_10` when no source is in view; +∞ on
    /// a black background).
    pub ugr: f64,
    pub ugr_sigma: f64,
    /// UGR is below 10, where CIE 117's scale starts: no discomfort glare to rate.
    pub ugr_below_10: bool,
    /// The simplified daylight glare probability and its standard error.
    pub dgps: f64,
    pub dgps_sigma: f64,
    /// Every source in front of the eye that it sees, largest term first.
    pub sources: Vec<GlareSource>,
    /// The one-sided mesh whose back faces every line of sight along the eye's six axes
    /// meets first, if one: the eye is inside a solid object (no light arrives there), or
    /// in a room drawn with its normals out (its light arrives, but no map records the
    /// room's inside). Worth a warning; the figures are what the eye gets either way.
    pub enclosed_by: Option<u32>,
}

/// The α-opic light at an eye (CIE S 026/E:2018), in the order of
/// `photometry::alpha_opic::ALPHA_OPIC_NAMES`: S-cone, M-cone, L-cone, rhodopic, melanopic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlphaOpic {
    /// α-opic irradiance, W/m².
    pub irradiance_w_m2: [f64; 5],
    /// α-opic equivalent daylight (D65) illuminance, lx (melanopic EDI last), and its
    /// standard error.
    pub edi_lx: [f64; 5],
    pub edi_sigma_lx: [f64; 5],
    /// Melanopic daylight (D65) efficacy ratio: melanopic EDI over the illuminance.
    pub melanopic_der: f64,
}

/// Emitting triangles are split until each piece subtends at most this solid angle, sr.
const PIECE_SR: f64 = 2e-3;
/// At most this many halvings of a triangle's edges (4⁶ pieces).
const MAX_SPLITS: u32 = 6;

impl Context {
    /// Adds a sensor at `observer`'s eye facing its view: a disk of five vertices and
    /// `radius` (scene units), the eye vertex 0, recording light from in front. Its front
    /// illuminance at vertex 0 after a run is the observer's vertical illuminance Ev
    /// (`illuminance` and `rel_error` of the returned mesh, side 0). Returns the mesh id.
    pub fn add_observer_sensor(&mut self, observer: &Observer, radius: f64) -> Result<u32> {
        let f = observer.frame()?;
        crate::error::check_finite_scalar("radius", radius)?;
        if radius <= 0.0 {
            bail!(
                ImapErrInvalidArgument,
                "radius = {radius} must be positive (scene units)"
            );
        }
        let right = f.view.cross(f.up);
        let mut positions = f.eye.to_array().to_vec();
        // up × right = view: the triangles face the view.
        for c in [f.up, right, -f.up, -right] {
            positions.extend((f.eye + c * radius).to_array());
        }
        let indices: Vec<u32> = (0..4u32)
            .flat_map(|i| [0, 1 + i, 1 + (i + 1) % 4])
            .collect();
        self.add_mesh(&MeshDesc {
            sensor: true,
            ..MeshDesc::new(&positions, &indices, 0)
        })
    }

    /// The vertical illuminance an observer's sensor (`add_observer_sensor`) read at its
    /// eye, and its standard error, lx: vertex 0 of mesh `sensor`, front side.
    pub fn observer_ev(&self, sensor: u32) -> Result<(f64, f64)> {
        let n = self.vertex_count(sensor)?;
        let (mut lux, mut rel) = (vec![0.0; n], vec![0.0; n]);
        self.illuminance(sensor, 0, &mut lux)?;
        self.rel_error(sensor, 0, &mut rel)?;
        Ok((lux[0], lux[0] * rel[0]))
    }

    /// The α-opic light at an observer's eye from its sensor's bands (vertex 0 of mesh
    /// `sensor`, front side), each band's power spread evenly over its interval. The
    /// standard errors are the band-mean irradiance's relative error times each value
    /// (exact when every photon has the same spectrum at the eye). Refused
    /// (IMAP_ERR_UNSUPPORTED) in an RGB context: its bands carry no wavelengths.
    pub fn observer_alpha_opic(&self, sensor: u32) -> Result<AlphaOpic> {
        let Some(weights) = alpha_opic_per_band(&self.config().bands) else {
            bail!(
                ImapErrUnsupported,
                "α-opic quantities (melanopic EDI) need a spectral context: an RGB context's bands carry no wavelengths (create the context with spectral bands)"
            );
        };
        let n = self.vertex_count(sensor)?;
        let mut out = AlphaOpic {
            irradiance_w_m2: [0.0; 5],
            edi_lx: [0.0; 5],
            edi_sigma_lx: [0.0; 5],
            melanopic_der: 0.0,
        };
        let mut e = vec![0.0; n];
        for (b, w) in weights.iter().enumerate() {
            self.irradiance(sensor, 0, b as u32, &mut e)?;
            for (o, wk) in out.irradiance_w_m2.iter_mut().zip(w) {
                *o += e[0] * wk;
            }
        }
        // Ev and its σ give the band-mean relative error (1 where nothing arrived).
        let (ev, sigma) = self.observer_ev(sensor)?;
        let rel = if ev > 0.0 { sigma / ev } else { 1.0 };
        for (k, kv) in D65_EFFICACY_MW_PER_LM.iter().enumerate() {
            out.edi_lx[k] = out.irradiance_w_m2[k] / (kv * 1e-3);
            out.edi_sigma_lx[k] = out.edi_lx[k] * rel;
        }
        out.melanopic_der = if ev > 0.0 { out.edi_lx[4] / ev } else { 0.0 };
        Ok(out)
    }

    /// The glare `observer` gets from the scene's light sources, given the vertical
    /// illuminance at its eye `ev_lx` and that value's standard error `ev_sigma_lx` (from
    /// its sensor: `add_observer_sensor`). `Glare::enclosed_by` names a one-sided mesh
    /// whose back faces surround the eye.
    pub fn observer_glare(
        &mut self,
        observer: &Observer,
        ev_lx: f64,
        ev_sigma_lx: f64,
    ) -> Result<Glare> {
        let f = observer.frame()?;
        for (name, v) in [("ev_lx", ev_lx), ("ev_sigma_lx", ev_sigma_lx)] {
            crate::error::check_finite_scalar(name, v)?;
            if v < 0.0 {
                bail!(
                    ImapErrInvalidArgument,
                    "{name} = {v} must not be negative (lx)"
                );
            }
        }
        let unit_m = self.config().unit_m;
        let sight = self.sight()?;
        let enclosed_by = enclosing_mesh(&sight, &f);
        let mut sources = Vec::new();
        for (id, light) in sight.scene.lights.iter().enumerate() {
            if let Some(s) = light_source(&sight, &f, light, id as u32, unit_m) {
                sources.push(s);
            }
        }
        for id in 0..sight.scene.meshes.len() {
            if let Some(s) = mesh_source(&sight, &f, id, unit_m) {
                sources.push(s);
            }
        }
        sources.sort_by(|a, b| b.term.total_cmp(&a.term));
        let direct: f64 = sources.iter().map(|s| s.ev_lx).sum();
        let background = (ev_lx - direct).max(0.0) / PI;
        let background_sigma = ev_sigma_lx / PI;
        let terms: f64 = sources.iter().map(|s| s.term).sum();
        let (ugr_value, ugr_sigma) = if sources.is_empty() || terms <= 0.0 {
            (0.0, 0.0)
        } else if background > 0.0 {
            (
                ugr(terms, background),
                8.0 / std::f64::consts::LN_10 * background_sigma / background,
            )
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        Ok(Glare {
            ev_lx,
            ev_sigma_lx,
            direct_lx: direct,
            background_cd_m2: background,
            background_sigma_cd_m2: background_sigma,
            ugr: ugr_value,
            ugr_sigma,
            // 0 with no source in view.
            ugr_below_10: ugr_value < 10.0,
            dgps: dgps(ev_lx),
            dgps_sigma: DGPS_PER_LX * ev_sigma_lx,
            sources,
            enclosed_by,
        })
    }
}

/// The one-sided mesh through whose back faces every line of sight along the eye's six
/// axes leaves, if one does: the eye is inside a solid object (where no light arrives), or
/// in a room drawn with its normals out (whose light then reaches the eye, but whose
/// inside no map records). Which of the two cannot be told from the geometry alone.
fn enclosing_mesh(sight: &Sight, f: &Frame) -> Option<u32> {
    let right = f.view.cross(f.up);
    let mut inside: Option<u32> = None;
    for d in [f.view, -f.view, f.up, -f.up, right, -right] {
        let h = sight.first_hit(f.eye, d)?;
        if h.front
            || sight.scene.meshes[h.mesh as usize].two_sided
            || inside.is_some_and(|m| m != h.mesh)
        {
            return None;
        }
        inside = Some(h.mesh);
    }
    inside
}

/// A light as the observer sees it (None behind the eye, unseen, or not a source of
/// luminance: a beam, a sky, the sun).
fn light_source(
    sight: &Sight,
    f: &Frame,
    light: &Light,
    id: u32,
    unit_m: f64,
) -> Option<GlareSource> {
    if matches!(
        light.shape,
        LightShape::Distant(_) | LightShape::Beam { .. }
    ) {
        return None;
    }
    let to = light.position - f.eye;
    let r = to.length();
    let d = to.try_normalize()?;
    let p = position_index(f.view, f.up, d)?;
    let intensity = light.shape.intensity_per_watt(-d) * sight.photometry.luminous(&light.power);
    if intensity <= 0.0 {
        return None;
    }
    // Points of the luminous area whose line to the eye is tested: its centre, and four
    // around it at 0.4 of its half-extents.
    let mut points = vec![light.position];
    let mut area = 0.0;
    if let LightShape::Luminaire(l) = &light.shape {
        let lum = &l.luminous;
        area = lum.projected_area_m2(d);
        let (length, width) = lum.opening.extent_m();
        if length > 0.0 || width > 0.0 {
            let (a, b) = (
                lum.along * (0.4 * length / unit_m),
                lum.across * (0.4 * width / unit_m),
            );
            points.extend([a, -a, b, -b].map(|o| light.position + o));
        }
    }
    let seen = points.iter().filter(|q| sight.clear(f.eye, **q)).count();
    if seen == 0 {
        return None;
    }
    let visible = seen as f64 / points.len() as f64;
    let r_m = r * unit_m;
    let small = area < SMALL_SOURCE_M2;
    let term = if small {
        visible * 200.0 * intensity * intensity / (r_m * r_m * p * p)
    } else {
        visible * intensity * intensity / (area * r_m * r_m * p * p)
    };
    Some(GlareSource {
        kind: SourceKind::Light(id),
        direction: d.to_array(),
        distance_m: r_m,
        intensity_cd: intensity,
        projected_area_m2: area,
        luminance_cd_m2: if area > 0.0 { intensity / area } else { 0.0 },
        solid_angle_sr: visible * area / (r_m * r_m),
        position_index: p,
        visible,
        ev_lx: visible * intensity * d.dot(f.view) / (r_m * r_m),
        term,
        small,
    })
}

/// An emitting mesh as the observer sees it: its triangles, split into pieces of small
/// solid angle, each seen (or not) at its centre. Lambertian emission of the mesh's
/// exitance: luminance M / π.
fn mesh_source(sight: &Sight, f: &Frame, id: usize, unit_m: f64) -> Option<GlareSource> {
    let mesh = &sight.scene.meshes[id];
    let exitance = mesh.exitance.as_ref()?;
    let luminance = sight.photometry.luminous(exitance) / PI;
    if luminance <= 0.0 {
        return None;
    }
    #[derive(Default)]
    struct Sum {
        omega: f64,
        omega_all: f64,
        over_p2: f64,
        ev: f64,
        dir: DVec3,
        area: f64,
    }
    let mut sum = Sum::default();
    let mut stack: Vec<([DVec3; 3], u32)> = Vec::new();
    for t in &mesh.triangles {
        let tri = t.map(|i| DVec3::from(mesh.positions[i as usize]));
        stack.push((tri, 0));
        while let Some(([a, b, c], depth)) = stack.pop() {
            let n2 = (b - a).cross(c - a);
            let area = 0.5 * n2.length();
            if area <= 0.0 {
                continue;
            }
            let n = n2.normalize();
            let centre = (a + b + c) / 3.0;
            let to = centre - f.eye;
            let r = to.length();
            let Some(d) = to.try_normalize() else {
                continue;
            };
            let cos_e = -d.dot(n);
            let facing = if mesh.two_sided { cos_e.abs() } else { cos_e };
            if facing <= 0.0 {
                continue;
            }
            let omega = area * facing / (r * r);
            if omega > PIECE_SR && depth < MAX_SPLITS {
                let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
                for piece in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                    stack.push((piece, depth + 1));
                }
                continue;
            }
            let Some(p) = position_index(f.view, f.up, d) else {
                continue;
            };
            sum.omega_all += omega;
            if !sight.clear(f.eye, centre) {
                continue;
            }
            sum.omega += omega;
            sum.over_p2 += omega / (p * p);
            sum.ev += luminance * omega * d.dot(f.view);
            sum.dir += d * omega;
            sum.area += area * facing * unit_m * unit_m;
        }
    }
    if sum.omega <= 0.0 {
        return None;
    }
    let dir = sum.dir.normalize_or_zero();
    // The distance at which the seen area subtends the seen solid angle.
    let r_m = (sum.area / sum.omega).sqrt();
    let intensity = luminance * sum.area;
    let small = sum.area < SMALL_SOURCE_M2;
    let p = (sum.omega / sum.over_p2).sqrt();
    let term = if small {
        200.0 * intensity * intensity / (r_m * r_m * p * p)
    } else {
        luminance * luminance * sum.over_p2
    };
    Some(GlareSource {
        kind: SourceKind::Mesh(id as u32),
        direction: dir.to_array(),
        distance_m: r_m,
        intensity_cd: intensity,
        projected_area_m2: sum.area,
        luminance_cd_m2: luminance,
        solid_angle_sr: sum.omega,
        position_index: p,
        visible: sum.omega / sum.omega_all,
        ev_lx: sum.ev,
        term,
        small,
    })
}

impl Context {
    /// `picture_glare` of a rendered fisheye picture: each pixel's luminance from its
    /// bands (this context's photometry), its error from `image.rel_error`.
    pub fn picture_glare(
        &self,
        camera: &crate::render::CameraDesc,
        image: &crate::render::Image,
        rules: &SourceRules,
    ) -> Result<PictureGlare> {
        let nb = image.bands;
        if image.width != camera.width || image.height != camera.height || nb == 0 {
            bail!(
                ImapErrInvalidArgument,
                "image is {}×{} with {nb} bands; the camera's picture is {}×{}",
                image.width,
                image.height,
                camera.width,
                camera.height
            );
        }
        self.picture_glare_of_bands(camera, &image.radiance, nb, Some(&image.rel_error), rules)
    }

    /// `picture_glare` of a picture's band values (`bands` per pixel, as a render writes
    /// them): each pixel's luminance by this context's photometry.
    pub fn picture_glare_of_bands(
        &self,
        camera: &crate::render::CameraDesc,
        radiance: &[f64],
        bands: usize,
        rel_error: Option<&[f64]>,
        rules: &SourceRules,
    ) -> Result<PictureGlare> {
        let photometry = self.photometry();
        let lum: Vec<f64> = radiance
            .chunks_exact(bands.max(1))
            .map(|c| photometry.luminous(c))
            .collect();
        picture_glare(camera, &lum, rel_error, rules)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_x() -> (DVec3, DVec3) {
        (DVec3::X, DVec3::Z)
    }

    #[test]
    fn position_index_is_one_on_the_line_of_sight_and_grows_off_it() {
        let (v, u) = frame_x();
        assert!((position_index(v, u, v).unwrap() - 1.0).abs() < 1e-12);
        assert!(position_index(v, u, -v).is_none());
        assert!(position_index(v, u, DVec3::Y).is_none());
        let at = |deg: f64, up: bool| {
            let a = deg.to_radians();
            let d = DVec3::new(a.cos(), 0.0, if up { a.sin() } else { -a.sin() });
            position_index(v, u, d).unwrap()
        };
        // Straight up (τ = 0): exp(0.03398 σ + 0.00021 σ²) - the formula at σ = 30°.
        let s: f64 = 30.0;
        let expect = ((35.2 - 1.22) * 1e-3 * s + 21e-5 * s * s).exp();
        assert!((at(30.0, true) - expect).abs() < 1e-9, "{}", at(30.0, true));
        let mut last = 1.0;
        for deg in [10.0, 20.0, 40.0, 50.0] {
            let p = at(deg, true);
            assert!(p > last, "p({deg}°) = {p} ≤ {last}");
            last = p;
        }
        // Straight up it reaches evalglare's cap of 16 at σ ≈ 59°.
        assert!(at(58.0, true) < 16.0 && at(60.0, true) == 16.0 && at(89.0, true) == 16.0);
        // Left and right are the same.
        let side = |y: f64| {
            let d = DVec3::new(1.0, y, 0.5).normalize();
            position_index(v, u, d).unwrap()
        };
        assert!((side(0.7) - side(-0.7)).abs() < 1e-12);
        // A source below the line of sight at the same σ is more glaring than one above
        // (the position index is smaller), and the two agree on the horizontal.
        assert!(at(30.0, false) < at(30.0, true));
        let h = |z: f64| {
            let d = DVec3::new(1.0, 0.6, z).normalize();
            position_index(v, u, d).unwrap()
        };
        assert!(
            (h(1e-9) - h(-1e-9)).abs() < 2e-3 * h(0.0),
            "{} {}",
            h(1e-9),
            h(-1e-9)
        );
    }

    #[test]
    fn ugr_and_dgps_are_their_formulas() {
        // One source of 10 000 cd/m², 0.01 sr, p = 2, on 20 cd/m²:
        // 8 log10(0.25 · 1e8 · 0.01 / 4 / 20) = 8 log10(3125) = 27.96.
        let term = 1e8 * 0.01 / 4.0;
        assert!((ugr(term, 20.0) - 8.0 * 3125f64.log10()).abs() < 1e-12);
        assert!(ugr(term, 0.0).is_infinite());
        assert!((dgps(2000.0) - (0.1244 + 0.184)).abs() < 1e-12);
    }

    #[test]
    fn an_observer_needs_a_view_and_an_up_across_it() {
        let o = Observer {
            eye: [0.0; 3],
            view: [0.0; 3],
            up: [0.0, 0.0, 1.0],
        };
        let e = o.frame().unwrap_err();
        assert!(e.message.contains("observer.view"), "{}", e.message);
        let o = Observer {
            view: [0.0, 0.0, 2.0],
            ..o
        };
        let e = o.frame().unwrap_err();
        assert!(e.message.contains("observer.up"), "{}", e.message);
        let o = Observer {
            eye: [f64::NAN, 0.0, 0.0],
            view: [1.0, 0.0, 0.0],
            ..o
        };
        assert!(o.frame().is_err());
    }
}
