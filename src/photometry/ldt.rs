//! EULUMDAT (.ldt) photometric files, written here from the format's published line
//! layout.
//!
//! Lines: 1 company; 2 type indicator Ityp; 3 symmetry indicator Isym (0 none, 1 about the
//! vertical axis, 2 about the C0–C180 plane, 3 about the C90–C270 plane, 4 about both);
//! 4 Mc, the number of C planes in 0–360°; 5 their spacing Dc; 6 Ng, the number of
//! intensities per plane; 7 their spacing Dg; 8–12 report, luminaire name and number, file
//! name, date; 13–15 luminaire length (or diameter), width (0: round), height, mm; 16–17
//! the luminous area's length (or diameter) and width (0: round), mm; 18–21 the luminous
//! area's heights in C0, C90, C180, C270, mm; 22 downward flux fraction, %; 23 light output
//! ratio, %; 24 conversion factor for luminous intensities; 25 tilt during measurement, °;
//! 26 the number n of lamp sets, then for the sets: number of lamps, lamp type, total
//! lamp flux (lm), colour temperature, colour rendering, wattage; ten direct ratios; the Mc
//! C angles; the Ng γ angles; the intensities (cd/klm) of the stored planes, Ng per plane:
//! all Mc planes (Isym 0), one (1), C0–C180 (2), C90–C270 (3), C0–C90 (4).
//!
//! Intensities become cd/klm × the first lamp set's flux / 1000 × the conversion factor.
//! Decimal commas are accepted. Every error names its line.

use super::gonio::{Opening, PhotometricData, PhotometricType, Symmetry};
use super::ies::printable;
use crate::error::{Error, ImapStatus, Result};

/// What the file says beyond the distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct LdtFile {
    pub company: String,
    pub luminaire: String,
    /// Light output ratio, %.
    pub lor_percent: f64,
    /// The first lamp set's total flux, lm.
    pub lamp_flux: f64,
    pub conversion_factor: f64,
    /// Tilt of the luminaire during measurement, degrees (not applied).
    pub measured_tilt_deg: f64,
    /// The distribution, in candela.
    pub data: PhotometricData,
}

const W: &str = "LDT";

fn parse_error(line: usize, msg: impl std::fmt::Display) -> Error {
    Error::new(ImapStatus::ImapErrParse, format!("{W} line {line}: {msg}"))
}

fn number(s: &str, line: usize, name: &str) -> Result<f64> {
    let t = s.trim().replace(',', ".");
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(parse_error(
            line,
            format!("{name} is {v}: values must be finite numbers"),
        )),
        Err(_) => Err(parse_error(
            line,
            format!("expected {name}, found '{}'", printable(s.trim())),
        )),
    }
}

fn whole(s: &str, line: usize, name: &str, lo: i64, hi: i64) -> Result<i64> {
    let v = number(s, line, name)?;
    if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
        return Err(parse_error(
            line,
            format!("{name} is {v}: it must be a whole number from {lo} to {hi}"),
        ));
    }
    Ok(v as i64)
}

