//! Field-of-view parameters of projective cameras (`fov`, `fov_axis`, `focal_length`), reduced to the
//! horizontal field of view exactly as Mitsuba 3's `parse_fov` does.

use crate::desc::{ObjectDesc, PropValue};
use crate::error::SceneResult;

/// Diagonal of the 36×24 mm "35 mm" film frame that `focal_length` refers to.
fn film_35mm_diagonal_mm() -> f64 {
    (36.0f64 * 36.0 + 24.0 * 24.0).sqrt()
}

/// The image axis a `fov` value applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal (the default).
    X,
    /// Vertical.
    Y,
    /// The image diagonal.
    Diagonal,
    /// The shorter image side.
    Smaller,
    /// The longer image side.
    Larger,
}

impl FovAxis {
    /// Parses a `fov_axis` value (case-insensitive, as Mitsuba lowercases it).
    pub fn parse(s: &str) -> Option<FovAxis> {
        match s.to_ascii_lowercase().as_str() {
            "x" => Some(FovAxis::X),
            "y" => Some(FovAxis::Y),
            "diagonal" => Some(FovAxis::Diagonal),
            "smaller" => Some(FovAxis::Smaller),
            "larger" => Some(FovAxis::Larger),
            _ => None,
        }
    }
}

/// Converts a field of view in degrees along `axis` to the horizontal field of view in degrees, for an
/// image of aspect ratio `aspect` = width / height.
pub fn x_fov_from_axis(fov_deg: f64, axis: FovAxis, aspect: f64) -> f64 {
    let axis = match axis {
        FovAxis::Smaller if aspect > 1.0 => FovAxis::Y,
        FovAxis::Smaller => FovAxis::X,
        FovAxis::Larger if aspect > 1.0 => FovAxis::X,
        FovAxis::Larger => FovAxis::Y,
        a => a,
    };
    let half_tan = (0.5 * fov_deg.to_radians()).tan();
    match axis {
        FovAxis::Y => 2.0 * (half_tan * aspect).atan().to_degrees(),
        FovAxis::Diagonal => {
            let width = 2.0 * half_tan / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            2.0 * (0.5 * width).atan().to_degrees()
        }
        _ => fov_deg,
    }
}

/// The diagonal field of view in degrees of a lens of `focal_mm` millimetres on 35 mm film.
pub fn diagonal_fov_from_focal_length(focal_mm: f64) -> f64 {
    2.0 * (film_35mm_diagonal_mm() / (2.0 * focal_mm))
        .atan()
        .to_degrees()
}

/// Reads `fov` + `fov_axis`, or else `focal_length` (default "50mm", a string with an optional "mm"
/// suffix or a number), and returns the horizontal field of view in degrees, in (0, 180).
pub fn parse_x_fov(sensor: &ObjectDesc, aspect: f64) -> SceneResult<f64> {
    let fov = sensor.float_opt("fov")?;
    let focal = sensor.prop("focal_length");
    if fov.is_some() && focal.is_some() {
        return Err(sensor.error(
            "specify either a focal length ('focal_length') or a field of view ('fov'), not both",
        ));
    }
    let x_fov = if let Some(fov) = fov {
        let axis_name = sensor.string_or("fov_axis", "x")?;
        let axis = FovAxis::parse(&axis_name).ok_or_else(|| {
            sensor.error(format!(
                "fov_axis '{axis_name}' is not one of 'x', 'y', 'diagonal', 'smaller', 'larger'"
            ))
        })?;
        x_fov_from_axis(fov, axis, aspect)
    } else {
        let focal_mm = match focal.map(|p| (&p.value, &p.loc)) {
            None => 50.0,
            Some((PropValue::Float(v), _)) => *v,
            Some((PropValue::Integer(v), _)) => *v as f64,
            Some((PropValue::String(s), loc)) => {
                let t = s.trim();
                let t = t.strip_suffix("mm").unwrap_or(t).trim();
                t.parse::<f64>().map_err(|_| {
                    crate::error::SceneError::at(
                        loc,
                        format!("could not parse focal_length '{s}' (expected e.g. \"50mm\")"),
                    )
                })?
            }
            Some((v, loc)) => {
                return Err(crate::error::SceneError::at(
                    loc,
                    format!(
                        "focal_length must be a string like \"50mm\", found <{}>",
                        v.type_name()
                    ),
                ))
            }
        };
        if !(focal_mm.is_finite() && focal_mm > 0.0) {
            return Err(sensor.error(format!("focal_length must be positive, got {focal_mm} mm")));
        }
        x_fov_from_axis(
            diagonal_fov_from_focal_length(focal_mm),
            FovAxis::Diagonal,
            aspect,
        )
    };
    if !(x_fov > 0.0 && x_fov < 180.0) {
        return Err(sensor.error(format!(
            "the horizontal field of view must be in (0, 180) degrees, got {x_fov}"
        )));
    }
    Ok(x_fov)
}
