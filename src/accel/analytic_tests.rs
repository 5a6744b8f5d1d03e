use super::*;

fn scale(x: f32, y: f32, z: f32) -> Mat4 {
    Mat4::from_scale(Vec3::new(x, y, z))
}

fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
    Ray::new(Vec3::from(o), Vec3::from(d))
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

/// Outside and inside a sphere, the nearer root in the interval; the surface re-projected.
#[test]
fn sphere_outside_inside_and_interval() {
    let s = Analytic::new(Kind::Sphere, Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_scale(Vec3::splat(0.5)), false).unwrap();
    let r = ray([1.0, 2.0, 10.0], [0.0, 0.0, -1.0]);
    assert_eq!(s.intersect(&r), Some(6.5));
    let inside = ray([1.0, 2.0, 3.0], [0.0, 0.0, -2.0]);
    assert_eq!(s.intersect(&inside), Some(0.25));
    assert_eq!(s.intersect(&Ray { t_max: 6.4, ..r }), None);
    assert_eq!(s.intersect(&Ray { t_min: 6.6, ..r }), Some(7.5));
    // The segment lies inside: no hit.
    assert_eq!(s.intersect(&Ray { t_min: 6.6, t_max: 7.4, ..r }), None);
    let sp = s.surface(&r, 6.5);
    assert!(close(sp.p, Vec3::new(1.0, 2.0, 3.5), 1e-6) && close(sp.n, Vec3::Z, 1e-6), "{sp:?}");
    assert!(sp.p_error.max_element() > 0.0 && sp.p_error.max_element() < 1e-5);
}

/// A ray tangent to the sphere hits it; one a little farther out misses.
#[test]
fn grazing_rays() {
    let s = Analytic::new(Kind::Sphere, Mat4::IDENTITY, false).unwrap();
    assert!(s.intersect(&ray([-5.0, 1.0, 0.0], [1.0, 0.0, 0.0])).is_some());
    assert!(s.intersect(&ray([-5.0, 1.000_001, 0.0], [1.0, 0.0, 0.0])).is_none());
    let c = Analytic::new(Kind::Cylinder, Mat4::IDENTITY, false).unwrap();
    assert!(c.intersect(&ray([-5.0, 1.000_001, 0.5], [1.0, 0.0, 0.0])).is_none());
    // Along the axis: parallel to the tube, no hit; a disk seen edge-on: none.
    assert!(c.intersect(&ray([0.0, 0.0, -1.0], [0.0, 0.0, 1.0])).is_none());
    let d = Analytic::new(Kind::Disk, Mat4::IDENTITY, false).unwrap();
    assert!(d.intersect(&ray([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0])).is_none());
}

/// Far from the origin, the f64 solution from the closest point keeps the hit on the surface.
#[test]
fn far_from_the_origin() {
    let s = Analytic::new(Kind::Sphere, Mat4::from_translation(Vec3::new(3.0e6, 0.0, 0.0)), false).unwrap();
    let r = ray([0.0, 0.5, 0.0], [1.0, 0.0, 0.0]);
    let t = s.intersect(&r).unwrap();
    let expect = 3.0e6 - 0.75f64.sqrt();
    assert!((f64::from(t) - expect).abs() <= 0.25, "{t}");
    let sp = s.surface(&r, t);
    assert!(((sp.p.as_dvec3() - DVec3::new(3.0e6, 0.0, 0.0)).length() - 1.0).abs() < 1e-6 * 3.0e6 / 2.0);
    // A ray from far away towards a unit sphere at the origin: the hit is on the sphere.
    let s = Analytic::new(Kind::Sphere, Mat4::IDENTITY, false).unwrap();
    let r = ray([1.0e7, 0.3, 0.2], [-1.0, 0.0, 0.0]);
    let sp = s.surface(&r, s.intersect(&r).unwrap());
    assert!((sp.p.length() - 1.0).abs() < 1e-6 && sp.p.x > 0.9, "{sp:?}");
}

