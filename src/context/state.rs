//! Map state out and in: everything a context has accumulated (the map's sums and squares
//! in every layer, the photon indices it holds, the energy tallies, the region tallies, the
//! run time and the error history), with a fingerprint of the scene and settings, as one
//! versioned, checksummed byte stream. A state can be written to a buffer or, atomically,
//! to a file; loaded back (resume) or merged into a context of the same scene (shards,
//! ranks). Photon k depends only on the seed and k, and every value of the state is a sum
//! over photons, so states of disjoint photon sets add: the merged map, its error estimate
//! (sums of squares add) and its tallies are those of one run of all their photons.
//!
//! Layout (little-endian): `IMAPSTAT`, format version (u32), flags (u32), total length
//! (u64), the fingerprint (four 128-bit hashes: settings, geometry, materials, lights), the
//! library version, the map's dimensions, the photon ranges, run time and history, energy
//! and region tallies (format 2: then the media's tallies, `transport::volumes`), the
//! caller's metadata, the map (unless `flags` says it was left
//! out; 8-byte aligned) and an XXH3-128 checksum of everything before it.

use super::Context;
use crate::error::{bail, Error, ImapStatus, Result};
use crate::progress::{push_history, Progress};
use crate::sched::RangeSet;
use crate::transport::direct::Estimator;
use crate::transport::PathStats;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;
use xxhash_rust::xxh3::Xxh3;

const MAGIC: &[u8; 8] = b"IMAPSTAT";
/// The state format this library writes (it reads this one and `FORMAT_VERSION - 1`).
pub const FORMAT_VERSION: u32 = 2;
/// The format before the media's tallies: read as a state without them, which a scene
/// with media refuses (`Context::check_state`).
const FORMAT_WITHOUT_VOLUMES: u32 = 1;
/// `flags`: the map's accumulators are not in the state (an MPI rank's ledger: its map is
/// summed by the caller, e.g. with `MPI_Reduce`).
pub const FLAG_NO_MAP: u32 = 1;
const PREFIX: usize = 8 + 4 + 4 + 8;
const CHECKSUM: usize = 16;

/// What a state's fingerprint covers, in the order of its four hashes.
const PARTS: [&str; 4] = [
    "settings (bands, seed, units, light aiming, layers)",
    "geometry (meshes: vertices, triangles, sides, recording, emission)",
    "materials",
    "lights",
];

/// Hashes of the scene and the settings that decide what photon k deposits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fingerprint(pub [u128; 4]);

/// A hasher that text can be formatted into (exact: `Debug` of f64 round-trips).
struct HashText(Xxh3);

impl std::fmt::Write for HashText {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.0.update(s.as_bytes());
        Ok(())
    }
}

impl Fingerprint {
    pub fn of(ctx: &Context) -> Self {
        let scene = &ctx.scene;
        let mut settings = HashText(Xxh3::new());
        let _ = write!(
            settings,
            "{:?}|{}|{:?}|{}|{:?}|{:?}",
            scene.bands,
            ctx.config.seed,
            ctx.config.unit_m.to_bits(),
            ctx.config.aim_lights,
            scene.layers,
            crate::imap::LayerLayout::of_scene(scene)
        );
        let mut geometry = Xxh3::new();
        for m in &scene.meshes {
            geometry.update(&(m.positions.len() as u64).to_le_bytes());
            for p in &m.positions {
                for c in p {
                    geometry.update(&c.to_le_bytes());
                }
            }
            geometry.update(&(m.triangles.len() as u64).to_le_bytes());
            for t in &m.triangles {
                for i in t {
                    geometry.update(&i.to_le_bytes());
                }
            }
            let mut rest = HashText(geometry);
            let _ = write!(
                rest,
                "|{}|{:?}|{}|{}|{:?}|{}|{}|{}|",
                m.material,
                m.triangle_materials,
                m.two_sided,
                m.record,
                m.exitance,
                m.sensor,
                m.tally,
                m.light_group
            );
            geometry = rest.0;
            // Only meshes with texture coordinates or vertex factors hash them.
            if let Some(uv) = &m.uvs {
                geometry.update(b"|uvs");
                for c in uv.iter().flatten() {
                    geometry.update(&c.to_le_bytes());
                }
            }
            if let Some(f) = &m.factors {
                geometry.update(&(f.channels as u64).to_le_bytes());
                for c in &f.values {
                    geometry.update(&c.to_le_bytes());
                }
            }
        }
        let mut materials = HashText(Xxh3::new());
        let _ = write!(materials, "{:?}", scene.materials);
        if let Some(m) = scene.medium {
            // Only scenes with a medium outside the meshes hash it.
            let _ = write!(materials, "|scene medium {m}");
        }
        for t in &scene.textures {
            t.hash_into(&mut materials.0);
        }
        let mut lights = HashText(Xxh3::new());
        let _ = write!(lights, "{:?}", scene.lights);
        if !scene.portals.is_empty() {
            // Only scenes with portals hash them: older states keep their fingerprint.
            let _ = write!(lights, "|portals {:?}", scene.portals);
        }
        Fingerprint([
            settings.0.digest128(),
            geometry.digest128(),
            materials.0.digest128(),
            lights.0.digest128(),
        ])
    }

