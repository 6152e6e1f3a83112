//! Coefficients that vary over a surface: a material's image texture read at the mesh's
//! texture coordinates, and per-vertex factors on a mesh, each multiplying the ideal
//! coefficients the material names (`Material::tint_lobes`: by default its diffuse
//! reflectance).
//!
//! A texture holds values in [0, 1] with 1 channel (every band), 3 (red, green, blue: RGB
//! runs read them band by band, spectral runs by each band's wavelength — blue below
//! 490 nm, green below 580 nm, red above) or one per band. Rows run from v = 0 (the
//! image's first row) to v = 1, columns from u = 0 to 1; coordinates outside repeat (or
//! clamp). Read bilinearly between texel centres (or the nearest texel). A hit's factor per
//! band is the texture's value at the barycentric mix of its triangle's coordinates, times
//! the barycentric mix of the vertex factors; the tinted coefficients stay within [0, 1]
//! and their sum within the material's, so energy is conserved.
//!
//! Pay for what you use: a hit on a mesh with neither looks up nothing.

use crate::error::{bail, Result};
use crate::scene::material::{
    Material, LOBE_DIFFUSE_REFLECT, LOBE_ROUGHNESS, LOBE_SPECULAR_REFLECT,
};
use crate::spectral::Bands;

/// What the caller describes.
#[derive(Clone, Debug, Default)]
pub struct TextureDesc<'a> {
    pub width: usize,
    pub height: usize,
    /// 1, 3 (RGB) or the band count.
    pub channels: usize,
    /// width × height × channels values in [0, 1], row by row from v = 0, channels
    /// innermost.
    pub values: &'a [f64],
    /// The nearest texel instead of bilinear reading.
    pub nearest: bool,
    /// Coordinates outside [0, 1] clamp to the edge instead of repeating.
    pub clamp: bool,
}

/// A checked texture.
#[derive(Clone, Debug)]
pub struct Texture {
    width: usize,
    height: usize,
    channels: usize,
    values: Vec<f32>,
    nearest: bool,
    clamp: bool,
}

/// Most texels a texture may hold.
const MAX_VALUES: usize = 1 << 28;

/// The channel band `b` reads among `channels` (`channels` 1, 3 or the band count).
#[inline]
pub fn band_channel(bands: &Bands, channels: usize, b: usize) -> usize {
    match channels {
        1 => 0,
        3 if bands.rgb => b,
        3 => {
            let nm = bands.wavelengths_nm[b];
            if nm < 490.0 {
                2
            } else if nm < 580.0 {
                1
            } else {
                0
            }
        }
        _ => b,
    }
}

/// Checks a channel count against the bands: 1, 3 or one per band.
pub fn check_channels(what: &str, channels: usize, bands: &Bands) -> Result<()> {
    if !(channels == 1 || channels == 3 || channels == bands.count()) {
        bail!(
            ImapErrInvalidArgument,
            "{what} = {channels}: 1 (every band), 3 (red, green, blue) or {} (one per band)",
            bands.count()
        );
    }
    Ok(())
}

/// Checks that factor values are finite and within [0, 1].
pub fn check_unit(what: &str, values: &[f64]) -> Result<()> {
    if let Some(i) = values.iter().position(|x| !x.is_finite()) {
        bail!(
            ImapErrNonFinite,
            "{what}[{i}] = {} is not finite",
            values[i]
        );
    }
    if let Some(i) = values.iter().position(|x| !(0.0..=1.0).contains(x)) {
        bail!(
            ImapErrInvalidArgument,
            "{what}[{i}] = {} is outside [0, 1] (a factor of the material's coefficients)",
            values[i]
        );
    }
    Ok(())
}

