//! EXR/PNG input and output, and image statistics, including reading Mitsuba 3 reference renders.

use focal_render::film::{Image, ImageLayer};
use focal_render::testing::test_data_dir;
use std::path::{Path, PathBuf};

fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("focal-image-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn test_image() -> Image {
    let (w, h) = (7u32, 5u32);
    let mut img = Image::new(w, h);
    for (i, p) in img.rgb.iter_mut().enumerate() {
        *p = [
            i as f32 * 0.125,
            1.0 / (i as f32 + 1.0),
            -0.5 + i as f32 * 1e-3,
        ];
    }
    let mut albedo = ImageLayer::new("albedo", &["R", "G", "B"], w, h);
    let mut normal = ImageLayer::new("normal", &["X", "Y", "Z"], w, h);
    let mut depth = ImageLayer::new("depth", &["Z"], w, h);
    for (i, v) in albedo.data.iter_mut().enumerate() {
        *v = i as f32 / 100.0;
    }
    for (i, v) in normal.data.iter_mut().enumerate() {
        *v = (i as f32).sin();
    }
    for (i, v) in depth.data.iter_mut().enumerate() {
        *v = 1e3 + i as f32;
    }
    img.layers = vec![albedo, normal, depth];
    img
}

#[test]
fn exr_round_trip_keeps_rgb_and_layers_exactly() {
    let img = test_image();
    let path = temp_path("roundtrip.exr");
    img.write_exr(&path).unwrap();
    let mut back = Image::read_exr(&path).unwrap();
    // EXR stores channels alphabetically, so layers come back sorted by name.
    let mut img = img;
    img.layers.sort_by(|a, b| a.name.cmp(&b.name));
    back.layers.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(back, img);
    std::fs::remove_file(&path).ok();
}

#[test]
fn reading_a_missing_or_broken_exr_is_an_error() {
    assert!(Image::read_exr(Path::new("/nonexistent/focal.exr")).is_err());
    let path = temp_path("broken.exr");
    std::fs::write(&path, b"not an exr").unwrap();
    assert!(Image::read_exr(&path).is_err());
}

#[test]
fn mitsuba_reference_exr_reads_with_the_recorded_mean() {
    let dir = test_data_dir().join("references/mitsuba3");
    let img = Image::read_exr(&dir.join("cbox_llvm_256px_1024spp.exr")).unwrap();
    assert_eq!((img.width, img.height), (256, 256));
    assert!(img.layers.is_empty());
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("cbox_llvm_256px_1024spp.json")).unwrap(),
    )
    .unwrap();
    let expected: Vec<f64> = json["mean_rgb"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let mean = img.mean_rgb();
    for c in 0..3 {
        let rel = (mean[c] - expected[c]).abs() / expected[c];
        assert!(rel < 1e-3, "channel {c}: {} vs {}", mean[c], expected[c]);
    }
    // Orientation and channel order: the ceiling light is near the top (row ≈ 37 of 256 for this
    // camera), the red wall on the left, the green wall on the right.
    let light = img.pixel(128, 37);
    assert!(
        light.iter().all(|v| *v > 1.0),
        "light expected near the top, got {light:?}"
    );
    assert!(img.pixel(128, 256 - 37)[0] < 1.0);
    let left = img.pixel(12, 128);
    let right = img.pixel(243, 128);
    assert!(
        left[0] > 2.0 * left[1] && left[0] > 2.0 * left[2],
        "red wall on the left: {left:?}"
    );
    assert!(
        right[1] > 1.5 * right[0] && right[1] > 1.5 * right[2],
        "green wall on the right: {right:?}"
    );
}

#[test]
fn png_is_exposed_clamped_and_srgb_encoded() {
    let mut img = Image::new(3, 1);
    img.rgb = vec![
        [0.5, 0.25, 0.0],
        [2.0, -1.0, f32::NAN],
        [0.0031308, 1.0, 0.214],
    ];
    let bytes = img.to_srgb8(0.0);
    assert_eq!(&bytes[..3], &[188, 137, 0]);
    assert_eq!(&bytes[3..6], &[255, 0, 0]);
    assert_eq!(bytes[6], 10);
    assert_eq!(bytes[7], 255);
    assert_eq!(img.to_srgb8(1.0)[1], 188, "exposure +1 doubles 0.25 to 0.5");
    let path = temp_path("tonemapped.png");
    img.write_png(&path, 0.0).unwrap();
    let decoded = image::open(&path).unwrap().to_rgb8();
    assert_eq!(decoded.dimensions(), (3, 1));
    assert_eq!(decoded.into_raw(), bytes);
}