    /// What differs between two fingerprints, in words.
    fn differences(&self, o: &Fingerprint) -> String {
        let differ: Vec<&str> = (0..4)
            .filter(|&i| self.0[i] != o.0[i])
            .map(|i| PARTS[i])
            .collect();
        differ.join("; ")
    }
}

/// The bit of `Dims::samples` that says the passes gather indirect light (samples per
/// pass are at most `direct::MAX_SAMPLES`).
const GATHER_BIT: u32 = 1 << 31;

/// The map's dimensions a state was written for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Dims {
    bands: u32,
    per_slot: u32,
    slots: u64,
    meshes: u32,
    regions: u64,
    /// The estimator: samples per vertex per pass (`GATHER_BIT` set when the passes
    /// gather) and photons per pass of light sampling; both 0 for photons only.
    samples: u32,
    pass_photons: u64,
}

impl Dims {
    /// Accumulators of the map: per cell, one per band and the sum of squares, and with
    /// light sampling the direct record (bands, sum of squares, pass count).
    fn values(&self) -> u64 {
        let cells = self.slots * self.per_slot as u64;
        let direct = if self.samples > 0 {
            cells * (self.bands as u64 + 3)
        } else {
            0
        };
        cells * (self.bands as u64 + 1) + direct
    }

    fn estimator(&self) -> Estimator {
        if self.samples == 0 {
            Estimator::Photons
        } else {
            Estimator::LightSampling {
                samples: self.samples & !GATHER_BIT,
                pass_photons: self.pass_photons,
                gather: self.samples & GATHER_BIT != 0,
            }
        }
    }

    fn same_but_estimator(&self, o: &Dims) -> bool {
        Dims {
            samples: o.samples,
            pass_photons: o.pass_photons,
            ..*self
        } == *o
    }
}

/// A state read from bytes, checked against its checksum.
pub struct StateFile<'a> {
    /// Its format (`FORMAT_VERSION`, or `FORMAT_WITHOUT_VOLUMES`).
    version: u32,
    pub flags: u32,
    pub fingerprint: Fingerprint,
    /// The libimap version that wrote it.
    pub library: String,
    dims: Dims,
    pub traced: RangeSet,
    pub elapsed_s: f64,
    pub history: Vec<Progress>,
    pub stats: PathStats,
    regions: crate::imap::regions::RegionTally,
    /// The caller's metadata, as written.
    pub meta: &'a [u8],
    /// The map's values (little-endian f64), unless `FLAG_NO_MAP`.
    map: &'a [u8],
}

/// The largest number a state may hold: sums of energies, squares and times far beyond
/// any run (a map of 1e12 photons of 1e9 W each squares to 1e42), and small enough that
/// sums and squares of them stay finite.
const MAX_STATE_NUMBER: f64 = 1e100;

/// Refuses a number of a state that no run can have written: not finite, negative where
/// only sums of energies, squares and times can stand, or beyond `MAX_STATE_NUMBER`
/// (IMAP_ERR_STATE_CORRUPT naming it).
fn check_number(what: &str, x: f64) -> Result<()> {
    if !(x.is_finite() && (0.0..=MAX_STATE_NUMBER).contains(&x)) {
        return Err(corrupt(format!(
            "state is corrupt: its {what} is {x} (a run writes finite, non-negative values up to {MAX_STATE_NUMBER:e})"
        )));
    }
    Ok(())
}

/// `check_number` for a tally that may be negative: what was absorbed, per mesh and per
/// band (a glossy draw that sends on more than arrived, or a medium's re-weighting that
/// gives to a band, tallies a negative absorption; the sum over photons of a band that
/// absorbs nothing is as often below zero as above).
fn check_signed(what: &str, x: f64) -> Result<()> {
    check_number(what, x.abs()).map_err(|_| {
        corrupt(format!(
            "state is corrupt: its {what} is {x} (a run writes finite values within ±{MAX_STATE_NUMBER:e})"
        ))
    })
}

