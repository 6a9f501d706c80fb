//! Normal contact models. Keyword = LIGGGHTS `model <kw>` (normal_model_<kw>.h).

mod hertz;
pub(crate) use hertz::SQRT_FIVE_OVER_SIX;
pub use hertz::{apply, hertz, NormalForce};
