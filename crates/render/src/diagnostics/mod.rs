//! Looking inside a render: where fireflies come from ([`fireflies`]) and what a guide has learned
//! (its pdf seen from the camera, [`guide_view`]; the mixture's components, [`guide_ellipses`]; a slice
//! through the octree, [`octree_slice`]). None of it changes an image.

pub mod colour_map;
pub mod fireflies;
pub mod guide_ellipses;
pub mod guide_view;
pub mod octree_slice;
