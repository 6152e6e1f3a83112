//! The daylight glare probability of a fisheye picture (Wienold & Christoffersen 2006),
//! with glare sources found by evalglare's rules, and its standard error from the
//! picture's per-pixel errors.
//!
//! The picture must show the whole front hemisphere: an angular or hemispherical fisheye
//! of at least 180° across and up. From its pixels in front of the eye (each with its
//! direction and solid angle, `Camera::pixel_direction`):
//! - Ev = Σ L ω cos θ, the vertical illuminance at the eye;
//! - the glare pixels: brighter than an absolute threshold (evalglare's default 2000
//!   cd/m²), or a multiple of the picture's mean luminance;
//! - the glare sources: glare pixels closer than half the search angle (evalglare's `-r`,
//!   0.2 rad) join one source, transitively; pixels above the peak luminance (50 000
//!   cd/m², evalglare's peak extraction) leave their source for sources of their own,
//!   found the same way among themselves;
//! - each source's solid angle ω, mean luminance L, and position index P (`position_index`)
//!   at its centre, the L·ω-weighted mean of its pixels' positions on the picture;
//! - DGP = 5.87·10⁻⁵ Ev + 9.18·10⁻² log10(1 + Σ L² ω / (Ev^1.87 P²)) + 0.16, at most 1,
//!   with the low-light correction below 1000 lx when asked (evalglare has it off since
//!   2.14).
//!
//! The standard error treats the found sources as given and the pixels' errors as
//! independent, and propagates them to first order.

use super::position_index;
use crate::error::{bail, Result};
use crate::render::{Camera, CameraDesc, Projection};
use glam::DVec3;

/// How glare sources are found in a picture; `Default` gives evalglare's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceRules {
    /// Above 100: the luminance (cd/m²) above which a pixel belongs to a glare source
    /// (evalglare's `-b`; default 2000). 100 or less: that multiple of the picture's mean
    /// luminance over the front hemisphere.
    pub threshold: f64,
    /// Glare pixels closer than half this angle (radians) join one source (evalglare's
    /// `-r`; default 0.2).
    pub search_angle_rad: f64,
    /// Pixels at or above this luminance (cd/m²) are split off into sources of their own
    /// (evalglare's peak extraction, `-Y`; default 50 000; 0: none).
    pub peak_cd_m2: f64,
    /// Apply Wienold's (2009) low-light correction below Ev = 1000 lx (evalglare's
    /// `-C l+`; default off, as in evalglare since 2.14).
    pub low_light: bool,
}

impl Default for SourceRules {
    fn default() -> Self {
        SourceRules {
            threshold: 2000.0,
            search_angle_rad: 0.2,
            peak_cd_m2: 50_000.0,
            low_light: false,
        }
    }
}

/// A glare source found in a picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PictureSource {
    /// From the eye toward its centre (unit, scene axes).
    pub direction: [f64; 3],
    /// Its centre on the picture, pixels from the top left (x right, y down): the L·ω
    /// weighted mean of its pixels' centres.
    pub centre_px: [f64; 2],
    pub solid_angle_sr: f64,
    /// Mean luminance over its solid angle, cd/m².
    pub luminance_cd_m2: f64,
    /// Guth's position index at its centre (`position_index`).
    pub position_index: f64,
    /// What it gives the eye, lx.
    pub ev_lx: f64,
    pub pixels: u32,
    /// Its DGP term L² ω / P².
    pub term: f64,
}

/// A picture's daylight glare probability and what it is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct PictureGlare {
    /// The vertical illuminance at the eye from the picture, and its standard error, lx.
    pub ev_lx: f64,
    pub ev_sigma_lx: f64,
    /// DGP and its standard error.
    pub dgp: f64,
    pub dgp_sigma: f64,
    /// The luminance a glare pixel exceeds, cd/m².
    pub threshold_cd_m2: f64,
    /// Mean luminance over the front hemisphere, cd/m².
    pub mean_luminance_cd_m2: f64,
    /// (Ev − what the sources give) / π, cd/m² (evalglare's default background).
    pub background_cd_m2: f64,
    /// The sources, largest term first.
    pub sources: Vec<PictureSource>,
    /// Per pixel (row-major from the top left): 0, or 1 + the index in `sources` of the
    /// source it belongs to.
    pub labels: Vec<u32>,
}

