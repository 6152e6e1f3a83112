//! The emitters as the tracer sees them (lights, distant sources with their portals,
//! emitting meshes), and the one interface every estimator reaches them through:
//! `Emitter::emit` (a photon), `Emitter::sample_toward` (where the light reaching a point
//! comes from, with its density) and `Emitter::photon_density` (how densely its photons
//! land, for weighting light samples against them).

use super::light::{DistantPart, LightShape};
use super::prepared_mesh::PreparedMesh;
use crate::sampling::{warp, AliasTable, PhotonRng};
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

/// Share of photons spread evenly over the emitters, whatever their power.
pub(crate) const EMITTER_FLOOR: f64 = 0.1;

/// One light source as the tracer sees it.
#[derive(Debug)]
pub struct Emitter {
    pub kind: EmitterKind,
    /// Position (scene units, recentred) of a light: its point, or the centre of its
    /// aperture or luminous opening.
    pub position: DVec3,
    /// Colour of an emitted photon: per-band power share times the band count, scaled by
    /// the emitter's power share over its selection probability (mean 1 with one emitter).
    pub colour: Vec<f64>,
    /// Radiant flux per band, W (a distant source's: through the bounding sphere).
    pub power: Vec<f64>,
    /// The map layer its photons write (its light group when groups are kept, else 0).
    pub layer: u8,
    /// Where a point-like light's photons are aimed (`Aim`), if they are.
    pub aim: Option<Aim>,
    /// The closed meshes with a scattering (or fluorescent) medium that hold the light,
    /// outermost first, each with its medium's material: its photons start in them (a lamp
    /// in a fog box, an LED in a diffuser's bulk). Empty for most lights.
    pub media: Vec<(u32, u32)>,
}

#[derive(Debug)]
pub enum EmitterKind {
    /// A light: point, spot, cosine, beam or goniometric luminaire.
    Light(LightShape),
    /// A distant source (one channel of a sky, or the sun): photons start on a disk of
    /// `radius` (the bounding sphere's, scene units) perpendicular to their direction, or,
    /// with `portals`, mostly through them. Its radiance per band is power × f(ω) / `norm`
    /// (norm = π R² ∫f, scene units²·sr); `gain` is how much denser its photons are behind
    /// the portals than from the whole sky (1 without).
    Distant {
        part: Arc<DistantPart>,
        radius: f64,
        norm: f64,
        gain: f64,
        portals: Option<Arc<Portals>>,
    },
    /// A self-emitting mesh: triangles chosen by area, Lambertian emission.
    Mesh {
        mesh: usize,
        triangles: AliasTable,
        two_sided: bool,
    },
}

/// A point-like light outside the sphere that holds the geometry (the one `enter` uses)
/// emits only into the cone of directions that meet the sphere: every other direction
/// meets nothing. Photons are sampled uniformly in the cone and weighted by the light's
/// flux share there, so the map is unchanged in expectation and the flux outside the cone
/// is counted as escaped at emission.
#[derive(Clone, Copy, Debug)]
pub struct Aim {
    /// From the light toward the sphere's centre.
    pub axis: DVec3,
    /// 1 − cos of the cone's half-angle, computed without cancellation (a light 10⁷ scene
    /// sizes away sees a cone of 10⁻¹⁴ here).
    pub one_minus_cos: f64,
    /// The cone's solid angle, 2π·one_minus_cos, sr.
    pub solid_angle: f64,
    /// The weight of every photon when the light's intensity is constant over the cone;
    /// None: I(d)/Φ times the solid angle, per direction.
    pub weight: Option<f64>,
}

/// Widest cone (half-angle) a light of non-uniform intensity is aimed into: beyond it,
/// weights I(d)·Ω/Φ spread too widely to pay for the photons saved.
const AIM_MAX_HALF_ANGLE_DEG: f64 = 30.0;

