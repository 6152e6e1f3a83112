//! Lights and photometry: lights given in lumens, candela, watts, lux or W/m² with a
//! spectrum; goniometric luminaires from IES LM-63 and EULUMDAT text or from a table;
//! illuminance (lux) and colour (XYZ, chromaticity, CCT) read-outs; the power balance per
//! band. docs/photometry.md states every convention.

use super::scene::add_with;
use super::{
    boundary, copy_bands, read_versioned, slice, with_context, write_defaults, write_optional,
    ImapContext, Versioned,
};
use crate::error::{bail, Error, ImapStatus, Result};
use crate::photometry::{Opening, PhotometricData, PhotometricType, Spectrum, Symmetry};
use crate::scene::light::{Amount, LightDesc, LightKind, Placement};

/// `ImapLight::kind`: isotropic point source.
pub const IMAP_LIGHT_POINT: u32 = 0;
/// `ImapLight::kind`: uniform intensity inside a cone (`half_angle_rad`) around `direction`.
pub const IMAP_LIGHT_SPOT: u32 = 1;
/// `ImapLight::kind`: I = I0 cos γ into the hemisphere around `direction` (a Lambertian
/// point source, as in CIE 171:2006 test case 5.2).
pub const IMAP_LIGHT_COSINE: u32 = 2;
/// `ImapLight::kind`: a collimated beam along `direction` leaving an aperture (disk or
/// rectangle) centred on `position`.
pub const IMAP_LIGHT_BEAM: u32 = 3;

/// `ImapLight::unit`: `band_power` holds the radiant flux per band, W (1 value or one per
/// band); the spectrum must be left at EQUAL.
pub const IMAP_UNIT_W_PER_BAND: u32 = 0;
/// `ImapLight::unit`: `amount` is the radiant flux over all bands, W.
pub const IMAP_UNIT_W: u32 = 1;
/// `ImapLight::unit`: `amount` is the luminous flux, lm.
pub const IMAP_UNIT_LM: u32 = 2;
/// `ImapLight::unit`: `amount` is the luminous intensity, cd (point and spot: in every
/// direction they light; cosine: along the axis).
pub const IMAP_UNIT_CD: u32 = 3;
/// `ImapLight::unit`: `amount` is the radiant intensity over all bands, W/sr.
pub const IMAP_UNIT_W_PER_SR: u32 = 4;
/// `ImapLight::unit`: `amount` is a beam's illuminance on a plane perpendicular to it, lx.
pub const IMAP_UNIT_LX: u32 = 5;
/// `ImapLight::unit`: `amount` is a beam's irradiance on a plane perpendicular to it, W/m².
pub const IMAP_UNIT_W_PER_M2: u32 = 6;

/// `ImapLight::aperture`: a disk of diameter `aperture_size[0]`.
pub const IMAP_APERTURE_DISK: u32 = 0;
/// `ImapLight::aperture`: a rectangle, `aperture_size[0]` along `aperture_up` (projected
/// onto the aperture's plane), `aperture_size[1]` across.
pub const IMAP_APERTURE_RECTANGLE: u32 = 1;

/// `ImapSpectrum::kind`: the same power per nm (spectral contexts) or R = G = B (RGB
/// contexts: D65 white).
pub const IMAP_SPECTRUM_EQUAL: u32 = 0;
/// `ImapSpectrum::kind`: a linear Rec. 709 colour `rgb`.
pub const IMAP_SPECTRUM_RGB: u32 = 1;
/// `ImapSpectrum::kind`: Planck's law at `cct_k` kelvin.
pub const IMAP_SPECTRUM_BLACKBODY: u32 = 2;
/// `ImapSpectrum::kind`: CIE standard illuminant A.
pub const IMAP_SPECTRUM_CIE_A: u32 = 3;
/// `ImapSpectrum::kind`: CIE standard illuminant D65.
pub const IMAP_SPECTRUM_CIE_D65: u32 = 4;
/// `ImapSpectrum::kind`: a table of relative power per nm at `table_nm`, linear between,
/// 0 outside.
pub const IMAP_SPECTRUM_TABLE: u32 = 5;
/// `ImapSpectrum::kind`: relative power per band, `band_values` (one per band).
pub const IMAP_SPECTRUM_BANDS: u32 = 6;

