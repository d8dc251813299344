//! Camera conventions (Mitsuba 3): frame, field of view, clip planes, thin lens, projection.

use focal_render::camera::{camera_from_desc, x_fov_from_axis, Camera, FovAxis};
use focal_render::desc::{ObjectClass, ObjectDesc, PropValue, Property};
use focal_render::error::SourceLoc;
use focal_render::sampler::Pcg32;
use glam::{Mat4, UVec2, Vec2, Vec3};
use std::path::Path;

fn loc() -> SourceLoc {
    SourceLoc::file_only(Path::new("test.xml"))
}

fn sensor(plugin: &str, props: Vec<(&str, PropValue)>) -> ObjectDesc {
    ObjectDesc {
        class: ObjectClass::Sensor,
        plugin: plugin.to_string(),
        id: None,
        props: props
            .into_iter()
            .map(|(name, value)| Property {
                name: name.to_string(),
                value,
                loc: loc(),
            })
            .collect(),
        children: Vec::new(),
        loc: loc(),
    }
}

/// Mitsuba's `lookat`: columns (left, up', dir, origin) with left = up × dir, up' = dir × left.
fn lookat(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let dir = (target - origin).normalize();
    let left = up.normalize().cross(dir).normalize();
    let new_up = dir.cross(left);
    Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    )
}

const ORIGIN: Vec3 = Vec3::new(1.0, 2.0, 3.0);
const TARGET: Vec3 = Vec3::new(-2.0, 1.0, -4.0);
const UP: Vec3 = Vec3::new(0.1, 1.0, 0.0);

fn camera(fov: f64, axis: &str, size: UVec2) -> Camera {
    let s = sensor(
        "perspective",
        vec![
            ("fov", PropValue::Float(fov)),
            ("fov_axis", PropValue::String(axis.into())),
            ("to_world", PropValue::Transform(lookat(ORIGIN, TARGET, UP))),
        ],
    );
    camera_from_desc(&s, size).unwrap()
}

