//! The render-ready scene: geometry, materials, lights, camera and settings, with the queries integrators
//! need (closest hit, visibility, light sampling and light pdfs).

mod build;
mod footprint;
mod sampler_spec;

pub use build::{
    build_scene, BuildOptions, GuidedSpec, IntegratorSpec, LoadedScene, SamplerSpec, Strictness,
};

use crate::accel::{Accel, PrimHit};
use crate::bsdf::{Bsdf, BsdfContext};
use crate::color::Rgb;
use crate::emitter::{Emitter, EmitterSample};
use crate::frame::Frame;
use crate::geometry::{Aabb, ShapeGeometry, SurfaceInteraction};
use crate::ray::{offset_ray_origin, Ray};
use glam::{Vec2, Vec3};

/// Per-shape material and light bindings (parallel to [`Scene::geometries`]).
#[derive(Clone, Debug)]
pub struct ShapeInfo {
    /// Index into [`Scene::bsdfs`].
    pub bsdf: u32,
    /// Index into [`Scene::emitters`] of the area light on this shape, if any.
    pub emitter: Option<u32>,
    /// The shape's `id`, or a description of where it came from (for messages and visualisation).
    pub name: String,
}

/// A scene ready to render.
pub struct Scene {
    /// Shape geometries, world space.
    pub geometries: Vec<ShapeGeometry>,
    /// Shape bindings, parallel to `geometries`.
    pub shapes: Vec<ShapeInfo>,
    /// Materials.
    pub bsdfs: Vec<Bsdf>,
    /// Lights.
    pub emitters: Vec<Emitter>,
    /// The environment light seen by escaping rays, if any.
    pub environment: Option<u32>,
    /// Bounds of all geometry (plus the camera position, as Mitsuba 0.6's scene AABB).
    pub bounds: Aabb,
    emitter_cdf: Vec<f32>,
    accel: Box<dyn Accel>,
    /// Some shape has a `mask` BSDF, so shadow rays must look for pass-through surfaces.
    has_pass_through: bool,
}

/// Most pass-through (masked) surfaces a ray may cross before it counts as blocked: only a pathological
/// stack of more than this many cut-outs on one line loses energy.
pub const MAX_PASS_THROUGH: u32 = 1024;

impl Scene {
    /// Assembles a scene and builds its acceleration structure.
    /// `emitter_weights` are the emitters' `sampling_weight`s (selection probability ∝ weight).
    pub fn new(
        geometries: Vec<ShapeGeometry>,
        shapes: Vec<ShapeInfo>,
        bsdfs: Vec<Bsdf>,
        emitters: Vec<Emitter>,
        emitter_weights: &[f32],
        extra_bounds: &[Vec3],
        accel: impl FnOnce(&[ShapeGeometry]) -> Box<dyn Accel>,
    ) -> Self {
        assert_eq!(geometries.len(), shapes.len());
        assert_eq!(emitters.len(), emitter_weights.len());
        let environment = emitters
            .iter()
            .position(|e| e.is_environment())
            .map(|i| i as u32);
        let mut bounds = geometries
            .iter()
            .fold(Aabb::EMPTY, |b, g| b.union(&g.bounds()));
        for p in extra_bounds {
            bounds.expand(*p);
        }
        for e in &emitters {
            match e {
                Emitter::Point { position, .. } => bounds.expand(*position),
                Emitter::Spot(s) => bounds.expand(s.position()),
                _ => {}
            }
        }
        let total: f64 = emitter_weights.iter().map(|&w| w.max(0.0) as f64).sum();
        let mut acc = 0.0f64;
        let emitter_cdf = emitter_weights
            .iter()
            .map(|&w| {
                acc += w.max(0.0) as f64;
                (acc / total.max(f64::MIN_POSITIVE)) as f32
            })
            .collect();
        let accel = accel(&geometries);
        let has_pass_through = shapes
            .iter()
            .any(|s| matches!(bsdfs[s.bsdf as usize], Bsdf::Mask(_)));
        Scene {
            has_pass_through,
            geometries,
            shapes,
            bsdfs,
            emitters,
            environment,
            bounds,
            emitter_cdf,
            accel,
        }
    }

