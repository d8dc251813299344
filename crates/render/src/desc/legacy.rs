//! Mitsuba 3's in-memory upgrade of pre-2.0 (Mitsuba 0.x) elements, and the defaults in which Mitsuba
//! 0.6 differs from Mitsuba 3, made explicit so that the builder reads one dialect.

use super::body::Body;
use super::{ObjectClass, PropValue, Property};
use crate::error::{SceneResult, SourceLoc};
use glam::{DMat4, DVec2};

/// BSDF plugins with a microfacet roughness.
const MICROFACET_PLUGINS: &[&str] = &[
    "roughconductor",
    "roughdielectric",
    "roughplastic",
    "roughcoating",
];

/// Mitsuba 0.6 reads `alpha_u` and `alpha_v` each with `alpha` (default 0.1) as its default, so one of
/// them alone, or both with `alpha`, are valid there (Mitsuba 3 rejects both): the missing one gets
/// `alpha`'s value and `alpha` goes.
fn separate_roughness(loc: &SourceLoc, body: &mut Body) -> SceneResult<()> {
    let (has_u, has_v) = (
        body.names.contains_key("alpha_u"),
        body.names.contains_key("alpha_v"),
    );
    if !(has_u || has_v) {
        return Ok(());
    }
    let (alpha, at) = match body.props.iter().position(|p| p.name == "alpha") {
        Some(i) => {
            let p = body.props.remove(i);
            body.names.remove("alpha");
            (p.value, p.loc)
        }
        None => (PropValue::Float(0.1), loc.clone()),
    };
    for (present, name) in [(has_u, "alpha_u"), (has_v, "alpha_v")] {
        if !present {
            body.add_prop(Property {
                name: name.into(),
                value: alpha.clone(),
                loc: at.clone(),
            })?;
        }
    }
    Ok(())
}

/// Mitsuba 3's in-memory upgrade of pre-2.0 files, beyond the renaming done for every file: a diffuse
/// BSDF's `diffuse_reflectance` is its `reflectance`, and `uoffset`/`voffset`/`uscale`/`vscale` become
/// a `to_uv` transform (translate, then scale). Then Mitsuba 0.6's own defaults where Mitsuba 3's
/// differ: a `bitmap` without `filter_type` is MIP-mapped (`ewa`).
pub(super) fn upgrade_legacy(
    class: &ObjectClass,
    plugin: &str,
    loc: &SourceLoc,
    body: &mut Body,
) -> SceneResult<()> {
    if *class == ObjectClass::Bsdf && MICROFACET_PLUGINS.contains(&plugin) {
        separate_roughness(loc, body)?;
    }
    // Mitsuba 0.6's bump map has no shadowing term (Mitsuba 3 adds Estevez et al.'s by default).
    if *class == ObjectClass::Bsdf
        && plugin == "bumpmap"
        && !body.names.contains_key("use_shadowing_function")
    {
        body.add_prop(Property {
            name: "use_shadowing_function".into(),
            value: PropValue::Boolean(false),
            loc: loc.clone(),
        })?;
    }
    if *class == ObjectClass::Texture
        && plugin == "bitmap"
        && !body.names.contains_key("filter_type")
    {
        body.add_prop(Property {
            name: "filter_type".into(),
            value: PropValue::String("ewa".into()),
            loc: loc.clone(),
        })?;
    }
    if *class == ObjectClass::Bsdf && plugin == "diffuse" && !body.names.contains_key("reflectance")
    {
        if let Some(loc) = body.names.remove("diffuse_reflectance") {
            body.names.insert("reflectance".into(), loc);
            for p in body
                .props
                .iter_mut()
                .filter(|p| p.name == "diffuse_reflectance")
            {
                p.name = "reflectance".into();
            }
            for c in body.children.iter_mut() {
                if c.name.as_deref() == Some("diffuse_reflectance") {
                    c.name = Some("reflectance".into());
                }
            }
        }
    }

    let mut offset = DVec2::ZERO;
    let mut scale = DVec2::ONE;
    let mut first_loc = None;
    body.props.retain(|p| {
        let v = match p.value {
            PropValue::Float(v) => v,
            PropValue::Integer(v) => v as f64,
            _ => return true,
        };
        match p.name.as_str() {
            "uoffset" => offset.x = v,
            "voffset" => offset.y = v,
            "uscale" => scale.x = v,
            "vscale" => scale.y = v,
            _ => return true,
        }
        first_loc.get_or_insert_with(|| p.loc.clone());
        false
    });
    if let Some(loc) = first_loc {
        for n in ["uoffset", "voffset", "uscale", "vscale"] {
            body.names.remove(n);
        }
        let m = DMat4::from_scale(scale.extend(1.0)) * DMat4::from_translation(offset.extend(0.0));
        body.add_prop(Property {
            name: "to_uv".into(),
            value: PropValue::Transform(m.as_mat4()),
            loc,
        })?;
    }
    Ok(())
}
