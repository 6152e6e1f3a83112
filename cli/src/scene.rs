//! Scenes in: OBJ + MTL (`obj`, `mtl`), and the TOML settings file.
//!
//! MTL mapping (`materials`): `Kd` → Lambertian reflectance, `Ks` → specular reflectance,
//! a transparent material (`d` < 1, `Tr` > 0 or `Tf`) with `Ni` > 1 → dielectric (index
//! `Ni`; `Tf` is the internal transmittance of 1 m of the material), `Ke` → self-emitting
//! surface with exitance `Ke` W/m² per band. RGB values become spectra for spectral runs by
//! band: below 490 nm the blue value, 490–580 nm green, above red. The TOML file can
//! override any material property.

use crate::diag::{printable, Diagnostics};
use crate::error::{fail, name_item, CliError, Result};
use crate::lights::{self, PlacedLight};
use crate::materials::{self, Resolved};
use crate::settings::Settings;
use imap::{Config, Context, MeshDesc};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// The triangles of the objects `names` as portals, each facing away from the model's
/// centre: an object whose triangles all face the centre (a window drawn facing in) is
/// turned round; one with triangles both ways (a pane's slab) keeps those facing out, so
/// that no line from the sky crosses two portals of one window.
pub fn portal_triangles(
    model: &crate::model::Model,
    names: &[String],
) -> std::result::Result<(Vec<f64>, Vec<u32>), String> {
    let (lo, hi) = model.bounds();
    let centre = (glam::DVec3::from(lo) + glam::DVec3::from(hi)) * 0.5;
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    for name in names {
        let objects: Vec<&crate::model::Object> =
            model.objects.iter().filter(|o| &o.name == name).collect();
        if objects.is_empty() {
            return Err(format!(
                "portals names '{}', which is no object or group of the model",
                printable(name)
            ));
        }
        let tris: Vec<[glam::DVec3; 3]> = objects
            .iter()
            .flat_map(|o| o.triangles.iter())
            .map(|t| t.v.map(|v| glam::DVec3::from(model.positions[v as usize])))
            .collect();
        let out = |t: &[glam::DVec3; 3]| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            n.dot((t[0] + t[1] + t[2]) / 3.0 - centre) > 0.0
        };
        let facing_out: Vec<[glam::DVec3; 3]> = tris.iter().filter(|t| out(t)).copied().collect();
        let chosen = if facing_out.is_empty() {
            tris.iter().map(|t| [t[0], t[2], t[1]]).collect()
        } else {
            facing_out
        };
        for t in chosen {
            for p in t {
                indices.push((positions.len() / 3) as u32);
                positions.extend(p.to_array());
            }
        }
    }
    Ok((positions, indices))
}

/// One mesh as loaded, kept for the outputs.
pub struct LoadedMesh {
    /// The OBJ object's name (with the material's for an emitting part split off).
    pub name: String,
    /// Positions as the file wrote them, in the file's vertex order (f64).
    pub positions: Vec<f64>,
    pub indices: Vec<u32>,
    /// Each vertex's index among the file's `v` statements (0-based).
    pub file_vertex: Vec<u32>,
    /// libimap's mesh id when recorded.
    pub id: Option<u32>,
    /// libimap's mesh id.
    pub mesh: u32,
    /// Diffuse reflectance per band of each vertex (the mean of its triangles'; for the
    /// rendered view) and exitance if emitting.
    pub diffuse: Vec<Vec<f64>>,
    pub emission: Option<Vec<f64>>,
}

/// The scene handed to libimap, and what the outputs need of it.
pub struct LoadedScene {
    pub meshes: Vec<LoadedMesh>,
    pub band_nm: Vec<f64>,
    pub rgb: bool,
    /// Warnings of the load (printed once each).
    pub warnings: Vec<String>,
    /// The lights and luminaires added, with their flux.
    pub lights: Vec<PlacedLight>,
    /// The calculation grids.
    pub grids: Vec<crate::grids::Grid>,
    /// The observers (`[[observer]]`), each a sensor at its eye.
    pub observers: Vec<crate::observers::ObserverEntry>,
    /// The model's file format, and its triangles (those repeating a vertex left out).
    pub format: &'static str,
    pub triangles_read: usize,
    /// libimap materials made for colours from textures and vertex colours: one per
    /// material and colour in steps of 1/63 of sRGB.
    pub material_variants: usize,
    /// Every mesh records both sides (settings `two_sided`).
    pub two_sided: bool,
}

