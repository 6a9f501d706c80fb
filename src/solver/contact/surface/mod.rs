//! Surface models. Keyword = LIGGGHTS `surface <kw>` (surface_model_<kw>.h); spheres use
//! `default`.

pub mod default;
