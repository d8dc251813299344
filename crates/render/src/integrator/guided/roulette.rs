//! Russian roulette of guided paths.

use super::PathState;
use crate::integrator::path_trace::PathObserver;
use crate::sampler::Sampler;

/// How a guided path decides to terminate.
///
/// Mitsuba's throughput-based roulette kills exactly the low-throughput prefixes that guiding makes
/// worthwhile: a guided direction through a pinhole has a tiny weight f·cos/p_mix with a huge radiance
/// behind it, so it is killed with high probability, which undoes the gain (Rath et al.'s README; they use
/// no roulette at all). But with no roulette, a closed room under an unlimited `max_depth` has paths of
/// thousands of bounces. The default therefore survives with the product of the BSDF *albedos* along the
/// path instead of the throughput: it terminates paths as fast as the path tracer does in expectation (the
/// mean BSDF-sampling weight is the albedo), whatever the guide chose. Unguided paths (the first
/// iteration, or a render that fell back to path tracing) have no guided prefixes to protect and use
/// the throughput roulette instead: it puts the samples where the throughput is
/// (docs/experiments/2026-12-01-unguided-roulette.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Roulette {
    /// No roulette (Rath et al.; set a `max_depth`).
    Off,
    /// Mitsuba's: survival min(0.95, max throughput · η²) from `rr_depth`.
    Throughput,
    /// Survival min(0.95, Π albedo · η² / Π earlier survivals) from `rr_depth` (default): as Mitsuba's,
    /// with the albedo product in place of the throughput.
    Albedo,
}

impl Roulette {
    /// Parses `off`, `throughput` or `albedo`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "off" | "none" => Ok(Roulette::Off),
            "throughput" | "mitsuba" => Ok(Roulette::Throughput),
            "albedo" => Ok(Roulette::Albedo),
            other => Err(format!(
                "unknown Russian roulette mode '{other}' (off, throughput or albedo)"
            )),
        }
    }

    /// The roulette a path actually uses: albedo roulette protects guided prefixes, so a path without
    /// a guide uses the throughput's.
    pub(super) fn for_path(self, guided: bool) -> Roulette {
        match (self, guided) {
            (Roulette::Albedo, false) => Roulette::Throughput,
            (r, _) => r,
        }
    }

    /// After a vertex has scattered the path (its throughput, η and depth updated), whether the path
    /// goes on: it ends where its throughput is zero or not finite, and from `rr_depth` on survives with
    /// the roulette's probability, dividing the throughput (and the albedo product, which carries the
    /// survivals so far as the throughput does) by it. `albedo` is the vertex BSDF's albedo, read only
    /// by albedo roulette.
    #[inline]
    pub(super) fn survives<O: PathObserver>(
        self,
        path: &mut PathState,
        albedo: impl FnOnce() -> f32,
        rr_depth: u32,
        sampler: &mut Sampler,
        observer: &mut O,
    ) -> bool {
        let tmax = path.throughput.max_element();
        if !(tmax > 0.0) || !tmax.is_finite() {
            return false;
        }
        if self == Roulette::Albedo {
            path.albedo *= albedo();
        }
        let survival = match self {
            Roulette::Off => 1.0,
            Roulette::Throughput => tmax,
            Roulette::Albedo => path.albedo,
        };
        if self != Roulette::Off && path.depth >= rr_depth {
            let q = (survival * path.eta * path.eta).min(0.95);
            observer.survival(q);
            if sampler.next_1d() >= q {
                return false;
            }
            path.throughput /= q;
            // As the throughput, the albedo product carries the survivals so far: the next vertex then
            // survives by its own albedo, and reaching depth k has the probability of the albedo
            // product. Without it every later roulette divided by the whole product again, and the
            // boosts compounded (docs/experiments/2026-12-03-albedo-roulette-fix.md).
            path.albedo /= q;
        }
        true
    }
}