impl LoadedScene {
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        crate::model::bounds(
            self.meshes
                .iter()
                .flat_map(|m| m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]])),
        )
    }
}

/// The context's configuration from the settings.
fn config(settings: &Settings) -> Result<Config> {
    Ok(Config {
        bands: settings.bands()?,
        threads: settings.run.threads,
        seed: settings.run.seed,
        scheduler: settings.scheduler()?,
        unit_m: settings.unit_m.unwrap_or(1.0),
        aim_lights: settings.run.aim_lights,
        ..Default::default()
    })
}

/// Warnings where the settings leave the model's units or up axis to a default that its
/// geometry disagrees with (`Model::guesses`): a model drawn in millimetres and read in
/// metres gets a millionth of its illuminance, and a z-up model read y-up gets its sky
/// from the side.
pub fn guess_warnings(
    model: &crate::model::Model,
    unit_m: Option<f64>,
    up_axis: Option<&str>,
) -> Vec<String> {
    let g = model.guesses();
    let mut out = Vec::new();
    if let (None, Some((name, k))) = (unit_m, g.unit) {
        out.push(format!(
            "no unit_m is set, so the model is read in metres: {}. It looks drawn in {name} ({}): set unit_m = {k} (or unit_m = 1 to keep metres)",
            g.size_at(1.0),
            g.size_at(k)
        ));
    }
    if let (None, Some(axis), Some((_, why))) = (up_axis, g.up_name(), &g.up) {
        if axis != "y" {
            out.push(format!(
                "no up_axis is set, so +y is up (the sky's zenith, the sun, the default camera); the model looks {axis}-up ({why}): set up_axis = \"{axis}\" (or up_axis = \"y\" to keep y)"
            ));
        }
    }
    out
}

/// The most triangles `refine` may make in all.
pub const MAX_REFINED_TRIANGLES: usize = 20_000_000;

/// Recorded objects whose vertices lie much farther apart than a calculation grid's points
/// would (more than twice EN 12464-1's spacing for the object's size): their map holds only
/// those vertices' values, and the view interpolates between them (a floor of two triangles
/// shows four values). Objects that emit are left out.
pub fn coarse_warnings(
    model: &crate::model::Model,
    records: &dyn Fn(&str) -> bool,
    unit_m: f64,
) -> Vec<String> {
    // (name, vertices, m² per vertex, spacing to suggest)
    let mut coarse: Vec<(String, usize, f64, f64)> = Vec::new();
    for o in model.objects.iter().filter(|o| records(&o.name)) {
        let emits = o.triangles.iter().any(|t| {
            t.material
                .and_then(|m| model.materials.get(m))
                .is_some_and(|m| m.ke.is_some_and(|k| k.iter().any(|&x| x > 0.0)))
        });
        if emits || o.triangles.is_empty() {
            continue;
        }
        let mut vertices: Vec<u32> = o.triangles.iter().flat_map(|t| t.v).collect();
        vertices.sort_unstable();
        vertices.dedup();
        let area: f64 = o
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.v.map(|v| glam::DVec3::from(model.positions[v as usize]));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum::<f64>()
            * unit_m
            * unit_m;
        let (lo, hi) = crate::model::bounds(vertices.iter().map(|&v| model.positions[v as usize]));
        let d = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) * unit_m;
        if !(area > 0.0 && d > 0.0) {
            continue;
        }
        let p = crate::grids::en12464_spacing_m(d);
        let spacing = (area / vertices.len() as f64).sqrt();
        if spacing > 2.0 * p {
            coarse.push((
                printable(&o.name),
                vertices.len(),
                area / vertices.len() as f64,
                p,
            ));
        }
    }
    if coarse.is_empty() {
        return Vec::new();
    }
    let p = coarse.iter().map(|c| c.3).fold(f64::INFINITY, f64::min);
    let mut named: Vec<String> = coarse
        .iter()
        .take(4)
        .map(|(n, v, a, _)| format!("'{n}' {v} vertices, one per {a:.2} m²"))
        .collect();
    if coarse.len() > 4 {
        named.push(format!("{} more", coarse.len() - 4));
    }
    vec![format!(
        "{} recorded object(s) have their vertices far apart ({}): a map holds only the vertices' values, and view.png interpolates between them; refine = {p:.2} (metres: EN 12464-1's grid spacing for their size) splits the recorded triangles to that edge length",
        coarse.len(),
        named.join("; ")
    )]
}