impl StateFile<'_> {
    /// Checks every number of the state (checksums catch damage, not a state written by a
    /// faulty or hostile program): run time, history, tallies, the estimator's settings
    /// and the map's accumulators.
    fn check_numbers(&self) -> Result<()> {
        check_number("run time", self.elapsed_s)?;
        for (i, p) in self.history.iter().enumerate() {
            for (what, x) in [
                ("elapsed time", p.elapsed_s),
                ("estimated error", p.rel_error),
                ("region error", p.region_rel_error),
            ] {
                check_number(&format!("history point {i}'s {what}"), x)?;
            }
        }
        let st = &self.stats;
        for (what, x) in [
            ("emitted energy", st.emitted),
            ("escaped energy", st.escaped),
            ("dropped energy", st.dropped),
        ] {
            check_number(what, x)?;
        }
        let lists: [(&str, &[f64]); 5] = [
            ("region sums", &self.regions.sum),
            ("region squares", &self.regions.sq),
            ("region luminous squares", &self.regions.sq_lum),
            ("media's squares", &st.volumes.sq),
            ("media's luminous squares", &st.volumes.sq_lum),
        ];
        for (what, xs) in lists {
            for (i, &x) in xs.iter().enumerate() {
                check_number(&format!("{what} [{i}]"), x)?;
            }
        }
        let signed = [
            ("absorbed energy", &st.absorbed[..]),
            ("media's sums", &st.volumes.sum),
        ];
        for (what, xs) in signed
            .into_iter()
            .chain(st.bands.iter().map(|b| ("energy per band", &b[..])))
        {
            for (i, &x) in xs.iter().enumerate() {
                check_signed(&format!("{what} [{i}]"), x)?;
            }
        }
        let samples = self.dims.samples & !GATHER_BIT;
        if samples > crate::transport::direct::MAX_SAMPLES
            || (self.dims.samples != 0 && (samples == 0 || self.dims.pass_photons == 0))
        {
            return Err(corrupt(format!(
                "state is corrupt: its estimator claims {samples} light samples per vertex per pass and {} photons per pass (1 … {} samples, and some photons, are possible)",
                self.dims.pass_photons,
                crate::transport::direct::MAX_SAMPLES
            )));
        }
        if let Some(i) = self
            .map_values()
            .position(|x| !(x.is_finite() && (0.0..=MAX_STATE_NUMBER).contains(&x)))
        {
            return Err(corrupt(format!(
                "state is corrupt: its map's accumulator {i} is {} (a run writes finite, non-negative sums up to {MAX_STATE_NUMBER:e})",
                self.map_values().nth(i).unwrap_or(f64::NAN)
            )));
        }
        // The direct records' pass counts are whole numbers (a fraction of a pass divides
        // a vertex's direct light by nearly nothing).
        if self.has_map() && self.dims.samples != 0 {
            let nb = self.dims.bands as usize;
            let cells = (self.dims.slots * self.dims.per_slot as u64) as usize;
            let photon_part = cells * (nb + 1);
            let bad = self
                .map_values()
                .skip(photon_part)
                .skip(nb + 1)
                .step_by(nb + 3)
                .position(|x| x.fract() != 0.0);
            if let Some(c) = bad {
                return Err(corrupt(format!(
                    "state is corrupt: the direct record of map cell {c} counts a fraction of a pass"
                )));
            }
        }
        Ok(())
    }

    pub fn photons(&self) -> u64 {
        self.traced.len()
    }
    pub fn has_map(&self) -> bool {
        self.flags & FLAG_NO_MAP == 0
    }
    /// The map's accumulators (none without the map).
    fn map_values(&self) -> impl Iterator<Item = f64> + '_ {
        self.map
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
    }
}

fn corrupt(what: impl std::fmt::Display) -> Error {
    Error::new(ImapStatus::ImapErrStateCorrupt, what.to_string())
}

/// Reads fields in order, refusing to read past the end.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8]> {
        let left = (self.b.len() - self.at) as u64;
        if n > left {
            return Err(corrupt(format!(
                "state is malformed: {what} needs {n} bytes at offset {} but {left} are left",
                self.at
            )));
        }
        let s = &self.b[self.at..self.at + n as usize];
        self.at += n as usize;
        Ok(s)
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn f64s(&mut self, n: u64, what: &str) -> Result<Vec<f64>> {
        let b = self.take(n.saturating_mul(8), what)?;
        Ok(b.chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }
    fn counted_f64s(&mut self, what: &str) -> Result<Vec<f64>> {
        let n = self.u64(what)?;
        self.f64s(n, what)
    }
}

/// Appends little-endian fields.
#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64s(&mut self, xs: &[f64]) {
        self.u64(xs.len() as u64);
        for &x in xs {
            self.f64(x);
        }
    }
}

/// A writer that hashes and counts what passes through it.
struct Hashing<W: Write> {
    inner: W,
    hash: Xxh3,
    written: u64,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.update(&buf[..n]);
        self.written += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Checks the frame of a state (magic, version, length, checksum) and reads it.
pub fn parse(b: &[u8]) -> Result<StateFile<'_>> {
    let s = parse_frame(b)?;
    s.check_numbers()?;
    Ok(s)
}

