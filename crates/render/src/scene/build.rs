//! Turns the neutral scene description into render objects (as pbrt-v4 and Mitsuba do): shapes with their
//! materials and area lights, other lights, the camera, film, sampler and integrator settings.

use super::sampler_spec::sampler_from_desc;
pub use super::sampler_spec::SamplerSpec;
use super::{Scene, ShapeInfo};
use crate::accel::{Accel, BvhAccel};
use crate::bsdf::{build_bsdf, Bsdf, Diffuse};
use crate::camera::{camera_from_desc, Camera};
use crate::desc::{ObjectClass, ObjectDesc, SceneDesc};
use crate::emitter::{Emitter, SpotLight};
use crate::error::{SceneError, SceneResult};
use crate::film::{film_from_desc, FilmSpec};
use crate::geometry::{
    cube_mesh, rectangle_mesh, Cylinder, Disk, ShapeGeometry, Sphere, TriangleMesh,
};
use crate::guide::{GuideParams, GuidingMethod};
use crate::integrator::{GuidedSettings, PathSettings, Roulette};
use crate::mesh::{load_obj, load_ply, load_serialized, MeshData};
use crate::texture::Texture;
use glam::{Affine3A, Mat4, Vec3};
use std::collections::HashMap;
use std::sync::Arc;

/// Which integrator the scene asks for (after mapping Mitsuba plugin names onto ours).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub enum IntegratorSpec {
    /// Unidirectional path tracing (`path`; also `volpath` in scenes without media, and `direct` as a
    /// path tracer limited to direct lighting, max_depth 2).
    Path(PathSettings),
    /// Guided path tracing with a learned guide (`guided`, or Rath et al.'s `focal_path`).
    Guided(Box<GuidedSpec>),
}

/// A guided integrator element's settings; the command line may override each.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct GuidedSpec {
    /// Which guide is learned.
    pub method: GuidingMethod,
    /// Integrator settings (depth, Russian roulette, guide fraction).
    pub settings: GuidedSettings,
    /// Total time budget in seconds (`budget`), if the element sets one.
    pub budget_s: Option<f64>,
    /// Number of training iterations (`iteration_count`/`iterationCount`), if set.
    pub iterations: Option<u32>,
    /// Share of the time budget spent training (`training_fraction`, or Rath's
    /// `iterationCount × iterationBudget / budget`), if set.
    pub training_fraction: Option<f64>,
    /// Guide parameters (`orth.threshold`, `orth.decay`, `orth.min_depth`, `orth.max_depth`).
    pub params: GuideParams,
}

/// How to handle plugins we do not support.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Strictness {
    /// An unknown plugin is an error (default).
    #[default]
    Strict,
    /// An unknown plugin is a warning and gets a documented fallback: unknown BSDFs become grey diffuse
    /// (0.5), unknown shapes and emitters are skipped, an unknown integrator becomes `path`.
    Lenient,
}

/// Integrator plugins of other renderers' research code that corpus scenes name (Müller et al.'s
/// `guided_path` in Mitsuba 0.6, a Mitsuba 3 `path_guiding_integrator`, Zeltner et al.'s specular
/// manifold sampling `path_sms_ss`/`path_sms_ms`). They estimate the same image as a path tracer, so they
/// are rendered with the unbiased path tracer and their `max_depth`/`rr_depth` (a documented mapping
/// with a warning, not an error); their other parameters are ignored.
pub const FOREIGN_GUIDING_INTEGRATORS: &[&str] = &[
    "guided_path",
    "path_guiding_integrator",
    "path_sms_ss",
    "path_sms_ms",
];

/// Options for building a scene.
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Replace the scene's integrator element by this plugin name (e.g. "path").
    pub integrator_override: Option<String>,
    /// Unknown-plugin handling.
    pub strictness: Strictness,
    /// Replace the film's size: width, and height (`None`: the film's aspect ratio). The camera is
    /// built for the new size, and a crop window scales with the film.
    pub film_size: Option<(u32, Option<u32>)>,
}

