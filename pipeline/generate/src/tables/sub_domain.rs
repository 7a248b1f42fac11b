//! A scene's sub-domain: the axes restricted to the ranges the options' scene target needs.

use super::options::BuildOptions;
use anyhow::Result;
use std::ops::RangeInclusive;
use twoscale_tables::axis::Axis;

/// The axes restricted to the options' sub-domain, with the kept index range of each.
pub fn restrict(axes: Vec<Axis>, options: &BuildOptions) -> Result<(Vec<Axis>, Vec<RangeInclusive<usize>>)> {
    let mut kept = Vec::new();
    let mut out = Vec::new();
    for axis in axes {
        let range = match options.scene.as_ref().and_then(|s| s.ranges.iter().find(|(name, _)| *name == axis.name)) {
            Some((_, r)) => axis
                .covering(r.lo, r.hi)
                .map_err(|e| anyhow::anyhow!("the scene needs {e} (the default preset's domain)"))?,
            None => 0..=axis.len() - 1,
        };
        out.push(axis.slice(range.clone()));
        kept.push(range);
    }
    Ok((out, kept))
}

/// The axes restricted to the options' sub-domain (`restrict`); for a cubic table also widened
/// by a node on either side, to at least 4 nodes, so that every point of the sub-domain reads the
/// stencil it reads in the whole table.
pub fn sub_domain(axes: Vec<Axis>, cubic: bool, options: &BuildOptions) -> Result<Vec<Axis>> {
    let (restricted, kept) = restrict(axes.clone(), options)?;
    if !cubic {
        return Ok(restricted);
    }
    Ok(axes
        .iter()
        .zip(kept)
        .map(|(axis, range)| {
            let last = axis.len() - 1;
            let (mut lo, mut hi) = (range.start().saturating_sub(1), (range.end() + 1).min(last));
            while hi - lo < 3 {
                if lo > 0 {
                    lo -= 1
                } else {
                    hi += 1
                }
            }
            axis.slice(lo..=hi)
        })
        .collect())
}
