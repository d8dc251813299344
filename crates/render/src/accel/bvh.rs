//! CPU BVH back-end on `obvhs`' compressed wide BVH (CWBVH, 8-wide, SIMD node tests).

use super::{Accel, PrimHit};
use crate::geometry::{Disk, ShapeGeometry, Sphere};
use crate::ray::Ray;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb as BAabb;
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::{Boundable, BvhBuildParams};
use std::time::Duration;

/// A primitive in BVH order, with what its intersection test needs inline.
#[derive(Clone, Copy, Debug)]
enum Prim {
    Triangle {
        v0: Vec3,
        e1: Vec3,
        e2: Vec3,
        shape: u32,
        tri: u32,
    },
    Sphere {
        sphere: Sphere,
        shape: u32,
    },
    Disk {
        disk: Disk,
        shape: u32,
    },
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
    prims: Vec<Prim>,
}

impl BvhAccel {
    /// Builds a BVH over all primitives of `shapes` (shape index = position in the slice).
    pub fn build(shapes: &[ShapeGeometry]) -> Self {
        let mut prims = Vec::new();
        for (si, g) in shapes.iter().enumerate() {
            let shape = si as u32;
            match g {
                ShapeGeometry::Mesh(m) => {
                    for i in 0..m.indices.len() {
                        let [a, b, c] = m.vertices(i);
                        prims.push(Prim::Triangle {
                            v0: a,
                            e1: b - a,
                            e2: c - a,
                            shape,
                            tri: i as u32,
                        });
                    }
                }
                ShapeGeometry::Sphere(s) => prims.push(Prim::Sphere { sphere: *s, shape }),
                ShapeGeometry::Disk(d) => prims.push(Prim::Disk { disk: *d, shape }),
            }
        }
        let bounds: Vec<Bounded> = prims
            .iter()
            .map(|p| {
                let (lo, hi) = match p {
                    Prim::Triangle { v0, e1, e2, .. } => {
                        let (a, b, c) = (*v0, *v0 + *e1, *v0 + *e2);
                        (a.min(b).min(c), a.max(b).max(c))
                    }
                    Prim::Sphere { sphere, .. } => {
                        let b = sphere.bounds();
                        (b.min, b.max)
                    }
                    Prim::Disk { disk, .. } => {
                        let b = disk.bounds();
                        (b.min, b.max)
                    }
                };
                Bounded(BAabb::new(Vec3A::from(lo), Vec3A::from(hi)))
            })
            .collect();
        let bvh = if bounds.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh(
                &bounds,
                BvhBuildParams::medium_build(),
                &mut Duration::default(),
            )
        };
        // Store primitives in BVH leaf order so that traversal reads them sequentially.
        let prims = if bounds.is_empty() {
            prims
        } else {
            bvh.primitive_indices
                .iter()
                .map(|&i| prims[i as usize])
                .collect()
        };
        BvhAccel { bvh, prims }
    }

    #[inline]
    fn intersect_prim(prim: &Prim, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec2)> {
        match prim {
            Prim::Triangle { v0, e1, e2, .. } => {
                // Möller–Trumbore.
                let p = d.cross(*e2);
                let det = e1.dot(p);
                if det == 0.0 {
                    return None;
                }
                let inv = 1.0 / det;
                let s = o - *v0;
                let b1 = s.dot(p) * inv;
                if !(0.0..=1.0).contains(&b1) {
                    return None;
                }
                let q = s.cross(*e1);
                let b2 = d.dot(q) * inv;
                if b2 < 0.0 || b1 + b2 > 1.0 {
                    return None;
                }
                let t = e2.dot(q) * inv;
                if t > 0.0 && t < t_max {
                    Some((t, Vec2::new(b1, b2)))
                } else {
                    None
                }
            }
            Prim::Sphere { sphere, .. } => {
                sphere.intersect(o, d, 0.0, t_max).map(|t| (t, Vec2::ZERO))
            }
            Prim::Disk { disk, .. } => disk.intersect(o, d, 0.0, t_max).map(|t| (t, Vec2::ZERO)),
        }
    }

    fn to_bvh_ray(ray: &Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(Vec3A::from(ray.o), Vec3A::from(ray.d), 0.0, ray.t_max)
    }
}

impl Accel for BvhAccel {
    fn intersect(&self, ray: &Ray) -> Option<PrimHit> {
        if self.prims.is_empty() {
            return None;
        }
        let mut hit = obvhs::ray::RayHit::none();
        let mut best: Option<(usize, Vec2)> = None;
        let (o, d) = (ray.o, ray.d);
        let found = self
            .bvh
            .ray_traverse(
                Self::to_bvh_ray(ray),
                &mut hit,
                |r, id| match Self::intersect_prim(&self.prims[id], o, d, r.tmax) {
                    Some((t, b)) => {
                        best = Some((id, b));
                        t
                    }
                    None => f32::INFINITY,
                },
            );
        if !found {
            return None;
        }
        let (id, bary) = best?;
        debug_assert_eq!(id as u32, hit.primitive_id);
        let (shape, prim) = match self.prims[id] {
            Prim::Triangle { shape, tri, .. } => (shape, tri),
            Prim::Sphere { shape, .. } | Prim::Disk { shape, .. } => (shape, 0),
        };
        Some(PrimHit {
            t: hit.t,
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
            Self::intersect_prim(&self.prims[id], o, d, r.tmax).map_or(f32::INFINITY, |(t, _)| t)
        })
    }
}
