//! Pictures of what a guide learned, seen from the camera.

use crate::camera::Camera;
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