/// DGP of Ev (lx) and the sources' summed terms Σ L² ω / P² (Wienold & Christoffersen
/// 2006), at most 1; with the low-light correction below 1000 lx when `low_light`.
pub fn dgp(ev_lx: f64, terms: f64, low_light: bool) -> f64 {
    if ev_lx.is_nan() || ev_lx <= 0.0 {
        return 0.0;
    }
    let mut d = 5.87e-5 * ev_lx + 9.18e-2 * (1.0 + terms / ev_lx.powf(1.87)).log10() + 0.16;
    if low_light && ev_lx < 1000.0 {
        let x = (0.024 * ev_lx - 4.0).exp();
        d *= x / (1.0 + x);
    }
    d.min(1.0)
}

/// A pixel of the front hemisphere.
struct Px {
    index: u32,
    dir: DVec3,
    omega: f64,
    lum: f64,
}

/// Union–find over glare pixels.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

fn check_picture(camera: &Camera, rules: &SourceRules) -> Result<()> {
    let d = &camera.desc;
    let (w, h) = (d.width as f64, d.height as f64);
    // The angle the picture's narrower side spans.
    let narrow = d.fov_y_deg * (w / h).min(1.0);
    let whole = match d.projection {
        Projection::Perspective => false,
        Projection::AngularFisheye => narrow >= 180.0 - 1e-9,
        Projection::Hemispherical => d.fov_y_deg >= 180.0 - 1e-9 && w >= h,
    };
    if !whole {
        bail!(
            ImapErrInvalidArgument,
            "camera: DGP needs a picture of the whole front hemisphere: an angular or hemispherical fisheye (projection) of at least 180° across and up (this one is {:?}, fov_y_deg = {}, {}×{})",
            d.projection,
            d.fov_y_deg,
            d.width,
            d.height
        );
    }
    if !(rules.threshold.is_finite() && rules.threshold > 0.0) {
        bail!(
            ImapErrInvalidArgument,
            "rules.threshold = {} must be positive: a luminance above 100 cd/m², or a multiple of the mean luminance",
            rules.threshold
        );
    }
    if !(rules.search_angle_rad.is_finite()
        && rules.search_angle_rad > 0.0
        && rules.search_angle_rad <= 1.0)
    {
        bail!(
            ImapErrInvalidArgument,
            "rules.search_angle_rad = {} is not in (0, 1] (evalglare's -r; 0.2 by default)",
            rules.search_angle_rad
        );
    }
    if !(rules.peak_cd_m2.is_finite() && rules.peak_cd_m2 >= 0.0) {
        bail!(
            ImapErrInvalidArgument,
            "rules.peak_cd_m2 = {} must be 0 (no peak extraction) or positive",
            rules.peak_cd_m2
        );
    }
    let pixel = camera.pixel_angle();
    if pixel > 0.5 * rules.search_angle_rad {
        let need = (d.fov_y_deg.to_radians() / (0.5 * rules.search_angle_rad)).ceil();
        bail!(
            ImapErrInvalidArgument,
            "camera: the picture's pixels span {:.2}° at its centre, more than half the search angle ({:.2}°): sources cannot be told apart; render at least {need} pixels up",
            pixel.to_degrees(),
            (0.5 * rules.search_angle_rad).to_degrees()
        );
    }
    Ok(())
}

/// Single-linkage clusters of `members` (indices into `px`): pixels closer than
/// `half_angle` join. `window` is how many pixels away a partner may lie. Returns the
/// clusters, each its members in `members`' order, ordered by their first member.
fn clusters(
    px: &[Px],
    members: &[usize],
    w: u32,
    h: u32,
    half_angle: f64,
    window: i64,
) -> Vec<Vec<usize>> {
    let n = members.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    // Slot of each member in a full-picture index, for the window scan.
    let mut slot = vec![u32::MAX; (w as usize) * (h as usize)];
    for (k, &m) in members.iter().enumerate() {
        slot[px[m].index as usize] = k as u32;
    }
    let cos_max = half_angle.cos();
    for (k, &m) in members.iter().enumerate() {
        let (x, y) = ((px[m].index % w) as i64, (px[m].index / w) as i64);
        for yy in (y - window).max(0)..=(y + window).min(h as i64 - 1) {
            for xx in (x - window).max(0)..=(x + window).min(w as i64 - 1) {
                let s = slot[(yy * w as i64 + xx) as usize];
                if s == u32::MAX || s as usize <= k {
                    continue;
                }
                let other = members[s as usize];
                if px[m].dir.dot(px[other].dir) >= cos_max {
                    let (a, b) = (find(&mut parent, k as u32), find(&mut parent, s));
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                }
            }
        }
    }
    // (A root is its cluster's smallest index: clusters come by their first member.)
    let mut groups: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
    for (k, &m) in members.iter().enumerate() {
        let root = find(&mut parent, k as u32);
        groups.entry(root).or_default().push(m);
    }
    groups.into_values().collect()
}