fn parse_frame(b: &[u8]) -> Result<StateFile<'_>> {
    if b.len() < 8 || &b[..8] != MAGIC {
        bail!(
            ImapErrStateCorrupt,
            "not a libimap state: it does not start with \"IMAPSTAT\""
        );
    }
    if b.len() < PREFIX + CHECKSUM {
        bail!(
            ImapErrStateCorrupt,
            "state is truncated: {} bytes, not even its header",
            b.len()
        );
    }
    let mut r = Reader { b, at: 8 };
    let version = r.u32("version")?;
    if version != FORMAT_VERSION && version != FORMAT_WITHOUT_VOLUMES {
        bail!(
            ImapErrUnsupported,
            "state format version {version}; this library (libimap {}) reads versions {FORMAT_WITHOUT_VOLUMES} and {FORMAT_VERSION}",
            env!("CARGO_PKG_VERSION")
        );
    }
    let flags = r.u32("flags")?;
    let total = r.u64("length")?;
    if total != b.len() as u64 {
        bail!(
            ImapErrStateCorrupt,
            "state is {}: {} bytes where its header says {total}",
            if (b.len() as u64) < total {
                "truncated"
            } else {
                "longer than written (trailing bytes)"
            },
            b.len()
        );
    }
    let body = &b[..b.len() - CHECKSUM];
    let stored = u128::from_le_bytes(b[b.len() - CHECKSUM..].try_into().unwrap());
    if xxhash_rust::xxh3::xxh3_128(body) != stored {
        bail!(
            ImapErrStateCorrupt,
            "state is corrupt: its checksum does not match its contents (a damaged or altered file)"
        );
    }
    let mut r = Reader {
        b: body,
        at: PREFIX,
    };
    let mut fp = [0u128; 4];
    for f in &mut fp {
        *f = u128::from_le_bytes(r.take(16, "fingerprint")?.try_into().unwrap());
    }
    let n = r.u32("library version")?;
    let library = String::from_utf8_lossy(r.take(n as u64, "library version")?).into_owned();
    let dims = Dims {
        bands: r.u32("bands")?,
        per_slot: r.u32("layers")?,
        slots: r.u64("slots")?,
        meshes: r.u32("meshes")?,
        regions: r.u64("regions")?,
        samples: r.u32("estimator")?,
        pass_photons: r.u64("estimator")?,
    };
    let ranges = r.u64("photon ranges")?;
    if ranges > (body.len() / 16) as u64 {
        return Err(corrupt(format!(
            "state is malformed: {ranges} photon ranges"
        )));
    }
    let mut traced = RangeSet::new();
    let mut last_end = 0;
    for i in 0..ranges {
        let (a, e) = (r.u64("photon range")?, r.u64("photon range")?);
        if a >= e || (i > 0 && a <= last_end) {
            return Err(corrupt(format!(
                "state is malformed: photon range {a}..{e} is empty or out of order"
            )));
        }
        last_end = e;
        traced.insert(a..e);
    }
    let elapsed_s = r.f64("run time")?;
    let points = r.u64("history")?;
    if points > (body.len() / 40) as u64 {
        return Err(corrupt(format!(
            "state is malformed: {points} history points"
        )));
    }
    let mut history = Vec::with_capacity(points as usize);
    for _ in 0..points {
        history.push(Progress {
            elapsed_s: r.f64("history")?,
            photons: r.u64("history")?,
            hits: r.u64("history")?,
            rel_error: r.f64("history")?,
            region_rel_error: r.f64("history")?,
        });
    }
    let mut stats = PathStats {
        photons: r.u64("photon count")?,
        hits: r.u64("hits")?,
        emitted: r.f64("energy tally")?,
        absorbed: r.counted_f64s("absorbed tally")?,
        escaped: r.f64("energy tally")?,
        escaped_photons: r.u64("energy tally")?,
        dropped: r.f64("energy tally")?,
        dropped_photons: r.u64("energy tally")?,
        ..Default::default()
    };
    // Format 1 had no fluoresced tally.
    let kinds = if version >= 2 { 5 } else { 4 };
    for b in stats.bands.iter_mut().take(kinds) {
        *b = r.counted_f64s("band tally")?;
    }
    let regions = crate::imap::regions::RegionTally {
        bands: r.u32("region tally")? as usize,
        sum: r.counted_f64s("region tally")?,
        sq: r.counted_f64s("region tally")?,
        sq_lum: r.counted_f64s("region tally")?,
    };
    if version >= 2 {
        let v = &mut stats.volumes;
        v.bands = r.u32("media's tally")? as usize;
        let n = r.u64("media's tally")?;
        if n > (body.len() / 4) as u64 {
            return Err(corrupt(format!("state is malformed: {n} media")));
        }
        v.meshes = (0..n)
            .map(|_| r.u32("media's tally"))
            .collect::<Result<_>>()?;
        v.sum = r.counted_f64s("media's tally")?;
        v.sq = r.counted_f64s("media's tally")?;
        v.sq_lum = r.counted_f64s("media's tally")?;
        if !v.consistent() {
            return Err(corrupt(
                "state is malformed: its media's tallies do not match their mesh list",
            ));
        }
    }
    let n = r.u64("metadata")?;
    let meta = r.take(n, "metadata")?;
    let pad = (8 - r.at % 8) % 8;
    r.take(pad as u64, "padding")?;
    let map = if flags & FLAG_NO_MAP == 0 {
        let n = r.u64("map")?;
        r.take(n.saturating_mul(8), "map")?
    } else {
        &[]
    };
    if r.at != body.len() {
        return Err(corrupt(format!(
            "state is malformed: {} bytes after the map",
            body.len() - r.at
        )));
    }
    if stats.photons != traced.len() {
        return Err(corrupt(format!(
            "state is malformed: {} photons counted, {} in its ranges",
            stats.photons,
            traced.len()
        )));
    }
    Ok(StateFile {
        version,
        flags,
        fingerprint: Fingerprint(fp),
        library,
        dims,
        traced,
        elapsed_s,
        history,
        stats,
        regions,
        meta,
        map,
    })
}

