//! IES LM-63 photometric files (1986, 1991, 1995, 2002, 2019), written here from the
//! standard's description of the format.
//!
//! Layout: an optional format line (`IESNA:LM-63-1995`, `IESNA:LM-63-2002`,
//! `IES:LM-63-2019`, `IESNA91`; none for 1986), keyword or label lines up to the `TILT=`
//! line, the TILT data when `TILT=INCLUDE` (lamp-to-luminaire geometry, the number of
//! pairs, the angles, the factors), then numbers separated by blanks, commas or line ends:
//! lamps, lumens per lamp, candela multiplier, vertical and horizontal angle counts,
//! photometric type, units, width, length, height; ballast factor, a version-dependent
//! field (ballast-lamp photometric factor in 1986/1991), input watts; the vertical angles;
//! the horizontal angles; a candela row per horizontal angle.
//!
//! Intensities become candela × multiplier × ballast factor (× the ballast-lamp factor for
//! 1986/1991 files). Every error names its line.

use super::gonio::{Opening, PhotometricData, PhotometricType, Symmetry};
use crate::error::{Error, ImapStatus, Result};

/// What the file says beyond the distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct IesFile {
    /// The format line (empty for LM-63-1986 files, which have none).
    pub format: String,
    /// Keyword lines, `[KEYWORD]` and its text.
    pub keywords: Vec<(String, String)>,
    pub lamps: f64,
    /// Lumens per lamp; −1 for absolute photometry.
    pub lumens_per_lamp: f64,
    pub multiplier: f64,
    pub ballast_factor: f64,
    /// The ballast-lamp photometric factor (1986/1991 files; 1 otherwise).
    pub ballast_lamp_factor: f64,
    pub input_watts: f64,
    /// The distribution, intensities scaled by the factors above.
    pub data: PhotometricData,
}

/// Most angles per axis, and values in the table, a file may give (far beyond any
/// goniophotometer: 0.1° steps over 0–360° are 3601 planes).
const MAX_ANGLES: usize = 100_000;
const MAX_VALUES: usize = 20_000_000;

fn parse_error(what: &str, line: usize, msg: impl std::fmt::Display) -> Error {
    Error::new(
        ImapStatus::ImapErrParse,
        format!("{what} line {line}: {msg}"),
    )
}

/// Numbers separated by blanks, commas and line ends, with their line numbers, read
/// lazily: a file's memory is what its values become, never a list of its tokens.
struct Numbers<'a> {
    what: &'static str,
    lines: Box<dyn Iterator<Item = (usize, &'a str)> + 'a>,
    /// The next token, if any (with its line).
    ahead: Option<(&'a str, usize)>,
    /// The rest of the current line after `ahead`.
    tail: &'a str,
    tail_line: usize,
    /// Line of the last line read (for "ends early" errors).
    last_line: usize,
}

fn is_separator(c: char) -> bool {
    c.is_whitespace() || c == ',' || c == '\u{1a}'
}

impl<'a> Numbers<'a> {
    fn new(what: &'static str, lines: impl Iterator<Item = (usize, &'a str)> + 'a) -> Self {
        let mut n = Numbers {
            what,
            lines: Box::new(lines),
            ahead: None,
            tail: "",
            tail_line: 0,
            last_line: 0,
        };
        n.advance();
        n
    }

    /// Moves `ahead` to the next token.
    fn advance(&mut self) {
        loop {
            let t = self.tail.trim_start_matches(is_separator);
            if !t.is_empty() {
                let end = t.find(is_separator).unwrap_or(t.len());
                self.ahead = Some((&t[..end], self.tail_line));
                self.tail = &t[end..];
                return;
            }
            match self.lines.next() {
                Some((n, l)) => {
                    self.last_line = n;
                    self.tail = l;
                    self.tail_line = n;
                }
                None => {
                    self.ahead = None;
                    self.tail = "";
                    return;
                }
            }
        }
    }

    fn line(&self) -> usize {
        self.ahead.map_or(self.last_line, |t| t.1)
    }

    fn next(&mut self, name: &str) -> Result<f64> {
        let Some((t, line)) = self.ahead else {
            return Err(parse_error(
                self.what,
                self.last_line,
                format!("the file ends before {name}"),
            ));
        };
        self.advance();
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(parse_error(
                self.what,
                line,
                format!("{name} is {v}: values must be finite numbers"),
            )),
            Err(_) => Err(parse_error(
                self.what,
                line,
                format!("expected {name}, found '{}'", printable(t)),
            )),
        }
    }

    fn count(&mut self, name: &str, max: usize) -> Result<usize> {
        let line = self.line();
        let v = self.next(name)?;
        if v.fract() != 0.0 || v < 0.0 || v > max as f64 {
            return Err(parse_error(
                self.what,
                line,
                format!("{name} is {v}: it must be a whole number from 0 to {max}"),
            ));
        }
        Ok(v as usize)
    }

    fn list(&mut self, n: usize, name: &str) -> Result<Vec<f64>> {
        let mut v = Vec::new();
        for i in 0..n {
            v.push(self.next(&format!("{name} {} of {n}", i + 1))?);
        }
        Ok(v)
    }

    /// `n` increasing angles; an error names the line of the first that is not.
    fn angles(&mut self, n: usize, name: &str, counts_line: usize) -> Result<Vec<f64>> {
        let mut v: Vec<f64> = Vec::new();
        for i in 0..n {
            let line = self.line();
            let a = self.next(&format!("{name} angle {} of {n}", i + 1))?;
            if let Some(&prev) = v.last() {
                if a <= prev {
                    return Err(parse_error(
                        self.what,
                        line,
                        format!(
                            "{name} angles must increase: angle {} ({a}°) follows {prev}° (do the angle counts on line {counts_line} match the data?)",
                            i + 1
                        ),
                    ));
                }
            }
            v.push(a);
        }
        Ok(v)
    }

    fn rest(&self) -> Option<(&'a str, usize)> {
        self.ahead
    }
}

