//! Weather files: EnergyPlus EPW and Radiance .wea, read into a site and its hours of
//! direct normal and diffuse horizontal irradiance.
//!
//! Both formats are plain text; the reader is ours (the one Rust EPW crate is an alpha
//! that reports no line or field) so that every error names the file, the line and the
//! field.
//!
//! Time: an EPW row of hour h holds what was measured over the hour that ends at h:00
//! local standard time (h = 1–24); its sun is taken at h − 0.5, as Radiance's epw2wea
//! writes it. A .wea row gives the decimal hour itself. Weather files hold standard time
//! all year: daylight saving time is not applied (an occupancy schedule given in clock
//! time must be shifted by the caller during its summer months).

use crate::error::{bail, Error, ImapStatus, Result};
use crate::files::{read_regular, ReadError};
use crate::photometry::ies::printable;
use std::path::Path;

/// Where the weather was recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct WeatherSite {
    /// The place's name as the file gives it.
    pub name: String,
    /// Degrees north.
    pub latitude_deg: f64,
    /// Degrees east.
    pub longitude_deg: f64,
    /// Local standard time's offset from UTC, hours (east positive).
    pub utc_offset_hours: f64,
    /// Metres above sea level.
    pub elevation_m: f64,
}

/// One hour (or time step) of weather.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeatherHour {
    /// The year the row gives (EPW; a typical year mixes years), or 0 (.wea).
    pub year: i32,
    pub month: u32,
    pub day: u32,
    /// The sun's time: decimal hours of local standard time, the middle of the row's time
    /// step (an hourly EPW row's hour − 0.5).
    pub hour: f64,
    /// Direct normal and diffuse horizontal irradiance, W/m² (the whole solar spectrum);
    /// `None` where the file marks the value missing (EPW 9999).
    pub direct_normal_w: Option<f64>,
    pub diffuse_horizontal_w: Option<f64>,
    /// The dew point, °C (EPW; `None` where missing, 99.9, and in .wea files).
    pub dew_point_c: Option<f64>,
    /// The 1-based line of the file the hour comes from.
    pub line: usize,
}

impl WeatherHour {
    /// The day of the year, 1–365 (366 for 31 December of a leap year; typical-year
    /// files have no 29 February, and .wea rows count as a common year).
    pub fn day_of_year(&self) -> u32 {
        day_of_year(self.year, self.month, self.day)
    }

    /// The sun's position (azimuth from north toward east, zenith angle; degrees) at the
    /// middle of the hour at `site`, by the solar position algorithm (`sun_position`);
    /// a .wea row (no year) is placed in 2001.
    pub fn sun_position(&self, site: &WeatherSite) -> Result<(f64, f64)> {
        let t = self.hour.clamp(0.0, 24.0 - 1e-9) * 3600.0;
        let s = (t.round() as u32).min(86_399);
        crate::solar::sun_position(&crate::solar::SunTime {
            year: if self.year == 0 { 2001 } else { self.year },
            month: self.month,
            day: self.day,
            hour: s / 3600,
            minute: s / 60 % 60,
            second: (s % 60) as f64,
            utc_offset_hours: site.utc_offset_hours,
            latitude_deg: site.latitude_deg,
            longitude_deg: site.longitude_deg,
            elevation_m: site.elevation_m,
        })
    }

    /// The hour's Perez sky (`perez_sky`) with the sun at `sun_zenith_deg`: its dew point
    /// gives the precipitable water (2 cm where the file has none). `None` for an hour
    /// without diffuse light or with its irradiance missing.
    pub fn perez_sky(&self, sun_zenith_deg: f64) -> Result<Option<crate::scene::light::PerezSky>> {
        let (Some(dni), Some(dhi)) = (self.direct_normal_w, self.diffuse_horizontal_w) else {
            return Ok(None);
        };
        let water = self
            .dew_point_c
            .map_or(2.0, crate::scene::light::precipitable_water);
        crate::scene::light::perez_sky(dni, dhi, sun_zenith_deg, self.day_of_year(), water)
    }
}