/// What a state holds, read without a context (`state_info`; `imap_state_info` in C).
#[derive(Clone, Copy, Debug)]
pub struct StateInfo<'a> {
    /// Photons traced into it.
    pub photons: u64,
    /// Whether it holds the map (not written with `FLAG_NO_MAP`).
    pub has_map: bool,
    /// The caller's metadata it was written with.
    pub meta: &'a [u8],
}

/// Checks a whole state (frame and checksum) and tells what it holds.
/// IMAP_ERR_STATE_CORRUPT, IMAP_ERR_UNSUPPORTED.
pub fn state_info(bytes: &[u8]) -> Result<StateInfo<'_>> {
    let s = parse(bytes)?;
    Ok(StateInfo {
        photons: s.photons(),
        has_map: s.has_map(),
        meta: s.meta,
    })
}

/// Reads a whole state file of at most `limit` bytes (`read_file`), for `state_info`.
pub fn read_state_file(path: &Path, limit: u64) -> Result<Vec<u8>> {
    read_file(path, limit)
}

/// Reads a whole state file of at most `limit` bytes, naming it in any error: a path that
/// is not a regular file (`/dev/zero`, a FIFO) is refused before anything is read
/// (IMAP_ERR_IO), a file over the limit with IMAP_ERR_MEMORY_BUDGET.
pub fn read_file(path: &Path, limit: u64) -> Result<Vec<u8>> {
    use crate::files::{read_regular, ReadError};
    read_regular(path, limit).map_err(|e| match e {
        ReadError::Io(e) => io_error(path, "cannot read", e),
        ReadError::NotRegular => Error::new(
            ImapStatus::ImapErrIo,
            format!(
                "cannot read {}: not a regular file (a device, FIFO or folder)",
                path.display()
            ),
        ),
        ReadError::TooLarge { size, limit } => Error::new(
            ImapStatus::ImapErrMemoryBudget,
            format!(
                "reading the state {} needs {size} bytes; the memory budget leaves {limit}",
                path.display()
            ),
        ),
    })
}

fn io_error(path: &Path, what: &str, e: std::io::Error) -> Error {
    Error::new(
        ImapStatus::ImapErrIo,
        format!("{what} {}: {e}", path.display()),
    )
}

impl Context {
    fn dims(&self) -> Dims {
        let (samples, pass_photons) = match self.estimator() {
            Estimator::Photons => (0, 0),
            Estimator::LightSampling {
                samples,
                pass_photons,
                gather,
            } => (samples | if gather { GATHER_BIT } else { 0 }, pass_photons),
        };
        Dims {
            samples,
            pass_photons,
            bands: self.bands() as u32,
            per_slot: self.layer_layout().per_slot() as u32,
            slots: self.scene.slot_count() as u64,
            meshes: self.scene.meshes.len() as u32,
            regions: self
                .prepared
                .as_ref()
                .map_or(0, |p| p.layout.regions.count as u64),
        }
    }

    /// The fingerprint of the scene and settings a state of this context carries.
    pub fn fingerprint(&self) -> Fingerprint {
        Fingerprint::of(self)
    }

