//! Normal contact models. Keyword = LIGGGHTS `model <kw>` (normal_model_<kw>.h).

pub mod hertz;
pub use hertz::NormalForce;
