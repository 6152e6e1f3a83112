//! Observers and glare through the C ABI (Since 0.2.3).

use super::scene::add_with;
use super::{
    boundary, check_out, read_versioned, with_context, write_defaults, write_out, write_versioned,
    ImapContext, Versioned,
};
use crate::error::{bail, ImapStatus, Result};
use crate::glare::{Glare, GlareSource, Observer, PictureSource, SourceKind, SourceRules};

/// An observer: an eye (scene units), the direction it looks in and its up (any vector
/// not parallel to the view; only its part across the view counts). Initialise with
/// `imap_observer_default(&o, sizeof o)`: eye at the origin, looking along +x, up +z.
/// (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapObserver {
    pub struct_size: u32,
    pub reserved: u32,
    pub eye: [f64; 3],
    pub view: [f64; 3],
    pub up: [f64; 3],
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapObserver {
    const NAME: &'static str = "ImapObserver";
    const INIT: &'static str = "imap_observer_default";
    fn defaults() -> Self {
        ImapObserver {
            struct_size: std::mem::size_of::<Self>() as u32,
            reserved: 0,
            eye: [0.0; 3],
            view: [1.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
        }
    }
}

/// An observer's light and glare (`imap_observer_glare`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapGlare {
    pub struct_size: u32,
    /// The light sources in front of the eye that it sees (luminaires, point, spot and
    /// cosine lights, emitting meshes).
    pub sources: u32,
    /// The vertical illuminance at the eye and its standard error, lx, as given.
    pub ev_lx: f64,
    pub ev_sigma_lx: f64,
    /// What those sources give the eye directly, lx.
    pub direct_lx: f64,
    /// The background luminance (Ev − direct) / π and its standard error, cd/m²
    /// (CIE 117: the indirect illuminance at the eye over π; 0 if noise makes it negative).
    pub background_cd_m2: f64,
    pub background_sigma_cd_m2: f64,
    /// UGR = 8 log10(0.25 / Lb · Σ L² ω / p²) (CIE 117:1995; a source of projected area
    /// below 0.005 m², a point light among them, with CIE 147:2002's term 200 I² / (r² p²)),
    /// and its standard error (from the background's). 0 when no source is in view; +∞
    /// when the background is black.
    pub ugr: f64,
    pub ugr_sigma: f64,
    /// 1 when UGR is below 10, where CIE 117's scale starts (no source in view included):
    /// no discomfort glare to rate.
    pub ugr_below_10: u32,
    /// The one-sided mesh whose back faces every line of sight along the eye's six axes
    /// meets first, or IMAP_GLARE_NOT_ENCLOSED: the eye is inside a solid object (no light
    /// arrives there) or in a room drawn with its normals out (its light arrives, but no
    /// map records the room's inside). Worth a warning to the user; the figures are what
    /// the eye gets either way.
    pub enclosed_by: u32,
    /// The simplified daylight glare probability DGPs = 6.22·10⁻⁵ Ev + 0.184 (Wienold
    /// 2009; it holds with no sun, nor a specular image of it, in view) and its standard
    /// error.
    pub dgps: f64,
    pub dgps_sigma: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapGlare {
    const NAME: &'static str = "ImapGlare";
    const INIT: &'static str = "sizeof(ImapGlare)";
    fn defaults() -> Self {
        ImapGlare {
            struct_size: std::mem::size_of::<Self>() as u32,
            sources: 0,
            ev_lx: 0.0,
            ev_sigma_lx: 0.0,
            direct_lx: 0.0,
            background_cd_m2: 0.0,
            background_sigma_cd_m2: 0.0,
            ugr: 0.0,
            ugr_sigma: 0.0,
            ugr_below_10: 0,
            enclosed_by: IMAP_GLARE_NOT_ENCLOSED,
            dgps: 0.0,
            dgps_sigma: 0.0,
        }
    }
}

/// `ImapGlare::enclosed_by`: no mesh encloses the eye.
pub const IMAP_GLARE_NOT_ENCLOSED: u32 = u32::MAX;

/// `ImapGlareSource::kind`: a light (`id` as `imap_add_light` and the luminaire calls
/// gave it).
pub const IMAP_GLARE_SOURCE_LIGHT: u32 = 0;
/// `ImapGlareSource::kind`: an emitting mesh (`id` its mesh id), its triangles summed.
pub const IMAP_GLARE_SOURCE_MESH: u32 = 1;

/// A light source as an observer sees it (`imap_observer_glare`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapGlareSource {
    pub struct_size: u32,
    /// `IMAP_GLARE_SOURCE_*`.
    pub kind: u32,
    pub id: u32,
    /// 1: a small source (projected area below 0.005 m²: CIE 147's term).
    pub small: u32,
    /// From the eye toward the source (unit; for a mesh its solid-angle-weighted mean).
    pub direction: [f64; 3],
    /// From the eye, m.
    pub distance_m: f64,
    /// Intensity toward the eye, cd.
    pub intensity_cd: f64,
    /// The luminous area it shows the eye, m² (0 for a point light), and its luminance
    /// toward the eye, cd/m² (0 for a point light).
    pub projected_area_m2: f64,
    pub luminance_cd_m2: f64,
    /// The solid angle of its visible part at the eye, sr.
    pub solid_angle_sr: f64,
    /// Guth's position index.
    pub position_index: f64,
    /// The share of its luminous area the eye sees (0–1).
    pub visible: f64,
    /// Its direct vertical illuminance at the eye, lx.
    pub ev_lx: f64,
    /// Its UGR term: L² ω / p² (or 200 I² / (r² p²) for a small source).
    pub term: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapGlareSource {
    const NAME: &'static str = "ImapGlareSource";
    const INIT: &'static str = "sizeof(ImapGlareSource)";
    fn defaults() -> Self {
        source_to_c(&GlareSource {
            kind: SourceKind::Light(0),
            direction: [0.0; 3],
            distance_m: 0.0,
            intensity_cd: 0.0,
            projected_area_m2: 0.0,
            luminance_cd_m2: 0.0,
            solid_angle_sr: 0.0,
            position_index: 0.0,
            visible: 0.0,
            ev_lx: 0.0,
            term: 0.0,
            small: false,
        })
    }
}

fn source_to_c(s: &GlareSource) -> ImapGlareSource {
    let (kind, id) = match s.kind {
        SourceKind::Light(i) => (IMAP_GLARE_SOURCE_LIGHT, i),
        SourceKind::Mesh(i) => (IMAP_GLARE_SOURCE_MESH, i),
    };
    ImapGlareSource {
        struct_size: std::mem::size_of::<ImapGlareSource>() as u32,
        kind,
        id,
        small: s.small as u32,
        direction: s.direction,
        distance_m: s.distance_m,
        intensity_cd: s.intensity_cd,
        projected_area_m2: s.projected_area_m2,
        luminance_cd_m2: s.luminance_cd_m2,
        solid_angle_sr: s.solid_angle_sr,
        position_index: s.position_index,
        visible: s.visible,
        ev_lx: s.ev_lx,
        term: s.term,
    }
}

fn glare_to_c(g: &Glare) -> ImapGlare {
    ImapGlare {
        struct_size: 0,
        sources: g.sources.len() as u32,
        ev_lx: g.ev_lx,
        ev_sigma_lx: g.ev_sigma_lx,
        direct_lx: g.direct_lx,
        background_cd_m2: g.background_cd_m2,
        background_sigma_cd_m2: g.background_sigma_cd_m2,
        ugr: g.ugr,
        ugr_sigma: g.ugr_sigma,
        ugr_below_10: g.ugr_below_10 as u32,
        enclosed_by: g.enclosed_by.unwrap_or(IMAP_GLARE_NOT_ENCLOSED),
        dgps: g.dgps,
        dgps_sigma: g.dgps_sigma,
    }
}

fn observer_from_c(o: *const ImapObserver) -> Result<Observer> {
    let o = read_versioned("observer", o)?;
    Ok(Observer {
        eye: o.eye,
        view: o.view,
        up: o.up,
    })
}

/// Fills `*out` (`size` = sizeof(ImapObserver)) with the defaults: eye at the origin,
/// looking along +x, up +z. (Since 0.2.3.)
///
/// # Safety
/// `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_observer_default(out: *mut ImapObserver, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Adds the sensor that measures `observer`'s vertical illuminance Ev: a disk of
/// `radius` (scene units; 0.05 m is a fair size: it averages the light arriving from the
/// scene over that disk) at the eye, facing the view, of five vertices with the eye
/// vertex 0. It changes no light path and no other result. After a run, its front
/// (side 0) vertex 0 holds Ev (`imap_get_vertex_illuminance`) and its relative error
/// (`imap_get_vertex_error`): give them to `imap_observer_glare`. `*out_mesh` receives its
/// mesh id. Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE,
/// IMAP_ERR_INVALID_ARGUMENT (a zero view, an up along it, a radius not positive),
/// IMAP_ERR_PRECISION, and `imap_add_mesh`'s statuses (IMAP_ERR_OUT_OF_ORDER once the
/// map holds photons). (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `observer` an initialised ImapObserver; `out_mesh` writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_observer_sensor(
    ctx: *mut ImapContext,
    observer: *const ImapObserver,
    radius: f64,
    out_mesh: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_mesh, |c| {
        let o = observer_from_c(observer)?;
        c.add_observer_sensor(&o, radius)
    })
}

