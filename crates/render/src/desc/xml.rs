//! Mitsuba XML reader (both the 0.6 and the 3.x dialects) producing a [`super::SceneDesc`].
