//! Where the sun is: NREL's Solar Position Algorithm for a moment and a place, with the
//! civil calendar it needs.

use crate::error::{bail, check_finite_scalar, check_range, Result};

/// A moment and a place on Earth, for the sun's position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunTime {
    pub year: i32,
    pub month: u32,
    pub day: u32,
    pub hour: u32,
    pub minute: u32,
    pub second: f64,
    /// Local time's offset from UTC, hours (e.g. +1 for CET).
    pub utc_offset_hours: f64,
    /// Degrees north.
    pub latitude_deg: f64,
    /// Degrees east.
    pub longitude_deg: f64,
    /// Metres above sea level.
    pub elevation_m: f64,
}

/// The sun's apparent position (azimuth from north toward east, zenith angle; degrees)
/// by NREL's Solar Position Algorithm (Reda & Andreas 2004, ±0.0003°; the
/// `solar-positioning` crate), with ΔT estimated from the date (Espenak & Meeus) and the
/// refraction of a standard atmosphere (1013.25 hPa, 10 °C; none below the horizon).
pub fn sun_position(t: &SunTime) -> Result<(f64, f64)> {
    sun_position_with(t, None, Some(STANDARD_ATMOSPHERE))
}

/// The atmosphere refraction is computed for unless a caller gives its own: (pressure
/// hPa, temperature °C).
pub const STANDARD_ATMOSPHERE: (f64, f64) = (1013.25, 10.0);

/// `sun_position` with ΔT (s) given, and refraction for (pressure hPa, temperature °C)
/// or none.
pub fn sun_position_with(
    t: &SunTime,
    delta_t: Option<f64>,
    refraction: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    use solar_positioning::{spa, time::DeltaT, time::JulianDate, RefractionCorrection};
    check_finite_scalar("second", t.second)?;
    check_range("utc_offset_hours", t.utc_offset_hours, -14.0, 14.0)?;
    check_range("latitude_deg", t.latitude_deg, -90.0, 90.0)?;
    check_range("longitude_deg", t.longitude_deg, -180.0, 180.0)?;
    check_range("elevation_m", t.elevation_m, -1000.0, 10_000.0)?;
    let bad = |what: String| {
        crate::error::Error::new(crate::error::ImapStatus::ImapErrInvalidArgument, what)
    };
    if !(-2000..=6000).contains(&t.year) {
        bail!(
            ImapErrInvalidArgument,
            "year = {}: the solar position algorithm covers −2000 to 6000",
            t.year
        );
    }
    if let Some(d) = delta_t {
        check_range("delta_t_s", d, -1e6, 1e6)?;
    }
    if let Some((p, c)) = refraction {
        check_range("pressure_hpa", p, 1.0, 2000.0)?;
        check_range("temperature_c", c, -100.0, 100.0)?;
    }
    let dt = match delta_t {
        Some(d) => d,
        None => DeltaT::estimate_from_date(t.year, t.month.clamp(1, 12))
            .map_err(|e| bad(format!("ΔT for {}-{}: {e}", t.year, t.month)))?,
    };
    // Local civil time to UTC: validate the local fields, then shift by whole days.
    let stamp = format!(
        "{:04}-{:02}-{:02} {:02}:{:02}:{:06.3}",
        t.year, t.month, t.day, t.hour, t.minute, t.second
    );
    JulianDate::from_utc(t.year, t.month, t.day, t.hour, t.minute, t.second, dt)
        .map_err(|e| bad(format!("{stamp}: {e}")))?;
    let secs =
        t.hour as f64 * 3600.0 + t.minute as f64 * 60.0 + t.second - t.utc_offset_hours * 3600.0;
    let shift = (secs / 86_400.0).floor();
    let secs = (secs - shift * 86_400.0).clamp(0.0, 86_399.999_999);
    let (y, m, d) = civil_from_days(days_from_civil(t.year, t.month, t.day) + shift as i64);
    let (h, rest) = ((secs / 3600.0) as u32, secs % 3600.0);
    let (mi, sec) = ((rest / 60.0) as u32, (rest % 60.0).min(59.999_999));
    let jd = JulianDate::from_utc(y, m, d, h.min(23), mi.min(59), sec, dt)
        .map_err(|e| bad(format!("{stamp} as UTC: {e}")))?;
    let refraction = match refraction {
        Some((p, c)) => Some(
            RefractionCorrection::new(p, c)
                .map_err(|e| bad(format!("refraction ({p} hPa, {c} °C): {e}")))?,
        ),
        None => None,
    };
    let pos = spa::solar_position_from_julian(
        jd,
        t.latitude_deg,
        t.longitude_deg,
        t.elevation_m,
        refraction,
    )
    .map_err(|e| bad(format!("the solar position: {e}")))?;
    Ok((pos.azimuth(), pos.zenith_angle()))
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i32, m: u32, d: u32) -> i64 {
    let y = y as i64 - if m <= 2 { 1 } else { 0 };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = m as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date of `days` since 1970-01-01 (inverse of `days_from_civil`).
fn civil_from_days(days: i64) -> (i32, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    (y as i32, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sun_position_matches_the_spa_papers_example() {
        // Reda & Andreas (2004), table A4.1: 2003-10-17 12:30:30 at UTC−7, 39.742476° N,
        // 105.1786° W, 1830.14 m, 820 hPa, 11 °C, ΔT = 67 s: topocentric zenith angle
        // 50.11162°, azimuth (from north, eastward) 194.34024°.
        let t = SunTime {
            year: 2003,
            month: 10,
            day: 17,
            hour: 12,
            minute: 30,
            second: 30.0,
            utc_offset_hours: -7.0,
            latitude_deg: 39.742476,
            longitude_deg: -105.1786,
            elevation_m: 1830.14,
        };
        let (az, zen) = sun_position_with(&t, Some(67.0), Some((820.0, 11.0))).unwrap();
        assert!((zen - 50.11162).abs() < 2e-5, "{zen}");
        assert!((az - 194.34024).abs() < 2e-5, "{az}");
        // The same moment given in UTC, and across a date line: 2003-10-18 04:30:30 at
        // UTC+9 is 2003-10-17 19:30:30 UTC.
        let utc = SunTime {
            hour: 19,
            utc_offset_hours: 0.0,
            ..t
        };
        let east = SunTime {
            day: 18,
            hour: 4,
            utc_offset_hours: 9.0,
            ..t
        };
        for t in [utc, east] {
            let (a, z) = sun_position_with(&t, Some(67.0), Some((820.0, 11.0))).unwrap();
            assert!((a - az).abs() < 1e-9 && (z - zen).abs() < 1e-9, "{t:?}");
        }
        assert_eq!(
            civil_from_days(days_from_civil(2000, 2, 29) + 1),
            (2000, 3, 1)
        );
        assert_eq!(
            civil_from_days(days_from_civil(2024, 1, 1) - 1),
            (2023, 12, 31)
        );
        let e = sun_position(&SunTime { month: 13, ..t })
            .unwrap_err()
            .to_string();
        assert!(e.contains("2003-13-17"), "{e}");
        let e = sun_position(&SunTime {
            latitude_deg: 91.0,
            ..t
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("latitude_deg"), "{e}");
    }
}