/// The glare `observer` gets from the context's light sources, given the vertical
/// illuminance at its eye `ev_lx` and its standard error `ev_sigma_lx` (lx; from its
/// sensor, `imap_add_observer_sensor`: the value at vertex 0 and that value times its
/// relative error). For every luminaire, point, spot and cosine light and emitting mesh in
/// front of the eye, the call computes its intensity toward the eye (the candela table
/// and the flux it was placed with), the luminous area it shows (the file's opening:
/// rectangle, disk, box, cylinder or sphere; an emitting mesh's triangles, each seen at
/// its centre after splitting to 0.002 sr), the share of that area the eye sees (lines
/// of sight through the scene: anything that is not a sensor blocks them, glass
/// included), Guth's position index and its direct illuminance at the eye. Skies, the sun
/// and beams are not sources here (their light is in Ev and so in the background).
/// Writes the observer's figures to `*out` (`out_size` = sizeof(ImapGlare)) and up to
/// `capacity` sources, largest UGR term first, to `sources` (elements of `element_size`
/// = sizeof(ImapGlareSource); NULL when `capacity` is 0), and their count to
/// `*out_count` (NULL: not wanted). Builds the scene's BVH if no run has.
///
/// `out->enclosed_by` names a one-sided mesh whose back faces surround the eye (inside a
/// solid, or in a room drawn with its normals out): tell the user.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (a zero
/// view, an up along it, a negative Ev or σ, sizes),
/// IMAP_ERR_NO_GEOMETRY (no mesh), IMAP_ERR_BUSY. (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `observer` an initialised ImapObserver; `out` points to
/// `out_size` writable bytes; `sources` to `capacity × element_size` writable bytes;
/// `out_count` NULL or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn imap_observer_glare(
    ctx: *mut ImapContext,
    observer: *const ImapObserver,
    ev_lx: f64,
    ev_sigma_lx: f64,
    out: *mut ImapGlare,
    out_size: usize,
    sources: *mut ImapGlareSource,
    capacity: usize,
    element_size: usize,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let o = observer_from_c(observer)?;
        check_out("out", out)?;
        super::check_elements("sources", sources, capacity, element_size)?;
        let g = c.observer_glare(&o, ev_lx, ev_sigma_lx)?;
        write_versioned("out", out, out_size, glare_to_c(&g))?;
        for (i, s) in g.sources.iter().take(capacity).enumerate() {
            // SAFETY: the caller provides capacity × element_size writable bytes.
            let dst = unsafe { (sources as *mut u8).add(i * element_size) } as *mut ImapGlareSource;
            write_versioned("sources", dst, element_size, source_to_c(s))?;
        }
        if !out_count.is_null() {
            write_out("out_count", out_count, g.sources.len())?;
        }
        Ok(())
    })
}

