//! The options of guided renders (`--guiding`, a guided scene integrator) and the guide files they
//! save and load, which are bound to the scene they were trained on.

use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::guide::{GuideParams, GuidingMethod};
use focal_render::guide_file::{read_guide_file, scene_fingerprint, GuideFile, GuideOrigin};
use focal_render::guiding::GuidingField;
use focal_render::integrator::{GuidedSettings, Roulette};
use focal_render::scene::{GuidedSpec, IntegratorSpec, Scene};
use std::path::{Path, PathBuf};

/// Options of guided renders (`--guiding`, or a scene whose integrator is `guided`/`focal_path`).
#[derive(Args, Debug, Clone)]
pub struct GuidingArgs {
    /// Guided rendering with this guide: none, octree or gmm. Default: the scene's integrator decides.
    #[arg(long, value_name = "METHOD")]
    pub guiding: Option<String>,
    /// Training iterations (time budget: their number, default 15 as Rath et al.; sample budget: the
    /// most doubling iterations, default 16).
    #[arg(long)]
    pub iterations: Option<u32>,
    /// Share of a --time budget spent training (default 0.5).
    #[arg(long)]
    pub train_fraction: Option<f64>,
    /// How the iterations' images are combined: variance (inverse-variance weighting) or last (Rath).
    #[arg(long, default_value = "variance")]
    pub combine: String,
    /// Probability of sampling the guide instead of the BSDF at every guided vertex, for either guide.
    /// Without it the octree uses 0.5 (Rath et al.) and the GMM its own `--gmm selection.guide_fraction=` (0.75)
    /// while training and a fraction learned per region for the final render (between
    /// `--gmm selection.min=` 0.4 and 0.75; `--gmm selection.learn=false` keeps 0.75).
    #[arg(long)]
    pub guide_fraction: Option<f32>,
    /// Russian roulette of guided renders: albedo (default; survival by the product of BSDF albedos),
    /// throughput (Mitsuba's, which undoes guiding's gains) or off (Rath et al.; set a max_depth).
    #[arg(long)]
    pub rr: Option<String>,
    /// Do not train on segments that escaped the scene (Rath et al. drop them).
    #[arg(long)]
    pub no_escaped: bool,
    /// Do not split guided paths whose throughput the sampling mixture inflated beyond the product of
    /// the BSDF albedos (by default such paths are split in renders that do not train).
    #[arg(long)]
    pub no_split: bool,
    /// Never give up guiding. By default a time-budget render compares, after every guided training
    /// iteration, the guided images so far with the unguided first iteration's; from the third check on,
    /// where guiding's relative error times its render time is more than the path tracer's (more than
    /// half of it where the guided vertices' second-moment ratio shows no gain), or more than twice it
    /// at a later check, it renders the rest of the budget unguided (the Cornell box, veach-mis).
    /// Guiding is kept whatever the images say where that ratio is at least 2, and where the comparison
    /// had nothing to go on.
    #[arg(long)]
    pub no_fallback: bool,
    /// Octree relative split threshold (orth.threshold).
    #[arg(long)]
    pub octree_threshold: Option<f64>,
    /// Most Gaussian components per mixture (converging and diverging each).
    #[arg(long)]
    pub gmm_k_max: Option<usize>,
    /// A GMM guide parameter, `name=value` (repeatable; the fields of the guide's config by path, e.g.
    /// `points.max=131072`, `em.iterations=2`, `schedule.decay=0.5`; the earlier flat names still work).
    #[arg(long = "gmm", value_name = "NAME=VALUE")]
    pub gmm_params: Vec<String>,
    /// Write the trained guide to this file after training.
    #[arg(long, value_name = "PATH")]
    pub save_guide: Option<PathBuf>,
    /// Use a guide trained earlier (--save-guide) and skip training. The guide's method comes from the
    /// file (no --guiding needed), and a guide trained on another scene is refused.
    #[arg(long, value_name = "PATH")]
    pub load_guide: Option<PathBuf>,
    /// Use a --load-guide guide even if it was trained on another scene.
    #[arg(long, requires = "load_guide")]
    pub force_guide: bool,
    /// Also write the guide's pdf seen from the camera (OUT.guide.exr and a false-colour OUT.guide.png)
    /// and a picture of its structure, OUT.guide_structure.png: the Gaussian components' 2σ ellipsoids
    /// projected over the render, or the octree leaves' density on a slice through the densest leaf.
    #[arg(long)]
    pub guide_image: bool,
    /// Also write every iteration's image as its two interleaved halves, DIR/iteration_K_a.exr and
    /// _b.exr (K as the sidecar's `iterations[].index`, which gives their spp, time and weight), for
    /// studying how iterations combine.
    #[arg(long, value_name = "DIR")]
    pub save_iterations: Option<PathBuf>,
}