/// The lines of the file, numbered from 1, read lazily (a file's memory is what its
/// values become, never a list of its lines): `at` lines are consumed, and `ahead` holds
/// the lines after them that were looked at.
struct Lines<'a> {
    rest: std::str::Lines<'a>,
    ahead: std::collections::VecDeque<&'a str>,
    at: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            rest: text.lines(),
            ahead: Default::default(),
            at: 0,
        }
    }

    /// Reads ahead so that lines up to index `i` (0-based) can be looked at.
    fn fill(&mut self, i: usize) {
        while self.at + self.ahead.len() <= i {
            match self.rest.next() {
                Some(l) => self.ahead.push_back(l),
                None => break,
            }
        }
    }

    /// Line `i` (0-based, not yet consumed) if `fill` reached it.
    fn peek(&self, i: usize) -> Option<&'a str> {
        i.checked_sub(self.at)
            .and_then(|k| self.ahead.get(k))
            .copied()
    }

    /// The number of lines in the file (reads to its end).
    fn count(&mut self) -> usize {
        let n = self.at + self.ahead.len();
        n + self.rest.clone().count()
    }

    /// Consumes lines up to index `i` (0-based, exclusive).
    fn skip_to(&mut self, i: usize) {
        while self.at < i {
            if self
                .ahead
                .pop_front()
                .or_else(|| self.rest.next())
                .is_none()
            {
                break;
            }
            self.at += 1;
        }
    }

    fn next(&mut self, name: &str) -> Result<(&'a str, usize)> {
        let Some(l) = self.ahead.pop_front().or_else(|| self.rest.next()) else {
            return Err(parse_error(
                self.at.max(1),
                format!("the file ends before {name}"),
            ));
        };
        self.at += 1;
        Ok((l, self.at))
    }

    fn number(&mut self, name: &str) -> Result<f64> {
        let (l, n) = self.next(name)?;
        number(l, n, name)
    }

    fn whole(&mut self, name: &str, lo: i64, hi: i64) -> Result<i64> {
        let (l, n) = self.next(name)?;
        whole(l, n, name, lo, hi)
    }
}

/// Numbers from the current line on, one or more per line.
fn numbers(
    lines: &mut Lines<'_>,
    count: usize,
    name: &dyn Fn(usize) -> String,
) -> Result<(Vec<f64>, usize)> {
    let first = lines.at + 1;
    let mut out = Vec::with_capacity(count.min(1 << 20));
    while out.len() < count {
        let (l, n) = lines.next(&name(out.len()))?;
        for t in l.split_whitespace() {
            if out.len() == count {
                return Err(parse_error(
                    n,
                    format!("'{}' beyond the {count} values expected", printable(t)),
                ));
            }
            out.push(number(t, n, &name(out.len()))?);
        }
    }
    Ok((out, first))
}

/// The first colour temperature in kelvin a lamp's colour text states ("3000K", "4000 K",
/// "3000"), if any: a number from 1000 to 100 000.
fn colour_temperature(s: &str) -> Option<f64> {
    s.split(|c: char| !c.is_ascii_digit() && c != '.')
        .filter_map(|t| t.parse::<f64>().ok())
        .find(|t| (1000.0..=100_000.0).contains(t))
}

/// Parses a EULUMDAT file.
pub fn parse(text: &str) -> Result<LdtFile> {
    parse_within(text, &|_| Ok(()))
}

