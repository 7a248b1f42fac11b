//! Fitting the two-scale model (docs/maths.md section 7) to measured BRDFs with the general tables
//! (docs/fit.md): `merl` reads the file, `model` evaluates the BRDF at any parameters from the
//! tables, `layer` the layered models (the interface's albedo, the layer or medium beneath), `params` maps the parameters to the unbounded coordinates Levenberg-Marquardt moves,
//! `problem` is the least-squares problem, `fit` the whole procedure. It reads tables only
//! (twoscale-tables); `twoscale fit` builds the missing ones.

pub mod compare;
pub mod fit;
pub mod layer;
pub mod merl;
pub mod model;
pub mod params;
pub mod problem;
