//! The native solver: pure numerics, no I/O. Contact laws ([`contact`]), integrator
//! ([`integrate`]), imposed motions ([`kinematics`]), walls ([`mesh`]) and the time loop of
//! the contact cases ([`two_body`]).

pub mod contact;
pub mod integrate;
pub mod kinematics;
pub mod material;
pub mod mesh;
pub mod shear;
pub mod stability;
pub mod team;
pub mod trimesh;
pub mod two_body;
pub mod vec3;

pub use two_body::{AtomState, Frame};