/// `parse`, asking `reserve` for the bytes the table will take (read and expanded to the
/// sphere, `gonio::table_bytes`) once the planes are known, before any intensity is
/// stored: a memory budget refuses a huge file before it is read.
pub fn parse_within(text: &str, reserve: &dyn Fn(u64) -> Result<()>) -> Result<LdtFile> {
    let mut l = Lines::new(text);
    let (company, _) = l.next("the company line")?;
    let company = company.trim_start_matches('\u{feff}').trim().to_string();
    l.whole("the type indicator Ityp", 0, 3)?;
    let isym = l.whole("the symmetry indicator Isym", 0, 4)?;
    let (mc_s, mc_line) = l.next("the number of C planes Mc")?;
    let mc = whole(mc_s, mc_line, "the number of C planes Mc", 1, 3600)? as usize;
    l.number("the C-plane spacing Dc")?;
    let (ng_s, ng_line) = l.next("the number of intensities per plane Ng")?;
    let ng = whole(
        ng_s,
        ng_line,
        "the number of intensities per plane Ng",
        2,
        3600,
    )? as usize;
    l.number("the intensity spacing Dg")?;
    l.next("the measurement report")?;
    let (luminaire, _) = l.next("the luminaire name")?;
    for name in ["the luminaire number", "the file name", "the date"] {
        l.next(name)?;
    }
    for name in [
        "the luminaire length",
        "the luminaire width",
        "the luminaire height",
    ] {
        l.number(name)?;
    }
    let (la_s, la_line) = l.next("the luminous area's length")?;
    let area_length = number(la_s, la_line, "the luminous area's length")?;
    let area_width = l.number("the luminous area's width")?;
    for name in [
        "the luminous height C0",
        "the luminous height C90",
        "the luminous height C180",
        "the luminous height C270",
        "the downward flux fraction",
    ] {
        l.number(name)?;
    }
    let lor_percent = l.number("the light output ratio")?;
    let (cf_s, cf_line) = l.next("the conversion factor for luminous intensities")?;
    let conversion_factor = number(
        cf_s,
        cf_line,
        "the conversion factor for luminous intensities",
    )?;
    if conversion_factor <= 0.0 {
        return Err(parse_error(
            cf_line,
            format!("the conversion factor for luminous intensities is {conversion_factor}: it must be positive"),
        ));
    }
    let measured_tilt_deg = l.number("the tilt during measurement")?;
    let sets = l.whole("the number of lamp sets", 1, 1000)? as usize;
    // The lamp sets' six fields: set by set (most files), or field by field; told apart by
    // whether the second line is a number (field by field: the second set's lamp count).
    let block_start = l.at;
    l.fill(block_start + 6 * sets);
    let file_lines = if l.peek(block_start + 6 * sets - 1).is_some() {
        0 // not needed: the block is whole
    } else {
        l.count()
    };
    let second_is_number = sets > 1
        && l.peek(block_start + 1)
            .is_some_and(|s| s.trim().replace(',', ".").parse::<f64>().is_ok());
    let line_of = |set: usize, field: usize| {
        if second_is_number {
            block_start + field * sets + set
        } else {
            block_start + set * 6 + field
        }
    };
    let get = |set: usize, field: usize, name: &str| -> Result<(&str, usize)> {
        let i = line_of(set, field);
        match l.peek(i) {
            Some(s) => Ok((s, i + 1)),
            None => Err(parse_error(
                file_lines.max(1),
                format!("the file ends before lamp set {}'s {name}", set + 1),
            )),
        }
    };
    let (flux_s, flux_line) = get(0, 2, "total luminous flux")?;
    let lamp_flux = number(flux_s, flux_line, "the lamp set's total luminous flux")?;
    if lamp_flux <= 0.0 {
        return Err(parse_error(
            flux_line,
            format!("the first lamp set's total luminous flux is {lamp_flux} lm: it must be positive (intensities are per 1000 lm of it)"),
        ));
    }
    let cct_k = colour_temperature(get(0, 3, "colour temperature")?.0);
    for s in 0..sets {
        let (t, n) = get(s, 0, "number of lamps")?;
        number(t, n, "the number of lamps")?;
        let (t, n) = get(s, 2, "total luminous flux")?;
        number(t, n, "the lamp set's total luminous flux")?;
        let (t, n) = get(s, 5, "wattage")?;
        number(t, n, "the lamp set's wattage")?;
    }
    l.skip_to(block_start + 6 * sets);
    numbers(&mut l, 10, &|i| format!("direct ratio {} of 10", i + 1))?;
    let (c, c_line) = numbers(&mut l, mc, &|i| format!("C angle {} of {mc}", i + 1))?;
    let (g, g_line) = numbers(&mut l, ng, &|i| format!("γ angle {} of {ng}", i + 1))?;
    for (a, name, line) in [(&c, "C", c_line), (&g, "γ", g_line)] {
        if let Some(i) = (1..a.len()).find(|&i| a[i] <= a[i - 1]) {
            return Err(parse_error(
                line + i,
                format!(
                    "{name} angles must increase: angle {} ({}°) follows {}°",
                    i + 1,
                    a[i],
                    a[i - 1]
                ),
            ));
        }
    }
    if c[0] < 0.0 || c[mc - 1] >= 360.0 + 1e-9 {
        return Err(parse_error(
            c_line,
            format!(
                "C angles run from {}° to {}°: they must lie in 0–360°",
                c[0],
                c[mc - 1]
            ),
        ));
    }
    if g[0] < 0.0 || g[ng - 1] > 180.0 {
        return Err(parse_error(
            g_line,
            format!(
                "γ angles run from {}° to {}°: they must lie in 0–180°",
                g[0],
                g[ng - 1]
            ),
        ));
    }
    // The stored planes: those of the file's C angles in the symmetry's domain.
    let (symmetry, domain): (Symmetry, &dyn Fn(f64) -> bool) = match isym {
        0 => (Symmetry::None, &|_| true),
        1 => (Symmetry::Rotational, &|a| a == c[0]),
        2 => (Symmetry::C0C180, &|a| a <= 180.0 + 1e-9),
        3 => (Symmetry::C90C270, &|a| {
            (90.0 - 1e-9..=270.0 + 1e-9).contains(&a)
        }),
        _ => (Symmetry::Quadrant, &|a| a <= 90.0 + 1e-9),
    };
    let mut stored: Vec<f64> = c.iter().copied().filter(|&a| domain(a)).collect();
    if isym == 1 {
        stored.truncate(1);
    }
    let expected = match isym {
        0 => mc,
        1 => 1,
        2 | 3 => mc / 2 + 1,
        _ => mc / 4 + 1,
    };
    if stored.len() != expected {
        return Err(parse_error(
            c_line,
            format!(
                "Isym {isym} with Mc = {mc} stores {expected} planes, but {} of the C angles lie in its range ({:?}…)",
                stored.len(),
                &stored[..stored.len().min(4)]
            ),
        ));
    }
    let rows = stored.len();
    reserve(
        super::gonio::table_bytes(
            (rows * ng) as u64,
            super::gonio::expanded_values(PhotometricType::C, symmetry, ng, rows),
        )
        .0,
    )?;
    let i_line = l.at + 1;
    let (values, _) = numbers(&mut l, rows * ng, &|i| {
        format!(
            "intensity {} of {ng} of C plane {}° (plane {} of the {rows} that Isym {isym} stores)",
            i % ng + 1,
            stored[i / ng],
            i / ng + 1
        )
    })?;
    let at = l.at;
    let mut after = std::iter::from_fn(|| l.next("").ok().map(|x| x.0));
    if let Some((rest, line)) = after
        .by_ref()
        .enumerate()
        .find(|(_, s)| !s.trim().is_empty())
        .map(|(k, s)| (s, at + k + 1))
    {
        return Err(parse_error(
            line,
            format!(
                "'{}' after the {rows} × {ng} intensities: Mc, Ng or Isym do not match the data",
                printable(rest.trim())
            ),
        ));
    }
    let scale = conversion_factor * lamp_flux / 1000.0;
    let candela: Vec<Vec<f64>> = values
        .chunks(ng)
        .map(|r| r.iter().map(|v| v * scale).collect())
        .collect();
    if let Some(i) = values.iter().position(|v| *v < 0.0) {
        return Err(parse_error(
            i_line,
            format!(
                "intensity {} (C {}°, γ {}°) is negative",
                values[i],
                stored[i / ng],
                g[i % ng]
            ),
        ));
    }
    let m = |mm: f64| mm / 1000.0;
    let opening = if area_length > 0.0 && area_width > 0.0 {
        Opening::Rectangle {
            width: m(area_width),
            length: m(area_length),
        }
    } else if area_length > 0.0 {
        Opening::Ellipse {
            width: m(area_length),
            length: m(area_length),
        }
    } else {
        Opening::Point
    };
    let data = PhotometricData {
        kind: PhotometricType::C,
        vertical: g,
        horizontal: stored,
        candela,
        symmetry,
        tilt: None,
        opening,
        cct_k,
    };
    data.validate()
        .map_err(|e| parse_error(i_line, e.message))?;
    Ok(LdtFile {
        company,
        luminaire: luminaire.trim().to_string(),
        lor_percent,
        lamp_flux,
        conversion_factor,
        measured_tilt_deg,
        data,
    })
}

