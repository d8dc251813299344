//! What a focal octree learned: the leaves' density on an axis-aligned slice through the guide's box,
//! by default through the centre of the densest leaf and across the axis the camera looks along most,
//! as a false-colour log-scale image (see [`super::colour_map::false_colour_log`]).
//!
//! The value of a point is the guide's spatial density there, `(1 − p_div)·conv + p_div·div` of the
//! leaves containing it (leaves partition the box, so every point has exactly one leaf per tree).

use super::colour_map::false_colour_log;
use crate::film::Image;
use focal_guiding::octree::{FocalOctreeGuide, FocalTree};
use focal_guiding::GuidingField;
use glam::{DVec3, Vec3};

/// Where a slice lies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlicePlane {
    /// Axis the plane is perpendicular to (0 = x, 1 = y, 2 = z).
    pub axis: usize,
    /// Coordinate of the plane along `axis` (world units).
    pub position: f64,
}

/// A slice image and where it was taken.
pub struct OctreeSlice {
    /// Linear density per pixel (grey: the same value in R, G and B).
    pub density: Image,
    /// The plane.
    pub plane: SlicePlane,
    /// World-space box of the image: image x runs along `axes.0`, image y (downwards) along `axes.1`
    /// from its maximum to its minimum.
    pub axes: (usize, usize),
}

/// The world box of a leaf at lattice `cell` of `depth`.
fn leaf_box(tree: &FocalTree, depth: u32, cell: glam::UVec3) -> (DVec3, DVec3) {
    let b = tree.aabb();
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let n = (1u64 << (depth + 1)) as f64;
    let size = (hi - lo) / n;
    let min = lo + size * cell.as_dvec3();
    (min, min + size)
}

/// The plane through the centre of the densest leaf of either tree, perpendicular to the axis of the
/// largest component of `view_dir` (so the slice faces the camera).
pub fn default_plane(guide: &FocalOctreeGuide, view_dir: Vec3) -> SlicePlane {
    let a = view_dir.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let mut best: Option<(f32, f64)> = None;
    for tree in [guide.converging(), guide.diverging()] {
        for leaf in tree.leaves() {
            if best.is_none_or(|(d, _)| leaf.density > d) {
                let (lo, hi) = leaf_box(tree, leaf.depth, leaf.cell);
                best = Some((leaf.density, 0.5 * (lo[axis] + hi[axis])));
            }
        }
    }
    let b = guide.aabb();
    let centre = 0.5 * (b.min[axis] as f64 + b.max[axis] as f64);
    SlicePlane {
        axis,
        position: best.map_or(centre, |(_, p)| p),
    }
}

/// The density on `plane`, `resolution` pixels along the longer side of the box's cross-section.
pub fn octree_slice(guide: &FocalOctreeGuide, plane: SlicePlane, resolution: u32) -> OctreeSlice {
    let (u, v) = match plane.axis {
        0 => (2, 1),
        1 => (0, 2),
        _ => (0, 1),
    };
    let b = guide.aabb();
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let (eu, ev) = (hi[u] - lo[u], hi[v] - lo[v]);
    let res = resolution.max(2) as f64;
    let (w, h) = if eu >= ev {
        (res as u32, ((res * ev / eu).round() as u32).max(1))
    } else {
        (((res * eu / ev).round() as u32).max(1), res as u32)
    };
    let mut density = Image::new(w, h);
    let shares = [1.0 - guide.p_div(), guide.p_div()];
    for (tree, share) in [guide.converging(), guide.diverging()]
        .into_iter()
        .zip(shares)
    {
        for leaf in tree.leaves() {
            let (min, max) = leaf_box(tree, leaf.depth, leaf.cell);
            // Leaves are half-open boxes; the plane lies in exactly one leaf along its axis.
            let inside = plane.position >= min[plane.axis]
                && (plane.position < max[plane.axis]
                    || (max[plane.axis] >= hi[plane.axis] && plane.position <= max[plane.axis]));
            if !inside {
                continue;
            }
            let value = (share * leaf.density as f64) as f32;
            let to_px =
                |x: f64, lo_: f64, e: f64, n: u32| ((x - lo_) / e * n as f64).round() as i64;
            let x0 = to_px(min[u], lo[u], eu, w).clamp(0, w as i64);
            let x1 = to_px(max[u], lo[u], eu, w).clamp(0, w as i64);
            // Image rows run from the top (maximum v) down.
            let y0 = (h as i64 - to_px(max[v], lo[v], ev, h)).clamp(0, h as i64);
            let y1 = (h as i64 - to_px(min[v], lo[v], ev, h)).clamp(0, h as i64);
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = &mut density.rgb[y as usize * w as usize + x as usize];
                    p[0] += value;
                    p[1] = p[0];
                    p[2] = p[0];
                }
            }
        }
    }
    OctreeSlice {
        density,
        plane,
        axes: (u, v),
    }
}

/// The false-colour picture of a slice (log scale over 4 decades below its maximum).
pub fn octree_slice_picture(slice: &OctreeSlice) -> Image {
    false_colour_log(&slice.density, 4.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use focal_guiding::octree::OctreeGuideConfig;
    use focal_guiding::Aabb3;

    #[test]
    fn slice_has_the_box_aspect_and_faces_the_camera() {
        let aabb = Aabb3 {
            min: Vec3::new(0.0, 0.0, 0.0),
            max: Vec3::new(2.0, 1.0, 1.0),
        };
        let guide = FocalOctreeGuide::new(aabb, OctreeGuideConfig::default()).unwrap();
        let plane = default_plane(&guide, Vec3::new(0.1, -0.2, 0.9));
        assert_eq!(plane.axis, 2);
        assert!(plane.position > 0.0 && plane.position < 1.0);
        let slice = octree_slice(&guide, plane, 64);
        assert_eq!((slice.density.width, slice.density.height), (64, 32));
        assert_eq!(slice.axes, (0, 1));
        // Every pixel lies in exactly one leaf per tree: no gaps, no double counting, so an untrained
        // (uniform) guide gives one value everywhere.
        let first = slice.density.rgb[0][0];
        assert!(slice.density.rgb.iter().all(|p| p[0] == first));
        assert!(first.is_finite() && first > 0.0, "{first}");
        let pic = octree_slice_picture(&slice);
        assert_eq!(pic.rgb.len(), slice.density.rgb.len());
    }
}
