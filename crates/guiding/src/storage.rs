//! The training-sample storage of one iteration (Open PGL's `SampleStorage`), owned by the renderer
//! and kept apart from the field it trains.

use std::any::Any;

/// What a field keeps of the segments recorded during one iteration until its update. The renderer
/// owns it: it asks the field for an empty one ([`crate::GuidingField::new_samples`]), has the field
/// add every pass's segments to it ([`crate::GuidingField::add_samples`]) and hands it to
/// [`crate::GuidingField::update`], which consumes it.
///
/// Its contents are typed per field: each field keeps segments in the form its update needs, as they
/// arrive, so that the storage does not grow with the number of samples where the field needs no more
/// (the octree splats each segment into its current leaves at once; the mixture clips it to training
/// rays, thinned beyond a cap; the selection layer adds it to its per-cell sums).
pub struct SampleStorage {
    owner: &'static str,
    model: u32,
    segments: u64,
    data: Box<dyn Any + Send>,
}

impl SampleStorage {
    /// A storage of a field named `owner` for the model after `model` updates, holding `data`.
    pub fn new<T: Any + Send>(owner: &'static str, model: u32, data: T) -> Self {
        Self {
            owner,
            model,
            segments: 0,
            data: Box::new(data),
        }
    }

    /// Segments added so far.
    pub fn segments(&self) -> u64 {
        self.segments
    }

    /// The name of the field that made it.
    pub fn owner(&self) -> &'static str {
        self.owner
    }

    /// The contents, for the field that made it (with `model` updates), counting `added` more
    /// segments. Panics if another kind of field, or the same field before an update since, made the
    /// storage (a programming error, as indexing out of bounds is): its samples were kept against
    /// another model.
    pub fn data_mut<T: Any + Send>(&mut self, model: u32, added: usize) -> &mut T {
        self.check_model(model);
        self.segments += added as u64;
        let owner = self.owner;
        self.data.downcast_mut::<T>().unwrap_or_else(|| {
            panic!("a sample storage of the {owner} guide given to another guide")
        })
    }

    /// The contents and the segment count, for the update of the field that made it (with `model`
    /// updates). Panics as [`SampleStorage::data_mut`] does.
    pub fn into_data<T: Any + Send>(self, model: u32) -> (T, u64) {
        self.check_model(model);
        let owner = self.owner;
        let data = self.data.downcast::<T>().unwrap_or_else(|_| {
            panic!("a sample storage of the {owner} guide given to another guide")
        });
        (*data, self.segments)
    }

    fn check_model(&self, model: u32) {
        assert!(
            self.model == model,
            "a sample storage of the {} guide after {} updates given to it after {model}",
            self.owner,
            self.model
        );
    }
}