/// The vertical illuminance an observer's sensor read at the eye and its standard error,
/// lx (vertex 0 of mesh `mesh`, front side: `imap_add_observer_sensor`), into `*out_ev_lx`
/// and `*out_sigma_lx` (NULL: not wanted). Returns IMAP_ERR_INDEX_OUT_OF_RANGE (no such
/// mesh), IMAP_ERR_INVALID_ARGUMENT (a mesh that records nothing), IMAP_ERR_NULL_POINTER.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `out_ev_lx` writable; `out_sigma_lx` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_observer_ev(
    ctx: *const ImapContext,
    mesh: u32,
    out_ev_lx: *mut f64,
    out_sigma_lx: *mut f64,
) -> ImapStatus {
    with_context(ctx, |c| {
        check_out("out_ev_lx", out_ev_lx)?;
        let (ev, sigma) = c.observer_ev(mesh)?;
        write_out("out_ev_lx", out_ev_lx, ev)?;
        super::write_optional(out_sigma_lx, sigma)
    })
}

/// The α-opic light at an observer's eye (CIE S 026/E:2018; `imap_get_observer_alpha_opic`),
/// each array in the standard's order: S-cone, M-cone, L-cone, rhodopic, melanopic.
/// (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapAlphaOpic {
    pub struct_size: u32,
    pub reserved: u32,
    /// α-opic irradiance, W/m².
    pub irradiance_w_m2: [f64; 5],
    /// α-opic equivalent daylight (D65) illuminance, lx: the irradiance over the
    /// standard's K_α,v^D65 (0.8173, 1.4558, 1.6289, 1.4497, 1.3262 mW/lm). Melanopic EDI
    /// is `edi_lx[4]`.
    pub edi_lx: [f64; 5],
    /// Their standard errors, lx.
    pub edi_sigma_lx: [f64; 5],
    /// The melanopic daylight (D65) efficacy ratio: melanopic EDI over the illuminance.
    pub melanopic_der: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapAlphaOpic {
    const NAME: &'static str = "ImapAlphaOpic";
    const INIT: &'static str = "sizeof(ImapAlphaOpic)";
    fn defaults() -> Self {
        ImapAlphaOpic {
            struct_size: std::mem::size_of::<Self>() as u32,
            reserved: 0,
            irradiance_w_m2: [0.0; 5],
            edi_lx: [0.0; 5],
            edi_sigma_lx: [0.0; 5],
            melanopic_der: 0.0,
        }
    }
}

