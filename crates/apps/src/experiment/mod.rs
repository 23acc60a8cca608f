//! Reproducible experiments: the paper's experiment redone on a synthetic,
//! physically lit room, from capture to scores (`plsr experiment paper`).
//!
//! - [`mesh`]: a small OBJ writer for the generated geometry;
//! - [`fixture`]: physical light fixtures and the PLS lights derived from
//!   their geometry;
//! - [`paper_room`]: the room, its fixtures and the scene file of every
//!   step;
//! - [`paper`]: the experiment itself.

pub mod fixture;
pub mod mesh;
pub mod paper;
pub mod paper_room;
