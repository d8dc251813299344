//! Surface scattering models (Mitsuba's BSDF plugins), evaluated in the local shading frame (normal = +Z).
//!
//! Conventions, as in Mitsuba 3: `wi` points away from the surface towards where the path came from (the
//! camera side); `wo` is the other direction (towards the light). [`Bsdf::eval`] returns f(wi, wo)·|cos θo|
//! of the non-delta components; [`Bsdf::pdf`] is the solid-angle density with which [`Bsdf::sample`] picks
//! `wo` through its non-delta components (including the lobe-selection probability); a sample that picks a
//! delta component has `delta = true` and a weight that already contains everything.
//!
//! All models assume radiance transport (paths traced from the camera): refraction scales radiance by
//! 1/η², as Mitsuba 3 does in `TransportMode::Radiance`.

mod blend;
pub mod build;
mod build_adapters;
mod bumpmap;
mod coating;
mod conductor;
mod dielectric;
mod difftrans;
mod diffuse;
pub mod fresnel;
pub mod ior;
mod mask;
pub mod microfacet;
mod mixture;
mod normalmap;
mod params;
mod phong;
mod plastic;
mod rough_interface;
mod roughcoating;
mod roughconductor;
mod roughdielectric;
mod roughplastic;
mod thindielectric;
mod twosided;
mod ward;

pub use blend::Blend;
pub use build::{bsdf_from_desc, build_bsdf};
pub use bumpmap::{shadow_terminator, BumpMap};
pub use coating::{Coating, CoatingLayer};
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use difftrans::DiffuseTransmitter;
pub use diffuse::Diffuse;
pub use mask::Mask;
pub use microfacet::{Microfacet, MicrofacetKind};
pub use mixture::Mixture;
pub use normalmap::NormalMap;
pub use params::texture_from_desc;
pub use phong::Phong;
pub use plastic::Plastic;
pub use roughcoating::RoughCoating;
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use roughplastic::RoughPlastic;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;
pub use ward::{Ward, WardVariant};

use crate::color::Rgb;
use crate::texture::{Texture, UvFootprint};
use glam::{Vec2, Vec3};

/// Per-query data a BSDF may need besides the directions.
#[derive(Clone, Copy, Debug, Default)]
pub struct BsdfContext {
    /// Surface uv coordinates for texture lookups.
    pub uv: Vec2,
    /// The pixel footprint in uv space at a camera ray's first hit (zero elsewhere), for MIP-mapped
    /// textures.
    pub footprint: UvFootprint,
    /// ∂p/∂u of the surface in the local shading frame (zero when unknown), for bump maps.
    pub dp_du: Vec3,
    /// ∂p/∂v in the local shading frame (zero when unknown).
    pub dp_dv: Vec3,
}

impl BsdfContext {
    /// A context at `uv` without a footprint.
    pub fn at_uv(uv: Vec2) -> Self {
        BsdfContext {
            uv,
            ..Default::default()
        }
    }
}

/// Texture lookups at a BSDF query's uv and footprint.
pub(crate) trait TextureAt {
    /// The value at the query point.
    fn at(&self, ctx: &BsdfContext) -> Rgb;
    /// The scalar value (mean of the channels) at the query point.
    fn at_1(&self, ctx: &BsdfContext) -> f32 {
        let c = self.at(ctx);
        (c.x + c.y + c.z) / 3.0
    }
}

impl TextureAt for Texture {
    #[inline]
    fn at(&self, ctx: &BsdfContext) -> Rgb {
        self.eval_filtered(ctx.uv, &ctx.footprint)
    }
}

/// A sampled outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction `wo` in the local frame (unit length).
    pub wo: Vec3,
    /// Solid-angle density of `wo` (for a delta lobe: the probability of having chosen that lobe).
    pub pdf: f32,
    /// f·|cos θo| / pdf (for a delta lobe: the lobe's reflectance or transmittance over its probability).
    pub weight: Rgb,
    /// Relative index of refraction along the sampled direction (1 for reflection), for Russian roulette.
    pub eta: f32,
    /// True if a delta (perfectly specular) component was sampled.
    pub delta: bool,
}