/// The α-opic irradiances and equivalent daylight illuminances (melanopic EDI among them)
/// at an observer's eye, with errors, from its sensor's bands (vertex 0 of mesh `mesh`,
/// front side; each band's power spread evenly over its interval, against the CIE S 026
/// action spectra at 1 nm), into `*out` (`size` = sizeof(ImapAlphaOpic)). The errors are
/// the band-mean irradiance's relative error times each value (exact when one spectrum
/// reaches the eye). Returns IMAP_ERR_UNSUPPORTED in an RGB context (its bands carry no
/// wavelengths: create the context with spectral bands), IMAP_ERR_INDEX_OUT_OF_RANGE,
/// IMAP_ERR_INVALID_ARGUMENT, IMAP_ERR_NULL_POINTER. (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_get_observer_alpha_opic(
    ctx: *const ImapContext,
    mesh: u32,
    out: *mut ImapAlphaOpic,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        check_out("out", out)?;
        let a = c.observer_alpha_opic(mesh)?;
        write_versioned(
            "out",
            out,
            size,
            ImapAlphaOpic {
                struct_size: 0,
                reserved: 0,
                irradiance_w_m2: a.irradiance_w_m2,
                edi_lx: a.edi_lx,
                edi_sigma_lx: a.edi_sigma_lx,
                melanopic_der: a.melanopic_der,
            },
        )
    })
}

/// `imap_ugr_table`'s file formats.
pub const IMAP_PHOTOMETRY_FILE_IES: u32 = 0;
/// EULUMDAT (.ldt).
pub const IMAP_PHOTOMETRY_FILE_LDT: u32 = 1;