/// `ImapPhotometry::type`: type C (vertical angle γ from the nadir, C planes around it).
pub const IMAP_PHOTOMETRY_C: u32 = 1;
/// `ImapPhotometry::type`: type B (planes around the luminaire's lateral axis).
pub const IMAP_PHOTOMETRY_B: u32 = 2;

/// `ImapPhotometry::opening`: a point source.
pub const IMAP_OPENING_POINT: u32 = 0;
/// `ImapPhotometry::opening`: a rectangle `opening_width` × `opening_length` m.
pub const IMAP_OPENING_RECTANGLE: u32 = 1;
/// `ImapPhotometry::opening`: an ellipse (a disk when equal) of those diameters, m.
pub const IMAP_OPENING_ELLIPSE: u32 = 2;

/// A light's colour. Initialise with `imap_spectrum_default(&s, sizeof s)` (EQUAL). The
/// library copies the arrays. NULL where a spectrum is asked for means EQUAL.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapSpectrum {
    pub struct_size: u32,
    /// `IMAP_SPECTRUM_*`.
    pub kind: u32,
    /// RGB: linear Rec. 709 colour, non-negative, not all 0.
    pub rgb: [f64; 3],
    /// BLACKBODY: temperature, K, in [100, 1e6].
    pub cct_k: f64,
    /// TABLE: increasing wavelengths (nm) and relative power per nm, `table_count` each.
    pub table_nm: *const f64,
    pub table_values: *const f64,
    pub table_count: usize,
    /// BANDS: one relative power per band.
    pub band_values: *const f64,
    pub band_count: usize,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapSpectrum {
    const NAME: &'static str = "ImapSpectrum";
    const INIT: &'static str = "imap_spectrum_default";
    fn defaults() -> Self {
        ImapSpectrum {
            struct_size: std::mem::size_of::<Self>() as u32,
            kind: IMAP_SPECTRUM_EQUAL,
            rgb: [1.0; 3],
            cct_k: 0.0,
            table_nm: std::ptr::null(),
            table_values: std::ptr::null(),
            table_count: 0,
            band_values: std::ptr::null(),
            band_count: 0,
        }
    }
}

/// A point, spot, cosine or beam light. Initialise with `imap_light_default(&l, sizeof l)`
/// (a point light at the origin in lumens, amount 0: set it).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapLight {
    pub struct_size: u32,
    /// `IMAP_LIGHT_*`.
    pub kind: u32,
    /// Scene units (a beam: the aperture's centre).
    pub position: [f64; 3],
    /// Spot, cosine and beam: the axis (any length but 0). Default (0, 0, −1).
    pub direction: [f64; 3],
    /// Spot: the cone's half-angle, (0, π].
    pub half_angle_rad: f64,
    /// Beam: `IMAP_APERTURE_*`.
    pub aperture: u32,
    /// `IMAP_UNIT_*` of `amount` (or of `band_power` for `IMAP_UNIT_W_PER_BAND`).
    pub unit: u32,
    /// Beam: diameter, or width and height, scene units.
    pub aperture_size: [f64; 2],
    /// Beam with a rectangular aperture: the direction of `aperture_size[0]`. Default
    /// (0, 0, 1).
    pub aperture_up: [f64; 3],
    /// How much light, in `unit`.
    pub amount: f64,
    /// `IMAP_UNIT_W_PER_BAND`: W per band, 1 value or one per band.
    pub band_power: *const f64,
    pub band_power_count: usize,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapLight {
    const NAME: &'static str = "ImapLight";
    const INIT: &'static str = "imap_light_default";
    fn defaults() -> Self {
        ImapLight {
            struct_size: std::mem::size_of::<Self>() as u32,
            kind: IMAP_LIGHT_POINT,
            position: [0.0; 3],
            direction: [0.0, 0.0, -1.0],
            half_angle_rad: 0.0,
            aperture: IMAP_APERTURE_DISK,
            unit: IMAP_UNIT_LM,
            aperture_size: [0.0; 2],
            aperture_up: [0.0, 0.0, 1.0],
            amount: 0.0,
            band_power: std::ptr::null(),
            band_power_count: 0,
        }
    }
}