/// A token shown in a message: at most 40 characters, control characters escaped.
pub(crate) fn printable(s: &str) -> String {
    let mut out: String = s.chars().take(40).flat_map(char::escape_debug).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    out
}

/// Reads TILT data (after `TILT=INCLUDE`, or the text of a TILT file).
fn tilt_data(n: &mut Numbers<'_>) -> Result<(Vec<f64>, Vec<f64>)> {
    let line = n.line();
    let geometry = n.next("the lamp-to-luminaire geometry")?;
    if ![1.0, 2.0, 3.0].contains(&geometry) {
        return Err(parse_error(
            n.what,
            line,
            format!("the lamp-to-luminaire geometry is {geometry}: it must be 1, 2 or 3"),
        ));
    }
    let pairs = n.count("the number of TILT angle-factor pairs", MAX_ANGLES)?;
    if pairs == 0 {
        return Err(parse_error(
            n.what,
            line,
            "the TILT data has no angle-factor pairs",
        ));
    }
    let at = n.line();
    let angles = n.list(pairs, "TILT angle")?;
    let factors = n.list(pairs, "TILT factor")?;
    if let Some(i) = (1..pairs).find(|&i| angles[i] <= angles[i - 1]) {
        return Err(parse_error(
            n.what,
            at,
            format!(
                "TILT angles must increase: angle {} ({}°) follows {}°",
                i + 1,
                angles[i],
                angles[i - 1]
            ),
        ));
    }
    if let Some(f) = factors.iter().find(|f| **f < 0.0) {
        return Err(parse_error(
            n.what,
            at,
            format!("TILT factor {f} is negative"),
        ));
    }
    if let Some(a) = angles.iter().find(|a| !(0.0..=180.0).contains(*a)) {
        return Err(parse_error(
            n.what,
            at,
            format!("TILT angle {a}° is outside 0–180°"),
        ));
    }
    Ok((angles, factors))
}

/// Parses an IES file. `tilt` is the text of the TILT file when the file says
/// `TILT=<file name>`.
pub fn parse(text: &str, tilt: Option<&str>) -> Result<IesFile> {
    parse_within(text, tilt, &|_| Ok(()))
}

