//! The neutral scene description: what a Mitsuba XML file says, independent of how we render it.
//!
//! The XML reader ([`xml`]) produces a tree of [`ObjectDesc`]s (one per plugin element) whose property
//! names are normalised to Mitsuba 3's snake_case, whose `$variables` are substituted, whose `<ref>`s are
//! resolved (shared `Arc`s) and whose `<include>`s are inlined. The builder then turns it into render
//! objects. Every object and property carries the file and line it came from, for error messages.

mod body;
mod legacy;
pub mod xml;

use crate::error::{SceneError, SceneResult, SourceLoc};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The kind of a plugin element (the XML tag name).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ObjectClass {
    /// `<scene>` (the root).
    Scene,
    /// `<shape>`.
    Shape,
    /// `<bsdf>`.
    Bsdf,
    /// `<emitter>`.
    Emitter,
    /// `<sensor>` (`<camera>` in old files).
    Sensor,
    /// `<film>`.
    Film,
    /// `<rfilter>`.
    Rfilter,
    /// `<sampler>`.
    Sampler,
    /// `<integrator>`.
    Integrator,
    /// `<texture>`.
    Texture,
    /// `<medium>`.
    Medium,
    /// `<phase>`.
    Phase,
    /// Any other plugin tag (kept so that the builder can name it in an error).
    Other(String),
}

impl ObjectClass {
    /// The XML tag name.
    pub fn tag(&self) -> &str {
        match self {
            ObjectClass::Scene => "scene",
            ObjectClass::Shape => "shape",
            ObjectClass::Bsdf => "bsdf",
            ObjectClass::Emitter => "emitter",
            ObjectClass::Sensor => "sensor",
            ObjectClass::Film => "film",
            ObjectClass::Rfilter => "rfilter",
            ObjectClass::Sampler => "sampler",
            ObjectClass::Integrator => "integrator",
            ObjectClass::Texture => "texture",
            ObjectClass::Medium => "medium",
            ObjectClass::Phase => "phase",
            ObjectClass::Other(s) => s,
        }
    }
}

/// A spectrum property as written in the file.
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumDesc {
    /// A uniform value (`<spectrum value="0.5"/>`).
    Uniform(f64),
    /// Wavelength/value pairs in nm (`<spectrum value="400:0.1, 700:0.5"/>`).
    Sampled(Vec<(f64, f64)>),
    /// A black body of the given temperature in Kelvin (`<blackbody temperature=".."/>`).
    Blackbody(f64),
}

/// A typed property value.
#[derive(Clone, Debug, PartialEq)]
pub enum PropValue {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Integer(i64),
    /// `<boolean>`.
    Boolean(bool),
    /// `<string>`.
    String(String),
    /// `<rgb>` (linear) or `<srgb>` (already converted to linear by the reader).
    Rgb(Vec3),
    /// `<spectrum>` or `<blackbody>`.
    Spectrum(SpectrumDesc),
    /// `<point>`.
    Point(Vec3),
    /// `<vector>`.
    Vector(Vec3),
    /// `<transform>`: the composed matrix (children applied in document order, M = Tn ... T1).
    Transform(Mat4),
}

impl PropValue {
    /// The XML tag this kind of value is written with (for error messages).
    pub fn type_name(&self) -> &'static str {
        match self {
            PropValue::Float(_) => "float",
            PropValue::Integer(_) => "integer",
            PropValue::Boolean(_) => "boolean",
            PropValue::String(_) => "string",
            PropValue::Rgb(_) => "rgb",
            PropValue::Spectrum(_) => "spectrum",
            PropValue::Point(_) => "point",
            PropValue::Vector(_) => "vector",
            PropValue::Transform(_) => "transform",
        }
    }
}

/// One named property of a plugin.
#[derive(Clone, Debug)]
pub struct Property {
    /// snake_case name (`toWorld` in a 0.6 file becomes `to_world`).
    pub name: String,
    /// The value.
    pub value: PropValue,
    /// Where it was written.
    pub loc: SourceLoc,
}

/// A nested plugin, with the `name` attribute it was given (e.g. `<texture name="reflectance">`).
#[derive(Clone, Debug)]
pub struct ChildDesc {
    /// The `name` attribute, if any (for `<ref>`, the ref's `name`).
    pub name: Option<String>,
    /// The plugin (shared when it came from a `<ref>`).
    pub object: Arc<ObjectDesc>,
}

/// One plugin element: `<bsdf type="diffuse" id="white"> ... </bsdf>`.
#[derive(Clone, Debug)]
pub struct ObjectDesc {
    /// The tag.
    pub class: ObjectClass,
    /// The `type` attribute (plugin name), e.g. `diffuse`; empty for `<scene>`.
    pub plugin: String,
    /// The `id` attribute.
    pub id: Option<String>,
    /// Properties in document order.
    pub props: Vec<Property>,
    /// Nested plugins in document order.
    pub children: Vec<ChildDesc>,
    /// Where the element starts.
    pub loc: SourceLoc,
}