/// The warning for a closed object whose normals point inward.
pub fn inward_warning(path: &Path, name: &str, volume: f64) -> String {
    format!(
        "{}: object '{}' is closed and its normals point inward (its signed volume is {volume:.4e} scene units³): the side libimap records faces its inside; flip_normals = [\"{}\"] records its outside (or two_sided = true both)",
        path.display(),
        printable(name),
        printable(name)
    )
}

/// The material `imap annual` gives a window group's openings in the runs of the other
/// groups' states: black, opaque.
pub const BLACK: &str = "imap:black";

/// Gives the objects of each of `settings.assign` its material (`imap annual`'s window
/// groups): one of the model's, a `[materials.NAME]` of the settings (a material of that
/// name is added for it to override), or `BLACK`.
fn assign_materials(
    model: &mut crate::model::Model,
    settings: &Settings,
    path: &Path,
    diag: &mut Diagnostics,
) {
    for a in &settings.assign {
        let (objects, material) = (&a.objects, &a.material);
        for n in objects {
            if !model.objects.iter().any(|o| &o.name == n) {
                diag.error(
                    &a.at.0,
                    a.at.1,
                    format!(
                        "{}: '{}' is no object or group of {}",
                        a.what,
                        printable(n),
                        path.display()
                    ),
                );
            }
        }
        let index = match model.materials.iter().position(|m| &m.name == material) {
            Some(i) => i,
            None => {
                let black = material == BLACK;
                if !black && !settings.materials.contains_key(material) {
                    diag.error(
                        &a.at.0,
                        a.at.1,
                        format!(
                            "{}: material '{}' is neither one of {} nor a [materials.{}] of the settings",
                            a.what,
                            printable(material),
                            path.display(),
                            printable(material)
                        ),
                    );
                }
                model.materials.push(crate::model::Mtl {
                    name: material.clone(),
                    at: settings.locate(&format!("[materials.{material}]")),
                    kd: black.then_some([0.0; 3]),
                    ..Default::default()
                });
                model.materials.len() - 1
            }
        };
        for o in model
            .objects
            .iter_mut()
            .filter(|o| objects.contains(&o.name))
        {
            for t in &mut o.triangles {
                t.material = Some(index);
            }
        }
    }
}

