//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod bsdf_check;

use focal_render::desc::xml::parse_scene_str;
use focal_render::film::Image;
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::{render, RenderOutput, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::{build_scene, BuildOptions, LoadedScene};
use std::path::{Path, PathBuf};

pub use focal_render::testing::test_data_dir;

/// Path of a reference scene in `tests/data/references/scenes`.
pub fn reference_scene(name: &str) -> PathBuf {
    test_data_dir()
        .join("references/scenes")
        .join(format!("{name}.xml"))
}

/// Settings for a fixed-spp render.
pub fn settings(spp: u32, seed: u64, threads: usize) -> RenderSettings {
    RenderSettings {
        spp,
        time_limit: None,
        seed,
        threads,
        aovs: false,
        sampler: SamplerKind::Independent,
        ..RenderSettings::default()
    }
}

/// Loads a scene file with `-D` parameters.
pub fn load(path: &Path, params: &[(&str, &str)]) -> LoadedScene {
    let params: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    load_scene(path, &params, &BuildOptions::default())
        .unwrap_or_else(|e| panic!("loading {}: {e}", path.display()))
}

/// Builds a scene from XML text (relative paths resolve against `dir`).
pub fn load_str(xml: &str, dir: &Path) -> LoadedScene {
    let desc = parse_scene_str(xml, &dir.join("inline.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders a loaded scene.
pub fn render_loaded(s: &LoadedScene, settings: &RenderSettings) -> RenderOutput {
    let integrator = make_integrator(&s.integrator);
    render(
        &s.scene,
        &s.camera,
        &s.film,
        integrator.as_ref(),
        settings,
        &|_| {},
    )
}

/// Image means of `passes` independently seeded renders: (mean per channel, standard error per channel).
pub fn mean_and_stderr(s: &LoadedScene, spp: u32, passes: u32) -> ([f64; 3], [f64; 3]) {
    let means: Vec<[f64; 3]> = (0..passes)
        .map(|i| {
            render_loaded(s, &settings(spp, 1000 + i as u64, 0))
                .image
                .mean_rgb()
        })
        .collect();
    let n = passes as f64;
    let mut mean = [0.0; 3];
    let mut se = [0.0; 3];
    for c in 0..3 {
        mean[c] = means.iter().map(|m| m[c]).sum::<f64>() / n;
        let var = means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (n - 1.0);
        se[c] = (var / n).sqrt();
    }
    (mean, se)
}

/// Reads the `mean_rgb` and `stderr_rgb` of a Mitsuba 3 reference JSON.
pub fn mitsuba_mean(json_name: &str) -> ([f64; 3], [f64; 3]) {
    let p = test_data_dir().join("references/mitsuba3").join(json_name);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    let get = |k: &str| -> [f64; 3] {
        let a = v[k].as_array().unwrap();
        [
            a[0].as_f64().unwrap(),
            a[1].as_f64().unwrap(),
            a[2].as_f64().unwrap(),
        ]
    };
    (get("mean_rgb"), get("stderr_rgb"))
}

/// True if no pixel of the image is NaN or infinite.
pub fn all_finite(img: &Image) -> bool {
    img.rgb.iter().all(|p| p.iter().all(|c| c.is_finite()))
}

/// A uniform sky of radiance 1.
pub const SKY: &str = r#"<emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#;

/// A camera looking down through a mask of opacity `o` (nested diffuse `top`) hung 1 cm above a diffuse
/// plane (ρ = 0.5), lit by `light`. The mask is 400 × 400 so that the plane sees the sky only through it.
pub fn masked_plane(o: f32, top: f32, light: &str, integrator: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="{integrator}"/>
    <sensor type="perspective">
        <float name="fov" value="20"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="2"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="200"/><translate z="0.01"/></transform>
        <bsdf type="mask">
            <float name="opacity" value="{o}"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="{top}"/></bsdf>
        </bsdf>
    </shape>
    {light}
</scene>"#
    )
}