    /// Writes the state (without the map's accumulators with `FLAG_NO_MAP`) and the
    /// caller's `meta` to `w`; returns the bytes written.
    pub fn write_state(&mut self, w: &mut dyn Write, flags: u32, meta: &[u8]) -> Result<u64> {
        if flags & !FLAG_NO_MAP != 0 {
            bail!(
                ImapErrInvalidArgument,
                "flags = {flags:#x} has bits other than IMAP_STATE_NO_MAP"
            );
        }
        // The state of a context that has not run is a map of zeros: prepare it.
        self.prepare()?;
        let dims = self.dims();
        let with_map = flags & FLAG_NO_MAP == 0;
        let mut h = Writer::default();
        for f in self.fingerprint().0 {
            h.0.extend_from_slice(&f.to_le_bytes());
        }
        let lib = env!("CARGO_PKG_VERSION");
        h.u32(lib.len() as u32);
        h.0.extend_from_slice(lib.as_bytes());
        h.u32(dims.bands);
        h.u32(dims.per_slot);
        h.u64(dims.slots);
        h.u32(dims.meshes);
        h.u64(dims.regions);
        h.u32(dims.samples);
        h.u64(dims.pass_photons);
        h.u64(self.traced.ranges().len() as u64);
        for r in self.traced.ranges() {
            h.u64(r.start);
            h.u64(r.end);
        }
        h.f64(self.elapsed_s);
        h.u64(self.history.len() as u64);
        for p in &self.history {
            h.f64(p.elapsed_s);
            h.u64(p.photons);
            h.u64(p.hits);
            h.f64(p.rel_error);
            h.f64(p.region_rel_error);
        }
        let s = &self.stats;
        h.u64(s.photons);
        h.u64(s.hits);
        h.f64(s.emitted);
        h.f64s(&s.absorbed);
        h.f64(s.escaped);
        h.u64(s.escaped_photons);
        h.f64(s.dropped);
        h.u64(s.dropped_photons);
        for b in &s.bands {
            h.f64s(b);
        }
        let t = &self.region_tally;
        h.u32(t.bands as u32);
        h.f64s(&t.sum);
        h.f64s(&t.sq);
        h.f64s(&t.sq_lum);
        let v = &s.volumes;
        h.u32(v.bands as u32);
        h.u64(v.meshes.len() as u64);
        for &m in &v.meshes {
            h.u32(m);
        }
        h.f64s(&v.sum);
        h.f64s(&v.sq);
        h.f64s(&v.sq_lum);
        h.u64(meta.len() as u64);
        h.0.extend_from_slice(meta);
        let pad = (8 - (PREFIX + h.0.len()) % 8) % 8;
        h.0.resize(h.0.len() + pad, 0);
        let values = dims.values();
        let map_bytes = if with_map { 8 + values * 8 } else { 0 };
        let total = (PREFIX + h.0.len()) as u64 + map_bytes + CHECKSUM as u64;

        let mut out = Hashing {
            inner: w,
            hash: Xxh3::new(),
            written: 0,
        };
        let io = |e: std::io::Error| {
            Error::new(ImapStatus::ImapErrIo, format!("writing the state: {e}"))
        };
        out.write_all(MAGIC).map_err(io)?;
        out.write_all(&FORMAT_VERSION.to_le_bytes()).map_err(io)?;
        out.write_all(&flags.to_le_bytes()).map_err(io)?;
        out.write_all(&total.to_le_bytes()).map_err(io)?;
        out.write_all(&h.0).map_err(io)?;
        if with_map {
            out.write_all(&values.to_le_bytes()).map_err(io)?;
            let map = self.map.as_ref().expect("prepared");
            let mut buf = Vec::with_capacity(1 << 16);
            for v in map.values() {
                buf.extend_from_slice(&v.to_le_bytes());
                if buf.len() == buf.capacity() {
                    out.write_all(&buf).map_err(io)?;
                    buf.clear();
                }
            }
            out.write_all(&buf).map_err(io)?;
        }
        let sum = out.hash.digest128();
        out.inner.write_all(&sum.to_le_bytes()).map_err(io)?;
        debug_assert_eq!(out.written + CHECKSUM as u64, total);
        Ok(total)
    }

    /// The state as bytes (`write_state`).
    pub fn state_bytes(&mut self, flags: u32, meta: &[u8]) -> Result<Vec<u8>> {
        let mut v = Vec::new();
        self.write_state(&mut v, flags, meta)?;
        Ok(v)
    }

