//! Pixel reconstruction filters (Mitsuba 3 `rfilter` plugins), evaluated separably as w(x)·w(y).

use crate::desc::ObjectDesc;
use crate::error::SceneResult;
use std::f32::consts::PI;

/// Largest filter radius in pixels a scene may ask for; wider filters would make every sample touch
/// tens of thousands of pixels and are certainly a mistake.
pub const MAX_FILTER_RADIUS: f32 = 64.0;

/// A separable reconstruction filter. Each sample is splatted into every pixel whose centre lies within
/// `radius()` of it (per axis) with weight `eval(dx)·eval(dy)`; a pixel's value is Σw·L / Σw.
#[derive(Clone, Debug, PartialEq)]
pub enum ReconstructionFilter {
    /// `box`: radius 0.5; a sample only contributes to the pixel it falls in.
    Box,
    /// `tent`: w(x) = max(0, 1 − |x|/r), default radius 1.
    Tent {
        /// Support radius in pixels.
        radius: f32,
    },
    /// `gaussian`: w(x) = max(0, exp(−x²/2σ²) − exp(−r²/2σ²)) with r = 4σ; default σ = 0.5 px.
    Gaussian {
        /// Standard deviation σ in pixels.
        stddev: f32,
    },
    /// `mitchell` (B = C = 1/3 by default) and `catmullrom` (B = 0, C = 1/2): Mitchell–Netravali
    /// cubics with radius 2.
    Mitchell {
        /// The B parameter.
        b: f32,
        /// The C parameter.
        c: f32,
    },
    /// `lanczos`: windowed sinc sinc(x)·sinc(x/n) with n lobes (default 3), radius n.
    Lanczos {
        /// Number of lobes (= radius in pixels).
        lobes: u32,
    },
}

impl Default for ReconstructionFilter {
    /// Mitsuba's default: a Gaussian with σ = 0.5 px.
    fn default() -> Self {
        ReconstructionFilter::Gaussian { stddev: 0.5 }
    }
}

impl ReconstructionFilter {
    /// Half-width of the filter's support in pixels.
    pub fn radius(&self) -> f32 {
        match self {
            ReconstructionFilter::Box => 0.5,
            ReconstructionFilter::Tent { radius } => *radius,
            ReconstructionFilter::Gaussian { stddev } => 4.0 * stddev,
            ReconstructionFilter::Mitchell { .. } => 2.0,
            ReconstructionFilter::Lanczos { lobes } => *lobes as f32,
        }
    }

    /// Number of pixels a block needs around its interior to receive every splat of the samples drawn
    /// inside it (Mitsuba's `border_size`, ceil(r − 0.5)); 0 for the box filter.
    pub fn border_size(&self) -> u32 {
        match self {
            ReconstructionFilter::Box => 0,
            f => (f.radius() - 0.5).ceil().max(0.0) as u32,
        }
    }

    /// True for the box filter, whose samples go to their own pixel only.
    pub fn is_box(&self) -> bool {
        matches!(self, ReconstructionFilter::Box)
    }

