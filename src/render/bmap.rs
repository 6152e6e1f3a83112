//! Backward photon maps and the pixel store.
//!
//! A backward photon is the first diffuse vertex of a path from the camera: its position,
//! the normal on the side the eye came from, the path's weight times the BRDF (and BTDF for
//! translucent surfaces) per band, its pixel and the gathering radius of that pixel. Forward
//! photons that land within the radius add to its accumulator (atomically: several threads
//! may gather into one map at once). A map is built once per phase, with a spatial hash
//! grid whose cells are one photon diameter wide, so a query reads one cell.

use glam::{IVec3, Vec3};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};

/// Adds `x` to the f64 stored as bits in `a` (compare-and-swap loop, relaxed).
#[inline]
pub fn atomic_add_f64(a: &AtomicU64, x: f64) {
    let mut cur = a.load(Ordering::Relaxed);
    loop {
        let new = (f64::from_bits(cur) + x).to_bits();
        match a.compare_exchange_weak(cur, new, Ordering::Relaxed, Ordering::Relaxed) {
            Ok(_) => return,
            Err(now) => cur = now,
        }
    }
}

#[inline]
pub fn load_f64(a: &AtomicU64) -> f64 {
    f64::from_bits(a.load(Ordering::Relaxed))
}

const NO_PHOTON: u32 = u32::MAX;

/// A backward photon: 32 bytes, per-band data in the map's arrays.
#[derive(Clone, Copy, Debug)]
pub struct BackwardPhoton {
    pub pos: Vec3,
    /// Gathering radius squared, scene units².
    pub r2: f32,
    /// Unit normal on the side the eye path arrived from.
    pub n: Vec3,
    /// Index of the map entry (pixel sample) it belongs to.
    pub entry: u32,
}

/// What one thread's share of a backward pass produced.
#[derive(Debug, Default)]
pub struct SampleBuf {
    /// Pixel of each entry.
    pub pixels: Vec<u32>,
    /// Direct luminance (emission seen and direct light), entries × bands.
    pub direct: Vec<f64>,
    pub photons: Vec<BackwardPhoton>,
    /// Path weight × BRDF per band, photons × bands.
    pub w_reflect: Vec<f64>,
    /// Path weight × BTDF per band (only in scenes with diffuse transmission).
    pub w_transmit: Vec<f64>,
    /// Per photon: the share of its gathering disc its surface covers (`EyeTracer::
    /// coverage`), NaN where it was not probed this phase.
    pub coverage: Vec<f32>,
    /// Per photon, in scenes with a fluorescent surface only (empty otherwise): the pixel
    /// band a photon on a fluorescent surface counts all it gathers into (its weights are
    /// then per band of the arriving light), or `NO_BAND`.
    pub out_band: Vec<u32>,
}

/// `SampleBuf::out_band` of a photon that counts each band into its own.
pub const NO_BAND: u32 = u32::MAX;

impl SampleBuf {
    pub fn clear(&mut self) {
        self.pixels.clear();
        self.direct.clear();
        self.photons.clear();
        self.w_reflect.clear();
        self.w_transmit.clear();
        self.coverage.clear();
        self.out_band.clear();
    }

    pub fn bytes(&self) -> usize {
        self.pixels.capacity() * 4
            + (self.direct.capacity() + self.w_reflect.capacity() + self.w_transmit.capacity()) * 8
            + self.photons.capacity() * std::mem::size_of::<BackwardPhoton>()
            + self.coverage.capacity() * 4
            + self.out_band.capacity() * 4
    }
}

/// One group's backward photon maps for one phase.
#[derive(Debug)]
pub struct BackwardMap {
    bands: usize,
    transmit: bool,
    pub samples: SampleBuf,
    /// Photon index of each entry, `NO_PHOTON` for paths that found no diffuse surface.
    photon_of: Vec<u32>,
    acc: Vec<AtomicU64>,
    grid: HashGrid,
    /// Forward photons gathered into this map (by its owner and by joiners): the estimate's
    /// normalisation.
    pub forward: AtomicU64,
    /// A forward photon was abandoned mid-path (the render was stopping) after gathering
    /// into this map: the phase's samples are discarded.
    pub interrupted: AtomicBool,
}

/// Cosine between the normals of a forward photon's surface side and a backward photon's
/// above which they are taken to be on the same surface side.
pub(crate) const SAME_SURFACE_COS: f32 = 0.9;

