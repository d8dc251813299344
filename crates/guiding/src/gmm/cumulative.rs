//! Inverting a discrete distribution given by unnormalised masses, the walk that component selection
//! (sphere and hemisphere) and the k-means++ seeding share.

/// The index i whose interval [Σ_{j<i} m_j, Σ_{j≤i} m_j) holds `target`, over the positive masses
/// only, returned with the interval's start and its mass (so that a caller can rescale the uniform it
/// used). A `target` at or beyond the total picks the last positive mass; `None` when no mass is
/// positive.
#[inline]
pub(crate) fn pick_interval(
    masses: impl Iterator<Item = f64>,
    target: f64,
) -> Option<(usize, f64, f64)> {
    let mut acc = 0.0;
    let mut chosen = None;
    for (i, m) in masses.enumerate() {
        if m > 0.0 {
            chosen = Some((i, acc, m));
            if target < acc + m {
                break;
            }
            acc += m;
        }
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::pick_interval;

    #[test]
    fn picks_the_interval_holding_the_target_and_skips_empty_masses() {
        let masses = [0.0, 1.0, 0.0, 2.0, -1.0, 1.0];
        let pick = |t: f64| pick_interval(masses.iter().copied(), t);
        assert_eq!(pick(0.0), Some((1, 0.0, 1.0)));
        assert_eq!(pick(0.999), Some((1, 0.0, 1.0)));
        assert_eq!(pick(1.0), Some((3, 1.0, 2.0)));
        assert_eq!(pick(3.5), Some((5, 3.0, 1.0)));
        // Rounding can put the target at the total: the last positive mass takes it.
        assert_eq!(pick(4.0), Some((5, 3.0, 1.0)));
        assert_eq!(pick_interval([0.0, -2.0].into_iter(), 0.5), None);
    }
}
