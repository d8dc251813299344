//! Special functions in `f64` for the exact directional pdf and the truncated sampling:
//!
//! - erf, erfc and the scaled erfcx. The rational approximations are those of FreeBSD's `s_erf.c`
//!   (fdlibm), whose notice is kept here as its licence asks:
//!
//!   > Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
//!   > Developed at SunPro, a Sun Microsystems, Inc. business. Permission to use, copy, modify, and
//!   > distribute this software is freely granted, provided that this notice is preserved.
//!
//!   erfcx reuses fdlibm's form erfc(x) = exp(−x² − 0.5625 + R(1/x²)/S(1/x²)) / x for x ≥ 1.25, in
//!   which the exp(−x²) factor drops out exactly, so erfcx keeps full relative accuracy.
//! - Φ, Φ(b) − Φ(a) and Φ⁻¹ (Acklam's approximation refined against erfc), accurate in both tails.
//! - H(β) = ∫₀^∞ v² e^{−βv − v²/2} dv, the function behind the half-line t²-moment (see
//!   [`half_line_h`]), and the Mills ratio R(β) = Φ(−β)/φ(β), from polynomial fits computed once in
//!   50-digit arithmetic (mpmath): they avoid the catastrophic cancellation of H = (1 + β²)R − β and any
//!   erfc call in the per-component hot loops, and have branch-free variants that vectorise.
//! - [`exp_fast`], a branch-free exp that vectorises and is identical on every machine.

// The fdlibm coefficients are kept digit for digit as published (so they can be checked against the
// source); they round to the intended f64 values.
#![allow(clippy::excessive_precision)]

use std::f64::consts::{FRAC_1_SQRT_2, PI};

/// √(2π).
pub const SQRT_2PI: f64 = 2.506_628_274_631_000_7;
/// ln √(2π).
pub const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

const ERX: f64 = 8.45062911510467529297e-01;
const EFX8: f64 = 1.02703333676410069053e+00;
const PP0: f64 = 1.28379167095512558561e-01;
const PP1: f64 = -3.25042107247001499370e-01;
const PP2: f64 = -2.84817495755985104766e-02;
const PP3: f64 = -5.77027029648944159157e-03;
const PP4: f64 = -2.37630166566501626084e-05;
const QQ1: f64 = 3.97917223959155352819e-01;
const QQ2: f64 = 6.50222499887672944485e-02;
const QQ3: f64 = 5.08130628187576562776e-03;
const QQ4: f64 = 1.32494738004321644526e-04;
const QQ5: f64 = -3.96022827877536812320e-06;
const PA0: f64 = -2.36211856075265944077e-03;
const PA1: f64 = 4.14856118683748331666e-01;
const PA2: f64 = -3.72207876035701323847e-01;
const PA3: f64 = 3.18346619901161753674e-01;
const PA4: f64 = -1.10894694282396677476e-01;
const PA5: f64 = 3.54783043256182359371e-02;
const PA6: f64 = -2.16637559486879084300e-03;
const QA1: f64 = 1.06420880400844228286e-01;
const QA2: f64 = 5.40397917702171048937e-01;
const QA3: f64 = 7.18286544141962662868e-02;
const QA4: f64 = 1.26171219808761642112e-01;
const QA5: f64 = 1.36370839120290507362e-02;
const QA6: f64 = 1.19844998467991074170e-02;
const RA0: f64 = -9.86494403484714822705e-03;
const RA1: f64 = -6.93858572707181764372e-01;
const RA2: f64 = -1.05586262253232909814e+01;
const RA3: f64 = -6.23753324503260060396e+01;
const RA4: f64 = -1.62396669462573470355e+02;
const RA5: f64 = -1.84605092906711035994e+02;
const RA6: f64 = -8.12874355063065934246e+01;
const RA7: f64 = -9.81432934416914548592e+00;
const SA1: f64 = 1.96512716674392571292e+01;
const SA2: f64 = 1.37657754143519042600e+02;
const SA3: f64 = 4.34565877475229228821e+02;
const SA4: f64 = 6.45387271733267880336e+02;
const SA5: f64 = 4.29008140027567833386e+02;
const SA6: f64 = 1.08635005541779435134e+02;
const SA7: f64 = 6.57024977031928170135e+00;
const SA8: f64 = -6.04244152148580987438e-02;
const RB0: f64 = -9.86494292470009928597e-03;
const RB1: f64 = -7.99283237680523006574e-01;
const RB2: f64 = -1.77579549177547519889e+01;
const RB3: f64 = -1.60636384855821916062e+02;
const RB4: f64 = -6.37566443368389627722e+02;
const RB5: f64 = -1.02509513161107724954e+03;
const RB6: f64 = -4.83519191608651397019e+02;
const SB1: f64 = 3.03380607434824582924e+01;
const SB2: f64 = 3.25792512996573918826e+02;
const SB3: f64 = 1.53672958608443695994e+03;
const SB4: f64 = 3.19985821950859553908e+03;
const SB5: f64 = 2.55305040643316442583e+03;
const SB6: f64 = 4.74528541206955367215e+02;
const SB7: f64 = -2.24409524465858183362e+01;

