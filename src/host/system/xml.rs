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
    Lines::default().at(text, pos)
}

/// Line numbers of increasing positions, each byte counted once: counting from the start for
/// every element made the parse quadratic in the file size (issue 34: 200 k elements took
/// minutes).
#[derive(Default)]
struct Lines {
    pos: usize,
    line: usize,
}

impl Lines {
    fn at(&mut self, text: &str, pos: u64) -> usize {
        let end = (pos as usize).min(text.len());
        if end < self.pos {
            *self = Lines::default();
        }
        self.line += text.as_bytes()[self.pos..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.pos = end;
        1 + self.line
    }
}

/// Deepest element nesting accepted: SSP files nest a few levels; a document nested deeper is
/// refused before its tree (whose drop recurses per level) could exhaust the stack.
pub const MAX_DEPTH: usize = 256;

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
    let mut lines = Lines::default();
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
                let line = lines.at(text, pos);
                if root.is_some() {
                    return Err(format!("{file}: line {line}: more than one root element"));
                }
                if stack.len() >= MAX_DEPTH {
                    return Err(format!(
                        "{file}: line {line}: elements nested deeper than {MAX_DEPTH} levels"
                    ));
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
            // Well-formedness quick-xml leaves to the application (XML 1.0 §2.5, §2.4, §2.1):
            // "--" inside a comment, an undefined entity or a stray "&" in text, and text
            // outside the root element.
            Event::Comment(ref c) if c.contains("--") => {
                return Err(format!(
                    "{file}: not well-formed XML at line {}: \"--\" inside a comment",
                    lines.at(text, pos)
                ));
            }
            Event::Text(ref t) => {
                let outside = stack.is_empty() && !t.trim().is_empty();
                if outside || t.contains('&') {
                    return Err(format!(
                        "{file}: not well-formed XML at line {}: {}",
                        lines.at(text, pos),
                        if outside {
                            "text outside the root element"
                        } else {
                            "a stray '&' in text"
                        }
                    ));
                }
            }
            Event::GeneralRef(ref r) => {
                let name: &str = r;
                let known = matches!(name, "lt" | "gt" | "amp" | "apos" | "quot")
                    || r.resolve_char_ref().ok().flatten().is_some();
                if !known || stack.is_empty() {
                    return Err(format!(
                        "{file}: not well-formed XML at line {}: undefined entity &{name};",
                        lines.at(text, pos)
                    ));
                }
            }
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
        // Not well-formed (issue 32 item 5, issue 34): each named with its line.
        for (bad, what) in [
            ("<a>\n<!-- x -- y -->\n</a>", "line 2: \"--\""),
            ("<a>\n\nR&D</a>", "line 3"),
            ("<a>&nbsp;</a>", "undefined entity &nbsp;"),
            ("<a/>\nx", "outside the root"),
        ] {
            let e = parse(bad, "f").unwrap_err();
            assert!(e.contains(what) && e.contains("-formed"), "{bad:?}: {e}");
        }
    }

    /// Parse time grows linearly with the file (issue 34: counting lines from the start per
    /// element made 200 k elements take minutes). 16× the elements: linear parsing takes
    /// about 16× the time, a quadratic one 256×; the bound 48× sits between them with room
    /// for the cache and allocator effects of the larger file (4× with a bound of 8× failed
    /// at 8.5× on an idle machine). A ratio measured in one run, best of three. Deep nesting
    /// is refused, naming the line, without exhausting the stack.
    #[test]
    fn parsing_is_linear_and_depth_is_bounded() {
        let flat = |n: usize| {
            let mut t = String::from("<r>\n");
            for _ in 0..n {
                t.push_str("<u a=\"1\"/>\n");
            }
            t + "</r>\n"
        };
        // CPU time of this thread, not wall time: a loaded machine (CI runs beside other
        // jobs) stretches wall time unevenly between the two sizes.
        let thread_cpu = || {
            let mut ts = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            // SAFETY: writes the calling thread's CPU clock into `ts`.
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
            ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
        };
        let time = |t: &str| {
            (0..3)
                .map(|_| {
                    let start = thread_cpu();
                    parse(t, "f").unwrap();
                    thread_cpu() - start
                })
                .fold(f64::INFINITY, f64::min)
        };
        let (small, large) = (flat(12_500), flat(200_000));
        let ratio = time(&large) / time(&small);
        assert!(ratio < 48.0, "16x the elements took {ratio:.1}x the time");
        let deep = "<u>".repeat(200_000) + &"</u>".repeat(200_000);
        let start = std::time::Instant::now();
        let e = parse(&deep, "f").unwrap_err();
        assert!(
            e.contains("nested deeper than 256") && e.contains("line 1"),
            "{e}"
        );
        assert!(start.elapsed().as_secs_f64() < 5.0);
    }
}
