//! Reading BSDF parameters: colours and textures, floats, indices of refraction (numbers or names from
//! Mitsuba's tables), conductors' complex indices and microfacet distributions, with Mitsuba 3's names
//! and defaults and the leniencies of Mitsuba 0.6 (see docs/plugins.md).

use super::ior::{conductor_ior, conductor_names, dielectric_ior, dielectric_names};
use super::{is_positive, Microfacet, MicrofacetKind};
use crate::color::Rgb;
use crate::desc::{ObjectClass, ObjectDesc, PropValue, Property};
use crate::error::{SceneError, SceneResult};
use crate::texture::{Bitmap, Checkerboard, Texture, UvTransform};
use std::sync::Arc;

/// The first property present under any of the given names (current name first, then aliases).
pub(super) fn find_prop<'a>(obj: &'a ObjectDesc, names: &[&str]) -> Option<&'a Property> {
    names.iter().find_map(|n| obj.prop(n))
}

/// Rejects a nested `<texture>` bound to one of `names` (bitmap/procedural textures come later).
pub(super) fn reject_texture_child(obj: &ObjectDesc, names: &[&str]) -> SceneResult<()> {
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
pub(super) fn texture(obj: &ObjectDesc, names: &[&str], default: Rgb) -> SceneResult<Texture> {
    Ok(optional_texture(obj, names)?.unwrap_or(Texture::Constant(default)))
}

/// Builds a nested `<texture>` element: `bitmap` or `checkerboard`.
pub fn texture_from_desc(t: &ObjectDesc) -> SceneResult<Texture> {
    match t.plugin.as_str() {
        "bitmap" => Ok(Texture::Bitmap(Arc::new(Bitmap::from_desc(t)?))),
        "checkerboard" => {
            reject_texture_child(t, &["color0", "color1"])?;
            Ok(Texture::Checkerboard(Arc::new(Checkerboard {
                color0: t.rgb_or("color0", Rgb::splat(0.4))?,
                color1: t.rgb_or("color1", Rgb::splat(0.2))?,
                to_uv: UvTransform::from_desc(t)?,
            })))
        }
        other => Err(t.error(format!(
            "unsupported texture plugin '{other}' (supported: bitmap, checkerboard)"
        ))),
    }
}

/// A colour parameter as a texture (a nested `<texture>`, or a constant rgb, spectrum or float), or
/// `None` if absent.
pub(super) fn optional_texture(obj: &ObjectDesc, names: &[&str]) -> SceneResult<Option<Texture>> {
    for n in names {
        if let Some(child) = obj.named_child(n) {
            if child.object.class == ObjectClass::Texture {
                return texture_from_desc(&child.object).map(Some);
            }
        }
    }
    reject_texture_child(obj, names)?;
    match find_prop(obj, names) {
        None => Ok(None),
        Some(p) => {
            let v = obj.rgb_or(&p.name, Rgb::ZERO)?;
            if !v.is_finite() {
                return Err(SceneError::at(
                    &p.loc,
                    format!("parameter '{}' must be finite, found {v}", p.name),
                ));
            }
            Ok(Some(Texture::Constant(v)))
        }
    }
}

/// A float parameter under any of `names`, or `default`; with its property for error locations.
pub(super) fn float_param<'a>(
    obj: &'a ObjectDesc,
    names: &[&str],
    default: f64,
) -> SceneResult<(f64, Option<&'a Property>)> {
    match find_prop(obj, names) {
        None => Ok((default, None)),
        Some(p) => {
            let v = obj.float_or(&p.name, default)?;
            if !v.is_finite() {
                return Err(SceneError::at(
                    &p.loc,
                    format!("parameter '{}' must be finite, found {v}", p.name),
                ));
            }
            Ok((v, Some(p)))
        }
    }
}