    /// The 1D filter weight at offset `x` (pixels) from the sample.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        let ax = x.abs();
        match *self {
            ReconstructionFilter::Box => {
                if (-0.5..0.5).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            }
            ReconstructionFilter::Tent { radius } => (1.0 - ax / radius).max(0.0),
            ReconstructionFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = 4.0 * stddev;
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
            ReconstructionFilter::Mitchell { b, c } => {
                let x2 = ax * ax;
                let x3 = x2 * ax;
                let v = if ax < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * x3
                        + (-18.0 + 12.0 * b + 6.0 * c) * x2
                        + (6.0 - 2.0 * b)
                } else if ax < 2.0 {
                    (-b - 6.0 * c) * x3
                        + (6.0 * b + 30.0 * c) * x2
                        + (-12.0 * b - 48.0 * c) * ax
                        + (8.0 * b + 24.0 * c)
                } else {
                    0.0
                };
                v / 6.0
            }
            ReconstructionFilter::Lanczos { lobes } => {
                let n = lobes as f32;
                if ax < 1e-6 {
                    1.0
                } else if ax >= n {
                    0.0
                } else {
                    let x1 = PI * ax;
                    let x2 = x1 / n;
                    (x1.sin() * x2.sin()) / (x1 * x2)
                }
            }
        }
    }

    /// Fills `out[i]` with the weight at offset `x0 + i`, hoisting per-filter constants out of the loop
    /// (used by image blocks to evaluate one axis of a splat).
    #[inline]
    pub fn eval_row(&self, x0: f32, out: &mut [f32]) {
        if let ReconstructionFilter::Gaussian { stddev } = *self {
            let alpha = -1.0 / (2.0 * stddev * stddev);
            let r = 4.0 * stddev;
            let bias = (alpha * r * r).exp();
            for (i, w) in out.iter_mut().enumerate() {
                let x = x0 + i as f32;
                *w = ((alpha * x * x).exp() - bias).max(0.0);
            }
        } else {
            for (i, w) in out.iter_mut().enumerate() {
                *w = self.eval(x0 + i as f32);
            }
        }
    }

    /// The Mitsuba plugin name of this filter.
    pub fn plugin_name(&self) -> &'static str {
        match self {
            ReconstructionFilter::Box => "box",
            ReconstructionFilter::Tent { .. } => "tent",
            ReconstructionFilter::Gaussian { .. } => "gaussian",
            ReconstructionFilter::Mitchell { b, c } if *b == 0.0 && *c == 0.5 => "catmullrom",
            ReconstructionFilter::Mitchell { .. } => "mitchell",
            ReconstructionFilter::Lanczos { .. } => "lanczos",
        }
    }
}

/// Builds the filter of a film's `<rfilter>` child; `None` gives Mitsuba's default Gaussian (σ = 0.5).
/// Unknown plugins and invalid parameters are scene errors.
pub fn filter_from_desc(rfilter: Option<&ObjectDesc>) -> SceneResult<ReconstructionFilter> {
    let Some(d) = rfilter else {
        return Ok(ReconstructionFilter::default());
    };
    let positive = |name: &str, v: f64| -> SceneResult<f32> {
        if v > 0.0 && v.is_finite() {
            Ok(v as f32)
        } else {
            Err(d.error(format!(
                "rfilter '{}': {name} must be positive, got {v}",
                d.plugin
            )))
        }
    };
    let bounded = |f: ReconstructionFilter| -> SceneResult<ReconstructionFilter> {
        if f.radius() <= MAX_FILTER_RADIUS {
            Ok(f)
        } else {
            Err(d.error(format!(
                "rfilter '{}': radius {} px exceeds the maximum of {MAX_FILTER_RADIUS} px",
                d.plugin,
                f.radius()
            )))
        }
    };
    // Mitsuba writes the Mitchell parameters as "B" and "C"; accept either case.
    let param = |upper: &str, lower: &str, default: f64| -> SceneResult<f64> {
        match d.float_opt(upper)? {
            Some(v) => Ok(v),
            None => d.float_or(lower, default),
        }
    };
    let finite = |name: &str, v: f64| -> SceneResult<f32> {
        if v.is_finite() {
            Ok(v as f32)
        } else {
            Err(d.error(format!("rfilter '{}': {name} must be finite", d.plugin)))
        }
    };
    match d.plugin.as_str() {
        "box" => Ok(ReconstructionFilter::Box),
        "tent" => bounded(ReconstructionFilter::Tent {
            radius: positive("radius", d.float_or("radius", 1.0)?)?,
        }),
        "gaussian" => bounded(ReconstructionFilter::Gaussian {
            stddev: positive("stddev", d.float_or("stddev", 0.5)?)?,
        }),
        "mitchell" => Ok(ReconstructionFilter::Mitchell {
            b: finite("B", param("B", "b", 1.0 / 3.0)?)?,
            c: finite("C", param("C", "c", 1.0 / 3.0)?)?,
        }),
        "catmullrom" => Ok(ReconstructionFilter::Mitchell { b: 0.0, c: 0.5 }),
        "lanczos" => {
            let lobes = d.int_or("lobes", 3)?;
            if !(1..=MAX_FILTER_RADIUS as i64).contains(&lobes) {
                return Err(d.error(format!(
                    "rfilter 'lanczos': lobes must be in 1..={MAX_FILTER_RADIUS}, got {lobes}"
                )));
            }
            Ok(ReconstructionFilter::Lanczos { lobes: lobes as u32 })
        }
        other => Err(d.error(format!(
            "unsupported reconstruction filter '{other}' (supported: box, tent, gaussian, mitchell, \
             catmullrom, lanczos)"
        ))),
    }
}