    /// Writes the whole state to `path` atomically: to a temporary file in the same folder,
    /// flushed to the disk, then renamed over `path` (and the folder flushed). A crash at
    /// any moment leaves either the old file or the new one, never a part.
    pub fn save_state(&mut self, path: &Path, meta: &[u8]) -> Result<u64> {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        let Some(name) = path.file_name() else {
            bail!(
                ImapErrInvalidArgument,
                "path {} names no file",
                path.display()
            );
        };
        // Unique per process and per call: two contexts of one process may save the same
        // path at once.
        static SAVES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let call = SAVES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut tmp_name = name.to_os_string();
        tmp_name.push(format!(".tmp-{}-{call}", std::process::id()));
        let tmp = dir.join(tmp_name);
        let result = (|| {
            let f = std::fs::File::create(&tmp).map_err(|e| io_error(&tmp, "cannot create", e))?;
            let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
            let n = self
                .write_state(&mut w, 0, meta)
                .map_err(|e| in_file(&tmp, e))?;
            let f = w
                .into_inner()
                .map_err(|e| io_error(&tmp, "cannot write", e.into_error()))?;
            f.sync_all()
                .map_err(|e| io_error(&tmp, "cannot flush", e))?;
            drop(f);
            crate::platform::replace_file(&tmp, path)
                .map_err(|e| io_error(path, "cannot rename into", e))?;
            // The rename itself reaches the disk with the folder.
            if let Ok(d) = std::fs::File::open(&dir) {
                let _ = d.sync_all();
            }
            remove_dead_temporaries(&dir, name);
            Ok(n)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result
    }

    /// Checks a state against this context: same fingerprint and dimensions (but for the
    /// estimator when the state is to replace the map: `adopt`).
    fn check_state(&self, s: &StateFile, adopt: bool) -> Result<()> {
        let mine = self.fingerprint();
        if s.fingerprint != mine {
            bail!(
                ImapErrStateMismatch,
                "the state is of another scene or other settings (written by libimap {}): its {} differ from this context's",
                s.library,
                s.fingerprint.differences(&mine)
            );
        }
        let mut dims = self.dims();
        if s.dims.same_but_estimator(&dims) && s.dims != dims {
            if !adopt {
                bail!(
                    ImapErrStateMismatch,
                    "the state's map was made with {}, this context's with {}",
                    s.dims.estimator().name(),
                    dims.estimator().name()
                );
            }
            dims = s.dims;
        }
        if s.dims != dims {
            bail!(
                ImapErrStateMismatch,
                "the state's map has {} slots × {} layers × {} bands, this context's {} × {} × {}",
                s.dims.slots,
                s.dims.per_slot,
                s.dims.bands,
                dims.slots,
                dims.per_slot,
                dims.bands
            );
        }
        if s.stats.absorbed.len() != dims.meshes as usize
            || (!s.regions.sq_lum.is_empty()
                && (s.regions.bands != dims.bands as usize
                    || s.regions.sq_lum.len() as u64 != dims.regions
                    || s.regions.sum.len() as u64 != dims.regions * dims.bands as u64
                    || s.regions.sq.len() != s.regions.sum.len()))
            || s.stats.bands.iter().any(|b| b.len() > dims.bands as usize)
        {
            return Err(corrupt(
                "state is malformed: its tallies do not match its map's dimensions",
            ));
        }
        let v = &s.stats.volumes;
        // (The scene's medium is the tally's last entry, `SCENE_MEDIUM`; the fingerprint
        // says whether the scene has one.)
        let scene_medium = self.scene.medium.is_some();
        let beyond =
            |m: u32| m >= dims.meshes && !(scene_medium && m == crate::transport::SCENE_MEDIUM);
        if (!v.meshes.is_empty() && v.bands != dims.bands as usize)
            || v.meshes.iter().any(|&m| beyond(m))
        {
            return Err(corrupt(
                "state is malformed: its media's tallies do not match its map's dimensions",
            ));
        }
        if s.version == FORMAT_WITHOUT_VOLUMES && s.photons() > 0 {
            // (A scene with a medium outside its meshes never matches an older state's
            // fingerprint.)
            if let Some(m) = (0..self.scene.meshes.len()).find(|&m| self.holds_medium(m)) {
                bail!(
                    ImapErrUnsupported,
                    "the state was written by libimap {} in state format {FORMAT_WITHOUT_VOLUMES}, which keeps no tallies of what media absorb, and this scene has media (mesh {m}): run it again from the start",
                    s.library
                );
            }
        }
        if s.has_map() && s.map.len() as u64 != dims.values() * 8 {
            return Err(corrupt("state is malformed: its map has the wrong size"));
        }
        Ok(())
    }

    /// Replaces what the context has accumulated by the state in `bytes` (resume): the map,
    /// photons, tallies, run time and history. Returns the caller's metadata. On any error
    /// the context is unchanged.
    pub fn load_state<'b>(&mut self, bytes: &'b [u8]) -> Result<&'b [u8]> {
        let s = parse(bytes)?;
        self.prepare()?;
        self.check_state(&s, true)?;
        if !s.has_map() {
            bail!(
                ImapErrInvalidArgument,
                "the state was written without its map (IMAP_STATE_NO_MAP): it can only be merged into a context whose map already holds its accumulators"
            );
        }
        if s.dims.estimator() != self.estimator() {
            // The state's map replaces this one: take its estimator.
            let old = (self.estimator, self.map.take());
            self.estimator = s.dims.estimator();
            if let Err(e) = self.prepare() {
                (self.estimator, self.map) = old;
                return Err(e);
            }
        }
        let map = self.map.as_mut().expect("prepared");
        for (v, x) in map.values_mut().zip(s.map_values()) {
            *v = x;
        }
        let mut stats = s.stats;
        for b in &mut stats.bands {
            b.resize(self.bands(), 0.0);
        }
        self.stats = stats;
        self.region_tally = s.regions;
        self.traced = s.traced;
        self.elapsed_s = s.elapsed_s;
        self.history = s.history;
        self.last_run = None;
        self.last_render = None;
        Ok(s.meta)
    }