/// A scene with everything needed to render it.
pub struct LoadedScene {
    /// Geometry, materials, lights.
    pub scene: Scene,
    /// The camera.
    pub camera: Camera,
    /// Film settings.
    pub film: FilmSpec,
    /// Sampler settings.
    pub sampler: SamplerSpec,
    /// Integrator settings.
    pub integrator: IntegratorSpec,
    /// Non-fatal problems (unsupported parameters ignored, lenient fallbacks used).
    pub warnings: Vec<String>,
}

struct Builder<'a> {
    opts: &'a BuildOptions,
    geometries: Vec<ShapeGeometry>,
    shapes: Vec<ShapeInfo>,
    bsdfs: Vec<Bsdf>,
    bsdf_index: HashMap<*const ObjectDesc, u32>,
    emitters: Vec<Emitter>,
    emitter_weights: Vec<f32>,
    warnings: Vec<String>,
    /// The scene file is Mitsuba 0.x (for warnings about defaults that changed in Mitsuba 3).
    legacy: bool,
}

/// The first `conductor`/`roughconductor` in a BSDF tree that names neither a `material` nor `eta`/`k`:
/// Mitsuba 0.6 made it copper, Mitsuba 3 a mirror.
fn conductor_without_material(o: &ObjectDesc) -> Option<&ObjectDesc> {
    if matches!(o.plugin.as_str(), "conductor" | "roughconductor")
        && ["material", "eta", "k"].iter().all(|n| o.prop(n).is_none())
    {
        return Some(o);
    }
    o.children_of(&ObjectClass::Bsdf)
        .find_map(|c| conductor_without_material(&c.object))
}

/// Builds a scene from its description.
pub fn build_scene(desc: &SceneDesc, opts: &BuildOptions) -> SceneResult<LoadedScene> {
    let mut b = Builder {
        opts,
        geometries: Vec::new(),
        shapes: Vec::new(),
        bsdfs: Vec::new(),
        bsdf_index: HashMap::new(),
        emitters: Vec::new(),
        emitter_weights: Vec::new(),
        warnings: Vec::new(),
        legacy: desc.version < (2, 0, 0),
    };
    let root = &desc.root;
    let mut sensor: Option<&ObjectDesc> = None;
    let mut integrator: Option<&ObjectDesc> = None;
    for child in &root.children {
        let o = child.object.as_ref();
        match &o.class {
            ObjectClass::Shape => b.add_shape(o)?,
            ObjectClass::Emitter => b.add_emitter(o, None)?,
            ObjectClass::Sensor => {
                if sensor.is_none() {
                    sensor = Some(o);
                } else {
                    b.warnings.push(format!(
                        "{}: extra sensor ignored (the first one is used)",
                        o.loc
                    ));
                }
            }
            ObjectClass::Integrator => integrator = Some(o),
            // Declarations referenced by id elsewhere.
            ObjectClass::Bsdf | ObjectClass::Texture => {}
            ObjectClass::Medium | ObjectClass::Phase => {
                return Err(o.error(format!(
                    "participating media ('{}' {}) are not supported yet",
                    o.plugin,
                    o.class.tag()
                )))
            }
            other => b.unknown(o, &format!("top-level <{}> element", other.tag()))?,
        }
    }
    let sensor =
        sensor.ok_or_else(|| SceneError::in_file(&desc.path, "the scene has no <sensor>"))?;
    let film_desc = sensor
        .children_of(&ObjectClass::Film)
        .next()
        .map(|c| c.object.as_ref());
    let mut film = film_from_desc(film_desc)?;
    if let Some((w, h)) = opts.film_size {
        film = film
            .resized(w, h)
            .map_err(|e| SceneError::in_file(&desc.path, e))?;
    }
    let camera = camera_from_desc(sensor, glam::UVec2::new(film.width, film.height))?;
    let sampler = sampler_from_desc(
        sensor
            .children_of(&ObjectClass::Sampler)
            .next()
            .map(|c| c.object.as_ref()),
        &mut b.warnings,
    )?;
    let integrator = b.integrator_from_desc(integrator, &desc.path)?;

    let Builder {
        geometries,
        shapes,
        bsdfs,
        emitters,
        emitter_weights,
        warnings,
        ..
    } = b;
    let scene = Scene::new(
        geometries,
        shapes,
        bsdfs,
        emitters,
        &emitter_weights,
        &[camera.position()],
        |g| Box::new(BvhAccel::build(g)) as Box<dyn Accel>,
    );
    Ok(LoadedScene {
        scene,
        camera,
        film,
        sampler,
        integrator,
        warnings,
    })
}

