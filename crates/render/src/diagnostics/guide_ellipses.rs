//! What a Gaussian-mixture guide learned, drawn over the rendered image: the outline of each
//! component's 2σ ellipsoid projected through the scene camera, coloured by its weight (viridis, the
//! heaviest component yellow), with a cross at its mean.
//!
//! The outline is exact up to sampling: the perspective image of a convex body in front of the camera
//! is convex, so it is the convex hull of the projections of points on its surface; 1024 surface points
//! give a hull indistinguishable from the true conic at image resolution.

use super::colour_map::viridis;
use crate::camera::Camera;
use crate::color::srgb_to_linear;
use crate::film::{FilmSpec, Image};
use focal_guiding::gmm::Mixture;
use focal_guiding::GmmGuide;
use glam::{DVec3, Vec2};

/// Radius of the drawn ellipsoids in standard deviations.
pub const ELLIPSOID_SIGMAS: f64 = 2.0;

/// One mixture component as drawn: overall weight (mixture weight × share of its mixture), mean and
/// the projected outline (film pixels of the crop window); `outline` is empty when part of the
/// ellipsoid lies behind the camera.
#[derive(Clone, Debug)]
pub struct ProjectedComponent {
    /// Weight in the whole guide.
    pub weight: f64,
    /// True for the diverging mixture (sampled from the far end of the path).
    pub diverging: bool,
    /// The mean's image position, if in front of the camera.
    pub mean: Option<Vec2>,
    /// Closed convex outline, counter-clockwise.
    pub outline: Vec<Vec2>,
}

/// Projects every component of both mixtures of `guide` through `camera`.
pub fn project_components(
    camera: &Camera,
    spec: &FilmSpec,
    guide: &GmmGuide,
) -> Vec<ProjectedComponent> {
    let offset = spec.crop_offset.as_vec2();
    let mut out = Vec::new();
    let mixtures: [(Mixture, f64, bool); 2] = [
        (guide.converging(), 1.0 - guide.p_div(), false),
        (guide.diverging(), guide.p_div(), true),
    ];
    let dirs = sphere_points(1024);
    for (mixture, share, diverging) in &mixtures {
        for (w, g) in mixture.weights().iter().zip(mixture.components()) {
            let mean = g.mean();
            let project = |p: DVec3| camera.world_to_film(p.as_vec3()).map(|q| q - offset);
            let mut pts = Vec::with_capacity(dirs.len());
            let mut behind = false;
            for d in &dirs {
                match project(g.point(*d * ELLIPSOID_SIGMAS)) {
                    Some(q) if q.is_finite() => pts.push(q),
                    _ => behind = true,
                }
            }
            out.push(ProjectedComponent {
                weight: w * share,
                diverging: *diverging,
                mean: project(mean),
                outline: if behind { Vec::new() } else { convex_hull(pts) },
            });
        }
    }
    out
}