/// `parse`, asking `reserve` for the bytes the table will take (read and expanded to the
/// sphere, `gonio::table_bytes`) as soon as the angles are known, before any candela value
/// is stored: a memory budget refuses a huge file before it is read.
pub fn parse_within(
    text: &str,
    tilt: Option<&str>,
    reserve: &dyn Fn(u64) -> Result<()>,
) -> Result<IesFile> {
    const W: &str = "IES";
    // The format line and keywords, up to TILT=.
    let mut format = String::new();
    let mut keywords = Vec::new();
    let mut tilt_at = None;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim_start_matches('\u{feff}').trim();
        let upper = t.to_ascii_uppercase();
        if upper.starts_with("TILT") && upper[4..].trim_start().starts_with('=') {
            tilt_at = Some((i, t));
            break;
        }
        if i == 0 && (upper.starts_with("IESNA") || upper.starts_with("IES:")) {
            format = t.to_string();
        } else if let Some(rest) = t.strip_prefix('[') {
            if let Some(end) = rest.find(']') {
                keywords.push((rest[..end].to_string(), rest[end + 1..].trim().to_string()));
            }
        }
    }
    let Some((tilt_at, tilt_line)) = tilt_at else {
        return Err(parse_error(
            W,
            text.lines().count().max(1),
            "no TILT= line: an LM-63 file gives TILT=NONE, TILT=INCLUDE or TILT=<file> before its photometric data",
        ));
    };
    let upper = format.to_ascii_uppercase();
    let old_format = upper.is_empty() || upper.starts_with("IESNA91");
    let tilt_value = tilt_line[tilt_line.find('=').expect("found above") + 1..].trim();
    let mut n = Numbers::new(
        W,
        text.lines()
            .enumerate()
            .skip(tilt_at + 1)
            .map(|(i, l)| (i + 1, l)),
    );
    let tilt_table = match tilt_value.to_ascii_uppercase().as_str() {
        "NONE" => None,
        "INCLUDE" => Some(tilt_data(&mut n)?),
        _ => match tilt {
            Some(t) => {
                let mut tn =
                    Numbers::new("TILT file", t.lines().enumerate().map(|(i, l)| (i + 1, l)));
                let data = tilt_data(&mut tn)?;
                if let Some((t, line)) = tn.rest() {
                    return Err(parse_error(
                        "TILT file",
                        line,
                        format!("'{}' after the TILT data", printable(t)),
                    ));
                }
                Some(data)
            }
            None => {
                return Err(parse_error(
                    W,
                    tilt_at + 1,
                    format!(
                        "the TILT data is in the file '{}': pass that file's text as the TILT text",
                        printable(tilt_value)
                    ),
                ))
            }
        },
    };

    let lamps = n.next("the number of lamps")?;
    let lumens_per_lamp = n.next("the lumens per lamp")?;
    let mult_line = n.line();
    let multiplier = n.next("the candela multiplier")?;
    let nv = n.count("the number of vertical angles", MAX_ANGLES)?;
    let nh = n.count("the number of horizontal angles", MAX_ANGLES)?;
    let type_line = n.line();
    let ptype = n.next("the photometric type")?;
    let units_line = n.line();
    let units = n.next("the units type")?;
    let width = n.next("the luminous opening's width")?;
    let length = n.next("the luminous opening's length")?;
    let height = n.next("the luminous opening's height")?;
    let bf_line = n.line();
    let ballast_factor = n.next("the ballast factor")?;
    let field2 = n.next("the ballast-lamp photometric factor / file generation type")?;
    let input_watts = n.next("the input watts")?;

    let kind = match ptype {
        1.0 => PhotometricType::C,
        2.0 => PhotometricType::B,
        3.0 => {
            return Err(Error::new(
                ImapStatus::ImapErrUnsupported,
                format!("IES line {type_line}: photometric type A (3) is not supported: only types C (1) and B (2)"),
            ))
        }
        t => {
            return Err(parse_error(
                W,
                type_line,
                format!("the photometric type is {t}: it must be 1 (C), 2 (B) or 3 (A)"),
            ))
        }
    };
    let metres = match units {
        1.0 => 0.3048,
        2.0 => 1.0,
        u => {
            return Err(parse_error(
                W,
                units_line,
                format!("the units type is {u}: it must be 1 (feet) or 2 (metres)"),
            ))
        }
    };
    if multiplier <= 0.0 {
        return Err(parse_error(
            W,
            mult_line,
            format!("the candela multiplier is {multiplier}: it must be positive"),
        ));
    }
    if ballast_factor <= 0.0 {
        return Err(parse_error(
            W,
            bf_line,
            format!("the ballast factor is {ballast_factor}: it must be positive"),
        ));
    }
    let ballast_lamp_factor = if old_format { field2 } else { 1.0 };
    if ballast_lamp_factor <= 0.0 {
        return Err(parse_error(
            W,
            bf_line,
            format!(
                "the ballast-lamp photometric factor is {ballast_lamp_factor}: it must be positive"
            ),
        ));
    }
    if nv < 2 || nh < 1 {
        return Err(parse_error(
            W,
            mult_line,
            format!("{nv} vertical and {nh} horizontal angles: a distribution needs at least 2 vertical angles and 1 horizontal"),
        ));
    }
    if nv.saturating_mul(nh) > MAX_VALUES {
        return Err(parse_error(
            W,
            mult_line,
            format!("{nv} × {nh} candela values is more than {MAX_VALUES}"),
        ));
    }
    let v_line = n.line();
    let vertical = n.angles(nv, "vertical", mult_line)?;
    let h_line = n.line();
    let horizontal = n.angles(nh, "horizontal", mult_line)?;
    {
        // The symmetry decides how far the table expands (the worst case when the angles
        // are wrong: that error is reported below, with its line).
        let sym = Symmetry::infer(kind, &horizontal).unwrap_or(Symmetry::Quadrant);
        let expanded = super::gonio::expanded_values(kind, sym, nv, nh);
        reserve(super::gonio::table_bytes((nv * nh) as u64, expanded).0)?;
    }
    let c_line = n.line();
    let scale = multiplier * ballast_factor * ballast_lamp_factor;
    let mut candela = Vec::with_capacity(nh);
    for (h, angle) in horizontal.iter().enumerate() {
        let mut row = Vec::with_capacity(nv);
        for (v, va) in vertical.iter().enumerate() {
            let line = n.line();
            let x = n.next(&format!(
                "candela value {} of {nv} for horizontal angle {angle}° (row {} of {nh})",
                v + 1,
                h + 1
            ))?;
            if x < 0.0 {
                return Err(parse_error(
                    W,
                    line,
                    format!("candela value {x} (horizontal angle {angle}°, vertical angle {va}°) is negative"),
                ));
            }
            row.push(x * scale);
        }
        candela.push(row);
    }
    if let Some((t, line)) = n.rest() {
        return Err(parse_error(
            W,
            line,
            format!(
                "'{}' after the {nh} × {nv} candela values: the angle counts on line {mult_line} do not match the data",
                printable(t)
            ),
        ));
    }
    match kind {
        PhotometricType::C => {
            let (v0, v1) = (vertical[0], vertical[nv - 1]);
            if v0 < 0.0 || v1 > 180.0 {
                return Err(parse_error(
                    W,
                    v_line,
                    format!(
                        "type C vertical angles run from {v0}° to {v1}°: they must lie in 0–180°"
                    ),
                ));
            }
        }
        PhotometricType::B => {
            let (v0, v1) = (vertical[0], vertical[nv - 1]);
            if v0 < -90.0 || v1 > 90.0 {
                return Err(parse_error(
                    W,
                    v_line,
                    format!(
                        "type B vertical angles run from {v0}° to {v1}°: they must lie in −90–90°"
                    ),
                ));
            }
        }
    }
    let symmetry = Symmetry::infer(kind, &horizontal).map_err(|why| parse_error(W, h_line, why))?;
    let _ = c_line;
    // The luminous opening (LM-63-2019 table of shapes; width along C90–C270, length
    // along C0–C180).
    let (w, l, h) = (width * metres, length * metres, height * metres);
    let solid = |what| Opening::Solid {
        what,
        width: w,
        length: l,
        height: h,
    };
    let opening = match (w, l, h) {
        (w, l, h) if w == 0.0 && l == 0.0 && h == 0.0 => Opening::Point,
        (w, l, h) if w > 0.0 && l > 0.0 && h == 0.0 => Opening::Rectangle {
            width: w,
            length: l,
        },
        (w, l, h) if w < 0.0 && l == 0.0 && h == 0.0 => Opening::Ellipse {
            width: -w,
            length: -w,
        },
        (w, l, h) if w < 0.0 && l < 0.0 && h == 0.0 => Opening::Ellipse {
            width: -w,
            length: -l,
        },
        (w, l, h) if w > 0.0 && l > 0.0 && h > 0.0 => solid("box with luminous sides"),
        (w, l, h) if w < 0.0 && l < 0.0 && h < 0.0 => solid("sphere or ellipsoid"),
        (_, _, h) if h != 0.0 => solid("cylinder"),
        _ => solid("shape LM-63 does not define"),
    };
    let data = PhotometricData {
        kind,
        vertical,
        horizontal,
        candela,
        symmetry,
        tilt: tilt_table,
        opening,
        cct_k: None,
    };
    data.validate()
        .map_err(|e| parse_error(W, c_line, e.message))?;
    Ok(IesFile {
        format,
        keywords,
        lamps,
        lumens_per_lamp,
        multiplier,
        ballast_factor,
        ballast_lamp_factor,
        input_watts,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const COSINE: &str = "IESNA:LM-63-2002\n[TEST] cosine\nTILT=NONE\n1 -1 2.0 3 1 1 2 0 0 0\n0.5 1 10\n0 45 90\n0\n1000 707.1068 0\n";

    #[test]
    fn reads_a_small_file_with_its_factors() {
        let f = parse(COSINE, None).unwrap();
        assert_eq!(f.keywords, vec![("TEST".into(), "cosine".into())]);
        assert_eq!(f.data.symmetry, Symmetry::Rotational);
        // multiplier 2 × ballast factor 0.5; the 2002 format's second field is not a factor.
        assert_eq!(f.data.candela[0][0], 1000.0);
        assert_eq!(f.ballast_lamp_factor, 1.0);
        let old = COSINE
            .replace("IESNA:LM-63-2002\n", "IESNA91\n")
            .replace("0.5 1 10", "0.5 0.8 10");
        let f = parse(&old, None).unwrap();
        assert!((f.data.candela[0][0] - 800.0).abs() < 1e-9);
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            (
                COSINE.replace("1000 707.1068 0\n", "1000 707.1068\n"),
                "line 8",
                "ends before",
            ),
            (
                COSINE.replace("0 45 90", "0 90 45"),
                "line 6",
                "must increase",
            ),
            (COSINE.replace("707.1068", "NaN"), "line 8", "finite"),
            (
                COSINE.replace("TILT=NONE", "TILT=lamp.tlt"),
                "line 3",
                "lamp.tlt",
            ),
            (
                COSINE.replace("2.0 3 1 1 2", "2.0 2 1 1 2"),
                "line 8",
                "do not match",
            ),
            (COSINE.replace("TILT=NONE\n", ""), "line", "TILT"),
            (COSINE.replace("1 -1 2.0", "1 -1 x"), "line 4", "'x'"),
        ];
        for (text, line, what) in cases {
            let e = parse(&text, None).unwrap_err();
            assert_eq!(e.status, ImapStatus::ImapErrParse, "{e}");
            assert!(e.message.contains(line) && e.message.contains(what), "{e}");
        }
        let a = COSINE.replace("3 1 1 2", "3 1 3 2");
        assert_eq!(
            parse(&a, None).unwrap_err().status,
            ImapStatus::ImapErrUnsupported
        );
    }

    #[test]
    fn tilt_include_and_tilt_files() {
        let inc = COSINE.replace("TILT=NONE\n", "TILT=INCLUDE\n1\n3\n0 45 90\n1 0.9 0.5\n");
        let f = parse(&inc, None).unwrap();
        assert_eq!(
            f.data.tilt,
            Some((vec![0.0, 45.0, 90.0], vec![1.0, 0.9, 0.5]))
        );
        assert!((f.data.tilt_factor(22.5) - 0.95).abs() < 1e-12);
        let ext = COSINE.replace("TILT=NONE", "TILT=a.tlt");
        let f = parse(&ext, Some("1\n2\n0 90\n1 0.5\n")).unwrap();
        assert_eq!(f.data.tilt_factor(45.0), 0.75);
        let e = parse(&ext, Some("1\n2\n0 90\n1\n")).unwrap_err();
        assert!(e.message.starts_with("TILT file line 4"), "{e}");
    }
}
