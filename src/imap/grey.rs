//! Grey sums of a spectral map: the few spectra (the lights' shapes, tinted once by a
//! material) whose multiples most photons' colours are, so a cell keeps one number for
//! such a photon instead of one per band (`IMap`'s grey arrays).

use crate::scene::{Emitter, Material};

/// Most spectra a map keeps grey sums for (`GreySpectra`).
pub const MAX_GREY: usize = 32;
/// Maps of at least this many bands keep grey sums (`GreySpectra`); at a few bands a cell
/// is a cache line or two anyway.
pub const GREY_MIN_BANDS: usize = 9;

/// The spectra for which a spectral map keeps, per cell, one sum of multiples
/// (`imap::IMap`): each emitter's spectrum, and each emitter's spectrum times the diffuse
/// reflectance of each material that reflects bands differently. A photon whose colour is
/// still a multiple of one of them (it met only surfaces whose coefficients are the same in
/// every band, or one tinted surface besides; every first hit) deposits one number instead
/// of one per band; the map's band values add each sum times its spectrum. Empty for maps
/// of fewer than `GREY_MIN_BANDS` bands; at most a quarter as many sums as bands (the
/// map's memory grows by at most a quarter) and `MAX_GREY`: spectra past those deposit
/// every band.
#[derive(Clone, Debug, Default)]
pub struct GreySpectra {
    pub bands: usize,
    /// The spectra, `bands` values each, each scaled so that its largest value is 1.
    pub spectra: Vec<f64>,
    /// Per spectrum: its band mean, and its largest band.
    pub means: Vec<f64>,
    pub peaks: Vec<usize>,
    /// Per emitter: its spectrum, if it has one here.
    pub of_emitter: Vec<Option<u8>>,
    /// Per (emitter spectrum, material): the tinted spectrum, if kept (`after`).
    tints: Vec<Option<u8>>,
    /// Per material: whether its diffuse reflectance is the same in every band.
    flat: Vec<bool>,
}

/// Most grey sums a map of `bands` bands keeps per cell (`GreySpectra`).
pub fn most_grey(bands: usize) -> usize {
    if bands < GREY_MIN_BANDS {
        0
    } else {
        MAX_GREY.min(bands / 4)
    }
}

impl GreySpectra {
    /// The distinct spectra of `emitters`' colours (up to scale), then of those times each
    /// tinted material's diffuse reflectance, for maps of `bands` bands.
    pub fn new(emitters: &[Emitter], materials: &[Material], bands: usize) -> Self {
        let mut g = GreySpectra {
            bands,
            of_emitter: vec![None; emitters.len()],
            ..Default::default()
        };
        let most = most_grey(bands);
        if most == 0 {
            return g;
        }
        let bases: Vec<Option<u8>> = emitters
            .iter()
            .map(|em| {
                if em.colour.len() == bands {
                    g.keep(em.colour.clone(), most)
                } else {
                    None
                }
            })
            .collect();
        g.of_emitter = bases;
        g.flat = materials
            .iter()
            .map(|m| {
                m.diffuse_reflect.len() != bands
                    || m.diffuse_reflect.iter().all(|r| *r == m.diffuse_reflect[0])
            })
            .collect();
        let spectra = g.count();
        g.tints = vec![None; spectra * materials.len()];
        for k in 0..spectra {
            for (i, m) in materials.iter().enumerate() {
                if g.flat[i] {
                    continue;
                }
                let tinted: Vec<f64> = g
                    .spectrum(k)
                    .iter()
                    .zip(&m.diffuse_reflect)
                    .map(|(s, r)| s * r)
                    .collect();
                g.tints[k * materials.len() + i] = g.keep(tinted, most);
            }
        }
        g
    }

    /// Spectra kept for `shapes` alone (no emitters, no materials): for tests.
    #[cfg(test)]
    pub(crate) fn of_shapes(bands: usize, shapes: &[Vec<f64>]) -> Self {
        let mut g = GreySpectra {
            bands,
            ..Default::default()
        };
        for s in shapes {
            g.keep(s.clone(), MAX_GREY);
        }
        g
    }

    /// The index of `colour`'s shape, added if new and there is room.
    fn keep(&mut self, colour: Vec<f64>, most: usize) -> Option<u8> {
        let (peak, max) =
            colour.iter().enumerate().fold(
                (0, 0.0),
                |(i, m), (j, &c)| if c > m { (j, c) } else { (i, m) },
            );
        if !(max > 0.0 && max.is_finite()) {
            return None;
        }
        let shape: Vec<f64> = colour.iter().map(|c| c / max).collect();
        let same = (0..self.count()).find(|&k| {
            self.spectrum(k)
                .iter()
                .zip(&shape)
                .all(|(a, b)| (a - b).abs() <= 1e-12)
        });
        match same {
            Some(k) => Some(k as u8),
            None if self.count() < most => {
                self.means
                    .push(shape.iter().sum::<f64>() / self.bands as f64);
                self.peaks.push(peak);
                self.spectra.extend(shape);
                Some((self.count() - 1) as u8)
            }
            None => None,
        }
    }

