//! Which Mitsuba 0.6 and Mitsuba 3 plugins focal renders, approximates or rejects: the table behind
//! docs/plugins.md. A test (tests/plugin_table.rs) checks the document against this table and the table
//! against the scene builder: every supported plugin loads in strict mode without a warning, every
//! approximated one loads with a warning naming it, every unsupported one is an error naming it.

/// How focal handles a plugin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Rendered as Mitsuba renders it.
    Supported,
    /// Loaded with a documented approximation and a warning.
    Approximated,
    /// A located error naming the plugin (`--lenient` may skip it, see docs/plugins.md).
    Unsupported,
}

impl Support {
    /// The word used in docs/plugins.md.
    pub fn word(self) -> &'static str {
        match self {
            Support::Supported => "supported",
            Support::Approximated => "approximated",
            Support::Unsupported => "error",
        }
    }
}

/// One plugin: its element tag (`bsdf`, `shape`, ...), its `type` and how focal handles it.
#[derive(Clone, Copy, Debug)]
pub struct PluginSupport {
    /// The XML tag of the plugin's class.
    pub class: &'static str,
    /// The `type` attribute.
    pub name: &'static str,
    /// How focal handles it.
    pub support: Support,
}

const fn p(class: &'static str, name: &'static str, support: Support) -> PluginSupport {
    PluginSupport {
        class,
        name,
        support,
    }
}

use Support::{Approximated as A, Supported as S, Unsupported as E};