/// Where and how a goniometric luminaire is placed. Initialise with
/// `imap_luminaire_default(&p, sizeof p)`: at the origin, aimed down −z with C0 along +x,
/// the world's up +z, the file's flux, emitting from a point.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapLuminaire {
    pub struct_size: u32,
    /// 1: emit from the file's luminous opening (rectangle or disk, in its plane
    /// perpendicular to `aim`) instead of a point.
    pub use_opening: u32,
    /// Photometric centre, scene units.
    pub position: [f64; 3],
    /// The photometric axis: type C the luminaire's nadir (γ = 0); type B its aim (V = H =
    /// 0).
    pub aim: [f64; 3],
    /// Type C: the C0 direction; type B: the luminaire's up (V = 90°). Its part along
    /// `aim` is ignored; it must not be parallel to `aim`.
    pub reference: [f64; 3],
    /// The world's up, for TILT: the tilt angle is the angle between `aim` and −`up`.
    pub up: [f64; 3],
    /// Multiplies the intensities (number of luminaires in one place, maintenance,
    /// dimming). Default 1.
    pub flux_scale: f64,
    /// When > 0: the luminaire's total luminous flux, lm, replacing the file's (its shape
    /// kept). Default 0.
    pub lumens: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapLuminaire {
    const NAME: &'static str = "ImapLuminaire";
    const INIT: &'static str = "imap_luminaire_default";
    fn defaults() -> Self {
        let p = Placement::default();
        ImapLuminaire {
            struct_size: std::mem::size_of::<Self>() as u32,
            use_opening: 0,
            position: p.position,
            aim: p.aim,
            reference: p.reference,
            up: p.up,
            flux_scale: p.flux_scale,
            lumens: p.lumens,
        }
    }
}

/// A photometric table from a host's own parser. Initialise with
/// `imap_photometry_default(&t, sizeof t)` (type C, point opening, no TILT). The symmetry
/// follows from the horizontal angles as in LM-63: one angle (rotational), 0–90 (four
/// quadrants), 0–180, 90–270, 0 to more than 180 (none); type B: 0–90 (lateral) or −90–90.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapPhotometry {
    pub struct_size: u32,
    /// `IMAP_PHOTOMETRY_C` or `IMAP_PHOTOMETRY_B`.
    pub photometric_type: u32,
    /// Increasing vertical angles, degrees (type C: γ in 0–180; type B: V in −90–90).
    pub vertical: *const f64,
    pub vertical_count: usize,
    /// Increasing horizontal angles, degrees (type C: C in 0–360; type B: H in −90–90).
    pub horizontal: *const f64,
    pub horizontal_count: usize,
    /// Candela, one row of `vertical_count` values per horizontal angle.
    pub candela: *const f64,
    /// Multiplies every candela value. Default 1.
    pub multiplier: f64,
    /// Optional TILT table: increasing angles (degrees) and factors, `tilt_count` each.
    pub tilt_angles: *const f64,
    pub tilt_factors: *const f64,
    pub tilt_count: usize,
    /// `IMAP_OPENING_*`, with its width (across C0–C180) and length (along it), metres.
    pub opening: u32,
    pub opening_width: f64,
    pub opening_length: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapPhotometry {
    const NAME: &'static str = "ImapPhotometry";
    const INIT: &'static str = "imap_photometry_default";
    fn defaults() -> Self {
        ImapPhotometry {
            struct_size: std::mem::size_of::<Self>() as u32,
            photometric_type: IMAP_PHOTOMETRY_C,
            vertical: std::ptr::null(),
            vertical_count: 0,
            horizontal: std::ptr::null(),
            horizontal_count: 0,
            candela: std::ptr::null(),
            multiplier: 1.0,
            tilt_angles: std::ptr::null(),
            tilt_factors: std::ptr::null(),
            tilt_count: 0,
            opening: IMAP_OPENING_POINT,
            opening_width: 0.0,
            opening_length: 0.0,
        }
    }
}