impl Builder<'_> {
    fn unknown(&mut self, o: &ObjectDesc, what: &str) -> SceneResult<()> {
        let msg = format!("unsupported {what}: plugin '{}'", o.plugin);
        match self.opts.strictness {
            Strictness::Strict => Err(o.error(msg)),
            Strictness::Lenient => {
                self.warnings.push(format!("{}: {msg} (skipped)", o.loc));
                Ok(())
            }
        }
    }

    fn integrator_from_desc(
        &mut self,
        i: Option<&ObjectDesc>,
        scene_path: &std::path::Path,
    ) -> SceneResult<IntegratorSpec> {
        let name = match (&self.opts.integrator_override, i) {
            (Some(n), _) => n.clone(),
            (None, Some(i)) => i.plugin.clone(),
            (None, None) => "path".to_string(),
        };
        let read = |i: Option<&ObjectDesc>, default_depth: i64| -> SceneResult<PathSettings> {
            let mut s = PathSettings::default();
            let Some(i) = i else { return Ok(s) };
            let md = i.int_or("max_depth", default_depth)?;
            s.max_depth = match md {
                -1 => u32::MAX,
                d if d >= 0 => d.min(u32::MAX as i64) as u32,
                d => {
                    return Err(
                        i.error(format!("max_depth must be -1 (unlimited) or >= 0, got {d}"))
                    )
                }
            };
            let rr = i.int_or("rr_depth", 5)?;
            if rr <= 0 {
                return Err(i.error(format!("rr_depth must be > 0, got {rr}")));
            }
            s.rr_depth = rr as u32;
            s.hide_emitters = i.bool_or("hide_emitters", false)?;
            Ok(s)
        };
        // Settings are read from the scene's element when it is a path-family integrator.
        let source = i.filter(|i| {
            matches!(
                i.plugin.as_str(),
                "path" | "volpath" | "direct" | "guided" | "focal_path"
            ) || FOREIGN_GUIDING_INTEGRATORS.contains(&i.plugin.as_str())
        });
        match name.as_str() {
            "guided" | "focal_path" => {
                let path = read(source, -1)?;
                let mut spec = GuidedSpec {
                    method: GuidingMethod::Octree,
                    settings: GuidedSettings {
                        path,
                        ..GuidedSettings::default()
                    },
                    budget_s: None,
                    iterations: None,
                    training_fraction: None,
                    params: GuideParams::default(),
                };
                if let Some(i) = source {
                    let method = i.string_or("method", "octree")?;
                    spec.method = GuidingMethod::parse(&method).map_err(|e| i.error(e))?;
                    // Rath's focal_path has no roulette; our `guided` uses the albedo roulette.
                    let default_rr = if i.plugin == "focal_path" {
                        "off"
                    } else {
                        "albedo"
                    };
                    spec.settings.roulette = Roulette::parse(&i.string_or("roulette", default_rr)?)
                        .map_err(|e| i.error(e))?;
                    // A fraction given in the scene is used everywhere; otherwise a guide that
                    // learns one (the GMM's selection grid) chooses per region.
                    if let Some(fraction) = i.float_opt("guide_fraction")? {
                        if !(0.0..1.0).contains(&fraction) {
                            return Err(i.error(format!(
                                "guide_fraction must lie in [0, 1), got {fraction}"
                            )));
                        }
                        spec.settings.guide_fraction = fraction as f32;
                        spec.settings.learned_selection = false;
                    }
                    spec.budget_s = i.float_opt("budget")?;
                    if let Some(b) = spec.budget_s {
                        if !(b > 0.0) {
                            return Err(i.error(format!("budget must be positive, got {b}")));
                        }
                    }
                    let count = i.int_or("iteration_count", -1)?;
                    if count >= 0 {
                        spec.iterations = Some(count as u32);
                    }
                    spec.training_fraction = i.float_opt("training_fraction")?;
                    if let (Some(per), Some(b), Some(n)) = (
                        i.float_opt("iteration_budget")?,
                        spec.budget_s,
                        spec.iterations,
                    ) {
                        spec.training_fraction = Some((per * n as f64 / b).clamp(0.0, 1.0));
                    }
                    let o = &mut spec.params.octree;
                    o.threshold = i.float_or("orth.threshold", o.threshold)?;
                    o.schedule.decay = i.float_or("orth.decay", o.schedule.decay)?;
                    o.min_depth = i.int_or("orth.min_depth", o.min_depth as i64)?.max(0) as u32;
                    o.max_depth = i.int_or("orth.max_depth", o.max_depth as i64)?.max(0) as u32;
                }
                Ok(IntegratorSpec::Guided(Box::new(spec)))
            }
            "path" | "volpath" => Ok(IntegratorSpec::Path(read(source, -1)?)),
            foreign if FOREIGN_GUIDING_INTEGRATORS.contains(&foreign) => {
                let s = read(source, -1)?;
                let depth = if s.max_depth == u32::MAX {
                    "unlimited".to_string()
                } else {
                    s.max_depth.to_string()
                };
                let at = i.map_or_else(|| scene_path.display().to_string(), |i| i.loc.to_string());
                self.warnings.push(format!(
                    "{at}: integrator '{foreign}' is another renderer's research plugin; rendering it \
                     with focal's unbiased path tracer 'path' (max_depth {depth}, rr_depth {}), its other \
                     parameters ignored (use --guiding octree|gmm for focal guiding)",
                    s.rr_depth
                ));
                Ok(IntegratorSpec::Path(s))
            }
            "direct" => {
                let mut s = read(None, -1)?;
                s.max_depth = 2;
                if let Some(i) = i {
                    s.hide_emitters = i.bool_or("hide_emitters", false)?;
                }
                Ok(IntegratorSpec::Path(s))
            }
            other => {
                let msg = format!(
                    "unsupported integrator plugin '{other}' (use --integrator path to override the scene's integrator)"
                );
                match (self.opts.strictness, i) {
                    (Strictness::Lenient, _) => {
                        self.warnings.push(format!("{msg}; rendering with 'path'"));
                        Ok(IntegratorSpec::Path(read(source, -1)?))
                    }
                    (Strictness::Strict, Some(i)) => Err(i.error(msg)),
                    (Strictness::Strict, None) => Err(SceneError::in_file(scene_path, msg)),
                }
            }
        }
    }

    fn bsdf_for(&mut self, o: &Arc<ObjectDesc>) -> SceneResult<u32> {
        let key = Arc::as_ptr(o);
        if let Some(&i) = self.bsdf_index.get(&key) {
            return Ok(i);
        }
        let bsdf = match build_bsdf(o, &mut self.warnings) {
            Ok(b) => b,
            Err(e)
                if self.opts.strictness == Strictness::Lenient
                    && e.message.contains("unknown BSDF plugin") =>
            {
                self.warnings.push(format!("{e} (using grey diffuse 0.5)"));
                Bsdf::Diffuse(Diffuse {
                    reflectance: Texture::constant(0.5),
                })
            }
            Err(e) => return Err(e),
        };
        if self.legacy {
            if let Some(c) = conductor_without_material(o) {
                self.warnings.push(format!(
                    "{}: '{}' without 'material' or 'eta'/'k' is a perfect mirror as in Mitsuba 3 \
                     (Mitsuba 0.6 used copper: add <string name=\"material\" value=\"Cu\"/> for its look)",
                    c.loc, c.plugin
                ));
            }
        }
        let i = self.bsdfs.len() as u32;
        self.bsdfs.push(bsdf);
        self.bsdf_index.insert(key, i);
        Ok(i)
    }

    fn add_shape(&mut self, o: &ObjectDesc) -> SceneResult<()> {
        self.add_shape_under(o, &Mat4::IDENTITY)
    }

    /// `shapegroup` + `instance`: the group's shapes are copied into the scene, each moved by the
    /// instance's `to_world` (instancing is flattened at build time: simple, at the cost of memory).
    fn add_instance(&mut self, o: &ObjectDesc, parent: &Mat4) -> SceneResult<()> {
        let to_world = *parent * o.transform_or_identity("to_world")?;
        let mut groups = o
            .children_of(&ObjectClass::Shape)
            .filter(|c| c.object.plugin == "shapegroup");
        let (Some(group), None) = (groups.next(), groups.next()) else {
            return Err(o.error("an 'instance' needs exactly one <ref> to a 'shapegroup'"));
        };
        for child in group.object.children_of(&ObjectClass::Shape) {
            let c = child.object.as_ref();
            if c.children_of(&ObjectClass::Emitter).next().is_some() {
                return Err(
                    c.error("shapes in a 'shapegroup' cannot carry emitters (as in Mitsuba)")
                );
            }
            match c.plugin.as_str() {
                "shapegroup" => {
                    return Err(c.error("a 'shapegroup' cannot contain another shapegroup"))
                }
                "instance" => return Err(c.error("a 'shapegroup' cannot contain instances")),
                _ => self.add_shape_under(c, &to_world)?,
            }
        }
        Ok(())
    }

    fn add_shape_under(&mut self, o: &ObjectDesc, parent: &Mat4) -> SceneResult<()> {
        let to_world = *parent * o.transform_or_identity("to_world")?;
        let flip = o.bool_or("flip_normals", false)?;
        let geometry = match o.plugin.as_str() {
            "obj" | "ply" => {
                let (path, loc) = o
                    .resolve_path("filename")?
                    .ok_or_else(|| o.error(format!("shape '{}' needs a 'filename'", o.plugin)))?;
                let mut data = if o.plugin == "obj" {
                    load_obj(&path, &loc, o.bool_or("flip_tex_coords", true)?)?
                } else {
                    load_ply(&path, &loc)?
                };
                data.validate(&path)?;
                if o.bool_or("face_normals", false)? {
                    data.normals = None;
                } else if data.normals.is_none() {
                    data.normals = Some(data.compute_vertex_normals());
                }
                data.transform(&to_world);
                ShapeGeometry::Mesh(mesh_from_data(data, flip))
            }
            "serialized" => {
                let (path, loc) = o
                    .resolve_path("filename")?
                    .ok_or_else(|| o.error("shape 'serialized' needs a 'filename'"))?;
                let m = load_serialized(&path, &loc, o.int_or("shape_index", 0)?)?;
                let mut data = m.data;
                if m.face_normals || o.bool_or("face_normals", false)? {
                    data.normals = None;
                } else if data.normals.is_none() {
                    data.normals = Some(data.compute_vertex_normals());
                }
                data.transform(&to_world);
                ShapeGeometry::Mesh(mesh_from_data(data, flip))
            }
            "rectangle" | "cube" => {
                // Flat faces: the shading normal is the face normal (as Mitsuba's analytic rectangle), so the
                // per-vertex normals are not kept.
                let (p, _face_normals, uv, idx) = if o.plugin == "rectangle" {
                    rectangle_mesh()
                } else {
                    cube_mesh()
                };
                let mut data = MeshData {
                    positions: p,
                    normals: None,
                    uvs: Some(uv),
                    indices: idx,
                };
                data.transform(&to_world);
                ShapeGeometry::Mesh(mesh_from_data(data, flip))
            }
            "sphere" => {
                let center = o.vec3_or("center", Vec3::ZERO)?;
                let radius = o.float_or("radius", 1.0)? as f32;
                let (scale, uniform) = uniform_scale(&to_world);
                if !uniform {
                    return Err(o.error("a sphere's to_world must not scale non-uniformly"));
                }
                let radius = radius * scale;
                if !(radius > 0.0) || !radius.is_finite() {
                    return Err(o.error(format!("sphere radius must be positive, got {radius}")));
                }
                ShapeGeometry::Sphere(Sphere {
                    center: to_world.transform_point3(center),
                    radius,
                    flip_normals: flip,
                })
            }
            "disk" => {
                let d = Disk::new(Affine3A::from_mat4(to_world), flip)
                    .ok_or_else(|| o.error("degenerate disk transform (zero area)"))?;
                ShapeGeometry::Disk(d)
            }
            // A group is only a declaration; its shapes appear through instances.
            "shapegroup" => return Ok(()),
            "instance" => return self.add_instance(o, parent),
            "cylinder" => {
                // Mitsuba: the unit tube along +Z from p0 to p1 with the given radius, then to_world.
                let p0 = o.vec3_or("p0", Vec3::ZERO)?;
                let p1 = o.vec3_or("p1", Vec3::Z)?;
                let radius = o.float_or("radius", 1.0)? as f32;
                let axis = p1 - p0;
                let length = axis.length();
                if !(radius > 0.0 && length > 0.0 && radius.is_finite() && length.is_finite()) {
                    return Err(o.error(format!(
                        "cylinder needs a positive radius and distinct p0, p1 (radius {radius}, length {length})"
                    )));
                }
                let frame = crate::frame::Frame::from_normal(axis / length);
                let local = Mat4::from_cols(
                    (frame.s * radius).extend(0.0),
                    (frame.t * radius).extend(0.0),
                    axis.extend(0.0),
                    p0.extend(1.0),
                );
                let c = Cylinder::new(Affine3A::from_mat4(to_world * local), flip)
                    .map_err(|e| o.error(e))?;
                ShapeGeometry::Cylinder(c)
            }
            _ => return self.unknown(o, "shape"),
        };
        if let ShapeGeometry::Mesh(m) = &geometry {
            if m.indices.is_empty() {
                self.warnings.push(format!(
                    "{}: shape '{}' has no triangles (skipped)",
                    o.loc, o.plugin
                ));
                return Ok(());
            }
        }
        let shape_index = self.geometries.len() as u32;
        let area_emitter = o
            .children_of(&ObjectClass::Emitter)
            .next()
            .map(|c| c.object.clone());
        let bsdf_child = o
            .children_of(&ObjectClass::Bsdf)
            .next()
            .map(|c| c.object.clone());
        let bsdf = match bsdf_child {
            Some(b) => self.bsdf_for(&b)?,
            None => {
                // Mitsuba: grey 0.5 diffuse, or black for emitters.
                let refl = if area_emitter.is_some() { 0.0 } else { 0.5 };
                let i = self.bsdfs.len() as u32;
                self.bsdfs.push(Bsdf::Diffuse(Diffuse {
                    reflectance: Texture::constant(refl),
                }));
                i
            }
        };
        let emitter = match area_emitter {
            Some(e) => {
                if e.plugin != "area" {
                    return Err(e.error(format!(
                        "emitter '{}' cannot be attached to a shape (only 'area' can)",
                        e.plugin
                    )));
                }
                self.add_emitter(&e, Some(shape_index))?;
                Some(self.emitters.len() as u32 - 1)
            }
            None => None,
        };
        let name =
            o.id.clone()
                .unwrap_or_else(|| format!("{} at {}", o.plugin, o.loc));
        self.geometries.push(geometry);
        self.shapes.push(ShapeInfo {
            bsdf,
            emitter,
            name,
        });
        Ok(())
    }

    fn add_emitter(&mut self, o: &ObjectDesc, shape: Option<u32>) -> SceneResult<()> {
        let to_world = o.transform_or_identity("to_world")?;
        let weight = o.float_or("sampling_weight", 1.0)? as f32;
        if !(weight >= 0.0) {
            return Err(o.error("sampling_weight must be non-negative"));
        }
        let nonneg = |name: &str, v: Vec3| -> SceneResult<Vec3> {
            if v.is_finite() && v.min_element() >= 0.0 {
                Ok(v)
            } else {
                Err(o.error(format!(
                    "emitter '{}': {name} must be finite and non-negative, got {v}",
                    o.plugin
                )))
            }
        };
        let emitter = match o.plugin.as_str() {
            "area" => {
                let Some(shape) = shape else {
                    return Err(o.error("an 'area' emitter must be nested inside a <shape>"));
                };
                Emitter::Area {
                    shape,
                    radiance: nonneg("radiance", o.rgb_or("radiance", Vec3::ONE)?)?,
                }
            }
            "point" => {
                let position = match o.prop("position") {
                    Some(_) => o.vec3_or("position", Vec3::ZERO)?,
                    None => to_world.transform_point3(Vec3::ZERO),
                };
                Emitter::Point {
                    position,
                    intensity: nonneg("intensity", o.rgb_or("intensity", Vec3::ONE)?)?,
                }
            }
            "spot" => {
                let cutoff = o.float_or("cutoff_angle", 20.0)?;
                let beam = o.float_or("beam_width", cutoff * 0.75)?;
                if !((0.0..=180.0).contains(&cutoff) && cutoff > 0.0 && beam >= 0.0) {
                    return Err(o.error(format!(
                        "spot: invalid cutoff_angle {cutoff} / beam_width {beam}"
                    )));
                }
                let beam = beam.min(cutoff);
                Emitter::Spot(SpotLight::new(
                    to_world.transform_point3(Vec3::ZERO),
                    to_world.transform_vector3(Vec3::Z),
                    nonneg("intensity", o.rgb_or("intensity", Vec3::ONE)?)?,
                    (cutoff as f32).to_radians(),
                    (beam as f32).to_radians(),
                ))
            }
            "constant" => Emitter::Constant {
                radiance: nonneg("radiance", o.rgb_or("radiance", Vec3::ONE)?)?,
            },
            "directional" => {
                let dir = match o.prop("direction") {
                    Some(_) => o.vec3_or("direction", Vec3::Z)?,
                    None => to_world.transform_vector3(Vec3::Z),
                };
                if !(dir.length_squared() > 0.0) {
                    return Err(o.error("directional: direction must be non-zero"));
                }
                Emitter::Directional {
                    direction: dir.normalize(),
                    irradiance: nonneg("irradiance", o.rgb_or("irradiance", Vec3::ONE)?)?,
                }
            }
            "envmap" => {
                let (path, loc) = o
                    .resolve_path("filename")?
                    .ok_or_else(|| o.error("emitter 'envmap' needs a 'filename'"))?;
                let (w, h, mut texels) = crate::texture::load_image(&path, false)
                    .map_err(|e| SceneError::at(&loc, e))?;
                let scale = o.float_or("scale", 1.0)? as f32;
                if !(scale >= 0.0) || !scale.is_finite() {
                    return Err(o.error(format!("envmap: scale must be non-negative, got {scale}")));
                }
                for t in &mut texels {
                    *t = if t.is_finite() {
                        t.max(Vec3::ZERO) * scale
                    } else {
                        Vec3::ZERO
                    };
                }
                let m = glam::Mat3::from_mat4(to_world);
                if !(m.determinant().abs() > 0.0) {
                    return Err(o.error("envmap: degenerate to_world"));
                }
                match crate::emitter::EnvMap::new(w as usize, h as usize, texels, m) {
                    Some(e) => Emitter::Envmap(Box::new(e)),
                    None => {
                        self.warnings.push(format!(
                            "{}: envmap '{}' is black (skipped)",
                            o.loc,
                            path.display()
                        ));
                        return Ok(());
                    }
                }
            }
            "sunsky" | "sun" | "sky" => return self.sunsky_fallback(o, &to_world, weight),
            _ => return self.unknown(o, "emitter"),
        };
        if emitter.is_environment() && self.emitters.iter().any(|e| e.is_environment()) {
            return Err(o.error("only one environment emitter is allowed"));
        }
        self.emitters.push(emitter);
        self.emitter_weights.push(weight);
        Ok(())
    }
}

