//! Mitsuba's canonical shapes that are exactly representable as triangle meshes (object space).

use glam::{Vec2, Vec3};

/// Mitsuba `rectangle`: [-1, 1]² in the z = 0 plane, normal +Z, uv = (x + 1, y + 1) / 2.
pub fn rectangle_mesh() -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let n = vec![Vec3::Z; 4];
    let uv = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    (p, n, uv, vec![[0, 1, 2], [0, 2, 3]])
}

/// Mitsuba `cube`: [-1, 1]³ with 24 vertices (4 per face), per-face outward normals, 12 triangles.
pub fn cube_mesh() -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>) {
    let mut p = Vec::with_capacity(24);
    let mut n = Vec::with_capacity(24);
    let mut uv = Vec::with_capacity(24);
    let mut idx = Vec::with_capacity(12);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut normal = Vec3::ZERO;
            normal[axis] = sign;
            // Two tangent axes ordered so that (t1 × t2) = normal: counter-clockwise seen from outside.
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = p.len() as u32;
            for (k, (s1, s2)) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .iter()
                .enumerate()
            {
                let mut v = Vec3::ZERO;
                v[axis] = sign;
                v[a1] = *s1;
                v[a2] = *s2 * sign;
                p.push(v);
                n.push(normal);
                uv.push(
                    [
                        Vec2::new(0.0, 0.0),
                        Vec2::new(1.0, 0.0),
                        Vec2::new(1.0, 1.0),
                        Vec2::new(0.0, 1.0),
                    ][k],
                );
            }
            idx.push([base, base + 1, base + 2]);
            idx.push([base, base + 2, base + 3]);
        }
    }
    (p, n, uv, idx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_wind_outwards() {
        let (p, n, _, idx) = cube_mesh();
        assert_eq!(p.len(), 24);
        assert_eq!(idx.len(), 12);
        for t in idx {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            assert!(
                (face - n[t[0] as usize]).length() < 1e-6,
                "{face} vs {}",
                n[t[0] as usize]
            );
            assert!(face.dot((a + b + c) / 3.0) > 0.0);
        }
    }

    #[test]
    fn rectangle_faces_plus_z() {
        let (p, _, _, idx) = rectangle_mesh();
        for t in idx {
            let [a, b, c] = t.map(|i| p[i as usize]);
            assert!((b - a).cross(c - a).normalize().abs_diff_eq(Vec3::Z, 1e-6));
        }
    }
}
