//! Window BSDF files: LBNL WINDOW / Radiance BSDF XML in a Klems angle basis (full 145,
//! half 77, quarter 41 patches, or a basis the file defines), front and back, reflection and
//! transmission.
//!
//! A Klems basis splits each hemisphere into rings of polar angle, each ring into equal
//! azimuth patches centred on φ = 360° · k / n. A matrix holds one value (the BSDF, 1/sr)
//! per (incident patch, outgoing patch): constant over both patches.
//!
//! Orientation (as Radiance's libBSDF reads these files): a direction's patch is that of its
//! direction of travel, (x, y) in the surface's frame and |z|, whichever side it is on; the
//! frame's y is the up direction (the material's `tangent`) projected onto the surface, its
//! x is normal × up, the normal pointing to the file's *front* side (WINDOW's front: the
//! exterior of a window). Light travelling straight through keeps its patch, so a clear
//! pane's transmission matrix is diagonal; a specular reflection keeps it too. (Radiance's
//! own BSDF primitive points its normal to WINDOW's back, into the room: the same frame with
//! the normal reversed.)
//!
//! Missing data: without "Transmission Back" the back's transmission is the front's by
//! reciprocity (a row that would then send on more than arrives, from a file that is not
//! reciprocal, is scaled down); without a reflection matrix that side reflects nothing.
//! Only `Visible` data are read (the same value in every band): Solar and NIR blocks are
//! skipped, and so are Radiance's CIE-X and CIE-Z colour blocks. Tensor-tree files are
//! refused as unsupported.
//!
//! Sampling: an incident patch's row is an alias table over (reflect or transmit, outgoing
//! patch) ∝ value × the patch's projected solid angle Λ, and a direction is drawn uniformly
//! in projected solid angle inside the patch: f cos / pdf is the row's albedo, exactly.

use crate::error::{bail, Error, ImapStatus, Result};
use crate::sampling::AliasTable;
use crate::scene::table::TableCheck;
use glam::DVec3;
use std::f64::consts::PI;
use std::path::Path;

/// One ring of patches: polar angles [lo, hi) in radians, `n` azimuth patches, the first
/// patch's index.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ring {
    lo: f64,
    hi: f64,
    n: usize,
    first: usize,
}

/// A Klems angle basis.
#[derive(Clone, Debug, PartialEq)]
pub struct KlemsBasis {
    rings: Vec<Ring>,
    patches: usize,
}

impl KlemsBasis {
    /// From ring lower bounds in degrees (the last one's upper bound is 90°) and patch
    /// counts; None when they are not a basis.
    fn from_rings(rings: &[(f64, f64, usize)]) -> Option<KlemsBasis> {
        let mut out = Vec::with_capacity(rings.len());
        let mut first = 0;
        let mut prev = 0.0;
        for &(lo, hi, n) in rings {
            if n == 0 || !(lo >= 0.0 && hi > lo && hi <= 90.0 + 1e-9) || (lo - prev).abs() > 1e-6 {
                return None;
            }
            out.push(Ring {
                lo: lo.to_radians(),
                hi: hi.to_radians(),
                n,
                first,
            });
            first += n;
            prev = hi;
        }
        if out.is_empty() || out[0].lo != 0.0 || (prev - 90.0).abs() > 1e-6 {
            return None;
        }
        if let Some(last) = out.last_mut() {
            last.hi = 0.5 * PI;
        }
        Some(KlemsBasis {
            rings: out,
            patches: first,
        })
    }

    /// The bases WINDOW and Radiance know by name.
    pub fn named(name: &str) -> Option<KlemsBasis> {
        let lows: &[(f64, usize)] = match name.trim().to_ascii_lowercase().as_str() {
            "lbnl/klems full" => &[
                (0.0, 1),
                (5.0, 8),
                (15.0, 16),
                (25.0, 20),
                (35.0, 24),
                (45.0, 24),
                (55.0, 24),
                (65.0, 16),
                (75.0, 12),
            ],
            "lbnl/klems half" => &[
                (0.0, 1),
                (6.5, 8),
                (19.5, 12),
                (32.5, 16),
                (45.5, 20),
                (58.5, 12),
                (71.5, 8),
            ],
            "lbnl/klems quarter" => &[(0.0, 1), (9.0, 8), (27.0, 12), (45.0, 12), (63.0, 8)],
            _ => return None,
        };
        let rings: Vec<(f64, f64, usize)> = lows
            .iter()
            .enumerate()
            .map(|(i, &(lo, n))| (lo, lows.get(i + 1).map_or(90.0, |r| r.0), n))
            .collect();
        Self::from_rings(&rings)
    }

    /// How many patches.
    #[inline]
    pub fn len(&self) -> usize {
        self.patches
    }