/// erf(x) − x on |x| < 0.84375, as x·R(x²).
#[inline]
fn erf_small_correction(x: f64) -> f64 {
    let z = x * x;
    let r = PP0 + z * (PP1 + z * (PP2 + z * (PP3 + z * PP4)));
    let s = 1.0 + z * (QQ1 + z * (QQ2 + z * (QQ3 + z * (QQ4 + z * QQ5))));
    x * (r / s)
}

/// erf(1 + s) − ERX for |x| = 1 + s in [0.84375, 1.25].
#[inline]
fn erf_near_one(ax: f64) -> f64 {
    let s = ax - 1.0;
    let p = PA0 + s * (PA1 + s * (PA2 + s * (PA3 + s * (PA4 + s * (PA5 + s * PA6)))));
    let q = 1.0 + s * (QA1 + s * (QA2 + s * (QA3 + s * (QA4 + s * (QA5 + s * QA6)))));
    p / q
}

/// R/S with erfc(x) = exp(−x² − 0.5625 + R/S)/x, for x in [1.25, 28].
#[inline]
fn erfc_tail_ratio(ax: f64) -> f64 {
    let s = 1.0 / (ax * ax);
    let (r, big_s) = if ax < 1.0 / 0.35 {
        (
            RA0 + s * (RA1 + s * (RA2 + s * (RA3 + s * (RA4 + s * (RA5 + s * (RA6 + s * RA7)))))),
            1.0 + s
                * (SA1
                    + s * (SA2
                        + s * (SA3 + s * (SA4 + s * (SA5 + s * (SA6 + s * (SA7 + s * SA8))))))),
        )
    } else {
        (
            RB0 + s * (RB1 + s * (RB2 + s * (RB3 + s * (RB4 + s * (RB5 + s * RB6))))),
            1.0 + s * (SB1 + s * (SB2 + s * (SB3 + s * (SB4 + s * (SB5 + s * (SB6 + s * SB7)))))),
        )
    };
    r / big_s
}

/// erfc(x) for x in [1.25, 28]; exp(−x²) is split as fdlibm does so its rounding error stays one ulp.
#[inline]
fn erfc_tail(ax: f64) -> f64 {
    let z = f64::from_bits(ax.to_bits() & 0xffff_ffff_0000_0000);
    exp_fast(-z * z - 0.5625) * exp_fast((z - ax) * (z + ax) + erfc_tail_ratio(ax)) / ax
}

