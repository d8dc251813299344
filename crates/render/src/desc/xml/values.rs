//! Attribute values of scene XML: numbers, vectors, colours and spectra, and the properties and
//! transforms built from them.

use super::{canonical, check_no_text, to_snake_case, FileCtx, Reader};
use crate::color::srgb_to_linear;
use crate::desc::{PropValue, Property, SpectrumDesc};
use crate::error::{SceneError, SceneResult};
use glam::{DMat3, DMat4, DVec3, Vec3};
use roxmltree::{Node, NodeType};

impl Reader {
    // ----- numbers ----------------------------------------------------------------------------

    /// All numbers of an attribute value, separated by commas and/or whitespace.
    pub(super) fn numbers(
        &self,
        text: &str,
        attr: &str,
        node: Node,
        ctx: &FileCtx,
    ) -> SceneResult<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| parse_number(t).ok_or_else(|| number_error(t, attr, node, ctx)))
            .collect()
    }

    /// Exactly one number.
    pub(super) fn number(&mut self, node: Node, attr: &str, ctx: &FileCtx) -> SceneResult<f64> {
        let text = self.required(node, attr, ctx)?;
        parse_number(text.trim()).ok_or_else(|| number_error(&text, attr, node, ctx))
    }

    /// A 3-vector from `x`/`y`/`z` attributes (missing or empty = `default`) or from `value` (1 or 3
    /// numbers).
    pub(super) fn xyz(&mut self, node: Node, ctx: &FileCtx, default: f64) -> SceneResult<DVec3> {
        let tag = node.tag_name().name();
        let comps = [
            self.attr(node, "x", ctx)?,
            self.attr(node, "y", ctx)?,
            self.attr(node, "z", ctx)?,
        ];
        if let Some(value) = self.attr(node, "value", ctx)? {
            if comps.iter().any(Option::is_some) {
                return Err(ctx.error(
                    node,
                    format!("<{tag}> cannot mix 'value' with 'x'/'y'/'z' attributes"),
                ));
            }
            let n = self.numbers(&value, "value", node, ctx)?;
            return match n.len() {
                1 => Ok(DVec3::splat(n[0])),
                3 => Ok(DVec3::new(n[0], n[1], n[2])),
                k => Err(ctx.error(
                    node,
                    format!("'value' of <{tag}> must have 1 or 3 numbers, found {k}"),
                )),
            };
        }
        let mut v = [default; 3];
        for (slot, (text, axis)) in v.iter_mut().zip(comps.iter().zip(["x", "y", "z"])) {
            if let Some(text) = text.as_ref().filter(|t| !t.trim().is_empty()) {
                *slot =
                    parse_number(text.trim()).ok_or_else(|| number_error(text, axis, node, ctx))?;
            }
        }
        Ok(DVec3::from_array(v))
    }

    /// A vector attribute of exactly three numbers (`lookat`'s origin/target/up).
    pub(super) fn vec3_attr(
        &mut self,
        node: Node,
        attr: &str,
        ctx: &FileCtx,
    ) -> SceneResult<Option<DVec3>> {
        let Some(text) = self.attr(node, attr, ctx)? else {
            return Ok(None);
        };
        let n = self.numbers(&text, attr, node, ctx)?;
        if n.len() != 3 {
            return Err(ctx.error(
                node,
                format!(
                    "'{attr}' of <{}> must have 3 numbers, found {}",
                    node.tag_name().name(),
                    n.len()
                ),
            ));
        }
        Ok(Some(DVec3::new(n[0], n[1], n[2])))
    }

    // ----- properties -------------------------------------------------------------------------

    pub(super) fn parse_property(&mut self, node: Node, ctx: &FileCtx) -> SceneResult<Property> {
        let tag = node.tag_name().name();
        let loc = ctx.loc(node);
        let name = to_snake_case(&self.required(node, "name", ctx)?);
        let value = match tag {
            "float" => {
                self.check_attributes(node, ctx, &["name", "value"])?;
                PropValue::Float(self.number(node, "value", ctx)?)
            }
            "integer" => {
                self.check_attributes(node, ctx, &["name", "value"])?;
                let text = self.required(node, "value", ctx)?;
                let v = text.trim().parse::<i64>().map_err(|_| {
                    ctx.error(
                        node,
                        format!("could not parse integer value \"{text}\" in <integer>"),
                    )
                })?;
                PropValue::Integer(v)
            }
            "boolean" => {
                self.check_attributes(node, ctx, &["name", "value"])?;
                let text = self.required(node, "value", ctx)?;
                match text.trim().to_ascii_lowercase().as_str() {
                    "true" => PropValue::Boolean(true),
                    "false" => PropValue::Boolean(false),
                    _ => {
                        return Err(ctx.error(
                            node,
                            format!(
                                "could not parse boolean value \"{text}\" (must be true or false)"
                            ),
                        ))
                    }
                }
            }
            "string" => {
                self.check_attributes(node, ctx, &["name", "value"])?;
                let mut text = self.required(node, "value", ctx)?;
                if name == "filename" && !ctx.dir.join(&text).exists() {
                    if let Some(found) = self.locate(&text, ctx) {
                        text = canonical(&found).to_string_lossy().into_owned();
                    }
                }
                PropValue::String(text)
            }
            "rgb" | "color" | "srgb" => {
                let allowed: &[&str] = if ctx.legacy {
                    &["name", "value", "intent"]
                } else {
                    &["name", "value"]
                };
                self.check_attributes(node, ctx, allowed)?;
                let text = self.required(node, "value", ctx)?;
                let c = if tag == "srgb" {
                    let c = match parse_hex_colour(&text) {
                        Some(c) => c,
                        None => self.colour_triple(&text, node, ctx)?,
                    };
                    Vec3::new(
                        srgb_to_linear(c.x),
                        srgb_to_linear(c.y),
                        srgb_to_linear(c.z),
                    )
                } else {
                    self.colour_triple(&text, node, ctx)?
                };
                PropValue::Rgb(c)
            }
            "spectrum" => PropValue::Spectrum(self.parse_spectrum(node, ctx)?),
            "blackbody" => {
                self.check_attributes(node, ctx, &["name", "temperature", "scale"])?;
                let text = self.required(node, "temperature", ctx)?;
                let t = text.trim().trim_end_matches(['k', 'K']);
                let t = parse_number(t).filter(|t| *t > 0.0).ok_or_else(|| {
                    ctx.error(node, format!("invalid black body temperature \"{text}\""))
                })?;
                if let Some(scale) = self.attr(node, "scale", ctx)? {
                    if parse_number(scale.trim()) != Some(1.0) {
                        return Err(ctx.error(
                            node,
                            "a <blackbody> 'scale' other than 1 is not supported (scale the emitter instead)",
                        ));
                    }
                }
                PropValue::Spectrum(SpectrumDesc::Blackbody(t))
            }
            "point" | "vector" => {
                self.check_attributes(node, ctx, &["name", "value", "x", "y", "z"])?;
                let v = self.xyz(node, ctx, 0.0)?.as_vec3();
                if tag == "point" {
                    PropValue::Point(v)
                } else {
                    PropValue::Vector(v)
                }
            }
            "transform" => {
                self.check_attributes(node, ctx, &["name"])?;
                PropValue::Transform(self.parse_transform(node, ctx)?.as_mat4())
            }
            _ => return Err(ctx.error(node, format!("unexpected element <{tag}>"))),
        };
        Ok(Property { name, value, loc })
    }

    /// One or three numbers (`<rgb value="0.25"/>` is grey).
    pub(super) fn colour_triple(&self, text: &str, node: Node, ctx: &FileCtx) -> SceneResult<Vec3> {
        let n = self.numbers(text, "value", node, ctx)?;
        match n.len() {
            1 => Ok(Vec3::splat(n[0] as f32)),
            3 => Ok(DVec3::new(n[0], n[1], n[2]).as_vec3()),
            k => Err(ctx.error(
                node,
                format!(
                    "<{}> needs one or three values, found {k} in \"{text}\"",
                    node.tag_name().name()
                ),
            )),
        }
    }

    pub(super) fn parse_spectrum(
        &mut self,
        node: Node,
        ctx: &FileCtx,
    ) -> SceneResult<SpectrumDesc> {
        let allowed: &[&str] = if ctx.legacy {
            &[
                "name",
                "value",
                "filename",
                "wavelengths",
                "values",
                "intent",
            ]
        } else {
            &["name", "value", "filename", "wavelengths", "values"]
        };
        self.check_attributes(node, ctx, allowed)?;
        if let Some(file) = self.attr(node, "filename", ctx)? {
            return Err(ctx.error(
                node,
                format!(
                    "spectrum files are not supported (filename=\"{file}\"); write the spectrum inline as \
                     value=\"λ:v, λ:v, ...\" or use <rgb>"
                ),
            ));
        }
        let pairs: Vec<(f64, f64)> = if let Some(wl) = self.attr(node, "wavelengths", ctx)? {
            let values = self.required(node, "values", ctx)?;
            let wl = self.numbers(&wl, "wavelengths", node, ctx)?;
            let values = self.numbers(&values, "values", node, ctx)?;
            if wl.len() != values.len() || wl.is_empty() {
                return Err(ctx.error(
                    node,
                    format!(
                        "<spectrum> has {} wavelengths but {} values",
                        wl.len(),
                        values.len()
                    ),
                ));
            }
            wl.into_iter().zip(values).collect()
        } else {
            let text = self.required(node, "value", ctx)?;
            if !text.contains(':') {
                let n = self.numbers(&text, "value", node, ctx)?;
                if n.len() != 1 {
                    return Err(ctx.error(
                        node,
                        format!(
                            "<spectrum> value must be one number or 'wavelength:value' pairs, found \"{text}\""
                        ),
                    ));
                }
                return Ok(SpectrumDesc::Uniform(n[0]));
            }
            let mut pairs = Vec::new();
            for token in text
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|t| !t.is_empty())
            {
                let pair = token
                    .split_once(':')
                    .and_then(|(l, v)| Some((parse_number(l)?, parse_number(v)?)))
                    .ok_or_else(|| {
                        ctx.error(
                            node,
                            format!("could not parse wavelength:value pair \"{token}\""),
                        )
                    })?;
                pairs.push(pair);
            }
            pairs
        };
        if pairs.windows(2).any(|w| w[1].0 <= w[0].0) || pairs[0].0 <= 0.0 {
            return Err(ctx.error(
                node,
                "<spectrum> wavelengths must be positive and increasing",
            ));
        }
        Ok(SpectrumDesc::Sampled(pairs))
    }

    /// Composes the children of `<transform>` in document order: M = Tn ··· T1.
    pub(super) fn parse_transform(&mut self, node: Node, ctx: &FileCtx) -> SceneResult<DMat4> {
        let mut m = DMat4::IDENTITY;
        for op in node.children() {
            match op.node_type() {
                NodeType::Element => {}
                NodeType::Text => {
                    check_no_text(op, ctx)?;
                    continue;
                }
                _ => continue,
            }
            let t = match op.tag_name().name() {
                "translate" => {
                    self.check_attributes(op, ctx, &["x", "y", "z", "value"])?;
                    DMat4::from_translation(self.xyz(op, ctx, 0.0)?)
                }
                "scale" => {
                    self.check_attributes(op, ctx, &["x", "y", "z", "value"])?;
                    DMat4::from_scale(self.xyz(op, ctx, 1.0)?)
                }
                "rotate" => {
                    self.check_attributes(op, ctx, &["x", "y", "z", "value", "angle"])?;
                    let axis = self.xyz(op, ctx, 0.0)?;
                    let angle = self.number(op, "angle", ctx)?;
                    let axis = axis.try_normalize().ok_or_else(|| {
                        ctx.error(op, "<rotate> needs a non-zero axis (x, y, z or value)")
                    })?;
                    DMat4::from_axis_angle(axis, angle.to_radians())
                }
                "matrix" => {
                    self.check_attributes(op, ctx, &["value"])?;
                    let text = self.required(op, "value", ctx)?;
                    let n = self.numbers(&text, "value", op, ctx)?;
                    match n.len() {
                        16 => DMat4::from_cols_slice(&n).transpose(),
                        9 => DMat4::from_mat3(DMat3::from_cols_slice(&n).transpose()),
                        k => {
                            return Err(ctx
                                .error(op, format!("<matrix> needs 16 (or 9) numbers, found {k}")))
                        }
                    }
                }
                "lookat" | "lookAt" => {
                    self.check_attributes(op, ctx, &["origin", "target", "up"])?;
                    let origin = self.vec3_attr(op, "origin", ctx)?;
                    let target = self.vec3_attr(op, "target", ctx)?;
                    let (Some(origin), Some(target)) = (origin, target) else {
                        return Err(ctx.error(op, "<lookat> needs 'origin' and 'target'"));
                    };
                    let up = self.vec3_attr(op, "up", ctx)?.unwrap_or(DVec3::ZERO);
                    look_at(origin, target, up)
                        .ok_or_else(|| ctx.error(op, "<lookat> has origin equal to target"))?
                }
                other => {
                    return Err(ctx.error(
                        op,
                        format!(
                        "unexpected <{other}> in <transform> (expected translate, rotate, scale, \
                             matrix or lookat)"
                    ),
                    ))
                }
            };
            m = t * m;
        }
        Ok(m)
    }
}