impl Texture {
    pub fn new(desc: &TextureDesc, bands: &Bands) -> Result<Texture> {
        let (w, h, c) = (desc.width, desc.height, desc.channels);
        if w == 0 || h == 0 {
            bail!(
                ImapErrInvalidArgument,
                "texture.width = {w}, texture.height = {h}: both must be at least 1"
            );
        }
        check_channels("texture.channels", c, bands)?;
        let n = w
            .checked_mul(h)
            .and_then(|x| x.checked_mul(c))
            .filter(|&x| x <= MAX_VALUES);
        let Some(n) = n else {
            bail!(
                ImapErrInvalidArgument,
                "texture of {w} × {h} × {c} values is larger than {MAX_VALUES}"
            );
        };
        if desc.values.len() != n {
            bail!(
                ImapErrInvalidArgument,
                "texture.values has {} values; {w} × {h} texels of {c} channels need {n}",
                desc.values.len()
            );
        }
        check_unit("texture.values", desc.values)?;
        Ok(Texture {
            width: w,
            height: h,
            channels: c,
            values: desc.values.iter().map(|&x| x as f32).collect(),
            nearest: desc.nearest,
            clamp: desc.clamp,
        })
    }

    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Feeds its size, reading and values to a state fingerprint's hash.
    pub fn hash_into(&self, h: &mut xxhash_rust::xxh3::Xxh3) {
        for x in [self.width, self.height, self.channels] {
            h.update(&(x as u64).to_le_bytes());
        }
        h.update(&[u8::from(self.nearest), u8::from(self.clamp)]);
        for v in &self.values {
            h.update(&v.to_le_bytes());
        }
    }

    /// Bytes it holds.
    pub fn bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }

    /// The texel index along an axis of `n` texels for texel coordinate `x` (texel units,
    /// centres at k + 0.5 mapped to k).
    #[inline]
    fn wrap(&self, k: i64, n: usize) -> usize {
        if self.clamp {
            k.clamp(0, n as i64 - 1) as usize
        } else {
            k.rem_euclid(n as i64) as usize
        }
    }

    /// Each channel's value at (u, v) into `out` (`channels` values).
    pub fn sample(&self, u: f64, v: f64, out: &mut [f64]) {
        let (w, h, c) = (self.width, self.height, self.channels);
        let (mut u, mut v) = (u, v);
        if self.clamp {
            u = u.clamp(0.0, 1.0);
            v = v.clamp(0.0, 1.0);
        }
        let x = u * w as f64 - 0.5;
        let y = v * h as f64 - 0.5;
        let at = |i: usize, j: usize, ch: usize| self.values[(j * w + i) * c + ch] as f64;
        if self.nearest {
            let i = self.wrap((x + 0.5).floor() as i64, w);
            let j = self.wrap((y + 0.5).floor() as i64, h);
            for (ch, o) in out.iter_mut().enumerate().take(c) {
                *o = at(i, j, ch);
            }
            return;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i0, i1) = (self.wrap(x0 as i64, w), self.wrap(x0 as i64 + 1, w));
        let (j0, j1) = (self.wrap(y0 as i64, h), self.wrap(y0 as i64 + 1, h));
        for (ch, o) in out.iter_mut().enumerate().take(c) {
            *o = (1.0 - fy) * ((1.0 - fx) * at(i0, j0, ch) + fx * at(i1, j0, ch))
                + fy * ((1.0 - fx) * at(i0, j1, ch) + fx * at(i1, j1, ch));
        }
    }
}

/// Per-vertex factors of a mesh.
#[derive(Clone, Debug)]
pub struct VertexFactors {
    pub channels: usize,
    /// vertices × channels.
    pub values: Vec<f32>,
}

/// A thread's scratch for tinted hits: a copy of the hit's material with its coefficients
/// multiplied, reused from hit to hit (allocated at the first tinted hit).
#[derive(Clone, Debug, Default)]
pub struct TintScratch {
    material: Option<Material>,
    factor: Vec<f64>,
    channels: Vec<f64>,
}

/// A hit's surface description for tinting: its mesh's coordinates and factors at the
/// triangle's corners, and the barycentric weights.
pub struct TintAt<'a> {
    pub uvs: Option<[[f32; 2]; 3]>,
    pub factors: Option<(&'a VertexFactors, [u32; 3])>,
    /// The triangle's direction of increasing u, when its mesh keeps one
    /// (`PreparedMesh::uv_tangents`).
    pub tangent: Option<glam::DVec3>,
    /// Weights of the three corners.
    pub w: [f64; 3],
}