impl Aim {
    /// The aim of a light of `shape` at `position` (local units) toward the sphere of
    /// radius `r` around the origin; None when the light is inside it, is not point-like,
    /// or gains nothing.
    pub(super) fn new(shape: &LightShape, position: DVec3, r: f64) -> Option<Aim> {
        let d = position.length();
        if !d.is_finite() || d <= r * (1.0 + 1e-9) {
            return None;
        }
        let axis = -position / d;
        let sin = r / d;
        let cos_max = (1.0 - sin * sin).max(0.0).sqrt();
        let one_minus_cos = sin * sin / (1.0 + cos_max);
        let solid_angle = 2.0 * std::f64::consts::PI * one_minus_cos;
        let aim = |weight| {
            Some(Aim {
                axis,
                one_minus_cos,
                solid_angle,
                weight,
            })
        };
        let narrow = cos_max >= AIM_MAX_HALF_ANGLE_DEG.to_radians().cos();
        match shape {
            LightShape::Point => aim(Some(solid_angle / (4.0 * std::f64::consts::PI))),
            LightShape::Spot {
                axis: a,
                cos_half_angle,
            } => {
                let beta = a.dot(axis).clamp(-1.0, 1.0).acos();
                let alpha = cos_half_angle.clamp(-1.0, 1.0).acos();
                let theta = cos_max.clamp(-1.0, 1.0).acos();
                if beta + theta <= alpha {
                    // The cone lies inside the spot: constant intensity over it.
                    let spot = 2.0 * std::f64::consts::PI * (1.0 - cos_half_angle);
                    aim(Some(solid_angle / spot))
                } else {
                    None
                }
            }
            LightShape::Cosine { .. } if narrow => aim(None),
            LightShape::Luminaire(l) if narrow && l.opening.is_none() => aim(None),
            _ => None,
        }
    }
}

/// Share of a portal-lit distant source's photons that come through its portals; the rest
/// come from the whole sky as without portals.
pub const PORTAL_SHARE: f64 = 0.75;

/// Window portals of one distant source: the openings its light enters the model through
/// (as pbrt-v4's and Mitsuba's portals). A photon's line is drawn by one of two
/// strategies: with probability `PORTAL_SHARE` through a portal — a triangle k by
/// A_k J_k (J_k = ∫ f max(ω·n_k, 0) dω), a point on it uniformly, a direction ω toward the
/// source (a sky's half by its radiance and half cosine-distributed about n_k; the sun's
/// over its disk) — otherwise from the whole sky, as without portals. Either way it starts
/// beyond the bounding sphere, so overhangs and panes in front of an opening still meet
/// it, and it carries f(ω) / (p(line) ∫f π R²), p the mixture's density of that line (the
/// one-sample balance heuristic): mean 1, the source's power unchanged, and unbiased for
/// every surface — light reflected into the openings by outside surfaces (overhangs, light
/// shelves, neighbours) comes with the whole-sky photons — while the rooms behind the
/// portals get nearly all photons.
#[derive(Debug)]
pub struct Portals {
    /// Triangles (recentred scene units), their unit normals (facing out), areas and J_k.
    tris: Vec<[DVec3; 3]>,
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    j: Vec<f64>,
    table: AliasTable,
    /// Σ A_k J_k, scene units²·sr.
    pub total: f64,
    /// The disk's radius (the bounding sphere's).
    radius: f64,
}