    /// Adds the state in `bytes` to what the context holds (shards, ranks): refused when it
    /// is of another scene or settings, or when it holds photons the context already holds
    /// (they would count twice). Without the map (`FLAG_NO_MAP`) everything but the map is
    /// added: the caller has summed the maps itself (`map_accumulators`). The run times
    /// add; the history gains one point with the combined error. Returns the metadata.
    /// On any error the context is unchanged.
    pub fn merge_state<'b>(&mut self, bytes: &'b [u8]) -> Result<&'b [u8]> {
        let s = parse(bytes)?;
        self.prepare()?;
        self.check_state(&s, false)?;
        for r in s.traced.ranges() {
            if let Some(both) = self.traced.overlap(r) {
                bail!(
                    ImapErrStateOverlap,
                    "the state holds photons this context holds too (indices {}..{} among others): merging would count them twice; merge states of disjoint photon ranges or shards",
                    both.start,
                    both.end
                );
            }
        }
        let map = self.map.as_mut().expect("prepared");
        for (v, x) in map.values_mut().zip(s.map_values()) {
            *v += x;
        }
        self.stats.merge(&s.stats);
        if !s.regions.sq_lum.is_empty() {
            self.region_tally.merge(&s.regions);
        }
        for r in s.traced.ranges() {
            self.traced.insert(r.clone());
        }
        self.elapsed_s += s.elapsed_s;
        self.push_merge_point();
        Ok(s.meta)
    }

    /// A history point for the state after a merge: the combined photons and error.
    fn push_merge_point(&mut self) {
        let Some(readout) = self.readout(None) else {
            return;
        };
        let photons = readout.photons;
        let err = readout.global_error();
        push_history(
            &mut self.history,
            Progress {
                elapsed_s: self.elapsed_s,
                photons,
                hits: self.stats.hits,
                rel_error: err.unwrap_or(crate::imap::NO_DATA_REL_ERROR),
                region_rel_error: 0.0,
            },
        );
    }

    /// `load_state` from a file.
    pub fn load_state_file(&mut self, path: &Path) -> Result<Vec<u8>> {
        let bytes = self.read_state_file(path)?;
        self.load_state(&bytes)
            .map(<[u8]>::to_vec)
            .map_err(|e| in_file(path, e))
    }

    /// `merge_state` from a file.
    pub fn merge_state_file(&mut self, path: &Path) -> Result<Vec<u8>> {
        let bytes = self.read_state_file(path)?;
        self.merge_state(&bytes)
            .map(<[u8]>::to_vec)
            .map_err(|e| in_file(path, e))
    }

    fn read_state_file(&self, path: &Path) -> Result<Vec<u8>> {
        let left = self.memory_budget().saturating_sub(self.memory_estimate());
        read_file(path, left)
    }

    /// The map's accumulators as one contiguous array (allocated, zeroed, when the context
    /// has not run yet): per cell (`IMap`: slot · layers + layer), the band sums then the sum
    /// of squares. Summing this array over contexts of the same scene element by element
    /// (e.g. `MPI_Reduce`) and merging their states written with `FLAG_NO_MAP` gives the
    /// merged state exactly. A spectral map's grey sums are folded into the band sums
    /// first: the array is current as of this call.
    pub fn map_accumulators(&mut self) -> Result<&mut [f64]> {
        self.prepare()?;
        Ok(self.map.as_mut().expect("prepared").raw_mut())
    }

    /// The light-sampling estimator's direct records as one contiguous array (empty with
    /// photons only): per map cell the band sums, the sum of squares, the pass count and
    /// the sum of squares of the slot's total. Summed over contexts like
    /// `map_accumulators`.
    pub fn direct_accumulators(&mut self) -> Result<&mut [f64]> {
        self.prepare()?;
        let map = self.map.as_mut().expect("prepared");
        Ok(match map.direct_mut() {
            Some(d) => d.raw_mut(),
            None => &mut [],
        })
    }
}

/// Removes the temporary files earlier writers of `name` left when they were killed (their
/// process no longer exists): a run killed many times leaves no litter.
fn remove_dead_temporaries(dir: &Path, name: &std::ffi::OsStr) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut prefix = name.to_os_string();
    prefix.push(".tmp-");
    let prefix = prefix.as_encoded_bytes();
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(pid) = file
            .as_encoded_bytes()
            .strip_prefix(prefix)
            .and_then(|p| std::str::from_utf8(p).ok())
            .and_then(|p| p.split('-').next()?.parse::<u32>().ok())
        else {
            continue;
        };
        if crate::platform::process_gone(pid) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Prefixes an error with the file it came from.
fn in_file(path: &Path, e: Error) -> Error {
    Error::new(e.status, format!("{}: {}", path.display(), e.message))
}
