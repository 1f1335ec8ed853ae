//! Readers and writers for the files the baker touches.

pub mod capture;
pub mod control_triangles;
pub mod glb;
pub mod gltf_mesh;
pub mod layout;
pub mod marker_groups;
pub mod mask_image;
pub mod npy;