    /// Closest surface hit along `ray`.
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        let hit = self.accel.intersect(ray)?;
        Some(self.interaction(ray, &hit))
    }

    /// True if the segment `ray` (up to `t_max`) is blocked.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    /// The fraction of light that gets along the segment `ray` (up to `t_max`): 0 if an opaque surface
    /// blocks it, else the product of the transmittances 1 − opacity of the `mask` surfaces it crosses
    /// (the same [`Bsdf::pass_through`] the integrators sample, so both MIS strategies agree).
    pub fn transmittance(&self, ray: &Ray) -> Rgb {
        if !self.has_pass_through {
            return if self.occluded(ray) {
                Rgb::ZERO
            } else {
                Rgb::ONE
            };
        }
        let mut t = Rgb::ONE;
        let mut r = *ray;
        for _ in 0..MAX_PASS_THROUGH {
            let Some(si) = self.intersect(&r) else {
                return t;
            };
            let bsdf = &self.bsdfs[self.shapes[si.shape as usize].bsdf as usize];
            let Some(tr) = bsdf.pass_through(&BsdfContext::at_uv(si.uv)) else {
                return Rgb::ZERO;
            };
            t *= tr;
            if t.max_element() <= 0.0 {
                return Rgb::ZERO;
            }
            let o = offset_ray_origin(si.p, si.ng, r.d);
            let remaining = r.t_max - (o - r.o).dot(r.d);
            if !(remaining > 0.0) {
                return t;
            }
            r = Ray::segment(o, r.d, remaining);
        }
        Rgb::ZERO
    }

    /// Computes surface data for a primitive hit.
    pub fn interaction(&self, ray: &Ray, hit: &PrimHit) -> SurfaceInteraction {
        let shape = hit.shape;
        match &self.geometries[shape as usize] {
            ShapeGeometry::Mesh(m) => {
                let b = hit.bary;
                let b0 = 1.0 - b.x - b.y;
                let [i0, i1, i2] = m.indices[hit.prim as usize].map(|k| k as usize);
                let (a, bb, c) = (m.positions[i0], m.positions[i1], m.positions[i2]);
                let p = a * b0 + bb * b.x + c * b.y;
                let (e1, e2) = (bb - a, c - a);
                let sign = if m.flip_normals { -1.0 } else { 1.0 };
                let ng = e1.cross(e2).normalize() * sign;
                let ns = match &m.normals {
                    Some(n) => {
                        let v = (n[i0] * b0 + n[i1] * b.x + n[i2] * b.y).normalize_or_zero();
                        if v == Vec3::ZERO {
                            ng
                        } else {
                            v * sign
                        }
                    }
                    None => ng,
                };
                // dp/du from the uv parameterisation gives anisotropic BSDFs a consistent tangent and
                // bump maps their surface derivatives; without uvs, uv are the barycentrics (Mitsuba 3).
                let (uv, dp_du, dp_dv) = match &m.uvs {
                    Some(uvs) => {
                        let (t0, t1, t2) = (uvs[i0], uvs[i1], uvs[i2]);
                        let (d1, d2) = (t1 - t0, t2 - t0);
                        let det = d1.x * d2.y - d1.y * d2.x;
                        let (dp_du, dp_dv) = if det.abs() > 1e-12 {
                            ((e1 * d2.y - e2 * d1.y) / det, (e2 * d1.x - e1 * d2.x) / det)
                        } else {
                            (e1, e2)
                        };
                        (t0 * b0 + t1 * b.x + t2 * b.y, dp_du, dp_dv)
                    }
                    None => (b, e1, e2),
                };
                SurfaceInteraction {
                    t: hit.t,
                    p,
                    ng,
                    sh_frame: Frame::from_normal_tangent(ns, dp_du),
                    uv,
                    dp_du,
                    dp_dv,
                    shape,
                    prim: hit.prim,
                }
            }
            ShapeGeometry::Sphere(s) => {
                let p = s.project(ray.at(hit.t));
                let n = s.normal(p);
                let (dp_du, dp_dv) = s.uv_partials(p);
                SurfaceInteraction {
                    t: hit.t,
                    p,
                    ng: n,
                    sh_frame: Frame::from_normal_tangent(n, dp_du),
                    uv: s.uv(p),
                    dp_du,
                    dp_dv,
                    shape,
                    prim: 0,
                }
            }
            ShapeGeometry::Disk(d) => {
                let p = ray.at(hit.t);
                let n = d.normal();
                let (dp_du, dp_dv) = d.uv_partials(p);
                SurfaceInteraction {
                    t: hit.t,
                    p,
                    ng: n,
                    sh_frame: Frame::from_normal(n),
                    uv: d.uv(p),
                    dp_du,
                    dp_dv,
                    shape,
                    prim: 0,
                }
            }
            ShapeGeometry::Cylinder(c) => {
                let (p, n, uv, tangent) = c.surface(ray.at(hit.t));
                let (dp_du, dp_dv) = c.uv_partials(p);
                SurfaceInteraction {
                    t: hit.t,
                    p,
                    ng: n,
                    sh_frame: Frame::from_normal_tangent(n, tangent),
                    uv,
                    dp_du,
                    dp_dv,
                    shape,
                    prim: hit.prim,
                }
            }
        }
    }

    /// Probability of choosing emitter `i` for next-event estimation.
    #[inline]
    pub fn emitter_selection_pdf(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.emitter_cdf[i - 1] };
        self.emitter_cdf[i] - lo
    }

    /// Chooses an emitter with `u1`, then samples a direction towards it from `x`. The returned sample's pdf
    /// and weight include the selection probability. Visibility is not tested.
    pub fn sample_emitter_direction(
        &self,
        x: Vec3,
        u1: f32,
        u2: f32,
        u: Vec2,
    ) -> Option<(u32, EmitterSample)> {
        if self.emitters.is_empty() {
            return None;
        }
        let i = self
            .emitter_cdf
            .partition_point(|&c| c <= u1)
            .min(self.emitters.len() - 1);
        let sel = self.emitter_selection_pdf(i);
        if !(sel > 0.0) {
            return None;
        }
        let mut s = self.emitters[i].sample_direction(&self.geometries, x, u2, u)?;
        s.pdf *= sel;
        s.weight /= sel;
        Some((i as u32, s))
    }

    /// Solid-angle density of [`Scene::sample_emitter_direction`] producing the direction from `x` to the
    /// area-light point `si` (including selection).
    pub fn pdf_emitter_direction_area(&self, x: Vec3, si: &SurfaceInteraction) -> f32 {
        match self.shapes[si.shape as usize].emitter {
            Some(e) => {
                self.emitters[e as usize].pdf_direction(&self.geometries, x, si.p, si.sh_frame.n)
                    * self.emitter_selection_pdf(e as usize)
            }
            None => 0.0,
        }
    }

    /// Solid-angle density of sampling direction `d` towards the environment light (including selection).
    pub fn pdf_emitter_direction_env(&self, d: Vec3) -> f32 {
        match self.environment {
            Some(e) => {
                self.emitters[e as usize].pdf_direction(&self.geometries, Vec3::ZERO, d, Vec3::ZERO)
                    * self.emitter_selection_pdf(e as usize)
            }
            None => 0.0,
        }
    }
}
