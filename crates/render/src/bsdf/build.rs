//! Builds BSDFs from the neutral scene description with Mitsuba 3's parameter names and defaults
//! (Mitsuba 0.6 names arrive already normalised to snake_case, e.g. `intIOR` → `int_ior`).

use super::ior::{conductor_ior, conductor_names, dielectric_ior, dielectric_names};
use super::{
    Bsdf, Conductor, Dielectric, Diffuse, Microfacet, MicrofacetKind, Plastic, RoughConductor, RoughDielectric,
    RoughPlastic, ThinDielectric, TwoSided,
};
use crate::color::Rgb;
use crate::desc::{ObjectClass, ObjectDesc, PropValue, Property};
use crate::error::{SceneError, SceneResult};
use crate::texture::Texture;

/// The BSDF plugins we can build.
const KNOWN_PLUGINS: &[&str] = &[
    "diffuse",
    "conductor",
    "roughconductor",
    "dielectric",
    "roughdielectric",
    "thindielectric",
    "plastic",
    "roughplastic",
    "twosided",
];

/// Builds the BSDF described by a `<bsdf>` element.
pub fn bsdf_from_desc(obj: &ObjectDesc) -> SceneResult<Bsdf> {
    match obj.plugin.as_str() {
        "diffuse" => Ok(Bsdf::Diffuse(Diffuse { reflectance: texture(obj, &["reflectance"], Rgb::splat(0.5))? })),
        "conductor" => {
            let (eta, k) = conductor_eta_k(obj)?;
            Ok(Bsdf::Conductor(Box::new(Conductor {
                eta,
                k,
                specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            })))
        }
        "roughconductor" => {
            let (eta, k) = conductor_eta_k(obj)?;
            Ok(Bsdf::RoughConductor(Box::new(RoughConductor {
                distribution: microfacet(obj, true)?,
                eta,
                k,
                specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            })))
        }
        "dielectric" => Ok(Bsdf::Dielectric(Dielectric {
            eta: relative_ior(obj, "bk7", false)?,
            specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            specular_transmittance: texture(obj, &["specular_transmittance"], Rgb::ONE)?,
        })),
        "thindielectric" => Ok(Bsdf::ThinDielectric(ThinDielectric {
            eta: relative_ior(obj, "bk7", false)?,
            specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            specular_transmittance: texture(obj, &["specular_transmittance"], Rgb::ONE)?,
        })),
        "roughdielectric" => Ok(Bsdf::RoughDielectric(Box::new(RoughDielectric {
            distribution: microfacet(obj, true)?,
            eta: relative_ior(obj, "bk7", true)?,
            specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            specular_transmittance: texture(obj, &["specular_transmittance"], Rgb::ONE)?,
        }))),
        "plastic" => Ok(Bsdf::Plastic(Box::new(Plastic::new(
            relative_ior(obj, "polypropylene", false)?,
            texture(obj, &["diffuse_reflectance"], Rgb::splat(0.5))?,
            optional_texture(obj, &["specular_reflectance"])?,
            obj.bool_or("nonlinear", false)?,
        )))),
        "roughplastic" => {
            let dist = microfacet(obj, false)?;
            Ok(Bsdf::RoughPlastic(Box::new(RoughPlastic::new(
                dist.kind,
                dist.alpha_u,
                dist.sample_visible,
                relative_ior(obj, "polypropylene", true)?,
                texture(obj, &["diffuse_reflectance"], Rgb::splat(0.5))?,
                optional_texture(obj, &["specular_reflectance"])?,
                obj.bool_or("nonlinear", false)?,
            ))))
        }
        "twosided" => twosided(obj),
        other => Err(obj.error(format!(
            "unknown BSDF plugin '{other}' (supported: {})",
            KNOWN_PLUGINS.join(", ")
        ))),
    }
}

/// The first property present under any of the given names (current name first, then aliases).
fn find_prop<'a>(obj: &'a ObjectDesc, names: &[&str]) -> Option<&'a Property> {
    names.iter().find_map(|n| obj.prop(n))
}

/// Rejects a nested `<texture>` bound to one of `names` (bitmap/procedural textures come later).
fn reject_texture_child(obj: &ObjectDesc, names: &[&str]) -> SceneResult<()> {
    for n in names {
        if let Some(child) = obj.named_child(n) {
            return Err(SceneError::at(
                &child.object.loc,
                format!(
                    "parameter '{n}' of {} '{}': textures not yet supported (<{} type=\"{}\">)",
                    obj.class.tag(),
                    obj.plugin,
                    child.object.class.tag(),
                    child.object.plugin
                ),
            ));
        }
    }
    Ok(())
}