impl Portals {
    /// The portals `tris` (recentred) for `part`, the bounding sphere of `radius`; None
    /// when no light of it passes them.
    pub(super) fn new(part: &DistantPart, tris: &[[DVec3; 3]], radius: f64) -> Option<Portals> {
        let mut cache: Vec<(DVec3, f64)> = Vec::new();
        let (mut keep, mut normals, mut areas, mut j, mut weights) =
            (vec![], vec![], vec![], vec![], vec![]);
        for t in tris {
            let c = (t[1] - t[0]).cross(t[2] - t[0]);
            let area = 0.5 * c.length();
            let Some(n) = c.try_normalize() else { continue };
            // Triangles of one window share their normal: integrate once per direction.
            let jk = match cache.iter().find(|(m, _)| m.dot(n) > 1.0 - 1e-12) {
                Some(&(_, v)) => v,
                None => {
                    let v = part.cos_integral(n);
                    cache.push((n, v));
                    v
                }
            };
            if jk > 0.0 && area > 0.0 {
                keep.push(*t);
                normals.push(n);
                areas.push(area);
                j.push(jk);
                weights.push(area * jk);
            }
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        Some(Portals {
            tris: keep,
            normals,
            areas,
            j,
            table: AliasTable::new(&weights).ok()?,
            total,
            radius,
        })
    }

    /// The density over directions toward the source of the portal strategy's portal k:
    /// half the source's own density (over every direction it lights, behind the portal
    /// too: such a line crosses the portal from its back) and half cosine-distributed
    /// about the portal's normal.
    #[inline]
    fn q(&self, part: &DistantPart, k: usize, toward: DVec3) -> f64 {
        if part.mixes_cosine() {
            let cos = toward.dot(self.normals[k]).max(0.0);
            0.5 * part.pdf(toward) + 0.5 * cos / std::f64::consts::PI
        } else {
            part.pdf(toward)
        }
    }

    /// The mixture's density of the line through `x` toward `toward` (per unit area
    /// across it and per sr); `own`: the portal triangle `x` was drawn on.
    fn line_density(&self, part: &DistantPart, x: DVec3, toward: DVec3, own: Option<usize>) -> f64 {
        let mut portal = 0.0;
        for k in 0..self.tris.len() {
            // A line crosses the portal from either side: the source's own half of q
            // draws directions behind it too (a density of 0 there weighed such photons,
            // which the strategy does draw, as if only the whole sky had: 1.75 times the
            // source's power came out, and a portal facing into the model gave its room
            // 30 times its light).
            let cos = toward.dot(self.normals[k]).abs();
            if cos <= 1e-12 {
                continue;
            }
            if own != Some(k) && !crosses(&self.tris[k], x, toward) {
                continue;
            }
            // P_k q_k / (A_k |cos_k|): the triangle's pick, its point, the direction.
            portal += self.j[k] * self.areas[k] / self.total * self.q(part, k, toward)
                / (self.areas[k] * cos);
        }
        // The whole sky's lines cross its disk of the sphere's radius (a portal beyond the
        // sphere may have lines that do not).
        let off_axis = (x - toward * x.dot(toward)).length();
        let disk = if off_axis <= self.radius {
            part.pdf(toward) / (std::f64::consts::PI * self.radius * self.radius)
        } else {
            0.0
        };
        PORTAL_SHARE * portal + (1.0 - PORTAL_SHARE) * disk
    }

    /// A photon's start, direction and weight (mean 1).
    fn emit(&self, part: &DistantPart, rng: &mut PhotonRng) -> (DVec3, DVec3, f64) {
        let r = self.radius;
        let (x, toward, own) = if rng.uniform() < PORTAL_SHARE {
            let k = self.table.sample(rng.uniform());
            let [a, b, c] = self.tris[k];
            let (b1, b2) = warp::uniform_triangle(rng.uniform(), rng.uniform());
            let x = a + (b - a) * b1 + (c - a) * b2;
            let n = self.normals[k];
            let (u0, u1, u2) = (rng.uniform(), rng.uniform(), rng.uniform());
            let toward = if part.mixes_cosine() {
                if u0 < 0.5 {
                    part.sample([2.0 * u0, u1, u2]).0
                } else {
                    warp::cosine_hemisphere(n, 2.0 * u0 - 1.0, u1)
                }
            } else {
                part.sample([u0, u1, u2]).0
            };
            (x, toward, Some(k))
        } else {
            let (toward, _) = part.sample([rng.uniform(), rng.uniform(), rng.uniform()]);
            let (t, b) = warp::basis(toward);
            let rr = r * rng.uniform().sqrt();
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            (t * (rr * phi.cos()) + b * (rr * phi.sin()), toward, None)
        };
        let f = part.value(toward);
        let p = self.line_density(part, x, toward, own);
        let w = if f > 0.0 && p > 0.0 {
            f / (p * part.integral * std::f64::consts::PI * r * r)
        } else {
            0.0
        };
        // Beyond the sphere on the line: x lies within it.
        let far = 2.0 * r + x.length();
        (x + toward * far, -toward, w)
    }
}

/// Whether the line through `x` along `d` crosses triangle `t` (Möller–Trumbore on the
/// whole line).
#[inline]
fn crosses(t: &[DVec3; 3], x: DVec3, d: DVec3) -> bool {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = x - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    v >= 0.0 && u + v <= 1.0
}

/// A photon's first ray (`Emitter::emit`).
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    /// Where it starts (scene units, recentred): on the light, on the disk beyond the
    /// bounding sphere of a distant source, or just off an emitting triangle.
    pub origin: DVec3,
    pub direction: DVec3,
    /// Multiplies the photon's colour: 1 but for aimed lights (`Aim`), whose photons carry
    /// their light's flux share in the cone, and distant sources (the share of the
    /// source's radiance, mean 1).
    pub weight: f64,
    /// The cosine of the direction to an emitting mesh's normal (1 for other emitters).
    pub cos: f64,
}