    /// The ring and azimuth index of patch `p`.
    #[inline]
    fn locate(&self, p: usize) -> (Ring, usize) {
        let r = self
            .rings
            .iter()
            .rev()
            .find(|r| r.first <= p)
            .copied()
            .unwrap_or(self.rings[0]);
        (r, p - r.first)
    }

    /// The patch of a direction with components (x, y) in the basis' frame and cosine
    /// `cos` (≥ 0) to the normal.
    #[inline]
    pub fn index(&self, x: f64, y: f64, cos: f64) -> usize {
        let theta = cos.clamp(0.0, 1.0).acos();
        let ring = self
            .rings
            .iter()
            .rev()
            .find(|r| r.lo <= theta)
            .copied()
            .unwrap_or(self.rings[0]);
        let phi = y.atan2(x).rem_euclid(2.0 * PI);
        let k = (phi / (2.0 * PI) * ring.n as f64 + 0.5) as usize % ring.n;
        ring.first + k
    }

    /// The projected solid angle Λ of patch `p`: π (cos²θ_lo − cos²θ_hi) / n.
    #[inline]
    pub fn lambda(&self, p: usize) -> f64 {
        let (r, _) = self.locate(p);
        PI * (r.lo.cos().powi(2) - r.hi.cos().powi(2)) / r.n as f64
    }

    /// The patch opposite `p` in azimuth (φ + 180°): the same ring.
    #[inline]
    fn opposite(&self, p: usize) -> usize {
        // (An odd ring has no opposite patch: the nearest one; a one-patch cap is its own.)
        let (r, k) = self.locate(p);
        r.first + (k + r.n / 2) % r.n
    }

    /// A direction (x, y, cos) uniform in projected solid angle inside patch `p`.
    #[inline]
    fn sample_in(&self, p: usize, u1: f64, u2: f64) -> (f64, f64, f64) {
        let (r, k) = self.locate(p);
        let (a, b) = (r.lo.sin().powi(2), r.hi.sin().powi(2));
        let s2 = a + (b - a) * u1;
        let (sin, cos) = (s2.sqrt(), (1.0 - s2).max(0.0).sqrt());
        let phi = 2.0 * PI * (k as f64 + u2 - 0.5) / r.n as f64;
        (sin * phi.cos(), sin * phi.sin(), cos)
    }

    /// Patch `p`'s centre (θ, φ) in degrees, for messages.
    pub fn centre_deg(&self, p: usize) -> (f64, f64) {
        let (r, k) = self.locate(p);
        let theta = if r.lo == 0.0 {
            0.0
        } else {
            0.5 * (r.lo + r.hi).to_degrees()
        };
        (theta, 360.0 * k as f64 / r.n as f64)
    }
}

/// The largest BSDF file read (bytes): 64 MiB, sixty times a Klems full file's four
/// matrices written out.
const MAX_FILE_BYTES: u64 = 64 << 20;

/// Which matrices: [incident side: front, back][reflection, transmission].
const SIDES: [&str; 2] = ["Front", "Back"];
const KINDS: [&str; 2] = ["Reflection", "Transmission"];

/// A window BSDF in a Klems basis, checked, with its sampling rows.
#[derive(Debug)]
pub struct KlemsBsdf {
    basis: KlemsBasis,
    /// [side][kind]: n × n values (incident-major), or empty when absent.
    m: [[Vec<f64>; 2]; 2],
    /// [side]: per incident patch, the distribution over (kind, outgoing patch).
    rows: [Vec<Option<AliasTable>>; 2],
    /// The largest value (1/sr): how sharp its lobes are.
    pub peak: f64,
    pub check: TableCheck,
}

/// A direction's (x, y) in the basis' frame from the local frame at a hit (x: the
/// tangent = up, y: n_in × up): the basis' y is up, its x is normal × up with the
/// normal to the front.
#[inline]
fn basis_xy(v: DVec3, front: bool) -> (f64, f64) {
    (if front { v.y } else { -v.y }, v.x)
}

/// The local direction at a hit from the basis' (x, y) and a signed z.
#[inline]
fn local_from(x: f64, y: f64, z: f64, front: bool) -> DVec3 {
    DVec3::new(y, if front { x } else { -x }, z)
}