/// Every plugin of Mitsuba 0.6 and Mitsuba 3 (and focal's own integrators), by class.
pub const PLUGINS: &[PluginSupport] = &[
    // Shapes.
    p("shape", "obj", S),
    p("shape", "ply", S),
    p("shape", "serialized", S),
    p("shape", "rectangle", S),
    p("shape", "cube", S),
    p("shape", "sphere", S),
    p("shape", "disk", S),
    p("shape", "cylinder", S),
    p("shape", "shapegroup", S),
    p("shape", "instance", S),
    p("shape", "hair", E),
    p("shape", "heightfield", E),
    p("shape", "bsplinecurve", E),
    p("shape", "linearcurve", E),
    p("shape", "sdfgrid", E),
    p("shape", "ellipsoids", E),
    p("shape", "ellipsoidsmesh", E),
    p("shape", "merge", E),
    // BSDFs.
    p("bsdf", "diffuse", S),
    p("bsdf", "roughdiffuse", A),
    p("bsdf", "conductor", S),
    p("bsdf", "roughconductor", S),
    p("bsdf", "dielectric", S),
    p("bsdf", "roughdielectric", S),
    p("bsdf", "thindielectric", S),
    p("bsdf", "plastic", S),
    p("bsdf", "roughplastic", S),
    p("bsdf", "twosided", S),
    p("bsdf", "normalmap", S),
    p("bsdf", "blendbsdf", S),
    p("bsdf", "mask", S),
    p("bsdf", "difftrans", S),
    p("bsdf", "null", S),
    p("bsdf", "bumpmap", S),
    p("bsdf", "coating", S),
    p("bsdf", "roughcoating", S),
    p("bsdf", "phong", S),
    p("bsdf", "ward", S),
    p("bsdf", "mixturebsdf", S),
    p("bsdf", "hk", E),
    p("bsdf", "irawan", E),
    p("bsdf", "principled", E),
    p("bsdf", "principledthin", E),
    p("bsdf", "pplastic", E),
    p("bsdf", "measured", E),
    p("bsdf", "measured_polarized", E),
    p("bsdf", "hair", E),
    p("bsdf", "polarizer", E),
    p("bsdf", "retarder", E),
    p("bsdf", "circular", E),
    // Emitters.
    p("emitter", "area", S),
    p("emitter", "point", S),
    p("emitter", "spot", S),
    p("emitter", "directional", S),
    p("emitter", "constant", S),
    p("emitter", "envmap", S),
    p("emitter", "sunsky", E),
    p("emitter", "sun", E),
    p("emitter", "sky", E),
    p("emitter", "timed_sunsky", E),
    p("emitter", "collimated", E),
    p("emitter", "directionalarea", E),
    p("emitter", "projector", E),
    // Sensors.
    p("sensor", "perspective", S),
    p("sensor", "thinlens", S),
    p("sensor", "orthographic", E),
    p("sensor", "telecentric", E),
    p("sensor", "spherical", E),
    p("sensor", "perspective_rdist", E),
    p("sensor", "irradiancemeter", E),
    p("sensor", "radiancemeter", E),
    p("sensor", "fluencemeter", E),
    p("sensor", "distant", E),
    p("sensor", "batch", E),
    // Films.
    p("film", "hdrfilm", S),
    p("film", "ldrfilm", S),
    p("film", "tiledhdrfilm", S),
    p("film", "mfilm", E),
    p("film", "specfilm", E),
    // Reconstruction filters.
    p("rfilter", "box", S),
    p("rfilter", "tent", S),
    p("rfilter", "gaussian", S),
    p("rfilter", "mitchell", S),
    p("rfilter", "catmullrom", S),
    p("rfilter", "lanczos", S),
    // Samplers.
    p("sampler", "independent", S),
    p("sampler", "sobol", S),
    p("sampler", "stratified", A),
    p("sampler", "multijitter", A),
    p("sampler", "orthogonal", A),
    p("sampler", "ldsampler", A),
    p("sampler", "halton", A),
    p("sampler", "hammersley", A),
    // Integrators.
    p("integrator", "path", S),
    p("integrator", "volpath", S),
    p("integrator", "direct", S),
    p("integrator", "guided", S),
    p("integrator", "focal_path", S),
    p("integrator", "guided_path", A),
    p("integrator", "path_guiding_integrator", A),
    p("integrator", "path_sms_ss", A),
    p("integrator", "path_sms_ms", A),
    p("integrator", "volpathmis", E),
    p("integrator", "volpath_simple", E),
    p("integrator", "bdpt", E),
    p("integrator", "pssmlt", E),
    p("integrator", "mlt", E),
    p("integrator", "erpt", E),
    p("integrator", "photonmapper", E),
    p("integrator", "ppm", E),
    p("integrator", "sppm", E),
    p("integrator", "ptracer", E),
    p("integrator", "ao", E),
    p("integrator", "aov", E),
    p("integrator", "depth", E),
    p("integrator", "moment", E),
    p("integrator", "stokes", E),
    p("integrator", "irrcache", E),
    p("integrator", "multichannel", E),
    p("integrator", "field", E),
    p("integrator", "vpl", E),
    p("integrator", "adaptive", E),
    // Textures.
    p("texture", "bitmap", S),
    p("texture", "checkerboard", S),
    p("texture", "gridtexture", E),
    p("texture", "scale", E),
    p("texture", "vertexcolors", E),
    p("texture", "wireframe", E),
    p("texture", "curvature", E),
    p("texture", "mesh_attribute", E),
    p("texture", "volume", E),
    // Participating media, phase functions and volumes.
    p("medium", "homogeneous", E),
    p("medium", "heterogeneous", E),
    p("phase", "isotropic", E),
    p("phase", "hg", E),
    p("phase", "rayleigh", E),
    p("phase", "sggx", E),
    p("phase", "tabphase", E),
    p("phase", "blendphase", E),
    p("phase", "microflake", E),
    p("phase", "mixturephase", E),
    p("volume", "gridvolume", E),
    p("volume", "constvolume", E),
    // Spectrum plugins (Mitsuba 3's `<spectrum type="...">`; inline `<spectrum value>` is supported).
    p("spectrum", "uniform", E),
    p("spectrum", "regular", E),
    p("spectrum", "irregular", E),
    p("spectrum", "blackbody", E),
    p("spectrum", "d65", E),
    p("spectrum", "srgb", E),
    p("spectrum", "rawconstant", E),
];

/// The entry of a plugin, if the table has it.
pub fn lookup(class: &str, name: &str) -> Option<&'static PluginSupport> {
    PLUGINS.iter().find(|p| p.class == class && p.name == name)
}
