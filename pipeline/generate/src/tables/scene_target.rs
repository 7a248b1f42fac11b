//! A scene build's target: its name, the scene file's hash, and the range of values each axis
//! needs (what `sub_domain` restricts the grids to).

/// Closed range of the values a scene uses on one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub lo: f64,
    pub hi: f64,
}

impl Range {
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Range> {
        values.into_iter().fold(None, |r, x| match r {
            None => Some(Range { lo: x, hi: x }),
            Some(r) => Some(Range { lo: r.lo.min(x), hi: r.hi.max(x) }),
        })
    }
}

/// A scene build: its name (the output directory is `scene-<name>`), the
/// scene file's SHA-256, and the ranges each axis needs.
#[derive(Clone, Debug)]
pub struct SceneTarget {
    pub name: String,
    pub sha256: String,
    pub ranges: Vec<(String, Range)>,
}