fn dir() -> Vec3 {
    (TARGET - ORIGIN).normalize()
}
fn right() -> Vec3 {
    dir().cross(UP).normalize()
}
fn up() -> Vec3 {
    right().cross(dir())
}
fn angle_deg(a: Vec3, b: Vec3) -> f32 {
    a.normalize()
        .dot(b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

#[test]
fn centre_ray_follows_lookat_direction_and_starts_on_near_plane() {
    let cam = camera(40.0, "x", UVec2::new(320, 240));
    let ray = cam.generate_ray(Vec2::new(160.0, 120.0), Vec2::splat(0.5));
    assert!(
        (ray.d - dir()).length() < 1e-5,
        "{:?} vs {:?}",
        ray.d,
        dir()
    );
    assert!((ray.d.length() - 1.0).abs() < 1e-6);
    assert!((ray.o - (ORIGIN + dir() * 0.01)).length() < 1e-5);
    assert!((ray.t_max - (1e4 - 0.01)).abs() < 1e-1);
    assert_eq!(cam.position(), ORIGIN);
}

#[test]
fn off_axis_rays_start_on_near_plane_and_end_on_far_plane() {
    let s = sensor(
        "perspective",
        vec![
            ("fov", PropValue::Float(70.0)),
            ("near_clip", PropValue::Float(0.5)),
            ("far_clip", PropValue::Float(20.0)),
            ("to_world", PropValue::Transform(lookat(ORIGIN, TARGET, UP))),
        ],
    );
    let cam = camera_from_desc(&s, UVec2::new(64, 48)).unwrap();
    let ray = cam.generate_ray(Vec2::new(3.0, 40.0), Vec2::ZERO);
    let depth = |p: Vec3| (p - ORIGIN).dot(dir());
    assert!((depth(ray.o) - 0.5).abs() < 1e-5);
    assert!((depth(ray.at(ray.t_max)) - 20.0).abs() < 1e-3);
}

#[test]
fn fov_x_90_right_edge_is_45_degrees_to_the_right_and_row_zero_is_up() {
    let size = UVec2::new(200, 100);
    let cam = camera(90.0, "x", size);
    let r = cam.generate_ray(Vec2::new(200.0, 50.0), Vec2::ZERO);
    assert!((angle_deg(r.d, dir()) - 45.0).abs() < 1e-3);
    assert!(
        r.d.dot(right()) > 0.7,
        "right edge must point to the camera's right"
    );
    assert!(r.d.dot(up()).abs() < 1e-5);
    let l = cam.generate_ray(Vec2::new(0.0, 50.0), Vec2::ZERO);
    assert!(l.d.dot(right()) < -0.7);
    // Row 0 is the top: vertical half-angle atan(tan 45° / aspect).
    let t = cam.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO);
    assert!(t.d.dot(up()) > 0.4);
    assert!((angle_deg(t.d, dir()) - 0.5f32.atan().to_degrees()).abs() < 1e-3);
    let b = cam.generate_ray(Vec2::new(100.0, 100.0), Vec2::ZERO);
    assert!(b.d.dot(up()) < -0.4);
}

#[test]
fn points_right_of_and_above_the_camera_project_to_the_right_half_and_top_half() {
    let size = UVec2::new(160, 120);
    let cam = camera(60.0, "x", size);
    let p = ORIGIN + dir() * 5.0 + right() * 1.0;
    let f = cam.world_to_film(p).unwrap();
    assert!(f.x > 80.0 && (f.y - 60.0).abs() < 1e-3, "{f:?}");
    let q = ORIGIN + dir() * 5.0 + up() * 1.0;
    let g = cam.world_to_film(q).unwrap();
    assert!(g.y < 60.0 && (g.x - 80.0).abs() < 1e-3, "{g:?}");
    assert!(
        cam.world_to_film(ORIGIN - dir()).is_none(),
        "points behind the camera do not project"
    );
}

#[test]
fn world_to_film_inverts_generate_ray() {
    let cam = camera(50.0, "smaller", UVec2::new(90, 130));
    let mut rng = Pcg32::new(7, 1);
    for _ in 0..200 {
        let f = Vec2::new(rng.next_f32() * 90.0, rng.next_f32() * 130.0);
        let ray = cam.generate_ray(f, Vec2::ZERO);
        let t = 0.1 + 10.0 * rng.next_f32();
        let back = cam.world_to_film(ray.at(t)).unwrap();
        assert!((back - f).length() < 2e-3, "{f:?} -> {back:?}");
    }
}

#[test]
fn fov_axis_conversions_match_mitsuba() {
    // y: the vertical half-angle is fov/2.
    let size = UVec2::new(200, 100);
    let cam = camera(40.0, "y", size);
    let t = cam.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO);
    assert!((angle_deg(t.d, dir()) - 20.0).abs() < 1e-3);
    // diagonal: a corner ray makes fov/2 with the axis.
    let cam = camera(40.0, "diagonal", size);
    let c = cam.generate_ray(Vec2::new(200.0, 0.0), Vec2::ZERO);
    assert!((angle_deg(c.d, dir()) - 20.0).abs() < 1e-3);
    // smaller / larger on a landscape film are y / x; on a portrait film x / y.
    let edge_angle =
        |cam: &Camera, pos: Vec2| angle_deg(cam.generate_ray(pos, Vec2::ZERO).d, dir());
    assert!(
        (edge_angle(&camera(30.0, "smaller", size), Vec2::new(100.0, 0.0)) - 15.0).abs() < 1e-3
    );
    assert!(
        (edge_angle(&camera(30.0, "larger", size), Vec2::new(200.0, 50.0)) - 15.0).abs() < 1e-3
    );
    let portrait = UVec2::new(100, 200);
    assert!(
        (edge_angle(&camera(30.0, "smaller", portrait), Vec2::new(100.0, 100.0)) - 15.0).abs()
            < 1e-3
    );
    assert!(
        (edge_angle(&camera(30.0, "larger", portrait), Vec2::new(50.0, 0.0)) - 15.0).abs() < 1e-3
    );
    // Formulas directly: y → x on aspect 2.
    let x = x_fov_from_axis(40.0, FovAxis::Y, 2.0);
    assert!((x - 2.0 * (20f64.to_radians().tan() * 2.0).atan().to_degrees()).abs() < 1e-9);
}

#[test]
fn default_focal_length_gives_38_18_degrees_on_768x576() {
    let s = sensor("perspective", vec![]);
    let cam = camera_from_desc(&s, UVec2::new(768, 576)).unwrap();
    let x_fov = cam.projection().x_fov_degrees();
    assert!((x_fov - 38.18).abs() < 0.005, "x fov {x_fov}");
    let edge = cam.generate_ray(Vec2::new(768.0, 288.0), Vec2::ZERO);
    assert!((2.0 * angle_deg(edge.d, Vec3::Z) - 38.18).abs() < 0.01);
    // "50mm", 50 (float) and the default agree; a longer lens narrows the view.
    for v in [
        PropValue::String("50mm".into()),
        PropValue::Float(50.0),
        PropValue::String("50".into()),
    ] {
        let c = camera_from_desc(
            &sensor("perspective", vec![("focal_length", v)]),
            UVec2::new(768, 576),
        )
        .unwrap();
        assert!((c.projection().x_fov_degrees() - x_fov).abs() < 1e-9);
    }
    let tele = sensor(
        "perspective",
        vec![("focal_length", PropValue::String("100mm".into()))],
    );
    assert!(
        camera_from_desc(&tele, UVec2::new(768, 576))
            .unwrap()
            .projection()
            .x_fov_degrees()
            < 25.0
    );
}