impl KlemsBsdf {
    /// Builds from matrices ([side][kind], incident-major, empty when absent); `name` names
    /// the source in messages.
    pub fn new(basis: KlemsBasis, mut m: [[Vec<f64>; 2]; 2], name: &str) -> Result<KlemsBsdf> {
        let n = basis.len();
        for s in 0..2 {
            for k in 0..2 {
                let v = &m[s][k];
                if v.is_empty() {
                    continue;
                }
                if v.len() != n * n {
                    bail!(
                        ImapErrInvalidArgument,
                        "{name}: {} {} has {} values; the basis of {n} patches needs {}",
                        KINDS[k],
                        SIDES[s],
                        v.len(),
                        n * n
                    );
                }
                if let Some(i) = v.iter().position(|x| !x.is_finite() || *x < 0.0) {
                    let (ti, pi) = basis.centre_deg(i / n);
                    let (to, po) = basis.centre_deg(i % n);
                    bail!(
                        ImapErrBadMaterial,
                        "{name}: {} {} from θ {ti}° φ {pi}° to θ {to}° φ {po}° is {} (values must be finite and >= 0)",
                        KINDS[k],
                        SIDES[s],
                        v[i]
                    );
                }
            }
        }
        if m.iter().flatten().all(Vec::is_empty) {
            bail!(
                ImapErrParse,
                "{name}: no Visible reflection or transmission data"
            );
        }
        // The back's transmission by reciprocity when only the front's is given (and the
        // other way round): T_b(i → o) = T_f(o' → i'), ' the opposite azimuth.
        let mut derived = [false; 2];
        for s in 0..2 {
            if m[s][1].is_empty() && !m[1 - s][1].is_empty() {
                derived[s] = true;
                let other = &m[1 - s][1];
                let mut v = vec![0.0; n * n];
                for i in 0..n {
                    for o in 0..n {
                        v[i * n + o] = other[basis.opposite(o) * n + basis.opposite(i)];
                    }
                }
                m[s][1] = v;
            }
        }
        let lambda: Vec<f64> = (0..n).map(|p| basis.lambda(p)).collect();
        let mut check = TableCheck::default();
        let mut rows: [Vec<Option<AliasTable>>; 2] = [Vec::new(), Vec::new()];
        for s in 0..2 {
            for i in 0..n {
                let weights: Vec<f64> = (0..2)
                    .flat_map(|k| {
                        let v = &m[s][k];
                        (0..n).map(move |o| if v.is_empty() { 0.0 } else { v[i * n + o] })
                    })
                    .zip(lambda.iter().chain(&lambda))
                    .map(|(f, l)| f * l)
                    .collect();
                let mut weights = weights;
                let mut albedo: f64 = weights.iter().sum();
                if albedo > 1.0 && derived[s] {
                    // A transmission derived by reciprocity from a file that is not
                    // reciprocal can send on more than arrives: scaled down to what the
                    // reflection leaves (the file's own values are checked below).
                    let r: f64 = weights[..n].iter().sum();
                    let k = ((1.0 - r) / (albedo - r)).max(0.0);
                    for o in 0..n {
                        weights[n + o] *= k;
                        m[s][1][i * n + o] *= k;
                    }
                    albedo = weights.iter().sum();
                }
                check.worst_albedo = check.worst_albedo.max(albedo);
                if albedo > 1.01 {
                    let (t, p) = basis.centre_deg(i);
                    bail!(
                        ImapErrBadMaterial,
                        "{name}: light arriving on the {} side in the patch at θ {t}° φ {p}° leaves with {albedo:.4} of its power (reflection + transmission > 1: energy would be created)",
                        SIDES[s].to_ascii_lowercase()
                    );
                }
                rows[s].push(AliasTable::new(&weights).ok());
            }
        }
        // Reciprocity: f(i → o) = f(o' → i') for each reflection, and between the two
        // transmissions (relative to their mean, over values above 1 % of the peak).
        let peak = m.iter().flatten().flatten().cloned().fold(0.0, f64::max);
        let mut worst = 0.0f64;
        for (a, b) in [
            (&m[0][0], &m[0][0]),
            (&m[1][0], &m[1][0]),
            (&m[0][1], &m[1][1]),
        ] {
            if a.is_empty() || b.is_empty() {
                continue;
            }
            for i in 0..n {
                for o in 0..n {
                    let x = a[i * n + o];
                    let y = b[basis.opposite(o) * n + basis.opposite(i)];
                    if x.max(y) > 0.01 * peak {
                        worst = worst.max((x - y).abs() / (0.5 * (x + y)));
                    }
                }
            }
        }
        check.worst_reciprocity = worst;
        Ok(KlemsBsdf {
            basis,
            m,
            rows,
            peak,
            check,
        })
    }