#[test]
fn statistics_and_arithmetic() {
    let mut a = Image::new(2, 2);
    a.rgb = vec![
        [1.0, 2.0, 3.0],
        [3.0, 2.0, 1.0],
        [f32::NAN, 0.0, 0.0],
        [0.0, f32::INFINITY, 0.0],
    ];
    let st = a.stats();
    assert_eq!(st.non_finite, 2);
    assert_eq!((st.min_rgb, st.max_rgb), ([0.0, 0.0, 0.0], [3.0, 2.0, 3.0]));
    assert_eq!(a.sanitize(), 2);
    assert!(a.rgb.iter().flatten().all(|v| v.is_finite()));
    assert_eq!(a.mean_rgb(), [1.0, 1.0, 1.0]);
    let json = serde_json::to_value(a.stats()).unwrap();
    assert!((json["mean_luminance"].as_f64().unwrap() - 1.0).abs() < 1e-6);
    assert_eq!(json["non_finite"], 0);

    let b = test_image();
    let mut c = b.clone();
    c.add_scaled(&b, -1.0);
    assert!(c.rgb.iter().flatten().all(|v| *v == 0.0));
    assert!(c.layers.iter().flat_map(|l| &l.data).all(|v| *v == 0.0));
    let mut d = b.clone();
    d.scale(3.0);
    let mean = Image::mean(&[b.clone(), d.clone()]).unwrap();
    for (m, x) in mean.rgb.iter().zip(&b.rgb) {
        for k in 0..3 {
            assert!((m[k] - 2.0 * x[k]).abs() <= 1e-5 * x[k].abs().max(1.0));
        }
    }
    assert!(Image::mean(&[]).is_none());
}

#[test]
fn every_mitsuba_reference_matches_its_recorded_mean() {
    let dir = test_data_dir().join("references/mitsuba3");
    for name in [
        "cbox_llvm_256px_1024spp",
        "caustic_llvm_256px_4096spp",
        "obscura_llvm_128px_16384spp",
    ] {
        let img = Image::read_exr(&dir.join(format!("{name}.exr"))).unwrap();
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("{name}.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(img.width as u64, json["width"].as_u64().unwrap(), "{name}");
        assert_eq!(
            img.height as u64,
            json["height"].as_u64().unwrap(),
            "{name}"
        );
        let mean = img.mean_rgb();
        for c in 0..3 {
            let expected = json["mean_rgb"][c].as_f64().unwrap();
            assert!(
                (mean[c] - expected).abs() / expected < 1e-3,
                "{name} channel {c}: {} vs {expected}",
                mean[c]
            );
        }
    }
}

#[test]
fn half_float_exr_with_luminance_and_prefixed_channels_is_read() {
    use exr::prelude::{
        f16, AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec,
        WritableImage,
    };
    let (w, h) = (4usize, 3usize);
    let y: Vec<f16> = (0..w * h).map(|i| f16::from_f32(i as f32 * 0.5)).collect();
    let z: Vec<f16> = (0..w * h).map(|i| f16::from_f32(10.0 + i as f32)).collect();
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        AnyChannel::new("Y", FlatSamples::F16(y)),
        AnyChannel::new("depth.Z", FlatSamples::F16(z)),
    ]));
    let path = temp_path("half.exr");
    exr::prelude::Image::from_layer(Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        channels,
    ))
    .write()
    .to_file(&path)
    .unwrap();
    let img = Image::read_exr(&path).unwrap();
    assert_eq!((img.width, img.height), (4, 3));
    assert_eq!(
        img.pixel(1, 2),
        [4.5; 3],
        "Y is replicated to grey, row-major from the top"
    );
    let depth = img.layer("depth").unwrap();
    assert_eq!(depth.channels, ["Z"]);
    assert_eq!(depth.data[5], 15.0);
}
