//! CPU BVH back-end on `obvhs`' compressed wide BVH (CWBVH, 8-wide, SIMD node tests).

use super::{Accel, PrimHit};
use crate::geometry::{Cylinder, Disk, ShapeGeometry, Sphere};
use crate::ray::Ray;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb as BAabb;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::{Boundable, BvhBuildParams};
use std::time::Duration;

/// How far behind its origin a ray starts for the BVH traversal. `obvhs`' node test (0.4) culls every
/// box the ray leaves within 1e-4 of its origin, ignoring the ray's own least distance: a path vertex
/// nearer than that to another surface (a room's corner, a gap) saw through it, and on the camera
/// obscura such leaks to the bright sky were the brightest samples of every guided render
/// (docs/experiments/2026-12-03-bvh-near-hits.md).
const TRAVERSAL_SHIFT: f32 = 2e-4;

/// Marks [`TriPrim::tri`] as an index into [`BvhAccel::analytic`] instead of a triangle index.
const ANALYTIC: u32 = 1 << 31;

/// A primitive in BVH leaf order, compact (44 bytes) so that leaf tests stream through memory. Analytic
/// shapes are rare; they keep only their shape id and an index into a side table here.
#[derive(Clone, Copy, Debug)]
struct TriPrim {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    shape: u32,
    /// Triangle index within the mesh, or `ANALYTIC | index into the analytic table`.
    tri: u32,
}

#[derive(Clone, Copy, Debug)]
enum Analytic {
    Sphere(Sphere),
    Disk(Disk),
    Cylinder(Cylinder),
}

struct Bounded(BAabb);

impl Boundable for Bounded {
    fn aabb(&self) -> BAabb {
        self.0
    }
}

/// The default acceleration structure.
pub struct BvhAccel {
    bvh: CwBvh,
    prims: Vec<TriPrim>,
    analytic: Vec<Analytic>,
}

