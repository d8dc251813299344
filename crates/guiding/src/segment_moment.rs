//! What a recorded segment says about other guide fractions: the importance-reweighted second moment
//! its vertex would have had had the guide been sampled with another probability.
//!
//! A segment was sampled with p₀ = α₀·p_g + (1 − α₀)·p_b and carries c, which holds 1/p₀, so for a
//! fraction a with p_a = a·p_g + (1 − a)·p_b, c²·p₀/p_a is an unbiased estimate of that vertex's second
//! moment under p_a, provided the integrand c·p₀ does not itself depend on a. Emission found at x_{k+1}
//! breaks that: its MIS weight against next-event estimation depends on p_a, and where NEE samples a
//! light well (the Cornell box's ceiling lamp) a small a hands that light to NEE rather than losing it.
//! Taken as it was sampled, a guide that merely points at a directly visible light looks irreplaceable.
//! So the emitted part F (the unweighted integrand) is split off and both of its estimators are
//! reweighted: the direction sample's F·w_a/p_a and NEE's F·w_n/p_n, with power-heuristic weights w_a
//! and w_n = 1 − w_a. Their sum of second moments is what a costs for direct light; the two strategies'
//! samples are independent, so variances add (the small difference of their squared means is
//! neglected).

use crate::TrainingSegment;

impl TrainingSegment {
    /// The second moment, times `pixel_weight`, that this segment's vertex estimate (direction sample
    /// plus, for the emission at x_{k+1}, next-event estimation) would have had with guide fraction `a`,
    /// estimated from this one sample. Infinite if p_a = 0 where the segment carries contribution; `None`
    /// if the segment's own numbers are invalid (non-positive pdf, non-finite values).
    pub fn second_moment_with_fraction(&self, a: f32) -> Option<f64> {
        let (p0, pg, pb) = (self.pdf as f64, self.guide_pdf as f64, self.bsdf_pdf as f64);
        let c = self.weight as f64;
        let pixel = self.pixel_weight as f64;
        let pn = self.emitter_pdf as f64;
        let valid = p0 > 0.0
            && p0.is_finite()
            && pg >= 0.0
            && pg.is_finite()
            && pb >= 0.0
            && pb.is_finite()
            && c >= 0.0
            && c.is_finite()
            && pixel >= 0.0
            && pixel.is_finite()
            && pn >= 0.0
            && pn.is_finite()
            && self.emitted.is_finite();
        if !valid {
            return None;
        }
        let a = a.clamp(0.0, 1.0) as f64;
        let pa = a * pg + (1.0 - a) * pb;
        let emitted = (self.emitted as f64).clamp(0.0, c);
        let deeper = c - emitted;
        let power = |p: f64, q: f64| p * p / (p * p + q * q);
        let moment = if emitted > 0.0 && pn > 0.0 {
            // F/p₀: the emission before its MIS weight.
            let unweighted = emitted / power(p0, pn);
            let nee = unweighted * unweighted * p0 * power(pn, pa).powi(2) / pn;
            if pa > 0.0 {
                let direction = deeper + unweighted * power(pa, pn);
                p0 / pa * direction * direction + nee
            } else if deeper > 0.0 {
                f64::INFINITY
            } else {
                nee
            }
        } else if pa > 0.0 {
            c * c * p0 / pa
        } else if c > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        Some(if pixel > 0.0 { moment * pixel } else { 0.0 })
    }
}
