//! Surfaces just in front of a ray's origin are hit: a path vertex in a room's corner must not see
//! through the adjacent wall (the BVH's node test once culled everything within 1e-4 of the origin, and
//! the camera obscura's brightest samples were such leaks to its sky); and directions with −0
//! components find what they point at.

use focal_render::load::load_scene;
use focal_render::ray::Ray;
use glam::Vec3;

/// A 2 m ceiling at y = 1 facing down (a Mitsuba rectangle turned about x), and a floor at y = −1.
const SCENE: &str = r#"<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="1"/><rotate x="1" angle="90"/><translate y="1"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="1"/><rotate x="1" angle="-90"/><translate y="-1"/></transform>
        <bsdf type="diffuse"/>
    </shape>
</scene>"#;

#[test]
fn surfaces_within_a_hair_of_the_origin_are_hit_and_occlude() {
    let dir = std::env::temp_dir().join(format!("focal_near_hits_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ceiling.xml");
    std::fs::write(&path, SCENE).unwrap();
    let scene = load_scene(&path, &[], &Default::default()).unwrap().scene;
    for gap in [1e-7f32, 1e-6, 1e-5, 5e-5, 1e-4, 1e-3, 0.1] {
        for d in [Vec3::Y, Vec3::new(0.42, 0.74, 0.53).normalize()] {
            let o = Vec3::new(0.3, 1.0 - gap, -0.2);
            let hit = scene.intersect(&Ray::new(o, d));
            let expected = (1.0 - o.y) / d.y;
            let t = hit.map(|h| h.t);
            assert!(
                t.is_some_and(|t| (t - expected).abs() <= 1e-6 + 1e-4 * expected),
                "a ray {gap} below the ceiling going {d} found {t:?}, expected {expected}"
            );
            assert!(
                scene.occluded(&Ray::segment(o, d, 2.0 * expected + 1e-3)),
                "the ceiling {gap} away does not block a shadow ray going {d}"
            );
            // Short of the surface nothing is hit.
            assert!(!scene.occluded(&Ray::segment(o, d, 0.5 * expected)));
        }
    }
    // Away from the ceiling (down towards the floor) the shift behind the origin must not make the
    // ray find the surface it leaves; -Vec3::Y has −0 components, which once made the BVH miss all.
    let o = Vec3::new(0.3, 1.0 - 1e-5, -0.2);
    let hit = scene.intersect(&Ray::new(o, -Vec3::Y)).expect("the floor");
    let expected = o.y + 1.0;
    assert!(
        (hit.t - expected).abs() < 1e-3,
        "{} against {expected}",
        hit.t
    );
    let _ = std::fs::remove_dir_all(&dir);
}