/// A whole parsed scene.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    /// The `<scene>` element; its children are the top-level plugins.
    pub root: Arc<ObjectDesc>,
    /// The `version` attribute of the root file, e.g. `(3, 0, 0)` or `(0, 6, 0)`.
    pub version: (u32, u32, u32),
    /// The main XML file.
    pub path: PathBuf,
}

impl ObjectDesc {
    /// The property with this name, if present.
    pub fn prop(&self, name: &str) -> Option<&Property> {
        self.props.iter().find(|p| p.name == name)
    }

    /// An error located at this element.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::at(&self.loc, message)
    }

    fn type_error(&self, p: &Property, wanted: &str) -> SceneError {
        SceneError::at(
            &p.loc,
            format!(
                "property '{}' of {} '{}' must be a {wanted}, found <{}>",
                p.name,
                self.class.tag(),
                self.plugin,
                p.value.type_name()
            ),
        )
    }

    /// A float property (integers are accepted too), or `default`.
    pub fn float_or(&self, name: &str, default: f64) -> SceneResult<f64> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                PropValue::Float(v) => Ok(*v),
                PropValue::Integer(v) => Ok(*v as f64),
                PropValue::Spectrum(SpectrumDesc::Uniform(v)) => Ok(*v),
                _ => Err(self.type_error(p, "float")),
            },
        }
    }

    /// An optional float property.
    pub fn float_opt(&self, name: &str) -> SceneResult<Option<f64>> {
        if self.prop(name).is_some() {
            self.float_or(name, 0.0).map(Some)
        } else {
            Ok(None)
        }
    }

    /// An integer property, or `default`.
    pub fn int_or(&self, name: &str, default: i64) -> SceneResult<i64> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                PropValue::Integer(v) => Ok(*v),
                PropValue::Float(v) if v.fract() == 0.0 => Ok(*v as i64),
                _ => Err(self.type_error(p, "integer")),
            },
        }
    }

    /// A boolean property, or `default`.
    pub fn bool_or(&self, name: &str, default: bool) -> SceneResult<bool> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                PropValue::Boolean(v) => Ok(*v),
                _ => Err(self.type_error(p, "boolean")),
            },
        }
    }

    /// A string property, or `default`.
    pub fn string_or(&self, name: &str, default: &str) -> SceneResult<String> {
        match self.prop(name) {
            None => Ok(default.to_string()),
            Some(p) => match &p.value {
                PropValue::String(v) => Ok(v.clone()),
                _ => Err(self.type_error(p, "string")),
            },
        }
    }

    /// An optional string property.
    pub fn string_opt(&self, name: &str) -> SceneResult<Option<String>> {
        if self.prop(name).is_some() {
            self.string_or(name, "").map(Some)
        } else {
            Ok(None)
        }
    }

    /// A point or vector property, or `default`.
    pub fn vec3_or(&self, name: &str, default: Vec3) -> SceneResult<Vec3> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                PropValue::Point(v) | PropValue::Vector(v) => Ok(*v),
                _ => Err(self.type_error(p, "point or vector")),
            },
        }
    }

    /// A colour property given as rgb, srgb, a uniform spectrum or a float, or `default`.
    /// Sampled spectra and black bodies are converted to linear RGB (see [`spectrum_to_rgb`]).
    /// A nested plugin bound to `name` (a `<texture>` or `<spectrum type="..">`) is an error here: only
    /// BSDF parameters take textures.
    pub fn rgb_or(&self, name: &str, default: Vec3) -> SceneResult<Vec3> {
        match self.prop(name) {
            None => match self.named_child(name) {
                Some(c) => Err(SceneError::at(
                    &c.object.loc,
                    format!(
                        "parameter '{name}' of {} '{}' cannot be a nested <{} type=\"{}\"> (give a \
                         constant <rgb>, <spectrum value=\"..\"> or <float>)",
                        self.class.tag(),
                        self.plugin,
                        c.object.class.tag(),
                        c.object.plugin
                    ),
                )),
                None => Ok(default),
            },
            Some(p) => match &p.value {
                PropValue::Rgb(v) => Ok(*v),
                PropValue::Float(v) => Ok(Vec3::splat(*v as f32)),
                PropValue::Integer(v) => Ok(Vec3::splat(*v as f32)),
                PropValue::Spectrum(s) => Ok(spectrum_to_rgb(s)),
                _ => Err(self.type_error(p, "colour (rgb, spectrum or float)")),
            },
        }
    }

    /// A transform property, or the identity.
    pub fn transform_or_identity(&self, name: &str) -> SceneResult<Mat4> {
        match self.prop(name) {
            None => Ok(Mat4::IDENTITY),
            Some(p) => match &p.value {
                PropValue::Transform(m) => Ok(*m),
                _ => Err(self.type_error(p, "transform")),
            },
        }
    }

    /// Nested plugins of one class, with their names.
    pub fn children_of<'a>(
        &'a self,
        class: &'a ObjectClass,
    ) -> impl Iterator<Item = &'a ChildDesc> + 'a {
        self.children
            .iter()
            .filter(move |c| &c.object.class == class)
    }

    /// The nested plugin bound to property `name` (e.g. `<texture name="reflectance" ...>`).
    pub fn named_child(&self, name: &str) -> Option<&ChildDesc> {
        self.children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))
    }

    /// Resolves a `filename` property relative to the directory of the XML file that wrote it.
    pub fn resolve_path(&self, name: &str) -> SceneResult<Option<(PathBuf, SourceLoc)>> {
        let Some(p) = self.prop(name) else {
            return Ok(None);
        };
        let PropValue::String(s) = &p.value else {
            return Err(self.type_error(p, "string"));
        };
        let rel = Path::new(s);
        let full = if rel.is_absolute() {
            rel.to_path_buf()
        } else {
            p.loc.file.parent().unwrap_or(Path::new(".")).join(rel)
        };
        Ok(Some((full, p.loc.clone())))
    }
}