/// The error function.
pub fn erf(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let ax = x.abs();
    if ax < 0.84375 {
        if ax < 3.725_290_298_461_914e-9 {
            return 0.125 * (8.0 * x + EFX8 * x);
        }
        return x + erf_small_correction(x);
    }
    let y = if ax < 1.25 {
        ERX + erf_near_one(ax)
    } else if ax < 6.0 {
        1.0 - erfc_tail(ax)
    } else {
        1.0
    };
    if x < 0.0 {
        -y
    } else {
        y
    }
}

/// The complementary error function 1 − erf(x), with full relative accuracy in the upper tail.
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let ax = x.abs();
    if ax < 0.84375 {
        if ax < 1.387_778_780_781_445_7e-17 {
            return 1.0 - x;
        }
        let y = erf_small_correction(x);
        if x < 0.25 {
            return 1.0 - (x + y);
        }
        return 0.5 - (x - 0.5 + y);
    }
    if ax < 1.25 {
        let tail = 1.0 - ERX - erf_near_one(ax);
        return if x > 0.0 { tail } else { 2.0 - tail };
    }
    if ax < 28.0 {
        let tail = erfc_tail(ax);
        return if x > 0.0 { tail } else { 2.0 - tail };
    }
    if x > 0.0 {
        0.0
    } else {
        2.0
    }
}

/// The scaled complementary error function exp(x²)·erfc(x). Accurate to a few ulp for x ≥ 0, where it
/// never overflows or underflows; for x < 0 it grows like 2·exp(x²) and overflows below about −26.6.
pub fn erfcx(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x < 0.0 {
        return 2.0 * (x * x).exp() - erfcx(-x);
    }
    if x < 1.25 {
        return (x * x).exp() * erfc(x);
    }
    if x < 28.0 {
        return exp_fast(erfc_tail_ratio(x) - 0.5625) / x;
    }
    if x.is_infinite() {
        return 0.0;
    }
    // Asymptotic series Σ (−1)^n (2n−1)!! / (2x²)^n; at x ≥ 28 the eighth term is below 1e-17.
    let inv = 1.0 / (2.0 * x * x);
    let mut term = 1.0;
    let mut sum = 1.0;
    for n in 1..8 {
        term *= -((2 * n - 1) as f64) * inv;
        sum += term;
    }
    sum / (x * PI.sqrt())
}

/// The standard normal CDF Φ(x), accurate in relative terms in the lower tail (via erfc).
#[inline]
pub fn norm_cdf(x: f64) -> f64 {
    0.5 * erfc(-x * FRAC_1_SQRT_2)
}

/// The standard normal survival function 1 − Φ(x) = Φ(−x), accurate in relative terms in the upper tail.
#[inline]
pub fn norm_sf(x: f64) -> f64 {
    0.5 * erfc(x * FRAC_1_SQRT_2)
}

/// Φ(b) − Φ(a) for a ≤ b, without cancellation: both tails use the survival form on their side, and a
/// straddling interval uses erf, which is accurate in relative terms near 0 (narrow intervals).
pub fn norm_interval(a: f64, b: f64) -> f64 {
    if !(a < b) {
        return 0.0;
    }
    let d = if b <= 0.0 {
        norm_cdf(b) - norm_cdf(a)
    } else if a >= 0.0 {
        norm_sf(a) - norm_sf(b)
    } else {
        0.5 * (erf(b * FRAC_1_SQRT_2) - erf(a * FRAC_1_SQRT_2))
    };
    d.max(0.0)
}

/// Φ⁻¹ on (0, 0.5]: Acklam's rational approximation (relative error 1.15e-9) refined by one Halley
/// step against erfc, which brings it to the accuracy of erfc.
fn inv_norm_cdf_lower(p: f64) -> f64 {
    let x = acklam_lower(p);
    if p < 1e-16 {
        return refine_log_quantile(x, p.ln());
    }
    let e = norm_cdf(x) - p;
    let u = e * SQRT_2PI * (0.5 * x * x).exp();
    let refined = x - u / (1.0 + 0.5 * x * u);
    if refined.is_finite() {
        refined
    } else {
        x
    }
}