/// The guided render a run asks for: `--guiding` or a loaded guide (`loaded`: its file and method) on
/// the command line, else a guided scene integrator; `None` for a plain render. A loaded guide's method
/// is the render's: a `--guiding` that names another is an error.
pub(crate) fn guided_spec(
    scene: &IntegratorSpec,
    g: &GuidingArgs,
    loaded: Option<(&Path, GuidingMethod)>,
) -> Result<Option<GuidedSpec>> {
    let mut spec = match (scene, g.guiding.is_some() || loaded.is_some()) {
        (IntegratorSpec::Guided(s), _) => (**s).clone(),
        (IntegratorSpec::Path(p), true) => GuidedSpec {
            method: GuidingMethod::Octree,
            settings: GuidedSettings {
                path: *p,
                ..GuidedSettings::default()
            },
            budget_s: None,
            iterations: None,
            training_fraction: None,
            params: GuideParams::default(),
        },
        (IntegratorSpec::Path(_), false) => {
            if g.save_guide.is_some() {
                bail!("--save-guide needs a guided render (--guiding METHOD)");
            }
            return Ok(None);
        }
    };
    if let Some(m) = &g.guiding {
        spec.method = GuidingMethod::parse(m).map_err(|e| anyhow::anyhow!(e))?;
    }
    if let Some((path, method)) = loaded {
        if g.guiding.is_some() && spec.method != method {
            bail!(
                "--guiding {} but {} holds a {} guide (a loaded guide's method comes from its file: \
                 drop --guiding)",
                spec.method.name(),
                path.display(),
                method.name()
            );
        }
        if spec.method != method {
            eprintln!(
                "note: the scene's integrator asks for the {} guide; {} holds a {} guide, which is used",
                spec.method.name(),
                path.display(),
                method.name()
            );
        }
        spec.method = method;
    }
    if let Some(r) = &g.rr {
        spec.settings.roulette = Roulette::parse(r).map_err(anyhow::Error::msg)?;
    }
    if g.no_escaped {
        spec.settings.train_escaped = false;
    }
    if g.no_split {
        spec.settings.split = false;
    }
    if let Some(f) = g.guide_fraction {
        if !(0.0..1.0).contains(&f) {
            bail!("--guide-fraction must lie in [0, 1), got {f}");
        }
        spec.settings.guide_fraction = f;
        spec.settings.learned_selection = false;
    }
    if let Some(t) = g.octree_threshold {
        spec.params.octree.threshold = t;
    }
    if let Some(k) = g.gmm_k_max {
        let em = &mut spec.params.gmm.em;
        em.k_max = k;
        em.k_init = em.k_init.min(k);
        em.k_min = em.k_min.min(k);
    }
    for p in &g.gmm_params {
        spec.params.gmm = gmm_param(&spec.params.gmm, p).context("--gmm")?;
    }
    if let Some(f) = g.train_fraction {
        if !(0.0..=1.0).contains(&f) {
            bail!("--train-fraction must lie in [0, 1], got {f}");
        }
    }
    Ok(Some(spec))
}