    /// Reads a BSDF XML file.
    pub fn read(path: &Path) -> Result<KlemsBsdf> {
        // A Klems full file of four matrices is about 1 MB; a file far larger is not one
        // (and reading it whole could exhaust the host's memory).
        let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        if len > MAX_FILE_BYTES {
            bail!(
                ImapErrInvalidArgument,
                "bsdf_xml_path {}: {len} bytes is more than a BSDF file holds (at most {MAX_FILE_BYTES})",
                path.display()
            );
        }
        let text = std::fs::read_to_string(path).map_err(|e| {
            Error::new(
                ImapStatus::ImapErrIo,
                format!("bsdf_xml_path {}: {e}", path.display()),
            )
        })?;
        let name = path.display().to_string();
        let (basis, m) = parse_xml(&text, &name)?;
        Self::new(basis, m, &name)
    }

    /// Whether it transmits.
    #[inline]
    pub fn transmits(&self) -> bool {
        !self.m[0][1].is_empty() || !self.m[1][1].is_empty()
    }

    /// The incident patch of light arriving from local `wo` (z > 0).
    #[inline]
    fn incident(&self, wo: DVec3, front: bool) -> usize {
        let (x, y) = basis_xy(-wo, front);
        self.basis.index(x, y, wo.z)
    }

    /// f(wo → wi) into every band of `out`; `front` whether `wo` is on the front side.
    pub fn eval(&self, wo: DVec3, wi: DVec3, front: bool, out: &mut [f64]) {
        let v = self.value(wo, wi, front);
        out.iter_mut().for_each(|x| *x = v);
    }

    fn value(&self, wo: DVec3, wi: DVec3, front: bool) -> f64 {
        let kind = usize::from(wi.z < 0.0);
        let m = &self.m[usize::from(!front)][kind];
        if wo.z <= 0.0 || wi.z == 0.0 || m.is_empty() {
            return 0.0;
        }
        let n = self.basis.len();
        let i = self.incident(wo, front);
        let (x, y) = basis_xy(wi, front);
        m[i * n + self.basis.index(x, y, wi.z.abs())]
    }

    /// The density of `sample`'s direction.
    pub fn pdf(&self, wo: DVec3, wi: DVec3, front: bool) -> f64 {
        if wo.z <= 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let n = self.basis.len();
        let i = self.incident(wo, front);
        let Some(row) = &self.rows[usize::from(!front)][i] else {
            return 0.0;
        };
        let (x, y) = basis_xy(wi, front);
        let o = self.basis.index(x, y, wi.z.abs());
        row.pdf(usize::from(wi.z < 0.0) * n + o) * wi.z.abs() / self.basis.lambda(o)
    }

    /// A direction for light from `wo`, from three uniform numbers.
    pub fn sample(&self, wo: DVec3, u: [f64; 3], front: bool) -> Option<DVec3> {
        if wo.z <= 0.0 {
            return None;
        }
        let n = self.basis.len();
        let i = self.incident(wo, front);
        let cell = self.rows[usize::from(!front)][i].as_ref()?.sample(u[0]);
        let (x, y, c) = self.basis.sample_in(cell % n, u[1], u[2]);
        let z = if cell < n { c } else { -c };
        let wi = local_from(x, y, z, front);
        (wi.z != 0.0).then_some(wi)
    }
}

/// The first child element of `node` named `tag` (any case, any namespace).
fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name().eq_ignore_ascii_case(tag))
}

/// The trimmed text of `node`'s child `tag`.
fn txt(node: roxmltree::Node, tag: &str) -> Option<String> {
    child(node, tag).map(|c| c.text().unwrap_or("").trim().to_owned())
}

