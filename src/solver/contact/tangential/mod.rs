//! Tangential contact models. Keyword = LIGGGHTS `tangential <kw>` (tangential_model_<kw>.h).

pub mod history;