/// A BSDF. Closed set (hot path): one variant per supported Mitsuba plugin. Large models are boxed to
/// keep the enum small.
#[derive(Clone, Debug)]
pub enum Bsdf {
    /// Lambertian reflection (`diffuse`).
    Diffuse(Diffuse),
    /// Smooth conductor (`conductor`).
    Conductor(Box<Conductor>),
    /// Rough conductor (`roughconductor`).
    RoughConductor(Box<RoughConductor>),
    /// Smooth dielectric interface (`dielectric`).
    Dielectric(Dielectric),
    /// Rough dielectric interface (`roughdielectric`).
    RoughDielectric(Box<RoughDielectric>),
    /// Thin dielectric sheet (`thindielectric`).
    ThinDielectric(ThinDielectric),
    /// Smooth plastic (`plastic`).
    Plastic(Box<Plastic>),
    /// Rough plastic (`roughplastic`).
    RoughPlastic(Box<RoughPlastic>),
    /// Two-sided adapter (`twosided`).
    TwoSided(TwoSided),
    /// Normal-mapped nested BSDF (`normalmap`).
    NormalMap(Box<NormalMap>),
    /// Linear blend of two BSDFs (`blendbsdf`).
    Blend(Box<Blend>),
    /// Opacity mask with a pass-through event (`mask`).
    Mask(Box<Mask>),
    /// Ideal diffuse transmission (`difftrans`).
    DiffuseTransmitter(DiffuseTransmitter),
    /// Modified Phong (Mitsuba 0.6 `phong`).
    Phong(Box<Phong>),
    /// Anisotropic Ward (Mitsuba 0.6 `ward`).
    Ward(Box<Ward>),
    /// Weighted sum of N BSDFs (Mitsuba 0.6 `mixturebsdf`).
    Mixture(Box<Mixture>),
    /// Bump-mapped nested BSDF (`bumpmap`).
    BumpMap(Box<BumpMap>),
    /// Smooth dielectric layer over a nested BSDF (Mitsuba 0.6 `coating`).
    Coating(Box<Coating>),
    /// Rough dielectric layer over a nested BSDF (Mitsuba 0.6 `roughcoating`).
    RoughCoating(Box<RoughCoating>),
}

/// True for a strictly positive number (false for NaN), for rejecting degenerate samples.
#[inline]
pub(crate) fn is_positive(x: f32) -> bool {
    x > 0.0
}

/// The mean of a texture's values (Mitsuba's `Texture::mean`), used for sampling weights.
pub(crate) fn texture_mean(t: &Texture) -> f32 {
    let c = t.mean();
    (c.x + c.y + c.z) / 3.0
}

