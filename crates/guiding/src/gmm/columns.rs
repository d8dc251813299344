//! Gaussians laid out as padded structure-of-arrays columns, the layout the vectorised kernels read (the
//! mixture's pdf and narrowing, the origin model's weights).

use super::gaussian::Gaussian3;

/// The means, Cholesky factors L and inverse factors L⁻¹ (packed lower triangles) of a list of
/// Gaussians, one column per coordinate, padded to a multiple of the kernels' lane count with mean 0
/// and identity factors, so that padding lanes stay finite.
pub(crate) struct GaussianColumns {
    /// x, y and z of the means.
    pub mean: [Vec<f64>; 3],
    /// The six entries of L⁻¹.
    pub inv_chol: [Vec<f64>; 6],
    /// The six entries of L.
    pub chol: [Vec<f64>; 6],
}

impl GaussianColumns {
    /// The columns of `gaussians`, each `padded` (≥ their number) entries long.
    pub(crate) fn new(gaussians: &[Gaussian3], padded: usize) -> Self {
        let column = |f: &dyn Fn(&Gaussian3) -> f64, fill: f64| {
            let mut v: Vec<f64> = gaussians.iter().map(f).collect();
            v.resize(padded, fill);
            v
        };
        let identity = [1.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        Self {
            mean: std::array::from_fn(|a| column(&|g| g.mean()[a], 0.0)),
            inv_chol: std::array::from_fn(|i| column(&|g| g.inverse_cholesky().0[i], identity[i])),
            chol: std::array::from_fn(|i| column(&|g| g.cholesky().0[i], identity[i])),
        }
    }
}
