//! One-call scene loading: parse the XML, then build render objects.

use crate::desc::xml::parse_scene_file;
use crate::error::SceneResult;
use crate::integrator::{GuidedPathIntegrator, Integrator, PathIntegrator};
use crate::scene::{build_scene, BuildOptions, IntegratorSpec, LoadedScene};
use std::path::Path;

/// Loads a Mitsuba XML scene; `params` are `-D name=value` overrides.
pub fn load_scene(
    path: &Path,
    params: &[(String, String)],
    opts: &BuildOptions,
) -> SceneResult<LoadedScene> {
    let desc = parse_scene_file(path, params)?;
    build_scene(&desc, opts)
}

/// The integrator a scene's settings ask for, for a single-pass render. A guided scene gets its guided
/// path tracer without a guide here (guiding needs the iterations of
/// [`crate::render::guided::render_guided`]).
pub fn make_integrator(spec: &IntegratorSpec) -> Box<dyn Integrator> {
    match spec {
        IntegratorSpec::Path(s) => Box::new(PathIntegrator { settings: *s }),
        IntegratorSpec::Guided(g) => Box::new(GuidedPathIntegrator {
            settings: g.settings,
            guide: None,
        }),
    }
}