/// Fills `size` bytes at `out` with an EQUAL spectrum; sets `struct_size = size`.
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (size). Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_spectrum_default(out: *mut ImapSpectrum, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills `size` bytes at `out` with a light's defaults (see `ImapLight`).
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_light_default(out: *mut ImapLight, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills `size` bytes at `out` with a luminaire placement's defaults (see
/// `ImapLuminaire`).
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_luminaire_default(
    out: *mut ImapLuminaire,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills `size` bytes at `out` with an empty photometric table's defaults (see
/// `ImapPhotometry`).
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_photometry_default(
    out: *mut ImapPhotometry,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

pub(super) fn spectrum_from_c(s: *const ImapSpectrum) -> Result<Spectrum> {
    if s.is_null() {
        return Ok(Spectrum::Equal);
    }
    let s = read_versioned("spectrum", s)?;
    Ok(match s.kind {
        IMAP_SPECTRUM_EQUAL => Spectrum::Equal,
        IMAP_SPECTRUM_RGB => Spectrum::Rgb(s.rgb),
        IMAP_SPECTRUM_BLACKBODY => Spectrum::Blackbody(s.cct_k),
        IMAP_SPECTRUM_CIE_A => Spectrum::CieA,
        IMAP_SPECTRUM_CIE_D65 => Spectrum::CieD65,
        IMAP_SPECTRUM_TABLE => {
            let nm = slice("spectrum.table_nm", s.table_nm, s.table_count)?;
            let v = slice("spectrum.table_values", s.table_values, s.table_count)?;
            Spectrum::Table(nm.iter().copied().zip(v.iter().copied()).collect())
        }
        IMAP_SPECTRUM_BANDS => {
            Spectrum::Bands(slice("spectrum.band_values", s.band_values, s.band_count)?.to_vec())
        }
        k => bail!(
            ImapErrInvalidArgument,
            "spectrum.kind = {k} is not an IMAP_SPECTRUM_* value (0–6)"
        ),
    })
}

fn placement_from_c(p: *const ImapLuminaire) -> Result<Placement> {
    let p = read_versioned("placement", p)?;
    if p.use_opening > 1 {
        bail!(
            ImapErrInvalidArgument,
            "placement.use_opening = {} must be 0 or 1",
            p.use_opening
        );
    }
    Ok(Placement {
        position: p.position,
        aim: p.aim,
        reference: p.reference,
        up: p.up,
        flux_scale: p.flux_scale,
        lumens: p.lumens,
        use_opening: p.use_opening == 1,
    })
}

/// The text of a file passed as a buffer: any bytes (Latin-1 and UTF-8 alike: the
/// formats' numbers are ASCII).
pub(super) fn text_from_c<'a>(
    name: &str,
    ptr: *const std::ffi::c_char,
    len: usize,
) -> Result<std::borrow::Cow<'a, str>> {
    if len == 0 {
        bail!(ImapErrParse, "{name} is empty");
    }
    let bytes = slice(name, ptr as *const u8, len)?;
    Ok(String::from_utf8_lossy(bytes))
}

/// Adds a point, spot, cosine or beam light with its amount in any `IMAP_UNIT_*` and a
/// spectrum (NULL: EQUAL); `*out_id` receives its id (lights and luminaires share ids).
/// Lumens and candela become band powers through the bands' luminous efficacies
/// (docs/photometry.md): the light then emits exactly that luminous flux.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (naming
/// the field: an unknown kind or unit, a unit the kind cannot take, a zero direction, an
/// amount ≤ 0, a spectrum with no power in the bands), IMAP_ERR_PRECISION, IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `light` points to an initialised `ImapLight` whose arrays hold
/// their counts; `spectrum` is NULL or likewise; `out_id` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_light(
    ctx: *mut ImapContext,
    light: *const ImapLight,
    spectrum: *const ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let l = read_versioned("light", light)?;
        let spectrum = spectrum_from_c(spectrum)?;
        let kind = match l.kind {
            IMAP_LIGHT_POINT => LightKind::Point,
            IMAP_LIGHT_SPOT => LightKind::Spot {
                direction: l.direction,
                half_angle_rad: l.half_angle_rad,
            },
            IMAP_LIGHT_COSINE => LightKind::Cosine {
                direction: l.direction,
            },
            IMAP_LIGHT_BEAM => LightKind::Beam {
                direction: l.direction,
                disk: match l.aperture {
                    IMAP_APERTURE_DISK => true,
                    IMAP_APERTURE_RECTANGLE => false,
                    a => bail!(
                        ImapErrInvalidArgument,
                        "light.aperture = {a} is not an IMAP_APERTURE_* value (0, 1)"
                    ),
                },
                size: l.aperture_size,
                up: l.aperture_up,
            },
            k => bail!(
                ImapErrInvalidArgument,
                "light.kind = {k} is not an IMAP_LIGHT_* value (0–3)"
            ),
        };
        let x = l.amount;
        let amount = match l.unit {
            IMAP_UNIT_W_PER_BAND => Amount::WattsPerBand(
                slice("light.band_power", l.band_power, l.band_power_count)?.to_vec(),
            ),
            IMAP_UNIT_W => Amount::Watts(x),
            IMAP_UNIT_LM => Amount::Lumens(x),
            IMAP_UNIT_CD => Amount::Candela(x),
            IMAP_UNIT_W_PER_SR => Amount::WattsPerSr(x),
            IMAP_UNIT_LX => Amount::Lux(x),
            IMAP_UNIT_W_PER_M2 => Amount::WattsPerM2(x),
            u => bail!(
                ImapErrInvalidArgument,
                "light.unit = {u} is not an IMAP_UNIT_* value (0–6)"
            ),
        };
        c.add_light_desc(&LightDesc {
            kind,
            position: l.position,
            amount,
            spectrum,
        })
    })
}