/// Where the light an emitter sends toward a receiving point comes from
/// (`Emitter::sample_toward`). Every kind of emitter draws one of these shapes of sample;
/// the estimators handle the shapes, never the kinds.
#[derive(Clone, Copy, Debug)]
pub enum LightSample {
    /// A point of a light (its own point, or a point of its aperture or luminous opening,
    /// uniform over it): its radiant intensity toward the receiver is
    /// `Emitter::intensity_per_watt`, per watt of its flux.
    Point(DVec3),
    /// A point of an emitting mesh, uniform over its area, with its triangle's normal (a
    /// Lambertian emitter: radiance power / (π sides area)).
    Area { point: DVec3, normal: DVec3 },
    /// A collimated beam's ray that reaches the receiver: the point `foot` on the
    /// aperture's plane, `t` scene units from the receiver back along the beam's axis.
    Beam {
        foot: DVec3,
        t: f64,
        axis: DVec3,
        area: f64,
    },
    /// A direction toward a distant source, drawn with density `pdf` per steradian, the
    /// source's relative radiance there (`DistantPart::value`), how far a shadow ray must
    /// look (`reach`: nothing lies beyond the bounding sphere, 2R from any point inside)
    /// and the radiance's normalisation (radiance per band = power × value / `norm`).
    Direction {
        toward: DVec3,
        pdf: f64,
        value: f64,
        reach: f64,
        norm: f64,
    },
}

/// A point receiving light (`Emitter::sample_toward`): its normal, and the probability
/// that the light it weighs comes from the front (the normal's side): 1 for a surface
/// that only reflects, the reflected share of a translucent one.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub n: DVec3,
    pub p_front: f64,
}

/// Whether a photon of an emitter can be path traced back to it through a specular chain:
/// point-like emitters (lights and the sun) are reached only by their photons.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extent {
    /// Points, openings, beams and the sun's disk: delta-like, only photons carry their
    /// caustics.
    PointLike,
    /// Emitting meshes and skies: a path can meet them.
    Extended,
}

impl Emitter {
    /// A photon's first ray, from `rng` (`meshes`: the prepared scene's, `offset_at`: its
    /// ray offset at a point).
    pub fn emit(
        &self,
        meshes: &[PreparedMesh],
        offset_at: impl Fn(DVec3) -> f64,
        rng: &mut PhotonRng,
    ) -> Photon {
        let photon = |origin, direction, weight, cos| Photon {
            origin,
            direction,
            weight,
            cos,
        };
        match &self.kind {
            EmitterKind::Light(shape) => match &self.aim {
                Some(a) => {
                    let (u1, u2) = (rng.uniform(), rng.uniform());
                    let d = warp::uniform_narrow_cone(a.axis, a.one_minus_cos, u1, u2);
                    let w = a
                        .weight
                        .unwrap_or_else(|| shape.intensity_per_watt(d) * a.solid_angle);
                    photon(self.position, d, w, 1.0)
                }
                None => {
                    let (at, d) = shape.sample(rng);
                    photon(self.position + at, d, 1.0, 1.0)
                }
            },
            EmitterKind::Distant {
                part,
                portals: Some(p),
                ..
            } => {
                let (org, dir, w) = p.emit(part, rng);
                photon(org, dir, w, 1.0)
            }
            EmitterKind::Distant { part, radius, .. } => {
                let (toward, w) = part.sample([rng.uniform(), rng.uniform(), rng.uniform()]);
                let (t, b) = warp::basis(toward);
                let r = radius * rng.uniform().sqrt();
                let phi = 2.0 * std::f64::consts::PI * rng.uniform();
                let org = toward * (radius * 1.001) + t * (r * phi.cos()) + b * (r * phi.sin());
                photon(org, -toward, w, 1.0)
            }
            EmitterKind::Mesh {
                mesh,
                triangles,
                two_sided,
            } => {
                let (u1, u2) = (rng.uniform(), rng.uniform());
                let (p, mut n) =
                    self.area_point(&meshes[*mesh], triangles, [u1, u2, rng.uniform()]);
                if *two_sided && rng.uniform() < 0.5 {
                    n = -n;
                }
                let d = warp::cosine_hemisphere(n, rng.uniform(), rng.uniform());
                photon(p + n * offset_at(p), d, 1.0, d.dot(n))
            }
        }
    }

