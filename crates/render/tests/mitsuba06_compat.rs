//! Mitsuba 0.6 scenes as other authors write them load in strict mode: the leniencies of Mitsuba 0.6's
//! parser and plugins that focal follows (docs/plugins.md), each with a test.

mod common;

use common::*;
use focal_render::bsdf::fresnel::fresnel_conductor;
use focal_render::bsdf::{Bsdf, BsdfContext};
use focal_render::texture::{BitmapFilter, Texture};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/grazing_texture")
}

/// A Mitsuba 0.6 scene (camelCase names, `<camera>`-era syntax) around `body`.
fn scene06(body: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<scene version="0.6.0">
    <integrator type="path"><integer name="maxDepth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="toWorld"><lookAt origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><spectrum name="radiance" value="1"/></emitter>
    {body}
</scene>"#
    )
}

fn load06(body: &str) -> focal_render::scene::LoadedScene {
    load_str(&scene06(body), &data_dir())
}

fn shape_bsdf(s: &focal_render::scene::LoadedScene, i: usize) -> &Bsdf {
    &s.scene.bsdfs[s.scene.shapes[i].bsdf as usize]
}

#[test]
fn the_three_failures_of_the_issue_load_strictly() {
    let s = load06(
        r#"<shape type="rectangle">
            <bsdf type="diffuse">
                <texture type="bitmap" name="reflectance">
                    <string name="filename" value="checker.png"/>
                    <string name="filterType" value="trilinear"/>
                </texture>
            </bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="conductor"><string name="material" value="None"/></bsdf>
        </shape>
        <shape type="sphere"><point name="center" x="3" y="0" z="0"/>
            <bsdf type="roughconductor">
                <rgb name="eta" value="-0.05, 4.1, 4.7"/>
                <rgb name="k" value="-1.2, 2.5, -3"/>
                <float name="alpha" value="0.2"/>
            </bsdf>
        </shape>"#,
    );
    let Bsdf::Diffuse(d) = shape_bsdf(&s, 0) else {
        panic!("diffuse")
    };
    let Texture::Bitmap(b) = &d.reflectance else {
        panic!("bitmap")
    };
    assert_eq!(b.filter(), BitmapFilter::Trilinear);
    // "None" is the perfect mirror.
    assert!(matches!(shape_bsdf(&s, 1), Bsdf::Conductor(_)));
    let r = shape_bsdf(&s, 1).albedo(&BsdfContext::default());
    assert!((r - Vec3::ONE).abs().max_element() < 1e-6, "{r}");
    // The negative indices are read as their absolute values, with one warning that says so.
    let Bsdf::RoughConductor(rc) = shape_bsdf(&s, 2) else {
        panic!("roughconductor")
    };
    assert_eq!(rc.eta.eval(Vec2::ZERO), Vec3::new(0.05, 4.1, 4.7));
    assert_eq!(rc.k.eval(Vec2::ZERO), Vec3::new(1.2, 2.5, 3.0));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("negative") && s.warnings[0].contains("inline.xml:25:"),
        "{}",
        s.warnings[0]
    );
    let out = render_loaded(&s, &settings(2, 1, 1));
    assert!(all_finite(&out.image));
}

#[test]
fn negative_conductor_indices_keep_the_fresnel_term_in_the_unit_interval() {
    let eta = Vec3::new(-0.05, 4.1, -4.7);
    let k = Vec3::new(-1.2, 0.0, 3.0);
    for i in 0..=100 {
        let cos = i as f32 / 100.0;
        let f = fresnel_conductor(cos, eta, k);
        assert!(
            f.is_finite() && f.min_element() >= 0.0 && f.max_element() <= 1.0,
            "cos {cos}: {f}"
        );
        // What Mitsuba 0.6 computes: the term only depends on the squares.
        let g = fresnel_conductor(cos, eta.abs(), k.abs());
        assert!((f - g).abs().max_element() < 1e-6, "cos {cos}: {f} vs {g}");
    }
}

#[test]
fn conductor_material_names_other_than_none_keep_their_case() {
    let xml = scene06(
        r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="au"/></bsdf></shape>"#,
    );
    let desc = focal_render::desc::xml::parse_scene_str(&xml, Path::new("x.xml"), &[]).unwrap();
    let e = focal_render::scene::build_scene(&desc, &Default::default())
        .err()
        .expect("'au' is not a material name (Au is)");
    assert!(e.message.contains("unknown conductor material 'au'"), "{e}");
    for none in ["none", "NONE", "None"] {
        let s = load06(&format!(
            r#"<shape type="sphere"><bsdf type="roughconductor"><string name="material" value="{none}"/></bsdf></shape>"#
        ));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    }
}