impl BvhAccel {
    /// Builds a BVH over all primitives of `shapes` (shape index = position in the slice).
    pub fn build(shapes: &[ShapeGeometry]) -> Self {
        let mut prims = Vec::new();
        let mut analytic = Vec::new();
        let mut bounds = Vec::new();
        let mut push_analytic = |a: Analytic, shape: u32, prims: &mut Vec<TriPrim>| {
            prims.push(TriPrim {
                v0: Vec3::ZERO,
                e1: Vec3::ZERO,
                e2: Vec3::ZERO,
                shape,
                tri: ANALYTIC | analytic.len() as u32,
            });
            analytic.push(a);
        };
        for (si, g) in shapes.iter().enumerate() {
            let shape = si as u32;
            match g {
                ShapeGeometry::Mesh(m) => {
                    for i in 0..m.indices.len() {
                        let [a, b, c] = m.vertices(i);
                        prims.push(TriPrim {
                            v0: a,
                            e1: b - a,
                            e2: c - a,
                            shape,
                            tri: i as u32,
                        });
                        bounds.push((a.min(b).min(c), a.max(b).max(c)));
                    }
                }
                ShapeGeometry::Sphere(s) => {
                    push_analytic(Analytic::Sphere(*s), shape, &mut prims);
                    let b = s.bounds();
                    bounds.push((b.min, b.max));
                }
                ShapeGeometry::Disk(d) => {
                    push_analytic(Analytic::Disk(*d), shape, &mut prims);
                    let b = d.bounds();
                    bounds.push((b.min, b.max));
                }
                ShapeGeometry::Cylinder(c) => {
                    push_analytic(Analytic::Cylinder(*c), shape, &mut prims);
                    let b = c.bounds();
                    bounds.push((b.min, b.max));
                }
            }
        }
        let bounds: Vec<Bounded> = bounds
            .into_iter()
            .map(|(lo, hi)| Bounded(BAabb::new(Vec3A::from(lo), Vec3A::from(hi))))
            .collect();
        if bounds.is_empty() {
            return BvhAccel {
                bvh: CwBvh::default(),
                prims,
                analytic,
            };
        }
        let bvh = build_cwbvh(
            &bounds,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // Store primitives in BVH leaf order so that traversal reads them sequentially.
        let prims = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        BvhAccel {
            bvh,
            prims,
            analytic,
        }
    }

    #[inline(always)]
    fn intersect_prim(&self, prim: &TriPrim, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec2)> {
        if prim.tri & ANALYTIC != 0 {
            return match &self.analytic[(prim.tri & !ANALYTIC) as usize] {
                Analytic::Sphere(s) => s.intersect(o, d, 0.0, t_max).map(|t| (t, Vec2::ZERO)),
                Analytic::Disk(k) => k.intersect(o, d, 0.0, t_max).map(|t| (t, Vec2::ZERO)),
                Analytic::Cylinder(c) => c.intersect(o, d, 0.0, t_max).map(|t| (t, Vec2::ZERO)),
            };
        }
        // Möller–Trumbore.
        let p = d.cross(prim.e2);
        let det = prim.e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - prim.v0;
        let b1 = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let q = s.cross(prim.e1);
        let b2 = d.dot(q) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = prim.e2.dot(q) * inv;
        if t > 0.0 && t < t_max {
            Some((t, Vec2::new(b1, b2)))
        } else {
            None
        }
    }

    /// The ray `obvhs` traverses: started [`TRAVERSAL_SHIFT`] behind the real origin (its parameters
    /// are the real ones plus the shift), so that the node test's least entry distance lies behind the
    /// real origin and no surface in front of it is culled. A direction component of −0 becomes +0:
    /// `obvhs` takes its octant from the sign test d < 0 but its reciprocal from the sign bit, and
    /// with −0 the two disagree and the ray misses everything (`-Vec3::Y` found no floor).
    fn to_bvh_ray(ray: &Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(
            Vec3A::from(ray.o - ray.d * TRAVERSAL_SHIFT),
            Vec3A::from(ray.d) + Vec3A::ZERO,
            0.0,
            ray.t_max + TRAVERSAL_SHIFT,
        )
    }
}

impl Accel for BvhAccel {
    fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        if self.prims.is_empty() {
            return None;
        }
        let mut hit = obvhs::ray::RayHit::none();
        let mut best: Option<(usize, Vec2, f32)> = None;
        let (o, d) = (ray.o, ray.d);
        // Primitives are tested from the real origin; the traversal works in shifted parameters.
        let found = self
            .bvh
            .ray_traverse(Self::to_bvh_ray(ray), &mut hit, |r, id| {
                let t_max = (r.tmax - TRAVERSAL_SHIFT).min(ray.t_max);
                match self.intersect_prim(&self.prims[id], o, d, t_max) {
                    // The shifted distance rounds, so a primitive a hair behind the best can pass the
                    // t_max test here; keep the closest in real distance (ties: the first found).
                    Some((t, b)) if best.is_none_or(|(_, _, bt)| t < bt) => {
                        best = Some((id, b, t));
                        t + TRAVERSAL_SHIFT
                    }
                    _ => f32::INFINITY,
                }
            });
        if !found {
            return None;
        }
        let (id, bary, t) = best?;
        let p = &self.prims[id];
        let (shape, prim) = (p.shape, if p.tri & ANALYTIC != 0 { 0 } else { p.tri });
        Some(PrimHit {
            t,
            shape,
            prim,
            bary,
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.prims.is_empty() {
            return false;
        }
        let (o, d) = (ray.o, ray.d);
        !self.bvh.ray_traverse_miss(Self::to_bvh_ray(ray), |r, id| {
            let t_max = (r.tmax - TRAVERSAL_SHIFT).min(ray.t_max);
            self.intersect_prim(&self.prims[id], o, d, t_max)
                .map_or(f32::INFINITY, |(t, _)| t + TRAVERSAL_SHIFT)
        })
    }
}
