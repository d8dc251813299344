//! Training data and trained guides shared by the GMM training tests: three known foci, a virtual
//! image, and checks on what a guide learned from them.

use focal_guiding::gmm::em::SuffStats;
use focal_guiding::gmm::{Gaussian3, GmmConfig, GmmGuide, Sym3};
use focal_guiding::{GuidingField, TrainingSegment, UpdateStats};
use glam::DVec3;

use super::{context, exit_distance, scene_box, segment_through, Rng};
use std::f64::consts::PI;

/// The three foci of the recovery tests: (weight, Gaussian), in the scene box.
pub fn foci() -> Vec<(f64, Gaussian3)> {
    vec![
        (
            0.5,
            Gaussian3::new(
                DVec3::new(0.2, 0.4, 0.3),
                Sym3::scaled_identity(0.02f64.powi(2)),
            )
            .unwrap(),
        ),
        (
            0.3,
            Gaussian3::new(
                DVec3::new(-0.5, 0.7, 0.6),
                Sym3::scaled_identity(0.03f64.powi(2)),
            )
            .unwrap(),
        ),
        (
            0.2,
            Gaussian3::new(
                DVec3::new(1.0, 0.2, -0.1),
                Sym3::diagonal(DVec3::new(0.04, 0.01, 0.02).powf(2.0)),
            )
            .unwrap(),
        ),
    ]
}

/// Segments through points drawn from the foci mixture, or (with probability `noise`) through uniform
/// points of the box: uniformly random lines.
pub fn focal_batch(rng: &mut Rng, n: usize, noise: f64) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    let foci = foci();
    (0..n)
        .map(|_| {
            let y = if rng.f64() < noise {
                rng.in_box(aabb.min.as_dvec3(), aabb.max.as_dvec3())
            } else {
                let mut u = rng.f64();
                let mut j = 0;
                while j + 1 < foci.len() && u >= foci[j].0 {
                    u -= foci[j].0;
                    j += 1;
                }
                foci[j]
                    .1
                    .point(DVec3::new(rng.normal(), rng.normal(), rng.normal()))
            };
            segment_through(rng, aabb, y, 1.0)
        })
        .collect()
}

/// Segments towards glossy endpoints whose backward lines pass through `VIRTUAL` (a virtual image).
pub const VIRTUAL: DVec3 = DVec3::new(-0.52, 0.77, 0.64);

pub fn virtual_image_batch(rng: &mut Rng, n: usize) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    (0..n)
        .map(|_| {
            let d = rng.sphere();
            let ahead = exit_distance(aabb, VIRTUAL, d);
            let origin = VIRTUAL + d * ((0.05 + 0.5 * rng.f64()) * ahead);
            TrainingSegment {
                origin: origin.as_vec3(),
                direction: d.as_vec3(),
                distance: (0.3 * rng.f64() * exit_distance(aabb, origin, d)) as f32,
                weight: 0.5,
                pdf: (1.0 / (4.0 * PI)) as f32,
                bsdf_pdf: (1.0 / (4.0 * PI)) as f32,
                guide_pdf: 0.0,
                guide_fraction: 0.0,
                glossy_endpoint: true,
                glossy_origin: false,
                refracting_endpoint: false,
                emitted: 0.0,
                emitter_pdf: 0.0,
                pixel_weight: 1.0,
            }
        })
        .collect()
}

pub fn detail(stats: &UpdateStats, key: &str) -> f64 {
    stats
        .details
        .iter()
        .find(|(k, _)| k == key)
        .unwrap_or_else(|| panic!("no detail {key}"))
        .1
}

/// Every number of both mixtures and p_div is finite, and pdf/sample behave at random queries.
pub fn assert_finite(guide: &GmmGuide, rng: &mut Rng) {
    assert!(guide.p_div().is_finite() && (0.0..=1.0).contains(&guide.p_div()));
    for m in [guide.converging_unit(), guide.diverging_unit()] {
        for (w, g) in m.weights().iter().zip(m.components()) {
            assert!(w.is_finite() && *w > 0.0, "weight {w}");
            assert!(g.mean().is_finite() && g.covariance().is_finite());
            assert!(g.log_normalizer().is_finite());
        }
    }
    let (sc, sd) = guide.statistics();
    assert!(sc.iter().chain(sd).all(SuffStats::is_valid));
    for _ in 0..200 {
        let x = rng.in_box(DVec3::splat(-2.0), DVec3::splat(2.0)).as_vec3();
        let d = rng.sphere().as_vec3();
        let n = Some(rng.sphere().as_vec3()).filter(|_| rng.f64() < 0.5);
        let p = guide.pdf_at(x, n, d);
        assert!(p.is_finite() && p >= 0.0, "pdf {p}");
        let u = [rng.f32(), rng.f32(), rng.f32()];
        if let Some(s) = guide.sample_at(x, n, u) {
            assert!(s.direction.is_finite() && s.pdf.is_finite() && s.pdf > 0.0);
        }
    }
}

/// Trains on `iterations` batches of the focal scene without narrowing (the schedule plans three times
/// as many iterations: with the synthetic uniform p_mix, narrowing would only sharpen the weights).
pub fn train_foci(noise: f64, iterations: u32, n: usize, seed: u64) -> GmmGuide {
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(seed);
    for i in 0..iterations {
        let stats = guide.update_with(
            &focal_batch(&mut rng, n, noise),
            &context(i, 3 * iterations),
        );
        assert_eq!(detail(&stats, "narrowing"), 0.0);
    }
    guide
}

/// Each true focus has a learned component centred on it and about its size.
///
/// Tolerance: the mean must lie within half a standard deviation of the focus (Mahalanobis distance
/// < 0.5 under the focus covariance, i.e. 5-20 mm here). Monte Carlo noise of a core fitted to ~10⁴
/// effective points is σ/100; the main bias is the asymmetric halo the box clips from the lines
/// through the focus, which pulls the core by a small fraction of its width (measured ≤ 0.15σ). Half a
/// σ is also the scale that matters for guiding: directions aimed there still cross the focus. The
/// component must be a core (largest σ at most twice the focus's), not a halo.
pub fn assert_foci_recovered(guide: &GmmGuide) {
    let m = guide.converging();
    for (j, (_, focus)) in foci().iter().enumerate() {
        let (fv, _) = focus.covariance().eigen();
        let best = m
            .components()
            .iter()
            .filter(|g| g.covariance().eigen().0[2].sqrt() <= 2.0 * fv[2].sqrt())
            .map(|g| focus.mahalanobis_sq(g.mean()).sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(
            best < 0.5,
            "focus {j}: nearest core at {best:.3} σ ({} components)",
            m.len()
        );
    }
}
