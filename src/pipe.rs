//! `geardyn … | head`: the reader of a pipe went away. A Unix filter then ends quietly with
//! status 141 (128 + SIGPIPE, what the shell reports for `cat` killed by SIGPIPE), and so does
//! `geardyn` — after its own clean-up: Rust ignores SIGPIPE, so the write fails with `EPIPE`,
//! the error (or, from `println!`, the panic) unwinds through the destructors that remove
//! temporary files and folders, and `main` returns [`BROKEN_PIPE_STATUS`] without a message.

/// The exit status after a closed pipe: 128 + SIGPIPE.
pub const BROKEN_PIPE_STATUS: u8 = 128 + libc::SIGPIPE as u8;

/// The text of the `EPIPE` error as the messages carry it (`Broken pipe (os error 32)`).
fn epipe_text() -> String {
    std::io::Error::from_raw_os_error(libc::EPIPE).to_string()
}

/// Whether an error message (`cannot write 'x': <io error>`) reports a closed pipe.
pub fn is_broken_pipe(message: &str) -> bool {
    message.contains(&epipe_text())
}

/// Whether a panic payload is `println!`'s or `eprintln!`'s failure on a closed pipe
/// (`failed printing to stdout: Broken pipe (os error 32)`).
pub fn is_broken_pipe_panic(payload: &(dyn std::any::Any + Send)) -> bool {
    let text = payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("");
    text.starts_with("failed printing to") && is_broken_pipe(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognises_the_closed_pipe_only() {
        assert!(is_broken_pipe(
            "cannot write '/dev/stdout': Broken pipe (os error 32)"
        ));
        assert!(!is_broken_pipe(
            "cannot write 'x.csv': No space left on device (os error 28)"
        ));
        let panic: Box<dyn std::any::Any + Send> =
            Box::new("failed printing to stdout: Broken pipe (os error 32)".to_string());
        assert!(is_broken_pipe_panic(panic.as_ref()));
        let other: Box<dyn std::any::Any + Send> = Box::new("index out of bounds");
        assert!(!is_broken_pipe_panic(other.as_ref()));
    }
}
