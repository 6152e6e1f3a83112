//! Light groups and the map's layers: on request the map keeps one layer per light group
//! (so a host recombines E = Σ dimming_g · E_g without a rerun) and one for the direct
//! component (`imap::LayerLayout`). Memory is paid only then: a scene that asks for
//! neither has one cell per slot, as before.

use super::Context;
use crate::error::{bail, Result};
use crate::imap::{LayerLayout, MAX_LIGHT_GROUPS};
use crate::scene::LayerRequest;

/// Which values of the map a read-out reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layer {
    /// The whole map (the sum of the group layers).
    #[default]
    Combined,
    /// The photons of the lights and emitting meshes of one light group.
    Group(u32),
    /// The direct component: deposits made before the photon's first surface event.
    Direct,
}

impl Context {
    /// Chooses the layers the map keeps. Before any photon is traced (or after a reset);
    /// the map is reallocated on the next run.
    pub fn set_layers(&mut self, request: LayerRequest) -> Result<()> {
        self.check_unlocked("change the map's layers")?;
        if request != self.scene.layers {
            self.check_layout_budget(request, None)?;
            self.scene.layers = request;
            self.invalidate();
        }
        Ok(())
    }

    /// Puts light `light` in light group `group` (0 … `MAX_LIGHT_GROUPS` − 1).
    pub fn set_light_group(&mut self, light: u32, group: u32) -> Result<()> {
        self.check_unlocked("change a light's group")?;
        check_group(group)?;
        let n = self.scene.lights.len();
        if light as usize >= n {
            bail!(
                ImapErrIndexOutOfRange,
                "light id {light} is out of range (the scene has {n} lights)"
            );
        }
        self.check_layout_budget(self.scene.layers, Some(group))?;
        if self.scene.lights[light as usize].group != group {
            self.scene.lights[light as usize].group = group;
            self.footprint.regroup(&self.scene);
            self.invalidate();
        }
        Ok(())
    }

    /// Puts emitting mesh `mesh` in light group `group`.
    pub fn set_mesh_light_group(&mut self, mesh: u32, group: u32) -> Result<()> {
        self.check_unlocked("change a mesh's light group")?;
        check_group(group)?;
        let i = self.mesh_index(mesh)?;
        if self.scene.meshes[i].exitance.is_none() {
            bail!(
                ImapErrInvalidArgument,
                "mesh {mesh} does not emit: only lights and emitting meshes have a light group"
            );
        }
        self.check_layout_budget(self.scene.layers, Some(group))?;
        if self.scene.meshes[i].light_group != group {
            self.scene.meshes[i].light_group = group;
            self.footprint.regroup(&self.scene);
            self.invalidate();
        }
        Ok(())
    }

    /// The layers the map keeps for the scene as it is: (group layers, direct layer). 0
    /// group layers when groups are not kept.
    pub fn layers(&self) -> (u32, bool) {
        let l = self.layer_layout();
        let groups = if self.scene.layers.groups {
            l.groups as u32
        } else {
            0
        };
        (groups, l.direct)
    }

    /// Refuses a layout whose map would not fit the memory budget.
    fn check_layout_budget(&self, request: LayerRequest, group: Option<u32>) -> Result<()> {
        let now = self.layer_layout();
        let next = LayerLayout::new(request, self.footprint.largest_group.max(group));
        let extra = next.per_slot().saturating_sub(now.per_slot()) as u64;
        if extra == 0 {
            return Ok(());
        }
        let cells = self.footprint.slots.saturating_mul(extra);
        let bands = self.scene.bands.count() as u64;
        let mut bytes = super::memory::map_bytes(cells, bands);
        if self.estimator.is_light_sampling() {
            // The direct records of the new cells.
            bytes = bytes.saturating_add(super::memory::direct_record_bytes(cells, bands));
        }
        self.check_budget(
            self.memory_estimate(),
            bytes,
            &format!(
                "keeping {} map layers instead of {}",
                next.per_slot(),
                now.per_slot()
            ),
        )
    }

    /// The map layer a read-out of `layer` reads (None: combined), or why it cannot.
    pub(super) fn layer_index(&self, layer: Layer) -> Result<Option<u8>> {
        let l = self.layer_layout();
        match layer {
            Layer::Combined => Ok(None),
            Layer::Group(g) => {
                if !self.scene.layers.groups {
                    bail!(
                        ImapErrNotRecorded,
                        "light-group layers are not kept: ask for them (imap_set_layers with IMAP_KEEP_LIGHT_GROUPS) before the run"
                    );
                }
                if g >= l.groups as u32 {
                    bail!(
                        ImapErrIndexOutOfRange,
                        "light group {g} is out of range (the scene's lights use groups 0 … {})",
                        l.groups - 1
                    );
                }
                Ok(Some(g as u8))
            }
            Layer::Direct => match l.direct_layer() {
                Some(d) => Ok(Some(d)),
                None => bail!(
                    ImapErrNotRecorded,
                    "the direct layer is not kept: ask for it (imap_set_layers with IMAP_KEEP_DIRECT) before the run"
                ),
            },
        }
    }
}

fn check_group(group: u32) -> Result<()> {
    if group as usize >= MAX_LIGHT_GROUPS {
        bail!(
            ImapErrInvalidArgument,
            "light group {group} is too large: groups are 0 … {}",
            MAX_LIGHT_GROUPS - 1
        );
    }
    Ok(())
}