/// Reads the XML text: its basis and matrices [side][kind] (incident-major).
fn parse_xml(text: &str, name: &str) -> Result<(KlemsBasis, [[Vec<f64>; 2]; 2])> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
        let p = e.pos();
        Error::new(
            ImapStatus::ImapErrParse,
            format!("{name}:{}: not XML: {e}", p.row),
        )
    })?;
    let line = |node: roxmltree::Node| doc.text_pos_at(node.range().start).row;
    let root = doc.root_element();
    let layer = root
        .descendants()
        .find(|d| d.is_element() && d.tag_name().name() == "Layer");
    let Some(layer) = layer else {
        bail!(
            ImapErrParse,
            "{name}:{}: no <Layer> (not a WINDOW BSDF file)",
            line(root)
        );
    };
    let Some(def) = child(layer, "DataDefinition") else {
        bail!(
            ImapErrParse,
            "{name}:{}: <Layer> has no <DataDefinition>",
            line(layer)
        );
    };
    let structure = txt(def, "IncidentDataStructure").unwrap_or_default();
    let rows_incident = match structure.to_ascii_lowercase().as_str() {
        "columns" => false,
        "rows" => true,
        s if s.starts_with("tensortree") => bail!(
            ImapErrUnsupported,
            "{name}:{}: a tensor-tree BSDF ({structure}) is not supported: give a Klems matrix file (Radiance's bsdf2klems converts one)",
            line(def)
        ),
        _ => bail!(
            ImapErrParse,
            "{name}:{}: IncidentDataStructure '{structure}' is neither Columns nor Rows",
            line(def)
        ),
    };
    // Bases the file defines (usually the full Klems basis written out).
    let mut defined: Vec<(String, KlemsBasis)> = Vec::new();
    for ab in def
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "AngleBasis")
    {
        let bname = txt(ab, "AngleBasisName").unwrap_or_default();
        let mut rings = Vec::new();
        for block in ab
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "AngleBasisBlock")
        {
            let num = |node: Option<roxmltree::Node>, what: &str| -> Result<f64> {
                let v = node
                    .and_then(|n| n.text())
                    .and_then(|t| t.trim().parse::<f64>().ok());
                v.ok_or_else(|| {
                    Error::new(
                        ImapStatus::ImapErrParse,
                        format!(
                            "{name}:{}: AngleBasisBlock needs a number in <{what}>",
                            line(block)
                        ),
                    )
                })
            };
            let nphi = num(child(block, "nPhis"), "nPhis")?;
            let bounds = child(block, "ThetaBounds");
            let lo = num(bounds.and_then(|b| child(b, "LowerTheta")), "LowerTheta")?;
            let hi = num(bounds.and_then(|b| child(b, "UpperTheta")), "UpperTheta")?;
            if !(nphi >= 1.0 && nphi.fract() == 0.0 && nphi <= 10_000.0) {
                bail!(ImapErrParse, "{name}:{}: nPhis = {nphi}", line(block));
            }
            rings.push((lo, hi, nphi as usize));
        }
        match KlemsBasis::from_rings(&rings) {
            Some(b) => defined.push((bname, b)),
            None => bail!(
                ImapErrParse,
                "{name}:{}: angle basis '{bname}' does not cover 0–90° in increasing rings",
                line(ab)
            ),
        }
    }
    let basis_of = |node: roxmltree::Node, tag: &str| -> Result<KlemsBasis> {
        let b = txt(node, tag).unwrap_or_default();
        if let Some((_, d)) = defined.iter().find(|(n, _)| n.eq_ignore_ascii_case(&b)) {
            return Ok(d.clone());
        }
        KlemsBasis::named(&b).ok_or_else(|| {
            Error::new(
                ImapStatus::ImapErrUnsupported,
                format!(
                    "{name}:{}: unknown angle basis '{b}' in <{tag}>",
                    line(node)
                ),
            )
        })
    };
    let mut basis: Option<KlemsBasis> = None;
    let mut m: [[Vec<f64>; 2]; 2] = Default::default();
    for wd in layer
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "WavelengthData")
    {
        let wl = txt(wd, "Wavelength").unwrap_or_default();
        if !wl.eq_ignore_ascii_case("visible") {
            continue;
        }
        for block in wd
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "WavelengthDataBlock")
        {
            let dir = txt(block, "WavelengthDataDirection").unwrap_or_default();
            let words: Vec<String> = dir
                .split_whitespace()
                .map(|w| w.to_ascii_lowercase())
                .collect();
            let (kind, side) = match words.iter().map(String::as_str).collect::<Vec<_>>()[..] {
                ["reflection", "front"] => (0, 0),
                ["reflection", "back"] => (0, 1),
                ["transmission", "front"] => (1, 0),
                ["transmission", "back"] => (1, 1),
                _ => bail!(
                    ImapErrParse,
                    "{name}:{}: WavelengthDataDirection '{dir}' is not Reflection/Transmission Front/Back",
                    line(block)
                ),
            };
            let cols = basis_of(block, "ColumnAngleBasis")?;
            let rows = basis_of(block, "RowAngleBasis")?;
            if cols != rows {
                bail!(
                    ImapErrUnsupported,
                    "{name}:{}: row and column angle bases differ: not supported",
                    line(block)
                );
            }
            if let Some(b) = &basis {
                if *b != cols {
                    bail!(
                        ImapErrUnsupported,
                        "{name}:{}: the blocks use different angle bases: not supported",
                        line(block)
                    );
                }
            }
            let n = cols.len();
            let Some(data) = child(block, "ScatteringData") else {
                bail!(ImapErrParse, "{name}:{}: no <ScatteringData>", line(block));
            };
            let start = data
                .first_child()
                .map_or(data.range().start, |t| t.range().start);
            let body = data.text().unwrap_or("");
            let mut values = Vec::with_capacity(n * n);
            let mut offset = 0;
            for tok in body.split(|c: char| c == ',' || c.is_whitespace()) {
                let at = offset;
                offset += tok.len() + 1;
                if tok.is_empty() {
                    continue;
                }
                match tok.parse::<f64>() {
                    Ok(v) if v.is_finite() => values.push(v),
                    _ => bail!(
                        ImapErrParse,
                        "{name}:{}: ScatteringData value '{tok}' is not a finite number",
                        doc.text_pos_at(start + at).row
                    ),
                }
            }
            if values.len() != n * n {
                bail!(
                    ImapErrParse,
                    "{name}:{}: ScatteringData holds {} values; a {n}-patch basis needs {}",
                    line(data),
                    values.len(),
                    n * n
                );
            }
            if let Some(i) = values.iter().position(|&v| v < 0.0) {
                bail!(
                    ImapErrBadMaterial,
                    "{name}:{}: ScatteringData value {} is negative",
                    line(data),
                    values[i]
                );
            }
            // Incident-major: the file's rows are outgoing patches when incident data are
            // in columns.
            let v = if rows_incident {
                values
            } else {
                let mut t = vec![0.0; n * n];
                for r in 0..n {
                    for c in 0..n {
                        t[c * n + r] = values[r * n + c];
                    }
                }
                t
            };
            m[side][kind] = v;
            basis = Some(cols);
        }
    }
    let Some(basis) = basis else {
        bail!(
            ImapErrParse,
            "{name}:{}: no Visible WavelengthData block (Solar and NIR data are not light)",
            line(layer)
        );
    };
    Ok((basis, m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;
    use crate::scene::microfacet::Frame;

    /// Writes a WINDOW-style XML (incident data in columns) from matrices [side][kind],
    /// incident-major.
    pub(crate) fn xml(m: &[[Option<Vec<f64>>; 2]; 2], n_basis: &str) -> String {
        let b = KlemsBasis::named(n_basis).unwrap();
        let n = b.len();
        let mut s = String::from(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\">\n<FileType>BSDF</FileType>\n<Optical>\n<Layer>\n<Material><Name>test</Name></Material>\n<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>\n<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength>\n",
        );
        for (side, row) in m.iter().enumerate() {
            for (kind, v) in row.iter().enumerate() {
                let Some(v) = v else { continue };
                s += &format!(
                    "<WavelengthDataBlock><WavelengthDataDirection>{} {}</WavelengthDataDirection><ColumnAngleBasis>{n_basis}</ColumnAngleBasis><RowAngleBasis>{n_basis}</RowAngleBasis><ScatteringDataType>BTDF</ScatteringDataType><ScatteringData>\n",
                    KINDS[kind], SIDES[side]
                );
                for o in 0..n {
                    let line: Vec<String> = (0..n).map(|i| format!("{}", v[i * n + o])).collect();
                    s += &line.join(", ");
                    s += ",\n";
                }
                s += "</ScatteringData></WavelengthDataBlock>\n";
            }
        }
        s += "</WavelengthData>\n</Layer>\n</Optical>\n</WindowElement>\n";
        s
    }

    fn parse(text: &str) -> Result<KlemsBsdf> {
        let (b, m) = parse_xml(text, "t.xml")?;
        KlemsBsdf::new(b, m, "t.xml")
    }

    #[test]
    fn the_full_basis_covers_the_hemisphere() {
        let b = KlemsBasis::named("LBNL/Klems Full").unwrap();
        assert_eq!(b.len(), 145);
        let total: f64 = (0..145).map(|p| b.lambda(p)).sum();
        assert!((total - PI).abs() < 1e-12, "Σ Λ = {total}");
        assert_eq!(KlemsBasis::named("LBNL/Klems Half").unwrap().len(), 77);
        assert_eq!(KlemsBasis::named("LBNL/Klems Quarter").unwrap().len(), 41);
        // Patch centres index to themselves; φ patches are centred on 360° k / n.
        for p in 0..145 {
            let (t, f) = b.centre_deg(p);
            let (t, f) = (t.to_radians(), f.to_radians());
            assert_eq!(b.index(t.sin() * f.cos(), t.sin() * f.sin(), t.cos()), p);
            assert_eq!(b.opposite(b.opposite(p)), p);
        }
        assert_eq!(
            b.index(1.0, -1e-9, 0.0),
            133,
            "φ just under 360° is patch k = 0"
        );
    }

    /// A clear pane: diagonal transmission τ/Λ and reflection ρ/Λ.
    fn clear(tau: f64, rho: f64) -> [[Option<Vec<f64>>; 2]; 2] {
        let b = KlemsBasis::named("LBNL/Klems Full").unwrap();
        let n = b.len();
        let diag = |x: f64| {
            let mut v = vec![0.0; n * n];
            for p in 0..n {
                v[p * n + p] = x / b.lambda(p);
            }
            Some(v)
        };
        [[diag(rho), diag(tau)], [None, None]]
    }

    #[test]
    fn a_clear_pane_goes_straight_through_and_reflects_specularly() {
        let k = parse(&xml(&clear(0.8, 0.1), "LBNL/Klems Full")).unwrap();
        assert!(k.transmits());
        assert!((k.check.worst_albedo - 0.9).abs() < 1e-9);
        let mut rng = PhotonRng::new(3, 0);
        let mut through = 0.0;
        for front in [true, false] {
            let n_in = if front { DVec3::Z } else { -DVec3::Z };
            let frame = Frame::new(n_in, Some(DVec3::Y));
            for _ in 0..2000 {
                // Light travelling along `d` onto the side `n_in` faces.
                let d = DVec3::new(0.3, -0.5, 0.0) - n_in * 0.8;
                let d = d.normalize();
                let wo = frame.to_local(-d);
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                let Some(wi) = k.sample(wo, u, front) else {
                    continue;
                };
                let out = frame.to_world(wi);
                let expect = if wi.z < 0.0 {
                    through += f64::from(u8::from(front));
                    d
                } else {
                    d - n_in * (2.0 * d.dot(n_in))
                };
                // Within the patch (10° rings, 15° azimuths here).
                assert!(
                    out.dot(expect) > (15f64).to_radians().cos(),
                    "{out} vs {expect}"
                );
                // f cos / pdf: the front's albedo; the back only transmits (reciprocity).
                let f = k.value(wo, wi, front);
                let p = k.pdf(wo, wi, front);
                let albedo = if front { 0.9 } else { 0.8 };
                assert!((f * wi.z.abs() / p - albedo).abs() < 1e-9);
            }
        }
        assert!((through / 2000.0 - 0.8 / 0.9).abs() < 0.03);
    }

    #[test]
    fn the_basis_frame_is_radiances() {
        // Every incident patch transmits to one outgoing patch at θ 40°: φ 90° (up) or 0°.
        let b = KlemsBasis::named("LBNL/Klems Full").unwrap();
        let n = b.len();
        let (c40, s40) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
        // A vertical pane whose front (the exterior) faces −y, up +z: the basis' x is
        // normal × up = −x.
        let normal = -DVec3::Y;
        for (phi, toward) in [(90.0f64, DVec3::Z), (0.0, normal.cross(DVec3::Z))] {
            let o = b.index(phi.to_radians().cos(), phi.to_radians().sin(), c40);
            let mut t = vec![0.0; n * n];
            for i in 0..n {
                t[i * n + o] = 0.5 / b.lambda(o);
            }
            let none = vec![0.0; n * n];
            let k = parse(&xml(
                &[[None, Some(t)], [None, Some(none)]],
                "LBNL/Klems Full",
            ))
            .unwrap();
            let frame = Frame::new(normal, Some(DVec3::Z));
            let mut rng = PhotonRng::new(5, 1);
            for _ in 0..100 {
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                // Light along −normal onto the front leaves on the back (+y), 40° off the
                // normal toward `toward`.
                let dir = frame.to_world(k.sample(DVec3::Z, u, true).unwrap());
                let want = -normal * c40 + toward * s40;
                assert!(
                    dir.dot(want) > (8f64).to_radians().cos(),
                    "φ {phi}: {dir} vs {want}"
                );
            }
            // The back transmits nothing.
            let back = Frame::new(-normal, Some(DVec3::Z));
            let u = [0.3, 0.3, 0.3];
            assert!(k.sample(back.to_local(-normal), u, false).is_none());
        }
    }

    #[test]
    fn sampling_matches_the_density() {
        // A scattering row: every outgoing patch, front reflection and transmission.
        let b = KlemsBasis::named("LBNL/Klems Quarter").unwrap();
        let n = b.len();
        let r: Vec<f64> = (0..n * n)
            .map(|x| 0.2 * (1.0 + ((x * 7) % 5) as f64) / (3.0 * PI))
            .collect();
        let t: Vec<f64> = (0..n * n)
            .map(|x| 0.1 * (1.0 + ((x * 3) % 4) as f64) / (2.5 * PI))
            .collect();
        let k = parse(&xml(
            &[[Some(r), Some(t)], [None, None]],
            "LBNL/Klems Quarter",
        ))
        .unwrap();
        let wo = DVec3::new(0.4, 0.2, 0.8).normalize();
        // The weights f cos / pdf are the albedo, and the pdf integrates to 1.
        let mut rng = PhotonRng::new(9, 0);
        let (mut sum, mut count) = (0.0, 0);
        for _ in 0..20_000 {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            let wi = k.sample(wo, u, true).unwrap();
            sum += k.value(wo, wi, true) * wi.z.abs() / k.pdf(wo, wi, true);
            count += 1;
        }
        let i = k.incident(wo, true);
        let albedo: f64 = (0..n)
            .map(|o| (k.m[0][0][i * n + o] + k.m[0][1][i * n + o]) * b.lambda(o))
            .sum();
        assert!((sum / count as f64 - albedo).abs() < 1e-9 * albedo);
        let (mut integral, m) = (0.0, 400);
        for a in 0..m {
            for c in 0..2 * m {
                let mu = (a as f64 + 0.5) / m as f64;
                let phi = 2.0 * PI * (c as f64 + 0.5) / (2 * m) as f64;
                let s = (1.0 - mu * mu).sqrt();
                for z in [mu, -mu] {
                    integral += k.pdf(wo, DVec3::new(s * phi.cos(), s * phi.sin(), z), true)
                        * (1.0 / m as f64)
                        * (PI / m as f64);
                }
            }
        }
        assert!((integral - 1.0).abs() < 0.01, "∫ pdf = {integral}");
        // The back side has only the front's transmission, by reciprocity, and no reflection.
        let mut rng = PhotonRng::new(9, 1);
        for _ in 0..200 {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            let wi = k.sample(wo, u, false).unwrap();
            assert!(wi.z < 0.0);
        }
    }

    #[test]
    fn bad_files_are_refused_with_file_and_line() {
        let good = xml(&clear(0.8, 0.1), "LBNL/Klems Full");
        let status = |t: &str| parse(t).unwrap_err();
        let e = status("<WindowElement><Optical><Layer>");
        assert_eq!(e.status, ImapStatus::ImapErrParse);
        assert!(e.message.starts_with("t.xml:1: not XML"), "{}", e.message);
        let e = status(&good.replace("Columns", "TensorTree3"));
        assert_eq!(e.status, ImapStatus::ImapErrUnsupported);
        assert!(e.message.contains("tensor-tree"), "{}", e.message);
        let e = status(&good.replacen("LBNL/Klems Full", "LBNL/Shirley-Chiu", 1));
        assert_eq!(e.status, ImapStatus::ImapErrUnsupported);
        assert!(e.message.contains("Shirley-Chiu"), "{}", e.message);
        // A bad number on line 12 of the text.
        let bad = good.replacen("0, 0,", "0, x1,", 1);
        let row = bad[..bad.find("x1").unwrap()].lines().count();
        let e = status(&bad);
        assert_eq!(e.status, ImapStatus::ImapErrParse);
        assert!(
            e.message
                .starts_with(&format!("t.xml:{row}: ScatteringData value 'x1'")),
            "{}",
            e.message
        );
        let e = status(&good.replacen(", 0,", ", 0, 1,", 1));
        assert!(e.message.contains("21026 values"), "{}", e.message);
        let e = status(&good.replacen(", 0,", ", -0.5,", 1));
        assert_eq!(e.status, ImapStatus::ImapErrBadMaterial);
        let e = status(&good.replace("Visible", "Solar"));
        assert!(e.message.contains("no Visible"), "{}", e.message);
        // More out than in.
        let e = status(&xml(&clear(0.8, 0.3), "LBNL/Klems Full"));
        assert_eq!(e.status, ImapStatus::ImapErrBadMaterial);
        assert!(
            e.message.contains("front side") && e.message.contains("1.1000"),
            "{}",
            e.message
        );
        let e = KlemsBsdf::read(Path::new("/nonexistent/pane.xml")).unwrap_err();
        assert_eq!(e.status, ImapStatus::ImapErrIo);
        assert!(e.message.contains("bsdf_xml_path /nonexistent/pane.xml"));
        // A file far larger than any BSDF file is refused before it is read.
        let big = std::env::temp_dir().join(format!("imap-big-{}.xml", std::process::id()));
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(MAX_FILE_BYTES + 1).unwrap();
        let e = KlemsBsdf::read(&big).unwrap_err();
        std::fs::remove_file(&big).ok();
        assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument);
        assert!(
            e.message.contains("more than a BSDF file holds"),
            "{}",
            e.message
        );
    }

    #[test]
    fn reciprocity_is_reported() {
        let k = parse(&xml(&clear(0.8, 0.1), "LBNL/Klems Full")).unwrap();
        assert!(k.check.worst_reciprocity < 1e-12, "{:?}", k.check);
        let b = KlemsBasis::named("LBNL/Klems Full").unwrap();
        let n = b.len();
        let mut m = clear(0.8, 0.1);
        let mut tb = m[0][1].clone().unwrap();
        tb[5 * n + 5] *= 0.5;
        m[1][1] = Some(tb);
        let k = parse(&xml(&m, "LBNL/Klems Full")).unwrap();
        assert!(
            (k.check.worst_reciprocity - 2.0 / 3.0).abs() < 1e-9,
            "{:?}",
            k.check
        );
    }
}
