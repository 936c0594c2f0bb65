//! Parameter paths as messages and `scene[...]` write them: `gear[0].bearing_stiffness[1]`,
//! `mesh.stiffness.mean`, `gear[2].pin_error[radial]`.

/// One element of a list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Index {
    /// `[3]`.
    At(usize),
    /// `[x]`, `[y]`, `[radial]`, `[tangential]`: the components of a pair, as validation
    /// messages name them (the position in the pair).
    Named(usize),
    /// No index where the format has a list of tables (`mesh.damping` in a single-mesh file).
    Implicit,
}

/// A key and the indices after it.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub key: String,
    pub indices: Vec<Index>,
}

/// Splits a path into steps; `Err` names the path and what is wrong with it.
pub fn parse(path: &str) -> Result<Vec<Step>, String> {
    let bad = |why: &str| format!("scene path '{path}': {why}");
    if path.is_empty() {
        return Err(bad("empty"));
    }
    let mut steps = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if key.is_empty() {
            return Err(bad("an empty key"));
        }
        let mut indices = Vec::new();
        while !rest.is_empty() {
            let close = rest
                .find(']')
                .filter(|_| rest.starts_with('['))
                .ok_or_else(|| bad("an index must be written [n]"))?;
            let inner = &rest[1..close];
            indices.push(match inner {
                "x" | "radial" => Index::Named(0),
                "y" | "tangential" => Index::Named(1),
                n => Index::At(
                    n.parse()
                        .map_err(|_| bad(&format!("index '{n}' is not a whole number >= 0")))?,
                ),
            });
            rest = &rest[close + 1..];
        }
        steps.push(Step {
            key: key.to_owned(),
            indices,
        });
    }
    Ok(steps)
}

/// The path of `steps` (indices as given).
pub fn join(steps: &[Step]) -> String {
    steps
        .iter()
        .map(|s| {
            let mut out = s.key.clone();
            for i in &s.indices {
                match i {
                    Index::At(n) | Index::Named(n) => out.push_str(&format!("[{n}]")),
                    Index::Implicit => {}
                }
            }
            out
        })
        .collect::<Vec<_>>()
        .join(".")
}
