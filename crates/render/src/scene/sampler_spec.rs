//! The sensor's `<sampler>`: which generator and how many samples per pixel.

use crate::desc::ObjectDesc;
use crate::error::SceneResult;
use crate::sampler::SamplerKind;

/// Sampler settings of the sensor.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct SamplerSpec {
    /// Generator.
    pub kind: SamplerKind,
    /// Samples per pixel the scene asks for.
    pub spp: u32,
}

/// Reads the sampler (none: Mitsuba's default, `independent` with 4 samples). Mitsuba's stratified and
/// low-discrepancy samplers become focal's Sobol sampler with a warning (see docs/plugins.md).
pub(super) fn sampler_from_desc(
    s: Option<&ObjectDesc>,
    warnings: &mut Vec<String>,
) -> SceneResult<SamplerSpec> {
    let Some(s) = s else {
        return Ok(SamplerSpec {
            kind: SamplerKind::Independent,
            spp: 4,
        });
    };
    let kind = match s.plugin.as_str() {
        "independent" => SamplerKind::Independent,
        "sobol" => SamplerKind::Sobol,
        "stratified" | "multijitter" | "orthogonal" | "ldsampler" | "halton" | "hammersley" => {
            warnings.push(format!(
                "{}: sampler '{}' is replaced by focal's Owen-scrambled Sobol sampler (the same \
                 expectation, a different noise pattern)",
                s.loc, s.plugin
            ));
            SamplerKind::Sobol
        }
        other => return Err(s.error(format!("unknown sampler plugin '{other}'"))),
    };
    let spp = s.int_or("sample_count", 4)?;
    if spp < 1 {
        return Err(s.error(format!("sample_count must be at least 1, got {spp}")));
    }
    Ok(SamplerSpec {
        kind,
        spp: spp.min(u32::MAX as i64) as u32,
    })
}