/// A colour parameter as a constant texture (rgb, spectrum or float), or `default`.
fn texture(obj: &ObjectDesc, names: &[&str], default: Rgb) -> SceneResult<Texture> {
    Ok(optional_texture(obj, names)?.unwrap_or(Texture::Constant(default)))
}

/// A colour parameter as a constant texture, or `None` if absent.
fn optional_texture(obj: &ObjectDesc, names: &[&str]) -> SceneResult<Option<Texture>> {
    reject_texture_child(obj, names)?;
    match find_prop(obj, names) {
        None => Ok(None),
        Some(p) => {
            let v = obj.rgb_or(&p.name, Rgb::ZERO)?;
            if !v.is_finite() {
                return Err(SceneError::at(&p.loc, format!("parameter '{}' must be finite, found {v}", p.name)));
            }
            Ok(Some(Texture::Constant(v)))
        }
    }
}

/// A float parameter under any of `names`, or `default`; with its property for error locations.
fn float_param<'a>(obj: &'a ObjectDesc, names: &[&str], default: f64) -> SceneResult<(f64, Option<&'a Property>)> {
    match find_prop(obj, names) {
        None => Ok((default, None)),
        Some(p) => {
            let v = obj.float_or(&p.name, default)?;
            if !v.is_finite() {
                return Err(SceneError::at(&p.loc, format!("parameter '{}' must be finite, found {v}", p.name)));
            }
            Ok((v, Some(p)))
        }
    }
}

/// An index of refraction given as a number or a material name from Mitsuba's table.
fn ior_param(obj: &ObjectDesc, names: &[&str], default_name: &str) -> SceneResult<f32> {
    let Some(p) = find_prop(obj, names) else {
        return Ok(dielectric_ior(default_name).expect("default IOR names are in the table"));
    };
    let v = match &p.value {
        PropValue::String(name) => dielectric_ior(name).ok_or_else(|| {
            SceneError::at(
                &p.loc,
                format!(
                    "unknown index of refraction '{name}' for '{}' (known: {})",
                    p.name,
                    dielectric_names().collect::<Vec<_>>().join(", ")
                ),
            )
        })?,
        _ => obj.float_or(&p.name, 1.0)? as f32,
    };
    if !(v > 0.0) || !v.is_finite() {
        return Err(SceneError::at(&p.loc, format!("index of refraction '{}' must be positive, found {v}", p.name)));
    }
    Ok(v)
}

/// int_ior / ext_ior (ext_ior defaults to air, 1.000277, as in Mitsuba 3). `must_differ` rejects
/// index-matched interfaces, which the rough models cannot represent (as Mitsuba).
fn relative_ior(obj: &ObjectDesc, default_int: &str, must_differ: bool) -> SceneResult<f32> {
    let int_names = ["int_ior", "int_i_o_r"];
    let int_ior = ior_param(obj, &int_names, default_int)?;
    let ext_ior = ior_param(obj, &["ext_ior", "ext_i_o_r"], "air")?;
    if must_differ && int_ior == ext_ior {
        let loc = find_prop(obj, &int_names).map_or(&obj.loc, |p| &p.loc);
        return Err(SceneError::at(
            loc,
            format!("{} '{}': the interior and exterior indices of refraction must differ", obj.class.tag(), obj.plugin),
        ));
    }
    Ok(int_ior / ext_ior)
}

