//! The streaming pass of the modelDescription parser (quick-xml `Reader`): well-formedness,
//! the root element and its `fmiVersion`, and line numbers for messages (FMI 2.0.5 §2.2.1).

/// 1-based line and column of a byte offset, for messages.
fn line_col(xml: &str, pos: u64) -> (usize, usize) {
    let pos = (pos as usize).min(xml.len());
    let before = &xml.as_bytes()[..pos];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = pos
        - before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1)
        + 1;
    (line, col)
}

/// Line numbers of increasing byte offsets, counting each newline once (the tag positions of
/// one pass only grow; [`line_col`] from the start for every tag would be quadratic).
struct LineCounter {
    pos: usize,
    line: usize,
}

impl LineCounter {
    fn line_at(&mut self, xml: &str, pos: u64) -> usize {
        let pos = (pos as usize).clamp(self.pos, xml.len());
        self.line += xml.as_bytes()[self.pos..pos]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.pos = pos;
        self.line
    }
}

/// What the streaming pass learns before the serde pass: the root's `fmiVersion` and the line
/// of every `<ScalarVariable>` start tag (serde does not report positions).
pub(super) struct Scan {
    pub(super) version: Option<String>,
    pub(super) variable_lines: Vec<usize>,
}

/// Read the whole document with the streaming reader: checks it is well-formed XML (quick-xml's
/// serde layer tolerates some truncation at the end; a validator must not), reads the root and
/// its `fmiVersion`, and records the line of each `<ScalarVariable>`.
pub(super) fn scan(xml: &str) -> Result<Scan, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    reader.config_mut().check_end_names = true;
    let mut version = None;
    let mut variable_lines = Vec::new();
    let mut depth: i64 = 0;
    let mut seen_root = false;
    let mut lines = LineCounter { pos: 0, line: 1 };
    loop {
        let pos = reader.buffer_position();
        let ev = reader.read_event().map_err(|e| {
            let (l, c) = line_col(xml, reader.error_position());
            format!("malformed XML at line {l}, column {c}: {e}")
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = e.name();
                let name: &str = name.as_ref();
                let line = lines.line_at(xml, pos);
                if name == "ScalarVariable" {
                    variable_lines.push(line);
                }
                for a in e.attributes() {
                    a.map_err(|err| {
                        format!("malformed attribute on <{name}> at line {line}: {err}")
                    })?;
                }
                if !seen_root {
                    seen_root = true;
                    if name != "fmiModelDescription" {
                        return Err(format!(
                            "root element is <{name}> (line {line}), expected <fmiModelDescription>"
                        ));
                    }
                    for a in e.attributes().flatten() {
                        let key: &str = a.key.as_ref();
                        if key == "fmiVersion" {
                            let v = a
                                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                                .map_err(|e| format!("malformed fmiVersion value: {e}"))?;
                            version = Some(v.into_owned());
                        }
                    }
                } else if depth == 0 {
                    return Err(format!(
                        "more than one root element (<{name}> at line {line})"
                    ));
                }
                if matches!(ev, Event::Start(_)) {
                    depth += 1;
                }
            }
            Event::End(_) => depth -= 1,
            Event::Eof => break,
            _ => {}
        }
    }
    if !seen_root {
        return Err("no XML element found (empty or not XML)".into());
    }
    if depth != 0 {
        let (l, _) = line_col(xml, xml.len() as u64);
        return Err(format!(
            "truncated XML: {depth} element(s) not closed at the end of the file (line {l})"
        ));
    }
    Ok(Scan {
        version,
        variable_lines,
    })
}