/// Reads the guide file `path` for a render of `scene` (the file `scene_path`): refused if it was trained
/// on a scene with other geometry or lights, unless `force`.
pub fn load_guide_for(
    path: &Path,
    scene: &Scene,
    scene_path: &Path,
    force: bool,
) -> Result<GuideFile> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let loaded = read_guide_file(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    match &loaded.origin {
        Some(o) if o.fingerprint != scene_fingerprint(scene) => {
            let what = format!(
                "{} was trained on {}, not on {} (their geometry or lights differ)",
                path.display(),
                o.scene,
                scene_path.display()
            );
            if !force {
                bail!("{what}; --force-guide uses it anyway");
            }
            eprintln!("warning: {what}; used anyway (--force-guide)");
        }
        Some(_) => {}
        None => eprintln!(
            "warning: {} does not record the scene it was trained on (saved by an older focal), \
             so it cannot be checked against {}",
            path.display(),
            scene_path.display()
        ),
    }
    Ok(loaded)
}

/// Writes `guide`, trained on `scene` (the file `scene_path`) with `method`, to the guide file `path`.
pub fn save_guide_for(
    path: &Path,
    guide: &dyn GuidingField,
    method: GuidingMethod,
    scene: &Scene,
    scene_path: &Path,
) -> Result<()> {
    let origin = GuideOrigin {
        scene: scene_path.display().to_string(),
        fingerprint: scene_fingerprint(scene),
        method,
    };
    std::fs::write(
        path,
        focal_render::guide_file::guide_file_bytes(guide, &origin),
    )
    .with_context(|| format!("writing {}", path.display()))
}

/// `config` with the field named in `assignment` (`name=value`) set, through its serde form, so every
/// field of a guide's config can be set from the command line without a flag each.
fn with_param<T>(config: &T, assignment: &str) -> Result<T>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let (name, value) = assignment
        .split_once('=')
        .with_context(|| format!("expected name=value, got `{assignment}`"))?;
    let mut json = serde_json::to_value(config)?;
    // A dotted name walks into nested groups (`em.iterations`).
    let mut fields = json
        .as_object_mut()
        .context("the config is not a set of named fields")?;
    let mut path = name.split('.').peekable();
    let mut prefix = String::new();
    let leaf = loop {
        let part = path.next().unwrap_or_default();
        if path.peek().is_none() {
            break part;
        }
        let known: Vec<String> = fields.keys().map(|k| format!("{prefix}{k}")).collect();
        fields = match fields.get_mut(part).and_then(|v| v.as_object_mut()) {
            Some(group) => group,
            None => bail!(
                "unknown parameter group `{prefix}{part}` (known: {})",
                known.join(", ")
            ),
        };
        prefix = format!("{prefix}{part}.");
    };
    let Some(old) = fields.get(leaf) else {
        let names: Vec<String> = fields.keys().map(|k| format!("{prefix}{k}")).collect();
        bail!("unknown parameter `{name}` (known: {})", names.join(", "));
    };
    let parsed: serde_json::Value = serde_json::from_str(value)
        .or_else(|_| serde_json::from_str(&format!("\"{value}\"")))
        .with_context(|| format!("bad value `{value}` for `{name}`"))?;
    // An optional value (null by default) takes a number or null.
    if !old.is_null() && std::mem::discriminant(old) != std::mem::discriminant(&parsed) {
        bail!("`{name}` takes a value like {old}, got `{value}`");
    }
    fields.insert(leaf.to_string(), parsed);
    serde_json::from_value(json).with_context(|| format!("bad value `{value}` for `{name}`"))
}

/// A GMM guide parameter `name=value`: the config's field path (`em.iterations=2`), or an earlier
/// flat name (`em_iterations=2`); a removed experiment's parameter is refused with the reason.
fn gmm_param(
    config: &focal_render::guiding::GmmConfig,
    assignment: &str,
) -> Result<focal_render::guiding::GmmConfig> {
    use focal_render::guiding::GmmConfig;
    let (name, value) = assignment
        .split_once('=')
        .with_context(|| format!("expected name=value, got `{assignment}`"))?;
    if let Some(why) = GmmConfig::removed(name) {
        bail!("{why}");
    }
    let name = GmmConfig::renamed(name).unwrap_or(name);
    with_param(config, &format!("{name}={value}"))
}