impl BackwardMap {
    pub fn new(bands: usize, transmit: bool) -> Self {
        BackwardMap {
            bands,
            transmit,
            samples: SampleBuf::default(),
            photon_of: Vec::new(),
            acc: Vec::new(),
            grid: HashGrid::default(),
            forward: AtomicU64::new(0),
            interrupted: AtomicBool::new(false),
        }
    }

    /// Rebuilds the map from the threads' buffers (which are emptied).
    pub fn build<'b>(&mut self, bufs: impl Iterator<Item = &'b mut SampleBuf>) {
        let nb = self.bands;
        let s = &mut self.samples;
        s.clear();
        for b in bufs {
            let base = s.pixels.len() as u32;
            s.pixels.extend_from_slice(&b.pixels);
            s.direct.extend_from_slice(&b.direct);
            s.photons.extend(b.photons.iter().map(|p| BackwardPhoton {
                entry: p.entry + base,
                ..*p
            }));
            s.w_reflect.extend_from_slice(&b.w_reflect);
            s.w_transmit.extend_from_slice(&b.w_transmit);
            s.coverage.extend_from_slice(&b.coverage);
            s.out_band.extend_from_slice(&b.out_band);
            b.clear();
        }
        self.photon_of.clear();
        self.photon_of.resize(s.pixels.len(), NO_PHOTON);
        for (i, p) in s.photons.iter().enumerate() {
            self.photon_of[p.entry as usize] = i as u32;
        }
        let n = s.photons.len() * nb;
        self.acc.clear();
        self.acc.resize_with(n, || AtomicU64::new(0));
        self.grid.build(&s.photons);
        self.forward.store(0, Ordering::Relaxed);
        self.interrupted.store(false, Ordering::Relaxed);
    }

    pub fn entries(&self) -> usize {
        self.samples.pixels.len()
    }

    /// Bytes an entry (pixel sample) takes at most, for the memory budget: pixel and photon
    /// index, the photon, direct, reflected, transmitted and accumulated values per band,
    /// and the grid (a photon is listed in up to 8 cells, two buckets per photon).
    pub fn bytes_per_entry(bands: usize) -> usize {
        4 + 4 + std::mem::size_of::<BackwardPhoton>() + 4 * 8 * bands + 8 * 4 + 2 * 4 + 4
    }

    /// Bytes held (capacity), for the memory report.
    pub fn bytes(&self) -> usize {
        self.samples.bytes()
            + self.photon_of.capacity() * 4
            + self.acc.capacity() * 8
            + self.grid.bytes()
    }

    /// Adds a forward photon of colour `c` arriving at `y` on the surface side with normal
    /// `n_in` to every backward photon within its radius. Returns the number of backward
    /// photons it reached.
    #[inline]
    pub fn gather(&self, y: Vec3, n_in: Vec3, c: &[f64], band: Option<usize>) -> u32 {
        if self.samples.out_band.is_empty() {
            self.gather_into::<false>(y, n_in, c, band)
        } else {
            self.gather_into::<true>(y, n_in, c, band)
        }
    }

    /// `gather`; with `FLUORESCENT` (a scene with a fluorescent surface), a backward photon
    /// on one (`SampleBuf::out_band`) counts every band of the arriving light into the one
    /// pixel band its path chose.
    #[inline]
    fn gather_into<const FLUORESCENT: bool>(
        &self,
        y: Vec3,
        n_in: Vec3,
        c: &[f64],
        band: Option<usize>,
    ) -> u32 {
        let nb = self.bands;
        let mut reached = 0;
        for &i in self.grid.candidates(y) {
            let bp = &self.samples.photons[i as usize];
            if (bp.pos - y).length_squared() >= bp.r2 {
                continue;
            }
            let cos = bp.n.dot(n_in);
            let w = if cos > SAME_SURFACE_COS {
                &self.samples.w_reflect[i as usize * nb..][..nb]
            } else if self.transmit && cos < -SAME_SURFACE_COS {
                &self.samples.w_transmit[i as usize * nb..][..nb]
            } else {
                continue;
            };
            let acc = &self.acc[i as usize * nb..][..nb];
            reached += 1;
            if FLUORESCENT {
                let j = self.samples.out_band[i as usize];
                if j != NO_BAND {
                    let x: f64 = match band {
                        Some(b) => w[b] * c[b],
                        None => w.iter().zip(c).map(|(w, c)| w * c).sum(),
                    };
                    if x != 0.0 {
                        atomic_add_f64(&acc[j as usize], x);
                    }
                    continue;
                }
            }
            match band {
                Some(b) => atomic_add_f64(&acc[b], w[b] * c[b]),
                None => {
                    for ((a, w), c) in acc.iter().zip(w).zip(c) {
                        let x = w * c;
                        if x != 0.0 {
                            atomic_add_f64(a, x);
                        }
                    }
                }
            }
        }
        reached
    }

    /// The accumulated (unnormalised) value of backward photon `i`.
    pub fn accumulated(&self, i: usize) -> &[AtomicU64] {
        &self.acc[i * self.bands..][..self.bands]
    }

    /// Entry `e`'s sample after the forward step: its pixel, its luminance per band (direct
    /// plus gathered, the latter times `scale / r²`) into `out`, and its photon's radius².
    pub fn sample(&self, e: usize, scale: f64, out: &mut [f64]) -> (u32, Option<Gathered>) {
        let nb = self.bands;
        out.copy_from_slice(&self.samples.direct[e * nb..][..nb]);
        let i = self.photon_of[e];
        if i == NO_PHOTON {
            return (self.samples.pixels[e], None);
        }
        let r2 = self.samples.photons[i as usize].r2 as f64;
        let k = scale / r2;
        let mut gathered = 0.0;
        for (o, a) in out.iter_mut().zip(self.accumulated(i as usize)) {
            let x = load_f64(a) * k;
            *o += x;
            gathered += x;
        }
        let coverage = self.samples.coverage.get(i as usize).copied();
        (
            self.samples.pixels[e],
            Some(Gathered {
                r2,
                value: gathered / nb as f64,
                coverage: coverage.unwrap_or(f32::NAN),
            }),
        )
    }
}