/// Mitsuba 3.9.1's answers (scalar_rgb, `ray_intersect`) under non-uniform scales and mirrors.
#[test]
fn non_uniform_scale_and_flips_as_mitsuba() {
    // Sphere, scale(2, 1, 1): Mitsuba intersects the sphere of radius 2.
    let s = Analytic::new(Kind::Sphere, scale(2.0, 1.0, 1.0), false).unwrap();
    let r = ray([5.0, 0.0, 0.3], [-1.0, 0.0, 0.0]);
    let t = s.intersect(&r).unwrap();
    assert!((t - 3.022_628).abs() < 1e-5, "{t}");
    let sp = s.surface(&r, t);
    assert!(close(sp.p, Vec3::new(1.97737, 0.0, 0.3), 1e-5) && (sp.uv - Vec2::new(0.0, 0.414_215)).abs().max_element() < 1e-5, "{sp:?}");
    assert_eq!(s.intersect(&ray([0.0, 0.0, 5.0], [0.0, 0.0, -1.0])), Some(3.0));
    // Mirrored spheres face in (sphere.cpp: a negative scale toggles flip_normals); flip_normals too.
    for (m, flip, n) in [(scale(-1.0, 1.0, 1.0), false, -1.0), (scale(-1.0, -1.0, -1.0), false, -1.0), (Mat4::IDENTITY, true, -1.0), (scale(-1.0, 1.0, 1.0), true, 1.0)] {
        let s = Analytic::new(Kind::Sphere, m, flip).unwrap();
        let r = ray([0.0, 0.0, 5.0], [0.0, 0.0, -1.0]);
        assert_eq!(s.surface(&r, 4.0).n, Vec3::new(0.0, 0.0, n), "{m} {flip}");
    }
    let s = Analytic::new(Kind::Sphere, scale(-1.0, -1.0, -1.0), false).unwrap();
    let r = ray([5.0, 0.0, 0.3], [-1.0, 0.0, 0.0]);
    let uv = s.surface(&r, s.intersect(&r).unwrap()).uv;
    assert!((uv - Vec2::new(0.5, 0.596_987)).abs().max_element() < 1e-5, "{uv}");

    // Cylinder, scale(2, 0.5, 1): an elliptic tube in object space.
    let c = Analytic::new(Kind::Cylinder, scale(2.0, 0.5, 1.0), false).unwrap();
    let r = ray([5.0, 0.1, 0.3], [-1.0, 0.0, 0.0]);
    let t = c.intersect(&r).unwrap();
    assert!((t - 3.040_408).abs() < 1e-5, "{t}");
    let sp = c.surface(&r, t);
    assert!(close(sp.n, Vec3::new(0.774_597, 0.632_456, 0.0), 1e-5) && (sp.uv - Vec2::new(0.032_047_1, 0.3)).abs().max_element() < 1e-5, "{sp:?}");
    assert!(close(c.derivatives(sp.p).0, Vec3::new(-2.51327, 3.07812, 0.0), 1e-4));
    // Mirrored: still facing out (the mirror's two flips cancel), u running the other way.
    let c = Analytic::new(Kind::Cylinder, scale(-1.0, 1.0, 1.0), false).unwrap();
    let r = ray([5.0, 0.1, 0.3], [-1.0, 0.0, 0.0]);
    let sp = c.surface(&r, c.intersect(&r).unwrap());
    assert!(sp.n.x > 0.99 && (sp.uv.x - 0.484_058).abs() < 1e-5, "{sp:?}");
    assert!(Analytic::new(Kind::Cylinder, Mat4::IDENTITY, true).unwrap().surface(&r, 4.005_012_5).n.x < -0.99);
    // Outside [0, 1] along the axis: the far wall where the near one is cut off.
    let c = Analytic::new(Kind::Cylinder, Mat4::IDENTITY, false).unwrap();
    assert!(c.intersect(&ray([5.0, 0.0, 1.5], [-1.0, 0.0, 0.0])).is_none());
    let t = c.intersect(&ray([0.0, 0.0, 2.0], [0.5, 0.0, -1.0])).unwrap();
    assert!((t - 2.0).abs() < 1e-6, "{t}");

    // Disk, scale(2, 0.5, 1).
    let d = Analytic::new(Kind::Disk, scale(2.0, 0.5, 1.0), false).unwrap();
    let r = ray([0.3, 0.2, 1.0], [0.0, 0.0, -1.0]);
    assert_eq!(d.intersect(&r), Some(1.0));
    let sp = d.surface(&r, 1.0);
    assert!((sp.uv - Vec2::new(0.4272, 0.1929)).abs().max_element() < 1e-4 && sp.n == Vec3::Z, "{sp:?}");
    let (du, dv) = d.derivatives(sp.p);
    assert!(close(du, Vec3::new(0.702_247, 0.468_165, 0.0), 1e-5) && close(dv, Vec3::new(-5.02655, 0.471_239, 0.0), 1e-4), "{du} {dv}");
    assert!(d.intersect(&ray([1.9, 0.0, 1.0], [0.0, 0.0, -1.0])).is_some());
    assert!(d.intersect(&ray([0.0, 0.6, 1.0], [0.0, 0.0, -1.0])).is_none());
    // flip_normals: the normal faces −z, the uvs unchanged.
    let f = Analytic::new(Kind::Disk, scale(2.0, 0.5, 1.0), true).unwrap();
    let sf = f.surface(&r, 1.0);
    assert!(sf.n == -Vec3::Z && sf.uv == sp.uv, "{sf:?}");
}

/// The boxes hold the surfaces (points of many hits), under rotations and non-uniform scales.
#[test]
fn bounds_hold_the_surface() {
    let m = Mat4::from_scale_rotation_translation(Vec3::new(0.3, 2.0, 0.7), glam::Quat::from_rotation_y(0.4) * glam::Quat::from_rotation_x(1.1), Vec3::new(-3.0, 1.0, 2.0));
    for kind in [Kind::Sphere, Kind::Disk, Kind::Cylinder] {
        let s = Analytic::new(kind, m, false).unwrap();
        let b = s.bounds();
        let c = b.center();
        let mut sampler = crate::sampler::Sampler::for_key(5, 0, 0);
        let mut hits = 0;
        for _ in 0..2000 {
            let mut v = || 2.0 * sampler.next_1d() - 1.0;
            let o = c + Vec3::new(v(), v(), v()) * 10.0;
            let r = Ray::new(o, c + Vec3::new(v(), v(), v()) - o);
            if let Some(t) = s.intersect(&r) {
                hits += 1;
                assert!(b.contains(s.surface(&r, t).p), "{kind:?}");
            }
        }
        assert!(hits > 100, "{kind:?}: {hits}");
    }
    assert!(Analytic::new(Kind::Disk, scale(1.0, 0.0, 1.0), false).is_none());
}