/// Converts a spectrum description to linear RGB. Uniform spectra map to grey. Sampled spectra are
/// integrated against the CIE 1931 colour matching functions (Wyman et al. 2013 fit) and converted to
/// linear Rec.709 with an equal-energy white point, so a flat spectrum maps to grey of the same value.
/// Black bodies are normalised to unit luminance, as Mitsuba 0.6 does for `<blackbody>` with `scale` 1.
pub fn spectrum_to_rgb(s: &SpectrumDesc) -> Vec3 {
    fn cie(lambda: f64) -> (f64, f64, f64) {
        let g = |x: f64, mu: f64, s1: f64, s2: f64| {
            let t = (x - mu) / if x < mu { s1 } else { s2 };
            (-0.5 * t * t).exp()
        };
        let x = 1.056 * g(lambda, 599.8, 37.9, 31.0) + 0.362 * g(lambda, 442.0, 16.0, 26.7)
            - 0.065 * g(lambda, 501.1, 20.4, 26.2);
        let y = 0.821 * g(lambda, 568.8, 46.9, 40.5) + 0.286 * g(lambda, 530.9, 16.3, 31.1);
        let z = 1.217 * g(lambda, 437.0, 11.8, 36.0) + 0.681 * g(lambda, 459.0, 26.0, 13.8);
        (x, y, z)
    }
    let integrate = |f: &dyn Fn(f64) -> f64| -> (f64, f64, f64, f64) {
        let (mut x, mut y, mut z, mut n) = (0.0, 0.0, 0.0, 0.0);
        let mut l = 360.0;
        while l <= 830.0 {
            let (cx, cy, cz) = cie(l);
            let v = f(l);
            x += cx * v;
            y += cy * v;
            z += cz * v;
            n += cy;
            l += 1.0;
        }
        (x / n, y / n, z / n, n)
    };
    let xyz = match s {
        SpectrumDesc::Uniform(v) => return Vec3::splat(*v as f32),
        SpectrumDesc::Sampled(pts) => {
            if pts.is_empty() {
                return Vec3::ZERO;
            }
            let f = |l: f64| -> f64 {
                if l <= pts[0].0 {
                    return pts[0].1;
                }
                for w in pts.windows(2) {
                    if l <= w[1].0 {
                        let t = (l - w[0].0) / (w[1].0 - w[0].0).max(1e-12);
                        return w[0].1 * (1.0 - t) + w[1].1 * t;
                    }
                }
                pts[pts.len() - 1].1
            };
            let (x, y, z, _) = integrate(&f);
            (x, y, z)
        }
        SpectrumDesc::Blackbody(t) => {
            let t = *t;
            let planck = |l: f64| {
                let lm = l * 1e-9;
                let c1 = 3.741771852e-16;
                let c2 = 1.438776877e-2;
                c1 / (lm.powi(5) * ((c2 / (lm * t)).exp() - 1.0))
            };
            let (x, y, z, _) = integrate(&planck);
            (x / y, 1.0, z / y)
        }
    };
    let to_rgb = |(x, y, z): (f64, f64, f64)| {
        (
            3.2404542 * x - 1.5371385 * y - 0.4985314 * z,
            -0.9692660 * x + 1.8760108 * y + 0.0415560 * z,
            0.0556434 * x - 0.2040259 * y + 1.0572252 * z,
        )
    };
    // Normalise by the response to a flat unit spectrum, so that flat spectra map to grey of their value.
    let (ex, ey, ez, _) = integrate(&|_| 1.0);
    let (wr, wg, wb) = to_rgb((ex, ey, ez));
    let (r, g, b) = to_rgb(xyz);
    Vec3::new((r / wr) as f32, (g / wg) as f32, (b / wb) as f32)
}
