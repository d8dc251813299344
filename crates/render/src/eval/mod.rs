//! Judging renders: error metrics against a reference ([`metrics`]), the benchmark's score with its
//! bias check ([`score`]), error against the truth from two independent references
//! ([`two_reference`]) and whether two references agree ([`agreement`]), and merging shards or
//! references ([`merge`]).

pub mod agreement;
pub mod merge;
pub mod metrics;
pub mod score;
pub mod two_reference;
