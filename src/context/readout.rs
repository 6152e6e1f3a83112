//! Reading the map: irradiance, errors and absorbed power per mesh.

use super::Context;
use super::Layer;
use crate::error::{bail, Result};
use crate::imap::readout::photon_total;
use crate::imap::stats::{self, Estimate, Extremes};
use crate::imap::Readout;

/// What a mesh of the context is (`Context::mesh_info`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshInfo {
    pub vertices: usize,
    pub triangles: usize,
    /// 1, or 2 for a two-sided mesh (its map has both sides).
    pub sides: u32,
    /// Whether its map is kept.
    pub records: bool,
    /// Whether it is a sensor (crossed by photons, never stopping them).
    pub sensor: bool,
    /// Whether it emits.
    pub emits: bool,
}

impl Context {
    pub(crate) fn mesh_index(&self, mesh: u32) -> Result<usize> {
        if mesh as usize >= self.scene.meshes.len() {
            bail!(
                ImapErrIndexOutOfRange,
                "mesh id {mesh} is out of range (the scene has {} meshes)",
                self.scene.meshes.len()
            );
        }
        Ok(mesh as usize)
    }

    /// Vertex count of a mesh.
    pub fn vertex_count(&self, mesh: u32) -> Result<usize> {
        Ok(self.scene.meshes[self.mesh_index(mesh)?].positions.len())
    }

    /// What mesh `mesh` is: its vertex and triangle counts, sides and roles
    /// (IMAP_ERR_INDEX_OUT_OF_RANGE for no such mesh).
    pub fn mesh_info(&self, mesh: u32) -> Result<MeshInfo> {
        let m = &self.scene.meshes[self.mesh_index(mesh)?];
        Ok(MeshInfo {
            vertices: m.positions.len(),
            triangles: m.triangles.len(),
            sides: if m.two_sided { 2 } else { 1 },
            records: m.record,
            sensor: m.sensor,
            emits: m.exitance.is_some(),
        })
    }

    /// Lights added so far (luminaires, skies, the sun and the ground included; emitting
    /// meshes are meshes).
    pub fn light_count(&self) -> usize {
        self.scene.lights.len()
    }

    /// Checks that mesh `mesh` records side `side` (IMAP_ERR_NOT_RECORDED,
    /// IMAP_ERR_INDEX_OUT_OF_RANGE otherwise), before anything is traced for it.
    pub fn check_recorded_side(&self, mesh: u32, side: u32) -> Result<()> {
        self.recorded_side(mesh, side).map(|_| ())
    }

    /// The index of recording mesh `mesh`, whose side `side` exists.
    fn recorded_side(&self, mesh: u32, side: u32) -> Result<usize> {
        let i = self.mesh_index(mesh)?;
        let m = &self.scene.meshes[i];
        if !m.record {
            bail!(
                ImapErrNotRecorded,
                "mesh {mesh} does not record (it was added with record = 0)"
            );
        }
        if side as usize >= m.sides() {
            bail!(ImapErrIndexOutOfRange, "side {side} is out of range: mesh {mesh} is one-sided and records only side 0 (front)");
        }
        Ok(i)
    }

    /// What reads `layer` of mesh `mesh`'s side `side` into `out_len` values, and the
    /// mesh's index; None before the first run.
    fn layer_readout_args(
        &self,
        mesh: u32,
        side: u32,
        layer: Layer,
        out_len: usize,
    ) -> Result<Option<(Readout<'_>, usize)>> {
        let layer = self.layer_index(layer)?;
        let i = self.recorded_side(mesh, side)?;
        let m = &self.scene.meshes[i];
        if out_len < m.positions.len() {
            bail!(
                ImapErrBufferTooSmall,
                "the output holds {out_len} values but mesh {mesh} has {} vertices",
                m.positions.len()
            );
        }
        Ok(self.readout(layer).map(|r| (r, i)))
    }

