//! Readers and writers for the files the baker touches: parsing and writing only, into and out
//! of the types of [`crate::model`].

pub mod capture;
pub mod glb;
pub mod gltf_mesh;
pub mod layout;
pub mod mask_image;
pub mod mask_sides;
pub mod npy;