    /// The spectrum a photon's colour is a multiple of after a diffuse reflection off
    /// `material`, when it was one of spectrum `k` (an emitter's) before: `k` again off a
    /// material that reflects every band alike, the tinted spectrum off one that does not
    /// (if kept); None when `k` is not an emitter's or `material` is out of range.
    #[inline]
    pub fn after(&self, k: u8, base: u8, material: usize) -> Option<u8> {
        match self.flat.get(material)? {
            true => Some(k),
            false if k == base => self.tints[base as usize * self.flat.len() + material],
            false => None,
        }
    }

    /// Spectra kept (K).
    #[inline]
    pub fn count(&self) -> usize {
        self.means.len()
    }

    #[inline]
    pub fn spectrum(&self, k: usize) -> &[f64] {
        &self.spectra[k * self.bands..(k + 1) * self.bands]
    }

    /// The multiple of spectrum `k` that `colour` is, if it is one (to 1e-9 of its largest
    /// band).
    #[inline]
    pub fn multiple(&self, k: usize, colour: &[f64]) -> Option<f64> {
        let s = self.spectrum(k);
        let a = colour[self.peaks[k]];
        if !(a > 0.0 && a.is_finite()) {
            return None;
        }
        let tol = 1e-9 * a;
        // Every band checked (no early exit): the loop vectorises. A NaN band is off.
        let off = colour.iter().zip(s).fold(false, |off, (c, s)| {
            let d = (c - a * s).abs();
            off | (d > tol) | d.is_nan()
        });
        (!off).then_some(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::emitter::EmitterKind;
    use crate::scene::{LightShape, MaterialDesc};
    use crate::spectral::Bands;
    use glam::DVec3;

    fn point(colour: Vec<f64>) -> Emitter {
        Emitter {
            kind: EmitterKind::Light(LightShape::Point),
            position: DVec3::ZERO,
            power: colour.clone(),
            colour,
            layer: 0,
            aim: None,
            media: Vec::new(),
        }
    }

    #[test]
    fn grey_spectra_keep_each_light_shape_once_and_each_tint_within_the_cap() {
        let nb = 12;
        let bands = Bands::spectral(nb as u32, 400.0, 700.0).unwrap();
        let ramp: Vec<f64> = (0..nb).map(|b| 1.0 + b as f64).collect();
        let emitters = [
            point(ramp.clone()),
            point(ramp.iter().map(|x| 3.0 * x).collect()), // the same shape
            point(vec![2.0; nb]),
        ];
        let material = |rho: Vec<f64>| {
            Material::new(
                &MaterialDesc {
                    diffuse_reflect: rho,
                    ..Default::default()
                },
                &bands,
            )
            .unwrap()
        };
        let materials = [
            material(vec![0.5]),                                        // flat
            material((0..nb).map(|b| 0.2 + 0.05 * b as f64).collect()), // tinted
        ];
        let g = GreySpectra::new(&emitters, &materials, nb);
        // 12 bands: at most 3 sums. The two light shapes, then the first tint.
        assert_eq!(g.count(), 3);
        assert_eq!(g.of_emitter, vec![Some(0), Some(0), Some(1)]);
        assert!(g.spectrum(0).iter().all(|&s| s > 0.0 && s <= 1.0));
        assert_eq!(g.spectrum(0)[nb - 1], 1.0);
        // Off the flat material a colour stays in its class; off the tinted one it moves
        // to the tint kept for the first light (the second light's tint had no room), and
        // a second tint leaves every class.
        assert_eq!(g.after(0, 0, 0), Some(0));
        assert_eq!(g.after(0, 0, 1), Some(2));
        assert_eq!(g.after(1, 1, 1), None);
        assert_eq!(g.after(2, 0, 1), None);
        assert_eq!(g.after(2, 0, 0), Some(2));
        assert_eq!(g.after(0, 0, 7), None, "no such material");
        let tinted: Vec<f64> = g
            .spectrum(0)
            .iter()
            .zip(&materials[1].diffuse_reflect)
            .map(|(s, r)| 0.37 * s * r)
            .collect();
        assert!(g.multiple(2, &tinted).is_some());
        assert!(g.multiple(0, &tinted).is_none());
        // Few bands: no sums at all.
        let rgb = GreySpectra::new(&emitters, &materials, 3);
        assert_eq!((rgb.count(), rgb.of_emitter[0]), (0, None));
    }
}