    /// What reads the map's `layer` (None: the combined values); None before the first run.
    pub(super) fn readout(&self, layer: Option<u8>) -> Option<Readout<'_>> {
        let prepared = self.prepared.as_ref()?;
        Some(Readout {
            map: self.map.as_ref()?,
            scene: &prepared.scene,
            photons: self.photons(),
            unit_m: self.config.unit_m,
            layer,
            plan: prepared
                .direct
                .as_ref()
                .map(|p| p as &dyn crate::imap::Neighbours),
        })
    }

    /// Irradiance in W/m² of `band` at each vertex of `mesh` on `side` (0 front, 1 back).
    /// All zeros before the first run.
    pub fn irradiance(&self, mesh: u32, side: u32, band: u32, out: &mut [f64]) -> Result<()> {
        self.irradiance_layer(mesh, side, band, Layer::Combined, out)
    }

    /// `irradiance` of one layer of the map.
    pub fn irradiance_layer(
        &self,
        mesh: u32,
        side: u32,
        band: u32,
        layer: Layer,
        out: &mut [f64],
    ) -> Result<()> {
        if band as usize >= self.scene.bands.count() {
            bail!(
                ImapErrIndexOutOfRange,
                "band {band} is out of range (the context has {} bands)",
                self.scene.bands.count()
            );
        }
        let nv = self.vertex_count(mesh)?;
        match self.layer_readout_args(mesh, side, layer, out.len())? {
            Some((r, i)) => r.irradiance(
                &r.scene.meshes[i],
                side as usize,
                band as usize,
                &mut out[..nv],
            ),
            None => out[..nv].iter_mut().for_each(|x| *x = 0.0),
        }
        Ok(())
    }

    /// Illuminance in lux at each vertex of `mesh` on `side`: Σ_b K_b E_b with the bands'
    /// luminous efficacies (docs/photometry.md). All zeros before the first run.
    pub fn illuminance(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        self.illuminance_layer(mesh, side, Layer::Combined, out)
    }

    /// `illuminance` of one layer of the map.
    pub fn illuminance_layer(
        &self,
        mesh: u32,
        side: u32,
        layer: Layer,
        out: &mut [f64],
    ) -> Result<()> {
        let nv = self.vertex_count(mesh)?;
        let k = self.photometry.efficacy.clone();
        self.weighted(mesh, side, layer, &[&k], nv, out)
    }

    /// CIE 1931 X, Y, Z at each vertex of `mesh` on `side`, three values per vertex (Y is
    /// the illuminance in lux). All zeros before the first run.
    pub fn tristimulus(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        let nv = self.vertex_count(mesh)?;
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|k| self.photometry.xyz.iter().map(|w| w[k]).collect())
            .collect();
        let rows: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        self.weighted(mesh, side, Layer::Combined, &rows, 3 * nv, out)
    }

    fn weighted(
        &self,
        mesh: u32,
        side: u32,
        layer: Layer,
        rows: &[&[f64]],
        len: usize,
        out: &mut [f64],
    ) -> Result<()> {
        let per_vertex = rows.len();
        if out.len() < len {
            bail!(
                ImapErrBufferTooSmall,
                "the output holds {} values but mesh {mesh} needs {len} ({per_vertex} per vertex)",
                out.len()
            );
        }
        match self.layer_readout_args(mesh, side, layer, len / per_vertex)? {
            Some((r, i)) => r.weighted(&r.scene.meshes[i], side as usize, rows, &mut out[..len]),
            None => out[..len].iter_mut().for_each(|x| *x = 0.0),
        }
        Ok(())
    }

    /// Relative standard error of each vertex's irradiance (band mean); 1 where nothing has
    /// arrived yet or the vertex has no area.
    pub fn rel_error(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        self.rel_error_layer(mesh, side, Layer::Combined, out)
    }

    /// `rel_error` of one layer of the map (the layer's own Monte Carlo error).
    pub fn rel_error_layer(
        &self,
        mesh: u32,
        side: u32,
        layer: Layer,
        out: &mut [f64],
    ) -> Result<()> {
        let nv = self.vertex_count(mesh)?;
        match self.layer_readout_args(mesh, side, layer, out.len())? {
            Some((r, i)) => r.rel_error(&r.scene.meshes[i], side as usize, &mut out[..nv]),
            None => out[..nv]
                .iter_mut()
                .for_each(|x| *x = crate::imap::NO_DATA_REL_ERROR),
        }
        Ok(())
    }
}