/// The day of the year of `month`/`day` in `year` of the Gregorian calendar (1–366; year 0,
/// a .wea row's, counts as a common year).
pub fn day_of_year(year: i32, month: u32, day: u32) -> u32 {
    const START: [u32; 12] = [0, 31, 59, 90, 120, 151, 181, 212, 243, 273, 304, 334];
    let leap = year != 0 && ((year % 4 == 0 && year % 100 != 0) || year % 400 == 0);
    START[(month.clamp(1, 12) - 1) as usize] + day + u32::from(leap && month > 2)
}

/// A weather file's site and hours.
#[derive(Clone, Debug, PartialEq)]
pub struct Weather {
    pub site: WeatherSite,
    pub hours: Vec<WeatherHour>,
}

/// The largest weather file read: a year of 1-minute steps of EPW is ~250 MB; we take up
/// to 64 MB (a year of 10-minute steps).
pub const WEATHER_FILE_LIMIT: u64 = 64 << 20;

fn read_text(path: &Path) -> Result<String> {
    let shown = path.display();
    let bytes = read_regular(path, WEATHER_FILE_LIMIT).map_err(|e| match e {
        ReadError::TooLarge { .. } => Error::new(
            ImapStatus::ImapErrMemoryBudget,
            format!("{shown}: {e}: a weather file is at most 64 MB"),
        ),
        e => Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")),
    })?;
    // EPW files in the wild carry Latin-1 place names: keep every byte readable.
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => e.into_bytes().iter().map(|&b| b as char).collect(),
    })
}

/// Reads an EnergyPlus EPW file. IMAP_ERR_IO when it cannot be read, IMAP_ERR_PARSE
/// naming the file, line and field of the first value that is not what the format says.
pub fn read_epw(path: &Path) -> Result<Weather> {
    parse_epw(&read_text(path)?, &path.display().to_string())
}

/// Reads a Radiance .wea file (as epw2wea and gendaymtx write and read it): radiometric
/// units (`weather_data_file_units 1`) only.
pub fn read_wea(path: &Path) -> Result<Weather> {
    parse_wea(&read_text(path)?, &path.display().to_string())
}

/// Reads a weather file: Radiance .wea by its extension, EnergyPlus EPW otherwise.
pub fn read(path: &Path) -> Result<Weather> {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("wea"))
    {
        read_wea(path)
    } else {
        read_epw(path)
    }
}

/// A parse error at `file`:`line`.
fn at(file: &str, line: usize, what: String) -> Error {
    Error::new(ImapStatus::ImapErrParse, format!("{file}:{line}: {what}"))
}

fn number(file: &str, line: usize, field: &str, text: &str) -> Result<f64> {
    let t = text.trim();
    match t.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(at(
            file,
            line,
            format!("{field} = \"{}\" is not a number", printable(t)),
        )),
    }
}

/// A number of `field` in [lo, hi].
fn ranged(file: &str, line: usize, field: &str, text: &str, lo: f64, hi: f64) -> Result<f64> {
    in_range(file, line, field, number(file, line, field, text)?, lo, hi)
}

fn in_range(file: &str, line: usize, field: &str, x: f64, lo: f64, hi: f64) -> Result<f64> {
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err(at(
            file,
            line,
            format!("{field} = {x} is outside {lo}–{hi}"),
        ))
    }
}

