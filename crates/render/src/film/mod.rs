//! The film: reconstruction filters, image blocks that accumulate filtered samples, the film that merges
//! them, and the developed image with its EXR/PNG output.
//!
//! Data flow: a render worker asks the [`Film`] for an [`ImageBlock`] covering its tile (plus the
//! filter's border), `put`s samples into it, and the caller merges finished blocks into the film in a
//! fixed order (deterministic results). [`Film::develop`] divides Σw·L by Σw into an [`Image`].

mod block;
#[allow(clippy::module_inception)]
mod film;
mod filter;
mod image;

pub use block::{AovSample, ImageBlock};
pub use film::{
    film_from_desc, Film, FilmSpec, PixelFormat, AOV_LAYERS, FILTER_WEIGHT_LAYER, MAX_FILM_SIDE,
};
pub use filter::{filter_from_desc, ReconstructionFilter, MAX_FILTER_RADIUS};
pub use image::{Image, ImageLayer, ImageStats};