impl Bsdf {
    /// The Mitsuba plugin name of this BSDF (for diagnostics).
    pub fn plugin_name(&self) -> &'static str {
        match self {
            Bsdf::Diffuse(_) => "diffuse",
            Bsdf::Conductor(_) => "conductor",
            Bsdf::RoughConductor(_) => "roughconductor",
            Bsdf::Dielectric(_) => "dielectric",
            Bsdf::RoughDielectric(_) => "roughdielectric",
            Bsdf::ThinDielectric(_) => "thindielectric",
            Bsdf::Plastic(_) => "plastic",
            Bsdf::RoughPlastic(_) => "roughplastic",
            Bsdf::TwoSided(_) => "twosided",
            Bsdf::NormalMap(_) => "normalmap",
            Bsdf::Blend(_) => "blendbsdf",
            Bsdf::Mask(_) => "mask",
            Bsdf::DiffuseTransmitter(_) => "difftrans",
            Bsdf::Phong(_) => "phong",
            Bsdf::Ward(_) => "ward",
            Bsdf::Mixture(_) => "mixturebsdf",
            Bsdf::BumpMap(_) => "bumpmap",
            Bsdf::Coating(_) => "coating",
            Bsdf::RoughCoating(_) => "roughcoating",
        }
    }

    /// f(wi, wo)·|cos θo| of the non-delta components.
    #[inline]
    pub fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        match self {
            Bsdf::Diffuse(b) => b.eval(ctx, wi, wo),
            Bsdf::RoughConductor(b) => b.eval(ctx, wi, wo),
            Bsdf::RoughDielectric(b) => b.eval(ctx, wi, wo),
            Bsdf::Plastic(b) => b.eval(ctx, wi, wo),
            Bsdf::RoughPlastic(b) => b.eval(ctx, wi, wo),
            Bsdf::TwoSided(b) => b.eval(ctx, wi, wo),
            Bsdf::NormalMap(b) => b.eval(ctx, wi, wo),
            Bsdf::Blend(b) => b.eval(ctx, wi, wo),
            Bsdf::Mask(b) => b.eval(ctx, wi, wo),
            Bsdf::DiffuseTransmitter(b) => b.eval(ctx, wi, wo),
            Bsdf::Phong(b) => b.eval(ctx, wi, wo),
            Bsdf::Ward(b) => b.eval(ctx, wi, wo),
            Bsdf::Mixture(b) => b.eval(ctx, wi, wo),
            Bsdf::BumpMap(b) => b.eval(ctx, wi, wo),
            Bsdf::Coating(b) => b.eval(ctx, wi, wo),
            Bsdf::RoughCoating(b) => b.eval(ctx, wi, wo),
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => Rgb::ZERO,
        }
    }

    /// Solid-angle density of sampling `wo` through the non-delta components.
    #[inline]
    pub fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(b) => b.pdf(ctx, wi, wo),
            Bsdf::RoughConductor(b) => b.pdf(ctx, wi, wo),
            Bsdf::RoughDielectric(b) => b.pdf(ctx, wi, wo),
            Bsdf::Plastic(b) => b.pdf(ctx, wi, wo),
            Bsdf::RoughPlastic(b) => b.pdf(ctx, wi, wo),
            Bsdf::TwoSided(b) => b.pdf(ctx, wi, wo),
            Bsdf::NormalMap(b) => b.pdf(ctx, wi, wo),
            Bsdf::Blend(b) => b.pdf(ctx, wi, wo),
            Bsdf::Mask(b) => b.pdf(ctx, wi, wo),
            Bsdf::DiffuseTransmitter(b) => b.pdf(ctx, wi, wo),
            Bsdf::Phong(b) => b.pdf(ctx, wi, wo),
            Bsdf::Ward(b) => b.pdf(ctx, wi, wo),
            Bsdf::Mixture(b) => b.pdf(ctx, wi, wo),
            Bsdf::BumpMap(b) => b.pdf(ctx, wi, wo),
            Bsdf::Coating(b) => b.pdf(ctx, wi, wo),
            Bsdf::RoughCoating(b) => b.pdf(ctx, wi, wo),
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => 0.0,
        }
    }

    /// Samples `wo` given `wi`; `u1` selects a component, `u2` samples within it. `None` if the sample
    /// carries no energy (e.g. `wi` below a one-sided surface).
    #[inline]
    pub fn sample(&self, ctx: &BsdfContext, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Conductor(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::RoughConductor(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Dielectric(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::RoughDielectric(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::ThinDielectric(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Plastic(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::RoughPlastic(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::TwoSided(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::NormalMap(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Blend(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Mask(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::DiffuseTransmitter(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Phong(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Ward(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Mixture(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::BumpMap(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::Coating(b) => b.sample(ctx, wi, u1, u2),
            Bsdf::RoughCoating(b) => b.sample(ctx, wi, u1, u2),
        }
    }

    /// True if some component is non-delta (so next-event estimation and guiding make sense).
    #[inline]
    pub fn has_smooth(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::RoughConductor(_) | Bsdf::RoughDielectric(_) => true,
            Bsdf::Plastic(_) | Bsdf::RoughPlastic(_) | Bsdf::DiffuseTransmitter(_) => true,
            Bsdf::Phong(_) | Bsdf::Ward(_) => true,
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => false,
            Bsdf::TwoSided(b) => b.lobes.smooth,
            Bsdf::NormalMap(b) => b.nested.has_smooth(),
            Bsdf::BumpMap(b) => b.nested.has_smooth(),
            Bsdf::Coating(b) => b.nested.has_smooth(),
            Bsdf::RoughCoating(_) => true,
            Bsdf::Blend(b) => b.bsdfs.iter().any(Bsdf::has_smooth),
            Bsdf::Mixture(b) => b.bsdfs.iter().any(Bsdf::has_smooth),
            Bsdf::Mask(b) => b.nested.has_smooth(),
        }
    }

    /// True if some component is a delta distribution.
    #[inline]
    pub fn has_delta(&self) -> bool {
        match self {
            Bsdf::Conductor(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Plastic(_)
            | Bsdf::Mask(_) => true,
            Bsdf::Diffuse(_)
            | Bsdf::RoughConductor(_)
            | Bsdf::RoughDielectric(_)
            | Bsdf::RoughPlastic(_)
            | Bsdf::DiffuseTransmitter(_)
            | Bsdf::Phong(_)
            | Bsdf::Ward(_) => false,
            Bsdf::TwoSided(b) => b.lobes.delta,
            Bsdf::NormalMap(b) => b.nested.has_delta(),
            Bsdf::BumpMap(b) => b.nested.has_delta(),
            Bsdf::Coating(_) => true,
            Bsdf::RoughCoating(b) => b.nested.has_delta(),
            Bsdf::Blend(b) => b.bsdfs.iter().any(Bsdf::has_delta),
            Bsdf::Mixture(b) => b.bsdfs.iter().any(Bsdf::has_delta),
        }
    }

    /// True if some component transmits light to the other side of the surface.
    pub fn has_transmission(&self) -> bool {
        match self {
            Bsdf::Dielectric(_) | Bsdf::RoughDielectric(_) | Bsdf::ThinDielectric(_) => true,
            // The null event of a mask passes light to the other side.
            Bsdf::Mask(_) | Bsdf::DiffuseTransmitter(_) => true,
            Bsdf::TwoSided(b) => b.lobes.transmission,
            Bsdf::NormalMap(b) => b.nested.has_transmission(),
            Bsdf::BumpMap(b) => b.nested.has_transmission(),
            Bsdf::Coating(b) => b.nested.has_transmission(),
            Bsdf::RoughCoating(b) => b.nested.has_transmission(),
            Bsdf::Blend(b) => b.bsdfs.iter().any(Bsdf::has_transmission),
            Bsdf::Mixture(b) => b.bsdfs.iter().any(Bsdf::has_transmission),
            _ => false,
        }
    }

    /// The smallest roughness of any component: infinity for diffuse, 0 for smooth specular, α for
    /// microfacet lobes (Mitsuba 0.6 `getRoughness`), used by focal guiding to spot glossy vertices.
    pub fn min_roughness(&self) -> f32 {
        match self {
            Bsdf::Diffuse(_) | Bsdf::DiffuseTransmitter(_) => f32::INFINITY,
            Bsdf::Conductor(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Plastic(_) => 0.0,
            Bsdf::RoughConductor(b) => b.distribution.min_alpha(),
            Bsdf::RoughDielectric(b) => b.distribution.min_alpha(),
            Bsdf::RoughPlastic(b) => b.distribution.min_alpha(),
            Bsdf::Phong(b) => b.roughness(),
            Bsdf::Ward(b) => 0.5 * (b.alpha_u + b.alpha_v),
            Bsdf::TwoSided(b) => b.lobes.min_roughness,
            Bsdf::NormalMap(b) => b.nested.min_roughness(),
            Bsdf::BumpMap(b) => b.nested.min_roughness(),
            // The interface is a mirror.
            Bsdf::Coating(_) => 0.0,
            Bsdf::RoughCoating(b) => b.distribution.min_alpha().min(b.nested.min_roughness()),
            Bsdf::Blend(b) => b.bsdfs[0].min_roughness().min(b.bsdfs[1].min_roughness()),
            Bsdf::Mixture(b) => b
                .bsdfs
                .iter()
                .map(Bsdf::min_roughness)
                .fold(f32::INFINITY, f32::min),
            // The pass-through is no scattering vertex (see [`Bsdf::pass_through`]).
            Bsdf::Mask(b) => b.nested.min_roughness(),
        }
    }

    /// The transmittance 1 − opacity of a pass-through (null) event at `ctx` if this BSDF is a `mask`,
    /// else `None`. Integrators decide a pass-through before treating the hit as a vertex: with
    /// probability mean(1 − o) the ray continues unchanged with weight (1 − o)/mean(1 − o); otherwise
    /// the vertex scatters with [`Bsdf::opaque_part`] and weight o/mean(o). Shadow rays multiply by it.
    #[inline]
    pub fn pass_through(&self, ctx: &BsdfContext) -> Option<Rgb> {
        match self {
            Bsdf::Mask(m) => Some(Rgb::ONE - m.opacity(ctx)),
            _ => None,
        }
    }

    /// The BSDF that scatters at a vertex once a pass-through has been ruled out: a mask's nested
    /// BSDF, or `self`.
    #[inline]
    pub fn opaque_part(&self) -> &Bsdf {
        match self {
            Bsdf::Mask(m) => &m.nested,
            b => b,
        }
    }

    /// A rough reflectance at `uv` for the albedo AOV (diffuse + specular reflectance at normal
    /// incidence, clamped to [0, 1]; dielectrics report reflectance + transmittance).
    pub fn albedo(&self, ctx: &BsdfContext) -> Rgb {
        let a = match self {
            Bsdf::Diffuse(b) => b.reflectance.at(ctx),
            Bsdf::Conductor(b) => b.reflectance(ctx, 1.0),
            Bsdf::RoughConductor(b) => {
                fresnel::fresnel_conductor(1.0, b.eta.at(ctx), b.k.at(ctx))
                    * b.specular_reflectance.at(ctx)
            }
            Bsdf::Dielectric(b) => {
                let f = fresnel::fresnel_dielectric(1.0, b.eta).f;
                b.specular_reflectance.at(ctx) * f + b.specular_transmittance.at(ctx) * (1.0 - f)
            }
            Bsdf::RoughDielectric(b) => {
                let f = fresnel::fresnel_dielectric(1.0, b.eta).f;
                b.specular_reflectance.at(ctx) * f + b.specular_transmittance.at(ctx) * (1.0 - f)
            }
            Bsdf::ThinDielectric(b) => {
                let r = b.slab_reflectance(1.0);
                b.specular_reflectance.at(ctx) * r + b.specular_transmittance.at(ctx) * (1.0 - r)
            }
            Bsdf::Plastic(b) => b.diffuse_reflectance.at(ctx) + b.specular_albedo(ctx),
            Bsdf::RoughPlastic(b) => b.diffuse_reflectance.at(ctx) + b.specular_albedo(ctx),
            Bsdf::TwoSided(b) => b.sides[0].albedo(ctx),
            Bsdf::NormalMap(b) => b.nested.albedo(ctx),
            Bsdf::BumpMap(b) => b.nested.albedo(ctx),
            Bsdf::Coating(b) => b.albedo(ctx),
            Bsdf::RoughCoating(b) => b.albedo(ctx),
            Bsdf::Blend(b) => {
                let w = b.weight.at_1(ctx).clamp(0.0, 1.0);
                b.bsdfs[0].albedo(ctx) * (1.0 - w) + b.bsdfs[1].albedo(ctx) * w
            }
            Bsdf::Mixture(b) => b
                .bsdfs
                .iter()
                .zip(b.weights())
                .fold(Rgb::ZERO, |acc, (c, w)| acc + c.albedo(ctx) * *w),
            Bsdf::Mask(b) => b.nested.albedo(ctx) * b.opacity(ctx),
            Bsdf::DiffuseTransmitter(b) => b.transmittance.at(ctx),
            Bsdf::Phong(b) => b.diffuse_reflectance.at(ctx) + b.specular_reflectance.at(ctx),
            Bsdf::Ward(b) => b.diffuse_reflectance.at(ctx) + b.specular_reflectance.at(ctx),
        };
        a.clamp(Rgb::ZERO, Rgb::ONE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enum_stays_small() {
        assert!(
            std::mem::size_of::<Bsdf>() <= 48,
            "{}",
            std::mem::size_of::<Bsdf>()
        );
    }
}