/// Builds the libimap context from a model file (OBJ, glTF, PLY, STL) and settings.
pub fn load(path: &Path, settings: &Settings) -> Result<(Context, LoadedScene)> {
    let mut diag = Diagnostics::default();
    let mut model = crate::readers::load(path, &mut diag).map_err(CliError)?;
    for n in &settings.flip_normals {
        if !model.objects.iter().any(|m| &m.name == n) {
            let (file, line) = settings.locate("flip_normals");
            diag.error(
                &file,
                line,
                format!(
                    "flip_normals names '{n}', which is no object or group of {}",
                    path.display()
                ),
            );
        }
    }
    model.flip(&settings.flip_normals);
    assign_materials(&mut model, settings, path, &mut diag);
    if !settings.window_groups.is_empty() {
        diag.warn(format!(
            "{}: [[window_group]] is read by imap annual only: ignored here",
            settings
                .source
                .as_ref()
                .map_or("settings".into(), |(p, _)| p.display().to_string())
        ));
    }
    let unit_m = settings.unit_m.unwrap_or(1.0);
    let records =
        |name: &str| settings.record.is_empty() || settings.record.iter().any(|r| r == name);
    match settings.refine {
        Some(r) => {
            if let Err(e) = model.refine(&records, r / unit_m, MAX_REFINED_TRIANGLES) {
                let (file, line) = settings.locate("refine");
                diag.error(&file, line, format!("refine = {r}: {e}"));
            }
        }
        None => {
            for w in coarse_warnings(&model, &records, unit_m) {
                diag.warn(w);
            }
        }
    }
    if !settings.two_sided {
        for (name, v) in model.inward() {
            let recorded = settings.record.is_empty() || settings.record.contains(&name);
            if recorded {
                diag.warn(inward_warning(path, &name, v));
            }
        }
    }
    for w in guess_warnings(&model, settings.unit_m, settings.up_axis.as_deref()) {
        diag.warn(w);
    }
    for name in settings.materials.keys() {
        if !model.materials.iter().any(|m| &m.name == name) {
            diag.warn(format!(
                "settings: [materials.{name}] names no material of {}",
                path.display()
            ));
        }
    }
    for n in &settings.record {
        if !model.objects.iter().any(|m| &m.name == n) {
            let (file, line) = settings.locate("record");
            diag.error(
                &file,
                line,
                format!(
                    "record names '{n}', which is no object or group of {}",
                    path.display()
                ),
            );
        }
    }
    let bands = settings.bands()?;
    let band_nm = bands.wavelengths_nm.clone();
    let rgb = bands.rgb;
    let efficacy = imap::photometry::BandPhotometry::new(&bands).efficacy;
    let units = materials::Units {
        efficacy: &efficacy,
        unit_m,
    };
    // Materials: the file's first, then the settings' overrides (warnings once each).
    let resolved: Vec<Resolved> = model
        .materials
        .iter()
        .map(|m| {
            let at = settings.locate(&format!("[materials.{}]", m.name));
            materials::resolve(
                m,
                settings.materials.get(&m.name),
                &at,
                &band_nm,
                rgb,
                &units,
                &mut diag,
            )
        })
        .collect();
    if diag.has_errors() {
        return Err(CliError::from_diagnostics(&diag));
    }
    let mut ctx = Context::new(config(settings)?)?;
    // Objects wholly of glass (a dielectric), for `glass_portals`.
    let glass_objects: Vec<String> = if settings.glass_portals {
        let glass: Vec<bool> = resolved.iter().map(|r| r.desc.ior.is_some()).collect();
        model
            .objects
            .iter()
            .filter(|o| {
                !o.triangles.is_empty()
                    && o.triangles
                        .iter()
                        .all(|t| t.material.is_some_and(|m| glass[m]))
            })
            .map(|o| o.name.clone())
            .collect()
    } else {
        Vec::new()
    };
    let mut palette = Palette::new(&model, settings, &band_nm, rgb, &units, resolved);

    let mut meshes = Vec::new();
    for object in &model.objects {
        // One mesh of the object's non-emitting triangles, one per emitting material (and
        // per colour of its emission texture: a texel that is black emits nothing).
        // (emitting material, its emission texture's colour key), or None.
        type Emits = Option<(usize, Option<[u8; 3]>)>;
        let mut parts: Vec<(Emits, Vec<&crate::model::Triangle>)> = Vec::new();
        let mut index: HashMap<Emits, usize> = HashMap::new();
        for t in &object.triangles {
            let key = t
                .material
                .filter(|&i| palette.resolved[i].emission.is_some())
                .and_then(|i| match palette.emission_colour(i, t) {
                    None => Some((i, None)),
                    Some(k) if k == [0; 3] => None,
                    Some(k) => Some((i, Some(k))),
                });
            let next = parts.len();
            let at = *index.entry(key).or_insert(next);
            if at == next {
                parts.push((key, Vec::new()));
            }
            parts[at].1.push(t);
        }
        for (emitter, tris) in parts {
            let name = match emitter {
                Some((i, None)) => format!("{}/{}", object.name, model.materials[i].name),
                Some((i, Some(k))) => format!(
                    "{}/{}/emission {:02x}{:02x}{:02x}",
                    object.name, model.materials[i].name, k[0], k[1], k[2]
                ),
                None => object.name.clone(),
            };
            let emission = emitter.map(|(_, k)| k.map(crate::model::key_colour));
            let mesh = build_mesh(&name, &tris, &mut palette, &mut ctx, emission)?;
            let label = format!("{}: object '{}'", path.display(), printable(&name));
            let id = ctx
                .add_mesh(&mesh.desc())
                .map_err(|e| CliError(format!("{label}: {}", e.message)))?;
            name_item(|n| &mut n.meshes, id, label);
            meshes.push(LoadedMesh {
                id: mesh.record.then_some(id),
                mesh: id,
                ..mesh.loaded
            });
        }
    }
    let variants = palette.variants();
    let mut placed = Vec::new();
    let light_label = |i: usize| settings.label("[[light]]", i, &format!("light {}", i + 1));
    lights::add_lights(&mut ctx, &settings.lights, &light_label, &mut placed)?;
    let luminaire_label =
        |i: usize| settings.label("[[luminaire]]", i, &format!("luminaire {}", i + 1));
    lights::add_luminaires(
        &mut ctx,
        &settings.luminaires,
        &settings.base_dir,
        &luminaire_label,
        &mut placed,
    )?;
    crate::daylight::add_daylight(
        &mut ctx,
        settings.sky.as_ref(),
        settings.environment.as_ref(),
        settings.sun.as_ref(),
        &settings.base_dir,
        settings.up()?,
        &mut placed,
    )?;
    if settings.glass_portals && glass_objects.is_empty() {
        let (file, line) = settings.locate("glass_portals");
        fail!(
            "{}:{line}: glass_portals = true, but no object of the model is wholly glass (a transparent material with an index of refraction); name the openings in portals = [...]",
            file.display()
        );
    }
    let mut portal_names = settings.portals.clone();
    portal_names.extend(
        glass_objects
            .iter()
            .filter(|g| !settings.portals.contains(g))
            .cloned(),
    );
    if !portal_names.is_empty() {
        let (file, line) = settings.locate(if settings.portals.is_empty() {
            "glass_portals"
        } else {
            "portals"
        });
        if settings.sky.is_none() && settings.environment.is_none() && settings.sun.is_none() {
            fail!(
                "{}:{line}: portals bring daylight in, but there is no [sky], [environment] or [sun]",
                file.display()
            );
        }
        let (positions, indices) = portal_triangles(&model, &portal_names)
            .map_err(|e| CliError(format!("{}:{line}: {e}", file.display())))?;
        ctx.set_portals(&positions, &indices)
            .map_err(|e| CliError(format!("{}:{line}: portals: {}", file.display(), e.message)))?;
    }
    if let Some(m) = &settings.medium {
        scene_medium(&mut ctx, m, settings, band_nm.len())?;
    }
    for (id, l) in placed.iter().enumerate() {
        name_item(
            |n| &mut n.lights,
            id as u32,
            format!("settings: {}", l.name),
        );
    }
    let grid_label = |k: usize, what: &str| match settings.locate_nth("[[grid]]", k) {
        (p, line) if line > 0 => format!("{}:{line}: {what}", p.display()),
        _ => what.to_string(),
    };
    let triangles: Vec<[glam::DVec3; 3]> = if settings.grids.is_empty() {
        Vec::new()
    } else {
        meshes
            .iter()
            .flat_map(|m| {
                m.indices.chunks_exact(3).map(|t| {
                    [t[0], t[1], t[2]]
                        .map(|v| glam::DVec3::from_slice(&m.positions[3 * v as usize..]))
                })
            })
            .collect()
    };
    let mut grid_diag = Diagnostics::default();
    let grids = crate::grids::add_grids(
        &mut ctx,
        &settings.grids,
        settings.unit_m.unwrap_or(1.0),
        &settings.base_dir,
        &grid_label,
        &triangles,
        &mut grid_diag,
    )?;
    drop(triangles);
    diag.warnings.extend(grid_diag.warnings);
    for g in &grids {
        name_item(
            |n| &mut n.meshes,
            g.id,
            format!("settings: grid '{}'", g.name),
        );
    }
    let observers = crate::observers::add(&mut ctx, settings)?;
    for o in &observers {
        name_item(
            |n| &mut n.meshes,
            o.mesh,
            format!("settings: observer '{}'", o.name),
        );
    }
    Ok((
        ctx,
        LoadedScene {
            meshes,
            band_nm,
            rgb,
            warnings: diag.warnings,
            lights: placed,
            grids,
            observers,
            format: model.format,
            triangles_read: model.triangles(),
            material_variants: variants,
            two_sided: settings.two_sided,
        },
    ))
}

