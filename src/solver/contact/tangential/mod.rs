//! Tangential contact models. Keyword = LIGGGHTS `tangential <kw>` (tangential_model_<kw>.h).

mod history;
pub use history::history;
