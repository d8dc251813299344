//! The GMM guide's per-vertex pdf work, as the renderer does it at a guided vertex: the hemisphere
//! masses of one shading point and the directional pdf of two directions (next-event estimation's and
//! the sampled one), with the `f64` reference kernel against the renderer's `f32` kernel.
//!
//! `cargo bench -p focal-guiding --bench gmm_pdf`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use focal_guiding::gmm::{Gaussian3, Mixture, Sym3, MAX_COMPONENTS, TERMS_PER_COMPONENT};
use focal_testkit::TestRng;
use glam::DVec3;

/// Reproducible inputs.
struct Rng(TestRng);

impl Rng {
    fn f64(&mut self) -> f64 {
        self.0.next_f64()
    }

    fn sphere(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.f64(), self.f64(), self.f64()) * 2.0 - 1.0;
            let l = v.length_squared();
            if l > 1e-6 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// `k` components in the unit box with σ from 0.01 to 0.3, as a trained guide has them.
fn mixture(rng: &mut Rng, k: usize) -> Mixture {
    let components = (0..k)
        .map(|_| {
            let mean = DVec3::new(rng.f64(), rng.f64(), rng.f64()) * 1.6 - 0.8;
            let s = DVec3::new(rng.f64(), rng.f64(), rng.f64()) * 0.29 + 0.01;
            Gaussian3::new(mean, Sym3::diagonal(s * s)).unwrap()
        })
        .collect();
    let weights: Vec<f64> = (0..k).map(|_| 0.2 + rng.f64()).collect();
    Mixture::new(&weights, components).unwrap()
}

/// Shading points (x, n) and two unit directions each.
type Vertex = (DVec3, DVec3, [DVec3; 2]);

fn vertices(rng: &mut Rng) -> Vec<Vertex> {
    (0..256)
        .map(|_| {
            let x = DVec3::new(rng.f64(), rng.f64(), rng.f64()) * 2.0 - 1.0;
            (x, rng.sphere(), [rng.sphere(), rng.sphere()])
        })
        .collect()
}

fn per_vertex(c: &mut Criterion) {
    let mut group = c.benchmark_group("gmm_vertex");
    for k in [16usize, 48, 128] {
        let mut rng = Rng(TestRng::new(k as u64));
        let m = mixture(&mut rng, k);
        let vs = vertices(&mut rng);
        group.bench_with_input(BenchmarkId::new("f64_reference", k), &k, |b, _| {
            let mut masses = vec![0.0f64; MAX_COMPONENTS];
            b.iter(|| {
                let mut sum = 0.0;
                for (x, n, dirs) in &vs {
                    m.half_space_masses(*x, *n, true, &mut masses);
                    for d in dirs {
                        sum += m.directional_pdf(*x, *d);
                    }
                }
                black_box(sum + masses[0])
            })
        });
        group.bench_with_input(BenchmarkId::new("f32_kernel", k), &k, |b, _| {
            let mut masses = vec![0.0f64; MAX_COMPONENTS];
            let mut terms = vec![0.0f32; TERMS_PER_COMPONENT * MAX_COMPONENTS];
            b.iter(|| {
                let mut sum = 0.0;
                for (x, n, dirs) in &vs {
                    m.prepare_vertex(*x, Some((*n, true)), &mut terms, &mut masses);
                    for d in dirs {
                        let w = d.as_vec3().to_array();
                        sum += m.directional_pdf_prepared(&terms, w) as f64;
                    }
                }
                black_box(sum + masses[0])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, per_vertex);
criterion_main!(benches);
