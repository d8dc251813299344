//! Helpers shared by the integration tests.
#![allow(dead_code)]

use focal_render::desc::xml::parse_scene_str;
use focal_render::film::Image;
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::{render, RenderOutput, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::{build_scene, BuildOptions, LoadedScene};
use std::path::{Path, PathBuf};

pub use focal_render::testing::shared_dir;

/// Path of a reference scene in `shared/references/scenes`.
pub fn reference_scene(name: &str) -> PathBuf {
    shared_dir()
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
    let p = shared_dir().join("references/mitsuba3").join(json_name);
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
