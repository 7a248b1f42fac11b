//! Fitting the two-scale model (docs/maths.md section 7) to measured BRDFs with the general tables
//! (docs/fit.md):
//! - `measured` reads a file by its magic into samples: `merl` a MERL file, `rgl` an RGL-EPFL one (as
//!   Mitsuba's `measured` evaluates it);
//! - `model` evaluates the BRDF at any parameters from the tables, `layer` the layered models (the
//!   interface's albedo, the layer or medium beneath), `params` maps the parameters to the unbounded
//!   coordinates Levenberg-Marquardt moves;
//! - `loss` weighs and compresses the residuals, `problem` is the least-squares problem, `descent` the
//!   scout and finish stages every model's fit goes through, `fit` the whole procedure, `compare` the
//!   comparison models;
//! - `render` draws a sphere of a file or a fit and the SMAPE between two renders, `published` the
//!   published ABC and SGD fits of the MERL materials to compare with.
//!
//! It reads tables only (twoscale-tables); `twoscale fit` builds the missing ones.

pub mod compare;
mod descent;
pub mod fit;
pub mod layer;
pub mod loss;
pub mod measured;
pub mod merl;
pub mod model;
pub mod params;
pub mod problem;
pub mod published;
pub mod render;
pub mod rgl;
pub mod sample;