/// The complex IOR of a conductor: `eta`/`k` (defaults 0 and 1), or a named `material` (default
/// "none", a perfect mirror); not both. A Mitsuba 0.6 `ext_eta` divides both.
fn conductor_eta_k(obj: &ObjectDesc) -> SceneResult<(Texture, Texture)> {
    let material = obj.string_or("material", "none")?;
    let has_eta_k = obj.prop("eta").is_some() || obj.prop("k").is_some();
    let (eta, k) = if has_eta_k || material == "none" {
        if material != "none" {
            let p = obj.prop("material").expect("material was given");
            return Err(SceneError::at(&p.loc, "specify either 'eta'/'k' or 'material', not both"));
        }
        let eta = texture(obj, &["eta"], Rgb::ZERO)?;
        let k = texture(obj, &["k"], Rgb::ONE)?;
        match (eta, k) {
            (Texture::Constant(e), Texture::Constant(k)) => (e, k),
        }
    } else {
        conductor_ior(&material).ok_or_else(|| {
            let p = obj.prop("material").expect("material was given");
            SceneError::at(
                &p.loc,
                format!(
                    "unknown conductor material '{material}' (known: {})",
                    conductor_names().collect::<Vec<_>>().join(", ")
                ),
            )
        })?
    };
    if eta.min_element() < 0.0 || k.min_element() < 0.0 {
        return Err(obj.error("conductor 'eta' and 'k' must be non-negative"));
    }
    let ext_eta = ior_param(obj, &["ext_eta"], "vacuum")?;
    Ok((Texture::Constant(eta / ext_eta), Texture::Constant(k / ext_eta)))
}

/// The microfacet distribution: `distribution` (beckmann | ggx, default beckmann), `alpha` or
/// `alpha_u`/`alpha_v` (default 0.1), `sample_visible` (default true).
fn microfacet(obj: &ObjectDesc, allow_anisotropic: bool) -> SceneResult<Microfacet> {
    let kind = match obj.prop("distribution") {
        None => MicrofacetKind::Beckmann,
        Some(p) => {
            let name = obj.string_or("distribution", "beckmann")?;
            match name.to_ascii_lowercase().as_str() {
                "beckmann" => MicrofacetKind::Beckmann,
                "ggx" => MicrofacetKind::Ggx,
                _ => {
                    return Err(SceneError::at(
                        &p.loc,
                        format!("invalid microfacet distribution '{name}', must be 'beckmann' or 'ggx'"),
                    ))
                }
            }
        }
    };
    reject_texture_child(obj, &["alpha", "alpha_u", "alpha_v"])?;
    let alpha = float_param(obj, &["alpha"], 0.1)?;
    let alpha_u = float_param(obj, &["alpha_u"], 0.1)?;
    let alpha_v = float_param(obj, &["alpha_v"], 0.1)?;
    let (au, av) = match (alpha.1, alpha_u.1, alpha_v.1) {
        (Some(p), Some(_), _) | (Some(p), _, Some(_)) => {
            return Err(SceneError::at(&p.loc, "specify either 'alpha' or 'alpha_u'/'alpha_v', not both"))
        }
        (Some(_), None, None) => (alpha.0, alpha.0),
        (None, Some(_), Some(_)) => (alpha_u.0, alpha_v.0),
        (None, Some(p), None) | (None, None, Some(p)) => {
            return Err(SceneError::at(&p.loc, "both 'alpha_u' and 'alpha_v' must be specified"))
        }
        (None, None, None) => (0.1, 0.1),
    };
    for (v, p) in [alpha, alpha_u, alpha_v] {
        if let Some(p) = p {
            if v < 0.0 {
                return Err(SceneError::at(&p.loc, format!("roughness '{}' must be non-negative, found {v}", p.name)));
            }
        }
    }
    if !allow_anisotropic && au != av {
        let p = alpha_u.1.expect("anisotropy needs alpha_u");
        return Err(SceneError::at(
            &p.loc,
            format!("'{}' does not support anisotropic roughness", obj.plugin),
        ));
    }
    let sample_visible = obj.bool_or("sample_visible", true)?;
    Ok(Microfacet::new(kind, au as f32, av as f32, sample_visible))
}

/// `twosided` with one nested BSDF (both sides) or two (front, back); transmissive models are rejected.
fn twosided(obj: &ObjectDesc) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.is_empty() || nested.len() > 2 {
        return Err(obj.error(format!("'twosided' needs one or two nested BSDFs, found {}", nested.len())));
    }
    let mut sides = Vec::with_capacity(2);
    for child in &nested {
        let b = bsdf_from_desc(&child.object)?;
        if b.has_transmission() {
            return Err(SceneError::at(
                &child.object.loc,
                format!("'twosided' cannot wrap the transmissive BSDF '{}'", child.object.plugin),
            ));
        }
        sides.push(b);
    }
    let back = if sides.len() == 2 { sides.pop().expect("two sides") } else { sides[0].clone() };
    let front = sides.pop().expect("one side");
    Ok(Bsdf::TwoSided(TwoSided { sides: Box::new([front, back]) }))
}