/// The CIE 190:2010 UGR table of a luminaire file (`text`, `len` bytes; `format` an
/// `IMAP_PHOTOMETRY_FILE_*`): the UGR of an array of the luminaire at a spacing of 0.25 H
/// (H = 2 m above the eye) in the 19 standard rooms (2H × 2H … 12H × 8H, X across the line
/// of sight first), for the five reflectance combinations (ceiling/walls/floor 0.7/0.5/0.2,
/// 0.7/0.3/0.2, 0.5/0.5/0.2, 0.5/0.3/0.2, 0.3/0.3/0.2), crosswise then endwise. Into
/// `out`, 190 doubles, room by room: the room's 5 crosswise values, then its 5 endwise
/// ones; NaN where no luminaire counts. The background is CIE 190's, from the luminaire's
/// flux (EULUMDAT: its light output ratio times its first lamp set's flux; IES: the
/// table's own). docs/glare.md gives the method. Thread-safe; no context. Returns
/// IMAP_ERR_PARSE (with the line), IMAP_ERR_INVALID_ARGUMENT (no luminous area: the
/// luminance needs one; an unknown format), IMAP_ERR_UNSUPPORTED (type B), IMAP_ERR_NO_LIGHT,
/// IMAP_ERR_NULL_POINTER, IMAP_ERR_BUFFER_TOO_SMALL (`count` < 190). (Since 0.2.3.)
///
/// # Safety
/// `text` points to `len` readable bytes; `out` to `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_ugr_table(
    text: *const std::ffi::c_char,
    len: usize,
    format: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    boundary(None, || {
        let text = super::light::text_from_c("text", text, len)?;
        let out = super::slice_mut("out", out, count)?;
        if out.len() < 190 {
            bail!(
                ImapErrBufferTooSmall,
                "out holds {count} doubles; a UGR table is 190 (19 rooms × 10)"
            );
        }
        let t = match format {
            IMAP_PHOTOMETRY_FILE_IES => crate::photometry::ugr_table::ugr_table_ies(&text)?,
            IMAP_PHOTOMETRY_FILE_LDT => crate::photometry::ugr_table::ugr_table_ldt(&text)?,
            _ => bail!(
                ImapErrInvalidArgument,
                "format = {format} is not an IMAP_PHOTOMETRY_FILE_* value (0 IES, 1 EULUMDAT)"
            ),
        };
        for room in 0..19 {
            out[10 * room..10 * room + 5].copy_from_slice(&t.crosswise[room]);
            out[10 * room + 5..10 * room + 10].copy_from_slice(&t.endwise[room]);
        }
        Ok(())
    })
}

/// How `imap_picture_glare` finds glare sources, evalglare's rules. Initialise with
/// `imap_glare_rules_default(&r, sizeof r)`: evalglare's defaults. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapGlareRules {
    pub struct_size: u32,
    /// 1: Wienold's (2009) low-light correction below Ev = 1000 lx (evalglare's `-C l+`;
    /// default 0, as evalglare since 2.14).
    pub low_light: u32,
    /// Above 100: the luminance (cd/m²) above which a pixel belongs to a glare source
    /// (evalglare's `-b`; default 2000). 100 or less: that multiple of the picture's mean
    /// luminance over the front hemisphere.
    pub threshold: f64,
    /// Glare pixels closer than half this angle (radians) join one source (evalglare's
    /// `-r`; default 0.2; at most 1).
    pub search_angle_rad: f64,
    /// Pixels at or above this luminance (cd/m²) become sources of their own (evalglare's
    /// peak extraction; default 50 000; 0: none).
    pub peak_cd_m2: f64,
}

