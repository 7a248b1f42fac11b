//! Fitting the two-scale model (docs/maths.md section 7) to measured BRDFs with the general tables
//! (docs/fit.md): `merl` reads the file (`rgl` an RGL-EPFL one, as Mitsuba's `measured` evaluates it), `model` evaluates the BRDF at any parameters from the
//! tables, `layer` the layered models (the interface's albedo, the layer or medium beneath), `params` maps the parameters to the unbounded coordinates Levenberg-Marquardt moves,
//! `problem` is the least-squares problem, `fit` the whole procedure, `published` the published ABC
//! and SGD fits of the MERL materials to compare with. It reads tables only
//! (twoscale-tables); `twoscale fit` builds the missing ones.

pub mod compare;
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
