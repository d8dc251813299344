//! Builders of the BSDFs that wrap other BSDFs and came with Mitsuba 0.6 scenes: `mixturebsdf`,
//! `bumpmap`, `coating`, `roughcoating`.

use super::build::build_bsdf;
use super::params::{microfacet, relative_ior, texture, texture_from_desc};

use super::{Bsdf, BumpMap, Coating, CoatingLayer, Mixture, RoughCoating};
use crate::color::Rgb;
use crate::desc::{ObjectClass, ObjectDesc, PropValue};
use crate::error::{SceneError, SceneResult};

/// `mixturebsdf` (Mitsuba 0.6): nested BSDFs in document order and `weights`, a string of as many
/// non-negative numbers separated by commas, spaces or semicolons. With `ensureEnergyConservation`
/// (default true) weights summing to more than one are divided by their sum, with Mitsuba's warning.
pub(super) fn mixture(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    let Some(prop) = obj.prop("weights") else {
        return Err(obj.error(
            "'mixturebsdf' needs 'weights', a string of one weight per nested BSDF (e.g. \"0.3, 0.7\")",
        ));
    };
    let mut weights = Vec::new();
    match &prop.value {
        PropValue::String(text) => {
            for token in text
                .split([' ', ',', ';', '\t', '\n'])
                .filter(|t| !t.is_empty())
            {
                let v: f64 = token.parse().map_err(|_| {
                    SceneError::at(
                        &prop.loc,
                        format!("'mixturebsdf' weights: cannot parse '{token}' as a number"),
                    )
                })?;
                weights.push(v);
            }
        }
        PropValue::Float(v) => weights.push(*v),
        PropValue::Integer(v) => weights.push(*v as f64),
        other => {
            return Err(SceneError::at(
                &prop.loc,
                format!(
                    "'mixturebsdf' weights must be a string of numbers, found <{}>",
                    other.type_name()
                ),
            ))
        }
    }
    if let Some(bad) = weights.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        return Err(SceneError::at(
            &prop.loc,
            format!("'mixturebsdf' weights must be finite and non-negative, got {bad}"),
        ));
    }
    if weights.len() != nested.len() {
        return Err(SceneError::at(
            &prop.loc,
            format!(
                "'mixturebsdf' has {} nested BSDFs but {} weights",
                nested.len(),
                weights.len()
            ),
        ));
    }
    let total: f64 = weights.iter().sum();
    if !(total > 0.0) {
        return Err(SceneError::at(
            &prop.loc,
            "'mixturebsdf' weights must not all be zero",
        ));
    }
    if total > 1.0 && obj.bool_or("ensure_energy_conservation", true)? {
        w.push(format!(
            "{}: 'mixturebsdf' weights sum to {total}, more than one: they are divided by their sum \
             (as Mitsuba 0.6 does; set ensureEnergyConservation=false to keep them)",
            prop.loc
        ));
        weights.iter_mut().for_each(|v| *v /= total);
    }
    let bsdfs = nested
        .iter()
        .map(|c| build_bsdf(&c.object, w))
        .collect::<SceneResult<Vec<_>>>()?;
    let mixture = Mixture::new(bsdfs, weights.iter().map(|v| *v as f32).collect())
        .ok_or_else(|| SceneError::at(&prop.loc, "'mixturebsdf' weights are out of range"))?;
    Ok(Bsdf::Mixture(Box::new(mixture)))
}