#[test]
fn bitmap_parameters_of_mitsuba06_are_read() {
    let s = load06(
        r#"<shape type="rectangle">
            <bsdf type="diffuse">
                <texture type="bitmap" name="reflectance">
                    <string name="filename" value="checker.png"/>
                    <string name="filterType" value="EWA"/>
                    <float name="maxAnisotropy" value="8"/>
                    <string name="wrapModeU" value="mirror"/>
                    <string name="wrapModeV" value="zero"/>
                    <float name="gamma" value="1"/>
                    <string name="channel" value="R"/>
                    <boolean name="cache" value="false"/>
                    <float name="uscale" value="2"/>
                    <float name="voffset" value="0.5"/>
                </texture>
            </bsdf>
        </shape>
        <shape type="rectangle">
            <bsdf type="diffuse">
                <texture type="bitmap" name="reflectance">
                    <string name="filename" value="checker.png"/>
                    <string name="wrapMode" value="one"/>
                    <float name="gamma" value="-1"/>
                </texture>
            </bsdf>
        </shape>"#,
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let bitmap = |i: usize| {
        let Bsdf::Diffuse(d) = shape_bsdf(&s, i) else {
            panic!("diffuse")
        };
        let Texture::Bitmap(b) = &d.reflectance else {
            panic!("bitmap")
        };
        b.clone()
    };
    let b = bitmap(0);
    assert_eq!(b.filter(), BitmapFilter::Ewa);
    // gamma 1: the stored 8-bit values (0.1 and 0.9, as 26/255 and 230/255) are linear.
    let texel = b.pyramid().finest().texels[0];
    assert!((texel.x - 230.0 / 255.0).abs() < 1e-6, "{texel}");
    // v offset by 0.5 lands outside [0, 1) for v > 0.5: zero there.
    assert_eq!(b.eval(Vec2::new(0.3, 0.7)), Vec3::ZERO);
    // The Mitsuba 0.6 default is ewa (MIP-mapped), the sRGB curve for gamma -1, `one` outside.
    let b = bitmap(1);
    assert_eq!(b.filter(), BitmapFilter::Ewa);
    let texel = b.pyramid().finest().texels[0];
    assert!((texel.x - 0.7913).abs() < 1e-3, "{texel}");
    assert_eq!(b.eval(Vec2::new(1.7, 0.2)), Vec3::ONE);
}

#[test]
fn bitmap_parameter_errors_are_located() {
    for (param, value, needle) in [
        ("filterType", "cubic", "invalid filter_type 'cubic'"),
        ("wrapModeU", "tile", "invalid wrap mode 'tile'"),
        ("channel", "q", "invalid channel 'q'"),
    ] {
        let xml = scene06(&format!(
            r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
                <string name="filename" value="checker.png"/>
                <string name="{param}" value="{value}"/>
            </texture></bsdf></shape>"#
        ));
        let desc =
            focal_render::desc::xml::parse_scene_str(&xml, &data_dir().join("x.xml"), &[]).unwrap();
        let e = focal_render::scene::build_scene(&desc, &Default::default())
            .err()
            .expect("invalid value");
        assert!(e.message.contains(needle), "{e}");
        assert_eq!(e.loc.as_ref().map(|l| l.line), Some(14), "{e}");
    }
}

#[test]
fn mitsuba3_bitmaps_stay_bilinear_by_default() {
    let xml = r#"<scene version="3.0.0">
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
            <integer name="height" value="4"/></film></sensor>
        <shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
            <string name="filename" value="checker.png"/></texture></bsdf></shape>
    </scene>"#;
    let s = load_str(xml, &data_dir());
    let Bsdf::Diffuse(d) = shape_bsdf(&s, 0) else {
        panic!("diffuse")
    };
    let Texture::Bitmap(b) = &d.reflectance else {
        panic!("bitmap")
    };
    assert_eq!(b.filter(), BitmapFilter::Bilinear);
    assert_eq!(b.pyramid().levels().len(), 1);
}

#[test]
fn mitsuba06_roughness_defaults_and_phong_distribution() {
    let s = load06(
        r#"<shape type="sphere">
            <bsdf type="roughconductor">
                <float name="alpha" value="0.3"/>
                <float name="alphaU" value="0.05"/>
                <string name="distribution" value="Phong"/>
                <string name="material" value="Al"/>
            </bsdf>
        </shape>
        <shape type="sphere">
            <bsdf type="roughdielectric"><float name="alphaV" value="0.2"/></bsdf>
        </shape>"#,
    );
    let Bsdf::RoughConductor(c) = shape_bsdf(&s, 0) else {
        panic!()
    };
    assert_eq!(
        (c.distribution.alpha_u, c.distribution.alpha_v),
        (0.05, 0.3)
    );
    let Bsdf::RoughDielectric(d) = shape_bsdf(&s, 1) else {
        panic!()
    };
    assert_eq!((d.distribution.alpha_u, d.distribution.alpha_v), (0.1, 0.2));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("'Phong'"), "{}", s.warnings[0]);
}