/// An index of refraction given as a number or a material name from Mitsuba's table.
pub(super) fn ior_param(obj: &ObjectDesc, names: &[&str], default_name: &str) -> SceneResult<f32> {
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
    if !is_positive(v) || !v.is_finite() {
        return Err(SceneError::at(
            &p.loc,
            format!(
                "index of refraction '{}' must be positive, found {v}",
                p.name
            ),
        ));
    }
    Ok(v)
}

/// int_ior / ext_ior (ext_ior defaults to air, 1.000277, as in Mitsuba 3). `must_differ` rejects
/// index-matched interfaces, which the rough models cannot represent (as Mitsuba).
pub(super) fn relative_ior(
    obj: &ObjectDesc,
    default_int: &str,
    must_differ: bool,
) -> SceneResult<f32> {
    let int_names = ["int_ior", "int_i_o_r"];
    let int_ior = ior_param(obj, &int_names, default_int)?;
    let ext_ior = ior_param(obj, &["ext_ior", "ext_i_o_r"], "air")?;
    if must_differ && int_ior == ext_ior {
        let loc = find_prop(obj, &int_names).map_or(&obj.loc, |p| &p.loc);
        return Err(SceneError::at(
            loc,
            format!(
                "{} '{}': the interior and exterior indices of refraction must differ",
                obj.class.tag(),
                obj.plugin
            ),
        ));
    }
    Ok(int_ior / ext_ior)
}