/// Days in `month` (February 29 days: a leap year's row is taken as written).
fn check_date(file: &str, line: usize, month: f64, day: f64) -> Result<(u32, u32)> {
    const DAYS: [u32; 12] = [31, 29, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
    if month.fract() != 0.0 || !(1.0..=12.0).contains(&month) {
        return Err(at(file, line, format!("month = {month} is not 1–12")));
    }
    let m = month as u32;
    if day.fract() != 0.0 || day < 1.0 || day > DAYS[m as usize - 1] as f64 {
        return Err(at(
            file,
            line,
            format!("day = {day} is not a day of month {m}"),
        ));
    }
    Ok((m, day as u32))
}

/// Parses EPW text; `file` names it in messages.
pub fn parse_epw(text: &str, file: &str) -> Result<Weather> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let Some((n, first)) = lines.next() else {
        bail!(ImapErrParse, "{file}: empty: not an EPW file");
    };
    let f: Vec<&str> = first.split(',').collect();
    if f.first().map(|s| s.trim()) != Some("LOCATION") || f.len() < 10 {
        return Err(at(
            file,
            n,
            "an EPW file starts with LOCATION,city,state,country,source,WMO,latitude,longitude,time zone,elevation".into(),
        ));
    }
    let site = WeatherSite {
        name: f[1].trim().to_string(),
        latitude_deg: ranged(file, n, "latitude", f[6], -90.0, 90.0)?,
        longitude_deg: ranged(file, n, "longitude", f[7], -180.0, 180.0)?,
        utc_offset_hours: ranged(file, n, "time zone", f[8], -12.0, 14.0)?,
        elevation_m: ranged(file, n, "elevation", f[9], -1000.0, 10_000.0)?,
    };
    // The other seven header lines, the last DATA PERIODS (its second field: records per
    // hour).
    let mut header = 1;
    let mut per_hour = 1.0;
    for (n, l) in lines.by_ref() {
        header += 1;
        if l.starts_with("DATA PERIODS") {
            if let Some(x) = l.split(',').nth(2) {
                per_hour = ranged(file, n, "records per hour", x, 1.0, 60.0)?;
            }
            break;
        }
        if header == 8 {
            return Err(at(
                file,
                n,
                "the eighth line of an EPW file is DATA PERIODS".into(),
            ));
        }
    }
    if header < 8 {
        bail!(
            ImapErrParse,
            "{file}: the header ends before its DATA PERIODS line"
        );
    }
    let mut hours = Vec::new();
    for (n, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = l.split(',').collect();
        if f.len() < 22 {
            return Err(at(
                file,
                n,
                format!(
                    "{} fields; an EPW data row has 35 (at least the 22 up to wind speed)",
                    f.len()
                ),
            ));
        }
        let num = |i: usize, name: &str| number(file, n, name, f[i]);
        let year = num(0, "year")?;
        let (month, day) = check_date(file, n, num(1, "month")?, num(2, "day")?)?;
        let hour = num(3, "hour")?;
        if hour.fract() != 0.0 || !(1.0..=24.0).contains(&hour) {
            return Err(at(file, n, format!("hour = {hour} is not 1–24")));
        }
        let minute = num(4, "minute")?;
        if !(0.0..=60.0).contains(&minute) {
            return Err(at(file, n, format!("minute = {minute} is not 0–60")));
        }
        // Missing values: 9999 for radiation, 99.9 for the dew point.
        let radiation = |i: usize, name: &str| -> Result<Option<f64>> {
            let x = num(i, name)?;
            if x >= 9999.0 {
                return Ok(None);
            }
            in_range(file, n, name, x, 0.0, 2000.0).map(Some)
        };
        let dew = num(7, "dew point")?;
        hours.push(WeatherHour {
            year: year as i32,
            month,
            day,
            // The middle of the step that ends at (hour − 1):minute (hour:00 for minute 0
            // or 60): h − 0.5 in an hourly file.
            hour: if minute == 0.0 || minute == 60.0 {
                hour
            } else {
                hour - 1.0 + minute / 60.0
            } - 0.5 / per_hour,
            direct_normal_w: radiation(14, "direct normal radiation")?,
            diffuse_horizontal_w: radiation(15, "diffuse horizontal radiation")?,
            dew_point_c: (dew < 99.0).then_some(dew).filter(|d| *d > -90.0),
            line: n,
        });
    }
    if hours.is_empty() {
        bail!(ImapErrParse, "{file}: no data rows after the header");
    }
    Ok(Weather { site, hours })
}