/// Acklam's rational approximation of Φ⁻¹ on (0, 0.5] (relative error below 1.15e-9).
fn acklam_lower(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e+01,
        2.209460984245205e+02,
        -2.759285104469687e+02,
        1.383577518672690e+02,
        -3.066479806614716e+01,
        2.506628277459239e+00,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e+01,
        1.615858368580409e+02,
        -1.556989798598866e+02,
        6.680131188771972e+01,
        -1.328068155288572e+01,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-03,
        -3.223964580411365e-01,
        -2.400758277161838e+00,
        -2.549732539343734e+00,
        4.374664141464968e+00,
        2.938163982698783e+00,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-03,
        3.224671290700398e-01,
        2.445134137142996e+00,
        3.754408661907416e+00,
    ];
    if p < 0.02425 {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Newton on ln Φ(x) = `log_p` for the far lower tail, where Acklam's start is too coarse for one Halley
/// step: ln Φ is nearly quadratic there, and both it and its derivative φ/Φ = 1/(√(π/2)·erfcx(−x/√2))
/// are computed without underflow.
fn refine_log_quantile(mut x: f64, log_p: f64) -> f64 {
    for _ in 0..16 {
        let r = (PI / 2.0).sqrt() * erfcx(-x * FRAC_1_SQRT_2);
        let log_cdf = (0.5 * erfcx(-x * FRAC_1_SQRT_2)).ln() - 0.5 * x * x;
        let step = (log_cdf - log_p) * r;
        if !step.is_finite() {
            break;
        }
        x -= step;
        if step.abs() <= 1e-15 * x.abs() {
            break;
        }
    }
    x
}

/// The standard normal quantile Φ⁻¹(p); −∞ at 0, +∞ at 1. The upper half is computed as −Φ⁻¹(1 − p),
/// where 1 − p is exact, so both tails keep their relative accuracy.
pub fn inv_norm_cdf(p: f64) -> f64 {
    quantile_by_halves(p, inv_norm_cdf_lower)
}

/// Φ⁻¹(p) to Acklam's relative accuracy of 1.15e-9, without the refinement of [`inv_norm_cdf`]: for
/// drawing unconstrained normal variates, where an error that small only moves each sample by 1e-9 of
/// itself (the pdf is evaluated at the direction actually drawn) and the refinement's erfc and exp
/// would double the cost. −∞ at 0, +∞ at 1.
pub fn inv_norm_cdf_approx(p: f64) -> f64 {
    quantile_by_halves(p, acklam_lower)
}

/// Φ⁻¹(p) from a quantile `lower` of the lower half (0, 0.5], by symmetry above; NaN, −∞ and +∞ at
/// NaN, p ≤ 0 and p ≥ 1.
#[inline]
fn quantile_by_halves(p: f64, lower: fn(f64) -> f64) -> f64 {
    if p.is_nan() {
        return p;
    }
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    if p > 0.5 {
        -lower(1.0 - p)
    } else {
        lower(p)
    }
}

/// Maps a uniform number in [0, 1] into [2⁻⁵³, 1 − 2⁻⁵³], so quantiles stay finite (|z| ≤ 8.2).
#[inline]
pub fn open_unit(u: f64) -> f64 {
    const LO: f64 = 1.0 / 9_007_199_254_740_992.0;
    u.clamp(LO, 1.0 - LO)
}

/// β³H(β)/2 on β ∈ [3, 6] as a polynomial in t = (2β − 9)/3: the Chebyshev interpolant of degree 20,
/// computed in 40-digit arithmetic and converted to monomials (relative error 1.8e-16 in f64).
#[rustfmt::skip]
const H_NEAR: [f64; 21] = [
    0.7802502670390606,
    0.11027503331871145,
    -0.037713573923344394,
    0.010189501265795115,
    -0.0021597688024135864,
    0.0002940659320524345,
    1.843647839822977e-05,
    -3.1838821101733687e-05,
    1.4718187567603742e-05,
    -5.064773490744701e-06,
    1.4725183395406713e-06,
    -3.736173571594184e-07,
    8.208734620660461e-08,
    -1.4662839824937886e-08,
    1.5624554390606373e-09,
    2.629570005167508e-10,
    -2.38009183433271e-10,
    8.83354212186078e-11,
    -3.178672023599412e-11,
    1.6154285750655173e-11,
    -4.4526141998300305e-12,
];

/// β³H(β)/2 on β ≥ 6 as a polynomial in t = 2ν − 1, ν = 36/β² (the function is smooth in ν down to
/// ν = 0, where it tends to 1): Chebyshev interpolant of degree 16 (relative error 1.3e-16).
#[rustfmt::skip]
const H_FAR: [f64; 17] = [
    0.9243710595027881,
    -0.06877385853538438,
    0.006114046087352613,
    -0.0006483297349336985,
    7.961453253714859e-05,
    -1.1044200763331625e-05,
    1.6979706024867623e-06,
    -2.850944404832774e-07,
    5.167692294669677e-08,
    -1.0018926157403145e-08,
    2.0622675800635983e-09,
    -4.4901354223718326e-10,
    1.0242398780950851e-10,
    -2.3193289238186924e-11,
    5.707208124889598e-12,
    -2.1563993410493003e-12,
    5.866729435914434e-13,
];

/// ln H(β) on β ∈ [0, 3] as a polynomial in t = (2β − 3)/3 (Chebyshev interpolant of degree 18 from
/// 50-digit arithmetic; absolute error 5e-16, i.e. H to 5e-16 relative).
#[rustfmt::skip]
const LN_H_LOW: [f64; 19] = [
    -1.73499646303725,
    -1.5982225412805826,
    0.2998419953306623,
    -0.05497579930889324,
    0.007616672909615537,
    -0.00036714210791410044,
    -0.0001729953832809672,
    5.875402095262849e-05,
    -6.861789437302245e-06,
    -1.352783831918814e-06,
    7.950471539861831e-07,
    -1.4972991425522835e-07,
    -6.467459851810273e-09,
    1.197306080743576e-08,
    -3.2622851201795694e-09,
    1.6019827836274315e-10,
    1.8171005107338596e-10,
    -5.5075009176295886e-11,
    3.299424220745476e-12,
];

/// ln R(β) of the Mills ratio R(β) = Φ(−β)/φ(β) on β ∈ [0, 3], t = (2β − 3)/3 (degree 18, absolute
/// error 4e-16).
#[rustfmt::skip]
const LN_R_LOW: [f64; 19] = [
    -0.6620058676192171,
    -0.6580157499338097,
    0.16823991774397848,
    -0.04677295748876143,
    0.01195661924334465,
    -0.0025368898639430448,
    0.00035005836993367054,
    2.161761171895861e-05,
    -3.562760154587069e-05,
    1.4236202735071063e-05,
    -3.4658473612905824e-06,
    3.3845605489595207e-07,
    1.612181078428169e-07,
    -1.0862413300771969e-07,
    3.720887993927565e-08,
    -8.053159179127745e-09,
    -1.53223649889361e-10,
    1.218095156568107e-09,
    -3.9337143432966895e-10,
];

/// βR(β) on β ∈ [3, 6], t = (2β − 9)/3 (degree 18, relative error 1.2e-16).
#[rustfmt::skip]
const R_NEAR: [f64; 19] = [
    0.9565676119891431,
    0.02568725158976344,
    -0.011028398908976968,
    0.0040842604932780505,
    -0.0013791095993116451,
    0.00043559856853309266,
    -0.00013055093026863733,
    3.746106507304286e-05,
    -1.0355024233409236e-05,
    2.7696610762830943e-06,
    -7.192389353265786e-07,
    1.818105920643472e-07,
    -4.4839468212600504e-08,
    1.0825923674807617e-08,
    -2.553634062078412e-09,
    5.738347399755721e-10,
    -1.3043027209885748e-10,
    3.7373046729469234e-11,
    -8.12719279322559e-12,
];

/// βR(β) on β ≥ 6 as a polynomial in t = 2ν − 1, ν = 36/β² (degree 12, relative error 1.1e-16).
#[rustfmt::skip]
const R_FAR: [f64; 13] = [
    0.9866531092311654,
    -0.012838486937538312,
    0.000477596239828966,
    -2.830576893443469e-05,
    2.2511449155431056e-06,
    -2.2115138765528305e-07,
    2.556525902933181e-08,
    -3.369300655290136e-09,
    4.950252074101069e-10,
    -7.923769793201831e-11,
    1.3801548781552988e-11,
    -2.998826502834945e-12,
    6.066387913620395e-13,
];

/// ln H(β) for β ∈ [0, 3] (see [`half_line_t2_moment_scaled`]).
#[inline(always)]
pub fn ln_h_low(beta: f64) -> f64 {
    poly4(&LN_H_LOW, t_low(beta))
}

/// The Mills ratio R(β) = Φ(−β)/φ(β) for β ≥ 0, from polynomial fits (no erfc).
#[inline]
pub fn mills_ratio(beta: f64) -> f64 {
    if beta <= 3.0 {
        exp_fast(poly4(&LN_R_LOW, t_low(beta)))
    } else {
        let inv = 1.0 / beta;
        if beta < 6.0 {
            poly4(&R_NEAR, t_near(beta)) * inv
        } else {
            poly4(&R_FAR, (72.0 * inv).mul_add(inv, -1.0)) * inv
        }
    }
}

/// Φ(k) from the Mills ratio: φ(k)R(−k) for k ≤ 0 and 1 − φ(k)R(k) above (no erfc, no cancellation;
/// relative accuracy ~1e-15, ~k²·1e-16 far in the lower tail from rounding k²). Used where Φ is needed
/// for every component in the hot loop; [`norm_cdf`] is the erfc-based reference.
#[inline]
pub fn norm_cdf_fast(k: f64) -> f64 {
    const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;
    let beta = k.abs();
    // Beyond 37.5 the lower tail is below 1e-307 (and e^{−k²/2} would leave exp_fast's range).
    if beta > 37.5 {
        return if k > 0.0 { 1.0 } else { 0.0 };
    }
    let tail = INV_SQRT_2PI * exp_fast(-0.5 * k * k) * mills_ratio(beta);
    if k <= 0.0 {
        tail
    } else {
        1.0 - tail
    }
}

/// Φ(b) − Φ(a) for a ≤ b from [`norm_cdf_fast`] (no erfc): each tail on its own side, a straddling
/// interval as 1 − Φ(a) − Φ(−b). Relative accuracy ~1e-15 unless the interval is narrower than ~1e-6
/// around 0 (use [`norm_interval`] where that matters); narrowing only needs it to ~1e-9.
#[inline]
pub fn norm_interval_fast(a: f64, b: f64) -> f64 {
    if !(a < b) {
        return 0.0;
    }
    let d = if b <= 0.0 {
        norm_cdf_fast(b) - norm_cdf_fast(a)
    } else if a >= 0.0 {
        norm_cdf_fast(-a) - norm_cdf_fast(-b)
    } else {
        1.0 - norm_cdf_fast(a) - norm_cdf_fast(-b)
    };
    d.max(0.0)
}

/// H(β) for β ≥ 0 without branches (all three fits evaluated on clamped arguments, one selected), for
/// loops over components that should vectorise. Agrees with [`half_line_h`] to rounding.
#[inline(always)]
pub fn half_line_h_branchless(beta: f64) -> f64 {
    let low = exp_fast(poly4(&LN_H_LOW, t_low(beta.min(3.0))));
    let bn = beta.clamp(3.0, 6.0);
    let near = poly4(&H_NEAR, t_near(bn));
    let inv = 1.0 / beta.max(3.0);
    let inv_far = inv.min(1.0 / 6.0);
    let far = poly4(&H_FAR, (72.0 * inv_far).mul_add(inv_far, -1.0));
    let tail = 2.0 * (if beta < 6.0 { near } else { far }) * (inv * inv * inv);
    if beta <= 3.0 {
        low
    } else {
        tail
    }
}

/// Φ(k) without branches (see [`norm_cdf_fast`], which it matches to rounding), for vectorised loops.
#[inline(always)]
pub fn norm_cdf_branchless(k: f64) -> f64 {
    const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;
    let beta = k.abs();
    let low = exp_fast(poly4(&LN_R_LOW, t_low(beta.min(3.0))));
    let bn = beta.clamp(3.0, 6.0);
    let near = poly4(&R_NEAR, t_near(bn));
    let inv = 1.0 / beta.max(3.0);
    let inv_far = inv.min(1.0 / 6.0);
    let far = poly4(&R_FAR, (72.0 * inv_far).mul_add(inv_far, -1.0));
    let r = if beta <= 3.0 {
        low
    } else {
        (if beta < 6.0 { near } else { far }) * inv
    };
    let tail = INV_SQRT_2PI * exp_fast(-0.5 * k * k) * r;
    let tail = if beta > 37.5 { 0.0 } else { tail };
    if k <= 0.0 {
        tail
    } else {
        1.0 - tail
    }
}

/// The fit variable t = (2β − 3)/3 of the [0, 3] fits (as a multiply-add: no division).
#[inline(always)]
fn t_low(beta: f64) -> f64 {
    beta.mul_add(2.0 / 3.0, -1.0)
}

/// The fit variable t = (2β − 9)/3 of the [3, 6] fits.
#[inline(always)]
fn t_near(beta: f64) -> f64 {
    beta.mul_add(2.0 / 3.0, -3.0)
}

/// Σ c_k t^k split four ways by k mod 4 and evaluated in t⁴, so the dependency chains are a quarter as
/// long as Horner's.
#[inline(always)]
fn poly4<const N: usize>(c: &[f64; N], t: f64) -> f64 {
    let t2 = t * t;
    let t4 = t2 * t2;
    let mut p = [0.0f64; 4];
    let top = (N - 1) / 4;
    for level in (0..=top).rev() {
        for (r, acc) in p.iter_mut().enumerate() {
            let k = 4 * level + r;
            let coef = if k < N { c[k] } else { 0.0 };
            *acc = acc.mul_add(t4, coef);
        }
    }
    p[3].mul_add(t, p[2]).mul_add(t2, p[1].mul_add(t, p[0]))
}

/// H(β) = ∫₀^∞ v² exp(−βv − v²/2) dv for β ≥ 3. H = (1 + β²)R(β) − β with R the Mills ratio, but that
/// difference cancels catastrophically (H ≈ 2/β³), so H is evaluated from the polynomial fits
/// [`H_NEAR`], [`H_FAR`] of β³H/2 (validated against mpmath to 4e-16 in the tests).
#[inline]
pub fn h_tail(beta: f64) -> f64 {
    let inv = 1.0 / beta;
    let scaled = if beta < 6.0 {
        poly4(&H_NEAR, t_near(beta))
    } else {
        poly4(&H_FAR, (72.0 * inv).mul_add(inv, -1.0))
    };
    2.0 * scaled * (inv * inv * inv)
}

/// H(β) = ∫₀^∞ v² exp(−βv − v²/2) dv for β ≥ 0 (ln H fit below 3, [`h_tail`] above).
///
/// H is the one function behind the half-line t²-moment G(α) = ∫₀^∞ τ² exp(−(τ − α)²/2) dτ
/// = √(2π)(1 + α²)Φ(α) + α e^{−α²/2}: substituting τ = v − α gives G(α) = e^{−α²/2} H(−α) for every α,
/// and, since H(−α) = √(2π)(1 + α²)e^{α²/2} − H(α), also G(α) = √(2π)(1 + α²) − e^{−α²/2} H(α). The
/// first form is used for α ≤ 0 and the second for α > 0; neither cancels by more than a factor 2.
#[inline]
pub fn half_line_h(beta: f64) -> f64 {
    if beta <= 3.0 {
        exp_fast(ln_h_low(beta))
    } else {
        h_tail(beta)
    }
}

/// G(α) = ∫₀^∞ τ² exp(−(τ − α)²/2) dτ = √(2π)(1 + α²)Φ(α) + α exp(−α²/2), the t²-moment of a unit
/// Gaussian along a half-line: with τ = t/s and α = m/s, ∫₀^∞ exp(−(t − m)²/(2s²)) t² dt = s³ G(α)
/// (see [`half_line_h`] for the evaluation). Underflows to 0 for α ≲ −38; use
/// [`half_line_t2_moment_scaled`] there.
pub fn half_line_t2_moment(alpha: f64) -> f64 {
    if alpha <= 0.0 {
        exp_fast(-0.5 * alpha * alpha) * half_line_h(-alpha)
    } else {
        SQRT_2PI * alpha.mul_add(alpha, 1.0) - exp_fast(-0.5 * alpha * alpha) * half_line_h(alpha)
    }
}

/// G(α)·exp(α²/2) = H(−α) (see [`half_line_h`]), which stays representable for α ≪ 0 (it decays like
/// 2/|α|³), so callers can fold exp(−α²/2) into their own exponent. Overflows for α ≳ 37.
pub fn half_line_t2_moment_scaled(alpha: f64) -> f64 {
    if alpha <= 0.0 {
        half_line_h(-alpha)
    } else {
        let e = (0.5 * alpha * alpha).exp();
        SQRT_2PI * alpha.mul_add(alpha, 1.0) * e - half_line_h(alpha)
    }
}

/// e^x for |x| ≤ 708 in plain IEEE arithmetic (no libm call, no branches; `mul_add` is exactly rounded
/// whether or not the CPU has FMA), so loops of it vectorise and give the same bits on every machine;
/// relative error below 3e-16. Arguments outside are clamped to ±708 (callers only use such values
/// where they do not matter, e.g. added to sums ≥ 1).
#[inline(always)]
pub fn exp_fast(x: f64) -> f64 {
    const SHIFTER: f64 = 6_755_399_441_055_744.0; // 1.5·2⁵², rounds x/ln 2 to an integer
    const LN2_HI: f64 = 6.931_471_803_691_238_2e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let x = x.clamp(-708.0, 708.0);
    let t = x.mul_add(std::f64::consts::LOG2_E, SHIFTER);
    let n = t - SHIFTER;
    let r = n.mul_add(-LN2_LO, n.mul_add(-LN2_HI, x));
    // Taylor polynomial of e^r on |r| ≤ ln2/2, degree 12 (truncation error < 2e-16), in Estrin's
    // scheme: four levels of independent multiply-adds instead of a 12-deep Horner chain.
    const C: [f64; 13] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5_040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
    ];
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let a0 = C[1].mul_add(r, C[0]);
    let a1 = C[3].mul_add(r, C[2]);
    let a2 = C[5].mul_add(r, C[4]);
    let a3 = C[7].mul_add(r, C[6]);
    let a4 = C[9].mul_add(r, C[8]);
    let a5 = C[11].mul_add(r, C[10]);
    let b0 = a1.mul_add(r2, a0);
    let b1 = a3.mul_add(r2, a2);
    let b2 = a5.mul_add(r2, a4);
    let c0 = b1.mul_add(r4, b0);
    let c1 = C[12].mul_add(r4, b2);
    let p = c1.mul_add(r8, c0);
    let k = t.to_bits().wrapping_sub(SHIFTER.to_bits());
    p * f64::from_bits(k.wrapping_add(1023) << 52)
}
