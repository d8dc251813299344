//! MIP-mapped bitmap textures against Mitsuba 3: a checkered plane seen at a grazing angle (scene, texture
//! and Mitsuba 3's converged bilinear render in tests/data/grazing_texture, made by
//! tools/mitsuba3_grazing_texture.py). Every pixel sample reads the texture exactly (a directional light
//! straight above a diffuse plane), so the only noise is aliasing. Converged, focal's bilinear render is
//! Mitsuba 3's; at 4 samples per pixel, trilinear filtering over the first hit's footprint (Mitsuba 0.6)
//! is much closer to the converged image than bilinear lookups, and keeps its mean.

mod common;

use common::*;
use focal_render::film::Image;
use focal_render::geometry::ShapeGeometry;
use glam::Vec2;
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/grazing_texture")
}

fn render(filter: &str, spp: u32, seed: u64) -> Image {
    let spp_text = spp.to_string();
    let scene = load(
        &data_dir().join("scene.xml"),
        &[("filter", filter), ("spp", &spp_text)],
    );
    render_loaded(&scene, &settings(spp, seed, 0)).image
}

fn reference() -> Image {
    Image::read_exr(&data_dir().join("mitsuba3_bilinear_4096spp.exr")).expect("reference EXR")
}

/// Root-mean-square difference of the first channel (the scene is grey) over rows `rows`.
fn rmse_rows(a: &Image, b: &Image, rows: std::ops::Range<usize>) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let w = a.width as usize;
    let range = rows.start * w..rows.end * w;
    let n = range.len() as f64;
    let sum: f64 = a.rgb[range.clone()]
        .iter()
        .zip(&b.rgb[range])
        .map(|(p, q)| (p[0] as f64 - q[0] as f64).powi(2))
        .sum();
    (sum / n).sqrt()
}

fn rmse(a: &Image, b: &Image) -> f64 {
    rmse_rows(a, b, 0..a.height as usize)
}

#[test]
fn converged_bilinear_render_matches_mitsuba3() {
    let ours = render("bilinear", 256, 1);
    let theirs = reference();
    let e = rmse(&ours, &theirs);
    let (m, r) = (ours.mean_rgb()[0], theirs.mean_rgb()[0]);
    eprintln!("bilinear 256 spp: rmse {e:.5}, mean {m:.5} vs Mitsuba 3 {r:.5}");
    assert!(e < 0.02, "rmse {e}");
    assert!((m - r).abs() < 0.003 * r, "mean {m} vs {r}");
}

#[test]
fn trilinear_filtering_removes_most_aliasing_at_few_samples() {
    let theirs = reference();
    let trilinear = render("trilinear", 4, 2);
    let bilinear = render("bilinear", 4, 2);
    let ewa = render("ewa", 4, 2);
    let (et, eb) = (rmse(&trilinear, &theirs), rmse(&bilinear, &theirs));
    // The far half of the plane (from the horizon down to the middle of the plane's rows), where a
    // pixel covers many checker squares and point samples alias.
    let w = theirs.width as usize;
    let horizon = (0..theirs.height as usize)
        .find(|y| theirs.rgb[y * w..(y + 1) * w].iter().any(|p| p[0] > 0.0))
        .expect("the plane is visible");
    let far = horizon..(horizon + theirs.height as usize) / 2;
    let (ft, fb) = (
        rmse_rows(&trilinear, &theirs, far.clone()),
        rmse_rows(&bilinear, &theirs, far.clone()),
    );
    let r = theirs.mean_rgb()[0];
    let mt = trilinear.mean_rgb()[0];
    eprintln!(
        "4 spp against Mitsuba 3 converged: trilinear rmse {et:.5}, bilinear rmse {eb:.5}; far rows \
         {far:?}: trilinear {ft:.5}, bilinear {fb:.5}; trilinear mean {mt:.5} vs {r:.5}"
    );
    // Isotropic filtering blurs the near, anisotropic footprints (Mitsuba 0.6's documented trade-off),
    // so the gain is in the far half.
    assert!(ft < 0.35 * fb, "far rows: trilinear {ft} vs bilinear {fb}");
    assert!(et < 0.8 * eb, "trilinear {et} vs bilinear {eb}");
    assert!((mt - r).abs() < 0.01 * r, "mean {mt} vs {r}");
    // `ewa` is read as trilinear.
    assert_eq!(ewa.rgb, trilinear.rgb);
}

#[test]
fn footprint_of_a_frontal_plane_is_one_pixel_of_uv() {
    // A 2 × 2 rectangle filling a 90° field of view from distance 1: 100 pixels span uv [0, 1].
    let xml = r#"<scene version="3.0.0">
        <sensor type="perspective"><float name="fov" value="90"/>
            <transform name="to_world"><lookat origin="0, 0, 1" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="100"/><integer name="height" value="100"/></film>
        </sensor>
        <shape type="rectangle"/>
    </scene>"#;
    let s = load_str(xml, std::path::Path::new("."));
    assert!(matches!(s.scene.geometries[0], ShapeGeometry::Mesh(_)));
    let cam = s
        .camera
        .generate_ray_differential(Vec2::new(30.5, 60.5), Vec2::ZERO);
    let si = s.scene.intersect(&cam.ray).expect("hits the rectangle");
    let fp = s
        .scene
        .uv_footprint(&si, cam.differential.as_ref().unwrap());
    // One pixel step is 1/100 of uv, along u for x and along v for y (up to sign).
    assert!((fp.duv_dx.length() - 0.01).abs() < 1e-4, "{fp:?}");
    assert!((fp.duv_dy.length() - 0.01).abs() < 1e-4, "{fp:?}");
    assert!(fp.duv_dx.dot(fp.duv_dy).abs() < 1e-8, "{fp:?}");
}