/// A file material (None: the default grey) and a colour key (None: its own colour).
type MaterialKey = (Option<usize>, Option<[u8; 3]>);

/// `[medium]`: a material of index 1 with the medium's coefficients, made the scene's
/// medium; errors name the settings' line.
fn scene_medium(
    ctx: &mut imap::Context,
    m: &crate::settings::MediumSettings,
    settings: &Settings,
    nb: usize,
) -> Result<()> {
    let (file, line) = settings.locate("[medium]");
    let at = |e: String| CliError(format!("{}:{line}: [medium] {e}", file.display()));
    let per_band = |s: &Option<crate::settings::Spectrum>, what: &str| -> Result<Vec<f64>> {
        let v = s.as_ref().map_or(vec![], |s| s.values());
        match v.len() {
            0 | 1 => Ok(v),
            n if n == nb => Ok(v),
            n => Err(at(format!(
                "{what} has {n} values; give 1 or {nb} (one per band)"
            ))),
        }
    };
    let table = m.phase_table.as_deref().unwrap_or(&[]);
    let desc = imap::MaterialDesc {
        ior: Some(imap::IorModel::Constant(1.0)),
        absorption_per_m: per_band(&m.absorption_per_m, "absorption_per_m")?,
        scattering_per_m: per_band(&m.scattering_per_m, "scattering_per_m")?,
        phase_g: per_band(&m.phase_g, "phase_g")?,
        phase_angles_deg: table.iter().map(|r| r[0]).collect(),
        phase_values: table.iter().map(|r| r[1]).collect(),
        ..Default::default()
    };
    if desc.absorption_per_m.is_empty() && desc.scattering_per_m.is_empty() {
        return Err(at(
            "gives neither absorption_per_m nor scattering_per_m: a medium needs one".into(),
        ));
    }
    let id = ctx.add_material(&desc).map_err(|e| at(e.message))?;
    ctx.set_scene_medium(Some(id)).map_err(|e| at(e.message))
}

