//! A record of one guided path's decisions, for finding where a render's fireflies come from: at every
//! scattering vertex how the direction was chosen and with which densities, where Russian roulette
//! boosted the throughput, where the path was split, and which light the path added. The guided
//! integrator fills it through [`PathObserver`] only when asked
//! ([`crate::integrator::GuidedPathIntegrator::li_traced`]); its ordinary `li` observes nothing, at no
//! cost.

/// How a vertex chose its outgoing direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// The BSDF's smooth lobes (at a guided vertex: the BSDF branch of the one-sample mixture).
    Bsdf,
    /// The guide.
    Guide,
    /// A delta lobe of the BSDF (never guided).
    Delta,
}

/// One scattering vertex of a traced path.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct TracedVertex {
    /// Scattering vertices before this one (0 at the first hit).
    pub depth: u32,
    /// The BSDF's Mitsuba plugin name.
    pub bsdf: &'static str,
    /// The BSDF counts as glossy (narrow lobes).
    pub glossy: bool,
    /// The probability α of sampling the guide here (0 where the vertex was not guided).
    pub guide_fraction: f32,
    /// How the direction was chosen.
    pub strategy: Strategy,
    /// The BSDF's solid-angle pdf of the chosen direction.
    pub bsdf_pdf: f32,
    /// The guide's pdf of the chosen direction (0 where not guided).
    pub guide_pdf: f32,
    /// The pdf the direction was sampled with (the mixture's at a guided vertex).
    pub pdf: f32,
    /// The largest channel of f·cos/pdf.
    pub weight: f32,
    /// The path throughput's largest channel after this vertex (before Russian roulette).
    pub throughput: f32,
    /// The Russian roulette survival probability applied after this vertex (1 if none was played).
    pub survival: f32,
    /// How many copies the path was split into after this vertex, in expectation (1 if not split; see
    /// [`crate::integrator::GuidedSettings::split`]).
    pub split: f32,
    /// Which copy of the path this vertex belongs to: 0 for the camera path, k for the k-th split-off
    /// copy continued (each continues from the vertex it was split at, so its depths go on from there).
    pub branch: u32,
}

/// How a path added light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LightEvent {
    /// Next-event estimation at a vertex.
    NextEvent,
    /// The sampled direction hit an area emitter.
    EmitterHit,
    /// The sampled direction escaped to an environment emitter.
    Environment,
}

/// Light a traced path added to its estimate.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct TracedLight {
    /// Scattering vertices before the light was found (next-event estimation at vertex d: d; an emitter
    /// hit after d vertices: d).
    pub depth: u32,
    /// How it was found.
    pub event: LightEvent,
    /// The mean over channels of what it added (throughput, MIS weight and all).
    pub value: f32,
    /// The copy of the path that found it (see [`TracedVertex::branch`]).
    pub branch: u32,
}

/// One path's vertices and light, in order.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PathTrace {
    /// The scattering vertices.
    pub vertices: Vec<TracedVertex>,
    /// The light added.
    pub lights: Vec<TracedLight>,
    /// Split-off copies continued so far (the branch the next records belong to).
    pub branches: u32,
}

impl PathTrace {
    /// The light event that added the most.
    pub fn dominant_light(&self) -> Option<&TracedLight> {
        self.lights
            .iter()
            .max_by(|a, b| a.value.total_cmp(&b.value))
    }

    /// The vertices a copy of the path went through from the camera on, one per depth: its own, after
    /// those of the copy it was split from, up to the vertex of the split. That vertex is the last one
    /// recorded before the copy's first vertex that lies one depth shallower and split (copies run one
    /// after another, so this finds it). Empty if the copy recorded no vertex of its own (it found
    /// its light on the ray it was split with, or nothing).
    pub fn lineage(&self, branch: u32) -> Vec<TracedVertex> {
        let mut out: Vec<TracedVertex> = Vec::new();
        let mut branch = branch;
        // Only records made up to the split the current copy came from count.
        let mut end = self.vertices.len();
        loop {
            let own: Vec<(usize, &TracedVertex)> = self.vertices[..end]
                .iter()
                .enumerate()
                .filter(|(_, v)| v.branch == branch)
                .collect();
            for (_, v) in own.iter().rev() {
                if out.last().is_none_or(|l| v.depth < l.depth) {
                    out.push(**v);
                }
            }
            let Some(&(first, _)) = own.first() else {
                break;
            };
            let Some(depth) = out.last().map(|v| v.depth) else {
                break;
            };
            if branch == 0 || depth == 0 {
                break;
            }
            let Some((at, parent)) = self.vertices[..first]
                .iter()
                .enumerate()
                .rev()
                .find(|(_, v)| v.depth + 1 == depth && v.split > 1.0)
            else {
                break;
            };
            branch = parent.branch;
            end = at + 1;
        }
        out.reverse();
        out
    }
}

/// What the guided integrator reports while it traces a path.
pub(crate) trait PathObserver {
    /// The path scattered at a vertex (its survival is set by [`PathObserver::survival`]).
    fn vertex(&mut self, vertex: TracedVertex);
    /// Russian roulette kept the path with probability `q` after the last vertex.
    fn survival(&mut self, q: f32);
    /// The path added light: `value` (the mean over channels) found by `event` after `depth` vertices.
    fn light(&mut self, depth: u32, event: LightEvent, value: f32);
    /// The path was split into `copies` (in expectation) after the last vertex.
    fn split(&mut self, copies: f32);
    /// A split-off copy is continued; what follows belongs to it.
    fn resume(&mut self);
}

/// Observes nothing: the ordinary render.
impl PathObserver for () {
    #[inline(always)]
    fn vertex(&mut self, _: TracedVertex) {}
    #[inline(always)]
    fn survival(&mut self, _: f32) {}
    #[inline(always)]
    fn light(&mut self, _: u32, _: LightEvent, _: f32) {}
    #[inline(always)]
    fn split(&mut self, _: f32) {}
    #[inline(always)]
    fn resume(&mut self) {}
}

impl PathObserver for PathTrace {
    fn vertex(&mut self, vertex: TracedVertex) {
        self.vertices.push(TracedVertex {
            branch: self.branches,
            ..vertex
        });
    }
    fn survival(&mut self, q: f32) {
        if let Some(v) = self.vertices.last_mut() {
            v.survival = q;
        }
    }
    fn light(&mut self, depth: u32, event: LightEvent, value: f32) {
        self.lights.push(TracedLight {
            depth,
            event,
            value,
            branch: self.branches,
        });
    }
    fn split(&mut self, copies: f32) {
        if let Some(v) = self.vertices.last_mut() {
            v.split = copies;
        }
    }
    fn resume(&mut self) {
        self.branches += 1;
    }
}
