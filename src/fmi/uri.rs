//! `fmuResourceLocation` decoding (FMI 2.0.x §2.1.5: "an URI according to the IETF RFC3986
//! syntax ... an FMU must understand at least the file scheme").

use std::path::PathBuf;

/// Turns `file:///abs/path`, `file://localhost/abs/path` or `file:/abs/path` into a path,
/// decoding percent-escapes (hosts escape spaces and non-ASCII bytes).
pub fn file_uri_to_path(uri: &str) -> Result<PathBuf, String> {
    let rest = uri
        .get(..5)
        .filter(|s| s.eq_ignore_ascii_case("file:"))
        .map(|_| &uri[5..])
        .ok_or_else(|| "only file: URIs are supported".to_string())?;
    let path = if let Some(after) = rest.strip_prefix("//") {
        let slash = after.find('/').unwrap_or(after.len());
        let host = &after[..slash];
        if !(host.is_empty() || host.eq_ignore_ascii_case("localhost")) {
            return Err(format!("host '{host}' is not local"));
        }
        &after[slash..]
    } else {
        rest
    };
    if !path.starts_with('/') {
        return Err("the path is not absolute".into());
    }
    // A query or fragment is not part of a file path.
    let path = path.split(['?', '#']).next().unwrap_or(path);
    let bytes = percent_decode(path)?;
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStringExt;
        Ok(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
    }
    #[cfg(not(unix))]
    {
        String::from_utf8(bytes)
            .map(PathBuf::from)
            .map_err(|_| "path is not UTF-8".to_string())
    }
}

fn percent_decode(s: &str) -> Result<Vec<u8>, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("invalid percent-escape at byte {i}"))?;
            if hex == 0 {
                return Err("percent-escape %00 is not allowed in a path".into());
            }
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forms() {
        let p = PathBuf::from("/tmp/a b/resources");
        assert_eq!(file_uri_to_path("file:///tmp/a%20b/resources").unwrap(), p);
        assert_eq!(
            file_uri_to_path("file://localhost/tmp/a%20b/resources").unwrap(),
            p
        );
        assert_eq!(file_uri_to_path("FILE:/tmp/a b/resources").unwrap(), p);
        assert_eq!(
            file_uri_to_path("file:///tmp/%C3%A4/").unwrap(),
            PathBuf::from("/tmp/ä/")
        );
    }

    #[test]
    fn rejects() {
        for bad in [
            "http://x/y",
            "file://server/share",
            "file:relative",
            "file:///a%2",
            "file:///a%zz",
            "file:///a%00b",
            "",
            "fil",
        ] {
            assert!(file_uri_to_path(bad).is_err(), "{bad}");
        }
    }
}