/// Adds a goniometric luminaire from the text of an IES LM-63 file (1986, 1991, 1995,
/// 2002 or 2019; photometric types C and B), `len` bytes (no terminator needed). When the
/// file says `TILT=<file>`, pass that file's text as `tilt_text` (else NULL, 0). The
/// luminaire emits the table's flux × multiplier × ballast factor (× ballast-lamp factor
/// for 1986/1991 files) × `flux_scale` × the TILT factor of its placement, or
/// `placement.lumens`, in `spectrum` (NULL: EQUAL).
///
/// Returns IMAP_ERR_PARSE (the message names the line and the problem), IMAP_ERR_UNSUPPORTED
/// (photometric type A; emission from a three-dimensional opening), IMAP_ERR_NO_LIGHT (a
/// table of zeros), and as `imap_add_light`. The context is unchanged on any error.
///
/// # Safety
/// `ctx` is a live handle; `text` holds `len` readable bytes, `tilt_text` `tilt_len` (or is
/// NULL with 0); `placement` points to an initialised `ImapLuminaire`; `spectrum` is NULL
/// or initialised; `out_id` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_luminaire_ies(
    ctx: *mut ImapContext,
    text: *const std::ffi::c_char,
    len: usize,
    tilt_text: *const std::ffi::c_char,
    tilt_len: usize,
    placement: *const ImapLuminaire,
    spectrum: *const ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let text = text_from_c("text", text, len)?;
        let tilt = if tilt_len == 0 {
            None
        } else {
            Some(text_from_c("tilt_text", tilt_text, tilt_len)?)
        };
        let place = placement_from_c(placement)?;
        let spectrum = spectrum_from_c(spectrum)?;
        c.add_luminaire_ies(&text, tilt.as_deref(), &place, &spectrum)
    })
}

/// Adds a goniometric luminaire from the text of a EULUMDAT (.ldt) file, `len` bytes. Its
/// intensities (cd/klm) are scaled by the first lamp set's flux / 1000 and the conversion
/// factor. Otherwise as `imap_add_luminaire_ies`.
///
/// # Safety
/// As `imap_add_luminaire_ies`.
#[no_mangle]
pub unsafe extern "C" fn imap_add_luminaire_ldt(
    ctx: *mut ImapContext,
    text: *const std::ffi::c_char,
    len: usize,
    placement: *const ImapLuminaire,
    spectrum: *const ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let text = text_from_c("text", text, len)?;
        let place = placement_from_c(placement)?;
        let spectrum = spectrum_from_c(spectrum)?;
        c.add_luminaire_ldt(&text, &place, &spectrum)
    })
}

/// Adds a goniometric luminaire from a table of angles and candela (for hosts with their
/// own parsers). The table is interpolated and sampled exactly as a file's. Returns
/// IMAP_ERR_PARSE for an inconsistent table (counts, angles out of range or not
/// increasing, negative or non-finite candela), and as `imap_add_luminaire_ies`.
///
/// # Safety
/// `table` points to an initialised `ImapPhotometry` whose arrays hold their counts (the
/// candela array `vertical_count × horizontal_count`); otherwise as
/// `imap_add_luminaire_ies`.
#[no_mangle]
pub unsafe extern "C" fn imap_add_luminaire_table(
    ctx: *mut ImapContext,
    table: *const ImapPhotometry,
    placement: *const ImapLuminaire,
    spectrum: *const ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let t = read_versioned("table", table)?;
        let place = placement_from_c(placement)?;
        let spectrum = spectrum_from_c(spectrum)?;
        let data = table_from_c(&t)?;
        c.add_luminaire(&data, &place, &spectrum)
    })
}