/// `bumpmap` (Mitsuba 0.6 and 3): one nested BSDF, one nested texture of any name (the height field)
/// and Mitsuba 3's `scale` (default 1) and `use_shadowing_function` (default true; false in 0.x files,
/// see desc/legacy.rs). A Mitsuba 0.6 `scale` texture around the height field (how 0.6 scenes scale
/// bumps) multiplies `scale` by its factor.
pub(super) fn bumpmap(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.len() != 1 {
        return Err(obj.error(format!(
            "'bumpmap' needs exactly one nested BSDF, found {}",
            nested.len()
        )));
    }
    let textures: Vec<_> = obj.children_of(&ObjectClass::Texture).collect();
    if textures.len() != 1 {
        return Err(obj.error(format!(
            "'bumpmap' needs exactly one nested texture (the height field), found {}",
            textures.len()
        )));
    }
    let mut scale = obj.float_or("scale", 1.0)?;
    let mut tex = &textures[0].object;
    while tex.plugin == "scale" {
        scale *= tex.float_or("scale", 1.0)?;
        let inner: Vec<_> = tex.children_of(&ObjectClass::Texture).collect();
        if inner.len() != 1 {
            return Err(tex.error(format!(
                "'scale' texture of a 'bumpmap' needs exactly one nested texture, found {}",
                inner.len()
            )));
        }
        tex = &inner[0].object;
    }
    if !scale.is_finite() {
        let loc = obj.prop("scale").map_or(&obj.loc, |p| &p.loc);
        return Err(SceneError::at(loc, "'bumpmap' scale must be finite"));
    }
    Ok(Bsdf::BumpMap(Box::new(BumpMap {
        nested: build_bsdf(&nested[0].object, w)?,
        height: texture_from_desc(tex)?,
        scale: scale as f32,
        shadowing: obj.bool_or("use_shadowing_function", true)?,
    })))
}

/// The one nested BSDF of `obj`, built; transmissive models are refused (a coating's layer model
/// only reflects).
fn one_reflecting_nested(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.len() != 1 {
        return Err(obj.error(format!(
            "'{}' needs exactly one nested BSDF, found {}",
            obj.plugin,
            nested.len()
        )));
    }
    let b = build_bsdf(&nested[0].object, w)?;
    if b.has_transmission() {
        return Err(SceneError::at(
            &nested[0].object.loc,
            format!(
                "'{}' cannot coat the transmissive BSDF '{}'",
                obj.plugin, nested[0].object.plugin
            ),
        ));
    }
    Ok(b)
}

/// What `coating` and `roughcoating` share: the nested BSDF and the layer (relative IOR, thickness, σₐ
/// and the specular multiplier).
fn layer(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<(Bsdf, CoatingLayer)> {
    let nested = one_reflecting_nested(obj, w)?;
    let eta = relative_ior(obj, "bk7", true)?;
    let thickness = obj.float_or("thickness", 1.0)?;
    if !(thickness.is_finite() && thickness >= 0.0) {
        let loc = obj.prop("thickness").map_or(&obj.loc, |p| &p.loc);
        return Err(SceneError::at(
            loc,
            format!(
                "'{}' thickness must be finite and non-negative, got {thickness}",
                obj.plugin
            ),
        ));
    }
    let sigma_a = texture(obj, &["sigma_a"], Rgb::ZERO)?;
    if sigma_a.mean().min_element() < 0.0 || !sigma_a.max_value().is_finite() {
        let loc = obj.prop("sigma_a").map_or(&obj.loc, |p| &p.loc);
        return Err(SceneError::at(
            loc,
            format!("'{}' sigmaA must be finite and non-negative", obj.plugin),
        ));
    }
    let specular_reflectance = texture(obj, &["specular_reflectance"], Rgb::ONE)?;
    let layer = CoatingLayer::new(eta, thickness as f32, sigma_a, specular_reflectance);
    Ok((nested, layer))
}

/// `coating` (Mitsuba 0.6): one nested BSDF, `intIOR` (bk7) / `extIOR` (air), `thickness` (1),
/// `sigmaA` (0, spectrum or texture) and `specularReflectance` (1).
pub(super) fn coating(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let (nested, layer) = layer(obj, w)?;
    Ok(Bsdf::Coating(Box::new(Coating::new(nested, layer))))
}

/// `roughcoating` (Mitsuba 0.6): as `coating`, plus the isotropic microfacet parameters
/// (`distribution` beckmann, `alpha` 0.1, `sample_visible`).
pub(super) fn roughcoating(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let (nested, layer) = layer(obj, w)?;
    let distribution = microfacet(obj, false, w)?;
    Ok(Bsdf::RoughCoating(Box::new(RoughCoating::new(
        nested,
        distribution,
        layer,
    ))))
}
