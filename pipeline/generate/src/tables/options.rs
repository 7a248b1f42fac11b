//! What changes how a table is computed (not its grid): the zh method and degree, a scene's
//! sub-domain, the build context shared by the jobs of one build.

use super::context::BuildContext;
use super::scene_target::SceneTarget;
use crate::progress::Progress;
use std::str::FromStr;
use std::sync::Arc;

/// How `zh_convolution` computes C (docs/maths.md section 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The zonal-harmonic sum C_L.
    Zh,
    /// The direct 2-D integral (slow: for small grids and checks).
    Exact,
    /// C_L where its estimated truncation error is below a tolerance, C elsewhere.
    Auto,
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "zh" => Ok(Method::Zh),
            "exact" => Ok(Method::Exact),
            "auto" => Ok(Method::Auto),
            _ => Err(format!("unknown method {s:?} (known: zh, exact, auto)")),
        }
    }
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Zh => "zh",
            Method::Exact => "exact",
            Method::Auto => "auto",
        }
    }
}

/// Options that change how a table is computed (not its grid).
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    pub progress: Progress,
    /// Zonal-harmonic degree L (zh_convolution; default from the preset).
    pub degree: Option<usize>,
    /// zh_convolution method (default from the preset).
    pub method: Option<Method>,
    /// Rebuild even when an existing table has the same inputs.
    pub force: bool,
    /// Build for a scene: the default grids keep only the nodes covering its ranges.
    pub scene: Option<SceneTarget>,
    /// What the jobs of one build share (none: each job computes from cold).
    pub context: Option<Arc<BuildContext>>,
}