/// Stand-in sun and sky of the `--lenient` fallback for Mitsuba 0.6's `sunsky`, in the same units as
/// the scene's other radiances only by convention: sun irradiance 10 (a diffuse white floor under a sun
/// at the zenith reads 10/π ≈ 3.2) and sky radiance 0.5 (that floor reads 0.5 under the sky alone).
const FALLBACK_SUN_IRRADIANCE: f32 = 10.0;
const FALLBACK_SKY_RADIANCE: f32 = 0.5;

impl Builder<'_> {
    /// Mitsuba 0.6's `sunsky`/`sun`/`sky` (Preetham/Hosek-Wilkie spectral models) are not implemented. In
    /// strict mode this is an error naming the element. With `--lenient` they become a directional sun
    /// towards Mitsuba's sun position for the element's date, time and place (or `sun_direction`) and a
    /// constant sky, scaled by `scale`, `sun_scale` and `sky_scale`, with a warning saying so.
    fn sunsky_fallback(&mut self, o: &ObjectDesc, to_world: &Mat4, weight: f32) -> SceneResult<()> {
        let msg = format!(
            "emitter '{}' (Mitsuba 0.6's physical sun/sky model) is not supported; --lenient replaces it \
             by a directional sun at Mitsuba's sun position plus a constant sky (approximate brightness)",
            o.plugin
        );
        if self.opts.strictness == Strictness::Strict {
            return Err(o.error(msg));
        }
        use crate::emitter::sun_position::{sun_direction_local, SunTimePlace};
        let d = SunTimePlace::default();
        let at = SunTimePlace {
            year: o.int_or("year", d.year)?,
            month: o.int_or("month", d.month)?,
            day: o.int_or("day", d.day)?,
            hour: o.float_or("hour", d.hour)?,
            minute: o.float_or("minute", d.minute)?,
            second: o.float_or("second", d.second)?,
            latitude: o.float_or("latitude", d.latitude)?,
            longitude: o.float_or("longitude", d.longitude)?,
            timezone: o.float_or("timezone", d.timezone)?,
        };
        if !(1..=12).contains(&at.month) || !(1..=31).contains(&at.day) {
            return Err(o.error(format!("invalid date {}-{}-{}", at.year, at.month, at.day)));
        }
        let local = match o.prop("sun_direction") {
            Some(_) => o.vec3_or("sun_direction", Vec3::Y)?,
            None => sun_direction_local(&at).as_vec3(),
        };
        let to_sun = to_world.transform_vector3(local);
        if !(to_sun.length_squared() > 0.0) || !to_sun.is_finite() {
            return Err(o.error("sunsky: the sun direction is degenerate"));
        }
        let scale = o.float_or("scale", 1.0)? as f32;
        let sun_scale = scale * o.float_or("sun_scale", 1.0)? as f32;
        let sky_scale = scale * o.float_or("sky_scale", 1.0)? as f32;
        if !(sun_scale >= 0.0 && sky_scale >= 0.0) {
            return Err(o.error("sunsky: scales must be non-negative"));
        }
        let to_sun = to_sun.normalize();
        self.warnings.push(format!(
            "{}: {msg}: sun towards ({:.3}, {:.3}, {:.3}) with irradiance {}, sky radiance {}",
            o.loc,
            to_sun.x,
            to_sun.y,
            to_sun.z,
            FALLBACK_SUN_IRRADIANCE * sun_scale,
            FALLBACK_SKY_RADIANCE * sky_scale
        ));
        if o.plugin != "sky" {
            self.emitters.push(Emitter::Directional {
                direction: -to_sun,
                irradiance: Vec3::splat(FALLBACK_SUN_IRRADIANCE * sun_scale),
            });
            self.emitter_weights.push(weight);
        }
        if o.plugin != "sun" {
            if self.emitters.iter().any(|e| e.is_environment()) {
                return Err(o.error("only one environment emitter is allowed"));
            }
            self.emitters.push(Emitter::Constant {
                radiance: Vec3::splat(FALLBACK_SKY_RADIANCE * sky_scale),
            });
            self.emitter_weights.push(weight);
        }
        Ok(())
    }
}

fn mesh_from_data(d: MeshData, flip: bool) -> TriangleMesh {
    TriangleMesh::new(d.positions, d.normals, d.uvs, d.indices, flip)
}

/// The scale factor of a similarity transform, and whether the transform's scale is uniform.
fn uniform_scale(m: &Mat4) -> (f32, bool) {
    let sx = m.x_axis.truncate().length();
    let sy = m.y_axis.truncate().length();
    let sz = m.z_axis.truncate().length();
    let uniform = (sx - sy).abs() <= 1e-4 * sx && (sx - sz).abs() <= 1e-4 * sx;
    (sx, uniform)
}
