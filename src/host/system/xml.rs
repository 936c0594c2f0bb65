//! A small element tree over quick-xml's streaming reader, for the SSP files.
//!
//! SSP documents use namespace prefixes (`ssd:`, `ssc:`, `ssv:`) that a writer may choose
//! freely; the tree keeps the *local* names of elements and attributes only, so a file
//! written with other prefixes (or a default namespace) reads the same. Every element keeps
//! the line of its start tag, for messages.

use quick_xml::events::{BytesStart, Event};

/// One XML element: local name, attributes (local names; `xmlns` declarations dropped),
/// child elements, and the line of its start tag. Text content is not kept (SSP 1.0 puts
/// all values in attributes).
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Node>,
    pub line: usize,
}

impl Node {
    /// The value of an attribute, if present.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The children with this local name.
    pub fn all<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Node> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// The first child with this local name.
    pub fn first(&self, name: &str) -> Option<&Node> {
        self.children.iter().find(|c| c.name == name)
    }
}

fn line_of(text: &str, pos: u64) -> usize {
    let end = (pos as usize).min(text.len());
    1 + text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

fn local(qname: &str) -> &str {
    qname.rsplit_once(':').map_or(qname, |(_, l)| l)
}

fn node(e: &BytesStart, line: usize, file: &str) -> Result<Node, String> {
    let qname = e.name();
    let qname: &str = qname.as_ref();
    let mut attrs = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| {
            format!("{file}: line {line}: malformed attribute on <{qname}>: {err}")
        })?;
        let key: &str = a.key.as_ref();
        if key == "xmlns" || key.starts_with("xmlns:") {
            continue;
        }
        let value = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| format!("{file}: line {line}: attribute {key} on <{qname}>: {err}"))?;
        attrs.push((local(key).to_string(), value.into_owned()));
    }
    Ok(Node {
        name: local(qname).to_string(),
        attrs,
        children: Vec::new(),
        line,
    })
}

/// Parse a whole document into its root element. Errors name the file and line.
pub fn parse(text: &str, file: &str) -> Result<Node, String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = quick_xml::Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<Node> = Vec::new();
    let mut root: Option<Node> = None;
    loop {
        let pos = reader.buffer_position();
        let ev = reader.read_event().map_err(|e| {
            format!(
                "{file}: malformed XML at line {}: {e}",
                line_of(text, reader.error_position())
            )
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let line = line_of(text, pos);
                if root.is_some() {
                    return Err(format!("{file}: line {line}: more than one root element"));
                }
                let n = node(e, line, file)?;
                if matches!(ev, Event::Start(_)) {
                    stack.push(n);
                } else if let Some(parent) = stack.last_mut() {
                    parent.children.push(n);
                } else {
                    root = Some(n);
                }
            }
            Event::End(_) => {
                let done = stack
                    .pop()
                    .ok_or_else(|| format!("{file}: unbalanced end tag"))?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(done),
                    None => root = Some(done),
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !stack.is_empty() {
        return Err(format!(
            "{file}: truncated XML: <{}> (line {}) is not closed",
            stack[stack.len() - 1].name,
            stack[stack.len() - 1].line
        ));
    }
    root.ok_or_else(|| format!("{file}: no XML element found (empty or not XML)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_names_lines_and_errors() {
        let t = "<?xml version=\"1.0\"?>\n<a:Root xmlns:a=\"u\" a:x=\"1\">\n  <a:Kid y=\"&lt;2\"/>\n</a:Root>\n";
        let r = parse(t, "f").unwrap();
        assert_eq!(r.name, "Root");
        assert_eq!(r.attr("x"), Some("1"));
        assert_eq!(r.attrs.len(), 1);
        let k = r.first("Kid").unwrap();
        assert_eq!((k.attr("y"), k.line), (Some("<2"), 3));
        assert!(parse("<a><b></a>", "f")
            .unwrap_err()
            .contains("malformed XML"));
        assert!(parse("<a>", "f").unwrap_err().contains("not closed"));
        assert!(parse("", "f").unwrap_err().contains("no XML element"));
    }
}
