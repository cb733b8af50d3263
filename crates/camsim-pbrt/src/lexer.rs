//! Tokenizer for the pbrt-v4 scene format: quoted strings (with pbrt's escapes), bare words
//! (directive names, numbers, `true`/`false`), `[` and `]`, and `#` comments to the end of the
//! line. Every token carries its line and column (1-based; columns count characters).

use super::PbrtError;
use std::path::Path;

/// What a token is.
#[derive(Debug, Clone, PartialEq)]
pub enum TokenKind {
    /// A quoted string, escapes resolved.
    Str(String),
    /// Any unquoted word: a directive name, a number, `true`, `false`.
    Word(String),
    /// `[`
    Open,
    /// `]`
    Close,
    /// A `#ObjectName NAME` comment (ISET3d's convention for naming the shapes that follow in
    /// the enclosing attribute block); the name is the text up to the first `:`.
    ObjectName(String),
}

/// A token and where it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    pub kind: TokenKind,
    /// 1-based line.
    pub line: usize,
    /// 1-based column (characters).
    pub column: usize,
}

impl Token {
    /// The token as written, for error messages.
    pub fn describe(&self) -> String {
        match &self.kind {
            TokenKind::Str(s) => format!("\"{s}\""),
            TokenKind::Word(w) => w.clone(),
            TokenKind::Open => "[".into(),
            TokenKind::Close => "]".into(),
            TokenKind::ObjectName(n) => format!("#ObjectName {n}"),
        }
    }
}

/// Split `text` into tokens; `path` names the file in errors.
pub fn tokenize(text: &str, path: &Path) -> Result<Vec<Token>, PbrtError> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    let (mut line, mut col) = (1usize, 1usize);
    // Advance one character, tracking the position.
    macro_rules! bump {
        () => {{
            let c = chars.next();
            if c == Some('\n') {
                line += 1;
                col = 1;
            } else if c.is_some() {
                col += 1;
            }
            c
        }};
    }
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            bump!();
            continue;
        }
        let (tl, tc) = (line, col);
        match c {
            '#' => {
                let mut comment = String::new();
                while let Some(&c) = chars.peek() {
                    if c == '\n' {
                        break;
                    }
                    comment.push(c);
                    bump!();
                }
                if let Some(rest) = comment[1..].trim_start().strip_prefix("ObjectName") {
                    let name = rest.split(':').next().unwrap_or("").trim();
                    if !name.is_empty() {
                        out.push(Token {
                            kind: TokenKind::ObjectName(name.to_string()),
                            line: tl,
                            column: tc,
                        });
                    }
                }
            }
            '[' => {
                bump!();
                out.push(Token {
                    kind: TokenKind::Open,
                    line: tl,
                    column: tc,
                });
            }
            ']' => {
                bump!();
                out.push(Token {
                    kind: TokenKind::Close,
                    line: tl,
                    column: tc,
                });
            }
            '"' => {
                bump!();
                let mut s = String::new();
                loop {
                    match bump!() {
                        None => return Err(PbrtError::at(path, tl, tc, "unterminated string")),
                        Some('"') => break,
                        Some('\n') => {
                            return Err(PbrtError::at(
                                path,
                                tl,
                                tc,
                                "newline inside a quoted string",
                            ));
                        }
                        Some('\\') => {
                            let e = bump!();
                            s.push(match e {
                                Some('n') => '\n',
                                Some('t') => '\t',
                                Some('r') => '\r',
                                Some('b') => '\u{8}',
                                Some('f') => '\u{c}',
                                Some('\\') => '\\',
                                Some('\'') => '\'',
                                Some('"') => '"',
                                Some(other) => {
                                    return Err(PbrtError::at(
                                        path,
                                        line,
                                        col.saturating_sub(1),
                                        format!("unknown escape sequence \\{other}"),
                                    ))
                                }
                                None => {
                                    return Err(PbrtError::at(path, tl, tc, "unterminated string"))
                                }
                            });
                        }
                        Some(ch) => s.push(ch),
                    }
                }
                out.push(Token {
                    kind: TokenKind::Str(s),
                    line: tl,
                    column: tc,
                });
            }
            _ => {
                let mut w = String::new();
                while let Some(&c) = chars.peek() {
                    if c.is_whitespace() || c == '"' || c == '[' || c == ']' || c == '#' {
                        break;
                    }
                    w.push(c);
                    bump!();
                }
                out.push(Token {
                    kind: TokenKind::Word(w),
                    line: tl,
                    column: tc,
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_strings_and_comments() {
        let t = tokenize(
            "Shape \"sphere\" # c\n  \"float radius\" [ 2.5 ]\n",
            Path::new("x"),
        )
        .unwrap();
        assert_eq!(t.len(), 6);
        assert_eq!(t[0].kind, TokenKind::Word("Shape".into()));
        assert_eq!((t[2].line, t[2].column), (2, 3));
        assert_eq!(t[3].kind, TokenKind::Open);
        assert_eq!(t[4].kind, TokenKind::Word("2.5".into()));
        let e = tokenize("A \"abc", Path::new("f.pbrt")).unwrap_err();
        assert_eq!((e.line, e.column), (1, 3));
    }
}
