//! The contact models by their LIGGGHTS keywords (`model`, `tangential`, `rolling_friction`):
//! the closed sets the contact chain composes ([`super::surfaces_intersect`]) and a case names
//! (re-exported by [`crate::spec`]).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Normal contact model. Keyword = LIGGGHTS `model <kw>` (normal_model_<kw>.h).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalModel {
    Hertz,
}

/// Tangential contact model. Keyword = LIGGGHTS `tangential <kw>` (tangential_model_<kw>.h).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TangentialModel {
    History,
}

/// Rolling resistance. Keyword = LIGGGHTS `rolling_friction <kw>` (rolling_model_<kw>.h).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RollingModel {
    Off,
    Cdt,
    Epsd,
    Epsd2,
    Epsd3,
    /// Native only, not a LIGGGHTS model: epsd's spring with the rolling dashpot integrated
    /// implicitly (trapezoidal) per particle, stable at any dt (`solver::shear` docs).
    EpsdImplicit,
}

impl RollingModel {
    pub const ALL: [RollingModel; 6] = [
        RollingModel::Off,
        RollingModel::Cdt,
        RollingModel::Epsd,
        RollingModel::Epsd2,
        RollingModel::Epsd3,
        RollingModel::EpsdImplicit,
    ];

    /// The models LIGGGHTS 3.8 has (every one but the native-only implicit dashpot).
    pub const LIGGGHTS: [RollingModel; 5] = [
        RollingModel::Off,
        RollingModel::Cdt,
        RollingModel::Epsd,
        RollingModel::Epsd2,
        RollingModel::Epsd3,
    ];

    /// The LIGGGHTS keyword (`off` for no rolling resistance).
    pub fn keyword(self) -> &'static str {
        match self {
            RollingModel::Off => "off",
            RollingModel::Cdt => "cdt",
            RollingModel::Epsd => "epsd",
            RollingModel::Epsd2 => "epsd2",
            RollingModel::Epsd3 => "epsd3",
            RollingModel::EpsdImplicit => "epsd_implicit",
        }
    }

    /// Parses a keyword; the error lists the valid ones.
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.keyword() == s)
            .ok_or_else(|| Error::Unknown {
                what: "rolling model",
                name: s.to_string(),
                valid: Self::ALL.map(|m| m.keyword()).join(", "),
            })
    }

    /// [`RollingModel::parse`] for a study that runs LIGGGHTS: lists only LIGGGHTS' models,
    /// and says why a native-only one is refused.
    pub fn parse_liggghts(s: &str) -> Result<Self> {
        let m = Self::parse(s).map_err(|_| Error::Unknown {
            what: "rolling model",
            name: s.to_string(),
            valid: Self::LIGGGHTS.map(|m| m.keyword()).join(", "),
        })?;
        if m.native_only() {
            return Err(Error::invalid(
                "--rolling",
                m,
                format!(
                    "a LIGGGHTS model ({}): `{m}` exists only in the native solver",
                    Self::LIGGGHTS.map(|m| m.keyword()).join(", ")
                ),
            ));
        }
        Ok(m)
    }

    /// Whether the model stores the rolling torque `r_torque_old` as contact history.
    pub fn has_history(self) -> bool {
        matches!(
            self,
            RollingModel::Epsd
                | RollingModel::Epsd2
                | RollingModel::Epsd3
                | RollingModel::EpsdImplicit
        )
    }

    /// Whether `coefficientRollingViscousDamping` (eta_r) acts in this model.
    pub fn has_damping(self) -> bool {
        matches!(
            self,
            RollingModel::Epsd | RollingModel::Epsd3 | RollingModel::EpsdImplicit
        )
    }

    /// Models of the native solver that LIGGGHTS does not have (never in a deck).
    pub fn native_only(self) -> bool {
        self == RollingModel::EpsdImplicit
    }
}

impl std::fmt::Display for RollingModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.keyword())
    }
}