#[test]
fn thin_lens_rays_converge_on_the_focus_plane() {
    let to_world = lookat(ORIGIN, TARGET, UP);
    let s = sensor(
        "thinlens",
        vec![
            ("fov", PropValue::Float(45.0)),
            ("aperture_radius", PropValue::Float(0.2)),
            ("focus_distance", PropValue::Float(4.0)),
            ("to_world", PropValue::Transform(to_world)),
        ],
    );
    let cam = camera_from_desc(&s, UVec2::new(100, 80)).unwrap();
    let pin = camera(45.0, "x", UVec2::new(100, 80));
    let depth = |p: Vec3| (p - ORIGIN).dot(dir());
    let mut rng = Pcg32::new(3, 9);
    for _ in 0..20 {
        let f = Vec2::new(rng.next_f32() * 100.0, rng.next_f32() * 80.0);
        let pinhole_ray = pin.generate_ray(f, Vec2::ZERO);
        let target = pinhole_ray.at((4.0 - depth(pinhole_ray.o)) / pinhole_ray.d.dot(dir()));
        let mut origins = Vec::new();
        for _ in 0..8 {
            let ray = cam.generate_ray(f, Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!((ray.d.length() - 1.0).abs() < 1e-5);
            assert!(
                (depth(ray.o) - 0.01).abs() < 1e-5,
                "starts on the near plane"
            );
            let hit = ray.at((4.0 - depth(ray.o)) / ray.d.dot(dir()));
            assert!((hit - target).length() < 1e-4, "{hit:?} vs {target:?}");
            assert!(
                (ray.o - ORIGIN).length() < 0.2 + 0.02,
                "starts within the aperture"
            );
            origins.push(ray.o);
        }
        assert!(
            origins.iter().any(|o| (*o - origins[0]).length() > 1e-3),
            "lens samples spread"
        );
    }
}

#[test]
fn mirrored_camera_flips_the_image_and_scale_is_rejected() {
    let mirror = lookat(ORIGIN, TARGET, UP) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let s = sensor(
        "perspective",
        vec![("to_world", PropValue::Transform(mirror))],
    );
    let cam = camera_from_desc(&s, UVec2::new(100, 100)).unwrap();
    let f = cam.world_to_film(ORIGIN + dir() * 5.0 + right()).unwrap();
    assert!(f.x < 50.0, "a reflection mirrors the image, as in Mitsuba");

    let scaled = lookat(ORIGIN, TARGET, UP) * Mat4::from_scale(Vec3::splat(2.0));
    let s = sensor(
        "perspective",
        vec![("to_world", PropValue::Transform(scaled))],
    );
    let err = camera_from_desc(&s, UVec2::new(100, 100)).unwrap_err();
    assert!(err.message.contains("scale"), "{}", err.message);
    assert!(err.loc.is_some());
}

#[test]
fn invalid_sensors_are_scene_errors() {
    let size = UVec2::new(10, 10);
    let bad = [
        sensor("orthographic", vec![]),
        sensor(
            "perspective",
            vec![
                ("fov", PropValue::Float(40.0)),
                ("focal_length", PropValue::String("35mm".into())),
            ],
        ),
        sensor(
            "perspective",
            vec![
                ("fov", PropValue::Float(40.0)),
                ("fov_axis", PropValue::String("z".into())),
            ],
        ),
        sensor("perspective", vec![("fov", PropValue::Float(180.0))]),
        sensor(
            "perspective",
            vec![("focal_length", PropValue::String("wide".into()))],
        ),
        sensor("perspective", vec![("near_clip", PropValue::Float(0.0))]),
        sensor(
            "perspective",
            vec![
                ("near_clip", PropValue::Float(5.0)),
                ("far_clip", PropValue::Float(1.0)),
            ],
        ),
        sensor("thinlens", vec![("focus_distance", PropValue::Float(2.0))]),
        sensor(
            "thinlens",
            vec![("aperture_radius", PropValue::Float(-1.0))],
        ),
    ];
    for s in &bad {
        assert!(
            camera_from_desc(s, size).is_err(),
            "{s:?} should be rejected"
        );
    }
}