fn rules_to_c(r: &SourceRules) -> ImapGlareRules {
    ImapGlareRules {
        struct_size: std::mem::size_of::<ImapGlareRules>() as u32,
        low_light: r.low_light as u32,
        threshold: r.threshold,
        search_angle_rad: r.search_angle_rad,
        peak_cd_m2: r.peak_cd_m2,
    }
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapGlareRules {
    const NAME: &'static str = "ImapGlareRules";
    const INIT: &'static str = "imap_glare_rules_default";
    fn defaults() -> Self {
        rules_to_c(&SourceRules::default())
    }
}

/// Fills `*out` (`size` = sizeof(ImapGlareRules)) with evalglare's default rules.
/// (Since 0.2.3.)
///
/// # Safety
/// `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_glare_rules_default(
    out: *mut ImapGlareRules,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// A fisheye picture's daylight glare probability (`imap_picture_glare`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapPictureGlare {
    pub struct_size: u32,
    /// The glare sources found.
    pub sources: u32,
    /// The vertical illuminance at the eye from the picture (Σ L ω cos θ over its front
    /// hemisphere) and its standard error, lx.
    pub ev_lx: f64,
    pub ev_sigma_lx: f64,
    /// DGP = 5.87·10⁻⁵ Ev + 9.18·10⁻² log10(1 + Σ L² ω / (Ev^1.87 P²)) + 0.16 (Wienold &
    /// Christoffersen 2006), at most 1, and its standard error (first order, from the
    /// pixels' errors taken as independent, the sources as found).
    pub dgp: f64,
    pub dgp_sigma: f64,
    /// The luminance a glare pixel exceeds, cd/m².
    pub threshold_cd_m2: f64,
    /// The picture's mean luminance over the front hemisphere, cd/m².
    pub mean_luminance_cd_m2: f64,
    /// (Ev − what the sources give) / π, cd/m².
    pub background_cd_m2: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapPictureGlare {
    const NAME: &'static str = "ImapPictureGlare";
    const INIT: &'static str = "sizeof(ImapPictureGlare)";
    fn defaults() -> Self {
        ImapPictureGlare {
            struct_size: std::mem::size_of::<Self>() as u32,
            sources: 0,
            ev_lx: 0.0,
            ev_sigma_lx: 0.0,
            dgp: 0.0,
            dgp_sigma: 0.0,
            threshold_cd_m2: 0.0,
            mean_luminance_cd_m2: 0.0,
            background_cd_m2: 0.0,
        }
    }
}

/// A glare source found in a picture (`imap_picture_glare`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapPictureSource {
    pub struct_size: u32,
    /// Its pixels.
    pub pixels: u32,
    /// From the eye toward its centre (unit, scene axes).
    pub direction: [f64; 3],
    /// Its centre on the picture, pixels from the top left (x right, y down): the L·ω
    /// weighted mean of its pixels' centres.
    pub centre_px: [f64; 2],
    pub solid_angle_sr: f64,
    /// Its mean luminance, cd/m².
    pub luminance_cd_m2: f64,
    /// Guth's position index at its centre.
    pub position_index: f64,
    /// What it gives the eye, lx.
    pub ev_lx: f64,
    /// Its DGP term L² ω / P².
    pub term: f64,
}