/// The libimap materials of a model, made on first use: one per file material, and one per
/// (material, colour) where a texture or vertex colours give triangles their own colour.
struct Palette<'a> {
    model: &'a crate::model::Model,
    settings: &'a Settings,
    band_nm: &'a [f64],
    rgb: bool,
    units: &'a materials::Units<'a>,
    /// The file's materials with the settings' overrides.
    resolved: Vec<Resolved>,
    /// Per file material: whether the settings fix its colour (a diffuse value, or glass),
    /// so that no texture or vertex colour changes it.
    fixed_colour: Vec<bool>,
    /// Every material made, with its libimap id, by key.
    made: BTreeMap<MaterialKey, (u32, Resolved)>,
}

impl<'a> Palette<'a> {
    fn new(
        model: &'a crate::model::Model,
        settings: &'a Settings,
        band_nm: &'a [f64],
        rgb: bool,
        units: &'a materials::Units<'a>,
        resolved: Vec<Resolved>,
    ) -> Self {
        let fixed_colour = model
            .materials
            .iter()
            .map(|m| {
                settings
                    .materials
                    .get(&m.name)
                    .is_some_and(|o| o.diffuse.is_some() || o.dielectric == Some(true))
            })
            .collect();
        Palette {
            model,
            settings,
            band_nm,
            rgb,
            units,
            resolved,
            fixed_colour,
            made: BTreeMap::new(),
        }
    }