impl TintScratch {
    /// `base` with the lobes it names multiplied by the texture and the vertex factors at
    /// `at`, or `base` itself when nothing tints it.
    pub fn material<'s>(
        &'s mut self,
        base: &'s Material,
        textures: &[std::sync::Arc<Texture>],
        bands: &Bands,
        at: &TintAt,
    ) -> &'s Material {
        let texture = base.texture.map(|t| &textures[t as usize]);
        let texture = texture.filter(|_| at.uvs.is_some());
        // Ideal non-dielectric coefficients and conductors', plastics' and rough
        // dielectrics' vary (`Material::tint_lobes`): a mesh's vertex factors leave its
        // smooth dielectrics, measured tables, window and host BSDFs as they are.
        let ideal = base.glossy.is_none() && base.dielectric.is_none();
        let tintable = base.glossy.as_ref().is_some_and(|g| g.tintable());
        // The tangent frame from the texture coordinates (`Material::uv_tangent`: a
        // microfacet, measured or host surface, never an ideal one).
        let tangent = at.tangent.filter(|_| base.uv_tangent);
        let tints = (ideal || tintable)
            && base.tint_lobes != 0
            && (texture.is_some() || at.factors.is_some());
        if !tints && tangent.is_none() {
            return base;
        }
        // The factor per band of the lobes the material names (none when only the tangent
        // varies).
        let lobes = if tints { base.tint_lobes } else { 0 };
        let nb = base.diffuse_reflect.len();
        self.factor.clear();
        self.factor.resize(nb, 1.0);
        if let (Some(t), Some(uv), true) = (texture, at.uvs, tints) {
            let u: f64 = (0..3).map(|k| at.w[k] * uv[k][0] as f64).sum();
            let v: f64 = (0..3).map(|k| at.w[k] * uv[k][1] as f64).sum();
            self.channels.resize(t.channels(), 0.0);
            t.sample(u, v, &mut self.channels);
            for (b, f) in self.factor.iter_mut().enumerate() {
                *f *= self.channels[band_channel(bands, t.channels(), b)];
            }
        }
        if let (Some((vf, tri)), true) = (at.factors, tints) {
            for (b, f) in self.factor.iter_mut().enumerate() {
                let ch = band_channel(bands, vf.channels, b);
                let x: f64 = (0..3)
                    .map(|k| at.w[k] * vf.values[tri[k] as usize * vf.channels + ch] as f64)
                    .sum();
                *f *= x;
            }
        }
        if let Some(g) = &base.glossy {
            // A microfacet, measured or host surface (tinted only when `tintable`): its
            // copy's fields all rewritten from `base`.
            let m = self.material.get_or_insert_with(|| base.clone());
            if m.glossy.is_none() {
                *m = base.clone();
            }
            Self::copy_glossy(base, m);
            m.tangent = tangent.or(base.tangent);
            let colour = (lobes & (LOBE_DIFFUSE_REFLECT | LOBE_SPECULAR_REFLECT) != 0)
                .then_some(&self.factor[..]);
            let alpha = (lobes & LOBE_ROUGHNESS != 0)
                .then(|| self.factor.iter().sum::<f64>() / nb.max(1) as f64);
            g.tint_into(colour, alpha, m.glossy.as_mut().expect("a glossy copy"));
            return m;
        }
        // An ideal surface: the scratch keeps the other fields of the first tinted ideal
        // material (none: they are the same for every ideal, non-dielectric one).
        let m = self.material.get_or_insert_with(|| base.clone());
        if m.glossy.is_some() {
            *m = base.clone();
        }
        let tint = |dst: &mut Vec<f64>, src: &[f64], on: bool, f: &[f64]| {
            dst.clear();
            if on {
                dst.extend(src.iter().zip(f).map(|(a, k)| a * k));
            } else {
                dst.extend_from_slice(src);
            }
        };
        tint(
            &mut m.diffuse_reflect,
            &base.diffuse_reflect,
            lobes & 1 != 0,
            &self.factor,
        );
        tint(
            &mut m.specular_reflect,
            &base.specular_reflect,
            lobes & 2 != 0,
            &self.factor,
        );
        tint(
            &mut m.diffuse_transmit,
            &base.diffuse_transmit,
            lobes & 4 != 0,
            &self.factor,
        );
        m.events = base.events;
        m
    }

    /// A glossy copy `m`'s fields but the surface's own (`Glossy::tint_into`) and the
    /// tangent, from `base`.
    fn copy_glossy(base: &Material, m: &mut Material) {
        m.texture = base.texture;
        m.tint_lobes = base.tint_lobes;
        m.uv_tangent = base.uv_tangent;
        if base.dielectric.is_some() {
            m.dielectric.clone_from(&base.dielectric);
        } else {
            m.dielectric = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textures_read_bilinearly_and_by_the_nearest_texel() {
        let bands = Bands::rgb();
        // 2 × 1, one channel: 0.2 on the left, 1.0 on the right.
        let values = [0.2, 1.0];
        let desc = TextureDesc {
            width: 2,
            height: 1,
            channels: 1,
            values: &values,
            ..Default::default()
        };
        let t = Texture::new(&desc, &bands).unwrap();
        let mut out = [0.0];
        t.sample(0.25, 0.5, &mut out);
        assert!((out[0] - 0.2).abs() < 1e-7, "{out:?}");
        t.sample(0.5, 0.5, &mut out);
        assert!((out[0] - 0.6).abs() < 1e-7, "{out:?}");
        // Repeating: u = 1.0 is between the right texel's centre and the left's again.
        t.sample(1.0, 0.5, &mut out);
        assert!((out[0] - 0.6).abs() < 1e-7, "{out:?}");
        let nearest = Texture::new(
            &TextureDesc {
                nearest: true,
                ..desc.clone()
            },
            &bands,
        )
        .unwrap();
        nearest.sample(0.49, 0.5, &mut out);
        assert_eq!(out[0], 0.2f32 as f64);
        nearest.sample(0.51, 0.5, &mut out);
        assert_eq!(out[0], 1.0);
        let clamped = Texture::new(
            &TextureDesc {
                clamp: true,
                ..desc
            },
            &bands,
        )
        .unwrap();
        clamped.sample(1.3, 0.5, &mut out);
        assert!((out[0] - 1.0).abs() < 1e-7, "{out:?}");
    }

    #[test]
    fn vertex_factors_leave_smooth_dielectrics_alone() {
        use crate::scene::{IorModel, MaterialDesc};
        let bands = Bands::rgb();
        let lambert = Material::new(
            &MaterialDesc {
                diffuse_reflect: vec![0.8],
                ..Default::default()
            },
            &bands,
        )
        .unwrap();
        let glass = Material::new(
            &MaterialDesc {
                ior: Some(IorModel::Constant(1.5)),
                ..Default::default()
            },
            &bands,
        )
        .unwrap();
        let factors = VertexFactors {
            channels: 1,
            values: vec![0.5, 0.5, 0.5],
        };
        let at = TintAt {
            uvs: None,
            factors: Some((&factors, [0, 1, 2])),
            tangent: None,
            w: [0.2, 0.3, 0.5],
        };
        let mut scratch = TintScratch::default();
        let tinted = scratch.material(&lambert, &[], &bands, &at);
        assert_eq!(tinted.diffuse_reflect, vec![0.4; 3]);
        // The glass on the same mesh after it: itself, not the scratch.
        let g = scratch.material(&glass, &[], &bands, &at);
        assert!(std::ptr::eq(g, &glass));
        assert!(g.dielectric.is_some());
    }

    #[test]
    fn bad_textures_are_refused_by_name() {
        let bands = Bands::spectral(9, 380.0, 780.0).unwrap();
        let v = [0.5; 8];
        let desc = |w, h, c, values: &'static [f64]| TextureDesc {
            width: w,
            height: h,
            channels: c,
            values,
            ..Default::default()
        };
        let leak: &'static [f64] = Box::leak(Box::new(v));
        assert!(Texture::new(&desc(2, 2, 2, leak), &bands)
            .unwrap_err()
            .message
            .contains("texture.channels = 2"));
        assert!(Texture::new(&desc(3, 2, 1, leak), &bands)
            .unwrap_err()
            .message
            .contains("has 8 values"));
        let bad: &'static [f64] = Box::leak(Box::new([0.5, 1.5, 0.2, 0.1]));
        let e = Texture::new(&desc(2, 2, 1, bad), &bands).unwrap_err();
        assert!(
            e.message.contains("texture.values[1] = 1.5"),
            "{}",
            e.message
        );
        let nan: &'static [f64] = Box::leak(Box::new([0.5, f64::NAN, 0.2, 0.1]));
        let e = Texture::new(&desc(2, 2, 1, nan), &bands).unwrap_err();
        assert_eq!(e.status, crate::error::ImapStatus::ImapErrNonFinite);
        // Channels by wavelength in a spectral run.
        assert_eq!(band_channel(&bands, 3, 0), 2);
        assert_eq!(band_channel(&bands, 3, 3), 1);
        assert_eq!(band_channel(&bands, 3, 8), 0);
        assert_eq!(band_channel(&bands, 9, 5), 5);
    }
}