/// A EULUMDAT file's text for a distribution (for tests and examples): planes `c`
/// (degrees, in 0–360) with symmetry `isym`, γ angles `g`, intensities in cd/klm per
/// stored plane, one lamp set of `flux` lm.
pub fn write(isym: u8, c: &[f64], g: &[f64], cd_per_klm: &[Vec<f64>], flux: f64) -> String {
    let mut s = String::new();
    let mut line = |x: &dyn std::fmt::Display| s.push_str(&format!("{x}\n"));
    line(&"libimap test");
    line(&1);
    line(&isym);
    line(&c.len());
    line(&if c.len() > 1 { c[1] - c[0] } else { 0.0 });
    line(&g.len());
    line(&if g.len() > 1 { g[1] - g[0] } else { 0.0 });
    for t in ["report", "luminaire", "number", "file.ldt", "date"] {
        line(&t);
    }
    for v in [0.0; 9] {
        line(&v);
    }
    line(&100.0); // downward flux fraction
    line(&100.0); // light output ratio
    line(&1.0); // conversion factor
    line(&0.0); // tilt
    line(&1); // lamp sets
    line(&1);
    line(&"LED");
    line(&flux);
    line(&"3000K");
    line(&"80");
    line(&10.0);
    for _ in 0..10 {
        line(&0.5);
    }
    for v in c.iter().chain(g) {
        line(v);
    }
    for row in cd_per_klm {
        for v in row {
            line(v);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quarter() -> String {
        let c: Vec<f64> = (0..24).map(|i| i as f64 * 15.0).collect();
        let g: Vec<f64> = (0..=18).map(|i| i as f64 * 10.0).collect();
        let rows: Vec<Vec<f64>> = (0..7)
            .map(|p| g.iter().map(|&a| 100.0 + p as f64 + a).collect())
            .collect();
        write(4, &c, &g, &rows, 2000.0)
    }

    #[test]
    fn reads_the_stored_planes_and_scales_to_candela() {
        let f = parse(&quarter()).unwrap();
        assert_eq!(f.data.symmetry, Symmetry::Quadrant);
        assert_eq!(
            f.data.horizontal,
            vec![0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
        );
        // 100 cd/klm × 2000 lm / 1000.
        assert_eq!(f.data.candela[0][0], 200.0);
        assert_eq!(f.data.cct_k, Some(3000.0));
        // Decimal commas.
        let f2 = parse(&quarter().replace("\n0.5\n", "\n0,5\n")).unwrap();
        assert_eq!(f2.data, f.data);
    }

    #[test]
    fn errors_name_the_line() {
        let q = quarter();
        let lines: Vec<&str> = q.lines().collect();
        let n = lines.len();
        let truncated = lines[..n - 3].join("\n");
        let e = parse(&truncated).unwrap_err();
        assert!(e.message.contains("ends before intensity 17 of 19"), "{e}");
        let mut bad = lines.clone();
        bad[2] = "7";
        let e = parse(&bad.join("\n")).unwrap_err();
        assert!(
            e.message.starts_with("LDT line 3:") && e.message.contains("Isym"),
            "{e}"
        );
        let mut bad = lines.clone();
        let g_at = n - 7 * 19 - 19 + 3; // the fourth γ angle
        bad[g_at] = "5";
        let e = parse(&bad.join("\n")).unwrap_err();
        assert!(
            e.message.contains(&format!("line {}", g_at + 1)) && e.message.contains("increase"),
            "{e}"
        );
        let mut bad = lines.clone();
        bad[n - 1] = "nan";
        let e = parse(&bad.join("\n")).unwrap_err();
        assert!(e.message.contains(&format!("line {n}")), "{e}");
        let extra = format!("{q}5\n");
        let e = parse(&extra).unwrap_err();
        assert!(e.message.contains("do not match"), "{e}");
        assert_eq!(e.status, ImapStatus::ImapErrParse);
    }
}