    /// Materials made for colours from textures and vertex colours.
    fn variants(&self) -> usize {
        self.made.keys().filter(|k| k.1.is_some()).count()
    }

    /// The quantised colour of material `i`'s emission texture over triangle `t` (None when
    /// the material has none, or the settings give its emission).
    fn emission_colour(&self, i: usize, t: &crate::model::Triangle) -> Option<[u8; 3]> {
        let m = &self.model.materials[i];
        if self
            .settings
            .materials
            .get(&m.name)
            .is_some_and(|o| o.emission.is_some())
        {
            return None;
        }
        let tex = m.emission_texture.as_ref()?;
        let c = match t.vt {
            Some(vt) => tex.footprint(vt.map(|v| self.model.texcoords[v as usize])),
            None => tex.average,
        };
        Some(crate::model::colour_key(c))
    }

    /// The colour a triangle takes from a texture or its vertices, if any.
    fn colour(&self, t: &crate::model::Triangle) -> Option<[f64; 3]> {
        if t.material.is_some_and(|i| self.fixed_colour[i]) {
            return None;
        }
        let m = t.material.map(|i| &self.model.materials[i]);
        if let Some(tex) = m.and_then(|m| m.texture.as_ref()) {
            let c = match t.vt {
                Some(vt) => tex.footprint(vt.map(|i| self.model.texcoords[i as usize])),
                None => tex.average,
            };
            // map_Kd multiplies Kd (the MTL definition); without a Kd the texture alone.
            let kd = m.and_then(|m| m.kd).unwrap_or([1.0; 3]);
            return Some([0, 1, 2].map(|k| c[k] * kd[k]));
        }
        let cols = self.model.colours.as_ref()?;
        // Vertex colours colour what the file gives no colour: no material, or one without
        // Kd (the default material of PLY and STL files counts as none).
        if m.is_some_and(|m| m.kd.is_some() && !m.implicit) {
            return None;
        }
        let mut c = [0.0; 3];
        for v in t.v {
            for k in 0..3 {
                c[k] += cols[v as usize][k] / 3.0;
            }
        }
        Some(c)
    }

    /// The material a key stands for, resolved.
    fn resolve(&self, key: MaterialKey) -> Resolved {
        match key {
            (None, None) => materials::default_grey(self.band_nm.len()),
            (Some(i), None) => self.resolved[i].clone(),
            (m, Some(k)) => {
                let mut base = match m {
                    Some(i) => self.model.materials[i].clone(),
                    None => crate::model::Mtl {
                        name: "default".into(),
                        ..Default::default()
                    },
                };
                base.kd = Some(crate::model::key_colour(k));
                base.texture = None;
                base.map_kd = None;
                // Warnings were given for the material itself.
                let mut quiet = Diagnostics::default();
                let o = self.settings.materials.get(&base.name);
                let at = self.settings.locate(&format!("[materials.{}]", base.name));
                materials::resolve(
                    &base,
                    o,
                    &at,
                    self.band_nm,
                    self.rgb,
                    self.units,
                    &mut quiet,
                )
            }
        }
    }