/// What a region (a recorded side of a mesh, or a part of it) received: incident flux per
/// band and in lumens, average illuminance, and its extremes and uniformities, each with a
/// standard error (`imap::stats`; docs/results.md).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RegionStats {
    /// The region's area, m².
    pub area_m2: f64,
    /// Vertices of the region.
    pub vertices: usize,
    /// Photons the figures are made of (0 before any run).
    pub photons: u64,
    /// The flux and average errors are exact (the mesh keeps per-photon region tallies:
    /// a sensor, or added with `tally`); otherwise they are an upper bound, Σ aᵥσᵥ.
    pub exact_errors: bool,
    /// Incident radiant flux per band, W.
    pub flux_w: Vec<Estimate>,
    /// Incident luminous flux, lm.
    pub flux_lm: Estimate,
    /// Incident irradiance averaged over the region per band, W/m².
    pub average_w_m2: Vec<Estimate>,
    /// Average illuminance, lx (flux_lm / area).
    pub average: Estimate,
    /// Minimum and maximum vertex illuminance (bias-corrected), U0 = Emin/Eavg,
    /// Ud = Emin/Emax, over the vertices that received light; None before any photon.
    pub extremes: Option<Extremes>,
    /// Vertices of the region that received no light at all (no photon, no light sample:
    /// under or inside an object). They are left out of the extremes and of region
    /// targets on the vertices' errors; their value is 0.
    pub unlit_vertices: usize,
}

impl Context {
    /// Each vertex's share of the adjacent triangles' area (a third of each), m².
    pub fn vertex_areas(&self, mesh: u32, out: &mut [f64]) -> Result<()> {
        let m = &self.scene.meshes[self.mesh_index(mesh)?];
        let nv = m.positions.len();
        if out.len() < nv {
            bail!(
                ImapErrBufferTooSmall,
                "the output holds {} values but mesh {mesh} has {nv} vertices",
                out.len()
            );
        }
        let unit2 = self.config.unit_m * self.config.unit_m;
        for (o, a) in out.iter_mut().zip(m.area_shares(None)) {
            *o = a * unit2;
        }
        Ok(())
    }

    /// The figures of mesh `mesh`'s side `side`, or of its part made of material `part`.
    pub fn region_stats(&self, mesh: u32, side: u32, part: Option<u32>) -> Result<RegionStats> {
        self.region_stats_layer(mesh, side, part, Layer::Combined)
    }