/// What a sample's backward photon gathered: its radius², the band mean of the gathered
/// radiance, and its disc's coverage if probed (NaN if not).
#[derive(Clone, Copy, Debug)]
pub struct Gathered {
    pub r2: f64,
    pub value: f64,
    pub coverage: f32,
}

/// A spatial hash of backward photons: each photon is listed in every cell its gathering
/// sphere overlaps, cells are as wide as the largest sphere, so a point needs one cell.
#[derive(Debug, Default)]
struct HashGrid {
    inv_cell: f32,
    mask: u32,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl HashGrid {
    #[inline]
    fn cell(&self, p: Vec3) -> IVec3 {
        (p * self.inv_cell).floor().as_ivec3()
    }

    #[inline]
    fn bucket(&self, c: IVec3) -> usize {
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        (h & self.mask) as usize
    }

    /// The buckets of the cells photon `p`'s sphere overlaps, without repeats (at most 8).
    fn buckets_of(&self, p: &BackwardPhoton, out: &mut Vec<usize>) {
        out.clear();
        let r = p.r2.sqrt();
        let (lo, hi) = (self.cell(p.pos - r), self.cell(p.pos + r));
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    out.push(self.bucket(IVec3::new(x, y, z)));
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    fn build(&mut self, photons: &[BackwardPhoton]) {
        self.start.clear();
        self.items.clear();
        let r_max = photons.iter().map(|p| p.r2).fold(0.0f32, f32::max).sqrt();
        if photons.is_empty() || r_max <= 0.0 {
            self.mask = 0;
            self.start.resize(2, 0);
            self.inv_cell = 0.0;
            return;
        }
        self.inv_cell = 1.0 / (2.0 * r_max);
        let buckets = (2 * photons.len()).next_power_of_two();
        self.mask = buckets as u32 - 1;
        self.start.resize(buckets + 1, 0);
        let mut b = Vec::with_capacity(8);
        for p in photons {
            self.buckets_of(p, &mut b);
            for &k in &b {
                self.start[k + 1] += 1;
            }
        }
        for k in 0..buckets {
            self.start[k + 1] += self.start[k];
        }
        self.items.resize(self.start[buckets] as usize, 0);
        let mut fill: Vec<u32> = self.start[..buckets].to_vec();
        for (i, p) in photons.iter().enumerate() {
            self.buckets_of(p, &mut b);
            for &k in &b {
                self.items[fill[k] as usize] = i as u32;
                fill[k] += 1;
            }
        }
    }

    #[inline]
    fn candidates(&self, p: Vec3) -> &[u32] {
        if self.items.is_empty() {
            return &[];
        }
        let k = self.bucket(self.cell(p));
        &self.items[self.start[k] as usize..self.start[k + 1] as usize]
    }

    fn bytes(&self) -> usize {
        (self.start.capacity() + self.items.capacity()) * 4
    }
}

/// Per-pixel accumulators of the progressive estimate: every phase that covers a pixel adds
/// one independent sample (direct + gathered luminance); the pixel's radius shrinks after
/// each (Knaus & Zwicker: r²ₙ₊₁ = r²ₙ (n + α)/(n + 1)). A pixel is written by one thread at
/// a time (the masks of concurrent phases are disjoint); others may read it for progress.
#[derive(Debug)]
pub struct PixelStore {
    bands: usize,
    sum: Vec<AtomicU64>,
    /// Sum over samples of the squared band mean.
    sumsq: Vec<AtomicU64>,
    count: Vec<AtomicU32>,
    r2: Vec<AtomicU64>,
    /// Sum over samples of the boundary bias of the gathered part (band mean): what the
    /// part of the disc its surface does not cover would have added, (1 − f)/f × gathered,
    /// f the pixel's latest probed coverage.
    bias: Vec<AtomicU64>,
    /// The pixel's latest probed coverage (f32 bits; 1 before any probe).
    cover: Vec<AtomicU32>,
}

impl PixelStore {
    pub fn new(pixels: usize, bands: usize) -> Self {
        let zeros = |n: usize| (0..n).map(|_| AtomicU64::new(0)).collect::<Vec<_>>();
        PixelStore {
            bands,
            sum: zeros(pixels * bands),
            sumsq: zeros(pixels),
            count: (0..pixels).map(|_| AtomicU32::new(0)).collect(),
            r2: zeros(pixels),
            bias: zeros(pixels),
            cover: (0..pixels)
                .map(|_| AtomicU32::new(1f32.to_bits()))
                .collect(),
        }
    }

    pub fn bytes(pixels: usize, bands: usize) -> usize {
        pixels * (bands * 8 + 8 + 4 + 8 + 8 + 4)
    }

    /// The pixel's current gathering radius², 0 before its first sample with a photon.
    #[inline]
    pub fn r2(&self, pixel: usize) -> f64 {
        load_f64(&self.r2[pixel])
    }

    /// Number of samples of the pixel so far.
    #[inline]
    pub fn count(&self, pixel: usize) -> u32 {
        self.count[pixel].load(Ordering::Relaxed)
    }

    /// Whether the next sample of `pixel` should probe its disc's coverage: its first
    /// four, then at every power of two (the radius shrinks slowly; a handful of probes
    /// follow it).
    #[inline]
    pub fn probe(&self, pixel: usize) -> bool {
        let n = self.count(pixel);
        n < 4 || n.is_power_of_two()
    }

    /// Adds one sample `value` (per band) to `pixel`; `gathered` is what its photon
    /// gathered (None when the path found no diffuse surface).
    pub fn add_sample(&self, pixel: usize, value: &[f64], gathered: Option<Gathered>, alpha: f64) {
        if let Some(g) = gathered {
            let mut f = g.coverage;
            if f.is_nan() {
                f = f32::from_bits(self.cover[pixel].load(Ordering::Relaxed));
            } else {
                self.cover[pixel].store(f.to_bits(), Ordering::Relaxed);
            }
            let f = (f as f64).clamp(0.05, 1.0);
            let b = &self.bias[pixel];
            b.store(
                (load_f64(b) + g.value * (1.0 - f) / f).to_bits(),
                Ordering::Relaxed,
            );
        }
        let r2_used = gathered.map(|g| g.r2);
        let nb = self.bands;
        let mut mean = 0.0;
        for (a, v) in self.sum[pixel * nb..][..nb].iter().zip(value) {
            a.store((load_f64(a) + v).to_bits(), Ordering::Relaxed);
            mean += v;
        }
        mean /= nb as f64;
        let q = &self.sumsq[pixel];
        q.store((load_f64(q) + mean * mean).to_bits(), Ordering::Relaxed);
        let n = self.count[pixel].load(Ordering::Relaxed) + 1;
        self.count[pixel].store(n, Ordering::Relaxed);
        if let Some(r2) = r2_used {
            let shrunk = r2 * (n as f64 + alpha) / (n as f64 + 1.0);
            self.r2[pixel].store(shrunk.to_bits(), Ordering::Relaxed);
        }
    }

    /// Adds this store's (count, per-band sums, sum of squares) of `pixel` to the arguments.
    /// Adds this store's boundary-bias sum of `pixel` to `bias`.
    pub fn read_bias(&self, pixel: usize, bias: &mut f64) {
        *bias += load_f64(&self.bias[pixel]);
    }

    pub fn read(&self, pixel: usize, n: &mut u64, sum: &mut [f64], sumsq: &mut f64) {
        *n += self.count(pixel) as u64;
        for (s, a) in sum
            .iter_mut()
            .zip(&self.sum[pixel * self.bands..][..self.bands])
        {
            *s += load_f64(a);
        }
        *sumsq += load_f64(&self.sumsq[pixel]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photon(p: [f32; 3], r: f32, entry: u32) -> BackwardPhoton {
        BackwardPhoton {
            pos: Vec3::from(p),
            r2: r * r,
            n: Vec3::Z,
            entry,
        }
    }

    /// The grid finds exactly the photons whose sphere holds the query point, against a
    /// brute-force scan, with radii that differ by photon.
    #[test]
    fn gather_matches_brute_force() {
        let mut rng = crate::sampling::PhotonRng::new(3, 0);
        let mut buf = SampleBuf::default();
        for i in 0..2000 {
            let p = [
                rng.uniform() as f32 * 4.0 - 2.0,
                rng.uniform() as f32 * 4.0 - 2.0,
                rng.uniform() as f32 * 0.1,
            ];
            let r = 0.05 + 0.1 * rng.uniform() as f32;
            buf.pixels.push(i);
            buf.direct.push(0.0);
            buf.photons.push(photon(p, r, i));
            buf.w_reflect.push(1.0);
        }
        let mut map = BackwardMap::new(1, false);
        map.build(std::iter::once(&mut buf));
        for _ in 0..3000 {
            let y = Vec3::new(
                rng.uniform() as f32 * 4.4 - 2.2,
                rng.uniform() as f32 * 4.4 - 2.2,
                rng.uniform() as f32 * 0.1,
            );
            let brute = map
                .samples
                .photons
                .iter()
                .filter(|p| (p.pos - y).length_squared() < p.r2)
                .count() as u32;
            assert_eq!(map.gather(y, Vec3::Z, &[1.0], None), brute);
            // The other side of the surface, with no transmission, reaches nothing.
            assert_eq!(map.gather(y, -Vec3::Z, &[1.0], None), 0);
        }
        let total: f64 = (0..2000).map(|i| load_f64(&map.accumulated(i)[0])).sum();
        assert!(total > 0.0);
    }

    #[test]
    fn pixel_radius_shrinks_by_the_progressive_rule() {
        let s = PixelStore::new(1, 2);
        let g = |r2: f64, value: f64, coverage: f32| {
            Some(Gathered {
                r2,
                value,
                coverage,
            })
        };
        s.add_sample(0, &[1.0, 3.0], g(1.0, 0.6, 1.0), 2.0 / 3.0);
        assert!((s.r2(0) - (1.0 + 2.0 / 3.0) / 2.0).abs() < 1e-15);
        s.add_sample(0, &[3.0, 5.0], g(s.r2(0), 0.6, f32::NAN), 2.0 / 3.0);
        let (mut n, mut sum, mut q) = (0, [0.0; 2], 0.0);
        s.read(0, &mut n, &mut sum, &mut q);
        assert_eq!((n, sum, q), (2, [4.0, 8.0], 4.0 + 16.0));
        // Full coverage: no boundary bias. A disc half covered: its gathered part again.
        let mut b = 0.0;
        s.read_bias(0, &mut b);
        assert_eq!(b, 0.0);
        s.add_sample(0, &[3.0, 5.0], g(s.r2(0), 0.5, 0.5), 2.0 / 3.0);
        s.add_sample(0, &[3.0, 5.0], g(s.r2(0), 0.25, f32::NAN), 2.0 / 3.0);
        s.read_bias(0, &mut b);
        assert!((b - 0.75).abs() < 1e-12, "{b}");
        // Probes at samples 1–4, then at powers of two: the 5th sample (count 4) probes,
        // the 6th does not.
        assert!(s.probe(0));
        s.add_sample(0, &[3.0, 5.0], None, 2.0 / 3.0);
        assert!(!s.probe(0));
    }
}
