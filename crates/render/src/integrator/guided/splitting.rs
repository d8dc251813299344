//! Splitting guided paths whose throughput the one-sample mixture inflated (see
//! [`super::GuidedSettings::split`]).

use super::PathState;
use crate::integrator::path_trace::PathObserver;
use crate::sampler::Sampler;

/// A path is split where its throughput exceeds this many times the albedo product, into copies that
/// each carry this many times it.
const SPLIT_AT: f32 = 2.0;
/// The most copies one split makes, in expectation.
const MAX_SPLIT: f32 = 4.0;
/// The most split-off copies one camera sample may make in all.
const MAX_BRANCHES: usize = 64;

/// The splitting of one camera sample's path: how many copies it has made so far.
pub(super) struct Splitter {
    enabled: bool,
    made: usize,
}

impl Splitter {
    /// Splitting for one camera sample, if `enabled`.
    pub(super) fn new(enabled: bool) -> Self {
        Splitter { enabled, made: 0 }
    }

    /// Splits `path` (about to continue along its next ray) where its throughput exceeds [`SPLIT_AT`]
    /// times its albedo product: into a random number of copies with expectation ratio / [`SPLIT_AT`]
    /// (at most [`MAX_SPLIT`]), each carrying the throughput divided by that expectation; the copies
    /// beyond `path` itself go to `branches`, to be continued later. Within [`MAX_BRANCHES`] per camera
    /// sample.
    #[inline]
    pub(super) fn split<O: PathObserver>(
        &mut self,
        path: &mut PathState,
        branches: &mut Vec<PathState>,
        sampler: &mut Sampler,
        observer: &mut O,
    ) {
        if !self.enabled {
            return;
        }
        let ratio = path.throughput.max_element() / path.albedo;
        if !(ratio > SPLIT_AT) {
            return;
        }
        let target = (ratio / SPLIT_AT).min(MAX_SPLIT);
        let extra = target.floor() as usize - 1 + usize::from(sampler.next_1d() < target.fract());
        if self.made + extra <= MAX_BRANCHES {
            self.made += extra;
            path.throughput /= target;
            observer.split(target);
            branches.extend(std::iter::repeat_n(*path, extra));
        }
    }
}