/// Parses .wea text; `file` names it in messages. Radiance's longitudes and meridians are
/// degrees west; ours east.
pub fn parse_wea(text: &str, file: &str) -> Result<Weather> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let mut key = |name: &str| -> Result<(usize, String)> {
        match lines.next() {
            Some((n, l)) => match l.trim().strip_prefix(name) {
                Some(v) => Ok((n, v.trim().to_string())),
                None => Err(at(
                    file,
                    n,
                    format!("expected \"{name} …\" (a .wea header line)"),
                )),
            },
            None => bail!(ImapErrParse, "{file}: the header ends before \"{name}\""),
        }
    };
    let (_, name) = key("place")?;
    let (n, lat) = key("latitude")?;
    let latitude_deg = ranged(file, n, "latitude", &lat, -90.0, 90.0)?;
    let (n, lon) = key("longitude")?;
    let longitude_deg = -ranged(file, n, "longitude", &lon, -180.0, 180.0)?;
    let (n, tz) = key("time_zone")?;
    let meridian = ranged(file, n, "time_zone", &tz, -210.0, 180.0)?;
    let (n, el) = key("site_elevation")?;
    let elevation_m = ranged(file, n, "site_elevation", &el, -1000.0, 10_000.0)?;
    let (n, units) = key("weather_data_file_units")?;
    if units.trim() != "1" {
        return Err(at(
            file,
            n,
            format!(
                "weather_data_file_units = {}: only 1 (direct normal and diffuse horizontal irradiance, W/m²) is read",
                printable(&units)
            ),
        ));
    }
    let mut hours = Vec::new();
    for (n, l) in lines {
        if l.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() != 5 {
            return Err(at(
                file,
                n,
                format!(
                    "{} values; a .wea row has 5: month day hour direct diffuse",
                    f.len()
                ),
            ));
        }
        let (month, day) = check_date(
            file,
            n,
            number(file, n, "month", f[0])?,
            number(file, n, "day", f[1])?,
        )?;
        let hour = ranged(file, n, "hour", f[2], 0.0, 24.0)?;
        let dni = ranged(file, n, "direct", f[3], 0.0, 2000.0)?;
        let dhi = ranged(file, n, "diffuse", f[4], 0.0, 2000.0)?;
        hours.push(WeatherHour {
            year: 0,
            month,
            day,
            hour,
            direct_normal_w: Some(dni),
            diffuse_horizontal_w: Some(dhi),
            dew_point_c: None,
            line: n,
        });
    }
    if hours.is_empty() {
        bail!(ImapErrParse, "{file}: no data rows after the header");
    }
    Ok(Weather {
        site: WeatherSite {
            name,
            latitude_deg,
            longitude_deg,
            utc_offset_hours: -meridian / 15.0,
            elevation_m,
        },
        hours,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "LOCATION,Test Town,ST,XYZ,TMY3,123456,47.50,8.25,1.0,410.0\n\
        DESIGN CONDITIONS,0\nTYPICAL/EXTREME PERIODS,0\nGROUND TEMPERATURES,0\n\
        HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0\nCOMMENTS 1,x\nCOMMENTS 2,y\n\
        DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n";

    fn row(month: u32, day: u32, hour: u32, dew: &str, dni: &str, dhi: &str) -> String {
        format!(
            "1999,{month},{day},{hour},60,?9?9?9?9E0?9?9?9?9*9?9?9?9?9?9?9?9?9?9?9*_*9*9*9*9*9,\
             12.0,{dew},70,96000,0,0,300,400,{dni},{dhi},0,0,0,0,180,3.0,5,5,20.0,77777,9,999999999,1.2,0.1,0,88,0.2,0,1\n"
        )
    }

    #[test]
    fn an_epw_file_reads_its_site_and_hours() {
        let text = format!(
            "{HEADER}{}{}{}",
            row(1, 1, 1, "5.0", "0", "0"),
            row(6, 21, 13, "14.2", "612", "148"),
            row(12, 31, 24, "99.9", "9999", "80")
        );
        let w = parse_epw(&text, "t.epw").unwrap();
        assert_eq!(w.site.name, "Test Town");
        assert_eq!(
            (
                w.site.latitude_deg,
                w.site.longitude_deg,
                w.site.utc_offset_hours,
                w.site.elevation_m
            ),
            (47.5, 8.25, 1.0, 410.0)
        );
        assert_eq!(w.hours.len(), 3);
        let h = &w.hours[1];
        assert_eq!((h.month, h.day, h.hour), (6, 21, 12.5));
        assert_eq!(
            (h.direct_normal_w, h.diffuse_horizontal_w),
            (Some(612.0), Some(148.0))
        );
        assert_eq!(h.dew_point_c, Some(14.2));
        assert_eq!(h.line, 10);
        assert_eq!(h.day_of_year(), 172);
        let h = &w.hours[2];
        assert_eq!(
            (h.direct_normal_w, h.dew_point_c, h.hour),
            (None, None, 23.5)
        );
        assert_eq!(h.day_of_year(), 365);
        // The sun at 12:30 CET on 21 June at 47.5° N 8.25° E: 12:03 solar time, the
        // zenith angle latitude − declination (23.44°) ≈ 24.1°, due south.
        let (a, z) = w.hours[1].sun_position(&w.site).unwrap();
        assert!((z - 24.1).abs() < 0.2 && (a - 180.0).abs() < 3.0, "{a} {z}");
        let p = w.hours[1].perez_sky(z).unwrap().unwrap();
        let q = crate::scene::light::perez_sky(
            612.0,
            148.0,
            z,
            172,
            crate::scene::light::precipitable_water(14.2),
        )
        .unwrap();
        assert_eq!(Some(p), q);
        assert_eq!(w.hours[2].perez_sky(z).unwrap(), None);
    }

    #[test]
    fn bad_epw_files_name_the_line_and_field() {
        let e = |t: String| parse_epw(&t, "w.epw").unwrap_err().to_string();
        assert!(e(String::new()).contains("empty"));
        assert!(e("NOT,AN,EPW".into()).contains("w.epw:1"));
        assert!(e(HEADER.replace("47.50", "94")).contains("latitude = 94"));
        assert!(e(HEADER.to_string()).contains("no data rows"));
        assert!(e(HEADER.lines().take(5).collect::<Vec<_>>().join("\n")).contains("DATA PERIODS"));
        let bad = |r: String| e(format!("{HEADER}{}{r}", row(1, 1, 1, "5", "0", "0")));
        let m = bad(row(2, 30, 1, "5", "0", "0"));
        assert!(m.contains("w.epw:10") && m.contains("day = 30"), "{m}");
        assert!(bad(row(1, 1, 25, "5", "0", "0")).contains("hour = 25"));
        assert!(bad(row(1, 1, 2, "5", "x", "0")).contains("direct normal radiation = \"x\""));
        assert!(bad(row(1, 1, 2, "5", "0", "-3")).contains("diffuse horizontal radiation = -3"));
        assert!(bad("1999,1,1,3,60\n".into()).contains("5 fields"));
    }

    #[test]
    fn a_wea_file_reads_its_site_and_hours() {
        let text = "place Test_Town\nlatitude 47.5\nlongitude -8.25\ntime_zone -15\n\
                    site_elevation 410\nweather_data_file_units 1\n6 21 12.5 612 148\n12 31 23.5 0 80\n";
        let w = parse_wea(text, "t.wea").unwrap();
        assert_eq!(
            (
                w.site.latitude_deg,
                w.site.longitude_deg,
                w.site.utc_offset_hours
            ),
            (47.5, 8.25, 1.0)
        );
        assert_eq!(w.hours.len(), 2);
        assert_eq!(
            (w.hours[0].hour, w.hours[0].direct_normal_w),
            (12.5, Some(612.0))
        );
        assert_eq!(w.hours[1].line, 8);
        let e = parse_wea(&text.replace("units 1", "units 3"), "t.wea").unwrap_err();
        assert!(e.to_string().contains("t.wea:6"), "{e}");
        let e = parse_wea(&text.replace("12 31 23.5 0 80", "12 31 23.5 0"), "t.wea").unwrap_err();
        assert!(e.to_string().contains("t.wea:8: 4 values"), "{e}");
    }
}
