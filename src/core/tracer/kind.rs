//! Tracer ids: the one list of tracers raysched knows, feature-gated ones included.

use super::TracerError;
use serde::{Deserialize, Serialize};

/// A tracer, by the stable snake_case id the CLI, TOML and CSV use.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    Serialize,
    Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum TracerKind {
    /// obvhs binary BVH, flattened to an 8-wide BVH.
    Bvh,
    /// Every primitive per ray: the reference.
    Brute,
    /// Intel Embree 3, default intersector.
    Embree,
    /// Embree with `RTC_SCENE_FLAG_ROBUST` (fewer leaks through shared edges).
    EmbreeRobust,
    /// Intel Embree 4, default intersector.
    Embree4,
    /// Embree 4 with `RTC_SCENE_FLAG_ROBUST`.
    Embree4Robust,
}

impl TracerKind {
    /// Every tracer, including those whose cargo feature this build lacks.
    pub const ALL: [TracerKind; 6] = [
        TracerKind::Bvh,
        TracerKind::Brute,
        TracerKind::Embree,
        TracerKind::EmbreeRobust,
        TracerKind::Embree4,
        TracerKind::Embree4Robust,
    ];

    /// The stable snake_case id (`bvh`, `brute`, `embree`, `embree_robust`, `embree4`,
    /// `embree4_robust`).
    pub fn id(self) -> &'static str {
        match self {
            TracerKind::Bvh => "bvh",
            TracerKind::Brute => "brute",
            TracerKind::Embree => "embree",
            TracerKind::EmbreeRobust => "embree_robust",
            TracerKind::Embree4 => "embree4",
            TracerKind::Embree4Robust => "embree4_robust",
        }
    }

    /// The ids of [`Self::ALL`], comma-separated (for error messages).
    pub fn id_list() -> String {
        Self::ALL.map(Self::id).join(", ")
    }

    /// # Errors
    /// [`TracerError::Unknown`] for an id not in [`Self::ALL`].
    pub fn from_id(id: &str) -> Result<Self, TracerError> {
        Self::ALL
            .into_iter()
            .find(|k| k.id() == id)
            .ok_or_else(|| TracerError::Unknown(id.to_string()))
    }

    /// The cargo feature this tracer needs, if any.
    pub fn feature(self) -> Option<&'static str> {
        match self {
            TracerKind::Bvh | TracerKind::Brute => None,
            TracerKind::Embree | TracerKind::EmbreeRobust => Some("embree"),
            TracerKind::Embree4 | TracerKind::Embree4Robust => Some("embree4"),
        }
    }

    /// Whether this build has the tracer (its feature, if any, was compiled in).
    pub fn compiled_in(self) -> bool {
        match self {
            TracerKind::Bvh | TracerKind::Brute => true,
            TracerKind::Embree | TracerKind::EmbreeRobust => cfg!(feature = "embree"),
            TracerKind::Embree4 | TracerKind::Embree4Robust => cfg!(feature = "embree4"),
        }
    }

    /// `self` if this build has the tracer, checked without building anything (plans validate
    /// before timing starts): `TracerKind::from_id(id).and_then(TracerKind::available)`.
    ///
    /// # Errors
    /// [`TracerError::FeatureOff`] naming the feature to rebuild with.
    pub fn available(self) -> Result<Self, TracerError> {
        if self.compiled_in() {
            Ok(self)
        } else {
            Err(self.feature_off())
        }
    }

    pub(super) fn feature_off(self) -> TracerError {
        TracerError::FeatureOff {
            id: self.id().to_string(),
            feature: self.feature().unwrap_or_default().to_string(),
        }
    }
}

impl std::fmt::Display for TracerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.id())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_lists_them() {
        for k in TracerKind::ALL {
            assert_eq!(TracerKind::from_id(k.id()), Ok(k));
            let toml = toml::to_string(&std::collections::BTreeMap::from([("t", k)])).unwrap();
            assert_eq!(toml.trim(), format!("t = \"{}\"", k.id()));
            let value = <TracerKind as clap::ValueEnum>::to_possible_value(&k).unwrap();
            assert_eq!(value.get_name(), k.id());
        }
        let err = TracerKind::from_id("optix").unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown tracer 'optix' (expected one of: bvh, brute, embree, embree_robust, embree4, \
             embree4_robust)"
        );
    }

    #[test]
    fn feature_gated_tracers_name_their_feature() {
        assert_eq!(TracerKind::Bvh.available(), Ok(TracerKind::Bvh));
        assert_eq!(TracerKind::Embree.feature(), Some("embree"));
        assert_eq!(
            TracerKind::EmbreeRobust.available().is_ok(),
            cfg!(feature = "embree")
        );
        assert_eq!(TracerKind::Embree4Robust.feature(), Some("embree4"));
        assert_eq!(
            TracerKind::Embree4.available().is_ok(),
            cfg!(feature = "embree4")
        );
    }
}
