//! What each volume's medium absorbed: per mesh whose material holds a medium (an
//! absorbing or scattering dielectric), the power its inside took from the photons, per
//! band, with the Monte Carlo error of it.
//!
//! A photon's path changes its colour inside a medium in three ways: Beer–Lambert survival
//! re-weights the bands (keeping their total), a scattering medium's free flights and
//! collisions re-weight them too, and an absorption there ends the path with what it
//! carried. Each change is what the medium took from each band (a re-weighting takes from
//! some bands and gives to others; the total it takes is zero). For every photon the
//! tracer sums those changes per mesh it travelled in (`PhotonVolumes`), and the run keeps,
//! per mesh and band, the sums of the photon totals and of their squares (`VolumeTally`):
//! the absorbed power and its variance, exactly as a region's flux is tallied
//! (`imap::regions`). Surfaces do not count here: what a print on a light guide absorbs is
//! the mesh's (`PathStats::absorbed`), not its medium's.

/// One photon's changes in media, per mesh (scratch, reused from photon to photon).
#[derive(Clone, Debug, Default)]
pub(crate) struct PhotonVolumes {
    /// The meshes the photon travelled in, in the order it met them.
    meshes: Vec<u32>,
    /// `bands` values per entry of `meshes`.
    values: Vec<f64>,
}

impl PhotonVolumes {
    /// Adds `sign × values` to the photon's change in `mesh`'s medium.
    #[inline]
    pub(crate) fn add(&mut self, mesh: u32, values: &[f64], sign: f64) {
        let nb = values.len();
        let i = match self.meshes.iter().position(|&m| m == mesh) {
            Some(i) => i,
            None => {
                self.meshes.push(mesh);
                self.values.resize(self.meshes.len() * nb, 0.0);
                self.meshes.len() - 1
            }
        };
        for (d, v) in self.values[i * nb..(i + 1) * nb].iter_mut().zip(values) {
            *d += sign * v;
        }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.meshes.is_empty()
    }

    pub(crate) fn clear(&mut self) {
        self.meshes.clear();
        self.values.clear();
    }
}

/// Per mesh whose medium photons travelled in: the sums over photons of what each left
/// there, per band, and of the squares (band values as photons carry them: a photon's
/// values average to its energy in photon units).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VolumeTally {
    /// Values per mesh (0 while empty).
    pub bands: usize,
    /// The meshes, ascending.
    pub meshes: Vec<u32>,
    /// `bands` per mesh: Σ over photons of each photon's change.
    pub sum: Vec<f64>,
    /// `bands` per mesh: Σ over photons of its square.
    pub sq: Vec<f64>,
    /// Per mesh: Σ over photons of (Σ_b change_b × efficacy_b)², for the luminous error.
    pub sq_lum: Vec<f64>,
}

impl VolumeTally {
    /// The index of `mesh`, added (zero) when absent.
    fn index(&mut self, mesh: u32, bands: usize) -> usize {
        if self.bands == 0 {
            self.bands = bands;
        }
        match self.meshes.binary_search(&mesh) {
            Ok(i) => i,
            Err(i) => {
                let nb = self.bands;
                self.meshes.insert(i, mesh);
                self.sum
                    .splice(i * nb..i * nb, std::iter::repeat_n(0.0, nb));
                self.sq.splice(i * nb..i * nb, std::iter::repeat_n(0.0, nb));
                self.sq_lum.insert(i, 0.0);
                i
            }
        }
    }

    /// Adds one photon's changes (`efficacy`: lm/W per band).
    pub(crate) fn add_photon(&mut self, p: &PhotonVolumes, efficacy: &[f64]) {
        let nb = efficacy.len();
        for (k, &mesh) in p.meshes.iter().enumerate() {
            let x = &p.values[k * nb..(k + 1) * nb];
            let i = self.index(mesh, nb);
            let mut lum = 0.0;
            for (b, (&v, &e)) in x.iter().zip(efficacy).enumerate() {
                self.sum[i * nb + b] += v;
                self.sq[i * nb + b] += v * v;
                lum += v * e;
            }
            self.sq_lum[i] += lum * lum;
        }
    }

    /// Adds another run's (thread's, shard's) tally.
    pub fn merge(&mut self, o: &VolumeTally) {
        for (k, &mesh) in o.meshes.iter().enumerate() {
            let nb = o.bands;
            let i = self.index(mesh, nb);
            for b in 0..nb {
                self.sum[i * nb + b] += o.sum[k * nb + b];
                self.sq[i * nb + b] += o.sq[k * nb + b];
            }
            self.sq_lum[i] += o.sq_lum[k];
        }
    }

    /// `mesh`'s sums, squares and luminous squares, if photons travelled in it.
    pub fn of(&self, mesh: u32) -> Option<(&[f64], &[f64], f64)> {
        let i = self.meshes.binary_search(&mesh).ok()?;
        let nb = self.bands;
        Some((
            &self.sum[i * nb..(i + 1) * nb],
            &self.sq[i * nb..(i + 1) * nb],
            self.sq_lum[i],
        ))
    }

    /// Whether its lengths agree with its mesh list (a state read from a file).
    pub fn consistent(&self) -> bool {
        let n = self.meshes.len();
        self.meshes.windows(2).all(|w| w[0] < w[1])
            && self.sum.len() == n * self.bands
            && self.sq.len() == n * self.bands
            && self.sq_lum.len() == n
            && (n == 0 || self.bands > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photons_sum_and_square_per_mesh_and_merge_in_any_order() {
        let eff = [100.0, 500.0];
        let mut p = PhotonVolumes::default();
        p.add(7, &[1.0, 1.0], 1.0);
        p.add(3, &[0.5, 0.0], 1.0);
        p.add(7, &[0.25, 0.5], -1.0);
        let mut a = VolumeTally::default();
        a.add_photon(&p, &eff);
        assert_eq!(a.meshes, [3, 7]);
        let (s, q, l) = a.of(7).unwrap();
        assert_eq!(s, [0.75, 0.5]);
        assert_eq!(q, [0.5625, 0.25]);
        assert_eq!(l, (75.0f64 + 250.0).powi(2));
        p.clear();
        p.add(5, &[2.0, 0.0], 1.0);
        let mut b = VolumeTally::default();
        b.add_photon(&p, &eff);
        let mut ab = a.clone();
        ab.merge(&b);
        let mut ba = b.clone();
        ba.merge(&a);
        assert_eq!(ab, ba);
        assert_eq!(ab.meshes, [3, 5, 7]);
        assert_eq!(ab.of(5).unwrap().0, [2.0, 0.0]);
        assert!(ab.consistent());
        assert!(ab.of(4).is_none());
    }
}
