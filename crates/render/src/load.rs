//! One-call scene loading: parse the XML, then build render objects.

use crate::desc::xml::parse_scene_file;
use crate::error::SceneResult;
use crate::integrator::{Integrator, PathIntegrator};
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

/// The integrator a scene's settings ask for.
pub fn make_integrator(spec: &IntegratorSpec) -> Box<dyn Integrator> {
    match spec {
        IntegratorSpec::Path(s) => Box::new(PathIntegrator { settings: *s }),
    }
}
