//! Builds BSDFs from the neutral scene description with Mitsuba 3's parameter names and defaults
//! (Mitsuba 0.6 names arrive already normalised to snake_case, e.g. `intIOR` → `int_ior`).

use super::params::{
    conductor_eta_k, microfacet, optional_texture, relative_ior, texture, texture_from_desc,
};
use super::{
    Bsdf, Conductor, Dielectric, Diffuse, Plastic, RoughConductor, RoughDielectric, RoughPlastic,
    ThinDielectric, TwoSided,
};
use crate::color::Rgb;
use crate::desc::{ObjectClass, ObjectDesc};
use crate::error::{SceneError, SceneResult};
use crate::texture::{Bitmap, Texture};
use std::sync::Arc;

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
    "normalmap",
    "blendbsdf",
    "mask",
    "difftrans",
    "null",
    "roughdiffuse",
    "phong",
    "ward",
    "mixturebsdf",
    "bumpmap",
    "coating",
    "roughcoating",
];

/// Builds the BSDF described by a `<bsdf>` element, dropping warnings (see [`build_bsdf`]).
pub fn bsdf_from_desc(obj: &ObjectDesc) -> SceneResult<Bsdf> {
    build_bsdf(obj, &mut Vec::new())
}

/// Builds the BSDF described by a `<bsdf>` element; approximations and leniencies (documented in
/// docs/plugins.md) append a located message to `warnings`.
pub fn build_bsdf(obj: &ObjectDesc, warnings: &mut Vec<String>) -> SceneResult<Bsdf> {
    let w = warnings;
    match obj.plugin.as_str() {
        "diffuse" => Ok(Bsdf::Diffuse(Diffuse {
            reflectance: texture(obj, &["reflectance"], Rgb::splat(0.5))?,
        })),
        "roughdiffuse" => {
            w.push(format!(
                "{}: 'roughdiffuse' (Oren-Nayar) is rendered as Lambertian 'diffuse' with the same \
                 reflectance (its 'alpha' is ignored)",
                obj.loc
            ));
            Ok(Bsdf::Diffuse(Diffuse {
                reflectance: texture(obj, &["reflectance"], Rgb::splat(0.5))?,
            }))
        }
        "phong" => Ok(Bsdf::Phong(Box::new(super::Phong::new(
            texture(obj, &["exponent"], Rgb::splat(30.0))?,
            texture(obj, &["specular_reflectance"], Rgb::splat(0.2))?,
            texture(obj, &["diffuse_reflectance"], Rgb::splat(0.5))?,
        )))),
        "ward" => super::params::ward(obj),
        // Mitsuba 3's `null`: light passes through unchanged, i.e. a mask of opacity 0.
        "null" => Ok(Bsdf::Mask(Box::new(super::Mask {
            nested: Bsdf::Diffuse(Diffuse {
                reflectance: Texture::constant(0.0),
            }),
            opacity: Texture::constant(0.0),
        }))),
        "conductor" => {
            let (eta, k) = conductor_eta_k(obj, w)?;
            Ok(Bsdf::Conductor(Box::new(Conductor {
                eta,
                k,
                specular_reflectance: texture(obj, &["specular_reflectance"], Rgb::ONE)?,
            })))
        }
        "roughconductor" => {
            let (eta, k) = conductor_eta_k(obj, w)?;
            Ok(Bsdf::RoughConductor(Box::new(RoughConductor {
                distribution: microfacet(obj, true, w)?,
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
            distribution: microfacet(obj, true, w)?,
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
            let dist = microfacet(obj, false, w)?;
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
        "twosided" => twosided(obj, w),
        "normalmap" => normalmap(obj, w),
        "blendbsdf" => blend(obj, w),
        "mixturebsdf" => super::build_adapters::mixture(obj, w),
        "mask" => mask(obj, w),
        "difftrans" => Ok(Bsdf::DiffuseTransmitter(super::DiffuseTransmitter {
            // Mitsuba 0.6 also reads `diffuseTransmittance`.
            transmittance: texture(
                obj,
                &["transmittance", "diffuse_transmittance"],
                Rgb::splat(0.5),
            )?,
        })),
        "bumpmap" => super::build_adapters::bumpmap(obj, w),
        "coating" => super::build_adapters::coating(obj, w),
        "roughcoating" => super::build_adapters::roughcoating(obj, w),
        other => Err(obj.error(format!(
            "unknown BSDF plugin '{other}' (supported: {})",
            KNOWN_PLUGINS.join(", ")
        ))),
    }
}

/// `blendbsdf`: two nested BSDFs (`bsdf_0`, `bsdf_1` or in document order) and `weight` (default 0.5).
fn blend(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.len() != 2 {
        return Err(obj.error(format!(
            "'blendbsdf' needs exactly two nested BSDFs, found {}",
            nested.len()
        )));
    }
    let pick = |name: &str, fallback: usize| {
        nested
            .iter()
            .find(|c| c.name.as_deref() == Some(name))
            .unwrap_or(&nested[fallback])
    };
    let (b0, b1) = (pick("bsdf_0", 0), pick("bsdf_1", 1));
    if std::ptr::eq(*b0, *b1) {
        return Err(obj.error("'blendbsdf': bsdf_0 and bsdf_1 are the same element"));
    }
    let weight = texture(obj, &["weight"], Rgb::splat(0.5))?;
    if let Texture::Constant(w) = &weight {
        if w.min_element() < 0.0 || w.max_element() > 1.0 {
            return Err(obj.error(format!("'blendbsdf' weight must lie in [0, 1], got {w}")));
        }
    }
    Ok(Bsdf::Blend(Box::new(super::Blend {
        bsdfs: Box::new([build_bsdf(&b0.object, w)?, build_bsdf(&b1.object, w)?]),
        weight,
    })))
}

/// `mask`: one nested BSDF and `opacity` (constant or texture, default 0.5, values in [0, 1]).
fn mask(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.len() != 1 {
        return Err(obj.error(format!(
            "'mask' needs exactly one nested BSDF, found {}",
            nested.len()
        )));
    }
    let opacity = texture(obj, &["opacity"], Rgb::splat(0.5))?;
    if let Texture::Constant(o) = &opacity {
        if o.min_element() < 0.0 || o.max_element() > 1.0 {
            let loc = obj.prop("opacity").map_or(&obj.loc, |p| &p.loc);
            return Err(SceneError::at(
                loc,
                format!("'mask' opacity must lie in [0, 1], got {o}"),
            ));
        }
    }
    Ok(Bsdf::Mask(Box::new(super::Mask {
        nested: build_bsdf(&nested[0].object, w)?,
        opacity,
    })))
}

/// `normalmap`: one nested BSDF and the normal map, either a nested `<texture name="normalmap">` (Mitsuba
/// 3) or a `filename` on the element itself (Mitsuba 2 / SMS); the image is read raw (no sRGB decoding).
fn normalmap(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.len() != 1 {
        return Err(obj.error(format!(
            "'normalmap' needs exactly one nested BSDF, found {}",
            nested.len()
        )));
    }
    let normals = match obj.named_child("normalmap") {
        Some(c) if c.object.class == ObjectClass::Texture && c.object.plugin == "bitmap" => {
            Texture::Bitmap(Arc::new(Bitmap::from_desc_raw(&c.object, true)?))
        }
        Some(c) => texture_from_desc(&c.object)?,
        None if obj.prop("filename").is_some() => {
            Texture::Bitmap(Arc::new(Bitmap::from_desc_raw(obj, true)?))
        }
        None => return Err(obj.error(
            "'normalmap' needs a normal map: a nested <texture name=\"normalmap\"> or a 'filename'",
        )),
    };
    Ok(Bsdf::NormalMap(Box::new(super::NormalMap {
        nested: build_bsdf(&nested[0].object, w)?,
        normals,
    })))
}

/// `twosided` with one nested BSDF (both sides) or two (front, back); transmissive models are rejected.
fn twosided(obj: &ObjectDesc, w: &mut Vec<String>) -> SceneResult<Bsdf> {
    let nested: Vec<_> = obj.children_of(&ObjectClass::Bsdf).collect();
    if nested.is_empty() || nested.len() > 2 {
        return Err(obj.error(format!(
            "'twosided' needs one or two nested BSDFs, found {}",
            nested.len()
        )));
    }
    let mut sides = Vec::with_capacity(2);
    for child in &nested {
        let b = build_bsdf(&child.object, w)?;
        if b.has_transmission() {
            return Err(SceneError::at(
                &child.object.loc,
                format!(
                    "'twosided' cannot wrap the transmissive BSDF '{}'",
                    child.object.plugin
                ),
            ));
        }
        sides.push(b);
    }
    let back = if sides.len() == 2 {
        sides.pop().expect("two sides")
    } else {
        sides[0].clone()
    };
    let front = sides.pop().expect("one side");
    Ok(Bsdf::TwoSided(TwoSided::new(front, back)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{BsdfContext, MicrofacetKind};
    use crate::desc::{ChildDesc, PropValue, Property};
    use crate::error::SourceLoc;
    use glam::Vec3;
    use std::path::PathBuf;
    use std::sync::Arc;

    fn loc(line: u32) -> SourceLoc {
        SourceLoc {
            file: Arc::new(PathBuf::from("scene.xml")),
            line,
            col: 1,
        }
    }

    /// A `<bsdf>` element at line 1 whose properties sit on lines 2, 3, ...
    fn bsdf(plugin: &str, props: &[(&str, PropValue)]) -> ObjectDesc {
        ObjectDesc {
            class: ObjectClass::Bsdf,
            plugin: plugin.into(),
            id: None,
            props: props
                .iter()
                .enumerate()
                .map(|(i, (n, v))| Property {
                    name: n.to_string(),
                    value: v.clone(),
                    loc: loc(i as u32 + 2),
                })
                .collect(),
            children: Vec::new(),
            loc: loc(1),
        }
    }

    fn with_children(mut obj: ObjectDesc, children: Vec<(Option<&str>, ObjectDesc)>) -> ObjectDesc {
        obj.children = children
            .into_iter()
            .map(|(n, o)| ChildDesc {
                name: n.map(str::to_string),
                object: Arc::new(o),
            })
            .collect();
        obj
    }

    fn float(v: f64) -> PropValue {
        PropValue::Float(v)
    }

    fn string(s: &str) -> PropValue {
        PropValue::String(s.into())
    }

    fn err_line(r: SceneResult<Bsdf>) -> (u32, String) {
        let e = r.expect_err("expected a scene error");
        (e.loc.expect("located").line, e.message)
    }

    #[test]
    fn defaults_follow_mitsuba3() {
        let Bsdf::Diffuse(d) = bsdf_from_desc(&bsdf("diffuse", &[])).unwrap() else {
            panic!()
        };
        assert_eq!(d.reflectance.eval(Default::default()), Rgb::splat(0.5));

        let Bsdf::Dielectric(d) = bsdf_from_desc(&bsdf("dielectric", &[])).unwrap() else {
            panic!()
        };
        assert!((d.eta - 1.5046 / 1.000277).abs() < 1e-6);
        let Bsdf::Dielectric(d) =
            bsdf_from_desc(&bsdf("dielectric", &[("int_ior", float(1.5))])).unwrap()
        else {
            panic!()
        };
        assert!((d.eta - 1.49958).abs() < 1e-5, "{}", d.eta);
        let Bsdf::Dielectric(d) = bsdf_from_desc(&bsdf(
            "dielectric",
            &[("int_ior", string("water")), ("ext_ior", string("vacuum"))],
        ))
        .unwrap() else {
            panic!()
        };
        assert!((d.eta - 1.333).abs() < 1e-6);

        let Bsdf::Plastic(p) = bsdf_from_desc(&bsdf("plastic", &[])).unwrap() else {
            panic!()
        };
        assert!((p.eta - 1.49 / 1.000277).abs() < 1e-6);
        assert!(!p.nonlinear && p.specular_reflectance.is_none());
        assert_eq!(
            p.diffuse_reflectance.eval(Default::default()),
            Rgb::splat(0.5)
        );

        let Bsdf::RoughConductor(c) = bsdf_from_desc(&bsdf("roughconductor", &[])).unwrap() else {
            panic!()
        };
        assert_eq!(c.distribution.kind, MicrofacetKind::Beckmann);
        assert_eq!((c.distribution.alpha_u, c.distribution.alpha_v), (0.1, 0.1));
        assert!(c.distribution.sample_visible);

        // Conductor "none": a perfect mirror.
        let b = bsdf_from_desc(&bsdf("conductor", &[])).unwrap();
        let s = b
            .sample(
                &BsdfContext::default(),
                Vec3::new(0.6, 0.0, 0.8),
                0.5,
                Default::default(),
            )
            .unwrap();
        assert!(s.delta && (s.weight - Rgb::ONE).abs().max_element() < 1e-6);
    }

    #[test]
    fn parameters_are_read() {
        let b = bsdf_from_desc(&bsdf(
            "roughdielectric",
            &[
                ("distribution", string("GGX")),
                ("alpha_u", float(0.2)),
                ("alpha_v", float(0.4)),
                ("int_i_o_r", float(1.33)),
                ("ext_i_o_r", float(1.0)),
                (
                    "specular_transmittance",
                    PropValue::Rgb(Vec3::new(0.5, 0.6, 0.7)),
                ),
            ],
        ))
        .unwrap();
        let Bsdf::RoughDielectric(d) = &b else {
            panic!()
        };
        assert_eq!(d.distribution.kind, MicrofacetKind::Ggx);
        assert_eq!((d.distribution.alpha_u, d.distribution.alpha_v), (0.2, 0.4));
        assert!((d.eta - 1.33).abs() < 1e-6);
        assert_eq!(
            d.specular_transmittance.eval(Default::default()),
            Vec3::new(0.5, 0.6, 0.7)
        );
        assert_eq!(b.min_roughness(), 0.2);

        let Bsdf::Conductor(c) =
            bsdf_from_desc(&bsdf("conductor", &[("material", string("Au"))])).unwrap()
        else {
            panic!()
        };
        let gold = c.reflectance(&BsdfContext::default(), 1.0);
        assert!(gold.x > gold.y && gold.y > gold.z && gold.x > 0.8, "{gold}");

        let b = bsdf_from_desc(&bsdf(
            "roughplastic",
            &[
                ("alpha", float(0.3)),
                ("nonlinear", PropValue::Boolean(true)),
                ("diffuse_reflectance", float(0.2)),
            ],
        ))
        .unwrap();
        let Bsdf::RoughPlastic(p) = &b else { panic!() };
        assert!(p.nonlinear && p.distribution.alpha_u == 0.3);
        assert!(
            p.internal_reflectance() > 0.4 && p.internal_reflectance() < 0.7,
            "{}",
            p.internal_reflectance()
        );
    }

    #[test]
    fn bad_parameters_are_located_errors() {
        let (line, msg) = err_line(bsdf_from_desc(&bsdf(
            "roughconductor",
            &[("alpha", float(-0.1))],
        )));
        assert_eq!(line, 2);
        assert!(msg.contains("non-negative"), "{msg}");
        let (line, msg) = err_line(bsdf_from_desc(&bsdf(
            "roughconductor",
            &[("alpha", float(0.1)), ("distribution", string("blinn"))],
        )));
        assert_eq!(line, 3);
        assert!(msg.contains("blinn"), "{msg}");
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "roughconductor",
            &[("alpha", float(0.1)), ("alpha_u", float(0.1))],
        )));
        assert_eq!(line, 2);
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "roughconductor",
            &[("alpha_u", float(0.1))],
        )));
        assert_eq!(line, 2);
        let (line, msg) = err_line(bsdf_from_desc(&bsdf(
            "dielectric",
            &[("int_ior", string("unobtainium"))],
        )));
        assert_eq!(line, 2);
        assert!(msg.contains("unobtainium") && msg.contains("bk7"), "{msg}");
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "dielectric",
            &[("int_ior", float(-1.5))],
        )));
        assert_eq!(line, 2);
        let (line, msg) = err_line(bsdf_from_desc(&bsdf(
            "conductor",
            &[("material", string("Unobtainium"))],
        )));
        assert_eq!(line, 2);
        assert!(msg.contains("Au"), "{msg}");
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "conductor",
            &[("material", string("Au")), ("eta", float(1.0))],
        )));
        assert_eq!(line, 2);
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "roughplastic",
            &[("alpha_u", float(0.1)), ("alpha_v", float(0.2))],
        )));
        assert_eq!(line, 2);
        let (line, _) = err_line(bsdf_from_desc(&bsdf(
            "roughdielectric",
            &[("int_ior", float(1.2)), ("ext_ior", float(1.2))],
        )));
        assert_eq!(line, 2);
        let (line, msg) = err_line(bsdf_from_desc(&bsdf(
            "diffuse",
            &[("reflectance", string("red"))],
        )));
        assert_eq!(line, 2);
        assert!(msg.contains("reflectance"), "{msg}");
        let (line, msg) = err_line(bsdf_from_desc(&bsdf("velvet", &[])));
        assert_eq!(line, 1);
        assert!(msg.contains("unknown BSDF plugin 'velvet'"), "{msg}");
    }

    #[test]
    fn nested_textures_are_built_or_located_errors() {
        let mut tex = bsdf("bitmap", &[]);
        tex.class = ObjectClass::Texture;
        tex.loc = loc(7);
        let obj = with_children(bsdf("diffuse", &[]), vec![(Some("reflectance"), tex)]);
        let (line, msg) = err_line(bsdf_from_desc(&obj));
        assert_eq!(line, 7);
        assert!(msg.contains("filename"), "{msg}");

        let mut checker = bsdf("checkerboard", &[("color1", float(0.9))]);
        checker.class = ObjectClass::Texture;
        let obj = with_children(bsdf("diffuse", &[]), vec![(Some("reflectance"), checker)]);
        let Bsdf::Diffuse(d) = bsdf_from_desc(&obj).unwrap() else {
            panic!()
        };
        assert_eq!(
            d.reflectance.eval(glam::Vec2::new(0.1, 0.1)),
            Rgb::splat(0.4)
        );
        assert_eq!(
            d.reflectance.eval(glam::Vec2::new(0.6, 0.1)),
            Rgb::splat(0.9)
        );
    }

    #[test]
    fn mask_and_difftrans_are_built() {
        let ctx = BsdfContext::default();
        let m = with_children(
            bsdf("mask", &[("opacity", float(0.25))]),
            vec![(None, bsdf("diffuse", &[]))],
        );
        let b = bsdf_from_desc(&m).unwrap();
        assert_eq!(b.pass_through(&ctx), Some(Rgb::splat(0.75)));
        let m = with_children(bsdf("mask", &[]), vec![(None, bsdf("diffuse", &[]))]);
        assert_eq!(
            bsdf_from_desc(&m).unwrap().pass_through(&ctx),
            Some(Rgb::splat(0.5))
        );
        let bad = with_children(
            bsdf("mask", &[("opacity", float(1.5))]),
            vec![(None, bsdf("diffuse", &[]))],
        );
        let (line, msg) = err_line(bsdf_from_desc(&bad));
        assert_eq!(line, 2);
        assert!(msg.contains("opacity"), "{msg}");
        let (line, msg) = err_line(bsdf_from_desc(&bsdf("mask", &[])));
        assert_eq!(line, 1);
        assert!(msg.contains("nested"), "{msg}");

        let Bsdf::DiffuseTransmitter(t) = bsdf_from_desc(&bsdf("difftrans", &[])).unwrap() else {
            panic!()
        };
        assert_eq!(t.transmittance.eval(Default::default()), Rgb::splat(0.5));
        let Bsdf::DiffuseTransmitter(t) =
            bsdf_from_desc(&bsdf("difftrans", &[("transmittance", float(0.8))])).unwrap()
        else {
            panic!()
        };
        assert_eq!(t.transmittance.eval(Default::default()), Rgb::splat(0.8));
    }

    #[test]
    fn twosided_wraps_one_or_two_reflection_models() {
        let one = with_children(bsdf("twosided", &[]), vec![(None, bsdf("diffuse", &[]))]);
        let b = bsdf_from_desc(&one).unwrap();
        let ctx = BsdfContext::default();
        let (wi, wo) = (Vec3::new(0.0, 0.6, -0.8), Vec3::new(0.6, 0.0, -0.8));
        assert!(
            (b.eval(&ctx, wi, wo) - Rgb::splat(0.5 * 0.8 / std::f32::consts::PI))
                .abs()
                .max_element()
                < 1e-6
        );

        let two = with_children(
            bsdf("twosided", &[]),
            vec![
                (None, bsdf("diffuse", &[])),
                (None, bsdf("diffuse", &[("reflectance", float(0.25))])),
            ],
        );
        let b = bsdf_from_desc(&two).unwrap();
        assert!((b.eval(&ctx, wi, wo).x - 0.25 * 0.8 / std::f32::consts::PI).abs() < 1e-6);
        assert!((b.eval(&ctx, -wi, -wo).x - 0.5 * 0.8 / std::f32::consts::PI).abs() < 1e-6);

        let mut glass = bsdf("dielectric", &[]);
        glass.loc = loc(9);
        let (line, msg) = err_line(bsdf_from_desc(&with_children(
            bsdf("twosided", &[]),
            vec![(None, glass)],
        )));
        assert_eq!(line, 9);
        assert!(msg.contains("transmissive"), "{msg}");
        let (line, _) = err_line(bsdf_from_desc(&bsdf("twosided", &[])));
        assert_eq!(line, 1);
    }
}
