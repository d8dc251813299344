//! Focal path guiding.