/// Mitsuba's `look_at`: columns [left, up', dir, origin] with dir = normalize(target − origin),
/// left = normalize(up × dir), up' = dir × left. A zero `up`, or one parallel to dir, is replaced by a
/// perpendicular vector (the first axis of Mitsuba's `coordinate_system(dir)`). `None` if origin = target.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let c = up.cross(dir);
    let left = if up.length() > 0.0 && c.length() > 1e-9 * up.length() {
        c.normalize()
    } else {
        let (perpendicular_up, _) = coordinate_system(dir);
        perpendicular_up.cross(dir).normalize()
    };
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Two unit vectors completing `n` to an orthonormal basis (Duff et al. 2017, as Mitsuba).
fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A finite number, or `None`.
pub(super) fn parse_number(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|v| v.is_finite())
}

pub(super) fn number_error(text: &str, attr: &str, node: Node, ctx: &FileCtx) -> SceneError {
    ctx.error(
        node,
        format!(
            "could not parse \"{}\" as a finite number in attribute '{attr}' of <{}>",
            text.trim(),
            node.tag_name().name()
        ),
    )
}

/// `#rrggbb` (as Mitsuba 0.6's `<srgb>` accepts) → components in [0, 1].
fn parse_hex_colour(text: &str) -> Option<Vec3> {
    let hex = text.trim().strip_prefix('#')?;
    if hex.len() != 6 || !hex.is_ascii() {
        return None;
    }
    let channel = |i: usize| {
        u8::from_str_radix(&hex[i..i + 2], 16)
            .ok()
            .map(|v| v as f32 / 255.0)
    };
    Some(Vec3::new(channel(0)?, channel(2)?, channel(4)?))
}