/// The complex IOR of a conductor: `eta`/`k` (defaults 0 and 1), or a named `material` (default
/// "none", a perfect mirror); not both. A Mitsuba 0.6 `ext_eta` divides both. As in Mitsuba 0.6,
/// "none" is matched case-insensitively (other names are file names there and keep their case), and
/// negative `eta`/`k` are accepted with a warning: the Fresnel term only uses their squares and the
/// product η·k squared, so they are read as |η| and |k|, exactly what Mitsuba 0.6 computes.
pub(super) fn conductor_eta_k(
    obj: &ObjectDesc,
    warnings: &mut Vec<String>,
) -> SceneResult<(Texture, Texture)> {
    let material = obj.string_or("material", "none")?;
    let is_none = material.eq_ignore_ascii_case("none");
    let has_eta_k = obj.prop("eta").is_some() || obj.prop("k").is_some();
    let (eta, k) = if has_eta_k || is_none {
        if !is_none {
            let p = obj.prop("material").expect("material was given");
            return Err(SceneError::at(
                &p.loc,
                "specify either 'eta'/'k' or 'material', not both",
            ));
        }
        let eta = texture(obj, &["eta"], Rgb::ZERO)?;
        let k = texture(obj, &["k"], Rgb::ONE)?;
        match (eta, k) {
            (Texture::Constant(e), Texture::Constant(k)) => (e, k),
            _ => {
                return Err(obj.error(
                    "conductor 'eta' and 'k' must be constant (textures are not supported)",
                ))
            }
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
        let at = ["eta", "k"]
            .iter()
            .filter_map(|n| obj.prop(n))
            .map(|p| p.loc.to_string())
            .next()
            .unwrap_or_else(|| obj.loc.to_string());
        warnings.push(format!(
            "{at}: {} '{}' has a negative 'eta' ({eta}) or 'k' ({k}); read as |eta| = {}, |k| = {} \
             (the conductor Fresnel term depends only on their squares, as in Mitsuba 0.6)",
            obj.class.tag(),
            obj.plugin,
            eta.abs(),
            k.abs()
        ));
    }
    let ext_eta = ior_param(obj, &["ext_eta"], "vacuum")?;
    Ok((
        Texture::Constant(eta.abs() / ext_eta),
        Texture::Constant(k.abs() / ext_eta),
    ))
}

/// The microfacet distribution: `distribution` (beckmann | ggx, default beckmann; Mitsuba 0.6's `phong`
/// and `as` are read as Beckmann with the same roughness, with a warning), `alpha` or
/// `alpha_u`/`alpha_v` (default 0.1), `sample_visible` (default true).
pub(super) fn microfacet(
    obj: &ObjectDesc,
    allow_anisotropic: bool,
    warnings: &mut Vec<String>,
) -> SceneResult<Microfacet> {
    let kind = match obj.prop("distribution") {
        None => MicrofacetKind::Beckmann,
        Some(p) => {
            let name = obj.string_or("distribution", "beckmann")?;
            match name.to_ascii_lowercase().as_str() {
                "beckmann" => MicrofacetKind::Beckmann,
                "ggx" => MicrofacetKind::Ggx,
                "phong" | "as" => {
                    warnings.push(format!(
                        "{}: Mitsuba 0.6's '{name}' microfacet distribution is approximated by Beckmann \
                         with the same roughness (its Phong exponent 2/alpha^2 - 2 was chosen to match it)",
                        p.loc
                    ));
                    MicrofacetKind::Beckmann
                }
                _ => {
                    return Err(SceneError::at(
                        &p.loc,
                        format!(
                            "invalid microfacet distribution '{name}', must be 'beckmann' or 'ggx' \
                             (or Mitsuba 0.6's 'phong' or 'as')"
                        ),
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
            return Err(SceneError::at(
                &p.loc,
                "specify either 'alpha' or 'alpha_u'/'alpha_v', not both",
            ))
        }
        (Some(_), None, None) => (alpha.0, alpha.0),
        (None, Some(_), Some(_)) => (alpha_u.0, alpha_v.0),
        (None, Some(p), None) | (None, None, Some(p)) => {
            return Err(SceneError::at(
                &p.loc,
                "both 'alpha_u' and 'alpha_v' must be specified",
            ))
        }
        (None, None, None) => (0.1, 0.1),
    };
    for (v, p) in [alpha, alpha_u, alpha_v] {
        if let Some(p) = p {
            if v < 0.0 {
                return Err(SceneError::at(
                    &p.loc,
                    format!("roughness '{}' must be non-negative, found {v}", p.name),
                ));
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

/// Mitsuba 0.6's `ward`: `variant` (ward | ward-duer | balanced, default balanced), `alpha_u`/`alpha_v`
/// (each defaulting to `alpha`, 0.1; positive), `specular_reflectance` (0.2), `diffuse_reflectance`
/// (0.5).
pub(super) fn ward(obj: &ObjectDesc) -> SceneResult<super::Bsdf> {
    use super::WardVariant;
    let variant = match obj.prop("variant") {
        None => WardVariant::Balanced,
        Some(p) => match obj.string_or("variant", "")?.to_ascii_lowercase().as_str() {
            "ward" => WardVariant::Ward,
            "ward-duer" => WardVariant::WardDuer,
            "balanced" => WardVariant::Balanced,
            other => {
                return Err(SceneError::at(
                    &p.loc,
                    format!("invalid Ward variant '{other}' (ward, ward-duer or balanced)"),
                ))
            }
        },
    };
    reject_texture_child(obj, &["alpha", "alpha_u", "alpha_v"])?;
    let (alpha, _) = float_param(obj, &["alpha"], 0.1)?;
    let (au, pu) = float_param(obj, &["alpha_u"], alpha)?;
    let (av, pv) = float_param(obj, &["alpha_v"], alpha)?;
    for (v, p) in [(au, pu), (av, pv)] {
        if !(v > 0.0) {
            let loc = p.or(obj.prop("alpha")).map_or(&obj.loc, |p| &p.loc);
            return Err(SceneError::at(
                loc,
                format!("'ward' roughness must be positive, found {v}"),
            ));
        }
    }
    Ok(super::Bsdf::Ward(Box::new(super::Ward::new(
        variant,
        au as f32,
        av as f32,
        texture(obj, &["specular_reflectance"], Rgb::splat(0.2))?,
        texture(obj, &["diffuse_reflectance"], Rgb::splat(0.5))?,
    ))))
}
