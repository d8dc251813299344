//! Reconstruction filters, image blocks and the film (Mitsuba 3 hdrfilm semantics).

use focal_render::desc::{ChildDesc, ObjectClass, ObjectDesc, PropValue, Property};
use focal_render::error::SourceLoc;
use focal_render::film::{
    film_from_desc, filter_from_desc, AovSample, Film, FilmSpec, ImageBlock, ReconstructionFilter,
};
use focal_render::sampler::Pcg32;
use glam::{IVec2, UVec2, Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

fn loc() -> SourceLoc {
    SourceLoc::file_only(Path::new("test.xml"))
}

fn object(class: ObjectClass, plugin: &str, props: Vec<(&str, PropValue)>) -> ObjectDesc {
    ObjectDesc {
        class,
        plugin: plugin.to_string(),
        id: None,
        props: props
            .into_iter()
            .map(|(name, value)| Property {
                name: name.to_string(),
                value,
                loc: loc(),
            })
            .collect(),
        children: Vec::new(),
        loc: loc(),
    }
}

fn gaussian_formula(x: f64) -> f64 {
    let s = 0.5f64;
    let r = 4.0 * s;
    ((-x * x / (2.0 * s * s)).exp() - (-r * r / (2.0 * s * s)).exp()).max(0.0)
}

#[test]
fn default_filter_is_mitsubas_gaussian() {
    let f = filter_from_desc(None).unwrap();
    assert_eq!(f, ReconstructionFilter::Gaussian { stddev: 0.5 });
    assert_eq!(f.radius(), 2.0);
    assert_eq!(f.border_size(), 2);
    for x in [0.0f32, 0.3, 1.0, 1.7, 2.0, 2.5] {
        assert!((f.eval(x) as f64 - gaussian_formula(x as f64)).abs() < 1e-6);
    }
}

#[test]
fn gaussian_splat_of_a_sample_at_a_pixel_centre_matches_the_formula() {
    let filter = ReconstructionFilter::default();
    let mut block = ImageBlock::new(IVec2::new(8, 8), UVec2::new(4, 4), &filter, false);
    let value = Vec3::new(2.0, 3.0, 4.0);
    assert!(block.put(Vec2::new(10.5, 10.5), value, None));
    for dy in -3i32..=3 {
        for dx in -3i32..=3 {
            let p = IVec2::new(10 + dx, 10 + dy);
            let expected = gaussian_formula(dx as f64) * gaussian_formula(dy as f64);
            let (wl, w) = block.weighted_sum(p).unwrap();
            assert!((w - expected).abs() < 1e-6, "pixel {p}: {w} vs {expected}");
            assert!((wl[1] - 3.0 * expected).abs() < 1e-5);
        }
    }
    // Pixel centres exactly at the radius get weight 0; the border (2 px) holds the whole splat.
    assert_eq!(block.weighted_sum(IVec2::new(12, 10)).unwrap().1, 0.0);
    assert!(block.weighted_sum(IVec2::new(5, 5)).is_none());
}

#[test]
fn box_filter_keeps_a_sample_in_its_own_pixel() {
    let filter = filter_from_desc(Some(&object(ObjectClass::Rfilter, "box", vec![]))).unwrap();
    assert_eq!(filter.border_size(), 0);
    let mut block = ImageBlock::new(IVec2::ZERO, UVec2::new(8, 8), &filter, false);
    block.put(Vec2::new(3.99, 5.01), Vec3::ONE, None);
    block.put(Vec2::new(3.0, 5.999), Vec3::ONE, None);
    for y in 0..8 {
        for x in 0..8 {
            let w = block.weighted_sum(IVec2::new(x, y)).unwrap().1;
            assert_eq!(
                w,
                if (x, y) == (3, 5) { 2.0 } else { 0.0 },
                "pixel ({x}, {y})"
            );
        }
    }
}

/// Splats a constant radiance at random positions over tiles and checks every pixel develops to it.
fn constant_develops_exactly(filter: ReconstructionFilter) {
    let spec = FilmSpec {
        width: 19,
        height: 13,
        crop_offset: UVec2::ZERO,
        crop_size: UVec2::new(19, 13),
        filter,
        ..FilmSpec::default()
    };
    let mut film = Film::new(spec, true);
    let value = Vec3::new(0.3, 1.7, 42.0);
    let aov = AovSample {
        albedo: Vec3::new(0.1, 0.2, 0.3),
        normal: Vec3::Z,
        depth: 5.0,
    };
    let mut rng = Pcg32::new(11, 0);
    for ty in (0..13).step_by(8) {
        for tx in (0..19).step_by(8) {
            let size = UVec2::new((19 - tx).min(8) as u32, (13 - ty).min(8) as u32);
            let mut block = film.create_block(IVec2::new(tx, ty), size);
            for y in 0..size.y {
                for x in 0..size.x {
                    for _ in 0..16 {
                        let pos = Vec2::new(
                            (tx as u32 + x) as f32 + rng.next_f32(),
                            (ty as u32 + y) as f32 + rng.next_f32(),
                        );
                        assert!(block.put(pos, value, Some(&aov)));
                    }
                }
            }
            film.merge_block(&block);
        }
    }
    let image = film.develop();
    assert_eq!((image.width, image.height), (19, 13));
    for p in &image.rgb {
        for c in 0..3 {
            let rel = (p[c] - value[c]).abs() / value[c];
            assert!(rel < 1e-5, "{p:?} vs {value:?}");
        }
    }
    let albedo = image.layer("albedo").unwrap();
    assert_eq!(albedo.channels, ["R", "G", "B"]);
    assert!(albedo.data.chunks(3).all(|c| (c[2] - 0.3).abs() < 1e-5));
    assert!(image
        .layer("normal")
        .unwrap()
        .data
        .chunks(3)
        .all(|c| (c[2] - 1.0).abs() < 1e-5));
    assert!(image
        .layer("depth")
        .unwrap()
        .data
        .iter()
        .all(|d| (d - 5.0).abs() < 1e-4));
}

#[test]
fn constant_radiance_develops_to_that_constant_for_every_filter() {
    constant_develops_exactly(ReconstructionFilter::default());
    constant_develops_exactly(ReconstructionFilter::Box);
    constant_develops_exactly(ReconstructionFilter::Tent { radius: 1.0 });
    constant_develops_exactly(ReconstructionFilter::Mitchell {
        b: 1.0 / 3.0,
        c: 1.0 / 3.0,
    });
    constant_develops_exactly(ReconstructionFilter::Mitchell { b: 0.0, c: 0.5 });
    constant_develops_exactly(ReconstructionFilter::Lanczos { lobes: 3 });
}

#[test]
fn tiled_rendering_equals_one_big_block_and_merging_is_deterministic() {
    let spec = FilmSpec {
        width: 24,
        height: 16,
        crop_size: UVec2::new(24, 16),
        ..FilmSpec::default()
    };
    let samples: Vec<(Vec2, Vec3)> = {
        let mut rng = Pcg32::new(5, 5);
        (0..24 * 16 * 8)
            .map(|_| {
                let p = Vec2::new(rng.next_f32() * 24.0, rng.next_f32() * 16.0);
                (
                    p,
                    Vec3::new(rng.next_f32(), rng.next_f32() * 10.0, rng.next_f32()),
                )
            })
            .collect()
    };
    let render_tiled = || {
        let mut film = Film::new(spec.clone(), false);
        let mut blocks = Vec::new();
        for ty in (0..16).step_by(8) {
            for tx in (0..24).step_by(8) {
                let mut b = film.create_block(IVec2::new(tx, ty), UVec2::splat(8));
                for (p, v) in &samples {
                    let inside = p.x >= tx as f32
                        && p.x < (tx + 8) as f32
                        && p.y >= ty as f32
                        && p.y < (ty + 8) as f32;
                    if inside {
                        b.put(*p, *v, None);
                    }
                }
                blocks.push(b);
            }
        }
        for b in &blocks {
            film.merge_block(b);
        }
        film.develop()
    };
    let mut whole = Film::new(spec.clone(), false);
    let mut big = whole.create_block(IVec2::ZERO, UVec2::new(24, 16));
    for (p, v) in &samples {
        big.put(*p, *v, None);
    }
    whole.merge_block(&big);
    let a = render_tiled();
    let b = render_tiled();
    let c = whole.develop();
    assert_eq!(a, b, "same merge order, same bits");
    for (x, y) in a.rgb.iter().zip(&c.rgb) {
        for k in 0..3 {
            assert!(
                (x[k] - y[k]).abs() <= 1e-5 * y[k].abs().max(1.0),
                "{x:?} vs {y:?}"
            );
        }
    }
}

#[test]
fn non_finite_samples_are_rejected_and_counted() {
    let spec = FilmSpec {
        width: 4,
        height: 4,
        crop_size: UVec2::new(4, 4),
        ..FilmSpec::default()
    };
    let mut film = Film::new(spec, true);
    let mut block = film.create_block(IVec2::ZERO, UVec2::new(4, 4));
    assert!(block.put(Vec2::new(1.5, 1.5), Vec3::ONE, None));
    assert!(!block.put(Vec2::new(1.5, 1.5), Vec3::new(f32::NAN, 0.0, 0.0), None));
    assert!(!block.put(
        Vec2::new(2.5, 1.5),
        Vec3::new(0.0, f32::INFINITY, 0.0),
        None
    ));
    assert!(!block.put(Vec2::new(f32::NAN, 1.5), Vec3::ONE, None));
    let bad_aov = AovSample {
        depth: f32::NAN,
        ..AovSample::default()
    };
    assert!(!block.put(Vec2::new(1.5, 1.5), Vec3::ONE, Some(&bad_aov)));
    assert!(
        block.put(Vec2::new(1e30, -1e30), Vec3::ONE, None),
        "far away: accepted, not written"
    );
    assert_eq!(block.rejected_samples(), 4);
    film.merge_block(&block);
    assert_eq!(film.rejected_samples(), 4);
    let image = film.develop();
    assert!(image.rgb.iter().flatten().all(|v| v.is_finite()));
    let p = image.pixel(1, 1);
    assert!(
        (p[0] - 1.0).abs() < 1e-6 && (p[1] - 1.0).abs() < 1e-6,
        "{p:?}"
    );
    assert_eq!(
        image.pixel(3, 3),
        [0.0; 3],
        "pixels beyond the splat have no weight and develop to 0"
    );
}

#[test]
fn film_parameters_follow_hdrfilm() {
    let d = film_from_desc(None).unwrap();
    assert_eq!((d.width, d.height), (768, 576));
    assert_eq!(d.crop_size, UVec2::new(768, 576));
    assert_eq!(d.filter, ReconstructionFilter::Gaussian { stddev: 0.5 });

    let mut film = object(
        ObjectClass::Film,
        "hdrfilm",
        vec![
            ("width", PropValue::Integer(64)),
            ("height", PropValue::Integer(32)),
            ("crop_offset_x", PropValue::Integer(8)),
            ("crop_width", PropValue::Integer(16)),
            ("pixel_format", PropValue::String("rgba".into())),
        ],
    );
    film.children.push(ChildDesc {
        name: None,
        object: Arc::new(object(
            ObjectClass::Rfilter,
            "tent",
            vec![("radius", PropValue::Float(1.5))],
        )),
    });
    let spec = film_from_desc(Some(&film)).unwrap();
    assert_eq!(spec.size(), UVec2::new(64, 32));
    assert_eq!(spec.crop_offset, UVec2::new(8, 0));
    assert_eq!(spec.crop_size, UVec2::new(16, 32));
    assert_eq!(spec.filter, ReconstructionFilter::Tent { radius: 1.5 });
    let f = Film::new(spec, false);
    assert_eq!((f.width(), f.height()), (16, 32));

    let ldr = object(
        ObjectClass::Film,
        "ldrfilm",
        vec![("width", PropValue::Integer(10))],
    );
    assert_eq!(film_from_desc(Some(&ldr)).unwrap().width, 10);

    let bad = [
        object(ObjectClass::Film, "mfilm", vec![]),
        object(
            ObjectClass::Film,
            "hdrfilm",
            vec![("width", PropValue::Integer(0))],
        ),
        object(
            ObjectClass::Film,
            "hdrfilm",
            vec![
                ("width", PropValue::Integer(10)),
                ("crop_width", PropValue::Integer(11)),
            ],
        ),
        object(
            ObjectClass::Film,
            "hdrfilm",
            vec![("pixel_format", PropValue::String("xyz".into()))],
        ),
        object(
            ObjectClass::Film,
            "hdrfilm",
            vec![("width", PropValue::String("wide".into()))],
        ),
    ];
    for b in &bad {
        assert!(film_from_desc(Some(b)).is_err(), "{b:?} should be rejected");
    }
}

#[test]
fn rfilter_plugins_and_errors() {
    let mk =
        |plugin: &str, props| filter_from_desc(Some(&object(ObjectClass::Rfilter, plugin, props)));
    assert_eq!(
        mk("tent", vec![]).unwrap(),
        ReconstructionFilter::Tent { radius: 1.0 }
    );
    assert_eq!(
        mk("gaussian", vec![("stddev", PropValue::Float(1.0))])
            .unwrap()
            .radius(),
        4.0
    );
    assert_eq!(
        mk("catmullrom", vec![]).unwrap(),
        ReconstructionFilter::Mitchell { b: 0.0, c: 0.5 }
    );
    assert_eq!(mk("lanczos", vec![]).unwrap().radius(), 3.0);
    let m = mk("mitchell", vec![]).unwrap();
    assert_eq!(m.radius(), 2.0);
    // Mitchell–Netravali with B = C = 1/3: w(0) = (6 − 2B)/6 = 8/9, w(2) = 0, and w integrates to 1.
    assert!((m.eval(0.0) - 8.0 / 9.0).abs() < 1e-6);
    assert!(m.eval(2.0).abs() < 1e-6);
    let integral: f32 = (0..4000)
        .map(|i| m.eval(-2.0 + (i as f32 + 0.5) * 1e-3) * 1e-3)
        .sum();
    assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    for f in [
        ReconstructionFilter::default(),
        ReconstructionFilter::Box,
        ReconstructionFilter::Tent { radius: 1.3 },
        m.clone(),
        ReconstructionFilter::Lanczos { lobes: 2 },
    ] {
        let mut row = [0.0f32; 7];
        f.eval_row(-3.2, &mut row);
        for (i, w) in row.iter().enumerate() {
            assert!((w - f.eval(-3.2 + i as f32)).abs() < 1e-6, "{f:?} at {i}");
        }
    }
    assert!(mk("bilinear", vec![]).is_err());
    assert!(mk("gaussian", vec![("stddev", PropValue::Float(-1.0))]).is_err());
    assert!(mk("tent", vec![("radius", PropValue::Float(1e6))]).is_err());
}