    /// The material id and resolved material of a triangle.
    fn of(&mut self, t: &crate::model::Triangle, ctx: &mut Context) -> Result<&(u32, Resolved)> {
        let key = (t.material, self.colour(t).map(crate::model::colour_key));
        if !self.made.contains_key(&key) {
            let r = self.resolve(key);
            let id = ctx.add_material(&r.desc).map_err(|e| {
                let name = key.0.map_or("default".to_string(), |i| {
                    let m = &self.model.materials[i];
                    format!(
                        "{}:{}: material '{}'",
                        m.at.0.display(),
                        m.at.1,
                        printable(&m.name)
                    )
                });
                CliError(format!("{name}: {}", e.message))
            })?;
            self.made.insert(key, (id, r));
        }
        Ok(&self.made[&key])
    }
}

/// A mesh to add: its loaded form and whether it records.
struct Built {
    loaded: LoadedMesh,
    materials: Vec<u32>,
    exitance: Option<Vec<f64>>,
    record: bool,
    two_sided: bool,
    material: u32,
}

impl Built {
    fn desc(&self) -> MeshDesc<'_> {
        // The model loader left out the triangles that repeat a vertex: no skip_degenerate.
        MeshDesc {
            triangle_materials: Some(&self.materials),
            two_sided: self.two_sided,
            record: self.record,
            exitance: self.exitance.as_deref(),
            ..MeshDesc::new(&self.loaded.positions, &self.loaded.indices, self.material)
        }
    }
}

fn build_mesh(
    name: &str,
    tris: &[&crate::model::Triangle],
    palette: &mut Palette,
    ctx: &mut Context,
    emission: Option<Option<[f64; 3]>>,
) -> Result<Built> {
    // None: the triangles emit nothing (black texels of an emission texture, or materials
    // without emission); Some(tint): their material's emission, times an emission
    // texture's colour.
    let tint = emission
        .flatten()
        .map(|c| materials::expand_rgb(c, palette.band_nm, palette.rgb));
    let o = palette.model;
    let settings = palette.settings;
    // The vertices the triangles use, in the file's order.
    let mut used: Vec<u32> = tris.iter().flat_map(|t| t.v).collect();
    used.sort_unstable();
    used.dedup();
    let local = |v: u32| used.binary_search(&v).expect("used vertex") as u32;
    let positions: Vec<f64> = used.iter().flat_map(|&v| o.positions[v as usize]).collect();
    let indices: Vec<u32> = tris.iter().flat_map(|t| t.v.map(local)).collect();
    // The view's colour of a vertex: the mean diffuse of its triangles.
    let nb = palette.band_nm.len();
    let mut diffuse = vec![vec![0.0; nb]; used.len()];
    let mut count = vec![0u32; used.len()];
    let mut materials = Vec::with_capacity(tris.len());
    let mut exitance = None;
    for (k, t) in tris.iter().enumerate() {
        let (id, r) = palette.of(t, ctx)?;
        materials.push(*id);
        if k == 0 {
            // An emission texture's colour multiplies the material's emission.
            exitance = r
                .emission
                .as_ref()
                .filter(|_| emission.is_some())
                .map(|e| match &tint {
                    Some(tint) => e.iter().zip(tint).map(|(x, t)| x * t).collect(),
                    None => e.clone(),
                });
        }
        for v in t.v {
            let l = local(v) as usize;
            count[l] += 1;
            for (d, x) in diffuse[l].iter_mut().zip(&r.diffuse) {
                *d += x;
            }
        }
    }
    for (d, c) in diffuse.iter_mut().zip(&count) {
        d.iter_mut().for_each(|x| *x /= (*c).max(1) as f64);
    }
    // Emitters are not recorded unless named; everything else is when `record` is empty.
    let record = if settings.record.is_empty() {
        exitance.is_none()
    } else {
        settings
            .record
            .iter()
            .any(|r| r == name || name.split('/').next() == Some(r.as_str()))
    };
    let material = materials[0];
    Ok(Built {
        loaded: LoadedMesh {
            name: name.to_string(),
            positions,
            indices,
            file_vertex: used,
            id: None,
            mesh: 0,
            diffuse,
            emission: exitance.clone(),
        },
        materials,
        exitance,
        record,
        two_sided: settings.two_sided,
        material,
    })
}
