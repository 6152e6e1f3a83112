//! Reading the map: irradiance, errors and absorbed power per mesh.

use super::Context;
use crate::error::{bail, Result};
use crate::imap::Readout;

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

    fn readout_args(
        &self,
        mesh: u32,
        side: u32,
        out_len: usize,
    ) -> Result<Option<(Readout<'_>, usize)>> {
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
        if out_len < m.positions.len() {
            bail!(
                ImapErrBufferTooSmall,
                "the output holds {out_len} values but mesh {mesh} has {} vertices",
                m.positions.len()
            );
        }
        Ok(match (&self.prepared, &self.map) {
            (Some(p), Some(map)) => Some((
                Readout {
                    map,
                    scene: &p.scene,
                    photons: self.photons(),
                    unit_m: self.config.unit_m,
                },
                i,
            )),
            _ => None,
        })
    }

    /// Irradiance in W/m² of `band` at each vertex of `mesh` on `side` (0 front, 1 back).
    /// All zeros before the first run.
    pub fn irradiance(&self, mesh: u32, side: u32, band: u32, out: &mut [f64]) -> Result<()> {
        if band as usize >= self.scene.bands.count() {
            bail!(
                ImapErrIndexOutOfRange,
                "band {band} is out of range (the context has {} bands)",
                self.scene.bands.count()
            );
        }
        let nv = self.vertex_count(mesh)?;
        match self.readout_args(mesh, side, out.len())? {
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
        let nv = self.vertex_count(mesh)?;
        let k = self.photometry.efficacy.clone();
        self.weighted(mesh, side, &[&k], nv, out)
    }

    /// CIE 1931 X, Y, Z at each vertex of `mesh` on `side`, three values per vertex (Y is
    /// the illuminance in lux). All zeros before the first run.
    pub fn tristimulus(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        let nv = self.vertex_count(mesh)?;
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|k| self.photometry.xyz.iter().map(|w| w[k]).collect())
            .collect();
        let rows: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        self.weighted(mesh, side, &rows, 3 * nv, out)
    }

    fn weighted(
        &self,
        mesh: u32,
        side: u32,
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
        match self.readout_args(mesh, side, len / per_vertex)? {
            Some((r, i)) => r.weighted(&r.scene.meshes[i], side as usize, rows, &mut out[..len]),
            None => out[..len].iter_mut().for_each(|x| *x = 0.0),
        }
        Ok(())
    }

    /// Relative standard error of each vertex's irradiance (band mean); 1 where nothing has
    /// arrived yet or the vertex has no area.
    pub fn rel_error(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        let nv = self.vertex_count(mesh)?;
        match self.readout_args(mesh, side, out.len())? {
            Some((r, i)) => r.rel_error(&r.scene.meshes[i], side as usize, &mut out[..nv]),
            None => out[..nv]
                .iter_mut()
                .for_each(|x| *x = crate::imap::NO_DATA_REL_ERROR),
        }
        Ok(())
    }
}
