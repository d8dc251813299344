//! Unidirectional path tracing with next-event estimation and MIS (Mitsuba `path`).

use super::{
    bsdf_context, next_event_estimate, power_heuristic, resolve_pass_through, FirstHitAovs,
    Integrator, PassThroughRun,
};
use crate::color::Rgb;
use crate::ray::{offset_ray_origin, CameraRay, Ray};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// Settings of the path integrator, with Mitsuba's meanings.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct PathSettings {
    /// Longest path in segments from the camera (`u32::MAX` = unlimited, Mitsuba's -1, which is how it
    /// is written); 1 = directly visible emitters only, 2 = direct lighting.
    #[serde(with = "unlimited_as_minus_one")]
    pub max_depth: u32,
    /// Depth (1 = first hit) from which Russian roulette applies (Mitsuba's `rr_depth`, default 5).
    pub rr_depth: u32,
    /// Russian roulette on or off (always on in Mitsuba's `path`; guided runs turn it off).
    pub russian_roulette: bool,
    /// Directly visible emitters read as black.
    pub hide_emitters: bool,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            max_depth: u32::MAX,
            rr_depth: 5,
            russian_roulette: true,
            hide_emitters: false,
        }
    }
}

/// `max_depth` in files as Mitsuba writes it: -1 for unlimited (`u32::MAX`).
mod unlimited_as_minus_one {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(depth: &u32, s: S) -> Result<S::Ok, S::Error> {
        if *depth == u32::MAX {
            s.serialize_i64(-1)
        } else {
            s.serialize_u32(*depth)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
        match i64::deserialize(d)? {
            -1 => Ok(u32::MAX),
            v => u32::try_from(v).map_err(serde::de::Error::custom),
        }
    }
}

/// The path tracer every guiding method is compared against.
#[derive(Clone, Debug, Default)]
pub struct PathIntegrator {
    /// Settings.
    pub settings: PathSettings,
}

impl Integrator for PathIntegrator {
    fn li(
        &self,
        scene: &Scene,
        camera_ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
    ) -> Rgb {
        let s = &self.settings;
        if s.max_depth == 0 {
            return Rgb::ZERO;
        }
        let mut ray = camera_ray.ray;
        let mut result = Rgb::ZERO;
        let mut throughput = Rgb::ONE;
        let mut eta = 1.0f32;
        // depth = number of surface interactions so far (Mitsuba: emission at hit k counts iff k ≤ max_depth).
        let mut depth: u32 = 0;
        let mut prev_p = ray.o;
        let mut prev_bsdf_pdf = 1.0f32;
        let mut prev_bsdf_delta = true;
        let mut run = PassThroughRun::default();

        loop {
            let si = scene.intersect(&ray);

            // Emission reached by the previous sampling decision (or the camera ray).
            let visible = !(s.hide_emitters && depth == 0);
            match &si {
                Some(si) => {
                    if let Some(e) = scene.shapes[si.shape as usize].emitter {
                        let le = scene.emitters[e as usize].eval_area(si.to_local(-ray.d).z);
                        if visible && le != Rgb::ZERO {
                            let mis = if prev_bsdf_delta {
                                1.0
                            } else {
                                power_heuristic(
                                    prev_bsdf_pdf,
                                    scene.pdf_emitter_direction_area(prev_p, si),
                                )
                            };
                            result += throughput * le * mis;
                        }
                    }
                }
                None => {
                    if let Some(env) = scene.environment {
                        if visible {
                            let le = scene.emitters[env as usize].eval_environment(ray.d);
                            let mis = if prev_bsdf_delta {
                                1.0
                            } else {
                                power_heuristic(
                                    prev_bsdf_pdf,
                                    scene.pdf_emitter_direction_env(ray.d),
                                )
                            };
                            result += throughput * le * mis;
                        }
                    }
                    break;
                }
            }
            let si = si.unwrap();
            let ctx = bsdf_context(scene, &si, camera_ray.differential.as_ref(), depth == 0);
            // A pass-through is no vertex: the MIS state of the last vertex stays, and so does the depth
            // (emission behind a mask is still reached by that vertex's direction).
            let Some(bsdf) = resolve_pass_through(
                &scene.bsdfs[scene.shapes[si.shape as usize].bsdf as usize],
                &ctx,
                sampler,
                &mut throughput,
            ) else {
                match run.pass(&ray, &si, throughput) {
                    Some(next) => ray = next,
                    None => break,
                }
                continue;
            };
            let distance = run.end(si.t);
            if depth == 0 {
                aovs.albedo = bsdf.albedo(&ctx);
                aovs.normal = si.sh_frame.n;
                aovs.depth = distance;
            }
            if depth.saturating_add(1) >= s.max_depth {
                break;
            }

            let wi = si.to_local(-ray.d);

            // Next-event estimation.
            result += throughput
                * next_event_estimate(scene, &si, bsdf, &ctx, wi, sampler, |wo, _| {
                    bsdf.pdf(&ctx, wi, wo)
                });

            // BSDF sampling.
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample(&ctx, wi, u1, u2) else {
                break;
            };
            let wo_world = si.to_world(bs.wo);
            throughput *= bs.weight;
            eta *= bs.eta;
            prev_p = si.p;
            prev_bsdf_pdf = bs.pdf;
            prev_bsdf_delta = bs.delta;
            depth += 1;

            let tmax = throughput.max_element();
            if !(tmax > 0.0) || !tmax.is_finite() {
                break;
            }
            if s.russian_roulette && depth >= s.rr_depth {
                let q = (tmax * eta * eta).min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                throughput /= q;
            }
            ray = Ray::new(offset_ray_origin(si.p, si.ng, wo_world), wo_world);
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unlimited_depth_is_written_as_minus_one() {
        let v = serde_json::to_value(PathSettings::default()).unwrap();
        assert_eq!(v["max_depth"], -1);
        let back: PathSettings = serde_json::from_value(v).unwrap();
        assert_eq!(back.max_depth, u32::MAX);
        let five = PathSettings {
            max_depth: 5,
            ..PathSettings::default()
        };
        let v = serde_json::to_value(five).unwrap();
        assert_eq!(v["max_depth"], 5);
        assert_eq!(
            serde_json::from_value::<PathSettings>(v).unwrap().max_depth,
            5
        );
    }
}
