//! Pictures of what a guide learned, seen from the camera.

use crate::camera::Camera;
use crate::color::srgb_to_linear;
use crate::film::{FilmSpec, Image};
use focal_guiding::GuidingField;
use glam::Vec2;

/// The guide's directional pdf at the camera position for the central ray of every pixel (Rath et al.'s
/// `d.pdf` AOV): bright where the learned density lies along the line of sight, so focal points and the
/// paths' crossing regions show up as they would be seen through the lens.
pub fn guide_pdf_image(camera: &Camera, spec: &FilmSpec, guide: &dyn GuidingField) -> Image {
    let (w, h) = (spec.crop_size.x, spec.crop_size.y);
    let mut image = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let pos = Vec2::new(
                (spec.crop_offset.x + x) as f32 + 0.5,
                (spec.crop_offset.y + y) as f32 + 0.5,
            );
            let ray = camera.generate_ray(pos, Vec2::splat(0.5));
            let p = guide.pdf_at(ray.o, None, ray.d);
            let p = if p.is_finite() { p.max(0.0) } else { 0.0 };
            image.rgb[(y * w + x) as usize] = [p; 3];
        }
    }
    image
}

/// A false-colour version of a non-negative scalar image on a log scale spanning `decades` below its
/// maximum (viridis-like: dark blue = low, yellow = high), as linear RGB ready for `write_png`.
pub fn false_colour_log(values: &Image, decades: f32) -> Image {
    let max = values
        .rgb
        .iter()
        .map(|p| p[0])
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    let mut out = Image::new(values.width, values.height);
    for (o, v) in out.rgb.iter_mut().zip(&values.rgb) {
        let t = if max > 0.0 && v[0] > 0.0 {
            ((v[0] / max).log10() / decades + 1.0).clamp(0.0, 1.0)
        } else {
            0.0
        };
        *o = viridis(t).map(srgb_to_linear);
    }
    out
}

/// A perceptually ordered dark-blue → green → yellow map (viridis control points), sRGB-encoded.
pub fn viridis(t: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.230, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    std::array::from_fn(|c| STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f)
}

/// A picture of the structure a guide learned, and a one-line caption: for a Gaussian mixture its
/// components' 2σ ellipsoids projected over `render` (see [`super::guide_ellipses`]), for the octree
/// the leaves' density on the default slice (see [`super::octree_slice`]). The concrete model is found
/// behind any layers ([`GuidingField::as_any`]). `None` for an unknown guide.
pub fn guide_structure_image(
    camera: &Camera,
    spec: &FilmSpec,
    guide: &dyn GuidingField,
    render: &Image,
) -> Option<(Image, String)> {
    use super::{guide_ellipses, octree_slice};
    let any = guide.as_any();
    if let Some(g) = any.downcast_ref::<focal_guiding::GmmGuide>() {
        {
            let comps = guide_ellipses::project_components(camera, spec, g);
            let caption = format!(
                "{} Gaussian components ({} converging, {} diverging, p_div {:.2}): 2σ ellipsoids \
                 projected through the camera, colour by weight (viridis, yellow = heaviest)",
                comps.len(),
                comps.iter().filter(|c| !c.diverging).count(),
                comps.iter().filter(|c| c.diverging).count(),
                g.p_div()
            );
            Some((guide_ellipses::ellipse_overlay(render, &comps), caption))
        }
    } else if let Some(g) = any.downcast_ref::<focal_guiding::octree::FocalOctreeGuide>() {
        {
            let view = camera.to_world().transform_vector3(glam::Vec3::Z);
            let plane = octree_slice::default_plane(g, view);
            let slice = octree_slice::octree_slice(g, plane, 512);
            let axis = ["x", "y", "z"];
            let caption = format!(
                "octree leaf density on the slice {} = {:.4} (through the densest leaf; image x = {}, \
                 y = {} upwards), log scale over 4 decades, {} + {} leaves",
                axis[plane.axis],
                plane.position,
                axis[slice.axes.0],
                axis[slice.axes.1],
                g.converging().leaf_count(),
                g.diverging().leaf_count()
            );
            Some((octree_slice::octree_slice_picture(&slice), caption))
        }
    } else {
        None
    }
}
