//! The presets of docs/maths.md section 5: which tables, on which grids.

use std::fmt;
use std::str::FromStr;

/// The presets of docs/maths.md section 5.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// The grids of the published reference tables.
    Paper,
    /// This project's grids, sized for the accuracy targets after interpolation.
    Default,
}

impl Preset {
    pub const ALL: [Preset; 2] = [Preset::Paper, Preset::Default];

    pub fn name(self) -> &'static str {
        match self {
            Preset::Paper => "paper",
            Preset::Default => "default",
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Preset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| format!("unknown preset {s:?} (known: paper, default)"))
    }
}