    /// A point of an emitting mesh uniform over its area (`u[2]` picks the triangle by
    /// area, `u[0..2]` the point in it) and the triangle's normal.
    #[inline]
    fn area_point(&self, m: &PreparedMesh, triangles: &AliasTable, u: [f64; 3]) -> (DVec3, DVec3) {
        let t = triangles.sample(u[2]);
        let [a, b, c] = m.triangles[t].map(|i| m.vertices[i as usize].as_dvec3());
        let (b1, b2) = warp::uniform_triangle(u[0], u[1]);
        (a + (b - a) * b1 + (c - a) * b2, m.normals[t].as_dvec3())
    }

    /// Where the light reaching receiver `x` comes from, drawn from `u`. A distant sky
    /// draws half its directions by its radiance and half cosine-distributed on one side
    /// of the receiver (`Receiver`; `pick_front` decides which, when the receiver takes
    /// light on both): one-sample MIS by the mixture's density (`LightSample::Direction::
    /// pdf`). The sun draws over its disk. None when this emitter sends nothing toward
    /// `x` (outside a beam).
    pub fn sample_toward(
        &self,
        meshes: &[PreparedMesh],
        x: DVec3,
        receiver: Receiver,
        u: [f64; 3],
        pick_front: impl FnOnce() -> bool,
    ) -> Option<LightSample> {
        match &self.kind {
            EmitterKind::Light(LightShape::Beam { axis, aperture }) => {
                // Lit when x lies in the beam: its projection along the axis falls inside
                // the aperture, in front of it.
                let t = (x - self.position).dot(*axis);
                let foot = x - *axis * t;
                (t > 0.0 && aperture.contains(foot - self.position)).then_some(LightSample::Beam {
                    foot,
                    t,
                    axis: *axis,
                    area: aperture.area(),
                })
            }
            EmitterKind::Light(shape) => Some(LightSample::Point(match shape.aperture() {
                Some(a) => self.position + a.sample(u[0], u[1]),
                None => self.position,
            })),
            EmitterKind::Distant {
                part, radius, norm, ..
            } => {
                let toward = if part.mixes_cosine() {
                    let n = receiver.n;
                    let favour = if pick_front() { n } else { -n };
                    if u[0] < 0.5 {
                        part.sample([2.0 * u[0], u[1], u[2]]).0
                    } else {
                        warp::cosine_hemisphere(favour, 2.0 * u[0] - 1.0, u[1])
                    }
                } else {
                    part.sample(u).0
                };
                let pdf = distant_density(part, toward, receiver);
                Some(LightSample::Direction {
                    toward,
                    pdf,
                    value: part.value(toward),
                    reach: 2.5 * radius,
                    norm: *norm,
                })
            }
            EmitterKind::Mesh {
                mesh, triangles, ..
            } => {
                let (point, normal) = self.area_point(&meshes[*mesh], triangles, u);
                Some(LightSample::Area { point, normal })
            }
        }
    }

    /// Radiant intensity per watt of flux toward unit `dir` of a light (`LightSample::
    /// Point`); 0 for other emitters.
    #[inline]
    pub fn intensity_per_watt(&self, dir: DVec3) -> f64 {
        match &self.kind {
            EmitterKind::Light(shape) => shape.intensity_per_watt(dir),
            _ => 0.0,
        }
    }

    /// The density of this emitter's photons landing at x from y along unit `dir` (from y
    /// to x) per unit area of a surface whose normal makes cos θx = `cos_x` with −`dir`,
    /// per photon: r² = |x − y|², cos θy = `cos_y` at an emitting mesh. A distant
    /// source's is scaled by `sky_ratio(part, toward)` for a sky (the estimator's gain of
    /// light samples over photons; the sun's is 1).
    #[inline]
    pub fn photon_density(
        &self,
        dir: DVec3,
        r2: f64,
        cos_x: f64,
        cos_y: f64,
        sky_ratio: impl Fn(&DistantPart, DVec3) -> f64,
    ) -> f64 {
        match &self.kind {
            EmitterKind::Light(LightShape::Beam { aperture, .. }) => cos_x / aperture.area(),
            EmitterKind::Distant {
                part, norm, gain, ..
            } => {
                let toward = -dir;
                let ratio = if part.is_sky() {
                    sky_ratio(part, toward)
                } else {
                    1.0
                };
                // Photons per unit area: 1 / (π R²) of the whole sky's (∫f / norm), times
                // the portals' concentration (`gain`; 1 without).
                cos_x * ratio * part.integral * gain / norm
            }
            EmitterKind::Light(shape) => shape.intensity_per_watt(dir) * cos_x / r2,
            EmitterKind::Mesh { two_sided, .. } => {
                let sides = if *two_sided { 2.0 } else { 1.0 };
                cos_y * cos_x / (PI * sides * r2)
            }
        }
    }