fn picture_source_to_c(s: &PictureSource) -> ImapPictureSource {
    ImapPictureSource {
        struct_size: std::mem::size_of::<ImapPictureSource>() as u32,
        pixels: s.pixels,
        direction: s.direction,
        centre_px: s.centre_px,
        solid_angle_sr: s.solid_angle_sr,
        luminance_cd_m2: s.luminance_cd_m2,
        position_index: s.position_index,
        ev_lx: s.ev_lx,
        term: s.term,
    }
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapPictureSource {
    const NAME: &'static str = "ImapPictureSource";
    const INIT: &'static str = "sizeof(ImapPictureSource)";
    fn defaults() -> Self {
        let mut s = picture_source_to_c(&PictureSource {
            direction: [0.0; 3],
            centre_px: [0.0; 2],
            solid_angle_sr: 0.0,
            luminance_cd_m2: 0.0,
            position_index: 0.0,
            ev_lx: 0.0,
            pixels: 0,
            term: 0.0,
        });
        s.struct_size = std::mem::size_of::<Self>() as u32;
        s
    }
}

/// The daylight glare probability of a fisheye picture that `camera` saw (an
/// `IMAP_PROJECTION_ANGULAR_FISHEYE` or `_HEMISPHERICAL` camera of at least 180° across
/// and up), with its glare sources found by `rules` (NULL: evalglare's defaults).
/// `radiance` holds `radiance_count` = width × height × bands doubles as `imap_render`
/// writes them (each pixel's luminance from its bands by this context's photometry);
/// `rel_error` (NULL: no errors) its `width × height` relative errors. Writes the result
/// to `*out` (`out_size` = sizeof(ImapPictureGlare)), up to `capacity` sources, largest
/// term first, to `sources` (elements of `element_size` = sizeof(ImapPictureSource);
/// NULL when `capacity` is 0), and, when `labels` is not NULL, `width × height` source
/// labels (0: none; k: `sources[k − 1]`; `labels_count` at least that).
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (a
/// picture that is not a fisheye of the whole front hemisphere; pixels coarser than half
/// the search angle, with the size that would do; a negative luminance or error; rules out
/// of range; the message names the argument), IMAP_ERR_BUFFER_TOO_SMALL. (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `camera` an initialised ImapCamera; `rules` NULL or an
/// initialised ImapGlareRules; `radiance` holds `radiance_count` doubles; `rel_error` is
/// NULL or holds width × height doubles; `out` points to `out_size` writable bytes;
/// `sources` to `capacity × element_size` writable bytes; `labels` is NULL or holds
/// `labels_count` writable uint32_t.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn imap_picture_glare(
    ctx: *const ImapContext,
    camera: *const super::render::ImapCamera,
    radiance: *const f64,
    radiance_count: usize,
    rel_error: *const f64,
    rules: *const ImapGlareRules,
    out: *mut ImapPictureGlare,
    out_size: usize,
    sources: *mut ImapPictureSource,
    capacity: usize,
    element_size: usize,
    labels: *mut u32,
    labels_count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let cam = super::render::camera_from_c(&read_versioned("camera", camera)?)?;
        let r = if rules.is_null() {
            SourceRules::default()
        } else {
            let r = read_versioned("rules", rules)?;
            if r.low_light > 1 {
                bail!(
                    ImapErrInvalidArgument,
                    "rules.low_light = {} is not 0 or 1",
                    r.low_light
                );
            }
            SourceRules {
                threshold: r.threshold,
                search_angle_rad: r.search_angle_rad,
                peak_cd_m2: r.peak_cd_m2,
                low_light: r.low_light == 1,
            }
        };
        check_out("out", out)?;
        super::check_elements("sources", sources, capacity, element_size)?;
        let pixels = cam.width as usize * cam.height as usize;
        let bands = c.scene().bands.count();
        let want = pixels * bands;
        if radiance_count != want {
            bail!(
                ImapErrInvalidArgument,
                "radiance_count {radiance_count} is not width {} × height {} × {bands} bands = {want}",
                cam.width,
                cam.height
            );
        }
        if !labels.is_null() && labels_count < pixels {
            bail!(
                ImapErrBufferTooSmall,
                "labels_count {labels_count} < {pixels} (width {} × height {})",
                cam.width,
                cam.height
            );
        }
        let rad = super::slice("radiance", radiance, radiance_count)?;
        if let Some(i) = rad.iter().position(|v| !v.is_finite()) {
            bail!(ImapErrNonFinite, "radiance[{i}] = {} is not finite", rad[i]);
        }
        let rel = if rel_error.is_null() {
            None
        } else {
            Some(super::slice("rel_error", rel_error, pixels)?)
        };
        let g = c.picture_glare_of_bands(&cam, rad, bands, rel, &r)?;
        write_versioned(
            "out",
            out,
            out_size,
            ImapPictureGlare {
                struct_size: std::mem::size_of::<ImapPictureGlare>() as u32,
                sources: g.sources.len() as u32,
                ev_lx: g.ev_lx,
                ev_sigma_lx: g.ev_sigma_lx,
                dgp: g.dgp,
                dgp_sigma: g.dgp_sigma,
                threshold_cd_m2: g.threshold_cd_m2,
                mean_luminance_cd_m2: g.mean_luminance_cd_m2,
                background_cd_m2: g.background_cd_m2,
            },
        )?;
        for (i, s) in g.sources.iter().take(capacity).enumerate() {
            // SAFETY: the caller provides capacity × element_size writable bytes.
            let dst =
                unsafe { (sources as *mut u8).add(i * element_size) } as *mut ImapPictureSource;
            write_versioned("sources", dst, element_size, picture_source_to_c(s))?;
        }
        if !labels.is_null() {
            super::slice_mut("labels", labels, pixels)?.copy_from_slice(&g.labels);
        }
        Ok(())
    })
}