/// The DGP of a fisheye picture of luminance `luminance` (cd/m², one per pixel, row-major
/// from the top left) seen by `camera`, with glare sources found by `rules`. `rel_error`
/// (one per pixel, the relative standard error of each pixel) gives the standard errors;
/// without it they are 0. Refused: a picture that is not a fisheye of the whole front
/// hemisphere, pixels too coarse for the search angle, a luminance that is negative or not
/// finite, and arrays of the wrong length.
pub fn picture_glare(
    camera: &CameraDesc,
    luminance: &[f64],
    rel_error: Option<&[f64]>,
    rules: &SourceRules,
) -> Result<PictureGlare> {
    let cam = Camera::new(camera, DVec3::ZERO)?;
    check_picture(&cam, rules)?;
    let (w, h) = (camera.width, camera.height);
    let n = cam.pixels();
    if luminance.len() != n {
        bail!(
            ImapErrInvalidArgument,
            "luminance holds {} values; the {w}×{h} picture has {n} pixels",
            luminance.len()
        );
    }
    if let Some(r) = rel_error {
        if r.len() != n {
            bail!(
                ImapErrInvalidArgument,
                "rel_error holds {} values; the {w}×{h} picture has {n} pixels",
                r.len()
            );
        }
        if let Some(i) = r.iter().position(|e| !(e.is_finite() && *e >= 0.0)) {
            bail!(
                ImapErrInvalidArgument,
                "rel_error[{i}] = {} is not a finite non-negative relative error",
                r[i]
            );
        }
    }
    if let Some(i) = luminance.iter().position(|l| !(l.is_finite() && *l >= 0.0)) {
        bail!(
            ImapErrInvalidArgument,
            "luminance[{i}] = {} (pixel ({}, {})) is not a finite non-negative luminance",
            luminance[i],
            i as u32 % w,
            i as u32 / w
        );
    }
    let view = cam.forward();
    let up = cam.up();
    // The front hemisphere's pixels.
    let mut px = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let Some((dir, omega)) = cam.pixel_direction(x, y) else {
                continue;
            };
            if dir.dot(view) <= 0.0 {
                continue;
            }
            let index = y * w + x;
            px.push(Px {
                index,
                dir,
                omega,
                lum: luminance[index as usize],
            });
        }
    }
    let ev: f64 = px.iter().map(|p| p.lum * p.omega * p.dir.dot(view)).sum();
    let omega_all: f64 = px.iter().map(|p| p.omega).sum();
    let mean = px.iter().map(|p| p.lum * p.omega).sum::<f64>() / omega_all;
    let threshold = if rules.threshold > 100.0 {
        rules.threshold
    } else {
        rules.threshold * mean
    };
    // The window that holds every partner closer than half the search angle: a pixel's
    // smallest angular pitch is 2/π of the centre's (an angular fisheye's rim, across).
    let half = 0.5 * rules.search_angle_rad;
    let window = (half / (cam.pixel_angle() * 2.0 / std::f64::consts::PI)).ceil() as i64 + 1;
    let glare: Vec<usize> = (0..px.len()).filter(|&i| px[i].lum > threshold).collect();
    // The clusters, then each cluster's peaks split off.
    let groups = clusters(&px, &glare, w, h, half, window);
    let mut sources_px: Vec<Vec<usize>> = Vec::new();
    let peak = rules.peak_cd_m2;
    let any_peak = peak > 0.0 && glare.iter().any(|&i| px[i].lum >= peak);
    for members in groups {
        if !any_peak {
            sources_px.push(members);
            continue;
        }
        let (peaks, rest): (Vec<usize>, Vec<usize>) =
            members.into_iter().partition(|&i| px[i].lum >= peak);
        if !rest.is_empty() {
            sources_px.push(rest);
        }
        if !peaks.is_empty() {
            sources_px.extend(clusters(&px, &peaks, w, h, half, window));
        }
    }
    // Each source's figures.
    let mut sources: Vec<(PictureSource, Vec<usize>)> = sources_px
        .into_iter()
        .map(|members| {
            let (mut omega, mut flux, mut e, mut cx, mut cy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for &i in &members {
                let p = &px[i];
                let lw = p.lum * p.omega;
                omega += p.omega;
                flux += lw;
                e += lw * p.dir.dot(view);
                cx += lw * ((p.index % w) as f64 + 0.5);
                cy += lw * ((p.index / w) as f64 + 0.5);
            }
            let (cx, cy) = (cx / flux, cy / flux);
            let (ix, iy) = (
                cx.floor().clamp(0.0, w as f64 - 1.0),
                cy.floor().clamp(0.0, h as f64 - 1.0),
            );
            let dir = cam
                .ray(ix as u32, iy as u32, cx - ix, cy - iy)
                .unwrap_or(px[members[0]].dir);
            let pos = position_index(view, up, dir).unwrap_or(16.0);
            let lum = flux / omega;
            (
                PictureSource {
                    direction: dir.to_array(),
                    centre_px: [cx, cy],
                    solid_angle_sr: omega,
                    luminance_cd_m2: lum,
                    position_index: pos,
                    ev_lx: e,
                    pixels: members.len() as u32,
                    term: lum * lum * omega / (pos * pos),
                },
                members,
            )
        })
        .collect();
    sources.sort_by(|a, b| b.0.term.total_cmp(&a.0.term));
    let terms: f64 = sources.iter().map(|s| s.0.term).sum();
    let e_direct: f64 = sources.iter().map(|s| s.0.ev_lx).sum();
    let value = dgp(ev, terms, rules.low_light);
    let mut labels = vec![0u32; n];
    for (k, (_, members)) in sources.iter().enumerate() {
        for &i in members {
            labels[px[i].index as usize] = k as u32 + 1;
        }
    }
    // First-order error: ∂DGP/∂L of every pixel, its σ = rel · L.
    let (mut ev_var, mut dgp_var) = (0.0, 0.0);
    if let Some(rel) = rel_error {
        let f = |e: f64, s: f64| dgp(e, s, rules.low_light);
        let de = 1e-6 * ev.max(1e-9);
        let ds = 1e-6 * terms.max(1e-9);
        let f_e =
            (f(ev + de, terms) - f((ev - de).max(0.0), terms)) / (ev + de - (ev - de).max(0.0));
        let f_s = if terms > 0.0 {
            (f(ev, terms + ds) - f(ev, (terms - ds).max(0.0)))
                / (terms + ds - (terms - ds).max(0.0))
        } else {
            0.0
        };
        for p in &px {
            let sigma = rel[p.index as usize] * p.lum;
            if sigma == 0.0 {
                continue;
            }
            let cosw = p.omega * p.dir.dot(view);
            let label = labels[p.index as usize];
            // d(L_s² ω_s / P²)/dL_p = 2 L_s ω_p / P² for a pixel of source s.
            let ds_dl = if label > 0 {
                let s = &sources[label as usize - 1].0;
                2.0 * s.luminance_cd_m2 * p.omega / (s.position_index * s.position_index)
            } else {
                0.0
            };
            ev_var += (cosw * sigma).powi(2);
            dgp_var += ((f_e * cosw + f_s * ds_dl) * sigma).powi(2);
        }
    }
    Ok(PictureGlare {
        ev_lx: ev,
        ev_sigma_lx: ev_var.sqrt(),
        dgp: value,
        dgp_sigma: dgp_var.sqrt(),
        threshold_cd_m2: threshold,
        mean_luminance_cd_m2: mean,
        background_cd_m2: (ev - e_direct) / std::f64::consts::PI,
        sources: sources.into_iter().map(|s| s.0).collect(),
        labels,
    })
}
