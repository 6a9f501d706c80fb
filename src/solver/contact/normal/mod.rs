//! Normal contact models. Keyword = LIGGGHTS `model <kw>` (normal_model_<kw>.h).

mod hertz;
pub use hertz::{apply, hertz, NormalForce};