    /// Whether paths can meet this emitter (`Extent`).
    pub fn extent(&self) -> Extent {
        match &self.kind {
            EmitterKind::Light(_) => Extent::PointLike,
            EmitterKind::Distant { part, .. } if part.is_sun() => Extent::PointLike,
            _ => Extent::Extended,
        }
    }

    /// The mesh an emitting mesh is (None for other emitters).
    pub fn mesh(&self) -> Option<usize> {
        match &self.kind {
            EmitterKind::Mesh { mesh, .. } => Some(*mesh),
            _ => None,
        }
    }

    /// A distant source's relative radiance (None for other emitters).
    /// The density (1/sr) with which `sample_toward` draws direction `toward` for
    /// `receiver`: 0 for an emitter that is not distant.
    pub fn direction_density(&self, toward: DVec3, receiver: Receiver) -> f64 {
        self.distant_part()
            .map_or(0.0, |part| distant_density(part, toward, receiver))
    }

    pub fn distant_part(&self) -> Option<&Arc<DistantPart>> {
        match &self.kind {
            EmitterKind::Distant { part, .. } => Some(part),
            _ => None,
        }
    }

    /// Whether an emitting mesh emits from both faces (false for other emitters).
    pub fn two_sided(&self) -> bool {
        matches!(
            self.kind,
            EmitterKind::Mesh {
                two_sided: true,
                ..
            }
        )
    }

    /// Whether it is a distant source (its photons' weight is their share of its radiance).
    pub fn is_distant(&self) -> bool {
        matches!(self.kind, EmitterKind::Distant { .. })
    }
}

/// The density (1/sr) of a distant source's light-sample directions at a receiver: a sky
/// draws half by its radiance and half cosine-distributed on one side (the front with
/// probability `p_front`); the sun over its disk.
#[inline]
fn distant_density(part: &DistantPart, toward: DVec3, receiver: Receiver) -> f64 {
    if !part.mixes_cosine() {
        return part.pdf(toward);
    }
    let cos = toward.dot(receiver.n);
    let p_side = if cos > 0.0 {
        receiver.p_front
    } else {
        1.0 - receiver.p_front
    };
    0.5 * part.pdf(toward) + 0.5 * p_side * cos.abs() / PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::light::{Distant, SkyAmount, SkyDesc, SkyKind};

    fn uniform_part() -> Arc<DistantPart> {
        let d = Distant::sky(
            &SkyDesc {
                kind: SkyKind::Uniform { sphere: false },
                amount: SkyAmount::Radiance(1.0),
                ..SkyDesc::default()
            },
            &crate::spectral::Bands::rgb(),
        )
        .unwrap();
        d.parts[0].clone()
    }

    #[test]
    fn portal_photons_weigh_one_on_average_whichever_way_the_portal_faces() {
        let part = uniform_part();
        let r = 5.0;
        // A window in the plane y = 0, facing −y (out) and +y (in).
        let a = [
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 1.5),
        ];
        for (name, t) in [("out", [a[0], a[2], a[1]]), ("in", a)] {
            let p = Portals::new(&part, &[t], r).unwrap();
            let mut rng = PhotonRng::new(7, 3);
            let n = 2_000_000;
            let (mut sum, mut sq) = (0.0, 0.0);
            for _ in 0..n {
                let w = p.emit(&part, &mut rng).2;
                sum += w;
                sq += w * w;
            }
            let mean = sum / n as f64;
            let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
            eprintln!("portal facing {name}: mean weight {mean:.5} ± {se:.5}");
            assert!(
                (mean - 1.0).abs() < 4.0 * se + 1e-9,
                "{name}: {mean} ± {se}"
            );
        }
    }
}
