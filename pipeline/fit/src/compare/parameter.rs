//! A closed-form comparison model's parameters as it lists them (`closed` fits them; `he`, `low` and
//! `sgd` list theirs).

use crate::params::Range;

/// A model's parameter: its name, the channel it belongs to (None: shared by the channels), its range
/// where it is fitted (None: held at its start's value).
pub(crate) struct Parameter {
    pub name: &'static str,
    pub channel: Option<usize>,
    pub range: Option<Range>,
}

/// The parameter `name` of each channel.
pub(crate) const fn per_channel(name: &'static str, range: Option<Range>) -> [Parameter; 3] {
    [
        Parameter { name, channel: Some(0), range },
        Parameter { name, channel: Some(1), range },
        Parameter { name, channel: Some(2), range },
    ]
}

pub(crate) const fn shared(name: &'static str, range: Range) -> Parameter {
    Parameter { name, channel: None, range: Some(range) }
}