    /// `region_stats` of one layer of the map: a light group's or the direct component's
    /// flux, average, extremes and uniformities, with errors as exact as the combined
    /// figures' (a recording mesh with tallies keeps them per layer).
    pub fn region_stats_layer(
        &self,
        mesh: u32,
        side: u32,
        part: Option<u32>,
        layer: Layer,
    ) -> Result<RegionStats> {
        let i = self.recorded_side(mesh, side)?;
        let index = self.layer_index(layer)?;
        let m = &self.scene.meshes[i];
        if let Some(p) = part {
            if !(0..m.triangles.len()).any(|t| m.material_of(t) == p) {
                bail!(
                    ImapErrIndexOutOfRange,
                    "mesh {mesh} has no triangle of material {p}: no such part"
                );
            }
        }
        // Each vertex's share of the region's area, m², and the region's area.
        let unit2 = self.config.unit_m * self.config.unit_m;
        let weights: Vec<f64> = m.area_shares(part).iter().map(|a| a * unit2).collect();
        let area: f64 = weights.iter().sum();
        let nb = self.scene.bands.count();
        let mut out = RegionStats {
            area_m2: area,
            vertices: weights.iter().filter(|w| **w > 0.0).count(),
            flux_w: vec![Estimate::default(); nb],
            average_w_m2: vec![Estimate::default(); nb],
            ..Default::default()
        };
        let (Some(p), n) = (&self.prepared, self.photons()) else {
            return Ok(out);
        };
        if n == 0 {
            return Ok(out);
        }
        out.photons = n;
        // The vertices' illuminance and errors.
        let nv = m.positions.len();
        let mut lux = vec![0.0; nv];
        let mut rel = vec![0.0; nv];
        self.illuminance_layer(mesh, side, layer, &mut lux)?;
        self.rel_error_layer(mesh, side, layer, &mut rel)?;
        if let Some(regions) = &p.layout.regions.meshes[i] {
            // The photon tallies: exact errors.
            out.exact_errors = true;
            let r = regions.region(side as usize, part);
            // A layer's own tally, except the one group layer of a map whose lights are
            // all in group 0 (its figures are the region's).
            let layout = &p.layout.regions;
            let r = match index {
                Some(l)
                    if layout.layers > 0
                        && (l >= p.layout.layers.groups || p.layout.layers.groups > 1) =>
                {
                    layout.layered(r, l)
                }
                _ => r,
            } as usize;
            let t = &self.region_tally;
            let nf = n as f64;
            let wpu = p.scene.total_power / (nf * nb as f64);
            let est = |sum: f64, sq: f64| photon_total(sum, sq, nf, wpu);
            for b in 0..nb {
                out.flux_w[b] = est(t.sum[r * nb + b], t.sq[r * nb + b]);
            }
            let lum_sum: f64 = (0..nb)
                .map(|b| t.sum[r * nb + b] * p.scene.efficacy[b])
                .sum();
            out.flux_lm = est(lum_sum, t.sq_lum[r]);
            // Light sampling: the tallies hold the photons' part; the direct part is the
            // vertices' (a run's region target reads the same: `sched::target`). For a mesh
            // side the vertices' fluxes sum to the side's exactly; for a part, each vertex
            // counts with its share of the part's area.
            let direct = self.readout(index).and_then(|r| {
                r.region_direct(&p.scene.meshes[i], side as usize, &m.area_shares(part))
            });
            if let Some(d) = direct {
                for b in 0..nb {
                    let e = &mut out.flux_w[b];
                    e.value += d.flux[b];
                    e.sigma = (e.sigma * e.sigma + d.var[b]).sqrt();
                }
                out.flux_lm.value += d.lum;
                out.flux_lm.sigma = (out.flux_lm.sigma.powi(2) + d.var_lum).sqrt();
            }
        } else {
            // No tallies: sums over the vertices, with the upper bound Σ aᵥσᵥ of their
            // errors (correlated vertices: the error of a sum is at most the sum of errors).
            let bound = |e: &[f64]| Estimate {
                value: e.iter().zip(&weights).map(|(e, w)| e * w).sum(),
                sigma: e
                    .iter()
                    .zip(&weights)
                    .zip(&rel)
                    .map(|((e, w), r)| e * w * r)
                    .sum(),
            };
            let mut e = vec![0.0; nv];
            for b in 0..nb {
                self.irradiance(mesh, side, b as u32, &mut e)?;
                out.flux_w[b] = bound(&e);
            }
            out.flux_lm = bound(&lux);
        }
        let per_area = |e: Estimate| Estimate {
            value: e.value / area,
            sigma: e.sigma / area,
        };
        out.average_w_m2 = out.flux_w.iter().copied().map(per_area).collect();
        out.average = per_area(out.flux_lm);
        let sigma: Vec<f64> = lux.iter().zip(&rel).map(|(l, r)| l * r).collect();
        let lit = stats::lit_weights(&lux, &weights);
        out.unlit_vertices = weights
            .iter()
            .zip(&lit)
            .filter(|(w, l)| **w > 0.0 && **l == 0.0)
            .count();
        out.extremes = stats::extremes(&lux, &sigma, &lit, out.average);
        Ok(out)
    }
}