fn table_from_c(t: &ImapPhotometry) -> Result<PhotometricData> {
    let kind = match t.photometric_type {
        IMAP_PHOTOMETRY_C => PhotometricType::C,
        IMAP_PHOTOMETRY_B => PhotometricType::B,
        k => bail!(
            ImapErrInvalidArgument,
            "table.photometric_type = {k} is not IMAP_PHOTOMETRY_C (1) or IMAP_PHOTOMETRY_B (2)"
        ),
    };
    crate::error::check_finite_scalar("table.multiplier", t.multiplier)?;
    if t.multiplier <= 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "table.multiplier = {} must be positive",
            t.multiplier
        );
    }
    let vertical = slice("table.vertical", t.vertical, t.vertical_count)?.to_vec();
    let horizontal = slice("table.horizontal", t.horizontal, t.horizontal_count)?.to_vec();
    let n = t
        .vertical_count
        .checked_mul(t.horizontal_count)
        .ok_or_else(|| {
            Error::new(
                ImapStatus::ImapErrInvalidArgument,
                "table: vertical_count × horizontal_count overflows",
            )
        })?;
    let cd = slice("table.candela", t.candela, n)?;
    if horizontal.is_empty() || vertical.len() < 2 {
        bail!(
            ImapErrParse,
            "table: {} vertical and {} horizontal angles: a distribution needs at least 2 vertical angles and 1 horizontal",
            vertical.len(),
            horizontal.len()
        );
    }
    let candela = cd
        .chunks(vertical.len())
        .map(|r| r.iter().map(|v| v * t.multiplier).collect())
        .collect();
    let symmetry = Symmetry::infer(kind, &horizontal)
        .map_err(|why| Error::new(ImapStatus::ImapErrParse, format!("table: {why}")))?;
    let tilt = if t.tilt_count == 0 {
        None
    } else {
        Some((
            slice("table.tilt_angles", t.tilt_angles, t.tilt_count)?.to_vec(),
            slice("table.tilt_factors", t.tilt_factors, t.tilt_count)?.to_vec(),
        ))
    };
    crate::error::check_finite("table.opening size", &[t.opening_width, t.opening_length])?;
    let (w, l) = (t.opening_width, t.opening_length);
    let opening = match t.opening {
        IMAP_OPENING_POINT => Opening::Point,
        IMAP_OPENING_RECTANGLE | IMAP_OPENING_ELLIPSE => {
            if !(w > 0.0 && l > 0.0) {
                bail!(
                    ImapErrInvalidArgument,
                    "table.opening_width = {w}, opening_length = {l}: an opening needs both positive (metres)"
                );
            }
            if t.opening == IMAP_OPENING_RECTANGLE {
                Opening::Rectangle {
                    width: w,
                    length: l,
                }
            } else {
                Opening::Ellipse {
                    width: w,
                    length: l,
                }
            }
        }
        o => bail!(
            ImapErrInvalidArgument,
            "table.opening = {o} is not an IMAP_OPENING_* value (0–2)"
        ),
    };
    let data = PhotometricData {
        kind,
        vertical,
        horizontal,
        candela,
        symmetry,
        tilt,
        opening,
        cct_k: None,
    };
    data.validate()
        .map_err(|e| Error::new(e.status, format!("table: {}", e.message)))?;
    Ok(data)
}

/// The radiant flux per band (W) of light `id` into `out_w[0 .. band count)` (NULL with
/// count 0 to skip), and its luminous flux (lm) into `*out_lm` (NULL to skip). For a
/// luminaire: what its placement emits (factors, TILT and `lumens` applied). For a sky or
/// the sun (Since 0.2.2): the irradiance per band (W/m²) and illuminance (lx) it gives an
/// unobstructed horizontal plane (its flux into a scene depends on the scene's size).
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INDEX_OUT_OF_RANGE, IMAP_ERR_BUFFER_TOO_SMALL,
/// IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out_w` holds `count` writable doubles or is NULL with 0;
/// `out_lm` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_light_flux(
    ctx: *const ImapContext,
    id: u32,
    out_w: *mut f64,
    count: usize,
    out_lm: *mut f64,
) -> ImapStatus {
    with_context(ctx, |c| {
        let (w, lm) = c.light_flux(id)?;
        if !out_w.is_null() || count > 0 {
            copy_bands(out_w, count, &w)?;
        }
        write_optional(out_lm, lm)
    })
}