/// Fibonacci points on the unit sphere.
fn sphere_points(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Andrew's monotone chain convex hull (counter-clockwise, no repeated end point).
fn convex_hull(mut pts: Vec<Vec2>) -> Vec<Vec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<Vec2> = Vec::with_capacity(pts.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The rendered image (darkened to half, so the outlines stand out) with every component's projected
/// 2σ outline, coloured by weight relative to the heaviest component (viridis), heaviest drawn last.
pub fn ellipse_overlay(base: &Image, components: &[ProjectedComponent]) -> Image {
    let mut out = base.clone();
    out.layers.clear();
    for p in &mut out.rgb {
        *p = p.map(|v| {
            if v.is_finite() {
                v.clamp(0.0, 1.0) * 0.5
            } else {
                0.0
            }
        });
    }
    let max_w = components.iter().map(|c| c.weight).fold(0.0, f64::max);
    let mut order: Vec<&ProjectedComponent> = components.iter().collect();
    order.sort_by(|a, b| a.weight.total_cmp(&b.weight));
    for c in order {
        let t = if max_w > 0.0 {
            (c.weight / max_w) as f32
        } else {
            0.0
        };
        let colour = viridis(0.15 + 0.85 * t).map(srgb_to_linear);
        let n = c.outline.len();
        for i in 0..n {
            draw_line(&mut out, c.outline[i], c.outline[(i + 1) % n], colour);
        }
        if let Some(m) = c.mean {
            draw_line(
                &mut out,
                m - Vec2::new(3.0, 0.0),
                m + Vec2::new(3.0, 0.0),
                colour,
            );
            draw_line(
                &mut out,
                m - Vec2::new(0.0, 3.0),
                m + Vec2::new(0.0, 3.0),
                colour,
            );
        }
    }
    out
}

/// Draws a one-pixel line, clipped to the image (DDA; long off-screen lines are clipped first).
pub fn draw_line(img: &mut Image, a: Vec2, b: Vec2, colour: [f32; 3]) {
    let (w, h) = (img.width as f32, img.height as f32);
    let Some((a, b)) = clip_segment(a, b, Vec2::splat(-1.0), Vec2::new(w + 1.0, h + 1.0)) else {
        return;
    };
    let steps = (b - a).abs().max_element().ceil().max(1.0) as usize;
    for i in 0..=steps {
        let p = a + (b - a) * (i as f32 / steps as f32);
        let (x, y) = (p.x.floor(), p.y.floor());
        if x >= 0.0 && y >= 0.0 && x < w && y < h {
            img.rgb[y as usize * img.width as usize + x as usize] = colour;
        }
    }
}

/// Liang–Barsky clipping of segment `a`–`b` to the box `lo`–`hi`.
fn clip_segment(a: Vec2, b: Vec2, lo: Vec2, hi: Vec2) -> Option<(Vec2, Vec2)> {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (p, q) in [
        (-d.x, a.x - lo.x),
        (d.x, hi.x - a.x),
        (-d.y, a.y - lo.y),
        (d.y, hi.y - a.y),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then(|| (a + d * t0, a + d * t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use focal_guiding::gmm::{Gaussian3, Sym3};
    use focal_guiding::{Aabb3, GmmConfig};
    use glam::{Mat4, UVec2, Vec3};

    #[test]
    fn a_sphere_in_front_of_the_camera_projects_to_the_right_circle() {
        // Camera at the origin looking along +Z, 64 px wide, 90° field of view: focal length 32 px.
        let camera = Camera::Perspective(Projection::new(
            Mat4::IDENTITY,
            UVec2::new(64, 64),
            90.0,
            0.01,
            100.0,
        ));
        let spec = FilmSpec {
            width: 64,
            height: 64,
            crop_size: UVec2::new(64, 64),
            ..FilmSpec::default()
        };
        // σ = 0.5, so the 2σ ellipsoid is the unit sphere at distance 5: its silhouette has angular
        // radius asin(1/5), i.e. 32 · tan(asin(0.2)) = 6.532 px around the image centre.
        let g = Gaussian3::new(DVec3::new(0.0, 0.0, 5.0), Sym3::scaled_identity(0.25)).unwrap();
        let mix = Mixture::new(&[1.0], vec![g]).unwrap();
        let aabb = Aabb3 {
            min: Vec3::splat(-10.0),
            max: Vec3::splat(10.0),
        };
        let guide = GmmGuide::from_mixtures(aabb, GmmConfig::default(), &mix, &mix, 0.25).unwrap();
        let comps = project_components(&camera, &spec, &guide);
        let conv: Vec<_> = comps.iter().filter(|c| !c.diverging).collect();
        assert_eq!(conv.len(), 1);
        assert!((conv[0].weight - 0.75).abs() < 1e-9);
        let centre = Vec2::splat(32.0);
        assert!((conv[0].mean.unwrap() - centre).length() < 1e-3);
        let expect = 32.0 * (0.2f32.asin()).tan();
        assert!(conv[0].outline.len() > 16);
        for p in &conv[0].outline {
            let r = (*p - centre).length();
            assert!((r - expect).abs() < 0.05 * expect, "{r} vs {expect}");
        }
        // The overlay marks the outline and leaves far pixels at the darkened image.
        let base = Image::new(64, 64);
        let img = ellipse_overlay(&base, &comps);
        assert_ne!(img.pixel(32 + expect as u32, 32), [0.0; 3]);
        assert_eq!(img.pixel(2, 2), [0.0; 3]);
    }

    #[test]
    fn hull_of_a_square_with_an_inner_point() {
        let pts = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(0.5, 0.5),
        ];
        let h = convex_hull(pts);
        assert_eq!(h.len(), 4);
        assert!(!h.contains(&Vec2::new(0.5, 0.5)));
    }

    #[test]
    fn lines_are_clipped_to_the_image() {
        let mut img = Image::new(4, 4);
        draw_line(
            &mut img,
            Vec2::new(-100.0, 1.5),
            Vec2::new(100.0, 1.5),
            [1.0; 3],
        );
        let row: Vec<f32> = (0..4).map(|x| img.pixel(x, 1)[0]).collect();
        assert_eq!(row, vec![1.0; 4]);
        assert_eq!(img.pixel(0, 0)[0], 0.0);
    }
}
